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
space; Benzi, Golub & Liesen 2005), the predictor and K are :mod:`.rigid_solve`'s. No rounded
constant enters every step the same way: ``E dv = ...`` uses a stored inverse, refined once.

Known limits (docs/methods.md): at 90 degrees of rotation per step the energy drifts (Newton
zeroes the computed residual, whose rounding error has a nonzero mean along the velocity);
in a field the point-mass kernel's accurate finish (:func:`.pointmass.reference.em_finish`) is
not here, so the plain sums leave an energy drift above the point-mass step's; the stopping
test weighs increments by mass: the axes stop at about 4 eps sqrt(m / E_kk) h |v| (orbit).

Forces: the effect set's (:mod:`.effects.signatures`), taken as arguments: ``forces`` at
the mass points, ``facets`` on the flat facets (:mod:`.rigid_surface`). Gravity models (per
body): ``GRAVITY_VOLUME`` (the point effects at every mass point, gravity-gradient torque
included), ``GRAVITY_POINT`` (at the centre of mass, no torque), ``GRAVITY_NONE`` (none).
Methods: ``METHOD_EM`` (discrete forces) and ``METHOD_MIDPOINT`` (conservative effects at the
midpoint configuration).
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
from .copies import copy1
from .effects.signatures import MODE_MIDPOINT, MODE_STEP
from .eft import kahan_add
from .jit import kernel
from .pointmass.effect_step import substep_times
from .rigid_solve import body_radius, central_stiffness, dense_kkt, dense_solve, kkt_solve, predict
from .rigid_surface import facet_forces, facet_jacobian, facet_scratch

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
def rigid_forces(forces, mode, model, q0, q1, X, mp, m, h, coef, pcoef, P, I, T, S, F, K, Pb, W, G, work, want_K):
    """Generalised force F (12) of the set's point effects and, if ``want_K``, its derivative
    K = dF/dq1 (12, 12).

    X (3, N) body coordinates and mp (N,) masses of the mass points, coef (k, N) their
    coefficients for each effect, pcoef (k, 1) the centre of mass's (the point gravity model);
    Pb (10, N) the block products (see :func:`work_arrays`), W (10, N) and G (3, N) scratch;
    ``work`` the body's work arrays. Returns the set's status (STATUS_SINGULAR where a force
    is not finite).

    For the volume model, with c_i = (1, X_i) and K_i = dg_i / dx1_i (3 x 3, the set's
    diagonal block per unit mass), K = sum_i m_i (c_i c_i^T) (x) K_i. The 10 distinct blocks
    (A <= B) are one matrix product, Pb W^T, of the products c_iA c_iB (rows of Pb, fixed per
    body) and the 9 entries of m_i K_i (rows of W), computed by :func:`_gram`.
    """
    F[:] = 0.0
    if want_K:
        K[:, :] = 0.0
    if model == GRAVITY_NONE:
        return STATUS_OK
    if model == GRAVITY_POINT:
        xa, xb, f1, w1, r1, m1, b1 = work[30], work[31], work[32], work[33], work[34], work[35], work[36]
        for d in range(3):
            xa[d, 0] = q0[d]
            xb[d, 0] = q1[d]
        m1[0] = m
        status = forces(xa, xb, m1, b1, pcoef, h, mode, P, I, T, S, f1, w1, r1, want_K, True)
        for d in range(3):
            F[d] = m * f1[d, 0]
            if want_K:
                for e in range(3):
                    K[d, e] = m * w1[3 * d + e, 0]
        return status
    n = mp.shape[0]
    xa, xb, fp, wp, rr, bb = work[25], work[26], work[27], work[28], work[29], work[37]
    d1x, d1y, d1z = q1[3], q1[4], q1[5]
    d2x, d2y, d2z = q1[6], q1[7], q1[8]
    d3x, d3y, d3z = q1[9], q1[10], q1[11]
    for i in range(n):
        X1 = X[0, i]
        X2 = X[1, i]
        X3 = X[2, i]
        xb[0, i] = q1[0] + X1 * d1x + X2 * d2x + X3 * d3x
        xb[1, i] = q1[1] + X1 * d1y + X2 * d2y + X3 * d3y
        xb[2, i] = q1[2] + X1 * d1z + X2 * d2z + X3 * d3z
    status = forces(xa, xb, mp, bb, coef, h, mode, P, I, T, S, fp, wp, rr, want_K, True)
    if status != STATUS_OK:
        return status
    for i in range(n):
        mi = mp[i]
        G[0, i] = mi * fp[0, i]
        G[1, i] = mi * fp[1, i]
        G[2, i] = mi * fp[2, i]
        if want_K:
            for e in range(9):
                W[e, i] = mi * wp[e, i]
            W[9, i] = 0.0
    # F_(A, d) = sum_i c_iA m_i g_id: rows 0..3 of Pb are c_A = (1, X1, X2, X3)
    Fm = _gram(Pb[:4], G)
    for A in range(4):
        for d in range(3):
            F[3 * A + d] = Fm[A, d]
    if want_K:
        Tk = _gram(Pb, W)  # (10, 10): [pair, (d, e) entry or the identity part]
        j = 0
        for A in range(4):
            for B in range(A, 4):
                for d in range(3):
                    for e in range(3):
                        K[3 * A + d, 3 * B + e] = Tk[j, 3 * d + e]
                        K[3 * B + d, 3 * A + e] = Tk[j, 3 * d + e]
                    K[3 * A + d, 3 * B + d] += Tk[j, 9]
                    if B != A:
                        K[3 * B + d, 3 * A + d] += Tk[j, 9]
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
    mass point from the centre of mass), [24] the null-space solve's scratch, [25] the mass
    points at the step's start, [26..29] and [37] the set's arguments at the mass points, [30..36]
    at the centre of mass; the rest scratch."""
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
        np.empty((3, npoints)),
        np.empty((3, npoints)),
        np.empty((3, npoints)),
        np.empty((9, npoints)),
        np.zeros(npoints),
        np.empty((3, 1)),
        np.empty((3, 1)),
        np.empty((3, 1)),
        np.empty((9, 1)),
        np.zeros(1),
        np.empty(1),
        np.zeros(1, np.int64),
        np.zeros(npoints, np.int64),
    )


_work_arrays = kernel(work_arrays)


@kernel
def rigid_step(
    forces, facets_fn, method, model, q0, v0, lam, m, E, Einv, X, mp, gm, c, h, max_iter, work, coef, pcoef, fP, fI, fT,
    fS, facets, f0, f1, fscratch,
):  # fmt: skip
    """One step of size ``h`` for one rigid body.

    The set's point effects act at the mass points (``forces``, coefficients ``coef``, the
    centre of mass's ``pcoef``), its surface effects on the facet rows ``f0 .. f1`` of
    ``facets`` (``facets_fn``, scratch ``fscratch`` from
    :func:`.rigid_surface.facet_scratch`); ``fP, fI, fT, fS`` are the set's arrays ``P, I, T,
    S``, prepared for the step's times. The facets' derivative joins the load stiffness (by differences,
    :func:`.rigid_surface.facet_jacobian`). GM and the centre ``c`` of the central field
    (0: none) serve the predictor and the choice of the load stiffness only.

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
    mode = MODE_MIDPOINT if method == METHOD_MIDPOINT else MODE_STEP
    volume = model == GRAVITY_VOLUME
    if volume:
        xa = work[25]
        for i in range(n):
            for d in range(3):
                xa[d, i] = q0[d] + X[0, i] * q0[3 + d] + X[1, i] * q0[6 + d] + X[2, i] * q0[9 + d]
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
    surfaces = f1 > f0
    kron = not surfaces and not volume  # K only in the centre of mass's block
    if model == GRAVITY_NONE:  # no field: F and K stay zero (the facets' derivative adds into K)
        for r in range(12):
            F[r] = 0.0
            for j in range(12):
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
        if model == GRAVITY_NONE:
            for r in range(12):
                F[r] = 0.0
        else:
            if want and central:
                st = rigid_forces(
                    forces, mode, GRAVITY_POINT, q0, q1, X, mp, 1.0, h, coef, pcoef, fP, fI, fT, fS, work[23], K,
                    work[4], work[5], work[20], work, True,
                )  # fmt: skip
                central = st == STATUS_OK
                if central:
                    central_stiffness(K, m, E)
            st = rigid_forces(
                forces, mode, model, q0, q1, X, mp, m, h, coef, pcoef, fP, fI, fT, fS, F, K, work[4], work[5], work[20],
                work, want and not central,
            )  # fmt: skip
            if st != STATUS_OK:
                status = st
                break
        if surfaces:
            st = facet_forces(facets_fn, q0, q1, h, F, facets, f0, f1, fP, fI, fT, fS, fscratch, False)
            if st != STATUS_OK:
                status = st
                break
            if it == 1:  # the facets' torques depend on the attitude: their derivative joins K
                facet_jacobian(facets_fn, q0, q1, h, K, facets, f0, f1, fP, fI, fT, fS, fscratch)
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
        if d2 <= _TOL2 * (floor2 + s2) and (not surfaces or d2 <= _FACET_TOL * _TOL2 * (floor2 + s2)):
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
    forces, prepare, work_of, facets_fn, method, models, q, v, cq, cv, lam, mass, E, Einv, offsets, X, mp, coef,
    pcoef, foff, facets, gm, center, dt, gammas, every, nrec, max_iter, rec_q, rec_v, rec_iters, rec_stalled, fail, P,
    I, T, S, work, cwork, rec_work, clock_base, clock_n0, ledger,
):  # fmt: skip
    """Advance every rigid body ``nrec * every`` composed steps, recording every ``every``.

    ``forces``, ``prepare``, ``work_of``, ``facets_fn``: the effect set's compiled functions
    (:mod:`.effects.signatures`) and ``P, I, T, S`` its arrays; models (nb,) gravity model per
    body; q, v, cq, cv (nb, 12) state and Kahan compensation; lam (nb, 6) multiplier warm
    starts; mass (nb,), E and Einv (nb, 3, 3); body b's mass points are
    X[:, offsets[b]:offsets[b+1]] (3, N) with masses mp and coefficients coef (k, N) columns,
    its centre of mass's coefficients pcoef[:, b]; its facets rows ``foff[b] .. foff[b+1]``
    of ``facets`` (:mod:`.rigid_surface`). rec_q/rec_v (nrec, nb, 12), rec_iters (nrec, nb),
    fail (nb, 2) as in :func:`emorbit.kernels.pointmass.reference.implicit_chunk`;
    rec_stalled (nrec, nb) counts each interval's sub-steps that :func:`rigid_step` accepted
    at its floor, above round-off. Step j starts at ``clock_base + (clock_n0 + j) dt``.
    ``work`` and ``cwork`` (nb, w) sum each working effect's work on each body (Kahan),
    recorded in ``rec_work`` (nrec, nb, w); ``ledger``: the last of them is the set's ledger row
    (:func:`_body_work`).
    """
    nb = q.shape[0]
    ns = gammas.shape[0]
    nw = work.shape[1]
    tp = np.empty(12)
    tu = np.empty(12)
    te = np.empty(12)
    tf = np.empty(12)
    tl = np.empty(6)
    tw = np.zeros(nw)
    tcw = np.zeros(nw)
    tcum = np.empty(ns + 1)
    tcum[0] = 0.0
    for k in range(ns):
        tcum[k + 1] = tcum[k] + gammas[k]
    mode = MODE_MIDPOINT if method == METHOD_MIDPOINT else MODE_STEP
    for b in range(nb):
        o0, o1 = offsets[b], offsets[b + 1]
        Xb = X[:, o0:o1]
        mb = np.ascontiguousarray(mp[o0:o1])
        cb = np.ascontiguousarray(coef[:, o0:o1])
        pb = np.ascontiguousarray(pcoef[:, b : b + 1])
        work_b = _work_arrays(Xb)
        Eb = E[b]
        Eib = Einv[b]
        dq = work_b[16]
        dv = work_b[19]
        f0 = foff[b]
        f1 = foff[b + 1]
        fscratch = facet_scratch(f1 - f0, nw)
        q1 = np.empty(12)
        wpts = _point_scratch(models[b], o1 - o0, nw)
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
                for j_ in range(nw):
                    tw[j_] = work[b, j_]
                    tcw[j_] = cwork[b, j_]
                for k in range(ns):
                    h = dt * gammas[k]
                    ta, tm, tb = substep_times(clock_base, clock_n0 + r * every + s, k, tcum, dt)
                    prepare(ta, tm, tb, P, I, T, S)
                    it, status, stalled = rigid_step(
                        forces, facets_fn, method, models[b], tp, tu, tl, mass[b], Eb, Eib, Xb, mb, gm, center, h,
                        max_iter, work_b, cb, pb, P, I, T, S, facets, f0, f1, fscratch,
                    )  # fmt: skip
                    its += it
                    stl += stalled
                    ok = status == STATUS_OK
                    if ok and nw > 0:  # the effects' work over the converged sub-step
                        for jj in range(12):
                            q1[jj] = tp[jj] + dq[jj]
                        _body_work(
                            work_of, facets_fn, mode, models[b], tp, q1, Xb, mb, mass[b], h, cb, pb, P, I, T, S,
                            facets, f0, f1, fscratch, wpts, tw, tcw, ledger,
                        )  # fmt: skip
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
                for j_ in range(nw):
                    work[b, j_] = tw[j_]
                    cwork[b, j_] = tcw[j_]
            if failed:
                break
            copy1(rec_q[r, b], q[b])
            copy1(rec_v[r, b], v[b])
            rec_iters[r, b] = its
            rec_stalled[r, b] = stl
            copy1(rec_work[r, b], work[b])


