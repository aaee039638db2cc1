"""The effect contract: an effect is one declaration that every body kind and every method
reads (emorbit.effects.base), and a user's effect from a file of their own works as a shipped
one does.

- A user's conservative effect (docs/examples/hill_tide.py, copied to a temporary folder and
  registered from there) runs on a point mass, a rigid body and an elastic body with the
  energy kept; its work over a step is its potential's drop and its Jacobian matches finite
  differences; a scene names it by its file.
- Every shipped effect, on every body kind it acts on, with em (fixed and adaptive steps)
  and the midpoint rule: em keeps the energy (or, for an effect that does work, the energy
  balance E - E0 - W) at round-off; the midpoint rule's energy error oscillates far above it.
- Adaptive em steps under J2 and the Moon on an orbit of e = 0.9 run back to their start.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest

import emorbit
from emorbit.effects import EFFECTS, register_file, unregister
from emorbit.errors import InputError
from emorbit.integrators import coefficients

EXAMPLE = Path(__file__).resolve().parent.parent / "docs" / "examples" / "hill_tide.py"
EARTH = emorbit.CentralField(body="earth")
EPS = np.finfo(float).eps
N = 1e-3  # the Hill problem's mean motion, rad/s
EPOCH = "2026-03-20T00:00:00 TDB"


@pytest.fixture(scope="module")
def hill(tmp_path_factory):
    """The example effect, registered from a file outside the package."""
    folder = tmp_path_factory.mktemp("user")
    path = folder / "hill_tide.py"
    shutil.copy(EXAMPLE, path)
    (cls,) = register_file(path)
    yield cls, path
    unregister(cls.NAME)


def _energy_error(res) -> float:
    e = res.si.energy
    return float(np.max(np.abs(e - e[0])) / np.abs(e[0]))


def _free(dt=5.0, **kw):
    return emorbit.Simulation(None, dt=dt, **kw)


def test_a_users_effect_keeps_the_energy_on_every_body_kind(hill):
    """1e4 em steps of T/125 in Hill's tidal field (no other force): the energy of a point, a
    tumbling rigid box and an elastic chain stays at round-off (bound 1e-12 as the contract
    asks). The bodies start in the plane x = 0 and stay there (the centre of mass; the tidal
    term pushes away from it, 3 n^2 x, and would carry them off exponentially), oscillating
    along z and drifting along y."""
    cls, _ = hill
    for add in ("point", "rigid", "elastic"):
        sim = _free(dt=2 * np.pi / N / 125)
        sim.add_effect(cls.NAME, mean_motion=N)
        if add == "point":
            sim.add_point("p", mass=1.0, position=[0.0, 20.0, 30.0], velocity=[0.0, -0.2, 0.03])
            steps = 10_000
        elif add == "rigid":
            sim.add_rigid("p", "box", size=[2, 1, 0.5], density=100.0, position=[0.0, 20.0, 30.0],
                          velocity=[0.0, -0.2, 0.03], angular_velocity=[0.01, 0.02, 0.03])  # fmt: skip
            steps = 10_000
        else:
            sim.add_elastic("p", "chain", start=[0.0, 0.0, 0], end=[0.0, 10.0, 0], elements=3, young=1e6,
                            density=100.0, area=1e-2, position=[0.0, 100.0, 0.0], velocity=[0.0, 0.0, 0.2])  # fmt: skip
            steps = 10_000
        res = sim.run(steps=steps, every=steps // 10, progress=False)
        err = _energy_error(res)
        assert err <= 1e-12, f"{add}: |dE|/|E0| = {err:.3g}"


def test_a_users_effect_keeps_the_energy_with_tfe_on_every_body_kind(hill):
    """The same bodies in Hill's tidal field with ``method = "tfe"`` (order 4, 200 steps of T/50,
    free space: the user's effect is the only force): the energy stays within 1e-13 (measured
    1.7e-16, 4.2e-16 and 4.2e-16) on a point, a rigid box and an elastic chain. (The plane x = 0 is unstable, by
    exp(sqrt(3) n t): the box's rounding off it grows to metres after about 8 periods.)"""
    cls, _ = hill
    for add in ("point", "rigid", "elastic"):
        sim = _free(dt=2 * np.pi / N / 50, method="tfe", order=4)
        sim.add_effect(cls.NAME, mean_motion=N)
        if add == "point":
            sim.add_point("p", mass=1.0, position=[0.0, 20.0, 30.0], velocity=[0.0, -0.2, 0.03])
        elif add == "rigid":
            sim.add_rigid("p", "box", size=[2, 1, 0.5], density=100.0, position=[0.0, 20.0, 30.0],
                          velocity=[0.0, -0.2, 0.03], angular_velocity=[0.01, 0.02, 0.03])  # fmt: skip
        else:
            sim.add_elastic("p", "chain", start=[0.0, 0.0, 0], end=[0.0, 10.0, 0], elements=3, young=1e6,
                            density=100.0, area=1e-2, position=[0.0, 100.0, 0.0], velocity=[0.0, 0.0, 0.2])  # fmt: skip
        res = sim.run(steps=200, every=20, progress=False)
        err = _energy_error(res)
        assert err <= 1e-13, f"{add}: |dE|/|E0| = {err:.3g}"


def test_tfe_refuses_a_force_that_depends_on_the_velocity_at_a_rigid_bodys_points(hill):
    """An effect that declares its force a function of the velocity (``EXPLICIT = False``) and
    acts at a rigid body's points: tfe's rigid stages take their points' positions alone, so
    the run is refused before it starts, naming the method, the effect and the reason."""
    cls, _ = hill
    moving = type("MovingTide", (cls,), {"NAME": "moving_tide", "EXPLICIT": False})
    emorbit.effects.register(moving)
    try:
        sim = _free(dt=10.0, method="tfe", order=4)
        sim.add_effect("moving_tide", mean_motion=N)
        sim.add_rigid("p", "box", size=[2, 1, 0.5], density=100.0, position=[0.0, 20.0, 30.0], velocity=[0.0, 0.0, 0.1])
        with pytest.raises(InputError) as info:
            sim.run(steps=1, progress=False)
        text = str(info.value)
        assert info.value.key == "method" and "moving_tide" in text and "velocity" in text, text
    finally:
        unregister("moving_tide")


def test_a_users_effect_does_the_work_of_its_potential_and_its_jacobian_is_right(hill):
    """Random steps: F . (x1 - x0) = V(x0) - V(x1) to round-off of the terms (measured 1e-16
    relative), and dF/dx1 against central differences (exact for a linear force: 1e-10)."""
    import importlib

    cls, path = hill
    module = importlib.import_module(cls.__module__)
    p = np.array([N * N])
    rng = np.random.default_rng(3)
    for _ in range(50):
        x0, x1 = rng.normal(size=3) * 1e3, rng.normal(size=3) * 1e3
        J = np.zeros((3, 3))
        f = np.array(module.hill_force(*x0, *x1, 1.0, 1.0, p, np.zeros(1), np.zeros(1), J, True))
        drop = module.hill_potential(*x0, 1.0, p, None, None) - module.hill_potential(*x1, 1.0, p, None, None)
        scale = N * N * (np.abs(x0) + np.abs(x1)).max() ** 2
        assert abs(f @ (x1 - x0) - drop) <= 8 * EPS * scale
        d = 10.0  # the force is linear: central differences are exact but for rounding
        fd = np.empty((3, 3))
        for j in range(3):
            up, down = x1.copy(), x1.copy()
            up[j] += d
            down[j] -= d
            fu = np.array(module.hill_force(*x0, *up, 1.0, 1.0, p, None, None, J, False))
            fm = np.array(module.hill_force(*x0, *down, 1.0, 1.0, p, None, None, J, False))
            fd[:, j] = (fu - fm) / (2 * d)
        assert np.allclose(J, fd, rtol=1e-10, atol=1e-12 * N * N)


def test_a_scene_names_a_users_effect_by_its_file(hill, tmp_path):
    """A scene's ``file`` registers the effect from the scene's folder; a second file that
    claims a kind already taken is refused, naming the kind's owner."""
    cls, path = hill
    shutil.copy(path, tmp_path / "tide.py")
    scene = f"""
[integrator]
dt = "50 s"
t_end = "5000 s"

[[effect]]
kind = "{cls.NAME}"
file = "tide.py"
mean_motion = "0.001 rad/s"

[[body]]
name = "p"
kind = "point"
mass = "1 kg"
position = ["0 m", "100 m", "0 m"]
velocity = ["0 m/s", "0 m/s", "0.1 m/s"]
"""
    (tmp_path / "s.toml").write_text(scene)
    with pytest.raises(InputError, match="taken by HillTide of") as exc:  # the fixture's file has it
        emorbit.load_scene(str(tmp_path / "s.toml")).build()
    unregister(cls.NAME)
    try:
        res = emorbit.load_scene(str(tmp_path / "s.toml")).build().run("5000 s", progress=False)
        assert _energy_error(res) <= 1e-13
        with pytest.raises(InputError) as exc:
            emorbit.parse_scene(scene.replace('"tide.py"', '"nowhere.py"'), str(tmp_path / "x.toml")).build()
        assert exc.value.key == "effect[0].file"
    finally:
        unregister(cls.NAME)
        register_file(path)


def test_registering_checks_the_declaration():
    from emorbit.effects.base import Effect, Pieces

    class NoPotential(Effect):
        NAME = "no_potential"
        CONSERVES = ("energy",)
        PIECES = Pieces("somewhere", force="f")

    with pytest.raises(InputError, match="gives its potential"):
        emorbit.effects.register(NoPotential)

    class Taken(Effect):
        NAME = "zonal"
        PIECES = Pieces("somewhere", force="f")
        CONSERVES = ()

    with pytest.raises(InputError, match="taken"):
        emorbit.effects.register(Taken)
    for bad in (-1e-9, math.nan, "0", None, True):

        class BadBound(Effect):
            NAME = "bad_bound"
            PIECES = Pieces("somewhere", force="f")
            CONSERVES = ()
            JACOBIAN_LEFT_OUT = bad

        with pytest.raises(InputError, match="a number >= 0 expected") as exc:
            emorbit.effects.register(BadBound)
        assert exc.value.key == "effect['bad_bound'].JACOBIAN_LEFT_OUT" and repr(bad) in str(exc.value)
    assert "no_potential" not in EFFECTS and "bad_bound" not in EFFECTS and EFFECTS["zonal"].__name__ == "Zonal"


# -- every shipped effect x body kind x method ---------------------------------------------

R_LEO = 6778.137e3
V_LEO = float(np.sqrt(EARTH.gm / R_LEO))
EFFECT_KEYS = {
    "zonal": {"model": "earth"},
    "gravity_field": {"model": "egm2008", "degree": 8, "rotation": "earth"},
    "drag": {"atmosphere": "ussa1976"},
    "srp": {"shadow": "conical"},
    "third_body": {"body": "moon"},
    "mutual": {},
    "thrust": {"body": "a", "thrust": "0.5 N", "isp": "300 s", "start": "0 s", "duration": "400 s"},
}
POINT_KEYS = {"drag": {"ballistic_coefficient": 0.02}, "srp": {"radiation_coefficient": 0.02}}


def _cases():
    for kind, cls in EFFECTS.items():
        if kind == "central" or cls.__module__.startswith("emorbit_user"):
            continue
        for body in ("point", "rigid", "elastic"):
            if cls.acts_on(body):
                yield kind, body


def _scene_sim(kind, body, method, adaptive=None, dt=20.0):
    sim = emorbit.Simulation(EARTH, method=method, order=2, dt=dt, adaptive=adaptive, epoch=EPOCH)
    keys = dict(EFFECT_KEYS[kind])
    if kind == "thrust" and body == "elastic":  # a burn pushes one node, its mass held
        keys = {**keys, "node": 0, "isp": None}
    sim.add_effect(kind, **{k: v for k, v in keys.items() if v is not None})
    place = {"position": [R_LEO, 0, 0], "velocity": [0, V_LEO * 1.01, 300.0]}
    if body == "point":
        sim.add_point("a", mass=100.0, **place, **POINT_KEYS.get(kind, {}))
    elif body == "rigid":
        sim.add_rigid("a", "box", size=[2, 1, 1], mass=300.0, **place, angular_velocity=[0.0, 0.0, 0.002])
    else:
        sim.add_elastic("a", "beam", size=[2.0, 0.5, 0.5], elements=[2, 1, 1], young=1e6, poisson=0.3,
                        density=100.0, **place)  # fmt: skip
    if kind == "mutual":  # a second body to attract
        sim.add_point("b", mass=1e12, position=[R_LEO + 2e3, 0, 0], velocity=[0, V_LEO * 1.01, 300.0])
    return sim


def _balance(res) -> float:
    b = res.relative_energy_balance()
    return float(np.max(np.abs(b if b is not None else res.relative_energy_error())))


@pytest.mark.parametrize("kind, body", list(_cases()))
def test_every_effect_on_every_body_kind_with_every_method(kind, body):
    """Fixed em steps, adaptive em steps (eta 0.05) and the midpoint rule, 100 steps (20 for
    an elastic body) of 20 s from LEO: em keeps the energy, or the balance E - E0 - W, at
    round-off (bound 1e-12; measured at most 4e-15); the midpoint rule's energy error is a
    thousand times that at least (an oscillation with the orbit, not round-off). The elastic
    beam is soft (E = 1 MPa: omega_max dt about 400), since a structure's step amplifies
    round-off like (omega_max dt)^2 (E = 100 MPa gives 1.6e-12). Adaptive steps resolve the
    beam's fastest mode (about 400 sub-steps a second at eta 0.05), so the elastic body's
    adaptive run covers two steps of 0.25 s (measured at most 5e-16), not of 20 s."""
    steps = 20 if body == "elastic" else 100
    em = _scene_sim(kind, body, "em").run(steps=steps, every=steps // 4, progress=False)
    assert _balance(em) <= 1e-12, f"em: {_balance(em):.3g}"
    adaptive_dt = 0.25 if body == "elastic" else 20.0
    adaptive = _scene_sim(kind, body, "em", adaptive=0.05, dt=adaptive_dt).run(
        steps=steps // 10, every=1, progress=False
    )
    assert _balance(adaptive) <= 1e-12, f"adaptive em: {_balance(adaptive):.3g}"
    mid = _scene_sim(kind, body, "midpoint").run(steps=steps, every=steps // 4, progress=False)
    e = mid.si.energy
    osc = float(np.max(np.abs(e - e[0])) / abs(e[0]))
    if kind != "mutual":  # the pair of point masses at 2 km is the field's own orbit: tiny
        assert osc >= 1e3 * max(_balance(em), 1e-16), f"midpoint: {osc:.3g}"


def test_leapfrog_refuses_a_force_that_depends_on_the_velocity():
    sim = emorbit.Simulation(EARTH, method="leapfrog", dt=10.0)
    with pytest.raises(InputError, match="leapfrog") as exc:
        sim.add_effect("drag", atmosphere="ussa1976")
    assert exc.value.key == "method" and not sim.effects.named
    sim.add_effect("zonal", model="earth")  # a force at points: leapfrog kicks with it
    sim.add_point("a", mass=1.0, position=[R_LEO, 0, 0], velocity=[0, V_LEO, 0])
    res = sim.run(steps=100, progress=False)
    assert _energy_error(res) < 1e-6


def test_adaptive_em_under_j2_and_the_moon_runs_back_to_its_start():
    """100 adaptive composed steps of order 4 (eta 0.02) on an orbit of e = 0.9 under J2..J6 and
    the Moon, velocities reversed, 100 steps back with the clock running backwards: back at the
    start within 1e3 eps n (measured 21 and 8.4 eps n for position and velocity)."""
    sim = emorbit.Simulation(EARTH, method="em", order=4, dt=600.0, adaptive=0.02, epoch=EPOCH)
    sim.add_effect("zonal", model="earth")
    sim.add_effect("third_body", body="moon")
    sim.add_point("sat", mass=1.0, orbit={"periapsis_altitude": "500 km", "e": 0.9, "i": "30 deg"})
    sim.run(steps=1, progress=False)  # samples the Moon's path
    pm, n = sim.points, 100
    sim._prepare_effects(2000, coefficients(4))
    x0, v0 = pm.x.copy(), pm.v.copy()
    t1 = pm.reversible_steps("em", coefficients(4), n, 50, t0=sim.time)
    pm.v[...] *= -1
    pm.cv[...] *= -1
    t2 = pm.reversible_steps("em", coefficients(4), n, 50, t0=sim.time + t1, direction=-1.0)
    dx = np.abs(pm.x - x0).max() / np.abs(x0).max() / (EPS * n)
    dv = np.abs(pm.v + v0).max() / np.abs(v0).max() / (EPS * n)
    assert dx <= 1e3 and dv <= 1e3, (dx, dv)
    assert abs(t1 - t2) <= 1e3 * EPS * n * t1


def test_steps_land_on_the_times_an_effect_switches_at(hill):
    """An effect that switches at given times (:meth:`Effect.landing_times`) runs where every
    such time is a step's end, and is refused, naming its key, where one falls between two."""
    cls, _ = hill
    switches = {"at": []}

    class Switching(cls):
        NAME = "hill_tide_switching"

        def landing_times(self, t0, t1):
            t = np.array(switches["at"], float)
            return t[(t > t0) & (t <= t1)]

    emorbit.effects.register(Switching)
    try:
        for at, fine in (([500.0, 2000.0], True), ([525.0], False), ([9000.0], True)):
            switches["at"] = at
            sim = _free(dt=50.0)
            sim.add_effect(Switching.NAME, key="effect[tide]", mean_motion=N)
            sim.add_point("p", mass=1.0, position=[100.0, 0.0, 0.0], velocity=[0.0, 0.1, 0.0])
            if fine:
                sim.run("5000 s", progress=False)
            else:
                with pytest.raises(InputError, match="525.0 s") as exc:
                    sim.run("5000 s", progress=False)
                assert exc.value.key == "effect[tide]"
    finally:
        unregister(Switching.NAME)


def test_a_point_without_field_or_effect_is_refused_naming_the_pair_effects():
    """Free space and no effect that moves a point: refused, naming the key and every
    registered effect between bodies (from the registry, not a hand-kept name)."""
    sim = emorbit.Simulation(None, dt=1.0)
    with pytest.raises(InputError, match=r"add_effect\('mutual'\)") as exc:
        sim.add_point("a", mass=1.0, position=[1.0, 0, 0], velocity=[0, 1.0, 0])
    assert exc.value.key == "field" and "body['a']" in str(exc.value)
