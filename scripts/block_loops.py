"""What an effect set's compiled functions cost per point: ``forces`` (with and without the
Jacobian blocks), ``prepare`` and ``work`` on one block of points.

    python scripts/block_loops.py [--sets Moon srp ...] [--points 64] [--calls 20000]

Each set is the central field and the effects of one row of the ``effects`` bench section
(:data:`emorbit.bench.effects.EFFECT_SETS`, e.g. ``Moon``: the central field and the Moon),
on that section's point masses in Earth orbits (:func:`emorbit.bench.effects.earth_orbits`),
each step of x1 - x0 about dt = T/1000 of the lowest orbit along the velocity. A compiled
loop calls each function ``--calls`` times; the script prints the wall time per point of each.
"""

from __future__ import annotations

import argparse
import math
import time

import numba
import numpy as np

from emorbit.bench.effects import _R_LOW, EFFECT_SETS, _effect_system, earth_orbits


@numba.njit
def _forces(forces, x0, x1, m, body, coef, h, P, I, T, S, F, W, R, jac, calls):
    for _ in range(calls):
        forces(x0, x1, m, body, coef, h, 0, P, I, T, S, F, W, R, jac, True)


@numba.njit
def _prepare(prepare, P, I, T, S, calls):
    for r in range(calls):
        prepare(1.0 * r, 1.0 * r + 0.5, 1.0 * r + 1.0, P, I, T, S)


@numba.njit
def _work(work, x0, dx, m, body, coef, h, P, I, T, S, out, calls):
    for _ in range(calls):
        work(x0, dx, m, body, coef, h, 0, P, I, T, S, out)


def _timed(fn, *args, calls: int, points: int) -> float:
    fn(*args, 3)  # compiled before the clock starts
    start = time.perf_counter()
    fn(*args, calls)
    return 1e9 * (time.perf_counter() - start) / calls / points


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sets", nargs="+", default=["J2", "drag, exponential", "srp", "Moon", "Sun"])
    ap.add_argument("--points", type=int, default=64)
    ap.add_argument("--calls", type=int, default=20000)
    args = ap.parse_args()
    if not 1 <= args.points <= 100_000:
        ap.error(f"--points: 1 to 100000 points expected, got {args.points}")
    if not 1 <= args.calls <= 10_000_000:
        ap.error(f"--calls: 1 to 10000000 calls expected, got {args.calls}")
    import emorbit

    field = emorbit.CentralField(body="earth")
    n = args.points
    x, v = earth_orbits(n, field.gm)
    dt = 2 * math.pi * math.sqrt(_R_LOW**3 / field.gm) / 1000
    print(f"{n} points, {args.calls} calls, ns per point (wall time)")
    print(f"{'set':22s} {'forces + J':>11s} {'forces':>8s} {'prepare':>8s} {'work':>8s}")
    for name in args.sets:
        if name not in EFFECT_SETS:
            raise SystemExit(f"--sets: {name!r} is not a row of the effects section ({', '.join(EFFECT_SETS)})")
        sim = _effect_system(field, (name,), x, v, dt)
        prog = sim.effects.program()
        P, I, T, S = sim.effects.arrays(n)
        x0 = np.zeros((6, n))
        x0[:3] = x
        dx = np.ascontiguousarray(v * dt)
        x1 = x0.copy()
        x1[:3] += dx
        m, body, coef = np.ones(n), np.arange(n, dtype=np.int64), np.ones((len(sim.effects), n))
        F, W, R = np.zeros((3, n)), np.zeros((9, n)), np.zeros(n)
        out = np.zeros((max(len(sim.effects.working()), 1), n))
        row = [
            _timed(
                _forces, prog.forces, x0, x1, m, body, coef, dt, P, I, T, S, F, W, R, jac, calls=args.calls, points=n
            )  # fmt: skip
            for jac in (True, False)
        ]
        row.append(_timed(_prepare, prog.prepare, P, I, T, S, calls=args.calls, points=n))
        row.append(_timed(_work, prog.work, x0, dx, m, body, coef, dt, P, I, T, S, out, calls=args.calls, points=n))
        print(f"{name:22s} " + " ".join(f"{t:8.2f}" for t in row))


if __name__ == "__main__":
    main()
