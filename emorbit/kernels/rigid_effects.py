"""Forces on rigid bodies beyond gravity at their mass points: drag and radiation pressure on
their facets, and third bodies at their mass points; each as a generalised force on
``q = (phi, d1, d2, d3)`` and with the discrete work an em step sums.

A point of body coordinates Y (relative to the centre of mass) is at ``x = phi + Y^k d_k``,
linear in q, so a force f there is the generalised force ``(f, Y^1 f, Y^2 f, Y^3 f)`` and its
work over a step is ``f . (x1 - x0)``, exactly what it adds to the kinetic energy in an em
step (the constraint forces do no work). A facet (centre Y, normal N, area A, drag
coefficient Cd, specular and diffuse coefficients, two-sided flag) is evaluated at the step's
midpoint: position ``x_m = (x0 + x1) / 2``, normal ``n = N^k (d_k0 + d_k1) / 2`` normalised,
velocity relative to the co-rotating air ``(x1 - x0) / h - w x (x_m - c)``; drag
(:func:`.effects.radiation.drag_plate`) with the density at x_m's altitude, radiation
pressure (:func:`.effects.radiation.srp_plate`) with the Sun at its position at the step's
middle time and the body's shadow fraction nu (conical: at the centre of mass's midpoint).
Third bodies act on each mass point with the conserving force of
:func:`.effects.third_body.third_body_force` (the centre of mass alone for the point gravity
model); their work is that of their potentials' change in time.

Data layout: facets (nf, 11) float64 rows ``[Yx, Yy, Yz, Nx, Ny, Nz, A, Cd, specular,
diffuse, two_sided]`` (body frame, m, m^2), a body's rows ``f0 .. f1``; drag_p, drag_t as
:mod:`.effects.atmosphere` (``[c, w, R]``, the band table); srp_p as
:mod:`emorbit.effects.srp` (``[P_au, au, R_occ, R_sun, shadow, c, step, k0]``); sun (3,) the
Sun relative to the central body; tb_p (k, 9) and tb_s (k, 3, 3) the third bodies and their
positions at the sub-step's start, middle and end (:mod:`emorbit.effects.third_body`).
References: J. C. Simo, N. Tarnow, ZAMP 43 (1992) 757-792; P. Betsch, P. Steinmann,
Comput. Methods Appl. Mech. Eng. 191 (2001) 467-488; O. Montenbruck, E. Gill, Satellite
Orbits (2000), 3.4-3.5.
"""

from __future__ import annotations

import math

import numpy as np

from .effects.atmosphere import ussa1976_density
from .effects.atmosphere_grid import grid_density
from .effects.radiation import drag_plate, shadow_conical, srp_plate
from .effects.third_body import third_body_force, tidal_potential
from .jit import kernel

__all__ = ["facet_forces", "facet_jacobian", "third_body_forces", "third_body_work"]


@kernel(inline="always")
def _spread(F, Y0, Y1, Y2, gx, gy, gz):
    """Add the generalised force of a force g at the body point Y: ``(g, Y^1 g, Y^2 g, Y^3 g)``."""
    F[0] += gx
    F[1] += gy
    F[2] += gz
    F[3] += Y0 * gx
    F[4] += Y0 * gy
    F[5] += Y0 * gz
    F[6] += Y1 * gx
    F[7] += Y1 * gy
    F[8] += Y1 * gz
    F[9] += Y2 * gx
    F[10] += Y2 * gy
    F[11] += Y2 * gz


@kernel(inline="always")
def _point(q0, q1, d, Y0, Y1, Y2, N0, N1, N2):
    """Component d of a body point at the step's start and end, and of its normal at the middle."""
    a = q0[d] + Y0 * q0[3 + d] + Y1 * q0[6 + d] + Y2 * q0[9 + d]
    b = q1[d] + Y0 * q1[3 + d] + Y1 * q1[6 + d] + Y2 * q1[9 + d]
    n = 0.5 * (N0 * (q0[3 + d] + q1[3 + d]) + N1 * (q0[6 + d] + q1[6 + d]) + N2 * (q0[9 + d] + q1[9 + d]))
    return a, b, n


