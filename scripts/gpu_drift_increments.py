"""One-off study: does the rounding of the increments make the default em step drift?

    python scripts/gpu_drift_increments.py MEMBERS STEPS_T100 STEPS_T8     (needs an NVIDIA GPU)

Variants of ``emorbit.kernels.pointmass.packed._increments`` (u = ua a - uv v0 and dx = h v0 + cx u
rounded once with fused multiply-adds, or dx compensated with error-free transformations)
are compiled into the GPU kernel in place of the plain one, and the energy drift of
perturbed paper orbits is measured as in scripts/energy_drift.py (seeds 0 and 1 at T/8 and
T/100; the unchanged kernel at T/8, seed 0, as a check). Measured on an H100 with 65536
orbits, 1e6 steps at T/100 and 1e5 at T/8 (``65536 1000000 100000``, 45 s): the drift stays
(T/8 -3.7e-20 to -5.4e-20 per step, 8.5 to 12.3 standard errors; T/100 +5.7e-22 to
+6.5e-22, 3.0 to 3.4), against -4.9e-20 (11.2) for the unchanged kernel: the increments are
not where it comes from. (The T/8 drift came from the finish's residual, since fixed:
pointmass._residual; these figures are from before that fix.) On numba's CUDA simulator the script runs too (small arguments).
"""

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import energy_drift as ed  # noqa: E402
from numba import cuda  # noqa: E402

from emorbit.kernels.eft import fma, two_prod, two_sum  # noqa: E402
from emorbit.kernels.jit import kernel  # noqa: E402
from emorbit.kernels.pointmass import cuda as kcuda  # noqa: E402
from emorbit.kernels.pointmass import packed as ensemble  # noqa: E402
from emorbit.kernels.pointmass import reference as pointmass


@kernel(inline="always")
def _u_fused(ax, ay, az, vx, vy, vz, ua, uv):
    """u = ua a - uv v0, each component rounded once."""
    return fma(ua, ax, -(uv * vx)), fma(ua, ay, -(uv * vy)), fma(ua, az, -(uv * vz))


@kernel(inline="always")
def _dx(h, v, c, u):
    """h v + c u compensated (error-free transformations), rounded once at the end."""
    p1, e1 = two_prod(h, v)
    p2, e2 = two_prod(c, u)
    s, es = two_sum(p1, p2)
    return s + (es + (e1 + e2))


def inc_fma(ax, ay, az, vx, vy, vz, w, ua, uv, h):
    cx = h * ((0.5 * h) * w)
    cv = h * w
    ux, uy, uz = _u_fused(ax, ay, az, vx, vy, vz, ua, uv)
    return fma(cx, ux, h * vx), fma(cx, uy, h * vy), fma(cx, uz, h * vz), cv * ux, cv * uy, cv * uz


def inc_fma_dx(ax, ay, az, vx, vy, vz, w, ua, uv, h):
    cx = h * ((0.5 * h) * w)
    cv = h * w
    ux = ua * ax - uv * vx
    uy = ua * ay - uv * vy
    uz = ua * az - uv * vz
    return fma(cx, ux, h * vx), fma(cx, uy, h * vy), fma(cx, uz, h * vz), cv * ux, cv * uy, cv * uz


def inc_comp(ax, ay, az, vx, vy, vz, w, ua, uv, h):
    cx = h * ((0.5 * h) * w)
    cv = h * w
    ux, uy, uz = _u_fused(ax, ay, az, vx, vy, vz, ua, uv)
    return _dx(h, vx, cx, ux), _dx(h, vy, cx, uy), _dx(h, vz, cx, uz), cv * ux, cv * uy, cv * uz


def main() -> int:
    if len(sys.argv) != 4:
        print(__doc__)
        return 2
    members, steps100, steps8 = (int(a) for a in sys.argv[1:4])
    kcuda._compile(False)
    fma_dev = kcuda._devices["fma"]
    variants = (
        ("fma u and dx", inc_fma),
        ("fma u, compensated dx", inc_comp),
        ("fma dx only", inc_fma_dx),
        ("baseline", None),
    )
    for name, variant in variants:
        kcuda._devices.clear()
        kcuda._devices["fma"] = fma_dev
        kcuda._compiled.clear()
        if variant is not None:
            device = cuda.jit(device=True)(kcuda._rebind(variant, cuda, kcuda._devices))
            kcuda._devices[ensemble._increments.py_func] = device  # _compile's walk finds it in place
        kcuda._compile(False)
        t = time.perf_counter()
        for div, steps in ((8, steps8), (100, steps100)):
            for seed in (0,) if variant is None else (0, 1):
                if variant is None and div == 100:
                    continue
                m, z, _ = ed.drift(pointmass.METHOD_EM, ed.T / div, steps, members, seed, "gpu")
                print(f"{name:24s} T/{div:<4d} seed {seed}: {m:+.2e} per step, z {z:+.2f}", flush=True)
        print(f"  ({time.perf_counter() - t:.1f} s)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
