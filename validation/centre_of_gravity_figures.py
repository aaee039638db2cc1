"""The figure of the centre-of-gravity case (PNG, matplotlib's Agg backend): emorbit's kernel
against the exact sums per attitude, the rod's convergence to its closed form, one em step's
force and torque against h, the gap between the centre of gravity and the centre of mass
against distance beside quadrupole theory, and the geometry at the paper's distance."""

from __future__ import annotations

import numpy as np

from .centre_of_gravity_referees import quadrupole_gap
from .figures import FLOOR, panel_figure

__all__ = ["centre_of_gravity_figure"]


def _sums(ax, run):
    for label, style in (("box, kernel vs exact sums", "o"), ("dumbbell, kernel vs closed form", "^")):
        tr = run.runs[label]
        for key, color in (("force", "C0"), ("torque", "C1")):
            if key in tr.series:
                y = np.maximum(tr.series[key], FLOOR)
                ax.semilogy(tr.t, y, style, ms=3, color=color if "box" in label else "C2", label=f"{label}: {key}")
    ax.axhline(2.220446049250313e-16, color="gray", ls=":", lw=0.8)
    ax.set(xlabel="attitude", ylabel="|error| / sum of |terms|", title="resultant force and torque: round-off")


def _rod(ax, run):
    d = run.convergence["rod"]
    n = np.asarray(d["points"], float)
    ax.loglog(n, d["force"], "o-", label=f"force: observed order {d['observed']:.4f}")
    ax.loglog(n, d["torque"], "s-", label="torque")
    ax.loglog(n, d["force"][0] * (n[0] / n) ** 2, "k:", lw=0.8, label="N^-2")
    ax.set(xlabel="mass points N", ylabel="|F_N - F| / |F|, worst attitude", title="rod of N points vs closed form")


def _step(ax, run):
    for kind, color in (("force", "C0"), ("torque", "C1")):
        s = run.step[kind]
        h = np.asarray(s["h"], float)
        ax.loglog(h, s["error"], "o-", color=color, label=f"{kind}: observed order {s['observed']:.5f}")
        ax.loglog([h[-1] / 2], [max(s["extrapolated"], FLOOR)], "*", ms=10, color=color, label=f"{kind}: extrapolated")
    ax.set(xlabel="h [s] (star: Richardson to h = 0)", ylabel="relative error", title="one em step from rest")


def _gaps(ax, run):
    for i, (name, per_R) in enumerate(run.gaps.items()):
        r = np.array(list(per_R))
        lo = np.array([v["gap_min"] for v in per_R.values()])
        hi = np.array([v["gap_max"] for v in per_R.values()])
        ax.fill_between(r, lo, hi, alpha=0.25, color=f"C{i}")
        ax.loglog(r, hi, "o-", color=f"C{i}", label=f"{name}: |x_g - x_c| (range over attitudes)")
        dev = np.array([v["deviation"] for v in per_R.values()])
        ax.loglog(r, dev * hi, "x--", color=f"C{i}", label=f"{name}: |d - d_quad| (worst, x max |d|)")
    ax.set(
        xlabel="distance r [m]", ylabel="m", title="centre of gravity - centre of mass: ~ l^2/r; quadrupole ~ l^4/r^3"
    )


def _deviation(ax, run):
    for i, (name, d) in enumerate((k[4:], v) for k, v in run.convergence.items() if k.startswith("gap-")):
        ax.loglog(d["distances"], d["deviation"], "o-", color=f"C{i}", label=f"{name}: observed {d['observed']:.3f}")
    ax.set(xlabel="distance r [m]", ylabel="|d - d_quad| / |d|, worst", title="against MacCullagh's quadrupole formula")


def _picture(ax, run):
    p = run.picture
    if not p:
        return
    x, F, g = p["x"], p["F"], p["g"]
    e1 = x / np.linalg.norm(x)
    f = F / np.linalg.norm(F)
    e2 = f - (f @ e1) * e1
    e2 = e2 / np.linalg.norm(e2) if np.linalg.norm(e2) > 0 else np.cross(e1, [0.0, 0.0, 1.0])
    pts = p["X"]  # offsets of the mass points from x_c, space axes

    def plane(v):
        return np.array([v @ e1, v @ e2])

    xy = np.array([plane(v) for v in pts.T])
    ax.plot(xy[:, 0], xy[:, 1], ".", color="0.6", ms=3, label="mass points (projected)")
    gap = plane(g - x)
    M = run.box.mass
    quad = plane(quadrupole_gap(p["R"] @ run.box.inertia @ p["R"].T, M, x))
    s = np.linspace(-3.0, 3.0, 2)
    line = np.array([plane(g + t * f - x) for t in s])
    ax.plot(line[:, 0], line[:, 1], "C3-", lw=1, label="line of action of F (through the field's centre)")
    ax.plot([-3, 3], [0, 0], "k--", lw=0.6, label="radial line through x_c")
    ax.plot(0, 0, "ko", ms=6, label="centre of mass x_c")
    ax.plot(*gap, "C3*", ms=12, label=f"centre of gravity x_g (|x_g - x_c| = {np.linalg.norm(g - x):.3g} m)")
    ax.plot(*quad, "C0x", ms=9, label="quadrupole theory")
    ax.set_aspect("equal", adjustable="datalim")
    zoom = ax.inset_axes([0.62, 0.04, 0.36, 0.36])
    w = 1.6 * float(np.linalg.norm(gap))
    zoom.plot(line[:, 0], line[:, 1], "C3-", lw=1)
    zoom.plot([-3, 3], [0, 0], "k--", lw=0.6)
    zoom.plot(0, 0, "ko", ms=6)
    zoom.plot(*gap, "C3*", ms=12)
    zoom.plot(*quad, "C0x", ms=9)
    zoom.set(xlim=(-w, w), ylim=(-w, w), aspect="equal")
    zoom.tick_params(labelsize=6)
    zoom.set_title(f"zoom: +-{w:.2g} m", fontsize=7)
    ax.legend(fontsize=6, loc="upper left")
    ax.set(
        xlabel="radial [m] (outward)",
        ylabel="across [m]",
        title=f"box at r = {np.linalg.norm(x):g} m: its largest gap of the attitudes",
    )


def centre_of_gravity_figure(run, outdir: str) -> str:
    """Write ``centre-of-gravity.png`` of a finished
    :class:`~.centre_of_gravity.CentreOfGravityRun` and return its file name."""
    return panel_figure(run, outdir, (_sums, _rod, _step, _gaps, _deviation, _picture), figsize=(18, 9.5))
