"""Newton's matrix of the rigid-body time finite element (:mod:`.rigid_tfe`): the field's
Jacobians and the block solve with them.

The residual of k stages is ``Z_l - h sum_j a_lj f(y0 + Z_j)`` in ``y = (phi, d1, d2, d3, u,
M)``. Its matrix ``I - h a (x) Jf`` is taken at the first guess of each stage, with ``Jf``:

* the rotation (12 x 12 in (d1, d2, d3, M)): ``dk' = R (Omega x e_k)`` and ``M' = M x Omega``
  in d and M (:func:`rotation_jacobian`), and the torque ``tau = R^-1 sum_i (R X_i) x f_i``
  in all 9 axis components, rotations or not (Newton's iterates leave them), and in the
  centre (:func:`torque_jacobian`);
* the centre: ``phi' = u``, ``u' = G phi`` with G gravity's gradient as of a point mass.

The force's response to the axes is left out (it cancels to first order over the body), so
the matrix is block triangular: the centre's 3k unknowns first (their factors ``Nt``), then
the rotation's 12k with the torque's response to the centre on the right
(:func:`solve_without_correction`). The axes' rows act on each space component alike, so the
rotation's block needs only 3k x 3k factors: ``Pm = I - h a_lj W_j`` for the axes and the
Schur complement for M (:func:`factor_rotation`), by LU with partial pivoting
(:func:`.rigid_solve.lu`); 3 x 3 inverses by the adjugate (:func:`inverse3`).

Data layout: ``Jst`` (k, 12, 12) the stages' rotation Jacobians; ``Gs`` and ``Ts`` (k, 9) the
centre's gravity gradient and the torque's derivative in the centre per stage, rows first;
``Pinv`` and ``Sr`` (3k, 3k), ``V`` (9k, 3k); X (k, 18) a right-hand side, solved in place.
The Jacobian and the solve are inlined where they are called (``forceinline``): as calls, the
reference counts of their array arguments took about a fifth of a step.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import kernel
from .rigid_solve import lu, lu_solve

__all__ = ["factor_rotation", "inverse3", "rotation_jacobian", "solve_without_correction", "torque_jacobian"]


@kernel(forceinline=True)
def inverse3(R, out):
    """The inverse of a 3 x 3 matrix by its adjugate; returns the determinant."""
    out[0, 0] = R[1, 1] * R[2, 2] - R[1, 2] * R[2, 1]
    out[0, 1] = R[0, 2] * R[2, 1] - R[0, 1] * R[2, 2]
    out[0, 2] = R[0, 1] * R[1, 2] - R[0, 2] * R[1, 1]
    out[1, 0] = R[1, 2] * R[2, 0] - R[1, 0] * R[2, 2]
    out[1, 1] = R[0, 0] * R[2, 2] - R[0, 2] * R[2, 0]
    out[1, 2] = R[0, 2] * R[1, 0] - R[0, 0] * R[1, 2]
    out[2, 0] = R[1, 0] * R[2, 1] - R[1, 1] * R[2, 0]
    out[2, 1] = R[0, 1] * R[2, 0] - R[0, 0] * R[2, 1]
    out[2, 2] = R[0, 0] * R[1, 1] - R[0, 1] * R[1, 0]
    det = R[0, 0] * out[0, 0] + R[0, 1] * out[1, 0] + R[0, 2] * out[2, 0]
    for i in range(3):
        for j in range(3):
            out[i, j] /= det
    return det


@kernel(forceinline=True)
def rotation_jacobian(y, Jinv, Jr):
    """The torque-free field's Jacobian in (d1, d2, d3, M) at ``y`` into ``Jr`` (12, 12)."""
    Jr[:, :] = 0.0
    om = np.empty(3)
    for i in range(3):
        om[i] = Jinv[i, 0] * y[15] + Jinv[i, 1] * y[16] + Jinv[i, 2] * y[17]
    for i in range(3):
        Jr[i, 3 + i] = om[2]  # d1' = Omega3 d2 - Omega2 d3
        Jr[i, 6 + i] = -om[1]
        Jr[3 + i, 6 + i] = om[0]  # d2' = Omega1 d3 - Omega3 d1
        Jr[3 + i, i] = -om[2]
        Jr[6 + i, i] = om[1]  # d3' = Omega2 d1 - Omega1 d2
        Jr[6 + i, 3 + i] = -om[0]
    # d(dk')/dOmega, times J^-1
    dO = np.zeros((12, 3))
    for i in range(3):
        dO[i, 1] = -y[9 + i]
        dO[i, 2] = y[6 + i]
        dO[3 + i, 0] = y[9 + i]
        dO[3 + i, 2] = -y[3 + i]
        dO[6 + i, 0] = -y[6 + i]
        dO[6 + i, 1] = y[3 + i]
    # M' = M x Omega: d/dM = -[Omega]x + [M]x J^-1
    m0 = y[15]
    m1 = y[16]
    m2 = y[17]
    dO[9, 1] = -m2
    dO[9, 2] = m1
    dO[10, 0] = m2
    dO[10, 2] = -m0
    dO[11, 0] = -m1
    dO[11, 1] = m0
    for r in range(12):
        for j in range(3):
            Jr[r, 9 + j] = dO[r, 0] * Jinv[0, j] + dO[r, 1] * Jinv[1, j] + dO[r, 2] * Jinv[2, j]
    Jr[9, 10] += om[2]
    Jr[9, 11] -= om[1]
    Jr[10, 9] -= om[2]
    Jr[10, 11] += om[0]
    Jr[11, 9] += om[1]
    Jr[11, 10] -= om[0]


