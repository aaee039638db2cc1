"""Work against precision: what accuracy costs in CPU time over 100 orbits.

Two orbits around GM = 3.9478 m^3/s^2, each started at aphelion: the paper's (a = 6 m,
e = 2/3) and an e = 0.9 one (a = 6 m). For every point: the CPU time of the run (the
integrator's own loop; set-up and just-in-time compilation excluded, the best of three
for runs under 50 ms), the final position error against the analytic Kepler solution
(:func:`emorbit.orbits.propagate`) relative to a, and the max relative energy error over
ten checkpoints per orbit. Engines:

* emorbit em, midpoint and leapfrog at orders 2, 4, 6 and 8, dt = T/N for several N
  (through ``PointMasses.advance``, checkpoints recorded by the kernel);
* emorbit em with adaptive steps (``h = eta 2 pi sqrt(r^3/GM)``, :mod:`emorbit.kernels.pointmass.adaptive`)
  at orders 4 and 8 for several eta;
* REBOUND IAS15 at several epsilons (its adaptive step, exact finish time), WHFast (without
  safe mode) and leapfrog at the same dt as emorbit;
* heyoka's Taylor integrator at tolerances from 1e-6 to machine precision, when it is
  installed (``pip install "emorbit[peers]"``); otherwise the section says it was skipped.

Fixed-step runs whose step is too long for the orbit fail or blow up; they are kept in the
JSON with their status and left out of the figures. The Pareto front of each panel (the
points no other point beats in both time and error) is marked.
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np

from ..integrators import coefficients
from ..orbits import propagate, semi_major_axis
from .common import GM, PAPER_V0, PAPER_X0, aphelion_state, period, point_masses, rebound_sim, rebound_state

__all__ = ["run", "table", "plot"]

METHODS = ("em", "midpoint", "leapfrog")
ORDERS = (2, 4, 6, 8)
CHECKPOINTS_PER_ORBIT = 10
#: a fixed-step run that would take longer than this (estimated from the ones before) is left out
MAX_RUN_S = 3.0


def _cpu(fn):
    """(result, CPU seconds) of fn(); the best of three when a run takes under 50 ms."""
    best, out = math.inf, None
    for k in range(3):
        t = time.process_time()
        out = fn()
        t = time.process_time() - t
        best = min(best, t)
        if k == 0 and t > 0.05:
            break
    return out, best


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
        recs = [pm.advance(method, GM, np.zeros(3), dt, coefficients(order), every, nrec, 50)]
        if rest and recs[0].first_failure() is None:
            recs.append(pm.advance(method, GM, np.zeros(3), dt, coefficients(order), rest, 1, 50))
        return pm, recs

    (pm, recs), cpu = _cpu(go)
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
        "newton": its / (steps * len(coefficients(order))) if method != "leapfrog" else 0.0,
    }


def _emorbit_adaptive(x0, v0, order, eta, T, orbits) -> dict:
    """em with adaptive steps (h = eta 2 pi sqrt(r^3/GM), at most T / CHECKPOINTS_PER_ORBIT;
    records on that grid)."""
    nrec = CHECKPOINTS_PER_ORBIT * orbits

    def go():
        pm = point_masses(x0[:, None], v0[:, None])
        pm.adaptive = eta
        rec = pm.advance("em", GM, np.zeros(3), T / CHECKPOINTS_PER_ORBIT, coefficients(order), 1, nrec, 50)
        return pm, rec

    (pm, rec), cpu = _cpu(go)
    if rec.first_failure() is not None:
        return {"status": f"failed: record {rec.first_failure()[0]}", "cpu_s": cpu}
    xs, vs = rec.x[:, :, 0], rec.v[:, :, 0]
    e = 0.5 * np.einsum("rk,rk->r", vs, vs) - GM / np.linalg.norm(xs, axis=1)
    return {
        "cpu_s": cpu,
        "x_end": pm.x[:, 0].copy(),
        "energies": e,
        "steps": pm.adaptive_steps,
        "newton": float(rec.iterations.sum()) / (pm.adaptive_steps * len(coefficients(order))),
    }


def _rebound_fixed(x0, v0, integrator, N, T, orbits) -> dict:
    steps = N * orbits
    dt = T / N

    def go():
        sim = rebound_sim(x0[:, None], v0[:, None], integrator, dt)
        sim.steps(steps)
        return sim

    sim, cpu = _cpu(go)
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
        sim, cpu = _cpu(go)
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

    res, cpu = _cpu(go)  # (outcome, min step, max step, steps, ...)
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

    def add(engine, method, order, param, param_name, res):
        p = {"engine": engine, "method": method, "order": order, param_name: param}
        if "x_end" in res:
            err = _errors(res.pop("x_end"), x_ref, res.pop("energies"), e0, a)
            finite = math.isfinite(err["position_error"]) and math.isfinite(err["energy_error"])
            res["status"] = "ok" if finite and err["position_error"] < 10 else "diverged"
            res.update(err)
        p.update(res)
        points.append(p)

    for method in METHODS:
        for order in ORDERS:
            point_masses(x0[:, None], v0[:, None]).advance(
                method, GM, np.zeros(3), T / 100, coefficients(order), 1, 1, 50
            )  # warm-up: load the kernels
            per_step = None
            for N in divisions:
                if per_step is not None and per_step * N * orbits > MAX_RUN_S:
                    add("emorbit", method, order, T / N, "dt", {"status": f"skipped: estimated over {MAX_RUN_S} s"})
                    continue
                res = _emorbit(x0, v0, method, order, N, T, orbits)
                per_step = res["cpu_s"] / (N * orbits)
                add("emorbit", method, order, T / N, "dt", res)
    for order in cfg.adaptive_orders:
        _emorbit_adaptive(x0, v0, order, cfg.adaptive_eta[0], T, 1)  # warm-up: load the kernel
        per_step = None
        for eta in cfg.adaptive_eta:
            steps = orbits * 2.0 * math.pi / eta  # a rough count (steps per Kepler time scale)
            if per_step is not None and per_step * steps > MAX_RUN_S:
                add("emorbit", "em adaptive", order, eta, "eta", {"status": f"skipped: estimated over {MAX_RUN_S} s"})
                continue
            res = _emorbit_adaptive(x0, v0, order, eta, T, orbits)
            per_step = res["cpu_s"] / steps
            add("emorbit", "em adaptive", order, eta, "eta", res)
    for integrator in ("leapfrog", "whfast"):
        for N in divisions:
            add("rebound", integrator, 2, T / N, "dt", _rebound_fixed(x0, v0, integrator, N, T, orbits))
    for eps in cfg.ias15_eps:
        add("rebound", "ias15", 15, eps, "epsilon", _ias15(x0, v0, eps, T, orbits))
    heyoka = 'skipped: heyoka is not installed (pip install "emorbit[peers]")'
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
    return {
        "name": name,
        "a": a,
        "e": float(np.linalg.norm(((np.dot(v0, v0) - GM / np.linalg.norm(x0)) * x0 - np.dot(x0, v0) * v0) / GM)),
        "period_s": T,
        "orbits": orbits,
        "heyoka": heyoka,
        "points": points,
    }


def run(cfg) -> dict:
    """Measure the section: both orbits, every engine.

    Parameters
    ----------
    cfg : Config
        A configuration of :data:`emorbit.bench.common.CONFIGS` (orbits, steps, epsilons,
        tolerances).

    Returns
    -------
    dict
        JSON-ready: per orbit its ``points`` (engine, method, order, parameter, CPU time,
        position and energy errors, status, Pareto flags) and whether heyoka ran.
    """
    try:
        system = _heyoka_system()
    except ImportError:
        system = None
    x9, v9 = aphelion_state(6.0, 0.9)
    orbits = [
        _orbit("paper", PAPER_X0, PAPER_V0, cfg.divisions, cfg, system),
        _orbit("e09", x9, v9, cfg.divisions_e09, cfg, system),
    ]
    return {
        "case": (
            f"{cfg.orbits} orbits from aphelion: final position error / a against the Kepler solution, "
            f"max |dE/E| over {CHECKPOINTS_PER_ORBIT} checkpoints per orbit, CPU time of the run"
        ),
        "orbits": orbits,
        "heyoka": orbits[0]["heyoka"],
    }


# -- figures ---------------------------------------------------------------------------------
_MAPS = {"em": "Blues", "midpoint": "Greens", "leapfrog": "Oranges", "em adaptive": "Purples"}
_PEERS = {
    ("rebound", "ias15"): ("REBOUND IAS15 (epsilon)", "tab:red", "*", "-"),
    ("rebound", "whfast"): ("REBOUND WHFast (exact Kepler drift)", "tab:purple", "x", "--"),
    ("rebound", "leapfrog"): ("REBOUND leapfrog", "tab:brown", "+", "--"),
    ("heyoka", "taylor"): ("heyoka Taylor (tolerance)", "black", "P", "-"),
}
_MARKERS = {2: "o", 4: "s", 6: "^", 8: "D"}


def _style(engine, method, order):
    """(label, color, marker, line style) of a series."""
    if engine == "emorbit":
        import matplotlib

        color = matplotlib.colormaps[_MAPS[method]](0.35 + 0.65 * (order - 2) / 6)
        ls = {"em": "-", "em adaptive": "-."}.get(method, ":")
        return f"emorbit {method} {order}", color, _MARKERS[order], ls
    return _PEERS[(engine, method)]


def plot(orbit: dict, path: str) -> None:
    """Draw one orbit's work-precision figure: position and energy error against CPU time.

    Parameters
    ----------
    orbit : dict
        One entry of the section's ``orbits``.
    path : str
        The PNG to write.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(13, 6.2), constrained_layout=True)
    series = {}
    for p in orbit["points"]:
        if p.get("status") == "ok":
            key = (p["engine"], p["method"], p["order"] if p["engine"] == "emorbit" else 0)
            series.setdefault(key, []).append(p)
    for ax, key, flag, label in (
        (axes[0], "position_error", "pareto_position", "final position error / a"),
        (axes[1], "energy_error", "pareto_energy", "max |dE/E| over the run"),
    ):
        for (engine, method, order), pts in sorted(series.items()):
            pts = sorted(pts, key=lambda p: p["cpu_s"])
            name, color, marker, ls = _style(engine, method, order)
            xs, ys = [p["cpu_s"] for p in pts], [max(p[key], 1e-17) for p in pts]
            ax.loglog(
                xs,
                ys,
                ls=ls,
                marker=marker,
                color=color,
                ms=5,
                lw=1.2 if engine == "emorbit" else 1.5,
                label=name if ax is axes[0] else None,
            )
            if engine != "emorbit" or method == "em adaptive":
                for p, x_, y_ in zip(pts, xs, ys):
                    param = p.get("epsilon", p.get("tolerance", p.get("eta")))
                    if param is not None:
                        ax.annotate(
                            f"{param:.0e}", (x_, y_), fontsize=6, color=color, xytext=(3, 3), textcoords="offset points"
                        )
        front = sorted((p for pts in series.values() for p in pts if p[flag]), key=lambda p: p["cpu_s"])
        fx, fy = [p["cpu_s"] for p in front], [max(p[key], 1e-17) for p in front]
        ax.step(
            fx,
            fy,
            where="post",
            color="0.3",
            lw=3,
            alpha=0.3,
            zorder=0,
            label="Pareto front (circled)" if ax is axes[0] else None,
        )
        ax.scatter(fx, fy, s=110, facecolors="none", edgecolors="0.15", lw=1.2, zorder=5)
        ax.set_xlabel(f"CPU time for {orbit['orbits']} orbits [s]")
        ax.set_ylabel(label)
        ax.grid(True, which="major", alpha=0.3)
    fig.legend(fontsize=7, ncol=6, loc="outside lower center")
    fig.suptitle(
        f"What accuracy costs: a = {orbit['a']:.2f} m, e = {orbit['e']:.3g}, {orbit['orbits']} orbits from "
        "aphelion (one particle, one thread)",
        fontsize=11,
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)


