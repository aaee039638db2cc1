"""Figures from run files: the paper's energy figure (several runs on one axes), the orbit or the
angular momentum, attitudes of rigid bodies and deformations of elastic ones.

The energy error of each run is its recorded points joined by a line over a shaded band: the
least and greatest error over the steps between records
(:meth:`emorbit.Result.relative_energy_error_range`), so a run recorded every k-th step shows
where it went between records, and a decimated record never looks like a dip the run did not
have. Under effects that do work (drag) the log panel adds each run's energy balance,
``|E - E0 - W| / |E0|``, as a dashed line in its colour. Legends sit beside the axes, never over the
curves. A run in a central field gets an orbit panel (x-y projection with the centre marked); a
free-space run gets the relative angular-momentum error instead. Rigid bodies add their
attitude angles and body-frame angular velocity; elastic bodies add their deformation: the
largest distance of a node from the best rigid placement of the mesh's reference nodes
(:func:`deformation`), which is the tip deflection of a beam relative to its rigid motion and
the sag and stretch of a tether.
"""

from __future__ import annotations

import os

import astropy.units as u
import numpy as np

from .errors import InputError
from .io.reader import read

__all__ = ["plot_runs", "euler_angles", "deformation"]


def _label(path, res) -> str:
    return f"{os.path.basename(path)}: {res.method}, order {res.order}, dt = {res.dt:.6g} s"


#: the legend entry of the shaded bands of the energy error
BAND_LABEL = "extremes between records"


def _band(res) -> np.ndarray | None:
    """(n, 2) the least and greatest relative energy error over each record interval, or None
    where the run has no extremes beyond its records (every step recorded, or a file
    without them)."""
    band = res.relative_energy_error_range()
    err = res.relative_energy_error()
    if len(err) < 2 or (np.array_equal(band[:, 0], err) and np.array_equal(band[:, 1], err)):
        return None
    return band


def _plot_energy(runs, ax_lin, ax_log, floor: float) -> None:
    """Each run's relative energy error, linear and in magnitude on a log scale: the records
    as a line over a band of the extremes between records, in the line's colour. Each band
    spans the interval that ends at its record (a step drawn before the record)."""
    banded = False
    for path, res in runs:
        err = res.relative_energy_error()
        label = _label(path, res)
        (line,) = ax_lin.plot(res.time, err, lw=0.8, label=label, zorder=3)
        (log_line,) = ax_log.semilogy(res.time, np.maximum(np.abs(err), floor), lw=0.8, label=label, zorder=3)
        balance = res.relative_energy_balance()
        if balance is not None:  # under drag: the balance E - E0 - W beside the energy, dashed
            ax_log.semilogy(
                res.time, np.maximum(np.abs(balance), floor), lw=0.8, ls="--", color=log_line.get_color(),
                label=f"{label}: |E - E0 - W| / |E0|", zorder=3,
            )  # fmt: skip
        band = _band(res)
        if band is None:
            continue
        lo, hi = band[:, 0], band[:, 1]
        style = {"step": "pre", "alpha": 0.3, "lw": 0.5, "zorder": 2}  # edges: a band narrower than a pixel shows
        ax_lin.fill_between(res.time, lo, hi, color=line.get_color(), **style)
        straddles = (lo <= 0.0) & (hi >= 0.0)
        least = np.where(straddles, 0.0, np.minimum(np.abs(lo), np.abs(hi)))
        most = np.maximum(np.abs(lo), np.abs(hi))
        ax_log.fill_between(
            res.time, np.maximum(least, floor), np.maximum(most, floor), color=log_line.get_color(), **style
        )
        banded = True
    if banded:  # one legend entry for the bands of every run, in a neutral grey
        for ax in (ax_lin, ax_log):
            ax.fill_between([], [], [], color="0.5", alpha=0.3, lw=0, label=BAND_LABEL)


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


def _metres(value) -> np.ndarray:
    """Lengths as a plain array in m: a Quantity converted, anything else read as m."""
    if isinstance(value, u.Quantity):
        return value.to_value(u.m)
    return np.asarray(value, float)


def deformation(reference, nodes) -> np.ndarray:
    """How far an elastic body is from a rigid placement of its reference mesh.

    For every row of node positions the reference nodes are placed by the rotation and
    translation that fit them best in the least-squares sense (Kabsch), and the largest
    distance of a node from its placed reference position is returned: zero for a rigid
    motion, the tip deflection relative to the rigid motion for a beam.

    Parameters
    ----------
    reference : Quantity or array_like
        (N, 3) node positions in the body frame (a Quantity of length, or plain m).
    nodes : Quantity or array_like
        (k, N, 3) node positions in space (a Quantity of length, or plain m).

    Returns
    -------
    ndarray
        (k,) the largest node offset from the best rigid placement, m.
    """
    X = _metres(reference)
    Y = _metres(nodes)
    Xc = X - X.mean(axis=0)
    Yc = Y - Y.mean(axis=1, keepdims=True)
    H = np.matmul(Xc.T[None], Yc)  # (k, 3, 3)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.matmul(U, Vt)))
    S = np.broadcast_to(np.eye(3), H.shape).copy()
    S[:, 2, 2] = d
    R = np.matmul(np.matmul(U, S), Vt)  # Xc @ R is the best placement of the reference
    placed = np.matmul(Xc[None], R)
    return np.linalg.norm(Yc - placed, axis=-1).max(axis=-1)


