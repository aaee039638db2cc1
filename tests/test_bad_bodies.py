"""Bad bodies and runs are refused before anything is created: runs too long to count or to
store, bodies inside the central body or falling into a singular centre, mesh files and mesh
tables that are not what they claim; and what a simulation measures before its first run."""

import astropy.constants as const
import h5py
import numpy as np
import pytest

import emorbit
from emorbit.cli import main
from emorbit.errors import InputError
from emorbit.scene import load_scene, parse_scene

PAPER = load_scene("paper-ellipse").text
R_EARTH = float(const.R_earth.si.value)
GM_EARTH = float(const.GM_earth.si.value)


def _write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


# -- item 2: step counts and output sizes ---------------------------------------------------------
@pytest.mark.parametrize(
    "old, new, key",
    [
        ('t_end = "4647.58 s"', 't_end = "1e30 s"', "integrator.t_end"),
        ('dt = "0.464758 s"', 'dt = "1e-300 s"', "integrator.t_end"),
        ('t_end = "4647.58 s"', 't_end = "1e15 s"', "integrator.t_end"),
    ],
)
def test_a_run_too_long_to_count_or_store_leaves_no_file(tmp_path, capsys, old, new, key):
    scene = _write(tmp_path, PAPER.replace(old, new))
    out = tmp_path / "out.h5"
    assert main(["run", scene, "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert key in err and "integrator.dt" in err and not out.exists(), err
    assert "Traceback" not in err


def test_the_projected_output_names_the_keys_and_the_size(tmp_path, capsys):
    out = tmp_path / "out.h5"
    assert main(["run", "paper-ellipse", "-o", str(out), "-q", "--t-end", "1e15 s"]) == 2
    err = capsys.readouterr().err
    for needle in ("error: --t-end: ", "integrator.dt", "integrator.output_every", "integrator.max_output", "PB"):
        assert needle in err, (needle, err)
    assert not out.exists()


def test_max_output_is_a_scene_key_and_an_argument(tmp_path):
    small = PAPER.replace("output_every = 10", 'output_every = 10\nmax_output = "5 kB"')
    scene = parse_scene(small)
    assert scene.max_output == 5000.0 and load_scene("paper-ellipse").max_output == 10e9
    out = tmp_path / "small.h5"
    with pytest.raises(InputError, match=r"integrator\.t_end.*1001 records.*integrator\.max_output = 5 kB"):
        scene.build().run(scene.t_end, every=10, output=out)
    assert not out.exists()
    raised = scene.with_overrides(max_output="1 MB")
    assert raised.max_output == 1e6 and "max_output" in raised.text
    raised.build().run(raised.t_end, every=10, output=out, progress=False)
    assert out.exists()
    # the API: the limit bounds the records kept in memory too; nothing kept, nothing to bound
    sim = scene.build()
    with pytest.raises(InputError, match="max_output"):
        sim.run(steps=1000, max_output="1 kB")
    with pytest.raises(InputError, match="steps"):
        sim.run(steps=2**63)
    assert len(sim.run(steps=1000, max_output="1 kB", keep=False)) == 2
    for bad in ("10 m", "-1 GB", "lots"):
        with pytest.raises(InputError, match="max_output"):
            parse_scene(PAPER.replace("output_every = 10", f'output_every = 10\nmax_output = "{bad}"'))


def test_the_projection_counts_every_dataset_nodes_included(tmp_path):
    """The projected bytes of the bodies' datasets are what the file holds."""
    for every in (1, 3):
        sim = emorbit.parse_scene(load_scene("elastic-bar-tumbling").text).build()
        sim.structure._pending[0].node_output_every = every
        out = tmp_path / f"bar{every}.h5"
        sim.run(steps=20, every=2, output=out, progress=False)
        with h5py.File(out, "r") as f:
            growing = []
            f["bodies"].visit(growing.append)
            held = [f["bodies"][n].nbytes for n in growing if getattr(f["bodies"][n], "maxshape", (0,))[0] is None]
        assert sum(held) == sim.structure.output_bytes(11), every


# -- item 3: a body inside the central body --------------------------------------------------------
def test_a_point_inside_the_central_body_leaves_no_file(tmp_path, capsys):
    text = PAPER.replace('gm = "3.9478 m3 / s2"', 'body = "earth"').replace(
        '"10 m", "0 m", "0 m"', '"100 km", "0 m", "0 m"'
    )
    out = tmp_path / "out.h5"
    assert main(["run", _write(tmp_path, text), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "body[0].position" in err and "inside the central body" in err and repr(R_EARTH) in err, err
    assert not out.exists()


def test_extended_bodies_inside_the_central_body():
    field = emorbit.CentralField(body="earth")
    sim = emorbit.Simulation(field, dt=1.0)
    v = [0, np.sqrt(GM_EARTH / R_EARTH), 0]
    with pytest.raises(InputError, match=r"b\.position.*mass point.*inside the central body"):
        sim.add_rigid("b", "box", size=[10, 10, 10], density=1.0, position=[R_EARTH + 1, 0, 0], velocity=v, key="b")
    with pytest.raises(InputError, match=r"c\.position.*node.*inside the central body"):
        sim.add_elastic(
            "c", "chain", start=[-10, 0, 0], end=[10, 0, 0], elements=2, young=1e9, area=1e-4, density=1000.0,
            position=[R_EARTH + 1, 0, 0], velocity=v, key="c",
        )  # fmt: skip
    with pytest.raises(InputError, match="inside the central body"):  # without gravity too: the run checks all
        sim.add_rigid(
            "d", "box", size=[1, 1, 1], density=1.0, position=[0.5 * R_EARTH, 0, 0], velocity=v, gravity="none"
        )
    sim.add_rigid("e", "box", size=[1, 1, 1], density=1.0, position=[R_EARTH + 10, 0, 0], velocity=v)
    assert sim.names == ["e"]


# -- item 4: a radial line through a singular centre -----------------------------------------------
def test_a_radial_fall_into_a_centre_without_radius_is_refused(tmp_path, capsys):
    text = PAPER.replace('"0 m/s", "0.36276 m/s", "0 m/s"', '"-0.1 m/s", "0 m/s", "0 m/s"')
    out = tmp_path / "out.h5"
    assert main(["run", _write(tmp_path, text), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "body[0].velocity" in err and "radius" in err and "tangential" not in err and "across" in err, err
    assert not out.exists()
    field = emorbit.CentralField(gm=3.9478)
    for v in ([0, 0, 0], [1e-3, 0, 0], [-3, 0, 0], [-1, 1e-14, 0]):  # at rest, bound outwards, in, round-off
        sim = emorbit.Simulation(field, dt=0.1)
        with pytest.raises(InputError, match=r"velocity: .*radial line.*\[field\] a radius"):
            sim.add_point("p", mass=1.0, position=[10, 0, 0], velocity=v)
    sim = emorbit.Simulation(field, dt=0.1)
    sim.add_point("out", mass=1.0, position=[10, 0, 0], velocity=[1.0, 0, 0])  # escapes: never comes back
    sim.add_point("side", mass=1.0, position=[10, 0, 0], velocity=[-0.1, 1e-6, 0])  # misses the centre
    with pytest.raises(InputError, match="radial line"):  # a rigid body's centre of mass, too
        sim.add_rigid("b", "box", size=[1, 1, 1], density=1.0, position=[0, 10, 0], velocity=[0, 0, 0])
    sim.add_rigid("free", "box", size=[1, 1, 1], density=1.0, position=[0, 10, 0], velocity=[0, 0, 0], gravity="none")
    # with a collision radius the fall is stopped there, with a message
    sim = emorbit.Simulation(emorbit.CentralField(gm=3.9478, radius=1.0), dt=0.05)
    sim.add_point("p", mass=1.0, position=[10, 0, 0], velocity=[0, 0, 0])
    with pytest.raises(emorbit.IntegrationError, match="inside the central body"):
        sim.run(steps=10_000)


# -- item 10: mesh files and mesh tables -------------------------------------------------------------
TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])


def _mesh(tmp_path, nodes=TET, tets=((0, 1, 2, 3),), unit="m", name="mesh.h5"):
    path = tmp_path / name
    with h5py.File(path, "w") as f:
        f["nodes"] = nodes
        if unit is not None:
            f["nodes"].attrs["unit"] = unit
        f["tetrahedra"] = np.asarray(tets)
    return str(path)


def _elastic(path, **kw):
    sim = emorbit.Simulation(None, dt=0.1)
    sim.add_elastic(
        "m", "file", file=path, young=1e7, poisson=0.3, density=1000.0, position=[0, 0, 0], velocity=[0, 0, 0], **kw
    )
    return sim.structure._body("m")["spec"].ref


@pytest.mark.parametrize(
    "nodes, tets, unit, match",
    [
        (TET, [[0, 1.5, 2, 3]], "m", r"/tetrahedra.*integers"),
        (TET, np.array([[0.0, 1.0, 2.0, 3.0]]), "m", r"/tetrahedra.*float64"),
        (TET, np.array([[b"0", b"1", b"2", b"3"]]), "m", r"/tetrahedra.*integers"),
        (np.array([[b"0", b"0", b"0"]] * 4), [[0, 1, 2, 3]], "m", r"/nodes.*numbers"),
        (TET, [[0, 1, 2, 3]], None, r"mesh_unit.*no unit attribute"),
        (TET, [[0, 1, 2, 3]], "kg", r"/nodes.*not a length"),
    ],
)
def test_bad_hdf5_meshes_name_the_dataset(tmp_path, nodes, tets, unit, match):
    with pytest.raises(InputError, match=match):
        _elastic(_mesh(tmp_path, nodes, tets, unit))


def test_hdf5_mesh_units(tmp_path):
    np.testing.assert_array_equal(_elastic(_mesh(tmp_path, TET * 100.0, unit=None), mesh_unit="cm"), TET)
    np.testing.assert_array_equal(_elastic(_mesh(tmp_path, TET * 100.0, unit="cm"), mesh_unit="cm"), TET)
    np.testing.assert_array_equal(_elastic(_mesh(tmp_path, TET * 100.0, unit="cm")), TET)
    with pytest.raises(InputError, match=r"mesh_unit.*'mm' disagrees with the unit 'cm'"):
        _elastic(_mesh(tmp_path, TET * 100.0, unit="cm"), mesh_unit="mm")


RIGID_MESH = PAPER.replace(
    'kind = "point"\nmass = "1 kg"',
    'kind = "rigid"\nshape = "mesh"\ndensity = "1 kg / m3"\nmesh_unit = "m"\n'
    "nodes = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]\ntetrahedra = [[0, 1, 2, 3]]",
)


@pytest.mark.parametrize(
    "old, new, key",
    [
        ("tetrahedra = [[0, 1, 2, 3]]", "tetrahedra = [[0, 1.5, 2, 3]]", "body[0].tetrahedra"),
        ("tetrahedra = [[0, 1, 2, 3]]", "tetrahedra = [[0, 1.0, 2, 3]]", "body[0].tetrahedra"),
        ("tetrahedra = [[0, 1, 2, 3]]", "tetrahedra = [[0, true, 2, 3]]", "body[0].tetrahedra"),
        ("[0, 0, 1]]", '[0, 0, "1"]]', "body[0].nodes"),
        ("[0, 0, 1]]", "[0, 0, true]]", "body[0].nodes"),
    ],
)
def test_rigid_mesh_tables_take_numbers_and_integer_indices(old, new, key):
    assert parse_scene(RIGID_MESH).build().names == ["satellite"]
    with pytest.raises(InputError, match=key.replace("[", r"\[").replace("]", r"\]")):
        parse_scene(RIGID_MESH.replace(old, new))


def test_element_indices_of_the_api_are_integers():
    from emorbit.bodies.elastic import elastic_spec

    base = dict(young=1e7, density=1e3, poisson=0.3, position=[0, 0, 0], velocity=[0, 0, 0], R=np.eye(3))
    with pytest.raises(InputError, match="tetrahedra"):
        elastic_spec("m", TET, np.array([[0, 1, 2, 3.5]]), [], omega_space=np.zeros(3), **base)


# -- item 18: measuring before a run, and node selectors in the API ---------------------------------
def test_diagnostics_before_the_first_run_with_an_elastic_body():
    sim = emorbit.parse_scene(load_scene("satellite-flexible-boom").text).build()
    e0, p0, L0 = sim.energy(), sim.momentum(), sim.angular_momentum()
    x0, v0 = sim.state("boom")
    assert sim.structure is not None and not sim.structure._built  # still open for more bodies
    sim.add_point("extra", mass=1.0, position=[8e6, 0, 0], velocity=[0, 7000.0, 0])
    res = sim.run(steps=1).si
    assert res.energy[0] == pytest.approx(e0 + 0.5 * 7000.0**2 - GM_EARTH / 8e6, rel=1e-14)
    assert np.allclose(res.bodies["boom"]["position"][0], x0) and np.allclose(res.bodies["boom"]["velocity"][0], v0)
    assert np.all(np.isfinite(p0)) and np.all(np.isfinite(L0))


def test_attach_takes_the_selectors_of_scenes():
    def build(nodes, x=1.5):
        sim = emorbit.Simulation(None, dt=0.01)
        sim.add_rigid("bus", "box", size=[1, 1, 1], density=100.0, position=[0, 0, 0], velocity=[0, 0, 0])
        sim.add_elastic(
            "boom", "beam", size=[2, 0.2, 0.2], elements=[2, 1, 1], young=1e7, poisson=0.3, density=100.0,
            position=[x, 0, 0], velocity=[0, 0, 0],
        )  # fmt: skip
        sim.attach("boom", nodes, "bus")
        return sim

    ref = build("x-min").structure._attach[0][1]
    assert ref == [0, 1, 2, 3] and build([0, 1, 2, 3]).structure._attach[0][1] == ref
    assert build("last", x=-1.5).structure._attach[0][1] == [11]  # the boom on the -x side: its last node on the bus
    for bad, match in (
        ("side", "unknown node selector"),
        ([0, 1.5], "integers"),
        ([True], "integers"),
        ([], "no nodes"),
    ):
        with pytest.raises(InputError, match=match):
            build(bad)


def test_attaching_nodes_far_outside_a_rigid_body_is_refused():
    """A boom whose clamped face lies 10 m beyond the bus's face: refused, naming the nodes and
    the distance, and nothing is attached (the bus stays a rigid body of its own); the same
    where the bus is already in the structure through another boom."""

    def sim_with(*booms):
        sim = emorbit.Simulation(None, dt=0.01)
        sim.add_rigid("bus", "box", size=[1, 1, 1], density=100.0, position=[0, 0, 0], velocity=[0, 0, 0])
        for name, x in booms:
            sim.add_elastic(
                name, "beam", size=[2, 0.2, 0.2], elements=[2, 1, 1], young=1e7, poisson=0.3, density=100.0,
                position=[x, 0, 0], velocity=[0, 0, 0],
            )  # fmt: skip
        return sim

    sim = sim_with(("boom", 11.5))  # its x-min face at 10.5 m, the bus's +x face at 0.5 m
    with pytest.raises(InputError, match=r"^coupling\.nodes: node\(s\) 0, 1, 2, 3 of 'boom' lie up to 10\.2") as err:
        sim.attach("boom", "x-min", "bus")
    assert "nearest mass point of 'bus'" in str(err.value)
    assert sim.rigid.names == ["bus"] and not getattr(sim.structure, "_attach", [])
    sim = sim_with(("near", 1.5), ("far", 11.5))
    sim.attach("near", "x-min", "bus")  # on the face: accepted, and the bus joins the structure
    with pytest.raises(InputError, match="of 'far' lie up to 10.2"):
        sim.attach("far", "x-min", "bus")
    assert [a[0] for a in sim.structure._attach] == ["near"]
