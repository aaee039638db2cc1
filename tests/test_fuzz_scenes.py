"""Property-based fuzz of scenes through ``emorbit run``: valid scenes (three bodies, orbits
in elements, a coupled structure) with one to three mutations of their keys, types, units and
values, the ``orbit`` table and ``[integrator] max_output`` included. A mutation may keep the
scene valid; every case ends in one of:

* a clean error: exit 2, one line on stderr naming a key of the table that was mutated (or a
  key that the mutation makes wrong: a body's start for a changed field, the run's length for
  a changed step), no traceback, and no file left in the output folder;
* a correct run: exit 0, a completed file that reads back with every record finite, on the
  record grid to t_end, and em's energy at round-off; where each mutation only rewrote a
  value in another unit of the same kind, the same records as the unmutated scene;
* a step that fails (exit 1, one line, the file marked "failed" with the records before it).

The scenes are short (at most a few thousand steps) and each case runs under a watchdog.
Runs whose length or size is what is mutated (steps beyond int64, outputs beyond
max_output, or a long run that must still stop on SIGTERM) run in a child process with a
timeout: ``test_generated_run_lengths``.
"""

from __future__ import annotations

import copy
import math
import os
import re
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest
from fuzz_support import BASE, clean_error, cli, correct_run, estimated_steps, listing, run_failed, to_toml
from hypothesis import HealthCheck, Phase, assume, event, given, settings
from hypothesis import strategies as st

import emorbit
from emorbit.scene import SCHEMA

SETTINGS = dict(deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))

#: BASE with the point and the box placed by orbital elements, and every [integrator] key given
ORBITS = copy.deepcopy(BASE)
ORBITS["field"]["radius"] = "1 m"
ORBITS["integrator"].update({"max_output": "1 GB", "checkpoint_every": 4, "roundoff": "brouwer"})
for _body, _orbit in (
    (ORBITS["body"][0], {"a": "10 m", "e": 0.1, "i": "10 deg", "raan": "20 deg", "argp": "30 deg", "nu": "40 deg"}),
    (ORBITS["body"][1], {"periapsis_radius": "9 m", "apoapsis_radius": "11 m", "mean_anomaly": "1 rad"}),
):
    del _body["position"], _body["velocity"]
    _body["orbit"] = _orbit

#: a box with a tether attached to it (a coupled structure), in orbit
COUPLED = {
    "field": {"gm": "3.9478 m3 / s2"},
    "integrator": {"method": "em", "dt": "0.464758 s", "t_end": "2.32379 s", "output_every": 1},
    "body": [
        {
            "name": "box",
            "kind": "rigid",
            "shape": "box",
            "size": ["0.2 m", "0.2 m", "0.2 m"],
            "mass": "10 kg",
            "position": ["10 m", "0 m", "0 m"],
            "velocity": ["0 m/s", "0.36276 m/s", "0 m/s"],
        },
        {
            "name": "tether",
            "kind": "elastic",
            "mesh": "chain",
            "start": ["0.1 m", "0 m", "0 m"],
            "end": ["1.1 m", "0 m", "0 m"],
            "elements": 2,
            "area": "1 mm2",
            "young": "1 GPa",
            "density": "1000 kg / m3",
            "position": ["10 m", "0 m", "0 m"],
            "velocity": ["0 m/s", "0.36276 m/s", "0 m/s"],
        },
    ],
    "coupling": [{"kind": "attach", "elastic": "tether", "nodes": "first", "to": "box"}],
}
SCENES = {"base": BASE, "orbits": ORBITS, "coupled": COUPLED}

