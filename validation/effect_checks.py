"""The checks particular to each effect case (the common ones, energy, momenta and orders,
are in :mod:`.effect_runner`). Each function takes the case's run, its IAS15 trajectory and
its reference (IAS15 itself, or the analytic two-body solution) and adds checks, metrics
and, for the figures, further trajectories (``run.named``) and results (``run.extra``).

Tolerances come from :mod:`.checks`, each with its unit and reason; the position tolerance
of em order 8 is the suite's, ``POSITION_PER_ORBIT`` (1e-9 of the orbit's size per period),
and a referee may use ``REFEREE_FRACTION`` (10 %) of it.
"""

from __future__ import annotations

import math

import numpy as np

from emorbit import orbits

from . import checks as C
from .effect_cases import J2, R_EARTH
from .effect_runs import kepler_test_particles, reboundx_potential, run_ias15, zonal_energy, zonal_potential
from .secular import (
    DEG_PER_DAY,
    SUN_SYNCHRONOUS_RATE,
    mean_rates,
    node_rate,
    perigee_rate,
    second_order_scale,
)

__all__ = ["CASE_CHECKS", "rates_of"]

#: IAS15's accuracy parameter for its own error estimate: 100 times tighter than the default
TIGHT_EPSILON = 1e-11


def _position(run, key, what, against, err, unit, detail=""):
    run.check(
        key,
        what,
        against,
        float(np.max(err)),
        C.POSITION_PER_ORBIT * run.n,
        unit,
        f"the suite's position tolerance for em order 8, {C.POSITION_PER_ORBIT:g} {unit} per period x {run.n} "
        "periods (a phase error grows linearly in time)",
        detail,
    )


def _referee(run, key, what, against, err, unit, detail=""):
    run.check(
        key,
        what,
        against,
        float(np.max(err)),
        C.REFEREE_FRACTION * C.POSITION_PER_ORBIT * run.n,
        unit,
        f"{C.REFEREE_FRACTION:g} of the em order-8 position tolerance ({C.POSITION_PER_ORBIT:g} {unit} per period "
        f"x {run.n} periods): a referee may not use more of it",
        detail,
    )


def _ias15_epsilon(run, ias, unit):
    """IAS15 against itself at a 100 times tighter epsilon: its own error."""
    tight = run_ias15(run.case, run.times, epsilon=TIGHT_EPSILON, label=f"{ias.label}, epsilon {TIGHT_EPSILON:g}")
    run.runs[tight.label] = tight
    err = ias.position_error(tight, run.case.length)
    _referee(
        run,
        "referee-ias15-epsilon",
        f"{ias.label} (epsilon {ias.info['epsilon']:g}) position, max over time and bodies",
        f"the same at epsilon {TIGHT_EPSILON:g}",
        err,
        unit,
        f"{ias.info['steps']} and {tight.info['steps']} IAS15 steps",
    )
    return err


def _order_metrics(run, reference, unit):
    for p in (2, 4, 6, 8):
        tr = run.main(p)
        run.metric(
            f"em{p}.position_vs_reference.max", tr.position_error(reference, run.case.length).max(), unit, tr.label
        )


