"""Adaptive, time-symmetric steps for point masses in the central field: the reversible
controller of :mod:`emorbit.kernels.adaptive` around the symmetric em, midpoint, leapfrog or
time finite element (tfe, :mod:`.tfe`: one step of 2 to 6 Gauss stages is the composed step)
step of one point.

Control. On the exact motion ``rho = 1 / s(x)``, ``s(x) = eta 2 pi sqrt(r**3 / GM)`` (``r =
|x - c|``; the Sundman-type rule dt ~ r**(3/2)), so ``g(y) = -3/2 (x - c).v s(x) / r**2``. A
tfe step is one sub-step, so its kicks are the Hermite rule's (:func:`~..adaptive.kick4`), with
``g' = -3/2 s(x)^2 / r^2 (|v|^2 - GM / r - ((x - c).v)^2 / (2 r^2))`` on the Kepler motion;
with the plain kicks the control falls behind the motion near the periapsis of e = 0.99.
A tfe step's Newton starts from the last step's force polynomial within an interval
(:func:`_tfe_sub`), as the fixed steps of :func:`.tfe.tfe_chunk` do.

Round-off: the sub-steps read rounded positions, which moves the energy of the compensated
state (x - cx, v - cv) by about eps times the energy a sub-step exchanges (a walk of 1e-14 of
E over 100 orbits of e = 0.9, 1e-12 of a along the track). em's composed step ends by
restoring it (:func:`_restore_energy`): ``cv += (dE / |v|^2) v``, ``dE`` the end state's
energy minus the interval's first, both double-double; zero in exact arithmetic, skipped
beyond :data:`~emorbit.kernels.adaptive.RESTORE_MAX` of ``|v|^2 + GM/r``, applied to em
(either roundoff) and tfe, not to midpoint or leapfrog. The energy target travels with the state.

Data layout: ``x, v, cx, cv`` (3, n) state and Kahan compensations as in :mod:`.chunk`;
``rho`` (n,) the control variables (<= 0: set from ``s(x)``), part of a checkpoint. A point's
state in the controller is a tuple of 17 floats: x, v, cx, cv, the leapfrog acceleration and
the energy target (a double-double).
"""

from __future__ import annotations

import math

import numpy as np

from ..adaptive import KICK_MAX, RESTORE_MAX, U_MAX, interval, kick, kick4
from ..codes import (
    METHOD_EM,
    METHOD_EM_PLAIN,
    METHOD_LEAPFROG,
    METHOD_TFE,
    STATUS_NO_CONVERGENCE,
    STATUS_OK,
    STATUS_SINGULAR,
)
from ..eft import dd_add, dd_div, dd_mul, dd_sqrt, kahan_add
from ..gravity import accel
from ..jit import kernel
from .point_step import _implicit_point_em, _implicit_point_em_plain, _implicit_point_mid, _leapfrog_point
from .roots import _tau
from .tfe import extrapolate, keep_forces, predict, tfe_step

__all__ = ["adaptive_chunk", "reversible_steps", "control"]

_TWO_PI = 2.0 * math.pi


@kernel
def control(x0, x1, x2, c0, c1, c2, gm, eta):
    """``1 / s(x)``: the control variable of a state on the exact motion, 1/s."""
    ax = x0 - c0
    ay = x1 - c1
    az = x2 - c2
    r = math.sqrt(ax * ax + ay * ay + az * az)
    return 1.0 / (eta * _TWO_PI * r * math.sqrt(r / gm))


@kernel
def tfe_scratch(tab):
    """The time finite element's context of :func:`_sub`: its Gauss tables ``tab`` (k, 3 + 2k)
    (:func:`.tfe.tables`), the step's scratch, ``phi`` (k, 2), ``work`` (2k, 2k + 8) and
    ``piv`` (2k,), and the predictor's memory: the last step's nodal forces in space ``prevf``
    (k, 3), the extrapolation weights ``ext`` (k, k) and ``last`` (2,), whether there is a last
    step (1.0) and its h; allocated once per call rather than once per step."""
    k = tab.shape[0]
    return (
        tab, np.empty((k, 2)), np.empty((2 * k, 2 * k + 8)), np.empty(2 * k, np.int64),
        np.empty((k, 3)), np.empty((k, k)), np.zeros(2),
    )  # fmt: skip


