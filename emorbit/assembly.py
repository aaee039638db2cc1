"""Setting up a :class:`~emorbit.simulation.Simulation`: adding its bodies and its effects.

:class:`Assembly` is the set-up half of the scripting API: :meth:`~Assembly.add_point`,
:meth:`~Assembly.add_rigid` and :meth:`~Assembly.add_elastic` check a body's keys (astropy
Quantities, strings with units or SI floats), convert them to SI and hand the body to its
kind's system; :meth:`~Assembly.attach` ties an elastic body's nodes to another body;
:meth:`~Assembly.add_effect` adds an effect (:mod:`emorbit.effects`) after checking it
against the method, the epoch and the bodies already added, and
:meth:`~Assembly.check` checks the whole set and the plan (a round-off treatment the bodies'
paths do not honour) before a run. It works on the
attributes :class:`~emorbit.simulation.Simulation` sets up: ``field``, ``method``,
``adaptive``, ``epoch``, ``effects``, ``points``, ``rigid`` and ``structure``.
"""

from __future__ import annotations

import numpy as np

from .bodies.effect_binding import EffectBinding
from .bodies.system import check_body_name
from .effects.base import ON_SURFACES
from .errors import InputError
from .orbits import initial_state
from .units import to_si, vector_to_si

__all__ = ["Assembly"]


