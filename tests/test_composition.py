"""Composition coefficients: symmetric, summing to one exactly, and the published ones."""

from fractions import Fraction

import numpy as np
import pytest

from emorbit.integrators import ORDERS, coefficients
from emorbit.integrators.composition import COMPOSITIONS

#: the first half of each composition (the middle coefficient last) as published, digits as
#: printed: Yoshida's triple jump, 1 / (2 - 2^(1/3)) and -2^(1/3) / (2 - 2^(1/3)) (H. Yoshida,
#: Phys. Lett. A 150 (1990) 262-268, eq. (5.5)); Kahan & Li's s9odr6a and s17odr8a (W. Kahan,
#: R.-C. Li, Math. Comp. 66 (1997) 1089-1099, section 4; also E. Hairer, C. Lubich, G. Wanner,
#: Geometric Numerical Integration, 2nd ed., Springer 2006, sec. V.3.2)
PUBLISHED = {
    2: ("1",),
    4: ("1.3512071919596576340476878089715", "-1.7024143839193152680953756179429"),
    6: (
        "0.39216144400731413928",
        "0.33259913678935943860",
        "-0.70624617255763935981",
        "0.082213596293550800230",
        "0.79854399093482996340",
    ),
    8: (
        "0.13020248308889008088",
        "0.56116298177510838456",
        "-0.38947496264484728641",
        "0.15884190655515560090",
        "-0.39590389413323757734",
        "0.18453964097831570709",
        "0.25837438768632204729",
        "0.29501172360931029887",
        "-0.60550853383003451170",
    ),
}


def _published(order: int) -> np.ndarray:
    half = [float(Fraction(s)) for s in PUBLISHED[order]]
    return np.array(half[:-1] + [half[-1]] + half[:-1][::-1])


@pytest.mark.parametrize("order", ORDERS)
def test_coefficients_symmetric_and_sum_to_one(order):
    c = coefficients(order)
    assert np.array_equal(c, c[::-1])
    assert abs(c.sum() - 1.0) <= 4.5e-16
    assert c.size == {2: 1, 4: 3, 6: 9, 8: 17}[order]


@pytest.mark.parametrize("order", ORDERS)
def test_coefficients_are_the_published_ones(order):
    """Every sub-step fraction, in its place, equals the published digits: the outer ones as
    stored (measured: to the last bit at orders 6 and 8; at order 4, 1 / (2 - 2^(1/3))
    evaluated in double is one unit in the last place above the published, 1.6e-16), the
    middle one, recomputed as 1 - 2 sum(outer) so that the fractions sum to one, to the
    rounding of that sum (measured: 2.2e-16 at order 4, one unit in the last place of -1.70;
    1.1e-16 at order 6; 0 at order 8; the printed middles equal 1 - 2 sum(outer) of the
    printed digits to 1e-20)."""
    c, want = coefficients(order), _published(order)
    assert c.shape == want.shape
    middle = c.size // 2
    outer = np.delete(np.arange(c.size), middle)
    np.testing.assert_allclose(c[outer], want[outer], rtol=2.3e-16, atol=0)
    assert abs(c[middle] - want[middle]) <= 2.3e-16, (order, c[middle] - want[middle])


def test_a_swap_fails_the_published_check_and_not_the_power_sums():
    """The point of comparing each coefficient in its place: swapping the first two of order 8
    (and their mirrors) keeps every sum of powers (the order conditions tested below) and
    changes the scheme, by 0.43 in a coefficient."""
    c = coefficients(8).copy()
    c[[0, 1]], c[[-1, -2]] = c[[1, 0]], c[[-2, -1]]
    for k in (3, 5, 7):
        assert np.sum(c**k) == pytest.approx(np.sum(coefficients(8) ** k), abs=1e-16)
    assert np.max(np.abs(c - _published(8))) > 0.4
    assert not np.array_equal(c, coefficients(8))


@pytest.mark.parametrize("order", [4, 6, 8])
def test_odd_power_conditions(order):
    """A symmetric composition of a symmetric order-2 step has order >= 4 iff
    sum gamma = 1 and sum gamma^3 = 0 (Yoshida 1990); order 6 needs sum gamma^5 = 0 as well and
    order 8 sum gamma^7 = 0 (the conditions of the pure powers, McLachlan 1995). The next
    power's sum is far from zero (measured 5.3, 3.6e-2 and 7.5e-4 of the raw sums for orders
    4, 6, 8), so a coefficient table of a lower order fails here. The sums are unchanged by a
    permutation of the coefficients: the published values above are what pins each in its
    place."""
    c = coefficients(order)
    vanishing = range(3, order, 2)
    for k in vanishing:
        assert abs(np.sum(c**k)) < 1e-15, (order, k, np.sum(c**k))
    assert abs(np.sum(c ** (order + 1))) > 5e-4, (order, np.sum(c ** (order + 1)))
    assert len(COMPOSITIONS[order][1]) == (c.size + 1) // 2  # the stored half and its mirror


def test_unknown_order():
    with pytest.raises(ValueError):
        coefficients(3)
