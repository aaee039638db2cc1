"""A rotating body's gravity field in spherical harmonics of any degree and order, and a
discrete force over a step that keeps the Jacobi integral (docs/methods.md derives both).

Field: in the body's frame y, ``r = |y|``, ``(s, t, u) = y / r``, fully normalised ``C_nm,
S_nm`` of a model (``mu``, radius ``R``), the potential of the degrees ``1..N`` (degree 0 is the
central field's) in Pines' singularity-free form::

    U = sum_n (mu / r) (R / r)^n sum_{m <= min(n, M)} A_nm(u) (C_nm Re (s+it)^m + S_nm Im (s+it)^m)

``A_nm = P_nm / (1 - u^2)^(m/2)``, the normalised derived Legendre functions, by the column
recursion ``A_nm = a_nm u A_{n-1,m} - b_nm A_{n-2,m}`` from ``A_mm`` (stable to high degree; no
division by the latitude's cosine); the gradient from ``A_nm``, ``A_{n,m+1}``, ``(s+it)^(m-1)``.

Rotation: ``y = P Rz(theta)^T B^T (x - c)``, ``B = [e1 e2 e3]``: uniform (B and P fixed,
``theta = theta0 + w t``), or tabulated (the Earth's ITRS: B = RC2I^T, P the polar motion and
theta's departure from uniform sampled every ``step`` and interpolated, cubic, per sub-step;
the step's turn from the rotation ``M_b^T M_a`` between its ends, ``M`` the frame's matrix).

Force per unit mass over x0 -> x1 (offsets from c, middle x_m) from t0 to t0 + h, with the
step's Cayley turn ``h w_h = 2 tan(w h / 2)``::

    delta = (x1 - x0) - h w_h e3 x x_m,  dU = U(x1, t1) - U(x0, t0),  g = grad U(x_m, t_m)
    F = g + ((dU - g . delta) / (delta . delta)) delta      (so F . delta = dU)

Gonzalez's midpoint discrete gradient along the rotating frame's move: an em step then keeps
``E - w_h . L`` to round-off (``delta`` is the body-frame move scaled by sec(w h / 2) across
the pole, so the correction stays O(h^2) even for a satellite at rest over the ground). The
correction is left out where ``|dU - g . delta|`` is within 8
eps of ``|U0| + |U1|``; with x0 = x1 the force is g. The field's work over the step is ``W =
F . (x1 - x0) - dU``. No Jacobian (the central effect's carries Newton).

Data layout: ``p = [c0, c1, c2, B (9, row-major), theta0, w, mu, R, N, M, P (9, row-major),
tabulated, step, k0, rows]``; ``tab`` the
triangular arrays (index ``n (n + 1) / 2 + m``) C, S, a, b, q (``dA_nm/du = q_nm A_{n,m+1}``),
then ``A_mm`` (N + 1,) (:func:`tables`), then a tabulated frame's rows (19 each: B, P, the
angle's departure); ``s`` cos and sin of the angle at the sub-step's start, middle and end,
h, the last start (x0, its angle's cos and sin, U there), B and P at the three times (54), the
step's turn (3), the recursion's two columns (2 (N + 2)). References: S. Pines,
AIAA J. 11 (1973) 1508-1511; S. A. Holmes, W. E. Featherstone, J. Geodesy 76 (2002) 279-299;
O. Gonzalez, J. Nonlinear Sci. 6 (1996) 449-467.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import kernel

__all__ = [
    "tables",
    "field_body",
    "field_at",
    "gravity_field_force",
    "gravity_field_prepare",
    "gravity_field_piece",
    "gravity_field_time_work",
    "gravity_field_potential_piece",
    "P_SIZE",
]

_EPS = 2.0**-52
#: the length of ``p``
P_SIZE = 31
_inline = kernel(inline="always")
# an effect-set piece: compiled on its own (cached per install) and inlined by LLVM into the set
_piece = kernel(forceinline=True)


def tables(C, S, degree, order):
    """The flat table of a field truncated at ``degree`` and ``order``.

    Parameters
    ----------
    C, S : numpy.ndarray
        (N + 1, N + 1) fully normalised coefficients, ``C[n, m]`` (N >= degree).
    degree, order : int
        N and M of the truncation (1 <= M <= N).

    Returns
    -------
    numpy.ndarray
        ``C, S, a, b, q`` (triangular, (N + 1)(N + 2) / 2 each) and the diagonal ``A_mm``.
    """
    n_max = int(degree)
    size = (n_max + 1) * (n_max + 2) // 2
    out = np.zeros((5, size))
    for n in range(n_max + 1):
        for m in range(n + 1):
            k = n * (n + 1) // 2 + m
            if m <= order:
                out[0, k] = C[n, m]
                out[1, k] = S[n, m]
            if n > m:
                out[2, k] = math.sqrt((2 * n + 1) * (2 * n - 1) / ((n - m) * (n + m)))
                if n > m + 1:
                    out[3, k] = math.sqrt((2 * n + 1) * (n + m - 1) * (n - m - 1) / ((2 * n - 3) * (n + m) * (n - m)))
            out[4, k] = math.sqrt((2.0 - (m == 0)) * (n - m) * (n + m + 1) / 2.0)
    diag = np.ones(n_max + 1)
    for m in range(1, n_max + 1):
        diag[m] = math.sqrt(3.0) if m == 1 else diag[m - 1] * math.sqrt((2 * m + 1) / (2 * m))
    return np.concatenate([out.ravel(), diag])


@kernel
def field_body(y0, y1, y2, mu, radius, n_max, m_max, tab, grad, work):
    """The potential U (m^2/s^2, degrees 1..N) at a point of the body's frame and, where
    ``grad``, its gradient (m/s^2): (U, gx, gy, gz). ``work``: 2 (N + 2) values of scratch."""
    size = (n_max + 1) * (n_max + 2) // 2
    C = tab[0:size]
    S = tab[size : 2 * size]
    a = tab[2 * size : 3 * size]
    b = tab[3 * size : 4 * size]
    q = tab[4 * size : 5 * size]
    diag = tab[5 * size : 5 * size + n_max + 1]
    r2 = y0 * y0 + y1 * y1 + y2 * y2
    r = math.sqrt(r2)
    s = y0 / r
    t = y1 / r
    u = y2 / r
    ratio = radius / r
    even = work[0 : n_max + 2]  # the columns A_{., m} and A_{., m+1}, alternating
    odd = work[n_max + 2 : 2 * n_max + 4]
    even[0] = 1.0  # column 0
    if n_max >= 1:
        even[1] = a[1] * u
    for n in range(2, n_max + 1):
        k = n * (n + 1) // 2
        even[n] = a[k] * u * even[n - 1] - b[k] * even[n - 2]
    pot = 0.0
    gx = 0.0
    gy = 0.0
    gz = 0.0
    rm = 1.0  # Re (s + i t)^m
    im = 0.0
    rp = 0.0  # Re (s + i t)^(m - 1)
    ip = 0.0
    start = mu / r * ratio  # (mu / r) (R / r)^max(m, 1)
    for m in range(min(m_max, n_max) + 1):
        col, nxt = (even, odd) if m % 2 == 0 else (odd, even)
        mm = m + 1  # the column m + 1: A_{n,m+1} = 0 for n < m + 1
        nxt[m] = 0.0
        if mm <= n_max:
            nxt[mm] = diag[mm]
            if mm + 1 <= n_max:
                k = (mm + 1) * (mm + 2) // 2 + mm
                nxt[mm + 1] = a[k] * u * nxt[mm]
            for n in range(mm + 2, n_max + 1):
                k = n * (n + 1) // 2 + mm
                nxt[n] = a[k] * u * nxt[n - 1] - b[k] * nxt[n - 2]
        if m > 1:
            start *= ratio
        rho = start
        for n in range(max(m, 1), n_max + 1):
            k = n * (n + 1) // 2 + m
            c = C[k]
            sn = S[k]
            if c != 0.0 or sn != 0.0:
                A = col[n]
                d = c * rm + sn * im
                pot += rho * A * d
                if grad:
                    dA = q[k] * nxt[n]
                    w = rho / r
                    common = ((n + m + 1) * A + u * dA) * d
                    if m > 0:
                        e = c * rp + sn * ip
                        f = sn * rp - c * ip
                        gx += w * (m * A * e - s * common)
                        gy += w * (m * A * f - t * common)
                    else:
                        gx -= w * s * common
                        gy -= w * t * common
                    gz += w * (dA * d - u * common)
            rho *= ratio
        rp = rm
        ip = im
        rm = s * rp - t * ip
        im = s * ip + t * rp
    return pot, gx, gy, gz


@_inline
def _to_body(d0, d1, d2, f, ob, op, cs, sn):
    """Body coordinates of the inertial offset d: ``P Rz(theta)^T B^T d``, B and P (row-major)
    at ``f[ob:ob+9]`` and ``f[op:op+9]``, theta's (cos, sin)."""
    b0 = f[ob] * d0 + f[ob + 3] * d1 + f[ob + 6] * d2  # B^T d
    b1 = f[ob + 1] * d0 + f[ob + 4] * d1 + f[ob + 7] * d2
    b2 = f[ob + 2] * d0 + f[ob + 5] * d1 + f[ob + 8] * d2
    r0 = cs * b0 + sn * b1
    r1 = -sn * b0 + cs * b1
    return (
        f[op] * r0 + f[op + 1] * r1 + f[op + 2] * b2,
        f[op + 3] * r0 + f[op + 4] * r1 + f[op + 5] * b2,
        f[op + 6] * r0 + f[op + 7] * r1 + f[op + 8] * b2,
    )


