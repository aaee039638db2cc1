"""Rigid-body work against precision: attitude, angular-velocity and energy errors against CPU
time, emorbit beside Exudyn and Basilisk (``emorbit bench --only rigid-precision``).

Cases (:data:`CASES`):

* ``free2`` and ``free5``: the torque-free box 3 x 2 x 1 m (1 kg/m^3) tumbling near its
  intermediate axis (it flips) from omega0 = (0.01, 2, 0.01) and (0.01, 5, 0.01) rad/s (body
  frame), identity attitude, over :data:`T_FREE` s;
* ``leo``: the 2 x 1 x 0.5 m, 500 kg box of :func:`emorbit.bench.rigid_cases.leo_sim` (8 mass
  points, ``gravity="volume"``) in a 7000 km circular Earth orbit, over :data:`T_LEO` =
  12,000 s (2.06 orbits: a whole number of every step, in whole nanoseconds for Basilisk).

Engines, each a series of settings from coarse to fine:

* emorbit em and midpoint at orders 2, 4, 6 and 8 (compositions of the second-order step),
  and tfe at orders 4 to 12 (one implicit solve of 2 to 6 Gauss stages per step,
  :mod:`emorbit.kernels.rigid_tfe`), fixed step dt;
* Exudyn (torque-free only; it has no gravity gradient): generalized-alpha (its default
  spectral radius) with rotation-vector and with Euler-parameter nodes, and its explicit RK44
  (rotation-vector node, Lie-group integration; Exudyn refuses explicit solvers on
  Euler-parameter nodes, whose constraint is algebraic), fixed step dt;
* Basilisk: a ``Spacecraft`` hub with the box's mass and inertia (torque-free: no gravity; in
  the field: point-mass Earth gravity with its first-order ``GravityGradientEffector``), RK4
  at fixed dt and RKF78 at relative tolerances (absolute tolerance 1e-3 of it) inside task
  steps of :data:`RKF78_TASK`.

Reference: scipy's DOP853 at rtol = 1e-13 (``atol`` 1e-13 of each component's scale) on the
same body: Euler's equations with dR/dt = R [omega]x torque-free; in the field, the orbit and
the attitude under the same 8 mass-point volume gravity as emorbit's (force and torque summed
over the points). Basilisk integrates first-order gravity gradient instead: its model floor,
the attitude and omega difference between DOP853 on that model and on the 8 points, is
measured and printed; the reference's own error is estimated as its difference from DOP853 at
rtol = 1e-12.

Errors, at the end of the run: the attitude error, the rotation angle of R_ref^T R (rad), and
the omega error, |omega - omega_ref| / |omega_ref| (body frame); and the energy error, the
largest |E / E(0) - 1| over :data:`RECORDS` records of the run (the kinetic energy; in the
field the translational and rotational kinetic energy plus the 8-point potential, computed
for every engine from its own states). CPU time (``time.process_time``) of the run alone
(set-up excluded, the best of three below 50 ms), recorded in a second, untimed run; a case's
``fixed_cpu_s`` is that of a one-step em run: what any run pays beyond its steps.

A run estimated from the one before in its series to take over the configuration's
``max_run_s`` is skipped. Targets (:func:`targets`): at each attitude error of
:data:`ACCURACIES`, the least CPU time of each engine (:func:`reach`: the cheapest point or a
log-log interpolation between neighbouring settings of one series, the
:func:`emorbit.bench.workprecision.reach` rule), and the best em order within
:data:`LIMIT` times the best Exudyn or Basilisk configuration that reaches it; and the energy
error of every em point at round-off (:data:`emorbit.bench.rigid.ROUND_OFF`). A peer that is
not installed (``pip install "emorbit[rigid-peers]"``) or fails is reported as
``"skipped: <reason>"``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import partial

import numpy as np

from ..integrators import TFE_ORDERS
from .rigid import ROUND_OFF, _Basilisk, _Exudyn
from .rigid_cases import (
    FAST_OMEGA,
    FREE_BOX,
    FREE_OMEGA,
    LEO_BOX,
    LEO_RATE_OFFSET,
    LEO_ROTATION_VECTOR,
    R_ORBIT,
    box_inertia,
    earth_field,
    free_sim,
    leo_sim,
    mrp_to_dcm,
    orbit_rate,
)
from .timing import best_cpu, loadavg, machine, package_version
from .workprecision import _pareto
from .workprecision import reach as _reach_series

__all__ = ["CASES", "CONFIGS", "ACCURACIES", "LIMIT", "run", "table", "plot", "reach", "targets"]
__all__ += ["attitude_angle", "series_name"]

#: the attitude errors (rad) of the targets table
ACCURACIES = (1e-4, 1e-7, 1e-10)
#: em's CPU time over the best peer's at the same attitude error, at most
LIMIT = 1.0
#: length of the torque-free runs, s
T_FREE = 20.0
#: length of the field case, s (2.06 orbits)
T_LEO = 12000.0
#: records of the untimed run that gives the energy error
RECORDS = 100
#: the reference's relative tolerance
REFERENCE_RTOL = 1e-13
#: Basilisk RKF78's task step (the adaptive steps run inside it), s, by case kind
RKF78_TASK = {"free": 1.0, "field": 600.0}
#: the cases: kind, initial body-frame angular velocity (torque-free) and the step sizes (s)
#: that the fixed-step engines try, coarsest first
CASES = {
    "free2": {
        "kind": "free",
        "omega": FREE_OMEGA,
        "dts": (0.4, 0.2, 0.1, 0.05, 0.02, 0.01, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4),
    },
    "free5": {
        "kind": "free",
        "omega": FAST_OMEGA,
        "dts": (0.16, 0.08, 0.04, 0.02, 8e-3, 4e-3, 2e-3, 8e-4, 4e-4, 2e-4, 8e-5),
    },
    "leo": {"kind": "field", "dts": (1200.0, 600.0, 300.0, 120.0, 60.0, 30.0, 10.0, 5.0, 2.0)},
}
EM_METHODS = ("em", "midpoint", "tfe")
ORDERS = (2, 4, 6, 8)
#: the orders each method runs at (tfe: its Gauss stages times 2)
METHOD_ORDERS = {"em": ORDERS, "midpoint": ORDERS, "tfe": TFE_ORDERS}


def series_name(method: str, order: int) -> str:
    """How the section names emorbit's series: ``"em 4"``, ``"tfe 6 (one solve, 3 stages)"``."""
    return f"tfe {order} (one solve, {order // 2} stages)" if method == "tfe" else f"{method} {order}"


