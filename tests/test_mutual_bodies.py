"""Mutual gravity between extended bodies: rigid bodies and elastic bodies attract each other
and point masses through their mass points (emorbit.kernels.effects.mutual), in one coupled
structure.

Checked: each body kind's conservation of E, P and L over long runs at large steps; the pair
forces' work equals the drop of their potential, their own Jacobian blocks match finite
differences, their sum and moment vanish; a uniform sphere of mass points attracts like a
point mass; the order of adding bodies and the effect does not matter; bodies left out of
``bodies`` feel nothing; the potential is recorded and a run resumes bit for bit. An elastic
chain keeps its invariants over many steps under zonal harmonics and under mutual gravity (the
longest runs under the ``long`` marker).
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest

import emorbit
from emorbit.effects.mutual import G
from emorbit.errors import InputError
from emorbit.kernels.effects.mutual import mutual_pair_potential, mutual_pairs

M = 1e12  # kg
D = 1000.0  # m
V_REL = float(np.sqrt(G * 2 * M / D))
T_BINARY = 2 * np.pi * float(np.sqrt(D**3 / (G * 2 * M)))


def _binary(first: str, second: str, dt: float, **sim_keys) -> emorbit.Simulation:
    """Two 1e12 kg bodies 1 km apart on an eccentric mutual orbit in free space, tumbling."""
    sim = emorbit.Simulation(None, dt=dt, **sim_keys)
    sim.add_effect("mutual")
    for name, kind, sign, spin in (("a", first, -1, [0.0, 0.0, 1e-3]), ("b", second, 1, [1e-4, 2e-4, 3e-4])):
        x, v = [sign * D / 2, 0.0, 0.0], [0.0, sign * 0.45 * V_REL, 0.0]
        if kind == "point":
            sim.add_point(name, mass=M, position=x, velocity=v)
        elif kind == "box":
            sim.add_rigid(name, "box", size=[300, 200, 100], mass=M, position=x, velocity=v, angular_velocity=spin)
        else:
            sim.add_rigid(
                name, "ellipsoid", semi_axes=[150, 100, 80], mass=M, position=x, velocity=v, angular_velocity=spin
            )
    return sim


def _errors(res) -> tuple[float, float, float]:
    """Largest relative changes of E, P and L over a run (P against the sum of m |v|)."""
    E, P, L = res.energy, res.momentum, res.angular_momentum
    p_scale = 2 * M * 0.45 * V_REL
    return (
        float(np.max(np.abs(E - E[0])) / abs(E[0])),
        float(np.max(np.linalg.norm(P - P[0], axis=1)) / p_scale),
        float(np.max(np.linalg.norm(L - L[0], axis=1)) / np.linalg.norm(L[0])),
    )


@pytest.mark.parametrize("steps", [pytest.param(100_000, marks=pytest.mark.long), 20_000])
def test_a_rigid_binary_keeps_energy_momentum_and_angular_momentum_over_many_steps(steps):
    """Two tumbling boxes on an eccentric mutual orbit (e ~ 0.6), T/50 per step, 2e4 steps
    (400 orbits; 1e5 steps, 2000 orbits, under the ``long`` marker): E, P and L, measured
    3.8e-15, 3.1e-15 and 5.5e-16 over 2e4 steps; limits 10x over 2e4 steps and 1e-12 over
    1e5; the spins exchange angular momentum with the orbit."""
    sim = _binary("box", "box", T_BINARY / 50)
    res = sim.run(steps=steps, every=2000, progress=False).si
    dE, dP, dL = _errors(res)
    limits = (4e-14, 3e-14, 6e-15) if steps == 20_000 else (1e-12, 1e-12, 1e-12)
    assert all(x <= y for x, y in zip((dE, dP, dL), limits)), (dE, dP, dL, limits)
    w = res.angular_velocities["a"]
    assert np.max(np.abs(w - w[0])) > 1e-6  # gravity-gradient torques of the partner change the spin


@pytest.mark.parametrize(("first", "second"), [("point", "ellipsoid"), ("ellipsoid", "ellipsoid")])
def test_point_rigid_and_ellipsoid_pairs_keep_every_invariant(first, second):
    sim = _binary(first, second, T_BINARY / 50)
    res = sim.run(steps=10_000, every=500, progress=False).si
    dE, dP, dL = _errors(res)
    # measured over 1e4 steps: point-ellipsoid 2.7e-15, 0, 1.1e-15; ellipsoid-ellipsoid 6.3e-15,
    # 1.7e-15, 9.0e-16 (E, P, L); limits 10x the larger
    assert dE <= 6.3e-14 and dP <= 1.7e-14 and dL <= 1.1e-14, (dE, dP, dL)


def test_an_elastic_tether_a_rigid_box_and_a_point_in_earth_orbit_with_j2():
    """Mutual gravity inside a field with zonal harmonics, between a point mass, a rigid box
    and an elastic chain none of which are attached: energy and the angular momentum about
    the pole within 1e-12; the mutual potential is recorded."""
    earth = emorbit.CentralField(body="earth")
    r = 7000e3
    v = float(np.sqrt(earth.gm / r))
    sim = emorbit.Simulation(earth, dt=5.0)
    sim.add_effect("zonal", model="earth")
    sim.add_effect("mutual")
    sim.add_point("p", mass=1e7, position=[r, 30.0, 0.0], velocity=[0.0, v, 0.01])
    sim.add_rigid("box", "box", size=[10, 4, 2], density=2000.0, position=[r, -30.0, 5.0], velocity=[0.0, v, 0.0],
                  angular_velocity=[0.01, 0.0, 0.02])  # fmt: skip
    sim.add_elastic(
        "chain", "chain", start=[0.0, 0.0, 0.0], end=[40.0, 0.0, 0.0], elements=4, young=1e9, density=3000.0,
        area=1e-2, position=[r - 20.0, 0.0, 20.0], velocity=[0.0, v, 0.0],
    )  # fmt: skip
    assert [type(s).__name__ for s in sim.systems] == ["Structure"]
    res = sim.run(steps=2000, every=100, progress=False).si
    E, L = res.energy, res.angular_momentum
    assert np.max(np.abs(E - E[0])) / abs(E[0]) <= 1e-12
    assert np.max(np.abs(L[:, 2] - L[0, 2])) / np.linalg.norm(L[0]) <= 1e-12


def mutual_forces(g, x0, x1, m, body, on, f, k):
    """The pair forces (n, 3) N and own blocks (n, 3, 3) N/m of :func:`mutual_pairs` (weighted)
    into f, k."""
    n = len(m)
    F, W, R = np.zeros((3, n)), np.zeros((9, n)), np.zeros(n)
    mutual_pairs(
        np.ascontiguousarray(x0.T), np.ascontiguousarray(x1.T), m, body, on, 1.0, np.array([g]), np.zeros(27 * n), F,
        W, R, True, True, True,
    )  # fmt: skip
    f[...] = F.T
    k[...] = W.T.reshape(n, 3, 3)
    return 0 if np.all(np.isfinite(F)) else 2


def mutual_potential(g, x, m, body, on):
    """The pairs' potential energy, J (:func:`mutual_pair_potential` summed)."""
    out = np.zeros(len(m))
    mutual_pair_potential(np.ascontiguousarray(x.T), m, body, on, np.array([g]), out)
    return float(out.sum())


