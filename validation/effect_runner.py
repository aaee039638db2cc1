"""Runs one effect case: em at every order and step, the referees, the checks and the figures.

What runs (``n`` = case.orbits[mode] periods):

* em at orders 2, 4, 6, 8, each at the steps per period of ``case.steps`` (two or more steps
  per order give its observed order of convergence, ``case.main`` its accuracy check);
* the referee on the same record times: REBOUND IAS15, with REBOUNDx's
  ``gravitational_harmonics`` for zonal harmonics; the analytic Kepler solution for the two
  bodies. Without REBOUNDx (an optional package) the zonal cases run em all the same, and
  the checks against REBOUNDx say "skipped: REBOUNDx not installed";
* every em run's invariants: energy (with the effects' potentials), and what the effect
  keeps besides (the angular momentum about the pole under zonal harmonics; linear and
  angular momentum under mutual gravity).

The case-specific checks are in :mod:`.effect_checks`. The outcome has the keys of
:class:`~.runner.CaseOutcome`, so the report and the JSON treat both kinds of case alike.
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import checks as C
from .checks import Check
from .effect_cases import EffectCase
from .effect_runs import (
    EffectTrajectory,
    effect_record_times,
    reboundx_missing,
    run_em,
    run_ias15,
    two_body_analytic,
)

__all__ = ["run_effect_case"]

ORDERS = (2, 4, 6, 8)


class EffectRun:
    """The runs, checks and measurements of one effect case (what the figures read)."""

    def __init__(self, case: EffectCase, mode: str, scale: float, outdir: str):
        self.case = case
        self.mode = mode
        self.scale = scale
        self.outdir = outdir
        self.n = case.orbits[mode]
        self.times = effect_record_times(case, self.n)
        self.checks: list[Check] = []
        self.metrics: dict = {}
        self.runs: dict[str, EffectTrajectory] = {}
        self.em_runs: dict[tuple[int, int], EffectTrajectory] = {}
        self.named: dict[str, EffectTrajectory] = {}
        self.convergence: dict = {}
        self.extra: dict = {}  # case-specific results for the figures
        self.timing: dict = {}
        #: "" or why the checks against REBOUNDx are skipped (zonal cases without REBOUNDx)
        self.rebx_missing = reboundx_missing() if case.kind == "zonal" else ""

    # -- helpers -----------------------------------------------------------------------
    def check(self, id_, what, against, value, tolerance, unit, reason, detail=""):
        self.checks.append(Check(id_, what, against, value, tolerance * self.scale, unit, reason, detail))

    def skip(self, id_, what, against, unit="1"):
        """A check against REBOUNDx that did not run: REBOUNDx is not installed."""
        self.checks.append(
            Check(id_, what, against, math.nan, 0.0, unit, "an optional referee", skipped=self.rebx_missing)
        )

    def metric(self, key, value, unit, note=""):
        v = value.item() if isinstance(value, np.generic) else value
        self.metrics[key] = {"value": v, "unit": unit, "note": note}

    def em(self, order, steps, *, zonal=None, label=None, key=True, method="em") -> EffectTrajectory:
        tr = run_em(self.case, order, steps, self.n, zonal=zonal, label=label, method=method)
        self.runs[tr.label] = tr
        if key:
            self.em_runs[(order, steps)] = tr
        return tr

    def main(self, order: int) -> EffectTrajectory:
        """The em run whose accuracy is checked, at ``case.main[order]`` steps per period."""
        return self.em_runs[(order, self.case.main[order])]

    # -- the pipeline ------------------------------------------------------------------
    def run(self):
        from .effect_checks import CASE_CHECKS

        c = self.case
        t0 = time.perf_counter()
        for p in ORDERS:
            for n in dict.fromkeys((*c.steps[p], c.main[p])):
                self.em(p, n)
        self.timing["em_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        ias = None  # IAS15 (+ REBOUNDx for zonal harmonics); None when REBOUNDx is missing
        if not self.rebx_missing:
            ias = run_ias15(c, self.times, label="IAS15 + REBOUNDx" if c.kind == "zonal" else "IAS15")
            self.runs[ias.label] = ias
        reference = two_body_analytic(c, self.times) if c.name == "mutual-two-body" else ias
        self.timing["referee_s"] = time.perf_counter() - t0
        self.named = {"IAS15": ias, "reference": reference, **{f"em{p}": self.main(p) for p in ORDERS}}
        self._energy(ias)
        if c.kind == "zonal":
            self._pole_angular_momentum()
        else:
            self._momenta()
        self._orders(reference)
        CASE_CHECKS[c.name](self, ias, reference)

    # -- invariants --------------------------------------------------------------------
    def _energy(self, ias):
        e_ias = None if ias is None else float(ias.rel_energy_error().max())
        if e_ias is not None:
            self.metric(
                "ias15.energy.max",
                e_ias,
                "1",
                "|E - E0| / |E0|"
                + (", the zonal potential included (computed here)" if self.case.kind == "zonal" else ""),
            )
        if e_ias is None:
            tol2 = C.ENERGY_ORDER2
            why2 = (
                "em conserves the energy with the effects' potentials exactly up to round-off (IAS15 + REBOUNDx, "
                "whose own error would set this bound where it exceeds it, is not installed)"
            )
        elif e_ias <= C.ENERGY_ORDER2:
            tol2 = C.ENERGY_ORDER2
            why2 = (
                f"IAS15 keeps {C.ENERGY_ORDER2:g} here (measured {e_ias:.2g}), so em at order 2 must too: em "
                "conserves the energy with the effects' potentials exactly up to round-off"
            )
        else:
            tol2 = C.ENERGY_HIGH
            why2 = f"IAS15 itself exceeds {C.ENERGY_ORDER2:g} here (measured {e_ias:.2g}); the orders-4-8 bound"
        for p in ORDERS:
            runs = [tr for (q, _), tr in self.em_runs.items() if q == p]
            worst = max(runs, key=lambda tr: tr.rel_energy_error().max())
            self.check(
                f"energy-em{p}",
                f"em order {p} energy with the effects' potentials, max |E - E0| / |E0| over {self.n} periods, "
                f"worst of {len(runs)} step(s)",
                "the initial energy",
                worst.rel_energy_error().max(),
                tol2 if p == 2 else C.ENERGY_HIGH,
                "1",
                why2
                if p == 2
                else f"em at orders 4-8 conserves the energy exactly up to round-off; the compensated update keeps "
                f"the round-off of its sub-steps below {C.ENERGY_HIGH:g}",
                ", ".join(f"{tr.label}: {tr.rel_energy_error().max():.2g}" for tr in runs),
            )

    def _pole_angular_momentum(self):
        """The angular momentum about the pole (z) of every body, every em run."""
        worst, per = 0.0, []
        for tr in self.em_runs.values():
            L = np.cross(tr.x, tr.v)
            err = float((np.abs(L[..., 2] - L[0, :, 2]) / np.linalg.norm(L[0], axis=-1)).max())
            worst = max(worst, err)
            per.append(f"{tr.label}: {err:.2g}")
        self.check(
            "angular-momentum-pole",
            "|Lz - Lz0| / |L0| of every body about the pole (z), worst of every em run",
            "the initial angular momentum about the pole",
            worst,
            C.ANGULAR_MOMENTUM,
            "1",
            "the em force of the zonal harmonics lies in the plane of d0 + d1 and the pole, so an em step keeps "
            "L about the pole exactly up to round-off (the other components turn with the node)",
            "; ".join(per),
        )

    def _momenta(self):
        """Linear and angular momentum of the bodies under mutual gravity, every em run."""
        for key, attr, scale_key, tol, what in (
            ("momentum", "momentum", "momentum_scale", C.MOMENTUM, "sum m |v|"),
            ("angular-momentum", "angular_momentum", "angular_momentum_scale", C.ANGULAR_MOMENTUM, "sum m |x| |v|"),
        ):
            values = {}
            for tr in self.em_runs.values():
                q = getattr(tr, attr)
                values[tr.label] = float(np.linalg.norm(q - q[0], axis=-1).max() / tr.info[scale_key])
            self.check(
                key,
                f"|{'P' if key == 'momentum' else 'L'} - its start| relative to {what} at the start, worst of every "
                "em run" + (" (about the origin)" if key != "momentum" else ""),
                "the initial value",
                max(values.values()),
                tol,
                "1",
                "Greenspan's pair forces are equal and opposite and lie along the mean separation: em keeps P and L "
                "exactly up to round-off; relative to the terms that cancel (the figure-eight's P and L are 0)",
                "; ".join(f"{k}: {v:.2g}" for k, v in values.items()),
            )

    # -- orders of convergence -----------------------------------------------------------
    def _orders(self, reference):
        c = self.case
        for p in ORDERS:
            ns = c.steps[p]
            if reference is None:  # the referee, IAS15 + REBOUNDx, is not installed
                if len(ns) >= 2:
                    self.skip(
                        f"order-em{p}",
                        f"em order {p}: observed order of the position error from T/{ns[0]} and T/{ns[1]}",
                        f"the nominal order {p} (errors against REBOUND IAS15 + REBOUNDx)",
                        "1 (order)",
                    )
                continue
            errs = [float(self.em_runs[(p, n)].position_error(reference, c.length).max()) for n in ns]
            entry = {"steps_per_period": list(ns), "error": errs}
            self.convergence[p] = entry
            if len(ns) < 2:
                continue
            n1, n2 = ns[0], ns[1]
            observed = math.log(errs[0] / errs[1]) / math.log(n2 / n1) if errs[1] > 0 else math.inf
            entry["observed"] = observed
            ref = "REBOUND IAS15 + REBOUNDx" if c.kind == "zonal" else self.named["reference"].label
            self.check(
                f"order-em{p}",
                f"em order {p}: observed order of the position error (max over {self.n} periods) from "
                f"T/{n1} and T/{n2}, shortfall below the nominal order",
                f"the nominal order {p} (errors against {ref})",
                max(0.0, p - observed),
                C.SLOPE,
                "1 (order)",
                "the steps are chosen so that both errors lie above the referee's own error and below a 1 % phase "
                "error; within 0.5 of the nominal order as the unit tests and the Kepler cases",
                f"errors {errs[0]:.3g} and {errs[1]:.3g} {self._unit()}; observed order {observed:.3f}",
            )

    def _unit(self) -> str:
        return "a" if self.case.name != "figure-eight" else "L"


def run_effect_case(case: EffectCase, mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True) -> dict:
    """Run one effect case in a mode, write its figures and return its outcome.

    An exception inside the case becomes a failed check, not a crash.

    Parameters
    ----------
    case : EffectCase
        The case.
    mode : str
        ``"quick"`` or ``"full"``.
    outdir : str
        The report folder.
    scale : float
        Multiplies every tolerance.
    figures : bool
        Draw the figures.

    Returns
    -------
    CaseOutcome
        The outcome, with the keys of the orbit cases and a ``summary`` of what ran.
    """
    from .runner import case_outcome

    def draw(run):  # matplotlib is imported only where figures are drawn
        from .effect_figures import effect_figures

        return effect_figures(run, outdir)

    start = time.perf_counter()
    r = EffectRun(case, mode, scale, outdir)
    steps = "; ".join(
        f"order {p}: T/" + ", T/".join(map(str, dict.fromkeys((*case.steps[p], case.main[p])))) for p in ORDERS
    )
    return case_outcome(
        case,
        mode,
        r,
        start,
        draw if figures else None,
        summary=f"em runs {r.n} periods of {case.period:.10g} s at {steps} (T the period); "
        f"{case.records} records per period.",
        steps_per_period=case.main[2],
    )
