"""The energy balance under effects that do work: drag, solar radiation pressure and third bodies.

Over every em step the kinetic energy changes by exactly the conservative potentials' drop plus
the discrete work of the non-conservative forces (``F . (x1 - x0)``, per facet for rigid
bodies) plus the work of the third bodies' potentials changing in time; the step sums those
works, so ``E - E0 - W`` stays at round-off however large the step. These tests run 1e5 steps
of a fiftieth of a 400 km orbit (111 s) for each effect alone and for all of them together, on
a point mass and on a rigid box, and check the records, the files and the drift monitor.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest

import emorbit

EARTH = emorbit.CentralField(body="earth")
EPOCH = "2026-03-20T00:00:00 TDB"  # an equinox: a 400 km orbit crosses the Earth's shadow every orbit
R_LEO = EARTH.radius + 400e3
V_LEO = float(np.sqrt(EARTH.gm / R_LEO))
T_LEO = 2 * np.pi * float(np.sqrt(R_LEO**3 / EARTH.gm))
MASS = 2000.0  # kg: drag takes 0.27 % of the energy in 2000 orbits, the orbit stays near 400 km
DRAG = dict(
    atmosphere="exponential",
    density="3.7e-12 kg/m3",
    reference_altitude="400 km",
    scale_height="58 km",
    rotation_rate="7.292115e-5 rad/s",
)
EFFECTS = {
    "drag": [("drag", DRAG)],
    "srp": [("srp", {"shadow": "conical"})],
    "third_body": [("third_body", {"body": "moon"}), ("third_body", {"body": "sun"})],
}
EFFECTS["all"] = EFFECTS["drag"] + EFFECTS["srp"] + EFFECTS["third_body"]


def _leo(effects: str, kind: str, dt: float = T_LEO / 50) -> emorbit.Simulation:
    """A 2000 kg satellite at 400 km, inclined 52 deg: a point mass, or a 3 x 2 x 1 m box turning
    once per orbit with reflecting faces."""
    sim = emorbit.Simulation(EARTH, method="em", dt=dt, epoch=EPOCH)
    for name, keys in EFFECTS[effects]:
        sim.add_effect(name, **keys)
    c, s = np.cos(0.9), np.sin(0.9)
    state = dict(position=[R_LEO, 0, 0], velocity=[0, V_LEO * c, V_LEO * s])
    if kind == "point":
        sim.add_point(
            "sat", mass=MASS, ballistic_coefficient=2.2 * 6 / MASS, radiation_coefficient=1.3 * 6 / MASS, **state
        )
    else:
        sim.add_rigid(
            "sat", "box", size=[3, 2, 1], mass=MASS, angular_velocity=[0, 0, 2 * np.pi / T_LEO],
            angular_velocity_frame="space", specular=0.3, diffuse=0.2, **state,
        )  # fmt: skip
    return sim


#: the least max |W| / |E0| each effect reaches over the 1e5 steps (measured, records every
#: 1000 steps: drag 2.7e-3; srp 5.4e-9 on the point, 3.8e-8 on the box; the Moon 2.2e-8): far
#: above the balance's limit
LEAST_WORK = {"drag": 1e-3, "srp": 2e-9, "third_body": 1e-8}


@pytest.mark.parametrize("kind", ["point", "rigid"])
@pytest.mark.parametrize("effects", ["drag", "srp", "third_body", "all"])
def test_the_balance_closes_to_roundoff_over_1e5_large_steps(tmp_path, effects, kind):
    """1e5 em steps of T/50 (2000 orbits, 128 days): |E - E0 - W| / |E0| stays below 8e-14
    (measured 4.2e-15 to 8.6e-15 for every effect and both body kinds, but 2.9e-14 for the
    rigid box under drag, whose balance grows about linearly, a trend whose cause is not
    pinned down; the issue asks 1e-12), while each effect's work
    reaches 2e3 to 3e9 times that; the file holds the same balance, each work with its unit."""
    sim = _leo(effects, kind)
    path = tmp_path / "run.h5"
    res = sim.run(steps=100_000, every=1000, output=path, progress=False)
    e0 = abs(res.energy[0].value)
    balance = np.abs(res.energy_balance.value) / e0
    assert balance.max() <= 8e-14, f"the balance reached {balance.max():.2e} of |E0|, measured <= 2.9e-14"
    labels = {"drag": "drag", "srp": "srp", "third_body": "third_body"}
    for label, work in res.work.items():
        kind_ = next(k for k in labels if label.startswith(k))
        if kind_ == "third_body" and label != "third_body":  # the Sun's share: the Moon's carries the test
            continue
        assert work[0].value == 0.0
        most = np.abs(work.value).max() / e0
        assert most > LEAST_WORK[kind_], f"{label}: the work reached {most:.2e} of |E0| only: too small to test"
    with h5py.File(path, "r") as f:
        energy = f["invariants/energy"][()]
        works = {k[len("work_") :]: f["invariants"][k] for k in f["invariants"] if k.startswith("work_")}
        assert set(works) == set(res.work)
        assert all(w.attrs["unit"] == "J" for w in works.values())
        total = sum(w[()] for w in works.values())
        np.testing.assert_array_equal(f["invariants/energy_balance"][()], energy - energy[0] - total)
        if effects in ("third_body", "all"):  # a potential that the records hold, at their times
            assert "potential_third_body" in f["invariants"] and "potential_third_body_2" in f["invariants"]
        assert f["diagnostics/invariant_drift"][-1, 0] >= 0.0  # the monitor checks E - W ...
        assert np.all(f["diagnostics/invariant_drift"][:, 1:] == -1.0)  # ... and no momentum
        assert "warning" not in f.attrs


def test_a_step_time_does_not_depend_on_where_chunks_end(tmp_path):
    """The clock of step j is t_base + (n0 + j) dt whatever chunk holds it: runs whose
    checkpoints (and so chunks) fall elsewhere record the same bits, with the Sun and the Moon
    moving and drag, radiation pressure and the third bodies all on."""
    runs = []
    for cp in (7, 50):
        sim = _leo("all", "point")
        sim.run(steps=700, every=7, output=tmp_path / f"cp{cp}.h5", checkpoint_every=cp, progress=False)
        with h5py.File(tmp_path / f"cp{cp}.h5", "r") as f:
            runs.append({k: f[k][()] for k in ("bodies/sat/position", "invariants/energy_balance")})
    for k in runs[0]:
        np.testing.assert_array_equal(runs[0][k], runs[1][k])


@pytest.mark.parametrize("kind", ["point", "rigid"])
def test_resume_continues_bit_for_bit_under_every_effect(tmp_path, kind):
    """A run with drag, radiation pressure and both third bodies, stopped at a checkpoint and
    resumed, records the same bits as one that never stopped: state, work sums and their
    compensation, and the third bodies' tables sampled afresh on the same grid."""
    whole = _leo("all", kind)
    whole.run(steps=600, every=20, output=tmp_path / "whole.h5", checkpoint_every=100, progress=False)
    part = _leo("all", kind)
    part.run(steps=300, every=20, output=tmp_path / "part.h5", checkpoint_every=100, progress=False)
    emorbit.resume(tmp_path / "part.h5", t_end=600 * T_LEO / 50, progress=False)
    with h5py.File(tmp_path / "whole.h5", "r") as a, h5py.File(tmp_path / "part.h5", "r") as b:
        for k in ("bodies/sat/position", "bodies/sat/velocity", "invariants/energy", "invariants/energy_balance"):
            np.testing.assert_array_equal(a[k][()], b[k][()], err_msg=k)
        for k in ("work_drag", "work_srp", "work_third_body", "work_third_body_2"):
            np.testing.assert_array_equal(a["invariants"][k][()], b["invariants"][k][()], err_msg=k)


