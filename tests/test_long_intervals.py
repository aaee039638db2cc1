"""Record intervals longer than a chunk: a run records every 10 million steps, yet SIGTERM
stops it within a chunk's time, its file says "interrupted", and resume reaches the records of
a run that was never stopped, bit for bit (the steps of the unfinished interval are redone
from the last checkpoint)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np

#: the paper's ellipse, 2e7 steps recorded every 1e7: two record intervals of a few seconds each
ARGS = ["paper-ellipse", "--t-end", "9295160 s", "--every", "10000000", "-q"]


def _records(path) -> dict:
    with h5py.File(path, "r") as f:
        names = ["time", "invariants/energy", "invariants/energy_range", "bodies/satellite/position"]
        return {n: f[n][()] for n in names}


def test_sigterm_inside_a_long_record_interval_stops_and_resumes(tmp_path):
    cli = [sys.executable, "-m", "emorbit.cli"]
    unbroken = tmp_path / "unbroken.h5"
    subprocess.run(cli + ["run", *ARGS[:1], "-o", str(unbroken), *ARGS[1:]], check=True, timeout=300)
    path = tmp_path / "stopped.h5"
    proc = subprocess.Popen(cli + ["run", ARGS[0], "-o", str(path), *ARGS[1:]], stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not os.path.exists(path) and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(0.5)  # inside the first interval of 1e7 steps
        sent = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
        stopped_in = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 143, err
    assert stopped_in < 5.0, f"SIGTERM took {stopped_in:.1f} s to stop the run"
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "interrupted"
        assert f["time"].shape[0] == 1  # the start only: the interval was not finished
    subprocess.run(cli + ["resume", str(path), "--t-end", "9295160 s", "-q"], check=True, timeout=300)
    got, want = _records(path), _records(unbroken)
    for name, a in want.items():
        np.testing.assert_array_equal(got[name], a, err_msg=name)
