"""What a body system holds of its simulation's effects: :class:`EffectBinding`.

Every body system (point masses, rigid bodies, structures) steps its points under the same
compiled effect set (:mod:`emorbit.effects.program`). The binding gives it the compiled
functions, the set's arrays for its number of points, each body's coefficients for each
effect, the slots of the effects whose work the step sums, and the effects' potential
energies at recorded states (:func:`emorbit.kernels.effects.records.record_potentials`).
"""

from __future__ import annotations

import numpy as np

from ..notices import announce

__all__ = ["EffectBinding"]


class EffectBinding:
    """The effects of a simulation as one body system of a kind sees them.

    Parameters
    ----------
    effects : EffectSet
        The simulation's effects (shared: effects added later are seen).
    body_kind : str
        ``"point"``, ``"rigid"`` or ``"elastic"``.
    """

    def __init__(self, effects, body_kind: str):
        self.effects = effects
        self.body_kind = body_kind

    @property
    def program(self):
        """The set compiled (the first use of a new set compiles it, and says so)."""
        return self.effects.program(announce)

    def arrays(self, n_points: int):
        """The set's ``P, I, T, S`` for ``n_points`` points (after the tables' last sampling)."""
        return self.effects.arrays(n_points)

    def coefficients(self, names, values: dict, counts=None) -> np.ndarray:
        """(k, points) each body's points' coefficient for each effect.

        Parameters
        ----------
        names : list of str
            The bodies.
        values : dict
            {name: {body key: SI value}}: the effect keys given for each body.
        counts : sequence of int, optional
            Points per body (default 1 each).
        """
        cols = [self.effects.coefficients(self.body_kind, n, values.get(n, {})) for n in names]
        if counts is None:
            counts = [1] * len(names)
        if not cols:
            return np.zeros((len(self.effects), 0))
        return np.ascontiguousarray(np.repeat(np.array(cols).T, counts, axis=1))

    def working(self) -> list:
        """The effects whose work the step sums, in slot order."""
        return self.effects.working()

    def tfe_split(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """How the time finite element's stages take the set: ``(static, other, row_effect)``.
        ``static`` (k,) is 1 for the effects whose potential does not change in time (scaled
        with the central field for exact energy), ``other`` (k,) 1 for the rest; the central
        field is in neither (the kernels form it in closed form). ``row_effect`` (w,) gives each
        work row's effect where its potential changes in time (its change joins the work), else
        -1."""
        effects = list(self.effects.all)
        central = self.effects.central
        static = np.array(
            [float(type(e).has_potential() and not type(e).PIECES.time_work and e is not central) for e in effects]
        )
        other = np.array([float(e is not central) for e in effects]) - static
        row_effect = np.array([effects.index(e) if type(e).PIECES.time_work else -1 for e in self.working()], np.int64)
        return static, other, row_effect

    def working_labels(self) -> list[str]:
        """Their labels (``invariants/work_<label>``)."""
        return [e.label for e in self.working()]

    def potentials(self, x, t, m, body, coef) -> dict:
        """Each effect's potential energy at recorded states.

        Parameters
        ----------
        x : ndarray
            (rows, 3, n) the points, m.
        t : ndarray or None
            (rows,) the records' times, s from the epoch (None: 0).
        m, body, coef
            The points' masses (kg), bodies (int64) and coefficients (k, n).

        Returns
        -------
        dict
            {``potential_<label>``: (rows,) J} for each effect that has a potential.
        """
        from ..kernels.effects.records import record_potentials

        effects = self.effects.all
        rows = x.shape[0]
        out = np.zeros((rows, len(effects)))
        if rows and x.shape[2]:
            prog = self.program
            P, I, T, S = self.arrays(x.shape[2])
            times = np.zeros(rows) if t is None else np.ascontiguousarray(t, float)
            record_potentials(
                prog.prepare, prog.potential, np.ascontiguousarray(x, float), times, m, body, coef, P, I, T, S, out
            )
        return {f"potential_{e.label}": out[:, j] for j, e in enumerate(effects) if type(e).has_potential()}
