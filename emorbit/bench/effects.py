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
    Sun), and under all of them together, against the central field alone: CPU time per
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
    ``emorbit run`` of each shipped scene with effects, shortened to 20 steps, in a fresh
    process with an empty cache (the cold run's CPU time: every kernel it needs compiles,
    the body kinds' step kernels and the effect set's functions) and then warm (wall time).
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
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

import numpy as np

from .common import CONFIGS, ensemble_states, point_masses
from .timing import calibrate, clock, paired_ratio, since, timed

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
CPU = "cpu_samples_us"
#: the effect sets of the start-up rows, each with the central field
SETS = (("central",), ("central", "zonal"), ("central", "mutual"), ("central", "zonal", "mutual"))
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
#: what the point masses of the effect rows give (area per mass, m2/kg)
POINT_KEYS = {"ballistic_coefficient": 0.01, "radiation_coefficient": 0.01}
#: the shipped scenes whose cold compile and warm start the section times
SCENES = ("leo-drag-sunlight-moon-sun", "earth-j2-sun-synchronous", "three-body-figure-eight", "binary-asteroid")
#: the semi-major axes of the Earth orbits, m: from 500 km altitude to GPS's
_R_LOW, _R_HIGH = 6878.1366e3, 26_560e3
_MAX_ITER = 50


@dataclass(frozen=True)
class Size:
    """How big the section's cases are (see :data:`SIZES`)."""

    n_orbits: int  # point masses in Earth orbits (central + J2 row)
    n_mutual: int  # mutually attracting point masses
    warm_runs: int  # warm runs per effect set (start-up rows)
    sets: tuple  # effect sets of the start-up rows
    n_effects: int  # point masses of the per-effect rows
    effect_sets: tuple  # names of EFFECT_SETS timed (and all of them together)
    scenes: tuple  # shipped scenes whose cold compile and warm start are timed


#: by the name of the configuration in :data:`emorbit.bench.common.CONFIGS`
SIZES = {
    "full": Size(1000, 1000, 5, SETS, 1000, tuple(EFFECT_SETS), SCENES),
    "quick": Size(1000, 1000, 2, SETS, 1000, tuple(EFFECT_SETS), SCENES),
    # a smoke run for the tests: its timings mean nothing
    "tiny": Size(20, 20, 1, SETS[:2], 20, ("J2", "Moon"), SCENES[1:2]),
}


def _size(cfg) -> Size:
    return SIZES[next((name for name, c in CONFIGS.items() if c == cfg), "full")]


class _SystemRunner:
    """``n`` em steps of a body system (its ``advance``) per call: (wall, CPU) seconds."""

    def __init__(self, points, gm: float, center, dt: float):
        from ..integrators import coefficients

        self.points, self.gm, self.center, self.dt = points, gm, np.asarray(center, float), dt
        self.gammas = coefficients(2)
        self.steps = 0
        self.sweeps = []

    def __call__(self, n: int) -> tuple:
        start = clock()
        rec = self.points.advance("em", self.gm, self.center, self.dt, self.gammas, n, 1, _MAX_ITER)
        elapsed = since(start)
        if rec.first_failure() is not None:
            raise RuntimeError(f"emorbit {type(self.points).__name__}: a step failed {rec.first_failure()}")
        self.steps += n
        self.sweeps.append(float(rec.iterations.mean()) / (n * self.gammas.size))
        return elapsed


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
            _MAX_ITER, rx, rv, its, fail,
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


def _points_of(sim, x, v):
    """Put point masses of unit mass at (x, v) into ``sim``, under its effects."""
    pm = point_masses(x, v)
    pm.effects, pm.plan = sim.points.effects, sim.plan
    sim.points = pm
    return pm


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
            _points_of(sim, xs, vs)
            if zonal:
                sim.add_effect("zonal", model="earth", degree=2)
            systems[label + suffix] = sim
    runners = {name: _SystemRunner(sim.points, gm, center, dt) for name, sim in systems.items()}
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


