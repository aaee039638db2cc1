"""``emorbit bench`` in a seconds-long configuration: the JSON has the keys the issue names,
the sections hang together, the figures are written. Timings are never asserted here."""

import json

import numpy as np
import pytest

from emorbit.bench import SECTIONS, limits
from emorbit.bench.runner import run_bench
from emorbit.bench.workprecision import ACCURACIES, ENGINES, _emorbit_adaptive, _pareto, reach
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
    assert len(data["targets"]) == 6  # em and em roundoff="fast" for two of them


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
    # the floor has em's counts; the fractions of the bound are information, no longer targets
    assert (ens["floor"]["sqrts"], ens["floor"]["divisions"]) == (2, 3)
    for suffix in ("1thread", "all_threads"):
        assert 0 < ens[f"em_ceiling_fraction_of_bound_{suffix}"] and 0 < ens[f"em_fraction_of_bound_{suffix}"]
    assert not [t for t in data["targets"] if "division / square-root bound" in t["target"]]
    for orbit in data["work_precision"]["orbits"]:
        engines = {(p["engine"], p["method"]) for p in orbit["points"]}
        assert {("emorbit", m) for m in ("em", "midpoint", "leapfrog")} <= engines
        assert {("rebound", m) for m in ("ias15", "whfast", "leapfrog")} <= engines
        for p in orbit["points"]:
            assert {"engine", "method", "order", "status"} <= set(p), p
            if p["status"] == "ok":
                assert p["cpu_s"] > 0 and p["position_error"] >= 0 and p["energy_error"] >= 0, p
        em = [p for p in orbit["points"] if p["method"] == "em" and p.get("status") == "ok"]
        assert em and all(p["energy_error"] < 1e-12 for p in em)
        assert any(p["pareto_position"] for p in orbit["points"])
        assert orbit["heyoka"] == "ok" or orbit["heyoka"].startswith(("skipped", "failed"))


def _adaptive(orbit, method="em"):
    """{order: [(eta, point), ...] from the largest eta} of an orbit's adaptive em (or tfe) points."""
    out = {}
    for p in orbit["points"]:
        if p.get("adaptive") and p["method"] == method:
            out.setdefault(p["order"], []).append((p["tolerance"], p))
    return {o: sorted(pts, key=lambda t: -t[0]) for o, pts in out.items()}


def test_work_precision_adaptive_points(result):
    """Adaptive em points are em points with eta as their tolerance (fixed-step ones keep dt):
    on each of the three orbits (e = 0.99 among them) every one ran, kept the energy to
    round-off, and its error falls with eta: at order 4 by at least 8x from eta 0.02 to 0.008
    (the nominal (0.02/0.008)^4 = 39x; measured 21-37x), and order 8 is the more accurate."""
    orbits = result[0]["work_precision"]["orbits"]
    assert [o["name"] for o in orbits] == ["paper", "e09", "e099"]
    assert [round(o["e"], 3) for o in orbits] == [0.667, 0.9, 0.99]
    assert all(abs(o["a"] - 6.0) < 1e-4 for o in orbits)
    for orbit in orbits:
        for p in orbit["points"]:
            if p["engine"] == "emorbit" and p["method"] == "em":
                assert ("tolerance" in p) == bool(p.get("adaptive")) != ("dt" in p), p
        series = _adaptive(orbit)
        assert set(series) == {4, 8}
        for order, pts in series.items():
            assert [eta for eta, _ in pts] == [0.02, 0.008]
            for _, p in pts:
                assert p["status"] == "ok" and p["steps"] > 0, p
                assert p["energy_error"] < 1e-12, p
            errors = [p["position_error"] for _, p in pts]
            assert errors[1] < errors[0], (orbit["name"], order, errors)
            if order == 4:
                assert errors[0] > 8 * errors[1], (orbit["name"], errors)
        for (_, p4), (_, p8) in zip(series[4], series[8]):
            assert p8["position_error"] < p4["position_error"], orbit["name"]
        tfe = _adaptive(orbit, "tfe")
        assert list(tfe) == [6] and [eta for eta, _ in tfe[6]] == [0.02, 0.008]
        assert all(p["status"] == "ok" and p["energy_error"] < 1e-12 for _, p in tfe[6]), tfe
        errors = [p["position_error"] for _, p in tfe[6]]
        assert errors[0] > 20 * errors[1], (orbit["name"], errors)  # order 6: 244x nominal, 41-9651x measured


