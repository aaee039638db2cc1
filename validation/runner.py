"""Runs one case: emorbit at every method and order, the referees, the checks and the figures.

What runs for a case (``n`` = case.orbits[mode] periods, ``nh`` = case.orbits_high[mode]):

* em, midpoint and leapfrog at order 2 with dt = period / steps, ``n`` periods; em also at
  dt/2 (Richardson estimate of its period error and order of its apsidal precession);
* em at orders 4, 6, 8 with dt/4 for ``nh`` periods; em order 8 also at dt/2 (Richardson);
  midpoint and leapfrog at orders 4, 6, 8 with dt/4 (energy and angular momentum);
* REBOUND IAS15 and WHFast on the same record times, and the analytic Kepler solution;
* (where the mode asks for it) the convergence study: position error after one period
  against the analytic solution, every method and order, steps per period on a sqrt(2) ladder.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np

from emorbit import orbits

from . import checks as C
from .cases import HIGH_ORDER_REFINEMENT, Case
from .checks import Check, measure_period, richardson, run_checked, wrap
from .runs import Trajectory, analytic, record_times, run_emorbit, run_rebound

__all__ = ["run_case", "CaseOutcome", "body_outcome"]

ORDERS = (2, 4, 6, 8)
METHODS = ("em", "midpoint", "leapfrog")
#: sqrt(2) ladder of steps per period: exponents j in steps * 2^(j/2), per order (finer
#: steps are skipped once the error is below the fit window)
LADDER = {2: range(0, 11), 4: range(-4, 11), 6: range(-6, 9), 8: range(-6, 9)}
#: refinements (x steps) at which em order 8's error after one period is pure round-off: its
#: truncation error there is below 8^-8 = 6e-8 of that at the case's step
FLOOR_REFINEMENTS = (8, 16)
#: the fit uses errors above this multiple of the measured round-off floor (which, from two
#: samples of a random walk, can be low by a few)
FLOOR_FACTOR = 30.0


class CaseOutcome(dict):
    """The JSON-ready result of one case (a dict).

    Keys: name, title, description, params, mode, orbits, orbits_high, steps_per_period,
    period_s, runs, metrics, convergence, checks (each :meth:`Check.to_dict`), figures, files,
    error, timing, wall_s and passed.
    """

    @property
    def passed(self) -> bool:
        """Whether every check of the case passed."""
        return bool(self["passed"])


class _CaseRun:
    def __init__(self, case: Case, mode: str, scale: float, outdir: str):
        self.case = case
        self.mode = mode
        self.scale = scale
        self.outdir = outdir
        self.n = case.orbits[mode]
        self.nh = case.orbits_high[mode]
        self.a = case.semi_major_axes()
        self.el0 = case.initial_elements()
        self.checks: list[Check] = []
        self.metrics: dict = {}
        self.runs: dict[str, Trajectory] = {}
        self.files: list[str] = []
        self.convergence: dict = {}
        self.named: dict[str, Trajectory] = {}
        self.timing: dict = {}
        self.single = case.n == 1

    # -- helpers -----------------------------------------------------------------------
    def check(self, id_, what, against, value, tolerance, unit, reason, detail=""):
        self.checks.append(Check(id_, what, against, value, tolerance * self.scale, unit, reason, detail))

    def metric(self, key, value, unit, note=""):
        v = value.item() if isinstance(value, np.generic) else value
        self.metrics[key] = {"value": v, "unit": unit, "note": note}

    def em(self, method, order, refinement, periods, output=None, label=None) -> Trajectory:
        c = self.case
        steps = c.steps * refinement
        label = label or (f"{method} {order}, dt = T/{steps}")
        tr = run_emorbit(c, method, order, steps, periods, steps // c.records, output=output, label=label)
        self.runs[label] = tr
        return tr

    # -- the pipeline ------------------------------------------------------------------
    def run(self):
        c = self.case
        times = record_times(c, self.n)
        files = {}
        if c.name == "paper":  # the paper's energy figure is drawn from these files
            files = {m: os.path.join(self.outdir, f"paper-{m}.h5") for m in ("em", "midpoint")}
            self.files += [os.path.basename(f) for f in files.values()]
        em2 = self.em("em", 2, 1, self.n, output=files.get("em"))
        mid2 = self.em("midpoint", 2, 1, self.n, output=files.get("midpoint"))
        lf2 = self.em("leapfrog", 2, 1, self.n)
        em2h = self.em("em", 2, 2, self.n) if self.single else None
        high = {p: self.em("em", p, HIGH_ORDER_REFINEMENT, self.nh) for p in (4, 6, 8)}
        em8c = self.em("em", 8, 2, self.nh) if self.single else None
        baselines = {
            f"{m}{p}": self.em(m, p, HIGH_ORDER_REFINEMENT, self.nh)
            for m in ("midpoint", "leapfrog")
            for p in (4, 6, 8)
        }
        ias = run_rebound(c, "ias15", times)
        whf = run_rebound(c, "whfast", times)
        self.runs["IAS15"] = ias
        self.runs["WHFast"] = whf
        kep = analytic(c, times)
        kep_w = analytic(c, whf.t)
        self.named = {
            "em2": em2,
            "midpoint2": mid2,
            "leapfrog2": lf2,
            **{f"em{p}": tr for p, tr in high.items()},
            **baselines,
            "IAS15": ias,
            "WHFast": whf,
            "Kepler": kep,
            "Kepler (WHFast times)": kep_w,
        }

        self._referees(ias, whf, kep, kep_w)
        tol_e2 = self._energy(em2, high, ias)
        ours = [tr for label, tr in self.runs.items() if label not in ("IAS15", "WHFast")]
        self._angular_momentum(ours, ias)
        for tr in ours:
            self.metric(
                f"energy.max[{tr.label}]",
                tr.rel_energy_error(c).max(),
                "1",
                f"{tr.info['orbits']} orbits; "
                + (
                    "exact up to round-off"
                    if tr.info["method"] == "em"
                    else "not conserved: oscillates with the step's error"
                ),
            )
        self._elements(em2, em2h, ias, tol_e2)
        self._positions(em2, high, ias, kep)
        if self.single:
            self._periods(em2, em2h, high[8], em8c, ias, kep, tol_e2)
        if self.mode in c.convergence:
            t0 = time.perf_counter()
            self._convergence()
            self.timing["convergence_s"] = time.perf_counter() - t0
        if c.offset_study:
            self._offset_study()

    # -- referees ----------------------------------------------------------------------
    def _referees(self, ias, whf, kep, kep_w):
        a = self.a
        tol = C.REFEREE_FRACTION * C.POSITION_PER_ORBIT * self.n
        why = (
            f"{C.REFEREE_FRACTION:g} of the em order-8 position tolerance ({C.POSITION_PER_ORBIT:g} a per orbit "
            f"x {self.n} orbits): a referee may not use more of it"
        )
        e_ias = ias.position_error(kep, a)
        self.check(
            "referee-ias15-position",
            "REBOUND IAS15 position, max over time and particles",
            "analytic Kepler solution (emorbit.orbits.propagate)",
            e_ias.max(),
            tol,
            "a",
            why,
            f"{ias.info['steps']} IAS15 steps; at the end {e_ias[-1].max():.3g} a",
        )
        e_whf = whf.position_error(kep_w, a)
        self.check(
            "referee-whfast-position",
            "REBOUND WHFast position (dt = record interval), max over time",
            "analytic Kepler solution at t = k dt",
            e_whf.max(),
            tol,
            "a",
            why,
            f"REBOUND's clock sim.t drifted {whf.info['clock_drift_s']:.3g} s from k dt (not an integrator error)",
        )
        self.metric("ias15.position_vs_kepler.max", e_ias.max(), "a")
        self.metric("whfast.position_vs_kepler.max", e_whf.max(), "a")
        self.metric("ias15.steps", ias.info["steps"], "1")
        self.metric("ias15.wall", ias.wall, "s", "sampling at every record time included")
        self.metric(
            "ias15.central_body_displacement",
            ias.info["central_body_displacement_m"],
            "m",
            "N_active = 1: the test particles do not move the central mass",
        )

    # -- energy ------------------------------------------------------------------------
    def _energy(self, em2, high, ias) -> float:
        c = self.case
        e_ias = ias.rel_energy_error(c).max()
        self.metric("ias15.energy.max", e_ias, "1", "|E - E0| / |E0|")
        e2 = em2.rel_energy_error(c).max()
        if e_ias <= C.ENERGY_ORDER2:
            tol = C.ENERGY_ORDER2
            why = (
                f"IAS15 keeps {C.ENERGY_ORDER2:g} here (measured {e_ias:.2g}), so em at order 2 must too: "
                "em conserves energy exactly up to round-off"
            )
        else:
            tol = C.ENERGY_HIGH
            why = (
                f"IAS15 itself exceeds {C.ENERGY_ORDER2:g} here (measured {e_ias:.2g}); em at order 2 is "
                f"held to the orders-4-8 bound {C.ENERGY_HIGH:g}"
            )
        self.check(
            "energy-em2",
            f"em order 2 energy, max |E - E0| / |E0| over {self.n} orbits"
            + (" and all particles" if not self.single else ""),
            "the initial energy; IAS15's error on the same records",
            e2,
            tol,
            "1",
            why,
            f"{em2.info['steps']} steps, dt = {em2.info['dt_s']:.6g} s",
        )
        for p, tr in high.items():
            ep = tr.rel_energy_error(c).max()
            self.check(
                f"energy-em{p}",
                f"em order {p} energy, max |E - E0| / |E0| over {self.nh} orbits",
                "the initial energy",
                ep,
                C.ENERGY_HIGH,
                "1",
                f"em at orders 4-8 conserves energy exactly up to round-off, and the compensated (Kahan) "
                f"update of the state keeps the round-off of its many sub-steps below {C.ENERGY_HIGH:g}",
                f"{tr.info['substeps']} sub-steps, dt = {tr.info['dt_s']:.6g} s",
            )
        return tol

    def _angular_momentum(self, runs, ias):
        c = self.case
        worst = max(runs, key=lambda tr: tr.rel_angular_momentum_error(c).max())
        value = worst.rel_angular_momentum_error(c).max()
        per = ", ".join(f"{tr.label}: {tr.rel_angular_momentum_error(c).max():.2g}" for tr in runs)
        self.check(
            "angular-momentum",
            "|L - L0| / |L0| about the centre, worst of every run (em, midpoint, leapfrog at orders 2-8 and two steps)",
            "the initial angular momentum",
            value,
            C.ANGULAR_MOMENTUM,
            "1",
            "every method applies central forces only, so L is exact up to round-off (Brouwer's walk)",
            per,
        )
        self.metric("ias15.angular_momentum.max", ias.rel_angular_momentum_error(c).max(), "1")

    # -- orbital elements ----------------------------------------------------------------
    def _elements(self, em2, em2h, ias, tol_e):
        c = self.case
        el = em2.elements(c)
        e0 = self.el0.e
        tol_L = C.ANGULAR_MOMENTUM
        who = "all particles" if not self.single else f"{self.n} orbits"
        da = np.abs(el.a / el.a[0] - 1.0).max()
        self.check(
            "elements-a",
            f"em order 2: drift of a, max |a - a0| / a0 ({who})",
            "a at the start",
            da,
            tol_e,
            "1",
            "a = -GM / (2 E), so |da| / a = |dE| / |E|: the energy tolerance of this case",
        )
        de2 = np.abs(el.e**2 - el.e[0] ** 2).max()
        tol_e2 = float(np.max((1.0 - e0**2) * (tol_e + 2 * tol_L) + 8 * C.EPS))
        self.check(
            "elements-e",
            f"em order 2: drift of e, max |e^2 - e0^2| ({who})",
            "e at the start",
            de2,
            tol_e2,
            "1",
            "e^2 = 1 + 2 E L^2 / GM^2, so |d(e^2)| <= (1 - e^2)(|dE|/|E| + 2 |dL|/|L|) at the energy and "
            "angular-momentum tolerances (+ 8 eps for evaluating e); e^2, not e, is smooth at e = 0",
            f"max |e - e0| = {np.abs(el.e - el.e[0]).max():.3g}",
        )
        tilt = em2.plane_tilt(c).max()
        self.check(
            "elements-plane",
            f"em order 2: tilt of the orbital plane, max angle between L(t) and L0 ({who})",
            "the initial orbit normal",
            tilt,
            tol_L,
            "rad",
            "the normal L/|L| turns by at most |dL| / |L| (the angular-momentum tolerance)",
        )
        sin_i = np.sin(self.el0.i)
        inclined = sin_i > 1e-3
        if np.all(inclined):
            di = np.abs(el.i - el.i[0]).max()
            dO = np.abs(wrap(el.raan - el.raan[0]) * sin_i).max()
            tol_i = tol_L + 4 * C.EPS / float(sin_i.min())
            self.check(
                "elements-i",
                f"em order 2: drift of the inclination i ({who})",
                "i at the start",
                di,
                tol_i,
                "rad",
                "i changes by at most the plane's tilt; + 4 eps / sin i for evaluating arccos",
            )
            self.check(
                "elements-raan",
                f"em order 2: drift of the node Omega, max |dOmega| sin i ({who})",
                "Omega at the start",
                dO,
                tol_L + 4 * C.EPS,
                "rad",
                "the node moves by at most tilt / sin i; weighted by sin i, the plane's tolerance",
                f"max |dOmega| = {np.abs(wrap(el.raan - el.raan[0])).max():.3g} rad",
            )
        else:
            self.metric(
                "elements.i_raan",
                "undefined",
                "",
                "equatorial orbit: i = 0 and Omega undefined; the plane check covers them",
            )
        for key, tr in (("em2", em2), ("ias15", ias)):
            e = tr.elements(c)
            self.metric(f"{key}.drift.a", np.abs(e.a / e.a[0] - 1).max(), "1", "max |a - a0| / a0")
            self.metric(f"{key}.drift.e", np.abs(e.e - e.e[0]).max(), "1", "max |e - e0|")
            self.metric(f"{key}.drift.i", np.abs(e.i - e.i[0]).max(), "rad")
            if np.all(inclined):
                self.metric(f"{key}.drift.raan", np.abs(wrap(e.raan - e.raan[0])).max(), "rad")
        # omega: em's phase error shows as apsidal precession, second order in dt
        if self.single and e0[0] >= C.CIRCULAR:
            rates = {}
            for key, tr in (("em2", em2), ("em2 dt/2", em2h), ("IAS15", ias)):
                w = np.unwrap(tr.elements(c).argp[:, 0])
                rates[key] = float(np.polyfit(tr.t / c.period, w, 1)[0])
                self.metric(f"{key}.argp_rate", rates[key], "rad / orbit", "apsidal precession (fit over the run)")
            order = math.log2(abs(rates["em2"] / rates["em2 dt/2"])) if rates["em2 dt/2"] else math.nan
            self.check(
                "elements-omega-order",
                "em order 2: order of the apsidal precession d(omega)/dt in dt",
                "the method's order 2 (rates at dt and dt/2)",
                abs(order - 2.0),
                C.SLOPE,
                "1 (order)",
                "omega is not conserved: em's phase error turns the apse line, at second order in dt",
                f"omega' = {rates['em2']:.3g} rad/orbit at dt, {rates['em2 dt/2']:.3g} at dt/2 (observed order "
                f"{order:.3f}); IAS15 {rates['IAS15']:.2g} rad/orbit",
            )

    # -- positions -----------------------------------------------------------------------
    def _positions(self, em2, high, ias, kep):
        a = self.a
        c = self.case
        for key, tr in (("em2", em2), *((f"em{p}", tr) for p, tr in high.items())):
            m = len(tr.t)
            self.metric(f"{key}.position_vs_kepler.end", tr.position_error(kep.head(m), a)[-1].max(), "a")
            self.metric(f"{key}.position_vs_ias15.max", tr.position_error(ias.head(m), a).max(), "a")
        em8 = high[8]
        m = len(em8.t)
        err = em8.position_error(ias.head(m), a)
        self.check(
            "position-em8-vs-ias15",
            f"em order 8 (dt = T/{c.steps * HIGH_ORDER_REFINEMENT}) position, "
            f"max over {self.nh} orbits" + ("" if self.single else " and all particles"),
            "REBOUND IAS15 on the same records",
            err.max(),
            C.POSITION_PER_ORBIT * self.nh,
            "a",
            f"the suite's accuracy target, < 1e-7 a after 100 orbits on the paper's orbit at T/400, per "
            f"orbit: a phase error grows linearly in time, so {C.POSITION_PER_ORBIT:g} a per orbit",
        )
        if c.name == "paper" and self.nh >= 100:
            k = 100 * c.records
            self.check(
                "position-em8-vs-ias15-100-orbits",
                "em order 8, dt = T/400, position after 100 orbits (max over them)",
                "REBOUND IAS15",
                err[: k + 1].max(),
                1e-7,
                "a",
                "the suite's accuracy target itself: em order 8 at T/400 stays within 1e-7 a of IAS15 "
                "for 100 orbits of the paper's orbit",
            )

    # -- periods -------------------------------------------------------------------------
    def _periods(self, em2, em2h, em8, em8c, ias, kep, tol_e):
        c = self.case
        e0 = float(self.el0.e[0])
        kind = "apses" if e0 >= C.CIRCULAR else "crossings"
        t_kepler = float(c.kepler_periods()[0])
        if c.target_period:
            t_ref, source = c.target_period
            against = f"{source} = {t_ref:.10g} s"
        else:
            t_ref, against = t_kepler, f"Kepler period of the initial state, 2 pi sqrt(a^3 / GM) = {t_kepler:.10g} s"

        def per(tr):
            return measure_period(tr.t, tr.x[:, 0], tr.v[:, 0], c.gm, c.center, kind)

        p_kep = per(kep)
        floor = abs(p_kep.value - t_kepler)  # the measurement's own error on exact motion
        self.metric("period.kepler", t_kepler, "s", "from the initial osculating a")
        self.metric(
            "period.measurement_floor",
            floor / t_kepler,
            "1",
            f"{kind} measured on the analytic solution at the same records",
        )
        # from the osculating a (Kepler's third law) along the em run
        a_mean = float(np.mean(em2.elements(c).a[:, 0]))
        t_osc = float(orbits.kepler_period(a_mean, c.gm))
        self.metric("period.em2.osculating_a", t_osc, "s", "Kepler's third law on the mean osculating a of em 2")
        self.check(
            "period-osculating-a",
            "period from em order 2's osculating a (Kepler's third law), relative",
            against,
            abs(t_osc / t_ref - 1),
            1.5 * tol_e + 8 * C.EPS,
            "1",
            "em keeps a to the energy tolerance and T ~ a^1.5 ~ |E|^-1.5 (+ 8 eps of evaluation)",
        )
        runs = (("em2", em2, em2h, 0.5, 2), ("em8", em8, em8c, 2.0, 8))
        for key, tr, other, ratio, p in runs:
            p1, p2 = per(tr), per(other)
            err = richardson(p1.value, p2.value, ratio, p)
            # T ~ |E|^-1.5: the run's own energy error bounds how well its period can be defined
            energy = 1.5 * tr.rel_energy_error(c).max() * t_ref + 8 * C.EPS * t_ref
            tol = (
                C.PERIOD_ALLOWANCE * abs(err)
                + C.SIGMAS * (p1.sigma if math.isfinite(p1.sigma) else 0)
                + 2 * floor
                + energy
            )
            self.metric(f"period.{key}.{kind}", p1.value, "s", f"{p1.events} passages")
            self.metric(
                f"period.{key}.richardson_error",
                err / t_ref,
                "1",
                f"from dt and {ratio:g} dt: (T(dt) - T({ratio:g} dt)) / (1 - {ratio:g}^{p})",
            )
            self.check(
                f"period-{key}",
                f"em order {p} period from {kind} ({p1.events} passages, dt = "
                f"{tr.info['dt_s']:.6g} s), |T - T_ref| (relative)",
                against,
                abs(p1.value / t_ref - 1),
                tol / t_ref,
                "1",
                f"the method's measured error: {C.PERIOD_ALLOWANCE:g} x the Richardson estimate "
                f"({err / t_ref:+.3g}) + {C.SIGMAS:g} standard errors of the passage fit "
                f"({p1.sigma / t_ref:.2g}) + 2 x the measurement's error on the exact orbit ({floor / t_ref:.2g})"
                f" + 1.5 x the run's energy error + 8 eps ({energy / t_ref:.2g}; T ~ |E|^-1.5)",
                f"T = {p1.value:.12g} s; Richardson-corrected {p1.value - err:.12g} s",
            )
        p_ias = per(ias)
        tol = C.REFEREE_FRACTION * C.POSITION_PER_ORBIT / (2 * math.pi)
        self.metric(f"period.ias15.{kind}", p_ias.value, "s")
        self.check(
            "referee-ias15-period",
            f"IAS15 period from {kind}, |T - T_ref| (relative)",
            against,
            abs(p_ias.value / t_ref - 1),
            tol + (C.SIGMAS * p_ias.sigma + 2 * floor) / t_ref,
            "1",
            "a period error dT/T moves the body 2 pi a dT/T per orbit: the referee's share of the em "
            f"position tolerance, {C.REFEREE_FRACTION:g} x {C.POSITION_PER_ORBIT:g} a per orbit / 2 pi, "
            "+ the fit's noise",
        )

    # -- convergence -----------------------------------------------------------------------
    def _convergence(self):
        """Position error after one period against the analytic solution, for every method
        and order on a ladder of steps; the order is fitted above the round-off floor."""
        c = self.case
        from emorbit import IntegrationError

        def error(method, p, n):
            tr = run_emorbit(c, method, p, n, 1, n)
            ref = analytic(c, tr.t[-1:])
            return float((np.linalg.norm(tr.x[-1] - ref.x[0], axis=-1) / self.a).max())

        floor = max(error("em", 8, c.steps * k) for k in FLOOR_REFINEMENTS)
        lo, hi = max(FLOOR_FACTOR * floor, C.SLOPE_WINDOW[0]), C.SLOPE_WINDOW[1]
        self.metric(
            "convergence.round_off_floor",
            floor,
            "a",
            f"em 8 after one period at {' and '.join(map(str, FLOOR_REFINEMENTS))} x the steps: round-off only",
        )
        for method in METHODS:
            for p in ORDERS:
                ns, errs = [], []
                for j in LADDER[p]:
                    n = int(round(c.steps * 2.0 ** (j / 2)))
                    if ns and n == ns[-1]:
                        continue
                    try:
                        e = error(method, p, n)
                    except IntegrationError:
                        continue  # a step too large for Newton: not part of the fit
                    ns.append(n)
                    errs.append(e)
                    if e < lo:
                        break
                slope, used = C.fit_slope(ns, errs, lo, hi)
                self.convergence[f"{method}{p}"] = {
                    "steps_per_orbit": ns,
                    "error_a": errs,
                    "slope": slope,
                    "points": used,
                    "window_a": [lo, hi],
                }
                self.check(
                    f"order-{method}{p}",
                    f"{method} order {p}: order of convergence of the position "
                    "error after one period, shortfall below the nominal order",
                    f"the nominal order {p} (errors against the analytic Kepler solution)",
                    max(0.0, p - slope) if math.isfinite(slope) else math.inf,
                    C.SLOPE,
                    "1 (order)",
                    f"fitted to the 3 finest steps with errors in [{lo:.2g}, {hi:g}] a: above {FLOOR_FACTOR:g} x "
                    f"the measured round-off floor ({floor:.2g} a) and {C.SLOPE_WINDOW[0]:g} a, below a 1 % phase "
                    "error; the unit tests allow 0.5 too. An order above nominal is not a defect: compositions "
                    "converge faster than h^p before they reach the asymptotic range",
                    f"observed order {slope:.3f} from {used} points",
                )

    def _offset_study(self):
        """em order 2 and IAS15 energy error with the centre moved away from the origin."""
        import dataclasses

        c = self.case
        rows = []
        for center in c.offset_study:
            center = np.asarray(center, float)
            moved = dataclasses.replace(c, center=center, x0=c.x0 - c.center + center, offset_study=())
            tr = run_emorbit(moved, "em", 2, c.steps, self.n, c.steps // c.records)
            ias = run_rebound(moved, "ias15", record_times(moved, self.n))
            rows.append(
                {
                    "center_m": center.tolist(),
                    "em2_energy": float(tr.rel_energy_error(moved).max()),
                    "ias15_energy": float(ias.rel_energy_error(moved).max()),
                }
            )
        self.metrics["offset_study"] = {
            "value": rows,
            "unit": "1",
            "note": "max |E - E0| / |E0| over the same orbits with the centre elsewhere",
        }


def run_case(case: Case, mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True) -> CaseOutcome:
    """Run one case in a mode, write its figures and return its outcome.

    An exception inside the case becomes a failed check, not a crash.

    Parameters
    ----------
    case : Case
        The case (the effect cases run :func:`.effect_runner.run_effect_case`).
    mode : str
        ``"quick"`` or ``"full"``.
    outdir : str
        The report folder (figures, and the paper case's HDF5 files).
    scale : float
        Multiplies every tolerance.
    figures : bool
        Draw the figures.

    Returns
    -------
    CaseOutcome
        The outcome.
    """

    def draw(run):  # matplotlib is imported only where figures are drawn
        from .figures import case_figures

        return case_figures(run, outdir)

    start = time.perf_counter()
    r = _CaseRun(case, mode, scale, outdir)
    return case_outcome(
        case,
        mode,
        r,
        start,
        draw if figures else None,
        orbits=r.n,
        orbits_high=r.nh,
        steps_per_period=case.steps,
        convergence=r.convergence,
        files=r.files,
    )


#: the keys of a :class:`CaseOutcome`, in the order results.json writes them
_OUTCOME_KEYS = (
    "name", "title", "description", "params", "mode", "orbits", "orbits_high", "summary", "steps_per_period",
    "period_s", "runs", "metrics", "convergence", "checks", "figures", "files", "error", "timing", "wall_s", "passed",
)  # fmt: skip


def case_outcome(case, mode: str, r, start: float, draw=None, *, drop=(), **keys) -> CaseOutcome:
    """Run a case's run object and gather its outcome: what every kind of case shares.

    Parameters
    ----------
    case : object
        The case: ``name``, ``title``, ``description``, ``params`` and ``period``.
    mode : str
        ``"quick"`` or ``"full"``.
    r : object
        The case's run: ``run()``, and ``checks``, ``runs`` (label to a trajectory with
        ``wall`` and ``info``), ``metrics``, ``convergence`` and ``timing``. An exception in
        ``run()`` becomes a failed check (:func:`~.checks.run_checked`).
    start : float
        ``time.perf_counter()`` when the case began (``wall_s`` counts from it).
    draw : callable or None
        ``draw(r)`` returns the paths of the figures, drawn only where the run reached its
        end; its time lands in ``timing["figures_s"]``.
    drop : tuple of str
        ``info`` keys left out of ``runs`` (bulky arrays).
    **keys
        The case's own keys of the outcome (``summary``, ``orbits``, ``steps_per_period``,
        ``files``, ...); by default ``orbits``, ``orbits_high`` and ``steps_per_period`` are
        None, ``files`` empty and ``convergence`` keyed by strings; no ``summary``.

    Returns
    -------
    CaseOutcome
        The outcome.
    """
    error = run_checked(r)
    figs = []
    if draw is not None and error is None:
        t0 = time.perf_counter()
        figs = draw(r)
        r.timing["figures_s"] = time.perf_counter() - t0
    out = {
        "name": case.name,
        "title": case.title,
        "description": case.description,
        "params": case.params,
        "mode": mode,
        "orbits": None,
        "orbits_high": None,
        "steps_per_period": None,
        "period_s": case.period,
        "runs": {
            label: {"wall_s": tr.wall, **{k: v for k, v in tr.info.items() if k not in drop}}
            for label, tr in r.runs.items()
        },
        "metrics": r.metrics,
        "convergence": {str(k): v for k, v in r.convergence.items()},
        "checks": [ch.to_dict() for ch in r.checks],
        "figures": figs,
        "files": [],
        "error": error,
        "timing": r.timing,
        "passed": all(ch.passed for ch in r.checks),
    }
    out.update(keys)
    out["wall_s"] = time.perf_counter() - start
    return CaseOutcome({k: out[k] for k in _OUTCOME_KEYS if k in out})


def body_outcome(case, mode: str, outdir: str, make, draw, *, figures: bool = True, summary="", **keys) -> CaseOutcome:
    """Run a body case (:mod:`.body_case`) and gather its outcome: what every body module's
    ``run`` shares.

    Parameters
    ----------
    case : BodyCase
        The case.
    mode : str
        ``"quick"`` or ``"full"``.
    outdir : str
        The report folder.
    make : callable
        ``make()`` gives the case's :class:`~.body_case.BodyRun`, not yet run (``wall_s``
        counts from before it).
    draw : callable
        ``draw(run, outdir)`` writes the figure of the finished run and returns its file name;
        it imports its figures module (matplotlib) itself, only where figures are drawn.
    figures : bool
        Draw the figure.
    summary : str or callable
        The report's line on the runs, or ``summary(run)`` giving it from the run not yet run.
    **keys
        Passed to :func:`case_outcome` (``drop``, ``orbits``, ``steps_per_period``, ...).

    Returns
    -------
    CaseOutcome
        The outcome.
    """
    start = time.perf_counter()
    r = make()
    text = summary(r) if callable(summary) else summary
    return case_outcome(
        case, mode, r, start, (lambda run: [draw(run, outdir)]) if figures else None, summary=text, **keys
    )
