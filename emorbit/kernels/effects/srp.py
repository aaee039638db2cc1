"""Solar radiation pressure's pieces for an effect set (:mod:`.signatures`): on a cannonball
point mass and on a flat facet, with the central body's shadow.

The Sun is at its position on its sampled path at the sub-step's middle time (``prepare``).
The shadow function nu (:mod:`.radiation`: none, cylindrical or conical with penumbra) and the
pressure ``P = P_au (au / r)^2`` are evaluated at the step's midpoint ``(x0 + x1) / 2``
(a facet's: its centre's), so the step stays symmetric in time. A point of radiation
coefficient ``c = Cr A / m`` gets ``a = nu P c u`` (u from the Sun to the point,
:func:`.radiation.srp_cannonball`); a facet the flat-plate force :func:`.radiation.srp_plate`
with its specular (k1) and diffuse (k2) coefficients. Both do work ``F . (x1 - x0)``. The
cannonball force is a function of position alone, so leapfrog's kicks may use it. Its
derivative goes into Newton's matrix: with ``e = m - s``, ``k = P_au au^2 c``,

    dF/dx1 = 1/2 k / |e|^3 [e grad nu^T + nu (I - 3 e e^T / |e|^2)]

with the conical shadow's gradient (:func:`.radiation.shadow_conical_gradient`), by which
the force changes by its own size over the penumbra's width (tens of km in LEO). The
cylinder's edge is a jump, which no derivative holds: its grad nu is left out (0).

Data layout: ``p = [P_au, au, R_occ, R_sun, shadow (0 none, 1 cylindrical, 2 conical), c0,
c1, c2, table_step, k0, nsun]``, ``tab`` the Sun's table relative to the central body (nsun,
6), ``s`` (3,) the Sun at the sub-step's middle time.
"""

from __future__ import annotations

import math

from ..jit import kernel
from .radiation import shadow_conical, shadow_conical_gradient, shadow_cylindrical, srp_cannonball, srp_plate
from .third_body import table_position

__all__ = ["srp_piece", "srp_prepare", "srp_facet"]

_inline = kernel(inline="always")
# an effect-set piece: compiled on its own (cached per install) and inlined by LLVM into the set
_piece = kernel(forceinline=True)


@_inline
def _shade(dx, dy, dz, p, s):
    """The visible fraction of the Sun at d (relative to the central body)."""
    if p[4] == 2.0:
        return shadow_conical(dx, dy, dz, s[0], s[1], s[2], p[2], p[3])
    if p[4] == 1.0:
        return shadow_cylindrical(dx, dy, dz, s[0], s[1], s[2], p[2])
    return 1.0


@_inline
def _jacobian(mx, my, mz, p, s, c, nu, gx, gy, gz, J):
    """Add dF/dx1 = 1/2 dF/dm into J: ``dF/dm = k [(e / r^3) g^T + nu (I / r^3 - 3 e e^T /
    r^5)]``, ``e = m - s``, ``k = P_au au^2 c``, g the shadow function's gradient."""
    ex, ey, ez = mx - s[0], my - s[1], mz - s[2]
    r2 = ex * ex + ey * ey + ez * ez
    ir3 = 1.0 / (r2 * math.sqrt(r2))
    k = 0.5 * p[0] * p[1] * p[1] * c * ir3
    t = 3.0 * nu / r2
    e = (ex, ey, ez)
    g = (gx, gy, gz)
    for i in range(3):
        for j in range(3):
            J[i, j] += k * (e[i] * g[j] - t * e[i] * e[j] + (nu if i == j else 0.0))


@_piece
def srp_piece(x0, y0, z0, x1, y1, z1, h, c, p, tab, s, J, jac):
    """Radiation pressure on a cannonball of coefficient ``c`` at the step's midpoint (per unit
    mass), its derivative with respect to x1 added into J where ``jac`` (the conical shadow's
    gradient from the same evaluation as nu; the cylinder's jump left out)."""
    mx = 0.5 * (x0 + x1) - p[5]
    my = 0.5 * (y0 + y1) - p[6]
    mz = 0.5 * (z0 + z1) - p[7]
    gx, gy, gz = 0.0, 0.0, 0.0
    if jac and p[4] == 2.0:
        nu, gx, gy, gz = shadow_conical_gradient(mx, my, mz, s[0], s[1], s[2], p[2], p[3])
    else:
        nu = _shade(mx, my, mz, p, s)
    if jac and c != 0.0:
        _jacobian(mx, my, mz, p, s, c, nu, gx, gy, gz, J)
    return srp_cannonball(mx, my, mz, s[0], s[1], s[2], p[0], p[1], c, nu)


@_piece
def srp_prepare(ta, tm, tb, p, tab, s):
    """The Sun at the sub-step's middle time."""
    ns = int(p[10])
    s[0], s[1], s[2] = table_position(tm, p[8], p[9], tab[0 : 6 * ns].reshape((ns, 6)))


@_piece
def srp_facet(ax, ay, az, bx, by, bz, nx, ny, nz, area, k0, k1, k2, k3, h, p, tab, s):
    """Radiation pressure on a flat facet (specular k1, diffuse k2, two-sided where k3 > 0.5), N."""
    mx = 0.5 * (ax + bx) - p[5]
    my = 0.5 * (ay + by) - p[6]
    mz = 0.5 * (az + bz) - p[7]
    nu = _shade(mx, my, mz, p, s)
    if not nu > 0.0:
        return 0.0, 0.0, 0.0
    ex, ey, ez = s[0] - mx, s[1] - my, s[2] - mz
    r = math.sqrt(ex * ex + ey * ey + ez * ez)
    pressure = nu * p[0] * (p[1] / r) ** 2
    return srp_plate(nx, ny, nz, ex / r, ey / r, ez / r, area, pressure, k1, k2, k3)
