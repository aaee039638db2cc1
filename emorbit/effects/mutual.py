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
each body's own 3 x 3 block (its field terms and the diagonal block of its pair forces), all
bodies at once from the pair forces of the last sweep (block Jacobi), until every update is at
round-off; no dense 3n x 3n matrix is formed. The pair forces come from
:func:`~emorbit.kernels.effects.central.pair_pass`: the bodies are packed into contiguous
coordinate arrays, and the first sweep of each sub-step evaluates every pair from each of its
two sides in branch-free loops that LLVM vectorises (the two sides are bitwise opposite, so
the pair forces stay equal and opposite); a later sweep evaluates again only the pairs of the
bodies whose end positions moved (in a cluster, a handful by the third sweep: the others'
updates fall below the last bit of their positions) and adds each moved body's change to the
others' forces. A body's pair block joins its Newton matrix where its pairs couple strongly
(6 h^2/2 times the bound of its pair Jacobians' norms above 1e-4), formed at each sweep's
iterate; elsewhere the pair forces converge by the sweeps alone, at that rate per sweep.

Rigid and elastic bodies attract each other and point masses through their mass points (a
rigid body's quadrature points, an elastic body's gravity points): every pair of mass points
of two different bodies takes the same pair force, which gives the full two-body problem of
extended bodies (binary asteroids, docking) with E, P and L kept exactly. Such a scene runs
as one coupled structure (:mod:`emorbit.bodies.coupled`): the pair forces enter its Newton
iteration with each mass point's own Jacobian block; the blocks between bodies stay out of
the sparse matrix, and the iteration converges on them at the rate h^2/2 |dF/dx| per
iteration (:mod:`emorbit.kernels.effects.pairs`). Pairs inside one body are left out.

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
    Key("bodies", False, "array of strings", "every body", "names of bodies in the scene, at least 2",
        "the bodies that attract each other (point masses, rigid and elastic bodies)"),
)  # fmt: skip
POTENTIAL = "V = -sum_{i<j} G m_i m_j / |x_i - x_j|"
DISCRETE_FORCE = "F_ij = -G m_i m_j (d0 + d1) / (r0 r1 (r0 + r1)) = -F_ji, d = x_i - x_j (Greenspan's pair g_em)"
JACOBIAN = "dF_ij/dx_i1 = the central field's with GM = G m_j; dF_ij/dx_j1 = its negative"
CONSERVES = ("energy", "linear momentum (in free space)", "angular momentum")
BODY_KINDS = ("point", "rigid", "elastic")

KERNEL = {
    "imports": "from emorbit.kernels.effects.central import pair_block, pair_blocks, pair_pass",
    "setup": """
mutual_idx = np.flatnonzero(mutual_on != 0.0)  # the points that attract each other, packed
mutual_k = mutual_idx.shape[0]
mutual_w = np.zeros((17, mutual_k))  # packed rows (pair_pass): x0, x1, G m, forces, rho, new x1, scratch
mutual_m = np.zeros(mutual_k, np.int64)  # scratch: the points that moved
mutual_b = np.zeros((9, mutual_k))  # the diagonal Jacobian blocks of the strongly coupled points
mutual_s = np.zeros(mutual_k)  # 1 where a point is strongly coupled
mutual_at = np.full(n, -1)  # each point's index in the packed rows (-1: no pair forces)
for p in range(mutual_k):
    mutual_at[mutual_idx[p]] = p
    mutual_w[6, p] = mutual_p[0] * m[mutual_idx[p]]
""",
    "own": "",
    "pairs": """
pair_pass(it == 0, hh, x, dx, mutual_idx, mutual_w, mutual_m, fp, rho)
strong = 0  # strongly coupled points: their pairs' own blocks join their Newton matrices
for p in range(mutual_k):
    mutual_s[p] = 1.0 if 6.0 * hh * mutual_w[10, p] > 1e-4 else 0.0
    strong += int(mutual_s[p])
if 8 * strong > mutual_k:
    pair_blocks(mutual_w[0], mutual_w[1], mutual_w[2], mutual_w[3], mutual_w[4], mutual_w[5], mutual_w[6], mutual_b)
elif strong > 0:
    for p in range(mutual_k):
        if mutual_s[p] != 0.0:
            pair_block(
                p, mutual_w[0], mutual_w[1], mutual_w[2], mutual_w[3], mutual_w[4], mutual_w[5], mutual_w[6], mutual_b
            )
""",
    "blocks": """
if mutual_at[i] >= 0 and mutual_s[mutual_at[i]] != 0.0:
    p = mutual_at[i]
    for a in range(3):
        for b in range(3):
            J[a, b] += mutual_b[3 * a + b, p]
""",
}


class Mutual(EffectTerm):
    """Mutual gravity as an effect term: ``params["mutual_p"] = [G]``; the points it acts on
    are set when the simulation lays out its points (``mutual_on``)."""

    def potential(self, x, masses, active, t=None):
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
