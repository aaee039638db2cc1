"""The validation cases: initial states, field, step sizes and run lengths.

Every orbit case is a set of test particles around one fixed point mass (GM, centre). Steps are
chosen by one resolution rule, the paper's: its orbit (e = 2/3) runs at dt = T/100, which is
0.42 of its periapsis time-scale tau_p = r_p / v_p. Every other orbit gets the same number of
steps per tau_p (and at least 100 per orbit), so that errors are comparable across
eccentricities; orders 4-8 run at a quarter of that step (the paper's T/400).

The cases of the effects beyond the central field (zonal harmonics, mutual gravity) are
:mod:`.effect_cases`, the rigid-rigid binary :mod:`.rigid_binary_case`, and the cases of rigid
and elastic bodies against outside referees :mod:`.body_case`; :data:`CASES` lists them after
the orbit cases (the body cases last). The studies of
:data:`STUDY_CASES` (Brouwer's law with J2..J6, :mod:`.brouwer`) are cases of the suite as
well, listed before the effect cases; :func:`get_cases` gives each as a :class:`Study`. The
perturbation cases (drag, radiation pressure, the Moon and the Sun against IAS15,
:mod:`.perturbation_cases`) come between the studies and the effect cases.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import astropy.constants as const
import astropy.units as u
import numpy as np

from emorbit import orbits

from .body_case import BodyCase, body_case_names, body_cases
from .effect_cases import EFFECT_CASES, EffectCase, effect_cases
from .perturbation_cases import PERTURBATION_CASES, PerturbationCase, perturbation_cases
from .rigid_binary_case import RIGID_BINARY_CASES, RigidBinaryCase, rigid_binary_cases

__all__ = [
    "Case",
    "CASES",
    "STUDY_CASES",
    "STUDY_TITLES",
    "Study",
    "case_names",
    "get_cases",
    "periapsis_timescale",
    "steps_per_orbit",
]

#: the paper's orbit (Goettlicher & Schweizerhof): r_max = 10 m, GM = 3.9478 m^3/s^2
PAPER_GM = 3.9478
PAPER_X0 = (10.0, 0.0, 0.0)
PAPER_V0 = (0.0, 0.36276, 0.0)
PAPER_T = 46.4758  # s, as the paper quotes it (the rounded v0 gives 46.47620 s)
#: steps per orbit of the paper's em / midpoint runs and of the higher orders
BASE_STEPS = 100
HIGH_ORDER_REFINEMENT = 4


def periapsis_timescale(e: float) -> float:
    """The periapsis time-scale as a fraction of the period.

    tau_p = r_p / v_p, the time a body needs to cross its periapsis distance there:
    tau_p / T = (1 - e)^1.5 / (2 pi sqrt(1 + e)).

    Parameters
    ----------
    e : float
        Eccentricity, 0 <= e < 1.

    Returns
    -------
    float
        tau_p / T.
    """
    return (1.0 - e) ** 1.5 / (2.0 * math.pi * math.sqrt(1.0 + e))


def steps_per_orbit(e: float, records: int) -> int:
    """Steps per period at order 2, by the suite's resolution rule.

    The paper's T/100 scaled to the same steps per periapsis time-scale, at least 100,
    rounded up to a multiple of ``records``.

    Parameters
    ----------
    e : float
        Eccentricity.
    records : int
        Records per period.

    Returns
    -------
    int
        Steps per period.
    """
    n = max(float(BASE_STEPS), BASE_STEPS * periapsis_timescale(2.0 / 3.0) / periapsis_timescale(e))
    return int(math.ceil(n / records - 1e-9) * records)


@dataclass
class Case:
    """One validation case: test particles around a fixed point mass.

    Attributes
    ----------
    name, title, description : str
        How the report names and describes it.
    gm : float
        GM, m^3/s^2.
    center : ndarray
        The field's centre (3,), m.
    x0, v0 : ndarray
        (n, 3) initial positions (m) and velocities (m/s).
    period : float
        The period that sets the steps, s: dt = period / steps at order 2.
    steps : int
        Steps per ``period`` at order 2 (orders 4-8: HIGH_ORDER_REFINEMENT times more).
    records : int
        Records per ``period`` (all runs and references share these times).
    orbits : dict
        {"quick": n, "full": n}: periods run at order 2 and by the references.
    orbits_high : dict
        The same for orders 4, 6, 8.
    convergence : tuple of str
        Modes in which the order-of-convergence study runs.
    target_period : tuple or None
        An independent period (s) the simulated one must reproduce, and its source.
    params : dict
        Human-readable parameters for the report (strings with units).
    field_body : str or None
        A named central body (GM from astropy), or None.
    offset_study : tuple
        Other centres (m) at which em 2's and IAS15's energy errors are also measured.
    """

    name: str
    title: str
    description: str
    gm: float
    center: np.ndarray
    x0: np.ndarray
    v0: np.ndarray
    period: float
    steps: int
    records: int
    orbits: dict
    orbits_high: dict
    convergence: tuple = ("quick", "full")
    target_period: tuple | None = None
    params: dict = field(default_factory=dict)
    field_body: str | None = None
    #: other centres (m) at which em 2 and IAS15 energy errors are also measured (reported)
    offset_study: tuple = ()

    @property
    def n(self) -> int:
        """The number of particles."""
        return len(self.x0)

    @property
    def names(self) -> list[str]:
        """The particles' body names."""
        return ["satellite"] if self.n == 1 else [f"p{i:04d}" for i in range(self.n)]

    def initial_elements(self) -> orbits.OrbitalElements:
        """The osculating elements of the initial states.

        Returns
        -------
        OrbitalElements
            Arrays over the particles, m and rad.
        """
        return orbits.elements(self.x0, self.v0, self.gm, self.center)

    def semi_major_axes(self) -> np.ndarray:
        """The particles' semi-major axes: position errors are reported in units of these.

        Returns
        -------
        ndarray
            (n,), m.
        """
        return np.asarray(orbits.semi_major_axis(self.x0, self.v0, self.gm, self.center), float)

    def kepler_periods(self) -> np.ndarray:
        """The particles' Kepler periods.

        Returns
        -------
        ndarray
            (n,), s.
        """
        return np.asarray(orbits.kepler_period(self.semi_major_axes(), self.gm), float)


