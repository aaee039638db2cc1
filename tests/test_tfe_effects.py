"""The time finite element ("tfe") for point masses under effects
(emorbit.kernels.pointmass.effect_tfe): observed orders under J2..J6 and under drag, the energy
balance at round-off over 1e5 large steps with zonal terms, the Moon, the Sun and radiation
pressure, the axial angular momentum under zonal terms, each effect's work against em's,
points that do not see each other, and what it refuses."""

import numpy as np
import pytest

import emorbit
from emorbit.errors import InputError
from emorbit.integrators import get_method

#: the time finite element: its coefficients (Gauss weights) name the order
TFE = get_method("tfe")

EPS = np.finfo(float).eps

EARTH = emorbit.CentralField(body="earth")
EPOCH = "2026-03-20T00:00:00 TDB"
R0 = EARTH.radius + 400e3  # the perigee
T0 = 2 * np.pi * float(np.sqrt(R0**3 / EARTH.gm))  # the period of the circular orbit at R0
MASS = 2000.0
ZONAL = [("zonal", dict(model="earth", degree=6))]
THIRD = [("third_body", dict(body="moon")), ("third_body", dict(body="sun"))]
SRP = [("srp", dict(shadow="conical"))]


def leo(method, order, dt, effects, e=0.3, points=("sat",), cr=(1.3 * 6 / MASS, 0.0)):
    """Points from a 400 km perigee, inclined 52 deg, eccentricity e (the second one, if any,
    with its perigee turned by 0.5 rad), with radiation coefficients ``cr``."""
    sim = emorbit.Simulation(EARTH, method=method, order=order, dt=dt, epoch=EPOCH)
    for kind, table in effects:
        sim.add_effect(kind, **table)
    v = float(np.sqrt(EARTH.gm * (1 + e) / R0))
    c, s = np.cos(0.9), np.sin(0.9)
    for j, name in enumerate(points):
        a = 0.5 * j
        sim.add_point(
            name, mass=MASS, radiation_coefficient=cr[j],
            position=[R0 * np.cos(a), R0 * np.sin(a), 0], velocity=[-v * c * np.sin(a), v * c * np.cos(a), v * s],
        )  # fmt: skip
    return sim


def end_position(sim, steps, name="sat"):
    res = sim.run(steps=steps, every=steps, progress=False)
    return res.positions[name][-1].value, res


