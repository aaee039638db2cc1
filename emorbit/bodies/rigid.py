"""Rigid bodies: their mass points, director state, and the calls into
:mod:`emorbit.kernels.rigid` (a body from user input: :mod:`emorbit.bodies.rigid_input`).

State per body (SI): ``q = (phi, d1, d2, d3)`` and ``v = dq/dt`` (12 each, rows of (nb, 12)
arrays) with Kahan compensation terms, and a warm start for the 6 multipliers of the
orthonormality constraints d_k . d_l = delta_kl. The attitude is R = [d1 d2 d3] (body axes
in space); it is recorded as a unit quaternion (scalar first) and the angular velocity in
the body frame, Omega = J^-1 R^T L from the spin angular momentum
(:mod:`emorbit.kernels.rigid_records`). The director mass matrix is E = sum m X X^T over the mass
points (:mod:`emorbit.bodies.shapes`), the inertia J = tr(E) I - E.

Effects (the simulation's set, :class:`~emorbit.bodies.effect_binding.EffectBinding`) act at
a body's mass points (its centre of mass for the point gravity model) and on its flat facets
(:mod:`emorbit.bodies.facets`: the shape's surface and any facet tables, built on first use);
the work of the effects that do work is summed per body into ``work`` (nb, k) J with Kahan
terms ``cwork`` (state, checkpointed, zeroed at a run's start); records carry it
(``RigidRecords.work``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..integrators.dispatch import method_code
from ..integrators.plan import Plan
from ..kernels import rigid as kern
from ..kernels.rigid_records import rigid_record_values
from .ledger import ledger_terms
from .pointmasses import earliest_failure
from .shapes import MassPoints
from .system import BodySystem, WorkSums, roundoff_scales

__all__ = ["RigidBodies", "RigidRecords", "GRAVITY_MODELS"]

#: gravity models a rigid body can ask for
GRAVITY_MODELS = {"volume": kern.GRAVITY_VOLUME, "point": kern.GRAVITY_POINT, "none": kern.GRAVITY_NONE}


@dataclass
class RigidRecords:
    """The states one kernel call recorded.

    Attributes
    ----------
    q, v : ndarray
        (nrec, nb, 12) director states and their velocities after each record interval, SI.
    iterations : ndarray
        (nrec, nb) Newton iterations summed over each interval.
    fail : ndarray
        (nb, 2) step index within the chunk and status code per body, -1 if none.
    stalled : ndarray or None
        (nrec, nb) sub-steps of each interval whose Newton iteration was accepted at its
        floor, above round-off.
    work : ndarray or None
        (nrec, nb, k) the work each of k effects that do work (drag, radiation pressure,
        third bodies) has done on each body since the run's start, J.
    solves : ndarray or None
        (nrec, nb) sub-steps per interval, when the steps vary (adaptive).
    t : ndarray or None
        (nrec,) the records' times, s from the epoch (set by the recorder).
    """

    q: np.ndarray
    v: np.ndarray
    iterations: np.ndarray
    fail: np.ndarray
    stalled: np.ndarray | None = None
    work: np.ndarray | None = None
    solves: np.ndarray | None = None
    t: np.ndarray | None = None

    def first_failure(self):
        """The earliest failure.

        Returns
        -------
        tuple of int or None
            (step index in the chunk, body index, status), or None.
        """
        return earliest_failure(self.fail)


class RigidBodies(WorkSums, BodySystem):
    """A set of rigid bodies, each with its own mass points and gravity model.

    The rigid-body system of a simulation; the arrays hold every body's state in rows and
    all mass points packed into one (3, N) array with ``offsets`` per body.

    Attributes
    ----------
    effects : EffectBinding or None
        The simulation's effects (set by the simulation).
    values : dict
        {name: {body key: SI value}}: the effect keys given for each body.
    """

    kind = "rigid"
    #: per-body datasets and their units (see emorbit.io.reader)
    DATASETS = {
        "position": (3, "m"),
        "velocity": (3, "m / s"),
        "attitude": (4, "1"),
        "angular_velocity": (3, "rad / s"),
    }
    METHODS = ("em", "midpoint", "tfe")
    #: methods whose steps take effects at the gravity points only, not on surfaces
    #: (:class:`~emorbit.bodies.rigid_tfe.RigidTFE`)
    POINTS_ONLY = ("tfe",)
    #: the state of every set of rigid bodies
    BASE_FIELDS = ("q", "v", "cq", "cv", "lam")
    #: the state that effects doing work add: their work so far and its compensation
    WORK_FIELDS = ("work", "cwork")
    #: units of the state arrays beyond emorbit.io.reader.STATE_UNITS
    STATE_UNITS = {"work": "J", "cwork": "J"}

    def __init__(self, plan: Plan | None = None):
        self.plan = Plan() if plan is None else plan
        self.names: list[str] = []
        self.shapes: list[str] = []
        self.params: list[dict] = []
        self.points: list[MassPoints] = []
        self.models = np.zeros(0, dtype=np.int64)
        self.mass = np.zeros(0)
        self.E = np.zeros((0, 3, 3))
        self.Einv = np.zeros((0, 3, 3))
        self._inverse_inertias = None  # (E, J^-1 of that E): see inverse_inertias
        self.q = np.zeros((0, 12))
        self.v = np.zeros((0, 12))
        self.cq = np.zeros((0, 12))
        self.cv = np.zeros((0, 12))
        self.lam = np.zeros((0, 6))
        self.rho = np.zeros(0)  # adaptive steps' control variables, 1/s (0: set from the state)
        self.effects = None
        self.values: dict[str, dict] = {}
        self.surfaces: list = []  # per body: how its facets are made (see add), built on first use
        self._facets: list = []  # per body: Facets or None, once built
        self._work = np.zeros((0, 0))
        self._cwork = np.zeros((0, 0))
        self._pack()

    def _pack(self) -> None:
        counts = [len(p) for p in self.points]
        self.offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self.X = (
            np.ascontiguousarray(np.concatenate([p.X for p in self.points], axis=1))
            if self.points
            else np.zeros((3, 0))
        )
        self.mp = np.ascontiguousarray(np.concatenate([p.m for p in self.points])) if self.points else np.zeros(0)

    def add(
        self,
        name: str,
        shape: str,
        points: MassPoints,
        model: str,
        position,
        velocity,
        R,
        omega_space,
        params: dict | None = None,
        surface=None,
    ) -> None:
        """Append a body; the others keep their state, compensation terms and warm starts.

        Parameters
        ----------
        name : str
            A new name.
        shape : str
            The shape's name.
        points : MassPoints
            The mass points, body frame.
        model : str
            A key of :data:`GRAVITY_MODELS`.
        position, velocity : array_like
            The centre of mass's state (3,), m and m/s.
        R : array_like
            (3, 3) attitude matrix, body to space.
        omega_space : array_like
            (3,) angular velocity in space axes, rad/s.
        params : dict, optional
            The shape's parameters in SI, kept to write the body back as a scene.
        surface : tuple, optional
            How its facets are made, for drag and radiation pressure: ``(mode, facets,
            defaults, key)``, mode ``"shape"`` (the shape's surface, plus ``facets``) or
            ``"none"`` (``facets`` alone, a :class:`~emorbit.bodies.facets.Facets` or None),
            ``defaults`` the shape facets' coefficients, ``key`` the body's key in errors.
            None: no facets.
        """
        self.names.append(name)
        self.surfaces.append(surface)
        self._facets.append(None)
        self.shapes.append(shape)
        self.params.append(dict(params or {}))
        self.points.append(points)
        E = points.second_moment
        self.models = np.append(self.models, GRAVITY_MODELS[model])
        self.mass = np.append(self.mass, points.mass)
        self.E = np.concatenate([self.E, E[None]])
        self.Einv = np.concatenate([self.Einv, np.linalg.inv(E)[None]])
        self.rho = np.append(self.rho, 0.0)
        R = np.asarray(R, float)
        w = np.asarray(omega_space, float)
        q = np.concatenate([position, R[:, 0], R[:, 1], R[:, 2]])
        v = np.concatenate([velocity] + [np.cross(w, R[:, k]) for k in range(3)])
        self.q = np.ascontiguousarray(np.vstack([self.q, q]))
        self.v = np.ascontiguousarray(np.vstack([self.v, v]))
        # the bodies already there keep their compensation terms, warm starts and work
        k = self._work_shape()[1]
        if self._work.shape == (len(self.names) - 1, k):  # the others' work so far is kept
            self._work = np.vstack([self._work, np.zeros((1, k))])
            self._cwork = np.vstack([self._cwork, np.zeros((1, k))])
        self.cq = np.ascontiguousarray(np.vstack([self.cq, np.zeros_like(q)]))
        self.cv = np.ascontiguousarray(np.vstack([self.cv, np.zeros_like(v)]))
        self.lam = np.ascontiguousarray(np.vstack([self.lam, np.zeros(6)]))
        self._pack()

    def pop(self, name: str) -> dict:
        """Remove a body and return what is needed to add it elsewhere.

        Parameters
        ----------
        name : str
            The body.

        Returns
        -------
        dict
            ``shape``, ``points``, ``gravity``, ``position``, ``velocity``, ``R``,
            ``omega_space``, ``params``, ``surface`` and ``values`` (its effect keys).
        """
        b = self.names.index(name)
        q, v = self.q[b], self.v[b]
        D = q[3:].reshape(3, 3)
        dD = v[3:].reshape(3, 3)
        inv = {val: k for k, val in GRAVITY_MODELS.items()}
        out = {
            "shape": self.shapes[b],
            "points": self.points[b],
            "gravity": inv[int(self.models[b])],
            "position": q[:3].copy(),
            "velocity": v[:3].copy(),
            "R": D.T.copy(),
            "omega_space": 0.5 * np.cross(D, dD).sum(axis=0),
            "params": self.params[b],
            "surface": self.surfaces[b],
            "values": self.values.get(name, {}),
        }
        keep = [j for j in range(len(self.names)) if j != b]
        if self._work.shape[0] == len(self.names):
            self._work, self._cwork = self._work[keep], self._cwork[keep]
        self.values.pop(name, None)
        for attr in ("names", "shapes", "points", "params", "surfaces", "_facets"):
            lst = getattr(self, attr)
            del lst[b]
        for attr in ("models", "mass", "E", "Einv", "q", "v", "cq", "cv", "lam", "rho"):
            setattr(self, attr, np.ascontiguousarray(getattr(self, attr)[keep]))
        self._pack()
        return out

    # -- stepping ------------------------------------------------------------------------
    def work_per_step(self) -> int:
        """Mass points touched per step."""
        return int(sum(len(p) if m == kern.GRAVITY_VOLUME else 1 for p, m in zip(self.points, self.models))) + 50 * len(
            self
        )

    def advance(
        self,
        method: str,
        gm: float,
        center,
        dt: float,
        gammas,
        every: int,
        nrec: int,
        max_iter: int,
        clock: tuple = (0.0, 0),
    ) -> RigidRecords:
        """Advance all bodies ``nrec * every`` composed steps, recording every ``every``.

        Parameters
        ----------
        method : str
            ``"em"``, ``"midpoint"`` or ``"tfe"`` (:class:`~emorbit.bodies.rigid_tfe.RigidTFE`).
        gm : float
            GM, m^3/s^2.
        center : array_like
            The field's centre (3,), m.
        dt : float
            The step, s.
        gammas : ndarray
            The composition's sub-step fractions.
        every : int
            Steps per record.
        nrec : int
            Records.
        max_iter : int
            Newton iterations per sub-step at most.
        clock : tuple
            ``(t_base, n0)``: the chunk's j-th step starts at ``t_base + (n0 + j) dt``, s from
            the run's epoch (effects that depend on time read it; a step's time does not
            depend on where chunks start).

        Returns
        -------
        RigidRecords
            The records.
        """
        if method == "tfe":
            from .rigid_tfe import RigidTFE

            return RigidTFE(self, gammas).advance(gm, center, dt, every, nrec, max_iter, clock)
        if self.adaptive is not None:
            return self._advance_adaptive(method, gm, center, dt, gammas, every, nrec, max_iter, clock)
        rec = self._records(nrec)
        prog = self.effects.program
        P, I, T, S = self.effects.arrays(self.mp.size)
        coef, pcoef = self.coefficients()
        foff, facets = self.packed_facets()
        work = self.work
        rec.work = np.empty((nrec,) + work.shape)
        kern.rigid_chunk(
            prog.forces, prog.prepare, prog.work, prog.facets, method_code(method), self.models, self.q, self.v,
            self.cq, self.cv, self.lam, self.mass, self.E, self.Einv, self.offsets, self.X, self.mp, coef, pcoef, foff,
            facets, float(gm), np.ascontiguousarray(center, float), float(dt), np.ascontiguousarray(gammas, float),
            int(every), int(nrec), int(max_iter), rec.q, rec.v, rec.iterations, rec.stalled, rec.fail, P, I, T, S,
            work, self.cwork, rec.work, float(clock[0]), float(clock[1]), self._ledger(),
        )  # fmt: skip
        if not work.shape[1]:
            rec.work = None
        return rec

    # -- effects ---------------------------------------------------------------------------
    def _ledger(self) -> bool:
        """Whether the work sums end with the effect set's ledger row."""
        return self.effects is not None and self.effects.effects.ledger()

    def _work_shape(self) -> tuple:
        return (len(self), self.effects.effects.work_rows() if self.effects is not None else 0)

    def coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """Each effect's coefficient at the bodies' points: (k, N) for the mass points, (k, nb)
        for the centres of mass (the point gravity model)."""
        counts = np.diff(self.offsets)
        coef = self.effects.coefficients(self.names, self.values, counts)
        pcoef = self.effects.coefficients(self.names, self.values)
        return coef, pcoef

    def facets(self, b: int):
        """Body b's facets (:class:`~emorbit.bodies.facets.Facets`), or None where it has none
        (``facets = "none"`` and no facet tables), built on first use.

        Raises
        ------
        InputError
            The shape has no surface (a dumbbell) and no facet tables were given.
        """
        if self._facets[b] is None and self.surfaces[b] is not None:
            from .facets import Facets, shape_facets

            mode, extra, defaults, key = self.surfaces[b]
            parts = [shape_facets(self.shapes[b], self.params[b], key=key, **defaults)] if mode == "shape" else []
            if extra is not None and len(extra):
                parts.append(extra)
            self._facets[b] = Facets.concatenate(parts) if parts else None
            if self._facets[b] is None or not len(self._facets[b]):
                self._facets[b] = None
                self.surfaces[b] = None
        return self._facets[b]

    def packed_facets(self) -> tuple[np.ndarray, np.ndarray]:
        """The facets of the bodies that surface effects reach, packed: ``foff`` (nb + 1,) int64
        and the rows (nf, 11) (:mod:`emorbit.kernels.rigid_surface`); no rows where none does."""
        effects, rows, counts = self.effects.effects, [], []
        for b, name in enumerate(self.names):
            f = self.facets(b) if effects.needs_surface("rigid", name) else None
            own = effects.own_facets("rigid", name)
            counts.append(len(own) + (0 if f is None else len(f)))
            if f is not None:
                rows.append(f.packed())
            rows.append(own)
        foff = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        return foff, np.ascontiguousarray(np.vstack(rows)) if rows else np.zeros((0, 11))

    def effect_work(self, rec, nrec: int) -> dict:
        """The work of each effect that does work on all bodies since the run's start.

        Returns
        -------
        dict
            {``work_<label>``: (nrec,) J}; {} without such effects.
        """
        if rec.work is None:
            return {}
        return {f"work_{e.label}": rec.work[:nrec, :, k].sum(axis=1) for k, e in enumerate(self.effects.working())}

    #: adaptive steps taken so far, summed over the bodies
    adaptive_steps: int = 0

    @property
    def STATE_FIELDS(self) -> tuple:  # noqa: N802 (the name every body system uses)
        """The whole state: :attr:`BASE_FIELDS`, :attr:`WORK_FIELDS` where an effect does work,
        and the control variables ``rho`` of adaptive steps."""
        work = self.WORK_FIELDS if self._work_shape()[1] else ()
        return self.BASE_FIELDS + work + (("rho",) if self.adaptive is not None else ())

    def inverse_inertias(self) -> np.ndarray:
        """(nb, 3, 3) the inverse body-frame inertias J^-1, J = tr(E) I - E, 1/(kg m^2), kept
        while ``E`` is the same array (adding or removing a body replaces it)."""
        cached = self._inverse_inertias
        if cached is not None and cached[0] is self.E:
            return cached[1]
        tr = np.trace(self.E, axis1=1, axis2=2)[:, None, None]
        out = np.ascontiguousarray(np.linalg.inv(tr * np.eye(3) - self.E))
        self._inverse_inertias = (self.E, out)
        return out

    def _records(self, nrec: int) -> RigidRecords:
        """Empty records of ``nrec`` intervals (no failure, no stall yet)."""
        nb = len(self)
        z = np.zeros((nrec, nb), np.int64)
        return RigidRecords(
            np.empty((nrec, nb, 12)), np.empty((nrec, nb, 12)), z, np.full((nb, 2), -1, np.int64), z.copy()
        )

    def _advance_adaptive(self, method, gm, center, dt, gammas, every, nrec, max_iter, clock) -> RigidRecords:
        """Adaptive, time-symmetric steps (:mod:`emorbit.kernels.rigid_adaptive`) that land on
        every multiple of ``dt``, recorded every ``every * dt`` seconds."""
        from ..kernels.rigid_adaptive import rigid_adaptive_chunk

        nb = len(self)
        rec = self._records(nrec)
        if self.rho.shape != (nb,):  # the arrays were set directly: start the control from the state
            self.rho = np.zeros(nb)
        steps = np.zeros((nrec, nb), np.int64)
        prog = self.effects.program
        P, I, T, S = self.effects.arrays(self.mp.size)
        coef, pcoef = self.coefficients()
        foff, facets = self.packed_facets()
        work = self.work
        rec.work = np.empty((nrec,) + work.shape)
        rigid_adaptive_chunk(
            prog.forces, prog.facets, prog.prepare, prog.work, method_code(method), self.models, self.q, self.v,
            self.cq, self.cv, self.lam, self.rho, self.mass, self.E, self.Einv, self.inverse_inertias(), self.offsets,
            self.X, self.mp, coef, pcoef, foff, facets, float(gm), np.ascontiguousarray(center, float), float(dt),
            int(every), float(self.adaptive), np.ascontiguousarray(gammas, float), int(nrec), int(max_iter), rec.q,
            rec.v, rec.iterations, steps, rec.stalled, rec.fail, P, I, T, S, work, self.cwork, rec.work,
            float(clock[0]), float(clock[1]), self._ledger(),
        )  # fmt: skip
        if not work.shape[1]:
            rec.work = None
        rec.solves = steps * len(gammas)
        self.adaptive_steps += int(steps.sum())
        return rec

    def reversible_steps(self, method: str, gm: float, center, gammas, nsteps: int, max_iter: int) -> np.ndarray:
        """Take exactly ``nsteps`` adaptive composed steps of size 1 in tau from every body (no
        landing on a time): the scheme alone, for its time symmetry. Reversing ``v`` and ``cv``
        and calling it again runs the same steps back.

        Returns
        -------
        ndarray
            (nb,) the physical time each body advanced, s.

        Raises
        ------
        RuntimeError
            A step failed (its status in the message).
        """
        from ..kernels.rigid_adaptive import rigid_reversible_steps

        if method == "tfe":
            from .rigid_tfe import RigidTFE

            return RigidTFE(self, gammas).reversible_steps(gm, center, nsteps, max_iter)
        prog = self.effects.program
        P, I, T, S = self.effects.arrays(self.mp.size)
        coef, pcoef = self.coefficients()
        foff, facets = self.packed_facets()
        elapsed = np.zeros(len(self))
        status = rigid_reversible_steps(
            prog.forces, prog.facets, prog.prepare, prog.work, method_code(method), self.models, self.q, self.v,
            self.cq, self.cv, self.lam, self.rho, self.mass, self.E, self.Einv, self.inverse_inertias(), self.offsets,
            self.X, self.mp, coef, pcoef, foff, facets, float(gm), np.ascontiguousarray(center, float),
            float(self.adaptive), np.ascontiguousarray(gammas, float), int(nsteps), int(max_iter), elapsed, P, I, T,
            S, self.work, self.cwork, self._ledger(),
        )  # fmt: skip
        if status != 0:
            raise RuntimeError(f"an adaptive step failed with status {status}")
        return elapsed

    def gravity_points(self, q: np.ndarray):
        """Where the point effects act on each body at recorded states q (rows, nb, 12): for
        each body that feels them, (b, its mass points' positions (rows, 3, N), their masses
        (N,)) (the centre of mass and the body's mass for the point model)."""
        D = q[..., 3:].reshape(q.shape[:-1] + (3, 3))
        for b in range(len(self)):
            if self.models[b] == kern.GRAVITY_NONE:
                continue
            if self.models[b] == kern.GRAVITY_POINT:
                yield b, q[:, b, 0:3, None], np.array([self.mass[b]])
            else:
                Xb, mb = self.points[b].X, self.points[b].m
                yield b, q[:, b, 0:3, None] + np.einsum("kn,rki->rin", Xb, D[:, b]), mb

    def current(self) -> RigidRecords:
        """The current state as one record, with the work so far where an effect does work."""
        return RigidRecords(
            self.q[None].copy(),
            self.v[None].copy(),
            np.zeros((1, len(self)), np.int64),
            np.full((len(self), 2), -1, np.int64),
            work=self.work[None].copy() if self._work_shape()[1] else None,
        )

    def snapshot(self):
        """Copies of q, v, cq, cv, lam, the work sums and rho."""
        return tuple(a.copy() for a in (self.q, self.v, self.cq, self.cv, self.lam, self.work, self.cwork, self.rho))

    KICKS = True

    def kick(self, name: str, dv, key: str = "dv") -> tuple[float, np.ndarray]:
        """Add ``dv`` to a body's centre-of-mass velocity (its spin unchanged), the rounding
        kept in ``cv``; see :meth:`~emorbit.bodies.system.BodySystem.kick`."""
        b = self.names.index(name)
        before = self.v[b, :3].copy()
        new = before + dv
        err = (before - (new - (new - before))) + (dv - (new - before))
        self.v[b, :3], self.cv[b, :3] = new, self.cv[b, :3] - err
        return float(self.mass[b]), before

    def restore(self, snap) -> None:
        """Put back q, v, cq, cv, lam, the work sums and rho from :meth:`snapshot`."""
        for a, s in zip((self.q, self.v, self.cq, self.cv, self.lam, self.work, self.cwork, self.rho), snap):
            a[...] = s

    # -- diagnostics -----------------------------------------------------------------------
    def invariants(self, rec: RigidRecords, nrec: int, gm: float, center):
        """Energy (kinetic plus every effect's potential), momentum and angular momentum
        (orbital plus spin) about the field's centre at each record."""
        sums = self._values(rec, nrec, center)[0]
        return sums[:, 0] + sum(self._potentials(rec, nrec).values()), sums[:, 1:4], sums[:, 4:7]

    def _values(self, rec: RigidRecords, nrec: int, center=None):
        """The records' kinetic energy, momenta about ``center`` (None: any, for the attitudes
        and spins alone), attitudes and spins (:func:`~emorbit.kernels.rigid_records.rigid_record_values`),
        once per records: a record's invariants, their scales and its datasets ask for the same."""
        c = np.zeros(3) if center is None else np.ascontiguousarray(center, float)
        key = (nrec, tuple(c))
        cached = self.__dict__.get("_last_values")
        if cached is not None and cached[0] is rec and (cached[1] == key or center is None and cached[1][0] == nrec):
            return cached[2]
        nb = len(self)
        out = (np.empty((nrec, 8)), np.empty((nrec, nb, 4)), np.empty((nrec, nb, 3)))
        rigid_record_values(
            np.ascontiguousarray(rec.q[:nrec]), np.ascontiguousarray(rec.v[:nrec]), self.mass, self.E,
            self.inverse_inertias(), c, *out,
        )  # fmt: skip
        self._last_values = (rec, key, out)
        return out

    def _potentials(self, rec: RigidRecords, nrec: int, only: int | None = None) -> dict:
        """Every effect's potential energy at each record, of the bodies' points (``only``: of
        that body's): {``potential_<label>``: (nrec,) J}."""
        cached = self.__dict__.get("_last_energies")  # invariants, scales and the file ask for the same
        if only is None and cached is not None and cached[0] is rec and cached[1] == nrec:
            return cached[2]
        q = rec.q[:nrec]
        parts = [part for part in self.gravity_points(q) if only is None or part[0] == only]
        coef, pcoef = self.coefficients()
        cols, xs, ms, bodies = [], [], [], []
        for b, x, mb in parts:
            o0, o1 = self.offsets[b], self.offsets[b + 1]
            cols.append(pcoef[:, b : b + 1] if self.models[b] == kern.GRAVITY_POINT else coef[:, o0:o1])
            xs.append(x)
            ms.append(mb)
            bodies.append(np.full(mb.shape[0], b, np.int64))
        if not xs:
            out = {f"potential_{e.label}": np.zeros(nrec) for e in self.effects.effects.with_potential()}
        else:
            out = self.effects.potentials(
                np.concatenate(xs, axis=2), None if rec.t is None else rec.t[:nrec], np.concatenate(ms),
                np.concatenate(bodies), np.ascontiguousarray(np.concatenate(cols, axis=1)),
            )  # fmt: skip
        if only is None:
            self._last_energies = (rec, nrec, out)
        return out

    def ledger(self, rec: RigidRecords, nrec: int, lost: dict) -> dict:
        """The mass ledger's terms at each record (:func:`~emorbit.bodies.ledger.ledger_terms`):
        a body a burn lightens loses its mass evenly, so its energy at its initial mass counts
        its spin as well."""
        if rec.work is None or not self._ledger():
            return {}
        nk = len(self.effects.working())
        v = rec.v[:nrec]

        def energy_at(b):
            dphi, dD = v[:, b, 0:3], v[:, b, 3:].reshape(nrec, 3, 3)
            kinetic = 0.5 * self.mass[b] * np.einsum("ri,ri->r", dphi, dphi)
            kinetic = kinetic + 0.5 * np.einsum("kl,rki,rli->r", self.E[b], dD, dD)
            return kinetic + sum(self._potentials(rec, nrec, only=b).values())

        rows = rec.work[:nrec]  # (nrec, nb, w)
        return ledger_terms(rows[:, :, :nk].sum(axis=2), rows[:, :, nk], lost, self.names, self.mass, energy_at)

    def effect_energies(self, rec: RigidRecords, nrec: int, gm: float, center) -> dict:
        """Each effect's potential energy at each record, where the bodies feel effects beyond
        the central field ({} otherwise: the energy alone is recorded)."""
        if not self.effects.effects.beyond_field():
            return {}
        return self._potentials(rec, nrec)

    def invariant_scales(self, rec: RigidRecords, nrec: int, gm: float, center) -> np.ndarray:
        """Round-off scales of the invariants at each record (:func:`~emorbit.bodies.system.roundoff_scales`):
        kinetic energy (translation and spin), the potential's magnitude, the mass, and
        m |phi - c|^2 + tr E, each summed over the bodies."""
        sums = self._values(rec, nrec, center)[0]
        T, moment = sums[:, 0], sums[:, 7]
        energy = T + sum(self._potentials(rec, nrec).values())
        return roundoff_scales(T, np.abs(energy - T), self.mass.sum(), moment)

    def newton_facts(self, index: int, method: str, gm: float, center, h: float, max_iter: int):
        """:func:`emorbit.kernels.rigid.rigid_step` on the body's next step (under the effects
        prepared for the last step's times): status and its last update relative to the
        mass-weighted scale of the increments (residual: None); None for tfe, whose Newton
        iteration is not the em step's."""
        from ..kernels.rigid_surface import facet_scratch

        if method == "tfe":
            return None

        b = index
        sl = slice(self.offsets[b], self.offsets[b + 1])
        Xb, mb = np.ascontiguousarray(self.X[:, sl]), np.ascontiguousarray(self.mp[sl])
        work = kern.work_arrays(Xb)
        q0, v0 = self.q[b].copy(), self.v[b].copy()
        c = np.asarray(center, float)
        prog = self.effects.program
        P, I, T, S = self.effects.arrays(self.mp.size)
        coef, pcoef = self.coefficients()
        foff, facets = self.packed_facets()
        f0, f1 = int(foff[b]), int(foff[b + 1])
        _, status, _ = kern.rigid_step(
            prog.forces, prog.facets, method_code(method), self.models[b], q0, v0, self.lam[b].copy(),
            self.mass[b], self.E[b], self.Einv[b], Xb, mb, float(gm), c, float(h), int(max_iter), work,
            np.ascontiguousarray(coef[:, sl]), np.ascontiguousarray(pcoef[:, b : b + 1]), P, I, T, S, facets, f0, f1,
            facet_scratch(f1 - f0, 0),
        )  # fmt: skip
        w, delta, dq = work[15], work[12], work[16]
        scale = float(np.sum(w * (h * v0) ** 2) + w[3] + w[6] + w[9] + np.sum(w * dq * dq))
        return int(status), float(np.sqrt(np.sum(w * delta[:12] ** 2) / scale)), None

    def datasets(self, rec: RigidRecords, nrec: int, times=None, first_row: int = 0) -> dict:
        """{name: {dataset: (nrec, width)}}: ``position`` (m), ``velocity`` (m/s), ``attitude`` (unit
        quaternion w, x, y, z) and ``angular_velocity`` (rad/s, body frame)."""
        q, v = rec.q[:nrec], rec.v[:nrec]
        _, quat, Omega = self._values(rec, nrec)
        out = {}
        for b, name in enumerate(self.names):
            out[name] = {
                "position": np.ascontiguousarray(q[:, b, 0:3]),
                "velocity": np.ascontiguousarray(v[:, b, 0:3]),
                "attitude": np.ascontiguousarray(quat[:, b]),
                "angular_velocity": np.ascontiguousarray(Omega[:, b]),
            }
        return out

    def body_datasets(self, i: int) -> dict:
        """:attr:`DATASETS`, the same for every rigid body."""
        return self.DATASETS

    def body_attrs(self, b: int) -> dict:
        """``kind`` "rigid", ``mass`` (kg), ``shape``, ``mass_points``, ``gravity`` and ``inertia``
        (kg m^2, of the mass points)."""
        p = self.points[b]
        inv = {v: k for k, v in GRAVITY_MODELS.items()}
        return {
            "kind": "rigid",
            "mass": float(self.mass[b]),
            "mass_unit": "kg",
            "shape": self.shapes[b],
            "mass_points": len(p),
            "gravity": inv[int(self.models[b])],
            "inertia": p.inertia,
            "inertia_unit": "kg m2",
        }

    def body_constants(self, b: int) -> dict:
        """The mass points in the body frame: positions (m) and masses (kg)."""
        p = self.points[b]
        return {"mass_points/position": (np.ascontiguousarray(p.X.T), "m"), "mass_points/mass": (p.m, "kg")}
