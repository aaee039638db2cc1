"""A rotating Earth's gravity field (``gravity_field``, EGM2008): what a step costs, and what
accuracy costs beside heyoka (``emorbit bench --only gravity-field``).

The case. A point of unit mass in LEO: a = R + 400 km, e = 0.001, i = 51.6 deg, node 0.2
rad, argument of perigee 0.1 rad, true anomaly 0 (:func:`leo_state`), around EGM2008's GM and
radius R (heyoka's ``get_egm2008_mu``, ``get_egm2008_a``), in the inertial frame, the field
turning uniformly about z at :data:`RATE` rad/s from the prime meridian's angle
:data:`ANGLE` at t = 0: body coordinates ``y = Rz(theta)^T x``, ``theta = ANGLE + RATE t``.

Cost per step (:func:`cost_rows`). em order 2 (one sub-step per step), dt = 60 s, one point,
through the scene's body system (:class:`~emorbit.bench.common.SystemRunner`): the central
field alone (the packed kernels) and central + ``gravity_field`` at degree and order 2, 20,
70 and 120 (the effect step). CPU microseconds per step (the median of interleaved repeats,
:func:`emorbit.bench.timing.timed`) and each one's ratio to the central field's
(:func:`~emorbit.bench.timing.paired_ratio`, the median of the per-repeat ratios), with the
Newton sweeps per sub-step.

Work against precision (:func:`work_precision`), 1 day at degree and order 20. Engines:

* em, fixed steps dt, orders 4, 6 and 8 (:attr:`Size.fixed`);
* em, adaptive time-symmetric steps of about eta times the local Kepler period (``adaptive =
  eta``), orders 6 and 8 (:attr:`Size.etas`), timed over one record interval (the whole run:
  steps land only at its end, as heyoka's);
* heyoka's ``taylor_adaptive`` (compact mode: at degree 20 its default, full unrolling, had
  not compiled after 120 s on the machine the figures below come from) at several
  tolerances, with the same force: ``a = Rz(theta(t)) egm2008_acc(Rz(theta(t))^T x, 20, 20)``
  with ``theta(t) = ANGLE + RATE hy.time`` (:func:`heyoka_force`).

For each run: the CPU time of the integration alone (set-up and compilation excluded, the
best of three for runs under 50 ms), the final position error against the reference over a,
and the drift of the Jacobi integral ``C = E - w . L`` (``w`` the spin vector, L the
angular momentum about the centre, E the energy with the field's potential), the largest
``|C / C(0) - 1|`` over :data:`RECORDS` records of a second, untimed run (em's adaptive
steps land on each record there): em's from its records (``Result.si.energy`` and
``angular_momentum``), heyoka's from its states on the same grid with the potential U of
``hy.model.egm2008_pot`` at the rotated position (a ``cfunc``), ``C = v^2 / 2 - U - w . (x x
v)``. heyoka's compile time (``taylor_adaptive``'s construction, CPU seconds) is a column of
its own, measured with heyoka's caches of compiled code switched off (:func:`_cold`; with
its disk cache, ``~/.cache/heyoka``, a second construction of the same integrator took
0.15-0.2 s).

The reference: heyoka in long double (``fp_type = numpy.longdouble``, 64-bit mantissa on
x86-64) at tolerance :data:`REFERENCE_TOL`, checked against em order 8 at dt = 60 s (an
independent method); where long double is no wider than double, em order 8 at dt =
:data:`FALLBACK_DT` checked against heyoka in double at machine precision. The section
reports which and the check.

The least CPU time to reach a final position error of 1e-6 and 1e-9 of a
(:data:`ACCURACIES`): each engine's cheapest point that reaches it or the log-log
interpolation between two neighbouring settings of one series that bracket it
(:func:`emorbit.bench.workprecision.reach`; em takes its best order), and em's time (the
better of fixed and adaptive) over heyoka's at each. Target (:func:`targets`): em <=
:data:`LIMIT_HEYOKA` times heyoka's CPU time at each accuracy.

Measured with ``--quick`` (42 s with Numba's cache filled; the effect set's first compile
adds about 30 s) on a 2-core Xeon: per step (em order 2), the central field 0.10 us, central +
gravity_field at degree 2, 20, 70, 120 2.9, 17, 193, 581 us (28x, 166x, 1900x, 5700x; 3.8
Newton sweeps per sub-step, the zonal effect's packed J2 0.17 us, 1.7x, 2.0 sweeps). Over the
day: to 1e-6 of a em order 8 (fixed) 54 ms, heyoka 38 ms, 1.42x; to 1e-9 of a em order 8
(fixed) 98 ms, heyoka 74 ms, 1.34x (adaptive 1.48x and 1.57x): the target is met. heyoka
compiles in 2.2 s per tolerance, its potential's cfunc in 0.4 s; the long double reference
(tolerance 1e-18, order 22, 0.5 s) is within 4.9e-14 of a of em order 8 at dt = 60 s. em's
Jacobi integral drifts by 9e-16 ... 4e-12 (the coarsest steps; with true spin, not the step's
Cayley rate), heyoka's by 2e-5 at tolerance 1e-6 to 6e-14 at 1e-13.

References: N. K. Pavlis et al., J. Geophys. Res. 117 (2012) B04406 (EGM2008); F. Biscani, D.
Izzo, Mon. Not. R. Astron. Soc. 504 (2021) 2614-2628 (heyoka).
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from .common import CONFIGS, SystemRunner, points_of
from .timing import CPU, best_cpu, loadavg, paired_ratio, timed

__all__ = [
    "RATE",
    "ANGLE",
    "DEGREE",
    "ACCURACIES",
    "LIMIT_HEYOKA",
    "Size",
    "SIZES",
    "leo_state",
    "simulation",
    "heyoka_force",
    "cost_rows",
    "work_precision",
    "targets",
    "run",
    "table",
]

#: the field's spin rate, rad/s (the Earth's, IERS 2010)
RATE = 7.292115146706979e-5
#: the prime meridian's angle from the x axis at t = 0, rad
ANGLE = 0.3
#: degree and order of the work-precision runs
DEGREE = 20
#: the step of the cost rows, s
COST_DT = 60.0
#: the final position errors (relative to a) of the targets
ACCURACIES = (1e-6, 1e-9)
#: em's CPU time (the better of fixed and adaptive steps) over heyoka's at the same error, at most
LIMIT_HEYOKA = 2.0
#: records of the untimed runs that give the Jacobi integral's drift
RECORDS = 48
#: heyoka's tolerance in long double for the reference
REFERENCE_TOL = 1e-18
#: em order 8's step for the reference where long double is no wider than double, s
FALLBACK_DT = 30.0
#: em order 8's step that checks heyoka's long double reference, s
CHECK_DT = 60.0
#: the cost rows' labels of the central field alone and of the zonal effect's J2 (for comparison)
CENTRAL = "central"
ZONAL = "zonal J2"


@dataclass(frozen=True)
class Size:
    """What one configuration of the section measures (see :data:`SIZES`)."""

    degrees: tuple  # degree and order of the cost rows
    duration: float  # length of the work-precision runs, s
    fixed: tuple  # ((order, (dt, ...)), ...), coarsest first
    etas: tuple  # ((order, (eta, ...)), ...), coarsest first
    tolerances: tuple  # heyoka's, loosest first
    max_run_s: float  # a run estimated (from the one before in its series) to take longer is skipped


#: by the name of the configuration in :data:`emorbit.bench.common.CONFIGS`
SIZES = {
    "full": Size(
        (2, 20, 70, 120),
        86400.0,
        (
            (4, (60.0, 30.0, 20.0, 15.0, 10.0)),
            (6, (400.0, 300.0, 240.0, 180.0, 120.0, 90.0, 60.0)),
            (8, (600.0, 480.0, 400.0, 300.0, 240.0, 180.0, 120.0, 90.0, 60.0)),
        ),
        ((6, (0.05, 0.04, 0.03, 0.02, 0.015, 0.01)), (8, (0.1, 0.08, 0.06, 0.05, 0.04, 0.03, 0.02, 0.015, 0.01))),
        (1e-6, 1e-8, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14, 2.0**-52),
        3.0,
    ),
    "quick": Size(
        (2, 20, 70, 120),
        86400.0,
        ((4, (30.0, 20.0)), (6, (240.0, 180.0, 120.0)), (8, (600.0, 480.0, 400.0, 300.0, 240.0, 180.0))),
        ((6, (0.04, 0.03, 0.02)), (8, (0.1, 0.08, 0.05, 0.03, 0.02))),
        (1e-6, 1e-8, 1e-10, 1e-11, 1e-13),
        1.0,
    ),
    # a smoke run for the tests: its timings mean nothing
    "tiny": Size((2, 20), 6000.0, ((8, (600.0, 300.0)),), ((8, (0.05,)),), (1e-9,), 1.0),
}


def _size(cfg) -> tuple[str, Size]:
    name = next((n for n, c in CONFIGS.items() if c == cfg), "full")
    return name, SIZES[name]


def _egm():
    """(mu, R) of EGM2008 from heyoka (ImportError without it)."""
    import heyoka as hy

    return float(hy.model.get_egm2008_mu()), float(hy.model.get_egm2008_a())


def leo_state(mu: float, radius: float):
    """The LEO of the section: a = R + 400 km, e = 0.001, i = 51.6 deg, node 0.2 rad,
    argument of perigee 0.1 rad, true anomaly 0.

    Parameters
    ----------
    mu, radius : float
        GM (m^3/s^2) and the reference radius (m).

    Returns
    -------
    x0, v0 : numpy.ndarray
        (3,) position (m) and velocity (m/s).
    a : float
        The semi-major axis, m.
    """
    from ..orbits import state_from_elements

    a = radius + 400e3
    x0, v0 = state_from_elements((a, 0.001, math.radians(51.6), 0.2, 0.1, 0.0), mu)
    return np.asarray(x0, float), np.asarray(v0, float), a


def simulation(degree: int, dt: float, order: int = 2, adaptive: float | None = None, state=None):
    """A simulation of the central field (EGM2008's GM and radius) and, where ``degree``, the
    uniformly turning EGM2008 field to that degree and order, with the LEO point ``sat``.

    Parameters
    ----------
    degree : int
        Degree and order of the field; 0: the central field alone.
    dt : float
        The step (adaptive: the record grid), s.
    order : int
        em's order.
    adaptive : float, optional
        eta of adaptive steps.
    state : tuple, optional
        (x0, v0) instead of :func:`leo_state`.

    Returns
    -------
    emorbit.Simulation
    """
    import emorbit

    mu, radius = _egm()
    keys = {"method": "em", "order": order}
    if adaptive is not None:
        keys["adaptive"] = adaptive
    sim = emorbit.Simulation(emorbit.CentralField(gm=mu, radius=radius), dt=dt, **keys)
    if degree:
        sim.add_effect("gravity_field", model="egm2008", degree=degree, rotation="uniform", rate=RATE, angle=ANGLE)
    x0, v0 = state if state is not None else leo_state(mu, radius)[:2]
    sim.add_point("sat", mass=1.0, position=x0, velocity=v0)
    return sim


def heyoka_force(degree: int = DEGREE):
    """heyoka's variables and the inertial force per unit mass of the turning EGM2008 field.

    Parameters
    ----------
    degree : int
        Degree and order.

    Returns
    -------
    xyz : list
        heyoka's variables x, y, z.
    acc : list
        The expressions ``Rz(theta) egm2008_acc(Rz(theta)^T x, N, N)``, ``theta = ANGLE +
        RATE hy.time`` (the central term included).
    pot : expression
        ``egm2008_pot`` at the rotated position (U, the central term mu / r included).
    """
    import heyoka as hy

    x, y, z = hy.make_vars("x", "y", "z")
    theta = ANGLE + RATE * hy.time
    c, s = hy.cos(theta), hy.sin(theta)
    body = [c * x + s * y, -s * x + c * y, z]
    g = hy.model.egm2008_acc(body, degree, degree)
    acc = [c * g[0] - s * g[1], s * g[0] + c * g[1], g[2]]
    return [x, y, z], acc, hy.model.egm2008_pot(body, degree, degree)


# -- cost per step -------------------------------------------------------------------------------
def cost_rows(cfg, degrees=(2, 20, 70, 120)) -> dict:
    """CPU time per em step (order 2) of one LEO point under central + ``gravity_field`` at
    each degree and order, against the central field alone, the engines interleaved.

    Parameters
    ----------
    cfg : Config
        ``repeat_s`` and ``repeats`` (:data:`emorbit.bench.common.CONFIGS`).
    degrees : sequence of int
        Degrees (and orders) of the field.

    Returns
    -------
    dict
        ``case``, ``dt`` and ``rows`` ({``"central"``, ``"degree N"`` or ``"zonal J2"`` (the
        zonal effect at degree 2, the axisymmetric fast path): ``effect``, ``degree``, ``us_per_step`` (CPU),
        ``us_per_step_wall``, ``newton_per_substep``, ``over_central`` (paired ratio), ``steps``,
        ``system``}).
    """
    from ..integrators import coefficients

    mu, radius = _egm()
    x0, v0, _ = leo_state(mu, radius)
    specs = [(CENTRAL, "", 0)] + [(f"degree {n}", "gravity_field", n) for n in degrees] + [(ZONAL, "zonal", 2)]
    runners = {}
    for name, effect, degree in specs:
        sim = simulation(degree if effect == "gravity_field" else 0, COST_DT)
        if effect == "zonal":
            sim.add_effect("zonal", model="earth", degree=2)
        points = points_of(sim, x0[:, None].copy(), v0[:, None].copy())
        sim._prepare_effects(1, coefficients(2))  # the uniform rotation needs nothing; as a run does
        runners[name] = SystemRunner(points, mu, np.zeros(3), COST_DT)
    times = timed(runners, cfg)
    rows = {}
    for name, effect, degree in specs:
        r, stats = runners[name], times[name]
        rows[name] = {
            "effect": effect,
            "degree": degree,
            "system": type(r.points).__name__,
            "under_effects": bool(r.points.under_effects()),
            "us_per_step": stats["cpu_us_per_step"],
            "us_per_step_wall": stats["us_per_step"],
            "newton_per_substep": float(np.median(r.sweeps)) if r.sweeps else None,
            "over_central": 1.0 if name == CENTRAL else paired_ratio(stats, times[CENTRAL]),
            "steps": r.steps,
            "samples_cpu_us": stats[CPU],
        }
    return {
        "case": (
            f"one point in LEO (a = R + 400 km, e = 0.001, i = 51.6 deg), em order 2, dt = {COST_DT:g} s; "
            "central field alone against central + gravity_field (EGM2008, degree = order, turning uniformly) "
            'and, for comparison, central + zonal J2 (add_effect("zonal", model="earth", degree=2))'
        ),
        "dt": COST_DT,
        "rows": rows,
    }


# -- work against precision ----------------------------------------------------------------------
def _jacobi_em(res) -> float:
    c = res.si.energy - res.si.angular_momentum @ np.array([0.0, 0.0, RATE])
    return float(np.max(np.abs(c / c[0] - 1.0)))


def _em(order: int, dt: float | None, duration: float, adaptive: float | None = None, state=None) -> dict:
    """One em run: CPU time, the final position, the Jacobi integral's drift, the steps. Fixed
    steps of dt; or adaptive steps (dt None) timed over one record interval, the whole run,
    the Jacobi integral from a run that lands on each record."""
    if adaptive is None:
        steps = int(round(duration / dt))
        timed_dt, timed_steps, rec_dt, rec_steps, every = dt, steps, dt, steps, max(1, steps // RECORDS)
    else:
        timed_dt, timed_steps, rec_dt, rec_steps, every = duration, 1, duration / RECORDS, RECORDS, 1

    def setup(h=timed_dt):
        return simulation(DEGREE, h, order=order, adaptive=adaptive, state=state)

    def go(sim):
        return sim, sim.run(steps=timed_steps, every=timed_steps, keep=False, progress=False)

    try:
        (sim, res), cpu = best_cpu(go, setup)
        rec = setup(rec_dt).run(steps=rec_steps, every=every, progress=False)
    except Exception as exc:  # noqa: BLE001 - a step too long for the orbit is a point that failed
        return {"status": f"failed: {type(exc).__name__}: {exc}"}
    if abs(res.si.time[-1] - duration) > 1e-6 * duration:
        return {"status": f"failed: ended at t = {res.si.time[-1]:g} s", "cpu_s": cpu}
    return {
        "cpu_s": cpu,
        "x_end": np.array(res.si.positions["sat"][-1], float),
        "jacobi_drift": _jacobi_em(rec),
        "steps": int(sim.points.adaptive_steps) if adaptive is not None else steps,
    }


@contextmanager
def _cold(hy):
    """heyoka without its caches of compiled code (the in-memory one cleared, the one on disk,
    ``~/.cache/heyoka``, switched off and its setting restored after): a construction inside
    compiles. Yields what was switched off: "memory and disk", or "memory" where this heyoka
    has no disk cache."""
    state = hy.llvm_state
    disk = getattr(state, "get_diskcache_enabled", None)
    enabled = disk() if disk is not None else None
    if enabled:
        state.set_diskcache_enabled(False)
    state.clear_memcache()
    try:
        yield "memory and disk" if disk is not None else "memory"
    finally:
        state.clear_memcache()
        if enabled:
            state.set_diskcache_enabled(True)


class _Heyoka:
    """heyoka's integrators of the section's force, its potential's cfunc, compiled once each."""

    def __init__(self):
        import heyoka as hy

        self.hy = hy
        self.xyz, self.acc, pot = heyoka_force(DEGREE)
        with _cold(hy) as self.caches:
            t = time.process_time()
            self.pot = hy.cfunc([pot], self.xyz)
            self.pot_compile_s = time.process_time() - t

    def system(self):
        hy = self.hy
        vx, vy, vz = hy.make_vars("vx", "vy", "vz")
        x, y, z = self.xyz
        return [(x, vx), (y, vy), (z, vz), (vx, self.acc[0]), (vy, self.acc[1]), (vz, self.acc[2])]

    def jacobi(self, t, states) -> float:
        """max |C / C(0) - 1| over states (n, 6) at times t (n,)."""
        x, v = states[:, :3], states[:, 3:]
        u = self.pot(np.ascontiguousarray(x.T), time=np.ascontiguousarray(t))[0]
        c = 0.5 * np.einsum("ik,ik->i", v, v) - u - RATE * (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0])
        return float(np.max(np.abs(c / c[0] - 1.0)))

    def run(self, state0, tol: float, duration: float, fp_type=float) -> dict:
        """A run at ``tol``: compile time, CPU time, the final position, the Jacobi drift."""
        hy = self.hy
        state0 = np.array(state0, dtype=fp_type)
        with _cold(hy):
            t = time.perf_counter(), time.process_time()
            ta = hy.taylor_adaptive(self.system(), state0, tol=fp_type(tol), compact_mode=True, fp_type=fp_type)
            compile_wall, compile_cpu = time.perf_counter() - t[0], time.process_time() - t[1]

        def setup():
            ta.time = fp_type(0.0)
            ta.state[:] = state0
            return ta

        res, cpu = best_cpu(lambda ta: ta.propagate_until(fp_type(duration)), setup)
        if res[0] != hy.taylor_outcome.time_limit:
            return {"status": f"failed: {res[0]}", "compile_s": compile_cpu}
        x_end = np.array(ta.state[:3], dtype=fp_type)
        setup()
        grid = np.linspace(0.0, duration, RECORDS + 1).astype(fp_type)
        traj = np.asarray(ta.propagate_grid(grid)[-1], dtype=float)
        return {
            "cpu_s": cpu,
            "x_end": x_end,
            "jacobi_drift": self.jacobi(grid.astype(float), traj),
            "steps": int(res[3]),
            "order": int(ta.order),
            "compile_s": compile_cpu,
            "compile_wall_s": compile_wall,
        }


