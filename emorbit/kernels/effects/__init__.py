"""Conserving discrete forces ("discrete gradients") of gravity effects, with their Jacobians.

Method: the energy-momentum (em) step of a point of mass m over a step h from (x0, v0)
solves for x1 with ``v_mid = (x1 - x0) / h``, ``v1 = 2 v_mid - v0`` and
``m (v1 - v0) / h = m F(x0, x1)``, where F (per unit mass) is a discrete force whose work
equals the potential drop exactly (Simo & Tarnow 1992; Gonzalez 1996)::

    F(x0, x1) . (x1 - x0) = -(V(x1) - V(x0)),        F(x, x) = -grad V(x)

so the step conserves the energy; F is also built so that it conserves the angular
momentum the effect conserves. Newton solves for x1 with the exact ``dF/dx1``.

Data layout: every kernel takes components as float64 scalars (positions ``x, y, z``,
centre ``c0, c1, c2``, pole ``p0, p1, p2``, a unit vector), parameters as scalars or a
small float64 array (``jn``), and returns a tuple ``(fx, fy, fz)``; the Jacobian kernels
add ``dF_i/dx1_j`` into a (3, 3) float64 array ``J`` (so several effects sum into one
matrix). All are Numba kernels callable from Python too: helpers ``inline="always"``, the
effect-set pieces (``*_piece`` and the like) ``forceinline=True``, compiled once per install
and inlined by LLVM, so that a new effect set does not compile them again.

- :mod:`.central`: a point mass at ``c``, ``V = -gm / r``, with Greenspan's conserving
  pair force (Greenspan 1984; the ``g_em`` of Goettlicher & Schweizerhof)
  ``F = -gm (d0 + d1) / (r0 r1 (r0 + r1))``, ``d = x - c``; it conserves the angular
  momentum about ``c``. The mutual gravity of bodies i and j is the same kernel with
  ``d = x_i - x_j`` (centre 0) and ``gm = G m_j`` (per unit mass of i);
  :func:`~.central.central_potential`, :func:`~.central.central_force`,
  :func:`~.central.central_jacobian`.
- :mod:`.zonal`: the zonal harmonics J2..J6 of the central body about its pole ``p``,
  a sum of products ``f(r) g(z)``; the averaged split of each product (an Itoh & Abe 1988
  discrete gradient in the variables r and z) gives a force along ``d0 + d1`` and ``p``,
  which conserves the energy and the angular momentum about the pole;
  :func:`~.zonal.zonal_potential`, :func:`~.zonal.zonal_force`,
  :func:`~.zonal.zonal_jacobian`.

References: J. C. Simo, N. Tarnow, ZAMP 43 (1992) 757-792; D. Greenspan, J. Comput. Phys.
56 (1984) 28-41; O. Gonzalez, J. Nonlinear Sci. 6 (1996) 449-467; T. Itoh, K. Abe,
J. Comput. Phys. 76 (1988) 85-102.
"""

from __future__ import annotations

from .central import central_force, central_jacobian, central_potential
from .zonal import zonal_force, zonal_jacobian, zonal_potential

__all__ = [
    "central_potential",
    "central_force",
    "central_jacobian",
    "zonal_potential",
    "zonal_force",
    "zonal_jacobian",
]
