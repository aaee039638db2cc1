"""Solar radiation pressure (``[[effect]] kind = "srp"``), with the central body's shadow.

Sunlight pushes a body with the pressure ``P = P_au (au / r)^2`` at its distance r from the
Sun (``P_au`` = L_sun / (4 pi au^2 c) = 4.5404e-6 N/m^2 from astropy's IAU 2015 nominal solar
luminosity, unless ``pressure`` gives another). A point mass is a cannonball with
``radiation_coefficient = Cr A / m`` (m^2/kg): ``a = nu P Cr (A / m) u``, u the unit vector
from the Sun to the body. A rigid body takes the flat facets of its surface
(:mod:`emorbit.bodies.facets`), each with its specular and diffuse reflection coefficients:
``F = -nu P A cos(theta) [(1 - specular) e + 2 (specular cos(theta) + diffuse / 3) n]`` on the
facets that face the Sun (e the unit vector towards the Sun, n the facet's normal), at the
facet's centre, which gives a torque. ``nu`` is the fraction of the solar disc that the
central body leaves visible: 1 without shadow, the cylindrical shadow (0 or 1), or the
conical one with its penumbra (Montenbruck & Gill's overlap of the two discs)
(:mod:`emorbit.kernels.effects.radiation`).

Over a step the forces are evaluated at the chord's midpoint (for a rigid body: each facet's
midpoint position and normal) and at the step's middle time, where the Sun is on its sampled
path (:mod:`emorbit.effects.third_body`'s tables: the builtin ephemeris or a JPL kernel,
every ``table_step``). The conical shadow is continuous and is evaluated at the chord's
midpoint too (a rigid body's: its centre of mass's), which keeps the step symmetric in time;
but the visible fraction enters and leaves the penumbra as ``1 - k delta^(3/2)``, so across
the shadow's contacts compositions of order 4 to 8 converge at about order 5/2 (measured in
the ``srp-ias15`` validation case: order 2 keeps 2.00; order 8 falls to about 3 where the
shadow's error dominates, 7.97 without shadow). The cylindrical shadow jumps, and is
evaluated at the midpoint predicted from the step's start, ``x0 + h v0 / 2``, so that the
jump cannot stall the Newton iteration. Radiation pressure has no potential: the step sums
its discrete work ``F . (x1 - x0)`` (per facet, ``F . (x_f1 - x_f0)``) into
``invariants/work_<label>`` and ``E - E0 - W`` stays at round-off. A point mass's force is
left out of Newton's matrix (below 1e-12 of the central field's derivative); a rigid body's
facets' forces join it (their torques depend on the attitude).

Data layout of the kernel's parameters: ``srp_p`` (10,) ``[P_au, au, R_occ, R_sun, shadow
(0 none, 1 cylindrical, 2 conical), c0, c1, c2, table_step, k0]``, ``srp_tab`` (n, 6) the
Sun's table relative to the central body, ``srp_c`` (n,) each point's ``Cr A / m``.
References: O. Montenbruck, E. Gill, Satellite Orbits (Springer, 2000), sections 3.4.1-3.4.2;
D. A. Vallado, Fundamentals of Astrodynamics and Applications, 4th ed. (2013), section 8.6.4.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..keys import Key
from ..units import to_si
from .base import EffectTerm
from .ephemeris import _ephemeris, sample_table

__all__ = ["NAME", "SUMMARY", "KEYS", "CONSERVES", "BODY_KINDS", "KERNEL", "build", "RadiationPressure", "SHADOWS"]

NAME = "srp"
SUMMARY = "solar radiation pressure on point masses (cannonball) and rigid bodies' facets, with shadow"
#: the shadow models and their codes in ``srp_p[4]``
SHADOWS = {"none": 0.0, "cylindrical": 1.0, "conical": 2.0}


def _constants() -> tuple[float, float, float]:
    from astropy import constants as const

    au = float(const.au.si.value)
    p_au = float(const.L_sun.si.value / (4.0 * math.pi * au**2 * const.c.si.value))
    return p_au, au, float(const.R_sun.si.value)


#: radiation pressure at 1 au (N/m^2), the au (m), the Sun's radius (m): IAU 2015 nominal values
P_AU, AU, SUN_RADIUS = _constants()
KEYS = (
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
)  # fmt: skip
POTENTIAL = "none: radiation pressure does work W = sum F . (x1 - x0), recorded as invariants/work_srp"
DISCRETE_FORCE = (
    "F = nu P(x_m) Cr (A / m) m u(x_m), Sun at s(t_m), nu at x_m (cylindrical: x0 + h v0 / 2); facets: plates"
)
JACOBIAN = "points: left out (below 1e-12 of the central field's); facets: by differences in the attitude"
CONSERVES: tuple[str, ...] = ()
BODY_KINDS = ("point", "rigid")
HAS_POTENTIAL = False

KERNEL = {
    "imports": (
        "from emorbit.kernels.effects.radiation import shadow_conical, shadow_cylindrical, srp_cannonball\n"
        "from emorbit.kernels.effects.third_body import table_position"
    ),
    "setup": "srp_nu = np.ones(n)  # the cylindrical shadow at each point's predicted midpoint",
    "substep": """
