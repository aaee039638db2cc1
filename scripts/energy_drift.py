"""Round-off drift of the point-mass em step: is the energy error a random walk or a drift?

    python scripts/energy_drift.py [--roundoff brouwer|fast] [--div 100] [--steps 1000000]
                                   [--members 256] [--seeds 4] [--first-seed 0]
                                   [--kernel packed|reference|gpu] [--contract]

Perturbed copies of the paper's orbit (speeds scaled by 1 + 1e-9 N(0, 1)) run as one
ensemble, STEPS steps of T/DIV, for several seeds. For each seed it prints the mean of
E/E0 - 1 over the copies at the end, per step, and that mean's distance from zero in
standard errors (z): a random walk gives |z| ~ 1, a drift grows like sqrt(steps). E < 0, so a
positive mean means the energy falls. Energies are evaluated exactly from the float64 states
(:func:`emorbit.analysis.relative_energy_change_exact`): in float64, the rounding of
GM / |x0|, the same in every copy, would offset every mean (by -6.7e-17 of E for the
paper's orbit) and read as a drift.

``--kernel`` picks the kernel: the packed ensemble kernel a Simulation uses on the CPU
(default), the one-point reference kernel (:mod:`emorbit.kernels.pointmass.reference`), or
the per-point step compiled for an NVIDIA GPU (:mod:`emorbit.kernels.pointmass.cuda`;
without a CUDA device the script says why and exits with status 1). ``--contract`` lets NVVM fuse
multiply-adds on the GPU. methods.md explains the two roundoff settings;
tests/test_hardcases.py asserts the same z-test at T/8 and T/30.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from emorbit.analysis import relative_energy_change_exact
from emorbit.integrators.dispatch import method_code
from emorbit.kernels.pointmass import packed, reference

GM = 3.9478
X0 = np.array([10.0, 0.0, 0.0])
V0 = np.array([0.0, 0.36276, 0.0])
T = 46.4758  # the paper's period, s


def drift(
    method: int, dt: float, steps: int, members: int, seed: int, kernel: str = "packed", contract: bool = False
) -> tuple[float, float, float]:
    """The drift of one seed's ensemble.

    Parameters
    ----------
    method : int
        A method code (:func:`emorbit.integrators.dispatch.method_code`).
    dt : float
        The step, s.
    steps : int
        Steps.
    members : int
        Copies of the orbit.
    seed : int
        Seed of the speed perturbations.
    kernel : str
        ``"packed"``, ``"reference"`` or ``"gpu"``.
    contract : bool
        With ``"gpu"``: let NVVM fuse multiply-adds.

    Returns
    -------
    tuple of float
        (mean of E/E0 - 1 per step, z, ns per particle-step of wall time).
    """
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
        reference.implicit_chunk(method, *args)
    else:
        packed.ensemble_chunk(method, *args)
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
