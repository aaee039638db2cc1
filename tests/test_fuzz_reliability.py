"""Property-based fuzz of reliability: generated scenes with edge-case values, command-line
argument lists and damaged run files go through emorbit in this process, each under a time
bound and a memory bound; a few go through a child process under ``resource.setrlimit``.

Every case is sorted into one class:

* clean error: exit 2, the last line "emorbit: error: <key>: ..." (or argparse's "emorbit ...:
  error: ...", which names the argument), no traceback, nothing left in the output folder;
* clean stop: exit 1, 3, 130 or 143 with a one-line message, no traceback, the run's file
  readable with its status;
* valid run: exit 0 (a run file that reads back completed and correct; a command's output), or
  a damaged file read back with the very records it had (the damage in bytes no record uses);
* traceback: an exception escaped, or "Traceback" on stderr;
* silent: exit 0 with wrong or lost data (a damaged file read or resumed into records that
  differ from the file's), or an error that left files behind;
* hang: the case ran past its time bound;
* memory: the case grew the process's peak memory past its bound;
* vague error: exit 2 without a key, or another exit code.

Only the first three pass. The cases come from hypothesis with a fixed seed (``derandomize``);
``EMORBIT_FUZZ_SCALE`` multiplies their number (default 1: 1046 cases, about two minutes on two
cores). To measure code that fails: ``EMORBIT_FUZZ_OBSERVE=1`` counts the classes without
failing, ``EMORBIT_FUZZ_TALLY=<file>`` writes the totals as JSON when the module ends,
``EMORBIT_FUZZ_LOG=<file>`` appends each case's class as it ends (a case stuck in C code,
which only the watchdog ends, stays "pending" there), ``EMORBIT_FUZZ_SKIP`` (JSON, {test:
cases}) skips the first cases of a test, to go on after such a case, and
``EMORBIT_FUZZ_CASE_SECONDS`` sets the time bound (default 30 s).

Left out on purpose, because other work owns them: ``emorbit plot`` (its command-line wrapper),
effect tables (their parameter bounds and table sizes) and sweeps on Dask or MPI.
"""

from __future__ import annotations

import collections
import contextlib
import copy
import inspect
import io
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
import traceback
import warnings

import h5py
import numpy as np
import pytest
from fuzz_support import BASE, correct_run, estimated_steps, listing, records, to_toml, watchdog
from hypothesis import HealthCheck, Phase, event, given, settings
from hypothesis import strategies as st
from hypothesis.errors import InvalidArgument

import emorbit
from emorbit.cli import main
from emorbit.errors import InputError

SCALE = float(os.environ.get("EMORBIT_FUZZ_SCALE", "1"))
OBSERVE = os.environ.get("EMORBIT_FUZZ_OBSERVE") == "1"
SETTINGS = dict(
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=list(HealthCheck),
    phases=[Phase.explicit, Phase.generate],  # no shrinking: a failing case is printed as it was drawn
)

#: the longest one case may take, s (a SIGALRM ends it; the watchdog, at four times that, ends
#: the process where a case is stuck in C code)
CASE_SECONDS = float(os.environ.get("EMORBIT_FUZZ_CASE_SECONDS", "30"))
#: how far one case may raise the process's peak memory (ru_maxrss), bytes
MEMORY_GROWTH = 1 << 30
#: the exit codes emorbit may end with
EXITS = {0, 1, 2, 3, 130, 143}
#: the classes that pass
GOOD = {"clean error", "clean stop", "valid run"}
#: the totals of this module's cases, by class
TALLY: collections.Counter = collections.Counter()
#: cases begun, by test; and those to skip (see the module's notes)
_BEGUN: collections.Counter = collections.Counter()
_SKIP = json.loads(os.environ.get("EMORBIT_FUZZ_SKIP", "{}"))


def _log(line: str) -> None:
    if os.environ.get("EMORBIT_FUZZ_LOG"):
        with open(os.environ["EMORBIT_FUZZ_LOG"], "a", encoding="utf-8") as fh:
            fh.write(line + "\n")


