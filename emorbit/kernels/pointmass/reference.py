"""Point-mass (test-particle) step kernels, one point at a time: energy-momentum, implicit
midpoint, leapfrog. The reference the packed kernels (:mod:`.packed`) are tested against, and the
per-point steps the adaptive (:mod:`.adaptive`) and scalar fallback paths use.

The points do not disturb the field and do not attract each other, so every point is
integrated on its own. State arrays are structure-of-arrays float64, shape (3, n):
positions ``x``, velocities ``v`` and their compensation terms ``cx``, ``cv`` (the low
bits lost by ``x += dx``, carried by Kahan summation).

One step of size ``h`` of each implicit method solves for the increment ``dx = x1 - x0``::

    R(dx) = dx - h v0 - h**2/2 g_*(dx) = 0,    v1 = v0 + h g_*(dx)

with ``g_* = g_em(x0, x0 + dx)`` (``em``) or ``g(x0 + dx/2)`` (``midpoint``). Both Jacobians
are a scaled identity plus a rank-one term, so each Newton update is solved exactly by the
Sherman-Morrison formula. Newton starts from the explicit Taylor predictor
``h v0 + h**2/2 g(x0)`` and stops when the update falls below the round-off of the unknown
or stops shrinking (its floor), never at a loose tolerance. Leapfrog is kick-drift-kick; the
closing kick's acceleration is reused by the next sub-step's opening kick.

A chunk kernel advances every point ``nrec * every`` steps of the composed method (each
step is the sequence of sub-steps ``gammas[k] * dt``), storing the state every ``every`` steps.

Two details keep the energy error a random walk (Brouwer's law) instead of a drift
(docs/methods.md has the measurements):

* ``h**2/2`` is never formed: a rounded ``hh = fl(h*h/2)`` carries the same relative error
  in every step, an energy error ``-hh eps |g|**2`` of one sign. The residual is written
  ``dx - h (v0 + (h/2) g)``, whose roundings depend on the state.
* ``em`` ends with an accurate update (:func:`em_finish`): Newton in floating point converges
  on the plain evaluation of ``g_em``, whose error of a few roundings is then correlated with
  the solution it picks. One more Newton update whose residual uses ``g_em`` evaluated to
  within a rounding (:func:`~.gravity.em_accel_dd_lo`) and is itself carried to eps**2
  (:func:`_residual`) leaves nothing to correlate with. ``roundoff="fast"`` skips it.

Failures (Newton not converging, a point at the centre, a non-finite state) stop that point
before the failing step and are reported in ``fail`` (step index, code, ``STATUS_*``); the
caller turns them into errors.
"""

from __future__ import annotations

import math

from ..codes import METHOD_EM, METHOD_EM_PLAIN, METHOD_MIDPOINT, STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from ..eft import fma, kahan_add, two_sum
from ..gravity import (
    accel,
    accel_jacobian_coeffs,
    em_accel,
    em_accel_dd_lo,
    em_accel_root,
    em_jacobian_coeffs,
    norm_sq_lo,
)
from ..jit import kernel

__all__ = [
    "STATUS_OK",
    "STATUS_NO_CONVERGENCE",
    "STATUS_SINGULAR",
    "METHOD_EM",
    "METHOD_MIDPOINT",
    "METHOD_EM_PLAIN",
    "kahan_add",
    "em_step",
    "em_finish",
    "midpoint_step",
    "implicit_chunk",
    "leapfrog_chunk",
]

_EPS = 2.220446049250313e-16
_TOL2 = (4.0 * _EPS) ** 2  # converged: |update| <= 4 eps |scale|
_FLOOR2 = (1024.0 * _EPS) ** 2  # a stalled update is accepted as round-off below 1024 eps |scale|


@kernel
def _newton_done(d2, prev2, scale2):
    """Newton stopping rule on squared norms: returns (stop, converged). Converged when the
    update is at round-off, or no longer shrinks once below 1024 eps (its floor); a larger
    update that grows (far from the solution) keeps iterating until max_iter."""
    if d2 <= _TOL2 * scale2 or (d2 >= prev2 and d2 <= _FLOOR2 * scale2):
        return True, True
    return False, False


