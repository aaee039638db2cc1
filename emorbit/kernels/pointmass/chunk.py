"""Every step of a chunk for one packed block (:func:`_run_packed`) or one point alone (:func:`_run_point`).

A chunk advances each point ``nrec * every`` composed steps; a composed step is the sequence of
sub-steps ``gammas[k] * dt`` (orders 4-8: symmetric compositions, :mod:`emorbit.integrators`),
and the state is recorded every ``every`` steps. Arguments and records are those of the
reference kernels (:func:`~.reference.implicit_chunk`): ``x, v, cx, cv`` (3, n) state and
compensations, updated in place; ``rec_x, rec_v`` (nrec, 3, n); ``rec_iters`` (nrec, n) Newton
updates per record interval; ``fail`` (n, 2), (step index, status) of a point that failed,
which stops before the failing step (a failing sub-step discards its whole composed step).

:func:`_run_packed` copies the block into the work array of :mod:`.block` and takes every
sub-step as its passes: the packed solve, the scalar pass for the points it did not accept
(and, for em, for the points whose state is not finite), the update pass, the finish of
large-t em steps, and the fix-up of failed points. :func:`_run_point` takes the same sub-step
through :mod:`.point_step` for blocks too small to pack (fewer than ``_PACKED_MIN`` points, a
single orbit); it is also what each GPU thread runs (:mod:`.cuda`).

Both count Newton updates the same way: ``_packed_iters`` per sub-step (em 1, fast em and
midpoint 2, leapfrog 0) plus the extra updates of the scalar pass. ``method`` is a constant in
every caller (the entry kernels of :mod:`.packed`), so Numba compiles only its branch.
"""

from __future__ import annotations

import math

from ..codes import METHOD_EM, METHOD_EM_PLAIN, METHOD_LEAPFROG, STATUS_OK, STATUS_SINGULAR
from ..gravity import accel
from ..jit import kernel
from .block import (
    _ALIVE,
    _BK,
    _BUF0,
    _BUF1,
    _EXTRA,
    _NS,
    _OG0,
    _OG1,
    _OG2,
    _OX0,
    _OX1,
    _OX2,
    _ST,
    LD,
    _fail_before,
    _fixup,
    _pass_em_plain_solve,
    _pass_em_solve,
    _pass_finish_big_t,
    _pass_leapfrog,
    _pass_mid_solve,
    _pass_update,
    _pass_update_em,
    _resolve_em,
    _resolve_em_plain,
    _resolve_mid,
)
from .point_step import (
    _implicit_point_em,
    _implicit_point_em_plain,
    _implicit_point_mid,
    _leapfrog_point,
    _packed_iters,
)
from .roots import _tau

_inline = kernel(inline="always")


