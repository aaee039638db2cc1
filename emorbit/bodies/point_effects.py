"""Point masses under a set of effects: which step kernel runs, and with which arrays.

:class:`EffectRun` holds what every step kernel of points under effects takes from
:class:`~emorbit.bodies.pointmasses.PointMasses`: the set compiled and its arrays
(:class:`~emorbit.bodies.effect_binding.EffectBinding`), the state (3, n) ``x, v, cx, cv``
with em's warm start ``wp`` (3, n), ``hp`` (1,), the masses (n,), each point's coefficient
for each effect (k, n) and the work sums ``work, cwork`` (w, n), J. Its methods run

- fixed steps: the packed kernel an effect declares for exactly the set (em,
  :meth:`emorbit.effects.base.Effect.packed`), the time finite element
  (:mod:`emorbit.kernels.pointmass.effect_tfe`), or
  :func:`~emorbit.kernels.pointmass.effect_step.effect_chunk` (em, midpoint, leapfrog);
- adaptive steps of the whole set (:mod:`emorbit.kernels.pointmass.effect_adaptive`; for tfe
  one step of it is the composed step), and the reversible steps that check their time
  symmetry.

Every array is updated in place; the records go into the caller's
:class:`~emorbit.bodies.pointmasses.ChunkRecords` (with ``work`` (nrec, w, n) allocated).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..integrators import dispatch

__all__ = ["EffectRun"]


@dataclass
class EffectRun:
    """One call's view of the points under effects (the module's docstring gives the arrays)."""

    binding: object
    x: np.ndarray
    v: np.ndarray
    cx: np.ndarray
    cv: np.ndarray
    wp: np.ndarray
    hp: np.ndarray
    masses: np.ndarray
    coef: np.ndarray
    work: np.ndarray
    cwork: np.ndarray
    dense: bool

    def _done(self, rec):
        if not self.work.shape[0]:
            rec.work = None
        return rec

    def fixed(self, rec, method: str, dt: float, gammas, every: int, nrec: int, max_iter: int, clock: tuple):
        """``nrec * every`` fixed steps of ``method`` into the records ``rec`` (see
        :meth:`PointMasses.advance`), which it returns."""
        from ..kernels.pointmass.effect_step import effect_chunk

        if method == "tfe":
            return self._tfe(rec, dt, gammas, every, nrec, max_iter, clock)
        args = (float(dt), np.ascontiguousarray(gammas, float), int(every), int(nrec), int(max_iter))
        records = (rec.x, rec.v, rec.iterations, rec.fail)
        packed = self.binding.effects.packed_points() if method == "em" else None
        if packed is not None:
            chunk, params = packed
            chunk(self.x, self.v, self.cx, self.cv, self.wp, self.hp, self.masses, *params, *args, *records)
            rec.work = None
            return rec
        prog = self.binding.program
        P, I, T, S = self.binding.arrays(self.x.shape[1])
        effect_chunk(
            prog.forces, prog.cross, prog.prepare, prog.work, dispatch.method_code(method, "fast"), self.x, self.v,
            self.cx, self.cv, self.wp, self.hp, self.masses, self._bodies(), self.coef, P, I, T, S, self.work,
            self.cwork, rec.work, float(clock[0]), float(clock[1]), *args, self.dense, *records, self._central(),
        )  # fmt: skip
        return self._done(rec)

    def _central(self) -> tuple:
        """(GM, centre, loose) of :func:`~emorbit.kernels.pointmass.effect_step.effect_substep`:
        the central field's (GM 0 where there is none) and the largest part of their Jacobian
        that the set's pieces at points leave out, relative to the central field's
        (:attr:`~emorbit.effects.base.Effect.JACOBIAN_LEFT_OUT`)."""
        effects = self.binding.effects
        if effects.field is None:
            return 0.0, np.zeros(3), math.inf
        return float(effects.field.gm), np.ascontiguousarray(effects.field.center, float), effects.jacobian_left_out()

    def _bodies(self) -> np.ndarray:
        return np.arange(self.x.shape[1], dtype=np.int64)

    def _tfe_arrays(self, method: str, gammas) -> tuple:
        """What the time finite element's step takes beside the set: (potential, Gauss tables,
        their low parts, GM, the centre, ``coef_c``, ``coef_n``, has_n, has_d, ``row_effect``).
        The kernel forms the central field itself (its row is 0 in both coefficient arrays);
        the forces of the other effects whose potential does not change in time are scaled
        with it for the energy (``coef_c``), the others' are not (``coef_n``; ``has_n`` 1 where
        there are any, 2 where a force among them depends on the velocity); a working
        effect's work is its force's over the stages, plus its potential's change where that
        changes in time (``row_effect`` >= 0). For another method, placeholders of the same
        types (unread)."""
        from ..kernels.pointmass.tfe import low_parts

        prog = self.binding.program
        gm, center, _ = self._central()
        if method != "tfe":
            w = self.work.shape[0]
            return (prog.potential, np.zeros((1, 5)), np.zeros((1, 2)), gm, center, self.coef, self.coef, 0, False,
                    np.full(w, -1, np.int64))  # fmt: skip
        static, other, row_effect = self.binding.tfe_split()
        moving = any(w and not type(e).EXPLICIT for w, e in zip(other, self.binding.effects.all))
        tab = dispatch.tfe_tables(gammas)
        return (
            prog.potential, tab, low_parts(2 * tab.shape[0]), gm, center,
            np.ascontiguousarray(self.coef * static[:, None]), np.ascontiguousarray(self.coef * other[:, None]),
            (2 if moving else 1) if other.max(initial=0.0) > 0.0 else 0, bool((row_effect >= 0).any()), row_effect,
        )  # fmt: skip

    def _tfe(self, rec, dt, gammas, every, nrec, max_iter, clock):
        """Fixed steps of the time finite element (:meth:`_tfe_arrays`)."""
        from ..kernels.pointmass.effect_tfe import effect_tfe_chunk

        potential, tab, lo, gm, center, coef_c, coef_n, has_n, has_d, row_effect = self._tfe_arrays("tfe", gammas)
        prog = self.binding.program
        P, I, T, S = self.binding.arrays(self.x.shape[1])
        effect_tfe_chunk(
            prog.forces, prog.prepare, prog.work, potential, tab, lo, self.x, self.v, self.cx, self.cv, self.masses,
            self._bodies(), gm, center, coef_c, coef_n, has_n, has_d, P, I, T, S, self.work, self.cwork, rec.work,
            row_effect, float(clock[0]), float(clock[1]), float(dt), int(every), int(nrec), int(max_iter), rec.x, rec.v,
            rec.iterations, rec.fail,
        )  # fmt: skip
        return self._done(rec)

    def _gammas(self, method: str, gammas) -> np.ndarray:
        """The composed step's sub-steps: one step for tfe (its order is its Gauss stages')."""
        return np.ones(1) if method == "tfe" else np.ascontiguousarray(gammas, float)

    def adaptive(self, rec, method, rho, eta, dt, gammas, every, nrec, max_iter, clock):
        """Adaptive, time-symmetric steps of all points together, landing on every multiple of
        ``dt``, into the records ``rec``; ``rho`` (1,) the set's control variable, updated in
        place. Returns the records and the composed steps per record (nrec, n)."""
        from ..kernels.pointmass.effect_adaptive import effect_adaptive_chunk

        n = self.x.shape[1]
        steps = np.zeros((nrec, n), dtype=np.int64)
        prog = self.binding.program
        P, I, T, S = self.binding.arrays(n)
        effect_adaptive_chunk(
            prog.forces, prog.cross, prog.prepare, prog.work, prog.rate, dispatch.method_code(method, "fast"), self.x,
            self.v, self.cx, self.cv, self.wp, self.hp, rho, self.masses, self._bodies(), self.coef, P, I, T, S,
            self.work, self.cwork, rec.work, float(clock[0]), float(clock[1]), float(dt), int(every), float(eta),
            self._gammas(method, gammas), int(nrec), int(max_iter), self.dense, rec.x, rec.v, rec.iterations, steps,
            rec.fail, self._tfe_arrays(method, gammas), self._central(),
        )  # fmt: skip
        return self._done(rec), steps

    def reversible(self, method, rho, eta, gammas, nsteps, max_iter, t0, direction):
        """Exactly ``nsteps`` adaptive composed steps of size 1 in tau from time ``t0`` (the
        clock running backwards with ``direction`` -1), without landing. Returns (elapsed
        time, status)."""
        from ..kernels.pointmass.effect_adaptive import effect_reversible_steps

        prog = self.binding.program
        P, I, T, S = self.binding.arrays(self.x.shape[1])
        return effect_reversible_steps(
            prog.forces, prog.cross, prog.prepare, prog.work, prog.rate, dispatch.method_code(method, "fast"), self.x,
            self.v, self.cx, self.cv, self.wp, self.hp, rho, self.masses, self._bodies(), self.coef, P, I, T, S,
            self.work, self.cwork, float(t0), float(direction), float(eta), self._gammas(method, gammas),
            int(nsteps), int(max_iter), self.dense, self._tfe_arrays(method, gammas), self._central(),
        )  # fmt: skip
