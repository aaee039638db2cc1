r"""Energy-momentum time finite elements for rigid bodies: orders 4 to 12 in one implicit solve.

State of a body in a step: ``y = (phi, d1, d2, d3, u, M)`` (18): centre of mass, axes in space
(``R = [d1 d2 d3]``), its velocity, body angular momentum; ``Omega = J^-1 M``, ``J = tr E - E``::

    phi' = u,  R' = R [Omega]x,  m u' = F,  M' = M x Omega + tau,  F = sum_i f_i,
    tau = R^-1 sum_i (R X_i) x f_i,   f_i = (1 + nu P_l) m_i g(p_i),   p_i = phi - c + R X_i

over the gravity points (mass points; the centre of mass for the point model), ``g(p) = -GM
p / |p|^3``, P_l gravity's power ``F . u + tau . Omega`` at stage l. A step is k-stage Gauss
collocation (Hairer's energy-preserving collocation; the cG(k) element of Betsch & Steinmann),
order 2k. Quadratic invariants change by exact node sums (``b_i a_ij + b_j a_ji = b_i b_j``,
kept to 20 digits by :func:`.pointmass.tfe.low_parts`), so for any stage values: ``R R^T`` stays I
(``(R R^T)' = 0`` for any R); ``L = (phi - c) x m u + R M`` changes by ``h sum_l b_l sum_i
p_il x f_il = 0`` (radial forces; ``R^-1`` where a rotation has ``R^T``); ``T = m|u|^2/2 +
M.J^-1 M/2`` by ``h sum_l b_l P_l (1 + nu P_l)``. nu makes that equal the potential's drop,
``U_i(1) - U_i(0) = GM m_i (r1^2 - r0^2) / (r0 r1 (r0 + r1))`` from the increments: the energy
is exact, not the rule's order; nu is O(h^{2k}) and P_l mirrors under ``h -> -h``, so the
order stays 2k and the step symmetric.

Solve: Newton on the stage increments Z (k, 18), residual ``Z_l - h sum_j a_lj f_j(y0 + Z_j)``,
matrix ``I - h a (x) Jf`` (:mod:`.rigid_tfe_newton`: 3k x 3k blocks) factored at a first guess and kept for the
next step after one of at most 3 iterations; nu's response through P (rank k) by Woodbury.
Newton holds nu; a safeguarded secant on nu zeroes the energy change ``e(nu)`` below 2 eps of
the power's terms. First guess: the last step's stage derivatives extrapolated; the axes'
rounding is taken off after each step (first-order polar factor). Stops as
:func:`.pointmass.tfe.tfe_step` does, each group of y against its increment (the axes also
against the centre's over the body's size, M also against the torque's moments).
Limits: in a near-circular orbit P is small; beyond about h n = 0.14 (order 4) or 0.27 (order
6) the secant may not settle and the step fails with ``STATUS_NO_CONVERGENCE``. Effects at the
gravity points (:mod:`.rigid_tfe_effects`): static ones scaled with f_i and in U, others not.
Data layout: the rigid kernels' ``q, v, cq, cv`` (nb, 12), converted at a chunk's start (``M =
R^T sum E_kl d_k x dd_l``) and back at its end (``dd_k = R (Omega x e_k)``); records ``rec_q,
rec_v`` (nrec, nb, 12), ``rec_iters`` (nrec, nb), ``fail`` (nb, 2).

References: P. Betsch, P. Steinmann, J. Comput. Phys. 160 (2000) 88-116; Int. J. Numer. Meth.
Eng. 50 (2001) 1931-1955 (directors); E. Hairer, JNAIAM 5 (2010) 73-84; E. Hairer, C. Lubich,
G. Wanner, Geometric Numerical Integration (2006), IV.2; M. A. Woodbury (1950).
"""

from __future__ import annotations

import math

import numpy as np

from .codes import GRAVITY_NONE, GRAVITY_POINT, STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from .copies import copy1, copy2
from .eft import kahan_add
from .jit import kernel
from .pointmass.tfe import _extrapolation
from .rigid_solve import lu, lu_solve
from .rigid_tfe_effects import body_context, prepare_step, stage_forces, static_rise, step_work
from .rigid_tfe_newton import factor_rotation, inverse3, rotation_jacobian, solve_without_correction, torque_jacobian

__all__ = ["body_gravity", "rigid_tfe_chunk", "rigid_tfe_step", "step_scratch", "store_state"]

_TOL = 2.0**-53
_FLOOR = 2.0**-40
#: the energy's change is round-off below this fraction of the power's terms
_E_TOL = 2.0 * 2.0**-52
#: ... and a secant that stops shrinking it is at its floor below this one
_E_FLOOR = 64.0 * 2.0**-52
#: secant updates of the energy correction at most
_SECANTS = 8
#: Newton's factors are kept for the next step after a step of at most this many iterations
_REUSE_ITERATIONS = 3
#: a secant slope below this fraction of the direct response is not trusted
_SLOPE_MIN = 0.01
#: the groups of y whose updates are weighed against their own increments
_GROUPS = ((0, 3), (3, 12), (12, 15), (15, 18))


