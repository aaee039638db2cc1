"""The conserving discrete forces of :mod:`emorbit.kernels.effects`: exact work, the gradient
limit, the pole torque, the Jacobians, the zonal potential and the shipped Earth model.

The potential and its gradient are evaluated independently here with
:mod:`numpy.polynomial.legendre`. Pairs of states come in four kinds: independent points
0.5 to 5 R from the centre ("far"), an end point close to the start ("near", relative
distances 1e-12 to 1e-1), ``r1 = r0`` exactly and ``z1 = z0`` exactly.

Round-off scales (measured maxima in the comments, in units of eps):

- central: ``|F . dx + dV| <= 16 eps (|V0| + |V1|)`` (measured 1.2 eps);
- zonal: ``|F . dx + dV| <= 16 eps * s`` (measured 2.0 eps) with ``s = sum_terms |C| (|z0|^k + |z1|^k)
  (r0^-m + r1^-m)``, the size of the terms ``C z^k r^-m`` and of the intermediate products
  of the discrete gradient. ``|V0| + |V1|`` is no scale for the zonal part alone: V_zonal
  vanishes on the cones where its Legendre sum does (for J2, ``z^2 = r^2 / 3``) while its
  terms do not, and for distant points ``g0 f1`` exceeds both ``|V0|`` and ``|V1|``; the
  potential itself is evaluated no better than ``eps * s``.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import legendre as L

from emorbit.effects.zonal import zonal_model
from emorbit.kernels.effects import (
    central_force,
    central_jacobian,
    central_potential,
    zonal_force,
    zonal_jacobian,
    zonal_potential,
)
from emorbit.kernels.effects.zonal import _LEGENDRE

EPS = np.finfo(float).eps
R = 6378136.3
GM = 3.986004415e14
EARTH_JN = np.array(zonal_model("earth")["jn"])
#: J2..J6 all of the size of J2, so that the high degrees are not hidden under J2
STRESS_JN = np.array([1.1e-3, -0.9e-3, 0.8e-3, 1.2e-3, -1.0e-3])
N = 200
#: the work tolerance, in eps times the scale
WORK_TOL = 16.0


def _unit(rng, n):
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1)[:, None]


def _poles(rng):
    return {"z": np.array([0.0, 0.0, 1.0]), "random": _unit(rng, 1)[0]}


def _pairs(kind, rng, centre):
    """(x0, x1), each (N, 3): the pairs of states of one kind."""
    r0 = R * rng.uniform(0.5, 5.0, N)
    d0 = _unit(rng, N) * r0[:, None]
    if kind == "far":
        d1 = _unit(rng, N) * (R * rng.uniform(0.5, 5.0, N))[:, None]
    elif kind == "near":
        d1 = d0 + _unit(rng, N) * (r0 * 10.0 ** rng.uniform(-12, -1, N))[:, None]
    elif kind == "r_equal":  # sign flips: |d1| = |d0| to the bit; z1 = -z0 or z1 = z0
        flip = np.where(rng.random(N)[:, None] < 0.5, [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0])
        d1 = d0 * flip
    elif kind == "z_equal":  # pole along z: z1 = z0 to the bit, r1 != r0
        d1 = np.column_stack([R * rng.uniform(-3, 3, N), R * rng.uniform(-3, 3, N), d0[:, 2]])
    else:
        raise ValueError(kind)
    if kind in ("r_equal", "z_equal"):  # centre 0 and pole e_z keep the equalities exact
        return d0, d1
    return centre + d0, centre + d1


KINDS = ["far", "near", "r_equal", "z_equal"]


def _setup(kind, pole_kind, seed):
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-1e6, 1e6, 3)
    pole = _poles(rng)[pole_kind]
    x0, x1 = _pairs(kind, rng, centre)
    if kind in ("r_equal", "z_equal"):
        centre = np.zeros(3)
        pole = np.array([0.0, 0.0, 1.0])
    return x0, x1, centre, pole


def _vz(x, c, p, jn):
    return zonal_potential(x[0], x[1], x[2], c[0], c[1], c[2], p[0], p[1], p[2], GM, R, jn)


def _fz(x0, x1, c, p, jn):
    return np.array(zonal_force(*x0, *x1, *c, *p, GM, R, jn))


def _jz(x0, x1, c, p, jn, J):
    zonal_jacobian(*x0, *x1, *c, *p, GM, R, jn, J)


def _vc(x, c):
    return central_potential(x[0], x[1], x[2], c[0], c[1], c[2], GM)


def _fc(x0, x1, c):
    return np.array(central_force(*x0, *x1, *c, GM))


def _jc(x0, x1, c, J):
    central_jacobian(*x0, *x1, *c, GM, J)


def _terms(jn):
    """[(n, k, a_nk)] of the zonal series, from numpy's Legendre-to-power conversion."""
    out = []
    for n in range(2, len(jn) + 2):
        a = L.leg2poly(np.eye(n + 1)[n])
        out += [(n, k, a[k]) for k in range(n + 1) if a[k] != 0.0]
    return out


