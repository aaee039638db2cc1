"""Integration methods, chosen by name from :data:`METHODS`, and the settings that go with
them: :data:`ORDERS`, :data:`ROUNDOFF` and :data:`DEVICES`, each checked here and nowhere else.

Every method is a symmetric second-order step; :mod:`.composition` raises it to order 4, 6
or 8. :mod:`.dispatch` maps (method, roundoff, device) to the kernel that runs it. To add a
method: give it a code in :mod:`emorbit.kernels.codes`, write its step kernel for each body
kind it supports (see :mod:`emorbit.kernels.pointmass`), add a :class:`Method` entry here and
its code to :mod:`.dispatch`; the test suite's parametrised checks (order of convergence,
exact invariants, reversibility) pick it up.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

from ..errors import InputError
from .composition import ORDERS, coefficients

__all__ = [
    "Method",
    "METHODS",
    "ORDERS",
    "ROUNDOFF",
    "DEVICES",
    "coefficients",
    "get_method",
    "check_order",
    "check_roundoff",
    "check_device",
]

#: round-off treatment of em steps of point masses: "brouwer" solves each step's scalar
#: equation to its correctly rounded root, so that the energy error stays a random walk;
#: "fast" solves it in plain floating point (faster; the energy drifts at round-off level)
ROUNDOFF = ("brouwer", "fast")
#: where point masses run: "cpu" (the packed Numba kernels) or "gpu" (numba's CUDA target)
DEVICES = ("cpu", "gpu")


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


def check_roundoff(roundoff, key: str = "roundoff") -> str:
    """``roundoff`` if it is one of :data:`ROUNDOFF`, else an :class:`InputError`."""
    if not isinstance(roundoff, str) or roundoff not in ROUNDOFF:
        raise InputError(key, f"must be one of {', '.join(map(repr, ROUNDOFF))}, got {roundoff!r}")
    return roundoff


def check_device(device, key: str = "device") -> str:
    """``device`` if it is one of :data:`DEVICES`, else an :class:`InputError`."""
    if not isinstance(device, str) or device not in DEVICES:
        raise InputError(key, f"must be one of {', '.join(DEVICES)}, got {device!r}")
    return device