def _random_points(rng, n: int = 12, bodies: int = 3):
    x0 = rng.normal(size=(n, 3)) * 50.0
    x1 = x0 + rng.normal(size=(n, 3))
    m = rng.uniform(1e6, 1e9, n)
    body = np.arange(n) % bodies
    return x0, x1, m, body.astype(np.int64), np.ones(n)


def test_pair_forces_do_the_work_of_the_potential_drop_and_cancel():
    rng = np.random.default_rng(5)
    for _ in range(20):
        x0, x1, m, body, on = _random_points(rng)
        f, k = np.empty_like(x0), np.empty((len(m), 3, 3))
        status = mutual_forces(G, x0, x1, m, body, on, f, k)
        assert status == 0
        work = float(np.sum(f * (x1 - x0)))
        drop = mutual_potential(G, x0, m, body, on) - mutual_potential(G, x1, m, body, on)
        assert abs(work - drop) <= 1e-13 * np.sum(np.abs(f) * np.abs(x1 - x0))
        assert np.linalg.norm(f.sum(axis=0)) <= 1e-14 * np.abs(f).sum()
        moment = np.cross(0.5 * (x0 + x1), f).sum(axis=0)  # about the origin, at the mean positions
        assert np.linalg.norm(moment) <= 1e-13 * np.sum(np.linalg.norm(0.5 * (x0 + x1), axis=1) * np.abs(f).sum(1))


def test_the_own_blocks_match_finite_differences_and_same_body_pairs_are_left_out():
    rng = np.random.default_rng(6)
    x0, x1, m, body, on = _random_points(rng)
    f, k = np.empty_like(x0), np.empty((len(m), 3, 3))
    mutual_forces(G, x0, x1, m, body, on, f, k)
    h = 1e-4
    for a in (0, 5):
        fd = np.empty((3, 3))
        for j in range(3):
            xp, xm = x1.copy(), x1.copy()
            xp[a, j] += h
            xm[a, j] -= h
            fp, fm = np.empty_like(f), np.empty_like(f)
            mutual_forces(G, x0, xp, m, body, on, fp, k.copy())
            mutual_forces(G, x0, xm, m, body, on, fm, k.copy())
            fd[:, j] = (fp[a] - fm[a]) / (2 * h)
        assert np.allclose(k[a], fd, rtol=1e-6, atol=1e-9 * np.abs(k[a]).max())
    one = np.zeros_like(body)  # every point in one body: no pairs
    mutual_forces(G, x0, x1, m, one, on, f, k)
    assert not f.any() and mutual_potential(G, x0, m, one, on) == 0.0