@kernel(forceinline=True)
def _load(L, mj, A, j, q0, q1, q2, V0, V1, V2):
    """Add point j's load ``e = mj A[:, j]`` to L (9): its force, its moment ``q x e``, its
    power ``e . V`` and the round-off scales ``|e| |q|``, ``|e| |V|``."""
    e0 = mj * A[0, j]
    e1 = mj * A[1, j]
    e2 = mj * A[2, j]
    L[0] += e0
    L[1] += e1
    L[2] += e2
    L[3] += q1 * e2 - q2 * e1
    L[4] += q2 * e0 - q0 * e2
    L[5] += q0 * e1 - q1 * e0
    L[6] += e0 * V0 + e1 * V1 + e2 * V2
    f = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    L[7] += f * math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    L[8] += f * math.sqrt(V0 * V0 + V1 * V1 + V2 * V2)


@kernel(forceinline=True)
def _field(y, Jinv, Xg, mg, mass, gm, c, K, D, R, Ri, Dh, gP, Fc, Fn, has_c, has_n, Lx):
    """The field at ``y`` (18) into ``K`` (18) without the energy correction, and the
    correction per unit nu, ``P`` times gravity's acceleration and torque, into ``D`` (18);
    returns ``(sum_i m_i s_i / r_i^3, P^2, sum_i |f_i| |R X_i|, sum_i |f_i| |V_i|, P_s)`` with
    ``s_i = p_i . V_i``, ``V_i = u + (R^-T Omega) x (R X_i)`` (so ``P = -GM`` times the first
    plus ``P_s``): the torque's and the power's round-off scales, then the static effects'
    power. ``Dh`` (6): gravity's acceleration and torque; ``gP`` (9): P's gradient in (phi, u,
    M), ``(m G u, m a, J^-1 tau)``. ``Xg`` (3, N), ``mg`` (N,): the gravity points; ``Fc``,
    ``Fn`` (3, N): the static and the other effects' accelerations there (read where
    ``has_c``, ``has_n``; :mod:`.rigid_tfe_effects`), the first scaled with the field, the
    second not; R, Ri: 3 x 3 scratch; Lx (2, 9): their loads (:func:`_load`)."""
    for k in range(3):
        for i in range(3):
            R[i, k] = y[3 + 3 * k + i]
    om0 = Jinv[0, 0] * y[15] + Jinv[0, 1] * y[16] + Jinv[0, 2] * y[17]
    om1 = Jinv[1, 0] * y[15] + Jinv[1, 1] * y[16] + Jinv[1, 2] * y[17]
    om2 = Jinv[2, 0] * y[15] + Jinv[2, 1] * y[16] + Jinv[2, 2] * y[17]
    for i in range(3):
        K[i] = y[12 + i]
        K[3 + i] = om2 * y[6 + i] - om1 * y[9 + i]  # d1' = Omega3 d2 - Omega2 d3
        K[6 + i] = om0 * y[9 + i] - om2 * y[3 + i]  # d2' = Omega1 d3 - Omega3 d1
        K[9 + i] = om1 * y[3 + i] - om0 * y[6 + i]  # d3' = Omega2 d1 - Omega1 d2
        D[i] = 0.0
        D[3 + i] = 0.0
        D[6 + i] = 0.0
        D[9 + i] = 0.0
    K[15] = y[16] * om2 - y[17] * om1
    K[16] = y[17] * om0 - y[15] * om2
    K[17] = y[15] * om1 - y[16] * om0
    n = mg.shape[0]
    if (gm == 0.0 and not (has_c or has_n)) or n == 0:
        for i in range(12, 15):
            K[i] = 0.0
        for i in range(12, 18):
            D[i] = 0.0
        for i in range(6):
            Dh[i] = 0.0
        for i in range(9):
            gP[i] = 0.0
        return 0.0, 0.0, 0.0, 0.0, 0.0
    inverse3(R, Ri)
    # R^-T Omega, the angular velocity that pairs with the torque R^-1 w
    a0 = Ri[0, 0] * om0 + Ri[1, 0] * om1 + Ri[2, 0] * om2
    a1 = Ri[0, 1] * om0 + Ri[1, 1] * om1 + Ri[2, 1] * om2
    a2 = Ri[0, 2] * om0 + Ri[1, 2] * om1 + Ri[2, 2] * om2
    F0 = F1 = F2 = 0.0
    w0 = w1 = w2 = 0.0
    sa = 0.0
    ta = 0.0
    pa = 0.0
    # the static effects' force, torque and power; the others' force and torque
    Fs0 = Fs1 = Fs2 = ws0 = ws1 = ws2 = po = 0.0
    Fn0 = Fn1 = Fn2 = wn0 = wn1 = wn2 = 0.0
    if has_c or has_n:
        Lx[:, :] = 0.0
    for j in range(n):
        X0 = Xg[0, j]
        X1 = Xg[1, j]
        X2 = Xg[2, j]
        q0 = R[0, 0] * X0 + R[0, 1] * X1 + R[0, 2] * X2
        q1 = R[1, 0] * X0 + R[1, 1] * X1 + R[1, 2] * X2
        q2 = R[2, 0] * X0 + R[2, 1] * X1 + R[2, 2] * X2
        p0 = y[0] - c[0] + q0
        p1 = y[1] - c[1] + q1
        p2 = y[2] - c[2] + q2
        r2 = p0 * p0 + p1 * p1 + p2 * p2
        ir3 = 1.0 / (r2 * math.sqrt(r2)) if gm != 0.0 else 0.0
        V0 = y[12] + (a1 * q2 - a2 * q1)
        V1 = y[13] + (a2 * q0 - a0 * q2)
        V2 = y[14] + (a0 * q1 - a1 * q0)
        s = p0 * V0 + p1 * V1 + p2 * V2
        mj = mg[j]
        g = -gm * mj * ir3
        F0 += g * p0
        F1 += g * p1
        F2 += g * p2
        w0 += g * (q1 * p2 - q2 * p1)
        w1 += g * (q2 * p0 - q0 * p2)
        w2 += g * (q0 * p1 - q1 * p0)
        sa += mj * s * ir3
        ta += abs(g) * math.sqrt(r2 * (q0 * q0 + q1 * q1 + q2 * q2))
        pa += abs(g) * math.sqrt(r2 * (V0 * V0 + V1 * V1 + V2 * V2))
        if has_c:
            _load(Lx[0], mj, Fc, j, q0, q1, q2, V0, V1, V2)
        if has_n:
            _load(Lx[1], mj, Fn, j, q0, q1, q2, V0, V1, V2)
    if has_c:
        Fs0, Fs1, Fs2, ws0, ws1, ws2, po = Lx[0, 0], Lx[0, 1], Lx[0, 2], Lx[0, 3], Lx[0, 4], Lx[0, 5], Lx[0, 6]
        ta += Lx[0, 7]
        pa += Lx[0, 8]
    if has_n:
        Fn0, Fn1, Fn2, wn0, wn1, wn2 = Lx[1, 0], Lx[1, 1], Lx[1, 2], Lx[1, 3], Lx[1, 4], Lx[1, 5]
        ta += Lx[1, 7]
    # the correction: gravity's force and torque times its power P = -GM sum_i m_i s_i / r_i^3
    # (with no effects the added zeros leave every bit as the field's alone)
    P = -gm * sa + po
    im = 1.0 / mass
    K[12] = (F0 + Fs0) * im
    K[13] = (F1 + Fs1) * im
    K[14] = (F2 + Fs2) * im
    w0 += ws0
    w1 += ws1
    w2 += ws2
    for i in range(3):
        t = Ri[i, 0] * w0 + Ri[i, 1] * w1 + Ri[i, 2] * w2
        K[15 + i] += t
        D[15 + i] = P * t
        Dh[3 + i] = t
    D[12] = P * K[12]
    D[13] = P * K[13]
    D[14] = P * K[14]
    for i in range(3):
        Dh[i] = K[12 + i]
        gP[3 + i] = mass * K[12 + i]
    for i in range(3):
        gP[6 + i] = Jinv[i, 0] * Dh[3] + Jinv[i, 1] * Dh[4] + Jinv[i, 2] * Dh[5]
    if has_n:  # the other effects: unscaled
        K[12] += Fn0 * im
        K[13] += Fn1 * im
        K[14] += Fn2 * im
        for i in range(3):
            K[15 + i] += Ri[i, 0] * wn0 + Ri[i, 1] * wn1 + Ri[i, 2] * wn2
    # and in phi: m G u, G gravity's gradient at the centre of mass, as of a point mass
    c0 = y[0] - c[0]
    c1 = y[1] - c[1]
    c2 = y[2] - c[2]
    rc2 = c0 * c0 + c1 * c1 + c2 * c2
    w = gm * mass / (rc2 * math.sqrt(rc2)) if gm != 0.0 else 0.0
    cu = 3.0 * (c0 * y[12] + c1 * y[13] + c2 * y[14]) / rc2 if gm != 0.0 else 0.0
    gP[0] = w * (cu * c0 - y[12])
    gP[1] = w * (cu * c1 - y[13])
    gP[2] = w * (cu * c2 - y[14])
    ss = P * P
    return sa, ss, ta, pa, po


