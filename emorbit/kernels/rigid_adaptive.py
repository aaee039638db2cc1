"""Adaptive, time-symmetric steps for rigid bodies: the reversible step-size controller of
:mod:`.adaptive` (Hairer & Soederlind) around the symmetric energy-momentum (or midpoint)
step :func:`.rigid.rigid_step`, under any effect set.

Method. Each body carries a control variable ``rho``; its step is ``h = eps / rho``. The
step follows the fastest of the body's two motions, the orbit and the rotation: on the exact
motion ``rho = 1 / s(y)`` with

    s(y) = eta 2 pi / sqrt(W),    W = GM / r**3 + |w|**2,

``r = |phi - c|`` the centre of mass's distance from the field's centre (the term is absent
in free space), ``w = 1/2 sum_k d_k x dd_k`` the angular velocity in space. In the step
variable tau (dt = d tau / rho), ``d ln rho / d tau = g(y) = pi eta W' W**(-3/2)`` with

    W' = -3 GM (phi - c).dphi / r**5 + 2 Omega . J^-1 ((J Omega) x Omega),

``Omega = R^T w`` the body-frame rate and J the inertia: the rate's change is that of Euler's
torque-free equations (the gravity-gradient torque's share is left out of g; it only moves
how closely ``rho`` follows ``1 / s``, and ``rho`` is reset to ``1 / s`` at each landing on the ``dt`` grid).
The splitting, the compositions, the landing on every multiple of the run's ``dt`` and the
retries are those of :func:`.adaptive.interval`, which runs each body. Energy and angular
momentum stay exact (or the energy balance, under effects that do work: each converged
sub-step adds their work, as the fixed steps do): each sub-step is an energy-momentum step,
whatever its size. Effects that depend on time read each sub-step's own times.

Data layout: as :func:`.rigid.rigid_chunk` (``q, v, cq, cv`` (nb, 12), ``lam`` (nb, 6), the
effect set's functions and arrays, the work sums); ``rho`` (nb,) the control variables (0 or
less: set from ``s(y)`` at the first step), updated in place and part of a checkpoint;
``Jinv`` (nb, 3, 3) the inverse body-frame inertias (``RigidBodies.inverse_inertias``). A
body's state in the controller is the tuple (q, v, cq, cv, lam, work, cwork) of its rows.

References: E. Hairer, G. Soederlind, SIAM J. Sci. Comput. 26 (2005) 1838-1851; P. Betsch,
P. Steinmann, Comput. Methods Appl. Mech. Engrg. 190 (2001) 6663-6692 (the director step).
"""

from __future__ import annotations

import math

import numpy as np

from .adaptive import KICK_MAX, U_MAX, interval, kick
from .codes import METHOD_MIDPOINT, STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from .copies import copy1
from .effects.signatures import MODE_MIDPOINT, MODE_STEP
from .eft import kahan_add
from .jit import kernel
from .rigid import _body_work, _point_scratch, _work_arrays, rigid_step
from .rigid_surface import facet_scratch

__all__ = ["motion_rates", "rigid_rates", "rigid_adaptive_chunk", "rigid_reversible_steps"]

_TWO_PI = 2.0 * math.pi


@kernel
def motion_rates(a0, a1, a2, u0, u1, u2, o0, o1, o2, l0, l1, l2, Jinv, gm):
    """(W, W') from the centre's offset a from the field's centre and velocity u, the body-frame
    rate Omega and angular momentum L = J Omega: W = GM / r**3 + |Omega|**2 (1/s**2) and its
    rate of change along the motion (the torque-free share for the rotation), 1/s**3."""
    W = 0.0
    dW = 0.0
    if gm > 0.0:
        r2 = a0 * a0 + a1 * a1 + a2 * a2
        w2 = gm / (r2 * math.sqrt(r2))
        W += w2
        dW += -3.0 * w2 * (a0 * u0 + a1 * u1 + a2 * u2) / r2
    W += o0 * o0 + o1 * o1 + o2 * o2
    t0 = l1 * o2 - l2 * o1  # (J Omega) x Omega
    t1 = l2 * o0 - l0 * o2
    t2 = l0 * o1 - l1 * o0
    dW += 2.0 * o0 * (Jinv[0, 0] * t0 + Jinv[0, 1] * t1 + Jinv[0, 2] * t2)
    dW += 2.0 * o1 * (Jinv[1, 0] * t0 + Jinv[1, 1] * t1 + Jinv[1, 2] * t2)
    dW += 2.0 * o2 * (Jinv[2, 0] * t0 + Jinv[2, 1] * t1 + Jinv[2, 2] * t2)
    return W, dW


