"""Adaptive, time-symmetric steps for point masses: a reversible step-size controller
(Hairer & Soederlind) around the symmetric em, midpoint or leapfrog step.

Method. Each point carries a control variable ``rho``; its step is ``h = eps / rho``. On the
exact motion ``rho = 1 / s(x)``, ``s(x) = eta 2 pi sqrt(r**3 / GM)`` (``r = |x - c|``; the
Sundman-type rule dt ~ r**(3/2)), so in tau (dt = d tau / rho) ``d ln rho / d tau = g(y) =
-3/2 (x - c).v s(x) / r**2``. One step of size ``eps`` is the symmetric splitting

    rho_1/2 = rho_0 C(eps/4 g(y_0)),   y_1 = Phi_h(y_0), h = eps / rho_1/2,   rho_1 = rho_1/2 C(eps/4 g(y_1)),

``C(a) = (1 + a) / (1 - a)`` (exp(2 a) to third order, ``C(-a) = 1 / C(a)``), ``Phi_h`` the
symmetric method and g odd in v: the step of size ``-eps`` undoes the step of size ``eps``.
It is of order 2 in tau; the compositions of :mod:`emorbit.integrators` (sub-steps ``gammas[k]
eps``) raise it to 4-8. em keeps E and L exactly for any step sequence. ``eps`` is 1: ``eta``
alone sets the accuracy. Closing and opening kicks of neighbouring sub-steps share one g.

Round-off: the sub-steps read rounded positions, which moves the energy of the compensated
state (x - cx, v - cv) by about eps times the energy a sub-step exchanges (a walk of 1e-14 of
E over 100 orbits of e = 0.9, 1e-12 of a along the track). em's composed step ends by
restoring it (:func:`_restore_energy`): ``cv += (dE / |v|^2) v``, ``dE`` the end state's
energy minus the interval's first, both double-double; zero in exact arithmetic, skipped
beyond :data:`RESTORE_MAX` of ``|v|^2 + GM/r``, applied to em (either roundoff), not to
midpoint or leapfrog.

Steps land exactly on the grid ``k * interval`` (the run's ``dt``; records on every ``every``-th
point): a composed step that would pass the next grid time (expected from the last step,
:data:`PREDICT`, or found by taking it) is replaced by one composed step of the remaining time
(fixed sub-steps), after which ``rho = 1 / s(x)``, and ``rho s(x)``, which drifts from orbit
to orbit, starts each interval at 1. Each interval starts afresh from the state, so a run does
not depend on how it is cut into calls. A composed step whose solve fails, whose kicks exceed
:data:`KICK_MAX` or that leaves ``rho s(x)`` beyond :data:`U_MAX` is retried once with ``rho =
1 / s(x)``, then with trial steps of half the ``eps`` (at most :data:`MAX_HALVINGS` times)
before the point fails. The symmetry is broken at those resets and at the grid points only.

Data layout: ``x, v, cx, cv`` (3, n) state and Kahan compensations as in :mod:`.chunk`;
``rho`` (n,) the control variables (<= 0: set from ``s(x)``), part of a checkpoint.

References: E. Hairer, G. Soederlind, SIAM J. Sci. Comput. 26 (2005) 1838-1851; E. Hairer,
C. Lubich, G. Wanner, Geometric Numerical Integration, 2nd ed. (Springer 2006), sec. VIII.3;
K. Sundman, Acta Math. 36 (1913) 105-179.
"""

from __future__ import annotations

import math

from ..codes import METHOD_EM, METHOD_EM_PLAIN, METHOD_LEAPFROG, STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from ..eft import dd_add, dd_div, dd_mul, dd_sqrt, kahan_add
from ..gravity import accel
from ..jit import kernel
from .point_step import _implicit_point_em, _implicit_point_em_plain, _implicit_point_mid, _leapfrog_point
from .roots import _tau

__all__ = ["adaptive_chunk", "reversible_steps", "control", "MAX_HALVINGS", "MAX_STEPS", "KICK_MAX", "U_MAX"]

