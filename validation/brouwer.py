"""Brouwer's law: over many steps the energy error of em must be a random walk (RMS growing
like sqrt(steps), no systematic drift), not a drift that grows like steps.

Two studies share one method: an ensemble of slightly perturbed copies of one orbit (initial
speeds scaled by 1 + 1e-9 z, z standard normal) runs as one simulation of independent points;
each point's relative energy error is taken at every record. The RMS over the ensemble is
fitted against steps on log-log axes, and the ensemble mean must stay well below the RMS.

* ``brouwer``: the paper's orbit in its point-mass field; the slope must be <= 0.6. Full
  suite only: 1e7 steps at dt = T/100 and T/1000.
* ``brouwer-j2``: an eccentric, inclined LEO orbit (a = 7000 km, e = 0.05, i = 63 deg,
  starting at periapsis) in the Earth's field with its zonal harmonics J2..J6 on
  (``model = "earth"``); each point's energy includes the zonal potential. The slope must be
  0.5 +- 0.1. Full suite: 1e7 steps at T/100 and T/1000; quick suite: 2e5 steps at T/100.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass

import numpy as np

import emorbit
from emorbit import orbits
from emorbit.analysis import relative_energy_change_exact

from .cases import PAPER_GM, PAPER_T, PAPER_V0, PAPER_X0, STUDY_TITLES
from .checks import RANDOM_WALK_SLOPE, Check
from .effect_eval import point_potentials
from .runner import CaseOutcome

__all__ = ["run_brouwer", "run_brouwer_j2", "run_study", "STUDIES", "SIZES", "SIZES_J2", "DIVS_J2", "J2_ORBIT"]

#: (steps, records, ensemble size) per mode
SIZES = {"quick": (200_000, 200, 16), "full": (10_000_000, 1000, 32)}
SLOPE_MAX = 0.6
MEAN_OVER_RMS_MAX = 0.5
#: brouwer-j2: (steps, records, ensemble size) per mode
SIZES_J2 = {"quick": (200_000, 200, 32), "full": (10_000_000, 1000, 32)}
#: brouwer-j2's steps, as divisors of the period, per mode: in 2e5 steps at T/1000 the walk
#: (4e-16 of E at the end) rises little above the rounding of the recorded states (1e-16),
#: and the slope fitted there reads 0.34
DIVS_J2 = {"quick": (100,), "full": (100, 1000)}
#: brouwer-j2's orbit: a (m), e, i, Omega, omega, true anomaly (rad); at periapsis r = 6650 km
J2_ORBIT = (7000e3, 0.05, math.radians(63.0), 0.0, 0.0, 0.0)
#: the step sizes, as divisors of the period
DIVS = (100, 1000)
#: the report's description of ``brouwer``
DESCRIPTION = """Brouwer's law: over many steps the energy error of em must be a random walk (RMS growing
like sqrt(steps), no systematic drift), not a drift that grows like steps.

