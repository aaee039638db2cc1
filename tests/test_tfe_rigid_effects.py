"""The rigid-body time finite element ("tfe") under effects at the gravity points
(emorbit.kernels.rigid_tfe_effects): observed orders under zonal terms and the Moon, agreement
with em, energy at round-off under static effects, the energy balance with the Moon and the
Sun, each third body's work against em's, adaptive steps that run back to the start, and the
refusal of effects on surfaces. Every run goes through Simulation, as a user's does."""

import numpy as np
import pytest
from shared_scenes import EARTH, EPOCH, MOON, R0, SUN, ZONAL

import emorbit
from emorbit.errors import InputError
from emorbit.integrators import get_method

#: the time finite element: its coefficients (Gauss weights) name the order
TFE = get_method("tfe")

EPS = np.finfo(float).eps


def box_sim(method, order, dt, effects, adaptive=None, gravity="volume", spin=1.0):
    """A 1 x 2 x 3 m box of 100 kg (8 mass points) tumbling at ``spin`` times 0.055 rad/s on an
    ellipse of e about 0.1 from 500 km, inclined 37 deg."""
    sim = emorbit.Simulation(EARTH, method=method, order=order, dt=dt, epoch=EPOCH, adaptive=adaptive)
    for kind, table in effects:
        sim.add_effect(kind, **table)
    v = 1.05 * float(np.sqrt(EARTH.gm / R0))
    sim.add_rigid(
        "box", "box", size=[1.0, 2.0, 3.0], mass=100.0, position=[R0, 0, 0], velocity=[0, 0.8 * v, 0.6 * v],
        angular_velocity=[0.01 * spin, 0.02 * spin, 0.05 * spin], gravity=gravity,
    )  # fmt: skip
    return sim


def run_to(sim, t_end, every=None):
    steps = int(round(t_end / sim.dt))
    res = sim.run(steps=steps, every=every or steps, progress=False)
    return res, sim.rigid.q[0].copy()


def attitude(qa, qb):
    """The angle between two attitudes (director states), rad."""
    Ra, Rb = qa[3:].reshape(3, 3).T, qb[3:].reshape(3, 3).T
    c = (np.trace(Ra.T @ Rb) - 1) / 2
    return float(np.arccos(np.clip(c, -1, 1)))


@pytest.mark.parametrize("order, dts", [(4, (40.0, 20.0, 10.0)), (6, (80.0, 40.0, 20.0))])
def test_observed_order_under_zonal_terms_and_the_moon(order, dts):
    """Over 6000 s under J2..J6 and the Moon, tumbling at 0.011 rad/s, against order 6 at a
    quarter of the smallest step: the centre converges at the order within 0.3 (measured 3.97,
    3.99 and 6.00, 5.87), the attitude at order 4 too (3.99, 4.00)."""
    eff = ZONAL + MOON
    _, ref = run_to(box_sim("tfe", 6, dts[-1] / 4, eff, spin=0.2), 6000.0)
    ends = [run_to(box_sim("tfe", order, dt, eff, spin=0.2), 6000.0)[1] for dt in dts]
    pos = [np.linalg.norm(q[:3] - ref[:3]) for q in ends]
    rates = np.log2(np.asarray(pos[:-1]) / np.asarray(pos[1:]))
    assert np.all(np.abs(rates - order) <= 0.3), pos
    if order == 4:
        att = [attitude(ref, q) for q in ends]
        rates = np.log2(np.asarray(att[:-1]) / np.asarray(att[1:]))
        assert np.all(np.abs(rates - order) <= 0.3), att


def test_agrees_with_em():
    """The same 6000 s under J2..J6 and the Moon, tumbling at 0.011 rad/s, with em order 6 at
    5 s and tfe order 6 at 20 s: the centres agree within 1e-8 of what the effects move the
    box (measured 4.0e-7 m of 105 km) and the attitudes within 1e-2 of what the effects turn
    it (measured 4.0e-6 of 2.0e-3 rad, em's own error at 5 s): the kernels apply the same
    forces and torques at the gravity points."""
    eff = ZONAL + MOON
    _, em = run_to(box_sim("em", 6, 5.0, eff, spin=0.2), 6000.0)
    _, tfe = run_to(box_sim("tfe", 6, 20.0, eff, spin=0.2), 6000.0)
    _, bare = run_to(box_sim("tfe", 6, 20.0, [], spin=0.2), 6000.0)
    moved = np.linalg.norm(bare[:3] - tfe[:3])
    turned = attitude(bare, tfe)
    assert moved > 1e4 and turned > 1e-3
    assert np.linalg.norm(em[:3] - tfe[:3]) <= 1e-8 * moved
    assert attitude(em, tfe) <= 1e-2 * turned


