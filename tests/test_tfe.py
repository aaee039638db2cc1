"""The energy-momentum time finite element ("tfe", orders 4 and 6 in one solve of 2 or 3
Gauss stages; emorbit.kernels.pointmass.tfe) on the paper's ellipse (e = 2/3): observed
orders, exact energy and angular momentum at large steps, time symmetry, and the inputs it
refuses. Every run goes through the kernel that dispatch names for the method, as
PointMasses.advance calls it."""

import importlib.resources

import numpy as np
import pytest
from conftest import PAPER_GM, PAPER_T, PAPER_V0, PAPER_X0

import emorbit
from emorbit import orbits
from emorbit.errors import InputError
from emorbit.integrators import METHODS, check_method_order, coefficients, dispatch, get_method
from emorbit.kernels.codes import STATUS_OK
from emorbit.kernels.pointmass import tfe

#: the time finite element: its coefficients (Gauss weights) name the order
TFE = get_method("tfe")

EPS = np.finfo(float).eps


def run(order, dt, steps, every=None, x0=PAPER_X0, v0=PAPER_V0, center=(0.0, 0.0, 0.0)):
    """``steps`` steps of tfe at ``order`` from (x0, v0): (x, v) records (nrec, 3), Newton
    iterations per record, the end state."""
    code, chunk = dispatch.point_chunk("tfe")
    every = every or steps
    nrec = steps // every
    x = np.array(x0, float).reshape(3, 1) + np.reshape(center, (3, 1))
    v = np.array(v0, float).reshape(3, 1).copy()
    cx, cv = np.zeros((3, 1)), np.zeros((3, 1))
    rx, rv = np.empty((nrec, 3, 1)), np.empty((nrec, 3, 1))
    its, fail = np.zeros((nrec, 1), np.int64), np.full((1, 2), -1, np.int64)
    chunk(
        code,
        x,
        v,
        cx,
        cv,
        PAPER_GM,
        np.asarray(center, float),
        dt,
        TFE.coefficients(order),
        every,
        nrec,
        50,
        rx,
        rv,
        its,
        fail,
    )
    assert fail[0, 0] == -1, f"step {fail[0, 0]} failed with status {fail[0, 1]}"
    return rx[:, :, 0], rv[:, :, 0], its[:, 0], (x[:, 0], v[:, 0])


def adaptive_errors(order, e, n_orbits, etas):
    """The final position errors of a point (a = 1, GM = 1, from apoapsis) after ``n_orbits``
    orbits of adaptive tfe steps at each eta, against Kepler; each run's energy within 1e-15 of E."""
    x0, v0 = orbits.state_from_elements((1.0, e, 0.3, 0.2, 0.1, np.pi), 1.0)
    ref, _ = orbits.propagate(x0, v0, 1.0, 2 * np.pi * n_orbits)
    errors = []
    for eta in etas:
        sim = emorbit.Simulation(emorbit.CentralField(gm=1.0), method="tfe", order=order, dt=2 * np.pi, adaptive=eta)
        sim.add_point("p", mass=1.0, position=x0, velocity=v0)
        res = sim.run(steps=n_orbits, every=n_orbits, progress=False)
        assert np.abs(res.relative_energy_error()).max() <= 1e-15
        errors.append(np.linalg.norm(res.si.positions["p"][-1] - ref))
    return np.array(errors)


def energy(x, v):
    return 0.5 * np.einsum("...k,...k", v, v) - PAPER_GM / np.linalg.norm(x, axis=-1)


@pytest.mark.parametrize("order", [4, 6])
def test_observed_order(order):
    """Position error after one orbit against the Kepler solution at T/100 ... T/800 (the
    periapsis on a step boundary in every run). Measured slopes 3.95 (order 4: 5.8e-3 ...
    1.6e-6) and 5.77 (order 6: 1.6e-5 ... 9.9e-11); the fit must lie within 0.3 of 2k."""
    ref, _ = orbits.propagate(PAPER_X0, PAPER_V0, PAPER_GM, PAPER_T)
    divs = [100, 200, 400, 800]
    errs = [np.linalg.norm(run(order, PAPER_T / n, n)[3][0] - ref) for n in divs]
    slope = -np.polyfit(np.log(divs), np.log(errs), 1)[0]
    assert abs(slope - order) < 0.3, f"fitted order {slope:.3f} for tfe {order}; errors {errs}"
    assert min(errs) > 1e-12


