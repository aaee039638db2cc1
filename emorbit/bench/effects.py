"""Effects beyond the central field: what point masses' em step under an effect set costs.

Six groups of rows, each a ratio within the run (the engines of a comparison interleaved
repeat by repeat, medians of the per-repeat ratios in CPU time, :mod:`.timing`):

central + J2 against central only
    1000 point masses in Earth orbits (a uniform from 500 km altitude to 26,560 km, e in
    [0, 0.02], isotropic planes, time-uniform phases; GM and J2 of the Earth, dt = T/1000 of
    the lowest orbit), em order 2, through the scene's body systems: the point masses of a
    central-only simulation (:class:`~emorbit.bodies.pointmasses.PointMasses`, the packed
    kernels; one thread below ``PARALLEL_MIN`` points) and the same points after
    ``add_effect("zonal", model="earth", degree=2)`` (``PointMasses`` under the simulation's
    effects: the packed central + zonal kernel that the zonal effect declares for exactly that
    set, :mod:`emorbit.kernels.effects.zonal_packed`, on all threads from its
    ``PARALLEL_MIN`` points).
    ns per particle-step of each and their ratio; the same for one point (the lowest orbit);
    each run's largest relative energy error over the particles (kinetic plus every
    effect's potential energy, from the simulation's compiled effect set) after the steps it
    took.
each effect beside the central field
    the same 1000 point masses, em order 2, under the central field and one effect of
    :data:`EFFECT_SETS` (J2; J2..J6; drag in an exponential atmosphere and in NRLMSIS 2.1,
    the latter with pymsis only; radiation pressure with the conical shadow; the Moon; the
    Sun), and under all of them together (:data:`ALL`: J2..J6, exponential drag, radiation
    pressure, the Moon and the Sun), against the central field alone: CPU time per
    particle-step and the ratio. The points give ``Cd A / m = Cr A / m = 0.01 m2/kg``. A set
    without a packed kernel of its own runs the effect step
    (:func:`emorbit.kernels.pointmass.effect_step.effect_chunk`) with the set compiled.
1000 mutually attracting point masses
    a Plummer sphere (1000 stars of one solar mass, scale radius 1 pc, velocities scaled to
    virial equilibrium 2K = |W|, no softening; G of astropy, SI) in free space, dt =
    1e-4 sqrt(a^3 / (G M)): em time per step (``add_effect("mutual")``, the serial effect
    step, :func:`emorbit.kernels.pointmass.effect_step.effect_chunk` with the set compiled)
    against REBOUND's leapfrog with direct summation (``gravity = "basic"``, the
    same G and initial conditions), and each one's relative energy error over the steps it
    took (em's at round-off; REBOUND's about 1e-9 at this dt, while at 1e-3 a close
    encounter in other draws of the cluster costs it up to 1e-3).
compile time per effect set, and the warm start-up
    ``emorbit run`` of a short scene (two points in LEO, 100 em steps) in a fresh process:
    central only, central + zonal, central + mutual, central + zonal + mutual. Each set
    first with an empty cache (``XDG_CACHE_HOME``, ``LOCALAPPDATA`` and, on macOS,
    ``HOME`` point into a new temporary folder and ``NUMBA_CACHE_DIR`` is unset, so the
    kernel cache of :func:`emorbit.kernels.jit.cache_dir` and the compiled effect sets of
    :func:`~emorbit.effects.program.compile_set` go there; the user's own cache is neither
    used nor touched), then warm; compile time = cold - warm (median of the warm runs).
the shipped scenes' compile time and start-up
    ``emorbit run`` of shipped scenes (every one in the full configuration, four in the
    quick one: :data:`~.effects_compile.SCENES`), shortened to 20 steps, in a fresh
    process with an empty cache (the cold run's CPU time: every kernel it needs compiles,
    the body kinds' step kernels and the effect set's functions), again with the effect
    set's compiled module alone removed (the set's own compile: what a new effect set costs
    once the install's step kernels are cached) and warm (wall time).
the central-only path
    a central-only scene does not go through the effect step: its point masses run the
    packed central-field kernels, and the first row times them against
    the bare packed kernel on one thread. The ``ensemble`` section's "scene / bare kernel"
    row measures the same at 1e5 particles on all threads (``ensemble.scene_over_bare``).

The targets (:func:`targets`): central + J2 <= 1.5x central only per particle-step; each
single effect <= 2x and all together <= 4x; em <= 3x REBOUND leapfrog's time per step for
1000 mutually attracting bodies; a shipped scene's cold compile <= 15 s of CPU and its warm
start <= 1.5 s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene import list_scenes
from .common import CONFIGS, MAX_ITER, SystemRunner, ensemble_states, points_of
from .effects_compile import SCENES, SETS, compile_rows, scene_compile_rows
from .effects_mutual import mutual_rows, plummer
from .timing import CPU, clock, paired_ratio, since, timed

__all__ = [
    "Size",
    "SIZES",
    "SETS",
    "earth_orbits",
    "plummer",
    "zonal_rows",
    "mutual_rows",
    "compile_rows",
    "effect_rows",
    "scene_compile_rows",
    "run",
    "table",
    "targets",
]

#: the samples ratios use: CPU time (every engine here runs on one thread)
#: the targets of this section, as ratios within one run
TARGET_J2 = 1.5  # central + J2 <= 1.5x central only, per particle-step
TARGET_MUTUAL = 3.0  # em <= 3x REBOUND leapfrog's time per step, 1000 mutually attracting bodies
TARGET_SINGLE = 2.0  # each single effect <= 2x central only, per particle-step
TARGET_ALL = 4.0  # all of them together <= 4x central only, per particle-step
TARGET_COMPILE = 15.0  # a shipped scene's cold compile <= 15 s of CPU
TARGET_WARM = 1.5  # a shipped scene's warm start <= 1.5 s of wall time
#: the epoch of the effect rows (the Sun's and the Moon's positions, NRLMSIS's day)
EPOCH = "2026-03-20T00:00:00 TDB"
#: the effect rows: {name: [(kind, keys), ...]}, each beside the central field; NRLMSIS only
#: where pymsis is installed
EFFECT_SETS = {
    "J2": [("zonal", {"model": "earth", "degree": 2})],
    "J2..J6": [("zonal", {"model": "earth"})],
    "drag, exponential": [
        ("drag", {"atmosphere": "exponential", "density": "3.7e-12 kg/m3", "reference_altitude": "400 km",
                  "scale_height": "58 km"}),
    ],
    "drag, NRLMSIS": [("drag", {"atmosphere": "nrlmsis", "f107": 150.0, "f107a": 150.0, "ap": 15.0})],
    "srp": [("srp", {"shadow": "conical"})],
    "Moon": [("third_body", {"body": "moon"})],
    "Sun": [("third_body", {"body": "sun"})],
}  # fmt: skip
#: the effects of the row "all": one of each kind that a scene may name once
ALL = ("J2..J6", "drag, exponential", "srp", "Moon", "Sun")
#: what the point masses of the effect rows give (area per mass, m2/kg)
POINT_KEYS = {"ballistic_coefficient": 0.01, "radiation_coefficient": 0.01}
#: the semi-major axes of the Earth orbits, m: from 500 km altitude to GPS's
_R_LOW, _R_HIGH = 6878.1366e3, 26_560e3


@dataclass(frozen=True)
class Size:
    """How big the section's cases are (see :data:`SIZES`)."""

    n_orbits: int  # point masses in Earth orbits (central + J2 row)
    n_mutual: int  # mutually attracting point masses
    warm_runs: int  # warm runs per effect set (start-up rows)
    sets: tuple  # effect sets of the start-up rows
    n_effects: int  # point masses of the per-effect rows
    effect_sets: tuple  # names of EFFECT_SETS timed (and all of them together)
    scenes: tuple  # shipped scenes whose cold compile and warm start are timed (full: all of them)