@kernel(inline="always")
def _residual(d, v, g, gl, h, hf):
    """``d - h (v + hf (g + gl))`` with the products and the sum carried to about eps**2
    (error-free transformations; ``g + gl`` the double-double ``g_em``): the residual of the
    energy-momentum step is then exact to far below one rounding of ``d``, so the Newton
    update lands on the rounded exact solution whatever ``d`` it starts from (the packed and
    reference kernels start from different ones). With ``g`` rounded to a double (``gl``
    dropped) the residual would carry an error of a rounding of ``h hf g``, at large steps
    one of ``d``, which the update converges on: a drift at large steps (docs/methods.md)."""
    q = hf * g
    s, es = two_sum(v, q)
    es += fma(hf, g, -q) + hf * gl
    p = h * s
    ep = fma(h, s, -p) + h * es
    return (d - p) - ep


@kernel(inline="always")
def em_finish(ax, ay, az, r0, vx, vy, vz, dx, dy, dz, h, gm):
    """The last update of an energy-momentum step whose Newton iteration (in plain floating
    point) has converged to ``dx``: one more Newton update whose residual uses ``g_em``
    evaluated to about eps**2 (:func:`~.gravity.em_accel_dd`) and is itself carried to
    eps**2 (:func:`_residual`), and ``g_em`` at the updated ``dx`` for the velocity (the
    accurate value, moved by the update to first order, rounded once). Returns (dx, dy, dz,
    gx, gy, gz); ``a = X_Z - x0`` and ``r0 = sqrt(ax*ax + ay*ay + az*az)``, evaluated plainly.

    Why (see the module notes): the plain evaluation's error of a few roundings is what
    Newton converges on, so the solution it picks is correlated with that error and the
    energy drifts. From an accurate ``g_em`` and residual the update lands within a rounding
    of the exact solution whatever ``dx`` it starts from, with nothing to correlate with. A
    Newton update (not a fixed-point one) keeps this sound at any step size, where
    ``h**2/2 |dg/dx|`` exceeds 1. ``b = a - dx`` is formed with its rounding error (a
    two-sum), and ``g_em`` evaluated at the exact difference
    (:func:`~.gravity.em_accel_dd_lo`): the state moves by exactly ``dx``, and with ``b``
    rounded the update would converge on that rounding (docs/methods.md).
    Cost: one square root and two divisions (the Jacobian's coefficients come from the
    reciprocal of :func:`~.gravity.em_accel_root`), and about 120 other operations."""
    hf = 0.5 * h
    hh = hf * h
    t0 = norm_sq_lo(ax, ay, az, r0)
    bx, cbx = two_sum(ax, -dx)
    by, cby = two_sum(ay, -dy)
    bz, cbz = two_sum(az, -dz)
    r1, iP = em_accel_root(bx, by, bz, r0)
    gx, gy, gz, lx, ly, lz, k = em_accel_dd_lo(ax, ay, az, r0, t0, bx, by, bz, cbx, cby, cbz, gm, r1, iP)
    rx = _residual(dx, vx, gx, lx, h, hf)
    ry = _residual(dy, vy, gy, ly, h, hf)
    rz = _residual(dz, vz, gz, lz, h, hf)
    # Newton: J = (1 + hh k) I - hh w u b^T (see em_step), w = k (s + r1) / (r1**2 s) with
    # 1 / (r1**2 s) = r0**2 s iP**2; Sherman-Morrison with one division:
    # e = (D r - wj (b.r) u) / (cj D), D = cj + wj (b.u)
    s = r0 + r1
    w = k * (s + r1) * ((r0 * r0) * s * (iP * iP))
    cj = 1.0 + hh * k
    wj = -hh * w
    ux = ax + bx
    uy = ay + by
    uz = az + bz
    D = cj + wj * (bx * ux + by * uy + bz * uz)
    f = wj * (bx * rx + by * ry + bz * rz)
    iD = 1.0 / (cj * D)
    ex = (D * rx - f * ux) * iD
    ey = (D * ry - f * uy) * iD
    ez = (D * rz - f * uz) * iD
    # g_em at dx - e, to first order: g + k e - w (b.e) u, added to the accurate value's
    # correction before the one rounding
    f = w * (bx * ex + by * ey + bz * ez)
    return (
        dx - ex,
        dy - ey,
        dz - ez,
        gx + (lx + (k * ex - f * ux)),
        gy + (ly + (k * ey - f * uy)),
        gz + (lz + (k * ez - f * uz)),
    )


