"""A structure's energy-momentum time finite element steps (``method = "tfe"``): Newton on the
stage velocities of :mod:`emorbit.kernels.elastic_tfe`, with the rigid bodies' axes held by
velocity constraints at the stages.

A step of k Gauss stages (order 2k) solves, for the stage velocities ``V_l`` (k, n_slots, 3)
and the rigid bodies' constraint forces ``lam_l`` (k, 6 n_rigid),

    R_l = M (V_l - v0) - h sum_j a_lj (A_j(V) - G(Q_j)^T lam_j) = 0,
    S_l = G(Q_l) V_l = 0,                    Q_l = u0 + h sum_j a_lj V_j,

``A_j`` the stage forces of :mod:`emorbit.kernels.elastic_tfe` (the elements' assumed strain
forces at the 2k - 1 point rule, the field's corrected forces at the nodes) and ``G`` the
gradient of a rigid body's six axis constraints ``g = (|d_i|^2 - 1) / 2, d_i . d_j``.

How the invariants are kept. The position path q(t) is the collocation polynomial of degree k,
``q'(c_l) = V_l``, so ``g(q(t))`` is a polynomial whose derivative ``G(q) q'`` has degree 2k - 1
and the k-point Gauss rule integrates it exactly: ``g(q1) - g(q0) = h sum_l b_l G(Q_l) V_l = 0``.
The axes stay orthonormal to round-off at the step's end. The constraint forces' work, ``h
sum_l b_l lam_l . G(Q_l) V_l``, vanishes stage by stage, so the energy is the elements' and the
field's, exact as for elastic structures alone. Their moment ``sum d_i x lam_ij d_j`` is zero
(lam symmetric), so the angular momentum is kept too. The velocities' component across the
constraints (the axes' stretching rate ``d_i . d_j' + d_j . d_i'``) is not held at zero: it is
of order k in the step and does not grow, since every step's stages meet the constraints
again. Positions, the attitude and the angular velocity converge at order 2k.

Newton's method uses the exact derivatives: the matrix ``I (x) M - h [sum_j a_lj dA_j / dV_m]``
on k x k blocks of the em step's sparse pattern, bordered by the constraints' rows and columns
(``h a_lj G(Q_j)^T``, ``G(Q_l) + h a_lm G(V_l)``, and ``h^2 sum_j a_lj a_jm lam_j`` between a
body's axes), equilibrated and factored by SuperLU at the first iterate and again when an
iteration contracts by less than 1 / :data:`SLOW`. The first guess carries the last step's mean
acceleration and constraint force (the structure's ``acc`` and ``lam``, so results do not depend
on where chunks or checkpoints fall). It stops once the update is below 4 eps of the slot's
scale (the increment, ``h v0`` and the size of the coordinates, as
:meth:`~emorbit.bodies.coupled.Structure.step` measures it). A rigid body's axes are also
weighed against its centre's scale over its size ``sqrt(tr E / m)``, what moves its points as
much: its gravity points' large forces, whose moments nearly cancel, round the axes' update
above 4 eps of the unit axes in orbit. A stall above that (the update no longer halving three
times running, below 2**20 eps) is not accepted: the step fails and the structure redoes it in
halves, so every accepted step keeps energy and momenta to round-off.
The end state is ``u1 = u0 + h sum_l b_l V_l``, ``v1 = v0 + h sum_l b_l M^-1 (A_l - G_l^T
lam_l)`` (M solved with one step of refinement).

Effects at the gravity points (:meth:`StructureTFE.effect_forces`): the kernels form the
central field; the set's other effects act at the gravity points' stage positions (MODE_EXPLICIT,
at each stage's time). Those with a potential that does not change in time (static) are scaled
per point, ``C_il (1 + nu_i P_il)`` with ``P_il = C_il . V_il``, where ``nu_i = (G_i . dx_i - h
sum_l b_l P_il) / (h sum_l b_l P_il^2)``, ``G_i`` their em force over the step (whose work is
their potential's drop exactly): each point's work is that drop, and the energy stays exact.
The others act unscaled; their work is their force's at the stages, ``sum_l h b_l N_il .
V_il``, plus the change of a potential that changes in time, so ``E1 - E0 = W`` to round-off.
Newton's matrix leaves the effects' derivatives out. Effects on surfaces are refused
(:attr:`~emorbit.bodies.coupled.Structure.POINTS_ONLY`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..kernels import elastic as kel
from ..kernels.codes import STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from ..kernels.effects.signatures import MODE_EXPLICIT, MODE_POINT, MODE_STEP
from ..kernels.elastic_tfe import assumed_strain_tables, stage_element_forces, stage_gravity_forces
from ..kernels.structure_effects import point_effects, point_effects_work, point_potentials, prepare_set
from .coupled_sparse import EquilibratedLU

__all__ = ["StructureTFE"]

_EPS = 2.220446049250313e-16
_TOL2 = (4.0 * _EPS) ** 2
_FLOOR2 = (2.0**20 * _EPS) ** 2
_STALLS = 3
#: contraction above which the matrix is formed and factored again
SLOW = 0.2
#: a rigid body's six axis constraints, as pairs of axes (em's order)
_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


class StructureTFE:
    """The tfe steps of one built structure.

    Parameters
    ----------
    st : Structure
        The structure, built; its layout arrays are read, never changed.
    tab : ndarray
        (k, 3 + 2k) Gauss table (:func:`emorbit.kernels.pointmass.tfe.tables`).
    gm : float
        The central field's GM, m^3/s^2 (0 in free space).
    center : array_like
        (3,) the field's centre, m.
    """

    def __init__(self, st, tab, gm: float, center):
        self.st = st
        self.tab = np.ascontiguousarray(tab, float)
        self.k = k = self.tab.shape[0]
        self.a = self.tab[:, 3 : 3 + k].copy()
        self.b = self.tab[:, 1].copy()
        self.rule = assumed_strain_tables(2 * k)
        self.gm = float(gm)
        self.center = np.asarray(center, float)
        ns = st.u.shape[0]
        self.n = 3 * ns
        self.nr = st.rb_slots.shape[0]
        self._ref = int(np.argmax(st.slot_pos)) if st.slot_pos.any() else -1
        self._velocity_pattern(st.J, st.J_mass)
        self._constraint_layout(st.rb_slots, st.rb_es)
        # a rigid body's axes are weighed against its centre's scale over its size sqrt(tr E / m)
        diag = st.Ms.diagonal()
        rb = np.asarray(st.rb_slots, np.int64).reshape(-1, 4)
        self._axes = rb[:, 1:].ravel()
        self._axes_centre = np.repeat(rb[:, 0], 3)
        self._axes_weight = np.repeat(diag[rb[:, 0]] / (3.0 * np.asarray(st.rb_es, float)), 3)
        nn, ng = st.node_slot.shape[0], st.gp_m.size
        self._fn = np.empty((k, nn, 3))
        self._fg = np.empty((k, ng, 3))
        self._nodata = np.zeros(0)
        self._effects_setup()
        #: each working effect's work over the last converged step, J
        self.step_work = np.zeros(len(self.row_effect))

    def _effects_setup(self) -> None:
        """Split the set's coefficients at the gravity points into the static effects' and the
        others' (the central field's row 0 in both: the kernels form it), and note each work
        row's effect where its potential changes in time (else -1)."""
        fx = self.st.fx
        static, other, self.row_effect = fx.binding.tfe_split()
        self.coef_c = np.ascontiguousarray(fx.gp_coef * static[:, None])
        self.coef_n = np.ascontiguousarray(fx.gp_coef * other[:, None])
        self.has_c = bool(np.any(self.coef_c != 0.0))
        self.has_n = bool(np.any(self.coef_n != 0.0))
        ng = self.st.gp_m.size
        self._zeros = np.zeros(ng)
        self._blocks = np.empty((ng, 3, 3))  # the points' Jacobian blocks, not asked for
        self._t0 = 0.0
        self._sk = None

    def _prepare(self, t0: float, h: float) -> None:
        """The set's scratch at each stage's time ``t0 + c_l h`` and over the step (last)."""
        self._t0 = t0
        if not (self.has_c or self.has_n):
            return
        prog, (P, I, T, S) = self.st.fx._arrays()
        sk = []
        for c in self.tab[:, 0]:
            prepare_set(prog.prepare, t0 + c * h, t0 + c * h, t0 + c * h, P, I, T, S)
            sk.append(S.copy())
        prepare_set(prog.prepare, t0, t0 + 0.5 * h, t0 + h, P, I, T, S)
        sk.append(S.copy())
        self._sk = sk

    def _at(self, coef, l, x0, x1, h, mode):
        """The effects of ``coef`` at the gravity points (relative positions (ng, 3) at both
        ends) with the scratch of stage l (the step's: l = k), N (ng, 3)."""
        st = self.st
        prog, (P, I, T, S) = st.fx._arrays()
        S[:] = self._sk[l]
        f = np.empty((st.gp_m.size, 3))
        status = point_effects(
            prog.forces, mode, x0, x1, self._origin, st.gp_m, st.gp_body, coef, h, P, I, T, S, self._zeros, f,
            self._blocks, False, True,
        )  # fmt: skip
        if status != STATUS_OK:  # Newton sees a residual that is not finite: the step fails
            f[...] = np.nan
        return f

    def effect_forces(self, Zg, Vg, h):
        """The effects' stage forces at the gravity points (k, ng, 3), N, for their stage
        increments and velocities (k, ng, 3) from ``self._xg0`` (module notes)."""
        k = self.k
        out = np.zeros(Zg.shape)
        x0 = self._xg0
        if self.has_n:
            for l in range(k):
                x = x0 + Zg[l]
                out[l] += self._at(self.coef_n, l, x, x, h, MODE_EXPLICIT)
        if self.has_c:
            C = np.stack([self._at(self.coef_c, l, x0 + Zg[l], x0 + Zg[l], h, MODE_EXPLICIT) for l in range(k)])
            P = np.einsum("lid,lid->li", C, Vg)
            dx = h * np.einsum("l,lid->id", self.b, Vg)
            G = self._at(self.coef_c, k, x0, x0 + dx, h, MODE_STEP)
            num = np.einsum("id,id->i", G, dx) - h * np.einsum("l,li->i", self.b, P)
            den = h * np.einsum("l,li->i", self.b, P * P)
            nu = np.divide(num, den, out=np.zeros_like(num), where=den > 0.0)
            out += C * (1.0 + nu[None, :] * P)[:, :, None]
        return out

    def _work(self, Zg, Vg, h) -> np.ndarray:
        """Each working effect's work over the converged step (module notes), J."""
        st = self.st
        out = np.zeros(len(self.row_effect))
        prog, (P, I, T, S) = st.fx._arrays()
        x0 = self._xg0
        full = np.zeros(st.fx.nw)
        for l in range(self.k):
            S[:] = self._sk[l]
            x = x0 + Zg[l]
            point_effects_work(
                prog.work, MODE_POINT, x, x + h * self.b[l] * Vg[l], self._origin, st.gp_m, st.gp_body, self.coef_n, h,
                P, I, T, S, full,
            )  # fmt: skip
        out += full[: out.size]
        if np.any(self.row_effect >= 0):
            x1 = x0 + h * np.einsum("l,lid->id", self.b, Vg)
            U = np.zeros((self.coef_n.shape[0], st.gp_m.size))
            for x, t, sign in ((x1, self._t0 + h, 1.0), (x0, self._t0, -1.0)):
                prepare_set(prog.prepare, t, t, t, P, I, T, S)
                point_potentials(prog.potential, x, self._origin, st.gp_m, st.gp_body, self.coef_n, P, I, T, S, U)
                for r, e in enumerate(self.row_effect):
                    if e >= 0:
                        out[r] += sign * U[e].sum()
        return out

    def _velocity_pattern(self, J, J_mass) -> None:
        """The stage matrix's velocity part: k x k blocks of the em step's pattern over the
        slots (its constraint rows and columns left out), its mass values, and the (row,
        column) of each entry for the bordered matrix."""
        n, k = self.n, self.k
        label = sp.csc_matrix((np.arange(1.0, J.data.size + 1.0), J.indices, J.indptr), shape=J.shape)[:n, :n]
        label.sort_indices()
        orig = label.data.astype(np.int64) - 1  # each slot entry's place in J's values
        nnz = orig.size
        entry = sp.csc_matrix((np.arange(1.0, nnz + 1.0), label.indices, label.indptr), shape=(n, n))
        block = sp.kron(np.arange(1.0, k * k + 1.0).reshape(k, k), sp.csc_matrix(entry.astype(bool)), format="csc")
        which = sp.kron(np.ones((k, k)), entry, format="csc")
        block.sort_indices()
        which.sort_indices()
        if not (np.array_equal(block.indices, which.indices) and np.array_equal(block.indptr, which.indptr)):
            raise RuntimeError("stage matrix pattern mismatch")
        where = (block.data.astype(np.int64) - 1) * nnz + which.data.astype(np.int64) - 1
        self._pattern = (block.indices.astype(np.int64), block.indptr.astype(np.int64))
        diag = np.zeros((k * k, nnz))
        diag[:: k + 1] = J_mass.data[orig]
        self._mass_big = diag.ravel()[where]
        self._vv_rows = block.indices.astype(np.int64)
        self._vv_cols = np.repeat(np.arange(k * n), np.diff(block.indptr))

    def _constraint_layout(self, rb_slots, rb_es) -> None:
        """Index arrays of the axis constraints: entry e pairs slot A_e with slot B_e under
        multiplier i_e, so ``G(Q)^T lam`` puts ``lam_i Q[B]`` on slot A and ``G(Q) V`` sums
        ``Q[A] . V[B]`` into row i (both orders for two different axes, one for an axis
        with itself)."""
        A, B, i = [], [], []
        for r in range(self.nr):
            for j, (p, q) in enumerate(_PAIRS):
                sp_, sq = int(rb_slots[r, 1 + p]), int(rb_slots[r, 1 + q])
                A.append(sp_), B.append(sq), i.append(6 * r + j)
                if p != q:
                    A.append(sq), B.append(sp_), i.append(6 * r + j)
        self._A = np.array(A, dtype=np.int64)
        self._B = np.array(B, dtype=np.int64)
        self._i = np.array(i, dtype=np.int64)
        self._es = np.repeat(np.asarray(rb_es, float), 6)  # constraint rows in units of the axes' inertia
        self.nc = 6 * self.nr

    def _nodes(self, s):
        """Node values (k, nn, 3) of slot values (k, ns, 3) (the maps are linear)."""
        st = self.st
        out = np.empty((s.shape[0], st.node_slot.shape[0], 3))
        for l in range(s.shape[0]):
            kel.combine_rows(s[l], st.node_slot, st.node_coef, out[l])
        return out

    def _gravity_points(self, xn):
        st = self.st
        out = np.empty((xn.shape[0], st.gp_m.size, 3))
        for l in range(xn.shape[0]):
            kel.combine_rows(xn[l], st.gp_node, st.gp_w, out[l])
        return out

    def forces(self, x0n, p0, V, h, want_J=False):
        """The stage forces (k, n_slots, 3), N, for stage velocities V (k, n_slots, 3), the
        stage increments Z (k, n_slots, 3) and, if ``want_J``, the values of Newton's matrix
        on the velocity pattern: ``I (x) M - h [sum_j a_lj dA_j / dV_m]``."""
        st = self.st
        Z = h * np.einsum("lj,jsd->lsd", self.a, V)
        # the elements see differences of nodes alone: they take the stages relative to the
        # reference slot's own motion, whose rounding (eps |h v| in orbit) would be stress noise
        move = st.slot_pos[None, :, None] * (Z[:, self._ref, None] if self._ref >= 0 else 0.0)
        turn = st.slot_pos[None, :, None] * (V[:, self._ref, None] if self._ref >= 0 else 0.0)
        Zn, Vn = self._nodes(Z - move), self._nodes(V - turn)
        fn = self._fn
        indices, indptr = self._pattern
        data = self._mass_big.copy() if want_J else self._nodata
        elements = (st.bar_node, st.bar_EA, st.bar_L, st.tet_node, st.tet_g, st.tet_V, st.tet_lam, st.tet_mu)
        maps = (st.node_slot, st.node_coef, self.n, indptr, indices, data)
        stage_element_forces(self.tab, *self.rule, h, x0n, Zn, Vn, *elements, fn, want_J, *maps)
        effects = self.has_c or self.has_n
        if (self.gm != 0.0 or effects) and st.gp_m.size:
            Zg, Vg = self._gravity_points(self._nodes(Z)), self._gravity_points(self._nodes(V))
            if self.gm != 0.0:
                stage_gravity_forces(
                    self.tab, h, self.gm, p0, Zg, Vg, st.gp_m, self._fg, want_J, st.gp_node, st.gp_w, *maps
                )
            else:
                self._fg[...] = 0.0
            if effects:
                self._fg += self.effect_forces(Zg, Vg, h)
                self._stage_points = (Zg, Vg)
            for l in range(self.k):
                kel.spread_rows(self._fg[l], st.gp_node, st.gp_w, fn[l])
        F = np.zeros(V.shape)
        for l in range(self.k):
            kel.spread_rows(fn[l], st.node_slot, st.node_coef, F[l])
        return F, Z, (data if want_J else None)

    def constraint_forces(self, Q, lam):
        """``G(Q_l)^T lam_l`` (k, n_slots, 3) for stage positions Q (k, n_slots, 3) and
        multipliers lam (k, 6 n_rigid)."""
        Fc = np.zeros(Q.shape)
        np.add.at(Fc, (slice(None), self._A), lam[:, self._i, None] * Q[:, self._B])
        return Fc

    def constraint_rates(self, Q, V):
        """``G(Q_l) V_l`` (k, 6 n_rigid), in units of the axes' inertia (kg m^2 / s)."""
        S = np.zeros((Q.shape[0], self.nc))
        np.add.at(S, (slice(None), self._i), np.sum(Q[:, self._A] * V[:, self._B], axis=2))
        return S * self._es

    def matrix(self, data, Q, V, lam, h):
        """Newton's matrix (CSC) for the unknowns ``(V, lam)``: the velocity part's values
        ``data`` bordered by the constraints' derivatives (module notes)."""
        k, n, nc, a = self.k, self.n, self.nc, self.a
        rows, cols, vals = [self._vv_rows], [self._vv_cols], [data]
        if nc:
            A, B, i = self._A, self._B, self._i
            d = np.arange(3)
            es = self._es[i]
            for l in range(k):
                for m in range(k):
                    ra = (l * n + 3 * A[:, None] + d).ravel()  # rows of slot A's components in R_l
                    # d R_l / d lam_m: h a_lm Q_m[B]
                    rows.append(ra)
                    cols.append(np.repeat(k * n + m * nc + i, 3))
                    vals.append((h * a[l, m] * Q[m][B]).ravel())
                    # d R_l / d V_m: h^2 sum_j a_lj a_jm lam_j (between slots A and B)
                    c = h * h * np.einsum("j,ji->i", a[l] * a[:, m], lam[:, i])
                    rows.append(ra)
                    cols.append((m * n + 3 * B[:, None] + d).ravel())
                    vals.append(np.repeat(c, 3))
                    # d S_l / d V_m: delta_lm Q_l[A] on slot B, h a_lm V_l[B] on slot A
                    rs = np.repeat(k * n + l * nc + i, 3)
                    rows.append(rs)
                    cols.append((m * n + 3 * A[:, None] + d).ravel())
                    vals.append((es[:, None] * h * a[l, m] * V[l][B]).ravel())
                    if l == m:
                        rows.append(rs)
                        cols.append((m * n + 3 * B[:, None] + d).ravel())
                        vals.append((es[:, None] * Q[l][A]).ravel())
        size = k * (n + nc)
        mat = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(size, size))
        mat.sum_duplicates()
        mat.sort_indices()
        return mat

    def residual(self, u0, v0, x0n, p0, V, lam, h, want_J=False):
        """The stage equations' residual ``(R, S)`` flattened, the stage increments Z (k,
        n_slots, 3) and, if ``want_J``, Newton's matrix (:meth:`matrix`), for stage velocities
        V (k, n_slots, 3) and multipliers lam (k, 6 n_rigid) from ``(u0, v0)`` (relative
        coordinates), with x0n, p0 the nodes and gravity points at u0 (p0 from the field's
        centre)."""
        st = self.st
        F, Z, data = self.forces(x0n, p0, V, h, want_J)
        Q = u0[None] + Z
        F = F - self.constraint_forces(Q, lam)
        R = np.stack([st.Mmul @ (V[l] - v0) for l in range(self.k)]) - h * np.einsum("lj,jsd->lsd", self.a, F)
        R = np.concatenate([R.ravel(), self.constraint_rates(Q, V).ravel()])
        return R, Z, (self.matrix(data, Q, V, lam, h) if want_J else None)

    def step(self, u0, v0, lam0, acc, ref, h, max_iter, t0=0.0):
        """One step from time ``t0`` (s from the epoch; module notes), with the signature and
        returns of :meth:`~emorbit.bodies.coupled.Structure.step`: ``(du, dv, iterations,
        status, stalled)``; ``acc`` (the predictor) becomes this step's mean acceleration and
        ``lam0`` its mean constraint force, and :attr:`step_work` the effects' work."""
        st = self.st
        k, n, nc = self.k, self.n, self.nc
        x0n = self._nodes(u0[None])[0]
        self._xg0 = self._gravity_points(x0n[None])[0]
        self._origin = np.asarray(ref, float)
        self._prepare(t0, h)
        p0 = self._xg0 + (np.asarray(ref, float) - self.center)
        c = self.tab[:, 0]
        V = v0[None] + h * c[:, None, None] * acc[None]
        lam = np.tile(np.asarray(lam0, float), (k, 1))
        size2 = float(np.max(np.sum(u0 * u0, axis=1) * st.slot_pos, initial=0.0))
        base2 = np.sum((h * v0) ** 2, axis=1) + np.where(st.slot_pos > 0, size2, 1.0)
        base2[self._axes] += base2[self._axes_centre] * self._axes_weight
        lu = None
        prev2 = np.inf
        stalls = 0
        status = STATUS_NO_CONVERGENCE
        it = 0
        while it < max_iter:
            it += 1
            fresh = lu is None
            R, Z, J = self.residual(u0, v0, x0n, p0, V, lam, h, fresh)
            if fresh:
                try:
                    ind32, ptr32 = J.indices.astype(np.int32), J.indptr.astype(np.int32)
                    lu = EquilibratedLU(J.data, J.indices.astype(np.int64), J.indptr.astype(np.int64), J.shape[0],
                                        ind32, ptr32)  # fmt: skip
                except RuntimeError:  # singular
                    status = STATUS_SINGULAR
                    break
                st.factorizations += 1
            delta = lu.solve(R)
            dV = delta[: k * n].reshape(V.shape)
            V = V - dV
            lam = lam - delta[k * n :].reshape(k, nc)
            d2 = float(np.max(np.sum((h * dV) ** 2, axis=2) / (base2[None] + np.sum(Z * Z, axis=2))))
            if not np.isfinite(d2):
                status = STATUS_SINGULAR
                break
            if d2 <= _TOL2:
                status = STATUS_OK
                break
            # a stall near round-off (the update no longer halves, three times in a row, below
            # 2**20 eps) is not accepted: the step is redone in halves, where Newton reaches it
            stalls = stalls + 1 if d2 >= 0.25 * prev2 else 0
            if stalls >= _STALLS and d2 <= _FLOOR2:
                break
            if d2 > SLOW**2 * prev2:
                lu = None
            prev2 = d2
        if status != STATUS_OK:
            return np.zeros_like(u0), np.zeros_like(v0), it, status, False
        F, Z, _ = self.forces(x0n, p0, V, h)
        if self.step_work.size and self.has_n:
            self.step_work = self._work(*self._stage_points, h)
        F = F - self.constraint_forces(u0[None] + Z, lam)
        du = h * np.einsum("l,lsd->sd", self.b, V)
        dv = h * sum(self.b[l] * st.solve_mass(F[l]) for l in range(k))
        acc[:] = dv / h
        lam0[:] = self.b @ lam
        return du, dv, it, status, False
