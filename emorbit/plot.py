"""Figures from run files: the paper's energy figure (several runs on one axes), the orbit or the
angular momentum, attitudes of rigid bodies and deformations of elastic ones.

The energy error of each run is its recorded points joined by a line over a shaded band: the
least and greatest error over the steps between records
(:meth:`emorbit.Result.relative_energy_error_range`), so a run recorded every k-th step shows
where it went between records, and a decimated record never looks like a dip the run did not
have. Under effects that do work (drag, radiation pressure, third bodies) the energy changes
with the physics: the error is then the energy balance ``(E - E0 - W) / |E0|``, labelled so,
and the log panel adds the energy's own change ``|E - E0| / |E0|`` as a dotted line in the
run's colour. Legends sit under the axes, never over the curves. Every run's bodies are drawn
along their paths (x-y projection; a central field's centre is marked); a free-space run adds
its relative angular-momentum error. Rigid bodies add their
attitude angles and body-frame angular velocity; elastic bodies add their deformation: the
largest distance of a node from the best rigid placement of the mesh's reference nodes
(:func:`deformation`), which is the tip deflection of a beam relative to its rigid motion and
the sag and stretch of a tether. A run whose effects record a turning central body (a gravity
field's ``body_frame``) adds each body's longitude over the ground against time and its
ground track (:func:`ground_track`). A run with events, or with effects that do work (drag, a
burn), adds each body's altitude against time, its events marked (an orbital lifetime ends at
its stopping event; a spiral climbs).
"""

from __future__ import annotations

import os

import astropy.units as u
import numpy as np

from .errors import InputError
from .io.reader import read

__all__ = ["plot_runs", "draw_runs", "check_figure_path", "euler_angles", "deformation", "body_frame", "ground_track"]


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


#: the energy panels' titles and labels: every run conservative, every run under effects that
#: do work (its error is the energy balance), or some of each
ENERGY_TITLES = {
    "energy": ("relative energy error", "(E - E0) / |E0|", "|E - E0| / |E0|"),
    "balance": (
        "energy balance error, W the work the effects do",
        "(E - E0 - W) / |E0|",
        "|E - E0 - W| / |E0| (dotted: |E - E0| / |E0|)",
    ),
    "both": (
        "relative energy error; the balance E - E0 - W where effects do work",
        "(E - E0) / |E0| or (E - E0 - W) / |E0|",
        "|E - E0| / |E0| or |E - E0 - W| / |E0|",
    ),
}


def _plot_energy(runs, ax_lin, ax_log, floor: float) -> None:
    """Each run's relative energy error, linear and in magnitude on a log scale: the records
    as a line over a band of the extremes between records, in the line's colour. Each band
    spans the interval that ends at its record (a step drawn before the record). Under
    effects that do work the error is the energy balance ``(E - E0 - W) / |E0|``, labelled
    so, and the energy's own change, what the physics did, is a dotted line beside it."""
    banded = False
    for path, res in runs:
        label = _label(path, res)
        balance = res.relative_energy_balance()
        if balance is not None:  # effects do work: the balance is the error, the change is physics
            label = f"{label}: (E - E0 - W) / |E0|"
            ax_lin.plot(res.time, balance, lw=0.8, label=label, zorder=3)
            (log_line,) = ax_log.semilogy(res.time, np.maximum(np.abs(balance), floor), lw=0.8, label=label, zorder=3)
            ax_log.semilogy(
                res.time, np.maximum(np.abs(res.relative_energy_error()), floor), lw=0.8, ls=":",
                color=log_line.get_color(), label=f"{_label(path, res)}: |E - E0| / |E0|, the work done", zorder=3,
            )  # fmt: skip
            continue
        err = res.relative_energy_error()
        (line,) = ax_lin.plot(res.time, err, lw=0.8, label=label, zorder=3)
        (log_line,) = ax_log.semilogy(res.time, np.maximum(np.abs(err), floor), lw=0.8, label=label, zorder=3)
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


def body_frame(res) -> dict | None:
    """The turning frame of the central body that a run's effects record (``body_frame`` in
    the ``effects`` attribute: ``axes``, ``angle``, ``rate``), or None."""
    import json

    try:
        effects = json.loads(res.attrs.get("effects", "[]"))
    except (TypeError, ValueError):
        return None
    for effect in effects if isinstance(effects, list) else []:
        if isinstance(effect, dict) and isinstance(effect.get("body_frame"), dict):
            return effect["body_frame"]
    return None


def ground_track(positions, center, time, frame) -> tuple[np.ndarray, np.ndarray]:
    """Longitude and latitude over the turning body, degrees.

    Parameters
    ----------
    positions : ndarray
        (n, 3) m, in the scene's axes.
    center : array_like
        (3,) the body's centre, m.
    time : ndarray
        (n,) s.
    frame : dict
        :func:`body_frame`'s: the body's axes (columns e1, e2, e3), its angle at time 0 (rad)
        and its rate (rad/s).

    Returns
    -------
    tuple of ndarray
        (n,) longitude (unwrapped: a drifting satellite's longitude runs on past 180) and
        (n,) latitude.
    """
    d = np.asarray(positions, float) - np.asarray(center, float)
    y = d @ np.asarray(frame["axes"], float)  # B^T d per row
    theta = float(frame["angle"]) + float(frame["rate"]) * np.asarray(time, float)
    c, s = np.cos(theta), np.sin(theta)
    east, north = c * y[:, 0] + s * y[:, 1], -s * y[:, 0] + c * y[:, 1]
    lon = np.degrees(np.unwrap(np.arctan2(north, east)))
    lat = np.degrees(np.arcsin(np.clip(y[:, 2] / np.linalg.norm(y, axis=1), -1.0, 1.0)))
    return lon, lat