@_inline
def _to_inertial(g0, g1, g2, f, ob, op, cs, sn):
    """An inertial vector from body components: ``B Rz(theta) P^T g`` (as :func:`_to_body`)."""
    q0 = f[op] * g0 + f[op + 3] * g1 + f[op + 6] * g2
    q1 = f[op + 1] * g0 + f[op + 4] * g1 + f[op + 7] * g2
    q2 = f[op + 2] * g0 + f[op + 5] * g1 + f[op + 8] * g2
    a0 = cs * q0 - sn * q1
    a1 = sn * q0 + cs * q1
    return (
        f[ob] * a0 + f[ob + 1] * a1 + f[ob + 2] * q2,
        f[ob + 3] * a0 + f[ob + 4] * a1 + f[ob + 5] * q2,
        f[ob + 6] * a0 + f[ob + 7] * a1 + f[ob + 8] * q2,
    )


#: the scratch's offsets: B and P at the sub-step's start, middle and end, the step's turn
_SB, _SP, _SK, _WORK = 13, 40, 67, 70


@_inline
def field_at(d0, d1, d2, p, tab, s, x, grad, work):
    """U and its inertial gradient at the inertial offset d from the centre, the body as the
    scratch holds it at the sub-step's start (x = 0), middle (1) or end (2)."""
    cs, sn = s[2 * x], s[2 * x + 1]
    ob, op = _SB + 9 * x, _SP + 9 * x
    y0, y1, y2 = _to_body(d0, d1, d2, s, ob, op, cs, sn)
    pot, g0, g1, g2 = field_body(y0, y1, y2, p[14], p[15], int(p[16]), int(p[17]), tab, grad, work)
    if not grad:
        return pot, 0.0, 0.0, 0.0
    a0, a1, a2 = _to_inertial(g0, g1, g2, s, ob, op, cs, sn)
    return pot, a0, a1, a2