# -- J2 against REBOUNDx --------------------------------------------------------------------
def _j2_reboundx(run, ias, reference):
    c = run.case
    a, gm, h = c.length, c.gm, c.harmonics
    x0 = c.x0[0]
    what = "the zonal potential computed here, +(GM / r) J2 (R/r)^2 P2(z/r), at the initial state (relative)"
    if ias is None:
        run.skip("zonal-potential-convention", what, "REBOUNDx's gravitational_harmonics_potential")
    else:
        mine, theirs = float(zonal_potential(x0, gm, h)), reboundx_potential(x0, gm, h)
        s2 = (x0[2] / np.linalg.norm(x0)) ** 2
        kappa = (1.5 * s2 + 0.5) / abs(1.5 * s2 - 0.5)  # P2 = 1.5 s^2 - 0.5 cancels near s^2 = 1/3
        run.check(
            "zonal-potential-convention",
            what,
            f"REBOUNDx's gravitational_harmonics_potential = {theirs:.12g} J/kg",
            abs(mine / theirs - 1.0),
            C.POTENTIAL_CONVENTION * kappa,
            "1",
            f"one expression evaluated in two orders of operations: {C.POTENTIAL_CONVENTION / C.EPS:g} eps times "
            f"the condition number of P2(s) = 1.5 s^2 - 0.5 at this s ({kappa:.3g}); a sign or factor would be O(1)",
            f"here {mine:.12g} J/kg",
        )
    worst, per = 0.0, []
    for tr in run.em_runs.values():
        here = zonal_energy(tr.x, tr.v, gm, h)
        d = float(np.abs(tr.energy - here).max() / abs(tr.energy[0]))
        worst = max(worst, d)
        per.append(f"{tr.label}: {d:.2g}")
    run.check(
        "recorded-energy",
        "emorbit's recorded energy (kinetic + central + zonal potential) against the energy computed here from its "
        "recorded states with REBOUNDx's J2 and convention, max over records and em runs, relative to |E0|",
        "v^2/2 - GM/r + (GM/r) J2 (R/r)^2 P2(z/r) per unit mass (1 kg)",
        worst,
        C.RECORDED_ENERGY,
        "1",
        "the same sum evaluated twice from the same states: terms up to 2 |E| rounded at eps each (~45 eps); a "
        "zonal potential left out or of the wrong sign would be ~3e-5 of |E|",
        "; ".join(per),
    )
    kep = kepler_test_particles(c, run.times)
    ias0 = run_ias15(c, run.times, harmonics={}, label="IAS15, J2 = 0")
    run.runs[ias0.label] = ias0
    _referee(
        run,
        "referee-ias15-kepler",
        "REBOUND IAS15 without harmonics, position, max over time",
        "the analytic Kepler solution (emorbit.orbits.propagate)",
        ias0.position_error(kep, a),
        "a",
        f"{ias0.info['steps']} IAS15 steps",
    )
    em8j4 = run.em(8, c.main[8], zonal=c.extra["j4"], label=f"em 8 with J2 and J4, dt = T/{c.main[8]}", key=False)
    run.check(
        "energy-em8-j4",
        "em order 8 with J2 and J4, max |E - E0| / |E0|",
        "the initial energy",
        em8j4.rel_energy_error().max(),
        C.ENERGY_HIGH,
        "1",
        "em conserves the energy with every zonal term exactly up to round-off",
    )
    tfe6 = run.em(6, c.main[8], label=f"tfe 6 with J2, dt = T/{c.main[8]}", key=False, method="tfe")
    run.check(
        "energy-tfe6",
        "tfe order 6 (one solve of 3 Gauss stages) with J2, max |E - E0| / |E0|",
        "the initial energy",
        tfe6.rel_energy_error().max(),
        C.ENERGY_HIGH,
        "1",
        "the time finite element keeps the energy with every zonal term exactly up to round-off, as em does",
    )
    run.named.update({"Kepler": kep, "IAS15, J2 = 0": ias0, "em8 J2+J4": em8j4, "tfe6 J2": tfe6})
    if ias is None:
        _j2_reboundx_skipped(run)
        return
    eps_err = _ias15_epsilon(run, ias, "a")
    em8 = run.main(8)
    err8 = em8.position_error(ias, a)
    _position(
        run,
        "position-em8-vs-reboundx",
        f"em order 8 (dt = T/{c.main[8]}) with J2, position, max over {run.n} orbits",
        "REBOUND IAS15 + REBOUNDx gravitational_harmonics (J2) on the same records",
        err8,
        "a",
        f"at the end {err8[-1]:.3g} a; J2 moves the satellite {ias.position_error(kep, a).max():.3g} a from the "
        f"Kepler orbit over the run; IAS15's own error (epsilon test) {eps_err.max():.2g} a",
    )
    _position(
        run,
        "position-tfe6-vs-reboundx",
        f"tfe order 6 (dt = T/{c.main[8]}) with J2, position, max over {run.n} orbits",
        "REBOUND IAS15 + REBOUNDx gravitational_harmonics (J2) on the same records",
        tfe6.position_error(ias, a),
        "a",
    )
    ias4 = run_ias15(c, run.times, harmonics=c.extra["harmonics_j4"], label="IAS15 + REBOUNDx, J2 and J4")
    run.runs[ias4.label] = ias4
    err4 = em8j4.position_error(ias4, a)
    j4_effect = ias4.position_error(ias, a).max()
    _position(
        run,
        "position-em8-j4-vs-reboundx",
        f"em order 8 with J2 and J4 (`j = [J2, 0, J4]`, dt = T/{c.main[8]}), position, max over {run.n} orbits",
        "REBOUND IAS15 + REBOUNDx with J2 and J4",
        err4,
        "a",
        f"J4 moves the satellite {j4_effect:.3g} a over the run (REBOUNDx with and without it)",
    )
    run.metric("ias15.j2_j4.energy.max", zonal_energy_error(ias4, c), "1", "J2 and J4 potential computed here")
    run.metric("j2.effect.max", ias.position_error(kep, a).max(), "a", "REBOUNDx (J2) against Kepler")
    run.metric("j4.effect.max", j4_effect, "a", "REBOUNDx with J2 and J4 against J2 only")
    run.metric("ias15.steps", ias.info["steps"], "1")
    _order_metrics(run, ias, "a")
    run.named["IAS15 J2+J4"] = ias4


