"""A third body on a prescribed path: its position from a sampled table, the tidal potential, the
conserving discrete force at a frozen time, and the work of the potential's change in time.

Table: rows ``(x, y, z, vx, vy, vz)`` (m, m/s; relative to the central body) at the times
``(k0 + j) step`` (s from the run's epoch); between samples a cubic Hermite interpolant. The
interval and the fraction within it come from ``t / step`` alone, so a table that starts at
another sample gives the same bits at the same time (a resumed run matches an unbroken one).
Outside the table the end intervals extrapolate.

Potential per unit mass at ``d = x - c`` of a body of ``gm`` at ``s`` (relative to the central
body, ``sigma = |s|``, ``rho = |s - d|``, ``p = s . d``, ``q = d . d``). In a frame whose origin
is the central body (``indirect``) the central body's own acceleration towards the third body
enters as the indirect term, and the constant ``gm / sigma`` is taken out::

    U = -gm (1 / rho - 1 / sigma - p / sigma^3)
      = -gm [p (2 p - q) (2 sigma + rho) / (rho sigma^3 (sigma + rho)^2) - q / (rho sigma (sigma + rho))]

(the second form has no cancellation: it is O(q / sigma^3), the tidal potential). Without
``indirect`` (an inertial frame) ``U = -gm / rho``. Force over the step x0 -> x1 at a frozen
time, s = s(t_m): the point-mass force of :func:`.central.central_force` towards s, minus
``gm s / sigma^3`` with ``indirect``: its work is ``-(U(x1) - U(x0))`` at s(t_m) exactly.

Work of the time dependence over a step t_a -> t_b with t_m its midpoint, per unit mass::

    W_t = [U(x1, s_b) - U(x1, s_m)] + [U(x0, s_m) - U(x0, s_a)]

so that ``E(t_b) - E(t_a) = W_t`` (+ the work of non-conservative forces) holds to round-off
for ``E = T + V + U``. Data layout: scalars; tables (n, 6) float64; records' potentials from
(rows, 3, n) positions. References: O. Montenbruck, E. Gill, Satellite Orbits (2000), 3.3;
D. Greenspan, J. Comput. Phys. 56 (1984) 28-41.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import kernel
from .central import central_force, central_jacobian

__all__ = [
    "table_position",
    "tidal_potential",
    "third_body_force",
    "third_body_jacobian",
    "third_body_potentials",
    "table_positions",
    "third_body_piece",
    "third_body_prepare",
    "third_body_time_work",
    "third_body_potential_piece",
]

_inline = kernel(inline="always")
# an effect-set piece: compiled on its own (cached per install) and inlined by LLVM into the set
_piece = kernel(forceinline=True)


@_inline
def table_position(t, step, k0, tab):
    """The interpolated position of a table at time ``t``.

    Parameters
    ----------
    t : float
        Seconds from the epoch.
    step : float
        The sampling interval, s.
    k0 : float
        The first row's sample index (its time is ``k0 step``), an integer.
    tab : ndarray
        (n, 6) float64, n >= 2: positions (m) and velocities (m/s) at the samples.

    Returns
    -------
    tuple of float
        ``(x, y, z)``, m.
    """
    s = t / step
    kf = math.floor(s)
    f = s - kf
    j = int(kf - k0)
    last = tab.shape[0] - 2
    if j < 0:
        f += j
        j = 0
    elif j > last:
        f += j - last
        j = last
    f2 = f * f
    f3 = f2 * f
    h00 = 2.0 * f3 - 3.0 * f2 + 1.0
    h10 = f3 - 2.0 * f2 + f
    h01 = 3.0 * f2 - 2.0 * f3
    h11 = f3 - f2
    x = h00 * tab[j, 0] + h01 * tab[j + 1, 0] + step * (h10 * tab[j, 3] + h11 * tab[j + 1, 3])
    y = h00 * tab[j, 1] + h01 * tab[j + 1, 1] + step * (h10 * tab[j, 4] + h11 * tab[j + 1, 4])
    z = h00 * tab[j, 2] + h01 * tab[j + 1, 2] + step * (h10 * tab[j, 5] + h11 * tab[j + 1, 5])
    return x, y, z


@_inline
def tidal_potential(dx, dy, dz, sx, sy, sz, gm, indirect):
    """The third body's potential per unit mass.

    Parameters
    ----------
    dx, dy, dz : float
        The point relative to the central body, m.
    sx, sy, sz : float
        The third body relative to the central body, m.
    gm : float
        The third body's GM, m^3/s^2.
    indirect : bool
        With the indirect term (the frame's origin is the central body).

    Returns
    -------
    float
        U, J/kg (the cancellation-free form with ``indirect``, else ``-gm / rho``).
    """
    ex = sx - dx
    ey = sy - dy
    ez = sz - dz
    rho = math.sqrt(ex * ex + ey * ey + ez * ez)
    if not indirect:
        return -gm / rho
    sigma = math.sqrt(sx * sx + sy * sy + sz * sz)
    p = sx * dx + sy * dy + sz * dz
    q = dx * dx + dy * dy + dz * dz
    sr = sigma + rho
    return -gm * (p * (2.0 * p - q) * (2.0 * sigma + rho) / (rho * sigma**3 * sr * sr) - q / (rho * sigma * sr))


@_inline
def third_body_force(x0, y0, z0, x1, y1, z1, c0, c1, c2, sx, sy, sz, gm, indirect):
    """The conserving force per unit mass of a third body at a frozen position over x0 -> x1.

    Parameters
    ----------
    x0, y0, z0, x1, y1, z1 : float
        The step's start and end, m.
    c0, c1, c2 : float
        The central body (the frame's origin of s), m.
    sx, sy, sz : float
        The third body relative to the central body at the step's middle time, m.
    gm : float
        Its GM, m^3/s^2.
    indirect : bool
        Subtract the central body's acceleration ``gm s / |s|^3``.

    Returns
    -------
    tuple of float
        ``(fx, fy, fz)``, m/s^2, with ``F . (x1 - x0) = -(U(x1) - U(x0))``.
    """
    fx, fy, fz = central_force(x0, y0, z0, x1, y1, z1, c0 + sx, c1 + sy, c2 + sz, gm)
    if indirect:
        sigma = math.sqrt(sx * sx + sy * sy + sz * sz)
        k = gm / (sigma * sigma * sigma)
        fx -= k * sx
        fy -= k * sy
        fz -= k * sz
    return fx, fy, fz


@_inline
def third_body_jacobian(x0, y0, z0, x1, y1, z1, c0, c1, c2, sx, sy, sz, gm, J):
    """Add the derivative of :func:`third_body_force` with respect to the end point into ``J``
    (the indirect term is constant in x1).

    Parameters
    ----------
    x0, y0, z0, x1, y1, z1, c0, c1, c2, sx, sy, sz, gm
        As :func:`third_body_force`.
    J : ndarray
        (3, 3) float64; ``J[i, j] += dF_i / dx1_j``, 1/s^2.
    """
    central_jacobian(x0, y0, z0, x1, y1, z1, c0 + sx, c1 + sy, c2 + sz, gm, J)


@kernel
def table_positions(t, step, k0, tab):
    """:func:`table_position` at each of the times ``t`` (n,): (n, 3) float64, m."""
    out = np.empty((t.shape[0], 3))
    for i in range(t.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = table_position(t[i], step, k0, tab)
    return out


@kernel
def third_body_potentials(x, t, masses, c, gm, indirect, step, k0, tab):
    """The third body's potential energy of points at recorded states.

    Parameters
    ----------
    x : ndarray
        (rows, 3, n) positions, m.
    t : ndarray
        (rows,) the records' times, s from the epoch.
    masses : ndarray
        (n,) kg (0 for points it does not act on).
    c : ndarray
        (3,) the central body, m.
    gm, indirect, step, k0, tab
        As :func:`tidal_potential` and :func:`table_position`.

    Returns
    -------
    ndarray
        (rows,) J.
    """
    rows = x.shape[0]
    out = np.zeros(rows)
    for r in range(rows):
        sx, sy, sz = table_position(t[r], step, k0, tab)
        e = 0.0
        for i in range(x.shape[2]):
            if masses[i] != 0.0:
                u = tidal_potential(x[r, 0, i] - c[0], x[r, 1, i] - c[1], x[r, 2, i] - c[2], sx, sy, sz, gm, indirect)
                e += masses[i] * u
        out[r] = e
    return out


# -- the pieces of an effect set (.signatures): p = [gm, indirect, c0, c1, c2, step, k0, rows],
# tab the body's table (rows, 6), s (9,) its positions at the sub-step's start, middle and end


@_inline
def _table(p, tab):
    rows = int(p[7])
    return tab[0 : 6 * rows].reshape((rows, 6))


@_piece
def third_body_prepare(ta, tm, tb, p, tab, s):
    """The body at the sub-step's start, middle and end (into s[0:3], s[3:6], s[6:9])."""
    t = _table(p, tab)
    s[0], s[1], s[2] = table_position(ta, p[5], p[6], t)
    s[3], s[4], s[5] = table_position(tm, p[5], p[6], t)
    s[6], s[7], s[8] = table_position(tb, p[5], p[6], t)


@_piece
def third_body_piece(x0, y0, z0, x1, y1, z1, h, c, p, tab, s, J, jac):
    """:func:`third_body_force` at the body's position at the sub-step's middle time, and its
    Jacobian where ``jac``."""
    if jac:
        third_body_jacobian(x0, y0, z0, x1, y1, z1, p[2], p[3], p[4], s[3], s[4], s[5], p[0], J)
    return third_body_force(x0, y0, z0, x1, y1, z1, p[2], p[3], p[4], s[3], s[4], s[5], p[0], p[1] != 0.0)


@_piece
def third_body_time_work(x0, y0, z0, x1, y1, z1, c, p, tab, s):
    """The work per unit mass of the potential's change in time over the sub-step: the body
    at the end against its middle at x1, the middle against the start at x0."""
    gm = p[0]
    ind = p[1] != 0.0
    a0 = x0 - p[2]
    a1 = y0 - p[3]
    a2 = z0 - p[4]
    b0 = x1 - p[2]
    b1 = y1 - p[3]
    b2 = z1 - p[4]
    ue = tidal_potential(b0, b1, b2, s[6], s[7], s[8], gm, ind) - tidal_potential(b0, b1, b2, s[3], s[4], s[5], gm, ind)
    us = tidal_potential(a0, a1, a2, s[3], s[4], s[5], gm, ind) - tidal_potential(a0, a1, a2, s[0], s[1], s[2], gm, ind)
    return ue + us


@_piece
def third_body_potential_piece(x, y, z, c, p, tab, s):
    """:func:`tidal_potential` with the body at the prepared middle position."""
    return tidal_potential(x - p[2], y - p[3], z - p[4], s[3], s[4], s[5], p[0], p[1] != 0.0)
