"""A density grid over altitude, latitude and local solar time (NRLMSIS sampled at an epoch).

The density at a point d (relative to the central body's centre) with the Sun at s and the
body's pole p (unit) is read from a grid of ``log rho`` by trilinear interpolation in

    a = |d| - R                        (altitude above a sphere of radius R, m)
    phi = asin(d . p / |d|)            (geocentric latitude, rad)
    lam = atan2(p . (s_e x d_e), s_e . d_e) + pi    (local solar time as an angle, rad: 0 at
                                        midnight, pi at noon; d_e, s_e the parts normal to p)

so that the density's diurnal bulge follows the Sun. Between grid altitudes ``log rho`` is
linear (an exponential layer); below and above the grid the end layers extend, latitudes
clamp at the poles' rows and the local time wraps around (the grid's last column is its
first). The altitude derivative ``d rho / d a = rho d(log rho)/da`` is the interpolated
layer slope, which drag's Jacobian takes (:func:`.atmosphere.drag_jacobian_rho`), beside the
interpolant's horizontal slopes (:func:`grid_horizontal_gradient_at`).

Data layout: ``g_p`` (5,) float64 ``[a0, da, phi0, dphi, dlam]`` (m, m, rad, rad, rad): the
grid's first altitude and spacing, first latitude and spacing, local-time spacing; ``grid``
(na, nphi, nlam + 1) float64 ``log(rho / (kg/m^3))``. References: J. T. Emmert et al.,
J. Geophys. Res. Space Phys. 127 (2022) e2022JA030896 (NRLMSIS 2.1).
"""

from __future__ import annotations

import math

from ..jit import kernel

__all__ = ["grid_density", "grid_density_at", "grid_horizontal_gradient_at"]

_inline = kernel(inline="always")


@_inline
def grid_density(d0, d1, d2, s0, s1, s2, p0, p1, p2, radius, g_p, grid):
    """The density of the grid at a point, and its altitude derivative.

    Parameters
    ----------
    d0, d1, d2 : float
        The point relative to the central body's centre, m.
    s0, s1, s2 : float
        The Sun relative to the same centre, m.
    p0, p1, p2 : float
        The body's pole, a unit vector.
    radius : float
        R, m.
    g_p : ndarray
        (5,) the grid's axes (the module's docstring).
    grid : ndarray
        (na, nphi, nlam + 1) ``log rho``.

    Returns
    -------
    tuple of float
        ``(rho, drho)``: kg/m^3 and kg/m^4.
    """
    flat = grid.reshape(grid.size)
    return grid_density_at(
        d0, d1, d2, s0, s1, s2, p0, p1, p2, radius, g_p[0], g_p[1], g_p[2], g_p[3], g_p[4], flat, 0,
        grid.shape[0], grid.shape[1], grid.shape[2],
    )  # fmt: skip


@_inline
def _cell(d0, d1, d2, s0, s1, s2, p0, p1, p2, radius, a0, da, phi0, dphi, dlam, na, nphi, nl):
    """A point's cell of the grid and its place in it: ``(i, fa, j, fp, k, fl, unclamped)``
    (altitude layer, latitude row and local-time column with their fractions; whether the
    latitude lies between two rows), and ``(r, z, e0, e1, e2)``: |d|, d . p and d's part
    normal to the pole."""
    r = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    z = d0 * p0 + d1 * p1 + d2 * p2
    zs = s0 * p0 + s1 * p1 + s2 * p2
    e0, e1, e2 = d0 - z * p0, d1 - z * p1, d2 - z * p2
    f0, f1, f2 = s0 - zs * p0, s1 - zs * p1, s2 - zs * p2
    cross = p0 * (f1 * e2 - f2 * e1) + p1 * (f2 * e0 - f0 * e2) + p2 * (f0 * e1 - f1 * e0)
    lam = math.atan2(cross, f0 * e0 + f1 * e1 + f2 * e2) + math.pi
    phi = math.asin(max(-1.0, min(1.0, z / r)))
    nlam = nl - 1
    # altitude: the layer below (the end layers extend)
    x = (r - radius - a0) / da
    i = min(max(int(math.floor(x)), 0), na - 2)
    fa = x - i
    # latitude: clamped at the poles' rows
    y = (phi - phi0) / dphi
    j = min(max(int(math.floor(y)), 0), nphi - 2)
    fp = min(max(y - j, 0.0), 1.0)
    # local time: periodic
    w = lam / dlam
    k = int(math.floor(w)) % nlam
    fl = w - math.floor(w)
    return i, fa, j, fp, k, fl, 0.0 < y - j < 1.0, r, z, e0, e1, e2


