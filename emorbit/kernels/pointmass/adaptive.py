"""Adaptive steps for point masses: each point steps by a fraction ``eta`` of its local Kepler
time scale, ``h = eta * 2 pi sqrt(r**3 / GM)`` (a Sundman-type rule, dt proportional to
r**(3/2)), bounded above by ``dt_max``, and lands exactly on the record times.

The energy-momentum step conserves energy and angular momentum for any step size, so exact
conservation survives any step sequence; compositions (order 4-8) are applied to every
adaptive step. Points are independent, so each takes its own sequence; the records stay on
the common grid ``every * dt_max``. The step size depends only on the state at the start of
the step, so results do not depend on how a run is cut into chunks (bit-exact restarts).

A step whose Newton iteration fails is retried with half the step, up to
:data:`MAX_HALVINGS` times, before the point is reported as failed.
"""

from __future__ import annotations

import math

from ..codes import METHOD_EM, METHOD_EM_PLAIN, METHOD_LEAPFROG, STATUS_OK, STATUS_SINGULAR
from ..eft import kahan_add
from ..jit import kernel
from .reference import em_step, midpoint_step

__all__ = ["adaptive_chunk", "MAX_HALVINGS"]

MAX_HALVINGS = 20
_TWO_PI = 2.0 * math.pi


@kernel
def _leapfrog_sub(px, py, pz, vx, vy, vz, h, gm, c0, c1, c2):
    """One kick-drift-kick sub-step: (dx, dy, dz, dvx, dvy, dvz, 0, status)."""
    ax = c0 - px
    ay = c1 - py
    az = c2 - pz
    r0 = math.sqrt(ax * ax + ay * ay + az * az)
    f0 = gm / (r0 * r0 * r0)
    hf = 0.5 * h
    dx = h * (vx + hf * f0 * ax)
    dy = h * (vy + hf * f0 * ay)
    dz = h * (vz + hf * f0 * az)
    bx = ax - dx
    by = ay - dy
    bz = az - dz
    r1 = math.sqrt(bx * bx + by * by + bz * bz)
    f1 = gm / (r1 * r1 * r1)
    status = STATUS_OK if (r1 > 0.0 and r1 < math.inf) else STATUS_SINGULAR
    return dx, dy, dz, hf * (f0 * ax + f1 * bx), hf * (f0 * ay + f1 * by), hf * (f0 * az + f1 * bz), 0, status


@kernel
def _composed(method, px, py, pz, vx, vy, vz, ex, ey, ez, fx, fy, fz, h, gammas, gm, c0, c1, c2, max_iter):
    """One composed step of size h from a state with Kahan terms; returns the new state and
    (iterations, status). On failure the returned state is meaningless."""
    its = 0
    for k in range(gammas.shape[0]):
        hk = h * gammas[k]
        if method == METHOD_EM or method == METHOD_EM_PLAIN:
            d0, d1, d2, w0, w1, w2, it, status = em_step(
                px, py, pz, vx, vy, vz, hk, gm, c0, c1, c2, max_iter, method == METHOD_EM
            )
        elif method == METHOD_LEAPFROG:
            d0, d1, d2, w0, w1, w2, it, status = _leapfrog_sub(px, py, pz, vx, vy, vz, hk, gm, c0, c1, c2)
        else:
            d0, d1, d2, w0, w1, w2, it, status = midpoint_step(px, py, pz, vx, vy, vz, hk, gm, c0, c1, c2, max_iter)
        its += it
        if status != STATUS_OK:
            return px, py, pz, vx, vy, vz, ex, ey, ez, fx, fy, fz, its, status
        px, ex = kahan_add(px, ex, d0)
        py, ey = kahan_add(py, ey, d1)
        pz, ez = kahan_add(pz, ez, d2)
        vx, fx = kahan_add(vx, fx, w0)
        vy, fy = kahan_add(vy, fy, w1)
        vz, fz = kahan_add(vz, fz, w2)
        if not (abs(px + py + pz + vx + vy + vz) < math.inf):
            return px, py, pz, vx, vy, vz, ex, ey, ez, fx, fy, fz, its, STATUS_SINGULAR
    return px, py, pz, vx, vy, vz, ex, ey, ez, fx, fy, fz, its, STATUS_OK