@dataclass(frozen=True)
class Study:
    """A study over many steps that is a case of the suite (run by :func:`.brouwer.run_study`).

    Attributes
    ----------
    name : str
        Its name in :data:`STUDY_CASES`.
    mode : str
        ``"quick"`` or ``"full"``.
    """

    name: str
    mode: str

    @property
    def title(self) -> str:
        """What the study checks, in one line (:data:`STUDY_TITLES`)."""
        return STUDY_TITLES[self.name]


def _single(
    name,
    title,
    description,
    gm,
    center,
    x0,
    v0,
    *,
    period=None,
    records=50,
    orbits_=None,
    orbits_high=None,
    convergence=("quick", "full"),
    target_period=None,
    params=None,
    field_body=None,
    offset_study=(),
):
    x0 = np.atleast_2d(np.asarray(x0, float))
    v0 = np.atleast_2d(np.asarray(v0, float))
    center = np.asarray(center, float)
    el = orbits.elements(x0[0], v0[0], gm, center)
    T = float(orbits.kepler_period(el.a, gm)) if period is None else float(period)
    return Case(
        name=name,
        title=title,
        description=description,
        gm=float(gm),
        center=center,
        x0=x0,
        v0=v0,
        period=T,
        steps=steps_per_orbit(float(el.e), records),
        records=records,
        orbits=orbits_ or {"quick": 100, "full": 1000},
        orbits_high=orbits_high or {"quick": 100, "full": 1000},
        convergence=convergence,
        target_period=target_period,
        params=params or {},
        field_body=field_body,
        offset_study=offset_study,
    )