class _EffectRunner(_SystemRunner):
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
    pm = _points_of(sim, x, v)
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
        ratio of a single effect and its name), ``all_over_central`` and the case.
    """
    import importlib.util

    import emorbit

    field = emorbit.CentralField(body="earth")
    x, v = earth_orbits(n, field.gm)
    dt = 2 * math.pi * math.sqrt(_R_LOW**3 / field.gm) / 1000
    runnable = [nm for nm in names if "NRLMSIS" not in nm or importlib.util.find_spec("pymsis") is not None]
    sets = {"central": ()} | {nm: (nm,) for nm in runnable} | {"all": tuple(runnable)}
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
    }


def _cpu_children() -> float:
    """CPU seconds of this process's finished children (wall clock where there is no resource)."""
    try:
        import resource
    except ImportError:  # Windows
        return time.perf_counter()
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def scene_compile_rows(scenes=SCENES, warm_runs: int = 2) -> dict:
    """Cold and warm ``emorbit run`` of shipped scenes, shortened to 20 steps, in fresh processes.

    Parameters
    ----------
    scenes : sequence of str
        Shipped scene names.
    warm_runs : int
        Warm runs per scene (their median is the warm time).

    Returns
    -------
    dict
        ``scenes`` (one per scene: ``scene``, ``cold_cpu_s`` (the cold run's CPU time, an empty
        kernel cache: compiling every kernel the scene needs), ``cold_s`` (wall), ``warm_s``
        (wall, the median of the warm runs), ``warm_samples_s``) and the case.
    """
    import emorbit

    out = []
    with tempfile.TemporaryDirectory(prefix="emorbit-bench-scenes-") as tmp:
        for name in scenes:
            home = os.path.join(tmp, name)
            os.makedirs(home)
            env, h5 = _environment(home), os.path.join(tmp, f"{name}.h5")
            t_end = f"{20 * emorbit.load_scene(name).dt!r} s"
            cmd = [sys.executable, "-m", "emorbit.cli", "run", name, "-o", h5, "--overwrite", "-q", "--t-end", t_end]

            def once(cmd=cmd, env=env):
                cpu, start = _cpu_children(), time.perf_counter()
                subprocess.run(cmd, env=env, check=True, capture_output=True)
                return time.perf_counter() - start, _cpu_children() - cpu

            cold, cold_cpu = once()
            warm = [once()[0] for _ in range(warm_runs)]
            out.append(
                {"scene": name, "cold_s": cold, "cold_cpu_s": cold_cpu, "warm_s": float(np.median(warm)),
                 "warm_samples_s": warm}
            )  # fmt: skip
    return {
        "case": "emorbit run SCENE --t-end (20 steps) -o OUT.h5 --overwrite -q, fresh processes; cold: an empty "
        "kernel cache (a new temporary folder: every kernel the scene needs compiles), warm: the same cache filled",
        "scenes": out,
    }


def plummer(n: int, seed: int = 8):
    """A Plummer sphere of n stars of one solar mass, scale radius 1 pc, in virial equilibrium.

    Positions and speeds are drawn from Plummer's distribution function (Aarseth, Henon and
    Wielen 1974; radii out to the one enclosing 99 % of the mass), isotropic directions,
    moved to the centre of mass at rest; the velocities are then scaled so that 2K = |W|.

    Parameters
    ----------
    n : int
        Number of stars (at least 2).
    seed : int
        Seed of numpy's default generator.

    Returns
    -------
    m : ndarray
        (n,) masses, kg.
    x, v : ndarray
        (3, n) positions (m) and velocities (m/s).
    a, total : float
        The scale radius (m) and the total mass (kg).
    """
    import astropy.constants as const
    import astropy.units as u

    from ..effects.mutual import G

    rng = np.random.default_rng(seed)
    msun, a = float(const.M_sun.si.value), float((1 * u.pc).si.value)
    m = np.full(n, msun)
    total = float(m.sum())
    r = a / np.sqrt(rng.uniform(0.0, 0.99, n) ** (-2.0 / 3.0) - 1.0)
    q = np.empty(n)
    k = 0
    while k < n:  # von Neumann rejection for q = v / v_escape: g(q) = q^2 (1 - q^2)^3.5
        s, y = rng.uniform(0.0, 1.0), rng.uniform(0.0, 0.1)
        if y < s * s * (1.0 - s * s) ** 3.5:
            q[k] = s
            k += 1
    speed = q * np.sqrt(2.0 * G * total / np.sqrt(r * r + a * a))

    def directions():
        c, phi = rng.uniform(-1.0, 1.0, n), rng.uniform(0.0, 2 * np.pi, n)
        s = np.sqrt(1.0 - c * c)
        return np.array([s * np.cos(phi), s * np.sin(phi), c])

    x, v = r * directions(), speed * directions()
    x -= (x @ m / total)[:, None]
    v -= (v @ m / total)[:, None]
    kinetic, potential = _nbody_energy(m, x, v)
    v *= math.sqrt(-potential / (2.0 * kinetic))
    return m, np.ascontiguousarray(x), np.ascontiguousarray(v), a, total


def _nbody_energy(m, x, v) -> tuple:
    """Kinetic and mutual potential energy of point masses, J (the mutual effect's own
    potential, from its compiled set in free space; each point a body of its own)."""
    from ..bodies.effect_binding import EffectBinding
    from ..effects.effectset import EffectSet

    effects = EffectSet(None)
    effects.add({"kind": "mutual"}, "mutual")
    n = m.size
    x, m = np.ascontiguousarray(x, float)[None], np.ascontiguousarray(m, float)
    potentials = EffectBinding(effects, "point").potentials(x, None, m, np.arange(n, dtype=np.int64), np.ones((1, n)))
    kinetic = 0.5 * float(np.einsum("kn,kn,n->", v, v, m))
    return kinetic, float(potentials["potential_mutual"][0])


