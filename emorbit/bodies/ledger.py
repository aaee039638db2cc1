"""The mass ledger of burns that expel mass: the terms a body system adds to a record.

A burn's step keeps each body's energy at its initial mass m0, ``E_0 = m0 eps``, and its
balance ``E_0 - E_0(0) - sum_k W_k`` at round-off, W_k the work of each working effect
(``invariants/work_<label>``). The body's true mass is ``m = mu m0``, ``mu = 1 - lost / m0``,
and its energy ``E_b = mu E_0``. Over each sub-step ``m_b eps_b - m_a eps_a = m_mean (eps_b -
eps_a) + (m_b - m_a) eps_mean``: the work done on the body at its true mass, which the step
kernels sum in the effect set's ledger row (``W_b = sum mu_mean sum_k dW_k``), and the energy
the expelled propellant carries away, ``X = sum (m_a - m_b) eps_mean``. With the step's exact
identity ``eps_b - eps_a = sum_k dW_k / m0``, summing by parts gives X from the record's own
state::

    X = (1 - mu) E_0(t) - sum_k W_k + W_b

so that ``E_b - E_b(0) - W_b + X`` stays at round-off (``docs/methods.md``, "Finite burns").

Data layout: ``done`` and ``true`` (nrec, nb) each body's work at m0 (summed over the working
effects) and at its true mass (the ledger row), J; ``lost`` {body name: (nrec,) kg}.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ledger_terms"]


def ledger_terms(done, true, lost: dict, names, masses, energy_at) -> dict:
    """A body system's terms of the mass ledger at each record.

    Parameters
    ----------
    done, true : ndarray
        (nrec, nb) each body's work at its initial mass and at its true mass, J.
    lost : dict
        {body name: (nrec,) kg} the mass the burns have taken (bodies of other systems are
        skipped).
    names : sequence of str
        The system's body names, in the columns' order.
    masses : ndarray
        (nb,) their initial masses, kg.
    energy_at : callable
        ``energy_at(b)`` -> (nrec,) body b's energy at its initial mass, J (kinetic, spin and
        potential).

    Returns
    -------
    dict
        ``energy`` (the bodies' energy at their true masses less that at their initial
        masses, ``sum (mu - 1) E_0``), ``work`` (the work at their true masses less that at
        their initial masses) and ``expelled`` (X), each (nrec,) J.
    """
    nrec = done.shape[0]
    out = {"energy": np.zeros(nrec), "work": (true - done).sum(axis=1), "expelled": np.zeros(nrec)}
    for name, kg in lost.items():
        if name not in names:
            continue
        b = list(names).index(name)
        mu = 1.0 - np.asarray(kg, float)[:nrec] / masses[b]
        energy = energy_at(b)
        out["energy"] += (mu - 1.0) * energy
        out["expelled"] += (1.0 - mu) * energy - done[:, b] + true[:, b]
    return out
