r"""The effect set at a rigid body's gravity points over the stages of its time finite element.

Method (:mod:`.rigid_tfe`). At stage l the body's gravity points sit at ``x_i = phi + R X_i``
and move with ``V_i = u + (R^-T Omega) x (R X_i)``, the velocity whose pairing with the force
``f_i`` is the rate of the kinetic energy: ``m u' . u + M' . Omega = sum_i f_i . V_i``. The set's
effects split in three (:meth:`emorbit.bodies.rigid.RigidBodies.tfe_effects`):

- the central field, which :mod:`.rigid_tfe` forms itself (its row is 0 in both coefficient
  arrays);
- the *static* effects, with a potential that does not change in time (``coef_c``): their
  forces at the stages (MODE_EXPLICIT) join the field's, are scaled with it by ``1 + nu P_l``,
  and their potential's rise over the step, ``-sum_i m_i G_i . (x_i1 - x_i0)`` with ``G_i`` their
  em force over the step (its work is their potential's drop exactly), joins the field's in
  the energy correction: energy is exact;
- the others (``coef_n``): their forces act at the stages unscaled, and their work over the
  step is the force's at the stages, ``sum_l h b_l sum_i m_i f_il . V_il`` (MODE_POINT), plus,
  for a potential that changes in time (``row_effect >= 0``), its change over the step; the
  kinetic energy changes by exactly that work, so ``E1 - E0 = W`` to round-off.

Data layout of a body's effect context ``fx`` (:func:`body_context`): ``(P, I, T, S, Sk, coef_c,
coef_n, body, has_c, has_n, has_d, row_effect, xa, xb, va, Fc, Fn, Wsc, Rsc, out, U, tot, Lx)``:
the set's arrays (:mod:`.effects.signatures`), ``Sk`` (k + 1, ns) the scratch that
``prepare`` fills at each stage's time and over the whole step (last row), the body's gravity
points' coefficients (ke, N) split as above, ``body`` (N,) zeros, flags, ``row_effect`` (w,),
positions ``xa, xb`` and velocities ``va`` (3, N), accelerations ``Fc, Fn`` (3, N), scratch
``Wsc`` (9, N), ``Rsc`` (N,), work per point ``out`` (w, N), potentials ``U`` (ke, N), the step's
work ``tot`` (w,), the loads' sums ``Lx`` (2, 9).

References: P. Betsch, P. Steinmann, J. Comput. Phys. 160 (2000) 88-116; E. Hairer, JNAIAM 5
(2010) 73-84.
"""

from __future__ import annotations

import numpy as np

from .codes import GRAVITY_NONE, GRAVITY_POINT
from .copies import copy1
from .effects.signatures import MODE_EXPLICIT, MODE_POINT, MODE_STEP
from .eft import kahan_add
from .jit import kernel
from .rigid_tfe_newton import inverse3

__all__ = ["body_context", "prepare_step", "stage_forces", "static_rise", "step_work"]


@kernel
def body_context(models, offsets, P, I, T, S, k, coefs, row_effect, has_d, b):
    """Body b's effect context ``fx`` (module notes) by its gravity model: ``coefs = (coef_c,
    coef_n, pcoef_c, pcoef_n)``, the set's split coefficients at every mass point (ke, N) and
    at every centre of mass (ke, nb) (the columns are copied)."""
    if models[b] == GRAVITY_POINT:
        return _context(P, I, T, S, k, coefs[2], coefs[3], row_effect, has_d, b, b + 1)
    if models[b] == GRAVITY_NONE:
        return _context(P, I, T, S, k, coefs[0], coefs[1], row_effect, has_d, 0, 0)
    return _context(P, I, T, S, k, coefs[0], coefs[1], row_effect, has_d, offsets[b], offsets[b + 1])