def begin(test: str) -> bool:
    """Count a case of ``test`` as begun; False where it is to be skipped."""
    _BEGUN[test] += 1
    if _BEGUN[test] <= _SKIP.get(test, 0):
        return False
    _log(f"{test} {_BEGUN[test]} pending")
    return True


def _examples(n: int) -> int:
    return max(1, int(n * SCALE))


class _Hang(BaseException):
    """The case ran past its time bound."""


@contextlib.contextmanager
def _bounded(seconds: float):
    """SIGALRM after ``seconds`` raises :class:`_Hang` in the case (Python code); the watchdog,
    four times as long, ends the process where the case is stuck in C code."""

    def alarm(signum, frame):
        raise _Hang()

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        with watchdog(4 * seconds):
            yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _peak() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB


class Case:
    """What one call did: exit code (or "hang"), stdout, stderr, the traceback of an exception
    that escaped, its wall time and how far it raised the peak memory."""

    def __init__(self, code, out="", err="", tb="", seconds=0.0, grown=0):
        self.code, self.out, self.err, self.tb, self.seconds, self.grown = code, out, err, tb, seconds, grown

    def __repr__(self) -> str:
        return f"Case(code={self.code!r}, err={self.err[-1500:]!r}, tb={self.tb[-3000:]!r})"


