"""What the tests of the body cases share (``tests/test_validation_libration.py``,
``_torque_free``, ``_centre_of_gravity``, ``_elastic_bodies``): their quick report, run once per
test module, what every case of it must show, and the checks of an outcome that failed."""

import json

from emorbit.cli import main

#: the first bytes of a PNG file
PNG = b"\x89PNG\r\n\x1a\n"


def quick_report(tmp_path_factory, names):
    """``emorbit validate --quick`` of the cases ``names`` into a fresh folder.

    Returns (the exit code, the folder, results.json read)."""
    out = tmp_path_factory.mktemp(names[0])
    code = main(["validate", "--quick", "--cases", ",".join(names), "--report", str(out), "-q"])
    return code, out, json.loads((out / "results.json").read_text())


def number(value) -> str:
    """A check's value or tolerance as results.json holds it, for a message: a number with
    three figures; a non-finite one, which results.json writes as a string ("inf" for a case
    that raised, "nan" for a skipped check), as that string; anything else as its repr."""
    try:
        return f"{float(value):.3g}"
    except (TypeError, ValueError):
        return repr(value)


def failures(cases) -> list[str]:
    """One line per failed check of the outcomes ``cases`` (as results.json holds them): the
    case, the check's id, value, tolerance, unit and what it measures; a case that stopped with
    an exception adds its message and the check's detail (the traceback)."""
    lines = []
    for case in cases:
        for ch in case["checks"]:
            if not ch["passed"]:
                value, tol, unit = number(ch["value"]), number(ch["tolerance"]), f" {ch['unit']}" if ch["unit"] else ""
                lines.append(f"{case['name']}: {ch['id']} = {value} > {tol}{unit} ({ch['what']})")
                if ch["id"] == "case-error":
                    lines.append(f"  {case.get('error')}\n{ch.get('detail', '')}")
    return lines


def failed_ids(outcome) -> set:
    """The ids of the checks of an outcome that failed."""
    return {ch["id"] for ch in outcome["checks"] if not ch["passed"]}


def passed_cases(report, names, note) -> dict:
    """Assert what every body case's quick report shows and return {name: case of results.json}.

    The cases ``names``, in that order, each check passed and stating its reason, unit, tolerance
    and referee; the exit code 0; one figure per case, ``<name>.png``, written and linked from
    report.md, which carries the module's ``note``."""
    code, out, suite = report
    cases = {c["name"]: c for c in suite["cases"]}
    assert list(cases) == list(names)
    bad = failures(cases.values())
    assert not bad, "\n".join(bad)
    assert code == 0 and suite["passed"]
    text = (out / "report.md").read_text()
    assert note in text
    for name, case in cases.items():
        for ch in case["checks"]:
            assert ch["reason"] and ch["unit"] is not None and ch["tolerance"] >= 0 and ch["against"], ch["id"]
        assert case["figures"] == [f"{name}.png"] and (out / f"{name}.png").read_bytes()[:8] == PNG
        assert f"]({name}.png)" in text
    return cases
