"""Work against precision: what accuracy costs in CPU time over 100 orbits.

Three orbits around GM = 3.9478 m^3/s^2, each started at aphelion: the paper's (a = 6 m,
e = 2/3), an e = 0.9 one and an e = 0.99 one (a = 6 m). For every point: the CPU time of the
run (the integrator's own loop; set-up and just-in-time compilation excluded, the best of
three for runs under 50 ms), the final position error against the analytic Kepler solution
(:func:`emorbit.orbits.propagate`) relative to a, and the max relative energy error over
ten checkpoints per orbit. Engines:

* emorbit em, midpoint and leapfrog at orders 2, 4, 6 and 8 (symmetric compositions of 1, 3,
  9 and 17 second-order steps), dt = T/N for several N (through ``PointMasses.advance``,
  checkpoints recorded by the kernel); points carry ``dt``;
* emorbit tfe, the energy-momentum time finite element, at orders 4 to 12 (one implicit
  solve of 2 to 6 Gauss stages per step, :mod:`emorbit.kernels.pointmass.tfe`) at the same dt;
  labelled with its order and scheme beside the compositions;
* emorbit em with adaptive, time-symmetric steps (:mod:`emorbit.kernels.pointmass.adaptive`,
  ``h ~ eta 2 pi sqrt(r^3/GM)``) at orders 2-8 for several eta: points with ``method = "em"``,
  ``adaptive = True`` and eta as ``tolerance`` (a step too long for the control fails the run,
  which is kept as a failed point); tfe with the same adaptive steps at the orders of
  :attr:`Config.tfe_adaptive_orders` (``method = "tfe"``, ``adaptive = True``);
* REBOUND IAS15 at several epsilons (its adaptive step, exact finish time), WHFast (without
  safe mode) and leapfrog at the same dt as emorbit;
* heyoka's Taylor integrator at tolerances from 1e-6 to machine precision, when it is
  installed (``pip install "emorbit[peers]"``); otherwise the section says it was skipped.

Fixed-step runs whose step is too long for the orbit fail or blow up; they are kept in the
JSON with their status and left out of the figures. A run estimated (from the one before in
its series) to take over :data:`MAX_RUN_S` is skipped. The Pareto front of each panel (the
points no other point beats in both time and error) is marked.

Targets (:func:`reach`, :func:`accuracy_targets`): for each orbit and a final position error
of 1e-6, 1e-9 and 1e-12 of a, the least CPU time each engine needs to reach it (emorbit em
adaptive, em fixed-step and tfe, each at its best order, IAS15, WHFast, heyoka), and tfe's
time over em fixed-step's and over heyoka's: the cheapest of
its points that reach it and of the interpolations, linear in log(CPU time) against
log(error), between two neighbouring points of one series (consecutive settings of one
order) that bracket it; nothing is extrapolated past the measured points. The verdicts
(:func:`verdicts`): em adaptive at the final position error of IAS15 at REBOUND's default
epsilon (1e-9) within :data:`LIMIT_IAS15` times IAS15's CPU time, and within
:data:`LIMIT_HEYOKA` times heyoka's at each of the three errors both reach; and emorbit's
cheapest scheme (em or tfe, fixed or adaptive) at 1e-9 of a within :data:`LIMIT_BEST_HEYOKA`
times heyoka's.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..integrators import coefficients, get_method
from ..orbits import propagate, semi_major_axis
from .common import GM, PAPER_V0, PAPER_X0, aphelion_state, period, point_masses, rebound_sim, rebound_state
from .timing import best_cpu

__all__ = ["run", "table", "plot", "plot_orbits", "reach", "accuracy_targets", "verdicts"]

METHODS = ("em", "midpoint", "leapfrog", "tfe")
ORDERS = (2, 4, 6, 8)
CHECKPOINTS_PER_ORBIT = 10
#: a run that would take longer than this (estimated from the one before in its series) is left out
MAX_RUN_S = 3.0
#: the final position errors (relative to a) of the targets table
ACCURACIES = (1e-6, 1e-9, 1e-12)
#: REBOUND's default IAS15 epsilon: the verdict compares at this point's final position error
IAS15_EPSILON = 1e-9
#: em adaptive's CPU time at IAS15's final position error over IAS15's, at most (by orbit)
LIMIT_IAS15 = {"paper": 1.0, "e09": 1.0, "e099": 2.0}
#: em adaptive's CPU time over heyoka's at the same final position error, at most
LIMIT_HEYOKA = 5.0
#: emorbit's best scheme's CPU time over heyoka's at the final position error BEST_ACCURACY, at most
LIMIT_BEST_HEYOKA = 3.0
#: the final position error (relative to a) at which emorbit's best scheme meets heyoka
BEST_ACCURACY = 1e-9
#: emorbit's engines that the best-scheme target takes the least of
OURS = ("em adaptive", "em fixed", "tfe", "tfe adaptive")
#: the engines of the targets table: (engine, method, adaptive, the setting that orders a series)
ENGINES = {
    "em adaptive": ("emorbit", "em", True, "tolerance"),
    "em fixed": ("emorbit", "em", False, "dt"),
    "tfe": ("emorbit", "tfe", False, "dt"),
    "tfe adaptive": ("emorbit", "tfe", True, "tolerance"),
    "ias15": ("rebound", "ias15", False, "epsilon"),
    "whfast": ("rebound", "whfast", False, "dt"),
    "heyoka": ("heyoka", "taylor", False, "tolerance"),
}


def _solves(method: str, order: int) -> int:
    """Implicit solves in one step: a composition's sub-steps, or one (tfe)."""
    return get_method(method).solves_per_step(order)