@pytest.mark.parametrize("order", [4, 6])
def test_energy_and_angular_momentum_exact_at_large_steps(order):
    """1e4 steps of T/40 (250 orbits; the phase is wrong by far more than round-off): the
    relative energy error of every step measured at most 1.8e-13 (order 4) and 1.0e-13
    (order 6), the angular momentum 3.2e-14 and 1.5e-14; limits 1e-12. Plain Gauss
    collocation (the correction left out) misses the energy by 1.2e-2 and 3.0e-4 here."""
    x, v, _, _ = run(order, PAPER_T / 40, 10_000, every=1)
    e0 = energy(PAPER_X0, PAPER_V0)
    l0 = np.cross(PAPER_X0, PAPER_V0)
    dE = np.abs(energy(x, v) / e0 - 1.0).max()
    dL = np.linalg.norm(np.cross(x, v) - l0, axis=1).max() / np.linalg.norm(l0)
    assert dE <= 1e-12, f"order {order}: |dE|/|E0| = {dE:.3g}"
    assert dL <= 1e-12, f"order {order}: |dL|/|L0| = {dL:.3g}"
    ref, _ = orbits.propagate(PAPER_X0, PAPER_V0, PAPER_GM, 10_000 * PAPER_T / 40)
    assert np.linalg.norm(x[-1] - ref) > 1e-6  # a large step: only the invariants are exact


@pytest.mark.parametrize("order", [4, 6])
def test_time_symmetric(order):
    """n = 1000 steps of T/100 forward, the velocity reversed, n steps back: the start returns
    within 1e3 eps n = 2.2e-10 (measured 4.5e-15 and 1.1e-14 of |x0| and |v0| at order 4,
    3.4e-14 and 1.1e-13 at order 6)."""
    n = 1000
    _, _, _, (x, v) = run(order, PAPER_T / 100, n)
    _, _, _, (xb, vb) = run(order, PAPER_T / 100, n, x0=x, v0=-v)
    dx = np.linalg.norm(xb - PAPER_X0) / np.linalg.norm(PAPER_X0)
    dv = np.linalg.norm(-vb - PAPER_V0) / np.linalg.norm(PAPER_V0)
    assert dx <= 1e3 * EPS * n and dv <= 1e3 * EPS * n, (dx, dv)


def test_centre_and_newton_cost():
    """An offset centre gives the same orbit about it (to round-off), and the predictor from
    the previous step's force polynomial keeps Newton near 2 iterations per step at T/100
    (measured 2.46 for order 4, 2.13 for order 6, the first step's included)."""
    _, _, its4, (xa, va) = run(4, PAPER_T / 100, 1000)
    _, _, its6, _ = run(6, PAPER_T / 100, 1000)
    c = np.array([3.0, -2.0, 1.0])
    _, _, _, (xb, vb) = run(4, PAPER_T / 100, 1000, center=c)
    assert np.allclose(xb - c, xa, rtol=0, atol=1e-10) and np.allclose(vb, va, rtol=0, atol=1e-11)
    assert its4.sum() / 1000 <= 3.0 and its6.sum() / 1000 <= 2.6, (its4.sum(), its6.sum())


def test_step_solves_to_round_off_from_either_start():
    """One step from the explicit start and from a poor predictor lands on the same state
    (to round-off): Newton does not stop at a loose tolerance."""
    tab = tfe.tables(6)
    outs = []
    for predicted in (False, True):
        phi = np.full((3, 2), -0.05)  # a poor predictor, used only when predicted
        work = np.zeros((6, 14))
        piv = np.zeros(6, np.int64)
        out = tfe.tfe_step(tab, phi, work, piv, *PAPER_X0, *PAPER_V0, PAPER_T / 30, PAPER_GM, 50, predicted)
        assert out[-1] == STATUS_OK
        outs.append(np.array(out[:6]))
    assert np.allclose(outs[0], outs[1], rtol=0, atol=4 * EPS * 10)