@kernel
def torque_jacobian(y, Xg, mg, gm, c, R, Ri, Jr, Ts):
    """Add the torque's derivatives in the axes to ``Jr``'s rows of M' and write those in the
    centre into ``Ts`` (9, rows), from ``tau = R^-1 w``, ``w = sum_i x_i x f_i``, ``x_i = R
    X_i``, ``f_i = m_i g(phi - c + x_i)``, G_i = df_i/dp: ``d tau / d(d_k)_b = -tau_k R^-1 e_b
    + R^-1 sum_i X_i^k (e_b x f_i + x_i x G_i e_b)``, ``d tau / d phi_b = R^-1 sum_i x_i x
    G_i e_b``. Every direction of the 9 axis components counts: Newton's iterates leave the
    rotations."""
    for kk in range(3):
        for i in range(3):
            R[i, kk] = y[3 + 3 * kk + i]
    inverse3(R, Ri)
    dW = np.zeros((4, 3, 3))  # [k or 3 for phi, b, component]
    w = np.zeros(3)
    for j in range(mg.shape[0]):
        X0 = Xg[0, j]
        X1 = Xg[1, j]
        X2 = Xg[2, j]
        x = np.empty(3)
        p = np.empty(3)
        for i in range(3):
            x[i] = R[i, 0] * X0 + R[i, 1] * X1 + R[i, 2] * X2
            p[i] = y[i] - c[i] + x[i]
        r2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
        s = -gm * mg[j] / (r2 * math.sqrt(r2))
        f0 = s * p[0]
        f1 = s * p[1]
        f2 = s * p[2]
        w[0] += x[1] * f2 - x[2] * f1
        w[1] += x[2] * f0 - x[0] * f2
        w[2] += x[0] * f1 - x[1] * f0
        Xk = (X0, X1, X2)
        for b in range(3):
            # G e_b = s (e_b - 3 p p_b / r^2)
            q = -3.0 * p[b] / r2
            g0 = s * ((1.0 if b == 0 else 0.0) + q * p[0])
            g1 = s * ((1.0 if b == 1 else 0.0) + q * p[1])
            g2 = s * ((1.0 if b == 2 else 0.0) + q * p[2])
            m0 = x[1] * g2 - x[2] * g1
            m1 = x[2] * g0 - x[0] * g2
            m2 = x[0] * g1 - x[1] * g0
            dW[3, b, 0] += m0
            dW[3, b, 1] += m1
            dW[3, b, 2] += m2
            # e_b x f
            e0 = 0.0
            e1 = 0.0
            e2 = 0.0
            if b == 0:
                e1 = -f2
                e2 = f1
            elif b == 1:
                e0 = f2
                e2 = -f0
            else:
                e0 = -f1
                e1 = f0
            for kk in range(3):
                dW[kk, b, 0] += Xk[kk] * (e0 + m0)
                dW[kk, b, 1] += Xk[kk] * (e1 + m1)
                dW[kk, b, 2] += Xk[kk] * (e2 + m2)
    tau = np.empty(3)
    for a in range(3):
        tau[a] = Ri[a, 0] * w[0] + Ri[a, 1] * w[1] + Ri[a, 2] * w[2]
    for kk in range(4):
        for b in range(3):
            for a in range(3):
                t = Ri[a, 0] * dW[kk, b, 0] + Ri[a, 1] * dW[kk, b, 1] + Ri[a, 2] * dW[kk, b, 2]
                if kk < 3:
                    Jr[9 + a, 3 * kk + b] += t - tau[kk] * Ri[a, b]
                else:
                    Ts[3 * a + b] = t


