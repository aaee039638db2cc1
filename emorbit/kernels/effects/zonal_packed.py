"""The em step of test particles under the central field plus zonal harmonics, as packed loops.

Without mutual gravity every point moves on its own, so the points run as the central-only
kernels run them (:mod:`emorbit.kernels.pointmass.packed`): blocks of :data:`BLOCK` in a work
array ``W`` (rows of :data:`LD` at constant offsets, as :mod:`emorbit.kernels.pointmass.block`),
each sub-step five short branch-free loops that LLVM vectorises (:func:`_pass`; one square
root and one division at most in each chain of dependencies, so that the core overlaps many
points) from one of two state buffers into the other, and a scalar pass for the rest
(:func:`_resolve`). The helpers are compiled once each and inlined by LLVM (``forceinline``:
Numba's own inlining of them took most of a compile). Arguments and records are those
of the effect step (:func:`emorbit.kernels.pointmass.effect_step.effect_chunk`), whose equations
and discrete force this solves. Method, per point (``d = x - c``, ``p`` the pole, sub-step
``h``), for ``omega = v1 - v0`` (the effect step's ``w`` is ``h omega / 2``)::

    x1 - x0 = h v0 + h/2 omega,   R(omega) = omega - h F(x0, x1) = 0
    F = -((K + a) (d0 + d1) + k B p),   K = GM / (r0 r1 (r0 + r1)),   a = k A / (r0 + r1)

with the central g_em (:mod:`.central`) and the zonal averaged discrete partials ``A``, ``B``
(:func:`.zonal.zonal_sums`, the force of :func:`.zonal.zonal_force`, ``k = GM / R^2``), which
keep the energy and the angular momentum about the pole exactly; ``h`` and ``h/2`` scale
exactly (a rounded ``h^2/2`` or ``2/h`` would change the energy by eps (h F)^2 of one sign
each step). Newton's matrix is a multiple of the identity less a rank-2 term, solved in closed
form (:func:`_newton`). From a predictor accurate to O(h^4) (:func:`_predict`: up to 5e-8 of
the increment at T/1000 in low Earth orbit), one update leaves Newton's remainder ``kappa
|delta x|^2``, ``kappa = 8 h^2/2 (K + a) / r1``, of one sign in every step; a step is accepted
where the update is below 2**-20 of the increment and the remainder below 1e-3 eps of it: the
effect step's rule (stopping at eps itself made the energy drift), the next update estimated
from the curvature instead of measured. Where a quarter of a block is pending, it takes a
second packed update; the scalar pass stops by the effect step's rule and fails after
``max_iter`` updates. Kahan-compensated updates; a failing point stops before its failing
composed step, the others go on (as :class:`~emorbit.bodies.pointmasses.PointMasses`).

Variants, a kernel each: J2 alone (:func:`_sums_2`) or J2..J6 (the coefficients above the
model's zero), the pole (0, 0, 1) (dot products with p are z components) or any. Data layout:
x, v, cx, cv, wp (3, n) float64 (wp: the last sub-step's w, written at a chunk's end);
``central_p`` = [c0, c1, c2, GM], ``zonal_p`` = [c0, c1, c2, p0, p1, p2, GM, R], ``zonal_j`` =
[J2, ..., J_degree]. References: M. Goettlicher, K. Schweizerhof (g_em); T. Itoh, K. Abe,
J. Comput. Phys. 76 (1988) 85-102; W. Kahan, Comm. ACM 8 (1965) 40; M. A. Woodbury (1950).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from ..codes import STATUS_NO_CONVERGENCE, STATUS_SINGULAR
from ..eft import fma
from ..jit import kernel
from .zonal import NMAX, zonal_sums_unrolled

__all__ = ["BLOCK", "LD", "PARALLEL_MIN", "chunk", "variant"]

_inline = kernel(inline="always")
_force = kernel(forceinline=True)

#: points per block
BLOCK = 64
#: row length of the work array (see :mod:`emorbit.kernels.pointmass.block`)
LD = BLOCK + 8
#: from this many points on, :func:`chunk` runs the blocks on all of Numba's threads
PARALLEL_MIN = 1024

# rows of the work array: two state buffers (a sub-step reads one and writes the other)
_NS = 12  # rows of a state buffer: x, v, cx, cv
_OX0, _OX1, _OX2 = 0 * LD, 1 * LD, 2 * LD
_OV0, _OV1, _OV2 = 3 * LD, 4 * LD, 5 * LD
_OCX0, _OCX1, _OCX2 = 6 * LD, 7 * LD, 8 * LD
_OCV0, _OCV1, _OCV2 = 9 * LD, 10 * LD, 11 * LD
_BUF1 = 12 * LD  # the second state buffer (the first at 0)
_BK = 24 * LD  # the state at the start of a composed step (orders 4-8)
_OM0, _OM1, _OM2 = 36 * LD, 37 * LD, 38 * LD  # omega: predicted, then after a packed update
_B0, _B1, _B2 = 39 * LD, 40 * LD, 41 * LD  # d1 = x1 - c
_R0 = 42 * LD  # r0 = |x0 - c|
_IR0 = 43 * LD  # 1 / r0
_ZD0 = 44 * LD  # (x0 - c) . p
_R1 = 45 * LD  # r1 = |d1|
_IQ = 46 * LD  # 1 / (r0 r1 (r0 + r1))
_AL, _KB = 47 * LD, 48 * LD  # h (K + a), h k B
_HBE, _HGA, _HDE, _HEP = 49 * LD, 50 * LD, 51 * LD, 52 * LD  # h^2/2 (beta, gamma, delta, epsilon)
_KAP = 53 * LD  # kappa (h/2)^2: Newton's remainder in x over |delta omega|^2
_ZD1 = 54 * LD  # d1 . p
_UPD = 55 * LD  # |delta omega|^2 of the last packed update
_GO = 56 * LD  # 1 where a point is pending after a packed update
_ALIVE = 57 * LD  # 1 until the point fails
_ST = 58 * LD  # failure code in the current composed step
_EXTRA = 59 * LD  # updates beyond the first, in the current record interval
_NROWS = 60

_EPS = 2.0**-52
#: accept where |delta x| <= 2**-20 |dx| (so far below r1 that Newton's remainder is the
#: quadratic term; the predictor leaves up to 5e-8 |dx| at T/1000) ...
_SMALL2 = 2.0**-40
#: ... and the estimated next update kappa |delta x|^2 <= 1e-3 eps |dx|
_NEXT = 1e-3 * _EPS
#: Newton's remainder: kappa = _CURVE h^2/2 (K + a) / r1
_CURVE = 8.0


@_force
def _dotp(a0, a1, a2, p0, p1, p2, polez):
    """a . p, the pole p; ``polez`` (a constant once inlined): p = (0, 0, 1), a's z component."""
    if polez:
        return a2
    return fma(a0, p0, fma(a1, p1, a2 * p2))


