"""What accuracy costs with perturbations (``emorbit bench --only perturbed``): work against
precision of em and its peers on orbits users run, every engine on the same force model
from the same initial state.

Cases (:data:`CASES`), a point of unit mass about the Earth (``CentralField(body="earth")``),
epoch :data:`EPOCH` (an equinox: low orbits cross the Earth's shadow every revolution):

* ``leo``: a = R + 400 km, e = 0.001, i = 51.6 deg, 1 day; zonal J2..J6 (EGM2008), drag in
  air co-rotating with the Earth with one exponential band (Vallado's Table 8-4 band that
  holds 400 km, :data:`emorbit.effects.atmosphere_tables.VALLADO_2013`), Cd A / m = 0.01
  m^2/kg, cannonball radiation pressure with a cylindrical shadow, Cr A / m = 0.01 m^2/kg,
  the Moon and the Sun;
* ``leo-no-shadow``: the same without the shadow (radiation pressure always on): what the
  shadow's jumps cost the engines (heyoka locates them by its events, em's fixed steps land on
  them, radiation pressure's ``land``; em's adaptive steps, IAS15 and DOP853 step across them:
  events are scanned on the record grid's unit, which would bound em's adaptive steps);
* ``molniya``: a of half a sidereal day, e = 0.74, i = 63.4 deg, argument of perigee 270 deg,
  10 days; J2..J4, the Moon and the Sun;
* ``geo``: a of a sidereal day, e = 0, i = 0.05 deg, 30 days; EGM2008 to degree and order 2
  turning with the Earth (the ``gravity_field`` effect, ``rotation = "earth"``: J2, C21/S21
  and the tesseral C22/S22, which pull a geostationary orbit along its longitude), the Moon,
  the Sun and radiation pressure (cylindrical shadow). The field's coefficients, GM and radius
  are those of the package's EGM2008 file (``emorbit/data/egm2008_6.gfc``, heyoka's table bit
  for bit, read by :func:`emorbit.io.icgem.read_gfc`), so the case needs no heyoka; J2 comes
  from the field alone (no zonal effect beside it).

The Sun's and the Moon's paths are emorbit's own (the builtin ephemeris sampled every 6 h and
1 h, cubic Hermite between samples): the peers read the effects' tables and interpolate them
with the same polynomials, and every constant of their force model is read from the effects
(:mod:`.perturbed_models`, which states the formulas; the peers' runs: :mod:`.perturbed_peers`).
``tests/test_bench_perturbed.py`` checks at 100 random states that each peer's acceleration
is emorbit's to 1e-13.

Engines (:data:`SIZES`): em at fixed steps dt (orders 4-8; the quick configuration 6 and 8) and
with adaptive steps (``adaptive = eta``, orders 6 and 8), timed over one record interval, the
whole run (adaptive steps land only at its end); the time finite element (``method = "tfe"``,
order 6) at fixed and adaptive steps; heyoka's ``taylor_adaptive`` at several
tolerances (compile time in its own column, caches off); REBOUND's IAS15 at several epsilons
(``additional_forces``, a Python callback: REBOUNDx's ``gravitational_harmonics`` has J2 and J4
only, so it is not used); scipy's DOP853 at several rtol. Measured for each: the CPU time of
the run (set-up and compilation excluded, and for em the sampling of the Sun's and the Moon's
paths, which the peers get from the model; the best of three under 50 ms), the final position
error against the reference over a, and the largest energy balance ``|E - E0 - W| / |E0|`` over
its records: em's from the records of a second, untimed run (every :data:`RECORD_S`, where
adaptive steps land), the peers' with W integrated from the same force model along their
solution. em's compile time (Numba's, or the load from its cache) is that of its first runs,
once per case.

The reference: heyoka in long double at tolerance :data:`REFERENCE_TOL` (the shadow's edges
found by its event detection), checked against em order 8 at a small step; without heyoka or
without a wide long double, em order 8 at a small step, checked against em order 8 at twice
that step. The least CPU time to 1e-3, 1e-6 and 1e-9 of a (:data:`ACCURACIES`;
:func:`emorbit.bench.workprecision.reach`). Targets per case (:func:`targets`): em (best of
em's and tfe's fixed and adaptive series, best order) <= 1x IAS15's CPU time at IAS15's error
at epsilon 1e-9;
em <= :data:`LIMIT_HEYOKA` x heyoka's at 1e-6 and 1e-9 of a; em's energy balance <=
:data:`LIMIT_BALANCE` on every point.

References: D. A. Vallado, Fundamentals of Astrodynamics and Applications, 4th ed. (2013),
chapter 8; O. Montenbruck, E. Gill, Satellite Orbits (Springer, 2000), chapter 3; F. Biscani,
D. Izzo, Mon. Not. R. Astron. Soc. 504 (2021) 2614-2628 (heyoka); H. Rein, D. S. Spiegel,
Mon. Not. R. Astron. Soc. 446 (2015) 1424-1437 (IAS15); E. Hairer, S. P. Norsett, G. Wanner,
Solving Ordinary Differential Equations I (Springer, 1993) (DOP853).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from .common import CONFIGS
from .gravity_field import _e, _reached, point_line, scored, verdict_lines
from .timing import best_cpu, loadavg

__all__ = [
    "EPOCH",
    "CASES",
    "SIZES",
    "ACCURACIES",
    "LIMIT_IAS15",
    "LIMIT_HEYOKA",
    "LIMIT_BALANCE",
    "Case",
    "Size",
    "initial_state",
    "field_file",
    "simulation",
    "model",
    "work_precision",
    "targets",
    "run",
    "table",
    "plot",
]

#: the runs' epoch (TDB): the March equinox
EPOCH = "2026-03-20T00:00:00 TDB"
#: the final position errors (relative to a) of the least-CPU-time table
ACCURACIES = (1e-3, 1e-6, 1e-9)
#: em's CPU time at IAS15's final position error (epsilon :data:`IAS15_EPSILON`) over IAS15's, at most
LIMIT_IAS15 = 1.0
#: REBOUND's default epsilon: the target compares at this point's error
IAS15_EPSILON = 1e-9
#: em's CPU time over heyoka's at 1e-6 and 1e-9 of a, at most
LIMIT_HEYOKA = 3.0
#: em's energy balance |E - E0 - W| / |E0| on every point, at most
LIMIT_BALANCE = 1e-12
#: heyoka's tolerance in long double for the reference
REFERENCE_TOL = 1e-18
#: emorbit's series in the least-CPU-time table (names of emorbit.bench.workprecision.ENGINES)
EMORBIT = ("em fixed", "em adaptive", "tfe", "tfe adaptive")
#: the record interval of em's runs (adaptive steps land there) and of the peers' balance, s
RECORD_S = 3600.0
#: the point's Cd A / m and Cr A / m, m^2/kg
COEFFICIENTS = {"ballistic_coefficient": 0.01, "radiation_coefficient": 0.01}


@dataclass(frozen=True)
class Case:
    """One orbit and its force model."""

    name: str
    elements: tuple  # (a or None: R + altitude; altitude, e, i deg, node, argp deg, true anomaly), see initial_state
    duration: float  # s
    degree: int  # zonal J2..J_degree
    drag: bool
    srp: bool
    check_dt: float  # em order 8's step for the reference's check, s
    shadow: str = "cylindrical"  # the radiation pressure's shadow: "cylindrical" or "none"
    field_order: int = 0  # > 0: EGM2008 to degree and order (degree, field_order) turning with the Earth, not zonal


def _sidereal_a(gm: float, fraction: float) -> float:
    """The semi-major axis of a period of ``fraction`` of a sidereal day (the Earth's rotation rate
    of the drag effect)."""
    from ..effects.drag import EARTH_ROTATION

    n = EARTH_ROTATION / fraction
    return (gm / (n * n)) ** (1.0 / 3.0)


#: the cases by name: (sidereal fraction or None, altitude m), e, i deg, node rad, argp deg, nu rad
CASES = {
    "leo": Case("leo", ((None, 400e3), 0.001, 51.6, 0.2, 5.73, 0.0), 86400.0, 6, True, True, 15.0),
    "molniya": Case("molniya", ((0.5, 0.0), 0.74, 63.4, 0.2, 270.0, 0.0), 10 * 86400.0, 4, False, False, 30.0),
    "geo": Case("geo", ((1.0, 0.0), 0.0, 0.05, 0.2, 0.0, 0.0), 30 * 86400.0, 2, False, True, 300.0, field_order=2),
}

#: the LEO without the shadow (radiation pressure always on): what the shadow's jumps cost each engine
CASES = {"leo": CASES["leo"], "leo-no-shadow": replace(CASES["leo"], name="leo-no-shadow", shadow="none")} | {
    k: c for k, c in CASES.items() if k != "leo"
}


@dataclass(frozen=True)
class Size:
    """What one configuration measures for one case."""

    duration: float | None  # None: the case's
    fixed: tuple  # ((order, (dt, ...)), ...), coarsest first
    etas: tuple  # ((order, (eta, ...)), ...), coarsest first
    tolerances: tuple  # heyoka's, loosest first
    epsilons: tuple  # IAS15's, loosest first
    rtols: tuple  # DOP853's, loosest first
    max_run_s: float  # a run estimated (from the one before in its series) to take longer is skipped
    tfe: tuple = ()  # the time finite element's fixed steps ((order, (dt, ...)), ...)
    tfe_etas: tuple = ()  # and its adaptive steps ((order, (eta, ...)), ...)


#: by configuration name, then by case
SIZES = {
    "full": {
        "leo": Size(
            None,
            ((4, (60.0, 30.0, 15.0)), (6, (120.0, 60.0, 30.0)), (8, (240.0, 120.0, 60.0, 30.0, 15.0))),
            ((6, (0.04, 0.02, 0.01)), (8, (0.08, 0.04, 0.02, 0.01, 0.005))),
            (1e-6, 1e-9, 1e-12, 1e-15),
            (1e-5, 1e-7, 1e-9, 1e-11),
            (1e-6, 1e-8, 1e-10, 1e-12),
            20.0,
            ((6, (120.0, 60.0, 30.0)),),
            ((6, (0.04, 0.02, 0.01, 0.005)),),
        ),
        "molniya": Size(
            None,
            ((8, (120.0, 60.0, 30.0)),),
            ((6, (0.04, 0.02, 0.01)), (8, (0.08, 0.04, 0.02, 0.01))),
            (1e-6, 1e-9, 1e-12, 1e-15),
            (1e-5, 1e-7, 1e-9, 1e-11),
            (1e-6, 1e-8, 1e-10, 1e-12),
            20.0,
            ((6, (120.0, 60.0, 30.0)),),
            ((6, (0.04, 0.02, 0.01, 0.005)),),
        ),
        "geo": Size(
            None,
            ((8, (3600.0, 1800.0, 900.0)),),
            ((8, (0.08, 0.04, 0.02, 0.01)),),
            (1e-6, 1e-9, 1e-12, 1e-15),
            (1e-5, 1e-7, 1e-9, 1e-11),
            (1e-6, 1e-8, 1e-10, 1e-12),
            20.0,
            ((6, (1800.0, 900.0, 450.0)),),
            ((6, (0.04, 0.02, 0.01, 0.005)),),
        ),
    },
    "quick": {
        "leo": Size(
            None,
            ((6, (120.0, 60.0)), (8, (240.0, 120.0, 60.0, 30.0, 20.0))),
            ((6, (0.04, 0.02)), (8, (0.08, 0.04, 0.02, 0.01, 0.005))),
            (1e-6, 1e-9, 1e-12, 1e-15),
            (1e-7, 1e-9),
            (1e-6, 1e-9),
            3.0,
            ((6, (120.0, 60.0, 30.0)),),
            ((6, (0.04, 0.02, 0.01, 0.005)),),
        ),
        "molniya": Size(
            None,
            ((8, (120.0, 60.0, 30.0)),),
            ((6, (0.04, 0.02, 0.01)), (8, (0.08, 0.04, 0.02, 0.01))),
            (1e-6, 1e-9, 1e-12, 1e-15),
            (1e-7, 1e-9),
            (1e-6, 1e-9),
            3.0,
            ((6, (120.0, 60.0, 30.0)),),
            ((6, (0.04, 0.02, 0.01, 0.005)),),
        ),
        "geo": Size(
            None,
            ((8, (3600.0, 1800.0, 900.0, 300.0)),),
            ((8, (0.08, 0.04, 0.02, 0.01)),),
            (1e-6, 1e-9, 1e-12, 1e-15),
            (1e-7, 1e-9),
            (1e-6, 1e-9),
            3.0,
            ((6, (1800.0, 900.0, 450.0)),),
            ((6, (0.04, 0.02, 0.01, 0.005)),),
        ),
    },
    # a smoke run for the tests: its timings mean nothing
    "tiny": {"leo": Size(7200.0, ((8, (120.0,)),), ((8, (0.05,)),), (1e-9,), (1e-9,), (1e-8,), 5.0)},
}

for _sizes in (SIZES["full"], SIZES["quick"]):  # the LEO's settings serve it without the shadow too
    _sizes["leo-no-shadow"] = _sizes["leo"]
    for _name in [k for k in _sizes if k not in ("leo", "leo-no-shadow")]:
        _sizes[_name] = _sizes.pop(_name)  # after the LEOs, in the order of CASES


def _field():
    import emorbit

    return emorbit.CentralField(body="earth")


def initial_state(case: Case):
    """The case's initial position and velocity (m, m/s) and its semi-major axis a (m)."""
    from ..orbits import state_from_elements

    field = _field()
    (fraction, altitude), e, inc, node, argp, nu = case.elements
    a = field.radius + altitude if fraction is None else _sidereal_a(field.gm, fraction)
    x0, v0 = state_from_elements((a, e, math.radians(inc), node, math.radians(argp), nu), field.gm)
    return np.asarray(x0, float), np.asarray(v0, float), a


