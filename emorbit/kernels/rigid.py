"""Rigid-body step kernels: the rotationless director formulation (Betsch & Steinmann 2001)
with the energy-momentum gravity of Goettlicher & Schweizerhof over the body's mass points.

Configuration of one body: ``q = (phi, d1, d2, d3)`` in R^12 (centre of mass and the body axes
in space, ``R = [d1 d2 d3]``); a mass point with body coordinates ``X`` (relative to the
centre of mass) sits at ``x = phi + X^k d_k``, linear in ``q``. The mass matrix is constant,
``M = diag(m I3, E (x) I3)`` with ``E_kl = sum_i m_i X_i^k X_i^l``, and six quadratic
constraints ``d_k . d_l = delta_kl`` keep the axes orthonormal. One step of size ``h``::

    q1 - q0 = h/2 (v0 + v1)
    M (v1 - v0) = h (F(q0, q1) - G(q05)^T lambda),      g(q1) = 0

with ``F = sum_i B_i^T m_i g_*(x_i0, x_i1)``. Because the constraints are quadratic,
``G(q05) (q1 - q0) = g(q1) - g(q0)``: the constraint forces do no work, and with
``g_* = g_em`` the discrete energy and the angular momentum about the centre are conserved
to round-off, for any rotation per step.

Newton solves for ``z = (dq, nu)`` with the constraint impulse ``nu = h lambda``::

    R1 = M dq - h (M v0 + (h/2) F) + (h/2) G(q0 + dq/2)^T nu = 0      (12)
    R2 = g(q0 + dq) = 0                                                (6)

with the load stiffness ``K = dF/dq1`` (chord), constraint rows scaled by ``trace(E)/3``; then
``M dv = h F - G(q05)^T nu``, ``F`` linearised at the final iterate. The linear solves (null
space; Benzi, Golub & Liesen 2005), the predictor and K are :mod:`.rigid_solve`'s.

No rounded constant may enter every step the same way, or the energy drifts: ``h*h/2``, ``2/h``
and ``E^-1`` never touch the state; ``E dv = ...`` uses a stored inverse plus one refinement.

Known limits (docs/methods.md): at 90 degrees of rotation per step the energy drifts (Newton
zeroes the computed residual, whose rounding error has a nonzero mean along the velocity);
in a field the point-mass kernel's accurate finish (:func:`.pointmass.reference.em_finish`) is
not here, so the plain sums leave an energy drift above the point-mass step's; the stopping
test weighs increments by mass: the axes stop at about 4 eps sqrt(m / E_kk) h |v| (orbit).

Gravity models (per body): ``GRAVITY_VOLUME`` sums over the mass points (gravity-gradient
torque included), ``GRAVITY_POINT`` puts all mass at the centre of mass (no torque),
``GRAVITY_NONE`` is free motion. Zonal harmonics (``zonal_p``, ``zonal_j``; None: none) add
their discrete force (:mod:`.effects.zonal`) on the same points. Methods: ``METHOD_EM``
(g_em) and ``METHOD_MIDPOINT`` (g at the midpoint configuration; energy oscillates in a field).
"""

from __future__ import annotations

import math

import numpy as np

from .codes import (
    GRAVITY_NONE,
    GRAVITY_POINT,
    GRAVITY_VOLUME,
    METHOD_EM,
    METHOD_MIDPOINT,
    STATUS_NO_CONVERGENCE,
    STATUS_OK,
    STATUS_SINGULAR,
)
from .effects.radiation import shadow_cylindrical
from .effects.third_body import table_position
from .effects.zonal import zonal_force, zonal_jacobian
from .eft import kahan_add
from .gravity import accel, accel_jacobian_coeffs, em_accel, em_jacobian_coeffs
from .jit import kernel
from .rigid_effects import facet_forces, facet_jacobian, third_body_forces, third_body_work
from .rigid_solve import body_radius, central_stiffness, dense_kkt, dense_solve, kkt_solve, predict

__all__ = [
    "GRAVITY_NONE",
    "GRAVITY_POINT",
    "GRAVITY_VOLUME",
    "METHOD_EM",
    "METHOD_MIDPOINT",
    "rigid_forces",
    "rigid_step",
    "rigid_chunk",
]

_EPS = 2.220446049250313e-16
_TOL2 = (4.0 * _EPS) ** 2
_FLOOR2 = (1024.0 * _EPS) ** 2  # a stalled update is accepted as round-off below 1024 eps |scale|
#: with facets, an update must also fall below this fraction of the round-off test: stopping
#: at the test alone let a box's energy balance under drag grow to 8.4e-14 over 1e5 LEO steps,
#: 2.9e-14 with this (tests/test_energy_balance.py); why facets need it is not pinned down
_FACET_TOL = 1e-4
_CENTRAL_K = 1e-8  # the volume model takes the centre of mass's load stiffness up to this h^2 GM rho / r^4


