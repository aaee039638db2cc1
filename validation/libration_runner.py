"""The runs and checks of the libration cases (:mod:`.libration`): em at T/500 and T/1000 and
Basilisk at 1 s and 2 s on the same starts, the periods and frequencies measured from their
records, and the checks against the theory, against Basilisk and of the invariants (what the
figures of :mod:`.libration_figures` read).

em runs at T/500 and T/1000 (order 4): the difference is em's discretisation error
(Richardson, order 4), from which the tolerances of the comparisons at T/500 follow; em's error
there (2e-8 relative) lies far above the measurement's (the crossings' fit: standard errors of
at most 3.4e-10 relative, at 0.57 degrees; the frequency fits: 1e-9).

Basilisk's pitch series is compared with emorbit's at emorbit's record times (a cubic spline
through Basilisk's 1 s records), its pitch period and roll-yaw frequencies measured as
emorbit's. emorbit's volume torque (its field's acceleration summed over its mass points) at the
start tends to Basilisk's as the body grows from 2 m to size / r = 0.005, 0.01, 0.02 like
(size / r)^2, and emorbit's pitch period tends to the pendulum's alike. Without Basilisk these
checks are skipped ("skipped: Basilisk not installed") and the cases pass.

em's energy E and angular momentum L about the Earth's centre are checked at round-off relative
to the terms that cancel, and K = E - n L_z (:func:`~.libration_referees.attitude_invariant`:
E cannot resolve the attitude, whose share of it is 1e-14) relative to its own terms.
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import checks as C
from .body_case import BodyCase, BodyRun, Trajectory
from .libration_referees import (
    amplitude_key,
    basilisk_missing,
    em_torque,
    fit_modes,
    libration_period,
    orbit_rate,
    pendulum_period,
    pitch_frequency,
    referee_inertia,
    roll_yaw_frequencies,
    run_basilisk,
    run_em,
)

__all__ = ["ORDER", "LibrationRun", "PitchRun", "RollYawRun"]

#: em's order (emorbit's rigid compositions of orders 6 and 8 reach order 4: no gain)
ORDER = 4
#: a comparison at T/500 may deviate by this many times em's own error there (Richardson from
#: T/500 and T/1000; em's error dominates the measurement's there)
ALLOWANCE = 3.0

# -- the runs and checks ---------------------------------------------------------------------------------
#: |E - E0| / (T + |V|) and |L - L0| / (sum m |x| |v| + |I w|) of every em run, by mode: measured
#: at most 4.9e-16 and 4.4e-16 (pitch) and 6.7e-16 and 8.9e-16 (roll-yaw) in quick mode, 9.4e-16 and
#: 1.0e-15 (pitch) and 1.4e-15 and 1.9e-15 (roll-yaw) in full mode: the round-off of 1500 to 20000 steps
CONSERVED = {"quick": 4e-15, "full": 8e-15}
#: |K - K0| / (sum of |K's terms|) of the em runs of the 2 m box, by case: measured at most 6.0e-10
#: (quick) and 8.4e-10 (full) in pitch (up to 60 degrees), 6.9e-13 and 1.3e-12 in roll-yaw
#: (offsets of 4e-3 rad): what is left of em's exactness 1e14 times below the orbit's energy
ATTITUDE_INVARIANT = {"libration-pitch": 3e-9, "libration-roll-yaw": 5e-12}
#: the roll-yaw frequencies at zero offset, beyond em's error: the eps^4 remainder of the
#: extrapolation (6e-10: measured from offsets of 4e-3 and 8e-3 rad, 16 times larger) and the
#: fits' scatter (1e-9: the zero-offset values at T/1000, where em's error is 16 times smaller)
FIT_FLOOR = 2e-9
#: the referee's analytic inertia against the inertia of emorbit's 8 mass points, relative to
#: the largest moment: measured 6.8e-17 (the rounding of the products m X X^T of the Gauss points)
SAME_INERTIA = 5e-16
#: emorbit's volume torque at the start of the 2 m box against Basilisk's first-order torque,
#: relative: the multipole terms (size / r)^2 = 8e-14 lie below the sum's round-off (each
#: point's torque m_i g s is r / s = 3.5e6 times the gradient torque: eps r / s = 8e-10);
#: measured 9.8e-10
SMALL_TORQUE = 5e-9
#: |slope - 2| of log(torque difference) against log(size / r) at 0.005, 0.01, 0.02: the next
#: even multipole term, relative (size / r)^2, bends it; measured 2.4e-6 and 1.0e-5 (four times,
#: as such a term does)
TORQUE_SLOPE = 5e-5


class LibrationRun(BodyRun):
    """What both libration cases share: em runs, Basilisk runs, the inertia and invariant checks."""

    def __init__(self, case: BodyCase, mode: str, scale: float, outdir: str):
        super().__init__(case, mode, scale, outdir)
        s = case.settings
        self.s = s
        self.n = orbit_rate(s["gm"], s["radius"])
        self.T = 2 * math.pi / self.n
        self.inertia = referee_inertia(s["size"], s["density"])  # the referee's
        self.basilisk = basilisk_missing()
        self.em: dict = {}  # (key, steps) -> Trajectory
        self.bsk: dict = {}  # (key, dt) -> Trajectory
        self.series_difference: dict = {}  # key -> (t, |pitch_em - pitch_Basilisk| / theta0, em's error / theta0)

    def em_run(self, key, rotation_vector, steps, orbits=None, **other) -> Trajectory:
        """Run em once and keep it under (key, steps)."""
        label = f"em {ORDER} T/{steps} {key}"
        tr = self.add(run_em(label, self.s, rotation_vector, steps, orbits or self.s["orbits"], **other))
        self.em[(key, steps)] = tr
        return tr

    def basilisk_run(self, key, rotation_vector, dt, t_end, record_dt=None, inertia=None, mass=None):
        """Run Basilisk once and keep it under (key, dt)."""
        tr = run_basilisk(
            f"Basilisk RK4 {dt:g} s {key}",
            self.inertia if inertia is None else inertia,
            self.s["mass"] if mass is None else mass,
            self.s["gm"],
            self.s["radius"],
            rotation_vector,
            dt,
            t_end,
            record_dt,
        )
        self.bsk[(key, dt)] = self.add(tr)
        return tr

    def same_inertia(self):
        """The referee's analytic inertia against emorbit's mass points."""
        pts = next(iter(self.em.values())).info["points"]
        I = pts.inertia
        d = float(np.abs(I - self.inertia).max() / np.abs(self.inertia).max())
        self.check(
            "same-inertia",
            "the referee's inertia (the analytic box, m/12 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2)) against the "
            "inertia of emorbit's 8 mass points (tr E - E, E = sum m X X^T), max |difference| / largest moment",
            "emorbit's sim.rigid.points[0].inertia",
            d,
            SAME_INERTIA,
            "1",
            "the box's 2-point Gauss rule integrates second moments exactly: only the rounding of the products "
            "remains (measured 6.8e-17); a wrong moment in the theory or in Basilisk shows here",
            f"emorbit diag {np.diag(I).tolist()}, referee diag {np.diag(self.inertia).tolist()} kg m2",
        )

    def invariants(self, small_keys):
        """Energy and angular momentum of every em run, K of the runs of the case's box."""
        for key, what in (
            ("energy", "|E - E0| / (T + |V|)"),
            ("angular-momentum", "|L - L0| / (sum m |x| |v| + |I w|) (about the Earth's centre)"),
        ):
            vals = {tr.label: float(tr.series[key.replace("-", "_")].max()) for tr in self.em.values()}
            worst = max(vals, key=vals.get)
            self.check(
                key,
                f"{what}, worst over every step of every em run",
                "the initial value",
                vals[worst],
                CONSERVED[self.mode],
                "1",
                "em's gravity over the mass points does work equal to the drop of its potential and its director "
                "constraints do none: E and L are exact up to round-off relative to the terms that cancel "
                "(measured at most 4.9e-16 to 1.9e-15 by case and mode; 4 to 9 times that)",
                f"worst: {worst}; " + "; ".join(f"{k}: {v:.2g}" for k, v in vals.items()),
            )
        vals = {tr.label: float(tr.series["K"].max()) for (k, _), tr in self.em.items() if k in small_keys}
        worst = max(vals, key=vals.get)
        self.check(
            "attitude-invariant",
            "|K - K0| / (sum of |K's terms|), K = E - n L_z without the orbit's cancelling terms (the module's "
            "docstring), worst over every step of the runs of the 2 m box",
            "the initial value",
            vals[worst],
            ATTITUDE_INVARIANT[self.case.name],
            "1",
            "K is conserved because E and L are, but it is 1e-14 of T + |V|: em's exactness at the orbit's "
            "round-off leaves K a drift, measured at most 8.4e-10 at pitch amplitudes up to 60 deg and 1.3e-12 at "
            "roll-yaw offsets of 4e-3 rad (em's Newton iteration stops at the round-off of its mass-weighted "
            "increments, which the centre's motion dominates, and each point's force is r / size = 3.5e6 times its "
            "share of the torque); a torque that did work would move K by its own size",
            "; ".join(f"{k}: {v:.2g}" for k, v in vals.items()),
        )

    def skip_basilisk(self, ids):
        """Skip the Basilisk checks ``ids`` (Basilisk not installed)."""
        for id_ in ids:
            self.skip(id_, "against Basilisk", "Basilisk (bsk)", self.basilisk)


