"""The case ``torque-free``: a rigid box tumbling in free space near its intermediate axis
(the Dzhanibekov flip), emorbit's em method against the analytic period of Euler's equations,
against scipy's DOP853 and beside Exudyn's implicit integrators at large steps (the referees and
the equations: :mod:`.torque_free_referees`; the figure: :mod:`.torque_free_figures`).

The body is emorbit's homogeneous box 3 x 2 x 1 m of density 1 kg/m^3 (6 kg, 8 mass points:
``add_rigid(..., "box")``, the box of ``tests/test_rigid.py`` and ``emorbit bench``), no field
(``Simulation(None, ...)``), spinning at body-frame angular velocity w0 = (0.01, 2, 0.01) rad/s,
0.4 deg off its intermediate axis y. Its inertia, I = m/12 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2)
= diag(2.5, 5, 6.5) kg m^2, is exact for the box's Gauss points (checked). Its rates repeat after
T = 4 K(k) / rate = 28.43787 s (k'^2 = 1.867e-5, K = 6.8307; Landau & Lifshitz sec. 37), and w_y
changes sign every T/2 = 14.21894 s.

What is checked:

1. The flip interval of em at orders 2 and 4, each at two steps, from successive sign changes
   of the recorded w2 (each located on the cubic through the four records around it), against
   T/2: the observed order of convergence, and the finer step's error within 1.5 times its
   Richardson estimate (its discretisation error measured from the two steps). DOP853's flip
   events confirm the analytic period.
2. Body rates and attitude of em at orders 2, 4, 6, 8 against DOP853 on Euler's equations and
   the quaternion (rtol 1e-13; the same solve at rtol 1e-11 bounds its error), and the observed
   orders (emorbit's orders 6 and 8 reach 4 for rigid bodies: ``ORDER_REACHED`` of
   :mod:`.rigid_binary`).
3. Energy and angular momentum at round-off at every step of every em run, including steps of
   w dt = 0.1 to 1 (rotations of up to 53 degrees per step), where Exudyn's generalized-alpha
   solver (its default spectral radius, Euler-parameter and rotation-vector nodes) loses energy
   and angular momentum, and with Euler parameters fails Newton at a fixed step (Exudyn's
   default step reduction then takes smaller steps); its errors are metrics. Without Exudyn its
   part is skipped and the case passes.

References: L. D. Landau, E. M. Lifshitz, *Mechanics* (3rd ed., Pergamon 1976), sec. 37; P.
Betsch, P. Steinmann, Constrained integration of rigid body dynamics, Comput. Methods Appl.
Mech. Engrg. 191 (2001) 467-488 (the director step); M. Arnold, O. Bruls, Convergence of the
generalized-alpha scheme for constrained mechanical systems, Multibody Syst. Dyn. 18 (2007)
185-202; J. Gerstmayr, Exudyn - a C++-based Python package for flexible multibody systems,
Multibody Syst. Dyn. 60 (2024) 533-561.
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import checks as C
from .body_case import BodyCase, BodyRun, Trajectory, build_cases
from .rigid_binary import ORDER_REACHED, attitude_error
from .torque_free_referees import (
    box_inertia,
    exudyn_version,
    exudyn_wrapper,
    flip_times,
    jacobi_period,
    mean_interval,
    relative_errors,
    run_em,
    run_exudyn,
    run_referee,
)

__all__ = [
    "NAMES",
    "NOTE",
    "ORDERS",
    "RTOL",
    "RTOL_LOOSE",
    "cases",
    "run",
    "jacobi_period",
    "run_referee",
    "run_em",
    "run_exudyn",
    "flip_times",
    "TorqueFreeRun",
]

NAMES = ("torque-free",)
ORDERS = (2, 4, 6, 8)
#: DOP853's relative tolerance, and the looser one that bounds its own error
RTOL, RTOL_LOOSE = 1e-13, 1e-11
#: |E - E0| / E0 and |L - L0| / |L0| of every em run at every step: measured at most 4.3e-15
#: (energy, order 4 at T/500 over 6 T, 3000 steps) and 2.2e-15 (angular momentum); 2.3 times that
CONSERVED = 1e-14
#: the referee's inertia against the inertia of emorbit's 8 Gauss points, relative to its
#: largest entry: measured 1.9e-18 (off-diagonal rounding of sum m X X^T, 1.2e-17 kg m^2);
#: 8 times that
SAME_INERTIA = 1.5e-17
#: Exudyn's inertia and initial energy and angular momentum against emorbit's, relative:
#: measured 2.8e-18 (E0 bit for bit the same; L0 differs by emorbit's off-diagonal rounding);
#: one rounding of E0 (up to eps) is allowed
SAME_START = C.EPS
#: DOP853's (rtol 1e-13) flip interval against the analytic one, relative, per period T run:
#: measured 4.5e-13 to 8.9e-13 (1 T), 6.5e-13 (2 T) and 3.0e-12 (6 T)
DOP853_FLIP = 1.5e-12
#: |observed - expected| of the orders of convergence of the rates and the attitude, by order:
#: measured at most 1.7e-3, 0.012, 0.038 and 9.6e-3 (quick and full)
ORDER_TOLERANCE = {2: 0.01, 4: 0.05, 6: 0.1, 8: 0.05}
#: the same for the flip interval: measured 3.1e-5 (order 2) and 0.012 (order 4)
FLIP_ORDER_TOLERANCE = {2: 3e-4, 4: 0.05}

NOTE = (
    "The torque-free box (`torque-free`) tumbles near its intermediate axis (the Dzhanibekov flip). Its flip "
    "interval is checked against the period of the Jacobi-elliptic solution of Euler's equations (Landau & "
    "Lifshitz, *Mechanics*, sec. 37; `scipy.special.ellipkm1`), its body rates and attitude against scipy's "
    "DOP853 (rtol 1e-13, bounded by rtol 1e-11) at em orders 2, 4, 6, 8, and its energy and angular momentum at "
    "round-off at every step up to w dt = 1, beside Exudyn's generalized-alpha solver (Arnold & Bruls 2007; "
    "Exudyn, Gerstmayr 2024) at the same steps, whose energy and angular-momentum errors the report lists."
)


# -- the case ----------------------------------------------------------------------------------
def _torque_free(mode: str) -> BodyCase:
    from emorbit.bench.rigid_cases import FREE_BOX, FREE_OMEGA

    size, density, w0 = list(FREE_BOX["size"]), float(FREE_BOX["density"]), np.array(FREE_OMEGA, float)
    inertia = box_inertia(size, density)
    jac = jacobi_period(inertia, w0)
    T = jac["period"]
    periods = {"quick": 2, "full": 6}[mode]
    large = (0.05, 0.1, 0.2, 0.5)
    w = float(np.linalg.norm(w0))
    return BodyCase(
        name="torque-free",
        module="torque_free",
        title="Torque-free box near its intermediate axis: the Dzhanibekov flip against Euler's equations",
        description=(
            f"emorbit's homogeneous box {size[0]:g} x {size[1]:g} x {size[2]:g} m of {density:g} kg/m3 (8 mass "
            f"points, inertia diag {inertia.tolist()} kg m2) in free space (`Simulation(None, ...)`), spinning at "
            f"w0 = {w0.tolist()} rad/s in body axes, 0.4 deg off its intermediate axis: every T/2 = {T / 2:.7g} s it "
            "flips (w_y changes sign). The flip interval of em at orders 2 and 4 is checked against the "
            "Jacobi-elliptic solution of Euler's equations (Landau & Lifshitz sec. 37, K(k) from "
            f"scipy.special.ellipkm1 at k'^2 = {jac['k2c']:.6g}); the body rates and attitude of em at orders 2, 4, "
            "6, 8 against scipy's DOP853 on Euler's equations and the quaternion (rtol 1e-13, checked against rtol "
            "1e-11); energy and angular momentum at round-off at every step, also at w dt = "
            + ", ".join(f"{w * dt:.2g}" for dt in large)
            + ", where Exudyn's generalized-alpha solver (Euler-parameter and rotation-vector nodes) runs beside "
            "em on the same box."
        ),
        period=T,
        params={
            "box": f"{size} m, {density:g} kg/m3, {density * np.prod(size):g} kg, 8 mass points",
            "inertia": f"diag {inertia.tolist()} kg m2",
            "w0 (body frame)": f"{w0.tolist()} rad/s",
            "period T of the rates (Landau & Lifshitz sec. 37)": f"{T:.12g} s (flip interval {T / 2:.12g} s)",
            "k'^2, K": f"{jac['k2c']:.8g}, {jac['K']:.10g}",
            "run length": f"{periods} T",
            "large steps": ", ".join(f"{dt:g}" for dt in large)
            + f" s (w dt = {', '.join(f'{w * dt:.2g}' for dt in large)})",
            "DOP853": f"rtol {RTOL:g} (and {RTOL_LOOSE:g}), atol 1e-3 rtol on the scales (1, |w0|)",
        },
        settings={
            "size": size,
            "density": density,
            "omega0": w0,
            "referee_inertia": inertia,  # the referee's and the analytic period's moments
            "periods": periods,
            "records": 50,  # per period T, compared with DOP853
            "steps": {2: (2000, 4000), 4: (500, 1000), 6: (200, 400), 8: (200, 400)},
            "flip_orders": (2, 4),
            "large_dts": large,
            "large_periods": {"quick": 1, "full": 2}[mode],
            "exudyn_nodes": ("euler-parameters", "rotation-vector"),
            # about 3 times the errors measured at the finer step (quick, 2 T: rates 1.30e-3, 5.78e-5, 6.82e-5,
            # 2.06e-6 |w0|; attitude 2.16e-3, 9.23e-5, 1.44e-4, 2.57e-6 rad; full, 6 T: 4.20e-3, 1.86e-4,
            # 1.47e-4, 5.50e-6 |w0|; 6.95e-3, 2.97e-4, 4.37e-4, 7.52e-6 rad)
            "tolerance": {
                "quick": {2: (4e-3, 6.5e-3), 4: (1.8e-4, 2.8e-4), 6: (2e-4, 4.5e-4), 8: (6e-6, 8e-6)},
                "full": {2: (1.3e-2, 2.1e-2), 4: (5.6e-4, 9e-4), 6: (4.5e-4, 1.3e-3), 8: (1.7e-5, 2.3e-5)},
            }[mode],
        },
    )


def cases(mode: str) -> dict[str, BodyCase]:
    """The torque-free case of a mode by name (:func:`~.body_case.build_cases`): ``"quick"`` (2
    periods of the rates, large steps over 1) or ``"full"`` (6 and 2)."""
    return build_cases(mode, _torque_free)


# -- the case's run and checks ----------------------------------------------------------------
class TorqueFreeRun(BodyRun):
    """The runs, checks and measurements of the torque-free case (what the figure reads).

    After :meth:`run`: ``referee`` and ``loose`` (DOP853), ``em_runs`` {(order, steps per
    period): Trajectory}, ``large`` {dt: Trajectory} (em order 2), ``exudyn`` {(node, dt,
    adaptive): Trajectory} (empty without Exudyn), ``jacobi`` (:func:`jacobi_period` of the
    referee's inertia), ``flips`` {(order, steps): interval} and ``convergence``.
    """

    def __init__(self, case, mode, scale, outdir):
        super().__init__(case, mode, scale, outdir)
        s = case.settings
        self.T, self.n = case.period, s["periods"]
        self.times = np.arange(self.n * s["records"] + 1) * (self.T / s["records"])
        self.em_runs: dict = {}
        self.large: dict = {}
        self.exudyn: dict = {}
        self.flips: dict = {}
        self.exudyn_status = None
        self.referee = self.loose = None
        self.jacobi = None

    def main(self, order: int) -> Trajectory:
        """The run at the finer step of an order (the one checked against DOP853)."""
        return self.em_runs[(order, self.case.settings["steps"][order][1])]

    def at_records(self, tr: Trajectory, steps_per_period: int, key: str) -> np.ndarray:
        """An em run's series at the referee's record times."""
        every = steps_per_period // self.case.settings["records"]
        return tr.series[key][::every]

    def run(self):
        """Run the referees, em and Exudyn, and make the checks."""
        c, s = self.case, self.case.settings
        I = np.asarray(s["referee_inertia"], float)
        self.jacobi = jacobi_period(I, s["omega0"])
        t_large = s["large_periods"] * self.T
        t0 = time.perf_counter()
        self.referee = self.add(run_referee(I, s["omega0"], self.times, RTOL, t_end=max(self.times[-1], t_large)))
        self.loose = self.add(run_referee(I, s["omega0"], self.times, RTOL_LOOSE))
        self.timing["referee_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        for p, steps in s["steps"].items():
            for n in steps:
                tr = run_em(c, p, self.T / n, n * self.n, f"em {p}, dt = T/{n}")
                tr.info["steps_per_period"] = n
                self.em_runs[(p, n)] = self.add(tr)
        for dt in s["large_dts"]:
            w = np.linalg.norm(s["omega0"])
            tr = run_em(c, 2, dt, int(round(t_large / dt)), f"em 2, dt = {dt:g} s (w dt = {w * dt:.2g})")
            self.large[dt] = self.add(tr)
        self.timing["em_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        self._run_exudyn(t_large)
        self.timing["exudyn_s"] = time.perf_counter() - t0
        self._same_body()
        self._invariants()
        self._flip()
        self._rates()
        self._referee_checks()
        self._large_steps()

    def _run_exudyn(self, t_large):
        from emorbit.bench.rigid_cases import FREE_BOX, FREE_OMEGA

        s = self.case.settings
        if not s["exudyn_nodes"]:
            self.exudyn_status = "skipped: no Exudyn runs asked for (settings exudyn_nodes is empty)"
            return
        ex, why = exudyn_wrapper()
        if ex is None:
            self.exudyn_status = why
            return
        if list(FREE_BOX["size"]) != list(s["size"]) or tuple(FREE_OMEGA) != tuple(s["omega0"]):
            raise ValueError("the bench's Exudyn box (FREE_BOX, FREE_OMEGA) is not the case's box")
        self.exudyn_status = "ok"
        for node in s["exudyn_nodes"]:
            for dt in s["large_dts"]:
                for adaptive in (True, False):
                    tr = run_exudyn(ex, self.case, node, dt, int(round(t_large / dt)), adaptive)
                    self.exudyn[(node, dt, adaptive)] = self.add(tr)

    # -- the same body ------------------------------------------------------------------------
    def _same_body(self):
        s = self.case.settings
        mine = np.diag(np.asarray(s["referee_inertia"], float))
        theirs = next(iter(self.em_runs.values())).info["inertia"]
        d = float(np.abs(mine - theirs).max() / np.abs(theirs).max())
        self.check(
            "same-body",
            "the referee's principal moments (the box's analytic inertia) against the inertia of emorbit's mass "
            "points (sum m X X^T), max |dI| / max |I|",
            "emorbit's sim.rigid.points[0].inertia",
            d,
            SAME_INERTIA,
            "1",
            "the box's 2 x 2 x 2 Gauss points reproduce its second moments exactly; what remains is the rounding of "
            "8 products and sums (measured 1.9e-18); a referee with another inertia fails",
            f"emorbit's inertia diag {np.diag(theirs).tolist()}, off-diagonal up to "
            f"{np.abs(theirs - np.diag(np.diag(theirs))).max():.2g} kg m2",
        )
        if self.exudyn_status != "ok":
            self.skip(
                "exudyn-same-body",
                "Exudyn's inertia and initial energy and angular momentum against emorbit's",
                "emorbit's",
                self.exudyn_status,
            )
            return
        em = self.large[s["large_dts"][0]]
        worst, detail = 0.0, []
        for tr in self.exudyn.values():
            I = tr.info["inertia"]
            dI = np.abs(I - np.diag(np.diag(em.info["inertia"]))).max() / np.abs(I).max()
            dE = abs(tr.series["energy"][0] - em.series["energy"][0]) / abs(em.series["energy"][0])
            dL = np.linalg.norm(tr.series["L"][0] - em.series["L"][0]) / np.linalg.norm(em.series["L"][0])
            worst = max(worst, float(dI), float(dE), float(dL))
        detail.append(f"E0 = {em.series['energy'][0]:.15g} J, |L0| = {np.linalg.norm(em.series['L'][0]):.15g}")
        self.check(
            "exudyn-same-body",
            "Exudyn's inertia (InertiaCuboid) and its energy and angular momentum at t = 0 against emorbit's, "
            "relative, worst of every Exudyn run",
            "emorbit's",
            worst,
            SAME_START,
            "1",
            "the same box and w0: the same numbers up to a rounding (measured 2.8e-18: E0 bit for bit, L0 within "
            "emorbit's 1e-17 off-diagonal rounding); a different body in Exudyn would make its errors meaningless",
            "; ".join(detail),
        )

    # -- invariants -----------------------------------------------------------------------------
    def _invariants(self):
        per = {"energy": {}, "angular-momentum": {}}
        for tr in list(self.em_runs.values()) + list(self.large.values()):
            dE, dL = relative_errors(tr)
            per["energy"][tr.label] = dE
            per["angular-momentum"][tr.label] = dL
        for key, what in (("energy", "|E - E0| / E0"), ("angular-momentum", "|L - L0| / |L0| (L in space)")):
            vals = per[key]
            worst = max(vals, key=vals.get)
            self.check(
                key,
                f"{what} at every step of every em run (orders 2-8 and the large steps up to w dt = 1)",
                "the initial value",
                vals[worst],
                CONSERVED,
                "1",
                "em's director step keeps the kinetic energy and the angular momentum of a free rigid body exactly "
                "(its constraint forces do no work, Betsch & Steinmann 2001): what remains is round-off, measured at "
                "most 4.3e-15 (energy) and 2.2e-15 (angular momentum); 2.3 times that",
                f"worst: {worst}; " + "; ".join(f"{k}: {v:.2g}" for k, v in vals.items()),
            )

    # -- the flip -------------------------------------------------------------------------------
    def _flip(self):
        s, jac = self.case.settings, self.jacobi
        axis, exact = jac["intermediate"], jac["flip"]
        ref_flips = self.referee.info["flips"]
        dop = mean_interval(ref_flips)
        loose = mean_interval(self.loose.info["flips"])
        self.metric("flip.analytic", exact, "s", f"T/2 = 2 K / rate, K = {jac['K']:.12g}, k'^2 = {jac['k2c']:.6g}")
        self.check(
            "flip-analytic",
            "the analytic flip interval T/2 (Jacobi-elliptic solution) against DOP853's (rtol 1e-13) intervals "
            "between the sign changes of w2 (its event location), relative",
            "DOP853 on Euler's equations",
            abs(dop - exact) / exact,
            DOP853_FLIP * self.n,
            "1",
            "DOP853's own error in the flip interval, which grows with the run: measured 4.5e-13 to 8.9e-13 over 1 T, "
            "6.5e-13 over 2 T, 3.0e-12 over 6 T; 1.5e-12 per T. A wrong formula (a factor, the other regime, K(k) "
            "for K(k')) is off by 1e-6 or more",
            f"analytic {exact:.13g} s, DOP853 {dop:.13g} s ({len(ref_flips)} flips), rtol 1e-11 {loose:.13g} s",
        )
        for p in s["flip_orders"]:
            n1, n2 = s["steps"][p]
            vals = []
            for n in (n1, n2):
                tr = self.em_runs[(p, n)]
                times = flip_times(tr.t, tr.series["w"], axis)
                if times.size != len(ref_flips):
                    raise RuntimeError(f"{tr.label}: {times.size} flips, DOP853 {len(ref_flips)}")
                vals.append(mean_interval(times))
                self.flips[(p, n)] = vals[-1]
            e1, e2 = abs(vals[0] - exact), abs(vals[1] - exact)
            expected = ORDER_REACHED[p]
            observed = math.log(e1 / e2) / math.log(n2 / n1) if e2 > 0 else math.inf
            self.convergence[f"flip-em{p}"] = {
                "steps_per_period": [n1, n2],
                "interval": vals,
                "error": [e1 / exact, e2 / exact],
                "observed": observed,
            }
            self.check(
                f"flip-order-em{p}",
                f"em order {p}: observed order of the flip-interval error against T/2 from T/{n1} and T/{n2}, "
                f"|observed - {expected}|",
                f"order {expected}",
                abs(observed - expected),
                FLIP_ORDER_TOLERANCE.get(p, 0.05),
                "1 (order)",
                "the error of a symmetric method's period falls as dt^p; both errors lie far above the sign changes' "
                "location error (cubic through 4 records) and the formula's; measured deviations 3.1e-5 (order 2) "
                "and 0.012 (order 4), 10 and 4 times less",
                f"errors {e1 / exact:.3g} and {e2 / exact:.3g} (relative); observed {observed:.4f}",
            )
            estimate = abs(C.richardson(vals[1], vals[0], n2 / n1, expected))
            self.check(
                f"flip-em{p}",
                f"em order {p} at T/{n2}: |flip interval - T/2|, relative",
                "the Jacobi-elliptic flip interval T/2",
                e2 / exact,
                C.PERIOD_ALLOWANCE * estimate / exact,
                "1",
                f"the step's discretisation error, estimated from T/{n1} and T/{n2} (Richardson, order {expected}: "
                f"{estimate / exact:.3g}) times {C.PERIOD_ALLOWANCE}: em converges to the analytic interval; an error "
                "in the body or the formula (an inertia 1e-3 off: 2e-4) leaves a gap that does not shrink with dt",
                f"em {vals[1]:.13g} s at T/{n2}, {vals[0]:.13g} s at T/{n1}; T/2 = {exact:.13g} s",
            )
        for p in s["steps"]:
            if p in s["flip_orders"]:
                continue
            tr = self.main(p)
            v = mean_interval(flip_times(tr.t, tr.series["w"], axis))
            self.flips[(p, s["steps"][p][1])] = v
            self.metric(f"flip.em{p}", abs(v - exact) / exact, "1", f"{tr.label}: |flip interval - T/2| / (T/2)")

    # -- rates and attitude against DOP853 ------------------------------------------------------
    def _errors(self, tr, n, ref):
        w0 = np.linalg.norm(self.case.settings["omega0"])
        w = self.at_records(tr, n, "w")
        q = self.at_records(tr, n, "q")
        return np.linalg.norm(w - ref.series["w"], axis=-1) / w0, attitude_error(q, ref.series["q"])

    def _rates(self):
        s, ref = self.case.settings, self.referee
        for p in s["steps"]:
            n1, n2 = s["steps"][p]
            entry = {"steps_per_period": [n1, n2], "rate": [], "attitude": []}
            for n in (n1, n2):
                ew, ea = self._errors(self.em_runs[(p, n)], n, ref)
                entry["rate"].append(float(ew.max()))
                entry["attitude"].append(float(ea.max()))
            expected = ORDER_REACHED[p]
            for kind, errs, unit in (("rate", entry["rate"], "|w0|"), ("attitude", entry["attitude"], "rad")):
                observed = math.log(errs[0] / errs[1]) / math.log(n2 / n1)
                entry[f"observed_{kind}"] = observed
                nominal = "" if expected == p else f" (nominal {p}: emorbit's rigid compositions reach {expected})"
                self.check(
                    f"order-{kind}-em{p}",
                    f"em order {p}: observed order of the {kind} error against DOP853 (max over {self.n} T) from "
                    f"T/{n1} and T/{n2}, |observed - {expected}|{nominal}",
                    f"order {expected}",
                    abs(observed - expected),
                    ORDER_TOLERANCE.get(p, 0.1),
                    "1 (order)",
                    "both errors lie far above DOP853's (the referee checks) and in the asymptotic range; measured "
                    "deviations (rates and attitude, quick and full) up to 1.7e-3, 0.012, 0.038, 9.6e-3 at orders 2, "
                    "4, 6, 8",
                    f"errors {errs[0]:.3g} and {errs[1]:.3g} {unit}; observed {observed:.4f}",
                )
            self.convergence[f"em{p}"] = entry
            tol_w, tol_a = s["tolerance"][p]
            tr = self.main(p)
            for kind, err, tol, unit in (
                ("rate", entry["rate"][1], tol_w, "|w0|"),
                ("attitude", entry["attitude"][1], tol_a, "rad"),
            ):
                self.check(
                    f"{kind}-em{p}",
                    f"{tr.label}: {'|w - w_DOP853| / |w0|' if kind == 'rate' else 'rotation angle to DOP853'}, max "
                    f"over {self.n} T ({s['records']} records per T)",
                    f"DOP853 (rtol {RTOL:g}) on Euler's equations and the quaternion",
                    err,
                    tol,
                    unit,
                    f"about 3 times the error measured at this step ({self.mode} mode): it guards the accuracy "
                    "reached; near the separatrix a small error in the body or its start shifts the flips by far more",
                )

    def _referee_checks(self):
        ref, loose = self.referee, self.loose
        w0 = np.linalg.norm(self.case.settings["omega0"])
        for kind, err, unit in (
            ("rate", np.linalg.norm(loose.series["w"] - ref.series["w"], axis=-1) / w0, "|w0|"),
            ("attitude", attitude_error(loose.series["q"], ref.series["q"]), "rad"),
        ):
            smallest = min(min(e[kind]) for k, e in self.convergence.items() if k.startswith("em"))
            self.check(
                f"referee-{kind}",
                f"DOP853 at rtol {RTOL_LOOSE:g} against rtol {RTOL:g}: {kind}, max over {self.n} T (bounds the "
                f"error of the rtol {RTOL:g} solve from above)",
                f"{C.REFEREE_FRACTION:g} of the smallest em {kind} error compared",
                float(err.max()),
                C.REFEREE_FRACTION * smallest,
                unit,
                f"a referee may use at most {C.REFEREE_FRACTION:g} of what it referees (smallest em error "
                f"{smallest:.3g} {unit})",
                f"{ref.info['nfev']} and {loose.info['nfev']} evaluations",
            )
        for tr in (ref, loose):
            dE, dL = relative_errors(tr)
            self.metric(f"dop853.rtol{tr.info['rtol']:g}.energy", dE, "1", f"{tr.label}: max |E - E0| / E0 (drifts)")
            self.metric(f"dop853.rtol{tr.info['rtol']:g}.angular_momentum", dL, "1", f"{tr.label}: |L - L0| / |L0|")
            self.metric(
                f"dop853.rtol{tr.info['rtol']:g}.quaternion_norm_drift",
                tr.info["quaternion_norm_drift"],
                "1",
                f"{tr.label}: max | |q| - 1 | (not renormalised)",
            )

    # -- large steps: emorbit beside Exudyn -----------------------------------------------------
    def _omega_at_end(self, tr):
        w0 = np.linalg.norm(self.case.settings["omega0"])
        t_end = float(tr.t[-1])
        ref = self.referee.info["sol"](t_end)[4:]
        return float(np.linalg.norm(tr.series["w"][-1] - ref) / w0), t_end

    def _large_steps(self):
        s = self.case.settings
        w0 = float(np.linalg.norm(s["omega0"]))
        rows = []
        for dt, tr in self.large.items():
            dE, dL = relative_errors(tr)
            ew, t_end = self._omega_at_end(tr)
            rows.append(
                {
                    "dt_s": dt,
                    "w_dt": w0 * dt,
                    "energy": dE,
                    "angular_momentum": dL,
                    "rate_error_end": ew,
                    "t_end": t_end,
                }
            )
        self.metric(
            "large_steps.em2",
            rows,
            "1",
            "em order 2: max |E - E0| / E0, max |L - L0| / |L0| over every step, and |w - w_DOP853| / |w0| at the end",
        )
        self.check(
            "large-step-invariants",
            "em order 2 at w dt = " + ", ".join(f"{r['w_dt']:.2g}" for r in rows) + ": the larger of max |E - E0| / "
            "E0 and max |L - L0| / |L0| over every step",
            "round-off",
            max(max(r["energy"], r["angular_momentum"]) for r in rows),
            CONSERVED,
            "1",
            "exact conservation for any step (Betsch & Steinmann 2001): round-off, measured at most 2.2e-15 at "
            "these steps; Exudyn's generalized-alpha at the same steps loses 6e-4 to 5 of its energy",
            "; ".join(f"dt {r['dt_s']:g} s: {r['energy']:.2g}, {r['angular_momentum']:.2g}" for r in rows),
        )
        if self.exudyn_status != "ok":
            self.metric("exudyn", self.exudyn_status, "", "Exudyn's part did not run")
            return
        rows = []
        for (node, dt, adaptive), tr in self.exudyn.items():
            dE, dL = relative_errors(tr)
            row = {
                "node": node,
                "dt_s": dt,
                "w_dt": w0 * dt,
                "step_reduction": adaptive,
                "converged": tr.info["converged"],
                "t_reached": tr.info["t_reached"],
                "steps": tr.info["steps"],
                "min_step_s": tr.info["min_step_s"],
                "energy": dE,
                "angular_momentum": dL,
            }
            if tr.info["converged"]:
                row["rate_error_end"] = self._omega_at_end(tr)[0]
            rows.append(row)
        self.metrics["exudyn"] = {
            "value": rows,
            "unit": "1",
            "note": (
                f"Exudyn {exudyn_version()} generalized-alpha (spectral radius "
                f"{next(iter(self.exudyn.values())).info['spectral_radius']:g}): max |E - E0| / E0 and max |L - L0| / "
                "|L0| over the steps it took (a failed run: up to where it stopped), |w - w_DOP853| / |w0| at the end; "
                "step_reduction: Exudyn's default, which shortens a step whose Newton iteration fails"
            ),
        }
        failed = [r for r in rows if not r["converged"]]
        self.metric(
            "exudyn.newton_failures",
            "; ".join(f"{r['node']} dt {r['dt_s']:g} s stopped at t = {r['t_reached']:g} s" for r in failed) or "none",
            "",
            "generalized-alpha runs at a fixed step whose Newton iteration failed",
        )


def run(case: BodyCase, mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True):
    """Run the torque-free case and return its outcome (:func:`~.runner.body_outcome`; the figure
    ``torque-free.png``)."""
    from .runner import body_outcome

    s = case.settings
    steps = "; ".join(f"order {p}: T/{n1}, T/{n2}" for p, (n1, n2) in s["steps"].items())
    return body_outcome(
        case,
        mode,
        outdir,
        lambda: TorqueFreeRun(case, mode, scale, outdir),
        _draw,
        figures=figures,
        drop=("sol", "inertia", "flips"),
        summary=f"em runs {s['periods']} periods T = {case.period:.10g} s at {steps}, recorded at every step; DOP853 "
        f"at rtol {RTOL:g} and {RTOL_LOOSE:g}, {s['records']} records per T; em order 2 and Exudyn at dt = "
        + ", ".join(f"{dt:g}" for dt in s["large_dts"])
        + f" s over {s['large_periods']} T.",
        steps_per_period=s["steps"][2][1],
    )


def _draw(r, outdir):  # matplotlib is imported only where figures are drawn
    from .torque_free_figures import torque_free_figure

    return torque_free_figure(r, outdir)
