"""Drag in NRLMSIS 2.1 (``atmosphere = "nrlmsis"``, the msis extra): its grid against pymsis, the
diurnal bulge that follows the Sun, and the energy balance on point masses and rigid bodies.

The kernels read NRLMSIS from a grid of log-densities over altitude, latitude and local solar
time sampled at the run's epoch (:func:`emorbit.effects.atmosphere_msis.msis_grid`), local
time from the Sun's sampled path; the step's discrete work closes the balance as with any
density.
"""

from __future__ import annotations

import numpy as np
import pytest
from sweep_support import assert_one_sweep_matches_two

import emorbit
from emorbit.errors import InputError

pytest.importorskip("pymsis")

EARTH = emorbit.CentralField(body="earth")
EPOCH = "2026-03-20T00:00:00 TDB"
R = EARTH.radius + 400e3
V = float(np.sqrt(EARTH.gm / R))
T = 2 * np.pi * float(np.sqrt(R**3 / EARTH.gm))
WEATHER = dict(f107=150.0, f107a=150.0, ap=15.0)


def test_the_grid_reproduces_nrlmsis_and_its_scale_height():
    """At 300 random points from 150 to 900 km, all latitudes and local times, the grid's
    density (log-linear in altitude, bilinear in latitude and local time) agrees with pymsis at
    the same place to 1.2 % at most and 0.19 % in the median (the interpolation between nodes
    10 km, 5 deg and 1 h apart; NRLMSIS's own uncertainty is some 10 %), and its altitude
    derivative, the layer's mean slope, gives NRLMSIS's local scale height within 5.5 %."""
    import erfa

    from emorbit.effects.atmosphere_msis import msis_density, msis_grid
    from emorbit.epochs import to_epoch
    from emorbit.kernels.effects.atmosphere_grid import grid_density

    epoch = to_epoch(EPOCH)
    grid, axes = msis_grid(epoch, radius=EARTH.radius, **WEATHER)
    rng = np.random.default_rng(7)
    a, lat, lst = rng.uniform(150e3, 900e3, 300), rng.uniform(-85, 85, 300), rng.uniform(0, 24, 300)
    sun = np.array([1.496e11, 0.0, 0.0])
    r = EARTH.radius + a
    ang = lst * np.pi / 12 - np.pi  # the hour angle from the Sun: local noon at 0
    c = np.cos(np.radians(lat))
    d = r[:, None] * np.stack([c * np.cos(ang), c * np.sin(ang), np.sin(np.radians(lat))], axis=1)
    ours = np.array([grid_density(*p, *sun, 0.0, 0.0, 1.0, EARTH.radius, axes, grid) for p in d])
    meridian = np.stack([r * c, np.zeros_like(r), r * np.sin(np.radians(lat))], axis=1)
    _, geodetic, height = erfa.gc2gd(1, meridian)
    t = epoch.utc
    ut = (t.jd2 + 0.5 + (t.jd1 % 1.0)) % 1.0 * 24.0
    lon = (15.0 * (lst - ut) + 180.0) % 360.0 - 180.0
    direct = msis_density(height, np.degrees(geodetic), lon, epoch, **WEATHER)
    err = np.abs(ours[:, 0] / direct - 1)
    assert np.max(err) < 0.02 and np.median(err) < 4e-3
    up = msis_density(height + 1e3, np.degrees(geodetic), lon, epoch, **WEATHER)
    scale = 1e3 / np.log(direct / up)
    assert np.max(np.abs(-ours[:, 0] / ours[:, 1] / scale - 1)) < 0.08


def _orbit(kind: str, steps: int, dt: float = T / 100):
    sim = emorbit.Simulation(EARTH, method="em", dt=dt, epoch=EPOCH)
    sim.add_effect("drag", atmosphere="nrlmsis", **WEATHER)
    state = dict(position=[R, 0, 0], velocity=[0, V * np.cos(0.9), V * np.sin(0.9)])
    if kind == "point":
        sim.add_point("sat", mass=100.0, ballistic_coefficient=0.02, **state)
    else:
        sim.add_rigid("sat", "box", size=[1, 1, 2], mass=100.0, **state)
    return sim.run(steps=steps, every=1, progress=False)


@pytest.mark.parametrize("kind", ["point", "rigid"])
def test_the_balance_closes_in_nrlmsis_and_the_air_is_denser_by_day(kind):
    """100 orbits at T/100 at 400 km (F10.7 150, Ap 15, an equinox): the balance stays at
    round-off (measured 2.4e-15 of |E0| for the point, 9e-16 for the box) while drag takes
    2.4 km (point) and 7 km (box) of the semi-major axis; over one orbit the work per step on
    the day side is 2 to 4 times the night side's (measured ratio of the largest to the least
    2.5: the diurnal bulge follows the Sun)."""
    res = _orbit(kind, 10_000)
    e0 = abs(res.energy[0].value)
    assert np.abs(res.energy_balance.value).max() / e0 < 1e-13
    a = res.elements("sat").a.value
    assert a[-1] - a[0] < -1e3
    per_step = -np.diff(res.work["drag"].value[:101])  # the first orbit
    assert 1.8 < per_step.max() / per_step.min() < 5.0


