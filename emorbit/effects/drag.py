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
work ``m F . (x1 - x0)``. The step compiled for a scene with drag
(:mod:`emorbit.effects.compose`) adds that work of every point after each sub-step, with
Kahan compensation, into the state arrays ``work`` and ``cwork`` ((1, n), J; checkpointed,
so a resumed run continues the sum); the run records the work since its start as
``invariants/work_<label>`` and ``invariants/energy_balance = E - E0 - W``, which stays at
round-off however large the step. A rigid body takes the flat facets of its surface
(:mod:`emorbit.bodies.facets`): each facet of area A facing the flow gets
``-1/2 rho Cd A max(0, n . v / |v|) |v| v`` at its midpoint position and normal, with its own
velocity relative to the air (:mod:`emorbit.kernels.rigid_effects`), which gives a torque;
its work ``F . (x_f1 - x_f0)`` is summed the same way. Data layout of the parameters: ``drag_p = [c0, c1, c2,
w0, w1, w2, R]``, ``drag_t`` (3, nb) the band table's rows ``h0``, ``rho0``, ``H``, and
``drag_b`` (n,) each point's B (set by the point system). References: D. A. Vallado,
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
from .base import EffectTerm

__all__ = ["NAME", "SUMMARY", "KEYS", "CONSERVES", "BODY_KINDS", "KERNEL", "build", "Drag", "EARTH_ROTATION"]

NAME = "drag"
SUMMARY = "atmospheric drag on point masses and rigid bodies' facets, in air that co-rotates with the central body"
#: the Earth's rotation rate, rad/s (IERS, the mean angular velocity)
EARTH_ROTATION = 7.292115e-5
#: the shipped atmospheres (nrlmsis: through the optional package pymsis)
ATMOSPHERES = {"exponential": None, "ussa1976": USSA1976, "vallado": VALLADO_2013, "nrlmsis": None}
#: the keys of the NRLMSIS atmosphere
MSIS_KEYS = ("f107", "f107a", "ap", "msis_version")
#: the sampling interval of the Sun's path for NRLMSIS's local time, s
SUN_STEP = 6 * 3600.0
_EXP = "exponential only"
KEYS = (
    Key("atmosphere", True, "string", "", '"exponential", "ussa1976", "vallado", "nrlmsis"',
        "the density model: one exponential, the U.S. Standard Atmosphere 1976, Vallado's Table 8-4, or "
        "NRLMSIS 2.1 (the msis extra) at the run's epoch"),
    Key("density", False, "density (kg / m3)", "", f"> 0; {_EXP}, required there",
        "the density at reference_altitude"),
    Key("reference_altitude", False, "length (m)", "", f"{_EXP}, required there",
        "the altitude (above the field's radius) where the density is given"),
    Key("scale_height", False, "length (m)", "", f"> 0; {_EXP}, required there",
        "the scale height H: rho = density exp(-(a - reference_altitude) / H)"),
    Key("f107", False, "number (sfu)", "", ">= 0; nrlmsis only, required there",
        "the previous day's solar radio flux F10.7"),
    Key("f107a", False, "number (sfu)", "", ">= 0; nrlmsis only, required there", "F10.7's 81-day mean"),
    Key("ap", False, "number", "", ">= 0; nrlmsis only, required there", "the daily geomagnetic index Ap"),
    Key("msis_version", False, "number", "2.1", "0 (NRLMSISE-00), 2.0, 2.1; nrlmsis only", "the NRLMSIS version"),
    Key("rotation_rate", False, "angular speed (rad / s)",
        "the named central body's (emorbit.field.ROTATION_RATES), else the Earth's 7.292115e-5 rad / s", ">= 0",
        "the atmosphere co-rotates with the central body at this rate about pole"),
    Key("pole", False, "3 numbers", "[0, 0, 1]", "a vector other than 0 (normalised)",
        "the axis of the atmosphere's rotation, in the scene's axes"),
)  # fmt: skip
POTENTIAL = "none: drag does work W = sum m F . (x1 - x0), recorded as invariants/work_drag"
DISCRETE_FORCE = "F = -1/2 rho(a(x_m)) B |v| v, x_m = (x0 + x1) / 2, v = (x1 - x0) / h - w x (x_m - c)"
JACOBIAN = "dF/dx1 = -1/2 B [rho (|v| (I / h - W / 2) + v u^T / |v|) + rho' |v| v d^T / (2 |d|)], d = x_m - c"
CONSERVES: tuple[str, ...] = ()
BODY_KINDS = ("point", "rigid")
HAS_POTENTIAL = False

