"""Input hardening: generated bad scenes (each invalid by construction) are all clean
InputErrors naming a key, before anything runs, and the CLI leaves no file behind."""

import copy
import string

import pytest
from fuzz_support import BASE, to_toml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from emorbit.cli import main
from emorbit.errors import InputError
from emorbit.scene import SCHEMA, parse_scene

# the value kind of every dimensional key (a wrong unit for it is one of another kind)
LENGTH_KEYS = {"position", "center", "size", "start", "end", "r_ref", "radius", "length", "end_radius", "height"}
POSITIVE = {"dt", "mass", "density", "young", "area", "gm", "t_end"}
UNITS_OF = {
    "gm": "m3 / s2",
    "dt": "s",
    "t_end": "s",
    "mass": "kg",
    "density": "kg / m3",
    "young": "Pa",
    "area": "m2",
    "position": "m",
    "center": "m",
    "size": "m",
    "start": "m",
    "end": "m",
    "velocity": "m / s",
    "angular_velocity": "rad / s",
}
WRONG_UNIT = {
    "s": "kg",
    "kg": "m",
    "m": "s",
    "m / s": "m",
    "m3 / s2": "m2",
    "kg / m3": "kg",
    "Pa": "m",
    "m2": "m",
    "rad / s": "m / s",
}


def _tables(d):
    """(path, table, schema name) of every table in a scene dict."""
    yield "", d, ""
    for key in ("field", "integrator"):
        if key in d:
            yield key, d[key], key
    for i, b in enumerate(d["body"]):
        yield f"body[{i}]", b, f"body.{b['kind']}"


names = st.text(alphabet=string.ascii_lowercase + "_", min_size=1, max_size=12)


@st.composite
def bad_scenes(draw):
    d = copy.deepcopy(BASE)
    tables = list(_tables(d))
    path, table, schema = draw(st.sampled_from(tables))
    kind = draw(st.sampled_from(["unknown key", "missing key", "bad value"]))
    if kind == "unknown key":
        key = draw(names.filter(lambda k: k not in SCHEMA[schema] and k not in table))
        table[key] = draw(st.one_of(st.integers(), st.text(max_size=5), st.booleans()))
        return d, f"{path}.{key}" if path else key
    if kind == "missing key":
        required = [k for k, req in SCHEMA[schema].items() if req and k in table and k != "kind"]
        if not required:
            table["zz_unknown"] = 1
            return d, "zz_unknown"
        key = draw(st.sampled_from(required))
        del table[key]
        return d, f"{path}.{key}" if path else key
    candidates = [
        k
        for k in table
        if k not in ("kind", "name")
        and not isinstance(table[k], (dict,))
        and not (isinstance(table[k], list) and table[k] and isinstance(table[k][0], dict))
    ]
    if not candidates:  # the top level holds only tables
        table["zz_unknown"] = 1
        return d, "zz_unknown"
    key = draw(st.sampled_from(candidates))
    old = table[key]
    options = [True, {"x": 1}, "not a number", "7 parsecs of nonsense"]
    if key in UNITS_OF and isinstance(old, str):
        unit = UNITS_OF[key]
        options += [draw(st.floats(min_value=0.1, max_value=10)), f"1 {WRONG_UNIT[unit]}"]
        if key in POSITIVE:
            options += [f"-{draw(st.floats(min_value=0.1, max_value=10))} {unit}", f"0 {unit}"]
    elif isinstance(old, list):
        options += [old[:2], old + [old[0]], [True, True, True], ["1", "2", "3"]]
    elif key in ("method", "shape", "mesh", "body"):
        options += [
            draw(
                names.filter(
                    lambda t: (
                        t
                        not in (
                            "em",
                            "midpoint",
                            "leapfrog",
                            "box",
                            "chain",
                            "earth",
                            "sun",
                            "jupiter",
                            "beam",
                            "net",
                            "file",
                            "cylinder",
                            "sphere",
                            "shell",
                            "dumbbell",
                            "mesh",
                        )
                    )
                )
            )
        ]
    elif key in ("order",):
        options += [3, 0, -2, 2.5, "2"]
    elif key in ("output_every", "elements"):
        options += [0, -1, 1.5, "3"]
    table[key] = draw(st.sampled_from(options))
    return d, f"{path}.{key}" if path else key


@settings(max_examples=1000, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(bad_scenes())
def test_generated_bad_scenes_are_clean_input_errors(case):
    scene, key = case
    with pytest.raises(InputError) as info:
        parse_scene(to_toml(scene))
    assert isinstance(info.value.key, str) and info.value.key
    assert str(info.value)  # a message, not a traceback from deep inside


def test_base_scene_is_valid():
    """The fuzz starts from a valid scene, so every failure above is the mutation's."""
    parse_scene(to_toml(BASE)).build()


@settings(max_examples=60, deadline=None, derandomize=True)
@given(bad_scenes())
def test_cli_leaves_no_file_for_bad_scenes(tmp_path_factory, case):
    scene, _ = case
    d = tmp_path_factory.mktemp("fuzz")
    path = d / "bad.toml"
    path.write_text(to_toml(scene))
    out = d / "out.h5"
    assert main(["run", str(path), "-o", str(out), "-q"]) == 2
    assert not out.exists()
