"""The density of NRLMSIS 2.1 through the optional package pymsis (``pip install pymsis``).

Method: :func:`msis_density` hands altitudes, geodetic latitudes and longitudes, times and
the space-weather indices to ``pymsis.calculate`` in its fly-through mode (one point per
time, no grid) and returns the total mass density. NRLMSIS is an empirical model of the
neutral atmosphere from the ground to the exobase; it depends on the solar flux F10.7 (the
previous day's and its 81-day mean) and on the geomagnetic index Ap, which are given here
explicitly, so that nothing is fetched from the network. pymsis computes in float32, so the
densities carry 7 significant digits.

Data layout: every argument broadcasts to one shape (scalars or arrays); altitudes in m
above the WGS84 ellipsoid, latitudes and longitudes in degrees (or astropy Quantities),
times as astropy ``Time`` (converted to UTC) or numpy ``datetime64``; the result is a
float64 array of that shape, kg/m^3. :func:`msis_grid` keeps each grid it samples in the
per-user cache (``<user cache>/msis/<digest>.npy``, named by a digest of its inputs and of
pymsis's version), so that a run repeated with the same epoch and space weather reads it
from disk instead of calling NRLMSIS 82,584 times again.

References: J. T. Emmert et al., J. Geophys. Res. Space Phys. 127 (2022) e2022JA030896
(NRLMSIS 2.1); J. T. Emmert et al., Earth Space Sci. 8 (2021) e2020EA001321 (NRLMSIS 2.0);
J. M. Picone et al., J. Geophys. Res. 107 (2002) 1468 (NRLMSISE-00); G. Lucas, pymsis,
doi:10.5281/zenodo.5348502.
"""

from __future__ import annotations

import hashlib
import os
import tempfile

import numpy as np

from ..errors import InputError
from ..kernels.jit import cache_enabled, user_cache_dir

__all__ = ["msis_density", "msis_grid", "MSIS_VERSIONS", "GRID"]

#: the NRLMSIS versions pymsis computes (0: NRLMSISE-00)
MSIS_VERSIONS = (0, 2.0, 2.1)


def _pymsis():
    try:
        import pymsis
    except ImportError:
        raise InputError(
            "model",
            "'msis' needs the optional package pymsis, which is not installed: "
            "pip install pymsis (or the extra: pip install 'emorbit[msis]')",
        ) from None
    return pymsis


def _values(value, unit, key: str) -> np.ndarray:
    if hasattr(value, "unit"):
        try:
            value = value.to_value(unit)
        except Exception:
            raise InputError(key, f"a value in {unit} expected, got {value!r}") from None
    try:
        out = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(key, f"numbers expected, got {value!r}") from None
    if not np.all(np.isfinite(out)):
        raise InputError(key, f"finite numbers expected, got {value!r}")
    return out


def _dates(time) -> np.ndarray:
    from astropy.time import Time

    if isinstance(time, Time):
        return np.asarray(time.utc.datetime64, dtype="datetime64[ns]")
    try:
        return np.asarray(time, dtype="datetime64[ns]")
    except (TypeError, ValueError):
        raise InputError("time", f"an astropy Time or numpy datetime64 expected, got {time!r}") from None


def msis_density(h, lat, lon, time, f107, f107a, ap, *, version=2.1) -> np.ndarray:
    """The total mass density of NRLMSIS (2.1 by default) at points and times.

    Parameters
    ----------
    h : float, array_like or Quantity
        Altitude above the WGS84 ellipsoid, m.
    lat, lon : float, array_like or Quantity
        Geodetic latitude and longitude, deg.
    time : astropy.time.Time or datetime64
        When (UTC).
    f107 : float or array_like
        The previous day's solar radio flux F10.7, sfu.
    f107a : float or array_like
        Its 81-day mean centred on the day, sfu.
    ap : float or array_like
        The daily geomagnetic index Ap; or (..., 7) the seven ap values NRLMSIS takes
        (daily Ap, then the 3-hour ap history).
    version : float
        0 (NRLMSISE-00), 2.0 or 2.1.

    Returns
    -------
    ndarray
        float64 densities of the broadcast shape of the inputs, kg/m^3.

    Raises
    ------
    InputError
        pymsis is not installed, a value is not a finite number, a latitude outside
        [-90, 90] deg, negative solar or geomagnetic indices, or an unknown version.
    """
    import astropy.units as u

    pymsis = _pymsis()
    if version not in MSIS_VERSIONS:
        raise InputError("version", f"one of {MSIS_VERSIONS} expected, got {version!r}")
    alt_km = _values(h, u.m, "h") / 1e3
    lat_deg = _values(lat, u.deg, "lat")
    lon_deg = _values(lon, u.deg, "lon")
    if np.any(np.abs(lat_deg) > 90.0):
        raise InputError("lat", f"latitudes lie in [-90, 90] deg, got {lat!r}")
    dates = _dates(time)
    f107v = _values(f107, u.one, "f107")
    f107av = _values(f107a, u.one, "f107a")
    apv = _values(ap, u.one, "ap")
    for key, v in (("f107", f107v), ("f107a", f107av), ("ap", apv)):
        if np.any(v < 0):
            raise InputError(key, f"the index is >= 0, got {v!r}")
    seven = apv.ndim >= 1 and apv.shape[-1] == 7
    ap_daily = apv[..., 0] if seven else apv
    shape = np.broadcast_shapes(alt_km.shape, lat_deg.shape, lon_deg.shape, dates.shape, f107v.shape, f107av.shape)
    shape = np.broadcast_shapes(shape, ap_daily.shape)
    n = int(np.prod(shape))

    def flat(a):
        return np.broadcast_to(a, shape).reshape(n)

    aps = np.broadcast_to(apv, shape + (7,)).reshape(n, 7) if seven else np.repeat(flat(apv)[:, None], 7, axis=1)
    out = pymsis.calculate(
        flat(dates), flat(lon_deg), flat(lat_deg), flat(alt_km), flat(f107v), flat(f107av), aps, version=version
    )
    return np.asarray(out[..., pymsis.Variable.MASS_DENSITY], dtype=np.float64).reshape(shape)


