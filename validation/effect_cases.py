"""The validation cases of the effects beyond the central field: zonal harmonics and mutual
gravity (``sim.add_effect("zonal", ...)``, ``sim.add_effect("mutual")``).

* ``j2-reboundx``: a LEO satellite (a = 7000 km, e = 0.01, i = 50 deg) under the Earth's J2,
  em at orders 2-8 and several steps against REBOUND's IAS15 with REBOUNDx's
  ``gravitational_harmonics`` (Tamayo et al. 2020); a second run adds J4 on both sides.
* ``j2-secular``: five satellites at a = 7000 km, their mean nodal regression and apsidal
  rotation against first-order secular theory (Kozai 1959; Vallado, *Fundamentals of
  Astrodynamics*, sec. 9.6)::

      dOmega/dt = -3/2 n J2 (R/p)^2 cos i,   domega/dt = 3/4 n J2 (R/p)^2 (5 cos^2 i - 1)

  with p = a (1 - e^2); one of them sun-synchronous, its inclination from that theory.
* ``mutual-two-body``: two bodies of 2e12 and 1e12 kg in free space against the analytic
  Kepler solution of their relative orbit (GM = G (m1 + m2)) and the uniform motion of
  their centre of mass.
* ``figure-eight``: the three-body figure-eight (Chenciner & Montgomery 2000, Ann. Math.
  152, 881; initial conditions of C. Simo) of 1e12 kg bodies 100 m across, against IAS15.

Every case runs em at orders 2, 4, 6, 8 (two steps per order for the order of convergence);
steps are given per ``period`` (the Kepler period of the orbit, the figure-eight's period).
The rigid-rigid binary (two tumbling ellipsoids of mass points against scipy's DOP853) is the
case ``rigid-binary`` of :mod:`.rigid_binary_case` and :mod:`.rigid_binary`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from emorbit import orbits
from emorbit.effects.mutual import G
from emorbit.effects.zonal import zonal_model
from emorbit.field import CentralField

from .secular import sun_synchronous_inclination

__all__ = ["EffectCase", "EFFECT_CASES", "effect_cases", "J2", "J4", "R_EARTH"]

#: EGM2008's J2 and J4 and its reference radius (emorbit's zonal model "earth")
J2 = float(zonal_model("earth")["jn"][0])
J4 = float(zonal_model("earth")["jn"][2])
R_EARTH = float(zonal_model("earth")["radius"])
#: the effect cases, in the order they run
EFFECT_CASES = ("j2-reboundx", "j2-secular", "mutual-two-body", "figure-eight")


@dataclass
class EffectCase:
    """One validation case of the effects: point masses, a field or free space, effects.

    Attributes
    ----------
    name, title, description : str
        How the report names and describes it.
    kind : str
        ``"zonal"`` (point masses around the Earth with zonal harmonics) or ``"mutual"``
        (bodies attracting each other in free space).
    bodies : list of tuple
        (name, mass in kg, position (3,) in m, velocity (3,) in m/s).
    period : float
        The time unit of steps and records, s.
    length : float
        The length position errors are given in, m (a, or the figure-eight's size).
    records : int
        Records per period (every run and referee shares these times).
    orbits : dict
        {"quick": n, "full": n}: periods run.
    steps : dict
        {order: (steps per period, ...)}: the em runs; each order's first two steps give its
        observed order, the ``main`` step its accuracy.
    main : dict
        {order: steps per period} of the run whose position is checked against the referee.
    zonal : dict or None
        The keys of ``sim.add_effect("zonal", ...)`` (zonal cases).
    harmonics : dict or None
        REBOUNDx's particle parameters of the central body: ``J2``, ``J4``, ``R_eq``.
    gm : float
        GM of the field, m^3/s^2 (0 in free space).
    params : dict
        Human-readable parameters for the report.
    extra : dict
        What a case needs beyond these (the sun-synchronous satellite, the analytic orbit).
    """

    name: str
    title: str
    description: str
    kind: str
    bodies: list
    period: float
    length: float
    records: int
    orbits: dict
    steps: dict
    main: dict
    zonal: dict | None = None
    harmonics: dict | None = None
    gm: float = 0.0
    params: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        """The bodies' names."""
        return [b[0] for b in self.bodies]

    @property
    def masses(self) -> np.ndarray:
        """(n,) masses, kg."""
        return np.array([b[1] for b in self.bodies], float)

    @property
    def x0(self) -> np.ndarray:
        """(n, 3) initial positions, m."""
        return np.array([b[2] for b in self.bodies], float)

    @property
    def v0(self) -> np.ndarray:
        """(n, 3) initial velocities, m/s."""
        return np.array([b[3] for b in self.bodies], float)


def _earth_gm() -> float:
    return float(CentralField(body="earth").gm)


def _j2_reboundx() -> EffectCase:
    gm = _earth_gm()
    a, e, inc, raan, argp, nu = 7000e3, 0.01, 50.0, 30.0, 40.0, 10.0
    x0, v0 = orbits.state_from_elements((a, e, *np.radians([inc, raan, argp, nu])), gm)
    T = float(orbits.kepler_period(a, gm))
    return EffectCase(
        name="j2-reboundx",
        title="J2 against REBOUNDx's gravitational_harmonics with IAS15",
        description=(
            f"A satellite at a = 7000 km, e = {e}, i = {inc} deg (Omega = {raan} deg, omega = {argp} deg, "
            f"starting at true anomaly {nu} deg) in the Earth's field (astropy's GM_earth) with EGM2008's J2 "
            '(`add_effect("zonal", model="earth", degree=2)`), against REBOUND IAS15 (default epsilon 1e-9) with '
            "REBOUNDx's `gravitational_harmonics` (J2 and R_eq on the central body, Omega along z). em runs at "
            "orders 2 (three steps), 4, 6 and 8 (two steps each); a second em order 8 run adds J4 "
            "(`j = [J2, 0, J4]`), against REBOUNDx with J2 and J4. Energies include the zonal potential "
            "V = +(GM m / r) J2 (R/r)^2 P2(z/r), computed here for REBOUND. One orbit is "
            f"{T:.6g} s; 15 orbits are {15 * T / 86400:.3f} days."
        ),
        kind="zonal",
        bodies=[("satellite", 1.0, x0, v0)],
        period=T,
        length=a,
        records=10,
        orbits={"quick": 15, "full": 150},
        steps={2: (200, 400, 100), 4: (50, 100), 6: (30, 60), 8: (20, 40, 100)},
        main={2: 100, 4: 100, 6: 60, 8: 100},
        zonal={"model": "earth", "degree": 2},
        harmonics={"J2": J2, "R_eq": R_EARTH},
        gm=gm,
        params={
            "GM": f"{gm:.10g} m3 / s2 (astropy GM_earth)",
            "J2": f"{J2:.12g} (EGM2008, tide-free)",
            "J4 (second run)": f"{J4:.8g}",
            "R": f"{R_EARTH} m",
            "a": "7000 km",
            "e": f"{e}",
            "i": f"{inc} deg",
            "Omega, omega, nu0": f"{raan}, {argp}, {nu} deg",
        },
        extra={"j4": {"j": [J2, 0.0, J4], "radius": R_EARTH}, "harmonics_j4": {"J2": J2, "J4": J4, "R_eq": R_EARTH}},
    )


#: the secular case's satellites: (name, e, i in deg, omega, nu0 in deg); the last one is
#: sun-synchronous, its inclination from first-order theory, and starts at argument of
#: latitude 45 deg, where the short-period terms of a and i (proportional to cos 2u on a
#: near-circular orbit) vanish, so that its initial osculating a and i are mean elements
_SECULAR = [
    ("e0.01-i50", 0.01, 50.0, 40.0, 10.0),
    ("e0.05-i30", 0.05, 30.0, 90.0, 10.0),
    ("e0.04-i70", 0.04, 70.0, 140.0, 10.0),
    ("e0.02-i120", 0.02, 120.0, 190.0, 10.0),
]
SSO_E = 0.001
SSO_NAME = "sso"


def _j2_secular() -> EffectCase:
    gm = _earth_gm()
    a = 7000e3
    i_sso = sun_synchronous_inclination(a, SSO_E, gm, J2, R_EARTH)
    sats = [*_SECULAR, (SSO_NAME, SSO_E, math.degrees(i_sso), 0.0, 45.0)]
    bodies = []
    for k, (name, e, inc, argp, nu) in enumerate(sats):
        x0, v0 = orbits.state_from_elements((a, e, *np.radians([inc, 20.0 + 30.0 * k, argp, nu])), gm)
        bodies.append((name, 1.0, x0, v0))
    T = float(orbits.kepler_period(a, gm))
    return EffectCase(
        name="j2-secular",
        title="J2 against first-order secular theory, with a sun-synchronous orbit",
        description=(
            "Five satellites at a = 7000 km under EGM2008's J2 in one simulation: e = 0.01 at i = 50 deg, "
            "0.05 at 30 deg, 0.04 at 70 deg, 0.02 at 120 deg (retrograde), and a near-circular (e = 0.001) "
            f"sun-synchronous orbit at i = {math.degrees(i_sso):.4f} deg, the inclination at which first-order "
            "theory gives dOmega/dt = 360 deg per 365.2422 days (0.98565 deg/day) for the initial osculating a "
            "and e; it starts at argument of latitude 45 deg, where the short-period terms of a and i vanish. "
            "The mean rates are the slopes of lines fitted to the per-orbit means of the osculating Omega "
            "and omega (`result.elements(name, si=True)`); theory uses the per-orbit means of a, e and i. "
            "em runs at orders 2, 4, 6, 8 (dt = T/100); order 8 also with J2/2, which shows that the "
            "difference from first-order theory is of second order in J2; REBOUND IAS15 with REBOUNDx's J2 "
            "gives the same rates independently. omega is not checked on the sun-synchronous orbit "
            "(e = 0.001 is below the short-period oscillation of e, about J2 (R/a)^2 = 9e-4)."
        ),
        kind="zonal",
        bodies=bodies,
        period=T,
        length=a,
        records=20,
        orbits={"quick": 30, "full": 150},
        steps={2: (100,), 4: (100,), 6: (100,), 8: (100,)},
        main={2: 100, 4: 100, 6: 100, 8: 100},
        zonal={"model": "earth", "degree": 2},
        harmonics={"J2": J2, "R_eq": R_EARTH},
        gm=gm,
        params={
            "GM": f"{gm:.10g} m3 / s2 (astropy GM_earth)",
            "J2": f"{J2:.12g} (EGM2008)",
            "R": f"{R_EARTH} m",
            "a": "7000 km (all)",
            "sun-synchronous i": f"{math.degrees(i_sso):.6f} deg (e = {SSO_E})",
        },
        extra={"half_j2": {"j": [J2 / 2], "radius": R_EARTH}, "sso": SSO_NAME, "sso_inclination": i_sso},
    )


def _two_body() -> EffectCase:
    m1, m2 = 2e12, 1e12
    gm = G * (m1 + m2)
    a, e, inc, raan, argp, nu = 100.0, 0.5, 30.0, 40.0, 60.0, 120.0
    r0, w0 = orbits.state_from_elements((a, e, *np.radians([inc, raan, argp, nu])), gm)
    X0, V0 = np.array([10.0, -20.0, 5.0]), np.array([0.01, -0.02, 0.005])
    f1, f2 = m2 / (m1 + m2), m1 / (m1 + m2)
    T = float(orbits.kepler_period(a, gm))
    return EffectCase(
        name="mutual-two-body",
        title="Mutual gravity: two bodies of comparable mass against the Kepler solution",
        description=(
            f"Two point masses of {m1:g} kg and {m2:g} kg in free space (`Simulation(None, ...)`, "
            '`add_effect("mutual")`, G from astropy/CODATA) on a relative orbit of a = 100 m, e = 0.5, '
            f"i = {inc} deg, starting at true anomaly {nu} deg (period {T:.6g} s), their centre of mass at "
            f"{X0.tolist()} m moving at {V0.tolist()} m/s. The reference is the analytic Kepler solution of the "
            "relative orbit with GM = G (m1 + m2) (`emorbit.orbits.propagate`) and the uniform motion of the "
            "centre of mass; REBOUND IAS15 integrates the same two bodies. em at dt = T/200 (orders 2-8), "
            "and at further steps per order for its observed order."
        ),
        kind="mutual",
        bodies=[("m1", m1, X0 + f1 * r0, V0 + f1 * w0), ("m2", m2, X0 - f2 * r0, V0 - f2 * w0)],
        period=T,
        length=a,
        records=50,
        orbits={"quick": 10, "full": 100},
        steps={2: (200, 400), 4: (100, 200), 6: (50, 100), 8: (50, 100, 200)},
        main={2: 200, 4: 200, 6: 100, 8: 200},
        params={
            "masses": f"{m1:g} kg, {m2:g} kg",
            "G": f"{G:.8g} m3 / (kg s2) (astropy)",
            "a, e, i": f"100 m, {e}, {inc} deg",
            "Omega, omega, nu0": f"{raan}, {argp}, {nu} deg",
            "centre of mass": f"{X0.tolist()} m, moving at {V0.tolist()} m/s",
            "period": f"{T:.10g} s",
        },
        extra={"gm": gm, "r0": r0, "w0": w0, "X0": X0, "V0": V0, "fractions": (f1, -f2)},
    )


#: the figure-eight in units G = M = L = 1 (Chenciner & Montgomery; C. Simo's digits)
EIGHT_X1 = (0.97000436, -0.24308753, 0.0)
EIGHT_V3 = (-0.93240737, -0.86473146, 0.0)
EIGHT_PERIOD = 6.32591398
EIGHT_L = 100.0  # m
EIGHT_M = 1e12  # kg


def _figure_eight() -> EffectCase:
    tau = math.sqrt(EIGHT_L**3 / (G * EIGHT_M))
    T = EIGHT_PERIOD * tau
    x1, v3 = np.array(EIGHT_X1), np.array(EIGHT_V3)
    states = (("a", x1, -v3 / 2), ("b", -x1, -v3 / 2), ("c", np.zeros(3), v3))
    bodies = [(n, EIGHT_M, x * EIGHT_L, v * EIGHT_L / tau) for n, x, v in states]
    return EffectCase(
        name="figure-eight",
        title="Mutual gravity: the three-body figure-eight against IAS15",
        description=(
            "Chenciner & Montgomery's figure-eight of three equal masses (C. Simo's initial conditions, "
            "x1 = -x2 = (0.97000436, -0.24308753), v3 = -2 v1 = -2 v2 = (-0.93240737, -0.86473146), period "
            "6.32591398, in G = M = L = 1) scaled to SI: M = 1e12 kg, L = 100 m, time unit "
            f"sqrt(L^3 / (G M)) = {tau:.6g} s, period {T:.6g} s (as tests/test_effects.py). em at orders 2-8 "
            "against REBOUND IAS15 on the same records; no analytic solution, so IAS15 is checked against "
            "itself at a 100 times tighter epsilon, and both return to the start after one period within "
            "the precision of the published digits."
        ),
        kind="mutual",
        bodies=bodies,
        period=T,
        length=EIGHT_L,
        records=50,
        orbits={"quick": 10, "full": 100},
        steps={2: (200, 400), 4: (100, 200), 6: (50, 100), 8: (50, 100, 200)},
        main={2: 200, 4: 200, 6: 100, 8: 200},
        params={
            "masses": f"3 x {EIGHT_M:g} kg",
            "L": f"{EIGHT_L} m",
            "time unit": f"{tau:.10g} s",
            "period": f"{T:.10g} s = {EIGHT_PERIOD} time units",
            "G": f"{G:.8g} m3 / (kg s2) (astropy)",
        },
        extra={"tau": tau},
    )


def effect_cases(mode: str) -> dict[str, EffectCase]:
    """The effect cases by name (the same in both modes; ``orbits`` holds the run lengths).

    Parameters
    ----------
    mode : str
        ``"quick"`` or ``"full"`` (unused: the cases carry both lengths).

    Returns
    -------
    dict
        {name: EffectCase} in :data:`EFFECT_CASES` order.
    """
    del mode
    built = (_j2_reboundx(), _j2_secular(), _two_body(), _figure_eight())
    return {c.name: c for c in built}