@kernel
def rigid_forces(method, model, q0, q1, X, mp, m, gm, c, a0, r0, F, K, P, W, G, want_K, zonal_p, zonal_j):
    """Generalised gravity force F (12) and, if ``want_K``, its derivative K = dF/dq1 (12, 12).

    ``zonal_p`` and ``zonal_j`` are the zonal harmonics' parameters (:mod:`.effects.zonal`:
    centre, pole, GM, R; J2...), or None: Numba prunes the zonal code where they are None, so
    a body without zonal harmonics runs no zonal code. With them (em only), each mass point
    (the centre of mass, for ``GRAVITY_POINT``) adds the zonal force over the step and its
    Jacobian to g_em's: the torque of the zonal field comes from the mass points, as the
    gravity gradient's does.

    X (3, N) body coordinates and mp (N,) masses of the mass points; a0 (3, N) and r0 (N,)
    hold ``c - x_i0`` and its length (computed once per step by the caller); P (10, N) holds
    the block products (see :func:`work_arrays`), W (10, N) and G (3, N) are scratch. Returns a
    status: STATUS_SINGULAR if a point reached the centre.

    For the volume model, with c_i = (1, X_i) and K_i = d g / d x10 = cc_i I + w_i u_i b_i^T,
    K = sum_i m_i (c_i c_i^T) (x) K_i. The 10 distinct blocks (A <= B) are one matrix product,
    P W^T, of the products c_iA c_iB (rows of P, fixed per body) and the 9 entries of
    m_i w_i u_i b_i^T plus m_i cc_i (rows of W), computed by :func:`_gram`.
    """
    F[:] = 0.0
    if want_K:
        K[:, :] = 0.0
    if model == GRAVITY_NONE:
        return STATUS_OK
    if model == GRAVITY_POINT:
        ax = c[0] - q0[0]
        ay = c[1] - q0[1]
        az = c[2] - q0[2]
        bx = c[0] - q1[0]
        by = c[1] - q1[1]
        bz = c[2] - q1[2]
        if method == METHOD_EM:
            ra = math.sqrt(ax * ax + ay * ay + az * az)
            gx, gy, gz, rb, k = em_accel(ax, ay, az, ra, bx, by, bz, gm)
            if not (rb > 0.0 and ra > 0.0):
                return STATUS_SINGULAR
            cc, w = em_jacobian_coeffs(ra, rb, k)
            ux, uy, uz = ax + bx, ay + by, az + bz
        else:
            ux = 0.5 * (ax + bx)
            uy = 0.5 * (ay + by)
            uz = 0.5 * (az + bz)
            gx, gy, gz, r = accel(ux, uy, uz, gm)
            if not (r > 0.0):
                return STATUS_SINGULAR
            cc, w = accel_jacobian_coeffs(r, gm)
            cc *= 0.5
            w *= 0.5
            bx, by, bz = ux, uy, uz
        F[0] = m * gx
        F[1] = m * gy
        F[2] = m * gz
        if want_K:
            uu = (ux, uy, uz)
            bb = (bx, by, bz)
            for d in range(3):
                for e in range(3):
                    K[d, e] = m * w * uu[d] * bb[e]
                K[d, d] += m * cc
        if zonal_p is not None:
            zx, zy, zz = zonal_force(
                q0[0], q0[1], q0[2], q1[0], q1[1], q1[2], zonal_p[0], zonal_p[1], zonal_p[2], zonal_p[3],
                zonal_p[4], zonal_p[5], zonal_p[6], zonal_p[7], zonal_j,
            )  # fmt: skip
            F[0] += m * zx
            F[1] += m * zy
            F[2] += m * zz
            if want_K:
                Jz = np.zeros((3, 3))
                zonal_jacobian(
                    q0[0], q0[1], q0[2], q1[0], q1[1], q1[2], zonal_p[0], zonal_p[1], zonal_p[2], zonal_p[3],
                    zonal_p[4], zonal_p[5], zonal_p[6], zonal_p[7], zonal_j, Jz,
                )  # fmt: skip
                for d in range(3):
                    for e in range(3):
                        K[d, e] += m * Jz[d, e]
        return STATUS_OK
    n = mp.shape[0]
    d1x, d1y, d1z = q1[3], q1[4], q1[5]
    d2x, d2y, d2z = q1[6], q1[7], q1[8]
    d3x, d3y, d3z = q1[9], q1[10], q1[11]
    nbad = 0
    if zonal_p is not None:
        Jz = np.zeros((3, 3))
    # one pass without floating-point reductions (so LLVM can vectorise the square roots and
    # divisions): the force m_i g_i of every point, and the rows of W; the sums come after
    for i in range(n):
        X1 = X[0, i]
        X2 = X[1, i]
        X3 = X[2, i]
        bx = c[0] - (q1[0] + X1 * d1x + X2 * d2x + X3 * d3x)
        by = c[1] - (q1[1] + X1 * d1y + X2 * d2y + X3 * d3y)
        bz = c[2] - (q1[2] + X1 * d1z + X2 * d2z + X3 * d3z)
        bx1, by1, bz1 = bx, by, bz
        ax = a0[0, i]
        ay = a0[1, i]
        az = a0[2, i]
        if method == METHOD_EM:
            gx, gy, gz, rb, k = em_accel(ax, ay, az, r0[i], bx, by, bz, gm)
        else:
            ux = 0.5 * (ax + bx)
            uy = 0.5 * (ay + by)
            uz = 0.5 * (az + bz)
            gx, gy, gz, rb = accel(ux, uy, uz, gm)
        nbad += 0 if rb > 0.0 else 1  # a point at the centre (or nan)
        mi = mp[i]
        G[0, i] = mi * gx
        G[1, i] = mi * gy
        G[2, i] = mi * gz
        if want_K:
            if method == METHOD_EM:
                cc, w = em_jacobian_coeffs(r0[i], rb, k)
                ux = ax + bx
                uy = ay + by
                uz = az + bz
            else:
                cc, w = accel_jacobian_coeffs(rb, gm)
                cc *= 0.5
                w *= 0.5
                bx, by, bz = ux, uy, uz
            w *= mi
            W[0, i] = w * ux * bx
            W[1, i] = w * ux * by
            W[2, i] = w * ux * bz
            W[3, i] = w * uy * bx
            W[4, i] = w * uy * by
            W[5, i] = w * uy * bz
            W[6, i] = w * uz * bx
            W[7, i] = w * uz * by
            W[8, i] = w * uz * bz
            W[9, i] = mi * cc
        if zonal_p is not None:
            x0x, x0y, x0z = c[0] - ax, c[1] - ay, c[2] - az
            x1x, x1y, x1z = c[0] - bx1, c[1] - by1, c[2] - bz1
            zx, zy, zz = zonal_force(
                x0x, x0y, x0z, x1x, x1y, x1z, zonal_p[0], zonal_p[1], zonal_p[2], zonal_p[3], zonal_p[4],
                zonal_p[5], zonal_p[6], zonal_p[7], zonal_j,
            )  # fmt: skip
            G[0, i] += mi * zx
            G[1, i] += mi * zy
            G[2, i] += mi * zz
            if want_K:
                for d in range(3):
                    for e in range(3):
                        Jz[d, e] = 0.0
                zonal_jacobian(
                    x0x, x0y, x0z, x1x, x1y, x1z, zonal_p[0], zonal_p[1], zonal_p[2], zonal_p[3], zonal_p[4],
                    zonal_p[5], zonal_p[6], zonal_p[7], zonal_j, Jz,
                )  # fmt: skip
                for d in range(3):
                    for e in range(3):
                        W[3 * d + e, i] += mi * Jz[d, e]
    if nbad:
        return STATUS_SINGULAR
    # F_(A, d) = sum_i c_iA m_i g_id: rows 0..3 of P are c_A = (1, X1, X2, X3)
    Fm = _gram(P[:4], G)
    for A in range(4):
        for d in range(3):
            F[3 * A + d] = Fm[A, d]
    if want_K:
        T = _gram(P, W)  # (10, 10): [pair, (d, e) entry or the identity part]
        j = 0
        for A in range(4):
            for B in range(A, 4):
                for d in range(3):
                    for e in range(3):
                        K[3 * A + d, 3 * B + e] = T[j, 3 * d + e]
                        K[3 * B + d, 3 * A + e] = T[j, 3 * d + e]
                    K[3 * A + d, 3 * B + d] += T[j, 9]
                    if B != A:
                        K[3 * B + d, 3 * A + d] += T[j, 9]
                j += 1
    return STATUS_OK