@kernel
def _context(P, I, T, S, k, coef_c, coef_n, row_effect, has_d, a, b):
    cc = np.ascontiguousarray(coef_c[:, a:b])
    cn = np.ascontiguousarray(coef_n[:, a:b])
    n = b - a
    w = row_effect.shape[0]
    return (
        P, I, T, S, np.zeros((k + 1, S.shape[0])), cc, cn, np.zeros(n, np.int64), bool(np.any(cc != 0.0)),
        bool(np.any(cn != 0.0)), has_d and n > 0, row_effect, np.empty((3, n)), np.empty((3, n)),
        np.empty((3, n)), np.zeros((3, n)), np.zeros((3, n)), np.empty((9, n)), np.empty(n), np.zeros((w, n)),
        np.zeros((cc.shape[0], n)), np.zeros(w), np.zeros((2, 9)),
    )  # fmt: skip


@kernel
def prepare_step(prepare, fx, tab, t0, h):
    """What the effects read at each stage's time ``t0 + c_l h`` and over the step, into ``Sk``."""
    P, I, T, S, Sk = fx[0], fx[1], fx[2], fx[3], fx[4]
    if not (fx[8] or fx[9]):
        return
    k = tab.shape[0]
    for l in range(k):
        tl = t0 + tab[l, 0] * h
        prepare(tl, tl, tl, P, I, T, S)
        copy1(Sk[l], S)
    prepare(t0, t0 + 0.5 * h, t0 + h, P, I, T, S)
    copy1(Sk[k], S)


@kernel(forceinline=True)
def _points(y, Xg, x):
    """The gravity points' positions ``phi + R X_i`` at y (18) into x (3, N)."""
    for j in range(Xg.shape[1]):
        X0 = Xg[0, j]
        X1 = Xg[1, j]
        X2 = Xg[2, j]
        for i in range(3):
            x[i, j] = y[i] + (y[3 + i] * X0 + y[6 + i] * X1 + y[9 + i] * X2)


@kernel
def stage_forces(forces, fx, l, y, Xg, mg, h):
    """The static and the other effects' accelerations at the gravity points at y (18), stage
    l's time, into ``Fc`` and ``Fn`` (3, N); returns the set's status (0: finite)."""
    P, I, T, S, Sk, cc, cn, body, has_c, has_n = fx[:10]
    xa, Fc, Fn, Wsc, Rsc = fx[12], fx[15], fx[16], fx[17], fx[18]
    if not (has_c or has_n):
        return 0
    copy1(S, Sk[l])
    _points(y, Xg, xa)
    bad = 0
    if has_c:
        bad += forces(xa, xa, mg, body, cc, h, MODE_EXPLICIT, P, I, T, S, Fc, Wsc, Rsc, False, True)
    if has_n:
        bad += forces(xa, xa, mg, body, cn, h, MODE_EXPLICIT, P, I, T, S, Fn, Wsc, Rsc, False, True)
    return bad


@kernel
def static_rise(forces, fx, y0, dy, Xg, mg, h):
    """The static effects' potential rise over the step from y0 by dy (18): ``-sum_i m_i G_i .
    dx_i``, G their em forces over the step, ``dx_i`` from the increments (J)."""
    P, I, T, S, Sk, cc, body = fx[0], fx[1], fx[2], fx[3], fx[4], fx[5], fx[7]
    xa, xb, Fc, Wsc, Rsc = fx[12], fx[13], fx[15], fx[17], fx[18]
    k = Sk.shape[0] - 1
    copy1(S, Sk[k])
    _points(y0, Xg, xa)
    for j in range(Xg.shape[1]):
        for i in range(3):
            xb[i, j] = xa[i, j] + (dy[i] + dy[3 + i] * Xg[0, j] + dy[6 + i] * Xg[1, j] + dy[9 + i] * Xg[2, j])
    forces(xa, xb, mg, body, cc, h, MODE_STEP, P, I, T, S, Fc, Wsc, Rsc, False, True)
    out = 0.0
    for j in range(Xg.shape[1]):
        for i in range(3):
            out -= mg[j] * Fc[i, j] * (xb[i, j] - xa[i, j])
    return out


