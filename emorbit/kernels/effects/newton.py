"""The Newton update of one point's em step under a set of effects: a 3 x 3 solve.

The composed step (:mod:`emorbit.effects.compose`) solves, for each point, the second-order
part ``w`` of its increment ``x1 - x0 = h v0 + w`` from the residual

    R(w) = w - (h^2 / 2) F(x0, x1)

with ``F`` the sum of the effects' discrete forces per unit mass. Newton's matrix is
``A = I - (h^2 / 2) dF/dx1`` (dF/dx1: the sum of the effects' Jacobians); :func:`newton_update`
solves ``A delta = R`` by Cramer's rule on the 3 x 3 system (A is within O(h^2 |dF/dx|) of
the identity, so it is far from singular at any step the method can take) and returns the
update. Data layout: ``J`` a (3, 3) float64 array, the residual and the update as scalars.
"""

from __future__ import annotations

from ..jit import kernel

__all__ = ["newton_update"]

_inline = kernel(inline="always")


@_inline
def newton_update(J, hh, r0, r1, r2):
    """The Newton update of one point: the solution of ``(I - hh J) delta = r``.

    Parameters
    ----------
    J : ndarray
        (3, 3) the force's Jacobian with respect to the end position, per unit mass (1/s^2).
    hh : float
        h^2 / 2, s^2.
    r0, r1, r2 : float
        The residual, m.

    Returns
    -------
    tuple of float
        The update (3 components), m.
    """
    a00 = 1.0 - hh * J[0, 0]
    a01 = -hh * J[0, 1]
    a02 = -hh * J[0, 2]
    a10 = -hh * J[1, 0]
    a11 = 1.0 - hh * J[1, 1]
    a12 = -hh * J[1, 2]
    a20 = -hh * J[2, 0]
    a21 = -hh * J[2, 1]
    a22 = 1.0 - hh * J[2, 2]
    c00 = a11 * a22 - a12 * a21
    c01 = a12 * a20 - a10 * a22
    c02 = a10 * a21 - a11 * a20
    det = a00 * c00 + a01 * c01 + a02 * c02
    d0 = (r0 * c00 + r1 * (a02 * a21 - a01 * a22) + r2 * (a01 * a12 - a02 * a11)) / det
    d1 = (r0 * c01 + r1 * (a00 * a22 - a02 * a20) + r2 * (a02 * a10 - a00 * a12)) / det
    d2 = (r0 * c02 + r1 * (a01 * a20 - a00 * a21) + r2 * (a00 * a11 - a01 * a10)) / det
    return d0, d1, d2