def _wide_long_double() -> bool:
    """Whether numpy's long double is wider than double (x87's 64-bit mantissa on x86-64; not on
    Windows or Apple silicon)."""
    return bool(np.finfo(np.longdouble).eps < 1e-18)


def _difference(x_end, check: dict, a: float) -> float | None:
    """|x_end - the check's end| / a; None where the check did not finish."""
    if "x_end" not in check:
        return None
    return float(np.linalg.norm(np.asarray(x_end, float) - np.asarray(check["x_end"], float)) / a)


def _reference(hey: _Heyoka, state0, duration: float, a: float) -> dict:
    """The reference end position: heyoka in long double, or em order 8 at a small step;
    each checked against an independent run."""
    x0, v0 = state0
    if _wide_long_double():
        try:
            r = hey.run(np.concatenate([x0, v0]), REFERENCE_TOL, duration, fp_type=np.longdouble)
        except Exception as exc:  # noqa: BLE001 - a heyoka without long double falls back
            r = {"status": f"failed: {type(exc).__name__}: {exc}"}
        if "x_end" in r:
            check = _em(8, CHECK_DT, duration, state=state0)
            diff = _difference(r["x_end"], check, a)
            return {
                "method": f"heyoka taylor_adaptive, long double, tol {REFERENCE_TOL:g} (order {r['order']})",
                "x_end": np.asarray(r["x_end"], float),
                "x_end_long_double": r["x_end"],
                "cpu_s": r["cpu_s"],
                "compile_s": r["compile_s"],
                "check": f"em order 8, dt = {CHECK_DT:g} s",
                "check_difference": diff,
            }
        fallback = f"long double failed ({r['status']})"
    else:
        fallback = "long double is no wider than double here"
    r = _em(8, FALLBACK_DT, duration, state=state0)
    check = hey.run(np.concatenate([x0, v0]), 2.0**-52, duration)
    return {
        "method": f"em order 8, dt = {FALLBACK_DT:g} s ({fallback})",
        "x_end": r["x_end"],
        "cpu_s": r["cpu_s"],
        "check": "heyoka taylor_adaptive, double, tol 2.2e-16",
        "check_difference": _difference(r["x_end"], check, a),
    }