def call(fn, seconds: float = CASE_SECONDS) -> Case:
    """Run ``fn()`` (it returns an exit code) as a process would: warnings printed, not raised;
    SystemExit is its code; any other exception that escapes is recorded as a traceback."""
    out, err = io.StringIO(), io.StringIO()
    code, tb = None, ""
    peak, start = _peak(), time.monotonic()
    with warnings.catch_warnings(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        warnings.simplefilter("default")
        try:
            with _bounded(seconds):
                code = fn()
        except _Hang:
            code = "hang"
        except SystemExit as exc:  # argparse
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
        except BaseException:
            tb = traceback.format_exc()
    return Case(code, out.getvalue(), err.getvalue(), tb, time.monotonic() - start, _peak() - peak)


def cli(argv, seconds: float = CASE_SECONDS) -> Case:
    return call(lambda: main([str(a) for a in argv]), seconds)


def _names_key(err: str) -> bool:
    lines = [line for line in err.strip().splitlines() if not line.startswith("emorbit: warning:")]
    if not lines:
        return False
    last = lines[-1]
    if last.startswith("emorbit: error: "):
        key, sep, message = last[len("emorbit: error: ") :].partition(": ")
        return bool(sep and key.strip() and message.strip())
    return last.startswith("emorbit") and ": error: " in last  # argparse names the argument


def classify(case: Case) -> str:
    """The class of a call's outcome, by its exit code and output alone (callers check the data
    of exit 0 and the files of exit 2 as well)."""
    if case.code == "hang" or case.seconds > CASE_SECONDS:
        return "hang"
    if case.tb or "Traceback (most recent call last)" in case.err:
        return "traceback"
    if case.grown > MEMORY_GROWTH:
        return "memory"
    if case.code not in EXITS:
        return "vague error"
    if case.code == 2:
        return "clean error" if _names_key(case.err) else "vague error"
    if case.code == 0:
        return "valid run"
    lines = [line for line in case.err.strip().splitlines() if not line.startswith("emorbit: warning:")]
    return "clean stop" if lines and lines[-1].startswith("emorbit: ") else "vague error"


def record(test: str, cls: str, case=None) -> None:
    """Count a case of ``test``; unless observing, fail on a class that does not pass."""
    TALLY[cls] += 1
    with contextlib.suppress(InvalidArgument):  # outside a hypothesis test
        event(cls)
    _log(f"{test} {_BEGUN[test]} {cls}")
    if not OBSERVE:
        assert cls in GOOD, f"{cls}: {case!r}"


@pytest.fixture(scope="module", autouse=True)
def tally():
    yield TALLY
    line = ", ".join(f"{k}: {v}" for k, v in sorted(TALLY.items()))
    print(f"\nreliability fuzz: {sum(TALLY.values())} cases; {line}", file=sys.__stderr__)
    if os.environ.get("EMORBIT_FUZZ_TALLY"):
        with open(os.environ["EMORBIT_FUZZ_TALLY"], "w", encoding="utf-8") as fh:
            json.dump(dict(TALLY), fh, indent=1, sort_keys=True)


# -- scenes -------------------------------------------------------------------------------------------
def _one(kind: int) -> dict:
    d = copy.deepcopy(BASE)
    d["body"] = [d["body"][kind]]
    return d


#: small valid scenes: each kind of body alone, and all three (10 steps each)
SCENES = {"point": _one(0), "rigid": _one(1), "elastic": _one(2), "three": copy.deepcopy(BASE)}
#: numbers at the edges of float64 (and beyond it, as text)
EDGE_NUMBERS = ["5e-324", "1e-300", "1e-30", "1e30", "1e300", "-0.0", "nan", "inf", "-inf", "1e400", "9" * 400]
#: integers at the edges of int64 and beyond
EDGE_INTEGERS = [0, -1, 2**31, 2**53 + 1, 2**63 - 1, 2**63, 2**64, 10**30, True, 1.5]
#: names a body may be given
NAMES = ["\u0000", "a\u0000b", "tab\tname", "line\nbreak", "\u2028", "\u00e9t\u00e9", "x" * 5000, ".", "..", " ", "a/b"]
#: epochs, valid or not
EPOCHS = [
    "2026-01-01T00:00:00 TDB",
    "2200-01-01T00:00:00 UTC",
    "2015-12-31T23:59:60 UTC",
    "2016-12-31T23:59:60 UTC",
    "1000-01-01T00:00:00 TDB",
    "9999-12-31T23:59:59 TDB",
    "-5000-01-01T00:00:00 TDB",
    "not a date",
    "",
    "2026-13-45T99:00:00 UTC",
]
#: material constants far outside the usual, stiff or soft
MATERIALS = {"young": ["1e18 Pa", "1e14 Pa", "1e-300 Pa", "5e-324 Pa"], "density": ["5e-324 kg/m3", "1e300 kg/m3"]}


def _quantities(d: dict, path=()):
    """(path, unit) of every string with a unit in a scene, lists included."""
    items = d.items() if isinstance(d, dict) else enumerate(d)
    for k, v in items:
        here = path + (k,)
        if isinstance(v, (dict, list)):
            yield from _quantities(v, here)
        elif isinstance(v, str) and v[:1] in "-0123456789" and " " in v:
            yield here, v.split(" ", 1)[1]


def _set(d: dict, path, value) -> None:
    for p in path[:-1]:
        d = d[p]
    d[path[-1]] = value


@st.composite
def edge_scenes(draw):
    name = draw(st.sampled_from(sorted(SCENES)))
    d = copy.deepcopy(SCENES[name])
    depth = None
    for _ in range(draw(st.integers(1, 2))):
        how = draw(st.sampled_from(["number", "number", "integer", "name", "epoch", "material", "method", "nest"]))
        if how == "number":
            path, unit = draw(st.sampled_from(sorted(_quantities(d), key=str)))
            _set(d, path, f"{draw(st.sampled_from(EDGE_NUMBERS))} {unit}")
        elif how == "integer":
            key = draw(st.sampled_from(["output_every", "order", "checkpoint_every", "max_newton_iterations"]))
            d["integrator"][key] = draw(st.sampled_from(EDGE_INTEGERS))
        elif how == "name":
            d["body"][0]["name"] = draw(st.sampled_from(NAMES))
        elif how == "epoch":
            d["integrator"]["epoch"] = draw(st.sampled_from(EPOCHS))
        elif how == "material":
            elastic = [b for b in d["body"] if b["kind"] == "elastic"]
            body = elastic[0] if elastic else d["body"][0]
            key = draw(st.sampled_from(sorted(MATERIALS)))
            body[key] = draw(st.sampled_from(MATERIALS[key]))
        elif how == "method":
            d["integrator"]["method"] = draw(st.sampled_from(["midpoint", "leapfrog", "em"]))
            d["integrator"]["dt"] = draw(st.sampled_from(["0.464758 s", "4.64758 s", "0.0464758 s"]))
        else:  # arrays nested this deep, written into the text (see test_generated_edge_scenes)
            depth = draw(st.sampled_from([3, 17, 40, 3000]))
    return name, d, depth


def check_run(case: Case, folder, out, before: set) -> str:
    """The class of an ``emorbit run``: exit 2 leaves nothing; exit 0 leaves a correct file;
    exit 1 or 3 a file that reads back with its status."""
    cls = classify(case)
    if cls == "clean error" and listing(folder) != before:
        return "silent"
    if cls == "valid run":
        try:
            correct_run(out, err=case.err, energy_tol=1e-6)
        except (AssertionError, InputError):
            return "silent"
    if cls == "clean stop" and os.path.exists(out):
        try:
            status = emorbit.read(out).attrs["status"]
        except InputError:
            return "silent"
        if status not in ("failed", "completed"):
            return "silent"
    return cls


@settings(max_examples=_examples(450), **SETTINGS)
@given(case=edge_scenes())
def test_generated_edge_scenes(tmp_path_factory, case):
    name, d, depth = case
    if not begin("scenes"):
        return
    if estimated_steps(d) > 2000:  # a run made long, not wrong: test_fuzz_scenes.test_generated_run_lengths
        d["integrator"]["t_end"] = d["integrator"]["dt"]
    folder = tmp_path_factory.mktemp("scene")
    text = to_toml(d)
    if depth is not None:
        text = text.replace('["integrator"]\n', '["integrator"]\nnested = ' + "[" * depth + "]" * depth + "\n", 1)
    (folder / "scene.toml").write_text(text, encoding="utf-8")
    before = listing(folder)
    res = cli(["run", folder / "scene.toml", "-o", folder / "out.h5", "-q"])
    record("scenes", check_run(res, folder, folder / "out.h5", before), res)


# -- command lines ------------------------------------------------------------------------------------
QUANTITIES = ["10 s", "4.64758 s", "0.464758 s", "0 s", "-1 s", "1e400 s", "nan s", "abc", "", "1 kg", "1e-300 s"]
INTEGERS = ["1", "2", "4", "0", "-5", "x", "1e3", "99999999999999999999", ""]


@pytest.fixture(scope="module")
def material(tmp_path_factory):
    """Files the command lines name: a scene, a run file, a sweep, a folder, a FIFO, garbage."""
    folder = tmp_path_factory.mktemp("material")
    scene = copy.deepcopy(SCENES["point"])
    (folder / "scene.toml").write_text(to_toml(scene))
    res = cli(["run", folder / "scene.toml", "-o", folder / "run.h5", "-q"])
    assert res.code == 0, res
    (folder / "sweep.toml").write_text(
        '[sweep]\nscene = "scene.toml"\n[[parameter]]\nkey = "body[0].velocity[1]"\nvalues = ["0.36 m/s", "0.37 m/s"]\n'
    )
    (folder / "bigseed.toml").write_text(
        (folder / "sweep.toml").read_text().replace("[sweep]", "[sweep]\nseed = " + str(2**70))
    )
    (folder / "garbage.bin").write_bytes(bytes(range(256)) * 4)
    (folder / "empty.toml").write_text("")
    (folder / "folder").mkdir()
    os.mkfifo(folder / "fifo")
    return folder


@st.composite
def command_lines(draw, folder):
    sub = draw(st.sampled_from(["run"] * 5 + ["resume"] * 3 + ["sweep"] * 2 + ["scenes", "nonsense", "--version"]))
    files = {
        "scene": folder / "scene.toml",
        "run": "RUN",  # a fresh copy of the run file
        "missing": folder / "missing.toml",
        "folder": folder / "folder",
        "fifo": folder / "fifo",
        "garbage": folder / "garbage.bin",
        "empty": folder / "empty.toml",
        "shipped": "paper-ellipse",
        "unknown": "no-such-scene",
    }
    argv = [sub]
    if sub == "run":
        argv.append(files[draw(st.sampled_from(["scene"] * 4 + sorted(files)))])
        out = draw(st.sampled_from(["new", "new", "run", "folder", "fifo", "missing folder", "garbage", "none"]))
        if out != "none":
            argv += [
                "-o",
                {"new": "NEW", "run": "RUN", "missing folder": folder / "no" / "x.h5"}.get(out, files.get(out)),
            ]
        for option, values in (
            ("--t-end", QUANTITIES),
            ("--dt", QUANTITIES),
            ("--method", ["em", "midpoint", "leapfrog", "rk4", ""]),
            ("--order", INTEGERS),
            ("--every", INTEGERS),
            ("--checkpoint-every", INTEGERS),
            ("--max-output", ["1 kB", "10 GB", "0 B", "-1 B", "x", "1e400 B"]),
        ):
            if draw(st.integers(0, 3)) == 0:
                argv += [option, draw(st.sampled_from(values))]
        argv += [f for f in ("--overwrite", "--strict", "-q") if draw(st.booleans())]
        if argv[1] == "paper-ellipse" and "--t-end" not in argv:
            argv += ["--t-end", "46.4758 s"]  # its 10,000 steps are not what is tested
    elif sub == "resume":
        argv.append(files[draw(st.sampled_from(["run"] * 4 + ["missing", "folder", "fifo", "garbage", "scene"]))])
        if draw(st.integers(0, 5)):
            argv += ["--t-end", draw(st.sampled_from(["9.29516 s", "4.64758 s", "1 s", "1e6 s"] + QUANTITIES))]
        argv += [f for f in ("--truncate", "-q") if draw(st.booleans())]
    elif sub == "sweep":
        argv.append(
            folder / draw(st.sampled_from(["sweep.toml", "sweep.toml", "bigseed.toml", "missing.toml", "garbage.bin"]))
        )
        if draw(st.integers(0, 5)):
            argv += ["-o", draw(st.sampled_from(["NEWDIR", folder / "garbage.bin", folder / "no" / "out"]))]
        argv += [draw(st.sampled_from(["--serial", "--list", "--serial"]))]
        if draw(st.booleans()):
            argv += ["--scheduler", draw(st.sampled_from(["not-a-url", "tcp://", "tcp://h:0", "foo://h:1"]))]
            argv.remove("--serial") if "--serial" in argv else None
        if draw(st.integers(0, 3)) == 0:
            argv += [
                draw(st.sampled_from(["--workers", "--retries", "--max-runs", "--threads"])),
                draw(st.sampled_from(INTEGERS)),
            ]
        argv.append("-q")
    elif sub == "scenes" and draw(st.booleans()):
        argv.append("extra")
    if draw(st.integers(0, 9)) == 0:
        argv.insert(draw(st.integers(1, len(argv))), draw(st.sampled_from(["--bogus", "-x", "--", "-", "\u00e9"])))
    return argv


@settings(max_examples=_examples(400), **SETTINGS)
@given(data=st.data())
def test_generated_command_lines(tmp_path_factory, material, data):
    argv = data.draw(command_lines(material), label="argv")
    if not begin("command lines"):
        return
    folder = tmp_path_factory.mktemp("cli")
    shutil.copy(material / "run.h5", folder / "run.h5")
    argv = [
        {"RUN": folder / "run.h5", "NEW": folder / "new.h5", "NEWDIR": folder / "sweep"}.get(a, a)
        if isinstance(a, str)
        else a
        for a in argv
    ]
    before = listing(folder)
    material_before = listing(material)
    res = cli(argv)
    cls = classify(res)
    if cls == "clean error" and (listing(folder) != before or listing(material) != material_before):
        cls = "silent"
    if cls == "valid run" and argv[0] == "run":
        out = argv[argv.index("-o") + 1]
        cls = check_run(res, folder, out, before)
    record("command lines", cls, res)


# -- damaged files --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def damaged_material(tmp_path_factory):
    """A run file of the three bodies to t1 (a checkpoint in the middle), the unbroken run to t2,
    and the record datasets of each."""
    folder = tmp_path_factory.mktemp("damaged")
    (folder / "scene.toml").write_text(to_toml(BASE))
    for name, t_end in (("run", "4.64758 s"), ("reference", "9.29516 s")):
        res = cli(
            [
                "run",
                folder / "scene.toml",
                "-o",
                folder / f"{name}.h5",
                "-q",
                "--t-end",
                t_end,
                "--checkpoint-every",
                "4",
            ]
        )
        assert res.code == 0, res
    return folder


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        a[k].shape == b[k].shape and np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f") for k in a
    )


