"""Brouwer's law: over many steps the energy error of em must be a random walk (RMS growing
like sqrt(steps), no systematic drift), not a drift that grows like steps.

An ensemble of slightly perturbed copies of the paper's orbit (initial speeds scaled by
1 + 1e-9 z, z standard normal) runs as one simulation of independent points; each point's
relative energy error is taken at every record. The RMS over the ensemble must grow with a
log-log slope <= 0.6 against steps, and the ensemble mean must stay well below the RMS.
Full suite: 1e7 steps at dt = T/100 and T/1000; quick: 2e5 steps.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np

import emorbit

from .cases import PAPER_GM, PAPER_T, PAPER_V0, PAPER_X0
from .checks import Check
from .runner import CaseOutcome

__all__ = ["run_brouwer", "SIZES"]

#: (steps, records, ensemble size) per mode
SIZES = {"quick": (200_000, 200, 16), "full": (10_000_000, 1000, 32)}
SLOPE_MAX = 0.6
MEAN_OVER_RMS_MAX = 0.5


def _ensemble(div: int, steps: int, records: int, members: int, seed: int = 2026):
    rng = np.random.default_rng(seed)
    sim = emorbit.Simulation(emorbit.CentralField(gm=PAPER_GM), method="em", dt=PAPER_T / div)
    v0 = np.asarray(PAPER_V0)
    for i in range(members):
        sim.add_point(f"p{i}", mass=1.0, position=PAPER_X0, velocity=v0 * (1.0 + 1e-9 * rng.normal()))
    t0 = time.process_time()
    res = sim.run(steps=steps, every=steps // records).si  # plain SI arrays
    cpu = time.process_time() - t0
    x = np.stack([res.positions[n] for n in res.names])  # (members, records + 1, 3)
    v = np.stack([res.velocities[n] for n in res.names])
    e = 0.5 * np.sum(v * v, axis=-1) - PAPER_GM / np.linalg.norm(x, axis=-1)
    rel = (e - e[:, :1]) / np.abs(e[:, :1])
    n = np.arange(records + 1) * (steps // records)
    return n, rel, cpu


def _slope(n, rms, lo):
    keep = (n >= lo) & (rms > 0)
    return float(np.polyfit(np.log(n[keep]), np.log(rms[keep]), 1)[0])


def run_brouwer(mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True) -> CaseOutcome:
    """Run the Brouwer study and return its outcome.

    Parameters
    ----------
    mode : str
        ``"quick"`` or ``"full"`` (:data:`SIZES`).
    outdir : str
        Folder for the figure.
    scale : float
        Multiplies every tolerance.
    figures : bool
        Draw ``brouwer.png``.

    Returns
    -------
    CaseOutcome
        Its checks (slope of the RMS and mean over RMS at T/100 and T/1000), metrics and figure.
    """
    steps, records, members = SIZES[mode]
    start = time.perf_counter()
    checks, metrics, series = [], {}, {}
    for div in (100, 1000):
        n, rel, cpu = _ensemble(div, steps, records, members)
        rms = np.sqrt(np.mean(rel**2, axis=0))
        mean = np.mean(rel, axis=0)
        lo = max(1000, steps // 1000)
        slope = _slope(n, rms, lo)
        last = n >= steps // 10
        ratio = float(np.max(np.abs(mean[last])) / np.max(rms[last]))
        series[div] = (n, rms, mean)
        label = f"T/{div}"
        checks.append(
            Check(
                f"brouwer-slope-{div}",
                f"log-log slope of the ensemble RMS energy error, dt = {label}",
                "Brouwer's law: 0.5 for a random walk, 1 for a drift",
                slope,
                SLOPE_MAX * scale,
                "1",
                f"{members} runs, {steps:.0e} steps, fitted from {lo} steps on",
            )
        )
        checks.append(
            Check(
                f"brouwer-mean-{div}",
                f"|ensemble mean| / RMS of the energy error, last decade, dt = {label}",
                "no systematic drift (a drift makes the mean as large as the RMS)",
                ratio,
                MEAN_OVER_RMS_MAX * scale,
                "1",
                f"max over the last decade of steps, {members} runs",
            )
        )
        metrics[f"rms_final_{div}"] = {
            "value": float(rms[-1]),
            "unit": "1",
            "note": f"RMS relative energy error after {steps:.0e} steps at {label}",
        }
        metrics[f"cpu_s_{div}"] = {"value": cpu, "unit": "s", "note": f"{members} x {steps:.0e} point-steps"}
    figs = []
    if figures:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4.8), constrained_layout=True)
        for div, (n, rms, mean) in series.items():
            keep = n > 0
            ax.loglog(n[keep], rms[keep], lw=1.2, label=f"RMS, dt = T/{div}")
            ax.loglog(n[keep], np.maximum(np.abs(mean[keep]), 1e-20), lw=0.7, ls=":", label=f"|mean|, dt = T/{div}")
        nn = np.logspace(3, math.log10(steps), 20)
        ref = series[100][1][-1] * np.sqrt(nn / steps)
        ax.loglog(nn, ref, "k--", lw=0.8, label="slope 1/2 (random walk)")
        ax.set(xlabel="steps", ylabel="relative energy error", title="Brouwer's law: em energy error over many steps")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        path = os.path.join(outdir, "brouwer.png")
        fig.savefig(path, dpi=120)
        plt.close(fig)
        figs.append(os.path.basename(path))
    return CaseOutcome(
        name="brouwer",
        title="Round-off over many steps (Brouwer's law)",
        description=__doc__.strip(),
        params={
            "orbit": "the paper's (e = 2/3)",
            "steps": f"{steps:.0e}",
            "ensemble": str(members),
            "dt": "T/100 and T/1000",
        },
        mode=mode,
        orbits=None,
        orbits_high=None,
        steps_per_period=None,
        period_s=PAPER_T,
        runs={},
        metrics=metrics,
        convergence={},
        checks=[ch.to_dict() for ch in checks],
        figures=figs,
        files=[],
        error=None,
        timing={},
        wall_s=time.perf_counter() - start,
        passed=all(ch.passed for ch in checks),
    )