#: by the name of the configuration in :data:`emorbit.bench.common.CONFIGS`
SIZES = {
    "full": Size(1000, 1000, 5, SETS, 1000, tuple(EFFECT_SETS), tuple(list_scenes())),  # every shipped scene
    "quick": Size(1000, 1000, 2, SETS, 1000, tuple(EFFECT_SETS), SCENES),
    # a smoke run for the tests: its timings mean nothing
    "tiny": Size(20, 20, 1, SETS[:2], 20, ("J2", "Moon"), SCENES[1:2]),
}


def _size(cfg) -> Size:
    return SIZES[next((name for name, c in CONFIGS.items() if c == cfg), "full")]


class _BareRunner:
    """``n`` steps of the bare packed em kernel on one thread per call: (wall, CPU) seconds."""

    def __init__(self, x, v, gm: float, center, dt: float):
        from ..integrators import coefficients, dispatch

        self.x, self.v = np.array(x, float, order="C"), np.array(v, float, order="C")
        self.cx, self.cv = np.zeros_like(self.x), np.zeros_like(self.v)
        self.gm, self.center, self.dt = gm, np.asarray(center, float), dt
        self.gammas = coefficients(2)
        self.code, self.kernel = dispatch.point_chunk("em", "brouwer", "cpu", parallel=False)
        self.steps = 0

    def __call__(self, n: int) -> tuple:
        m = self.x.shape[1]
        rx, rv = np.empty((1, 3, m)), np.empty((1, 3, m))
        its, fail = np.zeros((1, m), np.int64), np.full((m, 2), -1, np.int64)
        start = clock()
        self.kernel(
            self.code, self.x, self.v, self.cx, self.cv, self.gm, self.center, self.dt, self.gammas, n, 1,
            MAX_ITER, rx, rv, its, fail,
        )  # fmt: skip
        elapsed = since(start)
        if np.any(fail[:, 0] >= 0):
            raise RuntimeError("emorbit kernel: a step failed")
        self.steps += n
        return elapsed


