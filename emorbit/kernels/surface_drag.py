"""Drag on the surface triangles of elastic bodies: nodal forces over a step and their work.

A surface triangle (nodes a, b, c, numbered so that the right-hand rule gives the outward
normal) is a flat facet that moves and deforms with its nodes. Over a step x0 -> x1 it is
evaluated at its midpoint configuration: normal and area from ``(x_b - x_a) x (x_c - x_a)``
at the nodes' midpoints, centroid ``x_m = (c0 + c1) / 2`` with ``c`` the mean of its nodes,
velocity relative to the co-rotating air ``v = (c1 - c0) / h - w x (x_m - c)``, the density
at x_m's altitude (a band table or NRLMSIS's grid, as point masses take it), and the facet's
force :func:`.effects.radiation.drag_plate` (one-sided, Cd per triangle) acts a third on
each node. Its work over the step is ``f . (c1 - c0) = sum over the nodes of (f / 3) .
(x1 - x0)``, exactly what it adds to the kinetic energy of an em step, which
:func:`surface_drag` returns, so that the structure sums it.

Data layout: node positions (n_nodes, 3) float64 (relative to any reference point, the
centre ``drag_p[0:3]`` in the same frame); ``tris`` (nt, 3) int64 node indices; ``cd`` (nt,)
float64; drag's parameters as :mod:`emorbit.effects.drag` (``drag_p``, ``drag_t``, ``drag_g``,
``drag_gp``) and ``dsun`` (3,) the Sun relative to the centre (NRLMSIS's local time);
nodal forces are added into ``fn`` (n_nodes, 3), N. References: J. C. Simo, N. Tarnow, ZAMP
43 (1992) 757-792; D. A. Vallado, Fundamentals of Astrodynamics and Applications, 4th ed.
(2013), section 8.6.2.
"""

from __future__ import annotations

import math

from .effects.atmosphere import ussa1976_density
from .effects.atmosphere_grid import grid_density
from .effects.radiation import drag_plate
from .jit import kernel

__all__ = ["surface_drag"]


@kernel
def surface_drag(x0n, x1n, tris, cd, h, drag_p, drag_t, drag_g, drag_gp, dsun, fn):
    """Add drag's nodal forces on the surface triangles into ``fn``; return their work (J).

    Parameters
    ----------
    x0n, x1n : ndarray
        (n_nodes, 3) node positions at the step's start and end, m.
    tris : ndarray
        (nt, 3) int64 the triangles' nodes, outward by the right-hand rule.
    cd : ndarray
        (nt,) each triangle's drag coefficient.
    h : float
        The step, s.
    drag_p, drag_t, drag_g, drag_gp : ndarray
        Drag's parameters (:class:`emorbit.effects.drag.Drag`).
    dsun : ndarray
        (3,) the Sun relative to the centre, m (read by a grid atmosphere).
    fn : ndarray
        (n_nodes, 3), added into, N.

    Returns
    -------
    float
        ``sum f . (c1 - c0)`` over the triangles, J.
    """
    third = 1.0 / 3.0
    work = 0.0
    for t in range(tris.shape[0]):
        a, b, c = tris[t, 0], tris[t, 1], tris[t, 2]
        ca0 = third * (x0n[a, 0] + x0n[b, 0] + x0n[c, 0])
        ca1 = third * (x0n[a, 1] + x0n[b, 1] + x0n[c, 1])
        ca2 = third * (x0n[a, 2] + x0n[b, 2] + x0n[c, 2])
        cb0 = third * (x1n[a, 0] + x1n[b, 0] + x1n[c, 0])
        cb1 = third * (x1n[a, 1] + x1n[b, 1] + x1n[c, 1])
        cb2 = third * (x1n[a, 2] + x1n[b, 2] + x1n[c, 2])
        e0 = 0.5 * ((x0n[b, 0] + x1n[b, 0]) - (x0n[a, 0] + x1n[a, 0]))
        e1 = 0.5 * ((x0n[b, 1] + x1n[b, 1]) - (x0n[a, 1] + x1n[a, 1]))
        e2 = 0.5 * ((x0n[b, 2] + x1n[b, 2]) - (x0n[a, 2] + x1n[a, 2]))
        g0 = 0.5 * ((x0n[c, 0] + x1n[c, 0]) - (x0n[a, 0] + x1n[a, 0]))
        g1 = 0.5 * ((x0n[c, 1] + x1n[c, 1]) - (x0n[a, 1] + x1n[a, 1]))
        g2 = 0.5 * ((x0n[c, 2] + x1n[c, 2]) - (x0n[a, 2] + x1n[a, 2]))
        n0 = e1 * g2 - e2 * g1
        n1 = e2 * g0 - e0 * g2
        n2 = e0 * g1 - e1 * g0
        nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if not nn > 0.0:
            continue
        d0 = 0.5 * (ca0 + cb0) - drag_p[0]
        d1 = 0.5 * (ca1 + cb1) - drag_p[1]
        d2 = 0.5 * (ca2 + cb2) - drag_p[2]
        s0, s1, s2 = cb0 - ca0, cb1 - ca1, cb2 - ca2
        v0 = s0 / h - (drag_p[4] * d2 - drag_p[5] * d1)
        v1 = s1 / h - (drag_p[5] * d0 - drag_p[3] * d2)
        v2 = s2 / h - (drag_p[3] * d1 - drag_p[4] * d0)
        if drag_p[7] == 0.0:
            rho = ussa1976_density(math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) - drag_p[6], drag_t[0], drag_t[1], drag_t[2])
        else:
            rho, _ = grid_density(
                d0, d1, d2, dsun[0], dsun[1], dsun[2], drag_p[10], drag_p[11], drag_p[12], drag_p[6], drag_gp, drag_g
            )
        fx, fy, fz = drag_plate(n0 / nn, n1 / nn, n2 / nn, v0, v1, v2, 0.5 * nn, cd[t], rho, False)
        work += fx * s0 + fy * s1 + fz * s2
        fx *= third
        fy *= third
        fz *= third
        for k in (a, b, c):
            fn[k, 0] += fx
            fn[k, 1] += fy
            fn[k, 2] += fz
    return work