def _timed_slow(runners: dict, cfg) -> dict:
    """:func:`.timing.timed` for engines whose step may take longer than a call should: calls
    of at least one step (not twenty)."""
    steps = {name: calibrate(fn, cfg.repeat_s, min_steps=1) for name, fn in runners.items()}
    samples = {name: [] for name in runners}
    for _ in range(cfg.repeats):
        for name, fn in runners.items():
            samples[name].append(np.array(fn(steps[name])) / steps[name] * 1e6)
    out = {}
    for name, us in samples.items():
        wall, cpu = np.array(us).T
        out[name] = {
            "us_per_step": float(np.median(wall)),
            "cpu_us_per_step": float(np.median(cpu)),
            "steps": steps[name],
            "repeats": len(us),
            "samples_us": [round(float(s), 4) for s in wall],
            CPU: [round(float(s), 4) for s in cpu],
        }
    return out


class _ReboundRunner:
    def __init__(self, sim):
        self.sim, self.steps = sim, 0

    def __call__(self, n: int) -> tuple:
        start = clock()
        self.sim.steps(n)
        elapsed = since(start)
        self.steps += n
        return elapsed


def _rebound_nbody(m, x, v, dt: float):
    """REBOUND's leapfrog with direct summation (no softening) of the same bodies, G of astropy."""
    import rebound

    from ..effects.mutual import G

    sim = rebound.Simulation()
    sim.G = G
    for i in range(m.size):
        sim.add(m=float(m[i]), x=x[0, i], y=x[1, i], z=x[2, i], vx=v[0, i], vy=v[1, i], vz=v[2, i])
    sim.integrator = "leapfrog"
    sim.gravity = "basic"
    sim.softening = 0.0
    sim.dt = dt
    return sim


def _rebound_xv(sim):
    n = sim.N
    xyz, vel = np.empty((n, 3)), np.empty((n, 3))
    sim.serialize_particle_data(xyz=xyz, vxvyvz=vel)
    return np.ascontiguousarray(xyz.T), np.ascontiguousarray(vel.T)


def mutual_rows(cfg, n: int) -> dict:
    """em against REBOUND's leapfrog (direct summation) for n mutually attracting point masses.

    Parameters
    ----------
    cfg : Config
        ``repeat_s`` and ``repeats`` (:data:`emorbit.bench.common.CONFIGS`).
    n : int
        Bodies.

    Returns
    -------
    dict
        ``rows`` ({"em", "rebound leapfrog"}: ms per step in CPU and wall time, steps,
        relative energy error over those steps; REBOUND's ``{"status": "skipped: ..."}``
        where it is not installed), ``em_over_rebound_leapfrog`` (None without REBOUND),
        the virial ratio and the case.
    """
    import emorbit

    from ..effects.mutual import G

    m, x, v, a, total = plummer(n)
    t_dyn = math.sqrt(a**3 / (G * total))
    dt = 1e-4 * t_dyn
    sim = emorbit.Simulation(None, method="em", dt=dt)
    sim.add_effect("mutual")
    points = _points_of(sim, x, v)
    points.masses = m.copy()
    runners = {"em": _SystemRunner(points, 0.0, np.zeros(3), dt)}
    rows = {}
    try:
        runners["rebound leapfrog"] = _ReboundRunner(_rebound_nbody(m, x, v, dt))
    except ImportError as exc:
        rows["rebound leapfrog"] = {"status": f"skipped: {type(exc).__name__}: {exc}"}
    kinetic, potential = _nbody_energy(m, x, v)
    e0 = kinetic + potential
    times = _timed_slow(runners, cfg)
    for name, r in runners.items():
        xs, vs = (points.x, points.v) if name == "em" else _rebound_xv(r.sim)
        stats = times[name]
        rows[name] = {
            "ms_per_step": 1e-3 * stats["cpu_us_per_step"],
            "ms_per_step_wall": 1e-3 * stats["us_per_step"],
            "steps": r.steps,
            "energy_error": abs(sum(_nbody_energy(m, xs, vs)) / e0 - 1.0),
            "samples_cpu_us": stats[CPU],
            "steps_per_call": stats["steps"],
        }
    rows["em"]["newton_sweeps_per_substep"] = float(np.median(runners["em"].sweeps))
    ratio = paired_ratio(times["em"], times["rebound leapfrog"]) if "rebound leapfrog" in times else None
    return {
        "case": (
            f"{n} stars of 1 solar mass in a Plummer sphere (a = 1 pc, 2K/|W| = 1, no softening), free space, "
            f"G = {G:.5e} m^3/(kg s^2), dt = 1e-4 sqrt(a^3/(G M)) = {dt:.4g} s; "
            'em: add_effect("mutual"); REBOUND: leapfrog, gravity = "basic"'
        ),
        "n": n,
        "dt": dt,
        "virial_ratio": 2 * kinetic / abs(potential),
        "rows": rows,
        "em_over_rebound_leapfrog": ratio,
    }


