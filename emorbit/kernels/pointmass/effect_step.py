"""Point masses under a set of effects: fixed steps of em, midpoint or leapfrog, for any set.

The effects come compiled (:mod:`emorbit.kernels.effects.signatures`: ``forces``,
``prepare``, ``work``), as arguments: these kernels compile once, whatever the set.

em and midpoint, each sub-step ``h = gamma_k dt`` of the composition: the unknowns are the
second-order parts ``w_i`` of the increments ``x1_i - x0_i = h v0_i + w_i``, and

    w_i = (h^2 / 2) F_i(x0, x1),    v1_i = v0_i + 2 w_i / h

with F_i the sum of the effects' forces per unit mass on point i: their discrete forces over
the step for em (MODE_STEP), the conservative ones at the midpoint for the midpoint rule
(MODE_MIDPOINT), and the pair forces with every other point. The iteration starts from the
last sub-step's w scaled by (h / h_last)^2 (``wp``, ``hp``: state, checkpointed), or, for em
with a central field, from the central step's series plus the rest of that w (:func:`_predict`).
Each sweep evaluates every point's force, diagonal Jacobian block and pair coupling at the
iterates (``forces``), then updates every point by Newton on its own 3 x 3 block
(:func:`emorbit.kernels.effects.newton.newton_update`; ``dense``, a few points under pair
effects: on the whole system with the pair blocks (``cross``), by LU). Sweeps stop when every
update is below 4 eps of its increment, or stalled at round-off (below 128 eps, no longer
halving), or, after a second sweep, is below 1e-8 with the next update estimated at 1e-3 eps:
the update times the larger of the measured contraction and the pair coupling (3 h^2 times
the bound of sum_j |dF_i / dx_j|); or, em after the first sweep, where every effect's J is
exact or leaves out a bounded part (``loose``) and no pair couples the points, each update is
below 2**-20 of its increment and the remainder it leaves (:func:`_curvature`) below 1e-3 eps
of it. Positions and velocities are updated with Kahan compensation.

leapfrog (explicit effects only): kick-drift-kick, ``v_1/2 = v0 + h/2 F(x0)``,
``x1 = x0 + h v_1/2``, ``v1 = v_1/2 + h/2 F(x1)``, with the forces at points (MODE_EXPLICIT).

Time: step j of the chunk starts at ``clock_base + (clock_n0 + j) dt``; a sub-step's start,
middle and end are prepared once. A working effect adds its work on every point into ``work[k,
i]`` (J) with Kahan compensation in ``cwork``; a failed step puts the sums back with the state.

Data layout: x, v, cx, cv, wp (3, n); hp (1,); m (n,); body (n,) int64; coef (k, n) and the
set's ``P, I, T, S`` (:mod:`emorbit.kernels.effects.signatures`); work and cwork (w, n),
rec_work (nrec, w, n); records rec_x, rec_v (nrec, 3, n), rec_iters (nrec, n), fail (n, 2)
(the step index and status of a failure, -1 where none).
"""

from __future__ import annotations

import math

import numpy as np

from ..codes import METHOD_LEAPFROG, METHOD_MIDPOINT, STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from ..copies import copy1, copy2
from ..effects.newton import newton_update
from ..effects.signatures import MODE_EXPLICIT, MODE_MIDPOINT, MODE_STEP
from ..jit import kernel
from ..rigid_solve import dense_solve

__all__ = ["effect_chunk", "effect_substep", "step_scratch", "method_mode", "stop_records", "substep_times"]

_EPS = 2.0**-52
#: the largest first update, relative to the increment, that may end a sub-step (see
#: :func:`_curvature`)
_ONE_UPDATE = 2.0**-20


