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

The implicit step couples every pair. The point masses' step solves it by Newton on each
body's own 3 x 3 block (its field terms and the diagonal block of its pair forces), all
bodies at once from the pair forces of the last sweep (block Jacobi), until every update is
at round-off; no dense 3n x 3n matrix is formed. The pair forces come from
:func:`~emorbit.kernels.effects.mutual.mutual_pairs`
(:func:`~emorbit.kernels.effects.central.pair_pass`): the bodies are packed into contiguous
coordinate arrays, and the first sweep of each sub-step evaluates every pair from each of
its two sides in branch-free loops that LLVM vectorises (the two sides are bitwise opposite,
so the pair forces stay equal and opposite); a later sweep evaluates again only the pairs of
the bodies whose end positions moved (in a cluster, a handful by the third sweep: the
others' updates fall below the last bit of their positions) and adds each moved body's
change to the others' forces. A body's pair block joins its Newton matrix where its pairs
couple strongly (6 h^2/2 times the bound of its pair Jacobians' norms above 1e-4), formed at
each sweep's iterate; elsewhere the pair forces converge by the sweeps alone, at that rate
per sweep.

Rigid and elastic bodies attract each other and point masses through their mass points (a
rigid body's quadrature points, an elastic body's gravity points): every pair of mass points
of two different bodies takes the same pair force, which gives the full two-body problem of
extended bodies (binary asteroids, docking) with E, P and L kept exactly. Such a scene runs
as one coupled structure (:mod:`emorbit.bodies.coupled`): the pair forces enter its Newton
iteration with each mass point's own Jacobian block, and the blocks between compact bodies
(point masses, rigid bodies; up to 64) join its sparse matrix (:mod:`emorbit.kernels.effects.mutual`'s
``mutual_pair_block``). Point masses alone step together, up to 32 of them with Newton's whole
system each sweep. Pairs inside one body are left out. A scene with one body, or a
``bodies`` list of one, has no pair: it is refused.

References: D. Greenspan, Conservative numerical methods for x'' = f(x), J. Comput. Phys. 56
(1984) 28-41; J. C. Simo, N. Tarnow, Z. angew. Math. Phys. 43 (1992) 757-792.
"""

from __future__ import annotations

import astropy.constants as const

from ..errors import InputError
from ..keys import Key
from .base import AT_POINTS, Effect, Pieces

__all__ = ["Mutual", "G"]

#: the constant of gravitation, m^3 / (kg s^2) (astropy, CODATA)
G = float(const.G.si.value)


class Mutual(Effect):
    """Mutual gravity as an effect: ``p = [G]``; it acts between the points of the bodies it
    reaches (its ``bodies``, or every body)."""

    NAME = "mutual"
    SUMMARY = "gravity between the bodies of the scene (all, or those listed)"
    KEYS = (
        Key("bodies", False, "array of strings", "every body", "names of bodies in the scene, at least 2",
            "the bodies that attract each other (point masses, rigid and elastic bodies)"),
    )  # fmt: skip
    ACTS = {"point": AT_POINTS, "rigid": AT_POINTS, "elastic": AT_POINTS}
    CONSERVES = ("energy", "momentum", "angular momentum")
    PIECES = Pieces(
        "emorbit.kernels.effects.mutual",
        pairs="mutual_pairs",
        pair_potential="mutual_pair_potential",
        pair_block="mutual_pair_block",
        pair_rate="mutual_pair_rate",
    )
    POTENTIAL = "V = -sum_{i<j} G m_i m_j / |x_i - x_j|"
    DISCRETE_FORCE = "F_ij = -G m_i m_j (d0 + d1) / (r0 r1 (r0 + r1)), d = x_i - x_j (Greenspan; g_em of each pair)"
    JACOBIAN_LEFT_OUT = 0.0
    JACOBIAN = (
        "each body's own block: dF_i/dx1_i = sum_j G m_i m_j (-k I + w (d0 + d1) d1^T); between bodies: the sweeps"
    )

    def scratch_size(self, n_points: int) -> int:
        from ..kernels.effects.mutual import scratch_size

        return scratch_size(n_points)

    @classmethod
    def from_table(cls, table, context) -> Mutual:
        """Mutual gravity; ``bodies`` (optional) names the bodies that attract each other.

        Raises
        ------
        InputError
            ``bodies`` is not a list of at least two distinct names of the scene.
        """
        key, bodies = context.key, context.bodies
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
        return cls(table, [G], bodies=names)
