"""The validation case ``centre-of-gravity``: emorbit's resultant gravity force and torque on
rigid bodies of mass points against exact sums and closed forms, and the gap between the centre
of gravity and the centre of mass against quadrupole theory. Its quick form passes every check;
a wrong GM in the referees, a rod of another length in the closed form and a wrong coefficient in
the quadrupole formula each fail the checks they referee; the closed forms hold in their limits."""

import dataclasses
import math

import numpy as np
import pytest
from validation_support import failed_ids, passed_cases, quick_report

from emorbit.validation import centre_of_gravity as cg

GM = 3.9478


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    return quick_report(tmp_path_factory, cg.NAMES)


def test_the_quick_case_passes_every_check(quick):
    case = passed_cases(quick, ["centre-of-gravity"], cg.NOTE)["centre-of-gravity"]
    ids = {ch["id"] for ch in case["checks"]}
    assert {"resultant-force", "resultant-torque", "dumbbell-force", "rod-closed-form", "rod-order"} <= ids
    assert {"rod-euler-maclaurin", "em-step-force", "em-step-torque", "em-step-force-order"} <= ids
    assert {f"gap-{k}-{b}" for k in ("quadrupole", "order") for b in ("box", "rod")} <= ids
    # the gap is of order l^2 / r (box at r = 10 m: 0.047 to 0.096 m, l^2 / r = 0.233 m)
    ((lo, hi),) = [(row["least"], row["greatest"]) for row in case["metrics"]["gap.box"]["value"]]
    assert 0.1 < lo / 0.2333 < hi / 0.2333 < 1.0


def _small():
    case = cg.cases("quick")["centre-of-gravity"]
    s = dict(case.settings, attitudes=8, closed_form_attitudes=8)
    return dataclasses.replace(case, settings=s)


def test_a_wrong_gm_in_the_referees_fails(tmp_path):
    """The referees' GM 1e-9 too large: the resultants against the exact sums and the closed
    forms are off by 1e-9 (their round-off is 1e-16), the rod's error floors; the gap, which
    compares emorbit's own force with quadrupole theory, does not see it."""
    case = _small()
    case.settings["referee_gm"] = GM * (1 + 1e-9)
    failed = failed_ids(cg.run(case, "quick", str(tmp_path), figures=False))
    assert {"resultant-force", "resultant-torque", "dumbbell-force", "em-step-force", "em-step-torque"} <= failed
    assert {"rod-order", "rod-euler-maclaurin"} <= failed
    assert not failed & {"gap-quadrupole-box", "gap-order-box", "rod-closed-form"}


def test_a_rod_of_another_length_in_the_closed_form_fails(tmp_path, monkeypatch):
    """The closed form for a rod 1e-4 longer: against Gauss-Legendre on the right rod and against
    emorbit's N-point rods (whose error then stops falling at N ~ 100)."""
    right = cg.rod_force
    monkeypatch.setattr(cg, "rod_force", lambda mass, length, *a: right(mass, length * (1 + 1e-4), *a))
    failed = failed_ids(cg.run(_small(), "quick", str(tmp_path), figures=False))
    assert {"rod-closed-form", "rod-order", "rod-euler-maclaurin"} <= failed
    assert not failed & {"resultant-force", "resultant-torque", "gap-quadrupole-box"}


def test_a_wrong_coefficient_in_the_quadrupole_formula_fails(tmp_path, monkeypatch):
    """9 u.I u / 4 replaced by 8.5 u.I u / 4 in the radial part: a deviation of order 10 %
    that does not fall with r."""
    right = cg.quadrupole_gap

    def wrong(inertia, mass, position):
        I, x = np.asarray(inertia, float), np.asarray(position, float)
        R = float(np.linalg.norm(x))
        u = x / R
        return right(I, mass, x) - 0.5 * float(u @ I @ u) / 4.0 * u / (mass * R)

    monkeypatch.setattr(cg, "quadrupole_gap", wrong)
    failed = failed_ids(cg.run(_small(), "quick", str(tmp_path), figures=False))
    assert {"gap-quadrupole-box", "gap-order-box", "gap-quadrupole-rod", "gap-order-rod"} <= failed
    assert not failed & {"resultant-force", "rod-order"}