@kernel(inline="always")
def _central_w(d0, d1, d2, v0, v1, v2, ir2, ir3, dv, vv, gm, h):
    """The central em step's w from ``d = x0 - c``, ``v0`` over a step h, as a series:
    ``w = -W d - (h W / 2) v0``, ``W = s (1 + 3/2 p + 5/2 p^2 + s - 3/4 q)``, ``s = h^2/2 GM /
    r^3``, ``p = -h d . v0 / r^2``, ``q = h^2 v0 . v0 / r^2`` (as
    :func:`emorbit.kernels.effects.zonal_packed._predict`'s central part); ``ir2 = 1 / r^2``,
    ``ir3 = 1 / r^3``, ``dv = d . v0``, ``vv = v0 . v0``."""
    s = 0.5 * h * h * gm * ir3
    p = -h * dv * ir2
    q = h * h * vv * ir2
    W = s * (1.0 + p * (1.5 + 2.5 * p) + s - 0.75 * q)
    hw = 0.5 * h * W
    return -(W * d0 + hw * v0), -(W * d1 + hw * v1), -(W * d2 + hw * v2)


@kernel
def _predict(w, x, v, wp, ctr, gm, h, hp, scale):
    """em's first guess of w: the central field's step as a series (:func:`_central_w`) plus
    the rest of the last sub-step's w, rescaled: ``w = Wc(h) + scale (wp - Wc(-hp))``. The
    last sub-step ended at (x, v), so its w is the em step back from there over ``-hp``
    (em's discrete forces are symmetric in their ends), and ``wp - Wc(-hp)`` is what the
    other effects (and the series' own error) added to it."""
    for i in range(x.shape[1]):
        d0, d1, d2 = x[0, i] - ctr[0], x[1, i] - ctr[1], x[2, i] - ctr[2]
        v0, v1, v2 = v[0, i], v[1, i], v[2, i]
        ir2 = 1.0 / (d0 * d0 + d1 * d1 + d2 * d2)
        ir3 = ir2 * math.sqrt(ir2)
        dv = d0 * v0 + d1 * v1 + d2 * v2
        vv = v0 * v0 + v1 * v1 + v2 * v2
        a0, a1, a2 = _central_w(d0, d1, d2, v0, v1, v2, ir2, ir3, dv, vv, gm, h)
        if hp != 0.0:
            b0, b1, b2 = _central_w(d0, d1, d2, v0, v1, v2, ir2, ir3, dv, vv, gm, -hp)
            a0 += scale * (wp[0, i] - b0)
            a1 += scale * (wp[1, i] - b1)
            a2 += scale * (wp[2, i] - b2)
        w[0, i], w[1, i], w[2, i] = a0, a1, a2


@kernel(inline="always")
def _curvature(x0, x1, W, ctr, gm, hh, size, i):
    """Point i's Newton remainder after one update, relative to the increment ``size``, as
    ``quad upd^2 + loose lin upd`` (upd the update over ``size``): (quad, lin). ``quad =
    kappa size + 3 |h^2/2 (W - Wc)|_1`` (the sum of the entries' magnitudes, above the
    Frobenius norm), with the central field's ``kappa = 8 h^2/2 K / r1`` (as
    :mod:`emorbit.kernels.effects.zonal_packed`) and the other effects' Jacobian (``W`` less
    the central field's ``Wc = -K I + K (r0 + 2 r1) / (r1^2 (r0 + r1)) (d0 + d1) d1^T``, ``K =
    GM / Q``, ``Q = r0 r1 (r0 + r1)``) taken to change by its own size over the increment at
    most: the update's part in their second derivative; ``lin = 4 h^2/2 K`` bounds ``|h^2/2
    Wc|``, of which a set's pieces may leave out a part (``loose``), the remainder's linear
    term. One division: ``1 / r1 = r0 (r0 + r1) / Q``."""
    a0, a1, a2 = x0[0, i] - ctr[0], x0[1, i] - ctr[1], x0[2, i] - ctr[2]
    b0, b1, b2 = x1[0, i] - ctr[0], x1[1, i] - ctr[1], x1[2, i] - ctr[2]
    r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    iQ = 1.0 / (r0 * r1 * (r0 + r1))
    K = gm * iQ
    ir1 = r0 * (r0 + r1) * iQ
    g = K * (r0 + 2.0 * r1) * ir1 * (r0 * iQ)
    u0, u1, u2 = a0 + b0, a1 + b1, a2 + b2
    rest = (
        abs(W[0, i] - g * u0 * b0 + K) + abs(W[1, i] - g * u0 * b1) + abs(W[2, i] - g * u0 * b2)
        + abs(W[3, i] - g * u1 * b0) + abs(W[4, i] - g * u1 * b1 + K) + abs(W[5, i] - g * u1 * b2)
        + abs(W[6, i] - g * u2 * b0) + abs(W[7, i] - g * u2 * b1) + abs(W[8, i] - g * u2 * b2 + K)
    )  # fmt: skip
    return 8.0 * hh * K * ir1 * size + 3.0 * hh * rest, 4.0 * hh * K