@kernel
def rigid_rates(q, v, E, Jinv, gm, c):
    """(W, W') of one body in the director form (:func:`motion_rates`), 1/s**2 and 1/s**3."""
    w0 = w1 = w2 = 0.0  # w = 1/2 sum d_k x dd_k, in space
    for k in range(3):
        d0 = q[3 + 3 * k]
        d1 = q[4 + 3 * k]
        d2 = q[5 + 3 * k]
        e0 = v[3 + 3 * k]
        e1 = v[4 + 3 * k]
        e2 = v[5 + 3 * k]
        w0 += 0.5 * (d1 * e2 - d2 * e1)
        w1 += 0.5 * (d2 * e0 - d0 * e2)
        w2 += 0.5 * (d0 * e1 - d1 * e0)
    o0 = q[3] * w0 + q[4] * w1 + q[5] * w2  # Omega = R^T w, the body-frame rate
    o1 = q[6] * w0 + q[7] * w1 + q[8] * w2
    o2 = q[9] * w0 + q[10] * w1 + q[11] * w2
    tr = E[0, 0] + E[1, 1] + E[2, 2]  # L = J Omega = tr(E) Omega - E Omega
    l0 = tr * o0 - (E[0, 0] * o0 + E[0, 1] * o1 + E[0, 2] * o2)
    l1 = tr * o1 - (E[1, 0] * o0 + E[1, 1] * o1 + E[1, 2] * o2)
    l2 = tr * o2 - (E[2, 0] * o0 + E[2, 1] * o1 + E[2, 2] * o2)
    return motion_rates(q[0] - c[0], q[1] - c[1], q[2] - c[2], v[0], v[1], v[2], o0, o1, o2, l0, l1, l2, Jinv, gm)


@kernel
def _control(q, v, E, Jinv, gm, c, eta):
    """``1 / s(y)`` (1/s) and ``g(y)``; (0, 0) where the body neither orbits nor turns."""
    W, dW = rigid_rates(q, v, E, Jinv, gm, c)
    if not W > 0.0:
        return 0.0, 0.0
    return math.sqrt(W) / (eta * _TWO_PI), math.pi * eta * dW / (W * math.sqrt(W))


@kernel
def _composed(ctx, s, rho, eps, fixed, t):
    """One composed step of a body (:func:`.adaptive.interval`): its state ``s`` = (q, v, cq,
    cv, lam, work, cwork) is copied into the context's buffers, which are stepped and returned
    (``s`` itself is left as it was). Sub-steps ``gammas[k] eps`` in tau, or (``fixed`` > 0)
    of physical size ``gammas[k] fixed`` with ``rho`` then set to ``1 / s``. Returns (state,
    rho, duration ``dur - dlo`` as a Kahan pair, iterations, status); the stalled sub-steps are
    counted into ``ctx``'s counter."""
    (method, model, m, E, Einv, Jinv, X, mp, gm, c, eta, gammas, max_iter, work, fx, wpts, buf, counter) = ctx
    forces, facets_fn, prepare, work_of, coef, pcoef, P, I, T, S, facets, f0, f1, fscratch, ledger = fx
    tp, tu, te, tf, tl, tw, tcw = buf
    for j in range(12):
        tp[j] = s[0][j]
        tu[j] = s[1][j]
        te[j] = s[2][j]
        tf[j] = s[3][j]
    for j in range(6):
        tl[j] = s[4][j]
    for j in range(tw.shape[0]):
        tw[j] = s[5][j]
        tcw[j] = s[6][j]
    mode = MODE_MIDPOINT if method == METHOD_MIDPOINT else MODE_STEP
    dq = work[16]
    dv = work[19]
    q1 = np.empty(12)
    its = 0
    dur = 0.0
    dlo = 0.0
    g = 0.0
    if fixed <= 0.0:
        r0, g = _control(tp, tu, E, Jinv, gm, c, eta)
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
        ta = t + (dur - dlo)
        prepare(ta, ta + 0.5 * h, ta + h, P, I, T, S)
        it, status, stalled = rigid_step(
            forces, facets_fn, method, model, tp, tu, tl, m, E, Einv, X, mp, gm, c, h, max_iter, work, coef, pcoef,
            P, I, T, S, facets, f0, f1, fscratch,
        )  # fmt: skip
        its += it
        counter[0] += stalled
        if status != STATUS_OK:
            return buf, rho, dur, dlo, its, status
        if tw.shape[0] > 0:  # the effects' work over the converged sub-step
            for j in range(12):
                q1[j] = tp[j] + dq[j]
            _body_work(
                work_of, facets_fn, mode, model, tp, q1, X, mp, m, h, coef, pcoef, P, I, T, S, facets, f0, f1,
                fscratch, wpts, tw, tcw, ledger,
            )  # fmt: skip
        for j in range(12):
            tp[j], te[j] = kahan_add(tp[j], te[j], dq[j])
            tu[j], tf[j] = kahan_add(tu[j], tf[j], dv[j])
            if not (abs(tp[j]) < math.inf and abs(tu[j]) < math.inf):
                return buf, rho, dur, dlo, its, STATUS_SINGULAR
        if fixed <= 0.0:
            r1, g = _control(tp, tu, E, Jinv, gm, c, eta)
            a = ak * g
            if not (r1 > 0.0 and abs(a) < KICK_MAX):
                return buf, rho, dur, dlo, its, STATUS_NO_CONVERGENCE
            rho = kick(rho, a)
        dur, dlo = kahan_add(dur, dlo, h)
    r1, g = _control(tp, tu, E, Jinv, gm, c, eta)
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
    return _control(s[0], s[1], ctx[3], ctx[5], ctx[8], ctx[9], ctx[10])[0]