def scored(point: dict, res: dict, x_ref, a: float) -> dict:
    """``point`` updated with a run's result ``res``, whose ``x_end`` becomes
    ``position_error`` (against ``x_ref``, over a) and ``status`` (ok, or diverged at an error
    of a or more)."""
    if "x_end" in res:
        err = float(np.linalg.norm(np.asarray(res.pop("x_end"), float) - x_ref) / a)
        res["position_error"] = err
        res["status"] = "ok" if math.isfinite(err) and err < 1.0 else "diverged"
    point.update(res)
    return point


def work_precision(size: Size) -> dict:
    """em fixed and adaptive at several orders and settings, and heyoka at several tolerances,
    over ``size.duration`` of the LEO at degree and order :data:`DEGREE`.

    Parameters
    ----------
    size : Size
        The settings (:data:`SIZES`).

    Returns
    -------
    dict
        ``case``, ``a``, ``duration``, ``reference`` (its method, CPU time and check),
        ``points`` (engine, method, order, ``dt`` / ``tolerance``, ``adaptive``, ``cpu_s``,
        ``position_error``, ``jacobi_drift``, ``steps``, heyoka's ``compile_s``, ``status``),
        ``reach`` (per accuracy of :data:`ACCURACIES` the least CPU time of each engine and
        em's over heyoka's) and ``heyoka_pot_compile_s``.
    """
    from .workprecision import reach

    mu, radius = _egm()
    x0, v0, a = leo_state(mu, radius)
    duration = size.duration
    simulation(DEGREE, 60.0, order=8).run(steps=1, progress=False)  # warm-up: compile or load the set
    simulation(DEGREE, 600.0, order=8, adaptive=0.05).run(steps=1, progress=False)
    hey = _Heyoka()
    ref = _reference(hey, (x0, v0), duration, a)
    points = []

    def add(point, res):
        points.append(scored(point, res, ref["x_end"], a))

    for order, dts in size.fixed:
        per_step = None
        for dt in dts:
            point = {"engine": "emorbit", "method": "em", "order": order, "dt": dt, "adaptive": False}
            steps = duration / dt
            if per_step is not None and per_step * steps > size.max_run_s:
                add(point, {"status": f"skipped: estimated over {size.max_run_s:g} s"})
                continue
            res = _em(order, dt, duration)
            if "cpu_s" in res:
                per_step = res["cpu_s"] / steps
            add(point, res)
    for order, etas in size.etas:
        scale = None  # CPU s x eta of the last run (steps ~ 1 / eta)
        for eta in etas:
            point = {"engine": "emorbit", "method": "em", "order": order, "tolerance": eta, "adaptive": True}
            if scale is not None and scale / eta > size.max_run_s:
                add(point, {"status": f"skipped: estimated over {size.max_run_s:g} s"})
                continue
            res = _em(order, None, duration, adaptive=eta)
            if "cpu_s" in res:
                scale = res["cpu_s"] * eta
            add(point, res)
    for tol in size.tolerances:
        point = {"engine": "heyoka", "method": "taylor", "order": 0, "tolerance": tol, "adaptive": False}
        try:
            res = hey.run(np.concatenate([x0, v0]), tol, duration)
        except Exception as exc:  # noqa: BLE001 - a peer never stops the bench
            res = {"status": f"failed: {type(exc).__name__}: {exc}"}
        if "order" in res:
            point["order"] = res.pop("order")
        add(point, res)
    rows = []
    for accuracy in ACCURACIES:
        engines = {name: reach(points, name, accuracy) for name in ("em fixed", "em adaptive", "heyoka")}
        ems = [e for e in (engines["em fixed"], engines["em adaptive"]) if e is not None]
        best = min(ems, key=lambda e: e["cpu_s"]) if ems else None
        h = engines["heyoka"]
        row = {"accuracy": accuracy, "engines": engines, "em_best": best}
        for key, ours in (("fixed", engines["em fixed"]), ("adaptive", engines["em adaptive"]), ("best", best)):
            row[f"em_{key}_over_heyoka"] = None if ours is None or h is None else ours["cpu_s"] / h["cpu_s"]
        rows.append(row)
    ref = {k: v for k, v in ref.items() if k not in ("x_end", "x_end_long_double")}
    return {
        "case": (
            f"LEO (a = R + 400 km, e = 0.001, i = 51.6 deg) in EGM2008 {DEGREE} x {DEGREE} turning at {RATE:.6g} "
            f"rad/s, {duration:g} s in the inertial frame; final position error / a against the reference, "
            f"max |C/C0 - 1| of the Jacobi integral C = E - w . L over {RECORDS} records, CPU time of the run"
        ),
        "a": a,
        "duration": duration,
        "reference": ref,
        "points": points,
        "reach": rows,
        "heyoka_pot_compile_s": hey.pot_compile_s,
        "heyoka_caches_off": hey.caches,
    }