#: the axes of :func:`msis_grid`: altitudes from 80 km every 10 km to 1000 km, geocentric
#: latitudes every 5 deg, local solar time every hour
GRID = {"a0": 80e3, "da": 10e3, "na": 93, "dphi_deg": 5.0, "nlam": 24}


def msis_grid(epoch, f107, f107a, ap, radius, *, version=2.1) -> tuple[np.ndarray, np.ndarray]:
    """NRLMSIS sampled on a grid over altitude, latitude and local solar time at an epoch: the
    density drag reads in its kernels (:mod:`emorbit.kernels.effects.atmosphere_grid`).

    The grid's altitudes are above a sphere of ``radius`` and its latitudes geocentric, as the
    kernels measure them; each node is converted to geodetic coordinates on the WGS84
    ellipsoid (ERFA's ``gc2gd``) for NRLMSIS, at the longitude whose mean local solar time at
    the epoch is the node's (``lon = 15 deg (LST - UT)``; the kernels' local time is the
    apparent one, from the Sun's direction: they differ by the equation of time, at most
    16 min). The space weather, the day of the year and the universal time are those of the
    epoch for the whole run.

    Parameters
    ----------
    epoch : astropy.time.Time
        The date and time (converted to UTC).
    f107, f107a, ap : float
        As :func:`msis_density`.
    radius : float
        The sphere altitudes are measured from, m.
    version : float
        As :func:`msis_density`.

    Returns
    -------
    grid : ndarray
        (na, nphi, nlam + 1) float64 ``log(rho / (kg/m^3))``; the last local-time column is
        the first.
    g_p : ndarray
        (5,) ``[a0, da, phi0, dphi, dlam]`` (m, m, rad, rad, rad).
    """
    t = epoch.utc
    weather = [np.asarray(v, dtype=np.float64).tolist() for v in (f107, f107a, ap, radius)]
    key = (_pymsis().__version__, version, sorted(GRID.items()), t.jd1, t.jd2, weather)
    path = os.path.join(user_cache_dir(), "msis", hashlib.sha1(repr(key).encode()).hexdigest() + ".npy")
    g_p = np.array([GRID["a0"], GRID["da"], -np.pi / 2, np.radians(GRID["dphi_deg"]), 2.0 * np.pi / GRID["nlam"]])
    nphi = int(round(180.0 / GRID["dphi_deg"])) + 1
    shape = (GRID["na"], nphi, GRID["nlam"] + 1)
    if cache_enabled():
        try:
            grid = np.load(path, allow_pickle=False)
            if grid.shape == shape and grid.dtype == np.float64:
                return np.ascontiguousarray(grid), g_p
        except (OSError, ValueError):  # absent, unreadable or damaged: sample again
            pass
    grid = _sample(t, f107, f107a, ap, radius, version, nphi)
    if cache_enabled():
        _keep(path, grid)
    return grid, g_p


def _keep(path: str, grid: np.ndarray) -> None:
    """Write ``grid`` to ``path`` whole or not at all (a temporary file renamed over it)."""
    try:
        os.makedirs(os.path.dirname(path), mode=0o700, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                np.save(f, grid, allow_pickle=False)
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise
    except OSError:  # no writable cache: the next run samples again
        pass


def _sample(t, f107, f107a, ap, radius, version, nphi) -> np.ndarray:
    """NRLMSIS's log density on the grid of :func:`msis_grid` at the UTC time ``t``."""
    import erfa

    a = GRID["a0"] + GRID["da"] * np.arange(GRID["na"])
    phi = np.radians(-90.0 + GRID["dphi_deg"] * np.arange(nphi))
    lam = (2.0 * np.pi / GRID["nlam"]) * np.arange(GRID["nlam"])
    A, P, L = np.meshgrid(a, phi, lam, indexing="ij")
    r = radius + A
    xyz = np.stack([r * np.cos(P), np.zeros_like(r), r * np.sin(P)], axis=-1)
    _, lat, height = erfa.gc2gd(1, xyz)  # 1: WGS84
    ut = (t.jd2 + 0.5 + (t.jd1 % 1.0)) % 1.0 * 24.0  # hours of the day
    lon = (15.0 * (L * 12.0 / np.pi - ut) + 180.0) % 360.0 - 180.0
    rho = msis_density(height, np.degrees(lat), lon, t, f107, f107a, ap, version=version)
    grid = np.empty((GRID["na"], nphi, GRID["nlam"] + 1))
    grid[:, :, :-1] = np.log(rho)
    grid[:, :, -1] = grid[:, :, 0]
    return np.ascontiguousarray(grid)
