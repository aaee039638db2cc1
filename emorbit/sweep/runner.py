"""The client side of a sweep: hand the runs to an executor, retry what a lost worker took
with it, and write the summary table.

Output folder::

    OUT/runs/run-000000.h5 ...   one file per run (see emorbit.sweep.task), written atomically
    OUT/summary.csv              one row per run, columns as in emorbit.sweep.task.row_columns;
                                 a header names each column with its unit: "t_final [s]"
    OUT/summary.h5               the same table as a compound dataset /summary; attribute
                                 ``units`` (JSON, column -> unit), the sweep file in ``sweep``
"""

from __future__ import annotations

import collections
import concurrent.futures as cf
import contextlib
import csv
import datetime as _dt
import json
import math
import numbers
import os
import re
import sys
from dataclasses import dataclass, field

import h5py
import numpy as np

from .._version import __version__
from ..errors import InputError
from ..integrators import check_device
from ..integrators.dispatch import require_device
from ..io.hdf5 import temp_pattern
from .backends import make_backend
from .spec import Sweep, load_sweep
from .task import TASK_TEMP, read_row, row_columns, run_file_name, run_task

__all__ = ["run_sweep", "SweepResult", "read_summary"]

#: how often a run whose worker was lost is tried again before it is recorded as failed
RETRIES = 3


@dataclass
class SweepResult:
    """What :func:`run_sweep` did.

    Attributes
    ----------
    output : str
        The output folder (absolute).
    rows : list of dict
        One per run, in run order (columns: :attr:`columns`).
    columns : list of str
        The summary's columns, in order.
    units : dict
        {column: unit} ("1" for dimensionless numbers, "" for text).
    counts : dict
        ``total``, ``skipped`` (finished before), ``ran``, ``completed``, ``failed``,
        ``not_run`` and ``retried`` (tasks submitted again after their worker was lost).
    """

    output: str
    rows: list[dict]
    columns: list[str]
    units: dict
    counts: dict = field(default_factory=dict)

    @property
    def summary_csv(self) -> str:
        """The path of ``summary.csv``."""
        return os.path.join(self.output, "summary.csv")

    @property
    def summary_h5(self) -> str:
        """The path of ``summary.h5``."""
        return os.path.join(self.output, "summary.h5")

    def column(self, name: str) -> list:
        """One column of the summary.

        Parameters
        ----------
        name : str
            A column name.

        Returns
        -------
        list
            Its value in every row (None where a row has none).
        """
        return [r.get(name) for r in self.rows]


def _check_size(sweep: Sweep, max_runs) -> None:
    if isinstance(max_runs, bool) or not isinstance(max_runs, int) or max_runs < 1:
        raise InputError("max_runs", f"must be an integer >= 1, got {max_runs!r}")
    if len(sweep) > max_runs:
        raise InputError("max_runs", f"the sweep has {len(sweep):,} runs, more than max_runs = {max_runs:,}")


def _task_dicts(sweep: Sweep, runs_dir: str, threads, device: str) -> list[dict]:
    base = {"data": sweep.scene.data, "source": sweep.scene.source}
    params = [(p.key, p.path, p.unit) for p in sweep.parameters]
    bodies = sweep.body_names()
    out = []
    for t in sweep.tasks():
        out.append(
            {
                "index": t.index,
                "seed": t.seed,
                "values": t.values,
                "digest": t.digest,
                "file": os.path.join(runs_dir, run_file_name(t.index)),
                "scene": base,
                "fixed": sweep.fixed,
                "params": params,
                "bodies": bodies,
                "threads": threads,
                "device": device,
            }
        )
    return out


def _not_run(task: dict, status: str, error: str) -> dict:
    row = {"run": task["index"], "seed": task["seed"], **task["values"], "status": status, "error": error}
    return row