@kernel(forceinline=True)
def _update_point(w, v, U, h, i, d0, d1, d2):
    """Point i's w less the update d, the update's square over the squared increment into
    ``U[0, i]`` (inf where not finite) and that squared increment into ``U[2, i]``. Inlined
    by LLVM (Numba's own inlining of a function that takes arrays keeps the loops that call it
    from vectorising)."""
    w0, w1, w2 = w[0, i] - d0, w[1, i] - d1, w[2, i] - d2
    w[0, i], w[1, i], w[2, i] = w0, w1, w2
    size2 = (h * v[0, i] + w0) ** 2 + (h * v[1, i] + w1) ** 2 + (h * v[2, i] + w2) ** 2
    upd2 = (d0 * d0 + d1 * d1 + d2 * d2) / max(size2, 1e-300)
    U[0, i] = upd2 if upd2 < math.inf else math.inf
    U[2, i] = size2


@kernel
def _newton_pass(W, F, w, v, U, hh, h):
    """One Newton update of every point's w on its own 3 x 3 block
    (:func:`~emorbit.kernels.effects.newton.newton_update`; :func:`_update_point`): a loop
    without branches or reductions, which LLVM vectorises."""
    for i in range(w.shape[1]):
        r0, r1, r2 = w[0, i] - hh * F[0, i], w[1, i] - hh * F[1, i], w[2, i] - hh * F[2, i]
        d0, d1, d2 = newton_update(W, i, hh, r0, r1, r2)
        _update_point(w, v, U, h, i, d0, d1, d2)


@kernel
def _dense_pass(rhs, w, v, U, h):
    """The whole system's Newton update (``rhs``, :func:`_dense_update`) applied to every
    point (:func:`_update_point`)."""
    for i in range(w.shape[1]):
        _update_point(w, v, U, h, i, rhs[3 * i], rhs[3 * i + 1], rhs[3 * i + 2])


@kernel
def _curvature_pass(x0, x1, W, v, w, U, ctr, gm, hh, h, loose):
    """Each point's remainder bound after the update (:func:`_curvature`) into ``U[1]``, from
    its update and squared increment in ``U[0]`` and ``U[2]`` (a loop LLVM vectorises)."""
    for i in range(w.shape[1]):
        quad, lin = _curvature(x0, x1, W, ctr, gm, hh, math.sqrt(U[2, i]), i)
        upd2 = U[0, i]
        t = loose * lin * math.sqrt(upd2)
        U[1, i] = quad * upd2 + (t if loose > 0.0 else 0.0)


@kernel(inline="always")
def substep_times(clock_base, j, k, tcum, dt):
    """The start, middle and end time of sub-step k of step j (s from the epoch)."""
    ns = tcum.shape[0] - 1
    ta = clock_base + (j + tcum[k] if k > 0 else j) * dt
    tb = clock_base + (j + 1.0 if k == ns - 1 else j + tcum[k + 1]) * dt
    return ta, 0.5 * (ta + tb), tb


@kernel(inline="always")
def _kahan(s, c, d):
    """Add d to s with the compensation c (the error carried with its sign): (s, c)."""
    y = d + c
    t = s + y
    return t, y - (t - s)


@kernel
def _add_work(work, cwork, out):
    for k in range(work.shape[0]):
        for i in range(work.shape[1]):
            work[k, i], cwork[k, i] = _kahan(work[k, i], cwork[k, i], out[k, i])