def earth_orbits(n: int, gm: float, seed: int = 3):
    """The ensemble of the J2 row: point masses in Earth orbits from LEO to MEO.

    a uniform in [6878.1366, 26560] km, e uniform in [0, 0.02] (every perigee above 6740 km),
    isotropic planes, time-uniform phases.

    Parameters
    ----------
    n : int
        Number of points.
    gm : float
        GM of the Earth, m^3/s^2.
    seed : int
        Seed of numpy's default generator.

    Returns
    -------
    x, v : ndarray
        (3, n) positions (m) and velocities (m/s), C-contiguous.
    """
    return ensemble_states(n, seed, a=(_R_LOW, _R_HIGH), e=(0.0, 0.02), gm=gm)


def _point_energies(sim, x, v) -> np.ndarray:
    """Each point's specific energy: v^2/2 plus every effect's potential, (n,) J/kg, from the
    simulation's compiled effect set (each point one record of a point of unit mass)."""
    binding = sim.points.effects
    rows = np.ascontiguousarray(x.T)[:, :, None]
    coef = binding.coefficients([""], {})  # a point that gives no effect keys
    potentials = binding.potentials(rows, None, np.ones(1), np.zeros(1, np.int64), coef)
    return 0.5 * np.einsum("kn,kn->n", v, v) + sum(potentials.values())