@kernel(forceinline=True)
def _drop(y0, dy, Xg, mg, gm, c):
    """The potential's rise ``U(y0 + dy) - U(y0)`` over the gravity points, from the
    increments: ``GM m (r1^2 - r0^2) / (r0 r1 (r0 + r1))`` each."""
    out = 0.0
    for j in range(mg.shape[0]):
        X0 = Xg[0, j]
        X1 = Xg[1, j]
        X2 = Xg[2, j]
        a = 0.0
        b = 0.0
        for i in range(3):
            p = y0[i] - c[i] + y0[3 + i] * X0 + y0[6 + i] * X1 + y0[9 + i] * X2
            d = dy[i] + dy[3 + i] * X0 + dy[6 + i] * X1 + dy[9 + i] * X2
            a += p * p
            b += d * (2.0 * p + d)
        r0 = math.sqrt(a)
        r1 = math.sqrt(a + b)
        out += gm * mg[j] * b / (r0 * r1 * (r0 + r1))
    return out


@kernel
def _stage(forces, fx, l, Y, Jinv, Xg, mg, mass, gm, c, h, K, D, R, Ri, Dh, gP):
    """:func:`_field` at stage l's state Y with the effects' accelerations there
    (:func:`.rigid_tfe_effects.stage_forces`); returns its values and the set's status."""
    bad = stage_forces(forces, fx, l, Y, Xg, mg, h)
    a, b, t, p, po = _field(Y, Jinv, Xg, mg, mass, gm, c, K, D, R, Ri, Dh, gP, fx[15], fx[16], fx[8], fx[9], fx[22])
    return a, b, t, p, po, bad


