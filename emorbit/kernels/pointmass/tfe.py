r"""Energy-momentum time finite elements: orders 4 to 12 for point masses in one implicit solve.

One step of size ``h`` is the continuous Galerkin element cG(k) of Betsch & Steinmann (2000) in
the form of Hairer's energy-preserving collocation (2010): ``p = x - X_Z`` and ``v`` polynomials
of degree k on the step, Galerkin conditions against degree k - 1, integrals by the k-point
Gauss rule (nodes c, weights b, matrix a), so collocation at the Gauss nodes::

    V_l = v0 + h sum_j a_lj F_j,     Q_l = p0 + h c_l v0 + h^2 sum_j (a^2)_lj F_j,
    v1  = v0 + h sum_j b_j F_j,      p1  = p0 + h v0 + h^2 sum_j b_j (1 - c_j) F_j,
    F_l = g(Q_l) + mu s_l Q_l,       g(p) = -GM p / |p|^3,     s_l = Q_l . V_l,
    mu  = GM sum_l b_l s_l (1/r_l^3 - K) / sum_l b_l s_l^2,    K = 2 / (r0 r1 (r0 + r1)).

Energy exact: ``b_i a_ij + b_j a_ji = b_i b_j`` makes ``|v1|^2/2 - |v0|^2/2 = h sum b_l V_l . F_l``
and ``r1^2 - r0^2 = 2 h sum b_l s_l`` identities, so ``U(p0) - U(p1) = -GM h K sum b_l s_l``
exactly, and mu makes the nodal forces' work equal to it (not to the rule's order). Angular
momentum exact: ``L1 - L0 = h sum b_l Q_l x F_l = 0``, every F_l along Q_l. mu is O(h^{2k}), so
the order is 2k; the step is symmetric. :func:`tfe_step` has the derivation.

Data layout. The stages lie in the plane of ``p0`` and ``h v0``; the unknowns are the scaled
nodal forces ``phi_l = h^2 F_l`` in that basis, a (k, 2) array (2k unknowns per point), solved
by Newton with gravity's 2 x 2 Jacobian at each stage and a dense 2k x 2k LU factorisation,
kept for the next iterations while they contract fast (chord iterations), started from the
previous step's force polynomial. The Gauss tables are one (k, 3 + 2k) array
(:func:`tables`), from :mod:`emorbit.kernels.gauss` rounded to 20 digits. State and records
are those of :func:`~.reference.implicit_chunk`: ``x, v, cx, cv`` (3, n) with compensated
sums, ``rec_x, rec_v`` (nrec, 3, n), ``rec_iters`` (nrec, n) Newton iterations, ``fail`` (n, 2).

References: P. Betsch, P. Steinmann, Inherently energy conserving time finite elements for
classical mechanics, J. Comput. Phys. 160 (2000) 88-116; E. Hairer, Energy-preserving variant
of collocation methods, JNAIAM 5 (2010) 73-84; E. Hairer, C. Lubich, G. Wanner, Geometric
Numerical Integration, 2nd ed. (2006), II.1.3 and IV.2.1 (Gauss methods, quadratic invariants).
"""

from __future__ import annotations

import math

import numpy as np

from ..codes import STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from ..eft import kahan_add
from ..jit import kernel
from ..rigid_solve import lu, lu_solve

__all__ = ["ORDERS", "extrapolate", "keep_forces", "low_parts", "predict", "tables", "tfe_chunk", "tfe_step"]

#: the orders a step of k stages reaches: 2k
ORDERS = (4, 6, 8, 10, 12)
#: Newton's update is round-off once below this fraction of the largest nodal force
_TOL = 2.0**-53
#: an update that stops shrinking is Newton's round-off floor below this fraction
_FLOOR = 2.0**-40
#: the matrix's factors are kept for the next iteration while updates shrink by this factor
_REFRESH = 2.0**-6

#: significant digits the tables keep (:func:`_gauss`)
_TABLE_DIGITS = 20


def _check(order: int) -> None:
    if order not in ORDERS:
        raise ValueError(f"a time finite element of order {ORDERS}, not {order!r}")


