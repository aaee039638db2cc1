"""A point mass ``gm`` at the centre ``c``: its potential, conserving discrete force and Jacobian.

Per unit mass of the moving point, with ``d = x - c`` and ``r = |d|``::

    V(x) = -gm / r
    F(x0, x1) = -gm (d0 + d1) / (r0 r1 (r0 + r1))

Since ``(d0 + d1) . (d1 - d0) = r1^2 - r0^2``, the work is
``F . (x1 - x0) = -gm (r1 - r0) / (r0 r1) = -(V(x1) - V(x0))`` exactly in exact
arithmetic, and the quotient is formed without a difference ``r1 - r0`` (no cancellation).
``F(x, x) = -gm d / r^3`` is the field, and F is parallel to ``d0 + d1``, so an em step
keeps the angular momentum about ``c``. This is Greenspan's conserving pair force
(Greenspan 1984) and the ``g_em`` of Goettlicher & Schweizerhof
(:mod:`emorbit.kernels.gravity`).

Mutual gravity: the force per unit mass of body i due to body j is this force with
``d = x_i - x_j`` (centre ``c = 0``) and ``gm = G m_j``; the force per unit mass of j is
the opposite times ``m_i / m_j``, which the caller applies.

Jacobian, with ``k = gm / (r0 r1 (r0 + r1))`` and ``s = d0 + d1``::

    dF/dx1 = -k I + k (1 / r1 + 1 / (r0 + r1)) s d1^T / r1

Data layout: components as float64 scalars, a (3, 3) float64 array ``J`` that the
Jacobian is added into (``J[i, j] += dF_i / dx1_j``). References: D. Greenspan,
J. Comput. Phys. 56 (1984) 28-41; J. C. Simo, N. Tarnow, ZAMP 43 (1992) 757-792.
"""

from __future__ import annotations

import math

from ..jit import kernel

__all__ = ["central_potential", "central_force", "central_jacobian", "pair_unit", "pair_force"]

_inline = kernel(inline="always")


@_inline
def central_potential(x, y, z, c0, c1, c2, gm):
    """The potential of a point mass per unit mass of the moving point.

    Parameters
    ----------
    x, y, z : float
        Position of the point (m).
    c0, c1, c2 : float
        Position of the centre (m).
    gm : float
        Gravitational parameter of the centre (m^3/s^2).

    Returns
    -------
    float
        ``V = -gm / r`` (J/kg), ``r = |x - c|``.
    """
    d0 = x - c0
    d1 = y - c1
    d2 = z - c2
    return -gm / math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@_inline
def central_force(x0, y0, z0, x1, y1, z1, c0, c1, c2, gm):
    """The conserving discrete force of a point mass over the step x0 -> x1.

    Parameters
    ----------
    x0, y0, z0 : float
        Position at the start of the step (m).
    x1, y1, z1 : float
        Position at the end of the step (m).
    c0, c1, c2 : float
        Position of the centre (m).
    gm : float
        Gravitational parameter of the centre (m^3/s^2).

    Returns
    -------
    tuple of float
        ``(fx, fy, fz)``, ``F = -gm (d0 + d1) / (r0 r1 (r0 + r1))`` per unit mass
        (m/s^2), ``d = x - c``; ``F . (x1 - x0) = -(V(x1) - V(x0))``.
    """
    a0 = x0 - c0
    a1 = y0 - c1
    a2 = z0 - c2
    b0 = x1 - c0
    b1 = y1 - c1
    b2 = z1 - c2
    r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    k = -gm / (r0 * r1 * (r0 + r1))
    return k * (a0 + b0), k * (a1 + b1), k * (a2 + b2)