@kernel
def _newton(forces, fx, tab, lo, y0, Z, Kst, h, Jinv, Xg, mg, mass, gm, c, size, max_iter, nu, work):
    """Newton on the stage increments ``Z`` at a fixed energy correction ``nu``; returns
    ``(iterations, status, e, scale, den)``: the energy's change per unit time over the step,
    ``e = sum_l b_l P_l (1 + nu P_l) + (U(y1) - U(y0)) / h``, its round-off scale and ``de /
    dnu`` at fixed stages, ``sum_l b_l P_l^2``, all at the last evaluation. Each group of
    y's update is weighed against its increment; an axis's also against the centre's
    increment over the body's size (``sqrt(tr E / m)``: what moves its mass points as much),
    the angular momentum's also against the moments that the torque sums, so that the
    torque's rounding (and through it the axes') is a floor, not a failure. The static effects'
    power and potential rise join the field's (:mod:`.rigid_tfe_effects`)."""
    (Jst, P, pivP, Pinv, V, Sr, pivS, tm, D, Y, R, Ri, dy, sa, ss, ta, pa, dlo, Nt, pivt, rt, Gs, W, Dh, gP, S,
     pivs, zv, Ts, Zb) = work  # fmt: skip
    k = tab.shape[0]
    prev = math.inf
    status = STATUS_NO_CONVERGENCE
    its = 0
    num = 0.0
    den = 0.0
    pw = 0.0
    numo = 0.0
    bad = 0
    while its < max_iter:
        its += 1
        numo = 0.0
        for l in range(k):
            for i in range(18):
                Y[i] = y0[i] + Z[l, i]
            a, b, t, p, po, bad = _stage(forces, fx, l, Y, Jinv, Xg, mg, mass, gm, c, h, Kst[l], D[l], R, Ri, Dh[l],
                                         gP[l])  # fmt: skip
            sa[l] = a
            ss[l] = b
            ta[l] = t
            pa[l] = p
            numo += tab[l, 1] * po
            for i in range(12, 18):
                Kst[l, i] += nu * D[l, i]
        if bad:
            status = STATUS_SINGULAR
            break
        num = 0.0
        den = 0.0
        pw = 0.0
        for i in range(12):
            dy[i] = 0.0
        for l in range(k):
            bl = tab[l, 1]
            num += bl * sa[l]
            den += bl * ss[l]
            pw += bl * pa[l]
            for i in range(12):
                dy[i] += bl * Kst[l, i]
        # residual, rotation block solved by the factors, translation in closed form
        for l in range(k):
            for i in range(18):
                s = Z[l, i]
                for j in range(k):
                    s -= h * tab[l, 3 + j] * Kst[j, i]
                # the coefficients' low parts after the high ones have cancelled Z
                t = 0.0
                for j in range(k):
                    t += lo[l, 1 + j] * Kst[j, i]
                D[l, i] = s - h * t  # D is free again: the residual
        if not abs(D[0, 3] + D[0, 0] + D[0, 12] + D[0, 15]) < math.inf:
            status = STATUS_SINGULAR
            break
        solve_without_correction(tab, h, Jst, Pinv, V, Sr, pivS, Nt, pivt, Gs, Ts, rt, tm, D)
        if nu != 0.0:  # the correction's response to the stages' power (Woodbury)
            for j in range(k):
                W[j, :, :] = 0.0
                for l in range(k):
                    for i in range(6):
                        W[j, l, 12 + i] = h * tab[l, 3 + j] * nu * Dh[j, i]
                solve_without_correction(tab, h, Jst, Pinv, V, Sr, pivS, Nt, pivt, Gs, Ts, rt, tm, W[j])
            for i in range(k):
                t = gP[i, 0] * D[i, 0] + gP[i, 1] * D[i, 1] + gP[i, 2] * D[i, 2]
                for c2 in range(6):
                    t += gP[i, 3 + c2] * D[i, 12 + c2]
                zv[i] = t
                for j in range(k):
                    t = gP[i, 0] * W[j, i, 0] + gP[i, 1] * W[j, i, 1] + gP[i, 2] * W[j, i, 2]
                    for c2 in range(6):
                        t += gP[i, 3 + c2] * W[j, i, 12 + c2]
                    S[i, j] = (1.0 if i == j else 0.0) - t
            if not lu(S, pivs, k):
                status = STATUS_SINGULAR
                break
            lu_solve(S, pivs, zv, k)
            for j in range(k):
                for l in range(k):
                    for i in range(18):
                        D[l, i] += zv[j] * W[j, l, i]
        worst = 0.0
        zphi = 0.0
        for l in range(k):
            for i in range(3):
                zphi = max(zphi, abs(Z[l, i] - D[l, i]))
        for g in range(4):
            first, last = _GROUPS[g]
            d = 0.0
            scale = zphi / size if g == 1 else 0.0
            ref = 0.0
            for l in range(k):
                for i in range(first, last):
                    Z[l, i] -= D[l, i]
                    d = max(d, abs(D[l, i]))
                    scale = max(scale, abs(Z[l, i]))
            for i in range(first, last):
                ref = max(ref, abs(y0[i]))
            if g == 3:  # the torque: a small sum of large moments, rounded as they are
                for l in range(k):
                    scale = max(scale, abs(h) * ta[l])
            scale += 2.0**-30 * ref + 1e-300
            worst = max(worst, d / scale)
        if worst <= _TOL or (prev < math.inf and worst * worst <= _TOL * prev):
            status = STATUS_OK
            break
        if worst >= prev:
            if worst < _FLOOR:
                status = STATUS_OK
            break
        prev = worst
    e = 0.0
    if mg.shape[0] > 0 and (gm != 0.0 or fx[8] or fx[9]):
        for i in range(12):
            dy[i] *= h
        e = -gm * num + nu * den
        if gm != 0.0:
            e += _drop(y0, dy, Xg, mg, gm, c) / h
        if fx[8]:
            e += numo + static_rise(forces, fx, y0, dy, Xg, mg, h) / h
    return its, status, e, pw, den


