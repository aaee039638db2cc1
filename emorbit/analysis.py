"""Measurements on recorded trajectories: plane crossings, apse passages and the periods
they give.

Event times are roots of a function f(t) known at the records together with its exact
time derivative, located on the cubic Hermite interpolant between two records (error
O(h^4) for records ``h`` apart), so they resolve a second-order method's phase error cleanly.
"""

from __future__ import annotations

import numpy as np

__all__ = ["event_times", "crossing_times", "apse_times", "period_from_crossings", "period_from_apses"]


def event_times(t, f, fdot, rising: bool = True) -> np.ndarray:
    """Times where ``f`` crosses zero (upwards if ``rising``, else downwards), given samples
    ``f`` and exact derivatives ``fdot`` at times ``t`` (all (n,))."""
    t = np.asarray(t, float)
    f = np.asarray(f, float)
    fdot = np.asarray(fdot, float)
    sign = 1.0 if rising else -1.0
    g = sign * f
    idx = np.flatnonzero((g[:-1] < 0.0) & (g[1:] >= 0.0))
    out = np.empty(idx.size)
    for j, i in enumerate(idx):
        h = t[i + 1] - t[i]
        f0, f1, d0, d1 = f[i], f[i + 1], fdot[i] * h, fdot[i + 1] * h
        s = f0 / (f0 - f1)  # secant start, then Newton on the Hermite cubic for s in [0, 1]
        for _ in range(50):
            p = (2 * s**3 - 3 * s**2 + 1) * f0 + (s**3 - 2 * s**2 + s) * d0 + (-2 * s**3 + 3 * s**2) * f1 \
                + (s**3 - s**2) * d1
            dp = (6 * s**2 - 6 * s) * (f0 - f1) + (3 * s**2 - 4 * s + 1) * d0 + (3 * s**2 - 2 * s) * d1
            ds = p / dp
            s -= ds
            if abs(ds) < 1e-15:
                break
        out[j] = t[i] + s * h
    return out


def crossing_times(t, x, v, normal, center=(0.0, 0.0, 0.0), side=None) -> np.ndarray:
    """Times at which the trajectory crosses the plane through ``center`` with ``normal`` in
    the +normal direction, optionally only where (x - center) . side > 0.

    t (n,), x and v (n, 3), recorded close enough that the cubic through two records is accurate.
    """
    x = np.asarray(x, float) - np.asarray(center, float)
    nrm = np.asarray(normal, float)
    times = event_times(t, x @ nrm, np.asarray(v, float) @ nrm)
    if side is None:
        return times
    keep = np.interp(times, t, x @ np.asarray(side, float)) > 0.0
    return times[keep]


def apse_times(t, x, v, gm, center=(0.0, 0.0, 0.0), apse: str = "apoapsis") -> np.ndarray:
    """Times of apoapsis (or ``"periapsis"``) passages: zeros of r . v, whose derivative
    v^2 - GM/r is exact at every record in a central field."""
    r = np.asarray(x, float) - np.asarray(center, float)
    v = np.asarray(v, float)
    f = np.einsum("ij,ij->i", r, v)
    fdot = np.einsum("ij,ij->i", v, v) - gm / np.linalg.norm(r, axis=1)
    if apse not in ("apoapsis", "periapsis"):
        raise ValueError(f"apse must be 'apoapsis' or 'periapsis', got {apse!r}")
    return event_times(t, f, fdot, rising=(apse == "periapsis"))


def _slope(times) -> float:
    if times.size < 2:
        raise ValueError("fewer than two events: record a longer run")
    return float(np.polyfit(np.arange(times.size), times, 1)[0])


def period_from_apses(t, x, v, gm, center=(0.0, 0.0, 0.0), apse: str = "apoapsis") -> tuple[float, int]:
    """The anomalistic period (apse to apse) of a recorded orbit: least-squares slope of the
    passage times against their number. Returns (period in s, number of passages)."""
    times = apse_times(t, x, v, gm, center, apse)
    return _slope(times), int(times.size)


def period_from_crossings(t, x, v, center=(0.0, 0.0, 0.0)) -> tuple[float, int]:
    """The sidereal period: successive crossings of the half-plane through the initial
    position (this includes the apsidal precession of a numerical orbit).
    Returns (period in s, number of crossings)."""
    x = np.asarray(x, float)
    r0 = x[0] - np.asarray(center, float)
    normal = np.cross(np.cross(r0, np.asarray(v, float)[0]), r0)  # in the orbital plane, along the motion
    times = crossing_times(t, x, v, normal, center, side=r0)
    return _slope(times), int(times.size)