def field_file() -> str:
    """The package's EGM2008 file (degree and order 6), the rotating field's coefficients."""
    import os

    from ..effects.zonal import MODELS

    return os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", MODELS["earth"])


def _band(altitude: float):
    """(h0, rho0, H) of Vallado's band that holds the altitude."""
    from ..effects.atmosphere_tables import VALLADO_2013 as t

    k = int(np.searchsorted(t.h0, altitude, side="right")) - 1
    return float(t.h0[k]), float(t.rho0[k]), float(t.H[k])


def simulation(case: Case, dt: float, order: int = 8, adaptive: float | None = None, method: str = "em"):
    """The case as an emorbit simulation with the point ``sat``.

    Parameters
    ----------
    case : Case
    dt : float
        The step, or the record interval of adaptive steps, s.
    order : int
    adaptive : float, optional
        eta of adaptive steps.
    method : str
        ``"em"`` or ``"tfe"``.

    Returns
    -------
    emorbit.Simulation
    """
    import emorbit

    keys = {} if adaptive is None else {"adaptive": adaptive}
    sim = emorbit.Simulation(_field(), method=method, order=order, dt=dt, epoch=EPOCH, **keys)
    if case.field_order:
        sim.add_effect("gravity_field", gfc=field_file(), degree=case.degree, order=case.field_order, rotation="earth")
    else:
        sim.add_effect("zonal", model="earth", degree=case.degree)
    if case.drag:
        h0, rho0, scale = _band(case.elements[0][1])
        sim.add_effect("drag", atmosphere="exponential", density=rho0, reference_altitude=h0, scale_height=scale)
    if case.srp:  # fixed steps land on the shadow's edges, as heyoka's events find them
        sim.add_effect("srp", shadow=case.shadow, land=case.shadow != "none" and adaptive is None)
    sim.add_effect("third_body", body="moon")
    sim.add_effect("third_body", body="sun")
    x0, v0, _ = initial_state(case)
    values = {k: v for k, v in COEFFICIENTS.items() if (case.drag if k[0] == "b" else case.srp)}
    sim.add_point("sat", mass=1.0, position=x0, velocity=v0, **values)
    return sim


