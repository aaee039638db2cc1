"""``emorbit sweep``: run a parameter sweep (a plug-in of :mod:`emorbit.cli`).

    emorbit sweep SWEEP.toml -o OUT [--dask | --scheduler tcp://HOST:PORT | --mpi | --serial]
                  [--workers N] [--threads N] [--device cpu|gpu] [--retries N]
                  [--rerun-failed] [--overwrite] [--max-runs N] [--list] [-q]

Exit codes: 0 every run completed, 1 some run failed (each is in the summary with its
error), 2 bad input (nothing ran). ``--list`` prints one line per run, each parameter value with
its unit (``0.35 m / s``), as it is written into the run's scene.
"""

from __future__ import annotations

import json
import os
import sys
import time

from ..errors import InputError

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    """Add ``emorbit sweep``'s options to its sub-command parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The parser of the ``sweep`` sub-command.
    """
    p.add_argument("sweep", help="the sweep file (TOML: a base scene and the parameters to vary)")
    p.add_argument("-o", "--output", help="folder for the run files and the summary (resumes what is there)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--dask", action="store_true", help="start a Dask LocalCluster on 127.0.0.1")
    where.add_argument(
        "--scheduler", metavar="ADDRESS", help="use the Dask cluster at this scheduler (tcp://HOST:PORT)"
    )
    where.add_argument("--mpi", action="store_true", help="run on MPI workers through mpi4py.futures")
    where.add_argument("--serial", action="store_true", help="run in this process, one run after another")
    p.add_argument("--workers", type=int, help="worker processes (default: one per core)")
    p.add_argument("--threads", type=int, default=1, help="Numba threads per worker (default 1)")
    p.add_argument("--device", choices=("cpu", "gpu"), default="cpu", help="where point masses step (default cpu)")
    p.add_argument("--retries", type=int, default=3, help="tries again after a lost worker (default 3)")
    p.add_argument("--rerun-failed", action="store_true", help="run again the runs that failed before")
    p.add_argument("--overwrite", action="store_true", help="replace run files of a different sweep in OUT")
    p.add_argument(
        "--max-runs",
        type=int,
        metavar="N",
        help="the most runs the sweep may have (default: the sweep file's max_runs, else 100000)",
    )
    p.add_argument("--list", action="store_true", help="print the runs and their parameters; run nothing")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no summary line")


def _shown(value) -> str:
    """A value as written into a scene, for --list: text as it is ("0.35 m / s"), anything else as JSON."""
    return value if isinstance(value, str) else json.dumps(value)


def run(args) -> int:
    """Run ``emorbit sweep`` with parsed arguments.

    Parameters
    ----------
    args : argparse.Namespace
        The options of :func:`add_arguments`.

    Returns
    -------
    int
        0 every run completed, 1 some run failed or did not run.

    Raises
    ------
    InputError
        A bad sweep file or option (the command line turns it into exit code 2).
    """
    from .runner import run_sweep
    from .spec import load_sweep

    sweep = load_sweep(args.sweep, args.max_runs)
    if args.list:
        try:
            print("\t".join(["run", "seed"] + [p.key for p in sweep.parameters]))
            for t in sweep.iter_tasks():
                shown = [_shown(p.scene_value(t.values[p.key], p.key)) for p in sweep.parameters]
                print("\t".join([str(t.index), str(t.seed)] + shown))
            sys.stdout.flush()
        except BrokenPipeError:  # the reader stopped (emorbit sweep ... --list | head)
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    if not args.output:
        raise InputError("output", "give the output folder with -o OUT")
    backend = "dask" if args.dask else "mpi" if args.mpi else "serial" if args.serial else "process"
    start = time.perf_counter()
    result = run_sweep(
        sweep,
        args.output,
        backend=backend,
        workers=args.workers,
        threads=args.threads,
        scheduler=args.scheduler,
        device=args.device,
        retries=args.retries,
        rerun_failed=args.rerun_failed,
        overwrite=args.overwrite,
        progress=False if args.quiet else None,
        max_runs=args.max_runs,
    )
    c = result.counts
    if not args.quiet:
        print(
            f"{result.output}: {c['total']} runs, {c['completed']} completed, {c['failed']} failed"
            + (f", {c['not_run']} not run" if c["not_run"] else "")
            + f" ({c['skipped']} finished before, {c['ran']} ran now, {c['retried']} retried after a lost worker); "
            f"summary {result.summary_csv}; wall {time.perf_counter() - start:.1f} s"
        )
        for row in result.rows:
            if row.get("status") != "completed":
                print(f"  run {row['run']}: {row.get('status')}: {row.get('error')}", file=sys.stderr)
    return 0 if c["failed"] == 0 and c["not_run"] == 0 else 1
