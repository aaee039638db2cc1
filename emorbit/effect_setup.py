"""The effects half of a simulation's set-up: :meth:`EffectSetup.add_effect`, the effects a
simulation holds, and where mutual gravity puts the bodies.

Point masses under effects run the em step compiled for the simulation's effects
(:class:`~emorbit.bodies.effectpoints.EffectPoints`, :mod:`emorbit.effects.compose`); rigid and
elastic bodies feel the central field and zonal harmonics at their mass and gravity points.
Mutual gravity that reaches a rigid or elastic body makes every body of the simulation part of
one coupled structure (:class:`~emorbit.bodies.coupled.Structure`), whichever was added first:
the bodies then attract each other through their mass points within one Newton iteration per
step.
"""

from __future__ import annotations

from .errors import InputError

__all__ = ["EffectSetup", "ON_POINTS_AND_RIGID"]

#: the effects that act on point masses and rigid bodies but not on structures
ON_POINTS_AND_RIGID = ("drag", "srp", "third_body")
_NOT_ON_STRUCTURES = (
    "{} acts on point masses and rigid bodies; this simulation has a structure (elastic bodies, or mutual "
    "gravity between bodies that are not all point masses), where only drag acts (on elastic bodies' surfaces "
    "and rigid bodies' facets)"
)