def _paper() -> Case:
    return _single(
        "paper",
        "The paper's orbit",
        "Goettlicher & Schweizerhof's satellite: start at aphelion r_max = 10 m with v0 = 0.36276 m/s in "
        "GM = 3.9478 m^3/s^2 (a = 6.0000135 m, e = 2/3). Steps as in the paper, dt = T/100 with its "
        "T = 46.4758 s; orders 4-8 at T/400.",
        PAPER_GM,
        (0.0, 0.0, 0.0),
        PAPER_X0,
        PAPER_V0,
        period=PAPER_T,
        orbits_high={"quick": 100, "full": 1000},
        params={
            "GM": "3.9478 m3 / s2",
            "r_max": "10 m",
            "v0": "0.36276 m / s",
            "T (paper)": "46.4758 s",
            "centre": "origin",
        },
    )


#: the 3D family: (name, e, i, raan, argp, start true anomaly), all around one off-origin centre
_FAMILY = [
    ("circular-inclined", 0.0, 30.0, 40.0, 0.0, 17.0, "circular, inclined 30 deg"),
    ("e0.3-polar", 0.3, 90.0, 120.0, 45.0, 200.0, "e = 0.3, polar (i = 90 deg)"),
    ("e0.6-retrograde", 0.6, 150.0, 200.0, 300.0, 95.0, "e = 0.6, retrograde (i = 150 deg)"),
    ("e0.9-inclined", 0.9, 63.4, 75.0, 130.0, 180.0, "e = 0.9, inclined 63.4 deg"),
    ("e0.99-retrograde-polar", 0.99, 100.0, 10.0, 200.0, 150.0, "e = 0.99, near-polar retrograde (i = 100 deg)"),
]
FAMILY_A = 6.0  # m
FAMILY_CENTER = (1.5, -2.0, 0.75)  # m: off the origin, on the scale of the orbits (a = 6 m)
#: the e = 0.99 orbit's centre: off the origin but within its periapsis distance (0.06 m).
#: emorbit and REBOUND store absolute positions, so near periapsis a centre at distance d
#: from the origin costs a relative precision ~eps d / r_p in r, which the potential's depth
#: (GM / r_p ~ 200 |E|) multiplies; the case measures that cost at FAMILY_CENTER and farther.
NEAR_CENTER = (0.03, -0.04, 0.015)  # m
OFFSETS = (FAMILY_CENTER, (30.0, -40.0, 15.0))


def _family() -> list[Case]:
    out = []
    for name, e, inc, raan, argp, nu, what in _FAMILY:
        hard = e >= 0.95  # 21000 steps per orbit: fewer orbits, convergence study in full mode only
        center = NEAR_CENTER if hard else FAMILY_CENTER
        x0, v0 = orbits.state_from_elements(
            (FAMILY_A, e, math.radians(inc), math.radians(raan), math.radians(argp), math.radians(nu)), PAPER_GM, center
        )
        out.append(
            _single(
                name,
                f"3D orbit: {what}",
                f"A test particle on an orbit with a = {FAMILY_A} m, e = {e}, i = {inc} deg, "
                f"Omega = {raan} deg, omega = {argp} deg, starting at true anomaly {nu} deg, around a centre at "
                f"{list(center)} m (not the origin) with GM = 3.9478 m^3/s^2."
                + (
                    " The centre lies within the periapsis distance of the origin: with absolute coordinates a "
                    "distant centre costs precision at periapsis; the energy errors of em 2 and IAS15 with the centre "
                    f"at {list(OFFSETS[0])} m and {list(OFFSETS[1])} m are reported too."
                    if hard
                    else ""
                ),
                PAPER_GM,
                center,
                x0,
                v0,
                orbits_={"quick": 10, "full": 100}
                if hard
                else ({"quick": 1000, "full": 1000} if e == 0.9 else {"quick": 100, "full": 1000}),
                orbits_high={"quick": 3, "full": 20} if hard else {"quick": 50, "full": 300},
                convergence=("full",) if hard else ("quick", "full"),
                offset_study=OFFSETS if hard else (),
                params={
                    "GM": "3.9478 m3 / s2",
                    "a": f"{FAMILY_A} m",
                    "e": f"{e}",
                    "i": f"{inc} deg",
                    "Omega": f"{raan} deg",
                    "omega": f"{argp} deg",
                    "nu0": f"{nu} deg",
                    "centre": f"{list(center)} m",
                },
            )
        )
    return out


