"""What a run says while something slow happens: the kernels' compile on a first run, once,
on stderr; and the progress bar's rate, which leaves the first chunk (the compile) out."""

from __future__ import annotations

import os
import subprocess
import sys
import time

from emorbit.io.recorder import progress_bar
from emorbit.notices import COMPILING


def _run(home, extra=()):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "EMORBIT_JIT_CACHE")}
    env["XDG_CACHE_HOME"] = str(home)
    cmd = [sys.executable, "-m", "emorbit.cli", "run", "paper-ellipse", "-o", str(home / "p.h5"), "--overwrite"]
    done = subprocess.run([*cmd, "--t-end", "10 s", *extra], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return done.stderr


def test_a_first_run_says_once_that_kernels_compile_and_a_warm_one_does_not(tmp_path):
    """With an empty kernel cache (a new XDG_CACHE_HOME) the run says so once on stderr; the
    same run again loads the kernels and says nothing; -q says nothing either way."""
    cold = _run(tmp_path / "cold")
    assert cold.count(COMPILING) == 1, cold
    assert COMPILING not in _run(tmp_path / "cold")
    assert COMPILING not in _run(tmp_path / "quiet", ["-q"])


def test_the_progress_bar_starts_after_the_first_chunk():
    """The bar is made at the first update, with the steps done so far as its start, so the time
    the first chunk took (a first run's compile) is not in its rate or its time left."""
    with progress_bar(1000, True) as bar:
        time.sleep(0.3)  # the first chunk, compiling
        made = time.time()
        bar.update(100)
        assert bar.bar.n == 100 and bar.bar.start_t >= made - 0.05
        bar.update(50)
        assert bar.bar.n == 150
