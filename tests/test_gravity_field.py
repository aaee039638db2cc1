"""A rotating body's gravity field (emorbit.effects.gravity_field,
emorbit.kernels.effects.gravity_field, emorbit.io.icgem): the acceleration against heyoka's
EGM2008 model, the zonal effect's acceleration from the same coefficients, the discrete
force's identity (its product with the rotating frame's move is the potential change), the
Jacobi integral of point masses and the energy balance of a rigid body in the field, an ICGEM
file read as the shipped model, and the errors naming their keys.

Round-off scales. The harmonics' potential at LEO is about 1e-3 of the central term
(6e7 m^2/s^2), so ``dU`` carries ~eps 6e4 m^2/s^2 and the identity ``F . delta = dU`` is measured
against ``|U0| + |U1|``. The Jacobi integral ``E - w . L`` is dominated by ``E``; its drift is
measured relative to ``|C|``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import emorbit
from emorbit.errors import InputError
from emorbit.io.icgem import model, read_gfc
from emorbit.kernels.effects.gravity_field import (
    field_body,
    gravity_field_force,
    gravity_field_prepare,
    gravity_field_time_work,
    tables,
)
from emorbit.kernels.effects.zonal import zonal_force

hy = pytest.importorskip("heyoka", reason='EGM2008 comes from heyoka: pip install "emorbit[field]"')

EPS = 2.0**-52
EGM = model("egm2008", 120)
MU, RADIUS = EGM.gm, EGM.radius
W_EARTH = 7.292115146706979e-5
EARTH = emorbit.CentralField(gm=MU, radius=RADIUS)


def _points(n, seed=1, low=200e3, high=40000e3):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    r = RADIUS + rng.uniform(low, high, n)
    return v / np.linalg.norm(v, axis=1)[:, None] * r[:, None]


@pytest.mark.parametrize("degree", [2, 20, 70, 120])
def test_acceleration_matches_heyokas_egm2008(degree):
    """1000 points from 200 to 40 000 km altitude: our harmonics plus the central term against
    heyoka's egm2008_acc (the same coefficients, an independent evaluation) to 1e-13 relative
    (measured 8.5e-16, 9.2e-16, 1.2e-15 and 1.1e-15; degree 120 compiles in heyoka's compact
    mode, about 30 s)."""
    x, y, z = hy.make_vars("x", "y", "z")
    ref = hy.cfunc(hy.model.egm2008_acc([x, y, z], degree, degree), [x, y, z], compact_mode=degree > 70)
    tab = tables(EGM.C, EGM.S, degree, degree)
    worst = 0.0
    for v in _points(1000):
        _, gx, gy, gz = field_body(v[0], v[1], v[2], MU, RADIUS, degree, degree, tab, True, np.empty(2 * degree + 4))
        ours = np.array([gx, gy, gz]) - MU * v / np.linalg.norm(v) ** 3
        theirs = ref(v)
        worst = max(worst, np.linalg.norm(ours - theirs) / np.linalg.norm(theirs))
    assert worst <= 1e-13


def test_potential_matches_heyokas_egm2008():
    """The potential of degree and order 20 against heyoka's egm2008_pot (central term added) to
    1e-14 relative."""
    x, y, z = hy.make_vars("x", "y", "z")
    ref = hy.cfunc([hy.model.egm2008_pot([x, y, z], 20, 20)], [x, y, z])
    tab = tables(EGM.C, EGM.S, 20, 20)
    for v in _points(200, seed=2):
        ours = field_body(v[0], v[1], v[2], MU, RADIUS, 20, 20, tab, False, np.empty(44))[0] + MU / np.linalg.norm(v)
        assert abs(ours - ref(v)[0]) <= 1e-14 * abs(ours)


def test_high_degree_is_regular_at_the_poles():
    """Degree and order 120 at both poles and 1 mm beside them: finite, within 5e-3 of the
    central term (J2 gives 3e-3 there), and continuous across the pole to 1e-9 of itself (the
    recursion does not divide by the latitude's cosine)."""
    tab = tables(EGM.C, EGM.S, 120, 120)
    r = RADIUS + 300e3
    for z in (r, -r):
        at = np.array(field_body(0.0, 0.0, z, MU, RADIUS, 120, 120, tab, True, np.empty(244)))
        assert np.all(np.isfinite(at))
        assert np.linalg.norm(at[1:]) <= 5e-3 * MU / r**2
        for dx, dy in ((1e-3, 0.0), (0.0, -1e-3), (-7e-4, 7e-4)):
            near = np.array(field_body(dx, dy, z, MU, RADIUS, 120, 120, tab, True, np.empty(244)))
            assert np.linalg.norm(near[1:] - at[1:]) <= 1e-9 * np.linalg.norm(at[1:])


def test_zonal_terms_give_the_zonal_effects_acceleration():
    """order = 0 to degree 6: the acceleration at a point equals the zonal effect's with
    J_n = -C_n0 sqrt(2n + 1), to 1e-14 of it."""
    tab = tables(EGM.C, EGM.S, 6, 0)
    jn = np.array([-EGM.C[n, 0] * math.sqrt(2 * n + 1) for n in range(2, 7)])
    for v in _points(300, seed=4):
        _, gx, gy, gz = field_body(*v, MU, RADIUS, 6, 0, tab, True, np.empty(16))
        ref = np.array(zonal_force(*v, *v, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, MU, RADIUS, jn))
        assert np.linalg.norm(np.array([gx, gy, gz]) - ref) <= 1e-14 * np.linalg.norm(ref)


def _p(degree, rate=W_EARTH, angle=0.4, pole=(0.0, 0.0, 1.0)):
    sim = emorbit.Simulation(EARTH, dt=1.0)
    effect = sim.add_effect(
        "gravity_field", model="egm2008", degree=degree, rotation="uniform", rate=rate, angle=angle, pole=list(pole)
    )
    return effect


def test_force_times_the_rotating_move_is_the_potential_change():
    """Random steps of LEO points (60 s, a tilted pole): F . delta = U(x1, t1) - U(x0, t0) to
    8 eps of |U0| + |U1| (measured within 2 eps), and the time work is F . dx - dU."""
    effect = _p(20, pole=(0.1, -0.2, 1.0))
    p, tab = effect.p, effect.tab
    rng = np.random.default_rng(7)
    s = np.zeros(effect.scratch_size(1))
    for a in _points(200, seed=5, low=200e3, high=2000e3):
        v = rng.normal(size=3)
        v *= 7.5e3 / np.linalg.norm(v)
        h = 60.0
        b = a + h * v + rng.normal(size=3) * 100.0
        ta = rng.uniform(0, 1e5)
        gravity_field_prepare(ta, ta + 0.5 * h, ta + h, p, tab, s)
        f0, f1, f2, du = gravity_field_force(*a, *b, p, tab, s)
        m = 0.5 * (a + b)
        delta = (b - a) - 2.0 * math.tan(0.5 * effect.rate * h) * np.cross(effect.frame[:, 2], m)
        u0 = -effect_potential(effect, a, ta)
        u1 = -effect_potential(effect, b, ta + h)
        assert abs(du - (u1 - u0)) <= 4 * EPS * (abs(u0) + abs(u1))
        assert abs(np.dot([f0, f1, f2], delta) - du) <= 8 * EPS * (abs(u0) + abs(u1))
        work = gravity_field_time_work(*a, *b, 0.0, p, tab, s)
        assert work == pytest.approx(np.dot([f0, f1, f2], b - a) - du, rel=1e-12, abs=1e-9)


def effect_potential(effect, x, t):
    """The effect's potential energy per unit mass at x and time t (the record's path)."""
    return float(effect.potential_energy(np.asarray(x, float)[None, :, None], np.ones(1), np.array([t]))[0])


def test_force_at_a_point_is_the_gradient():
    """x0 = x1: the field's acceleration at the middle time, rotated into the scene's axes."""
    effect = _p(8, angle=1.1)
    s = np.zeros(effect.scratch_size(1))
    gravity_field_prepare(100.0, 150.0, 200.0, effect.p, effect.tab, s)
    x = _points(1, seed=9)[0]
    f = np.array(gravity_field_force(*x, *x, effect.p, effect.tab, s)[:3])
    th = 1.1 + W_EARTH * 150.0
    c, sn = math.cos(th), math.sin(th)
    rz = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
    y = rz.T @ x
    g = np.array(field_body(*y, MU, RADIUS, 8, 8, effect.tab, True, np.empty(20))[1:])
    np.testing.assert_allclose(f, rz @ g, rtol=1e-14)


def _leo(degree, dt, **keys):
    from emorbit import orbits

    sim = emorbit.Simulation(EARTH, dt=dt, **keys)
    sim.add_effect("gravity_field", model="egm2008", degree=degree, rotation="uniform", rate=W_EARTH, angle=0.3)
    x, v = orbits.state_from_elements((RADIUS + 400e3, 0.001, math.radians(51.6), 0.2, 0.1, 0.0), MU)
    sim.add_point("sat", mass=1.0, position=x, velocity=v)
    return sim


def _jacobi(res, h=None):
    """E - w . L, w the spin (None) or the Cayley rate of steps of h, (2 / h) tan(w h / 2)."""
    rate = W_EARTH if h is None else 2.0 / h * math.tan(0.5 * W_EARTH * h)
    return res.si.energy - res.si.angular_momentum @ np.array([0.0, 0.0, rate])


def test_leo_keeps_the_jacobi_integral_at_degree_20():
    """1e5 em steps of 90 s (T/62) at degree and order 20: the step's Jacobi integral E - w_h . L
    within 1e-13 of itself (measured 5.2e-15) while the energy changes by 1e-5 (the field turns
    under the orbit); E - w . L with the true spin within 1e-10 (measured 2.5e-11: w_h is
    3.6e-6 above w and L_z moves by 1.3e-4); the energy balance E - E0 - W within 1e-13."""
    res = _leo(20, 90.0).run(steps=100_000, every=100, progress=False)
    c = _jacobi(res, 90.0)
    e = res.si.energy
    assert np.ptp(e) >= 1e-6 * abs(e[0])
    assert np.abs(c - c[0]).max() <= 1e-13 * abs(c[0])
    true = _jacobi(res)
    assert np.abs(true - true[0]).max() <= 1e-10 * abs(true[0])
    assert np.abs(res.si.relative_energy_balance()).max() <= 1e-13


def test_leo_keeps_the_jacobi_integral_at_degree_70():
    """1e5 em steps of 90 s at degree and order 70: the step's Jacobi integral within 1e-13."""
    res = _leo(70, 90.0).run(steps=100_000, every=100, progress=False)
    c = _jacobi(res, 90.0)
    assert np.abs(c - c[0]).max() <= 1e-13 * abs(c[0])


def test_a_gfc_file_reads_as_the_shipped_model(tmp_path):
    """EGM2008 to degree 12 written in ICGEM's format (Fortran exponents) and read back: the
    same coefficients bit for bit; a file that ends early, a time-variable line and a missing
    header each name the key."""
    path = tmp_path / "egm.gfc"
    lines = [
        "product_type gravity_field", "modelname EGM2008-12", f"earth_gravity_constant {float(MU)!r}",
        f"radius {float(RADIUS)!r}", "max_degree 12", "norm fully_normalized", "tide_system tide_free",
        "key n m C S sigmaC sigmaS", "end_of_head",
    ]  # fmt: skip
    lines.append("gfc 0 0 1.0D+00 0.0D+00 0 0")
    for n in range(2, 13):
        for m in range(n + 1):
            lines.append(f"gfc {n} {m} {float(EGM.C[n, m])!r} {float(EGM.S[n, m])!r} 0 0".replace("e", "D"))
    path.write_text("\n".join(lines) + "\n")
    got = read_gfc(str(path), 12)
    assert got.gm == MU and got.radius == RADIUS and got.tide_system == "tide_free"
    assert np.array_equal(got.C[2:, :], EGM.C[2:13, :13]) and np.array_equal(got.S, EGM.S[:13, :13])
    with pytest.raises(InputError, match="reaches degree 12"):
        read_gfc(str(path), 13, "effect[0].gfc")
    bad = tmp_path / "bad.gfc"
    bad.write_text("\n".join(lines[:9] + ["gfct 2 0 1 0 0 0 20000101"]) + "\n")
    with pytest.raises(InputError, match="time-variable"):
        read_gfc(str(bad), 2)
    bad.write_text("radius 1\nend_of_head\n")
    with pytest.raises(InputError, match="earth_gravity_constant"):
        read_gfc(str(bad), 2)


@pytest.mark.parametrize(
    "keys, where, what",
    [
        ({"degree": 20}, "rotation", "turns with its body"),
        ({"degree": 0, "rotation": "earth"}, "degree", "from 1 to"),
        ({"degree": 200, "rotation": "earth"}, "model", "reaches degree 150"),
        ({"degree": 4, "order": 5, "rotation": "earth"}, "order", "0 to the degree"),
        ({"degree": 4, "rotation": "uniform"}, "rate", "spin rate"),
        ({"degree": 4, "rotation": "earth", "rate": 1e-4}, "rate", "sets the rate"),
        ({"degree": 4, "rotation": "uniform", "rate": 1e-4, "pole": [0, 0, 0]}, "pole", "other than 0"),
    ],
)
def test_errors_name_the_key(keys, where, what):
    sim = emorbit.Simulation(EARTH, dt=1.0)
    with pytest.raises(InputError, match=what) as err:
        sim.add_effect("gravity_field", model="egm2008", **keys)
    assert where in str(err.value)


def test_earth_rotation_needs_an_epoch():
    """rotation = "earth" without the run's epoch is refused, naming the epoch; with one, the
    prime meridian starts at the Earth rotation angle of the epoch."""
    sim = emorbit.Simulation(EARTH, dt=10.0)
    with pytest.raises(InputError, match="epoch"):
        sim.add_effect("gravity_field", model="egm2008", degree=4, rotation="earth")
    from astropy.time import Time

    epoch = "2026-03-20T12:00:00 TDB"
    sim = emorbit.Simulation(EARTH, dt=10.0, epoch=epoch)
    effect = sim.add_effect("gravity_field", model="egm2008", degree=4, rotation="earth")
    effect.prepare(0.0, 10.0, Time("2026-03-20T12:00:00", scale="tdb"))
    era = Time("2026-03-20T12:00:00", scale="tdb").earth_rotation_angle(0.0).rad
    assert effect.p[12] == pytest.approx(era, abs=1e-9)  # erfa.era00 of UT1; astropy adds the TIO locator, 6e-11
    assert effect.rate == pytest.approx(7.292115146706979e-5, rel=1e-15)


def _body_in_field(kind):
    sim = emorbit.Simulation(EARTH, dt=20.0)
    sim.add_effect("gravity_field", model="egm2008", degree=20, rotation="uniform", rate=W_EARTH, angle=0.3)
    r = RADIUS + 400e3
    v = math.sqrt(MU / r)
    place = {"position": [r, 0.0, 0.0], "velocity": [0.0, v * 0.8, v * 0.6]}
    if kind == "rigid":
        sim.add_rigid("box", "box", size=[4.0, 2.0, 1.0], mass=500.0, angular_velocity=[0.01, 0.002, 0.02], **place)
    else:
        sim.add_elastic(
            "chain", "chain", start=[-50.0, 0, 0], end=[50.0, 0, 0], elements=4, young=1e9, area=1e-4,
            density=1000.0, **place,
        )  # fmt: skip
    return sim


@pytest.mark.parametrize(
    "kind, steps", [("rigid", 100_000), ("elastic", 20_000), pytest.param("elastic", 100_000, marks=pytest.mark.long)]
)
def test_rigid_and_elastic_bodies_keep_the_energy_balance(kind, steps):
    """A rigid box (1e5 em steps of 20 s, 23 days) and an elastic chain of four bars (2e4
    steps; 1e5 with ``-m long``, about 3 min) in the turning 20 x 20 field: E - E0 - W within
    2e-14 of E0 (measured 9.9e-16, 7.8e-16 and, at 1e5 steps, 1.4e-15), while W itself reaches
    5e-6 of it."""
    res = _body_in_field(kind).run(steps=steps, every=steps // 20, progress=False)
    balance = res.si.relative_energy_balance()
    work = sum(res.si.work.values())
    assert np.abs(work).max() >= 1e-7 * abs(res.si.energy[0])
    assert np.abs(balance).max() <= 2e-14


def _one_orbit(order, steps, adaptive=None):
    """One orbit (e = 0.01, 400 km, 51.6 deg) in the turning 8 x 8 field: the final position."""
    from emorbit import orbits

    a = RADIUS + 400e3
    period = 2 * math.pi * math.sqrt(a**3 / MU)
    sim = emorbit.Simulation(EARTH, dt=period / steps, method="em", order=order, adaptive=adaptive)
    sim.add_effect("gravity_field", model="egm2008", degree=8, rotation="uniform", rate=W_EARTH, angle=0.3)
    x, v = orbits.state_from_elements((a, 0.01, math.radians(51.6), 0.2, 0.1, 0.0), MU)
    sim.add_point("sat", mass=1.0, position=x, velocity=v)
    res = sim.run(f"{period} s", progress=False)
    return res.si.positions["sat"][-1], res


@pytest.fixture(scope="module")
def reference_orbit():
    return _one_orbit(8, 800)[0]


@pytest.mark.parametrize("order, coarse", [(2, 100), (4, 50), (6, 30), (8, 24)])
def test_orders_hold_with_the_field_on(order, coarse, reference_orbit):
    """The final position error over one orbit at N and 2N steps against order 8 at 800:
    the observed order within 0.5 of 2, 4, 6, 8 (measured 2.00, 3.99, 5.99, 8.01)."""
    errors = [np.linalg.norm(_one_orbit(order, n)[0] - reference_orbit) for n in (coarse, 2 * coarse)]
    assert abs(math.log2(errors[0] / errors[1]) - order) <= 0.5


def test_adaptive_steps_with_the_field_on(reference_orbit):
    """Adaptive em (order 2, record interval T/20) with the field: halving eta divides the error
    by four, and each run keeps the energy balance E - E0 - W within 1e-13."""
    errors = []
    for eta in (0.004, 0.002):
        end, res = _one_orbit(2, 20, adaptive=eta)
        errors.append(np.linalg.norm(end - reference_orbit))
        assert np.abs(res.si.relative_energy_balance()).max() <= 1e-13
    assert 3.0 <= errors[0] / errors[1] <= 5.0


def _geo(lon_deg, dt, order=4):
    """A satellite at rest over longitude lon_deg in the turning 2 x 2 field (C20, C22, S22), on
    the synchronous radius that J2 shifts: W^2 a = mu / a^2 (1 + 3/2 J2 (R / a)^2)."""
    j2 = -EGM.C[2, 0] * math.sqrt(5)
    a = (MU / W_EARTH**2) ** (1 / 3)
    for _ in range(50):
        a = (MU * (1 + 1.5 * j2 * (RADIUS / a) ** 2) / W_EARTH**2) ** (1 / 3)
    lam = math.radians(lon_deg)
    sim = emorbit.Simulation(EARTH, dt=dt, method="em", order=order)
    sim.add_effect("gravity_field", model="egm2008", degree=2, order=2, rotation="uniform", rate=W_EARTH, angle=0.0)
    x = a * np.array([math.cos(lam), math.sin(lam), 0.0])
    v = W_EARTH * a * np.array([-math.sin(lam), math.cos(lam), 0.0])
    sim.add_point("geo", mass=1.0, position=x, velocity=v)
    return sim, a


def _longitude(res):
    """The satellite's longitude in the turning frame, unwrapped, rad."""
    t, p = res.si.time, res.si.positions["geo"]
    return t, np.unwrap(np.arctan2(p[:, 1], p[:, 0]) - W_EARTH * t)


def _pendulum(a):
    """The two-term theory: lam'' = K sin 2 (lam - lam22), K = 18 n^2 (R / a)^2 J22, J22 and
    lam22 from the unnormalised C22, S22 (normalisation sqrt(5 / 12))."""
    j22 = math.sqrt(5 / 12) * math.hypot(EGM.C[2, 2], EGM.S[2, 2])
    lam22 = 0.5 * math.atan2(EGM.S[2, 2], EGM.C[2, 2])
    return 18 * W_EARTH**2 * (RADIUS / a) ** 2 * j22, lam22


def test_a_geostationary_satellite_drifts_towards_75_east():
    """Started at rest over 45 E: over 30 days (em order 4, 300 s) the longitude's acceleration,
    a quadratic fitted to it, is the two-term theory's fitted the same way within 3e-4
    (measured 9.4e-5; the theory leaves out J2's change of the drift rate, 2.5e-5, and the
    step's own error is 6e-4 at 600 s). Over 1000 days (1800 s steps) it librates about the
    stable point 75.07 E (lam22 + 90 deg) up to the theory's turning point 105.14 E, within 0.1
    deg (measured 105.16)."""
    from scipy.integrate import solve_ivp

    sim, a = _geo(45.0, 300.0)
    t, lam = _longitude(sim.run("30 d", every=6, progress=False))
    k, lam22 = _pendulum(a)
    sol = solve_ivp(
        lambda s, y: [y[1], k * math.sin(2 * (y[0] - lam22))], (0, t[-1]), [lam[0], 0.0], t_eval=t, rtol=1e-12,
        atol=1e-15,
    )  # fmt: skip
    fitted, theory = 2 * np.polyfit(t, lam, 2)[0], 2 * np.polyfit(t, sol.y[0], 2)[0]
    assert theory > 0 and abs(fitted / theory - 1) <= 3e-4
    sim, a = _geo(45.0, 1800.0)
    t, lam = _longitude(sim.run("1000 d", every=48, progress=False))
    stable = math.degrees(lam22) + 90.0
    turning = 2 * stable - 45.0
    assert abs(stable - 75.07) <= 0.01
    assert abs(math.degrees(lam.max()) - turning) <= 0.1


def test_the_plot_draws_longitude_and_ground_track(tmp_path):
    """A run in the turning field records its body frame; ground_track gives the longitude of a
    satellite at rest over 45 E as the turning frame's (within 0.01 deg of 45 over 2 days; it
    drifts 0.0025 deg) on the equator, and the figure gains the longitude and ground-track
    panels."""
    import matplotlib.pyplot as plt

    from emorbit.plot import body_frame, draw_runs, ground_track

    sim, _ = _geo(45.0, 600.0)
    res = sim.run("2 d", every=6, output=str(tmp_path / "geo.h5"), progress=False)
    stored = emorbit.read(str(tmp_path / "geo.h5")).si
    frame = body_frame(stored)
    assert frame is not None and frame["rate"] == W_EARTH
    lon, lat = ground_track(res.si.positions["geo"], res.si.center, res.si.time, frame)
    assert np.abs(lon - np.degrees(_longitude(res)[1])).max() <= 1e-9
    assert np.abs(lon - 45.0).max() <= 0.01 and np.abs(lat).max() <= 1e-6
    fig = draw_runs([("geo", stored)])
    titles = {ax.get_title() for ax in fig.axes}
    plt.close(fig)
    assert {"longitude over the turning body", "ground track"} <= titles


def test_the_run_file_records_the_jacobi_integral(tmp_path):
    """invariants/jacobi holds E - w . L of every record (J), and a run without a turning field
    writes none."""
    import h5py

    sim = _leo(8, 90.0)
    sim.run(steps=200, every=20, output=str(tmp_path / "leo.h5"), progress=False)
    with h5py.File(tmp_path / "leo.h5", "r") as f:
        jacobi = f["invariants/jacobi"][()]
        e, L = f["invariants/energy"][()], f["invariants/angular_momentum"][()]
        assert f["invariants/jacobi"].attrs["unit"] == "J"
    np.testing.assert_array_equal(jacobi, e - L @ np.array([0.0, 0.0, W_EARTH]))
    # the true spin's C moves by (w_h - w) . dL (measured 1.5e-11 over these 200 steps); the
    # step's own, E - w_h . L, stays at round-off
    assert np.abs(jacobi - jacobi[0]).max() <= 1e-10 * abs(jacobi[0])
    own = e - L @ np.array([0.0, 0.0, 2.0 / 90.0 * math.tan(0.5 * W_EARTH * 90.0)])
    assert np.abs(own - own[0]).max() <= 1e-14 * abs(own[0])
    plain = emorbit.Simulation(EARTH, dt=90.0)
    plain.add_point("sat", mass=1.0, position=[RADIUS + 400e3, 0, 0], velocity=[0, 7.7e3, 0])
    plain.run(steps=2, output=str(tmp_path / "plain.h5"), progress=False)
    with h5py.File(tmp_path / "plain.h5", "r") as f:
        assert "invariants/jacobi" not in f


def test_newton_converges_without_the_fields_jacobian():
    """The field gives Newton no Jacobian (the central effect's carries it): LEO at 90 s in the
    20 x 20 field takes 4.0 sweeps per step (zonal J2..J6, with its full Jacobian, 2.0); bound
    4.5."""
    res = _leo(20, 90.0).run(steps=2000, every=100, progress=False)
    assert res.si.mean_newton_iterations() <= 4.5


#: a text kernel in NAIF's format with Mars's IAU 2015 linear model (pck00011.tpc) and one
#: nutation-precession term of invented size, to exercise the trigonometric sums
PCK = r"""
KPL/PCK
\begintext
Mars, IAU 2015 (Archinal et al. 2018), linear part; one trigonometric term added for the test.
\begindata
BODY499_POLE_RA  = ( 317.269202  -0.10927547  0. )
BODY499_POLE_DEC = (  54.432516  -0.05827105  0. )
BODY499_PM       = ( 176.049863  +350.891982443297  0. )
BODY4_NUT_PREC_ANGLES = ( 198.991226 19139.4819985
                          226.292679 38280.8511281 )
BODY499_NUT_PREC_RA  = ( 0.000068 0.000238 )
BODY499_NUT_PREC_DEC = ( 0.000023 0.000029 )
BODY499_NUT_PREC_PM  = ( 0.000145 0.000157 )
BODY499_RADII = ( 3396.19 3396.19 3376.20 )
\begintext
"""


def test_a_pck_turns_the_field_with_the_bodys_iau_model(tmp_path):
    """rotation = "pck": the kernel's model at the epoch (d days, T centuries of TDB since
    J2000) gives the pole (RA, DEC), the node (RA + 90 deg) and W; the body's x axis at time 0
    is cos W node + sin W (pole x node), the rate dW/dt (350.89 deg/day and its trigonometric
    part), the pole and the node unit vectors; a LEO-like orbit in that turning field keeps
    E - E0 - W within 1e-13. Errors name the keys."""
    from astropy.time import Time

    path = tmp_path / "mars.tpc"
    path.write_text(PCK)
    epoch = Time("2026-03-20T12:00:00", scale="tdb")
    sim = emorbit.Simulation(EARTH, dt=60.0, epoch="2026-03-20T12:00:00 TDB")
    effect = sim.add_effect("gravity_field", model="egm2008", degree=4, rotation="pck", pck=str(path), body="mars")
    effect.prepare(0.0, 60.0, epoch)
    d = (epoch.tdb.jd1 - 2451545.0) + epoch.tdb.jd2
    t = d / 36525.0
    e = np.radians([198.991226 + 19139.4819985 * t, 226.292679 + 38280.8511281 * t])
    ra = math.radians(317.269202 - 0.10927547 * t + 0.000068 * math.sin(e[0]) + 0.000238 * math.sin(e[1]))
    dec = math.radians(54.432516 - 0.05827105 * t + 0.000023 * math.cos(e[0]) + 0.000029 * math.cos(e[1]))
    w = math.radians((176.049863 + 350.891982443297 * d + 0.000145 * math.sin(e[0]) + 0.000157 * math.sin(e[1])) % 360)
    pole = np.array([math.cos(dec) * math.cos(ra), math.cos(dec) * math.sin(ra), math.sin(dec)])
    node = np.array([-math.sin(ra), math.cos(ra), 0.0])
    np.testing.assert_allclose(effect.frame[:, 2], pole, atol=1e-15)
    np.testing.assert_allclose(effect.frame[:, 0], node, atol=1e-15)
    c, s = math.cos(effect.p[12]), math.sin(effect.p[12])
    x_axis = effect.frame @ np.array([c, s, 0.0])
    assert np.linalg.norm(x_axis - (math.cos(w) * node + math.sin(w) * np.cross(pole, node))) <= 1e-9
    rate = math.radians(350.891982443297 + 0.000145 * math.cos(e[0]) * math.radians(19139.4819985) / 36525
                        + 0.000157 * math.cos(e[1]) * math.radians(38280.8511281) / 36525) / 86400  # fmt: skip
    assert effect.rate == pytest.approx(rate, rel=1e-14)
    from emorbit import orbits

    x, v = orbits.state_from_elements((RADIUS + 600e3, 0.01, 1.0, 0.2, 0.1, 0.0), MU)
    sim.add_point("sat", mass=1.0, position=x, velocity=v)
    res = sim.run(steps=2000, every=100, progress=False)
    assert np.abs(res.si.relative_energy_balance()).max() <= 1e-13
    for keys, where in (
        ({"rotation": "pck", "body": "mars"}, "pck"),
        ({"rotation": "pck", "pck": str(path), "body": "pluto"}, "body"),
        ({"rotation": "pck", "pck": str(path), "body": 599}, "pck"),
        ({"rotation": "pck", "pck": str(path), "body": 499, "rate": 1e-4}, "rate"),
        ({"rotation": "uniform", "rate": 1e-4, "pck": str(path)}, "pck"),
    ):
        with pytest.raises(InputError) as err:
            s2 = emorbit.Simulation(EARTH, dt=60.0, epoch="2026-03-20T12:00:00 TDB")
            s2.add_effect("gravity_field", model="egm2008", degree=4, **keys).prepare(0.0, 1.0, epoch)
        assert where in str(err.value)


def test_the_moon_and_mars_are_named_central_bodies(monkeypatch):
    """[field] body = "moon" and "mars": GM, radius and rotation rate from pyshtools.constants
    (GRAIL's and Konopliv et al.'s GM), which drag's co-rotating air takes; without pyshtools
    the error names field.body and the extra that brings it."""
    shc = pytest.importorskip("pyshtools.constants")
    for name, ref in (("moon", shc.Moon), ("Mars", shc.Mars)):
        field = emorbit.CentralField(body=name)
        assert field.gm == ref.gm.value and field.radius == ref.mean_radius.value
        assert field.rate == ref.angular_velocity.value and field.body == name.lower()
    assert 4.9027e12 < emorbit.CentralField(body="moon").gm < 4.9029e12
    sim = emorbit.Simulation(emorbit.CentralField(body="mars"), dt=60.0)
    drag = sim.add_effect(
        "drag", atmosphere="exponential", density="1e-12 kg / m3", scale_height="10 km", reference_altitude="100 km"
    )
    assert drag.p[5] == shc.Mars.angular_velocity.value  # the air turns about z at Mars's rate
    import sys

    monkeypatch.setitem(sys.modules, "pyshtools.constants", None)
    with pytest.raises(InputError, match=r"field\.body.*emorbit\[bodies\]"):
        emorbit.CentralField(body="moon")
    with pytest.raises(InputError, match="unknown body 'pluto'"):
        emorbit.CentralField(body="pluto")


def test_a_mars_field_turns_with_the_named_bodys_iau_model(tmp_path):
    """[field] body = "mars" with a 4 x 4 field from an ICGEM file and rotation = "pck" without a
    body key: the kernel's Mars (NAIF 499) turns it, as body = "mars" does; a low Mars orbit
    keeps E - E0 - W within 1e-13 over 2000 steps of 30 s."""
    pytest.importorskip("pyshtools.constants")
    from astropy.time import Time

    from emorbit import orbits

    kernel = tmp_path / "mars.tpc"
    kernel.write_text(PCK)
    mars = emorbit.CentralField(body="mars")
    gfc = tmp_path / "mars4.gfc"
    lines = [
        "modelname test-4x4", f"earth_gravity_constant {mars.gm!r}", "radius 3396000.0", "max_degree 4",
        "norm fully_normalized", "end_of_head",
    ]  # fmt: skip
    rng = np.random.default_rng(4)
    for n in range(2, 5):
        for m in range(n + 1):
            c, s = (-8.75e-4, 0.0) if (n, m) == (2, 0) else (1e-5 * rng.standard_normal(), 1e-5 * rng.standard_normal())
            lines.append(f"gfc {n} {m} {c!r} {0.0 if m == 0 else s!r} 0 0")
    gfc.write_text("\n".join(lines) + "\n")
    epoch = "2026-03-20T12:00:00 TDB"
    frames = []
    for extra in ({}, {"body": "mars"}):
        sim = emorbit.Simulation(mars, dt=30.0, epoch=epoch)
        effect = sim.add_effect("gravity_field", gfc=str(gfc), degree=4, rotation="pck", pck=str(kernel), **extra)
        effect.prepare(0.0, 30.0, Time("2026-03-20T12:00:00", scale="tdb"))
        frames.append((effect.frame.copy(), effect.rate))
    assert np.array_equal(frames[0][0], frames[1][0]) and frames[0][1] == frames[1][1]
    sim = emorbit.Simulation(mars, dt=30.0, epoch=epoch)
    sim.add_effect("gravity_field", gfc=str(gfc), degree=4, rotation="pck", pck=str(kernel))
    x, v = orbits.state_from_elements((mars.radius + 300e3, 0.01, 1.2, 0.3, 0.1, 0.0), mars.gm)
    sim.add_point("orbiter", mass=1.0, position=x, velocity=v)
    res = sim.run(steps=2000, every=100, progress=False)
    assert np.abs(res.si.relative_energy_balance()).max() <= 1e-13


def test_a_scenes_files_are_found_beside_it(tmp_path, monkeypatch):
    """A scene's relative gfc and pck paths are found in the scene's folder, run from any
    other folder; a file that is in neither names the key."""
    pytest.importorskip("pyshtools.constants")
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "mars.tpc").write_text(PCK)
    lines = ["earth_gravity_constant 42828375815756.1", "radius 3396000.0", "max_degree 2", "end_of_head",
             "gfc 2 0 -8.75e-4 0.0 0 0", "gfc 2 1 0.0 0.0 0 0", "gfc 2 2 -8.46e-5 4.89e-5 0 0"]  # fmt: skip
    (folder / "mars2.gfc").write_text("\n".join(lines) + "\n")
    text = """
[field]
body = "mars"
[[effect]]
kind = "gravity_field"
gfc = "mars2.gfc"
degree = 2
rotation = "pck"
pck = "mars.tpc"
[[body]]
name = "orbiter"
kind = "point"
mass = "1 kg"
orbit = {a = "3800 km", e = 0.01, i = "80 deg"}
[integrator]
dt = "30 s"
t_end = "300 s"
epoch = "2026-03-20T12:00:00 TDB"
"""
    (folder / "mars.toml").write_text(text)
    monkeypatch.chdir(tmp_path)
    from emorbit.scene import load_scene

    sim = load_scene(str(folder / "mars.toml")).build()
    assert sim.effects.named[-1].coefficients.C[2, 2] == -8.46e-5
    (folder / "elsewhere.toml").write_text(text.replace('pck = "mars.tpc"', 'pck = "gone.tpc"'))
    with pytest.raises(InputError, match=r"effect\[0\]\.pck"):
        load_scene(str(folder / "elsewhere.toml")).build()


def test_itrs_turns_the_field_as_astropys_itrs():
    """rotation = "itrs": the body frame the kernel prepares (B, P and the angle interpolated
    from hourly samples) maps a position at 7000 km as astropy's GCRS to ITRS does, at the epoch,
    an hour, a day and 30 days later (bound 1e-12 rad; measured 9.5e-17, 2.4e-16, 2.1e-14,
    1.2e-13); a day of LEO in it keeps E - E0 - W within 1e-13. Past the IERS tables a warning
    names the key."""
    import astropy.units as u
    from astropy.coordinates import GCRS, ITRS, CartesianRepresentation
    from astropy.time import Time, TimeDelta

    from emorbit.kernels.effects.gravity_field import gravity_field_prepare

    epoch = Time("2026-03-20T12:00:00", scale="tdb")
    sim = emorbit.Simulation(EARTH, dt=60.0, epoch="2026-03-20T12:00:00 TDB")
    effect = sim.add_effect("gravity_field", model="egm2008", degree=2, rotation="itrs")
    effect.prepare(0.0, 31 * 86400.0, epoch)
    x = np.array([3.1e6, -5.2e6, 3.4e6])
    s = np.zeros(effect.scratch_size(1))
    errors = []
    for dt in (0.0, 3600.0, 86400.0 + 1234.5, 30 * 86400.0 + 77.0):
        gravity_field_prepare(dt, dt, dt, effect.p, effect.tab, s)
        c, sn = s[2], s[3]
        b = s[22:31].reshape(3, 3).T @ x
        r = np.array([c * b[0] + sn * b[1], -sn * b[0] + c * b[1], b[2]])
        ours = s[49:58].reshape(3, 3) @ r
        t = epoch + TimeDelta(dt, format="sec")
        gcrs = GCRS(CartesianRepresentation(x * u.m), obstime=t)
        theirs = gcrs.transform_to(ITRS(obstime=t)).cartesian.xyz.to_value(u.m)
        errors.append(np.linalg.norm(ours - theirs) / np.linalg.norm(x))
    assert max(errors) <= 1e-12, errors
    from emorbit import orbits

    pos, vel = orbits.state_from_elements((RADIUS + 500e3, 0.01, 1.2, 0.2, 0.1, 0.0), MU)
    sim.add_point("sat", mass=1.0, position=pos, velocity=vel)
    res = sim.run("1 d", every=60, progress=False)
    assert np.abs(res.si.relative_energy_balance()).max() <= 1e-13
    from astropy.utils import iers

    with iers.conf.set_temp("auto_download", False):  # a year past the installed tables' end
        last = float(iers.earth_orientation_table.get()["MJD"][-1].value)
    when = Time(last + 365.0, format="mjd", scale="tdb").strftime("%Y-%m-%dT%H:%M:%S")
    late = emorbit.Simulation(EARTH, dt=60.0, epoch=f"{when} TDB")
    late_effect = late.add_effect("gravity_field", model="egm2008", degree=2, rotation="itrs")
    with pytest.warns(UserWarning, match="rotation: astropy's IERS tables end"):
        late_effect.prepare(0.0, 60.0, Time(when, scale="tdb"))


ITRS_SCENE = """
[field]
gm = "3.986004415e14 m3 / s2"
radius = "6378.1363 km"

[integrator]
method = "em"
order = 4
dt = "60 s"
t_end = "6 h"
output_every = 10
epoch = "2026-03-20T12:00:00 TDB"

[[effect]]
kind = "gravity_field"
model = "egm2008"
degree = 8
rotation = "itrs"

[[body]]
name = "sat"
kind = "point"
mass = "100 kg"
orbit = {a = "6878 km", e = 0.001, i = "51.6 deg", raan = "0 deg", argp = "0 deg", nu = "0 deg"}
"""


def test_an_itrs_run_resumes_bit_for_bit(tmp_path):
    """Run 3 h of 6 in the ITRS-turning field, resume to 6 h: every record equals one run to 6 h
    (the resumed run samples its own table of the Earth's orientation, on the same grid)."""
    import h5py

    from emorbit.cli import main

    scene = tmp_path / "itrs.toml"
    scene.write_text(ITRS_SCENE)
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    assert main(["run", str(scene), "-o", str(full), "-q"]) == 0
    assert main(["run", str(scene), "-o", str(part), "-q", "--t-end", "3 h"]) == 0
    assert main(["resume", str(part), "--t-end", "6 h", "-q"]) == 0
    with h5py.File(full, "r") as a, h5py.File(part, "r") as b:
        for name in ("bodies/sat/position", "bodies/sat/velocity", "invariants/energy", "invariants/jacobi"):
            assert np.array_equal(a[name][()], b[name][()]), name