def test_a_sphere_of_mass_points_attracts_like_a_point_mass():
    """A uniform sphere's field outside it is a point mass's; its quadrature keeps that to
    degree 2, so a point orbiting a rigid sphere follows the point-point orbit closely."""
    ends = {}
    for kind in ("point", "sphere"):
        sim = emorbit.Simulation(None, dt=T_BINARY / 400, order=4)
        sim.add_effect("mutual")
        sim.add_point("p", mass=M, position=[-D / 2, 0, 0], velocity=[0, -0.5 * V_REL, 0])
        if kind == "point":
            sim.add_point("q", mass=M, position=[D / 2, 0, 0], velocity=[0, 0.5 * V_REL, 0])
        else:
            sim.add_rigid("q", "sphere", radius=100.0, mass=M, refinement=2, position=[D / 2, 0, 0],
                          velocity=[0, 0.5 * V_REL, 0])  # fmt: skip
        ends[kind] = sim.run(steps=400, progress=False).si.positions["p"][-1]
    assert np.linalg.norm(ends["point"] - ends["sphere"]) / D < 1e-6


def test_the_order_of_adding_does_not_matter_and_unlisted_bodies_feel_nothing():
    a = _binary("box", "point", T_BINARY / 50)
    b = emorbit.Simulation(None, dt=T_BINARY / 50)
    b.add_rigid("a", "box", size=[300, 200, 100], mass=M, position=[-D / 2, 0, 0], velocity=[0, -0.45 * V_REL, 0],
                angular_velocity=[0.0, 0.0, 1e-3], gravity="none")  # fmt: skip
    with pytest.raises(InputError, match="needs a central field or an effect that acts on it"):
        b.add_point("b", mass=M, position=[D / 2, 0, 0], velocity=[0, 0.45 * V_REL, 0])
    b.add_effect("mutual")
    b.add_point("b", mass=M, position=[D / 2, 0, 0], velocity=[0, 0.45 * V_REL, 0])
    ra, rb = (s.run(steps=200, progress=False).si for s in (a, b))
    for name in ("a", "b"):
        assert np.array_equal(ra.positions[name][-1], rb.positions[name][-1])
    c = _binary("box", "box", T_BINARY / 50)
    with pytest.raises(InputError, match="names 'mutual' once") as exc:
        c.add_effect("mutual", bodies=["a", "b"])
    assert exc.value.key == "effect[1]"
    d = emorbit.Simulation(None, dt=T_BINARY / 50)
    d.add_effect("mutual", bodies=["a", "far"])
    d.add_point("a", mass=M, position=[0, 0, 0], velocity=[0.5 * V_REL, 0, 0])  # a circular binary
    d.add_rigid("lone", "box", size=[1, 1, 1], mass=1.0, position=[D, 0, 0], velocity=[0, 1.0, 0])
    d.add_point("far", mass=M, position=[0, D, 0], velocity=[-0.5 * V_REL, 0, 0])
    t = 100 * T_BINARY / 50
    res = d.run(steps=100, progress=False).si
    assert np.allclose(res.positions["lone"][-1], [D, t, 0], rtol=0, atol=1e-9 * D)  # a straight line
    assert np.linalg.norm(res.positions["far"][-1] - [-0.5 * V_REL * t, D, 0]) > 0.1 * D  # pulled by "a"
    e = emorbit.Simulation(None, dt=10.0)
    e.add_effect("mutual", bodies=["a", "ghost"])
    e.add_point("a", mass=M, position=[0, 0, 0], velocity=[0, 0, 0])
    e.add_point("b", mass=M, position=[D, 0, 0], velocity=[0, 0, 0])
    with pytest.raises(InputError, match="no body named 'ghost'") as exc:
        e.run(steps=1, progress=False)
    assert exc.value.key == "effect[0].bodies"


