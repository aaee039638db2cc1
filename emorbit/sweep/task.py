"""One run of a sweep, as a worker does it, and its result file.

A worker builds the run's scene, runs it into a temporary file beside the final one
(``runs/.run-000012.h5.<random>.tmp``), adds the ``/sweep`` group (the run's index, seed,
parameter values, digest and summary row), flushes it to disk and only then renames it to
``runs/run-000012.h5``. A rename within a folder is atomic, so the final name never points at
a half-written file: a worker killed at any moment leaves at most hidden ``.tmp`` files
(its own, and one the run's writer made beside it), which the client removes. A run is
*finished* when its final file exists, its root attribute ``status`` is ``completed`` or
``failed`` and its ``/sweep`` digest matches the run; a finished run is never run again
(resume), and a task that finds its run finished returns the stored row, so running a task
twice (a retry after a lost worker, a duplicate scheduled by Dask) gives one file and one row.

A run that fails is recorded, not raised: bad input (:class:`~emorbit.errors.InputError`)
gives a file holding only the ``/sweep`` group and the error; a step that fails
(:class:`~emorbit.errors.IntegrationError`) keeps the records before it, as ``emorbit run``
does. Both have status ``failed`` and the error in the root attribute ``error``.
"""

from __future__ import annotations

import json
import math
import os
import socket
import time
import traceback
import uuid

import h5py
import numpy as np

from .._version import __version__
from ..errors import InputError, IntegrationError
from ..orbits import elements
from .spec import run_scene

__all__ = ["run_task", "read_row", "ELEMENTS", "row_columns", "run_file_name", "limit_threads", "TASK_TEMP"]

#: the final osculating elements each listed body gets in the summary (name, unit)
ELEMENTS = (("a", "m"), ("e", "1"), ("i", "rad"), ("raan", "rad"), ("argp", "rad"), ("nu", "rad"))
#: summary columns after the parameters (name, unit)
RESULT_COLUMNS = (
    ("status", ""),
    ("error", ""),
    ("t_final", "s"),
    ("records", "1"),
    ("energy_error", "1"),
    ("angular_momentum_error", "1"),
    ("newton_mean", "1"),
    ("newton_max", "1"),
)
FINISHED = ("completed", "failed")
#: the whole name of a worker's temporary file for a run (a regular expression):
#: ``.run-000012.h5.<12 random hex digits>.tmp``, renamed to the run's file when it is complete
TASK_TEMP = r"\.run-\d{6,}\.h5\.[0-9a-f]{12}\.tmp"


def run_file_name(index: int) -> str:
    """The file name of run ``index``: ``run-000012.h5``.

    Parameters
    ----------
    index : int
        The run's number.

    Returns
    -------
    str
        The name.
    """
    return f"run-{index:06d}.h5"


def row_columns(parameter_keys, bodies, parameter_units=None) -> list[tuple[str, str]]:
    """Every summary column, in order, with its unit.

    Parameter columns are named by their key; element columns ``<body>/<element>`` (a body
    name never holds '/'). A unit is ``"1"`` for a dimensionless number and ``""`` for text.

    Parameters
    ----------
    parameter_keys : list of str
        The parameters' keys.
    bodies : list of str
        Bodies whose final elements are listed.
    parameter_units : dict, optional
        {key: unit} of the parameter columns (default: "" each).

    Returns
    -------
    list of tuple
        (name, unit) per column.
    """
    cols = [("run", "1"), ("seed", "1")]
    cols += [(k, (parameter_units or {}).get(k, "")) for k in parameter_keys]
    cols += list(RESULT_COLUMNS)
    cols += [(f"{b}/{name}", unit) for b in bodies for name, unit in ELEMENTS]
    cols += [("wall_time", "s"), ("file", "")]
    return cols


def limit_threads(threads: int | None) -> None:
    """Set the threads of Numba (and of BLAS, where threadpoolctl is installed) in this worker.

    Parameters
    ----------
    threads : int or None
        Threads; None leaves the defaults.
    """
    if threads is None:
        return
    import numba

    numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return
    threadpool_limits(int(threads))


def read_row(path: str, digest: str | None = None):
    """The summary row stored in a finished run file.

    Parameters
    ----------
    path : str
        The run file.
    digest : str, optional
        The run's digest: a finished file of another run gives ``"mismatch"``.

    Returns
    -------
    dict or str or None
        The row; ``"mismatch"``; or None if the file is missing, unreadable or not finished.
    """
    try:
        with h5py.File(path, "r") as f:
            if str(f.attrs.get("status", "")) not in FINISHED or "sweep" not in f:
                return None
            g = f["sweep"].attrs
            if digest is not None and str(g.get("digest", "")) != digest:
                return "mismatch"
            return json.loads(str(g["row"]))
    except (OSError, KeyError, ValueError):
        return None


