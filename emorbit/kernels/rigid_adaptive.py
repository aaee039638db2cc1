"""Adaptive, time-symmetric steps for rigid bodies: the reversible step-size controller of
:mod:`.pointmass.adaptive` (Hairer & Soederlind) around the symmetric energy-momentum (or
midpoint) step :func:`.rigid.rigid_step`.

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
One step of size ``eps`` is the symmetric splitting

    rho_1/2 = rho_0 C(eps/4 g(y_0)),   y_1 = Phi_h(y_0), h = eps / rho_1/2,   rho_1 = rho_1/2 C(eps/4 g(y_1)),

``C(a) = (1 + a) / (1 - a)``, with the compositions of orders 4-8 applied to it, the steps
landing on every multiple of the run's ``dt`` (each interval starting afresh, so that a
run does not depend on how it is cut into calls) and a failed composed step retried with
its control started afresh, then with half the ``eps``, exactly as for point masses
(:mod:`.pointmass.adaptive`, where the constants are defined). Energy and angular momentum
stay exact: each sub-step is an energy-momentum step, whatever its size.

Data layout: as :func:`.rigid.rigid_chunk` (``q, v, cq, cv`` (nb, 12), ``lam`` (nb, 6));
``rho`` (nb,) the control variables (0 or less: set from ``s(y)`` at the first step), updated
in place and part of a checkpoint; ``Jinv`` (nb, 3, 3) the inverse body-frame inertias
(``RigidBodies.inverse_inertias``). The central field only: the Simulation refuses effects
with adaptive steps (the effect set's ``forces`` and ``facets`` are handed to
:func:`.rigid.rigid_step` as given).

References: E. Hairer, G. Soederlind, SIAM J. Sci. Comput. 26 (2005) 1838-1851; P. Betsch,
P. Steinmann, Comput. Methods Appl. Mech. Engrg. 190 (2001) 6663-6692 (the director step).
"""

from __future__ import annotations

import math

import numpy as np

from .codes import STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from .eft import kahan_add
from .jit import kernel
from .pointmass.adaptive import KICK_MAX, MAX_HALVINGS, MAX_STEPS, PREDICT, U_MAX
from .rigid import _work_arrays, rigid_step
from .rigid_surface import facet_scratch

__all__ = ["rigid_rates", "rigid_adaptive_chunk", "rigid_reversible_steps"]

_TWO_PI = 2.0 * math.pi


@kernel
def rigid_rates(q, v, E, Jinv, gm, c):
    """(W, W') of one body: the squared rate W = GM / r**3 + |w|**2, 1/s**2, and its rate of
    change along the motion (the torque-free share for the rotation), 1/s**3."""
    W = 0.0
    dW = 0.0
    if gm > 0.0:
        a0 = q[0] - c[0]
        a1 = q[1] - c[1]
        a2 = q[2] - c[2]
        r2 = a0 * a0 + a1 * a1 + a2 * a2
        r = math.sqrt(r2)
        w2 = gm / (r2 * r)
        W += w2
        dW += -3.0 * w2 * (a0 * v[0] + a1 * v[1] + a2 * v[2]) / r2
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
    W += o0 * o0 + o1 * o1 + o2 * o2
    tr = E[0, 0] + E[1, 1] + E[2, 2]  # L = J Omega = tr(E) Omega - E Omega
    l0 = tr * o0 - (E[0, 0] * o0 + E[0, 1] * o1 + E[0, 2] * o2)
    l1 = tr * o1 - (E[1, 0] * o0 + E[1, 1] * o1 + E[1, 2] * o2)
    l2 = tr * o2 - (E[2, 0] * o0 + E[2, 1] * o1 + E[2, 2] * o2)
    t0 = l1 * o2 - l2 * o1  # (J Omega) x Omega
    t1 = l2 * o0 - l0 * o2
    t2 = l0 * o1 - l1 * o0
    dW += 2.0 * o0 * (Jinv[0, 0] * t0 + Jinv[0, 1] * t1 + Jinv[0, 2] * t2)
    dW += 2.0 * o1 * (Jinv[1, 0] * t0 + Jinv[1, 1] * t1 + Jinv[1, 2] * t2)
    dW += 2.0 * o2 * (Jinv[2, 0] * t0 + Jinv[2, 1] * t1 + Jinv[2, 2] * t2)
    return W, dW