def _gauss(k: int) -> tuple:
    """The k-stage Gauss tables as Decimals rounded to 20 digits: nodes c, weights b, the
    collocation matrix a, its square a^2 and b (1 - c) (:func:`emorbit.kernels.gauss.collocation`,
    computed with 50 digits)."""
    from decimal import localcontext

    from ..gauss import DIGITS, collocation

    c, b, a = collocation(k)
    with localcontext() as ctx:
        ctx.prec = DIGITS
        aa = [[sum(a[i][m] * a[m][j] for m in range(k)) for j in range(k)] for i in range(k)]
        bb = [b[i] * (1 - c[i]) for i in range(k)]
        ctx.prec = _TABLE_DIGITS
        return (
            [+x for x in c],
            [+x for x in b],
            [[+x for x in row] for row in a],
            [[+x for x in row] for row in aa],
            [+x for x in bb],
        )


def tables(order: int) -> np.ndarray:
    """The Gauss tables of a step of ``order`` (4, 6, 8, 10 or 12) in one (k, 3 + 2k) array.

    Row l holds ``c_l, b_l, b_l (1 - c_l)``, then ``a_l1 .. a_lk``, then ``(a^2)_l1 .. (a^2)_lk``.

    Parameters
    ----------
    order : int
        4, 6, 8, 10 or 12 (k = 2 to 6 stages).

    Returns
    -------
    ndarray
        (k, 3 + 2k) float64.
    """
    _check(order)
    c, b, a, aa, bb = _gauss(order // 2)
    k = len(c)
    out = np.empty((k, 3 + 2 * k))
    for i in range(k):
        out[i, 0], out[i, 1], out[i, 2] = float(c[i]), float(b[i]), float(bb[i])
        out[i, 3 : 3 + k] = [float(s) for s in a[i]]
        out[i, 3 + k :] = [float(s) for s in aa[i]]
    return out


def low_parts(order: int) -> np.ndarray:
    """What the float64 Gauss tables of ``order`` (:func:`tables`) leave out:
    (k, 1 + k), row l ``b_l - fl(b_l)``, then ``a_lj - fl(a_lj)``, from the 20-digit values.

    The quadratic invariants are kept because ``b_i a_ij + b_j a_ji = b_i b_j``; rounded to
    float64 the identity is off by about 1e-17, the same in every step, and the invariants
    drift by that times ``(h omega)^2`` per step. With these parts the stage sums use the
    coefficients to 20 digits, so the drift is far below round-off's random walk."""
    if order not in _LOW:
        from decimal import Decimal, localcontext

        _check(order)
        c, b, a, _, _ = _gauss(order // 2)
        k = len(c)
        out = np.empty((k, 1 + k))
        with localcontext() as ctx:  # the caller's decimal context stays as it was
            ctx.prec = 40
            for i in range(k):
                out[i, 0] = float(Decimal(b[i]) - Decimal(float(b[i])))
                for j in range(k):
                    out[i, 1 + j] = float(Decimal(a[i][j]) - Decimal(float(a[i][j])))
        _LOW[order] = out
    return _LOW[order].copy()


#: :func:`low_parts` by order, computed once per process
_LOW: dict = {}


@kernel
def _lagrange(cs, j, t):
    """The Lagrange polynomial of nodes ``cs`` that is 1 at ``cs[j]``, at ``t``."""
    out = 1.0
    for m in range(cs.shape[0]):
        if m != j:
            out *= (t - cs[m]) / (cs[j] - cs[m])
    return out


@kernel
def extrapolate(out, tab, ratio):
    """Into ``out`` (k, k) the weights ``E[l, j]`` that carry a polynomial of degree k - 1
    through its values at the nodes of one step to the nodes of the next, ``ratio`` times as
    long: ``E[l, j] = ell_j(1 + ratio c_l)``."""
    k = tab.shape[0]
    cs = tab[:, 0]
    for l in range(k):
        for j in range(k):
            out[l, j] = _lagrange(cs, j, 1.0 + ratio * cs[l])


@kernel
def _extrapolation(tab, ratio):
    """:func:`extrapolate` into a new (k, k) array."""
    out = np.empty((tab.shape[0], tab.shape[0]))
    extrapolate(out, tab, ratio)
    return out


@kernel
def predict(ext, phi, prevf, p0, p1, p2, hv0, hv1, hv2, scale):
    """phi from the previous step's nodal forces ``prevf`` (k, 3) in space (h_prev^2 F): the
    force polynomial extrapolated to this step's nodes (weights ``ext``, :func:`extrapolate`),
    times ``scale = (h / h_prev)^2`` and written in the basis (p0, h v0) through its metric."""
    k = ext.shape[0]
    g00 = p0 * p0 + p1 * p1 + p2 * p2
    g01 = p0 * hv0 + p1 * hv1 + p2 * hv2
    g11 = hv0 * hv0 + hv1 * hv1 + hv2 * hv2
    det = g00 * g11 - g01 * g01
    for l in range(k):
        f0 = 0.0
        f1 = 0.0
        f2 = 0.0
        for j in range(k):
            w = ext[l, j]
            f0 += w * prevf[j, 0]
            f1 += w * prevf[j, 1]
            f2 += w * prevf[j, 2]
        a = scale * (p0 * f0 + p1 * f1 + p2 * f2)
        b = scale * (hv0 * f0 + hv1 * f1 + hv2 * f2)
        phi[l, 0] = (g11 * a - g01 * b) / det
        phi[l, 1] = (g00 * b - g01 * a) / det


@kernel
def keep_forces(prevf, phi, p0, p1, p2, hv0, hv1, hv2):
    """A solved step's nodal forces in space (h^2 F, (k, 3)) into ``prevf``, for the next
    step's :func:`predict`."""
    for l in range(phi.shape[0]):
        prevf[l, 0] = phi[l, 0] * p0 + phi[l, 1] * hv0
        prevf[l, 1] = phi[l, 0] * p1 + phi[l, 1] * hv1
        prevf[l, 2] = phi[l, 0] * p2 + phi[l, 1] * hv2


@kernel
def tfe_step(tab, phi, work, piv, p0, p1, p2, v0, v1, v2, h, gm, max_iter, predicted):
    r"""One step of the k-stage energy-momentum time finite element (module notes).

    Why the energy is exact, not only accurate to the quadrature's order. Gauss' coefficients
    satisfy ``b_i a_ij + b_j a_ji = b_i b_j``, so for ANY stage values the quadratic quantities
    change by exact sums over the nodes: ``|v1|^2/2 - |v0|^2/2 = h sum_l b_l V_l . F_l`` and
    ``|p1|^2 - |p0|^2 = 2 h sum_l b_l Q_l . V_l`` (``|p|^2`` has degree 2k, its derivative 2k - 1,
    which the k-point rule integrates exactly). The second gives the potential drop as a sum
    over the nodes, ``U(p0) - U(p1) = GM (r0 - r1) / (r0 r1) = -GM (r1^2 - r0^2) / (r0 r1 (r0 +
    r1)) = -GM h K sum_l b_l s_l``, and the nodal forces' work is ``-GM h sum_l b_l s_l / r_l^3 +
    h mu sum_l b_l s_l^2``, which mu makes equal to it. The correction is the least-squares one
    among radial corrections (``beta_l = mu s_l``): its denominator ``sum b_l s_l^2`` vanishes
    only where every s_l does (a circular orbit), and then so does its numerator. A scalar
    factor ``(1 + alpha)`` on every ``g(Q_l)`` would divide by the work ``sum b_l s_l / r_l^3``,
    which vanishes in a step across an apse (``r1 = r0`` gives alpha = -1: the step drops
    gravity). mu is the Gauss rule's error on ``int dU``, O(h^{2k}), and so is the correction.

    Angular momentum: by the same identity ``L1 - L0 = h sum_l b_l (V_l x V_l + Q_l x F_l)``,
    and every F_l lies along Q_l. Symmetry: the Gauss method is symmetric, and under ``h -> -h``
    the nodes mirror, s_l and mu change sign and ``mu s_l`` is the same at the mirrored node.

    The solve: with ``Q_l = x_l p0 + y_l h v0``, ``u_l = (x_l, y_l)``, the metric
    ``G = [[p0.p0, h p0.v0], [h p0.v0, h^2 v0.v0]]`` and ``tau = GM h^2``::

        u_l = (1, c_l) + sum_j (a^2)_lj phi_j,     w_l = (0, 1) + sum_j a_lj phi_j   (h V_l),
        Phi_l = u_l (-tau / r_l^3 + nu s~_l),      s~_l = u_l^T G w_l,  r_l^2 = u_l^T G u_l,
        nu = tau sum b_l s~_l (1/r_l^3 - K) / sum b_l s~_l^2,

    residual ``phi - Phi(phi)``, Jacobian ``I - D_l (a^2)_lj`` with ``D_l = -tau / r_l^3 (I - 3 u_l
    (G u_l)^T / r_l^2)`` (the correction's derivative, O(h^{2k}), left out). The end of the step
    is ``p1 - p0 = X p0 + Y h v0``, ``(X, Y) = (0, 1) + sum_j b_j (1 - c_j) phi_j``, and ``v1 - v0 =
    Xv p0 / h + Yv v0``, ``(Xv, Yv) = sum_j b_j phi_j``: the orbit's plane is kept by construction.
    The matrix is factored at the first iteration and its factors are kept while each update
    shrinks by 2^-6 or more (chord iterations; refactored at the iteration after one that does
    not). Newton stops when its update ``d`` falls below ``2^-53 max|phi|`` (relative to the forces,
    not to the basis: an absolute 1e-17 in phi is 1e-17 / (h omega) of the velocity's
    increment, which drifts the energy at small steps), or when the next update, estimated
    from the contraction just seen (``d^2 / d_prev``, an upper bound where convergence is
    quadratic, the chord's own rate where it is linear), would be below it, or when it stops
    shrinking below ``2^-40 max|phi|`` (its round-off floor) with fresh factors; otherwise it
    fails with ``STATUS_NO_CONVERGENCE``.

    Parameters
    ----------
    tab : ndarray
        (k, 3 + 2k) Gauss tables (:func:`tables`).
    phi : ndarray
        (k, 2) the scaled nodal forces in the basis (p0, h v0): the predictor in (when
        ``predicted``), the solution out.
    work : ndarray
        (2k, 2k + 8) scratch.
    piv : ndarray
        (2k,) int64 scratch: the factors' pivot rows.
    p0, p1, p2 : float
        Offset of the point from the centre, m.
    v0, v1, v2 : float
        Velocity, m/s.
    h : float
        Step (either sign), s.
    gm : float
        GM, m^3/s^2.
    max_iter : int
        Newton iterations at most.
    predicted : bool
        Whether ``phi`` holds a predictor; otherwise gravity at ``u_l = (1, c_l)`` starts.

    Returns
    -------
    tuple
        (dx0, dx1, dx2, dv0, dv1, dv2, X, Y, iterations, status): the increments of position
        and velocity, the end's coefficients (p1 = p0 + X p0 + Y h v0), Newton iterations and
        a ``STATUS_*`` code.
    """
    k = tab.shape[0]
    n = 2 * k
    hv0 = h * v0
    hv1 = h * v1
    hv2 = h * v2
    g00 = p0 * p0 + p1 * p1 + p2 * p2
    g01 = p0 * hv0 + p1 * hv1 + p2 * hv2
    g11 = hv0 * hv0 + hv1 * hv1 + hv2 * hv2
    r0 = math.sqrt(g00)
    tau = gm * (h * h)
    J = work[:, :n]
    rhs = work[:, n]
    ir3 = work[:k, n + 1]
    sig = work[:k, n + 2]
    ux = work[:k, n + 3]
    uy = work[:k, n + 4]
    gx = work[:k, n + 5]
    gy = work[:k, n + 6]
    if not predicted:
        for l in range(k):
            x = 1.0
            y = tab[l, 0]
            r2 = g00 * x * x + 2.0 * g01 * x * y + g11 * y * y
            s = -tau / (r2 * math.sqrt(r2))
            phi[l, 0] = s * x
            phi[l, 1] = s * y
    prev = math.inf
    status = STATUS_NO_CONVERGENCE
    its = 0
    fresh = True  # factor the matrix at this iteration's stages (else keep the last factors)
    while its < max_iter:
        its += 1
        # stages, end point and the energy correction from phi
        ex = 0.0
        ey = 1.0
        for l in range(k):
            ex += tab[l, 2] * phi[l, 0]
            ey += tab[l, 2] * phi[l, 1]
        re = math.sqrt(g00 * (1.0 + ex) * (1.0 + ex) + 2.0 * g01 * (1.0 + ex) * ey + g11 * ey * ey)
        kk = 2.0 / (r0 * re * (r0 + re))
        num = 0.0
        den = 0.0
        for l in range(k):
            x = 1.0
            y = tab[l, 0]
            wx = 0.0
            wy = 1.0
            for j in range(k):
                x += tab[l, 3 + k + j] * phi[j, 0]
                y += tab[l, 3 + k + j] * phi[j, 1]
                wx += tab[l, 3 + j] * phi[j, 0]
                wy += tab[l, 3 + j] * phi[j, 1]
            a = g00 * x + g01 * y
            b = g01 * x + g11 * y
            r2 = a * x + b * y
            ir3[l] = 1.0 / (r2 * math.sqrt(r2))
            sig[l] = a * wx + b * wy
            ux[l] = x
            uy[l] = y
            gx[l] = a / r2
            gy[l] = b / r2
            num += tab[l, 1] * sig[l] * (ir3[l] - kk)
            den += tab[l, 1] * sig[l] * sig[l]
        nu = tau * num / den if den > 0.0 else 0.0
        # residual and Jacobian
        for l in range(k):
            s = -tau * ir3[l]
            f = s + nu * sig[l]
            rhs[2 * l] = phi[l, 0] - f * ux[l]
            rhs[2 * l + 1] = phi[l, 1] - f * uy[l]
            if not fresh:
                continue
            d00 = s * (1.0 - 3.0 * ux[l] * gx[l])
            d01 = s * (-3.0 * ux[l] * gy[l])
            d10 = s * (-3.0 * uy[l] * gx[l])
            d11 = s * (1.0 - 3.0 * uy[l] * gy[l])
            for j in range(k):
                m = tab[l, 3 + k + j]
                J[2 * l, 2 * j] = -d00 * m
                J[2 * l, 2 * j + 1] = -d01 * m
                J[2 * l + 1, 2 * j] = -d10 * m
                J[2 * l + 1, 2 * j + 1] = -d11 * m
            J[2 * l, 2 * l] += 1.0
            J[2 * l + 1, 2 * l + 1] += 1.0
        if not abs(re + nu + rhs[0]) < math.inf:
            status = STATUS_SINGULAR
            break
        if fresh and not lu(J, piv, n):
            status = STATUS_SINGULAR
            break
        lu_solve(J, piv, rhs, n)
        d = 0.0
        scale = 0.0
        for l in range(k):
            phi[l, 0] -= rhs[2 * l]
            phi[l, 1] -= rhs[2 * l + 1]
            d = max(d, abs(rhs[2 * l]), abs(rhs[2 * l + 1]))
            scale = max(scale, abs(phi[l, 0]), abs(phi[l, 1]))
        if d <= _TOL * scale or (prev < math.inf and d * d <= _TOL * scale * prev):
            # below round-off, or the next update, by the contraction just seen, would be
            status = STATUS_OK
            break
        if d >= prev and fresh:
            if d < _FLOOR * scale:
                status = STATUS_OK
            break
        # factors kept while they contract fast; refreshed where they do not (or diverge)
        fresh = d > _REFRESH * prev
        prev = d
    ex = 0.0
    ey = 1.0
    vx = 0.0
    vy = 0.0
    for l in range(k):
        ex += tab[l, 2] * phi[l, 0]
        ey += tab[l, 2] * phi[l, 1]
        vx += tab[l, 1] * phi[l, 0]
        vy += tab[l, 1] * phi[l, 1]
    ih = 1.0 / h
    return (
        ex * p0 + ey * hv0,
        ex * p1 + ey * hv1,
        ex * p2 + ey * hv2,
        vx * ih * p0 + vy * v0,
        vx * ih * p1 + vy * v1,
        vx * ih * p2 + vy * v2,
        ex,
        ey,
        its,
        status,
    )


@kernel
def tfe_chunk(tab, x, v, cx, cv, gm, center, dt, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail):
    """Advance every point ``nrec * every`` steps of size ``dt`` of the time finite element
    whose Gauss tables are ``tab`` (:func:`tables`), recording every ``every`` steps.

    Arguments and records are those of :func:`~.reference.implicit_chunk` without the method
    code and the composition: ``x, v, cx, cv`` (3, n) updated in place, ``rec_x, rec_v``
    (nrec, 3, n), ``rec_iters`` (nrec, n), ``fail`` (n, 2) pre-filled with -1. Each step after
    the first starts Newton from the previous step's force polynomial."""
    k = tab.shape[0]
    n = x.shape[1]
    phi = np.empty((k, 2))
    work = np.empty((2 * k, 2 * k + 8))
    piv = np.empty(2 * k, np.int64)
    prevf = np.empty((k, 3))
    ext = _extrapolation(tab, 1.0)
    for i in range(n):
        t0 = x[0, i]
        t1 = x[1, i]
        t2 = x[2, i]
        u0 = v[0, i]
        u1 = v[1, i]
        u2 = v[2, i]
        e0 = cx[0, i]
        e1 = cx[1, i]
        e2 = cx[2, i]
        f0 = cv[0, i]
        f1 = cv[1, i]
        f2 = cv[2, i]
        have = False
        failed = False
        for r in range(nrec):
            its = 0
            for s in range(every):
                p0 = t0 - center[0]
                p1 = t1 - center[1]
                p2 = t2 - center[2]
                if have:
                    hv0 = dt * u0
                    hv1 = dt * u1
                    hv2 = dt * u2
                    predict(ext, phi, prevf, p0, p1, p2, hv0, hv1, hv2, 1.0)
                d0, d1, d2, w0, w1, w2, ex, ey, it, status = tfe_step(
                    tab, phi, work, piv, p0, p1, p2, u0, u1, u2, dt, gm, max_iter, have
                )
                its += it
                n0, m0 = kahan_add(t0, e0, d0)
                n1, m1 = kahan_add(t1, e1, d1)
                n2, m2 = kahan_add(t2, e2, d2)
                a0, b0 = kahan_add(u0, f0, w0)
                a1, b1 = kahan_add(u1, f1, w1)
                a2, b2 = kahan_add(u2, f2, w2)
                if status == STATUS_OK and not abs(n0 + n1 + n2 + a0 + a1 + a2) < math.inf:
                    status = STATUS_SINGULAR
                if status != STATUS_OK:
                    fail[i, 0] = r * every + s
                    fail[i, 1] = status
                    failed = True
                    break
                keep_forces(prevf, phi, p0, p1, p2, dt * u0, dt * u1, dt * u2)
                have = True
                t0, t1, t2, u0, u1, u2 = n0, n1, n2, a0, a1, a2
                e0, e1, e2, f0, f1, f2 = m0, m1, m2, b0, b1, b2
            if failed:
                break
            rec_x[r, 0, i] = t0
            rec_x[r, 1, i] = t1
            rec_x[r, 2, i] = t2
            rec_v[r, 0, i] = u0
            rec_v[r, 1, i] = u1
            rec_v[r, 2, i] = u2
            rec_iters[r, i] = its
        x[0, i] = t0
        x[1, i] = t1
        x[2, i] = t2
        v[0, i] = u0
        v[1, i] = u1
        v[2, i] = u2
        cx[0, i] = e0
        cx[1, i] = e1
        cx[2, i] = e2
        cv[0, i] = f0
        cv[1, i] = f1
        cv[2, i] = f2