def zonal_rows(cfg, n: int) -> dict:
    """Central + J2 against central only, per particle-step, and the scene against the bare kernel.

    Parameters
    ----------
    cfg : Config
        ``repeat_s`` and ``repeats`` (:data:`emorbit.bench.common.CONFIGS`).
    n : int
        Point masses.

    Returns
    -------
    dict
        ``rows`` ({engine: ns per particle-step in CPU and wall time, steps, Newton sweeps
        per sub-step, max relative energy error}), ``j2_over_central`` (the ratio of the
        times per particle-step), ``j2_over_central_one_point``, ``scene_over_bare`` (the
        central-only scene's throughput over the bare kernel's), the systems' classes,
        ``j2_kernel`` (the chunk kernel the J2 system runs: for central + zonal the packed
        kernel of :mod:`emorbit.kernels.effects.zonal_packed`) and the case.
    """
    import emorbit

    field = emorbit.CentralField(body="earth")
    gm, center = field.gm, field.center
    x, v = earth_orbits(n, gm)
    dt = 2 * math.pi * math.sqrt(_R_LOW**3 / gm) / 1000
    systems, ensembles = {}, {"": (x, v), " one point": (x[:, :1].copy(), v[:, :1].copy())}
    for suffix, (xs, vs) in ensembles.items():
        for label, zonal in (("central", False), ("central + J2", True)):
            sim = emorbit.Simulation(field, method="em", dt=dt)
            points_of(sim, xs, vs)
            if zonal:
                sim.add_effect("zonal", model="earth", degree=2)
            systems[label + suffix] = sim
    runners = {name: SystemRunner(sim.points, gm, center, dt) for name, sim in systems.items()}
    runners["central, bare kernel"] = _BareRunner(x, v, gm, center, dt)
    e0 = {name: _point_energies(sim, sim.points.x, sim.points.v) for name, sim in systems.items()}
    e0["central, bare kernel"] = e0["central"]
    times = timed(runners, cfg)
    packed = systems["central + J2"].effects.packed_points()
    if packed is None:
        from ..kernels.pointmass.effect_step import effect_chunk as j2_kernel
    else:
        j2_kernel = packed[0]
    rows = {}
    for name, r in runners.items():
        stats, bare = times[name], isinstance(r, _BareRunner)
        xs, vs = (r.x, r.v) if bare else (r.points.x, r.points.v)
        m = xs.shape[1]
        sim = systems.get(name, systems["central"])  # the bare kernel: the central field's
        rows[name] = {
            "system": "packed kernel" if bare else type(r.points).__name__,
            "n": m,
            "ns_per_particle_step": 1e3 * stats["cpu_us_per_step"] / m,
            "ns_per_particle_step_wall": 1e3 * stats["us_per_step"] / m,
            "steps": r.steps,
            "newton_per_substep": float(np.median(r.sweeps)) if getattr(r, "sweeps", None) else None,
            "max_energy_error": float(np.abs(_point_energies(sim, xs, vs) / e0[name] - 1.0).max()),
            "samples_cpu_us": stats[CPU],
            "steps_per_call": stats["steps"],
        }
    return {
        "case": (
            f"{n} point masses in Earth orbits (a in [{_R_LOW / 1e3:.0f}, {_R_HIGH / 1e3:.0f}] km, e in [0, 0.02], "
            f"isotropic planes, time-uniform phases), dt = {dt:.4g} s (T/1000 of the lowest orbit), em order 2; "
            'J2: add_effect("zonal", model="earth", degree=2)'
        ),
        "n": n,
        "dt": dt,
        "rows": rows,
        "j2_over_central": paired_ratio(times["central + J2"], times["central"]),
        "j2_over_central_one_point": paired_ratio(times["central + J2 one point"], times["central one point"]),
        "scene_over_bare": 1.0 / paired_ratio(times["central"], times["central, bare kernel"]),
        "central_system": type(systems["central"].points).__name__,
        "j2_system": type(systems["central + J2"].points).__name__,
        "central_under_effects": systems["central"].points.under_effects(),
        "j2_under_effects": systems["central + J2"].points.under_effects(),
        "j2_kernel": f"{j2_kernel.__module__}.{j2_kernel.__name__}",
    }


class _EffectRunner(SystemRunner):
    """``n`` em steps of point masses under an effect set, the clock from 0 at every call (the
    paths the effects follow are sampled over :attr:`SPAN` steps)."""

    SPAN = 100_000

    def __call__(self, n: int) -> tuple:
        if n > self.SPAN:
            raise RuntimeError(f"{n} steps per call: the effects' paths are sampled over {self.SPAN}")
        return super().__call__(n)


def _effect_system(field, names, x, v, dt):
    """A simulation whose point masses (unit mass, at x, v) feel the central field and the
    effects of ``names`` (keys of :data:`EFFECT_SETS`), their paths sampled ahead."""
    import emorbit

    from ..integrators import coefficients

    sim = emorbit.Simulation(field, method="em", dt=dt, epoch=EPOCH)
    for name in names:
        for kind, keys in EFFECT_SETS[name]:
            sim.add_effect(kind, **keys)
    pm = points_of(sim, x, v)
    wanted = {bk.key.name for bk in sim.effects.body_keys("point")}
    keys = {k: val for k, val in POINT_KEYS.items() if k in wanted}
    pm.values = {name: dict(keys) for name in pm.names}
    sim._prepare_effects(_EffectRunner.SPAN, coefficients(2))
    return sim


