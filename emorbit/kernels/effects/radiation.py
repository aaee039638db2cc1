"""Solar radiation pressure, the shadow of an occulting body, and free-molecular flat-plate drag.

Shadow: ``d`` the satellite's position and ``s`` the Sun's, both relative to the occulting
body's centre (radius R). Cylindrical: ``nu = 0`` where ``d . s_hat < 0`` and
``|d - (d . s_hat) s_hat| < R``, else 1. Conical (Montenbruck & Gill 2000, section 3.4.2):
the visible fraction of the Sun's disc, the discs taken as plane circles of angular radii
``a = asin(R_sun / |s - d|)`` (Sun) and ``b = asin(R / |d|)`` (body) at the angle
``c = atan2(|(-d) x (s - d)|, (-d) . (s - d))`` between their centres::

    c >= a + b: 1;   c <= b - a: 0 (umbra);   c <= a - b: 1 - b^2 / a^2 (annular);  else
    x = (c^2 + a^2 - b^2) / (2 c),  y = sqrt(a^2 - x^2),
    A = a^2 acos(x / a) + b^2 acos((c - x) / b) - c y,   nu = 1 - A / (pi a^2)

The kernel takes ``atan2(y, x)`` and ``atan2(y, c - x)`` for the two acos: the acos form
itself loses up to 2.0e-8 in nu where b >> a (measured on the test's 400 penumbra cases). Measured by quadrature
over the Sun's disc (``tests/test_radiation_kernels.py``): within 3.3e-13 of the plane-disc
overlap; the plane-disc model differs from the exact fraction of the solid angle (caps on the
sky) by at most 0.1073 a (1/b - cot b), from the curvature of Earth's limb on the sky (1/b in
the plane, cot b on the sphere): 2.35e-4 at 300 km, 2.50e-5 at GEO.

Pressure: ``P = P_au (au / r)^2`` at distance r from the Sun. A cannonball (``cram = Cr A / m``)
gets ``a = nu P cram (d - s) / r``. A flat plate (unit outward normal n, unit vector e toward the
Sun, ``cos = n . e``, specular and diffuse coefficients rho_s, rho_d, the rest absorbed)::

    F = -P A cos [(1 - rho_s) e + 2 (rho_s cos + rho_d / 3) n]      (cos > 0; else 0)

(Montenbruck & Gill eq. 3.75, with Lambertian diffuse reflection as in Vallado 2013, section
8.6.4, and Wertz). Flat-plate drag (v the plate's velocity relative to the air)::

    F = -1/2 rho Cd A max(0, n . v) v      (two-sided: |n . v|)

so the facets of a closed convex body give ``-1/2 rho Cd A_proj |v| v``, A_proj its area projected
along v, and a closed body of one-sided black plates gets ``-P A_proj e`` from sunlight.

Data layout: components as float64 scalars, a plate's sidedness as a bool (or a float, true
above 0.5); the kernels return floats or tuples ``(x, y, z)``, SI units. All are
``inline="always"`` Numba kernels, callable from Python. References: O. Montenbruck,
E. Gill, Satellite Orbits (Springer, 2000), sections 3.4.1-3.4.2; D. A. Vallado,
Fundamentals of Astrodynamics and Applications, 4th ed. (2013), section 8.6.4; J. R. Wertz
(ed.), Spacecraft Attitude Determination and Control (Reidel, 1978).
"""

from __future__ import annotations

import math

from ..jit import kernel

__all__ = [
    "shadow_cylindrical",
    "shadow_conical",
    "shadow_conical_gradient",
    "srp_cannonball",
    "srp_plate",
    "drag_plate",
]

_inline = kernel(inline="always")


@_inline
def shadow_cylindrical(dx, dy, dz, sx, sy, sz, radius):
    """The cylindrical shadow function: 0 inside the body's shadow cylinder, else 1.

    Parameters
    ----------
    dx, dy, dz : float
        The satellite's position relative to the occulting body's centre, m.
    sx, sy, sz : float
        The Sun's position relative to the same centre, m.
    radius : float
        The occulting body's radius, m.

    Returns
    -------
    float
        0.0 where ``d . s_hat < 0`` and ``|d - (d . s_hat) s_hat| < radius``, else 1.0.
    """
    s = math.sqrt(sx * sx + sy * sy + sz * sz)
    ux = sx / s
    uy = sy / s
    uz = sz / s
    p = dx * ux + dy * uy + dz * uz
    if p >= 0.0:
        return 1.0
    qx = dx - p * ux
    qy = dy - p * uy
    qz = dz - p * uz
    if qx * qx + qy * qy + qz * qz < radius * radius:
        return 0.0
    return 1.0