def targets(section: dict) -> list:
    """em (the better of fixed and adaptive steps, best order) within :data:`LIMIT_HEYOKA`
    times heyoka's CPU time at each accuracy of :data:`ACCURACIES` (``met`` None where either
    does not reach it or the section was skipped)."""
    out = []
    wp = section.get("work_precision")
    for accuracy in ACCURACIES:
        t = {
            "target": f"gravity field 20 x 20, LEO 1 day: em <= {LIMIT_HEYOKA:g}x heyoka's CPU time at a final "
            f"position error of {accuracy:g} of a",
            "limit": LIMIT_HEYOKA,
            "met": None,
        }
        row = None if wp is None else next(r for r in wp["reach"] if r["accuracy"] == accuracy)
        if row is None:
            t["note"] = section.get("status", "skipped")
        elif row["em_best_over_heyoka"] is None:
            t["note"] = "skipped: em or heyoka does not reach it"
        else:
            r = row["em_best_over_heyoka"]
            e, h = row["em_best"], row["engines"]["heyoka"]
            t.update(measured=r, met=r <= LIMIT_HEYOKA)
            t["note"] = f"em order {e['order']} {1e3 * e['cpu_s']:.1f} ms, heyoka {1e3 * h['cpu_s']:.1f} ms"
        out.append(t)
    return out


