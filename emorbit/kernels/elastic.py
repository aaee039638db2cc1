"""Elastic elements and coupled structures: internal forces and their derivatives, the
combination of slots into nodes and nodes into gravity points, assembled into the residual and
a fixed sparse (CSC) Jacobian pattern.

Unknowns are *slots*: 3-vectors that are FE node coordinates, point-mass positions, or a rigid
body's centre of mass ``phi`` and axes ``d_k``. Every mass matrix in the structure is a scalar
matrix times I3 over slots, and every material point is linear in the slots:

* a *node* is ``x = sum_j c_j u[s_j]`` over at most 4 slots (a free node: one slot with c = 1;
  a node riding on a rigid body: ``phi + X^k d_k``);
* a *gravity point* (quadrature point of an element, a point mass, a rigid body's mass point)
  is ``x = sum_a N_a x[node_a]`` over at most 4 nodes, with mass ``m``.

Elements (St. Venant-Kirchhoff, Green strain E = (F^T F - I)/2, S = lambda tr(E) I + 2 mu E):

* 2-node bar, E = (l^2 - L^2)/(2 L^2): force on node b ``-EA/L * E_bar * d05`` with
  ``E_bar = (E00 + E10)/2`` (energy-momentum) or ``E(d05)`` (midpoint), d = x_b - x_a;
* 4-node linear tetrahedron, F = sum_a x_a g_a^T (g_a the reference shape gradients): force on
  node a ``-V F05 S g_a`` with ``S = C : (E00 + E10)/2`` (Simo & Tarnow) or ``S(E(F05))``.

Because E is quadratic in the nodes, ``E10 - E00 = sym(F05^T (F10 - F00))`` exactly, so the
algorithmic stress does work equal to minus the change in strain energy; with the effects'
discrete forces at the gravity points (linear in the nodes; :mod:`.structure_effects`) the
discrete energy balance is exact. Jacobians are the
exact derivatives with respect to the end-of-step configuration (unsymmetric).

Everything here is plain arrays; :mod:`emorbit.bodies.coupled` builds them.
"""

from __future__ import annotations

import math

import numpy as np

from .codes import METHOD_EM
from .jit import kernel

__all__ = [
    "combine_rows",
    "spread_rows",
    "bar_forces",
    "tet_forces",
    "strain_energy",
    "stress_scale",
    "csc_find",
]


@kernel
def combine_rows(src, idx, coef, out):
    """out[i] = sum_j coef[i, j] src[idx[i, j]] over the 3 columns, up to the first idx < 0
    (at most 4 terms): node positions from slot values (node_slot, node_coef) and gravity-point
    positions from node positions (gp_node, gp_w)."""
    for i in range(idx.shape[0]):
        x0 = x1 = x2 = 0.0
        for j in range(4):
            s = idx[i, j]
            if s < 0:
                break
            c = coef[i, j]
            x0 += c * src[s, 0]
            x1 += c * src[s, 1]
            x2 += c * src[s, 2]
        out[i, 0] = x0
        out[i, 1] = x1
        out[i, 2] = x2


@kernel
def spread_rows(vals, idx, coef, out):
    """The transpose of :func:`combine_rows`: out[idx[i, j]] += coef[i, j] vals[i] over the 3
    columns, up to the first idx < 0 (gravity-point forces to nodes, node forces to slots)."""
    for i in range(idx.shape[0]):
        for j in range(4):
            s = idx[i, j]
            if s < 0:
                break
            c = coef[i, j]
            out[s, 0] += c * vals[i, 0]
            out[s, 1] += c * vals[i, 1]
            out[s, 2] += c * vals[i, 2]


@kernel
def bar_forces(method, x0, x1, bar_node, bar_EA, bar_L, fn, kb):
    """Add bar forces to fn (n_nodes, 3); kb (n_bars, 3, 3) receives K_bb = d f_b / d x_b1
    (the other blocks are K_aa = K_bb, K_ab = K_ba = -K_bb)."""
    for e in range(bar_node.shape[0]):
        a = bar_node[e, 0]
        b = bar_node[e, 1]
        L2 = bar_L[e] * bar_L[e]
        k = bar_EA[e] / bar_L[e]
        d0x = x0[b, 0] - x0[a, 0]
        d0y = x0[b, 1] - x0[a, 1]
        d0z = x0[b, 2] - x0[a, 2]
        d1x = x1[b, 0] - x1[a, 0]
        d1y = x1[b, 1] - x1[a, 1]
        d1z = x1[b, 2] - x1[a, 2]
        mx = 0.5 * (d0x + d1x)
        my = 0.5 * (d0y + d1y)
        mz = 0.5 * (d0z + d1z)
        if method == METHOD_EM:
            e0 = (d0x * d0x + d0y * d0y + d0z * d0z - L2) / (2.0 * L2)
            e1 = (d1x * d1x + d1y * d1y + d1z * d1z - L2) / (2.0 * L2)
            eb = 0.5 * (e0 + e1)
            gx, gy, gz = d1x, d1y, d1z  # d E_bar / d x_b1 = d1 / (2 L^2)
        else:
            eb = (mx * mx + my * my + mz * mz - L2) / (2.0 * L2)
            gx, gy, gz = mx, my, mz  # d E(d05) / d x_b1 = d05 / (2 L^2)
        fx = -k * eb * mx
        fy = -k * eb * my
        fz = -k * eb * mz
        fn[b, 0] += fx
        fn[b, 1] += fy
        fn[b, 2] += fz
        fn[a, 0] -= fx
        fn[a, 1] -= fy
        fn[a, 2] -= fz
        m3 = (mx, my, mz)
        g3 = (gx, gy, gz)
        for i in range(3):
            for j in range(3):
                kb[e, i, j] = -k * m3[i] * g3[j] / (2.0 * L2)
            kb[e, i, i] -= 0.5 * k * eb


