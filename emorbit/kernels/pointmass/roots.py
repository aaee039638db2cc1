"""The point-mass em and midpoint steps reduced to one scalar unknown, and its root solves.

A point-mass step is planar. With ``a = X_Z - x0`` (towards the centre), ``tau = h**2/2 GM``
(an unevaluated sum exact to eps**2, :func:`_tau`) and ``Q = r0 r1 (r0 + r1)``, the
energy-momentum step ``dx = h v0 + h**2/2 g_em``, ``g_em = GM (a + b) / Q``, ``b = a - dx``,
is explicit once ``r1 = |b|`` is known::

    g_em = w u,   u = 2 a - h v0,   w = GM / (Q + tau),   dx = h v0 + h (h/2 w) u,   dv = (h w) u

``r1`` is the root of ``F = r1**2 (1 + t)**2 - ((1 - t)**2 A - 2 (1 - t) P + V)``, ``t = tau / Q``,
a function of ``A = a.a``, ``P = h a.v0`` and ``V = h**2 v0.v0`` (:func:`_em_dots`). ``F Q**2`` and
``F' Q**3`` are polynomials in ``r1``, so a Newton update costs one division and no square root.
``F Q**2`` is evaluated as ``Q**2 D + 2 tau Q (r1**2 + A - P) + tau**2 (r1**2 - A)`` with
``D = r1**2 - |a - h v0|**2`` (:func:`_em_f2`): the cancellation of the large terms stays in ``D``.

* Predictor: the step's own equations solved as a series to fourth order (:func:`_em_predict`),
  an error in ``r1`` of O(h**7); roundoff="fast" uses the explicit Taylor step with the jerk,
  O(h**4) (:func:`_em_predict_taylor`).
* Default (``METHOD_EM``, roundoff="brouwer"): one Newton update on the plain ``F`` with a
  certificate (:func:`_em_newton_certified`), a rigorous bound on its error whose two ends round
  to the same double: that double is then the exact root of ``F`` (for ``A``, ``P``, ``V`` as
  rounded) correctly rounded. A step that is not certified takes more updates in a scalar pass
  (:mod:`.point_step`), the last on ``F`` with every rounding that depends on ``r1`` carried
  (:func:`_em_f2_accurate`, :func:`_em_ok_newton`): the same double. Steps with ``t > 1/128``
  end with the reference kernel's accurate finish (:func:`_em_finished`).
* roundoff="fast" (``METHOD_EM_PLAIN``): a Newton and a chord update with the same derivative on
  the plain ``F`` (Traub's method, third order, one division), uncertified (:func:`_em_ok`).
  Every accepted root lies where a root of the step can be (:func:`_em_plausible`, :func:`_em_small`).

Newton converges on the rounding errors of the ``F`` it evaluates, and the energy error of the
step is proportional to the error of its root: a root correlated with those errors makes the
energy drift instead of walking randomly (Brouwer's law; docs/methods.md has the measurements).

The implicit midpoint step reduces the same way: ``m = a - dx/2`` has ``|m| (1 + t/2) = |a - h/2 v0|``
with ``t = tau / |m|**3``, a cubic in ``|m|`` solved by Newton from ``|a - h/2 v0|``
(:func:`_mid_newton`), and ``g = w (a - h/2 v0)`` with ``w = GM / (|m|**3 + tau/2)``.

Scalars in, scalars out: the packed passes (:mod:`.block`) and the one-point step (:mod:`.point_step`)
run the same operations; the only fused multiply-adds are the explicit ones (:func:`~emorbit.kernels.eft.fma`).
References: Goettlicher & Schweizerhof (g_em); Traub, Iterative Methods for the Solution of Equations (1964).
"""

from __future__ import annotations

import math

from ..eft import fma, two_prod, two_prod_dekker, two_sum
from ..jit import kernel
from .reference import em_finish

_inline = kernel(inline="always")