MAX_HALVINGS = 20
#: composed steps per record interval beyond which a point fails (its control ran away)
MAX_STEPS = 10_000_000
#: a composed step that leaves rho s(x) beyond a factor U_MAX from 1 fails (and is retried
#: with half the eps): the control no longer follows the motion
U_MAX = 16.0
#: a half-kick ``rho (1 + a) / (1 - a)`` with ``|a|`` beyond this (rho changing by more than a
#: factor 1.5 in half a sub-step: the step is too long for the control) retries the composed
#: step with half the eps
KICK_MAX = 0.2
#: a step after one of duration d is expected to last at most PREDICT d: where less than that
#: is left to the record, the step of the remaining time is taken without a trial step
PREDICT = 1.1
#: em's round-off correction of the energy (:func:`_restore_energy`) applies to a composed
#: step whose energy moved by less than this fraction of |v|^2 + GM / r
RESTORE_MAX = 2.0**-36
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
def _g(x0, x1, x2, y0, y1, y2, c0, c1, c2, gm, eta):
    """g(y) = d ln(rho) / d tau = -3/2 (x - c).v s(x) / r**2 (odd in v)."""
    ax = x0 - c0
    ay = x1 - c1
    az = x2 - c2
    r = math.sqrt(ax * ax + ay * ay + az * az)
    return (-1.5 * eta * _TWO_PI) * (ax * y0 + ay * y1 + az * y2) / math.sqrt(r * gm)


@kernel
def _kick(rho, a):
    """rho (1 + a) / (1 - a): exp(2 a) to third order, and its own inverse with -a."""
    return rho * (1.0 + a) / (1.0 - a)


