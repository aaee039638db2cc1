"""One orbit, the paper's: what a step costs.

emorbit's em, midpoint and leapfrog at orders 2, 4, 6 and 8 through the scene's path
(``PointMasses.advance``, one record per call), em at order 2 also with roundoff="fast",
beside REBOUND's leapfrog and WHFast at the same step (dt = T/100) and IAS15 with its
default epsilon (1e-9, adaptive: it takes longer steps, and its steps per orbit are
recorded). The engines run interleaved; CPU time per step, medians.
"""

from __future__ import annotations

import numpy as np

from .common import PAPER_DT, PAPER_V0, PAPER_X0, EmorbitRunner, ReboundRunner, period, rebound_sim
from .timing import paired_ratio, timed

__all__ = ["run", "table"]

METHODS = ("em", "midpoint", "leapfrog")
ORDERS = (2, 4, 6, 8)
CLOCK = "cpu_us_per_step"
FAST = "em 2 fast"  # em order 2 with roundoff="fast" (no accurate finish of each step)


def run(cfg) -> dict:
    """Measure the section.

    Parameters
    ----------
    cfg : Config
        A configuration of :data:`emorbit.bench.common.CONFIGS`.

    Returns
    -------
    dict
        JSON-ready: ``rows`` (one per engine, ns per step in CPU and wall time, Newton
        iterations), ratios to REBOUND's leapfrog, and the headline figures.
    """
    x, v = PAPER_X0[:, None], PAPER_V0[:, None]
    T = period(PAPER_X0, PAPER_V0)
    runners = {f"{m} {o}": EmorbitRunner(x, v, m, o, PAPER_DT) for m in METHODS for o in ORDERS}
    runners[FAST] = EmorbitRunner(x, v, "em", 2, PAPER_DT, roundoff="fast")
    runners["rebound leapfrog"] = ReboundRunner(rebound_sim(x, v, "leapfrog", PAPER_DT))
    runners["rebound whfast"] = ReboundRunner(rebound_sim(x, v, "whfast", PAPER_DT))
    ias15 = ReboundRunner(rebound_sim(x, v, "ias15", PAPER_DT))
    runners["rebound ias15"] = ias15
    times = timed(runners, cfg)
    rows = []
    for name, stats in times.items():
        engine = "rebound" if name.startswith("rebound") else "emorbit"
        method, _, order = name.removeprefix("rebound ").partition(" ")
        order = order.removesuffix(" fast")
        row = {
            "engine": engine,
            "method": method,
            "order": int(order) if order else None,
            "ns_per_step": 1e3 * stats[CLOCK],
            "ns_per_step_wall": 1e3 * stats["us_per_step"],
            "samples_cpu_us": stats["cpu_samples_us"],
            "steps_per_call": stats["steps"],
        }
        if engine == "emorbit" and method == "em":
            row["roundoff"] = "fast" if name == FAST else "brouwer"
        if engine == "emorbit" and method != "leapfrog":
            row["newton_iterations_per_substep"] = float(
                np.median(runners[name].iterations[1:] or runners[name].iterations)
            )
        rows.append(row)
    ias = next(r for r in rows if r["method"] == "ias15")
    ias["steps_per_orbit"] = float(T / (ias15.sim.t / max(1, ias15.sim.steps_done)))
    ref = times["rebound leapfrog"]
    ratios = {f"{m} {o}": paired_ratio(times[f"{m} {o}"], ref) for m in METHODS for o in ORDERS}
    ratios[FAST] = paired_ratio(times[FAST], ref)
    em = next(r for r in rows if r["method"] == "em" and r["order"] == 2 and r["roundoff"] == "brouwer")
    fast = next(r for r in rows if r.get("roundoff") == "fast")
    lf = next(r for r in rows if r["method"] == "leapfrog" and r["engine"] == "rebound")
    return {
        "case": f"the paper's orbit (a = 6.0000135 m, e = 2/3, T = {T:.5f} s), dt = {PAPER_DT} s (T/100)",
        "clock": "CPU time per step (median of interleaved repeats); wall time beside it",
        "rows": rows,
        "ratio_to_rebound_leapfrog": ratios,
        "em_ns_per_step": em["ns_per_step"],
        "em_fast_ns_per_step": fast["ns_per_step"],
        "rebound_leapfrog_ns_per_step": lf["ns_per_step"],
        "rebound_whfast_ns_per_step": next(r for r in rows if r["method"] == "whfast")["ns_per_step"],
        "rebound_ias15_ns_per_step": ias["ns_per_step"],
    }


def table(section: dict) -> list[str]:
    """The section as printable lines.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.

    Returns
    -------
    list of str
        The lines of the table.
    """
    lines = [
        f"single orbit: {section['case']}; {section['clock']}",
        f"  {'':<27} {'ns/step':>9} {'wall':>9} {'x REBOUND leapfrog':>19} {'Newton/sub-step':>16}",
    ]
    for r in section["rows"]:
        name = f"{r['engine']} {r['method']}" + (f" order {r['order']}" if r["order"] else "")
        key = f"{r['method']} {r['order']}"
        if r.get("roundoff") == "fast":
            name, key = name + " fast", FAST
        ratio = section["ratio_to_rebound_leapfrog"].get(key) if r["engine"] == "emorbit" else None
        extra = f"{r['newton_iterations_per_substep']:.2f}" if "newton_iterations_per_substep" in r else ""
        if r["method"] == "ias15":
            extra = f"({r['steps_per_orbit']:.0f} steps/orbit)"
        lines.append(
            f"  {name:<27} {r['ns_per_step']:>9.1f} {r['ns_per_step_wall']:>9.1f} "
            f"{(f'{ratio:.2f}x' if ratio is not None else ''):>19} {extra:>16}"
        )
    return lines
