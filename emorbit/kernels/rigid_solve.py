"""Newton's linear algebra and predictor for the rigid-body step (:func:`.rigid.rigid_step`).

Each Newton iteration of the director step solves the saddle-point system::

    [ A        h/2 G05^T ] [dx]   [r]        A = M - (h^2/2) K + (h/4) S (x) I3   (12 x 12)
    [ es G1    0         ] [dy] = [g]        G05 = G(q05), G1 = G(q1)            (6 x 12)

with ``M = diag(m I3, E (x) I3)``, ``S`` the symmetric matrix of the multipliers and ``K``
the chord load stiffness. Where K acts on the centre of mass alone (free bodies,
``GRAVITY_POINT``, no facets), :func:`kkt_solve` solves it in null-space form: the
directors' correction is ``D1^-T (Sig + W)`` with ``Sig`` symmetric (fixed by the constraint
rows) and ``W`` skew, whose 3 unknowns come from a 3 x 3 system; the rest are 3 x 3 blocks.
Otherwise :func:`dense_solve` eliminates the 18 x 18 matrix (partial pivoting), also the
fallback where a 3 x 3 block is singular. Same equations, same solution to round-off.
:func:`lu` and :func:`lu_solve` keep the factors for several right-hand sides (the time
finite element's Newton, :mod:`.rigid_tfe_newton`).

K for ``GRAVITY_VOLUME`` is the sum over the mass points or, for a body small against its
distance (``h^2 GM rho / r^4 <= 1e-8``, rho the farthest mass point from the centre of
mass), the centre of mass's field derivative ``K_c`` as ``diag(m K_c, E (x) K_c)``
(:func:`central_stiffness`): no per-point Jacobian, and the chord contracts by a few times
that bound per iterate. :func:`predict` starts Newton on the scheme's own expansion.

Reference: M. Benzi, G. H. Golub, J. Liesen, Numerical solution of saddle point problems,
Acta Numerica 14 (2005) 1-137, section 6 (null-space methods).
"""

from __future__ import annotations

import math

import numpy as np

from .codes import GRAVITY_NONE
from .gravity import accel
from .jit import kernel

__all__ = [
    "predict",
    "central_stiffness",
    "dense_solve",
    "dense_kkt",
    "inv3",
    "kkt_solve",
    "body_radius",
    "lu",
    "lu_solve",
]

_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


@kernel(inline="always")
def _pivot(A, col, n):
    """Partial pivoting at column ``col``: swap the row of the largest ``|A[r, col]|``, r >=
    col, into row col (whole rows); returns that row, or -1 where the column is zero."""
    p = col
    big = abs(A[col, col])
    for r in range(col + 1, n):
        if abs(A[r, col]) > big:
            big = abs(A[r, col])
            p = r
    if not (big > 0.0):
        return -1
    if p != col:
        for j in range(n):
            t = A[col, j]
            A[col, j] = A[p, j]
            A[p, j] = t
    return p


@kernel
def dense_solve(A, b, n):
    """Solve A x = b in place (b becomes x) by Gaussian elimination with partial pivoting.
    Returns False if A is singular."""
    for col in range(n):
        p = _pivot(A, col, n)
        if p < 0:
            return False
        if p != col:
            t = b[col]
            b[col] = b[p]
            b[p] = t
        inv = 1.0 / A[col, col]
        for r in range(col + 1, n):
            f = A[r, col] * inv
            if f != 0.0:
                for j in range(col + 1, n):
                    A[r, j] -= f * A[col, j]
                b[r] -= f * b[col]
    for r in range(n - 1, -1, -1):
        s = b[r]
        for j in range(r + 1, n):
            s -= A[r, j] * b[j]
        b[r] = s / A[r, r]
    return True


@kernel
def lu(A, piv, n):
    """LU factors of A in place (partial pivoting, rows swapped whole, the multipliers below
    the diagonal), the pivot rows in ``piv``, for :func:`lu_solve`; False if A is singular."""
    for col in range(n):
        p = _pivot(A, col, n)
        if p < 0:
            return False
        piv[col] = p
        inv = 1.0 / A[col, col]
        for r in range(col + 1, n):
            A[r, col] *= inv
            f = A[r, col]
            if f != 0.0:
                for j in range(col + 1, n):
                    A[r, j] -= f * A[col, j]
    return True


