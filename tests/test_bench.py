"""``emorbit bench`` in a seconds-long configuration: the JSON has the keys the issue names,
the sections hang together, the figures are written. Timings are never asserted here."""

import json

import numpy as np
import pytest

from emorbit.bench import SECTIONS, limits
from emorbit.bench.runner import run_bench
from emorbit.bench.workprecision import _pareto
from emorbit.cli import main
from emorbit.kernels.pointmass.packed import BLOCK, LD

KEYS = {
    "ensemble": (
        "em_particle_steps_per_s",
        "em_1thread_particle_steps_per_s",
        "rebound_leapfrog_particle_steps_per_s",
        "rebound_whfast_particle_steps_per_s",
    ),
    "single": ("em_ns_per_step", "em_fast_ns_per_step", "rebound_leapfrog_ns_per_step", "rebound_ias15_ns_per_step"),
    "startup": ("cold_s", "warm_s"),
}


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    d = tmp_path_factory.mktemp("bench")
    path = d / "out.json"
    assert (
        run_bench(
            ["single", "ensemble", "work-precision", "startup"],
            json_path=str(path),
            plots_dir=str(d / "plots"),
            config="tiny",
        )
        == 0
    )
    return json.loads(path.read_text()), d


def test_json_has_the_issue_keys(result):
    data, _ = result
    for section, keys in KEYS.items():
        for key in keys:
            value = data[section][key]  # a None or a NaN (an empty timing loop) fails here
            assert isinstance(value, float) and np.isfinite(value), (section, key, value)
    assert {"cpu", "cores", "simd"} <= set(data["machine"])
    assert data["versions"]["emorbit"] and data["versions"]["rebound"]
    for t in data["targets"]:
        # each verdict is the comparison its text names, of the figure it reports
        at_least = ">=" in t["target"]
        assert at_least != ("<=" in t["target"]), t["target"]
        expected = t["measured"] >= t["limit"] if at_least else t["measured"] <= t["limit"]
        assert t["met"] is expected, t
    assert len(data["targets"]) == 8  # em and em roundoff="fast" for two of them


def test_sections_hang_together(result):
    data, _ = result
    single = data["single"]["rows"]
    assert {(r["method"], r["order"]) for r in single if r["engine"] == "emorbit"} == {
        (m, o) for m in ("em", "midpoint", "leapfrog") for o in (2, 4, 6, 8)
    }
    assert {r["method"] for r in single if r["engine"] == "rebound"} == {"leapfrog", "whfast", "ias15"}
    ens = data["ensemble"]
    assert ens["rows"]["em 1 thread"]["max_energy_error"] < 1e-12  # em keeps every particle's energy
    assert ens["limits"]["kernels"]["em"]["sqrts"] == 2 and ens["limits"]["kernels"]["em"]["divisions"] == 3
    assert ens["rows"]['em roundoff="fast" 1 thread']["max_energy_error"] < 1e-12
    assert ens["limits"]["kernels"]["em_fast"]["sqrts"] == 2 and ens["limits"]["kernels"]["em_fast"]["divisions"] == 3
    # the same counts, one measurement: a busy machine once gave em_fast half em's all-threads bound
    assert (
        ens["limits"]["kernels"]["em_fast"]["bound_per_s_all_threads"]
        == ens["limits"]["kernels"]["em"]["bound_per_s_all_threads"]
    )
    # the floor has em's counts, and the fraction targets say how much of the bound it reaches
    assert (ens["floor"]["sqrts"], ens["floor"]["divisions"]) == (2, 3)
    fraction = [t for t in data["targets"] if "division / square-root bound" in t["target"]]
    assert len(fraction) == 2 and all(t["ceiling"] > 0 and "floor" in t["note"] for t in fraction)
    for orbit in data["work_precision"]["orbits"]:
        engines = {(p["engine"], p["method"]) for p in orbit["points"]}
        assert {("emorbit", m) for m in ("em", "midpoint", "leapfrog")} <= engines
        assert {("rebound", m) for m in ("ias15", "whfast", "leapfrog")} <= engines
        em = [p for p in orbit["points"] if p["method"] == "em" and p.get("status") == "ok"]
        assert em and all(p["energy_error"] < 1e-12 for p in em)
        adaptive = [p for p in orbit["points"] if p["method"] == "em adaptive" and p.get("status") == "ok"]
        assert adaptive and all(p["energy_error"] < 1e-12 and p["steps"] > 0 for p in adaptive)
        assert any(p["pareto_position"] for p in orbit["points"])
        assert orbit["heyoka"] == "ok" or orbit["heyoka"].startswith(("skipped", "failed"))


