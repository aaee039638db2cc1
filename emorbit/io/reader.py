"""The run file's layout, and reading a run file back into a :class:`~emorbit.result.Result`.

Layout (docs/hdf5.md lists every dataset and attribute): ``/time`` (s), ``/invariants/``
``energy`` (J), ``energy_range`` (J: the least and the greatest total energy over the steps
of the record interval that ends at each record), ``momentum`` (kg m / s) and
``angular_momentum`` (kg m2 / s, about the field's centre), ``/diagnostics/``
``newton_iterations``, ``split_steps``, ``stalled_solves``, ``invariant_drift`` and
``drift_bound`` (1, :mod:`emorbit.io.drift`), one row per record; ``/bodies/<name>/``
``position`` (m) and ``velocity`` (m / s) of every body, ``attitude`` and
``angular_velocity`` (rad / s) of rigid bodies, ``nodes/position`` and ``nodes/time`` of
elastic ones, and what is written once (``mass_points/...``, ``mesh/...``). Every dataset has
a ``unit`` attribute. Root attributes with a unit are followed by ``<name>_unit``
(:data:`ROOT_UNITS`); checkpoint arrays carry theirs (:data:`STATE_UNITS`).

:func:`open_run_file` opens a file read-only and checks this layout (:func:`check_layout`),
with errors that say what a file is not; :func:`read` returns its records, as far as they
are complete in every dataset (a run killed while appending may leave some datasets a block
longer than others). Files of earlier versions lack the datasets of :data:`OPTIONAL`; their
rows read as it says (``energy_range``: the record's energy twice).
:mod:`emorbit.io.hdf5` writes the files.
"""

from __future__ import annotations

import hashlib
import os
import stat

import h5py
import numpy as np

from ..errors import InputError
from ..result import Result

__all__ = [
    "read",
    "open_run_file",
    "check_layout",
    "LAYOUT_UNITS",
    "WIDTHS",
    "OPTIONAL",
    "ROOT_UNITS",
    "STATE_UNITS",
    "NEXT_CHECKPOINT",
    "optional_rows",
    "read_events",
    "state_digest",
    "probe",
    "not_regular",
    "file_path",
    "read_dataset",
    "verify_checksums",
    "damage_message",
    "DAMAGE",
    "writer_id",
    "live_writer",
    "EFFECT_RECORDS",
]

#: the unit attribute of each top-level dataset
LAYOUT_UNITS = {
    "time": "s",
    "invariants/energy": "J",
    "invariants/momentum": "kg m / s",
    "invariants/angular_momentum": "kg m2 / s",
    "diagnostics/newton_iterations": "1",
    "diagnostics/split_steps": "1",
    "diagnostics/stalled_solves": "1",
    "diagnostics/invariant_drift": "1",
    "diagnostics/drift_bound": "1",
    "invariants/energy_range": "J",
}
#: the width of each top-level dataset's rows (None: one value per record)
WIDTHS = {name: None for name in LAYOUT_UNITS} | {
    "invariants/momentum": 3,
    "invariants/angular_momentum": 3,
    "diagnostics/invariant_drift": 3,
    "invariants/energy_range": 2,
}
#: record datasets that files of earlier versions lack, and the value their rows read as
#: (None: ``invariants/energy_range`` reads as the record's energy, twice)
OPTIONAL = {
    "diagnostics/split_steps": 0.0,
    "diagnostics/stalled_solves": 0.0,
    "diagnostics/invariant_drift": -1.0,
    "diagnostics/drift_bound": -1.0,
    "invariants/energy_range": None,
}


