r"""Energy-momentum time finite elements for point masses under a set of effects: orders 4 to 12.

Method: :mod:`.tfe`'s Gauss collocation in space, unknowns ``phi_l = h^2 F_l`` (k, 3) per point,
``V_l = v0 + sum_j a_lj phi_j / h``, ``Q_l = x0 + h sum_j a_lj V_j``, ``x1 = x0 + h sum_j b_j V_j``,
``v1 = v0 + sum_j b_j phi_j / h`` (a, b with their 20-digit low parts), and

    F_l = N_l + (1 + nu P_l) C_l,   P_l = V_l . C_l,   s_l = (Q_l - c) . V_l,
    nu = (GM h sum_l b_l s_l (r_l^-3 - K) + G . (x1 - x0) - h sum_l b_l P^o_l) / (h sum_l b_l P_l^2),

C_l the central field (formed here) plus the set's effects whose potential does not change in
time, N_l the others' (each at (Q_l, t0 + c_l h), MODE_EXPLICIT; where a force among them depends
on the velocity, over ``Q_l -+ h V_l / 2``, MODE_POINT: the others at its midpoint Q_l, drag
with its mean velocity V_l), G the static effects' em force over (x0, x1) (its work is
their potential's drop exactly), P^o_l their power, ``K = 2 / (r0 r1 (r0 + r1))``. ``b_i a_ij +
b_j a_ji = b_i b_j`` makes ``|v1|^2/2 - |v0|^2/2 = h sum b_l V_l . F_l`` and ``r1^2 - r0^2 = 2 h
sum b_l s_l`` exact for any stage values, so nu makes the scaled forces' work equal the
potentials' drop and ``E1 - E0 = W`` exactly, W each working effect's row: its force's work at
the stages (MODE_POINT, the velocity V_l), plus, for a potential that changes in time, its change
over the step (the work of that change to order 2k). The central part of nu is a sum of terms in
s_l, so its round-off shrinks with the radial motion as the denominator does. nu is O(h^{2k}):
order 2k; one factor per stage keeps the angular momentum the scaled forces keep (about the
centre, about the pole).

Newton on each point's 3k unknowns: ``delta_lj I - 2 h^2 (a^2)_lj W_l`` (W_l the set's x0 = x1
Jacobian, half the gradient) plus nu's response (rank one), a dense solve, started from the
last step's force polynomial or the forces at x0. A point stops when its update is below
``2^-53`` of phi (or the next would be), stalls below ``2^-40``, or, below ``2^-36``, where the
iterate's energy balance closes to 2 eps of its terms; a point's steps do not depend on the
others'.

Data layout: x, v, cx, cv (3, n) with Kahan compensation; m (n,); body (n,); gm, ctr (3,) the
central field (gm 0: none); ``coef_c`` (k_e, n) the set's coefficients of the other static
effects (others' rows 0), ``coef_n`` of the rest (the central row 0 in both); P, I, T, S;
work, cwork (w, n), rec_work (nrec, w, n); ``row_effect`` (w,) the set index of a row's effect
where its potential changes in time, else -1; records rec_x, rec_v (nrec, 3, n), rec_iters
(nrec, n), fail (n, 2).

References: P. Betsch, P. Steinmann, J. Comput. Phys. 160 (2000) 88-116; E. Hairer, JNAIAM 5
(2010) 73-84; E. Hairer, C. Lubich, G. Wanner, Geometric Numerical Integration (2006), IV.2.
"""

from __future__ import annotations

import math

import numpy as np

from ..codes import STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from ..copies import copy1, copy2, copy3
from ..effects.signatures import MODE_EXPLICIT, MODE_POINT, MODE_STEP
from ..eft import kahan_add
from ..jit import kernel
from ..rigid_solve import dense_solve
from .effect_step import stop_records
from .tfe import _extrapolation

__all__ = ["effect_tfe_chunk", "effect_tfe_step", "tfe_scratch"]

_TOL = 2.0**-53
_FLOOR = 2.0**-40
#: updates of a point that may grow (above the floor) before its step fails
_REGRESSIONS = 3
#: ``has_n`` where some of the other effects' forces depend on the velocity (drag)
_MOVING = 2
#: an update below this fraction of phi ends Newton where the iterate keeps the energy ...
_LOOSE = 2.0**-36
#: ... to this many eps of the energy change's terms (:func:`_energy_gap`)
_GAP = 2.0 * 2.0**-52