#: midpoint: accept a Newton update |delta| <= 2**-26 |m| (the next is below eps |m| / 2)
_ACCEPT2 = 2.0**-52
#: em: accept a Newton-chord pair |delta1 delta2| <= 2**-56 r1**2 (error ~ 4 |d1 d2| / r1)
_ACCEPT3 = 2.0**-56
#: em (roundoff="brouwer"): a Newton update d1 on the accurate F leaves about d1**2 / (2 r1):
#: |d1| <= 2**-32.5 r1 leaves below 2**-66 r1
_ACCEPT_NEWTON = 2.0**-65
#: ... and only where both updates are below r1 / 64 (a Newton update that runs off to a far
#: or negative r1 can leave a chord update tiny against that r1)
_SMALL = 2.0**-6
#: em (roundoff="brouwer"): steps with t = tau / Q above 1/128 (t / (1 + t) = tau w / GM above
#: 1/129) are finished by reference.em_finish: the unfinished step drifts by about t**2
#: (docs/methods.md)
_BIG_T = 1.0 / 129.0
#: the unit roundoff of float64
_U = 2.0**-53


@kernel
def _tau(h, gm):
    """h**2/2 GM as a sum hi + lo, exact to about eps**2.

    A rounded h**2/2 that multiplies gravity in the position but not in the velocity would
    give the energy an error -eps h**2/2 |g|**2 of one sign in every step (see
    :mod:`.reference`); carrying the rounding error lo makes that eps**2."""
    p, e = two_prod_dekker(h, h)
    q, f = two_prod_dekker(p, gm)
    lo = f + e * gm
    hi = q + lo
    return 0.5 * hi, 0.5 * (lo - (hi - q))


@kernel
def _em_dots(ax, ay, az, vx, vy, vz, h):
    """a.a, h a.v0, h**2 v0.v0 and |a| (the step enters the equations only in these forms).
    (``h (h v0.v0)``: a rounded ``h*h`` would carry the same relative error in every step.)"""
    A = fma(ax, ax, fma(ay, ay, az * az))
    return A, h * fma(ax, vx, fma(ay, vy, az * vz)), h * (h * fma(vx, vx, fma(vy, vy, vz * vz))), math.sqrt(A)


@kernel
def _em_predict(A, P, V, r0, h, gm):
    """r1 of the em step predicted from its own equations, P = h a.v0, V = h**2 v0.v0.

    With W = h**2 w (g_em = w (2 a - h v0)) the step gives exactly
    r1**2 = (1 - W)**2 A - 2 (1 - W)(1 - W/2) P + (1 - W/2)**2 V, and W = h**2 GM / (Q + tau)
    depends on r1 through Q = r0 r1 (r0 + r1). Solved as a series in p = P / A ~ h,
    v = V / A ~ h**2 and s = tau / r0**3 ~ h**2 (tau = h**2/2 GM), to fourth order::

        W / s = 1 + 3/2 p + 5/2 p**2 + 35/8 p**3 + 63/8 p**4
                  + s (1 + 7/2 p + 79/8 p**2 + 2 s - 17/8 v) - v (3/4 + 5/2 p + 105/16 p**2 - 5/8 v)

    (the p-only terms are the expansion of 2 / (y (1 + y)), y = sqrt(1 - 2 p)). r1 is then
    wrong by O(h**7) of r0 (the first term left out is s times a fifth-order one) instead of
    O(h**4) with W to first order (tests/test_ensemble.py::test_predictor_orders); on the
    paper's orbit at T/100 the largest relative error is 4.5e-5 (3.8e-3 with W to first order),
    at T/1000 below 5e-12, so that one Newton update finishes most steps. The polynomials are
    evaluated by Horner's rule with fused multiply-adds (:func:`.eft.fma`), as are the dot
    products (:func:`_em_dots`), the derivative (:func:`_em_g3`), the certificate's bound and
    the increments. ``F Q**2`` itself is not fused (:func:`_em_f2`): the certificate's error
    analysis is written for its plain operations."""
    ir = 1.0 / r0
    ir2 = ir * ir
    s = (0.5 * h) * (h * (gm * (ir2 * ir)))
    p = P * ir2
    v = V * ir2
    t1 = fma(p, fma(p, fma(p, fma(p, 7.875, 4.375), 2.5), 1.5), 1.0)
    t2 = fma(p, fma(p, 9.875, 3.5), fma(-2.125, v, fma(2.0, s, 1.0)))
    t3 = fma(p, fma(p, 6.5625, 2.5), fma(-0.625, v, 0.75))
    W = s * (t1 + fma(s, t2, -v * t3))
    c = 1.0 - W
    b = fma(-0.5, W, 1.0)
    return math.sqrt(fma(c * c, A, fma(-2.0 * (c * b), P, (b * b) * V)))


