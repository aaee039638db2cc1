"""One point's sub-step of em, midpoint or leapfrog, through the scalar helpers of :mod:`.roots`.

State of a point: position ``x``, velocity ``v`` and their compensation terms (the low bits lost
by ``x += dx``, carried by Kahan summation, :func:`_kahan3`), 12 float64 scalars; leapfrog adds
the acceleration at the state (3 more), which the next sub-step's opening kick reuses.

* :func:`_implicit_point_em`, :func:`_implicit_point_em_plain`, :func:`_implicit_point_mid`: one
  implicit sub-step of size ``h``: the dot products, the predictor, the packed path's updates of
  the scalar unknown and its acceptance test, then ``w``, the increments and the compensated
  update. em steps with ``t > 1/128`` end with the reference kernel's finish.
* :func:`_resolve_point`: a point whose first updates were not accepted takes more Newton
  updates of the scalar unknown (em, roundoff="brouwer": certified updates, and once an update
  leaves no remainder but is not certified, one update on the accurately evaluated equation);
  if that misbehaves (leaves the range where a root can be, stops shrinking, runs out of
  iterations) the reference kernel's Newton on 3-vectors solves the step
  (:func:`~.reference.em_step`, :func:`~.reference.midpoint_step`), whose stopping and failure
  rules then apply. The packed passes (:mod:`.block`) call it for the points they flag.
* :func:`_leapfrog_point`: one kick-drift-kick sub-step with the operations of
  :func:`~.reference.leapfrog_chunk`, so the same bits.

A new state that is not finite fails its step (``STATUS_SINGULAR``), as in the reference
kernels. Every point goes through these functions whether it runs in a packed block or alone
(:mod:`.chunk`), so its result does not depend on the other points, and the GPU kernels
(:mod:`.cuda`) compile the same functions again for the device.
"""

from __future__ import annotations

import math

from ..codes import METHOD_EM, METHOD_EM_PLAIN, METHOD_LEAPFROG, METHOD_MIDPOINT, STATUS_OK, STATUS_SINGULAR
from ..eft import kahan_add as _kahan
from ..gravity import accel
from ..jit import kernel
from .reference import em_step, midpoint_step
from .roots import (
    _ACCEPT_NEWTON,
    _em_big_t,
    _em_chord,
    _em_dots,
    _em_finished,
    _em_newton,
    _em_newton_accurate,
    _em_newton_certified,
    _em_ok,
    _em_ok_newton,
    _em_plausible,
    _em_predict,
    _em_predict_taylor,
    _em_w,
    _increments,
    _mid_newton,
    _mid_ok,
    _mid_start,
    _mid_w,
)

_inline = kernel(inline="always")

#: Newton iterations every packed point does per sub-step (fast em: Newton + chord;
#: midpoint: 2 Newton; leapfrog: none; the default em does one, see _packed_iters)
_PACKED_ITERS = 2


@kernel
def _packed_iters(method):
    if method == METHOD_LEAPFROG:
        return 0
    return 1 if method == METHOD_EM else _PACKED_ITERS


@kernel
def _kahan3(s0, s1, s2, c0, c1, c2, d0, d1, d2):
    """Compensated sums s + d of a 3-vector with compensations c: (t0, t1, t2, e0, e1, e2)."""
    t0, e0 = _kahan(s0, c0, d0)
    t1, e1 = _kahan(s1, c1, d1)
    t2, e2 = _kahan(s2, c2, d2)
    return t0, t1, t2, e0, e1, e2


@kernel
def _finite6(a, b, c, d, e, f):
    """All six finite (as reference._finite: a sum of finite values overflows only far
    beyond any state)."""
    return abs(a + b + c + d + e + f) < math.inf


@kernel
def _finite3(a, b, c):
    return abs(a + b + c) < math.inf


@kernel
def _resolve_plausible(method, rho, A, V):
    """em: :func:`_em_plausible`; midpoint (``A`` = |a - h/2 v0|): finite and positive."""
    if method == METHOD_MIDPOINT:
        return rho > 0.0 and rho < math.inf
    return _em_plausible(rho, A, V)


