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
    bad = [
        f"{name}: {ch['id']} = {ch['value']:.3g} > {ch['tolerance']:.3g} {ch['unit']}"
        for name, case in cases.items()
        for ch in case["checks"]
        if not ch["passed"]
    ]
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