@kernel
def em_step(px, py, pz, vx, vy, vz, h, gm, cx, cy, cz, max_iter, finish):
    """One energy-momentum step of size ``h`` for one point; ``finish``: end with
    :func:`em_finish` (the default of every caller but roundoff="fast").

    Returns (dx, dy, dz, dvx, dvy, dvz, iterations, status).
    """
    ax = cx - px
    ay = cy - py
    az = cz - pz
    g0x, g0y, g0z, r0 = accel(ax, ay, az, gm)
    hf = 0.5 * h  # exact; h*h/2 is never formed (see the module notes on bias)
    hh = hf * h  # rounded: used in the Jacobian only, which does not move the solution
    dx = h * (vx + hf * g0x)
    dy = h * (vy + hf * g0y)
    dz = h * (vz + hf * g0z)
    scale2 = h * h * ((vx * vx + vy * vy + vz * vz) + hf * hf * (g0x * g0x + g0y * g0y + g0z * g0z))
    gx = g0x
    gy = g0y
    gz = g0z
    prev2 = math.inf
    status = STATUS_NO_CONVERGENCE
    it = 0
    while it < max_iter:
        it += 1
        bx = ax - dx
        by = ay - dy
        bz = az - dz
        gx, gy, gz, r1, k = em_accel(ax, ay, az, r0, bx, by, bz, gm)
        if not (r1 > 0.0 and r1 < math.inf):
            status = STATUS_SINGULAR
            break
        rx = dx - h * (vx + hf * gx)
        ry = dy - h * (vy + hf * gy)
        rz = dz - h * (vz + hf * gz)
        # J = I - hh dg_em/dx10 = (1 + hh k) I - hh w (a + b) b^T
        c, w = em_jacobian_coeffs(r0, r1, k)
        cj = 1.0 - hh * c
        wj = -hh * w
        ux = ax + bx
        uy = ay + by
        uz = az + bz
        f = wj * (bx * rx + by * ry + bz * rz) / (cj + wj * (bx * ux + by * uy + bz * uz))
        ex = (rx - f * ux) / cj
        ey = (ry - f * uy) / cj
        ez = (rz - f * uz) / cj
        dx -= ex
        dy -= ey
        dz -= ez
        if not finish:
            # g_em at the updated iterate, to first order: g - (c I + w u b^T) e
            f = w * (bx * ex + by * ey + bz * ez)
            gx -= c * ex + f * ux
            gy -= c * ey + f * uy
            gz -= c * ez + f * uz
        d2 = ex * ex + ey * ey + ez * ez
        stop, converged = _newton_done(d2, prev2, max(scale2, dx * dx + dy * dy + dz * dz))
        if stop:
            status = STATUS_OK if converged else STATUS_NO_CONVERGENCE
            break
        prev2 = d2
    if status == STATUS_OK and finish:
        dx, dy, dz, gx, gy, gz = em_finish(ax, ay, az, r0, vx, vy, vz, dx, dy, dz, h, gm)
    return dx, dy, dz, h * gx, h * gy, h * gz, it, status


