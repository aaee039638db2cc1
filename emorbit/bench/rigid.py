"""Rigid-body rows of ``emorbit bench``: what a rigid-body step costs, beside Basilisk and
Exudyn in the same process. :func:`run` measures and returns a JSON-ready section,
:func:`table` prints it; the cases are in :mod:`emorbit.bench.rigid_cases`.

Timing is :mod:`emorbit.bench.timing`'s: a warm-up call, calls calibrated to a fixed length,
the engines of a row interleaved repeat by repeat; CPU and wall-clock time per step (Newton
included), medians; ratios are medians of the per-repeat CPU-time ratios.

1. Cost against mass points: the orbiting box refined into 8 r^3 mass points, em order 2,
   dt = 10 s, gravity ``"volume"`` (summed over the mass points: gravity-gradient torque)
   against ``"point"`` (all mass at the centre of mass). Cost per mass point: the slope of a
   straight-line fit and, row by row, (volume - point) / N.
2. The orbiting box with 8 mass points against Basilisk (``bsk``): a ``Spacecraft`` hub with
   the same mass, inertia and initial state, point-mass Earth gravity (same GM) and its
   first-order ``GravityGradientEffector``, RK4, at dt = 60 s and 10 s. Time per step and
   the drift of the rotational Jacobi integral (max over the run relative to |J(0)|);
   emorbit at orders 2 and 4 also reports its energy and angular-momentum errors.
3. The torque-free box (omega0 = (0.01, 2, 0.01) rad/s, body frame) against Exudyn's
   generalized-alpha solver (its default spectral radius) with Euler-parameter and
   rotation-vector nodes at dt = 2e-3 s and 1e-2 s; emorbit at those steps and 10x larger.
   Errors over 20 s: energy and angular momentum (max over every step, relative) and the
   body-frame angular velocity at the end against DOP853 on Euler's equations. Exudyn's
   trapezoidal rules (Newmark beta = 1/4, gamma = 1/2 with index-3 constraints, and
   ``TrapezoidalIndex2``) at dt = 1e-2 s on that tumble and a faster one (omega_y = 5
   rad/s): whether they converge, and their errors.
4. The bench's targets, as ratios within the run: a torque-free step <= 1x Exudyn's
   implicit step, with energy and angular momentum at round-off (:data:`ROUND_OFF`) at every
   dt; 8 mass points in the field <= 1x Basilisk's step; 1000 mass points <= 100 us per step
   and linear in the points.

A peer that is not installed (``pip install "emorbit[rigid-peers]"``) or that fails is
reported as ``"skipped: <reason>"``; the bench never stops for it. Exudyn's fast module
(``exudynCPPfast``: no range checks, AVX2) is used when nothing imported Exudyn before.
"""

from __future__ import annotations

import contextlib
import io
import math
import sys
import time
import warnings

import numpy as np

from .rigid_cases import (
    CONFIGS,
    EXUDYN_DTS,
    EXUDYN_NODES,
    FAST_OMEGA,
    FIELD_DTS,
    FREE_BOX,
    FREE_DTS,
    FREE_OMEGA,
    LEO_BOX,
    LEO_RATE_OFFSET,
    LEO_ROTATION_VECTOR,
    R_ORBIT,
    SCAN_DT,
    TRAPEZOIDAL_DT,
    Config,
    box_inertia,
    drift,
    earth_field,
    free_sim,
    jacobi,
    leo_sim,
    mrp_to_dcm,
    omega_reference,
    orbit_rate,
)
from .timing import CLOCK, clock, loadavg, machine, package_version, paired_ratio, since, timed

__all__ = ["run", "table", "CONFIGS", "ROUND_OFF"]

#: relative energy and angular-momentum error that counts as round-off (a target of the bench)
ROUND_OFF = 1e-12


class _EmorbitRunner:
    """``sim.run`` with one record at the end (the kernel takes all steps in one call); keeps
    the mean Newton iterations per step of each call."""

    def __init__(self, sim):
        self.sim = sim
        self.iterations = []

    def __call__(self, n: int) -> tuple:
        start = clock()
        res = self.sim.run(steps=n, every=n, keep=False)
        elapsed = since(start)
        self.iterations.append(float(res.newton_iterations[-1]))
        return elapsed

    def newton(self) -> float:
        return float(np.median(self.iterations[1:] or self.iterations))


