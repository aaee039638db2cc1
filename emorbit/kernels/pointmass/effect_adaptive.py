"""Adaptive, time-symmetric steps for point masses under a set of effects: the reversible
controller of :mod:`emorbit.kernels.adaptive` around :func:`.effect_step.effect_substep`, or,
for the time finite element (METHOD_TFE), around one :func:`.effect_tfe.effect_tfe_step` as
the composed step (``gammas`` = [1]; ``tfe`` its Gauss tables and force groups, unread by the
other methods).

The points step together (effects between pairs couple them), with one control variable for
the set. Its time scale comes from the effects that declare one (the set's ``rate``,
:mod:`emorbit.kernels.effects.signatures`): the largest squared rate W over the points and
pairs (the central field's ``GM / r**3``, a pair's ``G (m_a + m_b) / r**3``) sets ``s(y) =
eta 2 pi / sqrt(W)``, the local Kepler time of the fastest point or of the closest pair, and
``g = d ln rho / d tau = (1/2) (W' / W) s(y)`` with ``W'`` its rate of change along the
motion, in closed form (odd in the velocities, as the controller's symmetry needs).

Data layout: as :mod:`.effect_step`; ``rho`` (1,) the set's control variable (0 or less: set
from ``s(y)``), part of a checkpoint. The state in the controller is the tuple (x, v, cx, cv,
wp, hp, work, cwork) of the set's arrays.
"""

from __future__ import annotations

import math

import numpy as np

from ..adaptive import KICK_MAX, U_MAX, interval, kick
from ..codes import METHOD_TFE, STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from ..copies import copy2
from ..eft import kahan_add
from ..jit import kernel
from .effect_step import effect_substep, method_mode, step_scratch, stop_records
from .effect_tfe import effect_tfe_step, tfe_scratch

__all__ = ["effect_adaptive_chunk", "effect_reversible_steps"]

_TWO_PI = 2.0 * math.pi


@kernel
def _copy(dst, src):
    """Copy the eight arrays of a state into another's (a tuple of arrays of two shapes)."""
    dst[0][...] = src[0]
    dst[1][...] = src[1]
    dst[2][...] = src[2]
    dst[3][...] = src[3]
    dst[4][...] = src[4]
    dst[5][...] = src[5]
    dst[6][...] = src[6]
    dst[7][...] = src[7]


@kernel
def _control(ctx, x, v):
    """(1 / s(y), g(y)) of the set at x, v."""
    rate, m, body, coef = ctx[3], ctx[4], ctx[5], ctx[6]
    P, I, T, S, eta = ctx[7], ctx[8], ctx[9], ctx[10], ctx[13]
    w, dw = rate(x, v, m, body, coef, P, I, T, S)
    if not w > 0.0:
        return 0.0, 0.0
    s = eta * _TWO_PI / math.sqrt(w)
    return 1.0 / s, 0.5 * dw / w * s


@kernel
def _composed(ctx, s, rho, eps, fixed, t):
    """One composed step of the set (:func:`emorbit.kernels.adaptive.interval`) from time t
    (backwards where the context's direction is -1): the state ``s`` is copied into the
    context's buffers, which are stepped and returned."""
    forces, prepare, work_of, rate, m, body, coef, P, I, T, S, gammas, max_iter, eta, mode = ctx[:15]
    buf, scratch, direction, cross, method = ctx[15], ctx[16], ctx[17], ctx[18], ctx[19]
    potential, tab, lo, gm, ctr, coef_c, coef_n, has_n, has_d, row_effect = ctx[20]
    tsc, phi = ctx[21], ctx[22]
    _copy(buf, s)
    x, v, cx, cv, wp, hp, work, cwork = buf
    its = 0
    dur = 0.0
    dlo = 0.0
    g = 0.0
    if fixed <= 0.0:
        r0, g = _control(ctx, x, v)
        if not r0 > 0.0:
            return buf, rho, dur, dlo, its, STATUS_SINGULAR
    for k in range(gammas.shape[0]):
        ak = 0.25 * eps * gammas[k]
        if fixed > 0.0:
            h = fixed * gammas[k]
        else:
            a = ak * g
            if not abs(a) < KICK_MAX:
                return buf, rho, dur, dlo, its, STATUS_NO_CONVERGENCE
            rho = kick(rho, a)
            h = (4.0 * ak) / rho
        ta = t + direction * (dur - dlo)
        if method == METHOD_TFE:
            sweeps, status = effect_tfe_step(
                forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, gm, ctr, coef_c, coef_n, has_n,
                has_d, P, I, T, S, work, cwork, row_effect, ta, h, direction, max_iter, False, phi, tsc,
            )  # fmt: skip
        else:
            sweeps, status = effect_substep(
                forces, cross, prepare, work_of, mode, x, v, cx, cv, wp, hp, m, body, coef, P, I, T, S, work, cwork,
                h, ta, ta + direction * h, max_iter, scratch, ctx[23],
            )  # fmt: skip
        its += sweeps
        if status != STATUS_OK:
            return buf, rho, dur, dlo, its, status
        if fixed <= 0.0:
            r1, g = _control(ctx, x, v)
            a = ak * g
            if not (r1 > 0.0 and abs(a) < KICK_MAX):
                return buf, rho, dur, dlo, its, STATUS_NO_CONVERGENCE
            rho = kick(rho, a)
        dur, dlo = kahan_add(dur, dlo, h)
    r1, g = _control(ctx, x, v)
    if not r1 > 0.0:
        return buf, rho, dur, dlo, its, STATUS_SINGULAR
    if fixed > 0.0:
        rho = r1
    else:
        u = rho / r1
        if not (u > 1.0 / U_MAX and u < U_MAX):  # the control ran away from 1 / s(y)
            return buf, rho, dur, dlo, its, STATUS_NO_CONVERGENCE
    return buf, rho, dur, dlo, its, STATUS_OK


