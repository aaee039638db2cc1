"""Effects beyond the central field: zonal harmonics and mutual gravity on point masses, run by
the em step compiled for each scene's set of effects (emorbit.effects).

Conservation is checked over 1e5 steps at large steps (a fiftieth of the orbit or less), as
REBOUNDx's test_conservation does for each of its effects; convergence orders with J2 on; the
nodal regression of a sun-synchronous orbit against first-order secular theory; and that a
scene's compiled step holds the code of its own effects only.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest

import emorbit
import emorbit.effects.mutual
from emorbit.effects.program import loop_module, set_source
from emorbit.errors import InputError

EARTH = emorbit.CentralField(body="earth")
R_SSO = 7000e3
V_SSO = float(np.sqrt(EARTH.gm / R_SSO))
T_SSO = 2 * np.pi * float(np.sqrt(R_SSO**3 / EARTH.gm))


def _j2_sim(
    dt: float, order: int = 2, inclination: float = 98.0, degree: int = 2, e: float = 0.0
) -> emorbit.Simulation:
    sim = emorbit.Simulation(EARTH, method="em", dt=dt, order=order)
    sim.add_effect("zonal", model="earth", degree=degree)
    inc = np.radians(inclination)
    v = V_SSO * np.sqrt(1 + e)
    sim.add_point("sat", mass=1.0, position=[R_SSO * (1 - e), 0, 0], velocity=[0, v * np.cos(inc), v * np.sin(inc)])
    return sim


def _figure_eight(steps_per_period: int = 100) -> tuple[emorbit.Simulation, float]:
    """The three-body figure-eight (Chenciner & Montgomery) of 1e12 kg bodies, 100 m across:
    (the simulation, the period in s)."""
    L, M = 100.0, 1e12
    tau = float(np.sqrt(L**3 / (emorbit.effects.mutual.G * M)))  # the time unit of G = M = L = 1
    period = 6.32591398 * tau
    sim = emorbit.Simulation(None, method="em", dt=period / steps_per_period)
    sim.add_effect("mutual")
    x1, v3 = np.array([0.97000436, -0.24308753, 0.0]), np.array([-0.93240737, -0.86473146, 0.0])
    for name, x, v in (("a", x1, -v3 / 2), ("b", -x1, -v3 / 2), ("c", np.zeros(3), v3)):
        sim.add_point(name, mass=M, position=x * L, velocity=v * L / tau)
    return sim, period


def test_zonal_keeps_energy_and_the_pole_angular_momentum_over_1e5_steps():
    """J2..J6 of the Earth, an eccentric inclined orbit, T/95 per step, 1e5 steps: the energy
    and L_z kept to 3.1e-15 and 1.2e-15 (measured; bounds 5x), while L_x moves by 0.89."""
    sim = _j2_sim(T_SSO / 95, inclination=63.0, degree=6, e=0.05)
    res = sim.run(steps=100_000, every=1000, progress=False).si
    E, L = res.energy, res.angular_momentum
    dE = np.max(np.abs(E - E[0])) / abs(E[0])
    assert dE <= 1.5e-14, f"|dE|/|E0| = {dE:.3g}, measured 3.1e-15"
    dLz = np.max(np.abs(L[:, 2] - L[0, 2])) / np.linalg.norm(L[0])
    assert dLz <= 6e-15, f"|dLz|/|L0| = {dLz:.3g}, measured 1.2e-15"
    # the other components are not conserved: the node regresses
    assert np.max(np.abs(L[:, 0] - L[0, 0])) / np.linalg.norm(L[0]) > 1e-3


def test_mutual_gravity_keeps_energy_momentum_and_angular_momentum_over_1e5_steps():
    """The figure-eight at a hundredth of its period per step, 1000 periods: energy, momentum
    and angular momentum kept to 4.0e-14, 3.1e-15 and 2.8e-15 (measured; bounds 5x)."""
    sim, _ = _figure_eight()
    res = sim.run(steps=100_000, every=1000, progress=False).si
    E, P, L = res.energy, res.momentum, res.angular_momentum
    dE = np.max(np.abs(E - E[0])) / abs(E[0])
    assert dE <= 2e-13, f"|dE|/|E0| = {dE:.3g}, measured 4.0e-14"
    scale_p = sum(m * np.linalg.norm(v[0]) for m, v in zip(res.masses.values(), res.velocities.values()))
    dP = np.max(np.abs(P - P[0])) / scale_p
    assert dP <= 1.5e-14, f"|dP| = {dP:.3g} of sum m|v|, measured 3.1e-15"
    scale_l = sum(  # the figure's total angular momentum is 0: relative to the bodies' own
        m * np.linalg.norm(x[0]) * np.linalg.norm(v[0])
        for m, x, v in zip(res.masses.values(), res.positions.values(), res.velocities.values())
    )
    dL = np.max(np.linalg.norm(L - L[0], axis=1)) / scale_l
    assert dL <= 1.4e-14, f"|dL| = {dL:.3g} of sum m|x||v|, measured 2.8e-15"
    x = res.positions["a"]
    assert np.ptp(x[:, 0]) > 100.0  # they moved along the figure


def test_mutual_gravity_inside_the_central_field():
    """Two satellites attracting each other in the Earth's field: energy and the angular
    momentum about the centre are kept (2e4 steps: measured 1.2e-13 and 6.3e-14, bounds 5x);
    each effect's potential is recorded."""
    sim = emorbit.Simulation(EARTH, method="em", dt=30.0)
    sim.add_effect("mutual")
    sim.add_point("a", mass=1e10, position=[R_SSO, 0, 0], velocity=[0, V_SSO, 0])
    sim.add_point("b", mass=1e10, position=[R_SSO, 50.0, 0], velocity=[0, V_SSO, 0.01])
    res = sim.run(steps=20_000, every=100, progress=False).si
    E, L = res.energy, res.angular_momentum
    dE = np.max(np.abs(E - E[0])) / abs(E[0])
    assert dE <= 6e-13, f"|dE|/|E0| = {dE:.3g}, measured 1.2e-13"
    dL = np.max(np.linalg.norm(L - L[0], axis=1)) / np.linalg.norm(L[0])
    assert dL <= 3e-13, f"|dL|/|L0| = {dL:.3g}, measured 6.3e-14"


