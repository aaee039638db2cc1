r"""Energy-momentum time finite elements for point masses under a set of effects: orders 4 and 6.

Method: the Gauss collocation of :mod:`.tfe` in space, unknowns the scaled stage forces
``phi_l = h^2 F_l`` (k, 3) of each point,

    Q_l = x0 + h c_l v0 + sum_j (a^2)_lj phi_j,   V_l = v0 + sum_j a_lj phi_j / h,
    x1 = x0 + h v0 + sum_j b_j (1 - c_j) phi_j,    v1 = v0 + sum_j b_j phi_j / h,
    F_l = N_l + (1 + nu P_l) C_l,   P_l = V_l . C_l,
    nu = (G . (x1 - x0) - h sum_l b_l P_l) / (h sum_l b_l P_l^2),

C_l the force per unit mass at (Q_l, t0 + c_l h) of the effects whose potential U does not
change in time, N_l the others' (MODE_EXPLICIT), G their em step's discrete force over
(x0, x1), whose work is exactly ``U(x0) - U(x1)``. Gauss' ``b_i a_ij + b_j a_ji = b_i b_j``
(a and b to 20 digits with their low parts) makes ``|v1|^2/2 - |v0|^2/2 = h sum b_l V_l . F_l``
exact for any stage values, so nu makes C's work equal U's drop, and ``E1 - E0 = W`` exactly,
W each working effect's row: its force's work at the stages, ``h sum_l b_l m V_l . N_l``
(MODE_POINT), plus, for a potential that changes in time (a third body, a turning field), the
potential's change over the step: that row is the work of the change in time to order 2k.
nu is O(h^{2k}), so the order is 2k; C's forces are scaled by one number, so the angular
momentum they keep (about the centre, about the pole) is kept. Near a circular orbit every
P_l is small and a step may fail (it is then redone in sub-steps); it is never wrong in
energy.

Newton on each point's 3k unknowns: Jacobian ``delta_lj I - 2 h^2 (a^2)_lj W_l`` (W_l the
set's x0 = x1 Jacobian, half the gradient for symmetric discrete forces; nu's response left
out), a dense 3k x 3k solve; started from the last step's force polynomial, or the forces at
x0. A point stops when its update is below ``2^-53`` of its largest phi, or the next would be,
or it stalls below ``2^-40``; a point's steps do not depend on the other points.

Data layout: x, v, cx, cv (3, n) with Kahan compensation; m (n,); body (n,); ``coef_c``
(k_e, n) the set's coefficients of C's effects (others' rows 0), ``coef_n`` of the others;
the set's P, I, T, S; work, cwork (w, n), rec_work (nrec, w, n); ``row_effect`` (w,) the set
index of a row's effect where its potential changes in time, else -1; records rec_x, rec_v
(nrec, 3, n), rec_iters (nrec, n), fail (n, 2).

References: P. Betsch, P. Steinmann, J. Comput. Phys. 160 (2000) 88-116; E. Hairer, JNAIAM 5
(2010) 73-84; E. Hairer, C. Lubich, G. Wanner, Geometric Numerical Integration (2006), IV.2.
"""

from __future__ import annotations

import math

import numpy as np

from ..codes import STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from ..effects.signatures import MODE_EXPLICIT, MODE_POINT, MODE_STEP
from ..eft import kahan_add
from ..jit import kernel
from ..rigid_solve import dense_solve
from .effect_step import stop_records
from .tfe import _extrapolation

__all__ = ["effect_tfe_chunk", "effect_tfe_step", "tfe_scratch"]

_TOL = 2.0**-53
_FLOOR = 2.0**-40


@kernel
def tfe_scratch(k, n, ne, nw):
    """Scratch of :func:`effect_tfe_step` for k stages, n points, ne effects and nw work rows."""
    return (
        np.zeros((k, 6, n)), np.empty((k, 3, n)), np.empty((k, 3, n)), np.zeros((k, 3, n)), np.empty((k, 9, n)),
        np.zeros((k, 9, n)), np.empty((k, n)), np.empty((3, n)), np.empty((6, n)), np.empty((6, n)),
        np.empty((3, n)), np.empty((9, n)), np.zeros(n), np.empty(n), np.empty((3 * k, 3 * k)), np.empty(3 * k),
        np.empty((nw, n)), np.zeros((nw, n)), np.empty((3, n)), np.zeros(n, np.int64), np.empty((ne, n)),
    )  # fmt: skip


