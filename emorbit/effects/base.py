"""What every effect gives a simulation once it is built: :class:`EffectTerm`.

A term holds the effect's parameters in SI, packed as float64 arrays in the order its kernel
code reads them (:attr:`EffectTerm.params`), the scene table it came from (written back into
scenes and into the run file's ``effects`` attribute), and the potential energy of the bodies
it acts on at recorded states, which the run records as ``invariants/potential_<label>``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["EffectTerm"]


@dataclass
class EffectTerm:
    """One effect of a simulation.

    Attributes
    ----------
    kind : str
        The effect's name in :data:`emorbit.effects.EFFECTS`.
    label : str
        Its name in the run file's datasets (``invariants/potential_<label>``): the kind,
        numbered where a scene names a kind twice.
    table : dict
        The scene table that made it (values as given, plain TOML values).
    params : dict
        {argument name: float64 array}: the parameters its kernel code reads, SI.
    bodies : list of str or None
        The bodies it acts on (None: every body of a kind it supports).
    key : str
        Its name in errors (``effect[0]``).
    """

    kind: str
    label: str
    table: dict
    params: dict = field(default_factory=dict)
    bodies: list | None = None
    key: str = ""
    #: whether the effect depends on time: then :meth:`prepare` runs before the steps and
    #: :meth:`potential` takes the records' times
    time_dependent = False

    def prepare(self, t0: float, t1: float, epoch) -> None:
        """Make the parameters cover the times ``t0`` to ``t1`` (s from the epoch): an effect
        that follows a path in time samples it (nothing to do for the others).

        Parameters
        ----------
        t0, t1 : float
            The span the steps reach, s.
        epoch : astropy.time.Time or None
            The run's epoch.
        """

    def potential(self, x: np.ndarray, masses: np.ndarray, active: np.ndarray, t=None) -> np.ndarray:
        """The effect's potential energy at recorded states.

        Parameters
        ----------
        x : ndarray
            (rows, 3, n) positions, m.
        masses : ndarray
            (n,) kg.
        active : ndarray
            (n,) bool: the points it acts on.
        t : ndarray, optional
            (rows,) the records' times, s from the epoch (read where :attr:`time_dependent`).

        Returns
        -------
        ndarray
            (rows,) J.
        """
        raise NotImplementedError