class EffectSetup:
    """The effects of :class:`emorbit.Simulation`: a base class that holds no state (the
    simulation's ``_effects``, ``points``, ``rigid`` and ``structure`` are its)."""

    @property
    def effects(self) -> tuple:
        """The effects the bodies feel: the central field (where there is one), then those of
        :meth:`add_effect`, as :class:`~emorbit.effects.base.EffectTerm` (``.kind``, ``.table``)."""
        from .effects import central

        return ((central.build({}, self.field, "field", None),) if self.field is not None else ()) + tuple(
            self._effects
        )

    def add_effect(self, kind: str, *, key: str | None = None, strict: bool = False, **keys) -> None:
        """Add an effect beyond the central field: ``"zonal"``, ``"mutual"`` or ``"drag"``
        (:mod:`emorbit.effects` lists them and their keys).

        Point masses then run the em step compiled for the simulation's effects
        (:mod:`emorbit.effects.compose`), rigid bodies feel zonal harmonics on their mass
        points and elastic ones at their gravity points; each effect's potential energy is
        recorded as ``invariants/potential_<kind>``.

        Parameters
        ----------
        kind : str
            The effect.
        key : str, optional
            The name errors give the effect (default ``effect[<i>]``).
        strict : bool
            Require units on every dimensional value (scenes do).
        **keys
            The effect's keys, e.g. ``model="earth", degree=2``, ``bodies=["a", "b"]`` or
            ``atmosphere="exponential", density=..., reference_altitude=..., scale_height=...``
            (Quantities, strings with units or SI numbers).

        Raises
        ------
        InputError
            An unknown effect or key, a value the effect refuses, a method other than em,
            bodies of a kind the effect does not act on (zonal: every kind; mutual: point
            masses), a second set of zonal harmonics or a second drag, drag with rigid or
            elastic bodies or with a point mass that has no ``ballistic_coefficient``, or an
            effect that needs a central field in free space.
        """
        from .bodies.effectpoints import EffectPoints
        from .effects import build

        key = key or f"effect[{len(self._effects)}]"
        term = build({"kind": kind, **keys}, self.field, key, strict=strict)
        if self.method != "em":
            raise InputError(
                "method", f"effects other than the central field run with method 'em', got {self.method!r}"
            )
        if self.adaptive is not None:
            raise InputError(key, f"{kind!r} runs with fixed steps; this simulation has adaptive steps")
        if kind == "mutual" and self.structure is not None and self.structure._built:
            raise InputError(key, "mutual gravity cannot be added after the structure has started running")
        if kind == "zonal" and any(t.kind == "zonal" for t in self._effects):
            raise InputError(key, "the central body has one set of zonal harmonics; this simulation has it already")
        if kind in ("drag", "srp") and any(t.kind == kind for t in self._effects):
            what = "one atmosphere; this simulation has drag" if kind == "drag" else "one Sun; this simulation has srp"
            raise InputError(key, f"the central body has {what} already")
        if kind == "third_body" and any(t.kind == kind and t.body == term.body for t in self._effects):
            raise InputError(f"{key}.body", f"this simulation has the third body {term.body!r} already")
        if getattr(term, "needs_epoch", False) and getattr(self, "epoch", None) is None:
            raise InputError(
                "epoch",
                f"{key} ({kind}) takes the Sun's or the Moon's position from an ephemeris: give the run's "
                'epoch, e.g. epoch = "2026-01-01T00:00:00 TDB"',
            )
        if kind in ON_POINTS_AND_RIGID and kind != "drag" and self.structure is not None:
            raise InputError(key, _NOT_ON_STRUCTURES.format(kind))
        if kind == "drag" and self.structure is not None:
            if self.structure._built:
                raise InputError(key, "drag cannot be added after the structure has started running")
            self.structure.drag = term
        coefficient = {"drag": ("ballistic", "ballistic_coefficient", "Cd A / m"),
                       "srp": ("radiation", "radiation_coefficient", "Cr A / m")}.get(kind)  # fmt: skip
        if coefficient is not None:
            table, name_, what = coefficient
            for name in self.points.names:
                if name not in getattr(self.points, table):
                    raise InputError(
                        f"body[{name!r}].{name_}", f"{kind} acts on the point masses: give {what} (m2 / kg; 0 for none)"
                    )
        same = sum(t.kind == kind for t in self._effects)
        if same:
            term.label = f"{kind}_{same + 1}"
        self._effects.append(term)
        for system in (self.rigid, self.structure) if kind == "zonal" else ():
            if system is not None:
                system.zonal = term
        if kind in ON_POINTS_AND_RIGID and self.rigid is not None:
            self.rigid.effects = self._rigid_terms()
        if kind == "mutual" and ((self.rigid is not None and len(self.rigid)) or self.structure is not None):
            self._gather()
        if isinstance(self.points, EffectPoints):
            self.points.terms = list(self.effects)
            self.points._kernel = None
        else:
            self.points = EffectPoints.taking_over(self.points, self.effects)

    def _point_coefficients(self, ballistic, radiation, strict: bool, key: str) -> tuple:
        """A new point mass's ``Cd A / m`` and ``Cr A / m`` (m^2/kg, or None where not given);
        each is required where the simulation has drag, respectively radiation pressure."""
        from .units import to_si

        out = []
        for value, name, kind, what in (
            (ballistic, "ballistic_coefficient", "drag", "drag acts on the point masses: give Cd A / m"),
            (radiation, "radiation_coefficient", "srp", "radiation pressure acts on the point masses: give Cr A / m"),
        ):
            if value is not None:
                out.append(to_si(value, "area_per_mass", f"{key}.{name}", strict=strict, nonnegative=True))
            elif any(t.kind == kind for t in self._effects):
                raise InputError(f"{key}.{name}", f"{what} (m2 / kg; 0 for none)")
            else:
                out.append(None)
        return tuple(out)

    def _structure(self):
        """The simulation's structure, created with its effects where it has none yet (drag acts on
        it; radiation pressure and third bodies refuse it)."""
        if self.structure is None:
            from .bodies.coupled import Structure

            for term in self._rigid_terms():
                if term.kind != "drag":
                    raise InputError(
                        "body", f"{term.key} ({term.kind}) acts on point masses and rigid bodies, not on elastic "
                        "bodies or on a structure of bodies under mutual gravity",
                    )  # fmt: skip
            self.structure = Structure(newton=self.newton)
            self.structure.adaptive = self.adaptive
            self.structure.zonal = next((t for t in self._effects if t.kind == "zonal"), None)
            self.structure.drag = next((t for t in self._effects if t.kind == "drag"), None)
        if self.structure._built:
            raise InputError("body", "bodies and couplings cannot be added after the structure has started running")
        self.structure.mutual = [t for t in self._effects if t.kind == "mutual"]
        return self.structure

    def _rigid_terms(self) -> list:
        """The effects the rigid bodies feel beyond the field and zonal harmonics."""
        return [t for t in self._effects if t.kind in ON_POINTS_AND_RIGID]

    def _gather(self) -> None:
        """Mutual gravity that reaches a rigid or elastic body: every point mass and rigid body
        joins the structure (one system, one Newton iteration per step over all of them), with
        the mutual-gravity terms."""
        st = self._structure()
        for name in list(self.points.names):
            st.add_point(name, *self.points.pop(name))
        for name in list(self.rigid.names) if self.rigid is not None else ():
            st.add_rigid(name, **self.rigid.pop(name))

    def _check_effects(self) -> None:
        """The effects' bodies exist where the effects act (raises InputError naming the key)."""
        st = self.structure
        for term in self._effects:
            if term.kind in ON_POINTS_AND_RIGID and term.kind != "drag" and st is not None:
                raise InputError(term.key, _NOT_ON_STRUCTURES.format(term.kind))
            if term.kind in ("drag", "srp") and self.rigid is not None:
                for b in range(len(self.rigid)):
                    self.rigid.facets(b)  # a body without a surface says so here, before the run
        if st is None or not st.mutual:
            self.points.check(self.method)
            return
        for term in st.mutual:
            for name in term.bodies or ():
                if name not in st.names:
                    raise InputError(f"{term.key}.bodies", f"no body named {name!r}; bodies: {', '.join(self.names)}")
