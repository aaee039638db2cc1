"""The figures of the libration cases (PNG, matplotlib's Agg backend).

``libration-pitch.png``: the pitch angle over time (em and Basilisk), the period against the
amplitude (em beside the pendulum's 4 K(sin theta0) / w), em's period error at both steps, the
pitch difference to Basilisk beside em's own error, the approach of the mass points' torque and
period to the first-order model as the box shrinks, and the invariants.

``libration-roll-yaw.png``: roll and yaw over time (em and Basilisk), their spectra with the
linear theory's two frequencies, the stability regions of the gravity-gradient attitude in the
(k_R, k_Y) plane with the box's point, the frequencies' errors against eps^2 with their
extrapolation to zero offset, the fit's residual, and the invariants.
"""

from __future__ import annotations

import math

import numpy as np

from .figures import FLOOR, _thin, panel_figure
from .libration_referees import amplitude_key, pitch_frequency, spectrum

__all__ = ["PANELS", "libration_figure"]


def _note(ax, text):
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, fontsize=9, wrap=True)


def _invariants(ax, run, keys):
    T = run.T
    for key in keys:
        tr = run.em[(key, run.s["steps"])]
        for name, style in (("energy", "-"), ("angular_momentum", "--"), ("K", ":")):
            ax.semilogy(*_thin(tr.t / T, tr.series[name]), style, lw=0.9, label=f"{name} ({key})")
    ax.set(
        xlabel="time [orbits]",
        ylabel="relative change",
        title="E / (T+|V|), L / (m|x||v|+|Iw|), K = E - n L_z / its terms",
    )


# -- pitch ------------------------------------------------------------------------------------------------
def _pitch_series(ax, run):
    s, T = run.s, run.T
    for a in s["amplitudes"]:
        key = amplitude_key(a)
        tr = run.em[(key, s["steps"])]
        (line,) = ax.plot(tr.t / T, tr.series["angles"][:, 2] / a, lw=0.9, label=f"em {key}")
        b = run.bsk.get((key, s["basilisk_dts"][0]))
        if b is not None:
            ax.plot(b.t[::20] / T, b.series["angles"][::20, 2] / a, ":", color=line.get_color(), lw=1.6)
    ax.set(xlabel="time [orbits]", ylabel="pitch / theta0", title="pitch in the orbit frame (dotted: Basilisk)")


def _pitch_periods(ax, run):
    from scipy.special import ellipk

    deg = np.linspace(0.0, 85.0, 200)
    ax.plot(deg, 2 * ellipk(np.sin(np.radians(deg)) ** 2) / np.pi, "k-", lw=1, label="pendulum 4 K(sin theta0) / w")
    ax.axhline(1.0, color="gray", ls="--", lw=0.8, label="linear theory")
    rows = run.convergence["pendulum"]
    w = 2 * math.pi / _linear_period(run)
    ax.plot([r["amplitude_deg"] for r in rows], [r["em_s"][0] * w / (2 * math.pi) for r in rows], "o", ms=5,
            label=f"em T/{run.s['steps']}")  # fmt: skip
    ax.set(xlabel="amplitude theta0 [deg]", ylabel="period / (2 pi / w_pitch)", title="period against amplitude")


def _linear_period(run):
    return 2 * math.pi / pitch_frequency(run.n, run.inertia)


def _pitch_errors(ax, run):
    rows = run.convergence["pendulum"]
    deg = [r["amplitude_deg"] for r in rows]
    D = run.s["steps"]
    for k, (label, marker) in enumerate(((f"em T/{D}", "o-"), (f"em T/{2 * D}", "s-"))):
        ax.semilogy(deg, [max(abs(r["error"][k]), FLOOR) for r in rows], marker, ms=4, lw=1, label=label)
    ax.semilogy(deg, [r["richardson"] for r in rows], "k:", lw=1, label=f"Richardson estimate at T/{D}")
    ax.set(xlabel="amplitude theta0 [deg]", ylabel="|P / P_pendulum - 1|", title="em against the pendulum")


def _pitch_basilisk(ax, run):
    if run.basilisk:
        _note(ax, run.basilisk)
        ax.set(title="pitch against Basilisk")
        return
    T = run.T
    for key, (t, diff, err) in run.series_difference.items():
        (line,) = ax.semilogy(*_thin(t / T, diff), lw=0.9, label=f"|em - Basilisk| / theta0, {key}")
        ax.semilogy(*_thin(t / T, err), "--", color=line.get_color(), lw=0.8, label=f"em's own error, {key}")
    ax.set(xlabel="time [orbits]", ylabel="pitch difference / theta0", title="em (T/500) against Basilisk (RK4, 1 s)")


def _pitch_sizes(ax, run):
    rows = run.sizes
    ratios = np.array([r["size_over_r"] for r in rows])
    period = np.abs([r["period_relative"] for r in rows])
    ax.loglog(ratios, period, "s-", ms=5, label="|P_em / P_pendulum - 1|")
    if "torque_relative" in rows[0]:
        torque = np.array([r["torque_relative"] for r in rows])
        ax.loglog(ratios, torque, "o-", ms=5, label="|tau_em - tau_Basilisk| / |tau_Basilisk|")
        small = 2.0 / run.s["radius"]
        floor = next(ch.value for ch in run.checks if ch.id == "basilisk-torque")
        ax.loglog([small], [max(floor, FLOOR)], "o", mfc="none", ms=6,
                  label="2 m box (round-off of the sum)")  # fmt: skip
        guide = torque[0] * (np.array([small, ratios[-1]]) / ratios[0]) ** 2
        ax.loglog([small, ratios[-1]], guide, "k:", lw=0.8, label="(size / r)^2")
    ax.set(xlabel="size / r (long edge)", ylabel="relative difference", title="mass points -> first-order model")


