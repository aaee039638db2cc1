"""Integration methods, chosen by name from :data:`METHODS`.

Every method is a symmetric second-order step; :mod:`.composition` raises it to order 4, 6
or 8. To add a method: write its step kernel for each body kind it supports (see
:mod:`emorbit.kernels.pointmass`), add a :class:`Method` entry here, and the test suite's
parametrised checks (order of convergence, exact invariants, reversibility) pick it up.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

from ..errors import InputError
from .composition import ORDERS, coefficients

__all__ = ["Method", "METHODS", "ORDERS", "coefficients", "get_method", "check_order"]


@dataclass(frozen=True)
class Method:
    """What a method is and what it conserves exactly (up to round-off)."""

    name: str
    summary: str
    implicit: bool
    conserves: tuple[str, ...]


METHODS = {
    "em": Method(
        "em",
        "energy-momentum: conserving gravity g_em over the step (Goettlicher & Schweizerhof)",
        implicit=True,
        conserves=("energy", "angular_momentum"),
    ),
    "midpoint": Method(
        "midpoint",
        "implicit midpoint rule: gravity at (x0 + x1) / 2",
        implicit=True,
        conserves=("angular_momentum",),
    ),
    "leapfrog": Method(
        "leapfrog",
        "explicit kick-drift-kick (Stormer-Verlet)",
        implicit=False,
        conserves=("angular_momentum",),
    ),
}


def get_method(name, key: str = "method") -> Method:
    """The :class:`Method` called ``name``; an unknown name is an :class:`InputError`."""
    if not isinstance(name, str) or name not in METHODS:
        raise InputError(key, f"unknown method {name!r}; known: {', '.join(METHODS)}")
    return METHODS[name]


def check_order(order, key: str = "order") -> int:
    """``order`` as an int if it is one of :data:`ORDERS`, else an :class:`InputError`."""
    if isinstance(order, bool) or not isinstance(order, numbers.Integral) or int(order) not in ORDERS:
        raise InputError(key, f"order must be one of {', '.join(map(str, ORDERS))}, got {order!r}")
    return int(order)