@kernel
def rigid_tfe_step(
    forces, fx, tab, lo, y0, Z, Kst, h, Jinv, Xg, mg, mass, gm, c, size, tidal, max_iter, predicted, nu, refactor,
    work,
):  # fmt: skip
    """One step of the k-stage element from ``y0`` (18); returns ``(dy, dlo, iterations,
    status, nu)``: the increment ``h sum_l b_l K_l`` in two parts, from the weights' float64
    values and from their low parts (``lo``: :func:`.pointmass.tfe.low_parts`), and the energy correction.
    ``Z`` (k, 18) holds the stage increments (a predictor in when ``predicted``), ``Kst`` (k,
    18) the stage derivatives out (for the next predictor), ``nu`` the first guess of the
    correction (the last step's); ``tidal``: whether the torque depends on the attitude
    (volume gravity); ``work``: :func:`step_scratch`'s tuple; ``forces``, ``fx``: the effect
    set's forces and the body's effect context, prepared for the step
    (:mod:`.rigid_tfe_effects`).

    Newton holds nu fixed (:func:`_newton`); a secant on nu then zeroes the energy's change
    ``e(nu)``, each new nu starting Newton from the stages of the last. Solved inside Newton
    alongside the stages, nu chased the stages' small powers near a circular orbit and the
    iteration stalled."""
    (Jst, P, pivP, Pinv, V, Sr, pivS, tm, D, Y, R, Ri, dy, sa, ss, ta, pa, dlo, Nt, pivt, rt, Gs, W, Dh, gP, S,
     pivs, zv, Ts, Zb) = work  # fmt: skip
    k = tab.shape[0]
    if not predicted:
        if _stage(forces, fx, 0, y0, Jinv, Xg, mg, mass, gm, c, h, Kst[0], D[0], R, Ri, Dh[0], gP[0])[5]:
            return dy, dlo, 0, STATUS_SINGULAR, nu
        for l in range(1, k):
            copy1(Kst[l], Kst[0])
        for l in range(k):
            for i in range(18):
                Z[l, i] = h * tab[l, 0] * Kst[0, i]
    if refactor:
        # Newton's matrix: I - h a_lj Jf(Y_j) at the first guess of each stage (the axes turn
        # by up to h omega across the step)
        for j in range(k):
            for i in range(18):
                Y[i] = y0[i] + Z[j, i]
            rotation_jacobian(Y, Jinv, Jst[j])
            if tidal:
                torque_jacobian(Y, Xg, mg, gm, c, R, Ri, Jst[j], Ts[j])
        # the centre's: gravity's gradient at the first guess of each stage, as of a point mass
        for j in range(k):
            p0 = y0[0] + Z[j, 0] - c[0]
            p1 = y0[1] + Z[j, 1] - c[1]
            p2 = y0[2] + Z[j, 2] - c[2]
            r2 = p0 * p0 + p1 * p1 + p2 * p2
            w = 0.0
            if gm != 0.0 and mg.shape[0] > 0:
                w = gm / (r2 * math.sqrt(r2))
            pj = (p0, p1, p2)
            for r in range(3):
                for q in range(3):
                    Gs[j, 3 * r + q] = w * (3.0 * pj[r] * pj[q] / r2 - (1.0 if r == q else 0.0)) if w != 0.0 else 0.0
        for l in range(k):
            for j in range(k):
                hh = h * h * tab[l, 3 + k + j]
                for r in range(3):
                    for q in range(3):
                        Nt[3 * l + r, 3 * j + q] = -hh * Gs[j, 3 * r + q] + (1.0 if l == j and r == q else 0.0)
        if not (factor_rotation(tab, h, Jst, P, pivP, Pinv, V, Sr, pivS) and lu(Nt, pivt, 3 * k)):
            return dy, dlo, 0, STATUS_SINGULAR, nu
    its, status, e, scale, den = _newton(
        forces, fx, tab, lo, y0, Z, Kst, h, Jinv, Xg, mg, mass, gm, c, size, max_iter, nu, work
    )
    if status == STATUS_OK and den > 0.0 and not abs(e) <= _E_TOL * scale:
        # a secant on nu, safeguarded: its slope from the last two solves where that one has
        # the sign of the direct response ``den`` and is not far below it, ``den`` otherwise;
        # a solve that does not shrink |e| is undone and the best one kept
        copy2(Zb, Z)
        nu_b = nu
        e_b = e
        nu_last = nu
        e_last = e
        slope = den
        for _ in range(_SECANTS):
            nu = nu_b - e_b / slope
            it, status, e, scale, den = _newton(
                forces, fx, tab, lo, y0, Z, Kst, h, Jinv, Xg, mg, mass, gm, c, size, max_iter, nu, work
            )
            its += it
            if status != STATUS_OK or not abs(e) < abs(e_b):
                status = STATUS_OK
                copy2(Z, Zb)
                nu = nu_b
                e = e_b
                break
            if e != e_last and nu != nu_last:
                s = (e - e_last) / (nu - nu_last)
                slope = s if s * den > 0.0 and abs(s) >= _SLOPE_MIN * den else den
            nu_last = nu
            e_last = e
            copy2(Zb, Z)
            nu_b = nu
            e_b = e
            if abs(e) <= _E_TOL * scale:
                break
        if not abs(e) <= _E_FLOOR * scale:
            status = STATUS_NO_CONVERGENCE
    # the end from the updated stages: y1 - y0 = sum_l d_l Z_l, d = b^T a^-1 (the stage
    # derivatives in Kst are those before the last update)
    for l in range(k):
        for i in range(18):
            Y[i] = y0[i] + Z[l, i]
        _stage(forces, fx, l, Y, Jinv, Xg, mg, mass, gm, c, h, Kst[l], D[l], R, Ri, Dh[l], gP[l])
        for i in range(12, 18):
            Kst[l, i] += nu * D[l, i]
    for i in range(18):
        s = 0.0
        t = 0.0
        for l in range(k):
            s += tab[l, 1] * Kst[l, i]
            t += lo[l, 0] * Kst[l, i]
        dy[i] = h * s
        dlo[i] = h * t
    return dy, dlo, its, status, nu