def _remove_orphans(runs_dir: str) -> None:
    """Remove temporary files of attempts that never finished (their workers died): the
    worker's ``.run-000012.h5.<random>.tmp`` (:data:`~emorbit.sweep.task.TASK_TEMP`) and the
    temporary file the run's writer made beside it (:func:`~emorbit.io.hdf5.temp_pattern`).
    Only files whose whole name is one of these are removed."""
    names = re.compile(f"{TASK_TEMP}|{temp_pattern(TASK_TEMP)}")
    for entry in os.listdir(runs_dir) if os.path.isdir(runs_dir) else ():
        if names.fullmatch(entry):
            with contextlib.suppress(OSError):
                os.remove(os.path.join(runs_dir, entry))


def run_sweep(
    sweep,
    output,
    *,
    backend: str = "process",
    workers: int | None = None,
    threads: int | None = 1,
    scheduler: str | None = None,
    executor: cf.Executor | None = None,
    device: str = "cpu",
    retries: int = RETRIES,
    rerun_failed: bool = False,
    overwrite: bool = False,
    on_result=None,
    progress: bool | None = None,
    max_runs: int | None = None,
) -> SweepResult:
    """Run every run of a sweep not yet finished in a folder, then write the summary of all.

    A run that fails is recorded in its row (status "failed", the error) and the sweep goes
    on; running again skips finished runs.

    Parameters
    ----------
    sweep : Sweep or str or os.PathLike
        A parsed sweep or the path of a sweep file.
    output : str or os.PathLike
        The output folder (its parent must exist); one folder holds one sweep.
    backend : str
        ``"process"`` (default), ``"dask"``, ``"mpi"`` or ``"serial"`` (:mod:`.backends`).
    workers : int, optional
        Processes (process, mpi) or LocalCluster workers (default: one per core).
    threads : int or None
        Numba threads per worker (default 1; None: Numba's default).
    scheduler : str, optional
        ``tcp://HOST:PORT``: run on an existing Dask cluster.
    executor : concurrent.futures.Executor, optional
        Run on this executor, which the caller owns.
    device : str
        ``"cpu"`` or ``"gpu"``: where point masses step (:mod:`.device`).
    retries : int
        Times a run is tried again after its worker was lost.
    rerun_failed : bool
        Run again the runs that failed before (by default a finished run, failed or not, is
        kept).
    overwrite : bool
        Replace run files of a different sweep found in ``output`` (otherwise an error).
    on_result : callable, optional
        Called in this process as ``on_result(row, worker)`` for every run that finishes now
        (``worker``: {"host", "pid", "threads"} that ran it).
    progress : bool, optional
        A progress bar on stderr; default: when stderr is a terminal.
    max_runs : int, optional
        The most runs the sweep may have; default: the sweep file's ``max_runs``, else
        :data:`emorbit.sweep.spec.MAX_RUNS` (100,000). Counted before anything is listed.

    Returns
    -------
    SweepResult
        Every run's row, the columns and units, and the counts.

    Raises
    ------
    InputError
        A bad sweep or option, more runs than ``max_runs``, or a folder holding another
        sweep, before anything runs.
    """
    if not isinstance(sweep, Sweep):
        sweep = load_sweep(sweep, max_runs)
    elif max_runs is not None:
        _check_size(sweep, max_runs)
    check_device(device)
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise InputError("retries", f"must be an integer >= 0, got {retries!r}")
    output = os.path.abspath(os.fspath(output))
    parent = os.path.dirname(output)
    if not os.path.isdir(parent):
        raise InputError("output", f"folder {parent!r} does not exist")
    if os.path.exists(output) and not os.path.isdir(output):
        raise InputError("output", f"{output!r} exists and is not a folder")
    be = make_backend(backend, workers=workers, threads=threads, scheduler=scheduler, executor=executor)
    if device == "gpu" and (be.name in ("serial", "process") or (be.name == "dask" and scheduler is None)):
        require_device(device)  # local workers: say now, before anything runs
    runs_dir = os.path.join(output, "runs")
    tasks = _task_dicts(sweep, runs_dir, None if be.name == "serial" else threads, device)
    columns = row_columns(
        [p.key for p in sweep.parameters], sweep.body_names(), {p.key: p.column_unit for p in sweep.parameters}
    )
    rows: dict[int, dict] = {}
    pending, mismatched = [], set()
    for t in tasks:
        row = read_row(t["file"], t["digest"])
        if row == "mismatch":
            mismatched.add(t["index"])
        elif row is not None and (not rerun_failed or row.get("status") == "completed"):
            rows[t["index"]] = row
            continue
        pending.append(t)
        t["rerun"] = row is not None
    if mismatched and not overwrite:
        first = run_file_name(min(mismatched))
        raise InputError(
            "output",
            f"{runs_dir!r} holds {len(mismatched)} run files of a different sweep (first: "
            f"{first}); use another output folder, or overwrite to replace them",
        )
    counts = {
        "total": len(tasks),
        "skipped": len(rows),
        "ran": 0,
        "completed": 0,
        "failed": 0,
        "not_run": 0,
        "retried": 0,
    }
    ex = be.start() if pending else None  # a scheduler out of reach is an InputError: nothing written yet
    try:
        os.makedirs(runs_dir, exist_ok=True)
        _remove_orphans(runs_dir)
        _write_meta(output, sweep)
        if pending:
            _run_all(be, ex, pending, rows, counts, retries, on_result, progress)
    finally:
        if ex is not None:
            be.close()
        result = _finish(output, sweep, tasks, rows, columns, counts, be)
    return result