def _zonal_scale(x0, x1, c, p, jn):
    """sum_terms |C| (|z0|^k + |z1|^k) (r0^-m + r1^-m), C = gm J_n R^n a_nk, m = n + 1 + k."""
    d0, d1 = x0 - c, x1 - c
    r0, r1 = np.linalg.norm(d0), np.linalg.norm(d1)
    z0, z1 = d0 @ p / R, d1 @ p / R
    s = 0.0
    for n, k, a in _terms(jn):
        m = n + 1 + k
        s += abs(jn[n - 2] * a) * (abs(z0) ** k + abs(z1) ** k) * ((r0 / R) ** -m + (r1 / R) ** -m)
    return GM / R * s


def _v_numpy(x, c, p, jn):
    """V_zonal from numpy's Legendre series, and its scale gm/r sum |J_n| (R/r)^n."""
    d = x - c
    r = np.linalg.norm(d)
    s = d @ p / r
    v = sum(jn[n - 2] * (R / r) ** n * L.legval(s, np.eye(n + 1)[n]) for n in range(2, len(jn) + 2))
    return GM / r * v, GM / r * np.sum(np.abs(jn) * (R / r) ** np.arange(2, len(jn) + 2))


def _grad_numpy(x, c, p, jn):
    """grad V_zonal, analytic: V = sum gm J_n R^n r^-(n+1) P_n(s), s = z / r."""
    d = x - c
    r = np.linalg.norm(d)
    z = d @ p
    s = z / r
    ds = p / r - z * d / r**3
    g = np.zeros(3)
    for n in range(2, len(jn) + 2):
        e = np.eye(n + 1)[n]
        cn = GM * jn[n - 2] * R**n
        g += -(n + 1) * cn * r ** -(n + 2) * L.legval(s, e) * d / r + cn * r ** -(n + 1) * L.legval(s, L.legder(e)) * ds
    return g


# --- work equals the potential drop -------------------------------------------------------


@pytest.mark.parametrize("kind", KINDS)
def test_central_work_is_the_potential_drop(kind):
    x0, x1, c, _ = _setup(kind, "z", 1)
    worst = 0.0
    for a, b in zip(x0, x1):
        w = _fc(a, b, c) @ (b - a)
        v0, v1 = _vc(a, c), _vc(b, c)
        worst = max(worst, abs(w + (v1 - v0)) / (EPS * (abs(v0) + abs(v1))))
    # measured: at most 1.2 eps (|V0| + |V1|)
    assert worst <= WORK_TOL, worst


@pytest.mark.parametrize("pole_kind", ["z", "random"])
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("jn", [EARTH_JN[:1], EARTH_JN, STRESS_JN], ids=["J2", "earth", "stress"])
def test_zonal_work_is_the_potential_drop(kind, pole_kind, jn):
    x0, x1, c, p = _setup(kind, pole_kind, 2)
    worst = 0.0
    for a, b in zip(x0, x1):
        w = _fz(a, b, c, p, jn) @ (b - a)
        v0, v1 = _vz(a, c, p, jn), _vz(b, c, p, jn)
        worst = max(worst, abs(w + (v1 - v0)) / (EPS * _zonal_scale(a, b, c, p, jn)))
    # measured: at most 2.0 eps of the term scale
    assert worst <= WORK_TOL, worst


def test_work_check_fails_for_a_force_that_is_not_conserving():
    """The check above detects a discrete force that is only the midpoint gradient."""
    x0, x1, c, p = _setup("near", "random", 3)
    a, b = x0[0], x0[0] + 1e-2 * R * np.array([1.0, 0.5, -0.3])
    mid = 0.5 * (a + b)
    w = -_grad_numpy(mid, c, p, STRESS_JN) @ (b - a)
    v0, v1 = _vz(a, c, p, STRESS_JN), _vz(b, c, p, STRESS_JN)
    assert abs(w + (v1 - v0)) > WORK_TOL * EPS * _zonal_scale(a, b, c, p, STRESS_JN)