@st.composite
def damage(draw, size: int, chunks: list):
    how = draw(st.sampled_from(["flip"] * 4 + ["record"] * 3 + ["zero", "truncate", "append"]))
    if how == "record":  # a byte inside the records' data: a checksum must catch it
        start, length = draw(st.sampled_from(chunks))
        return how, start + draw(st.integers(0, length - 1)), 1
    if how == "truncate":
        return how, draw(st.integers(0, size - 1)), 0
    if how == "append":
        return how, size, draw(st.integers(1, 4096))
    n = 512 if how == "zero" else draw(st.sampled_from([1, 8, 64]))
    return how, draw(st.integers(0, size - n)), n


def _damaged_copy(src, dst, how: str, at: int, n: int, seed: int) -> None:
    with open(src, "rb") as fh:
        raw = bytearray(fh.read())
    rng = np.random.default_rng(seed)
    if how == "truncate":
        raw = raw[:at]
    elif how == "append":
        raw += rng.integers(0, 256, n, dtype=np.uint8).tobytes()
    elif how == "zero":
        raw[at : at + n] = bytes(n)
    else:
        for i in range(n):
            raw[at + i] ^= int(rng.integers(1, 256))
    with open(dst, "wb") as fh:
        fh.write(bytes(raw))


def _chunks(path) -> list:
    """(offset, length) of the stored chunks of every record dataset."""
    out = []
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.chunks and not name.startswith(("checkpoint", "final_state")):
                for i in range(obj.id.get_num_chunks()):
                    info = obj.id.get_chunk_info(i)
                    used = min(obj.shape[0] - info.chunk_offset[0], obj.chunks[0]) * obj.dtype.itemsize
                    used *= int(np.prod(obj.shape[1:]))
                    if used > 0:
                        out.append((info.byte_offset, used))

        f.visititems(visit)
    return out


