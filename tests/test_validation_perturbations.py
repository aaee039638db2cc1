"""The perturbation cases of the validation suite: drag, radiation pressure with the conical
shadow, and the Moon and the Sun, each against REBOUND IAS15 carrying the same force model.
Their quick forms must pass; the physics they rest on is asserted here with the measured
figures (em meets IAS15 at IAS15's own error, at the expected order); a force model that differs
by one part in a million, or a path an hour late, must fail them."""

import dataclasses
import json
import math

import numpy as np
import pytest
from validation_support import failures

from emorbit.cli import main
from emorbit.validation.cases import case_names, get_cases
from emorbit.validation.perturbation_cases import PERTURBATION_CASES
from emorbit.validation.perturbation_model import hermite, sample_path, shadow_conical, tidal_potential
from emorbit.validation.perturbation_runner import em_error_estimates, observed_order, run_perturbation_case

PNG = b"\x89PNG\r\n\x1a\n"


def _case(name):
    return next(iter(get_cases("quick", [name])))


def _failed(outcome):
    return {ch["id"] for ch in outcome["checks"] if not ch["passed"]}


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("perturbations")
    code = main(["validate", "--quick", "--cases", ",".join(PERTURBATION_CASES), "--report", str(out), "-q"])
    suite = json.loads((out / "results.json").read_text())
    return code, out, {c["name"]: c for c in suite["cases"]}


def _metric(case, key):
    return case["metrics"][key]["value"]


def test_the_cases_are_listed_before_the_effect_cases():
    names = list(case_names())
    assert names[names.index("brouwer-j2") + 1 : names.index("j2-reboundx")] == list(PERTURBATION_CASES)


def test_the_quick_cases_pass_with_their_figures(quick):
    code, out, cases = quick
    failed = failures(cases.values())
    assert not failed, "\n".join(failed)
    assert code == 0 and list(cases) == list(PERTURBATION_CASES)
    report = (out / "report.md").read_text()
    for name, case in cases.items():
        assert case["figures"] == [f"{name}.png"] and (out / f"{name}.png").read_bytes()[:8] == PNG
        assert f"]({name}.png)" in report
        ids = {ch["id"] for ch in case["checks"]}
        assert {"same-forces", "referee-ias15", "energy-ias15", "work-em-vs-ias15", "agreement-vs-effect"} <= ids
        assert {f"energy-em{p}" for p in (2, 4, 6, 8)} | {f"explained-em{p}" for p in (2, 4, 6, 8)} <= ids
        for ch in case["checks"]:
            assert ch["reason"] and ch["unit"] is not None


def test_drag_meets_ias15_at_its_own_error(quick):
    """1 day at 400 km: drag moves the satellite 49.8 km; em order 8 at 1 d/4096 meets IAS15 within
    1e-6 m (IAS15's own error 6e-7 m), every order converges at its order."""
    case = quick[2]["drag-ias15"]
    assert 4.9e4 < _metric(case, "effect.final") < 5.1e4
    assert _metric(case, "agreement.final") < 2e-6
    assert _metric(case, "ias15.error") < 1e-6
    for p in (2, 4, 6, 8):
        assert abs(case["convergence"][str(p)]["observed"] - p) < 0.15, p
    assert abs(_metric(case, "work.ias15") + 2950.1) < 0.1  # J/kg: a decays by 680 m


def test_radiation_pressure_through_the_shadow(quick):
    """30 days of eclipse season in GEO: 30 eclipses located; IAS15 without stops at the contacts
    errs by metres, with them by 1e-5 m; order 2 converges at 2, order 8 at least at the shadow's
    5/2 and at 8 without the shadow."""
    case = quick[2]["srp-ias15"]
    assert _metric(case, "eclipses") == 30
    assert 170 < _metric(case, "eclipse.penumbra") < 190 and 3800 < _metric(case, "eclipse.umbra_max") < 4300
    assert _metric(case, "ias15.without_contact_stops") > 1.0
    assert _metric(case, "ias15.error") < 5e-5
    assert 1.6e4 < _metric(case, "effect.final") < 1.9e4
    assert _metric(case, "agreement.final") < 3e-4
    conv = case["convergence"]
    assert abs(conv["2"]["observed"] - 2) < 0.05
    assert 2.0 <= conv["8"]["observed"] < 4.0
    assert abs(conv["8 without shadow"]["observed"] - 8) < 0.3


def test_the_moon_and_the_sun_meet_ias15_at_its_own_error(quick):
    case = quick[2]["third-body-ias15"]
    assert 4e5 < _metric(case, "effect.final") < 5e5
    assert _metric(case, "agreement.final") < 2e-5
    for p in (2, 4, 6, 8):
        assert abs(case["convergence"][str(p)]["observed"] - p) < 0.1, p
    checks = {ch["id"]: ch for ch in case["checks"]}
    assert checks["same-paths"]["value"] == 0.0  # the same samples, the same interpolant