def model(case: Case, duration: float):
    """The peers' force model of the case (:class:`~emorbit.bench.perturbed_models.Model`), its
    tables sampled over ``duration``, and the simulation it was read from."""
    from .perturbed_models import Model

    sim = simulation(case, 60.0)
    sim.effects.prepare(0.0, duration, sim.epoch)
    return Model.from_simulation(sim, COEFFICIENTS), sim


def _em(
    case: Case, order: int, dt: float | None, duration: float, adaptive: float | None = None, method: str = "em"
) -> dict:
    """One em (or tfe) run, timed over one record interval (adaptive steps land only at the end,
    as the peers'); the energy balance from a second, untimed run with records every RECORD_S
    (where adaptive steps land too)."""
    from ..integrators import coefficients

    every_s = min(RECORD_S, duration)
    if adaptive is None:
        steps = int(round(duration / dt))
        every = max(1, int(round(every_s / dt)))
        while steps % every:
            every -= 1
        timed, records = (dt, steps, steps), (dt, steps, every)
    else:
        timed, records = (duration, 1, 1), (every_s, int(round(duration / every_s)), 1)

    def setup(h, n, k):
        """The simulation, its Sun's and Moon's paths sampled as its run will sample them (the
        set-up, not timed: the peers get the same samples from the model)."""
        sim = simulation(case, h, order=order, adaptive=adaptive, method=method)
        sim._prepare_effects(n, coefficients(order))
        return sim, n, k

    def go(arg):
        sim, n, k = arg
        return sim, sim.run(steps=n, every=k, progress=False)

    try:
        (sim, res), cpu = best_cpu(go, lambda: setup(*timed))
        if abs(res.si.time[-1] - duration) > 1e-6 * duration:
            return {"status": f"failed: ended at t = {res.si.time[-1]:g} s", "cpu_s": cpu}
        rec = go(setup(*records))[1]
    except Exception as exc:  # noqa: BLE001 - a step too long for the orbit is a point that failed
        return {"status": f"failed: {type(exc).__name__}: {exc}"}
    return {
        "cpu_s": cpu,
        "x_end": np.array(res.si.positions["sat"][-1], float),
        "energy_balance": float(np.max(np.abs(rec.si.relative_energy_balance()))),
        "steps": int(sim.points.adaptive_steps) if adaptive is not None else timed[1],
        "newton": res.si.mean_newton_iterations(),
    }