@kernel
def step_scratch(n, nw, dense):
    """Scratch for :func:`effect_substep` of n points and nw working effects: dx (3, n), x1
    (6, n: the end positions and their low parts), w, F, G (3, n), W (9, n), R (n,) (the pair
    coupling bounds, kept between sweeps), U (3, n) (each point's last update, remainder
    bound and squared increment, :func:`_newton_pass`, :func:`_curvature_pass`), the work
    per point (nw, n), and where ``dense`` the whole Newton matrix A (3n, 3n) with its
    right-hand side (3n,) and the pair blocks ``acc`` (n, n, 4, 4, 3, 3) with their slot
    coefficients (4, n) and flags (n,) (empty where not), and the start positions with their
    low parts (6, n)."""
    k = n if dense else 0
    sc = np.zeros((4, k))
    sc[0, :] = 1.0
    return (
        np.empty((3, n)), np.empty((6, n)), np.empty((3, n)), np.empty((3, n)), np.empty((3, n)),
        np.empty((9, n)), np.zeros(n), np.empty((3, n)), np.empty((nw, n)),
        np.empty((3 * k, 3 * k)), np.empty(3 * k), np.zeros((k, k, 4, 4, 3, 3)), sc, np.ones(k),
        np.empty((6, n)),
    )  # fmt: skip


@kernel(inline="always")
def _end(x, cx, dx, x1):
    """The end positions ``x + dx`` (rows 0-2 of ``x1``, rounded as a plain sum) with their low
    parts (rows 3-5: the sum's rounding error plus the compensation ``cx``)."""
    for c in range(3):
        xr, dr, cr, hi, lo = x[c], dx[c], cx[c], x1[c], x1[3 + c]
        for i in range(xr.shape[0]):
            s = xr[i] + dr[i]
            bb = s - xr[i]
            hi[i] = s
            lo[i] = ((xr[i] - (s - bb)) + (dr[i] - bb)) + cr[i]


@kernel(inline="always")
def _increments(dx, v, w, h):
    """``dx = h v + w``, row by row."""
    for c in range(3):
        dr, vr, wr = dx[c], v[c], w[c]
        for i in range(dr.shape[0]):
            dr[i] = h * vr[i] + wr[i]


@kernel
def _dense_update(A, rhs, acc, W, F, w, m, hh):
    """Newton's update of all points at once, into ``rhs``: the solution of A d = w - hh F,
    A = I - hh dF/dx1 with every point's own block (W) and the pair blocks between points
    (``acc[a, b, 0, 0] = -d(m_a F_a)/dx1_b``, the same for b, a), by Gaussian elimination with
    partial pivoting. Returns False where A is singular."""
    n = W.shape[1]
    A[:, :] = 0.0
    for i in range(n):
        for a in range(3):
            rhs[3 * i + a] = w[a, i] - hh * F[a, i]
            for b in range(3):
                A[3 * i + a, 3 * i + b] = (1.0 if a == b else 0.0) - hh * W[3 * a + b, i]
    for i in range(n):
        for j in range(i + 1, n):
            for a in range(3):
                for b in range(3):
                    c = hh * acc[i, j, 0, 0, a, b]
                    A[3 * i + a, 3 * j + b] = c / m[i]
                    A[3 * j + a, 3 * i + b] = c / m[j]
    return dense_solve(A, rhs, 3 * n)


@kernel
def method_mode(method):
    """The effect set's mode of a method code."""
    if method == METHOD_MIDPOINT:
        return MODE_MIDPOINT
    if method == METHOD_LEAPFROG:
        return MODE_EXPLICIT
    return MODE_STEP