#: units of the same kind, with the factor that keeps a value: number in unit = number * f in other
SAME_KIND = {
    "m": [("km", 1e-3), ("cm", 100.0), ("mm", 1000.0)],
    "s": [("ms", 1000.0), ("min", 1 / 60)],
    "kg": [("g", 1000.0)],
    "m/s": [("km / s", 1e-3), ("cm / s", 100.0)],
    "m / s": [("km / s", 1e-3)],
    "rad/s": [("deg / s", 180 / math.pi)],
    "m3 / s2": [("km3 / s2", 1e-9)],
    "kg / m3": [("g / cm3", 1e-3)],
    "GPa": [("MPa", 1000.0), ("Pa", 1e9)],
    "mm2": [("m2", 1e-6), ("cm2", 1e-2)],
    "deg": [("rad", math.pi / 180)],
    "rad": [("deg", 180 / math.pi)],
    "GB": [("MB", 1000.0), ("kB", 1e6)],
}
#: units of other kinds, misspelt units, no unit
OTHER_UNITS = ["kg", "s", "m", "m / s", "J", "deg", "", "parsecs of nonsense", "m m m", "1/0", "%"]
#: values of any type
ANY_VALUE = st.one_of(
    st.integers(-3, 3),
    st.sampled_from([2**63, -(2**63), 10**30]),
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.booleans(),
    st.text(st.characters(exclude_categories=("Cs",)), max_size=8),
    st.sampled_from(["", "1", "3 m", "nan m", "inf s", "-0 kg", "1e400 m", "x-min", "first", "em", "box"]),
    st.lists(st.sampled_from([1, "1 m", True, 0.5, "a"]), max_size=4),
    st.builds(dict, x=st.just(1)),  # built anew per draw: a later mutation may change it in place
    st.builds(dict),
    st.builds(list),
)
#: values of [integrator] keys that a scene may add
INTEGRATOR_EXTRA = {
    "max_output": ["10 GB", "1 kB", "1 B", "0 B", "-5 GB", "1 m", "1e400 B", "2 GiB", 5, "abc", "1 PB", "nan GB"],
    "checkpoint_every": [1, 3, 0, -1, 2.5, "2", 10**20],
    "newton": ["full", "reuse", "auto", "fast", 1],
    "adaptive": [0.5, 0.0, 1.5, -1.0, math.nan, "x", True, 1],
    "roundoff": ["fast", "brouwer", "exact"],
    "max_newton_iterations": [1, 0, 100, 10**30, 2.0],
    "order": [4, 6, 8, 3, 0, 2.0],
    "method": ["midpoint", "leapfrog", "rk4", ""],
}
#: orbit tables, valid or not
ORBIT_TABLES = [
    {"a": "10 m"},
    {"a": "10 m", "e": 0.3, "nu": "3 rad"},
    {"a": "-10 m", "e": 1.5, "nu": "0.5 rad"},
    {"a": "-10 m", "e": 1.5, "nu": "3 rad"},
    {"periapsis_radius": "5 m", "e": 1.0, "nu": "1 rad"},
    {"periapsis_radius": "5 m", "e": 1.0, "mean_anomaly": "1 rad"},
    {"periapsis_altitude": "4 m", "apoapsis_altitude": "9 m"},
    {"periapsis_radius": "12 m", "apoapsis_radius": "9 m"},
    {"a": "10 m", "periapsis_radius": "9 m"},
    {"a": "10 m", "nu": "1 rad", "mean_anomaly": "1 rad"},
    {"a": "10 m", "i": "200 deg"},
    {"a": "0 m"},
    {"a": "10 m", "e": -0.1},
    {"a": "10 m", "e": 1.0},
    {"a": "10 s"},
    {"e": 0.1},
    {},
    {"a": "1e-300 m"},
]

Path = tuple
#: the mutations, those that may keep a scene valid more often
OPERATIONS = ["delete", "rename", "unknown", "inapplicable", "type", "length"] + ["quantity", "extra", "orbit"] * 3


def _get(d, path: Path):
    for p in path:
        d = d[p]
    return d


def _leaves(d, path: Path = ()):
    """Every (path, value) below ``d`` that is not a table or an array of tables."""
    items = d.items() if isinstance(d, dict) else enumerate(d)
    for k, v in items:
        here = path + (k,)
        if isinstance(v, dict) or (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)):
            yield from _leaves(v, here)
        else:
            yield here, v
            if isinstance(v, list):
                for i, x in enumerate(v):
                    yield here + (i,), x


def _tables(d, path: Path = ()):
    """Every (path, table) in ``d``, the top level included."""
    yield path, d
    items = d.items() if isinstance(d, dict) else enumerate(d)
    for k, v in items:
        if isinstance(v, dict):
            yield from _tables(v, path + (k,))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for i, x in enumerate(v):
                yield from _tables(x, path + (k, i))


def key_of(path: Path) -> str:
    """The scene key of a path, as errors name it: ("body", 1, "size", 0) -> "body[1].size[0]"."""
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else ("." if out else "") + p
    return out


_QUANTITY = re.compile(r"\s*(?P<number>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?P<unit>.*)")


