"""Measurements on recorded trajectories: plane crossings, apse passages and the periods
they give, and a point's energy change evaluated exactly.

Event times are roots of a function f(t) known at the records together with its exact
time derivative, located on the cubic Hermite interpolant between two records (error
O(h^4) for records ``h`` apart), so they resolve a second-order method's phase error cleanly.

Inputs are astropy Quantities, as a :class:`~emorbit.result.Result` gives them
(``res.time``, ``res.positions[name]``, ``res.velocities[name]``, ``res.gm``, ``res.center``),
converted to SI, or plain arrays read as SI (``res.si``); times, periods and ratios come back
as plain SI numbers (s).
"""

from __future__ import annotations

import decimal

import astropy.units as u
import numpy as np

__all__ = [
    "event_times",
    "crossing_times",
    "apse_times",
    "period_from_crossings",
    "period_from_apses",
    "relative_energy_change_exact",
]


_M, _MS, _GM = u.m, u.m / u.s, u.m**3 / u.s**2


def _si(value, unit) -> np.ndarray:
    """``value`` as a plain float array in ``unit``: a Quantity converted, anything else as given."""
    if isinstance(value, u.Quantity):
        return np.asarray(value.to_value(unit), float)
    return np.asarray(value, float)


def _direction(value) -> np.ndarray:
    """A direction: its numbers, whatever unit it carries."""
    return np.asarray(value.value if isinstance(value, u.Quantity) else value, float)


def event_times(t, f, fdot, rising: bool = True) -> np.ndarray:
    """Times where a sampled function crosses zero, located on its cubic Hermite interpolant.

    Parameters
    ----------
    t : Quantity or array_like
        Sample times (n,), s.
    f : Quantity or array_like
        Samples of the function (n,).
    fdot : Quantity or array_like
        Its exact time derivative at the samples (n,): the unit of ``f`` per s.
    rising : bool
        Upward crossings (f goes from < 0 to >= 0) if true, else downward ones.

    Returns
    -------
    ndarray
        The crossing times, s, in order.
    """
    t = _si(t, u.s)
    if isinstance(f, u.Quantity):
        f, fdot = f.value, _si(fdot, f.unit / u.s)
    f = np.asarray(f, float)
    fdot = _si(fdot, 1 / u.s)
    sign = 1.0 if rising else -1.0
    g = sign * f
    idx = np.flatnonzero((g[:-1] < 0.0) & (g[1:] >= 0.0))
    out = np.empty(idx.size)
    for j, i in enumerate(idx):
        h = t[i + 1] - t[i]
        f0, f1, d0, d1 = f[i], f[i + 1], fdot[i] * h, fdot[i + 1] * h
        s = f0 / (f0 - f1)  # secant start, then Newton on the Hermite cubic for s in [0, 1]
        for _ in range(50):
            p = (
                (2 * s**3 - 3 * s**2 + 1) * f0
                + (s**3 - 2 * s**2 + s) * d0
                + (-2 * s**3 + 3 * s**2) * f1
                + (s**3 - s**2) * d1
            )
            dp = (6 * s**2 - 6 * s) * (f0 - f1) + (3 * s**2 - 4 * s + 1) * d0 + (3 * s**2 - 2 * s) * d1
            ds = p / dp
            s -= ds
            if abs(ds) < 1e-15:
                break
        out[j] = t[i] + s * h
    return out


def crossing_times(t, x, v, normal, center=(0.0, 0.0, 0.0), side=None) -> np.ndarray:
    """Times at which a recorded trajectory crosses a plane through the centre.

    Parameters
    ----------
    t : Quantity or array_like
        Record times (n,), s, close enough that the cubic through two records is accurate.
    x, v : Quantity or array_like
        Positions and velocities (n, 3), m and m/s.
    normal : array_like
        Normal of the plane (3,); crossings in the +normal direction count.
    center : Quantity or array_like
        A point of the plane (the field's centre), m.
    side : array_like, optional
        Keep only crossings where (x - center) . side > 0 (a half-plane).

    Returns
    -------
    ndarray
        The crossing times, s.
    """
    t = _si(t, u.s)
    x = _si(x, _M) - _si(center, _M)
    nrm = _direction(normal)
    times = event_times(t, x @ nrm, _si(v, _MS) @ nrm)
    if side is None:
        return times
    keep = np.interp(times, t, x @ _direction(side)) > 0.0
    return times[keep]


def apse_times(t, x, v, gm, center=(0.0, 0.0, 0.0), apse: str = "apoapsis") -> np.ndarray:
    """Times of apoapsis or periapsis passages: the zeros of r . v.

    The derivative of r . v, v^2 - GM/r, is exact at every record in a central field.

    Parameters
    ----------
    t : Quantity or array_like
        Record times (n,), s.
    x, v : Quantity or array_like
        Positions and velocities (n, 3), m and m/s.
    gm : Quantity or float
        GM of the centre, m^3/s^2.
    center : Quantity or array_like
        The centre, m.
    apse : str
        ``"apoapsis"`` or ``"periapsis"``.

    Returns
    -------
    ndarray
        The passage times, s.

    Raises
    ------
    ValueError
        ``apse`` is neither.
    """
    r = _si(x, _M) - _si(center, _M)
    v = _si(v, _MS)
    f = np.einsum("ij,ij->i", r, v)
    fdot = np.einsum("ij,ij->i", v, v) - float(_si(gm, _GM)) / np.linalg.norm(r, axis=1)
    if apse not in ("apoapsis", "periapsis"):
        raise ValueError(f"apse must be 'apoapsis' or 'periapsis', got {apse!r}")
    return event_times(t, f, fdot, rising=(apse == "periapsis"))


