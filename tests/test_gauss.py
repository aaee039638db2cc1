"""Gauss-Legendre rules and Gauss collocation tables in decimals (emorbit.kernels.gauss): exact
on polynomials up to degree 2m - 1 to 45 digits, symmetric, equal to numpy's rule in float64,
and the collocation matrix integrating the Lagrange basis."""

from decimal import Decimal, localcontext

import numpy as np
import pytest

from emorbit.kernels.gauss import MAX_POINTS, collocation, gauss_rule


@pytest.mark.parametrize("m", [1, 2, 3, 4, 5, 7, 12])
def test_rule_is_exact_to_its_degree_and_symmetric(m):
    """sum w_i c_i^p = 1 / (p + 1) for p < 2m within 1e-45, and not for p = 2m (the rule's
    error there is nonzero); nodes mirrored about 1/2; float64 values within 2 eps of
    numpy.polynomial.legendre.leggauss."""
    c, b = gauss_rule(m)
    with localcontext() as ctx:
        ctx.prec = 60
        for p in range(2 * m):
            assert abs(sum(w * x**p for x, w in zip(c, b)) - Decimal(1) / (p + 1)) < Decimal("1e-45")
        assert abs(sum(w * x ** (2 * m) for x, w in zip(c, b)) - Decimal(1) / (2 * m + 1)) > Decimal("1e-30")
        for i in range(m):
            assert abs(c[i] + c[m - 1 - i] - 1) < Decimal("1e-45") and b[i] == b[m - 1 - i]
    x, w = np.polynomial.legendre.leggauss(m)
    assert np.allclose([float(v) for v in c], (1 + x) / 2, rtol=0, atol=2 * np.finfo(float).eps)
    assert np.allclose([float(v) for v in b], w / 2, rtol=0, atol=2 * np.finfo(float).eps)


def test_collocation_integrates_the_lagrange_basis():
    """For k = 4: sum_j a_ij c_j^p = c_i^(p+1) / (p + 1) for p < k (a integrates every polynomial
    of degree < k exactly), and b_i a_ij + b_j a_ji = b_i b_j within 1e-45."""
    k = 4
    c, b, a = collocation(k)
    with localcontext() as ctx:
        ctx.prec = 60
        for i in range(k):
            for p in range(k):
                assert abs(sum(a[i][j] * c[j] ** p for j in range(k)) - c[i] ** (p + 1) / (p + 1)) < Decimal("1e-45")
            for j in range(k):
                assert abs(b[i] * a[i][j] + b[j] * a[j][i] - b[i] * b[j]) < Decimal("1e-45")


def test_refuses_sizes_it_does_not_compute():
    for m in (0, MAX_POINTS + 1):
        with pytest.raises(ValueError, match=str(m)):
            gauss_rule(m)