@kernel
def _em_predict_taylor(A, P, V, r0, h, gm):
    """r1 of the explicit Taylor step with the jerk (roundoff="fast"): :func:`_em_predict`
    with W to first order, W = h**2/2 GM / r0**3 (1 + 3/2 P / A) for the ``a`` term and
    h**2/2 GM / r0**3 for the ``v0`` term, an error in r1 of O(h**4). At T/1000 it is
    accurate enough for the fast step's looser check (error below 5e-7 r1 on the paper's
    orbit), with 22 operations per point fewer than :func:`_em_predict`."""
    ir = 1.0 / r0
    ir2 = ir * ir
    f = gm * ir2 * ir
    hf = 0.5 * h
    alpha = ((h * hf) * f) * (1.0 + 1.5 * P * ir2)
    b = 1.0 - hf * (hf * f)
    c = 1.0 - alpha
    return math.sqrt((c * c) * A - 2.0 * (c * b) * P + (b * b) * V)


@_inline
def _em_f2_terms(A, P, V, rho, Q, tau0, tlo):
    """:func:`_em_f2` and what its error bound needs: (F Q**2, rho**2 rounded, D, Q**2)."""
    p, e = two_prod(rho, rho)
    D = (((p - A) + (P + P)) - V) + e
    X = Q * ((p + A) - P)
    Q2 = Q * Q
    return Q2 * D + (((tau0 + tau0) * X + (tlo + tlo) * X) + (tau0 * tau0) * (p - A)), p, D, Q2


@_inline
def _em_newton_certified(A, P, V, r0, rho, tau0, tlo):
    """A Newton update of r1 on the plainly evaluated F, and whether its result is certified
    to be the exact root correctly rounded: (r1_new, delta, certified).

    The exact root lies within ``E / 2`` of the real number ``rho - delta``, so between
    ``rho - b`` and ``rho - a`` with the doubles ``a = fl(delta - E)``, ``b = fl(delta + E)``
    (their roundings, below ``u (|delta| + E)``, fit in the other half of ``E``, which is at
    least ``128 u |delta|``). Rounding is monotonic: where ``fl(rho - a) == fl(rho - b)``,
    every real number between rounds to that double, the root and ``rho - delta``
    included, so ``r1_new = fl(rho - delta)`` is then the exact root correctly rounded,
    the double the accurate update (:func:`_em_newton_accurate`) lands on, at about a third
    of its extra operations. ``E`` adds up, each taken at least twice:

    * F's rounding, ``B |Q / (F' Q**3)|`` with ``B`` twice a first-order bound (unit
      roundoff u = 2**-53) on the error of ``F Q**2`` as :func:`_em_f2` evaluates it:
      ``2 u (Q**2 (12 |D| + V) + tau0 (24 Q + 5 tau0) (rho**2 + A + |P|) + |F Q**2|)``. Term
      by term: ``rho**2 - A`` is exact (Sterbenz: certified only where ``A/2 <= rho**2 <=
      2 A``), D's two further sums err by u of results below ``|D| + V``, D itself by u;
      ``Q`` carries 3 roundings, so ``Q**2 D`` 8 u of itself; ``Y = rho**2 + A - P`` errs by
      u of ``rho**2 + A`` and of itself and by the low part of rho**2 it omits, ``X = Q Y``
      by 4 u more, ``2 tau0 X`` and the sums after it by 14 u of ``tau0 |X|`` in all;
      ``tau0**2 (rho**2 - A)``, with the dropped ``2 tau0 tlo`` and low part of rho**2, 5 u of
      ``tau0**2 (rho**2 + A)``; the last sum u of ``|F Q**2|``.
    * the derivative's rounding (relative, below 20 u for t <= 1/8): 64 u of ``|delta|``;
    * Newton's remainder ``F'' / (2 F') delta**2`` with ``F'' <= 3`` and ``1 / F' = |Q**2 Q / (F' Q**3)|``:
      ``4 delta**2 Q**2 |Q / (F' Q**3)|`` (no division).

    ``E`` is about 25 t of a unit in the last place plus the remainder, so most steps at
    small t are certified (tests/test_ensemble.py::test_certified_update_is_the_accurate_root
    counts them); the others take the accurate update in the scalar pass. Steps with
    t > 1/128 are finished by :func:`~.reference.em_finish` whatever this returns."""
    g3, Q = _em_g3(A, P, r0, rho, tau0)
    f2, p, D, Q2 = _em_f2_terms(A, P, V, rho, Q, tau0, tlo)
    qg = Q / g3
    delta = f2 * qg
    B = fma(Q2, fma(12.0, abs(D), V), tau0 * fma(24.0, Q, 5.0 * tau0) * ((p + A) + abs(P))) + abs(f2)
    E = fma(2.0 * abs(qg), fma(2.0 * _U, B, 4.0 * ((delta * delta) * Q2)), (128.0 * _U) * abs(delta))
    return rho - delta, delta, ((rho - (delta - E)) == (rho - (delta + E))) & (p <= A + A) & (A <= p + p)


