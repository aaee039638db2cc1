"""The reversible step-size controller of adaptive steps, for every body kind.

Method (Hairer & Soederlind). A subject (a point mass, a rigid body, a set of points under effects,
a structure) carries a control variable ``rho``; its step is ``h = eps / rho``. On the exact motion
``rho = 1 / s(y)``, s the subject's time scale times the accuracy knob eta (a local Kepler time, a
rotation period, the highest elastic frequency's period), so in tau (dt = d tau / rho) ``d ln rho /
d tau = g(y)``, odd in the velocities. One step of size ``eps`` is the symmetric splitting

    rho_1/2 = rho_0 C(eps/4 g(y_0)),   y_1 = Phi_h(y_0), h = eps / rho_1/2,   rho_1 = rho_1/2 C(eps/4 g(y_1)),

``C(a) = (1 + a) / (1 - a)`` (:func:`kick`: exp(2 a) to third order, ``C(-a) = 1 / C(a)``),
``Phi_h`` the symmetric method (the step of size ``-eps`` undoes it). It is of order 2 in tau;
compositions (sub-steps ``gammas[k] eps``) raise it to 4-8, the closing and opening kicks of
neighbouring sub-steps sharing one g. A one-solve step that knows ``g' = dg/dtau`` (even in the
velocities) takes the Hermite rule's kicks (:func:`kick4`, order 4): ``exp(eps/2 g_0 + eps^2/12
g'_0)`` before, ``exp(eps/2 g_1 - eps^2/12 g'_1)`` after. ``eps`` is 1: ``eta`` alone sets the
accuracy.

The landing rule (:func:`interval`, the one loop every body kind runs): steps land exactly on the
grid ``k * length`` (the run's ``dt``; records on every ``every``-th point). A composed step that
would pass the next grid time (expected from the last step, :data:`PREDICT`, or found by taking it)
is replaced by one composed step of the remaining time (fixed sub-steps), after which ``rho = 1 /
s(y)``; each interval starts afresh from the state, so a run does not depend on how it is cut into
calls. A composed step whose solve fails, whose kicks exceed :data:`KICK_MAX` or that leaves ``rho
s(y)`` beyond :data:`U_MAX` is retried once with ``rho = 1 / s(y)``, then with trial steps of half
the ``eps`` (at most :data:`MAX_HALVINGS` times) before the subject fails; the symmetry is broken
at those resets and at the grid points only. An interval's elapsed time is a Kahan sum.

A body kind gives three functions of its own context ``ctx`` and state ``s`` (whatever types it
keeps them in), which :func:`interval` takes as arguments: ``composed(ctx, s, rho, eps, fixed, t)``
(one composed step from the state at time t: of size ``eps`` in tau, or, with ``fixed`` > 0, of
physical size ``fixed`` with rho then ``1 / s(y)``; returns the new state, rho, the duration as a
Kahan pair ``dur - dlo``, the iterations and a status; the state given is not changed),
``control(ctx, s)`` (``1 / s(y)``) and ``accept(ctx, s, q)`` (the state after a step to q,
returned). Compiled kernels pass Numba functions; the coupled structures, whose steps are Python,
run the same loop as Python (``interval.py_func``).

References: E. Hairer, G. Soederlind, SIAM J. Sci. Comput. 26 (2005) 1838-1851; E. Hairer, C.
Lubich, G. Wanner, Geometric Numerical Integration, 2nd ed. (2006), VIII.3; K. Sundman, Acta Math.
36 (1913) 105-179.
"""

from __future__ import annotations

import math

from .codes import STATUS_NO_CONVERGENCE, STATUS_OK
from .eft import kahan_add
from .jit import kernel

__all__ = ["interval", "kick", "kick4", "MAX_HALVINGS", "MAX_STEPS", "U_MAX", "KICK_MAX", "PREDICT", "RESTORE_MAX"]

