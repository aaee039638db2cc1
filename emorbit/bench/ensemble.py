"""Many test particles: particle-steps per second.

1e5 test particles (a uniform in [5, 10] m, e uniform in [0, 0.9], isotropic planes,
time-uniform phases), GM = 3.9478 m^3/s^2, dt = T/1000 of a 6 m orbit. emorbit's em on one
thread and on all threads (the bare packed kernel, :mod:`emorbit.kernels.pointmass.packed`),
the same with roundoff="fast" (the root of the plainly evaluated scalar equation: its energy
drifts at round-off level), its leapfrog on one thread, and REBOUND's leapfrog and WHFast
(N_active = 1, WHFast without safe mode), all interleaved; wall-clock time per step (the CPU
time of the single-threaded engines beside it). Each engine's max relative energy error
over the particles after the steps it took. Then:

* the bound from division and square-root throughput (:mod:`.limits`), measured in the same
  run, for the em kernel's counts per particle-step (the same for both roundoff settings)
  and leapfrog's;
* the floor (:func:`.limits.floor`): the least work an em particle-step can do on the
  kernel's state (its divisions and square roots, the compensated update of 12 rows of a
  block in the L1 cache), and with it the most of the bound any kernel keeping that state
  can reach on this machine (``em_ceiling_fraction_of_bound_*``);
* a point-mass scene's throughput against the bare kernel's: the scene's body system
  (:meth:`PointMasses.advance`, which records and dispatches) interleaved with the bare
  kernel, and once the whole driver (:meth:`Simulation.run`, one record per call: it also
  computes the invariants and hands 1e5 bodies' records to the sink).
"""

from __future__ import annotations

import numpy as np

from .common import (
    ENSEMBLE_DT,
    GM,
    EmorbitRunner,
    KernelRunner,
    ReboundRunner,
    energies,
    ensemble_states,
    numba_threads,
    point_masses,
    rebound_sim,
    rebound_state,
)
from .limits import floor, measure
from .timing import clock, loadavg, paired_ratio, since, timed

__all__ = ["run", "table"]

#: the samples that ratios use here: wall clock (the all-threads rows use every core)
WALL = "samples_us"


def _max_energy_error(x, v, e0) -> float:
    return float(np.abs(energies(x, v) / e0 - 1.0).max())


def _driver(x, v, steps: int) -> tuple:
    """Simulation.run over ``steps`` steps, one record: (wall, CPU) seconds."""
    import emorbit

    sim = emorbit.Simulation(emorbit.CentralField(gm=GM), method="em", order=2, dt=ENSEMBLE_DT)
    sim.points = point_masses(x, v)
    sim.run(steps=1, every=1, keep=False)  # warm-up
    start = clock()
    sim.run(steps=steps, every=steps, keep=False)
    return since(start)


