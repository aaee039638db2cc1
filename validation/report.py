"""The suite's outputs: ``results.json`` (everything), one ``<case>.json`` per case, and
``report.md``, a Markdown report with the figures that a reviewer can read top to bottom."""

from __future__ import annotations

import json
import math
import os

from .body_case import body_notes
from .cases import STUDY_CASES
from .effect_cases import EFFECT_CASES
from .rigid_binary_case import RIGID_BINARY_CASES, RIGID_BINARY_NOTE

__all__ = ["write_json", "write_markdown"]


def _clean(obj):
    """JSON-safe copy: non-finite floats become strings, numpy scalars Python numbers."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if hasattr(obj, "item") and not isinstance(obj, (str, bytes)):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    return obj


def write_json(suite: dict, outdir: str) -> list[str]:
    """Write ``results.json`` (everything) and one ``<case>.json`` per case.

    Parameters
    ----------
    suite : dict
        What :func:`emorbit.validation.run_suite` assembles.
    outdir : str
        The report folder.

    Returns
    -------
    list of str
        The file names written.
    """
    names = ["results.json"]
    with open(os.path.join(outdir, "results.json"), "w") as f:
        json.dump(_clean(suite), f, indent=1)
    for case in suite["cases"]:
        name = f"{case['name']}.json"
        with open(os.path.join(outdir, name), "w") as f:
            json.dump(_clean(case), f, indent=1)
        names.append(name)
    return names


def _g(x, digits=3) -> str:
    if isinstance(x, str):
        return x
    if x is None:
        return "-"
    if isinstance(x, bool):
        return str(x)
    if isinstance(x, int):
        return str(x)
    if not math.isfinite(x):
        return str(x)
    return f"{x:.{digits}g}"


def _esc(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def write_markdown(suite: dict, outdir: str) -> str:
    """Write ``report.md``: a summary table, then each case's checks, runs and figures.

    Parameters
    ----------
    suite : dict
        What :func:`emorbit.validation.run_suite` assembles.
    outdir : str
        The report folder.

    Returns
    -------
    str
        The path of ``report.md``.
    """
    env = suite["environment"]
    lines = [
        "# emorbit validation report",
        "",
        f"Mode **{suite['mode']}**, {len(suite['cases'])} cases, "
        f"**{'ALL PASSED' if suite['passed'] else 'FAILED'}** "
        f"({suite['checks_passed']} of {suite['checks_total']} checks passed), "
        f"wall time {suite['wall_s']:.1f} s, written {suite['created']}.",
        "",
        f"Machine: {env['machine']}. Software: " + ", ".join(f"{k} {v}" for k, v in env["versions"].items()) + ".",
        "",
        "Each case runs emorbit's em method (orders 2, 4, 6, 8), the implicit midpoint rule and leapfrog "
        "through the public API, and the same initial conditions in REBOUND as test particles (m = 0) around "
        "one massive body at the field's centre with N_active = 1 (IAS15 adaptive, and WHFast at a fixed "
        "step), and in the analytic Kepler solution (`emorbit.orbits.propagate`). All runs are recorded at "
        "the same times. The referees are checked against the analytic solution first. Every tolerance "
        "states its unit and reason; a check passes when the measured value is at most the tolerance "
        "(margin = tolerance / value).",
        "",
        "| case | checks | result | wall [s] |",
        "|------|--------|--------|----------|",
    ]
    for case in suite["cases"]:
        n_ok = sum(ch["passed"] for ch in case["checks"])
        lines.append(
            f"| [{case['name']}](#{case['name']}) | {n_ok} / {len(case['checks'])} | "
            f"{'PASS' if case['passed'] else '**FAIL**'} | {case['wall_s']:.1f} |"
        )
    lines.append("")
    if any(c["name"] in EFFECT_CASES for c in suite["cases"]):
        lines += [
            "The effect cases (" + ", ".join(f"`{n}`" for n in EFFECT_CASES) + ") run point masses under the "
            "effects beyond the central field: zonal harmonics against REBOUND IAS15 with REBOUNDx's "
            "`gravitational_harmonics` and against first-order secular theory, mutual gravity against the "
            "analytic two-body solution and against IAS15.",
            "",
        ]
    if any(c["name"] in RIGID_BINARY_CASES for c in suite["cases"]):
        lines += [RIGID_BINARY_NOTE, ""]
    for note in body_notes(c["name"] for c in suite["cases"]):
        lines += [note, ""]
    studies = [c["name"] for c in suite["cases"] if c["name"] in ("brouwer", *STUDY_CASES)]
    if studies:
        lines += [
            "The studies (" + ", ".join(f"`{n}`" for n in studies) + ") run em at order 2 on ensembles of "
            "perturbed copies of one orbit over many steps, and check Brouwer's law instead: the energy error "
            "is a random walk, not a drift.",
            "",
        ]
    for case in suite["cases"]:
        lines += _case_section(case)
    path = os.path.join(outdir, "report.md")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return path


def _case_section(case: dict) -> list[str]:
    out = [
        f'<a id="{case["name"]}"></a>',
        "",
        f"## {case['name']}: {case['title']} — {'PASS' if case['passed'] else 'FAIL'}",
        "",
        case["description"],
        "",
        "Parameters: " + "; ".join(f"{k} = {v}" for k, v in case["params"].items()) + ".",
        case["summary"]
        if case.get("summary")
        else (
            f"Order 2 runs {case['orbits']} periods of {case['period_s']:.10g} s at {case['steps_per_period']} "
            f"steps per period; orders 4-8 run {case['orbits_high']} periods at 4x the steps."
            if case.get("orbits") is not None
            else "A study over many steps (see the parameters)."
        ),
        "",
    ]
    if case.get("error"):
        out += ["**The case stopped with an error:**", "", "```", case["error"], "```", ""]
    out += [
        "| result | check | compared | against | measured | tolerance | unit | margin | why this tolerance |",
        "|--------|-------|----------|---------|----------|-----------|------|--------|--------------------|",
    ]
    for ch in case["checks"]:
        measured = _esc(ch["skipped"]) if ch.get("skipped") else _g(ch["value"])
        if ch.get("detail"):
            measured += f" ({_esc(ch['detail'])})"
        verdict = "SKIP" if ch.get("skipped") else "PASS" if ch["passed"] else "**FAIL**"
        out.append(
            f"| {verdict} | {ch['id']} | {_esc(ch['what'])} | {_esc(ch['against'])} | "
            f"{measured} | {_g(ch['tolerance'])} | {ch['unit']} | {_g(ch.get('margin'), 2)} | {_esc(ch['reason'])} |"
        )
    out += [
        "",
        "<details><summary>runs and further measurements</summary>",
        "",
        "| run | wall [s] | steps | dt [s] | Newton iterations per sub-step | ns per particle (sub-)step |",
        "|-----|----------|-------|--------|--------------------------------|----------------------------|",
    ]
    for label, info in case["runs"].items():
        ns = info.get("ns_per_particle_substep", info.get("ns_per_particle_step"))
        out.append(
            f"| {label} | {_g(info['wall_s'])} | {info.get('steps', '-')} | {_g(info.get('dt_s'), 8)} | "
            f"{_g(info.get('newton_iterations'))} | {_g(ns)} |"
        )
    out += ["", "| measurement | value | unit | note |", "|-------------|-------|------|------|"]
    for key, m in case["metrics"].items():
        value = m["value"]
        if isinstance(value, list):
            value = "; ".join(
                ", ".join(f"{k} {_g(v) if not isinstance(v, list) else v}" for k, v in row.items()) for row in value
            )
        out.append(f"| {key} | {_esc(_g(value, 6))} | {m['unit']} | {_esc(m.get('note', ''))} |")
    out += ["", "</details>", ""]
    for fig in case["figures"]:
        out += [f"![{fig}]({fig})", ""]
    return out