@kernel
def facet_forces(q0, q1, h, F, facets, f0, f1, drag_p, drag_t, drag_g, drag_gp, dsun, srp_p, sun, nu, work):
    """Add drag's and radiation pressure's generalised forces on facets ``f0 .. f1`` into F.

    Parameters
    ----------
    q0, q1 : ndarray
        (12,) the body's configuration at the step's start and end.
    h : float
        The step, s.
    F : ndarray
        (12,) the generalised force, added into (N; N m on the director rows).
    facets : ndarray
        (nf, 11) the facets (layout: the module's docstring).
    f0, f1 : int
        The body's facet rows.
    drag_p, drag_t : ndarray or None
        Drag's parameters and band table (None: no drag).
    drag_g, drag_gp, dsun : ndarray or None
        Drag's density grid, its axes and the Sun's position for its local time (read where
        ``drag_p[7]`` is 1: NRLMSIS, :mod:`.effects.atmosphere_grid`).
    srp_p : ndarray or None
        Radiation pressure's parameters (None: none).
    sun : ndarray
        (3,) the Sun relative to the central body at the step's middle time, m.
    nu : float
        The visible fraction of the Sun under a cylindrical shadow (or 1); a conical shadow
        (``srp_p[4]`` 2) is evaluated here, at the centre of mass's midpoint.
    work : ndarray
        (2,): adds each force's work ``f . (x1 - x0)`` over the step (J): [drag, srp].
    """
    shade = nu
    if srp_p is not None and srp_p[4] == 2.0:  # the conical shadow at the centre of mass's midpoint
        shade = shadow_conical(
            0.5 * (q0[0] + q1[0]) - srp_p[5], 0.5 * (q0[1] + q1[1]) - srp_p[6], 0.5 * (q0[2] + q1[2]) - srp_p[7],
            sun[0], sun[1], sun[2], srp_p[2], srp_p[3],
        )  # fmt: skip
    for f in range(f0, f1):
        Y0, Y1, Y2 = facets[f, 0], facets[f, 1], facets[f, 2]
        N0, N1, N2 = facets[f, 3], facets[f, 4], facets[f, 5]
        ax, bx, nx = _point(q0, q1, 0, Y0, Y1, Y2, N0, N1, N2)
        ay, by, ny = _point(q0, q1, 1, Y0, Y1, Y2, N0, N1, N2)
        az, bz, nz = _point(q0, q1, 2, Y0, Y1, Y2, N0, N1, N2)
        nn = math.sqrt(nx * nx + ny * ny + nz * nz)
        nx, ny, nz = nx / nn, ny / nn, nz / nn
        mx, my, mz = 0.5 * (ax + bx), 0.5 * (ay + by), 0.5 * (az + bz)
        sx, sy, sz = bx - ax, by - ay, bz - az
        area, two = facets[f, 6], facets[f, 10] > 0.5
        gx = gy = gz = 0.0
        if drag_p is not None:
            d0, d1, d2 = mx - drag_p[0], my - drag_p[1], mz - drag_p[2]
            vx = sx / h - (drag_p[4] * d2 - drag_p[5] * d1)
            vy = sy / h - (drag_p[5] * d0 - drag_p[3] * d2)
            vz = sz / h - (drag_p[3] * d1 - drag_p[4] * d0)
            if drag_p[7] == 0.0:
                rho = ussa1976_density(
                    math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) - drag_p[6], drag_t[0], drag_t[1], drag_t[2]
                )
            else:
                rho, _ = grid_density(
                    d0, d1, d2, dsun[0], dsun[1], dsun[2], drag_p[10], drag_p[11], drag_p[12], drag_p[6], drag_gp,
                    drag_g,
                )  # fmt: skip
            gx, gy, gz = drag_plate(nx, ny, nz, vx, vy, vz, area, facets[f, 7], rho, two)
            work[0] += gx * sx + gy * sy + gz * sz
        if srp_p is not None and shade > 0.0:
            ex, ey, ez = srp_p[5] + sun[0] - mx, srp_p[6] + sun[1] - my, srp_p[7] + sun[2] - mz
            r = math.sqrt(ex * ex + ey * ey + ez * ez)
            pressure = shade * srp_p[0] * (srp_p[1] / r) ** 2
            px, py, pz = srp_plate(nx, ny, nz, ex / r, ey / r, ez / r, area, pressure, facets[f, 8], facets[f, 9], two)
            work[1] += px * sx + py * sy + pz * sz
            gx += px
            gy += py
            gz += pz
        _spread(F, Y0, Y1, Y2, gx, gy, gz)


