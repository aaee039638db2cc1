"""A run's plan (emorbit.integrators.plan): the method and its settings checked once, read by
every body system, and a round-off treatment refused by name where a path does not honour it."""

from __future__ import annotations

import pytest

import emorbit
from emorbit.errors import InputError
from emorbit.integrators.plan import Plan

EARTH = emorbit.CentralField(body="earth")
R = 7000e3
V = (EARTH.gm / R) ** 0.5


@pytest.mark.parametrize(
    "changes, key",
    [
        ({"method": "rk4"}, "method"),
        ({"order": 3}, "order"),
        ({"roundoff": "exact"}, "roundoff"),
        ({"device": "tpu"}, "device"),
        ({"adaptive": 0.0}, "adaptive"),
        ({"adaptive": True}, "adaptive"),
        ({"max_iter": 0}, "max_newton_iterations"),
        ({"max_iter": 10**7}, "max_newton_iterations"),
        ({"newton": "sometimes"}, "newton"),
    ],
)
def test_a_plan_refuses_a_bad_setting_naming_its_key(changes, key):
    with pytest.raises(InputError) as exc:
        Plan(**changes)
    assert exc.value.key == key
    with pytest.raises(InputError) as exc:  # the keys a scene gives them
        Plan(**changes, keys=((key, f"integrator.{key}"),))
    assert exc.value.key == f"integrator.{key}"


def test_every_body_system_reads_the_simulations_plan():
    sim = emorbit.Simulation(EARTH, dt=10.0, adaptive=0.1, newton="full")
    sim.add_point("p", mass=1.0, position=[R, 0, 0], velocity=[0, V, 0])
    sim.add_rigid("r", "box", size=[1, 1, 1], mass=10.0, position=[0, R, 0], velocity=[-V, 0, 0])
    sim.add_elastic("e", "chain", start=[0, 0, 0], end=[1, 0, 0], elements=1, young=1e6, density=100.0,
                    area=1e-2, position=[0, 0, R], velocity=[V, 0, 0])  # fmt: skip
    assert sim.points.plan is sim.plan and sim.rigid.plan is sim.plan and sim.structure.plan is sim.plan
    assert sim.rigid.adaptive == sim.points.adaptive == 0.1 and sim.structure.newton == "full"
    sim.device = "cpu"  # a new plan, handed to every system
    assert sim.points.plan is sim.plan and sim.rigid.plan is sim.plan and sim.structure.plan is sim.plan
    with pytest.raises(InputError) as exc:
        sim.device = "gpu"  # adaptive steps run on the CPU only (checked before any device is looked for)
    assert exc.value.key == "device" and sim.device == "cpu"


def _run(roundoff, method="em", body="point", effect=None):
    sim = emorbit.Simulation(EARTH, dt=10.0, roundoff=roundoff, method=method)
    if effect:
        sim.add_effect(effect, model="earth")
    if body == "point":
        sim.add_point("p", mass=1.0, position=[R, 0, 0], velocity=[0, V, 0])
    else:
        sim.add_rigid("r", "box", size=[1, 1, 1], mass=10.0, position=[R, 0, 0], velocity=[0, V, 0])
    return sim.run(steps=10, progress=False)


def test_fast_roundoff_runs_where_it_is_honoured_and_is_refused_by_name_elsewhere():
    """``roundoff = "fast"`` is a way of solving em's step for point masses in the central
    field: it runs there (other bits than "brouwer"'s: its own solver ran), and is refused, naming the
    key and what the run steps, for a rigid body, for points under an effect and for another
    method; "brouwer" runs on every path."""
    runs = {}
    for roundoff in ("fast", "brouwer"):  # 20000 steps of T/27 on an orbit of e = 0.69
        sim = emorbit.Simulation(EARTH, dt=300.0, roundoff=roundoff)
        sim.add_point("p", mass=1.0, position=[R, 0, 0], velocity=[0, 1.3 * V, 0])
        runs[roundoff] = sim.run(steps=20_000, every=20_000, progress=False).si.positions["p"]
    assert (runs["fast"] != runs["brouwer"]).any()  # its own solver ran (measured: 2.5e-4 m apart)
    for kw, what in (
        ({"body": "rigid"}, "rigid bodies"),
        ({"effect": "zonal"}, "point masses under effects"),
        ({"method": "midpoint"}, "method 'midpoint'"),
    ):
        with pytest.raises(InputError, match=what) as exc:
            _run("fast", **kw)
        assert exc.value.key == "roundoff"
        _run("brouwer", **kw)


def test_a_scene_names_the_refused_roundoff_by_its_key():
    scene = """
[field]
body = "earth"

[integrator]
dt = "10 s"
t_end = "100 s"
roundoff = "fast"

[[body]]
name = "r"
kind = "rigid"
shape = "box"
size = ["1 m", "1 m", "1 m"]
mass = "10 kg"
position = ["7000 km", "0 km", "0 km"]
velocity = ["0 m/s", "7546 m/s", "0 m/s"]
"""
    with pytest.raises(InputError, match="rigid bodies") as exc:
        emorbit.parse_scene(scene).build()
    assert exc.value.key == "integrator.roundoff"


def test_the_gpu_refuses_point_masses_under_effects_naming_the_effect(monkeypatch):
    """``device = "gpu"`` with an effect on point masses is refused, naming the effect's key
    and kind, before anything runs; it never falls back to the CPU silently. (The device check
    itself is bypassed here: no machine of the suite has a GPU.)"""
    from emorbit.kernels.pointmass import cuda

    monkeypatch.setattr(cuda, "device_problem", lambda: None)
    sim = emorbit.Simulation(EARTH, dt=10.0)
    sim.device = "gpu"
    sim.add_effect("zonal", model="earth", key="effect[j2]")
    sim.add_point("p", mass=1.0, position=[R, 0, 0], velocity=[0, V, 0])
    with pytest.raises(InputError, match=r"effect\[j2\] \(zonal\)") as exc:
        sim.run(steps=10, progress=False)
    assert exc.value.key == "device" and sim.time == 0.0