def test_the_cylindrical_shadow_keeps_the_balance_and_the_shadow_matters():
    """The cylindrical shadow's jump is evaluated at the midpoint predicted from the step's
    start, so Newton converges across it: 2e4 steps of T/50 on the equator keep the balance at
    2e-15 of |E0| (conical 2e-15, no shadow 5e-15). The shadow matters: after 400 orbits
    sunlight has moved the point by 342 m (cylinder), 307 m (cone with penumbra) and 531 m
    (no shadow) from where it would be without; cylinder and cone differ by the penumbra's
    share, 35 m."""
    pos = {}
    for shadow in ("cylindrical", "conical", "none", "dark"):
        sim = emorbit.Simulation(EARTH, method="em", dt=T_LEO / 50, epoch=EPOCH)
        if shadow != "dark":
            sim.add_effect("srp", shadow=shadow)
        coefficient = 0.02 if shadow != "dark" else None
        sim.add_point(
            "sat", mass=MASS, radiation_coefficient=coefficient, position=[R_LEO, 0, 0], velocity=[0, V_LEO, 0]
        )
        res = sim.run(steps=20_000, every=1000, progress=False)
        pos[shadow] = res.positions["sat"].value[-1]
        if shadow != "dark":
            assert np.abs(res.energy_balance.value).max() / abs(res.energy[0].value) <= 2e-14
    push = {k: np.linalg.norm(pos[k] - pos["dark"]) for k in ("cylindrical", "conical", "none")}
    assert push["conical"] > 100.0
    assert push["cylindrical"] == pytest.approx(push["conical"], rel=0.2)
    assert push["none"] > 1.4 * push["conical"]