@kernel
def _accept(ctx, s, q):
    for i in range(7):
        s[i][:] = q[i]
    return s


@kernel
def _effects(forces, facets_fn, prepare, work_of, coef, pcoef, foff, facets, P, I, T, S, offsets, b, nw, ledger):
    """Body b's share of the effect set, as :func:`_composed` reads it."""
    f0, f1 = foff[b], foff[b + 1]
    return (
        forces, facets_fn, prepare, work_of, np.ascontiguousarray(coef[:, offsets[b] : offsets[b + 1]]),
        np.ascontiguousarray(pcoef[:, b : b + 1]), P, I, T, S, facets, f0, f1, facet_scratch(f1 - f0, nw), ledger,
    )  # fmt: skip


@kernel
def _body(method, models, mass, E, Einv, Jinv, offsets, X, mp, gm, center, eta, gammas, max_iter, fx, b, nw):
    """Body b's context for :func:`_composed` and its state buffers."""
    Xb = X[:, offsets[b] : offsets[b + 1]]
    mb = np.ascontiguousarray(mp[offsets[b] : offsets[b + 1]])
    buf = (np.empty(12), np.empty(12), np.empty(12), np.empty(12), np.empty(6), np.empty(nw), np.empty(nw))
    wpts = _point_scratch(models[b], offsets[b + 1] - offsets[b], nw)
    return (
        method, models[b], mass[b], E[b], Einv[b], Jinv[b], Xb, mb, gm, center, eta, gammas, max_iter,
        _work_arrays(Xb), fx, wpts, buf, np.zeros(1, np.int64),
    )  # fmt: skip


@kernel
def _state(q, v, cq, cv, lam, work, cwork, b):
    """Body b's state as copies of its rows."""
    return (q[b].copy(), v[b].copy(), cq[b].copy(), cv[b].copy(), lam[b].copy(), work[b].copy(), cwork[b].copy())


@kernel
def _store(s, q, v, cq, cv, lam, work, cwork, b):
    q[b] = s[0]
    v[b] = s[1]
    cq[b] = s[2]
    cv[b] = s[3]
    lam[b] = s[4]
    work[b] = s[5]
    cwork[b] = s[6]


