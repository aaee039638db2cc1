r"""What a rigid body's records hold beyond its state: kinetic energy, momenta, attitude, spin.

A record row of the rigid kernels holds each body's ``q = (phi, d1, d2, d3)`` and ``v =
(dphi, dd1, dd2, dd3)`` (12 each; ``R = [d1 d2 d3]`` its axes in space). From them, per
record r and body b, with mass m, director mass matrix ``E_kl`` and ``J = tr(E) I - E``::

    T     = m |dphi|^2 / 2 + sum_kl E_kl dd_k . dd_l / 2
    p     = m dphi
    L     = (phi - c) x m dphi + sum_kl E_kl d_k x dd_l        (about the field's centre c)
    I_c   = m |phi - c|^2 + tr E                               (the angular momentum's scale)
    Omega = J^-1 R^T sum_kl E_kl d_k x dd_l                    (body frame)

and the attitude quaternion of ``R`` by Shepperd's method (the largest of ``1 + tr R`` and
``1 + 2 R_kk - tr R`` first, so nothing cancels), scalar first with w >= 0, normalised.
Omega from the spin angular momentum follows the attitude's order (the directors' velocity
constraints hold only to O(dt^2)). T, p, L and I_c are summed over the bodies in body
order, so a record does not depend on how a run is chunked.

Layout: ``q, v`` (nrec, nb, 12), ``mass`` (nb,), ``E`` and ``Jinv`` (nb, 3, 3), ``c`` (3,);
out ``sums`` (nrec, 8): T, p (3), L (3), I_c; ``quat`` (nrec, nb, 4); ``omega`` (nrec, nb, 3).

References: J. C. Simo, K. K. Wong, Int. J. Numer. Meth. Eng. 31 (1991) 19-52 (directors);
S. W. Shepperd, J. Guidance Control 1 (1978) 223-224 (quaternion from a rotation matrix).
"""

from __future__ import annotations

import math

import numpy as np

from .jit import kernel

__all__ = ["rigid_record_values"]

#: the antisymmetric parts' (i, j): R_ij - R_ji = 4 w x_n for n = 0, 1, 2
_PAIRS = ((2, 1), (0, 2), (1, 0))


@kernel
def rigid_record_values(q, v, mass, E, Jinv, c, sums, quat, omega):
    """Fill ``sums``, ``quat`` and ``omega`` for every record and body (module docstring)."""
    nrec, nb = q.shape[0], q.shape[1]
    R = np.empty((3, 3))
    for r in range(nrec):
        for i in range(8):
            sums[r, i] = 0.0
        for b in range(nb):
            m = mass[b]
            t = 0.0
            a = 0.0
            for i in range(3):
                t += v[r, b, i] * v[r, b, i]
                a += (q[r, b, i] - c[i]) * (q[r, b, i] - c[i])
            spin = 0.0
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            for k in range(3):
                e0 = 0.0
                e1 = 0.0
                e2 = 0.0
                for l in range(3):  # sum_l E_kl dd_l
                    e0 += E[b, k, l] * v[r, b, 3 + 3 * l]
                    e1 += E[b, k, l] * v[r, b, 4 + 3 * l]
                    e2 += E[b, k, l] * v[r, b, 5 + 3 * l]
                spin += v[r, b, 3 + 3 * k] * e0 + v[r, b, 4 + 3 * k] * e1 + v[r, b, 5 + 3 * k] * e2
                d0 = q[r, b, 3 + 3 * k]
                d1 = q[r, b, 4 + 3 * k]
                d2 = q[r, b, 5 + 3 * k]
                s0 += d1 * e2 - d2 * e1
                s1 += d2 * e0 - d0 * e2
                s2 += d0 * e1 - d1 * e0
                R[0, k] = d0
                R[1, k] = d1
                R[2, k] = d2
            x0 = q[r, b, 0] - c[0]
            x1 = q[r, b, 1] - c[1]
            x2 = q[r, b, 2] - c[2]
            p0 = m * v[r, b, 0]
            p1 = m * v[r, b, 1]
            p2 = m * v[r, b, 2]
            sums[r, 0] += 0.5 * m * t + 0.5 * spin
            sums[r, 1] += p0
            sums[r, 2] += p1
            sums[r, 3] += p2
            sums[r, 4] += x1 * p2 - x2 * p1 + s0
            sums[r, 5] += x2 * p0 - x0 * p2 + s1
            sums[r, 6] += x0 * p1 - x1 * p0 + s2
            sums[r, 7] += m * a + E[b, 0, 0] + E[b, 1, 1] + E[b, 2, 2]
            # Omega = J^-1 R^T L_spin
            bo = (
                R[0, 0] * s0 + R[1, 0] * s1 + R[2, 0] * s2,
                R[0, 1] * s0 + R[1, 1] * s1 + R[2, 1] * s2,
                R[0, 2] * s0 + R[1, 2] * s1 + R[2, 2] * s2,
            )
            for i in range(3):
                omega[r, b, i] = Jinv[b, i, 0] * bo[0] + Jinv[b, i, 1] * bo[1] + Jinv[b, i, 2] * bo[2]
            _quaternion(R, quat[r, b])


@kernel(forceinline=True)
def _quaternion(R, out):
    """Shepperd's unit quaternion (w, x, y, z) of the rotation matrix R (3, 3) into ``out``, w >= 0."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    j = 0
    best = tr
    for k in range(3):
        if R[k, k] > best:
            best = R[k, k]
            j = k + 1
    s = math.sqrt(max(1.0 + 2.0 * best - tr, 0.0))
    f = 0.5 / s
    out[j] = 0.5 * s
    if j == 0:
        for n in range(3):
            a, b = _PAIRS[n]
            out[1 + n] = (R[a, b] - R[b, a]) * f
    else:
        i = j - 1
        a, b = _PAIRS[i]
        out[0] = (R[a, b] - R[b, a]) * f
        for n in range(3):
            if n != i:
                out[1 + n] = (R[i, n] + R[n, i]) * f
    sign = -1.0 if out[0] < 0.0 else 1.0
    norm = math.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3])
    for n in range(4):
        out[n] = sign * out[n] / norm