@kernel
def effect_substep(
    forces, cross, prepare, work_of, mode, x, v, cx, cv, wp, hp, m, body, coef, P, I, T, S, work, cwork, h, ta, tb,
    max_iter, scratch, central,
):  # fmt: skip
    """One sub-step of size h from time ``ta`` to ``tb`` of every point (the state, the warm
    start and the work sums updated in place where it succeeds; left as they were where not);
    ``central`` = (GM, centre, loose): the central field's (row 0 of the set; GM 0 where the
    set has none) and the bound of the Jacobian the set's pieces leave out, relative to the
    central field's (inf: unknown). Returns (Newton sweeps, status)."""
    dx, x1, w, F, G, W, R, U, out, A, rhs, acc, sc, on, x0 = scratch
    gm, ctr, loose = central
    dense = A.shape[0] > 0
    n = x.shape[1]
    hh = 0.5 * h * h
    for c in range(3):  # the start with its compensation: pair effects form separations from both
        copy1(x0[c], x[c])
        copy1(x0[3 + c], cx[c])
    prepare(ta, 0.5 * (ta + tb), tb, P, I, T, S)
    status = STATUS_OK
    sweeps = 0
    if mode == MODE_EXPLICIT:
        status = forces(x0, x0, m, body, coef, h, mode, P, I, T, S, F, W, R, False, True)
        for i in range(n):
            for c in range(3):
                dx[c, i] = h * (v[c, i] + 0.5 * h * F[c, i])
        _end(x, cx, dx, x1)
        if status == STATUS_OK:
            status = forces(x1, x1, m, body, coef, h, mode, P, I, T, S, G, W, R, False, True)
        sweeps = 1
        for i in range(n):
            for c in range(3):
                w[c, i] = 0.25 * h * h * (F[c, i] + G[c, i])  # v1 = v0 + 2 w / h
    else:
        scale = (h / hp[0]) ** 2 if hp[0] != 0.0 else 0.0  # the last sub-step's w, rescaled
        one = gm > 0.0 and loose < math.inf and mode == MODE_STEP and not dense  # predictor, one update
        if one:
            _predict(w, x, v, wp, ctr, gm, h, hp[0], scale)
        else:
            for c in range(3):
                wr, pr = w[c], wp[c]
                for i in range(n):
                    wr[i] = pr[i] * scale
        _increments(dx, v, w, h)
        prev = math.inf
        status = STATUS_NO_CONVERGENCE
        for it in range(max_iter):
            _end(x, cx, dx, x1)
            st = forces(x0, x1, m, body, coef, h, mode, P, I, T, S, F, W, R, True, it == 0)
            if dense:
                cross(x0, x1, m, body, coef, on, sc, acc, P, I, T, S)
                if not _dense_update(A, rhs, acc, W, F, w, m, hh):
                    st = STATUS_SINGULAR
            if dense:
                _dense_pass(rhs, w, v, U, h)
            else:
                _newton_pass(W, F, w, v, U, hh, h)
            first = one and it == 0
            if first:
                _curvature_pass(x0, x1, W, v, w, U, ctr, gm, hh, h, loose)
            worst = 0.0  # the largest update over its increment, and the remainder bound
            after = 0.0
            coupling = 0.0
            for i in range(n):
                worst = max(worst, U[0, i])
                coupling = max(coupling, 6.0 * hh * R[i])
            if first:
                for i in range(n):
                    after = max(after, U[1, i])
            worst = math.sqrt(worst)
            sweeps += 1
            _increments(dx, v, w, h)  # Jacobi: the next sweep's forces see every update
            if st != STATUS_OK or not worst < math.inf:
                status = STATUS_SINGULAR
                break
            # at round-off; or stalled there; or small enough that the next update, the larger
            # of the measured contraction (worst / prev: quadratic or linear) and the pair
            # coupling times worst, is a thousandth of round-off: an error that every step
            # leaves with the same sign adds up, so the bound is far below eps
            if (
                (one and it == 0 and coupling == 0.0 and worst <= _ONE_UPDATE and after <= 1e-3 * _EPS)
                or worst <= 4.0 * _EPS
                or (worst <= 128.0 * _EPS and worst > 0.5 * prev)
                or (prev < math.inf and worst <= 1e-8 and worst * max(worst / prev, coupling) <= 1e-3 * _EPS)
            ):
                status = STATUS_OK
                break
            prev = worst
    if status != STATUS_OK:
        return sweeps, status
    if work.shape[0] > 0:
        work_of(x, dx, m, body, coef, h, mode, P, I, T, S, out)
        _add_work(work, cwork, out)
    for c in range(3):
        xr, cxr, dr, vr, cvr, wr = x[c], cx[c], dx[c], v[c], cv[c], w[c]
        for i in range(n):
            xr[i], cxr[i] = _kahan(xr[i], cxr[i], dr[i])
        for i in range(n):
            vr[i], cvr[i] = _kahan(vr[i], cvr[i], 2.0 * wr[i] / h)
        copy1(wp[c], wr)
    hp[0] = h
    return sweeps, STATUS_OK


