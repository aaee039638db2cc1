"""Zonal harmonics J2..J6 of the central body: potential, conserving discrete force, Jacobian.

Per unit mass, with ``d = x - c``, ``r = |d|``, ``z = d . p`` (``p`` the unit pole)::

    V(x) = (gm / r) sum_{n=2}^{N} J_n (R / r)^n P_n(z / r)        (the -gm/r part: .central)

(with J2 > 0 an oblate body attracts more at its equator). With ``P_n(s) = sum_k a_nk s^k``
(``_LEGENDRE``) and the scaled ``rho = r / R``, ``zeta = z / R`` every term is a product
``(gm / R) J_n a_nk f(rho) g(zeta)`` with ``f = rho^-m``, ``g = zeta^k``, ``m = n + 1 + k``
(odd). The averaged split of each product (an Itoh-Abe discrete gradient in rho, zeta)::

    A = 1/2 (g0 + g1) df,  df = -sum_{i<m} rho0^-(i+1) rho1^-(m-i)   (= (f1 - f0) / (rho1 - rho0))
    B = 1/2 (f0 + f1) dg,  dg = sum_{i<k} zeta0^i zeta1^(k-1-i)      (= (g1 - g0) / (zeta1 - zeta0))

gives ``A (rho1 - rho0) + B (zeta1 - zeta0) = f1 g1 - f0 g0`` exactly, with no division by
a difference (``r1 = r0`` and ``z1 = z0`` need no special case) and no cancellation in df.
Summed over the terms (A, B then in J/kg per m, after the factor 1/R), the force is::

    F = -(A (d0 + d1) / (r0 + r1) + B p)

Since ``(d0 + d1) . (d1 - d0) / (r0 + r1) = r1 - r0`` and ``p . (d1 - d0) = z1 - z0``,
``F . (x1 - x0) = -(V(x1) - V(x0))``, and F lies in the plane of ``d0 + d1`` and ``p``, so
``p . ((d0 + d1) / 2 x F) = 0``: an em step keeps the angular momentum about the pole. As
x1 -> x0, A -> dV/dr and B -> dV/dz, and F -> -grad V. Jacobian (dr1/dx1 = d1/r1,
dz1/dx1 = p, u = (d0 + d1) / (r0 + r1))::

    dF/dx1 = -(u dA/dx1^T + A du/dx1 + p dB/dx1^T),
    du/dx1 = I / (r0 + r1) - (d0 + d1) d1^T / (r1 (r0 + r1)^2)

with the r1- and z1-derivatives of df and dg from the same recurrences as the sums.

Data layout: components as float64 scalars, ``jn`` a float64 array (J2, J3, ... up to J6;
length 1..5), ``J`` a (3, 3) float64 array the Jacobian is added into (the shipped
coefficients: :func:`emorbit.effects.zonal.zonal_model`). References: T. Itoh, K. Abe, J. Comput. Phys.
76 (1988) 85-102; O. Gonzalez, J. Nonlinear Sci. 6 (1996) 449-467; N. K. Pavlis et al.,
J. Geophys. Res. 117 (2012) B04406 (EGM2008).
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import kernel

__all__ = [
    "zonal_potential",
    "zonal_force",
    "zonal_jacobian",
    "zonal_sums",
    "zonal_sums_unrolled",
    "zonal_piece",
    "zonal_potential_piece",
    "NMAX",
]

_inline = kernel(inline="always")
_force = kernel(forceinline=True)
# an effect-set piece: compiled on its own (cached per install) and inlined by LLVM into the set
_piece = kernel(forceinline=True)

#: the highest degree the kernels take (``jn`` holds J2..J_NMAX)
NMAX = 6

#: _LEGENDRE[n, k]: the coefficient of s^k in the Legendre polynomial P_n(s), n = 0..6
_LEGENDRE = np.array(
    [
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [-0.5, 0.0, 1.5, 0.0, 0.0, 0.0, 0.0],
        [0.0, -1.5, 0.0, 2.5, 0.0, 0.0, 0.0],
        [3.0 / 8.0, 0.0, -30.0 / 8.0, 0.0, 35.0 / 8.0, 0.0, 0.0],
        [0.0, 15.0 / 8.0, 0.0, -70.0 / 8.0, 0.0, 63.0 / 8.0, 0.0],
        [-5.0 / 16.0, 0.0, 105.0 / 16.0, 0.0, -315.0 / 16.0, 0.0, 231.0 / 16.0],
    ]
)


@_inline
def zonal_potential(x, y, z, c0, c1, c2, p0, p1, p2, gm, R, jn):
    """The zonal part of the central body's potential per unit mass of the moving point.

    Parameters
    ----------
    x, y, z : float
        Position of the point (m).
    c0, c1, c2 : float
        Position of the centre (m).
    p0, p1, p2 : float
        The pole, a unit vector.
    gm : float
        Gravitational parameter of the body (m^3/s^2).
    R : float
        Reference radius of the coefficients (m).
    jn : numpy.ndarray
        float64 (J2, J3, ...), at most up to J6 (length 1..5).

    Returns
    -------
    float
        ``V = (gm / r) sum_n J_n (R / r)^n P_n(z / r)`` (J/kg), ``z = (x - c) . p``.
    """
    d0 = x - c0
    d1 = y - c1
    d2 = z - c2
    rho = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) / R
    zeta = (d0 * p0 + d1 * p1 + d2 * p2) / R
    q = 1.0 / rho
    nmax = jn.shape[0] + 1
    v = 0.0
    f = q
    for m in range(2, 2 * nmax + 2):
        f *= q
        if m % 2 == 0:
            continue
        # the polynomial in zeta multiplying rho^-m: k = m - 1 - n for n = 2..nmax, k <= n
        kmin = max(0, m - 1 - nmax)
        kmax = min((m - 1) // 2, m - 3)
        g = 0.0
        zp = 1.0
        for k in range(kmax + 1):
            if k >= kmin:
                n = m - 1 - k
                g += jn[n - 2] * _LEGENDRE[n, k] * zp
            zp *= zeta
        v += f * g
    return (gm / R) * v


@_inline
def _coef(n, j2, j3, j4, j5, j6):
    """J_n of (J2, ..., J6), n = 2..6 (a constant n folds to one of them)."""
    if n == 2:
        return j2
    if n == 3:
        return j3
    if n == 4:
        return j4
    if n == 5:
        return j5
    return j6


@_inline
def zonal_sums(q0, q1, z0, z1, nmax, j2, j3, j4, j5, j6, jac):
    """The discrete partials of :func:`zonal_potential` / (gm / R) in rho = r/R, zeta = z/R.

    ``q0, q1`` = 1 / rho and ``z0, z1`` = zeta at the two ends, ``nmax`` the highest degree
    and ``j2 .. j6`` the coefficients (those above ``nmax`` unused). Returns (A, B, dA/drho1,
    dA/dzeta1, dB/drho1, dB/dzeta1); the four derivatives are zero unless ``jac``. One
    :func:`_order` per power m = 1 .. 2 nmax + 1 of 1/rho, in a loop (compact code, for a
    degree known only at run time; :func:`zonal_sums_unrolled` writes them out).
    """
    # q = 1/rho; f = q^m at both ends; S = -df = sum_{i<m} q0^(i+1) q1^(m-i) and
    # T = sum_{i<m} (m-i) q0^(i+1) q1^(m-i), so that dS/drho1 = -q1 T; from m = 1 up:
    # S' = q1 S + q0^(m+1) q1, T' = q1 (T + S) + q0^(m+1) q1 (all terms positive)
    c = (q0, q1, z0, z1, nmax, j2, j3, j4, j5, j6, jac)
    st = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, q0, q1, q0 * q1, q0 * q1)
    for m in range(1, 2 * nmax + 2):
        st = _order(m, c, st)
    return st[0], st[1], st[2], st[3], st[4], st[5]


@_inline
def zonal_sums_unrolled(q0, q1, z0, z1, nmax, j2, j3, j4, j5, j6, jac):
    """:func:`zonal_sums` with the powers written out, one call of :func:`_order` each (the
    same operations): with ``nmax`` a constant (:mod:`.zonal_packed`) every loop has a constant
    trip count and LLVM unrolls them into straight code that vectorises over points."""
    c = (q0, q1, z0, z1, nmax, j2, j3, j4, j5, j6, jac)
    st = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, q0, q1, q0 * q1, q0 * q1)
    st = _order(1, c, st)
    st = _order(2, c, st)
    st = _order(3, c, st)
    st = _order(4, c, st)
    st = _order(5, c, st)
    if nmax >= 3:
        st = _order(6, c, st)
        st = _order(7, c, st)
    if nmax >= 4:
        st = _order(8, c, st)
        st = _order(9, c, st)
    if nmax >= 5:
        st = _order(10, c, st)
        st = _order(11, c, st)
    if nmax >= 6:
        st = _order(12, c, st)
        st = _order(13, c, st)
    return st[0], st[1], st[2], st[3], st[4], st[5]


@_force
def _order(m, c, st):
    """One power m of :func:`zonal_sums`: the term of the polynomial in zeta that multiplies
    rho^-m (odd m >= 3) added to (A, B and their derivatives), then the recurrences' step to
    m + 1. ``c`` = (q0, q1, z0, z1, nmax, j2, .., j6, jac), ``st`` = (A, B, dA/drho1,
    dA/dzeta1, dB/drho1, dB/dzeta1, f0, f1, S, T); returns the new ``st``."""
    q0, q1, z0, z1, nmax, j2, j3, j4, j5, j6, jac = c
    A, B, dAr, dAz, dBr, dBz, f0, f1, S, T = st
    if m >= 3 and m % 2 == 1:
        # k from max(0, m - 1 - nmax) to min((m - 1) // 2, m - 3), written out (no call
        # to min or max: with nmax a constant the trip count is one at once)
        kmin = m - 1 - nmax if m - 1 - nmax > 0 else 0
        kmax = (m - 1) // 2 if (m - 1) // 2 < m - 3 else m - 3
        g0 = 0.0
        g1 = 0.0
        gd = 0.0  # sum c dg, dg = (g1 - g0) / (zeta1 - zeta0)
        gdd = 0.0  # sum c d(dg)/dzeta1
        g1d = 0.0  # sum c dg/dzeta at zeta1
        zp0 = 1.0
        zp1 = 1.0
        zp1m = 0.0
        G = 0.0  # dg of zeta^k: sum_{i<k} zeta0^i zeta1^(k-1-i); G' = zeta1 G + zeta0^k
        H = 0.0  # dG/dzeta1; H' = G + zeta1 H
        for k in range(kmax + 1):
            if k >= kmin:
                n = m - 1 - k
                cn = _coef(n, j2, j3, j4, j5, j6) * _LEGENDRE[n, k]
                g0 += cn * zp0
                g1 += cn * zp1
                gd += cn * G
                if jac:
                    gdd += cn * H
                    g1d += cn * k * zp1m
            H = G + z1 * H
            G = z1 * G + zp0
            zp1m = zp1
            zp0 *= z0
            zp1 *= z1
        gs = 0.5 * (g0 + g1)
        fs = 0.5 * (f0 + f1)
        A -= gs * S
        B += fs * gd
        if jac:
            dAr += gs * q1 * T
            dAz -= 0.5 * g1d * S
            dBr -= 0.5 * m * f1 * q1 * gd
            dBz += fs * gdd
    f0n = f0 * q0
    T = q1 * (T + S) + f0n * q1
    S = q1 * S + f0n * q1
    return A, B, dAr, dAz, dBr, dBz, f0n, f1 * q1, S, T


@_inline
def _zonal_parts(a0, a1, a2, b0, b1, b2, p0, p1, p2, R, jn, o, jac):
    """The discrete partials of :func:`zonal_potential` / (gm / R) in rho = r/R, zeta = z/R.

    ``a = x0 - c``, ``b = x1 - c``, J2, J3, ... from ``jn[o:]`` (read by index: no array view,
    so a loop over points that calls it keeps no reference counts). Returns (A, B, dA/drho1,
    dA/dzeta1, dB/drho1, dB/dzeta1, r0, r1) (:func:`zonal_sums`); the four derivatives are
    zero unless ``jac``."""
    r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    z0 = (a0 * p0 + a1 * p1 + a2 * p2) / R
    z1 = (b0 * p0 + b1 * p1 + b2 * p2) / R
    q0 = 1.0 / (r0 / R)
    q1 = 1.0 / (r1 / R)
    nj = jn.shape[0] - o
    A, B, dAr, dAz, dBr, dBz = zonal_sums(
        q0,
        q1,
        z0,
        z1,
        nj + 1,
        jn[o],
        jn[o + 1] if nj > 1 else 0.0,
        jn[o + 2] if nj > 2 else 0.0,
        jn[o + 3] if nj > 3 else 0.0,
        jn[o + 4] if nj > 4 else 0.0,
        jac,
    )
    return A, B, dAr, dAz, dBr, dBz, r0, r1


@_inline
def zonal_force(x0, y0, z0, x1, y1, z1, c0, c1, c2, p0, p1, p2, gm, R, jn):
    """The conserving discrete force of the zonal harmonics over the step x0 -> x1.

    Parameters
    ----------
    x0, y0, z0 : float
        Position at the start of the step (m).
    x1, y1, z1 : float
        Position at the end of the step (m).
    c0, c1, c2 : float
        Position of the centre (m).
    p0, p1, p2 : float
        The pole, a unit vector.
    gm : float
        Gravitational parameter of the body (m^3/s^2).
    R : float
        Reference radius of the coefficients (m).
    jn : numpy.ndarray
        float64 (J2, J3, ...), at most up to J6 (length 1..5).

    Returns
    -------
    tuple of float
        ``(fx, fy, fz)``, ``F = -(A (d0 + d1) / (r0 + r1) + B p)`` per unit mass (m/s^2);
        ``F . (x1 - x0) = -(V(x1) - V(x0))`` (:func:`zonal_potential`) and
        ``p . ((d0 + d1) x F) = 0``.
    """
    a0 = x0 - c0
    a1 = y0 - c1
    a2 = z0 - c2
    b0 = x1 - c0
    b1 = y1 - c1
    b2 = z1 - c2
    A, B, _, _, _, _, r0, r1 = _zonal_parts(a0, a1, a2, b0, b1, b2, p0, p1, p2, R, jn, 0, False)
    k = gm / (R * R)
    ku = -k * A / (r0 + r1)
    kp = -k * B
    return ku * (a0 + b0) + kp * p0, ku * (a1 + b1) + kp * p1, ku * (a2 + b2) + kp * p2


@_inline
def zonal_jacobian(x0, y0, z0, x1, y1, z1, c0, c1, c2, p0, p1, p2, gm, R, jn, J):
    """Add the derivative of :func:`zonal_force` with respect to the end point into ``J``.

    Parameters
    ----------
    x0, y0, z0 : float
        Position at the start of the step (m).
    x1, y1, z1 : float
        Position at the end of the step (m).
    c0, c1, c2 : float
        Position of the centre (m).
    p0, p1, p2 : float
        The pole, a unit vector.
    gm : float
        Gravitational parameter of the body (m^3/s^2).
    R : float
        Reference radius of the coefficients (m).
    jn : numpy.ndarray
        float64 (J2, J3, ...), at most up to J6 (length 1..5).
    J : numpy.ndarray
        (3, 3) float64, updated in place: ``J[i, j] += dF_i / dx1_j`` (1/s^2).
    """
    a0 = x0 - c0
    a1 = y0 - c1
    a2 = z0 - c2
    b0 = x1 - c0
    b1 = y1 - c1
    b2 = z1 - c2
    A, B, dAr, dAz, dBr, dBz, r0, r1 = _zonal_parts(a0, a1, a2, b0, b1, b2, p0, p1, p2, R, jn, 0, True)
    _add_jacobian(a0, a1, a2, b0, b1, b2, p0, p1, p2, gm, R, A, dAr, dAz, dBr, dBz, r0, r1, J)


@_inline
def _add_jacobian(a0, a1, a2, b0, b1, b2, p0, p1, p2, gm, R, A, dAr, dAz, dBr, dBz, r0, r1, J):
    """:func:`zonal_jacobian` from :func:`_zonal_parts` (``a = x0 - c``, ``b = x1 - c``)."""
    # physical units: A, B carry gm / R^2; their x1-derivatives one more 1/R
    k = gm / (R * R)
    A *= k
    kd = k / R
    # dA/dx1 = ar b + az p, dB/dx1 = br b + bz p  (b = d1; dr1/dx1 = b / r1)
    ar = kd * dAr / r1
    az = kd * dAz
    br = kd * dBr / r1
    bz = kd * dBz
    rs = r0 + r1
    s0 = a0 + b0
    s1 = a1 + b1
    s2 = a2 + b2
    u0 = s0 / rs
    u1 = s1 / rs
    u2 = s2 / rs
    # A du/dx1 = (A / rs) I - (A / (r1 rs^2)) s b^T
    ai = A / rs
    w = A / (r1 * rs * rs)
    # dF/dx1 = -(u (ar b + az p)^T + A du/dx1 + p (br b + bz p)^T)
    e0 = u0 * ar - w * s0 + p0 * br
    e1 = u1 * ar - w * s1 + p1 * br
    e2 = u2 * ar - w * s2 + p2 * br
    h0 = u0 * az + p0 * bz
    h1 = u1 * az + p1 * bz
    h2 = u2 * az + p2 * bz
    J[0, 0] -= e0 * b0 + h0 * p0 + ai
    J[0, 1] -= e0 * b1 + h0 * p1
    J[0, 2] -= e0 * b2 + h0 * p2
    J[1, 0] -= e1 * b0 + h1 * p0
    J[1, 1] -= e1 * b1 + h1 * p1 + ai
    J[1, 2] -= e1 * b2 + h1 * p2
    J[2, 0] -= e2 * b0 + h2 * p0
    J[2, 1] -= e2 * b1 + h2 * p1
    J[2, 2] -= e2 * b2 + h2 * p2 + ai


@_piece
def zonal_piece(x0, y0, z0, x1, y1, z1, h, c, p, tab, s, J, jac):
    """The effect-set piece (:mod:`.signatures`): :func:`zonal_force` and, where ``jac``,
    :func:`zonal_jacobian`, with ``p = [c0, c1, c2, p0, p1, p2, gm, R, J2, ...]``."""
    # one pass of the sums for the force and, where jac, its Jacobian (A and B do not depend on
    # jac): the arithmetic of zonal_force and zonal_jacobian, the coefficients read from p
    a0, a1, a2 = x0 - p[0], y0 - p[1], z0 - p[2]
    b0, b1, b2 = x1 - p[0], y1 - p[1], z1 - p[2]
    A, B, dAr, dAz, dBr, dBz, r0, r1 = _zonal_parts(a0, a1, a2, b0, b1, b2, p[3], p[4], p[5], p[7], p, 8, jac)
    k = p[6] / (p[7] * p[7])
    ku = -k * A / (r0 + r1)
    kp = -k * B
    if jac:
        _add_jacobian(a0, a1, a2, b0, b1, b2, p[3], p[4], p[5], p[6], p[7], A, dAr, dAz, dBr, dBz, r0, r1, J)
    return ku * (a0 + b0) + kp * p[3], ku * (a1 + b1) + kp * p[4], ku * (a2 + b2) + kp * p[5]


@_piece
def zonal_potential_piece(x, y, z, c, p, tab, s):
    """The effect-set piece: :func:`zonal_potential` with :func:`zonal_piece`'s ``p``."""
    return zonal_potential(x, y, z, p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8:])