def test_work_precision_targets(result):
    """Each orbit's targets table names every engine at 1e-6, 1e-9 and 1e-12 of a, each entry
    the cheapest way its engine gets there (a point, or an interpolation between two
    neighbouring points that bracket it); the verdicts compare what they report."""
    section = result[0]["work_precision"]
    for orbit in section["orbits"]:
        assert [row["accuracy"] for row in orbit["targets"]] == list(ACCURACIES)
        for row in orbit["targets"]:
            assert set(row["engines"]) == set(ENGINES)
            for name, r in row["engines"].items():
                assert r == reach(orbit["points"], name, row["accuracy"])
                if r is not None:
                    assert r["cpu_s"] > 0
                    if "between" not in r:  # a measured point of that order reaches it
                        assert any(
                            p.get("status") == "ok"
                            and (p["cpu_s"], p["order"]) == (r["cpu_s"], r["order"])
                            and p["position_error"] <= row["accuracy"]
                            for p in orbit["points"]
                        ), r
            if orbit["heyoka"] != "ok":
                assert row["engines"]["heyoka"] is None and row["adaptive_over_heyoka"] is None
            ours, ias = row["engines"]["em adaptive"], row["engines"]["ias15"]
            if ours and ias:
                assert row["adaptive_over_ias15"] == pytest.approx(ours["cpu_s"] / ias["cpu_s"])
        # adaptive em order 8 reaches 1e-9 of a on every orbit in two orbits' time
        assert orbit["targets"][1]["engines"]["em adaptive"]["order"] == 8
    assert len(section["targets"]) == 3 * len(section["orbits"])
    for orbit, t in zip(section["orbits"], section["targets"][2::3]):  # emorbit's best scheme against heyoka
        row = orbit["targets"][ACCURACIES.index(1e-9)]
        ours = [row["engines"][k] for k in ("em adaptive", "em fixed", "tfe", "tfe adaptive") if row["engines"][k]]
        if "measured" in t:
            best = min(r["cpu_s"] for r in ours)
            assert t["measured"] == pytest.approx(best / row["engines"]["heyoka"]["cpu_s"]), t
    for t in section["targets"]:
        assert t["note"], t
        if "measured" in t:
            assert t["met"] is (t["measured"] <= t["limit"]), t
        elif t["met"] is None:
            assert t["note"].startswith("skipped"), t


def test_reach_interpolates_between_neighbours():
    """The least CPU time to an error: a point that reaches it, or the log-log interpolation
    between two neighbouring settings of one order (of one peer) that bracket it; the best
    order wins; nothing past the measured points."""
    pts = [
        {"engine": "emorbit", "method": "em", "adaptive": True, "status": "ok", "order": 4, "tolerance": t, **v}
        for t, v in (
            (0.02, {"cpu_s": 1e-3, "position_error": 1e-4}),
            (0.01, {"cpu_s": 1e-2, "position_error": 1e-8}),
        )
    ]
    pts.append({**pts[0], "order": 8, "cpu_s": 5e-3, "position_error": 1e-7})
    pts.append({**pts[0], "adaptive": False, "tolerance": None, "dt": 0.1, "cpu_s": 1e-9})  # fixed steps: not adaptive
    r = reach(pts, "em adaptive", 1e-6)
    assert r["order"] == 4 and r["between"] == [0.02, 0.01] and r["cpu_s"] == pytest.approx(10**-2.5)
    assert reach(pts, "em adaptive", 1e-7) == {"cpu_s": 5e-3, "order": 8, "setting": 0.02}
    assert reach(pts, "em adaptive", 1e-3)["cpu_s"] == 1e-3
    assert reach(pts, "em adaptive", 1e-9) is None
    assert reach(pts, "ias15", 1.0) is None
    # a peer's points are one series, whatever order each took (heyoka's follows its tolerance)
    peer = [
        {
            "engine": "heyoka",
            "method": "taylor",
            "status": "ok",
            "order": o,
            "tolerance": t,
            "cpu_s": c,
            "position_error": e,
        }
        for o, t, c, e in ((12, 1e-9, 1e-3, 1e-6), (15, 1e-12, 4e-3, 1e-10))
    ]
    r = reach(peer, "heyoka", 1e-8)
    assert r["between"] == [1e-9, 1e-12] and r["cpu_s"] == pytest.approx(2e-3)


def test_the_adaptive_run_that_once_stalled_keeps_its_energy():
    """e = 0.99, order 2, eta = 0.02, 100 orbits: the control variable once drifted from orbit
    to orbit (multiplied by (r_a / r_p)**1.5 on the way in) until the steps shrank without
    end. The timed run (landing at its end only) finishes in 5838 steps, and the run that
    lands on the records keeps the energy at round-off (measured 1.4e-13; 1.4e-12 is 10x)."""
    from emorbit.bench.common import aphelion_state, period

    x0, v0 = aphelion_state(6.0, 0.99)
    res = _emorbit_adaptive(x0, v0, 2, 0.02, period(x0, v0), 100)
    assert "status" not in res, res.get("status")
    dE = np.abs(np.asarray(res["energies"]) / res["energies"][0] - 1).max()
    assert dE <= 1.4e-12, f"|dE/E0| = {dE:.3g}, measured 1.4e-13"
    assert res["steps"] < 20_000


def test_figures_written(result):
    data, d = result
    figs = data["work_precision"]["figures"]
    assert len(figs) == 1 and figs[0].endswith("work-precision.png")  # one column per orbit
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
    assert set(SECTIONS) == {
        "single",
        "ensemble",
        "work-precision",
        "startup",
        "rigid",
        "rigid-precision",
        "gravity-field",
        "perturbed",
        "elastic",
        "effects",
        "gpu",
    }


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