@_inline
def gravity_field_force(x0, y0, z0, x1, y1, z1, p, tab, s):
    """The discrete force per unit mass over the prepared sub-step (the module docstring) and
    the field's potential change dU = U(x1, t1) - U(x0, t0): (fx, fy, fz, dU)."""
    a0 = x0 - p[0]
    a1 = y0 - p[1]
    a2 = z0 - p[2]
    b0 = x1 - p[0]
    b1 = y1 - p[1]
    b2 = z1 - p[2]
    m0 = 0.5 * (a0 + b0)
    m1 = 0.5 * (a1 + b1)
    m2 = 0.5 * (a2 + b2)
    work = s[_WORK:]
    um, g0, g1, g2 = field_at(m0, m1, m2, p, tab, s, 1, True, work)
    if a0 == b0 and a1 == b1 and a2 == b2:
        return g0, g1, g2, 0.0
    # U(x0, t0) is the same in every Newton sweep of a point's step: kept with its x0 and angle
    if s[7] == a0 and s[8] == a1 and s[9] == a2 and s[10] == s[0] and s[11] == s[1]:
        u0 = s[12]
    else:
        u0 = field_at(a0, a1, a2, p, tab, s, 0, False, work)[0]
        s[7], s[8], s[9], s[10], s[11], s[12] = a0, a1, a2, s[0], s[1], u0
    u1 = field_at(b0, b1, b2, p, tab, s, 2, False, work)[0]
    e0 = s[_SK]  # the step's turn: twice its Gibbs vector, 2 tan(phi / 2) n
    e1 = s[_SK + 1]
    e2 = s[_SK + 2]
    v0 = (b0 - a0) - (e1 * m2 - e2 * m1)
    v1 = (b1 - a1) - (e2 * m0 - e0 * m2)
    v2 = (b2 - a2) - (e0 * m1 - e1 * m0)
    du = u1 - u0
    res = du - (g0 * v0 + g1 * v1 + g2 * v2)
    vv = v0 * v0 + v1 * v1 + v2 * v2
    if vv > 0.0 and abs(res) > 8.0 * _EPS * (abs(u0) + abs(u1)):
        c = res / vv
        return g0 + c * v0, g1 + c * v1, g2 + c * v2, du
    return g0, g1, g2, du