@kernel
def _tfe_sub(tfe, p0, p1, p2, u0, u1, u2, h, gm, max_iter):
    """One tfe step from the offset ``p`` and velocity ``u``, Newton started from the last
    step's force polynomial (:func:`.tfe.predict`) where the last step was 0.8 to 1.25 times
    as long (else, or where that start fails, from gravity at the nodes: near a periapsis,
    where the steps change faster, the polynomial carried further starts Newton worse than
    gravity does); the step's forces are kept for the next. The start changes Newton's path,
    not its limit: the step is the same to round-off, and an interval that starts afresh
    (:func:`_interval`) still depends on its state alone."""
    tab, phi, work, piv, prevf, ext, last = tfe
    hv0 = h * u0
    hv1 = h * u1
    hv2 = h * u2
    ratio = h / last[1] if last[0] > 0.0 else 0.0
    predicted = ratio > 0.8 and ratio < 1.25
    if predicted:
        extrapolate(ext, tab, ratio)
        predict(ext, phi, prevf, p0, p1, p2, hv0, hv1, hv2, ratio * ratio)
    out = tfe_step(tab, phi, work, piv, p0, p1, p2, u0, u1, u2, h, gm, max_iter, predicted)
    if predicted and out[9] != STATUS_OK:
        its = out[8]
        out = tfe_step(tab, phi, work, piv, p0, p1, p2, u0, u1, u2, h, gm, max_iter, False)
        out = out[:8] + (out[8] + its, out[9])
    last[0] = 0.0
    if out[9] == STATUS_OK:
        keep_forces(prevf, phi, p0, p1, p2, hv0, hv1, hv2)
        last[0] = 1.0
        last[1] = h
    return out


@kernel
def _g(x0, x1, x2, y0, y1, y2, c0, c1, c2, gm, eta):
    """g(y) = d ln(rho) / d tau = -3/2 (x - c).v s(x) / r**2 (odd in v)."""
    ax = x0 - c0
    ay = x1 - c1
    az = x2 - c2
    r = math.sqrt(ax * ax + ay * ay + az * az)
    return (-1.5 * eta * _TWO_PI) * (ax * y0 + ay * y1 + az * y2) / math.sqrt(r * gm)


@kernel
def _gp(x0, x1, x2, y0, y1, y2, c0, c1, c2, gm, eta):
    """g'(y) = dg / d tau = s(x) dg/dt = -3/2 s(x)^2 / r^2 (|v|^2 - GM / r - (x - c).v^2 / (2 r^2))
    on the Kepler motion (even in v)."""
    ax = x0 - c0
    ay = x1 - c1
    az = x2 - c2
    r2 = ax * ax + ay * ay + az * az
    r = math.sqrt(r2)
    xv = ax * y0 + ay * y1 + az * y2
    s = eta * _TWO_PI * r * math.sqrt(r / gm)
    return (-1.5 * s * s / r2) * (y0 * y0 + y1 * y1 + y2 * y2 - gm / r - 0.5 * xv * xv / r2)


@kernel
def _sub(method, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, h, gm, c0, c1, c2, max_iter, tfe):
    """One sub-step of physical size h of the symmetric method: 15 values, iterations, status.
    ``tfe``: the time finite element's Gauss tables and scratch (:func:`tfe_scratch`; read by
    METHOD_TFE, whose one step is the composed step)."""
    extra = 0
    status = STATUS_OK
    if method == METHOD_TFE:
        d0, d1, d2, w0, w1, w2, _, _, extra, status = _tfe_sub(
            tfe, t0 - c0, t1 - c1, t2 - c2, u0, u1, u2, h, gm, max_iter
        )
        t0, e0 = kahan_add(t0, e0, d0)
        t1, e1 = kahan_add(t1, e1, d1)
        t2, e2 = kahan_add(t2, e2, d2)
        u0, f0 = kahan_add(u0, f0, w0)
        u1, f1 = kahan_add(u1, f1, w1)
        u2, f2 = kahan_add(u2, f2, w2)
    elif method == METHOD_LEAPFROG:
        (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, good) = _leapfrog_point(
            t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, h, gm, c0, c1, c2
        )
        if not good:
            status = STATUS_SINGULAR
    else:
        tau0, tlo = _tau(h, gm)
        if method == METHOD_EM:
            (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status) = _implicit_point_em(
                t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, h, gm, tau0, tlo, c0, c1, c2, max_iter
            )
        elif method == METHOD_EM_PLAIN:
            (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status) = _implicit_point_em_plain(
                t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, h, gm, tau0, tlo, c0, c1, c2, max_iter
            )
        else:
            (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status) = _implicit_point_mid(
                t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, h, gm, tau0, tlo, c0, c1, c2, max_iter
            )
        extra += 1
    return t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, extra, status