srp_sx, srp_sy, srp_sz = table_position(tm, srp_p[8], srp_p[9], srp_tab)
for i in range(n):
    if srp_c[i] != 0.0 and srp_p[4] == 1.0:
        srp_nu[i] = shadow_cylindrical(
            x[0, i] + 0.5 * h * v[0, i] - srp_p[5], x[1, i] + 0.5 * h * v[1, i] - srp_p[6],
            x[2, i] + 0.5 * h * v[2, i] - srp_p[7], srp_sx, srp_sy, srp_sz, srp_p[2],
        )
""",
    "own": """
if srp_c[i] != 0.0:
    mx = 0.5 * (x0 + x1) - srp_p[5]
    my = 0.5 * (y0 + y1) - srp_p[6]
    mz = 0.5 * (z0 + z1) - srp_p[7]
    nu = shadow_conical(mx, my, mz, srp_sx, srp_sy, srp_sz, srp_p[2], srp_p[3]) if srp_p[4] == 2.0 else srp_nu[i]
    gx, gy, gz = srp_cannonball(mx, my, mz, srp_sx, srp_sy, srp_sz, srp_p[0], srp_p[1], srp_c[i], nu)
    fx += gx
    fy += gy
    fz += gz
""",
    "pairs": "",
    # the discrete work m F . (x1 - x0) of the converged sub-step
    "work": """
if srp_c[i] != 0.0:
    mx = x[0, i] + 0.5 * dx[0, i] - srp_p[5]
    my = x[1, i] + 0.5 * dx[1, i] - srp_p[6]
    mz = x[2, i] + 0.5 * dx[2, i] - srp_p[7]
    nu = shadow_conical(mx, my, mz, srp_sx, srp_sy, srp_sz, srp_p[2], srp_p[3]) if srp_p[4] == 2.0 else srp_nu[i]
    gx, gy, gz = srp_cannonball(mx, my, mz, srp_sx, srp_sy, srp_sz, srp_p[0], srp_p[1], srp_c[i], nu)
    y = m[i] * (gx * dx[0, i] + gy * dx[1, i] + gz * dx[2, i]) + cwork[WORK_SLOT, i]  # Kahan, as x and v
    t = work[WORK_SLOT, i] + y
    cwork[WORK_SLOT, i] = y - (t - work[WORK_SLOT, i])
    work[WORK_SLOT, i] = t
