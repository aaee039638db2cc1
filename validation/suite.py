"""The whole suite: run the cases, write the JSON, the figures and the report."""

from __future__ import annotations

import datetime as _dt
import os
import platform
import time

from .body_case import BodyCase, run_body_case
from .cases import Study, case_names, get_cases
from .effect_cases import EffectCase
from .effect_runner import run_effect_case
from .perturbation_cases import PerturbationCase
from .report import write_json, write_markdown
from .rigid_binary import run_rigid_binary
from .rigid_binary_case import RigidBinaryCase
from .runner import run_case

__all__ = ["run_suite", "environment"]


def _run(case, mode: str, outdir: str, scale: float):
    """One case of the suite: an orbit, effect, perturbation or body case, the rigid binary or a study."""
    if isinstance(case, Study):
        from .brouwer import run_study

        return run_study(case.name, mode, outdir, scale=scale)
    if isinstance(case, BodyCase):
        return run_body_case(case, mode, outdir, scale=scale)
    if isinstance(case, RigidBinaryCase):
        return run_rigid_binary(case, mode, outdir, scale=scale)
    if isinstance(case, PerturbationCase):
        from .perturbation_runner import run_perturbation_case

        return run_perturbation_case(case, mode, outdir, scale=scale)
    return (run_effect_case if isinstance(case, EffectCase) else run_case)(case, mode, outdir, scale=scale)


def _cpu() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def environment() -> dict:
    """The machine and the package versions, for the report.

    Returns
    -------
    dict
        ``machine`` (CPU, cores, OS) and ``versions``.
    """
    import astropy
    import matplotlib
    import numba
    import numpy
    import rebound

    import emorbit

    try:
        import reboundx

        rebx = reboundx.__version__
    except ImportError:
        rebx = "not installed"
    return {
        "machine": f"{_cpu()}, {os.cpu_count()} cores, {platform.system()} {platform.release()}",
        "versions": {
            "python": platform.python_version(),
            "emorbit": emorbit.__version__,
            "numpy": numpy.__version__,
            "numba": numba.__version__,
            "rebound": rebound.__version__,
            "reboundx": rebx,
            "astropy": astropy.__version__,
            "matplotlib": matplotlib.__version__,
        },
    }


def run_suite(outdir: str, *, quick: bool = False, names=None, scale: float = 1.0, log=None) -> dict:
    """Run the validation suite and write its report.

    Writes ``report.md``, ``results.json``, one ``<case>.json`` per case and the figures into
    ``outdir``. The full suite adds the Brouwer study of round-off over many steps of the
    paper's orbit; the study with J2..J6 (``"brouwer-j2"``) is a case of both suites.

    Parameters
    ----------
    outdir : str
        The report folder (created if missing).
    quick : bool
        The quick suite instead of the full one.
    names : iterable of str, optional
        Only these cases (and ``"brouwer"``); default: all.
    scale : float
        Multiplies every tolerance (1 as stated; < 1 tightens them, e.g. to see a check fail).
    log : callable, optional
        Receives one line per finished case and one per failed check.

    Returns
    -------
    dict
        ``mode``, ``tolerance_scale``, ``created``, ``environment``, ``wall_s``,
        ``checks_total``, ``checks_passed``, ``passed`` and ``cases`` (each a CaseOutcome).
    """
    mode = "quick" if quick else "full"
    os.makedirs(outdir, exist_ok=True)
    start = time.perf_counter()
    results = []
    jobs = [
        (case.name, lambda c=case: _run(c, mode, outdir, scale))
        for case in get_cases(mode, [n for n in names if n in case_names()] if names else None)
    ]
    if mode == "full" and (names is None or "brouwer" in names):  # a study, not an orbit case
        from .brouwer import run_brouwer

        jobs.append(("brouwer", lambda: run_brouwer(mode, outdir, scale=scale)))
    for name, job in jobs:
        out = job()
        results.append(out)
        if log:
            n_ok = sum(ch["passed"] for ch in out["checks"])
            log(
                f"{name}: {'PASS' if out['passed'] else 'FAIL'} {n_ok}/{len(out['checks'])} checks "
                f"({out['wall_s']:.1f} s)"
            )
            skipped = [ch["skipped"] for ch in out["checks"] if ch.get("skipped")]
            for why in dict.fromkeys(skipped):  # one line per reason: "skipped: REBOUNDx not installed; ..."
                log(f"  SKIP {skipped.count(why)} check(s), {why}")
            for ch in out["checks"]:
                if ch["passed"]:
                    continue
                if ch["id"] == "case-error":  # the case stopped: its error, on one line
                    log(f"  FAIL {ch['id']}: {out.get('error') or ch['detail']}")
                else:
                    log(f"  FAIL {ch['id']}: {ch['value']:.3g} > {ch['tolerance']:.3g} {ch['unit']} ({ch['what']})")
    checks = [ch for r in results for ch in r["checks"]]
    suite = {
        "mode": mode,
        "tolerance_scale": scale,
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "environment": environment(),
        "wall_s": time.perf_counter() - start,
        "checks_total": len(checks),
        "checks_passed": sum(ch["passed"] for ch in checks),
        "passed": all(r["passed"] for r in results),
        "cases": results,
    }
    write_json(suite, outdir)
    write_markdown(suite, outdir)
    return suite
