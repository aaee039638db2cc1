"""Parameter sweeps: the sweep file's schema, the runs it expands to, failure isolation,
resume, the process and Dask backends against running the scenes one by one, and a worker
killed in the middle of a sweep."""

from __future__ import annotations

import copy
import csv
import json
import math
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from emorbit.cli import main
from emorbit.errors import InputError
from emorbit.scene import Scene, load_scene
from emorbit.sweep import load_sweep, parse_key, parse_sweep, read_summary, run_sweep

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

DT = 0.464758  # the paper's step, s

#: 200 tiny runs: 20 speeds at aphelion x 10 steps, 5 steps each
GRID = f"""
[sweep]
scene = "paper-ellipse"
seed = 11

[set]
integrator.output_every = 1

[[parameter]]
key = "integrator.dt"
values = [{", ".join(f'"{DT * (1 + k / 10)!r} s"' for k in range(10))}]

[[parameter]]
key = "body[satellite].velocity[1]"
range = {{ start = 0.30, stop = 0.40, num = 20 }}
unit = "m / s"

[[parameter]]
key = "integrator.t_end"
values = ["{5 * DT!r} s"]
"""


def _strip(rows, drop=("wall_time",)):
    return [{k: v for k, v in r.items() if k not in drop} for r in rows]


def _same(a, b) -> bool:
    """Rows equal, value for value (floats bit for bit; nan equals nan)."""
    if len(a) != len(b):
        return False
    for r, s in zip(a, b):
        if list(r) != list(s):
            return False
        for k in r:
            x, y = r[k], s[k]
            if isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y):
                continue
            if x != y:
                return False
    return True


def _one_by_one(speeds, dts, t_end):
    """The grid's rows computed without the sweep machinery: each scene edited by hand,
    built and run in this process, its figures taken from the Result and the Simulation."""
    base = load_scene("paper-ellipse")
    data0 = tomllib.loads(base.text)
    rows = []
    for dt in dts:
        for v in speeds:
            data = copy.deepcopy(data0)
            data["integrator"]["dt"] = dt
            data["integrator"]["t_end"] = t_end
            data["integrator"]["output_every"] = 1
            data["body"][0]["velocity"][1] = f"{float(v)!r} m / s"
            scene = Scene(data, base.text)
            sim = scene.build()
            res = sim.run(t_end=scene.t_end, every=1, progress=False)
            el = sim.elements("satellite", si=True)
            rows.append(
                {
                    "integrator.dt": dt,
                    "body[satellite].velocity[1]": float(v),
                    "status": "completed",
                    "t_final": float(res.si.time[-1]),
                    "records": len(res),
                    "energy_error": float(np.abs(res.relative_energy_error()).max()),
                    "angular_momentum_error": float(res.relative_angular_momentum_error().max()),
                    "newton_mean": res.mean_newton_iterations(),
                    "newton_max": float(np.max(res.newton_iterations[1:])),
                    **{f"satellite/{n}": float(getattr(el, n)) for n in ("a", "e", "i", "raan", "argp", "nu")},
                }
            )
    return rows


