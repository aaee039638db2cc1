"""Time finite elements (``method = "tfe"``) for structures with rigid bodies: a box with a boom
of tetrahedra clamped to it (the axes held by velocity constraints at the stages). Observed
orders 4 and 6, the shipped coupled-boom scene's invariants and axes at its own large steps,
time symmetry, adaptive steps, and Newton's bordered matrix against finite differences."""

import functools

import numpy as np
import pytest
from test_tfe_elastic import forth_and_back

from emorbit.bench.elastic_precision import bus_boom as _bus_boom
from emorbit.bodies.structure_tfe import StructureTFE
from emorbit.integrators import get_method
from emorbit.integrators.dispatch import tfe_tables
from emorbit.scene import load_scene, parse_scene

#: the time finite element: its coefficients (Gauss weights) name the order
TFE = get_method("tfe")


def _end(dt, order, t=1.0):
    """Slots, slot velocities, the box's angular velocity (rad/s) after t, and the result."""
    sim = _bus_boom(dt, order)
    n = int(round(t / dt))
    res = sim.run(steps=n, every=n, progress=False)
    st = sim.structure
    return st.u - st.cu, st.v - st.cv, res.angular_velocities["bus"][-1].value, res


@functools.lru_cache(maxsize=1)
def _reference():
    return _end(0.000625, 6)


@pytest.mark.parametrize("order", [4, 6])
def test_observed_order_bus_and_boom(order):
    """Over 1 s at steps of 10 and 5 ms against order 6 at 0.625 ms: positions (the axes
    included), velocities and the box's angular velocity converge at the order (measured 3.90,
    4.19, 4.11 at order 4; 5.94, 5.96, 5.98 at order 6); energy and angular momentum within
    1e-15 (measured 2.3e-16)."""
    ref = _reference()
    errs = []
    for dt in (0.01, 0.005):
        u, v, w, res = _end(dt, order)
        errs.append([np.abs(u - ref[0]).max(), np.abs(v - ref[1]).max(), np.abs(w - ref[2]).max()])
        assert np.abs(res.relative_energy_error()).max() <= 1e-15
        assert res.relative_angular_momentum_error().max() <= 1e-15
    rates = np.log2(np.array(errs[0]) / np.array(errs[1]))
    assert np.all(np.abs(rates - order) <= 0.3), (errs, rates)


def _axes(sim):
    st = sim.structure
    d = (st.u - st.cu)[st.rb_slots[0, 1:]]
    return np.abs(d @ d.T - np.eye(3)).max()


@pytest.mark.parametrize("order", [4, 6])
def test_coupled_boom_scene_at_its_steps(order):
    """The shipped ``satellite-flexible-boom`` (a 10-cell boom, E = 1 GPa, clamped to a box in
    a 7000 km orbit; its stiffest modes near 1e4 rad/s) at its own 0.2 s steps, 100 of them:
    every Newton iteration converges to round-off (no step redone in halves), energy and
    angular momentum within 2e-15 (measured 3.0e-16 at both orders, 4.9e-16 at both), the box's
    axes orthonormal within 1e-15 (measured 1.6e-17 and 1.1e-16)."""
    text = load_scene("satellite-flexible-boom").text.replace('method = "em"', f'method = "tfe"\norder = {order}')
    sim = parse_scene(text).build()
    res = sim.run(steps=100, every=20, progress=False)
    assert res.split_steps.sum() == 0
    assert np.abs(res.relative_energy_error()).max() <= 2e-15
    assert res.relative_angular_momentum_error().max() <= 2e-15
    assert _axes(sim) <= 1e-15


@pytest.mark.long
def test_coupled_boom_scene_over_1e5_steps():
    """The shipped ``satellite-flexible-boom`` at order 4 over 1e5 of its 0.2 s steps (5.6 h,
    3.4 orbits; about 30 minutes): no step redone in halves, energy and angular momentum within
    1e-14 (measured 1.0e-15 and 4.9e-16, 7.2 Newton iterations per step)."""
    text = load_scene("satellite-flexible-boom").text.replace('method = "em"', 'method = "tfe"\norder = 4')
    res = parse_scene(text).build().run(steps=100_000, every=10_000, progress=False)
    assert res.split_steps.sum() == 0
    assert np.abs(res.relative_energy_error()).max() <= 1e-14
    assert res.relative_angular_momentum_error().max() <= 1e-14


