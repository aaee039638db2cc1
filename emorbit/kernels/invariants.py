"""Invariants of a set of point masses in the central field, from recorded states.

Plain numpy over float64 arrays: ``x`` and ``v`` have shape (..., 3, n) (structure of
arrays, as the kernels store them), ``masses`` shape (n,). Results in SI (J, kg m/s,
kg m^2/s). Angular momentum is taken about the field's centre, where it is conserved.
"""

from __future__ import annotations

import numpy as np

__all__ = ["kinetic_energy", "potential_energy", "energy", "momentum", "angular_momentum"]


def kinetic_energy(masses, v):
    """sum_i m_i |v_i|^2 / 2 over the last axis; shape (...)."""
    return 0.5 * np.einsum("...kn,...kn,n->...", v, v, masses)


def potential_energy(masses, x, gm, center):
    """sum_i -GM m_i / |X_Z - x_i|; shape (...)."""
    r = np.sqrt(np.einsum("...kn,...kn->...n", x - center[:, None], x - center[:, None]))
    return -gm * np.einsum("...n,n->...", 1.0 / r, masses)


def energy(masses, x, v, gm, center):
    """Total energy (kinetic + potential) in J; shape (...)."""
    return kinetic_energy(masses, v) + potential_energy(masses, x, gm, center)


def momentum(masses, v):
    """Total linear momentum sum_i m_i v_i in kg m/s; shape (..., 3).

    Not conserved in a fixed central field (the field is external); recorded for completeness.
    """
    return np.einsum("...kn,n->...k", v, masses)


def angular_momentum(masses, x, v, center):
    """Total angular momentum about the centre, sum_i m_i (x_i - X_Z) x v_i; shape (..., 3)."""
    r = x - center[:, None]
    L = np.stack(
        [
            r[..., 1, :] * v[..., 2, :] - r[..., 2, :] * v[..., 1, :],
            r[..., 2, :] * v[..., 0, :] - r[..., 0, :] * v[..., 2, :],
            r[..., 0, :] * v[..., 1, :] - r[..., 1, :] * v[..., 0, :],
        ],
        axis=-2,
    )
    return np.einsum("...kn,n->...k", L, masses)
