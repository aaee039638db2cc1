"""What a coupled structure records: its invariants, the datasets of its bodies and their
file attributes (the output half of :class:`~emorbit.bodies.coupled.Structure`).

Energy is kinetic (1/2 v^T M v over the slots) plus the St. Venant-Kirchhoff strain energy
of the elements plus every effect's potential energy (the field's at the gravity points,
mutual gravity's over the pairs of mass points); linear momentum is the
mass matrix times the velocities of the position slots; angular momentum sums u x (M v)
over all slots (for a rigid body's director slots, its spin) and is taken about the field's
centre. A rigid body's attitude and body-frame angular velocity come from its director
slots as a rigid body's records do (:mod:`emorbit.kernels.rigid_records`); an elastic body's
position is its nodes' centre of mass, and its nodal positions are written every
``node_output_every`` records.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels import elastic as kel
from ..kernels.rigid_records import rigid_record_values
from .system import BodySystem, roundoff_scales

__all__ = ["StructureRecords", "StructureOutput"]


@dataclass
class StructureRecords:
    """States recorded by one call: u, v (nrec, n_slots, 3), iterations (nrec, 1), fail (1, 2),
    stalled (nrec, 1): the sub-steps of each interval whose Newton iteration was accepted at a
    stall, above round-off, and under effects that do work each one's work since the run's
    start (nrec, w) J."""

    u: np.ndarray
    v: np.ndarray
    iterations: np.ndarray
    fail: np.ndarray
    stalled: np.ndarray | None = None
    work: np.ndarray | None = None  # (nrec, w) the work of the effects that do work since the run's start, J
    solves: np.ndarray | None = None  # (nrec, 1) sub-steps per interval, when the steps vary (adaptive)
    t: np.ndarray | None = None  # (nrec,) the records' times (set by the recorder)

    def first_failure(self):
        """The failure, if any: (step index in the chunk, 0, status), or None.

        Returns
        -------
        tuple of int or None
            The structure fails as one body.
        """
        if self.fail[0, 0] < 0:
            return None
        return int(self.fail[0, 0]), 0, int(self.fail[0, 1])


class StructureOutput(BodySystem):
    """The output half of :class:`~emorbit.bodies.coupled.Structure` (a base class).

    It reads the structure's built arrays: slots, nodes, elements, gravity points and bodies.
    """

    # -- diagnostics ------------------------------------------------------------------------------
    def _energies(self, u, v, t=None):
        """Kinetic, strain and potential energy (J) of one state at time ``t``, M v, the node
        positions relative to the reference point (:meth:`relative`), and each effect's
        potential energy ({``potential_<label>``: J})."""
        Mv = self.Ms @ v
        T = 0.5 * float(np.sum(v * Mv))
        xn, ref = self._nodes(u)
        W = kel.strain_energy(
            xn,
            self.bar_node,
            self.bar_EA,
            self.bar_L,
            self.tet_node,
            self.tet_g,
            self.tet_V,
            self.tet_lam,
            self.tet_mu,
        )
        potentials = self.fx.potentials(xn, ref, 0.0 if t is None else float(t))
        return T, W, sum(potentials.values()), Mv, xn, potentials

    def _nodes(self, u):
        """The node positions relative to the reference point (:meth:`relative`), and that point."""
        urel, ref = self.relative(u, np.zeros_like(u))
        xn = np.empty((self.node_slot.shape[0], 3))
        kel.combine_rows(urel, self.node_slot, self.node_coef, xn)
        return xn, ref

    def _record_energies(self, rec, nrec) -> list:
        """:meth:`_energies` of every record (cached: invariants, scales and the file ask for the same)."""
        cached = self.__dict__.get("_last_energies")
        if cached is not None and cached[0] is rec and cached[1] == nrec:
            return cached[2]
        t = rec.t
        out = [self._energies(rec.u[r], rec.v[r], None if t is None else t[r]) for r in range(nrec)]
        self._last_energies = (rec, nrec, out)
        return out

    def effect_energies(self, rec, nrec, gm, center) -> dict:
        """Each effect's potential energy at each record where the structure feels effects
        beyond the central field ({``potential_<label>``: (nrec,) J}); else {}."""
        if not self.effects.effects.beyond_field():
            return {}
        out: dict = {}
        for r, (*_, potentials) in enumerate(self._record_energies(rec, nrec)):
            for name, e in potentials.items():
                out.setdefault(name, np.zeros(nrec))[r] = e
        return out

    def invariants(self, rec, nrec, gm, center):
        """Energy (kinetic, strain and potential), momentum and angular momentum at each record."""
        c = np.asarray(center, float)
        E = np.empty(nrec)
        P = np.empty((nrec, 3))
        L = np.empty((nrec, 3))
        pos = self.slot_pos
        for r, (T, W, V, Mv, _, _) in enumerate(self._record_energies(rec, nrec)):
            u = rec.u[r]
            E[r] = T + W + V
            P[r] = np.sum(pos[:, None] * Mv, axis=0)
            L[r] = np.sum(np.cross(u, Mv), axis=0) - np.cross(c, P[r])
        return E, P, L

    def invariant_scales(self, rec, nrec, gm, center):
        """Round-off scales of the invariants at each record (:func:`~emorbit.bodies.system.roundoff_scales`):
        the slots' kinetic energy 1/2 v^T M v; the potential's magnitude, the strain energy and
        the elements' :func:`~emorbit.kernels.elastic.stress_scale` (what a rounding of the
        strain moves it by, over eps); the mass of the position slots; and u^T M u with the
        position slots taken from the centre."""
        c = np.asarray(center, float)
        out = np.empty((nrec, 3))
        pos = self.slot_pos
        mass = float(pos @ (self.Ms @ pos))
        for r, (T, W, V, _, xn, _) in enumerate(self._record_energies(rec, nrec)):
            stress = kel.stress_scale(
                xn,
                self.bar_node,
                self.bar_EA,
                self.bar_L,
                self.tet_node,
                self.tet_g,
                self.tet_V,
                self.tet_lam,
                self.tet_mu,
            )
            ur = rec.u[r] - pos[:, None] * c[None, :]
            out[r] = roundoff_scales(T, abs(V) + W + stress, mass, float(np.sum(ur * (self.Ms @ ur))))
        return out

    def newton_facts(self, index, method, gm, center, h, max_iter):
        """:meth:`~emorbit.bodies.coupled.Structure.step` on the structure's next step, with
        ``max_iter`` and ``max_iter - 1`` iterations: status and the last update relative to its
        round-off scale (as the step's own test measures it; residual: None). The state and
        the kept factors are put back."""
        from ..integrators.dispatch import method_code

        snap = self.snapshot()
        urel, ref = self.relative(self.u, self.cu)
        steps = [(h * (self.v + 0.5 * h * self.acc), 0)]  # the predictor: the iterate before the first
        try:
            for n in range(max(1, max_iter - 1), max_iter + 1):
                du, _, _, status, _ = self.step(
                    method_code(method), urel, self.v, self.lam.copy(), self.acc.copy(), ref, h, n
                )
                steps.append((du, status))
                self.restore(snap)
        finally:
            self.restore(snap)
        (d0, _), (d1, status) = steps[-2:]
        with np.errstate(over="ignore", invalid="ignore"):  # an iterate far off (a warm start of 1e300): inf
            size2 = float(np.max(np.sum(urel * urel, axis=1) * self.slot_pos, initial=0.0))
            base2 = np.sum((h * self.v) ** 2, axis=1) + np.where(self.slot_pos > 0, size2, 1.0)
            dd = d1 - d0
            update = float(np.sqrt(np.max(np.sum(dd * dd, axis=1) / (base2 + np.sum(d1 * d1, axis=1)))))
        return int(status), update if np.isfinite(update) else float("inf"), None

    def body_datasets(self, i: int) -> dict:
        """The datasets of body i's group, by kind; an elastic body's ``nodes/...`` datasets grow
        by one row every ``node_output_every`` records."""
        b = self.bodies[i]
        out = {"position": (3, "m"), "velocity": (3, "m / s")}
        if b["kind"] == "rigid":
            out.update({"attitude": (4, "1"), "angular_velocity": (3, "rad / s")})
        if b["kind"] == "elastic":
            n = b["spec"].nodes.shape[0]
            out.update({"nodes/position": ((n, 3), "m"), "nodes/time": (None, "s")})
        return out

    def dataset_rows(self, i: int, dataset: str, records: int) -> int:
        """One row per record; an elastic body's ``nodes/...`` one every ``node_output_every``."""
        b = self.bodies[i]
        if b["kind"] == "elastic" and dataset.startswith("nodes/"):
            return -(-records // b["spec"].node_output_every)
        return records

    def datasets(self, rec, nrec, times=None, first_row: int = 0) -> dict:
        """{name: {dataset: rows}}; an elastic body's nodal positions appear only on records whose
        index in the run (``first_row + r``) is a multiple of its ``node_output_every``."""
        out = {}
        for b in self.bodies:
            u, v = rec.u[:nrec], rec.v[:nrec]
            if b["kind"] == "point":
                s = b["slot"]
                out[b["name"]] = {"position": u[:, s].copy(), "velocity": v[:, s].copy()}
            elif b["kind"] == "rigid":
                s = b["slots"]
                E = np.ascontiguousarray(b["points"].second_moment, float)[None]
                Jinv = np.linalg.inv(b["points"].inertia)[None]
                values = (np.empty((nrec, 8)), np.empty((nrec, 1, 4)), np.empty((nrec, 1, 3)))
                q = np.ascontiguousarray(u[:, s].reshape(nrec, 1, 12))  # a rigid body's record rows
                dq = np.ascontiguousarray(v[:, s].reshape(nrec, 1, 12))
                rigid_record_values(q, dq, np.array([b["mass"]]), E, Jinv, np.zeros(3), *values)
                out[b["name"]] = {
                    "position": u[:, s[0]].copy(),
                    "velocity": v[:, s[0]].copy(),
                    "attitude": values[1][:, 0],
                    "angular_velocity": values[2][:, 0],
                }
            else:
                spec = b["spec"]
                nodes = b["nodes"]
                xn = np.empty((nrec, nodes.size, 3))
                vn = np.empty_like(xn)
                for r in range(nrec):
                    allx = np.empty((self.node_slot.shape[0], 3))
                    allv = np.empty_like(allx)
                    kel.combine_rows(u[r], self.node_slot, self.node_coef, allx)
                    kel.combine_rows(v[r], self.node_slot, self.node_coef, allv)
                    xn[r] = allx[nodes]
                    vn[r] = allv[nodes]
                mrow = np.asarray(spec.node_mass.sum(axis=1)).ravel()
                com = np.einsum("n,rni->ri", mrow, xn) / mrow.sum()
                vcom = np.einsum("n,rni->ri", mrow, vn) / mrow.sum()
                d = {"position": com, "velocity": vcom}
                k = spec.node_output_every
                rows = [r for r in range(nrec) if (first_row + r) % k == 0]
                d["nodes/position"] = xn[rows]
                d["nodes/time"] = np.asarray(times, float)[rows] if times is not None else np.zeros(len(rows))
                out[b["name"]] = d
        return out

    def body_attrs(self, i: int) -> dict:
        """``kind`` and ``mass`` (kg); rigid bodies as in :mod:`emorbit.bodies.rigid`; elastic bodies
        their element counts, ``node_output_every`` and material."""
        b = self.bodies[i]
        attrs = {"kind": b["kind"], "mass": b["mass"], "mass_unit": "kg"}
        if b["kind"] == "rigid":
            p = b["points"]
            attrs.update(
                {
                    "shape": b["shape"],
                    "mass_points": len(p),
                    "gravity": b["gravity"],
                    "inertia": p.inertia,
                    "inertia_unit": "kg m2",
                }
            )
        if b["kind"] == "elastic":
            spec = b["spec"]
            attrs.update(
                {
                    "nodes": spec.nodes.shape[0],
                    "bars": spec.bars.shape[0],
                    "tetrahedra": spec.tets.shape[0],
                    "node_output_every": spec.node_output_every,
                }
            )
            for k, v in (spec.material or {}).items():
                attrs[k] = v
        return attrs

    def body_constants(self, i: int) -> dict:
        """A rigid body's mass points; an elastic body's reference nodes (m) and elements."""
        b = self.bodies[i]
        if b["kind"] == "rigid":
            p = b["points"]
            return {"mass_points/position": (np.ascontiguousarray(p.X.T), "m"), "mass_points/mass": (p.m, "kg")}
        if b["kind"] == "elastic":
            spec = b["spec"]
            out = {"mesh/reference_nodes": (spec.ref, "m")}
            if len(spec.bars):
                out["mesh/bars"] = (spec.bars, "1")
            if len(spec.tets):
                out["mesh/tetrahedra"] = (spec.tets, "1")
            return out
        return {}