@pytest.mark.parametrize(
    "axis, what",
    [((1.0, 0.0, 0.0), "pointing at the centre"), ((0.0, 1.0, 0.0), "across"), ((0.6, 0.48, 0.64), "oblique")],
)
def test_the_rod_closed_form_against_quadrature(axis, what):
    """Both forms of A (the centre beyond an end, and beside the rod) agree with 64-point
    Gauss-Legendre to round-off (measured below 1e-15), and the torque is -x_c x F: the line of
    action passes through the centre."""
    x = np.array([10.0, 0.0, 0.0])
    e = np.asarray(axis) / np.linalg.norm(axis)
    F, tau = cg.rod_force(6.0, 3.0, GM, x, e)
    gl = cg.gauss_legendre_rod(6.0, 3.0, GM, x, e)
    assert np.linalg.norm(F - gl) / np.linalg.norm(F) < 2e-15, what
    np.testing.assert_allclose(tau, -np.cross(x, F), rtol=0, atol=1e-14 * np.linalg.norm(x) * np.linalg.norm(F))


def test_a_short_rod_is_a_point_mass_and_a_point_mass_has_its_centre_of_gravity_at_its_centre():
    x = np.array([3.0, -4.0, 12.0])
    point = -GM * 6.0 * x / np.linalg.norm(x) ** 3
    F, _ = cg.rod_force(6.0, 1e-6, GM, x, np.array([0.0, 0.6, 0.8]))
    assert np.linalg.norm(F - point) / np.linalg.norm(point) < 1e-13
    np.testing.assert_allclose(cg.centre_of_gravity(point, 6.0, GM), x, rtol=2e-16 * 4)
    Fk, tau = cg.kernel_resultant(np.zeros((3, 1)), np.array([6.0]), GM, x, np.eye(3))
    np.testing.assert_allclose(Fk, point, rtol=4e-16)
    assert np.all(tau == 0)


def test_quadrupole_theory_gives_no_gap_for_an_isotropic_body():
    """A body with I = c 1 (a sphere's) has no quadrupole: no gap to first order."""
    gap = cg.quadrupole_gap(2.7 * np.eye(3), 6.0, np.array([3.0, -4.0, 12.0]))
    assert np.abs(gap).max() < 1e-16


def test_the_dumbbell_closed_form_is_the_sum_over_its_two_points():
    x, e = np.array([7.0, 5.0, -3.0]), np.array([0.0, 0.6, 0.8])
    (m1, m2), L = (2.0, 1.0), 3.0
    ends = (x - m2 * L / 3.0 * e, x + m1 * L / 3.0 * e)
    direct = sum(-GM * m * p / np.linalg.norm(p) ** 3 for m, p in zip((m1, m2), ends))
    np.testing.assert_allclose(cg.dumbbell_force((m1, m2), L, GM, x, e), direct, rtol=1e-15)


def test_bad_input_is_refused_by_name():
    with pytest.raises(ValueError, match="n must be an integer >= 1, got 0"):
        cg.rod_points(6.0, 3.0, 0)
    with pytest.raises(ValueError, match="mass and length"):
        cg.rod_points(-1.0, 3.0, 4)
    with pytest.raises(ValueError, match="farther than L/2"):
        cg.rod_force(6.0, 3.0, GM, [1.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="X must be"):
        cg.kernel_resultant(np.zeros((2, 3)), np.ones(3), GM, [10.0, 0.0, 0.0], np.eye(3))
    with pytest.raises(ValueError, match="status"):
        cg.kernel_resultant(np.zeros((3, 1)), np.ones(1), GM, [0.0, 0.0, 0.0], np.eye(3))
    with pytest.raises(ValueError, match="mode"):
        cg.cases("slow")
    assert math.isfinite(cg.rod_force(6.0, 3.0, GM, [1.6, 0.0, 0.0], [1.0, 0.0, 0.0])[0][0])
