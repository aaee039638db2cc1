"""Kill runs at random moments and count the files that cannot be read afterwards.

Each trial starts ``emorbit run paper-ellipse`` (5e6 steps, a checkpoint every 2000) in
a child process, waits until more than 400 records are checkpointed, waits a random 0-0.3 s
more and sends SIGKILL; then it opens the file as ``emorbit resume`` does
(:func:`emorbit.io.reader.open_run_file`, which checks the layout) and prints each file that
is damaged, then how many were. The files go into a temporary folder, removed at the end.

Usage::

    python scripts/kill_runs.py [--trials 25]
"""

from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import tempfile
import time

import h5py

from emorbit.errors import InputError
from emorbit.io.reader import open_run_file

ARGS = ["paper-ellipse", "-q", "--t-end", "2323790 s", "--checkpoint-every", "2000"]


def trial(out: str) -> str | None:
    """One killed run into ``out``: None where its file reads, else what is wrong with it."""
    proc = subprocess.Popen([sys.executable, "-m", "emorbit.cli", "run", ARGS[0], "-o", out] + ARGS[1:])
    deadline = time.time() + 60
    while time.time() < deadline:
        time.sleep(0.05)
        try:  # the run holds the file's lock: peek without it
            with h5py.File(out, "r", locking=False) as f:
                if f["checkpoint"].attrs["records"] > 400:
                    break
        except (OSError, KeyError):
            pass
    time.sleep(random.uniform(0.0, 0.3))
    proc.kill()
    proc.wait()
    try:
        open_run_file(out).close()
    except InputError as exc:
        return str(exc)
    return None


def main(trials: int) -> int:
    damaged = 0
    with tempfile.TemporaryDirectory() as folder:
        for i in range(trials):
            what = trial(os.path.join(folder, f"killed{i}.h5"))
            if what is not None:
                damaged += 1
                print(f"trial {i}: {what}", flush=True)
    print(f"{damaged} of {trials} killed runs left a file that cannot be read")
    return 1 if damaged else 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=25, help="killed runs (default 25)")
    sys.exit(main(parser.parse_args().trials))