# --- the gradient limit ---------------------------------------------------------------------


@pytest.mark.parametrize("pole_kind", ["z", "random"])
def test_forces_tend_to_the_gradient(pole_kind):
    x0, _, c, p = _setup("near", pole_kind, 4)
    rng = np.random.default_rng(5)
    worst = 0.0
    for a in x0:
        b = a + _unit(rng, 1)[0] * 1e-9 * np.linalg.norm(a - c)
        d = a - c
        g_central = -GM * d / np.linalg.norm(d) ** 3
        for got, want in [
            (_fc(a, a, c), g_central),
            (_fc(a, b, c), g_central),
            (_fz(a, a, c, p, STRESS_JN), -_grad_numpy(a, c, p, STRESS_JN)),
            (_fz(a, b, c, p, STRESS_JN), -_grad_numpy(a, c, p, STRESS_JN)),
            (_fz(a, b, c, p, EARTH_JN[:1]), -_grad_numpy(a, c, p, EARTH_JN[:1])),
        ]:
            worst = max(worst, np.linalg.norm(got - want) / np.linalg.norm(want))
    # measured: 4.6e-9 (the 1e-9 offset); 2e-14 at x1 = x0
    assert worst <= 1e-7, worst


# --- angular momentum about the pole ---------------------------------------------------------


@pytest.mark.parametrize("pole_kind", ["z", "random"])
@pytest.mark.parametrize("kind", KINDS)
def test_zonal_force_has_no_torque_about_the_pole(kind, pole_kind):
    x0, x1, c, p = _setup(kind, pole_kind, 6)
    worst = 0.0
    for a, b in zip(x0, x1):
        f = _fz(a, b, c, p, STRESS_JN)
        xm = 0.5 * ((a - c) + (b - c))
        worst = max(worst, abs(p @ np.cross(xm, f)) / (EPS * np.linalg.norm(xm) * np.linalg.norm(f)))
    # measured: at most 0.9 eps
    assert worst <= 8.0, worst


def test_torque_check_fails_for_a_force_off_the_plane():
    x0, x1, c, p = _setup("far", "random", 7)
    a, b = x0[0], x1[0]
    f = _fz(a, b, c, p, STRESS_JN) + 1e-12 * np.linalg.norm(_fz(a, b, c, p, STRESS_JN)) * np.cross(p, a - c)
    xm = 0.5 * ((a - c) + (b - c))
    assert abs(p @ np.cross(xm, f)) > 8.0 * EPS * np.linalg.norm(xm) * np.linalg.norm(f)


# --- Jacobians --------------------------------------------------------------------------------


def _fd_jacobian(force, x0, x1):
    J = np.zeros((3, 3))
    h = 1e-5 * np.linalg.norm(x1)
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        J[:, j] = (force(x0, x1 + e) - force(x0, x1 - e)) / (2 * h)
    return J


def _jacobian_error(kernel, force, x0, x1):
    fd = _fd_jacobian(force, x0, x1)
    start = np.random.default_rng(8).normal(size=(3, 3)) * np.abs(fd).max()
    J = start.copy()
    kernel(x0, x1, J)
    J -= start  # the kernels add into J
    return np.abs(J - fd).max() / np.abs(fd).max()


@pytest.mark.parametrize("kind", KINDS)
def test_central_jacobian_matches_finite_differences(kind):
    x0, x1, c, _ = _setup(kind, "z", 9)
    worst = 0.0
    for a, b in zip(x0, x1):
        worst = max(worst, _jacobian_error(lambda u, v, J: _jc(u, v, c, J), lambda u, v: _fc(u, v, c), a, b))
    # measured: 1.3e-10 to 1.8e-10 over the kinds (finite-difference error)
    assert worst <= 2e-9, worst