def table(section: dict) -> list[str]:
    """The section as printable lines: each orbit's Pareto front and em's best points.

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
            what = f"{p['engine']} {p['method']}" + (f" {p['order']}" if p["engine"] == "emorbit" else "")
            param = next(f"{k} {p[k]:.3g}" for k in ("dt", "epsilon", "tolerance", "eta") if k in p)
            lines.append(
                f"    {what:<24} {param:<18} {1e3 * p['cpu_s']:>10.3f} ms  position {p['position_error']:.1e}"
                f"  energy {p['energy_error']:.1e}"
            )
        best = {}
        for p in orbit["points"]:
            if p.get("status") == "ok" and p["engine"] == "emorbit" and p["method"] == "em":
                b = best.get(p["order"])
                if b is None or p["position_error"] < b["position_error"]:
                    best[p["order"]] = p
        for order, p in sorted(best.items()):
            lines.append(
                f"    best em order {order}: position {p['position_error']:.1e} in {1e3 * p['cpu_s']:.1f} ms "
                f"(dt = T/{orbit['period_s'] / p['dt']:.0f}), energy {p['energy_error']:.1e}"
            )
        for p in orbit["points"]:
            if p.get("status") == "ok" and p["method"] == "em adaptive":
                lines.append(
                    f"    em adaptive order {p['order']}, eta {p['eta']:g}: position {p['position_error']:.1e} "
                    f"in {1e3 * p['cpu_s']:.1f} ms ({p['steps'] / orbit['orbits']:.0f} steps per orbit), "
                    f"energy {p['energy_error']:.1e}"
                )
    return lines
