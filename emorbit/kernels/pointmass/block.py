"""A packed block of point masses: its work array and the passes over it.

Points are processed in blocks of :data:`BLOCK`; a block's state lives in a work array ``W`` for
a whole chunk (in the L1/L2 cache while every step of the chunk is taken). ``W`` is
one-dimensional, row ``r`` at ``r * LD``, and every row offset used in a packed loop is a
compile-time constant (``_OX0`` to ``_QG`` below), so LLVM knows the distance between any two
rows and vectorises without run-time alias checks. Rows: two state buffers of :data:`_NS` rows
(position, velocity, their compensations, leapfrog's acceleration), the state at the start of
a composed step, and one row per point-wise quantity of the solve (``|a|``, the unknown, the
dot products, the last update, ``w``, flags and counts).

A sub-step is a few short loops, the passes (``_pass_*`` over the inlined ``_loop_*``): short
dependency chains and few live values per loop let the out-of-order core overlap many points.
A sub-step reads one state buffer and writes the other, every point unconditionally (a "store
if" would become a masked store, slow on AMD processors). Each pass has one branch per buffer
(``cur``), so that the offsets ``S`` (read) and ``D`` (written) of its loop stay constants.
Scalar passes run only where a point needs them:

* ``_resolve_*``: the points whose packed solve was not accepted
  (:func:`~.point_step._resolve_point`);
* :func:`_pass_finish_big_t`: em steps with ``t > 1/128``, ended by the reference kernel's finish;
* :func:`_fixup`: after a sub-step in which a point failed, or with dead points, the old state back;
* :func:`_fail_before`: em's update pass does not test its new state (the last sub-step of a
  composed step does). A state that is not finite makes ``A`` or ``V`` inf or nan, which the
  certified update never accepts, so the next sub-step's scalar pass finds it and the point fails
  at the step that made it, its old state still in the other buffer; at the end of each record a
  check of the block catches the record's last step.

Every point goes through the scalar helpers of :mod:`.roots` and :mod:`.point_step`, packed or
alone, so its result does not depend on which points share its block. :mod:`.chunk` runs a block
through every step of a chunk with these passes.
"""

from __future__ import annotations

import numpy as np