def _scan(cfg: Config) -> dict:
    rows = []
    for r in cfg.refinements:
        runners = {g: _EmorbitRunner(leo_sim(r, SCAN_DT, g)) for g in ("volume", "point")}
        times = timed(runners, cfg)
        row = {"refinement": r, "mass_points": 8 * r**3}
        for g, runner in runners.items():
            row[g] = {**times[g], "newton_iterations": runner.newton()}
        row["us_per_point"] = (row["volume"][CLOCK] - row["point"][CLOCK]) / row["mass_points"]
        rows.append(row)
    npts = np.array([row["mass_points"] for row in rows], float)
    fit = {}
    for g in ("volume", "point"):
        us = np.array([row[g][CLOCK] for row in rows])
        slope, intercept = np.polyfit(npts, us, 1)
        fit[g] = {
            "us_per_point": float(slope),
            "intercept_us": float(intercept),
            "max_relative_residual": float(np.max(np.abs(us - (slope * npts + intercept)) / us)),
        }
    per_point = np.array([row["us_per_point"] for row in rows if row["mass_points"] >= 200])
    spread = float(per_point.max() / per_point.min()) if per_point.size > 1 else None
    return {
        "case": (
            f"box {LEO_BOX['size']} m, {LEO_BOX['density']:g} kg/m3 refined into 8 r^3 mass points, "
            f"em order 2, {R_ORBIT / 1e3:g} km circular Earth orbit, near long-axis-radial, turning at "
            f"about the orbit rate, dt = {SCAN_DT:g} s"
        ),
        "dt": SCAN_DT,
        "rows": rows,
        "fit": fit,
        "per_point_spread": spread,
    }


def _field_accuracy(order: int, dt: float, cfg: Config) -> dict:
    from ..bodies.rotations import quaternion_to_matrix

    sim = leo_sim(1, dt, order=order)
    n = orbit_rate(sim.gm)
    steps = max(1, int(round(cfg.orbits * 2 * math.pi / n / dt)))
    res = sim.run(steps=steps, every=1).si
    Rt = np.swapaxes(quaternion_to_matrix(res.attitudes["box"]), -1, -2)
    J = jacobi(sim.rigid.points[0].inertia, n, res.positions["box"], Rt, res.angular_velocities["box"])
    return {
        "accuracy_steps": steps,
        "energy_error": float(np.abs(res.relative_energy_error()).max()),
        "angular_momentum_error": float(res.relative_angular_momentum_error().max()),
        "jacobi_drift": drift(J),
    }


def _free_accuracy(dt: float, omega, cfg: Config) -> dict:
    res = free_sim(dt, omega).run(steps=int(round(cfg.t_free / dt)), every=1).si
    ref = omega_reference(box_inertia(**FREE_BOX), omega, cfg.t_free)
    return {
        "energy_error": float(np.abs(res.relative_energy_error()).max()),
        "angular_momentum_error": float(res.relative_angular_momentum_error().max()),
        "omega_error": float(np.abs(res.angular_velocities["box"][-1] - ref).max() / np.linalg.norm(ref)),
        "mean_newton_iterations": res.mean_newton_iterations(),
    }


# -- Basilisk --------------------------------------------------------------------------------


