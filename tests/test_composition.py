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
def test_third_order_condition(order):
    """A symmetric composition of a symmetric order-2 step has order >= 4 iff
    sum gamma = 1 and sum gamma^3 = 0 (Yoshida 1990)."""
    c = coefficients(order)
    assert abs(np.sum(c**3)) < 1e-15
    assert COMPOSITIONS[order][0]  # every composition names its source


def test_unknown_order():
    with pytest.raises(ValueError):
        coefficients(3)