@_inline
def shadow_conical(dx, dy, dz, sx, sy, sz, radius, sun_radius):
    """The conical shadow function: the visible fraction of the Sun's disc (plane-disc model).

    Parameters
    ----------
    dx, dy, dz : float
        The satellite's position relative to the occulting body's centre, m.
    sx, sy, sz : float
        The Sun's position relative to the same centre, m.
    radius : float
        The occulting body's radius, m.
    sun_radius : float
        The Sun's radius, m.

    Returns
    -------
    float
        ``nu`` in [0, 1]: 0 in the umbra (and inside the body), 1 in full sunlight,
        ``1 - b^2 / a^2`` in the annular region, ``1 - A / (pi a^2)`` in the penumbra, A the
        overlap of discs of radii a and b at distance c (module docstring).
    """
    return _conical(dx, dy, dz, sx, sy, sz, radius, sun_radius, False)[0]


@_inline
def shadow_conical_gradient(dx, dy, dz, sx, sy, sz, radius, sun_radius):
    """:func:`shadow_conical` and its gradient with respect to the satellite's position d.

    With the discs' radii ``a = asin(R_sun / |q|)``, ``b = asin(R / |d|)`` (``q = s - d``) and
    the angle c between ``-d`` and q::

        grad a = R_sun q / (|q|^3 cos a),   grad b = -R d / (|d|^3 cos b),
        grad c = -(dc/dp + dc/dq),  dc/dp = (cos c p^ - q^) / (|p| sin c)  (p = -d, likewise q)

    and ``grad nu = nu_a grad a + nu_b grad b + nu_c grad c``: in the annular region
    ``nu_a = 2 b^2 / a^3``, ``nu_b = -2 b / a^2``, ``nu_c = 0``; in the penumbra, from the
    overlap's ``dA/da = 2 a alpha``, ``dA/db = 2 b beta``, ``dA/dc = -2 y`` (alpha, beta the
    half-angles of the chord of half-length y seen from the discs' centres),
    ``nu_a = 2 (A / a^2 - alpha) / (pi a)``, ``nu_b = -2 b beta / (pi a^2)``,
    ``nu_c = 2 y / (pi a^2)``. Zero in full sunlight, in the umbra and inside the body.

    Parameters
    ----------
    dx, dy, dz, sx, sy, sz, radius, sun_radius : float
        As :func:`shadow_conical`.

    Returns
    -------
    tuple of float
        ``(nu, gx, gy, gz)``: nu as :func:`shadow_conical` gives it, bit for bit, and its
        gradient, 1/m.
    """
    return _conical(dx, dy, dz, sx, sy, sz, radius, sun_radius, True)


@_inline
def _conical(dx, dy, dz, sx, sy, sz, radius, sun_radius, grad):
    """nu and, where ``grad`` (a constant in each caller), its gradient: ``(nu, gx, gy, gz)``."""
    rd = math.sqrt(dx * dx + dy * dy + dz * dz)
    if rd <= radius:
        return 0.0, 0.0, 0.0, 0.0
    # from the satellite: to the body's centre (-d) and to the Sun (s - d)
    px = -dx
    py = -dy
    pz = -dz
    qx = sx - dx
    qy = sy - dy
    qz = sz - dz
    rq = math.sqrt(qx * qx + qy * qy + qz * qz)
    # in full sunlight without a transcendental where the body lies behind (p . q <= 0, so
    # c >= pi/2) and both discs are small (u^2 + w^2 <= 0.9 bounds a + b by 2 asin(sqrt(0.45))
    # < 1.48): the branch c >= a + b below would return the same 1.0
    u = sun_radius / rq
    w = radius / rd
    pq = px * qx + py * qy + pz * qz
    if pq <= 0.0 and u * u + w * w <= 0.9:
        return 1.0, 0.0, 0.0, 0.0
    a = math.asin(min(u, 1.0))
    b = math.asin(w)
    cx = py * qz - pz * qy
    cy = pz * qx - px * qz
    cz = px * qy - py * qx
    sn = math.sqrt(cx * cx + cy * cy + cz * cz)
    c = math.atan2(sn, pq)
    if c >= a + b:
        return 1.0, 0.0, 0.0, 0.0
    if c <= b - a:
        return 0.0, 0.0, 0.0, 0.0
    annular = c <= a - b
    if annular:
        nu = 1.0 - (b * b) / (a * a)
        na, nb, nc = 2.0 * b * b / (a * a * a), -2.0 * b / (a * a), 0.0
    else:
        # the chord: x from the Sun's centre along c, half-length y; acos(x / a) = atan2(y, x)
        # and acos((c - x) / b) = atan2(y, c - x), well conditioned where acos's argument nears 1
        x = (a * a + (c - b) * (c + b)) / (2.0 * c)
        y = math.sqrt(max((a - x) * (a + x), 0.0))
        alpha = math.atan2(y, x)
        beta = math.atan2(y, c - x)
        area = a * a * alpha + b * b * beta - c * y
        nu = min(max(1.0 - area / (math.pi * a * a), 0.0), 1.0)
        na = 2.0 * (area / (a * a) - alpha) / (math.pi * a)
        nb = -2.0 * b * beta / (math.pi * a * a)
        nc = 2.0 * y / (math.pi * a * a)
    if not grad or u >= 1.0:
        return nu, 0.0, 0.0, 0.0
    ka = sun_radius / (rq * rq * rq * math.sqrt((1.0 - u) * (1.0 + u)))
    kb = -radius / (rd * rd * rd * math.sqrt((1.0 - w) * (1.0 + w)))
    gx = na * ka * qx + nb * kb * dx
    gy = na * ka * qy + nb * kb * dy
    gz = na * ka * qz + nb * kb * dz
    if nc != 0.0 and sn > 0.0:
        # grad c = -(dc/dp + dc/dq), as dp/dd = dq/dd = -I
        cs = pq / (rd * rq)
        fp = rq / sn  # 1 / (|p| sin c), with |p x q| = |p| |q| sin c
        fq = rd / sn
        ux, uy, uz = qx / rq, qy / rq, qz / rq
        vx, vy, vz = px / rd, py / rd, pz / rd
        gx -= nc * (fp * (cs * vx - ux) + fq * (cs * ux - vx))
        gy -= nc * (fp * (cs * vy - uy) + fq * (cs * uy - vy))
        gz -= nc * (fp * (cs * vz - uz) + fq * (cs * uz - vz))
    return nu, gx, gy, gz