@kernel
def tfe_scratch(k, n, ne, nw, ns):
    """Scratch of :func:`effect_tfe_step` for k stages, n points, ne effects, nw work rows and
    an effect scratch of ns values (what ``prepare`` fills, kept for each stage's time)."""
    return (
        np.zeros((k, 6, n)), np.empty((k, 3, n)), np.empty((k, 3, n)), np.zeros((k, 3, n)), np.empty((k, 9, n)),
        np.zeros((k, 9, n)), np.empty((k, n)), np.empty((3, n)), np.empty((6, n)), np.empty((6, n)),
        np.empty((3, n)), np.empty((9, n)), np.zeros(n), np.empty(n), np.empty((3 * k, 3 * k)), np.empty(3 * k),
        np.empty((nw, n)), np.zeros((nw, n)), np.empty((3, n)), np.zeros(n, np.int64), np.empty((ne, n)),
        np.empty((k, 3 * k)), np.empty(3 * k), np.zeros((3, k, n)), np.zeros((3, n)), np.empty((k + 1, ns)),
    )  # fmt: skip


@kernel
def _stages(tab, lo, x, v, cx, cv, phi, Q, V, h):
    """The stage velocities ``V_l = v0 + sum_j a_lj phi_j / h`` (k, 3, n) and positions ``Q_l =
    x0 + h sum_j a_lj V_j`` (k, 6, n: high parts, then low parts with the compensation cx),
    with a's low parts ``lo``: so ``|Q|^2`` and ``|V|^2`` change over the step by the exact node
    sums, whatever the stage values, to the round-off of the sums themselves."""
    k = tab.shape[0]
    for l in range(k):
        for c in range(3):
            for i in range(x.shape[1]):
                u = 0.0
                ul = 0.0
                for j in range(k):
                    u += tab[l, 3 + j] * phi[j, c, i]
                    ul += lo[l, 1 + j] * phi[j, c, i]
                V[l, c, i] = v[c, i] + ((u + ul) / h + cv[c, i])
    for l in range(k):
        for c in range(3):
            for i in range(x.shape[1]):
                p = 0.0
                for j in range(k):
                    p += h * (tab[l, 3 + j] + lo[l, 1 + j]) * V[j, c, i]
                s = x[c, i] + p
                bb = s - x[c, i]
                Q[l, c, i] = s
                Q[l, 3 + c, i] = ((x[c, i] - (s - bb)) + (p - bb)) + cx[c, i]


@kernel
def _end(tab, lo, x, cx, V, dx, X0, X1, h):
    """The step's increment ``dx = h sum_j b_j V_j`` (b with its low parts), and its start X0
    and end X1 (6, n: high parts, then low parts with the compensation cx)."""
    k = tab.shape[0]
    for c in range(3):
        for i in range(x.shape[1]):
            d = 0.0
            for j in range(k):
                d += h * (tab[j, 1] + lo[j, 0]) * V[j, c, i]
            dx[c, i] = d
            s = x[c, i] + d
            bb = s - x[c, i]
            X0[c, i] = x[c, i]
            X0[3 + c, i] = cx[c, i]
            X1[c, i] = s
            X1[3 + c, i] = ((x[c, i] - (s - bb)) + (d - bb)) + cx[c, i]


@kernel
def _central_stage(gm, ctr, Q, V, F, W, Pw, Cs):
    """Add the central field at the stage positions Q (6, n) to the static forces F (3, n) and
    their half gradients W (9, n), and set the powers Pw (n,); keep s = q . V, 1 / r^3 and the
    other static effects' power in Cs (3, n)."""
    for i in range(Q.shape[1]):
        po = V[0, i] * F[0, i] + V[1, i] * F[1, i] + V[2, i] * F[2, i]
        Cs[2, i] = po
        Pw[i] = po
        if gm == 0.0:
            continue
        q0 = (Q[0, i] - ctr[0]) + Q[3, i]
        q1 = (Q[1, i] - ctr[1]) + Q[4, i]
        q2 = (Q[2, i] - ctr[2]) + Q[5, i]
        r2 = q0 * q0 + q1 * q1 + q2 * q2
        ir3 = 1.0 / (r2 * math.sqrt(r2))
        s = q0 * V[0, i] + q1 * V[1, i] + q2 * V[2, i]
        Cs[0, i] = s
        Cs[1, i] = ir3
        g = -gm * ir3
        F[0, i] += g * q0
        F[1, i] += g * q1
        F[2, i] += g * q2
        Pw[i] += g * s
        t = -3.0 / r2
        W[0, i] += 0.5 * g * (1.0 + t * q0 * q0)
        W[1, i] += 0.5 * g * t * q0 * q1
        W[2, i] += 0.5 * g * t * q0 * q2
        W[3, i] += 0.5 * g * t * q1 * q0
        W[4, i] += 0.5 * g * (1.0 + t * q1 * q1)
        W[5, i] += 0.5 * g * t * q1 * q2
        W[6, i] += 0.5 * g * t * q2 * q0
        W[7, i] += 0.5 * g * t * q2 * q1
        W[8, i] += 0.5 * g * (1.0 + t * q2 * q2)