def _j2_reboundx_skipped(run):
    """The checks of ``j2-reboundx`` that need REBOUNDx, skipped: it is not installed."""
    c = run.case
    run.skip("referee-ias15-epsilon", "IAS15 + REBOUNDx position, max over time", "the same at a tighter epsilon", "a")
    run.skip(
        "position-em8-vs-reboundx",
        f"em order 8 (dt = T/{c.main[8]}) with J2, position, max over {run.n} orbits",
        "REBOUND IAS15 + REBOUNDx gravitational_harmonics (J2) on the same records",
        "a",
    )
    run.skip(
        "position-tfe6-vs-reboundx",
        f"tfe order 6 (dt = T/{c.main[8]}) with J2, position, max over {run.n} orbits",
        "REBOUND IAS15 + REBOUNDx gravitational_harmonics (J2) on the same records",
        "a",
    )
    run.skip(
        "position-em8-j4-vs-reboundx",
        f"em order 8 with J2 and J4 (`j = [J2, 0, J4]`, dt = T/{c.main[8]}), position, max over {run.n} orbits",
        "REBOUND IAS15 + REBOUNDx with J2 and J4",
        "a",
    )


def zonal_energy_error(tr, case) -> float:
    """max |E - E0| / |E0| of a REBOUND run with J2 and J4, recomputed with both."""
    e = zonal_energy(tr.x, tr.v, case.gm, case.extra["harmonics_j4"])
    return float(np.abs(e - e[0]).max() / abs(e[0]))


# -- J2 against secular theory ----------------------------------------------------------------
def rates_of(run, tr, half: bool = False):
    """{body: mean rates} of a trajectory; emorbit's from its Result's elements."""
    c = run.case
    out = {}
    for k, name in enumerate(c.names):
        if tr.result is not None:
            el = tr.result.elements(name, si=True)
        else:
            el = orbits.elements(tr.x[:, k], tr.v[:, k], c.gm)
        rates = mean_rates(tr.t, el, c.records)
        j2 = J2 / 2 if half else J2
        rates["node_theory"] = node_rate(rates["a"], rates["e"], rates["i"], c.gm, j2, R_EARTH)
        rates["perigee_theory"] = perigee_rate(rates["a"], rates["e"], rates["i"], c.gm, j2, R_EARTH)
        rates["scale2"] = second_order_scale(rates["a"], rates["e"], c.gm, j2, R_EARTH)
        rates["q"] = j2 * (R_EARTH / (rates["a"] * (1 - rates["e"] ** 2))) ** 2
        rates["perigee_checked"] = bool(c.bodies[k][0] != c.extra["sso"])
        out[name] = rates
    return out


