r"""Adaptive, time-symmetric steps of the rigid-body time finite element: the reversible
controller of :mod:`.adaptive` (Hairer & Soederlind) around one step of
:func:`.rigid_tfe.rigid_tfe_step` as the composed step.

Method. A body's control variable ``rho`` follows ``1 / s(y)`` with, as for em's rigid steps
(:mod:`.rigid_adaptive`), ``s(y) = eta 2 pi / sqrt(W)``, ``W = GM / r**3 + |Omega|**2`` from the
element's own state y = (phi, R, u, M) (``Omega = J^-1 M``, ``|Omega| = |w|``), and

    W' = -3 GM (phi - c) . u / r**5 + 2 Omega . J^-1 (M x Omega),

the torque-free share of the rotation's change (the gravity-gradient torque's is left out, as
there). One composed step of size ``eps`` in tau is ``rho_1/2 = rho_0 C(eps/4 g(y_0))``, one
element step of ``h = eps / rho_1/2``, ``rho_1 = rho_1/2 C(eps/4 g(y_1))``, with ``g = pi eta W'
W**(-3/2)``: the element is symmetric, so the step of ``-eps`` undoes it. Each step starts
Newton from the stage derivatives at y0 and factors its matrix afresh, so a step is a function
of (y0, h) alone, whatever steps came before; after it the axes' rounding is taken off as in
:func:`.rigid_tfe.rigid_tfe_chunk`. The landing on the ``dt`` grid, the retries and the
halvings are :func:`.adaptive.interval`'s. Energy and angular momentum stay those of every
element step, exact whatever its size.

Data layout: as :func:`.rigid_tfe.rigid_tfe_chunk`, plus ``rho`` (nb,) the control variables
(0 or less: set from ``s(y)``), updated in place, and ``rec_steps`` (nrec, nb) the composed
steps per record. A body's state in the controller is the pair (y, cy) of (18,) arrays.

References: E. Hairer, G. Soederlind, SIAM J. Sci. Comput. 26 (2005) 1838-1851; P. Betsch,
P. Steinmann, J. Comput. Phys. 160 (2000) 88-116.
"""

from __future__ import annotations

import math

import numpy as np

from .adaptive import KICK_MAX, U_MAX, interval, kick
from .codes import STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from .copies import copy1
from .eft import kahan_add
from .jit import kernel
from .rigid_adaptive import motion_rates
from .rigid_tfe import _orthonormalize, _to_state, body_gravity, rigid_tfe_step, step_scratch, store_state
from .rigid_tfe_effects import body_context, prepare_step, step_work

__all__ = ["rigid_tfe_adaptive_chunk", "rigid_tfe_reversible_steps"]

_TWO_PI = 2.0 * math.pi


@kernel
def _control(y, Jinv, gm, c, eta):
    """``1 / s(y)`` (1/s) and ``g(y)`` of the element's state y
    (:func:`.rigid_adaptive.motion_rates`); (0, 0) where the body neither orbits nor turns."""
    o0 = Jinv[0, 0] * y[15] + Jinv[0, 1] * y[16] + Jinv[0, 2] * y[17]
    o1 = Jinv[1, 0] * y[15] + Jinv[1, 1] * y[16] + Jinv[1, 2] * y[17]
    o2 = Jinv[2, 0] * y[15] + Jinv[2, 1] * y[16] + Jinv[2, 2] * y[17]
    W, dW = motion_rates(
        y[0] - c[0], y[1] - c[1], y[2] - c[2], y[12], y[13], y[14], o0, o1, o2, y[15], y[16], y[17], Jinv, gm
    )
    if not W > 0.0:
        return 0.0, 0.0
    return math.sqrt(W) / (eta * _TWO_PI), math.pi * eta * dW / (W * math.sqrt(W))