@pytest.mark.parametrize("pole_kind", ["z", "random"])
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize(
    "jn, bound", [(EARTH_JN[:1], 1e-8), (EARTH_JN, 3e-8), (STRESS_JN, 2e-7)], ids=["J2", "earth", "stress"]
)
def test_zonal_jacobian_matches_finite_differences(kind, pole_kind, jn, bound):
    x0, x1, c, p = _setup(kind, pole_kind, 10)
    worst = 0.0
    for a, b in zip(x0[:100], x1[:100]):
        err = _jacobian_error(lambda u, v, J: _jz(u, v, c, p, jn, J), lambda u, v: _fz(u, v, c, p, jn), a, b)
        worst = max(worst, err)
    # measured over the kinds and poles: 9.9e-10 (J2), 3.0e-9 (earth), 2.1e-8 (stress): the
    # finite-difference error; bounds about 10x
    assert worst <= bound, worst


def test_jacobian_check_fails_for_a_wrong_jacobian():
    x0, x1, c, p = _setup("far", "random", 11)

    def wrong(u, v, J):
        _jz(u, v, c, p, STRESS_JN, J)
        J[0, 1] += 1e-4 * np.abs(J).max()

    assert _jacobian_error(wrong, lambda u, v: _fz(u, v, c, p, STRESS_JN), x0[0], x1[0]) > 2e-7


# --- the zonal potential and the model --------------------------------------------------------


def test_legendre_table_is_numpys():
    for n in range(7):
        np.testing.assert_allclose(_LEGENDRE[n, : n + 1], L.leg2poly(np.eye(n + 1)[n]), rtol=1e-15, atol=0)
        assert not _LEGENDRE[n, n + 1 :].any()


@pytest.mark.parametrize("pole_kind", ["z", "random"])
@pytest.mark.parametrize("degree", [2, 3, 4, 5, 6])
def test_zonal_potential_matches_numpy_legendre(degree, pole_kind):
    x0, _, c, p = _setup("far", pole_kind, 12)
    jn = STRESS_JN[: degree - 1]
    worst = 0.0
    for a in x0:
        want, scale = _v_numpy(a, c, p, jn)
        worst = max(worst, abs(_vz(a, c, p, jn) - want) / (EPS * scale))
    # measured: at most 6.1 eps
    assert worst <= 32.0, worst


def test_zonal_potential_sign_oblate_body_attracts_more_at_the_equator():
    """J2 > 0: V_zonal < 0 on the equator, > 0 over the pole."""
    c, p = np.zeros(3), np.array([0.0, 0.0, 1.0])
    assert _vz(np.array([2 * R, 0.0, 0.0]), c, p, EARTH_JN[:1]) < 0.0
    assert _vz(np.array([0.0, 0.0, 2 * R]), c, p, EARTH_JN[:1]) > 0.0


def test_pole_direction_is_a_rotation():
    """A random pole gives the potential and force of the z pole in rotated coordinates."""
    rng = np.random.default_rng(13)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    ez, c = np.array([0.0, 0.0, 1.0]), np.zeros(3)
    p = Q @ ez
    x0, x1, _, _ = _setup("far", "z", 14)
    for a, b in zip(x0[:50], x1[:50]):
        v_rot, v = _vz(Q @ a, c, p, STRESS_JN), _vz(a, c, ez, STRESS_JN)
        assert abs(v_rot - v) <= 64 * EPS * _zonal_scale(a, b, c, ez, STRESS_JN)
        f_rot, f = _fz(Q @ a, Q @ b, c, p, STRESS_JN), Q @ _fz(a, b, c, ez, STRESS_JN)
        assert np.linalg.norm(f_rot - f) <= 1e-12 * np.linalg.norm(f)  # measured 8.7e-14


def test_earth_model():
    """The shipped EGM2008 file: J2 as published (1.0826261738e-3 within 1e-9), J_n =
    -C_n0 sqrt(2n + 1), GM and radius as EGM2008 states them; the file is heyoka's table bit
    for bit (scripts/data_egm2008.py --check)."""
    m = zonal_model("earth")
    assert abs(m["jn"][0] / 1.0826261738e-3 - 1.0) <= 1e-9
    for n, (j, cbar) in enumerate(zip(m["jn"], m["cbar"]), start=2):
        assert j == -cbar * np.sqrt(2 * n + 1)
    assert len(m["jn"]) == 5 and m["radius"] == 6378136.3 and m["gm"] == 3.986004415e14
    heyoka = pytest.importorskip("heyoka")
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    check = subprocess.run([sys.executable, str(root / "scripts" / "data_egm2008.py"), "--check"], capture_output=True)
    assert check.returncode == 0, check.stdout.decode() + check.stderr.decode()
    CS = np.asarray(heyoka.model.get_egm2008_CS())
    assert m["cbar"] == tuple(CS[[0, 3, 7, 12, 18], 0])