@_inline
def _sample(p, tab, t, s, x):
    """The tabulated frame at time t into the scratch's slot x (B, P, the angle's cos and sin):
    cubic Lagrange interpolation of each entry over the four samples around t."""
    n_max = int(p[16])
    size = (n_max + 1) * (n_max + 2) // 2
    base = 5 * size + n_max + 1
    step, k0, rows = p[28], p[29], int(p[30])
    u = t / step  # on the grid anchored at the epoch: a table that starts later gives the same bits
    g = math.floor(u)
    j = min(max(int(g - k0), 1), rows - 3)
    tau = u - (j + k0)
    w0 = -tau * (tau - 1.0) * (tau - 2.0) / 6.0
    w1 = (tau + 1.0) * (tau - 1.0) * (tau - 2.0) / 2.0
    w2 = -(tau + 1.0) * tau * (tau - 2.0) / 2.0
    w3 = (tau + 1.0) * tau * (tau - 1.0) / 6.0
    r = base + 19 * (j - 1)
    for e in range(9):
        s[_SB + 9 * x + e] = w0 * tab[r + e] + w1 * tab[r + 19 + e] + w2 * tab[r + 38 + e] + w3 * tab[r + 57 + e]
        q = r + 9 + e
        s[_SP + 9 * x + e] = w0 * tab[q] + w1 * tab[q + 19] + w2 * tab[q + 38] + w3 * tab[q + 57]
    q = r + 18
    th = p[12] + p[13] * t + (w0 * tab[q] + w1 * tab[q + 19] + w2 * tab[q + 38] + w3 * tab[q + 57])
    s[2 * x], s[2 * x + 1] = math.cos(th), math.sin(th)


@_inline
def _matrix(s, x):
    """The body frame's matrix ``M = P Rz(theta)^T B^T`` of the scratch's slot x (y = M d)."""
    M = np.empty((3, 3))
    for c in range(3):
        e = np.zeros(3)
        e[c] = 1.0
        y0, y1, y2 = _to_body(e[0], e[1], e[2], s, _SB + 9 * x, _SP + 9 * x, s[2 * x], s[2 * x + 1])
        M[0, c], M[1, c], M[2, c] = y0, y1, y2
    return M


# -- the pieces of an effect set (.signatures)


@_piece
def gravity_field_prepare(ta, tm, tb, p, tab, s):
    """The body's frame at the sub-step's start, middle and end (the angle's cos and sin into
    s[0:6], B and P into s[13:67]), the sub-step's length (s[6]) and its turn (s[67:70]):
    ``2 tan(w h / 2) e3`` for a uniform rotation, twice the Gibbs vector of the rotation
    ``M_b^T M_a`` that carries the body from ta to tb for a tabulated one."""
    s[6] = tb - ta
    if p[27] == 0.0:
        for x, t in ((0, ta), (1, tm), (2, tb)):
            th = p[12] + p[13] * t
            s[2 * x], s[2 * x + 1] = math.cos(th), math.sin(th)
            for e in range(9):
                s[_SB + 9 * x + e] = p[3 + e]
                s[_SP + 9 * x + e] = p[18 + e]
        k = 2.0 * math.tan(0.5 * p[13] * (tb - ta))  # h w_h: the step's turn, Cayley's
        s[_SK], s[_SK + 1], s[_SK + 2] = k * p[5], k * p[8], k * p[11]
        return
    _sample(p, tab, ta, s, 0)
    _sample(p, tab, tm, s, 1)
    _sample(p, tab, tb, s, 2)
    R = _matrix(s, 2).T @ _matrix(s, 0)
    den = 1.0 + R[0, 0] + R[1, 1] + R[2, 2]
    s[_SK] = 2.0 * (R[2, 1] - R[1, 2]) / den
    s[_SK + 1] = 2.0 * (R[0, 2] - R[2, 0]) / den
    s[_SK + 2] = 2.0 * (R[1, 0] - R[0, 1]) / den


@_piece
def gravity_field_piece(x0, y0, z0, x1, y1, z1, h, c, p, tab, s, J, jac):
    """:func:`gravity_field_force` (no Jacobian: the central effect's carries Newton)."""
    f0, f1, f2, _ = gravity_field_force(x0, y0, z0, x1, y1, z1, p, tab, s)
    return f0, f1, f2


@_piece
def gravity_field_time_work(x0, y0, z0, x1, y1, z1, c, p, tab, s):
    """The work per unit mass of the field's motion over the sub-step: the energy the step's
    force leaves, ``F . (x1 - x0) - dU``."""
    f0, f1, f2, du = gravity_field_force(x0, y0, z0, x1, y1, z1, p, tab, s)
    return f0 * (x1 - x0) + f1 * (y1 - y0) + f2 * (z1 - z0) - du


@_piece
def gravity_field_potential_piece(x, y, z, c, p, tab, s):
    """The potential energy per unit mass, ``-U``, at the prepared middle time."""
    return -field_at(x - p[0], y - p[1], z - p[2], p, tab, s, 1, False, s[_WORK:])[0]