KERNEL = {
    "imports": (
        "from emorbit.kernels.effects.atmosphere import drag_force, drag_force_rho, drag_jacobian, "
        "drag_jacobian_rho\nfrom emorbit.kernels.effects.atmosphere_grid import grid_density\n"
        "from emorbit.kernels.effects.third_body import table_position"
    ),
    # a grid atmosphere (NRLMSIS) follows the Sun: its position at the sub-step's middle time
    "substep": """
drag_s0 = drag_s1 = drag_s2 = 0.0
if drag_p[7] != 0.0:
    drag_s0, drag_s1, drag_s2 = table_position(tm, drag_p[8], drag_p[9], drag_s)
""",
    "own": """
if drag_b[i] != 0.0:
    if drag_p[7] == 0.0:
        gx, gy, gz = drag_force(
            x0, y0, z0, x1, y1, z1, h, drag_p[0], drag_p[1], drag_p[2], drag_p[3], drag_p[4], drag_p[5],
            drag_b[i], drag_p[6], drag_t[0], drag_t[1], drag_t[2],
        )
        drag_jacobian(
            x0, y0, z0, x1, y1, z1, h, drag_p[0], drag_p[1], drag_p[2], drag_p[3], drag_p[4], drag_p[5],
            drag_b[i], drag_p[6], drag_t[0], drag_t[1], drag_t[2], J,
        )
    else:
        drag_rho, drag_drho = grid_density(
            0.5 * (x0 + x1) - drag_p[0], 0.5 * (y0 + y1) - drag_p[1], 0.5 * (z0 + z1) - drag_p[2], drag_s0,
            drag_s1, drag_s2, drag_p[10], drag_p[11], drag_p[12], drag_p[6], drag_gp, drag_g,
        )
        gx, gy, gz = drag_force_rho(
            x0, y0, z0, x1, y1, z1, h, drag_p[0], drag_p[1], drag_p[2], drag_p[3], drag_p[4], drag_p[5],
            drag_b[i], drag_rho,
        )
        drag_jacobian_rho(
            x0, y0, z0, x1, y1, z1, h, drag_p[0], drag_p[1], drag_p[2], drag_p[3], drag_p[4], drag_p[5],
            drag_b[i], drag_rho, drag_drho, J,
        )
    fx += gx
    fy += gy
    fz += gz
""",
    "pairs": "",
    # the discrete work m F . (x1 - x0) of the converged sub-step (x0 = x[:, i], dx its increment)
    "work": """
if drag_b[i] != 0.0:
    x0 = x[0, i]
    y0 = x[1, i]
    z0 = x[2, i]
    if drag_p[7] == 0.0:
        gx, gy, gz = drag_force(
            x0, y0, z0, x0 + dx[0, i], y0 + dx[1, i], z0 + dx[2, i], h, drag_p[0], drag_p[1], drag_p[2],
            drag_p[3], drag_p[4], drag_p[5], drag_b[i], drag_p[6], drag_t[0], drag_t[1], drag_t[2],
        )
    else:
        drag_rho, drag_drho = grid_density(
            x0 + 0.5 * dx[0, i] - drag_p[0], y0 + 0.5 * dx[1, i] - drag_p[1], z0 + 0.5 * dx[2, i] - drag_p[2],
            drag_s0, drag_s1, drag_s2, drag_p[10], drag_p[11], drag_p[12], drag_p[6], drag_gp, drag_g,
        )
        gx, gy, gz = drag_force_rho(
            x0, y0, z0, x0 + dx[0, i], y0 + dx[1, i], z0 + dx[2, i], h, drag_p[0], drag_p[1], drag_p[2],
            drag_p[3], drag_p[4], drag_p[5], drag_b[i], drag_rho,
        )
    y = m[i] * (gx * dx[0, i] + gy * dx[1, i] + gz * dx[2, i]) + cwork[WORK_SLOT, i]  # Kahan, as x and v
    t = work[WORK_SLOT, i] + y
    cwork[WORK_SLOT, i] = y - (t - work[WORK_SLOT, i])
    work[WORK_SLOT, i] = t
""",
}


