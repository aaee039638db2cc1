"""Gauss-Legendre rules on [0, 1] and the collocation tables of Gauss methods, in decimals.

Method: the m nodes of the m-point rule are the roots of the Legendre polynomial P_m,
found by Newton's method on the three-term recurrence
``n P_n = (2n - 1) x P_{n-1} - (n - 1) P_{n-2}`` (``P_m'(x) = m (x P_m - P_{m-1}) / (x^2 - 1)``),
from Tricomi's first guesses ``cos(pi (i + 3/4) / (m + 1/2))``; the weights are
``w_i = 2 / ((1 - x_i^2) P_m'(x_i)^2)``; both are mapped from [-1, 1] to [0, 1], the rule kept
symmetric (the roots above 0 found, mirrored; the middle one of an odd rule 0 exactly). The
collocation matrix of the k-stage Gauss method is ``a_ij = int_0^{c_i} ell_j``, with
``ell_j`` the Lagrange basis on the nodes c.

Data layout: lists of ``decimal.Decimal``, computed with :data:`DIGITS` significant digits in
a local decimal context (the caller's stays as it was), nodes in increasing order.

References: E. Hairer, S. P. Norsett, G. Wanner, Solving Ordinary Differential Equations I,
2nd ed. (1993), II.7 (Gauss methods); G. H. Golub, J. H. Welsch, Math. Comp. 23 (1969) 221-230;
F. G. Tricomi, Ann. Mat. Pura Appl. 31 (1950) 93-97 (the first guesses).
"""

from __future__ import annotations

import math
from decimal import Decimal, localcontext

__all__ = ["DIGITS", "MAX_POINTS", "gauss_rule", "lagrange_basis", "collocation"]

#: significant digits of the computation
DIGITS = 50
#: the largest rule computed
MAX_POINTS = 32


def _legendre(m: int, x: Decimal) -> tuple[Decimal, Decimal]:
    """``P_m(x)`` and ``P_m'(x)`` (|x| < 1)."""
    p0, p1 = Decimal(1), x
    for n in range(2, m + 1):
        p0, p1 = p1, ((2 * n - 1) * x * p1 - (n - 1) * p0) / n
    return p1, m * (x * p1 - p0) / (x * x - 1)


def gauss_rule(m: int) -> tuple[list, list]:
    """The m-point Gauss-Legendre rule on [0, 1].

    Parameters
    ----------
    m : int
        Points, 1 to :data:`MAX_POINTS`.

    Returns
    -------
    nodes, weights : list of Decimal
        m each, the nodes increasing; the weights sum to 1.
    """
    if not 1 <= m <= MAX_POINTS:
        raise ValueError(f"a Gauss rule of 1 to {MAX_POINTS} points, not {m!r}")
    with localcontext() as ctx:
        ctx.prec = DIGITS
        tiny = Decimal(10) ** (4 - DIGITS)
        xs, ws = [], []  # the roots in (0, 1) of [-1, 1], largest first: the rule is symmetric
        for i in range(m // 2):
            x = Decimal(math.cos(math.pi * (i + 0.75) / (m + 0.5)))
            for _ in range(60):
                p, dp = _legendre(m, x)
                step = p / dp
                x -= step
                if abs(step) <= tiny:
                    break
            _, dp = _legendre(m, x)
            xs.append(x)
            ws.append(1 / ((1 - x * x) * dp * dp))  # 2 / (...), halved for [0, 1]
        if m % 2:  # the middle node, 0 exactly
            _, dp = _legendre(m, Decimal(0))
            xs.append(Decimal(0))
            ws.append(1 / (dp * dp))
        nodes = [(1 - x) / 2 for x in xs] + [(1 + x) / 2 for x in reversed(xs[: m // 2])]
        weights = ws + list(reversed(ws[: m // 2]))
        return [+x for x in nodes], [+w for w in weights]


def _times(p: list, q: list) -> list:
    out = [Decimal(0)] * (len(p) + len(q) - 1)
    for i, pi in enumerate(p):
        for j, qj in enumerate(q):
            out[i + j] += pi * qj
    return out


def lagrange_basis(c: list) -> list:
    """The Lagrange basis on the nodes ``c``: for each j the coefficients (lowest first) of the
    polynomial of degree ``len(c) - 1`` that is 1 at ``c[j]`` and 0 at the other nodes."""
    with localcontext() as ctx:
        ctx.prec = DIGITS
        basis = []
        for j in range(len(c)):
            p = [Decimal(1)]
            for q in range(len(c)):
                if q != j:
                    p = _times(p, [-c[q] / (c[j] - c[q]), 1 / (c[j] - c[q])])
            basis.append(p)
        return basis


def collocation(k: int) -> tuple[list, list, list]:
    """The k-stage Gauss collocation method (order 2k): nodes, weights and matrix.

    Parameters
    ----------
    k : int
        Stages.

    Returns
    -------
    c, b : list of Decimal
        The nodes and weights of :func:`gauss_rule`.
    a : list of lists of Decimal
        (k, k) ``a_ij = int_0^{c_i} ell_j``.
    """
    c, b = gauss_rule(k)
    basis = lagrange_basis(c)
    with localcontext() as ctx:
        ctx.prec = DIGITS
        a = [[sum(pj * c[i] ** (n + 1) / (n + 1) for n, pj in enumerate(basis[j])) for j in range(k)] for i in range(k)]
        return c, b, a