@kernel(forceinline=True)
def lu_solve(A, piv, b, n):
    """Solve with :func:`lu`'s factors, b in place: the row swaps first (the factors' rows
    were swapped whole, multipliers included), then the two triangles."""
    for col in range(n):
        p = piv[col]
        if p != col:
            t = b[col]
            b[col] = b[p]
            b[p] = t
    for col in range(n):
        for r in range(col + 1, n):
            b[r] -= A[r, col] * b[col]
    for r in range(n - 1, -1, -1):
        s = b[r]
        for j in range(r + 1, n):
            s -= A[r, j] * b[j]
        b[r] = s / A[r, r]


@kernel
def dense_kkt(J, K, m, E, S, G05, G1, h, es):
    """The Newton matrix (18, 18) [[M - h^2/2 K + h/4 S (x) I3, h/2 G05^T], [es G1, 0]] into J."""
    hf = 0.5 * h
    hh = hf * h
    for r in range(12):
        for s_ in range(12):
            J[r, s_] = -hh * K[r, s_]
    for d in range(3):
        J[d, d] += m
        for k in range(3):
            for l in range(3):
                J[3 + 3 * k + d, 3 + 3 * l + d] += E[k, l] + 0.5 * hf * S[k, l]
    for j in range(6):
        for r in range(12):
            J[r, 12 + j] = hf * G05[j, r]
            J[12 + j, r] = es * G1[j, r]
        for r in range(6):
            J[12 + j, 12 + r] = 0.0


@kernel
def central_stiffness(K, m, E):
    """K (12, 12) = diag(m K_c, E (x) K_c) from K_c = K[:3, :3] (the field's derivative at the
    centre of mass, per unit mass): the load stiffness of a body whose mass points all feel
    the centre's field derivative; the error is of the order of the body's size over its
    distance, and Newton's chord contracts by h^2/2 times it."""
    k00, k01, k02 = K[0, 0], K[0, 1], K[0, 2]
    k10, k11, k12 = K[1, 0], K[1, 1], K[1, 2]
    k20, k21, k22 = K[2, 0], K[2, 1], K[2, 2]
    Kc = ((k00, k01, k02), (k10, k11, k12), (k20, k21, k22))
    for a in range(4):
        for b in range(4):
            w = m if a == 0 and b == 0 else (0.0 if a == 0 or b == 0 else E[a - 1, b - 1])
            for d in range(3):
                for e in range(3):
                    K[3 * a + d, 3 * b + e] = w * Kc[d][e]


@kernel
def inv3(sc, i, o):
    """sc[o] = sc[i]^-1 (3 x 3 slots of sc) by cofactors; returns False if sc[i] is singular
    (or not finite). Slots, not views: a view costs a reference-count update."""
    c00 = sc[i, 1, 1] * sc[i, 2, 2] - sc[i, 1, 2] * sc[i, 2, 1]
    c01 = sc[i, 1, 2] * sc[i, 2, 0] - sc[i, 1, 0] * sc[i, 2, 2]
    c02 = sc[i, 1, 0] * sc[i, 2, 1] - sc[i, 1, 1] * sc[i, 2, 0]
    det = sc[i, 0, 0] * c00 + sc[i, 0, 1] * c01 + sc[i, 0, 2] * c02
    if not (abs(det) > 0.0 and abs(det) < math.inf):
        return False
    f = 1.0 / det
    sc[o, 0, 0] = c00 * f
    sc[o, 1, 0] = c01 * f
    sc[o, 2, 0] = c02 * f
    sc[o, 0, 1] = (sc[i, 0, 2] * sc[i, 2, 1] - sc[i, 0, 1] * sc[i, 2, 2]) * f
    sc[o, 1, 1] = (sc[i, 0, 0] * sc[i, 2, 2] - sc[i, 0, 2] * sc[i, 2, 0]) * f
    sc[o, 2, 1] = (sc[i, 0, 1] * sc[i, 2, 0] - sc[i, 0, 0] * sc[i, 2, 1]) * f
    sc[o, 0, 2] = (sc[i, 0, 1] * sc[i, 1, 2] - sc[i, 0, 2] * sc[i, 1, 1]) * f
    sc[o, 1, 2] = (sc[i, 0, 2] * sc[i, 1, 0] - sc[i, 0, 0] * sc[i, 1, 2]) * f
    sc[o, 2, 2] = (sc[i, 0, 0] * sc[i, 1, 1] - sc[i, 0, 1] * sc[i, 1, 0]) * f
    return True