def _difference(x_end, other: dict, a: float) -> float | None:
    if "x_end" not in other:
        return None
    return float(np.linalg.norm(np.asarray(x_end, float) - np.asarray(other["x_end"], float)) / a)


def _reference(case: Case, hey, duration: float, a: float) -> dict:
    """heyoka in long double, checked against em order 8; or em order 8 checked against itself
    at twice the step."""
    from .perturbed_peers import heyoka_run

    check = _em(case, 8, case.check_dt, duration)
    if hey is not None and np.finfo(np.longdouble).eps < 1e-18:
        r = heyoka_run(hey, REFERENCE_TOL, fp_type=np.longdouble)
        if "x_end" in r:
            return {
                "method": f"heyoka taylor_adaptive, long double, tol {REFERENCE_TOL:g} (order {r['order']})",
                "x_end": np.asarray(r["x_end"], float),
                "cpu_s": r["cpu_s"],
                "compile_s": r["compile_s"],
                "energy_balance": r["energy_balance"],
                "check": f"em order 8, dt = {case.check_dt:g} s",
                "check_difference": _difference(r["x_end"], check, a),
            }
        why = f"heyoka in long double failed ({r['status']})"
    else:
        why = "without heyoka" if hey is None else "long double is no wider than double here"
    coarse = _em(case, 8, 2.0 * case.check_dt, duration)
    return {
        "method": f"em order 8, dt = {case.check_dt:g} s ({why})",
        "x_end": check.get("x_end"),
        "cpu_s": check.get("cpu_s"),
        "energy_balance": check.get("energy_balance"),
        "check": f"em order 8, dt = {2.0 * case.check_dt:g} s",
        "check_difference": _difference(check.get("x_end"), coarse, a) if "x_end" in check else None,
    }