def _run_all(be, ex, pending, rows, counts, retries, on_result, progress) -> None:
    from tqdm.auto import tqdm

    if progress is None:
        progress = sys.stderr.isatty()
    queue = collections.deque(pending)
    attempts = collections.Counter()
    inflight: dict = {}
    with tqdm(
        total=len(pending),
        disable=not progress,
        unit="run",
        file=sys.stderr,
        dynamic_ncols=True,
        leave=False,
        delay=1.0,
    ) as bar:
        while queue or inflight:
            while queue and (be.window is None or len(inflight) < be.window):
                t = queue.popleft()
                try:
                    inflight[ex.submit(run_task, t)] = t
                except cf.BrokenExecutor:
                    queue.appendleft(t)
                    ex = _recover(be, inflight, queue, attempts, rows, counts, retries)
            done, _ = cf.wait(list(inflight), return_when=cf.FIRST_COMPLETED)
            broken = False
            for fut in done:
                t = inflight.pop(fut)
                try:
                    out = fut.result()
                except Exception as exc:  # the worker was lost (run_task itself never raises)
                    broken |= isinstance(exc, cf.BrokenExecutor)
                    _lost(t, exc, queue, attempts, rows, counts, retries)
                    continue
                row = out["row"]
                rows[t["index"]] = row
                counts["ran"] += bool(out.get("ran", True))
                bar.update(1)
                if on_result is not None:
                    on_result(row, out.get("worker"))
            if broken:
                ex = _recover(be, inflight, queue, attempts, rows, counts, retries)


def _lost(t, exc, queue, attempts, rows, counts, retries) -> None:
    i = t["index"]
    attempts[i] += 1
    if attempts[i] <= retries:
        counts["retried"] += 1
        queue.append(t)
    else:
        rows[i] = _not_run(t, "failed", f"worker lost {attempts[i]} times; last: {type(exc).__name__}: {exc}")


def _recover(be, inflight, queue, attempts, rows, counts, retries):
    """A broken pool fails every task it held: collect them, requeue, start a new pool."""
    if inflight:
        cf.wait(list(inflight))
        for fut, t in list(inflight.items()):
            exc = fut.exception()
            if exc is None:
                rows[t["index"]] = fut.result()["row"]
                counts["ran"] += 1
            else:
                _lost(t, exc, queue, attempts, rows, counts, retries)
        inflight.clear()
    return be.restart()


def _write_meta(output: str, sweep: Sweep) -> None:
    path = os.path.join(output, "sweep.toml")
    if sweep.text:
        tmp = path + ".tmp"
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(sweep.text)
        os.replace(tmp, path)