@kernel
def _energy_dd(s, gm, c0, c1, c2):
    """(energy per unit mass of the compensated state (x - cx, v - cv), as a double-double;
    |v|^2 + GM / r, its scale)."""
    kh, kl = dd_mul(s[3], -s[9], s[3], -s[9])
    ph, pl = dd_mul(s[4], -s[10], s[4], -s[10])
    kh, kl = dd_add(kh, kl, ph, pl)
    ph, pl = dd_mul(s[5], -s[11], s[5], -s[11])
    kh, kl = dd_add(kh, kl, ph, pl)
    a0, a1, a2 = s[0] - c0, s[1] - c1, s[2] - c2
    rh, rl = dd_mul(a0, -s[6], a0, -s[6])
    ph, pl = dd_mul(a1, -s[7], a1, -s[7])
    rh, rl = dd_add(rh, rl, ph, pl)
    ph, pl = dd_mul(a2, -s[8], a2, -s[8])
    rh, rl = dd_add(rh, rl, ph, pl)
    rh, rl = dd_sqrt(rh, rl)
    qh, ql = dd_div(gm, 0.0, rh, rl)
    eh, el = dd_add(0.5 * kh, 0.5 * kl, -qh, -ql)
    return eh, el, kh + qh


@kernel
def _restore_energy(s, eh, el, gm, c0, c1, c2):
    """em's round-off correction: the composed step's end state ``s`` with the compensation
    of its velocity changed so that the compensated state's energy is ``eh + el`` (the
    energy the step started from) to double-double precision. Applied only where the
    difference is round-off (below :data:`RESTORE_MAX` of the energy's scale); otherwise
    ``s`` is kept and its own energy becomes the target. Returns (s, target energy)."""
    fh, fl, scale = _energy_dd(s, gm, c0, c1, c2)
    dh, dl = dd_add(fh, fl, -eh, -el)
    de = dh + dl
    v2 = s[3] * s[3] + s[4] * s[4] + s[5] * s[5]
    if not (v2 > 0.0 and abs(de) < RESTORE_MAX * scale):
        return s, fh, fl
    k = de / v2  # (v - cv)(1 - k) has the kinetic energy 1/2 |v - cv|^2 - de, to first order in k
    t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2 = s
    return (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0 + k * u0, f1 + k * u1, f2 + k * u2, n0, n1, n2), eh, el


