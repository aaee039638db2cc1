"""Gravity of a fixed point mass at ``X_Z``: the field, its potential, and the conserving
energy-momentum acceleration ``g_em`` over a step (Goettlicher & Schweizerhof).

Conventions (all SI, plain floats)::

    r_vec = X_Z - x            points from the body point to the centre,  r = |r_vec|
    g(x)  = GM r_vec / r**3    V(x) = -GM / r   (potential per unit mass)

    g_em(x00, x10) = GM / (r00 r10) * (r00_vec + r10_vec) / (r00 + r10)

``g_em . (x10 - x00) = V(x00) - V(x10)`` holds algebraically, and ``g_em`` is parallel to
``r00_vec + r10_vec``, so a step driven by it conserves energy and angular momentum about
``X_Z`` exactly. The scalar functions below take and return components so that they inline
into the step kernels; the ``*_points`` functions evaluate them over (3, n) arrays and
exist for tests, diagnostics and other kernels' assembly.
"""

from __future__ import annotations

import math

import numpy as np

from .eft import fma, two_prod, two_sum
from .jit import kernel

__all__ = [
    "accel",
    "accel_jacobian_coeffs",
    "em_accel",
    "em_jacobian_coeffs",
    "norm_sq_lo",
    "em_accel_root",
    "em_accel_dd",
    "em_accel_dd_lo",
    "em_accel_accurate",
    "accel_points",
    "potential_points",
    "em_accel_points",
    "em_jacobian_points",
    "midpoint_accel_points",
]


@kernel
def accel(rx, ry, rz, gm):
    """g for the vector ``r = X_Z - x`` (components): returns (gx, gy, gz, r)."""
    r = math.sqrt(rx * rx + ry * ry + rz * rz)
    f = gm / (r * r * r)
    return f * rx, f * ry, f * rz, r


@kernel
def accel_jacobian_coeffs(r, gm):
    """dg/dx = c I + w r_vec r_vec^T for ``r_vec = X_Z - x``: returns (c, w).

    From g = GM r_vec / r^3 and d r_vec / dx = -I:  dg/dx = GM (-I / r^3 + 3 r_vec r_vec^T / r^5).
    """
    r3 = r * r * r
    return -gm / r3, 3.0 * gm / (r3 * r * r)


@kernel
def em_accel(ax, ay, az, r0, bx, by, bz, gm):
    """g_em for ``a = X_Z - x00`` (length ``r0``, known to the caller) and ``b = X_Z - x10``.

    Returns (gx, gy, gz, r10, k) with g_em = k (a + b), k = GM / (r00 r10 (r00 + r10)).
    """
    r1 = math.sqrt(bx * bx + by * by + bz * bz)
    k = gm / (r0 * r1 * (r0 + r1))
    return k * (ax + bx), k * (ay + by), k * (az + bz), r1, k


@kernel(inline="always")
def norm_sq_lo(x, y, z, r):
    """``x*x + y*y + z*z - r*r`` to about eps**2 of ``r*r``, for ``r = sqrt(x*x + y*y + z*z)``
    evaluated plainly in that order (as :func:`accel`, :func:`em_accel` and the packed
    kernels do); ``|(x, y, z)| = r + lo`` with ``lo`` = this / (2 r) to about 1e-30 relative."""
    p0, e0 = two_prod(x, x)
    p1, e1 = two_prod(y, y)
    p2, e2 = two_prod(z, z)
    s, f1 = two_sum(p0, p1)
    s, f2 = two_sum(s, p2)
    # s - r**2 is exact for a correctly rounded root
    return fma(-r, r, s) + (((e0 + e1) + e2) + (f1 + f2))


@kernel(inline="always")
def em_accel_root(bx, by, bz, r0):
    """The square root and the division of :func:`em_accel_dd`: (r10, iP) with
    ``r10 = sqrt(bx*bx + by*by + bz*bz)`` and ``iP = 1 / (r0 r10 (r0 + r10))``, rounded (a
    separate function so that the packed kernels can run it in a pass of its own)."""
    r1 = math.sqrt((bx * bx + by * by) + bz * bz)
    return r1, 1.0 / ((r0 * r1) * (r0 + r1))


