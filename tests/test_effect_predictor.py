"""em's first guess and one-update stop for point masses under an effect set.

The effect step (:mod:`emorbit.kernels.pointmass.effect_step`) starts em's Newton iteration
from the central field's step as a series plus the rest of the last sub-step's w, and stops
after one sweep where every effect's Jacobian is exact or leaves out a bounded part and the
remainder bound is below 1e-3 eps. These tests show that the series is the central em step,
that a LEO ensemble under the Moon, the Sun and J2 then takes one sweep per sub-step, that the
result is the two-sweep iteration's to round-off with the same energy balance, and that an
effect whose Jacobian is unknown keeps the two-sweep rule.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from sweep_support import assert_one_sweep_matches_two

import emorbit
from emorbit.effects.srp import RadiationPressure
from emorbit.effects.third_body import ThirdBody
from emorbit.errors import InputError
from emorbit.kernels.pointmass.effect_step import _central_w

GM = 3.986004418e14
R_LEO = 6878.1366e3
PERIOD = 2 * math.pi * math.sqrt(R_LEO**3 / GM)
EPOCH = "2026-03-20T00:00:00 TDB"


def _em_central(x0, v0, h):
    """The central em step's w, iterated to a fixed point (60 iterations: far below round-off)."""
    w = np.zeros(3)
    r0 = np.linalg.norm(x0)
    for _ in range(60):
        x1 = x0 + h * v0 + w
        r1 = np.linalg.norm(x1)
        w = 0.5 * h * h * (-GM * (x0 + x1) / (r0 * r1 * (r0 + r1)))
    return w


@pytest.mark.parametrize("e, nu", [(0.0, 0.3), (0.02, 1.7), (0.02, 4.0)])
def test_series_is_the_central_em_step_both_ways(e, nu):
    """At T/1000 in LEO the series is the central em step to 2e-11 of the increment (measured
    3.1e-13 on the circle, 1.0e-11 at e = 0.02), forwards and backwards; the em step back from
    a step's end over -h is that step's w (its discrete force is symmetric in its ends), so
    wp minus the backward series is the other effects' part of wp."""
    a = R_LEO / (1 - e)
    p = a * (1 - e * e)
    r = p / (1 + e * math.cos(nu))
    x0 = r * np.array([math.cos(nu), math.sin(nu), 0.0])
    v0 = math.sqrt(GM / p) * np.array([-math.sin(nu), e + math.cos(nu), 0.0])
    h = PERIOD / 1000
    size = np.linalg.norm(h * v0)
    for step in (h, -h):
        want = _em_central(x0, v0, step)
        ir2 = 1.0 / (x0 @ x0)
        got = np.array(_central_w(*x0, *v0, ir2, ir2 * math.sqrt(ir2), x0 @ v0, v0 @ v0, GM, step))
        assert np.linalg.norm(got - want) <= 2e-11 * size
    w = _em_central(x0, v0, h)  # one step, then back from its end
    x1, v1 = x0 + h * v0 + w, v0 + 2 * w / h
    assert np.linalg.norm(_em_central(x1, v1, -h) - w) <= 1e-15 * size


def _ensemble(n=12, seed=5):
    rng = np.random.default_rng(seed)
    xs, vs = [], []
    for _ in range(n):
        a = rng.uniform(R_LEO, 2 * R_LEO)
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        nu = rng.uniform(0, 2 * math.pi)
        xs.append(q @ (a * np.array([math.cos(nu), math.sin(nu), 0.0])))
        vs.append(q @ (math.sqrt(GM / a) * np.array([-math.sin(nu), math.cos(nu), 0.0])))
    return xs, vs