def state_digest(arrays: dict, steps: int, time: float) -> str:
    """A SHA-256 digest of a stored state: its arrays (names, shapes, float64 bytes), its step
    count and time. ``/checkpoint`` and ``/final_state`` carry it as the attribute ``digest``,
    so that a resume refuses a state changed by a single byte since it was written.

    Parameters
    ----------
    arrays : dict
        {``"<kind>/<field>"``: array}.
    steps : int
        Steps since the run's start.
    time : float
        The state's time, s.

    Returns
    -------
    str
        64 hex digits.
    """
    h = hashlib.sha256(f"{int(steps)} {float(time)!r}".encode())
    for key in sorted(arrays):
        a = np.ascontiguousarray(np.asarray(arrays[key], float))
        h.update(f"{key} {a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def optional_rows(f, name: str, n: int) -> np.ndarray:
    """The first ``n`` rows of the optional record dataset ``name`` of an open run file, or
    what they read as in a file of an earlier version that lacks it (:data:`OPTIONAL`)."""
    if name in f:
        return read_dataset(f[name], f.filename, n)
    width = WIDTHS[name]
    if OPTIONAL[name] is None:  # energy_range: the record's energy, as least and greatest
        return np.repeat(f["invariants/energy"][:n][:, None], 2, axis=1)
    return np.full((n,) if width is None else (n, width), OPTIONAL[name])


#: root attributes that have a unit: each is written with a companion ``<name>_unit``
ROOT_UNITS = {
    "dt": "s",
    "t_start": "s",
    "t_end": "s",
    "gm": "m3 / s2",
    "center": "m",
    "field_radius": "m",
    "checkpoint_seconds": "s",
}

#: the ``unit`` attribute of each state array in /checkpoint and /final_state (a system may
#: add its own in a ``STATE_UNITS`` class attribute, {field: unit})
STATE_UNITS = {
    **dict.fromkeys(("point/x", "point/cx"), "m"),
    **dict.fromkeys(("point/v", "point/cv"), "m / s"),
    **dict.fromkeys(("rigid/q", "rigid/cq"), "m (columns 0-2), 1 (columns 3-11)"),
    **dict.fromkeys(("rigid/v", "rigid/cv"), "m / s (columns 0-2), 1 / s (columns 3-11)"),
    **dict.fromkeys(("rigid/lam", "structure/lam"), "J"),
    **dict.fromkeys(("structure/u", "structure/cu"), "m (rigid-body axes: 1)"),
    **dict.fromkeys(("structure/v", "structure/cv"), "m / s (rigid-body axes: 1 / s)"),
    "structure/acc": "m / s2 (rigid-body axes: 1 / s2)",
    "structure/lu_steps": "s",
    "structure/lu_jacobians": "mixed: the Newton system's Jacobian values, CSC order",
    "structure/last_iterations": "s (column 0), 1 (column 1)",
}

#: where a new checkpoint is written before it replaces /checkpoint
NEXT_CHECKPOINT = "checkpoint_next"


def _locked(exc: BaseException) -> bool:
    return "unable to lock file" in str(exc)


def _busy_message(path: str, writer: str | None = None) -> str:
    how = "it holds the file's HDF5 lock" if writer is None else f"{writer}, its status 'running'"
    return (
        f"{path!r} is being written by another process ({how}); "
        "wait for that run to end, stop it, or choose another name"
    )


#: what each kind of file that is not a regular one is called in messages
_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
)


def file_path(path, key: str = "file") -> str:
    """A path given as str, bytes or os.PathLike, as str.

    Parameters
    ----------
    path : str, bytes or os.PathLike
        The path.
    key : str
        The name the error gives it.

    Returns
    -------
    str
        The path (bytes decoded as the file system does).

    Raises
    ------
    InputError
        Anything else, or a path that holds a NUL character.
    """
    try:
        text = os.fsdecode(os.fspath(path))
    except TypeError:
        raise InputError(key, f"a path (a string) expected, got {path!r}") from None
    if "\0" in text:  # the operating system's calls would raise ValueError
        raise InputError(key, f"a path cannot hold a NUL character, got {text!r}")
    return text


def not_regular(path) -> str | None:
    """What an existing path is when it is not a regular file (a link is followed), found
    without opening it: a FIFO would block an open, and writing a device would write the device.

    Parameters
    ----------
    path : str
        The path.

    Returns
    -------
    str or None
        None for a regular file, a path that does not exist or a link to nothing; else
        what it is ("a FIFO (named pipe)", "a character device", "a folder", ...).
    """
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:
        return f"a path that cannot be inspected ({exc.strerror or exc})"
    if stat.S_ISREG(mode):
        return None
    return next((what for test, what in _KINDS if test(mode)), "not a regular file")


def _alive(pid: int) -> bool:
    """Whether a process with this id runs (on this machine)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # another user's, or not ours to ask: count it as running
    return True


def _process_start(pid: int) -> int | None:
    """When a process started, in clock ticks since boot (Linux), so that a process id that
    was reused is not taken for the process that had it; None where it cannot be told."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            return int(fh.read().rsplit(b")", 1)[1].split()[19])
    except (OSError, ValueError, IndexError):
        return None


def writer_id() -> str:
    """Who writes a run file: this machine's name, this process's id and start (JSON), the
    root attribute ``writer`` that :func:`live_writer` reads."""
    import json
    import socket

    return json.dumps({"host": socket.gethostname(), "pid": os.getpid(), "start": _process_start(os.getpid())})