@kernel
def _gram(P, W):
    """P W^T for (p, N) and (q, N) arrays, with four partial sums per entry (the loop stays
    throughput-bound without fastmath). Deliberately not BLAS: a threaded BLAS oversubscribes
    small machines (several times slower at 10,000 mass points on 2 busy cores) and may sum
    in an order that depends on the thread count, which would break bit-exact restarts."""
    n = P.shape[1]
    T = np.empty((P.shape[0], W.shape[0]))
    m = n - n % 4
    for j in range(P.shape[0]):
        for k in range(W.shape[0]):
            s0 = s1 = s2 = s3 = 0.0
            for i in range(0, m, 4):
                s0 += P[j, i] * W[k, i]
                s1 += P[j, i + 1] * W[k, i + 1]
                s2 += P[j, i + 2] * W[k, i + 2]
                s3 += P[j, i + 3] * W[k, i + 3]
            for i in range(m, n):
                s0 += P[j, i] * W[k, i]
            T[j, k] = (s0 + s1) + (s2 + s3)
    return T


@kernel
def _sym(mu, S):
    """S (3, 3) from the six multipliers, so that (G^T mu)_{d_k} = sum_l S_kl d_l."""
    S[0, 0] = mu[0]
    S[1, 1] = mu[1]
    S[2, 2] = mu[2]
    S[0, 1] = S[1, 0] = mu[3]
    S[0, 2] = S[2, 0] = mu[4]
    S[1, 2] = S[2, 1] = mu[5]