@kernel
def tet_forces(method, x0, x1, tet_node, tet_g, tet_V, tet_lam, tet_mu, fn, kt):
    """Add tetrahedron forces to fn (n_nodes, 3); kt (n_tets, 4, 4, 3, 3) receives
    K_ab = d f_a / d x_b1 for every node pair of each element."""
    F0 = np.empty((3, 3))
    F1 = np.empty((3, 3))
    Fm = np.empty((3, 3))
    Fs = np.empty((3, 3))  # F1 (energy-momentum) or F05 (midpoint): the strain's own gradient
    S = np.empty((3, 3))
    E = np.empty((3, 3))
    for e in range(tet_node.shape[0]):
        g = tet_g[e]  # (3, 4) reference gradients of the shape functions
        for i in range(3):
            for j in range(3):
                s0 = 0.0
                s1 = 0.0
                for a in range(4):
                    s0 += x0[tet_node[e, a], i] * g[j, a]
                    s1 += x1[tet_node[e, a], i] * g[j, a]
                F0[i, j] = s0
                F1[i, j] = s1
                Fm[i, j] = 0.5 * (s0 + s1)
        for i in range(3):
            for j in range(3):
                if method == METHOD_EM:
                    c0 = 0.0
                    c1 = 0.0
                    for k in range(3):
                        c0 += F0[k, i] * F0[k, j]
                        c1 += F1[k, i] * F1[k, j]
                    E[i, j] = 0.25 * (c0 + c1) - (0.5 if i == j else 0.0)  # (E00 + E10) / 2
                    Fs[i, j] = F1[i, j]
                else:
                    c = 0.0
                    for k in range(3):
                        c += Fm[k, i] * Fm[k, j]
                    E[i, j] = 0.5 * c - (0.5 if i == j else 0.0)  # E(F05)
                    Fs[i, j] = Fm[i, j]
        lam = tet_lam[e]
        mu = tet_mu[e]
        tr = E[0, 0] + E[1, 1] + E[2, 2]
        for i in range(3):
            for j in range(3):
                S[i, j] = 2.0 * mu * E[i, j] + (lam * tr if i == j else 0.0)
        V = tet_V[e]
        for a in range(4):
            # f_a = -V F05 S g_a
            sg0 = S[0, 0] * g[0, a] + S[0, 1] * g[1, a] + S[0, 2] * g[2, a]
            sg1 = S[1, 0] * g[0, a] + S[1, 1] * g[1, a] + S[1, 2] * g[2, a]
            sg2 = S[2, 0] * g[0, a] + S[2, 1] * g[1, a] + S[2, 2] * g[2, a]
            n = tet_node[e, a]
            for i in range(3):
                fn[n, i] -= V * (Fm[i, 0] * sg0 + Fm[i, 1] * sg1 + Fm[i, 2] * sg2)
            # Fs g_a
            fa0 = Fs[0, 0] * g[0, a] + Fs[0, 1] * g[1, a] + Fs[0, 2] * g[2, a]
            fa1 = Fs[1, 0] * g[0, a] + Fs[1, 1] * g[1, a] + Fs[1, 2] * g[2, a]
            fa2 = Fs[2, 0] * g[0, a] + Fs[2, 1] * g[1, a] + Fs[2, 2] * g[2, a]
            for b in range(4):
                # K_ab = -V/2 [ (g_b . S g_a) I + F05 (lam g_a (Fs g_b)^T + mu (g_a.g_b) Fs^T + mu g_b (Fs g_a)^T) ]
                gsg = g[0, b] * sg0 + g[1, b] * sg1 + g[2, b] * sg2
                gg = g[0, a] * g[0, b] + g[1, a] * g[1, b] + g[2, a] * g[2, b]
                fb0 = Fs[0, 0] * g[0, b] + Fs[0, 1] * g[1, b] + Fs[0, 2] * g[2, b]
                fb1 = Fs[1, 0] * g[0, b] + Fs[1, 1] * g[1, b] + Fs[1, 2] * g[2, b]
                fb2 = Fs[2, 0] * g[0, b] + Fs[2, 1] * g[1, b] + Fs[2, 2] * g[2, b]
                fbv = (fb0, fb1, fb2)
                fav = (fa0, fa1, fa2)
                for p in range(3):  # inner matrix A = lam g_a (Fs g_b)^T + mu gg Fs^T + mu g_b (Fs g_a)^T
                    for k in range(3):
                        inner = lam * g[p, a] * fbv[k] + mu * gg * Fs[k, p] + mu * g[p, b] * fav[k]
                        E[p, k] = inner  # reuse E as scratch for A (E is no longer needed)
                for i in range(3):
                    for k in range(3):
                        s = Fm[i, 0] * E[0, k] + Fm[i, 1] * E[1, k] + Fm[i, 2] * E[2, k]
                        kt[e, a, b, i, k] = -0.5 * V * (s + (gsg if i == k else 0.0))