def test_the_mutual_potential_is_recorded_and_a_run_resumes_bit_for_bit(tmp_path):
    text = f"""
[integrator]
method = "em"
dt = "{T_BINARY / 50!r} s"
t_end = "{200 * T_BINARY / 50!r} s"
output_every = 20

[[effect]]
kind = "mutual"

[[body]]
kind = "rigid"
name = "a"
shape = "ellipsoid"
semi_axes = ["150 m", "100 m", "80 m"]
mass = "1e12 kg"
position = ["-500 m", "0 m", "0 m"]
velocity = ["0 m/s", "{-0.45 * V_REL!r} m/s", "0 m/s"]
angular_velocity = ["0 rad/s", "0 rad/s", "1e-3 rad/s"]

[[body]]
kind = "point"
name = "b"
mass = "1e12 kg"
position = ["500 m", "0 m", "0 m"]
velocity = ["0 m/s", "{0.45 * V_REL!r} m/s", "0 m/s"]
"""
    scene = emorbit.parse_scene(text, "binary")
    whole = scene.build().run(scene.t_end, output=tmp_path / "whole.h5", every=20, progress=False)
    with h5py.File(tmp_path / "whole.h5", "r") as f:
        V = f["invariants/potential_mutual"][()]
        assert f["invariants/potential_mutual"].attrs["unit"] == "J" and np.all(V < 0)
        assert '"mutual"' in f.attrs["effects"]
    half = scene.with_overrides(t_end=f"{100 * T_BINARY / 50!r} s")
    half.build().run(half.t_end, output=tmp_path / "part.h5", every=20, progress=False)
    resumed = emorbit.resume(tmp_path / "part.h5", t_end=scene.t_end, progress=False)
    assert np.array_equal(resumed.si.positions["a"][-1], whole.si.positions["a"][-1])


def test_nothing_joins_mutual_gravity_once_the_structure_runs():
    sim = _binary("box", "box", T_BINARY / 50)
    sim.run(steps=1, progress=False)
    with pytest.raises(InputError, match="after the structure has started running"):
        sim.add_point("late", mass=M, position=[0, D, 0], velocity=[0, 0, 0])
    with pytest.raises(InputError, match="after the structure has started running"):
        sim.add_effect("mutual", bodies=["a", "b"])


@pytest.mark.parametrize(
    ("effect", "steps"),
    [
        pytest.param("zonal", 100_000, marks=pytest.mark.long),
        ("zonal", 10_000),
        pytest.param("mutual", 20_000, marks=pytest.mark.long),
        ("mutual", 4_000),
    ],
)
def test_effects_on_an_elastic_chain_over_many_steps(effect, steps):
    """An elastic chain of 4 bars under J2..J6 in a 7000 km orbit at 63 deg (1e4 steps; 1e5
    under the ``long`` marker), or attracting a tumbling rigid box in free space (4000 steps;
    2e4 under ``long``: the blocks between the bodies stay out of Newton's matrix, and each
    step takes 11 iterations), at T/50 per step: energy
    within 2e-13 and the angular momentum (about the pole under zonal harmonics) within 1e-13
    (measured over the long runs 4.7e-14 and 6.0e-14 for the energy, 1.1e-14 and 3.3e-15 for
    L). The zonal chain
    is soft (E = 1 MPa, axial omega dt = 660): a chain a thousand times stiffer takes 14
    iterations per step and its energy error, round-off amplified by its stiff mode, reaches
    1.2e-12 over 1e5 steps."""
    chain = dict(start=[0, 0, 0], elements=4, young=1e6 if effect == "zonal" else 1e9)
    if effect == "zonal":
        earth = emorbit.CentralField(body="earth")
        r, inc = 7000e3, np.radians(63.0)
        v = float(np.sqrt(earth.gm / r))
        sim = emorbit.Simulation(earth, dt=2 * np.pi * float(np.sqrt(r**3 / earth.gm)) / 50)
        sim.add_effect("zonal", model="earth")
        sim.add_elastic(
            "chain", "chain", end=[40.0, 0, 0], density=3000.0, area=1e-2, position=[r, 0, 0],
            velocity=[0, v * np.cos(inc), v * np.sin(inc)], angular_velocity=[0, 0, 0.001], **chain,
        )  # fmt: skip
        pole = np.array([0.0, 0.0, 1.0])
    else:
        sim = emorbit.Simulation(None, dt=T_BINARY / 50)
        sim.add_effect("mutual")
        sim.add_rigid("a", "box", size=[300, 200, 100], mass=M, position=[-D / 2, 0, 0],
                      velocity=[0, -0.45 * V_REL, 0], angular_velocity=[0, 0, 1e-3])  # fmt: skip
        sim.add_elastic("b", "chain", end=[200.0, 0, 0], density=M / 200.0, area=1.0, position=[D / 2 - 100, 0, 0],
                        velocity=[0, 0.45 * V_REL, 0], **chain)  # fmt: skip
        pole = None
    res = sim.run(steps=steps, every=1000, progress=False).si
    E, L = res.energy, res.angular_momentum
    assert np.max(np.abs(E - E[0])) / abs(E[0]) <= 2e-13
    dL = (L - L[0]) @ pole if pole is not None else np.linalg.norm(L - L[0], axis=1)
    assert np.max(np.abs(dL)) / np.linalg.norm(L[0]) <= 1e-13
