"""The rigid-body work-precision section (``emorbit bench --only rigid-precision``): its JSON,
em's energy at round-off, em's observed order, the reach interpolation, the peers-absent path.
The quick section runs once (about 30 s); timings are printed by the bench, never asserted."""

import json
import math
import sys

import numpy as np
import pytest

from emorbit.bench import rigid_precision as rp
from emorbit.bench.runner import run_bench


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    d = tmp_path_factory.mktemp("rigid_precision")
    path = d / "out.json"
    assert run_bench(["rigid-precision"], json_path=str(path), plots_dir=str(d), config="quick") == 0
    return json.loads(path.read_text()), d


def test_json_has_the_documented_shape(bench):
    result, d = bench
    s = result["rigid_precision"]
    assert s["name"] == "rigid-precision" and s["config"] == "quick"
    assert [c["name"] for c in s["cases"]] == list(rp.CONFIGS["quick"].cases)
    assert (d / "rigid-work-precision.png").is_file() and s["figures"] == [str(d / "rigid-work-precision.png")]
    for case in s["cases"]:
        ref = case["reference"]
        assert isinstance(case["fixed_cpu_s"], float) and 0 < case["fixed_cpu_s"] < 1.0, case["fixed_cpu_s"]
        assert ref["attitude_check"] < 1e-10 and ref["omega_check"] < 1e-10, ref  # the reference is below 1e-10
        if case["kind"] == "field":
            assert ref["gradient_model_floor"]["attitude"] < 1e-10, ref
        series = {p["series"] for p in case["points"]}
        assert {rp.series_name(m, o) for m in rp.EM_METHODS for o in rp.METHOD_ORDERS[m]} <= series
        for p in case["points"]:
            assert p["engine"] in ("emorbit", "exudyn", "basilisk") and ("dt" in p or "tolerance" in p)
            if p["status"] == "ok":
                for key in ("cpu_s", "attitude_error", "omega_error", "energy_error"):
                    assert isinstance(p[key], float) and math.isfinite(p[key]) and p[key] >= 0, (key, p)
            else:
                assert p["status"].startswith(("skipped: ", "failed: ", "diverged")), p
        assert [r["accuracy"] for r in case["reach"]] == list(rp.ACCURACIES)
        for row in case["reach"]:
            assert set(row["engines"]) == set(rp.GROUPS)
        for peer, status in case["peers"].items():
            assert status == "ok" or status.startswith("skipped: "), (peer, status)
    n_targets = 3 * len(s["cases"]) + 1
    assert len(s["targets"]) == n_targets and result["targets"][-n_targets:] == s["targets"]
    for t in s["targets"]:  # a verdict is the measured figure against its limit, or a reason
        assert t["target"]
        if t.get("measured") is not None:
            assert t["met"] is (t["measured"] <= t["limit"]), t
        else:
            assert t["met"] is None or (t["met"] is False and t.get("note")), t
    assert "rigid work-precision" in "\n".join(rp.table(s))


def test_em_energy_at_round_off_on_every_point(bench):
    """Measured: at most 3.5e-15 over the quick run's em points (2026-11, 2-core EPYC)."""
    s = bench[0]["rigid_precision"]
    em = [p for c in s["cases"] for p in c["points"] if p["method"] == "em" and p["status"] == "ok"]
    assert len(em) >= 20
    worst = max(p["energy_error"] for p in em)
    assert worst <= 4e-14, f"em energy error {worst:.2e} over 4e-14 (3.5e-15 measured)"
    assert s["targets"][-1]["met"] is True
    tfe = [p for c in s["cases"] for p in c["points"] if p["method"] == "tfe" and p["status"] == "ok"]
    assert len(tfe) >= 10 and max(p["energy_error"] for p in tfe) <= 1e-12


def test_em_errors_fall_at_its_order():
    """Attitude error against dt, torque-free at omega_y = 2: slopes 2 and 4 (measured 2.00 and 3.99)."""
    body = rp._Body("free2")
    body.ref = body.reference()
    for order, dts in ((2, (0.02, 0.01)), (4, (0.04, 0.02))):
        errs = [rp._emorbit(body, "em", order, dt)["attitude_error"] for dt in dts]
        slope = math.log(errs[0] / errs[1]) / math.log(dts[0] / dts[1])
        assert abs(slope - order) < 0.3, f"order {order}: slope {slope:.2f} from errors {errs}"


def _pt(series, dt, err, cpu, engine="emorbit", method="em"):
    p = {"engine": engine, "method": method, "series": series, "dt": dt, "cpu_s": cpu, "status": "ok"}
    return {**p, "attitude_error": err, "omega_error": err}


def test_reach_interpolates_within_a_series_and_never_extrapolates():
    pts = [_pt("em 2", 0.1, 1e-2, 1.0), _pt("em 2", 0.01, 1e-6, 10.0), _pt("em 4", 0.1, 1e-5, 50.0)]
    r = rp.reach(pts, "em", 1e-4)
    assert r["series"] == "em 2" and r["between"] == [0.1, 0.01]
    assert r["cpu_s"] == pytest.approx(math.sqrt(10.0), rel=1e-12)  # halfway in log error: halfway in log time
    assert rp.reach(pts, "em", 1e-2)["cpu_s"] == 1.0  # a point that reaches it
    assert rp.reach(pts, "em", 1e-7) is None  # past the finest point: nothing extrapolated
    assert rp.reach(pts, "exudyn", 1e-2) is None  # the group has no points
    with pytest.raises(KeyError, match="group"):
        rp.reach(pts, "rebound", 1e-2)


def test_attitude_angle_at_small_and_large_angles():
    from scipy.spatial.transform import Rotation

    for angle in (1e-12, 1e-6, 1.0, 3.0):
        R = Rotation.from_rotvec(angle * np.array([0.6, 0.0, 0.8])).as_matrix()
        assert rp.attitude_angle(np.eye(3), R) == pytest.approx(angle, rel=1e-6)


def test_missing_peers_are_skipped(monkeypatch):
    """Without bsk and exudyn the section says why for each peer, and the targets are skipped."""
    for mod in ("Basilisk", "Basilisk.simulation", "Basilisk.utilities", "exudyn", "exudyn.utilities"):
        monkeypatch.setitem(sys.modules, mod, None)
    monkeypatch.setitem(rp.CASES, "free2", {**rp.CASES["free2"], "dts": (0.1,)})
    monkeypatch.setitem(rp.CONFIGS, "tiny", rp.Config(("free2",), 1, 0.02, (1e-6,), orders=(2,)))
    s = rp.run(config="tiny")
    (case,) = s["cases"]
    assert case["peers"]["exudyn"].startswith("skipped: Exudyn not importable")
    assert case["peers"]["basilisk"].startswith("skipped: Basilisk not importable")
    assert {p["engine"] for p in case["points"]} == {"emorbit"}
    for t in s["targets"][:-1]:
        assert t["met"] is None and "skipped: " in t["note"], t
    assert "skipped: " in "\n".join(rp.table(s))