def test_scenes_take_the_effects_the_epoch_and_the_coefficients(tmp_path):
    """The scene form of the issue runs (drag, srp and a third body, an epoch, point and rigid
    bodies with facets), and the written-back scene of a Python run builds the same effects."""
    text = f"""
[field]
body = "earth"

[integrator]
dt = "60 s"
t_end = "6000 s"
output_every = 10
epoch = "{EPOCH}"

[[effect]]
kind = "drag"
atmosphere = "exponential"
density = "3.7e-12 kg/m3"
reference_altitude = "400 km"
scale_height = "58 km"

[[effect]]
kind = "srp"
shadow = "cylindrical"

[[effect]]
kind = "third_body"
body = "moon"

[[body]]
name = "sat"
kind = "point"
mass = "100 kg"
ballistic_coefficient = "0.02 m2/kg"
radiation_coefficient = "0.015 m2/kg"
position = ["6778 km", "0 km", "0 km"]
velocity = ["0 km/s", "7.669 km/s", "0 km/s"]

[[body]]
name = "probe"
kind = "rigid"
shape = "box"
size = ["1 m", "1 m", "2 m"]
mass = "500 kg"
specular = 0.4
position = ["0 km", "6800 km", "0 km"]
velocity = ["-7.656 km/s", "0 km/s", "0 km/s"]

[[body.facet]]
center = ["0 m", "0 m", "-2 m"]
normal = [0, 1, 0]
area = "2 m2"
two_sided = true
"""
    sim = emorbit.parse_scene(text).build()
    assert sim.epoch.tdb.isot == "2026-03-20T00:00:00.000"
    res = sim.run(t_end="6000 s", every=10, output=tmp_path / "out.h5", progress=False)
    assert set(res.work) == {"drag", "srp", "third_body"}
    assert np.all(res.work["drag"][1:].value < 0)  # both bodies in the air ...
    assert np.abs(res.energy_balance.value).max() / abs(res.energy[0].value) < 1e-13  # ... and the balance
    with h5py.File(tmp_path / "out.h5", "r") as f:
        assert f.attrs["epoch"] == "2026-03-20T00:00:00.000000000 TDB"
        assert "potential_third_body" in f["invariants"] and "potential_srp" not in f["invariants"]
    # a Python run writes its scene back with the epoch and the coefficients, and it builds again
    api = _leo("all", "point")
    back = emorbit.parse_scene(api.to_toml(t_end=6000.0)).build()
    assert back.epoch == api.epoch
    assert [t.kind for t in back.effects] == [t.kind for t in api.effects]
    assert back.points.values == api.points.values