_SCENE = """[field]
body = "earth"

[integrator]
method = "em"
dt = "10 s"
t_end = "1000 s"
output_every = 10
{effects}
[[body]]
name = "a"
kind = "point"
mass = "1000 kg"
orbit = {{a = "7000 km", e = 0.001, i = "98 deg"}}

[[body]]
name = "b"
kind = "point"
mass = "1000 kg"
orbit = {{a = "7000 km", e = 0.001, i = "98 deg", nu = "0.01 rad"}}
"""
_TABLES = {
    "zonal": '\n[[effect]]\nkind = "zonal"\nmodel = "earth"\ndegree = 2\n',
    "mutual": '\n[[effect]]\nkind = "mutual"\n',
}


def _environment(home: str) -> dict:
    """The environment of a run whose every cache lies under ``home``."""
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "EMORBIT_JIT_CACHE")}
    env["XDG_CACHE_HOME"] = os.path.join(home, "cache")
    env["LOCALAPPDATA"] = os.path.join(home, "local")
    if sys.platform == "darwin":
        env["HOME"] = home
    return env


def _run_scene(scene: str, out: str, env: dict) -> float:
    cmd = [sys.executable, "-m", "emorbit.cli", "run", scene, "-o", out, "--overwrite", "-q"]
    start = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, capture_output=True)
    return time.perf_counter() - start


def compile_rows(sets=SETS, warm_runs: int = 2) -> dict:
    """Cold and warm ``emorbit run`` of a short scene per effect set, each in fresh processes.

    Parameters
    ----------
    sets : sequence of tuple of str
        Effect sets, each starting with ``"central"``.
    warm_runs : int
        Warm runs per set (their median is the warm time).

    Returns
    -------
    dict
        ``sets`` (one per set: ``effects``, ``cold_s``, ``warm_s``, ``warm_samples_s``,
        ``compile_s`` = cold - warm, ``compile_over_central_s`` where the central-only set
        ran, ``cache_files``: the files the cold run left in the temporary cache) and the case.
    """
    out = []
    with tempfile.TemporaryDirectory(prefix="emorbit-bench-effects-") as tmp:
        for kinds in sets:
            name = "_".join(kinds)
            scene = os.path.join(tmp, f"{name}.toml")
            with open(scene, "w") as f:
                f.write(_SCENE.format(effects="".join(_TABLES[k] for k in kinds if k != "central")))
            home = os.path.join(tmp, name)
            os.makedirs(home)
            env, h5 = _environment(home), os.path.join(tmp, f"{name}.h5")
            cold = _run_scene(scene, h5, env)
            files = sum(len(f) for _, _, f in os.walk(home))
            warm = [_run_scene(scene, h5, env) for _ in range(warm_runs)]
            w = float(np.median(warm))
            out.append(
                {"effects": list(kinds), "cold_s": cold, "warm_s": w, "warm_samples_s": warm, "compile_s": cold - w,
                 "cache_files": files}
            )  # fmt: skip
    central = next((s["compile_s"] for s in out if s["effects"] == ["central"]), None)
    for s in out:
        if central is not None:
            s["compile_over_central_s"] = s["compile_s"] - central
    return {
        "case": "emorbit run SCENE -o OUT.h5 --overwrite -q: two points in LEO, 100 em steps, fresh process; "
        "cold: empty kernel cache (a new temporary folder), warm: the same cache filled",
        "sets": out,
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
        f"  {'scene':<30} {'cold CPU s':>11} {'cold s':>8} {'warm s':>8}",
    ]
    for r in sc["scenes"]:
        lines.append(f"  {r['scene']:<30} {r['cold_cpu_s']:>11.2f} {r['cold_s']:>8.2f} {r['warm_s']:>8.2f}")
    lines.append(f"  targets: cold compile <= {TARGET_COMPILE:g} s of CPU, warm start <= {TARGET_WARM:g} s per scene")
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
                "target": f"{r['scene']}: cold compile <= {TARGET_COMPILE:g} s of CPU",
                "measured": r["cold_cpu_s"],
                "limit": TARGET_COMPILE,
                "met": r["cold_cpu_s"] <= TARGET_COMPILE,
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