@kernel
def stop_records(x, v, work, rec_x, rec_v, rec_work, fail, r, step, status):
    """Where step ``step`` of record ``r`` failed: every point's ``fail`` row names it, and the
    records from r on repeat the state (x, v, work) the points stop at."""
    for i in range(x.shape[1]):
        fail[i, 0] = step
        fail[i, 1] = status
    for rr in range(r, rec_x.shape[0]):
        copy2(rec_x[rr], x)
        copy2(rec_v[rr], v)
        copy2(rec_work[rr], work)


@kernel
def effect_chunk(
    forces, cross, prepare, work_of, method, x, v, cx, cv, wp, hp, m, body, coef, P, I, T, S, work, cwork, rec_work,
    clock_base, clock_n0, dt, gammas, every, nrec, max_iter, dense, rec_x, rec_v, rec_iters, fail, central,
):  # fmt: skip
    """Advance all points ``nrec * every`` composed steps, recording every ``every``.

    ``forces``, ``prepare``, ``work_of``: the effect set's compiled functions; ``method``:
    METHOD_EM, METHOD_MIDPOINT or METHOD_LEAPFROG; ``central``: see :func:`effect_substep`. On
    a failure every point stops before the
    failing step (the records from there on repeat that state) and ``fail`` names the step and
    the status. Other arguments: the module's docstring.
    """
    n = x.shape[1]
    ns = gammas.shape[0]
    mode = method_mode(method)
    nw = work.shape[0]
    scratch = step_scratch(n, nw, dense)
    sx = np.empty((5, 3, n))  # the state at the start of a composed step: x, v, cx, cv, wp
    sw = np.empty((2, nw, n))  # work, cwork at the composed step's start
    tcum = np.empty(ns + 1)
    tcum[0] = 0.0
    for k in range(ns):
        tcum[k + 1] = tcum[k] + gammas[k]
    hp0 = hp[0]
    for r in range(nrec):
        for i in range(n):
            rec_iters[r, i] = 0
        for s in range(every):
            copy2(sx[0], x)
            copy2(sx[1], v)
            copy2(sx[2], cx)
            copy2(sx[3], cv)
            copy2(sx[4], wp)
            copy2(sw[0], work)
            copy2(sw[1], cwork)
            hp0 = hp[0]
            for k in range(ns):
                ta, tm, tb = substep_times(clock_base, clock_n0 + r * every + s, k, tcum, dt)
                sweeps, status = effect_substep(
                    forces, cross, prepare, work_of, mode, x, v, cx, cv, wp, hp, m, body, coef, P, I, T, S, work,
                    cwork, dt * gammas[k], ta, tb, max_iter, scratch, central,
                )  # fmt: skip
                for i in range(n):
                    rec_iters[r, i] += sweeps
                if status != STATUS_OK:
                    copy2(x, sx[0])
                    copy2(v, sx[1])
                    copy2(cx, sx[2])
                    copy2(cv, sx[3])
                    copy2(wp, sx[4])
                    hp[0] = hp0
                    copy2(work, sw[0])
                    copy2(cwork, sw[1])
                    stop_records(x, v, work, rec_x, rec_v, rec_work, fail, r, r * every + s, status)
                    return
        copy2(rec_x[r], x)
        copy2(rec_v[r], v)
        copy2(rec_work[r], work)
