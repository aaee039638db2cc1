"""Drag on a coupled structure: its elastic bodies' surface triangles and its rigid bodies'
facets, their forces in the structure's step and the work they do (:class:`StructureDrag`, a
part of :class:`~emorbit.bodies.coupled.Structure`).

Surfaces. An elastic body of tetrahedra takes the boundary triangles of its mesh
(:func:`emorbit.bodies.facets.boundary_triangles`), which move and deform with its nodes
(:mod:`emorbit.kernels.surface_drag`: each triangle's force at its midpoint configuration, a
third on each node); bars have no surface and feel no drag. A rigid body of the structure
takes the facets of its shape and its facet tables, as outside a structure
(:func:`emorbit.kernels.rigid_effects.facet_forces` on its four slots). The forces join the
structure's generalised forces in every Newton iterate; their derivatives stay out of the
Jacobian, so the iteration converges on them at the rate ``(omega h)^2 / 2`` of the fastest
attitude motion the drag drives (negligible where the elastic modes set the step).

Work. Each converged step adds ``sum f . (x1 - x0)`` over the triangles and facets to
``work`` with Kahan compensation ``cwork`` ((1,) J each; state, checkpointed, zeroed at a
run's start), which the records carry (``StructureRecords.work``) as
``invariants/work_drag``; ``E - E0 - W`` stays at round-off as for point masses. Where the
air is NRLMSIS's grid, the Sun's position at the middle of each sub-step gives local time.
"""

from __future__ import annotations

import numpy as np

from ..kernels import elastic as kel
from ..kernels.effects.third_body import table_position
from ..kernels.rigid_effects import facet_forces
from ..kernels.surface_drag import surface_drag

__all__ = ["StructureDrag"]


class StructureDrag:
    """The drag part of :class:`~emorbit.bodies.coupled.Structure`: a base class whose state
    (``drag``, ``surf_tri``, ``surf_cd``, ``rigid_facets``, ``work``, ``cwork``) the
    structure holds."""

    drag = None  # the EffectTerm of kind "drag", or None

    def _layout_surfaces(self) -> None:
        """The surface triangles of the elastic bodies (structure node numbers) and the rigid
        bodies' facets, once the bodies are laid out."""
        from .facets import Facets, boundary_triangles, shape_facets

        tris, cds = [], []
        self.rigid_facets = []  # (slots (4,), packed facets (nf, 11))
        for body in self.bodies:
            if body["kind"] == "elastic" and len(body["spec"].tets):
                spec = body["spec"]
                t = boundary_triangles(spec.tets, spec.nodes, key=f"body[{spec.name!r}]")
                tris.append(body["nodes"][t])
                cds.append(np.full(len(t), float(body.get("drag_coefficient", 2.2))))
            elif body["kind"] == "rigid" and body.get("surface") is not None:
                mode, extra, defaults, key = body["surface"]
                parts = [shape_facets(body["shape"], body["params"], key=key, **defaults)] if mode == "shape" else []
                if extra is not None and len(extra):
                    parts.append(extra)
                if parts:
                    self.rigid_facets.append((np.asarray(body["slots"], np.int64), Facets.concatenate(parts).packed()))
        self.surf_tri = np.ascontiguousarray(np.vstack(tris) if tris else np.zeros((0, 3), np.int64), np.int64)
        self.surf_cd = np.ascontiguousarray(np.concatenate(cds) if cds else np.zeros(0))
        self.work = np.zeros(1)
        self.cwork = np.zeros(1)
        self._dsun = np.zeros(3)

    def _drag_forces(self, u0, u1, c, h, F) -> float:
        """Add drag's generalised forces over the step u0 -> u1 (relative coordinates, the
        centre at ``c`` in them) into F (n_slots, 3); return their work, J."""
        p = self.drag.params
        dp = p["drag_p"].copy()
        dp[0:3] = c
        work = 0.0
        if self.surf_tri.shape[0]:
            x0n = np.empty((self.node_slot.shape[0], 3))
            x1n = np.empty_like(x0n)
            kel.combine_rows(u0, self.node_slot, self.node_coef, x0n)
            kel.combine_rows(u1, self.node_slot, self.node_coef, x1n)
            fn = np.zeros_like(x0n)
            work += surface_drag(
                x0n, x1n, self.surf_tri, self.surf_cd, h, dp, p["drag_t"], p["drag_g"], p["drag_gp"], self._dsun, fn
            )
            kel.spread_rows(fn, self.node_slot, self.node_coef, F)
        for slots, facets in self.rigid_facets:
            Fq = np.zeros(12)
            wk = np.zeros(2)
            facet_forces(
                np.ascontiguousarray(u0[slots].ravel()), np.ascontiguousarray(u1[slots].ravel()), h, Fq, facets, 0,
                facets.shape[0], dp, p["drag_t"], p["drag_g"], p["drag_gp"], self._dsun, None, np.zeros(3), 1.0, wk,
            )  # fmt: skip
            F[slots] += Fq.reshape(4, 3)
            work += wk[0]
        return work

    def _drag_clock(self, t: float) -> None:
        """The Sun's position at time ``t`` (s from the epoch), for NRLMSIS's local time."""
        dp = self.drag.params["drag_p"] if self.drag is not None else None
        if dp is not None and dp[7] != 0.0:
            self._dsun[:] = table_position(t, dp[8], dp[9], self.drag.params["drag_s"])

    def reset_work(self) -> None:
        """Start the work sum at 0 (a new run; a resumed run restores it instead)."""
        if self.drag is not None:
            self.work[...] = 0.0
            self.cwork[...] = 0.0

    def effect_work(self, rec, nrec: int) -> dict:
        """The work drag has done on the structure since the run's start: {``work_drag``:
        (nrec,) J}, or {} without drag."""
        if self.drag is None or getattr(rec, "work", None) is None:
            return {}
        return {f"work_{self.drag.label}": rec.work[:nrec, 0].copy()}

    @staticmethod
    def _clock_times(clock, dt: float, gammas, step: int) -> list:
        """The start of each sub-step of chunk step ``step``: the composition's partial sums,
        as the point-mass and rigid kernels take them."""
        j = float(clock[1]) + step
        out, acc = [], 0.0
        for k, g in enumerate(gammas):
            out.append(float(clock[0]) + ((j + acc) if k > 0 else j) * dt)
            acc += float(g)
        return out