# -- the sweep file ------------------------------------------------------------------------
def test_keys_parse_and_unknown_keys_are_named():
    assert parse_key("body[0].velocity[1]") == ("body", 0, "velocity", 1)
    assert parse_key("body[sat.1].mass") == ("body", ("name", "sat.1"), "mass")
    assert parse_key("integrator.dt") == ("integrator", "dt")
    cases = {
        '[sweep]\nscene = "paper-ellipse"\nsed = 1\n': "sweep.sed",
        '[sweep]\nscene = "paper-ellipse"\n[[parameter]]\nkey = "integrator.dt"\n'
        'value = ["1 s"]\n': "parameter[0].value",
        '[sweep]\nscene = "paper-ellipse"\n[[parameter]]\nkey = "integrator.dtt"\nvalues = ["1 s"]\n': "integrator.dtt",
        '[sweep]\nscene = "paper-ellipse"\n[[parameter]]\nkey = "body[3].mass"\nvalues = ["1 kg"]\n': "body[3]",
        '[sweep]\nscene = "paper-ellipse"\n[[parameter]]\nkey = "body[moon].mass"\nvalues = ["1 kg"]\n': "moon",
        '[sweep]\nscene = "paper-ellipse"\n[[parameter]]\nkey = "body[0].spin"\nvalues = [1]\n': "body[0].spin",
        '[sweep]\nscene = "paper-ellipse"\n[[parameter]]\nkey = "body[0].velocity[1]"\n'
        "range = { start = 0.3, stop = 0.4, num = 3 }\n": "parameter[0].unit",  # the scene wants a unit
        '[sweep]\nscene = "paper-ellipse"\n[[parameter]]\nkey = "integrator.order"\n'
        'range = { start = 2, stop = 4, step = 2 }\nunit = "s"\n': "parameter[0].unit",  # a bare number wanted
        '[sweep]\nscene = "paper-ellipse"\n[set]\n"integrator.dtt" = "1 s"\n': "set.integrator.dtt",
        '[sweep]\nscene = "no-such-scene"\n': "sweep.scene",
        '[sweep]\nscene = "paper-ellipse"\nsamples = 3\n': "sweep.samples",  # identical runs
        '[sweep]\nscene = "paper-ellipse"\n[[parameter]]\nkey = "integrator.dt"\n'
        'random = { distribution = "cauchy", low = 1, high = 2 }\nunit = "s"\n': "parameter[0].random.distribution",
    }
    for text, named in cases.items():
        with pytest.raises(InputError) as info:
            parse_sweep(text)
        assert named in str(info.value), (text, str(info.value))


def test_runs_expand_in_order_with_reproducible_seeds():
    text = """
[sweep]
scene = "paper-ellipse"
seed = 42
samples = 3

[[parameter]]
key = "integrator.dt"
values = ["0.4 s", "0.2 s"]

[[parameter]]
key = "integrator.order"
values = [2, 4]

[[parameter]]
key = "body[0].position[0]"
random = { distribution = "uniform", low = 9.5, high = 10.5 }
unit = "m"
"""
    sweep = parse_sweep(text)
    tasks = sweep.tasks()
    assert len(sweep) == len(tasks) == 12
    # product, the last list fastest, then the samples
    assert [(t.values["integrator.dt"], t.values["integrator.order"]) for t in tasks[::3]] == [
        ("0.4 s", 2),
        ("0.4 s", 4),
        ("0.2 s", 2),
        ("0.2 s", 4),
    ]
    children = np.random.SeedSequence(42).spawn(12)
    for t, child in zip(tasks, children):
        assert t.seed == int(child.generate_state(1, np.uint64)[0])
        assert t.values["body[0].position[0]"] == float(np.random.default_rng(child).uniform(9.5, 10.5))
    assert len({t.values["body[0].position[0]"] for t in tasks}) == 12
    # the same file gives the same runs; more samples keep the runs they share
    assert [t.values for t in parse_sweep(text).tasks()] == [t.values for t in tasks]
    more = parse_sweep(text.replace("samples = 3", "samples = 5")).tasks()
    assert more[0].values == tasks[0].values and more[0].digest == tasks[0].digest
    other = parse_sweep(text.replace("seed = 42", "seed = 43")).tasks()
    assert other[0].values["body[0].position[0]"] != tasks[0].values["body[0].position[0]"]
    # zip: the lists side by side
    z = parse_sweep(text.replace("samples = 3", 'combine = "zip"')).tasks()
    assert [(t.values["integrator.dt"], t.values["integrator.order"]) for t in z] == [("0.4 s", 2), ("0.2 s", 4)]
    scene = sweep.scene_for(tasks[4])
    assert scene.data["body"][0]["position"][0] == f"{tasks[4].values['body[0].position[0]']!r} m"
    assert scene.data["integrator"]["order"] == 4
    assert sweep.scene.data["integrator"]["order"] == 2  # the base scene is untouched