@settings(max_examples=_examples(150), **SETTINGS)
@given(data=st.data())
def test_generated_damaged_files_read(tmp_path_factory, damaged_material, data):
    """emorbit.read on a damaged file: a clean error naming the file, or the records it had.
    Read with ``probe``: without it, a damaged attribute heap can make the HDF5 library loop
    (1 case in 55 here), which no Python code can end; with it that is an error after 5 s."""
    src = damaged_material / "run.h5"
    how, at, n = data.draw(damage(os.path.getsize(src), _chunks(src)), label="damage")
    if not begin("damaged read"):
        return
    path = tmp_path_factory.mktemp("read") / "run.h5"
    _damaged_copy(src, path, how, at, n, seed=at)
    got = {}

    def read() -> int:  # as a command that reads would: an InputError is one line and exit 2
        try:
            got["result"] = emorbit.read(path, **PROBE)
        except InputError as exc:
            print(f"emorbit: error: {exc}", file=sys.stderr)
            return 2
        return 0

    res = call(read)
    cls = classify(res)
    if cls == "clean error" and str(path) not in res.err:
        cls = "vague error"
    if cls == "valid run":
        cls = "valid run" if _same_result(got["result"].si, emorbit.read(src).si) else "silent"
    record("damaged read", cls, res)