@kernel
def _composed(ctx, s, rho, eps, fixed, t):
    """One composed step of a body (:func:`.adaptive.interval`): one element step of ``h = eps
    / rho`` between the kicks, or (``fixed`` > 0) of ``fixed`` with rho then ``1 / s``. The
    state ``s`` = (y, cy) is copied into the context's buffers, which are stepped and returned."""
    tab, lo, Ji, Xg, mg, mass, gm, c, size, tidal, max_iter, eta, work, Z, Kst, Eo, buf = ctx[:17]
    forces, prepare, work_of, potential, fx, t_off, Rw = ctx[17:]
    ty, tcy, tw, tcw = buf
    copy1(ty, s[0])
    copy1(tcy, s[1])
    copy1(tw, s[2])
    copy1(tcw, s[3])
    g = 0.0
    if fixed > 0.0:
        h = fixed
    else:
        r0, g = _control(ty, Ji, gm, c, eta)
        a = 0.25 * eps * g
        if not (r0 > 0.0 and abs(a) < KICK_MAX):
            return buf, rho, 0.0, 0.0, 0, STATUS_NO_CONVERGENCE if r0 > 0.0 else STATUS_SINGULAR
        rho = kick(rho, a)
        h = eps / rho
    t0 = t_off + t
    prepare_step(prepare, fx, tab, t0, h)
    dy, dlo, its, status, _ = rigid_tfe_step(
        forces, fx, tab, lo, ty, Z, Kst, h, Ji, Xg, mg, mass, gm, c, size, tidal, max_iter, False, 0.0, True, work
    )
    if status != STATUS_OK:
        return buf, rho, 0.0, 0.0, its, status
    if tw.shape[0] > 0:
        step_work(work_of, prepare, potential, fx, tab, lo, ty, Z, dy, Ji, Xg, mg, h, t0, Eo, Rw, tw, tcw)
    for i in range(18):
        ty[i], tcy[i] = kahan_add(ty[i], tcy[i], dy[i])
        ty[i], tcy[i] = kahan_add(ty[i], tcy[i], dlo[i])
        if not abs(ty[i]) < math.inf:
            return buf, rho, 0.0, 0.0, its, STATUS_SINGULAR
    _orthonormalize(ty, tcy, Eo)
    r1, g = _control(ty, Ji, gm, c, eta)
    if not r1 > 0.0:
        return buf, rho, 0.0, 0.0, its, STATUS_SINGULAR
    if fixed > 0.0:
        rho = r1
    else:
        a = 0.25 * eps * g
        if not abs(a) < KICK_MAX:
            return buf, rho, 0.0, 0.0, its, STATUS_NO_CONVERGENCE
        rho = kick(rho, a)
        u = rho / r1
        if not (u > 1.0 / U_MAX and u < U_MAX):  # the control ran away from 1 / s(y)
            return buf, rho, 0.0, 0.0, its, STATUS_NO_CONVERGENCE
    return buf, rho, h, 0.0, its, STATUS_OK


@kernel
def _control_of(ctx, s):
    return _control(s[0], ctx[2], ctx[6], ctx[7], ctx[11])[0]


@kernel
def _accept(ctx, s, q):
    for i in range(4):
        s[i][:] = q[i]
    return s


@kernel
def _context(fns, eff, t_off, tab, lo, models, mass, E, Jinv, offsets, X, mp, gm, center, eta, max_iter, b, one):
    """Body b's context: its gravity points, constants, the element's scratch, the effect
    set's functions ``fns = (forces, prepare, work_of, potential)`` and its effect context."""
    k = tab.shape[0]
    Pe, Ie, Te, Se, coefs, row_effect, has_d, wsum = eff[:8]
    Xg, mg, tidal, size = body_gravity(models, mass, E, offsets, X, mp, gm, b, one)
    fx = body_context(models, offsets, Pe, Ie, Te, Se, k, coefs, row_effect, has_d, b)
    w = wsum.shape[1]
    return (
        tab, lo, Jinv[b], Xg, mg, mass[b], gm, center, size, tidal, max_iter, eta, step_scratch(k),
        np.empty((k, 18)), np.empty((k, 18)), np.empty((3, 3)), (np.empty(18), np.empty(18), np.empty(w), np.empty(w)),
        fns[0], fns[1], fns[2], fns[3], fx, t_off, np.empty((3, 3)),
    )  # fmt: skip


@kernel
def _start(fns, eff, t_off, tab, lo, models, q, v, cq, cv, rho, mass, E, Jinv, offsets, X, mp, gm, center, eta,
           max_iter, b, one):  # fmt: skip
    """Body b's context, its state (y, cy, work, cwork) from the director form and its work
    sums, and its control variable; its steps' times count from ``t_off`` (s from the epoch)."""
    ctx = _context(fns, eff, t_off, tab, lo, models, mass, E, Jinv, offsets, X, mp, gm, center, eta, max_iter, b, one)
    s = (np.empty(18), np.empty(18), eff[7][b].copy(), eff[8][b].copy())
    _to_state(q[b], v[b], cq[b], cv[b], E[b], s[0], s[1])
    r = rho[b]
    if not r > 0.0:
        r = _control_of(ctx, s)
    return ctx, s, r