@kernel
def _axial(sc, z, p):
    """Twice the axial vector of the skew part of ``sc[z] sc[p]`` (3 x 3 slots)."""
    m21 = sc[z, 2, 0] * sc[p, 0, 1] + sc[z, 2, 1] * sc[p, 1, 1] + sc[z, 2, 2] * sc[p, 2, 1]
    m12 = sc[z, 1, 0] * sc[p, 0, 2] + sc[z, 1, 1] * sc[p, 1, 2] + sc[z, 1, 2] * sc[p, 2, 2]
    m02 = sc[z, 0, 0] * sc[p, 0, 2] + sc[z, 0, 1] * sc[p, 1, 2] + sc[z, 0, 2] * sc[p, 2, 2]
    m20 = sc[z, 2, 0] * sc[p, 0, 0] + sc[z, 2, 1] * sc[p, 1, 0] + sc[z, 2, 2] * sc[p, 2, 0]
    m10 = sc[z, 1, 0] * sc[p, 0, 0] + sc[z, 1, 1] * sc[p, 1, 0] + sc[z, 1, 2] * sc[p, 2, 0]
    m01 = sc[z, 0, 0] * sc[p, 0, 1] + sc[z, 0, 1] * sc[p, 1, 1] + sc[z, 0, 2] * sc[p, 2, 1]
    return m21 - m12, m02 - m20, m10 - m01