class _Basilisk:
    """The orbiting box as a Basilisk spacecraft; ``skipped`` says why if Basilisk is missing."""

    def __init__(self):
        self.skipped = None
        try:
            from Basilisk.simulation import GravityGradientEffector, spacecraft
            from Basilisk.utilities import SimulationBaseClass, macros, simIncludeGravBody
        except Exception as exc:  # noqa: BLE001 - any import failure means: skipped
            self.skipped = (
                f"skipped: Basilisk not importable ({type(exc).__name__}: {exc}); pip install 'emorbit[rigid-peers]'"
            )
            return
        self.mods = (GravityGradientEffector, spacecraft, SimulationBaseClass, macros, simIncludeGravBody)
        from ..bodies.rotations import rotation_vector_to_matrix

        self.gm = earth_field().gm
        self.n = orbit_rate(self.gm)
        self.inertia = box_inertia(**LEO_BOX)
        self.mass = LEO_BOX["density"] * float(np.prod(LEO_BOX["size"]))
        rv = np.array(LEO_ROTATION_VECTOR)
        th = float(np.linalg.norm(rv))
        self.sigma = math.tan(th / 4) * rv / th  # MRP of the body frame: [BN] = R^T
        R = rotation_vector_to_matrix(rv)
        self.w_body = R.T @ np.array([LEO_RATE_OFFSET[0], LEO_RATE_OFFSET[1], self.n + LEO_RATE_OFFSET[2]])

    def build(self, dt: float, record: bool):
        GravityGradientEffector, spacecraft, SimulationBaseClass, macros, simIncludeGravBody = self.mods
        sim = SimulationBaseClass.SimBaseClass()
        sim.CreateNewProcess("dynamics").addTask(sim.CreateNewTask("task", macros.sec2nano(dt)))
        sc = spacecraft.Spacecraft()
        sc.ModelTag = "box"
        sc.hub.mHub = self.mass
        sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
        sc.hub.IHubPntBc_B = self.inertia.tolist()
        sim.AddModelToTask("task", sc)
        grav = simIncludeGravBody.gravBodyFactory()
        earth = grav.createCustomGravObject("earth", self.gm)
        earth.isCentralBody = True
        grav.addBodiesTo(sc)
        sc.hub.r_CN_NInit = [[R_ORBIT], [0.0], [0.0]]
        sc.hub.v_CN_NInit = [[0.0], [math.sqrt(self.gm / R_ORBIT)], [0.0]]
        sc.hub.sigma_BNInit = [[float(x)] for x in self.sigma]
        sc.hub.omega_BN_BInit = [[float(x)] for x in self.w_body]
        gg = GravityGradientEffector.GravityGradientEffector()
        gg.ModelTag = "gravityGradient"
        gg.addPlanetName(earth.planetName)
        sc.addDynamicEffector(gg)
        sim.AddModelToTask("task", gg)
        rec = None
        if record:
            rec = sc.scStateOutMsg.recorder(macros.sec2nano(dt))
            sim.AddModelToTask("task", rec)
        sim.InitializeSimulation()
        return sim, rec

    def runner(self, dt: float):
        macros = self.mods[3]

        def steps(k: int) -> tuple:
            sim, _ = self.build(dt, False)  # set-up not timed
            sim.ConfigureStopTime(macros.sec2nano(dt * k))
            start = clock()
            sim.ExecuteSimulation()
            return since(start)

        return steps

    def accuracy(self, dt: float, cfg: Config) -> dict:
        k = max(1, int(round(cfg.orbits * 2 * math.pi / self.n / dt)))
        sim, rec = self.build(dt, True)
        sim.ConfigureStopTime(self.mods[3].sec2nano(dt * k))
        sim.ExecuteSimulation()
        J = jacobi(self.inertia, self.n, np.asarray(rec.r_BN_N), mrp_to_dcm(rec.sigma_BN), np.asarray(rec.omega_BN_B))
        return {"accuracy_steps": k, "jacobi_drift": drift(J)}