def run(cfg) -> dict:
    """Measure the section.

    Parameters
    ----------
    cfg : Config
        A configuration of :data:`emorbit.bench.common.CONFIGS`.

    Returns
    -------
    dict
        JSON-ready: ``rows`` (one per engine: particle-steps per second, ns per
        particle-step, max energy error), the bound and the floor (:mod:`.limits`), the
        ratios the targets use, and the whole driver's throughput.
    """
    from ..kernels.pointmass import packed as kern

    n = cfg.ensemble_n
    load = loadavg()
    x, v = ensemble_states(n)
    e0 = energies(x, v)
    runners = {
        "em all threads": KernelRunner(x, v, "em", 2, ENSEMBLE_DT, parallel=True),
        "em 1 thread": KernelRunner(x, v, "em", 2, ENSEMBLE_DT, parallel=False),
        'em roundoff="fast" all threads': KernelRunner(x, v, "em", 2, ENSEMBLE_DT, parallel=True, roundoff="fast"),
        'em roundoff="fast" 1 thread': KernelRunner(x, v, "em", 2, ENSEMBLE_DT, parallel=False, roundoff="fast"),
        "em scene (PointMasses.advance)": EmorbitRunner(x, v, "em", 2, ENSEMBLE_DT),
        "leapfrog 1 thread": KernelRunner(x, v, "leapfrog", 2, ENSEMBLE_DT, parallel=False),
        "rebound leapfrog": ReboundRunner(rebound_sim(x, v, "leapfrog", ENSEMBLE_DT)),
        "rebound whfast": ReboundRunner(rebound_sim(x, v, "whfast", ENSEMBLE_DT)),
    }
    times = timed(runners, cfg)
    rows = {}
    for name, r in runners.items():
        stats = times[name]
        if isinstance(r, ReboundRunner):
            xs, vs = rebound_state(r.sim)
        elif isinstance(r, KernelRunner):
            xs, vs = r.x, r.v
        else:
            xs, vs = r.pm.x, r.pm.v
        rows[name] = {
            "particle_steps_per_s": n / (1e-6 * stats["us_per_step"]),
            "particle_steps_per_s_cpu": n / (1e-6 * stats["cpu_us_per_step"]),
            "ns_per_particle_step": 1e3 * stats["us_per_step"] / n,
            "steps": r.steps,
            "max_energy_error": _max_energy_error(xs, vs, e0),
            "samples_us_per_step": stats[WALL],
            "steps_per_call": stats["steps"],
        }
    threads = numba_threads()
    limits = measure(
        {
            "em": (kern.EM_SQRTS, kern.EM_DIVISIONS),
            "em_fast": (kern.EM_PLAIN_SQRTS, kern.EM_PLAIN_DIVISIONS),
            "leapfrog": (kern.LEAPFROG_SQRTS, kern.LEAPFROG_DIVISIONS),
        },
        threads["threads"],
    )
    em_bound = limits["kernels"]["em"]
    lowest = floor(threads["threads"])
    assert (lowest["sqrts"], lowest["divisions"]) == (em_bound["sqrts"], em_bound["divisions"])
    em1, emN = rows["em 1 thread"], rows["em all threads"]
    lf = rows["rebound leapfrog"]
    # the whole driver, once: the kernel's time for these steps is about 1 s on two cores
    steps = max(10, int(1.0 * emN["particle_steps_per_s"] / n)) if cfg.repeats > 2 else 10
    wall, cpu = _driver(x, v, steps)
    driver = {
        "steps": steps,
        "wall_s": wall,
        "particle_steps_per_s": n * steps / wall,
        "ratio_to_bare_all_threads": n * steps / wall / emN["particle_steps_per_s"],
    }
    return {
        "case": (
            f"{n} test particles: a in [5, 10] m, e in [0, 0.9], isotropic planes, time-uniform phases; "
            f"GM = {GM}, dt = {ENSEMBLE_DT:.6g} s (T/1000 of a 6 m orbit); em order 2"
        ),
        "clock": "wall time per step (median of interleaved repeats); CPU time beside it",
        "n": n,
        "threads": threads,
        "load_average_at_start": load,
        "rows": rows,
        "em_particle_steps_per_s": emN["particle_steps_per_s"],
        "em_1thread_particle_steps_per_s": em1["particle_steps_per_s"],
        "rebound_leapfrog_particle_steps_per_s": lf["particle_steps_per_s"],
        "rebound_whfast_particle_steps_per_s": rows["rebound whfast"]["particle_steps_per_s"],
        "em_over_rebound_leapfrog": 1.0 / paired_ratio(times["em all threads"], times["rebound leapfrog"], WALL),
        "em_1thread_over_rebound_leapfrog": 1.0 / paired_ratio(times["em 1 thread"], times["rebound leapfrog"], WALL),
        "em_fast_over_rebound_leapfrog": 1.0
        / paired_ratio(times['em roundoff="fast" all threads'], times["rebound leapfrog"], WALL),
        "em_fast_fraction_of_bound_all_threads": (
            rows['em roundoff="fast" all threads']["particle_steps_per_s"]
            / limits["kernels"]["em_fast"]["bound_per_s_all_threads"]
        ),
        "limits": limits,
        "em_fraction_of_bound_1thread": em1["particle_steps_per_s"] / em_bound["bound_per_s_1_thread"],
        "em_fraction_of_bound_all_threads": emN["particle_steps_per_s"] / em_bound["bound_per_s_all_threads"],
        "floor": lowest,
        "em_ceiling_fraction_of_bound_1thread": em_bound["mix_ns_1_thread"] / lowest["compensated"]["ns_1_thread"],
        "em_ceiling_fraction_of_bound_all_threads": (
            em_bound["mix_ns_all_threads"] / lowest["compensated"]["ns_all_threads"]
        ),
        "em_over_floor_1thread": em1["ns_per_particle_step"] / lowest["compensated"]["ns_1_thread"],
        "em_over_floor_all_threads": emN["ns_per_particle_step"] / lowest["compensated"]["ns_all_threads"],
        "scene_over_bare": 1.0 / paired_ratio(times["em scene (PointMasses.advance)"], times["em all threads"], WALL),
        "driver": driver,
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
    th = section["threads"]
    lines = [
        f"ensemble: {section['case']}",
        f"  {section['clock']}; Numba threads: {th['threads']} ({th['threading_layer']})",
        f"  {'':<34} {'particle-steps/s':>17} {'ns/particle-step':>17} {'max |dE/E|':>11} {'steps':>7}",
    ]
    for name, r in section["rows"].items():
        lines.append(
            f"  {name:<34} {r['particle_steps_per_s']:>17.3g} {r['ns_per_particle_step']:>17.2f} "
            f"{r['max_energy_error']:>11.1e} {r['steps']:>7}"
        )
    lim = section["limits"]
    em = lim["kernels"]["em"]
    lines += [
        f"  packed division {lim['divide_ns']:.3f} ns, square root {lim['sqrt_ns']:.3f} ns per element (one thread)",
        f"  em kernel: {em['sqrts']} square roots + {em['divisions']} divisions per particle-step: "
        f"bound {em['bound_per_s_1_thread']:.3g}/s on one thread, {em['bound_per_s_all_threads']:.3g}/s on all; "
        f"em reaches {100 * section['em_fraction_of_bound_1thread']:.0f} % and "
        f"{100 * section['em_fraction_of_bound_all_threads']:.0f} %",
        f"  floor, the least an em particle-step does on this state ({section['floor']['sqrts']} square roots + "
        f"{section['floor']['divisions']} divisions, {section['floor']['rows_compensated']} rows updated, "
        f"compensated): {section['floor']['compensated']['ns_1_thread']:.2f} ns on one thread, "
        f"{section['floor']['compensated']['ns_all_threads']:.2f} ns on all: no kernel keeping this state "
        f"reaches more than {100 * section['em_ceiling_fraction_of_bound_1thread']:.0f} % and "
        f"{100 * section['em_ceiling_fraction_of_bound_all_threads']:.0f} % of the bound; em takes "
        f"{section['em_over_floor_1thread']:.1f}x and {section['em_over_floor_all_threads']:.1f}x the floor "
        f"(floor without the compensations, {section['floor']['rows_plain']} rows: "
        f"{section['floor']['plain']['ns_1_thread']:.2f} and {section['floor']['plain']['ns_all_threads']:.2f} ns)",
        f"  em all threads / REBOUND leapfrog: {section['em_over_rebound_leapfrog']:.2f}x; one thread: "
        f"{section['em_1thread_over_rebound_leapfrog']:.2f}x",
        f'  em roundoff="fast" ({lim["kernels"]["em_fast"]["sqrts"]} square roots + '
        f"{lim['kernels']['em_fast']['divisions']} divisions, plain root: its energy drifts at round-off "
        f"level): {section['em_fast_over_rebound_leapfrog']:.2f}x REBOUND leapfrog, "
        f"{100 * section['em_fast_fraction_of_bound_all_threads']:.0f} % of its bound on all threads",
        f"  scene (PointMasses.advance) / bare kernel: {section['scene_over_bare']:.3f}; whole driver "
        f"(Simulation.run, {section['driver']['steps']} steps, one record): "
        f"{section['driver']['ratio_to_bare_all_threads']:.3f}",
    ]
    load = section.get("load_average_at_start")
    if load and load[0] >= 0.5:
        lines.append(
            f"  (the machine was busy: 1-minute load average {load[0]} at the start; the all-threads rows "
            "shared cores with other processes)"
        )
    return lines
