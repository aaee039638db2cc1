"""The compiled effect set's loops over blocks of points (emorbit.effects.program): every
point gets the very bits it gets alone, whatever block it falls in and wherever in it.

150 points (three blocks, the last one partial) in Earth orbits under the central field,
J2..J6, drag, radiation pressure with the conical shadow, the Moon and the Sun, some points
with a coefficient 0 for drag or radiation pressure: the forces with and without Jacobians,
in every mode (em's step, the midpoint rule, leapfrog's kicks, and weighted by the masses),
and each working effect's work equal, bit for bit, those of each point evaluated on its own.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

import emorbit
from emorbit.bench.effects import ALL, earth_orbits
from emorbit.bench.effects import _effect_system as effect_system
from emorbit.kernels.effects.blocks import run_forces
from emorbit.kernels.effects.signatures import MODE_EXPLICIT, MODE_MIDPOINT, MODE_STEP, MODE_WEIGHTED

N = 150


@numba.njit
def _work(work, x0, dx, m, body, coef, h, mode, P, I, T, S, out):
    work(x0, dx, m, body, coef, h, mode, P, I, T, S, out)


@pytest.fixture(scope="module")
def case():
    field = emorbit.CentralField(body="earth")
    x, v = earth_orbits(N, field.gm, seed=5)
    dt = 2 * math.pi * math.sqrt(6878.1366e3**3 / field.gm) / 1000
    sim = effect_system(field, ALL, x, v, dt)
    pm = sim.points
    kinds = pm.effects.effects.kinds()
    coef = np.ascontiguousarray(pm.coefficients())
    coef[kinds.index("drag"), ::7] = 0.0
    coef[kinds.index("srp"), 3::5] = 0.0
    P, I, T, S = pm.effects.arrays(N)
    prog = pm.effects.program
    prog.prepare(0.0, 0.5 * dt, dt, P, I, T, S)
    x0 = np.ascontiguousarray(x)
    x1 = np.ascontiguousarray(x + dt * v + 1e-3 * np.sin(np.arange(3 * N)).reshape(3, N))
    m = 1.0 + np.arange(N) % 3
    return prog, (P, I, T, S), x0, x1, m, coef, dt


def _alone(a, i):
    return np.ascontiguousarray(a[:, i : i + 1])


@pytest.mark.parametrize("mode", [MODE_STEP, MODE_MIDPOINT, MODE_EXPLICIT, MODE_STEP | MODE_WEIGHTED])
@pytest.mark.parametrize("jac", [True, False])
def test_each_point_of_a_block_gets_its_own_bits(case, mode, jac):
    prog, sets, x0, x1, m, coef, h = case
    if mode == MODE_EXPLICIT:
        x1 = x0
    body = np.arange(N, dtype=np.int64)
    F, W, R = np.full((3, N), np.nan), np.full((9, N), np.nan), np.zeros(N)
    assert run_forces(prog.forces, x0, x1, m, body, coef, h, mode, *sets, F, W, R, jac, True) == 0
    for i in range(N):
        f, w, r = np.empty((3, 1)), np.empty((9, 1)), np.zeros(1)
        one = (_alone(x0, i), _alone(x1, i), m[i : i + 1].copy(), body[:1].copy(), _alone(coef, i))
        run_forces(prog.forces, *one, h, mode, *sets, f, w, r, jac, True)
        assert np.array_equal(f[:, 0], F[:, i]), i
        if jac:
            assert np.array_equal(w[:, 0], W[:, i]), i
    assert np.all(np.isfinite(F)) and np.abs(F).max() > 0.0


@pytest.mark.parametrize("mode", [MODE_STEP, MODE_MIDPOINT])
def test_each_point_of_a_block_does_its_own_work(case, mode):
    prog, sets, x0, x1, m, coef, h = case
    body = np.arange(N, dtype=np.int64)
    dx = x1 - x0
    rows = len(prog.working) + int(prog.ledger)
    out = np.full((rows, N), np.nan)
    _work(prog.work, x0, dx, m, body, coef, h, mode, *sets, out)
    for i in range(N):
        o = np.empty((rows, 1))
        _work(prog.work, _alone(x0, i), _alone(dx, i), m[i : i + 1].copy(), body[:1].copy(), _alone(coef, i), h, mode,
              *sets, o)  # fmt: skip
        assert np.array_equal(o[:, 0], out[:, i]), i
    drag = prog.working.index(prog.kinds.index("drag"))
    assert np.all(out[drag, ::7] == 0.0) and np.all(out[drag, 1::7] < 0.0)


def test_the_forces_are_the_pieces_summed_in_the_sets_order(case):
    """A point's force and Jacobian block (em's step) are its effects' pieces called one after
    another, each adding into the sum and the block: the same bits."""
    import importlib

    prog, (P, I, T, S), x0, x1, m, coef, h = case
    body = np.arange(N, dtype=np.int64)
    F, W, R = np.empty((3, N)), np.empty((9, N)), np.zeros(N)
    run_forces(prog.forces, x0, x1, m, body, coef, h, MODE_STEP, P, I, T, S, F, W, R, True, True)
    pieces = []
    for e, kind in enumerate(prog.kinds):
        spec = emorbit.effects.EFFECTS[kind].PIECES
        if spec.force:
            piece = getattr(importlib.import_module(spec.module), spec.force)
            pieces.append((e, piece))
    for i in (0, 1, 7, 63, 64, 149):
        f = [0.0, 0.0, 0.0]
        J = np.zeros((3, 3))
        for e, call in pieces:
            if coef[e, i] != 0.0:
                views = P[I[e, 0] : I[e, 1]], T[I[e, 2] : I[e, 3]], S[I[e, 4] : I[e, 5]]
                g = call(*x0[:, i], *x1[:, i], h, coef[e, i], *views, J, True)
                f = [f[c] + g[c] for c in range(3)]
        assert np.array_equal(F[:, i], f), i
        assert np.array_equal(W[:, i], J.ravel()), i