@_inline
def _run_packed(
    method, W, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    """Every step of the chunk for the block of points lo..hi (at most :data:`BLOCK`) in
    the work array ``W`` (:func:`~.block._work_array`, any content)."""
    m = hi - lo
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    for d in range(3):
        for i in range(m):
            W[d * LD + i] = x[d, lo + i]
            W[(3 + d) * LD + i] = v[d, lo + i]
            W[(6 + d) * LD + i] = cx[d, lo + i]
            W[(9 + d) * LD + i] = cv[d, lo + i]
            # the gravity rows of both buffers: leapfrog's state, and checked by _fixup
            W[_BUF0 + _OG0 + d * LD + i] = 0.0
            W[_BUF1 + _OG0 + d * LD + i] = 0.0
    for i in range(m):
        W[_ALIVE + i] = 1.0
        W[_ST + i] = 0.0
    ndead = 0
    packed = _packed_iters(method)
    if method == METHOD_LEAPFROG:
        for i in range(m):
            a0, a1, a2, rr = accel(c0 - W[_OX0 + i], c1 - W[_OX1 + i], c2 - W[_OX2 + i], gm)
            W[_OG0 + i] = a0
            W[_OG1 + i] = a1
            W[_OG2 + i] = a2
            if not (rr > 0.0 and rr < math.inf):
                W[_ALIVE + i] = 0.0
                ndead += 1
                fail[lo + i, 0] = 0
                fail[lo + i, 1] = STATUS_SINGULAR
    ns = gammas.shape[0]
    cur = 0  # the buffer that holds the state
    for r in range(nrec):
        for i in range(m):
            W[_EXTRA + i] = 0.0
        for s in range(every):
            if ns > 1:  # a failing sub-step discards the whole composed step
                base = _BUF0 if cur == 0 else _BUF1
                for j in range(_NS):
                    for i in range(m):
                        W[_BK + j * LD + i] = W[base + j * LD + i]
            failed = False
            for k in range(ns):
                h = dt * gammas[k]
                tau0, tlo = _tau(h, gm)
                S = _BUF0 if cur == 0 else _BUF1
                nbad = 0
                if method == METHOD_LEAPFROG:
                    nbad = _pass_leapfrog(W, m, h, gm, c0, c1, c2, cur)
                elif method == METHOD_EM:
                    first = r == 0 and s == 0 and k == 0  # the caller's state: as the reference
                    if _pass_em_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
                        nf, nin = _resolve_em(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, not first)
                        nbad += nf
                        if nin and ns == 1:  # the step before made them so
                            ndead += _fail_before(
                                W, m, S, _BUF1 if cur == 0 else _BUF0, fail, lo, r * every + s - 1, False
                            )
                        else:  # an earlier sub-step of this step
                            nbad += nin
                    nb, nbig = _pass_update_em(W, m, h, gm, tau0, c0, c1, c2, cur, k == ns - 1 > 0)
                    nbad += nb
                    if nbig:
                        nbad += _pass_finish_big_t(W, m, h, gm, tau0, c0, c1, c2, cur)
                elif method == METHOD_EM_PLAIN:
                    if _pass_em_plain_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
                        nbad += _resolve_em_plain(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S)
                    nbad += _pass_update(W, m, 2.0, h, h, c0, c1, c2, cur)
                else:
                    if _pass_mid_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
                        nbad += _resolve_mid(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S)
                    nbad += _pass_update(W, m, 1.0, 0.5 * h, h, c0, c1, c2, cur)
                cur = 1 - cur
                if nbad or failed or ndead:
                    failed = failed or nbad > 0
                    _fixup(W, m, S, _BUF0 if cur == 0 else _BUF1)
            if failed:
                step = r * every + s
                base = _BUF0 if cur == 0 else _BUF1
                for i in range(m):
                    if W[_ALIVE + i] == 1.0 and W[_ST + i] != 0.0:
                        W[_ALIVE + i] = 0.0
                        ndead += 1
                        fail[lo + i, 0] = step
                        fail[lo + i, 1] = int(W[_ST + i])
                        if ns > 1:
                            for j in range(_NS):
                                W[base + j * LD + i] = W[_BK + j * LD + i]
                    W[_ST + i] = 0.0
        base = _BUF0 if cur == 0 else _BUF1
        if method == METHOD_EM and ns == 1:  # the last step's state: not checked by its update
            ndead += _fail_before(W, m, base, _BUF1 if cur == 0 else _BUF0, fail, lo, r * every + every - 1, True)
        for d in range(3):
            for i in range(m):
                rec_x[r, d, lo + i] = W[base + d * LD + i]
                rec_v[r, d, lo + i] = W[base + (3 + d) * LD + i]
        for i in range(m):
            rec_iters[r, lo + i] = every * ns * packed + int(W[_EXTRA + i])
    base = _BUF0 if cur == 0 else _BUF1
    for d in range(3):
        for i in range(m):
            x[d, lo + i] = W[base + d * LD + i]
            v[d, lo + i] = W[base + (3 + d) * LD + i]
            cx[d, lo + i] = W[base + (6 + d) * LD + i]
            cv[d, lo + i] = W[base + (9 + d) * LD + i]


@_inline
def _run_point(method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, i):
    """Every step of the chunk for point ``i`` alone (blocks too small to pack)."""
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    x0, x1, x2 = x[0, i], x[1, i], x[2, i]
    y0, y1, y2 = v[0, i], v[1, i], v[2, i]
    p0, p1, p2 = cx[0, i], cx[1, i], cx[2, i]
    q0, q1, q2 = cv[0, i], cv[1, i], cv[2, i]
    ns = gammas.shape[0]
    packed = _packed_iters(method)
    b0 = b1 = b2 = 0.0
    if method == METHOD_LEAPFROG:
        b0, b1, b2, rr = accel(c0 - x0, c1 - x1, c2 - x2, gm)
        if not (rr > 0.0 and rr < math.inf):
            fail[i, 0] = 0
            fail[i, 1] = STATUS_SINGULAR
            return
    for r in range(nrec):
        its = 0
        for s in range(every):
            # sub-steps go into trial copies: a failing step leaves the state untouched
            t0, t1, t2, u0, u1, u2 = x0, x1, x2, y0, y1, y2
            e0, e1, e2, f0, f1, f2 = p0, p1, p2, q0, q1, q2
            n0, n1, n2 = b0, b1, b2
            status = STATUS_OK
            for k in range(ns):
                h = dt * gammas[k]
                if method == METHOD_LEAPFROG:
                    (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, good) = _leapfrog_point(
                        t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, h, gm, c0, c1, c2
                    )
                    if not good:
                        status = STATUS_SINGULAR
                elif method == METHOD_EM:
                    tau0, tlo = _tau(h, gm)
                    (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status) = _implicit_point_em(
                        t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, h, gm, tau0, tlo, c0, c1, c2, max_iter
                    )
                elif method == METHOD_EM_PLAIN:
                    tau0, tlo = _tau(h, gm)
                    (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status) = _implicit_point_em_plain(
                        t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, h, gm, tau0, tlo, c0, c1, c2, max_iter
                    )
                else:
                    tau0, tlo = _tau(h, gm)
                    (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status) = _implicit_point_mid(
                        t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, h, gm, tau0, tlo, c0, c1, c2, max_iter
                    )
                if method != METHOD_LEAPFROG:
                    its += packed + extra
                if status != STATUS_OK:
                    fail[i, 0] = r * every + s
                    fail[i, 1] = status
                    break
            if status != STATUS_OK:
                break
            x0, x1, x2, y0, y1, y2 = t0, t1, t2, u0, u1, u2
            p0, p1, p2, q0, q1, q2 = e0, e1, e2, f0, f1, f2
            b0, b1, b2 = n0, n1, n2
        if fail[i, 0] >= 0:
            break
        rec_x[r, 0, i] = x0
        rec_x[r, 1, i] = x1
        rec_x[r, 2, i] = x2
        rec_v[r, 0, i] = y0
        rec_v[r, 1, i] = y1
        rec_v[r, 2, i] = y2
        rec_iters[r, i] = its
    x[0, i], x[1, i], x[2, i] = x0, x1, x2
    v[0, i], v[1, i], v[2, i] = y0, y1, y2
    cx[0, i], cx[1, i], cx[2, i] = p0, p1, p2
    cv[0, i], cv[1, i], cv[2, i] = q0, q1, q2
