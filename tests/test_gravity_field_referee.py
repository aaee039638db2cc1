"""A referee for the rotating gravity field: heyoka's Taylor integrator with the same force.

The case: LEO (a = R + 400 km, e = 0.001, i = 51.6 deg, node 0.2 rad, argument of perigee 0.1
rad, true anomaly 0) in EGM2008 to degree and order 20, the field turning uniformly about z at
W = 7.292115146706979e-5 rad/s from the angle 0.3 rad at t = 0, for 1 day in the inertial
frame; mu, R and the coefficients are heyoka's (``get_egm2008_mu``, ``get_egm2008_a``,
``get_egm2008_CS``): the bench's case, :mod:`emorbit.bench.gravity_field`.

heyoka's force is built from its own EGM2008 model, rotated as emorbit's effect turns its
field: ``a(x, t) = Rz(theta) egm2008_acc(Rz(theta)^T x, 20, 20)``, ``theta = 0.3 + W t``
(``hy.time``); emorbit's is :func:`~emorbit.kernels.effects.gravity_field.gravity_field_force`
at a point (x0 = x1, the angle prepared at t) plus the central term. Two independent
evaluations (heyoka's spherical-harmonic recursion against Pines' form) of one field.

Measured (2-core Xeon): the accelerations agree to 9.6e-16 relative at 200 points and 5 times
in the day; heyoka (``taylor_adaptive``, compact mode, tolerance eps = 2.2e-16, order 20, 647
steps) and em order 8 at dt = 60 s (1440 steps) end 1.2e-13 of a apart (0.8 micrometres), within
7.3e-14 and 4.8e-14 of a of heyoka in long double at tolerance 1e-18 (the bench's reference,
:mod:`emorbit.bench.gravity_field`); the Kepler orbit ends 1093 km away. The test takes 3.4 s
of CPU with heyoka's cache of compiled code filled and 6.5 s without it (the integrator
compiles in 2.2 s, the cfunc in 1.2 s); where Numba's cache is empty, the effect set's first
compile adds about 20 s.
"""

from __future__ import annotations

import numpy as np
import pytest

from emorbit import orbits
from emorbit.bench.gravity_field import heyoka_force, leo_state, simulation
from emorbit.kernels.effects.gravity_field import gravity_field_force, gravity_field_prepare

hy = pytest.importorskip("heyoka", reason='EGM2008 comes from heyoka: pip install "emorbit[field]"')

MU, RADIUS = float(hy.model.get_egm2008_mu()), float(hy.model.get_egm2008_a())
DAY = 86400.0


def _simulation(dt, order):
    """The bench's case (emorbit.bench.gravity_field: 20 x 20, rate and angle, the LEO point),
    its field effect and the start."""
    sim = simulation(20, dt, order)
    x, v, _ = leo_state(MU, RADIUS)
    return sim, sim.effects.named[0], x, v


def test_both_evaluate_the_same_acceleration():
    """200 points from 200 to 2000 km altitude at t = 0, 1234.5 s, a quarter day, 0.7 day and
    1 day: emorbit's force at a point (x0 = x1 after ``gravity_field_prepare(t, t, t)``) plus
    -mu x / r^3 against heyoka's cfunc of the rotated expression at the same time, to 1e-13
    relative (measured 9.6e-16)."""
    xyz, acc, _ = heyoka_force()
    cf = hy.cfunc(acc, xyz)
    _, effect, _, _ = _simulation(60.0, 8)
    p, tab = effect.p, effect.tab
    rng = np.random.default_rng(11)
    u = rng.normal(size=(200, 3))
    points = u / np.linalg.norm(u, axis=1)[:, None] * (RADIUS + rng.uniform(200e3, 2000e3, 200))[:, None]
    s = np.zeros(effect.scratch_size(1))
    worst = 0.0
    for t in (0.0, 1234.5, 0.25 * DAY, 0.7 * DAY, DAY):
        gravity_field_prepare(t, t, t, p, tab, s)
        theirs = cf(np.ascontiguousarray(points.T), time=np.full(len(points), t)).T
        for x, h in zip(points, theirs):
            f = np.array(gravity_field_force(*x, *x, p, tab, s)[:3]) - MU * x / np.linalg.norm(x) ** 3
            worst = max(worst, float(np.linalg.norm(f - h) / np.linalg.norm(h)))
    assert worst <= 1e-13, worst


def test_one_day_of_leo_agrees_with_heyoka():
    """1 day: em order 8 at dt = 60 s against heyoka's taylor_adaptive at tolerance eps with the
    same force, mu, radius, coefficients, rate and angle: the final positions within 1e-9 of a
    (measured 1.2e-13 of a, 0.8 micrometres) and the final velocities within 1e-9 of the speed
    (measured 1.2e-13); the field acts: the Kepler orbit ends over 100 km away (1093 km)."""
    sim, _, x0, v0 = _simulation(60.0, 8)
    steps = int(DAY / 60.0)
    res = sim.run(steps=steps, every=steps, progress=False)
    assert res.si.time[-1] == pytest.approx(DAY, rel=1e-15)
    xyz, acc, _ = heyoka_force()
    vx, vy, vz = hy.make_vars("vx", "vy", "vz")
    system = [(xyz[0], vx), (xyz[1], vy), (xyz[2], vz), (vx, acc[0]), (vy, acc[1]), (vz, acc[2])]
    ta = hy.taylor_adaptive(system, np.concatenate([x0, v0]), tol=2.0**-52, compact_mode=True)
    outcome = ta.propagate_until(DAY)
    assert outcome[0] == hy.taylor_outcome.time_limit
    x_em, v_em = res.si.positions["sat"][-1], res.si.velocities["sat"][-1]
    position = np.linalg.norm(x_em - ta.state[:3]) / leo_state(MU, RADIUS)[2]
    velocity = np.linalg.norm(v_em - ta.state[3:]) / np.linalg.norm(ta.state[3:])
    assert position <= 1e-9, position
    assert velocity <= 1e-9, velocity
    kepler = orbits.propagate(x0, v0, MU, DAY)[0]
    assert np.linalg.norm(kepler - ta.state[:3]) >= 100e3