An ensemble of slightly perturbed copies of the paper's orbit (initial speeds scaled by
1 + 1e-9 z, z standard normal) runs as one simulation of independent points; each point's
relative energy error is taken at every record. The RMS over the ensemble must grow with a
log-log slope <= 0.6 against steps, and the ensemble mean must stay well below the RMS.
Full suite: 1e7 steps at dt = T/100 and T/1000; quick: 2e5 steps."""


@dataclass
class _Ensemble:
    """An ensemble's relative energy errors at its records.

    Attributes
    ----------
    n : ndarray
        (records + 1,) steps at each record.
    rel : ndarray
        (members, records + 1) relative energy error of each point.
    cpu : float
        CPU seconds of the run.
    """

    n: np.ndarray
    rel: np.ndarray
    cpu: float


def _ensemble(sim, x0, v0, steps: int, records: int, members: int, relative, seed: int = 2026) -> _Ensemble:
    """Add ``members`` perturbed copies of (x0, v0) to ``sim``, run it and measure the energy.

    ``relative(sim, x, v)`` takes (members, records + 1, 3) SI positions and velocities and
    returns each point's relative energy error (E - E0) / |E0| at each record.
    """
    rng = np.random.default_rng(seed)
    v0 = np.asarray(v0)
    for i in range(members):
        sim.add_point(f"p{i}", mass=1.0, position=x0, velocity=v0 * (1.0 + 1e-9 * rng.normal()))
    t0 = time.process_time()
    res = sim.run(steps=steps, every=steps // records).si  # plain SI arrays
    cpu = time.process_time() - t0
    x = np.stack([res.positions[n] for n in res.names])  # (members, records + 1, 3)
    v = np.stack([res.velocities[n] for n in res.names])
    n = np.arange(records + 1) * (steps // records)
    return _Ensemble(n, relative(sim, x, v), cpu)


def _relative_kepler(gm: float):
    """(E - E0) / |E0| of E = |v|^2 / 2 - gm / |x|, in float64 (the paper's study)."""

    def relative(sim, x, v):
        e = 0.5 * np.sum(v * v, axis=-1) - gm / np.linalg.norm(x, axis=-1)
        return (e - e[:, :1]) / np.abs(e[:, :1])

    return relative


def _relative_zonal(sim, x, v):
    """(E - E0) / |E0| of E = |v|^2 / 2 - GM / |x| + the zonal potential, per unit mass.

    The central part is evaluated exactly from the float64 states
    (:func:`emorbit.analysis.relative_energy_change_exact`): in float64 the rounding of E0,
    the same in every copy, would offset the ensemble mean by about one eps, and the rounding
    of each evaluation would add a floor of about one eps that the walk at T/1000 reaches only
    after millions of steps. The zonal potential, about 1e-3 of the
    energy, is evaluated in float64 by the simulation's compiled effect set
    (:func:`.effect_eval.point_potentials`). The field's centre is the origin.
    """
    gm = sim.field.gm
    vz = point_potentials(sim, x)["zonal"]  # (members, records + 1), J/kg
    ek0 = 0.5 * np.sum(v[:, 0] ** 2, axis=-1) - gm / np.linalg.norm(x[:, 0], axis=-1)
    rk = np.stack(
        [relative_energy_change_exact(x[:, 0].T, v[:, 0].T, x[:, k].T, v[:, k].T, gm) for k in range(x.shape[1])],
        axis=1,
    )
    return (ek0[:, None] * rk + (vz - vz[:, :1])) / np.abs(ek0 + vz[:, 0])[:, None]


def _slope(n, rms, lo):
    keep = (n >= lo) & (rms > 0)
    return float(np.polyfit(np.log(n[keep]), np.log(rms[keep]), 1)[0])


def _measure(ens: _Ensemble, steps: int):
    """The RMS and mean over the ensemble, the fitted slope and |mean| / RMS over the last decade.

    Returns
    -------
    rms, mean : ndarray
        Per record.
    lo : int
        The fit uses records from ``lo`` steps on.
    slope, ratio : float
        The log-log slope of the RMS; max |mean| / max RMS over the last decade of steps.
    """
    rms = np.sqrt(np.mean(ens.rel**2, axis=0))
    mean = np.mean(ens.rel, axis=0)
    lo = max(1000, steps // 1000)
    slope = _slope(ens.n, rms, lo)
    last = ens.n >= steps // 10
    ratio = float(np.max(np.abs(mean[last])) / np.max(rms[last]))
    return rms, mean, lo, slope, ratio


def _metrics(metrics: dict, div: int, rms, cpu: float, steps: int, members: int) -> None:
    metrics[f"rms_final_{div}"] = {
        "value": float(rms[-1]),
        "unit": "1",
        "note": f"RMS relative energy error after {steps:.0e} steps at T/{div}",
    }
    metrics[f"cpu_s_{div}"] = {"value": cpu, "unit": "s", "note": f"{members} x {steps:.0e} point-steps"}


def _figure(series: dict, steps: int, path: str, title: str) -> str:
    """Draw RMS and |mean| against steps for each dt, with a slope-1/2 line; returns the file name."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.8), constrained_layout=True)
    for div, (n, rms, mean) in series.items():
        keep = n > 0
        ax.loglog(n[keep], rms[keep], lw=1.2, label=f"RMS, dt = T/{div}")
        ax.loglog(n[keep], np.maximum(np.abs(mean[keep]), 1e-20), lw=0.7, ls=":", label=f"|mean|, dt = T/{div}")
    nn = np.logspace(3, math.log10(steps), 20)
    ref = series[DIVS[0]][1][-1] * np.sqrt(nn / steps)
    ax.loglog(nn, ref, "k--", lw=0.8, label="slope 1/2 (random walk)")
    ax.set(xlabel="steps", ylabel="relative energy error", title=title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return os.path.basename(path)


def _outcome(name, title, description, params, mode, period, metrics, checks, figs, start) -> CaseOutcome:
    return CaseOutcome(
        name=name,
        title=title,
        description=description,
        params=params,
        mode=mode,
        orbits=None,
        orbits_high=None,
        steps_per_period=None,
        period_s=period,
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


def run_brouwer(mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True) -> CaseOutcome:
    """Run the Brouwer study of the paper's orbit and return its outcome.

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
    for div in DIVS:
        sim = emorbit.Simulation(emorbit.CentralField(gm=PAPER_GM), method="em", dt=PAPER_T / div)
        ens = _ensemble(sim, PAPER_X0, PAPER_V0, steps, records, members, _relative_kepler(PAPER_GM))
        rms, mean, lo, slope, ratio = _measure(ens, steps)
        series[div] = (ens.n, rms, mean)
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
        _metrics(metrics, div, rms, ens.cpu, steps, members)
    figs = []
    if figures:
        title = "Brouwer's law: em energy error over many steps"
        figs.append(_figure(series, steps, os.path.join(outdir, "brouwer.png"), title))
    return _outcome(
        "brouwer",
        "Round-off over many steps (Brouwer's law)",
        DESCRIPTION,
        {
            "orbit": "the paper's (e = 2/3)",
            "steps": f"{steps:.0e}",
            "ensemble": str(members),
            "dt": "T/100 and T/1000",
        },
        mode,
        PAPER_T,
        metrics,
        checks,
        figs,
        start,
    )


def run_brouwer_j2(mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True) -> CaseOutcome:
    """Run the Brouwer study with the Earth's zonal harmonics J2..J6 on and return its outcome.

    Parameters
    ----------
    mode : str
        ``"quick"`` or ``"full"`` (:data:`SIZES_J2`).
    outdir : str
        Folder for the figure.
    scale : float
        Multiplies every tolerance.
    figures : bool
        Draw ``brouwer-j2.png``.

    Returns
    -------
    CaseOutcome
        Its checks (|slope - 0.5| of the RMS and mean over RMS at each dt of :data:`DIVS_J2`),
        metrics (final RMS, CPU seconds) and figure.
    """
    steps, records, members = SIZES_J2[mode]
    divs = DIVS_J2[mode]
    dts = " and ".join(f"T/{d}" for d in divs)
    start = time.perf_counter()
    field = emorbit.CentralField(body="earth")
    x0, v0 = orbits.state_from_elements(J2_ORBIT, field.gm)
    period = float(orbits.kepler_period(J2_ORBIT[0], field.gm))
    checks, metrics, series = [], {}, {}
    for div in divs:
        sim = emorbit.Simulation(field, method="em", dt=period / div)
        sim.add_effect("zonal", model="earth")
        ens = _ensemble(sim, x0, v0, steps, records, members, _relative_zonal)
        rms, mean, lo, slope, ratio = _measure(ens, steps)
        series[div] = (ens.n, rms, mean)
        label = f"T/{div}"
        checks.append(
            Check(
                f"brouwer-j2-slope-{div}",
                f"|log-log slope - 0.5| of the ensemble RMS energy error (zonal potential included), dt = {label}",
                "Brouwer's law: 0.5 for a random walk, 1 for a drift",
                abs(slope - 0.5),
                RANDOM_WALK_SLOPE * scale,
                "1",
                "round-off that is independent from step to step adds up as a random walk, whose RMS grows "
                "as sqrt(steps); a systematic drift grows as steps (slope 1); 0.1 allows for the scatter of "
                f"an RMS over {members} runs",
                f"slope {slope:.3f}, {members} runs, {steps:.0e} steps, fitted from {lo} steps on",
            )
        )
        checks.append(
            Check(
                f"brouwer-j2-mean-{div}",
                f"|ensemble mean| / RMS of the energy error, last decade, dt = {label}",
                "no systematic drift (a drift makes the mean as large as the RMS)",
                ratio,
                MEAN_OVER_RMS_MAX * scale,
                "1",
                f"a random walk's mean over {members} runs is about 1/sqrt({members}) = "
                f"{1 / math.sqrt(members):.2f} of its RMS; a drift makes it 1",
                f"max over the last decade of steps, {members} runs",
            )
        )
        _metrics(metrics, div, rms, ens.cpu, steps, members)
    figs = []
    if figures:
        title = STUDY_TITLES["brouwer-j2"]
        figs.append(_figure(series, steps, os.path.join(outdir, "brouwer-j2.png"), title))
    a, e, inc = J2_ORBIT[:3]
    return _outcome(
        "brouwer-j2",
        "Round-off over many steps with J2..J6 (Brouwer's law)",
        f"{members} perturbed copies (speeds scaled by 1 + 1e-9 z) of an Earth orbit, a = {a / 1e3:.0f} km, "
        f"e = {e}, i = {math.degrees(inc):.0f} deg, starting at periapsis, under the Earth's field "
        '(CentralField(body="earth")) with its zonal harmonics J2..J6 (add_effect("zonal", model="earth")), '
        f"run {steps:.0e} steps at {dts} as one simulation of independent points. Each point's relative energy "
        "error, the zonal potential included (the central part evaluated exactly from the float64 states), is "
        "taken at every record; the log-log slope of the ensemble RMS against steps must be 0.5 +- 0.1 "
        "(Brouwer's law: a random walk; a drift gives 1), and the ensemble mean must stay below half the RMS "
        "over the last decade of steps. The quick suite runs T/100 only: in 2e5 steps at T/1000 the walk does "
        "not rise above the rounding of the recorded states.",
        {
            "orbit": f"a = {a / 1e3:.0f} km, e = {e}, i = {math.degrees(inc):.0f} deg, start at periapsis",
            "field": "Earth (GM_earth), zonal J2..J6 (model earth)",
            "steps": f"{steps:.0e}",
            "records": str(records),
            "ensemble": str(members),
            "dt": f"{dts} (T = {period:.6g} s)",
        },
        mode,
        period,
        metrics,
        checks,
        figs,
        start,
    )


#: the studies that are cases of the suite (listed, run in both modes), by name
STUDIES = {"brouwer-j2": run_brouwer_j2}


def run_study(name: str, mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True) -> CaseOutcome:
    """Run one of :data:`STUDIES` by name.

    Parameters
    ----------
    name : str
        A key of :data:`STUDIES`.
    mode : str
        ``"quick"`` or ``"full"``.
    outdir : str
        Folder for the figure.
    scale : float
        Multiplies every tolerance.
    figures : bool
        Draw the study's figure.

    Returns
    -------
    CaseOutcome
        The study's outcome.
    """
    return STUDIES[name](mode, outdir, scale=scale, figures=figures)
