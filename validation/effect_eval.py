"""emorbit's effects evaluated at given states, through a simulation's compiled effect set.

The cases compare emorbit's forces and potential energies with their referees' at the same
states. They read them as a step does: the simulation's effects compiled into the functions
every step kernel takes (:meth:`emorbit.effects.effectset.EffectSet.program`), with the set's
parameters, tables and scratch (:meth:`~emorbit.effects.effectset.EffectSet.arrays`) and a
point's coefficients, so both sides of a comparison evaluate the acceleration emorbit
integrates, not a re-wiring of the effects' kernels.

Each state is one point mass of its own (unit mass, body 0): pair effects (mutual gravity)
have no pair there and add nothing. Data layout: positions and velocities (n, 3) float64, m
and m/s; times (n,) s from the run's epoch; accelerations (n, 3) m/s^2; potentials per unit
mass, J/kg.
"""

from __future__ import annotations

import numba
import numpy as np

from emorbit.kernels.codes import STATUS_OK
from emorbit.kernels.effects.signatures import MODE_EXPLICIT, MODE_MIDPOINT

__all__ = ["point_coefficients", "accelerations", "point_potentials"]


@numba.njit(cache=False)  # it takes the set's compiled functions as arguments
def _forces_at(forces, prepare, x0, x1, t, h, mode, coef, P, I, T, S, out):
    """The set's force per unit mass on one point over the chord x0[i] -> x1[i] of length h,
    centred on the time t[i], for each i (into ``out``); the last status that was not OK."""
    a = np.empty((3, 1))
    b = np.empty((3, 1))
    m = np.ones(1)
    body = np.zeros(1, np.int64)
    F = np.empty((3, 1))
    W = np.empty((9, 1))
    R = np.zeros(1)
    status = STATUS_OK
    for i in range(x0.shape[0]):
        for c in range(3):
            a[c, 0] = x0[i, c]
            b[c, 0] = x1[i, c]
        prepare(t[i] - 0.5 * h, t[i], t[i] + 0.5 * h, P, I, T, S)
        s = forces(a, b, m, body, coef, h, mode, P, I, T, S, F, W, R, False, True)
        if s != STATUS_OK:
            status = s
        for c in range(3):
            out[i, c] = F[c, 0]
    return status


def point_coefficients(sim, name: str | None = None, kinds=None) -> np.ndarray:
    """(k, 1) a point mass's coefficient for each effect of the simulation's set.

    Parameters
    ----------
    sim : emorbit.Simulation
        The simulation.
    name : str, optional
        A point mass of the simulation: its effect keys (a ``ballistic_coefficient``); without
        one, a point that gives none.
    kinds : collection of str, optional
        Keep only these effects (the others' coefficients are 0: they do not act).

    Returns
    -------
    ndarray
        (k, 1) float64, in the order of ``sim.effects``.
    """
    coef = sim.points.effects.coefficients([name or ""], sim.points.values)
    if kinds is not None:
        for e, effect in enumerate(sim.effects):
            if effect.kind not in kinds:
                coef[e] = 0.0
    return np.ascontiguousarray(coef)


def accelerations(sim, name: str, x, v, t, kinds=None, h: float = 1000.0) -> np.ndarray:
    """The acceleration of a point mass at given states from the simulation's compiled effects.

    Effects whose force depends on the velocity (drag) see the chord ``x -+ v h / 2`` (the
    conservative ones at its midpoint x, the others over the chord: its mean velocity is v,
    rounded at eps |x| / h); where every effect is a function of position alone, the chord has
    length 0. Each effect that follows a path (the Sun, the Moon) is where its tables put it at
    t (the tables a run sampled: evaluate after :meth:`~emorbit.Simulation.run`).

    Parameters
    ----------
    sim : emorbit.Simulation
        After a run over the times t.
    name : str
        The point mass whose coefficients apply.
    x, v : array_like
        (n, 3) positions (m) and velocities (m/s).
    t : array_like
        (n,) s from the epoch.
    kinds : collection of str, optional
        The effects that act (default: every effect but the central field).
    h : float
        The chord's duration, s.

    Returns
    -------
    ndarray
        (n, 3) m/s^2.

    Raises
    ------
    ValueError
        A force that is not finite.
    """
    x = np.ascontiguousarray(np.atleast_2d(np.asarray(x, float)))
    v = np.ascontiguousarray(np.atleast_2d(np.asarray(v, float)))
    t = np.ascontiguousarray(np.atleast_1d(np.asarray(t, float)))
    if kinds is None:
        kinds = {e.kind for e in sim.effects if e.kind != "central"}
    acting = [e for e in sim.effects if e.kind in kinds]
    explicit = all(type(e).EXPLICIT for e in acting)
    x0, x1 = (x, x) if explicit else (x - 0.5 * h * v, x + 0.5 * h * v)
    prog = sim.effects.program()
    P, I, T, S = sim.effects.arrays(1)
    out = np.empty_like(x)
    mode = MODE_EXPLICIT if explicit else MODE_MIDPOINT
    coef = point_coefficients(sim, name, kinds)
    status = _forces_at(prog.forces, prog.prepare, x0, x1, t, float(h), mode, coef, P, I, T, S, out)
    if status != STATUS_OK:
        raise ValueError(f"emorbit's effects gave a force that is not finite (status {status})")
    return out


def point_potentials(sim, x, t=None, name: str | None = None) -> dict:
    """Each effect's potential energy per unit mass at positions, from the compiled set.

    Parameters
    ----------
    sim : emorbit.Simulation
        The simulation (after a run, for effects that follow a path).
    x : array_like
        (..., 3) positions, m.
    t : array_like, optional
        (...) s from the epoch (default 0).
    name : str, optional
        The point mass whose coefficients apply (default: one that gives no effect keys).

    Returns
    -------
    dict
        {label: (...) J/kg} for each effect that has a potential (``central``, ``zonal``, ...).
    """
    x = np.asarray(x, float)
    shape = x.shape[:-1]
    rows = np.ascontiguousarray(x.reshape(-1, 3))[:, :, None]  # one point per record
    times = None if t is None else np.ascontiguousarray(np.broadcast_to(np.asarray(t, float), shape).ravel())
    coef = point_coefficients(sim, name)
    out = sim.points.effects.potentials(rows, times, np.ones(1), np.zeros(1, np.int64), coef)
    return {key.removeprefix("potential_"): value.reshape(shape) for key, value in out.items()}
