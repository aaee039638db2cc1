r"""Energy-momentum time finite elements for elastic structures: the stage forces of orders 4 to 12.

A step of size h is the continuous Galerkin element cG(k) of Betsch & Steinmann on the
structure's slots, written at the k Gauss nodes c_l (weights b_l, matrix a): the slots' path
``q(tau)`` has degree k, its rate ``V(tau) = sum_l ell_l(tau) V_l`` (Lagrange basis at the nodes),
and with the stage velocities ``V_l`` (k, n_slots, 3) as unknowns::

    Q_l = u0 + h sum_j a_lj V_j,   u1 = u0 + h sum_l b_l V_l,   M (V_l - v0) = h sum_j a_lj A_j,
    v1 = v0 + h sum_l b_l M^-1 A_l,   A_l = (1 / b_l) int_0^1 ell_l(tau) f(tau) dtau.

Elements: the assumed strain method in time (Betsch & Steinmann 2001). With ``Pq(tau) = sum_l
ell_l(tau) Q_l`` (the path's projection onto degree k - 1, which meets it at the nodes), the
assumed strain rate is ``Ed*(tau) = sym(F(Pq)^T F(V))`` (bar: ``d(Pq) . d(V) / L^2``), degree
2k - 2, and the assumed strain ``Et(tau) = E0 + h int_0^tau Ed*`` ends at ``Et(1) = E1``
exactly (``q - Pq`` is orthogonal to degree k - 1); the force is ``f = -V F(Pq) C:Et g_a``
(bar: ``-EA/L Et d(Pq)`` on node b). Its work, ``h int V . f = -h V int C:Et : Ed* = -V [Et:C:Et
/ 2]_0^1``, is the strain energy's drop exactly, not to a rule's order, and the integrals of A_l
(degree 4k - 3) are exact with the 2k - 1 point Gauss rule (nodes sigma_i, weights w_i;
:func:`assumed_strain_tables`). Angular momentum: the stress is symmetric, so each f(sigma_i)
has no moment about ``Pq(sigma_i)``, and ``L1 - L0 = h int Pq x M V' = 0`` (``M V'`` has
degree k - 1). The force is a polynomial in the unknowns: Newton's matrix is exact and smooth.

Gravity points (``Q_l``, ``V_l`` relative to the field's centre): ``A_l = m (g(Q_l) + mu s_l
Q_l)``, ``s_l = Q_l . V_l``, mu of :func:`emorbit.kernels.pointmass.tfe.tfe_step`: each point's
work is its potential drop, the force radial. Newton's matrix ``I (x) M - h [sum_j a_lj dA_j /
dV_m]`` (block (l, m) of k x k blocks of ``n`` rows, row ``l n + 3 s + d`` for slot s, direction
d; nodes reach slots as in :mod:`.elastic`) holds the exact derivatives, mu's too: near an apse
of a point's radial motion mu is a ratio of two small sums, and without them Newton stalls.

Data layout: nodes ``x0n`` (nn, 3) at the step's start, stage increments ``Zn`` and velocities
``Vn`` (k, nn, 3) of the nodes; the forces ``fn`` (k, nn, 3) at the nodes (the A_l); gravity
points likewise (ng, 3) and (k, ng, 3); the Gauss table ``tab`` of
:func:`.pointmass.tfe.tables` and the element rule ``rule`` of :func:`assumed_strain_tables`.

References: P. Betsch, P. Steinmann, J. Comput. Phys. 160 (2000) 88-116; Int. J. Numer. Meth.
Eng. 50 (2001) 1931-1955 (the assumed strain method in time); E. Hairer, JNAIAM 5 (2010)
73-84; J. C. Simo, N. Tarnow, ZAMP 43 (1992) 757-792.
"""

from __future__ import annotations

import math

import numpy as np

from .coupled import add_block_at
from .gauss import gauss_rule
from .jit import kernel

__all__ = ["assumed_strain_tables", "stage_element_forces", "stage_gravity_forces"]


