"""The force model of the perturbation cases written out again in plain Python, for REBOUND's
``additional_forces``: atmospheric drag, solar radiation pressure with the conical shadow, and
the Moon and the Sun with their tidal (indirect) term, in the geocentric frame.

What the reference takes from emorbit: its constants (GM and radius of the field, ``P_au``, the
au, the Sun's radius, the third bodies' GM) and the Sun's and the Moon's sampled paths
(:func:`emorbit.effects.ephemeris.sample_table`, the samples emorbit's kernels interpolate).
What it computes itself: the cubic Hermite interpolation of those samples, every force, the
shadow function, the tidal potential and its rate, and the shadow's contact times. The
runner checks that both sides hold the same model: the paths against emorbit's own tables
after a run, and the accelerations against emorbit's kernels at states along the orbit.

Equations (x the satellite about the Earth's centre, v its velocity, t seconds from the epoch):

* drag, co-rotating exponential atmosphere: ``a = -1/2 rho(h) B |u| u``, ``u = v - w x x``,
  ``w = (0, 0, omega)``, ``h = |x| - R``, ``rho = rho0 exp(-(h - h0) / H)``;
* radiation pressure on a cannonball: ``a = nu P_au (au / r)^2 (Cr A / m) (x - s) / r``,
  ``r = |x - s|``, s the Sun, nu the visible fraction of the Sun's disc (Montenbruck & Gill
  2000, eq. 3.87, with ``acos``): apparent radii ``a_s = asin(R_sun / |s - x|)``,
  ``b = asin(R / |x|)``, separation ``c = acos(-x . (s - x) / (|x| |s - x|))``; 1 for
  ``c >= a_s + b``, 0 for ``c <= b - a_s``, else ``1 - A / (pi a_s^2)`` with the overlap
  ``A = a_s^2 acos(X / a_s) + b^2 acos((c - X) / b) - c Y``,
  ``X = (c^2 + a_s^2 - b^2) / (2 c)``, ``Y = sqrt(a_s^2 - X^2)``;
* a third body of ``gm`` at s, indirect term included:
  ``a = gm ((s - x) / |s - x|^3 - s / |s|^3)``, potential per unit mass
  ``U = -gm (1 / rho - 1 / sigma - p / sigma^3)`` (``rho = |s - x|``, ``sigma = |s|``,
  ``p = s . x``, ``q = x . x``) evaluated as
  ``-gm [p (2p - q)(2 sigma + rho) / (rho sigma^3 (sigma + rho)^2) - q / (rho sigma (sigma + rho))]``,
  and its rate along the path ``dU/dt = (dU/ds) . s'``.

The power that changes the energy ``E = v^2 / 2 - GM / |x| + U`` is ``a . v`` for drag and
radiation pressure and ``dU/dt`` for a third body. The shadow's contacts (``c = a_s + b``:
penumbra; ``c = b - a_s``: umbra) are where the force loses smoothness (nu behaves as
``1 - k delta^(3/2)`` inside a contact); :meth:`ReferenceModel.contacts` finds them ahead of a
state by Kepler propagation and Brent's method, so that IAS15 can stop there.

Data layout: a path is a ``Path`` (step s, first sample index k0, rows of
``[x, y, z, vx, vy, vz]`` as Python lists); states are float scalars in SI units.
References: O. Montenbruck, E. Gill, Satellite Orbits (Springer, 2000), sections 3.3 and
3.4; D. A. Vallado, Fundamentals of Astrodynamics and Applications, 4th ed. (2013), 8.6.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from emorbit import orbits
from emorbit.effects import srp as srp_effect
from emorbit.effects.ephemeris import GM, sample_table

__all__ = [
    "Path",
    "sample_path",
    "hermite",
    "shadow_conical",
    "tidal_potential",
    "ReferenceModel",
]


@dataclass
class Path:
    """A sampled path of the Sun or the Moon about the Earth.

    Attributes
    ----------
    body : str
        ``"sun"`` or ``"moon"``.
    step : float
        Sampling interval, s.
    k0 : int
        Index of the first sample (its time is ``k0 step`` from the epoch).
    rows : list of list of float
        ``[x, y, z, vx, vy, vz]`` per sample, m and m/s.
    """

    body: str
    step: float
    k0: int
    rows: list

    def positions(self, t) -> np.ndarray:
        """(n, 3) positions at the times ``t`` (s from the epoch), m: :func:`hermite` on arrays."""
        tab = np.asarray(self.rows)
        s = np.atleast_1d(np.asarray(t, float)) / self.step
        kf = np.floor(s)
        j = np.clip(kf - self.k0, 0, len(tab) - 2).astype(np.int64)
        f = (s - (j + self.k0))[:, None]
        f2 = f * f
        f3 = f2 * f
        a, b = tab[j], tab[j + 1]
        return (
            (2 * f3 - 3 * f2 + 1) * a[:, :3]
            + (3 * f2 - 2 * f3) * b[:, :3]
            + self.step * ((f3 - 2 * f2 + f) * a[:, 3:] + (f3 - f2) * b[:, 3:])
        )


def sample_path(body: str, step: float, span: float, epoch) -> Path:
    """Sample the Sun or the Moon every ``step`` from two samples before 0 to two after ``span``.

    Parameters
    ----------
    body : str
        ``"sun"`` or ``"moon"``.
    step : float
        s; the step of emorbit's table of that body.
    span : float
        The run's length, s.
    epoch : astropy.time.Time
        Time 0.

    Returns
    -------
    Path
        The samples (a sample depends on its time alone, so these equal emorbit's where they
        overlap).
    """
    k_first, k_last = -2, int(math.ceil(span / step)) + 2
    tab = sample_table(body, k_first, k_last, step, epoch)
    return Path(body, float(step), k_first, tab.tolist())


def hermite(t: float, step: float, k0: int, rows) -> tuple:
    """Position and velocity on a sampled path at time t: the cubic Hermite interpolant.

    Parameters
    ----------
    t : float
        s from the epoch.
    step : float
        Sampling interval, s.
    k0 : int
        Index of the first sample.
    rows : list
        Samples ``[x, y, z, vx, vy, vz]``.

    Returns
    -------
    tuple
        ``((x, y, z), (vx, vy, vz))``, m and m/s (the interpolant's derivative).
    """
    s = t / step
    kf = math.floor(s)
    f = s - kf
    j = int(kf - k0)
    last = len(rows) - 2
    if j < 0:
        f += j
        j = 0
    elif j > last:
        f += j - last
        j = last
    a, b = rows[j], rows[j + 1]
    f2 = f * f
    f3 = f2 * f
    h00, h10, h01, h11 = 2 * f3 - 3 * f2 + 1, f3 - 2 * f2 + f, 3 * f2 - 2 * f3, f3 - f2
    d00, d10, d01, d11 = 6 * f2 - 6 * f, 3 * f2 - 4 * f + 1, 6 * f - 6 * f2, 3 * f2 - 2 * f
    pos = tuple(h00 * a[i] + h01 * b[i] + step * (h10 * a[i + 3] + h11 * b[i + 3]) for i in range(3))
    vel = tuple((d00 * a[i] + d01 * b[i]) / step + d10 * a[i + 3] + d11 * b[i + 3] for i in range(3))
    return pos, vel


def shadow_conical(dx, dy, dz, sx, sy, sz, radius, sun_radius) -> float:
    """The visible fraction of the Sun's disc (Montenbruck & Gill eq. 3.87, acos form).

    Parameters
    ----------
    dx, dy, dz : float
        The satellite about the occulting body's centre, m.
    sx, sy, sz : float
        The Sun about the same centre, m.
    radius, sun_radius : float
        The occulting body's and the Sun's radii, m.

    Returns
    -------
    float
        nu in [0, 1].
    """
    rd = math.sqrt(dx * dx + dy * dy + dz * dz)
    qx, qy, qz = sx - dx, sy - dy, sz - dz
    rq = math.sqrt(qx * qx + qy * qy + qz * qz)
    a = math.asin(sun_radius / rq)
    b = math.asin(radius / rd)
    c = math.acos(max(-1.0, min(1.0, -(dx * qx + dy * qy + dz * qz) / (rd * rq))))
    if c >= a + b:
        return 1.0
    if c <= b - a:
        return 0.0
    if c <= a - b:
        return 1.0 - (b * b) / (a * a)
    x = (c * c + a * a - b * b) / (2.0 * c)
    y = math.sqrt(max(a * a - x * x, 0.0))
    area = a * a * math.acos(max(-1.0, min(1.0, x / a))) + b * b * math.acos(max(-1.0, min(1.0, (c - x) / b))) - c * y
    return min(max(1.0 - area / (math.pi * a * a), 0.0), 1.0)


def tidal_potential(dx, dy, dz, sx, sy, sz, gm) -> float:
    """A third body's potential per unit mass in the geocentric frame (indirect term included),
    in the form without cancellation (module docstring), J/kg."""
    ex, ey, ez = sx - dx, sy - dy, sz - dz
    rho = math.sqrt(ex * ex + ey * ey + ez * ez)
    sigma = math.sqrt(sx * sx + sy * sy + sz * sz)
    p = sx * dx + sy * dy + sz * dz
    q = dx * dx + dy * dy + dz * dz
    sr = sigma + rho
    return -gm * (p * (2 * p - q) * (2 * sigma + rho) / (rho * sigma**3 * sr * sr) - q / (rho * sigma * sr))


def _tidal(dx, dy, dz, s, w, gm):
    """The third body's acceleration (3,) and dU/dt at x = d for the body at s moving at w."""
    sx, sy, sz = s
    ex, ey, ez = sx - dx, sy - dy, sz - dz
    rho2 = ex * ex + ey * ey + ez * ez
    rho = math.sqrt(rho2)
    sigma2 = sx * sx + sy * sy + sz * sz
    sigma = math.sqrt(sigma2)
    r3, s3 = rho2 * rho, sigma2 * sigma
    acc = (gm * (ex / r3 - sx / s3), gm * (ey / r3 - sy / s3), gm * (ez / r3 - sz / s3))
    # dU/ds . w with dU/ds = -gm [-(s - x)/rho^3 + s/sigma^3 - x/sigma^3 + 3 p s/sigma^5]; the
    # s-terms regrouped: s (1/sigma^3 - 1/rho^3) with 1/sigma^3 - 1/rho^3 from rho - sigma
    p = sx * dx + sy * dy + sz * dz
    q = dx * dx + dy * dy + dz * dz
    sw = sx * w[0] + sy * w[1] + sz * w[2]
    dw = dx * w[0] + dy * w[1] + dz * w[2]
    rho_minus_sigma = (q - 2 * p) / (rho + sigma)
    inv3 = rho_minus_sigma * (rho2 + rho * sigma + sigma2) / (s3 * r3)  # 1/sigma^3 - 1/rho^3
    rate = -gm * (sw * inv3 + dw / r3 - dw / s3 + 3 * p * sw / (s3 * sigma2))
    return acc, rate


class ReferenceModel:
    """A case's force model for REBOUND's callback: accelerations, power and potential.

    Parameters
    ----------
    case : PerturbationCase
        The case (its ``kind`` and ``model`` settings).
    paths : dict
        {body: Path} of the Sun and the Moon the case needs.
    model : dict, optional
        Settings that replace ``case.model`` (the radiation case without shadow).

    Attributes
    ----------
    kind : str
        ``"drag"``, ``"srp"`` or ``"third_body"``.
    """

    def __init__(self, case, paths, model=None):
        self.case = case
        self.kind = case.kind
        self.settings = dict(case.model if model is None else model)
        self.paths = paths
        self.radius = case.radius
        self.shadow = self.settings.get("shadow", "none")
        self._bodies = [(paths[b].step, paths[b].k0, paths[b].rows, GM[b]) for b in self.settings.get("bodies", ())]
        if self.kind == "srp":
            self._sun = paths["sun"]

    def evaluate(self, x, y, z, vx, vy, vz, t):
        """The acceleration and the power at one state.

        Parameters
        ----------
        x, y, z, vx, vy, vz : float
            The state, m and m/s.
        t : float
            s from the epoch.

        Returns
        -------
        tuple
            ``(ax, ay, az, power)``: m/s^2 and W/kg (a . v, or dU/dt for third bodies).
        """
        m = self.settings
        if self.kind == "drag":
            w = m["rotation_rate"]
            ux, uy, uz = vx + w * y, vy - w * x, vz
            h = math.sqrt(x * x + y * y + z * z) - self.radius
            k = -0.5 * m["density"] * math.exp(-(h - m["reference_altitude"]) / m["scale_height"]) * m["ballistic"]
            k *= math.sqrt(ux * ux + uy * uy + uz * uz)
            ax, ay, az = k * ux, k * uy, k * uz
            return ax, ay, az, ax * vx + ay * vy + az * vz
        if self.kind == "srp":
            sun = self._sun
            (sx, sy, sz), _ = hermite(t, sun.step, sun.k0, sun.rows)
            nu = 1.0
            if self.shadow == "conical":
                nu = shadow_conical(x, y, z, sx, sy, sz, self.radius, srp_effect.SUN_RADIUS)
            dx, dy, dz = x - sx, y - sy, z - sz
            r2 = dx * dx + dy * dy + dz * dz
            k = nu * srp_effect.P_AU * (srp_effect.AU * srp_effect.AU / r2) * m["radiation"] / math.sqrt(r2)
            ax, ay, az = k * dx, k * dy, k * dz
            return ax, ay, az, ax * vx + ay * vy + az * vz
        ax = ay = az = power = 0.0
        for step, k0, rows, gm in self._bodies:
            s, w = hermite(t, step, k0, rows)
            acc, rate = _tidal(x, y, z, s, w, gm)
            ax += acc[0]
            ay += acc[1]
            az += acc[2]
            power += rate
        return ax, ay, az, power

    def potential(self, x, t) -> np.ndarray:
        """The time-dependent potential per unit mass at positions x (n, 3) and times t (n,):
        the third bodies' tidal potential (0 for drag and radiation pressure), J/kg."""
        out = np.zeros(len(t))
        for step, k0, rows, gm in self._bodies:
            for i, ti in enumerate(t):
                s, _ = hermite(float(ti), step, k0, rows)
                out[i] += tidal_potential(*map(float, x[i]), *s, gm)
        return out

    # -- the shadow's contacts -----------------------------------------------------------------
    def _gaps(self, X, V, t0, ts) -> np.ndarray:
        """(2, n): c - (a_s + b), the penumbra's edge, and c - (b - a_s), the umbra's, along the
        Kepler orbit of the state (X, V) at t0."""
        ts = np.atleast_1d(np.asarray(ts, float))
        d, _ = orbits.propagate(X, V, self.case.gm, ts - t0)
        d = d.reshape(-1, 3)
        q = self._sun.positions(ts) - d
        rq, rd = np.linalg.norm(q, axis=1), np.linalg.norm(d, axis=1)
        a = np.arcsin(srp_effect.SUN_RADIUS / rq)
        b = np.arcsin(self.radius / rd)
        c = np.arctan2(np.linalg.norm(np.cross(-d, q), axis=1), np.einsum("ij,ij->i", -d, q))
        return np.array([c - (a + b), c - (b - a)])

    def contacts(self, X, V, t0: float, span: float, grid: float = 30.0) -> list[float]:
        """The contact times of the conical shadow within [t0, t0 + span], s.

        The orbit is the Kepler orbit of the state at t0 (over an hour, radiation pressure moves
        a GEO satellite by centimetres from it, a few microseconds in the contact times); the
        sign changes of the gaps on a grid are refined by Brent's method.

        Parameters
        ----------
        X, V : array_like
            (3,) the state at t0, m and m/s.
        t0, span : float
            s.
        grid : float
            The search grid, s (shorter than any penumbra or umbra).

        Returns
        -------
        list of float
            Sorted contact times, s from the epoch.
        """
        from scipy.optimize import brentq

        if self.kind != "srp" or self.shadow != "conical" or span <= 0:
            return []
        ts = t0 + np.append(np.arange(0.0, span, grid), span)
        gaps = self._gaps(X, V, t0, ts)
        out = []
        for which, g in enumerate(gaps):
            for i in np.flatnonzero(np.sign(g[:-1]) != np.sign(g[1:])):
                f = lambda t, w=which: float(self._gaps(X, V, t0, t)[w, 0])  # noqa: E731
                out.append(brentq(f, ts[i], ts[i + 1], xtol=1e-9, rtol=1e-15))
        return sorted(out)
