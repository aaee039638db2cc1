"""Point-mass ensemble throughput on the GPU against the CPU kernels (``emorbit bench`` has no GPU rows).

    python scripts/bench_gpu.py [--points 100000 1000000] [--steps 100] [--json FILE]

Test particles on random orbits (e up to 0.9) around the paper's field, em and leapfrog at
order 2, dt = T/1000 of the widest orbit. Rows, in point-steps per second (warm: compiled
and run once before timing, median of 5):

* cpu reference   emorbit.kernels.pointmass.reference (one thread; the 3-vector Newton
                  reference), timed on the first 10,000 points (one thread's rate does not
                  depend on n)
* cpu ensemble    emorbit.kernels.pointmass.packed, all Numba threads (what Simulation uses)
* gpu chunk       emorbit.kernels.pointmass.cuda.chunk: copies the state in and the records out
* gpu kernel      the kernel alone on device-resident arrays (NVVM -fma=0, as chunk)
* gpu kernel fma  the same with NVVM's default contraction into fused multiply-adds

Without a CUDA device it says so and exits with status 1: nothing is measured.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def ensemble(n: int, seed: int = 3):
    gm = 3.9478
    rng = np.random.default_rng(seed)
    a = rng.uniform(4.0, 10.0, n)
    e = rng.uniform(0.0, 0.9, n)
    r = a * (1 + e)  # start at apoapsis
    vt = np.sqrt(gm / a * (1 - e) / (1 + e))
    phi = rng.uniform(0, 2 * np.pi, n)
    inc = rng.uniform(0, np.pi, n)
    x = np.vstack([r * np.cos(phi), r * np.sin(phi), np.zeros(n)])
    v = np.vstack([-vt * np.sin(phi) * np.cos(inc), vt * np.cos(phi) * np.cos(inc), vt * np.sin(inc)])
    period = 2 * np.pi * np.sqrt(10.0**3 / gm)
    return gm, np.ascontiguousarray(x), np.ascontiguousarray(v), period / 1000


def timed(fn, repeats: int = 5) -> float:
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--json")
    args = ap.parse_args()

    from emorbit.integrators import coefficients
    from emorbit.integrators.dispatch import method_code
    from emorbit.kernels.pointmass import cuda as kcuda
    from emorbit.kernels.pointmass import packed as kens
    from emorbit.kernels.pointmass import reference as kref

    if not kcuda.available():
        print("no CUDA device here: GPU throughput not measured")
        return 1
    cuda, kernels = kcuda._compile()
    kernels_fma = kcuda._compile(contract=True)[1]
    gammas = coefficients(2)
    rows = []
    for n in args.points:
        gm, x0, v0, dt = ensemble(n)
        center = np.zeros(3)
        for method in ("em", "leapfrog"):
            code = method_code(method)

            def arrays(m=n):
                return (
                    [x0[:, :m].copy(), v0[:, :m].copy(), np.zeros((3, m)), np.zeros((3, m))],
                    [
                        np.empty((1, 3, m)),
                        np.empty((1, 3, m)),
                        np.zeros((1, m), np.int64),
                        np.full((m, 2), -1, np.int64),
                    ],
                )

            def cpu_ref():
                a, rec = arrays(min(n, 10_000))
                if method == "leapfrog":
                    kref.leapfrog_chunk(*a, gm, center, dt, gammas, args.steps, 1, 50, *rec)
                else:
                    kref.implicit_chunk(code, *a, gm, center, dt, gammas, args.steps, 1, 50, *rec)

            def cpu_ens():
                a, rec = arrays()
                kens.ensemble_chunk_parallel(code, *a, gm, center, dt, gammas, args.steps, 1, 50, *rec)

            def gpu_chunk():
                a, rec = arrays()
                kcuda.chunk(code, *a, gm, center, dt, gammas, args.steps, 1, 50, *rec)

            a, rec = arrays()
            dev = [cuda.to_device(q) for q in a + rec]
            d_center, d_gammas = cuda.to_device(center), cuda.to_device(gammas)
            blocks = (n + kcuda.THREADS_PER_BLOCK - 1) // kcuda.THREADS_PER_BLOCK

            def gpu_kernel(table=kernels):
                common = (np.float64(gm), d_center, np.float64(dt), d_gammas, args.steps, 1, 50)
                table[code][blocks, kcuda.THREADS_PER_BLOCK](*dev[:4], *common, *dev[4:])
                cuda.synchronize()

            row = {"points": n, "method": method, "steps": args.steps}
            for name, fn, reps, m in (
                ("cpu reference", cpu_ref, 1, min(n, 10_000)),
                ("cpu ensemble", cpu_ens, 5, n),
                ("gpu chunk", gpu_chunk, 5, n),
                ("gpu kernel", gpu_kernel, 5, n),
                ("gpu kernel fma", lambda: gpu_kernel(kernels_fma), 5, n),
            ):
                t = timed(fn, reps)
                row[name] = m * args.steps / t
                print(f"{n:9d} points {method:8s} {name:14s} {row[name]:12.3e} point-steps/s ({t:.3f} s)")
            rows.append(row)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"device": str(cuda.get_current_device().name), "rows": rows}, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