_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


@kernel
def _constraint_jacobian(q, G):
    """G (6, 12) = dg/dq at q for g = (d1.d1/2, d2.d2/2, d3.d3/2, d1.d2, d1.d3, d2.d3) - const."""
    G[:, :] = 0.0
    for j in range(6):
        k, l = _PAIRS[j]
        for d in range(3):
            G[j, 3 + 3 * k + d] += q[3 + 3 * l + d]
            if k != l:
                G[j, 3 + 3 * l + d] += q[3 + 3 * k + d]


def work_arrays(X):
    """Scratch arrays for :func:`rigid_step` for a body with mass points X (3, N), allocated
    once per body and chunk; the block products of X are filled in (see :func:`rigid_forces`).
    A tuple: [4] the block products P, [16] dq, [19] dv, [22] the body's radius (the farthest
    mass point from the centre of mass), [24] the null-space solve's scratch; the rest scratch."""
    npoints = X.shape[1]
    P = np.empty((10, npoints))
    j = 0
    for A in range(4):
        for B in range(A, 4):
            for i in range(npoints):
                P[j, i] = (1.0 if A == 0 else X[A - 1, i]) * (1.0 if B == 0 else X[B - 1, i])
            j += 1
    return (
        np.empty((3, npoints)),
        np.empty(npoints),
        np.empty(12),
        np.empty((12, 12)),
        P,
        np.empty((10, npoints)),
        np.empty((18, 18)),
        np.empty(18),
        np.empty((6, 12)),
        np.empty((6, 12)),
        np.empty(12),
        np.empty(12),
        np.empty(12),
        np.empty(12),
        np.empty(6),
        np.empty(12),
        np.empty(12),
        np.empty(12),
        np.empty((3, 3)),
        np.empty(12),
        np.empty((3, npoints)),
        np.zeros(2),
        body_radius(X),
        np.empty(12),
        np.empty((9, 3, 3)),
    )


_work_arrays = kernel(work_arrays)


