"""Atmospheric drag on point masses (``[[effect]] kind = "drag"``).

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
round-off however large the step. Data layout of the parameters: ``drag_p = [c0, c1, c2,
w0, w1, w2, R]``, ``drag_t`` (3, nb) the band table's rows ``h0``, ``rho0``, ``H``, and
``drag_b`` (n,) each point's B (set by the point system). References: D. A. Vallado,
Fundamentals of Astrodynamics and Applications, 4th ed. (2013), section 8.6.2 and Table 8-4;
D. G. King-Hele, Theory of Satellite Orbits in an Atmosphere (Butterworths, 1964).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..keys import Key
from ..units import to_si, vector_to_si
from .atmosphere_tables import USSA1976, VALLADO_2013, exponential_table
from .base import EffectTerm

__all__ = ["NAME", "SUMMARY", "KEYS", "CONSERVES", "BODY_KINDS", "KERNEL", "build", "Drag", "EARTH_ROTATION"]

NAME = "drag"
SUMMARY = "atmospheric drag on point masses, in air that co-rotates with the central body"
#: the Earth's rotation rate, rad/s (IERS, the mean angular velocity)
EARTH_ROTATION = 7.292115e-5
#: the shipped atmospheres
ATMOSPHERES = {"exponential": None, "ussa1976": USSA1976, "vallado": VALLADO_2013}
_EXP = "exponential only"
KEYS = (
    Key("atmosphere", True, "string", "", '"exponential", "ussa1976", "vallado"',
        "the density model: one exponential, the U.S. Standard Atmosphere 1976, or Vallado's Table 8-4"),
    Key("density", False, "density (kg / m3)", "", f"> 0; {_EXP}, required there",
        "the density at reference_altitude"),
    Key("reference_altitude", False, "length (m)", "", f"{_EXP}, required there",
        "the altitude (above the field's radius) where the density is given"),
    Key("scale_height", False, "length (m)", "", f"> 0; {_EXP}, required there",
        "the scale height H: rho = density exp(-(a - reference_altitude) / H)"),
    Key("rotation_rate", False, "angular speed (rad / s)", '"7.292115e-5 rad / s" (the Earth)', ">= 0",
        "the atmosphere co-rotates with the central body at this rate about pole"),
    Key("pole", False, "3 numbers", "[0, 0, 1]", "a vector other than 0 (normalised)",
        "the axis of the atmosphere's rotation, in the scene's axes"),
)  # fmt: skip
POTENTIAL = "none: drag does work W = sum m F . (x1 - x0), recorded as invariants/work_drag"
DISCRETE_FORCE = "F = -1/2 rho(a(x_m)) B |v| v, x_m = (x0 + x1) / 2, v = (x1 - x0) / h - w x (x_m - c)"
JACOBIAN = "dF/dx1 = -1/2 B [rho (|v| (I / h - W / 2) + v u^T / |v|) + rho' |v| v d^T / (2 |d|)], d = x_m - c"
CONSERVES: tuple[str, ...] = ()
BODY_KINDS = ("point",)

KERNEL = {
    "imports": "from emorbit.kernels.effects.atmosphere import drag_force, drag_jacobian",
    "own": """
if drag_b[i] != 0.0:
    gx, gy, gz = drag_force(
        x0, y0, z0, x1, y1, z1, h, drag_p[0], drag_p[1], drag_p[2], drag_p[3], drag_p[4], drag_p[5],
        drag_b[i], drag_p[6], drag_t[0], drag_t[1], drag_t[2],
    )
    fx += gx
    fy += gy
    fz += gz
    drag_jacobian(
        x0, y0, z0, x1, y1, z1, h, drag_p[0], drag_p[1], drag_p[2], drag_p[3], drag_p[4], drag_p[5],
        drag_b[i], drag_p[6], drag_t[0], drag_t[1], drag_t[2], J,
    )
""",
    "pairs": "",
    # the discrete work m F . (x1 - x0) of the converged sub-step (x0 = x[:, i], dx its increment)
    "work": """
if drag_b[i] != 0.0:
    x0 = x[0, i]
    y0 = x[1, i]
    z0 = x[2, i]
    gx, gy, gz = drag_force(
        x0, y0, z0, x0 + dx[0, i], y0 + dx[1, i], z0 + dx[2, i], h, drag_p[0], drag_p[1], drag_p[2],
        drag_p[3], drag_p[4], drag_p[5], drag_b[i], drag_p[6], drag_t[0], drag_t[1], drag_t[2],
    )
    y = m[i] * (gx * dx[0, i] + gy * dx[1, i] + gz * dx[2, i]) + cwork[WORK_SLOT, i]  # Kahan, as x and v
    t = work[WORK_SLOT, i] + y
    cwork[WORK_SLOT, i] = y - (t - work[WORK_SLOT, i])
    work[WORK_SLOT, i] = t
""",
}


class Drag(EffectTerm):
    """Drag as an effect term: ``params["drag_p"] = [c0, c1, c2, w0, w1, w2, R]``,
    ``params["drag_t"]`` (3, nb) the band table; the points' B (``drag_b``) come from the
    point system."""

    def potential(self, x, masses, active):
        return np.zeros(x.shape[0])  # no potential: its work is recorded instead


def _table(table, key: str, strict: bool):
    """The band table (3, nb) of the ``atmosphere`` key and its keys."""
    name = table.get("atmosphere")
    if not isinstance(name, str) or name not in ATMOSPHERES:
        raise InputError(f"{key}.atmosphere", f"unknown atmosphere {name!r}; known: {', '.join(ATMOSPHERES)}")
    own = ("density", "reference_altitude", "scale_height")
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
        Unused: drag acts on every point mass, by its ``ballistic_coefficient``.
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
    rate = EARTH_ROTATION
    if "rotation_rate" in table:
        rate = to_si(table["rotation_rate"], "angular_speed", f"{key}.rotation_rate", strict=strict, nonnegative=True)
    pole = np.asarray(vector_to_si(table.get("pole", [0.0, 0.0, 1.0]), "dimensionless", f"{key}.pole"), float)
    norm = float(np.linalg.norm(pole))
    if not norm > 0.0:
        raise InputError(f"{key}.pole", f"a vector other than 0 expected, got {table.get('pole')!r}")
    params = {
        "drag_p": np.array([*field.center, *(rate * pole / norm), field.radius], float),
        "drag_t": bands,
    }
    return Drag("drag", "drag", dict(table), params)
