"""Coupled structures: elastic bodies (bars, tetrahedra), the rigid bodies and point masses they
are attached to, integrated together with the energy-momentum method.

Unknowns are 3-vector *slots* (see :mod:`emorbit.kernels.elastic`): FE nodes, point masses,
and each rigid body's centre of mass and axes (12 numbers, with 6 orthonormality
constraints). Coupling is exact and linear: a node attached to a rigid body is the material
point ``phi + X^k d_k`` of that body, so its forces reach the body through the same map
(the "coupling conditions"); a node attached to a point mass is that point mass.

One step of size h solves, for the increments ``du`` and the constraint impulses ``nu``,

    R1 = M du - h (M v0 + (h/2) F(u0, u0 + du)) + (h/2) G(u05)^T nu = 0
    R2 = g(u0 + du) = 0

by Newton's method on a sparse Jacobian whose pattern is built once; the values are filled
by Numba kernels (:mod:`emorbit.kernels.coupled`) and the system, equilibrated, is solved
with SuperLU (scipy.sparse.linalg.splu). The velocity follows from
``M dv = h F - G(u05)^T nu`` with F at the final iterate, M solved through its factorisation
with one step of iterative refinement: a fixed rounded inverse of M would make the same
error in every step, which adds up as a drift instead of a random walk. A step that fails
is redone in two halves, down to 2**MAX_SPLIT sub-steps.

The simulation's effects act at the structure's gravity points, between the mass points of
different bodies (an effect between pairs, such as mutual gravity, makes bodies that are not
all point masses one structure, attached or not) and on its surfaces
(:mod:`emorbit.bodies.coupled_effects`): each point's own 3 x 3 block of their Jacobian joins
the matrix, and the blocks between bodies stay out (the pattern stays that of the bodies
alone; the iteration converges on those couplings at the rate h^2/2 |dF/dx| per iteration).
What a structure records is :mod:`emorbit.bodies.coupled_output`.
"""

from __future__ import annotations

import numpy as np

from ..integrators.dispatch import method_code
from ..integrators.plan import Plan
from ..kernels import coupled as kc
from ..kernels import elastic as kel
from ..kernels.codes import METHOD_TFE, STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from .coupled_adaptive import StructureAdaptive
from .coupled_effects import StructureEffects
from .coupled_layout import StructureLayout
from .coupled_output import StructureRecords
from .coupled_sparse import EquilibratedLU, KeptFactors

__all__ = ["Structure", "StructureRecords"]

_EPS = 2.220446049250313e-16
_TOL2 = (4.0 * _EPS) ** 2
_FLOOR2 = (2.0**20 * _EPS) ** 2  # a stall (see Structure.step) is accepted only below 2**20 eps |scale|
_STALLS = 3  # iterations in a row without progress that make a stall