@kernel
def rigid_step(
    method, model, q0, v0, lam, m, E, Einv, X, mp, gm, c, h, max_iter, work, zonal_p, zonal_j,
    facets=None, f0=0, f1=0, drag_p=None, drag_t=None, drag_g=None, drag_gp=None, dsun=None, srp_p=None, sun=None,
    shade=1.0, tb_p=None, tb_s=None,
):  # fmt: skip
    """One step of size ``h`` for one rigid body.

    Beyond gravity (None: none, pruned): drag and radiation pressure on the facet rows
    ``f0 .. f1`` of ``facets`` with the Sun at ``sun`` and the shadow fraction ``shade``, and
    third bodies ``tb_p`` at ``tb_s`` (:mod:`.rigid_effects`). The facets' derivative joins the
    load stiffness (by differences, :func:`.rigid_effects.facet_jacobian`); the third bodies'
    stays out (below 1e-6 of the gravity gradient's), so the iteration converges on it.

    q0, v0 (12,) the state; lam (6,) the multipliers' warm start lambda (updated in place
    with this step's value); work from :func:`work_arrays`. Returns (iterations, status,
    stalled): ``stalled`` is 1 when the floor rule below accepted the iteration with its last
    update above the round-off tolerance, else 0. The increments dq and dv are ``work[16]``
    and ``work[19]``.

    Stopping rule: the iteration stops when the update falls to the round-off of the
    unknowns (mass-weighted; directors are unit vectors, so their increments are only defined
    to eps absolute) or stops shrinking once below 1024 eps (its floor); larger updates that
    grow (far from the solution) keep iterating up to ``max_iter``. The noise-level last
    update still matters to the multipliers, so the rule does not stop on a predicted next
    update.
    The load stiffness K is formed at the first iterate and kept for the step (chord): the sum
    over the mass points, or the centre of mass's for a small body (module docstring).
    """
    # the arrays every path uses; the others are taken from work where a path needs them
    F, K, rhs, q1, q05, delta, Mv0, nu, wdiag, dq, gen, S, dv = (
        work[2], work[3], work[7], work[10], work[11], work[12], work[13], work[14], work[15], work[16], work[17],
        work[18], work[19],
    )  # fmt: skip
    sc = work[24]
    n = mp.shape[0]
    volume = model == GRAVITY_VOLUME
    if volume:
        a0, r0 = work[0], work[1]
        for i in range(n):
            for d in range(3):
                a0[d, i] = c[d] - (q0[d] + X[0, i] * q0[3 + d] + X[1, i] * q0[6 + d] + X[2, i] * q0[9 + d])
            r0[i] = math.sqrt(a0[0, i] ** 2 + a0[1, i] ** 2 + a0[2, i] ** 2)
            if not (r0[i] > 0.0):
                return 0, STATUS_SINGULAR, 0
    es = (E[0, 0] + E[1, 1] + E[2, 2]) / 3.0  # scale of the constraint rows and multipliers
    hf = 0.5 * h
    for d in range(3):
        Mv0[d] = m * v0[d]
        wdiag[d] = m
        for k in range(3):
            s = 0.0
            for l in range(3):
                s += E[k, l] * v0[3 + 3 * l + d]
            Mv0[3 + 3 * k + d] = s
            wdiag[3 + 3 * k + d] = E[k, k]
    if not predict(model, q0, v0, lam, Einv, gm, c, h, dq):
        return 0, STATUS_SINGULAR, 0
    for j in range(6):
        nu[j] = h * lam[j]
    # round-off scale of the increments (mass-weighted): h v0, dq, and |d_k| = 1
    floor2 = 0.0
    for j in range(12):
        floor2 += wdiag[j] * (h * v0[j]) ** 2
    floor2 += wdiag[3] + wdiag[6] + wdiag[9]
    for j in range(12):
        delta[j] = 0.0
    # the load stiffness: the sum over the mass points, or, for a body small against its
    # distance, the centre of mass's (E (x) K_c): the chord then contracts by ~ h^2 GM rho / r^4
    central = False
    if volume and gm != 0.0:
        r2 = (c[0] - q0[0]) ** 2 + (c[1] - q0[1]) ** 2 + (c[2] - q0[2]) ** 2
        central = h * h * gm * work[22][0] <= _CENTRAL_K * r2 * r2
    kron = facets is None and not volume  # K only in the centre of mass's block
    if model == GRAVITY_NONE:  # no field: F and K (its centre-of-mass block) stay zero
        for r in range(12):
            F[r] = 0.0
        for r in range(3):
            for j in range(3):
                K[r, j] = 0.0
    prev2 = math.inf
    status = STATUS_NO_CONVERGENCE
    stalled = 0
    it = 0
    while it < max_iter:
        it += 1
        for j in range(12):
            q1[j] = q0[j] + dq[j]
            q05[j] = q0[j] + 0.5 * dq[j]
        # the load stiffness is assembled at the first iterate and kept for the step: it changes
        # by O(error) between iterates, so convergence stays quadratic to round-off
        want = it == 1
        if model != GRAVITY_NONE:
            if want and central:
                st = rigid_forces(
                    method, GRAVITY_POINT, q0, q1, X, mp, 1.0, gm, c, work[0], work[1], work[23], K, work[4], work[5],
                    work[20], True, zonal_p, zonal_j,
                )  # fmt: skip
                central = st == STATUS_OK
                if central:
                    central_stiffness(K, m, E)
            st = rigid_forces(
                method, model, q0, q1, X, mp, m, gm, c, work[0], work[1], F, K, work[4], work[5], work[20],
                want and not central, zonal_p, zonal_j,
            )  # fmt: skip
            if st != STATUS_OK:
                status = st
                break
        if facets is not None:
            facet_forces(
                q0, q1, h, F, facets, f0, f1, drag_p, drag_t, drag_g, drag_gp, dsun, srp_p, sun, shade, work[21]
            )
            if it == 1:  # the facets' torques depend on the attitude: their derivative joins K
                facet_jacobian(
                    q0, q1, h, K, facets, f0, f1, drag_p, drag_t, drag_g, drag_gp, dsun, srp_p, sun, shade,
                    work[6][:3, :12],
                )  # fmt: skip
        if tb_p is not None and model != GRAVITY_NONE:
            third_body_forces(q0, q1, X, mp, m, model == GRAVITY_POINT, tb_p, tb_s, F)
        _sym(nu, S)
        # R1 = M dq - h (M v0 + (h/2) F) + (h/2) G05^T nu
        for d in range(3):
            rhs[d] = m * dq[d] - h * (Mv0[d] + hf * F[d])
            for k in range(3):
                s = 0.0
                t = 0.0
                for l in range(3):
                    s += E[k, l] * dq[3 + 3 * l + d]
                    t += S[k, l] * q05[3 + 3 * l + d]
                rhs[3 + 3 * k + d] = s - h * (Mv0[3 + 3 * k + d] + hf * F[3 + 3 * k + d]) + hf * t
        # R2 = es g(q1)
        for j in range(6):
            k, l = _PAIRS[j]
            s = 0.0
            for d in range(3):
                s += q1[3 + 3 * k + d] * q1[3 + 3 * l + d]
            rhs[12 + j] = es * (0.5 * (s - 1.0) if k == l else s)
        ok = False
        if kron:  # K only in the centre of mass's block: the null-space solve (rigid_solve)
            ok = kkt_solve(rhs, m, E, K, S, q05, q1, h, es, sc)
        if not ok:
            if kron:  # K is zero outside its centre-of-mass block
                for r in range(12):
                    for j in range(12):
                        if r >= 3 or j >= 3:
                            K[r, j] = 0.0
            J, G05, G1 = work[6], work[8], work[9]
            _constraint_jacobian(q05, G05)
            _constraint_jacobian(q1, G1)
            dense_kkt(J, K, m, E, S, G05, G1, h, es)
            ok = dense_solve(J, rhs, 18)
        if not ok:
            status = STATUS_NO_CONVERGENCE
            break
        d2 = 0.0
        s2 = 0.0
        for j in range(12):
            delta[j] = rhs[j]
            dq[j] -= rhs[j]
            d2 += wdiag[j] * rhs[j] * rhs[j]
            s2 += wdiag[j] * dq[j] * dq[j]
        for j in range(6):
            nu[j] -= rhs[12 + j]
        # with facets, one more update once at round-off (see _FACET_TOL)
        if d2 <= _TOL2 * (floor2 + s2) and (facets is None or d2 <= _FACET_TOL * _TOL2 * (floor2 + s2)):
            status = STATUS_OK  # at round-off
            break
        if d2 >= prev2 and d2 <= _FLOOR2 * (floor2 + s2):
            status = STATUS_OK  # no longer shrinking at its floor: accepted above round-off
            stalled = 1
            break
        prev2 = d2
    # velocity: M dv = h F_lin - G(q05)^T nu, F linearised at the final iterate
    for j in range(12):
        q05[j] = q0[j] + 0.5 * dq[j]
    _sym(nu, S)
    nk = 3 if kron else 12  # K's nonzero block
    for r in range(12):
        s = F[r]
        if r < nk:
            for j in range(nk):
                s -= K[r, j] * delta[j]
        gen[r] = h * s
    for d in range(3):
        for k in range(3):
            t = 0.0
            for l in range(3):
                t += S[k, l] * q05[3 + 3 * l + d]
            gen[3 + 3 * k + d] -= t
    for d in range(3):
        dv[d] = gen[d] / m
        # E x = gen_d: stored inverse, then one refinement with the residual
        x0 = Einv[0, 0] * gen[3 + d] + Einv[0, 1] * gen[6 + d] + Einv[0, 2] * gen[9 + d]
        x1 = Einv[1, 0] * gen[3 + d] + Einv[1, 1] * gen[6 + d] + Einv[1, 2] * gen[9 + d]
        x2 = Einv[2, 0] * gen[3 + d] + Einv[2, 1] * gen[6 + d] + Einv[2, 2] * gen[9 + d]
        e0 = gen[3 + d] - (E[0, 0] * x0 + E[0, 1] * x1 + E[0, 2] * x2)
        e1 = gen[6 + d] - (E[1, 0] * x0 + E[1, 1] * x1 + E[1, 2] * x2)
        e2 = gen[9 + d] - (E[2, 0] * x0 + E[2, 1] * x1 + E[2, 2] * x2)
        dv[3 + d] = x0 + (Einv[0, 0] * e0 + Einv[0, 1] * e1 + Einv[0, 2] * e2)
        dv[6 + d] = x1 + (Einv[1, 0] * e0 + Einv[1, 1] * e1 + Einv[1, 2] * e2)
        dv[9 + d] = x2 + (Einv[2, 0] * e0 + Einv[2, 1] * e1 + Einv[2, 2] * e2)
    for j in range(6):
        lam[j] = nu[j] / h
    return it, status, stalled