@kernel
def step_scratch(k):
    """The scratch arrays of :func:`rigid_tfe_step` for k stages."""
    n3 = 3 * k
    return (
        np.empty((k, 12, 12)),
        np.empty((n3, n3)),
        np.zeros(n3, np.int64),
        np.empty((n3, n3)),
        np.empty((3 * n3, n3)),
        np.empty((n3, n3)),
        np.zeros(n3, np.int64),
        np.empty(n3),
        np.empty((k, 18)),
        np.empty(18),
        np.empty((3, 3)),
        np.empty((3, 3)),
        np.empty(18),
        np.empty(k),
        np.empty(k),
        np.zeros(k),
        np.zeros(k),
        np.empty(18),
        np.empty((n3, n3)),
        np.zeros(n3, np.int64),
        np.empty(n3),
        np.empty((k, 9)),
        np.empty((k, k, 18)),
        np.zeros((k, 6)),
        np.zeros((k, 9)),
        np.empty((k, k)),
        np.zeros(k, np.int64),
        np.empty(k),
        np.zeros((k, 9)),
        np.empty((k, 18)),
    )


@kernel
def _predict(ext, tab, Kp, Kst, Z, h):
    """The first guess from the last step's stage derivatives ``Kp``: their polynomial at
    this step's nodes (weights ``ext``) into ``Kst``, integrated, ``Z = h a Kst``."""
    k = tab.shape[0]
    for l in range(k):
        for i in range(18):
            t = 0.0
            for j in range(k):
                t += ext[l, j] * Kp[j, i]
            Kst[l, i] = t
    for l in range(k):
        for i in range(18):
            t = 0.0
            for j in range(k):
                t += tab[l, 3 + j] * Kst[j, i]
            Z[l, i] = h * t


