"""The central field: a fixed point mass GM at the field's centre (the ``[field]`` table).

Potential energy of a body of mass m at distance r from the centre: ``V = -GM m / r``.
Over a step from x0 to x1 the em force per unit mass is the paper's conserving gravity
``g_em = -GM (d0 + d1) / (r0 r1 (r0 + r1))`` with ``d = x - c`` (Goettlicher &
Schweizerhof; :mod:`emorbit.kernels.effects.central`): its work is exactly
``GM (1/r1 - 1/r0)``, the drop in the potential, and it points along ``d0 + d1``, so the
angular momentum about the centre is kept too. A scene whose only effect is the central
field runs the point-mass, rigid and elastic kernels built for it
(:mod:`emorbit.kernels.pointmass` and the body kinds' own); point masses under this field
and zonal harmonics alone run the packed kernel :mod:`emorbit.kernels.effects.zonal_packed`;
a scene with further effects runs the step that :mod:`emorbit.effects.compose` compiles for
its set, with this force.
"""

from __future__ import annotations

import numpy as np

from ..keys import Key
from .base import EffectTerm

__all__ = ["NAME", "SUMMARY", "KEYS", "CONSERVES", "BODY_KINDS", "KERNEL", "build", "Central"]

NAME = "central"
SUMMARY = "the fixed central mass of [field] (docs: the [field] table of scenes)"
#: its keys are those of the [field] table (emorbit.scene.KEYS["field"])
KEYS: tuple[Key, ...] = ()
POTENTIAL = "V = -GM m / r, r = |x - c|"
DISCRETE_FORCE = "F = -GM m (d0 + d1) / (r0 r1 (r0 + r1)), d = x - c (g_em)"
JACOBIAN = "dF/dx1 = -GM m [I / (r0 r1 (r0 + r1)) - (d0 + d1) d1^T (r0 + 2 r1) / (r0 r1^3 (r0 + r1)^2)]"
CONSERVES = ("energy", "angular momentum about the centre")
BODY_KINDS = ("point", "rigid", "elastic")

KERNEL = {
    "imports": "from emorbit.kernels.effects.central import central_force, central_jacobian",
    "own": """
gx, gy, gz = central_force(x0, y0, z0, x1, y1, z1, central_p[0], central_p[1], central_p[2], central_p[3])
fx += gx
fy += gy
fz += gz
central_jacobian(x0, y0, z0, x1, y1, z1, central_p[0], central_p[1], central_p[2], central_p[3], J)
""",
    "pairs": "",
}


class Central(EffectTerm):
    """The central field as an effect term: ``params["central_p"] = [c0, c1, c2, GM]``."""

    def potential(self, x, masses, active, t=None):
        c = self.params["central_p"][:3]
        gm = self.params["central_p"][3]
        r = np.sqrt(np.einsum("rkn,rkn->rn", x - c[None, :, None], x - c[None, :, None]))
        return -gm * np.einsum("rn,n->r", 1.0 / r, np.where(active, masses, 0.0))


def build(table, field, key: str, bodies, strict: bool = False) -> Central:
    """The central field of a simulation's :class:`~emorbit.field.CentralField`.

    Parameters
    ----------
    table : dict
        Ignored (the field's own keys are checked by the field).
    field : CentralField
        The field.
    key, bodies, strict
        Unused.

    Returns
    -------
    Central
    """
    p = np.array([*field.center, field.gm], float)
    return Central("central", "central", {"kind": "central"}, {"central_p": p})
