"""A finite burn's pieces for an effect set (:mod:`.signatures`): constant thrust with the
body's mass falling as the rocket equation says.

A burn of thrust T (N) and effective exhaust speed ``ve = Isp g0`` acts from ``t0`` to
``t1``, and steps land on both. The body's mass over its initial mass falls as ``mu(t) = mu0 -
q (t - t0)``, ``q = T / (ve m_initial)``. A sub-step from ta to tb whose middle tm lies inside
the window (every sub-step of a composed or adaptive step lies in its step's window when
its middle does: the middles of the compositions' sub-steps lie inside their steps, and no
step straddles t0 or t1) changes the velocity by the rocket equation's::

    dv = ve ln(mu(ta) / mu(tb)) = ve log1p(q (tb - ta) / mu(tb))

exactly (``ve = 0``: ``dv = (T / m0) (tb - ta)``, m0 the mass at the start); outside, by 0.
The sub-steps telescope to the rocket equation over the step, and the force is smooth in
time within each step, so a composition keeps its order. Over a step x0 -> x1 of length h
the force per unit mass is ``F = (dv / h) e``, e the burn's unit direction: fixed in the
scene's axes, or in the local frame of the step's midpoint ``r = (x0 + x1) / 2 - c`` and mean
velocity ``v = (x1 - x0) / h``: RSW (``r / |r|``, ``w x r``, ``w = r x v / |r x v|``) or VNC
(``v / |v|``, w, ``v x w / |v|``). In an em step ``(x1 - x0) / h`` is the mean velocity, so
the kinetic energy per unit mass changes by exactly the conservative potentials' drop plus
``dv e . (x1 - x0) / h``, the burn's work that the step sums. The derivative of the local
frame with respect to x1 (of order ``|F| / (|v| h)``: about 1e-4 of the central field's for
a low thrust in LEO at T/1000) stays out of Newton's matrix.

On a rigid body the burn acts through a thruster of its own, a facet of area 0 at the point
the thrust acts on, its normal the thrust's direction in the body (``thrust_facet``). The body
loses mass evenly, so it moves as at its initial mass M0 under ``T m0 / m(t)``: the facet's
force is ``M0 (dv / h) n`` (N), n its normal at the step's middle, and its work ``F . (b - a)``
over the thruster's path counts the torque's work too. On an elastic body the thruster is one
node (a facet whose three corners are that node), pushed with T along the direction in its
frame, its mass held (``M0 = 1``, ``a0 = T``).

Mass ledger: ``thrust_mass`` gives this burn's part of the body's mean mass over m0, less 1,
over a sub-step, for the set's ledger row (``docs/methods.md``, "Finite burns").

Data layout: ``p = [t0, t1, mu0, q, ve, a0, frame (0 inertial, 1 rsw, 2 vnc, 3 body), e0,
e1, e2, c0, c1, c2, M0, mark]``, ``a0 = T / m0`` (m/s^2, where ``ve = 0``), q (1/s), ``mark``
the thruster facet's k3 (negative: its own facets only); ``s`` (2,): dv, ``mu_mean - 1``.
"""

from __future__ import annotations

import math

from ..jit import kernel

__all__ = ["thrust_piece", "thrust_prepare", "thrust_facet", "thrust_mass", "burn_dv"]

_inline = kernel(inline="always")
# an effect-set piece: compiled on its own (cached per install) and inlined by LLVM into the set
_piece = kernel(forceinline=True)


@_inline
def burn_dv(ta, tm, tb, p):
    """The speed the burn gives over a sub-step from ta to tb with its middle at tm (negative
    where tb < ta; 0 where tm is outside the window), m/s."""
    if not (p[0] < tm < p[1]) or ta == tb:
        return 0.0
    if p[4] == 0.0:
        return p[5] * (tb - ta)
    mu_b = p[2] - p[3] * (tb - p[0])
    mu_a = p[2] - p[3] * (ta - p[0])
    floor = 1e-9 * p[2]
    if mu_a < floor or mu_b < floor:  # past its mass (a step the event <label>.empty cuts short)
        return p[4] * math.log(max(mu_a, floor) / max(mu_b, floor))
    return p[4] * math.log1p(p[3] * (tb - ta) / mu_b)