from ..codes import METHOD_EM, METHOD_EM_PLAIN, METHOD_MIDPOINT, STATUS_OK, STATUS_SINGULAR
from ..jit import kernel
from .point_step import _finite3, _finite6, _kahan3, _leapfrog_point, _resolve_point
from .roots import (
    _em_big_t,
    _em_chord,
    _em_dots,
    _em_finished,
    _em_newton,
    _em_newton_certified,
    _em_ok,
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

#: points per block
BLOCK = 64
#: row length of the work array: a multiple of 8 (rows start on 64-byte boundaries, so no
#: packed load splits a cache line) and not of 512 (rows do not share their low twelve
#: address bits: 4K aliasing would stall loads behind unrelated stores)
LD = BLOCK + 8
#: smaller blocks go point by point (same helpers, same bits)
_PACKED_MIN = 4

# rows of the work array
_NS = 15  # rows of a state buffer:
_OX0, _OX1, _OX2 = 0 * LD, 1 * LD, 2 * LD  # position
_OV0, _OV1, _OV2 = 3 * LD, 4 * LD, 5 * LD  # velocity
_OCX0, _OCX1, _OCX2 = 6 * LD, 7 * LD, 8 * LD  # compensation of the position
_OCV0, _OCV1, _OCV2 = 9 * LD, 10 * LD, 11 * LD  # compensation of the velocity
_OG0, _OG1, _OG2 = 12 * LD, 13 * LD, 14 * LD  # leapfrog: acceleration at the state
_BUF0 = 0 * LD  # state buffer 0
_BUF1 = 15 * LD  # state buffer 1
_BK = 30 * LD  # the state at the start of a composed step (orders 4-8)
_R0 = 45 * LD  # |a| (em)
_RHO = 46 * LD  # the unknown: r1 (em) or |m| (midpoint)
_AA = 47 * LD  # a.a (em); |a - h/2 v0| (midpoint)
_PP = 48 * LD  # h a.v0
_VV = 49 * LD  # h**2 v0.v0
_DEL = 50 * LD  # last Newton update
_PEND = 51 * LD  # 1 where the packed solve was not accepted
_ST = 52 * LD  # failure code of the current step (0: none)
_EXTRA = 53 * LD  # Newton iterations beyond the packed ones, in the current record interval
_ALIVE = 54 * LD  # 1 until the point fails
_WG = 55 * LD  # w, the size of gravity over the step (g = w (ua a - uv v0))
_QG = 56 * LD  # Q / (F' Q**3) of the Newton update, reused by the chord update (fast em)
_NROWS = 57


@kernel
def _store_state(W, D, i, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2):
    """Point i's position, velocity and their compensations into buffer D."""
    W[D + _OX0 + i] = t0
    W[D + _OX1 + i] = t1
    W[D + _OX2 + i] = t2
    W[D + _OV0 + i] = u0
    W[D + _OV1 + i] = u1
    W[D + _OV2 + i] = u2
    W[D + _OCX0 + i] = e0
    W[D + _OCX1 + i] = e1
    W[D + _OCX2 + i] = e2
    W[D + _OCV0 + i] = f0
    W[D + _OCV1 + i] = f1
    W[D + _OCV2 + i] = f2


@kernel
def _work_array():
    """A block's work array ``W`` (:data:`_NROWS` rows of :data:`LD`), its rows on 64-byte
    boundaries (``LD * 8`` is a multiple of 64). Not cleared: :func:`~.chunk._run_packed` sets
    what it reads before writing. One serves a whole range of blocks."""
    buf = np.empty(_NROWS * LD + 8)
    off = (8 - (buf.ctypes.data // 8) % 8) % 8
    return buf[off : off + _NROWS * LD]


# ----------------------------------------------------------------------------------------
# packed loops over one block of m points; S, D: offsets of the state buffers read and written


@_inline
def _loop_em_dots(W, m, h, c0, c1, c2, S):
    for i in range(m):
        ax = c0 - W[S + _OX0 + i]
        ay = c1 - W[S + _OX1 + i]
        az = c2 - W[S + _OX2 + i]
        vx = W[S + _OV0 + i]
        vy = W[S + _OV1 + i]
        vz = W[S + _OV2 + i]
        A, P, V, r0 = _em_dots(ax, ay, az, vx, vy, vz, h)
        W[_AA + i] = A
        W[_PP + i] = P
        W[_VV + i] = V
        W[_R0 + i] = r0


@_inline
def _pass_em_solve_impl(W, m, h, gm, tau0, tlo, c0, c1, c2, cur, method):
    """Dot products, predictor, the updates of r1 (em: one certified Newton update on the plain
    F; fast: Newton and chord on the plain F), and w, for every point, as short loops. Returns
    the count of points not accepted (flagged in _PEND)."""
    if cur == 0:
        _loop_em_dots(W, m, h, c0, c1, c2, _BUF0)
    else:
        _loop_em_dots(W, m, h, c0, c1, c2, _BUF1)
    if method == METHOD_EM:
        for i in range(m):
            W[_RHO + i] = _em_predict(W[_AA + i], W[_PP + i], W[_VV + i], W[_R0 + i], h, gm)
    else:
        for i in range(m):
            W[_RHO + i] = _em_predict_taylor(W[_AA + i], W[_PP + i], W[_VV + i], W[_R0 + i], h, gm)
        for i in range(m):
            rho, d1, qg = _em_newton(W[_AA + i], W[_PP + i], W[_VV + i], W[_R0 + i], W[_RHO + i], tau0, tlo)
            W[_RHO + i] = rho
            W[_DEL + i] = d1
            W[_QG + i] = qg
    npend = 0
    for i in range(m):
        r0 = W[_R0 + i]
        A = W[_AA + i]
        P = W[_PP + i]
        V = W[_VV + i]
        if method == METHOD_EM:
            rho, delta, cert = _em_newton_certified(A, P, V, r0, W[_RHO + i], tau0, tlo)
            # never with A or V not finite (a state the update made so, see chunk._run_packed):
            # then A/2 <= p <= 2 A fails, or D, delta or E is inf or nan and the
            # certificate's two roundings differ (tests/test_ensemble.py, the overflow test)
            ok = cert & _em_plausible(rho, A, V)
        else:
            rho, delta = _em_chord(A, P, V, r0, W[_RHO + i], tau0, tlo, W[_QG + i])
            ok = _em_ok(W[_DEL + i], delta, rho, A, V)
        W[_WG + i] = _em_w(r0, rho, gm, tau0, tlo)
        W[_PEND + i] = 0.0 if ok else 1.0
        W[_RHO + i] = rho
        W[_DEL + i] = delta
        npend += 0 if ok else 1
    return npend


@kernel
def _pass_em_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
    return _pass_em_solve_impl(W, m, h, gm, tau0, tlo, c0, c1, c2, cur, METHOD_EM)


@kernel
def _pass_em_plain_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
    return _pass_em_solve_impl(W, m, h, gm, tau0, tlo, c0, c1, c2, cur, METHOD_EM_PLAIN)


@_inline
def _loop_mid_start(W, m, h, c0, c1, c2, S):
    for i in range(m):
        W[_AA + i] = _mid_start(
            c0 - W[S + _OX0 + i],
            c1 - W[S + _OX1 + i],
            c2 - W[S + _OX2 + i],
            W[S + _OV0 + i],
            W[S + _OV1 + i],
            W[S + _OV2 + i],
            h,
        )


@kernel
def _pass_mid_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
    """|a - h/2 v0|, two Newton updates of |m| and w for every point. Returns the count of
    points not accepted (flagged in _PEND)."""
    if cur == 0:
        _loop_mid_start(W, m, h, c0, c1, c2, _BUF0)
    else:
        _loop_mid_start(W, m, h, c0, c1, c2, _BUF1)
    npend = 0
    for i in range(m):
        m0 = W[_AA + i]
        mu, delta = _mid_newton(m0, m0, tau0)
        mu, delta = _mid_newton(m0, mu, tau0)
        ok = _mid_ok(delta, mu)
        W[_PEND + i] = 0.0 if ok else 1.0
        W[_RHO + i] = mu
        W[_DEL + i] = delta
        W[_WG + i] = _mid_w(mu, gm, tau0, tlo)
        npend += 0 if ok else 1
    return npend


@_inline
def _loop_update(W, m, ua, uv, h, c0, c1, c2, S, D, gm, tau0, count_big, count_bad):
    """Increments from w and the compensated update of the state in S, into D; returns
    (``count_bad``, a constant) the count of points whose new state is not finite and
    (``count_big``, a constant: em) the count of steps with a large t (:func:`_em_big_t`),
    for :func:`_pass_finish_big_t` (counted here, where w is loaded anyway, not in a loop of
    its own). em leaves out the finite count where it can (see :func:`_fail_before`): it
    costs time here or in a loop of its own."""
    nbad = 0
    nbig = 0
    for i in range(m):
        x0 = W[S + _OX0 + i]
        x1 = W[S + _OX1 + i]
        x2 = W[S + _OX2 + i]
        y0 = W[S + _OV0 + i]
        y1 = W[S + _OV1 + i]
        y2 = W[S + _OV2 + i]
        wg = W[_WG + i]
        d0, d1, d2, w0, w1, w2 = _increments(c0 - x0, c1 - x1, c2 - x2, y0, y1, y2, wg, ua, uv, h)
        t0, t1, t2, e0, e1, e2 = _kahan3(x0, x1, x2, W[S + _OCX0 + i], W[S + _OCX1 + i], W[S + _OCX2 + i], d0, d1, d2)
        u0, u1, u2, f0, f1, f2 = _kahan3(y0, y1, y2, W[S + _OCV0 + i], W[S + _OCV1 + i], W[S + _OCV2 + i], w0, w1, w2)
        _store_state(W, D, i, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2)
        if count_bad:
            nbad += 0 if _finite6(t0, t1, t2, u0, u1, u2) else 1
        if count_big:
            nbig += 1 if _em_big_t(wg, gm, tau0) else 0
    return nbad, nbig


@_inline
def _loop_finish_big_t(W, m, h, gm, tau0, c0, c1, c2, S, D):
    """em: redo the steps with a large t (see _em_big_t) with the reference kernel's finish,
    from the state in S into D. Returns the count of points whose new state is not finite.
    (Its loads and compensated update are written out as in _loop_update: a helper shared by
    both stops LLVM from vectorising _loop_update.)"""
    nbad = 0
    for i in range(m):
        if not _em_big_t(W[_WG + i], gm, tau0):
            continue
        x0 = W[S + _OX0 + i]
        x1 = W[S + _OX1 + i]
        x2 = W[S + _OX2 + i]
        y0 = W[S + _OV0 + i]
        y1 = W[S + _OV1 + i]
        y2 = W[S + _OV2 + i]
        d0, d1, d2, w0, w1, w2 = _em_finished(c0 - x0, c1 - x1, c2 - x2, y0, y1, y2, W[_WG + i], W[_R0 + i], h, gm)
        t0, t1, t2, e0, e1, e2 = _kahan3(x0, x1, x2, W[S + _OCX0 + i], W[S + _OCX1 + i], W[S + _OCX2 + i], d0, d1, d2)
        u0, u1, u2, f0, f1, f2 = _kahan3(y0, y1, y2, W[S + _OCV0 + i], W[S + _OCV1 + i], W[S + _OCV2 + i], w0, w1, w2)
        _store_state(W, D, i, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2)
        nbad += 0 if _finite6(t0, t1, t2, u0, u1, u2) else 1
    return nbad


@kernel
def _pass_finish_big_t(W, m, h, gm, tau0, c0, c1, c2, cur):
    """em: after the update pass, the steps with a large t finished on the accurate g_em
    (a scalar pass, run only when :func:`_pass_update_em` counted such a step). Returns the
    count of points whose new state is not finite."""
    if cur == 0:
        return _loop_finish_big_t(W, m, h, gm, tau0, c0, c1, c2, _BUF0, _BUF1)
    return _loop_finish_big_t(W, m, h, gm, tau0, c0, c1, c2, _BUF1, _BUF0)


@kernel
def _pass_update(W, m, ua, uv, h, c0, c1, c2, cur):
    """Increments from w (g = w (ua a - uv v0)) and the compensated update into the other
    buffer. Returns the count of points whose new state is not finite."""
    if cur == 0:
        return _loop_update(W, m, ua, uv, h, c0, c1, c2, _BUF0, _BUF1, 0.0, 0.0, False, True)[0]
    return _loop_update(W, m, ua, uv, h, c0, c1, c2, _BUF1, _BUF0, 0.0, 0.0, False, True)[0]


@kernel
def _pass_update_em(W, m, h, gm, tau0, c0, c1, c2, cur, check):
    """em: :func:`_pass_update` (g = w (2 a - h v0)); returns the count of points whose new
    state is not finite (``check``; else 0) and the count of steps with a large t."""
    if check:
        if cur == 0:
            return _loop_update(W, m, 2.0, h, h, c0, c1, c2, _BUF0, _BUF1, gm, tau0, True, True)
        return _loop_update(W, m, 2.0, h, h, c0, c1, c2, _BUF1, _BUF0, gm, tau0, True, True)
    if cur == 0:
        return _loop_update(W, m, 2.0, h, h, c0, c1, c2, _BUF0, _BUF1, gm, tau0, True, False)
    return _loop_update(W, m, 2.0, h, h, c0, c1, c2, _BUF1, _BUF0, gm, tau0, True, False)


@_inline
def _loop_leapfrog(W, m, h, gm, c0, c1, c2, S, D):
    nbad = 0
    for i in range(m):
        (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, good) = _leapfrog_point(
            W[S + _OX0 + i],
            W[S + _OX1 + i],
            W[S + _OX2 + i],
            W[S + _OV0 + i],
            W[S + _OV1 + i],
            W[S + _OV2 + i],
            W[S + _OCX0 + i],
            W[S + _OCX1 + i],
            W[S + _OCX2 + i],
            W[S + _OCV0 + i],
            W[S + _OCV1 + i],
            W[S + _OCV2 + i],
            W[S + _OG0 + i],
            W[S + _OG1 + i],
            W[S + _OG2 + i],
            h,
            gm,
            c0,
            c1,
            c2,
        )
        _store_state(W, D, i, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2)
        W[D + _OG0 + i] = n0
        W[D + _OG1 + i] = n1
        W[D + _OG2 + i] = n2
        nbad += 0 if good else 1
    return nbad


@kernel
def _pass_leapfrog(W, m, h, gm, c0, c1, c2, cur):
    """One kick-drift-kick sub-step into the other buffer; returns the count of points
    whose new state or acceleration is not finite."""
    if cur == 0:
        return _loop_leapfrog(W, m, h, gm, c0, c1, c2, _BUF0, _BUF1)
    return _loop_leapfrog(W, m, h, gm, c0, c1, c2, _BUF1, _BUF0)


# ----------------------------------------------------------------------------------------
# scalar passes over a block: the points whose packed solve was not accepted, and failures


@_inline
def _resolve_impl(W, method, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, check_input):
    """Finish the points flagged pending (see _resolve_point) and set their w; returns the
    count that failed and (em, ``check_input``) the count whose state came in not finite
    (the sub-step before made it so: flagged 2 in _PEND, failed as STATUS_SINGULAR, see
    :func:`_run_packed`)."""
    nfail = 0
    nin = 0
    for i in range(m):
        if W[_PEND + i] == 0.0 or W[_ST + i] != 0.0 or W[_ALIVE + i] != 1.0:
            continue
        if (
            method == METHOD_EM
            and check_input
            and not _finite6(
                W[S + _OX0 + i], W[S + _OX1 + i], W[S + _OX2 + i], W[S + _OV0 + i], W[S + _OV1 + i], W[S + _OV2 + i]
            )
        ):
            W[_PEND + i] = 2.0
            W[_ST + i] = float(STATUS_SINGULAR)
            nin += 1
            continue
        r0, rho, extra, status = _resolve_point(
            method,
            W[_AA + i],
            W[_PP + i],
            W[_VV + i],
            W[_R0 + i],
            W[_RHO + i],
            abs(W[_DEL + i]),
            h,
            gm,
            tau0,
            tlo,
            W[S + _OX0 + i],
            W[S + _OX1 + i],
            W[S + _OX2 + i],
            W[S + _OV0 + i],
            W[S + _OV1 + i],
            W[S + _OV2 + i],
            c0,
            c1,
            c2,
            max_iter,
        )
        W[_EXTRA + i] += extra
        if status == STATUS_OK:
            W[_R0 + i] = r0
            W[_RHO + i] = rho
            W[_WG + i] = _mid_w(rho, gm, tau0, tlo) if method == METHOD_MIDPOINT else _em_w(r0, rho, gm, tau0, tlo)
        else:
            W[_ST + i] = float(status)
            nfail += 1
    return nfail, nin


@kernel
def _resolve_em(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, check_input):
    return _resolve_impl(W, METHOD_EM, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, check_input)


@kernel
def _resolve_em_plain(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S):
    return _resolve_impl(W, METHOD_EM_PLAIN, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, False)[0]


@kernel
def _resolve_mid(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S):
    return _resolve_impl(W, METHOD_MIDPOINT, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, False)[0]


@kernel
def _fail_before(W, m, S, P, fail, lo, step, check):
    """em, one sub-step per step: the step ``step`` gave points a state that is not finite,
    found afterwards (flagged 2 in _PEND by the scalar pass of the next step, or, ``check``,
    any live point whose state in buffer S is not finite: at the end of a record). They
    fail at that step as STATUS_SINGULAR with the state from before it, still in the other
    buffer P. Returns the count."""
    n = 0
    for i in range(m):
        if W[_ALIVE + i] != 1.0:
            continue
        if check:
            bad = not _finite6(
                W[S + _OX0 + i], W[S + _OX1 + i], W[S + _OX2 + i], W[S + _OV0 + i], W[S + _OV1 + i], W[S + _OV2 + i]
            )
        else:
            bad = W[_PEND + i] == 2.0
        if bad:
            for j in range(_NS):
                W[S + j * LD + i] = W[P + j * LD + i]
            W[_ALIVE + i] = 0.0
            W[_ST + i] = 0.0
            W[_WG + i] = 0.0
            fail[lo + i, 0] = step
            fail[lo + i, 1] = STATUS_SINGULAR
            n += 1
    return n


@kernel
def _fixup(W, m, S, D):
    """After a sub-step in which a point failed (or with dead points): give such points
    their old state back (buffer S into D) and record a non-finite state in _ST."""
    for i in range(m):
        fin = _finite6(
            W[D + _OX0 + i], W[D + _OX1 + i], W[D + _OX2 + i], W[D + _OV0 + i], W[D + _OV1 + i], W[D + _OV2 + i]
        )
        fin = fin & _finite3(W[D + _OG0 + i], W[D + _OG1 + i], W[D + _OG2 + i])
        if not fin and W[_ST + i] == 0.0:
            W[_ST + i] = float(STATUS_SINGULAR)
        if W[_ST + i] != 0.0 or W[_ALIVE + i] != 1.0:
            for j in range(_NS):
                W[D + j * LD + i] = W[S + j * LD + i]