@kernel
def kkt_solve(rhs, m, E, Kt, S, q05, q1, h, es, sc):
    """Solve the Newton system (module docstring) in place, rhs (18,) becoming (dx, dy), when
    K is zero outside its centre-of-mass block ``Kt`` (3 x 3, mass included).

    Null-space form: the directors' correction is ``dX = D1^-T C`` with ``C = Sig + W``,
    ``Sig`` the symmetric matrix that the constraint rows fix and ``W`` skew (3 unknowns w).
    With ``Z = D1^T D05`` and ``B = E + (h/4) S`` the director rows read
    ``Z^-1 (D1^T R - C B) = (h/2) Y`` (R: the director rows' right-hand side); Y symmetric
    gives 3 equations for w (the skew part), then Y is the symmetric part. S (3, 3) the
    multipliers' matrix; q05, q1 (12,) the configurations of G05 and G1; es the constraint
    rows' scale; sc (9, 3, 3) scratch (slots 0 B, 1 L^-1, 2 Z^-1, 3 D1^-1, 8 the centre of
    mass's inverse). Returns False, rhs untouched, if a 3 x 3 block is singular (the caller
    then solves the full matrix).
    """
    hf = 0.5 * h
    # centre of mass: (m I - h^2/2 Kt)^-1 (slot 8)
    for d in range(3):
        for e in range(3):
            sc[7, d, e] = -hf * h * Kt[d, e]
        sc[7, d, d] += m
    # Z = D1^T D05 and D1 (columns d1_k); their inverses (slots 2, 3); B = E + (h/4) S
    for a in range(3):
        for b in range(3):
            sc[0, a, b] = E[a, b] + 0.5 * hf * S[a, b]
            sc[6, a, b] = (
                q1[3 + 3 * a] * q05[3 + 3 * b] + q1[4 + 3 * a] * q05[4 + 3 * b] + q1[5 + 3 * a] * q05[5 + 3 * b]
            )
            sc[4, a, b] = q1[3 + 3 * b + a]
    if not (inv3(sc, 7, 8) and inv3(sc, 6, 2) and inv3(sc, 4, 3)):
        return False
    # L: column a = axial(Zi (e_a x B)) (e_a x each column of B); its inverse (slot 1)
    for a in range(3):
        a1 = (a + 1) % 3
        a2 = (a + 2) % 3
        for j in range(3):  # e_a x v = (component a: 0, a+1: -v_(a+2), a+2: v_(a+1))
            sc[6, a, j] = 0.0
            sc[6, a1, j] = -sc[0, a2, j]
            sc[6, a2, j] = sc[0, a1, j]
        l0, l1, l2 = _axial(sc, 2, 6)
        sc[7, 0, a] = l0
        sc[7, 1, a] = l1
        sc[7, 2, a] = l2
    if not inv3(sc, 7, 1):
        return False
    r0, r1, r2 = rhs[0], rhs[1], rhs[2]
    for d in range(3):
        rhs[d] = sc[8, d, 0] * r0 + sc[8, d, 1] * r1 + sc[8, d, 2] * r2
    # Sig from the constraint rows (in C), Q = D1^T R - Sig B, L w = axial(Zi Q)
    for k in range(3):
        sc[5, k, k] = rhs[12 + k] / es
    sc[5, 0, 1] = sc[5, 1, 0] = 0.5 * rhs[15] / es
    sc[5, 0, 2] = sc[5, 2, 0] = 0.5 * rhs[16] / es
    sc[5, 1, 2] = sc[5, 2, 1] = 0.5 * rhs[17] / es
    for a in range(3):
        for k in range(3):
            sc[4, a, k] = (
                q1[3 + 3 * a] * rhs[3 + 3 * k] + q1[4 + 3 * a] * rhs[4 + 3 * k] + q1[5 + 3 * a] * rhs[5 + 3 * k]
            ) - (sc[5, a, 0] * sc[0, 0, k] + sc[5, a, 1] * sc[0, 1, k] + sc[5, a, 2] * sc[0, 2, k])
    b0, b1, b2 = _axial(sc, 2, 4)
    w0 = sc[1, 0, 0] * b0 + sc[1, 0, 1] * b1 + sc[1, 0, 2] * b2
    w1 = sc[1, 1, 0] * b0 + sc[1, 1, 1] * b1 + sc[1, 1, 2] * b2
    w2 = sc[1, 2, 0] * b0 + sc[1, 2, 1] * b1 + sc[1, 2, 2] * b2
    # C = Sig + W, Q -= W B, (h/2) Y = sym(Zi Q)
    sc[5, 0, 1] -= w2
    sc[5, 1, 0] += w2
    sc[5, 0, 2] += w1
    sc[5, 2, 0] -= w1
    sc[5, 1, 2] -= w0
    sc[5, 2, 1] += w0
    for j in range(3):
        x, y, z = sc[0, 0, j], sc[0, 1, j], sc[0, 2, j]
        sc[4, 0, j] -= w1 * z - w2 * y
        sc[4, 1, j] -= w2 * x - w0 * z
        sc[4, 2, j] -= w0 * y - w1 * x
    for a in range(3):
        for b in range(3):
            sc[7, a, b] = sc[2, a, 0] * sc[4, 0, b] + sc[2, a, 1] * sc[4, 1, b] + sc[2, a, 2] * sc[4, 2, b]
    for k in range(3):
        rhs[12 + k] = sc[7, k, k] / hf
    rhs[15] = 0.5 * (sc[7, 0, 1] + sc[7, 1, 0]) / hf
    rhs[16] = 0.5 * (sc[7, 0, 2] + sc[7, 2, 0]) / hf
    rhs[17] = 0.5 * (sc[7, 1, 2] + sc[7, 2, 1]) / hf
    # dX = D1^-T C: dx_k[d] = sum_a sc[3, a, d] sc[5, a, k]
    for k in range(3):
        for d in range(3):
            rhs[3 + 3 * k + d] = sc[3, 0, d] * sc[5, 0, k] + sc[3, 1, d] * sc[5, 1, k] + sc[3, 2, d] * sc[5, 2, k]
    return True


