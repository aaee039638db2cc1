"""Figures of one case (PNG, matplotlib's Agg backend): errors over time and convergence.

The paper's energy figure (em against midpoint) is drawn by :func:`emorbit.plot.plot_runs`
from the HDF5 files the paper case writes.
"""

from __future__ import annotations

import os

import numpy as np

from . import checks as C

__all__ = ["case_figures", "panel_figure", "panels", "save_panels"]

FLOOR = C.EPS / 4  # |error| below this is drawn at this level on log axes
MAX_POINTS = 1500


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


#: the layout of a figure of 2 x 3 panels (the body cases' figures)
PANEL_LAYOUT = {"left": 0.05, "right": 0.99, "bottom": 0.07, "top": 0.92, "hspace": 0.3, "wspace": 0.22}


def panels(rows: int = 2, cols: int = 3, figsize=(18, 9), **adjust):
    """A figure of ``rows`` x ``cols`` panels, laid out by :data:`PANEL_LAYOUT` (``adjust``
    overrides it).

    Returns
    -------
    tuple
        (figure, array of axes).
    """
    fig, axes = _plt().subplots(rows, cols, figsize=figsize)
    fig.subplots_adjust(**{**PANEL_LAYOUT, **adjust})
    return fig, axes


def save_panels(fig, axes, case, outdir: str, *, legend_size=6, wide=(), title_size=None) -> str:
    """Finish a figure of panels and write ``<case name>.png``: a grid on every panel, a legend
    where a panel has labelled lines, the case's name and title above.

    Parameters
    ----------
    fig, axes
        The figure and its panels (:func:`panels`).
    case : object
        The case: ``name`` and ``title``.
    outdir : str
        The report folder.
    legend_size : float
        The legends' font size.
    wide : sequence of int
        The panels, counted row by row, whose legend has two columns.
    title_size : float, optional
        The title's font size (default: matplotlib's).

    Returns
    -------
    str
        The file name, in ``outdir``.
    """
    for k, ax in enumerate(np.ravel(axes)):
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=legend_size, ncol=2 if k in wide else 1)
    fig.suptitle(f"{case.name}: {case.title}", **({} if title_size is None else {"fontsize": title_size}))
    name = f"{case.name}.png"
    fig.savefig(os.path.join(outdir, name), dpi=90)
    _plt().close(fig)
    return name


def panel_figure(run, outdir: str, drawers, *, figsize=(18, 9), wide=()) -> str:
    """Draw a finished case run on 2 x 3 panels, ``drawer(ax, run)`` of each of ``drawers`` row
    by row, and write ``<case name>.png`` (:func:`save_panels`, ``wide`` as there); return its
    name."""
    fig, axes = panels(figsize=figsize)
    for ax, draw in zip(np.ravel(axes), drawers):
        draw(ax, run)
    return save_panels(fig, axes, run.case, outdir, wide=wide)