def _final_position(dt: float, order: int, t_end: float) -> np.ndarray:
    sim = _j2_sim(dt, order=order, inclination=50.0, e=0.05)
    return sim.run(t_end, every=10**9, progress=False).si.positions["sat"][-1]


@pytest.mark.parametrize("order", [2, 4, 6, 8])
def test_convergence_orders_with_j2(order):
    """The final position's error against T/800 at order 8, halving the step: rates measured
    1.999, 3.988, 5.992 and 7.981 (the worst 0.019 off the order; bound 0.1)."""
    t_end = 2 * T_SSO
    coarse = {2: 100, 4: 60, 6: 40, 8: 30}[order]  # steps per orbit at the coarse step
    ref = _final_position(T_SSO / 800, 8, t_end)
    errors = [np.linalg.norm(_final_position(T_SSO / n, order, t_end) - ref) for n in (coarse, 2 * coarse)]
    rate = np.log2(errors[0] / errors[1])
    assert abs(rate - order) <= 0.1, f"order {order}: rate {rate:.4f} from errors {errors}, measured within 0.019"


def test_sun_synchronous_node_advances_as_first_order_theory_says():
    """At 7000 km and 98 deg the node advances by -3/2 n J2 (R/a)^2 cos i per unit time
    (about 1.00 deg/day); first-order theory's own error is O(J2^2), about 1e-3 relative
    (measured -1.2e-3 over 2 days; bound 5e-3)."""
    sim = _j2_sim(60.0)
    res = sim.run("2 d", every=10, progress=False)
    el = res.elements("sat", si=True)
    # the mean node: fit a line through the osculating node over whole orbits
    t = res.si.time
    slope = np.polyfit(t, np.unwrap(el.raan), 1)[0]
    jn, radius = 1.0826261738e-3, 6378136.3
    a = np.mean(el.a)
    n = np.sqrt(EARTH.gm / a**3)
    theory = -1.5 * n * jn * (radius / a) ** 2 * np.cos(np.radians(98.0))
    assert abs(slope / theory - 1) < 5e-3, (np.degrees(slope) * 86400, np.degrees(theory) * 86400)