def test_figures_written(result):
    data, d = result
    figs = data["work_precision"]["figures"]
    assert len(figs) == 2
    for f in figs:
        with open(f, "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"


def test_pareto_front():
    points = [{"cpu_s": 1.0, "e": 1e-3}, {"cpu_s": 2.0, "e": 1e-2}, {"cpu_s": 3.0, "e": 1e-6}, {"cpu_s": 0.5, "e": 1.0}]
    assert _pareto(points, "e") == [3, 0, 2]


def test_command_line(capsys):
    """The subcommand is registered and rejects an unknown section."""
    with pytest.raises(SystemExit):
        main(["bench", "--only", "nonsense"])
    assert "invalid choice" in capsys.readouterr().err
    assert set(SECTIONS) == {"single", "ensemble", "work-precision", "startup", "rigid", "elastic", "effects"}


def test_precompile_parts_share_no_kernel(result):
    """The two compiling processes (emorbit.bench.precompile) each hold a method's one-orbit
    kernel with its packed kernel (``_range_*`` calls ``_points_*``), so neither waits on nor
    repeats the other's big compilations; their jobs compile exactly what the sections call
    (after the sections ran, in ``result``, the jobs add no compiled signature); sections
    without point-mass kernels start no helper, and the helper's command line runs."""
    import subprocess
    import sys

    from emorbit.bench import precompile as pc
    from emorbit.kernels.pointmass import packed as kern

    dispatchers = [
        getattr(kern, f"_{kind}_{m}")
        for kind in ("range", "points", "parallel")
        for m in ("em", "em_plain", "midpoint", "leapfrog")
    ]
    before = [len(d.signatures) for d in dispatchers]
    assert sum(before) > 0
    pc.run_part(0, ["single", "ensemble"])
    pc.run_part(1, ["single", "ensemble"])
    assert [len(d.signatures) for d in dispatchers] == before

    part_of = {}
    for part, _, _, method, roundoff in pc._JOBS:
        part_of.setdefault((method, roundoff), set()).add(part)
    assert all(len(parts) == 1 for parts in part_of.values()), part_of
    assert {p for p, *_ in pc._JOBS} == {0, 1}
    assert pc.precompile(["rigid", "elastic", "startup"]) is None
    done = subprocess.run([sys.executable, "-m", "emorbit.bench.precompile", "1", "rigid"], timeout=300)
    assert done.returncode == 0
    bad = subprocess.run(
        [sys.executable, "-m", "emorbit.bench.precompile", "2"], timeout=300, capture_output=True, text=True
    )
    assert bad.returncode == 2 and "PART 0 or 1" in bad.stderr


def _floor_energy(W):
    x = np.array([W[k * LD : k * LD + BLOCK] for k in range(3)])
    v = np.array([W[(3 + k) * LD : (3 + k) * LD + BLOCK] for k in range(3)])
    return 0.5 * (v * v).sum(axis=0) - 1.0 / np.sqrt((x * x).sum(axis=0)), np.sqrt((x * x).sum(axis=0))


def test_floor_takes_orbit_steps():
    """The bench's floor loop is a real (first-order) orbit step, compensated or not: over 1000
    steps of h = 0.05 (a quarter to two thirds of an orbit) the energy of every point changes by
    less than 5 % (measured 2.7 %), the orbits stay near-circular, the compensated and plain
    runs agree to round-off, and the compensations stay at round-off of the state. On all
    threads each block takes exactly the one-thread steps."""
    e0, r0 = _floor_energy(limits.floor_block())
    runs = {}
    for compensated in (True, False):
        W = limits.floor_block()
        limits._floor(W, limits._FLOOR_H, 1.0, compensated, 1000)
        e, r = _floor_energy(W)
        assert np.all(np.abs(e / e0 - 1.0) < 0.05)
        assert r.min() > 3.0 and r.max() < 15.0  # radii 5-10, e up to about 0.2
        runs[compensated] = W
    comp, plain = runs[True], runs[False]
    assert np.abs(comp[: 6 * LD] - plain[: 6 * LD]).max() < 1e-11 * np.abs(plain[: 6 * LD]).max()
    for k in range(6):  # each compensation row kept: nonzero, at round-off of its state row
        state, carried = comp[k * LD : k * LD + BLOCK], comp[(6 + k) * LD : (6 + k) * LD + BLOCK]
        assert 0 < np.abs(carried).max() < 1e-14 * np.abs(state).max(), k
    many = np.tile(limits.floor_block(), (3, 1))
    limits._floor_parallel(many, limits._FLOOR_H, 1.0, True, 1000)
    assert all(np.array_equal(row, comp) for row in many)