# -- Exudyn ----------------------------------------------------------------------------------
class _Exudyn:
    """The torque-free box in Exudyn; ``skipped`` says why if Exudyn is missing."""

    def __init__(self):
        self.skipped = None
        try:
            if "exudyn" not in sys.modules and not hasattr(sys, "exudynFast"):
                sys.exudynFast = True  # its fast module, when nothing imported Exudyn before
            with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                import exudyn as exu
                from exudyn.itemInterface import SensorNode
                from exudyn.utilities import InertiaCuboid
        except Exception as exc:  # noqa: BLE001
            self.skipped = (
                f"skipped: Exudyn not importable ({type(exc).__name__}: {exc}); pip install 'emorbit[rigid-peers]'"
            )
            return
        self.exu, self.SensorNode, self.InertiaCuboid = exu, SensorNode, InertiaCuboid
        self.module = "exudynCPPfast" if "exudyn.exudynCPPfast" in sys.modules else "exudynCPP"
        self.nodes = {
            "euler-parameters": exu.NodeType.RotationEulerParameters,
            "rotation-vector": exu.NodeType.RotationRotationVector,
        }
        self.spectral_radius = float(exu.SimulationSettings().timeIntegration.generalizedAlpha.spectralRadius)

    @contextlib.contextmanager
    def quiet(self):
        """No console output (Exudyn prints a banner when a solve fails), no deprecation warnings."""
        config = getattr(self.exu, "config", None)
        before = config.printToConsole if config is not None else True

        def set_console(flag):
            if config is not None:
                config.printToConsole = flag
            else:  # older Exudyn
                self.exu.SetWriteToConsole(flag)

        set_console(False)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                yield
        finally:
            set_console(before)

    def build(self, dt, steps, node, omega, scheme, sensors):
        exu = self.exu
        mbs = exu.SystemContainer().AddSystem()
        inertia = self.InertiaCuboid(FREE_BOX["density"], sideLengths=list(FREE_BOX["size"]))
        body = mbs.CreateRigidBody(
            inertia=inertia,
            referencePosition=[0.0, 0.0, 0.0],
            initialAngularVelocity=list(omega),
            nodeType=self.nodes[node],
            returnDict=True,
        )
        sens = (
            [
                mbs.AddSensor(self.SensorNode(nodeNumber=body["nodeNumber"], storeInternal=True, outputVariableType=ov))
                for ov in (exu.OutputVariableType.AngularVelocityLocal, exu.OutputVariableType.RotationMatrix)
            ]
            if sensors
            else None
        )
        mbs.Assemble()
        ss = exu.SimulationSettings()
        ti = ss.timeIntegration
        ti.numberOfSteps = steps
        ti.endTime = steps * dt
        ti.verboseMode = 0
        try:
            ss.solution.file.write = False
        except AttributeError:  # older Exudyn
            ss.solutionSettings.writeSolutionToFile = False
        solver = exu.DynamicSolverType.GeneralizedAlpha
        if scheme == "trapezoidal":  # Newmark beta = 1/4, gamma = 1/2 (its defaults), index-3 constraints
            ti.generalizedAlpha.useNewmark = True
            ti.generalizedAlpha.useIndex2Constraints = False
        elif scheme == "trapezoidal-index2":
            solver = exu.DynamicSolverType.TrapezoidalIndex2
        return mbs, ss, solver, np.array(inertia.Inertia()), sens

    def solve(self, mbs, ss, solver):
        """(converged, message); Exudyn raises SolverError when Newton fails."""
        try:
            ok = self.exu.SolveDynamic(mbs, ss, solverType=solver, showHints=False)
            return bool(ok), "" if ok else "SolveDynamic returned False"
        except Exception as exc:  # noqa: BLE001
            return False, f"{type(exc).__name__}: {exc}"

    def runner(self, dt: float, node: str):
        def steps(k: int) -> tuple:
            with self.quiet():
                mbs, ss, solver, _, _ = self.build(dt, k, node, FREE_OMEGA, "generalized-alpha", False)
                start = clock()
                ok, msg = self.solve(mbs, ss, solver)
                elapsed = since(start)
            if not ok:
                raise RuntimeError(f"generalized-alpha did not converge in a timing run: {msg}")
            return elapsed

        return steps

    def accuracy(self, dt: float, node: str, omega, scheme: str, cfg: Config) -> dict:
        with self.quiet():
            mbs, ss, solver, inertia, sens = self.build(dt, int(round(cfg.t_free / dt)), node, omega, scheme, True)
            ok, msg = self.solve(mbs, ss, solver)
            w = np.asarray(mbs.GetSensorStoredData(sens[0]))[:, 1:4]
            R = np.asarray(mbs.GetSensorStoredData(sens[1]))[:, 1:10].reshape(-1, 3, 3)  # row-major
            t_reached = float(mbs.systemData.GetTime())
        E = 0.5 * np.einsum("ni,ij,nj->n", w, inertia, w)
        L = np.einsum("nij,jk,nk->ni", R, inertia, w)
        out = {
            "converged": ok,
            "t_reached": t_reached,
            "energy_error": float(np.abs(E / E[0] - 1).max()),
            "angular_momentum_error": float(np.linalg.norm(L - L[0], axis=1).max() / np.linalg.norm(L[0])),
        }
        if ok:
            ref = omega_reference(inertia, omega, cfg.t_free)
            out["omega_error"] = float(np.abs(w[-1] - ref).max() / np.linalg.norm(ref))
        else:
            out["failure"] = msg
        return out


