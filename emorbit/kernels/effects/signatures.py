"""The one contract between the effects and the body kinds' step kernels: its data layout
and the Numba types of the functions an effect set compiles into.

An effect gives plain kernel functions of float64 scalars and arrays, its *pieces*
(:class:`emorbit.effects.base.Pieces` gives their arguments); :mod:`emorbit.effects.program`
compiles a set of effects into seven functions (its docstring gives their arguments). The
step kernels of every body kind (point masses, rigid bodies' mass points and facets, elastic
bodies' gravity points and surfaces) take those seven as arguments of the types defined
here, so a step kernel is compiled once per install, whatever effects a scene names, and an
effect set compiles only its own small functions.

Data layout of an effect set, k effects (the order in which their forces are summed):

``P`` (float64), ``T`` (float64), ``S`` (float64)
    every effect's parameters, tables and scratch, one after another;
``I`` (k, 6) int64
    effect e's slices: ``P[I[e, 0]:I[e, 1]]``, ``T[I[e, 2]:I[e, 3]]``, ``S[I[e, 4]:I[e, 5]]``;
``coef`` (k, n) float64
    each point's coefficient for each effect (0: the effect does not act on it);
``m`` (n,) kg, ``body`` (n,) int64
    the points' masses and the body each belongs to (pair effects act between bodies only).

``mode``: :data:`MODE_STEP` (the em step's discrete forces), :data:`MODE_MIDPOINT`
(conservative effects at the midpoint, others over the step), :data:`MODE_EXPLICIT` (the
force at a point, leapfrog's kicks) or :data:`MODE_POINT` (a stage: the forces at the
midpoint, those that depend on the velocity over the step), plus the flag
:data:`MODE_WEIGHTED` (forces, not forces per unit mass); the work function's
:data:`MODE_POINT` is the force at x0 times dx.
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
    "MODE_POINT",
    "MODE_WEIGHTED",
    "SLICES",
]

#: the em step's discrete forces over the step x0 -> x1
MODE_STEP = 0
#: the implicit midpoint rule: conservative effects at (x0 + x1) / 2, the others over the step
MODE_MIDPOINT = 1
#: the force at a point (x0 = x1): the explicit kicks of leapfrog
MODE_EXPLICIT = 2
#: a stage of a time finite element (:mod:`emorbit.kernels.pointmass.effect_tfe`) at the
#: midpoint of (x0, x1): the forces there, those that depend on the velocity over the segment;
#: the work function: each effect's force at x0 times the displacement dx (a force that
#: depends on the velocity takes it as dx / h, over (x0 - dx / 2, x0 + dx / 2))
MODE_POINT = 3
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
