"""The energy-momentum time finite element for rigid bodies ("tfe", orders 4 and 6 in one
solve of 2 or 3 Gauss stages; emorbit.kernels.rigid_tfe): observed orders torque-free and in
orbit, energy, angular momentum and the axes' orthonormality at large steps, time symmetry.
Every run goes through Simulation, as a user's does; the bodies are the rigid-precision
bench's (emorbit.bench.rigid_cases)."""

import numpy as np
import pytest

from emorbit.bench.rigid_cases import FAST_OMEGA, free_sim, leo_sim
from emorbit.bench.rigid_precision import attitude_angle
from emorbit.integrators import get_method

#: the time finite element: its coefficients (Gauss weights) name the order
TFE = get_method("tfe")

EPS = np.finfo(float).eps


def end_state(sim, t_end, every=None):
    """Run ``sim`` to ``t_end`` s; returns the result and the body's (q, v) at the end."""
    steps = int(round(t_end / sim.dt))
    res = sim.run(steps=steps, every=every or steps, progress=False)
    return res, sim.rigid.q[0].copy(), sim.rigid.v[0].copy()


def axes(q):
    """R = [d1 d2 d3] from a director state."""
    return q[3:].reshape(3, 3).T


def rates(errors):
    return np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:]))


@pytest.mark.parametrize("order", [4, 6])
def test_observed_order_torque_free(order):
    """The box tumbling at 5 rad/s about its intermediate axis over 10 s, dt = 0.1, 0.05 and
    0.025 s, against order 6 at dt/4: the attitude converges at the order (measured 3.98 and
    4.00 at order 4; 5.99 and 6.00 at order 6)."""
    _, ref, _ = end_state(free_sim(0.025 / 4, FAST_OMEGA, method="tfe", order=6), 10.0)
    errs = [
        attitude_angle(axes(ref), axes(end_state(free_sim(dt, FAST_OMEGA, method="tfe", order=order), 10.0)[1]))
        for dt in (0.1, 0.05, 0.025)
    ]
    assert np.all(np.abs(rates(errs) - order) <= 0.3), errs


@pytest.mark.parametrize("order, dts", [(4, (30.0, 15.0, 7.5)), (6, (60.0, 30.0, 15.0))])
def test_observed_order_in_orbit(order, dts):
    """The 8-point box in a 7000 km orbit over 6000 s, gravity gradient included: the centre
    converges at the order against order 6 at a quarter of the smallest step (measured 4.00
    and 4.00; 6.01 and 5.97), and the attitude at order 4 (4.00, 3.91)."""
    _, ref, _ = end_state(leo_sim(1, dts[-1] / 4, method="tfe", order=6), 6000.0)
    ends = [end_state(leo_sim(1, dt, method="tfe", order=order), 6000.0)[1] for dt in dts]
    pos = [np.linalg.norm(q[:3] - ref[:3]) for q in ends]
    assert np.all(np.abs(rates(pos) - order) <= 0.3), pos
    if order == 4:  # order 6 reaches the torque's round-off floor (about 1e-10 rad) first
        att = [attitude_angle(axes(ref), axes(q)) for q in ends]
        assert np.all(np.abs(rates(att) - order) <= 0.3), att


@pytest.mark.parametrize("order", [4, 6])
def test_invariants_over_1e5_large_steps_torque_free(order):
    """1e5 steps of 0.2 s at 5 rad/s (one radian per step): energy and angular momentum within
    1e-12 (measured 8.8e-14 and 4.2e-14 at order 4, 7.7e-14 and 4.3e-14 at order 6), the
    axes orthonormal to 4 eps (measured 1 eps)."""
    res, q, _ = end_state(free_sim(0.2, FAST_OMEGA, method="tfe", order=order), 2e4, every=10_000)
    assert np.abs(res.relative_energy_error()).max() <= 1e-12
    assert np.abs(res.relative_angular_momentum_error()).max() <= 1e-12
    R = axes(q)
    assert np.abs(R.T @ R - np.eye(3)).max() <= 4 * EPS


@pytest.mark.parametrize("order, dt", [(4, 120.0), (6, 240.0)])
def test_invariants_in_orbit_at_large_steps(order, dt):
    """Steps of 1/50 and 1/25 of the orbit, 2000 of them: energy and angular momentum about the
    centre within 5e-13 (measured 2.1e-13 and 2.7e-14 at order 4, 3.3e-14 and 1.7e-14 at
    order 6)."""
    sim = leo_sim(1, dt, method="tfe", order=order)
    res, _, _ = end_state(sim, 2000 * dt, every=200)
    assert np.abs(res.relative_energy_error()).max() <= 5e-13
    assert np.abs(res.relative_angular_momentum_error()).max() <= 5e-13


