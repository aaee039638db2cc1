"""The one contract between the effects and the body kinds' step kernels: its data layout
and the Numba types of the functions an effect set compiles into.

An effect gives plain kernel functions of float64 scalars and arrays, its *pieces*
(:mod:`emorbit.effects.base` declares them, :mod:`emorbit.effects.program` compiles a set of
effects into the seven functions below). The step kernels of every body kind (point masses,
rigid bodies' mass points and facets, elastic bodies' gravity points and surfaces) take
those seven as arguments of the types defined here, so a step kernel is compiled once per
install, whatever effects a scene names, and an effect set compiles only its own small
functions.

Pieces, per unit mass of a point (all optional but ``force``)::

    force(x0, y0, z0, x1, y1, z1, h, c, p, tab, s, J, jac) -> (fx, fy, fz)
        the effect's force over a step x0 -> x1 of length h (the discrete force of an em
        step: its work equals the drop of the effect's potential), and, where ``jac``, its
        derivative with respect to the end point added into J (3, 3): ``J[a, b] += dF_a /
        dx1_b``. With x0 = x1 = x it is the force at x. c is the point's coefficient for
        the effect (a body key such as drag's ``Cd A / m``; 1 where the effect has none; the
        set skips points whose c is 0).
    potential(x, y, z, c, p, tab, s) -> V
        the potential energy per unit mass (conservative effects).
    prepare(ta, tm, tb, p, tab, s)
        fills the scratch s with what every point's force reads over a sub-step from ta to
        tb (its middle tm): a body's position on its path, the Sun's.
    time_work(x0, y0, z0, x1, y1, z1, c, p, tab, s) -> W
        the work per unit mass of the potential's change in time over the sub-step (an
        effect that depends on time), at the positions x0 and x1.
    facet(ax, ay, az, bx, by, bz, nx, ny, nz, area, k0, k1, k2, k3, h, p, tab, s) -> (fx, fy, fz)
        a surface effect's force (N) on a flat facet of ``area`` (m^2) whose centre moves
        a -> b over the step, with unit normal n at the step's middle and the facet
        coefficients k (drag coefficient Cd, specular and diffuse reflectivity, two-sided
        flag).
    pairs(x0, x1, m, body, c, h, p, s, F, W, R, jac, first, weighted)
        an effect between pairs of points (mutual gravity): adds its forces per unit mass
        (``weighted``: the forces, N) into F (3, n), the diagonal blocks of their Jacobian
        into W (9, n) where ``jac``, and each point's coupling bound ``sum_j |dF_i / dx1_j|``
        (1/s^2) into R (n,), between points of different ``body`` where ``c`` is not 0;
        ``first`` is the first evaluation of a sub-step (the piece may keep what it formed in
        s). Weighted, the two forces of a pair are bitwise opposite, so that a system that
        steps masses (a structure) keeps momentum and angular momentum to round-off.

    rate(x, y, z, vx, vy, vz, c, p) -> (W, dW)
        the squared rate that sets adaptive steps' time scale at a point (1/s^2: a Kepler rate
        GM / r**3), and its rate of change along the motion (1/s^3).
    pair_rate(d0, d1, d2, u0, u1, u2, ma, mb, p) -> (W, dW)
        the same for a pair of points from their separation and relative velocity.
    pair_block(a0, a1, a2, b0, b1, b2, ma, mb, p, J)
        a pair effect's block between two points: ``J = -d F_a / d x1_b`` (N/m; F_a the force
        on point a, N) from their separation ``x_a - x_b`` at the step's start (a) and end (b)
        and their masses.

p is the effect's parameter vector, tab its tables (flat; the piece reshapes them from sizes
in p), s its scratch (what ``prepare`` fills, and a pair effect's working rows).

Data layout of an effect set, k effects (the order in which their forces are summed):

``P`` (float64), ``T`` (float64), ``S`` (float64)
    every effect's parameters, tables and scratch, one after another;
``I`` (k, 6) int64
    effect e's slices: ``P[I[e, 0]:I[e, 1]]``, ``T[I[e, 2]:I[e, 3]]``, ``S[I[e, 4]:I[e, 5]]``;
``coef`` (k, n) float64
    each point's coefficient for each effect (0: the effect does not act on it);
``m`` (n,) kg, ``body`` (n,) int64
    the points' masses and the body each belongs to (pair effects act between bodies only).

The compiled functions, with ``mode`` :data:`MODE_STEP` (the em step's discrete forces),
:data:`MODE_MIDPOINT` (conservative effects at the midpoint (x0 + x1) / 2, others over the
step) or :data:`MODE_EXPLICIT` (x0 = x1 = x: the force at a point, leapfrog's kicks), plus
:data:`MODE_WEIGHTED` for forces rather than forces per unit mass::

    forces(x0, x1, m, body, coef, h, mode, P, I, T, S, F, W, R, jac, first) -> status
        F (3, n) per unit mass, W (9, n) its diagonal Jacobian blocks ``W[3 a + b, i] =
        dF_a,i / dx1_b,i`` where ``jac``, R (n,) the pair coupling bounds; weighted, F and W
        are the pair effects' own plus the point's mass times the others' sum (N, N/m);
        status :data:`~emorbit.kernels.codes.STATUS_SINGULAR` where a force is not finite.
    prepare(ta, tm, tb, P, I, T, S)
    work(x0, dx, m, body, coef, h, mode, P, I, T, S, out)
        out (w, n): each working effect's work on each point over the step from x0 to
        x0 + dx (J): ``m F . dx`` for a force that does work, the ``time_work`` of a potential
        that changes in time; w is the number of working effects, in the set's order.
    potential(x, m, body, coef, P, I, T, S, out)
        out (k, n): each effect's potential energy at each point (J; 0 for effects without
        one; a pair effect puts half of each pair's energy on each point), after ``prepare``
        at the time of x.
    rate(x, v, m, body, coef, P, I, T, S) -> (W, dW)
        the largest squared rate over the points, the effects' ``rate`` and pairs'
        ``pair_rate`` (0 where none gives one), and its rate of change.
    cross(x0, x1, m, body, coef, on, sc, acc, P, I, T, S)
        the pair effects' blocks between bodies, summed onto each pair of bodies' slots: for
        points a, b of bodies A < B (``on`` not 0 for both), with slot coefficients ``sc``
        (4, n), ``acc[A, B, i, j] += sc[i, a] sc[j, b] J_ab`` (acc (nb, nb, 4, 4, 3, 3)).
    facets(a, b, nrm, area, kf, h, P, I, T, S, F, out, want_work) -> status
        a, b, nrm (3, nf): facet centres at the step's start and end, unit normals at its
        middle; area (nf,); kf (4, nf) the facet coefficients; F (3, nf) the surface
        effects' summed force on each facet (N); where ``want_work``, out (w, nf) gets each
        working effect's work ``F_e . (b - a)`` (J; 0 in the slots of effects without
        surfaces).
"""