def test_nrlmsis_keys_are_checked_by_name():
    """Space weather is given, not downloaded: each missing or bad index, an unknown version
    and keys that belong to another atmosphere are errors naming the key."""
    sim = emorbit.Simulation(EARTH, method="em", dt=10.0, epoch=EPOCH)
    for keys, bad in (
        (dict(f107a=150.0, ap=15.0), "f107"),
        (dict(f107=150.0, f107a=-1.0, ap=15.0), "f107a"),
        (dict(f107=150.0, f107a=150.0, ap="15"), "ap"),
        (dict(WEATHER, msis_version=3), "msis_version"),
        (dict(WEATHER, density="1e-12 kg/m3"), "density"),
    ):
        with pytest.raises(InputError) as exc:
            sim.add_effect("drag", atmosphere="nrlmsis", **keys)
        assert exc.value.key == f"effect[0].{bad}"
    with pytest.raises(InputError) as exc:
        sim.add_effect("drag", atmosphere="ussa1976", f107=150.0)
    assert exc.value.key == "effect[0].f107"
    no_epoch = emorbit.Simulation(EARTH, method="em", dt=10.0)
    with pytest.raises(InputError) as exc:
        no_epoch.add_effect("drag", atmosphere="nrlmsis", **WEATHER)
    assert exc.value.key == "epoch"


def test_the_grid_is_kept_on_disk_and_read_back_bit_for_bit(tmp_path, monkeypatch):
    """A second run with the same epoch and weather reads the grid from the per-user cache
    without calling NRLMSIS; other weather samples anew; a damaged file is sampled again and
    replaced; with ``EMORBIT_JIT_CACHE=0`` nothing is written."""
    import pymsis

    from emorbit.effects.atmosphere_msis import msis_grid
    from emorbit.epochs import to_epoch

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    epoch = to_epoch(EPOCH)
    first, axes = msis_grid(epoch, radius=EARTH.radius, **WEATHER)
    (kept,) = (tmp_path / "emorbit" / "msis").glob("*.npy")
    calls = []
    real = pymsis.calculate
    monkeypatch.setattr(pymsis, "calculate", lambda *a, **k: calls.append(1) or real(*a, **k))
    again, axes2 = msis_grid(epoch, radius=EARTH.radius, **WEATHER)
    assert calls == [] and np.array_equal(again, first) and np.array_equal(axes2, axes)
    stormy, _ = msis_grid(epoch, radius=EARTH.radius, f107=150.0, f107a=150.0, ap=80.0)
    assert calls == [1] and not np.array_equal(stormy, first)
    kept.write_bytes(kept.read_bytes()[:100])  # a torn file
    repaired, _ = msis_grid(epoch, radius=EARTH.radius, **WEATHER)
    assert calls == [1, 1] and np.array_equal(repaired, first)
    assert np.array_equal(np.load(kept), first)
    monkeypatch.setenv("EMORBIT_JIT_CACHE", "0")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "off"))
    off, _ = msis_grid(epoch, radius=EARTH.radius, **WEATHER)
    assert calls == [1, 1, 1] and np.array_equal(off, first) and not (tmp_path / "off").exists()


def _msis_drag():
    """A Drag effect on NRLMSIS, prepared for the first hour of the run, and the Sun at 30 min."""
    from emorbit.effects import build
    from emorbit.epochs import to_epoch
    from emorbit.kernels.effects.drag import drag_prepare

    effect = build({"kind": "drag", "atmosphere": "nrlmsis", **WEATHER}, EARTH, "effect[0]")
    effect.prepare(0.0, 3600.0, to_epoch(EPOCH))
    s = np.zeros(3)
    drag_prepare(1790.0, 1800.0, 1810.0, effect.p, effect.tab, s)
    return effect, s


def _points_off_nodes(effect, s, n, low, high, seed):
    """n random points (relative to the centre) from ``low`` to ``high`` above the surface,
    100 m in altitude and 1e-3 of a cell sideways from the grid's nodes, between the poles'
    rows: the central differences of the tests below reach no node."""
    from emorbit.kernels.effects.atmosphere_grid import _cell

    p, tab = effect.p, effect.tab
    o = 3 * int(p[13])
    shape = (int(p[14]), int(p[15]), int(p[16]))
    rng = np.random.default_rng(seed)
    taken = 0
    while taken < n:
        d = rng.normal(size=3)
        d *= (EARTH.radius + rng.uniform(low, high)) / np.linalg.norm(d)
        _, fa, _, fp, _, fl, inside, *_ = _cell(*d, *s, *p[10:13], p[6], *tab[o : o + 5], *shape)
        if inside and min(fa, 1 - fa) * tab[o + 1] >= 100.0 and min(fp, 1 - fp, fl, 1 - fl) >= 1e-3:
            taken += 1
            yield d