@kernel
def _central_ends(gm, ctr, X0, X1, dx, Ce):
    """The central field over the step from X0 to X1 (6, n): ``K = 2 / (r0 r1 (r0 + r1))``,
    ``dK/dr1 / r1`` and the potential's drop ``GM (1/r1 - 1/r0)`` as its em force's work,
    ``-GM K (q0 + q1) . dx / 2`` (per unit mass), into Ce (3, n)."""
    for i in range(X0.shape[1]):
        if gm == 0.0:
            Ce[0, i] = 0.0
            Ce[1, i] = 0.0
            Ce[2, i] = 0.0
            continue
        a0 = (X0[0, i] - ctr[0]) + X0[3, i]
        a1 = (X0[1, i] - ctr[1]) + X0[4, i]
        a2 = (X0[2, i] - ctr[2]) + X0[5, i]
        b0 = (X1[0, i] - ctr[0]) + X1[3, i]
        b1 = (X1[1, i] - ctr[1]) + X1[4, i]
        b2 = (X1[2, i] - ctr[2]) + X1[5, i]
        r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
        kk = 2.0 / (r0 * r1 * (r0 + r1))
        Ce[0, i] = kk
        Ce[1, i] = -kk * (r0 + 2.0 * r1) / (r1 * r1 * (r0 + r1))
        Ce[2, i] = -0.5 * gm * kk * ((a0 + b0) * dx[0, i] + (a1 + b1) * dx[1, i] + (a2 + b2) * dx[2, i])


@kernel
def _energy_gap(tab, lo, phi, Fn, V, G, dx, Ce, h, i):
    """How far point i's iterate phi misses the energy balance, and the size of its terms:
    ``h sum_l b_l V_l . (phi_l / h^2 - N_l) - G . dx - drop`` (the kinetic energy's change less
    the non-conservative work, less the potentials' drop: the other static effects' and the
    central field's ``Ce[2]``), per unit mass."""
    k = tab.shape[0]
    gap = 0.0
    size = 0.0
    for l in range(k):
        w = (tab[l, 1] + lo[l, 0]) / h
        for a in range(3):
            t = w * V[l, a, i] * (phi[l, a, i] - h * h * Fn[l, a, i])
            gap += t
            size += abs(t)
    for a in range(3):
        t = G[a, i] * dx[a, i]
        gap -= t
        size += abs(t)
    gap -= Ce[2, i]
    return gap, size + abs(Ce[2, i])


