"""Figures from run files: the paper's energy figure (several runs on one axes) and the orbit."""

from __future__ import annotations

import os

import numpy as np

from .io.hdf5 import read

__all__ = ["plot_runs"]


def _label(path, res) -> str:
    return f"{os.path.basename(path)}: {res.method}, order {res.order}, dt = {res.dt:.6g} s"


def plot_runs(paths, output, *, title: str | None = None) -> str:
    """Plot the relative energy error over time of every file in ``paths`` on shared axes
    (linear, as in the paper, and |error| on a log scale) and the orbits (x-y projection,
    centre marked). Writes ``output`` (any format matplotlib knows by its extension)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = [(p, read(p)) for p in paths]
    fig, (ax_lin, ax_log, ax_orb) = plt.subplots(1, 3, figsize=(16, 4.8), constrained_layout=True)
    for path, res in runs:
        err = res.relative_energy_error()
        label = _label(path, res)
        ax_lin.plot(res.time, err, lw=0.8, label=label)
        floor = np.finfo(float).eps / 4
        ax_log.semilogy(res.time, np.maximum(np.abs(err), floor), lw=0.8, label=label)
        for name in res.names:
            x = res.positions[name]
            ax_orb.plot(x[:, 0], x[:, 1], lw=0.6, label=f"{os.path.basename(path)}: {name}")
        ax_orb.plot(res.center[0], res.center[1], "k+", ms=10)
    ax_lin.set(xlabel="time [s]", ylabel="(E - E0) / |E0|", title="relative energy error")
    ax_log.set(xlabel="time [s]", ylabel="|E - E0| / |E0|", title="relative energy error (log)")
    ax_orb.set(xlabel="x [m]", ylabel="y [m]", title="orbit (x-y projection, + = centre)")
    ax_orb.set_aspect("equal", adjustable="datalim")
    for ax in (ax_lin, ax_log, ax_orb):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    if title:
        fig.suptitle(title)
    fig.savefig(output, dpi=120)
    plt.close(fig)
    return os.fspath(output)