# -- the comparisons ---------------------------------------------------------------------------
def _field(cfg: Config, bsk: _Basilisk) -> dict:
    emorbit_rows, bsk_rows = [], []
    status = bsk.skipped or "ok"
    for dt in FIELD_DTS:
        runners = {f"order{o}": _EmorbitRunner(leo_sim(1, dt, order=o)) for o in (2, 4)}
        if status == "ok":
            runners["basilisk"] = bsk.runner(dt)
        times = timed(runners, cfg, optional=("basilisk",))
        for o in (2, 4):
            emorbit_rows.append(
                {
                    "order": o,
                    "dt": dt,
                    "mass_points": 8,
                    "gravity": "volume",
                    **times[f"order{o}"],
                    "newton_iterations": runners[f"order{o}"].newton(),
                    **_field_accuracy(o, dt, cfg),
                }
            )
        if status != "ok":
            continue
        if "status" in times["basilisk"]:
            status = times["basilisk"]["status"]
            continue
        row = {"dt": dt, "integrator": "RK4 (svIntegratorRK4, its default)", **times["basilisk"]}
        try:
            row.update(bsk.accuracy(dt, cfg))
        except Exception as exc:  # noqa: BLE001
            status = f"skipped: Basilisk failed ({type(exc).__name__}: {exc})"
            continue
        row["emorbit_ratio"] = paired_ratio(times["order2"], times["basilisk"])
        row["emorbit_ratio_wall"] = paired_ratio(times["order2"], times["basilisk"], "samples_us")
        bsk_rows.append(row)
    basilisk = {"status": status, "rows": bsk_rows}
    if status == "ok":
        basilisk.update(
            version=package_version("bsk"),
            case=(
                "Spacecraft hub with the box's mass and inertia, point-mass Earth gravity (same GM), "
                "GravityGradientEffector (first order), same initial state"
            ),
        )
    return {"emorbit": {"rows": emorbit_rows}, "basilisk": basilisk}


def _torque_free(cfg: Config, ex: _Exudyn) -> dict:
    free_rows, implicit, trapezoidal = [], [], []
    status = ex.skipped or "ok"
    for dt in FREE_DTS:
        runners = {"emorbit": _EmorbitRunner(free_sim(dt))}
        peers = [node for node in EXUDYN_NODES if dt in EXUDYN_DTS] if status == "ok" else []
        for node in peers:
            runners[node] = ex.runner(dt, node)
        times = timed(runners, cfg, optional=peers)
        free_rows.append(
            {
                "omega0": list(FREE_OMEGA),
                "dt": dt,
                **times["emorbit"],
                "newton_iterations": runners["emorbit"].newton(),
                **_free_accuracy(dt, FREE_OMEGA, cfg),
            }
        )
        for node in peers:
            row = {
                "solver": "generalized-alpha",
                "node": node,
                "spectral_radius": ex.spectral_radius,
                "dt": dt,
                **times[node],
            }
            if "status" not in row:
                row.update(ex.accuracy(dt, node, FREE_OMEGA, "generalized-alpha", cfg))
                row["emorbit_ratio"] = paired_ratio(times["emorbit"], times[node])
                row["emorbit_ratio_wall"] = paired_ratio(times["emorbit"], times[node], "samples_us")
            implicit.append(row)
    for dt in (TRAPEZOIDAL_DT, 10 * TRAPEZOIDAL_DT):
        free_rows.append({"omega0": list(FAST_OMEGA), "dt": dt, **_free_accuracy(dt, FAST_OMEGA, cfg)})
    if status == "ok":
        for scheme in ("trapezoidal", "trapezoidal-index2"):
            for omega in (FREE_OMEGA, FAST_OMEGA):
                trapezoidal.append(
                    {
                        "solver": scheme,
                        "node": "euler-parameters",
                        "omega0": list(omega),
                        "dt": TRAPEZOIDAL_DT,
                        **ex.accuracy(TRAPEZOIDAL_DT, "euler-parameters", omega, scheme, cfg),
                    }
                )
    exudyn = {"status": status, "implicit": implicit, "trapezoidal": trapezoidal}
    if status == "ok":
        exudyn.update(
            version=package_version("exudyn"),
            module=ex.module,
            case=(
                "CreateRigidBody with InertiaCuboid (the same box), no gravity; SolveDynamic timed (its "
                "set-up, ~60 us a call, amortised over the steps)"
            ),
        )
    return {
        "emorbit": {
            "rows": free_rows,
            "case": (
                f"box {FREE_BOX['size']} m, no field, omega0 = {list(FREE_OMEGA)} rad/s (body frame); "
                f"errors over {cfg.t_free:g} s: max over every step (E, L), omega at the end "
                f"against DOP853"
            ),
        },
        "exudyn": exudyn,
    }


