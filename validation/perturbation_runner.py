"""Runs one perturbation case: em at every order and step, IAS15 with the same force model, the
checks, the convergence study and the figure.

What runs: em at orders 2, 4, 6, 8 at the case's steps per day (a doubling sequence per order;
the radiation case's order 8 adds steps sqrt(2) apart); IAS15 at epsilon 1e-11 (the reference)
and 1e-9 (full mode adds 1e-12), which bound IAS15's own error; the unperturbed Kepler orbit
(the effect's size). The radiation case adds IAS15 without stops at the shadow's contacts (a
measurement) and a control without shadow (em order 8 against IAS15).

How the difference is explained: at the end, ``d(h) = |x_em(h) - x_IAS15|``; em's own error at
step h is estimated by step doubling (Richardson) with the expected order q,
``e_em(h) = |x(h) - x(h/2)| 2^q / (2^q - 1)`` (at the finest step, shown but not checked,
``|x(2h) - x(h)| / (2^q - 1)``), its round-off as its largest energy-balance error taken as an
error of the mean motion, ``r_em = 1.5 n t a max|E - E0 - W| / |E0|`` (an along-track drift),
and IAS15's own error as ``e_ias = max |x_IAS15(eps) - x_IAS15(1e-11)|``. Every em run with a
run at half its step must satisfy ``d(h) <= 1.5 (e_em(h) + r_em + e_ias)`` (the triangle
inequality, with room for the estimates' own error); the observed order (least squares over the
runs whose difference is at least 10 e_ias) must reach the expected one; the smallest difference
is checked against the effect's size. Where the order is the shadow's 5/2 the errors scatter by
a factor of a few from step to step (each contact adds an error whose sign depends on where it
falls within the step): that order is fitted to the largest difference of each octave of steps
(the envelope). Data: ``convergence[order]`` holds the steps per day, the differences, em's
estimates and round-off, the expected and observed orders and the points fitted.

The outcome has the keys of :class:`~.runner.CaseOutcome`, so the report treats it as any case.
References: L. F. Richardson, Phil. Trans. R. Soc. A 210 (1911) 307-357 (extrapolation from two
steps); E. Hairer, C. Lubich, G. Wanner, Geometric Numerical Integration, 2nd ed. (Springer,
2006), sections II.4 and V.3 (compositions and their order).
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import checks as C
from .checks import Check
from .perturbation_cases import ORDERS, PerturbationCase
from .perturbation_model import Path, ReferenceModel, sample_path
from .perturbation_runs import (
    LOOSE,
    TIGHT,
    TIGHTER,
    Trajectory,
    kepler,
    kernel_accelerations,
    kernel_paths,
    record_times,
    run_em,
    run_ias15,
)

__all__ = [
    "PerturbationRun",
    "run_perturbation_case",
    "EXPLAINED",
    "ABOVE_FLOOR",
    "em_error_estimates",
    "observed_order",
]

#: d(h) <= EXPLAINED (e_em(h) + e_ias): the triangle inequality, 1.5 for the estimates' own error
EXPLAINED = 1.5
#: differences used for the observed order lie this many times above IAS15's own error
ABOVE_FLOOR = 10.0


def em_error_estimates(runs: dict, q: float) -> dict:
    """em's own error at the end of each run, by step doubling with the expected order q.

    Parameters
    ----------
    runs : dict
        {steps per day: Trajectory} of one order.
    q : float
        The expected order.

    Returns
    -------
    dict
        {steps per day: estimated |error| at the end, m}; runs without a partner at twice or
        half the steps are left out.
    """
    out = {}
    for n, tr in runs.items():
        if 2 * n in runs:
            out[n] = float(np.linalg.norm(tr.x[-1] - runs[2 * n].x[-1])) * 2**q / (2**q - 1)
        elif n % 2 == 0 and n // 2 in runs:
            out[n] = float(np.linalg.norm(runs[n // 2].x[-1] - tr.x[-1])) / (2**q - 1)
    return out


def observed_order(steps, diffs, floor: float, envelope: bool = False) -> tuple[float, list]:
    """The order of convergence: minus the least-squares slope of log d against log steps.

    Parameters
    ----------
    steps, diffs : sequence
        Steps per day and the differences at the end.
    floor : float
        Differences below ``ABOVE_FLOOR * floor`` are left out.
    envelope : bool
        Fit the largest difference of each octave of steps instead of every run.

    Returns
    -------
    order : float
        nan with fewer than two points.
    used : list
        The (steps, difference) pairs fitted.
    """
    pts = sorted((n, d) for n, d in zip(steps, diffs) if d >= ABOVE_FLOOR * floor)
    if envelope and pts:
        base = pts[0][0]
        octaves: dict = {}
        for n, d in pts:
            k = int(math.floor(math.log2(n / base) + 1e-9))
            octaves[k] = max(octaves.get(k, (n, 0.0)), (n, d), key=lambda p: p[1])
        pts = [octaves[k] for k in sorted(octaves)]
    if len(pts) < 2:
        return math.nan, pts
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(-np.polyfit(x, y, 1)[0]), pts


class PerturbationRun:
    """The runs, checks and measurements of one perturbation case (what the figure reads)."""

    def __init__(self, case: PerturbationCase, mode: str, scale: float, outdir: str):
        self.case = case
        self.mode = mode
        self.scale = scale
        self.outdir = outdir
        self.times = record_times(case)
        self.checks: list[Check] = []
        self.metrics: dict = {}
        self.runs: dict[str, Trajectory] = {}
        self.em: dict[tuple[int, int], Trajectory] = {}
        self.ias: dict[float, Trajectory] = {}
        self.convergence: dict = {}
        self.extra: dict = {}
        self.timing: dict = {}

    # -- helpers -------------------------------------------------------------------------------
    def check(self, id_, what, against, value, tolerance, unit, reason, detail=""):
        self.checks.append(Check(id_, what, against, value, tolerance * self.scale, unit, reason, detail))

    def metric(self, key, value, unit, note=""):
        v = value.item() if isinstance(value, np.generic) else value
        self.metrics[key] = {"value": v, "unit": unit, "note": note}

    def roundoff(self, tr: Trajectory) -> float:
        """em's round-off in position at the end, m: its largest energy-balance error as an error
        of the mean motion, 1.5 n t a max|E - E0 - W| / |E0| (an along-track drift)."""
        c = self.case
        return 1.5 * (2 * math.pi / c.period) * c.span * c.length * float(np.abs(tr.balance).max())

    def steps(self, order: int) -> tuple:
        """The steps per day of an order in this mode."""
        return tuple(self.case.steps[self.mode][order])

    # -- the pipeline --------------------------------------------------------------------------
    def run(self):
        c = self.case
        t0 = time.perf_counter()
        for p in ORDERS:
            for n in self.steps(p):
                tr = run_em(c, p, n)
                self.em[(p, n)] = self.runs[tr.label] = tr
        self.timing["em_s"] = time.perf_counter() - t0
        first = self.em[(2, self.steps(2)[0])]
        self.paths = self._paths(first.sim)
        self.model = ReferenceModel(c, self.paths)
        t0 = time.perf_counter()
        for eps in (TIGHT, LOOSE, *((TIGHTER,) if self.mode == "full" else ())):
            tr = run_ias15(c, self.model, self.times, epsilon=eps, label=f"IAS15, epsilon {eps:g}")
            self.ias[eps] = self.runs[tr.label] = tr
        self.ref = self.ias[TIGHT]
        self.kepler = kepler(c, self.times)
        self.timing["ias15_s"] = time.perf_counter() - t0
        self.e_ias = max(tr.final_difference(self.ref) for eps, tr in self.ias.items() if eps != TIGHT)
        self._same_model(first)
        self._referee()
        self._energy()
        self._work()
        self._convergence()
        self._effect()
        if c.kind == "srp":
            self._srp_extras()

    def _paths(self, sim) -> dict[str, Path]:
        """The Sun's and the Moon's samples at the steps of emorbit's tables."""
        paths = {}
        for term in sim.effects:
            if term.kind == "third_body":
                paths[term.body] = sample_path(term.body, term.step, self.case.span, sim.epoch)
            elif term.kind == "srp":
                paths["sun"] = sample_path("sun", term.step, self.case.span, sim.epoch)
        return paths

    # -- the same force model ------------------------------------------------------------------
    def _same_model(self, first: Trajectory):
        """The reference's paths and accelerations against emorbit's tables and kernels."""
        c, sim = self.case, first.sim
        if self.paths:
            t = np.concatenate([self.times, self.times[:-1] + 0.37 * np.diff(self.times)])
            worst, per = 0.0, []
            for body, path in self.paths.items():
                mine, theirs = path.positions(t), kernel_paths(sim, body, t)
                rel = float((np.linalg.norm(mine - theirs, axis=1) / np.linalg.norm(theirs, axis=1)).max())
                worst = max(worst, rel)
                per.append(f"{body}: {rel:.2g} ({path.step / 3600:g} h samples)")
            self.check(
                "same-paths",
                f"the reference's Sun and Moon (its own Hermite interpolation of sample_table's samples) at {len(t)} "
                "times, max |s_ref - s_emorbit| / |s|",
                "emorbit's tables after its run (the third body's and radiation pressure's `positions(t)`)",
                worst,
                8 * C.EPS,
                "1",
                "the same samples and the same cubic Hermite polynomials evaluated in another order: a few eps; "
                "another path (sample step, epoch, ephemeris) would differ by metres",
                "; ".join(per),
            )
        states = self._states()
        ref, kern, nu_diff = kernel_accelerations(self, sim, states)
        scale = np.linalg.norm(ref, axis=1)
        rel = float(np.linalg.norm(ref - kern, axis=1).max() / scale.max())
        lit = scale > 0
        self.check(
            "same-forces",
            f"the reference's acceleration at {len(states)} states along the orbit"
            + (" (half of them in and near the penumbra)" if c.kind == "srp" else "")
            + ", max |a_ref - a_emorbit| / max |a_ref|",
            "emorbit's compiled effect set without the central field at the same states ("
            + {
                "drag": "drag on the chord x -+ v h/2, h = 1000 s",
                "srp": "the cannonball with the conical shadow",
                "third_body": "the third bodies at the point itself",
            }[c.kind]
            + ")",
            rel,
            c.tolerance["forces"],
            "1",
            c.tolerance["forces_reason"],
            f"{int(lit.sum())} states with a force"
            + (f"; |nu_ref - nu_kernel| at most {nu_diff:.2g}" if nu_diff is not None else ""),
        )

    def _states(self) -> np.ndarray:
        """(n, 7) states [t, x, v] for the force comparison: the reference's records, and for the
        conical shadow states 90 s either side of each contact (Kepler from the record before)."""
        from emorbit import orbits

        ref = self.ref
        rows = [np.column_stack([ref.t, ref.x, ref.v])]
        for tc in ref.info.get("contacts", [])[:40]:
            k = int(np.searchsorted(ref.t, tc)) - 1
            dt = tc + np.linspace(-90.0, 90.0, 19) - ref.t[k]
            x, v = orbits.propagate(ref.x[k], ref.v[k], self.case.gm, dt)
            rows.append(np.column_stack([ref.t[k] + dt, x, v]))
        return np.vstack(rows)

    # -- IAS15's own error ---------------------------------------------------------------------
    def _referee(self):
        c = self.case
        per = {eps: tr.final_difference(self.ref) for eps, tr in self.ias.items() if eps != TIGHT}
        self.check(
            "referee-ias15",
            f"IAS15's own error: its final position at epsilon {', '.join(f'{e:g}' for e in per)} against "
            f"{TIGHT:g}, the largest",
            "IAS15 at epsilon 1e-11 (the reference)",
            self.e_ias,
            c.tolerance["ias15"],
            "m",
            c.tolerance["ias15_reason"],
            "; ".join(f"epsilon {e:g}: {d:.3g} m" for e, d in per.items())
            + "; steps "
            + ", ".join(f"{tr.info['steps']} ({e:g})" for e, tr in self.ias.items()),
        )
        for eps, tr in self.ias.items():
            self.metric(f"ias15.{eps:g}.steps", tr.info["steps"], "1", f"{tr.info['force_evaluations']} evaluations")

    # -- energy and work -----------------------------------------------------------------------
    def _energy(self):
        c = self.case
        ias_balance = float(np.abs(self.ref.balance).max())
        self.metric(
            "ias15.energy.max",
            ias_balance,
            "1",
            "IAS15's energy balance max |E - E0 - W| / |E0|, W integrated by IAS15 as a test particle's velocity",
        )
        self.check(
            "energy-ias15",
            "IAS15's energy balance max |E - E0 - W| / |E0| over the records (epsilon 1e-11), W its own quadrature "
            "of the power (" + ("dU/dt" if c.kind == "third_body" else "a . v") + ")",
            "0",
            ias_balance,
            c.tolerance["energy_ias15"],
            "1",
            "IAS15 integrates the work as the velocity of a test particle whose acceleration is the power: the "
            "balance holds to IAS15's own error and round-off (measured), as emorbit's holds by construction",
        )
        tol2 = C.ENERGY_ORDER2 if ias_balance <= C.ENERGY_ORDER2 else C.ENERGY_HIGH
        for p in ORDERS:
            runs = [tr for (q, _), tr in self.em.items() if q == p]
            worst = max(runs, key=lambda tr: np.abs(tr.balance).max())
            value = float(np.abs(worst.balance).max())
            self.check(
                f"energy-em{p}",
                f"em order {p}: energy balance max |E - E0 - W| / |E0| over the records, W emorbit's discrete work "
                f"(`result.work`), worst of {len(runs)} step(s)",
                "0",
                value,
                tol2 if p == 2 else C.ENERGY_HIGH,
                "1",
                (f"IAS15 keeps {C.ENERGY_ORDER2:g} here (measured {ias_balance:.2g}), so em at order 2 must too: "
                 if p == 2 else "")
                + "em's step changes the energy by exactly its discrete work, so the balance holds to round-off "
                "(with Kahan sums of x, v and W)",
                ", ".join(f"{tr.label}: {np.abs(tr.balance).max():.2g}" for tr in runs),
            )  # fmt: skip

    def _work(self):
        c = self.case
        best = min(self.em.values(), key=lambda tr: tr.final_difference(self.ref))
        diff = abs(best.work[-1] - self.ref.work[-1]) / abs(self.ref.energy[0])
        self.check(
            "work-em-vs-ias15",
            f"the work W at the end of the em run closest to IAS15 ({best.label}), |W_em - W_IAS15| / |E0|",
            f"IAS15's W (epsilon 1e-11) = {self.ref.work[-1]:.10g} J/kg",
            diff,
            c.tolerance["work"],
            "1",
            c.tolerance["work_reason"],
            f"em {best.work[-1]:.12g} J/kg; |E0| = {abs(self.ref.energy[0]):.6g} J/kg",
        )
        self.metric("work.ias15", float(self.ref.work[-1]), "J/kg", "the effect's work over the run (IAS15)")

    # -- convergence ---------------------------------------------------------------------------
    def _convergence(self):
        c = self.case
        for p in ORDERS:
            runs = {n: self.em[(p, n)] for n in self.steps(p)}
            q = c.expected[p]
            est = em_error_estimates(runs, q)
            diffs = {n: tr.final_difference(self.ref) for n, tr in runs.items()}
            envelope = c.kind == "srp" and q != p
            order, used = observed_order(list(diffs), list(diffs.values()), self.e_ias, envelope)
            roundoff = {n: self.roundoff(tr) for n, tr in runs.items()}
            checked = [n for n in est if 2 * n in runs]  # a finer run to estimate from
            ratios = {n: diffs[n] / (est[n] + roundoff[n] + self.e_ias) for n in checked}
            self.convergence[p] = {
                "steps_per_day": list(diffs),
                "difference": list(diffs.values()),
                "em_estimate": [est.get(n, math.nan) for n in diffs],
                "em_roundoff": [roundoff[n] for n in diffs],
                "expected": q,
                "observed": order,
                "fitted": [list(u) for u in used],
                "envelope": envelope,
            }
            self.check(
                f"explained-em{p}",
                f"em order {p}: the final position difference from IAS15 at each step that has a run at half the step, "
                f"over em's own error (step doubling, order {q:g}, plus its round-off) and IAS15's "
                f"({self.e_ias:.2g} m), the largest",
                "1: the difference is no more than the two integrators' own errors",
                max(ratios.values()),
                EXPLAINED,
                "1",
                "|x_em - x_IAS15| <= |e_em| + |e_IAS15| (triangle inequality); 1.5 allows for the estimates' own "
                "error. em's round-off: its largest energy-balance error taken as an error of the mean motion, "
                "1.5 n t a max|E - E0 - W| / |E0|",
                "; ".join(f"1 d/{n}: {diffs[n]:.3g} m vs {est[n]:.3g} + {roundoff[n]:.2g} m" for n in checked),
            )
            if p not in c.checked_orders:
                continue
            what = "the largest difference of each octave of steps (the envelope)" if envelope else "the differences"
            self.check(
                f"order-em{p}",
                f"em order {p}: observed order of convergence, least squares over {what} at least {ABOVE_FLOOR:g} "
                f"times IAS15's error, shortfall below {q:g}",
                f"{q:g}" + (" (the shadow's contacts, asymptotically)" if envelope else " (the composition's order)"),
                max(0.0, q - order),
                C.SLOPE,
                "1 (order)",
                "within 0.5 of the expected order as the other cases: a kink (C^0) in the shadow would give 2, a jump "
                "1; at steps near the penumbra's 3 min its smooth part still converges at the composition's order, "
                "so the envelope falls faster there"
                if envelope
                else "within 0.5 of the nominal order as the other cases",
                f"observed {order:.3f} from " + ", ".join(f"1 d/{n}: {d:.3g} m" for n, d in used),
            )

    # -- the effect's size and the best agreement ----------------------------------------------
    def _effect(self):
        c = self.case
        effect = self.ref.final_difference(self.kepler)
        best_key = min(self.em, key=lambda k: self.em[k].final_difference(self.ref))
        best = self.em[best_key].final_difference(self.ref)
        self.metric("effect.final", effect, "m", "IAS15 with the effect against the Kepler orbit, at the end")
        self.metric("agreement.final", best, "m", f"the em run closest to IAS15: {self.em[best_key].label}")
        self.metric("ias15.error", self.e_ias, "m", "IAS15's own error (epsilon test)")
        self.check(
            "agreement-vs-effect",
            f"the smallest final |x_em - x_IAS15| over all em runs ({self.em[best_key].label}) relative to what the "
            f"effect moves the satellite after {c.days:g} day(s)",
            f"the effect: IAS15 with it against the Kepler orbit, {effect:.4g} m",
            best / effect,
            c.tolerance["agreement"],
            "1",
            c.tolerance["agreement_reason"],
            f"{best:.3g} m; IAS15's own error {self.e_ias:.3g} m",
        )

    # -- the radiation case: the shadow ----------------------------------------------------------
    def _srp_extras(self):
        """IAS15 without stops at the contacts; the control without shadow; the eclipses."""
        c = self.case
        plain = run_ias15(c, self.model, self.times, epsilon=TIGHT, events=False, label="IAS15 without contact stops")
        self.runs[plain.label] = plain
        d = plain.final_difference(self.ref)
        self.metric(
            "ias15.without_contact_stops",
            d,
            "m",
            f"IAS15 (epsilon {TIGHT:g}) stepping over the shadow's contacts, against the reference: "
            f"{plain.info['steps']} steps; its energy balance {np.abs(plain.balance).max():.2g} does not show it",
        )
        contacts = np.asarray(self.ref.info["contacts"])
        groups = contacts[: len(contacts) // 4 * 4].reshape(-1, 4)  # penumbra in, umbra in, umbra out, out
        self.metric("eclipses", len(groups), "1", f"{len(contacts)} contacts of the conical shadow located")
        if len(groups):
            self.metric("eclipse.umbra_max", float((groups[:, 2] - groups[:, 1]).max()), "s", "the longest umbra")
            self.metric(
                "eclipse.penumbra",
                float(np.concatenate([groups[:, 1] - groups[:, 0], groups[:, 3] - groups[:, 2]]).max()),
                "s",
                "the longest crossing of the penumbra",
            )
        self.extra.update({"without_stops": plain, "contacts": contacts})
        # the control: no shadow, em order 8 converges at 8
        ctl = c.extra["no_shadow"]
        effects = [("srp", {"shadow": "none"})]
        model = ReferenceModel(c, self.paths, model={**c.model, "shadow": "none"})
        ias = {
            eps: run_ias15(c, model, self.times, epsilon=eps, label=f"IAS15 without shadow, epsilon {eps:g}")
            for eps in (TIGHT, LOOSE)
        }
        floor = ias[LOOSE].final_difference(ias[TIGHT])
        runs = {n: run_em(c, 8, n, effects=effects, label=f"em 8 without shadow, dt = 1 d/{n}") for n in ctl["steps"]}
        self.runs.update({tr.label: tr for tr in (*ias.values(), *runs.values())})
        diffs = {n: tr.final_difference(ias[TIGHT]) for n, tr in runs.items()}
        order, used = observed_order(list(diffs), list(diffs.values()), floor)
        self.check(
            "order-em8-no-shadow",
            "control without shadow (`shadow=\"none\"` on both sides): em order 8's observed order of convergence "
            f"against IAS15, least squares over the differences at least {ABOVE_FLOOR:g} times IAS15's error, "
            f"shortfall below {ctl['expected']:g}",
            f"{ctl['expected']:g}: the composition's order where the force is smooth",
            max(0.0, ctl["expected"] - order),
            C.SLOPE,
            "1 (order)",
            "within 0.5 of the nominal order as the other cases: with a smooth force em order 8 converges at 8, "
            "so the 5/2 with the shadow is the shadow's",
            f"observed {order:.3f} from " + ", ".join(f"1 d/{n}: {dd:.3g} m" for n, dd in used)
            + f"; IAS15's own error {floor:.2g} m",
        )  # fmt: skip
        self.convergence["8 without shadow"] = {
            "steps_per_day": list(diffs),
            "difference": list(diffs.values()),
            "expected": ctl["expected"],
            "observed": order,
            "fitted": [list(u) for u in used],
            "envelope": False,
        }
        self.extra["no_shadow_floor"] = floor


def run_perturbation_case(case: PerturbationCase, mode: str, outdir: str, *, scale: float = 1.0, figures=True) -> dict:
    """Run one perturbation case in a mode, write its figure and return its outcome.

    An exception inside the case becomes a failed check, not a crash.

    Parameters
    ----------
    case : PerturbationCase
        The case.
    mode : str
        ``"quick"`` or ``"full"``.
    outdir : str
        The report folder.
    scale : float
        Multiplies every tolerance.
    figures : bool
        Draw the figure.

    Returns
    -------
    CaseOutcome
        The outcome, with the keys of the other cases.
    """
    from .runner import case_outcome

    def draw(run):  # matplotlib is imported only where figures are drawn
        from .perturbation_figures import perturbation_figure

        return [perturbation_figure(run, outdir)]

    start = time.perf_counter()
    r = PerturbationRun(case, mode, scale, outdir)
    steps = "; ".join(f"order {p}: 1 d/" + ", 1 d/".join(map(str, case.steps[mode][p])) for p in ORDERS)
    return case_outcome(
        case,
        mode,
        r,
        start,
        draw if figures else None,
        drop=("contacts",),
        summary=f"em runs {case.days:g} day(s) ({case.span / case.period:.4g} orbits of {case.period:.8g} s) at "
        f"{steps}; IAS15 at epsilon 1e-11 and 1e-9{' and 1e-12' if mode == 'full' else ''}; "
        f"{case.records} records per day.",
    )