@kernel
def facet_jacobian(q0, q1, h, K, facets, f0, f1, drag_p, drag_t, drag_g, drag_gp, dsun, srp_p, sun, nu, scratch):
    """Add the derivative of :func:`facet_forces` with respect to q1 into K (12, 12), by forward
    differences: steps of 1e-6 of the centre's increment (at least 1e-6 m) and 1e-7 on the
    directors. The facets' aerodynamic and radiation torques depend on the attitude; at
    steps comparable to the period of the attitude motion they drive (a weathervane's), a
    Newton matrix without them contracts by only (omega h)^2 / 2 per iteration. The
    difference quotients' error (about 1e-7 relative) slows Newton's quadratic convergence
    no more than the chord matrix does.

    Parameters
    ----------
    q0, q1, h, facets, f0, f1, drag_p, drag_t, drag_g, drag_gp, dsun, srp_p, sun, nu
        As :func:`facet_forces`.
    K : ndarray
        (12, 12), ``K[i, j] += dF_i / dq1_j``.
    scratch : ndarray
        (3, 12) float64 work space.
    """
    base = scratch[0]
    moved = scratch[1]
    qq = scratch[2]
    wk = np.zeros(2)
    base[:] = 0.0
    facet_forces(q0, q1, h, base, facets, f0, f1, drag_p, drag_t, drag_g, drag_gp, dsun, srp_p, sun, nu, wk)
    for j in range(12):
        if j < 3:
            e = 1e-6 * max(abs(q1[j] - q0[j]), 1.0)
        else:
            e = 1e-7
        qq[:] = q1
        qq[j] = q1[j] + e
        e = qq[j] - q1[j]  # the step as represented
        moved[:] = 0.0
        facet_forces(q0, qq, h, moved, facets, f0, f1, drag_p, drag_t, drag_g, drag_gp, dsun, srp_p, sun, nu, wk)
        for i in range(12):
            K[i, j] += (moved[i] - base[i]) / e