@kernel
def _control_of(ctx, s):
    return _control(ctx, s[0], s[1])[0]


@kernel
def _accept(ctx, s, q):
    _copy(s, q)
    return s


@kernel
def _context(
    forces, cross, prepare, work_of, rate, method, m, body, coef, P, I, T, S, gammas, max_iter, eta, x, work,
    direction, dense, tfe, central,
):  # fmt: skip
    """The controller's context of the set: the functions, the arrays, the buffers."""
    n = x.shape[1]
    nw = work.shape[0]
    k = tfe[1].shape[0] if method == METHOD_TFE else 0
    buf = (
        np.empty((3, n)), np.empty((3, n)), np.empty((3, n)), np.empty((3, n)), np.empty((3, n)), np.empty(1),
        np.empty((nw, n)), np.empty((nw, n)),
    )  # fmt: skip
    return (
        forces, prepare, work_of, rate, m, body, coef, P, I, T, S, gammas, max_iter, eta, method_mode(method), buf,
        step_scratch(n, nw, dense), direction, cross, method, tfe, tfe_scratch(k, n, coef.shape[0], nw, S.shape[0]),
        np.empty((k, 3, n)), central,
    )  # fmt: skip


@kernel
def effect_adaptive_chunk(
    forces, cross, prepare, work_of, rate, method, x, v, cx, cv, wp, hp, rho, m, body, coef, P, I, T, S, work, cwork,
    rec_work, clock_base, clock_n0, length, every, eta, gammas, nrec, max_iter, dense, rec_x, rec_v, rec_iters,
    rec_steps, fail, tfe, central,
):  # fmt: skip
    """Advance the points by ``nrec`` records of ``every`` intervals of ``length`` seconds
    (steps land on every multiple of it) with adaptive, time-symmetric steps, recording at the
    end of each record. Interval j of the chunk starts at ``clock_base + (clock_n0 + j)
    length``. ``rho`` (1,) the set's control variable, updated in place; ``rec_steps`` (nrec,
    n) composed steps per record; on a failure the points stop at the start of the failing
    record and ``fail`` names the record and the status. ``tfe``: (potential, tab, lo, gm, ctr,
    coef_c, coef_n, has_n, has_d, row_effect) of :func:`.effect_tfe.effect_tfe_step`; ``central``
    of :func:`.effect_step.effect_substep`. Other arguments: :mod:`.effect_step`."""
    n = x.shape[1]
    ctx = _context(forces, cross, prepare, work_of, rate, method, m, body, coef, P, I, T, S, gammas, max_iter, eta, x,
                   work, 1.0, dense, tfe, central)  # fmt: skip
    s = (x, v, cx, cv, wp, hp, work, cwork)
    r = rho[0]
    if not r > 0.0:
        r = _control_of(ctx, s)
    start = (x.copy(), v.copy(), cx.copy(), cv.copy(), wp.copy(), hp.copy(), work.copy(), cwork.copy())
    for k in range(nrec):
        its = 0
        steps = 0
        _copy(start, s)
        r_start = r
        status = STATUS_OK
        for j in range(every):
            t0 = clock_base + (clock_n0 + k * every + j) * length
            s, r, it, ns, status = interval(_composed, _control_of, _accept, ctx, s, r, length, t0)
            its += it
            steps += ns
            if status != STATUS_OK:
                break
        if status != STATUS_OK:
            _copy(s, start)
            r = r_start
            stop_records(x, v, work, rec_x, rec_v, rec_work, fail, k, k, status)
            break
        for i in range(n):
            rec_iters[k, i] = its
            rec_steps[k, i] = steps
        copy2(rec_x[k], x)
        copy2(rec_v[k], v)
        copy2(rec_work[k], work)
    rho[0] = r


@kernel
def effect_reversible_steps(
    forces, cross, prepare, work_of, rate, method, x, v, cx, cv, wp, hp, rho, m, body, coef, P, I, T, S, work, cwork,
    t0, direction, eta, gammas, nsteps, max_iter, dense, tfe, central,
):  # fmt: skip
    """Take exactly ``nsteps`` composed steps of size 1 in tau from time ``t0``, the clock
    running forwards (``direction`` 1) or backwards (-1), no landing: the scheme alone, for its
    time symmetry (reversing the velocities and their compensations and calling it again
    backwards from the end time runs the same steps back). Returns (elapsed time, status)."""
    ctx = _context(forces, cross, prepare, work_of, rate, method, m, body, coef, P, I, T, S, gammas, max_iter, eta, x,
                   work, direction, dense, tfe, central)  # fmt: skip
    s = (x, v, cx, cv, wp, hp, work, cwork)
    r = rho[0]
    if not r > 0.0:
        r = _control_of(ctx, s)
    t = 0.0
    tc = 0.0
    for _ in range(nsteps):
        q, r, dur, dlo, its, status = _composed(ctx, s, r, 1.0, 0.0, t0 + direction * (t - tc))
        if status != STATUS_OK:
            return t - tc, status
        s = _accept(ctx, s, q)
        t, tc = kahan_add(t, tc + dlo, dur)
    rho[0] = r
    return t - tc, STATUS_OK
