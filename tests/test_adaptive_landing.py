"""Adaptive steps land their records exactly on their times (``Simulation(adaptive=eta)``: "records
land exactly on multiples of every * dt"), checked through the public API on an orbit whose
discrete motion is known in closed form.

em keeps a circular orbit circular: its energy and angular momentum fix r and v, so a step of
h turns the state by phi(h) = 2 atan(omega h / 2) (from x1 = x0 + h v0 + h^2/2 g_em with
g_em = -GM (x0 + x1) / (2 r^3)), and steps of any sizes that add up to D turn it by
sum phi(h_k). On a circle the adaptive control keeps every step at eta times the orbital period
(the local Kepler time 2 pi sqrt(r^3 / GM)); with D an integer number k of such steps, each
landing interval turns the state by k phi(D / k), and the equal steps make that insensitive to
the rounding of each step's size (only the sum matters, at first order). A landing interval
that lasted D plus a rounding, by an error in the compensated sum of its steps' durations,
turns it by omega times that rounding more, every interval: over 10 intervals of 1000 orbits
the phase then leaves the closed form by 1e-12 rad and more.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

import emorbit

#: steps an orbit (eta = 1 / S) on the unit circle, GM = 1
STEPS_PER_ORBIT = [5, 7, 8, 11, 13]
#: orbits per landing interval, landing intervals
ORBITS, INTERVALS = 1000, 10


def _rotation(k: int, interval: float) -> float:
    """The closed-form turn of one landing interval, k equal em steps over ``interval`` on the
    unit circle (omega = 1), less the whole turns, in [-pi, pi)."""
    with mpmath.workdps(40):
        turn = k * 2 * mpmath.atan(mpmath.mpf(interval) / k / 2)
        return float((turn + mpmath.pi) % (2 * mpmath.pi) - mpmath.pi)


@pytest.mark.parametrize("per_orbit", STEPS_PER_ORBIT)
def test_adaptive_records_land_on_their_times(per_orbit):
    """A circular orbit at eta = 1 / S (S = 5 to 13 steps an orbit), recorded at landings every
    1000 orbits, 10 times: at every record the phase is the closed form's (k = 1000 S equal em
    steps an interval, each turning by 2 atan(omega h / 2)) to round-off. Measured: at most
    5.0e-14, 6.4e-14, 8.9e-14, 6.8e-14, 4.5e-14 rad for S = 5, 7, 8, 11, 13 over 6.3e4 rad
    (1.4e-18 of the phase); bound 4e-13. With the remaining time of each interval taken with
    its compensation's sign flipped, the records land off their times by a rounding of D each
    interval: 1.2e-12 to 2.9e-12 rad."""
    interval = ORBITS * 2 * np.pi
    sim = emorbit.Simulation(emorbit.CentralField(gm=1.0), method="em", dt=interval, adaptive=1.0 / per_orbit)
    sim.add_point("p", mass=1.0, position=[1.0, 0.0, 0.0], velocity=[0.0, 1.0, 0.0])
    res = sim.run(steps=INTERVALS, every=1, progress=False).si
    np.testing.assert_array_equal(res.time, np.arange(INTERVALS + 1) * interval)
    x = res.positions["p"]
    assert np.max(np.abs(np.linalg.norm(x, axis=1) - 1.0)) <= 4e-13  # still the unit circle (measured 3.9e-14)
    # each interval's turn, from consecutive records (atan2 of cross and dot: exact to a rounding)
    a, b = x[:-1], x[1:]
    turn = np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], np.einsum("rk,rk->r", a, b))
    phase = np.cumsum(turn - _rotation(ORBITS * per_orbit, interval))
    worst = np.max(np.abs(phase))
    assert worst <= 4e-13, f"S = {per_orbit}: the phase leaves the closed form by {worst:.3g} rad"
