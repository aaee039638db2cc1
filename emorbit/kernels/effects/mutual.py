"""Mutual gravity's pieces for an effect set (:mod:`.signatures`): pair forces between points.

Every pair (a, b) of points of different bodies that both take part (coefficient not 0)
attracts with Greenspan's conserving pair force (:func:`.central.pair_unit`), per unit mass
of a: ``F_a = -G m_b (d0 + d1) / (r0 r1 (r0 + r1))``, ``d = x_a - x_b``; its work over the
step is the drop of the pair's potential ``-G m_a m_b / r``.

Where every point is a body of its own (point masses) the pairs are summed by
:func:`.central.pair_pass`: the first evaluation of a sub-step forms every pair in
vectorised loops, later ones only the pairs of the points that moved; the diagonal blocks of
the strongly coupled points (6 h^2/2 times their coupling bound above 1e-4) join their Newton
matrices (:func:`.central.pair_blocks`, :func:`.central.pair_block`). Where points share
bodies (the mass points of rigid and elastic bodies), every pair of different bodies is
summed directly, with every point's diagonal block.

Where the positions come with their low parts (rows 3-5 of ``x0`` and ``x1``: the point-mass
step passes its compensation ``cx``), the pair separations are formed from both, so a close
pair far from the origin keeps its separation, and its energy, to round-off of itself.

Data layout: ``p = [G]``; the scratch ``s`` holds, for the K points that take part, the
packed rows of :func:`.central.pair_pass` (``PAIR_ROWS``, K), their diagonal blocks (9, K)
and whether each is strongly coupled (K,): 36 K values (:func:`scratch_size`).
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import kernel
from .central import PAIR_ROWS, pair_block, pair_blocks, pair_pass, pair_unit

__all__ = ["mutual_pairs", "mutual_pair_potential", "mutual_pair_block", "mutual_pair_rate", "scratch_size"]

#: a point's pair block joins its Newton matrix above this coupling, 6 h^2/2 rho
STRONG = 1e-4


def scratch_size(k: int) -> int:
    """The scratch values of K points that take part."""
    return (PAIR_ROWS + 10) * k


@kernel
def _distinct(idx, body):
    """Whether the points ``idx`` all belong to different bodies."""
    seen = np.zeros(body.max() + 1 if body.shape[0] else 1, np.bool_)
    for i in idx:
        if seen[body[i]]:
            return False
        seen[body[i]] = True
    return True


@kernel
def mutual_pairs(x0, x1, m, body, c, h, p, s, F, W, R, jac, first, weighted):
    """Add the pair forces (per unit mass; ``weighted``: N) into F, their diagonal blocks into
    W where ``jac`` (point masses: only the strongly coupled points'), and set the coupling
    bounds R."""
    n = m.shape[0]
    idx = np.flatnonzero(c != 0.0)
    k = idx.shape[0]
    g = p[0]
    if weighted or not _distinct(idx, body):
        _bodies_pairs(x0, x1, m, body, idx, g, F, W, jac, weighted)
        return
    hh = 0.5 * h * h
    w = s[0 : PAIR_ROWS * k].reshape((PAIR_ROWS, k))
    b = s[PAIR_ROWS * k : (PAIR_ROWS + 9) * k].reshape((9, k))
    strong = s[(PAIR_ROWS + 9) * k : (PAIR_ROWS + 10) * k]
    if first:
        for q in range(k):
            w[6, q] = g * m[idx[q]]
    fp = np.zeros((3, n))
    pair_pass(first, hh, x0, x1, idx, w, np.empty(k, np.int64), fp, R)
    for q in range(k):
        i = idx[q]
        for d in range(3):
            F[d, i] += fp[d, i]
    if not jac:
        return
    count = 0
    for q in range(k):
        strong[q] = 1.0 if 6.0 * hh * w[10, q] > STRONG else 0.0
        count += int(strong[q])
    if 8 * count > k:
        pair_blocks(w[0], w[1], w[2], w[3], w[4], w[5], w[6], b)
    elif count > 0:
        for q in range(k):
            if strong[q] != 0.0:
                pair_block(q, w[0], w[1], w[2], w[3], w[4], w[5], w[6], b)
    for q in range(k):
        if strong[q] != 0.0:
            for e in range(9):
                W[e, idx[q]] += b[e, q]


@kernel
def _bodies_pairs(x0, x1, m, body, idx, g, F, W, jac, weighted):
    """Every pair of points of different bodies: forces per unit mass (``weighted``: N, the
    pair's two bitwise opposite) and diagonal blocks."""
    J = np.empty((3, 3))
    k = idx.shape[0]
    for qa in range(k):
        a = idx[qa]
        for qb in range(qa + 1, k):
            b = idx[qb]
            if body[a] == body[b]:
                continue
            sx, sy, sz, _ = pair_unit(
                x0[0, a] - x0[0, b], x0[1, a] - x0[1, b], x0[2, a] - x0[2, b],
                x1[0, a] - x1[0, b], x1[1, a] - x1[1, b], x1[2, a] - x1[2, b], J,
            )  # fmt: skip
            if weighted:
                ga = gb = g * m[a] * m[b]
            else:
                ga = g * m[b]
                gb = g * m[a]
            F[0, a] += ga * sx
            F[1, a] += ga * sy
            F[2, a] += ga * sz
            F[0, b] -= gb * sx
            F[1, b] -= gb * sy
            F[2, b] -= gb * sz
            if jac:
                for e in range(3):
                    for f in range(3):
                        W[3 * e + f, a] += ga * J[e, f]
                        W[3 * e + f, b] += gb * J[e, f]


@kernel
def mutual_pair_potential(x, m, body, c, p, out):
    """Each point's half of its pairs' potential energy ``-G m_a m_b / r``, J, into ``out`` (n,)."""
    n = m.shape[0]
    g = p[0]
    for a in range(n):
        if c[a] == 0.0:
            continue
        for b in range(a + 1, n):
            if c[b] == 0.0 or body[b] == body[a]:
                continue
            dx = x[0, a] - x[0, b]
            dy = x[1, a] - x[1, b]
            dz = x[2, a] - x[2, b]
            e = 0.5 * g * m[a] * m[b] / math.sqrt(dx * dx + dy * dy + dz * dz)
            out[a] -= e
            out[b] -= e


@kernel(inline="always")
def mutual_pair_block(a0, a1, a2, b0, b1, b2, ma, mb, p, J):
    """The block between two points a, b: ``J = G m_a m_b dS/d(x1_a - x1_b)``, which is
    ``-d F_a / d x1_b`` (N/m), from their separation at the step's start (a) and end (b)."""
    pair_unit(a0, a1, a2, b0, b1, b2, J)
    gab = p[0] * ma * mb
    for e in range(3):
        for f in range(3):
            J[e, f] *= gab


@kernel(inline="always")
def mutual_pair_rate(d0, d1, d2, u0, u1, u2, ma, mb, p):
    """The squared Kepler rate of a pair, ``W = G (m_a + m_b) / r**3`` (1/s^2), and its rate of
    change along the relative motion (separation d, relative velocity u), 1/s^3."""
    r2 = d0 * d0 + d1 * d1 + d2 * d2
    w = p[0] * (ma + mb) / (r2 * math.sqrt(r2))
    return w, -3.0 * w * (d0 * u0 + d1 * u1 + d2 * u2) / r2
