"""The effects as a coupled structure feels them: :class:`StructureEffects`.

A structure (:class:`~emorbit.bodies.coupled.Structure`) steps its slots; the simulation's
effect set (:class:`~emorbit.bodies.effect_binding.EffectBinding`) acts

- at its *gravity points* (a point mass's node, a rigid body's mass points or centre of
  mass, an elastic body's quadrature points), where every effect that acts at points does
  (the central field, zonal harmonics, third bodies, drag on a point mass by its ballistic
  coefficient, a user's effect);
- between its *mass points* of different bodies, where an effect between pairs does (mutual
  gravity);
- on its *surfaces* (an elastic body's boundary triangles, a rigid body's facets), where an
  effect on surfaces does (drag, radiation pressure).

Each converged step adds the work of the effects that do work to ``work`` (w,) J with Kahan
compensation ``cwork`` (the structure's state, checkpointed, zeroed at a run's start). The
effects' forces join the structure's generalised forces in every Newton iterate with the
points' own Jacobian blocks; the surfaces' derivatives stay out of the Jacobian, so the
iteration converges on them at the rate ``(omega h)^2 / 2`` of the fastest attitude motion
they drive (negligible where the elastic modes set the step). The kernels are
:mod:`emorbit.kernels.structure_effects` and :mod:`emorbit.kernels.rigid_surface`.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..kernels import elastic as kel
from ..kernels.codes import METHOD_MIDPOINT, STATUS_OK
from ..kernels.coupled import add_point_blocks
from ..kernels.effects.signatures import MODE_MIDPOINT, MODE_STEP
from ..kernels.rigid_surface import facet_forces, facet_scratch
from ..kernels.structure_effects import (
    cross_blocks,
    point_effects,
    point_effects_work,
    prepare_set,
    triangle_effects,
)

__all__ = ["StructureEffects"]


class StructureEffects:
    """The effects of a built structure.

    Parameters
    ----------
    binding : EffectBinding
        The simulation's effects.
    structure : Structure
        The structure, built (its layout arrays are read).
    """

    def __init__(self, binding, structure):
        self.binding = binding
        self.st = structure
        effects = binding.effects
        pairs = np.array([type(e).pairs() for e in effects.all], bool)
        values = structure.values
        cols = [effects.coefficients(b["kind"], b["name"], values.get(b["name"], {})) for b in structure.bodies]
        cols = np.array(cols).reshape(len(structure.bodies), len(effects)).T  # (k, bodies)
        self.gp_coef = np.ascontiguousarray(np.where(pairs[:, None], 0.0, cols)[:, structure.gp_body])
        self.mp_coef = np.ascontiguousarray(np.where(pairs[:, None], cols, 0.0)[:, structure.mp_body])
        self.any_points = bool(self.gp_coef.size and np.any(self.gp_coef != 0.0))
        self.any_pairs = bool(self.mp_coef.size and np.any(self.mp_coef != 0.0))
        self._layout_surfaces(effects)
        self.nw = effects.work_rows()
        self.n_working = len(effects.working())
        self.R_gp = np.zeros(structure.gp_m.size)
        self.R_mp = np.zeros(structure.mp_m.size)
        self._prog = self._set = None

    def _layout_surfaces(self, effects) -> None:
        """The boundary triangles of the elastic bodies (structure node numbers) and the rigid
        bodies' facets that surface effects reach."""
        from .facets import boundary_triangles, shape_facets

        tris, kfs = [], []
        self.rigid_facets = []  # (slots (4,), packed facets (nf, 11))
        for body in self.st.bodies:
            kind = body["kind"]
            if kind == "point" or not effects.surface_mask(kind, body["name"]).any():
                continue
            if kind == "elastic":
                spec = body["spec"]
                if len(spec.tets) and effects.needs_surface(kind, body["name"]):
                    t = boundary_triangles(spec.tets, spec.nodes, key=f"body[{spec.name!r}]")
                    tris.append(body["nodes"][t])
                    kf = np.zeros((4, len(t)))
                    kf[0] = float(body.get("drag_coefficient", 2.2))
                    kfs.append(kf)
                own = effects.own_facets(kind, body["name"])
                for row in own:  # a facet at one node: a burn's thruster
                    node = int(row[0])
                    if node >= len(body["nodes"]):
                        key = next(  # the effect whose facet it is (k3, its mark)
                            e.key
                            for e in effects.all
                            if type(e).OWN_FACETS and row[4] in e.own_facets(kind, body["name"])[:, 4]
                        )
                        raise InputError(
                            f"{key}.node",
                            f"{body['name']!r} has {len(body['nodes'])} nodes (0 to "
                            f"{len(body['nodes']) - 1}); node {node} is not one of them",
                        )
                    tris.append(np.full((1, 3), body["nodes"][node], np.int64))
                    kfs.append(row[1:5].reshape(4, 1))
            elif kind == "rigid":
                parts = [effects.own_facets(kind, body["name"])]
                if body.get("surface") is not None and effects.needs_surface(kind, body["name"]):
                    mode, extra, defaults, key = body["surface"]
                    if mode == "shape":
                        parts.append(shape_facets(body["shape"], body["params"], key=key, **defaults).packed())
                    if extra is not None and len(extra):
                        parts.append(extra.packed())
                rows = np.vstack(parts)
                if len(rows):
                    self.rigid_facets.append((np.asarray(body["slots"], np.int64), np.ascontiguousarray(rows)))
        self.tris = np.ascontiguousarray(np.vstack(tris) if tris else np.zeros((0, 3), np.int64), np.int64)
        self.tri_kf = np.ascontiguousarray(np.hstack(kfs) if kfs else np.zeros((4, 0)))

    def active(self) -> bool:
        """Whether any effect reaches the structure's points, pairs or surfaces."""
        return self.any_points or self.any_pairs or bool(self.tris.shape[0]) or bool(self.rigid_facets)

    @staticmethod
    def mode(code: int) -> int:
        """The set's mode for a method code."""
        return MODE_MIDPOINT if code == METHOD_MIDPOINT else MODE_STEP

    def begin(self) -> None:
        """Take the set's compiled functions and arrays for the next chunk of steps (the tables
        as the effects last sampled them; the scratch that ``prepare`` fills lives in them)."""
        self._prog = self.binding.program
        self._set = self.binding.arrays(max(self.st.gp_m.size, self.st.mp_m.size, 1))

    def _arrays(self):
        if self._set is None:
            self.begin()
        return self._prog, self._set

    def forces(self, code, x0n, x1n, u0, u1, ref, h, F, data, first):
        """Add the effects' forces on the structure over the step into F (n_slots, 3) and, where
        ``data`` is given, ``-h^2/2`` times the points' own blocks into the Jacobian's values.
        ``x0n``, ``x1n`` the nodes and ``u0``, ``u1`` the slots (relative to ``ref``). Returns a
        status."""
        st = self.st
        prog, (P, I, T, S) = self._arrays()
        mode = self.mode(code)
        want_K = data is not None
        hh = 0.5 * h * h
        status = STATUS_OK
        fn = np.zeros((st.node_slot.shape[0], 3))
        for active, node, w, m, body, coef, R in (
            (self.any_points, st.gp_node, st.gp_w, st.gp_m, st.gp_body, self.gp_coef, self.R_gp),
            (self.any_pairs, st.mp_node, st.mp_w, st.mp_m, st.mp_body, self.mp_coef, self.R_mp),
        ):
            if not active:
                continue
            x0 = np.empty((m.size, 3))
            x1 = np.empty((m.size, 3))
            kel.combine_rows(x0n, node, w, x0)
            kel.combine_rows(x1n, node, w, x1)
            f = np.empty((m.size, 3))
            k = np.empty((m.size, 3, 3))
            s = point_effects(
                prog.forces, mode, x0, x1, ref, m, body, coef, h, P, I, T, S, R, f, k, want_K, first
            )  # fmt: skip
            if s != STATUS_OK:
                status = s
            kel.spread_rows(f, node, w, fn)
            if want_K:
                add_point_blocks(node, w, k, -hh, st.node_slot, st.node_coef, st.J.indptr, st.J.indices, data)
                if node is st.mp_node and st.cross_acc.shape[0]:  # the pairs' blocks between compact bodies
                    cross_blocks(
                        prog.cross, x0, x1, ref, m, body, coef, st.mp_cross, st.mp_coef, st.cross_acc,
                        st.body_slots, hh, P, I, T, S, st.J.indptr, st.J.indices, data,
                    )  # fmt: skip
        if self.tris.shape[0]:
            s = triangle_effects(
                prog.facets, x0n, x1n, ref, self.tris, self.tri_kf, h, P, I, T, S, fn, np.zeros(self.nw), False
            )  # fmt: skip
            if s != STATUS_OK:
                status = s
        kel.spread_rows(fn, st.node_slot, st.node_coef, F)
        for slots, facets in self.rigid_facets:
            Fq = np.zeros(12)
            s = facet_forces(
                prog.facets, _absolute_q(u0[slots], ref), _absolute_q(u1[slots], ref), h, Fq, facets, 0,
                facets.shape[0], P, I, T, S, facet_scratch(facets.shape[0], self.nw), False,
            )  # fmt: skip
            if s != STATUS_OK:
                status = s
            F[slots] += Fq.reshape(4, 3)
        return status

    def work(self, code, x0n, x1n, u0, u1, ref, h) -> np.ndarray:
        """Each working effect's work on the structure over the converged step, (w,) J (a
        structure holds its masses: the set's ledger row, where it has one, is left out)."""
        st = self.st
        out = np.zeros(self.nw)
        if not self.nw:
            return out[: self.n_working]
        prog, (P, I, T, S) = self._arrays()
        mode = self.mode(code)
        if self.any_points:
            x0 = np.empty((st.gp_m.size, 3))
            x1 = np.empty((st.gp_m.size, 3))
            kel.combine_rows(x0n, st.gp_node, st.gp_w, x0)
            kel.combine_rows(x1n, st.gp_node, st.gp_w, x1)
            point_effects_work(prog.work, mode, x0, x1, ref, st.gp_m, st.gp_body, self.gp_coef, h, P, I, T, S, out)
        if self.tris.shape[0]:
            fn = np.zeros((st.node_slot.shape[0], 3))
            triangle_effects(prog.facets, x0n, x1n, ref, self.tris, self.tri_kf, h, P, I, T, S, fn, out, True)
        for slots, facets in self.rigid_facets:
            scratch = facet_scratch(facets.shape[0], self.nw)
            facet_forces(
                prog.facets, _absolute_q(u0[slots], ref), _absolute_q(u1[slots], ref), h, np.zeros(12), facets, 0,
                facets.shape[0], P, I, T, S, scratch, True,
            )  # fmt: skip
            out += scratch[6].sum(axis=1)
        return out[: self.n_working]

    def prepare(self, ta: float, tm: float, tb: float) -> None:
        """The set's values for a sub-step from ``ta`` to ``tb`` (s from the epoch)."""
        prog, (P, I, T, S) = self._arrays()
        prepare_set(prog.prepare, ta, tm, tb, P, I, T, S)

    def potentials(self, xn, ref, t) -> dict:
        """Each effect's potential energy of one state (nodes ``xn`` relative to ``ref``) at
        time ``t``: {``potential_<label>``: J}."""
        st = self.st
        total: dict = {}
        for node, w, m, body, coef in (
            (st.gp_node, st.gp_w, st.gp_m, st.gp_body, self.gp_coef),
            (st.mp_node, st.mp_w, st.mp_m, st.mp_body, self.mp_coef),
        ):
            if not m.size:
                continue
            x = np.empty((m.size, 3))
            kel.combine_rows(xn, node, w, x)
            values = self.binding.potentials((x + ref).T[None], np.array([t]), m, body, coef)
            for name, e in values.items():
                total[name] = total.get(name, 0.0) + float(e[0])
        return total


def _absolute_q(slots, ref) -> np.ndarray:
    """A rigid body's four slots (relative) as its configuration q (12,), the centre absolute."""
    q = np.ascontiguousarray(slots, dtype=float).ravel().copy()
    q[0:3] += ref
    return q