@_force
def _addp(a0, a1, a2, s, p0, p1, p2, polez):
    """a + s p (see :func:`_dotp`)."""
    if polez:
        return a0, a1, a2 + s
    return fma(s, p0, a0), fma(s, p1, a1), fma(s, p2, a2)


# the zonal sums of each variant: functions of their own, the degree a constant in each, so
# that LLVM unrolls their loops (as it optimises that function) before it inlines them
# (forceinline: LLVM's alwaysinline) into the loops over points, which then vectorise


@_force
def _sums_2(pa, q1, z0, z1, js):
    """:func:`.zonal.zonal_sums` of J2 alone, its sums written out (the same terms, in fewer
    operations). ``pa`` = (a, a^2, a^3, a^4), ``a = q0``; with ``b = q1``, ``c3 = -J2/2``,
    ``c5 = 3 J2/2`` (J2 P2(s) = c3 + c5 s^2), ``S_m = sum_{i<m} a^(i+1) b^(m-i)`` and ``T_m =
    sum_{i<m} (m-i) a^(i+1) b^(m-i)`` by Horner's rule in b, ``g = (c5 / 2) (z0^2 + z1^2)`` and
    ``f = (a^5 + b^5) / 2``::

        A = -(c3 S3 + g S5),  B = f c5 (z0 + z1),  dA/drho1 = b (c3 T3 + g T5),
        dA/dzeta1 = -c5 z1 S5,  dB/drho1 = -5/2 b^6 c5 (z0 + z1),  dB/dzeta1 = f c5
    """
    a, a2, a3, a4 = pa
    c3 = -0.5 * js[0]
    c5 = 1.5 * js[0]
    b = q1
    ab = a * b
    b2 = b * b
    S3 = ab * fma(b, b + a, a2)
    T3 = ab * fma(fma(3.0, b, a + a), b, a2)
    S5 = ab * fma(fma(fma(b + a, b, a2), b, a3), b, a4)
    T5 = ab * fma(fma(fma(fma(5.0, b, 4.0 * a), b, 3.0 * a2), b, a3 + a3), b, a4)
    b5 = (b2 * b2) * b
    f = 0.5 * fma(a4, a, b5)
    g = (0.5 * c5) * fma(z0, z0, z1 * z1)
    cz = c5 * (z0 + z1)
    return -fma(c3, S3, g * S5), f * cz, b * fma(c3, T3, g * T5), -(c5 * z1) * S5, (-2.5 * (b5 * b)) * cz, f * c5


@_force
def _grad_2(pa, z, js):
    """(A, B) of :func:`_sums_2` at equal ends: ``S3 = 3 a^4``, ``S5 = 5 a^6``, so
    ``A = -a^4 (3 c3 + 5 c5 z^2 a^2)`` and ``B = 2 c5 z a^5``."""
    a, a2, a3, a4 = pa
    return -a4 * fma((7.5 * js[0]) * (z * z), a2, -1.5 * js[0]), ((3.0 * js[0]) * z) * (a4 * a)


@_force
def _sums_6(pa, q1, z0, z1, js):
    """:func:`.zonal.zonal_sums` of degree 6 (J above the model's degree zero: the same sums)."""
    return zonal_sums_unrolled(pa[0], q1, z0, z1, NMAX, js[0], js[1], js[2], js[3], js[4], True)


@_force
def _grad_6(pa, z, js):
    """(A, B) of :func:`_sums_6` at equal ends."""
    return zonal_sums_unrolled(pa[0], pa[0], z, z, NMAX, js[0], js[1], js[2], js[3], js[4], False)[:2]