@kernel
def _update(tab, lo, phi, Fc, Fn, Wc, Wn, Pw, V, G, Wd, dx, gm, ctr, Q, X1, Cs, Ce, h, i, A, rhs, dP, dnu):
    """Newton's update of point i's phi (in ``rhs``), with its energy correction nu and nu's
    response to phi (a rank-one term of the matrix: where every P_l is small, nu's denominator
    is, and leaving it out would stall Newton)."""
    k = tab.shape[0]
    hh = h * h
    # nu's numerator: the other static effects' drop over the step, U(x0) - U(x1), is the work
    # of their em forces over (x0, x1) (G), less their work at the stages; the central field's,
    # GM h sum_l b_l s_l (1 / r_l^3 - K), is a sum of terms in s_l, so that its round-off
    # shrinks with the radial motion as the denominator does
    num = G[0, i] * dx[0, i] + G[1, i] * dx[1, i] + G[2, i] * dx[2, i]
    den = 0.0
    for l in range(k):
        w = h * (tab[l, 1] + lo[l, 0])
        num += w * (gm * Cs[0, l, i] * (Cs[1, l, i] - Ce[0, i]) - Cs[2, l, i])
        den += h * tab[l, 1] * Pw[l, i] * Pw[l, i]
    nu = num / den if den > 0.0 else 0.0
    # dP_l / dphi_j = (a_lj / h) C_l + (a^2)_lj J_l^T V_l, J_l = 2 Wc_l the force's gradient
    for l in range(k):
        for b in range(3):
            jv = 2.0 * (Wc[l, b, i] * V[l, 0, i] + Wc[l, 3 + b, i] * V[l, 1, i] + Wc[l, 6 + b, i] * V[l, 2, i])
            for j in range(k):
                dP[l, 3 * j + b] = (tab[l, 3 + j] + lo[l, 1 + j]) / h * Fc[l, b, i] + tab[l, 3 + k + j] * jv
    # dnu / dphi_j = (dnum - nu dden) / den; dnum = b_j (1 - c_j) (G + Wd^T dx) - h sum_l b_l dP_l
    for j in range(k):
        for b in range(3):
            c = 3 * j + b
            wd = Wd[b, i] * dx[0, i] + Wd[3 + b, i] * dx[1, i] + Wd[6 + b, i] * dx[2, i]
            dn = tab[j, 2] * (G[b, i] + wd)
            dd = 0.0
            q1 = (X1[b, i] - ctr[b]) + X1[3 + b, i]
            for l in range(k):
                w = h * (tab[l, 1] + lo[l, 0])
                dn -= w * dP[l, c]
                dd += 2.0 * h * tab[l, 1] * Pw[l, i] * dP[l, c]
                if gm != 0.0:  # the central part: -GM h sum_l b_l (ds_l K + s_l dK)
                    ql = (Q[l, b, i] - ctr[b]) + Q[l, 3 + b, i]
                    ds = tab[l, 3 + k + j] * V[l, b, i] + (tab[l, 3 + j] + lo[l, 1 + j]) / h * ql
                    dn -= gm * w * (ds * Ce[0, i] + Cs[0, l, i] * Ce[1, i] * tab[j, 2] * q1)
            dnu[c] = (dn - nu * dd) / den if den > 0.0 else 0.0
    for l in range(k):
        f = 1.0 + nu * Pw[l, i]
        for a in range(3):
            rhs[3 * l + a] = phi[l, a, i] - hh * (Fn[l, a, i] + f * Fc[l, a, i])
            for j in range(k):
                s = -2.0 * hh * tab[l, 3 + k + j]
                for b in range(3):
                    c = 3 * j + b
                    A[3 * l + a, c] = s * (f * Wc[l, 3 * a + b, i] + Wn[l, 3 * a + b, i]) - hh * Fc[l, a, i] * (
                        Pw[l, i] * dnu[c] + nu * dP[l, c]
                    )
            A[3 * l + a, 3 * l + a] += 1.0
    return abs(nu) < math.inf and dense_solve(A, rhs, 3 * k)


@kernel
def _work(forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, coef_n, has_n, has_d, P, I, T, S,
          row_effect, t0, h, sgn, phi, sc, work, cwork):  # fmt: skip
    """Add each working effect's work over the converged step into the sums: its force's over
    the stages (MODE_POINT; a force that depends on the velocity, ``has_n`` 2, reads the stage
    velocity as the displacement over ``sgn h b_l``), plus, for a potential that changes in time
    (``row_effect`` >= 0: its effect's index), the potential's change over the step."""
    Q, V, Fc, Fn, Wc, Wn, Pw, dx, X0, X1, G, Wd, R, prev, A, rhs, out, tot, D, done, U, dP, dnu, Cs, Ce, Sk = sc
    k = tab.shape[0]
    n = x.shape[1]
    tot[:, :] = 0.0
    _stages(tab, lo, x, v, cx, cv, phi, Q, V, h)
    for l in range(k):
        copy1(S, Sk[l])  # the stage's time, as the sweeps prepared it
        for c in range(3):
            for i in range(n):
                D[c, i] = h * (tab[l, 1] + lo[l, 0]) * V[l, c, i]
        hl = sgn * h * (tab[l, 1] + lo[l, 0]) if has_n == _MOVING else h
        work_of(Q[l], D, m, body, coef_n, hl, MODE_POINT, P, I, T, S, out)
        for r in range(out.shape[0]):
            for i in range(n):
                tot[r, i] += out[r, i]
    if has_d:
        _end(tab, lo, x, cx, V, dx, X0, X1, h)
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
def _others(forces, has_n, q, v, hs, m, body, coef_n, h, P, I, T, S, F, W, R, X0, X1, jac):
    """The other effects' forces at the points q with velocities v (``has_n`` :data:`_MOVING`:
    some depend on the velocity, which they read from the segment ``(q - hs v / 2, q + hs v /
    2)`` over h, the others at its midpoint, MODE_POINT; else at q, MODE_EXPLICIT); ``X0``,
    ``X1`` scratch (at least 3, n). Returns the set's status."""
    if has_n != _MOVING:
        return forces(q, q, m, body, coef_n, h, MODE_EXPLICIT, P, I, T, S, F, W, R, jac, True)
    for c in range(3):
        for i in range(m.shape[0]):
            d = 0.5 * hs * v[c, i]
            X0[c, i] = q[c, i] - d
            X1[c, i] = q[c, i] + d
    return forces(X0, X1, m, body, coef_n, h, MODE_POINT, P, I, T, S, F, W, R, jac, True)