@kernel
def _sub(method, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, h, gm, c0, c1, c2, max_iter):
    """One sub-step of physical size h of the symmetric method: 15 values, iterations, status."""
    extra = 0
    status = STATUS_OK
    if method == METHOD_LEAPFROG:
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
def _composed(method, s, rho, eps, fixed, gammas, gm, c0, c1, c2, eta, max_iter, eh, el):
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
            rho = _kick(rho, a)
            h = (4.0 * ak) / rho
        (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, it, status) = _sub(
            method, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, h, gm, c0, c1, c2, max_iter
        )
        its += it
        if status != STATUS_OK:
            return s, rho, dur, dlo, its, status, eh, el
        if fixed <= 0.0:
            g = _g(t0, t1, t2, u0, u1, u2, c0, c1, c2, gm, eta)
            a = ak * g
            if not abs(a) < KICK_MAX:
                return s, rho, dur, dlo, its, STATUS_NO_CONVERGENCE, eh, el
            rho = _kick(rho, a)
        dur, dlo = kahan_add(dur, dlo, h)
    if fixed > 0.0:
        rho = control(t0, t1, t2, c0, c1, c2, gm, eta)
    else:
        u = rho / control(t0, t1, t2, c0, c1, c2, gm, eta)
        if not (u > 1.0 / U_MAX and u < U_MAX):  # the control ran away from 1 / s(x)
            return s, rho, dur, dlo, its, STATUS_NO_CONVERGENCE, eh, el
    q = (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2)
    if method == METHOD_EM or method == METHOD_EM_PLAIN:
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
def _interval(method, s, r, interval, gammas, gm, c0, c1, c2, eta, max_iter):
    """Composed steps from ``s, r`` that end exactly ``interval`` seconds later: returns (s, r,
    iterations, composed steps, status). It starts afresh (its first step is a trial one), so
    what it does depends on the state alone, not on where a chunk started."""
    its = 0
    steps = 0
    elapsed = 0.0
    comp = 0.0
    prev = 0.0
    status = STATUS_OK
    last = False
    eh, el, _scale = _energy_dd(s, gm, c0, c1, c2)
    while not last:
        rem = (interval - elapsed) + comp  # kahan_add's compensation: the sum is elapsed - comp
        ok = False
        eps = 1.0
        q = s
        rq = r
        qh = eh
        ql = el
        reset = False
        for _attempt in range(MAX_HALVINGS + 2):
            if prev >= rem and eps == 1.0 and not reset:
                # the last step was longer than what is left: no trial step (but after a
                # failed landing step, trial steps)
                dur = rem
                dlo = 0.0
                status = STATUS_OK
            else:
                q, rq, dur, dlo, it, status, qh, ql = _composed(
                    method, s, r, eps, 0.0, gammas, gm, c0, c1, c2, eta, max_iter, eh, el
                )
                its += it
            if status == STATUS_OK and dur - dlo >= rem:
                # the step passes the landing: one step of the remaining time instead
                q, rq, dur, dlo, it, status, qh, ql = _composed(
                    method, s, r, 1.0, rem, gammas, gm, c0, c1, c2, eta, max_iter, eh, el
                )
                its += it
                last = True
            if status == STATUS_OK:
                ok = True
                break
            last = False
            if not reset:
                # first failure: the control may have run away from the motion (kicks too
                # large, rho s(x) beyond U_MAX): start it afresh from the state, as at a
                # landing, and try again before halving
                reset = True
                r = control(s[0], s[1], s[2], c0, c1, c2, gm, eta)
                continue
            eps *= 0.5
        if not ok:
            return s, r, its, steps, status
        s = q
        r = rq
        eh = qh
        el = ql
        steps += 1
        if steps > MAX_STEPS:  # the control ran away: fail rather than never return
            return s, r, its, steps, STATUS_NO_CONVERGENCE
        if not last:
            elapsed, comp = kahan_add(elapsed, comp + dlo, dur)
            prev = PREDICT * (dur - dlo)
    return s, r, its, steps, STATUS_OK


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

    method       METHOD_EM, METHOD_EM_PLAIN, METHOD_MIDPOINT or METHOD_LEAPFROG
    rho          (n,) control variables, updated in place (<= 0: set from the state)
    eta          the accuracy knob: steps of eta times the local Kepler time scale
    rec_steps    (nrec, n) composed steps each point took in each interval
    Other arguments as in :func:`~.chunk._run_point`; ``fail[i]`` holds (record interval
    index, status) of a point that failed even after halving its step :data:`MAX_HALVINGS`
    times (the point then stops at the start of that interval).
    """
    n = x.shape[1]
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    for i in range(n):
        s, r = _start(method, x, v, cx, cv, rho, gm, c0, c1, c2, eta, i)
        for k in range(nrec):
            its = 0
            steps = 0
            s_start = s
            r_start = r
            status = STATUS_OK
            for _j in range(every):
                s, r, it, st, status = _interval(method, s, r, interval, gammas, gm, c0, c1, c2, eta, max_iter)
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
def reversible_steps(method, x, v, cx, cv, rho, gm, center, eta, gammas, nsteps, max_iter, elapsed):
    """Take exactly ``nsteps`` composed steps of size 1 in tau from every point (no records,
    no landing on a time): the scheme alone, for its time symmetry. ``elapsed`` (n,) gets the
    physical time each point advanced. Reversing the velocities and their compensations and
    calling it again runs the same steps back (the scheme is time-symmetric). Returns the
    status of the first failure (0: none)."""
    n = x.shape[1]
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    for i in range(n):
        s, r = _start(method, x, v, cx, cv, rho, gm, c0, c1, c2, eta, i)
        t = 0.0
        tc = 0.0
        eh, el, _scale = _energy_dd(s, gm, c0, c1, c2)
        for _ in range(nsteps):
            s, r, dur, dlo, it, status, eh, el = _composed(
                method, s, r, 1.0, 0.0, gammas, gm, c0, c1, c2, eta, max_iter, eh, el
            )
            if status != STATUS_OK:
                return status
            t, tc = kahan_add(t, tc + dlo, dur)
        elapsed[i] = t - tc
        _store(s, r, x, v, cx, cv, rho, i)
    return STATUS_OK
