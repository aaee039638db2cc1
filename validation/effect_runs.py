"""Trajectories of the effect cases: emorbit with its effects, REBOUND IAS15 (with REBOUNDx's
``gravitational_harmonics`` for zonal harmonics) and the analytic two-body solution, all on
the same record times, with the invariants each needs.

Zonal cases: REBOUND integrates the satellites as test particles (m = 0) around one body of
mass 1 with G = GM at the origin, ``N_active = 1``; REBOUNDx's ``gravitational_harmonics``
reads ``J2``, ``J4`` and ``R_eq`` on that body (its pole ``Omega`` defaults to z). The
energy of both codes is computed per unit mass with the zonal potential in emorbit's and
REBOUNDx's sign convention::

    E = v^2 / 2 - GM / r + (GM / r) sum_n J_n (R / r)^n P_n(z / r)

(REBOUND's own ``energy()`` leaves out test particles and REBOUNDx's potential). Mutual
cases: REBOUND integrates the same bodies with G from astropy (CODATA), the value emorbit's
mutual gravity uses; its ``energy()`` is the total.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import astropy.units as u
import numpy as np

import emorbit
from emorbit import orbits
from emorbit.effects.mutual import G

from .effect_cases import EffectCase

__all__ = [
    "EffectTrajectory",
    "effect_record_times",
    "run_em",
    "run_ias15",
    "zonal_potential",
    "zonal_energy",
    "two_body_analytic",
    "reboundx_potential",
    "require_reboundx",
    "reboundx_missing",
    "kepler_test_particles",
]


@dataclass
class EffectTrajectory:
    """States and invariants of every body at the record times.

    Attributes
    ----------
    label : str
        The run's name.
    t : ndarray
        (m,) s.
    x, v : ndarray
        (m, n, 3) m and m/s.
    energy : ndarray
        (m,) total energy, J (per unit mass summed over the bodies for REBOUND's test
        particles, which is the same for emorbit's 1 kg satellites).
    momentum, angular_momentum : ndarray
        (m, 3) total linear momentum (kg m/s) and angular momentum about the origin
        (kg m^2/s).
    wall : float
        Wall time, s.
    info : dict
        Settings and counts (method, order, dt_s, steps, ...).
    result : Result or None
        emorbit's own :class:`~emorbit.result.Result` of the run (None for the referees).
    """

    label: str
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    energy: np.ndarray
    momentum: np.ndarray
    angular_momentum: np.ndarray
    wall: float = 0.0
    info: dict = field(default_factory=dict)
    result: object = None

    def rel_energy_error(self) -> np.ndarray:
        """|E - E0| / |E0| per record."""
        return np.abs(self.energy - self.energy[0]) / abs(self.energy[0])

    def position_error(self, other: EffectTrajectory, length: float) -> np.ndarray:
        """max over bodies of |x - x_other| / length, per record (the shorter run's records).

        Parameters
        ----------
        other : EffectTrajectory
            Recorded at the same times.
        length : float
            m.

        Returns
        -------
        ndarray
            (m,).
        """
        m = min(len(self.t), len(other.t))
        return np.linalg.norm(self.x[:m] - other.x[:m], axis=-1).max(axis=1) / length


def effect_record_times(case: EffectCase, periods: int) -> np.ndarray:
    """The shared record times: k * period / records, k = 0 .. periods * records, s.

    Computed as emorbit counts time (steps * dt) at the case's first order-2 step.

    Parameters
    ----------
    case : EffectCase
        The case.
    periods : int
        Periods.

    Returns
    -------
    ndarray
        s.
    """
    n = case.main[2]
    return np.arange(periods * case.records + 1) * (n // case.records) * (case.period / n)


def _scales(masses, x, v):
    """Sum of m |v| and of m |x| |v| at the start: the sizes of what cancels in P and L."""
    p = float(np.sum(masses * np.linalg.norm(v[0], axis=-1)))
    l = float(np.sum(masses * np.linalg.norm(x[0], axis=-1) * np.linalg.norm(v[0], axis=-1)))
    return p, l


def run_em(
    case: EffectCase, order: int, steps_per_period: int, periods: int, *, zonal=None, label=None, method="em"
) -> EffectTrajectory:
    """Run emorbit's em method (or ``method``) with the case's effects, through the public API.

    Parameters
    ----------
    case : EffectCase
        The case.
    order : int
        The composition's order.
    steps_per_period : int
        dt = period / steps_per_period (a multiple of ``case.records``).
    periods : int
        Periods to run.
    zonal : dict, optional
        Keys of the zonal effect instead of ``case.zonal``.
    label : str, optional
        The trajectory's label.
    method : str
        The method (``"em"``; ``"tfe"``, whose step is one solve at every order).

    Returns
    -------
    EffectTrajectory
        Records at every period / records; ``info`` holds the settings, Newton iterations
        and the P and L scales (sums of m |v| and m |x| |v|).
    """
    dt = case.period / steps_per_period
    if case.kind == "zonal":
        field_ = emorbit.CentralField(body="earth")
        if field_.gm != case.gm:  # the case takes GM from the same field
            raise RuntimeError(f"field GM {field_.gm!r} differs from the case's {case.gm!r}")
        sim = emorbit.Simulation(field_, method=method, order=order, dt=dt * u.s)
        sim.add_effect("zonal", **(zonal or case.zonal))
    else:
        sim = emorbit.Simulation(None, method=method, order=order, dt=dt * u.s)
        sim.add_effect("mutual")
    for name, m, x, v in case.bodies:
        sim.add_point(name, mass=m * u.kg, position=np.asarray(x) * u.m, velocity=np.asarray(v) * u.m / u.s)
    steps = steps_per_period * periods
    start = time.perf_counter()
    result = sim.run(steps=steps, every=steps_per_period // case.records, progress=False)
    wall = time.perf_counter() - start
    res = result.si
    x = np.stack([res.positions[n] for n in case.names], axis=1)
    v = np.stack([res.velocities[n] for n in case.names], axis=1)
    substeps = steps * emorbit.integrators.get_method(method).solves_per_step(order)
    p_scale, l_scale = _scales(case.masses, x, v)
    return EffectTrajectory(
        label or f"{method} {order}, dt = T/{steps_per_period}",
        res.time,
        x,
        v,
        res.energy,
        res.momentum,
        res.angular_momentum,
        wall,
        {
            "method": method,
            "order": order,
            "dt_s": dt,
            "steps_per_period": steps_per_period,
            "steps": steps,
            "substeps": substeps,
            "orbits": periods,
            "newton_iterations": res.mean_newton_iterations(),
            "ns_per_particle_substep": 1e9 * wall / (substeps * len(case.bodies)),
            "momentum_scale": p_scale,
            "angular_momentum_scale": l_scale,
        },
        result,
    )


def require_reboundx():
    """Import reboundx, or say how to install it.

    Returns
    -------
    module
        reboundx.

    Raises
    ------
    RuntimeError
        reboundx is not installed.
    """
    try:
        import reboundx
    except ImportError as exc:
        raise RuntimeError(
            "this case needs REBOUNDx (the J2 referee): pip install reboundx, or pip install 'emorbit[validation]'"
        ) from exc
    return reboundx


def reboundx_missing() -> str:
    """'' when REBOUNDx imports, else why its checks are skipped.

    Returns
    -------
    str
        ``""``, or ``"skipped: REBOUNDx not installed; pip install 'emorbit[validation]'"``.
    """
    try:
        require_reboundx()
    except RuntimeError:
        return "skipped: REBOUNDx not installed; pip install 'emorbit[validation]'"
    return ""


def zonal_potential(x, gm: float, harmonics: dict) -> np.ndarray:
    """The zonal potential per unit mass, (GM / r) sum_n J_n (R / r)^n P_n(z / r), pole z.

    Parameters
    ----------
    x : ndarray
        (..., 3) positions relative to the centre, m.
    gm : float
        GM, m^3/s^2.
    harmonics : dict
        ``J2`` and optionally ``J4`` (REBOUNDx's names), ``R_eq`` (m).

    Returns
    -------
    ndarray
        (...), J/kg.
    """
    r = np.linalg.norm(x, axis=-1)
    s = x[..., 2] / r
    R = harmonics["R_eq"]
    coef = np.zeros(5)
    coef[2] = harmonics.get("J2", 0.0)
    coef[4] = harmonics.get("J4", 0.0)
    terms = sum(coef[n] * (R / r) ** n * np.polynomial.legendre.legval(s, np.eye(5)[n]) for n in (2, 4))
    return gm / r * terms


def zonal_energy(x, v, gm: float, harmonics: dict) -> np.ndarray:
    """Total energy per unit mass of test particles in the field with zonal harmonics.

    Parameters
    ----------
    x, v : ndarray
        (m, n, 3) m and m/s.
    gm : float
        GM, m^3/s^2.
    harmonics : dict
        As :func:`zonal_potential`.

    Returns
    -------
    ndarray
        (m,) the sum over the particles of v^2/2 - GM/r + V_zonal, J/kg.
    """
    r = np.linalg.norm(x, axis=-1)
    e = 0.5 * np.einsum("mnk,mnk->mn", v, v) - gm / r + zonal_potential(x, gm, harmonics)
    return e.sum(axis=1)


def reboundx_potential(x, gm: float, harmonics: dict) -> float:
    """REBOUNDx's own zonal potential energy (``gravitational_harmonics_potential``) per unit
    mass of a body at x, for comparison with :func:`zonal_potential`.

    Parameters
    ----------
    x : array_like
        (3,) position relative to the centre, m.
    gm : float
        GM, m^3/s^2.
    harmonics : dict
        REBOUNDx's particle parameters.

    Returns
    -------
    float
        J/kg.
    """
    import rebound

    reboundx = require_reboundx()
    sim = rebound.Simulation()
    sim.G = gm
    sim.add(m=1.0)
    sim.add(m=1.0, x=x[0], y=x[1], z=x[2])  # its potential is G m0 m1 (...), so m1 = 1: per unit mass
    rebx = reboundx.Extras(sim)
    rebx.add_force(rebx.load_force("gravitational_harmonics"))
    for k, value in harmonics.items():
        sim.particles[0].params[k] = value
    # the satellite's own J2 is unset, so only the central body's harmonics act on it
    return float(rebx.gravitational_harmonics_potential())


def run_ias15(case: EffectCase, times, *, harmonics=None, epsilon=None, label="IAS15") -> EffectTrajectory:
    """Run REBOUND's IAS15 on the case's bodies, sampled at given times.

    Parameters
    ----------
    case : EffectCase
        The case.
    times : ndarray
        Record times, s (IAS15 lands on each exactly).
    harmonics : dict, optional
        Zonal cases: REBOUNDx's parameters of the central body (default ``case.harmonics``;
        ``{}``: no harmonics, REBOUNDx not loaded).
    epsilon : float, optional
        IAS15's accuracy parameter (default: REBOUND's, 1e-9).
    label : str
        The trajectory's label.

    Returns
    -------
    EffectTrajectory
        The records; ``info`` holds the steps and epsilon.
    """
    import rebound

    harmonics = case.harmonics if harmonics is None else harmonics
    sim = rebound.Simulation()
    zonal = case.kind == "zonal"
    if zonal:
        sim.G = case.gm
        sim.add(m=1.0)
        for _, _, x, v in case.bodies:
            sim.add(m=0.0, x=x[0], y=x[1], z=x[2], vx=v[0], vy=v[1], vz=v[2])
        sim.N_active = 1
    else:
        sim.G = G
        for _, m, x, v in case.bodies:
            sim.add(m=m, x=x[0], y=x[1], z=x[2], vx=v[0], vy=v[1], vz=v[2])
    sim.integrator = "ias15"
    config = getattr(sim, "ri_ias15", None) or sim.integrator  # REBOUND 4: sim.ri_ias15; 5: sim.integrator
    if epsilon is not None:
        config.epsilon = epsilon
    if zonal and harmonics:
        reboundx = require_reboundx()
        rebx = reboundx.Extras(sim)
        rebx.add_force(rebx.load_force("gravitational_harmonics"))
        for k, value in harmonics.items():
            sim.particles[0].params[k] = value
    off = 1 if zonal else 0
    nb = len(case.bodies)
    m = len(times)
    xs, vs, energy = np.empty((m, nb, 3)), np.empty((m, nb, 3)), np.empty(m)
    bx, bv = np.empty((nb + off, 3)), np.empty((nb + off, 3))
    start = time.perf_counter()
    for k, t in enumerate(times):
        if k:
            sim.integrate(float(t))
        sim.serialize_particle_data(xyz=bx, vxvyvz=bv)
        xs[k], vs[k] = bx[off:], bv[off:]
        if not zonal:
            energy[k] = sim.energy()
    wall = time.perf_counter() - start
    masses = np.ones(nb) if zonal else case.masses
    if zonal:
        energy = zonal_energy(xs, vs, case.gm, harmonics or {"R_eq": 1.0})
    momentum = np.einsum("n,mnk->mk", masses, vs)
    angular = np.einsum("n,mnk->mk", masses, np.cross(xs, vs))
    p_scale, l_scale = _scales(masses, xs, vs)
    info = {
        "steps": int(sim.steps_done),
        "epsilon": float(config.epsilon),
        "momentum_scale": p_scale,
        "angular_momentum_scale": l_scale,
        "ns_per_particle_step": 1e9 * wall / max(1, sim.steps_done * nb),
    }
    return EffectTrajectory(label, np.asarray(times, float), xs, vs, energy, momentum, angular, wall, info)


def two_body_analytic(case: EffectCase, times) -> EffectTrajectory:
    """The exact motion of the two-body case: Kepler's relative orbit, uniform centre of mass.

    x1 = X0 + V0 t + m2 / M r(t), x2 = X0 + V0 t - m1 / M r(t), r(t) from
    :func:`emorbit.orbits.propagate` with GM = G (m1 + m2).

    Parameters
    ----------
    case : EffectCase
        The two-body case.
    times : array_like
        s.

    Returns
    -------
    EffectTrajectory
        Labelled ``"Kepler"``; its invariants are those of the initial state.
    """
    ex = case.extra
    t = np.asarray(times, float)
    start = time.perf_counter()
    r, w = orbits.propagate(ex["r0"], ex["w0"], ex["gm"], t)
    X = ex["X0"] + ex["V0"] * t[:, None]
    f = np.asarray(ex["fractions"])
    x = X[:, None, :] + f[None, :, None] * r[:, None, :]
    v = ex["V0"][None, None, :] + f[None, :, None] * w[:, None, :]
    zeros = np.zeros((len(t), 3))
    return EffectTrajectory("Kepler", t, x, v, np.zeros(len(t)), zeros, zeros, time.perf_counter() - start)


def kepler_test_particles(case: EffectCase, times) -> EffectTrajectory:
    """The exact Kepler motion of a zonal case's satellites without the harmonics.

    Parameters
    ----------
    case : EffectCase
        A zonal case.
    times : array_like
        s.

    Returns
    -------
    EffectTrajectory
        Labelled ``"Kepler"``; energies per unit mass, summed over the satellites.
    """
    t = np.asarray(times, float)
    start = time.perf_counter()
    x, v = orbits.propagate(case.x0[None], case.v0[None], case.gm, t[:, None])
    energy = zonal_energy(x, v, case.gm, {"R_eq": 1.0})
    zeros = np.zeros((len(t), 3))
    return EffectTrajectory("Kepler", t, x, v, energy, zeros, zeros, time.perf_counter() - start)
