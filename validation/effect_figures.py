"""Figures of the effect cases (PNG, matplotlib's Agg backend), one per case.

* ``j2-reboundx``: position error against IAS15 + REBOUNDx over time, energy error,
  convergence of every order, and the node and perigee drift of em and REBOUNDx;
* ``j2-secular``: node and perigee against first-order theory, the sun-synchronous node
  against 0.9856 deg/day, the difference from theory in units of n (J2 (R/p)^2)^2 at J2 and
  J2/2, energy errors, and every order's rates against IAS15's;
* ``mutual-two-body`` and ``figure-eight``: the paths, position error against the reference,
  energy, momentum and angular momentum errors, and convergence.
"""

from __future__ import annotations

import os

import numpy as np

from . import checks as C
from .figures import FLOOR, _plt, _thin
from .secular import SUN_SYNCHRONOUS_RATE, per_orbit_means

__all__ = ["effect_figures"]

ORDERS = (2, 4, 6, 8)


def _finish(fig, axes, run, outdir):
    for ax in np.ravel(axes):
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    c = run.case
    fig.suptitle(f"{c.name}: {c.title}")
    name = f"{c.name}.png"
    fig.savefig(os.path.join(outdir, name), dpi=90)
    _plt().close(fig)
    return name


def _energy_panel(ax, run, extra=()):
    T = run.case.period
    for p in ORDERS:
        tr = run.main(p)
        ax.semilogy(*_thin(tr.t / T, tr.rel_energy_error()), lw=0.9, label=tr.label)
    for tr in (run.named["IAS15"], *extra):
        if tr is None:  # IAS15 + REBOUNDx: REBOUNDx is not installed
            continue
        ax.semilogy(*_thin(tr.t / T, tr.rel_energy_error()), "--", lw=0.9, label=tr.label)
    ax.axhline(C.ENERGY_ORDER2, color="gray", ls=":", lw=0.8)
    ax.axhline(C.ENERGY_HIGH, color="gray", ls="--", lw=0.8)
    ax.set(xlabel="time [periods]", ylabel="|E - E0| / |E0|", title="energy error with the effects' potentials")


def _convergence_panel(ax, run, unit):
    for p in ORDERS:
        d = run.convergence.get(p)
        if not d:
            continue
        n = np.asarray(d["steps_per_period"], float)
        e = np.maximum(np.asarray(d["error"], float), FLOOR)
        order = np.argsort(n)
        label = f"order {p}" + (f": observed {d['observed']:.2f}" if "observed" in d else "")
        (line,) = ax.loglog(n[order], e[order], "o-", ms=3, lw=1, label=label)
        ax.loglog(n[order], e[order][-1] * (n[order] / n[order][-1]) ** -p, ":", color=line.get_color(), lw=0.8)
    if not run.convergence:  # the zonal cases' referee, REBOUNDx, is not installed
        ax.text(0.5, 0.5, "no referee: REBOUNDx not installed", ha="center", va="center", transform=ax.transAxes)
    ax.set(
        xlabel="steps per period", ylabel=f"max position error [{unit}]", title="convergence (dotted: nominal order)"
    )


def _position_panel(ax, run, pairs, unit, title):
    T = run.case.period
    for label, tr, ref, style in pairs:
        ax.semilogy(*_thin(tr.t / T, tr.position_error(ref, run.case.length)), style, lw=0.9, label=label)
    ax.plot([0, run.n], [FLOOR, C.POSITION_PER_ORBIT * run.n], ":", color="gray", label="em 8 tolerance")
    ax.set(xlabel="time [periods]", ylabel=f"|x - x_ref| / {unit}", title=title)


