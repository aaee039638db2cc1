"""The figure of a perturbation case (PNG, matplotlib's Agg backend), four panels:

* the position difference from IAS15 (epsilon 1e-11) over time: em at each order's finest step,
  IAS15 at epsilon 1e-9, the effect itself (IAS15 against the Kepler orbit) and, with the
  shadow, IAS15 without its stops at the contacts;
* the convergence: the final difference against steps per day for every order (filled), em's
  own error estimated by step doubling (open), the expected order (dotted), IAS15's own error
  (grey band); with the shadow, the control without it;
* the energy balance ``|E - E0 - W| / |E0|`` over time, em and IAS15;
* the case's own panel: the semi-major axis from the energy (drag), the shadow function through
  the first eclipse (radiation pressure), or the work of the third bodies (Moon and Sun).
"""

from __future__ import annotations

import os

import numpy as np

from emorbit.effects.srp import SUN_RADIUS

from .figures import FLOOR, _plt
from .perturbation_cases import DAY, ORDERS
from .perturbation_model import hermite, shadow_conical
from .perturbation_runs import LOOSE

__all__ = ["perturbation_figure"]


def _finest(run, p):
    return run.em[(p, max(run.steps(p)))]


def _differences(ax, run):
    ref = run.ref
    for p in ORDERS:
        tr = _finest(run, p)
        ax.semilogy(tr.t / DAY, np.maximum(tr.difference(ref), FLOOR), lw=0.9, label=tr.label)
    loose = run.ias[LOOSE]
    ax.semilogy(ref.t / DAY, np.maximum(loose.difference(ref), FLOOR), "k--", lw=0.9, label=loose.label)
    ax.semilogy(ref.t / DAY, np.maximum(ref.difference(run.kepler), FLOOR), ":", color="gray", label="the effect")
    plain = run.extra.get("without_stops")
    if plain is not None:
        ax.semilogy(ref.t / DAY, np.maximum(plain.difference(ref), FLOOR), "r-.", lw=0.9, label=plain.label)
    ax.set(xlabel="time [days]", ylabel="|x - x_IAS15| [m]", title="difference from IAS15 (epsilon 1e-11)")


def _convergence(ax, run):
    for p in ORDERS:
        d = run.convergence[p]
        n = np.asarray(d["steps_per_day"], float)
        e = np.maximum(np.asarray(d["difference"], float), FLOOR)
        seen = f"observed {d['observed']:.2f}" if np.isfinite(d["observed"]) else "too few points to fit"
        seen += "" if p in run.case.checked_orders else " (not checked)"
        (line,) = ax.loglog(n, e, "o-", ms=4, lw=1, label=f"order {p} (expected {d['expected']:g}): {seen}")
        est = np.asarray(d["em_estimate"], float) + np.asarray(d["em_roundoff"], float)
        ax.loglog(n, np.maximum(est, FLOOR), "o", mfc="none", color=line.get_color(), ms=7)
        if d["fitted"]:
            n0, e0 = d["fitted"][-1]
            ax.loglog(n, e0 * (n / n0) ** -d["expected"], ":", color=line.get_color(), lw=0.8)
    ctl = run.convergence.get("8 without shadow")
    if ctl:
        n = np.asarray(ctl["steps_per_day"], float)
        ax.loglog(n, np.maximum(ctl["difference"], FLOOR), "^--", color="k", ms=4, lw=0.8,
                  label=f"order 8 without shadow: observed {ctl['observed']:.2f}")  # fmt: skip
    ax.axhline(run.e_ias, color="gray", ls="--", lw=1, label="IAS15's own error")
    ax.set(
        xlabel="steps per day",
        ylabel="final |x_em - x_IAS15| [m]",
        title="convergence (open: em's own error estimate; dotted: expected order)",
    )


def _balance(ax, run):
    for p in ORDERS:
        tr = _finest(run, p)
        ax.semilogy(tr.t / DAY, np.maximum(np.abs(tr.balance), FLOOR), lw=0.9, label=tr.label)
    ax.semilogy(run.ref.t / DAY, np.maximum(np.abs(run.ref.balance), FLOOR), "k--", lw=0.9, label=run.ref.label)
    ax.set(xlabel="time [days]", ylabel="|E - E0 - W| / |E0|", title="energy balance (W: the work done)")


def _own_drag(ax, run):
    gm = run.case.gm
    for tr, style in ((run.ref, "k--"), (_finest(run, 8), "-")):
        a = -gm / (2 * tr.energy)
        ax.plot(tr.t / DAY, a - a[0], style, lw=0.9, label=tr.label)
    ax.set(xlabel="time [days]", ylabel="a - a0 [m]", title="semi-major axis from the energy, -GM / 2E")


def _own_srp(ax, run):
    contacts = run.extra.get("contacts", [])
    if len(contacts) < 4:
        return
    ref, c = run.ref, run.case
    sun = run.paths["sun"]
    t = np.linspace(contacts[0] - 60.0, contacts[3] + 60.0, 1500)
    from emorbit import orbits

    k = int(np.searchsorted(ref.t, contacts[0])) - 1
    x, _ = orbits.propagate(ref.x[k], ref.v[k], c.gm, t - ref.t[k])
    nu = [
        shadow_conical(*xi, *hermite(ti, sun.step, sun.k0, sun.rows)[0], c.radius, SUN_RADIUS) for ti, xi in zip(t, x)
    ]
    ax.plot((t - contacts[0]) / 60.0, nu, lw=1, label="nu (conical shadow)")
    for tc in contacts[:4]:
        ax.axvline((tc - contacts[0]) / 60.0, color="gray", ls=":", lw=0.8)
    ax.set(
        xlabel="minutes after the first contact",
        ylabel="visible fraction of the Sun",
        title="the first eclipse (dotted: the contacts IAS15 stops at)",
    )


def _own_third_body(ax, run):
    for tr, style in ((run.ref, "k--"), (_finest(run, 8), "-")):
        ax.plot(tr.t / DAY, tr.work, style, lw=0.9, label=tr.label)
    ax.set(xlabel="time [days]", ylabel="W [J/kg]", title="work of the Moon's and the Sun's motion, integral of dU/dt")


def perturbation_figure(run, outdir: str) -> str:
    """Write the figure of a finished perturbation case.

    Parameters
    ----------
    run : PerturbationRun
        The case's runs and measurements.
    outdir : str
        The report folder.

    Returns
    -------
    str
        The file name, in ``outdir``.
    """
    plt = _plt()
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5))
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.06, top=0.93, hspace=0.28, wspace=0.2)
    _differences(axes[0, 0], run)
    _convergence(axes[0, 1], run)
    _balance(axes[1, 0], run)
    {"drag": _own_drag, "srp": _own_srp, "third_body": _own_third_body}[run.case.kind](axes[1, 1], run)
    for ax in np.ravel(axes):
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    c = run.case
    fig.suptitle(f"{c.name}: {c.title}")
    name = f"{c.name}.png"
    fig.savefig(os.path.join(outdir, name), dpi=90)
    plt.close(fig)
    return name