def _j2_secular(run, ias, reference):
    c = run.case
    em8 = run.main(8)
    half = run.em(8, c.main[8], zonal=c.extra["half_j2"], label=f"em 8 with J2/2, dt = T/{c.main[8]}", key=False)
    rates = rates_of(run, em8)
    rates_half = rates_of(run, half, half=True)
    rates_ias = None if ias is None else rates_of(run, ias)  # None: REBOUNDx is not installed

    def ias_says(name, key, digits):
        if rates_ias is None:
            return ""
        return f"; IAS15 + REBOUNDx {rates_ias[name][key] * f:.{digits}f}"

    f = DEG_PER_DAY
    residual, residual_half = [], []
    for name, r in rates.items():
        node_err = r["node"] / r["node_theory"] - 1.0
        run.check(
            f"node-rate-{name}",
            f"{name}: mean node rate of em order 8 (per-orbit means of the osculating Omega over {r['orbits']} "
            "orbits), relative",
            f"first-order theory -3/2 n J2 (R/p)^2 cos i = {r['node_theory'] * f:.6f} deg/day at the mean a, e, i",
            abs(node_err),
            C.SECULAR_NODE * r["q"],
            "1",
            f"first-order theory's own error: its neglected J2^2 terms, {C.SECULAR_NODE:g} x J2 (R/p)^2 "
            f"({r['q']:.3g}) relative (the node's terms are proportional to cos i at every order)",
            f"measured {r['node'] * f:.6f} deg/day{ias_says(name, 'node', 6)}; the difference from theory is "
            f"{(r['node'] - r['node_theory']) / r['scale2']:+.3f} n (J2 (R/p)^2)^2",
        )
        residual.append(r["node"] - r["node_theory"])
        residual_half.append(rates_half[name]["node"] - rates_half[name]["node_theory"])
        if not r["perigee_checked"]:
            continue
        d = r["perigee"] - r["perigee_theory"]
        run.check(
            f"perigee-rate-{name}",
            f"{name}: mean perigee rate of em order 8 (per-orbit means of the osculating omega), |measured - theory|",
            f"first-order theory 3/4 n J2 (R/p)^2 (5 cos^2 i - 1) = {r['perigee_theory'] * f:.5f} deg/day",
            abs(d) * f,
            C.SECULAR_PERIGEE * r["scale2"] * f,
            "deg/day",
            f"first-order theory's own error: its neglected J2^2 terms, {C.SECULAR_PERIGEE:g} n (J2 (R/p)^2)^2 "
            f"({r['scale2'] * f:.3g} deg/day per unit coefficient; they do not vanish with the first-order rate)",
            f"measured {r['perigee'] * f:.5f} deg/day{ias_says(name, 'perigee', 5)}; the difference is "
            f"{d / r['scale2']:+.3f} n (J2 (R/p)^2)^2",
        )
        residual.append(d)
        residual_half.append(rates_half[name]["perigee"] - rates_half[name]["perigee_theory"])
    # the residual is of second order in J2: at J2/2 it is a quarter
    r1, r2 = float(np.linalg.norm(residual)), float(np.linalg.norm(residual_half))
    observed = math.log2(r1 / r2) if r2 > 0 else math.inf
    run.check(
        "secular-residual-order",
        "the order in J2 of the difference between the measured rates and first-order theory (all checked rates, "
        "em order 8 at J2 and at J2/2)",
        "2: first-order theory's error is O(J2^2)",
        abs(observed - 2.0),
        C.SLOPE,
        "1 (order)",
        "a difference of order J2 (a wrong force, a wrong J2) would scale as J2 (order 1); the theory's neglected "
        "terms scale as J2^2 (order 2); 0.5 as the orders of convergence",
        f"|residual| {r1 * f:.4g} deg/day at J2, {r2 * f:.4g} at J2/2: observed order {observed:.3f}",
    )
    _rates_against_reboundx(run, rates, rates_ias)
    # the sun-synchronous orbit
    sso = c.extra["sso"]
    r = rates[sso]
    k = c.names.index(sso)
    el0 = orbits.elements(c.x0[k], c.v0[k], c.gm)
    da, de, di = r["a"] / float(el0.a) - 1.0, r["e"] - float(el0.e), r["i"] - float(el0.i)
    mean_vs_osc = 3.5 * abs(da) + 4 * r["e"] * abs(de) / (1 - r["e"] ** 2) + abs(math.tan(r["i"])) * abs(di)
    theory_err = C.SECULAR_NODE * r["q"]
    target = SUN_SYNCHRONOUS_RATE
    run.check(
        "sun-synchronous-node",
        f"the sun-synchronous orbit (i = {math.degrees(c.extra['sso_inclination']):.4f} deg from first-order theory "
        "for its initial osculating a, e): mean node rate of em order 8",
        f"360 deg per 365.2422 days = {target * f:.5f} deg/day",
        abs(r["node"] - target) * f,
        abs(target) * (theory_err + mean_vs_osc) * f,
        "deg/day",
        f"first-order theory's own error: its J2^2 terms ({C.SECULAR_NODE:g} J2 (R/p)^2 = {theory_err:.2g} relative) "
        "plus the initial osculating elements' difference from the mean ones the theory means, measured "
        f"(3.5 |da|/a + 4e |de| / (1 - e^2) + |tan i| |di| = {mean_vs_osc:.2g} relative: da/a = {da:.2g}, "
        f"de = {de:.2g}, di = {di:.2g} rad)",
        f"measured {r['node'] * f:.6f} deg/day ({r['node'] / target - 1:+.2e} relative)"
        f"{ias_says(sso, 'node', 6)}; theory at the mean elements {r['node_theory'] * f:.6f}",
    )
    for p in (2, 4, 6) if rates_ias is not None else ():
        rp = rates_of(run, run.main(p))
        worst = max(
            max(abs(rp[n]["node"] / rates_ias[n]["node"] - 1), abs(rp[n]["perigee"] / rates_ias[n]["perigee"] - 1))
            for n in rp
            if rp[n]["perigee_checked"]
        )
        run.metric(
            f"em{p}.rates_vs_ias15",
            worst,
            "1",
            "largest relative difference of the node and perigee rates from IAS15's (em's phase error turns the "
            "perigee at order 2)",
        )
    for name, r in rates.items():
        run.metric(f"{name}.node_rate", r["node"] * f, "deg/day", f"theory {r['node_theory'] * f:.6f}")
        run.metric(f"{name}.perigee_rate", r["perigee"] * f, "deg/day", f"theory {r['perigee_theory'] * f:.5f}")
    run.named["em8 J2/2"] = half
    run.extra.update(
        {"rates": rates, "rates_half": rates_half, "rates_ias": rates_ias, "sso_tolerance": theory_err + mean_vs_osc}
    )


