"""Figures from run files: the paper's energy figure (several runs on one axes) and the orbit."""

from __future__ import annotations

import os

import numpy as np

from .io.hdf5 import read

__all__ = ["plot_runs", "euler_angles"]


def _label(path, res) -> str:
    return f"{os.path.basename(path)}: {res.method}, order {res.order}, dt = {res.dt:.6g} s"


def euler_angles(q) -> np.ndarray:
    """Yaw, pitch and roll (z-y'-x'' Euler angles) of body-to-space quaternions.

    Parameters
    ----------
    q : array_like
        Unit quaternions (n, 4), scalar first.

    Returns
    -------
    ndarray
        (n, 3): yaw, pitch, roll in rad.
    """
    w, x, y, z = np.asarray(q, float).T
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    return np.stack([yaw, pitch, roll], axis=1)


def _plot_attitudes(runs, axes) -> None:
    ax_ang, ax_om, ax_spare = axes
    for path, res in runs:
        for name, q in res.attitudes.items():
            ang = np.degrees(euler_angles(q))
            for k, label in enumerate(("yaw", "pitch", "roll")):
                ax_ang.plot(res.time, ang[:, k], lw=0.7, label=f"{os.path.basename(path)}: {name} {label}")
            om = res.angular_velocities[name]
            for k, label in enumerate("xyz"):
                ax_om.plot(res.time, om[:, k], lw=0.7, label=f"{os.path.basename(path)}: {name} {label}")
    ax_ang.set(xlabel="time [s]", ylabel="angle [deg]", title="attitude: yaw, pitch, roll (z-y'-x'')")
    ax_om.set(xlabel="time [s]", ylabel="rad/s", title="angular velocity (body frame)")
    for ax in (ax_ang, ax_om):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    ax_spare.axis("off")


def plot_runs(paths, output, *, title: str | None = None) -> str:
    """Plot run files: energy error over time, the orbits, and rigid bodies' attitudes.

    The relative energy error of every file goes on shared axes (linear, as in the paper,
    and its magnitude on a log scale), the orbits in an x-y projection with the centre
    marked; for rigid bodies a second row shows their attitude angles and body-frame
    angular velocity.

    Parameters
    ----------
    paths : list of str
        HDF5 run files.
    output : str or os.PathLike
        The figure to write, in any format matplotlib knows by its extension.
    title : str, optional
        A title over the figure.

    Returns
    -------
    str
        The path of the figure.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = [(p, read(p)) for p in paths]
    rigid = any(res.attitudes for _, res in runs)
    fig, axes = plt.subplots(
        2 if rigid else 1, 3, figsize=(16, 9.6 if rigid else 4.8), constrained_layout=True, squeeze=False
    )
    ax_lin, ax_log, ax_orb = axes[0]
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
    if rigid:
        _plot_attitudes(runs, axes[1])
    if title:
        fig.suptitle(title)
    fig.savefig(output, dpi=120)
    plt.close(fig)
    return os.fspath(output)
