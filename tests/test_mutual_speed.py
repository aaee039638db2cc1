"""The vectorised pair pass of mutual gravity (emorbit.kernels.effects.central) and the em step
that uses it (emorbit.kernels.pointmass.effect_step).

Checked: every point's pair sum is the sum of Greenspan's pair forces and its coupling bound
holds; the diagonal Jacobian blocks are the pair kernels'; a later sweep that forms only the
pairs of the points that moved gives the forces of a full pass (the moved points' bit for bit);
a cluster's em steps match an independent solve of the same equations; a cluster keeps its
energy as a random walk at round-off; a swarm in the Earth's field keeps energy and angular
momentum, and the bodies left out of ``bodies`` move as in the field alone.
"""

from __future__ import annotations

import numpy as np

import emorbit
from emorbit.effects.mutual import G
from emorbit.kernels.effects.central import (
    PAIR_ROWS,
    central_force,
    pair_block,
    pair_blocks,
    pair_pass,
    pair_sums,
    pair_unit,
)

EARTH = emorbit.CentralField(body="earth")


def _cluster(n: int, seed: int = 5):
    """n points 1 km apart in a cloud, their steps of 1 m or so, and G m (m^3/s^2)."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(3, n)) * 1e3
    dx = rng.normal(size=(3, n))
    gm = rng.uniform(1.0, 3.0, n) * 1e-2
    return x, dx, gm


def _rows(x, dx, gm):
    n = gm.size
    w = np.zeros((PAIR_ROWS, n))
    w[0:3], w[3:6], w[6] = x, x + dx, gm
    return w


def _sums(w):
    """pair_sums on the packed rows (low parts in rows 17-22)."""
    pair_sums(*w[:6], w[17:23], *w[6:11])


def test_pair_sums_are_the_sums_of_the_pair_forces():
    x, dx, gm = _cluster(37)
    n = gm.size
    w = _rows(x, dx, gm)
    _sums(w)
    ref = np.zeros((3, n))
    bound = np.zeros(n)
    J = np.zeros((3, 3))
    for i in range(n):
        for j in range(n):
            if i != j:
                d0, d1 = x[:, i] - x[:, j], x[:, i] + dx[:, i] - x[:, j] - dx[:, j]
                ref[:, i] += central_force(*d0, *d1, 0.0, 0.0, 0.0, gm[j])
                bound[i] += gm[j] * pair_unit(*d0, *d1, J)[3]
    scale = np.abs(ref).max(axis=0)
    assert np.max(np.abs(w[7:10] - ref) / scale) <= 1e-14
    np.testing.assert_allclose(w[10], bound, rtol=1e-14)
    # equal and opposite: the momentum they change sums to round-off
    assert np.abs(w[7:10] @ gm).max() <= 1e-15 * np.abs(w[7:10] * gm).sum()


def test_pair_blocks_are_the_pair_kernels_jacobians():
    x, dx, gm = _cluster(21)
    n = gm.size
    w = _rows(x, dx, gm)
    blocks = np.zeros((9, n))
    one = np.zeros((9, n))
    pair_blocks(*w[:7], blocks)
    J = np.zeros((3, 3))
    for i in range(n):
        ref = np.zeros((3, 3))
        for j in range(n):
            if i != j:
                pair_unit(*(x[:, i] - x[:, j]), *(x[:, i] + dx[:, i] - x[:, j] - dx[:, j]), J)
                ref += gm[j] * J
        np.testing.assert_allclose(blocks[:, i], ref.ravel(), rtol=1e-12, atol=1e-14 * np.abs(ref).max())
        pair_block(i, *w[:7], one)
        np.testing.assert_allclose(one[:, i], ref.ravel(), rtol=1e-12, atol=1e-14 * np.abs(ref).max())


def _pass(first, x, dx, gm, w=None):
    n = gm.size
    w = _rows(x, dx, gm) if w is None else w
    fp, rho = np.zeros((3, n)), np.zeros(n)
    formed = pair_pass(first, 0.5, x, x + dx, np.arange(n), w, np.zeros(n, np.int64), fp, rho)
    return formed, w, fp


def test_a_sweep_that_forms_only_the_moved_pairs_gives_a_full_pass():
    x, dx, gm = _cluster(64)
    n = gm.size
    formed, w, fp = _pass(True, x, dx, gm)
    assert formed == n
    # nothing moved: nothing formed, the same forces
    again, w, fp2 = _pass(False, x, dx, gm, w)
    assert again == 0 and np.array_equal(fp, fp2)
    moved = [3, 17, 40, 63]
    dx2 = dx.copy()
    dx2[:, moved] += np.random.default_rng(1).normal(size=(3, len(moved))) * 1e-3
    formed, w, fp = _pass(False, x, dx2, gm, w)
    _, _, full = _pass(True, x, dx2, gm)
    assert formed == len(moved)
    assert np.max(np.abs(fp - full) / np.abs(full).max(axis=0)) <= 4 * 2.0**-52
    assert np.array_equal(fp[:, moved], full[:, moved])
    # more than an eighth of the points moved: every pair again, the bits of a full pass
    dx3 = dx2 + 1e-3
    formed, w, fp = _pass(False, x, dx3, gm, w)
    _, _, full = _pass(True, x, dx3, gm)
    assert formed == n and np.array_equal(fp, full)


def test_a_close_pair_far_out_is_formed_from_its_low_parts():
    """A pair 0.02 m apart, 1 km from the origin, given as high parts rounded at 1 km plus low
    parts: its pair forces are those of the same pair at the origin to 4 eps, where the high
    parts alone miss by 1e-12."""
    rng = np.random.default_rng(3)
    near = np.array([[0.0, 0.0137], [0.0, 0.0088], [0.0, -0.0051]]) + rng.normal(size=(3, 2)) * 1e-3
    step = rng.normal(size=(3, 2)) * 1e-3
    gm = np.array([0.7, 1.3])
    far = np.array([1000.0, -700.0, 300.0])[:, None]
    hi0 = near + far
    lo0 = (near - (hi0 - far)) + 0.0  # what rounding hi0 lost, in exact arithmetic to 1e-30 m
    hi1 = hi0 + step
    lo1 = (near + step) - (hi1 - far)
    forces = []
    for x0, x1 in ((near, near + step), (np.vstack([hi0, lo0]), np.vstack([hi1, lo1])), (hi0, hi1)):
        w = np.zeros((PAIR_ROWS, 2))
        fp, rho = np.zeros((3, 2)), np.zeros(2)
        w[6] = gm
        pair_pass(True, 0.5, np.ascontiguousarray(x0), np.ascontiguousarray(x1), np.arange(2), w,
                  np.zeros(2, np.int64), fp, rho)  # fmt: skip
        forces.append(fp)
    ref, low, high = forces
    scale = np.abs(ref).max()
    assert np.abs(low - ref).max() <= 4 * 2.0**-52 * scale
    assert np.abs(high - ref).max() >= 1e-12 * scale


def _reference_steps(m, x, v, dt, steps):
    """The em steps of point masses under mutual gravity, each solved by fixed-point iteration
    with numpy (every pair, every iteration) until w no longer changes."""
    x, v = x.copy(), v.copy()
    gm = G * m
    for _ in range(steps):
        w = np.zeros_like(x)
        for _ in range(100):
            x1 = x + dt * v + w
            d0 = x[:, :, None] - x[:, None, :]
            d1 = x1[:, :, None] - x1[:, None, :]
            r0, r1 = np.linalg.norm(d0, axis=0), np.linalg.norm(d1, axis=0)
            np.fill_diagonal(r0, 1.0)
            np.fill_diagonal(r1, 1.0)
            f = -np.einsum("kij,ij,j->ki", d0 + d1, 1.0 / (r0 * r1 * (r0 + r1)), gm)
            new = 0.5 * dt * dt * f
            if np.array_equal(new, w):
                break
            w = new
        x, v = x + dt * v + w, v + 2.0 * w / dt
    return x, v


def test_a_cluster_steps_as_an_independent_solve_of_the_em_equations():
    from emorbit.bench.effects import plummer

    m, x, v, a, total = plummer(40, seed=2)
    dt = 1e-3 * float(np.sqrt(a**3 / (G * total)))
    sim = emorbit.Simulation(None, method="em", dt=dt)
    sim.add_effect("mutual")
    for i in range(m.size):
        sim.add_point(f"s{i}", mass=m[i], position=x[:, i], velocity=v[:, i])
    res = sim.run(steps=30, every=30, progress=False).si
    got = np.array([res.positions[f"s{i}"][-1] for i in range(m.size)]).T
    ref, _ = _reference_steps(m, x, v, dt, 30)
    assert np.max(np.linalg.norm(got - ref, axis=0)) <= 1e-13 * a
    assert np.max(np.abs(res.energy - res.energy[0])) <= 1e-14 * abs(res.energy[0])


def test_a_cluster_keeps_its_energy_as_a_random_walk():
    """100 stars of a Plummer sphere, 20,000 steps of 1e-4 of the dynamical time: the energy
    error stays within a few eps and shows no trend."""
    from emorbit.bench.effects import plummer

    m, x, v, a, total = plummer(100, seed=4)
    dt = 1e-4 * float(np.sqrt(a**3 / (G * total)))
    sim = emorbit.Simulation(None, method="em", dt=dt)
    sim.add_effect("mutual")
    for i in range(m.size):
        sim.add_point(f"s{i}", mass=m[i], position=x[:, i], velocity=v[:, i])
    res = sim.run(steps=20_000, every=500, progress=False).si
    rel = (res.energy - res.energy[0]) / abs(res.energy[0])
    assert np.max(np.abs(rel)) <= 2e-14, rel
    P = res.momentum
    scale_p = sum(mi * np.linalg.norm(vi[0]) for mi, vi in zip(res.masses.values(), res.velocities.values()))
    assert np.max(np.abs(P - P[0])) / scale_p <= 1e-14


def test_a_swarm_in_the_earth_field_keeps_energy_and_angular_momentum():
    """24 bodies of 1e12 kg within a few km of each other in low Earth orbit, 20 of them
    attracting each other: energy and the angular momentum about the centre stay at round-off,
    and the four left out move as they do in the field alone."""
    r = 7000e3
    speed = float(np.sqrt(EARTH.gm / r))
    rng = np.random.default_rng(9)
    offsets = rng.normal(size=(24, 3)) * 2e3
    kicks = rng.normal(size=(24, 3)) * 0.5
    names = [f"b{i}" for i in range(24)]

    def swarm(effect: bool) -> emorbit.Simulation:
        sim = emorbit.Simulation(EARTH, method="em", dt=20.0)
        if effect:
            sim.add_effect("mutual", bodies=names[:20])
        for i, name in enumerate(names):
            sim.add_point(name, mass=1e12, position=[r, 0, 0] + offsets[i], velocity=[0, speed, 0] + kicks[i])
        return sim

    res = swarm(True).run(steps=3000, every=100, progress=False).si
    E, L = res.energy, res.angular_momentum
    assert np.max(np.abs(E - E[0])) / abs(E[0]) <= 1e-12
    assert np.max(np.linalg.norm(L - L[0], axis=1)) / np.linalg.norm(L[0]) <= 1e-12
    alone = swarm(False).run(steps=3000, every=100, progress=False).si
    for name in names[20:]:
        assert np.max(np.abs(res.positions[name] - alone.positions[name])) <= 1e-9 * r, name
    moved = max(np.max(np.abs(res.positions[n] - alone.positions[n])) for n in names[:20])
    assert moved > 1.0  # the others pull each other by metres
