"""Mutual gravity between the mass points of different bodies: pair forces and energy.

Method: the mass points ``a`` and ``b`` of two different bodies attract each other with
Greenspan's conserving pair force over a step (:func:`.central.pair_unit`, the g_em of the
central field with the separation ``d = x_a - x_b`` in place of ``x - c``)::

    f_a = -G m_a m_b (d0 + d1) / (r0 r1 (r0 + r1)) = -f_b

Its work over the step is exactly the drop of ``-G m_a m_b / r`` from ``r0`` to ``r1``; the two
forces are equal and opposite (linear momentum is kept) and lie along the mean separation
``(d0 + d1) / 2``, so their moments about any point cancel at the points' mean positions
(angular momentum is kept, for rigid bodies too: their mass points' forces act at the mean
positions ``x = phi + X^k d_k`` of the step, linear in the configuration). Pairs inside one
body are left out: a rigid body's are constant, an elastic body's self-gravity is not
modelled.

Data layout: ``x0``, ``x1`` (n, 3) the mass points at the start and end of the step, m;
``m`` (n,) their masses, kg; ``body`` (n,) int64 the body each belongs to; ``on`` (n,)
float64, 1 where the point takes part; ``f`` (n, 3) the forces, N; ``k`` (n, 3, 3) each
point's own Jacobian block ``d f_a / d x1_a`` (N/m). Between two compact bodies (point
masses, rigid bodies: ``cross`` (n,) 1) the blocks between points are summed per pair of
bodies onto their slots by :func:`mutual_cross`: point ``a`` sits at ``sum_i c_ai s_i`` of
its body's slots (``coef`` (n, 4)), and ``d f_a / d x1_b = d f_b / d x1_a = -G m_a m_b J_ab``
gives ``acc[A, B, i, j] = sum_ab c_ai c_bj G m_a m_b J_ab`` (nb, nb, 4, 4, 3, 3).

References: D. Greenspan, J. Comput. Phys. 56 (1984) 28-41; Goettlicher & Schweizerhof.
"""

from __future__ import annotations

import math

import numpy as np

from ..codes import STATUS_OK, STATUS_SINGULAR
from ..jit import kernel
from .central import pair_unit

__all__ = ["mutual_forces", "mutual_cross", "mutual_potential"]


@kernel
def mutual_forces(g, x0, x1, m, body, on, f, k):
    """The pair forces of mutual gravity on every point into ``f`` and their own Jacobian
    blocks into ``k`` (both overwritten); ``g`` is the constant of gravitation. Returns
    STATUS_SINGULAR where two points of different bodies meet (or a value is not finite),
    else STATUS_OK.
    """
    n = m.shape[0]
    J = np.empty((3, 3))
    f[:, :] = 0.0
    k[:, :, :] = 0.0
    check = 0.0
    for a in range(n):
        if on[a] == 0.0:
            continue
        for b in range(a + 1, n):
            if on[b] == 0.0 or body[b] == body[a]:
                continue
            sx, sy, sz, big = pair_unit(
                x0[a, 0] - x0[b, 0], x0[a, 1] - x0[b, 1], x0[a, 2] - x0[b, 2],
                x1[a, 0] - x1[b, 0], x1[a, 1] - x1[b, 1], x1[a, 2] - x1[b, 2], J,
            )  # fmt: skip
            gab = g * m[a] * m[b]
            f[a, 0] += gab * sx
            f[a, 1] += gab * sy
            f[a, 2] += gab * sz
            f[b, 0] -= gab * sx
            f[b, 1] -= gab * sy
            f[b, 2] -= gab * sz
            for i in range(3):
                for j in range(3):
                    k[a, i, j] += gab * J[i, j]
                    k[b, i, j] += gab * J[i, j]
            check += big
    if not (abs(check) < math.inf):
        return STATUS_SINGULAR
    return STATUS_OK


@kernel
def mutual_cross(g, x0, x1, m, body, on, cross, coef, acc):
    """The Jacobian blocks between compact bodies, summed per pair of bodies (A < B) onto
    their slots: ``acc`` (nb, nb, 4, 4, 3, 3), overwritten (see the module docstring)."""
    n = m.shape[0]
    J = np.empty((3, 3))
    acc[...] = 0.0
    for a in range(n):
        if on[a] == 0.0 or cross[a] == 0.0:
            continue
        for b in range(a + 1, n):
            if on[b] == 0.0 or cross[b] == 0.0 or body[b] == body[a]:
                continue
            pair_unit(
                x0[a, 0] - x0[b, 0], x0[a, 1] - x0[b, 1], x0[a, 2] - x0[b, 2],
                x1[a, 0] - x1[b, 0], x1[a, 1] - x1[b, 1], x1[a, 2] - x1[b, 2], J,
            )  # fmt: skip
            gab = g * m[a] * m[b]
            A = body[a]
            B = body[b]
            for i in range(4):
                ca = coef[a, i] * gab
                if ca == 0.0:
                    continue
                for j in range(4):
                    cab = ca * coef[b, j]
                    if cab == 0.0:
                        continue
                    for d in range(3):
                        for e in range(3):
                            acc[A, B, i, j, d, e] += cab * J[d, e]


@kernel
def mutual_potential(g, x, m, body, on):
    """The potential energy of mutual gravity, ``-sum G m_a m_b / |x_a - x_b|`` over the pairs
    of points of different bodies that take part, J (x (n, 3) m)."""
    n = m.shape[0]
    out = 0.0
    for a in range(n):
        if on[a] == 0.0:
            continue
        s = 0.0
        for b in range(a + 1, n):
            if on[b] == 0.0 or body[b] == body[a]:
                continue
            dx = x[a, 0] - x[b, 0]
            dy = x[a, 1] - x[b, 1]
            dz = x[a, 2] - x[b, 2]
            s += m[b] / math.sqrt(dx * dx + dy * dy + dz * dz)
        out -= g * m[a] * s
    return out