def test_the_grids_gradient_matches_central_differences():
    """At 300 random points from 150 to 900 km (all latitudes within the poles' rows and all
    local times, away from the grid's nodes by 100 m in altitude and 1e-3 of a cell sideways),
    ``rho (dL/da d / r + horizontal)`` against central differences of the grid's density (steps
    of 10 m); measured max relative difference 2.9e-8."""
    from emorbit.kernels.effects.atmosphere_grid import grid_density_at, grid_horizontal_gradient_at

    effect, s = _msis_drag()
    p, tab = effect.p, effect.tab
    o = 3 * int(p[13])
    a0, da, phi0, dphi, dlam = tab[o : o + 5]
    shape = (int(p[14]), int(p[15]), int(p[16]))

    def density(d):
        return grid_density_at(*d, *s, *p[10:13], p[6], a0, da, phi0, dphi, dlam, tab, o + 5, *shape)

    worst = 0.0
    for d in _points_off_nodes(effect, s, 300, 150e3, 900e3, seed=9):
        r = np.linalg.norm(d)
        rho, drho = density(d)
        g = rho * np.array(grid_horizontal_gradient_at(*d, *s, *p[10:13], p[6], a0, da, phi0, dphi, dlam, tab,
                                                        o + 5, *shape)) + drho * d / r  # fmt: skip
        fd = np.empty(3)
        for j in range(3):
            e = np.zeros(3)
            e[j] = 10.0
            fd[j] = (density(d + e)[0] - density(d - e)[0]) / 20.0
        worst = max(worst, np.abs(g - fd).max() / np.abs(fd).max())
    assert worst < 3e-7, worst


def test_drag_on_the_grid_has_its_whole_jacobian():
    """drag's piece on NRLMSIS adds dF/dx1 with the density's gradient, its horizontal part
    included, into J: against central differences of its force in x1 (steps of 1 m) over 100
    random steps of 10 s from 200 to 600 km with the air co-rotating, away from the grid's
    nodes; measured max relative difference 5.4e-10. The horizontal part is up to 2.4e-3 of
    J's largest entry (median 1.1e-3): left out, the check would fail by that much."""
    from emorbit.kernels.effects.drag import drag_piece

    effect, s = _msis_drag()
    p, tab = effect.p, effect.tab
    rng = np.random.default_rng(11)
    worst = 0.0
    for m in _points_off_nodes(effect, s, 100, 200e3, 600e3, seed=10):  # the centre is at the origin
        v = np.cross(rng.normal(size=3), m)
        v *= 7.6e3 / np.linalg.norm(v)
        x0, x1 = m - 5.0 * v, m + 5.0 * v
        J = np.zeros((3, 3))
        drag_piece(*x0, *x1, 10.0, 0.02, p, tab, s, J, True)
        fd = np.empty((3, 3))
        for j in range(3):
            e = np.zeros(3)
            e[j] = 1.0
            up = np.array(drag_piece(*x0, *(x1 + e), 10.0, 0.02, p, tab, s, np.zeros((3, 3)), False))
            down = np.array(drag_piece(*x0, *(x1 - e), 10.0, 0.02, p, tab, s, np.zeros((3, 3)), False))
            fd[:, j] = (up - down) / 2.0
        worst = max(worst, np.abs(J - fd).max() / np.abs(fd).max())
    assert worst < 1e-8, worst


def _msis_points(steps: int):
    sim = emorbit.Simulation(EARTH, method="em", order=2, dt=T / 1000, epoch=EPOCH)
    sim.add_effect("drag", atmosphere="nrlmsis", **WEATHER)
    rng = np.random.default_rng(12)
    for k in range(6):
        r = EARTH.radius + rng.uniform(250e3, 500e3)
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        v = float(np.sqrt(EARTH.gm / r))
        sim.add_point(f"p{k}", mass=1.0, ballistic_coefficient=0.05, position=q @ [r, 0, 0], velocity=q @ [0, v, 0])
    res = sim.run(steps=steps, every=steps // 4, progress=False).si
    return np.array([res.positions[f"p{k}"][-1] for k in range(6)]), res


def test_drag_on_nrlmsis_takes_one_sweep(monkeypatch):
    """Six points from 250 to 500 km under NRLMSIS drag (0.05 m^2/kg), 2000 em steps of T/1000:
    J holds the grid's whole gradient, so each sub-step after the first takes one Newton sweep.
    Declared unknown, the step takes two; the positions agree to 1e-14 of the orbit radius
    (measured 2.7e-16) and both keep the balance within 2e-15 of |E0| (measured
    1.8e-16 and 1.3e-16)."""
    from emorbit.effects.drag import Drag

    one = _msis_points(2000)
    monkeypatch.setattr(Drag, "JACOBIAN_LEFT_OUT", np.inf)
    assert_one_sweep_matches_two(one, _msis_points(2000), R)
