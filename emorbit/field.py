"""The central gravity field: a fixed point mass at ``center`` with parameter GM.

Three ways to give its strength (exactly one):

* ``gm``: GM itself (m^3/s^2);
* ``g_ref`` and ``r_ref``: the acceleration at a reference distance, GM = g_ref r_ref^2
  (the paper's form);
* ``body``: a named body whose GM comes from :mod:`astropy.constants` (see :data:`BODIES`).
"""

from __future__ import annotations

import astropy.constants as const
import numpy as np

from .errors import InputError
from .units import to_si, vector_to_si

__all__ = ["CentralField", "BODIES", "RADII"]

#: named central bodies and the astropy constant that gives their GM (IAU 2015 nominal values)
BODIES = {
    "earth": const.GM_earth,
    "sun": const.GM_sun,
    "jupiter": const.GM_jup,
}
#: their nominal equatorial radii (IAU 2015), the default collision radius
RADII = {
    "earth": const.R_earth,
    "sun": const.R_sun,
    "jupiter": const.R_jup,
}


class CentralField:
    """A stationary, radially symmetric field of a fixed point mass.

    Parameters
    ----------
    gm : Quantity, str or float, optional
        GM in m^3/s^2 (plain numbers are SI).
    g_ref, r_ref : optional
        acceleration (m/s^2) at distance ``r_ref`` (m); GM = g_ref * r_ref**2.
    body : str, optional
        ``"earth"``, ``"sun"`` or ``"jupiter"``: GM from astropy.constants.
    center : 3-vector, optional
        position X_Z of the centre in m (default: the origin).
    radius : optional
        the central body's radius in m: a body whose recorded position comes closer is
        stopped with an error (default: the nominal radius of a named body, else 0).
    strict : bool
        require units on every value (used for scenes).

    Attributes
    ----------
    gm : float
        GM in m^3/s^2.
    center : ndarray (3,)
        the centre in m.
    body : str or None
        the named body, if the field was given by name.
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
        self.body = None
        if gm is not None:
            self.gm = to_si(gm, "gm", f"{key}.gm", strict=strict, positive=True)
        elif g_ref is not None:
            if r_ref is None:
                raise InputError(f"{key}.g_ref", "g_ref needs r_ref (the distance where g = g_ref)")
            g = to_si(g_ref, "acceleration", f"{key}.g_ref", strict=strict, positive=True)
            r = to_si(r_ref, "length", f"{key}.r_ref", strict=strict, positive=True)
            self.gm = g * r * r
        else:
            if not isinstance(body, str) or body.lower() not in BODIES:
                raise InputError(f"{key}.body", f"unknown body {body!r}; known: {', '.join(sorted(BODIES))}")
            self.body = body.lower()
            self.gm = float(BODIES[self.body].si.value)
        self.center = vector_to_si(center, "length", f"{key}.center", strict=strict)
        if radius is not None:
            self.radius = to_si(radius, "length", f"{key}.radius", strict=strict, nonnegative=True)
        else:
            self.radius = float(RADII[self.body].si.value) if self.body else 0.0

    def __repr__(self) -> str:
        src = f"body={self.body!r}" if self.body else f"gm={self.gm!r}"
        return f"CentralField({src}, center={self.center.tolist()!r})"

    def acceleration(self, position) -> np.ndarray:
        """g at ``position`` (3,) or (3, n) in m; returns m/s^2 with the same shape."""
        r = self.center.reshape((3,) + (1,) * (np.ndim(position) - 1)) - np.asarray(position, dtype=float)
        return self.gm * r / np.linalg.norm(r, axis=0) ** 3

    def potential(self, position) -> np.ndarray:
        """Potential per unit mass V = -GM / r at ``position`` (3,) or (3, n), in J/kg."""
        r = self.center.reshape((3,) + (1,) * (np.ndim(position) - 1)) - np.asarray(position, dtype=float)
        return -self.gm / np.linalg.norm(r, axis=0)
