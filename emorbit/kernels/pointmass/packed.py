"""Packed point-mass chunk kernels: the energy-momentum, midpoint and leapfrog steps of many
test particles around a fixed centre, as packed (SIMD) arithmetic, on one thread or on all.

Each point moves in the central field on its own (it neither disturbs the field nor attracts
the others). State: structure-of-arrays float64, shape (3, n): ``x``, ``v`` and their
compensation terms ``cx``, ``cv`` (Kahan summation). A step of size ``h`` solves::

    em:        dx = h v0 + h**2/2 g_em(x0, x0 + dx),   dv = h g_em
    midpoint:  dx = h v0 + h**2/2 g(x0 + dx/2),        dv = h g(x0 + dx/2)
    leapfrog:  kick-drift-kick with g at x0 and x1

with ``g_em = GM (a + b) / (r0 r1 (r0 + r1))`` (:mod:`emorbit.kernels.gravity`); em conserves
energy and angular momentum about the centre to round-off at any step size. The implicit steps
reduce to one scalar unknown, solved by Newton, after which the step is explicit (:mod:`.roots`);
with roundoff="brouwer" (``METHOD_EM``) the root is the exact root correctly rounded, which keeps the
energy error a random walk (Brouwer's law; docs/methods.md), with roundoff="fast"
(``METHOD_EM_PLAIN``) it is the plain Newton-chord iterate.

:func:`ensemble_chunk` and :func:`ensemble_chunk_parallel` have the arguments, records and
failure codes of :func:`~.reference.implicit_chunk` and :func:`~.reference.leapfrog_chunk`;
the states agree with those reference kernels to round-off (leapfrog: bit for bit). A point's
result never depends on which points share its block, on the block size, the thread count or
how a run is cut into chunks: every point goes through the same scalar operations packed or
alone, and no fused multiply-add is formed (``fastmath=False``) but the explicit ones
(:func:`~emorbit.kernels.eft.fma`), so packed, scalar and GPU code (:mod:`.cuda`) give the
same bits.

The modules: :mod:`.roots` (the scalar equations and their solves), :mod:`.point_step` (one
point's sub-step), :mod:`.block` (the work array of a block of :data:`BLOCK` points and the passes
over it), :mod:`.chunk` (every step of a chunk for a block or a point), and this one: the entry
kernels per method (``_range_*``, ``_points_*`` for fewer than ``_PACKED_MIN`` points,
``_parallel_*``), in which the method is a constant, so a run compiles only its method's code.
A range's last block, when too small to pack, calls the method's ``_points_*`` kernel, which
the one-orbit path shares. On all threads each thread claims up to ``_GRAIN`` blocks at a time
from a shared atomic counter (:mod:`emorbit.kernels.atomic`), so that a thread slowed by other
work on its core takes fewer blocks instead of holding up the run.

The bench derives its bound from division and square-root throughput from the counts below
(:data:`EM_SQRTS`, :data:`EM_DIVISIONS`, ...: per point and sub-step on the packed path; the
steps finished by the reference kernel's finish are not counted).
"""

from __future__ import annotations

import numba
import numpy as np
from numba import prange

from ..atomic import fetch_add
from ..codes import METHOD_EM, METHOD_EM_PLAIN, METHOD_LEAPFROG, METHOD_MIDPOINT
from ..jit import kernel

# Beyond what this module uses, every compiled function of the packed kernels is imported here
# under its own name: tests and scripts look them up in this module (scripts/profile_ensemble.py
# charges its samples to the compiled functions it finds here).
from .block import (  # noqa: F401
    _PACKED_MIN,
    BLOCK,
    LD,
    _fail_before,
    _fixup,
    _loop_em_dots,
    _loop_finish_big_t,
    _loop_leapfrog,
    _loop_mid_start,
    _loop_update,
    _pass_em_plain_solve,
    _pass_em_solve,
    _pass_em_solve_impl,
    _pass_finish_big_t,
    _pass_leapfrog,
    _pass_mid_solve,
    _pass_update,
    _pass_update_em,
    _resolve_em,
    _resolve_em_plain,
    _resolve_impl,
    _resolve_mid,
    _store_state,
    _work_array,
)
from .chunk import _run_packed, _run_point
from .point_step import (  # noqa: F401
    _finite3,
    _finite6,
    _implicit_point_em,
    _implicit_point_em_plain,
    _implicit_point_impl,
    _implicit_point_mid,
    _kahan3,
    _leapfrog_point,
    _packed_iters,
    _resolve_plausible,
    _resolve_point,
    _resolve_point_em,
    _resolve_point_em_plain,
    _resolve_point_mid,
)
from .roots import (  # noqa: F401
    _em_big_t,
    _em_chord,
    _em_dots,
    _em_f2,
    _em_f2_accurate,
    _em_f2_terms,
    _em_fg,
    _em_finished,
    _em_g3,
    _em_newton,
    _em_newton_accurate,
    _em_newton_certified,
    _em_ok,
    _em_ok_newton,
    _em_plausible,
    _em_predict,
    _em_predict_taylor,
    _em_small,
    _em_w,
    _increments,
    _mid_newton,
    _mid_ok,
    _mid_start,
    _mid_w,
    _tau,
)