class Drag(EffectTerm):
    """Drag as an effect term: ``params["drag_p"]`` (13,) ``[c0, c1, c2, w0, w1, w2, R, grid,
    step, k0, p0, p1, p2]`` (grid 1 for NRLMSIS, with the Sun's table's step and first sample),
    ``drag_t`` (3, nb) the band table, ``drag_g`` and ``drag_gp`` the NRLMSIS grid and its axes
    (:mod:`emorbit.kernels.effects.atmosphere_grid`), ``drag_s`` (n, 6) the Sun's table
    (placeholders where unused); the points' B (``drag_b``) come from the point system.

    Attributes
    ----------
    msis : dict or None
        NRLMSIS's space weather and version (``f107``, ``f107a``, ``ap``, ``version``), or
        None for a band table.
    """

    msis = None

    @property
    def time_dependent(self) -> bool:
        """NRLMSIS's grid follows the Sun, and is sampled at the run's epoch."""
        return self.msis is not None

    @property
    def needs_epoch(self) -> bool:
        """NRLMSIS needs the date, and the Sun's position from the ephemeris."""
        return self.msis is not None

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
            raise InputError(
                "integrator.epoch",
                f"{self.key} (NRLMSIS) needs the date and the Sun's position: the run needs an epoch "
                '(e.g. epoch = "2026-01-01T00:00:00 TDB")',
            )
        stamp = (float(epoch.tdb.jd1), float(epoch.tdb.jd2))
        if getattr(self, "_grid_epoch", None) != stamp:
            m = self.msis
            self.params["drag_g"], self.params["drag_gp"] = msis_grid(
                epoch, m["f107"], m["f107a"], m["ap"], self.params["drag_p"][6], version=m["version"]
            )
            self._grid_epoch, self._span = stamp, None
        step = self.params["drag_p"][8]
        k_first = math.floor(t0 / step) - 1
        k_last = max(math.ceil(t1 / step) + 1, k_first + 2)
        if self._span is None or not (self._span[0] <= k_first and self._span[1] >= k_last):
            self.params["drag_s"] = sample_table("sun", k_first, k_last, step, epoch)
            self.params["drag_p"][9] = k_first
            self._span = (k_first, k_last)

    def potential(self, x, masses, active, t=None):
        return np.zeros(x.shape[0])  # no potential: its work is recorded instead


def _msis(table, key: str) -> dict:
    """NRLMSIS's keys: the space weather and the version."""
    from .atmosphere_msis import MSIS_VERSIONS

    out = {}
    for k in ("f107", "f107a", "ap"):
        value = table.get(k)
        if value is None:
            raise InputError(f"{key}.{k}", "atmosphere 'nrlmsis' needs f107, f107a and ap (no download at run time)")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value < math.inf:
            raise InputError(f"{key}.{k}", f"a number >= 0 expected, got {value!r}")
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
        t = exponential_table(rho0, h0, H)
    return np.ascontiguousarray(np.vstack([t.h0, t.rho0, t.H]), dtype=float)


def build(table, field, key: str, bodies, strict: bool = False) -> Drag:
    """Drag from its table.

    Parameters
    ----------
    table : dict
        ``atmosphere``; ``density``, ``reference_altitude``, ``scale_height`` (exponential);
        ``rotation_rate``, ``pole`` (see :data:`KEYS`).
    field : CentralField or None
        The central body: its centre and radius (altitudes are above a sphere of it).
    key : str
        The table's name in errors.
    bodies : list of str or None
        Unused: drag acts on every point mass, by its ``ballistic_coefficient``, and on every
        rigid body's facets.
    strict : bool
        Require units on dimensional values.

    Returns
    -------
    Drag

    Raises
    ------
    InputError
        No field, a field without a radius, an unknown atmosphere, a missing or bad density,
        reference altitude or scale height, a negative rotation rate, a pole of length 0.
    """
    if field is None:
        raise InputError(key, "drag needs a central body with an atmosphere: the scene needs a [field]")
    if not field.radius > 0.0:
        raise InputError(key, "drag measures altitudes above the central body: the [field] needs a radius (> 0)")
    bands = _table(table, key, strict)
    from ..field import ROTATION_RATES

    rate = ROTATION_RATES.get((field.body or "").lower(), EARTH_ROTATION)
    if "rotation_rate" in table:
        rate = to_si(table["rotation_rate"], "angular_speed", f"{key}.rotation_rate", strict=strict, nonnegative=True)
    pole = np.asarray(vector_to_si(table.get("pole", [0.0, 0.0, 1.0]), "dimensionless", f"{key}.pole"), float)
    norm = float(np.linalg.norm(pole))
    if not norm > 0.0:
        raise InputError(f"{key}.pole", f"a vector other than 0 expected, got {table.get('pole')!r}")
    msis = _msis(table, key) if table.get("atmosphere") == "nrlmsis" else None
    params = {
        "drag_p": np.array(
            [*field.center, *(rate * pole / norm), field.radius, 0.0 if msis is None else 1.0, SUN_STEP, 0.0]
            + list(pole / norm),
            float,
        ),
        "drag_t": bands,
        "drag_g": np.zeros((2, 2, 2)),
        "drag_gp": np.ones(5),
        "drag_s": np.zeros((2, 6)),
    }
    term = Drag("drag", "drag", dict(table), params)
    term.msis = msis
    term._span = None
    return term