def test_tables_are_gauss():
    """The tables' rows: the k-point rule integrates t^m exactly for m < 2k, the collocation
    matrix integrates the Lagrange polynomials, and b_i a_ij + b_j a_ji = b_i b_j (what makes
    the kinetic energy and |p|^2 exact sums over the nodes)."""
    for order in tfe.ORDERS:
        tab = tfe.tables(order)
        k = order // 2
        c, b, a, aa = tab[:, 0], tab[:, 1], tab[:, 3 : 3 + k], tab[:, 3 + k :]
        for m in range(2 * k):
            assert abs(b @ c**m - 1.0 / (m + 1)) < 4 * EPS
        assert np.allclose(a @ a, aa, rtol=0, atol=4 * EPS)
        assert np.allclose(tab[:, 2], b * (1 - c), rtol=0, atol=2 * EPS)
        assert np.allclose(b[:, None] * a + (b[:, None] * a).T, np.outer(b, b), rtol=0, atol=4 * EPS)


def test_refuses_what_it_does_not_run():
    """Orders other than 4 to 12 and the GPU: each an InputError naming its key and value,
    when the simulation is built (effects: tests/test_tfe_effects.py; structures with rigid
    bodies: tests/test_tfe_elastic.py); coefficients other than tfe's, naming the order."""
    assert get_method("tfe").orders == (4, 6, 8, 10, 12) == tfe.ORDERS and "tfe" in METHODS
    assert check_method_order("tfe", 12) == 12
    field = emorbit.CentralField(gm=PAPER_GM)
    for order in (2, 14):
        with pytest.raises(InputError) as info:
            emorbit.Simulation(field, method="tfe", order=order, dt=1.0)
        assert info.value.key == "order" and str(order) in str(info.value) and "'tfe'" in str(info.value)
    for gammas in (coefficients(8), np.full(4, 0.25), np.ones(1)):  # a composition's, equal weights, one
        with pytest.raises(InputError) as info:
            dispatch.tfe_tables(gammas)
        assert info.value.key == "order" and f"got {gammas.size} coefficients" in str(info.value)
    with pytest.raises(InputError) as info:
        emorbit.Simulation(field, method="tfe", order=4, dt=1.0).device = "gpu"
    assert info.value.key == "device" and "'tfe'" in str(info.value)


def test_a_scene_runs_it():
    """A scene's ``method = "tfe"``: the paper's orbit at order 6 and T/100 keeps the energy
    within 1e-12 over 10 orbits, as the kernel does."""
    text = (importlib.resources.files("emorbit") / "scenes" / "paper-ellipse.toml").read_text()
    text = text.replace('method = "em"\norder = 2', 'method = "tfe"\norder = 6')
    sim = emorbit.parse_scene(text).build()
    res = sim.run(steps=1000, every=100, progress=False)
    assert res.si.method == "tfe" and res.si.order == 6
    assert np.abs(res.relative_energy_error()).max() <= 1e-12


@pytest.mark.parametrize("order", [4, 6])
def test_adaptive_steps(order):
    """Adaptive steps (the reversible controller of emorbit.kernels.adaptive, one tfe step per
    composed step) on the e = 0.9 orbit over 20 orbits: the energy within 1e-15 of E, the
    error converging at the order in eta (measured 3.45 and 3.90; 6.02 and 6.01). The time
    symmetry is tests/test_adaptive.py's."""
    errors = adaptive_errors(order, 0.9, 20, (0.02, 0.01, 0.005))
    rates = np.log2(errors[:-1] / errors[1:])
    assert rates[-1] >= order - 0.3 and rates[0] >= order - 1.0, (errors, rates)
