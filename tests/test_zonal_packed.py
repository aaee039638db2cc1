"""The packed kernel of point masses under the central field plus zonal harmonics
(emorbit.kernels.effects.zonal_packed).

It is the kernel a simulation of central + zonal runs (mutual gravity keeps the effect step
of :mod:`emorbit.kernels.pointmass.effect_step`); it solves the effect step's equations with
the same discrete force (its runs agree with the effect step's to round-off, its Newton
update is the effect step's Newton update); it keeps the energy and the angular momentum
about the pole exactly, at the bench's step (one packed update per sub-step) and at steps
large enough to need the second packed update and the scalar pass; a point that fails stops
alone; and a point's result depends on neither the other points of its block, nor the thread
count, nor how a run is cut into chunks.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import emorbit
from emorbit.bench.effects import earth_orbits
from emorbit.integrators import coefficients
from emorbit.kernels.codes import STATUS_NO_CONVERGENCE, STATUS_SINGULAR
from emorbit.kernels.effects import zonal_packed as zp
from emorbit.kernels.effects.central import central_force, central_jacobian
from emorbit.kernels.effects.newton import newton_update
from emorbit.kernels.effects.zonal import zonal_force, zonal_jacobian, zonal_sums
from emorbit.kernels.pointmass.effect_step import effect_chunk

EARTH = emorbit.CentralField(body="earth")
R_LOW = 6878.1366e3
T_LOW = 2 * math.pi * math.sqrt(R_LOW**3 / EARTH.gm)
EPS = np.finfo(float).eps


def _params(degree=2, pole=None):
    sim = emorbit.Simulation(EARTH, method="em", dt=1.0)
    sim.add_effect("zonal", model="earth", degree=degree, **({} if pole is None else {"pole": pole}))
    return sim, list(sim.effects.packed_points()[1])


def _effect_step(sim):
    """The effect step of the simulation's set (:func:`effect_chunk`) as a chunk of the packed
    kernel's arguments (the set's own parameters; the packed ones are ignored)."""
    prog = sim.effects.program()

    def chunk(x, v, cx, cv, wp, hp, m, cp, zpar, zj, dt, gammas, every, nrec, max_iter, rx, rv, ri, fail):
        n = x.shape[1]
        P, I, T, S = sim.effects.arrays(n)
        work = np.zeros((0, n))
        effect_chunk(
            prog.forces, prog.cross, prog.prepare, prog.work, 0, x, v, cx, cv, wp, hp, m, np.arange(n, dtype=np.int64),
            np.ones((len(sim.effects), n)), P, I, T, S, work, work.copy(), np.zeros((nrec, 0, n)), 0.0, 0.0, dt,
            gammas, every, nrec, max_iter, False, rx, rv, ri, fail, (cp[3], np.ascontiguousarray(cp[:3]), 0.0),
        )  # fmt: skip

    return chunk


def _run(kernel, params, x, v, dt, order=2, steps=100, nrec=1, max_iter=50, state=None, **kw):
    """Run ``kernel`` (a chunk: zonal_packed.chunk or the compiled effect step): (state, records)."""
    n = x.shape[1]
    st = state or [x.copy(), v.copy(), np.zeros_like(x), np.zeros_like(x), np.zeros_like(x), np.zeros(1)]
    rx, rv = np.empty((nrec, 3, n)), np.empty((nrec, 3, n))
    ri, fail = np.zeros((nrec, n), np.int64), np.full((n, 2), -1, np.int64)
    kernel(*st, np.ones(n), *params, dt, coefficients(order), steps // nrec, nrec, max_iter, rx, rv, ri, fail, **kw)
    return st, (rx, rv, ri, fail)


def _energy(sim, x, v):
    """Each point's specific energy, kinetic plus every effect's potential, (n,) J/kg."""
    rows = np.ascontiguousarray(x.T)[:, :, None]
    one = np.ones(1)
    return 0.5 * np.einsum("kn,kn->n", v, v) + sum(t.potential_energy(rows, one) for t in sim.effects)


def test_central_plus_zonal_runs_the_packed_kernel():
    sim = emorbit.Simulation(EARTH, method="em", dt=10.0)
    sim.add_point("a", mass=1.0, position=[7e6, 0, 0], velocity=[0, 7.5e3, 0])
    sim.add_effect("zonal", model="earth")
    assert sim.effects.packed_points()[0] is zp.chunk
    sim.add_point("b", mass=1.0, position=[-7e6, 0, 0], velocity=[0, -7.5e3, 0])
    sim.add_effect("mutual")  # the points attract each other: one coupled system
    assert sim.effects.packed_points() is None


@pytest.mark.parametrize(
    "order, degree, pole, per_orbit",
    [
        (2, 2, None, 1000),
        (4, 2, [0.3, -0.2, 1.0], 500),
        (2, 6, None, 1000),
        (6, 4, [0.1, 0.2, 1.0], 200),
        (2, 2, None, 95),
    ],
)
def test_runs_agree_with_the_effect_step(order, degree, pole, per_orbit):
    """100 orbits from LEO to GPS, 200 steps: the same states to round-off (the two kernels
    differ in their predictor, Newton matrix solve and stopping, not in their equations)."""
    sim, params = _params(degree, pole)
    x, v = earth_orbits(100, EARTH.gm)
    dt = T_LOW / per_orbit
    (xa, va, *_), (_, _, iters, fail) = _run(zp.chunk, params, x, v, dt, order, steps=200)
    (xb, vb, *_), _ = _run(_effect_step(sim), params, x, v, dt, order, steps=200)
    assert np.all(fail == -1)
    assert np.max(np.abs(xa - xb)) <= 1e-13 * np.max(np.abs(x))
    assert np.max(np.abs(va - vb)) <= 1e-13 * np.max(np.abs(v))
    e0 = _energy(sim, x, v)
    assert np.max(np.abs(_energy(sim, xa, va) / e0 - 1)) <= 1e-14
    if per_orbit >= 1000:  # one packed Newton update finishes every sub-step
        assert np.all(iters == 200 * len(coefficients(order)))


def test_the_newton_update_is_the_effect_steps():
    """From iterates off the solution by up to 1e-4, the update of omega is twice over h
    the effect step's update of w, (I - h^2/2 dF/dx1)^-1 (w - h^2/2 F) with the kernels'
    own force and Jacobian (central_jacobian + zonal_jacobian, newton_update)."""
    rng = np.random.default_rng(5)
    for pole, polez in (([0.0, 0.0, 1.0], True), ([0.3, -0.2, 1.0], False)):
        for degree in (2, 6):
            sim, (cp, zpar, zj) = _params(degree, pole if not polez else None)
            cst, js = zp._constants(cp, zpar, zj)
            x, v = earth_orbits(50, EARTH.gm, seed=11)
            for i in range(x.shape[1]):
                h = T_LOW / rng.uniform(50, 2000)
                step = zp._step_constants(h, cst)
                x0, v0 = x[:, i], v[:, i]
                d0 = x0 - cp[:3]
                r0 = float(np.linalg.norm(d0))
                zd0 = float(d0 @ zpar[3:6]) if not polez else float(d0[2])
                g = -cp[3] * d0 / r0**3
                m = h * g * (1 + 1e-4 * rng.normal(size=3))  # omega near h g
                new = zp._newton(*x0, *v0, *m, r0, 1.0 / r0, zd0, cst, step, 2 if degree == 2 else 6, polez, js)
                w = 0.5 * h * m
                x1 = x0 + h * v0 + w
                F = np.array(central_force(*x0, *x1, *cp)) + np.array(zonal_force(*x0, *x1, *zpar, zj))
                J = np.zeros((3, 3))
                central_jacobian(*x0, *x1, *cp, J)
                zonal_jacobian(*x0, *x1, *zpar, zj, J)
                dw = np.array(newton_update(J.reshape(9, 1), 0, 0.5 * h * h, *(w - 0.5 * h * h * F)))
                dm = m - np.array(new[:3])
                np.testing.assert_allclose(dm, 2 * dw / h, rtol=1e-7, atol=1e-9 * np.linalg.norm(dm))
                assert new[3] == pytest.approx(float(dm @ dm), rel=1e-12)


def test_the_j2_sums_are_zonal_sums():
    """J2's sums written out (_sums_2) are zonal_sums of degree 2 to a few roundings of the
    terms' size, its gradient too; degree 6 with zeros above the degree is the degree's own."""
    rng = np.random.default_rng(0)
    j = np.array([1.08e-3, -2.5e-6, -1.6e-6, -2.3e-7, 5.4e-7])
    for _ in range(2000):
        q0, q1 = rng.uniform(0.2, 1.2, 2)
        z0, z1 = rng.uniform(-1.2, 1.2, 2)
        if rng.random() < 0.3:
            q1, z1 = q0 * (1 + 1e-9 * rng.normal()), z0 + 1e-9 * rng.normal()
        pa = (q0, q0**2, q0**3, q0**4)
        ref = np.array(zonal_sums(q0, q1, z0, z1, 2, j[0], 0.0, 0.0, 0.0, 0.0, True))
        got = np.array(zp._sums_2(pa, q1, z0, z1, (j[0], 0.0, 0.0, 0.0, 0.0)))
        S = [sum((q0 ** (i + 1)) * q1 ** (mm - i) * (mm - i) ** t for i in range(mm)) for mm in (3, 5) for t in (0, 1)]
        g = 0.75 * j[0] * (z0 * z0 + z1 * z1)
        size = [0.5 * j[0] * S[0] + g * S[2], abs(ref[1]), q1 * (0.5 * j[0] * S[1] + g * S[3])] + list(np.abs(ref[3:]))
        assert np.all(np.abs(got - ref) <= 8 * EPS * np.array(size)), (got, ref)
        grad = np.array(zp._grad_2(pa, z0, (j[0], 0.0, 0.0, 0.0, 0.0)))
        gref = np.array(zonal_sums(q0, q0, z0, z0, 2, j[0], 0.0, 0.0, 0.0, 0.0, False)[:2])
        assert np.all(
            np.abs(grad - gref) <= 8 * EPS * (np.abs(gref) + 1.5 * j[0] * q0**4 * (1 + 5 * z0 * z0 * q0 * q0))
        )
        for degree in (3, 4, 5):
            padded = tuple(float(c) if n < degree - 1 else 0.0 for n, c in enumerate(j))
            own = zonal_sums(q0, q1, z0, z1, degree, *padded, True)
            np.testing.assert_array_equal(zp._sums_6(pa, q1, z0, z1, padded), own)


@pytest.mark.parametrize("per_orbit, pole", [(1000, None), (100, [0.2, -0.1, 1.0])])
def test_energy_and_the_pole_angular_momentum_are_kept(per_orbit, pole):
    """32 eccentric inclined orbits under J2..J6 for 20000 steps: the energy and the angular
    momentum about the pole (at T/100 half the sub-steps need more than the first packed
    update). Measured 8.2e-16 and 9e-17 at both steps; limits 8e-15 and 9e-16 (10x)."""
    sim = emorbit.Simulation(EARTH, method="em", dt=T_LOW / per_orbit)
    sim.add_effect("zonal", model="earth", **({} if pole is None else {"pole": pole}))
    rng = np.random.default_rng(3)
    for i in range(32):
        a, e, inc = R_LOW * rng.uniform(1.0, 1.5), rng.uniform(0.0, 0.1), rng.uniform(0, np.pi)
        r, speed = a * (1 - e), math.sqrt(EARTH.gm * (1 + e) / (a * (1 - e)))
        sim.add_point(f"p{i}", mass=1.0, position=[r, 0, 0], velocity=[0, speed * np.cos(inc), speed * np.sin(inc)])
    res = sim.run(steps=20_000, every=1000, progress=False).si
    E, L = res.energy, res.angular_momentum
    pole_axis = np.array(pole or [0.0, 0.0, 1.0]) / np.linalg.norm(pole or [0.0, 0.0, 1.0])
    dE = np.max(np.abs(E - E[0])) / abs(E[0])
    dL = np.max(np.abs((L - L[0]) @ pole_axis)) / np.linalg.norm(L[0])
    assert dE <= 8e-15, f"|dE|/|E0| = {dE:.3g}, measured 8.2e-16"
    assert dL <= 9e-16, f"|dL_pole|/|L0| = {dL:.3g}, measured 9e-17"


@pytest.mark.parametrize("order", [2, 4])
def test_a_point_that_fails_stops_alone(order):
    """A point at the centre fails at the first step as singular; the others run as without
    it. With one update allowed, points at a large step fail as not converged."""
    _, params = _params()
    x, v = earth_orbits(20, EARTH.gm)
    dt = T_LOW / 1000
    bad = x.copy()
    bad[:, 7] = 0.0
    (xa, *_), (rx, _, _, fail) = _run(zp.chunk, params, bad, v, dt, order, steps=50, nrec=5)
    (xb, *_), _ = _run(zp.chunk, params, x, v, dt, order, steps=50, nrec=5)
    assert tuple(fail[7]) == (0, STATUS_SINGULAR) and np.all(np.delete(fail, 7, axis=0) == -1)
    np.testing.assert_array_equal(np.delete(xa, 7, axis=1), np.delete(xb, 7, axis=1))
    assert np.all(rx[:, :, 7] == 0.0) and np.all(xa[:, 7] == 0.0)
    fail = _run(zp.chunk, params, x, v, T_LOW / 20, order, steps=5, max_iter=1)[1][3]
    failed = fail[:, 0] >= 0
    assert failed.sum() >= 10 and np.all(fail[failed, 0] == 0) and np.all(fail[failed, 1] == STATUS_NO_CONVERGENCE)
    assert np.all(_run(zp.chunk, params, x, v, T_LOW / 20, order, steps=5)[1][3] == -1)


def test_results_depend_on_nothing_but_the_point():
    """Bit for bit: each point alone or among 300, on one thread or all of them, in one chunk
    or in two, with J2 alone and with J2..J6 about another pole, at order 4; and the kernel
    for the pole along z gives the general kernel's bits."""
    for degree, pole in ((2, None), (6, [0.3, -0.2, 1.0])):
        _, params = _params(degree, pole)
        x, v = earth_orbits(300, EARTH.gm)
        dt = T_LOW / 300
        (xa, va, *_), _ = _run(zp.chunk, params, x, v, dt, 4, steps=40, parallel=False)
        (xb, vb, *_), _ = _run(zp.chunk, params, x, v, dt, 4, steps=40, parallel=True)
        state, _ = _run(zp.chunk, params, x, v, dt, 4, steps=25)
        (xc, vc, *_), _ = _run(zp.chunk, params, x, v, dt, 4, steps=15, state=state)
        np.testing.assert_array_equal(xa, xb)
        np.testing.assert_array_equal(va, vb)
        np.testing.assert_array_equal(xa, xc)
        np.testing.assert_array_equal(va, vc)
        if pole is None:  # the pole-along-z variant is the general kernel's bits
            st = [x.copy(), v.copy(), np.zeros_like(x), np.zeros_like(x), np.zeros_like(x)]
            rx, rv, ri, fail = (
                np.empty((1, 3, 300)),
                np.empty((1, 3, 300)),
                np.zeros((1, 300), np.int64),
                np.full((300, 2), -1),
            )
            zp._range_2(*st, *params, dt, coefficients(4), 40, 1, 50, rx, rv, ri, fail, 0, 300)
            np.testing.assert_array_equal(st[0], xa)
            np.testing.assert_array_equal(st[1], va)
        for i in (0, 77, 299):
            (xi, vi, *_), _ = _run(zp.chunk, params, x[:, [i]], v[:, [i]], dt, 4, steps=40)
            np.testing.assert_array_equal(xi[:, 0], xa[:, i])
            np.testing.assert_array_equal(vi[:, 0], va[:, i])
