"""The central field: a fixed point mass GM at the field's centre (the ``[field]`` table).

Potential energy of a body of mass m at distance r from the centre: ``V = -GM m / r``.
Over a step from x0 to x1 the em force per unit mass is the paper's conserving gravity
``g_em = -GM (d0 + d1) / (r0 r1 (r0 + r1))`` with ``d = x - c`` (Goettlicher &
Schweizerhof; :mod:`emorbit.kernels.effects.central`): its work is exactly
``GM (1/r1 - 1/r0)``, the drop in the potential, and it points along ``d0 + d1``, so the
angular momentum about the centre is kept too. Point masses under this field alone run the
packed central-field kernels (:mod:`emorbit.kernels.pointmass`); with other effects, and on
rigid and elastic bodies, it is the first effect of the set (:mod:`emorbit.effects.program`).
"""

from __future__ import annotations

from ..keys import Key
from .base import AT_POINTS, Effect, Pieces

__all__ = ["Central"]


class Central(Effect):
    """The central field as an effect: ``p = [c0, c1, c2, GM]``."""

    NAME = "central"
    SUMMARY = "the fixed central mass of [field] (docs: the [field] table of scenes)"
    #: its keys are those of the [field] table (emorbit.scene.KEYS["field"])
    KEYS: tuple[Key, ...] = ()
    ACTS = {"point": AT_POINTS, "rigid": AT_POINTS, "elastic": AT_POINTS}
    CONSERVES = ("energy", "angular momentum about the centre")
    NEEDS_FIELD = True
    PIECES = Pieces(
        "emorbit.kernels.effects.central",
        force="central_piece",
        potential="central_potential_piece",
        rate="central_rate",
    )
    POTENTIAL = "V = -GM m / r, r = |x - c|"
    DISCRETE_FORCE = "F = -GM m (d0 + d1) / (r0 r1 (r0 + r1)), d = x - c (g_em)"
    JACOBIAN_LEFT_OUT = 0.0
    JACOBIAN = "dF/dx1 = -GM m [I / (r0 r1 (r0 + r1)) - (d0 + d1) d1^T (r0 + 2 r1) / (r0 r1^3 (r0 + r1)^2)]"

    @classmethod
    def from_table(cls, table, context) -> Central:
        field = context.field
        return cls({"kind": "central"}, [*field.center, field.gm])
