"""The figure of the torque-free case (PNG, matplotlib's Agg backend): the body rates through
the flips against DOP853, the rate errors over time per order, the convergence of the rates
and of the flip interval, and the energy and angular-momentum errors of em beside Exudyn's
generalized-alpha solver at large steps."""

from __future__ import annotations

import numpy as np

from .figures import FLOOR, _thin, panel_figure

__all__ = ["torque_free_figure"]

ORDERS = (2, 4, 6, 8)


def _color(p):
    return f"C{ORDERS.index(p)}" if p in ORDERS else "k"


def _rates(ax, run):
    T, ref, em = run.T, run.referee, run.main(2)
    for j, axis in enumerate("xyz"):
        (line,) = ax.plot(*_plain(em.t / T, em.series["w"][:, j]), lw=0.9, label=f"w_{axis}: {em.label}")
        ax.plot(ref.t / T, ref.series["w"][:, j], ":", color=line.get_color(), lw=1.6)
    first = run.referee.info["flips"][0] if run.referee.info["flips"] else 0.0
    k = np.arange(0, 2 * run.n + 1)
    for x in first + k * run.jacobi["flip"]:
        if x <= ref.t[-1]:
            ax.axvline(x / T, color="gray", lw=0.5, ls="--")
    ax.set(xlabel="time [T]", ylabel="body rate [rad/s]", title="the flips (dotted: DOP853; dashed: analytic T/2)")


def _plain(t, y, most=3000):
    step = max(1, len(t) // most)
    return t[::step], y[::step]


def _errors(ax, run):
    T, ref = run.T, run.referee
    w0 = np.linalg.norm(run.case.settings["omega0"])
    for p in run.case.settings["steps"]:
        n = run.case.settings["steps"][p][1]
        tr = run.main(p)
        err = np.linalg.norm(run.at_records(tr, n, "w") - ref.series["w"], axis=-1) / w0
        ax.semilogy(*_thin(ref.t / T, err), lw=0.9, label=tr.label)
    err = np.linalg.norm(run.loose.series["w"] - ref.series["w"], axis=-1) / w0
    ax.semilogy(*_thin(ref.t / T, err), "k--", lw=0.9, label=f"{run.loose.label} vs {ref.label}")
    ax.set(xlabel="time [T]", ylabel="|w - w_DOP853| / |w0|", title="body rates against DOP853 (rtol 1e-13)")


def _convergence(ax, run):
    for p in run.case.settings["steps"]:
        d = run.convergence[f"em{p}"]
        n = np.asarray(d["steps_per_period"], float)
        for key, style in (("rate", "o-"), ("attitude", "s--")):
            e = np.maximum(np.asarray(d[key], float), FLOOR)
            label = f"order {p} {key}: {d['observed_' + key]:.2f}"
            ax.loglog(n, e, style, ms=3, lw=1, label=label, color=_color(p))
    ax.set(xlabel="steps per period T", ylabel="max error ([|w0|], [rad])", title="convergence (observed orders)")


def _flip(ax, run):
    for p in run.case.settings["flip_orders"]:
        d = run.convergence[f"flip-em{p}"]
        n = np.asarray(d["steps_per_period"], float)
        ax.loglog(n, d["error"], "o-", ms=4, label=f"em {p}: observed {d['observed']:.3f}", color=_color(p))
        ax.loglog(n, d["error"][0] * (n[0] / n) ** p, ":", color="gray", lw=0.8)
    exact = run.jacobi["flip"]
    for (p, n), v in run.flips.items():
        if p not in run.case.settings["flip_orders"]:
            ax.loglog([n], [max(abs(v - exact) / exact, FLOOR)], "^", color=_color(p), label=f"em {p}")
    ax.set(
        xlabel="steps per period T",
        ylabel="|flip interval - T/2| / (T/2)",
        title=f"flip interval against Jacobi's T/2 = {exact:.6g} s",
    )


def _large(ax, run):
    s = run.case.settings
    w0 = np.linalg.norm(s["omega0"])
    wdt = np.array([w0 * dt for dt in run.large])
    ee = [max(_rel(tr)[0], FLOOR) for tr in run.large.values()]
    el = [max(_rel(tr)[1], FLOOR) for tr in run.large.values()]
    ax.loglog(wdt, ee, "ko-", lw=1.2, label="em 2: energy")
    ax.loglog(wdt, el, "ks--", lw=1.2, mfc="none", label="em 2: |L|")
    for i, node in enumerate(s["exudyn_nodes"]):
        for adaptive, style in ((True, "o-"), (False, "x:")):
            keys = [(node, dt, adaptive) for dt in run.large if (node, dt, adaptive) in run.exudyn]
            if not keys:
                continue
            x = np.array([w0 * k[1] for k in keys])
            e = np.array([_rel(run.exudyn[k])[0] for k in keys])
            ok = np.array([run.exudyn[k].info["converged"] for k in keys])
            what = "step reduction" if adaptive else "fixed step"
            ax.loglog(x, e, style, color=f"C{i + 1}", ms=5, lw=1, label=f"Exudyn {node} ({what}): energy")
            if (~ok).any():
                ax.loglog(x[~ok], e[~ok], "r*", ms=11, label="Newton failed (stopped)" if i == 0 else None)
    if run.exudyn_status != "ok":
        ax.text(0.05, 0.5, str(run.exudyn_status)[:60], transform=ax.transAxes, fontsize=7)
    ax.axhline(1e-14, color="gray", ls=":", lw=0.8)
    ax.set(xlabel="w dt", ylabel="max relative error over the run", title="large steps: em exact, generalized-alpha")


def _rel(tr):
    E, L = tr.series["energy"], tr.series["L"]
    return (
        float(np.abs(E - E[0]).max() / abs(E[0])),
        float(np.linalg.norm(L - L[0], axis=-1).max() / np.linalg.norm(L[0])),
    )


def _energy_time(ax, run):
    T = run.T
    dts = run.case.settings["large_dts"]
    dt = dts[min(2, len(dts) - 1)]
    w0 = np.linalg.norm(run.case.settings["omega0"])
    tr = run.large[dt]
    E = tr.series["energy"]
    ax.semilogy(tr.t / T, np.maximum(np.abs(E / E[0] - 1), FLOOR), "k-", lw=1, label=tr.label)
    for i, node in enumerate(run.case.settings["exudyn_nodes"]):
        for adaptive, style in ((True, "-"), (False, ":")):
            ex = run.exudyn.get((node, dt, adaptive))
            if ex is None:
                continue
            E = ex.series["energy"]
            ax.semilogy(
                ex.t / T, np.maximum(np.abs(E / E[0] - 1), FLOOR), style, color=f"C{i + 1}", lw=1, label=ex.label
            )
    ax.set(xlabel="time [T]", ylabel="|E / E0 - 1|", title=f"energy at w dt = {w0 * dt:.2g}")


def torque_free_figure(run, outdir: str) -> str:
    """Write ``torque-free.png`` of a finished :class:`~.torque_free.TorqueFreeRun` and return its
    file name."""
    drawers = (_rates, _errors, _convergence, _flip, _large, _energy_time)
    return panel_figure(run, outdir, drawers, figsize=(18, 9.5), wide=(2,))
