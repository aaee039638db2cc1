"""First-order secular theory of J2 and the mean rates measured from osculating elements.

The mean node and perigee of an orbit under J2 move at (Kozai 1959, AJ 64, 367; Vallado,
*Fundamentals of Astrodynamics and Applications*, sec. 9.6)::

    dOmega/dt = -3/2 n J2 (R/p)^2 cos i
    domega/dt =  3/4 n J2 (R/p)^2 (5 cos^2 i - 1)

with n = sqrt(GM / a^3), p = a (1 - e^2) and a, e, i mean elements. The theory neglects
terms of order J2^2: n (J2 (R/p)^2)^2 times polynomials in sin^2 i and e (Brouwer 1959,
AJ 64, 378). A sun-synchronous orbit's node turns once per tropical year, 360 deg per
365.2422 days = 0.98565 deg/day; first-order theory gives its inclination from
cos i = -(dOmega/dt) / (3/2 n J2 (R/p)^2).

The measured rates here: the osculating elements are averaged over each period of the
records (which removes their short-period terms, of order J2, to first order), and a line is
fitted to those per-orbit means.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "DAY",
    "SUN_SYNCHRONOUS_RATE",
    "node_rate",
    "perigee_rate",
    "second_order_scale",
    "sun_synchronous_inclination",
    "per_orbit_means",
    "mean_rates",
    "DEG_PER_DAY",
]

DAY = 86400.0  # s
#: the node rate of a sun-synchronous orbit: 2 pi per tropical year (365.2422 days), rad/s
SUN_SYNCHRONOUS_RATE = 2.0 * math.pi / (365.2422 * DAY)
#: rad/s -> deg/day
DEG_PER_DAY = DAY * 180.0 / math.pi


def _nq(a, e, gm, j2, radius):
    p = a * (1.0 - e * e)
    return math.sqrt(gm / a**3), j2 * (radius / p) ** 2


def node_rate(a: float, e: float, i: float, gm: float, j2: float, radius: float) -> float:
    """First-order secular node rate -3/2 n J2 (R/p)^2 cos i.

    Parameters
    ----------
    a, e, i : float
        Mean semi-major axis (m), eccentricity, inclination (rad).
    gm, j2, radius : float
        GM (m^3/s^2), J2 and its reference radius (m).

    Returns
    -------
    float
        rad/s.
    """
    n, q = _nq(a, e, gm, j2, radius)
    return -1.5 * n * q * math.cos(i)


def perigee_rate(a: float, e: float, i: float, gm: float, j2: float, radius: float) -> float:
    """First-order secular perigee rate 3/4 n J2 (R/p)^2 (5 cos^2 i - 1).

    Parameters
    ----------
    a, e, i : float
        Mean semi-major axis (m), eccentricity, inclination (rad).
    gm, j2, radius : float
        GM (m^3/s^2), J2 and its reference radius (m).

    Returns
    -------
    float
        rad/s.
    """
    n, q = _nq(a, e, gm, j2, radius)
    return 0.75 * n * q * (5.0 * math.cos(i) ** 2 - 1.0)


def second_order_scale(a: float, e: float, gm: float, j2: float, radius: float) -> float:
    """The size of the terms first-order theory neglects: n (J2 (R/p)^2)^2.

    Parameters
    ----------
    a, e : float
        Mean semi-major axis (m) and eccentricity.
    gm, j2, radius : float
        GM (m^3/s^2), J2 and its reference radius (m).

    Returns
    -------
    float
        rad/s.
    """
    n, q = _nq(a, e, gm, j2, radius)
    return n * q * q


def sun_synchronous_inclination(a: float, e: float, gm: float, j2: float, radius: float) -> float:
    """The inclination at which first-order theory turns the node at the sun-synchronous rate.

    Parameters
    ----------
    a, e : float
        Semi-major axis (m) and eccentricity.
    gm, j2, radius : float
        GM (m^3/s^2), J2 and its reference radius (m).

    Returns
    -------
    float
        rad (retrograde: above 90 deg).
    """
    n, q = _nq(a, e, gm, j2, radius)
    return math.acos(-SUN_SYNCHRONOUS_RATE / (1.5 * n * q))


def per_orbit_means(y, records: int) -> np.ndarray:
    """The means of a recorded quantity over each whole period.

    Parameters
    ----------
    y : array_like
        (m, ...) values at the records, ``records`` per period, the start included.
    records : int
        Records per period.

    Returns
    -------
    ndarray
        (k, ...) means over records j * records ... (j + 1) * records - 1, k whole periods.
    """
    y = np.asarray(y, float)
    k = (len(y) - 1) // records
    return y[: k * records].reshape(k, records, *y.shape[1:]).mean(axis=1)


def mean_rates(t, elements, records: int) -> dict:
    """Mean node and perigee rates, and the mean a, e, i, from osculating elements.

    Parameters
    ----------
    t : array_like
        (m,) record times, s.
    elements : OrbitalElements
        Osculating elements of one body at the records ((m,) arrays, m and rad).
    records : int
        Records per period.

    Returns
    -------
    dict
        ``node``, ``perigee`` (rad/s: slopes of lines through the per-orbit means of the
        unwrapped angles), ``a``, ``e``, ``i`` (means over the whole periods), ``orbits``.
    """
    tm = per_orbit_means(t, records)
    node = per_orbit_means(np.unwrap(elements.raan), records)
    perigee = per_orbit_means(np.unwrap(elements.argp), records)
    k = len(tm) * records
    return {
        "node": float(np.polyfit(tm, node, 1)[0]),
        "perigee": float(np.polyfit(tm, perigee, 1)[0]),
        "a": float(np.mean(elements.a[:k])),
        "e": float(np.mean(elements.e[:k])),
        "i": float(np.mean(elements.i[:k])),
        "orbits": len(tm),
    }
