"""Run files are never destroyed, never trusted blindly, and say what they hold: --overwrite
against a file another run writes, files replaced under a run, resume of edited files, resume
to an earlier time, plot of files that are not run files, steps redone in sub-steps, units of
every attribute and state array, and the wall-clock checkpoint interval."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest
from shared_scenes import reuse_structure

import emorbit
import emorbit.pacing as pacing
from emorbit.cli import main

#: a run of a few seconds, started in another process
LONG = ["paper-ellipse", "--t-end", "9295160 s", "--every", "2000", "-q"]


def _start(path, *extra):
    cmd = [sys.executable, "-m", "emorbit.cli", "run", *LONG, "-o", str(path), *extra]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _hdf5(path) -> bool:
    try:
        with open(path, "rb") as fh:
            return fh.read(8) == b"\x89HDF\r\n\x1a\n"
    except OSError:
        return False


def _wait_for(path, proc, timeout=120.0):
    """Until the run's file has its name (an HDF5 file at the path)."""
    deadline = time.monotonic() + timeout
    while not _hdf5(path):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.01)


def _complete(path) -> None:
    """The file opens, is completed, and holds every record of the run."""
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "completed"
        n = f.attrs["steps"] // f.attrs["output_every"] + 1
        assert f["time"].shape == (n,) and f["bodies/satellite/position"].shape == (n, 3)
        assert f["checkpoint"].attrs["records"] == n
        assert np.all(np.isfinite(f["bodies/satellite/position"][()]))


