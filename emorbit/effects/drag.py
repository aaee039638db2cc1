"""Atmospheric drag on point masses and on rigid bodies' facets (``[[effect]] kind = "drag"``).

The air co-rotates with the central body (rotation vector ``w = rotation_rate p`` about its
centre c) and its density is a band model of the altitude above a sphere of the field's
radius (:mod:`emorbit.kernels.effects.atmosphere`): a single exponential (the one-band
table, :func:`~emorbit.effects.atmosphere_tables.exponential_table`), the U.S. Standard
Atmosphere 1976 or Vallado's Table 8-4 (:mod:`emorbit.effects.atmosphere_tables`). Over a
step x0 -> x1 of length h the force per unit mass is evaluated at the midpoint, with the
point's ballistic coefficient ``B = Cd A / m`` (m^2/kg; the body key
``ballistic_coefficient``)::

    x_m = (x0 + x1) / 2,   v = (x1 - x0) / h - w x (x_m - c),   F = -1/2 rho(|x_m - c| - R) B |v| v

Drag has no potential: it does work. In an em step ``(x1 - x0) / h`` is the mean velocity,
so the kinetic energy changes by exactly the conservative potentials' drop plus the discrete
work ``m F . (x1 - x0)``. The step adds that work of every point after each sub-step, with
Kahan compensation, into the state arrays ``work`` and ``cwork`` (J; checkpointed, so a
resumed run continues the sum); the run records the work since its start as
``invariants/work_<label>`` and ``invariants/energy_balance = E - E0 - W``, which stays at
round-off however large the step. A rigid body takes the flat facets of its surface
(:mod:`emorbit.bodies.facets`), an elastic body the triangles of its tetrahedra's surface:
each facet of area A facing the flow gets ``-1/2 rho Cd A max(0, n . v / |v|) |v| v`` at its
midpoint position and normal, with its own velocity relative to the air
(:func:`emorbit.kernels.effects.drag.drag_facet`), which gives a torque;
its work ``F . (x_f1 - x_f0)`` is summed the same way. Data layout of the parameters:
:mod:`emorbit.kernels.effects.drag`; each point's B is its coefficient in the set. References: D. A. Vallado,
Fundamentals of Astrodynamics and Applications, 4th ed. (2013), section 8.6.2 and Table 8-4;
D. G. King-Hele, Theory of Satellite Orbits in an Atmosphere (Butterworths, 1964).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..keys import Key
from ..units import to_si, vector_to_si
from .atmosphere_tables import USSA1976, VALLADO_2013, exponential_table
from .base import AT_POINTS, ON_SURFACES, BodyKey, Effect, Pieces, epoch_needed

__all__ = ["Drag", "EARTH_ROTATION", "ATMOSPHERES"]

#: the Earth's rotation rate, rad/s (IERS, the mean angular velocity)
EARTH_ROTATION = 7.292115e-5
#: bounds of an exponential atmosphere's keys (kg/m3, m), beyond which no atmosphere lies (and
#: the density's exponent or its product with a speed squared would leave float64's range)
MAX_DENSITY, MAX_ALTITUDE, MIN_SCALE_HEIGHT = 1e3, 1e9, 1.0
#: bounds of NRLMSIS's space weather: F10.7 in sfu (observed below 500), Ap (its scale ends at 400)
MAX_F107, MAX_AP = 1000.0, 400.0
#: the shipped atmospheres (nrlmsis: through the optional package pymsis)
ATMOSPHERES = {"exponential": None, "ussa1976": USSA1976, "vallado": VALLADO_2013, "nrlmsis": None}
#: the keys of the NRLMSIS atmosphere
MSIS_KEYS = ("f107", "f107a", "ap", "msis_version")
#: the sampling interval of the Sun's path for NRLMSIS's local time, s
SUN_STEP = 6 * 3600.0
_EXP = "exponential only"
_KEYS = (
    Key("atmosphere", True, "string", "", '"exponential", "ussa1976", "vallado", "nrlmsis"',
        "the density model: one exponential, the U.S. Standard Atmosphere 1976, Vallado's Table 8-4, or "
        "NRLMSIS 2.1 (the msis extra) at the run's epoch"),
    Key("density", False, "density (kg / m3)", "", f"> 0, at most 1000; {_EXP}, required there",
        "the density at reference_altitude"),
    Key("reference_altitude", False, "length (m)", "", f"-1e9 to 1e9; {_EXP}, required there",
        "the altitude (above the field's radius) where the density is given"),
    Key("scale_height", False, "length (m)", "", f"1 to 1e9; {_EXP}, required there",
        "the scale height H: rho = density exp(-(a - reference_altitude) / H)"),
    Key("f107", False, "number (sfu)", "", "0 to 1000; nrlmsis only, required there",
        "the previous day's solar radio flux F10.7"),
    Key("f107a", False, "number (sfu)", "", "0 to 1000; nrlmsis only, required there", "F10.7's 81-day mean"),
    Key("ap", False, "number", "", "0 to 400; nrlmsis only, required there", "the daily geomagnetic index Ap"),
    Key("msis_version", False, "number", "2.1", "0 (NRLMSISE-00), 2.0, 2.1; nrlmsis only", "the NRLMSIS version"),
    Key("rotation_rate", False, "angular speed (rad / s)",
        "the named central body's (emorbit.field.body_constants), else the Earth's 7.292115e-5 rad / s", ">= 0",
        "the atmosphere co-rotates with the central body at this rate about pole"),
    Key("pole", False, "3 numbers", "[0, 0, 1]", "a vector other than 0 (normalised)",
        "the axis of the atmosphere's rotation, in the scene's axes"),
)  # fmt: skip

#: the sizes of the placeholder grid and Sun table of a band atmosphere
_NO_GRID = (2, 2, 2)


class Drag(Effect):
    """Drag as an effect: ``p`` and ``tab`` as :mod:`emorbit.kernels.effects.drag`.

    Attributes
    ----------
    msis : dict or None
        NRLMSIS's space weather and version (``f107``, ``f107a``, ``ap``, ``version``), or
        None for a band table.
    """

    NAME = "drag"
    SUMMARY = "atmospheric drag on point masses and on rigid and elastic bodies' surfaces, in co-rotating air"
    KEYS = _KEYS
    BODY_KEYS = (
        BodyKey(
            Key("ballistic_coefficient", False, "area per mass (m2 / kg)", "required under drag", ">= 0",
                "Cd A / m: how strongly drag acts on the point (0: not at all)"),
            ("point",), "area_per_mass", "m2 / kg",
        ),
    )  # fmt: skip
    ACTS = {"point": AT_POINTS, "rigid": ON_SURFACES, "elastic": ON_SURFACES}
    CONSERVES: tuple[str, ...] = ()
    NEEDS_FIELD = True
    EXPLICIT = False
    PIECES = Pieces("emorbit.kernels.effects.drag", force="drag_piece", prepare="drag_prepare", facet="drag_facet")
    POTENTIAL = "none: drag does work W = sum m F . (x1 - x0), recorded as invariants/work_drag"
    DISCRETE_FORCE = "F = -1/2 rho(a(x_m)) B |v| v, x_m = (x0 + x1) / 2, v = (x1 - x0) / h - w x (x_m - c)"
    JACOBIAN_LEFT_OUT = 0.0
    JACOBIAN = (
        "dF/dx1 = -1/2 B [rho (|v| (I / h - W / 2) + v u^T / |v|) + |v| v (grad rho)^T / 2] at x_m: "
        "grad rho = rho' d / |d|, d = x_m - c, for a band table; for NRLMSIS also the grid's horizontal slopes"
    )

    msis = None

    @property
    def time_dependent(self) -> bool:
        """NRLMSIS's grid follows the Sun, and is sampled at the run's epoch."""
        return self.msis is not None

    @property
    def needs_epoch(self) -> bool:
        """NRLMSIS needs the date, and the Sun's position from the ephemeris."""
        return self.msis is not None

    def scratch_size(self, n_points: int) -> int:
        return 3  # the Sun at the sub-step's middle time

    def _pack(self, bands, gp, grid, sun) -> None:
        """Lay out ``tab`` and the sizes in ``p``."""
        self.p[13:18] = [bands.shape[1], *grid.shape, sun.shape[0]]
        self.tab = np.ascontiguousarray(np.concatenate([bands.ravel(), gp.ravel(), grid.ravel(), sun.ravel()]))
        self._parts = (bands, gp, grid, sun)

    def prepare(self, t0: float, t1: float, epoch) -> None:
        """NRLMSIS only: sample its grid at the epoch (once per epoch) and the Sun's path over
        ``t0`` to ``t1`` (s from the epoch), 6-hourly.

        Raises
        ------
        InputError
            No epoch, or pymsis not installed.
        """
        if self.msis is None:
            return
        from .atmosphere_msis import msis_grid
        from .ephemeris import sample_table

        if epoch is None:
            raise epoch_needed(f"{self.key} (NRLMSIS) needs the date and the Sun's position")
        bands, gp, grid, sun = self._parts
        stamp = (float(epoch.tdb.jd1), float(epoch.tdb.jd2))
        if self._grid_epoch != stamp:
            m = self.msis
            grid, gp = msis_grid(epoch, m["f107"], m["f107a"], m["ap"], self.p[6], version=m["version"])
            self._grid_epoch, self._span = stamp, None
        step = self.p[8]
        k_first = math.floor(t0 / step) - 1
        k_last = max(math.ceil(t1 / step) + 1, k_first + 2)
        if self._span is None or not (self._span[0] <= k_first and self._span[1] >= k_last):
            sun = sample_table("sun", k_first, k_last, step, epoch, key=self.key)  # the Sun every 6 h
            self.p[9] = k_first
            self._span = (k_first, k_last)
        self._pack(bands, gp, grid, sun)

    @classmethod
    def from_table(cls, table, context) -> Drag:
        """Drag from ``atmosphere`` and its keys; ``rotation_rate``, ``pole``.

        Raises
        ------
        InputError
            A field without a radius, an unknown atmosphere, a missing or bad density,
            reference altitude or scale height, a negative rotation rate, a pole of length 0.
        """
        key, field, strict = context.key, context.field, context.strict
        if not field.radius > 0.0:
            raise InputError(key, "drag measures altitudes above the central body: the [field] needs a radius (> 0)")
        bands = _table(table, key, strict)
        rate = EARTH_ROTATION if field.rate is None else field.rate
        if "rotation_rate" in table:
            rate = to_si(
                table["rotation_rate"], "angular_speed", f"{key}.rotation_rate", strict=strict, nonnegative=True
            )
        pole = np.asarray(vector_to_si(table.get("pole", [0.0, 0.0, 1.0]), "dimensionless", f"{key}.pole"), float)
        norm = float(np.linalg.norm(pole))
        if not norm > 0.0:
            raise InputError(f"{key}.pole", f"a vector other than 0 expected, got {table.get('pole')!r}")
        msis = _msis(table, key) if table.get("atmosphere") == "nrlmsis" else None
        p = [*field.center, *(rate * pole / norm), field.radius, 0.0 if msis is None else 1.0, SUN_STEP, 0.0]
        effect = cls(table, p + list(pole / norm) + [0.0] * 5)
        effect.msis = msis
        effect._span = None
        effect._grid_epoch = None  # the epoch NRLMSIS's grid was sampled at
        effect._pack(bands, np.ones(5), np.zeros(_NO_GRID), np.zeros((2, 6)))
        return effect


