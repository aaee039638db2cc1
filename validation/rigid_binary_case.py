"""The case ``rigid-binary``: two tumbling rigid ellipsoids of mass points under their mutual
gravity, their initial states, run lengths, steps and tolerances. The referee (scipy's DOP853
on the same mass points), the runs and the checks are :mod:`.rigid_binary`; the figure
:mod:`.rigid_binary_figures`.

Two homogeneous ellipsoids, 1e12 kg (150 x 100 x 80 m) and 5e11 kg (110 x 80 x 65 m), 24 mass
points each, on a relative Kepler orbit of a = 1000 m, e = 0.25 (GM = G (m1 + m2), the time unit
T its period), tumbling at body-frame angular velocities n (2, 1.5, 6) and n (1.5, -2, 5),
n = 2 pi / T, 23 and 27 deg off their axes of largest inertia.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from emorbit import orbits
from emorbit.bodies.shapes import SHAPES
from emorbit.effects.mutual import G

__all__ = [
    "RIGID_BINARY_CASES",
    "RIGID_BINARY_NOTE",
    "RTOL",
    "RTOL_LOOSE",
    "ATOL_FRACTION",
    "RigidBody",
    "RigidBinaryCase",
    "rigid_binary_cases",
]

#: the case's name (listed after the effect cases)
RIGID_BINARY_CASES = ("rigid-binary",)
#: DOP853's relative tolerance, and the looser one that bounds its own error
RTOL, RTOL_LOOSE = 1e-13, 1e-11
#: the absolute tolerance as a fraction of rtol times each component's scale: tiny, so that the
#: relative tolerance decides
ATOL_FRACTION = 1e-3
#: what the report says about the case
RIGID_BINARY_NOTE = (
    "The rigid binary (`rigid-binary`) runs two tumbling rigid ellipsoids of 24 mass points each under their "
    "mutual gravity, em at orders 2, 4, 6 and 8 against scipy's DOP853 (rtol 1e-13) on the same mass points. "
    "emorbit's rigid-body compositions of orders 6 and 8 converge at order 4; the case's order checks hold them to 4."
)


@dataclass
class RigidBody:
    """One ellipsoid: its mass points' parameters and its initial state (SI)."""

    name: str
    semi_axes: tuple
    mass: float
    position: np.ndarray
    velocity: np.ndarray
    attitude: np.ndarray  # unit quaternion (w, x, y, z), body to space
    angular_velocity: np.ndarray  # body frame, rad/s
    refinement: int = 1

    def points(self):
        """The mass points, built as emorbit builds them (``SHAPES["ellipsoid"]``)."""
        return SHAPES["ellipsoid"](self.semi_axes, mass=self.mass, refinement=self.refinement, key=self.name)


@dataclass
class RigidBinaryCase:
    """The case: two rigid bodies, the time unit, records, run lengths, steps and tolerances.

    ``period`` is the Kepler period of the centres' initial relative orbit (GM = G (m1 + m2));
    ``length`` its semi-major axis a. ``steps`` {order: (steps per period, steps per period)}
    give each order's observed order; ``main`` {order: steps} the run checked against DOP853
    with ``tolerance`` {mode: {order: (position in a, attitude in rad)}}.
    """

    name: str
    title: str
    description: str
    bodies: list
    period: float
    length: float
    records: int
    orbits: dict
    steps: dict
    main: dict
    tolerance: dict
    params: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        return [b.name for b in self.bodies]


def _quaternion(rotation_vector) -> np.ndarray:
    v = np.asarray(rotation_vector, float)
    angle = float(np.linalg.norm(v))
    return np.array([math.cos(angle / 2), *(math.sin(angle / 2) * v / angle)])