@_inline
def _resolve_point(method, A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter):
    """Finish a point whose packed solve was not accepted: more Newton updates of the
    scalar unknown; if that misbehaves (leaves the range of :func:`_resolve_plausible`,
    stops shrinking, runs out of iterations), the reference kernel's Newton on 3-vectors.
    ``A`` is |a - h/2 v0| for the midpoint. em (roundoff="brouwer") takes certified
    updates (:func:`_em_newton_certified`) until one is certified, or, once an update left
    no remainder (``prev`` below 2**-32.5 r1) but its rounding was not certified, one
    update on the accurate F, accepted as :func:`_em_ok_newton` says; after the reference
    kernel's Newton it takes one more update on the accurate F, so that no remainder of the
    iteration is left. Returns (r0, unknown, extra iterations, status)."""
    packed = _packed_iters(method)
    it = packed
    while it < max_iter and _resolve_plausible(method, rho, A, V):
        if method == METHOD_EM:
            if prev * prev <= _ACCEPT_NEWTON * (rho * rho):
                # the last update left no remainder, only its rounding was not certified:
                # the accurate update decides it
                rho, delta = _em_newton_accurate(A, P, V, r0, rho, tau0, tlo)
                it += 1
                if _em_ok_newton(delta, rho, A, V):
                    return r0, rho, it - packed, STATUS_OK
            else:
                rho, delta, cert = _em_newton_certified(A, P, V, r0, rho, tau0, tlo)
                it += 1
                if cert & _em_plausible(rho, A, V):
                    return r0, rho, it - packed, STATUS_OK
        else:
            if method == METHOD_EM_PLAIN:
                rho, delta, qg = _em_newton(A, P, V, r0, rho, tau0, tlo)
            else:
                rho, delta = _mid_newton(A, rho, tau0)
            it += 1
            if _mid_ok(delta, rho) and _resolve_plausible(method, rho, A, V):
                return r0, rho, it - packed, STATUS_OK
        if not abs(delta) < prev:
            break
        prev = abs(delta)
    extra = it - packed
    # the reference kernel's Newton on 3-vectors, from its own predictor
    if method != METHOD_MIDPOINT:  # only its r1 is used: the caller finishes the step
        d0, d1, d2, w0, w1, w2, its, status = em_step(px, py, pz, vx, vy, vz, h, gm, c0, c1, c2, max_iter, False)
    else:
        d0, d1, d2, w0, w1, w2, its, status = midpoint_step(px, py, pz, vx, vy, vz, h, gm, c0, c1, c2, max_iter)
    extra += its
    ax = c0 - px
    ay = c1 - py
    az = c2 - pz
    if method != METHOD_MIDPOINT:
        bx = ax - d0
        by = ay - d1
        bz = az - d2
        r0 = math.sqrt(ax * ax + ay * ay + az * az)
        rho = math.sqrt(bx * bx + by * by + bz * bz)
        if method == METHOD_EM and status == STATUS_OK and _em_plausible(rho, A, V):
            rho, delta = _em_newton_accurate(A, P, V, r0, rho, tau0, tlo)
            extra += 1
    else:
        mx = ax - 0.5 * d0
        my = ay - 0.5 * d1
        mz = az - 0.5 * d2
        rho = math.sqrt(mx * mx + my * my + mz * mz)
    if status == STATUS_OK and not _resolve_plausible(method, rho, A, V):
        status = STATUS_SINGULAR
    return r0, rho, extra, status


# the scalar path calls these (rarely taken) instead of inlining them with the rest of its
# step, which keeps its compile time down; one per method, so a run compiles only its own


@kernel
def _resolve_point_em(A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter):
    return _resolve_point(
        METHOD_EM, A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter
    )


@kernel
def _resolve_point_em_plain(A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter):
    return _resolve_point(
        METHOD_EM_PLAIN, A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter
    )


@kernel
def _resolve_point_mid(A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter):
    return _resolve_point(
        METHOD_MIDPOINT, A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter
    )