@kernel
def _control(q, v, E, Jinv, gm, c, eta):
    """``1 / s(y)`` (1/s) and ``g(y)``; (0, 0) where the body neither orbits nor turns."""
    W, dW = rigid_rates(q, v, E, Jinv, gm, c)
    if not W > 0.0:
        return 0.0, 0.0
    return math.sqrt(W) / (eta * _TWO_PI), math.pi * eta * dW / (W * math.sqrt(W))


@kernel
def _composed(
    method, model, tp, tu, te, tf, tl, rho, eps, fixed, gammas, m, E, Einv, Jinv, X, mp, gm, c, eta, max_iter,
    work, fx,
):  # fmt: skip
    """One composed step of the state ``tp, tu, te, tf, tl`` (q, v, their compensations, the
    multipliers' warm start; updated in place): sub-steps ``gammas[k] eps`` in tau, or
    (``fixed`` > 0) of physical size ``gammas[k] fixed`` with ``rho`` then set to ``1 / s``.
    Returns (rho, duration ``dur - dlo`` as a Kahan pair, iterations, stalled sub-steps,
    status); after a failure the state is meaningless."""
    dq = work[16]
    dv = work[19]
    its = 0
    stl = 0
    dur = 0.0
    dlo = 0.0
    g = 0.0
    if fixed <= 0.0:
        r0, g = _control(tp, tu, E, Jinv, gm, c, eta)
        if not r0 > 0.0:
            return rho, dur, dlo, its, stl, STATUS_SINGULAR
    for k in range(gammas.shape[0]):
        ak = 0.25 * eps * gammas[k]
        if fixed > 0.0:
            h = fixed * gammas[k]
        else:
            a = ak * g
            if not abs(a) < KICK_MAX:
                return rho, dur, dlo, its, stl, STATUS_NO_CONVERGENCE
            rho = rho * (1.0 + a) / (1.0 - a)
            h = (4.0 * ak) / rho
        it, status, stalled = rigid_step(
            fx[0], fx[1], method, model, tp, tu, tl, m, E, Einv, X, mp, gm, c, h, max_iter, work, fx[2], fx[3],
            fx[4], fx[5], fx[6], fx[7], fx[8], fx[9], fx[10], fx[11],
        )  # fmt: skip
        its += it
        stl += stalled
        if status != STATUS_OK:
            return rho, dur, dlo, its, stl, status
        for j in range(12):
            tp[j], te[j] = kahan_add(tp[j], te[j], dq[j])
            tu[j], tf[j] = kahan_add(tu[j], tf[j], dv[j])
            if not (abs(tp[j]) < math.inf and abs(tu[j]) < math.inf):
                return rho, dur, dlo, its, stl, STATUS_SINGULAR
        if fixed <= 0.0:
            r1, g = _control(tp, tu, E, Jinv, gm, c, eta)
            a = ak * g
            if not (r1 > 0.0 and abs(a) < KICK_MAX):
                return rho, dur, dlo, its, stl, STATUS_NO_CONVERGENCE
            rho = rho * (1.0 + a) / (1.0 - a)
        dur, dlo = kahan_add(dur, dlo, h)
    r1, g = _control(tp, tu, E, Jinv, gm, c, eta)
    if not r1 > 0.0:
        return rho, dur, dlo, its, stl, STATUS_SINGULAR
    if fixed > 0.0:
        rho = r1
    else:
        u = rho / r1
        if not (u > 1.0 / U_MAX and u < U_MAX):  # the control ran away from 1 / s(y)
            return rho, dur, dlo, its, stl, STATUS_NO_CONVERGENCE
    return rho, dur, dlo, its, stl, STATUS_OK