""",
}


class RadiationPressure(EffectTerm):
    """Radiation pressure as an effect term: ``params["srp_p"]`` (10,) and ``params["srp_tab"]``
    (n, 6), the Sun's table sampled by :meth:`prepare` (layout: the module's docstring); the
    points' ``Cr A / m`` (``srp_c``) come from the point system.

    Attributes
    ----------
    step : float
        The Sun's sampling interval, s.
    shadow : str
        A key of :data:`SHADOWS`.
    """

    time_dependent = True
    needs_epoch = True

    def setup(self, shadow, pressure, occulting, sun_radius, step, center, ephemeris) -> None:
        """Set the constants (called by :func:`build`)."""
        self.shadow, self.step, self._ephemeris, self._span = shadow, float(step), ephemeris, None
        c = np.asarray(center, float)
        self.params["srp_p"] = np.array(
            [pressure, AU, occulting, sun_radius, SHADOWS[shadow], *c, self.step, 0.0], float
        )
        self.params["srp_tab"] = np.zeros((2, 6))

    def prepare(self, t0: float, t1: float, epoch) -> None:
        """Sample the Sun's path from before ``t0`` to after ``t1`` (s from the epoch).

        Raises
        ------
        InputError
            No epoch, or times the ephemeris cannot give.
        """
        if epoch is None:
            raise InputError(
                "integrator.epoch",
                f"{self.key} takes the Sun's position from an ephemeris: the run needs an epoch "
                '(e.g. epoch = "2026-01-01T00:00:00 TDB")',
            )
        k_first = math.floor(t0 / self.step) - 1
        k_last = max(math.ceil(t1 / self.step) + 1, k_first + 2)
        stamp = (float(epoch.tdb.jd1), float(epoch.tdb.jd2))
        if self._span is not None and self._span[0] <= k_first and self._span[1] >= k_last and self._span[2] == stamp:
            return
        self.params["srp_tab"] = sample_table("sun", k_first, k_last, self.step, epoch, self._ephemeris)
        self.params["srp_p"][9] = k_first
        self._span = (k_first, k_last, stamp)

    def potential(self, x, masses, active, t=None):
        return np.zeros(x.shape[0])  # no potential: its work is recorded instead


def build(table, field, key: str, bodies, strict: bool = False) -> RadiationPressure:
    """Radiation pressure from its table.

    Parameters
    ----------
    table : dict
        ``shadow``, ``ephemeris``, ``pressure``, ``occulting_radius``, ``sun_radius``,
        ``table_step`` (see :data:`KEYS`).
    field : CentralField or None
        The central body: it casts the shadow; the Sun's path is about it.
    key : str
        The table's name in errors.
    bodies : list of str or None
        Unused: it acts on every point with a ``radiation_coefficient`` and every rigid body's
        facets.
    strict : bool
        Require units on dimensional values.

    Returns
    -------
    RadiationPressure

    Raises
    ------
    InputError
        No field, a central body other than the Earth (the ephemeris is geocentric), an
        unknown shadow, a shadow without a radius, a bad pressure, radius, step or ephemeris.
    """
    if field is None:
        raise InputError(key, "radiation pressure takes the Sun about the central body: the scene needs a [field]")
    if field.body and field.body.lower() != "earth":
        raise InputError(key, f"the ephemeris gives the Sun about the Earth, but the central body is {field.body!r}")
    shadow = table.get("shadow", "conical")
    if not isinstance(shadow, str) or shadow not in SHADOWS:
        raise InputError(f"{key}.shadow", f"unknown shadow {shadow!r}; known: {', '.join(SHADOWS)}")
    pressure = P_AU
    if "pressure" in table:
        pressure = to_si(table["pressure"], "pressure", f"{key}.pressure", strict=strict, positive=True)
    occulting = field.radius
    if "occulting_radius" in table:
        occulting = to_si(table["occulting_radius"], "length", f"{key}.occulting_radius", strict=strict, positive=True)
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
    ephemeris = _ephemeris(table.get("ephemeris", "builtin"), f"{key}.ephemeris")
    term = RadiationPressure("srp", "srp", dict(table), {})
    term.key = key
    term.setup(shadow, pressure, occulting, sun_radius, step, field.center, ephemeris)
    return term