def _earth_case(
    name,
    title,
    description,
    a,
    e,
    inc,
    raan,
    argp,
    nu,
    *,
    target=None,
    params=None,
    orbits_=None,
    orbits_high=None,
    convergence=("quick", "full"),
):
    """An Earth orbit from astropy quantities; GM from astropy.constants.GM_earth."""
    gm = const.GM_earth.to_value(u.m**3 / u.s**2)
    el = (a.to_value(u.m), e, inc.to_value(u.rad), raan.to_value(u.rad), argp.to_value(u.rad), nu.to_value(u.rad))
    x0, v0 = orbits.state_from_elements(el, gm)
    p = {
        "GM": f"GM_earth = {const.GM_earth.value:.10g} m3 / s2 (astropy, {const.GM_earth.reference})",
        "a": f"{a.to(u.km):.6f}",
        "e": f"{e}",
        "i": f"{inc:.4g}",
        "Omega": f"{raan:.4g}",
        "omega": f"{argp:.4g}",
        "centre": "origin (Earth's centre)",
    }
    p.update(params or {})
    return _single(
        name,
        title,
        description,
        gm,
        (0.0, 0.0, 0.0),
        x0,
        v0,
        target_period=target,
        params=p,
        field_body="earth",
        orbits_=orbits_,
        orbits_high=orbits_high,
        convergence=convergence,
    )


def _semi_major_axis_for(period: u.Quantity) -> u.Quantity:
    """Kepler's third law with astropy's GM_earth: a = (GM (T / 2 pi)^2)^(1/3)."""
    return ((const.GM_earth * (period / (2 * np.pi)) ** 2) ** (1 / 3)).to(u.km)


def _earth() -> list[Case]:
    leo_alt = 400 * u.km
    molniya_T = (0.5 * u.sday).to(u.s)
    geo_T = (1 * u.sday).to(u.s)
    return [
        _earth_case(
            "earth-leo",
            "Earth: low orbit at 400 km",
            "A circular orbit 400 km above astropy's nominal equatorial Earth radius R_earth "
            f"({const.R_earth.to(u.km):.1f}), inclined 51.6 deg (like the ISS).",
            const.R_earth + leo_alt,
            0.0,
            51.6 * u.deg,
            30 * u.deg,
            0 * u.deg,
            0 * u.deg,
            params={"altitude": f"{leo_alt}", "R_earth": f"{const.R_earth.to(u.km):.1f} (astropy)"},
        ),
        _earth_case(
            "earth-molniya",
            "Earth: Molniya orbit",
            "e = 0.74, i = 63.4 deg, omega = 270 deg, period half a sidereal day "
            f"(astropy: 0.5 sday = {molniya_T:.4f}); a from Kepler's third law with GM_earth.",
            _semi_major_axis_for(molniya_T),
            0.74,
            63.4 * u.deg,
            45 * u.deg,
            270 * u.deg,
            0 * u.deg,
            target=(molniya_T.to_value(u.s), "0.5 sidereal day (astropy.units.sday)"),
            params={"period (target)": f"{molniya_T:.4f} = 0.5 sday"},
        ),
        _earth_case(
            "earth-geo",
            "Earth: geostationary orbit",
            f"Circular and equatorial, period one sidereal day (astropy: 1 sday = {geo_T:.4f}); "
            "a from Kepler's third law with GM_earth.",
            _semi_major_axis_for(geo_T),
            0.0,
            0 * u.deg,
            0 * u.deg,
            0 * u.deg,
            0 * u.deg,
            target=(geo_T.to_value(u.s), "1 sidereal day (astropy.units.sday)"),
            params={"period (target)": f"{geo_T:.4f} = 1 sday"},
        ),
    ]


CLOUD_CENTER = (-5.0, 7.0, 2.0)  # m