def test_pair_gravity_work_is_the_pair_potential_drop():
    """Mutual gravity: the central kernel with d = x_i - x_j, c = 0, gm = G m_j on i; the
    opposite times m_i / m_j on j; the total work is the drop of -G m_i m_j / |x_i - x_j|."""
    rng = np.random.default_rng(15)
    G, mi, mj = 6.674e-11, 5.97e24, 7.35e22
    zero = np.zeros(3)
    for _ in range(50):
        xi0, xj0 = rng.normal(size=3) * 4e8, rng.normal(size=3) * 4e8
        xi1, xj1 = xi0 + rng.normal(size=3) * 1e6, xj0 + rng.normal(size=3) * 1e6
        fi = np.array(central_force(*(xi0 - xj0), *(xi1 - xj1), *zero, G * mj))
        fj = -fi * mi / mj
        work = mi * fi @ (xi1 - xi0) + mj * fj @ (xj1 - xj0)
        v0 = -G * mi * mj / np.linalg.norm(xi0 - xj0)
        v1 = -G * mi * mj / np.linalg.norm(xi1 - xj1)
        assert abs(work + (v1 - v0)) <= 1e-10 * abs(v1 - v0)


def test_pair_unit_and_pair_force_are_central_force_with_unit_gm():
    """The mutual-gravity pair kernels: the same force as central_force (gm = 1, centre 0), the
    Jacobian central_jacobian's, and a bound above every entry of it."""
    from emorbit.kernels.effects.central import central_force, central_jacobian, pair_force, pair_unit

    rng = np.random.default_rng(11)
    for _ in range(200):
        a = rng.normal(size=3) * 10.0 ** rng.uniform(-1, 2)
        b = a + rng.normal(size=3) * np.linalg.norm(a) * 10.0 ** rng.uniform(-8, -0.5)
        J = np.zeros((3, 3))
        ref_J = np.zeros((3, 3))
        s_u = pair_unit(*a, *b, J)
        s_f = pair_force(*a, *b)
        ref = central_force(*a, *b, 0.0, 0.0, 0.0, 1.0)
        central_jacobian(*a, *b, 0.0, 0.0, 0.0, 1.0, ref_J)
        np.testing.assert_allclose(s_u[:3], ref, rtol=4e-16 * 8)
        np.testing.assert_allclose(s_f[:3], ref, rtol=4e-16 * 8)
        np.testing.assert_allclose(J, ref_J, rtol=1e-13, atol=1e-13 * np.abs(ref_J).max())
        assert np.abs(J).max() <= s_u[3] and np.isclose(s_u[3], s_f[3], rtol=1e-14)


def test_dense_newton_update_solves_the_system_and_reports_a_singular_one():
    """The few-point Newton update (pair blocks included) agrees with NumPy's solve, and a
    singular matrix gives False (the step then fails as singular) instead of raising."""
    from emorbit.kernels.pointmass.effect_step import _dense_update

    rng = np.random.default_rng(5)
    n, hh = 3, 0.3
    W = rng.normal(size=(9, n))
    F, w = rng.normal(size=(3, n)), rng.normal(size=(3, n))
    m = rng.uniform(1.0, 2.0, n)
    acc = np.zeros((n, n, 4, 4, 3, 3))
    for i in range(n):
        for j in range(i + 1, n):
            acc[i, j, 0, 0] = rng.normal(size=(3, 3))
    A, rhs = np.empty((3 * n, 3 * n)), np.empty(3 * n)
    assert _dense_update(A, rhs, acc, W, F, w, m, hh)
    A_ref = np.eye(3 * n)
    for i in range(n):
        A_ref[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] -= hh * W[:, i].reshape(3, 3)
        for j in range(i + 1, n):
            A_ref[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] = hh * acc[i, j, 0, 0] / m[i]
            A_ref[3 * j : 3 * j + 3, 3 * i : 3 * i + 3] = hh * acc[i, j, 0, 0] / m[j]
    expected = np.linalg.solve(A_ref, (w - hh * F).T.ravel())
    np.testing.assert_allclose(rhs, expected, rtol=1e-12, atol=1e-12)
    W_singular = np.zeros((9, n))
    W_singular[[0, 4, 8], 0] = 1.0 / hh  # point 0's block I - hh W is 0
    assert not _dense_update(A, rhs, np.zeros_like(acc), W_singular, F, w, m, hh)