@kernel
def effect_tfe_step(
    forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, gm, ctr, coef_c, coef_n, has_n, has_d, P, I,
    T, S, work, cwork, row_effect, t0, h, sgn, max_iter, predicted, phi, sc,
):  # fmt: skip
    """One step of size h > 0 of every point from time t0 to t0 + sgn h (module notes; ``sgn``
    -1: the clock runs backwards, the velocities reversed): the state and the work sums
    updated in place where it succeeds, left as they were where not. ``phi`` (k, 3, n) holds
    the predictor where ``predicted`` and the solution after; ``sc`` is :func:`tfe_scratch`.
    Returns (Newton sweeps, status)."""
    Q, V, Fc, Fn, Wc, Wn, Pw, dx, X0, X1, G, Wd, R, prev, A, rhs, out, tot, D, done, U, dP, dnu, Cs, Ce, Sk = sc
    k = tab.shape[0]
    n = x.shape[1]
    if not predicted:  # the forces at x0 at every stage
        for c in range(3):
            copy1(Q[0, c], x[c])
            copy1(Q[0, 3 + c], cx[c])
        prepare(t0, t0, t0, P, I, T, S)
        bad = forces(Q[0], Q[0], m, body, coef_c, h, MODE_EXPLICIT, P, I, T, S, Fc[0], Wc[0], R, False, True)
        if has_n:
            bad += _others(
                forces, has_n, Q[0], v, sgn * h, m, body, coef_n, h, P, I, T, S, Fn[0], Wn[0], R, X0, X1, False
            )
        if bad:
            return 0, STATUS_SINGULAR
        for i in range(n):
            q0 = (x[0, i] - ctr[0]) + cx[0, i]
            q1 = (x[1, i] - ctr[1]) + cx[1, i]
            q2 = (x[2, i] - ctr[2]) + cx[2, i]
            r2 = q0 * q0 + q1 * q1 + q2 * q2
            g = -gm / (r2 * math.sqrt(r2)) if gm != 0.0 else 0.0
            for l in range(k):
                phi[l, 0, i] = h * h * (Fc[0, 0, i] + Fn[0, 0, i] + g * q0)
                phi[l, 1, i] = h * h * (Fc[0, 1, i] + Fn[0, 1, i] + g * q1)
                phi[l, 2, i] = h * h * (Fc[0, 2, i] + Fn[0, 2, i] + g * q2)
    for i in range(n):
        done[i] = 0
        prev[i] = math.inf
    has_c = False  # static effects beside the central field
    for e in range(coef_c.shape[0]):
        for i in range(n):
            has_c = has_c or coef_c[e, i] != 0.0
    sweeps = 0
    while sweeps < max_iter:
        sweeps += 1
        _stages(tab, lo, x, v, cx, cv, phi, Q, V, h)
        bad = 0
        for l in range(k):
            if sweeps == 1:  # what the effects read at the stage's time, kept for the next sweeps
                tl = t0 + sgn * tab[l, 0] * h
                prepare(tl, tl, tl, P, I, T, S)
                copy1(Sk[l], S)
            else:
                copy1(S, Sk[l])
            if has_c:
                bad += forces(Q[l], Q[l], m, body, coef_c, h, MODE_EXPLICIT, P, I, T, S, Fc[l], Wc[l], R, True, True)
            else:  # the central field alone is static: the kernel's own
                Fc[l, :, :] = 0.0
                Wc[l, :, :] = 0.0
            if has_n:
                bad += _others(forces, has_n, Q[l], V[l], sgn * h, m, body, coef_n, h, P, I, T, S, Fn[l], Wn[l], R, X0,
                               X1, True)  # fmt: skip
            _central_stage(gm, ctr, Q[l], V[l], Fc[l], Wc[l], Pw[l], Cs[:, l])
        _end(tab, lo, x, cx, V, dx, X0, X1, h)
        _central_ends(gm, ctr, X0, X1, dx, Ce)
        if has_c:
            if sweeps == 1:
                prepare(t0, t0 + sgn * 0.5 * h, t0 + sgn * h, P, I, T, S)
                copy1(Sk[k], S)
            else:
                copy1(S, Sk[k])
            bad += forces(X0, X1, m, body, coef_c, h, MODE_STEP, P, I, T, S, G, Wd, R, True, True)
        else:
            G[:, :] = 0.0
            Wd[:, :] = 0.0
        if bad:
            return sweeps, STATUS_SINGULAR
        running = 0
        for i in range(n):
            if done[i] == 1:
                continue
            gap, size = _energy_gap(tab, lo, phi, Fn, V, G, dx, Ce, h, i)
            ok = _update(tab, lo, phi, Fc, Fn, Wc, Wn, Pw, V, G, Wd, dx, gm, ctr, Q, X1, Cs, Ce, h, i, A, rhs, dP, dnu)
            if not ok:
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
            elif d >= prev[i] and d < _FLOOR * scale:
                done[i] = 1  # stalled at round-off
            elif d < _LOOSE * scale and abs(gap) <= _GAP * size:
                # nu's round-off, amplified where every P_l is small, keeps the update above
                # the floor: the iterate before it keeps the energy to round-off, take it
                for l in range(k):
                    for a in range(3):
                        phi[l, a, i] += rhs[3 * l + a]
                done[i] = 1
            else:
                if d >= prev[i]:  # an update that grew: a few are allowed while nu settles
                    done[i] -= 1
                    if done[i] < -_REGRESSIONS:
                        return sweeps, STATUS_NO_CONVERGENCE
                prev[i] = d
                running += 1
        if running == 0:
            break
    if running:
        return sweeps, STATUS_NO_CONVERGENCE
    if work.shape[0] > 0:
        _work(
            forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, coef_n, has_n, has_d, P, I, T, S,
            row_effect, t0, h, sgn, phi, sc, work, cwork,
        )  # fmt: skip
    _stages(tab, lo, x, v, cx, cv, phi, Q, V, h)  # the solution's, for its end
    _end(tab, lo, x, cx, V, dx, X0, X1, h)
    for c in range(3):
        for i in range(n):
            u = 0.0
            ul = 0.0
            for j in range(k):
                u += tab[j, 1] * phi[j, c, i]
                ul += lo[j, 0] * phi[j, c, i]
            x[c, i], cx[c, i] = kahan_add(x[c, i], cx[c, i], dx[c, i])
            v[c, i], cv[c, i] = kahan_add(v[c, i], cv[c, i], (u + ul) / h)
    return sweeps, STATUS_OK


