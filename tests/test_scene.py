"""Scenes: the documented TOML form, shipped scenes, and bad input caught before any step."""

import re

import astropy.constants as const
import numpy as np
import pytest

import emorbit
from emorbit.cli import main
from emorbit.errors import InputError
from emorbit.scene import load_scene, parse_scene

PAPER = load_scene("paper-ellipse").text


def test_shipped_scenes():
    assert {"paper-ellipse", "paper-ellipse-midpoint"} <= set(emorbit.list_scenes())
    s = load_scene("paper-ellipse")
    assert (s.method, s.order, s.output_every) == ("em", 2, 10)
    assert s.dt == 0.464758 and s.t_end == 4647.58
    assert load_scene("paper-ellipse-midpoint").method == "midpoint"


def test_field_forms():
    g_ref = PAPER.replace('gm = "3.9478 m3 / s2"', 'g_ref = "0.039478 m / s2"\nr_ref = "10 m"')
    sim = parse_scene(g_ref).build()
    assert sim.field.gm == pytest.approx(3.9478, rel=1e-15)
    earth = PAPER.replace('gm = "3.9478 m3 / s2"', 'body = "earth"').replace(
        '"10 m", "0 m", "0 m"', '"7000 km", "0 m", "0 m"'
    )
    sim = parse_scene(earth).build()
    assert sim.field.gm == const.GM_earth.si.value
    moved = PAPER.replace('center = ["0 m", "0 m", "0 m"]', 'center = ["1 km", "0 m", "0 m"]')
    assert parse_scene(moved).build().field.center[0] == 1000.0


def test_to_toml_round_trip_is_exact():
    sim = emorbit.Simulation(
        emorbit.CentralField(gm=0.1 + 0.2, center=[1 / 3, 0, 0]), method="leapfrog", order=6, dt=0.1
    )
    sim.add_point('odd "name"', mass=1 / 7, position=[np.pi, 1e-300, 2.0], velocity=[0.0, 1 / 3, 5e-17])
    again = parse_scene(sim.to_toml(t_end=1.0)).build()
    assert again.field.gm == sim.field.gm and np.array_equal(again.field.center, sim.field.center)
    assert (again.method, again.order, again.dt) == ("leapfrog", 6, 0.1)
    assert np.array_equal(again.points.x, sim.points.x) and np.array_equal(again.points.v, sim.points.v)
    assert again.names == sim.names
    assert again.roundoff == "brouwer" and "roundoff" not in sim.to_toml(t_end=1.0)  # the default is not written


def test_roundoff_key_round_trips():
    """roundoff = "fast" parses, builds, and survives to_toml (a resumed run keeps it)."""
    scene = parse_scene(PAPER.replace("order = 2", 'order = 2\nroundoff = "fast"', 1))
    sim = scene.build()
    assert sim.roundoff == "fast" and sim.points.roundoff == "fast"
    assert parse_scene(sim.to_toml(t_end=1.0)).build().roundoff == "fast"