def _peer_status(name: str) -> str | None:
    """None where the peer imports, else why its rows are skipped."""
    import importlib

    try:
        importlib.import_module(name)
    except ImportError as exc:
        return f"skipped: {name} is not installed ({exc})"
    return None


def work_precision(case: Case, size: Size) -> dict:
    """Every engine at its settings on one case; the least CPU time to each accuracy.

    Parameters
    ----------
    case : Case
    size : Size

    Returns
    -------
    dict
        ``case``, ``a``, ``duration``, ``reference``, ``points`` (engine, method, order,
        adaptive, the setting, ``cpu_s``, ``compile_s``, ``position_error``,
        ``energy_balance``, ``steps``, ``status``), ``reach`` (per accuracy, each engine's least
        CPU time), ``em_compile_s`` and ``skipped`` (the peers that did not run, and why).
    """
    from .perturbed_peers import HeyokaRunner, dop853_run, heyoka_run, ias15_run

    duration = size.duration or case.duration
    x0, v0, a = initial_state(case)
    state0 = np.concatenate([x0, v0])
    records = max(1, int(round(duration / RECORD_S)))
    t = time.process_time()
    simulation(case, 60.0).run(steps=1, progress=False)  # compile the set, or load it from Numba's cache
    simulation(case, 600.0, adaptive=0.05).run(steps=1, progress=False)
    for order, _ in size.tfe:  # and tfe's kernels, where the case runs them
        simulation(case, 60.0, order=order, method="tfe").run(steps=1, progress=False)
    for order, _ in size.tfe_etas:
        simulation(case, 600.0, order=order, adaptive=0.05, method="tfe").run(steps=1, progress=False)
    em_compile = time.process_time() - t
    force_model, _ = model(case, duration)
    skipped = {name: why for name in ("heyoka", "rebound", "scipy") if (why := _peer_status(name))}
    hey = None if "heyoka" in skipped else HeyokaRunner(force_model, state0, duration)
    ref = _reference(case, hey, duration, a)
    points = []

    def add(point, res):
        points.append(scored(point, res, ref["x_end"], a))

    def series(settings, make, run, scale_of):
        """Run the settings coarsest first, skipping those estimated over max_run_s."""
        scale = None
        for s in settings:
            point = make(s)
            if scale is not None and scale_of(scale, s) > size.max_run_s:
                add(point, {"status": f"skipped: estimated over {size.max_run_s:g} s"})
                continue
            res = run(s)
            if "cpu_s" in res and res.get("status") is None:
                scale = (res["cpu_s"], s)
            add(point, res)

    for order, dts in size.fixed:
        series(
            dts,
            lambda dt, o=order: {"engine": "emorbit", "method": "em", "order": o, "dt": dt, "adaptive": False},
            lambda dt, o=order: _em(case, o, dt, duration),
            lambda sc, dt: sc[0] * sc[1] / dt,
        )
    for order, etas in size.etas:
        series(
            etas,
            lambda eta, o=order: {"engine": "emorbit", "method": "em", "order": o, "tolerance": eta, "adaptive": True},
            lambda eta, o=order: _em(case, o, None, duration, adaptive=eta),
            lambda sc, eta: sc[0] * sc[1] / eta,
        )
    for order, dts in size.tfe:
        series(
            dts,
            lambda dt, o=order: {"engine": "emorbit", "method": "tfe", "order": o, "dt": dt, "adaptive": False},
            lambda dt, o=order: _em(case, o, dt, duration, method="tfe"),
            lambda sc, dt: sc[0] * sc[1] / dt,
        )
    for order, etas in size.tfe_etas:
        series(
            etas,
            lambda eta, o=order: {"engine": "emorbit", "method": "tfe", "order": o, "tolerance": eta, "adaptive": True},
            lambda eta, o=order: _em(case, o, None, duration, adaptive=eta, method="tfe"),
            lambda sc, eta: sc[0] * sc[1] / eta,
        )
    peers = (
        ("heyoka", "taylor", "tolerance", size.tolerances, lambda tol: heyoka_run(hey, tol)),
        (
            "rebound",
            "ias15",
            "epsilon",
            size.epsilons,
            lambda e: ias15_run(force_model, state0, duration, e, records, e == IAS15_EPSILON),
        ),
        (
            "scipy",
            "dop853",
            "tolerance",
            size.rtols,
            lambda r: dop853_run(force_model, state0, duration, r, records, a),
        ),
    )
    for engine, method, key, settings, go in peers:
        for s in settings:
            point = {"engine": engine, "method": method, "order": 0, key: s, "adaptive": False}
            res = {"status": skipped[engine]} if engine in skipped else go(s)
            if "order" in res:
                point["order"] = res.pop("order")
            add(point, res)
    return {
        "case": _describe(case, duration, a),
        "name": case.name,
        "a": a,
        "duration": duration,
        "reference": {k: v for k, v in ref.items() if k != "x_end"},
        "points": points,
        "reach": _reach_rows(points),
        "em_compile_s": em_compile,
        "skipped": skipped,
    }


