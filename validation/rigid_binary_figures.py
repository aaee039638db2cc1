"""The figure of the rigid binary (PNG, matplotlib's Agg backend): the centres' paths, position
and attitude errors against DOP853 over time per order, the energy error of em beside
DOP853's, the convergence of every order, and the tumbling of both bodies."""

from __future__ import annotations

import os

import numpy as np

from .figures import FLOOR, _plt, _thin

__all__ = ["rigid_binary_figure"]

ORDERS = (2, 4, 6, 8)


def _paths(ax, run):
    ref, em8, em2 = run.referee, run.main(8), run.main(2)
    for k, name in enumerate(run.case.names):
        (line,) = ax.plot(em8.x[:, k, 0], em8.x[:, k, 1], lw=0.8, label=f"{name}: {em8.label}")
        ax.plot(ref.x[:, k, 0], ref.x[:, k, 1], ":", color=line.get_color(), lw=1.4)
        ax.plot(em2.x[:, k, 0], em2.x[:, k, 1], lw=0.4, alpha=0.5, color=line.get_color())
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"centres of mass (dotted: DOP853; faint: {em2.label})")
    ax.set_aspect("equal", adjustable="datalim")


def _errors(ax, run, kind):
    T, ref, loose = run.case.period, run.referee, run.loose
    for p in ORDERS:
        tr = run.main(p)
        err = tr.position_error(ref, run.case.length) if kind == "position" else tr.attitude_error(ref)
        ax.semilogy(*_thin(tr.t / T, err), lw=0.9, label=tr.label)
    err = loose.position_error(ref, run.case.length) if kind == "position" else loose.attitude_error(ref)
    ax.semilogy(*_thin(loose.t / T, err), "k--", lw=0.9, label=f"{loose.label} vs {ref.label}")
    unit = "|x - x_DOP853| / a, worse body" if kind == "position" else "rotation angle to DOP853 [rad], worse body"
    ax.set(xlabel="time [periods]", ylabel=unit, title=f"{kind} against DOP853 (rtol 1e-13)")


def _energy(ax, run):
    T = run.case.period
    e_scale = run.referee.info["scales"][0]
    for p in ORDERS:
        tr = run.main(p)
        ax.semilogy(*_thin(tr.t / T, np.abs(tr.energy - tr.energy[0]) / e_scale), lw=0.9, label=tr.label)
    for tr, style in ((run.referee, "k-"), (run.loose, "k--")):
        ax.semilogy(*_thin(tr.t / T, np.abs(tr.energy - tr.energy[0]) / e_scale), style, lw=0.9, label=tr.label)
    ax.axhline(1e-12, color="gray", ls=":", lw=0.8)
    ax.set(xlabel="time [periods]", ylabel="|E - E0| / (T + |V|)", title="energy: em exact, DOP853 drifts")


def _convergence(ax, run):
    for p in ORDERS:
        d = run.convergence[p]
        n = np.asarray(d["steps_per_period"], float)
        for key, style, what in (("error", "o-", "position [a]"), ("attitude", "s--", "attitude [rad]")):
            e = np.maximum(np.asarray(d[key], float), FLOOR)
            label = f"order {p} {what}: {d['observed_' + ('position' if key == 'error' else key)]:.2f}"
            ax.loglog(n, e, style, ms=3, lw=1, label=label, color=f"C{ORDERS.index(p)}")
    ax.set(xlabel="steps per period", ylabel="max error against DOP853", title="convergence (observed orders)")


def _spins(ax, run):
    T, n = run.case.period, run.case.extra["n"]
    em8, ref = run.main(8), run.referee
    for k, name in enumerate(run.case.names):
        for j, axis in enumerate("xyz"):
            (line,) = ax.plot(em8.t / T, em8.w[:, k, j] / n, lw=0.8, label=f"{name}: w_{axis}")
            ax.plot(ref.t / T, ref.w[:, k, j] / n, ":", color=line.get_color(), lw=1.2)
    ax.set(xlabel="time [periods]", ylabel="w / n (body frame)", title=f"tumbling: {em8.label} (dotted: DOP853)")


def rigid_binary_figure(run, outdir: str) -> str:
    """Write ``rigid-binary.png`` of a finished run and return its file name."""
    plt = _plt()
    fig, axes = plt.subplots(2, 3, figsize=(18, 9))
    fig.subplots_adjust(left=0.05, right=0.99, bottom=0.07, top=0.92, hspace=0.28, wspace=0.22)
    _paths(axes[0, 0], run)
    _errors(axes[0, 1], run, "position")
    _errors(axes[0, 2], run, "attitude")
    _energy(axes[1, 0], run)
    _convergence(axes[1, 1], run)
    _spins(axes[1, 2], run)
    for ax in np.ravel(axes):
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=6, ncol=2 if ax is axes[1, 2] else 1)
    c = run.case
    fig.suptitle(f"{c.name}: {c.title}")
    name = f"{c.name}.png"
    fig.savefig(os.path.join(outdir, name), dpi=90)
    plt.close(fig)
    return name