@kernel
def _stages(tab, lo, x, v, cx, cv, phi, Q, V, h):
    """The stage positions Q (k, 6, n: high parts, then low parts with the compensation cx) and
    velocities V (k, 3, n) from phi (a's low parts ``lo`` joining the velocities' sums)."""
    k = tab.shape[0]
    for l in range(k):
        for c in range(3):
            for i in range(x.shape[1]):
                p = h * tab[l, 0] * v[c, i]
                u = 0.0
                ul = 0.0
                for j in range(k):
                    p += tab[l, 3 + k + j] * phi[j, c, i]
                    u += tab[l, 3 + j] * phi[j, c, i]
                    ul += lo[l, 1 + j] * phi[j, c, i]
                s = x[c, i] + p
                bb = s - x[c, i]
                Q[l, c, i] = s
                Q[l, 3 + c, i] = ((x[c, i] - (s - bb)) + (p - bb)) + cx[c, i]
                V[l, c, i] = v[c, i] + ((u + ul) / h + cv[c, i])


@kernel
def _end(tab, x, v, cx, phi, dx, X0, X1, h):
    """The step's increment dx = h v0 + sum_j b_j (1 - c_j) phi_j, and its start X0 and end X1
    (6, n: high parts, then low parts with the compensation cx)."""
    k = tab.shape[0]
    for c in range(3):
        for i in range(x.shape[1]):
            d = h * v[c, i]
            for j in range(k):
                d += tab[j, 2] * phi[j, c, i]
            dx[c, i] = d
            s = x[c, i] + d
            bb = s - x[c, i]
            X0[c, i] = x[c, i]
            X0[3 + c, i] = cx[c, i]
            X1[c, i] = s
            X1[3 + c, i] = ((x[c, i] - (s - bb)) + (d - bb)) + cx[c, i]


@kernel
def _update(tab, lo, phi, Fc, Fn, Wc, Wn, Pw, G, dx, h, i, A, rhs):
    """Newton's update of point i's phi (in ``rhs``), with its energy correction nu."""
    k = tab.shape[0]
    hh = h * h
    # the potentials' drop over the step, U(x0, t0) - U(x1, t1) + W_t, is the work of the em
    # step's discrete forces over (x0, x1) (G): exact to the round-off of F . dx, not of U
    num = G[0, i] * dx[0, i] + G[1, i] * dx[1, i] + G[2, i] * dx[2, i]
    den = 0.0
    for l in range(k):
        num -= h * (tab[l, 1] + lo[l, 0]) * Pw[l, i]
        den += h * tab[l, 1] * Pw[l, i] * Pw[l, i]
    nu = num / den if den > 0.0 else 0.0
    for l in range(k):
        f = 1.0 + nu * Pw[l, i]
        for a in range(3):
            rhs[3 * l + a] = phi[l, a, i] - hh * (Fn[l, a, i] + f * Fc[l, a, i])
            for j in range(k):
                s = -2.0 * hh * tab[l, 3 + k + j]
                for b in range(3):
                    A[3 * l + a, 3 * j + b] = s * (f * Wc[l, 3 * a + b, i] + Wn[l, 3 * a + b, i])
            A[3 * l + a, 3 * l + a] += 1.0
    return abs(nu) < math.inf and dense_solve(A, rhs, 3 * k)


