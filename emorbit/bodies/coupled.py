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
is redone in two halves, down to 2**MAX_SPLIT sub-steps. What a structure records is
:mod:`emorbit.bodies.coupled_output`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import InputError
from ..integrators.dispatch import method_code
from ..kernels import coupled as kc
from ..kernels import elastic as kel
from ..kernels.codes import STATUS_NO_CONVERGENCE, STATUS_OK, STATUS_SINGULAR
from .coupled_output import StructureOutput, StructureRecords
from .coupled_sparse import EquilibratedLU, KeptFactors, jacobian_pattern, slot_pairs
from .elastic import ElasticSpec

__all__ = ["Structure", "StructureRecords"]

_EPS = 2.220446049250313e-16
_TOL2 = (4.0 * _EPS) ** 2
_FLOOR2 = (2.0**20 * _EPS) ** 2  # a stall (see Structure.step) is accepted only below 2**20 eps |scale|
_STALLS = 3  # iterations in a row without progress that make a stall


class Structure(StructureOutput):
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
    METHODS = ("em", "midpoint")
    #: the whole state: what a checkpoint stores
    STATE_FIELDS = ("u", "v", "cu", "cv", "lam", "acc")
    NEWTON = ("auto", "reuse", "full")
    #: unknowns from which "auto" reuses factors
    AUTO_FULL = 500
    #: contraction (|update_k| / |update_k-1|) above which the factors are renewed
    SLOW = 0.2

    def __init__(self, newton: str = "auto"):
        self.newton_option = newton
        self.newton = newton
        self.retries_step = 0
        self.retries_total = 0  # failed steps that were redone in sub-steps
        self._kept = KeptFactors()  # "reuse" mode's factors and iteration counts: state, in checkpoints
        self.factorizations = 0
        self.bodies: list[dict] = []  # name, kind, slot/node ranges, output info
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
        self.zonal = None  # an EffectTerm of kind "zonal" at the gravity points, or None

    # -- building ---------------------------------------------------------------------------
    @property
    def names(self) -> list[str]:
        """Body names, in the order of adding."""
        return [b["name"] for b in self.bodies]

    def __len__(self) -> int:
        return len(self.bodies)

    def __contains__(self, name) -> bool:
        return any(b["name"] == name for b in self.bodies)

    def _new_slots(self, u, v, kind, mass):
        s0 = len(self._u)
        for i in range(len(u)):
            self._u.append(np.asarray(u[i], float))
            self._v.append(np.asarray(v[i], float))
            self._slot_kind.append(kind[i])
        idx = np.arange(s0, s0 + len(u))
        self._slot_mass_blocks.append((idx, sp.csr_matrix(mass)))
        return idx

    def _new_node(self, slots, coefs) -> int:
        self._node_slot.append(list(slots) + [-1] * (4 - len(slots)))
        self._node_coef.append(list(coefs) + [0.0] * (4 - len(coefs)))
        return len(self._node_slot) - 1

    def add_point(self, name, mass, x, v) -> int:
        """Add a point mass.

        Parameters
        ----------
        name : str
            Its name.
        mass : float
            kg.
        x, v : array_like
            (3,) position (m) and velocity (m/s).

        Returns
        -------
        int
            Its node index (a node on its own slot).
        """
        (s,) = self._new_slots([x], [v], [1], [[mass]])
        n = self._new_node([s], [1.0])
        self._gp.append(([n], [1.0], mass))
        self.bodies.append({"name": name, "kind": "point", "slot": s, "node": n, "mass": float(mass)})
        return n

    def add_rigid(self, name, points, gravity, position, velocity, R, omega_space, shape="", params=None):
        """Add a rigid body: four slots (centre of mass and three axes) with 6 constraints.

        Parameters
        ----------
        name : str
            Its name.
        points : MassPoints
            Its mass points (:mod:`emorbit.bodies.shapes`).
        gravity : str
            ``"volume"``, ``"point"`` or ``"none"``.
        position, velocity : array_like
            (3,) centre of mass, m and m/s.
        R : array_like
            (3, 3) attitude, body to space.
        omega_space : array_like
            (3,) angular velocity in space axes, rad/s.
        shape : str
            The shape's name, for the output.
        params : dict, optional
            The shape's parameters, for the output.

        Returns
        -------
        ndarray
            Its four slot indices.
        """
        E = points.second_moment
        m = points.mass
        mass = np.zeros((4, 4))
        mass[0, 0] = m
        mass[1:, 1:] = E
        u = [position] + [R[:, k] for k in range(3)]
        v = [velocity] + [np.cross(omega_space, R[:, k]) for k in range(3)]
        slots = self._new_slots(u, v, [1, 0, 0, 0], mass)
        self._rb_slots.append(list(slots))
        self._rb_es.append(float(np.trace(E) / 3.0))
        if gravity == "volume":
            for i in range(len(points)):
                X = points.X[:, i]
                n = self._new_node(slots, [1.0, X[0], X[1], X[2]])
                self._gp.append(([n], [1.0], float(points.m[i])))
        elif gravity == "point":
            n = self._new_node([slots[0]], [1.0])
            self._gp.append(([n], [1.0], m))
        self.bodies.append(
            {
                "name": name,
                "kind": "rigid",
                "slots": slots,
                "mass": float(m),
                "points": points,
                "gravity": gravity,
                "shape": shape,
                "params": params or {},
            }
        )
        return slots

    def rigid_node(self, body: str, X) -> int:
        """Add a node riding on a rigid body.

        Parameters
        ----------
        body : str
            The rigid body.
        X : array_like
            (3,) body coordinates relative to its centre of mass, m.

        Returns
        -------
        int
            The node index.
        """
        b = self._body(body)
        return self._new_node(b["slots"], [1.0, float(X[0]), float(X[1]), float(X[2])])

    def point_node(self, body: str) -> int:
        """The node of a point mass of the structure.

        Parameters
        ----------
        body : str
            The point mass.

        Returns
        -------
        int
            Its node index.
        """
        return self._body(body)["node"]

    def _body(self, name):
        for b in self.bodies:
            if b["name"] == name:
                return b
        raise KeyError(name)

    def add_elastic(self, spec: ElasticSpec) -> None:
        """Add an elastic body; it is laid out in :meth:`build`, once every attachment is known.

        Parameters
        ----------
        spec : ElasticSpec
            The body.
        """
        self._pending = getattr(self, "_pending", [])
        self._pending.append(spec)
        self.bodies.append({"name": spec.name, "kind": "elastic", "spec": spec, "mass": float(spec.node_mass.sum())})

    def attach(self, elastic: str, nodes, target: str) -> None:
        """Declare that nodes of an elastic body ride on another body of the structure.

        On a rigid body a node rides at the material point where it is at :meth:`build`; a
        node attached to a point mass is that point mass.

        Parameters
        ----------
        elastic : str
            The elastic body.
        nodes : sequence of int
            Indices into its mesh's nodes.
        target : str
            A rigid body or point mass of the structure.
        """
        self._attach = getattr(self, "_attach", [])
        self._attach.append((elastic, [int(n) for n in nodes], target))

    def _layout_elastic(self, spec: ElasticSpec, attached: dict[int, int]) -> None:
        """Slots, nodes, elements and gravity points of an elastic body; ``attached`` maps some
        of its nodes to existing structure nodes (those get no slots of their own, and their
        mass joins the body they ride on)."""
        n = spec.nodes.shape[0]
        free = [i for i in range(n) if i not in attached]
        Mn = sp.csr_matrix(spec.node_mass)
        node_of = np.empty(n, dtype=np.int64)
        slots = self._new_slots(
            [spec.nodes[i] for i in free],
            [spec.velocities[i] for i in free],
            [1] * len(free),
            Mn[free][:, free].toarray() if len(free) < 2000 else Mn[free][:, free],
        )
        for k, i in enumerate(free):
            node_of[i] = self._new_node([slots[k]], [1.0])
        for i, target in attached.items():
            node_of[i] = target
        # mass of attached nodes (and their coupling to free nodes) goes through the node maps
        self._node_mass_terms = getattr(self, "_node_mass_terms", [])
        att = sorted(attached)
        if att:
            coo = Mn.tocoo()
            keep = np.isin(coo.row, att) | np.isin(coo.col, att)
            self._node_mass_terms.append((node_of[coo.row[keep]], node_of[coo.col[keep]], coo.data[keep]))
        self._bars.extend(node_of[spec.bars].tolist() if len(spec.bars) else [])
        self._bar_EA.extend(spec.bar_EA.tolist())
        self._bar_L.extend(spec.bar_L.tolist())
        self._tets.extend(node_of[spec.tets].tolist() if len(spec.tets) else [])
        self._tet_g.extend(list(spec.tet_g))
        self._tet_V.extend(spec.tet_V.tolist())
        self._tet_lam.extend(spec.tet_lam.tolist())
        self._tet_mu.extend(spec.tet_mu.tolist())
        if spec.gravity:
            for q in range(spec.gp_m.size):
                nodes = [int(node_of[a]) for a in spec.gp_node[q] if a >= 0]
                self._gp.append((nodes, [float(w) for w in spec.gp_w[q][: len(nodes)]], float(spec.gp_m[q])))
        body = self._body(spec.name)
        body["nodes"] = node_of
        body["free_slots"] = slots

    def build(self) -> None:
        """Lay out the elastic bodies and their attachments, then freeze the arrays and the pattern.

        Called before the first step; later calls do nothing.

        Raises
        ------
        InputError
            An attached node does not start with the velocity of the point it rides on.
        """
        if self._built:
            return
        for spec in getattr(self, "_pending", []):
            attached = {}
            for name, nodes, target in getattr(self, "_attach", []):
                if name != spec.name:
                    continue
                tb = self._body(target)
                for i in nodes:
                    if tb["kind"] == "point":
                        attached[i] = tb["node"]
                        v_target = self._v[tb["slot"]]
                    else:
                        s = tb["slots"]
                        R = np.column_stack([self._u[k] for k in s[1:]])
                        X = R.T @ (spec.nodes[i] - self._u[s[0]])
                        attached[i] = self.rigid_node(target, X)
                        v_target = self._v[s[0]] + sum(X[k] * self._v[s[1 + k]] for k in range(3))
                    gap = float(np.linalg.norm(spec.velocities[i] - v_target))
                    if gap > 1e-9 * max(1.0, float(np.linalg.norm(v_target))):
                        raise InputError(
                            f"coupling ({spec.name} -> {target})",
                            f"node {i} of {spec.name!r} starts at velocity {spec.velocities[i].tolist()} "
                            f"m/s but the point of {target!r} it rides on moves at {v_target.tolist()} m/s "
                            f"(difference {gap:.3g} m/s): give the elastic body the same rigid motion",
                        )
            self._layout_elastic(spec, attached)
        ns = len(self._u)
        self.u = np.ascontiguousarray(np.array(self._u, dtype=float).reshape(ns, 3))
        self.v = np.ascontiguousarray(np.array(self._v, dtype=float).reshape(ns, 3))
        self.cu = np.zeros_like(self.u)
        self.cv = np.zeros_like(self.v)
        self.slot_pos = np.array(self._slot_kind, dtype=float)
        self.node_slot = np.array(self._node_slot, dtype=np.int64).reshape(-1, 4)
        self.node_coef = np.array(self._node_coef, dtype=float).reshape(-1, 4)
        # scalar mass matrix over slots
        rows, cols, vals = [], [], []
        for idx, Ms in self._slot_mass_blocks:
            c = Ms.tocoo()
            rows.append(idx[c.row])
            cols.append(idx[c.col])
            vals.append(c.data)
        for na, nb, mv in getattr(self, "_node_mass_terms", []):
            for a, b, m_ in zip(na, nb, mv):  # node masses through the node maps: M += m c_a c_b^T
                for si, sj, ca, cb in slot_pairs(self.node_slot, self.node_coef, a, b):
                    rows.append(np.array([si]))
                    cols.append(np.array([sj]))
                    vals.append(np.array([m_ * ca * cb]))
        self.Ms = sp.coo_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(ns, ns)
        ).tocsc()
        self.Ms.sum_duplicates()
        self.Ms_lu = spla.splu(self.Ms)
        self.mdiag = self.Ms.diagonal()
        self._Mmul = self.Ms.toarray() if ns <= 300 else self.Ms  # dense matvec for small structures
        self.bar_node = np.array(self._bars, dtype=np.int64).reshape(-1, 2)
        self.bar_EA = np.array(self._bar_EA, dtype=float)
        self.bar_L = np.array(self._bar_L, dtype=float)
        self.tet_node = np.array(self._tets, dtype=np.int64).reshape(-1, 4)
        self.tet_g = np.ascontiguousarray(np.array(self._tet_g, dtype=float).reshape(-1, 3, 4))
        self.tet_V = np.array(self._tet_V, dtype=float)
        self.tet_lam = np.array(self._tet_lam, dtype=float)
        self.tet_mu = np.array(self._tet_mu, dtype=float)
        ng = len(self._gp)
        self.gp_node = -np.ones((ng, 4), dtype=np.int64)
        self.gp_w = np.zeros((ng, 4))
        self.gp_m = np.zeros(ng)
        for q, (nodes, w, m) in enumerate(self._gp):
            self.gp_node[q, : len(nodes)] = nodes
            self.gp_w[q, : len(nodes)] = w
            self.gp_m[q] = m
        self.rb_slots = np.array(self._rb_slots, dtype=np.int64).reshape(-1, 4)
        self.rb_es = np.array(self._rb_es, dtype=float)
        self.lam = np.zeros(6 * len(self.rb_slots))
        self.acc = np.zeros_like(self.u)  # the last step's mean acceleration (predictor warm start)
        self.J, self._indices32, self._indptr32, self.J_mass = jacobian_pattern(
            self.Ms, self.node_slot, self.bar_node, self.tet_node, self.gp_node, self.rb_slots
        )
        if self.newton_option == "auto":
            self.newton = "full" if self.J.shape[0] < self.AUTO_FULL else "reuse"
        self._built = True

    # -- stepping ------------------------------------------------------------------------------
    def work_per_step(self) -> int:
        """Slots, elements and gravity points touched per step."""
        return int(20 * (self.u.shape[0] + self.tet_node.shape[0] + self.gp_m.size))

    def _forces(self, code, u0, u1, gm, c, h, with_jacobian: bool, with_stiffness: bool | None = None):
        x0n = np.empty((self.node_slot.shape[0], 3))
        x1n = np.empty_like(x0n)
        kel.combine_rows(u0, self.node_slot, self.node_coef, x0n)
        kel.combine_rows(u1, self.node_slot, self.node_coef, x1n)
        xg0 = np.empty((self.gp_m.size, 3))
        xg1 = np.empty_like(xg0)
        kel.combine_rows(x0n, self.gp_node, self.gp_w, xg0)
        kel.combine_rows(x1n, self.gp_node, self.gp_w, xg1)
        data = self.J_mass.data.copy() if with_jacobian else self._nodata
        F = np.empty_like(u0)
        hf = 0.5 * h
        zonal = (None, None)  # zonal harmonics at the gravity points, centred like them
        if self.zonal is not None:
            zonal = (np.concatenate([c, self.zonal.params["zonal_p"][3:]]), self.zonal.params["zonal_j"])
        elements = (self.bar_node, self.bar_EA, self.bar_L, self.tet_node, self.tet_g, self.tet_V, self.tet_lam)
        status = kc.fill_forces(
            code, hf * h, hf, x0n, x1n, self.node_slot, self.node_coef, *elements, self.tet_mu, self.gp_node,
            self.gp_w, self.gp_m, xg0, xg1, gm, c, gm != 0.0, with_jacobian, self.J.indptr, self.J.indices, data,
            F, self._fn, self._kb, self._kt, self._fg, self._kg, *zonal,
        )  # fmt: skip
        return status, F, data

    def _solve_mass(self, b):
        """M x = b for (n_slots, 3) b with one step of iterative refinement."""
        x = self.Ms_lu.solve(b)
        r = b - self._Mmul @ x
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

    def step(self, code: int, u0, v0, lam, acc, gm, c, h, max_iter):
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
        gm : float
            GM, m^3/s^2.
        c : ndarray
            (3,) the field's centre, relative to the same reference, m.
        h : float
            The step, s.
        max_iter : int
            Newton iterations at most.

        Returns
        -------
        tuple
            (du, dv, iterations, status, stalled): the increments of position and velocity,
            the iterations taken, a ``STATUS_*`` code of :mod:`emorbit.kernels.codes`, and
            whether the iteration was accepted at a stall (its last update above the
            round-off tolerance, below the floor) rather than at round-off.
        """
        ns = u0.shape[0]
        nr = self.rb_slots.shape[0]
        hf = 0.5 * h
        Mv0 = self._Mmul @ v0
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
        lu = None if self.newton == "full" or self._kept.its.get(h, 0) > 4 else self._kept.lus.get(h)
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
            st, F, data = self._forces(code, u0, u1, gm, c, h, fresh)
            if st != STATUS_OK:
                status = st
                break
            R1 = (self._Mmul @ du - h * (Mv0 + hf * F)).ravel()
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
                    self._kept.keep(h, lu, data)
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
        self._kept.its[h] = it
        if status != STATUS_OK:
            self._kept.drop(h)
            return du, np.zeros_like(du), it, status, False
        u1 = u0 + du
        u05 = u0 + 0.5 * du
        st, F, _ = self._forces(code, u0, u1, gm, c, h, False)
        gen = h * F
        pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
        for r in range(nr):
            for j, (k, l) in enumerate(pairs):
                sk, sl = self.rb_slots[r, 1 + k], self.rb_slots[r, 1 + l]
                gen[sk] -= nu[6 * r + j] * u05[sl]
                if k != l:
                    gen[sl] -= nu[6 * r + j] * u05[sk]
        dv = self._solve_mass(gen)
        lam[:] = nu / h
        acc[:] = dv / h
        return du, dv, it, status, stalled

    def advance(self, method, gm, center, dt, gammas, every, nrec, max_iter) -> StructureRecords:
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

        Returns
        -------
        StructureRecords
            The records; after a failure the state is that before the failing step.
        """
        ns = self.u.shape[0]
        self._scratch()
        rec = StructureRecords(
            np.empty((nrec, ns, 3)),
            np.empty((nrec, ns, 3)),
            np.zeros((nrec, 1), np.int64),
            np.full((1, 2), -1, np.int64),
            np.zeros((nrec, 1), np.int64),
        )
        code = method_code(method)
        c = np.asarray(center, float)
        for r in range(nrec):
            its = stl = 0
            for s in range(every):
                u, v, cu, cv = self.u.copy(), self.v.copy(), self.cu.copy(), self.cv.copy()
                lam, acc = self.lam.copy(), self.acc.copy()
                ok = True
                for g in gammas:
                    status, its_g, stl_g = self._substeps(code, dt * g, (u, v, cu, cv, lam, acc), gm, c, max_iter, 0)
                    its += its_g
                    stl += stl_g
                    if status != STATUS_OK:
                        ok = False
                        break
                if not ok:
                    rec.fail[0] = (r * every + s, status)
                    return rec
                self.u, self.v, self.cu, self.cv, self.lam, self.acc = u, v, cu, cv, lam, acc
                self.retries_total += self.retries_step
                self.retries_step = 0
            rec.u[r] = self.u
            rec.v[r] = self.v
            rec.iterations[r, 0] = its
            rec.stalled[r, 0] = stl
        return rec

    #: how often a failed step may be halved (2**MAX_SPLIT sub-steps at most)
    MAX_SPLIT = 4

    def _substeps(self, code, h, state, gm, c, max_iter, depth):
        """Advance ``state`` = (u, v, cu, cv, lam, acc) (arrays updated in place) by one step of
        size h; a step whose Newton iteration fails is retried as two steps of h/2, down to
        2**MAX_SPLIT sub-steps. Every sub-step is an energy-momentum step, so conservation
        is untouched. Returns (status, iterations, sub-steps accepted at a stall)."""
        u, v, cu, cv, lam, acc = state
        saved = tuple(a.copy() for a in state)
        urel, ref = self.relative(u, cu)
        du, dv, it, status, stalled = self.step(code, urel, v, lam, acc, gm, c - ref, h, max_iter)
        if status == STATUS_OK:
            u2, cu2 = _kahan(u, cu, du)
            v2, cv2 = _kahan(v, cv, dv)
            if np.all(np.isfinite(u2)) and np.all(np.isfinite(v2)):
                u[...], cu[...], v[...], cv[...] = u2, cu2, v2, cv2
                return status, it, int(stalled)
            status = STATUS_SINGULAR
        for a, b in zip(state, saved):
            a[...] = b
        if depth >= self.MAX_SPLIT or status == STATUS_SINGULAR:
            return status, it, 0
        self.retries_step += 1
        total, stl = it, 0
        for _ in range(2):
            status, k, n = self._substeps(code, 0.5 * h, state, gm, c, max_iter, depth + 1)
            total += k
            stl += n
            if status != STATUS_OK:
                for a, b in zip(state, saved):
                    a[...] = b
                return status, total, 0
        return status, total, stl

    def _scratch(self) -> None:
        nb, nt, ng = self.bar_node.shape[0], self.tet_node.shape[0], self.gp_m.size
        self._fn = np.empty((self.node_slot.shape[0], 3))
        self._kb = np.empty((nb, 3, 3))
        self._kt = np.empty((nt, 4, 4, 3, 3))
        self._fg = np.empty((ng, 3))
        self._kg = np.empty((ng, 3, 3))
        self._nodata = np.zeros(self.J.data.size)

    def current(self) -> StructureRecords:
        """The current state as one record."""
        z = np.zeros((1, 1), np.int64)
        return StructureRecords(self.u[None].copy(), self.v[None].copy(), z, np.full((1, 2), -1, np.int64), z.copy())

    def snapshot(self):
        """Copies of u, v, cu, cv, lam, acc and of the kept factors (:class:`KeptFactors`)."""
        return tuple(a.copy() for a in (self.u, self.v, self.cu, self.cv, self.lam, self.acc)) + (self._kept.copy(),)

    def restore(self, snap) -> None:
        """Put back the state of :meth:`snapshot`, kept factors included."""
        self.u, self.v, self.cu, self.cv, self.lam, self.acc = (a.copy() for a in snap[:6])
        self._kept = snap[6].copy()

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
