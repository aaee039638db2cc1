"""A rigid body's facets under the surface effects of a set (drag, radiation pressure, a
user's): their geometry over a step, the generalised force and its derivative.

A point of body coordinates Y (relative to the centre of mass) is at ``x = phi + Y^k d_k``,
linear in ``q = (phi, d1, d2, d3)``, so a force f there is the generalised force ``(f, Y^1 f,
Y^2 f, Y^3 f)`` and its work over a step is ``f . (x1 - x0)``, exactly what it adds to the
kinetic energy in an em step (the constraint forces do no work). A facet (centre Y, normal N,
area A, coefficients Cd, specular, diffuse, two-sided) enters the set's ``facets`` function
(:mod:`.effects.signatures`) with its centre at the step's start and end, and its normal at
the step's middle, ``n = N^k (d_k0 + d_k1) / 2`` normalised.

Data layout: ``facets`` (nf, 11) float64 rows ``[Yx, Yy, Yz, Nx, Ny, Nz, A, Cd, specular,
diffuse, two_sided]`` (body frame, m, m^2), a body's rows ``f0 .. f1``; the scratch of
:func:`facet_scratch`. References: J. C. Simo, N. Tarnow, ZAMP 43 (1992) 757-792; P. Betsch,
P. Steinmann, Comput. Methods Appl. Mech. Eng. 191 (2001) 467-488.
"""

from __future__ import annotations

import math

import numpy as np

from .codes import STATUS_OK
from .copies import copy1
from .jit import kernel

__all__ = ["facet_scratch", "facet_forces", "facet_jacobian", "spread"]


@kernel(inline="always")
def spread(F, Y0, Y1, Y2, gx, gy, gz):
    """Add the generalised force of a force g at the body point Y: ``(g, Y^1 g, Y^2 g, Y^3 g)``."""
    F[0] += gx
    F[1] += gy
    F[2] += gz
    F[3] += Y0 * gx
    F[4] += Y0 * gy
    F[5] += Y0 * gz
    F[6] += Y1 * gx
    F[7] += Y1 * gy
    F[8] += Y1 * gz
    F[9] += Y2 * gx
    F[10] += Y2 * gy
    F[11] += Y2 * gz


@kernel
def facet_scratch(nf, nw):
    """Scratch for :func:`facet_forces` of a body with ``nf`` facets and ``nw`` working effects:
    (A, B, N (3, nf), area (nf,), kf (4, nf), forces (3, nf), work (nw, nf), three (12,) rows)."""
    return (
        np.empty((3, nf)), np.empty((3, nf)), np.empty((3, nf)), np.empty(nf), np.empty((4, nf)),
        np.empty((3, nf)), np.zeros((nw, nf)), np.empty(12), np.empty(12), np.empty(12),
    )  # fmt: skip


@kernel
def _geometry(q0, q1, facets, f0, f1, A, B, N, area, kf):
    """The facets' centres at q0 and q1, unit normals at the middle, areas and coefficients."""
    for f in range(f0, f1):
        j = f - f0
        Y0, Y1, Y2 = facets[f, 0], facets[f, 1], facets[f, 2]
        N0, N1, N2 = facets[f, 3], facets[f, 4], facets[f, 5]
        nn = 0.0
        for d in range(3):
            A[d, j] = q0[d] + Y0 * q0[3 + d] + Y1 * q0[6 + d] + Y2 * q0[9 + d]
            B[d, j] = q1[d] + Y0 * q1[3 + d] + Y1 * q1[6 + d] + Y2 * q1[9 + d]
            n = 0.5 * (N0 * (q0[3 + d] + q1[3 + d]) + N1 * (q0[6 + d] + q1[6 + d]) + N2 * (q0[9 + d] + q1[9 + d]))
            N[d, j] = n
            nn += n * n
        nn = math.sqrt(nn)
        for d in range(3):
            N[d, j] /= nn
        area[j] = facets[f, 6]
        for k in range(4):
            kf[k, j] = facets[f, 7 + k]


@kernel
def facet_forces(facets_fn, q0, q1, h, F, facets, f0, f1, P, I, T, S, scratch, want_work):
    """Add the surface effects' generalised force on facets ``f0 .. f1`` into F (12,) (N; N m
    on the director rows); where ``want_work``, ``scratch[6]`` (nw, nf) gets each working
    effect's work on each facet over the step (J). Returns the set's status."""
    A, B, N, area, kf, Ff, out = scratch[0], scratch[1], scratch[2], scratch[3], scratch[4], scratch[5], scratch[6]
    _geometry(q0, q1, facets, f0, f1, A, B, N, area, kf)
    status = facets_fn(A, B, N, area, kf, h, P, I, T, S, Ff, out, want_work)
    for f in range(f0, f1):
        j = f - f0
        spread(F, facets[f, 0], facets[f, 1], facets[f, 2], Ff[0, j], Ff[1, j], Ff[2, j])
    return status


@kernel
def facet_jacobian(facets_fn, q0, q1, h, K, facets, f0, f1, P, I, T, S, scratch):
    """Add the derivative of :func:`facet_forces` with respect to q1 into K (12, 12), by forward
    differences: steps of 1e-6 of the centre's increment (at least 1e-6 m) and 1e-7 on the
    directors. The facets' aerodynamic and radiation torques depend on the attitude; at
    steps comparable to the period of the attitude motion they drive (a weathervane's), a
    Newton matrix without them contracts by only (omega h)^2 / 2 per iteration. The
    difference quotients' error (about 1e-7 relative) slows Newton's quadratic convergence
    no more than the chord matrix does."""
    base, moved, qq = scratch[7], scratch[8], scratch[9]
    base[:] = 0.0
    facet_forces(facets_fn, q0, q1, h, base, facets, f0, f1, P, I, T, S, scratch, False)
    for j in range(12):
        e = 1e-6 * max(abs(q1[j] - q0[j]), 1.0) if j < 3 else 1e-7
        copy1(qq, q1)
        qq[j] = q1[j] + e
        e = qq[j] - q1[j]  # the step as represented
        moved[:] = 0.0
        facet_forces(facets_fn, q0, qq, h, moved, facets, f0, f1, P, I, T, S, scratch, False)
        for i in range(12):
            K[i, j] += (moved[i] - base[i]) / e
    return STATUS_OK
