"""The ``effects`` section of ``emorbit bench`` in its tiny configuration: the structure it
returns, that the em runs it times keep the energy to round-off, that the cold runs really
filled a cache of their own. Timings are never asserted here."""

import importlib.util
import json

import pytest

from emorbit.bench import SECTIONS, effects
from emorbit.bench.common import CONFIGS
from emorbit.bench.runner import _jsonable, _sections, targets


@pytest.fixture(scope="module")
def data():
    return effects.run(CONFIGS["tiny"])


def test_the_section_is_registered():
    assert "effects" in SECTIONS and _sections()["effects"] is effects


def test_central_and_j2_rows(data):
    z = data["zonal"]
    assert set(z["rows"]) == {
        "central",
        "central + J2",
        "central one point",
        "central + J2 one point",
        "central, bare kernel",
    }
    # a central-only scene keeps the packed central-field kernels; under J2 the same point
    # masses run the packed central + zonal kernel the zonal effect declares for that set
    assert (z["central_system"], z["j2_system"]) == ("PointMasses", "PointMasses")
    assert not z["central_under_effects"] and z["j2_under_effects"]
    assert z["j2_kernel"] == "emorbit.kernels.effects.zonal_packed.chunk"
    assert data["central_path"]["reference"] == "ensemble.scene_over_bare"
    for name, row in z["rows"].items():
        assert row["steps"] > 0 and row["ns_per_particle_step"] > 0, name
        assert row["max_energy_error"] < 1e-12, (name, row["max_energy_error"])
    assert z["rows"]["central + J2"]["n"] == effects.SIZES["tiny"].n_orbits
    assert z["rows"]["central one point"]["n"] == 1
    assert data["j2_over_central"] == z["j2_over_central"] > 0 and z["scene_over_bare"] > 0


def test_mutual_rows(data):
    mu = data["mutual"]
    assert 0.999 < mu["virial_ratio"] < 1.001
    em = mu["rows"]["em"]
    assert em["steps"] > 0 and em["ms_per_step"] > 0
    assert em["energy_error"] < 1e-12, em["energy_error"]
    peer = mu["rows"]["rebound leapfrog"]
    if importlib.util.find_spec("rebound") is None:
        assert peer["status"].startswith("skipped") and mu["em_over_rebound_leapfrog"] is None
    else:
        assert peer["steps"] > 0 and 0 < peer["energy_error"] < 1.0
        assert data["mutual_em_over_rebound_leapfrog"] == mu["em_over_rebound_leapfrog"] > 0


def test_compile_rows(data):
    sets = data["compile"]["sets"]
    assert [tuple(s["effects"]) for s in sets] == list(effects.SIZES["tiny"].sets)
    for s in sets:
        assert s["cold_s"] > 0 and s["warm_s"] > 0 and len(s["warm_samples_s"]) == 1
        assert s["compile_s"] == pytest.approx(s["cold_s"] - s["warm_s"])
        assert s["cache_files"] > 0, "the cold run did not compile into the temporary cache"
        assert "compile_over_central_s" in s
    assert set(data["compile_s"]) == set(data["warm_startup_s"]) == {" + ".join(s["effects"]) for s in sets}


def test_each_effect_rows(data):
    each = data["each"]
    names = effects.SIZES["tiny"].effect_sets
    assert list(each["rows"]) == ["central", *names, "all"]
    for name, row in each["rows"].items():
        assert row["ns_per_particle_step"] > 0 and row["newton_per_substep"] >= 1, name
    assert each["rows"]["central"]["over_central"] == 1.0
    assert each["worst_single"]["name"] in names
    assert each["worst_single"]["over_central"] == max(each["rows"][n]["over_central"] for n in names)


def test_scene_compile_rows(data):
    rows = data["scenes"]["scenes"]
    assert [r["scene"] for r in rows] == list(effects.SIZES["tiny"].scenes)
    for r in rows:  # a cold run compiles: it takes more CPU than the warm run's wall time
        assert r["cold_cpu_s"] > r["set_cpu_s"] > r["warm_s"] > 0 and len(r["warm_samples_s"]) == 1
    assert data["scenes"]["floor_s"] > 0


def test_table_targets_and_json(data):
    lines = effects.table(data)
    assert any("central + J2 / central only" in line for line in lines)
    assert any("em / REBOUND leapfrog" in line for line in lines)
    assert any("each single effect" in line for line in lines)
    assert any("new set CPU s" in line for line in lines)
    assert any("the libraries' floor of every warm start" in line for line in lines)
    found = [
        t
        for t in targets({"effects": data})
        if t["target"].startswith("central + J2 <= 1.5x") or "REBOUND" in t["target"]
    ]
    assert len(found) == (2 if data["mutual_em_over_rebound_leapfrog"] is not None else 1)
    every = targets({"effects": data})
    names = effects.SIZES["tiny"].effect_sets
    assert sum(t["limit"] == effects.TARGET_SINGLE for t in every) == len(names)
    assert sum(t["limit"] == effects.TARGET_COMPILE for t in every) == len(effects.SIZES["tiny"].scenes)
    for t in every:
        assert t["met"] == (t["measured"] <= t["limit"]), t
    for t in found:  # the verdict is the comparison of the measured with the limit
        assert t["measured"] > 0 and t["met"] == (t["measured"] <= t["limit"]), t
    json.dumps(data, default=_jsonable)