@kernel
def _point_scratch(model, npoints, nw):
    """Scratch for :func:`_body_work`: the points at the start, their increments, the body
    index (zeros) and the work per point (nw, n); one point (the centre of mass) for the point
    gravity model, none for free motion."""
    n = 0 if model == GRAVITY_NONE else (1 if model == GRAVITY_POINT else npoints)
    return np.empty((3, n)), np.empty((3, n)), np.zeros(n, np.int64), np.zeros((nw, n)), np.empty(n)


@kernel
def body_points(model, q, X, m, mp, out, mout):
    """Where the point effects act on a body in configuration q: its mass points (volume), its
    centre of mass with all the mass (point), or none; into ``out`` (3, n) and ``mout`` (n,)."""
    if model == GRAVITY_POINT:
        for d in range(3):
            out[d, 0] = q[d]
        mout[0] = m
        return
    for i in range(out.shape[1]):
        for d in range(3):
            out[d, i] = q[d] + X[0, i] * q[3 + d] + X[1, i] * q[6 + d] + X[2, i] * q[9 + d]
        mout[i] = mp[i]


@kernel
def _body_work(
    work_of, facets_fn, mode, model, q0, q1, X, mp, m, h, coef, pcoef, P, I, T, S, facets, f0, f1, fscratch,
    wpts, tw, tcw, ledger,
):  # fmt: skip
    """Add each working effect's work on the body over the step (its points' and its facets')
    into ``tw`` with Kahan compensation ``tcw``. Where the set has a ledger row (``ledger``, the
    last), add to it the body's work at its true mean mass: the sum of the others times ``1 +``
    its facets' mass marks (the body loses its mass evenly)."""
    x0, dx, bb, out, mm = wpts
    n = x0.shape[1]
    nw = tw.shape[0]
    nk = nw - 1 if ledger else nw
    body = 0.0
    if n > 0:
        body_points(model, q0, X, m, mp, x0, mm)
        body_points(model, q1, X, m, mp, dx, mm)
        for i in range(n):
            for d in range(3):
                dx[d, i] -= x0[d, i]
        work_of(x0, dx, mm, bb, pcoef if model == GRAVITY_POINT else coef, h, mode, P, I, T, S, out)
        for k in range(nk):
            total = 0.0
            for i in range(n):
                total += out[k, i]
            tw[k], tcw[k] = kahan_add(tw[k], tcw[k], total)
            body += total
    mu = 1.0
    if f1 > f0:
        F = np.zeros(12)
        facet_forces(facets_fn, q0, q1, h, F, facets, f0, f1, P, I, T, S, fscratch, True)
        fo = fscratch[6]
        for k in range(nk):
            total = 0.0
            for j in range(f1 - f0):
                total += fo[k, j]
            tw[k], tcw[k] = kahan_add(tw[k], tcw[k], total)
            body += total
        if ledger:
            for j in range(f1 - f0):
                mu += fo[nk, j]
    if ledger:
        tw[nk], tcw[nk] = kahan_add(tw[nk], tcw[nk], mu * body)