@_force
def _predict(d0, d1, d2, v0, v1, v2, ir0, zd0, cst, step, nmax, polez, js):
    """The predictor of omega: the central em step as a series in h, plus h times the zonal
    gradient at x0.

    With ``s = h^2/2 GM / r0^3``, ``p = -h d0 . v0 / r0^2`` and ``v = h^2 v0 . v0 / r0^2``
    the central em step is ``w = -W d0 - (h W / 2) v0``, ``W = s (1 + 3/2 p + 5/2 p^2 + s -
    3/4 v)`` to second order in those (the leading terms of
    :func:`emorbit.kernels.pointmass.roots._em_predict`'s series; the rest is below the zonal
    part's error), and ``omega = 2 w / h``. The zonal force at ``x1 = x0`` is the gradient,
    ``-(k A d0 / r0 + k B p)`` (:func:`.zonal.zonal_sums` at equal ends). ``cst``, ``step``,
    ``js``: see :func:`_run_block`. Returns omega (3 components)."""
    h, hq, hgm, h2, hk = step[0], step[1], step[3], step[4], step[5]
    ir2 = ir0 * ir0
    sp = hgm * (ir2 * ir0)  # 2 s / h
    p = (-h * ir2) * fma(d0, v0, fma(d1, v1, d2 * v2))
    v = (h2 * ir2) * fma(v0, v0, fma(v1, v1, v2 * v2))
    Wn = sp * (fma(0.75, v, fma(p, fma(p, -2.5, -1.5), -1.0)) - hq * sp)  # -2 W / h
    a = cst[7] * ir0
    a2 = a * a
    pa = (a, a2, a2 * a, a2 * a2)
    z0 = zd0 * cst[8]
    A, B = _grad_2(pa, z0, js) if nmax == 2 else _grad_6(pa, z0, js)
    cd = fma(-(hk * A), ir0, Wn)
    cv = hq * Wn
    return _addp(
        fma(cd, d0, cv * v0), fma(cd, d1, cv * v1), fma(cd, d2, cv * v2), -(hk * B), cst[3], cst[4], cst[5], polez
    )


@_force
def _reach(x0, x1, x2, v0, v1, v2, m0, m1, m2, o0, o1, o2, r0, h, hq):
    """The end of the step for omega: ``d1 = x0 + (h v0 + h/2 omega) - c``, ``r1 = |d1|`` and
    ``1 / Q``, ``Q = r0 r1 (r0 + r1)``: (d1 (3), r1, 1/Q)."""
    b0 = (x0 + fma(hq, m0, h * v0)) - o0
    b1 = (x1 + fma(hq, m1, h * v1)) - o1
    b2 = (x2 + fma(hq, m2, h * v2)) - o2
    r1 = math.sqrt(fma(b0, b0, fma(b1, b1, b2 * b2)))
    return b0, b1, b2, r1, 1.0 / ((r0 * r1) * (r0 + r1))


@_force
def _coefficients(b0, b1, b2, r0, r1, iQ, ir0, zd0, cst, step, nmax, polez, js):
    """The force's scalars over the step, times h, and h^2/2 times its derivative's (see
    :func:`_newton`): (h (K + a), h k B, h^2/2 (beta, gamma, delta, epsilon), kappa (h/2)^2,
    d1 . p)."""
    rad, irad, gm, k, kd = cst[7], cst[8], cst[9], cst[10], cst[11]
    h, hh, hk, nhhkd, chh = step[0], step[2], step[5], step[6], step[7]
    K = gm * iQ
    ir1 = (r0 * (r0 + r1)) * iQ
    isr = (r0 * r1) * iQ
    zd1 = _dotp(b0, b1, b2, cst[3], cst[4], cst[5], polez)
    a = rad * ir0
    a2 = a * a
    pa = (a, a2, a2 * a, a2 * a2)
    if nmax == 2:
        A, B, dAr, dAz, dBr, dBz = _sums_2(pa, rad * ir1, zd0 * irad, zd1 * irad, js)
    else:
        A, B, dAr, dAz, dBr, dBz = _sums_6(pa, rad * ir1, zd0 * irad, zd1 * irad, js)
    ai = (k * A) * isr
    hal = h * (K + ai)
    be = fma((K * ir1), (ir1 + isr), (ai - kd * dAr) * (ir1 * isr))
    return hal, hk * B, hh * be, (nhhkd * dAz) * isr, (nhhkd * dBr) * ir1, nhhkd * dBz, chh * (hal * ir1), zd1


@_force
def _solve(x0, x1, x2, m0, m1, m2, b0, b1, b2, zd0, zd1, hal, hkB, hbe, hga, hde, hep, cst, hq, polez):
    """The residual ``R = omega + h ((K + a) u + k B p)`` and the update ``M^-1 R`` (Woodbury,
    see :func:`_newton`): (omega - M^-1 R (3), |M^-1 R|^2)."""
    p0, p1, p2 = cst[3], cst[4], cst[5]
    pp = 1.0 if polez else cst[6]
    u0 = (x0 - cst[0]) + b0
    u1 = (x1 - cst[1]) + b1
    u2 = (x2 - cst[2]) + b2
    R0, R1, R2 = _addp(fma(hal, u0, m0), fma(hal, u1, m1), fma(hal, u2, m2), hkB, p0, p1, p2, polez)
    mu = fma(hq, hal, 1.0)
    bR = fma(b0, R0, fma(b1, R1, b2 * R2))
    pR = _dotp(R0, R1, R2, p0, p1, p2, polez)
    bu = fma(b0, u0, fma(b1, u1, b2 * u2))
    pu = zd0 + zd1
    s00 = mu - fma(hbe, bu, hga * pu)  # S = [[s00, -t01], [-t10, s11]]
    t01 = fma(hbe, zd1, hga * pp)
    t10 = fma(hde, bu, hep * pu)
    s11 = mu - fma(hde, zd1, hep * pp)
    c0 = fma(hbe, bR, hga * pR)
    c1 = fma(hde, bR, hep * pR)
    det = fma(s00, s11, -(t01 * t10))
    y0 = fma(s11, c0, t01 * c1)
    y1 = fma(s00, c1, t10 * c0)
    inv = 1.0 / (mu * det)
    D0, D1, D2 = _addp(fma(det, R0, u0 * y0), fma(det, R1, u1 * y0), fma(det, R2, u2 * y0), y1, p0, p1, p2, polez)
    D0 *= inv
    D1 *= inv
    D2 *= inv
    return m0 - D0, m1 - D1, m2 - D2, fma(D0, D0, fma(D1, D1, D2 * D2))