def _cloud(n_quick: int = 200, n_full: int = 1000, seed: int = 20240607) -> dict[str, Case]:
    """Many test particles at once: a in [5, 10] m, e in [0, 0.7], isotropic orientations and
    random phases around GM = 3.9478 m^3/s^2 at an off-origin centre. One dt for all, set by
    the resolution rule for the most demanding particle (small a, large e)."""
    out = {}
    for mode, n in (("quick", n_quick), ("full", n_full)):
        rng = np.random.default_rng(seed)
        a = rng.uniform(5.0, 10.0, n)
        e = rng.uniform(0.0, 0.7, n)
        inc = np.arccos(rng.uniform(-1.0, 1.0, n))
        raan, argp, nu = (rng.uniform(0.0, 2 * np.pi, n) for _ in range(3))
        x0, v0 = orbits.state_from_elements((a, e, inc, raan, argp, nu), PAPER_GM, CLOUD_CENTER)
        periods = orbits.kepler_period(a, PAPER_GM)
        tau = np.array([periapsis_timescale(float(ei)) for ei in e]) * periods
        t_min = float(periods.min())
        records = 5
        dt = min(t_min / BASE_STEPS, float(tau.min()) / (BASE_STEPS * periapsis_timescale(2.0 / 3.0)))
        steps = int(math.ceil(t_min / dt / records) * records)
        out[mode] = Case(
            name="cloud",
            title=f"A cloud of {n} test particles at once",
            description=f"{n} test particles (a uniform in [5, 10] m, e uniform in [0, 0.7], isotropic "
            f"orientations, random phases; seed {seed}) around GM = 3.9478 m^3/s^2 at {list(CLOUD_CENTER)} m, "
            "integrated in one simulation with one dt; IAS15 integrates all of them in one "
            "REBOUND simulation with N_active = 1. Times are in periods of the innermost orbit.",
            gm=PAPER_GM,
            center=np.asarray(CLOUD_CENTER, float),
            x0=x0,
            v0=v0,
            period=t_min,
            steps=steps,
            records=records,
            orbits={"quick": 10, "full": 50},
            orbits_high={"quick": 2, "full": 5},
            convergence=(),
            params={
                "particles": str(n),
                "GM": "3.9478 m3 / s2",
                "a": "5 ... 10 m",
                "e": "0 ... 0.7",
                "centre": f"{list(CLOUD_CENTER)} m",
                "innermost period": f"{t_min:.6g} s",
            },
        )
    return out


#: the studies that are cases of the suite (their runs: :data:`.brouwer.STUDIES`)
STUDY_CASES = ("brouwer-j2",)
#: each study's title (the report's heading, its figure's title, ``emorbit validate --list``)
STUDY_TITLES = {"brouwer-j2": "Brouwer's law with J2..J6: em energy error over many steps"}


def _all_cases(mode: str) -> dict[str, Case | EffectCase | PerturbationCase | RigidBinaryCase | BodyCase | Study]:
    cases = [_paper(), *_family(), *_earth(), _cloud()[mode]]
    studies = {name: Study(name, mode) for name in STUDY_CASES}
    return {
        **{c.name: c for c in cases},
        **studies,
        **perturbation_cases(mode),
        **effect_cases(mode),
        **rigid_binary_cases(mode),
        **body_cases(mode),
    }


CASES = (
    "paper",
    *(f[0] for f in _FAMILY),
    "earth-leo",
    "earth-molniya",
    "earth-geo",
    "cloud",
    *STUDY_CASES,
    *PERTURBATION_CASES,
    *EFFECT_CASES,
    *RIGID_BINARY_CASES,
    *body_case_names(),
)


def case_names() -> tuple[str, ...]:
    """The names of every case, in the order they run.

    Returns
    -------
    tuple of str
        The names.
    """
    return CASES


def get_cases(mode: str, names=None) -> list[Case | EffectCase | RigidBinaryCase | Study]:
    """The cases of a mode, all or some (orbit cases, studies, effect cases and the rigid binary).

    Parameters
    ----------
    mode : str
        ``"quick"`` or ``"full"`` (run lengths and ensemble sizes differ).
    names : iterable of str, optional
        Only these cases (in suite order); default: all.

    Returns
    -------
    list of Case, EffectCase, RigidBinaryCase or Study
        The cases.
    """
    table = _all_cases(mode)
    wanted = CASES if names is None else [n for n in CASES if n in set(names)]
    return [table[n] for n in wanted]