@kernel
def factor_rotation(tab, h, Jst, P, pivP, Pinv, V, Sr, pivS):
    """Factors of the rotation's block of Newton's matrix from the stages' Jacobians ``Jst``
    (k, 12, 12) (:func:`rotation_jacobian`, :func:`torque_jacobian`); False if singular.

    In (d, M) per stage the block is ``[[I - h a (x) kron(W, I3), -h a (x) B], [-h a (x) C,
    I - h a (x) Q]]``: the axes' rows act on each space component alike (``d_k' = sum_m
    W_km d_m``), so their part is ``kron(Pm, I3)`` with ``Pm = I - h a_lj W_j`` (3k x 3k:
    ``P``, ``pivP``, and its inverse ``Pinv``); ``V = kron(Pm, I3)^-1 (h a (x) B)`` (9k x 3k)
    and the Schur complement ``Sr = I - h a (x) Q - (h a (x) C) V`` (3k x 3k, ``pivS``)."""
    k = tab.shape[0]
    n3 = 3 * k
    for l in range(k):
        for kk in range(3):
            for j in range(k):
                ha = h * tab[l, 3 + j]
                for m in range(3):
                    P[3 * l + kk, 3 * j + m] = (1.0 if l == j and kk == m else 0.0) - ha * Jst[j, 3 * kk, 3 * m]
    if not lu(P, pivP, n3):
        return False
    for c in range(n3):
        for r in range(n3):
            Pinv[r, c] = 1.0 if r == c else 0.0
    for c in range(n3):
        lu_solve(P, pivP, Pinv[:, c], n3)
    for j in range(k):
        for m in range(3):
            col = 3 * j + m
            for l in range(k):
                for kk in range(3):
                    for i in range(3):
                        t = 0.0
                        for l2 in range(k):
                            ha = h * tab[l2, 3 + j]
                            for k2 in range(3):
                                t += Pinv[3 * l + kk, 3 * l2 + k2] * ha * Jst[j, 3 * k2 + i, 9 + m]
                        V[9 * l + 3 * kk + i, col] = t
    for l in range(k):
        for a in range(3):
            for col in range(n3):
                j = col // 3
                m = col - 3 * j
                t = (1.0 if 3 * l + a == col else 0.0) - h * tab[l, 3 + j] * Jst[j, 9 + a, 9 + m]
                for j2 in range(k):
                    ha = h * tab[l, 3 + j2]
                    for r in range(9):
                        t -= ha * Jst[j2, 9 + a, r] * V[9 * j2 + r, col]
                Sr[3 * l + a, col] = t
    return lu(Sr, pivS, n3)


@kernel(forceinline=True)
def solve_without_correction(tab, h, Jst, Pinv, V, Sr, pivS, Nt, pivt, Gs, Ts, rt, tm, X):
    """Apply the inverse of Newton's matrix without the correction's response to ``X`` (k,
    18) in place. It is block triangular: the centre first, by the factors of Nt,
    ``(I - h^2 a^2 (x) G) dphi = x_phi + h a x_u``, ``du = x_u + h a G dphi``; then the
    rotation (:func:`factor_rotation`), the torque's response to the centre (``Ts``) on the
    right: ``x0 = kron(Pm, I3)^-1 x_d``, ``Sr dM = x_M + (h a (x) C) x0``, ``dd = x0 + V dM``.
    ``rt``, ``tm``: 3k scratch."""
    k = tab.shape[0]
    n3 = 3 * k
    for l in range(k):
        for i in range(3):
            t = X[l, i]
            for j in range(k):
                t += h * tab[l, 3 + j] * X[j, 12 + i]
            rt[3 * l + i] = t
    lu_solve(Nt, pivt, rt, n3)
    for l in range(k):
        for i in range(3):
            X[l, i] = rt[3 * l + i]
    for l in range(k):
        for i in range(3):
            t = 0.0
            u = 0.0
            for j in range(k):
                gd = Gs[j, 3 * i] * rt[3 * j] + Gs[j, 3 * i + 1] * rt[3 * j + 1] + Gs[j, 3 * i + 2] * rt[3 * j + 2]
                td = Ts[j, 3 * i] * rt[3 * j] + Ts[j, 3 * i + 1] * rt[3 * j + 1] + Ts[j, 3 * i + 2] * rt[3 * j + 2]
                t += tab[l, 3 + j] * gd
                u += tab[l, 3 + j] * td
            X[l, 12 + i] += h * t
            X[l, 15 + i] += h * u
    for i in range(3):  # x0, one space component at a time
        for l in range(k):
            for kk in range(3):
                t = 0.0
                for l2 in range(k):
                    for k2 in range(3):
                        t += Pinv[3 * l + kk, 3 * l2 + k2] * X[l2, 3 + 3 * k2 + i]
                tm[3 * l + kk] = t
        for l in range(k):
            for kk in range(3):
                X[l, 3 + 3 * kk + i] = tm[3 * l + kk]
    for l in range(k):
        for a in range(3):
            t = X[l, 15 + a]
            for j in range(k):
                ha = h * tab[l, 3 + j]
                for r in range(9):
                    t += ha * Jst[j, 9 + a, r] * X[j, 3 + r]
            tm[3 * l + a] = t
    lu_solve(Sr, pivS, tm, n3)
    for l in range(k):
        for a in range(3):
            X[l, 15 + a] = tm[3 * l + a]
        for r in range(9):
            t = X[l, 3 + r]
            for col in range(n3):
                t += V[9 * l + r, col] * tm[col]
            X[l, 3 + r] = t
