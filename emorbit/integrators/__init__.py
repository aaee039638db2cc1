"""Integration methods, chosen by name from :data:`METHODS`, and the settings that go with
them: :data:`ORDERS`, :data:`ROUNDOFF` and :data:`DEVICES`, each checked here and nowhere else.

Every method but one is a symmetric second-order step; :mod:`.composition` raises it to order
4, 6 or 8. ``"tfe"`` reaches its orders (4 to 12, :attr:`Method.orders`) in one
implicit solve of 2 to 6 stages instead (:mod:`emorbit.kernels.pointmass.tfe`,
:mod:`emorbit.kernels.rigid_tfe`). A body's ``advance`` takes a step's coefficients
(:meth:`Method.coefficients`): a composition's sub-step fractions, or a time finite
element's Gauss weights, which name its order by their count. :mod:`.dispatch` maps
(method, roundoff, device) to the kernel that runs it. To add a method: give it a code in
:mod:`emorbit.kernels.codes`, write its step kernel for each body kind it supports (see
:mod:`emorbit.kernels.pointmass`), add a :class:`Method` entry here and its code to
:mod:`.dispatch`; the test suite's parametrised checks (order of convergence, exact
invariants, reversibility) pick it up.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from functools import cache

import numpy as np

from ..errors import InputError
from .composition import ORDERS, coefficients

__all__ = [
    "Method",
    "METHODS",
    "ORDERS",
    "ROUNDOFF",
    "DEVICES",
    "coefficients",
    "gauss_weights",
    "TFE_ORDERS",
    "get_method",
    "check_order",
    "check_method_order",
    "check_roundoff",
    "check_device",
]

TFE_ORDERS = (4, 6, 8, 10, 12)
"""The orders of the time finite element ``"tfe"``: 2k for k = 2 to 6 Gauss stages."""
ROUNDOFF = ("brouwer", "fast")
"""Round-off treatments of em steps of point masses: ``"brouwer"`` solves each step's scalar
equation to its correctly rounded root, so that the energy error stays a random walk;
``"fast"`` solves it in plain floating point (cheaper; the energy drifts at round-off level)."""
DEVICES = ("cpu", "gpu")
"""Where point masses run: ``"cpu"`` (the packed Numba kernels) or ``"gpu"`` (Numba's CUDA target)."""


@dataclass(frozen=True)
class Method:
    """What a method is and what it conserves exactly (up to round-off).

    Attributes
    ----------
    name : str
        The name a simulation or scene gives.
    summary : str
        One line on what the step does.
    implicit : bool
        Whether a step solves an implicit equation (Newton iterations).
    conserves : tuple of str
        ``"energy"`` and/or ``"angular_momentum"``: what the step conserves exactly in a
        central field (every method conserves angular momentum there).
    orders : tuple of int
        The orders it runs at: :data:`ORDERS` for a second-order step and its compositions.
    effects : bool
        Whether its kernels run under effects beyond the central field.
    composed : bool
        Whether its orders above 2 are compositions of second-order sub-steps (each a Newton
        solve); otherwise a step is one solve at every order.
    """

    name: str
    summary: str
    implicit: bool
    conserves: tuple[str, ...]
    orders: tuple[int, ...] = ORDERS
    effects: bool = True
    composed: bool = True

    def solves_per_step(self, order: int) -> int:
        """The solves (sub-steps) one step of ``order`` takes."""
        return coefficients(order).size if self.composed else 1

    def coefficients(self, order: int) -> np.ndarray:
        """The coefficients a body's ``advance`` takes for a step of ``order``.

        A composed method's are the sub-step fractions (:func:`coefficients`: 1, 3, 9 or 17
        of them). A step in one solve (tfe) has k = order / 2 Gauss stages; its coefficients
        are their weights (:func:`gauss_weights`), summing to 1, whose count names the order.

        Raises
        ------
        ValueError
            Not one of the method's :attr:`orders`.
        """
        if order not in self.orders:
            raise ValueError(f"method {self.name!r} runs at order {self.orders}, not {order!r}")
        return coefficients(order) if self.composed else gauss_weights(order // 2)


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
    "tfe": Method(
        "tfe",
        "energy-momentum time finite element: order 2k in one solve of k Gauss stages "
        "(point masses, also under effects whose force is explicit; rigid bodies, and structures of elastic "
        "and rigid bodies and point masses, in the central field)",
        implicit=True,
        conserves=("energy", "angular_momentum"),
        orders=TFE_ORDERS,
        composed=False,
    ),
}
"""The methods by name: ``"em"`` (energy-momentum), ``"midpoint"``, ``"leapfrog"`` and ``"tfe"``
(energy-momentum time finite elements of orders 4 to 12, :mod:`emorbit.kernels.pointmass.tfe`,
:mod:`emorbit.kernels.rigid_tfe` and :mod:`emorbit.kernels.elastic_tfe`: point masses, also
under effects whose force is a function of position and time
(:mod:`emorbit.kernels.pointmass.effect_tfe`), rigid bodies, and structures of elastic and
rigid bodies and point masses, in the central field; on the CPU)."""


def get_method(name, key: str = "method") -> Method:
    """The method of a name.

    Parameters
    ----------
    name : str
        A key of :data:`METHODS`.
    key : str
        Where the name came from, for the error message.

    Returns
    -------
    Method
        The method.

    Raises
    ------
    InputError
        An unknown name.
    """
    if not isinstance(name, str) or name not in METHODS:
        raise InputError(key, f"unknown method {name!r}; known: {', '.join(METHODS)}")
    return METHODS[name]


def check_order(order, key: str = "order") -> int:
    """Check a composition order.

    Parameters
    ----------
    order : int
        One of :data:`ORDERS`.
    key : str
        Where it came from, for the error message.

    Returns
    -------
    int
        ``order``.

    Raises
    ------
    InputError
        Not one of :data:`ORDERS`.
    """
    if isinstance(order, bool) or not isinstance(order, numbers.Integral) or int(order) not in ORDERS:
        raise InputError(key, f"order must be one of {', '.join(map(str, ORDERS))}, got {order!r}")
    return int(order)


def check_method_order(method, order, key: str = "order") -> int:
    """Check an order against what a method runs at.

    Parameters
    ----------
    method : str
        A name of :data:`METHODS`.
    order : int
        One of the method's :attr:`Method.orders`.
    key : str
        Where the order came from, for the error message.

    Returns
    -------
    int
        ``order``.

    Raises
    ------
    InputError
        Not one of the method's orders.
    """
    m = get_method(method)
    if isinstance(order, bool) or not isinstance(order, numbers.Integral) or int(order) not in m.orders:
        raise InputError(key, f"method {m.name!r} runs at order {' or '.join(map(str, m.orders))}, got {order!r}")
    return int(order)


@cache
def _weights(k: int) -> tuple:
    from ..kernels.gauss import gauss_rule

    return tuple(float(w) for w in gauss_rule(k)[1])


def gauss_weights(k: int) -> np.ndarray:
    """The weights of the k-point Gauss rule on [0, 1] (:func:`emorbit.kernels.gauss.gauss_rule`,
    50 digits, rounded): the coefficients of a tfe step of order 2k (:meth:`Method.coefficients`)."""
    return np.array(_weights(int(k)))


def check_roundoff(roundoff, key: str = "roundoff") -> str:
    """Check a round-off treatment.

    Parameters
    ----------
    roundoff : str
        One of :data:`ROUNDOFF`.
    key : str
        Where it came from, for the error message.

    Returns
    -------
    str
        ``roundoff``.

    Raises
    ------
    InputError
        Not one of :data:`ROUNDOFF`.
    """
    if not isinstance(roundoff, str) or roundoff not in ROUNDOFF:
        raise InputError(key, f"must be one of {', '.join(map(repr, ROUNDOFF))}, got {roundoff!r}")
    return roundoff


def check_device(device, key: str = "device") -> str:
    """Check a device name.

    Parameters
    ----------
    device : str
        One of :data:`DEVICES`.
    key : str
        Where it came from, for the error message.

    Returns
    -------
    str
        ``device``.

    Raises
    ------
    InputError
        Not one of :data:`DEVICES`.
    """
    if not isinstance(device, str) or device not in DEVICES:
        raise InputError(key, f"must be one of {', '.join(DEVICES)}, got {device!r}")
    return device