def test_a_scene_compiles_only_the_effects_it_names():
    from emorbit.effects import EFFECTS

    def code(*kinds):
        source, working, _ = set_source([EFFECTS[k] for k in kinds])
        return source.split('"""', 2)[2], working

    central_only, _ = code("central")
    with_mutual, _ = code("central", "mutual")
    with_zonal, _ = code("central", "zonal")
    with_drag, working = code("central", "zonal", "drag")
    assert "zonal" not in with_mutual and "mutual" not in with_zonal
    # a per-point effect's force is called from its loop module's C callbacks, by name: the set
    # neither imports nor links them (linked, LLVM would optimise and emit them in every set)
    zonal_loops = loop_module(EFFECTS["zonal"])[0]
    assert f"call_c('{zonal_loops}_forces_jac'" in with_zonal and "mutual_pairs" in with_mutual
    assert "from emorbit_effect_loops" not in with_zonal and "import emorbit_effect_loops" not in with_zonal
    assert "zonal_piece as force_" in loop_module(EFFECTS["zonal"])[1]
    assert "@numba.cfunc(FORCES_LOOP" in loop_module(EFFECTS["zonal"])[1]
    assert "zonal" not in central_only and "mutual" not in central_only
    assert working == (2,) and "drag_facet" in with_drag  # drag does work (slot 0) and acts on surfaces


SCENE = """
[field]
body = "earth"

[integrator]
dt = "60 s"
t_end = "6000 s"
output_every = 10

[[effect]]
kind = "zonal"
model = "earth"
degree = 2

[[effect]]
kind = "mutual"
bodies = ["a", "b"]

[[body]]
name = "a"
kind = "point"
mass = "1e10 kg"
orbit = {a = "7000 km", e = 0.001, i = "98 deg"}

[[body]]
name = "b"
kind = "point"
mass = "1e10 kg"
orbit = {a = "7000 km", e = 0.001, i = "98 deg", nu = "0.0001 rad"}
"""


def test_a_scene_with_effects_runs_records_each_potential_and_resumes(tmp_path):
    path = tmp_path / "run.h5"
    (tmp_path / "scene.toml").write_text(SCENE)
    from emorbit.cli import main

    assert main(["run", str(tmp_path / "scene.toml"), "-o", str(path), "-q"]) == 0
    with h5py.File(path, "r") as f:
        assert "zonal" in f.attrs["effects"] and "mutual" in f.attrs["effects"]
        parts = {k: f[f"invariants/{k}"][()] for k in f["invariants"] if k.startswith("potential_")}
        assert set(parts) == {"potential_central", "potential_zonal", "potential_mutual"}
        assert all(f[f"invariants/{k}"].attrs["unit"] == "J" for k in parts)
        energy = f["invariants/energy"][()]
        kinetic = sum(
            0.5 * f[f"bodies/{b}"].attrs["mass"] * np.sum(f[f"bodies/{b}/velocity"][()] ** 2, axis=1) for b in "ab"
        )
        # the parts add up to the energy to one rounding (measured 2.2e-16), and 100 steps keep
        # it to 4.5e-16 (measured)
        np.testing.assert_allclose(kinetic + sum(parts.values()), energy, rtol=1e-15)
        dE = np.max(np.abs(energy - energy[0])) / abs(energy[0])
        assert dE < 2.5e-15, f"|dE|/|E0| = {dE:.3g}, measured 4.5e-16"
        unbroken = {k: f[k][()] for k in ("time", "invariants/energy", "bodies/a/position")}
    again = tmp_path / "half.h5"
    sim = emorbit.load_scene(str(tmp_path / "scene.toml")).build()
    sim.run("3000 s", every=10, output=again, progress=False)
    emorbit.resume(again, "6000 s")
    with h5py.File(again, "r") as f:
        for k, a in unbroken.items():
            np.testing.assert_array_equal(f[k][()], a, err_msg=k)