# -- failures, files and resume (in this process: the serial backend) -----------------------
FAILING = f"""
[sweep]
scene = "paper-ellipse"
combine = "zip"

[set]
integrator.t_end = "{5 * DT!r} s"
integrator.output_every = 1

[[parameter]]
key = "integrator.dt"
values = ["{DT!r} s", "100 s", "-1 s", "{DT / 2!r} s"]

[[parameter]]                    # one Newton iteration cannot solve a step of two orbits
key = "integrator.max_newton_iterations"
values = [50, 1, 50, 50]
"""


def test_failed_runs_are_recorded_and_the_sweep_goes_on(tmp_path):
    res = run_sweep(parse_sweep(FAILING), tmp_path / "out", backend="serial")
    status = [r["status"] for r in res.rows]
    assert status == ["completed", "failed", "failed", "completed"]
    assert res.counts == {"total": 4, "skipped": 0, "ran": 4, "completed": 2, "failed": 2, "not_run": 0, "retried": 0}
    assert res.rows[1]["error"].startswith("IntegrationError: ") and "max_newton_iterations" in res.rows[1]["error"]
    assert res.rows[2]["error"].startswith("InputError: integrator.dt")
    assert res.rows[0]["records"] == 6 and res.rows[0]["energy_error"] < 1e-14
    assert res.rows[1]["records"] == 1 and res.rows[1]["t_final"] == 0.0  # kept the records before the failure
    assert math.isnan(res.rows[2]["energy_error"])
    with h5py.File(tmp_path / "out/runs/run-000001.h5", "r") as f:
        assert f.attrs["status"] == "failed" and "raise integrator.max_newton_iterations" in f.attrs["error"]
        assert f["sweep"].attrs["index"] == 1 and "digest" in f["sweep"].attrs
        assert "# sweep run 1: integrator.dt" in f.attrs["scene"]
    with h5py.File(tmp_path / "out/runs/run-000002.h5", "r") as f:
        assert f.attrs["status"] == "failed" and "time" not in f  # bad input: nothing ran
    csv_lines = (tmp_path / "out/summary.csv").read_text().splitlines()
    assert len(csv_lines) == 5
    # every numeric column names its unit in the header ("[1]": dimensionless); text columns
    # (and parameters written with their units, such as "0.464758 s") have none
    assert csv_lines[0].split(",") == [
        "run [1]",
        "seed [1]",
        "integrator.dt",
        "integrator.max_newton_iterations [1]",
        "status",
        "error",
        "t_final [s]",
        "records [1]",
        "energy_error [1]",
        "angular_momentum_error [1]",
        "newton_mean [1]",
        "newton_max [1]",
        "satellite/a [m]",
        "satellite/e [1]",
        "satellite/i [rad]",
        "satellite/raan [rad]",
        "satellite/argp [rad]",
        "satellite/nu [rad]",
        "wall_time [s]",
        "file",
    ]
    with open(tmp_path / "out/summary.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [r["t_final [s]"] for r in table] == [repr(r["t_final"]) for r in res.rows]
    assert float(table[0]["satellite/a [m]"]) == res.rows[0]["satellite/a"]
    assert res.units["t_final"] == "s" and res.units["integrator.max_newton_iterations"] == "1"
    with h5py.File(tmp_path / "out/summary.h5", "r") as f:
        assert json.loads(f["summary"].attrs["units"]) == res.units
    assert _same(_strip(read_summary(tmp_path / "out")), _strip(res.rows))


def test_resume_skips_finished_runs_and_redoes_unfinished_ones(tmp_path):
    out = tmp_path / "out"
    sweep = parse_sweep(FAILING)
    first = run_sweep(sweep, out, backend="serial")
    again = run_sweep(sweep, out, backend="serial")
    assert again.counts["skipped"] == 4 and again.counts["ran"] == 0
    assert _same(again.rows, first.rows)  # wall times too: read back from the files
    runs = out / "runs"
    # a run whose file is gone, a run file that never finished under the final name, and the
    # temporary file of an attempt whose worker died
    (runs / "run-000000.h5").unlink()
    with h5py.File(runs / "run-000003.h5", "a") as f:
        f.attrs["status"] = "running"
    (runs / ".run-000002.h5.0123456789ab.tmp").write_bytes(b"half")
    third = run_sweep(sweep, out, backend="serial")
    assert third.counts["skipped"] == 2 and third.counts["ran"] == 2
    assert _same(_strip(third.rows), _strip(first.rows))
    assert sorted(os.listdir(runs)) == [f"run-00000{i}.h5" for i in range(4)]
    # failed runs are kept unless asked for
    fourth = run_sweep(sweep, out, backend="serial", rerun_failed=True)
    assert fourth.counts["ran"] == 2 and fourth.counts["skipped"] == 2
    # one folder holds one sweep
    changed = parse_sweep(FAILING.replace("100 s", "50 s"))
    with pytest.raises(InputError, match="different sweep"):
        run_sweep(changed, out, backend="serial")
    replaced = run_sweep(changed, out, backend="serial", overwrite=True)
    assert replaced.counts["ran"] == 1 and replaced.rows[1]["integrator.dt"] == "50 s"


def test_command_line(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text(FAILING)
    assert main(["sweep", str(f), "--list"]) == 0
    assert "100 s" in capsys.readouterr().out
    assert main(["sweep", str(f), "-o", str(tmp_path / "o"), "--serial", "-q"]) == 1  # two runs failed
    assert len(read_summary(tmp_path / "o")) == 4
    ok = tmp_path / "ok.toml"
    ok.write_text(FAILING.replace('"100 s", "-1 s", ', "").replace("1, 50, 50", "50"))
    assert main(["sweep", str(ok), "-o", str(tmp_path / "o2"), "--serial"]) == 0
    assert "2 completed, 0 failed" in capsys.readouterr().out
    bad = tmp_path / "bad.toml"
    bad.write_text(FAILING.replace('key = "integrator.dt"', 'key = "integrator.step"'))
    assert main(["sweep", str(bad), "-o", str(tmp_path / "o3")]) == 2
    assert "integrator.step" in capsys.readouterr().err
    assert not (tmp_path / "o3").exists()  # nothing created


# -- how many runs: counted before anything is listed ---------------------------------------
#: 1e16 runs: two ranges of 1e8 values each
HUGE = """
[sweep]
scene = "paper-ellipse"

[[parameter]]
key = "integrator.dt"
range = { start = 0.1, stop = 0.2, num = 100000000 }
unit = "s"

[[parameter]]
key = "body[satellite].velocity[1]"
range = { start = 0.30, stop = 0.40, step = 1e-9 }
unit = "m / s"
"""

#: 1,000,000 runs: more than the default limit, 100,000
MILLION = """
[sweep]
scene = "paper-ellipse"

[[parameter]]
key = "integrator.dt"
range = { start = 0.1, stop = 0.2, num = 1000 }
unit = "s"

[[parameter]]
key = "body[satellite].velocity[1]"
range = { start = 0.30, stop = 0.40, num = 1000 }
unit = "m / s"
"""


def test_a_sweep_over_the_run_limit_is_refused_before_it_is_expanded():
    with pytest.raises(InputError) as info:
        parse_sweep(MILLION)
    message = str(info.value)
    assert message.startswith("parameter: the sweep has 1,000,000 runs"), message
    assert "parameter[0] (integrator.dt): 1,000 values" in message
    assert "parameter[1] (body[satellite].velocity[1]): 1,000 values" in message
    assert "100,000" in message and "max_runs" in message and "--max-runs" in message
    # raised on purpose: in the file, or by the caller (which wins over the file)
    start = time.perf_counter()
    sweep = parse_sweep(MILLION.replace('scene = "paper-ellipse"', 'scene = "paper-ellipse"\nmax_runs = 1000000'))
    assert len(sweep) == 1_000_000
    first = next(iter(sweep.iter_tasks()))  # one at a time, without making the other runs
    assert first.index == 0 and first.values["integrator.dt"] == 0.1
    assert time.perf_counter() - start < 30
    assert len(parse_sweep(MILLION, max_runs=1_000_000)) == 1_000_000
    with pytest.raises(InputError, match=r"more than max_runs \(12\)"):
        parse_sweep(
            MILLION.replace('scene = "paper-ellipse"', 'scene = "paper-ellipse"\nmax_runs = 10000000'), max_runs=12
        )
    for bad in ("0", '"many"', "1.5", "true"):
        with pytest.raises(InputError, match="sweep.max_runs"):
            parse_sweep(MILLION.replace('scene = "paper-ellipse"', f'scene = "paper-ellipse"\nmax_runs = {bad}'))
    with pytest.raises(InputError, match="max_runs"):
        parse_sweep(MILLION, max_runs=0)
    # samples count too, and a zip is as long as its longest list (checked before zip's lengths)
    samples = '[sweep]\nscene = "paper-ellipse"\nsamples = 1000000000000\n[[parameter]]\nkey = "body[0].mass"\n'
    samples += 'random = { distribution = "uniform", low = 1, high = 2 }\nunit = "kg"\n'
    with pytest.raises(
        InputError, match=r"^sweep.samples: the sweep has 1,000,000,000,000 runs \(samples = 1,000,000,000,000\)"
    ):
        parse_sweep(samples)
    endless = HUGE.replace("start = 0.30, stop = 0.40, step = 1e-9", "start = -1e308, stop = 1e308, step = 1e-300")
    with pytest.raises(InputError, match=r"the sweep has over 1e308 runs"):
        parse_sweep(endless, max_runs=10**18)
    zipped = HUGE.replace('scene = "paper-ellipse"', 'scene = "paper-ellipse"\ncombine = "zip"')
    with pytest.raises(InputError, match=r"the sweep has 100,000,001 runs .* side by side with "):
        parse_sweep(zipped)


def test_zip_of_random_parameters_only_has_its_samples():
    text = '[sweep]\nscene = "paper-ellipse"\ncombine = "zip"\nsamples = 3\n[[parameter]]\nkey = "body[0].mass"\n'
    sweep = parse_sweep(text + 'random = { distribution = "uniform", low = 1, high = 2 }\nunit = "kg"\n')
    assert len(sweep) == 3 and [t.index for t in sweep.tasks()] == [0, 1, 2]


def test_a_huge_sweep_fails_at_once_on_the_command_line(tmp_path):
    """1e16 runs: exit 2 with one line naming the parameters and the count, for --list and
    for a run, within seconds (a child process, so that a regression cannot hang the suite)."""
    f = tmp_path / "huge.toml"
    f.write_text(HUGE)
    for args in (["--list"], ["-o", str(tmp_path / "out")]):
        done = subprocess.run(
            [sys.executable, "-m", "emorbit.cli", "sweep", str(f), *args],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert done.returncode == 2, done.stderr[-2000:]
        lines = done.stderr.strip().splitlines()
        assert len(lines) == 1 and "10,000,000,100,000,000 runs" in lines[0], done.stderr
        assert "integrator.dt" in lines[0] and "body[satellite].velocity[1]" in lines[0]
        assert done.stdout == ""
    assert not (tmp_path / "out").exists()
    # the limit raised on the command line
    small = tmp_path / "small.toml"
    small.write_text(MILLION.replace("num = 1000 }", "num = 3 }"))
    assert main(["sweep", str(small), "--list", "--max-runs", "8"]) == 2
    assert main(["sweep", str(small), "--list", "--max-runs", "9"]) == 0


def test_list_shows_each_value_with_its_unit(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text(
        """
[sweep]
scene = "paper-ellipse"
samples = 2

[[parameter]]
key = "integrator.dt"
values = ["0.4 s", "0.2 s"]

[[parameter]]
key = "body[satellite].velocity[1]"
range = { start = 0.30, stop = 0.40, num = 2 }
unit = "m / s"

[[parameter]]
key = "body[satellite].position[0]"
random = { distribution = "uniform", low = 9.5, high = 10.5 }
unit = "m"

[[parameter]]
key = "integrator.order"
values = [2]
"""
    )
    assert main(["sweep", str(f), "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split("\t") == [
        "run",
        "seed",
        "integrator.dt",
        "body[satellite].velocity[1]",
        "body[satellite].position[0]",
        "integrator.order",
    ]
    assert len(lines) == 9
    tasks = load_sweep(f).tasks()
    for line, t in zip(lines[1:], tasks):
        cells = line.split("\t")
        assert cells[:4] == [
            str(t.index),
            str(t.seed),
            t.values["integrator.dt"],
            "0.3 m / s" if t.index % 4 < 2 else "0.4 m / s",
        ]
        assert cells[4] == f"{t.values['body[satellite].position[0]']!r} m" and cells[5] == "2"


#: the longest an MPI sweep of the tests may take (seconds) before its process group is killed
MPI_TIMEOUT = 300


def _run_in_own_session(args, timeout: float):
    """Run a command in a session (and process group) of its own; kill that group at the end.

    MPI starts helpers (MPICH's ``mpiexec`` and ``hydra_pmi_proxy``, the spawned workers)
    beside the process that loads it. The tests never load MPI themselves: a pytest worker that
    did would start them in the terminal's process group, and their cleanup at its exit could
    kill the test run. Here they live in the command's own group, which is killed when the
    command ends or runs past ``timeout`` (the test then fails).

    Returns
    -------
    tuple
        (exit code, stdout and stderr together).
    """
    proc = subprocess.Popen(args, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        pytest.fail(f"{' '.join(map(str, args))} ran past {timeout} s; its process group was killed\n{out[-2000:]}")
    finally:
        try:  # helpers left behind in the group (the leader has exited; the group may live on)
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
    return proc.returncode, out


def test_mpi_backend_says_what_is_missing(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "mpi4py", None)  # import mpi4py raises ImportError, installed or not
    f = tmp_path / "s.toml"
    f.write_text(FAILING)
    assert main(["sweep", str(f), "-o", str(tmp_path / "o"), "--mpi"]) == 2
    assert "mpi4py" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


# -- backends against running the scenes one by one -----------------------------------------
@pytest.fixture(scope="module")
def grid_reference():
    sweep = parse_sweep(GRID)
    assert len(sweep) == 200
    speeds = np.linspace(0.30, 0.40, 20)
    dts = [f"{DT * (1 + k / 10)!r} s" for k in range(10)]
    return sweep, _one_by_one(speeds, dts, f"{5 * DT!r} s")


def _check_against(rows, reference):
    assert [r["run"] for r in rows] == list(range(len(reference)))
    for row, ref in zip(rows, reference):
        got = {k: row[k] for k in ref}
        assert got == ref, (row["run"], got, ref)


@pytest.fixture(scope="module")
def process_summary(grid_reference, tmp_path_factory):
    sweep, _ = grid_reference
    out = tmp_path_factory.mktemp("process") / "out"
    res = run_sweep(sweep, out, backend="process", workers=2)
    return res, read_summary(out)


def test_process_backend_equals_running_one_by_one(grid_reference, process_summary):
    _, reference = grid_reference
    res, summary = process_summary
    assert res.counts["completed"] == 200 and res.counts["ran"] == 200
    _check_against(summary, reference)


def test_dask_local_cluster_equals_one_by_one_and_the_process_backend(grid_reference, process_summary, tmp_path):
    pytest.importorskip("distributed", reason="dask.distributed is not installed (pip install 'emorbit[cluster]')")
    sweep, reference = grid_reference
    res = run_sweep(sweep, tmp_path / "out", backend="dask", workers=2)
    assert res.counts["completed"] == 200 and res.counts["ran"] == 200
    summary = read_summary(tmp_path / "out")
    _check_against(summary, reference)
    drop = ("wall_time",)
    assert _same(_strip(summary, drop), _strip(process_summary[1], drop))
    assert (tmp_path / "out/summary.csv").read_text().count("\n") == 201


def test_mpi_backend_equals_the_process_backend(process_summary, tmp_path):
    """``emorbit sweep --mpi`` in a subprocess of its own session, as a user runs it: an MPI
    singleton that spawns two workers. MPI is never loaded into the pytest process."""
    f = tmp_path / "grid.toml"
    f.write_text(GRID)
    args = [sys.executable, "-m", "emorbit.cli", "sweep", str(f), "-o", str(tmp_path / "out")]
    code, out = _run_in_own_session([*args, "--mpi", "--workers", "2", "-q"], MPI_TIMEOUT)
    if code == 2 and "the MPI backend needs mpi4py" in out:
        pytest.skip(f"the MPI backend needs mpi4py with an MPI library: {out.strip()[-300:]}")
    assert code == 0, out[-2000:]
    assert "mpi4py.MPI" not in sys.modules  # MPI was never loaded into this pytest process
    assert _same(_strip(read_summary(tmp_path / "out")), _strip(process_summary[1]))
    assert len(read_summary(tmp_path / "out")) == 200


# -- a worker killed in the middle of a sweep -----------------------------------------------
#: 24 runs of about 0.2 s each (1e6 steps), so that a worker is busy when it is killed
SLOW = f"""
[sweep]
scene = "paper-ellipse"

[set]
integrator.output_every = 100000
integrator.t_end = "{1_000_000 * DT!r} s"

[[parameter]]
key = "body[0].velocity[1]"
range = {{ start = 0.30, stop = 0.40, num = 24 }}
unit = "m / s"
"""


def _kill_third(killed, threads):
    def on_result(row, worker):
        threads.add(worker["threads"])
        if len(killed) == 0 and row["run"] >= 2:
            killed.append(worker["pid"])
            os.kill(worker["pid"], signal.SIGKILL)  # it has already taken its next run

    return on_result


def _no_loss_no_duplicate(res, out):
    assert res.counts["completed"] == 24 and res.counts["failed"] == 0
    assert [r["run"] for r in res.rows] == list(range(24))
    files = sorted(os.listdir(out / "runs"))
    assert files == [f"run-{i:06d}.h5" for i in range(24)]  # one file each, no temporary left
    for name in files:
        with h5py.File(out / "runs" / name, "r") as f:
            assert f.attrs["status"] == "completed" and f["time"].shape == (11,)


@pytest.fixture(scope="module")
def killed_process_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("kill") / "out"
    killed, threads = [], set()
    res = run_sweep(parse_sweep(SLOW), out, backend="process", workers=2, on_result=_kill_third(killed, threads))
    return res, out, killed, threads


def test_killing_a_process_worker_loses_nothing_and_duplicates_nothing(killed_process_sweep):
    res, out, killed, threads = killed_process_sweep
    assert len(killed) == 1
    assert threads == {1}  # Numba ran one thread per worker
    assert res.counts["retried"] >= 1  # the broken pool's runs went to a new pool
    _no_loss_no_duplicate(res, out)


def test_killing_a_dask_worker_loses_nothing_and_duplicates_nothing(killed_process_sweep, tmp_path):
    """On an existing cluster (``scheduler=``, as ``--scheduler tcp://...`` does): Dask's nanny
    restarts the killed worker and the scheduler gives its run to a worker again."""
    distributed = pytest.importorskip(
        "distributed", reason="dask.distributed is not installed (pip install 'emorbit[cluster]')"
    )
    killed, threads = [], set()
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=None, env={"NUMBA_NUM_THREADS": "1"}
    ) as cluster:
        res = run_sweep(
            parse_sweep(SLOW),
            tmp_path / "out",
            scheduler=cluster.scheduler_address,
            on_result=_kill_third(killed, threads),
        )
    assert len(killed) == 1 and threads == {1}
    _no_loss_no_duplicate(res, tmp_path / "out")
    assert _same(_strip(res.rows), _strip(killed_process_sweep[0].rows))


def test_sweep_file_paths_are_relative_to_the_file(tmp_path):
    scene = tmp_path / "scenes" / "mine.toml"
    scene.parent.mkdir()
    scene.write_text(load_scene("paper-ellipse").text)
    sweep_file = tmp_path / "sweeps" / "s.toml"
    sweep_file.parent.mkdir()
    sweep_file.write_text(FAILING.replace('"paper-ellipse"', '"../scenes/mine.toml"'))
    sweep = load_sweep(sweep_file)
    assert sweep.scene.source == str(scene) or os.path.samefile(sweep.scene.source, scene)