@kernel
def effect_tfe_chunk(
    forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, gm, ctr, coef_c, coef_n, has_n, has_d, P, I,
    T, S, work, cwork, rec_work, row_effect, clock_base, clock_n0, dt, every, nrec, max_iter, rec_x, rec_v, rec_iters,
    fail,
):  # fmt: skip
    """Advance every point ``nrec * every`` steps of size ``dt``, recording every ``every``.

    Step j of the chunk starts at ``clock_base + (clock_n0 + j) dt`` (s from the epoch). Each
    step after the first starts Newton from the previous one's force polynomial. On a failure
    every point stops before the failing step (the records from there on repeat that state)
    and ``fail`` names the step and the status. Other arguments: the module's docstring.
    """
    k = tab.shape[0]
    n = x.shape[1]
    sc = tfe_scratch(k, n, coef_c.shape[0], work.shape[0], S.shape[0])
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
                forces, prepare, work_of, potential, tab, lo, x, v, cx, cv, m, body, gm, ctr, coef_c, coef_n, has_n,
                has_d, P, I, T, S, work, cwork, row_effect, clock_base + (clock_n0 + r * every + s) * dt, dt, 1.0,
                max_iter, have, phi, sc,
            )  # fmt: skip
            for i in range(n):
                rec_iters[r, i] += sweeps
            if status != STATUS_OK:
                stop_records(x, v, work, rec_x, rec_v, rec_work, fail, r, r * every + s, status)
                return
            copy3(last, phi)
            have = True
        copy2(rec_x[r], x)
        copy2(rec_v[r], v)
        copy2(rec_work[r], work)