@kernel
def adaptive_chunk(
    method,
    x,
    v,
    cx,
    cv,
    gm,
    center,
    dt_max,
    eta,
    gammas,
    every,
    nrec,
    max_iter,
    rec_x,
    rec_v,
    rec_iters,
    rec_steps,
    fail,
):
    """Advance every point by ``nrec`` record intervals of ``every * dt_max`` with adaptive steps.

    method       METHOD_EM, METHOD_EM_PLAIN (3), METHOD_MIDPOINT (1) or METHOD_LEAPFROG
    eta          steps per local Kepler time scale: h = eta 2 pi sqrt(r^3 / GM) <= dt_max
    rec_steps    (nrec, n) steps each point took in each interval
    Other arguments as in :func:`emorbit.kernels.pointmass.reference.implicit_chunk`; ``fail[i]`` holds
    (record interval index * every, status) for a point that failed even after halving its
    step :data:`MAX_HALVINGS` times (the point then stops at the start of that interval).
    """
    n = x.shape[1]
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    interval = every * dt_max
    inv_gm = 1.0 / gm
    for i in range(n):
        px, py, pz = x[0, i], x[1, i], x[2, i]
        vx, vy, vz = v[0, i], v[1, i], v[2, i]
        ex, ey, ez = cx[0, i], cx[1, i], cx[2, i]
        fx, fy, fz = cv[0, i], cv[1, i], cv[2, i]
        failed = False
        for r in range(nrec):
            its = 0
            steps = 0
            elapsed = 0.0
            comp = 0.0
            last = False
            sx, sy, sz, sv0, sv1, sv2 = px, py, pz, vx, vy, vz  # state at the interval's start
            se0, se1, se2, sf0, sf1, sf2 = ex, ey, ez, fx, fy, fz
            while not last:
                rx = c0 - px
                ry = c1 - py
                rz = c2 - pz
                rr = math.sqrt(rx * rx + ry * ry + rz * rz)
                h = eta * _TWO_PI * rr * math.sqrt(rr * inv_gm)
                if h > dt_max:
                    h = dt_max
                rem = interval - elapsed
                if h >= rem:
                    h = rem
                    last = True
                elif h > 0.5 * rem:
                    h = 0.5 * rem  # two even steps rather than a long one and a sliver
                ok = False
                for _halving in range(MAX_HALVINGS + 1):
                    (qx, qy, qz, wx, wy, wz, gx, gy, gz, kx, ky, kz, it, status) = _composed(
                        method, px, py, pz, vx, vy, vz, ex, ey, ez, fx, fy, fz, h, gammas, gm, c0, c1, c2, max_iter
                    )
                    its += it
                    if status == STATUS_OK:
                        ok = True
                        break
                    h *= 0.5
                    last = False
                if not ok:
                    failed = True
                    break
                px, py, pz, vx, vy, vz = qx, qy, qz, wx, wy, wz
                ex, ey, ez, fx, fy, fz = gx, gy, gz, kx, ky, kz
                elapsed, comp = kahan_add(elapsed, comp, h)
                steps += 1
            if failed:
                px, py, pz, vx, vy, vz = sx, sy, sz, sv0, sv1, sv2
                ex, ey, ez, fx, fy, fz = se0, se1, se2, sf0, sf1, sf2
                fail[i, 0] = r * every
                fail[i, 1] = status
                break
            rec_x[r, 0, i] = px
            rec_x[r, 1, i] = py
            rec_x[r, 2, i] = pz
            rec_v[r, 0, i] = vx
            rec_v[r, 1, i] = vy
            rec_v[r, 2, i] = vz
            rec_iters[r, i] = its
            rec_steps[r, i] = steps
        x[0, i], x[1, i], x[2, i] = px, py, pz
        v[0, i], v[1, i], v[2, i] = vx, vy, vz
        cx[0, i], cx[1, i], cx[2, i] = ex, ey, ez
        cv[0, i], cv[1, i], cv[2, i] = fx, fy, fz