@kernel(inline="always")
def em_accel_dd(ax, ay, az, r0, t0, bx, by, bz, gm, r1, iP):
    """g_em as :func:`em_accel`, to about eps**2: returns (gx, gy, gz, lx, ly, lz, k) with
    ``g = (gx + lx, ...)`` (``gx`` the plainly rounded product, ``lx`` its correction) and
    ``k`` rounded. ``|a| = r0 + t0 / (2 r0)`` (``r0`` plain, ``t0`` from
    :func:`norm_sq_lo`); ``r1, iP`` from :func:`em_accel_root`. No square root and no
    division: ``1 / r0`` and ``1 / r10`` come from ``iP`` (``1 / r0 = r10 s iP``,
    ``s = r0 + r10``).

    Why: the plain evaluation has an error of a few roundings (up to 4 ulp, measured) that a
    Newton iteration in plain floating point converges on, so its work ``dg . dx`` does not
    average out over many steps (see :func:`emorbit.kernels.pointmass.reference.em_finish`).
    """
    return em_accel_dd_lo(ax, ay, az, r0, t0, bx, by, bz, 0.0, 0.0, 0.0, gm, r1, iP)


@kernel(inline="always")
def em_accel_dd_lo(ax, ay, az, r0, t0, bx, by, bz, cx, cy, cz, gm, r1, iP):
    """:func:`em_accel_dd` at ``b + c``, ``c`` the rounding error of ``b`` (``b + c = a - dx``
    exactly when ``b, c`` come from a two-sum); ``r1, iP`` of the rounded ``b``."""
    p0, e0 = two_prod(bx, bx)
    p1, e1 = two_prod(by, by)
    p2, e2 = two_prod(bz, bz)
    bb, f1 = two_sum(p0, p1)
    bb, f2 = two_sum(bb, p2)
    # 2 r1 (|b + c| - r1), to first order
    t1 = fma(-r1, r1, bb) + ((((e0 + e1) + e2) + (f1 + f2)) + 2.0 * ((bx * cx + by * cy) + bz * cz))
    # P = r0 r1 (r0 + r1) = q s in double-double, k = GM / P
    s, es = two_sum(r0, r1)
    q, eq = two_prod(r0, r1)
    P, eP = two_prod(q, s)
    hs = 0.5 * iP * s
    r0l = t0 * (hs * r1)  # t0 / (2 r0)
    r1l = t1 * (hs * r0)  # t1 / (2 r1)
    sl = (es + r0l) + r1l
    ql = (eq + r0 * r1l) + r0l * r1
    Pl = (eP + q * sl) + ql * s
    k = gm * iP
    kl = (fma(-k, P, gm) - k * Pl) * iP
    # g = k (a + b) = k (u + l)
    ux, lx = two_sum(ax, bx)
    uy, ly = two_sum(ay, by)
    uz, lz = two_sum(az, bz)
    lx += cx
    ly += cy
    lz += cz
    gx = k * ux
    gy = k * uy
    gz = k * uz
    return (
        gx,
        gy,
        gz,
        (fma(k, ux, -gx) + k * lx) + kl * ux,
        (fma(k, uy, -gy) + k * ly) + kl * uy,
        (fma(k, uz, -gz) + k * lz) + kl * uz,
        k + kl,
    )


@kernel(inline="always")
def em_accel_accurate(ax, ay, az, r0, t0, bx, by, bz, gm):
    """g_em of the given doubles with each component within about one rounding (correctly
    rounded unless within about 1e-9 ulp of a tie): :func:`em_accel_dd` rounded. Returns
    (gx, gy, gz, r10, k) as :func:`em_accel` does."""
    r1, iP = em_accel_root(bx, by, bz, r0)
    gx, gy, gz, lx, ly, lz, k = em_accel_dd(ax, ay, az, r0, t0, bx, by, bz, gm, r1, iP)
    return gx + lx, gy + ly, gz + lz, r1, k