def _describe(case: Case, duration: float, a: float) -> str:
    _, e, inc, _, _, _ = case.elements
    gravity = f"J2..J{case.degree}"
    if case.field_order:
        terms = " (J2, C21/S21, C22/S22)" if (case.degree, case.field_order) == (2, 2) else ""
        gravity = f"EGM2008 {case.degree}x{case.field_order} turning with the Earth{terms}"
    forces = [gravity] + (["drag"] if case.drag else []) + ([f"SRP ({case.shadow} shadow)"] if case.srp else [])
    return (
        f"{case.name}: a = {a / 1e3:.1f} km, e = {e:g}, i = {inc:g} deg, {duration / 86400:g} d; "
        f"{' + '.join(forces + ['Moon + Sun'])}"
    )


def _reach_rows(points: list) -> list:
    """Per accuracy, each engine's least CPU time (:func:`emorbit.bench.workprecision.reach`;
    DOP853's through the same function, its points relabelled)."""
    from .workprecision import reach

    dop = [dict(p, engine="heyoka", method="taylor") for p in points if p["engine"] == "scipy"]
    rows = []
    for accuracy in ACCURACIES:
        engines = {name: reach(points, name, accuracy) for name in EMORBIT + ("heyoka", "ias15")}
        engines["dop853"] = reach(dop, "heyoka", accuracy)
        best = _em_at(points, accuracy)
        row = {"accuracy": accuracy, "engines": engines, "em_best": best}
        for peer in ("heyoka", "ias15", "dop853"):
            theirs = engines[peer]
            row[f"em_over_{peer}"] = None if best is None or theirs is None else best["cpu_s"] / theirs["cpu_s"]
        rows.append(row)
    return rows