@kernel
def rigid_adaptive_chunk(
    forces, facets_fn, prepare, work_of, method, models, q, v, cq, cv, lam, rho, mass, E, Einv, Jinv, offsets, X, mp,
    coef, pcoef, foff, facets, gm, center, interval_length, every, eta, gammas, nrec, max_iter, rec_q, rec_v,
    rec_iters, rec_steps, rec_stalled, fail, P, I, T, S, work, cwork, rec_work, clock_base, clock_n0, ledger,
):  # fmt: skip
    """Advance every rigid body by ``nrec`` records of ``every`` intervals of
    ``interval_length`` seconds (the landing grid: steps end on every multiple of it) with
    adaptive, time-symmetric steps, recording at the end of each record.

    rho          (nb,) control variables, updated in place (<= 0: set from the state)
    Jinv         (nb, 3, 3) inverse inertias in the body frame
    eta          the accuracy knob: steps of eta times the body's fastest time scale
    rec_steps    (nrec, nb) composed steps each body took in each record
    Other arguments as in :func:`.rigid.rigid_chunk`; interval j of the chunk starts at
    ``clock_base + (clock_n0 + j) interval_length``; ``fail[b]`` holds (record index, status)
    of a body that failed even after halving its step (it then stops at the start of that
    record).
    """
    nb = q.shape[0]
    nw = work.shape[1]
    for b in range(nb):
        fx = _effects(
            forces, facets_fn, prepare, work_of, coef, pcoef, foff, facets, P, I, T, S, offsets, b, nw, ledger
        )
        ctx = _body(method, models, mass, E, Einv, Jinv, offsets, X, mp, gm, center, eta, gammas, max_iter, fx, b, nw)
        s = _state(q, v, cq, cv, lam, work, cwork, b)
        r = rho[b]
        if not r > 0.0:
            r = _control_of(ctx, s)
        for k in range(nrec):
            its = 0
            steps = 0
            ctx[17][0] = 0
            start = _state(q, v, cq, cv, lam, work, cwork, b)
            r_start = r
            status = STATUS_OK
            for j in range(every):
                t0 = clock_base + (clock_n0 + k * every + j) * interval_length
                s, r, it, ns, status = interval(_composed, _control_of, _accept, ctx, s, r, interval_length, t0)
                its += it
                steps += ns
                if status != STATUS_OK:
                    break
            if status != STATUS_OK:
                _store(start, q, v, cq, cv, lam, work, cwork, b)
                r = r_start
                fail[b, 0] = k
                fail[b, 1] = status
                break
            _store(s, q, v, cq, cv, lam, work, cwork, b)
            copy1(rec_q[k, b], q[b])
            copy1(rec_v[k, b], v[b])
            rec_iters[k, b] = its
            rec_stalled[k, b] = ctx[17][0]
            rec_steps[k, b] = steps
            copy1(rec_work[k, b], work[b])
        rho[b] = r


@kernel
def rigid_reversible_steps(
    forces, facets_fn, prepare, work_of, method, models, q, v, cq, cv, lam, rho, mass, E, Einv, Jinv, offsets, X, mp,
    coef, pcoef, foff, facets, gm, center, eta, gammas, nsteps, max_iter, elapsed, P, I, T, S, work, cwork, ledger,
):  # fmt: skip
    """Take exactly ``nsteps`` composed steps of size 1 in tau from every body (no records, no
    landing on a time): the scheme alone, for its time symmetry. ``elapsed`` (nb,) gets the
    physical time each body advanced. Reversing the velocities and their compensations and
    calling it again runs the same steps back. Returns the first failure's status (0: none)."""
    nb = q.shape[0]
    nw = work.shape[1]
    for b in range(nb):
        fx = _effects(
            forces, facets_fn, prepare, work_of, coef, pcoef, foff, facets, P, I, T, S, offsets, b, nw, ledger
        )
        ctx = _body(method, models, mass, E, Einv, Jinv, offsets, X, mp, gm, center, eta, gammas, max_iter, fx, b, nw)
        s = _state(q, v, cq, cv, lam, work, cwork, b)
        r = rho[b]
        if not r > 0.0:
            r = _control_of(ctx, s)
        t = 0.0
        tc = 0.0
        for _ in range(nsteps):
            out, r, dur, dlo, it, status = _composed(ctx, s, r, 1.0, 0.0, t - tc)
            if status != STATUS_OK:
                return status
            s = _accept(ctx, s, out)
            t, tc = kahan_add(t, tc + dlo, dur)
        elapsed[b] = t - tc
        rho[b] = r
        _store(s, q, v, cq, cv, lam, work, cwork, b)
    return STATUS_OK