@pytest.mark.parametrize("order", [4, 6])
def test_observed_order_under_zonal_terms(order):
    """Two orbits of e = 0.3 under J2..J6 at T0/50, T0/100, T0/200 against em order 8 at
    T0/1600: the fitted order within 0.3 of 4 and 6 (measured 3.99 and 6.00)."""
    n = 2 * int(0.7**-1.5 * 100)  # about two orbits of the e = 0.3 ellipse in units of T0/100
    ref, _ = end_position(leo("em", 8, T0 / 1600, ZONAL), 16 * n)
    errors = []
    for f in (1, 2, 4):
        x, _ = end_position(leo("tfe", order, T0 / (50 * f), ZONAL), n * f // 2)
        errors.append(np.linalg.norm(x - ref))
    slope = -np.polyfit(np.log([1, 2, 4]), np.log(errors), 1)[0]
    assert abs(slope - order) < 0.3, f"fitted order {slope:.2f}; errors {errors} m"


@pytest.mark.parametrize("order", [4, 6])
def test_energy_balance_over_1e5_large_steps(order):
    """1e5 steps of T0/50 (about 1200 orbits of e = 0.3) under J2..J6, the Moon, the Sun and
    radiation pressure with the Earth's conical shadow: |E - E0 - W| / |E0| within 5e-14
    (measured 8.1e-15 and 2.0e-14 at orders 4 and 6), while each effect's work reaches
    5.8e-8 (the Sun) to 1.7e-6 (radiation pressure) of |E0|."""
    sim = leo("tfe", order, T0 / 50, ZONAL + THIRD + SRP)
    res = sim.run(steps=100_000, every=1000, progress=False)
    e0 = abs(res.energy[0].value)
    balance = np.abs(res.relative_energy_balance()).max()
    assert balance <= 5e-14, f"the balance reached {balance:.2e} of |E0|"
    work = {k: np.abs(w.value).max() / e0 for k, w in res.work.items()}
    assert min(work.values()) > 1e3 * balance, work


def test_axial_angular_momentum_under_zonal_terms():
    """Under J2..J6 the angular momentum about the pole is kept: 1e4 steps of T0/50 at order 4
    keep L_z within 5e-15 of |L| (measured 9.2e-16) and the energy within 2e-14 (1.5e-15),
    while L_x, L_y turn with the node (by 0.3 of |L|)."""
    res = leo("tfe", 4, T0 / 50, ZONAL).run(steps=10_000, every=100, progress=False)
    L = res.angular_momentum.value
    norm = np.linalg.norm(L[0])
    assert np.abs(L[:, 2] - L[0, 2]).max() <= 5e-15 * norm
    assert np.abs(L[:, :2] - L[0, :2]).max() > 0.1 * norm
    assert np.abs(res.relative_energy_error()).max() <= 2e-14


def test_work_of_each_effect_agrees_with_em():
    """Each working effect's work over one orbit, tfe order 6 at T0/100 against em order 8 at
    T0/800, radiation pressure without shadow (a shadow's edge within a step limits both to
    low order): radiation pressure's and the third bodies' rows agree to 1e-7 of their size
    (measured 2.6e-9, the Moon 3.1e-11, the Sun 6.5e-9): the rows are each effect's own, not
    a share of a sum, and a potential's change in time is summed to the method's order."""
    sunlit = [("srp", dict(shadow="none"))]
    steps = int(0.7**-1.5 * 100)
    _, a = end_position(leo("tfe", 6, T0 / 100, THIRD + sunlit), steps)
    _, b = end_position(leo("em", 8, T0 / 800, THIRD + sunlit), 8 * steps)
    assert set(a.work) == set(b.work) and len(a.work) == 3
    for k in a.work:
        wa, wb = a.work[k][-1].value, b.work[k][-1].value
        assert abs(wa - wb) <= 1e-7 * abs(wb) and abs(wb) > 0, (k, wa, wb)


def test_points_do_not_see_each_other():
    """Two points, radiation pressure on one of them: the other's steps are bit for bit those
    it takes alone, and the first's are those it takes alone under radiation pressure."""
    both = leo("tfe", 6, T0 / 60, ZONAL + SRP, points=("sat", "other"))
    res = both.run(steps=500, every=500, progress=False)
    alone, _ = end_position(leo("tfe", 6, T0 / 60, ZONAL + SRP), 500)
    assert np.array_equal(res.positions["sat"][-1].value, alone)
    other = leo("tfe", 6, T0 / 60, ZONAL, points=("sat", "other"))
    x, _ = end_position(other, 500, "other")
    assert np.array_equal(res.positions["other"][-1].value, x)


def test_refuses_what_it_cannot_step():
    """Forces that act between pairs (mutual gravity): an InputError naming the key, the
    effect and the reason (effects on rigid and elastic bodies' surfaces:
    tests/test_tfe_rigid_effects.py, tests/test_tfe_structure_effects.py)."""
    sim = emorbit.Simulation(EARTH, method="tfe", order=4, dt=10.0, epoch=EPOCH)
    with pytest.raises(InputError) as info:
        sim.add_effect("mutual")
    assert info.value.key == "method" and "mutual" in str(info.value) and "pairs" in str(info.value)


#: an exponential atmosphere and a light, large point: drag near 1e-5 of gravity at perigee
DRAG = [("drag", dict(atmosphere="exponential", density="3.7e-12 kg/m3", reference_altitude="400 km",
                      scale_height="58 km"))]  # fmt: skip


def dragged(method, order, dt, adaptive=None):
    """A point of ballistic coefficient 0.5 m^2/kg from a 400 km perigee, e = 0.1, under J2,
    the Moon (its force at the stages' midpoints, beside drag's over their segments) and drag."""
    sim = emorbit.Simulation(EARTH, method=method, order=order, dt=dt, epoch=EPOCH, adaptive=adaptive)
    for kind, table in [("zonal", dict(model="earth", degree=2))] + THIRD[:1] + DRAG:
        sim.add_effect(kind, **table)
    v = float(np.sqrt(EARTH.gm * 1.1 / R0))
    sim.add_point("sat", mass=10.0, ballistic_coefficient=0.5, position=[R0, 0, 0], velocity=[0, 0.8 * v, 0.6 * v])
    return sim


@pytest.mark.parametrize("order", [4, 6])
def test_drag_at_the_stages(order):
    """Drag reads each stage's velocity (the stage is the midpoint of a segment over which that
    is the mean velocity): one orbit of e = 0.1 under J2, the Moon and drag at T0/40, T0/80, T0/160
    against em order 8 at T0/1280, the fitted order within 0.3 of 4 and 6 (measured 3.93 and
    5.99; drag moves the point by 424 m, and a stage force of second order in h would hold
    order 6 near 2); E - E0 - W within 1e-14 of |E0| (measured 3.3e-16), W drag's work, which
    agrees with em's to 1e-5 (order 4) and 1e-9 (order 6) of itself at T0/160 (measured 9.8e-7
    and 2.4e-11)."""
    n = int(40 / 0.9**1.5)  # about one orbit (a = R0 / 0.9) in steps of T0/40
    ref, em = end_position(dragged("em", 8, T0 / 1280), 32 * n)
    errors, balance = [], []
    for f in (1, 2, 4):
        x, res = end_position(dragged("tfe", order, T0 / (40 * f)), n * f)
        errors.append(np.linalg.norm(x - ref))
        balance.append(float(np.abs(res.relative_energy_balance()).max()))
    slope = -np.polyfit(np.log([1, 2, 4]), np.log(errors), 1)[0]
    assert abs(slope - order) < 0.3, f"fitted order {slope:.2f}; errors {errors} m"
    assert max(balance) <= 1e-14, balance
    w, w_em = res.work["drag"][-1].value, em.work["drag"][-1].value
    assert abs(w - w_em) <= (1e-5 if order == 4 else 1e-9) * abs(w_em) and w_em < 0, (w, w_em)


def test_drag_with_adaptive_steps_keeps_the_balance():
    """Adaptive tfe steps (eta 0.02) over one orbit under J2, the Moon and drag: E - E0 - W
    within 1e-14 of |E0| at every record (measured 4.5e-16), while drag takes 1.4 kJ."""
    res = dragged("tfe", 6, T0 / 20, adaptive=0.02).run(steps=20, every=1, progress=False)
    assert np.abs(res.relative_energy_balance()).max() <= 1e-14
    assert res.work["drag"][-1].value < -1e3


EXPLICIT_KEYS = {
    "zonal": {"model": "earth"},
    "gravity_field": {"model": "egm2008", "degree": 8, "rotation": "earth"},
    "srp": {"shadow": "conical"},
    "third_body": {"body": "moon"},
}


@pytest.mark.parametrize("kind", sorted(EXPLICIT_KEYS))
def test_each_explicit_effect_with_fixed_and_adaptive_steps(kind):
    """Each shipped effect whose force is a function of position and time, on a point from
    LEO, 100 fixed steps of 20 s and 10 adaptive intervals (eta 0.05), orders 4 and 6: the
    energy, or the balance E - E0 - W, within 1e-13 of |E0| (measured at most 5.8e-16, the
    Moon)."""
    worst = 0.0
    for order in (4, 6):
        for adaptive, steps in ((None, 100), (0.05, 10)):
            sim = emorbit.Simulation(EARTH, method="tfe", order=order, dt=20.0, adaptive=adaptive, epoch=EPOCH)
            sim.add_effect(kind, **EXPLICIT_KEYS[kind])
            sim.add_point("a", mass=100.0, position=[R0, 0, 0], velocity=[0, 7750.0, 300.0], radiation_coefficient=0.02)
            res = sim.run(steps=steps, every=steps // 2, progress=False)
            b = res.relative_energy_balance()
            worst = max(worst, float(np.abs(b if b is not None else res.relative_energy_error()).max()))
    assert worst <= 1e-13, worst


@pytest.mark.parametrize("order", [4, 6])
def test_adaptive_steps_under_j2_and_the_moon_run_back_to_the_start(order):
    """100 adaptive tfe steps (eta 0.02; one step of 2 or 3 Gauss stages is the composed step)
    on an orbit of e = 0.9 under J2..J6 and the Moon, velocities reversed, 100 steps back with
    the clock running backwards: back at the start within 1e3 eps n (measured 2.2 and 0.9 eps n
    for position and velocity at order 4, 3.5 and 1.4 at order 6)."""
    sim = emorbit.Simulation(EARTH, method="tfe", order=order, dt=600.0, adaptive=0.02, epoch=EPOCH)
    sim.add_effect("zonal", model="earth")
    sim.add_effect("third_body", body="moon")
    sim.add_point("sat", mass=1.0, orbit={"periapsis_altitude": "500 km", "e": 0.9, "i": "30 deg"})
    sim.run(steps=1, progress=False)  # samples the Moon's path
    pm, n = sim.points, 100
    sim._prepare_effects(2000, TFE.coefficients(order))
    x0, v0 = pm.x.copy(), pm.v.copy()
    t1 = pm.reversible_steps("tfe", TFE.coefficients(order), n, 50, t0=sim.time)
    pm.v[...] *= -1
    pm.cv[...] *= -1
    t2 = pm.reversible_steps("tfe", TFE.coefficients(order), n, 50, t0=sim.time + t1, direction=-1.0)
    dx = np.abs(pm.x - x0).max() / np.abs(x0).max() / (EPS * n)
    dv = np.abs(pm.v + v0).max() / np.abs(v0).max() / (EPS * n)
    assert dx <= 1e3 and dv <= 1e3, (dx, dv)
    assert abs(t1 - t2) <= 1e3 * EPS * n * t1


@pytest.mark.parametrize("order", [4, 6])
def test_adaptive_steps_converge_and_keep_the_balance(order):
    """Adaptive tfe on the e = 0.9 orbit under J2..J6 and the Moon over 400 intervals of 600 s
    (about 1.3 orbits): the balance within 1e-14 of |E0| at every eta (measured at most
    5.5e-15), and the end position converging as eta halves (against eta = 0.005, at eta =
    0.04, 0.02, 0.01: 5.0e4, 1.5e3, 32 m at order 4; 45, 1.1, 0.083 m at order 6)."""
    ends = []
    for eta in (0.04, 0.02, 0.01, 0.005):
        sim = emorbit.Simulation(EARTH, method="tfe", order=order, dt=600.0, adaptive=eta, epoch=EPOCH)
        sim.add_effect("zonal", model="earth")
        sim.add_effect("third_body", body="moon")
        sim.add_point("sat", mass=1.0, orbit={"periapsis_altitude": "500 km", "e": 0.9, "i": "30 deg"})
        res = sim.run(steps=400, every=100, progress=False)
        assert np.abs(res.relative_energy_balance()).max() <= 1e-14
        ends.append(res.positions["sat"][-1].value)
    errors = [np.linalg.norm(e - ends[-1]) for e in ends[:-1]]
    assert errors[0] > errors[1] > errors[2], errors