class Assembly:
    """Adds bodies and effects to a simulation (the base of
    :class:`~emorbit.simulation.Simulation`, which documents the attributes it reads)."""

    def _new_name(self, name, key: str) -> None:
        check_body_name(name, f"{key}.name")
        if any(name in s for s in (self.points, self.rigid, self.structure) if s is not None):
            raise InputError(f"{key}.name", f"a body named {name!r} already exists")

    def _check_method_supports(self, system, key: str) -> None:
        if self.method not in system.METHODS:
            raise InputError(
                "method",
                f"method {self.method!r} has no {system.kind}-body kernel "
                f"(needed by {key}); use one of {', '.join(system.METHODS)}",
            )

    def add_point(
        self,
        name: str,
        *,
        mass,
        position=None,
        velocity=None,
        orbit=None,
        strict: bool = False,
        key: str | None = None,
        **effect_keys,
    ) -> None:
        """Add a point mass: it feels the field and the simulation's effects (other bodies too,
        under mutual gravity).

        Parameters
        ----------
        name : str
            A new body name (non-empty, without '/').
        mass : Quantity, str or float
            Mass, kg (> 0).
        position : Quantity or sequence
            Initial position (3 components), m.
        velocity : Quantity or sequence
            Initial velocity (3 components), m/s.
        orbit : dict, optional
            Osculating elements about the field's centre instead of ``position`` and
            ``velocity``: ``a`` and ``e``, or a periapsis with an apoapsis or ``e``
            (``periapsis_radius`` / ``_altitude`` ...), ``i``, ``raan``, ``argp``, and ``nu``
            or ``mean_anomaly``; lengths and angles as Quantities, strings or SI numbers
            (:func:`emorbit.orbits.orbit_state`).
        strict : bool
            Require units on every value.
        key : str, optional
            Prefix of the keys that error messages name (default ``body['<name>']``).
        **effect_keys
            The keys effects attach to point masses (:attr:`emorbit.effects.base.Effect.BODY_KEYS`),
            e.g. ``ballistic_coefficient`` (``Cd A / m``, m^2/kg, for drag) or
            ``radiation_coefficient`` (``Cr A / m``, for srp); required where the simulation
            has the effect.

        Raises
        ------
        InputError
            A bad value, a taken name, no field, a position at the centre or inside the
            central body, a radial fall into a centre without radius (see
            :meth:`CentralField.check_start`), a method without a point-mass kernel, or an
            unknown effect key, or none where an effect of the simulation requires it.
        """
        key = key or f"body[{name!r}]"
        self._new_name(name, key)
        if not (self.effects.acts_at_points("point") or self.effects.pair_effects()):
            from .effects import EFFECTS

            pairs = ", ".join(f"add_effect({n!r})" for n, cls in EFFECTS.items() if cls.pairs())
            raise InputError(
                "field",
                f"{key} is a point mass, which needs a central field or an effect that acts on it (between "
                f"bodies: {pairs}); this simulation has neither",
            )
        m = to_si(mass, "mass", f"{key}.mass", strict=strict, positive=True)
        values = self._body_values("point", effect_keys, strict, key)
        position, velocity, xkey, vkey = initial_state(position, velocity, orbit, self.field, strict=strict, key=key)
        x = vector_to_si(position, "length", xkey, strict=strict)
        v = vector_to_si(velocity, "speed", vkey, strict=strict)
        self._check_method_supports(self.points, key)
        if self.field is not None:
            self.field.check_start(x, x, v, gravity=True, key=xkey, what=f"{x.tolist()} m", motion_key=vkey)
        if self.structure is not None and self.effects.pair_effects():  # pairs with other bodies
            self._structure().add_point(name, m, x, v, values)
            return
        self.points.add(name, m, x, v)
        self.points.values[name] = values

    def add_rigid(
        self,
        name: str,
        shape: str,
        *,
        position=None,
        velocity=None,
        orbit=None,
        attitude=None,
        rotation_vector=None,
        angular_velocity=(0.0, 0.0, 0.0),
        angular_velocity_frame: str = "body",
        gravity: str | None = None,
        facets: str = "shape",
        facet=None,
        drag_coefficient=2.2,
        specular=0.0,
        diffuse=0.0,
        strict: bool = False,
        key: str | None = None,
        **shape_params,
    ) -> None:
        """Add a rigid body discretised into mass points (see :mod:`emorbit.bodies.shapes`).

        Parameters
        ----------
        name : str
            A new body name.
        shape : str
            ``"box"``, ``"cylinder"``, ``"sphere"``, ``"ellipsoid"``, ``"shell"``, ``"dumbbell"`` or
            ``"mesh"``.
        position : Quantity or sequence
            Initial position of the centre of mass, m.
        velocity : Quantity or sequence
            Initial velocity of the centre of mass, m/s.
        orbit : dict, optional
            The centre of mass's osculating elements instead of ``position`` and
            ``velocity``, as for :meth:`add_point`.
        attitude : sequence of 4 floats, optional
            Unit quaternion (w, x, y, z) rotating body axes into space axes.
        rotation_vector : Quantity or sequence, optional
            The attitude as angle times unit axis, rad (instead of ``attitude``; default:
            body axes are space axes).
        angular_velocity : Quantity or sequence
            Initial angular velocity, rad/s.
        angular_velocity_frame : str
            ``"body"`` (default) or ``"space"``: the axes of ``angular_velocity``.
        gravity : str, optional
            ``"volume"`` (the field summed over the mass points: gravity-gradient torque),
            ``"point"`` (all mass at the centre of mass, no torque) or ``"none"`` (free
            motion); default ``"volume"`` with a field, ``"none"`` without.
        facets : str
            The flat facets that drag and radiation pressure act on (:mod:`emorbit.bodies.facets`):
            ``"shape"`` (default) the shape's closed surface, ``"none"`` only those of ``facet``.
        facet : list of dict, optional
            More facets, e.g. solar panels or a fin: each ``center`` (body frame, m),
            ``normal``, ``area`` (m^2), optional ``two_sided``, ``drag_coefficient``,
            ``specular``, ``diffuse`` (:data:`emorbit.bodies.facets.FACET_KEYS`).
        drag_coefficient : float
            Cd of the shape's facets and the default of ``facet`` (2.2).
        specular, diffuse : float
            The reflection coefficients of the shape's facets and the defaults of ``facet``, in
            [0, 1], summing to at most 1 (0, 0: a black body).
        strict : bool
            Require units on every value.
        key : str, optional
            Prefix of the keys that error messages name.
        **shape_params
            The shape's parameters: box ``size``; cylinder ``radius``, ``height``; sphere
            ``radius``; ellipsoid ``semi_axes``; shell ``radius``, ``mass``; dumbbell ``masses``, ``length``
            [, ``end_radius``]; mesh ``nodes``, ``tetrahedra``, ``density``
            [, ``mesh_unit``]; plus ``density`` or ``mass`` and ``refinement`` (cells per
            edge, default 1) where they apply (scenes.md lists them with their units).

        Raises
        ------
        InputError
            A bad shape or value, a taken name, adaptive steps for a body that neither
            orbits nor turns, a mass point at the centre or inside the central body, a
            radial fall into a centre without radius, or a method without a rigid-body
            kernel.
        """
        from .bodies.facets import surface_spec
        from .bodies.rigid import RigidBodies
        from .bodies.rigid_input import build_rigid

        key = key or f"body[{name!r}]"
        self._new_name(name, key)
        position, velocity, xkey, vkey = initial_state(position, velocity, orbit, self.field, strict=strict, key=key)
        spec = build_rigid(
            shape,
            shape_params,
            position=position,
            velocity=velocity,
            attitude=attitude,
            rotation_vector=rotation_vector,
            angular_velocity=angular_velocity,
            frame=angular_velocity_frame,
            gravity=gravity,
            has_field=self.field is not None or self.effects.acts_at_points("rigid"),
            strict=strict,
            key=key,
        )
        if self.adaptive is not None and self.field is None and not np.any(spec["omega_space"]):
            raise InputError(
                f"{key}.angular_velocity",
                "adaptive steps follow the orbit and the rotation; this body has neither (no field, no rotation)",
            )
        surface = surface_spec(facets, facet, drag_coefficient, specular, diffuse, strict, key)
        if self.rigid is None:
            self.rigid = RigidBodies(self.plan)
            self.rigid.effects = EffectBinding(self.effects, "rigid")
        self._check_method_supports(self.rigid, key)
        if self.field is not None:
            self.field.check_start(
                np.vstack([spec["position"], (spec["position"][:, None] + spec["R"] @ spec["points"].X).T]),
                spec["position"],
                spec["velocity"],
                gravity=spec["gravity"] != "none",
                key=xkey,
                what="the centre of mass or a mass point of the body",
                motion_key=vkey,
            )
        self.rigid.add(
            name,
            shape,
            spec["points"],
            spec["gravity"],
            spec["position"],
            spec["velocity"],
            spec["R"],
            spec["omega_space"],
            spec["params"],
            surface,
        )
        if self.effects.pair_effects():
            self._gather()

    def add_elastic(
        self,
        name: str,
        mesh: str,
        *,
        position=None,
        velocity=None,
        young,
        density,
        orbit=None,
        poisson=None,
        area=None,
        attitude=None,
        rotation_vector=None,
        angular_velocity=(0.0, 0.0, 0.0),
        angular_velocity_frame: str = "body",
        gravity: str | None = None,
        mass_matrix: str = "consistent",
        node_output_every: int = 1,
        drag_coefficient=2.2,
        strict: bool = False,
        key: str | None = None,
        **mesh_params,
    ) -> None:
        """Add an elastic body of St. Venant-Kirchhoff bars and/or tetrahedra.

        See :mod:`emorbit.bodies.meshes` for the meshes and :mod:`emorbit.bodies.elastic` for the
        materials.

        Parameters
        ----------
        name : str
            A new body name.
        mesh : str
            ``"beam"``, ``"chain"``, ``"net"`` or ``"file"``; node coordinates are in the
            body frame.
        position, velocity, attitude, rotation_vector, angular_velocity, angular_velocity_frame
            The body frame's placement and rigid initial motion, as for :meth:`add_rigid`.
        orbit : dict, optional
            The osculating elements of the body frame's origin instead of ``position`` and
            ``velocity``, as for :meth:`add_point`.
        young : Quantity, str or float
            Young's modulus E, Pa.
        density : Quantity, str or float
            Density, kg/m^3.
        poisson : float, optional
            Poisson's ratio, in (-1, 0.5); required with tetrahedra.
        area : Quantity, str or float, optional
            Cross-section of the bars, m^2; required with bars.
        gravity : str, optional
            ``"volume"`` (at the elements' quadrature points; default with a field) or
            ``"none"``.
        mass_matrix : str
            ``"consistent"`` (default) or ``"lumped"``.
        node_output_every : int
            Records between the nodal positions written to the file.
        drag_coefficient : float
            Cd of the surface triangles of its tetrahedra, where the simulation has drag
            (bars have no surface).
        strict : bool
            Require units on every value.
        key : str, optional
            Prefix of the keys that error messages name.
        **mesh_params
            The mesh's parameters: beam ``size``, ``elements``; chain ``start``, ``end``,
            ``elements``; net ``size``, ``elements``; file ``file`` [, ``mesh_unit``].

        Raises
        ------
        InputError
            A bad mesh, material or value, a taken name, a node at the
            centre or inside the central body, a radial fall into a centre without radius,
            or a method without an elastic kernel (:attr:`~emorbit.bodies.coupled.Structure.METHODS`).
        """
        from .bodies import elastic as el
        from .bodies.facets import facet_coefficients

        key = key or f"body[{name!r}]"
        self._new_name(name, key)
        position, velocity, xkey, vkey = initial_state(position, velocity, orbit, self.field, strict=strict, key=key)
        from .bodies.coupled import Structure

        if self.method not in Structure.METHODS:
            raise InputError(
                "method",
                f"method {self.method!r} has no elastic-body kernel (needed by {key}); "
                f"use one of {', '.join(Structure.METHODS)}",
            )
        spec = el.build_elastic(
            name,
            mesh,
            mesh_params,
            position=position,
            velocity=velocity,
            young=young,
            density=density,
            poisson=poisson,
            area=area,
            attitude=attitude,
            rotation_vector=rotation_vector,
            angular_velocity=angular_velocity,
            frame=angular_velocity_frame,
            gravity=gravity,
            mass_matrix=mass_matrix,
            node_output_every=node_output_every,
            has_field=self.field is not None or self.effects.acts_at_points("elastic"),
            strict=strict,
            key=key,
        )
        if self.field is not None:
            m = np.asarray(spec.node_mass.sum(axis=1)).ravel()
            com = m @ spec.nodes / m.sum()
            self.field.check_start(
                np.vstack([com, spec.nodes]),
                com,
                m @ spec.velocities / m.sum(),
                gravity=spec.gravity,
                key=xkey,
                what="the centre of mass or a node of the body",
                motion_key=vkey,
            )
        self._structure().add_elastic(spec, facet_coefficients(drag_coefficient, 0.0, 0.0, key)[0])
        if self.effects.pair_effects():
            self._gather()

    def attach(self, elastic: str, nodes, to: str, key: str = "coupling") -> None:
        """Attach nodes of an elastic body to a rigid body or a point mass.

        On a rigid body each node rides at the material point where it is now; a node
        attached to a point mass is that point mass (it must start where the point mass is).
        The attached body joins the elastic body's structure.

        Parameters
        ----------
        elastic : str
            The elastic body.
        nodes : sequence of int or str
            Indices into its mesh's nodes (exactly one for a point mass), or a selector:
            ``"first"``, ``"last"``, ``"<axis>-min"`` / ``"<axis>-max"`` with axis x, y or z
            (the nodes on that face of the reference mesh; see
            :func:`emorbit.bodies.elastic.select_nodes`, which scenes use too).
        to : str
            The rigid body or point mass.
        key : str
            Prefix of the keys that error messages name.

        Raises
        ------
        InputError
            No such bodies, bad node indices or selector, a node that does not start on
            the point mass, or nodes not on or in the rigid body
            (:func:`~emorbit.bodies.shapes.check_on_body`); nothing is attached then.
        """
        from .bodies.elastic import select_nodes
        from .bodies.shapes import check_on_body

        st = self._structure()
        if elastic not in st.names or st._body(elastic)["kind"] != "elastic":
            raise InputError(f"{key}.elastic", f"no elastic body named {elastic!r}")
        spec = st._body(elastic)["spec"]
        idx = select_nodes(spec.ref, nodes, f"{key}.nodes")
        if to == elastic:
            raise InputError(f"{key}.to", "a body cannot be attached to itself")
        pose = self._rigid_pose(to)  # None unless `to` is a rigid body
        if pose is not None:  # the nodes must start on or in it
            check_on_body(spec.nodes[idx], idx, *pose, key=f"{key}.nodes", elastic=elastic, to=to)
        if to in self.points:
            values = self.points.values.get(to, {})
            st.add_point(to, *self.points.pop_onto(to, idx, spec.nodes[idx], f"{key}.nodes"), values)
        elif self.rigid is not None and to in self.rigid.names:
            st.add_rigid(to, **self.rigid.pop(to))
        elif to in st.names and st._body(to)["kind"] in ("point", "rigid"):
            pass  # already in the structure
        else:
            raise InputError(f"{key}.to", f"no point mass or rigid body named {to!r}")
        st.attach(elastic, idx, to)

    # -- events -------------------------------------------------------------------------
    def add_event(
        self, kind: str, *, body=None, value=None, direction=None, stop: bool = False, other=None, label=None,
        dv=None, frame=None, after=None, sun=None, shadow=None, key: str | None = None, strict: bool = False,
    ):  # fmt: skip
        """Add an event: a zero crossing of a function of the state, found after every step and
        located to round-off in time (:mod:`emorbit.events` has the kinds and the method).

        Parameters
        ----------
        kind : str
            ``"radius"``, ``"altitude"`` (above the field's radius), ``"periapsis"``,
            ``"apoapsis"``, ``"node"`` (the scene's z = 0 plane), ``"time"``, ``"distance"`` or
            ``"eclipse"``.
        body : str, optional
            The body whose state it reads (a rigid or elastic body's centre of mass); not for
            ``time``.
        value : Quantity, str or float, optional
            The level: a length for radius, altitude and distance, a time for time (SI numbers
            are m and s).
        direction : str, optional
            ``"rising"``, ``"falling"`` or ``"either"`` (default: the kind's; periapsis is
            rising, apoapsis falling, time rising only).
        stop : bool
            End the run at the event (status ``stopped``).
        other : str, optional
            The second body of ``distance``.
        label : str, optional
            Its name in the log (default ``<kind>[<i>]``).
        dv : sequence of 3, optional
            An impulse added to the body's velocity at the event, once (velocities: Quantities,
            strings with units, or m/s), in ``frame``; its work is recorded as
            ``work_manoeuvres`` and kept in the energy balance.
        frame : str, optional
            ``"inertial"`` (default), ``"rsw"`` (radial, along-track, orbit normal) or
            ``"vnc"`` (velocity, orbit normal, their cross product), at the body's state.
        after : str, optional
            The label of an event that must have happened before this one counts.
        sun : sequence of 3, optional
            An eclipse's fixed direction to the Sun, in the scene's axes (default: the Sun of
            astropy's builtin ephemeris, from the run's epoch).
        shadow : str, optional
            An eclipse's edge: ``"cylindrical"`` (default), or the conical shadow's
            ``"penumbra"`` or ``"umbra"`` (the edges of radiation pressure's default shadow).
        key : str, optional
            Its name in errors (default ``event[<i>]``).
        strict : bool
            Require units on the value (scenes do).

        Returns
        -------
        emorbit.events.Event

        Raises
        ------
        InputError
            A key the kind does not take or lacks, a bad value or direction, altitude in a
            field without a radius.
        """
        key = key or f"event[{len(self.events)}]"
        has_radius = self.field is not None and self.field.radius > 0
        if kind in ("radius", "altitude", "periapsis", "apoapsis", "node", "eclipse") and self.field is None:
            raise InputError(
                f"{key}.kind", f"a {kind} event is measured from the field's centre: the scene needs a [field]"
            )
        return self.events.add(
            kind, body=body, value=value, direction=direction, stop=stop, other=other, label=label, dv=dv,
            frame=frame, after=after, sun=sun, epoch=self.epoch, key=key, strict=strict, has_radius=has_radius,
            shadow=shadow,
        )  # fmt: skip

    # -- effects ------------------------------------------------------------------------
    def add_effect(self, kind: str, *, key: str | None = None, strict: bool = False, folder: str = "", **keys):
        """Add an effect beyond the central field (:mod:`emorbit.effects` lists the shipped ones
        and their keys; a user's own is registered with :func:`emorbit.effects.register`, or
        named by its ``file``).

        Every body kind the effect acts on feels it (point masses at their positions, rigid
        bodies at their mass points or facets, elastic bodies at their gravity points or
        surfaces), with every method it allows; its potential energy is recorded as
        ``invariants/potential_<label>``, or, for an effect that does work, its work as
        ``invariants/work_<label>``.

        Parameters
        ----------
        kind : str
            The effect.
        key : str, optional
            The name errors give the effect (default ``effect[<i>]``).
        strict : bool
            Require units on every dimensional value (scenes do).
        folder : str
            Where a relative ``file`` key is found (a scene's folder).
        **keys
            The effect's keys, e.g. ``model="earth", degree=2``, ``bodies=["a", "b"]`` or
            ``atmosphere="exponential", density=..., reference_altitude=..., scale_height=...``
            (Quantities, strings with units or SI numbers).

        Returns
        -------
        Effect
            The effect added.

        Raises
        ------
        InputError
            An unknown effect or key, a value the effect refuses, a second one of a kind a
            scene names once, a method it cannot run with, bodies that lack a key it requires,
            an effect of a central field in free space, or bodies that started running.
        """
        key = key or f"effect[{len(self.effects.named)}]"
        if self.structure is not None and self.structure._built:
            raise InputError(key, "effects cannot be added after the structure has started running")
        effect = self.effects.add({"kind": kind, **keys}, key, None, strict, folder)
        try:
            if effect.needs_epoch and self.epoch is None:
                raise InputError(
                    "epoch",
                    f"{key} ({kind}) follows the calendar (an ephemeris, a dated atmosphere, the Earth's "
                    'rotation): give the run\'s epoch, e.g. epoch = "2000-01-01T12:00:00 TDB"',
                )
            self.effects.check_method(self.method)
            for system in self.systems:
                for name in system.names:
                    self._require_values(system, name, getattr(system, "values", {}).get(name, {}))
        except InputError:
            self.effects.remove(effect)
            raise
        if self.effects.pair_effects() and ((self.rigid is not None and len(self.rigid)) or self.structure):
            self._gather()
        return effect

    def _body_values(self, body_kind: str, given: dict, strict: bool, key: str) -> dict:
        """The effect keys given for a new body, in SI (each checked by the key's declaration)."""
        from .effects import EFFECTS

        known = {bk.name: bk for cls in EFFECTS.values() for bk in cls.BODY_KEYS if body_kind in bk.kinds}
        values = {}
        for name, raw in given.items():
            if name not in known:
                raise InputError(
                    f"{key}.{name}",
                    f"unknown key of a {body_kind} body; effect keys: {', '.join(sorted(known)) or 'none'}",
                )
            if raw is not None:
                values[name] = known[name].value(raw, f"{key}.{name}", strict)
        missing = [bk for bk in self.effects.body_keys(body_kind) if bk.name not in values]
        if missing:
            bk = missing[0]
            raise InputError(f"{key}.{bk.name}", f"{bk.key.meaning}; the simulation's effects require it")
        return values

    def _require_values(self, system, name: str, values: dict) -> None:
        """A body already added has every key the effects require of its kind."""
        kind = "point" if system is self.points else system.kind
        for bk in self.effects.body_keys(kind):
            if bk.name not in values:
                raise InputError(f"body[{name!r}].{bk.name}", f"{bk.key.meaning}; the simulation's effects require it")

    def _structure(self):
        """The simulation's structure, created with the first elastic body (or when an effect
        between pairs of bodies reaches a rigid or elastic one)."""
        if self.structure is None:
            from .bodies.coupled import Structure

            self.structure = Structure(self.plan)
            self.structure.effects = EffectBinding(self.effects, "elastic")
        if self.structure._built:
            raise InputError("body", "bodies and couplings cannot be added after the structure has started running")
        return self.structure

    def _gather(self) -> None:
        """An effect between pairs of bodies that reaches a rigid or elastic body: every point
        mass and rigid body joins the structure (one system, one Newton iteration per step)."""
        st = self._structure()
        for name in list(self.points.names):
            values = self.points.values.get(name, {})
            st.add_point(name, *self.points.pop(name), values)
        for name in list(self.rigid.names) if self.rigid is not None else ():
            st.add_rigid(name, **self.rigid.pop(name))

    def check(self) -> None:
        """Check the effects and the plan against the bodies, the method and the device (a
        scene does it when built, :meth:`run` before it starts).

        Raises
        ------
        InputError
            An effect names a body that does not exist or that it does not act on, an effect
            between pairs reaches fewer than two bodies, a method it cannot run with, point
            masses under effects on the GPU, or ``roundoff = "fast"`` where a body's path does
            not honour it (:meth:`~emorbit.integrators.plan.Plan.check_roundoff`); naming the
            key.
        """
        under = self.points.under_effects()
        self.plan.check_roundoff(
            {
                "points in the central field": len(self.points) > 0 and not under,
                "point masses under effects": len(self.points) > 0 and under,
                "rigid bodies": self.rigid is not None and len(self.rigid) > 0,
                "elastic bodies": self.structure is not None and len(self.structure) > 0,
            }
        )
        kinds: dict = {"point": list(self.points.names), "rigid": list(self.rigid.names) if self.rigid else []}
        masses = dict(zip(self.points.names, map(float, self.points.masses)))
        if self.rigid is not None:
            masses.update(zip(self.rigid.names, map(float, self.rigid.mass)))
        for b in self.structure.bodies if self.structure is not None else ():
            kinds.setdefault(b["kind"], []).append(b["name"])
            if "mass" in b:
                masses[b["name"]] = b["mass"]
        self.effects.check_bodies(kinds, masses)
        self.effects.check_method(self.method)
        for system in self.systems:
            if not len(system) or self.method not in system.POINTS_ONLY:
                continue
            acting = [  # on surfaces, or at points with a force that depends on the velocity
                (e, kind, "acts on their surfaces" if e.acts_on(kind) == ON_SURFACES else "depends on the velocity")
                for kind, names in kinds.items()
                for e in self.effects.named
                if (e.acts_on(kind) == ON_SURFACES or e.acts_on(kind) and not type(e).EXPLICIT)
                and any(n in system and e.reaches(n) for n in names)
            ]
            if acting:
                e, kind, why = acting[0]
                raise InputError(
                    "method",
                    f"method {self.method!r} steps {kind} bodies under effects at their points' positions alone, "
                    f"and {e.key} ({e.kind}) {why}; use em",
                )
        if self.adaptive is not None and self.points.under_effects() and not self.effects.sets_time_scale("point"):
            raise InputError(
                "adaptive",
                "adaptive steps of point masses follow the time scale an effect sets (the central field's, mutual "
                "gravity's); these effects set none: give a [field] or use fixed steps",
            )
        if self.device == "gpu" and self.points.under_effects():
            e = self.effects.named[0]
            raise InputError(
                "device", f"point masses under effects run on the CPU: {e.key} ({e.kind}); use device 'cpu'"
            )
