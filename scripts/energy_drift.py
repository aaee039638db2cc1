"""Round-off drift of the point-mass em step: perturbed copies of the paper's orbit
(speeds scaled by 1 + 1e-9 N(0, 1)) in one packed ensemble, STEPS steps of T/DIV, several
seeds. For each seed: the mean of E/E0 - 1 over the copies at the end, per step, and its
distance from zero in standard errors (z; a random walk gives |z| ~ 1, a drift grows like
sqrt(steps)). E < 0, so a positive mean means the energy falls. Energies are evaluated
exactly from the float64 states (emorbit.analysis.relative_energy_change_exact): until
2026-11-23 they were evaluated in float64, and the rounding of GM / |x0|, the same in every
copy, offset every mean by -6.7e-17 of E, which over 1e6 steps read as a drift of -6.7e-23
per step (the "T/1000 drift" of the notes in emorbit/kernels/ensemble.py).

    python scripts/energy_drift.py [--roundoff brouwer|fast] [--div 100] [--steps 1000000]
                                   [--members 256] [--seeds 4] [--first-seed 0]
                                   [--kernel packed|reference|gpu] [--contract]

The figures in the notes of emorbit/kernels/ensemble.py come from this measurement (256
copies, 4 seeds, 1e6 steps: about 20 s per seed on the development machine). ``--kernel``
picks the kernel: the packed ensemble kernel Simulation uses on the CPU (default), the
one-point reference kernel of emorbit.kernels.pointmass, or that reference kernel compiled
for an NVIDIA GPU (emorbit.kernels.pointmass.cuda; without a CUDA device it stops with the reason).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from emorbit.analysis import relative_energy_change_exact
from emorbit.integrators.dispatch import method_code
from emorbit.kernels.pointmass import packed as ensemble
from emorbit.kernels.pointmass import reference as pointmass

GM = 3.9478
X0 = np.array([10.0, 0.0, 0.0])
V0 = np.array([0.0, 0.36276, 0.0])
T = 46.4758  # the paper's period, s


def drift(
    method: int, dt: float, steps: int, members: int, seed: int, kernel: str = "packed", contract: bool = False
) -> tuple[float, float, float]:
    """(mean of E/E0 - 1 per step, z, ns per particle-step) for one seed."""
    rng = np.random.default_rng(seed)
    x = np.repeat(X0[:, None], members, axis=1)
    v = V0[:, None] * (1.0 + 1e-9 * rng.normal(size=members))[None, :]
    x0, v0 = x.copy(), v.copy()
    cx, cv = np.zeros_like(x), np.zeros_like(v)
    rec_x, rec_v = np.empty((1, 3, members)), np.empty((1, 3, members))
    iters, fail = np.zeros((1, members), np.int64), np.full((members, 2), -1, np.int64)
    t = time.perf_counter()
    args = (x, v, cx, cv, GM, np.zeros(3), dt, np.array([1.0]), steps, 1, 50, rec_x, rec_v, iters, fail)
    if kernel == "gpu":
        from emorbit.kernels.pointmass import cuda

        cuda.chunk(method, *args, contract=contract)
    elif kernel == "reference":
        pointmass.implicit_chunk(method, *args)
    else:
        ensemble.ensemble_chunk(method, *args)
    ns = 1e9 * (time.perf_counter() - t) / (members * steps)
    if (fail[:, 0] >= 0).any():
        raise RuntimeError(f"{int((fail[:, 0] >= 0).sum())} copies failed")
    rel = relative_energy_change_exact(x0, v0, x, v, GM, cx, cv)
    return rel.mean() / steps, rel.mean() / (rel.std() / np.sqrt(members)), ns


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--roundoff", choices=("brouwer", "fast"), default="brouwer")
    p.add_argument("--div", type=float, default=100.0, help="dt = T / DIV (default 100)")
    p.add_argument("--steps", type=int, default=1_000_000)
    p.add_argument("--members", type=int, default=256)
    p.add_argument("--seeds", type=int, default=4)
    p.add_argument("--first-seed", type=int, default=0)
    p.add_argument(
        "--kernel",
        choices=("packed", "reference", "gpu"),
        default="packed",
        help="packed ensemble kernel (default), the one-point reference kernel, or the GPU kernel",
    )
    p.add_argument(
        "--contract",
        action="store_true",
        help="with --kernel gpu: let NVVM fuse multiply-adds (its default; emorbit compiles with -fma=0)",
    )
    args = p.parse_args(argv)
    for name, value, low in (
        ("--div", args.div, 0.0),
        ("--steps", args.steps, 0),
        ("--members", args.members, 1),
        ("--seeds", args.seeds, 0),
    ):
        if not value > low:
            p.error(f"{name} must be > {low}, got {value}")
    if args.contract and args.kernel != "gpu":
        p.error(f"--contract applies to --kernel gpu only, got --kernel {args.kernel}")
    if args.kernel == "gpu":
        from emorbit.kernels.pointmass import cuda

        if cuda.device_problem() is not None:
            print(cuda.device_problem())
            return 1
    method = method_code("em", args.roundoff)
    per_step, zs = [], []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        m, z, ns = drift(method, T / args.div, args.steps, args.members, seed, args.kernel, args.contract)
        per_step.append(m)
        zs.append(z)
        print(f"seed {seed}: {m:+.2e} per step, z {z:+.2f} ({ns:.1f} ns per particle-step)", flush=True)
    print(f"mean {np.mean(per_step):+.2e} per step; z of the mean over seeds {np.mean(zs) * np.sqrt(len(zs)):+.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
