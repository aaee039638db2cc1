"""Mutual gravity between the bodies of a scene (``[[effect]] kind = "mutual"``).

Potential energy of the pairs: ``V = -sum_{i<j} G m_i m_j / |x_i - x_j|``. Over a step the
force on body i from body j is Greenspan's conserving pair force, the central field's g_em
with the pair's separation ``d = x_i - x_j`` in place of ``x - c`` and ``G m_j`` in place of
GM::

    F_ij = -G m_i m_j (d0 + d1) / (r0 r1 (r0 + r1)) = -F_ji

Its work over the step is exactly the drop of the pair's potential, the pair's forces are
equal and opposite (linear momentum is kept) and lie along the mean separation
``(d0 + d1) / 2`` (angular momentum is kept). Bodies may attract each other inside a central
field (the field stays fixed, as in the paper) or in free space.

The implicit step couples every pair. :mod:`emorbit.effects.compose` solves it by Newton on
each body's own 3 x 3 block (its field terms and the diagonal blocks of its pair forces),
all bodies at once from the pair forces of the last sweep (block Jacobi), until every update
is at round-off: a sweep evaluates each pair once, for both of its bodies, and no dense
3n x 3n matrix is formed. Where the pairs couple weakly (h^2/2 times the pair Jacobians' norms
below 1e-4: their part of each Newton matrix would change the update by less than that), the
pairs' blocks are left out of the Newton matrices and the pair forces converge by the sweeps
alone, at that rate per sweep.

References: D. Greenspan, Conservative numerical methods for x'' = f(x), J. Comput. Phys. 56
(1984) 28-41; J. C. Simo, N. Tarnow, Z. angew. Math. Phys. 43 (1992) 757-792.
"""

from __future__ import annotations

import astropy.constants as const
import numpy as np

from ..errors import InputError
from ..keys import Key
from .base import EffectTerm

__all__ = ["NAME", "SUMMARY", "KEYS", "CONSERVES", "BODY_KINDS", "KERNEL", "build", "Mutual", "G"]

NAME = "mutual"
SUMMARY = "gravity between the bodies of the scene (all, or those listed)"
#: the constant of gravitation, m^3 / (kg s^2) (astropy, CODATA)
G = float(const.G.si.value)
KEYS = (
    Key("bodies", False, "array of strings", "every body", "names of point masses in the scene, at least 2",
        "the bodies that attract each other"),
)  # fmt: skip
POTENTIAL = "V = -sum_{i<j} G m_i m_j / |x_i - x_j|"
DISCRETE_FORCE = "F_ij = -G m_i m_j (d0 + d1) / (r0 r1 (r0 + r1)) = -F_ji, d = x_i - x_j (Greenspan's pair g_em)"
JACOBIAN = "dF_ij/dx_i1 = the central field's with GM = G m_j; dF_ij/dx_j1 = its negative"
CONSERVES = ("energy", "linear momentum (in free space)", "angular momentum")
BODY_KINDS = ("point",)

KERNEL = {
    "imports": "from emorbit.kernels.effects.central import pair_force, pair_unit",
    "own": "",
    "pairs": """
pair_blocks = coupling > 1e-4  # strong coupling: the pairs' own blocks join each point's Newton matrix
for i in range(n):
    if mutual_on[i] == 0.0:
        continue
    xi0 = x[0, i]
    yi0 = x[1, i]
    zi0 = x[2, i]
    xi1 = xi0 + dx[0, i]
    yi1 = yi0 + dx[1, i]
    zi1 = zi0 + dx[2, i]
    gj = mutual_p[0] * m[i]
    fxi = 0.0
    fyi = 0.0
    fzi = 0.0
    rhoi = 0.0
    for j in range(i + 1, n):
        if mutual_on[j] == 0.0:
            continue
        ax = xi0 - x[0, j]
        ay = yi0 - x[1, j]
        az = zi0 - x[2, j]
        bx = xi1 - (x[0, j] + dx[0, j])
        by = yi1 - (x[1, j] + dx[1, j])
        bz = zi1 - (x[2, j] + dx[2, j])
        gi = mutual_p[0] * m[j]
        if pair_blocks:
            gx, gy, gz, big = pair_unit(ax, ay, az, bx, by, bz, Ju)
            for a in range(3):
                for b in range(3):
                    jp[i, a, b] += gi * Ju[a, b]
                    jp[j, a, b] += gj * Ju[a, b]
        else:
            gx, gy, gz, big = pair_force(ax, ay, az, bx, by, bz)
        fxi += gi * gx
        fyi += gi * gy
        fzi += gi * gz
        fp[j, 0] -= gj * gx
        fp[j, 1] -= gj * gy
        fp[j, 2] -= gj * gz
        rhoi += gi * big
        rho[j] += gj * big
    fp[i, 0] += fxi
    fp[i, 1] += fyi
    fp[i, 2] += fzi
    rho[i] += rhoi
""",
}


class Mutual(EffectTerm):
    """Mutual gravity as an effect term: ``params["mutual_p"] = [G]``; the points it acts on
    are set when the simulation lays out its points (``mutual_on``)."""

    def potential(self, x, masses, active):
        idx = np.flatnonzero(active)
        out = np.zeros(x.shape[0])
        for a, i in enumerate(idx[:-1]):
            j = idx[a + 1 :]
            d = x[:, :, j] - x[:, :, i : i + 1]
            r = np.sqrt(np.einsum("rkn,rkn->rn", d, d))
            out -= G * masses[i] * np.einsum("rn,n->r", 1.0 / r, masses[j])
        return out


def build(table, field, key: str, bodies, strict: bool = False) -> Mutual:
    """Mutual gravity from its table.

    Parameters
    ----------
    table : dict
        ``bodies`` (optional): the names of the bodies that attract each other.
    field : CentralField or None
        Unused: the bodies feel the field as well where there is one.
    key : str
        The table's name in errors.
    bodies : list of str or None
        The scene's bodies (None: the names are checked when the simulation runs).
    strict : bool
        Unused (no dimensional keys).

    Returns
    -------
    Mutual

    Raises
    ------
    InputError
        ``bodies`` is not a list of at least two distinct names of the scene.
    """
    names = table.get("bodies")
    if names is not None:
        if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
            raise InputError(f"{key}.bodies", f"a list of body names expected, got {names!r}")
        if len(set(names)) != len(names) or len(names) < 2:
            raise InputError(f"{key}.bodies", f"at least two different bodies expected, got {list(names)!r}")
        unknown = [n for n in names if bodies is not None and n not in bodies]
        if unknown:
            raise InputError(f"{key}.bodies", f"no body named {unknown[0]!r}; bodies: {', '.join(bodies)}")
        names = list(names)
    return Mutual("mutual", "mutual", dict(table), {"mutual_p": np.array([G])}, names)