def _thin(t, y):
    step = max(1, len(t) // MAX_POINTS)
    return t[::step], np.maximum(y[::step], FLOOR)


def _worst(y):
    """Per record, the worst particle."""
    return y.max(axis=1) if y.ndim == 2 else y


def case_figures(run, outdir: str) -> list[str]:
    """Write the figures of a finished case run.

    Parameters
    ----------
    run : object
        The case run (the runner's internal record of runs, checks and convergence study).
    outdir : str
        The report folder.

    Returns
    -------
    list of str
        The figures' file names, in ``outdir``.
    """
    plt = _plt()
    c = run.case
    named = run.named
    T = c.period
    kep, ias = named["Kepler"], named["IAS15"]
    a = run.a
    out = []

    # a fixed layout: constrained_layout would double the drawing time of these log axes
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5))
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.06, top=0.93, hspace=0.25, wspace=0.2)
    ax = axes[0, 0]
    for key in ("em2", "em4", "em6", "em8"):
        tr = named[key]
        m = len(tr.t)
        ax.semilogy(*_thin(tr.t / T, _worst(tr.position_error(kep.head(m), a))), lw=0.9, label=f"{tr.label} vs Kepler")
    em8 = named["em8"]
    ax.semilogy(
        *_thin(em8.t / T, _worst(em8.position_error(ias.head(len(em8.t)), a))), "k--", lw=0.9, label="em 8 vs IAS15"
    )
    ax.semilogy(*_thin(ias.t / T, _worst(ias.position_error(kep, a))), lw=0.9, label="IAS15 vs Kepler")
    whf = named["WHFast"]
    ax.semilogy(
        *_thin(whf.t / T, _worst(whf.position_error(named["Kepler (WHFast times)"], a))),
        lw=0.9,
        label="WHFast vs Kepler",
    )
    nh = run.nh
    ax.plot([0, nh], [FLOOR, C.POSITION_PER_ORBIT * nh], ":", color="gray", label="em 8 tolerance (1e-9 a / orbit)")
    ax.set(xlabel="time [orbits]", ylabel="|x - x_ref| / a", title="position error")

    ax = axes[0, 1]
    for key in ("em2", "em4", "em6", "em8", "midpoint2", "leapfrog2", "midpoint8", "leapfrog8", "IAS15"):
        tr = named[key]
        ax.semilogy(*_thin(tr.t / T, _worst(tr.rel_energy_error(c))), lw=0.9, label=tr.label)
    ax.axhline(C.ENERGY_ORDER2, color="gray", ls=":", lw=0.8)
    ax.axhline(C.ENERGY_HIGH, color="gray", ls="--", lw=0.8)
    ax.set(xlabel="time [orbits]", ylabel="|E - E0| / |E0|", title="relative energy error (tolerances dotted/dashed)")

    ax = axes[1, 0]
    em2 = named["em2"]
    for label, tr, style in (("em 2", em2, "-"), ("IAS15", ias, "--")):
        el = tr.elements(c)
        ax.semilogy(*_thin(tr.t / T, _worst(np.abs(el.a / el.a[0] - 1))), style, lw=0.9, label=f"{label}: |da| / a")
        ax.semilogy(*_thin(tr.t / T, _worst(np.abs(el.e - el.e[0]))), style, lw=0.9, label=f"{label}: |de|")
        ax.semilogy(*_thin(tr.t / T, _worst(tr.plane_tilt(c))), style, lw=0.9, label=f"{label}: plane tilt [rad]")
        if run.single and run.el0.e[0] >= C.CIRCULAR:
            w = np.unwrap(el.argp[:, 0])
            ax.semilogy(*_thin(tr.t / T, np.abs(w - w[0])), style, lw=0.9, label=f"{label}: |d omega| [rad]")
    ax.set(xlabel="time [orbits]", ylabel="drift", title="orbital elements (em 2 and IAS15)")

    ax = axes[1, 1]
    for key in ("em2", "em8", "midpoint2", "leapfrog2", "IAS15"):
        tr = named[key]
        ax.semilogy(*_thin(tr.t / T, _worst(tr.rel_angular_momentum_error(c))), lw=0.9, label=tr.label)
    ax.axhline(C.ANGULAR_MOMENTUM, color="gray", ls=":", lw=0.8)
    ax.set(xlabel="time [orbits]", ylabel="|L - L0| / |L0|", title="angular momentum error about the centre")
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"{c.name}: {c.title}")
    name = f"{c.name}.png"
    fig.savefig(os.path.join(outdir, name), dpi=90)
    plt.close(fig)
    out.append(name)

    if run.convergence:
        fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), sharey=True)
        fig.subplots_adjust(left=0.06, right=0.99, bottom=0.12, top=0.86, wspace=0.08)
        for ax, method in zip(axes, ("em", "midpoint", "leapfrog")):
            for p in (2, 4, 6, 8):
                d = run.convergence.get(f"{method}{p}")
                if not d or not d["steps_per_orbit"]:
                    continue
                n = np.asarray(d["steps_per_orbit"], float)
                e = np.maximum(np.asarray(d["error_a"], float), FLOOR)
                (line,) = ax.loglog(n, e, "o-", ms=3, lw=1, label=f"order {p}: observed {d['slope']:.2f}")
                ax.loglog(n, e[-1] * (n / n[-1]) ** -p, ":", color=line.get_color(), lw=0.8)
            lo, hi = next(iter(run.convergence.values()))["window_a"]
            ax.axhspan(lo, hi, color="gray", alpha=0.07)
            ax.set(xlabel="steps per orbit", title=f"{method}: error after one orbit (dotted: nominal order)")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
        axes[0].set_ylabel("|x - x_Kepler| / a")
        fig.suptitle(f"{c.name}: convergence against the analytic Kepler solution (shaded: fitted window)")
        name = f"{c.name}_convergence.png"
        fig.savefig(os.path.join(outdir, name), dpi=90)
        plt.close(fig)
        out.append(name)

    if c.name == "paper" and len(run.files) == 2:
        from emorbit.plot import plot_runs

        name = "paper_energy.png"
        plot_runs(
            [os.path.join(outdir, f) for f in run.files],
            os.path.join(outdir, name),
            title=f"The paper's figure: em against midpoint, dt = T/{c.steps}, {run.n} orbits",
        )
        out.insert(0, name)
    return out