def _gauss(m: int) -> tuple[list, list]:
    """Gauss-Legendre nodes and weights on [0, 1] as Decimals: closed forms at the context's
    precision for m = 2, 3 and 5 (those of orders 4 and 6), Newton's roots of
    :func:`.gauss.gauss_rule` for other m (order 8 takes 4 and 7)."""
    from decimal import Decimal as D

    if m == 2:
        x = [-(D(1) / D(3)).sqrt(), (D(1) / D(3)).sqrt()]
        w = [D(1), D(1)]
    elif m == 3:
        r = (D(3) / D(5)).sqrt()
        x = [-r, D(0), r]
        w = [D(5) / D(9), D(8) / D(9), D(5) / D(9)]
    elif m == 5:
        s = 2 * (D(10) / D(7)).sqrt()
        x1, x2 = (5 - s).sqrt() / 3, (5 + s).sqrt() / 3
        w1, w2 = (322 + 13 * D(70).sqrt()) / 900, (322 - 13 * D(70).sqrt()) / 900
        x = [-x2, -x1, D(0), x1, x2]
        w = [w2, w1, D(128) / D(225), w1, w2]
    else:
        return gauss_rule(m)
    return [(1 + xi) / 2 for xi in x], [wi / 2 for wi in w]


def assumed_strain_tables(order: int) -> tuple[np.ndarray, ...]:
    """The element rule of a step of ``order`` (4 to 12): with the k Gauss nodes c (k = order /
    2), the Lagrange basis ell_j on them and the 2k - 1 point Gauss rule (sigma_i, w_i) on [0, 1]:

    - ``ell`` (k, m): ``ell_j(sigma_i)``;
    - ``beta`` (m, k, k): ``int_0^sigma_i ell_j ell_l``;
    - ``gamma`` (k, m): ``w_i ell_l(sigma_i) / b_l``.

    Computed with 40-digit decimals and rounded once.
    """
    from decimal import Decimal as D
    from decimal import localcontext

    with localcontext() as ctx:  # the caller's decimal context stays as it was
        ctx.prec = 40
        return _strain_tables(order // 2, D)


def _strain_tables(k: int, D) -> tuple[np.ndarray, ...]:
    """:func:`assumed_strain_tables` for k stages, in the current decimal context."""
    c, b = _gauss(k)
    sig, w = _gauss(2 * k - 1)
    m = len(sig)

    def mul(p, q):
        out = [D(0)] * (len(p) + len(q) - 1)
        for i, pi in enumerate(p):
            for j, qj in enumerate(q):
                out[i + j] += pi * qj
        return out

    def integral(p, x):  # int_0^x of the polynomial with coefficients p (lowest first)
        return sum(pi * x ** (i + 1) / (i + 1) for i, pi in enumerate(p))

    def value(p, x):
        return sum(pi * x**i for i, pi in enumerate(p))

    basis = []
    for j in range(k):
        p = [D(1)]
        for q in range(k):
            if q != j:
                p = mul(p, [-c[q] / (c[j] - c[q]), D(1) / (c[j] - c[q])])
        basis.append(p)
    ell = np.array([[float(value(basis[j], s)) for s in sig] for j in range(k)])
    beta = np.array([[[float(integral(mul(basis[j], basis[q]), s)) for q in range(k)] for j in range(k)] for s in sig])
    gamma = np.array([[float(w[i] * value(basis[l_], sig[i]) / b[l_]) for i in range(m)] for l_ in range(k)])
    return ell, beta, gamma


@kernel
def stage_element_forces(
    tab, ell, beta, gamma, h, x0n, Zn, Vn, bar_node, bar_EA, bar_L, tet_node, tet_g, tet_V, tet_lam, tet_mu,
    fn, want_J, node_slot, node_coef, n, indptr, indices, data,
):  # fmt: skip
    """The elements' stage forces A_l (module notes) into ``fn`` (k, nn, 3), overwritten, and,
    if ``want_J``, their part of Newton's matrix added into ``data``."""
    k = tab.shape[0]
    fn[:, :, :] = 0.0
    # Gam[l, i] = sum_j a_lj gamma_ji: how the force at sigma_i enters stage l's residual;
    # iota[i, m] = sum_j ell_j(sigma_i) a_jm: d Pq(sigma_i) / d V_m, over h
    m = ell.shape[1]
    Gam = np.zeros((k, m))
    iota = np.zeros((m, k))
    for i in range(m):
        for j in range(k):
            for q in range(k):
                Gam[j, i] += tab[j, 3 + q] * gamma[q, i]
                iota[i, q] += ell[j, i] * tab[j, 3 + q]
    _bars(
        tab, ell, iota, beta, gamma, Gam, h, x0n, Zn, Vn, bar_node, bar_EA, bar_L, fn, want_J, node_slot, node_coef,
        n, indptr, indices, data,
    )  # fmt: skip
    _tets(
        tab, ell, iota, beta, gamma, Gam, h, x0n, Zn, Vn, tet_node, tet_g, tet_V, tet_lam, tet_mu, fn, want_J,
        node_slot, node_coef, n, indptr, indices, data,
    )  # fmt: skip


@kernel
def _bars(
    tab, ell, iota, beta, gamma, Gam, h, x0n, Zn, Vn, bar_node, bar_EA, bar_L, fn, want_J, node_slot, node_coef,
    n, indptr, indices, data,
):  # fmt: skip
    k = tab.shape[0]
    m = ell.shape[1]
    D = np.empty((k, 3))  # d(Q_j)
    W = np.empty((k, 3))  # d(V_j)
    DW = np.empty((k, k))  # d(Q_j) . d(V_l)
    Et = np.empty(m)  # assumed strain at sigma_i
    ds = np.empty((m, 3))  # d(Pq(sigma_i))
    f = np.empty((m, 3))
    G = np.empty((k, 3, 3))
    d0 = np.empty(3)
    for e in range(bar_node.shape[0]):
        a = bar_node[e, 0]
        b = bar_node[e, 1]
        L2 = bar_L[e] * bar_L[e]
        kk = bar_EA[e] / bar_L[e]
        for r in range(3):
            d0[r] = x0n[b, r] - x0n[a, r]
        e0 = (d0[0] * d0[0] + d0[1] * d0[1] + d0[2] * d0[2] - L2) / (2.0 * L2)
        for j in range(k):
            for r in range(3):
                D[j, r] = d0[r] + Zn[j, b, r] - Zn[j, a, r]
                W[j, r] = Vn[j, b, r] - Vn[j, a, r]
        for j in range(k):
            for q in range(k):
                DW[j, q] = D[j, 0] * W[q, 0] + D[j, 1] * W[q, 1] + D[j, 2] * W[q, 2]
        for i in range(m):
            s = 0.0
            for j in range(k):
                for q in range(k):
                    s += beta[i, j, q] * DW[j, q]
            Et[i] = e0 + h * s / L2
            for r in range(3):
                x = 0.0
                for j in range(k):
                    x += ell[j, i] * D[j, r]
                ds[i, r] = x
                f[i, r] = -kk * Et[i] * x
        for l in range(k):
            for r in range(3):
                x = 0.0
                for i in range(m):
                    x += gamma[l, i] * f[i, r]
                fn[l, b, r] += x
                fn[l, a, r] -= x
        if not want_J:
            continue
        # d / d w_mm[r] (w = V_b - V_a): dD_j = h a_j,mm e_r, dW_q = delta_q,mm e_r
        for mm in range(k):
            G[:, :, :] = 0.0
            for r in range(3):
                for i in range(m):
                    s = 0.0
                    for j in range(k):
                        haj = h * tab[j, 3 + mm]
                        for q in range(k):
                            s += beta[i, j, q] * haj * W[q, r]
                        s += beta[i, j, mm] * D[j, r]
                    dEt = h * s / L2
                    hal = h * iota[i, mm]
                    for t in range(3):
                        df = -kk * (dEt * ds[i, t] + (Et[i] * hal if t == r else 0.0))
                        for l in range(k):
                            G[l, t, r] -= h * Gam[l, i] * df
            for l in range(k):
                add_block_at(l, mm, b, b, G[l], 1.0, node_slot, node_coef, n, indptr, indices, data)
                add_block_at(l, mm, a, a, G[l], 1.0, node_slot, node_coef, n, indptr, indices, data)
                add_block_at(l, mm, a, b, G[l], -1.0, node_slot, node_coef, n, indptr, indices, data)
                add_block_at(l, mm, b, a, G[l], -1.0, node_slot, node_coef, n, indptr, indices, data)


@kernel
def _stress(lam, mu, E, out):
    """out = C : E = lam tr(E) I + 2 mu E."""
    tr = E[0, 0] + E[1, 1] + E[2, 2]
    for i in range(3):
        for j in range(3):
            out[i, j] = 2.0 * mu * E[i, j] + (lam * tr if i == j else 0.0)


@kernel
def _tets(
    tab, ell, iota, beta, gamma, Gam, h, x0n, Zn, Vn, tet_node, tet_g, tet_V, tet_lam, tet_mu, fn, want_J,
    node_slot, node_coef, n, indptr, indices, data,
):  # fmt: skip
    k = tab.shape[0]
    m = ell.shape[1]
    F0 = np.empty((3, 3))
    E0 = np.empty((3, 3))
    F = np.empty((k, 3, 3))  # F(Q_j)
    W = np.empty((k, 3, 3))  # F(V_j)
    P = np.empty((k, k, 3, 3))  # F(Q_j)^T F(V_q)
    Fs = np.empty((m, 3, 3))  # F(Pq(sigma_i))
    St = np.empty((m, 3, 3))  # C : Et(sigma_i)
    X = np.empty((3, 3))
    dS = np.empty((3, 3))
    Y = np.empty(3)
    Xr = np.empty(3)
    Sg = np.empty((m, 4, 3))  # St_i g_a
    G = np.empty((k, 4, 3, 3))
    for e in range(tet_node.shape[0]):
        g = tet_g[e]
        lam = tet_lam[e]
        mu = tet_mu[e]
        V = tet_V[e]
        for r in range(3):
            for q in range(3):
                s = 0.0
                for a in range(4):
                    s += x0n[tet_node[e, a], r] * g[q, a]
                F0[r, q] = s
        for p in range(3):
            for q in range(3):
                c = 0.0
                for r in range(3):
                    c += F0[r, p] * F0[r, q]
                E0[p, q] = 0.5 * c - (0.5 if p == q else 0.0)
        for j in range(k):
            for r in range(3):
                for q in range(3):
                    sz = 0.0
                    sv = 0.0
                    for a in range(4):
                        nd = tet_node[e, a]
                        sz += Zn[j, nd, r] * g[q, a]
                        sv += Vn[j, nd, r] * g[q, a]
                    F[j, r, q] = F0[r, q] + sz
                    W[j, r, q] = sv
        for j in range(k):
            for jj in range(k):
                for p in range(3):
                    for q in range(3):
                        P[j, jj, p, q] = F[j, 0, p] * W[jj, 0, q] + F[j, 1, p] * W[jj, 1, q] + F[j, 2, p] * W[jj, 2, q]
        for i in range(m):
            for p in range(3):
                for q in range(3):
                    s = 0.0
                    for j in range(k):
                        for jj in range(k):
                            s += beta[i, j, jj] * (P[j, jj, p, q] + P[j, jj, q, p])
                    X[p, q] = E0[p, q] + 0.5 * h * s
                    x = 0.0
                    for j in range(k):
                        x += ell[j, i] * F[j, p, q]
                    Fs[i, p, q] = x
            _stress(lam, mu, X, St[i])
            for a in range(4):
                for p in range(3):
                    Sg[i, a, p] = St[i, p, 0] * g[0, a] + St[i, p, 1] * g[1, a] + St[i, p, 2] * g[2, a]
            for a in range(4):
                nd = tet_node[e, a]
                for r in range(3):
                    fa = -V * (Fs[i, r, 0] * Sg[i, a, 0] + Fs[i, r, 1] * Sg[i, a, 1] + Fs[i, r, 2] * Sg[i, a, 2])
                    for l in range(k):
                        fn[l, nd, r] += gamma[l, i] * fa
        if not want_J:
            continue
        # d / d V_mm[node c][r]: dF_j = h a_j,mm e_r g_c^T, dW_q = delta_q,mm e_r g_c^T
        for mm in range(k):
            for c in range(4):
                G[:, :, :, :] = 0.0
                for r in range(3):
                    for i in range(m):
                        # dEt = h (h sym(g_c (x) Y) + sym(Xr (x) g_c)), Y = sum beta_i,j,q a_j,mm W_q[r, :],
                        # Xr = sum_j beta_i,j,mm F_j[r, :]
                        for q in range(3):
                            y = 0.0
                            x = 0.0
                            for j in range(k):
                                aj = tab[j, 3 + mm]
                                for jj in range(k):
                                    y += beta[i, j, jj] * aj * W[jj, r, q]
                                x += beta[i, j, mm] * F[j, r, q]
                            Y[q] = y
                            Xr[q] = x
                        for p in range(3):
                            for q in range(3):
                                X[p, q] = (
                                    0.5
                                    * h
                                    * (h * (g[p, c] * Y[q] + g[q, c] * Y[p]) + Xr[p] * g[q, c] + Xr[q] * g[p, c])
                                )
                        _stress(lam, mu, X, dS)
                        hal = h * iota[i, mm]
                        for a in range(4):
                            gsg = g[0, c] * Sg[i, a, 0] + g[1, c] * Sg[i, a, 1] + g[2, c] * Sg[i, a, 2]
                            for t in range(3):
                                s = 0.0
                                for p in range(3):
                                    s += Fs[i, t, p] * (dS[p, 0] * g[0, a] + dS[p, 1] * g[1, a] + dS[p, 2] * g[2, a])
                                df = -V * (s + (hal * gsg if t == r else 0.0))
                                for l in range(k):
                                    G[l, a, t, r] -= h * Gam[l, i] * df
                for l in range(k):
                    for a in range(4):
                        add_block_at(
                            l, mm, tet_node[e, a], tet_node[e, c], G[l, a], 1.0, node_slot, node_coef, n, indptr,
                            indices, data,
                        )  # fmt: skip


@kernel
def stage_gravity_forces(
    tab, h, gm, p0, Zg, Vg, gp_m, fg, want_J, gp_node, gp_w, node_slot, node_coef, n, indptr, indices, data
):
    """The central field's stage forces at the gravity points into ``fg`` (k, ng, 3),
    overwritten, and, if ``want_J``, their part of Newton's matrix added into ``data``:
    ``p0`` (ng, 3) their start positions relative to the field's centre, m; ``Zg``, ``Vg``
    (k, ng, 3) their stage increments and velocities; ``gp_m`` (ng,) masses; ``gp_node``,
    ``gp_w`` (ng, 4) their nodes and weights."""
    k = tab.shape[0]
    fg[:, :, :] = 0.0
    if gm == 0.0:
        return
    s = np.empty(k)
    ir3 = np.empty(k)
    rr = np.empty(k)
    Q = np.empty((k, 3))
    G = np.empty((k, 3, 3))
    dir3 = np.empty(k)
    ds = np.empty(k)
    for q in range(p0.shape[0]):
        r0 = math.sqrt(p0[q, 0] ** 2 + p0[q, 1] ** 2 + p0[q, 2] ** 2)
        e2 = 0.0
        for i in range(3):
            dz = 0.0
            for l in range(k):
                dz += tab[l, 1] * Vg[l, q, i]
            e2 += (p0[q, i] + h * dz) ** 2
        r1 = math.sqrt(e2)
        kk = 2.0 / (r0 * r1 * (r0 + r1))
        num = 0.0
        den = 0.0
        for l in range(k):
            r2 = 0.0
            sl = 0.0
            for i in range(3):
                Q[l, i] = p0[q, i] + Zg[l, q, i]
                r2 += Q[l, i] * Q[l, i]
                sl += Q[l, i] * Vg[l, q, i]
            ir3[l] = 1.0 / (r2 * math.sqrt(r2))
            rr[l] = r2
            s[l] = sl
            num += tab[l, 1] * sl * (ir3[l] - kk)
            den += tab[l, 1] * sl * sl
        mu = gm * num / den if den > 0.0 else 0.0
        m = gp_m[q]
        for l in range(k):
            c = m * (-gm * ir3[l] + mu * s[l])
            for i in range(3):
                fg[l, q, i] = c * Q[l, i]
        if not want_J:
            continue
        # d/d V_mm[i]: dQ_j = h a_jm e_i, dV_j = delta_jm e_i, d p1 = h b_m e_i
        for mm in range(k):
            G[:, :, :] = 0.0
            for i in range(3):
                p1i = p0[q, i]
                for l in range(k):
                    p1i += h * tab[l, 1] * Vg[l, q, i]
                dr1 = p1i * h * tab[mm, 1] / r1
                dK = -kk * dr1 * (1.0 / r1 + 1.0 / (r0 + r1))
                dnum = 0.0
                dden = 0.0
                for j in range(k):
                    ha = h * tab[j, 3 + mm]
                    dir3[j] = -3.0 * ir3[j] * Q[j, i] * ha / rr[j]
                    ds[j] = ha * Vg[j, q, i] + (Q[j, i] if j == mm else 0.0)
                    dnum += tab[j, 1] * (ds[j] * (ir3[j] - kk) + s[j] * (dir3[j] - dK))
                    dden += 2.0 * tab[j, 1] * s[j] * ds[j]
                dmu = (gm * dnum - mu * dden) / den if den > 0.0 else 0.0
                for j in range(k):
                    ha = h * tab[j, 3 + mm]
                    dc = -gm * dir3[j] + dmu * s[j] + mu * ds[j]
                    for r in range(3):
                        df = m * (dc * Q[j, r] + ((-gm * ir3[j] + mu * s[j]) * ha if r == i else 0.0))
                        for l in range(k):
                            G[l, r, i] -= h * tab[l, 3 + j] * df
            for l in range(k):
                for a in range(4):
                    na = gp_node[q, a]
                    if na < 0:
                        break
                    for b in range(4):
                        nb = gp_node[q, b]
                        if nb < 0:
                            break
                        add_block_at(
                            l, mm, na, nb, G[l], gp_w[q, a] * gp_w[q, b], node_slot, node_coef, n, indptr, indices,
                            data,
                        )  # fmt: skip