@_force
def _newton(x0, x1, x2, v0, v1, v2, m0, m1, m2, r0, ir0, zd0, cst, step, nmax, polez, js):
    """One Newton update of omega from the residual ``R = omega - h F(x0, x1)``,
    ``x1 = x0 + h v0 + h/2 omega``.

    ``F = -((K + a) u + k B p)``, ``u = d0 + d1``, ``K = GM / Q``, ``Q = r0 r1 (r0 + r1)``,
    ``a = k A / (r0 + r1)`` (``A``, ``B`` of :func:`.zonal.zonal_sums`). The derivative
    (:func:`.central.central_jacobian` plus :func:`.zonal.zonal_jacobian`)::

        dF/dx1 = -(K + a) I + u (beta d1 + gamma p)^T + p (delta d1 + epsilon p)^T
        beta = K (1/r1 + 1/(r0 + r1)) / r1 - (k dA/drho1 / R - a) / (r1 (r0 + r1))
        gamma = -k dA/dzeta1 / (R (r0 + r1)),  delta = -k dB/drho1 / (R r1),  epsilon = -k dB/dzeta1 / R

    so ``M = dR/domega = I - h^2/2 dF/dx1 = mu I - U V^T``, ``U = [u, p]``, ``V = h^2/2 [beta
    d1 + gamma p, delta d1 + epsilon p]``, ``mu = 1 + h^2/2 (K + a)``, and (Woodbury)
    ``M^-1 R = (R + U S^-1 V^T R) / mu``, ``S = mu I - V^T U`` (2 x 2): one division, for
    ``1 / (mu det S)``. The operations of the packed passes (:func:`_reach`,
    :func:`_coefficients`, :func:`_solve`), so an update has the same bits in either. Returns
    the new omega (3), ``|delta omega|^2`` and ``kappa (h/2)^2`` (Newton's remainder in x
    over ``|delta omega|^2``, see the module)."""
    b0, b1, b2, r1, iQ = _reach(x0, x1, x2, v0, v1, v2, m0, m1, m2, cst[0], cst[1], cst[2], r0, step[0], step[1])
    hal, hkB, hbe, hga, hde, hep, kap, zd1 = _coefficients(b0, b1, b2, r0, r1, iQ, ir0, zd0, cst, step, nmax, polez, js)
    n0, n1, n2, upd2 = _solve(
        x0, x1, x2, m0, m1, m2, b0, b1, b2, zd0, zd1, hal, hkB, hbe, hga, hde, hep, cst, step[1], polez
    )
    return n0, n1, n2, upd2, kap


@_force
def _kahan(x, c, d):
    """x + d with the compensation c: (new x, new c)."""
    y = d + c
    t = x + y
    return t, y - (t - x)


# ----------------------------------------------------------------------------------------
# the passes of a sub-step over a block


@_force
def _pass_start(W, m, o0, o1, o2, S):
    """r0 = |x0 - c| and 1 / r0 (the state in buffer ``S``)."""
    for i in range(m):
        d0 = W[S + _OX0 + i] - o0
        d1 = W[S + _OX1 + i] - o1
        d2 = W[S + _OX2 + i] - o2
        r0 = math.sqrt(fma(d0, d0, fma(d1, d1, d2 * d2)))
        W[_R0 + i] = r0
        W[_IR0 + i] = 1.0 / r0


@_force
def _pass_predict(W, m, cst, step, nmax, polez, js, S):
    """The predictor (:func:`_predict`) into the rows of omega; d0 . p into ``_ZD0``."""
    o0, o1, o2, p0, p1, p2 = cst[0], cst[1], cst[2], cst[3], cst[4], cst[5]
    for i in range(m):
        d0 = W[S + _OX0 + i] - o0
        d1 = W[S + _OX1 + i] - o1
        d2 = W[S + _OX2 + i] - o2
        zd0 = _dotp(d0, d1, d2, p0, p1, p2, polez)
        m0, m1, m2 = _predict(
            d0, d1, d2, W[S + _OV0 + i], W[S + _OV1 + i], W[S + _OV2 + i], W[_IR0 + i], zd0, cst, step, nmax, polez, js
        )
        W[_OM0 + i] = m0
        W[_OM1 + i] = m1
        W[_OM2 + i] = m2
        W[_ZD0 + i] = zd0