def test_to_toml_writes_the_effects_back():
    sim = emorbit.parse_scene(SCENE, "test").build()
    again = emorbit.parse_scene(sim.to_toml(), "again").build()
    assert [(t.kind, t.table) for t in again.effects.named] == [(t.kind, t.table) for t in sim.effects.named]


def test_python_quantities_are_written_as_strings_with_units():
    import astropy.units as u

    sim = emorbit.Simulation(EARTH, dt=60.0)
    sim.add_effect("zonal", j=[1.08e-3], radius=6378 * u.km)
    sim.add_point("s", mass=1.0, position=[R_SSO, 0, 0], velocity=[0, V_SSO, 0])
    again = emorbit.parse_scene(sim.to_toml(), "again").build()
    np.testing.assert_array_equal(again.effects.named[0].p, sim.effects.named[0].p)


@pytest.mark.parametrize(
    "table, key, message",
    [
        ('kind = "magnetic"', "effect[0].kind", "unknown effect"),
        ('kind = "zonal"\nmodel = "earth"\ncolour = 1', "effect[0].colour", "unknown key"),
        ('kind = "zonal"\nmodel = "mars"', "effect[0].model", "unknown zonal model"),
        ('kind = "zonal"\nj = [1e-3]', "effect[0].radius", "reference radius"),
        ('kind = "zonal"\nj = [1e-3]\nradius = 6000', "effect[0].radius", "no unit"),
        ('kind = "zonal"\nmodel = "earth"\nj = [1e-3]', "effect[0]", "exactly one of model"),
        ('kind = "zonal"\nmodel = "earth"\ndegree = 7', "effect[0].degree", "from 2 to 6"),
        ('kind = "zonal"\nj = [1e-3, "x"]\nradius = "1 km"', "effect[0].j", "finite numbers"),
        ('kind = "zonal"\nmodel = "earth"\npole = [0, 0, 0]', "effect[0].pole", "other than 0"),
        ('kind = "mutual"\nbodies = ["a", "z"]', "effect[0].bodies", "no body named 'z'"),
        ('kind = "mutual"\nbodies = ["a"]', "effect[0].bodies", "at least two"),
    ],
)
def test_bad_effect_tables_name_their_key(table, key, message):
    text = SCENE.split("[[effect]]")[0] + "[[effect]]\n" + table + "\n" + "[[body]]" + SCENE.split("[[body]]", 1)[1]
    with pytest.raises(InputError) as exc:
        emorbit.parse_scene(text, "test").build()
    assert exc.value.key == key and message in exc.value.message, str(exc.value)


def test_zonal_needs_a_field_and_is_named_once():
    with pytest.raises(InputError, match="needs a \\[field\\]"):
        emorbit.Simulation(None, dt=1.0).add_effect("zonal", model="earth")
    sim = emorbit.Simulation(EARTH, dt=1.0)
    sim.add_rigid("box", "box", size=[1, 1, 1], density=1.0, position=[R_SSO, 0, 0], velocity=[0, V_SSO, 0])
    sim.add_effect("zonal", model="earth")
    with pytest.raises(InputError, match="names 'zonal' once") as exc:
        sim.add_effect("zonal", model="earth")
    assert exc.value.key == "effect[1]" and len(sim.effects.named) == 1
    with pytest.raises(InputError, match="central field or an effect that acts on it"):
        emorbit.Simulation(None, dt=1.0).add_point("p", mass=1.0, position=[1, 0, 0], velocity=[0, 0, 0])


