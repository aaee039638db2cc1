"""What the point-mass sections of the bench share: configurations, the cases, and runners
for emorbit and REBOUND that take ``n`` steps and return (wall, CPU) seconds.

The runners are timed by :mod:`emorbit.bench.timing`: a warm-up call, calls calibrated to a
fixed length, the engines of one comparison interleaved repeat by repeat, medians; ratios
are medians of the per-repeat ratios, so that load from other processes hits both sides.
The cases: the paper's orbit (GM = 3.9478 m^3/s^2, from aphelion r = 10 m at 0.36276 m/s,
dt = T/100) and an ensemble of test particles (:func:`ensemble_states`, dt = T/1000 of a
6 m orbit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..bodies.pointmasses import PointMasses
from ..integrators import coefficients, dispatch
from ..orbits import kepler_period, semi_major_axis, solve_kepler, state_from_elements
from .timing import clock, package_version, since

__all__ = [
    "GM",
    "PAPER_X0",
    "PAPER_V0",
    "PAPER_DT",
    "ENSEMBLE_DT",
    "Config",
    "CONFIGS",
    "ensemble_states",
    "aphelion_state",
    "period",
    "energies",
    "point_masses",
    "EmorbitRunner",
    "KernelRunner",
    "rebound_sim",
    "rebound_state",
    "ReboundRunner",
    "versions",
    "numba_threads",
    "MAX_ITER",
    "points_of",
    "SystemRunner",
]

#: Newton iterations allowed per sub-step in the timed runs
MAX_ITER = 50

#: the paper's orbit (Goettlicher & Schweizerhof): GM, start at aphelion
GM = 3.9478
PAPER_X0 = np.array([10.0, 0.0, 0.0])
PAPER_V0 = np.array([0.0, 0.36276, 0.0])
#: the paper's step: its period 46.4758 s / 100
PAPER_DT = 0.464758
#: the ensemble's step: T/1000 of a 6 m orbit
ENSEMBLE_DT = 2 * math.pi * math.sqrt(6.0**3 / GM) / 1000


@dataclass(frozen=True)
class Config:
    """How long and how often the point-mass sections measure (see :data:`CONFIGS`)."""

    repeat_s: float  # wall time aimed at per timed call
    repeats: int
    ensemble_n: int  # test particles
    orbits: int  # length of the work-precision runs
    divisions: tuple  # steps per orbit of the work-precision runs (paper's orbit)
    divisions_e09: tuple  # the same for the e = 0.9 orbit
    divisions_e099: tuple  # the same for the e = 0.99 orbit
    ias15_eps: tuple
    heyoka_tol: tuple
    warm_runs: int  # repeats of the warm start-up
    adaptive_orders: tuple = (2, 4, 6, 8)  # em with adaptive steps in the work-precision runs
    tfe_adaptive_orders: tuple = (4, 6, 8, 10, 12)  # and tfe with adaptive steps
    #: the adaptive steps' knob: h = eta 2 pi sqrt(r^3 / GM), a fraction of the local Kepler time scale
    adaptive_eta: tuple = (0.08, 0.06, 0.05, 0.04, 0.03, 0.02, 0.0125, 0.008, 0.005, 0.003)


#: "full", "quick" (``emorbit bench --quick``) and "tiny"
CONFIGS = {
    "full": Config(
        repeat_s=0.2,
        repeats=9,
        ensemble_n=100_000,
        orbits=100,
        divisions=(25, 35, 50, 71, 100, 141, 200, 283, 400, 566, 800, 1131, 1600, 2263, 3200),
        divisions_e09=(100, 141, 200, 283, 400, 566, 800, 1131, 1600, 2263, 3200, 4525, 6400, 9051, 12800),
        divisions_e099=(1600, 2263, 3200, 4525, 6400, 9051, 12800, 18102, 25600, 36204, 51200, 72408, 102400),
        ias15_eps=(1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10),
        heyoka_tol=(1e-6, 1e-8, 1e-10, 1e-12, 1e-14, 2.220446049250313e-16),
        warm_runs=5,
    ),
    "quick": Config(
        repeat_s=0.06,
        repeats=5,
        ensemble_n=100_000,
        orbits=100,
        divisions=(25, 50, 100, 200, 400, 800, 1600),
        divisions_e09=(100, 200, 400, 800, 1600, 3200, 6400, 12800),
        divisions_e099=(3200, 12800, 51200),
        ias15_eps=(1e-3, 1e-5, 1e-7, 1e-9),
        heyoka_tol=(1e-6, 1e-9, 1e-12, 2.220446049250313e-16),
        warm_runs=3,
        tfe_adaptive_orders=(8, 10, 12),
        adaptive_eta=(0.08, 0.06, 0.05, 0.04, 0.03, 0.02, 0.008, 0.003),
    ),
    # a seconds-long smoke run for the tests: its timings mean nothing
    "tiny": Config(
        repeat_s=0.005,
        repeats=2,
        ensemble_n=2_000,
        orbits=2,
        divisions=(50, 100),
        divisions_e09=(200, 400),
        divisions_e099=(3200,),
        ias15_eps=(1e-9,),
        heyoka_tol=(1e-9,),
        warm_runs=1,
        adaptive_orders=(4, 8),
        tfe_adaptive_orders=(6,),
        adaptive_eta=(0.02, 0.008),
    ),
}


def ensemble_states(n: int, seed: int = 1, a=(5.0, 10.0), e=(0.0, 0.9), gm: float = GM):
    """The bench's ensemble of test particles: by default around GM = 3.9478 m^3/s^2.

    a uniform in [5, 10] m, e uniform in [0, 0.9], isotropic planes (cos i, node and argument
    of pericentre uniform), time-uniform phases (mean anomaly uniform).

    Parameters
    ----------
    n : int
        Number of particles.
    seed : int
        Seed of numpy's default generator.
    a, e : tuple of float
        The ranges of the semi-major axis (m) and the eccentricity.
    gm : float
        GM of the centre, m^3/s^2.

    Returns
    -------
    x, v : ndarray
        (3, n) positions (m) and velocities (m/s), C-contiguous.
    """
    rng = np.random.default_rng(seed)
    a = rng.uniform(*a, n)
    e = rng.uniform(*e, n)
    inc = np.arccos(rng.uniform(-1.0, 1.0, n))
    raan, argp, M = (rng.uniform(0.0, 2 * np.pi, n) for _ in range(3))
    E = solve_kepler(M, e)
    nu = 2 * np.arctan2(np.sqrt(1 + e) * np.sin(E / 2), np.sqrt(1 - e) * np.cos(E / 2))
    x, v = state_from_elements((a, e, inc, raan, argp, nu), gm)
    return np.ascontiguousarray(x.T), np.ascontiguousarray(v.T)


def aphelion_state(a: float, e: float):
    """The state at aphelion on the x axis, moving along +y, of an orbit around GM.

    Parameters
    ----------
    a : float
        Semi-major axis, m.
    e : float
        Eccentricity.

    Returns
    -------
    x0, v0 : ndarray
        (3,) position (m) and velocity (m/s).
    """
    ra = a * (1 + e)
    return np.array([ra, 0.0, 0.0]), np.array([0.0, math.sqrt(GM * (1 - e) / ra), 0.0])


def period(x0, v0) -> float:
    """The Kepler period of the orbit through a state, around GM.

    Parameters
    ----------
    x0, v0 : array_like
        (3,) position (m) and velocity (m/s).

    Returns
    -------
    float
        s.
    """
    return float(kepler_period(semi_major_axis(x0, v0, GM), GM))


def energies(x, v):
    """The specific energy v^2/2 - GM/r of each point, J/kg.

    Parameters
    ----------
    x, v : ndarray
        (..., 3, n) positions (m) and velocities (m/s), summed over the axis of length 3.

    Returns
    -------
    ndarray
        (..., n).
    """
    return 0.5 * np.einsum("...kn,...kn->...n", v, v) - GM / np.sqrt(np.einsum("...kn,...kn->...n", x, x))


def point_masses(x, v) -> PointMasses:
    """A :class:`~emorbit.bodies.pointmasses.PointMasses` holding given states, of unit masses.

    Parameters
    ----------
    x, v : ndarray
        (3, n) positions (m) and velocities (m/s).

    Returns
    -------
    PointMasses
        Points named ``p0``, ``p1``, ..., with zero compensation terms.
    """
    pm = PointMasses()
    n = x.shape[1]
    pm.names = [f"p{i}" for i in range(n)]
    pm.masses = np.ones(n)
    pm.x, pm.v = np.array(x, float, order="C"), np.array(v, float, order="C")
    pm.cx, pm.cv = np.zeros_like(pm.x), np.zeros_like(pm.v)
    return pm


class EmorbitRunner:
    """``n`` steps of one method and order through ``PointMasses.advance``, the scene's path.

    Each call takes ``n`` steps with one record at the end and returns (wall, CPU) seconds;
    the state carries over between calls.

    Parameters
    ----------
    x, v : ndarray
        (3, n) initial positions (m) and velocities (m/s).
    method : str
        A name in :data:`emorbit.METHODS`.
    order : int
        The composition's order.
    dt : float
        The step, s.
    max_iter : int
        Newton iterations per sub-step at most.
    roundoff : str
        ``"brouwer"`` or ``"fast"``.
    """

    def __init__(self, x, v, method: str, order: int, dt: float, max_iter: int = 50, roundoff: str = "brouwer"):
        self.pm = point_masses(x, v)
        self.pm.plan = self.pm.plan.with_(roundoff=roundoff)
        self.method, self.gammas, self.dt, self.max_iter = method, coefficients(order), dt, max_iter
        self.iterations = []
        self.steps = 0

    def __call__(self, n: int) -> tuple:
        start = clock()
        rec = self.pm.advance(self.method, GM, np.zeros(3), self.dt, self.gammas, n, 1, self.max_iter)
        elapsed = since(start)
        if rec.first_failure() is not None:
            raise RuntimeError(f"emorbit {self.method}: a step failed {rec.first_failure()}")
        self.steps += n
        self.iterations.append(float(rec.iterations.mean()) / (n * self.gammas.size))
        return elapsed


class KernelRunner:
    """``n`` steps of the bare packed kernel (:mod:`emorbit.kernels.pointmass.packed`).

    Each call takes ``n`` steps with one record and returns (wall, CPU) seconds; the state
    carries over between calls.

    Parameters
    ----------
    x, v : ndarray
        (3, n) initial positions (m) and velocities (m/s).
    method : str
        A name in :data:`emorbit.METHODS`.
    order : int
        The composition's order.
    dt : float
        The step, s.
    parallel : bool
        The kernel on all of Numba's threads, or on one.
    roundoff : str
        ``"brouwer"`` or ``"fast"``.
    """

    def __init__(self, x, v, method: str, order: int, dt: float, parallel: bool, roundoff: str = "brouwer"):
        self.x, self.v = np.array(x, float, order="C"), np.array(v, float, order="C")
        self.cx, self.cv = np.zeros_like(self.x), np.zeros_like(self.v)
        self.gammas, self.dt = coefficients(order), dt
        self.method, self.kernel = dispatch.point_chunk(method, roundoff, "cpu", parallel=parallel)
        self.steps = 0

    def __call__(self, n: int) -> tuple:
        m = self.x.shape[1]
        rx, rv = np.empty((1, 3, m)), np.empty((1, 3, m))
        its, fail = np.zeros((1, m), np.int64), np.full((m, 2), -1, np.int64)
        start = clock()
        self.kernel(
            self.method,
            self.x,
            self.v,
            self.cx,
            self.cv,
            GM,
            np.zeros(3),
            self.dt,
            self.gammas,
            n,
            1,
            50,
            rx,
            rv,
            its,
            fail,
        )
        elapsed = since(start)
        if np.any(fail[:, 0] >= 0):
            raise RuntimeError("emorbit kernel: a step failed")
        self.steps += n
        return elapsed


def rebound_sim(x, v, integrator: str, dt: float | None = None, epsilon: float | None = None):
    """A REBOUND simulation of test particles around a central mass GM at the origin.

    G = 1, the central mass is GM, the particles have m = 0 and N_active = 1. WHFast runs
    without safe mode (no synchronisation between steps), as for a production run.

    Parameters
    ----------
    x, v : ndarray
        (3, n) positions (m) and velocities (m/s).
    integrator : str
        REBOUND's integrator name (``"leapfrog"``, ``"whfast"``, ``"ias15"``).
    dt : float, optional
        The step (IAS15's first step), s.
    epsilon : float, optional
        IAS15's precision parameter.

    Returns
    -------
    rebound.Simulation
        Ready to step.
    """
    import rebound

    n = x.shape[1]
    sim = rebound.Simulation()
    sim.G = 1.0
    sim.add(m=GM)
    p = rebound.Particle(m=0.0, x=1.0)
    for _ in range(n):
        sim.add(p)
    xyz = np.zeros((n + 1, 3))
    vel = np.zeros((n + 1, 3))
    xyz[1:] = x.T
    vel[1:] = v.T
    sim.set_serialized_particle_data(xyz=xyz, vxvyvz=vel)
    sim.N_active = 1
    sim.integrator = integrator
    if dt is not None:
        sim.dt = dt
    if integrator == "whfast":
        sim.integrator.safe_mode = 0
    if epsilon is not None:
        sim.integrator.epsilon = epsilon
    return sim


def rebound_state(sim):
    """The test particles' states of a REBOUND simulation, synchronised first.

    Parameters
    ----------
    sim : rebound.Simulation
        Made by :func:`rebound_sim` (WHFast without safe mode keeps its own coordinates
        between steps, hence the synchronisation).

    Returns
    -------
    x, v : ndarray
        (3, n) positions (m) and velocities (m/s) relative to the central mass.
    """
    sim.synchronize()
    n = sim.N - 1
    xyz, vel = np.empty((n + 1, 3)), np.empty((n + 1, 3))
    sim.serialize_particle_data(xyz=xyz, vxvyvz=vel)
    return np.ascontiguousarray((xyz[1:] - xyz[0]).T), np.ascontiguousarray((vel[1:] - vel[0]).T)


class ReboundRunner:
    """``n`` steps of a REBOUND simulation per call, returning (wall, CPU) seconds.

    Parameters
    ----------
    sim : rebound.Simulation
        Made by :func:`rebound_sim`; fixed-step integrators take ``n`` steps of dt, IAS15
        ``n`` of its own.
    """

    def __init__(self, sim):
        self.sim = sim
        self.steps = 0

    def __call__(self, n: int) -> tuple:
        start = clock()
        self.sim.steps(n)
        elapsed = since(start)
        self.steps += n
        return elapsed


def versions() -> dict:
    """The versions of emorbit and of the packages the bench uses.

    Returns
    -------
    dict
        {package: version, or None where it is not installed}.
    """
    import numba

    from .._version import __version__

    return {
        "emorbit": __version__,
        "numba": numba.__version__,
        "numpy": np.__version__,
        "rebound": package_version("rebound"),
        "heyoka": package_version("heyoka"),
        "llvmlite": package_version("llvmlite"),
        "scipy": package_version("scipy"),
        "matplotlib": package_version("matplotlib"),
    }


def numba_threads() -> dict:
    """Numba's thread count and threading layer.

    Returns
    -------
    dict
        ``threads`` and ``threading_layer`` (None until a parallel kernel has run).
    """
    import numba

    return {"threads": numba.get_num_threads(), "threading_layer": _threading_layer()}


def _threading_layer():
    import numba

    try:
        return numba.threading_layer()
    except ValueError:  # not initialised: no parallel kernel has run yet
        return None


def points_of(sim, x, v):
    """Put point masses of unit mass at (x, v) into ``sim``, under its effects."""
    pm = point_masses(x, v)
    pm.effects, pm.plan = sim.points.effects, sim.plan
    sim.points = pm
    return pm


class SystemRunner:
    """``n`` em steps of a body system (its ``advance``) per call: (wall, CPU) seconds."""

    def __init__(self, points, gm: float, center, dt: float):
        from ..integrators import coefficients

        self.points, self.gm, self.center, self.dt = points, gm, np.asarray(center, float), dt
        self.gammas = coefficients(2)
        self.steps = 0
        self.sweeps = []

    def __call__(self, n: int) -> tuple:
        start = clock()
        rec = self.points.advance("em", self.gm, self.center, self.dt, self.gammas, n, 1, MAX_ITER)
        elapsed = since(start)
        if rec.first_failure() is not None:
            raise RuntimeError(f"emorbit {type(self.points).__name__}: a step failed {rec.first_failure()}")
        self.steps += n
        self.sweeps.append(float(rec.iterations.mean()) / (n * self.gammas.size))
        return elapsed