#: emorbit.read's probe: 5 s for a file of 0.6 MB that reads in 0.3 s (none where emorbit.read
#: has none, to measure the code before it)
PROBE = {"probe": 5.0} if "probe" in inspect.signature(emorbit.read).parameters else {}


def _same_result(a, b) -> bool:
    if len(a) != len(b):
        return False
    fields = ("time", "energy", "momentum", "angular_momentum")
    return all(np.array_equal(getattr(a, q), getattr(b, q)) for q in fields) and all(
        np.array_equal(a.bodies[n][q], b.bodies[n][q]) for n in b.bodies for q in b.bodies[n]
    )


@settings(max_examples=_examples(40), **SETTINGS)
@given(data=st.data())
def test_generated_damaged_files_resume(tmp_path_factory, damaged_material, data):
    """emorbit resume on a damaged file: a clean error that leaves the file as it was, or a
    continuation whose records are the unbroken run's."""
    src = damaged_material / "run.h5"
    how, at, n = data.draw(damage(os.path.getsize(src), _chunks(src)), label="damage")
    if not begin("damaged resume"):
        return
    folder = tmp_path_factory.mktemp("resume")
    path = folder / "run.h5"
    _damaged_copy(src, path, how, at, n, seed=at)
    before = path.read_bytes()
    res = cli(["resume", path, "--t-end", "9.29516 s", "-q"])
    cls = classify(res)
    if cls == "clean error" and path.read_bytes() != before:
        cls = "silent"
    if cls == "valid run":
        try:
            same = _same(records(path), records(damaged_material / "reference.h5"))
        except Exception:  # what h5py raises on a damaged file: a continuation of damage
            same = False
        cls = "valid run" if same else "silent"
    record("damaged resume", cls, res)


