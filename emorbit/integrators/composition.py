"""Symmetric compositions that raise a symmetric (time-reversible) order-2 step to order
4, 6 or 8. Every sub-step is the base method with step ``gamma_k * dt``, so a composition of
energy-momentum steps still conserves energy and angular momentum exactly (some gammas are
negative: the step runs backwards, which the scheme allows).

=====  ======  ==================================================================
order  stages  coefficients
=====  ======  ==================================================================
2      1       the base step
4      3       Yoshida (1990) / Suzuki triple jump: g1 = 1 / (2 - 2^(1/3))
6      9       Kahan & Li (1997), s9odr6a
8      17      Kahan & Li (1997), s17odr8a
=====  ======  ==================================================================

Kahan & Li's schemes have much smaller error constants than Yoshida's minimal 7- and
15-stage ones at a modest cost in stages.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ORDERS", "coefficients", "COMPOSITIONS"]

_CBRT2 = 2.0 ** (1.0 / 3.0)

#: first half (including the middle coefficient last) of each symmetric composition
COMPOSITIONS = {
    2: ("base step", (1.0,)),
    4: ("Yoshida 1990 triple jump", (1.0 / (2.0 - _CBRT2), -_CBRT2 / (2.0 - _CBRT2))),
    6: (
        "Kahan & Li 1997 s9odr6a",
        (
            0.39216144400731413928,
            0.33259913678935943860,
            -0.70624617255763935981,
            0.082213596293550800230,
            0.79854399093482996340,
        ),
    ),
    8: (
        "Kahan & Li 1997 s17odr8a",
        (
            0.13020248308889008088,
            0.56116298177510838456,
            -0.38947496264484728641,
            0.15884190655515560090,
            -0.39590389413323757734,
            0.18453964097831570709,
            0.25837438768632204729,
            0.29501172360931029887,
            -0.60550853383003451170,
        ),
    ),
}

ORDERS = tuple(sorted(COMPOSITIONS))
"""The orders a simulation accepts: 2 (the base step), 4, 6 and 8."""


def coefficients(order: int) -> np.ndarray:
    """The sub-step fractions of the symmetric composition of an order.

    The middle coefficient is recomputed as 1 - 2 * (sum of the others), so the fractions
    sum to 1 to double precision whatever digits the source printed. (Time is counted as
    steps * dt, never by adding sub-steps.)

    Parameters
    ----------
    order : int
        One of :data:`ORDERS`.

    Returns
    -------
    ndarray
        The gammas of the sub-steps, in order (1, 3, 9 or 17 of them).

    Raises
    ------
    ValueError
        Not one of :data:`ORDERS`.
    """
    if order not in COMPOSITIONS:
        raise ValueError(f"order must be one of {ORDERS}, got {order!r}")
    half = list(COMPOSITIONS[order][1])
    outer = half[:-1]
    middle = 1.0 - 2.0 * sum(outer)
    return np.array(outer + [middle] + outer[::-1], dtype=np.float64)