@_force
def _pass_reach(W, m, o0, o1, o2, h, hq, S):
    """d1, r1 and 1 / Q at the end of the step for the current omega (:func:`_reach`)."""
    for i in range(m):
        b0, b1, b2, r1, iQ = _reach(
            W[S + _OX0 + i], W[S + _OX1 + i], W[S + _OX2 + i], W[S + _OV0 + i], W[S + _OV1 + i], W[S + _OV2 + i],
            W[_OM0 + i], W[_OM1 + i], W[_OM2 + i], o0, o1, o2, W[_R0 + i], h, hq,
        )  # fmt: skip
        W[_B0 + i] = b0
        W[_B1 + i] = b1
        W[_B2 + i] = b2
        W[_R1 + i] = r1
        W[_IQ + i] = iQ


@_force
def _pass_coefficients(W, m, cst, step, nmax, polez, js):
    """The force's and its derivative's scalars (:func:`_coefficients`) into their rows."""
    for i in range(m):
        hal, hkB, hbe, hga, hde, hep, kap, zd1 = _coefficients(
            W[_B0 + i], W[_B1 + i], W[_B2 + i], W[_R0 + i], W[_R1 + i], W[_IQ + i], W[_IR0 + i], W[_ZD0 + i],
            cst, step, nmax, polez, js,
        )  # fmt: skip
        W[_AL + i] = hal
        W[_KB + i] = hkB
        W[_HBE + i] = hbe
        W[_HGA + i] = hga
        W[_HDE + i] = hde
        W[_HEP + i] = hep
        W[_KAP + i] = kap
        W[_ZD1 + i] = zd1


@_force
def _pass_solve(W, m, cst, step, polez, mask, S, D):
    """The Newton update (:func:`_solve`) of the points that are to be updated (1 in the row
    ``mask``: ``_ALIVE`` in the first update, ``_GO`` in the second), the acceptance test and
    the compensated update of the state in buffer ``S`` into ``D``: every point's new state,
    unconditionally, in the first update (the caller puts back the old state of the dead
    points, the scalar pass finishes the pending ones); in the second only that of the points
    to be updated. The pending points get 1 in ``_GO``, their new omega and |delta omega|^2
    in the rows ``_OM*`` and ``_UPD``. Returns their count."""
    h, hq, sm = step[0], step[1], step[8]
    npend = 0
    for i in range(m):
        x0 = W[S + _OX0 + i]
        x1 = W[S + _OX1 + i]
        x2 = W[S + _OX2 + i]
        v0 = W[S + _OV0 + i]
        v1 = W[S + _OV1 + i]
        v2 = W[S + _OV2 + i]
        n0, n1, n2, upd2 = _solve(
            x0, x1, x2, W[_OM0 + i], W[_OM1 + i], W[_OM2 + i], W[_B0 + i], W[_B1 + i], W[_B2 + i],
            W[_ZD0 + i], W[_ZD1 + i], W[_AL + i], W[_KB + i], W[_HBE + i], W[_HGA + i], W[_HDE + i], W[_HEP + i],
            cst, hq, polez,
        )  # fmt: skip
        e0 = fma(hq, n0, h * v0)
        e1 = fma(hq, n1, h * v1)
        e2 = fma(hq, n2, h * v2)
        size2 = fma(e0, e0, fma(e1, e1, e2 * e2))
        nxt = W[_KAP + i] * upd2
        ok = (upd2 <= sm * size2) & (nxt * nxt <= (_NEXT * _NEXT) * size2)
        go = W[mask + i] == 1.0
        t0, f0 = _kahan(x0, W[S + _OCX0 + i], e0)
        t1, f1 = _kahan(x1, W[S + _OCX1 + i], e1)
        t2, f2 = _kahan(x2, W[S + _OCX2 + i], e2)
        u0, g0 = _kahan(v0, W[S + _OCV0 + i], n0)
        u1, g1 = _kahan(v1, W[S + _OCV1 + i], n1)
        u2, g2 = _kahan(v2, W[S + _OCV2 + i], n2)
        if mask == _ALIVE:
            _store(W, D, i, t0, t1, t2, u0, u1, u2, f0, f1, f2, g0, g1, g2)
            W[_OM0 + i] = n0
            W[_OM1 + i] = n1
            W[_OM2 + i] = n2
        else:
            take = ok & go
            _store(
                W, D, i, t0 if take else W[D + _OX0 + i], t1 if take else W[D + _OX1 + i],
                t2 if take else W[D + _OX2 + i], u0 if take else W[D + _OV0 + i], u1 if take else W[D + _OV1 + i],
                u2 if take else W[D + _OV2 + i], f0 if take else W[D + _OCX0 + i], f1 if take else W[D + _OCX1 + i],
                f2 if take else W[D + _OCX2 + i], g0 if take else W[D + _OCV0 + i], g1 if take else W[D + _OCV1 + i],
                g2 if take else W[D + _OCV2 + i],
            )  # fmt: skip
            W[_OM0 + i] = n0 if go else W[_OM0 + i]
            W[_OM1 + i] = n1 if go else W[_OM1 + i]
            W[_OM2 + i] = n2 if go else W[_OM2 + i]
        W[_UPD + i] = upd2
        pend = go & ~ok
        W[_GO + i] = 1.0 if pend else 0.0
        npend += 1 if pend else 0
    return npend


