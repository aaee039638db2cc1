"""Meshes given in another length unit (``mesh_unit``): a rigid body's tetrahedral mesh in mm
and an elastic body's HDF5 mesh file in mm are the same bodies as the meshes in m, through
the public API (``add_rigid(..., "mesh", mesh_unit=...)``, a scene's ``mesh_unit``,
``add_elastic(..., "file", mesh_unit=...)``) and what a run records.

A mesh whose unit were dropped (mm read as m) would be 1000 times larger: 1e9 times the mass
and 1e15 times the inertia."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

import emorbit
from emorbit.scene import parse_scene

#: a block about 0.8 x 0.5 x 0.3 m: a cube's six Kuhn tetrahedra (positively oriented), stretched and
#: sheared so that no axis is one of symmetry
NODES_M = np.array(
    [[0, 0, 0], [0.8, 0, 0], [0, 0.5, 0], [0.8, 0.5, 0], [0.1, 0, 0.3], [0.9, 0, 0.3], [0.1, 0.5, 0.3]]
    + [[0.6, 0.4, 0.35]]
)
TETS = np.array([[0, 1, 3, 7], [0, 5, 1, 7], [0, 3, 2, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 6, 4, 7]])


def _rigid_sim(nodes, unit):
    """A tumbling aluminium block in free space, steps of 0.01 s."""
    sim = emorbit.Simulation(None, method="em", dt=0.01)
    sim.add_rigid(
        "block", "mesh", nodes=nodes.tolist(), tetrahedra=TETS.tolist(), mesh_unit=unit, density=2700.0,
        position=[1.0, 2.0, 3.0], velocity=[0.1, 0.0, -0.05], angular_velocity=[0.3, 1.2, -0.4],
    )  # fmt: skip
    return sim


def _rigid(nodes, unit, steps=200):
    """The block's records over ``steps`` steps."""
    return _rigid_sim(nodes, unit).run(steps=steps, every=20, progress=False).si


def test_a_rigid_mesh_in_mm_starts_as_the_mesh_in_m():
    """Before a step: the energy (the kinetic energy of the centre and of the spin) and the angular
    momentum of the block in mm equal those in m (measured 1.1e-16 and 2.2e-16 relative; bounds
    2e-15); read as m, the mm block's energy would be 1e15 times larger."""
    mm, m = _rigid_sim(NODES_M * 1000.0, "mm"), _rigid_sim(NODES_M, "m")
    assert mm.energy() == pytest.approx(m.energy(), rel=2e-15)
    L, Lm = mm.angular_momentum(), m.angular_momentum()
    assert np.linalg.norm(L - Lm) <= 2e-15 * np.linalg.norm(Lm)


def test_a_rigid_mesh_in_mm_is_the_mesh_in_m():
    """The block given in mm and in m, tumbling for 2 s: the same mass (measured 2.2e-16
    relative), angular momentum (2.2e-16), attitude (1.1e-16) and angular velocity (3.4e-16 of
    |w|), the node coordinates differing by the rounding of x 1e-3 alone; bounds about 10x.
    Read as m, the mm mesh would weigh 1e9 times as much."""
    mm, m = _rigid(NODES_M * 1000.0, "mm"), _rigid(NODES_M, "m")
    volume = sum(abs(np.linalg.det(NODES_M[t[1:]] - NODES_M[t[0]])) / 6 for t in TETS)
    assert m.masses["block"] == pytest.approx(2700.0 * volume, rel=1e-14)
    assert mm.masses["block"] == pytest.approx(m.masses["block"], rel=2e-15)
    L, Lm = mm.angular_momentum, m.angular_momentum
    assert np.max(np.linalg.norm(L - Lm, axis=1)) <= 2e-15 * np.linalg.norm(Lm[0]), "angular momentum"
    q, qm = mm.attitudes["block"], m.attitudes["block"]
    assert np.max(np.abs(q - qm)) <= 1e-15, f"attitudes differ by {np.max(np.abs(q - qm)):.3g}"
    w, wm = mm.angular_velocities["block"], m.angular_velocities["block"]
    assert np.max(np.abs(w - wm)) <= 3e-15 * np.linalg.norm(wm[0]), "angular velocities"
    np.testing.assert_array_equal(mm.positions["block"][0], [1.0, 2.0, 3.0])


def test_a_scene_takes_the_mesh_unit():
    """The same block in a scene, nodes in mm with ``mesh_unit = "mm"``: the mass of the m mesh."""
    nodes = ", ".join(f"[{x:g}, {y:g}, {z:g}]" for x, y, z in NODES_M * 1000.0)
    tets = ", ".join(f"[{a}, {b}, {c}, {d}]" for a, b, c, d in TETS)
    scene = f"""
[integrator]
method = "em"
dt = "0.01 s"
t_end = "0.1 s"

[[body]]
name = "block"
kind = "rigid"
shape = "mesh"
density = "2700 kg / m3"
mesh_unit = "mm"
nodes = [{nodes}]
tetrahedra = [{tets}]
position = ["1 m", "2 m", "3 m"]
velocity = ["0 m/s", "0 m/s", "0 m/s"]
"""
    res = parse_scene(scene).build().run(steps=1, progress=False).si
    assert res.masses["block"] == pytest.approx(_rigid(NODES_M, "m", steps=1).masses["block"], rel=1e-14)


def _elastic_file(tmp_path, scale, unit_attr):
    path = tmp_path / f"beam-{scale:g}.h5"
    nodes = NODES_M * scale
    with h5py.File(path, "w") as f:
        f["nodes"] = nodes
        if unit_attr is not None:
            f["nodes"].attrs["unit"] = unit_attr
        f["tetrahedra"] = TETS
    return str(path)


def _elastic(path, mesh_unit):
    """The block as an elastic body read from an HDF5 file, free, spinning: 20 steps of 1e-3 s."""
    sim = emorbit.Simulation(None, method="em", dt=1e-3)
    kw = {} if mesh_unit is None else {"mesh_unit": mesh_unit}
    sim.add_elastic(
        "block", "file", file=path, young=7e6, poisson=0.33, density=2700.0,
        position=[0.0, 0.0, 0.0], velocity=[0.0, 0.0, 0.0], angular_velocity=[0.0, 0.0, 2.0], **kw,
    )  # fmt: skip
    return sim.run(steps=20, every=10, progress=False)


def test_an_elastic_mesh_file_in_mm_is_the_file_in_m(tmp_path):
    """An HDF5 mesh in mm (``mesh_unit = "mm"`` for a file without a unit attribute, or the
    attribute itself) gives the body of the file in m: the same mass (measured 2.2e-16
    relative) and the same nodal positions over 20 steps of a spinning, soft body (1.1e-16 m
    on 0.9 m; bound 1e-15 m)."""
    ref = _elastic(_elastic_file(tmp_path, 1.0, "m"), None)
    size = np.ptp(NODES_M, axis=0).max()
    for path, unit in ((_elastic_file(tmp_path, 1000.0, None), "mm"), (_elastic_file(tmp_path, 1000.0, "mm"), None)):
        res = _elastic(path, unit)
        assert res.si.masses["block"] == pytest.approx(ref.si.masses["block"], rel=2e-15)
        x, xr = res.si.bodies["block"]["nodes/position"], ref.si.bodies["block"]["nodes/position"]
        assert x.shape == xr.shape and np.max(np.abs(x - xr)) <= 1e-15 * size, (unit, np.max(np.abs(x - xr)))
