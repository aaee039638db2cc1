"""Composition coefficients: symmetric, summing to one exactly."""

import numpy as np
import pytest

from emorbit.integrators import ORDERS, coefficients
from emorbit.integrators.composition import COMPOSITIONS


@pytest.mark.parametrize("order", ORDERS)
def test_coefficients_symmetric_and_sum_to_one(order):
    c = coefficients(order)
    assert np.array_equal(c, c[::-1])
    assert abs(c.sum() - 1.0) <= 4.5e-16
    assert c.size == {2: 1, 4: 3, 6: 9, 8: 17}[order]


@pytest.mark.parametrize("order", [4, 6, 8])
def test_odd_power_conditions(order):
    """A symmetric composition of a symmetric order-2 step has order >= 4 iff
    sum gamma = 1 and sum gamma^3 = 0 (Yoshida 1990); order 6 needs sum gamma^5 = 0 as well and
    order 8 sum gamma^7 = 0 (the conditions of the pure powers, McLachlan 1995). The next
    power's sum is far from zero (measured 5.3, 3.6e-2 and 7.5e-4 of the raw sums for orders
    4, 6, 8), so a coefficient table of a lower order fails here."""
    c = coefficients(order)
    vanishing = range(3, order, 2)
    for k in vanishing:
        assert abs(np.sum(c**k)) < 1e-15, (order, k, np.sum(c**k))
    assert abs(np.sum(c ** (order + 1))) > 5e-4, (order, np.sum(c ** (order + 1)))
    assert len(COMPOSITIONS[order][1]) == (c.size + 1) // 2  # the stored half and its mirror


def test_unknown_order():
    with pytest.raises(ValueError):
        coefficients(3)
