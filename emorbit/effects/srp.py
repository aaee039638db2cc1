"""Solar radiation pressure (``[[effect]] kind = "srp"``), with the central body's shadow.

Sunlight pushes a body with the pressure ``P = P_au (au / r)^2`` at its distance r from the
Sun (``P_au`` = L_sun / (4 pi au^2 c) = 4.5404e-6 N/m^2 from astropy's IAU 2015 nominal
solar luminosity, unless ``pressure`` gives another). A point mass is a cannonball with
``radiation_coefficient = Cr A / m`` (m^2/kg): ``a = nu P Cr (A / m) u``, u the unit vector
from the Sun to the body. A rigid body takes the flat facets of its surface
(:mod:`emorbit.bodies.facets`), an elastic body the triangles of its tetrahedra's surface,
each with its specular and diffuse reflection coefficients: ``F = -nu P A cos(theta) [(1 -
specular) e + 2 (specular cos(theta) + diffuse / 3) n]`` on the facets that face the Sun (e
the unit vector towards the Sun, n the facet's normal), at the facet's centre, which gives a
torque. ``nu`` is the fraction of the solar disc that the central body leaves visible: 1
without shadow, the cylindrical shadow (0 or 1), or the conical one with its penumbra
(Montenbruck & Gill's overlap of the two discs) (:mod:`emorbit.kernels.effects.radiation`).

Over a step the forces are evaluated at the chord's midpoint (for a rigid body: each facet's
midpoint position and normal) and at the step's middle time, where the Sun is on its sampled
path (:mod:`emorbit.effects.third_body`'s tables: the builtin ephemeris or a JPL kernel,
every ``table_step``). The shadow is evaluated at the chord's midpoint too (a facet's: its
centre's), which keeps the step symmetric in time. The conical shadow is continuous,
but the visible fraction enters and leaves the penumbra as ``1 - k delta^(3/2)``, so across
the shadow's contacts compositions of order 4 to 8 converge at about order 5/2 (measured in
the ``srp-ias15`` validation case: order 2 keeps 2.00; order 8 falls to about 3 where the
shadow's error dominates, 7.97 without shadow). The cylindrical shadow jumps:
a step whose midpoint ends within the Newton iteration's last update of the shadow's edge
(about 1e-9 m) may fail to converge, and is then redone in sub-steps. With ``land = true``
steps land on the shadow's edges instead (:mod:`emorbit.events`: each body's crossings of the
cylinder, or of the penumbra's and the umbra's cones, with this effect's Sun and radii, split
their steps there), so the force is smooth within every step and the compositions keep their
order. Radiation pressure has no potential: the step sums
its discrete work ``F . (x1 - x0)`` (per facet, ``F . (x_f1 - x_f0)``) into
``invariants/work_<label>`` and ``E - E0 - W`` stays at round-off. A point mass's force is
left out of Newton's matrix (below 1e-12 of the central field's derivative); a rigid body's
facets' forces join it (their torques depend on the attitude).

Data layout of the parameters: :mod:`emorbit.kernels.effects.srp`; each point's
``Cr A / m`` is its coefficient in the set.
References: O. Montenbruck, E. Gill, Satellite Orbits (Springer, 2000), sections 3.4.1-3.4.2;
D. A. Vallado, Fundamentals of Astrodynamics and Applications, 4th ed. (2013), section 8.6.4.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..keys import Key
from ..units import to_si
from .base import AT_POINTS, ON_SURFACES, BodyKey, Effect, Pieces, epoch_needed
from .ephemeris import _ephemeris, sample_table

__all__ = ["RadiationPressure", "SHADOWS", "P_AU", "AU", "SUN_RADIUS"]

#: the shadow models and their codes in ``p[4]``
SHADOWS = {"none": 0.0, "cylindrical": 1.0, "conical": 2.0}
#: the shortest sampling interval of the Sun's path, s (its table is cubic Hermite: 6 h is to 0.4 m)
MIN_TABLE_STEP = 60.0


def _constants() -> tuple[float, float, float]:
    from astropy import constants as const

    au = float(const.au.si.value)
    p_au = float(const.L_sun.si.value / (4.0 * math.pi * au**2 * const.c.si.value))
    return p_au, au, float(const.R_sun.si.value)


#: radiation pressure at 1 au (N/m^2), the au (m), the Sun's radius (m): IAU 2015 nominal values
P_AU, AU, SUN_RADIUS = _constants()
#: the most bodies whose steps land on the shadow's edges (two events each for a conical shadow)
MAX_LANDING = 16
_KEYS = (
    Key("shadow", False, "string", '"conical"', '"conical", "cylindrical", "none"',
        "the central body's shadow: with penumbra, a cylinder, or none"),
    Key("ephemeris", False, "string", '"builtin"', '"builtin" or the path of a JPL kernel (.bsp)',
        "where the Sun's position comes from (a kernel needs jplephem)"),
    Key("pressure", False, "pressure (Pa)", '"4.5404e-6 Pa" (L_sun / (4 pi au^2 c))', "> 0",
        "the radiation pressure at 1 au"),
    Key("occulting_radius", False, "length (m)", "the field's radius", "> 0",
        "the radius of the central body's shadow-casting sphere"),
    Key("sun_radius", False, "length (m)", '"695700 km"', "> 0", "the Sun's radius (the penumbra's width)"),
    Key("table_step", False, "time (s)", '"6 h"', "> 0", "the sampling interval of the Sun's path"),
    Key("land", False, "boolean", "false", f"true or false; at most {MAX_LANDING} bodies",
        "steps land on the shadow's edges, so the force is smooth within every step"),
)  # fmt: skip


class RadiationPressure(Effect):
    """Radiation pressure as an effect: ``p`` and the Sun's table ``tab`` as
    :mod:`emorbit.kernels.effects.srp`, the table sampled by :meth:`prepare`.

    Attributes
    ----------
    step : float
        The Sun's sampling interval, s.
    shadow : str
        A key of :data:`SHADOWS`.
    """

    NAME = "srp"
    SUMMARY = "solar radiation pressure on point masses (cannonball) and on bodies' surfaces, with shadow"
    KEYS = _KEYS
    BODY_KEYS = (
        BodyKey(
            Key("radiation_coefficient", False, "area per mass (m2 / kg)", "required under srp", ">= 0",
                "Cr A / m: how strongly sunlight pushes the point, a cannonball (0: not at all)"),
            ("point",), "area_per_mass", "m2 / kg",
        ),
    )  # fmt: skip
    ACTS = {"point": AT_POINTS, "rigid": ON_SURFACES, "elastic": ON_SURFACES}
    CONSERVES: tuple[str, ...] = ()
    NEEDS_FIELD = True
    PATH_KEYS = ("ephemeris",)
    PIECES = Pieces("emorbit.kernels.effects.srp", force="srp_piece", prepare="srp_prepare", facet="srp_facet")
    POTENTIAL = "none: radiation pressure does work W = sum F . (x1 - x0), recorded as invariants/work_srp"
    DISCRETE_FORCE = "F = nu P(x_m) Cr (A / m) m u(x_m), Sun at s(t_m), nu at x_m = (x0 + x1) / 2; facets: plates"
    JACOBIAN = (
        "dF/dx1 = 1/2 k / |e|^3 [e grad nu^T + nu (I - 3 e e^T / |e|^2)], e = x_m - s, k = P_au au^2 Cr A / m; "
        "the cylindrical shadow's jump left out"
    )

    time_dependent = True
    needs_epoch = True
    land = False
    _landing: list = []
    _epoch = None

    def jacobian_left_out(self) -> float:
        """0 without shadow and with the conical one (J holds the derivative of the force and
        of the shadow function); inf with the cylindrical shadow, whose edge is a jump."""
        return math.inf if self.shadow == "cylindrical" else 0.0

    def scratch_size(self, n_points: int) -> int:
        return 3  # the Sun at the sub-step's middle time

    def prepare(self, t0: float, t1: float, epoch) -> None:
        """Sample the Sun's path from before ``t0`` to after ``t1`` (s from the epoch).

        Raises
        ------
        InputError
            No epoch, or times the ephemeris cannot give.
        """
        if epoch is None:
            raise epoch_needed(f"{self.key} takes the Sun's position from an ephemeris")
        self._epoch = epoch
        k_first = math.floor(t0 / self.step) - 1
        k_last = max(math.ceil(t1 / self.step) + 1, k_first + 2)
        stamp = (float(epoch.tdb.jd1), float(epoch.tdb.jd2))
        if self._span is not None and self._span[0] <= k_first and self._span[1] >= k_last and self._span[2] == stamp:
            return
        tab = sample_table("sun", k_first, k_last, self.step, epoch, self._ephemeris, f"{self.key}.table_step")
        self.p[9] = k_first
        self.p[10] = len(tab)
        self.tab = np.ascontiguousarray(tab.ravel())
        self._span = (k_first, k_last, stamp)

    def bind(self, kinds: dict, masses: dict, named) -> None:
        """With ``land``, take the bodies whose steps land on the shadow's edges: all of them.

        Raises
        ------
        InputError
            More than :data:`MAX_LANDING` bodies, naming ``land``.
        """
        self._landing = list(kinds) if self.land else []
        if len(self._landing) > MAX_LANDING:
            raise InputError(
                f"{self.key}.land",
                f"steps land on the shadow's edges of at most {MAX_LANDING} bodies (two events each), and the "
                f"scene has {len(self._landing)}: set land = false",
            )

    def attach(self, events) -> None:
        """With ``land``, add the events that steps land on: each body's crossings of the
        shadow's edges (the cylinder's, or the penumbra's and the umbra's), with this effect's
        Sun, occulting radius and solar radius, labelled ``<label>.<edge>.<body>``."""
        edges = ("cylindrical",) if self.shadow == "cylindrical" else ("penumbra", "umbra")
        have = {e.label for e in events.events}
        for body in self._landing:
            for edge in edges:
                label = f"{self.label}.{edge}.{body}"
                if label in have:
                    continue
                event = events.add(
                    "eclipse", body=body, direction="either", shadow=edge, label=label, key=f"{self.key}.land",
                    epoch=self._epoch,
                )  # fmt: skip
                event.lands, event.added_by, event.sun_path = True, self.key, self.positions
                event.occulting, event.sun_radius = float(self.p[2]), float(self.p[3])

    def positions(self, t) -> np.ndarray:
        """The Sun on the sampled path at times ``t`` (s from the epoch), relative to the central
        body: (n, 3) m (after :meth:`prepare` has covered them)."""
        from ..kernels.effects.third_body import table_positions

        rows = int(self.p[10])
        tab = self.tab[: 6 * rows].reshape(rows, 6)
        return table_positions(np.atleast_1d(np.asarray(t, float)), self.step, float(self.p[9]), tab)

    @classmethod
    def from_table(cls, table, context) -> RadiationPressure:
        """Radiation pressure from ``shadow``, ``ephemeris``, ``pressure``, ``occulting_radius``,
        ``sun_radius``, ``table_step``.

        Raises
        ------
        InputError
            A central body other than the Earth (the ephemeris is geocentric), an unknown
            shadow, a shadow without a radius, a bad pressure, radius, step or ephemeris.
        """
        key, field, strict = context.key, context.field, context.strict
        if field.body and field.body.lower() != "earth":
            raise InputError(
                key, f"the ephemeris gives the Sun about the Earth, but the central body is {field.body!r}"
            )
        shadow = table.get("shadow", "conical")
        if not isinstance(shadow, str) or shadow not in SHADOWS:
            raise InputError(f"{key}.shadow", f"unknown shadow {shadow!r}; known: {', '.join(SHADOWS)}")
        pressure = P_AU
        if "pressure" in table:
            pressure = to_si(table["pressure"], "pressure", f"{key}.pressure", strict=strict, positive=True)
        occulting = field.radius
        if "occulting_radius" in table:
            occulting = to_si(
                table["occulting_radius"], "length", f"{key}.occulting_radius", strict=strict, positive=True
            )
        if shadow != "none" and not occulting > 0.0:
            raise InputError(
                f"{key}.occulting_radius", f"a {shadow} shadow needs the central body's radius: the [field] has none"
            )
        sun_radius = SUN_RADIUS
        if "sun_radius" in table:
            sun_radius = to_si(table["sun_radius"], "length", f"{key}.sun_radius", strict=strict, positive=True)
        step = 6 * 3600.0
        if "table_step" in table:
            step = to_si(table["table_step"], "time", f"{key}.table_step", strict=strict, positive=True)
            if step < MIN_TABLE_STEP:
                raise InputError(
                    f"{key}.table_step", f"{step!r} s samples the Sun's path more finely than needed; give >= 1 min"
                )
        land = table.get("land", False)
        if not isinstance(land, bool):
            raise InputError(f"{key}.land", f"true or false expected, got {land!r}")
        if land and shadow == "none":
            raise InputError(f"{key}.land", "steps land on the shadow's edges, and shadow is none")
        ephemeris = _ephemeris(table.get("ephemeris", "builtin"), f"{key}.ephemeris")
        c = np.asarray(field.center, float)
        effect = cls(table, [pressure, AU, occulting, sun_radius, SHADOWS[shadow], *c, step, 0.0, 2.0], np.zeros(12))
        effect.shadow, effect.step, effect._ephemeris, effect._span = shadow, float(step), ephemeris, None
        effect.land, effect._landing, effect._epoch = land, [], None
        return effect
