"""Kernels of coupled structures: the sparse Jacobian's values and the forces, filled in place.

A structure's unknowns are 3-vector *slots* (FE nodes, point masses, each rigid body's
centre of mass and three axes); node ``n`` of an element is the combination
``sum_k node_coef[n, k] * slot[node_slot[n, k]]`` (at most four slots, -1 ends the list).
The Jacobian of one step, in compressed sparse columns (``indptr``, ``indices``, ``data``),
has a pattern built once by :class:`emorbit.bodies.coupled.Structure`; these kernels add
values into it:

* :func:`fill_forces`: the element forces F mapped to the slots and, for Newton,
  ``-h**2/2 K`` of the element stiffness;
* :func:`add_point_blocks`: the own blocks of the effects' forces at points (gravity points,
  mass points: :mod:`.structure_effects`), mapped to the slots (the blocks between points stay
  out of the matrix, which keeps its pattern that of the bodies alone);
* :func:`fill_constraints`: the rigid bodies' orthonormality constraints
  ``d_k . d_l = delta_kl``: ``(h/2) G(u05)^T nu`` in the momentum rows, ``g(u1)`` scaled by
  ``es`` in the constraint rows, and their derivatives;
* :func:`equilibrate`: row and column scales to unit max-norm (LAPACK's geequ), so that
  SuperLU factors a balanced matrix;
* :func:`scatter`: values given as (row, col, value) triplets added onto the pattern.

References: Goettlicher & Schweizerhof (g_em and its load stiffness); Betsch & Steinmann
(2001) for the director constraints.
"""

from __future__ import annotations

import numpy as np

from .codes import STATUS_OK
from .elastic import bar_forces, csc_find, spread_rows, tet_forces
from .jit import kernel

__all__ = ["fill_forces", "add_point_blocks", "add_block", "add_block_at", "fill_constraints", "equilibrate", "scatter"]


@kernel
def fill_forces(
    method, hh, x0n, x1n, node_slot, node_coef, bar_node, bar_EA, bar_L, tet_node, tet_g, tet_V, tet_lam, tet_mu,
    want_K, indptr, indices, data, Fslot, fn, kb, kt,
):  # fmt: skip
    """The elements' generalised forces into Fslot (n_slots, 3) and, if ``want_K``, -hh K of
    their stiffness added into the Jacobian values ``data``. Returns a status."""
    fn[:, :] = 0.0
    bar_forces(method, x0n, x1n, bar_node, bar_EA, bar_L, fn, kb)
    tet_forces(method, x0n, x1n, tet_node, tet_g, tet_V, tet_lam, tet_mu, fn, kt)
    # node forces -> slot forces
    Fslot[:, :] = 0.0
    spread_rows(fn, node_slot, node_coef, Fslot)
    if not want_K:
        return STATUS_OK
    # stiffness blocks -> J
    for e in range(bar_node.shape[0]):
        a = bar_node[e, 0]
        b = bar_node[e, 1]
        add_block(a, a, kb[e], -hh, node_slot, node_coef, indptr, indices, data)
        add_block(b, b, kb[e], -hh, node_slot, node_coef, indptr, indices, data)
        add_block(a, b, kb[e], hh, node_slot, node_coef, indptr, indices, data)
        add_block(b, a, kb[e], hh, node_slot, node_coef, indptr, indices, data)
    for e in range(tet_node.shape[0]):
        for a in range(4):
            for b in range(4):
                add_block(tet_node[e, a], tet_node[e, b], kt[e, a, b], -hh, node_slot, node_coef, indptr, indices, data)
    return STATUS_OK


@kernel
def add_point_blocks(p_node, p_w, K, scale, node_slot, node_coef, indptr, indices, data):
    """data += scale * w_a w_b K[q] for every two nodes a, b of every point q (gravity or
    mass points: p_node, p_w (q, 4), -1 ends a row; K (q, 3, 3) each point's own block)."""
    for q in range(p_node.shape[0]):
        for a in range(4):
            na = p_node[q, a]
            if na < 0:
                break
            for b in range(4):
                nb = p_node[q, b]
                if nb < 0:
                    break
                add_block(na, nb, K[q], scale * p_w[q, a] * p_w[q, b], node_slot, node_coef, indptr, indices, data)


