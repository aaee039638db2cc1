"""Runs the bench's sections, prints their tables and the targets, writes the JSON and figures.

The targets (:data:`TARGETS`) are ratios measured within one run, so they hold or fail on
any machine: em on all threads >= 3x REBOUND leapfrog's particle-steps per second; em on one
orbit <= 1x REBOUND leapfrog's time per step; a warm-cache
``emorbit run paper-ellipse`` <= 2 s wall; a point-mass scene >= 0.9x the bare kernel; on a
GPU, the resident point-mass path >= 50 % of the kernel alone (:mod:`.gpu`; "skipped" without one);
in a turning 20 x 20 gravity field, em <= 2x heyoka's CPU time at 1e-6 and 1e-9 of a
(:mod:`.gravity_field`); on perturbed orbits, em <= 1x IAS15's CPU time at IAS15's error,
<= 3x heyoka's at 1e-6 and 1e-9 of a, and em's energy balance <= 1e-12 (:mod:`.perturbed`).
"""

from __future__ import annotations

import json
import os
import time

from .common import CONFIGS, versions
from .timing import loadavg, machine

__all__ = ["TARGETS", "targets", "run_bench"]

#: the bench's targets, as ratios within one run (the warm start-up in seconds)
TARGETS = {
    "ensemble_vs_rebound": 3.0,  # em on all threads >= 3x REBOUND leapfrog's particle-steps/s
    "single_vs_rebound": 1.0,  # em on one orbit <= 1.0x REBOUND leapfrog's time per step
    "warm_startup_s": 2.0,  # warm-cache emorbit run paper-ellipse <= 2 s wall
    "scene_vs_bare": 0.9,  # a point-mass scene >= 0.9x the bare ensemble kernel's throughput
}


def targets(result: dict) -> list[dict]:
    """The targets of :data:`TARGETS` evaluated on a bench result.

    Parameters
    ----------
    result : dict
        The sections' results, keyed by section (``"ensemble"``, ``"single"``, ``"startup"``).

    Returns
    -------
    list of dict
        One per target of the sections present: ``target`` (what is asked), ``measured``,
        ``limit`` and ``met``.
    """
    out = []
    ens = result.get("ensemble")
    if ens:
        for label, key in (("", "em_over_rebound_leapfrog"), (' (roundoff="fast")', "em_fast_over_rebound_leapfrog")):
            r = ens[key]
            out.append(
                {
                    "target": f"em{label} ensemble on all threads >= 3x REBOUND leapfrog particle-steps/s",
                    "measured": r,
                    "limit": TARGETS["ensemble_vs_rebound"],
                    "met": r >= TARGETS["ensemble_vs_rebound"],
                }
            )
        s = ens["scene_over_bare"]
        out.append(
            {
                "target": "point-mass scene (PointMasses.advance) >= 0.9x the bare kernel's throughput",
                "measured": s,
                "limit": TARGETS["scene_vs_bare"],
                "met": s >= TARGETS["scene_vs_bare"],
            }
        )
    single = result.get("single")
    if single:
        for label, key in (("", "em 2"), (' (roundoff="fast")', "em 2 fast")):
            r = single["ratio_to_rebound_leapfrog"][key]
            out.append(
                {
                    "target": f"em{label} single orbit <= 1.0x REBOUND leapfrog's time per step",
                    "measured": r,
                    "limit": TARGETS["single_vs_rebound"],
                    "met": r <= TARGETS["single_vs_rebound"],
                }
            )
    start = result.get("startup")
    if start:
        w = start["warm_s"]
        out.append(
            {
                "target": "warm-cache emorbit run paper-ellipse <= 2 s wall",
                "measured": w,
                "limit": TARGETS["warm_startup_s"],
                "met": w <= TARGETS["warm_startup_s"],
            }
        )
    if result.get("rigid_precision"):
        out += result["rigid_precision"]["targets"]
    if result.get("gpu"):
        out += result["gpu"]["targets"]
    if result.get("effects"):
        from .effects import targets as effects_targets

        out += effects_targets(result["effects"])
    if result.get("gravity_field"):
        out += result["gravity_field"]["targets"]
    if result.get("perturbed"):
        out += result["perturbed"]["targets"]
    return out


def _sections():
    from . import effects, ensemble, gravity_field, perturbed, single, startup, workprecision

    return {
        "single": single,
        "ensemble": ensemble,
        "work-precision": workprecision,
        "startup": startup,
        "effects": effects,
        "gravity-field": gravity_field,
        "perturbed": perturbed,
    }