@kernel
def _interval(
    method, model, q, v, cq, cv, lam, r, interval, gammas, m, E, Einv, Jinv, X, mp, gm, c, eta, max_iter, work,
    fx, tp, tu, te, tf, tl,
):  # fmt: skip
    """Composed steps of one body's state ``q, v, cq, cv, lam`` (updated in place) that end
    exactly ``interval`` seconds later; ``tp .. tl`` are scratch. Returns (rho, iterations,
    stalled sub-steps, composed steps, status); on a failure the state is where it stopped.
    It starts afresh (a trial first step), so it depends on the state alone."""
    its = 0
    stl = 0
    steps = 0
    elapsed = 0.0
    comp = 0.0
    prev = 0.0
    last = False
    status = STATUS_OK
    while not last:
        rem = (interval - elapsed) + comp
        ok = False
        eps = 1.0
        rq = r
        reset = False
        for _attempt in range(MAX_HALVINGS + 2):
            dur = rem
            dlo = 0.0
            status = STATUS_OK
            if prev < rem or eps < 1.0 or reset:
                # a trial step (none when the last one was longer than what is left, unless
                # the landing step failed)
                tp[:] = q
                tu[:] = v
                te[:] = cq
                tf[:] = cv
                tl[:] = lam
                rq, dur, dlo, it, st, status = _composed(
                    method, model, tp, tu, te, tf, tl, r, eps, 0.0, gammas, m, E, Einv, Jinv, X, mp, gm, c, eta,
                    max_iter, work, fx,
                )  # fmt: skip
                its += it
                stl += st
            if status == STATUS_OK and dur - dlo >= rem:  # it passes the landing: the remaining time
                tp[:] = q
                tu[:] = v
                te[:] = cq
                tf[:] = cv
                tl[:] = lam
                rq, dur, dlo, it, st, status = _composed(
                    method, model, tp, tu, te, tf, tl, r, 1.0, rem, gammas, m, E, Einv, Jinv, X, mp, gm, c, eta,
                    max_iter, work, fx,
                )  # fmt: skip
                its += it
                stl += st
                last = True
            if status == STATUS_OK:
                ok = True
                break
            last = False
            if not reset:  # first failure: start the control afresh from the state, try again
                reset = True
                r = _control(q, v, E, Jinv, gm, c, eta)[0]
                continue
            eps *= 0.5
        if not ok:
            return r, its, stl, steps, status
        q[:] = tp
        v[:] = tu
        cq[:] = te
        cv[:] = tf
        lam[:] = tl
        r = rq
        steps += 1
        if steps > MAX_STEPS:
            return r, its, stl, steps, STATUS_NO_CONVERGENCE
        if not last:
            elapsed, comp = kahan_add(elapsed, comp + dlo, dur)
            prev = PREDICT * (dur - dlo)
    return r, its, stl, steps, STATUS_OK


@kernel
def _effects(forces, facets_fn, coef, pcoef, foff, facets, P, I, T, S, offsets, b):
    """Body b's share of the effect set, as :func:`.rigid.rigid_step` takes it."""
    f0, f1 = foff[b], foff[b + 1]
    return (
        forces, facets_fn, np.ascontiguousarray(coef[:, offsets[b] : offsets[b + 1]]),
        np.ascontiguousarray(pcoef[:, b : b + 1]), P, I, T, S, facets, f0, f1, facet_scratch(f1 - f0, 0),
    )  # fmt: skip