@kernel
def _em_f2(A, P, V, rho, Q, tau0, tlo):
    """F Q**2 at r1 = rho, for Q = r0 rho (r0 + rho) (A = a.a, P = h a.v0, V = h**2 v0.v0 as
    :func:`_em_dots` rounds them; tau = tau0 + tlo)::

        F Q**2 = (rho Qp)**2 - (Qm (A Qm - 2 P Q) + V Q**2)        (Qp, Qm = Q +- tau)
               = Q**2 D + 2 tau Q (rho**2 + A - P) + tau**2 (rho**2 - A),
        D = rho**2 - A + 2 P - V = rho**2 - |a - h v0|**2

    The second form keeps the cancellation in D, which is evaluated to within a rounding of
    D (rho**2 - A is exact once rho**2 is split); the first loses a rounding of (rho Qp)**2 to
    it, an error Newton converges on (the energy then drifts: docs/methods.md)."""
    return _em_f2_terms(A, P, V, rho, Q, tau0, tlo)[0]


@_inline
def _em_f2_accurate(A, P, V, r0, rho, tau0, tlo):
    """F Q**2 at r1 = rho as :func:`_em_f2`, with every rounding of a quantity that depends
    on rho carried (error-free transformations) to well below eps r1**2 Q**2: Q, rho**2, D,
    Q**2 D, Q (rho**2 + A - P) and the products with tau. (A, P and V, which do not depend on
    rho, keep the roundings of :func:`_em_dots`: an error of the data, the same whatever rho
    the iteration tries, so nothing it can converge on. tau**2 (rho**2 - A) is O(t**2) of the
    rest.)"""
    q, eq = two_prod(r0, rho)
    s, es = two_sum(r0, rho)
    Q, eQ = two_prod(q, s)
    Ql = eQ + (q * es + eq * s)
    Q2, eQ2 = two_prod(Q, Q)
    Q2l = eQ2 + 2.0 * (Q * Ql)
    p, e = two_prod(rho, rho)
    D1 = p - A  # exact near the root
    D2, eD2 = two_sum(D1, P + P)
    D3, eD3 = two_sum(D2, -V)
    Dl = (eD2 + eD3) + e
    T1, eT1 = two_prod(Q2, D3)
    T1l = eT1 + (Q2 * Dl + Q2l * D3)
    Y1, eY1 = two_sum(p, A)
    Y2, eY2 = two_sum(Y1, -P)
    Yl = (eY1 + eY2) + e
    X, eX = two_prod(Q, Y2)
    Xl = eX + (Q * Yl + Ql * Y2)
    T2, eT2 = two_prod(tau0 + tau0, X)
    T2l = eT2 + ((tau0 + tau0) * Xl + (tlo + tlo) * X)
    F, eF = two_sum(T1, T2)
    return F + ((eF + (T1l + T2l)) + (tau0 * tau0) * D1)