__all__ = [
    "BLOCK",
    "EM_DIVISIONS",
    "EM_PLAIN_DIVISIONS",
    "EM_PLAIN_SQRTS",
    "EM_SQRTS",
    "LD",
    "LEAPFROG_DIVISIONS",
    "LEAPFROG_SQRTS",
    "METHOD_EM",
    "METHOD_EM_PLAIN",
    "METHOD_LEAPFROG",
    "METHOD_MIDPOINT",
    "PARALLEL_MIN",
    "ensemble_chunk",
    "ensemble_chunk_parallel",
]

#: from this many points on, PointMasses.advance runs ensemble_chunk_parallel
PARALLEL_MIN = 1024
#: the most blocks a thread claims at a time in a parallel run (see :mod:`.atomic`)
_GRAIN = 8

#: square roots and divisions per em point and sub-step on the packed path: |a| and the
#: predictor's root; the predictor's 1 / |a|, the Newton update's and w's (the fast step's
#: chord update and the default's certificate need none)
EM_SQRTS = 2
EM_DIVISIONS = 3
#: the same for em with roundoff="fast"
EM_PLAIN_SQRTS = 2
EM_PLAIN_DIVISIONS = 3
#: the same for leapfrog (|r| and GM / r**3 at the new position)
LEAPFROG_SQRTS = 1
LEAPFROG_DIVISIONS = 1

_inline = kernel(inline="always")


# ----------------------------------------------------------------------------------------
# entry points: kernels per method. The method is a constant in each, so Numba prunes the
# other methods' code before compiling: a run compiles only what it uses.


