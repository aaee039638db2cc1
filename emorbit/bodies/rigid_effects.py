"""What effects beyond gravity add to rigid bodies: their facets, the work sums and the third
bodies' potential energy (:class:`RigidEffects`, a part of
:class:`~emorbit.bodies.rigid.RigidBodies`).

Drag and radiation pressure act on each body's flat facets (:mod:`emorbit.bodies.facets`:
the shape's surface and any facet tables), third bodies on its mass points; the kernels are
:mod:`emorbit.kernels.rigid_effects`, called by :func:`emorbit.kernels.rigid.rigid_chunk`.
These effects do work, which the step sums per body and effect into ``work`` (nb, k) J with
Kahan terms ``cwork`` (state, checkpointed, zeroed at a run's start), in the slot order drag,
radiation pressure, third bodies; records carry it (``RigidRecords.work``). A third body's
potential energy at the records' times joins the bodies' energy.
"""

from __future__ import annotations

import numpy as np

from .system import WorkSums

__all__ = ["RigidEffects"]

#: drag's parameter arrays, in the kernels' argument order
DRAG_ARRAYS = ("drag_p", "drag_t", "drag_g", "drag_gp", "drag_s")


class RigidEffects(WorkSums):
    """The effects part of :class:`~emorbit.bodies.rigid.RigidBodies`: a base class whose state
    (``effects``, ``surfaces``, ``_facets``, ``_work``, ``_cwork``) the rigid bodies hold."""

    @property
    def STATE_FIELDS(self) -> tuple:  # noqa: N802 (the name every body system uses)
        """The whole state: :attr:`BASE_FIELDS`, and :attr:`WORK_FIELDS` where an effect does
        work (the checkpoints of other runs hold what they always held)."""
        return self.BASE_FIELDS + (self.WORK_FIELDS if self.working_terms() else ())

    def working_terms(self) -> list:
        """The effects whose work the step sums, in their slot order: drag, radiation
        pressure, the third bodies."""
        rank = {"drag": 0, "srp": 1, "third_body": 2}
        return sorted(self.effects, key=lambda t: rank[t.kind])

    def _work_shape(self) -> tuple:
        return (len(self), len(self.working_terms()))

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

    def _effect_args(self, rec, nrec: int, clock) -> tuple:
        """The arguments of :func:`~emorbit.kernels.rigid.rigid_chunk` after ``zonal_j``: the
        clock, the facets, drag, radiation pressure, the third bodies and the work arrays;
        () where the bodies feel none of them (the kernel then runs without their code)."""
        if not self.effects:
            return ()
        from ..effects.third_body import stack

        by = {t.kind: t for t in self.effects}
        facets = foff = None
        if "drag" in by or "srp" in by:
            rows, counts = [], []
            for b in range(len(self)):
                f = self.facets(b)
                counts.append(0 if f is None else len(f))
                if f is not None:
                    rows.append(f.packed())
            foff = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
            facets = np.ascontiguousarray(np.vstack(rows)) if rows else np.zeros((0, 11))
        drag = by.get("drag")
        srp = by.get("srp")
        third = [t for t in self.working_terms() if t.kind == "third_body"]
        tb_p, tb_tab = stack(third) if third else (None, None)
        rec.work = np.empty((nrec,) + self.work.shape)
        return (
            float(clock[0]), float(clock[1]), facets, foff,
            *((None,) * 5 if drag is None else (drag.params[k] for k in DRAG_ARRAYS)),
            None if srp is None else srp.params["srp_p"], None if srp is None else srp.params["srp_tab"],
            tb_p, tb_tab, self.work, self.cwork, rec.work,
        )  # fmt: skip

    def effect_work(self, rec, nrec: int) -> dict:
        """The work of each effect of :meth:`working_terms` on all bodies since the run's start.

        Returns
        -------
        dict
            {``work_<label>``: (nrec,) J}; {} without such effects.
        """
        if rec.work is None or not self.effects:
            return {}
        return {f"work_{t.label}": rec.work[:nrec, :, k].sum(axis=1) for k, t in enumerate(self.working_terms())}

    def third_body_energy(self, q: np.ndarray, t) -> dict:
        """Each third body's potential energy of the bodies' mass points (their centres of mass
        for the point model) at recorded states q (rows, nb, 12) and times t (rows,):
        {``potential_<label>``: (rows,) J}."""
        out = {}
        for term in (t_ for t_ in self.effects if t_.kind == "third_body"):
            e = np.zeros(q.shape[0])
            for x, mb in self.gravity_points(q):
                e += term.potential(x, mb, np.ones(mb.shape[0], bool), t)
            out[f"potential_{term.label}"] = e
        return out