def test_the_effects_page_is_generated_from_the_declarations():
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parent.parent / "scripts" / "docs_effects.py"
    done = subprocess.run([sys.executable, str(script), "--check"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    page = (script.parent.parent / "docs" / "effects.md").read_text()
    for name, module in emorbit.effects.EFFECTS.items():
        assert f"## `{name}`" in page
        assert all(f"| `{k.name}` |" in page for k in module.KEYS)


# -- rigid bodies under zonal harmonics ------------------------------------------------------------
def _j2_gravity(x: np.ndarray, gm: float, j2: float, radius: float) -> np.ndarray:
    """-grad of V = (GM J2 R^2 / (2 r^3)) (3 z^2 / r^2 - 1) per unit mass, the pole along z."""
    r = np.linalg.norm(x)
    z = x[2]
    k = gm * j2 * radius**2 / 2
    grad = -3 * k * r**-5 * x * (3 * z**2 / r**2 - 1) + k * r**-3 * (
        6 * z * np.array([0, 0, 1.0]) / r**2 - 6 * z**2 * x / r**4
    )
    return -grad


def _spin(res) -> np.ndarray:
    """The bodies' spin angular momentum at each record: total minus orbital."""
    si = res.si
    orbital = sum(si.masses[n] * np.cross(si.positions[n], si.velocities[n]) for n in si.names)
    return si.angular_momentum - orbital


def test_the_zonal_torque_on_a_dumbbell_is_the_analytic_one():
    """The torque of J2 on a rigid body comes from its mass points, as the gravity gradient's
    does: over one short step from rest, the spin a dumbbell gains with J2 on, less the spin it
    gains without, is h times the analytic J2 torque on its two ends (measured: to 8.4e-5 of
    |torque|, the step's own error; bound 1e-4 + 1e-4 relative)."""
    h, L, m = 0.01, 100.0, 1000.0
    x_c = np.array([7000e3, 0.0, 1500e3])
    rotation = [0.3, 0.5, 0.2]
    spins = {}
    for zonal in (False, True):
        sim = emorbit.Simulation(EARTH, method="em", dt=h)
        if zonal:
            sim.add_effect("zonal", j=[1.0826261738e-3], radius=6378136.3)
        sim.add_rigid(
            "d", "dumbbell", masses=[m, m], length=L, position=x_c, velocity=[0, 0, 0], rotation_vector=rotation
        )
        spins[zonal] = _spin(sim.run(steps=1, progress=False))[-1]
    from scipy.spatial.transform import Rotation

    axis = Rotation.from_rotvec(rotation).apply([1.0, 0, 0])
    torque = sum(
        np.cross(s, m * _j2_gravity(x_c + s, EARTH.gm, 1.0826261738e-3, 6378136.3))
        for s in (axis * L / 2, -axis * L / 2)
    )
    measured = (spins[True] - spins[False]) / h
    np.testing.assert_allclose(
        measured, torque, rtol=1e-4, atol=1e-4 * np.linalg.norm(torque), err_msg="measured 8.4e-5 of |torque|"
    )
    assert np.linalg.norm(torque) > 0


def test_a_tumbling_box_with_j2_keeps_energy_and_the_pole_angular_momentum():
    """A rigid box tumbling on an inclined orbit with J2..J6 at T/50 per step: energy and L_z
    (orbital plus spin) over 1e5 steps, measured 8.6e-15 and 4.4e-15 (limits 10x); the other
    components move (the node regresses)."""
    r, v = R_SSO, V_SSO
    inc = np.radians(63.0)
    sim = emorbit.Simulation(EARTH, method="em", dt=T_SSO / 50)
    sim.add_effect("zonal", model="earth")
    vel = [0, v * np.cos(inc), v * np.sin(inc)]
    sim.add_rigid(
        "box", "box", size=[10, 4, 2], density=500.0, position=[r, 0, 0], velocity=vel,
        angular_velocity=[0.0002, 0.002, 0.0001],
    )  # fmt: skip
    res = sim.run(steps=100_000, every=1000, progress=False).si
    E, Lv = res.energy, res.angular_momentum
    dE = np.max(np.abs(E - E[0])) / abs(E[0])
    dLz = np.max(np.abs(Lv[:, 2] - Lv[0, 2])) / np.linalg.norm(Lv[0])
    assert dE <= 8.6e-14, f"|dE|/|E0| = {dE:.3g}, measured 8.6e-15"
    assert dLz <= 4.4e-14, f"|dLz|/|L0| = {dLz:.3g}, measured 4.4e-15"
    assert np.max(np.abs(Lv[:, 0] - Lv[0, 0])) / np.linalg.norm(Lv[0]) > 1e-3


def test_the_energy_error_with_j2_is_a_random_walk():
    """Brouwer's law with J2..J6 on: 32 slightly perturbed copies of an eccentric inclined
    orbit, 2e5 steps at T/100; the ensemble RMS of each point's relative energy error grows
    with a log-log slope of 0.5 +- 0.1, and its mean stays well below the RMS (no drift)."""
    rng = np.random.default_rng(2026)
    dt, steps, records, members = T_SSO / 100, 200_000, 200, 32
    sim = emorbit.Simulation(EARTH, method="em", dt=dt)
    sim.add_effect("zonal", model="earth")
    inc, e = np.radians(63.0), 0.05
    v0 = V_SSO * np.sqrt(1 + e) * np.array([0, np.cos(inc), np.sin(inc)])
    for i in range(members):
        sim.add_point(f"p{i}", mass=1.0, position=[R_SSO * (1 - e), 0, 0], velocity=v0 * (1 + 1e-9 * rng.normal()))
    res = sim.run(steps=steps, every=steps // records, progress=False).si
    zonal = sim.effects[1]
    x = np.stack([res.positions[n] for n in res.names], axis=-1)  # (records, 3, members)
    v = np.stack([res.velocities[n] for n in res.names], axis=-1)
    ones = np.ones(1)
    energy = 0.5 * np.sum(v * v, axis=1) - EARTH.gm / np.linalg.norm(x, axis=1)
    energy += np.stack([zonal.potential_energy(x[:, :, [j]], ones) for j in range(members)], axis=-1)
    rel = (energy - energy[:1]) / np.abs(energy[:1])
    rms, mean = np.sqrt(np.mean(rel**2, axis=1)), np.mean(rel, axis=1)
    n = np.arange(records + 1) * (steps // records)
    keep = n >= 1000
    slope = np.polyfit(np.log(n[keep]), np.log(rms[keep]), 1)[0]
    # statistical (32 members): measured slope 0.437, |mean| up to 0.16 of the RMS
    assert abs(slope - 0.5) <= 0.1, f"log-log slope {slope:.3f}, measured 0.437"
    drift = np.max(np.abs(mean[n >= steps // 10])) / np.max(rms[n >= steps // 10])
    assert drift <= 0.5, f"|mean| up to {drift:.3g} of the RMS, measured 0.16"


def test_a_sweep_varies_an_effect_key(tmp_path):
    """Sweeps take effect keys like any other: J2 alone against J2..J6 moves the orbit (by 4.4 m
    in 600 s, measured), the energy kept to 1.1e-16 and 2.2e-16 (measured; bound 1.1e-15)."""
    from emorbit.sweep import parse_sweep, run_sweep

    (tmp_path / "scene.toml").write_text(SCENE)
    text = f"""
[sweep]
scene = "{tmp_path / "scene.toml"}"

[set]
"integrator.t_end" = "600 s"

[[parameter]]
key = "effect[0].degree"
values = [2, 6]
"""
    res = run_sweep(parse_sweep(text), tmp_path / "out", backend="serial")
    assert [r["status"] for r in res.rows] == ["completed", "completed"]
    errors = [r["energy_error"] for r in res.rows]
    assert max(errors) < 1.1e-15, f"energy errors {errors}, measured 1.1e-16 and 2.2e-16"
    finals = [emorbit.read(tmp_path / f"out/runs/run-00000{i}.h5").si.positions["a"][-1] for i in range(2)]
    moved = np.linalg.norm(finals[0] - finals[1])
    assert 1.0 < moved < 20.0, f"J3..J6 moved it by {moved:.3g} m, measured 4.4 m"  # a little


def test_a_binary_keeps_its_energy_without_drift():
    """Two bodies of comparable mass, e = 0.5, T/200, 100 orbits: the energy error stays a
    random walk at a few eps. Stopping the coupled iteration as soon as its rest was bounded
    by eps (not a thousandth of it) left an error of one sign each step: -5.9e-14 after 100
    orbits, growing linearly. Measured now 6.6e-15 (bound 1e-14, below that drift)."""
    from emorbit.effects.mutual import G

    m1, m2, a, e = 2e12, 1e12, 100.0, 0.5
    M = m1 + m2
    T = 2 * np.pi * np.sqrt(a**3 / (G * M))
    rp = a * (1 - e)
    vp = np.sqrt(G * M * (1 + e) / rp)
    sim = emorbit.Simulation(None, method="em", dt=T / 200)
    sim.add_effect("mutual")
    sim.add_point("a", mass=m1, position=[-m2 / M * rp, 0, 0], velocity=[0, -m2 / M * vp, 0])
    sim.add_point("b", mass=m2, position=[m1 / M * rp, 0, 0], velocity=[0, m1 / M * vp, 0])
    E = sim.run(steps=20_000, every=200, progress=False).si.energy
    rel = (E - E[0]) / abs(E[0])
    assert np.max(np.abs(rel)) < 1e-14, f"{rel[::10]}, measured |dE/E0| <= 6.6e-15"


def test_tethered_satellites_with_j2_keep_energy_and_the_pole_angular_momentum():
    """Zonal harmonics on a coupled structure (two rigid boxes and an elastic tether) act at its
    gravity points: energy and the angular momentum about a tilted pole stay within 3.3e-15 and
    4.6e-15 over 600 steps (measured 6.6e-16 and 9.2e-16), while the component about another
    axis moves (measured 1.4e-4 of |L|); the zonal potential is recorded."""
    text = emorbit.load_scene("tethered-satellites").text.replace("[integrator]", EFFECT_TABLE + "\n[integrator]")
    scene = emorbit.parse_scene(text, "test").with_overrides(t_end="600 s")
    sim = scene.build()
    res = sim.run(scene.t_end, every=20, progress=False).si
    pole = np.array([0.3, 0.0, 1.0]) / np.linalg.norm([0.3, 0.0, 1.0])
    E, L = res.energy, res.angular_momentum
    dE = np.max(np.abs(E - E[0])) / abs(E[0])
    assert dE <= 3.3e-15, f"|dE|/|E0| = {dE:.3g}, measured 6.6e-16"
    Lp = L @ pole
    dLp = np.max(np.abs(Lp - Lp[0])) / np.linalg.norm(L[0])
    assert dLp <= 4.6e-15, f"|dL.pole|/|L0| = {dLp:.3g}, measured 9.2e-16"
    other = L @ np.array([1.0, 0.0, 0.0])
    moved = np.max(np.abs(other - other[0])) / np.linalg.norm(L[0])
    assert moved > 1e-5, f"L_x moved by {moved:.3g} of |L0| only, measured 1.4e-4"


EFFECT_TABLE = """
[[effect]]
kind = "zonal"
model = "earth"
pole = [0.3, 0, 1]
"""


def test_zonal_on_a_structure_changes_its_motion_and_records_its_potential(tmp_path):
    text = emorbit.load_scene("tethered-satellites").text
    with_j2 = text.replace("[integrator]", EFFECT_TABLE + "\n[integrator]")
    ends = []
    for name, t in (("plain", text), ("j2", with_j2)):
        scene = emorbit.parse_scene(t, name).with_overrides(t_end="100 s")
        sim = scene.build()
        res = sim.run(scene.t_end, every=20, output=tmp_path / f"{name}.h5", progress=False).si
        ends.append(res.positions["upper"][-1])
    moved = np.linalg.norm(ends[0] - ends[1])
    assert moved > 10.0, f"J2 moved it by {moved:.3g} m, measured 51 m in 100 s"
    with h5py.File(tmp_path / "j2.h5", "r") as f:
        zonal = f["invariants/potential_zonal"][()]
        assert f["invariants/potential_zonal"].attrs["unit"] == "J" and np.all(np.abs(zonal) > 0)
        ratio = np.abs(zonal / f["invariants/potential_central"][()])
        # J2 (R/r)^2 P2 of the central part: measured 3.37e-4 to 3.39e-4 along this orbit
        assert np.all((2.5e-4 < ratio) & (ratio < 4.5e-4)), f"{ratio.min():.3g} to {ratio.max():.3g}"


def test_the_sets_facts_follow_an_effect_added_after_they_were_asked():
    """What a set says of itself is kept between questions (a run asks many times); adding or
    removing an effect makes it answer anew: its order, the working effects, the work rows."""
    sim = emorbit.Simulation(EARTH, method="em", dt=10.0)
    effects = sim.effects
    assert effects.kinds() == ("central",) and effects.working() == [] and effects.work_rows() == 0
    drag = effects.add({"kind": "drag", "atmosphere": "ussa1976"}, "effect[0]")
    assert effects.kinds() == ("central", "drag")
    assert [e.kind for e in effects.working()] == ["drag"] and effects.work_rows() == 1
    effects.add({"kind": "zonal", "model": "earth", "degree": 2}, "effect[1]")
    assert effects.kinds() == ("central", "zonal", "drag") and effects.work_rows() == 1
    effects.remove(drag)
    assert effects.kinds() == ("central", "zonal") and effects.working() == [] and effects.work_rows() == 0


def test_the_sets_arrays_follow_its_effects_tables_and_parameters():
    """The set keeps its compiled program and its tables' concatenation between chunks; a
    table an effect replaces, a parameter it writes in place and a new effect all show in the
    next arrays, which equal the ones built from scratch."""
    sim = emorbit.Simulation(EARTH, method="em", dt=10.0, epoch="2026-03-20T00:00:00 TDB")
    effects = sim.effects
    moon = effects.add({"kind": "third_body", "body": "moon"}, "effect[0]")
    effects.prepare(0.0, 3600.0, sim.epoch)
    assert effects.program() is effects.program()

    def fresh(n):
        return np.concatenate([e.p for e in effects.all]), np.concatenate([e.tab for e in effects.all])

    P, I, T, S = effects.arrays(3)
    assert np.array_equal(P, fresh(3)[0]) and np.array_equal(T, fresh(3)[1]) and S.shape == (max(I[-1, 5], 1),)
    moon.p[0] *= 2.0  # in place
    moon.tab = moon.tab * 1.5  # replaced
    P, I2, T, _ = effects.arrays(3)
    assert np.array_equal(P, fresh(3)[0]) and np.array_equal(T, fresh(3)[1]) and np.array_equal(I, I2)
    effects.add({"kind": "zonal", "model": "earth", "degree": 2}, "effect[1]")
    P, I3, T, _ = effects.arrays(3)
    assert I3.shape[0] == 3 and np.array_equal(P, fresh(3)[0]) and np.array_equal(T, fresh(3)[1])
    assert effects.program().kinds == ("central", "zonal", "third_body")
    P, I, T, S = emorbit.Simulation(None, method="em", dt=10.0).effects.arrays(2)  # free space: no effects
    assert (P.size, I.shape, T.size, S.size) == (0, (0, I.shape[1]), 1, 1)


def test_a_cfunc_is_typed_once_and_as_numba_types_it():
    """A step kernel takes the set's cfuncs: their Numba type is built once per cfunc
    (emorbit.effects.program), it is the type Numba itself gives them, and the address a call
    reads by the wrapper address protocol is the cfunc's own."""
    import numba
    from numba.core.types import FunctionType
    from numba.experimental.function_type import _get_wrapper_address

    prog = emorbit.Simulation(EARTH, method="em", dt=10.0).effects.program()
    for f in (prog.forces, prog.prepare, prog.work, prog.potential):
        assert numba.typeof(f) is numba.typeof(f)
        assert numba.typeof(f) == FunctionType(f._sig)
        assert f.__wrapper_address__() == f.address == _get_wrapper_address(f, f._sig) > 0
