"""Checks with physical tolerances, and the measurements they compare.

Every tolerance below carries its unit and the reason for its size. A check passes when the
measured deviation (never negative) is at most the tolerance; the report prints both, the
ratio (the margin) and the reason.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from emorbit import analysis

__all__ = [
    "run_checked",
    "one_line_error",
    "Check",
    "EPS",
    "ENERGY_ORDER2",
    "ENERGY_HIGH",
    "ANGULAR_MOMENTUM",
    "POSITION_PER_ORBIT",
    "REFEREE_FRACTION",
    "SLOPE",
    "SLOPE_WINDOW",
    "PERIOD_ALLOWANCE",
    "SIGMAS",
    "CIRCULAR",
    "MOMENTUM",
    "RECORDED_ENERGY",
    "POTENTIAL_CONVENTION",
    "SECULAR_NODE",
    "SECULAR_PERIGEE",
    "RETURN_AFTER_PERIOD",
    "RANDOM_WALK_SLOPE",
    "Period",
    "measure_period",
    "richardson",
    "fit_slope",
    "wrap",
]

EPS = float(np.finfo(float).eps)

#: relative energy error |E - E0| / |E0| that em at order 2 must keep wherever IAS15 keeps it
ENERGY_ORDER2 = 1e-12
#: relative energy error for em at orders 4-8 (exact up to round-off; the compensated (Kahan)
#: update of the state keeps the round-off of many sub-steps below this), and for order 2
#: where IAS15 itself exceeds ENERGY_ORDER2: about 10x the worst measured, 1.0e-13 (the full
#: suite's e0.99-retrograde-polar at order 4; the quick suite's worst 7.8e-14, e0.9-inclined;
#: the effect and perturbation cases 5.1e-14 and below), so that em's energy at round-off is
#: what passes, not a g_em 1e-12 off
ENERGY_HIGH = 1e-12
#: |L - L0| / |L0| for em (and for midpoint and leapfrog, which apply central forces only);
#: 1e-12 leaves Brouwer's round-off walk (eps sqrt(steps), ~3e-13 after 1e6 steps) a margin
ANGULAR_MOMENTUM = 1e-12
#: position error in units of a per orbit for em at order 8 on the high-order step (the
#: paper's T/400, the same steps per periapsis time-scale for every orbit): the suite's
#: target is < 1e-7 a after 100 orbits; a phase error grows linearly in time, hence per orbit
POSITION_PER_ORBIT = 1e-9
#: a referee (IAS15, WHFast) may use at most this fraction of the tolerance it referees, so
#: its own error cannot decide a check
REFEREE_FRACTION = 0.1
#: fitted order of convergence within this of the nominal order (as the unit tests)
SLOPE = 0.5
#: position errors (units of a) used to fit orders: above 30x a typical one-orbit round-off
#: (1e-15 a; raised to 30x the measured floor where that is higher), below the point where
#: the error stops being small (a phase error of 1 % of an orbit)
SLOPE_WINDOW = (3e-14, 1e-2)
#: a measured period must lie within this multiple of the method's measured (Richardson)
#: error of the reference period: 1.5 allows for a step not yet fully asymptotic
PERIOD_ALLOWANCE = 1.5
#: standard errors of the fitted passage slope added to a period tolerance (noise of the
#: passage times found on the cubic Hermite interpolant between records)
SIGMAS = 4.0
#: below this e an orbit has no apses to time: the period is taken from plane crossings
CIRCULAR = 0.01

# -- the effect cases (validation/effect_runner.py) ---------------------------------------
#: |P - P0| relative to sum m |v| (the size of the terms that cancel in P), bodies under
#: mutual gravity in free space: the pair forces are equal and opposite, so P is exact up to
#: round-off; 1e-12 leaves Brouwer's walk a margin, as ANGULAR_MOMENTUM
MOMENTUM = 1e-12
#: emorbit's recorded energy against the energy computed here from its recorded states with
#: the zonal potential in REBOUNDx's convention, relative to |E|: the same sum evaluated
#: twice, of terms up to 2 |E| (GM / r) each rounded at eps: ~45 eps
RECORDED_ENERGY = 1e-14
#: the zonal potential computed here against REBOUNDx's gravitational_harmonics_potential
#: at one state, relative, per unit condition number of the Legendre sum there: one
#: expression evaluated in two orders of operations, a few eps
POTENTIAL_CONVENTION = 16 * EPS
#: the node rate against first-order secular theory, relative, in units of J2 (R/p)^2: the
#: node's neglected J2^2 terms are proportional to cos i like its first-order term (no order
#: moves the node of a polar orbit), so theory's own error is relative, J2 (R/p)^2 times a
#: coefficient of a few (Brouwer's second-order bracket, up to ~3, and the choice of n,
#: Kozai's mean motion or sqrt(GM / a^3), up to 1.5 more)
SECULAR_NODE = 5.0
#: the perigee rate against first-order secular theory, absolute, in units of
#: n (J2 (R/p)^2)^2: its neglected J2^2 terms do not vanish where the first-order rate does
#: (the critical inclination), and their coefficient grows to ~15 towards i = 0 (Brouwer)
SECULAR_PERIGEE = 15.0
#: the figure-eight's state after one period against its start, in units of its size L: the
#: published initial conditions and period carry 8 and 9 digits (rounding ~5e-9); 1e-6
#: allows 200 times that for its growth over one period, and is 1e-7 of the motion
RETURN_AFTER_PERIOD = 1e-6

# -- the Brouwer studies (validation/brouwer.py) -------------------------------------------
#: |slope - 0.5| of the ensemble RMS energy error against steps on log-log axes: round-off
#: independent from step to step adds up as a random walk (Brouwer's law, slope 0.5), a
#: systematic drift grows like steps (slope 1); 0.1 allows for the scatter of an RMS over
#: 32 runs
RANDOM_WALK_SLOPE = 0.1


@dataclass
class Check:
    """One comparison: a measured deviation against a tolerance, with its unit and reason.

    It passes when ``value`` is finite and at most ``tolerance``.

    Attributes
    ----------
    id : str
        A short name, unique in the case.
    what : str
        What is measured.
    against : str
        What it is compared with.
    value : float
        The measured deviation (>= 0).
    tolerance : float
        The tolerance, after scaling.
    unit : str
        The unit of both.
    reason : str
        Why the tolerance has its size.
    detail : str
        Further measurements for the report.
    skipped : str
        Empty, or why the check did not run (a referee that is not installed:
        ``"skipped: Basilisk not installed"``); a skipped check passes, its value is NaN.
    passed : bool
        Set from value and tolerance (True when skipped).
    """

    id: str
    what: str
    against: str
    value: float
    tolerance: float
    unit: str
    reason: str
    detail: str = ""
    skipped: str = ""
    passed: bool = False

    def __post_init__(self):
        self.value = math.nan if self.skipped else float(self.value)
        self.tolerance = float(self.tolerance)
        self.passed = bool(self.skipped) or bool(math.isfinite(self.value) and self.value <= self.tolerance)

    @property
    def margin(self) -> float:
        """tolerance / value (inf for a zero value): how far inside the tolerance."""
        if self.skipped:
            return math.nan
        return math.inf if self.value == 0 else self.tolerance / self.value

    def to_dict(self) -> dict:
        """The check as a JSON-ready dict, with its margin (None for an infinite one).

        Returns
        -------
        dict
            The fields and ``margin``.
        """
        d = asdict(self)
        d["margin"] = None if not math.isfinite(self.margin) else self.margin
        return d


@dataclass
class Period:
    """A period measured from event passages: the slope of passage times against their number.

    Attributes
    ----------
    value : float
        The period, s.
    sigma : float
        The standard error of the slope, s (nan with fewer than 4 events).
    events : int
        Passages used.
    kind : str
        ``"apses"`` or ``"crossings"``.
    """

    value: float  # s
    sigma: float  # standard error of the slope, s
    events: int
    kind: str  # "apses" or "crossings"


def measure_period(t, x, v, gm, center, kind: str) -> Period:
    """The period of one particle's recorded orbit, with the standard error of the fit.

    From apoapsis passages (``kind="apses"``, :func:`emorbit.analysis.period_from_apses`) or
    from crossings of the half-plane through the start (``"crossings"``,
    :func:`emorbit.analysis.period_from_crossings`).

    Parameters
    ----------
    t : array_like
        Record times (m,), s.
    x, v : array_like
        Positions and velocities (m, 3), m and m/s.
    gm : float
        GM, m^3/s^2.
    center : array_like
        The centre, m.
    kind : str
        ``"apses"`` or ``"crossings"``.

    Returns
    -------
    Period
        The period and its standard error.

    Raises
    ------
    ValueError
        An unknown kind, or fewer than two events.
    """
    if kind == "apses":
        value, n = analysis.period_from_apses(t, x, v, gm, center)
        times = analysis.apse_times(t, x, v, gm, center)
    elif kind == "crossings":
        value, n = analysis.period_from_crossings(t, x, v, center)
        r0 = np.asarray(x[0], float) - np.asarray(center, float)
        normal = np.cross(np.cross(r0, v[0]), r0)
        times = analysis.crossing_times(t, x, v, normal, center, side=r0)
    else:
        raise ValueError(f"kind must be 'apses' or 'crossings', got {kind!r}")
    sigma = math.nan
    if times.size >= 4:
        _, cov = np.polyfit(np.arange(times.size), times, 1, cov=True)
        sigma = float(np.sqrt(max(cov[0, 0], 0.0)))
    return Period(float(value), sigma, int(n), kind)


def richardson(value_h: float, value_other: float, ratio: float, order: int) -> float:
    """The discretisation error of a value, estimated from a second value at another step.

    For an error C h^order: (v_h - v_other) / (1 - ratio^order).

    Parameters
    ----------
    value_h : float
        The value at step h.
    value_other : float
        The value at step ``ratio * h``.
    ratio : float
        The ratio of the steps.
    order : int
        The order of the error.

    Returns
    -------
    float
        The estimated error of ``value_h``.
    """
    return (value_h - value_other) / (1.0 - ratio**order)


def fit_slope(n_steps, errors, lo: float, hi: float, finest: int = 3):
    """The order of convergence: minus the slope of log(error) against log(steps per orbit).

    It is fitted to the ``finest`` smallest steps whose errors lie in [lo, hi], the most
    asymptotic points above round-off.

    Parameters
    ----------
    n_steps : array_like
        Steps per orbit, ascending.
    errors : array_like
        The errors at those steps.
    lo, hi : float
        The window of errors that may be used.
    finest : int
        How many of the finest usable points to fit.

    Returns
    -------
    slope : float
        The order (nan with fewer than 3 points).
    used : int
        Points used.
    """
    n = np.asarray(n_steps, float)
    e = np.asarray(errors, float)
    ok = np.flatnonzero(np.isfinite(e) & (e >= lo) & (e <= hi))[-finest:]
    if ok.size < 3:
        return math.nan, int(ok.size)
    return float(-np.polyfit(np.log(n[ok]), np.log(e[ok]), 1)[0]), int(ok.size)


def wrap(angle):
    """Angle differences folded into [-pi, pi).

    Parameters
    ----------
    angle : array_like
        rad.

    Returns
    -------
    ndarray
        rad.
    """
    return np.mod(np.asarray(angle, float) + np.pi, 2 * np.pi) - np.pi


def run_checked(case_run) -> str | None:
    """Run a case (``case_run.run()``); an exception becomes a failed check.

    Parameters
    ----------
    case_run : object
        With ``run()`` and a list ``checks``.

    Returns
    -------
    str or None
        The exception's text on one line (``"RuntimeError: ..."``), after the check
        "case-error" carrying that line was appended to ``case_run.checks``; None when the
        case ran to the end. No traceback goes into the check, so the report's table stays
        one line a check; rerun the case from Python to see where it stopped.
    """
    try:
        case_run.run()
    except Exception as exc:  # noqa: BLE001 - reported as a failed check, its error on one line
        error = one_line_error(exc)
        case_run.checks.append(
            Check(
                "case-error",
                "the case ran to the end",
                "no exception",
                math.inf,
                0.0,
                "",
                "a case that cannot run has failed",
                error,
            )
        )
        return error
    return None


def one_line_error(exc: BaseException) -> str:
    """An exception as one line: its type and message, newlines and runs of blanks folded.

    Parameters
    ----------
    exc : BaseException
        The exception.

    Returns
    -------
    str
        ``"TypeName: message"`` (the type alone when the message is empty).
    """
    message = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {message}" if message else type(exc).__name__