@_piece
def thrust_prepare(ta, tm, tb, p, tab, s):
    """The sub-step's dv (0 outside the window) and the mean mass the burn has expelled over
    it, negated, over m0."""
    s[0] = burn_dv(ta, tm, tb, p)
    if p[0] < tm < p[1]:
        s[1] = -p[3] * (0.5 * (ta + tb) - p[0])
    elif tm >= p[1]:
        s[1] = -p[3] * (p[1] - p[0])
    else:
        s[1] = 0.0


@_piece
def thrust_mass(c, facet, p, s):
    """This burn's part of the body's mean mass over its initial mass, less 1, over the sub-step:
    at a point it acts on (c its coefficient, not 0) or at its own thruster facet (``facet``, c
    the facet's mark); 0 at other facets."""
    if facet and c != p[14]:
        return 0.0
    return s[1]


@_inline
def _direction(x0, y0, z0, x1, y1, z1, h, p):
    """The burn's unit direction over a step x0 -> x1: fixed, or in the RSW or VNC frame of
    its midpoint and mean velocity."""
    if p[6] == 0.0:
        return p[7], p[8], p[9]
    rx, ry, rz = 0.5 * (x0 + x1) - p[10], 0.5 * (y0 + y1) - p[11], 0.5 * (z0 + z1) - p[12]
    vx, vy, vz = (x1 - x0) / h, (y1 - y0) / h, (z1 - z0) / h
    wx, wy, wz = ry * vz - rz * vy, rz * vx - rx * vz, rx * vy - ry * vx
    wn = math.sqrt(wx * wx + wy * wy + wz * wz)
    wx, wy, wz = wx / wn, wy / wn, wz / wn
    if p[6] == 1.0:  # rsw: radial, along-track in the plane (w x radial), normal
        n = math.sqrt(rx * rx + ry * ry + rz * rz)
        ax, ay, az = rx / n, ry / n, rz / n
        bx, by, bz = wy * az - wz * ay, wz * ax - wx * az, wx * ay - wy * ax
        cx, cy, cz = wx, wy, wz
    else:  # vnc: velocity, normal, co-normal (velocity x w)
        n = math.sqrt(vx * vx + vy * vy + vz * vz)
        ax, ay, az = vx / n, vy / n, vz / n
        bx, by, bz = wx, wy, wz
        cx, cy, cz = ay * wz - az * wy, az * wx - ax * wz, ax * wy - ay * wx
    return (
        p[7] * ax + p[8] * bx + p[9] * cx,
        p[7] * ay + p[8] * by + p[9] * cy,
        p[7] * az + p[8] * bz + p[9] * cz,
    )


@_piece
def thrust_piece(x0, y0, z0, x1, y1, z1, h, c, p, tab, s, J, jac):
    """The burn's force per unit mass over the step, ``(dv / h) e``."""
    if s[0] == 0.0:
        return 0.0, 0.0, 0.0
    a = s[0] / h
    ex, ey, ez = _direction(x0, y0, z0, x1, y1, z1, h, p)
    return a * ex, a * ey, a * ez


@_piece
def thrust_facet(ax, ay, az, bx, by, bz, nx, ny, nz, area, k0, k1, k2, k3, h, p, tab, s):
    """The burn's force on its thruster facet (k3 its mark), N: ``M0 (dv / h) e``, e the
    facet's normal (a rigid body's thruster) or the direction in its frame over the facet's
    path a -> b (an elastic body's node)."""
    if k3 != p[14] or s[0] == 0.0:
        return 0.0, 0.0, 0.0
    f = p[13] * s[0] / h
    if p[6] == 3.0:
        return f * nx, f * ny, f * nz
    ex, ey, ez = _direction(ax, ay, az, bx, by, bz, h, p)
    return f * ex, f * ey, f * ez
