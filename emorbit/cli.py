"""The ``emorbit`` command line. ``main(argv)`` returns the exit code, so tests can call it.

    emorbit run SCENE -o OUT.h5 [--t-end T] [--dt DT] [--method M] [--order N] [--every K] [--overwrite] [--strict]
    emorbit resume OUT.h5 --t-end T2 [--truncate]
    emorbit plot OUT.h5 [OUT2.h5 ...] -o FIG.png
    emorbit scenes
    emorbit validate | sweep | bench ...     (plug-ins: see PLUGINS)

SCENE is a shipped scene's name (``emorbit scenes`` lists them) or a TOML file. Values given
on the command line carry units like those in a scene: ``--t-end "100 s"``, ``--dt "0.1 s"``.
Exit codes: 0 success; 1 a run failed while stepping or diverged, or its file was removed,
replaced or truncated by another process while it ran; 2 bad input (also an output file that
another run is writing, and a damaged run file); 3 (``run --strict`` only) the run completed,
but a conserved invariant drifted beyond what round-off explains (:mod:`emorbit.io.drift`;
the file is complete); 130 interrupted by SIGINT (Ctrl-C), 143 by SIGTERM: the run stops at
the end of the chunk in progress, and the file keeps everything up to the interruption,
marked "interrupted", and can be resumed. Without ``--strict`` that drift is a warning on
stderr.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import signal
import sys
import time
import warnings

from ._version import __version__
from .errors import EmorbitError, EmorbitWarning, InputError, IntegrationError, RoundoffError

__all__ = ["main", "console_main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="emorbit", description="Energy-momentum conserving orbits in a central field.")
    p.add_argument("--version", action="version", version=f"emorbit {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a scene and write an HDF5 file")
    run.add_argument("scene", help="a shipped scene name or a TOML file")
    run.add_argument("-o", "--output", required=True, help="HDF5 file to write")
    run.add_argument("--t-end", help='end time with a unit, e.g. "100 s"')
    run.add_argument("--dt", help='step with a unit, e.g. "0.1 s"')
    run.add_argument("--method", help="em | midpoint | leapfrog")
    run.add_argument("--order", type=int, help="2 | 4 | 6 | 8; tfe 4 | 6 | 8 | 10 | 12")
    run.add_argument("--every", type=int, help="steps between records (output_every)")
    run.add_argument(
        "--checkpoint-every",
        type=int,
        help="steps between checkpoints (state and records flushed); default: at most 5 s of wall time apart",
    )
    run.add_argument(
        "--overwrite", action="store_true", help="replace an existing output file (never one another run is writing)"
    )
    run.add_argument(
        "--max-output",
        help='the largest output the run may project, with a unit, e.g. "50 GB" (default: the scene\'s '
        "integrator.max_output, else 10 GB)",
    )
    run.add_argument(
        "--strict",
        action="store_true",
        help="exit with code 3 when a conserved invariant drifts beyond what round-off explains "
        "(the file is complete; without it that is a warning)",
    )
    run.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no summary")

    res = sub.add_parser("resume", help="continue a finished, failed, interrupted or killed run file")
    res.add_argument("file", help="the HDF5 run file (continued in place)")
    res.add_argument("--t-end", required=True, help='new end time with a unit, e.g. "200 s"')
    res.add_argument(
        "--truncate",
        action="store_true",
        help="allow a --t-end before the file's last record (deletes the records after it)",
    )
    res.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no summary")

    plot = sub.add_parser("plot", help="plot energy error and orbit of run files")
    plot.add_argument("files", nargs="+", help="HDF5 run files")
    plot.add_argument("-o", "--output", required=True, help="figure file (png, pdf, svg)")
    plot.add_argument("--title", help="figure title")

    sub.add_parser("scenes", help="list the shipped scenes, each with a line that says what it is")
    for name, (module, summary) in PLUGINS.items():
        try:
            mod = _plugin(module)
        except ImportError as exc:  # an optional dependency is missing: say so when it is used
            sp = sub.add_parser(name, help=f"{summary} (unavailable: {exc})")
            sp.add_argument("args", nargs="*")
            sp.set_defaults(plugin=None, unavailable=f"'emorbit {name}' is unavailable: {exc}")
            continue
        sp = sub.add_parser(name, help=summary)
        sp.set_defaults(plugin=module)
        mod.add_arguments(sp)
    return p


#: subcommands implemented in their own modules: name -> (module, help). Each module has
#: ``add_arguments(parser)`` and ``run(args) -> int`` and is imported only when needed.
PLUGINS: dict[str, tuple[str, str]] = {
    "validate": ("emorbit.validation.cli", "compare against REBOUND, astropy and Kepler; write a report"),
    "sweep": ("emorbit.sweep.cli", "run a parameter sweep of a scene on local processes, Dask or MPI"),
    "bench": ("emorbit.bench", "time emorbit beside REBOUND; work-precision diagrams"),
}


def _plugin(module: str):
    import importlib

    return importlib.import_module(module)


@contextlib.contextmanager
def _warnings_on_stderr():
    """Print the block's warnings on stderr once each, after the block.

    An emorbit warning (a RoundoffWarning, an EpochWarning) is one paragraph,
    ``emorbit: warning: ...``; any other warning (NumPy's, astropy's) is printed in Python's
    own format, once per message and category. The warnings
    are printed after ``catch_warnings`` has restored the previous ``showwarning``: printing
    them inside it would record them again into the list being read, without end.
    """
    caught: list[warnings.WarningMessage] = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", EmorbitWarning)
            yield
    finally:
        seen: set[tuple[type, str]] = set()
        for w in caught:
            key = (w.category, str(w.message))
            if key in seen:
                continue
            seen.add(key)
            if issubclass(w.category, EmorbitWarning):
                print(f"emorbit: warning: {w.message}", file=sys.stderr)
            else:
                sys.stderr.write(warnings.formatwarning(w.message, w.category, w.filename, w.lineno))


#: the options of ``emorbit run`` and ``resume`` that override a scene's keys: {the key an
#: error names: (the option, its attribute in the parsed arguments)}
OVERRIDES = {
    **{
        f"{prefix}{key}": (option, attr)
        for key, option, attr in (
            ("t_end", "--t-end", "t_end"),
            ("dt", "--dt", "dt"),
            ("method", "--method", "method"),
            ("order", "--order", "order"),
            ("output_every", "--every", "every"),
            ("checkpoint_every", "--checkpoint-every", "checkpoint_every"),
            ("max_output", "--max-output", "max_output"),
        )
        for prefix in ("integrator.", "")
    },
    "every": ("--every", "every"),
}


@contextlib.contextmanager
def _options_named(args):
    """An input error about a key that an option of the command line set names that option
    (``--t-end``, not ``integrator.t_end``): the value is the one the user typed."""
    try:
        yield
    except InputError as exc:
        option, attr = OVERRIDES.get(exc.key, (None, None))
        if option is None or getattr(args, attr, None) is None:
            raise
        raise InputError(option, exc.message) from None


def _run(args) -> int:
    from .interrupts import RunInterrupted, stop_on_signals
    from .scene import load_scene

    with (
        _options_named(args),
        stop_on_signals() as stop,
        _warnings_on_stderr(),
    ):  # a signal while the scene builds stops the run before its file exists
        scene = load_scene(args.scene, check=False).with_overrides(
            t_end=args.t_end,
            dt=args.dt,
            method=args.method,
            order=args.order,
            output_every=args.every,
            checkpoint_every=args.checkpoint_every,
            max_output=args.max_output,
            check=False,
        )
        sim = scene.build()  # checked and built once
        if stop.is_set():
            raise RunInterrupted(stop.signum)
        start = time.perf_counter()
        progress = False if args.quiet else None
        sim.run(
            t_end=scene.t_end,
            every=scene.output_every,
            output=args.output,
            overwrite=args.overwrite,
            progress=progress,
            keep=False,
            checkpoint_every=scene.checkpoint_every,
            strict=args.strict,
        )
    if not args.quiet:
        print(
            f"{args.output}: {sim.method} order {sim.order}, dt = {sim.dt:.6g} s, t = {sim.time:.6g} s, "
            f"{_run_summary(args.output)}, wall {time.perf_counter() - start:.2f} s"
        )
    if sim.stopped_by is not None:  # said even with -q: the run ended before t_end
        print(f"{args.output}: stopped at t = {sim.time!r} s ({sim.time / 86400:.6g} d) by {sim.stopped_by.describe()}")
    if sim.events.log and not args.quiet:
        print(f"{args.output}: {len(sim.events.log)} events (events/ in the file)")
    return 0


def _run_summary(path) -> str:
    """What ``emorbit run`` says of a run file's records (:func:`summary_text`).

    Parameters
    ----------
    path : str or os.PathLike
        A run file, closed by its writer.

    Returns
    -------
    str
        The energy error, largest and at the end, and the solves that did not reach round-off.
    """
    from .io.reader import open_run_file, optional_rows

    with open_run_file(path) as f:
        n = f["time"].shape[0]
        return summary_text(
            f["invariants/energy"][:n],
            optional_rows(f, "invariants/energy_range", n),
            f["invariants/energy_balance"][:n] if "energy_balance" in f["invariants"] else None,
            int(optional_rows(f, "diagnostics/stalled_solves", n).sum()),
            int(optional_rows(f, "diagnostics/split_steps", n).sum()),
        )


def summary_text(energy, energy_range, balance, stalled: int, split: int) -> str:
    """A run's energy error, largest and at the end, and its stalled solves and split steps.

    The largest error includes the steps between records where the run measured them
    (``energy_range``): a midpoint run's energy oscillates around each orbit, and its error
    at the end can be far below its largest. Under effects that do work (drag, radiation
    pressure, third bodies) the energy changes with the physics, and the balance
    ``E - E0 - W`` is what an em step keeps: its largest value is named too. Stalled solves
    (sub-steps whose Newton iteration was accepted at a stall, above round-off) and split
    steps (steps redone in sub-steps after Newton failed) are named where there are any.

    Parameters
    ----------
    energy : array_like
        (n,) the records' total energy, J.
    energy_range : array_like
        (n, 2) the least and greatest energy over each record's interval, J.
    balance : array_like or None
        (n,) ``E - E0 - W``, J, under effects that do work; None otherwise.
    stalled, split : int
        Stalled solves and split steps over the run.

    Returns
    -------
    str
        For example ``"max |dE/E0| = 8.012e-02, at end 2.412e-06; 1889 stalled solves"``.
    """
    import numpy as np

    energy = np.asarray(energy, float)
    if energy.size == 0:
        return "no records"
    scale = abs(energy[0]) if energy[0] != 0 else 1.0
    rel = np.abs(energy - energy[0]) / scale
    largest = max(float(rel.max()), float(np.abs(np.asarray(energy_range, float) - energy[0]).max() / scale))
    text = f"max |dE/E0| = {largest:.3e}, at end {rel[-1]:.3e}"
    if balance is not None:  # effects that do work: the balance is what an em step keeps
        text += f"; max |E - E0 - W|/|E0| = {float(np.abs(np.asarray(balance, float)).max()) / scale:.3e}"
    troubles = [
        f"{count} {what}{'s' if count != 1 else ''}"
        for count, what in ((stalled, "stalled solve"), (split, "split step"))
        if count
    ]
    return text + ("; " + ", ".join(troubles) if troubles else "")


def _resume(args) -> int:
    from .interrupts import stop_on_signals
    from .io.resume import resume

    start = time.perf_counter()
    with _options_named(args), stop_on_signals(), _warnings_on_stderr():
        result = resume(args.file, args.t_end, progress=False if args.quiet else None, truncate=args.truncate)
    if not args.quiet:
        si = result.si
        err = abs(si.energy[-1] / si.energy[0] - 1) if len(si) else 0.0
        print(
            f"{args.file}: continued to t = {si.time[-1]:.6g} s, |dE/E| over the continuation = {err:.3e}, "
            f"wall {time.perf_counter() - start:.2f} s"
        )
    stopped = _stopped(args.file)
    if stopped is not None:  # said even with -q: the run ended before t_end
        t = float(result.si.time[-1])
        print(f"{args.file}: stopped at t = {t!r} s ({t / 86400:.6g} d) by {stopped}")
    return 0


def _stopped(path) -> str | None:
    """The event that stopped the run in a file, in words (None: it was not stopped)."""
    from .io.reader import open_run_file

    with open_run_file(path) as f:
        return str(f.attrs["stopped_by"]) if f.attrs.get("status") == "stopped" and "stopped_by" in f.attrs else None


def _plot(args) -> int:
    from .plot import check_figure_path, plot_runs

    check_figure_path(args.output, args.files, key="-o/--output")
    plot_runs(args.files, args.output, title=args.title)
    return 0


def scene_description(name: str) -> str:
    """One line that says what a shipped scene is: the first clause of its leading comment in
    full (without what is in parentheses), then its method and order.

    Parameters
    ----------
    name : str
        A shipped scene's name.

    Returns
    -------
    str
        The line (without the name).
    """
    import importlib.resources
    import re

    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib

    text = (importlib.resources.files("emorbit") / "scenes" / f"{name}.toml").read_text(encoding="utf-8")
    lines = []
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    first = " ".join(lines)
    while (shorter := re.sub(r"\s*\([^()]*\)", "", first)) != first:
        first = shorter
    first = re.split(r"[:;]|\.(?:\s|$)", first, maxsplit=1)[0].strip()
    integ = tomllib.loads(text).get("integrator", {})
    how = f"[{integ.get('method', 'em')}, order {integ.get('order', 2)}]"
    return f"{first} {how}" if first else how


def _scenes(args) -> int:
    from .scene import list_scenes

    names = list_scenes()
    width = max(map(len, names), default=0)
    for name in names:
        print(f"{name:<{width}}  {scene_description(name)}")
    return 0


def main(argv=None) -> int:
    """Run the command line.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after the program name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit code: 0 success, 1 a run failed while stepping or lost its file (or a
        plug-in's own failure), 2 bad input, 3 ``run --strict`` completed with a conserved
        invariant beyond round-off, 128 + the signal when SIGINT (130) or SIGTERM (143)
        interrupted a run.
    """
    args = _parser().parse_args(argv)
    if getattr(args, "unavailable", None):
        print(f"emorbit: error: {args.unavailable}", file=sys.stderr)
        return 2
    if getattr(args, "plugin", None):
        handler = _plugin(args.plugin).run
    else:
        handler = {"run": _run, "resume": _resume, "plot": _plot, "scenes": _scenes}[args.command]
    try:
        return handler(args)
    except InputError as exc:
        print(f"emorbit: error: {' '.join(str(exc).split())}", file=sys.stderr)  # one line
        return 2
    except IntegrationError as exc:
        print(f"emorbit: run failed: {exc}", file=sys.stderr)
        return 1
    except RoundoffError as exc:  # --strict: the file is complete
        print(f"emorbit: run completed, but (--strict) {exc}", file=sys.stderr)
        return 3
    except EmorbitError as exc:  # the output file was removed or replaced under the run
        print(f"emorbit: run failed: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        print(f"emorbit: interrupted by {signal.Signals(signum).name}", file=sys.stderr)
        return 128 + signum


def console_main(argv=None) -> None:
    """Entry point of the ``emorbit`` script and of ``python -m emorbit.cli``.

    Runs :func:`main` and exits the process with its code. Before the interpreter shuts
    down, every object still alive is frozen out of the cyclic garbage collector
    (:func:`gc.freeze`), so the collections Python runs while it tears its modules down
    skip the many objects that astropy and Numba leave behind, a noticeable part of a short
    command's wall time. Only cyclic garbage goes unfreed, which the process's exit returns
    anyway: the HDF5 files a command writes are closed by then, and atexit handlers still
    run. Tests call :func:`main`, which leaves the collector alone.

    Parameters
    ----------
    argv : list of str, optional
        As for :func:`main`.

    Raises
    ------
    SystemExit
        Always, with :func:`main`'s exit code.
    """
    code = main(argv)
    gc.freeze()
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    console_main()