class PitchRun(LibrationRun):
    """The runs, checks and measurements of ``libration-pitch`` (what its figure reads)."""

    def run(self):
        """The em runs at every amplitude and both steps, the grown boxes, Basilisk, and the checks."""
        s = self.s
        D = s["steps"]
        t0 = time.perf_counter()
        for a in s["amplitudes"]:
            for steps in (D, 2 * D):
                self.em_run(amplitude_key(a), (0.0, 0.0, a), steps)
        self.timing["em_s"] = time.perf_counter() - t0
        self.periods = {}  # amplitude key -> (Period at T/D, Period at T/2D)
        for a in s["amplitudes"]:
            key = amplitude_key(a)
            self.periods[key] = tuple(libration_period(tr.t, tr.series["angles"][:, 2]) for tr in self._pair(key))
        self.same_inertia()
        self._linear()
        self._pendulum()
        t0 = time.perf_counter()
        self._sizes()
        self.timing["sizes_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        self._basilisk()
        self.timing["basilisk_s"] = time.perf_counter() - t0
        self.invariants({amplitude_key(a) for a in s["amplitudes"]})

    def _pair(self, key):
        D = self.s["steps"]
        return self.em[(key, D)], self.em[(key, 2 * D)]

    def em_error(self, a) -> float:
        """em's relative period error at T/D for amplitude ``a`` (Richardson from T/D and T/2D)."""
        p1, p2 = self.periods[amplitude_key(a)]
        return abs(C.richardson(p1.value, p2.value, 0.5, ORDER)) / p1.value

    def _linear(self):
        s, n = self.s, self.n
        a = s["linear"]
        w_lin = pitch_frequency(n, self.inertia)
        p = self.periods[amplitude_key(a)][0]
        w_em = 2 * math.pi / p.value
        value = abs(w_em / w_lin - 1)
        from scipy.special import ellipk

        truncation = 1 - math.pi / (2 * float(ellipk(math.sin(a) ** 2)))
        err = self.em_error(a)
        sigma = p.sigma / p.value
        self.metric("pitch.linear.frequency_over_n", w_em / n, "n", f"em at T/{s['steps']}, theta0 = {a:g} rad")
        self.check(
            "pitch-linear",
            f"em at T/{s['steps']}, theta0 = {a:g} rad: |w_pitch - n sqrt(3 (I_roll - I_yaw) / I_pitch)| / w_pitch "
            f"over {s['orbits']} T ({p.events} zero crossings of the pitch angle)",
            "linear theory (Hughes 1986, ch. 9)",
            value,
            truncation + C.PERIOD_ALLOWANCE * err + C.SIGMAS * sigma,
            "1",
            "the linear theory's truncation, the pendulum's amplitude correction 1 - pi / (2 K(sin theta0)) = "
            f"{truncation:.4g} (theta0^2 / 4 to leading order), plus {C.PERIOD_ALLOWANCE:g} times em's own error at "
            f"this step (Richardson from T/{s['steps']} and T/{2 * s['steps']}: {err:.2g}) and {C.SIGMAS:g} standard "
            f"errors of the crossings' fit ({sigma:.2g}); an inertia 1e-3 off moves w_pitch by 5e-4",
            f"w_em / w_lin - 1 = {w_em / w_lin - 1:.6g}; w_lin = {w_lin / n:.10g} n",
        )

    def _pendulum(self):
        s, n = self.s, self.n
        rows = []
        for a in s["amplitudes"]:
            p1, p2 = self.periods[amplitude_key(a)]
            theory = pendulum_period(n, self.inertia, a)
            value = abs(p1.value / theory - 1)
            err = self.em_error(a)
            sigma = p1.sigma / p1.value
            deg = math.degrees(a)
            rows.append(
                {
                    "amplitude_deg": deg,
                    "theory_s": theory,
                    "em_s": [p1.value, p2.value],
                    "error": [p1.value / theory - 1, p2.value / theory - 1],
                    "richardson": err,
                    "sigma": sigma,
                    "crossings": p1.events,
                }
            )
            self.check(
                f"pitch-period-{deg:.4g}deg",
                f"em at T/{s['steps']}, theta0 = {deg:.4g} deg: |P - 4 K(sin theta0) / w_pitch| / P over "
                f"{s['orbits']} T ({p1.events} zero crossings)",
                "the pendulum in 2 theta (Landau & Lifshitz sec. 11; scipy.special.ellipk)",
                value,
                C.PERIOD_ALLOWANCE * err + C.SIGMAS * sigma + 1e-13,
                "1",
                f"{C.PERIOD_ALLOWANCE:g} times em's own error at this step (Richardson from T/{s['steps']} and "
                f"T/{2 * s['steps']}: {err:.2g}), {C.SIGMAS:g} standard errors of the crossings' fit ({sigma:.2g}) and "
                "the theory's truncation, (size / r)^2 = 1e-13 (the torque's and the orbit's next terms): em "
                "converges to the pendulum; an inertia 1e-3 off moves the period by 5e-4",
                f"P = {p1.value:.12g} s at T/{s['steps']}, {p2.value:.12g} s at T/{2 * s['steps']}, theory "
                f"{theory:.12g} s; at T/{2 * s['steps']}: {abs(p2.value / theory - 1):.2g}",
            )
        self.convergence["pendulum"] = rows

    def _sizes(self):
        """The grown boxes: emorbit's torque and period against the first-order model."""
        s, n = self.s, self.n
        a = s["size_amplitude"]
        theory = pendulum_period(n, self.inertia, a)  # size-independent: the moments scale together
        if amplitude_key(a) not in self.periods or s["size_steps"] != 2 * s["steps"]:
            raise ValueError("settings: size_amplitude must be one of the amplitudes and size_steps twice steps")
        rows = []
        for ratio in s["sizes"]:
            ell = ratio * s["radius"]
            size = [ell, ell / 2, ell / 4]
            tr = self.em_run(f"size {ratio:g}", (0.0, 0.0, a), s["size_steps"], s["size_orbits"], size=size, mass=500.0)
            pts = tr.info["points"]
            p = libration_period(tr.t, tr.series["angles"][:, 2])
            rows.append(
                {
                    "size_over_r": ratio,
                    "edge_m": ell,
                    "torque": em_torque(tr),
                    "period": p.value,
                    "inertia": pts.inertia,
                }
            )
        period_rel = np.array([r["period"] / theory - 1 for r in rows])
        ratios = np.array(s["sizes"])
        if not np.allclose(ratios[1:] / ratios[:-1], 2.0):
            raise ValueError(f"settings['sizes'] must double from one to the next, got {s['sizes']!r}")
        slopes = np.diff(np.log(np.abs(period_rel))) / np.diff(np.log(ratios))
        # the next term, relative B (size / r)^2, shifts a pair's slope by B (r2^2 - r1^2) / ln 2: 3 and 12 r1^2
        # for doubling sizes, so (4 s1 - s2) / 3 removes it (Richardson in (size / r)^2)
        limit = (4 * slopes[0] - slopes[1]) / 3
        em_err = self.em_error(a) / 16  # at T/2D: em's error at T/D over 2^4
        # an error e at each size moves log |dP| by e / |dP|: the pairs' slopes by at most (1 + 1/4) and
        # (1/4 + 1/16) times e / (|dP_1| ln 2), their extrapolation by (4 * 1.25 + 0.3125) / 3 = 1.77 times
        shift = C.PERIOD_ALLOWANCE * 1.77 * em_err / abs(period_rel[0]) / math.log(2)
        self.sizes = rows
        self.size_slopes = {"period": slopes.tolist(), "period_limit": limit}
        for row, v in zip(rows, period_rel):
            row["period_relative"] = float(v)
        self.metric(
            "sizes.period",
            [{"size / r": r["size_over_r"], "P / P_pendulum - 1": r["period_relative"]} for r in rows],
            "1",
            f"em at T/{s['size_steps']}, theta0 = 30 deg, against the pendulum's period",
        )
        self.check(
            "size-period-slope",
            "emorbit's pitch period at theta0 = 30 deg of the box grown to size / r = "
            + ", ".join(f"{r:g}" for r in ratios)
            + f" (em at T/{s['size_steps']}): |slope - 2| of log |P / P_pendulum - 1| against log(size / r), the "
            "slopes of the two pairs extrapolated to zero size, (4 s1 - s2) / 3",
            "(size / r)^2: the first-order (pendulum) period as the box shrinks",
            abs(limit - 2),
            shift,
            "1 (slope)",
            "the mass points' torque and orbit differ from the first-order model by terms (size / r)^2 (the box is "
            "centrally symmetric); the next, relative B (size / r)^2, bends the pairs' slopes (here B = "
            f"{(slopes[1] - slopes[0]) * math.log(2) / (9 * ratios[0] ** 2):.3g}) and the extrapolation removes it; "
            f"what is left is em's error at T/{s['size_steps']} ({em_err:.2g} relative, measured on the 2 m box at "
            f"the same amplitude and step), times {C.PERIOD_ALLOWANCE:g}, carried through the logarithms and the "
            "extrapolation (at most 1.77 e / (|P_1 / P - 1| ln 2))",
            "P / P_pendulum - 1 = "
            + ", ".join(f"{v:.6g}" for v in period_rel)
            + "; pair slopes "
            + ", ".join(f"{v:.6f}" for v in slopes)
            + f"; extrapolated {limit:.6f}",
        )

    def _basilisk(self):
        s = self.s
        ids_series = [f"basilisk-series-{math.degrees(a):.4g}deg" for a in s["basilisk_amplitudes"]]
        ids_period = [f"basilisk-period-{math.degrees(a):.4g}deg" for a in s["basilisk_amplitudes"]]
        if self.basilisk:
            self.skip_basilisk(["basilisk-torque", *ids_series, *ids_period, "size-torque-slope"])
            return
        # the start of the 2 m box: the torques
        a0 = s["basilisk_amplitudes"][-1]
        key0 = amplitude_key(a0)
        tau_em = em_torque(self.em[(key0, s["steps"])])
        T = self.T
        for a in s["basilisk_amplitudes"]:
            key = amplitude_key(a)
            for dt in s["basilisk_dts"]:
                self.basilisk_run(key, (0.0, 0.0, a), dt, s["orbits"] * T)
        bt = self.bsk[(key0, s["basilisk_dts"][0])].series["torque0"]
        d = float(np.linalg.norm(tau_em - bt) / np.linalg.norm(bt))
        self.check(
            "basilisk-torque",
            f"the 2 m box at theta0 = {math.degrees(a0):.4g} deg, t = 0: |tau_emorbit - tau_Basilisk| / |tau_Basilisk| "
            "(emorbit's field summed over its mass points; Basilisk's GravityGradientEffector)",
            "Basilisk's first-order gravity-gradient torque 3 GM / r^3 c x I c",
            d,
            SMALL_TORQUE,
            "1",
            "the multipole terms beyond the first, (size / r)^2 = 8e-14, lie below the round-off of the sum over "
            "the mass points (eps r / size = 8e-10: each point's torque is r / size times the gradient torque); "
            "measured 9.8e-10",
            f"emorbit {tau_em.tolist()} N m, Basilisk {bt.tolist()} N m",
        )
        for a, id_s, id_p in zip(s["basilisk_amplitudes"], ids_series, ids_period):
            self._basilisk_pitch(a, id_s, id_p)
        self._torque_slope()

    def _basilisk_pitch(self, a, id_series, id_period):
        from scipy.interpolate import CubicSpline

        s = self.s
        D, (dt1, dt2) = s["steps"], s["basilisk_dts"]
        key = amplitude_key(a)
        e1, e2 = self._pair(key)
        b1, b2 = self.bsk[(key, dt1)], self.bsk[(key, dt2)]
        th_b1 = CubicSpline(b1.t, b1.series["angles"][:, 2])(e1.t)
        th_b2 = CubicSpline(b2.t, b2.series["angles"][:, 2])(e1.t)
        th_e1, th_e2 = e1.series["angles"][:, 2], e2.series["angles"][::2, 2]
        diff = np.abs(th_e1 - th_b1) / a
        em_err = np.abs(th_e1 - th_e2) * 16 / 15 / a
        bsk_err = np.abs(th_b1 - th_b2) / 15 / a
        tol = C.PERIOD_ALLOWANCE * float(em_err.max()) + C.PERIOD_ALLOWANCE * float(bsk_err.max()) + 1e-12
        self.series_difference[key] = (e1.t, diff, em_err)
        self.check(
            id_series,
            f"theta0 = {math.degrees(a):.4g} deg: max |pitch_em - pitch_Basilisk| / theta0 over {s['orbits']} T (em "
            f"at T/{D}, its records; Basilisk RK4 at {dt1:g} s through a cubic spline)",
            "Basilisk's pitch angle",
            float(diff.max()),
            tol,
            "1 (of theta0)",
            f"{C.PERIOD_ALLOWANCE:g} times em's own error at T/{D} (Richardson from T/{D} and T/{2 * D}: "
            f"{em_err.max():.2g}) and Basilisk's at {dt1:g} s (from {dt1:g} and {dt2:g} s: {bsk_err.max():.2g}); the "
            "first-order torque's truncation (size / r)^2 = 1e-13 and the spline's error ((w h)^4 / 384 = 1e-14) "
            "lie below",
            f"at the end: {diff[-1]:.3g}",
        )
        pe = self.periods[key][0]
        pb1, pb2 = (libration_period(b.t, b.series["angles"][:, 2]) for b in (b1, b2))
        berr = abs(C.richardson(pb1.value, pb2.value, dt2 / dt1, 4)) / pb1.value
        tol = C.PERIOD_ALLOWANCE * (self.em_error(a) + berr) + C.SIGMAS * math.hypot(
            pe.sigma / pe.value, pb1.sigma / pb1.value
        )
        self.check(
            id_period,
            f"theta0 = {math.degrees(a):.4g} deg: |P_em / P_Basilisk - 1| (em at T/{D}, Basilisk RK4 at {dt1:g} s, "
            "both from zero crossings)",
            "Basilisk's pitch period",
            abs(pe.value / pb1.value - 1),
            tol,
            "1",
            f"{C.PERIOD_ALLOWANCE:g} times the two discretisation errors (em {self.em_error(a):.2g}, Basilisk "
            f"{berr:.2g}, Richardson) and {C.SIGMAS:g} standard errors of the two crossing fits",
            f"P_em = {pe.value:.12g} s, P_Basilisk = {pb1.value:.12g} s ({dt1:g} s), {pb2.value:.12g} s ({dt2:g} s)",
        )
        self.metric(
            f"basilisk.{math.degrees(a):.4g}deg.period_vs_pendulum",
            pb1.value / pendulum_period(self.n, self.inertia, a) - 1,
            "1",
            "Basilisk's pitch period against the pendulum's (its model is first order: they agree to its error)",
        )

    def _torque_slope(self):
        s = self.s
        a = s["size_amplitude"]
        rel = []
        for row in self.sizes:
            bt = self.basilisk_run(
                f"size {row['size_over_r']:g}", (0.0, 0.0, a), s["basilisk_dts"][0], 0.0, inertia=row["inertia"],
                mass=500.0,
            ).series["torque0"]  # fmt: skip
            row["basilisk_torque"] = bt
            rel.append(float(np.linalg.norm(row["torque"] - bt) / np.linalg.norm(bt)))
        ratios = np.array(s["sizes"])
        slopes = np.diff(np.log(rel)) / np.diff(np.log(ratios))
        for row, v in zip(self.sizes, rel):
            row["torque_relative"] = v
        self.metric(
            "sizes.torque",
            [{"size / r": r["size_over_r"], "relative difference": r["torque_relative"]} for r in self.sizes],
            "1",
            "|tau_emorbit - tau_Basilisk| / |tau_Basilisk| at t = 0, theta0 = 30 deg",
        )
        self.check(
            "size-torque-slope",
            "the box grown to size / r = "
            + ", ".join(f"{r:g}" for r in ratios)
            + " at theta0 = 30 deg, t = 0: the larger |slope - 2| of log |tau_emorbit - tau_Basilisk| / "
            "|tau_Basilisk| against log(size / r)",
            "(size / r)^2: emorbit's mass-point torque tends to Basilisk's first-order torque",
            float(np.abs(slopes - 2).max()),
            TORQUE_SLOPE,
            "1 (slope)",
            "the difference is the multipole series beyond the first term: (size / r)^2 for a centrally symmetric "
            "body, bent by the next term, relative (size / r)^2 (measured 2.4e-6 and 1.0e-5, four times apart as "
            "such a term is)",
            "relative differences "
            + ", ".join(f"{v:.6g}" for v in rel)
            + "; slopes "
            + ", ".join(f"{v:.8f}" for v in slopes),
        )


class RollYawRun(LibrationRun):
    """The runs, checks and measurements of ``libration-roll-yaw`` (what its figure reads)."""

    def run(self):
        """The em runs at both offsets and steps, their frequency fits, Basilisk, and the checks."""
        s, n = self.s, self.n
        D = s["steps"]
        t0 = time.perf_counter()
        for eps in s["offsets"]:
            for steps in (D, 2 * D):
                self.em_run(f"eps {eps:g}", (eps, eps, 0.0), steps)
        self.timing["em_s"] = time.perf_counter() - t0
        self.theory = roll_yaw_frequencies(n, self.inertia)
        self.fits = {}
        for (key, steps), tr in self.em.items():
            ang = tr.series["angles"]
            eps = tr.info["rotation_vector"][0]
            self.fits[(key, steps)] = fit_modes(tr.t, [ang[:, 1] / eps, ang[:, 0] / eps])
        self.same_inertia()
        self._modes()
        t0 = time.perf_counter()
        self._basilisk()
        self.timing["basilisk_s"] = time.perf_counter() - t0
        self.invariants({f"eps {e:g}" for e in s["offsets"]})

    def zero_amplitude(self, steps):
        """The frequencies at ``steps`` extrapolated to eps = 0, their standard errors and the eps^2 term."""
        e1, e2 = self.s["offsets"]
        (f1, s1, _), (f2, s2, _) = self.fits[(f"eps {e1:g}", steps)], self.fits[(f"eps {e2:g}", steps)]
        q = (e2 / e1) ** 2
        return (q * f1 - f2) / (q - 1), np.hypot(q * s1, s2) / (q - 1), (f2 - f1) / (q - 1)

    def _modes(self):
        s, n = self.s, self.n
        D = s["steps"]
        w_lin = np.array([self.theory["fast"], self.theory["slow"]])
        f1, sig1, amp1 = self.zero_amplitude(D)
        f2 = self.zero_amplitude(2 * D)[0]
        err = np.abs(C.richardson(f1, f2, 0.5, ORDER))
        rows = {}
        for k, mode in enumerate(("fast", "slow")):
            value = abs(f1[k] / w_lin[k] - 1)
            rows[mode] = {
                "theory_n": w_lin[k] / n,
                "em_n": [f1[k] / n, f2[k] / n],
                "error": [f1[k] / w_lin[k] - 1, f2[k] / w_lin[k] - 1],
                "richardson": float(err[k] / w_lin[k]),
                "amplitude_term": float(amp1[k] / w_lin[k]),
                "per_offset": {
                    key: float(fit[0][k] / w_lin[k] - 1) for (key, steps), fit in self.fits.items() if steps == D
                },
            }
            self.check(
                f"roll-yaw-{mode}",
                f"em at T/{D}: the {mode} roll-yaw frequency fitted to roll and yaw over {s['orbits']} T, extrapolated "
                f"to zero offset from eps = {s['offsets'][0]:g} and {s['offsets'][1]:g} rad, |w / w_linear - 1|",
                "the characteristic equation of the linearised roll-yaw equations (Hughes 1986, ch. 9)",
                value,
                ALLOWANCE * err[k] / w_lin[k] + FIT_FLOOR,
                "1",
                f"{ALLOWANCE:g} times em's own error at this step (Richardson from T/{D} and T/{2 * D}: "
                f"{err[k] / w_lin[k]:.2g}) and {FIT_FLOOR:g} for the rest: the offsets' eps^2 term "
                f"({amp1[k] / w_lin[k]:.2g} at eps = {s['offsets'][0]:g}) is removed, its eps^4 remainder (6e-10, "
                "measured from offsets 16 times larger) and the fits' scatter (1e-9, the zero-offset values at "
                f"T/{2 * D}) stay; the fits' formal standard errors ({sig1[k] / w_lin[k]:.2g}) measure the "
                "offset's harmonics in the residual, not noise; an inertia 1e-3 off moves the frequencies by 3e-4",
                f"w = {f1[k] / n:.10g} n at T/{D}, {f2[k] / n:.10g} n at T/{2 * D}; theory {w_lin[k] / n:.10g} n",
            )
        self.convergence["modes"] = rows

    def _basilisk(self):
        s, n = self.s, self.n
        ids = ["basilisk-roll-yaw-fast", "basilisk-roll-yaw-slow"]
        if self.basilisk:
            self.skip_basilisk(ids)
            return
        eps = s["offsets"][0]
        key = f"eps {eps:g}"
        fits = {}
        for dt in s["basilisk_dts"]:
            tr = self.basilisk_run(key, (eps, eps, 0.0), dt, s["orbits"] * self.T, s["basilisk_record"])
            ang = tr.series["angles"]
            fits[dt] = fit_modes(tr.t, [ang[:, 1] / eps, ang[:, 0] / eps])
        dt1, dt2 = s["basilisk_dts"]
        D = s["steps"]
        fe = self.fits[(key, D)][0]
        fe2 = self.fits[(key, 2 * D)][0]
        em_err = np.abs(C.richardson(fe, fe2, 0.5, ORDER)) / fe
        fb = fits[dt1][0]
        b_err = np.abs(C.richardson(fb, fits[dt2][0], dt2 / dt1, 4)) / fb
        self.basilisk_fits = fits
        for k, (mode, id_) in enumerate(zip(("fast", "slow"), ids)):
            value = abs(fe[k] / fb[k] - 1)
            self.check(
                id_,
                f"eps = {eps:g} rad: the {mode} roll-yaw frequency of em at T/{D} against Basilisk's (RK4 at "
                f"{dt1:g} s), both fitted to roll and yaw over {s['orbits']} T, |w_em / w_Basilisk - 1|",
                "Basilisk's roll-yaw frequencies",
                value,
                ALLOWANCE * (em_err[k] + b_err[k]) + FIT_FLOOR,
                "1",
                f"{ALLOWANCE:g} times the two discretisation errors (em {em_err[k]:.2g} from T/{D} and T/{2 * D}, "
                f"Basilisk {b_err[k]:.2g} from {dt1:g} and {dt2:g} s) and {FIT_FLOOR:g} for the fits' scatter (1e-9 "
                "measured); both carry the same offset's eps^2 term",
                f"em {fe[k] / n:.10g} n, Basilisk {fb[k] / n:.10g} n",
            )