@kernel
def _work(forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, coef_n, has_d, P, I, T, S, row_effect,
          t0, h, sgn, phi, sc, work, cwork):  # fmt: skip
    """Add each working effect's work over the converged step into the sums: its force's over
    the stages (MODE_POINT), plus, for a potential that changes in time (``row_effect`` >= 0:
    its effect's index), the potential's change over the step."""
    Q, V, Fc, Fn, Wc, Wn, Pw, dx, X0, X1, G, Wd, R, prev, A, rhs, out, tot, D, done, U = sc
    k = tab.shape[0]
    n = x.shape[1]
    tot[:, :] = 0.0
    _stages(tab, lo, x, v, cx, cv, phi, Q, V, h)
    for l in range(k):
        tl = t0 + sgn * tab[l, 0] * h
        prepare(tl, tl, tl, P, I, T, S)
        for c in range(3):
            for i in range(n):
                D[c, i] = h * (tab[l, 1] + lo[l, 0]) * V[l, c, i]
        work_of(Q[l], D, m, body, coef_n, h, MODE_POINT, P, I, T, S, out)
        for r in range(out.shape[0]):
            for i in range(n):
                tot[r, i] += out[r, i]
    if has_d:
        _end(tab, x, v, cx, phi, dx, X0, X1, h)
        for end in range(2):
            te = t0 + sgn * h if end == 0 else t0
            prepare(te, te, te, P, I, T, S)
            potential(X1 if end == 0 else X0, m, body, coef_n, P, I, T, S, U)
            for r in range(out.shape[0]):
                e = row_effect[r]
                if e >= 0:
                    for i in range(n):
                        tot[r, i] += U[e, i] if end == 0 else -U[e, i]
    for r in range(tot.shape[0]):
        for i in range(n):
            work[r, i], cwork[r, i] = kahan_add(work[r, i], cwork[r, i], tot[r, i])


@kernel
def effect_tfe_step(
    forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, coef_c, coef_n, has_n, has_d, P, I, T, S,
    work, cwork, row_effect, t0, h, sgn, max_iter, predicted, phi, sc,
):  # fmt: skip
    """One step of size h > 0 of every point from time t0 to t0 + sgn h (module notes; ``sgn``
    -1: the clock runs backwards, the velocities reversed): the state and the work sums
    updated in place where it succeeds, left as they were where not. ``phi`` (k, 3, n) holds
    the predictor where ``predicted`` and the solution after; ``sc`` is :func:`tfe_scratch`.
    Returns (Newton sweeps, status)."""
    Q, V, Fc, Fn, Wc, Wn, Pw, dx, X0, X1, G, Wd, R, prev, A, rhs, out, tot, D, done, U = sc
    k = tab.shape[0]
    n = x.shape[1]
    if not predicted:  # the forces at x0 at every stage
        for c in range(3):
            Q[0, c, :] = x[c]
            Q[0, 3 + c, :] = cx[c]
        prepare(t0, t0, t0, P, I, T, S)
        bad = forces(Q[0], Q[0], m, body, coef_c, h, MODE_EXPLICIT, P, I, T, S, Fc[0], Wc[0], R, False, True)
        if has_n:
            bad += forces(Q[0], Q[0], m, body, coef_n, h, MODE_EXPLICIT, P, I, T, S, Fn[0], Wn[0], R, False, True)
        if bad:
            return 0, STATUS_SINGULAR
        for l in range(k):
            for c in range(3):
                for i in range(n):
                    phi[l, c, i] = h * h * (Fc[0, c, i] + Fn[0, c, i])
    for i in range(n):
        done[i] = 0
        prev[i] = math.inf
    sweeps = 0
    while sweeps < max_iter:
        sweeps += 1
        _stages(tab, lo, x, v, cx, cv, phi, Q, V, h)
        bad = 0
        for l in range(k):
            tl = t0 + sgn * tab[l, 0] * h
            prepare(tl, tl, tl, P, I, T, S)
            bad += forces(Q[l], Q[l], m, body, coef_c, h, MODE_EXPLICIT, P, I, T, S, Fc[l], Wc[l], R, True, True)
            if has_n:
                bad += forces(Q[l], Q[l], m, body, coef_n, h, MODE_EXPLICIT, P, I, T, S, Fn[l], Wn[l], R, True, True)
            for i in range(n):
                Pw[l, i] = V[l, 0, i] * Fc[l, 0, i] + V[l, 1, i] * Fc[l, 1, i] + V[l, 2, i] * Fc[l, 2, i]
        _end(tab, x, v, cx, phi, dx, X0, X1, h)
        prepare(t0, t0 + sgn * 0.5 * h, t0 + sgn * h, P, I, T, S)
        bad += forces(X0, X1, m, body, coef_c, h, MODE_STEP, P, I, T, S, G, Wd, R, False, True)
        if bad:
            return sweeps, STATUS_SINGULAR
        running = 0
        for i in range(n):
            if done[i] == 1:
                continue
            if not _update(tab, lo, phi, Fc, Fn, Wc, Wn, Pw, G, dx, h, i, A, rhs):
                return sweeps, STATUS_SINGULAR
            d = 0.0
            scale = 0.0
            for l in range(k):
                for a in range(3):
                    phi[l, a, i] -= rhs[3 * l + a]
                    d = max(d, abs(rhs[3 * l + a]))
                    scale = max(scale, abs(phi[l, a, i]))
            if not d < math.inf:
                return sweeps, STATUS_SINGULAR
            if d <= _TOL * scale or (prev[i] < math.inf and d * d <= _TOL * scale * prev[i]):
                done[i] = 1  # at round-off, or the next update, by the contraction seen, would be
            elif d >= prev[i]:
                if not d < _FLOOR * scale:
                    return sweeps, STATUS_NO_CONVERGENCE
                done[i] = 1  # stalled at round-off
            else:
                prev[i] = d
                running += 1
        if running == 0:
            break
    if running:
        return sweeps, STATUS_NO_CONVERGENCE
    if work.shape[0] > 0:
        _work(
            forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, coef_n, has_d, P, I, T, S,
            row_effect, t0, h, sgn, phi, sc, work, cwork,
        )  # fmt: skip
    for c in range(3):
        for i in range(n):
            d = h * v[c, i]
            u = 0.0
            ul = 0.0
            for j in range(k):
                d += tab[j, 2] * phi[j, c, i]
                u += tab[j, 1] * phi[j, c, i]
                ul += lo[j, 0] * phi[j, c, i]
            x[c, i], cx[c, i] = kahan_add(x[c, i], cx[c, i], d)
            v[c, i], cv[c, i] = kahan_add(v[c, i], cv[c, i], (u + ul) / h)
    return sweeps, STATUS_OK


