"""What landing on the shadow's edges costs: the perturbed bench's LEO for a day, with and
without the shadow.

    python scripts/landing_cost.py [--dt 60 120] [--order 8 6] [--method em] [--repeats 3]

The case is the ``perturbed`` bench section's LEO (:data:`emorbit.bench.perturbed.CASES`:
400 km, 51.6 degrees, J2..J6, exponential drag, radiation pressure with the cylindrical
shadow, the Moon and the Sun), fixed steps for 86,400 s, its effects' paths sampled before the
timed run as the bench samples them. For each (dt, order) pair and each case it prints the
least CPU time of ``--repeats`` runs and, from the last run, the edges logged, the calls of
the point masses' step kernel (those of one step apart, with their mean CPU time: the trials
of :func:`emorbit.events.locate` and the rest of a split step), the trials per edge and the
steps taken against those the day needs. The steps beyond them are the trials
and the chunks' steps that a split drops and takes again (:class:`emorbit.pacing.Pace`).
"""

from __future__ import annotations

import argparse
import time

from emorbit import event_run
from emorbit.bench.perturbed import CASES, simulation
from emorbit.bodies.pointmasses import PointMasses
from emorbit.events import locate
from emorbit.integrators import coefficients

DAY = 86400.0


class _Count:
    """Counts the step kernel's calls and steps, and locate's trials, while it is installed."""

    def __init__(self):
        self.calls = self.one_step = self.steps = self.trials = 0
        self.one_step_s = 0.0  # CPU time in the one-step calls

    def __enter__(self):
        advance, count = PointMasses.advance, self

        def counted(pm, method, gm, center, dt, gammas, every, nrec, *args, **kwargs):
            count.calls += 1
            count.steps += every * nrec
            count.one_step += every * nrec == 1
            start = time.process_time()
            out = advance(pm, method, gm, center, dt, gammas, every, nrec, *args, **kwargs)
            if every * nrec == 1:
                count.one_step_s += time.process_time() - start
            return out

        def traced(g_of_tau, *args):
            def g(tau):
                count.trials += 1
                return g_of_tau(tau)

            return locate(g, *args)

        self._undo = [(PointMasses, "advance", advance), (event_run, "locate", event_run.locate)]
        PointMasses.advance = counted
        event_run.locate = traced
        return self

    def __exit__(self, *exc):
        for owner, name, value in self._undo:
            setattr(owner, name, value)


def run(case_name: str, dt: float, order: int, method: str, repeats: int) -> dict:
    """The least CPU time of ``repeats`` day-long runs and the counts of the last."""
    steps = int(round(DAY / dt))

    def setup():
        sim = simulation(CASES[case_name], dt, order=order, method=method)
        sim._prepare_effects(steps, coefficients(order))
        return sim

    setup().run(steps=2, every=1, progress=False)  # compile or load the kernels
    best = float("inf")
    for _ in range(repeats):
        sim = setup()
        with _Count() as count:
            start = time.process_time()
            sim.run(steps=steps, every=steps, progress=False)
            best = min(best, time.process_time() - start)
    edges = len(sim.events.log)
    return {"cpu_s": best, "edges": edges, "count": count, "steps": steps}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dt", type=float, nargs="+", default=[60.0, 120.0], help="steps, s")
    parser.add_argument("--order", type=int, nargs="+", default=[8, 6], help="an order per step")
    parser.add_argument("--method", default="em", choices=["em", "tfe"])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    if len(args.dt) != len(args.order):
        parser.error("--dt and --order take as many values each")
    print(f"{'case':<15} {'dt':>6} {'order':>5} {'CPU s':>7} {'edges':>5} {'calls':>6} {'one-step':>8} "
          f"{'us each':>7} {'trials/edge':>11} {'steps':>6} {'needed':>6}")  # fmt: skip
    for dt, order in zip(args.dt, args.order):
        for name in ("leo", "leo-no-shadow"):
            r = run(name, dt, order, args.method, args.repeats)
            c = r["count"]
            per = f"{c.trials / r['edges']:.2f}" if r["edges"] else "-"
            each = f"{1e6 * c.one_step_s / c.one_step:.0f}" if c.one_step else "-"
            print(f"{name:<15} {dt:>6g} {order:>5} {r['cpu_s']:>7.3f} {r['edges']:>5} {c.calls:>6} {c.one_step:>8} "
                  f"{each:>7} {per:>11} {c.steps:>6} {r['steps']:>6}")  # fmt: skip


if __name__ == "__main__":
    main()