@_inline
def _em_g3(A, P, r0, rho, tau0):
    """F' Q**3 at r1 = rho, and Q = r0 rho (r0 + rho), in plain floating point:
    F' Q**3 = 2 rho Qp**2 Q - 2 tau0 r0 (r0 + 2 rho) (rho**2 Qp + A Qm - P Q)."""
    s = r0 + rho
    Q = r0 * rho * s
    Qp = Q + tau0
    rq = rho * Qp
    g = fma(-(tau0 * r0) * (s + rho), fma(rho, rq, fma(A, Q - tau0, -P * Q)), rq * Qp * Q)
    return g + g, Q


@kernel
def _em_fg(A, P, V, r0, rho, tau0, tlo):
    """F Q**2 (:func:`_em_f2`) and F' Q**3 (:func:`_em_g3`) at r1 = rho, and Q."""
    g3, Q = _em_g3(A, P, r0, rho, tau0)
    return _em_f2(A, P, V, rho, Q, tau0, tlo), g3, Q


@kernel
def _em_newton(A, P, V, r0, rho, tau0, tlo):
    """A Newton update of r1: (r1_new, delta, Q / (F' Q**3))."""
    f2, g3, Q = _em_fg(A, P, V, r0, rho, tau0, tlo)
    qg = Q / g3
    delta = f2 * qg
    return rho - delta, delta, qg


@kernel
def _em_newton_accurate(A, P, V, r0, rho, tau0, tlo):
    """A Newton update of r1 on the accurate F (:func:`_em_f2_accurate`; the derivative
    in plain floating point, :func:`_em_g3`: its rounding changes the update by a few eps of
    itself): (r1_new, delta). Only the scalar pass takes it (the steps whose certified update
    is not certified), so it is one compiled function, not inlined in its two uses there
    (which would lengthen the first compile of an em run)."""
    g3, Q = _em_g3(A, P, r0, rho, tau0)
    delta = _em_f2_accurate(A, P, V, r0, rho, tau0, tlo) * (Q / g3)
    return rho - delta, delta


@kernel
def _em_chord(A, P, V, r0, rho, tau0, tlo, qg):
    """A chord update of r1 with the previous Newton update's derivative: (r1_new, delta).
    (F Q1**2 times Q0 / (F'(r1_0) Q0**3): Q1 taken for Q0, a relative 3 |delta1| / r1 of delta.)"""
    delta = _em_f2(A, P, V, rho, r0 * rho * (r0 + rho), tau0, tlo) * qg
    return rho - delta, delta


@kernel
def _em_small(d1, d2, rho):
    """Both updates below r1 / 64, so that the error estimates from them mean something."""
    return (abs(d1) <= _SMALL * rho) & (abs(d2) <= _SMALL * rho)


@kernel
def _em_plausible(rho, A, V):
    """Whether r1 = rho can be the step's: 0 < r1 and r1**2 <= 18 A + 2 V. (dx = (h v0 + 2 t a)
    / (1 + t) with t > 0, so |dx| <= |h v0| + 2 |a| and r1 = |a - dx| <= 3 r0 + sqrt(V).)
    Every such root of F Q**2 (Q > 0) is a root of F, a solution of the step's equations,
    which conserves the energy; far off or negative values are not (a NaN is neither)."""
    return (rho > 0.0) & (rho * rho <= 18.0 * A + 2.0 * V)


