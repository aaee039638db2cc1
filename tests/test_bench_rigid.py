"""The rigid-body bench section: structure and emorbit's conservation in a tiny run (seconds).
Timings are printed by the bench, never asserted here."""

import json

import pytest

from emorbit.bench import rigid as bench_rigid


@pytest.fixture(scope="module")
def section():
    return bench_rigid.run(config="tiny")


def test_section_is_json_and_complete(section):
    back = json.loads(json.dumps(section))
    assert back["name"] == "rigid" and back["config"] == "tiny"
    for key in ("machine", "load_average", "versions", "scaling", "field", "torque_free", "targets"):
        assert key in back
    rows = back["scaling"]["rows"]
    assert [r["mass_points"] for r in rows] == [8 * r**3 for r in bench_rigid.CONFIGS["tiny"].refinements]
    for r in rows:
        for gravity in ("volume", "point"):
            assert r[gravity]["us_per_step"] > 0 and r[gravity]["repeats"] >= 1 and r[gravity]["newton_iterations"] > 0
    assert {"us_per_point", "intercept_us"} <= set(back["scaling"]["fit"]["volume"])
    for t in back["targets"]:  # a verdict is the measured figure against its limit, or None without one
        assert "target" in t
        measured = t.get("measured", t.get("ratio"))
        if measured is not None:
            assert t["met"] is (measured <= t["limit"]), t
        else:
            assert t["met"] is None and t.get("note"), t
    text = bench_rigid.table(section)
    assert "targets" in text and "torque-free" in text


def test_peers_run_or_say_why(section):
    """A peer is either measured or skipped with a reason; it never stops the bench."""
    bsk = section["field"]["basilisk"]
    ex = section["torque_free"]["exudyn"]
    for peer in (bsk, ex):
        assert peer["status"] == "ok" or peer["status"].startswith("skipped: ")
    if bsk["status"] == "ok":
        assert [r["dt"] for r in bsk["rows"]] == list(bench_rigid.FIELD_DTS)
        assert all(r["us_per_step"] > 0 and r["jacobi_drift"] >= 0 for r in bsk["rows"])
    if ex["status"] == "ok":
        assert {(r["node"], r["dt"]) for r in ex["implicit"]} == {
            (n, dt) for n in ("euler-parameters", "rotation-vector") for dt in bench_rigid.EXUDYN_DTS
        }
        assert all(isinstance(r["converged"], bool) for r in ex["trapezoidal"])


def test_emorbit_conserves_to_round_off(section):
    """emorbit's energy and angular momentum in every row: torque-free at Exudyn's steps and
    10x larger, and the 8-point body in the field at Basilisk's steps (orders 2 and 4)."""
    free = section["torque_free"]["emorbit"]["rows"]
    assert sorted({r["dt"] for r in free}) == sorted(set(bench_rigid.FREE_DTS) | {0.1})
    field = section["field"]["emorbit"]["rows"]
    assert {(r["order"], r["dt"]) for r in field} == {(o, dt) for o in (2, 4) for dt in bench_rigid.FIELD_DTS}
    for r in free + field:
        assert r["energy_error"] <= 1e-13, r
        assert r["angular_momentum_error"] <= 1e-13, r


def test_missing_peers_are_skipped(section, monkeypatch):
    """Without bsk and exudyn installed the peers say so, and the targets that need them too."""
    import sys

    for mod in (
        "Basilisk",
        "Basilisk.simulation",
        "Basilisk.utilities",
        "exudyn",
        "exudyn.utilities",
        "exudyn.itemInterface",
    ):
        monkeypatch.setitem(sys.modules, mod, None)
    bsk, ex = bench_rigid._Basilisk(), bench_rigid._Exudyn()
    assert bsk.skipped.startswith("skipped: Basilisk not importable")
    assert ex.skipped.startswith("skipped: Exudyn not importable")
    cfg = bench_rigid.CONFIGS["tiny"]
    monkeypatch.setattr(bench_rigid, "FIELD_DTS", (60.0,))
    monkeypatch.setattr(bench_rigid, "FREE_DTS", (0.1,))
    field, free = bench_rigid._field(cfg, bsk), bench_rigid._torque_free(cfg, ex)
    assert field["basilisk"] == {"status": bsk.skipped, "rows": []}
    assert free["exudyn"]["status"] == ex.skipped and free["exudyn"]["implicit"] == []
    targets = bench_rigid._targets(section["scaling"], field, free)
    assert sum(t["met"] is None for t in targets) == 2
    field["case"] = section["field"]["case"]
    text = bench_rigid.table({**section, "field": field, "torque_free": free, "targets": targets})
    assert text.count("skipped") >= 2