def _rates_against_reboundx(run, rates, rates_ias):
    """em order 8's mean node and perigee rates against IAS15 + REBOUNDx's (skipped without it)."""
    what = "mean node and perigee rates of em order 8 against IAS15 + REBOUNDx's from the same fit, worst"
    if rates_ias is None:
        run.skip("rates-em8-vs-reboundx", what, "REBOUND IAS15 + REBOUNDx (J2)", "deg/day")
        return
    diffs, relative = [], []
    for name, r in rates.items():
        for key in ("node", "perigee") if r["perigee_checked"] else ("node",):
            diffs.append(abs(r[key] - rates_ias[name][key]))
            relative.append(diffs[-1] / abs(rates_ias[name][key]))
    f = DEG_PER_DAY
    run.check(
        "rates-em8-vs-reboundx",
        what,
        "REBOUND IAS15 + REBOUNDx (J2)",
        max(diffs) * f,
        C.POSITION_PER_ORBIT / run.case.period * f,
        "deg/day",
        f"an angle that drifts by {C.POSITION_PER_ORBIT:g} rad per orbit moves the body by at most "
        f"{C.POSITION_PER_ORBIT:g} a per orbit: the suite's position tolerance",
        f"largest relative difference {max(relative):.2g}",
    )


# -- mutual gravity ----------------------------------------------------------------------------
def _two_body(run, ias, kepler):
    c = run.case
    a = c.length
    _referee(
        run,
        "referee-ias15-kepler",
        "REBOUND IAS15 positions of both bodies, max over time",
        "the analytic solution: Kepler's relative orbit and the centre of mass's uniform motion",
        ias.position_error(kepler, a),
        "a",
        f"{ias.info['steps']} IAS15 steps",
    )
    em8 = run.main(8)
    _position(
        run,
        "position-em8-vs-kepler",
        f"em order 8 (dt = T/{c.main[8]}) positions of both bodies, max over {run.n} orbits",
        "the analytic solution",
        em8.position_error(kepler, a),
        "a",
    )
    m = c.masses
    worst, per = 0.0, []
    t_end = float(run.times[-1])
    for tr in run.em_runs.values():
        X = np.einsum("n,mnk->mk", m, tr.x) / m.sum()
        d = float(np.linalg.norm(X - (c.extra["X0"] + c.extra["V0"] * tr.t[:, None]), axis=-1).max())
        worst = max(worst, d / a)
        per.append(f"{tr.label}: {d / a:.2g}")
    p_scale = run.em_runs[(8, c.main[8])].info["momentum_scale"]
    run.check(
        "centre-of-mass",
        "the centre of mass's path, max |X(t) - (X0 + V0 t)| over the em runs",
        "uniform motion from the start",
        worst,
        (C.MOMENTUM * p_scale / m.sum() * t_end + 8 * C.EPS * float(np.abs(kepler.x).max())) / a,
        "a",
        f"P is kept to {C.MOMENTUM:g} of sum m |v|, so the centre's velocity to that / M; over the run "
        f"({t_end:.4g} s) its position to that x t, + 8 eps of the coordinates",
        "; ".join(per),
    )
    for p in (2, 4, 6, 8):
        tr = run.main(p)
        rel = tr.x[:, 0] - tr.x[:, 1]
        ref = kepler.x[:, 0] - kepler.x[:, 1]
        run.metric(
            f"em{p}.relative_orbit_error.max", np.linalg.norm(rel - ref, axis=-1).max() / a, "a", f"{tr.label}: x1 - x2"
        )
    run.metric("ias15.steps", ias.info["steps"], "1")
    _order_metrics(run, kepler, "a")


