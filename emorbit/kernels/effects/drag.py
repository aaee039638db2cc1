"""Drag's pieces for an effect set (:mod:`.signatures`): on a point mass and on a flat facet.

The air co-rotates with the central body (rotation vector w about its centre c); its density
at the step's midpoint ``x_m = (x0 + x1) / 2`` is a band table's (:mod:`.atmosphere`) or an
NRLMSIS grid's (:mod:`.atmosphere_grid`, with the Sun at the sub-step's middle time for the
local time). On a point of ballistic coefficient ``c = Cd A / m`` (m^2/kg)::

    v = (x1 - x0) / h - w x (x_m - c),   F = -1/2 rho c |v| v

(:func:`.atmosphere.drag_force`; its Jacobian :func:`.atmosphere.drag_jacobian`, with an
NRLMSIS grid also the density's horizontal gradient g: ``-1/4 c |v| v g^T``). On a facet
of area A, drag coefficient Cd and unit normal n (at the step's middle) whose centre moves
a -> b, the free-molecular plate force :func:`.radiation.drag_plate` with
``v = (b - a) / h - w x (m - c)``. Both do work ``F . (x1 - x0)``, which the step sums.

Data layout: ``p = [c0, c1, c2, w0, w1, w2, R, grid, sun_step, sun_k0, p0, p1, p2, nb, na,
nphi, nlam1, nsun]`` (grid 1 for NRLMSIS: the Sun's table's sampling interval and first
sample, the pole p; table sizes); ``tab`` the band table's rows h0, rho0, H (3 nb), then the
grid's axes (5), the grid ``log rho`` (na, nphi, nlam1) and the Sun's table (nsun, 6); ``s``
(3,) the Sun at the sub-step's middle time (NRLMSIS).
"""

from __future__ import annotations

import math

from ..jit import kernel
from .atmosphere import band_at, drag_force_rho, drag_jacobian_rho
from .atmosphere_grid import grid_density_at, grid_horizontal_gradient_at
from .radiation import drag_plate
from .third_body import table_position

__all__ = ["drag_piece", "drag_prepare", "drag_facet"]

_inline = kernel(inline="always")
# an effect-set piece: compiled on its own (cached per install) and inlined by LLVM into the set
_piece = kernel(forceinline=True)


@_inline
def _sun(p, tab):
    """The Sun's table (nsun, 6), a view into ``tab``."""
    nb = int(p[13])
    o = 3 * nb + 5 + int(p[14]) * int(p[15]) * int(p[16])
    ns = int(p[17])
    return tab[o : o + 6 * ns].reshape((ns, 6))


@_inline
def _band(a, tab, nb):
    """The band table's density at altitude ``a`` and the band's scale height: (rho, H), read
    from ``tab`` by index (:func:`.atmosphere.ussa1976_density`'s band and arithmetic; no
    array views, so the loops over points keep no reference counts)."""
    i = band_at(a, tab, nb)
    H = tab[2 * nb + i]
    return tab[nb + i] * math.exp(-(a - tab[i]) / H), H


@_inline
def _grid_at(d0, d1, d2, p, tab, s):
    """The NRLMSIS grid's density and its altitude derivative at d (relative to the centre)."""
    o = 3 * int(p[13])
    return grid_density_at(
        d0, d1, d2, s[0], s[1], s[2], p[10], p[11], p[12], p[6], tab[o], tab[o + 1], tab[o + 2], tab[o + 3],
        tab[o + 4], tab, o + 5, int(p[14]), int(p[15]), int(p[16]),
    )  # fmt: skip