BAD = [
    # (description, old, new, key expected in message, value expected in message)
    ("unknown method", 'method = "em"', 'method = "rk4"', "integrator.method", "rk4"),
    ("zero dt", 'dt = "0.464758 s"', 'dt = "0 s"', "integrator.dt", "0 s"),
    ("negative dt", 'dt = "0.464758 s"', 'dt = "-1 s"', "integrator.dt", "-1 s"),
    ("zero mass", 'mass = "1 kg"', 'mass = "0 kg"', "body[0].mass", "0 kg"),
    ("negative mass", 'mass = "1 kg"', 'mass = "-2 kg"', "body[0].mass", "-2 kg"),
    (
        "point at centre",
        'position = ["10 m", "0 m", "0 m"]',
        'position = ["0 m", "0 m", "0 m"]',
        "body[0].position",
        "centre",
    ),
    ("missing unit", 'dt = "0.464758 s"', "dt = 0.464758", "integrator.dt", "0.464758"),
    ("missing unit in a string", 'mass = "1 kg"', 'mass = "1"', "body[0].mass", "'1'"),
    ("wrong unit", 'dt = "0.464758 s"', 'dt = "0.464758 m"', "integrator.dt", "0.464758 m"),
    ("wrong unit on a vector", '"0.36276 m/s"', '"0.36276 m"', "body[0].velocity[1]", "0.36276 m"),
    ("unknown field body", 'gm = "3.9478 m3 / s2"', 'body = "pluto"', "field.body", "pluto"),
    ("unknown top-level key", "[field]", "colour = 1\n[field]", "colour", "colour"),
    ("unknown field key", "[field]", '[field]\nmass = "1 kg"', "field.mass", "mass"),
    ("unknown integrator key", "[integrator]", "[integrator]\ntolerance = 1e-9", "integrator.tolerance", "tolerance"),
    ("unknown body key", 'kind = "point"', 'kind = "point"\ncolor = "red"', "body[0].color", "color"),
    ("unknown body kind", 'kind = "point"', 'kind = "comet"', "body[0].kind", "comet"),
    ("missing dt", 'dt = "0.464758 s"\n', "", "integrator.dt", "missing"),
    ("missing position", 'position = ["10 m", "0 m", "0 m"]\n', "", "body[0].position", "missing"),
    ("bad order", "order = 2", "order = 3", "integrator.order", "3"),
    ("unknown roundoff", "order = 2", 'order = 2\nroundoff = "exact"', "integrator.roundoff", "exact"),
    ("order not an integer", "order = 2", 'order = "2"', "integrator.order", "'2'"),
    ("zero output_every", "output_every = 10", "output_every = 0", "integrator.output_every", "0"),
    ("two field strengths", 'gm = "3.9478 m3 / s2"', 'gm = "3.9478 m3 / s2"\nbody = "earth"', "field", "gm and body"),
    ("g_ref without r_ref", 'gm = "3.9478 m3 / s2"', 'g_ref = "0.039478 m / s2"', "field.g_ref", "r_ref"),
    ("non-positive GM", 'gm = "3.9478 m3 / s2"', 'gm = "-3.9478 m3 / s2"', "field.gm", "-3.9478"),
    (
        "two components",
        'position = ["10 m", "0 m", "0 m"]',
        'position = ["10 m", "0 m"]',
        "body[0].position",
        "3 components",
    ),
    ("empty name", 'name = "satellite"', 'name = ""', "body[0].name", "''"),
    ("slash in name", 'name = "satellite"', 'name = "a/b"', "body[0].name", "a/b"),
    ("t_end before one step", 't_end = "4647.58 s"', 't_end = "-5 s"', "integrator.t_end", "-5 s"),
    ("not TOML", "[integrator]", "[integrator", "<string>", "TOML"),
]


@pytest.mark.parametrize("what, old, new, key, value", BAD, ids=[b[0] for b in BAD])
def test_bad_scene_is_a_clear_error(what, old, new, key, value):
    assert old in PAPER
    with pytest.raises(InputError) as info:
        parse_scene(PAPER.replace(old, new, 1))
    message = str(info.value)
    assert key in message and value in message, message


def test_duplicate_names():
    text = PAPER + PAPER[PAPER.index("[[body]]") :]
    with pytest.raises(InputError, match=re.escape("body[1].name") + ".*already exists"):
        parse_scene(text)


def test_no_bodies():
    with pytest.raises(InputError, match="body"):
        parse_scene(PAPER[: PAPER.index("[[body]]")])


@pytest.mark.parametrize("what, old, new, key, value", BAD[:6], ids=[b[0] for b in BAD[:6]])
def test_cli_bad_scene_writes_nothing(tmp_path, capsys, what, old, new, key, value):
    scene = tmp_path / "bad.toml"
    scene.write_text(PAPER.replace(old, new, 1))
    out = tmp_path / "out.h5"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 2
    assert not out.exists()
    assert key in capsys.readouterr().err


def test_cli_bad_override_writes_nothing(tmp_path, capsys):
    out = tmp_path / "out.h5"
    assert main(["run", "paper-ellipse", "-o", str(out), "--dt", "0.1", "-q"]) == 2
    assert "error: --dt: " in capsys.readouterr().err and not out.exists()  # the option typed, not integrator.dt
    assert main(["run", "paper-ellipse", "-o", str(out), "--method", "euler", "-q"]) == 2
    assert main(["run", "no-such-scene", "-o", str(out), "-q"]) == 2
    assert not out.exists()


def test_api_errors():
    field = emorbit.CentralField(gm=1.0)
    with pytest.raises(InputError, match="method"):
        emorbit.Simulation(field, method="verlet", dt=0.1)
    with pytest.raises(InputError, match="dt"):
        emorbit.Simulation(field, dt=0.0)
    with pytest.raises(InputError, match="roundoff.*'exact'"):
        emorbit.Simulation(field, dt=0.1, roundoff="exact")
    sim = emorbit.Simulation(field, dt=0.1)
    with pytest.raises(InputError, match="no bodies"):
        sim.run(steps=1)
    sim.add_point("a", mass=1, position=[1, 0, 0], velocity=[0, 1, 0])
    with pytest.raises(InputError, match="already exists"):
        sim.add_point("a", mass=1, position=[2, 0, 0], velocity=[0, 1, 0])
    with pytest.raises(InputError, match="output_every"):
        sim.run(steps=1, every=0)
    with pytest.raises(InputError, match="exactly one"):
        sim.run(steps=1, t_end=1.0)
