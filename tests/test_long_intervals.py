"""Record intervals longer than a chunk: a run recording every 1e9 steps (minutes of work per
interval) stops within seconds of SIGTERM, its file says "interrupted", and resume from its
checkpoint reaches the records of a run that was never stopped, bit for bit."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np

CLI = [sys.executable, "-m", "emorbit.cli"]
#: the paper's ellipse (dt = 0.464758 s) recording every 1e9 steps
EVERY = ["--every", "1000000000", "-q"]


def _records(path) -> dict:
    with h5py.File(path, "r") as f:
        names = ["time", "invariants/energy", "invariants/energy_range", "bodies/satellite/position"]
        return {n: f[n][()] for n in names}


def test_sigterm_inside_a_long_record_interval_stops_and_resumes(tmp_path):
    path = tmp_path / "stopped.h5"
    run = CLI + ["run", "paper-ellipse", "-o", str(path), "--t-end", "464758000 s", *EVERY]  # 1e9 steps
    proc = subprocess.Popen(run, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not os.path.exists(path) and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(1.0)  # well inside the first interval, about 100 s of work
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
    # resumed to 2e7 steps, against a run to the same time that was never stopped
    subprocess.run(CLI + ["resume", str(path), "--t-end", "9295160 s", "-q"], check=True, timeout=300)
    unbroken = tmp_path / "unbroken.h5"
    subprocess.run(CLI + ["run", "paper-ellipse", "-o", str(unbroken), "--t-end", "9295160 s", *EVERY], check=True)
    got, want = _records(path), _records(unbroken)
    for name, a in want.items():
        np.testing.assert_array_equal(got[name], a, err_msg=name)