# -- 1. --overwrite never destroys a file another run writes ------------------------------------------
@pytest.mark.parametrize("first_overwrites", [False, True])
def test_overwrite_refuses_a_file_another_run_is_writing(tmp_path, capsys, first_overwrites):
    """A run writes a file; a second run on the same path with --overwrite is refused (exit 2,
    naming the file and the other process) and leaves it alone: the first run ends with 0 and
    a complete, readable file."""
    path = tmp_path / "same.h5"
    if first_overwrites:
        path.write_bytes(b"an earlier file")
    first = _start(path, *(["--overwrite"] if first_overwrites else []))
    _wait_for(path, first)
    time.sleep(0.3)
    assert main(["run", "paper-ellipse", "-o", str(path), "-q", "--overwrite", "--t-end", "46.4758 s"]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "another process" in err and len(err.strip().splitlines()) == 1
    out, err = first.communicate(timeout=300)
    assert first.returncode == 0, err
    _complete(path)
    assert [p.name for p in tmp_path.iterdir()] == ["same.h5"]  # no temporary file left


def test_concurrent_overwrites_never_exit_0_with_a_broken_file(tmp_path):
    """Two runs with --overwrite started together on one path, in either order: whatever the
    race, a run that exits 0 leaves the complete file at the path, and a run whose file was
    taken fails loudly (exit 1, saying so) or is refused (exit 2)."""
    for attempt in range(3):
        path = tmp_path / f"race{attempt}.h5"
        procs = [_start(path, "--overwrite") for _ in range(2)]
        results = [p.communicate(timeout=300) + (p.returncode,) for p in procs]
        codes = sorted(r[2] for r in results)
        assert codes in ([0, 1], [0, 2]), results
        for _out, err, code in results:
            if code == 1:
                assert "was replaced by another file" in err or "was removed" in err, err
            if code == 2:
                assert "another process" in err or "exists" in err, err
        _complete(path)


def test_a_file_removed_or_replaced_under_a_run_fails_loudly(tmp_path):
    """A run whose file is removed (or replaced by another file) while it runs exits 1 with a
    message saying so, and keeps its records next to the path."""
    for how in ("removed", "replaced"):
        path = tmp_path / f"{how}.h5"
        proc = _start(path)
        _wait_for(path, proc)
        time.sleep(0.3)
        if how == "removed":
            os.remove(path)
        else:
            other = tmp_path / "other.h5"
            other.write_bytes(b"someone else's file")
            os.replace(other, path)
        out, err = proc.communicate(timeout=300)
        assert proc.returncode == 1, err
        what = "was removed" if how == "removed" else "was replaced by another file"
        assert what in err and str(path) in err and "kept in" in err, err
        (kept,) = [p for p in tmp_path.iterdir() if p.name.startswith(f"{how}.h5.lost-")]
        with h5py.File(kept, "r") as f:
            assert f.attrs["status"] in ("completed", "failed") and f["time"].shape[0] > 1


def test_python_api_overwrite_error_names_both_ways(tmp_path):
    path = tmp_path / "x.h5"
    path.write_bytes(b"x")
    sim = emorbit.load_scene("paper-ellipse").build()
    with pytest.raises(emorbit.InputError) as info:
        sim.run(steps=10, output=path)
    assert "overwrite=True" in str(info.value) and "--overwrite" in str(info.value)
    assert path.read_bytes() == b"x"


def test_a_python_run_in_this_process_replaces_its_own_earlier_file(tmp_path):
    """overwrite=True replaces a finished file (not held by any run) in place."""
    path = tmp_path / "x.h5"
    sim = emorbit.load_scene("paper-ellipse").build()
    sim.run(steps=10, output=path)
    sim2 = emorbit.load_scene("paper-ellipse").build()
    sim2.run(steps=20, every=10, output=path, overwrite=True)
    with h5py.File(path, "r") as f:
        assert f["time"].shape == (3,) and f.attrs["status"] == "completed"


# -- 8. resume does not trust edited files ---------------------------------------------------------------
@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("resume") / "run.h5"
    assert (
        main(["run", "paper-ellipse", "-o", str(path), "-q", "--t-end", "464.758 s", "--checkpoint-every", "300"]) == 0
    )
    return path


def _edit_attr(name, value):
    def edit(f):
        if value is None:
            del f.attrs[name]
        else:
            f.attrs[name] = value

    return edit


def _edit_cp(name, value):
    def edit(f):
        f["checkpoint"].attrs[name] = value

    return edit


def _replace(name, data):
    def edit(f):
        del f[name]
        f.create_dataset(name, data=data)

    return edit


def _shorten(name, rows):
    def edit(f):
        ds = f[name]
        ds.resize(rows, axis=0)

    return edit


EDITS = {
    "renamed body": (lambda f: f.move("bodies/satellite", "bodies/sat2"), "/bodies"),
    "deleted dt": (_edit_attr("dt", None), "'dt'"),
    "dt a string": (_edit_attr("dt", "abc"), "'dt'"),
    "dt negative": (_edit_attr("dt", -0.5), "'dt'"),
    "dt not finite": (_edit_attr("dt", np.nan), "'dt'"),
    "order a string": (_edit_attr("order", "four"), "'order'"),
    "output_every 0": (_edit_attr("output_every", 0), "'output_every'"),
    "deleted t_start": (_edit_attr("t_start", None), "'t_start'"),
    "deleted scene": (_edit_attr("scene", None), "'scene'"),
    "method a number": (_edit_attr("method", 5), "'method'"),
    "deleted checkpoint_every": (_edit_attr("checkpoint_every", None), "'checkpoint_every'"),
    "records 1e9": (_edit_cp("records", 10**9), "records"),
    "records negative": (_edit_cp("records", -1), "'records'"),
    "records zero": (_edit_cp("records", 0), "'records'"),
    "records a string": (_edit_cp("records", "many"), "'records'"),
    "steps negative": (_edit_cp("steps", -5), "'steps'"),
    "steps off the record grid": (_edit_cp("steps", 3), "steps"),
    "steps and records moved together": (
        lambda f: (_edit_cp("steps", 310)(f), _edit_cp("records", 32)(f)),
        "time",
    ),
    "time of the checkpoint": (_edit_cp("time", 1.0), "time"),
    "deleted checkpoint": (lambda f: f.__delitem__("checkpoint"), "no checkpoint"),
    "deleted state array": (lambda f: f.__delitem__("checkpoint/point/x"), "point/x"),
    "mis-shaped state array": (_replace("checkpoint/point/x", np.zeros((3, 2))), "point/x"),
    "state array of strings": (_replace("checkpoint/point/v", np.array([b"a", b"b", b"c"])), "point/v"),
    "state array not finite": (_replace("checkpoint/point/cv", np.full((3, 1), np.nan)), "point/cv"),
    "foreign state array": (lambda f: f.create_dataset("checkpoint/point/extra", data=np.zeros(3)), "point/extra"),
    "deleted /time": (lambda f: f.__delitem__("time"), "/time"),
    "deleted body dataset": (lambda f: f.__delitem__("bodies/satellite/velocity"), "velocity"),
    "body dataset shorter than the checkpoint": (_shorten("bodies/satellite/position", 2), "position"),
    "energy shorter than the checkpoint": (_shorten("invariants/energy", 2), "records"),
    "mis-shaped body dataset": (
        lambda f: (
            f.__delitem__("bodies/satellite/position"),
            f["bodies/satellite"].create_dataset("position", shape=(101, 2), maxshape=(None, 2), dtype="f8"),
        ),
        "position",
    ),
    "scene not TOML": (_edit_attr("scene", "[[body"), "TOML"),
}


@pytest.mark.parametrize("edit", list(EDITS))
def test_resume_rejects_an_edited_file(tmp_path, capsys, run_file, edit):
    """Each edit is one line on stderr (exit 2) naming the dataset or attribute; the file is
    left as it was: no dataset grown, no row duplicated."""
    change, named = EDITS[edit]
    path = tmp_path / "edited.h5"
    shutil.copy(run_file, path)
    with h5py.File(path, "r+") as f:
        change(f)
    before = path.read_bytes()
    assert main(["resume", str(path), "--t-end", "929.516 s", "-q"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("emorbit: error: ") and len(err.strip().splitlines()) == 1, err
    assert named in err, err
    assert "Traceback" not in err
    assert path.read_bytes() == before


def test_resume_of_an_untouched_copy_works(tmp_path, run_file):
    path = tmp_path / "copy.h5"
    shutil.copy(run_file, path)
    assert main(["resume", str(path), "--t-end", "929.516 s", "-q"]) == 0
    with h5py.File(path, "r") as f:
        assert f["time"].shape == (201,) and f.attrs["status"] == "completed"


# -- 7. resume to an earlier time ---------------------------------------------------------------------
def test_resume_to_an_earlier_time_needs_truncate(tmp_path, capsys):
    """A t_end before the file's last record would delete records: refused (exit 2, naming the
    file's end), the file untouched; with --truncate the file ends as a run to that t_end."""
    path, short = tmp_path / "long.h5", tmp_path / "short.h5"
    args = ["paper-ellipse", "-q", "--checkpoint-every", "100"]
    assert main(["run", *args, "-o", str(path), "--t-end", "464.758 s"]) == 0
    assert main(["run", *args, "-o", str(short), "--t-end", "232.379 s"]) == 0
    with h5py.File(path, "r+") as f, h5py.File(short, "r") as g:  # as after a kill: a checkpoint at 500 steps
        del f["checkpoint"]
        g.copy(g["checkpoint"], f, "checkpoint")
    before = path.read_bytes()
    assert main(["resume", str(path), "--t-end", "300 s", "-q"]) == 2
    err = capsys.readouterr().err
    assert "464.758" in err and "--truncate" in err and "delete" in err
    assert path.read_bytes() == before
    assert main(["resume", str(path), "--t-end", "300 s", "-q", "--truncate"]) == 0
    with h5py.File(path, "r") as f:
        assert f["time"][-1] == pytest.approx(300.2, abs=0.5) and f.attrs["status"] == "completed"
        assert f["time"].shape == (66,)  # 646 steps: records every 10 and the last
    with pytest.raises(emorbit.InputError, match="truncate=True"):
        emorbit.resume(path, "100 s")


# -- 11. plot says what a file is not ------------------------------------------------------------------
def test_plot_says_what_a_file_is_not(tmp_path, capsys, run_file):
    text = tmp_path / "notes.txt"
    text.write_text("not HDF5\n")
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f.create_dataset("x", data=[1.0])
    empty = tmp_path / "empty.h5"
    shutil.copy(run_file, empty)
    with h5py.File(empty, "r+") as f:
        for name in ("time", "invariants/energy", "invariants/momentum", "invariants/angular_momentum"):
            f[name].resize(0, axis=0)
    fig = tmp_path / "fig.png"
    for path, what in (
        (text, "is not an HDF5 file"),
        (other, "not an emorbit run file"),
        (empty, "holds no records"),
        (tmp_path, "is a folder"),
        (tmp_path / "missing.h5", "does not exist"),
    ):
        assert main(["plot", str(path), "-o", str(fig)]) == 2, path
        err = capsys.readouterr().err
        assert what in err and str(path) in err and len(err.strip().splitlines()) == 1, err
    assert not fig.exists()


def test_plot_of_a_free_space_run_and_a_flexible_body(tmp_path):
    """A free-space run draws no orbit panel; an elastic body gets a deformation panel."""
    from emorbit.plot import deformation

    path = tmp_path / "bar.h5"
    assert main(["run", "elastic-bar-tumbling", "-o", str(path), "-q", "--t-end", "1 s"]) == 0
    assert main(["plot", str(path), "-o", str(tmp_path / "bar.png")]) == 0
    res = emorbit.read(path).si
    ref = res.bodies["bar"]["mesh/reference_nodes"]
    nodes = res.bodies["bar"]["nodes/position"]
    dev = deformation(ref, nodes)
    assert dev[0] < 1e-12 and dev.max() > 1e-6  # starts undeformed, then bends and stretches
    # a rigid motion of the reference nodes is no deformation
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    assert deformation(ref, (ref @ R.T + [5.0, -2.0, 1.0])[None])[0] < 1e-12


# -- 13. steps redone in sub-steps are recorded --------------------------------------------------------
def test_split_steps_are_recorded_per_record(tmp_path):
    """The tumbling box at 150 degrees per step: every step Newton fails on is redone in
    sub-steps and counted in the record that closes its interval."""
    w = 2.0
    sim = emorbit.Simulation(None, method="em", dt=2 * np.tan(np.radians(75)) / w, max_newton_iterations=12)
    sim.add_rigid(
        "b", "box", size=[3.0, 2.0, 1.0], density=1.0, position=[0, 0, 0], velocity=[0, 0, 0],
        angular_velocity=[0.01, w, 0.01],
    )  # fmt: skip
    path = tmp_path / "split.h5"
    res = sim.run(steps=2000, every=10, output=path)
    assert sim.retried_steps > 10
    assert res.split_steps.sum() == sim.retried_steps and res.split_steps[0] == 0
    with h5py.File(path, "r") as f:
        ds = f["diagnostics/split_steps"]
        assert ds.attrs["unit"] == "1" and ds.shape == (201,)
        np.testing.assert_array_equal(ds[()], res.split_steps)
        assert ds[()].max() <= 10
    np.testing.assert_array_equal(emorbit.read(path).split_steps, res.split_steps)


# -- 17. units of root attributes and state arrays -----------------------------------------------------
@pytest.mark.parametrize(
    "scene, t_end", [("paper-ellipse", "46.4758 s"), ("rigid-tumbling-box", "1 s"), ("tethered-satellites", "20 s")]
)
def test_every_root_attribute_with_a_unit_and_every_state_array_carries_it(tmp_path, scene, t_end):
    from emorbit.io.hdf5 import ROOT_UNITS, STATE_UNITS

    path = tmp_path / "u.h5"
    assert main(["run", scene, "-o", str(path), "-q", "--t-end", t_end]) == 0
    with h5py.File(path, "r") as f:
        for name, unit in ROOT_UNITS.items():
            assert f.attrs[f"{name}_unit"] == unit, name
        for group in ("checkpoint", "final_state"):
            names = _datasets(f[group])
            assert names
            for name in names:
                assert f[group][name].attrs.get("unit"), f"{group}/{name} has no unit"
                if name in STATE_UNITS:
                    assert f[group][name].attrs["unit"] == STATE_UNITS[name]


def _datasets(group) -> list[str]:
    names = []
    group.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
    return names


# -- 6. checkpoints by wall time ------------------------------------------------------------------------
def test_default_checkpoints_follow_the_wall_clock(tmp_path, monkeypatch):
    """By default a checkpoint falls at least every CHECKPOINT_SECONDS of wall time (here
    0.3 s), and chunks are short enough for that: the gaps between checkpoints stay within
    it, plus one chunk."""
    monkeypatch.setattr(pacing, "CHECKPOINT_SECONDS", 0.3)
    times = []
    original = emorbit.io.hdf5.Writer.write_checkpoint

    def timed(self, *args, **kwargs):
        times.append(time.monotonic())
        return original(self, *args, **kwargs)

    monkeypatch.setattr(emorbit.io.hdf5.Writer, "write_checkpoint", timed)
    path = tmp_path / "c.h5"
    sim = emorbit.load_scene("elastic-bar-tumbling").build()
    sim.run(t_end="20 s", every=5, output=path)
    gaps = np.diff(times)
    assert len(times) >= 4 and gaps.max() < 0.3 + pacing.CHUNK_SECONDS + 0.5, gaps
    with h5py.File(path, "r") as f:
        assert f.attrs["checkpoint_every"] == 0 and f.attrs["checkpoint_seconds"] == 0.3
        assert f["checkpoint"].attrs["records"] == f["time"].shape[0]  # the end is a checkpoint


def test_chunks_are_sized_from_their_measured_time():
    pace = pacing.Pace(max_records=10**6)
    assert pace.records == 2
    pace.measured(2, 2e-4)
    assert pace.records == 8  # grows at most 4-fold
    for _ in range(10):
        pace.measured(pace.records, pace.records * 1e-4)
    assert pace.records == int(pacing.CHUNK_SECONDS / 1e-4)
    pace.measured(pace.records, pace.records * 0.2)
    assert pace.records == 2  # slow records: short chunks


def test_splits_that_repeat_are_foreseen():
    """Splits every 35 and 57 steps in turn (a low orbit's shadow at dt = 60 s): once one came
    where the gap before the last said, chunks run to 2 steps before the next one due and take
    the 5 steps around it in one chunk; a split that comes elsewhere brings back half the last
    gap."""
    pace = pacing.Pace(max_records=10**6)
    at = 0
    for gap in (35, 57, 35, 57):
        at += gap
        pace.split(at)
    assert pace.foreseen  # 35 + 57 + 35 + 57: the last came 57 after the one before, as due
    assert pace.split_steps(at) == 35 - 2 and pace.split_steps(at + 10) == 35 - 2 - 10
    assert pace.split_steps(at + 33) == 5 and pace.split_steps(at + 37) == 5
    assert pace.split_steps(at + 38) == pace.split_cap == 28  # past the margin: half the last gap
    pace.split(at + 20)  # not where it was due
    assert not pace.foreseen and pace.split_steps(at + 20) == pace.split_cap == 10


def test_a_killed_slow_run_keeps_a_recent_checkpoint(tmp_path):
    """satellite-flexible-boom takes seconds per thousand steps: killed after about 7 s of
    stepping, its file holds a checkpoint after the start (the default interval is 5 s)."""
    path = tmp_path / "boom.h5"
    proc = subprocess.Popen(
        [sys.executable, "-m", "emorbit.cli", "run", "satellite-flexible-boom", "-o", str(path), "-q"],
        stderr=subprocess.DEVNULL,
    )
    _wait_for(path, proc)
    time.sleep(7.0)
    proc.kill()
    assert proc.wait(timeout=60) == -9
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "running"
        assert f["checkpoint"].attrs["records"] > 1


REUSE_STRUCTURE = reuse_structure("2 s", node_output_every=1)
POINT_SCENE = ("paper-ellipse", "464.758 s")
RIGID_SCENE = ("rigid-tumbling-box", "20 s")


@pytest.mark.parametrize("kind", ["point", "rigid", "reuse-structure"])
def test_where_checkpoints_fall_changes_no_result(tmp_path, kind):
    """A checkpoint after every record, every 7 records, or none: the same records, bit for
    bit (point masses, rigid bodies, and a structure whose Newton reuses its factors)."""
    if kind == "reuse-structure":
        scene_path = tmp_path / "reuse.toml"
        scene_path.write_text(REUSE_STRUCTURE)
        scene, t_end = str(scene_path), "2 s"
    else:
        scene, t_end = POINT_SCENE if kind == "point" else RIGID_SCENE
    results = []
    for cp in (None, 1, 7, 10**6):
        sc = emorbit.load_scene(scene)
        sim = sc.build()
        every = sc.output_every
        res = sim.run(t_end=t_end, every=every, checkpoint_every=None if cp is None else cp * every).si
        results.append(np.concatenate([res.energy, *[np.ravel(a) for d in res.bodies.values() for a in d.values()]]))
    for other in results[1:]:
        np.testing.assert_array_equal(other, results[0])


def test_lost_error_is_an_emorbit_error():
    from emorbit.io.hdf5 import FileLostError

    assert issubclass(FileLostError, emorbit.EmorbitError)


def test_a_run_removes_the_temporary_files_of_killed_runs(tmp_path):
    """A run SIGKILLed before its first checkpoint leaves its hidden temporary file; the next
    run to the same path removes it (its process is gone), and leaves a running process's."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()  # a process id that no longer runs
    orphan = tmp_path / f".out.h5.{dead.pid}-deadbeef.tmp"
    orphan.write_bytes(b"half a file")
    mine = tmp_path / f".out.h5.{os.getpid()}-cafecafe.tmp"  # this process runs: not an orphan
    mine.write_bytes(b"a run in progress")
    other = tmp_path / f".other.h5.{dead.pid}-deadbeef.tmp"  # another path's: not this run's to judge
    other.write_bytes(b"x")
    assert main(["run", "paper-ellipse", "-o", str(tmp_path / "out.h5"), "--t-end", "46.4758 s", "-q"]) == 0
    assert not orphan.exists() and mine.exists() and other.exists()
