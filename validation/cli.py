"""``emorbit validate``: run the validation suite and write its report.

    emorbit validate [--quick] [--report DIR] [--cases NAME,...] [--tolerance-scale S] [--overwrite] [-q]
    emorbit validate --list

Exit codes: 0 every check passed, 1 a check failed, 2 bad input.
"""

from __future__ import annotations

import math
import os

from emorbit.errors import InputError

__all__ = ["add_arguments", "run", "REPORT_FILES"]

#: files whose presence marks a directory as holding a report
REPORT_FILES = ("report.md", "results.json")


def add_arguments(parser) -> None:
    """Add ``emorbit validate``'s options to its sub-command parser.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The parser of the ``validate`` sub-command.
    """
    parser.add_argument(
        "--quick", action="store_true", help="the quick suite (fewer orbits and particles); default: the full suite"
    )
    parser.add_argument(
        "--report",
        default="validation-report",
        metavar="DIR",
        help="directory for report.md, results.json, <case>.json and figures (default: %(default)s)",
    )
    parser.add_argument("--cases", metavar="NAME,...", help="run only these cases (see --list)")
    parser.add_argument(
        "--tolerance-scale",
        default="1",
        metavar="S",
        help="multiply every tolerance by S > 0 (S < 1 tightens; default 1)",
    )
    parser.add_argument("--overwrite", action="store_true", help="replace an existing report in DIR")
    parser.add_argument("--list", action="store_true", help="list the cases, each with its title, and exit")
    parser.add_argument("-q", "--quiet", action="store_true", help="print only the final line")


def _scale(text: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise InputError("--tolerance-scale", f"expected a positive number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise InputError("--tolerance-scale", f"expected a positive finite number, got {text!r}")
    return value


def _cases(text):
    if text is None:
        return None
    names = [n.strip() for n in text.split(",") if n.strip()]
    from .cases import case_names

    known = case_names() + ("brouwer",)  # brouwer: the full suite's round-off study
    unknown = [n for n in names if n not in known]
    if not names or unknown:
        raise InputError("--cases", f"unknown case(s) {', '.join(unknown) or repr(text)}; known: {', '.join(known)}")
    return names


def _report_dir(path: str, overwrite: bool) -> str:
    if os.path.exists(path) and not os.path.isdir(path):
        raise InputError("--report", f"{path!r} exists and is not a directory")
    if not overwrite and any(os.path.exists(os.path.join(path, f)) for f in REPORT_FILES):
        raise InputError("--report", f"{path!r} already holds a report; use --overwrite to replace it")
    return path


def run(args) -> int:
    """Run ``emorbit validate`` with parsed arguments.

    Parameters
    ----------
    args : argparse.Namespace
        The options of :func:`add_arguments`.

    Returns
    -------
    int
        0 every check passed, 1 a check failed.

    Raises
    ------
    InputError
        Bad options or a report folder that holds a report (exit code 2).
    """
    if args.list:  # each case with its title, in full
        from .cases import get_cases

        cases = get_cases("quick")
        width = max(len(c.name) for c in cases)
        for case in cases:
            print(f"{case.name:<{width}}  {case.title}")
        return 0
    scale = _scale(args.tolerance_scale)
    names = _cases(args.cases)
    outdir = _report_dir(args.report, args.overwrite)
    from .suite import run_suite

    log = None if args.quiet else (lambda line: print(line, flush=True))
    suite = run_suite(outdir, quick=args.quick, names=names, scale=scale, log=log)
    print(
        f"{'PASSED' if suite['passed'] else 'FAILED'}: {suite['checks_passed']}/{suite['checks_total']} checks "
        f"in {len(suite['cases'])} cases, {suite['mode']} mode, {suite['wall_s']:.1f} s; "
        f"report: {os.path.join(outdir, 'report.md')}"
    )
    return 0 if suite["passed"] else 1