@_inline
def grid_density_at(d0, d1, d2, s0, s1, s2, p0, p1, p2, radius, a0, da, phi0, dphi, dlam, tab, o, na, nphi, nl):
    """:func:`grid_density` with the axes as scalars and the grid read from a flat array,
    ``grid[i, j, k] = tab[o + (i nphi + j) nl + k]`` (nl = nlam + 1): no array views, so a loop
    over points that calls it keeps no reference counts."""
    i, fa, j, fp, k, fl, _, _, _, _, _, _ = _cell(
        d0, d1, d2, s0, s1, s2, p0, p1, p2, radius, a0, da, phi0, dphi, dlam, na, nphi, nl
    )
    lo = 0.0
    hi = 0.0
    for jj, wj in ((j, 1.0 - fp), (j + 1, fp)):
        for kk, wk in ((k, 1.0 - fl), (k + 1, fl)):
            lo += wj * wk * tab[o + (i * nphi + jj) * nl + kk]
            hi += wj * wk * tab[o + ((i + 1) * nphi + jj) * nl + kk]
    slope = (hi - lo) / da
    rho = math.exp(lo + fa * (hi - lo))
    return rho, rho * slope


@_inline
def grid_horizontal_gradient_at(
    d0, d1, d2, s0, s1, s2, p0, p1, p2, radius, a0, da, phi0, dphi, dlam, tab, o, na, nphi, nl
):  # fmt: skip
    """The horizontal part of the gradient of ``log rho`` (:func:`grid_density_at`'s
    arguments), 1/m: ``dL/dphi grad phi + dL/dlam grad lam``, the interpolant's slopes along
    latitude (0 beyond the poles' rows) and local time, with ``grad phi = (p - z d / r^2) /
    |e|`` and ``grad lam = (p x e) / |e|^2`` (e: d's part normal to the pole; 0 on the pole's
    axis). With the altitude part, ``grad rho = rho (dL/da d / r + this)``."""
    i, fa, j, fp, k, fl, inside, r, z, e0, e1, e2 = _cell(
        d0, d1, d2, s0, s1, s2, p0, p1, p2, radius, a0, da, phi0, dphi, dlam, na, nphi, nl
    )
    ee = e0 * e0 + e1 * e1 + e2 * e2
    if not ee > 1e-12 * r * r:
        return 0.0, 0.0, 0.0
    lp = 0.0  # d L / d fp
    ll = 0.0  # d L / d fl
    for layer, wa in ((i, 1.0 - fa), (i + 1, fa)):
        base = o + layer * nphi * nl
        for kk, wk in ((k, 1.0 - fl), (k + 1, fl)):
            lp += wa * wk * (tab[base + (j + 1) * nl + kk] - tab[base + j * nl + kk])
        for jj, wj in ((j, 1.0 - fp), (j + 1, fp)):
            ll += wa * wj * (tab[base + jj * nl + k + 1] - tab[base + jj * nl + k])
    cp = (lp / dphi if inside else 0.0) / math.sqrt(ee)
    cl = ll / (dlam * ee)
    q = z / (r * r)
    return (
        cp * (p0 - q * d0) + cl * (p1 * e2 - p2 * e1),
        cp * (p1 - q * d1) + cl * (p2 * e0 - p0 * e2),
        cp * (p2 - q * d2) + cl * (p0 * e1 - p1 * e0),
    )