def _figure_eight(run, ias, reference):
    c = run.case
    L = c.length
    eps_err = _ias15_epsilon(run, ias, "L")
    em8 = run.main(8)
    _position(
        run,
        "position-em8-vs-ias15",
        f"em order 8 (dt = T/{c.main[8]}) positions of the three bodies, max over {run.n} periods",
        "REBOUND IAS15 on the same records",
        em8.position_error(ias, L),
        "L",
        f"IAS15's own error (epsilon test) {eps_err.max():.2g} L",
    )
    k = c.records  # the record at t = T
    back = {tr.label: float(np.linalg.norm(tr.x[k] - tr.x[0], axis=-1).max() / L) for tr in (em8, ias)}
    run.check(
        "return-after-one-period",
        "the bodies' distance from their start after one period (em order 8 and IAS15, the larger)",
        "the start: the published orbit is periodic",
        max(back.values()),
        C.RETURN_AFTER_PERIOD,
        "L",
        "the published initial conditions and period carry 8 and 9 digits (~5e-9); their growth over one period "
        "is allowed 200 times that; a wrong G, mass or time unit by 1e-7 would move them by more",
        "; ".join(f"{kk}: {v:.3g}" for kk, v in back.items()),
    )
    run.metric(
        "return.after_all_periods",
        float(np.linalg.norm(ias.x[-1] - ias.x[0], axis=-1).max() / L),
        "L",
        f"IAS15 after {run.n} periods: the published digits' drift",
    )
    run.metric("ias15.steps", ias.info["steps"], "1")
    _order_metrics(run, ias, "L")


CASE_CHECKS = {
    "j2-reboundx": _j2_reboundx,
    "j2-secular": _j2_secular,
    "mutual-two-body": _two_body,
    "figure-eight": _figure_eight,
}