@_inline
def _implicit_point_impl(
    method, x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter
):
    """One em or midpoint sub-step of one point, through the same helpers as the packed
    passes. Returns the 12 new state values, extra iterations and status."""
    ax = c0 - x0
    ay = c1 - x1
    az = c2 - x2
    if method != METHOD_MIDPOINT:
        A, P, V, r0 = _em_dots(ax, ay, az, y0, y1, y2, h)
        if method == METHOD_EM:
            rho = _em_predict(A, P, V, r0, h, gm)
            rho, delta, cert = _em_newton_certified(A, P, V, r0, rho, tau0, tlo)
            ok = cert & _em_plausible(rho, A, V)
        else:
            rho = _em_predict_taylor(A, P, V, r0, h, gm)
            rho, d1, qg = _em_newton(A, P, V, r0, rho, tau0, tlo)
            rho, delta = _em_chord(A, P, V, r0, rho, tau0, tlo, qg)
            ok = _em_ok(d1, delta, rho, A, V)
    else:
        A = _mid_start(ax, ay, az, y0, y1, y2, h)
        P = 0.0
        V = 0.0
        r0 = 0.0
        rho, delta = _mid_newton(A, A, tau0)
        rho, delta = _mid_newton(A, rho, tau0)
        ok = _mid_ok(delta, rho)
    extra = 0
    status = STATUS_OK
    if not ok and method == METHOD_EM:
        r0, rho, extra, status = _resolve_point_em(
            A, P, V, r0, rho, abs(delta), h, gm, tau0, tlo, x0, x1, x2, y0, y1, y2, c0, c1, c2, max_iter
        )
    elif not ok and method == METHOD_EM_PLAIN:
        r0, rho, extra, status = _resolve_point_em_plain(
            A, P, V, r0, rho, abs(delta), h, gm, tau0, tlo, x0, x1, x2, y0, y1, y2, c0, c1, c2, max_iter
        )
    elif not ok:
        r0, rho, extra, status = _resolve_point_mid(
            A, P, V, r0, rho, abs(delta), h, gm, tau0, tlo, x0, x1, x2, y0, y1, y2, c0, c1, c2, max_iter
        )
    if method != METHOD_MIDPOINT:
        w = _em_w(r0, rho, gm, tau0, tlo)
        if method == METHOD_EM and _em_big_t(w, gm, tau0):
            d0, d1, d2, w0, w1, w2 = _em_finished(ax, ay, az, y0, y1, y2, w, r0, h, gm)
        else:
            d0, d1, d2, w0, w1, w2 = _increments(ax, ay, az, y0, y1, y2, w, 2.0, h, h)
    else:
        w = _mid_w(rho, gm, tau0, tlo)
        d0, d1, d2, w0, w1, w2 = _increments(ax, ay, az, y0, y1, y2, w, 1.0, 0.5 * h, h)
    t0, t1, t2, e0, e1, e2 = _kahan3(x0, x1, x2, p0, p1, p2, d0, d1, d2)
    u0, u1, u2, f0, f1, f2 = _kahan3(y0, y1, y2, q0, q1, q2, w0, w1, w2)
    if status == STATUS_OK and not _finite6(t0, t1, t2, u0, u1, u2):
        status = STATUS_SINGULAR
    return t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status


@_inline
def _implicit_point_em(x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter):
    """The default em step of one point, inlined into the point-by-point path (as a call it
    would pass 20 values and return 14 through memory). The other methods' steps are calls:
    inlined, each would be processed (and then dropped) in every method's kernel, which
    lengthens each one's first compile."""
    return _implicit_point_impl(
        METHOD_EM, x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter
    )


@kernel
def _implicit_point_em_plain(x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter):
    return _implicit_point_impl(
        METHOD_EM_PLAIN, x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter
    )


@kernel
def _implicit_point_mid(x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter):
    return _implicit_point_impl(
        METHOD_MIDPOINT, x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter
    )


@kernel
def _leapfrog_point(x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, b0, b1, b2, h, gm, c0, c1, c2):
    """One kick-drift-kick sub-step of one point, with the same operations as
    reference.leapfrog_chunk (so the same bits). Returns 15 values and whether finite."""
    hf = 0.5 * h
    t0, t1, t2, e0, e1, e2 = _kahan3(x0, x1, x2, p0, p1, p2, h * (y0 + hf * b0), h * (y1 + hf * b1), h * (y2 + hf * b2))
    n0, n1, n2, rr = accel(c0 - t0, c1 - t1, c2 - t2, gm)
    u0, u1, u2, f0, f1, f2 = _kahan3(
        y0, y1, y2, q0, q1, q2, 0.5 * h * (b0 + n0), 0.5 * h * (b1 + n1), 0.5 * h * (b2 + n2)
    )
    # a centre hit makes the acceleration nan, so "finite" covers the reference's test of r
    good = _finite6(t0, t1, t2, u0, u1, u2) & _finite3(n0, n1, n2)
    return t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, good
