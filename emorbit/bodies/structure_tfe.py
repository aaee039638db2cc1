"""A structure's energy-momentum time finite element steps (``method = "tfe"``): Newton on the
stage velocities of :mod:`emorbit.kernels.elastic_tfe`.

A step of k Gauss stages (order 2k) solves, for the stage velocities ``V_l`` (k, n_slots, 3),

    R_l = M (V_l - v0) - h sum_j a_lj A_j(V) = 0,

``A_j`` the stage forces of :mod:`emorbit.kernels.elastic_tfe` (the elements' assumed strain
forces at the 2k - 1 point rule, the field's corrected forces at the nodes), by Newton's method
with their exact derivatives: the matrix ``I (x) M - h [sum_j a_lj dA_j / dV_m]_lm`` on k x k
blocks of the em step's sparse pattern, factored by SuperLU at the first iterate and again when
an iteration contracts by less than 1 / :data:`SLOW`. The first guess carries the last step's
mean acceleration (the structure's ``acc``, so results do not depend on where chunks or
checkpoints fall). It stops once the update is below 4 eps of the slot's scale (the increment,
``h v0`` and the size of the coordinates, as :meth:`~emorbit.bodies.coupled.Structure.step`
measures it). A stall above that (the update no longer halving three times running, below
2**20 eps) is not accepted: the step fails and the structure redoes it in halves, so every
accepted step keeps energy and momenta to round-off. The end state is ``u1 = u0 + h sum_l b_l
V_l``, ``v1 = v0 + h sum_l b_l M^-1 A_l`` (M solved with one step of refinement).

Structures of elastic bodies and point masses, in the central field or in free space: a rigid
body's axes would need their constraints at the stages, and other effects their stage forces
(both are refused, by :meth:`~emorbit.bodies.coupled.Structure.check_method` and
:attr:`~emorbit.bodies.coupled.Structure.FIELD_ONLY`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..kernels import elastic as kel
from ..kernels.codes import STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from ..kernels.elastic_tfe import assumed_strain_tables, stage_element_forces, stage_gravity_forces

__all__ = ["StructureTFE"]

_EPS = 2.220446049250313e-16
_TOL2 = (4.0 * _EPS) ** 2
_FLOOR2 = (2.0**20 * _EPS) ** 2
_STALLS = 3
#: contraction above which the matrix is formed and factored again
SLOW = 0.2


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
        self.k = self.tab.shape[0]
        self.a = self.tab[:, 3 : 3 + self.k].copy()
        self.b = self.tab[:, 1].copy()
        self.rule = assumed_strain_tables(2 * self.k)
        self.gm = float(gm)
        self.center = np.asarray(center, float)
        self.n = 3 * st.u.shape[0]
        if st.J.shape[0] != self.n:
            raise ValueError("a structure with rigid bodies has no tfe step")
        # the stage matrix's pattern: k x k blocks of the em step's; (block, entry) of each value
        nnz, k = st.J.data.size, self.k
        entry = sp.csc_matrix((np.arange(1.0, nnz + 1.0), st.J.indices, st.J.indptr), shape=st.J.shape)
        block = sp.kron(np.arange(1.0, k * k + 1.0).reshape(k, k), sp.csc_matrix(entry.astype(bool)), format="csc")
        which = sp.kron(np.ones((k, k)), entry, format="csc")
        block.sort_indices()
        which.sort_indices()
        if not (np.array_equal(block.indices, which.indices) and np.array_equal(block.indptr, which.indptr)):
            raise RuntimeError("stage matrix pattern mismatch")
        where = (block.data.astype(np.int64) - 1) * nnz + which.data.astype(np.int64) - 1
        self._pattern = (block.indices, block.indptr)
        # the mass on the diagonal blocks, in the stage matrix's values
        diag = np.zeros((k * k, nnz))
        diag[:: k + 1] = st.J_mass.data
        self._mass_big = diag.ravel()[where]
        nn, ng = st.node_slot.shape[0], st.gp_m.size
        self._fn = np.empty((self.k, nn, 3))
        self._fg = np.empty((self.k, ng, 3))
        self._nodata = np.zeros(0)

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
        stage increments Z (k, n_slots, 3) and, if ``want_J``, Newton's matrix (CSC, k x k
        blocks of 3 n_slots): ``I (x) M - h [sum_j a_lj dA_j / dV_m]``."""
        st = self.st
        Z = h * np.einsum("lj,jsd->lsd", self.a, V)
        Zn, Vn = self._nodes(Z), self._nodes(V)
        fn = self._fn
        indices, indptr = self._pattern
        data = self._mass_big.copy() if want_J else self._nodata
        elements = (st.bar_node, st.bar_EA, st.bar_L, st.tet_node, st.tet_g, st.tet_V, st.tet_lam, st.tet_mu)
        maps = (st.node_slot, st.node_coef, self.n, indptr, indices, data)
        stage_element_forces(self.tab, *self.rule, h, x0n, Zn, Vn, *elements, fn, want_J, *maps)
        if self.gm != 0.0 and st.gp_m.size:
            Zg, Vg = self._gravity_points(Zn), self._gravity_points(Vn)
            stage_gravity_forces(
                self.tab, h, self.gm, p0, Zg, Vg, st.gp_m, self._fg, want_J, st.gp_node, st.gp_w, *maps
            )
            for l in range(self.k):
                kel.spread_rows(self._fg[l], st.gp_node, st.gp_w, fn[l])
        F = np.zeros(V.shape)
        for l in range(self.k):
            kel.spread_rows(fn[l], st.node_slot, st.node_coef, F[l])
        J = sp.csc_matrix((data, indices, indptr), shape=(self.k * self.n,) * 2) if want_J else None
        return F, Z, J

    def step(self, u0, v0, acc, ref, h, max_iter):
        """One step (module notes), with the signature and returns of
        :meth:`~emorbit.bodies.coupled.Structure.step`: ``(du, dv, iterations, status,
        stalled)``; ``acc`` (the predictor) becomes this step's mean acceleration."""
        st = self.st
        k = self.k
        x0n = self._nodes(u0[None])[0]
        p0 = self._gravity_points(x0n[None])[0] + (np.asarray(ref, float) - self.center)
        c = self.tab[:, 0]
        V = v0[None] + h * c[:, None, None] * acc[None]
        size2 = float(np.max(np.sum(u0 * u0, axis=1) * st.slot_pos, initial=0.0))
        base2 = np.sum((h * v0) ** 2, axis=1) + np.where(st.slot_pos > 0, size2, 1.0)
        lu = None
        prev2 = np.inf
        stalls = 0
        status = STATUS_NO_CONVERGENCE
        it = 0
        while it < max_iter:
            it += 1
            fresh = lu is None
            F, Z, J = self.forces(x0n, p0, V, h, fresh)
            R = np.stack([st._Mmul @ (V[l] - v0) for l in range(k)]) - h * np.einsum("lj,jsd->lsd", self.a, F)
            if fresh:
                try:
                    lu = spla.splu(J)
                except RuntimeError:  # singular
                    status = STATUS_SINGULAR
                    break
                st.factorizations += 1
            dV = lu.solve(R.ravel()).reshape(V.shape)
            V = V - dV
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
        F, _, _ = self.forces(x0n, p0, V, h)
        du = h * np.einsum("l,lsd->sd", self.b, V)
        dv = h * sum(self.b[l] * st._solve_mass(F[l]) for l in range(k))
        acc[:] = dv / h
        return du, dv, it, status, False