def effect_rows(cfg, n: int, names=tuple(EFFECT_SETS)) -> dict:
    """Each effect of :data:`EFFECT_SETS` beside the central field, and all of them together,
    against the central field alone: CPU time per particle-step of em (order 2) on ``n`` point
    masses in Earth orbits (:func:`earth_orbits`; dt = T/1000 of the lowest orbit), the
    engines interleaved repeat by repeat.

    Parameters
    ----------
    cfg : Config
        ``repeat_s`` and ``repeats``.
    n : int
        Point masses.
    names : sequence of str
        The effect rows to time (NRLMSIS is skipped without pymsis).

    Returns
    -------
    dict
        ``rows`` ({name: ns per particle-step (CPU, wall), Newton sweeps per sub-step, the
        ratio to central only} or {"status": "skipped: ..."}), ``worst_single`` (the largest
        ratio of a single effect and its name), ``all_over_central`` (the effects of :data:`ALL`
        that were timed, together), ``all`` (their names) and the case.
    """
    import importlib.util

    import emorbit

    field = emorbit.CentralField(body="earth")
    x, v = earth_orbits(n, field.gm)
    dt = 2 * math.pi * math.sqrt(_R_LOW**3 / field.gm) / 1000
    runnable = [nm for nm in names if "NRLMSIS" not in nm or importlib.util.find_spec("pymsis") is not None]
    together = tuple(nm for nm in ALL if nm in runnable) or tuple(runnable[-1:])
    sets = {"central": ()} | {nm: (nm,) for nm in runnable} | {"all": together}
    runners = {}
    for label, chosen in sets.items():
        sim = _effect_system(field, chosen, x, v, dt)
        runners[label] = _EffectRunner(sim.points, field.gm, field.center, dt)
    times = timed(runners, cfg)
    rows = {}
    for label, r in runners.items():
        st = times[label]
        rows[label] = {
            "ns_per_particle_step": 1e3 * st["cpu_us_per_step"] / n,
            "ns_per_particle_step_wall": 1e3 * st["us_per_step"] / n,
            "newton_per_substep": float(np.median(r.sweeps)),
            "over_central": paired_ratio(st, times["central"]) if label != "central" else 1.0,
            "samples_cpu_us": st[CPU],
        }
    for nm in names:
        if nm not in runnable:
            rows[nm] = {"status": "skipped: pymsis is not installed (pip install emorbit[msis])"}
    single = {nm: rows[nm]["over_central"] for nm in runnable}
    worst = max(single, key=single.get) if single else None
    return {
        "case": (
            f"{n} point masses in Earth orbits (as the central + J2 rows), dt = {dt:.4g} s, em order 2, epoch {EPOCH}; "
            f"point masses give {POINT_KEYS}; each effect beside the central field"
        ),
        "n": n,
        "rows": rows,
        "worst_single": {"name": worst, "over_central": single[worst]} if worst else None,
        "all_over_central": rows["all"]["over_central"],
        "all": list(together),
    }