@kernel
def rigid_tfe_adaptive_chunk(
    fns, eff, tab, lo, models, q, v, cq, cv, rho, mass, E, Jinv, offsets, X, mp, gm, center, interval_length, every,
    eta, nrec, max_iter, rec_q, rec_v, rec_iters, rec_steps, fail,
):  # fmt: skip
    """Advance every rigid body by ``nrec`` records of ``every`` intervals of
    ``interval_length`` seconds (steps land on every multiple of it) with adaptive,
    time-symmetric element steps, recording at the end of each record; ``fail[b]`` gets the
    record index and status of a body that failed (it stops at the start of that record).
    ``fns = (forces, prepare, work_of, potential)`` and ``eff`` the effect set's, as
    :func:`.rigid_tfe.rigid_tfe_chunk` takes them (the intervals are its steps). Other
    arguments: the module's docstring and :func:`.rigid_tfe.rigid_tfe_chunk`."""
    one = np.zeros((3, 1))[:, 0:1]
    vd = np.empty(12)
    t_off = eff[10] + eff[11] * interval_length
    for b in range(q.shape[0]):
        ctx, s, r = _start(fns, eff, t_off, tab, lo, models, q, v, cq, cv, rho, mass, E, Jinv, offsets, X, mp, gm,
                           center, eta, max_iter, b, one)  # fmt: skip
        start = (np.empty(18), np.empty(18), s[2].copy(), s[3].copy())
        for k in range(nrec):
            its = 0
            steps = 0
            for i in range(4):
                start[i][:] = s[i]
            r_start = r
            status = STATUS_OK
            for j in range(every):
                s, r, it, ns, status = interval(
                    _composed, _control_of, _accept, ctx, s, r, interval_length, (k * every + j) * interval_length
                )
                its += it
                steps += ns
                if status != STATUS_OK:
                    break
            if status != STATUS_OK:
                for i in range(4):
                    s[i][:] = start[i]
                r = r_start
                fail[b, 0] = k
                fail[b, 1] = status
                break
            store_state(s[0], s[1], Jinv[b], q, v, cq, cv, b, vd)
            copy1(rec_q[k, b], q[b])
            copy1(rec_v[k, b], v[b])
            rec_iters[k, b] = its
            rec_steps[k, b] = steps
            eff[9][k, b, :] = s[2]
        store_state(s[0], s[1], Jinv[b], q, v, cq, cv, b, vd)
        eff[7][b, :] = s[2]
        eff[8][b, :] = s[3]
        rho[b] = r


@kernel
def rigid_tfe_reversible_steps(
    fns, eff, tab, lo, models, q, v, cq, cv, rho, mass, E, Jinv, offsets, X, mp, gm, center, eta, nsteps, max_iter, out
):  # fmt: skip
    """Exactly ``nsteps`` composed steps of size 1 in tau of every body, no landing: the scheme
    alone, for its time symmetry (reversing the velocities and calling it again runs the
    steps back; time-dependent effects are read at the chunk's start, ``eff``'s clock).
    ``out`` (nb, 2) gets each body's elapsed time and status."""
    one = np.zeros((3, 1))[:, 0:1]
    vd = np.empty(12)
    for b in range(q.shape[0]):
        ctx, s, r = _start(fns, eff, eff[10], tab, lo, models, q, v, cq, cv, rho, mass, E, Jinv, offsets, X, mp, gm,
                           center, eta, max_iter, b, one)  # fmt: skip
        t = 0.0
        tc = 0.0
        status = STATUS_OK
        for _ in range(nsteps):
            w, r, dur, dlo, its, status = _composed(ctx, s, r, 1.0, 0.0, 0.0)
            if status != STATUS_OK:
                break
            s = _accept(ctx, s, w)
            t, tc = kahan_add(t, tc + dlo, dur)
        store_state(s[0], s[1], Jinv[b], q, v, cq, cv, b, vd)
        eff[7][b, :] = s[2]
        eff[8][b, :] = s[3]
        rho[b] = r
        out[b, 0] = t - tc
        out[b, 1] = status