@kernel
def em_jacobian_coeffs(r0, r1, k):
    """d g_em / d x10 = -k I + w (a + b) b^T: returns (-k, w) with w = k (s + r10) / (r10^2 s).

    With s = r00 + r10 and e10 = b / r10 the paper's form is
    -k I + k (s + r10) / (r10 s) (a + b) (x) e10; folding 1/r10 into w lets callers use b.
    """
    s = r0 + r1
    return -k, k * (s + r1) / (r1 * r1 * s)


@kernel
def accel_points(x, gm, center):
    """g at each column of ``x`` (3, n); returns (3, n)."""
    n = x.shape[1]
    out = np.empty((3, n))
    for i in range(n):
        gx, gy, gz, r = accel(center[0] - x[0, i], center[1] - x[1, i], center[2] - x[2, i], gm)
        out[0, i] = gx
        out[1, i] = gy
        out[2, i] = gz
    return out


@kernel
def potential_points(x, gm, center):
    """Potential per unit mass V = -GM / r at each column of ``x`` (3, n); returns (n,)."""
    n = x.shape[1]
    out = np.empty(n)
    for i in range(n):
        rx = center[0] - x[0, i]
        ry = center[1] - x[1, i]
        rz = center[2] - x[2, i]
        out[i] = -gm / math.sqrt(rx * rx + ry * ry + rz * rz)
    return out


@kernel
def em_accel_points(x0, x1, gm, center):
    """g_em(x0[:, i], x1[:, i]) for (3, n) arrays; returns (3, n)."""
    n = x0.shape[1]
    out = np.empty((3, n))
    for i in range(n):
        ax = center[0] - x0[0, i]
        ay = center[1] - x0[1, i]
        az = center[2] - x0[2, i]
        gx, gy, gz, r1, k = em_accel(
            ax,
            ay,
            az,
            math.sqrt(ax * ax + ay * ay + az * az),
            center[0] - x1[0, i],
            center[1] - x1[1, i],
            center[2] - x1[2, i],
            gm,
        )
        out[0, i] = gx
        out[1, i] = gy
        out[2, i] = gz
    return out


@kernel
def em_jacobian_points(x0, x1, gm, center):
    """d g_em / d x10 at each pair of columns; returns (n, 3, 3) (unsymmetric)."""
    n = x0.shape[1]
    out = np.empty((n, 3, 3))
    u = np.empty(3)
    b = np.empty(3)
    for i in range(n):
        for d in range(3):
            b[d] = center[d] - x1[d, i]
            u[d] = (center[d] - x0[d, i]) + b[d]
        ax = center[0] - x0[0, i]
        ay = center[1] - x0[1, i]
        az = center[2] - x0[2, i]
        r0 = math.sqrt(ax * ax + ay * ay + az * az)
        gx, gy, gz, r1, k = em_accel(ax, ay, az, r0, b[0], b[1], b[2], gm)
        c, w = em_jacobian_coeffs(r0, r1, k)
        for p in range(3):
            for q in range(3):
                out[i, p, q] = w * u[p] * b[q]
            out[i, p, p] += c
    return out


@kernel
def midpoint_accel_points(x0, x1, gm, center):
    """The midpoint rule's acceleration g((x0 + x1) / 2) for (3, n) arrays; returns (3, n)."""
    n = x0.shape[1]
    out = np.empty((3, n))
    for i in range(n):
        gx, gy, gz, r = accel(
            center[0] - 0.5 * (x0[0, i] + x1[0, i]),
            center[1] - 0.5 * (x0[1, i] + x1[1, i]),
            center[2] - 0.5 * (x0[2, i] + x1[2, i]),
            gm,
        )
        out[0, i] = gx
        out[1, i] = gy
        out[2, i] = gz
    return out
