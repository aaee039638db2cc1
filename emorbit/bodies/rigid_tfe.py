"""A rigid-body system's energy-momentum time finite element steps (``method = "tfe"``).

:class:`RigidTFE` hands the system's arrays to the kernels: fixed steps
(:mod:`emorbit.kernels.rigid_tfe`), adaptive steps that land on every multiple of ``dt`` and the
reversible steps that check their time symmetry (:mod:`emorbit.kernels.rigid_tfe_adaptive`).
Its order is its number of Gauss stages times 2, so a composition's fractions only give the
order (:func:`emorbit.integrators.dispatch.tfe_tables`).

Effects (:meth:`RigidTFE.effects`): the kernels form the central field themselves; the set's
other effects act at the bodies' gravity points (:mod:`emorbit.kernels.rigid_tfe_effects`),
split into the static ones (a potential that does not change in time: scaled with the field
for exact energy) and the others (unscaled, their work summed). Effects on surfaces (drag,
radiation pressure on facets) are refused before a run
(:attr:`~emorbit.bodies.rigid.RigidBodies.POINTS_ONLY`).
"""

from __future__ import annotations

import numpy as np

from ..integrators.dispatch import tfe_tables
from ..kernels.pointmass.tfe import low_parts

__all__ = ["RigidTFE"]


class RigidTFE:
    """The time finite element's steps of one rigid-body system.

    Parameters
    ----------
    system : RigidBodies
        The bodies (their state arrays are updated in place).
    gammas : array_like
        The composition's fractions of the run's order (they give the element's order).
    """

    def __init__(self, system, gammas):
        self.system = system
        self.tab = tfe_tables(gammas)
        self.lo = low_parts(2 * self.tab.shape[0])

    def effects(self, clock: tuple, rec_work: np.ndarray) -> tuple:
        """The effect set's compiled functions ``(forces, prepare, work, potential)`` and the
        kernels' ``eff`` tuple (:func:`emorbit.kernels.rigid_tfe.rigid_tfe_chunk`): the set's
        arrays, its coefficients split into the static effects' and the others' at the mass
        points and at the centres of mass, each work row's effect where its potential changes
        in time (else -1), the work sums, their records ``rec_work`` and the clock."""
        s = self.system
        binding = s.effects
        prog = binding.program
        P, I, T, S = binding.arrays(max(s.mp.size, len(s)))
        static, other, row_effect = binding.tfe_split()
        coef, pcoef = s.coefficients()
        pairs = ((coef, static), (coef, other), (pcoef, static), (pcoef, other))
        coefs = tuple(np.ascontiguousarray(c * w[:, None]) for c, w in pairs)
        eff = (
            P, I, T, S, coefs, row_effect, bool((row_effect >= 0).any()), s.work, s.cwork, rec_work,
            float(clock[0]), float(clock[1]),
        )  # fmt: skip
        return (prog.forces, prog.prepare, prog.work, prog.potential), eff

    def _body(self, gm, center) -> tuple:
        s = self.system
        return (
            self.tab, self.lo, s.models, s.q, s.v, s.cq, s.cv, s.mass, s.E, s.inverse_inertias(), s.offsets, s.X,
            s.mp, float(gm), np.ascontiguousarray(center, float),
        )  # fmt: skip

    def advance(self, gm, center, dt, every, nrec, max_iter, clock):
        """``nrec * every`` steps of ``dt`` (fixed, or adaptive with the plan's eta, landing on
        every multiple of ``dt``); returns the records (:class:`~emorbit.bodies.rigid.RigidRecords`)."""
        from ..kernels.rigid_tfe import rigid_tfe_chunk
        from ..kernels.rigid_tfe_adaptive import rigid_tfe_adaptive_chunk

        s = self.system
        rec = s._records(nrec)
        rec.work = np.zeros((nrec,) + s.work.shape)
        fns, eff = self.effects(clock, rec.work)
        body = self._body(gm, center)
        if s.adaptive is None:
            rigid_tfe_chunk(
                *fns, eff, *body, float(dt), int(every), int(nrec), int(max_iter), rec.q, rec.v, rec.iterations,
                rec.fail,
            )  # fmt: skip
        else:
            if s.rho.shape != (len(s),):
                s.rho = np.zeros(len(s))
            steps = np.zeros((nrec, len(s)), np.int64)
            rigid_tfe_adaptive_chunk(
                fns, eff, *body[:7], s.rho, *body[7:], float(dt), int(every), float(s.adaptive), int(nrec),
                int(max_iter), rec.q, rec.v, rec.iterations, steps, rec.fail,
            )  # fmt: skip
            rec.solves = steps
            s.adaptive_steps += int(steps.sum())
        if not s.work.shape[1]:
            rec.work = None
        return rec

    def reversible_steps(self, gm, center, nsteps, max_iter, clock=(0.0, 0)) -> np.ndarray:
        """Exactly ``nsteps`` adaptive steps of size 1 in tau from every body
        (:meth:`~emorbit.bodies.rigid.RigidBodies.reversible_steps`); returns each body's
        elapsed time (nb,), s.

        Raises
        ------
        RuntimeError
            A step failed (its status in the message).
        """
        from ..kernels.rigid_tfe_adaptive import rigid_tfe_reversible_steps

        s = self.system
        if s.rho.shape != (len(s),):
            s.rho = np.zeros(len(s))
        out = np.zeros((len(s), 2))
        fns, eff = self.effects(clock, np.zeros((0,) + s.work.shape))
        body = self._body(gm, center)
        rigid_tfe_reversible_steps(
            fns, eff, *body[:7], s.rho, *body[7:], float(s.adaptive), int(nsteps), int(max_iter), out
        )  # fmt: skip
        if np.any(out[:, 1] != 0):
            raise RuntimeError(f"an adaptive step failed with status {int(out[out[:, 1] != 0, 1][0])}")
        return out[:, 0]