@_force
def _store(W, D, i, t0, t1, t2, u0, u1, u2, f0, f1, f2, g0, g1, g2):
    """Point i's position, velocity and their compensations into buffer ``D``."""
    W[D + _OX0 + i] = t0
    W[D + _OX1 + i] = t1
    W[D + _OX2 + i] = t2
    W[D + _OV0 + i] = u0
    W[D + _OV1 + i] = u1
    W[D + _OV2 + i] = u2
    W[D + _OCX0 + i] = f0
    W[D + _OCX1 + i] = f1
    W[D + _OCX2 + i] = f2
    W[D + _OCV0 + i] = g0
    W[D + _OCV1 + i] = g1
    W[D + _OCV2 + i] = g2


@_force
def _copy_state(W, i, S, D):
    """Point i's state from buffer ``S`` into ``D``."""
    for j in range(_NS):
        W[D + j * LD + i] = W[S + j * LD + i]


@_inline
def _pass(W, m, cst, step, max_iter, nmax, polez, js, ndead, S, D):
    """One sub-step of every live point of the block from buffer ``S`` into ``D``:
    predictor, one Newton update, the acceptance test and the update of the accepted points,
    as five passes (see the module); where more than a quarter of the block is pending, a
    second packed update for those. The dead points (``ndead`` of them) keep their state.
    Returns the count of pending points and of the packed updates."""
    o0, o1, o2 = cst[0], cst[1], cst[2]
    _pass_start(W, m, o0, o1, o2, S)
    _pass_predict(W, m, cst, step, nmax, polez, js, S)
    _pass_reach(W, m, o0, o1, o2, step[0], step[1], S)
    _pass_coefficients(W, m, cst, step, nmax, polez, js)
    npend = _pass_solve(W, m, cst, step, polez, _ALIVE, S, D)
    if ndead:
        for i in range(m):
            if W[_ALIVE + i] != 1.0:
                _copy_state(W, i, S, D)
    if 4 * npend <= m or max_iter < 2:
        return npend, 1
    for i in range(m):
        W[_EXTRA + i] += W[_GO + i]
    _pass_reach(W, m, o0, o1, o2, step[0], step[1], S)
    _pass_coefficients(W, m, cst, step, nmax, polez, js)
    return _pass_solve(W, m, cst, step, polez, _GO, S, D), 2


@_force
def _resolve(W, m, cst, step, rounds, max_iter, nmax, polez, js, S, D):
    """The pending points one by one: Newton updates (:func:`_newton`) from the last packed
    one's omega until the effect step's rule accepts (see the module), then the compensated
    update from buffer ``S`` into ``D``. A point whose update is not finite fails as
    STATUS_SINGULAR, one that is not accepted after ``max_iter`` updates in all (``rounds``
    packed ones) as STATUS_NO_CONVERGENCE: its old state goes into ``D``, ``_ALIVE`` is
    cleared and ``_ST`` holds the code. Returns the count of failures."""
    h, hq = step[0], step[1]
    nfail = 0
    for i in range(m):
        if W[_GO + i] != 1.0:
            continue
        x0 = W[S + _OX0 + i]
        x1 = W[S + _OX1 + i]
        x2 = W[S + _OX2 + i]
        v0 = W[S + _OV0 + i]
        v1 = W[S + _OV1 + i]
        v2 = W[S + _OV2 + i]
        m0 = W[_OM0 + i]
        m1 = W[_OM1 + i]
        m2 = W[_OM2 + i]
        size = math.sqrt(fma(hq, m0, h * v0) ** 2 + fma(hq, m1, h * v1) ** 2 + fma(hq, m2, h * v2) ** 2)
        prev = hq * math.sqrt(W[_UPD + i]) / max(size, 1e-300)
        status = STATUS_SINGULAR if not prev < math.inf else STATUS_NO_CONVERGENCE
        it = rounds
        while status == STATUS_NO_CONVERGENCE and it < max_iter:
            m0, m1, m2, upd2, kap = _newton(
                x0, x1, x2, v0, v1, v2, m0, m1, m2, W[_R0 + i], W[_IR0 + i], W[_ZD0 + i], cst, step, nmax, polez, js
            )
            it += 1
            W[_EXTRA + i] += 1.0
            e0 = fma(hq, m0, h * v0)
            e1 = fma(hq, m1, h * v1)
            e2 = fma(hq, m2, h * v2)
            delta = math.sqrt(upd2)
            upd = hq * delta / max(math.sqrt(e0 * e0 + e1 * e1 + e2 * e2), 1e-300)
            if not upd < math.inf:
                status = STATUS_SINGULAR
            elif (
                upd <= 4.0 * _EPS
                or (upd <= 128.0 * _EPS and upd > 0.5 * prev)
                or (upd <= 1e-8 and upd * max(upd / prev, kap * delta / hq) <= _NEXT)
            ):
                status = 0
                W[D + _OX0 + i], W[D + _OCX0 + i] = _kahan(x0, W[S + _OCX0 + i], e0)
                W[D + _OX1 + i], W[D + _OCX1 + i] = _kahan(x1, W[S + _OCX1 + i], e1)
                W[D + _OX2 + i], W[D + _OCX2 + i] = _kahan(x2, W[S + _OCX2 + i], e2)
                W[D + _OV0 + i], W[D + _OCV0 + i] = _kahan(v0, W[S + _OCV0 + i], m0)
                W[D + _OV1 + i], W[D + _OCV1 + i] = _kahan(v1, W[S + _OCV1 + i], m1)
                W[D + _OV2 + i], W[D + _OCV2 + i] = _kahan(v2, W[S + _OCV2 + i], m2)
                W[_OM0 + i] = m0
                W[_OM1 + i] = m1
                W[_OM2 + i] = m2
            prev = upd
        if status != 0:
            _copy_state(W, i, S, D)
            W[_ALIVE + i] = 0.0
            W[_ST + i] = float(status)
            nfail += 1
    return nfail