@_inline
def _grid_horizontal(x0, y0, z0, x1, y1, z1, h, c, rho, p, tab, s, J):
    """Add the derivative of drag through the grid density's horizontal gradient g into J:
    ``dF/dx1 = -1/2 c |v| v (rho g)^T / 2`` (g of log rho at the midpoint)."""
    d0 = 0.5 * (x0 + x1) - p[0]
    d1 = 0.5 * (y0 + y1) - p[1]
    d2 = 0.5 * (z0 + z1) - p[2]
    o = 3 * int(p[13])
    g0, g1, g2 = grid_horizontal_gradient_at(
        d0, d1, d2, s[0], s[1], s[2], p[10], p[11], p[12], p[6], tab[o], tab[o + 1], tab[o + 2], tab[o + 3],
        tab[o + 4], tab, o + 5, int(p[14]), int(p[15]), int(p[16]),
    )  # fmt: skip
    v0 = (x1 - x0) / h - (p[4] * d2 - p[5] * d1)
    v1 = (y1 - y0) / h - (p[5] * d0 - p[3] * d2)
    v2 = (z1 - z0) / h - (p[3] * d1 - p[4] * d0)
    k = -0.25 * c * rho * math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    v = (v0, v1, v2)
    g = (g0, g1, g2)
    for a in range(3):
        for b in range(3):
            J[a, b] += k * v[a] * g[b]


@_inline
def _density(mx, my, mz, p, tab, s):
    """The density at the point m (absolute coordinates), kg/m^3."""
    d0 = mx - p[0]
    d1 = my - p[1]
    d2 = mz - p[2]
    if p[7] == 0.0:
        return _band(math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) - p[6], tab, int(p[13]))[0]
    return _grid_at(d0, d1, d2, p, tab, s)[0]


@_piece
def drag_piece(x0, y0, z0, x1, y1, z1, h, c, p, tab, s, J, jac):
    """Drag on a point of ballistic coefficient ``c`` over the step (per unit mass): the
    density at the midpoint once, then :func:`.atmosphere.drag_force_rho` and, where ``jac``,
    :func:`.atmosphere.drag_jacobian_rho` (the arithmetic of :func:`.atmosphere.drag_force`
    and :func:`.atmosphere.drag_jacobian` for a band table)."""
    d0 = 0.5 * (x0 + x1) - p[0]
    d1 = 0.5 * (y0 + y1) - p[1]
    d2 = 0.5 * (z0 + z1) - p[2]
    if p[7] == 0.0:
        rho, H = _band(math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) - p[6], tab, int(p[13]))
        drho = -rho / H
    else:
        rho, drho = _grid_at(d0, d1, d2, p, tab, s)
    fx, fy, fz = drag_force_rho(x0, y0, z0, x1, y1, z1, h, p[0], p[1], p[2], p[3], p[4], p[5], c, rho)
    if jac:
        drag_jacobian_rho(x0, y0, z0, x1, y1, z1, h, p[0], p[1], p[2], p[3], p[4], p[5], c, rho, drho, J)
        if p[7] != 0.0:
            _grid_horizontal(x0, y0, z0, x1, y1, z1, h, c, rho, p, tab, s, J)
    return fx, fy, fz


@_piece
def drag_prepare(ta, tm, tb, p, tab, s):
    """NRLMSIS's local time follows the Sun: its position at the sub-step's middle time."""
    if p[7] != 0.0:
        s[0], s[1], s[2] = table_position(tm, p[8], p[9], _sun(p, tab))


@_piece
def drag_facet(ax, ay, az, bx, by, bz, nx, ny, nz, area, k0, k1, k2, k3, h, p, tab, s):
    """Drag on a flat facet (drag coefficient k0, two-sided where k3 > 0.5), N."""
    mx, my, mz = 0.5 * (ax + bx), 0.5 * (ay + by), 0.5 * (az + bz)
    d0, d1, d2 = mx - p[0], my - p[1], mz - p[2]
    vx = (bx - ax) / h - (p[4] * d2 - p[5] * d1)
    vy = (by - ay) / h - (p[5] * d0 - p[3] * d2)
    vz = (bz - az) / h - (p[3] * d1 - p[4] * d0)
    return drag_plate(nx, ny, nz, vx, vy, vz, area, k0, _density(mx, my, mz, p, tab, s), k3)