@kernel(inline="always")
def predict(model, q0, v0, lam, Einv, gm, c, h, dq):
    """Newton's starting point dq (12,) for the step; returns False if the centre of mass is at
    the field's centre.

    Centre of mass: the scheme's own Taylor expansion, ``h v0 + h^2/2 (g + h/2 dg/dt)`` (g_em
    is the field at about the midpoint), for a step that resolves the orbit (h^2 GM / r^3 <
    0.1), else ``h v0 + h^2/2 g``. Axes: turned by the Cayley map of ``(h/2) w`` (the scheme's
    own rotation for a steady spin: (d1 - d0) = h/2 w x (d0 + d1), by 2 atan(h |w| / 2)),
    with the midpoint rate ``w = w0 + (h/2) dw/dt``. ``w0 = 1/2 sum d_k x v_k``;
    ``dw/dt = 1/2 sum d_k x a_k`` with the axes' accelerations of the last step's multipliers
    ``lam`` (``E a_k = -sum_l Lam_kl d_l``, the constraint forces that turn the axes; the
    torque's share is left out), used while ``h |dw/dt| <= |w0|``.
    """
    hf = 0.5 * h
    gx = gy = gz = 0.0
    if model != GRAVITY_NONE:
        ax, ay, az = c[0] - q0[0], c[1] - q0[1], c[2] - q0[2]
        gx, gy, gz, r = accel(ax, ay, az, gm)
        if not (r > 0.0):
            return False
        k3 = gm / (r * r * r)
        if h * h * k3 < 0.1:  # + h/2 dg/dt, dg/dt = GM (3 a (a.v) / r^5 - v / r^3), a = c - x
            av = 3.0 * (ax * v0[0] + ay * v0[1] + az * v0[2]) / (r * r)
            gx += hf * k3 * (av * ax - v0[0])
            gy += hf * k3 * (av * ay - v0[1])
            gz += hf * k3 * (av * az - v0[2])
    dq[0] = h * (v0[0] + hf * gx)
    dq[1] = h * (v0[1] + hf * gy)
    dq[2] = h * (v0[2] + hf * gz)
    wx = wy = wz = 0.0
    for k in range(3):
        dx, dy, dz = q0[3 + 3 * k], q0[4 + 3 * k], q0[5 + 3 * k]
        ex, ey, ez = v0[3 + 3 * k], v0[4 + 3 * k], v0[5 + 3 * k]
        wx += 0.5 * (dy * ez - dz * ey)
        wy += 0.5 * (dz * ex - dx * ez)
        wz += 0.5 * (dx * ey - dy * ex)
    # dw/dt = -1/2 sum_(k<l) (C_kl - C_lk) d_k x d_l, C = E^-1 Lam
    ux = uy = uz = 0.0
    for j in range(3, 6):
        k, l = _PAIRS[j]
        ckl = Einv[k, 0] * _lam(lam, 0, l) + Einv[k, 1] * _lam(lam, 1, l) + Einv[k, 2] * _lam(lam, 2, l)
        clk = Einv[l, 0] * _lam(lam, 0, k) + Einv[l, 1] * _lam(lam, 1, k) + Einv[l, 2] * _lam(lam, 2, k)
        f = -0.5 * (ckl - clk)
        dx, dy, dz = q0[3 + 3 * k], q0[4 + 3 * k], q0[5 + 3 * k]
        ex, ey, ez = q0[3 + 3 * l], q0[4 + 3 * l], q0[5 + 3 * l]
        ux += f * (dy * ez - dz * ey)
        uy += f * (dz * ex - dx * ez)
        uz += f * (dx * ey - dy * ex)
    if h * h * (ux * ux + uy * uy + uz * uz) <= wx * wx + wy * wy + wz * wz:
        wx += hf * ux
        wy += hf * uy
        wz += hf * uz
    # the Cayley map of w h/2: d1 = d0 + 2 / (1 + |t|^2) (t x d0 + t x (t x d0)), t = w h/2
    tx, ty, tz = hf * wx, hf * wy, hf * wz
    s1 = 2.0 / (1.0 + (tx * tx + ty * ty + tz * tz))
    for k in range(3):
        dx, dy, dz = q0[3 + 3 * k], q0[4 + 3 * k], q0[5 + 3 * k]
        cx = ty * dz - tz * dy
        cy = tz * dx - tx * dz
        cz = tx * dy - ty * dx
        dq[3 + 3 * k] = s1 * (cx + (ty * cz - tz * cy))
        dq[4 + 3 * k] = s1 * (cy + (tz * cx - tx * cz))
        dq[5 + 3 * k] = s1 * (cz + (tx * cy - ty * cx))
    return True


@kernel(inline="always")
def _lam(lam, k, l):
    """Entry (k, l) of the symmetric matrix of the six multipliers (order of _PAIRS)."""
    if k == l:
        return lam[k]
    return lam[k + l + 2]


@kernel
def body_radius(X):
    """The largest distance of a mass point from the centre of mass (X (3, N) body
    coordinates), as a (1,) array; 0 for no points."""
    out = np.zeros(1)
    for i in range(X.shape[1]):
        out[0] = max(out[0], math.sqrt(X[0, i] ** 2 + X[1, i] ** 2 + X[2, i] ** 2))
    return out