def run(cfg) -> dict:
    """Measure the section: the cost rows, the work-precision runs, the targets.

    Parameters
    ----------
    cfg : Config
        A configuration of :data:`emorbit.bench.common.CONFIGS`; its name picks the
        :data:`SIZES` entry.

    Returns
    -------
    dict
        JSON-ready: ``config``, ``cost`` (:func:`cost_rows`), ``work_precision``
        (:func:`work_precision`), ``targets`` (:func:`targets`), the load average; or, without
        heyoka (it brings the model), ``status`` ``"skipped: ..."``.
    """
    name, size = _size(cfg)
    section = {"name": "gravity-field", "config": name, "load_average": {"before": loadavg()}}
    try:
        _egm()
    except ImportError:
        section["status"] = 'skipped: EGM2008 comes from heyoka: pip install "emorbit[field]"'
        section["targets"] = targets(section)
        return section
    section["cost"] = cost_rows(cfg, size.degrees)
    section["work_precision"] = work_precision(size)
    section["targets"] = targets(section)
    section["load_average"]["after"] = loadavg()
    return section


# -- the table -----------------------------------------------------------------------------------
def _e(x) -> str:
    return "-" if x is None else f"{x:.1e}"


def _setting(p: dict) -> str:
    if p["engine"] == "heyoka":
        return f"tol {p['tolerance']:.0e}"
    return f"eta {p['tolerance']:g}" if p["adaptive"] else f"dt {p['dt']:g} s"