@pytest.mark.parametrize("case", ["free", "orbit"])
def test_time_symmetric(case):
    """n = 500 steps forward, the velocities reversed, n steps back: the start returns within
    1e3 eps n = 1.1e-10 (measured 1.0e-12 of the state torque-free, 2.5e-13 in orbit at
    1/50 of the orbit per step: Newton's factors, kept from step to step, take another path
    back, within its tolerance)."""
    n = 500
    sim = (
        free_sim(0.05, FAST_OMEGA, method="tfe", order=6)
        if case == "free"
        else leo_sim(1, 120.0, method="tfe", order=6)
    )
    rb = sim.rigid
    q0, v0 = rb.q[0].copy(), rb.v[0].copy()
    sim.run(steps=n, every=n, progress=False)
    rb.v[...] *= -1.0
    rb.cv[...] *= -1.0
    sim.run(steps=n, every=n, progress=False)
    scale_q = np.abs(q0).max()
    scale_v = np.abs(v0).max()
    dq = np.abs(rb.q[0] - q0).max() / scale_q
    dv = np.abs(-rb.v[0] - v0).max() / scale_v
    assert dq <= 1e3 * EPS * n and dv <= 1e3 * EPS * n, (dq, dv)


def _adaptive(sim, eta):
    sim.plan = sim.plan.with_(adaptive=eta)
    sim.rigid.plan = sim.plan
    return sim


@pytest.mark.parametrize(
    "case, order, eta", [("free", 4, 0.01), ("free", 6, 0.01), ("orbit", 4, 0.005), ("orbit", 6, 0.01)]
)
def test_adaptive_steps_run_back_to_the_start(case, order, eta):
    """n = 200 adaptive steps (one element step between the controller's kicks), the
    velocities reversed, n steps back: the start within 1e3 eps n and the elapsed times equal
    to the same (measured 0.15 and 0.21 eps n torque-free at orders 4 and 6, 34 and 90 eps n in
    orbit; the times within 0, 0, 9.0 and 12 eps n). In the circular orbit order 4 takes eta 0.005 (steps of about
    h n = 0.03): beyond about h n = 0.05 its fixed steps there are not time-symmetric either
    (the energy correction's secant settles on another nu back than forth)."""
    n = 200
    sim = (
        free_sim(0.05, FAST_OMEGA, method="tfe", order=order)
        if case == "free"
        else leo_sim(1, 120.0, method="tfe", order=order)
    )
    sim = _adaptive(sim, eta)
    rb, gm, c = sim.rigid, sim.gm, sim.center
    q0, v0 = rb.q[0].copy(), rb.v[0].copy()
    t1 = rb.reversible_steps("tfe", gm, c, TFE.coefficients(order), n, 50)[0]
    rb.v[...] *= -1.0
    rb.cv[...] *= -1.0
    t2 = rb.reversible_steps("tfe", gm, c, TFE.coefficients(order), n, 50)[0]
    dq = np.abs(rb.q[0] - q0).max() / np.abs(q0).max() / (EPS * n)
    dv = np.abs(-rb.v[0] - v0).max() / np.abs(v0).max() / (EPS * n)
    assert dq <= 1e3 and dv <= 1e3, (dq, dv)
    assert abs(t1 - t2) <= 1e3 * EPS * n * t1


@pytest.mark.parametrize("order", [4, 6])
def test_adaptive_steps_converge_and_keep_the_invariants(order):
    """The box tumbling at 5 rad/s over 10 s with adaptive steps, eta 0.02, 0.01, 0.005 (order
    4) and 0.04, 0.02, 0.01 (order 6), against fixed order-6 steps of 0.025 / 4 s: the
    attitude converges at the order in eta (measured 3.99, 3.99 and 5.98, 5.91), energy and
    angular momentum within 1e-14 (measured at most 3.4e-16 and 3.1e-16)."""
    _, ref, _ = end_state(free_sim(0.025 / 4, FAST_OMEGA, method="tfe", order=6), 10.0)
    errs = []
    for eta in (0.02, 0.01, 0.005) if order == 4 else (0.04, 0.02, 0.01):
        sim = _adaptive(free_sim(1.0, FAST_OMEGA, method="tfe", order=order), eta)
        res, q, _ = end_state(sim, 10.0)
        assert np.abs(res.relative_energy_error()).max() <= 1e-14
        assert np.abs(res.relative_angular_momentum_error()).max() <= 1e-14
        errs.append(attitude_angle(axes(ref), axes(q)))
    assert np.all(np.abs(rates(errs) - order) <= 0.5), errs