@kernel
def midpoint_step(px, py, pz, vx, vy, vz, h, gm, cx, cy, cz, max_iter):
    """One implicit-midpoint step of size ``h`` for one point: g at (x00 + x10) / 2.

    Returns (dx, dy, dz, dvx, dvy, dvz, iterations, status).
    """
    ax = cx - px
    ay = cy - py
    az = cz - pz
    g0x, g0y, g0z, r0 = accel(ax, ay, az, gm)
    hf = 0.5 * h  # exact; h*h/2 is never formed (see the module notes on bias)
    hh = hf * h  # rounded: used in the Jacobian only, which does not move the solution
    dx = h * (vx + hf * g0x)
    dy = h * (vy + hf * g0y)
    dz = h * (vz + hf * g0z)
    scale2 = h * h * ((vx * vx + vy * vy + vz * vz) + hf * hf * (g0x * g0x + g0y * g0y + g0z * g0z))
    gx = g0x
    gy = g0y
    gz = g0z
    prev2 = math.inf
    status = STATUS_NO_CONVERGENCE
    it = 0
    while it < max_iter:
        it += 1
        mx = ax - 0.5 * dx
        my = ay - 0.5 * dy
        mz = az - 0.5 * dz
        gx, gy, gz, r = accel(mx, my, mz, gm)
        if not (r > 0.0 and r < math.inf):
            status = STATUS_SINGULAR
            break
        rx = dx - h * (vx + hf * gx)
        ry = dy - h * (vy + hf * gy)
        rz = dz - h * (vz + hf * gz)
        # J = I - hh/2 dg/dx (x05) = (1 - hh c / 2) I - (hh w / 2) m m^T
        c, w = accel_jacobian_coeffs(r, gm)
        cj = 1.0 - 0.5 * hh * c
        wj = -0.5 * hh * w
        f = wj * (mx * rx + my * ry + mz * rz) / (cj + wj * (mx * mx + my * my + mz * mz))
        ex = (rx - f * mx) / cj
        ey = (ry - f * my) / cj
        ez = (rz - f * mz) / cj
        dx -= ex
        dy -= ey
        dz -= ez
        d2 = ex * ex + ey * ey + ez * ez
        stop, converged = _newton_done(d2, prev2, max(scale2, dx * dx + dy * dy + dz * dz))
        if stop:
            status = STATUS_OK if converged else STATUS_NO_CONVERGENCE
            break
        prev2 = d2
    return dx, dy, dz, h * gx, h * gy, h * gz, it, status


@kernel
def _finite(a, b, c, d, e, f):
    return abs(a + b + c + d + e + f) < math.inf


@kernel
def implicit_chunk(method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail):
    """Advance every point ``nrec * every`` composed steps of ``em`` or ``midpoint``.

    method     METHOD_EM, METHOD_EM_PLAIN or METHOD_MIDPOINT
    x, v       (3, n) state, updated in place; cx, cv (3, n) their compensation terms
    gm, center field strength (m^3/s^2) and centre (3,) in m
    dt, gammas step (s) and composition coefficients (sum 1); sub-step k is gammas[k] * dt
    every      steps between records; nrec records are written
    rec_x/rec_v (nrec, 3, n) state after each record interval
    rec_iters  (nrec, n) Newton iterations summed over each interval's sub-steps
    fail       (n, 2) int64, set to (step index in this chunk, status) for a point that
               failed; that point stops before the failing step (the caller pre-fills -1)
    """
    n = x.shape[1]
    ns = gammas.shape[0]
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    for i in range(n):
        p0 = x[0, i]
        p1 = x[1, i]
        p2 = x[2, i]
        q0 = v[0, i]
        q1 = v[1, i]
        q2 = v[2, i]
        e0 = cx[0, i]
        e1 = cx[1, i]
        e2 = cx[2, i]
        f0 = cv[0, i]
        f1 = cv[1, i]
        f2 = cv[2, i]
        failed = False
        for r in range(nrec):
            its = 0
            for s in range(every):
                # sub-steps go into trial copies: a failing step leaves the state untouched
                t0, t1, t2, u0, u1, u2 = p0, p1, p2, q0, q1, q2
                g0, g1, g2, k0, k1, k2 = e0, e1, e2, f0, f1, f2
                for k in range(ns):
                    h = dt * gammas[k]
                    if method != METHOD_MIDPOINT:
                        d0, d1, d2, w0, w1, w2, it, status = em_step(
                            t0, t1, t2, u0, u1, u2, h, gm, c0, c1, c2, max_iter, method == METHOD_EM
                        )
                    else:
                        d0, d1, d2, w0, w1, w2, it, status = midpoint_step(
                            t0, t1, t2, u0, u1, u2, h, gm, c0, c1, c2, max_iter
                        )
                    its += it
                    t0, g0 = kahan_add(t0, g0, d0)
                    t1, g1 = kahan_add(t1, g1, d1)
                    t2, g2 = kahan_add(t2, g2, d2)
                    u0, k0 = kahan_add(u0, k0, w0)
                    u1, k1 = kahan_add(u1, k1, w1)
                    u2, k2 = kahan_add(u2, k2, w2)
                    if status == STATUS_OK and not _finite(t0, t1, t2, u0, u1, u2):
                        status = STATUS_SINGULAR
                    if status != STATUS_OK:
                        fail[i, 0] = r * every + s
                        fail[i, 1] = status
                        failed = True
                        break
                if failed:
                    break
                p0, p1, p2, q0, q1, q2 = t0, t1, t2, u0, u1, u2
                e0, e1, e2, f0, f1, f2 = g0, g1, g2, k0, k1, k2
            if failed:
                break
            rec_x[r, 0, i] = p0
            rec_x[r, 1, i] = p1
            rec_x[r, 2, i] = p2
            rec_v[r, 0, i] = q0
            rec_v[r, 1, i] = q1
            rec_v[r, 2, i] = q2
            rec_iters[r, i] = its
        x[0, i] = p0
        x[1, i] = p1
        x[2, i] = p2
        v[0, i] = q0
        v[1, i] = q1
        v[2, i] = q2
        cx[0, i] = e0
        cx[1, i] = e1
        cx[2, i] = e2
        cv[0, i] = f0
        cv[1, i] = f1
        cv[2, i] = f2