def _j2_reboundx(run, outdir):
    plt = _plt()
    c, nm = run.case, run.named
    ias = nm["IAS15"]
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5))
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.06, top=0.93, hspace=0.25, wspace=0.2)
    pairs = [("IAS15 (J2 = 0) vs Kepler", nm["IAS15, J2 = 0"], nm["Kepler"], "-.")]
    if ias is not None:
        pairs = [(f"{run.main(p).label} vs REBOUNDx", run.main(p), ias, "-") for p in ORDERS]
        pairs += [
            ("em 8 J2+J4 vs REBOUNDx J2+J4", nm["em8 J2+J4"], nm["IAS15 J2+J4"], "k--"),
            ("IAS15 (J2 = 0) vs Kepler", nm["IAS15, J2 = 0"], nm["Kepler"], "-."),
            ("J2's effect: REBOUNDx vs Kepler", ias, nm["Kepler"], ":"),
            ("J4's effect: REBOUNDx J2+J4 vs J2", nm["IAS15 J2+J4"], ias, ":"),
        ]
    title = "position against IAS15 + REBOUNDx" + (" (REBOUNDx not installed)" if ias is None else "")
    _position_panel(axes[0, 0], run, pairs, "a", title)
    _energy_panel(axes[0, 1], run)
    _convergence_panel(axes[1, 0], run, "a")
    ax = axes[1, 1]
    T = c.period
    for tr, style in ((run.main(8), "-"), (ias, "--")):
        if tr is None:
            continue
        el = tr.result.elements("satellite", si=True) if tr.result is not None else None
        if el is None:
            from emorbit import orbits

            el = orbits.elements(tr.x[:, 0], tr.v[:, 0], c.gm)
        for angle, name in ((el.raan, "Omega"), (el.argp, "omega")):
            w = np.degrees(np.unwrap(angle))
            ax.plot(tr.t / T, w - w[0], style, lw=0.9, label=f"{tr.label}: {name} - {name}0")
    ax.set(xlabel="time [orbits]", ylabel="deg", title="osculating node and perigee (em 8 and REBOUNDx)")
    return _finish(fig, axes, run, outdir)


def _j2_secular(run, outdir):
    plt = _plt()
    c = run.case
    rates, half, ias_rates = run.extra["rates"], run.extra["rates_half"], run.extra["rates_ias"]
    em8 = run.main(8)
    day = 86400.0
    fig, axes = plt.subplots(2, 3, figsize=(17, 8.5))
    fig.subplots_adjust(left=0.05, right=0.99, bottom=0.07, top=0.92, hspace=0.3, wspace=0.22)
    tm = per_orbit_means(em8.t, c.records)
    for name, r in rates.items():
        el = em8.result.elements(name, si=True)
        for ax, key, angle in ((axes[0, 0], "node", el.raan), (axes[0, 1], "perigee", el.argp)):
            if key == "perigee" and not r["perigee_checked"]:
                continue
            w = np.degrees(np.unwrap(angle))
            (line,) = ax.plot(em8.t / day, w - w[0], lw=0.5, alpha=0.6)
            wm = per_orbit_means(w - w[0], c.records)
            ax.plot(tm / day, wm, "o", ms=2, color=line.get_color(), label=f"{name}: per-orbit means")
            ax.plot(tm / day, wm[0] + np.degrees(r[f"{key}_theory"]) * (tm - tm[0]), "k--", lw=0.7)
    axes[0, 0].set(xlabel="time [days]", ylabel="Omega - Omega0 [deg]", title="node (dashed: first-order theory)")
    axes[0, 1].set(xlabel="time [days]", ylabel="omega - omega0 [deg]", title="perigee (dashed: first-order theory)")
    ax = axes[0, 2]
    sso = c.extra["sso"]
    el = em8.result.elements(sso, si=True)
    w = np.degrees(np.unwrap(el.raan))
    wm = per_orbit_means(w - w[0], c.records)
    target = np.degrees(SUN_SYNCHRONOUS_RATE) * (tm - tm[0])
    ax.plot(tm / day, wm - wm[0] - target, "o-", ms=2, lw=0.8, label="em 8: per-orbit mean node - 0.9856 deg/day x t")
    tol = abs(SUN_SYNCHRONOUS_RATE) * run.extra["sso_tolerance"]
    ax.fill_between(
        tm / day,
        -np.degrees(tol) * (tm - tm[0]),
        np.degrees(tol) * (tm - tm[0]),
        color="gray",
        alpha=0.2,
        label="tolerance: first-order theory's error",
    )
    ax.set(xlabel="time [days]", ylabel="deg", title="sun-synchronous node against 360 deg / 365.2422 days")
    ax = axes[1, 0]
    names = list(rates)
    xs = np.arange(len(names))
    for dx, key, mark in ((-0.15, "node", "o"), (0.15, "perigee", "s")):
        for src, fill, lab in ((rates, None, "J2"), (half, "none", "J2/2")):
            ys = [
                (src[n][key] - src[n][f"{key}_theory"]) / src[n]["scale2"]
                if src[n]["perigee_checked"] or key == "node"
                else np.nan
                for n in names
            ]
            ax.plot(xs + dx, ys, mark, mfc=fill, label=f"{key}, {lab}")
    node_tol = [C.SECULAR_NODE * abs(rates[n]["node_theory"]) * rates[n]["q"] / rates[n]["scale2"] for n in names]
    ax.plot(xs - 0.15, node_tol, "_", color="gray", ms=12, label="node tolerance")
    ax.plot(xs - 0.15, -np.asarray(node_tol), "_", color="gray", ms=12)
    ax.axhline(C.SECULAR_PERIGEE, color="gray", ls=":", lw=0.8)
    ax.axhline(-C.SECULAR_PERIGEE, color="gray", ls=":", lw=0.8)
    ax.set_xticks(xs, names, fontsize=7)
    ax.set(
        ylabel="(measured - theory) / (n (J2 (R/p)^2)^2)",
        title="difference from first-order theory: O(J2^2) (dotted: perigee tolerance)",
    )
    _energy_panel(axes[1, 1], run)
    ax = axes[1, 2]
    # against IAS15 + REBOUNDx; without REBOUNDx, orders 2-6 against em order 8
    ref_rates, ref = (ias_rates, "IAS15 + REBOUNDx") if ias_rates is not None else (rates, "em order 8")
    for p in ORDERS if ias_rates is not None else ORDERS[:-1]:
        from .effect_checks import rates_of

        rp = rates if p == 8 else rates_of(run, run.main(p))
        ys = [abs(rp[n]["node"] / ref_rates[n]["node"] - 1) for n in names]
        ax.semilogy(xs, np.maximum(ys, FLOOR), "o-", ms=3, lw=0.8, label=f"em {p}: node")
        ys = [
            abs(rp[n]["perigee"] / ref_rates[n]["perigee"] - 1) if rp[n]["perigee_checked"] else np.nan for n in names
        ]
        ax.semilogy(xs, np.maximum(ys, FLOOR), "s--", ms=3, lw=0.8, label=f"em {p}: perigee")
    ax.set_xticks(xs, names, fontsize=7)
    ax.set(ylabel="|rate / rate_ref - 1|", title=f"mean rates against {ref} (dt = T/100)")
    return _finish(fig, axes, run, outdir)


