"""Trajectories of the perturbation cases: emorbit's em method through its public API, REBOUND's
IAS15 with the reference force model in ``additional_forces``, and the unperturbed Kepler orbit,
on the same record times, each with its energy balance.

REBOUND: one body of mass 1 with ``G = GM`` at the origin and the satellite as a test particle
(``m = 0``, ``N_active = 1``), so the Earth stays at the origin and the frame is emorbit's
geocentric one; the third bodies' indirect term is part of their acceleration. A second test
particle integrates the work: ``additional_forces`` sets its acceleration to ``C + P(t)`` (P the
power of :meth:`~.perturbation_model.ReferenceModel.evaluate`, C = 1 W/kg), so its velocity is
``C t + W(t)`` on IAS15's own quadrature; the constant keeps its acceleration away from zero and
its relative variation small, so that it never drives IAS15's step control (the power has the
shadow's ``delta^(3/2)`` contacts and vanishes in the umbra). The energy per unit mass is
``E = v^2 / 2 - GM / |x| + U(x, t)`` (U the third bodies' tidal potential) and the balance
``(E - E0 - W) / |E0|``.

With the conical shadow IAS15 stops at the shadow's contacts (:meth:`ReferenceModel.contacts`,
looked up an hour ahead from the current state) and at ``t_c +- 64 s 2^-k``, k = 0..8: the
force is then smooth within every step IAS15 takes, and each step next to a contact holds
the ``delta^(3/2)`` behaviour on a scale of its own length. Measured on ``srp-ias15`` (epsilon
1e-11): stops down to k = 12 move the final position by 5e-13 m, down to k = 6 by 3.7e-5 m, and
no stops at all by 13.6 m. emorbit's runs record at the same times,
``span / (records * days)`` apart; em's step counts are multiples of them.

Data layout: a :class:`Trajectory` holds float64 arrays in SI units, times (m,), positions and
velocities (m, 3), energy, work and balance (m,), per unit mass (emorbit's satellite is 1 kg).
References: H. Rein, D. S. Spiegel, MNRAS 446 (2015) 1424 (IAS15); D. Pham, H. Rein,
D. S. Spiegel, Open J. Astrophys. (2024) (IAS15's step criterion in REBOUND 4 and later).
"""

from __future__ import annotations

import heapq
import time
from dataclasses import dataclass, field

import astropy.units as u
import numpy as np

import emorbit
from emorbit import orbits

from .effect_eval import accelerations
from .perturbation_cases import DAY, PerturbationCase
from .perturbation_model import ReferenceModel

__all__ = [
    "Trajectory",
    "record_times",
    "run_em",
    "run_ias15",
    "kepler",
    "kernel_paths",
    "kernel_accelerations",
    "TIGHT",
    "LOOSE",
    "TIGHTER",
    "WORK_OFFSET",
    "GRADED_LEVELS",
    "GRADED_SPAN",
    "LOOKAHEAD",
]

#: IAS15's epsilon of the reference, and of the runs that bound its error
TIGHT, LOOSE, TIGHTER = 1e-11, 1e-9, 1e-12
#: the accumulator's constant acceleration, W/kg (module docstring)
WORK_OFFSET = 1.0
#: the stops about a shadow contact: t_c +- GRADED_SPAN 2^-k, k = 0 .. GRADED_LEVELS
GRADED_SPAN, GRADED_LEVELS = 64.0, 8
#: how far ahead the contacts are looked up from the current state, s
LOOKAHEAD = 3600.0
#: the accumulator's distance from the Earth, m (its acceleration is set, not added)
_FAR = 1e15


@dataclass
class Trajectory:
    """The satellite's states, energy and work at the record times.

    Attributes
    ----------
    label : str
        The run's name.
    t : ndarray
        (m,) s from the epoch.
    x, v : ndarray
        (m, 3) m and m/s.
    energy : ndarray
        (m,) E per unit mass (the satellite is 1 kg in emorbit), J/kg.
    work : ndarray
        (m,) W since the start, J/kg.
    balance : ndarray
        (m,) (E - E0 - W) / |E0|.
    wall : float
        Wall time, s.
    info : dict
        Settings and counts.
    sim : object
        emorbit's Simulation after the run (its effects hold the sampled paths), or None.
    """

    label: str
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    energy: np.ndarray
    work: np.ndarray
    balance: np.ndarray
    wall: float = 0.0
    info: dict = field(default_factory=dict)
    sim: object = None

    def difference(self, other: Trajectory) -> np.ndarray:
        """|x - x_other| per record, m (the shorter run's records)."""
        m = min(len(self.t), len(other.t))
        return np.linalg.norm(self.x[:m] - other.x[:m], axis=-1)

    def final_difference(self, other: Trajectory) -> float:
        """|x - x_other| at the last record, m."""
        return float(np.linalg.norm(self.x[-1] - other.x[-1]))


def record_times(case: PerturbationCase) -> np.ndarray:
    """The record times: k span / n, n = records per day x days, s.

    Parameters
    ----------
    case : PerturbationCase
        The case.

    Returns
    -------
    ndarray
        (n + 1,) s.
    """
    n = int(round(case.records * case.days))
    return np.arange(n + 1) * (case.span / n)


