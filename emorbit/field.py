"""The central gravity field: a fixed point mass at ``center`` with parameter GM.

Three ways to give its strength (exactly one):

* ``gm``: GM itself (m^3/s^2);
* ``g_ref`` and ``r_ref``: the acceleration at a reference distance, GM = g_ref r_ref^2
  (the paper's form);
* ``body``: a named body (:data:`BODIES`, :func:`body_constants`). The Earth, the Sun and
  Jupiter take GM and radius from :mod:`astropy.constants` (IAU 2015 nominal values); the
  Moon and Mars from :mod:`pyshtools.constants` (pyshtools, BSD-3-Clause; the ``bodies``
  extra, ``pip install "emorbit[bodies]"``): the Moon's GM from GRAIL (J. G. Williams et al.,
  J. Geophys. Res. Planets 119 (2014) 1546), Mars's from A. S. Konopliv, R. S. Park,
  W. M. Folkner, Icarus 274 (2016) 253, each with its mean radius and sidereal rate as
  pyshtools states them.

A named body also gives the rate at which its atmosphere co-rotates (drag) by default; the
pole and the prime meridian of a turning gravity field come from the IAU WGCCRE model in a
NAIF text kernel the user names (:mod:`emorbit.effects.gravity_field`, ``rotation = "pck"``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import astropy.constants as const
import numpy as np

from .errors import InputError
from .units import to_si, vector_to_si

__all__ = ["CentralField", "BODIES", "NamedBody", "body_constants"]

BODIES = {
    "earth": "astropy.constants: GM_earth, R_earth (IAU 2015 nominal); the IERS 2010 mean rotation rate",
    "sun": "astropy.constants: GM_sun, R_sun (IAU 2015 nominal); the Carrington rate (25.38 days)",
    "jupiter": "astropy.constants: GM_jup, R_jup (IAU 2015 nominal); System III (9 h 55 min 29.711 s)",
    "moon": "pyshtools.constants.Moon: gm (GRAIL, Williams et al. 2014), mean_radius, angular_velocity",
    "mars": "pyshtools.constants.Mars: gm (Konopliv et al. 2016), mean_radius, angular_velocity",
}
"""The named central bodies and where their constants come from."""

#: astropy's bodies: GM and radius constants, and the sidereal rotation rate (rad/s): the
#: Earth's mean angular velocity (IERS Conventions 2010), the Sun's Carrington rate,
#: Jupiter's System III
_ASTROPY = {
    "earth": (const.GM_earth, const.R_earth, 7.292115e-5),
    "sun": (const.GM_sun, const.R_sun, 2.0 * math.pi / (25.38 * 86400.0)),
    "jupiter": (const.GM_jup, const.R_jup, 2.0 * math.pi / (9.0 * 3600.0 + 55.0 * 60.0 + 29.711)),
}
#: pyshtools's bodies: the module of :mod:`pyshtools.constants` that holds them
_PYSHTOOLS = {"moon": "Moon", "mars": "Mars"}


@dataclass(frozen=True)
class NamedBody:
    """A named central body's constants, SI.

    Attributes
    ----------
    name : str
        The body (lower case).
    gm : float
        GM, m^3/s^2.
    radius : float
        The collision radius a field of this body takes by default, m (the nominal equatorial
        radius for astropy's bodies, the mean radius for pyshtools's).
    rate : float
        The sidereal rotation rate, rad/s (drag's co-rotating atmosphere by default).
    source : str
        Where the values come from.
    """

    name: str
    gm: float
    radius: float
    rate: float
    source: str


def body_constants(name, key: str = "field.body") -> NamedBody:
    """A named body's GM, radius and rotation rate.

    Parameters
    ----------
    name : str
        A key of :data:`BODIES`, any case.
    key : str
        The key that named it, for errors.

    Returns
    -------
    NamedBody

    Raises
    ------
    InputError
        An unknown name, or the Moon or Mars without pyshtools installed.
    """
    lower = name.strip().lower() if isinstance(name, str) else None
    if lower not in BODIES:
        raise InputError(key, f"unknown body {name!r}; known: {', '.join(sorted(BODIES))}")
    if lower in _ASTROPY:
        gm, radius, rate = _ASTROPY[lower]
        return NamedBody(lower, float(gm.si.value), float(radius.si.value), rate, BODIES[lower])
    try:
        import pyshtools.constants as shc
    except ImportError:
        raise InputError(
            key,
            f"body = {name!r} takes GM and radius from pyshtools, which is not installed: "
            'pip install "emorbit[bodies]" (or give gm and radius)',
        ) from None
    body = getattr(shc, _PYSHTOOLS[lower])
    return NamedBody(
        lower,
        float(body.gm.value),
        float(body.mean_radius.value),
        float(body.angular_velocity.value),
        BODIES[lower],
    )


class CentralField:
    """A stationary, radially symmetric field of a fixed point mass.

    Give exactly one of ``gm``, ``g_ref`` with ``r_ref``, and ``body``. Physical values
    are astropy Quantities, strings with a unit, or plain numbers in SI.

    Parameters
    ----------
    gm : Quantity, str or float, optional
        GM, m^3/s^2.
    g_ref : Quantity, str or float, optional
        The acceleration at distance ``r_ref``, m/s^2; GM = g_ref r_ref^2 (the paper's form).
    r_ref : Quantity, str or float, optional
        The distance at which ``g_ref`` is given, m.
    body : str, optional
        ``"earth"``, ``"sun"``, ``"jupiter"``, ``"moon"`` or ``"mars"``: GM from
        :func:`body_constants` (:data:`BODIES` says where each comes from).
    center : Quantity or sequence, optional
        Position of the centre, m (default: the origin).
    radius : Quantity, str or float, optional
        The central body's radius, m: a body whose recorded position comes closer stops
        the run with an :class:`~emorbit.errors.IntegrationError` (default: the nominal
        radius of a named body, :func:`body_constants`, else 0: no check).
    strict : bool
        Require units on every value (scenes do).
    key : str
        Prefix of the keys that error messages name.

    Attributes
    ----------
    gm : float
        GM, m^3/s^2.
    center : ndarray
        The centre (3,), m.
    radius : float
        The collision radius, m (0: none).
    body : str or None
        The named body, if the field was given by name.
    rate : float or None
        The named body's sidereal rotation rate, rad/s (None for a field given by GM).

    Raises
    ------
    InputError
        Not exactly one way of giving GM, an unknown body, or a value that is not a
        positive quantity of the right kind.
    """

    def __init__(
        self,
        gm=None,
        *,
        g_ref=None,
        r_ref=None,
        body=None,
        center=(0.0, 0.0, 0.0),
        radius=None,
        strict: bool = False,
        key: str = "field",
    ):
        given = [name for name, value in (("gm", gm), ("g_ref", g_ref), ("body", body)) if value is not None]
        if r_ref is not None and g_ref is None:
            raise InputError(f"{key}.r_ref", "r_ref needs g_ref (the acceleration at r_ref)")
        if len(given) != 1:
            what = "none" if not given else " and ".join(given)
            raise InputError(key, f"give exactly one of gm, (g_ref and r_ref) or body; got {what}")
        self.body, self.rate, named = None, None, None
        if gm is not None:
            self.gm = to_si(gm, "gm", f"{key}.gm", strict=strict, positive=True)
        elif g_ref is not None:
            if r_ref is None:
                raise InputError(f"{key}.g_ref", "g_ref needs r_ref (the distance where g = g_ref)")
            g = to_si(g_ref, "acceleration", f"{key}.g_ref", strict=strict, positive=True)
            r = to_si(r_ref, "length", f"{key}.r_ref", strict=strict, positive=True)
            self.gm = g * r * r
        else:
            named = body_constants(body, f"{key}.body")
            self.body, self.gm, self.rate = named.name, named.gm, named.rate
        self.center = vector_to_si(center, "length", f"{key}.center", strict=strict)
        if radius is not None:
            self.radius = to_si(radius, "length", f"{key}.radius", strict=strict, nonnegative=True)
        else:
            self.radius = named.radius if named else 0.0

    def __repr__(self) -> str:
        src = f"body={self.body!r}" if self.body else f"gm={self.gm!r}"
        return f"CentralField({src}, center={self.center.tolist()!r})"

    #: |r x v| below this fraction of r |v| is a radial line through the centre (round-off)
    RADIAL = 1e-12

    def check_start(self, points, position, velocity, *, gravity: bool, key: str, what: str, motion_key: str) -> None:
        """Refuse a body that starts inside the central body or runs into the singular centre.

        Parameters
        ----------
        points : array_like
            (n, 3) positions, m: a point mass's position, a rigid body's mass points or an
            elastic body's nodes.
        position, velocity : array_like
            (3,) position (m) and velocity (m/s) of the body's centre of mass.
        gravity : bool
            Whether the field acts on the body (the centre is singular only then).
        key : str
            The key that placed the points (``body[0].position`` or ``body[0].orbit``).
        what : str
            What the points are, for the message (``"the point"``, ``"a mass point of the body"``).
        motion_key : str
            The key of the velocity (``body[0].velocity`` or ``body[0].orbit``).

        Raises
        ------
        InputError
            A point at the centre (with gravity), a point closer to the centre than
            :attr:`radius`, or (with gravity and no radius) a centre of mass that moves on a
            radial line through the centre towards it, or away from it too slowly to escape:
            angular momentum zero to round-off (:attr:`RADIAL` of r |v|), with v = 0 included.
        """
        x = np.atleast_2d(np.asarray(points, float)) - self.center
        d = np.linalg.norm(x, axis=1)
        if gravity and not np.all(d > 0):
            raise InputError(key, f"{what} is at the field's centre, where gravity is singular")
        if self.radius > 0 and np.any(d < self.radius):
            raise InputError(
                key,
                f"{what} starts inside the central body: r = {float(d.min())!r} m from the centre, below the "
                f"field's radius {self.radius!r} m",
            )
        if not gravity or self.radius > 0:
            return
        r = np.asarray(position, float) - self.center
        v = np.asarray(velocity, float)
        rn, vn = float(np.linalg.norm(r)), float(np.linalg.norm(v))
        if rn == 0 or float(np.linalg.norm(np.cross(r, v))) > self.RADIAL * rn * vn:
            return
        if float(r @ v) > 0 and 0.5 * vn * vn >= self.gm / rn:
            return  # outwards at escape speed or more: it never comes back
        raise InputError(
            motion_key,
            "the body moves on a radial line through the field's centre (no angular momentum about it) and "
            "reaches the centre, where gravity is singular and nothing stops it; give the [field] a radius "
            "(a collision radius stops the run there) or the velocity a part across the line to the centre",
        )

    def acceleration(self, position) -> np.ndarray:
        """The field's acceleration g at given positions.

        Parameters
        ----------
        position : array_like
            Positions (3,) or (3, n), m.

        Returns
        -------
        ndarray
            g, m/s^2, with the shape of ``position``.
        """
        r = self.center.reshape((3,) + (1,) * (np.ndim(position) - 1)) - np.asarray(position, dtype=float)
        return self.gm * r / np.linalg.norm(r, axis=0) ** 3

    def potential(self, position) -> np.ndarray:
        """The potential per unit mass V = -GM / r at given positions.

        Parameters
        ----------
        position : array_like
            Positions (3,) or (3, n), m.

        Returns
        -------
        ndarray
            V, J/kg: a scalar for (3,), shape (n,) for (3, n).
        """
        r = self.center.reshape((3,) + (1,) * (np.ndim(position) - 1)) - np.asarray(position, dtype=float)
        return -self.gm / np.linalg.norm(r, axis=0)