def _errors(x_end, x_ref, energies_, e0, a) -> dict:
    return {
        "position_error": float(np.linalg.norm(np.asarray(x_end) - x_ref) / a),
        "energy_error": float(np.max(np.abs(np.asarray(energies_) / e0 - 1.0))),
    }


def _energy(x, v) -> float:
    return 0.5 * float(np.dot(v, v)) - GM / float(np.linalg.norm(x))


def _emorbit(x0, v0, method, order, N, T, orbits) -> dict:
    steps = N * orbits
    dt = T / N
    every = max(1, N // CHECKPOINTS_PER_ORBIT)
    nrec = steps // every

    rest = steps - nrec * every  # N need not be a multiple of the checkpoint interval

    def go():
        pm = point_masses(x0[:, None], v0[:, None])
        recs = [pm.advance(method, GM, np.zeros(3), dt, get_method(method).coefficients(order), every, nrec, 50)]
        if rest and recs[0].first_failure() is None:
            recs.append(pm.advance(method, GM, np.zeros(3), dt, get_method(method).coefficients(order), rest, 1, 50))
        return pm, recs

    (pm, recs), cpu = best_cpu(go)
    failed = [r.first_failure() for r in recs if r.first_failure() is not None]
    if failed:
        return {"status": f"failed: step {failed[0][0]} of a call ({steps} steps in all)", "cpu_s": cpu}
    xs = np.concatenate([r.x[:, :, 0] for r in recs])
    vs = np.concatenate([r.v[:, :, 0] for r in recs])
    e = 0.5 * np.einsum("rk,rk->r", vs, vs) - GM / np.linalg.norm(xs, axis=1)
    its = sum(float(r.iterations.sum()) for r in recs)
    return {
        "cpu_s": cpu,
        "x_end": pm.x[:, 0].copy(),
        "energies": e,
        "steps": steps,
        # Newton iterations per solve: a tfe step is one solve, a composed step one per sub-step
        "newton": its / (steps * _solves(method, order)) if method != "leapfrog" else 0.0,
    }


def _emorbit_adaptive(x0, v0, order, eta, T, orbits, method="em") -> dict:
    """em (or tfe, ``method``) with adaptive steps (``h ~ eta 2 pi sqrt(r^3/GM)``, not capped),
    timed over the whole run with steps landing only at its end, as the peers run; the energy at the records
    T / CHECKPOINTS_PER_ORBIT apart comes from a second run that lands on each (a step that
    would pass one is replaced by one of the remaining time)."""
    nrec = CHECKPOINTS_PER_ORBIT * orbits

    def run(dt, nrec_):
        pm = point_masses(x0[:, None], v0[:, None])
        pm.plan = pm.plan.with_(adaptive=eta)
        rec = pm.advance(method, GM, np.zeros(3), dt, get_method(method).coefficients(order), 1, nrec_, 50)
        return pm, rec

    (pm, rec), cpu = best_cpu(lambda: run(orbits * T, 1))
    if rec.first_failure() is not None:
        return {"status": "failed: the run without records", "cpu_s": cpu}
    x_end = pm.x[:, 0].copy()
    steps = pm.adaptive_steps
    newton = float(rec.iterations.sum()) / (steps * _solves(method, order))
    pm, rec = run(T / CHECKPOINTS_PER_ORBIT, nrec)
    if rec.first_failure() is not None:
        return {"status": f"failed: record {rec.first_failure()[0]}", "cpu_s": cpu}
    xs, vs = rec.x[:, :, 0], rec.v[:, :, 0]
    e = 0.5 * np.einsum("rk,rk->r", vs, vs) - GM / np.linalg.norm(xs, axis=1)
    return {"cpu_s": cpu, "x_end": x_end, "energies": e, "steps": steps, "newton": newton}


def _rebound_fixed(x0, v0, integrator, N, T, orbits) -> dict:
    steps = N * orbits
    dt = T / N

    def go():
        sim = rebound_sim(x0[:, None], v0[:, None], integrator, dt)
        sim.steps(steps)
        return sim

    sim, cpu = best_cpu(go)
    x_end = rebound_state(sim)[0][:, 0]
    # energy at the checkpoints, in a second run (synchronising between steps costs time)
    sim = rebound_sim(x0[:, None], v0[:, None], integrator, dt)
    every = max(1, N // CHECKPOINTS_PER_ORBIT)
    e = []
    done = 0
    while done < steps:
        k = min(every, steps - done)
        sim.steps(k)
        done += k
        xs, vs = rebound_state(sim)
        e.append(_energy(xs[:, 0], vs[:, 0]))
    return {"cpu_s": cpu, "x_end": x_end, "energies": e, "steps": steps}


def _ias15(x0, v0, eps, T, orbits) -> dict:
    """IAS15 at ``eps``; REBOUND's warnings (its predictor-corrector not converging at a
    large epsilon) are kept in the point, not printed."""
    t_end = orbits * T

    def go():
        sim = rebound_sim(x0[:, None], v0[:, None], "ias15", T / 100, epsilon=eps)
        sim.integrate(t_end, exact_finish_time=1)
        return sim

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sim, cpu = best_cpu(go)
        x_end = rebound_state(sim)[0][:, 0]
        steps = int(sim.steps_done)
        sim = rebound_sim(x0[:, None], v0[:, None], "ias15", T / 100, epsilon=eps)
        e = []
        for k in range(1, orbits * CHECKPOINTS_PER_ORBIT + 1):
            sim.integrate(k * T / CHECKPOINTS_PER_ORBIT, exact_finish_time=1)
            xs, vs = rebound_state(sim)
            e.append(_energy(xs[:, 0], vs[:, 0]))
    out = {"cpu_s": cpu, "x_end": x_end, "energies": e, "steps": steps}
    if caught:
        out["warning"] = str(caught[0].message)
    return out


def _heyoka_system():
    import heyoka as hy

    x, y, z, vx, vy, vz = hy.make_vars("x", "y", "z", "vx", "vy", "vz")
    r3 = hy.sum([x * x, y * y, z * z]) ** -1.5
    return [(x, vx), (y, vy), (z, vz), (vx, -GM * x * r3), (vy, -GM * y * r3), (vz, -GM * z * r3)]


def _heyoka(x0, v0, tol, T, orbits, system) -> dict:
    import heyoka as hy

    state = list(x0) + list(v0)
    ta = hy.taylor_adaptive(system, state, tol=tol)  # just-in-time compilation: not timed
    t_end = orbits * T

    def go():
        ta.time = 0.0
        ta.state[:] = state
        return ta.propagate_until(t_end)

    res, cpu = best_cpu(go)  # (outcome, min step, max step, steps, ...)
    x_end = ta.state[:3].copy()
    ta.time = 0.0
    ta.state[:] = state
    grid = np.arange(1, orbits * CHECKPOINTS_PER_ORBIT + 1) * (T / CHECKPOINTS_PER_ORBIT)
    out = ta.propagate_grid(np.concatenate([[0.0], grid]))
    traj = out[-1][1:]
    e = 0.5 * np.einsum("ik,ik->i", traj[:, 3:], traj[:, 3:]) - GM / np.linalg.norm(traj[:, :3], axis=1)
    return {"cpu_s": cpu, "x_end": x_end, "energies": e, "steps": int(res[3]), "order": int(ta.order)}


def _pareto(points: list, key: str) -> list:
    """Indices of the points on the Pareto front (less CPU time and less error)."""
    ok = [(p["cpu_s"], p[key], i) for i, p in enumerate(points) if p.get(key) is not None and p[key] > 0]
    front, best = [], math.inf
    for _time, err, i in sorted(ok):
        if err < best:
            front.append(i)
            best = err
    return front


def _orbit(name, x0, v0, divisions, cfg, heyoka_system) -> dict:
    T = period(x0, v0)
    a = float(semi_major_axis(x0, v0, GM))
    orbits = cfg.orbits
    x_ref = propagate(x0, v0, GM, orbits * T)[0]
    e0 = _energy(x0, v0)
    points = []

    def add(engine, method, order, param, param_name, res, **extra):
        p = {"engine": engine, "method": method, "order": order, param_name: param, **extra}
        if "x_end" in res:
            err = _errors(res.pop("x_end"), x_ref, res.pop("energies"), e0, a)
            finite = math.isfinite(err["position_error"]) and math.isfinite(err["energy_error"])
            res["status"] = "ok" if finite and err["position_error"] < 10 else "diverged"
            res.update(err)
        p.update(res)
        points.append(p)

    skipped = {"status": f"skipped: estimated over {MAX_RUN_S} s"}
    for method in METHODS:
        for order in get_method(method).orders:
            point_masses(x0[:, None], v0[:, None]).advance(
                method, GM, np.zeros(3), T / 100, get_method(method).coefficients(order), 1, 1, 50
            )  # warm-up: load the kernels
            per_step = None
            for N in divisions:
                if per_step is not None and per_step * N * orbits > MAX_RUN_S:
                    add("emorbit", method, order, T / N, "dt", dict(skipped))
                    continue
                res = _emorbit(x0, v0, method, order, N, T, orbits)
                per_step = res["cpu_s"] / (N * orbits)
                add("emorbit", method, order, T / N, "dt", res)
    for method, orders in (("em", cfg.adaptive_orders), ("tfe", cfg.tfe_adaptive_orders)):
        scale = None  # CPU s x eta / solves per step of the last run that finished (steps ~ 1 / eta)
        _emorbit_adaptive(x0, v0, orders[0], cfg.adaptive_eta[0], T, 1, method)  # warm-up: load the kernel
        for order in orders:
            solves = _solves(method, order)
            for eta in cfg.adaptive_eta:
                estimate = None if scale is None else scale * solves / eta
                if estimate is not None and estimate > MAX_RUN_S:
                    add("emorbit", method, order, eta, "tolerance", dict(skipped), adaptive=True)
                    continue
                res = _emorbit_adaptive(x0, v0, order, eta, T, orbits, method)
                if "steps" in res:
                    scale = res["cpu_s"] * eta / solves
                add("emorbit", method, order, eta, "tolerance", res, adaptive=True)
    for integrator in ("leapfrog", "whfast"):
        per_step = None
        for N in divisions:
            if per_step is not None and per_step * N * orbits > MAX_RUN_S:
                add("rebound", integrator, 2, T / N, "dt", dict(skipped))
                continue
            res = _rebound_fixed(x0, v0, integrator, N, T, orbits)
            per_step = res["cpu_s"] / (N * orbits)
            add("rebound", integrator, 2, T / N, "dt", res)
    for eps in cfg.ias15_eps:
        add("rebound", "ias15", 15, eps, "epsilon", _ias15(x0, v0, eps, T, orbits))
    heyoka = 'skipped: heyoka not installed (pip install "emorbit[peers]")'
    if heyoka_system is not None:
        heyoka = "ok"
        for tol in cfg.heyoka_tol:
            try:
                res = _heyoka(x0, v0, tol, T, orbits, heyoka_system)
            except Exception as exc:  # noqa: BLE001 - a peer never stops the bench
                heyoka = f"failed: {type(exc).__name__}: {exc}"
                break
            order = res.pop("order")
            add("heyoka", "taylor", order, tol, "tolerance", res)
    good = [p for p in points if p.get("status") == "ok"]
    for p in points:
        p["pareto_position"] = False
        p["pareto_energy"] = False
    for key, flag in (("position_error", "pareto_position"), ("energy_error", "pareto_energy")):
        for i in _pareto(good, key):
            good[i][flag] = True
    orbit = {
        "name": name,
        "a": a,
        "e": float(np.linalg.norm(((np.dot(v0, v0) - GM / np.linalg.norm(x0)) * x0 - np.dot(x0, v0) * v0) / GM)),
        "period_s": T,
        "orbits": orbits,
        "heyoka": heyoka,
        "points": points,
    }
    orbit["targets"] = accuracy_targets(orbit)
    return orbit


def _series(points: list, name: str) -> list:
    """The points of engine ``name`` of :data:`ENGINES` that ran, one series per order for
    emorbit (one in all for a peer), each from its coarsest setting to its finest."""
    engine, method, adaptive, setting = ENGINES[name]
    out = {}
    for p in points:
        if (p["engine"], p["method"], bool(p.get("adaptive"))) == (engine, method, adaptive) and p.get(
            "status"
        ) == "ok":
            out.setdefault(p["order"] if engine == "emorbit" else 0, []).append(p)  # heyoka's order follows tol
    return [sorted(s, key=lambda p: -p[setting]) for _, s in sorted(out.items())]


def reach(points: list, name: str, accuracy: float) -> dict | None:
    """The least CPU time at which an engine reaches a final position error.

    Parameters
    ----------
    points : list of dict
        An orbit's ``points``.
    name : str
        A key of :data:`ENGINES` (emorbit's engines take their best order).
    accuracy : float
        The final position error, relative to a.

    Returns
    -------
    dict or None
        ``cpu_s``, ``order`` and ``setting`` (eta, dt, epsilon or tolerance) of the cheapest
        point with an error <= ``accuracy``, or of the interpolation (linear in log-log) between
        two neighbouring points of one series that bracket it, then with ``between`` (the
        coarser and the finer setting); None when no point gets there.
    """
    setting = ENGINES[name][3]
    best = None
    for series in _series(points, name):
        for i, p in enumerate(series):
            cpu, between = None, None
            if p["position_error"] <= accuracy:
                cpu = p["cpu_s"]
            if i > 0:
                q = series[i - 1]
                eq, ep = q["position_error"], p["position_error"]
                if eq > accuracy >= ep > 0.0:
                    f = math.log(eq / accuracy) / math.log(eq / ep)
                    interp = math.exp((1.0 - f) * math.log(q["cpu_s"]) + f * math.log(p["cpu_s"]))
                    if cpu is None or interp < cpu:
                        cpu, between = interp, [q[setting], p[setting]]
            if cpu is not None and (best is None or cpu < best["cpu_s"]):
                best = {"cpu_s": cpu, "order": p["order"], "setting": p[setting]}
                if between:
                    best["between"] = between
    return best


def accuracy_targets(orbit: dict) -> list:
    """For each of :data:`ACCURACIES`, the least CPU time of each engine of :data:`ENGINES`
    (:func:`reach`; heyoka None when it did not run), em adaptive's ratios to IAS15 and to
    heyoka, and tfe's to em fixed-step (compositions) and to heyoka (None where either does not
    get there)."""
    out = []
    for accuracy in ACCURACIES:
        engines = {name: reach(orbit["points"], name, accuracy) for name in ENGINES}
        row = {"accuracy": accuracy, "engines": engines}
        for ours, peer, key in (
            ("em adaptive", "ias15", "adaptive_over_ias15"),
            ("em adaptive", "heyoka", "adaptive_over_heyoka"),
            ("tfe", "em fixed", "tfe_over_em_fixed"),
            ("tfe", "heyoka", "tfe_over_heyoka"),
        ):
            a, b = engines[ours], engines[peer]
            row[key] = None if a is None or b is None else a["cpu_s"] / b["cpu_s"]
        out.append(row)
    return out


def _label(orbit: dict) -> str:
    return f"{orbit['name']} orbit (e = {orbit['e']:.3g})"


def verdicts(orbits: list) -> list:
    """The section's targets, three per orbit: em adaptive (best order) at the final
    position error of IAS15 at epsilon :data:`IAS15_EPSILON` within :data:`LIMIT_IAS15` times
    IAS15's CPU time, and within :data:`LIMIT_HEYOKA` times heyoka's at each accuracy of the
    targets table that both reach; emorbit's best scheme within :data:`LIMIT_BEST_HEYOKA` times
    heyoka's at :data:`BEST_ACCURACY` (``met`` None when heyoka did not run).

    Parameters
    ----------
    orbits : list of dict
        The section's ``orbits``.

    Returns
    -------
    list of dict
        ``target``, ``limit``, ``met``, ``note`` and, where measured, ``measured`` (the ratio).
    """
    out = []
    for orbit in orbits:
        limit = LIMIT_IAS15.get(orbit["name"], 1.0)
        t = {
            "target": f"em adaptive at IAS15's final position error (epsilon {IAS15_EPSILON:g}) <= {limit:g}x "
            f"IAS15's CPU time, {_label(orbit)}",
            "limit": limit,
            "met": False,
        }
        ias = [p for p in orbit["points"] if p["method"] == "ias15" and p.get("epsilon") == IAS15_EPSILON]
        ias = [p for p in ias if p.get("status") == "ok"]
        if not ias:
            t.update(met=None, note=f"skipped: IAS15 at epsilon {IAS15_EPSILON:g} not measured")
        else:
            err, cpu = ias[0]["position_error"], ias[0]["cpu_s"]
            ours = reach(orbit["points"], "em adaptive", err)
            if ours is None:
                t["note"] = f"em adaptive does not reach IAS15's {err:.1e} (IAS15: {1e3 * cpu:.1f} ms)"
            else:
                t.update(measured=ours["cpu_s"] / cpu, met=ours["cpu_s"] / cpu <= limit)
                t["note"] = (
                    f"{err:.1e} of a: em adaptive order {ours['order']} {1e3 * ours['cpu_s']:.1f} ms, "
                    f"IAS15 {1e3 * cpu:.1f} ms" + ("" if t["met"] else f"; {t['measured'] / limit:.2f}x the limit")
                )
        out.append(t)
        t = {
            "target": f"em adaptive <= {LIMIT_HEYOKA:g}x heyoka's CPU time at a position error of "
            f"{', '.join(f'{x:g}' for x in ACCURACIES)} (where both reach it), {_label(orbit)}",
            "limit": LIMIT_HEYOKA,
            "met": None,
        }
        ratios = {r["accuracy"]: r["adaptive_over_heyoka"] for r in orbit["targets"]}
        ratios = {k: v for k, v in ratios.items() if v is not None}
        if orbit["heyoka"] != "ok":
            t["note"] = orbit["heyoka"]
        elif not ratios:
            t["note"] = "skipped: em adaptive and heyoka reach none of these errors both"
        else:
            worst = max(ratios.values())
            t.update(measured=worst, met=worst <= LIMIT_HEYOKA)
            t["note"] = ", ".join(f"{r:.2f}x at {k:g}" for k, r in ratios.items()) + (
                "" if t["met"] else f"; {worst / LIMIT_HEYOKA:.2f}x the limit"
            )
        out.append(t)
        out.append(_best_verdict(orbit))
    return out


def _best_verdict(orbit: dict) -> dict:
    """emorbit's cheapest engine of :data:`OURS` at :data:`BEST_ACCURACY` within
    :data:`LIMIT_BEST_HEYOKA` times heyoka's CPU time there."""
    t = {
        "target": f"emorbit's best scheme (em or tfe, fixed or adaptive steps) <= {LIMIT_BEST_HEYOKA:g}x heyoka's "
        f"CPU time at a position error of {BEST_ACCURACY:g}, {_label(orbit)}",
        "limit": LIMIT_BEST_HEYOKA,
        "met": None,
    }
    row = next(r for r in orbit["targets"] if r["accuracy"] == BEST_ACCURACY)
    ours = [(r["cpu_s"], name, r["order"]) for name in OURS if (r := row["engines"][name]) is not None]
    heyoka = row["engines"]["heyoka"]
    if orbit["heyoka"] != "ok":
        t["note"] = orbit["heyoka"]
    elif not ours or heyoka is None:
        t["note"] = f"skipped: emorbit or heyoka does not reach {BEST_ACCURACY:g}"
    else:
        cpu, name, order = min(ours)
        ratio = cpu / heyoka["cpu_s"]
        t.update(measured=ratio, met=ratio <= LIMIT_BEST_HEYOKA)
        t["note"] = f"{name} order {order} {1e3 * cpu:.2f} ms, heyoka {1e3 * heyoka['cpu_s']:.2f} ms" + (
            "" if t["met"] else f"; {ratio / LIMIT_BEST_HEYOKA:.2f}x the limit"
        )
    return t


def run(cfg) -> dict:
    """Measure the section: the three orbits, every engine, the targets.

    Parameters
    ----------
    cfg : Config
        A configuration of :data:`emorbit.bench.common.CONFIGS` (orbits, steps, epsilons,
        tolerances, adaptive orders and etas).

    Returns
    -------
    dict
        JSON-ready: per orbit its ``points`` (engine, method, order, setting, CPU time,
        position and energy errors, status, Pareto flags) and ``targets`` (the least CPU time
        of each engine at each of :data:`ACCURACIES`), whether heyoka ran, and the section's
        ``targets`` (:func:`verdicts`).
    """
    try:
        system = _heyoka_system()
    except ImportError:
        system = None
    x9, v9 = aphelion_state(6.0, 0.9)
    x99, v99 = aphelion_state(6.0, 0.99)
    orbits = [
        _orbit("paper", PAPER_X0, PAPER_V0, cfg.divisions, cfg, system),
        _orbit("e09", x9, v9, cfg.divisions_e09, cfg, system),
        _orbit("e099", x99, v99, cfg.divisions_e099, cfg, system),
    ]
    return {
        "case": (
            f"{cfg.orbits} orbits from aphelion: final position error / a against the Kepler solution, "
            f"max |dE/E| over {CHECKPOINTS_PER_ORBIT} checkpoints per orbit, CPU time of the run"
        ),
        "orbits": orbits,
        "heyoka": orbits[0]["heyoka"],
        "targets": verdicts(orbits),
    }


# -- figures ---------------------------------------------------------------------------------
_MAPS = {
    "em": "Blues",
    "midpoint": "Greens",
    "leapfrog": "Oranges",
    "em adaptive": "Purples",
    "tfe": "Reds",
    "tfe adaptive": "RdPu",
}
_PEERS = {
    ("rebound", "ias15"): ("REBOUND IAS15 (epsilon)", "tab:red", "*", "-"),
    ("rebound", "whfast"): ("REBOUND WHFast (exact Kepler drift)", "tab:purple", "x", "--"),
    ("rebound", "leapfrog"): ("REBOUND leapfrog", "tab:brown", "+", "--"),
    ("heyoka", "taylor"): ("heyoka Taylor (tolerance)", "black", "P", "-"),
}
_MARKERS = {2: "o", 4: "s", 6: "^", 8: "D", 10: "v", 12: "P"}


def _style(engine, method, adaptive, order):
    """(label, color, marker, line style) of a series."""
    if engine == "emorbit":
        import matplotlib

        kind = f"{method} adaptive" if adaptive else method
        color = matplotlib.colormaps[_MAPS[kind]](0.35 + 0.65 * (order - 2) / 10)
        ls = {"em": "-", "em adaptive": "-.", "tfe": "--", "tfe adaptive": (0, (3, 1, 1, 1, 1, 1))}.get(kind, ":")
        if method == "tfe":  # the scheme beside the compositions: one solve of order / 2 Gauss stages
            eta = " (eta)" if adaptive else ""
            return f"emorbit {kind} {order} (one solve, {order // 2} stages){eta}", color, _MARKERS[order], ls
        scheme = f" (composition of {len(coefficients(order))})" if order > 2 and not adaptive else ""
        return f"emorbit {kind} {order}{scheme}" + (" (eta)" if adaptive else ""), color, _MARKERS[order], ls
    return _PEERS[(engine, method)]


def plot_orbits(orbits: list, path: str) -> None:
    """Draw the work-precision figure of some orbits: one column per orbit, the final position
    error (top) and the energy error (bottom) against CPU time.

    Parameters
    ----------
    orbits : list of dict
        Entries of the section's ``orbits``.
    path : str
        The PNG to write.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(orbits)
    fig, axes = plt.subplots(2, n, figsize=(6.2 * n, 10), constrained_layout=True, squeeze=False)
    labelled = set()
    for col, orbit in enumerate(orbits):
        series = {}
        for p in orbit["points"]:
            if p.get("status") == "ok":
                key = (p["engine"], p["method"], bool(p.get("adaptive")), p["order"] if p["engine"] == "emorbit" else 0)
                series.setdefault(key, []).append(p)
        for ax, key, flag, label in (
            (axes[0, col], "position_error", "pareto_position", "final position error / a"),
            (axes[1, col], "energy_error", "pareto_energy", "max |dE/E| over the run"),
        ):
            for (engine, method, adaptive, order), pts in sorted(series.items()):
                pts = sorted(pts, key=lambda p: p["cpu_s"])
                name, color, marker, ls = _style(engine, method, adaptive, order)
                xs, ys = [p["cpu_s"] for p in pts], [max(p[key], 1e-17) for p in pts]
                lw = 1.5 if engine != "emorbit" or adaptive else 1.2
                ax.loglog(
                    xs, ys, ls=ls, marker=marker, color=color, ms=5, lw=lw, label=None if name in labelled else name
                )
                labelled.add(name)
                if engine != "emorbit" or adaptive:
                    for p, x_, y_ in zip(pts, xs, ys):
                        param = p.get("epsilon", p.get("tolerance"))
                        if param is None:
                            continue
                        text = f"{param:g}" if adaptive else f"{param:.0e}"
                        ax.annotate(text, (x_, y_), fontsize=6, color=color, xytext=(3, 3), textcoords="offset points")
            front = sorted((p for pts in series.values() for p in pts if p[flag]), key=lambda p: p["cpu_s"])
            fx, fy = [p["cpu_s"] for p in front], [max(p[key], 1e-17) for p in front]
            pareto = "Pareto front (circled)"
            ax.step(
                fx,
                fy,
                where="post",
                color="0.3",
                lw=3,
                alpha=0.3,
                zorder=0,
                label=None if pareto in labelled else pareto,
            )
            labelled.add(pareto)
            ax.scatter(fx, fy, s=110, facecolors="none", edgecolors="0.15", lw=1.2, zorder=5)
            ax.set_xlabel(f"CPU time for {orbit['orbits']} orbits [s]")
            ax.set_ylabel(label)
            ax.grid(True, which="major", alpha=0.3)
        axes[0, col].set_title(f"{orbit['name']}: a = {orbit['a']:.2f} m, e = {orbit['e']:.3g}", fontsize=10)
    fig.legend(fontsize=7, ncol=2 * n, loc="outside lower center")
    fig.suptitle(
        f"What accuracy costs: {orbits[0]['orbits']} orbits from aphelion (one particle, one thread)", fontsize=11
    )
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot(orbit: dict, path: str) -> None:
    """Draw one orbit's work-precision figure: :func:`plot_orbits` of ``[orbit]``."""
    plot_orbits([orbit], path)


# -- the table -------------------------------------------------------------------------------
def point_label(p: dict) -> str:
    """A point's engine and method, as the tables (and the docs' tables) name them."""
    if p["engine"] != "emorbit":
        return f"{p['engine']} {p['method']}"
    return f"emorbit {p['method']}{' adaptive' if p.get('adaptive') else ''} order {p['order']}"


def point_setting(p: dict) -> str:
    """A point's setting: eta, dt (s), epsilon or tolerance."""
    if p.get("adaptive"):
        return f"eta {p['tolerance']:g}"
    return next(f"{k} {p[k]:.3g}" for k in ("dt", "epsilon", "tolerance") if k in p) + (" s" if "dt" in p else "")


def _cell(r: dict | None, emorbit: bool) -> str:
    if r is None:
        return "-"
    return f"{1e3 * r['cpu_s']:.2f} ms" + (f" ({r['order']})" if emorbit else "")


def targets_lines(orbit: dict) -> list[str]:
    """An orbit's ``targets`` (:func:`accuracy_targets`) as printable lines."""
    heyoka = orbit["heyoka"] == "ok"
    lines = [
        "    least CPU time to reach a final position error (best order in brackets; the cheapest point "
        "or a log-log interpolation between two neighbouring points)"
        + ("" if heyoka else f"; heyoka {orbit['heyoka']}"),
        f"      {'error / a':<10}"
        + "".join(f"{n:>16}" for n in ENGINES)
        + f"{'x IAS15':>10}{'x heyoka':>10}{'tfe x em':>10}{'tfe x hy':>10}",
    ]
    for row in orbit["targets"]:
        cells = [
            _cell(row["engines"][n], ENGINES[n][0] == "emorbit") if n != "heyoka" or heyoka else "skipped"
            for n in ENGINES
        ]
        keys = ("adaptive_over_ias15", "adaptive_over_heyoka", "tfe_over_em_fixed", "tfe_over_heyoka")
        ratios = [f"{row[k]:.2f}x" if row.get(k) is not None else "-" for k in keys]
        lines.append(
            f"      {row['accuracy']:<10g}" + "".join(f"{c:>16}" for c in cells) + "".join(f"{r:>10}" for r in ratios)
        )
    return lines


def table(section: dict) -> list[str]:
    """The section as printable lines: each orbit's Pareto front, em's best fixed-step points,
    the adaptive runs, the targets table; then the verdicts.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.

    Returns
    -------
    list of str
        The lines of the table.
    """
    lines = [f"work-precision: {section['case']}; heyoka: {section['heyoka']}"]
    for orbit in section["orbits"]:
        lines.append(
            f"  {orbit['name']} orbit (a = {orbit['a']:.3f} m, e = {orbit['e']:.3g}): Pareto front, position error"
        )
        front = sorted((p for p in orbit["points"] if p.get("pareto_position")), key=lambda p: p["cpu_s"])
        for p in front:
            lines.append(
                f"    {point_label(p):<34} {point_setting(p):<18} {1e3 * p['cpu_s']:>10.3f} ms  "
                f"position {p['position_error']:.1e}  energy {p['energy_error']:.1e}"
            )
        best = {}
        for p in orbit["points"]:
            if p.get("status") == "ok" and p["engine"] == "emorbit" and p["method"] == "em" and not p.get("adaptive"):
                b = best.get(p["order"])
                if b is None or p["position_error"] < b["position_error"]:
                    best[p["order"]] = p
        for p in orbit["points"]:
            if p.get("status") == "ok" and p["method"] == "tfe" and not p.get("adaptive"):
                b = best.get(("tfe", p["order"]))
                if b is None or p["position_error"] < b["position_error"]:
                    best[("tfe", p["order"])] = p
        for order, p in sorted(best.items(), key=lambda kv: (isinstance(kv[0], tuple), str(kv[0]))):
            name = f"tfe order {order[1]} (one solve)" if isinstance(order, tuple) else f"em order {order}"
            lines.append(
                f"    best {name}: position {p['position_error']:.1e} in {1e3 * p['cpu_s']:.1f} ms "
                f"(dt = T/{orbit['period_s'] / p['dt']:.0f}), energy {p['energy_error']:.1e}"
            )
        for p in orbit["points"]:
            if p.get("adaptive"):
                head = f"    {p['method']} adaptive order {p['order']}, eta {p['tolerance']:g}: "
                if p.get("status") != "ok":
                    lines.append(head + p.get("status", "?"))
                    continue
                lines.append(
                    head + f"position {p['position_error']:.1e} in {1e3 * p['cpu_s']:.1f} ms "
                    f"({p['steps'] / orbit['orbits']:.0f} steps per orbit), energy {p['energy_error']:.1e}"
                )
        lines += targets_lines(orbit)
    lines.append("  targets:")
    for t in section["targets"]:
        verdict = {True: "met", False: "NOT met", None: "skipped"}[t["met"]]
        measured = f": {t['measured']:.3g}" if "measured" in t else ""
        lines.append(f"    {verdict:>8}  {t['target']}{measured} ({t['note']})")
    return lines