@kernel
def rigid_chunk(
    method,
    models,
    q,
    v,
    cq,
    cv,
    lam,
    mass,
    E,
    Einv,
    offsets,
    X,
    mp,
    gm,
    center,
    dt,
    gammas,
    every,
    nrec,
    max_iter,
    rec_q,
    rec_v,
    rec_iters,
    rec_stalled,
    fail,
    zonal_p,
    zonal_j,
    clock_base=0.0,
    clock_n0=0.0,
    facets=None,
    foff=None,
    drag_p=None,
    drag_t=None,
    drag_g=None,
    drag_gp=None,
    drag_s=None,
    srp_p=None,
    srp_tab=None,
    tb_p=None,
    tb_tab=None,
    work=None,
    cwork=None,
    rec_work=None,
):
    """Advance every rigid body ``nrec * every`` composed steps, recording every ``every``.

    models (nb,) gravity model per body; q, v, cq, cv (nb, 12) state and Kahan compensation;
    lam (nb, 6) multiplier warm starts; mass (nb,), E and Einv (nb, 3, 3); body b's mass
    points are X[:, offsets[b]:offsets[b+1]] (3, N) with masses mp. rec_q/rec_v (nrec, nb, 12),
    rec_iters (nrec, nb), fail (nb, 2) as in :func:`emorbit.kernels.pointmass.reference.implicit_chunk`;
    rec_stalled (nrec, nb) counts each interval's sub-steps that :func:`rigid_step` accepted at
    its floor, above round-off.

    Effects beyond gravity (None: none): body b's facets are rows ``foff[b] .. foff[b+1]`` of
    ``facets`` (drag with ``drag_p``, ``drag_t`` or NRLMSIS's ``drag_g``, ``drag_gp`` and the Sun's
    table ``drag_s``; radiation pressure with ``srp_p`` and the
    Sun's table ``srp_tab``); third bodies ``tb_p`` with their tables ``tb_tab``
    (:mod:`.rigid_effects`, :mod:`emorbit.effects.third_body`). Step j starts at
    ``clock_base + (clock_n0 + j) dt``. With them, ``work`` and ``cwork`` (nb, k) sum each
    effect's work on each body (slots: drag, srp, then the third bodies; Kahan), recorded in
    ``rec_work`` (nrec, nb, k).
    """
    nb = q.shape[0]
    ns = gammas.shape[0]
    tp = np.empty(12)
    tu = np.empty(12)
    te = np.empty(12)
    tf = np.empty(12)
    tl = np.empty(6)
    q1 = np.empty(12)
    Fs = np.empty(12)
    wk = np.zeros(2)
    sun = np.zeros(3)
    dsun = np.zeros(3)
    tcum = np.empty(ns + 1)
    tcum[0] = 0.0
    for k in range(ns):
        tcum[k + 1] = tcum[k] + gammas[k]
    nw = 0 if work is None else work.shape[1]
    tw = np.zeros(nw)
    tcw = np.zeros(nw)
    slot_drag = 0
    slot_srp = 1 if drag_p is not None else 0
    slot_tb = (1 if drag_p is not None else 0) + (1 if srp_p is not None else 0)
    ntb = 0 if tb_p is None else tb_p.shape[0]
    tb_s = np.zeros((ntb, 3, 3))
    for b in range(nb):
        Xb = X[:, offsets[b] : offsets[b + 1]]
        mb = mp[offsets[b] : offsets[b + 1]]
        work_b = _work_arrays(Xb)
        Eb = E[b]
        Eib = Einv[b]
        dq = work_b[16]
        dv = work_b[19]
        f0 = 0 if foff is None else foff[b]
        f1 = 0 if foff is None else foff[b + 1]
        failed = False
        for r in range(nrec):
            its = 0
            stl = 0
            for s in range(every):
                for j_ in range(12):  # element copies, no row views
                    tp[j_] = q[b, j_]
                    tu[j_] = v[b, j_]
                    te[j_] = cq[b, j_]
                    tf[j_] = cv[b, j_]
                for j_ in range(6):
                    tl[j_] = lam[b, j_]
                if work is not None:
                    tw[:] = work[b]
                    tcw[:] = cwork[b]
                for k in range(ns):
                    h = dt * gammas[k]
                    shade = 1.0
                    if srp_p is not None or tb_p is not None or drag_p is not None:
                        j = clock_n0 + r * every + s
                        ta = clock_base + (j + tcum[k] if k > 0 else j) * dt
                        tb = clock_base + (j + 1.0 if k == ns - 1 else j + tcum[k + 1]) * dt
                        tm = 0.5 * (ta + tb)
                        if drag_p is not None and drag_p[7] != 0.0:  # NRLMSIS's local time
                            dsun[0], dsun[1], dsun[2] = table_position(tm, drag_p[8], drag_p[9], drag_s)
                        if srp_p is not None:
                            sun[0], sun[1], sun[2] = table_position(tm, srp_p[8], srp_p[9], srp_tab)
                            if srp_p[4] == 1.0:  # the cylindrical shadow at the predicted midpoint
                                px = tp[0] + 0.5 * h * tu[0] - srp_p[5]
                                py = tp[1] + 0.5 * h * tu[1] - srp_p[6]
                                pz = tp[2] + 0.5 * h * tu[2] - srp_p[7]
                                shade = shadow_cylindrical(px, py, pz, sun[0], sun[1], sun[2], srp_p[2])
                        if tb_p is not None:
                            for jb in range(ntb):
                                o = int(tb_p[jb, 7])
                                tab = tb_tab[o : o + int(tb_p[jb, 8])]
                                for e, te_ in ((0, ta), (1, tm), (2, tb)):
                                    sx, sy, sz = table_position(te_, tb_p[jb, 5], tb_p[jb, 6], tab)
                                    tb_s[jb, e, 0] = sx
                                    tb_s[jb, e, 1] = sy
                                    tb_s[jb, e, 2] = sz
                    it, status, stalled = rigid_step(
                        method, models[b], tp, tu, tl, mass[b], Eb, Eib, Xb, mb, gm, center, h, max_iter, work_b,
                        zonal_p, zonal_j, facets, f0, f1, drag_p, drag_t, drag_g, drag_gp, dsun, srp_p, sun, shade,
                        tb_p, tb_s,
                    )  # fmt: skip
                    its += it
                    stl += stalled
                    ok = status == STATUS_OK
                    if ok and work is not None:  # the effects' work over the converged sub-step
                        for jj in range(12):
                            q1[jj] = tp[jj] + dq[jj]
                        if facets is not None:
                            wk[0] = 0.0
                            wk[1] = 0.0
                            facet_forces(
                                tp, q1, h, Fs, facets, f0, f1, drag_p, drag_t, drag_g, drag_gp, dsun, srp_p, sun, shade,
                                wk,
                            )  # fmt: skip
                            if drag_p is not None:
                                tw[slot_drag], tcw[slot_drag] = kahan_add(tw[slot_drag], tcw[slot_drag], wk[0])
                            if srp_p is not None:
                                tw[slot_srp], tcw[slot_srp] = kahan_add(tw[slot_srp], tcw[slot_srp], wk[1])
                        if tb_p is not None and models[b] != GRAVITY_NONE:
                            for jb in range(ntb):
                                w_ = third_body_work(
                                    tp, q1, Xb, mb, mass[b], models[b] == GRAVITY_POINT, tb_p, tb_s, jb
                                )
                                tw[slot_tb + jb], tcw[slot_tb + jb] = kahan_add(tw[slot_tb + jb], tcw[slot_tb + jb], w_)
                    for j_ in range(12):
                        tp[j_], te[j_] = kahan_add(tp[j_], te[j_], dq[j_])
                        tu[j_], tf[j_] = kahan_add(tu[j_], tf[j_], dv[j_])
                        if not (abs(tp[j_]) < math.inf and abs(tu[j_]) < math.inf):
                            ok = False
                    if not ok:
                        fail[b, 0] = r * every + s
                        fail[b, 1] = status if status != STATUS_OK else STATUS_SINGULAR
                        failed = True
                        break
                if failed:
                    break
                for j_ in range(12):
                    q[b, j_] = tp[j_]
                    v[b, j_] = tu[j_]
                    cq[b, j_] = te[j_]
                    cv[b, j_] = tf[j_]
                for j_ in range(6):
                    lam[b, j_] = tl[j_]
                if work is not None:
                    work[b] = tw
                    cwork[b] = tcw
            if failed:
                break
            rec_q[r, b, :] = q[b]
            rec_v[r, b, :] = v[b]
            rec_iters[r, b] = its
            rec_stalled[r, b] = stl
            if work is not None:
                rec_work[r, b, :] = work[b]