# -- under a memory limit, in a child process ---------------------------------------------------------
#: the child: the limit on its address space, then the command line; its exit code is emorbit's
_CHILD = r"""
import resource, sys
limit = int(sys.argv[1])
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
from emorbit.cli import console_main
console_main(sys.argv[2:])
"""
#: the address space a child may take, bytes (Numba and LLVM reserve a few hundred MB)
CHILD_MEMORY = 3 << 30


@pytest.mark.parametrize(
    "how",
    ["long output", "nested", "deep values", "huge mesh", "huge refinement", "seed"],
)
def test_generated_inputs_under_a_memory_limit(tmp_path, how):
    """Inputs that ask for much memory end cleanly inside an address space of 3 GiB: refused
    before they allocate, never a MemoryError traceback or a kill."""
    if not begin("memory limit"):
        return
    d = copy.deepcopy(SCENES["three"] if how in ("huge mesh", "huge refinement") else SCENES["point"])
    argv = ["run", "scene.toml", "-o", "out.h5", "-q"]
    if how == "long output":
        d["integrator"].update({"dt": "1e-6 s", "t_end": "1e6 s"})  # 1e12 records: refused by max_output
    elif how == "nested":
        pass  # written into the text below
    elif how == "deep values":
        d["body"][0]["name"] = "n" * 1_000_000
    elif how == "huge mesh":
        d["body"][2]["elements"] = 10**9
    elif how == "huge refinement":
        d["body"][1]["refinement"] = 10**6
    else:
        (tmp_path / "sweep.toml").write_text(f'[sweep]\nscene = "paper-ellipse"\nseed = {2**70}\n')
        argv = ["sweep", "sweep.toml", "-o", "out", "--serial", "-q"]
    text = to_toml(d)
    if how == "nested":
        text = text.replace('["integrator"]\n', '["integrator"]\nx = ' + "[" * 50_000 + "]" * 50_000 + "\n", 1)
    (tmp_path / "scene.toml").write_text(text)
    done = subprocess.run(
        [sys.executable, "-c", _CHILD, str(CHILD_MEMORY), *argv],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    res = Case(done.returncode, done.stdout, done.stderr)
    record("memory limit", classify(res) if done.returncode >= 0 else f"killed by signal {-done.returncode}", res)