@kernel
def rigid_adaptive_chunk(
    method, models, q, v, cq, cv, lam, rho, mass, E, Einv, Jinv, offsets, X, mp, gm, center, interval, every,
    eta, gammas, nrec, max_iter, rec_q, rec_v, rec_iters, rec_steps, rec_stalled, fail, forces, facets_fn, coef,
    pcoef, foff, facets, P, I, T, S,
):  # fmt: skip
    """Advance every rigid body by ``nrec`` records of ``every`` intervals of ``interval``
    seconds (the landing grid: steps end on every multiple of it) with adaptive,
    time-symmetric steps, recording at the end of each record.

    rho          (nb,) control variables, updated in place (<= 0: set from the state)
    Jinv         (nb, 3, 3) inverse inertias in the body frame
    eta          the accuracy knob: steps of eta times the body's fastest time scale
    rec_steps    (nrec, nb) composed steps each body took in each record
    Other arguments as in :func:`.rigid.rigid_chunk`; ``fail[b]`` holds (record index,
    status) of a body that failed even after halving its step :data:`MAX_HALVINGS` times (it
    then stops at the start of that record).
    """
    nb = q.shape[0]
    tp = np.empty(12)
    tu = np.empty(12)
    te = np.empty(12)
    tf = np.empty(12)
    tl = np.empty(6)
    sq = np.empty(12)
    sv = np.empty(12)
    scq = np.empty(12)
    scv = np.empty(12)
    sl = np.empty(6)
    for b in range(nb):
        Xb = X[:, offsets[b] : offsets[b + 1]]
        mb = np.ascontiguousarray(mp[offsets[b] : offsets[b + 1]])
        work = _work_arrays(Xb)
        fx = _effects(forces, facets_fn, coef, pcoef, foff, facets, P, I, T, S, offsets, b)
        r = rho[b]
        if not r > 0.0:
            r, g = _control(q[b], v[b], E[b], Jinv[b], gm, center, eta)
        for k in range(nrec):
            its = 0
            stl = 0
            steps = 0
            r_start = r
            sq[:] = q[b]
            sv[:] = v[b]
            scq[:] = cq[b]
            scv[:] = cv[b]
            sl[:] = lam[b]
            status = STATUS_OK
            for _j in range(every):
                r, it, st, ns, status = _interval(
                    method, models[b], q[b], v[b], cq[b], cv[b], lam[b], r, interval, gammas, mass[b], E[b],
                    Einv[b], Jinv[b], Xb, mb, gm, center, eta, max_iter, work, fx, tp, tu, te, tf, tl,
                )  # fmt: skip
                its += it
                stl += st
                steps += ns
                if status != STATUS_OK:
                    break
            if status != STATUS_OK:
                q[b] = sq
                v[b] = sv
                cq[b] = scq
                cv[b] = scv
                lam[b] = sl
                r = r_start
                fail[b, 0] = k
                fail[b, 1] = status
                break
            rec_q[k, b, :] = q[b]
            rec_v[k, b, :] = v[b]
            rec_iters[k, b] = its
            rec_stalled[k, b] = stl
            rec_steps[k, b] = steps
        rho[b] = r


@kernel
def rigid_reversible_steps(
    method, models, q, v, cq, cv, lam, rho, mass, E, Einv, Jinv, offsets, X, mp, gm, center, eta, gammas,
    nsteps, max_iter, elapsed, forces, facets_fn, coef, pcoef, foff, facets, P, I, T, S,
):  # fmt: skip
    """Take exactly ``nsteps`` composed steps of size 1 in tau from every body (no records, no
    landing on a time): the scheme alone, for its time symmetry. ``elapsed`` (nb,) gets the
    physical time each body advanced. Reversing the velocities and their compensations and
    calling it again runs the same steps back. Returns the first failure's status (0: none)."""
    nb = q.shape[0]
    for b in range(nb):
        Xb = X[:, offsets[b] : offsets[b + 1]]
        mb = np.ascontiguousarray(mp[offsets[b] : offsets[b + 1]])
        work = _work_arrays(Xb)
        fx = _effects(forces, facets_fn, coef, pcoef, foff, facets, P, I, T, S, offsets, b)
        r = rho[b]
        if not r > 0.0:
            r, g = _control(q[b], v[b], E[b], Jinv[b], gm, center, eta)
        t = 0.0
        tc = 0.0
        for _ in range(nsteps):
            r, dur, dlo, it, st, status = _composed(
                method, models[b], q[b], v[b], cq[b], cv[b], lam[b], r, 1.0, 0.0, gammas, mass[b], E[b], Einv[b],
                Jinv[b], Xb, mb, gm, center, eta, max_iter, work, fx,
            )  # fmt: skip
            if status != STATUS_OK:
                return status
            t, tc = kahan_add(t, tc + dlo, dur)
        elapsed[b] = t - tc
        rho[b] = r
    return STATUS_OK