@_inline
def central_jacobian(x0, y0, z0, x1, y1, z1, c0, c1, c2, gm, J):
    """Add the derivative of :func:`central_force` with respect to the end point into ``J``.

    Parameters
    ----------
    x0, y0, z0 : float
        Position at the start of the step (m).
    x1, y1, z1 : float
        Position at the end of the step (m).
    c0, c1, c2 : float
        Position of the centre (m).
    gm : float
        Gravitational parameter of the centre (m^3/s^2).
    J : numpy.ndarray
        (3, 3) float64, updated in place: ``J[i, j] += dF_i / dx1_j`` (1/s^2).
    """
    a0 = x0 - c0
    a1 = y0 - c1
    a2 = z0 - c2
    b0 = x1 - c0
    b1 = y1 - c1
    b2 = z1 - c2
    r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    rs = r0 + r1
    k = gm / (r0 * r1 * rs)
    w = k * (1.0 / r1 + 1.0 / rs) / r1
    s0 = w * (a0 + b0)
    s1 = w * (a1 + b1)
    s2 = w * (a2 + b2)
    J[0, 0] += s0 * b0 - k
    J[0, 1] += s0 * b1
    J[0, 2] += s0 * b2
    J[1, 0] += s1 * b0
    J[1, 1] += s1 * b1 - k
    J[1, 2] += s1 * b2
    J[2, 0] += s2 * b0
    J[2, 1] += s2 * b1
    J[2, 2] += s2 * b2 - k


@_inline
def pair_unit(a0, a1, a2, b0, b1, b2, J):
    """A pair's force over the step per unit G m_j, and its Jacobian, in one pass (mutual gravity).

    With the pair's separation ``d = x_i - x_j`` at the start (``a``) and at the end (``b``)
    of the step: ``S = -(a + b) k``, ``k = 1 / (r0 r1 (r0 + r1))`` (:func:`central_force`
    with ``gm = 1`` and the centre at 0), and ``J = dS/db = -k I + w (a + b) b^T``,
    ``w = k (1/r1 + 1/(r0 + r1)) / r1`` (:func:`central_jacobian`). Two square roots and two
    divisions for both.

    Parameters
    ----------
    a0, a1, a2 : float
        The separation at the start of the step (m).
    b0, b1, b2 : float
        The separation at the end of the step (m).
    J : numpy.ndarray
        (3, 3) float64, overwritten with ``dS_i / db_j`` (1/m^3).

    Returns
    -------
    tuple of float
        ``S`` (3 components, 1/m^2) and a bound of the entries of ``J``, ``k (3 + r0 / r1)``.
    """
    r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    rs = r0 + r1
    k = 1.0 / (r0 * r1 * rs)
    w = k * k * r0 * (r0 + 2.0 * r1) / r1
    u0 = a0 + b0
    u1 = a1 + b1
    u2 = a2 + b2
    s0 = w * u0
    s1 = w * u1
    s2 = w * u2
    J[0, 0] = s0 * b0 - k
    J[0, 1] = s0 * b1
    J[0, 2] = s0 * b2
    J[1, 0] = s1 * b0
    J[1, 1] = s1 * b1 - k
    J[1, 2] = s1 * b2
    J[2, 0] = s2 * b0
    J[2, 1] = s2 * b1
    J[2, 2] = s2 * b2 - k
    return -k * u0, -k * u1, -k * u2, k * (3.0 + r0 / r1)


@_inline
def pair_force(a0, a1, a2, b0, b1, b2):
    """:func:`pair_unit` without the Jacobian: the force per unit G m_j and the bound.

    Parameters
    ----------
    a0, a1, a2 : float
        The separation at the start of the step (m).
    b0, b1, b2 : float
        The separation at the end of the step (m).

    Returns
    -------
    tuple of float
        ``S`` (3 components, 1/m^2) and ``k (3 + r0 / r1)``, a bound of the entries of dS/db.
    """
    r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    rs = r0 + r1
    k = 1.0 / (r0 * r1 * rs)
    return -k * (a0 + b0), -k * (a1 + b1), -k * (a2 + b2), k * (3.0 + k * r0 * r0 * rs)