def _msis(table, key: str) -> dict:
    """NRLMSIS's keys: the space weather and the version."""
    from .atmosphere_msis import MSIS_VERSIONS

    out = {}
    for k in ("f107", "f107a", "ap"):
        value = table.get(k)
        if value is None:
            raise InputError(f"{key}.{k}", "atmosphere 'nrlmsis' needs f107, f107a and ap (no download at run time)")
        top = MAX_AP if k == "ap" else MAX_F107
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= top:
            raise InputError(f"{key}.{k}", f"a number in [0, {top:g}] expected, got {value!r}")
        out[k] = float(value)
    version = table.get("msis_version", 2.1)
    if isinstance(version, bool) or version not in MSIS_VERSIONS:
        raise InputError(
            f"{key}.msis_version", f"one of {', '.join(map(str, MSIS_VERSIONS))} expected, got {version!r}"
        )
    out["version"] = version
    try:
        import pymsis  # noqa: F401 (checked here, before anything runs)
    except ImportError:
        raise InputError(
            f"{key}.atmosphere", "'nrlmsis' needs the optional package pymsis: pip install 'emorbit[msis]'"
        ) from None
    return out


def _table(table, key: str, strict: bool):
    """The band table (3, nb) of the ``atmosphere`` key and its keys (a placeholder for NRLMSIS)."""
    name = table.get("atmosphere")
    if not isinstance(name, str) or name not in ATMOSPHERES:
        raise InputError(f"{key}.atmosphere", f"unknown atmosphere {name!r}; known: {', '.join(ATMOSPHERES)}")
    for k in MSIS_KEYS:
        if k in table and name != "nrlmsis":
            raise InputError(f"{key}.{k}", f"belongs to atmosphere 'nrlmsis', not {name!r}")
    own = ("density", "reference_altitude", "scale_height")
    if name == "nrlmsis":
        for k in own:
            if k in table:
                raise InputError(f"{key}.{k}", "belongs to atmosphere 'exponential', not 'nrlmsis'")
        return np.zeros((3, 1))
    if name != "exponential":
        for k in own:
            if k in table:
                raise InputError(f"{key}.{k}", f"belongs to atmosphere 'exponential', not {name!r}")
        t = ATMOSPHERES[name]
    else:
        for k in own:
            if k not in table:
                raise InputError(f"{key}.{k}", "atmosphere 'exponential' needs density, reference_altitude and "
                                 "scale_height")  # fmt: skip
        rho0 = to_si(table["density"], "density", f"{key}.density", strict=strict, positive=True)
        h0 = to_si(table["reference_altitude"], "length", f"{key}.reference_altitude", strict=strict)
        H = to_si(table["scale_height"], "length", f"{key}.scale_height", strict=strict, positive=True)
        for name, value, lo, hi, unit in (
            ("density", rho0, 0.0, MAX_DENSITY, "kg/m3"),
            ("reference_altitude", h0, -MAX_ALTITUDE, MAX_ALTITUDE, "m"),
            ("scale_height", H, MIN_SCALE_HEIGHT, MAX_ALTITUDE, "m"),
        ):
            if not lo <= value <= hi:
                raise InputError(
                    f"{key}.{name}", f"{value!r} {unit} is no atmosphere's: give a value in [{lo:g}, {hi:g}] {unit}"
                )
        t = exponential_table(rho0, h0, H)
    return np.ascontiguousarray(np.vstack([t.h0, t.rho0, t.H]), dtype=float)