def _ratio_target(target: str, ours: dict, row: dict) -> dict:
    """A 'emorbit <= 1x peer' target from a peer row (with its paired ratios) and emorbit's row."""
    return {
        "target": target,
        "emorbit_us": ours[CLOCK],
        "reference_us": row[CLOCK],
        "ratio": row["emorbit_ratio"],
        "ratio_wall": row["emorbit_ratio_wall"],
        "limit": 1.0,
        "met": row["emorbit_ratio"] <= 1.0,
    }


def _targets(scan: dict, field: dict, free: dict) -> list:
    out = []
    ex = free["exudyn"]
    if ex["status"] == "ok":
        for row in ex["implicit"]:
            if "status" in row:
                out.append(
                    {
                        "target": f"torque-free step <= 1x Exudyn generalized-alpha ({row['node']} node), "
                        f"dt = {row['dt']:g} s",
                        "met": None,
                        "note": row["status"],
                    }
                )
                continue
            ours = next(r for r in free["emorbit"]["rows"] if r["dt"] == row["dt"] and CLOCK in r)
            out.append(
                _ratio_target(
                    f"torque-free step <= 1x Exudyn generalized-alpha ({row['node']} node), dt = {row['dt']:g} s",
                    ours,
                    row,
                )
            )
    else:
        out.append({"target": "torque-free step <= 1x Exudyn's implicit step", "met": None, "note": ex["status"]})
    free_rows = [r for r in free["emorbit"]["rows"] if r["omega0"] == list(FREE_OMEGA)]
    worst = max(max(r["energy_error"], r["angular_momentum_error"]) for r in free_rows)
    out.append(
        {
            "target": "torque-free: energy and angular momentum at round-off at dt = "
            + ", ".join(f"{r['dt']:g}" for r in free_rows)
            + " s",
            "measured": worst,
            "limit": ROUND_OFF,
            "met": worst <= ROUND_OFF,
        }
    )
    bsk = field["basilisk"]
    if bsk["status"] == "ok":
        for row in bsk["rows"]:
            ours = next(r for r in field["emorbit"]["rows"] if r["order"] == 2 and r["dt"] == row["dt"])
            out.append(
                _ratio_target(
                    f"8 mass points in the field <= 1x Basilisk (RK4 + gravity gradient), dt = {row['dt']:g} s",
                    ours,
                    row,
                )
            )
    else:
        out.append({"target": "8 mass points in the field <= 1x Basilisk's step", "met": None, "note": bsk["status"]})
    thousand = [r for r in scan["rows"] if r["mass_points"] == 1000]
    if thousand:
        us = thousand[0]["volume"][CLOCK]
        out.append(
            {
                "target": "1000 mass points <= 100 us per step (Newton included)",
                "measured": us,
                "measured_wall": thousand[0]["volume"]["us_per_step"],
                "limit": 100.0,
                "met": us <= 100.0,
                "newton_iterations": thousand[0]["volume"]["newton_iterations"],
            }
        )
    if scan["per_point_spread"] is not None:
        out.append(
            {
                "target": "linear in the mass points: (volume - point) / N within 1.5x for N >= 200",
                "measured": scan["per_point_spread"],
                "limit": 1.5,
                "met": scan["per_point_spread"] <= 1.5,
            }
        )
    return out