def _reached(r) -> str:
    if r is None:
        return "-"
    where = f"order {r['order']}" if r["order"] else ""
    return f"{1e3 * r['cpu_s']:.1f} ms" + (f" ({where})" if where else "")


def table(section: dict) -> list[str]:
    """The section as printable lines: the cost rows, the work-precision points, the least CPU
    time at each accuracy with em / heyoka, the targets.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.

    Returns
    -------
    list of str
        The lines of the tables.
    """
    lines = [f"gravity field ({section['config']})"]
    if "status" in section:
        return lines + [f"  {section['status']}"]
    cost = section["cost"]
    lines += [
        f"  cost per step: {cost['case']}; CPU time, median of interleaved repeats",
        f"    {'':<12} {'system':<12} {'us/step':>9} {'wall':>9} {'Newton/sub-step':>16} {'/ central':>10}",
    ]
    for name, r in cost["rows"].items():
        newton = "" if r["newton_per_substep"] is None else f"{r['newton_per_substep']:.2f}"
        lines.append(
            f"    {name:<12} {r['system']:<12} {r['us_per_step']:>9.2f} {r['us_per_step_wall']:>9.2f} "
            f"{newton:>16} {r['over_central']:>9.2f}x"
        )
    wp = section["work_precision"]
    ref = wp["reference"]
    lines += [
        "",
        f"  work-precision: {wp['case']}",
        f"    reference: {ref['method']}, {1e3 * ref['cpu_s']:.0f} ms; its difference from {ref['check']}: "
        f"{_e(ref['check_difference'])} of a",
        f"    {'engine':<22} {'setting':<12} {'CPU ms':>9} {'compile s':>10} {'steps':>7} {'error / a':>10} "
        f"{'Jacobi drift':>13}",
    ]
    for p in wp["points"]:
        engine = (
            f"heyoka (order {p['order']})"
            if p["engine"] == "heyoka"
            else f"em{' adaptive' if p['adaptive'] else ''} order {p['order']}"
        )
        lines.append(point_line(f"    {engine:<22} {_setting(p):<12}", p, "jacobi_drift", 13))
    lines += [
        f"    heyoka's potential cfunc (for its Jacobi integral) compiled in {wp['heyoka_pot_compile_s']:.2f} s",
        "    least CPU time to a final position error (best order; cheapest point or log-log interpolation; "
        "heyoka's compile not counted)",
        f"      {'error / a':<10} {'em fixed':>18} {'em adaptive':>18} {'heyoka':>12} {'fixed/hy':>9} "
        f"{'adapt/hy':>9} {'em/hy':>7}",
    ]
    for row in wp["reach"]:
        eng = row["engines"]
        ratios = [row[f"em_{k}_over_heyoka"] for k in ("fixed", "adaptive", "best")]
        cells = [f"{r:.2f}x" if r is not None else "-" for r in ratios]
        lines.append(
            f"      {row['accuracy']:<10g} {_reached(eng['em fixed']):>18} {_reached(eng['em adaptive']):>18} "
            f"{_reached(eng['heyoka']):>12} {cells[0]:>9} {cells[1]:>9} {cells[2]:>7}"
        )
    return lines + verdict_lines(section["targets"])


def point_line(head: str, p: dict, last: str, width: int) -> str:
    """A work-precision point's line after ``head``: its status where it did not run, else CPU
    ms, compile s, steps, error / a and ``p[last]`` in ``width`` columns."""
    if p.get("status") != "ok":
        return head + f" {p.get('status')}"
    comp = f"{p['compile_s']:.2f}" if "compile_s" in p else ""
    return (
        head + f" {1e3 * p['cpu_s']:>9.2f} {comp:>10} {p['steps']:>7} {_e(p['position_error']):>10} "
        f"{_e(p.get(last)):>{width}}"
    )


def verdict_lines(found: list) -> list[str]:
    """``targets:`` and a line per target: met, NOT met or skipped, the measured ratio, the note."""
    lines = ["  targets:"]
    for t in found:
        verdict = {True: "met", False: "NOT met", None: "skipped"}[t["met"]]
        measured = f": {t['measured']:.3g}" if t.get("measured") is not None else ""
        lines.append(f"    {verdict:>8}  {t['target']}{measured} ({t.get('note', '')})")
    return lines