def live_writer(attrs) -> str | None:
    """The process that still writes a run file whose status is "running", where it can be
    told: one on this machine (not this process) that runs and started when the file's
    ``writer`` attribute says. This catches a second writer where the file system does not
    take HDF5's file locks.

    Parameters
    ----------
    attrs : mapping
        The file's root attributes.

    Returns
    -------
    str or None
        "process <pid>" while it writes; None for a finished, failed, interrupted or killed
        run, or a writer that cannot be told (another machine, a file of an earlier version).
    """
    import json
    import socket

    try:
        if str(attrs.get("status", "")) != "running":
            return None
        info = json.loads(attrs["writer"])
        pid, host, start = int(info["pid"]), info["host"], info.get("start")
    except (KeyError, ValueError, TypeError, OSError, RuntimeError):
        return None
    if host != socket.gethostname() or pid == os.getpid() or not _alive(pid):
        return None
    if start is not None and _process_start(pid) not in (None, start):
        return None  # the id now names another process
    return f"process {pid}"


def open_run_file(path, key: str = "file", *, peek: bool = False) -> h5py.File:
    """Open an emorbit run file read-only, with errors that say what the file is not.

    Parameters
    ----------
    path : str, bytes or os.PathLike
        The file.
    key : str
        The name the errors give the file (``"file"``, ``"files"``).
    peek : bool
        If another process is writing the file (and holds its lock), read it without the
        lock (what the writer has flushed); otherwise that is an error.

    Returns
    -------
    h5py.File
        Open for reading, with the layout of a run file (:func:`check_layout`).

    Raises
    ------
    InputError
        The file does not exist, is not HDF5 or not a run file, or another process writes it
        (without ``peek``).
    """
    path = file_path(path, key)
    if not os.path.exists(path):
        raise InputError(key, f"{path!r} does not exist")
    if (what := not_regular(path)) is not None:
        raise InputError(key, f"{path!r} is {what}, not a run file")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        f = None
        if _locked(exc) and peek:
            try:
                f = h5py.File(path, "r", locking=False)
            except OSError:
                pass
        if f is None:
            if _locked(exc):
                raise InputError(key, _busy_message(path)) from None
            if "signature" in str(exc):
                raise InputError(key, f"{path!r} is not an HDF5 file (an emorbit run file is one)") from None
            raise InputError(key, f"{path!r} cannot be read as an HDF5 file ({exc})") from None
    try:
        check_layout(f, path, key)
    except InputError:
        f.close()
        raise
    except DAMAGE as exc:  # h5py on a damaged file
        f.close()
        raise InputError(key, f"{path!r} is damaged: its layout cannot be read ({damage_message(exc)})") from None
    except BaseException:
        f.close()
        raise
    return f


#: what :func:`probe` runs in a child process: every attribute of every object, every dataset
#: (up to 64 MiB each, else its last rows), each read on its own so that one error does not
#: end the probe
_PROBE = r"""
import sys, h5py
def read(get):
    try:
        get()
    except Exception:
        pass
def attrs(obj):
    names = []
    read(lambda: names.extend(obj.attrs))
    for k in names:
        read(lambda: obj.attrs[k])
def visit(name, obj):
    attrs(obj)
    if isinstance(obj, h5py.Dataset):
        read(lambda: obj[()] if obj.size * obj.dtype.itemsize <= 1 << 26 else obj[-2:])
with h5py.File(sys.argv[1], "r", locking=False) as f:
    attrs(f)
    read(lambda: f.visititems(visit))
"""


def probe(path, seconds: float | None = None) -> str | None:
    """Read a file in a child process first: the HDF5 library can loop forever or crash on a
    damaged file (a byte of an attribute's heap overwritten), where no error reaches Python.

    Parameters
    ----------
    path : str
        The file.
    seconds : float, optional
        How long the child may read (default: 10 s plus 1 s per 100 MB).

    Returns
    -------
    str or None
        None where the child's reading ends (errors it met are left to the caller's own
        reading, which raises them); otherwise what went wrong.
    """
    import subprocess
    import sys

    if seconds is None:
        seconds = 10.0 + os.path.getsize(path) / 1e8
    try:
        done = subprocess.run(
            [sys.executable, "-c", _PROBE, os.fspath(path)], capture_output=True, timeout=seconds, check=False
        )
    except subprocess.TimeoutExpired:
        return f"reading it does not end within {seconds:.0f} s (the HDF5 library loops on a damaged part)"
    if done.returncode < 0:
        return f"reading it crashes the HDF5 library (signal {-done.returncode}): the file is damaged"
    return None


