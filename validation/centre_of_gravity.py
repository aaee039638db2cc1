"""The case ``centre-of-gravity``: the resultant gravity force and torque on a rigid body of mass
points in a central field, as emorbit computes them, against exact sums and closed forms, and
the gap between the centre of gravity and the centre of mass against quadrupole theory (the
referees and the equations: :mod:`.centre_of_gravity_referees`; the figure:
:mod:`.centre_of_gravity_figures`).

In an inhomogeneous field the resultant gravity force on a rigid body does not act at its
centre of mass: emorbit sums the field over the body's mass points (Goettlicher & Schweizerhof's
rigid body; ``gravity="volume"``), which gives the gravity-gradient torque, and the resultant
acts along a line through the field's centre that misses the centre of mass. The centre of
gravity x_g is the point on that line where a point mass M (the body's mass) feels the resultant
F; its gap from the centre of mass is of order l^2 / r (quadrupole theory).

The case, in the paper's field (GM = 3.9478 m^3/s^2) at its distance r = 10 m:

1. emorbit's rigid-body force kernel (:func:`emorbit.kernels.rigid.rigid_forces` at q0 = q1)
   on emorbit's box 3 x 2 x 1 m (refinement 2: 64 mass points) against the exact sums over the
   same points (Python's ``decimal``, 40 digits) at random attitudes and directions: force and
   torque about the centre of mass at round-off.
2. The kernel on a dumbbell of two mass points against its closed form; on a rod of N midpoint
   mass points against the rod's closed form (itself checked against Gauss-Legendre
   quadrature): order 2 in 1/N, with the Euler-Maclaurin coefficient.
3. One em step of the box from rest through the public API at two steps: M dv / h and L_spin / h
   converge to the exact force and torque at O(h^2), and their Richardson extrapolation matches
   them to round-off.
4. The gap x_g - x_c of the box (emorbit's kernel) and of the rod (its closed form) at r = 10 to
   80 m against MacCullagh's quadrupole formula: within O((l / r)^2), falling at order 2.

The data layout: ``runs`` holds the per-attitude errors as :class:`~.body_case.Trajectory`
records (``series`` ``force`` and ``torque``, (n,), t the attitude's index) and the em steps;
the rod's errors by N, the gaps by body and distance and the em step's errors are attributes of
:class:`CentreOfGravityRun` and its ``convergence``.

References: M. Goettlicher, K. Schweizerhof (the energy-momentum method for a satellite in a
central field); MacCullagh's formula (e.g. A. E. Roy, *Orbital Motion*, 4th ed., IoP 2005); A.
Riaguas, A. Elipe, M. Lara, Celest. Mech. Dyn. Astron. 73 (1999) 169-178 (the massive straight
segment).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .body_case import BodyCase, BodyRun, Trajectory, build_cases
from .centre_of_gravity_referees import (
    DIGITS,
    centre_of_gravity,
    dumbbell_force,
    exact_resultant,
    gauss_legendre_rod,
    kernel_resultant,
    quadrupole_gap,
    random_attitudes,
    rod_force,
    rod_leading_error,
    rod_points,
)

__all__ = ["NAMES", "NOTE", "cases", "run", "CentreOfGravityRun"]

NAMES = ("centre-of-gravity",)

NOTE = (
    "The centre of gravity (`centre-of-gravity`) checks the resultant gravity force and torque that emorbit's "
    "rigid-body kernel sums over a body's mass points (Goettlicher & Schweizerhof) against exact sums over the same "
    "points (Python's decimal, 40 digits), a two-point dumbbell and a homogeneous rod in closed form (the rod's "
    "integral; the massive segment of Riaguas, Elipe & Lara 1999), one em step from rest through the public API, "
    "and the gap between the centre of gravity and the centre of mass against MacCullagh's quadrupole theory."
)


# -- the case ----------------------------------------------------------------------------------
def _centre_of_gravity(mode: str) -> BodyCase:
    from .cases import PAPER_GM, PAPER_X0

    gm, r0 = PAPER_GM, float(np.linalg.norm(PAPER_X0))
    return BodyCase(
        name="centre-of-gravity",
        module="centre_of_gravity",
        title="Centre of gravity: the resultant gravity force and torque on a rigid body of mass points",
        description=(
            f"The paper's field (GM = {gm} m3/s2) and distance (r = {r0:g} m). emorbit's rigid-body force kernel "
            "(`emorbit.kernels.rigid.rigid_forces`, at q0 = q1 where g_em is the field itself) sums the field over "
            "the mass points of emorbit's box 3 x 2 x 1 m (1 kg/m3, refinement 2: 64 points), a dumbbell of two "
            "mass points (2 and 1 kg, 3 m apart) and a rod of N mass points (6 kg, 3 m). The resultant force and the "
            "torque about the centre of mass are compared with exact sums (Python's decimal at 40 digits) at random "
            "attitudes and directions, with the dumbbell's closed form and with the rod's closed form (the integral "
            "along the rod, checked against Gauss-Legendre quadrature); the N-point rod converges at O(1/N^2) with "
            "the Euler-Maclaurin coefficient. One em step of the box from rest through the public API gives M dv/h "
            "and L_spin/h, which converge to the exact force and torque at O(h^2). The centre of gravity (the point "
            "on the line of action where a point mass M feels F) lies d ~ l^2/R from the centre of mass; d is "
            "checked against MacCullagh's quadrupole formula at R = 10 to 80 m."
        ),
        period=1.0,
        params={
            "GM": f"{gm} m3/s2 (the paper's)",
            "distance": f"{r0:g} m (and 20, 40, 80 m for the gap)",
            "box": "3 x 2 x 1 m, 1 kg/m3, 6 kg, refinement 2 (64 mass points)",
            "dumbbell": "2 kg and 1 kg, 3 m apart (two mass points)",
            "rod": "6 kg, 3 m, N mass points at the midpoints of N cells",
            "attitudes": f"{ {'quick': 48, 'full': 400}[mode] } random (uniform on SO(3)), random directions",
            "exact sums": f"decimal, {DIGITS} digits",
        },
        settings={
            "gm": gm,
            "referee_gm": gm,  # the referees' GM (another value shows the checks fail)
            "distance": r0,
            "box": {"size": [3.0, 2.0, 1.0], "density": 1.0, "refinement": 2},
            "dumbbell": {"masses": (2.0, 1.0), "length": 3.0},
            "rod": {"mass": 6.0, "length": 3.0},
            "attitudes": {"quick": 48, "full": 400}[mode],
            "closed_form_attitudes": {"quick": 24, "full": 96}[mode],  # of the rod and the gaps
            "seed": 20250,
            "rod_points": (4, 8, 16, 32, 64, 128, 256),
            "distances": (10.0, 20.0, 40.0, 80.0),
            "steps": (2e-3, 1e-3),  # s: the em steps from rest
            "step_start": {"position": [6.0, 8.0, 0.0], "rotation_vector": [0.3, -0.7, 1.1]},
        },
    )


def cases(mode: str) -> dict[str, BodyCase]:
    """The centre-of-gravity case of a mode by name (:func:`~.body_case.build_cases`): ``"quick"``
    (48 attitudes) or ``"full"`` (400)."""
    return build_cases(mode, _centre_of_gravity)


# -- the case's run and checks ------------------------------------------------------------------
class CentreOfGravityRun(BodyRun):
    """The runs, checks and measurements of the centre-of-gravity case (what the figure reads).

    After :meth:`run`: ``box`` (emorbit's MassPoints), ``attitudes`` (R, u), the per-attitude
    errors in ``runs`` (``series`` force, torque), ``rod`` and ``rod_torque`` {N: worst relative
    error}, ``gaps`` {body: {r: {gap_min, gap_max (m), deviation (from quadrupole theory),
    gap_scaled_min, gap_scaled_max (in l^2 / r)}}}, ``step`` {force, torque: the em step's errors,
    observed order and extrapolation}, ``picture`` (the box's offsets, x_c, x_g, F for the sketch).
    """

    def __init__(self, case, mode, scale, outdir):
        super().__init__(case, mode, scale, outdir)
        s = case.settings
        self.gm, self.gm_ref, self.r0 = s["gm"], s["referee_gm"], s["distance"]
        self.box = None
        self.attitudes = None
        self.rod: dict = {}
        self.rod_torque: dict = {}
        self.gaps: dict = {}
        self.picture: dict = {}
        self.step: dict = {}

    def run(self):
        """Compute the resultants, the em steps, the rods and the gaps, and make the checks."""
        from emorbit.bodies.shapes import box

        s = self.case.settings
        self.box = box(s["box"]["size"], density=s["box"]["density"], refinement=s["box"]["refinement"])
        self.attitudes = random_attitudes(s["attitudes"], s["seed"])
        t0 = time.perf_counter()
        self._box()
        self._dumbbell()
        self.timing["sums_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        self._em_step()
        self.timing["em_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        self._rod()
        self._gaps()
        self.timing["rod_and_gaps_s"] = time.perf_counter() - t0

    # -- the box: kernel against exact sums -----------------------------------------------------
    def _box(self):
        Rs, us = self.attitudes
        X, m = self.box.X, self.box.m
        ef, et, lever = [], [], []
        start = time.perf_counter()
        for R, u in zip(Rs, us):
            x = self.r0 * u
            F, tau = kernel_resultant(X, m, self.gm, x, R)
            Fx, Tx, f_scale, t_scale = exact_resultant(X, m, self.gm_ref, x, R)
            ef.append(np.linalg.norm(F - Fx) / f_scale)
            et.append(np.linalg.norm(tau - Tx) / t_scale)
            lever.append(np.linalg.norm(tau + np.cross(x, F)) / (np.linalg.norm(x) * np.linalg.norm(F)))
        n = len(Rs)
        self.add(
            Trajectory(
                "box, kernel vs exact sums",
                np.arange(n, dtype=float),
                {"force": np.array(ef), "torque": np.array(et)},
                time.perf_counter() - start,
                {"method": "rigid_forces vs decimal", "steps": n},
            )
        )
        detail = f"{n} attitudes at r = {self.r0:g} m, {len(m)} mass points; median "
        self.check(
            "resultant-force",
            "emorbit's kernel: |F - F_exact| / sum m_i |g_i| on the box, worst attitude",
            f"the exact sum over the same 64 mass points ({DIGITS} digits)",
            max(ef),
            8e-16,
            "1",
            "the kernel's rounding: the positions x_i = x_c + X^k d_k, g_i and a sum of 64 terms of one sign: "
            "measured 2.4e-16 (quick) and 2.7e-16 (full) of the summed magnitudes, about 3 times that; a mass or GM "
            "1e-15 off fails",
            detail + f"{np.median(ef):.2g}",
        )
        self.check(
            "resultant-torque",
            "emorbit's kernel: |tau - tau_exact| / sum m_i |r_i| |g_i| about the centre of mass on the box, worst "
            "attitude",
            f"the exact sum over the same 64 mass points ({DIGITS} digits)",
            max(et),
            5e-16,
            "1",
            "tau = sum_k d_k x F_k from the director forces F_k = sum m_i X_i^k g_i: terms of both signs cancel to "
            "|tau| ~ (l / R) of their size; measured 1.5e-16 (quick) and 1.6e-16 (full) of the summed magnitudes, "
            "about 3 times that",
            detail + f"{np.median(et):.2g}",
        )
        self.metric(
            "line_of_action.through_centre",
            float(max(lever)),
            "1",
            "emorbit's kernel: |tau + x_c x F| / (|x_c| |F|), worst attitude (0 exactly: the line of action passes "
            "through the field's centre; round-off and the cancellation in tau)",
        )

    def _dumbbell(self):
        s = self.case.settings["dumbbell"]
        m1, m2 = s["masses"]
        M, L = m1 + m2, s["length"]
        X = np.zeros((3, 2))
        X[0] = (-m2 * L / M, m1 * L / M)
        m = np.array([m1, m2])
        Rs, us = self.attitudes
        errs = []
        for R, u in zip(Rs, us):
            x = self.r0 * u
            F, _ = kernel_resultant(X, m, self.gm, x, R)
            Fd = dumbbell_force((m1, m2), L, self.gm_ref, x, R[:, 0])
            scale = self.gm_ref * sum(mj / float(np.linalg.norm(x + R @ X[:, j])) ** 2 for j, mj in enumerate(m))
            errs.append(float(np.linalg.norm(F - Fd) / scale))
        self.runs["dumbbell, kernel vs closed form"] = Trajectory(
            "dumbbell, kernel vs closed form",
            np.arange(len(errs), dtype=float),
            {"force": np.array(errs)},
            0.0,
            {"method": "rigid_forces vs closed form", "steps": len(errs)},
        )
        self.check(
            "dumbbell-force",
            "emorbit's kernel on two mass points (2 and 1 kg, 3 m apart): |F - F_closed| / sum m_j |g_j|, worst "
            "attitude",
            "the two-point closed form in R, theta and the masses' offsets",
            max(errs),
            2.5e-15,
            "1",
            "the same two terms evaluated in two orders of operations (the closed form's (R^2 + 2 R s cos(theta) + "
            "s^2)^(3/2) rounds a few times): measured 5.8e-16 (quick) and 8.4e-16 (full), about 3 times that",
            f"{len(errs)} attitudes",
        )
        self.dumbbell_shape()

    def dumbbell_shape(self):
        """emorbit's dumbbell shape (end spheres of mass points) beside the two-point closed form: a metric."""
        from emorbit.bodies.shapes import dumbbell

        s = self.case.settings["dumbbell"]
        pts = dumbbell(s["masses"], s["length"])
        Rs, us = self.attitudes
        worst = 0.0
        for R, u in list(zip(Rs, us))[:16]:
            x = self.r0 * u
            F, _ = kernel_resultant(pts.X, pts.m, self.gm, x, R)
            Fd = dumbbell_force(s["masses"], s["length"], self.gm_ref, x, R[:, 0])
            worst = max(worst, float(np.linalg.norm(F - Fd) / np.linalg.norm(Fd)))
        self.metric(
            "dumbbell_shape.vs_two_points",
            worst,
            "1",
            f"emorbit's `dumbbell` shape ({len(pts)} mass points: end spheres of radius L/20) against two point "
            "masses, |dF| / |F|, worst of 16 attitudes: the end spheres' discretisation",
        )

    # -- one em step from rest through the public API ---------------------------------------------
    def _em_step(self):
        import emorbit
        from emorbit.bodies.rotations import quaternion_to_matrix

        s = self.case.settings
        start = s["step_start"]
        res_by_h = {}
        for h in s["steps"]:
            sim = emorbit.Simulation(emorbit.CentralField(gm=self.gm, radius=1.0), method="em", dt=h)
            sim.add_rigid(
                "box",
                "box",
                size=s["box"]["size"],
                density=s["box"]["density"],
                refinement=s["box"]["refinement"],
                position=start["position"],
                velocity=[0.0, 0.0, 0.0],
                rotation_vector=start["rotation_vector"],
                angular_velocity=[0.0, 0.0, 0.0],
            )
            t0 = time.perf_counter()
            res = sim.run(steps=1, every=1, progress=False).si
            wall = time.perf_counter() - t0
            pts = sim.rigid.points[0]
            M = pts.mass
            R1 = quaternion_to_matrix(res.attitudes["box"][1])
            F_step = M * (res.velocities["box"][1] - res.velocities["box"][0]) / h
            tau_step = R1 @ (pts.inertia @ res.angular_velocities["box"][1]) / h
            res_by_h[h] = (F_step, tau_step)
            self.add(
                Trajectory(
                    f"em 2, one step of {h:g} s from rest",
                    res.time,
                    {},
                    wall,
                    {
                        "method": "em",
                        "order": 2,
                        "dt_s": h,
                        "steps": 1,
                        "newton_iterations": res.mean_newton_iterations(),
                    },
                )
            )
        R0 = quaternion_to_matrix(res.attitudes["box"][0])
        Fx, Tx, _, _ = exact_resultant(pts.X, pts.m, self.gm_ref, res.positions["box"][0], R0)
        h1, h2 = s["steps"]
        for kind, exact, k in (("force", Fx, 0), ("torque", Tx, 1)):
            e1 = float(np.linalg.norm(res_by_h[h1][k] - exact) / np.linalg.norm(exact))
            e2 = float(np.linalg.norm(res_by_h[h2][k] - exact) / np.linalg.norm(exact))
            observed = math.log(e1 / e2) / math.log(h1 / h2)
            extrapolated = (res_by_h[h2][k] * (h1 / h2) ** 2 - res_by_h[h1][k]) / ((h1 / h2) ** 2 - 1)
            ext = float(np.linalg.norm(extrapolated - exact) / np.linalg.norm(exact))
            self.step[kind] = {"h": [h1, h2], "error": [e1, e2], "observed": observed, "extrapolated": ext}
            what = "M dv / h" if kind == "force" else "L_spin / h = R I w / h"
            self.check(
                f"em-step-{kind}-order",
                f"one em step of the box from rest (public API): observed order of |{what} - exact| / |exact| "
                f"from h = {h1:g} and {h2:g} s, |observed - 2|",
                "order 2",
                abs(observed - 2.0),
                1e-6,
                "1 (order)",
                "the step's gravity g_em(x0, x1) differs from g(x0) by the body's fall, O(h^2); the next term is "
                "smaller by O(h^2 GM / r^3) ~ 4e-9 at these steps: measured deviations 3.3e-8 (force) and 1.0e-7 "
                "(torque), 10 times the larger",
                f"errors {e1:.4g} and {e2:.4g}; observed {observed:.6f}",
            )
            self.check(
                f"em-step-{kind}",
                f"one em step from rest: {what} extrapolated to h = 0 (Richardson, order 2, from h = {h1:g} and "
                f"{h2:g} s), |. - exact| / |exact|",
                f"the exact {kind} on the same 64 mass points ({DIGITS} digits)",
                ext,
                {"force": 1e-15, "torque": 3e-15}[kind],
                "1",
                "round-off in dv (the step's velocities ~ h |F| / M, each rounded) amplified by the extrapolation's "
                "(4 e2 - e1) / 3: measured 1.2e-16 (force) and 9.6e-16 (torque), at most 10 times that; the whole "
                "path (shapes, structure, the step's Newton solve, the records) against the exact resultant",
                f"error before extrapolation {e2:.3g} at h = {h2:g} s",
            )

    # -- the rod --------------------------------------------------------------------------------
    def _rod(self):
        s = self.case.settings
        mass, L = s["rod"]["mass"], s["rod"]["length"]
        Rs, us = self.attitudes
        k = min(len(Rs), s["closed_form_attitudes"])
        gl = []
        for R, u in list(zip(Rs, us))[:k]:
            x, e = self.r0 * u, R[:, 0]
            F, _ = rod_force(mass, L, self.gm_ref, x, e)
            gl.append(float(np.linalg.norm(F - gauss_legendre_rod(mass, L, self.gm_ref, x, e)) / np.linalg.norm(F)))
        self.check(
            "rod-closed-form",
            f"the rod's closed form against 64-point Gauss-Legendre quadrature of its integral, |dF| / |F|, worst "
            f"of {k} attitudes",
            "numerical quadrature (exact for polynomials of degree 127; the integrand is analytic along the rod)",
            max(gl),
            3e-15,
            "1",
            "two evaluations of one integral, both near round-off: measured 5.0e-16 (quick) and 9.2e-16 (full), about "
            "3 times that; a wrong sign or factor in the derivation shows at the percent level",
        )
        errs = {n: [] for n in s["rod_points"]}
        terr = {n: [] for n in s["rod_points"]}
        lead = []
        for R, u in list(zip(Rs, us))[:k]:
            x, e = self.r0 * u, R[:, 0]
            F, tau = rod_force(mass, L, self.gm_ref, x, e)
            for n in s["rod_points"]:
                X, m = rod_points(mass, L, n)
                Fn, tn = kernel_resultant(X, m, self.gm, x, R)
                errs[n].append(float(np.linalg.norm(Fn - F) / np.linalg.norm(F)))
                terr[n].append(float(np.linalg.norm(tn - tau) / np.linalg.norm(tau)))
            n = s["rod_points"][-2]
            X, m = rod_points(mass, L, n)
            Fn, _ = kernel_resultant(X, m, self.gm, x, R)
            predicted = rod_leading_error(mass, L, self.gm_ref, x, e, n)
            lead.append(float(np.linalg.norm((F - Fn) - predicted) / np.linalg.norm(F - Fn)))
        self.rod = {n: max(v) for n, v in errs.items()}
        self.rod_torque = {n: max(v) for n, v in terr.items()}
        ns = np.array(s["rod_points"], float)
        e = np.array([self.rod[n] for n in s["rod_points"]])
        slope = -np.polyfit(np.log(ns[-3:]), np.log(e[-3:]), 1)[0]
        self.convergence["rod"] = {
            "points": list(s["rod_points"]),
            "force": list(e),
            "observed": float(slope),
            "torque": [self.rod_torque[n] for n in s["rod_points"]],
        }
        self.check(
            "rod-order",
            f"emorbit's kernel on a rod of N midpoint mass points against the closed form: order of the worst "
            f"|F_N - F| / |F| fitted over N = {', '.join(str(n) for n in s['rod_points'][-3:])}, |observed - 2|",
            "the midpoint rule's order 2",
            abs(slope - 2.0),
            5e-5,
            "1 (order)",
            "the midpoint rule's error expands in even powers of h = L / N; the h^4 term is ~(h / r)^2 of the "
            "leading one (< 1e-4 here): measured deviations 5.4e-6 (quick) and 8.7e-6 (full); a closed form with "
            "another L floors the error and fails",
            "errors " + ", ".join(f"N = {n}: {v:.3g}" for n, v in self.rod.items()),
        )
        self.check(
            "rod-euler-maclaurin",
            f"the rod's error F - F_N at N = {s['rod_points'][-2]} against the Euler-Maclaurin leading term (h^2 / "
            "24) (g'(L/2) - g'(-L/2)), relative, worst attitude",
            "the midpoint rule's leading error term",
            max(lead),
            1e-5,
            "1",
            "the next term, -(7 h^4 / 5760) (g'''(L/2) - g'''(-L/2)), is O((h / r)^2) of the leading one: measured "
            "2.8e-6 (quick) and 3.3e-6 (full), about 3 times that; the kernel's round-off (1e-16 of F against errors "
            "of 1e-6 of F) does not show",
        )
        self.metric(
            "rod.torque_error",
            [{"N": n, "error": v} for n, v in self.rod_torque.items()],
            "1",
            "|tau_N - tau| / |tau| by N, worst attitude (the closed-form torque)",
        )

    # -- the gap --------------------------------------------------------------------------------
    def _gaps(self):
        s = self.case.settings
        Rs, us = self.attitudes
        k = min(len(Rs), s["closed_form_attitudes"])
        rod = s["rod"]
        bodies = {"box": (self.box.X, self.box.m, self.box.inertia)}
        bodies["rod"] = (None, None, rod["mass"] * rod["length"] ** 2 / 12.0 * np.diag([0.0, 1.0, 1.0]))
        for name, (X, m, I_body) in bodies.items():
            M = float(m.sum()) if m is not None else rod["mass"]
            size2 = float(np.trace(I_body)) / M
            per_R = {}
            for dist in s["distances"]:
                gaps, dev, scaled = [], [], []
                for R, u in list(zip(Rs, us))[:k]:
                    x = dist * u
                    if name == "box":
                        F, _ = kernel_resultant(X, m, self.gm, x, R)
                    else:  # the closed form: the continuous rod
                        F, _ = rod_force(rod["mass"], rod["length"], self.gm, x, R[:, 0])
                    d = centre_of_gravity(F, M, self.gm_ref) - x
                    dq = quadrupole_gap(R @ I_body @ R.T, M, x)
                    gaps.append(float(np.linalg.norm(d)))
                    dev.append(float(np.linalg.norm(d - dq) / np.linalg.norm(d)))
                    scaled.append(float(np.linalg.norm(d)) * dist / size2)
                per_R[dist] = {
                    "gap_min": min(gaps),
                    "gap_max": max(gaps),
                    "deviation": max(dev),
                    "gap_scaled_min": min(scaled),
                    "gap_scaled_max": max(scaled),
                }
                if name == "box" and dist == s["distances"][0]:
                    i = int(np.argmax(gaps))
                    R, u = Rs[i], us[i]
                    F, _ = kernel_resultant(X, m, self.gm, dist * u, R)
                    self.picture = {
                        "X": R @ X,
                        "x": dist * u,
                        "F": F,
                        "g": centre_of_gravity(F, M, self.gm_ref),
                        "R": R,
                        "size": s["box"]["size"],
                    }
            self.gaps[name] = per_R
            d = np.array(s["distances"])
            dev = np.array([per_R[r]["deviation"] for r in s["distances"]])
            slope = -np.polyfit(np.log(d), np.log(dev), 1)[0]
            self.convergence[f"gap-{name}"] = {"distances": list(d), "deviation": list(dev), "observed": float(slope)}
            first = per_R[s["distances"][0]]
            self.metric(
                f"gap.{name}",
                [{"least": first["gap_min"], "greatest": first["gap_max"]}],
                "m",
                f"|x_g - x_c| at r = {s['distances'][0]:g} m, least and greatest of {k} attitudes; in units of "
                f"l^2 / r (l^2 = tr I / M = {size2:.4g} m2): {first['gap_scaled_min']:.3g} to "
                f"{first['gap_scaled_max']:.3g} (quadrupole theory: O(1))",
            )
            what = "emorbit's kernel on the box's 64 mass points" if name == "box" else "the rod's closed form"
            self.check(
                f"gap-quadrupole-{name}",
                f"{name}: the gap x_g - x_c ({what}) against MacCullagh's quadrupole formula at r = "
                f"{s['distances'][0]:g} m, |d - d_quad| / |d|, worst of {k} attitudes",
                "quadrupole theory",
                first["deviation"],
                {"box": 0.05, "rod": 0.04}[name],
                "1",
                "the formula's truncation: the hexadecapole and the square of the quadrupole, O((l / r)^2) for a "
                f"centrally symmetric body, measured {first['deviation']:.3g} = "
                f"{first['deviation'] * s['distances'][0] ** 2 / size2:.3g} l^2 / r^2; ~3 times the measured",
                "; ".join(
                    f"r = {r:g} m: |d| {v['gap_min']:.3g} to {v['gap_max']:.3g} m, deviation {v['deviation']:.3g}"
                    for r, v in per_R.items()
                ),
            )
            self.check(
                f"gap-order-{name}",
                f"{name}: order in 1/r of the deviation from the quadrupole formula, fitted over r = "
                f"{', '.join(f'{r:g}' for r in s['distances'])} m, |observed - 2|",
                "order 2 (the first neglected terms)",
                abs(slope - 2.0),
                {"box": 0.1, "rod": 0.005}[name],
                "1 (order)",
                "the truncation falls as (l / r)^2 for a centrally symmetric body; the higher terms bend the fit by "
                "O((l / r)^2) at r = 10 m: measured 0.020 and 0.024 (box, quick and full), 8.5e-4 and 7.8e-4 (rod); a "
                "wrong coefficient in the formula leaves a deviation of order 1 that does not fall",
                f"observed {slope:.4f}",
            )


def run(case: BodyCase, mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True):
    """Run the centre-of-gravity case and return its outcome (:func:`~.runner.body_outcome`; the
    figure ``centre-of-gravity.png``)."""
    from .runner import body_outcome

    s = case.settings
    return body_outcome(
        case,
        mode,
        outdir,
        lambda: CentreOfGravityRun(case, mode, scale, outdir),
        _draw,
        figures=figures,
        summary=f"{s['attitudes']} random attitudes and directions at r = {s['distance']:g} m; rods of "
        f"{', '.join(str(n) for n in s['rod_points'])} mass points; gaps at r = "
        f"{', '.join(f'{r:g}' for r in s['distances'])} m; one em step of {s['steps'][0]:g} and {s['steps'][1]:g} s.",
    )


def _draw(r, outdir):  # matplotlib is imported only where figures are drawn
    from .centre_of_gravity_figures import centre_of_gravity_figure

    return centre_of_gravity_figure(r, outdir)