@kernel
def step_work(work_of, prepare, potential, fx, tab, lo, y0, Z, dy, Jinv, Xg, mg, h, t0, R, Ri, work, cwork):
    """Add each working effect's work over the converged step (stages y0 + Z_l, increment dy)
    to the body's sums ``work, cwork`` (w,): the force's at the stages (MODE_POINT at the
    gravity points, displacement ``h b_l V_il``), plus the change of a potential that changes
    in time. R, Ri: 3 x 3 scratch."""
    P, I, T, S, Sk, cn, body, has_d, row_effect = fx[0], fx[1], fx[2], fx[3], fx[4], fx[6], fx[7], fx[10], fx[11]
    xa, xb, va, out, U, tot = fx[12], fx[13], fx[14], fx[19], fx[20], fx[21]
    k = tab.shape[0]
    n = Xg.shape[1]
    tot[:] = 0.0
    Y = np.empty(18)
    for l in range(k):
        for i in range(18):
            Y[i] = y0[i] + Z[l, i]
        _points(Y, Xg, xa)
        for c in range(3):
            for i in range(3):
                R[i, c] = Y[3 + 3 * c + i]
        inverse3(R, Ri)
        om0 = Jinv[0, 0] * Y[15] + Jinv[0, 1] * Y[16] + Jinv[0, 2] * Y[17]
        om1 = Jinv[1, 0] * Y[15] + Jinv[1, 1] * Y[16] + Jinv[1, 2] * Y[17]
        om2 = Jinv[2, 0] * Y[15] + Jinv[2, 1] * Y[16] + Jinv[2, 2] * Y[17]
        a0 = Ri[0, 0] * om0 + Ri[1, 0] * om1 + Ri[2, 0] * om2
        a1 = Ri[0, 1] * om0 + Ri[1, 1] * om1 + Ri[2, 1] * om2
        a2 = Ri[0, 2] * om0 + Ri[1, 2] * om1 + Ri[2, 2] * om2
        w = h * (tab[l, 1] + lo[l, 0])
        for j in range(n):  # R X_j as the field forms it
            q0 = Y[3] * Xg[0, j] + Y[6] * Xg[1, j] + Y[9] * Xg[2, j]
            q1 = Y[4] * Xg[0, j] + Y[7] * Xg[1, j] + Y[10] * Xg[2, j]
            q2 = Y[5] * Xg[0, j] + Y[8] * Xg[1, j] + Y[11] * Xg[2, j]
            va[0, j] = w * (Y[12] + (a1 * q2 - a2 * q1))
            va[1, j] = w * (Y[13] + (a2 * q0 - a0 * q2))
            va[2, j] = w * (Y[14] + (a0 * q1 - a1 * q0))
        copy1(S, Sk[l])
        work_of(xa, va, mg, body, cn, h, MODE_POINT, P, I, T, S, out)
        for r in range(out.shape[0]):
            for j in range(n):
                tot[r] += out[r, j]
    if has_d:
        for end in range(2):
            te = t0 + h if end == 0 else t0
            prepare(te, te, te, P, I, T, S)
            if end == 0:
                for i in range(18):
                    Y[i] = y0[i] + dy[i]
                _points(Y, Xg, xb)
                potential(xb, mg, body, cn, P, I, T, S, U)
            else:
                _points(y0, Xg, xa)
                potential(xa, mg, body, cn, P, I, T, S, U)
            for r in range(tot.shape[0]):
                e = row_effect[r]
                if e >= 0:
                    for j in range(n):
                        tot[r] += U[e, j] if end == 0 else -U[e, j]
    for r in range(tot.shape[0]):
        work[r], cwork[r] = kahan_add(work[r], cwork[r], tot[r])