def run_bench(sections, quick: bool = False, json_path=None, plots_dir=None, config: str | None = None) -> int:
    """Run sections of the bench, print their tables and the targets, write the results.

    Parameters
    ----------
    sections : list of str
        Names from :data:`emorbit.bench.SECTIONS`, run in the order given.
    quick : bool
        The quick configuration instead of the full one.
    json_path : str, optional
        Write every figure, the machine and the targets here as JSON.
    plots_dir : str, optional
        Write the work-precision figures (PNG) into this folder.
    config : str, optional
        ``"full"``, ``"quick"`` or ``"tiny"`` (a smoke run for the tests); overrides ``quick``.

    Returns
    -------
    int
        0.
    """
    name = config or ("quick" if quick else "full")
    cfg = CONFIGS[name]
    modules = _sections()
    start = time.perf_counter()
    result = {
        "config": name,
        "machine": machine(),
        "versions": versions(),
        "load_average": {"before": loadavg()},
        "seconds": {},
    }
    print(
        f"emorbit bench ({name}): {result['machine']['cpu']}, {result['machine']['cores']} cores, "
        f"{result['machine']['simd']}; load average {result['load_average']['before']}",
        flush=True,
    )
    if name != "tiny":  # the kernels compile on both cores, before anything is timed
        from .precompile import precompile

        took = precompile(sections)
        if took is not None:
            result["seconds"]["precompile"] = round(took, 1)
            print(
                f"point-mass kernels compiled or loaded from Numba's cache in two processes: {took:.1f} s", flush=True
            )
    for section in sections:
        t0 = time.perf_counter()
        if section == "rigid":
            from . import rigid as bench_rigid

            data = bench_rigid.run(config="tiny" if name == "tiny" else None, quick=name != "full")
            lines = bench_rigid.table(data).splitlines()
        elif section == "rigid-precision":
            from . import rigid_precision

            data = rigid_precision.run(config=name)
            lines = rigid_precision.table(data)
        elif section == "gpu":
            from . import gpu as bench_gpu

            data = bench_gpu.run(config=name)
            lines = bench_gpu.table(data)
        elif section == "elastic":
            from . import elastic as bench_elastic

            data = bench_elastic.run(config=name)
            lines = bench_elastic.table(data).splitlines()
        else:
            mod = modules[section]
            data = mod.run(cfg)
            lines = mod.table(data)
        result[section.replace("-", "_")] = data
        result["seconds"][section] = round(time.perf_counter() - t0, 1)
        print("\n" + "\n".join(lines), flush=True)
    if plots_dir and "work_precision" in result:
        from .workprecision import plot_orbits

        os.makedirs(plots_dir, exist_ok=True)
        path = os.path.join(plots_dir, "work-precision.png")
        plot_orbits(result["work_precision"]["orbits"], path)
        result["work_precision"]["figures"] = [path]
        print(f"\nfigures: {path}")
    if plots_dir and "rigid_precision" in result:
        from .rigid_precision import plot as plot_rigid

        os.makedirs(plots_dir, exist_ok=True)
        path = os.path.join(plots_dir, "rigid-work-precision.png")
        plot_rigid(result["rigid_precision"], path)
        result["rigid_precision"]["figures"] = [path]
        print(f"\nfigures: {path}")
    if plots_dir and "perturbed" in result:
        from .perturbed import plot as plot_perturbed

        os.makedirs(plots_dir, exist_ok=True)
        result["perturbed"]["figures"] = plot_perturbed(result["perturbed"], plots_dir)
        print(f"\nfigures: {', '.join(result['perturbed']['figures'])}")
    result["targets"] = targets(result)
    result["load_average"]["after"] = loadavg()
    result["seconds"]["total"] = round(time.perf_counter() - start, 1)
    print("\ntargets (ratios within this run):")
    for t in result["targets"]:
        verdict = {True: "met", False: "NOT met", None: "skipped"}[t["met"]]
        note = f"; {t['note']}" if "note" in t else ""
        measured = "-" if t.get("measured") is None else f"{t['measured']:.3g}"
        print(f"  {verdict:>8}  {t['target']}: {measured} (limit {t['limit']:g}{note})")
    print(
        f"load average {result['load_average']['before']} -> {result['load_average']['after']}; "
        f"{result['seconds']['total']} s"
    )
    if json_path:
        with open(json_path, "w") as f:
            json.dump(result, f, indent=1, default=_jsonable)
            f.write("\n")
    return 0


def _jsonable(x):
    import numpy as np

    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")