@_inline
def _run_points(
    method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    """Every step of the chunk for points lo..hi one by one (blocks too small to pack)."""
    for i in range(lo, hi):
        _run_point(
            method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, i
        )


@kernel
def _points_em(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi):
    _run_points(
        METHOD_EM, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
    )


@kernel
def _points_em_plain(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    _run_points(
        METHOD_EM_PLAIN,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@kernel
def _points_midpoint(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    _run_points(
        METHOD_MIDPOINT,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@kernel
def _points_leapfrog(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    _run_points(
        METHOD_LEAPFROG,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@_inline
def _run_range(
    method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    """Every step of the chunk for points lo..hi, block by block (packed, or point by point
    where a block is too small)."""
    W = _work_array()
    for b in range(lo, hi, BLOCK):
        e = min(b + BLOCK, hi)
        if e - b >= _PACKED_MIN:
            _run_packed(
                method,
                W,
                x,
                v,
                cx,
                cv,
                gm,
                center,
                dt,
                gammas,
                every,
                nrec,
                max_iter,
                rec_x,
                rec_v,
                rec_iters,
                fail,
                b,
                e,
            )
        elif method == METHOD_EM:  # a call, not inlined: the one-orbit path's own kernel
            _points_em(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, b, e)
        elif method == METHOD_EM_PLAIN:
            _points_em_plain(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, b, e
            )
        elif method == METHOD_MIDPOINT:
            _points_midpoint(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, b, e
            )
        else:
            _points_leapfrog(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, b, e
            )


@kernel
def _range_em(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi):
    _run_range(
        METHOD_EM, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
    )


@kernel
def _range_em_plain(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi):
    _run_range(
        METHOD_EM_PLAIN,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@kernel
def _range_midpoint(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi):
    _run_range(
        METHOD_MIDPOINT,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@kernel
def _range_leapfrog(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi):
    _run_range(
        METHOD_LEAPFROG,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@_inline
def _claim_blocks(n, threads):
    """The blocks of a parallel run of n points on ``threads`` threads, and how many of them
    a thread claims at a time from the shared counter: up to :data:`_GRAIN`, and at least
    four claims per thread (the last claims even out the threads' ends)."""
    nb = (n + BLOCK - 1) // BLOCK
    return nb, max(1, min(_GRAIN, nb // (4 * threads)))


@_inline
def _run_claims(
    method, counter, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, threads
):
    """One thread's part of a parallel run: claim blocks from ``counter`` and run them with
    the method's range kernel until none are left."""
    n = x.shape[1]
    nb, grain = _claim_blocks(n, threads)
    b = fetch_add(counter, 0, grain)
    while b < nb:
        lo, hi = b * BLOCK, min((b + grain) * BLOCK, n)
        if method == METHOD_EM:
            _range_em(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
            )
        elif method == METHOD_EM_PLAIN:
            _range_em_plain(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
            )
        elif method == METHOD_MIDPOINT:
            _range_midpoint(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
            )
        else:
            _range_leapfrog(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
            )
        b = fetch_add(counter, 0, grain)


@kernel(parallel=True)
def _parallel_em(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, threads):
    counter = np.zeros(1, np.int64)
    for _ in prange(threads):
        _run_claims(
            METHOD_EM,
            counter,
            x,
            v,
            cx,
            cv,
            gm,
            center,
            dt,
            gammas,
            every,
            nrec,
            max_iter,
            rec_x,
            rec_v,
            rec_iters,
            fail,
            threads,
        )


@kernel(parallel=True)
def _parallel_em_plain(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, threads
):
    counter = np.zeros(1, np.int64)
    for _ in prange(threads):
        _run_claims(
            METHOD_EM_PLAIN,
            counter,
            x,
            v,
            cx,
            cv,
            gm,
            center,
            dt,
            gammas,
            every,
            nrec,
            max_iter,
            rec_x,
            rec_v,
            rec_iters,
            fail,
            threads,
        )


@kernel(parallel=True)
def _parallel_midpoint(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, threads
):
    counter = np.zeros(1, np.int64)
    for _ in prange(threads):
        _run_claims(
            METHOD_MIDPOINT,
            counter,
            x,
            v,
            cx,
            cv,
            gm,
            center,
            dt,
            gammas,
            every,
            nrec,
            max_iter,
            rec_x,
            rec_v,
            rec_iters,
            fail,
            threads,
        )


@kernel(parallel=True)
def _parallel_leapfrog(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, threads
):
    counter = np.zeros(1, np.int64)
    for _ in prange(threads):
        _run_claims(
            METHOD_LEAPFROG,
            counter,
            x,
            v,
            cx,
            cv,
            gm,
            center,
            dt,
            gammas,
            every,
            nrec,
            max_iter,
            rec_x,
            rec_v,
            rec_iters,
            fail,
            threads,
        )


_RANGE = {
    METHOD_EM: _range_em,
    METHOD_EM_PLAIN: _range_em_plain,
    METHOD_MIDPOINT: _range_midpoint,
    METHOD_LEAPFROG: _range_leapfrog,
}
_POINTS = {
    METHOD_EM: _points_em,
    METHOD_EM_PLAIN: _points_em_plain,
    METHOD_MIDPOINT: _points_midpoint,
    METHOD_LEAPFROG: _points_leapfrog,
}
_PARALLEL = {
    METHOD_EM: _parallel_em,
    METHOD_EM_PLAIN: _parallel_em_plain,
    METHOD_MIDPOINT: _parallel_midpoint,
    METHOD_LEAPFROG: _parallel_leapfrog,
}


def ensemble_chunk(method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail):
    """Advance every point ``nrec * every`` composed steps on one thread.

    method     METHOD_EM, METHOD_EM_PLAIN (roundoff="fast"), METHOD_MIDPOINT or METHOD_LEAPFROG;
               the other arguments as in
               :func:`~.pointmass.implicit_chunk` (``fail`` pre-filled with -1; leapfrog
               ignores ``max_iter`` and counts no iterations).
    """
    if x.shape[1] < _PACKED_MIN:  # a kernel of the point-by-point path alone: less to compile
        _POINTS[method](
            x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, 0, x.shape[1]
        )
    else:
        _RANGE[method](
            x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, 0, x.shape[1]
        )


def ensemble_chunk_parallel(
    method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail
):
    """:func:`ensemble_chunk` on all of Numba's threads (blocks are independent, and each
    point's result is the same as on one thread). The threads claim blocks from a shared
    counter as they finish the previous ones (:mod:`.atomic`): a thread that runs slower,
    on a core shared with other work, takes fewer blocks instead of holding up the run."""
    _PARALLEL[method](
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        numba.get_num_threads(),
    )
