"""Point masses: names, masses and their structure-of-arrays state.

In the central field alone the points are independent and advanced by the kernels in
:mod:`emorbit.kernels.pointmass` that :mod:`emorbit.integrators.dispatch` names. Under a set
of effects (:mod:`emorbit.effects`: zonal harmonics, drag, third bodies, mutual gravity, a
user's) they are advanced by the kernels :class:`~emorbit.bodies.point_effects.EffectRun`
calls with the set compiled (:class:`~emorbit.bodies.effect_binding.EffectBinding`). The state
is (3, n) float64 arrays of positions ``x`` (m) and velocities ``v`` (m/s) with Kahan
compensation terms ``cx`` and ``cv``: the exact state is ``x - cx``, ``v - cv``. Under
effects it adds the Newton iteration's warm start (``wp`` (3, n), ``hp`` (1,)) and, where an
effect does work, the work each has done on each point since the run's start (``work``,
``cwork`` (k, n), J, Kahan-compensated); each point's effect keys (a ``ballistic_coefficient``)
are in :attr:`PointMasses.values`.

On the GPU (``device = "gpu"``, fixed steps) the state lives in device memory between chunks
(:class:`emorbit.kernels.pointmass.cuda_resident.DeviceEnsemble`): it is uploaded at the
first chunk, and the host arrays are brought up to date only when something reads them
(``x``, ``v``, ``cx``, ``cv``, :meth:`PointMasses.current`, :meth:`PointMasses.state_arrays`:
checkpoints, the final state). Reading an array through its attribute also counts as a
possible change (the caller may write into it), so the next chunk uploads the host arrays
again; snapshots for redoing a failed step are copies on the device.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..integrators import dispatch, get_method
from ..integrators.plan import Plan
from ..kernels import invariants as inv
from .ledger import ledger_terms
from .system import BodySystem, WorkSums, roundoff_scales

__all__ = ["PointMasses", "ChunkRecords", "earliest_failure"]


def earliest_failure(fail: np.ndarray):
    """The earliest failure in a kernel's ``fail`` array.

    Parameters
    ----------
    fail : ndarray
        (n, 2) int64: per body, the step index within the chunk and the status code of its
        failure, step -1 where none.

    Returns
    -------
    tuple of int or None
        (step index in the chunk, body index, status), or None if no body failed.
    """
    bad = np.flatnonzero(fail[:, 0] >= 0)
    if bad.size == 0:
        return None
    i = bad[np.argmin(fail[bad, 0])]
    return int(fail[i, 0]), int(i), int(fail[i, 1])


@dataclass
class ChunkRecords:
    """The states one kernel call recorded.

    Attributes
    ----------
    x, v : ndarray
        (nrec, 3, n) positions (m) and velocities (m/s) after each record interval.
    iterations : ndarray
        (nrec, n) Newton iterations summed over each interval's sub-steps.
    fail : ndarray
        (n, 2) step index within the chunk and status code per point, -1 if none.
    solves : ndarray or None
        (nrec, n) implicit solves per interval, when the steps vary (adaptive).
    work : ndarray or None
        (nrec, k, n) the work each of k non-conservative effects (drag) has done on each point
        since the run's start, J, at each record (point masses under effects).
    t : ndarray or None
        (nrec,) the records' times, s from the epoch: the recorder sets them before it asks
        for the potentials of effects that depend on time.
    """

    x: np.ndarray
    v: np.ndarray
    iterations: np.ndarray
    fail: np.ndarray
    solves: np.ndarray | None = None  # (nrec, n) implicit solves per interval, when steps vary (adaptive)
    work: np.ndarray | None = None  # (nrec, k, n) work of k non-conservative effects so far, J (effects)
    t: np.ndarray | None = None  # (nrec,) the records' times, s from the epoch (set by the recorder)

    def first_failure(self):
        """The earliest failure.

        Returns
        -------
        tuple of int or None
            (step index in the chunk, body index, status), or None.
        """
        return earliest_failure(self.fail)


class PointMasses(WorkSums, BodySystem):
    """The point masses of a simulation.

    The state lives in (3, n) float64 arrays ``x``, ``v`` with Kahan compensation terms
    ``cx``, ``cv`` (the part of the exact sum that the rounded arrays miss); all SI. Points
    added one by one are appended to the arrays at once, when the arrays are next read.

    Attributes
    ----------
    effects : EffectBinding or None
        The simulation's effects (set by the simulation): with more than the central field,
        the points advance under them.
    values : dict
        {name: {body key: SI value}}: the effect keys given for each point.
    """

    kind = "point"

    def __init__(self, plan: Plan | None = None):
        self.plan = Plan() if plan is None else plan
        self._names: list[str] = []
        self._index: dict[str, int] | None = {}
        self._pending: list[tuple[float, np.ndarray, np.ndarray]] = []  # added, not yet in the arrays
        self._masses = np.zeros(0)
        self._x = np.zeros((3, 0))
        self._v = np.zeros((3, 0))
        self._cx = np.zeros((3, 0))
        self._cv = np.zeros((3, 0))
        self._rho = np.zeros(0)
        self.effects = None
        self.values: dict[str, dict] = {}
        self._wp = np.zeros((3, 0))
        self.hp = np.zeros(1)
        self._work = np.zeros((0, 0))
        self._cwork = np.zeros((0, 0))

    def __len__(self) -> int:
        return len(self._names)

    def __contains__(self, name) -> bool:
        if self._index is None or len(self._index) != len(self._names):
            self._index = {n: i for i, n in enumerate(self._names)}
        return name in self._index

    #: the state on the GPU (a DeviceEnsemble) once a chunk ran there, else None
    _dev = None
    #: the device's state is newer than the host arrays (download before reading them)
    _dev_newer = False
    #: the host arrays may have changed since the device's copy (upload before the next chunk)
    _host_newer = False

    def _sync_host(self) -> None:
        """Bring the host arrays up to date with the device's state, if that is newer."""
        if self._dev_newer:
            self._dev.download((self._x, self._v, self._cx, self._cv))
            self._dev_newer = False

    def _drop_device(self) -> None:
        """Forget the device's copy (after the host arrays are current): the points change."""
        self._sync_host()
        self._dev, self._host_newer = None, False

    def _flush(self) -> None:
        """Append the points added since the arrays were last read, all at once (adding
        points one by one then costs O(1) each, not a copy of every array)."""
        if not self._pending:
            return
        self._drop_device()
        m = np.array([p[0] for p in self._pending])
        x = np.array([p[1] for p in self._pending]).T
        v = np.array([p[2] for p in self._pending]).T
        self._pending = []
        self._masses = np.concatenate([self._masses, m])
        self._x = np.ascontiguousarray(np.concatenate([self._x, x], axis=1))
        self._v = np.ascontiguousarray(np.concatenate([self._v, v], axis=1))
        self._cx = np.ascontiguousarray(np.concatenate([self._cx, np.zeros_like(x)], axis=1))
        self._cv = np.ascontiguousarray(np.concatenate([self._cv, np.zeros_like(v)], axis=1))
        self._rho = np.concatenate([self._rho, np.zeros(len(m))])

    def _array(name: str, doc: str, state: bool = False):
        def get(self):
            self._flush()
            if state and self._dev is not None:  # current on the host; the caller may write into it
                self._sync_host()
                self._host_newer = True
            return getattr(self, name)

        def set(self, value):
            self._flush()
            if state and self._dev is not None:
                self._sync_host()
                self._host_newer = True
            setattr(self, name, value)

        return property(get, set, doc=doc)

    masses = _array("_masses", "(n,) masses (kg)")
    x = _array("_x", "(3, n) positions (m)", True)
    v = _array("_v", "(3, n) velocities (m/s)", True)
    cx = _array("_cx", "(3, n) compensation terms of x (m)", True)
    cv = _array("_cv", "(3, n) compensation terms of v (m/s)", True)
    rho = _array("_rho", "(n,) adaptive steps' control variables (1/s; 0: set from the state at the next step)")
    del _array

    def _state(self) -> tuple:
        """(x, v, cx, cv), current, for reading only (the device's copy stays valid)."""
        self._flush()
        self._sync_host()
        return self._x, self._v, self._cx, self._cv

    @property
    def names(self) -> list[str]:
        """Point names, in the order of adding."""
        return self._names

    @names.setter
    def names(self, value) -> None:
        self._names = list(value)
        self._index = None

    def add(self, name: str, mass: float, position: np.ndarray, velocity: np.ndarray) -> None:
        """Append one point; the others keep their state and compensation terms.

        Parameters
        ----------
        name : str
            A new name (checked by the simulation).
        mass : float
            kg.
        position, velocity : array_like
            (3,) m and m/s.
        """
        if self._index is not None:
            self._index[name] = len(self._names)
        self._names.append(name)
        self._pending.append(
            (float(mass), np.asarray(position, float).reshape(3).copy(), np.asarray(velocity, float).reshape(3).copy())
        )

    def pop_onto(self, name: str, nodes, positions, key: str):
        """Remove a point that a node of an elastic body becomes (checked first: a refused
        attachment changes nothing).

        Parameters
        ----------
        name : str
            The point.
        nodes : list of int
            The node indices (exactly one).
        positions : ndarray
            (len(nodes), 3) their positions, m.
        key : str
            The key named in errors.

        Returns
        -------
        tuple
            As :meth:`pop`.

        Raises
        ------
        InputError
            Not exactly one node, or a node that does not start where the point is.
        """
        if len(nodes) != 1:
            raise InputError(key, f"a point mass takes exactly one node, got {len(nodes)}")
        x = self.x[:, self.names.index(name)]
        if np.linalg.norm(positions[0] - x) > 1e-9 * max(1.0, np.linalg.norm(x)):
            raise InputError(
                key, f"node {nodes[0]} starts at {positions[0].tolist()} m, not at point mass {name!r} ({x.tolist()} m)"
            )
        return self.pop(name)

    def pop(self, name: str):
        """Remove a point; the others keep their state and compensation terms.

        Parameters
        ----------
        name : str
            The point.

        Returns
        -------
        tuple
            (mass in kg, position (3,) in m, velocity (3,) in m/s).
        """
        self._flush()
        self._drop_device()
        i = self._names.index(name)
        out = (float(self._masses[i]), self._x[:, i].copy(), self._v[:, i].copy())
        keep = [j for j in range(len(self._names)) if j != i]
        del self._names[i]
        self.values.pop(name, None)
        self._index = None
        self._masses = self._masses[keep]
        self._x = np.ascontiguousarray(self._x[:, keep])
        self._v = np.ascontiguousarray(self._v[:, keep])
        self._cx = np.ascontiguousarray(self._cx[:, keep])
        self._cv = np.ascontiguousarray(self._cv[:, keep])
        self._rho = np.ascontiguousarray(self._rho[keep])
        if self._wp.shape[1] == len(keep) + 1:
            self._wp = np.ascontiguousarray(self._wp[:, keep])
        return out

    def advance(
        self,
        method: str,
        gm: float,
        center: np.ndarray,
        dt: float,
        gammas: np.ndarray,
        every: int,
        nrec: int,
        max_iter: int,
        clock: tuple = (0.0, 0),
    ) -> ChunkRecords:
        """Advance all points ``nrec * every`` composed steps, recording every ``every``.

        The kernel is the one :mod:`emorbit.integrators.dispatch` names for the method,
        :attr:`roundoff` and :attr:`device`: on the CPU the packed kernels of
        :mod:`emorbit.kernels.pointmass.packed` (the same results as the reference kernels
        to round-off, leapfrog bit for bit), on all of Numba's threads from
        ``PARALLEL_MIN`` points on; a point's result does not depend on the thread count or
        on the other points. With :attr:`adaptive` set, the adaptive kernel runs instead. On
        the GPU the state stays on the device (see the module notes) and the records' arrays
        are pinned host buffers, used again only once nothing holds them.

        Parameters
        ----------
        method : str
            A name of :data:`emorbit.METHODS`.
        gm : float
            GM, m^3/s^2.
        center : array_like
            The field's centre (3,), m.
        dt : float
            The step (adaptive: the unit of the record grid), s.
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
        ChunkRecords
            The records; on a failure, the point's state stops at the failing step.
        """
        n = len(self)
        if self.under_effects():
            return self._advance_effects(method, dt, gammas, every, nrec, max_iter, clock)
        if self.adaptive is not None:
            return self._advance_adaptive(method, gm, center, dt, gammas, every, nrec, max_iter)
        if self.device == "gpu" and n:
            return self._advance_resident(method, gm, center, dt, gammas, every, nrec, max_iter)
        if self._dev is not None:  # back on the CPU: the host arrays become the state
            self._drop_device()
        rec = ChunkRecords(
            x=np.empty((nrec, 3, n)),
            v=np.empty((nrec, 3, n)),
            iterations=np.zeros((nrec, n), dtype=np.int64),
            fail=np.full((n, 2), -1, dtype=np.int64),
        )
        code, chunk = dispatch.point_chunk(method, self.roundoff, self.device, n)
        chunk(
            code,
            self.x,
            self.v,
            self.cx,
            self.cv,
            float(gm),
            np.ascontiguousarray(center, float),
            float(dt),
            np.ascontiguousarray(gammas, float),
            int(every),
            int(nrec),
            int(max_iter),
            rec.x,
            rec.v,
            rec.iterations,
            rec.fail,
        )
        return rec

    #: adaptive steps taken so far, summed over the points
    adaptive_steps: int = 0

    @property
    def roundoff(self) -> str:
        """The plan's round-off treatment (:data:`emorbit.integrators.ROUNDOFF`)."""
        return self.plan.roundoff

    @property
    def device(self) -> str:
        """The plan's device (:data:`emorbit.integrators.DEVICES`)."""
        return self.plan.device

    def under_effects(self) -> bool:
        """Whether the points move under effects beyond the central field."""
        return self.effects is not None and self.effects.effects.beyond_field()

    @property
    def wp(self) -> np.ndarray:
        """(3, n) the second-order part w of each point's last sub-step increment under effects,
        m (the next iteration starts from it, scaled by (h / :attr:`hp`)^2); zeros for new points."""
        if self._wp.shape != (3, len(self)):
            self._wp, self.hp = np.zeros((3, len(self))), np.zeros(1)
        return self._wp

    @wp.setter
    def wp(self, value) -> None:
        self._wp = np.ascontiguousarray(value, dtype=float)

    def _work_shape(self) -> tuple:
        return (self.effects.effects.work_rows() if self.under_effects() else 0, len(self))

    def coefficients(self) -> np.ndarray:
        """(k, n) each point's coefficient for each effect of the set."""
        return self.effects.coefficients(self.names, self.values)

    def _effect_run(self):
        """The points' arrays as the step kernels under effects take them."""
        from .point_effects import EffectRun

        return EffectRun(
            self.effects, self.x, self.v, self.cx, self.cv, self.wp, self.hp, self.masses, self.coefficients(),
            self.work, self.cwork, self._dense(),
        )  # fmt: skip

    def _advance_effects(self, method, dt, gammas, every, nrec, max_iter, clock) -> ChunkRecords:
        """Steps under the simulation's effects (:class:`~emorbit.bodies.point_effects.EffectRun`):
        adaptive steps of the whole set, whose control variable is ``rho[0]`` (every entry holds
        it), or fixed steps."""
        run = self._effect_run()
        n = len(self)
        rec = ChunkRecords(
            np.empty((nrec, 3, n)), np.empty((nrec, 3, n)), np.zeros((nrec, n), np.int64), np.full((n, 2), -1, np.int64)
        )
        rec.work = np.empty((nrec,) + self.work.shape)
        if self.adaptive is None:
            return run.fixed(rec, method, dt, gammas, every, nrec, max_iter, clock)
        if self.rho.shape != (n,):
            self.rho = np.zeros(n)
        rho = self.rho[:1].copy()
        rec, steps = run.adaptive(rec, method, rho, self.adaptive, dt, gammas, every, nrec, max_iter, clock)
        self.rho[:] = rho[0]
        rec.solves = steps * (len(gammas) if get_method(method).composed else 1)
        self.adaptive_steps += int(steps[:, 0].sum()) if n else 0
        return rec

    #: up to this many points under effects between pairs, each sweep solves Newton's whole
    #: system (the pair blocks between points included) instead of each point's own block: a
    #: close encounter couples two points too strongly for the block iteration to end at
    #: round-off (a binary with pericentre 19 m at dt 10 s lost 1.2e-12 of its energy)
    DENSE_MAX = 32

    def _dense(self) -> bool:
        """Whether the points' Newton sweeps solve the whole system (:attr:`DENSE_MAX`)."""
        return bool(self.effects.effects.pair_effects()) and 1 < len(self) <= self.DENSE_MAX

    def reversible_steps(self, method: str, gammas, nsteps: int, max_iter: int, t0: float = 0.0, direction=1.0):
        """Take exactly ``nsteps`` adaptive composed steps of size 1 in tau of the points under
        effects from time ``t0`` (the clock running backwards with ``direction`` -1), without
        landing: the scheme alone, for its time symmetry.

        Returns
        -------
        float
            The physical time advanced, s.

        Raises
        ------
        RuntimeError
            A step failed (its status in the message).
        """
        n = len(self)
        rho = self.rho[:1].copy() if self.rho.shape == (n,) else np.zeros(1)
        elapsed, status = self._effect_run().reversible(
            method, rho, self.adaptive, gammas, nsteps, max_iter, t0, direction
        )
        if status != 0:
            raise RuntimeError(f"an adaptive step failed with status {status}")
        self.rho = np.full(n, rho[0])
        return elapsed

    def _advance_resident(self, method, gm, center, dt, gammas, every, nrec, max_iter) -> ChunkRecords:
        """Fixed steps on the GPU with the state kept there (:mod:`emorbit.kernels.pointmass.cuda_resident`):
        uploaded at the first chunk (and again after the host arrays may have changed), records
        copied back in pinned buffers, the state only when read."""
        self._flush()
        if self._dev is None or self._dev.n != len(self):
            self._dev = dispatch.point_ensemble(self.device)(self._x, self._v, self._cx, self._cv)
        elif self._host_newer:
            self._dev.upload(self._x, self._v, self._cx, self._cv)
        self._host_newer = False
        code = dispatch.method_code(method, self.roundoff)
        out = self._dev.advance(code, gm, center, dt, gammas, every, nrec, max_iter)
        self._dev_newer = True
        return ChunkRecords(out.x, out.v, out.iterations, out.fail)

    def _advance_adaptive(self, method, gm, center, dt, gammas, every, nrec, max_iter) -> ChunkRecords:
        """Adaptive, time-symmetric steps (see :mod:`emorbit.kernels.pointmass.adaptive`) that
        land on every multiple of ``dt``, recorded every ``every * dt`` seconds."""
        n = len(self)
        steps = np.zeros((nrec, n), dtype=np.int64)
        rec = ChunkRecords(
            np.empty((nrec, 3, n)),
            np.empty((nrec, 3, n)),
            np.zeros((nrec, n), dtype=np.int64),
            np.full((n, 2), -1, dtype=np.int64),
        )
        if self.rho.shape != (n,):  # the arrays were set directly: start the control from the state
            self.rho = np.zeros(n)
        code, chunk = dispatch.adaptive_chunk(method, self.roundoff, self.device)
        chunk(
            code,
            self.x,
            self.v,
            self.cx,
            self.cv,
            self.rho,
            float(gm),
            np.ascontiguousarray(center, float),
            float(dt),
            int(every),
            float(self.adaptive),
            np.ascontiguousarray(gammas, float),
            int(nrec),
            int(max_iter),
            rec.x,
            rec.v,
            rec.iterations,
            steps,
            rec.fail,
        )
        rec.solves = steps * (len(gammas) if get_method(method).composed else 1)
        self.adaptive_steps += int(steps.sum())
        return rec

    # -- the BodySystem interface ------------------------------------------------------
    #: per-body datasets (width, unit) written to the output file
    DATASETS = {"position": (3, "m"), "velocity": (3, "m / s")}
    #: methods with a point-mass kernel
    METHODS = ("em", "midpoint", "leapfrog", "tfe")
    #: the state of fixed steps: what their checkpoints store
    BASE_FIELDS = ("x", "v", "cx", "cv")
    #: units of the state arrays beyond emorbit.io.reader.STATE_UNITS
    STATE_UNITS = {"wp": "m", "hp": "s", "work": "J", "cwork": "J"}

    @property
    def STATE_FIELDS(self) -> tuple:  # noqa: N802 (the name every body system uses)
        """The whole state: :attr:`BASE_FIELDS`; under effects the warm start ``wp``, ``hp``
        and, where an effect does work, its sums ``work``, ``cwork``; the control variables
        ``rho`` of adaptive steps."""
        effects = ("wp", "hp") if self.under_effects() else ()
        work = ("work", "cwork") if self.under_effects() and self.effects.working() else ()
        return self.BASE_FIELDS + effects + work + (("rho",) if self.adaptive is not None else ())

    def work_per_step(self) -> int:
        """Point updates per step: n, or n^2 under an effect between pairs."""
        n = len(self)
        return n * n if self.under_effects() and self.effects.effects.pair_effects() else n

    def current(self) -> ChunkRecords:
        """The current state as one record (with the work so far, where an effect does work)."""
        n = len(self)
        x, v, _, _ = self._state()
        rec = ChunkRecords(x[None].copy(), v[None].copy(), np.zeros((1, n), np.int64), np.full((n, 2), -1, np.int64))
        if self.under_effects() and self.work.shape[0]:
            rec.work = self.work[None].copy()
        return rec

    def snapshot(self):
        """Copies of x, v, cx, cv and rho (x: a device-to-device copy of the four state arrays,
        and v, cx, cv None, while the state is on the GPU), and of the effects' state."""
        self._flush()
        extra = (self.wp.copy(), self.hp.copy(), self.work.copy(), self.cwork.copy())
        if self._dev is not None and not self._host_newer:
            return (self._dev.snapshot(), None, None, None, self.rho.copy()) + extra
        return tuple(a.copy() for a in (self.x, self.v, self.cx, self.cv, self.rho)) + extra

    KICKS = True

    def kick(self, name: str, dv, key: str = "dv") -> tuple[float, np.ndarray]:
        """Add ``dv`` to a point's velocity, the rounding kept in ``cv`` (the exact velocity is
        v - cv); see :meth:`~emorbit.bodies.system.BodySystem.kick`."""
        i = self.names.index(name)
        v, cv = self.v, self.cv
        before = v[:, i].copy()
        new = before + dv
        err = (before - (new - (new - before))) + (dv - (new - before))  # two-sum: before + dv = new + err
        v[:, i], cv[:, i] = new, cv[:, i] - err
        self.v, self.cv = v, cv
        return float(self.masses[i]), before

    def restore(self, snap) -> None:
        """Put back x, v, cx, cv, rho and the effects' state from :meth:`snapshot`."""
        self.wp[...], self.hp[...], self.work[...], self.cwork[...] = snap[5:]
        if snap[1] is None:  # a snapshot on the device
            self._flush()
            self._dev.restore(snap[0])
            self._dev_newer, self._host_newer = True, False
            self.rho[...] = snap[4]
            return
        for a, s in zip((self.x, self.v, self.cx, self.cv, self.rho), snap[:5]):
            a[...] = s

    def state_arrays(self) -> dict:
        """Copies of :attr:`STATE_FIELDS` (the GPU's state downloaded first, where it is newer).

        Returns
        -------
        dict
            {name: array}, what a checkpoint stores.
        """
        x, v, cx, cv = self._state()
        current = {"x": x, "v": v, "cx": cx, "cv": cv}
        return {f: np.array(current[f] if f in current else getattr(self, f), copy=True) for f in self.STATE_FIELDS}

    def invariants(self, rec: ChunkRecords, nrec: int, gm: float, center):
        """Energy (under effects: kinetic plus every effect's potential), momentum and angular
        momentum about the field's centre of the points at each record."""
        x, v = rec.x[:nrec], rec.v[:nrec]
        if self.under_effects():
            energy = inv.kinetic_energy(self.masses, v) + sum(self.effect_energies(rec, nrec).values())
        else:
            energy = inv.energy(self.masses, x, v, gm, center)
        return energy, inv.momentum(self.masses, v), inv.angular_momentum(self.masses, x, v, center)

    def effect_energies(self, rec: ChunkRecords, nrec: int, gm: float = 0.0, center=None) -> dict:
        """Each effect's potential energy at each record ({} without effects).

        Returns
        -------
        dict
            {``potential_<label>``: (nrec,) J}.
        """
        if not self.under_effects():
            return {}
        cached = self.__dict__.get("_last_energies")  # invariants, scales and the file ask for the same
        if cached is not None and cached[0] is rec and cached[1] == nrec:
            return cached[2]
        t = None if rec.t is None else rec.t[:nrec]
        n = len(self)
        out = self.effects.potentials(rec.x[:nrec], t, self.masses, np.arange(n, dtype=np.int64), self.coefficients())
        self._last_energies = (rec, nrec, out)
        return out

    def effect_work(self, rec: ChunkRecords, nrec: int) -> dict:
        """The work of each effect that does work on all points since the run's start.

        Returns
        -------
        dict
            {``work_<label>``: (nrec,) J}; {} where no effect does work.
        """
        if rec.work is None or not self.under_effects():
            return {}
        return {f"work_{e.label}": rec.work[:nrec, k].sum(axis=1) for k, e in enumerate(self.effects.working())}

    def ledger(self, rec: ChunkRecords, nrec: int, lost: dict) -> dict:
        """The mass ledger's terms at each record (:func:`~emorbit.bodies.ledger.ledger_terms`);
        {} where the effect set has no ledger row."""
        if rec.work is None or not self.under_effects() or not self.effects.effects.ledger():
            return {}
        nk = len(self.effects.working())
        t = None if rec.t is None else rec.t[:nrec]
        coef = self.coefficients()

        def energy_at(i):
            x, v = rec.x[:nrec, :, i : i + 1], rec.v[:nrec, :, i]
            own = self.effects.potentials(
                np.ascontiguousarray(x), t, self.masses[i : i + 1], np.zeros(1, np.int64),
                np.ascontiguousarray(coef[:, i : i + 1]),
            )  # fmt: skip
            return 0.5 * self.masses[i] * np.einsum("rk,rk->r", v, v) + sum(own.values())

        rows = rec.work[:nrec]
        return ledger_terms(rows[:, :nk, :].sum(axis=1), rows[:, nk, :], lost, self.names, self.masses, energy_at)

    def invariant_scales(self, rec: ChunkRecords, nrec: int, gm: float, center) -> np.ndarray:
        """Round-off scales of the invariants at each record (:func:`~emorbit.bodies.system.roundoff_scales`)
        from the points' kinetic and potential energy, mass and sum m |x - c|^2.

        Records carry no ``stalled``: the packed and adaptive kernels accept a step only at
        their round-off tests; the rare fallback to the reference kernel's Newton iteration
        (a point whose update runs off) can stop at its floor, 1024 eps, and is not counted,
        which would need an output array in every point-mass kernel."""
        x, v = rec.x[:nrec], rec.v[:nrec]
        c = np.asarray(center, float)[:, None]
        r2 = np.einsum("...kn,...kn->...n", x - c, x - c)
        if self.under_effects():
            V = sum(np.abs(e) for e in self.effect_energies(rec, nrec).values())
        else:
            V = gm * np.einsum("...n,n->...", 1.0 / np.sqrt(r2), self.masses) if gm != 0.0 else 0.0
        moment = np.einsum("...n,n->...", r2, self.masses)
        return roundoff_scales(inv.kinetic_energy(self.masses, v), np.abs(V), self.masses.sum(), moment)

    def newton_facts(self, index: int, method: str, gm: float, center, h: float, max_iter: int):
        """The reference kernel's Newton iteration (:mod:`emorbit.kernels.pointmass.reference`) on
        the point's next step: status, its last update and the residual ``|dx - h (v + h/2 g)|``
        of its last iterate (g evaluated there), both relative to ``|dx|``; None for leapfrog and
        tfe."""
        from ..kernels import gravity
        from ..kernels.pointmass import reference

        if method in ("leapfrog", "tfe") or self.under_effects():  # no per-point account of a sweep
            return None
        x, v, c = self.x[:, index], self.v[:, index], np.asarray(center, float)
        args = (x[0], x[1], x[2], v[0], v[1], v[2], h, gm, c[0], c[1], c[2])
        d = []
        for n in (max_iter - 1, max_iter):
            if n == 0:  # the predictor
                a = c - x
                d.append((h * (v + 0.5 * h * gm * a / np.linalg.norm(a) ** 3), 0))
                continue
            out = reference.em_step(*args, n, False) if method == "em" else reference.midpoint_step(*args, n)
            d.append((np.array(out[:3]), out[7]))
        (d0, _), (d1, status) = d
        field = gravity.em_accel_points if method == "em" else gravity.midpoint_accel_points
        g = field(x[:, None].copy(), (x + d1)[:, None].copy(), gm, c)[:, 0]
        size = max(float(np.linalg.norm(d1)), 1e-300)
        residual = float(np.linalg.norm(d1 - h * (v + 0.5 * h * g))) / size
        return int(status), float(np.linalg.norm(d1 - d0)) / size, residual

    def datasets(self, rec: ChunkRecords, nrec: int, times=None, first_row: int = 0) -> dict:
        """{name: {"position": (nrec, 3) m, "velocity": (nrec, 3) m/s}}."""
        # one transposing copy each, then a contiguous (nrec, 3) view per point (a copy per
        # point cost about 2 us each, most of the driver's time per record with 1e5 points)
        x = np.ascontiguousarray(rec.x[:nrec].transpose(2, 0, 1))
        v = np.ascontiguousarray(rec.v[:nrec].transpose(2, 0, 1))
        return {n: {"position": x[i], "velocity": v[i]} for i, n in enumerate(self.names)}

    def body_datasets(self, i: int) -> dict:
        """:attr:`DATASETS`, the same for every point."""
        return self.DATASETS

    def body_attrs(self, i: int) -> dict:
        """``kind`` "point" and ``mass`` (kg)."""
        return {"kind": "point", "mass": float(self.masses[i]), "mass_unit": "kg"}

    def body_constants(self, i: int) -> dict:
        """None: a point has no fixed datasets."""
        return {}