def _em_at(points: list, accuracy: float):
    """emorbit's least CPU time to ``accuracy``: the best of em's and tfe's fixed and adaptive
    series, with the series' name (``engine``); None where none reaches it."""
    from .workprecision import reach

    ems = [dict(e, engine=n) for n in EMORBIT if (e := reach(points, n, accuracy)) is not None]
    return min(ems, key=lambda e: e["cpu_s"]) if ems else None


def targets(section: dict) -> list:
    """Per case: em at IAS15's error (epsilon :data:`IAS15_EPSILON`) within :data:`LIMIT_IAS15`
    times its CPU time; em within :data:`LIMIT_HEYOKA` times heyoka's at 1e-6 and 1e-9 of a;
    em's energy balance within :data:`LIMIT_BALANCE` on every point (``met`` None where not
    measured)."""
    out = []
    for name, wp in section.get("cases", {}).items():
        pts = wp["points"]
        ias = next((p for p in pts if p["method"] == "ias15" and p.get("epsilon") == IAS15_EPSILON), None)
        t = {"target": f"perturbed {name}: em <= {LIMIT_IAS15:g}x IAS15's CPU time at IAS15's error (eps 1e-9)"}
        t.update(limit=LIMIT_IAS15, met=None)
        if ias is None or ias.get("status") != "ok":
            t["note"] = f"skipped: IAS15 {ias['status'] if ias else 'did not run'}"
        else:
            em = _em_at(pts, ias["position_error"])
            if em is None:
                t["note"] = f"skipped: em does not reach IAS15's {ias['position_error']:.1e} of a"
            else:
                r = em["cpu_s"] / ias["cpu_s"]
                t.update(measured=r, met=r <= LIMIT_IAS15)
                t["note"] = (
                    f"at {ias['position_error']:.1e} of a: {em['engine']} order {em['order']} "
                    f"{1e3 * em['cpu_s']:.1f} ms, IAS15 {1e3 * ias['cpu_s']:.1f} ms"
                )
        out.append(t)
        for row in wp["reach"]:
            if row["accuracy"] not in (1e-6, 1e-9):
                continue
            t = {"target": f"perturbed {name}: em <= {LIMIT_HEYOKA:g}x heyoka's CPU time at {row['accuracy']:g} of a"}
            t.update(limit=LIMIT_HEYOKA, met=None)
            r, h = row["em_over_heyoka"], row["engines"]["heyoka"]
            if r is None:
                t["note"] = "skipped: em or heyoka does not reach it"
            else:
                t.update(measured=r, met=r <= LIMIT_HEYOKA)
                e = row["em_best"]
                t["note"] = (
                    f"{e['engine']} order {e['order']} {1e3 * e['cpu_s']:.1f} ms, heyoka {1e3 * h['cpu_s']:.1f} ms"
                )
            out.append(t)
        balances = [p["energy_balance"] for p in pts if p["engine"] == "emorbit" and p.get("status") == "ok"]
        t = {"target": f"perturbed {name}: em's energy balance |E - E0 - W| / |E0| <= {LIMIT_BALANCE:g} on every point"}
        t.update(limit=LIMIT_BALANCE, met=None)
        if balances:
            worst = max(balances)
            peers = {}
            for p in pts:
                if p["engine"] != "emorbit" and p.get("status") == "ok" and p.get("energy_balance") is not None:
                    peers[p["method"]] = min(peers.get(p["method"], math.inf), p["energy_balance"])
            t.update(measured=worst, met=worst <= LIMIT_BALANCE)
            t["note"] = "peers' best: " + ", ".join(f"{k} {v:.1e}" for k, v in peers.items())
        out.append(t)
    return out


def _size(cfg) -> tuple[str, dict]:
    name = next((n for n, c in CONFIGS.items() if c == cfg), "full")
    return name, SIZES[name]


def run(cfg) -> dict:
    """Measure the section: every case of the configuration, the targets.

    Parameters
    ----------
    cfg : Config
        A configuration of :data:`emorbit.bench.common.CONFIGS`; its name picks :data:`SIZES`.

    Returns
    -------
    dict
        JSON-ready: ``config``, ``cases`` (by name, :func:`work_precision`), ``targets``,
        ``seconds`` (per case), the load average.
    """
    name, sizes = _size(cfg)
    section = {"name": "perturbed", "config": name, "load_average": {"before": loadavg()}, "cases": {}, "seconds": {}}
    for case_name, size in sizes.items():
        t = time.perf_counter()
        section["cases"][case_name] = work_precision(CASES[case_name], size)
        section["seconds"][case_name] = round(time.perf_counter() - t, 1)
    section["targets"] = targets(section)
    section["load_average"]["after"] = loadavg()
    return section


