"""Atmospheric drag on point masses (emorbit.effects.drag): the energy balance, the decay rate
against theory, the co-rotating air, the records and resume, and bad keys.

The em step's kinetic-energy change is the conservative potentials' drop plus drag's discrete
work ``m F . (x1 - x0)``, which the compiled step sums per point; so ``E - E0 - W`` stays at
round-off over 1e5 steps at a fiftieth of the orbit, whatever the atmosphere.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest

import emorbit
from emorbit.errors import InputError

EARTH = emorbit.CentralField(body="earth")
R_LEO = 6778e3
V_LEO = float(np.sqrt(EARTH.gm / R_LEO))
T_LEO = 2 * np.pi * float(np.sqrt(R_LEO**3 / EARTH.gm))
EXPONENTIAL = dict(atmosphere="exponential", density="3.7e-12 kg/m3", reference_altitude="400 km", scale_height="58 km")
B = 0.02  # Cd A / m, m^2/kg
SCENE = """
[field]
body = "earth"

[integrator]
method = "em"
dt = "55.3 s"
t_end = "5530 s"
output_every = 10

[[effect]]
kind = "drag"
atmosphere = "exponential"
density = "3.7e-12 kg/m3"
reference_altitude = "400 km"
scale_height = "58 km"

[[body]]
name = "sat"
kind = "point"
mass = "100 kg"
ballistic_coefficient = "0.02 m2/kg"
position = ["6778 km", "0 km", "0 km"]
velocity = ["0 km/s", "7.669 km/s", "0 km/s"]
"""


def _leo(dt, atmosphere=None, rotation="0 rad/s", inclination=0.0, zonal=False, order=2, mass=100.0):
    sim = emorbit.Simulation(EARTH, method="em", dt=dt, order=order)
    if zonal:
        sim.add_effect("zonal", model="earth", degree=2)
    sim.add_effect("drag", rotation_rate=rotation, **(atmosphere or EXPONENTIAL))
    c, s = np.cos(inclination), np.sin(inclination)
    sim.add_point("sat", mass=mass, ballistic_coefficient=B, position=[R_LEO, 0, 0], velocity=[0, V_LEO * c, V_LEO * s])
    return sim


@pytest.mark.parametrize(
    "atmosphere, zonal",
    [(EXPONENTIAL, False), ({"atmosphere": "ussa1976"}, False), (EXPONENTIAL, True)],
    ids=["exponential", "ussa1976", "exponential+J2"],
)
def test_the_energy_balance_closes_to_roundoff_over_1e5_large_steps(tmp_path, atmosphere, zonal):
    """1e5 em steps of T/50 (2000 orbits) at 400 km, inclined 52 deg, co-rotating air: drag takes
    1 to 3 % of the energy (measured: 1.7 %, 1.0 %, 2.8 %) and the balance closes to 3.6e-15,
    6.5e-15 and 1.1e-14 of |E0| (bound 1e-13)."""
    sim = _leo(T_LEO / 50, atmosphere, rotation="7.292115e-5 rad/s", inclination=0.9, zonal=zonal)
    path = tmp_path / "run.h5"
    sim.run(steps=100_000, every=1000, output=path, progress=False)
    with h5py.File(path, "r") as f:
        time = f["time"][()]
        energy = f["invariants/energy"][()]
        work = f["invariants/work_drag"][()]
        balance = f["invariants/energy_balance"][()]
    assert time[-1] == pytest.approx(100_000 * T_LEO / 50)
    assert work[0] == 0.0 and np.all(np.diff(work) < 0)  # drag only takes energy
    assert abs(work[-1] / energy[0]) > 5e-3
    np.testing.assert_array_equal(balance, energy - energy[0] - work)
    worst = np.max(np.abs(balance)) / abs(energy[0])
    assert worst <= 1e-13, f"|E - E0 - W| / |E0| = {worst:.3g}, measured 3.6e-15 to 1.1e-14"


#: orders 2, 4, 8: the largest |E - E0 - W| / |E0| over 1e5 steps, about 10x the measured
#: (4.0e-15, 3.5e-14, 2.5e-14; a composed step's 3 or 17 sub-steps each add their round-off)
BALANCE = {2: 4e-14, 4: 3.5e-13, 8: 2.5e-13}


@pytest.mark.parametrize("order", [2, 4, 8])
def test_the_balance_closes_at_every_order_and_the_work_sum_keeps_its_compensation(order):
    """1e5 steps of T/50 at 400 km, inclined 52 deg, co-rotating air, at orders 2, 4 and 8.
    Every sub-step of a composition (3 at order 4 and 17 at order 8, some of them backwards)
    adds drag's work over that sub-step, so the balance E - E0 - W closes at every order
    (:data:`BALANCE`); drag takes 1.7 %, 0.7 % and 1.0 % of the energy (the orders' phases
    differ at this step). The work sum is compensated: a satellite three times as heavy on the
    same path (drag per unit mass is B's, so the path is the same bits) has three times the
    work to the rounding of the sum, measured 1 unit in the last place of W at every record
    (bound 8); summed without its compensation the two differ by 88 to 704 units, a random
    walk of the sum's rounding that the balance itself cannot tell from its own round-off.
    With the work of a sub-step evaluated at the composed step's dt instead of the sub-step's,
    the balance is off by 0.15 (order 4) and 7e-4 (order 8)."""
    runs = [
        _leo(T_LEO / 50, rotation="7.292115e-5 rad/s", inclination=0.9, order=order, mass=m).run(
            steps=100_000,
            every=1000,
            progress=False,
            drift_tolerance=np.inf,  # the balance is asserted here
        )
        for m in (1.0, 3.0)
    ]
    light, heavy = (r.si for r in runs)
    np.testing.assert_array_equal(light.positions["sat"], heavy.positions["sat"])
    for res in (light, heavy):
        worst = np.max(np.abs(res.energy_balance)) / abs(res.energy[0])
        assert worst <= BALANCE[order], f"order {order}: |E - E0 - W| / |E0| = {worst:.3g}"
        assert abs(res.work["drag"][-1] / res.energy[0]) > 5e-3
    w1, w3 = light.work["drag"], heavy.work["drag"]
    ulps = np.max(np.abs(w3 - 3.0 * w1) / np.spacing(np.abs(w3)))
    assert ulps <= 8, f"order {order}: the work of 3 m is 3 times that of m to {ulps:.0f} units in the last place"


def _decay_rate(sim, per_orbit: int, orbits: int = 20):
    """The rate of the osculating semi-major axis at the run's middle (a quadratic fit), m/s,
    and the semi-major axis there."""
    res = sim.run(steps=orbits * per_orbit, every=per_orbit // 10, progress=False)
    a, t = res.elements("sat").a.value, res.time.value
    p = np.polyfit(t - t.mean(), a, 2)
    return p[1], p[2], res


def test_the_decay_rate_of_a_circular_orbit_matches_theory():
    """Without rotation, a circular orbit decays at da/dt = -B rho(a) sqrt(GM a), that is
    -2 pi B rho(a) a^2 per revolution (King-Hele). The theory's own error here: the
    eccentricity stays below 1e-8 (the density's variation over the orbit, ~(a e / H)^2, is
    nil), the second-order terms are O(B rho a) = 5e-7, and the density's change as the orbit
    decays (21 m per orbit, 4e-4 of rho) is taken up by the quadratic fit. The em step adds
    its own: the drag acts at the chord's midpoint, a (1 - cos(pi / n)) lower, so the air
    there is exp(a (1 - cos(pi / n)) / H) denser (5.6e-4 at n = 1000 steps per orbit).
    Measured with that factor: 1 - 1.2e-5 at n = 1000 (3.7e-4 at n = 200, falling as 1/n^2);
    the tolerance is 1e-4."""
    n = 1000
    rate, a, _ = _decay_rate(_leo(T_LEO / n), n)
    rho = 3.7e-12 * np.exp(-(a - EARTH.radius - 400e3) / 58e3)
    theory = -B * rho * np.sqrt(EARTH.gm * a)
    chord = np.exp(a * (1 - np.cos(np.pi / n)) / 58e3)
    assert rate / theory == pytest.approx(1.0, abs=1e-3)
    assert rate / (theory * chord) == pytest.approx(1.0, abs=1e-4)


def test_the_co_rotating_air_slows_the_decay_and_tilts_the_orbit():
    """The air turns with the Earth: relative to it the satellite is slower by omega r cos i,
    so drag and the decay fall by about (1 - omega r cos i / v)^2 (0.875 on the equator,
    0.922 at i = 0.9 rad; measured at 400 steps per orbit 0.8752 and 0.9221), and the
    cross-track wind turns the orbit's plane: the inclination falls (measured 8e-7 rad in 20
    orbits at i = 0.9), where without rotation it keeps to round-off."""
    n = 400
    still, _, res0 = _decay_rate(_leo(T_LEO / n, inclination=0.9), n)
    for inc in (0.0, 0.9):
        turning, _, res = _decay_rate(_leo(T_LEO / n, rotation="7.292115e-5 rad/s", inclination=inc), n)
        expected = (1 - 7.292115e-5 * R_LEO * np.cos(inc) / V_LEO) ** 2
        assert turning / still == pytest.approx(expected, rel=2e-3)
    di = res.elements("sat").i.value
    di0 = res0.elements("sat").i.value
    assert di[-1] - di[0] < -5e-7
    assert np.max(np.abs(di0 - di0[0])) < 1e-13


def test_a_run_records_work_and_balance_with_units_and_resumes_bit_for_bit(tmp_path):
    (tmp_path / "scene.toml").write_text(SCENE)
    from emorbit.cli import main

    path = tmp_path / "run.h5"
    assert main(["run", str(tmp_path / "scene.toml"), "-o", str(path), "-q"]) == 0
    with h5py.File(path, "r") as f:
        names = set(f["invariants"])
        assert {"work_drag", "energy_balance", "potential_central"} <= names
        assert "potential_drag" not in names
        for q in ("work_drag", "energy_balance"):
            assert f[f"invariants/{q}"].attrs["unit"] == "J"
        assert f["checkpoint/point/work"].attrs["unit"] == "J"
        assert f["bodies/sat"].attrs["mass"] == 100.0
        unbroken = {
            k: f[k][()] for k in ("time", "invariants/energy", "invariants/work_drag", "invariants/energy_balance")
        }
        unbroken["bodies/sat/position"] = f["bodies/sat/position"][()]
    assert unbroken["invariants/work_drag"][-1] < 0
    half = tmp_path / "half.h5"
    sim = emorbit.load_scene(str(tmp_path / "scene.toml")).build()
    sim.run("2765 s", every=10, output=half, progress=False)
    emorbit.resume(half, "5530 s")
    with h5py.File(half, "r") as f:
        for k, a in unbroken.items():
            np.testing.assert_array_equal(f[k][()], a, err_msg=k)
    again = emorbit.parse_scene(sim.to_toml(), "again").build()  # the coefficient is written back
    assert again.points.values == {"sat": {"ballistic_coefficient": 0.02}}


def test_a_scene_without_drag_records_no_work(tmp_path):
    sim = emorbit.Simulation(EARTH, method="em", dt=60.0)
    sim.add_effect("zonal", model="earth", degree=2)
    sim.add_point("sat", mass=1.0, position=[R_LEO, 0, 0], velocity=[0, V_LEO, 0])
    sim.run(steps=20, output=tmp_path / "z.h5", progress=False)
    with h5py.File(tmp_path / "z.h5", "r") as f:
        assert not any(k.startswith("work_") or k == "energy_balance" for k in f["invariants"])
        assert "work" not in f["checkpoint/point"]
    assert sim.effects.packed_points() is not None  # the packed zonal kernel
    assert _leo(60.0, zonal=True).effects.packed_points() is None  # drag: the effect step


def test_ballistic_coefficient_zero_means_no_drag():
    sim = emorbit.Simulation(EARTH, method="em", dt=55.3)
    sim.add_effect("drag", **EXPONENTIAL)
    sim.add_point("sat", mass=1.0, ballistic_coefficient="0 m2/kg", position=[R_LEO, 0, 0], velocity=[0, V_LEO, 0])
    res = sim.run(steps=200, progress=False)
    assert abs(res.energy[-1] - res.energy[0]) <= 1e-13 * abs(res.energy[0])


def _scene(effect: str = "", body: str = 'ballistic_coefficient = "0.02 m2/kg"', field: str = 'body = "earth"'):
    text = SCENE.replace('body = "earth"', field, 1)
    text = text.replace('ballistic_coefficient = "0.02 m2/kg"', body)
    if effect:
        start = text.index("[[effect]]")
        end = text.index("[[body]]")
        text = text[:start] + effect + "\n\n" + text[end:]
    return text


@pytest.mark.parametrize(
    "effect, body, field, key",
    [
        ('[[effect]]\nkind = "drag"\natmosphere = "msis"', None, None, "effect[0].atmosphere"),
        (
            '[[effect]]\nkind = "drag"\natmosphere = "exponential"\ndensity = "-1 kg/m3"\n'
            'reference_altitude = "400 km"\nscale_height = "58 km"',
            None,
            None,
            "effect[0].density",
        ),
        (
            '[[effect]]\nkind = "drag"\natmosphere = "exponential"\ndensity = "1e-12 kg/m3"\n'
            'reference_altitude = "400 km"',
            None,
            None,
            "effect[0].scale_height",
        ),
        ('[[effect]]\nkind = "drag"\natmosphere = "ussa1976"\nscale_height = "58 km"', None, None,
         "effect[0].scale_height"),
        ('[[effect]]\nkind = "drag"\natmosphere = "ussa1976"\nrotation_rate = "-1 rad/s"', None, None,
         "effect[0].rotation_rate"),
        ('[[effect]]\nkind = "drag"\natmosphere = "ussa1976"\nwind = 3', None, None, "effect[0].wind"),
        (None, 'ballistic_coefficient = "-0.02 m2/kg"', None, "body[0].ballistic_coefficient"),
        (None, 'ballistic_coefficient = "0.02 m2"', None, "body[0].ballistic_coefficient"),
        (None, "", None, "body[0].ballistic_coefficient"),
        (None, None, 'gm = "3.986e14 m3/s2"', "effect[0]"),
    ],
)  # fmt: skip
def test_bad_drag_keys_name_the_key(effect, body, field, key):
    text = _scene(effect or "", *(() if body is None else (body,)))
    if field is not None:
        text = text.replace('body = "earth"', field, 1)
    with pytest.raises(InputError) as exc:
        emorbit.parse_scene(text, "test").build()
    assert exc.value.key == key


def test_drag_in_free_space_and_a_point_without_coefficient_are_refused():
    sim = emorbit.Simulation(None, method="em", dt=1.0)
    with pytest.raises(InputError, match="needs a central body"):
        sim.add_effect("drag", **EXPONENTIAL)
    sim = emorbit.Simulation(EARTH, method="em", dt=1.0)
    sim.add_point("sat", mass=1.0, position=[R_LEO, 0, 0], velocity=[0, V_LEO, 0])
    with pytest.raises(InputError) as exc:
        sim.add_effect("drag", **EXPONENTIAL)
    assert exc.value.key == "body['sat'].ballistic_coefficient"
    sim = emorbit.Simulation(EARTH, method="em", dt=1.0)
    sim.add_effect("drag", atmosphere="vallado")
    with pytest.raises(InputError, match="names 'drag' once"):
        sim.add_effect("drag", atmosphere="vallado")


def test_the_result_and_the_plot_carry_the_work_and_the_balance(tmp_path):
    """The kept records and the file read back give the same work and balance, with units;
    the balance stays at round-off while the energy falls; the plot draws it."""
    import matplotlib

    matplotlib.use("Agg")
    from emorbit.plot import plot_runs

    sim = _leo(T_LEO / 100, EXPONENTIAL)
    res = sim.run(steps=2000, every=100, output=tmp_path / "d.h5", progress=False)
    back = emorbit.read(tmp_path / "d.h5")
    assert set(res.work) == {"drag"} and res.work["drag"].unit == "J" and res.energy_balance.unit == "J"
    assert np.array_equal(res.si.work["drag"], back.si.work["drag"])
    assert np.array_equal(res.si.energy_balance, back.si.energy_balance)
    rel = back.relative_energy_balance()
    assert np.max(np.abs(rel)) <= 1e-13 and abs(back.relative_energy_error()[-1]) > 1e-7
    assert np.all(np.diff(res.si.work["drag"]) < 0)  # drag takes energy, record after record
    conservative = emorbit.Simulation(EARTH, dt=10.0)
    conservative.add_point("p", mass=1.0, position=[R_LEO, 0, 0], velocity=[0, V_LEO, 0])
    plain = conservative.run(steps=10, progress=False)
    assert plain.work == {} and plain.energy_balance is None and plain.relative_energy_balance() is None
    out = plot_runs([tmp_path / "d.h5"], tmp_path / "d.png")
    assert (tmp_path / "d.png").stat().st_size > 0 and out