@kernel
def _composed(method, s, rho, eps, fixed, gammas, gm, c0, c1, c2, eta, max_iter, eh, el, tfe):
    """One composed step from the 15 values ``s`` (x, v, cx, cv, the leapfrog acceleration)
    and ``rho``: sub-steps ``gammas[k] eps`` in tau, or (``fixed`` > 0) of physical size
    ``gammas[k] fixed``, with ``rho`` then set to ``1 / s(x)`` at its end. Returns (new 15
    values, rho, the physical duration as ``dur - dlo`` (a Kahan sum and its compensation),
    iterations, status, the energy target); on a failure the values are meaningless. em's
    end state gets :func:`_restore_energy` towards the energy ``eh + el``.

    The kick closing one sub-step and the kick opening the next read g at the same state: it
    is evaluated once per sub-step."""
    t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2 = s
    its = 0
    dur = 0.0
    dlo = 0.0
    if fixed <= 0.0:
        g = _g(t0, t1, t2, u0, u1, u2, c0, c1, c2, gm, eta)
    for k in range(gammas.shape[0]):
        if fixed > 0.0:
            h = fixed * gammas[k]
        else:
            ak = 0.25 * eps * gammas[k]
            a = ak * g
            if not abs(a) < KICK_MAX:
                return s, rho, dur, dlo, its, STATUS_NO_CONVERGENCE, eh, el
            if method == METHOD_TFE:
                rho = kick4(rho, a, (4.0 / 3.0) * ak * ak * _gp(t0, t1, t2, u0, u1, u2, c0, c1, c2, gm, eta))
            else:
                rho = kick(rho, a)
            h = (4.0 * ak) / rho
        (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, it, status) = _sub(
            method, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, h, gm, c0, c1, c2, max_iter, tfe
        )
        its += it
        if status != STATUS_OK:
            return s, rho, dur, dlo, its, status, eh, el
        if fixed <= 0.0:
            g = _g(t0, t1, t2, u0, u1, u2, c0, c1, c2, gm, eta)
            a = ak * g
            if not abs(a) < KICK_MAX:
                return s, rho, dur, dlo, its, STATUS_NO_CONVERGENCE, eh, el
            if method == METHOD_TFE:
                rho = kick4(rho, a, (-4.0 / 3.0) * ak * ak * _gp(t0, t1, t2, u0, u1, u2, c0, c1, c2, gm, eta))
            else:
                rho = kick(rho, a)
        dur, dlo = kahan_add(dur, dlo, h)
    if fixed > 0.0:
        rho = control(t0, t1, t2, c0, c1, c2, gm, eta)
    else:
        u = rho / control(t0, t1, t2, c0, c1, c2, gm, eta)
        if not (u > 1.0 / U_MAX and u < U_MAX):  # the control ran away from 1 / s(x)
            return s, rho, dur, dlo, its, STATUS_NO_CONVERGENCE, eh, el
    q = (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2)
    if method == METHOD_EM or method == METHOD_EM_PLAIN or method == METHOD_TFE:
        q, eh, el = _restore_energy(q, eh, el, gm, c0, c1, c2)
    return q, rho, dur, dlo, its, STATUS_OK, eh, el


@kernel
def _start(method, x, v, cx, cv, rho, gm, c0, c1, c2, eta, i):
    """The 15 values of point i and its control variable (set from s(x) where not started)."""
    n0 = n1 = n2 = 0.0
    if method == METHOD_LEAPFROG:
        n0, n1, n2, rr = accel(c0 - x[0, i], c1 - x[1, i], c2 - x[2, i], gm)
    s = (x[0, i], x[1, i], x[2, i], v[0, i], v[1, i], v[2, i], cx[0, i], cx[1, i], cx[2, i])
    s = s + (cv[0, i], cv[1, i], cv[2, i], n0, n1, n2)
    r = rho[i]
    if not r > 0.0:
        r = control(x[0, i], x[1, i], x[2, i], c0, c1, c2, gm, eta)
    return s, r


@kernel
def _store(s, r, x, v, cx, cv, rho, i):
    x[0, i], x[1, i], x[2, i] = s[0], s[1], s[2]
    v[0, i], v[1, i], v[2, i] = s[3], s[4], s[5]
    cx[0, i], cx[1, i], cx[2, i] = s[6], s[7], s[8]
    cv[0, i], cv[1, i], cv[2, i] = s[9], s[10], s[11]
    rho[i] = r


@kernel
def _step(ctx, s, rho, eps, fixed, t):
    """The controller's composed step of one point (:func:`emorbit.kernels.adaptive.interval`):
    the 17 values of ``s`` (the state and the energy target) and the context ``ctx``
    (method, gm, c0, c1, c2, eta, gammas, max_iter, tfe), ``tfe`` from :func:`tfe_scratch`."""
    method, gm, c0, c1, c2, eta, gammas, max_iter, tfe = ctx
    q, rq, dur, dlo, its, status, eh, el = _composed(
        method, s[:15], rho, eps, fixed, gammas, gm, c0, c1, c2, eta, max_iter, s[15], s[16], tfe
    )
    return q + (eh, el), rq, dur, dlo, its, status


@kernel
def _control(ctx, s):
    method, gm, c0, c1, c2, eta, gammas, max_iter, tfe = ctx
    return control(s[0], s[1], s[2], c0, c1, c2, gm, eta)


@kernel
def _accept(ctx, s, q):
    return q


