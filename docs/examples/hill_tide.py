"""A user's own effect for emorbit: the tidal field of Hill's problem (Clohessy-Wiltshire).

Near a reference point on a circular orbit of mean motion n about a distant body, in axes
with x pointing away from the body and z along the orbit normal, the body's tidal field has
the potential per unit mass

    V(x) = (n^2 / 2) (z^2 - 3 x^2)

(Hill 1878; the rotating frame's Coriolis and centrifugal terms are not part of it). V is
quadratic, so the gradient at the step's midpoint is an exact discrete gradient: the force
over a step x0 -> x1,

    F = n^2 (3 x_m, 0, -z_m),   x_m = (x0 + x1) / 2,

does work ``F . (x1 - x0) = V(x0) - V(x1)`` exactly, and an em step keeps the energy. Its
derivative with respect to the end point is ``dF/dx1 = (n^2 / 2) diag(3, 0, -1)``.

Register it with ``emorbit.effects.register_file("hill_tide.py")`` (or name the file in a
scene: ``[[effect]] kind = "hill_tide", file = "hill_tide.py", mean_motion = "1e-3 rad/s"``);
it then acts on point masses, on rigid bodies' mass points and on elastic bodies' gravity
points, with em, midpoint, leapfrog and adaptive steps. Reference: G. W. Hill, Am. J. Math.
1 (1878) 5-26; W. H. Clohessy, R. S. Wiltshire, J. Aerospace Sci. 27 (1960) 653-658.
"""

from __future__ import annotations

from emorbit.effects.base import Effect, Pieces
from emorbit.kernels.jit import kernel
from emorbit.keys import Key
from emorbit.units import to_si


@kernel(inline="always")
def hill_force(x0, y0, z0, x1, y1, z1, h, c, p, tab, s, J, jac):
    """The force per unit mass over the step, ``p = [n^2]``; its derivative added into J."""
    n2 = p[0]
    if jac:
        J[0, 0] += 1.5 * n2
        J[2, 2] -= 0.5 * n2
    return 1.5 * n2 * (x0 + x1), 0.0, -0.5 * n2 * (z0 + z1)


@kernel(inline="always")
def hill_potential(x, y, z, c, p, tab, s):
    """The potential per unit mass."""
    return 0.5 * p[0] * (z * z - 3.0 * x * x)


class HillTide(Effect):
    """The tidal field of Hill's problem: ``p = [n^2]``."""

    NAME = "hill_tide"
    SUMMARY = "the tidal field of Hill's problem about a reference point on a circular orbit"
    KEYS = (Key("mean_motion", True, "angular speed (rad / s)", "", "> 0", "the reference orbit's mean motion n"),)
    CONSERVES = ("energy",)
    PIECES = Pieces(__file__, force="hill_force", potential="hill_potential")
    POTENTIAL = "V = (n^2 / 2) m (z^2 - 3 x^2)"
    DISCRETE_FORCE = "F = n^2 m (3 x_m, 0, -z_m), x_m = (x0 + x1) / 2"
    JACOBIAN = "dF/dx1 = (n^2 / 2) m diag(3, 0, -1)"
    #: J is the exact derivative: em on point masses may stop after one Newton sweep
    JACOBIAN_LEFT_OUT = 0.0

    @classmethod
    def from_table(cls, table, context):
        n = to_si(table["mean_motion"], "angular_speed", f"{context.key}.mean_motion", strict=context.strict,
                  positive=True)  # fmt: skip
        return cls(table, [n * n])
