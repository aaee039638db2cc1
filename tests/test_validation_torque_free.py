"""The validation case ``torque-free``: the Dzhanibekov flip of emorbit's box against the
Jacobi-elliptic period of Euler's equations, DOP853 and Exudyn. Its quick form passes every
check; a referee with an inertia 1e-3 off fails the checks that referee emorbit (and not its
invariants); without Exudyn its check is skipped, not failed; the analytic period holds in both
regimes and in the small-wobble limit."""

import dataclasses
import math
import sys

import numpy as np
import pytest
from validation_support import PNG, failed_ids, passed_cases, quick_report

from emorbit.validation import torque_free as tf

I_BOX = np.array([2.5, 5.0, 6.5])  # the 3 x 2 x 1 m box of 1 kg/m3


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    return quick_report(tmp_path_factory, tf.NAMES)


def test_the_quick_case_passes_every_check(quick):
    case = passed_cases(quick, ["torque-free"], tf.NOTE)["torque-free"]
    ids = {ch["id"] for ch in case["checks"]}
    assert {"same-body", "energy", "angular-momentum", "flip-analytic", "large-step-invariants"} <= ids
    assert {f"flip-{k}em{p}" for p in (2, 4) for k in ("", "order-")} <= ids
    for p in (2, 4, 6, 8):
        assert {f"rate-em{p}", f"attitude-em{p}", f"order-rate-em{p}", f"order-attitude-em{p}"} <= ids
    assert {"referee-rate", "referee-attitude", "exudyn-same-body"} <= ids
    # the flip interval converges to Jacobi's T/2 = 2 K / rate (measured 2.7e-5 at T/4000, order 2)
    assert case["convergence"]["flip-em2"]["error"][1] < 1e-4


def test_exudyn_loses_energy_where_em_keeps_it(quick):
    """At w dt = 0.1 to 1 em keeps E and L to round-off; Exudyn's generalized-alpha loses at least
    5.9e-4 of its energy (measured: 5.9e-4 to 5.1e-2 with rotation-vector nodes, up to 5 with
    Euler parameters, whose Newton iteration fails at fixed steps of w dt >= 0.4)."""
    _, _, suite = quick
    metrics = suite["cases"][0]["metrics"]
    em = metrics["large_steps.em2"]["value"]
    assert max(max(r["energy"], r["angular_momentum"]) for r in em) < 1e-14
    rows = metrics["exudyn"]["value"]
    if isinstance(rows, str):
        pytest.skip(rows)
    assert min(r["energy"] for r in rows) > 1e-4
    assert any(not r["converged"] for r in rows if r["node"] == "euler-parameters")


def _small(**settings):
    """Two periods, orders 2 and 4, one large step, no Exudyn (about 1.5 s)."""
    case = tf.cases("quick")["torque-free"]
    s = dict(case.settings)
    s.update(
        steps={2: (2000, 4000), 4: (500, 1000)},
        large_dts=(0.5,),
        exudyn_nodes=(),
        tolerance={2: s["tolerance"][2], 4: s["tolerance"][4]},
    )
    s.update(settings)
    return dataclasses.replace(case, settings=s)


def test_a_referee_with_a_wrong_inertia_fails(tmp_path):
    """The referee's (and the analytic period's) I_y 1e-3 too large: the flip interval moves by
    1.6e-3 (em's error at T/4000 is 2.7e-5), the rates by 0.038 |w0| (em's: 5.8e-4); the
    referee stays consistent with itself and em keeps its invariants."""
    wrong = _small(referee_inertia=I_BOX * np.array([1.0, 1.0 + 1e-3, 1.0]))
    failed = failed_ids(tf.run(wrong, "quick", str(tmp_path), figures=False))
    assert {"same-body", "flip-em2", "flip-em4", "flip-order-em2", "rate-em2", "rate-em4", "attitude-em4"} <= failed
    assert not failed & {"energy", "angular-momentum", "large-step-invariants", "flip-analytic", "referee-rate"}


def test_without_exudyn_its_check_is_skipped_and_the_case_passes(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "exudyn", None)  # `import exudyn` raises ImportError
    out = tf.run(_small(exudyn_nodes=("rotation-vector",)), "quick", str(tmp_path), figures=True)
    assert out["passed"] and out["error"] is None, failed_ids(out)
    (ch,) = [ch for ch in out["checks"] if ch["id"] == "exudyn-same-body"]
    assert ch["skipped"].startswith("skipped: Exudyn not installed") and ch["passed"]
    assert out["metrics"]["exudyn"]["value"].startswith("skipped: Exudyn not installed")
    assert (tmp_path / "torque-free.png").read_bytes()[:8] == PNG


def test_the_period_in_the_small_wobble_limit():
    """Near the axis of largest inertia k -> 0, K -> pi/2: T = 2 pi / (w3 sqrt((I3 - I1)(I3 - I2)
    / (I1 I2))), the frequency of the linearised wobble."""
    w3 = 2.0
    jac = tf.jacobi_period(I_BOX, [1e-7, 1e-7, w3])
    I1, I2, I3 = I_BOX
    wobble = 2 * math.pi / (w3 * math.sqrt((I3 - I1) * (I3 - I2) / (I1 * I2)))
    assert jac["regime"] == "I3" and abs(jac["period"] / wobble - 1) < 1e-12


@pytest.mark.parametrize("omega0, regime", [((0.0, 2.0, 0.05), "I3"), ((0.05, 2.0, 0.0), "I1")])
def test_the_period_against_dop853_on_both_sides_of_the_separatrix(omega0, regime):
    """The sign changes of w_y of DOP853 (rtol 1e-13) are T/2 apart on either side of the
    separatrix (measured within 3e-14 relative over two periods)."""
    jac = tf.jacobi_period(I_BOX, omega0)
    ref = tf.run_referee(I_BOX, omega0, np.linspace(0.0, 2 * jac["period"], 5), tf.RTOL)
    flips = np.array(ref.info["flips"])
    assert jac["regime"] == regime and flips.size == 4
    assert np.abs(np.diff(flips) / jac["flip"] - 1).max() < 3e-13


def test_the_period_refuses_the_separatrix_and_equal_moments():
    with pytest.raises(ValueError, match="separatrix"):
        tf.jacobi_period(I_BOX, [0.0, 2.0, 0.0])
    with pytest.raises(ValueError, match="inertia"):
        tf.jacobi_period([1.0, 1.0, 2.0], [0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="omega0"):
        tf.jacobi_period(I_BOX, [0.1, math.nan, 0.3])
    with pytest.raises(ValueError, match="mode"):
        tf.cases("slow")


def test_flip_times_find_the_zeros_on_a_cubic_through_four_records():
    """sin(t + 0.3) + 0.2 sampled every 0.1 (zeros where the curvature is not zero): found to
    4.8e-7 (a straight line through two records: 2.6e-4)."""
    t = np.arange(0.0, 10.0, 0.1)
    w = np.zeros((t.size, 3))
    w[:, 1] = np.sin(t + 0.3) + 0.2
    a = math.asin(0.2)
    exact = np.array([math.pi + a, 2 * math.pi - a, 3 * math.pi + a]) - 0.3
    zeros = tf.flip_times(t, w, 1)
    assert zeros.size == 3 and np.abs(zeros - exact).max() < 4.8e-6