@kernel
def leapfrog_chunk(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail):
    """Advance every point with explicit kick-drift-kick leapfrog (same arguments as
    :func:`implicit_chunk` without ``method``; ``max_iter`` is unused, iterations are 0).

    The closing kick's acceleration is reused by the next sub-step's opening kick.
    """
    n = x.shape[1]
    ns = gammas.shape[0]
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    for i in range(n):
        p0 = x[0, i]
        p1 = x[1, i]
        p2 = x[2, i]
        q0 = v[0, i]
        q1 = v[1, i]
        q2 = v[2, i]
        e0 = cx[0, i]
        e1 = cx[1, i]
        e2 = cx[2, i]
        f0 = cv[0, i]
        f1 = cv[1, i]
        f2 = cv[2, i]
        a0, a1, a2, rr = accel(c0 - p0, c1 - p1, c2 - p2, gm)
        failed = not (rr > 0.0 and rr < math.inf)
        if failed:
            fail[i, 0] = 0
            fail[i, 1] = STATUS_SINGULAR
        for r in range(nrec):
            if failed:
                break
            for s in range(every):
                t0, t1, t2, u0, u1, u2 = p0, p1, p2, q0, q1, q2
                g0, g1, g2, k0, k1, k2 = e0, e1, e2, f0, f1, f2
                b0, b1, b2 = a0, a1, a2
                for k in range(ns):
                    h = dt * gammas[k]
                    hf = 0.5 * h
                    t0, g0 = kahan_add(t0, g0, h * (u0 + hf * b0))
                    t1, g1 = kahan_add(t1, g1, h * (u1 + hf * b1))
                    t2, g2 = kahan_add(t2, g2, h * (u2 + hf * b2))
                    n0, n1, n2, rr = accel(c0 - t0, c1 - t1, c2 - t2, gm)
                    u0, k0 = kahan_add(u0, k0, 0.5 * h * (b0 + n0))
                    u1, k1 = kahan_add(u1, k1, 0.5 * h * (b1 + n1))
                    u2, k2 = kahan_add(u2, k2, 0.5 * h * (b2 + n2))
                    b0, b1, b2 = n0, n1, n2
                    if not (rr > 0.0 and rr < math.inf) or not _finite(t0, t1, t2, u0, u1, u2):
                        fail[i, 0] = r * every + s
                        fail[i, 1] = STATUS_SINGULAR
                        failed = True
                        break
                if failed:
                    break
                p0, p1, p2, q0, q1, q2 = t0, t1, t2, u0, u1, u2
                e0, e1, e2, f0, f1, f2 = g0, g1, g2, k0, k1, k2
                a0, a1, a2 = b0, b1, b2
            if failed:
                break
            rec_x[r, 0, i] = p0
            rec_x[r, 1, i] = p1
            rec_x[r, 2, i] = p2
            rec_v[r, 0, i] = q0
            rec_v[r, 1, i] = q1
            rec_v[r, 2, i] = q2
            rec_iters[r, i] = 0
        x[0, i] = p0
        x[1, i] = p1
        x[2, i] = p2
        v[0, i] = q0
        v[1, i] = q1
        v[2, i] = q2
        cx[0, i] = e0
        cx[1, i] = e1
        cx[2, i] = e2
        cv[0, i] = f0
        cv[1, i] = f1
        cv[2, i] = f2
