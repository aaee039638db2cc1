"""A coupled structure's points and surfaces under the effects of a set.

The structure steps in coordinates relative to a reference point ``ref`` (its first position
slot), which keeps its elements' strains precise; the effects take absolute positions,
``x = x_rel + ref`` (the same ``ref`` at both ends of a step, so a discrete force's work is
still the drop of its potential). Point effects act at the gravity points (a point mass, a
rigid body's mass points or centre of mass, an elastic body's quadrature points); pair
effects at the mass points of mutual gravity; surface effects on the boundary triangles of
elastic bodies (a triangle's centroid, its normal and area at the midpoint configuration, the
force a third on each node: its work ``f . (c1 - c0)`` is the nodes' ``sum f/3 . (x1 -
x0)``) and on the facets of rigid bodies (:mod:`.rigid_surface`).

Data layout: points (q, 3) relative positions, m; ``m`` (q,) kg; ``body`` (q,) int64;
``coef`` (k, q); forces out (q, 3) N and blocks (q, 3, 3) N/m; triangles ``tris`` (nt, 3)
int64 node indices (outward by the right-hand rule; a burn's thruster is one node three
times, of area and normal 0), ``kf`` (4, nt) facet coefficients; the
set's arrays as :mod:`.effects.signatures`.
"""

from __future__ import annotations

import math

import numpy as np

from .effects.signatures import MODE_WEIGHTED
from .elastic import csc_find
from .jit import kernel

__all__ = ["point_effects", "point_effects_work", "point_potentials", "triangle_effects", "prepare_set", "cross_blocks"]


@kernel
def _absolute(x0, x1, ref):
    """(3, q) absolute positions at both ends from (q, 3) relative ones."""
    q = x0.shape[0]
    a = np.empty((3, q))
    b = np.empty((3, q))
    for i in range(q):
        for d in range(3):
            a[d, i] = x0[i, d] + ref[d]
            b[d, i] = x1[i, d] + ref[d]
    return a, b


@kernel
def point_effects(forces, mode, x0, x1, ref, m, body, coef, h, P, I, T, S, R, f, k, want_K, first):
    """The set's forces at the points (f, N; weighted, so that a pair's two forces are bitwise
    opposite) and, where ``want_K``, their own blocks (k, N/m); R (q,) the pair coupling
    bounds, kept between calls. Returns the set's status."""
    q = x0.shape[0]
    a, b = _absolute(x0, x1, ref)
    F = np.empty((3, q))
    W = np.empty((9, q))
    status = forces(a, b, m, body, coef, h, mode | MODE_WEIGHTED, P, I, T, S, F, W, R, want_K, first)
    for i in range(q):
        for d in range(3):
            f[i, d] = F[d, i]
        if want_K:
            for d in range(3):
                for e in range(3):
                    k[i, d, e] = W[3 * d + e, i]
    return status


@kernel
def point_effects_work(work_of, mode, x0, x1, ref, m, body, coef, h, P, I, T, S, out):
    """Add each working effect's work over the step on all points into ``out`` (w,), J."""
    q = x0.shape[0]
    a, b = _absolute(x0, x1, ref)
    dx = np.empty((3, q))
    for i in range(q):
        for d in range(3):
            dx[d, i] = b[d, i] - a[d, i]
    each = np.zeros((out.shape[0], q))
    work_of(a, dx, m, body, coef, h, mode, P, I, T, S, each)
    for s in range(out.shape[0]):
        total = 0.0
        for i in range(q):
            total += each[s, i]
        out[s] += total


@kernel
def point_potentials(potential, x, ref, m, body, coef, P, I, T, S, out):
    """Each effect's potential energy at each point (relative positions x (q, 3)) into ``out``
    (k, q), J, after ``prepare`` at the points' time."""
    a, _ = _absolute(x, x, ref)
    potential(a, m, body, coef, P, I, T, S, out)


