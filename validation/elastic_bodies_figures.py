"""The figures of the elastic cases (PNG, matplotlib's Agg backend), one per case:

- ``elastic-bar-axial.png``: the modal coordinates, emorbit's frequencies against the exact
  chain, their convergence to the continuum, the invariants' drift;
- ``elastic-cantilever.png``: the tip's motion, the mode shapes against Euler-Bernoulli's, the
  convergence of both frequencies with the Richardson extrapolation and Timoshenko's
  correction, emorbit against the referee's discrete modes and the invariants' drift;
- ``elastic-spinning-bar.png``: the ends' paths, the steady separation at round-off, the radial
  oscillation and its frequency's convergence in the step, the SVK tension law with the steady
  spins on it, the invariants' drift.
"""

from __future__ import annotations

import math

import numpy as np

from .figures import FLOOR, _thin, panels, save_panels

__all__ = ["FIGURES", "bar_figure", "cantilever_figure", "spinning_figure"]

EPS = float(np.finfo(float).eps)


def _drift(ax, run, period, unit):
    """The running maximum of each run's energy and angular-momentum drift, in eps (floor 1e-2)."""
    for k, style in enumerate(("-", ":")):
        for i, tr in enumerate(run.runs.values()):
            if "drift" not in tr.series:
                continue
            d = np.maximum.accumulate(np.maximum(tr.series["drift"][:, 2 * k], 0.0) / EPS)
            t, d = _thin(tr.t / period, d)
            ax.semilogy(t, np.maximum(d, 1e-2), style, lw=0.8, color=f"C{i % 10}", label=tr.label if k == 0 else None)
    ax.set(
        xlabel=f"time [{unit}]",
        ylabel="running max of drift / (eps x round-off scale)",
        title="energy (solid) and angular momentum (dotted) at round-off",
    )


def bar_figure(run, outdir: str) -> str:
    """Write ``elastic-bar-axial.png`` of a finished :class:`~.elastic_bar.BarRun`; return its name."""
    from .elastic_bar import BAR_FREQUENCY

    s = run.case.settings
    T = run.case.period
    fig, axes = panels(2, 2, figsize=(14, 9), left=0.06, wspace=0.2)
    N = s["elements"][-1]
    tr = run.runs[f"lumped mass, N = {N}"]
    for k, n in enumerate(s["modes"]):
        eta = tr.series["eta"][:, k]
        axes[0, 0].plot(tr.t / T, eta / np.abs(eta).max() + 2.5 * k, lw=0.8, label=f"mode {n}")
    axes[0, 0].set(xlabel="time [T_1]", ylabel="modal coordinate (scaled, offset)", title=f"{tr.label}: modes 1-3")
    ax = axes[0, 1]
    Ns = np.asarray(s["elements"], float)
    for mm in s["mass_matrices"]:
        for k, n in enumerate(s["modes"]):
            err = np.abs([run.spatial[(mm, int(N))][k] / run.continuum[k] - 1 for N in Ns])
            exact = np.abs([run.exact[(mm, int(N))][k] / run.continuum[k] - 1 for N in Ns])
            color = f"C{k}"
            marker = dict(marker="s", mfc="none", ms=7) if mm == "lumped" else dict(marker="o", ms=4)
            ax.loglog(Ns, err, ls="none", color=color, label=f"{mm}, mode {n}: emorbit", **marker)
            ax.loglog(Ns, exact, "-" if mm == "lumped" else "--", lw=0.8, color=color)
    ax.set(
        xlabel="bars N",
        ylabel="|w / (n pi c / L) - 1|",
        title="against n pi c / L (lines: exact chains, lumped below)",
    )
    ax = axes[1, 0]
    for i, mm in enumerate(s["mass_matrices"]):
        for k, n in enumerate(s["modes"]):
            dev = [abs(run.omega[(mm, int(N))][k] / run.carried[(mm, int(N))][k] - 1) for N in Ns]
            ax.semilogy(Ns * (1 + 0.03 * (3 * i + k - 2.5)), np.maximum(dev, FLOOR), "o", ms=4, label=f"{mm}, mode {n}")
    ax.axhline(BAR_FREQUENCY, color="gray", ls=":", lw=0.8, label="tolerance")
    ax.set_xscale("log")
    ax.set_xticks(Ns, [str(int(x)) for x in Ns])
    ax.minorticks_off()
    ax.set(
        xlabel="bars N", ylabel="|w_em / w_h - 1|", title="emorbit against the exact chain through the midpoint rule"
    )
    _drift(axes[1, 1], run, T, "T_1")
    return save_panels(fig, axes, run.case, outdir, title_size=10)


