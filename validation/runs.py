"""Trajectories of one case from emorbit, from REBOUND (IAS15, WHFast) and from the analytic
Kepler solution, all on the same record times and in the same form.

REBOUND integrates the case's particles as test particles (m = 0) around one massive body
of mass 1 with G = GM (so G m is GM to the last bit), placed at rest at the field's centre;
``N_active = 1`` keeps the test particles from acting on it, so it stays at the centre.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import astropy.units as u
import numpy as np

import emorbit
from emorbit import orbits
from emorbit.kernels import invariants

from .cases import Case

__all__ = ["Trajectory", "run_emorbit", "run_rebound", "analytic", "record_times"]


@dataclass
class Trajectory:
    """The states of all of a case's particles at the record times.

    Attributes
    ----------
    label : str
        The run's name (method, order, step).
    t : ndarray
        (m,) record times, s.
    x, v : ndarray
        (m, n, 3) positions (m) and velocities (m/s).
    wall : float
        Wall time of the run, s.
    info : dict
        The run's settings and counts (method, order, dt_s, steps, ...).
    """

    label: str
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    wall: float = 0.0
    info: dict = field(default_factory=dict)

    def head(self, m: int) -> Trajectory:
        """The first records.

        Parameters
        ----------
        m : int
            How many.

        Returns
        -------
        Trajectory
            The first ``m`` records.
        """
        return Trajectory(self.label, self.t[:m], self.x[:m], self.v[:m], self.wall, self.info)

    # -- invariants per particle ---------------------------------------------------------
    def energy(self, case: Case) -> np.ndarray:
        """The specific energy v^2/2 - GM/r per record and particle.

        Parameters
        ----------
        case : Case
            The case (GM and centre).

        Returns
        -------
        ndarray
            (m, n), J/kg.
        """
        ones = np.ones(1)
        return invariants.energy(ones, self.x[..., None], self.v[..., None], case.gm, case.center)

    def rel_energy_error(self, case: Case) -> np.ndarray:
        """The relative energy error |E - E0| / |E0| per record and particle.

        Parameters
        ----------
        case : Case
            The case (GM and centre).

        Returns
        -------
        ndarray
            (m, n).
        """
        e = self.energy(case)
        return np.abs(e - e[0]) / np.abs(e[0])

    def angular_momentum(self, case: Case) -> np.ndarray:
        """The specific angular momentum about the centre per record and particle.

        Parameters
        ----------
        case : Case
            The case (GM and centre).

        Returns
        -------
        ndarray
            (m, n, 3), m^2/s.
        """
        return np.cross(self.x - case.center, self.v)

    def rel_angular_momentum_error(self, case: Case) -> np.ndarray:
        """The relative angular-momentum error |L - L0| / |L0| per record and particle.

        Parameters
        ----------
        case : Case
            The case (GM and centre).

        Returns
        -------
        ndarray
            (m, n).
        """
        L = self.angular_momentum(case)
        return np.linalg.norm(L - L[0], axis=-1) / np.linalg.norm(L[0], axis=-1)

    def plane_tilt(self, case: Case) -> np.ndarray:
        """The angle between the orbit normal L/|L| now and at the start.

        Well conditioned at every inclination, unlike i and Omega.

        Parameters
        ----------
        case : Case
            The case (its centre).

        Returns
        -------
        ndarray
            (m, n), rad.
        """
        L = self.angular_momentum(case)
        return np.arctan2(np.linalg.norm(np.cross(L[0], L), axis=-1), np.einsum("...k,...k->...", L[0], L))

    def elements(self, case: Case) -> orbits.OrbitalElements:
        """The osculating elements per record and particle.

        Parameters
        ----------
        case : Case
            The case (GM and centre).

        Returns
        -------
        OrbitalElements
            (m, n), m and rad.
        """
        return orbits.elements(self.x, self.v, case.gm, case.center)

    def position_error(self, other: Trajectory, a: np.ndarray) -> np.ndarray:
        """The distance to another trajectory in units of a, per record and particle.

        Parameters
        ----------
        other : Trajectory
            Recorded at the same times (the shorter length is used).
        a : ndarray
            (n,) semi-major axes, m.

        Returns
        -------
        ndarray
            |x - x_other| / a, shape (m, n).
        """
        m = min(len(self.t), len(other.t))
        return np.linalg.norm(self.x[:m] - other.x[:m], axis=-1) / a


def record_times(case: Case, orbits_: int) -> np.ndarray:
    """The record times the runs and references share, start included.

    Parameters
    ----------
    case : Case
        The case.
    orbits_ : int
        Periods.

    Returns
    -------
    ndarray
        k * period / records for k = 0 .. orbits_ * records, s (computed as steps * dt, as
        emorbit counts time).
    """
    n = orbits_ * case.records
    every = case.steps // case.records
    dt = case.period / case.steps
    return np.arange(n + 1) * every * dt  # the same expression emorbit uses: steps * dt


def run_emorbit(
    case: Case,
    method: str,
    order: int,
    steps_per_period: int,
    periods: int,
    every: int,
    *,
    output=None,
    label: str | None = None,
) -> Trajectory:
    """Run emorbit through its public API, astropy quantities at the edge.

    Parameters
    ----------
    case : Case
        The case.
    method : str
        A name of :data:`emorbit.METHODS`.
    order : int
        The composition's order.
    steps_per_period : int
        dt = period / steps_per_period.
    periods : int
        Periods to run.
    every : int
        Steps between records.
    output : str, optional
        An HDF5 file to write.
    label : str, optional
        The trajectory's label.

    Returns
    -------
    Trajectory
        The records, with the run's settings, Newton iterations and cost in ``info``.

    Raises
    ------
    IntegrationError
        A step failed.
    """
    dt = case.period / steps_per_period
    field_ = (
        emorbit.CentralField(body=case.field_body)
        if case.field_body
        else emorbit.CentralField(gm=case.gm * u.m**3 / u.s**2, center=case.center * u.m)
    )
    if field_.gm != case.gm:  # cannot happen: the case takes GM from the same astropy constant
        raise RuntimeError(f"field GM {field_.gm!r} differs from the case's {case.gm!r}")
    sim = emorbit.Simulation(field_, method=method, order=order, dt=dt * u.s)
    for name, x, v in zip(case.names, case.x0, case.v0):
        sim.add_point(name, mass=1.0 * u.kg, position=x * u.m, velocity=v * u.m / u.s)
    steps = steps_per_period * periods
    start = time.perf_counter()
    res = sim.run(steps=steps, every=every, output=output, overwrite=True, progress=False).si  # plain SI arrays
    wall = time.perf_counter() - start
    x = np.stack([res.positions[n] for n in case.names], axis=1)
    v = np.stack([res.velocities[n] for n in case.names], axis=1)
    substeps = steps * len(emorbit.integrators.coefficients(order))
    return Trajectory(
        label or f"{method} {order}",
        res.time,
        x,
        v,
        wall,
        {
            "method": method,
            "order": order,
            "dt_s": dt,
            "steps": steps,
            "substeps": substeps,
            "orbits": periods,
            "newton_iterations": res.mean_newton_iterations(),
            "ns_per_particle_substep": 1e9 * wall / (substeps * case.n),
        },
    )


def run_rebound(case: Case, integrator: str, times: np.ndarray) -> Trajectory:
    """Run REBOUND with its default settings for an integrator, sampled at given times.

    IAS15 (adaptive, epsilon 1e-9) lands on each time exactly (``exact_finish_time``). WHFast
    (Jacobi coordinates, safe mode) takes one step per record interval; its record time is
    k * dt, not ``sim.t``: REBOUND advances its clock by adding dt, whose rounding grows with
    the steps, an error of the clock and not of the integrator.

    Parameters
    ----------
    case : Case
        The case.
    integrator : str
        ``"ias15"`` or ``"whfast"``.
    times : ndarray
        Record times, s.

    Returns
    -------
    Trajectory
        The records; ``info`` holds the steps, the central body's displacement and, for
        WHFast, the clock's drift.
    """
    import rebound

    sim = rebound.Simulation()
    sim.G = case.gm
    c = case.center
    sim.add(m=1.0, x=c[0], y=c[1], z=c[2])
    for x, v in zip(case.x0, case.v0):
        sim.add(m=0.0, x=x[0], y=x[1], z=x[2], vx=v[0], vy=v[1], vz=v[2])
    sim.N_active = 1
    sim.integrator = integrator
    if integrator == "whfast":
        sim.dt = float(times[1] - times[0])
    m = len(times)
    xs = np.empty((m, case.n, 3))
    vs = np.empty((m, case.n, 3))
    ts = np.empty(m)
    bx = np.empty((case.n + 1, 3))
    bv = np.empty((case.n + 1, 3))
    start = time.perf_counter()
    for k, t in enumerate(times):
        if k:
            if integrator == "whfast":
                sim.steps(1)
            else:
                sim.integrate(float(t))
        sim.serialize_particle_data(xyz=bx, vxvyvz=bv)
        xs[k] = bx[1:]
        vs[k] = bv[1:]
        ts[k] = sim.t
    wall = time.perf_counter() - start
    info = {
        "steps": int(sim.steps_done),
        "central_body_displacement_m": float(np.linalg.norm(bx[0] - c)),
        "ns_per_particle_step": 1e9 * wall / max(1, sim.steps_done * case.n),
    }
    if integrator == "whfast":
        clock = np.arange(m) * sim.dt
        info["clock_drift_s"] = float(np.abs(ts - clock).max())
        ts = clock
    return Trajectory(integrator.upper(), ts, xs, vs, wall, info)


def analytic(case: Case, times: np.ndarray) -> Trajectory:
    """The exact Kepler motion of every particle at given times.

    By :func:`emorbit.orbits.propagate` (universal variables, Kepler's equation solved by
    Newton's method to round-off).

    Parameters
    ----------
    case : Case
        The case.
    times : array_like
        Times, s.

    Returns
    -------
    Trajectory
        Labelled ``"Kepler"``.
    """
    start = time.perf_counter()
    x, v = orbits.propagate(case.x0[None], case.v0[None], case.gm, np.asarray(times, float)[:, None], case.center)
    return Trajectory("Kepler", np.asarray(times, float), x, v, time.perf_counter() - start)