_probe = probe  # read() takes an argument of this name


#: the record datasets of effects, one per effect (or the balance of those that do work)
EFFECT_RECORDS = (
    "invariants/potential_",
    "invariants/work_",
    "invariants/energy_balance",
    "invariants/jacobi",
    "invariants/ledger_",
)


def check_layout(f: h5py.File, path: str, key: str = "file") -> None:
    """Check that an open HDF5 file has the layout of an emorbit run file.

    Parameters
    ----------
    f : h5py.File
        The open file.
    path : str
        Its path, for the messages.
    key : str
        The name the errors give the file.

    Raises
    ------
    InputError
        A dataset, group or root attribute of the layout is missing or has the wrong shape, or
        a name in /invariants or /diagnostics is not one emorbit writes, naming it.
    """
    what = f"{path!r} is an HDF5 file but not an emorbit run file"
    if "time" not in f and "bodies" not in f and "method" not in f.attrs:
        raise InputError(key, f"{what} (it has no /time, no /bodies and no 'method' attribute)")
    try:
        f.visit(lambda name: None)
    except (TypeError, UnicodeDecodeError):  # h5py on a name that is not UTF-8 text
        raise InputError(key, f"{path!r} is damaged: the name of a group or dataset is not text") from None
    for group in ("invariants", "diagnostics"):  # a damaged name would pass for a dataset of an earlier version
        for name in f[group] if isinstance(f.get(group), h5py.Group) else ():
            if f"{group}/{name}" not in LAYOUT_UNITS and not f"{group}/{name}".startswith(EFFECT_RECORDS):
                raise InputError(key, f"{path!r}: /{group}/{name} is not a dataset emorbit writes (a damaged name?)")
    for name in LAYOUT_UNITS:
        if name in OPTIONAL and name not in f:
            continue  # absent in files of earlier versions: read as OPTIONAL says
        if not isinstance(f.get(name), h5py.Dataset):
            raise InputError(key, f"{what}: dataset /{name} is missing")
        width = () if WIDTHS[name] is None else (WIDTHS[name],)
        if f[name].ndim != 1 + len(width) or f[name].shape[1:] != width:
            raise InputError(
                key,
                f"{path!r}: dataset /{name} has shape {f[name].shape}, expected (n{''.join(f', {w}' for w in width)})",
            )
    if not isinstance(f.get("bodies"), h5py.Group):
        raise InputError(key, f"{what}: group /bodies is missing")
    for attr in ("method", "order", "dt", "gm", "center"):
        if attr not in f.attrs:
            raise InputError(key, f"{what}: root attribute {attr!r} is missing")


def _rows(f) -> int:
    """Records complete in every record dataset (a run killed while appending may leave some
    datasets a block longer than others)."""
    n = min(f[name].shape[0] for name in LAYOUT_UNITS if name in f)
    for g in f["bodies"].values():
        for ds in g.values():
            if isinstance(ds, h5py.Dataset) and ds.maxshape and ds.maxshape[0] is None:
                n = min(n, ds.shape[0])
    return n


def _attr(f, path: str, name: str, kind):
    value = f.attrs[name]
    try:
        return kind(value.item() if isinstance(value, np.generic) else value)
    except (TypeError, ValueError):
        raise InputError("file", f"{path!r}: root attribute {name!r} is {value!r}, not a {kind.__name__}") from None


#: what h5py raises on a file whose bytes were changed (a checksum that fails, a damaged
#: heap or object header): each is reported as damage, naming what was being read
DAMAGE = (OSError, RuntimeError, KeyError, ValueError, TypeError, AttributeError, IndexError, MemoryError)


def damage_message(exc: BaseException) -> str:
    """What an h5py error on a damaged file says, in one line (a failing Fletcher-32 checksum in
    words).

    Parameters
    ----------
    exc : BaseException
        The error.

    Returns
    -------
    str
        The line.
    """
    text = " ".join(str(exc).split())
    if "filter returned failure" in text:
        return "its Fletcher-32 checksum fails: bytes in it changed since they were written"
    return text or type(exc).__name__


def _chunk_starts(ds) -> list[int]:
    """Where along the first axis each chunk the file holds for ``ds`` starts, sorted (only
    chunks that were written: a damaged shape may claim many more rows than that)."""
    return sorted({ds.id.get_chunk_info(i).chunk_offset[0] for i in range(ds.id.get_num_chunks())})