@pytest.mark.parametrize("order", [4, 6])
def test_time_symmetric(order):
    """n = 100 steps of 20 ms (the boom at young = 1e6 Pa, h w_max about 6) forward, the
    velocities reversed, n back: the start returns within 1e3 eps n (measured 0.06 and 0.03 eps n
    in position, 12.8 and 12.6 eps n in velocity)."""
    du, dv = forth_and_back(_bus_boom(0.02, order, young=1e6), 100)
    assert du <= 1e3 and dv <= 1e3, (du, dv)


@pytest.mark.parametrize("order", [4, 6])
def test_adaptive_steps(order):
    """Adaptive steps (eta = 0.1; the boom's modes set them: 180 steps in 1 s) keep energy and
    angular momentum at round-off (measured 1.1e-16 and 0, 2.4e-16 and 3.5e-16); 30 steps
    forth and back return within 1e3 eps n (measured 0.03 and 0.02 eps n in position, 2.0 and
    3.1 in velocity), in the same time."""
    sim = _bus_boom(0.1, order, adaptive=0.1)
    res = sim.run(steps=10, every=5, progress=False)
    st = sim.structure
    assert st.adaptive_steps >= 100
    assert res.split_steps.sum() == 0
    assert np.abs(res.relative_energy_error()).max() <= 2e-15
    assert res.relative_angular_momentum_error().max() <= 2e-15
    n, eps = 30, np.finfo(float).eps
    u0, v0 = st.u.copy(), st.v.copy()
    t1 = st.reversible_steps("tfe", 0.0, np.zeros(3), TFE.coefficients(order), n, 50)
    st.v[...] *= -1.0
    st.cv[...] *= -1.0
    t2 = st.reversible_steps("tfe", 0.0, np.zeros(3), TFE.coefficients(order), n, 50)
    assert np.abs(st.u - u0).max() / np.abs(u0).max() <= 1e3 * eps * n
    assert np.abs(-st.v - v0).max() / np.abs(v0).max() <= 1e3 * eps * n
    assert abs(t1 - t2) <= 1e3 * eps * n * t1


@pytest.mark.parametrize("order", [4, 6])
def test_newton_matrix_matches_finite_differences(order):
    """Newton's matrix, bordered by the axes' constraints, against central differences of the
    stage equations at perturbed stage velocities and multipliers: measured 3.6e-10 of its
    largest entry at both orders."""
    sim = _bus_boom(0.02, order, young=1e6)
    sim.run(steps=2, every=2, progress=False)
    st = sim.structure
    tfe = StructureTFE(st, tfe_tables(TFE.coefficients(order)), 0.0, np.zeros(3))
    u0, ref = st.relative(st.u, st.cu)
    x0n = tfe._nodes(u0[None])[0]
    p0 = tfe._gravity_points(x0n[None])[0] + ref
    rng = np.random.default_rng(1)
    h = 0.05
    V = st.v[None] + 0.01 * rng.standard_normal((tfe.k,) + st.v.shape) * np.abs(st.v).max()
    lam = 100.0 * rng.standard_normal((tfe.k, tfe.nc))
    x = np.concatenate([V.ravel(), lam.ravel()])

    def residual(x):
        return tfe.residual(u0, st.v, x0n, p0, x[: V.size].reshape(V.shape), x[V.size :].reshape(lam.shape), h)[0]

    J = tfe.residual(u0, st.v, x0n, p0, V, lam, h, True)[2].toarray()
    fd = np.empty_like(J)
    for c in range(x.size):
        d = 1e-6 * max(abs(x[c]), 1.0)
        e = np.zeros(x.size)
        e[c] = d
        fd[:, c] = (residual(x + e) - residual(x - e)) / (2 * d)
    assert np.abs(J - fd).max() <= 1e-7 * np.abs(fd).max()
