"""How a coupled structure is laid out: its bodies become slots, nodes, elements and gravity
points (:class:`StructureLayout`, the building half of :class:`~emorbit.bodies.coupled.Structure`).

Unknowns are 3-vector *slots*: a point mass has one, an elastic body one per free node, a rigid
body four (its centre of mass and three axes). A *node* is a combination of at most four slots
with coefficients (``node_slot``, ``node_coef`` (n_nodes, 4)): a free node is its slot, a node
riding on a rigid body is the material point ``phi + X^k d_k``. Elements (bars, tetrahedra)
join nodes; *gravity points* (``gp_node``, ``gp_w``, ``gp_m``, ``gp_body``) are where the
effects at points act; the *mass points* (``mp_node``, ``mp_w``, ``mp_m``, ``mp_body``) are
where effects between pairs of bodies (mutual gravity) act. :meth:`StructureLayout.build`
freezes all of it into arrays, with the scalar mass matrix over slots and the sparse
Jacobian's pattern.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import InputError
from .coupled_effects import StructureEffects
from .coupled_output import StructureOutput
from .coupled_sparse import jacobian_pattern, slot_pairs
from .elastic import ElasticSpec

__all__ = ["StructureLayout"]


class StructureLayout(StructureOutput):
    """The building half of a structure: bodies are added, attachments declared, then
    :meth:`build` lays out the arrays. The lists it fills are created by
    :class:`~emorbit.bodies.coupled.Structure`'s constructor."""

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

    def add_point(self, name, mass, x, v, values=None) -> int:
        """Add a point mass.

        Parameters
        ----------
        name : str
            Its name.
        mass : float
            kg.
        x, v : array_like
            (3,) position (m) and velocity (m/s).
        values : dict, optional
            Its effect keys (SI), e.g. a ballistic coefficient.

        Returns
        -------
        int
            Its node index (a node on its own slot).
        """
        (s,) = self._new_slots([x], [v], [1], [[mass]])
        n = self._new_node([s], [1.0])
        self._gp.append(([n], [1.0], mass, len(self.bodies)))
        self.bodies.append({"name": name, "kind": "point", "slot": s, "node": n, "mass": float(mass)})
        self.values[name] = dict(values or {})
        return n

    def add_rigid(
        self,
        name,
        points,
        gravity,
        position,
        velocity,
        R,
        omega_space,
        shape="",
        params=None,
        surface=None,
        values=None,
    ):
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
        surface : tuple, optional
            Its facets for surface effects (:func:`emorbit.bodies.facets.surface_spec`).
        values : dict, optional
            Its effect keys (SI).

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
                self._gp.append(([n], [1.0], float(points.m[i]), len(self.bodies)))
        elif gravity == "point":
            n = self._new_node([slots[0]], [1.0])
            self._gp.append(([n], [1.0], m, len(self.bodies)))
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
                "surface": surface,
            }
        )
        self.values[name] = dict(values or {})
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

    def add_elastic(self, spec: ElasticSpec, drag_coefficient: float = 2.2) -> None:
        """Add an elastic body; it is laid out in :meth:`build`, once every attachment is known.

        Parameters
        ----------
        spec : ElasticSpec
            The body.
        drag_coefficient : float
            Cd of its surface triangles under drag.
        """
        self._pending.append(spec)
        mass = float(spec.node_mass.sum())
        body = {"name": spec.name, "kind": "elastic", "spec": spec, "mass": mass, "drag_coefficient": drag_coefficient}
        self.bodies.append(body)

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
        body = self._body(spec.name)
        if spec.gravity:
            index = self.bodies.index(body)
            for q in range(spec.gp_m.size):
                nodes = [int(node_of[a]) for a in spec.gp_node[q] if a >= 0]
                self._gp.append((nodes, [float(w) for w in spec.gp_w[q][: len(nodes)]], float(spec.gp_m[q]), index))
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
        for spec in self._pending:
            attached = {}
            for name, nodes, target in self._attach:
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
        self._layout_pair_points()
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
        for na, nb, mv in self._node_mass_terms:
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
        self.Mmul = self.Ms.toarray() if ns <= 300 else self.Ms  # dense matvec for small structures
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
        self.gp_body = np.zeros(ng, dtype=np.int64)
        for q, (nodes, w, m, b) in enumerate(self._gp):
            self.gp_node[q, : len(nodes)] = nodes
            self.gp_w[q, : len(nodes)] = w
            self.gp_m[q] = m
            self.gp_body[q] = b
        nm = len(self._mp)
        self.mp_node = -np.ones((nm, 4), dtype=np.int64)
        self.mp_w = np.zeros((nm, 4))
        self.mp_m = np.zeros(nm)
        self.mp_body = np.zeros(nm, dtype=np.int64)
        for q, (nodes, w, m, b) in enumerate(self._mp):
            self.mp_node[q, : len(nodes)] = nodes
            self.mp_w[q, : len(nodes)] = w
            self.mp_m[q] = m
            self.mp_body[q] = b
        self._layout_cross()
        self.rb_slots = np.array(self._rb_slots, dtype=np.int64).reshape(-1, 4)
        self.rb_es = np.array(self._rb_es, dtype=float)
        self.lam = np.zeros(6 * len(self.rb_slots))
        self.acc = np.zeros_like(self.u)  # the last step's mean acceleration (predictor warm start)
        gp_all = np.vstack([self.gp_node, self.mp_node, self._cross_rows])  # the pair effects' blocks too
        self.J, self._indices32, self._indptr32, self.J_mass = jacobian_pattern(
            self.Ms, self.node_slot, self.bar_node, self.tet_node, gp_all, self.rb_slots
        )
        if self.plan.newton == "auto":
            self.newton = "full" if self.J.shape[0] < self.AUTO_FULL else "reuse"
        if self.effects is None:  # a structure of its own, outside a simulation: the field alone
            from ..effects.effectset import EffectSet
            from .effect_binding import EffectBinding

            self.effects = EffectBinding(EffectSet(None), "elastic")
        self.fx = StructureEffects(self.effects, self)
        self.reset_work()
        self._built = True

    def _layout_pair_points(self) -> None:
        """The mass points of the effects between pairs (as mutual gravity), where the structure
        has one: a point mass's node, every mass point of a rigid body (a node riding on it,
        whatever its gravity model in the field) and an elastic body's gravity points (its
        quadrature points)."""
        self._mp = []  # (nodes, weights, mass, body index)
        if self.effects is None or not self.effects.effects.pair_effects():
            return
        for i, b in enumerate(self.bodies):
            if b["kind"] == "point":
                self._mp.append(([b["node"]], [1.0], b["mass"], i))
            elif b["kind"] == "rigid":
                pts = b["points"]
                for j in range(len(pts)):
                    X = pts.X[:, j]
                    n = self._new_node(b["slots"], [1.0, float(X[0]), float(X[1]), float(X[2])])
                    self._mp.append(([n], [1.0], float(pts.m[j]), i))
            else:
                spec = b["spec"]
                for q in range(spec.gp_m.size):
                    nodes = [int(b["nodes"][a]) for a in spec.gp_node[q] if a >= 0]
                    self._mp.append((nodes, [float(w) for w in spec.gp_w[q][: len(nodes)]], float(spec.gp_m[q]), i))

    #: the most bodies whose pair effects' blocks between bodies join the Jacobian
    MAX_CROSS_BODIES = 64

    def _layout_cross(self) -> None:
        """Where the blocks of the pair effects between compact bodies (point masses, rigid
        bodies; up to :attr:`MAX_CROSS_BODIES` bodies) go: each mass point's slot coefficients
        (``mp_coef``), each body's slots (``body_slots``), whether a point is on a compact body
        (``mp_cross``), and pattern rows (two nodes each) that couple every two such bodies'
        slots. Elastic bodies' blocks stay out: the iteration converges on them."""
        nb = len(self.bodies)
        compact = np.array([b["kind"] in ("point", "rigid") for b in self.bodies], bool)
        pairs = self.effects is not None and bool(self.effects.effects.pair_effects())
        use = pairs and 1 < nb <= self.MAX_CROSS_BODIES and int(compact.sum()) > 1
        nm = self.mp_m.size
        self.mp_cross = np.zeros(nm)
        self.mp_coef = np.zeros((4, nm))
        self.body_slots = -np.ones((nb, 4), dtype=np.int64)
        self.cross_acc = np.zeros((nb if use else 0, nb, 4, 4, 3, 3))
        rows, first = [], {}
        if use:
            for q in range(nm):
                b = int(self.mp_body[q])
                if compact[b]:
                    n = int(self.mp_node[q, 0])
                    self.mp_cross[q] = 1.0
                    self.mp_coef[:, q] = self.node_coef[n]
                    self.body_slots[b] = self.node_slot[n]
                    first.setdefault(b, n)
            bodies = sorted(first)
            rows = [[first[a], first[c], -1, -1] for i, a in enumerate(bodies) for c in bodies[i + 1 :]]
        self._cross_rows = np.array(rows, dtype=np.int64).reshape(-1, 4)