def _stats(f: h5py.File, bodies) -> dict:
    """Invariant errors, Newton statistics and final elements from a run file's records,
    computed as :class:`~emorbit.result.Result` computes them."""
    out = {}
    if "time" not in f or f["time"].shape[0] == 0:
        return out
    E = f["invariants/energy"][()]
    L = f["invariants/angular_momentum"][()]
    its = f["diagnostics/newton_iterations"][()]
    out["t_final"] = float(f["time"][-1])
    out["records"] = int(E.shape[0])
    with np.errstate(invalid="ignore", divide="ignore"):
        out["energy_error"] = float(np.abs((E - E[0]) / abs(E[0])).max())
        out["angular_momentum_error"] = float((np.linalg.norm(L - L[0], axis=-1) / np.linalg.norm(L[0])).max())
    out["newton_mean"] = float(np.mean(its[1:])) if its.shape[0] > 1 else 0.0
    out["newton_max"] = float(np.max(its[1:])) if its.shape[0] > 1 else 0.0
    gm = float(f.attrs.get("gm", 0.0))
    for b in bodies:
        g = f.get(f"bodies/{b}")
        if gm > 0 and g is not None and "position" in g and "velocity" in g:
            el = elements(g["position"][-1], g["velocity"][-1], gm, np.asarray(f.attrs["center"], float))
            for name, _ in ELEMENTS:
                out[f"{b}/{name}"] = float(getattr(el, name))
    return out


def _json_value(v):
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    return v


def _finish(tmp: str, final: str, task: dict, status: str, error: str, wall: float) -> dict:
    """Add the /sweep group and the row to ``tmp`` (creating it for a run that never
    started), flush it to disk and rename it to ``final``; returns the row."""
    mode = "a" if os.path.exists(tmp) else "w"
    with h5py.File(tmp, mode) as f:
        if mode == "w":
            f.attrs["creator"] = f"emorbit {__version__}"
            f.attrs["emorbit_version"] = __version__
        f.attrs["status"] = status
        if error:
            f.attrs["error"] = error
        row = {"run": task["index"], "seed": task["seed"]}
        row.update({k: _json_value(v) for k, v in task["values"].items()})
        row.update({"status": status, "error": error})
        stats = _stats(f, task["bodies"])
        for name, _ in RESULT_COLUMNS[2:]:
            row[name] = stats.get(name, math.nan if name != "records" else 0)
        for b in task["bodies"]:
            for name, _ in ELEMENTS:
                row[f"{b}/{name}"] = stats.get(f"{b}/{name}", math.nan)
        row["wall_time"] = wall
        row["file"] = os.path.join(os.path.basename(os.path.dirname(final)), os.path.basename(final))
        g = f.require_group("sweep")
        g.attrs["index"] = task["index"]
        g.attrs["seed"] = np.uint64(task["seed"])
        g.attrs["digest"] = task["digest"]
        g.attrs["values"] = json.dumps(row_values(task))
        g.attrs["row"] = json.dumps(row)
        g.attrs["wall_time"] = wall
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, final)
    try:  # make the rename itself durable
        dfd = os.open(os.path.dirname(final), os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError:
        pass
    return row


def row_values(task: dict) -> dict:
    """A task's parameter values, JSON-ready.

    Parameters
    ----------
    task : dict
        The task.

    Returns
    -------
    dict
        {key: value} with numpy scalars as Python numbers.
    """
    return {k: _json_value(v) for k, v in task["values"].items()}


def run_task(task: dict) -> dict:
    """Run one sweep task, as a worker does, and write its file.

    Never raises for a failing run: its error goes into the row. Only a failure of the worker
    itself (killed, out of memory) reaches the client, which retries the task.

    Parameters
    ----------
    task : dict
        Made by the client (:func:`emorbit.sweep.run_sweep`): the run's index, seed, values,
        digest, file, base scene, fixed values, parameters, bodies, threads and device.

    Returns
    -------
    dict
        ``row`` (the summary row), ``worker`` ({"host", "pid", "threads"}: Numba's thread
        count in the worker while it ran) and ``ran`` (False if the run was finished before).
    """
    import numba

    limit_threads(task.get("threads"))
    worker = {"host": socket.gethostname(), "pid": os.getpid(), "threads": numba.get_num_threads()}
    final = task["file"]
    if not task.get("rerun"):
        row = read_row(final, task["digest"])
        if isinstance(row, dict):
            return {"row": row, "worker": worker, "ran": False}
    folder, base = os.path.split(final)
    tmp = os.path.join(folder, f".{base}.{uuid.uuid4().hex[:12]}.tmp")  # TASK_TEMP
    start = time.perf_counter()
    status, error = "completed", ""
    try:
        base = task["scene"]
        scene = run_scene(base["data"], base["source"], task["fixed"], task["params"], task["index"], task["values"])
        sim = scene.build()
        if task.get("device", "cpu") != "cpu":
            from .device import use_device

            use_device(sim, task["device"])
        sim.run(t_end=scene.t_end, every=scene.output_every, output=tmp, overwrite=True, progress=False, keep=False)
    except (InputError, IntegrationError) as exc:
        status, error = "failed", f"{type(exc).__name__}: {exc}"
    except Exception as exc:  # a bug or a resource problem: record it with where it happened
        where = traceback.extract_tb(exc.__traceback__)[-1]
        status, error = "failed", f"{type(exc).__name__}: {exc} (at {os.path.basename(where.filename)}:{where.lineno})"
    wall = time.perf_counter() - start
    try:
        row = _finish(tmp, final, task, status, error, wall)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return {"row": row, "worker": worker, "ran": True}