def _mutual(run, outdir):
    plt = _plt()
    c = run.case
    ias, ref = run.named["IAS15"], run.named["reference"]
    unit = "a" if c.name == "mutual-two-body" else "L"
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5))
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.06, top=0.93, hspace=0.25, wspace=0.2)
    ax = axes[0, 0]
    em8 = run.main(8)
    for k, name in enumerate(c.names):
        (line,) = ax.plot(em8.x[:, k, 0], em8.x[:, k, 1], lw=0.8, label=f"{name}: {em8.label}")
        ax.plot(ref.x[:, k, 0], ref.x[:, k, 1], ":", color=line.get_color(), lw=1.2)
        em2 = run.main(2)
        ax.plot(em2.x[:, k, 0], em2.x[:, k, 1], lw=0.4, alpha=0.5, color=line.get_color())
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"paths (dotted: {ref.label}; faint: {run.main(2).label})")
    ax.set_aspect("equal", adjustable="datalim")
    pairs = [(f"{run.main(p).label} vs {ref.label}", run.main(p), ref, "-") for p in ORDERS]
    if ref is not ias:
        pairs.append((f"IAS15 vs {ref.label}", ias, ref, "k--"))
    else:
        tight = next(tr for label, tr in run.runs.items() if "epsilon" in label)
        pairs.append(("IAS15 vs IAS15 at epsilon 1e-11", ias, tight, "k--"))
    _position_panel(axes[0, 1], run, pairs, unit, f"position against {ref.label}")
    ax = axes[1, 0]
    T = c.period
    for p in ORDERS:
        tr = run.main(p)
        for q, scale, style, what in (
            (tr.energy, abs(tr.energy[0]), "-", "E"),
            (tr.momentum, tr.info["momentum_scale"], "--", "P"),
            (tr.angular_momentum, tr.info["angular_momentum_scale"], ":", "L"),
        ):
            d = np.abs(q - q[0]) if q.ndim == 1 else np.linalg.norm(q - q[0], axis=-1)
            ax.semilogy(*_thin(tr.t / T, d / scale), style, lw=0.8, label=f"em {p}: {what}")
    ax.axhline(C.ENERGY_ORDER2, color="gray", ls=":", lw=0.8)
    ax.set(
        xlabel="time [periods]", ylabel="relative error", title="invariants: E / |E0|, P / sum m|v|, L / sum m|x||v|"
    )
    _convergence_panel(axes[1, 1], run, unit)
    return _finish(fig, axes, run, outdir)


def effect_figures(run, outdir: str) -> list[str]:
    """Write the figure of a finished effect case run.

    Parameters
    ----------
    run : EffectRun
        The case's runs, checks and measurements.
    outdir : str
        The report folder.

    Returns
    -------
    list of str
        The figures' file names, in ``outdir``.
    """
    draw = {"j2-reboundx": _j2_reboundx, "j2-secular": _j2_secular}.get(run.case.name, _mutual)
    return [draw(run, outdir)]