def _rigid_binary() -> RigidBinaryCase:
    m1, m2 = 1e12, 5e11
    gm = G * (m1 + m2)
    a, e, inc, raan, argp, nu = 1000.0, 0.25, 10.0, 20.0, 30.0, 30.0
    r0, w0 = orbits.state_from_elements((a, e, *np.radians([inc, raan, argp, nu])), gm)
    T = float(orbits.kepler_period(a, gm))
    n = 2 * math.pi / T
    X0, V0 = np.array([50.0, -30.0, 20.0]), np.array([0.01, -0.02, 0.005])
    f1, f2 = m2 / (m1 + m2), m1 / (m1 + m2)
    spins = ((2.0, 1.5, 6.0), (1.5, -2.0, 5.0))  # body frame, units of the mean motion n
    rotations = ((0.2, -0.1, 0.4), (0.3, -0.5, 0.8))  # initial attitudes, rotation vectors (rad)
    bodies = [
        RigidBody(
            "a", (150.0, 100.0, 80.0), m1, X0 + f1 * r0, V0 + f1 * w0, _quaternion(rotations[0]), n * np.array(spins[0])
        ),
        RigidBody(
            "b", (110.0, 80.0, 65.0), m2, X0 - f2 * r0, V0 - f2 * w0, _quaternion(rotations[1]), n * np.array(spins[1])
        ),
    ]
    tilt = [math.degrees(math.atan2(math.hypot(s[0], s[1]), s[2])) for s in spins]
    return RigidBinaryCase(
        name="rigid-binary",
        title="Rigid-rigid binary: two tumbling ellipsoids of mass points against scipy's DOP853",
        description=(
            f"Two homogeneous ellipsoids in free space, {m1:g} kg with semi-axes 150 x 100 x 80 m and {m2:g} kg with "
            '110 x 80 x 65 m, 24 mass points each (`add_rigid(..., "ellipsoid", refinement=1)`), attracting each '
            'other through every pair of mass points (`add_effect("mutual")`, G from astropy). Their centres start '
            f"on a relative Kepler orbit of a = {a:g} m, e = {e}, i = {inc} deg (GM = G (m1 + m2), period T = "
            f"{T:.6g} s, separation 750 to 1250 m), their centre of mass moving at {V0.tolist()} m/s. Both tumble: "
            f"body-frame angular velocities n ({', '.join(map(str, spins[0]))}) and n "
            f"({', '.join(map(str, spins[1]))}) (n = 2 pi / T), {tilt[0]:.0f} and {tilt[1]:.0f} deg off the axis of "
            "largest inertia, so the gravity-gradient torques between them couple the spins to the orbit. The "
            "referee integrates the same mass points as two rigid bodies (centre of mass, attitude quaternion, "
            "Euler's equations, all pair forces and torques) with scipy's DOP853 at rtol 1e-13, checked against "
            "itself at rtol 1e-11. em runs at orders 2, 4, 6, 8, each at two steps per period."
        ),
        bodies=bodies,
        period=T,
        length=a,
        records=25,
        orbits={"quick": 3, "full": 10},
        steps={2: (400, 800), 4: (200, 400), 6: (75, 150), 8: (50, 100)},
        main={2: 800, 4: 400, 6: 150, 8: 100},
        # about 3 times the errors measured at the main steps (quick: 1.1e-4, 3.5e-6, 4.7e-6, 4.7e-7 a and
        # 0.026, 8.5e-4, 3.6e-3, 2.3e-4 rad; full: 1.3e-3, 4.2e-5, 2.4e-4, 1.5e-5 a and 0.088, 2.9e-3,
        # 0.012, 7.2e-4 rad)
        tolerance={
            "quick": {2: (3e-4, 0.08), 4: (1e-5, 2.5e-3), 6: (1.5e-5, 0.01), 8: (1.5e-6, 7e-4)},
            "full": {2: (4e-3, 0.25), 4: (1.2e-4, 9e-3), 6: (7e-4, 0.035), 8: (4.5e-5, 2.2e-3)},
        },
        params={
            "masses": f"{m1:g} kg, {m2:g} kg",
            "semi-axes": "150 x 100 x 80 m, 110 x 80 x 65 m (24 mass points each)",
            "G": f"{G:.8g} m3 / (kg s2) (astropy)",
            "relative orbit a, e, i": f"{a:g} m, {e}, {inc} deg",
            "Omega, omega, nu0": f"{raan}, {argp}, {nu} deg",
            "period T": f"{T:.10g} s",
            "angular velocities (body frame)": f"n {spins[0]}, n {spins[1]}, n = {n:.6g} rad/s",
            "attitudes (rotation vectors)": f"{rotations[0]}, {rotations[1]} rad",
            "centre of mass": f"{X0.tolist()} m, moving at {V0.tolist()} m/s",
            "DOP853": f"rtol {RTOL:g} (and {RTOL_LOOSE:g}), atol {ATOL_FRACTION:g} rtol on the scales (a, a n, 1, n)",
        },
        extra={"gm": gm, "r0": r0, "w0": w0, "X0": X0, "V0": V0, "fractions": (f1, -f2), "n": n},
    )


def rigid_binary_cases(mode: str) -> dict[str, RigidBinaryCase]:
    """The rigid-binary case by name (both modes; ``orbits`` holds the run lengths)."""
    del mode
    case = _rigid_binary()
    return {case.name: case}