@kernel
def triangle_effects(facets_fn, x0n, x1n, ref, tris, kf, h, P, I, T, S, fn, out, want_work):
    """Add the surface effects' nodal forces on the triangles into ``fn`` (n_nodes, 3), and,
    where ``want_work``, each working effect's work on them into ``out`` (w,). Returns the
    set's status."""
    nt = tris.shape[0]
    A = np.empty((3, nt))
    B = np.empty((3, nt))
    N = np.empty((3, nt))
    area = np.empty(nt)
    for t in range(nt):
        i, j, l = tris[t, 0], tris[t, 1], tris[t, 2]
        ex = ey = ez = 0.0
        for d in range(3):
            A[d, t] = (x0n[i, d] + x0n[j, d] + x0n[l, d]) / 3.0 + ref[d]
            B[d, t] = (x1n[i, d] + x1n[j, d] + x1n[l, d]) / 3.0 + ref[d]
        # the midpoint configuration's edges
        u0 = 0.5 * ((x0n[j, 0] + x1n[j, 0]) - (x0n[i, 0] + x1n[i, 0]))
        u1 = 0.5 * ((x0n[j, 1] + x1n[j, 1]) - (x0n[i, 1] + x1n[i, 1]))
        u2 = 0.5 * ((x0n[j, 2] + x1n[j, 2]) - (x0n[i, 2] + x1n[i, 2]))
        w0 = 0.5 * ((x0n[l, 0] + x1n[l, 0]) - (x0n[i, 0] + x1n[i, 0]))
        w1 = 0.5 * ((x0n[l, 1] + x1n[l, 1]) - (x0n[i, 1] + x1n[i, 1]))
        w2 = 0.5 * ((x0n[l, 2] + x1n[l, 2]) - (x0n[i, 2] + x1n[i, 2]))
        ex = u1 * w2 - u2 * w1
        ey = u2 * w0 - u0 * w2
        ez = u0 * w1 - u1 * w0
        norm = math.sqrt(ex * ex + ey * ey + ez * ez)
        area[t] = 0.5 * norm
        if norm == 0.0:  # a facet at one node (a thruster): no area, no normal
            norm = 1.0
        N[0, t] = ex / norm
        N[1, t] = ey / norm
        N[2, t] = ez / norm
    Ff = np.empty((3, nt))
    each = np.zeros((out.shape[0], nt))
    status = facets_fn(A, B, N, area, kf, h, P, I, T, S, Ff, each, want_work)
    for t in range(nt):
        for c in range(3):
            g = Ff[c, t] / 3.0
            fn[tris[t, 0], c] += g
            fn[tris[t, 1], c] += g
            fn[tris[t, 2], c] += g
    if want_work:
        for s in range(out.shape[0]):
            total = 0.0
            for t in range(nt):
                total += each[s, t]
            out[s] += total
    return status


@kernel
def prepare_set(prepare, ta, tm, tb, P, I, T, S):
    """The set's ``prepare`` for a sub-step from ``ta`` to ``tb`` (callable from Python)."""
    prepare(ta, tm, tb, P, I, T, S)


@kernel
def cross_blocks(cross, x0, x1, ref, m, body, coef, on, sc, acc, body_slots, hh, P, I, T, S, indptr, indices, data):
    """The pair effects' blocks between compact bodies (``cross``, the set's compiled function,
    into ``acc`` (nb, nb, 4, 4, 3, 3)), added as ``-hh K`` onto each pair of bodies' slots
    (``body_slots`` (nb, 4), -1 ends a row) in the Jacobian's values ``data``."""
    a, b = _absolute(x0, x1, ref)
    cross(a, b, m, body, coef, on, sc, acc, P, I, T, S)
    nb = acc.shape[0]
    for A in range(nb):
        for B in range(A + 1, nb):
            for i in range(4):
                si = body_slots[A, i]
                if si < 0:
                    break
                for j in range(4):
                    sj = body_slots[B, j]
                    if sj < 0:
                        break
                    for d in range(3):
                        for e in range(3):
                            v = hh * acc[A, B, i, j, d, e]  # -hh K, K = -J summed
                            if v != 0.0:
                                data[csc_find(indptr, indices, 3 * si + d, 3 * sj + e)] += v
                                data[csc_find(indptr, indices, 3 * sj + d, 3 * si + e)] += v
