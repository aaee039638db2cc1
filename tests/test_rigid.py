"""Rigid bodies: discretisation, torque-free motion against an independent solve, the
gravity-gradient torque against theory, exact invariants, and bad input."""

import astropy.constants as const
import h5py
import numpy as np
import pytest
from conftest import PAPER_GM, PAPER_T, PAPER_V0, PAPER_X0
from scipy.integrate import solve_ivp

import emorbit
from emorbit.bodies import shapes
from emorbit.bodies.rotations import matrix_to_quaternion, quaternion_to_matrix, rotation_vector_to_matrix
from emorbit.cli import main
from emorbit.errors import InputError
from emorbit.kernels import rigid as kr

GM_EARTH = const.GM_earth.si.value


# -- discretisation ------------------------------------------------------------------------


@pytest.mark.parametrize(
    "points, npts",
    [
        (lambda: shapes.box([3.0, 2.0, 1.0], density=7.0, refinement=1), 8),
        (lambda: shapes.box([3.0, 2.0, 1.0], mass=5.0, refinement=3), 216),
        (lambda: shapes.cylinder(0.5, 2.0, density=3.0, refinement=2), 2 * 2 * 2 * 2 * 8),
        (lambda: shapes.sphere(1.5, density=2.0, refinement=2), 24 * 8),
        (lambda: shapes.ellipsoid([3.0, 2.0, 0.5], mass=7.0, refinement=2), 24 * 8),
        (lambda: shapes.shell(2.0, mass=4.0, refinement=2), 32),
        (lambda: shapes.dumbbell([1.0, 3.0], 10.0, refinement=1), 48),
    ],
)
def test_discrete_inertia_is_exact(points, npts):
    """The quadratures integrate second moments exactly: the inertia of the mass points
    equals the analytic inertia of the shape, and the centre of mass is the origin."""
    p = points()
    assert len(p) == npts
    np.testing.assert_allclose(p.inertia, p.analytic_inertia, rtol=1e-12, atol=1e-12 * np.abs(p.analytic_inertia).max())
    assert np.abs(p.X @ p.m).max() < 1e-12 * p.mass


def test_an_ellipsoid_has_its_volume_and_names_bad_semi_axes():
    p = shapes.ellipsoid([3.0, 2.0, 0.5], density=2.0)
    assert p.mass == pytest.approx(2.0 * 4 / 3 * np.pi * 3.0, rel=1e-14)
    for bad in ([1.0, 2.0], [1.0, -2.0, 3.0], "1 m"):
        with pytest.raises(InputError, match="three lengths > 0") as exc:
            shapes.ellipsoid(bad, mass=1.0, key="body['e']")
        assert exc.value.key == "body['e'].semi_axes"


