"""The Newton update of one point's em step under a set of effects: a 3 x 3 solve.

The effect step (:mod:`emorbit.kernels.pointmass.effect_step`) solves, for each point, the
second-order part ``w`` of its increment ``x1 - x0 = h v0 + w`` from the residual

    R(w) = w - (h^2 / 2) F(x0, x1)

with ``F`` the sum of the effects' discrete forces per unit mass. Newton's matrix is
``A = I - (h^2 / 2) dF/dx1`` (dF/dx1: the sum of the effects' Jacobians); :func:`newton_update`
solves ``A delta = R`` by Cramer's rule on the 3 x 3 system, with one division (the
determinant's reciprocal; A is within O(h^2 |dF/dx|) of the identity, so it is far from
singular at any step the method can take) and returns the update. Data layout: ``W`` (9, n),
point i's Jacobian ``J[a, b] = W[3 a + b, i]``; the residual and the update as scalars.
"""

from __future__ import annotations

from ..jit import kernel

__all__ = ["newton_update"]

_inline = kernel(inline="always")


@_inline
def newton_update(W, i, hh, r0, r1, r2):
    """The Newton update of point i: the solution of ``(I - hh J) delta = r``.

    Parameters
    ----------
    W : ndarray
        (9, n) the force's Jacobians with respect to the end positions, per unit mass (1/s^2):
        point i's ``J[a, b] = W[3 a + b, i]``.
    i : int
        The point.
    hh : float
        h^2 / 2, s^2.
    r0, r1, r2 : float
        The residual, m.

    Returns
    -------
    tuple of float
        The update (3 components), m.
    """
    a00 = 1.0 - hh * W[0, i]
    a01 = -hh * W[1, i]
    a02 = -hh * W[2, i]
    a10 = -hh * W[3, i]
    a11 = 1.0 - hh * W[4, i]
    a12 = -hh * W[5, i]
    a20 = -hh * W[6, i]
    a21 = -hh * W[7, i]
    a22 = 1.0 - hh * W[8, i]
    c00 = a11 * a22 - a12 * a21
    c01 = a12 * a20 - a10 * a22
    c02 = a10 * a21 - a11 * a20
    inv = 1.0 / (a00 * c00 + a01 * c01 + a02 * c02)
    d0 = (r0 * c00 + r1 * (a02 * a21 - a01 * a22) + r2 * (a01 * a12 - a02 * a11)) * inv
    d1 = (r0 * c01 + r1 * (a00 * a22 - a02 * a20) + r2 * (a02 * a10 - a00 * a12)) * inv
    d2 = (r0 * c02 + r1 * (a01 * a20 - a00 * a21) + r2 * (a00 * a11 - a01 * a10)) * inv
    return d0, d1, d2
