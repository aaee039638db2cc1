"""Checkpoints and restarts: a resumed run is bit for bit the run that never stopped, for
point masses, rigid and elastic bodies, after a finished run, SIGINT or SIGKILL."""

import shutil
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest
from shared_scenes import reuse_structure

import emorbit
from emorbit.cli import main
from emorbit.io.hdf5 import Writer
from emorbit.io.resume import resume


def _same_files(a, b):
    """Every record dataset equal bit for bit (the checkpoint groups may differ in where
    they were last written)."""
    diffs = []
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and not name.startswith(("checkpoint", "final_state")):
                if name not in fb or not np.array_equal(obj[()], fb[name][()]):
                    diffs.append(name)

        fa.visititems(visit)
        fb.visititems(
            lambda name, obj: (
                diffs.append(name)
                if isinstance(obj, h5py.Dataset)
                and not name.startswith(("checkpoint", "final_state"))
                and name not in fa
                else None
            )
        )
    return diffs


REUSE_STRUCTURE = reuse_structure("4 s")
#: the paper's orbit with adaptive, time-symmetric steps at order 8 (the control variables are state)
ADAPTIVE = """
[field]
gm = "3.9478 m3 / s2"

[integrator]
method = "em"
order = 8
adaptive = 0.01
dt = "0.464758 s"
t_end = "500 s"
output_every = 10

[[body]]
name = "satellite"
kind = "point"
mass = "1 kg"
position = ["10 m", "0 m", "0 m"]
velocity = ["0 m/s", "0.36276 m/s", "0 m/s"]
"""


#: a rigid box on the paper's orbit with adaptive steps at order 4
ADAPTIVE_RIGID = ADAPTIVE.replace("order = 8", "order = 4").replace(
    'kind = "point"\nmass = "1 kg"',
    'kind = "rigid"\nshape = "box"\nsize = ["0.5 m", "0.3 m", "0.2 m"]\ndensity = "1000 kg / m3"\n'
    'angular_velocity = ["0.01 rad/s", "0 rad/s", "0.05 rad/s"]',
)
#: a tumbling elastic bar in free space with adaptive steps (they follow its elastic modes)
ADAPTIVE_ELASTIC = (
    reuse_structure("3 s").replace("order = 4", "adaptive = 0.2").replace("output_every = 3", "output_every = 5")
)
SCENES = {"reuse-structure": REUSE_STRUCTURE, "adaptive": ADAPTIVE, "adaptive-rigid": ADAPTIVE_RIGID}
SCENES["adaptive-elastic"] = ADAPTIVE_ELASTIC


@pytest.mark.parametrize(
    "scene, t1, t2",
    [
        ("paper-ellipse", "2000 s", "4647.58 s"),
        ("rigid-box-paper-ellipse", "1500 s", "3000 s"),
        ("rigid-dumbbell-libration", "5000 s", "12000 s"),
        ("elastic-bar-tumbling", "7 s", "14 s"),
        ("tethered-satellites", "300 s", "700 s"),
        ("reuse-structure", "1.7 s", "4 s"),
        ("adaptive", "200 s", "500 s"),
        ("adaptive-rigid", "200 s", "500 s"),
        ("adaptive-elastic", "1.3 s", "3 s"),
    ],
)
def test_resume_is_bit_identical(tmp_path, scene, t1, t2):
    """Run to t1 (off the checkpoint grid), resume to t2: every record equals a single run to t2."""
    if scene in SCENES:
        path = tmp_path / f"{scene}.toml"
        path.write_text(SCENES[scene])
        scene = str(path)
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    assert main(["run", scene, "-o", str(full), "-q", "--t-end", t2, "--checkpoint-every", "60"]) == 0
    assert main(["run", scene, "-o", str(part), "-q", "--t-end", t1, "--checkpoint-every", "60"]) == 0
    assert main(["resume", str(part), "--t-end", t2, "-q"]) == 0
    assert _same_files(full, part) == []
    with h5py.File(part, "r") as f:
        assert f.attrs["status"] == "completed"


@pytest.mark.parametrize("sig, code, status", [(signal.SIGKILL, -9, "running"), (signal.SIGINT, 130, "interrupted")])
def test_killed_or_interrupted_run_resumes(tmp_path, sig, code, status):
    """A run killed with SIGKILL leaves a readable file with every record up to its last flush
    (a checkpoint); Ctrl-C stops cleanly after writing the state. Either resumes to the very
    file an uninterrupted run writes."""
    full, out = tmp_path / "full.h5", tmp_path / "killed.h5"
    args = ["paper-ellipse", "-q", "--t-end", "464758 s", "--checkpoint-every", "2000"]  # 1e6 steps
    assert main(["run", args[0], "-o", str(full)] + args[1:]) == 0
    proc = subprocess.Popen([sys.executable, "-m", "emorbit.cli", "run", args[0], "-o", str(out)] + args[1:])
    deadline = time.time() + 60
    while time.time() < deadline:  # wait until at least two checkpoints are on disk
        time.sleep(0.05)
        try:  # HDF5 locks a file open for writing: peek without taking the lock
            with h5py.File(out, "r", locking=False) as f:
                if f["checkpoint"].attrs["records"] > 400:
                    break
        except (OSError, KeyError):
            pass
    proc.send_signal(sig)
    assert proc.wait(timeout=60) == code
    with h5py.File(out, "r") as f:
        assert f.attrs["status"] == status
        n = f["time"].shape[0]
        assert n >= f["checkpoint"].attrs["records"] > 0
        assert np.all(np.isfinite(f["bodies/satellite/position"][()]))
        assert f["bodies/satellite/position"].shape[0] == n
    assert main(["resume", str(out), "--t-end", "464758 s", "-q"]) == 0
    assert _same_files(full, out) == []