@kernel(forceinline=True)
def _orthonormalize(y, cy, Eo):
    """Take the axes' rounding off the rotations: ``d_k -= 1/2 sum_l (d_k . d_l - delta_kl) d_l``
    (the polar factor to first order), added with compensation."""
    for k in range(3):
        for m in range(3):
            t = 0.0
            for i in range(3):
                t += y[3 + 3 * k + i] * y[3 + 3 * m + i]
            Eo[k, m] = t - (1.0 if k == m else 0.0)
    for k in range(3):
        for i in range(3):
            d = Eo[k, 0] * y[3 + i] + Eo[k, 1] * y[6 + i] + Eo[k, 2] * y[9 + i]
            y[3 + 3 * k + i], cy[3 + 3 * k + i] = kahan_add(y[3 + 3 * k + i], cy[3 + 3 * k + i], -0.5 * d)


@kernel
def _to_state(q, v, cq, cv, E, y, cy):
    """(q, v) of the director form into y (18), M = R^T sum E_kl d_k x dd_l."""
    for i in range(12):
        y[i] = q[i]
        cy[i] = cq[i]
    for i in range(3):
        y[12 + i] = v[i]
        cy[12 + i] = cv[i]
        cy[15 + i] = 0.0
    L0 = L1 = L2 = 0.0
    for k in range(3):
        for m in range(3):
            e = E[k, m]
            a = 3 + 3 * k
            b = 3 + 3 * m
            L0 += e * (q[a + 1] * v[b + 2] - q[a + 2] * v[b + 1])
            L1 += e * (q[a + 2] * v[b] - q[a] * v[b + 2])
            L2 += e * (q[a] * v[b + 1] - q[a + 1] * v[b])
    for k in range(3):
        a = 3 + 3 * k
        y[15 + k] = q[a] * L0 + q[a + 1] * L1 + q[a + 2] * L2


@kernel
def _director_velocity(y, Jinv, out):
    """The director velocities (12) of y: u, then dd_k = R (Omega x e_k)."""
    om0 = Jinv[0, 0] * y[15] + Jinv[0, 1] * y[16] + Jinv[0, 2] * y[17]
    om1 = Jinv[1, 0] * y[15] + Jinv[1, 1] * y[16] + Jinv[1, 2] * y[17]
    om2 = Jinv[2, 0] * y[15] + Jinv[2, 1] * y[16] + Jinv[2, 2] * y[17]
    for i in range(3):
        out[i] = y[12 + i]
        out[3 + i] = om2 * y[6 + i] - om1 * y[9 + i]
        out[6 + i] = om0 * y[9 + i] - om2 * y[3 + i]
        out[9 + i] = om1 * y[3 + i] - om0 * y[6 + i]


@kernel
def store_state(y, cy, Ji, q, v, cq, cv, b, vd):
    """The element's state y (with its compensation cy) into the director form's arrays of body
    b; ``vd`` (12,) scratch."""
    _director_velocity(y, Ji, vd)
    for i in range(12):
        q[b, i] = y[i]
        cq[b, i] = cy[i]
        v[b, i] = vd[i]
        cv[b, i] = 0.0
    for i in range(3):
        cv[b, i] = cy[12 + i]


@kernel
def body_gravity(models, mass, E, offsets, X, mp, gm, b, one):
    """Body b's gravity points and masses by its model (its mass points, its centre of mass as
    ``one``, a (3, 1) zero, or none), whether the torque depends on the attitude, and its size
    ``sqrt(tr E / m)`` (m)."""
    if models[b] == GRAVITY_NONE:
        Xg = X[:, 0:0]
        mg = mp[0:0]
    elif models[b] == GRAVITY_POINT:
        Xg = one
        mg = mass[b : b + 1]
    else:
        Xg = X[:, offsets[b] : offsets[b + 1]]
        mg = mp[offsets[b] : offsets[b + 1]]
    tidal = gm != 0.0 and models[b] != GRAVITY_NONE and models[b] != GRAVITY_POINT
    return Xg, mg, tidal, math.sqrt((E[b, 0, 0] + E[b, 1, 1] + E[b, 2, 2]) / mass[b])