@pytest.mark.parametrize("order", [4, 6])
def test_energy_under_zonal_terms_over_1e4_large_steps(order):
    """1e4 steps of 60 s (about 105 orbits, a turn of 3.3 rad per step) under J2..J6: energy
    within 2e-13 (measured 5.2e-14 and 1.4e-14 at orders 4 and 6), the angular momentum about
    the pole within 1e-13 of |L| (8.9e-16, 5.3e-15) while L_x, L_y turn with the node (0.3)."""
    res, _ = run_to(box_sim("tfe", order, 60.0, ZONAL), 6e5, every=100)
    err = np.abs(res.relative_energy_error()).max()
    assert err <= 2e-13, err
    L = res.angular_momentum.value
    assert np.abs(L[:, 2] - L[0, 2]).max() <= 1e-13 * np.linalg.norm(L[0])
    assert np.abs(L[:, :2] - L[0, :2]).max() > 0.1 * np.linalg.norm(L[0])


@pytest.mark.parametrize("order", [4, 6])
def test_energy_balance_with_the_moon_and_the_sun(order):
    """1e4 steps of 60 s under J2..J6, the Moon and the Sun: |E - E0 - W| / |E0| within 2e-13
    (measured 5.5e-14 and 1.3e-14 at orders 4 and 6), while the third bodies' work reaches
    7.8e-9 (the Moon) and 5.3e-10 (the Sun) of |E0|."""
    res, _ = run_to(box_sim("tfe", order, 60.0, ZONAL + MOON + SUN), 6e5, every=100)
    balance = np.abs(res.relative_energy_balance()).max()
    assert balance <= 2e-13, balance
    e0 = abs(res.energy[0].value)
    work = {k: np.abs(w.value).max() / e0 for k, w in res.work.items()}
    assert len(work) == 2 and min(work.values()) > 1e3 * balance, work


def test_work_of_each_third_body_agrees_with_em():
    """Each third body's work over 6000 s, tfe order 6 at 20 s against em order 4 at 5 s: within
    1e-6 of its size (measured 6.4e-11 the Moon, 6.1e-10 the Sun): the rows are each
    effect's own, and a potential's change in time is summed to the method's order."""
    a, _ = run_to(box_sim("tfe", 6, 20.0, MOON + SUN, spin=0.2), 6000.0)
    b, _ = run_to(box_sim("em", 4, 5.0, MOON + SUN, spin=0.2), 6000.0)
    assert set(a.work) == set(b.work) and len(a.work) == 2
    for k in a.work:
        wa, wb = a.work[k][-1].value, b.work[k][-1].value
        assert abs(wa - wb) <= 1e-6 * abs(wb) and abs(wb) > 0, (k, wa, wb)


@pytest.mark.parametrize("order", [4, 6])
def test_adaptive_steps_under_j2_and_the_moon_run_back_to_the_start(order):
    """100 adaptive steps (eta 0.05) forth, velocities reversed, 100 back: the state returns
    within 1e3 eps n of its scale (measured 0.11 and 0.47 eps n in position, 0.23 and 0.75 in
    velocity at orders 4 and 6), the time too (0.02, 0.71)."""
    sim = box_sim("tfe", order, 60.0, ZONAL[:1] + MOON, adaptive=0.05)
    sim.run(steps=1, progress=False)  # binds the effects
    rb = sim.rigid
    q0, v0 = rb.q.copy(), rb.v.copy()
    gammas = TFE.coefficients(order)
    n = 100
    t = rb.reversible_steps("tfe", sim.gm, sim.center, gammas, n, 50)[0]
    rb.v[:], rb.cv[:] = -rb.v, -rb.cv
    back = rb.reversible_steps("tfe", sim.gm, sim.center, gammas, n, 50)[0]
    tol = 1e3 * EPS * n
    assert abs(back - t) <= tol * t
    assert np.abs(rb.q - q0).max() <= tol * np.abs(q0).max()
    assert np.abs(-rb.v - v0).max() <= tol * np.abs(v0).max()


def test_adaptive_steps_keep_the_balance():
    """Adaptive steps (eta 0.05) over 3e4 s under J2..J6, the Moon and the Sun: the balance
    within 2e-14 (measured 5.5e-16)."""
    res, _ = run_to(box_sim("tfe", 4, 60.0, ZONAL + MOON + SUN, adaptive=0.05), 3e4, every=50)
    assert np.abs(res.relative_energy_balance()).max() <= 2e-14


def test_refuses_effects_on_surfaces():
    """Radiation pressure acts on a rigid body's facets, which tfe's stages do not take: an
    InputError naming the method, the effect and the surfaces; on a point mass it runs."""
    sim = box_sim("tfe", 4, 60.0, [("srp", dict(shadow="none"))])
    with pytest.raises(InputError) as info:
        sim.run(steps=1, progress=False)
    assert info.value.key == "method" and "srp" in str(info.value) and "surfaces" in str(info.value)