@_inline
def srp_cannonball(dx, dy, dz, sx, sy, sz, pressure_au, au, cram, nu):
    """The acceleration of a cannonball by sunlight.

    Parameters
    ----------
    dx, dy, dz : float
        The satellite's position, m.
    sx, sy, sz : float
        The Sun's position in the same frame, m.
    pressure_au : float
        The radiation pressure at distance ``au`` from the Sun, N/m^2.
    au : float
        The reference distance, m.
    cram : float
        ``Cr A / m``, m^2/kg.
    nu : float
        The shadow function's value (1 in full sunlight).

    Returns
    -------
    tuple of float
        ``(ax, ay, az)``, ``nu P cram (d - s) / r`` with ``r = |d - s|`` and
        ``P = pressure_au (au / r)^2``, m/s^2 (away from the Sun).
    """
    ux = dx - sx
    uy = dy - sy
    uz = dz - sz
    r2 = ux * ux + uy * uy + uz * uz
    r = math.sqrt(r2)
    k = nu * pressure_au * (au * au / r2) * cram / r
    return k * ux, k * uy, k * uz


@_inline
def srp_plate(nx, ny, nz, ex, ey, ez, area, pressure, specular, diffuse, two_sided):
    """The force of sunlight on a flat plate.

    Parameters
    ----------
    nx, ny, nz : float
        The plate's unit outward normal.
    ex, ey, ez : float
        The unit vector from the plate toward the Sun.
    area : float
        The plate's area, m^2.
    pressure : float
        The radiation pressure at the plate, N/m^2 (times the shadow function where wanted).
    specular, diffuse : float
        The fractions of the light reflected specularly and diffusely (Lambert); the rest,
        ``1 - specular - diffuse``, is absorbed.
    two_sided : bool or float
        Whether the back face reflects like the front one (a float: true above 0.5);
        a one-sided plate's back face takes no force.

    Returns
    -------
    tuple of float
        ``(fx, fy, fz)``, ``-P A cos [(1 - specular) e + 2 (specular cos + diffuse / 3) n]``
        with ``cos = n . e`` (n and cos negated for a two-sided plate lit from behind), N;
        zero where the lit face turns away from the Sun.
    """
    cs = nx * ex + ny * ey + nz * ez
    if two_sided > 0.5 and cs < 0.0:
        nx = -nx
        ny = -ny
        nz = -nz
        cs = -cs
    if cs <= 0.0:
        return 0.0, 0.0, 0.0
    k = -pressure * area * cs
    ke = k * (1.0 - specular)
    kn = k * 2.0 * (specular * cs + diffuse / 3.0)
    return ke * ex + kn * nx, ke * ey + kn * ny, ke * ez + kn * nz


@_inline
def drag_plate(nx, ny, nz, vx, vy, vz, area, cd, rho, two_sided):
    """The free-molecular drag force on a flat plate.

    Parameters
    ----------
    nx, ny, nz : float
        The plate's unit outward normal.
    vx, vy, vz : float
        The plate's velocity relative to the air, m/s.
    area : float
        The plate's area, m^2.
    cd : float
        The drag coefficient.
    rho : float
        The air's density, kg/m^3.
    two_sided : bool or float
        Whether the back face meets the flow too (a float: true above 0.5).

    Returns
    -------
    tuple of float
        ``(fx, fy, fz)``, ``-1/2 rho cd area f |v| v`` with the projected fraction
        ``f = max(0, n . v / |v|)`` (two-sided ``|n . v| / |v|``), N; zero at rest.
    """
    # f |v| = max(0, n . v): no division, and zero at zero speed
    p = nx * vx + ny * vy + nz * vz
    if p < 0.0:
        if two_sided > 0.5:
            p = -p
        else:
            p = 0.0
    k = -0.5 * rho * cd * area * p
    return k * vx, k * vy, k * vz