@kernel
def rigid_tfe_chunk(
    forces, prepare, work_of, potential, eff, tab, lo, models, q, v, cq, cv, mass, E, Jinv, offsets, X, mp, gm,
    center, dt, every, nrec, max_iter, rec_q, rec_v, rec_iters, fail,
):  # fmt: skip
    """Advance every body ``nrec * every`` steps of size ``dt`` of the element whose Gauss
    tables are ``tab`` (:func:`emorbit.kernels.pointmass.tfe.tables`), recording every
    ``every`` steps. Gravity per body by ``models`` (the rigid kernels' codes): its mass
    points ``X[:, offsets[b]:offsets[b + 1]]`` with masses ``mp``, its centre of mass, or
    none. ``q, v, cq, cv`` (nb, 12) are updated in place; ``fail`` (nb, 2) pre-filled with
    -1 gets the step index and status of a body's failing step, which it stops before.

    Effects: the set's compiled ``forces, prepare, work_of, potential`` and ``eff = (P, I, T, S,
    coefs, row_effect, has_d, work, cwork, rec_work, clock_base, clock_n0)``
    (:func:`.rigid_tfe_effects.body_context`; ``work, cwork`` (nb, w) the work sums, updated in
    place, ``rec_work`` (nrec, nb, w)); step j of the chunk starts at ``clock_base + (clock_n0
    + j) dt`` (s from the epoch)."""
    k = tab.shape[0]
    nb = q.shape[0]
    Pe, Ie, Te, Se, coefs, row_effect, has_d, wsum, cwsum, rec_work, clock_base, clock_n0 = eff
    ext = _extrapolation(tab, 1.0)
    work = step_scratch(k)
    Z = np.empty((k, 18))
    Kst = np.empty((k, 18))
    Kp = np.empty((k, 18))
    y = np.empty(18)
    cy = np.empty(18)
    vd = np.empty(12)
    Eo = np.empty((3, 3))
    Rw = np.empty((3, 3))
    one = np.zeros((3, 1))[:, 0:1]
    for b in range(nb):
        Xg, mg, tidal, size = body_gravity(models, mass, E, offsets, X, mp, gm, b, one)
        fx = body_context(models, offsets, Pe, Ie, Te, Se, k, coefs, row_effect, has_d, b)
        Ji = Jinv[b]
        _to_state(q[b], v[b], cq[b], cv[b], E[b], y, cy)
        have = False
        failed = False
        nu = 0.0
        last = 0
        for r in range(nrec):
            its = 0
            for s in range(every):
                # Newton's factors are kept from step to step while it converges fast; a step
                # that fails on kept factors is tried again on new ones
                refactor = not have or last > _REUSE_ITERATIONS
                nu0 = nu
                t0 = clock_base + (clock_n0 + r * every + s) * dt
                prepare_step(prepare, fx, tab, t0, dt)
                for _attempt in range(2):
                    if have:
                        _predict(ext, tab, Kp, Kst, Z, dt)
                    dy, dlo, it, status, nu = rigid_tfe_step(
                        forces, fx, tab, lo, y, Z, Kst, dt, Ji, Xg, mg, mass[b], gm, center, size, tidal, max_iter,
                        have, nu0, refactor, work,
                    )  # fmt: skip
                    its += it
                    if status == STATUS_OK or refactor:
                        break
                    refactor = True
                last = it
                if status == STATUS_OK:
                    total = 0.0
                    for i in range(18):
                        total += dy[i]
                    if not abs(total) < math.inf:
                        status = STATUS_SINGULAR
                if status != STATUS_OK:
                    fail[b, 0] = r * every + s
                    fail[b, 1] = status
                    failed = True
                    break
                if wsum.shape[1] > 0:
                    step_work(work_of, prepare, potential, fx, tab, lo, y, Z, dy, Ji, Xg, mg, dt, t0, Eo, Rw,
                              wsum[b], cwsum[b])  # fmt: skip
                for i in range(18):
                    y[i], cy[i] = kahan_add(y[i], cy[i], dy[i])
                    y[i], cy[i] = kahan_add(y[i], cy[i], dlo[i])
                _orthonormalize(y, cy, Eo)
                copy2(Kp, Kst)
                have = True
            if failed:
                break
            _director_velocity(y, Ji, vd)
            for i in range(12):
                rec_q[r, b, i] = y[i]
                rec_v[r, b, i] = vd[i]
            rec_iters[r, b] = its
            copy1(rec_work[r, b], wsum[b])
        store_state(y, cy, Ji, q, v, cq, cv, b, vd)