@kernel
def add_block(na, nb, K, scale, node_slot, node_coef, indptr, indices, data):
    """data += scale * (c_i c_j) K for every slot pair of nodes na, nb."""
    add_block_at(0, 0, na, nb, K, scale, node_slot, node_coef, 0, indptr, indices, data)


@kernel
def add_block_at(l, m, na, nb, K, scale, node_slot, node_coef, n, indptr, indices, data):
    """:func:`add_block` into block (l, m) of a matrix of blocks of ``n`` rows and columns
    (the time finite element's stage matrix, :mod:`.elastic_tfe`)."""
    for i in range(4):
        si = node_slot[na, i]
        if si < 0:
            break
        ci = node_coef[na, i]
        for j in range(4):
            sj = node_slot[nb, j]
            if sj < 0:
                break
            f = scale * ci * node_coef[nb, j]
            if f == 0.0:
                continue
            for e in range(3):
                col = m * n + 3 * sj + e
                for d in range(3):
                    p = csc_find(indptr, indices, l * n + 3 * si + d, col)
                    data[p] += f * K[d, e]


@kernel
def fill_constraints(rb_slots, u05, u1, nu, es, hf, want_K, indptr, indices, data, R1, R2, nslot3):
    """Rigid-body constraints: hf G(u05)^T nu into R1, es g(u1) into R2, and the blocks
    hf/2 S (x) I, hf G05^T, es G1 into the Jacobian values."""
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    for r in range(rb_slots.shape[0]):
        base = nslot3 + 6 * r
        for j in range(6):
            k, l = pairs[j]
            sk = rb_slots[r, 1 + k]
            sl = rb_slots[r, 1 + l]
            # residuals
            dot = 0.0
            for d in range(3):
                dot += u1[sk, d] * u1[sl, d]
            R2[6 * r + j] = es[r] * (0.5 * (dot - 1.0) if k == l else dot)
            for d in range(3):
                R1[3 * sk + d] += hf * nu[6 * r + j] * u05[sl, d]
                if k != l:
                    R1[3 * sl + d] += hf * nu[6 * r + j] * u05[sk, d]
            if not want_K:
                continue
            # Jacobian: columns of nu (hf G05^T) and rows of g (es G1)
            for d in range(3):
                p = csc_find(indptr, indices, 3 * sk + d, base + j)
                data[p] += hf * u05[sl, d]
                p = csc_find(indptr, indices, base + j, 3 * sk + d)
                data[p] += es[r] * u1[sl, d]
                if k != l:
                    p = csc_find(indptr, indices, 3 * sl + d, base + j)
                    data[p] += hf * u05[sk, d]
                    p = csc_find(indptr, indices, base + j, 3 * sl + d)
                    data[p] += es[r] * u1[sk, d]
            # d (hf G05^T nu) / d du = hf/2 nu_j (blocks (k, l) and (l, k) of I)
            for d in range(3):
                p = csc_find(indptr, indices, 3 * sk + d, 3 * sl + d)
                data[p] += 0.5 * hf * nu[6 * r + j]
                if k != l:
                    p = csc_find(indptr, indices, 3 * sl + d, 3 * sk + d)
                    data[p] += 0.5 * hf * nu[6 * r + j]


@kernel
def equilibrate(data, indices, indptr, n):
    """Row scales r, column scales c (unit max-norm rows, then columns) and the scaled values."""
    r = np.zeros(n)
    for col in range(n):
        for p in range(indptr[col], indptr[col + 1]):
            a = abs(data[p])
            if a > r[indices[p]]:
                r[indices[p]] = a
    for i in range(n):
        r[i] = 1.0 / r[i] if r[i] > 0.0 else 1.0
    c = np.zeros(n)
    out = np.empty_like(data)
    for col in range(n):
        m = 0.0
        for p in range(indptr[col], indptr[col + 1]):
            a = abs(data[p]) * r[indices[p]]
            if a > m:
                m = a
        c[col] = 1.0 / m if m > 0.0 else 1.0
        for p in range(indptr[col], indptr[col + 1]):
            out[p] = data[p] * r[indices[p]] * c[col]
    return r, c, out


@kernel
def scatter(rows, cols, vals, indptr, indices, data):
    for k in range(rows.shape[0]):
        data[csc_find(indptr, indices, rows[k], cols[k])] += vals[k]