@dataclass(frozen=True)
class Config:
    """What one configuration of the section measures (see :data:`CONFIGS`)."""

    cases: tuple  # names of CASES
    every: int  # take every k-th step size of a case
    max_run_s: float  # a run estimated to take longer is skipped
    rkf78_tolerances: tuple
    orders: tuple = tuple(sorted(set(ORDERS) | set(TFE_ORDERS)))  # each method runs those of its own


#: "full", "quick" (``emorbit bench --quick``) and "tiny" (a smoke run for the tests)
CONFIGS = {
    "full": Config(("free2", "free5", "leo"), 1, 2.0, (1e-4, 1e-6, 1e-8, 1e-10, 1e-12)),
    "quick": Config(("free2", "free5", "leo"), 2, 0.25, (1e-5, 1e-8, 1e-11)),
    "tiny": Config(("free2", "leo"), 3, 0.02, (1e-6,), orders=(2, 4)),
}


# -- reference -------------------------------------------------------------------------------
def _hat(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def attitude_angle(R_ref, R) -> float:
    """The rotation angle of R_ref^T R, rad (accurate at small angles: atan2 of the skew part
    against the trace).

    Parameters
    ----------
    R_ref, R : array_like
        (3, 3) rotation matrices.

    Returns
    -------
    float
        The angle in [0, pi].
    """
    A = np.asarray(R_ref, float).T @ np.asarray(R, float)
    s = 0.5 * math.sqrt((A[2, 1] - A[1, 2]) ** 2 + (A[0, 2] - A[2, 0]) ** 2 + (A[1, 0] - A[0, 1]) ** 2)
    return math.atan2(s, 0.5 * (np.trace(A) - 1.0))


class _Body:
    """One case's body: initial state, inertia, mass points (field) and its energy."""

    def __init__(self, name: str):
        case = CASES[name]
        self.name, self.kind = name, case["kind"]
        if self.kind == "free":
            self.inertia = box_inertia(**FREE_BOX)
            self.mass = FREE_BOX["density"] * float(np.prod(FREE_BOX["size"]))
            self.R0, self.w0 = np.eye(3), np.asarray(case["omega"], float)
            self.t_end = T_FREE
            return
        from ..bodies.rotations import rotation_vector_to_matrix

        points = leo_sim(1, 60.0).rigid.points[0]
        self.X, self.m = np.asarray(points.X, float), np.asarray(points.m, float)  # (3, 8) body frame, kg
        self.inertia = box_inertia(**LEO_BOX)
        self.mass = float(self.m.sum())
        self.gm = earth_field().gm
        n = orbit_rate(self.gm)
        self.R0 = rotation_vector_to_matrix(np.array(LEO_ROTATION_VECTOR))
        self.w0 = self.R0.T @ np.array([LEO_RATE_OFFSET[0], LEO_RATE_OFFSET[1], n + LEO_RATE_OFFSET[2]])
        self.r0 = np.array([R_ORBIT, 0.0, 0.0])
        self.v0 = np.array([0.0, math.sqrt(self.gm / R_ORBIT), 0.0])
        self.t_end = T_LEO

    def energy(self, w, R=None, r=None, v=None) -> np.ndarray:
        """Energy per record: w (n, 3) body frame; in the field also R (n, 3, 3) body to space,
        r and v (n, 3)."""
        e = 0.5 * np.einsum("ni,ij,nj->n", w, self.inertia, w)
        if self.kind == "field":
            s = r[:, :, None] + R @ self.X  # (n, 3, 8) the mass points in space
            e = (
                e
                + 0.5 * self.mass * np.einsum("ni,ni->n", v, v)
                - self.gm * (self.m / np.linalg.norm(s, axis=1)).sum(1)
            )
        return e

    def _rhs(self, model: str):
        Iinv, inertia = np.linalg.inv(self.inertia), self.inertia
        if self.kind == "free":

            def f(_, y):
                w, R = y[:3], y[3:].reshape(3, 3)
                return np.concatenate([Iinv @ np.cross(inertia @ w, w), (R @ _hat(w)).ravel()])

            return f
        gm, X, m, mass = self.gm, self.X, self.m, self.mass

        def f(_, y):
            r, v, R, w = y[:3], y[3:6], y[6:15].reshape(3, 3), y[15:]
            d2 = float(r @ r)
            if model == "volume":  # each point's pull less the centre's, without cancellation
                p = R @ X  # (3, 8)
                q = (2.0 * (r @ p) + np.einsum("ij,ij->j", p, p)) / d2
                inv3 = d2**-1.5
                dacc = -gm * inv3 * (p * (1.0 + q) ** -1.5 + r[:, None] * np.expm1(-1.5 * np.log1p(q)))
                force = -gm * mass * inv3 * r + dacc @ m
                tau = R.T @ (np.cross(p.T, dacc.T) * m[:, None]).sum(0)
            else:  # point-mass force on the centre of mass, first-order gravity-gradient torque
                force = -gm * mass * r * d2**-1.5
                rb = R.T @ r
                tau = 3.0 * gm * d2**-2.5 * np.cross(rb, inertia @ rb)
            dw = Iinv @ (np.cross(inertia @ w, w) + tau)
            return np.concatenate([v, force / mass, (R @ _hat(w)).ravel(), dw])

        return f

    def reference(self, rtol: float = REFERENCE_RTOL, model: str = "volume") -> dict:
        """The end state by DOP853 at ``rtol``: R (body to space), w (body frame)."""
        from scipy.integrate import solve_ivp

        wscale = max(float(np.linalg.norm(self.w0)), 1e-300)
        if self.kind == "free":
            y0 = np.concatenate([self.w0, self.R0.ravel()])
            scale = np.concatenate([np.full(3, wscale), np.ones(9)])
        else:
            y0 = np.concatenate([self.r0, self.v0, self.R0.ravel(), self.w0])
            scale = np.concatenate([np.full(3, R_ORBIT), np.full(3, self.v0[1]), np.ones(9), np.full(3, wscale)])
        sol = solve_ivp(self._rhs(model), (0.0, self.t_end), y0, method="DOP853", rtol=rtol, atol=rtol * scale)
        y = sol.y[:, -1]
        if self.kind == "free":
            return {"w": y[:3], "R": y[3:].reshape(3, 3), "nfev": int(sol.nfev)}
        return {"w": y[15:], "R": y[6:15].reshape(3, 3), "r": y[:3], "nfev": int(sol.nfev)}

    def errors(self, R, w, energies=None) -> dict:
        """Attitude and omega errors at the end (against ``ref``), and the energy error."""
        out = {
            "attitude_error": attitude_angle(self.ref["R"], R),
            "omega_error": float(np.linalg.norm(np.asarray(w) - self.ref["w"]) / np.linalg.norm(self.ref["w"])),
        }
        if energies is not None:
            energies = np.asarray(energies, float)
            out["energy_error"] = float(np.max(np.abs(energies / energies[0] - 1.0)))
        return out


# -- the engines -----------------------------------------------------------------------------
def _emorbit(body: _Body, method: str, order: int, dt: float) -> dict:
    from ..bodies.rotations import quaternion_to_matrix

    steps = max(1, int(round(body.t_end / dt)))

    def setup():
        if body.kind == "free":
            return free_sim(dt, body.w0, method=method, order=order)
        return leo_sim(1, dt, order=order, method=method)

    cpu = best_cpu(lambda sim: sim.run(steps=steps, every=steps, keep=False), setup)[1]
    every = max(1, steps // RECORDS)
    res = setup().run(steps=steps, every=every).si
    R = quaternion_to_matrix(res.attitudes["box"][-1])
    out = {"cpu_s": cpu, "steps": steps, **body.errors(R, res.angular_velocities["box"][-1])}
    out["energy_error"] = float(np.abs(res.relative_energy_error()).max())  # emorbit's own energy
    out["angular_momentum_error"] = float(res.relative_angular_momentum_error().max())
    return out


def _exudyn(ex, body: _Body, solver: str, node: str, dt: float) -> dict:
    exu = ex.exu
    steps = max(1, int(round(body.t_end / dt)))
    kind = exu.DynamicSolverType.RK44 if solver == "RK44" else exu.DynamicSolverType.GeneralizedAlpha

    def setup(sensors=False):
        with ex.quiet():
            mbs, ss, _, inertia, sens = ex.build(dt, steps, node, body.w0, "generalized-alpha", sensors)
        if sensors:
            ss.solution.sensors.writePeriod = body.t_end / RECORDS
        return mbs, ss, sens

    def go(state):
        with ex.quiet():
            ok, msg = ex.solve(state[0], state[1], kind)
        if not ok:
            raise RuntimeError(msg)

    cpu = best_cpu(go, setup)[1]
    mbs, ss, sens = setup(True)
    go((mbs, ss))
    w = np.asarray(mbs.GetSensorStoredData(sens[0]))[:, 1:4]
    R = np.asarray(mbs.GetSensorStoredData(sens[1]))[:, 1:10].reshape(-1, 3, 3)  # row-major, body to space
    return {"cpu_s": cpu, "steps": steps, **body.errors(R[-1], w[-1], body.energy(w))}


def _bsk_build(bsk, body: _Body, integrator: str, dt: float, tol, record_dt):
    GravityGradientEffector, spacecraft, SimulationBaseClass, macros, simIncludeGravBody = bsk.mods
    from Basilisk.simulation import svIntegrators

    sim = SimulationBaseClass.SimBaseClass()
    sim.keep = []  # Python objects the C++ side points to, alive as long as the simulation
    sim.CreateNewProcess("dynamics").addTask(sim.CreateNewTask("task", macros.sec2nano(dt)))
    sc = spacecraft.Spacecraft()
    sc.ModelTag = "box"
    sc.hub.mHub = body.mass
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = body.inertia.tolist()
    if integrator == "RKF78":
        integ = svIntegrators.svIntegratorRKF78(sc)
        integ.relTol, integ.absTol = tol, 1e-3 * tol
        sc.setIntegrator(integ)
        sim.keep.append(integ)
    sim.AddModelToTask("task", sc)
    if body.kind == "field":
        grav = simIncludeGravBody.gravBodyFactory()
        earth = grav.createCustomGravObject("earth", body.gm)
        earth.isCentralBody = True
        grav.addBodiesTo(sc)
        sc.hub.r_CN_NInit = [[float(x)] for x in body.r0]
        sc.hub.v_CN_NInit = [[float(x)] for x in body.v0]
        gg = GravityGradientEffector.GravityGradientEffector()
        gg.ModelTag = "gravityGradient"
        gg.addPlanetName(earth.planetName)
        sc.addDynamicEffector(gg)
        sim.AddModelToTask("task", gg)
        sim.keep += [grav, gg]
    rv = _rotation_vector(body.R0)
    th = float(np.linalg.norm(rv))
    sigma = rv * (math.tan(th / 4) / th if th > 0 else 0.25)  # MRP of the body frame: [BN] = R^T
    sc.hub.sigma_BNInit = [[float(x)] for x in sigma]
    sc.hub.omega_BN_BInit = [[float(x)] for x in body.w0]
    rec = None
    if record_dt:
        rec = sc.scStateOutMsg.recorder(macros.sec2nano(record_dt))
        sim.AddModelToTask("task", rec)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(macros.sec2nano(body.t_end))
    return sim, rec


def _rotation_vector(R) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(R).as_rotvec()


def _basilisk(bsk, body: _Body, integrator: str, dt: float, tol=None) -> dict:
    cpu = best_cpu(lambda sim: sim.ExecuteSimulation(), lambda: _bsk_build(bsk, body, integrator, dt, tol, None)[0])[1]
    steps = max(1, int(round(body.t_end / dt)))
    every = max(1, steps // RECORDS)
    while steps % every:  # records that land on the end
        every -= 1
    sim, rec = _bsk_build(bsk, body, integrator, dt, tol, dt * every)
    sim.ExecuteSimulation()
    w = np.asarray(rec.omega_BN_B)
    R = np.swapaxes(mrp_to_dcm(rec.sigma_BN), -1, -2)
    t_last = float(rec.times()[-1]) * 1e-9
    if abs(t_last - body.t_end) > 1e-6 * body.t_end:
        raise RuntimeError(f"the last record is at t = {t_last} s, not t_end = {body.t_end} s")
    e = body.energy(w, R, np.asarray(rec.r_BN_N), np.asarray(rec.v_BN_N))
    return {"cpu_s": cpu, "steps": steps, **body.errors(R[-1], w[-1], e)}


# -- one case --------------------------------------------------------------------------------
def _series_runs(points, label: dict, settings, key, fn, max_run_s) -> None:
    """Run one series (coarse to fine), skipping a run estimated to exceed ``max_run_s``."""
    per_unit = None
    for s in settings:
        p = {**label, key: s}
        units = 1.0 / s  # steps (dt) or a rough ~1/tol^(1/8) for tolerances; an estimate only
        if key == "tolerance":
            units = s ** (-1.0 / 8.0)
        if per_unit is not None and per_unit * units > max_run_s:
            p["status"] = f"skipped: estimated over {max_run_s:g} s"
            points.append(p)
            continue
        try:
            p.update(fn(s))
            finite = all(math.isfinite(p[k]) for k in ("attitude_error", "omega_error", "energy_error"))
            p["status"] = "ok" if finite else "diverged"
            per_unit = p["cpu_s"] / units
        except Exception as exc:  # noqa: BLE001 - a failed run is kept as a failed point
            p["status"] = f"failed: {type(exc).__name__}: {str(exc)[:160]}"
        points.append(p)


def _case(name: str, cfg: Config, ex: _Exudyn, bsk: _Basilisk) -> dict:
    body = _Body(name)
    t0 = time.process_time()
    body.ref = body.reference()
    ref_cpu = time.process_time() - t0
    check = body.reference(rtol=10 * REFERENCE_RTOL)
    reference = {
        "method": f"scipy DOP853, rtol {REFERENCE_RTOL:g}",
        "cpu_s": ref_cpu,
        "evaluations": body.ref["nfev"],
        "attitude_check": attitude_angle(body.ref["R"], check["R"]),
        "omega_check": float(np.linalg.norm(check["w"] - body.ref["w"]) / np.linalg.norm(body.ref["w"])),
    }
    dts = CASES[name]["dts"][:: cfg.every]
    one = (lambda: free_sim(0.01, body.w0)) if body.kind == "free" else (lambda: leo_sim(1, 60.0))
    one().run(steps=1, every=1, keep=False)
    # what any run pays beyond its steps: the start and end records, the drift check, the result
    fixed = best_cpu(lambda sim: sim.run(steps=1, every=1, keep=False), one)[1]
    points = []
    for method in EM_METHODS:
        for order in (o for o in cfg.orders if o in METHOD_ORDERS[method]):
            warm = (
                free_sim(0.01, body.w0, method, order)
                if body.kind == "free"
                else leo_sim(1, 60.0, order=order, method=method)
            )
            warm.run(steps=2, every=2, keep=False)  # warm-up: compile or load the kernel
            label = {"engine": "emorbit", "method": method, "order": order, "series": series_name(method, order)}
            _series_runs(
                points, label, dts, "dt", lambda dt, m=method, o=order: _emorbit(body, m, o, dt), cfg.max_run_s
            )
    peers = {}
    if body.kind == "free":
        peers["exudyn"] = ex.skipped or "ok"
        if not ex.skipped:
            for solver, node in (("generalized-alpha", "rotation-vector"), ("generalized-alpha", "euler-parameters")):
                label = {"engine": "exudyn", "method": solver, "node": node, "series": f"Exudyn {solver}, {node}"}
                _series_runs(
                    points, label, dts, "dt", lambda dt, s=solver, n=node: _exudyn(ex, body, s, n, dt), cfg.max_run_s
                )
            label = {"engine": "exudyn", "method": "RK44", "node": "rotation-vector", "series": "Exudyn RK44"}
            _series_runs(
                points, label, dts, "dt", lambda dt: _exudyn(ex, body, "RK44", "rotation-vector", dt), cfg.max_run_s
            )
    else:
        body.model_floor = body.reference(model="gradient")
        reference["gradient_model_floor"] = {
            "attitude": attitude_angle(body.ref["R"], body.model_floor["R"]),
            "omega": float(np.linalg.norm(body.model_floor["w"] - body.ref["w"]) / np.linalg.norm(body.ref["w"])),
        }
    peers["basilisk"] = bsk.skipped or "ok"
    if not bsk.skipped:
        label = {"engine": "basilisk", "method": "RK4", "series": "Basilisk RK4"}
        _series_runs(points, label, dts, "dt", lambda dt: _basilisk(bsk, body, "RK4", dt), cfg.max_run_s)
        task = RKF78_TASK[body.kind]
        label = {"engine": "basilisk", "method": "RKF78", "series": "Basilisk RKF78", "task_dt": task}
        go = partial(_basilisk, bsk, body, "RKF78", task)
        _series_runs(points, label, cfg.rkf78_tolerances, "tolerance", go, cfg.max_run_s)
    good = [p for p in points if p.get("status") == "ok"]
    for p in points:
        p["pareto_attitude"] = p["pareto_omega"] = False
    for key, flag in (("attitude_error", "pareto_attitude"), ("omega_error", "pareto_omega")):
        for i in _pareto(good, key):
            good[i][flag] = True
    out = {
        "name": name,
        "kind": body.kind,
        "t_end": body.t_end,
        "omega0_body": body.w0.tolist(),
        "reference": reference,
        "fixed_cpu_s": fixed,
        "peers": peers,
        "points": points,
    }
    out["reach"] = [{"accuracy": a, "engines": {g: reach(points, g, a) for g in GROUPS}} for a in ACCURACIES]
    for row in out["reach"]:
        em = row["engines"]["em"]
        best = [r for g, r in row["engines"].items() if g in ("exudyn", "basilisk") and r is not None]
        peer = min(best, key=lambda r: r["cpu_s"]) if best else None
        row["best_peer"] = peer
        row["em_over_best_peer"] = None if em is None or peer is None else em["cpu_s"] / peer["cpu_s"]
    return out


#: the groups of the targets table: which points each takes (its best series wins)
GROUPS = {
    "em": lambda p: p["engine"] == "emorbit" and p["method"] in ("em", "tfe"),
    "tfe": lambda p: p["engine"] == "emorbit" and p["method"] == "tfe",
    "midpoint": lambda p: p["engine"] == "emorbit" and p["method"] == "midpoint",
    "exudyn": lambda p: p["engine"] == "exudyn",
    "basilisk": lambda p: p["engine"] == "basilisk",
}


def reach(points: list, group: str, accuracy: float, key: str = "attitude_error") -> dict | None:
    """The least CPU time at which a group of :data:`GROUPS` reaches an error.

    The rule of :func:`emorbit.bench.workprecision.reach` (the cheapest point with an error
    <= ``accuracy``, or the log-log interpolation between two neighbouring settings of one
    series that bracket it; nothing extrapolated), applied to each series of the group.

    Parameters
    ----------
    points : list of dict
        A case's ``points``.
    group : str
        A key of :data:`GROUPS`.
    accuracy : float
        The error to reach (rad for the attitude error).
    key : str
        The error: ``"attitude_error"`` or ``"omega_error"``.

    Returns
    -------
    dict or None
        ``cpu_s``, ``series`` (the engine and configuration), ``setting`` (dt, s, or the
        tolerance) and, when interpolated, ``between`` (the coarser and the finer setting);
        None when no point gets there.
    """
    if group not in GROUPS:
        raise KeyError(f"group: {group!r} is not one of {sorted(GROUPS)}")
    names, pseudo = [], []
    for p in points:
        if p.get("status") != "ok" or not GROUPS[group](p):
            continue
        if p["series"] not in names:
            names.append(p["series"])
        setting = p.get("dt", p.get("tolerance"))  # larger is coarser either way
        pseudo.append(
            {
                "engine": "emorbit",
                "method": "em",
                "order": names.index(p["series"]),
                "dt": setting,
                "position_error": p[key],
                "cpu_s": p["cpu_s"],
                "status": "ok",
            }
        )
    best = _reach_series(pseudo, "em fixed", accuracy)
    if best is None:
        return None
    out = {"cpu_s": best["cpu_s"], "series": names[best["order"]], "setting": best["setting"]}
    if "between" in best:
        out["between"] = best["between"]
    return out


def targets(section: dict) -> list:
    """The section's targets: per case and attitude error of :data:`ACCURACIES`, em's best
    order within :data:`LIMIT` times the best Exudyn or Basilisk configuration's CPU time
    (``met`` None where no peer, or em, reaches it); and every em point's energy error at
    round-off.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.

    Returns
    -------
    list of dict
        ``target``, ``met`` and, where measured, ``measured``, ``limit`` and ``note``.
    """
    out = []
    for case in section["cases"]:
        for row in case["reach"]:
            t = {
                "target": f"rigid {case['name']}: em (best order or tfe) CPU time to an attitude error of "
                f"{row['accuracy']:g} rad <= {LIMIT:g}x the best Exudyn/Basilisk configuration's",
                "limit": LIMIT,
                "met": None,
            }
            em, peer = row["engines"]["em"], row["best_peer"]
            if peer is None:
                skipped = [f"{k}: {v}" for k, v in case["peers"].items() if v != "ok"]
                t["note"] = "no peer reaches it" + (f" ({'; '.join(skipped)})" if skipped else "")
            elif em is None:
                t.update(met=False, note=f"em does not reach it; {peer['series']} does in {1e3 * peer['cpu_s']:.2f} ms")
            else:
                r = row["em_over_best_peer"]
                t.update(measured=r, met=r <= LIMIT)
                t["note"] = f"{em['series']} {1e3 * em['cpu_s']:.2f} ms, {peer['series']} {1e3 * peer['cpu_s']:.2f} ms"
            out.append(t)
    em = [p for c in section["cases"] for p in c["points"] if GROUPS["em"](p) and p.get("status") == "ok"]
    worst = max((p["energy_error"] for p in em), default=None)
    out.append(
        {
            "target": "rigid work-precision: energy error of every em and tfe point at round-off",
            "measured": worst,
            "limit": ROUND_OFF,
            "met": None if worst is None else worst <= ROUND_OFF,
            "note": f"{len(em)} points",
        }
    )
    return out


def run(quick: bool = True, *, config: str | None = None) -> dict:
    """Measure the section: every case, every engine, the targets.

    Parameters
    ----------
    quick : bool
        The quick configuration instead of the full one.
    config : str, optional
        ``"full"``, ``"quick"`` or ``"tiny"`` (a smoke run for the tests); overrides ``quick``.

    Returns
    -------
    dict
        JSON-ready: ``config``, ``machine``, ``versions``, ``cases`` (per case its
        ``reference``, ``peers`` (status by peer), ``points`` and ``reach``, the least CPU
        time of each group at each of :data:`ACCURACIES`) and ``targets``.
    """
    name = config or ("quick" if quick else "full")
    if name not in CONFIGS:
        raise KeyError(f"config: {name!r} is not one of {sorted(CONFIGS)}")
    cfg = CONFIGS[name]
    ex, bsk = _Exudyn(), _Basilisk()
    load_before = loadavg()
    t0 = time.perf_counter()
    cases = [_case(c, cfg, ex, bsk) for c in cfg.cases]
    section = {
        "name": "rigid-precision",
        "config": name,
        "machine": machine(),
        "load_average": {"before": load_before, "after": loadavg()},
        "versions": {"exudyn": package_version("exudyn"), "bsk": package_version("bsk")},
        "exudyn_module": None if ex.skipped else ex.module,
        "case": (
            f"end-of-run attitude error (rad) and omega error against DOP853 (rtol {REFERENCE_RTOL:g}), "
            f"max |dE/E| over {RECORDS} records, CPU time of the run; torque-free box {FREE_BOX['size']} m "
            f"over {T_FREE:g} s; the box {LEO_BOX['size']} m with 8 mass points over {T_LEO:g} s "
            f"({T_LEO * orbit_rate(earth_field().gm) / (2 * math.pi):.2f} orbits) at "
            f"{R_ORBIT / 1e3:g} km"
        ),
        "round_off": ROUND_OFF,
        "cases": cases,
    }
    section["targets"] = targets(section)
    section["seconds"] = round(time.perf_counter() - t0, 1)
    return section


# -- printing and the figure -------------------------------------------------------------------
def _e(x) -> str:
    return "-" if x is None else f"{x:.1e}"


def _ms(r) -> str:
    return "-" if r is None else f"{1e3 * r['cpu_s']:.2f} ms ({r['series']})"


def point_setting(p: dict) -> str:
    """A point's setting as the tables name it: dt (s) or a tolerance (with its task step)."""
    if "tolerance" in p:
        return f"rtol {p['tolerance']:g} (task {p['task_dt']:g} s)"
    return f"dt {p['dt']:g} s"


def table(section: dict) -> list[str]:
    """The section as printable lines: per case the reference, each series' points, the
    least CPU time of each group at each attitude error; then the targets.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.

    Returns
    -------
    list of str
        The lines of the table.
    """
    m = section["machine"]
    lines = [
        f"rigid work-precision ({section['config']}): {m['cpu']}, {m['cores']} cores; load average "
        f"{section['load_average']['before']} -> {section['load_average']['after']}; {section['seconds']} s",
        f"  {section['case']}",
    ]
    for case in section["cases"]:
        ref = case["reference"]
        lines.append(
            f"  {case['name']} ({case['kind']}, omega0 = {[round(x, 6) for x in case['omega0_body']]} rad/s body, "
            f"{case['t_end']:g} s): reference {ref['method']}, {1e3 * ref['cpu_s']:.0f} ms; its difference from "
            f"rtol 1e-12: attitude {ref['attitude_check']:.1e} rad, omega {ref['omega_check']:.1e}"
        )
        if "gradient_model_floor" in ref:
            f = ref["gradient_model_floor"]
            lines.append(
                f"    first-order gravity gradient (Basilisk's model) against the 8 points, both DOP853: attitude "
                f"{f['attitude']:.1e} rad, omega {f['omega']:.1e} (Basilisk's model floor)"
            )
        lines.append(f"    emorbit's fixed cost per run (one em step, its records): {1e3 * case['fixed_cpu_s']:.2f} ms")
        for peer, status in case["peers"].items():
            if status != "ok":
                lines.append(f"    {peer}: {status}")
        lines.append(f"    {'series':<42} {'setting':<24} {'CPU ms':>9} {'attitude':>8} {'omega':>8} {'|dE/E|':>8}")
        for p in case["points"]:
            head = f"    {p['series']:<42} {point_setting(p):<24}"
            if p.get("status") != "ok":
                lines.append(head + f" {p.get('status')}")
                continue
            lines.append(
                head + f" {1e3 * p['cpu_s']:>9.2f} {_e(p['attitude_error']):>8} {_e(p['omega_error']):>8} "
                f"{_e(p['energy_error']):>8}" + (" *" if p["pareto_attitude"] else "")
            )
        lines.append("    least CPU time to an attitude error (* above: the Pareto front)")
        for row in case["reach"]:
            ratio = row["em_over_best_peer"]
            cells = ", ".join(f"{g} {_ms(r)}" for g, r in row["engines"].items())
            lines.append(
                f"      {row['accuracy']:<6g} {cells}; em / best peer: " + ("-" if ratio is None else f"{ratio:.2f}x")
            )
    lines.append("  targets:")
    for t in section["targets"]:
        verdict = {True: "met", False: "NOT met", None: "skipped"}[t["met"]]
        measured = f": {t['measured']:.3g}" if t.get("measured") is not None else ""
        lines.append(f"    {verdict:>8}  {t['target']}{measured} ({t.get('note', '')})")
    return lines


_COLORS = {"em": "Blues", "midpoint": "Greens", "tfe": "Reds"}
_PEERS = {
    "Exudyn generalized-alpha, rotation-vector": ("tab:red", "v", "-"),
    "Exudyn generalized-alpha, euler-parameters": ("tab:orange", "^", "-"),
    "Exudyn RK44": ("tab:purple", "x", "--"),
    "Basilisk RK4": ("tab:brown", "+", "--"),
    "Basilisk RKF78": ("black", "P", "-."),
}
_MARKERS = {2: "o", 4: "s", 6: "^", 8: "D", 10: "v", 12: "P"}


def plot(section: dict, path: str) -> None:
    """Draw the figure: one column per case; attitude error (top), omega error (middle) and
    energy error (bottom) against CPU time, every series that ran.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.
    path : str
        The PNG to write.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = section["cases"]
    fig, axes = plt.subplots(3, len(cases), figsize=(5.5 * len(cases), 12), constrained_layout=True, squeeze=False)
    labelled = set()
    for col, case in enumerate(cases):
        series = {}
        for p in case["points"]:
            if p.get("status") == "ok":
                series.setdefault(p["series"], []).append(p)
        for row, (key, label) in enumerate(
            (
                ("attitude_error", "attitude error at the end [rad]"),
                ("omega_error", "|omega - omega_ref| / |omega_ref| at the end"),
                ("energy_error", "max |dE/E| over the run"),
            )
        ):
            ax = axes[row, col]
            for name, pts in series.items():
                pts = sorted(pts, key=lambda p: p["cpu_s"])
                if pts[0]["engine"] == "emorbit":
                    color = matplotlib.colormaps[_COLORS[pts[0]["method"]]](0.35 + 0.65 * (pts[0]["order"] - 2) / 10)
                    marker = _MARKERS[pts[0]["order"]]
                    ls = {"em": "-", "tfe": "--"}.get(pts[0]["method"], ":")
                else:
                    color, marker, ls = _PEERS.get(name, ("gray", ".", "-"))
                ax.loglog(
                    [p["cpu_s"] for p in pts],
                    [max(p[key], 1e-17) for p in pts],
                    ls=ls,
                    marker=marker,
                    color=color,
                    ms=5,
                    label=None if name in labelled else name,
                )
                labelled.add(name)
            if row == 0:
                for a in ACCURACIES:
                    ax.axhline(a, color="0.6", lw=0.8, ls=":")
                ax.set_title(f"{case['name']}: {case['kind']}, {case['t_end']:g} s", fontsize=10)
            ax.set_xlabel("CPU time of the run [s]")
            ax.set_ylabel(label)
            ax.grid(True, which="major", alpha=0.3)
    fig.legend(fontsize=7, ncol=4, loc="outside lower center")
    fig.suptitle("Rigid bodies: what accuracy costs (against DOP853 at rtol 1e-13; one thread)", fontsize=11)
    fig.savefig(path, dpi=90)
    plt.close(fig)