def run(cfg, size: Size | None = None) -> dict:
    """Measure the section.

    Parameters
    ----------
    cfg : Config
        A configuration of :data:`emorbit.bench.common.CONFIGS`.
    size : Size, optional
        The cases' sizes; default: the one of :data:`SIZES` named like ``cfg``.

    Returns
    -------
    dict
        JSON-ready: ``zonal`` (:func:`zonal_rows`), ``each`` (:func:`effect_rows`),
        ``mutual`` (:func:`mutual_rows`), ``compile`` (:func:`compile_rows`), ``scenes``
        (:func:`scene_compile_rows`), ``central_path`` (which system a central-only
        scene runs, and where the ``ensemble`` section measures it), and the headline
        figures ``j2_over_central``, ``mutual_em_over_rebound_leapfrog``, ``compile_s``
        and ``warm_startup_s`` ({effect set: s}).
    """
    size = size or _size(cfg)
    zonal = zonal_rows(cfg, size.n_orbits)
    each = effect_rows(cfg, size.n_effects, size.effect_sets)
    mutual = mutual_rows(cfg, size.n_mutual)
    compiled = compile_rows(size.sets, size.warm_runs)
    scenes = scene_compile_rows(size.scenes, size.warm_runs)
    sets = {" + ".join(s["effects"]): s for s in compiled["sets"]}
    return {
        "zonal": zonal,
        "each": each,
        "mutual": mutual,
        "compile": compiled,
        "scenes": scenes,
        "central_path": {
            "system": zonal["central_system"],
            "scene_over_bare_1thread": zonal["scene_over_bare"],
            "reference": "ensemble.scene_over_bare",
            "note": "the ensemble section times a point-mass scene against the bare kernel at 1e5 particles "
            "on all threads, with the effects registry imported (import emorbit imports it)",
        },
        "j2_over_central": zonal["j2_over_central"],
        "mutual_em_over_rebound_leapfrog": mutual["em_over_rebound_leapfrog"],
        "compile_s": {k: s["compile_s"] for k, s in sets.items()},
        "warm_startup_s": {k: s["warm_s"] for k, s in sets.items()},
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
        The lines of the tables.
    """
    z, mu, co = section["zonal"], section["mutual"], section["compile"]
    lines = [
        f"effects, central + J2: {z['case']}; CPU time per step (median of interleaved repeats), wall beside it",
        f"  {'':<26} {'system':<14} {'ns/particle-step':>17} {'wall':>9} {'Newton/sub-step':>16} {'max |dE/E|':>11}",
    ]
    for name, r in z["rows"].items():
        newton = f"{r['newton_per_substep']:.2f}" if r["newton_per_substep"] is not None else ""
        lines.append(
            f"  {name:<26} {r['system']:<14} {r['ns_per_particle_step']:>17.2f} {r['ns_per_particle_step_wall']:>9.2f} "
            f"{newton:>16} {r['max_energy_error']:>11.1e}"
        )
    lines += [
        f"  central + J2 / central only per particle-step: {z['j2_over_central']:.2f}x ({z['n']} points), "
        f"{z['j2_over_central_one_point']:.2f}x (one point); target <= {TARGET_J2:g}x",
        f"  central-only path: the scene's points are {section['central_path']['system']} (the packed kernels, no "
        f"effect step): scene / bare kernel on one thread {z['scene_over_bare']:.3f}; at 1e5 particles on all "
        "threads see the ensemble section's scene / bare kernel row (JSON ensemble.scene_over_bare)",
        "",
        f"effects, each beside the central field: {section['each']['case']}",
        f"  {'':<20} {'ns/particle-step':>17} {'wall':>9} {'Newton/sub-step':>16} {'/ central':>10}",
    ]
    for name, r in section["each"]["rows"].items():
        if "status" in r:
            lines.append(f"  {name:<20} {r['status']}")
            continue
        lines.append(
            f"  {name:<20} {r['ns_per_particle_step']:>17.2f} {r['ns_per_particle_step_wall']:>9.2f} "
            f"{r['newton_per_substep']:>16.2f} {r['over_central']:>9.2f}x"
        )
    lines += [
        f"  targets: each single effect <= {TARGET_SINGLE:g}x, all together <= {TARGET_ALL:g}x central only",
        "",
        f"effects, mutual gravity: {mu['case']}; virial ratio 2K/|W| = {mu['virial_ratio']:.3f}",
        f"  {'':<18} {'ms/step':>10} {'wall':>10} {'steps':>7} {'|dE/E| over them':>17}",
    ]
    for name, r in mu["rows"].items():
        if "status" in r:
            lines.append(f"  {name:<18} {r['status']}")
            continue
        lines.append(
            f"  {name:<18} {r['ms_per_step']:>10.3f} {r['ms_per_step_wall']:>10.3f} {r['steps']:>7} "
            f"{r['energy_error']:>17.1e}"
        )
    ratio = mu["em_over_rebound_leapfrog"]
    lines.append(
        f"  em / REBOUND leapfrog per step: {f'{ratio:.2f}x' if ratio is not None else 'n/a'}; target <= "
        f"{TARGET_MUTUAL:g}x (em: {mu['rows']['em']['newton_sweeps_per_substep']:.1f} Newton sweeps per sub-step)"
    )
    lines += [
        "",
        f"effects, compile time and start-up: {co['case']}",
        f"  {'effects':<26} {'cold s':>8} {'warm s':>8} {'compile s':>10} {'vs central s':>13}",
    ]
    for s in co["sets"]:
        extra = f"{s['compile_over_central_s']:+.2f}" if "compile_over_central_s" in s else ""
        lines.append(
            f"  {' + '.join(s['effects']):<26} {s['cold_s']:>8.2f} {s['warm_s']:>8.2f} {s['compile_s']:>10.2f} "
            f"{extra:>13}"
        )
    lines.append(
        "  (a central-only scene compiles the packed point-mass kernels, a scene with effects the effect step "
        "instead: 'vs central' is the difference of the two compile times)"
    )
    sc = section["scenes"]
    lines += [
        "",
        f"effects, shipped scenes: {sc['case']}",
        f"  {'scene':<30} {'cold CPU s':>11} {'new set CPU s':>14} {'cold s':>8} {'warm s':>8}",
    ]
    for r in sc["scenes"]:
        lines.append(
            f"  {r['scene']:<30} {r['cold_cpu_s']:>11.2f} {r['set_cpu_s']:>14.2f} {r['cold_s']:>8.2f} "
            f"{r['warm_s']:>8.2f}"
        )
    lines += [
        f"  targets: an effect set's compile (new set CPU s: the install's step kernels cached) <= {TARGET_COMPILE:g} s"
        f" of CPU, warm start <= {TARGET_WARM:g} s per scene",
        "  (cold CPU s: an empty cache, every kernel compiles, as on the first run after an install)",
        f"  the libraries' floor of every warm start (import astropy.units and numba, ready numba's CPU target): "
        f"{sc['floor_s']:.2f} s",
    ]
    return lines


def targets(section: dict) -> list[dict]:
    """The section's targets, evaluated on what :func:`run` returned.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.

    Returns
    -------
    list of dict
        As :func:`emorbit.bench.runner.targets`: ``target``, ``measured``, ``limit``, ``met``.
    """
    out = []
    r = section["j2_over_central"]
    out.append(
        {
            "target": "central + J2 <= 1.5x central only per particle-step",
            "measured": r,
            "limit": TARGET_J2,
            "met": r <= TARGET_J2,
        }
    )
    each = section["each"]
    for name, row in each["rows"].items():
        if "status" in row or name in ("central", "all"):
            continue
        out.append(
            {
                "target": f"central + {name} <= {TARGET_SINGLE:g}x central only per particle-step",
                "measured": row["over_central"],
                "limit": TARGET_SINGLE,
                "met": row["over_central"] <= TARGET_SINGLE,
            }
        )
    out.append(
        {
            "target": f"central + all effects <= {TARGET_ALL:g}x central only per particle-step",
            "measured": each["all_over_central"],
            "limit": TARGET_ALL,
            "met": each["all_over_central"] <= TARGET_ALL,
        }
    )
    for r in section["scenes"]["scenes"]:
        out.append(
            {
                "target": f"{r['scene']}: its effect set's cold compile <= {TARGET_COMPILE:g} s of CPU",
                "measured": r["set_cpu_s"],
                "limit": TARGET_COMPILE,
                "met": r["set_cpu_s"] <= TARGET_COMPILE,
            }
        )
        out.append(
            {
                "target": f"{r['scene']}: warm start <= {TARGET_WARM:g} s",
                "measured": r["warm_s"],
                "limit": TARGET_WARM,
                "met": r["warm_s"] <= TARGET_WARM,
            }
        )
    r = section["mutual_em_over_rebound_leapfrog"]
    if r is not None:
        out.append(
            {
                "target": f"em <= 3x REBOUND leapfrog per step, {section['mutual']['n']} mutually attracting bodies",
                "measured": r,
                "limit": TARGET_MUTUAL,
                "met": r <= TARGET_MUTUAL,
            }
        )
    return out