@kernel
def third_body_forces(q0, q1, X, mp, m, point, tb_p, tb_s, F):
    """Add the third bodies' conserving generalised forces at the mass points into F.

    Parameters
    ----------
    q0, q1 : ndarray
        (12,) the configuration at the step's start and end.
    X : ndarray
        (3, N) the mass points' body coordinates, m.
    mp : ndarray
        (N,) their masses, kg.
    m : float
        The body's mass, kg (the point gravity model).
    point : bool
        The point gravity model: all mass at the centre of mass.
    tb_p, tb_s : ndarray
        The third bodies and their positions (layout: the module's docstring).
    F : ndarray
        (12,) added into.
    """
    for jb in range(tb_p.shape[0]):
        gm, ind = tb_p[jb, 0], tb_p[jb, 1] != 0.0
        c0, c1, c2 = tb_p[jb, 2], tb_p[jb, 3], tb_p[jb, 4]
        s0, s1, s2 = tb_s[jb, 1, 0], tb_s[jb, 1, 1], tb_s[jb, 1, 2]
        if point:
            gx, gy, gz = third_body_force(q0[0], q0[1], q0[2], q1[0], q1[1], q1[2], c0, c1, c2, s0, s1, s2, gm, ind)
            F[0] += m * gx
            F[1] += m * gy
            F[2] += m * gz
            continue
        for i in range(mp.shape[0]):
            Y0, Y1, Y2 = X[0, i], X[1, i], X[2, i]
            a0 = q0[0] + Y0 * q0[3] + Y1 * q0[6] + Y2 * q0[9]
            a1 = q0[1] + Y0 * q0[4] + Y1 * q0[7] + Y2 * q0[10]
            a2 = q0[2] + Y0 * q0[5] + Y1 * q0[8] + Y2 * q0[11]
            b0 = q1[0] + Y0 * q1[3] + Y1 * q1[6] + Y2 * q1[9]
            b1 = q1[1] + Y0 * q1[4] + Y1 * q1[7] + Y2 * q1[10]
            b2 = q1[2] + Y0 * q1[5] + Y1 * q1[8] + Y2 * q1[11]
            gx, gy, gz = third_body_force(a0, a1, a2, b0, b1, b2, c0, c1, c2, s0, s1, s2, gm, ind)
            _spread(F, Y0, Y1, Y2, mp[i] * gx, mp[i] * gy, mp[i] * gz)


@kernel
def third_body_work(q0, q1, X, mp, m, point, tb_p, tb_s, jb):
    """The work of third body ``jb``'s potential's change in time over a step (J):
    ``sum_i m_i ([U(x_i1, t1) - U(x_i1, t_m)] + [U(x_i0, t_m) - U(x_i0, t0)])``.

    Parameters
    ----------
    q0, q1, X, mp, m, point, tb_p, tb_s
        As :func:`third_body_forces`.
    jb : int
        The third body.

    Returns
    -------
    float
        J.
    """
    gm, ind = tb_p[jb, 0], tb_p[jb, 1] != 0.0
    c0, c1, c2 = tb_p[jb, 2], tb_p[jb, 3], tb_p[jb, 4]
    total = 0.0
    count = 1 if point else mp.shape[0]
    for i in range(count):
        if point:
            Y0 = Y1 = Y2 = 0.0
            mi = m
        else:
            Y0, Y1, Y2 = X[0, i], X[1, i], X[2, i]
            mi = mp[i]
        a0 = q0[0] + Y0 * q0[3] + Y1 * q0[6] + Y2 * q0[9] - c0
        a1 = q0[1] + Y0 * q0[4] + Y1 * q0[7] + Y2 * q0[10] - c1
        a2 = q0[2] + Y0 * q0[5] + Y1 * q0[8] + Y2 * q0[11] - c2
        b0 = q1[0] + Y0 * q1[3] + Y1 * q1[6] + Y2 * q1[9] - c0
        b1 = q1[1] + Y0 * q1[4] + Y1 * q1[7] + Y2 * q1[10] - c1
        b2 = q1[2] + Y0 * q1[5] + Y1 * q1[8] + Y2 * q1[11] - c2
        ue = tidal_potential(b0, b1, b2, tb_s[jb, 2, 0], tb_s[jb, 2, 1], tb_s[jb, 2, 2], gm, ind)
        ue -= tidal_potential(b0, b1, b2, tb_s[jb, 1, 0], tb_s[jb, 1, 1], tb_s[jb, 1, 2], gm, ind)
        us = tidal_potential(a0, a1, a2, tb_s[jb, 1, 0], tb_s[jb, 1, 1], tb_s[jb, 1, 2], gm, ind)
        us -= tidal_potential(a0, a1, a2, tb_s[jb, 0, 0], tb_s[jb, 0, 1], tb_s[jb, 0, 2], gm, ind)
        total += mi * (ue + us)
    return total