def _plot_ground(runs, ax_lon, ax_track) -> None:
    """Each body's longitude over the turning central body against time, and its ground track."""
    for path, res in runs:
        frame = body_frame(res)
        if frame is None:
            continue
        for name in res.names:
            lon, lat = ground_track(res.positions[name], res.center, res.time, frame)
            ax_lon.plot(res.time / 86400.0, lon, lw=0.8, label=f"{_who(path, runs)}{name}")
            wrapped = (lon + 180.0) % 360.0 - 180.0
            ax_track.plot(wrapped, lat, ".", ms=1.5, color=ax_lon.lines[-1].get_color())
    ax_lon.set(xlabel="time [d]", ylabel="longitude [deg]", title="longitude over the turning body")
    ax_track.set(xlabel="longitude [deg]", ylabel="latitude [deg]", title="ground track", xlim=(-180, 180),
                 ylim=(-90, 90))  # fmt: skip
    for ax in (ax_lon, ax_track):
        ax.grid(True, alpha=0.3)
        _legend(ax)


def _plot_altitude(runs, ax) -> None:
    """Each body's altitude above the field's radius (the distance from the centre without
    one) against time, with the run's events marked where they fell."""
    for path, res in runs:
        if res.gm == 0.0:
            continue
        radius = float(res.attrs.get("field_radius", 0.0))
        for name in res.names:
            h = np.linalg.norm(res.positions[name] - res.center, axis=1) - radius
            ax.plot(res.time / 86400.0, h / 1e3, lw=0.8, label=f"{_who(path, runs)}{name}")
        for e in res.events:
            ax.axvline(e["time"] / 86400.0, color="0.5", lw=0.6, ls=":")
            ax.annotate(e["label"], (e["time"] / 86400.0, 1.0), xycoords=("data", "axes fraction"), rotation=90,
                        va="top", ha="right", fontsize=7)  # fmt: skip
    what = "altitude above the field's radius" if any(r.attrs.get("field_radius") for _, r in runs) else "distance"
    ax.set(xlabel="time [d]", ylabel=f"{what} [km]", title=f"{what}; dotted: events")


def _read(path):
    res = read(path, probe=True)  # a damaged file that would hang HDF5 fails in a child process instead
    if len(res) == 0:
        raise InputError("files", f"{os.fspath(path)!r} holds no records (the run stopped before its first)")
    return res


def _formats() -> dict:
    """{extension: format name} that matplotlib can write."""
    from matplotlib.backend_bases import FigureCanvasBase

    return FigureCanvasBase.get_supported_filetypes()


def check_figure_path(output, inputs=(), key: str = "output") -> str:
    """Refuse a figure path that would not give a new figure file, before anything is drawn.

    Parameters
    ----------
    output : str or os.PathLike
        The figure to write.
    inputs : iterable of str or os.PathLike
        The run files being plotted: the figure may not replace one.
    key : str
        The name the errors give the path (``"-o/--output"`` on the command line).

    Returns
    -------
    str
        The path.

    Raises
    ------
    InputError
        The path is a folder (or ends like one), would replace one of ``inputs`` or another
        thing that is not a regular file, lies in a folder that does not exist, or has no
        extension or one matplotlib cannot write (it would otherwise append ``.png`` itself,
        or fail after drawing).
    """
    path = os.fspath(output)
    name = os.path.basename(path)
    if os.path.isdir(path) or name in ("", ".", ".."):
        raise InputError(key, f"{path!r} is a folder; give a figure file, such as {os.path.join(path, 'fig.png')!r}")
    for run_file in inputs:
        if os.path.exists(path) and os.path.exists(run_file) and os.path.samefile(path, run_file):
            raise InputError(key, f"{path!r} is one of the run files being plotted; the figure would replace it")
    if os.path.exists(path) and not os.path.isfile(path):
        raise InputError(key, f"{path!r} exists and is not a regular file")
    folder = os.path.dirname(path)
    if folder and not os.path.isdir(folder):
        raise InputError(key, f"the folder {folder!r} does not exist")
    ext = os.path.splitext(name)[1].lstrip(".").lower()
    formats = _formats()
    if ext not in formats:
        known = ", ".join(f".{e}" for e in sorted(formats))
        what = "has no extension" if not ext else f"has the extension .{ext}, which matplotlib cannot write"
        raise InputError(key, f"{path!r} {what}; give one of {known}")
    return path


