"""Third bodies' positions about the central body: the Sun and the Moon from astropy's
ephemerides, a sampled table that interpolates them smoothly, and a body on a Kepler orbit.

Method. :func:`sun_moon_positions` gives geometric geocentric positions (no light time,
no aberration: the instantaneous separation that Newtonian gravity needs) as the difference
of astropy's barycentric positions, ``get_body_barycentric(body) -
get_body_barycentric("earth")``, in the ICRS axes (the axes of the GCRS). With
``ephemeris="builtin"`` these are ERFA's series (``epv00`` for the Earth and the Sun,
``moon98`` for the Moon), evaluated offline by the calls astropy's builtin ephemeris makes
(its bits, without importing ``astropy.coordinates``); from 2000 to 2050 they differ from
JPL's DE421 by up to 25 km for the Moon (median 5 km) and up to 11 km for the Sun (measured
every 2 days, in this module's axes). A JPL kernel file (``.bsp``, SPK types 2 and 3) given
by its path is read through jplephem (astropy's ``ephemeris=`` argument). Astropy's ``get_body`` gives
apparent positions instead (light time and aberration applied): up to 39 km from these for
the Moon and 15000 km for the Sun (measured over 30 days).

:class:`EphemerisTable` samples positions every ``step`` seconds, takes their derivatives
by 5-point central differences and interpolates by cubic Hermite polynomials on each
interval (``C^1`` in time). Interpolation's error term ``|x''''| step^4 / 384`` peaks at an
interval's midpoint and the velocities' at a third of it, so the table measures its error
against the ephemeris at 1/3, 1/2 and 2/3 of every interval (``error_bound``). Measured
over 30 days with the builtin ephemeris: the Moon 1.5 cm at 1 h samples, 0.25 m at 2 h,
20 m at 6 h; the Sun 0.38 m at 6 h, 114 m at 1 d (the Earth's monthly motion about the
Earth-Moon barycentre). At 20000 random times the largest error equals ``error_bound``
to 3 digits, except where it nears the ephemeris' own round-off (the Sun at 1 h samples:
9 mm against an ``error_bound`` of 7 mm). The remainders: Hermite's
``x''''(xi) (t - a)^2 (t - b)^2 / 4!``, the difference's ``step^4 x^(5)(xi) / 30``.

:func:`kepler_third_body` puts a point mass on a fixed Kepler orbit about the centre
(:func:`emorbit.orbits.propagate`, exact to round-off).

Data layout: times are astropy ``Time`` (converted to TDB) or seconds from an epoch
(float64); positions are (n, 3) float64 arrays in m. GM values: :data:`GM_SUN` is astropy's
``GM_sun`` (IAU 2015 Resolution B3, nominal); astropy has no GM of the Moon, so
:data:`GM_MOON` is DE440's 4902.800118 km^3/s^2 (R. S. Park et al., Astron. J. 161 (2021)
105; DE430 had 4902.800066 km^3/s^2, W. M. Folkner et al., IPN Progress Report 42-196,
2014). References: the IAU SOFA library (ERFA) routines ``epv00`` and ``moon98`` (after
J. Meeus, Astronomical Algorithms, 2nd ed., 1998, ch. 47).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping

import numpy as np

from ..errors import InputError
from ..orbits import kepler_period, orbit_state, propagate, state_from_elements
from ..units import to_si

__all__ = [
    "BODIES",
    "GM_SUN",
    "GM_MOON",
    "GM",
    "sun_moon_positions",
    "sun_moon_states",
    "EphemerisTable",
    "sample_table",
    "KeplerThirdBody",
    "kepler_third_body",
]

#: the bodies :func:`sun_moon_positions` knows
BODIES = ("sun", "moon")


def _gm_sun() -> float:
    from astropy.constants import GM_sun

    return float(GM_sun.si.value)


#: GM of the Sun, m^3/s^2 (astropy's GM_sun: IAU 2015 Resolution B3, nominal)
GM_SUN = _gm_sun()
#: GM of the Moon, m^3/s^2 (DE440: R. S. Park et al., Astron. J. 161 (2021) 105)
GM_MOON = 4902.800118e9
#: GM by body name, m^3/s^2
GM = {"sun": GM_SUN, "moon": GM_MOON}


def _body(body, key: str = "body") -> str:
    if not isinstance(body, str) or body.strip().lower() not in BODIES:
        raise InputError(key, f"unknown body {body!r}; known: {', '.join(BODIES)}")
    return body.strip().lower()


def _ephemeris(ephemeris, key: str = "ephemeris") -> str:
    """``"builtin"``, or the absolute path of an existing JPL kernel file (jplephem importable).

    The path is made absolute: astropy reads a name that starts like ``de430`` as one to
    download, and nothing here downloads.
    """
    if isinstance(ephemeris, str) and ephemeris.strip().lower() == "builtin":
        return "builtin"
    if not isinstance(ephemeris, (str, os.PathLike)):
        raise InputError(key, f"'builtin' or the path of a JPL kernel file (.bsp) expected, got {ephemeris!r}")
    path = os.path.abspath(os.fspath(ephemeris))
    if not os.path.isfile(path):
        raise InputError(key, f"no such file: {os.fspath(ephemeris)!r} (give 'builtin' or a JPL kernel's path)")
    try:
        from jplephem.spk import SPK
    except ImportError:
        raise InputError(
            key, f"reading the JPL kernel {os.fspath(ephemeris)!r} needs the package jplephem (pip install jplephem)"
        ) from None
    try:
        SPK.open(path).close()
    except Exception:  # jplephem's message may echo the file's first bytes: not repeated here
        raise InputError(key, f"{os.fspath(ephemeris)!r} is not a JPL kernel (SPK) file") from None
    return path


def _times(times, key: str = "times"):
    from astropy.time import Time

    if not isinstance(times, Time):
        raise InputError(key, f"an astropy Time expected, got {times!r}")
    return Time(np.atleast_1d(times.tdb).ravel())


def _builtin(times, body: str):
    """:func:`_posvel` from ERFA's series: the calls and the arithmetic of astropy's
    ``get_body_barycentric_posvel(..., ephemeris="builtin")`` (``epv00``; ``moon98`` added to
    the Earth's barycentric state with ``pvppv``, the Sun's as ``pvmpv``; the Earth's then
    subtracted in au and au/day, and scaled by astropy's factors to m and m/s), so the same
    bits, without importing ``astropy.coordinates`` (about 0.2 s of a run's start)."""
    import astropy.units as u
    import erfa

    tdb = times if times.scale == "tdb" else times.tdb
    jd1, jd2 = tdb.jd1, tdb.jd2
    helio, bary = erfa.epv00(jd1, jd2)
    pv = erfa.pvppv(erfa.moon98(jd1, jd2), bary) if body == "moon" else erfa.pvmpv(bary, helio)
    pos = (pv["p"] - bary["p"]) * u.au._to(u.m)
    vel = (pv["v"] - bary["v"]) * (u.au / u.day)._to(u.m / u.s)
    return np.ascontiguousarray(pos, dtype=np.float64), np.ascontiguousarray(vel, dtype=np.float64)


def _posvel(times, body: str, ephemeris: str, key: str):
    """Geocentric position (n, 3) m and velocity (n, 3) m/s of ``body`` at TDB ``times``."""
    if ephemeris == "builtin":
        return _builtin(times, body)
    import astropy.units as u
    from astropy.coordinates import get_body_barycentric_posvel

    try:
        pb, vb = get_body_barycentric_posvel(body, times, ephemeris=ephemeris)
        pe, ve = get_body_barycentric_posvel("earth", times, ephemeris=ephemeris)
    except KeyError as exc:  # a kernel without the body's segments
        raise InputError("ephemeris", f"the kernel {ephemeris!r} has no segments for {body}: {exc}") from None
    except ValueError as exc:  # jplephem: a time outside the kernel's span
        raise InputError(key, f"the ephemeris {ephemeris!r} cannot give {body} at these times: {exc}") from None
    pos = (pb.xyz - pe.xyz).to_value(u.m).T
    vel = (vb.xyz - ve.xyz).to_value(u.m / u.s).T
    return np.ascontiguousarray(pos, dtype=np.float64), np.ascontiguousarray(vel, dtype=np.float64)


def sun_moon_positions(times, body: str, *, ephemeris="builtin") -> np.ndarray:
    """Geometric geocentric positions of the Sun or the Moon.

    Parameters
    ----------
    times : astropy.time.Time
        When (any scale; converted to TDB); a scalar or an array of n times.
    body : str
        ``"sun"`` or ``"moon"``.
    ephemeris : str or path
        ``"builtin"`` (ERFA's series, offline) or the path of a JPL kernel file (``.bsp``;
        needs jplephem).

    Returns
    -------
    ndarray
        (n, 3) float64 positions relative to the Earth's centre, m, in the ICRS axes.

    Raises
    ------
    InputError
        An unknown body, times that are no Time, a missing kernel file or jplephem, or
        times outside the kernel's span.
    """
    return sun_moon_states(times, body, ephemeris=ephemeris)[0]


def sun_moon_states(times, body: str, *, ephemeris="builtin") -> tuple[np.ndarray, np.ndarray]:
    """Geometric geocentric positions and velocities of the Sun or the Moon.

    Parameters
    ----------
    times, body, ephemeris
        As :func:`sun_moon_positions`.

    Returns
    -------
    position, velocity : ndarray
        (n, 3) float64, m and m/s, in the ICRS axes.
    """
    name = _body(body)
    eph = _ephemeris(ephemeris)
    return _posvel(_times(times), name, eph, "times")


#: the most samples of a path one run may ask for (a table of 6 float64 per sample)
MAX_SAMPLES = 2_000_000


def _seconds(value, key: str, *, positive: bool = False) -> float:
    return to_si(value, "time", key, positive=positive)


def sample_table(
    body: str, k_first: int, k_last: int, step: float, epoch, ephemeris="builtin", key: str = "table_step"
) -> np.ndarray:
    """Positions and velocities of the Sun or the Moon at the samples ``k step`` from an epoch,
    ``k = k_first .. k_last``: the rows of a table that
    :func:`emorbit.kernels.effects.third_body.table_position` interpolates.

    The positions are :func:`sun_moon_positions`'; the velocities are their 5-point central
    differences (error ``step^4 |x^(5)| / 30``), consistent with the positions, as in
    :class:`EphemerisTable`. A sample's values depend on its time alone, not on the range:
    tables of overlapping ranges agree bit for bit where they overlap.

    Parameters
    ----------
    body : str
        ``"sun"`` or ``"moon"``.
    k_first, k_last : int
        The first and the last sample index (k_last > k_first).
    step : float
        The sampling interval, s.
    epoch : astropy.time.Time
        Time 0 of the samples.
    ephemeris : str or path
        As :func:`sun_moon_positions`.
    key : str
        The key that sets the sampling interval, for the error.

    Returns
    -------
    ndarray
        (k_last - k_first + 1, 6) float64: x, y, z (m), vx, vy, vz (m/s), geocentric, ICRS axes.
    Raises
    ------
    InputError
        More than :data:`MAX_SAMPLES` samples, naming ``key``.
    """
    from astropy.time import TimeDelta

    count = int(k_last) - int(k_first) + 1
    if count > MAX_SAMPLES:
        raise InputError(
            key,
            f"the run spans {count} samples of the {body}'s path at {float(step)!r} s, more than {MAX_SAMPLES}: "
            "raise the sampling interval or shorten the run",
        )
    k = np.arange(int(k_first) - 2, int(k_last) + 3, dtype=np.float64)
    p = _posvel(epoch.tdb + TimeDelta(k * float(step), format="sec"), _body(body), _ephemeris(ephemeris), "t_end")[0]
    v = (p[:-4] - 8.0 * p[1:-3] + 8.0 * p[3:-1] - p[4:]) / (12.0 * float(step))
    return np.ascontiguousarray(np.hstack([p[2:-2], v]))


class EphemerisTable:
    """Positions of the Sun or the Moon sampled every ``step`` and interpolated (cubic Hermite).

    Parameters
    ----------
    body : str
        ``"sun"`` or ``"moon"``.
    t0, t1 : astropy.time.Time
        The span to cover (t1 > t0); the last sample is at or after t1. The ephemeris is
        also read two steps before the first sample and after the last one (the
        differences), so a JPL kernel must cover that much more.
    step : float, Quantity or str
        The sampling interval, s (> 0).
    epoch : astropy.time.Time, optional
        The time that :meth:`position` counts seconds from (default ``t0``).
    ephemeris : str or path
        As :func:`sun_moon_positions`.
    check : bool
        Measure :attr:`error_bound` (three more ephemeris evaluations per interval).

    Attributes
    ----------
    body : str
        As given, lower case.
    epoch : astropy.time.Time
        TDB.
    step : float
        s.
    times : ndarray
        (n + 1,) float64 sample times, s from ``epoch``.
    positions : ndarray
        (n + 1, 3) float64 sampled positions, m.
    velocities : ndarray
        (n + 1, 3) float64 derivatives of the positions by the 5-point central difference
        (error ``step^4 |x^(5)| / 30``), m/s: consistent with the positions, which the
        builtin series' own velocities are not (they differ from the derivative of its
        positions by 3 mm/s for the Moon).
    error_bound : float
        The largest distance between the interpolant and the ephemeris at 1/3, 1/2 and 2/3
        of every interval, m, where the error terms peak (NaN when not ``check``).
    """

    def __init__(self, body: str, t0, t1, step, *, epoch=None, ephemeris="builtin", check: bool = True):
        from astropy.time import Time, TimeDelta

        self.body = _body(body)
        self._ephemeris = _ephemeris(ephemeris)
        for key, t in (("t0", t0), ("t1", t1)):
            if not isinstance(t, Time) or not t.isscalar:
                raise InputError(key, f"one astropy Time expected, got {t!r}")
        if epoch is None:
            epoch = t0
        elif not isinstance(epoch, Time) or not epoch.isscalar:
            raise InputError("epoch", f"one astropy Time expected, got {epoch!r}")
        self.epoch = epoch.tdb
        self.step = _seconds(step, "step", positive=True)
        start = float((t0.tdb - self.epoch).sec)
        end = float((t1.tdb - self.epoch).sec)
        if not end > start:
            raise InputError("t1", f"the span must end after it starts: t1 = {t1.isot} is not after t0 = {t0.isot}")
        n = max(1, math.ceil((end - start) / self.step * (1.0 - 1e-12)))
        # two more samples on either side for the velocities' central differences
        wide = start + self.step * np.arange(-2, n + 3, dtype=np.float64)
        p = _posvel(self.epoch + TimeDelta(wide, format="sec"), self.body, self._ephemeris, "t1")[0]
        self.times = wide[2:-2].copy()
        self.positions = np.ascontiguousarray(p[2:-2])
        self.velocities = np.ascontiguousarray((p[:-4] - 8.0 * p[1:-3] + 8.0 * p[3:-1] - p[4:]) / (12.0 * self.step))
        self.error_bound = math.nan
        if check:
            inner = (self.times[:-1, None] + self.step * np.array([1.0 / 3.0, 0.5, 2.0 / 3.0])).ravel()
            direct = _posvel(self.epoch + TimeDelta(inner, format="sec"), self.body, self._ephemeris, "t1")[0]
            self.error_bound = float(np.linalg.norm(self.position(inner) - direct, axis=-1).max())

    @property
    def start(self) -> float:
        """The first sample's time, s from ``epoch``."""
        return float(self.times[0])

    @property
    def end(self) -> float:
        """The last sample's time, s from ``epoch``."""
        return float(self.times[-1])

    def position(self, t) -> np.ndarray:
        """The interpolated position at times ``t``.

        Parameters
        ----------
        t : float, array_like or Quantity
            Seconds from ``epoch``, within [``start``, ``end``].

        Returns
        -------
        ndarray
            Positions (``t``'s shape + (3,)) float64, m.

        Raises
        ------
        InputError
            A time outside the table's span, or not finite.
        """
        if hasattr(t, "unit"):
            import astropy.units as u

            t = t.to_value(u.s)
        t = np.asarray(t, dtype=np.float64)
        if not np.all(np.isfinite(t)) or np.any(t < self.start) or np.any(t > self.end):
            bad = t[~((t >= self.start) & (t <= self.end))].ravel()[0]
            raise InputError("t", f"{bad!r} s is outside the table's span [{self.start!r}, {self.end!r}] s")
        s = (t - self.start) / self.step
        k = np.clip(np.floor(s).astype(np.int64), 0, len(self.times) - 2)
        f = (s - k)[..., None]
        f2 = f * f
        f3 = f2 * f
        h00 = 2.0 * f3 - 3.0 * f2 + 1.0
        h10 = f3 - 2.0 * f2 + f
        h01 = 3.0 * f2 - 2.0 * f3
        h11 = f3 - f2
        p, v = self.positions, self.velocities
        return h00 * p[k] + h01 * p[k + 1] + self.step * (h10 * v[k] + h11 * v[k + 1])

    __call__ = position


class KeplerThirdBody:
    """A point mass on a fixed Kepler orbit about the centre.

    Parameters
    ----------
    position, velocity : array_like
        (3,) its state relative to the centre at ``epoch``, m and m/s.
    gm : float
        GM of the relative orbit (the centre's plus the body's), m^3/s^2.
    epoch : float
        When the state holds, s (on the integrator's clock).

    Attributes
    ----------
    position0, velocity0 : ndarray
        (3,) float64, as given.
    gm, epoch : float
        As given.
    period : float
        The orbital period, s (inf for an open orbit).
    """

    def __init__(self, position, velocity, gm: float, epoch: float = 0.0):
        self.position0 = np.array(position, dtype=np.float64).reshape(3)
        self.velocity0 = np.array(velocity, dtype=np.float64).reshape(3)
        self.gm = float(gm)
        self.epoch = float(epoch)
        r = float(np.linalg.norm(self.position0))
        energy = 0.5 * float(self.velocity0 @ self.velocity0) - self.gm / r
        self.period = float(kepler_period(-0.5 * self.gm / energy, self.gm)) if energy < 0 else math.inf

    def position(self, t) -> np.ndarray:
        """Positions at times ``t`` (s on the integrator's clock): ``t``'s shape + (3,), m."""
        if hasattr(t, "unit"):
            import astropy.units as u

            t = t.to_value(u.s)
        dt = np.asarray(t, dtype=np.float64) - self.epoch
        return propagate(self.position0, self.velocity0, self.gm, dt)[0]

    __call__ = position


def kepler_third_body(gm_central, elements, epoch=0.0, *, gm_body=0.0) -> KeplerThirdBody:
    """A third body on a Kepler orbit about the centre, from its elements.

    Parameters
    ----------
    gm_central : float, Quantity or str
        GM of the central body, m^3/s^2.
    elements : mapping or tuple
        Osculating elements about the centre (reference plane x-y): a mapping as a scene's
        ``orbit`` table takes them (:func:`emorbit.orbits.orbit_state`: ``a``, ``e``, ``i``,
        ``raan``, ``argp``, ``nu`` or ``mean_anomaly``, with units), or a tuple
        ``(a, e, i, raan, argp, nu)`` in m and rad.
    epoch : float, Quantity or str
        When the elements hold, s on the integrator's clock.
    gm_body : float, Quantity or str
        GM of the third body itself (the relative orbit then has GM = gm_central + gm_body).

    Returns
    -------
    KeplerThirdBody
        Its ``position(t)`` gives the body's positions relative to the centre.

    Raises
    ------
    InputError
        A GM that is not > 0 (gm_body: < 0), elements that are not elements, a bad epoch.
    """
    gm = to_si(gm_central, "gm", "gm_central", positive=True)
    gm_own = to_si(gm_body, "gm", "gm_body", nonnegative=True)
    t = _seconds(epoch, "epoch")
    mu = gm + gm_own
    if isinstance(elements, Mapping):
        pos, vel = orbit_state(elements, mu, (0.0, 0.0, 0.0), key="elements")
    else:
        try:
            values = tuple(float(q) for q in tuple(elements)[:6])
        except (TypeError, ValueError):
            raise InputError(
                "elements", f"a table or (a, e, i, raan, argp, nu) in m and rad, got {elements!r}"
            ) from None
        if len(values) != 6 or not all(math.isfinite(q) for q in values):
            raise InputError("elements", f"six finite numbers (a, e, i, raan, argp, nu) expected, got {elements!r}")
        try:
            pos, vel = state_from_elements(values, mu)
        except ValueError as exc:
            raise InputError("elements", f"{exc}: got {elements!r}") from None
    return KeplerThirdBody(pos, vel, mu, t)