@kernel
def _interval(method, s, r, length, gammas, gm, c0, c1, c2, eta, max_iter, tfe):
    """Composed steps from ``s, r`` that end exactly ``length`` seconds later: returns (s, r,
    iterations, composed steps, status). It starts afresh (its first step is a trial one), so
    what it does depends on the state alone, not on where a chunk started."""
    eh, el, _scale = _energy_dd(s, gm, c0, c1, c2)
    tfe[6][0] = 0.0  # no predictor from before the interval
    ctx = (method, gm, c0, c1, c2, eta, gammas, max_iter, tfe)
    q, r, its, steps, status = interval(_step, _control, _accept, ctx, s + (eh, el), r, length, 0.0)
    return q[:15], r, its, steps, status


@kernel
def adaptive_chunk(
    method,
    x,
    v,
    cx,
    cv,
    rho,
    gm,
    center,
    interval,
    every,
    eta,
    gammas,
    tab,
    nrec,
    max_iter,
    rec_x,
    rec_v,
    rec_iters,
    rec_steps,
    fail,
):
    """Advance every point by ``nrec`` records of ``every`` intervals of ``interval`` seconds
    (the landing grid: steps end on every multiple of it) with adaptive, time-symmetric
    steps, recording at the end of each record.

    method       METHOD_EM, METHOD_EM_PLAIN, METHOD_MIDPOINT, METHOD_LEAPFROG or METHOD_TFE
    gammas       the composition's sub-step fractions ([1.0] for METHOD_TFE: one step)
    tab          METHOD_TFE's Gauss tables (:func:`.tfe.tables`); any (k, 3 + 2k) array otherwise
    rho          (n,) control variables, updated in place (<= 0: set from the state)
    eta          the accuracy knob: steps of eta times the local Kepler time scale
    rec_steps    (nrec, n) composed steps each point took in each interval
    Other arguments as in :func:`~.chunk._run_point`; ``fail[i]`` holds (record interval
    index, status) of a point that failed even after halving its step
    :data:`~emorbit.kernels.adaptive.MAX_HALVINGS`
    times (the point then stops at the start of that interval).
    """
    n = x.shape[1]
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    tfe = tfe_scratch(tab)
    for i in range(n):
        s, r = _start(method, x, v, cx, cv, rho, gm, c0, c1, c2, eta, i)
        for k in range(nrec):
            its = 0
            steps = 0
            s_start = s
            r_start = r
            status = STATUS_OK
            for _j in range(every):
                s, r, it, st, status = _interval(method, s, r, interval, gammas, gm, c0, c1, c2, eta, max_iter, tfe)
                its += it
                steps += st
                if status != STATUS_OK:
                    break
            if status != STATUS_OK:
                s = s_start
                r = r_start
                fail[i, 0] = k
                fail[i, 1] = status
                break
            rec_x[k, 0, i] = s[0]
            rec_x[k, 1, i] = s[1]
            rec_x[k, 2, i] = s[2]
            rec_v[k, 0, i] = s[3]
            rec_v[k, 1, i] = s[4]
            rec_v[k, 2, i] = s[5]
            rec_iters[k, i] = its
            rec_steps[k, i] = steps
        _store(s, r, x, v, cx, cv, rho, i)


@kernel
def reversible_steps(method, x, v, cx, cv, rho, gm, center, eta, gammas, nsteps, max_iter, elapsed, tab):
    """Take exactly ``nsteps`` composed steps of size 1 in tau from every point (no records,
    no landing on a time): the scheme alone, for its time symmetry. ``elapsed`` (n,) gets the
    physical time each point advanced. Reversing the velocities and their compensations and
    calling it again runs the same steps back (the scheme is time-symmetric). Returns the
    status of the first failure (0: none)."""
    n = x.shape[1]
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    tfe = tfe_scratch(tab)
    for i in range(n):
        s, r = _start(method, x, v, cx, cv, rho, gm, c0, c1, c2, eta, i)
        tfe[6][0] = 0.0  # no predictor from the point before
        t = 0.0
        tc = 0.0
        eh, el, _scale = _energy_dd(s, gm, c0, c1, c2)
        for _ in range(nsteps):
            s, r, dur, dlo, it, status, eh, el = _composed(
                method, s, r, 1.0, 0.0, gammas, gm, c0, c1, c2, eta, max_iter, eh, el, tfe
            )
            if status != STATUS_OK:
                return status
            t, tc = kahan_add(t, tc + dlo, dur)
        elapsed[i] = t - tc
        _store(s, r, x, v, cx, cv, rho, i)
    return STATUS_OK