@kernel
def strain_energy(x, bar_node, bar_EA, bar_L, tet_node, tet_g, tet_V, tet_lam, tet_mu):
    """Total strain energy (J) of bars and tetrahedra at node positions x (n_nodes, 3)."""
    W = 0.0
    for e in range(bar_node.shape[0]):
        a = bar_node[e, 0]
        b = bar_node[e, 1]
        L2 = bar_L[e] * bar_L[e]
        d2 = 0.0
        for i in range(3):
            d2 += (x[b, i] - x[a, i]) ** 2
        eps = (d2 - L2) / (2.0 * L2)
        W += 0.5 * bar_EA[e] * bar_L[e] * eps * eps
    F = np.empty((3, 3))
    for e in range(tet_node.shape[0]):
        g = tet_g[e]
        for i in range(3):
            for j in range(3):
                s = 0.0
                for a in range(4):
                    s += x[tet_node[e, a], i] * g[j, a]
                F[i, j] = s
        tr = 0.0
        ee = 0.0
        for i in range(3):
            for j in range(3):
                c = 0.0
                for k in range(3):
                    c += F[k, i] * F[k, j]
                Eij = 0.5 * c - (0.5 if i == j else 0.0)
                ee += Eij * Eij
                if i == j:
                    tr += Eij
        W += tet_V[e] * (0.5 * tet_lam[e] * tr * tr + tet_mu[e] * ee)
    return W


@kernel
def stress_scale(x, bar_node, bar_EA, bar_L, tet_node, tet_g, tet_V, tet_lam, tet_mu):
    """sum of EA L |E| over bars and V |S| (Frobenius) over tetrahedra at node positions x, J.

    A rounding of eps in the strain (E = (F^T F - I)/2 of coordinates rounded to eps of their
    size) moves the strain energy by up to eps times this: the round-off scale of the strain
    energy, which the energy itself (quadratic in a small strain) can be far below."""
    total = 0.0
    for e in range(bar_node.shape[0]):
        a = bar_node[e, 0]
        b = bar_node[e, 1]
        L2 = bar_L[e] * bar_L[e]
        d2 = 0.0
        for i in range(3):
            d2 += (x[b, i] - x[a, i]) ** 2
        total += bar_EA[e] * bar_L[e] * abs((d2 - L2) / (2.0 * L2))
    F = np.empty((3, 3))
    E = np.empty((3, 3))
    for e in range(tet_node.shape[0]):
        g = tet_g[e]
        for i in range(3):
            for j in range(3):
                s = 0.0
                for a in range(4):
                    s += x[tet_node[e, a], i] * g[j, a]
                F[i, j] = s
        for i in range(3):
            for j in range(3):
                c = 0.0
                for k in range(3):
                    c += F[k, i] * F[k, j]
                E[i, j] = 0.5 * c - (0.5 if i == j else 0.0)
        tr = E[0, 0] + E[1, 1] + E[2, 2]
        ss = 0.0
        for i in range(3):
            for j in range(3):
                sij = 2.0 * tet_mu[e] * E[i, j] + (tet_lam[e] * tr if i == j else 0.0)
                ss += sij * sij
        total += tet_V[e] * math.sqrt(ss)
    return total


@kernel
def csc_find(indptr, indices, row, col):
    """Position of entry (row, col) in a CSC matrix with sorted row indices, or -1."""
    lo = indptr[col]
    hi = indptr[col + 1] - 1
    while lo <= hi:
        mid = (lo + hi) // 2
        r = indices[mid]
        if r == row:
            return mid
        if r < row:
            lo = mid + 1
        else:
            hi = mid - 1
    return -1