def _damaged_rows(ds, rows: int | None) -> str:
    """Which rows of a chunked dataset cannot be read, chunk by chunk along the first axis
    ("rows 0 to 1023, 2048 to 2499"), or "" when that cannot be told."""
    if not ds.chunks or ds.ndim == 0:
        return ""
    n = ds.shape[0] if rows is None else min(rows, ds.shape[0])
    bad = []
    try:
        starts = [a for a in _chunk_starts(ds) if a < n]
    except DAMAGE:
        return ""
    for start in starts:
        stop = min(start + ds.chunks[0], n)
        try:
            ds[start:stop]
        except DAMAGE:
            if bad and bad[-1][1] == start - 1:
                bad[-1][1] = stop - 1
            else:
                bad.append([start, stop - 1])
    return ", ".join(f"{a} to {b}" if b > a else f"{a}" for a, b in bad)


def _claim(ds, rows: int | None) -> str | None:
    """Why a dataset cannot hold what its shape says: more bytes than its file has (a shape
    that was damaged), or None."""
    n = ds.shape[0] if rows is None or ds.ndim == 0 else min(rows, ds.shape[0])
    size = n * ds.dtype.itemsize * int(np.prod(ds.shape[1:], dtype=np.int64))
    limit = os.path.getsize(ds.file.filename) + (1 << 20)  # a chunk, 1 MiB at most, may be partly filled
    return f"its shape {ds.shape} claims {size:,} bytes, more than the file holds" if size > limit else None


def read_dataset(ds, path: str, rows: int | None = None, key: str = "file") -> np.ndarray:
    """A dataset's first ``rows`` rows (all of it when None), or an error that names the
    dataset and the rows that cannot be read (a Fletcher-32 checksum that fails: the file was
    damaged since it was written).

    Parameters
    ----------
    ds : h5py.Dataset
        The dataset.
    path : str
        Its file's path, for the message.
    rows : int, optional
        Rows to read.
    key : str
        The name the error gives the file.

    Returns
    -------
    ndarray
        The rows.

    Raises
    ------
    InputError
        The rows cannot be read.
    """
    try:
        if (claim := _claim(ds, rows)) is not None:
            raise InputError(key, f"{path!r} is damaged: dataset {ds.name}: {claim}")
        return ds[()] if rows is None else ds[:rows]
    except InputError:
        raise
    except DAMAGE as exc:
        which = _damaged_rows(ds, rows)
        where = f"dataset {ds.name}" + (f", rows {which}," if which else "")
        raise InputError(key, f"{path!r} is damaged: {where} cannot be read ({damage_message(exc)})") from None


def verify_checksums(f, path: str, key: str = "file") -> None:
    """Read every chunk of every dataset of an open file that carries Fletcher-32 checksums,
    so that a changed byte anywhere in them is an error naming the dataset and its rows.
    Datasets of files written before checksums are not checked.

    Parameters
    ----------
    f : h5py.File
        The open file.
    path : str
        Its path, for the message.
    key : str
        The name the error gives the file.

    Raises
    ------
    InputError
        A dataset whose checksum fails.
    """
    found = []
    f.visititems(lambda name, obj: found.append(obj) if isinstance(obj, h5py.Dataset) and obj.fletcher32 else None)
    for ds in found:
        try:
            if (claim := _claim(ds, None)) is not None:
                raise InputError(key, f"{path!r} is damaged: dataset {ds.name}: {claim}")
            for start in _chunk_starts(ds):  # the chunks the file holds, one by one
                ds[start : start + ds.chunks[0]]
        except InputError:
            raise
        except DAMAGE:
            read_dataset(ds, path, key=key)  # names the rows
            raise


