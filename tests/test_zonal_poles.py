"""The odd zonal harmonics (J3, J5) and the pole they are measured about, through the public API
(``Simulation.add_effect("zonal", ...)``, ``run``, the Result).

An odd harmonic changes sign with the pole: the potential is
V = (GM m / r) sum_n J_n (R / r)^n P_n(z / r), z = (x - c) . p, and P_n is odd for odd n, so
turning the pole over flips J3's and J5's force while J2's, J4's and J6's stay. These tests
hold the force of one short em step to the closed form of that potential's gradient for
south-pointing, north-pointing, tilted and default poles, so that a step that took the pole
(0, 0, -1) for (0, 0, 1), or a default pole written the wrong way round, fails. (The packed
kernel of the central field plus zonal harmonics has a variant for the pole (0, 0, 1); every
other pole runs the general one.)
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import legendre

import emorbit

EARTH = emorbit.CentralField(body="earth")
R_EQ = 6378136.3  # EGM2008's reference radius, m
J3 = 1e-3  # a large J3, so that its force stands far above the step's own error


def _closed_form(x, p, jn, radius, gm):
    """The zonal acceleration -grad V / m at positions x (n, 3) about the unit pole p:
    sum_n (f_n / r) [(n + 1) P_n(s) d/r - P_n'(s) (p - s d/r)], f_n = GM J_n R^n / r^(n+1),
    s = d.p / r (the gradient of each f_n(r) P_n(s) term, written out)."""
    r = np.linalg.norm(x, axis=1)
    u = x / r[:, None]
    s = u @ p
    a = np.zeros_like(x)
    for n, j in enumerate(jn, start=2):
        if j == 0.0:
            continue
        c = np.zeros(n + 1)
        c[n] = 1.0
        pn, dpn = legendre.legval(s, c), legendre.legval(s, legendre.legder(c))
        f = gm * j * radius**n / r ** (n + 1)
        a += (f / r)[:, None] * ((n + 1) * pn[:, None] * u - dpn[:, None] * (p[None, :] - s[:, None] * u))
    return a


def _points():
    """Eight states at 7000 km, latitudes from -70 to +80 degrees, circular speed across them."""
    lat = np.radians([-70.0, -45.0, -20.0, -5.0, 10.0, 30.0, 55.0, 80.0])
    lon = np.radians([0.0, 40.0, 95.0, 150.0, 200.0, 250.0, 300.0, 340.0])
    r = 7000e3
    x = r * np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=1)
    east = np.stack([-np.sin(lon), np.cos(lon), np.zeros_like(lon)], axis=1)
    return x, np.sqrt(EARTH.gm / r) * east


def _step(dt, zonal):
    """One em step of ``dt`` of the eight points with the zonal harmonics ``zonal`` (a dict of
    add_effect keys; None: the central field alone): the step's midpoints and velocity
    changes, (n, 3) each."""
    sim = emorbit.Simulation(EARTH, method="em", dt=dt)
    if zonal is not None:
        sim.add_effect("zonal", **zonal)
    x, v = _points()
    for i in range(len(x)):
        sim.add_point(f"p{i}", mass=1.0, position=x[i], velocity=v[i])
    res = sim.run(steps=1, progress=False, drift_tolerance=np.inf).si  # the force is checked, not the drift
    xs = np.stack([res.positions[f"p{i}"] for i in range(len(x))], axis=1)  # (2 records, n, 3)
    vs = np.stack([res.velocities[f"p{i}"] for i in range(len(x))], axis=1)
    return 0.5 * (xs[0] + xs[1]), vs[1] - vs[0]


def _zonal_force(zonal, dt=0.1):
    """The zonal part of one em step's force per unit mass, (dv - dv_central) / dt, and the
    step's midpoints. Over dt = 0.1 s (0.75 km of a 7000 km orbit) the em step's discrete
    gradient is the gradient at the midpoint to (v dt / r)^2 = 1e-8 relative."""
    xm, dv = _step(dt, zonal)
    _, dv0 = _step(dt, None)
    return (dv - dv0) / dt, xm


#: the zonal force of one em step against the closed form, relative: measured 1.9e-8 for J3
#: about the poles below, 1.1e-8 for EGM2008's J2..J6 (the step's (v dt / r)^2 = 1.1e-8);
#: a J3 of the wrong sign is off by 2
FORCE = 2e-7


def _force_error(zonal, pole, jn, radius):
    f, xm = _zonal_force(zonal)
    ref = _closed_form(xm, pole / np.linalg.norm(pole), jn, radius, EARTH.gm)
    return np.max(np.linalg.norm(f - ref, axis=1) / np.linalg.norm(ref, axis=1))


@pytest.mark.parametrize(
    "pole",
    [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.3, -0.2, 1.0], [0.0, 0.0, -3.0], [1.0, 0.0, 0.0]],
    ids=["south", "north", "tilted", "south-unnormalised", "x"],
)
def test_j3_follows_its_pole(pole):
    """J3 = 1e-3 alone about a pole: one em step of eight points from latitude -70 to +80
    degrees exerts the closed-form gradient of J3's potential about that pole (a force of
    9.4e-3 m/s^2 at least), to FORCE. About the south pole the force is the north pole's
    turned over, J3 being odd: a step that ran the pole (0, 0, -1) as (0, 0, 1) is off by 2."""
    err = _force_error({"j": [0.0, J3], "radius": R_EQ, "pole": pole}, np.array(pole), [0.0, J3], R_EQ)
    assert err <= FORCE, f"zonal force against the closed form about the pole {pole}: {err:.3g} relative"


def test_the_default_pole_points_north():
    """Without ``pole`` the axis is +z (the documented [0, 0, 1]): J3's force is the closed form
    about (0, 0, 1), and so is EGM2008's J2..J6 (``model = "earth"``). The Earth's J3 < 0 (its
    southern hemisphere the fuller) pulls a satellite on the equator south, by
    1.5 GM J3 R^3 / r^5 = -2.34e-5 m/s^2 at 7000 km, J5 taking back 2.2e-6."""
    north = np.array([0.0, 0.0, 1.0])
    err = _force_error({"j": [0.0, J3], "radius": R_EQ}, north, [0.0, J3], R_EQ)
    assert err <= FORCE, f"J3 about the default pole against the closed form about +z: {err:.3g}"
    from emorbit.effects.zonal import zonal_model

    jn, radius = zonal_model("earth")["jn"], zonal_model("earth")["radius"]
    err = _force_error({"model": "earth"}, north, jn, radius)
    assert err <= FORCE, f"EGM2008 about the default pole against the closed form about +z: {err:.3g}"
    # on the equator the odd harmonics alone pull along the pole, the Earth's to the south
    x = np.array([[7000e3, 0.0, 0.0], [0.0, -7000e3, 0.0]])
    a = _closed_form(x, north, [0.0, jn[1], 0.0, jn[3]], radius, EARTH.gm)
    assert jn[1] < 0 and np.all(a[:, 2] < -1e-5) and np.allclose(a[:, :2], 0.0, atol=1e-20)
    sim = emorbit.Simulation(EARTH, method="em", dt=1.0)
    sim.add_effect("zonal", model="earth")
    sim.add_point("s", mass=1.0, position=x[0], velocity=[0.0, 7546.0, 0.0])
    dvz = sim.run(steps=1, progress=False).si.velocities["s"][1, 2]  # the central field and J2, J4, J6: radial
    assert dvz == pytest.approx(a[0, 2], rel=1e-6), f"the Earth's zonal pull on the equator over 1 s: {dvz:.6g} m/s"


@pytest.mark.parametrize("pole", [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]], ids=["south", "north"])
def test_the_recorded_energy_holds_about_either_pole(pole):
    """Two orbits of a = 7500 km, e = 0.1 at 63 degrees, T/200, under J2 and J3 = 1e-3 about a
    polar pole: the energy recorded with the zonal potential about that pole (the result's, evaluated apart
    from the step) stays at round-off: measured 9.8e-16 (south) and 7.0e-16 (north). A step
    run about the other pole keeps its own energy, and this one then moves by 1.6e-3 of |E|."""
    a, e, inc = 7500e3, 0.1, np.radians(63.0)
    rp = a * (1 - e)
    vp = np.sqrt(EARTH.gm * (1 + e) / rp)
    period = 2 * np.pi * np.sqrt(a**3 / EARTH.gm)
    sim = emorbit.Simulation(EARTH, method="em", dt=period / 200)
    sim.add_effect("zonal", j=[1.08e-3, J3], radius=R_EQ, pole=pole)
    sim.add_point("s", mass=1.0, position=[rp, 0.0, 0.0], velocity=[0.0, vp * np.cos(inc), vp * np.sin(inc)])
    res = sim.run(steps=400, every=4, progress=False, drift_tolerance=np.inf)  # asserted here instead
    dE = np.max(np.abs(res.relative_energy_error()))
    assert dE <= 1e-14, f"|dE|/|E0| = {dE:.3g} about the pole {pole}"
