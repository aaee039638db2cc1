"""SIGTERM, SIGINT and SIGKILL at random moments of runs of a point-mass, a rigid and a coupled
(elastic) scene: every file opens, its status says what happened, and ``emorbit resume``
reaches the very records of a run that was never stopped.

SIGTERM and SIGINT stop a run at the end of its chunk, write the records, the final state and
a checkpoint, mark the file "interrupted" and exit with 143 and 130. SIGKILL leaves the file
as it was at its last flush, status "running", with a checkpoint. The runs take checkpoints
every 0.2 s of wall time (instead of 5 s), so that the resumed runs start from checkpoints at
random places too: where checkpoints fall changes no result.
"""

from __future__ import annotations

import json
import os
import random
import select
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest
from fuzz_support import records

from emorbit.cli import main

#: per kind: the scene and the run's options (about a second of wall time each)
SCENES = {
    "point": ["paper-ellipse", "--t-end", "9295160 s", "--every", "2000"],
    "rigid": ["rigid-tumbling-box", "--t-end", "4000 s", "--every", "40"],
    "coupled": ["elastic-bar-tumbling", "--t-end", "15 s"],
}
KINDS = list(SCENES)
KILLS = 9  # of each signal: three runs of each kind

#: a process that runs ``emorbit run`` once per line of JSON arguments on stdin and prints the
#: exit code; between runs it ignores SIGINT and SIGTERM (a signal meant for a run that has
#: already ended), during runs emorbit's handlers take them
WORKER = """
import json, signal, sys
import emorbit.pacing
emorbit.pacing.CHECKPOINT_SECONDS = 0.2
signal.signal(signal.SIGINT, signal.SIG_IGN)
signal.signal(signal.SIGTERM, signal.SIG_IGN)
from emorbit.cli import main
for line in sys.stdin:
    print(main(json.loads(line)), flush=True)
"""


def differences(a: dict, b: dict) -> list[str]:
    return sorted(k for k in a.keys() | b.keys() if k not in a or k not in b or not np.array_equal(a[k], b[k]))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The records of each scene's run that is never stopped."""
    folder = tmp_path_factory.mktemp("reference")
    out = {}
    for kind, (scene, *options) in SCENES.items():
        path = folder / f"{kind}.h5"
        assert main(["run", scene, "-o", str(path), "-q", *options]) == 0
        out[kind] = records(path)
    return out


def _wait_for(path, proc, timeout=120.0) -> None:
    """Until the run's file has its name (it gets it with its first checkpoint)."""
    deadline = time.monotonic() + timeout
    while not os.path.exists(path):
        assert proc.poll() is None, f"the run ended before its file appeared (exit {proc.returncode})"
        assert time.monotonic() < deadline, "the run's file did not appear"
        time.sleep(0.005)


def _check_and_resume(path, kind, expected_status, reference) -> None:
    """The file opens and says what happened; resumed, its records are the unbroken run's."""
    scene, *options = SCENES[kind]
    with h5py.File(path, "r") as f:
        status = f.attrs["status"]
        assert status in expected_status, (path, status)
        assert f["checkpoint"].attrs["records"] >= 1
        if status == "interrupted":
            assert "interrupted by SIG" in f.attrs["error"]
    if status != "completed":
        t_end = options[options.index("--t-end") + 1]
        assert main(["resume", str(path), "--t-end", t_end, "-q"]) == 0, path
    assert differences(records(path), reference[kind]) == [], path


def _delay(rng: random.Random) -> float:
    return rng.uniform(0.0, 1.0)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_sigterm_and_sigint_at_random_moments_resume_bit_identical(tmp_path, reference, sig):
    """9 runs stopped by the signal at a random moment: exit 128 + signal (or 0 if the run
    was done first), status "interrupted" with the signal named, and a resume to the end
    gives the unbroken run's records."""
    rng = random.Random(int(sig))
    log = open(tmp_path / "worker.err", "w")
    proc = subprocess.Popen(
        [sys.executable, "-c", WORKER], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=log, text=True
    )
    codes = []
    try:
        for i in range(KILLS):
            kind = KINDS[i % len(KINDS)]
            scene, *options = SCENES[kind]
            path = tmp_path / f"{kind}-{i}.h5"
            proc.stdin.write(json.dumps(["run", scene, "-o", str(path), "-q", *options]) + "\n")
            proc.stdin.flush()
            _wait_for(path, proc)
            time.sleep(_delay(rng))
            proc.send_signal(sig)
            ready, _, _ = select.select([proc.stdout], [], [], 120)
            assert ready, "the run did not end after the signal"
            code = int(proc.stdout.readline())
            assert code in (0, 128 + sig), (path, code)
            codes.append(code)
            _check_and_resume(path, kind, ("interrupted",) if code else ("completed",), reference)
    finally:
        proc.stdin.close()
        proc.wait(timeout=60)
        proc.stdout.close()
        log.close()
    assert codes.count(128 + sig) >= KILLS // 2, codes  # most signals fall inside a run


def test_sigkill_at_random_moments_resumes_bit_identical(tmp_path, reference):
    """9 runs killed at a random moment: every file opens, status "running" (or "completed"
    if the run was done first), and a resume to the end gives the unbroken run's records."""
    rng = random.Random(9)
    killed = 0
    for i in range(KILLS):
        kind = KINDS[i % len(KINDS)]
        scene, *options = SCENES[kind]
        path = tmp_path / f"{kind}-{i}.h5"
        args = json.dumps(["run", scene, "-o", str(path), "-q", *options])
        code = f"import sys\n{WORKER.split('for line')[0]}sys.exit(main({args}))"
        proc = subprocess.Popen([sys.executable, "-c", code], stderr=subprocess.DEVNULL)
        _wait_for(path, proc)
        time.sleep(_delay(rng))
        proc.kill()
        rc = proc.wait(timeout=60)
        assert rc in (0, -signal.SIGKILL), rc
        killed += rc == -signal.SIGKILL
        _check_and_resume(path, kind, ("running", "completed"), reference)
        assert not [p for p in os.listdir(tmp_path) if p.endswith(".tmp")]
    assert killed >= KILLS // 2
