"""What the fuzz tests share: a small valid scene with a point, a rigid and an elastic body,
TOML text from a dict (:func:`emorbit.sweep.scene_text.scene_toml`), the command line run in
this process with its output captured and a watchdog on its time, and the checks of a clean
error and of a correct run."""

from __future__ import annotations

import contextlib
import faulthandler
import io
import os
import re
import sys

import h5py
import numpy as np

import emorbit
from emorbit.cli import main
from emorbit.sweep.scene_text import scene_toml

#: a valid scene of three bodies and 10 steps (one of each kind: point, rigid, elastic)
BASE = {
    "field": {"gm": "3.9478 m3 / s2", "center": ["0 m", "0 m", "0 m"]},
    "integrator": {"method": "em", "order": 2, "dt": "0.464758 s", "t_end": "4.64758 s", "output_every": 2},
    "body": [
        {
            "name": "sat",
            "kind": "point",
            "mass": "1 kg",
            "position": ["10 m", "0 m", "0 m"],
            "velocity": ["0 m/s", "0.36276 m/s", "0 m/s"],
        },
        {
            "name": "box",
            "kind": "rigid",
            "shape": "box",
            "size": ["0.3 m", "0.2 m", "0.1 m"],
            "density": "1000 kg / m3",
            "position": ["-10 m", "0 m", "0 m"],
            "velocity": ["0 m/s", "-0.36276 m/s", "0 m/s"],
            "angular_velocity": ["0 rad/s", "0 rad/s", "0.1 rad/s"],
        },
        {
            "name": "bar",
            "kind": "elastic",
            "mesh": "chain",
            "start": ["0 m", "10 m", "0 m"],
            "end": ["0 m", "11 m", "0 m"],
            "elements": 2,
            "area": "1 mm2",
            "young": "1 GPa",
            "density": "1000 kg / m3",
            "position": ["0 m", "0 m", "0 m"],
            "velocity": ["-0.36276 m/s", "0 m/s", "0 m/s"],
        },
    ],
}

#: the longest one fuzz case may take in this process before the watchdog ends the test run
#: (with every thread's traceback on stderr): a hang fails loudly instead of stalling CI
CASE_SECONDS = 120


#: TOML text of a scene or sweep dict: the writer a sweep run's file uses for its scene
to_toml = scene_toml


@contextlib.contextmanager
def watchdog(seconds: float = CASE_SECONDS):
    """Bound one case in time: past ``seconds`` the process prints every thread's stack and
    exits (faulthandler's timer runs in its own C thread, so it fires inside a stuck C call too)."""
    faulthandler.dump_traceback_later(seconds, exit=True, file=sys.__stderr__)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()


def cli(argv: list[str], seconds: float = CASE_SECONDS) -> tuple[int, str, str]:
    """``emorbit ARGV`` in this process: (exit code, stdout, stderr). An exception that
    escapes :func:`emorbit.cli.main` (a traceback for a user) fails the test as it is."""
    out, err = io.StringIO(), io.StringIO()
    with watchdog(seconds), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def listing(folder) -> set[str]:
    """Every file and folder under ``folder``, relative to it (hidden ones included)."""
    found = set()
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            found.add(os.path.relpath(os.path.join(root, name), folder))
    return found


_ERROR = re.compile(r"emorbit: error: (?P<key>[^\s:][^:]*?): .+")


def clean_error(code: int, err: str) -> str:
    """Check the form of a clean error (exit 2, one line on stderr that starts with
    "emorbit: error: <key>: ", no traceback) and return the key it names."""
    assert code == 2, f"exit {code}, stderr: {err[-3000:]}"
    assert "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, f"{len(lines)} lines on stderr: {err[-3000:]}"
    m = _ERROR.fullmatch(lines[0])
    assert m, f"not a clean error naming a key: {lines[0]!r}"
    return m.group("key")


def run_failed(code: int, err: str, path) -> None:
    """A run that failed while stepping (exit 1): one line that says so, and a file whose
    status is "failed" with the records before the failure."""
    assert code == 1, f"exit {code}, stderr: {err[-3000:]}"
    lines = err.strip().splitlines()
    assert lines and lines[-1].startswith("emorbit: run failed: step at t = "), err
    assert "Traceback" not in err, err
    res = emorbit.read(path).si
    assert res.attrs["status"] == "failed" and len(res) >= 1


def correct_run(path, t_end: float | None = None, err: str = "", energy_tol: float = 1e-10) -> emorbit.result.ResultSI:
    """A completed run file: it reads back, its status is completed, every record is finite,
    its times are a grid that reaches ``t_end``, and an em run keeps its energy to
    ``energy_tol`` or says on stderr (``err``) that an invariant left round-off (a stiff
    structure at a large step amplifies round-off: docs/hard-cases.md). Returns what it read,
    in plain SI (``Result.si``)."""
    res = emorbit.read(path).si
    assert res.attrs["status"] == "completed", res.attrs.get("status")
    assert len(res) >= 2
    assert np.all(np.isfinite(res.time)) and np.all(np.diff(res.time) > 0)
    if t_end is not None:
        assert res.time[-1] >= t_end * (1 - 1e-9) - 1e-300, (res.time[-1], t_end)
        assert res.time[-1] < t_end + res.dt * (1 + 1e-9) + abs(t_end) * 1e-9, (res.time[-1], t_end, res.dt)
    for name in ("energy", "momentum", "angular_momentum"):
        assert np.all(np.isfinite(getattr(res, name))), name
    for name, sets in res.bodies.items():
        for q, a in sets.items():
            assert np.all(np.isfinite(a)), f"{name}/{q}"
    steps = round((res.time[-1] - res.time[0]) / res.dt)
    every = int(res.attrs["output_every"])
    assert len(res) == -(-steps // every) + 1, (len(res), steps, every)
    if res.method == "em" and abs(res.energy[0]) > 0 and "emorbit: warning:" not in err:
        drift = np.abs(res.relative_energy_error()).max()
        assert drift < energy_tol, f"em energy error {drift:.3e} and no warning on stderr: {err}"
    return res


def records(path) -> dict:
    """Every dataset outside the checkpoint and final-state groups, by name."""
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(
            lambda name, obj: (
                out.__setitem__(name, obj[()])
                if isinstance(obj, h5py.Dataset) and not name.startswith(("checkpoint", "final_state"))
                else None
            )
        )
    return out


def estimated_steps(d) -> float:
    """t_end / dt of a scene dict where both read as times, else 0 (the scene fails before it runs)."""
    from emorbit.units import to_si

    try:
        integ = d["integrator"]
        return to_si(integ["t_end"], "time", "t") / to_si(integ["dt"], "time", "dt")
    except Exception:
        return 0.0
