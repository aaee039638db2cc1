"""Point masses under a set of effects: the point-mass system of a scene with ``[[effect]]`` tables.

The state and records are those of :class:`~emorbit.bodies.pointmasses.PointMasses` ((3, n)
arrays ``x``, ``v`` with Kahan compensation terms; SI), plus the Newton iteration's warm
start (``wp`` (3, n), ``hp`` (1,)), which checkpoints store. The step is the em step compiled for
the simulation's effects (:func:`emorbit.effects.compose.compile_step`): the central field
when there is one, then each ``[[effect]]`` in the order the scene names them. Mutual gravity
couples the points, so all of them are one system and advance together. Where the effects are
the central field and its zonal harmonics only, the points are independent and run in the
packed kernel of :mod:`emorbit.kernels.effects.zonal_packed` instead (the same equations and
discrete force, vectorised over blocks of points like the central-only kernels; on all of
Numba's threads from its ``PARALLEL_MIN`` points on): :meth:`EffectPoints.step_kernel`. The
energy a record holds is the kinetic energy plus every effect's potential energy; each
effect's own is in :meth:`EffectPoints.effect_energies`. An effect that does work (drag) has
no potential: the compiled step sums its discrete work on each point into ``work`` (k, n) J
with Kahan terms ``cwork`` (state, checkpointed, zeroed at a run's start), records carry it
(``ChunkRecords.work``) and :meth:`EffectPoints.effect_work` gives its totals; each point's
``Cd A / m`` is :attr:`ballistic` (name -> m^2/kg).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..kernels import invariants as inv
from .pointmasses import ChunkRecords, PointMasses
from .system import WorkSums, roundoff_scales

__all__ = ["EffectPoints"]


class EffectPoints(WorkSums, PointMasses):
    """Point masses moved by the em step of a set of effects.

    Parameters
    ----------
    terms : list of EffectTerm
        The effects, the central field first where there is one.
    """

    #: the state of every effect set: the points' and the warm start of the next Newton iteration
    BASE_FIELDS = ("x", "v", "cx", "cv", "wp", "hp")
    #: the state a set with non-conservative effects adds: their work so far and its compensation
    WORK_FIELDS = ("work", "cwork")
    #: units of the state arrays beyond emorbit.io.reader.STATE_UNITS
    STATE_UNITS = {"wp": "m", "hp": "s", "work": "J", "cwork": "J"}

    def __init__(self, terms):
        super().__init__()
        self.terms = list(terms)
        self._kernel = None
        self._wp = np.zeros((3, 0))
        self.hp = np.zeros(1)
        self._work = np.zeros((0, 0))
        self._cwork = np.zeros((0, 0))

    @property
    def STATE_FIELDS(self) -> tuple:  # noqa: N802 (the name every body system uses)
        """The whole state: :attr:`BASE_FIELDS`, and :attr:`WORK_FIELDS` where an effect does
        work (a conservative set's checkpoints hold what they always held)."""
        return self.BASE_FIELDS + (self.WORK_FIELDS if self.working_terms() else ())

    def ordered_terms(self) -> list:
        """The effects in the order a step adds their forces: the registry's
        (:data:`emorbit.effects.EFFECTS`), several third bodies one after another."""
        from ..effects import EFFECTS

        rank = {k: i for i, k in enumerate(EFFECTS)}
        return sorted(self.terms, key=lambda t: rank[t.kind])

    def kinds(self) -> list:
        """The kinds of :meth:`ordered_terms`, each once: the compiled step's effect set."""
        return list(dict.fromkeys(t.kind for t in self.ordered_terms()))

    def working_terms(self) -> list:
        """The effects whose work the step sums (drag, radiation pressure, third bodies), in
        their slot order in :attr:`work`."""
        from ..effects import EFFECTS
        from ..effects.compose import does_work

        return [t for t in self.ordered_terms() if does_work(EFFECTS[t.kind])]

    def _work_shape(self) -> tuple:
        return (len(self.working_terms()), len(self))

    def current(self) -> ChunkRecords:
        """The current state as one record, with the work so far where an effect does work."""
        rec = super().current()
        if self.working_terms():
            rec.work = self.work[None].copy()
        return rec

    @property
    def wp(self) -> np.ndarray:
        """(3, n) the second-order part w of each point's last sub-step increment, m (the next
        iteration starts from it, scaled by (h / :attr:`hp`)^2); zeros for new points."""
        if self._wp.shape != self.x.shape:
            self._wp, self.hp = np.zeros_like(self.x), np.zeros(1)
        return self._wp

    @wp.setter
    def wp(self, value) -> None:
        self._wp = np.ascontiguousarray(value, dtype=float)

    def snapshot(self):
        """Copies of the points' state (:meth:`PointMasses.snapshot`), the warm start and the work sums."""
        return super().snapshot() + (self.wp.copy(), self.hp.copy(), self.work.copy(), self.cwork.copy())

    def restore(self, snap) -> None:
        """Put back what :meth:`snapshot` copied."""
        n = len(snap) - 4
        super().restore(snap[:n])
        self.wp[...] = snap[n]
        self.hp[...] = snap[n + 1]
        self.work[...] = snap[n + 2]
        self.cwork[...] = snap[n + 3]

    @classmethod
    def taking_over(cls, points: PointMasses, terms) -> EffectPoints:
        """An effect system with the points (state and compensation terms) of ``points``."""
        out = cls(terms)
        out.names = list(points.names)
        out.masses, out.x, out.v = points.masses.copy(), points.x.copy(), points.v.copy()
        out.cx, out.cv = points.cx.copy(), points.cv.copy()
        out.ballistic = dict(points.ballistic)
        out.radiation = dict(points.radiation)
        out.device = getattr(points, "device", "cpu")
        return out

    def _active(self, term) -> np.ndarray:
        """(n,) bool: the points the term acts on."""
        if term.bodies is None:
            return np.ones(len(self), bool)
        return np.isin(np.array(self.names, dtype=object), term.bodies)

    def independent(self) -> bool:
        """Whether the effects are the central field and its zonal harmonics only: then every
        point moves on its own, and :meth:`step_kernel` is the packed zonal kernel (a set with
        drag or mutual gravity is not: it runs the step compiled for it)."""
        if self.kinds() != ["central", "zonal"]:  # the kernel's parameter order
            return False
        params = {t.kind: t.params for t in self.terms}
        central, zonal = params["central"]["central_p"], params["zonal"]["zonal_p"]
        return bool(np.array_equal(central[:3], zonal[:3]))  # one centre, as build() makes it

    def step_kernel(self):
        """The chunk kernel for the effects: the packed kernel of the central field plus zonal
        harmonics (:func:`emorbit.kernels.effects.zonal_packed.chunk`) where
        :meth:`independent`, else the effect step compiled for the set
        (:func:`emorbit.effects.compose.compile_step`, which couples the points through
        mutual gravity). Both take ``chunk(x, v, cx, cv, wp, hp, m, *params, dt, gammas,
        every, nrec, max_iter, rec_x, rec_v, rec_iters, fail)``."""
        if self.independent():
            from ..kernels.effects.zonal_packed import chunk

            return chunk
        from ..effects.compose import compile_step

        return compile_step(self.kinds())

    def _params(self, clock=None) -> list:
        from ..effects.third_body import stack

        out = []
        third = [t for t in self.ordered_terms() if t.kind == "third_body"]
        for term in self.ordered_terms():
            if term.kind == "third_body":
                if term is third[0]:
                    out.extend(stack(third))
                continue
            out.extend(term.params.values())
            if term.kind == "mutual":
                out.append(self._active(term).astype(float))
            if term.kind == "drag":
                out.append(np.array([self.ballistic.get(n, 0.0) for n in self.names], float))
            if term.kind == "srp":
                out.append(np.array([self.radiation.get(n, 0.0) for n in self.names], float))
        if self.working_terms():
            out.extend([self.work, self.cwork])
        return out

    def timed(self) -> bool:
        """Whether the compiled step reads the run's clock (an effect's kernel code does)."""
        from ..effects import EFFECTS
        from ..effects.compose import timed

        return not self.independent() and any(timed(EFFECTS[k]) for k in self.kinds())

    def check(self, method: str, key: str = "method") -> None:
        """Refuse what the effect step cannot do yet.

        Raises
        ------
        InputError
            A method other than em, or a mutual term that names a body that is not a point.
        """
        if method != "em":
            raise InputError(key, f"effects other than the central field run with method 'em', got {method!r}")
        for term in self.terms:
            if term.bodies is not None:
                for name in term.bodies:
                    if name not in self.names:
                        raise InputError(
                            f"{term.key}.bodies", f"{name!r} is not a point mass: {term.kind} acts on point masses"
                        )

    def advance(self, method, gm, center, dt, gammas, every, nrec, max_iter, clock=(0.0, 0)) -> ChunkRecords:
        """Advance all points ``nrec * every`` composed em steps, recording every ``every``.

        Parameters
        ----------
        method : str
            ``"em"``.
        gm, center
            Unused: the effects carry the field.
        dt : float
            The step, s.
        gammas : ndarray
            The composition's sub-step fractions.
        every, nrec : int
            Steps per record, records.
        max_iter : int
            Newton sweeps per sub-step at most.
        clock : tuple
            ``(t_base, n0)``: the chunk's j-th step starts at ``t_base + (n0 + j) dt``, s from
            the run's epoch (effects that depend on time read it; a step's time does not
            depend on where chunks start).

        Returns
        -------
        ChunkRecords
            The records; on a failure every point stops before the failing step (in the
            packed zonal kernel, the failing point does; the others go on).
        """
        if self._kernel is None:
            self._kernel = self.step_kernel()
        n = len(self)
        rec = ChunkRecords(
            x=np.empty((nrec, 3, n)),
            v=np.empty((nrec, 3, n)),
            iterations=np.zeros((nrec, n), dtype=np.int64),
            fail=np.full((n, 2), -1, dtype=np.int64),
        )
        wp = self.wp
        params = self._params()
        if self.working_terms():
            rec.work = np.empty((nrec,) + self.work.shape)
            params.append(rec.work)
        if self.timed():
            params.extend([float(clock[0]), float(clock[1])])
        self._kernel(
            self.x, self.v, self.cx, self.cv, wp, self.hp, self.masses, *params, float(dt),
            np.asarray(gammas, float), int(every), int(nrec), int(max_iter), rec.x, rec.v, rec.iterations, rec.fail,
        )  # fmt: skip
        return rec

    def effect_work(self, rec: ChunkRecords, nrec: int) -> dict:
        """The work of each non-conservative effect on all points since the run's start.

        Returns
        -------
        dict
            {``work_<label>``: (nrec,) J}; {} where every effect is conservative.
        """
        if rec.work is None:
            return {}
        return {f"work_{t.label}": rec.work[:nrec, k].sum(axis=1) for k, t in enumerate(self.working_terms())}

    def effect_energies(self, rec: ChunkRecords, nrec: int, gm: float = 0.0, center=None) -> dict:
        """Each effect's potential energy at each record.

        Returns
        -------
        dict
            {``potential_<label>``: (nrec,) J}.
        """
        cached = getattr(self, "_last_energies", None)  # invariants, scales and the file ask for the same
        if cached is not None and cached[0] is rec and cached[1] == nrec:
            return cached[2]
        from ..effects import EFFECTS, has_potential

        x = rec.x[:nrec]
        t = None if getattr(rec, "t", None) is None else rec.t[:nrec]
        out = {
            f"potential_{e.label}": e.potential(x, self.masses, self._active(e), t)
            for e in self.terms
            if has_potential(EFFECTS[e.kind])  # drag and radiation pressure: their work is recorded instead
        }
        self._last_energies = (rec, nrec, out)
        return out

    def invariants(self, rec: ChunkRecords, nrec: int, gm: float, center):
        """Energy (kinetic plus every effect's potential), momentum and angular momentum about
        the field's centre at each record."""
        x, v = rec.x[:nrec], rec.v[:nrec]
        energy = inv.kinetic_energy(self.masses, v) + sum(self.effect_energies(rec, nrec).values())
        return energy, inv.momentum(self.masses, v), inv.angular_momentum(self.masses, x, v, center)

    def invariant_scales(self, rec: ChunkRecords, nrec: int, gm: float, center) -> np.ndarray:
        """Round-off scales of the invariants (:func:`~emorbit.bodies.system.roundoff_scales`):
        the kinetic energy plus the magnitudes of the effects' potentials, the mass, and
        sum m |x - c|^2."""
        x, v = rec.x[:nrec], rec.v[:nrec]
        c = np.asarray(center, float)[:, None]
        moment = np.einsum("...kn,...kn,n->...", x - c, x - c, self.masses)
        V = sum(np.abs(e) for e in self.effect_energies(rec, nrec).values())
        return roundoff_scales(inv.kinetic_energy(self.masses, v), V, self.masses.sum(), moment)

    def newton_facts(self, index, method, gm, center, h, max_iter):
        """None: the coupled sweeps have no per-point account of a failure."""
        return None

    def work_per_step(self) -> int:
        """Point updates per step, per Newton sweep: n, or n^2 with mutual gravity."""
        n = len(self)
        return n * n if any(t.kind == "mutual" for t in self.terms) else n