@_force
def _constants(central_p, zonal_p, zonal_j):
    """The effects' constants: ``cst`` = (c0, c1, c2, p0, p1, p2, p . p, R, 1/R, GM, k =
    GM_zonal / R^2, k / R) and ``js`` = (J2, ..., J6), zeros above the degree."""
    p0, p1, p2, rad = zonal_p[3], zonal_p[4], zonal_p[5], zonal_p[7]
    k = zonal_p[6] / (rad * rad)
    pp = fma(p0, p0, fma(p1, p1, p2 * p2))
    cst = (central_p[0], central_p[1], central_p[2], p0, p1, p2, pp, rad, 1.0 / rad, central_p[3], k, k / rad)
    n = zonal_j.shape[0]
    js = (zonal_j[0], zonal_j[1] if n > 1 else 0.0, zonal_j[2] if n > 2 else 0.0, zonal_j[3] if n > 3 else 0.0)
    return cst, js + (zonal_j[4] if n > 4 else 0.0,)


@_force
def _step_constants(h, cst):
    """A sub-step's constants: (h, h/2, h^2/2, h GM, h^2, h k, -h^2/2 k / R, _CURVE h^2/2
    (h/2)^2 / h, _SMALL2 / (h/2)^2)."""
    hq = 0.5 * h
    hh = h * hq
    return (
        h,
        hq,
        hh,
        h * cst[9],
        h * h,
        h * cst[10],
        -hh * cst[11],
        (_CURVE * hh) * (hq * hq) / h,
        _SMALL2 / (hq * hq),
    )


@_inline
def _run_block(
    W, x, v, cx, cv, wp, central_p, zonal_p, zonal_j, dt, gammas, every, nrec, max_iter,
    rec_x, rec_v, rec_iters, fail, lo, hi, nmax, polez,
):  # fmt: skip
    """Every step of the chunk for the points lo..hi (at most :data:`BLOCK`) in the work
    array ``W``. Returns 1 if a point took a step, else 0."""
    m = hi - lo
    cst, js = _constants(central_p, zonal_p, zonal_j)
    for d in range(3):
        for i in range(m):
            W[_OX0 + d * LD + i] = x[d, lo + i]
            W[_OV0 + d * LD + i] = v[d, lo + i]
            W[_OCX0 + d * LD + i] = cx[d, lo + i]
            W[_OCV0 + d * LD + i] = cv[d, lo + i]
    for i in range(m):
        W[_ALIVE + i] = 1.0
        W[_ST + i] = 0.0
    ns = gammas.shape[0]
    cur = 0  # the buffer that holds the state
    ndead = 0
    for r in range(nrec):
        for i in range(m):
            W[_EXTRA + i] = 0.0
        for s in range(every):
            if ns > 1:  # a failing sub-step discards the whole composed step
                for j in range(_NS * LD):
                    W[_BK + j] = W[cur * _BUF1 + j]
            nfail = 0
            for kk in range(ns):
                step = _step_constants(dt * gammas[kk], cst)
                # the buffers as constants in each branch: LLVM then knows every row's offset
                if cur == 0:
                    npend, rounds = _pass(W, m, cst, step, max_iter, nmax, polez, js, ndead, 0, _BUF1)
                    if npend:
                        nfail += _resolve(W, m, cst, step, rounds, max_iter, nmax, polez, js, 0, _BUF1)
                else:
                    npend, rounds = _pass(W, m, cst, step, max_iter, nmax, polez, js, ndead, _BUF1, 0)
                    if npend:
                        nfail += _resolve(W, m, cst, step, rounds, max_iter, nmax, polez, js, _BUF1, 0)
                ndead += nfail
                nfail = 0
                cur = 1 - cur
            if ndead:
                for i in range(m):
                    if W[_ST + i] != 0.0:
                        fail[lo + i, 0] = r * every + s
                        fail[lo + i, 1] = int(W[_ST + i])
                        W[_ST + i] = 0.0
                        if ns > 1:
                            _copy_state(W, i, _BK, cur * _BUF1)
        for d in range(3):
            for i in range(m):
                rec_x[r, d, lo + i] = W[cur * _BUF1 + _OX0 + d * LD + i]
                rec_v[r, d, lo + i] = W[cur * _BUF1 + _OV0 + d * LD + i]
        for i in range(m):
            rec_iters[r, lo + i] = every * ns + int(W[_EXTRA + i])
    hq = 0.5 * dt * gammas[ns - 1]
    took = 0
    for i in range(m):
        for d in range(3):
            x[d, lo + i] = W[cur * _BUF1 + _OX0 + d * LD + i]
            v[d, lo + i] = W[cur * _BUF1 + _OV0 + d * LD + i]
            cx[d, lo + i] = W[cur * _BUF1 + _OCX0 + d * LD + i]
            cv[d, lo + i] = W[cur * _BUF1 + _OCV0 + d * LD + i]
            if W[_ALIVE + i] == 1.0 and nrec * every > 0:  # the last sub-step's w
                wp[d, lo + i] = hq * W[_OM0 + d * LD + i]
        if nrec * every > 0 and (W[_ALIVE + i] == 1.0 or fail[lo + i, 0] > 0):  # it took a step
            took = 1
    return took