from __future__ import annotations

from numba import types

__all__ = [
    "FORCES",
    "PREPARE",
    "WORK",
    "POTENTIAL",
    "FACETS",
    "CROSS",
    "RATE",
    "MODE_STEP",
    "MODE_MIDPOINT",
    "MODE_EXPLICIT",
    "MODE_WEIGHTED",
    "SLICES",
]

#: the em step's discrete forces over the step x0 -> x1
MODE_STEP = 0
#: the implicit midpoint rule: conservative effects at (x0 + x1) / 2, the others over the step
MODE_MIDPOINT = 1
#: the force at a point (x0 = x1): the explicit kicks of leapfrog
MODE_EXPLICIT = 2
#: a flag added to a mode: forces (N) rather than forces per unit mass
MODE_WEIGHTED = 4
#: the columns of ``I``: parameter, table and scratch slices (start, end)
SLICES = 6

_F1 = types.Array(types.float64, 1, "C")
_F2 = types.Array(types.float64, 2, "C")
_I1 = types.Array(types.int64, 1, "C")
_I2 = types.Array(types.int64, 2, "C")
_F, _I, _B = types.float64, types.int64, types.boolean

#: forces(x0, x1, m, body, coef, h, mode, P, I, T, S, F, W, R, jac, first) -> status
FORCES = _I(_F2, _F2, _F1, _I1, _F2, _F, _I, _F1, _I2, _F1, _F1, _F2, _F2, _F1, _B, _B)
#: prepare(ta, tm, tb, P, I, T, S)
PREPARE = types.void(_F, _F, _F, _F1, _I2, _F1, _F1)
#: work(x0, dx, m, body, coef, h, mode, P, I, T, S, out)
WORK = types.void(_F2, _F2, _F1, _I1, _F2, _F, _I, _F1, _I2, _F1, _F1, _F2)
#: potential(x, m, body, coef, P, I, T, S, out)
POTENTIAL = types.void(_F2, _F1, _I1, _F2, _F1, _I2, _F1, _F1, _F2)
#: rate(x, v, m, body, coef, P, I, T, S) -> (W, dW)
RATE = types.UniTuple(_F, 2)(_F2, _F2, _F1, _I1, _F2, _F1, _I2, _F1, _F1)
#: cross(x0, x1, m, body, coef, on, sc, acc, P, I, T, S)
CROSS = types.void(_F2, _F2, _F1, _I1, _F2, _F1, _F2, types.Array(types.float64, 6, "C"), _F1, _I2, _F1, _F1)
#: facets(a, b, nrm, area, kf, h, P, I, T, S, F, out, want_work) -> status
FACETS = _I(_F2, _F2, _F2, _F1, _F2, _F, _F1, _I2, _F1, _F1, _F2, _F2, _B)