def _slope(times) -> float:
    if times.size < 2:
        raise ValueError("fewer than two events: record a longer run")
    return float(np.polyfit(np.arange(times.size), times, 1)[0])


def period_from_apses(t, x, v, gm, center=(0.0, 0.0, 0.0), apse: str = "apoapsis") -> tuple[float, int]:
    """The anomalistic period (apse to apse) of a recorded orbit.

    The least-squares slope of the passage times (:func:`apse_times`) against their number.

    Parameters
    ----------
    t : Quantity or array_like
        Record times (n,), s.
    x, v : Quantity or array_like
        Positions and velocities (n, 3), m and m/s.
    gm : Quantity or float
        GM of the centre, m^3/s^2.
    center : Quantity or array_like
        The centre, m.
    apse : str
        ``"apoapsis"`` or ``"periapsis"``: which passages to time.

    Returns
    -------
    period : float
        s.
    passages : int
        Number of passages the fit used.

    Raises
    ------
    ValueError
        Fewer than two passages were recorded.
    """
    times = apse_times(t, x, v, gm, center, apse)
    return _slope(times), int(times.size)


def period_from_crossings(t, x, v, center=(0.0, 0.0, 0.0)) -> tuple[float, int]:
    """The sidereal period: successive crossings of the half-plane through the first position.

    This includes the apsidal precession of a numerical orbit; it is defined for circular
    orbits, which have no apses.

    Parameters
    ----------
    t : Quantity or array_like
        Record times (n,), s.
    x, v : Quantity or array_like
        Positions and velocities (n, 3), m and m/s.
    center : Quantity or array_like
        The centre, m.

    Returns
    -------
    period : float
        s.
    crossings : int
        Number of crossings the fit used.

    Raises
    ------
    ValueError
        Fewer than two crossings were recorded.
    """
    x = _si(x, _M)
    v = _si(v, _MS)
    r0 = x[0] - _si(center, _M)
    normal = np.cross(np.cross(r0, v[0]), r0)  # in the orbital plane, along the motion
    times = crossing_times(t, x, v, normal, center, side=r0)
    return _slope(times), int(times.size)


def relative_energy_change_exact(x0, v0, x1, v1, gm, cx1=None, cv1=None) -> np.ndarray:
    """Relative energy change E1 / E0 - 1 of test particles, evaluated exactly.

    ``E = |v|**2 / 2 - gm / |x|`` (centre at the origin) is evaluated from the float64
    states with 60 significant digits and the ratio rounded once. This is for drift
    measurements whose signal is below one rounding of the energy: evaluated in float64,
    ``E0`` of copies that start at one position carries the same rounding error of
    ``gm / |x0|`` in every copy, an offset of the ensemble mean that does not average out
    (for the paper's orbit, ``gm / 10``, it is -6.7e-17 of ``E``).

    Parameters
    ----------
    x0, v0 : Quantity or array_like
        Initial positions and velocities (3, n), the kernels' layout, m and m/s.
    x1, v1 : Quantity or array_like
        Final positions and velocities (3, n).
    gm : Quantity or float
        GM, m^3/s^2.
    cx1, cv1 : Quantity or array_like, optional
        Compensation terms of the final state (3, n): the state is then ``x1 - cx1``,
        ``v1 - cv1`` (see :func:`emorbit.kernels.eft.kahan_add`).

    Returns
    -------
    ndarray
        E1 / E0 - 1 per particle (n,).

    Raises
    ------
    ValueError
        Shapes differ from (3, n), a state is not finite, or a point is at the centre.
    """
    arrays = [_si(a, unit) for a, unit in ((x0, _M), (v0, _MS), (x1, _M), (v1, _MS))]
    if any(a.ndim != 2 or a.shape[0] != 3 or a.shape != arrays[0].shape for a in arrays):
        raise ValueError(f"x0, v0, x1, v1 must all be (3, n) arrays, got shapes {[a.shape for a in arrays]}")
    x0, v0, x1, v1 = arrays
    cx1 = np.zeros_like(x1) if cx1 is None else _si(cx1, _M)
    cv1 = np.zeros_like(v1) if cv1 is None else _si(cv1, _MS)
    if cx1.shape != x1.shape or cv1.shape != v1.shape:
        raise ValueError(f"cx1, cv1 must have the shape of x1, {x1.shape}, got {cx1.shape} and {cv1.shape}")
    if not (np.isfinite(arrays).all() and np.isfinite(cx1).all() and np.isfinite(cv1).all()):
        raise ValueError("relative_energy_change_exact: a state is not finite")
    D = decimal.Decimal
    out = np.empty(x0.shape[1])
    with decimal.localcontext() as ctx:
        ctx.prec = 60
        g = D(float(_si(gm, _GM)))

        def energy(x, v):
            r = sum(D(c) * D(c) for c in x).sqrt()
            if r == 0:
                raise ValueError("relative_energy_change_exact: a point is at the centre")
            return sum(D(c) * D(c) for c in v) / 2 - g / r

        for i in range(x0.shape[1]):
            e0 = energy(x0[:, i].tolist(), v0[:, i].tolist())
            x = [D(a) - D(b) for a, b in zip(x1[:, i].tolist(), cx1[:, i].tolist())]
            v = [D(a) - D(b) for a, b in zip(v1[:, i].tolist(), cv1[:, i].tolist())]
            out[i] = float(energy(x, v) / e0 - 1)
    return out