def run(quick: bool = False, *, config: str | None = None) -> dict:
    """Measure the rigid-body section: the scan, the orbiting box and the torque-free box.

    Parameters
    ----------
    quick : bool
        The quick configuration instead of the full one.
    config : str, optional
        ``"full"``, ``"quick"`` or ``"tiny"`` (a seconds-long smoke run for the tests);
        overrides ``quick``.

    Returns
    -------
    dict
        JSON-ready: the machine, versions, ``scaling``, ``field``, ``torque_free`` and
        ``targets``.
    """
    name = config or ("quick" if quick else "full")
    cfg = CONFIGS[name]
    import numba

    from .._version import __version__

    load_before = loadavg()
    t0 = time.perf_counter()
    scan = _scan(cfg)
    field = _field(cfg, _Basilisk())
    free = _torque_free(cfg, _Exudyn())
    field["case"] = (
        f"box {LEO_BOX['size']} m, {LEO_BOX['density']:g} kg/m3, 8 mass points (volume gravity), "
        f"{R_ORBIT / 1e3:g} km circular Earth orbit, rotation vector {list(LEO_ROTATION_VECTOR)} rad from "
        f"long-axis-radial, omega = n z + {list(LEO_RATE_OFFSET)} rad/s (space); accuracy over "
        f"{cfg.orbits:g} orbits, Jacobi drift relative to |J(0)|"
    )
    return {
        "name": "rigid",
        "config": name,
        "machine": machine(),
        "load_average": {"before": load_before, "after": loadavg()},
        "versions": {
            "emorbit": __version__,
            "numba": numba.__version__,
            "numpy": np.__version__,
            "bsk": package_version("bsk"),
            "exudyn": package_version("exudyn"),
        },
        "round_off": ROUND_OFF,
        "scaling": scan,
        "field": field,
        "torque_free": free,
        "targets": _targets(scan, field, free),
        "seconds": round(time.perf_counter() - t0, 1),
    }


# -- printing --------------------------------------------------------------------------------
def _e(x) -> str:
    return "-" if x is None else f"{x:.1e}"


def _us(x) -> str:
    return "-" if x is None else (f"{x:.1f}" if x < 100 else f"{x:.0f}")


