"""A run's plan: the method and its settings, resolved once and read by every body system.

A :class:`Plan` holds what a simulation steps with: the method, the order of its
composition, the round-off treatment, the device, adaptive steps' accuracy knob, the Newton
iterations allowed per sub-step and a structure's Newton strategy. It checks each value once
(:mod:`emorbit.integrators`' checks, with the key that names it) and is frozen: a change (a
new device) is a new plan, handed to every body system, so that no system keeps a setting of
its own that could disagree with another's.

:meth:`Plan.check_roundoff` refuses a round-off treatment a path does not honour, by name: the
packed point-mass kernels of the central field alone take ``"fast"`` (method em); every other
path (point masses under effects, rigid bodies, structures) steps with compensated sums and
stops its Newton iterations at round-off, which is ``"brouwer"``.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..units import to_count
from . import check_device, check_method_order, check_roundoff, get_method

__all__ = ["Plan", "MAX_NEWTON_ITERATIONS", "NEWTON"]

#: the most Newton iterations a sub-step may take
MAX_NEWTON_ITERATIONS = 1_000_000
NEWTON = ("auto", "reuse", "full")
"""A structure's Newton strategies (:class:`~emorbit.bodies.coupled.Structure`)."""


@dataclass(frozen=True)
class Plan:
    """The method and its settings, each checked once.

    Attributes
    ----------
    method : str
        A name of :data:`emorbit.METHODS`.
    order : int
        2, 4, 6 or 8 (:data:`emorbit.ORDERS`); tfe 4 to 12 (:data:`emorbit.integrators.TFE_ORDERS`).
    roundoff : str
        ``"brouwer"`` or ``"fast"`` (:data:`emorbit.integrators.ROUNDOFF`).
    device : str
        ``"cpu"`` or ``"gpu"`` (where point masses run).
    adaptive : float or None
        Adaptive steps' accuracy knob eta in (0, 1]; None for fixed steps.
    max_iter : int
        Newton iterations allowed per implicit sub-step.
    newton : str
        A structure's Newton strategy: ``"auto"``, ``"reuse"`` or ``"full"``.
    keys : tuple of (str, str)
        How errors name each setting (a scene's ``integrator.*`` keys); default the names
        above.

    Raises
    ------
    InputError
        A value that its check refuses, naming its key.
    """

    method: str = "em"
    order: int = 2
    roundoff: str = "brouwer"
    device: str = "cpu"
    adaptive: float | None = None
    max_iter: int = 50
    newton: str = "auto"
    keys: tuple = ()

    def __post_init__(self):
        key = self.key
        object.__setattr__(self, "method", get_method(self.method, key("method")).name)
        object.__setattr__(self, "order", check_method_order(self.method, self.order, key("order")))
        object.__setattr__(self, "roundoff", check_roundoff(self.roundoff, key("roundoff")))
        object.__setattr__(self, "device", check_device(self.device, key("device")))
        eta = self.adaptive
        if eta is not None:
            if isinstance(eta, bool) or not isinstance(eta, numbers.Real) or not 0 < eta <= 1:
                raise InputError(
                    key("adaptive"), f"must be a number in (0, 1] (steps per local time scale), got {eta!r}"
                )
            object.__setattr__(self, "adaptive", float(eta))
        object.__setattr__(
            self, "max_iter", to_count(self.max_iter, key("max_newton_iterations"), 1, MAX_NEWTON_ITERATIONS)
        )
        if self.newton not in NEWTON:
            raise InputError(key("newton"), f"must be 'auto', 'reuse' or 'full', got {self.newton!r}")
        if self.method == "tfe" and self.device != "cpu":
            raise InputError(key("device"), "method 'tfe' runs on the CPU; use method 'em' for this run")
        if self.device == "gpu" and self.adaptive is not None:
            raise InputError(key("device"), "adaptive steps run on the CPU only; use device 'cpu'")

    def key(self, name: str) -> str:
        """The key that errors about setting ``name`` give."""
        return dict(self.keys).get(name, name)

    def with_(self, **changes) -> Plan:
        """A new plan with ``changes`` (checked as a new plan is)."""
        return replace(self, **changes)

    @property
    def gammas(self) -> np.ndarray:
        """The step's coefficients (:meth:`emorbit.integrators.Method.coefficients`): the
        composition's sub-step fractions, or tfe's Gauss weights."""
        return get_method(self.method).coefficients(self.order)

    def check_roundoff(self, paths: dict) -> None:
        """Refuse ``"fast"`` where a path does not honour it.

        Parameters
        ----------
        paths : dict
            What the run steps: ``{"points in the central field": bool, "points under
            effects": bool, "rigid bodies": bool, "elastic bodies": bool}``.

        Raises
        ------
        InputError
            ``roundoff = "fast"`` with a method other than em, or with a path other than
            point masses in the central field alone (they step with compensated sums and
            stop at round-off: ``"brouwer"``).
        """
        if self.roundoff != "fast":
            return
        if self.method != "em":
            raise InputError(
                self.key("roundoff"),
                f"'fast' is a way of solving em's step; method {self.method!r} has no other: use 'brouwer'",
            )
        others = [name for name, used in paths.items() if used and name != "points in the central field"]
        if others:
            raise InputError(
                self.key("roundoff"),
                f"'fast' applies to point masses in the central field alone; this run also steps "
                f"{' and '.join(others)}, whose steps use compensated sums ('brouwer'): use 'brouwer'",
            )