def _run(steps, method="em"):
    sim = emorbit.Simulation(emorbit.CentralField(body="earth"), method=method, order=2, dt=PERIOD / 1000, epoch=EPOCH)
    sim.add_effect("zonal", model="earth", degree=2)
    sim.add_effect("third_body", body="moon")
    sim.add_effect("third_body", body="sun")
    for k, (x, v) in enumerate(zip(*_ensemble())):
        sim.add_point(f"p{k}", mass=1.0, position=x, velocity=v)
    res = sim.run(steps=steps, every=steps // 4, progress=False).si
    return np.array([res.positions[f"p{k}"][-1] for k in range(12)]), res


def test_one_sweep_per_substep_and_the_two_sweep_result(monkeypatch):
    """Twelve points from LEO to 2 LEO radii under J2, the Moon and the Sun, 2000 em steps of
    T/1000: one sweep per sub-step, but for the first step (whose first guess lacks J2's part:
    there is no last w yet). With the third body's Jacobian declared unknown the iteration
    takes two sweeps, and the positions agree to 1e-14 of the orbit radius (measured 6e-16);
    the energy balance of both stays within 2e-15 of |E0| (measured 3.2e-16 and 4.4e-16)."""
    one = _run(2000)
    assert np.asarray(one[1].newton_iterations)[1] == pytest.approx(1.0 + 1 / 500, abs=1e-12)
    monkeypatch.setattr(ThirdBody, "JACOBIAN_LEFT_OUT", math.inf)
    assert_one_sweep_matches_two(one, _run(2000), R_LEO)


def _srp_run(steps, shadow="conical", coefficient=1.0):
    sim = emorbit.Simulation(emorbit.CentralField(body="earth"), method="em", order=2, dt=PERIOD / 1000, epoch=EPOCH)
    sim.add_effect("srp", shadow=shadow)
    for k, (x, v) in enumerate(zip(*_ensemble(6, seed=8))):
        sim.add_point(f"p{k}", mass=1.0, position=x, velocity=v, radiation_coefficient=coefficient)
    res = sim.run(steps=steps, every=steps // 4, progress=False).si
    return np.array([res.positions[f"p{k}"][-1] for k in range(6)]), res


def test_srp_with_its_jacobian_takes_one_sweep_through_the_penumbra(monkeypatch):
    """Six sail-like points (Cr A / m = 1 m^2/kg) from LEO to 2 LEO radii under radiation
    pressure with the conical shadow, 3000 em steps of T/1000 (three of them pass the shadow
    each orbit: 34 step ends lie in the penumbra): J holds the shadow's gradient, so each
    sub-step after the first takes one sweep. Declared unknown, the step takes two, and the
    positions agree to 1e-14 of the orbit radius (measured 4.1e-16); both keep the energy
    balance within 2e-15 of |E0| (measured 1.9e-16 and 2.7e-16). The cylindrical shadow,
    whose edge is a jump, keeps the two-sweep stop."""
    one = _srp_run(3000)
    monkeypatch.setattr(RadiationPressure, "jacobian_left_out", lambda self: math.inf)
    assert_one_sweep_matches_two(one, _srp_run(3000), R_LEO)
    monkeypatch.undo()
    _, res3 = _srp_run(200, shadow="cylindrical")
    assert np.all(np.asarray(res3.newton_iterations)[1:] >= 2.0)


def test_an_effects_own_bound_is_checked(monkeypatch):
    """A bound an effect gives at run time (:meth:`Effect.jacobian_left_out`) that is negative
    would let the stop ignore the left-out part: the run refuses it, naming the effect."""
    monkeypatch.setattr(ThirdBody, "jacobian_left_out", lambda self: -1.0)
    with pytest.raises(InputError, match="a number >= 0 expected") as exc:
        _run(8)
    assert exc.value.key == "effect[1].jacobian_left_out()"  # the Moon, the set's second effect


def test_midpoint_keeps_its_own_stopping_rule():
    """The one-update stop is em's: the midpoint rule's equations differ from the series', and it
    iterates to its own test (two sweeps or more)."""
    _, res = _run(200, method="midpoint")
    assert np.all(np.asarray(res.newton_iterations)[1:] >= 2.0)