@pytest.mark.parametrize("opened", ["created", "reopened"])
def test_a_kill_between_flushes_leaves_the_file_of_the_last_flush(tmp_path, opened):
    """HDF5's metadata cache writes what it evicts between flushes, and a kill then leaves
    structures past the end the superblock records: the file cannot be read. The writer keeps
    them until its flush, so a copy of its file taken between flushes (what a kill leaves)
    reads as the last flush left it. 4000 new groups overflow the cache (without the hold
    their copy cannot be read from 2000 on)."""
    path = tmp_path / "run.h5"
    if opened == "created":
        writer = Writer(path, [], {})
    else:
        assert main(["run", "paper-ellipse", "-o", str(path), "-q", "--t-end", "600 s"]) == 0
        with h5py.File(path, "r") as f:
            records = f["time"].shape[0]
        writer = Writer.reopen(path, records, {})
    f = writer.file
    f.flush()
    flushed = []
    f.visit(flushed.append)
    for i in range(4000):
        f.create_group(f"churn{i}").attrs["note"] = "x" * 200
    shutil.copyfile(f.filename, tmp_path / "killed.h5")
    writer.file.close()
    with h5py.File(tmp_path / "killed.h5", "r") as copy:
        names = []
        copy.visit(names.append)
        assert names == flushed


def test_resume_errors(tmp_path):
    assert main(["resume", str(tmp_path / "none.h5"), "--t-end", "1 s", "-q"]) == 2
    bare = tmp_path / "bare.h5"
    with h5py.File(bare, "w") as f:
        f.attrs["scene"] = "x"
    with pytest.raises(emorbit.InputError, match="not an emorbit run file"):
        resume(bare, "1 s")
    out = tmp_path / "r.h5"
    assert main(["run", "paper-ellipse", "-o", str(out), "-q", "--t-end", "46.4758 s", "--checkpoint-every", "10"]) == 0
    assert main(["resume", str(out), "--t-end", "1 s", "-q"]) == 2  # before the last checkpoint
    with h5py.File(out, "r") as f:
        assert f.attrs["status"] == "completed" and f["time"].shape[0] == 11  # untouched


def test_checkpoint_every_is_checked():
    sim = emorbit.Simulation(emorbit.CentralField(gm=1.0), dt=0.1)
    sim.add_point("p", mass=1.0, position=[1, 0, 0], velocity=[0, 1, 0])
    with pytest.raises(emorbit.InputError, match="checkpoint_every"):
        sim.run(steps=10, checkpoint_every=0)
    assert sim._checkpoint_steps(7, 3) == 9  # rounded up to whole record intervals


def test_checkpoint_survives_a_kill_at_any_point_of_its_replacement(tmp_path):
    """A new checkpoint is written aside, flushed, then renamed: a kill while it is written
    leaves the previous checkpoint (a half-written /checkpoint_next is ignored), and a kill
    between removing the old one and renaming the new one leaves the complete new one. Both
    resume to the file an uninterrupted run writes."""
    args = ["paper-ellipse", "-q", "--t-end", "464.758 s", "--checkpoint-every", "100"]
    full = tmp_path / "full.h5"
    assert main(["run", args[0], "-o", str(full)] + args[1:]) == 0
    # a run stopped at 200 s, then the two kinds of kill simulated on its file
    for kind in ("while writing", "between the links"):
        out = tmp_path / f"{kind.replace(' ', '_')}.h5"
        assert main(["run", args[0], "-o", str(out), "-q", "--t-end", "232.379 s", "--checkpoint-every", "100"]) == 0
        with h5py.File(out, "r+") as f:
            f.attrs["status"] = "running"
            if kind == "while writing":
                g = f.create_group("checkpoint_next")
                for name, obj in f["checkpoint"].items():
                    if isinstance(obj, h5py.Dataset):
                        g.create_dataset(name, data=np.full(obj.shape, np.nan))
                        break  # half written: one array, no attributes
            else:
                f.move("checkpoint", "checkpoint_next")
        assert main(["resume", str(out), "--t-end", "464.758 s", "-q"]) == 0
        assert _same_files(full, out) == [], kind
        with h5py.File(out, "r") as f:
            assert "checkpoint" in f and "checkpoint_next" not in f