def read(path, *, probe: bool | float = False) -> Result:
    """Read a run file.

    A file that another run is writing is read as far as that run has flushed it; records
    that are complete in every dataset are returned.

    Parameters
    ----------
    path : str, bytes or os.PathLike
        An HDF5 file written by emorbit.
    probe : bool or float
        Read the file in a child process first (:func:`probe`, about 0.3 s more): on some
        damaged files (an attribute's heap or an object header overwritten) the HDF5 library
        loops forever or crashes, where no error reaches Python; with ``probe`` such a file
        is an InputError. A number is how long the child may read, s (True: 10 s plus 1 s
        per 100 MB). ``emorbit resume`` always probes.

    Returns
    -------
    Result
        Every record, SI arrays; ``attrs`` holds the root attributes.

    Raises
    ------
    InputError
        The file does not exist, is not HDF5 or is not an emorbit run file, or it is damaged:
        a dataset whose Fletcher-32 checksum fails (named, with the rows that cannot be read),
        or a part that h5py cannot read (named).
    """
    path = file_path(path)
    seconds = None if probe is True else float(probe)
    if probe and os.path.isfile(path) and (problem := _probe(path, seconds)) is not None:
        raise InputError("file", f"{path!r} is damaged: {problem}")
    with open_run_file(path, peek=True) as f:
        at = ["the record datasets' lengths"]  # the part being read, for the message
        try:
            return _read(f, path, at)
        except InputError:
            raise
        except DAMAGE as exc:  # h5py on a damaged part that no checksum covers: say which
            raise InputError("file", f"{path!r} is damaged: {at[0]} cannot be read ({damage_message(exc)})") from None


def _read(f, path: str, at: list) -> Result:
    """:func:`read` of the open file; ``at[0]`` says what is being read."""
    n = _rows(f)
    bodies, masses, kinds = {}, {}, {}
    for name, g in f["bodies"].items():
        at[0] = f"group /bodies/{name}"
        bodies[name] = {q: read_dataset(ds, path, n) for q, ds in g.items() if isinstance(ds, h5py.Dataset)}
        if "nodes" in g:
            nodes = {q: read_dataset(ds, path) for q, ds in g["nodes"].items()}
            k = min(len(a) for a in nodes.values())
            bodies[name].update({f"nodes/{q}": a[:k] for q, a in nodes.items()})
        for sub in ("mesh", "mass_points"):
            if isinstance(g.get(sub), h5py.Group):
                bodies[name].update({f"{sub}/{q}": read_dataset(ds, path) for q, ds in g[sub].items()})
        if "mass" not in g.attrs or "kind" not in g.attrs:
            raise InputError("file", f"{path!r}: group /bodies/{name} has no 'mass' or 'kind' attribute")
        masses[name] = float(g.attrs["mass"])
        kinds[name] = str(g.attrs["kind"])
    at[0] = "the record datasets"
    diag = {name.split("/")[1]: optional_rows(f, name, n) for name in OPTIONAL}
    at[0] = "the root attributes"
    center = np.asarray(f.attrs["center"], float)
    if center.shape != (3,):
        raise InputError("file", f"{path!r}: root attribute 'center' has shape {center.shape}, expected (3,)")
    attrs = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in f.attrs.items()}
    at[0] = "group /invariants"
    invariants = f["invariants"]
    return Result(
        time=read_dataset(f["time"], path, n),
        energy=read_dataset(f["invariants/energy"], path, n),
        momentum=read_dataset(f["invariants/momentum"], path, n),
        angular_momentum=read_dataset(f["invariants/angular_momentum"], path, n),
        newton_iterations=read_dataset(f["diagnostics/newton_iterations"], path, n),
        bodies=bodies,
        masses=masses,
        kinds=kinds,
        method=_attr(f, path, "method", str),
        order=_attr(f, path, "order", int),
        dt=_attr(f, path, "dt", float),
        gm=_attr(f, path, "gm", float),
        center=center,
        attrs=attrs,
        work={k[len("work_") :]: read_dataset(ds, path, n) for k, ds in invariants.items() if k.startswith("work_")},
        energy_balance=read_dataset(invariants["energy_balance"], path, n) if "energy_balance" in invariants else None,
        ledger={k[7:]: read_dataset(ds, path, n) for k, ds in invariants.items() if k.startswith("ledger_")},
        events=read_events(f, path),
        **diag,
    )


def read_events(f, path) -> list:
    """The ``events/`` group as the list :attr:`emorbit.result.ResultSI.events` holds."""
    if "events" not in f or "time" not in f["events"]:
        return []
    g = f["events"]
    cols = {q: read_dataset(g[q], path) for q in ("time", "step", "position", "velocity", "dv", "work")}
    text = {q: [v.decode() if isinstance(v, bytes) else str(v) for v in g[q][()]] for q in ("label", "kind", "body")}
    n = min(len(cols["time"]), *(len(v) for v in text.values()))
    return [
        {"label": text["label"][i], "kind": text["kind"][i], "body": text["body"][i], "time": float(cols["time"][i]),
         "step": int(cols["step"][i]), "position": cols["position"][i], "velocity": cols["velocity"][i],
         "dv": cols["dv"][i], "work": float(cols["work"][i])}
        for i in range(n)
    ]  # fmt: skip