def _legend(ax, ncol: int = 1) -> None:
    """A legend under the axes, outside the data."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=ncol, frameon=False)


def _who(path, runs) -> str:
    """The file's name before a curve's label when several files are plotted."""
    return f"{os.path.basename(path)}: " if len(runs) > 1 else ""


def _plot_attitudes(runs, ax_ang, ax_om) -> None:
    for path, res in runs:
        for name, q in res.attitudes.items():
            ang = np.degrees(euler_angles(q))
            for k, label in enumerate(("yaw", "pitch", "roll")):
                ax_ang.plot(res.time, ang[:, k], lw=0.7, label=f"{_who(path, runs)}{name} {label}")
            om = res.angular_velocities[name]
            for k, label in enumerate("xyz"):
                ax_om.plot(res.time, om[:, k], lw=0.7, label=f"{_who(path, runs)}{name} {label}")
    ax_ang.set(xlabel="time [s]", ylabel="angle [deg]", title="attitude: yaw, pitch, roll (z-y'-x'')")
    ax_om.set(xlabel="time [s]", ylabel="rad/s", title="angular velocity (body frame)")
    for ax in (ax_ang, ax_om):
        ax.grid(True, alpha=0.3)
        _legend(ax, ncol=3)


def _elastic(res) -> dict:
    """{name: (times, deformation)} of a run's elastic bodies with recorded nodes."""
    out = {}
    for name, kind in res.kinds.items():
        d = res.bodies.get(name, {})
        if kind == "elastic" and "nodes/position" in d and "mesh/reference_nodes" in d and len(d["nodes/time"]):
            out[name] = (d["nodes/time"], deformation(d["mesh/reference_nodes"], d["nodes/position"]))
    return out


def _plot_deformation(runs, ax) -> None:
    for path, res in runs:
        for name, (t, dev) in _elastic(res).items():
            ax.plot(t, dev, lw=0.8, label=f"{_who(path, runs)}{name}")
    ax.set(
        xlabel="time [s]",
        ylabel="largest node offset [m]",
        title="deformation: nodes from the best rigid placement",
    )
    ax.grid(True, alpha=0.3)
    _legend(ax)


def _read(path):
    res = read(path)
    if len(res) == 0:
        raise InputError("files", f"{os.fspath(path)!r} holds no records (the run stopped before its first)")
    return res


def plot_runs(paths, output, *, title: str | None = None) -> str:
    """Plot run files: energy error, orbits or angular momentum, attitudes and deformations.

    The relative energy error of every file goes on shared axes (linear, as in the paper,
    and its magnitude on a log scale), its records as a line over a shaded band of the
    extremes between records (:meth:`emorbit.Result.relative_energy_error_range`; absent
    where it adds nothing: every step recorded, or a file that holds no extremes). Runs in a
    central field add their orbits in an x-y projection with the centre marked; free-space
    runs the relative angular-momentum error.
    A second row shows rigid bodies' attitude angles and body-frame angular velocity and
    elastic bodies' :func:`deformation`. Legends sit under their axes.

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

    Raises
    ------
    InputError
        A file does not exist, is not an HDF5 file, is not an emorbit run file or holds no
        records.
    """
    runs = [(p, _read(p).si) for p in paths]  # plain SI arrays
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rigid = any(res.attitudes for _, res in runs)
    elastic = any(_elastic(res) for _, res in runs)
    field = any(res.gm != 0.0 for _, res in runs)
    rows = 2 if rigid or elastic else 1
    fig, axes = plt.subplots(rows, 3, figsize=(16, 5.6 * rows), constrained_layout=True, squeeze=False)
    ax_lin, ax_log, ax_third = axes[0]
    floor = np.finfo(float).eps / 4
    _plot_energy(runs, ax_lin, ax_log, floor)
    for path, res in runs:
        label = _label(path, res)
        if field:
            for name in res.names:
                x = res.positions[name]
                ax_third.plot(x[:, 0], x[:, 1], lw=0.6, label=f"{_who(path, runs)}{name}")
            ax_third.plot(res.center[0], res.center[1], "k+", ms=10)
        else:
            dL = res.relative_angular_momentum_error() if np.any(res.angular_momentum[0]) else np.zeros(len(res))
            ax_third.semilogy(res.time, np.maximum(dL, floor), lw=0.8, label=label)
    ax_lin.set(xlabel="time [s]", ylabel="(E - E0) / |E0|", title="relative energy error")
    ax_log.set(xlabel="time [s]", ylabel="|E - E0| / |E0|", title="relative energy error (log)")
    if field:
        ax_third.set(xlabel="x [m]", ylabel="y [m]", title="orbit (x-y projection, + = centre)")
        ax_third.set_aspect("equal", adjustable="datalim")
    else:
        ax_third.set(xlabel="time [s]", ylabel="|L - L0| / |L0|", title="relative angular-momentum error (log)")
    for ax in (ax_lin, ax_log, ax_third):
        ax.grid(True, alpha=0.3)
        _legend(ax)
    if rows == 2:
        second = list(axes[1])
        if rigid:
            _plot_attitudes(runs, second.pop(0), second.pop(0))
        if elastic:
            _plot_deformation(runs, second.pop(0))
        for ax in second:
            ax.axis("off")
    if title:
        fig.suptitle(title)
    fig.savefig(output, dpi=120)
    plt.close(fig)
    return os.fspath(output)