def test_mesh_inertia_and_volume():
    """A unit cube cut into 6 tetrahedra: volume 1 and the cube's inertia, exactly."""
    nodes = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    # Kuhn triangulation of the cube along the diagonal 0 -> 7
    paths = [(4, 2, 1), (4, 1, 2), (2, 4, 1), (2, 1, 4), (1, 4, 2), (1, 2, 4)]
    tets = []
    for a, b, _c in paths:
        v1 = a
        v2 = a + b
        tet = [0, v1, v2, 7]
        P = nodes[tet]
        if np.linalg.det(P[1:] - P[0]) < 0:
            tet = [0, v2, v1, 7]
        tets.append(tet)
    p = shapes.tetra_mesh(nodes, np.array(tets), density=2.0)
    assert p.volume == pytest.approx(1.0, rel=1e-14)
    np.testing.assert_allclose(p.inertia, 2.0 / 6.0 * np.eye(3), rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize(
    "change, key, needle",
    [
        ("invert", "tetrahedra[0]", "inverted"),
        ("flat", "tetrahedra[0]", "zero-volume"),
        ("dangling", "nodes[4]", "dangling"),
        ("index", "tetrahedra[0]", "out of range"),
    ],
)
def test_bad_meshes(change, key, needle):
    nodes = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    tets = np.array([[0, 1, 2, 3]])
    if change == "invert":
        tets = np.array([[0, 2, 1, 3]])
    elif change == "flat":
        nodes[3] = [0.3, 0.3, 0.0]
    elif change == "dangling":
        nodes = np.vstack([nodes, [5.0, 5.0, 5.0]])
    elif change == "index":
        tets = np.array([[0, 1, 2, 9]])
    with pytest.raises(InputError) as info:
        shapes.tetra_mesh(nodes, tets, density=1.0)
    assert key in str(info.value) and needle in str(info.value)


@pytest.mark.parametrize(
    "kwargs, key",
    [
        (dict(shape="cube", size=[1, 1, 1], density=1.0), "shape"),
        (dict(shape="box", size=[1, 1, 1], density=1.0, radius=2.0), "radius"),
        (dict(shape="box", size=[1, 1, 1], density=0.0), "density"),
        (dict(shape="box", size=[1, 1, 1], density=-1.0), "density"),
        (dict(shape="box", size=[1, 1, 1]), "exactly one of density and mass"),
        (dict(shape="box", size=[1, 1, 0], density=1.0), "size"),
        (dict(shape="sphere", radius=1.0, mass=-2.0), "mass"),
        (dict(shape="box", size=[1, 1, 1], density=1.0, attitude=[1, 1, 0, 0]), "unit quaternion"),
        (dict(shape="box", size=[1, 1, 1], density=1.0, attitude=[1, 0, 0, 0], rotation_vector=[0, 0, 1]), "not both"),
        (dict(shape="box", size=[1, 1, 1], density=1.0, gravity="tidal"), "gravity"),
        (dict(shape="box", size=[1, 1, 1], density=1.0, refinement=0), "refinement"),
        (dict(shape="mesh", nodes=[[0, 0, 0]], tetrahedra=[[0, 1, 2, 3]], density=1.0), "nodes"),
    ],
)
def test_bad_rigid_input(kwargs, key):
    sim = emorbit.Simulation(emorbit.CentralField(gm=1.0), dt=0.1)
    shape = kwargs.pop("shape")
    with pytest.raises(InputError, match=key):
        sim.add_rigid("b", shape, position=[10, 0, 0], velocity=[0, 0.3, 0], **kwargs)
    assert sim.names == []


def test_field_and_method_requirements():
    free = emorbit.Simulation(None, dt=0.1)
    with pytest.raises(InputError, match="needs a central field"):
        free.add_rigid(
            "b", "box", size=[1, 1, 1], density=1.0, position=[0, 0, 0], velocity=[0, 0, 0], gravity="volume"
        )
    with pytest.raises(InputError, match="point mass"):
        free.add_point("p", mass=1, position=[1, 0, 0], velocity=[0, 0, 0])
    leap = emorbit.Simulation(emorbit.CentralField(gm=1.0), method="leapfrog", dt=0.1)
    with pytest.raises(InputError, match="no rigid-body kernel"):
        leap.add_rigid("b", "box", size=[1, 1, 1], density=1.0, position=[5, 0, 0], velocity=[0, 0, 0])


def test_rotations_round_trip():
    rng = np.random.default_rng(5)
    q = rng.normal(size=(1000, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    q *= np.sign(q[:, :1])
    R = quaternion_to_matrix(q)
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", R, R), np.broadcast_to(np.eye(3), R.shape), atol=1e-14)
    np.testing.assert_allclose(matrix_to_quaternion(R), q, atol=1e-14)
    v = np.array([0.3, -0.2, 0.5])
    Rv = rotation_vector_to_matrix(v)
    np.testing.assert_allclose(Rv @ v, v, atol=1e-15)  # the axis is fixed
    assert np.arccos((np.trace(Rv) - 1) / 2) == pytest.approx(np.linalg.norm(v))


# -- torque-free motion --------------------------------------------------------------------


def _euler_reference(inertia, omega0, t):
    """Euler's equations and quaternion kinematics by scipy's DOP853 at rtol 1e-12."""
    Iinv = np.linalg.inv(inertia)

    def rhs(_, y):
        om, (w, x, yy, z) = y[:3], y[3:]
        p, q, r = om
        dq = 0.5 * np.array(
            [-x * p - yy * q - z * r, w * p + yy * r - z * q, w * q + z * p - x * r, w * r + x * q - yy * p]
        )
        return np.concatenate([Iinv @ np.cross(inertia @ om, om), dq])

    sol = solve_ivp(
        rhs, (0, t[-1]), np.concatenate([omega0, [1.0, 0, 0, 0]]), method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t
    )
    return sol.y[:3].T, sol.y[3:].T


def _attitude_error(qa, qb):
    """Rotation angle between attitudes, from the chord |Ra - Rb|_F = 2 sqrt(2) sin(angle / 2)
    (arccos of the trace would lose half the digits at small angles)."""
    d = np.linalg.norm(quaternion_to_matrix(qa) - quaternion_to_matrix(qb), axis=(1, 2))
    return 2 * np.arcsin(np.clip(d / (2 * np.sqrt(2)), 0, 1))


@pytest.mark.parametrize(
    "case, size, omega0, tol",
    [
        # measured at dt = 0.01 s over 20 s: omega 8.2e-4 / 3.8e-4 rad/s, attitude 1.35e-3 / 1.38e-3 rad
        ("intermediate-axis flip", [3.0, 2.0, 1.0], [0.01, 2.0, 0.01], (1.2e-3, 2e-3)),
        ("symmetric top", [1.0, 1.0, 3.0], [0.3, 0.0, 2.0], (6e-4, 2e-3)),
    ],
)
def test_torque_free_against_dop853(case, size, omega0, tol):
    """Angular velocity and attitude agree with an independent high-accuracy solve within the
    measured second-order error, which falls by 4 when dt halves; E and L exact."""
    errs = []
    for dt in (0.01, 0.005):
        sim = emorbit.Simulation(None, method="em", dt=dt)
        sim.add_rigid(
            "b", "box", size=size, density=1.0, position=[0, 0, 0], velocity=[0, 0, 0], angular_velocity=omega0
        )
        res = sim.run(steps=int(round(20.0 / dt)), every=int(round(0.5 / dt))).si
        om, q = _euler_reference(sim.rigid.points[0].inertia, np.array(omega0), res.time)
        errs.append((np.abs(res.angular_velocities["b"] - om).max(), _attitude_error(res.attitudes["b"], q).max()))
        assert np.abs(res.relative_energy_error()).max() < 1e-14
        assert res.relative_angular_momentum_error().max() < 1e-14
    assert errs[0][0] < tol[0] and errs[0][1] < tol[1]
    orders = np.log2(np.array(errs[0]) / np.array(errs[1]))
    np.testing.assert_allclose(orders, 2.0, atol=0.1)
    if "flip" in case:  # the body really flips: omega_y changes sign
        assert res.angular_velocities["b"][:, 1].min() < -1.9


def test_angular_velocity_follows_the_composition_order():
    """At order 4 the attitude and the reported angular velocity (from the spin angular
    momentum) both converge at fourth order (measured 3.99 and 4.00 per halving)."""
    om0 = np.array([0.01, 2.0, 0.01])
    errs = []
    for dt in (0.04, 0.02, 0.01):
        sim = emorbit.Simulation(None, method="em", order=4, dt=dt)
        sim.add_rigid(
            "b", "box", size=[3.0, 2.0, 1.0], density=1.0, position=[0, 0, 0], velocity=[0, 0, 0], angular_velocity=om0
        )
        res = sim.run(steps=int(round(2.0 / dt)), every=int(round(2.0 / dt))).si
        om, q = _euler_reference(sim.rigid.points[0].inertia, om0, res.time)
        errs.append(
            (
                np.abs(res.angular_velocities["b"][-1] - om[-1]).max(),
                _attitude_error(res.attitudes["b"][-1:], q[-1:])[0],
            )
        )
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    np.testing.assert_allclose(orders, 4.0, atol=0.3)


@pytest.mark.parametrize("degrees", [30.0])
def test_large_rotations_per_step_conserve(degrees):
    """1e5 steps turning 30 degrees each, intermediate-axis tumble: E and L stay at round-off
    (the scheme turns by 2 atan(h w / 2) per step). At 90 degrees per step the run is stable
    but the energy drifts to 1e-12 over 1e5 steps: a bias in the rounding of the residual,
    left for the issue on hard cases (see emorbit/kernels/rigid.py). Measured at 30 degrees:
    3.3e-14 (energy), 8.2e-15 (angular momentum); limits 10x."""
    w = 2.0
    dt = 2 * np.tan(np.radians(degrees) / 2) / w
    sim = emorbit.Simulation(None, method="em", dt=dt)
    sim.add_rigid(
        "b",
        "box",
        size=[3.0, 2.0, 1.0],
        density=1.0,
        position=[0, 0, 0],
        velocity=[0, 0, 0],
        angular_velocity=[0.01, w, 0.01],
    )
    res = sim.run(steps=100_000, every=1000)
    dE, dL = np.abs(res.relative_energy_error()).max(), res.relative_angular_momentum_error().max()
    assert dE <= 3.3e-13, f"|dE|/|E0| = {dE:.3g}, measured 3.3e-14"
    assert dL <= 8.2e-14, f"|dL|/|L0| = {dL:.3g}, measured 8.2e-15"
    q = res.attitudes["b"]
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)


def _effects(sim):
    """The effect set's functions and arrays as :func:`kr.rigid_step` takes them, for body 0:
    (forces, facets, coef, pcoef, P, I, T, S, facet rows, f0, f1, facet scratch)."""
    from emorbit.kernels.rigid_surface import facet_scratch

    rb = sim.rigid
    prog = sim.effects.program()
    coef, pcoef = rb.coefficients()
    P, I, T, S = sim.effects.arrays(rb.mp.size)
    return (prog.forces, prog.facets, coef, np.ascontiguousarray(pcoef[:, :1]), P, I, T, S, np.zeros((0, 11)), 0, 0,
            facet_scratch(0, 0))  # fmt: skip


def test_newton_converges_quadratically():
    """The iterates of one step in the field: each error is at most a constant times the
    square of the previous one until round-off (measured 6.7e-6, 1.9e-11, 0)."""
    sim = emorbit.Simulation(emorbit.CentralField(gm=PAPER_GM), method="em", dt=PAPER_T / 100)
    sim.add_rigid(
        "b",
        "box",
        size=[0.3, 0.2, 0.1],
        density=1000.0,
        refinement=2,
        position=PAPER_X0,
        velocity=PAPER_V0,
        angular_velocity=[0, 0, 0.1],
    )
    sim.run(steps=57, every=57)
    rb = sim.rigid
    iterates = []
    for k in range(1, 6):
        w = kr.work_arrays(rb.X)
        kr.rigid_step(
            *_effects(sim)[:2], kr.METHOD_EM, kr.GRAVITY_VOLUME, rb.q[0].copy(), rb.v[0].copy(), rb.lam[0].copy(),
            rb.mass[0], rb.E[0], rb.Einv[0], rb.X, rb.mp, PAPER_GM, np.zeros(3), sim.dt, k, w, *_effects(sim)[2:],
        )  # fmt: skip
        iterates.append(w[16].copy())
    err = [np.abs(x - iterates[-1]).max() for x in iterates[:-1]]
    assert err[0] > 1e-8  # a real first correction
    assert err[1] <= 1.0 * err[0] ** 2
    assert err[2] <= 1e-15


def test_null_space_solve_matches_the_dense_solve():
    """The null-space solve of the Newton system (free bodies, 'point' gravity) gives the
    dense 18 x 18 solution to round-off (measured 1.3e-15 relative over 200 random systems,
    axes up to 3e-3 off orthonormal, rotations up to about 1 rad per step)."""
    from emorbit.kernels import rigid_solve as rs

    rng = np.random.default_rng(1)
    worst = 0.0
    for trial in range(200):
        R0 = rotation_vector_to_matrix(rng.normal(size=3))
        R1 = rotation_vector_to_matrix(0.3 * rng.normal(size=3)) @ R0 + 1e-3 * rng.normal(size=(3, 3))
        q0 = np.concatenate([rng.normal(size=3), R0.T.ravel()])
        q1 = np.concatenate([rng.normal(size=3), R1.T.ravel()])
        q05 = 0.5 * (q0 + q1)
        A = rng.normal(size=(3, 3))
        m, E, h = 2.0, A @ A.T + np.eye(3), 0.3
        es = np.trace(E) / 3.0
        S = np.empty((3, 3))
        kr._sym(rng.normal(size=6), S)
        K = np.zeros((12, 12))
        K[:3, :3] = rng.normal(size=(3, 3)) * (trial % 2)
        rhs = rng.normal(size=18)
        G05, G1, J = np.empty((6, 12)), np.empty((6, 12)), np.empty((18, 18))
        kr._constraint_jacobian(q05, G05)
        kr._constraint_jacobian(q1, G1)
        rs.dense_kkt(J, K, m, E, S, G05, G1, h, es)
        dense = rhs.copy()
        assert rs.dense_solve(J.copy(), dense, 18)
        null = rhs.copy()
        assert rs.kkt_solve(null, m, E, K, S, q05, q1, h, es, np.empty((9, 3, 3)))
        worst = max(worst, np.abs(null - dense).max() / np.abs(dense).max())
    assert worst < 1e-13, worst


def _step_residual(q0, v0, lam, m, E, F, h, dq):
    """The discrete equations' residual R1 (12) and g(q1) (6) for a step dq with multipliers lam."""
    nu = h * lam
    q05, q1 = q0 + 0.5 * dq, q0 + dq
    G05 = np.empty((6, 12))
    kr._constraint_jacobian(q05, G05)
    M = np.zeros((12, 12))
    M[:3, :3] = m * np.eye(3)
    M[3:, 3:] = np.kron(E, np.eye(3))
    R1 = M @ dq - h * (M @ v0 + 0.5 * h * F) + 0.5 * h * G05.T @ nu
    D = q1[3:].reshape(3, 3)
    return R1, (D @ D.T - np.eye(3))[np.triu_indices(3)]


@pytest.mark.parametrize("case", ["free", "orbit, 1000 points"])
def test_the_step_solves_the_discrete_equations(case):
    """Whatever the solve (null-space for the free body; the centre of mass's load stiffness
    for the 1000-point box in orbit), the returned step zeroes the discrete equations to
    round-off: |R1| below 1e-14 of |M h v0| and the constraints below 4 eps (measured 5e-17
    and 1e-18 free, 2.5e-17 and 2.2e-16 in orbit); Newton takes 2 iterations here (about 2.7
    per step with the predictor that ignored the field's rate and the axes' acceleration)."""
    if case == "free":
        sim = emorbit.Simulation(None, method="em", dt=2e-3)
        sim.add_rigid("b", "box", size=[3.0, 2.0, 1.0], density=1.0, position=[0, 0, 0], velocity=[0, 0, 0],
                      angular_velocity=[0.01, 2.0, 0.01])  # fmt: skip
        model, gm = kr.GRAVITY_NONE, 0.0
    else:
        gm = GM_EARTH
        sim = emorbit.Simulation(emorbit.CentralField(body="earth"), method="em", dt=10.0)
        sim.add_rigid("b", "box", size=[2.0, 1.0, 0.5], density=500.0, refinement=5, position=[R_ORBIT, 0, 0],
                      velocity=[0, np.sqrt(GM_EARTH / R_ORBIT), 0], rotation_vector=[0.05, 0.03, 0.1],
                      angular_velocity=[2e-4, -1e-4, N_ORBIT + 3e-4], angular_velocity_frame="space")  # fmt: skip
        model = kr.GRAVITY_VOLUME
    sim.run(steps=20, every=20)
    rb = sim.rigid
    q0, v0, lam = rb.q[0].copy(), rb.v[0].copy(), rb.lam[0].copy()
    w = kr.work_arrays(rb.X)
    forces, facets, *rest = _effects(sim)
    its, status, stalled = kr.rigid_step(
        forces, facets, kr.METHOD_EM, model, q0, v0, lam, rb.mass[0], rb.E[0], rb.Einv[0], rb.X, rb.mp, gm,
        np.zeros(3), sim.dt, 50, w, *rest,
    )  # fmt: skip
    assert (its, status, stalled) == (2, 0, 0)
    dq = w[16].copy()
    F = np.zeros(12)
    if model == kr.GRAVITY_VOLUME:  # the em force of the converged step, summed afresh
        for d in range(3):
            w[25][d] = q0[d] + rb.X[0] * q0[3 + d] + rb.X[1] * q0[6 + d] + rb.X[2] * q0[9 + d]
        coef, pcoef, P, I, T, S = rest[:6]
        kr.rigid_forces(forces, 0, model, q0, q0 + dq, rb.X, rb.mp, rb.mass[0], sim.dt, coef, pcoef, P, I, T, S, F,
                        w[3], w[4], w[5], w[20], w, False)  # fmt: skip
    R1, g = _step_residual(q0, v0, lam, rb.mass[0], rb.E[0], F, sim.dt, dq)
    scale = np.abs(sim.dt * np.concatenate([rb.mass[0] * v0[:3], np.kron(rb.E[0], np.eye(3)) @ v0[3:]])).max()
    assert np.abs(R1).max() < 1e-14 * scale, np.abs(R1).max() / scale
    assert np.abs(g).max() < 4 * np.finfo(float).eps


# -- gravity gradient ----------------------------------------------------------------------

R_ORBIT = 7.0e6
N_ORBIT = np.sqrt(GM_EARTH / R_ORBIT**3)


def _pitch(res):
    d1 = quaternion_to_matrix(res.attitudes["b"])[:, :, 0]
    p = res.positions["b"]
    radial = p / np.linalg.norm(p, axis=1)[:, None]
    along = np.cross([0.0, 0.0, 1.0], radial)
    return np.arctan2(np.einsum("ij,ij->i", d1, along), np.einsum("ij,ij->i", d1, radial))


def _orbiting_box(angle, orbits, div=2000):
    sim = emorbit.Simulation(emorbit.CentralField(body="earth"), method="em", dt=2 * np.pi / N_ORBIT / div)
    sim.add_rigid(
        "b",
        "box",
        size=[2.0, 1.0, 0.5],
        density=500.0,
        position=[R_ORBIT, 0, 0],
        velocity=[0, np.sqrt(GM_EARTH / R_ORBIT), 0],
        rotation_vector=[0, 0, angle],
        angular_velocity=[0, 0, N_ORBIT],
        angular_velocity_frame="space",
    )
    return sim, sim.run(steps=orbits * div, every=1).si


def test_pitch_libration_frequency():
    """A 2 m box (size/radius 3e-7) in a circular orbit, long axis radial, pitched 1 degree:
    it librates at n sqrt(3 (I_along - I_radial) / I_normal) (1 - theta0^2 / 4); measured
    agreement 3.9e-6, required 4e-5 (10x); energy 9.4e-16, required 1e-14."""
    theta0 = np.radians(1.0)
    sim, res = _orbiting_box(theta0, orbits=8)
    I = sim.rigid.points[0].inertia
    theory = N_ORBIT * np.sqrt(3 * (I[1, 1] - I[0, 0]) / I[2, 2]) * (1 - theta0**2 / 4)
    th, t = _pitch(res), res.time
    i = np.flatnonzero((th[:-1] < 0) & (th[1:] >= 0))
    crossings = t[i] - th[i] * (t[i + 1] - t[i]) / (th[i + 1] - th[i])
    assert crossings.size >= 8
    period = np.polyfit(np.arange(crossings.size), crossings, 1)[0]
    rel = abs(2 * np.pi / period / theory - 1)
    assert rel < 4e-5, f"libration frequency off by {rel:.3g} of linear theory, measured 3.9e-6"
    assert np.abs(th).max() == pytest.approx(theta0, rel=1e-3)  # it librates, it does not tumble
    dE = np.abs(res.relative_energy_error()).max()
    assert dE < 1e-14, f"|dE|/|E0| = {dE:.3g}, measured 9.4e-16"


def test_along_track_orientation_is_unstable():
    """Long axis along track: a 0.01 degree offset grows like theta0 cosh(sigma t) with
    sigma = n sqrt(3 (I_radial - I_along) / I_normal) (measured within 2.1e-4 while < 0.05 rad;
    required 1e-3)."""
    theta0 = np.radians(0.01)
    sim, res = _orbiting_box(np.pi / 2 + theta0, orbits=1)
    I = sim.rigid.points[0].inertia
    sigma = N_ORBIT * np.sqrt(3 * (I[1, 1] - I[0, 0]) / I[2, 2])
    th = _pitch(res) - np.pi / 2
    small = np.abs(th) < 0.05
    assert small.sum() > 100 and np.abs(th).max() > 0.3  # it does depart
    np.testing.assert_allclose(th[small], theta0 * np.cosh(sigma * res.time[small]), rtol=1e-3)


def test_shrinking_body_tends_to_point_mass():
    """The centre-of-mass orbit of a spinning box on the paper's ellipse tends to the point-mass
    orbit as the box shrinks, like size^2 (the quadrupole): after one orbit the difference
    falls by 4.02, 4.005, 4.001 as the size halves from 0.1 m (measured)."""
    point = emorbit.Simulation(emorbit.CentralField(gm=PAPER_GM), method="em", dt=PAPER_T / 100)
    point.add_point("p", mass=1.0, position=PAPER_X0, velocity=PAPER_V0)
    point.run(steps=100, every=100)
    xp = point.state("p")[0]
    diffs = []
    for s in (0.1, 0.05, 0.025, 0.0125):
        sim = emorbit.Simulation(emorbit.CentralField(gm=PAPER_GM), method="em", dt=PAPER_T / 100)
        sim.add_rigid(
            "b",
            "box",
            size=[s, 0.6 * s, 0.3 * s],
            density=1.0,
            position=PAPER_X0,
            velocity=PAPER_V0,
            angular_velocity=[0, 0, 0.2],
        )
        sim.run(steps=100, every=100)
        diffs.append(np.linalg.norm(sim.state("b")[0] - xp))
    np.testing.assert_allclose(np.log2(np.array(diffs[:-1]) / np.array(diffs[1:])), 2.0, atol=0.01)
    assert diffs[-1] < 1e-3


def test_em_exact_midpoint_not_over_1000_orbits():
    """A discretised box (8 mass points, gravity over the volume) on the paper's ellipse for
    1000 orbits at T/100: em keeps energy to round-off (6.1e-14), midpoint's oscillates (8e-2)."""
    out = {}
    for method in ("em", "midpoint"):
        sim = emorbit.Simulation(emorbit.CentralField(gm=PAPER_GM), method=method, dt=PAPER_T / 100)
        sim.add_rigid(
            "b",
            "box",
            size=[0.5, 0.3, 0.2],
            density=1000.0,
            position=PAPER_X0,
            velocity=PAPER_V0,
            angular_velocity=[0.02, 0.01, 0.1],
        )
        out[method] = sim.run(steps=100_000, every=100)
    # measured: em 6.1e-14 (energy) and 5.7e-15 (angular momentum); midpoint 8.0e-2 and 3.8e-15
    dE = np.abs(out["em"].relative_energy_error()).max()
    assert dE <= 6e-13, f"em: |dE|/|E0| = {dE:.3g}, measured 6.1e-14"
    assert out["em"].relative_angular_momentum_error().max() <= 5.7e-14
    assert np.abs(out["midpoint"].relative_energy_error()).max() > 1e-3
    assert out["midpoint"].relative_angular_momentum_error().max() <= 3.8e-14


def test_gravity_models():
    """'point' puts all mass at the centre of mass (no torque: the spin is untouched) and
    costs no mass-point work; 'volume' exerts the gravity-gradient torque. Measured over 500
    steps: the energy kept to 2.7e-15 ('point') and 2.3e-15 ('volume'), bounds about 5x (a
    random walk of roundings: 1.1e-14 and 7.8e-15 after 20,000 steps); the spin
    stays exactly 0 with 'point' and reaches 0.44 rad/s with 'volume'."""
    spins = {}
    for model in ("point", "volume"):
        sim = emorbit.Simulation(emorbit.CentralField(gm=PAPER_GM), method="em", dt=PAPER_T / 100)
        sim.add_rigid(
            "b",
            "box",
            size=[0.4, 0.1, 0.06],
            density=1.0,
            position=PAPER_X0,
            velocity=PAPER_V0,
            rotation_vector=[0, 0, 0.4],
            gravity=model,
        )
        res = sim.run(steps=500, every=500).si
        spins[model] = np.abs(res.angular_velocities["b"][-1]).max()
        dE = np.abs(res.relative_energy_error()).max()
        bound, measured = {"point": (1.4e-14, 2.7e-15), "volume": (1.2e-14, 2.3e-15)}[model]
        assert dE < bound, f"{model}: |dE|/|E0| = {dE:.3g}, measured {measured:.2g}"
    assert spins["point"] == 0.0, spins["point"]  # no torque: the body at rest stays at rest
    assert spins["volume"] > 1e-3


def test_chunking_is_bit_identical_and_mixed_scenes():
    def make():
        sim = emorbit.Simulation(emorbit.CentralField(gm=PAPER_GM), method="em", order=4, dt=PAPER_T / 100)
        sim.add_point("p", mass=1.0, position=PAPER_X0, velocity=PAPER_V0)
        sim.add_rigid(
            "b",
            "cylinder",
            radius=0.2,
            height=0.5,
            density=100.0,
            refinement=1,
            position=-PAPER_X0,
            velocity=-PAPER_V0,
            angular_velocity=[0.1, 0.2, 0.3],
        )
        return sim

    a, b = make(), make()
    ra = a.run(steps=300, every=1)
    b.run(steps=123, every=7)
    b.run(steps=177, every=100)
    assert np.array_equal(a.rigid.q, b.rigid.q) and np.array_equal(a.rigid.v, b.rigid.v)
    assert np.array_equal(a.points.x, b.points.x)
    dE = np.abs(ra.relative_energy_error()).max()
    assert dE < 1.7e-14, f"|dE|/|E0| = {dE:.3g} over 300 steps, measured 3.4e-15"
    assert ra.kinds == {"p": "point", "b": "rigid"}


# -- scenes, files and plots ---------------------------------------------------------------


@pytest.mark.parametrize("scene", ["rigid-tumbling-box", "rigid-dumbbell-libration", "rigid-box-paper-ellipse"])
def test_shipped_rigid_scenes(tmp_path, scene):
    """The shipped rigid scenes run and are plotted: unit quaternions to 1.1e-15 (measured
    2.2e-16, one rounding), the energy to 5x its measured worst (rigid-tumbling-box 1.8e-15,
    rigid-dumbbell-libration 1.1e-15, rigid-box-paper-ellipse 7.8e-15)."""
    out = tmp_path / "r.h5"
    assert main(["run", scene, "-o", str(out), "-q"]) == 0
    with h5py.File(out, "r") as f:
        name = next(iter(f["bodies"]))
        g = f["bodies"][name]
        assert g.attrs["kind"] == "rigid"
        assert g["attitude"].attrs["unit"] == "1" and g["attitude"].shape[1] == 4
        assert g["angular_velocity"].attrs["unit"] == "rad / s"
        assert g["mass_points/position"].shape[0] == g.attrs["mass_points"]
        norm = np.abs(np.linalg.norm(g["attitude"][()], axis=1) - 1).max()
        assert norm <= 1.1e-15, f"|q| off 1 by {norm:.3g}, measured <= 2.2e-16"
        e = f["invariants/energy"][()]
        dE = np.abs(e / e[0] - 1).max()
        bound, measured = {
            "rigid-tumbling-box": (9e-15, 1.8e-15),
            "rigid-dumbbell-libration": (5.5e-15, 1.1e-15),
            "rigid-box-paper-ellipse": (4e-14, 7.8e-15),
        }[scene]
        assert dE < bound, f"|dE|/|E0| = {dE:.3g}, measured {measured:.2g}"
    fig = tmp_path / "r.png"
    assert main(["plot", str(out), "-o", str(fig)]) == 0 and fig.stat().st_size > 10_000


def test_dumbbell_scene_librates_at_sqrt3_n(tmp_path):
    """The shipped dumbbell: pitch libration at n sqrt(3) for a body with I_radial ~ 0
    (end spheres give I_radial / I_normal = 8e-4, included in the theory below): measured
    1.9e-5 off it over 8 swings (bound 1e-4)."""
    sim = emorbit.load_scene("rigid-dumbbell-libration").build()
    res = sim.run(t_end=sim.t_end_requested, every=1).si
    d1 = quaternion_to_matrix(res.attitudes["dumbbell"])[:, :, 0]
    p = res.positions["dumbbell"]
    radial = p / np.linalg.norm(p, axis=1)[:, None]
    th = np.arctan2(np.einsum("ij,ij->i", d1, np.cross([0, 0, 1.0], radial)), np.einsum("ij,ij->i", d1, radial))
    I = sim.rigid.points[0].inertia
    n = np.sqrt(GM_EARTH / 7.0e6**3)
    theta0 = np.radians(5.0)
    theory = n * np.sqrt(3 * (I[1, 1] - I[0, 0]) / I[2, 2]) * (1 - theta0**2 / 4)
    i = np.flatnonzero((th[:-1] < 0) & (th[1:] >= 0))
    t = res.time
    crossings = t[i] - th[i] * (t[i + 1] - t[i]) / (th[i + 1] - th[i])
    period = np.polyfit(np.arange(crossings.size), crossings, 1)[0]
    off = 2 * np.pi / period / theory - 1
    assert abs(off) < 1e-4, f"libration frequency off by {off:.3g}, measured -1.9e-5"


def test_adding_a_body_later_keeps_the_others_bit_for_bit():
    """A rigid body added between runs leaves the others' compensation terms and Newton warm
    starts as they were, so they go on exactly as if it had not been added (the energy kept to 3.3e-16,
    measured; bound 1.7e-15)."""

    def sim():
        s = emorbit.Simulation(emorbit.CentralField(gm=3.9478), method="em", dt=0.2)
        s.add_rigid(
            "a",
            "box",
            size=[1.0, 0.5, 0.2],
            density=1.0,
            position=[6, 0, 0],
            velocity=[0, 0.8, 0],
            angular_velocity=[0.1, 0.3, 1.0],
        )
        return s

    plain, grown = sim(), sim()
    for s in (plain, grown):
        s.run(steps=200, every=200, progress=False)
    assert np.any(grown.rigid.lam != 0.0)  # warm starts to keep
    grown.add_rigid("b", "box", size=[1.0, 1.0, 1.0], density=2.0, position=[0, 7, 0], velocity=[-0.7, 0, 0])
    plain.run(steps=200, every=200, progress=False)
    r = grown.run(steps=200, every=200, progress=False)
    for k in (0, 1):
        assert np.array_equal(plain.state("a")[k], grown.state("a")[k])
    assert np.array_equal(plain.rigid.q[0], grown.rigid.q[0])
    dE = np.abs(r.relative_energy_error()).max()
    assert dE < 1.7e-15, f"|dE|/|E0| = {dE:.3g}, measured 3.3e-16"