def cantilever_figure(run, outdir: str) -> str:
    """Write ``elastic-cantilever.png`` of a finished :class:`~.elastic_cantilever.CantileverRun`; return its name."""
    from .elastic_cantilever import cantilever_shape

    s = run.case.settings
    th = run.theory
    fig, axes = panels()
    T = run.case.period
    for rec in run.meshes.values():
        tr = run.runs[rec["label"]]
        axes[0, 0].plot(tr.t / T, tr.series["tip"] / s["length"], lw=0.8, label=rec["label"])
    axes[0, 0].set(xlabel="time [Euler-Bernoulli T_1]", ylabel="tip z displacement / L", title="the tip (modes 1 + 2)")
    ax = axes[0, 1]
    x = np.linspace(0, 1, 200)
    fine = list(run.meshes.values())[-1]
    for k in range(2):
        ax.plot(x, cantilever_shape(th["beta_L"][k], x), "k-", lw=0.8, label="Euler-Bernoulli" if k == 0 else None)
        ax.plot(fine["shape_x"], fine["shape"][:, k], "o", ms=2.5, color=f"C{k}", label=f"referee, mode {k + 1}")
    ax.set(xlabel="x / L", ylabel="z (tip = 1)", title=f"mode shapes, {fine['label']}")
    ax = axes[0, 2]
    h = np.array([r["h"] for r in run.meshes.values()])
    for k in range(2):
        err = np.array([abs(r["spatial"][k] / th["omega"][k] - 1) for r in run.meshes.values()])
        ref = np.array([abs(r["omega_ref"][k] / th["omega"][k] - 1) for r in run.meshes.values()])
        ax.loglog(h, err, "o", ms=5, color=f"C{k}", label=f"mode {k + 1}: emorbit")
        ax.loglog(h, ref, "-", lw=0.8, color=f"C{k}")
        ax.axhline(abs(th["delta"][k]), color=f"C{k}", ls=":", lw=0.8, label=f"|Timoshenko delta_{k + 1}|")
        if "richardson" in run.convergence:
            r = abs(run.convergence["richardson"][k] / th["omega"][k] - 1)
            ax.loglog([h[-1] / 2], [r], "*", ms=9, color=f"C{k}", label=f"mode {k + 1}: Richardson")
    ax.loglog(h, 0.5 * (h / h[0]) ** 2, "k--", lw=0.6, label="h^2")
    ax.set(xlabel="cell size h [m]", ylabel="|w / w_EB - 1|", title="convergence to Euler-Bernoulli (lines: referee)")
    ax = axes[1, 0]
    recs = list(run.meshes.values()) + ([run.poisson_run] if run.poisson_run else [])
    for k in range(2):
        dev = [max(abs(r["omega"][k] / r["carried"][k] - 1), FLOOR) for r in recs]
        ax.semilogy(range(len(recs)), dev, "o", ms=5, label=f"mode {k + 1}")
    ax.set_xticks(range(len(recs)), [r["label"].replace(" cells", "") for r in recs], fontsize=7)
    tol = [ch.tolerance for ch in run.checks if ch.id == "frequency-discrete"]
    if tol:
        ax.axhline(tol[0], color="gray", ls=":", lw=0.8, label="tolerance")
    ax.set(ylabel="|w_em / w_h - 1|", title="emorbit against the referee's discrete modes (midpoint rule)")
    _drift(axes[1, 1], run, T, "T_1")
    ax = axes[1, 2]
    for i, rec in enumerate(run.meshes.values()):
        tr = run.runs[rec["label"]]
        eta = tr.series["eta"]
        ax.plot(tr.t / T, eta[:, 1] / np.abs(eta[:, 1]).max() + 2.5 * i, lw=0.7, label=rec["label"])
    ax.set(xlabel="time [Euler-Bernoulli T_1]", ylabel="mode 2's coordinate (scaled, offset)", title="mode 2")
    return save_panels(fig, axes, run.case, outdir, title_size=10)