def test_drag_one_part_in_a_million_off_fails(tmp_path):
    """B larger by 1e-6 in the reference moves it 5 cm from em: the agreement and the explained
    checks fail; em's own checks (its energy balance) do not."""
    case = _case("drag-ias15")
    model = {**case.model, "ballistic": case.model["ballistic"] * (1 + 1e-6)}
    failed = _failed(
        run_perturbation_case(dataclasses.replace(case, model=model), "quick", str(tmp_path), figures=False)
    )
    assert {"agreement-vs-effect", "explained-em8", "same-forces"} <= failed
    assert not any(f.startswith("energy-em") for f in failed)


def test_a_moon_an_hour_late_fails(tmp_path, monkeypatch):
    """The reference's Moon and Sun sampled from an epoch one hour late: the paths, the forces and
    the positions disagree."""
    from astropy.time import TimeDelta

    import emorbit.validation.perturbation_runner as runner

    late = lambda body, step, span, epoch: sample_path(body, step, span, epoch + TimeDelta(3600.0, format="sec"))  # noqa: E731
    monkeypatch.setattr(runner, "sample_path", late)
    failed = _failed(run_perturbation_case(_case("third-body-ias15"), "quick", str(tmp_path), figures=False))
    assert {"same-paths", "same-forces", "agreement-vs-effect", "explained-em8"} <= failed


def test_error_estimates_and_orders():
    """Step doubling recovers a C h^q error; the order fit reads q; the envelope takes the
    largest of each octave; points at IAS15's floor are left out."""

    class Tr:
        def __init__(self, x):
            self.x = np.array([[0.0, 0.0, 0.0], [x, 0.0, 0.0]])

    q, c = 2.5, 3e6
    runs = {n: Tr(c * n**-q) for n in (1024, 2048, 4096)}
    est = em_error_estimates(runs, q)
    for n in runs:
        assert est[n] == pytest.approx(c * n**-q, rel=1e-12)
    order, used = observed_order([1024, 2048, 4096, 8192], [c * n**-q for n in (1024, 2048, 4096, 8192)], 1e-30)
    assert order == pytest.approx(q) and len(used) == 4
    order, used = observed_order([1000, 1400, 2000, 2800], [1.0, 2.0, 0.1, 0.05], 1e-30, envelope=True)
    assert used == [(1400, 2.0), (2000, 0.1)] and order == pytest.approx(math.log(20) / math.log(2000 / 1400))
    assert math.isnan(observed_order([1000, 2000], [1.0, 1e-6], 1e-6)[0])


def test_reference_shadow_matches_emorbits_kernel():
    """The reference's conical shadow (Montenbruck & Gill's acos form) against emorbit's kernel
    (atan2 form) at 2000 geometries through a GEO eclipse: within 3e-8 (the acos form's loss near
    a contact), equal outside the penumbra."""
    from emorbit.effects.srp import SUN_RADIUS
    from emorbit.kernels.effects.radiation import shadow_conical as kernel

    rng = np.random.default_rng(4)
    sun = np.array([1.496e11, 0.0, 0.0])
    r, R = 4.2164e7, 6378100.0
    ang = np.pi + rng.uniform(-0.2, 0.2, 2000)
    z = rng.uniform(-1.2, 1.2, 2000) * R
    worst = 0.0
    for a, zz in zip(ang, z):
        d = np.array([r * math.cos(a), r * math.sin(a), zz])
        mine, theirs = shadow_conical(*d, *sun, R, SUN_RADIUS), kernel(*d, *sun, R, SUN_RADIUS)
        worst = max(worst, abs(mine - theirs))
        if theirs in (0.0, 1.0):
            assert mine == theirs or abs(mine - theirs) < 3e-8
    assert worst < 3e-8


def test_reference_tidal_rate_is_the_derivative_of_its_potential():
    """dU/dt of the reference (the work's integrand) against a central difference of its own
    potential along the Moon's path; its acceleration against the potential's gradient."""
    from astropy.time import Time

    from emorbit.effects.ephemeris import GM
    from emorbit.validation.perturbation_model import _tidal

    path = sample_path("moon", 3600.0, 86400.0, Time("2026-01-01T00:00:00", scale="tdb"))
    x = (4.2e7, 1.0e6, -3.0e6)
    for t in (1000.0, 50000.0):
        s, w = hermite(t, path.step, path.k0, path.rows)
        acc, rate = _tidal(*x, s, w, GM["moon"])
        u = [tidal_potential(*x, *hermite(t + h, path.step, path.k0, path.rows)[0], GM["moon"]) for h in (-1.0, 1.0)]
        assert rate == pytest.approx((u[1] - u[0]) / 2.0, rel=1e-6)
        grad = [
            (tidal_potential(*(np.array(x) + e), *s, GM["moon"]) - tidal_potential(*(np.array(x) - e), *s, GM["moon"]))
            / 2.0
            for e in np.eye(3)
        ]
        assert np.allclose(acc, -np.array(grad), rtol=1e-6, atol=0)