def draw_runs(runs, *, title: str | None = None):
    """Draw the figure of :func:`plot_runs` from runs in memory.

    Parameters
    ----------
    runs : list of tuple
        (name, :class:`~emorbit.result.ResultSI`) pairs: a label for each run (a file's path)
        and its records in SI units (``Result.si``).
    title : str, optional
        A title over the figure.

    Returns
    -------
    matplotlib.figure.Figure
        The figure (matplotlib's Agg backend); close it with ``matplotlib.pyplot.close``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rigid = any(res.attitudes for _, res in runs)
    elastic = any(_elastic(res) for _, res in runs)
    turning = any(body_frame(res) is not None for _, res in runs)
    field = any(res.gm != 0.0 for _, res in runs)
    events = field and any(res.events or res.work for _, res in runs)  # events, or effects that do work
    free = [(path, res) for path, res in runs if res.gm == 0.0]
    rows = 2 if rigid or elastic or turning or events else 1
    cols = 4 if free else 3
    fig, axes = plt.subplots(rows, cols, figsize=(5.3 * cols, 5.6 * rows), constrained_layout=True, squeeze=False)
    ax_lin, ax_log, ax_paths = axes[0][:3]
    floor = np.finfo(float).eps / 4
    _plot_energy(runs, ax_lin, ax_log, floor)
    kinds = {res.relative_energy_balance() is not None for _, res in runs}
    title_lin, ylabel_lin, ylabel_log = ENERGY_TITLES[
        "both" if len(kinds) == 2 else "balance" if True in kinds else "energy"
    ]
    ax_lin.set(xlabel="time [s]", ylabel=ylabel_lin, title=title_lin)
    ax_log.set(xlabel="time [s]", ylabel=ylabel_log, title=f"{title_lin} (log)")
    for path, res in runs:
        for name in res.names:
            x = res.positions[name]
            ax_paths.plot(x[:, 0], x[:, 1], lw=0.6, label=f"{_who(path, runs)}{name}")
            ax_paths.plot(x[-1, 0], x[-1, 1], "o", ms=3, color=ax_paths.lines[-1].get_color())
        if res.gm != 0.0:
            ax_paths.plot(res.center[0], res.center[1], "k+", ms=10)
    where = "orbit (x-y projection, + = centre" if field else "paths (x-y projection"
    ax_paths.set(xlabel="x [m]", ylabel="y [m]", title=f"{where}, dot = end)")
    ax_paths.set_aspect("equal", adjustable="datalim")
    panels = [ax_lin, ax_log, ax_paths]
    if free:
        ax_L = axes[0][3]
        for path, res in free:
            dL = res.relative_angular_momentum_error() if np.any(res.angular_momentum[0]) else np.zeros(len(res))
            ax_L.semilogy(res.time, np.maximum(dL, floor), lw=0.8, label=_label(path, res))
        ax_L.set(xlabel="time [s]", ylabel="|L - L0| / |L0|", title="relative angular-momentum error (log)")
        panels.append(ax_L)
    for ax in panels:
        ax.grid(True, alpha=0.3)
        _legend(ax)
    if rows == 2:
        second = list(axes[1])
        if rigid:
            _plot_attitudes(runs, second.pop(0), second.pop(0))
        if elastic:
            _plot_deformation(runs, second.pop(0))
        if turning and len(second) >= 2:
            _plot_ground(runs, second.pop(0), second.pop(0))
        if events and second:
            _plot_altitude(runs, second.pop(0))
        for ax in second:
            ax.axis("off")
    if title:
        fig.suptitle(title)
    return fig


def plot_runs(paths, output, *, title: str | None = None) -> str:
    """Plot run files: energy error, paths, angular momentum, attitudes and deformations.

    The relative energy error of every file goes on shared axes (linear, as in the paper,
    and its magnitude on a log scale), its records as a line over a shaded band of the
    extremes between records (:meth:`emorbit.Result.relative_energy_error_range`; absent
    where it adds nothing: every step recorded, or a file that holds no extremes). Under
    effects that do work (drag, radiation pressure, third bodies) the error drawn is the
    energy balance ``(E - E0 - W) / |E0|``, and the energy's change beside it. Every body is
    drawn along its path in an x-y projection (a central field's centre marked); free-space
    runs add their relative angular-momentum error.
    A second row shows rigid bodies' attitude angles and body-frame angular velocity and
    elastic bodies' :func:`deformation`. Legends sit under their axes.

    Parameters
    ----------
    paths : list of str
        HDF5 run files.
    output : str or os.PathLike
        The figure to write, in a format matplotlib knows by its extension
        (:func:`check_figure_path`).
    title : str, optional
        A title over the figure.

    Returns
    -------
    str
        The path of the figure.

    Raises
    ------
    InputError
        The figure's path is refused (:func:`check_figure_path`: nothing is written), or a
        file does not exist, is not an HDF5 file, is not an emorbit run file or holds no
        records.
    """
    check_figure_path(output, paths)
    runs = [(p, _read(p).si) for p in paths]  # plain SI arrays
    import matplotlib.pyplot as plt

    fig = draw_runs(runs, title=title)
    fig.savefig(output, dpi=120)
    plt.close(fig)
    return os.fspath(output)