def spinning_figure(run, outdir: str) -> str:
    """Write ``elastic-spinning-bar.png`` of a finished :class:`~.elastic_spinning.SpinningRun`; return its name."""
    from .elastic_spinning import STEADY_LENGTH, spinning_state

    s = run.case.settings
    fig, axes = panels()
    ax = axes[0, 0]
    for i, v in enumerate(run.steady.values()):
        xy = run.runs[v["label"]].series["xy"]
        ax.plot(xy[:, 1, 0], xy[:, 1, 1], "-", lw=0.8, color=f"C{i}", label=v["label"])
        ax.plot(xy[:, 0, 0], xy[:, 0, 1], "-", lw=0.8, color=f"C{i}")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="x [m]", ylabel="y [m]", title="steady spins: the ends")
    ax = axes[0, 1]
    for v in run.steady.values():
        tr = run.runs[v["label"]]
        ax.semilogy(*_thin(tr.t * run.states[(tr.info["stretch"], tr.info["mass_matrix"])]["omega"] / (2 * math.pi),
                           np.abs(tr.series["stretch"])), lw=0.7, label=v["label"])  # fmt: skip
    ax.axhline(STEADY_LENGTH, color="gray", ls=":", lw=0.8, label="tolerance")
    ax.set(xlabel="time [turns]", ylabel="|s / (lam L0) - 1|", title="steady separation: round-off")
    ax = axes[0, 2]
    (lam, mm), fits = next(iter(run.radial.items()))
    tr = run.runs[fits[-1][2]]
    Om = run.states[(lam, mm)]["radial"]
    ax.plot(tr.t * Om / (2 * math.pi), tr.series["stretch"], lw=0.8, label=tr.label)
    ax.set(xlabel="time [radial periods 2 pi / Omega]", ylabel="s / (lam L0) - 1", title="radial oscillation")
    ax = axes[1, 0]
    for i, ((lam, mm), fits) in enumerate(run.radial.items()):
        Om = run.states[(lam, mm)]["radial"]
        n = np.array([f[0] for f in fits], float)
        e = np.abs([f[1] / Om - 1 for f in fits])
        ax.loglog(n, e, "o-", ms=4, color=f"C{i}", label=f"lam = {lam:g}, {mm}")
        conv = run.convergence[f"lam{lam:g}-{mm}"]
        ax.loglog([n[-1] * 1.4], [max(abs(conv["richardson"]), FLOOR)], "*", ms=8, color=f"C{i}")
        ax.set_xticks(n, [str(int(x)) for x in n])
        ax.minorticks_off()
    ax.set(
        xlabel="steps per radial period", ylabel="|Omega_em / Omega - 1|", title="radial frequency (star: Richardson)"
    )
    ax = axes[1, 1]
    lam = np.linspace(1.0, 2.2, 200)
    E, A = s["young"], s["area"]
    ax.plot(lam, E * A * lam * (lam**2 - 1) / 2, "k-", lw=1, label="SVK: N = A E lam (lam^2 - 1) / 2")
    ax.plot(lam, E * A * (lam - 1), "k:", lw=1, label="linear: N = A E (lam - 1)")
    for (lam0, mm, _), v in run.steady.items():
        st = spinning_state(s, lam0, mm, E)
        ax.plot([lam0], [st["reduced_mass"] * v["omega_measured"] ** 2 * st["separation"]], "o", ms=5,
                label=f"emorbit: {v['label']}")  # fmt: skip
    ax.set(xlabel="stretch lam", ylabel="tension [N]", title="tension from the measured spin (mu w^2 lam L0)")
    _drift(axes[1, 2], run, run.case.period, "turns at lam = 1.5")
    return save_panels(fig, axes, run.case, outdir, title_size=10)


#: the figure of each case by name
FIGURES = {
    "elastic-bar-axial": bar_figure,
    "elastic-cantilever": cantilever_figure,
    "elastic-spinning-bar": spinning_figure,
}