def _finish(output, sweep, tasks, rows, columns, counts, be) -> SweepResult:
    _remove_orphans(os.path.join(output, "runs"))
    ordered = []
    for t in tasks:
        row = rows.get(t["index"])
        if row is None:
            row = _not_run(t, "not run", "the sweep stopped before this run")
        ordered.append(row)
    counts["completed"] = sum(r.get("status") == "completed" for r in ordered)
    counts["failed"] = sum(r.get("status") == "failed" for r in ordered)
    counts["not_run"] = sum(r.get("status") == "not run" for r in ordered)
    names = [c for c, _ in columns]
    units = dict(columns)
    _write_csv(os.path.join(output, "summary.csv"), names, units, ordered)
    _write_h5(os.path.join(output, "summary.h5"), names, units, ordered, sweep, be, counts)
    return SweepResult(output=output, rows=ordered, columns=names, units=units, counts=dict(counts))


def _text(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (list, dict)):
        return json.dumps(v)
    return str(v)


def _csv_header(name: str, unit: str) -> str:
    """A summary.csv column header: the column's name, then its unit in brackets where it has one.

    Parameters
    ----------
    name : str
        The column (``"t_final"``).
    unit : str
        Its unit (``"s"``; ``"1"`` dimensionless; ``""`` text).

    Returns
    -------
    str
        ``"t_final [s]"``, or the name alone for a text column.
    """
    return f"{name} [{unit}]" if unit else name


@contextlib.contextmanager
def _replacing(path: str):
    """Write a file under ``<path>.tmp`` in the block and rename it to ``path`` after it; an
    error in the block removes the temporary file."""
    tmp = path + ".tmp"
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _write_csv(path, names, units, rows) -> None:
    with _replacing(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow([_csv_header(n, units.get(n, "")) for n in names])
        for r in rows:
            w.writerow([_text(r.get(c)) for c in names])


def _column(values: list):
    """A column as a numpy array: int64, float64 or UTF-8 strings."""
    if all(isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.int64) if all(v < 2**63 for v in values) else np.array(values, np.uint64)
    if all((isinstance(v, numbers.Real) and not isinstance(v, bool)) or v is None for v in values):
        return np.array([math.nan if v is None else float(v) for v in values], dtype=np.float64)
    return np.array([_text(v) for v in values], dtype=h5py.string_dtype())


def _write_h5(path, names, units, rows, sweep, be, counts) -> None:
    cols = [_column([r.get(c) for r in rows]) for c in names]
    dtype = np.dtype([(n, c.dtype) for n, c in zip(names, cols)])
    table = np.empty(len(rows), dtype=dtype)
    for n, c in zip(names, cols):
        table[n] = c
    with _replacing(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["creator"] = f"emorbit {__version__}"
        f.attrs["emorbit_version"] = __version__
        f.attrs["created"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        f.attrs["sweep"] = sweep.text
        f.attrs["scene"] = sweep.scene.text
        f.attrs["seed"] = sweep.seed
        f.attrs["backend"] = be.describe()
        f.attrs["counts"] = json.dumps(counts)
        ds = f.create_dataset("summary", data=table)
        ds.attrs["units"] = json.dumps(units)
        ds.attrs["columns"] = json.dumps(names)


def read_summary(path) -> list[dict]:
    """The rows of a sweep's ``summary.h5``.

    Parameters
    ----------
    path : str or os.PathLike
        The file, or the sweep's output folder.

    Returns
    -------
    list of dict
        One per run, {column: value}.
    """
    path = os.fspath(path)
    if os.path.isdir(path):
        path = os.path.join(path, "summary.h5")
    with h5py.File(path, "r") as f:
        ds = f["summary"]
        names = json.loads(ds.attrs["columns"])
        table = ds[()]
    out = []
    for rec in table:
        row = {}
        for n in names:
            v = rec[n]
            if isinstance(v, bytes):
                v = v.decode("utf-8")
            elif isinstance(v, np.generic):
                v = v.item()
            row[n] = v
        out.append(row)
    return out