#: trial steps of half the eps a failing composed step may take before the subject fails
MAX_HALVINGS = 20
#: composed steps per interval beyond which a subject fails (its control ran away)
MAX_STEPS = 10_000_000
#: a composed step that leaves rho s(y) beyond a factor U_MAX from 1 fails (and is retried
#: with half the eps): the control no longer follows the motion
U_MAX = 16.0
#: a half-kick ``rho (1 + a) / (1 - a)`` with ``|a|`` beyond this (rho changing by more than a
#: factor 1.5 in half a sub-step: the step is too long for the control) retries the composed
#: step with half the eps
KICK_MAX = 0.2
#: a step after one of duration d is expected to last at most PREDICT d: where less than that
#: is left to the landing, the step of the remaining time is taken without a trial step
PREDICT = 1.1
#: em's round-off correction of a point's energy applies to a composed step whose energy moved
#: by less than this fraction of its scale (:mod:`emorbit.kernels.pointmass.adaptive`)
RESTORE_MAX = 2.0**-36


@kernel(inline="always")
def kick(rho, a):
    """rho (1 + a) / (1 - a): exp(2 a) to third order, and its own inverse with -a."""
    return rho * (1.0 + a) / (1.0 - a)


@kernel(inline="always")
def kick4(rho, a, b):
    """rho exp(2 a + b): a half-kick of the Hermite rule, ``a = eps/4 g``, ``b = eps^2/12 g'``
    opening a step and ``-eps^2/12 g'`` closing it; its inverse is ``kick4(rho, -a, -b)``."""
    return rho * math.exp(2.0 * a + b)


@kernel(inline="always")  # inlined into each caller (cached there) with its body kind's functions
def interval(composed, control, accept, ctx, s, r, length, t0):
    """Composed steps of a subject from state ``s`` and control ``r`` at time ``t0`` that end
    exactly ``length`` seconds later (the landing rule of the module's docstring).

    Returns
    -------
    tuple
        (state, rho, iterations, composed steps, status); on a failure, the state and rho
        where the subject stopped.
    """
    its = 0
    steps = 0
    elapsed = 0.0
    comp = 0.0
    prev = 0.0
    status = STATUS_OK
    last = False
    while not last:
        rem = (length - elapsed) + comp  # kahan_add's compensation: the sum is elapsed - comp
        t = t0 + (elapsed - comp)
        ok = False
        eps = 1.0
        q = s
        rq = r
        reset = False
        dur = rem
        dlo = 0.0
        for _attempt in range(MAX_HALVINGS + 2):
            if prev >= rem and eps == 1.0 and not reset:
                # the last step was longer than what is left: no trial step (but after a
                # failed landing step, trial steps)
                dur = rem
                dlo = 0.0
                status = STATUS_OK
            else:
                q, rq, dur, dlo, it, status = composed(ctx, s, r, eps, 0.0, t)
                its += it
            if status == STATUS_OK and dur - dlo >= rem:
                # the step passes the landing: one step of the remaining time instead
                q, rq, dur, dlo, it, status = composed(ctx, s, r, 1.0, rem, t)
                its += it
                last = True
            if status == STATUS_OK:
                ok = True
                break
            last = False
            if not reset:
                # first failure: the control may have run away from the motion (kicks too
                # large, rho s(y) beyond U_MAX): start it afresh from the state, as at a
                # landing, and try again before halving
                reset = True
                r = control(ctx, s)
                continue
            eps *= 0.5
        if not ok:
            return s, r, its, steps, status
        s = accept(ctx, s, q)
        r = rq
        steps += 1
        if steps > MAX_STEPS:  # the control ran away: fail rather than never return
            return s, r, its, steps, STATUS_NO_CONVERGENCE
        if not last:
            elapsed, comp = kahan_add(elapsed, comp + dlo, dur)
            prev = PREDICT * (dur - dlo)
    return s, r, its, steps, STATUS_OK