def run_em(case: PerturbationCase, order: int, per_day: int, *, effects=None, label=None) -> Trajectory:
    """Run emorbit's em method on the case through the public API.

    Parameters
    ----------
    case : PerturbationCase
        The case.
    order : int
        The composition's order.
    per_day : int
        Steps per day: dt = 1 day / per_day.
    effects : list, optional
        ``(kind, keys)`` instead of ``case.effects``.
    label : str, optional
        The trajectory's label.

    Returns
    -------
    Trajectory
        Records every span / (records x days); ``info`` holds dt, steps, Newton iterations.
    """
    steps = int(round(per_day * case.days))
    records = int(round(case.records * case.days))
    if steps % records:
        raise ValueError(f"{per_day} steps per day is not a multiple of {case.records} records per day")
    dt = case.span / steps
    sim = emorbit.Simulation(
        emorbit.CentralField(body="earth"), method="em", order=order, dt=dt * u.s, epoch=case.epoch
    )
    for kind, keys in effects if effects is not None else case.effects:
        sim.add_effect(kind, **keys)
    sim.add_point(
        "satellite", mass=1.0 * u.kg, position=case.x0 * u.m, velocity=case.v0 * u.m / u.s, **case.coefficients
    )
    start = time.perf_counter()
    result = sim.run(steps=steps, every=steps // records, progress=False)
    wall = time.perf_counter() - start
    res = result.si
    energy = np.asarray(res.energy, float)
    work = sum((np.asarray(w, float) for w in res.work.values()), np.zeros(len(energy)))
    balance = np.asarray(res.relative_energy_balance(), float)
    substeps = steps * len(emorbit.integrators.coefficients(order))
    return Trajectory(
        label or f"em {order}, dt = 1 d/{per_day}",
        np.asarray(res.time, float),
        np.asarray(res.positions["satellite"], float),
        np.asarray(res.velocities["satellite"], float),
        energy,
        work,
        balance,
        wall,
        {
            "method": "em",
            "order": order,
            "per_day": per_day,
            "dt_s": dt,
            "steps": steps,
            "substeps": substeps,
            "newton_iterations": res.mean_newton_iterations(),
            "ns_per_particle_substep": 1e9 * wall / substeps,
        },
        sim,
    )


def run_ias15(
    case: PerturbationCase, model: ReferenceModel, times, *, epsilon=None, events: bool = True, label="IAS15"
) -> Trajectory:
    """Run REBOUND's IAS15 with the reference force model, recorded at ``times``.

    Parameters
    ----------
    case : PerturbationCase
        The case.
    model : ReferenceModel
        The force model of ``additional_forces``.
    times : ndarray
        Record times, s (IAS15 lands on each).
    epsilon : float, optional
        IAS15's accuracy parameter (default REBOUND's, 1e-9).
    events : bool
        Stop at the shadow's contacts (conical shadow only).
    label : str
        The trajectory's label.

    Returns
    -------
    Trajectory
        ``info``: steps, force evaluations, epsilon, the contacts found.
    """
    import rebound

    sim = rebound.Simulation()
    sim.G = case.gm
    sim.add(m=1.0)
    x0, v0 = case.x0, case.v0
    sim.add(m=0.0, x=x0[0], y=x0[1], z=x0[2], vx=v0[0], vy=v0[1], vz=v0[2])
    sim.add(m=0.0, x=_FAR)
    sim.N_active = 1
    sim.integrator = "ias15"
    config = getattr(sim, "ri_ias15", None) or sim.integrator  # REBOUND 4: sim.ri_ias15; 5: sim.integrator
    if epsilon is not None:
        config.epsilon = epsilon
    sim.force_is_velocity_dependent = 1  # the power a . v of the accumulator uses the velocity
    sat, acc = sim.particles[1], sim.particles[2]
    evaluate = model.evaluate
    calls = [0]

    def forces(_):
        calls[0] += 1
        ax, ay, az, power = evaluate(sat.x, sat.y, sat.z, sat.vx, sat.vy, sat.vz, sim.t)
        sat.ax += ax
        sat.ay += ay
        sat.az += az
        acc.ax, acc.ay, acc.az = WORK_OFFSET + power, 0.0, 0.0

    sim.additional_forces = forces
    times = np.asarray(times, float)
    t_end = float(times[-1])
    rows = np.empty((len(times), 7))
    rows[0] = (*x0, *v0, 0.0)
    k = 1
    stops = list(times[1:])
    heapq.heapify(stops)
    covered, found = 0.0, []
    locate = events and model.kind == "srp" and model.shadow == "conical"
    start = time.perf_counter()
    while k < len(times):
        if locate and sim.t >= covered:
            span = min(LOOKAHEAD, t_end - sim.t)
            state = np.array([sat.x, sat.y, sat.z]), np.array([sat.vx, sat.vy, sat.vz])
            for tc in model.contacts(*state, sim.t, span):
                found.append(tc)
                for j in range(GRADED_LEVELS + 1):
                    for t in (tc - GRADED_SPAN * 2.0**-j, tc, tc + GRADED_SPAN * 2.0**-j):
                        if sim.t < t < t_end:
                            heapq.heappush(stops, t)
            covered = sim.t + span
        while stops[0] <= sim.t:
            heapq.heappop(stops)
        target = min(stops[0], covered) if locate else stops[0]
        sim.integrate(target)
        if target == times[k]:
            rows[k] = (sat.x, sat.y, sat.z, sat.vx, sat.vy, sat.vz, acc.vx - WORK_OFFSET * sim.t)
            k += 1
    wall = time.perf_counter() - start
    x, v, work = rows[:, :3], rows[:, 3:6], rows[:, 6]
    energy = 0.5 * np.einsum("ij,ij->i", v, v) - case.gm / np.linalg.norm(x, axis=1) + model.potential(x, times)
    balance = (energy - energy[0] - work) / abs(energy[0])
    info = {
        "steps": int(sim.steps_done),
        "force_evaluations": calls[0],
        "epsilon": float(config.epsilon),
        "contacts": found,
        "ns_per_particle_step": 1e9 * wall / max(1, sim.steps_done),
    }
    return Trajectory(label, times, x, v, energy, work, balance, wall, info)


def kepler(case: PerturbationCase, times) -> Trajectory:
    """The unperturbed orbit: the analytic Kepler motion of the initial state.

    Parameters
    ----------
    case : PerturbationCase
        The case.
    times : array_like
        s.

    Returns
    -------
    Trajectory
        Labelled "Kepler"; its energy is constant and its work zero.
    """
    t = np.asarray(times, float)
    start = time.perf_counter()
    x, v = orbits.propagate(case.x0, case.v0, case.gm, t)
    energy = 0.5 * np.einsum("ij,ij->i", v, v) - case.gm / np.linalg.norm(x, axis=1)
    zeros = np.zeros(len(t))
    return Trajectory("Kepler", t, x, v, energy, zeros, zeros, time.perf_counter() - start)


def days(t) -> np.ndarray:
    """Seconds as days."""
    return np.asarray(t, float) / DAY


def kernel_paths(sim, body: str, t) -> np.ndarray:
    """The Sun's or the Moon's position on emorbit's own table after a run.

    Parameters
    ----------
    sim : emorbit.Simulation
        After its run (its effects hold the sampled tables).
    body : str
        ``"sun"`` or ``"moon"``.
    t : array_like
        s from the epoch.

    Returns
    -------
    ndarray
        (n, 3) m: ``effect.positions(t)`` of the third body, or of radiation pressure's Sun.
    """
    t = np.atleast_1d(np.asarray(t, float))
    for effect in sim.effects:
        if effect.kind == "third_body" and effect.body == body:
            return effect.positions(t)
    for effect in sim.effects:
        if effect.kind == "srp" and body == "sun":
            return effect.positions(t)
    raise KeyError(f"no table of {body!r} in this simulation")


def kernel_accelerations(run, sim, states):
    """The reference's and emorbit's accelerations at the same states.

    emorbit's is the perturbation its step integrates: the simulation's compiled effect set
    without the central field (:func:`.effect_eval.accelerations`), at the satellite's
    coefficients, on the chord ``x -+ v h / 2``, h = 1000 s, for drag (its midpoint x, its mean
    velocity v) and at the point itself for the others, with the Sun and the Moon where the
    run's tables put them.

    Parameters
    ----------
    run : PerturbationRun
        Its ``model`` and ``case``.
    sim : emorbit.Simulation
        After a run: its effects' parameters and tables.
    states : ndarray
        (n, 7) rows ``[t, x, y, z, vx, vy, vz]``.

    Returns
    -------
    ref, kern : ndarray
        (n, 3) m/s^2.
    nu_diff : float or None
        The largest |nu_ref - nu_kernel| of the conical shadow (radiation case), emorbit's
        shadow function (:func:`emorbit.kernels.effects.radiation.shadow_conical`) with the
        srp effect's radii at its Sun.
    """
    from emorbit.kernels.effects.radiation import shadow_conical

    from .perturbation_model import shadow_conical as shadow_ref

    case, model = run.case, run.model
    states = np.asarray(states, float)
    ref = np.array([model.evaluate(*s[1:], s[0])[:3] for s in states])
    kern = accelerations(sim, "satellite", states[:, 1:4], states[:, 4:7], states[:, 0])
    nu_diff = 0.0 if case.kind == "srp" else None
    if case.kind == "srp" and model.shadow == "conical":
        srp = next(e for e in sim.effects if e.kind == "srp")
        p, sun = srp.p, srp.positions(states[:, 0])  # p = [P_au, au, R_occ, R_sun, shadow, c, ...]
        for (_, *xv), s in zip(states, sun):
            d = np.array(xv[:3]) - p[5:8]
            nu_diff = max(nu_diff, abs(shadow_conical(*d, *s, p[2], p[3]) - shadow_ref(*d, *s, p[2], p[3])))
    return ref, kern, nu_diff