# -- the table and the figures -------------------------------------------------------------------
def _label(p: dict) -> str:
    if p["engine"] == "emorbit":
        return f"{p['method']}{' adaptive' if p['adaptive'] else ''} order {p['order']}"
    return f"{p['engine']} {p['method']}" + (f" ({p['order']})" if p["order"] else "")


def _setting(p: dict) -> str:
    if p["engine"] == "emorbit":
        return f"eta {p['tolerance']:g}" if p["adaptive"] else f"dt {p['dt']:g} s"
    return f"eps {p['epsilon']:.0e}" if "epsilon" in p else f"tol {p['tolerance']:.0e}"


def table(section: dict) -> list[str]:
    """The lines that print ``section`` (what :func:`run` returned): per case the reference,
    the points and the least CPU time at each accuracy; then the targets."""
    lines = [f"perturbed orbits ({section['config']})"]
    for name, wp in section["cases"].items():
        ref = wp["reference"]
        cpu = "-" if ref.get("cpu_s") is None else f"{ref['cpu_s']:.2f} s"
        lines += [
            "",
            f"  {wp['case']} ({section['seconds'][name]:g} s)",
            f"    reference: {ref['method']}, {cpu}, its energy balance {_e(ref.get('energy_balance'))}; "
            f"its difference from {ref['check']}: {_e(ref['check_difference'])} of a",
            f"    em: the effect set's compile (or load from Numba's cache) and first steps: "
            f"{wp['em_compile_s']:.2f} s CPU",
            f"    {'engine':<24} {'setting':<12} {'CPU ms':>9} {'compile s':>10} {'steps':>7} {'error / a':>10} "
            f"{'|E-E0-W|/|E0|':>14}",
        ]
        for p in wp["points"]:
            lines.append(point_line(f"    {_label(p):<24} {_setting(p):<12}", p, "energy_balance", 14))
        lines += [
            "    least CPU time to a final position error (em, tfe: best order; em/...: the best of them; cheapest "
            "point or log-log interpolation)",
            f"      {'error / a':<10} {'em fixed':>14} {'em adaptive':>14} {'tfe fixed':>14} {'tfe adaptive':>14} "
            f"{'heyoka':>14} {'IAS15':>12} {'DOP853':>12} {'em/hy':>7} {'em/IAS':>7} {'em/DOP':>7}",
        ]
        for row in wp["reach"]:
            eng = row["engines"]
            cells = [
                f"{row[f'em_over_{k}']:.2f}x" if row[f"em_over_{k}"] else "-" for k in ("heyoka", "ias15", "dop853")
            ]
            lines.append(
                f"      {row['accuracy']:<10g} {_reached(eng['em fixed']):>14} {_reached(eng['em adaptive']):>14} "
                f"{_reached(eng.get('tfe')):>14} {_reached(eng.get('tfe adaptive')):>14} "
                f"{_reached(eng['heyoka']):>14} {_reached(eng['ias15']):>12} {_reached(eng['dop853']):>12} "
                f"{cells[0]:>7} {cells[1]:>7} {cells[2]:>7}"
            )
    return lines + verdict_lines(section["targets"])


def plot(section: dict, folder: str) -> list[str]:
    """One figure per case: final position error and energy balance against CPU time.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.
    folder : str
        Where the PNGs go.

    Returns
    -------
    list of str
        The paths written.
    """
    import os

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for name, wp in section["cases"].items():
        fig, axes = plt.subplots(1, 2, figsize=(12, 5), constrained_layout=True)
        series = {}
        for p in wp["points"]:
            if p.get("status") == "ok":
                series.setdefault(_label(p).split(" (")[0], []).append(p)
        for label, pts in sorted(series.items()):
            pts = sorted(pts, key=lambda p: p["cpu_s"])
            for ax, key in zip(axes, ("position_error", "energy_balance")):
                xy = [(p["cpu_s"], max(p[key], 1e-17)) for p in pts if p.get(key) is not None]
                ax.loglog([q[0] for q in xy], [q[1] for q in xy], "o-", label=label, ms=4)
        for ax, what in zip(axes, ("final position error / a", "max |E - E0 - W| / |E0|")):
            ax.set_xlabel("CPU time [s]")
            ax.set_ylabel(what)
            ax.grid(True, which="major", alpha=0.3)
        axes[0].legend(fontsize=7)
        fig.suptitle(wp["case"], fontsize=10)
        path = os.path.join(folder, f"perturbed-{name}.png")
        fig.savefig(path, dpi=100)
        plt.close(fig)
        paths.append(path)
    return paths