@kernel
def _em_ok(d1, d2, rho, A, V):
    return (abs(d1 * d2) <= _ACCEPT3 * (rho * rho)) & _em_small(d1, d2, rho) & _em_plausible(rho, A, V)


@kernel
def _em_ok_newton(d1, rho, A, V):
    """After a Newton update d1 on the accurate F (default em, packed and scalar pass):
    Newton leaves about |F''/(2 F')| d1**2 ~ d1**2 / (2 r1), so |d1| <= 2**-32.5 r1 leaves
    below 2**-66 r1, a ten-thousandth of a rounding. The root is then that of the accurate F,
    with no one-sided remainder of the iteration left in it."""
    return (d1 * d1 <= _ACCEPT_NEWTON * (rho * rho)) & _em_small(d1, d1, rho) & _em_plausible(rho, A, V)


@kernel
def _em_w(r0, rho, gm, tau0, tlo):
    """GM / (Q + tau) at r1 = rho (tau = tau0 + tlo = h**2/2 GM): g_em = w (2 a - h v0)."""
    Q = r0 * rho * (r0 + rho)
    return gm / ((Q + tau0) + tlo)


@kernel
def _increments(ax, ay, az, vx, vy, vz, w, ua, uv, h):
    """g = w (ua a - uv v0), then dx = h v0 + h (h/2 w) u and dv = (h w) u with u = ua a - uv v0:
    the reference kernel's form dx = h (v0 + h/2 g), dv = h g (no rounded h**2/2: the two
    coefficients are rounded afresh from each step's w). ``u`` and ``dx`` take one fused
    multiply-add each (one rounding instead of two)."""
    cx = h * ((0.5 * h) * w)
    cv = h * w
    ux = fma(ua, ax, -uv * vx)
    uy = fma(ua, ay, -uv * vy)
    uz = fma(ua, az, -uv * vz)
    return fma(cx, ux, h * vx), fma(cx, uy, h * vy), fma(cx, uz, h * vz), cv * ux, cv * uy, cv * uz


@kernel
def _em_big_t(w, gm, tau0):
    """Whether a step's t = tau / Q exceeds 1/128 (w = GM / (Q + tau))."""
    return tau0 * w > _BIG_T * gm


@kernel
def _em_finished(ax, ay, az, vx, vy, vz, w, r0, h, gm):
    """An em step with a large t: the increments from w, finished as the reference kernel
    finishes (:func:`~.reference.em_finish`)."""
    d0, d1, d2, w0, w1, w2 = _increments(ax, ay, az, vx, vy, vz, w, 2.0, h, h)
    d0, d1, d2, g0, g1, g2 = em_finish(ax, ay, az, r0, vx, vy, vz, d0, d1, d2, h, gm)
    return d0, d1, d2, h * g0, h * g1, h * g2


@kernel
def _mid_start(ax, ay, az, vx, vy, vz, h):
    """Midpoint: |a - h/2 v0|, the starting value of |m|."""
    hf = 0.5 * h
    mx = ax - hf * vx
    my = ay - hf * vy
    mz = az - hf * vz
    return math.sqrt(mx * mx + my * my + mz * mz)


@kernel
def _mid_newton(m0, mu, tau0):
    """A Newton update of mu = |m| on mu**3 - m0 mu**2 + tau0 / 2 = 0: (mu_new, delta)."""
    g = mu * mu * (mu - m0) + 0.5 * tau0
    d = mu * (3.0 * mu - 2.0 * m0)
    delta = g / d
    return mu - delta, delta


@kernel
def _mid_ok(delta, mu):
    return (delta * delta <= _ACCEPT2 * (mu * mu)) & (mu > 0.0) & (mu < math.inf)


@kernel
def _mid_w(mu, gm, tau0, tlo):
    """GM / (mu**3 + tau / 2) at |m| = mu: g = w (a - h/2 v0)."""
    return gm / ((mu * mu * mu + 0.5 * tau0) + 0.5 * tlo)