@st.composite
def mutation(draw, d: dict):
    """Apply one mutation to ``d`` in place; return (the paths of what changed, whether the
    scene means the same as before)."""
    op = draw(st.sampled_from(OPERATIONS))
    leaves = [(p, v) for p, v in _leaves(d) if isinstance(p[-1], str) or op in ("type", "quantity")]
    tables = list(_tables(d))
    if op in ("delete", "rename"):
        named = [(p, v) for p, v in leaves if isinstance(p[-1], str)]
        named += [(p, t) for p, t in tables if p and isinstance(p[-1], str)]  # a whole table
        path, _ = draw(st.sampled_from(named))
        parent = _get(d, path[:-1])
        value = parent.pop(path[-1])
        if op == "rename":
            new = draw(st.sampled_from([path[-1] + "s", path[-1][:-1], path[-1].upper(), path[-1] + " "]))
            parent[new] = value
            return [path, path[:-1] + (new,)], False
        return [path], False
    if op == "unknown":
        path, table = draw(st.sampled_from(tables))
        name = draw(st.text(alphabet="abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=10))
        assume(name not in table)
        table[name] = draw(ANY_VALUE)
        return [path + (name,)], False
    if op == "inapplicable":  # a key that exists in another table, or for another shape
        path, table = draw(st.sampled_from([(p, t) for p, t in tables if p]))
        name = draw(st.sampled_from(sorted({k for s in SCHEMA.values() for k in s} - set(table))))
        table[name] = draw(st.sampled_from(["1 m", 1, ["1 m", "1 m", "1 m"], "x-min"]))
        return [path + (name,)], False
    if op == "type":
        path, _ = draw(st.sampled_from(leaves))
        _get(d, path[:-1])[path[-1]] = draw(ANY_VALUE)
        return [path], False
    if op == "quantity":
        quantities = [(p, v) for p, v in _leaves(d) if isinstance(v, str) and _QUANTITY.fullmatch(v)]
        path, old = draw(st.sampled_from(quantities))
        m = _QUANTITY.fullmatch(old)
        number, unit = float(m.group("number")), m.group("unit").strip()
        how = draw(st.sampled_from(["same kind", "same kind", "other unit", "number"]))
        if how == "same kind" and unit in SAME_KIND:
            other, factor = draw(st.sampled_from(SAME_KIND[unit]))
            new, same = f"{number * factor!r} {other}", True
        elif how == "other unit":
            new, same = f"{number!r} {draw(st.sampled_from(OTHER_UNITS))}".strip(), False
        else:
            scale = draw(
                st.sampled_from([0.0, -1.0, 1e-300, 1e-12, 0.5, 0.9, 1.1, 2.0, 1e6, 1e300, math.nan, math.inf])
            )
            new, same = f"{number * scale!r} {unit}", False
        _get(d, path[:-1])[path[-1]] = new
        return [path], same
    if op == "length":
        lists = [(p, v) for p, v in _leaves(d) if isinstance(v, list)]
        path, old = draw(st.sampled_from(lists))
        _get(d, path[:-1])[path[-1]] = draw(st.sampled_from([old[:-1], old + old[-1:], [], [old]]))
        return [path], False
    if op == "extra":
        name = draw(st.sampled_from(sorted(INTEGRATOR_EXTRA)))
        d.setdefault("integrator", {})[name] = draw(st.sampled_from(INTEGRATOR_EXTRA[name]))
        return [("integrator", name)], False
    # an orbit table for a body (with or without its position and velocity)
    bodies = [(i, b) for i, b in enumerate(d.get("body", [])) if isinstance(b, dict)]
    assume(bodies)
    i, b = draw(st.sampled_from(bodies))
    b["orbit"] = copy.deepcopy(draw(st.sampled_from(ORBIT_TABLES)))
    if draw(st.booleans()):
        b.pop("position", None)
        b.pop("velocity", None)
    return [("body", i, "orbit")], False


@st.composite
def mutated_scenes(draw):
    name = draw(st.sampled_from(sorted(SCENES)))
    d = copy.deepcopy(SCENES[name])
    changes = [draw(mutation(d)) for _ in range(draw(st.sampled_from([1, 1, 1, 2, 3])))]
    return name, d, [p for paths, _ in changes for p in paths], all(same for _, same in changes)


def related(key: str, paths: list[Path]) -> bool:
    """Whether the key an error names belongs to a mutation: the mutated key, its table, a
    key inside it; a body's keys for a mutated field or integrator (a start inside the field's
    radius, an orbit without a field); the run's length keys for a mutated step; couplings for
    a mutated body (a coupling names bodies and nodes)."""
    for path in paths:
        top = key_of(path[:2]) if path[0] in ("body", "coupling") else key_of(path[:1])
        if key == top or key.startswith((top + ".", top + "[")) or key_of(path).startswith(key):
            return True
        if path[0] in ("field", "integrator") and key.startswith("body["):
            return True
        if path[0] == "body" and key.startswith(("coupling[", "field")):
            return True
        if path[0] == "integrator" and key.startswith("integrator."):
            return True
    return False


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    """Each unmutated scene's run: the records that a mutation meaning the same must give."""
    folder = tmp_path_factory.mktemp("references")
    out = _Quiet()
    for name, d in SCENES.items():
        (folder / f"{name}.toml").write_text(to_toml(d))
        code, _, err = cli(["run", folder / f"{name}.toml", "-o", folder / f"{name}.h5", "-q"])
        assert code == 0, err
        out[name] = correct_run(folder / f"{name}.h5")
    return out


def test_the_scenes_are_valid(references):
    """The fuzz starts from valid scenes, so every error below is a mutation's."""
    assert set(references) == set(SCENES)


class _Quiet(dict):
    """A dict that hypothesis prints in one word (it prints the arguments of a failing case)."""

    def __repr__(self) -> str:
        return f"<{len(self)} reference runs>"


@settings(max_examples=400, **SETTINGS)
@given(case=mutated_scenes())
def test_generated_scenes(tmp_path_factory, references, case):
    name, d, paths, same = case
    assume(estimated_steps(d) < 5000)  # runs whose length is mutated further: test_generated_run_lengths
    folder = tmp_path_factory.mktemp("scene")
    scene = folder / "scene.toml"
    scene.write_text(to_toml(d))
    before = listing(folder)
    out = folder / "out.h5"
    code, _, err = cli(["run", scene, "-o", out, "-q"])
    event(f"exit {code}")
    if code == 2:
        key = clean_error(code, err)
        assert related(key, paths), f"{key!r} names none of the mutated keys {[key_of(p) for p in paths]}: {err}"
        assert listing(folder) == before, listing(folder) - before
        assert not same, f"a change of units only was refused: {err}"
        return
    if code == 1:
        run_failed(code, err, out)
        assert not same, f"a change of units only failed: {err}"
        return
    assert code == 0, err
    assert "Traceback" not in err
    integ = emorbit.load_scene(str(scene))
    res = correct_run(out, integ.t_end, err)
    assert listing(folder) == before | {"out.h5"}
    if same:  # only units changed: the same run, to rounding of the converted values
        ref = references[name]
        assert len(res) == len(ref)
        for body, sets in ref.bodies.items():
            np.testing.assert_allclose(res.bodies[body]["position"], sets["position"], rtol=1e-7, atol=1e-9)


@st.composite
def equivalent_scenes(draw):
    """A scene with some of its values written in other units of the same kind."""
    name = draw(st.sampled_from(sorted(SCENES)))
    d = copy.deepcopy(SCENES[name])
    for path, old in _leaves(d):
        m = _QUANTITY.fullmatch(old) if isinstance(old, str) else None
        if m and m.group("unit").strip() in SAME_KIND and draw(st.booleans()):
            other, factor = draw(st.sampled_from(SAME_KIND[m.group("unit").strip()]))
            _get(d, path[:-1])[path[-1]] = f"{float(m.group('number')) * factor!r} {other}"
    return name, d


@settings(max_examples=40, **SETTINGS)
@given(case=equivalent_scenes())
def test_values_in_other_units_give_the_same_run(tmp_path_factory, references, case):
    """A scene whose values are written in other units of the same kind is the same scene:
    it runs, and gives the records of the scene as first written (to the rounding of the
    converted values)."""
    name, d = case
    folder = tmp_path_factory.mktemp("units")
    (folder / "scene.toml").write_text(to_toml(d))
    code, _, err = cli(["run", folder / "scene.toml", "-o", folder / "out.h5", "-q"])
    assert code == 0, err
    res = correct_run(folder / "out.h5", references[name].time[-1], err)
    ref = references[name]
    assert len(res) == len(ref)
    np.testing.assert_allclose(res.time, ref.time, rtol=1e-12)
    np.testing.assert_allclose(res.energy, ref.energy, rtol=1e-9)
    for body, sets in ref.bodies.items():  # the stiff tether amplifies rounding to about 1e-9
        for q in ("position", "velocity"):
            np.testing.assert_allclose(res.bodies[body][q], sets[q], rtol=1e-7, atol=1e-9)


# -- the length of a run: steps, records and output size, in a child process ------------------
DT = [
    "0.464758 s",
    "1e-300 s",
    "1e-12 s",
    "1e-6 s",
    "5e-324 s",
    "1e300 s",
    "0.1 s",
    "1e-3 s",
]
T_END = ["4.64758 s", "1e30 s", "1e15 s", "4.64758e6 s", "1e308 s", "1 s", "0.1 s", "1e-300 s", "1e20 yr"]
EVERY = [1, 2, 1000, 10**6, 10**18, 2**63 - 1]
MAX_OUTPUT = [None, "1 kB", "1 GB", "1 PB", "1e30 B", "1e400 B", "1 TB"]


@st.composite
def run_lengths(draw):
    d = copy.deepcopy(BASE)  # the point alone: a long run is a run of cheap steps
    d["body"] = d["body"][:1]
    integ = d["integrator"]
    integ["dt"] = draw(st.sampled_from(DT))
    integ["t_end"] = draw(st.sampled_from(T_END))
    integ["output_every"] = draw(st.sampled_from(EVERY))
    limit = draw(st.sampled_from(MAX_OUTPUT))
    if limit is not None:
        integ["max_output"] = limit
    if draw(st.booleans()):
        integ["checkpoint_every"] = draw(st.sampled_from([1, 100, 10**12]))
    # a long run of long record intervals cannot be stopped: test_a_long_record_interval_stops
    assume(not (estimated_steps(d) > 1e6 and integ["output_every"] > 10**5))
    return d


#: seconds a run may take in the child before it counts as long (then it must be writing its
#: file, and stop cleanly on SIGTERM)
LONG = 8.0


def check_run_length(folder, d) -> str:
    """Run the scene ``d`` in a child process and check its outcome; return which it was."""
    scene = folder / "scene.toml"
    scene.write_text(to_toml(d))
    out = folder / "out.h5"
    proc = subprocess.Popen(
        [sys.executable, "-m", "emorbit.cli", "run", str(scene), "-o", str(out), "-q"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        try:
            _, err = proc.communicate(timeout=LONG)
        except subprocess.TimeoutExpired:
            assert os.path.exists(out), f"no file after {LONG} s: stuck before the run started ({d['integrator']})"
            steps = estimated_steps(d)
            assert steps > 1e6, f"{steps} steps still running after {LONG} s ({d['integrator']})"
            proc.send_signal(signal.SIGTERM)
            _, err = proc.communicate(timeout=60)
            assert proc.returncode == 143, err
            with h5py.File(out, "r") as f:
                assert f.attrs["status"] == "interrupted"
            assert emorbit.read(out).si.time[-1] > 0
            return "long: stopped by SIGTERM"
    finally:
        if proc.poll() is None:  # a failed check above: the run must not outlive the test
            proc.kill()
            proc.communicate()
    if proc.returncode == 2:
        key = clean_error(2, err)
        assert key.startswith("integrator."), err
        assert listing(folder) == {"scene.toml"}
        return "exit 2"
    assert proc.returncode == 0, err
    res = correct_run(out, emorbit.load_scene(str(scene)).t_end, err)
    assert res.attrs["output_every"] == d["integrator"]["output_every"]
    return "exit 0"


@settings(max_examples=15, phases=[Phase.explicit, Phase.generate], **SETTINGS)  # no shrinking: each case is a process
@given(d=run_lengths())
def test_generated_run_lengths(tmp_path_factory, d):
    """A run's length is refused before anything is created when it exceeds int64 steps or
    its projected output exceeds max_output; otherwise it runs, and a long run is writing its
    file and stops on SIGTERM (exit 143, status "interrupted"), never stuck before it starts."""
    event(check_run_length(tmp_path_factory.mktemp("length"), d))


def test_a_long_run_is_stopped_by_sigterm_not_refused(tmp_path):
    """The branch above for long runs is taken: 4.6e9 steps of a point mass."""
    d = copy.deepcopy(BASE)
    d["body"] = d["body"][:1]
    d["integrator"].update({"dt": "1e-9 s", "output_every": 10000})
    assert check_run_length(tmp_path, d) == "long: stopped by SIGTERM"


def test_a_long_record_interval_stops_on_sigterm(tmp_path):
    """A run whose record interval is longer than a chunk's few seconds of work (here: the
    whole run of 2e15 steps) stops on SIGTERM within seconds, like any other run."""
    d = copy.deepcopy(BASE)
    d["body"] = d["body"][:1]
    d["integrator"].update({"t_end": "1e15 s", "output_every": 10**18})
    (tmp_path / "scene.toml").write_text(to_toml(d))
    out = tmp_path / "out.h5"
    cmd = [sys.executable, "-m", "emorbit.cli", "run", str(tmp_path / "scene.toml"), "-o", str(out), "-q"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not os.path.exists(out) and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(1.0)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=15)
        assert proc.returncode == 143, err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