def _pitch_invariants(ax, run):
    _invariants(ax, run, [amplitude_key(run.s["amplitudes"][-1])])


# -- roll-yaw ------------------------------------------------------------------------------------------
def _roll_yaw_series(ax, run):
    s, T = run.s, run.T
    eps = s["offsets"][0]
    key = f"eps {eps:g}"
    tr = run.em[(key, s["steps"])]
    b = run.bsk.get((key, s["basilisk_dts"][0]))
    for j, name in ((1, "roll"), (0, "yaw")):
        (line,) = ax.plot(tr.t / T, tr.series["angles"][:, j] / eps, lw=0.9, label=f"em {name}")
        if b is not None:
            ax.plot(b.t / T, b.series["angles"][:, j] / eps, ":", color=line.get_color(), lw=1.6)
    ax.set(xlabel="time [orbits]", ylabel="angle / eps", title=f"roll and yaw, eps = {eps:g} rad (dotted: Basilisk)")


def _roll_yaw_spectrum(ax, run):
    s, n = run.s, run.n
    eps = s["offsets"][0]
    tr = run.em[(f"eps {eps:g}", s["steps"])]
    for j, name in ((1, "roll"), (0, "yaw")):
        f, a = spectrum(tr.t, tr.series["angles"][:, j] / eps)
        keep = f < 3 * n
        ax.semilogy(f[keep] / n, np.maximum(a[keep], 1e-9), lw=0.9, label=name)
    for mode, style in (("fast", "k--"), ("slow", "k:")):
        ax.axvline(run.theory[mode] / n, color="k", ls=style[1:], lw=0.8, label=f"linear {mode}")
    ax.set(xlabel="frequency / n", ylabel="amplitude / eps", title="spectrum (Hann window) and linear theory")


def _stability(ax, run):
    k = np.linspace(-1.0, 1.0, 401)
    kr, ky = np.meshgrid(k, k, indexing="xy")
    b = 1 + 3 * kr + kr * ky
    roll_yaw = (kr * ky > 0) & (b > 4 * np.sqrt(np.abs(kr * ky)))
    pitch = kr > ky
    ax.contourf(kr, ky, (roll_yaw & pitch).astype(float), levels=[0.5, 1.5], colors=["#9ecae1"])
    ax.contour(kr, ky, roll_yaw.astype(float), levels=[0.5], colors="gray", linewidths=0.6)
    ax.plot(k, k, "k:", lw=0.6)
    ax.plot(run.theory["k_roll"], run.theory["k_yaw"], "r*", ms=12, label="the box")
    ax.text(0.5, 0.2, "Lagrange", fontsize=9)
    ax.text(-0.32, -0.9, "DeBra-Delp", fontsize=9)
    ax.set(xlabel="k_R = (I_pitch - I_yaw) / I_roll", ylabel="k_Y = (I_pitch - I_roll) / I_yaw",
           title="stable regions (shaded: pitch and roll-yaw)", xlim=(-1, 1), ylim=(-1, 1))  # fmt: skip


def _roll_yaw_errors(ax, run):
    s = run.s
    rows = run.convergence["modes"]
    eps2 = np.array([0.0, *(e * e for e in s["offsets"])])
    for mode, marker in (("fast", "o"), ("slow", "s")):
        for k, steps in enumerate((s["steps"], 2 * s["steps"])):
            err = [
                rows[mode]["error"][k],
                *(float(run.fits[(f"eps {e:g}", steps)][0][0 if mode == "fast" else 1] / run.theory[mode] - 1)
                  for e in s["offsets"]),
            ]  # fmt: skip
            ax.plot(eps2 * 1e6, err, marker + ("-" if k == 0 else "--"), ms=4, lw=1, label=f"{mode}, T/{steps}")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set(xlabel="eps^2 [1e-6 rad^2] (0: extrapolated)", ylabel="w / w_linear - 1",
           title="frequencies against the offset")  # fmt: skip


def _roll_yaw_residual(ax, run):
    s, T = run.s, run.T
    eps = s["offsets"][0]
    tr = run.em[(f"eps {eps:g}", s["steps"])]
    t0 = tr.t - tr.t.mean()  # as fit_modes centres its times
    freqs = run.fits[(f"eps {eps:g}", s["steps"])][0]
    A = np.column_stack([f(w * t0) for w in freqs for f in (np.cos, np.sin)] + [np.ones_like(t0)])
    for j, name in ((1, "roll"), (0, "yaw")):
        y = tr.series["angles"][:, j] / eps
        r = A @ np.linalg.lstsq(A, y, rcond=None)[0] - y
        ax.plot(tr.t / T, r, lw=0.7, label=name)
    ax.set(xlabel="time [orbits]", ylabel="residual / eps", title="two-mode fit's residual (the offset's harmonics)")


def _roll_yaw_invariants(ax, run):
    _invariants(ax, run, [f"eps {run.s['offsets'][-1]:g}"])


#: the panels of each case's figure, row by row
PANELS = {
    "libration-pitch": (_pitch_series, _pitch_periods, _pitch_errors, _pitch_basilisk, _pitch_sizes, _pitch_invariants),
    "libration-roll-yaw": (
        _roll_yaw_series, _roll_yaw_spectrum, _stability, _roll_yaw_errors, _roll_yaw_residual, _roll_yaw_invariants,
    ),
}  # fmt: skip


def libration_figure(run, outdir: str) -> str:
    """Write the figure of a finished libration case run, ``<case name>.png``, and return its name.

    Parameters
    ----------
    run : PitchRun or RollYawRun
        The finished run (:mod:`.libration_runner`).
    outdir : str
        The report folder.

    Returns
    -------
    str
        The file name.
    """
    return panel_figure(run, outdir, PANELS[run.case.name])