@kernel
def effect_tfe_chunk(
    forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, coef_c, coef_n, has_n, has_d, P, I, T, S,
    work, cwork, rec_work, row_effect, clock_base, clock_n0, dt, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail,
):  # fmt: skip
    """Advance every point ``nrec * every`` steps of size ``dt``, recording every ``every``.

    Step j of the chunk starts at ``clock_base + (clock_n0 + j) dt`` (s from the epoch). Each
    step after the first starts Newton from the previous one's force polynomial. On a failure
    every point stops before the failing step (the records from there on repeat that state)
    and ``fail`` names the step and the status. Other arguments: the module's docstring.
    """
    k = tab.shape[0]
    n = x.shape[1]
    sc = tfe_scratch(k, n, coef_c.shape[0], work.shape[0])
    phi = np.empty((k, 3, n))
    last = np.empty((k, 3, n))
    ext = _extrapolation(tab, 1.0)
    have = False
    for r in range(nrec):
        for i in range(n):
            rec_iters[r, i] = 0
        for s in range(every):
            if have:
                for l in range(k):
                    for c in range(3):
                        for i in range(n):
                            f = 0.0
                            for j in range(k):
                                f += ext[l, j] * last[j, c, i]
                            phi[l, c, i] = f
            sweeps, status = effect_tfe_step(
                forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, coef_c, coef_n, has_n, has_d, P,
                I, T, S, work, cwork, row_effect, clock_base + (clock_n0 + r * every + s) * dt, dt, 1.0, max_iter,
                have, phi, sc,
            )  # fmt: skip
            for i in range(n):
                rec_iters[r, i] += sweeps
            if status != STATUS_OK:
                stop_records(x, v, work, rec_x, rec_v, rec_work, fail, r, r * every + s, status)
                return
            last[:, :, :] = phi
            have = True
        rec_x[r, :, :] = x
        rec_v[r, :, :] = v
        rec_work[r, :, :] = work
