"""The ``gravity-field`` section of ``emorbit bench`` in its tiny configuration (degrees 2 and
20, 6000 s of LEO, one heyoka tolerance): its registration, the structure it returns, finite
figures and positive ratios, the targets' verdicts, the table, the paths without heyoka and
without a long double wider than double. Timings are never asserted here. About 10 s of CPU
with Numba's cache filled (heyoka compiles four integrators and a cfunc without its caches)."""

import json
import math

import pytest

from emorbit.bench import SECTIONS, gravity_field
from emorbit.bench.common import CONFIGS
from emorbit.bench.runner import _jsonable, _sections, targets

pytest.importorskip("heyoka", reason='EGM2008 comes from heyoka: pip install "emorbit[field]"')


def _finite(x) -> bool:
    return isinstance(x, float) and math.isfinite(x)


@pytest.fixture(scope="module")
def data():
    return gravity_field.run(CONFIGS["tiny"])


def test_the_section_is_registered():
    assert "gravity-field" in SECTIONS and _sections()["gravity-field"] is gravity_field


def test_cost_rows(data):
    assert data["config"] == "tiny"
    rows = data["cost"]["rows"]
    size = gravity_field.SIZES["tiny"]
    assert list(rows) == ["central", *(f"degree {n}" for n in size.degrees), "zonal J2"]
    assert rows["central"]["over_central"] == 1.0 and not rows["central"]["under_effects"]
    for name, r in rows.items():
        assert _finite(r["us_per_step"]) and r["us_per_step"] > 0, (name, r)
        assert _finite(r["over_central"]) and r["over_central"] > 0, (name, r)
        assert r["steps"] > 0 and r["newton_per_substep"] >= 1, (name, r)
    for n in size.degrees:
        r = rows[f"degree {n}"]
        assert r["under_effects"] and r["effect"] == "gravity_field" and r["degree"] == n


def test_work_precision_points(data):
    wp = data["work_precision"]
    size = gravity_field.SIZES["tiny"]
    ref = wp["reference"]
    assert _finite(ref["cpu_s"]) and ref["method"] and ref["check"]
    assert ref["check_difference"] < 1e-12, ref  # two independent integrations agree (measured 1.2e-15)
    em = [p for p in wp["points"] if p["engine"] == "emorbit"]
    hy = [p for p in wp["points"] if p["engine"] == "heyoka"]
    assert len(em) == sum(len(d) for _, d in size.fixed) + sum(len(e) for _, e in size.etas)
    assert [p["tolerance"] for p in hy] == list(size.tolerances)
    for p in wp["points"]:
        assert p["status"] == "ok", p
        for key in ("cpu_s", "position_error", "jacobi_drift"):
            assert _finite(p[key]) and p[key] >= 0, (key, p)
        assert p["steps"] > 0
    for p in hy:
        assert _finite(p["compile_s"]) and p["compile_s"] > 0 and p["order"] > 0
    assert wp["heyoka_pot_compile_s"] > 0


def test_reach_and_targets(data):
    wp = data["work_precision"]
    assert [r["accuracy"] for r in wp["reach"]] == list(gravity_field.ACCURACIES)
    for row in wp["reach"]:
        assert set(row["engines"]) == {"em fixed", "em adaptive", "heyoka"}
        for key in ("em_fixed_over_heyoka", "em_adaptive_over_heyoka", "em_best_over_heyoka"):
            r = row[key]
            assert r is None or (_finite(r) and r > 0), (key, row)
        for r in row["engines"].values():
            assert r is None or (_finite(r["cpu_s"]) and r["cpu_s"] > 0)
    ts = data["targets"]
    assert len(ts) == len(gravity_field.ACCURACIES)
    for t in ts:
        if t.get("measured") is not None:
            assert t["met"] is (t["measured"] <= t["limit"]), t
        else:
            assert t["met"] is None and t["note"], t
    assert targets({"gravity_field": data})[-len(ts) :] == ts


def test_table_and_json(data):
    text = "\n".join(gravity_field.table(data))
    assert "gravity field (tiny)" in text and "degree 20" in text and "reference:" in text
    assert "targets:" in text
    json.dumps(data, default=_jsonable)


def test_skipped_without_heyoka(monkeypatch):
    def missing():
        raise ImportError("no heyoka")

    monkeypatch.setattr(gravity_field, "_egm", missing)
    section = gravity_field.run(CONFIGS["tiny"])
    assert section["status"].startswith("skipped: ")
    assert all(t["met"] is None for t in section["targets"])
    assert section["status"] in "\n".join(gravity_field.table(section))


def test_reference_without_long_double(monkeypatch):
    """Where long double is no wider than double, the reference is em order 8 at a small step,
    checked against heyoka at machine precision (over 6000 s: measured 2.4e-15 of a apart)."""
    monkeypatch.setattr(gravity_field, "_wide_long_double", lambda: False)
    mu, radius = gravity_field._egm()
    x0, v0, a = gravity_field.leo_state(mu, radius)
    ref = gravity_field._reference(gravity_field._Heyoka(), (x0, v0), 6000.0, a)
    assert ref["method"].startswith("em order 8") and "no wider than double" in ref["method"]
    assert ref["check"].startswith("heyoka") and ref["check_difference"] < 1e-12, ref