@kernel
def _work_array():
    """A block's work array (:data:`_NROWS` rows of :data:`LD`), its rows on 64-byte boundaries."""
    buf = np.empty(_NROWS * LD + 8)
    off = (8 - (buf.ctypes.data // 8) % 8) % 8
    return buf[off : off + _NROWS * LD]


@_inline
def _run_range(
    x, v, cx, cv, wp, central_p, zonal_p, zonal_j, dt, gammas, every, nrec, max_iter,
    rec_x, rec_v, rec_iters, fail, lo, hi, nmax, polez,
):  # fmt: skip
    """Every step of the chunk for points lo..hi, block by block. Returns 1 if a point took a step."""
    W = _work_array()
    took = 0
    for b in range(lo, hi, BLOCK):
        took |= _run_block(
            W, x, v, cx, cv, wp, central_p, zonal_p, zonal_j, dt, gammas, every, nrec, max_iter,
            rec_x, rec_v, rec_iters, fail, b, min(b + BLOCK, hi), nmax, polez,
        )  # fmt: skip
    return took


@_inline
def _run_parallel(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, nmax, polez):
    """:func:`_run_range` over all points, the blocks shared among Numba's threads (blocks
    are independent: a point's result does not depend on the thread count)."""
    nb = (x.shape[1] + BLOCK - 1) // BLOCK
    took = np.zeros(nb + 1, np.int64)
    for b in prange(nb):
        lo, hi = b * BLOCK, min((b + 1) * BLOCK, x.shape[1])
        took[b] = _run_range(
            x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, lo, hi, nmax, polez
        )  # fmt: skip
    return took.max()


# entry kernels, one per variant (J2 alone or J2..J6; the pole along z or not), each with
# its variant as constants: a run compiles only its own


@kernel
def _range_2(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, lo, hi):
    return _run_range(
        x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, lo, hi, 2, False
    )


@kernel
def _range_2z(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, lo, hi):
    return _run_range(
        x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, lo, hi, 2, True
    )


@kernel
def _range_6(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, lo, hi):
    return _run_range(
        x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, lo, hi, 6, False
    )


@kernel
def _range_6z(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, lo, hi):
    return _run_range(
        x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, lo, hi, 6, True
    )


@kernel(parallel=True)
def _parallel_2(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail):
    return _run_parallel(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, 2, False)


@kernel(parallel=True)
def _parallel_2z(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail):
    return _run_parallel(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, 2, True)


@kernel(parallel=True)
def _parallel_6(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail):
    return _run_parallel(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, 6, False)


@kernel(parallel=True)
def _parallel_6z(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail):
    return _run_parallel(x, v, cx, cv, wp, cp, zp, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail, 6, True)


_RANGE = {(2, False): _range_2, (2, True): _range_2z, (6, False): _range_6, (6, True): _range_6z}
_PARALLEL = {(2, False): _parallel_2, (2, True): _parallel_2z, (6, False): _parallel_6, (6, True): _parallel_6z}


def variant(zonal_p, zonal_j) -> tuple:
    """The kernel variant for the zonal parameters: (2 for J2 alone or NMAX, whether the pole
    is (0, 0, 1) exactly)."""
    return (2 if zonal_j.shape[0] == 1 else NMAX, bool(zonal_p[3] == 0.0 and zonal_p[4] == 0.0 and zonal_p[5] == 1.0))


def chunk(
    x, v, cx, cv, wp, hp, m, central_p, zonal_p, zonal_j, dt, gammas, every, nrec, max_iter, rec_x, rec_v,
    rec_iters, fail, parallel=None,
):  # fmt: skip
    """Advance every point ``nrec * every`` composed em steps under the central field and
    the zonal harmonics: the arguments of the effect step's ``chunk``
    (:func:`emorbit.kernels.pointmass.effect_step.effect_chunk`) for the effects central and zonal.

    Parameters
    ----------
    x, v, cx, cv, wp : ndarray
        (3, n) state, compensations and the last sub-step's w; updated in place.
    hp : ndarray
        (1,) the last sub-step's h, set where a point took a step.
    m : ndarray
        (n,) masses (unused: the forces are per unit mass).
    central_p, zonal_p, zonal_j : ndarray
        The effects' parameters (see the module).
    dt, gammas, every, nrec, max_iter
        The step, the composition's sub-step fractions, steps per record, records, and
        Newton updates per sub-step at most.
    rec_x, rec_v, rec_iters, fail : ndarray
        Records (nrec, 3, n), (nrec, 3, n), (nrec, n) and failures (n, 2), pre-filled with -1.
    parallel : bool, optional
        Blocks on all of Numba's threads (default: from :data:`PARALLEL_MIN` points on).
    """
    n = x.shape[1]
    key = variant(zonal_p, zonal_j)
    if parallel is None:
        parallel = n >= PARALLEL_MIN and numba.get_num_threads() > 1
    args = (x, v, cx, cv, wp, central_p, zonal_p, zonal_j, float(dt), gammas, int(every), int(nrec), int(max_iter))
    if parallel:
        took = _PARALLEL[key](*args, rec_x, rec_v, rec_iters, fail)
    else:
        took = _RANGE[key](*args, rec_x, rec_v, rec_iters, fail, 0, n)
    if took:
        hp[0] = dt * gammas[-1]