def table(section: dict) -> str:
    """The section as printable rows.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.

    Returns
    -------
    str
        The tables and the targets, one row per line.
    """
    m = section["machine"]
    threads = ", ".join(f"{k}={v}" for k, v in m.get("thread_variables", {}).items()) or "BLAS threads: default"
    lines = [
        f"Rigid bodies ({section['config']}): {m['cpu']}, {m['cores']} cores, {m['simd']}; {threads}; "
        f"load average {section['load_average']['before']} -> {section['load_average']['after']}; "
        f"{section['seconds']} s",
        "  us per step, Newton included, medians of interleaved repeats after a warm-up: wall clock / CPU time;",
        "  em/peer: median of per-repeat CPU-time ratios emorbit / peer (verdicts and fits use CPU time)",
    ]
    if section["config"] == "tiny":
        lines.append("  (tiny: a smoke run; its timings are dominated by the fixed cost of each call and mean nothing)")
    scan = section["scaling"]
    lines += [
        "",
        f"  cost per step against mass points: {scan['case']}",
        f"  {'points':>7} {'volume us':>14} {'Newton':>7} {'point us':>12} {'(vol-pt)/N ns':>14}",
    ]
    for r in scan["rows"]:
        v, p = r["volume"], r["point"]
        lines.append(
            f"  {r['mass_points']:>7} {_us(v['us_per_step']) + ' / ' + _us(v[CLOCK]):>14} "
            f"{v['newton_iterations']:>7.2f} {_us(p['us_per_step']) + ' / ' + _us(p[CLOCK]):>12} "
            f"{1e3 * r['us_per_point']:>14.1f}"
        )
    fv = scan["fit"]["volume"]
    spread = scan["per_point_spread"]
    lines.append(
        f"  straight line (volume): {1e3 * fv['us_per_point']:.1f} ns per mass point + {fv['intercept_us']:.1f} us, "
        f"max residual {100 * fv['max_relative_residual']:.0f} %"
        + (f"; (vol-pt)/N spread {spread:.2f}x for N >= 200" if spread is not None else "")
    )

    def timing(r):
        return (_us(r["us_per_step"]) + " / " + _us(r[CLOCK])) if CLOCK in r else "-"

    field = section["field"]
    bsk = field["basilisk"]
    ratio = {r["dt"]: r["emorbit_ratio"] for r in bsk["rows"]}
    lines += [
        "",
        f"  in the field: {field['case']}",
        f"  {'':<34} {'dt s':>5} {'us/step':>13} {'|dE/E|':>8} {'|dL/L|':>8} {'Jacobi':>8} {'em/peer':>8}",
    ]
    for r in field["emorbit"]["rows"]:
        vs = f"{ratio[r['dt']]:.2f}x" if r["order"] == 2 and r["dt"] in ratio else ""
        lines.append(
            f"  {'emorbit em order ' + str(r['order']) + ', 8 points':<34} {r['dt']:>5g} {timing(r):>13} "
            f"{_e(r['energy_error']):>8} {_e(r['angular_momentum_error']):>8} {_e(r['jacobi_drift']):>8} {vs:>8}"
        )
    for r in bsk["rows"]:
        lines.append(
            f"  {'Basilisk ' + bsk['version'] + ' RK4 + GG effector':<34} {r['dt']:>5g} {timing(r):>13} "
            f"{'-':>8} {'-':>8} {_e(r['jacobi_drift']):>8}"
        )
    if bsk["status"] != "ok":
        lines.append(f"  Basilisk: {bsk['status']}")

    free = section["torque_free"]
    ex = free["exudyn"]
    lines += [
        "",
        f"  torque-free: {free['emorbit']['case']}",
        f"  {'':<42} {'dt s':>6} {'us/step':>13} {'|dE/E|':>8} {'|dL/L|':>8} {'omega err':>9} {'em/peer':>8}",
    ]
    for r in free["emorbit"]["rows"]:
        label = "emorbit em" + ("" if r["omega0"] == list(FREE_OMEGA) else f" (omega_y = {r['omega0'][1]:g})")
        lines.append(
            f"  {label:<42} {r['dt']:>6g} {timing(r):>13} {_e(r['energy_error']):>8} "
            f"{_e(r['angular_momentum_error']):>8} {_e(r['omega_error']):>9}"
        )
    for r in ex["implicit"]:
        label = f"Exudyn {ex['version']} gen-alpha, {r['node']}"
        if "status" in r:
            lines.append(f"  {label:<42} {r['dt']:>6g}  {r['status']}")
            continue
        lines.append(
            f"  {label:<42} {r['dt']:>6g} {timing(r):>13} {_e(r['energy_error']):>8} "
            f"{_e(r['angular_momentum_error']):>8} {_e(r.get('omega_error')):>9} {r['emorbit_ratio']:>7.2f}x"
        )
    for r in ex["trapezoidal"]:
        label = f"Exudyn {r['solver']} (omega_y = {r['omega0'][1]:g})"
        failed = "" if r["converged"] else f"  FAILED at t = {r['t_reached']:.2f} s ({r['failure']})"
        lines.append(
            f"  {label:<42} {r['dt']:>6g} {'-':>13} {_e(r['energy_error']):>8} "
            f"{_e(r['angular_momentum_error']):>8} {_e(r.get('omega_error')):>9}{failed}"
        )
    if ex["status"] == "ok":
        lines.append(f"  (Exudyn module: {ex['module']})")
    else:
        lines.append(f"  Exudyn: {ex['status']}")

    lines += ["", "  targets"]
    for t in section["targets"]:
        verdict = {True: "met", False: "NOT met", None: "skipped"}[t["met"]]
        if "ratio" in t:
            what = (
                f"{_us(t['emorbit_us'])} / {_us(t['reference_us'])} CPU us, ratio {t['ratio']:.2f}x "
                f"(wall {t['ratio_wall']:.2f}x)"
            )
        elif "measured_wall" in t:
            what = f"{t['measured']:.3g} CPU us (wall {t['measured_wall']:.3g}; limit {t['limit']:g})"
        elif "measured" in t:
            what = f"{t['measured']:.3g} (limit {t['limit']:g})"
        else:
            what = t.get("note", "")
        lines.append(f"  {verdict:>8}  {t['target']}: {what}")
    return "\n".join(lines)