class Structure(StructureAdaptive, StructureLayout):
    """A coupled structure of elastic bodies, rigid bodies and point masses: one system.

    Bodies are added, attachments declared, then :meth:`build` lays out the slots and the
    Jacobian's pattern before the first step; nothing can be added after that.

    Parameters
    ----------
    newton : str
        ``"full"`` refactors the Jacobian at every iteration (Newton's method proper,
        quadratic convergence); ``"reuse"`` keeps the sparse LU factors (one set per
        distinct sub-step) across iterations and steps, and renews them when an iteration
        contracts by less than 1 / :attr:`SLOW`, when an update made with them raises the
        residual, or at the start of a step when the last one needed more than 4
        iterations; ``"auto"`` (default) is ``"full"`` below :attr:`AUTO_FULL` unknowns and
        ``"reuse"`` above. All iterate to round-off; they differ in cost and robustness:
        reusing factors saves most of the work per step on large structures and needs more
        iterations on stiff, ill-conditioned ones (``emorbit bench --only elastic``
        measures the cost per step against size). Kept factors are state: checkpoints store
        them (:meth:`state_arrays`), so results do not depend on where checkpoints fall.

    Attributes
    ----------
    newton : str
        The mode in use (``"auto"`` resolved by :meth:`build`).
    factorizations : int
        LU factorisations so far.
    retries_total : int
        Steps that were redone in sub-steps.
    bodies : list of dict
        The bodies: name, kind, slots or nodes, and what their output needs.
    """

    kind = "structure"
    #: methods with a structure kernel
    METHODS = ("em", "midpoint", "tfe")
    #: methods whose steps take effects at the gravity points only, not on surfaces
    #: (:class:`~emorbit.bodies.structure_tfe.StructureTFE`)
    POINTS_ONLY = ("tfe",)
    #: the state of every structure
    BASE_FIELDS = ("u", "v", "cu", "cv", "lam", "acc")
    #: units of the state arrays beyond emorbit.io.reader.STATE_UNITS
    STATE_UNITS = {"work": "J", "cwork": "J"}
    #: the state that effects doing work add: their work so far and its compensation
    WORK_FIELDS = ("work", "cwork")
    NEWTON = ("auto", "reuse", "full")
    #: unknowns from which "auto" reuses factors
    AUTO_FULL = 500
    #: contraction (|update_k| / |update_k-1|) above which the factors are renewed
    SLOW = 0.2

    def __init__(self, plan: Plan | None = None):
        self.plan = Plan() if plan is None else plan
        self.newton = self.plan.newton  # "auto" becomes "full" or "reuse" when the structure is built
        self.retries_step = 0
        self.retries_total = 0  # failed steps that were redone in sub-steps
        self._kept = KeptFactors()  # "reuse" mode's factors and iteration counts: state, in checkpoints
        self.factorizations = 0
        self.bodies: list[dict] = []  # name, kind, slot/node ranges, output info
        self._pending: list = []  # elastic bodies added, laid out when the structure is built
        self._attach: list = []  # (elastic body, its nodes, the body they ride on)
        self._node_mass_terms: list = []  # mass coupling of attached nodes (built with the layout)
        self._slot_mass_blocks: list[tuple] = []  # (slot indices, scalar mass matrix)
        self._slot_kind: list[int] = []  # 1 for position-type slots, 0 for director slots
        self._u: list[np.ndarray] = []
        self._v: list[np.ndarray] = []
        self._node_slot: list[list[int]] = []
        self._node_coef: list[list[float]] = []
        self._bars, self._bar_EA, self._bar_L = [], [], []
        self._tets, self._tet_g, self._tet_V, self._tet_lam, self._tet_mu = [], [], [], [], []
        self._gp = []  # (nodes, weights, mass)
        self._rb_slots: list[list[int]] = []
        self._rb_es: list[float] = []
        self._rb_omega: list[np.ndarray] = []
        self._built = False
        self.effects = None  # the simulation's EffectBinding, set by the simulation
        self.values: dict[str, dict] = {}  # {name: {body key: SI value}} of the effects' body keys
        self.fx: StructureEffects | None = None  # the effects on the built structure
        self.work = np.zeros(0)  # the work of each effect that does work since the run's start, J
        self.cwork = np.zeros(0)
        self.rho = np.zeros(1)  # adaptive steps' control variable, 1/s (0: set from the state)

    @property
    def STATE_FIELDS(self) -> tuple:  # noqa: N802 (the name every body system uses)
        """The whole state: :attr:`BASE_FIELDS`, the work sums where an effect does work, and
        the control variable ``rho`` of adaptive steps."""
        work = self.WORK_FIELDS if self._working() else ()
        return self.BASE_FIELDS + work + (("rho",) if self.adaptive is not None else ())

    def _working(self) -> list:
        """The effects whose work the step sums (none before the structure joins a simulation)."""
        return self.effects.working() if self.effects is not None else []

    # -- stepping ------------------------------------------------------------------------------
    def work_per_step(self) -> int:
        """Slots, elements and gravity points touched per step (and pairs of mass points)."""
        pairs = self.mp_m.size**2 // 2 if self.fx is not None and self.fx.any_pairs else 0
        return int(20 * (self.u.shape[0] + self.tet_node.shape[0] + self.gp_m.size) + pairs)

    def _nodes_at(self, u0, u1):
        x0n = np.empty((self.node_slot.shape[0], 3))
        x1n = np.empty_like(x0n)
        kel.combine_rows(u0, self.node_slot, self.node_coef, x0n)
        kel.combine_rows(u1, self.node_slot, self.node_coef, x1n)
        return x0n, x1n

    def _element_forces(self, code, u0, u1):
        """The elements' generalised forces alone at u0 -> u1, (n_slots, 3) N."""
        x0n, x1n = self._nodes_at(u0, u1)
        F = np.empty_like(u0)
        elements = (self.bar_node, self.bar_EA, self.bar_L, self.tet_node, self.tet_g, self.tet_V, self.tet_lam)
        kc.fill_forces(
            code, 0.0, x0n, x1n, self.node_slot, self.node_coef, *elements, self.tet_mu, False, self.J.indptr,
            self.J.indices, self._nodata, F, self._fn, self._kb, self._kt,
        )  # fmt: skip
        return F

    def _forces(self, code, u0, u1, ref, h, with_jacobian: bool, first: bool = True):
        """The generalised forces over the step u0 -> u1 (relative to ``ref``) and, if
        ``with_jacobian``, the Jacobian's values: (status, F (n_slots, 3), data)."""
        x0n, x1n = self._nodes_at(u0, u1)
        data = self.J_mass.data.copy() if with_jacobian else self._nodata
        F = np.empty_like(u0)
        hf = 0.5 * h
        elements = (self.bar_node, self.bar_EA, self.bar_L, self.tet_node, self.tet_g, self.tet_V, self.tet_lam)
        status = kc.fill_forces(
            code, hf * h, x0n, x1n, self.node_slot, self.node_coef, *elements, self.tet_mu, with_jacobian,
            self.J.indptr, self.J.indices, data, F, self._fn, self._kb, self._kt,
        )  # fmt: skip
        if self.fx.active():
            st = self.fx.forces(code, x0n, x1n, u0, u1, ref, h, F, data if with_jacobian else None, first)
            if st != STATUS_OK:
                status = st
        return status, F, data

    def solve_mass(self, b):
        """M x = b for (n_slots, 3) b with one step of iterative refinement."""
        x = self.Ms_lu.solve(b)
        r = b - self.Mmul @ x
        return x + self.Ms_lu.solve(r)

    def relative(self, u, cu):
        """The compensated state with the position slots taken relative to a reference point.

        Internal forces depend on coordinate differences only, so this keeps them precise to
        eps times the body's size however far from the origin the body is (absolute
        coordinates of 7e6 m would limit a 0.2 m element's strain to ~1e-8 and feed stress
        noise into stiff modes every step).

        Parameters
        ----------
        u, cu : ndarray
            (n_slots, 3) state and its compensation terms.

        Returns
        -------
        urel : ndarray
            (n_slots, 3) ``u - cu`` with ``ref`` subtracted from the position slots.
        ref : ndarray
            (3,) the first position slot's value, m (zero without position slots).
        """
        ref = u[int(np.argmax(self.slot_pos))] * (1.0 if self.slot_pos.any() else 0.0)
        return (u - ref[None, :] * self.slot_pos[:, None]) - cu, ref

    def step(self, code: int, u0, v0, lam, acc, ref, h, max_iter, t0=0.0):
        """One step of the energy-momentum (or midpoint) scheme by Newton's method.

        Parameters
        ----------
        code : int
            The method code.
        u0, v0 : ndarray
            (n_slots, 3) start state in relative coordinates (:meth:`relative`).
        lam : ndarray
            (6 n_rigid,) constraint forces, the warm start; updated in place.
        acc : ndarray
            (n_slots, 3) the last step's mean acceleration, the predictor; updated in place.
        ref : ndarray
            (3,) the reference point of the relative coordinates (:meth:`relative`), m.
        h : float
            The step, s.
        max_iter : int
            Newton iterations at most.
        t0 : float
            The step's start, s from the epoch (the time finite element's stages read the
            effects at their own times; em's set is prepared by the caller).

        Returns
        -------
        tuple
            (du, dv, iterations, status, stalled): the increments of position and velocity,
            the iterations taken, a ``STATUS_*`` code of :mod:`emorbit.kernels.codes`, and
            whether the iteration was accepted at a stall (its last update above the
            round-off tolerance, below the floor) rather than at round-off.
        """
        if code == METHOD_TFE:
            return self._tfe.step(u0, v0, lam, acc, ref, h, max_iter, t0)
        ns = u0.shape[0]
        nr = self.rb_slots.shape[0]
        hf = 0.5 * h
        Mv0 = self.Mmul @ v0
        du = h * (v0 + hf * acc)  # predictor: the last step's mean acceleration
        nu = h * lam
        # round-off scale per slot: the increment, h v0, and the size of the coordinates (node
        # forces depend on absolute coordinates, so an increment is only defined to eps |u|:
        # the largest position for position slots, 1 for a rigid body's unit axes)
        size2 = float(np.max(np.sum(u0 * u0, axis=1) * self.slot_pos, initial=0.0))
        base2 = np.sum((h * v0) ** 2, axis=1) + np.where(self.slot_pos > 0, size2, 1.0)
        prev2 = np.inf
        status = STATUS_NO_CONVERGENCE
        it = 0
        n = 3 * ns + 6 * nr
        key = self.factor_key(h)
        lu = None if self.newton == "full" or self._kept.its.get(key, 0) > 4 else self._kept.lus.get(key)
        back = None  # (du, nu, residual) before an update made with reused factors
        prev_r = np.inf
        stalls = 0
        stalled = False
        self.residuals = []  # equilibrated residual norm at each iterate of this step (diagnostics)
        while it < max_iter:
            it += 1
            u1 = u0 + du
            u05 = u0 + 0.5 * du
            fresh = lu is None
            st, F, data = self._forces(code, u0, u1, ref, h, fresh, it == 1)
            if st != STATUS_OK:
                status = st
                break
            R1 = (self.Mmul @ du - h * (Mv0 + hf * F)).ravel()
            R2 = np.zeros(6 * nr)
            if nr:
                kc.fill_constraints(
                    self.rb_slots,
                    u05,
                    u1,
                    nu,
                    self.rb_es,
                    hf,
                    fresh,
                    self.J.indptr,
                    self.J.indices,
                    data,
                    R1,
                    R2,
                    3 * ns,
                )
            if fresh:
                try:
                    lu = EquilibratedLU(data, self.J.indices, self.J.indptr, n, self._indices32, self._indptr32)
                except RuntimeError:  # singular
                    break
                self.factorizations += 1
                if self.newton == "reuse":
                    self._kept.keep(key, lu, data)
            R = np.concatenate([R1, R2])
            rnorm = lu.norm(R)
            if back is not None and rnorm > back[2]:
                # the reused factors made things worse: return to the last iterate, renew them
                du, nu, _ = back
                back = None
                lu = None
                prev_r = np.inf
                continue
            back = (du, nu, rnorm) if not fresh else None
            rflat = rnorm >= 0.5 * prev_r  # the residual no longer falls
            prev_r = rnorm
            self.residuals.append(rnorm)
            delta = lu.solve(R)
            dd = delta[: 3 * ns].reshape(ns, 3)
            du = du - dd
            nu = nu - delta[3 * ns :]
            d2 = float(np.max(np.sum(dd * dd, axis=1) / (base2 + np.sum(du * du, axis=1))))
            if not np.isfinite(d2):
                status = STATUS_SINGULAR
                break
            # a stall: neither the update nor the residual falls by 2x. Three in a row, with the
            # update below 2.3e-10 of its scale, is the round-off floor of an ill-conditioned
            # system (a stiff, clamped boom sits at ~4e-13 for dozens of iterations); a single
            # one is not (Newton cycling on a stiff bar stalls once at 5 mm, then moves on).
            stalls = stalls + 1 if (d2 >= 0.25 * prev2 and rflat) else 0
            if d2 <= _TOL2 or (stalls >= _STALLS and d2 <= _FLOOR2):
                status = STATUS_OK
                stalled = d2 > _TOL2
                break
            if self.newton == "full" or (not fresh and d2 > self.SLOW**2 * prev2):
                lu = None  # renew the factors at the next iterate
            prev2 = d2
        self._kept.its[key] = it
        if status != STATUS_OK:
            self._kept.drop(key)
            return du, np.zeros_like(du), it, status, False
        u1 = u0 + du
        u05 = u0 + 0.5 * du
        st, F, _ = self._forces(code, u0, u1, ref, h, False, False)
        gen = h * F
        pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
        for r in range(nr):
            for j, (k, l) in enumerate(pairs):
                sk, sl = self.rb_slots[r, 1 + k], self.rb_slots[r, 1 + l]
                gen[sk] -= nu[6 * r + j] * u05[sl]
                if k != l:
                    gen[sl] -= nu[6 * r + j] * u05[sk]
        dv = self.solve_mass(gen)
        lam[:] = nu / h
        acc[:] = dv / h
        return du, dv, it, status, stalled

    def advance(self, method, gm, center, dt, gammas, every, nrec, max_iter, clock=(0.0, 0)) -> StructureRecords:
        """Advance the structure ``nrec * every`` composed steps, recording every ``every``.

        Parameters
        ----------
        method : str
            ``"em"`` or ``"midpoint"``.
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
        StructureRecords
            The records; after a failure the state is that before the failing step.
        """
        ns = self.u.shape[0]
        self._scratch()
        code, gammas = self.method_setup(method, gm, center, gammas)
        rec = StructureRecords(
            np.empty((nrec, ns, 3)),
            np.empty((nrec, ns, 3)),
            np.zeros((nrec, 1), np.int64),
            np.full((1, 2), -1, np.int64),
            np.zeros((nrec, 1), np.int64),
        )
        c = np.asarray(center, float)
        self.fx.begin()
        nw = self.work.size
        rec.work = np.empty((nrec, nw)) if nw else None
        if self.adaptive is not None:
            rec.solves = np.zeros((nrec, 1), np.int64)
            self.advance_adaptive(code, gm, c, dt, every, gammas, nrec, max_iter, rec, clock)
            return rec
        for r in range(nrec):
            its = stl = 0
            for s in range(every):
                u, v, cu, cv = self.u.copy(), self.v.copy(), self.cu.copy(), self.cv.copy()
                lam, acc = self.lam.copy(), self.acc.copy()
                state = (u, v, cu, cv, lam, acc, self.work.copy(), self.cwork.copy())
                ok = True
                starts = clock_times(clock, dt, gammas, r * every + s)
                for g, t0 in zip(gammas, starts):
                    status, its_g, stl_g = self._substeps(code, dt * g, state, max_iter, 0, t0)
                    its += its_g
                    stl += stl_g
                    if status != STATUS_OK:
                        ok = False
                        break
                if not ok:
                    rec.fail[0] = (r * every + s, status)
                    return rec
                self.u, self.v, self.cu, self.cv, self.lam, self.acc = u, v, cu, cv, lam, acc
                self.work, self.cwork = state[6], state[7]
                self.retries_total += self.retries_step
                self.retries_step = 0
            rec.u[r] = self.u
            rec.v[r] = self.v
            if rec.work is not None:
                rec.work[r] = self.work
            rec.iterations[r, 0] = its
            rec.stalled[r, 0] = stl
        return rec

    def method_setup(self, method: str, gm: float, center, gammas) -> tuple:
        """The method's code and the sub-steps of its composed step: the composition's, or
        for ``"tfe"`` one step of the Gauss stages its order says
        (:class:`~emorbit.bodies.structure_tfe.StructureTFE`, set up here)."""
        if method != "tfe":
            return method_code(method), gammas
        from ..integrators.dispatch import tfe_tables
        from .structure_tfe import StructureTFE

        self._tfe = StructureTFE(self, tfe_tables(gammas), gm, center)
        return METHOD_TFE, np.ones(1)

    #: how often a failed step may be halved (2**MAX_SPLIT sub-steps at most)
    MAX_SPLIT = 4

    def _substeps(self, code, h, state, max_iter, depth, t0=0.0):
        """Advance ``state`` = (u, v, cu, cv, lam, acc, work, cwork) (arrays updated in place)
        by one step of size h from time ``t0``; a step whose Newton iteration fails is retried
        as two steps of h/2, down to 2**MAX_SPLIT sub-steps. Every sub-step is an
        energy-momentum step, so conservation is untouched (and the effects' work is summed).
        Returns (status, iterations, sub-steps accepted at a stall)."""
        u, v, cu, cv, lam, acc = state[:6]
        saved = tuple(a.copy() for a in state)
        urel, ref = self.relative(u, cu)
        self.fx.prepare(t0, t0 + 0.5 * h, t0 + h)
        du, dv, it, status, stalled = self.step(code, urel, v, lam, acc, ref, h, max_iter, t0)
        if status == STATUS_OK:
            u2, cu2 = _kahan(u, cu, du)
            v2, cv2 = _kahan(v, cv, dv)
            if np.all(np.isfinite(u2)) and np.all(np.isfinite(v2)):
                if state[6].size:  # the work of the converged step
                    if code == METHOD_TFE:
                        w = self._tfe.step_work
                    else:
                        x0n, x1n = self._nodes_at(urel, urel + du)
                        w = self.fx.work(code, x0n, x1n, urel, urel + du, ref, h)
                    state[6][...], state[7][...] = _kahan(state[6], state[7], w)
                u[...], cu[...], v[...], cv[...] = u2, cu2, v2, cv2
                return status, it, int(stalled)
            status = STATUS_SINGULAR
        for a, b in zip(state, saved):
            a[...] = b
        if depth >= self.MAX_SPLIT or status == STATUS_SINGULAR:
            return status, it, 0
        self.retries_step += 1
        total, stl = it, 0
        for half in range(2):
            status, k, n = self._substeps(code, 0.5 * h, state, max_iter, depth + 1, t0 + half * 0.5 * h)
            total += k
            stl += n
            if status != STATUS_OK:
                for a, b in zip(state, saved):
                    a[...] = b
                return status, total, 0
        return status, total, stl

    def _scratch(self) -> None:
        nb, nt = self.bar_node.shape[0], self.tet_node.shape[0]
        self._fn = np.empty((self.node_slot.shape[0], 3))
        self._kb = np.empty((nb, 3, 3))
        self._kt = np.empty((nt, 4, 4, 3, 3))
        self._nodata = np.zeros(self.J.data.size)

    def reset_work(self) -> None:
        """Start the work sums at 0 (a new run; a resumed run restores them instead)."""
        self.work = np.zeros(len(self._working()))
        self.cwork = np.zeros(len(self._working()))

    def effect_work(self, rec, nrec: int) -> dict:
        """The work of each effect that does work on the structure since the run's start:
        {``work_<label>``: (nrec,) J}; {} without such effects."""
        if rec.work is None:
            return {}
        return {f"work_{e.label}": rec.work[:nrec, k].copy() for k, e in enumerate(self._working())}

    def current(self) -> StructureRecords:
        """The current state as one record (with the effects' work so far)."""
        z = np.zeros((1, 1), np.int64)
        work = self.work[None].copy() if self.work.size else None
        return StructureRecords(
            self.u[None].copy(), self.v[None].copy(), z, np.full((1, 2), -1, np.int64), z.copy(), work
        )

    def snapshot(self):
        """Copies of u, v, cu, cv, lam, acc, rho, of the kept factors (:class:`KeptFactors`) and
        of the work sums."""
        state = tuple(a.copy() for a in (self.u, self.v, self.cu, self.cv, self.lam, self.acc, self.rho))
        return state + (self._kept.copy(), self.work.copy(), self.cwork.copy())

    def restore(self, snap) -> None:
        """Put back the state of :meth:`snapshot`, kept factors and work sums included."""
        self.u, self.v, self.cu, self.cv, self.lam, self.acc, self.rho = (a.copy() for a in snap[:7])
        self._kept = snap[7].copy()
        self.work, self.cwork = snap[8].copy(), snap[9].copy()

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The arrays of :attr:`STATE_FIELDS` and, in "reuse" mode, the kept factors as the
        Jacobian values they were made from (``lu_steps``, ``lu_jacobians``,
        ``last_iterations``: see :class:`~emorbit.bodies.coupled_sparse.KeptFactors`), so that
        a run gives the same bits wherever its checkpoints fall."""
        out = super().state_arrays()
        if self.newton == "reuse":
            out.update(self._kept.arrays(self.J.data.size))
        return out

    def set_state_arrays(self, arrays: dict) -> None:
        """Restore :meth:`state_arrays`; kept Jacobians are factored again (missing ones: none kept).

        Raises
        ------
        InputError
            An array is missing or does not match the structure (key ``checkpoint``).
        """
        super().set_state_arrays(arrays)
        self._kept = KeptFactors()
        if self.newton == "reuse":
            n = 3 * self.u.shape[0] + 6 * self.rb_slots.shape[0]
            self._kept.load(
                arrays,
                self.J.data.size,
                lambda d: EquilibratedLU(d, self.J.indices, self.J.indptr, n, self._indices32, self._indptr32),
            )


def _kahan(s, c, d):
    y = d - c
    t = s + y
    return t, (t - s) - y


def clock_times(clock, dt: float, gammas, step: int) -> list:
    """The start of each sub-step of chunk step ``step`` (s from the epoch): the composition's
    partial sums, as the point-mass and rigid kernels take them."""
    j = float(clock[1]) + step
    out, acc = [], 0.0
    for k, g in enumerate(gammas):
        out.append(float(clock[0]) + (j + acc if k > 0 else j) * dt)
        acc += g
    return out
