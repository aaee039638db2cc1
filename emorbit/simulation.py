"""The scripting API's :class:`Simulation`: the field, the method and the bodies, run to a
time with records kept in memory and, optionally, written to an HDF5 file (the example is in
:mod:`emorbit`). Physical values accept astropy Quantities, strings with units or plain SI
floats. The stepping itself (compiled chunks, checkpoints, failed steps redone in
sub-steps) is its base class, :class:`~emorbit.stepping.ChunkDriver`.

Bodies of each kind live in a *system* that owns their arrays and calls their kernels:
:class:`~emorbit.bodies.pointmasses.PointMasses`, :class:`~emorbit.bodies.rigid.RigidBodies`
and :class:`~emorbit.bodies.coupled.Structure` (elastic bodies and what they are attached
to). Systems do not interact, so each advances on its own, and only the systems that have
bodies run: a point-mass scene never touches rigid-body code. Every system offers the
interface of :class:`emorbit.bodies.system.BodySystem`.
"""

from __future__ import annotations

import math
import numbers
import sys

import numpy as np

from .bodies.pointmasses import PointMasses
from .bodies.system import check_body_name, check_output
from .effect_setup import EffectSetup
from .epochs import to_epoch
from .errors import InputError
from .field import CentralField
from .integrators import METHODS, check_device, check_order, check_roundoff, get_method
from .integrators.dispatch import require_device
from .orbits import initial_state
from .result import Result
from .state import StateQueries
from .stepping import ChunkDriver
from .units import to_count, to_si, vector_to_si

__all__ = ["Simulation", "check_body_name", "MAX_STEPS", "MAX_OUTPUT"]

#: the most steps one run takes (the step counters are int64)
MAX_STEPS = 2**63 - 1
#: the default limit of a run's projected output (file, or records kept in memory)
MAX_OUTPUT = "10 GB"


def _steps_between(t_start: float, t_end: float, dt: float, key: str, dt_key: str = "dt") -> int:
    """Whole steps from t_start to t_end: the nearest count if within 1e-9 relative, else rounded up
    (at most :data:`MAX_STEPS`)."""
    span = (t_end - t_start) / dt
    if not span <= MAX_STEPS:
        raise InputError(
            key,
            f"t_end = {t_end!r} s is {span:.3g} steps of {dt_key} = {dt!r} s from {t_start!r} s, more than a run "
            f"can count ({MAX_STEPS}); shorten t_end or raise {dt_key}",
        )
    nearest = round(span)
    n = nearest if abs(span - nearest) <= 1e-9 * max(1.0, abs(span)) else math.ceil(span)
    if n < 1:
        raise InputError(key, f"t_end = {t_end!r} s is not after the current time {t_start!r} s (dt = {dt!r} s)")
    return int(n)


class Simulation(EffectSetup, StateQueries, ChunkDriver):
    """Bodies in a central field (or in free space), advanced by one method at a fixed step.

    Bodies are added with :meth:`add_point`, :meth:`add_rigid` and :meth:`add_elastic`,
    tied together with :meth:`attach`, and advanced with :meth:`run`.

    Parameters
    ----------
    field : CentralField or None
        The field; ``None`` is free space (no gravity; rigid and elastic bodies only).
    method : str
        A name in :data:`emorbit.METHODS`: ``"em"`` (energy-momentum, the default),
        ``"midpoint"`` or ``"leapfrog"``.
    order : int
        2 (the base step) or 4, 6, 8 (symmetric compositions of it, :data:`emorbit.ORDERS`).
    dt : Quantity, str or float
        The step, s.
    max_newton_iterations : int
        Newton iterations allowed per implicit sub-step before the step is retried in
        sub-steps (and, if those fail too, the run stops).
    newton : str
        Elastic structures only: ``"full"`` refactors the Jacobian at every iteration,
        ``"reuse"`` keeps sparse LU factors while they converge fast, ``"auto"`` (default)
        picks by size (see :class:`~emorbit.bodies.coupled.Structure`).
    adaptive : float, optional
        The accuracy knob eta of adaptive, time-symmetric steps of about eta times the
        fastest time scale, chosen from both ends of each step (a reversible controller;
        errors fall as eta**order): point masses follow the local Kepler time,
        h ~ eta 2 pi sqrt(r^3 / GM) (:mod:`emorbit.kernels.pointmass.adaptive`); a rigid
        body also its rotation, h ~ eta 2 pi / sqrt(GM / r^3 + |w|^2)
        (:mod:`emorbit.kernels.rigid_adaptive`); a structure of elastic bodies also its
        highest elastic frequency (:mod:`emorbit.bodies.coupled_adaptive`), which on stiff
        structures makes it far dearer than fixed steps over those modes. ``dt`` is then the
        unit of the record grid only: records land exactly on multiples of ``every * dt``.
        The central field only: effects run with fixed steps. A number in (0, 1]; default:
        fixed steps of ``dt``.
    roundoff : str
        Point masses with method ``"em"``: ``"brouwer"`` (default) keeps the energy error a
        random walk over many steps (Brouwer's law, no drift of one sign): a fixed step
        takes the exact root of its scalar equation correctly rounded (a Newton update
        certified to be it, else one on an accurate evaluation), and steps with a large
        h^2/2 GM / (r0 r1 (r0 + r1)) finish on g_em evaluated to within a rounding (see
        :mod:`emorbit.kernels.pointmass.packed`). ``"fast"`` solves the equation in plain
        floating point: a little cheaper per step, with an energy drift
        at round-off level (methods.md compares the two). Rigid and elastic bodies ignore it.
    epoch : astropy.time.Time or str, optional
        The instant the run's time 0 stands for (:func:`emorbit.epochs.to_epoch`:
        ``"2026-01-01T00:00:00 TDB"``); the clock then counts seconds of TDB from it.
        Required by the effects that take the Sun's or the Moon's position from an
        ephemeris (``srp``, ``third_body``).

    Attributes
    ----------
    points : PointMasses
        The point masses' system.
    rigid : RigidBodies or None
        The rigid bodies' system, created with the first rigid body.
    structure : Structure or None
        Elastic bodies and the bodies attached to them, created with the first elastic body.
    scene_text : str or None
        The scene text stored in output files (set by :meth:`emorbit.Scene.build`; when
        None, :meth:`to_toml` writes one).
    max_output : Quantity, str or float
        The default limit of :meth:`run`'s projected output, bytes: :data:`MAX_OUTPUT`, or
        a scene's ``integrator.max_output`` after :meth:`emorbit.Scene.build`.
    keys : dict
        How errors about the run's length and output name ``t_end``, ``dt``, ``every`` and
        ``max_output`` (as scene keys ``integrator.*`` after :meth:`emorbit.Scene.build`).
    drift_tolerance : float
        The default C of :meth:`run`'s drift bound C eps sqrt(n), 1000 (a scene's
        ``integrator.drift_tolerance`` sets it).
    epoch : astropy.time.Time or None
        The run's epoch in TDB (None: none given).

    Raises
    ------
    InputError
        An unknown method, order or roundoff, a step that is not a positive time, or an
        option that does not fit the field.
    """

    def __init__(
        self,
        field: CentralField | None,
        *,
        method: str = "em",
        order: int = 2,
        dt,
        max_newton_iterations: int = 50,
        newton: str = "auto",
        adaptive: float | None = None,
        roundoff: str = "brouwer",
        epoch=None,
    ):
        if field is not None and not isinstance(field, CentralField):
            raise InputError("field", f"expected a CentralField or None (free space), got {field!r}")
        self.field = field
        self.method = get_method(method).name
        self.order = check_order(order)
        self._dt = to_si(dt, "time", "dt", positive=True)
        self.max_newton_iterations = to_count(max_newton_iterations, "max_newton_iterations")
        if newton not in ("auto", "reuse", "full"):
            raise InputError("newton", f"must be 'auto', 'reuse' or 'full', got {newton!r}")
        self.newton = newton  # structures (elastic bodies) only: see emorbit.bodies.coupled.Structure
        if adaptive is not None:
            if isinstance(adaptive, bool) or not isinstance(adaptive, numbers.Real) or not 0 < adaptive <= 1:
                raise InputError(
                    "adaptive", f"must be a number in (0, 1] (steps per local Kepler time scale), got {adaptive!r}"
                )
        self.adaptive = None if adaptive is None else float(adaptive)
        self.roundoff = check_roundoff(roundoff)
        self.points = PointMasses()
        self.points.adaptive = self.adaptive
        self.points.roundoff = roundoff
        self.rigid = None  # created on the first rigid body, so point-mass runs never import it
        self.structure = None  # elastic bodies and what they are attached to
        self._t_base = 0.0
        self._steps = 0
        self.scene_text: str | None = None
        self.t_end_requested: float | None = None
        self.keys = {k: k for k in ("t_end", "dt", "every", "max_output")}
        self.max_output = MAX_OUTPUT
        self._effects: list = []  # the effects beyond the central field, in the order added
        self.epoch = None if epoch is None else to_epoch(epoch, "epoch")

    # -- set-up -----------------------------------------------------------------------
    @property
    def dt(self) -> float:
        """The step, s."""
        return self._dt

    @property
    def time(self) -> float:
        """The current time, s."""
        return self._t_base + self._steps * self._dt

    @property
    def gm(self) -> float:
        """GM of the field, m^3/s^2 (0 in free space)."""
        return self.field.gm if self.field is not None else 0.0

    @property
    def center(self) -> np.ndarray:
        """The field's centre (3,), m (the origin in free space)."""
        return self.field.center if self.field is not None else np.zeros(3)

    @property
    def device(self) -> str:
        """Where the point masses run: ``"cpu"`` (default) or ``"gpu"``.

        The kernel is chosen by :mod:`emorbit.integrators.dispatch`. Rigid and elastic
        bodies always run on the CPU. Setting ``"gpu"`` checks at once that a CUDA device is
        present and that the run can use it (fixed steps), else raises an
        :class:`~emorbit.errors.InputError`.
        """
        return self.points.device

    @device.setter
    def device(self, device: str) -> None:
        device = check_device(device)
        if device == "gpu":
            require_device(device)
            if self.adaptive is not None:
                raise InputError("device", "adaptive steps run on the CPU only; use device 'cpu'")
        self.points.device = device

    @property
    def systems(self) -> list:
        """The body systems that have bodies, in a fixed order (points, rigid, structure)."""
        return [s for s in (self.points, self.rigid, self.structure) if s is not None and len(s)]

    @property
    def names(self) -> list[str]:
        """Body names, in the order of their systems and then of adding."""
        return [n for s in self.systems for n in s.names]

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
        ballistic_coefficient=None,
        radiation_coefficient=None,
        strict: bool = False,
        key: str | None = None,
    ) -> None:
        """Add a point mass: a test particle that feels the field and nothing else.

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
        ballistic_coefficient : Quantity, str or float, optional
            ``Cd A / m``, m^2/kg (>= 0; 0: no drag): how strongly drag
            (``add_effect("drag")``) acts on the point; required when the simulation has drag.
        radiation_coefficient : Quantity, str or float, optional
            ``Cr A / m``, m^2/kg (>= 0; 0: none): how strongly solar radiation pressure
            (``add_effect("srp")``) pushes the point, a cannonball; required with srp.
        strict : bool
            Require units on every value.
        key : str, optional
            Prefix of the keys that error messages name (default ``body['<name>']``).

        Raises
        ------
        InputError
            A bad value, a taken name, no field, a position at the centre or inside the
            central body, a radial fall into a centre without radius (see
            :meth:`CentralField.check_start`), a method without a point-mass kernel, or no
            ballistic coefficient under drag.
        """
        key = key or f"body[{name!r}]"
        self._new_name(name, key)
        if self.field is None and not any(t.kind == "mutual" for t in self._effects):
            raise InputError(
                "field",
                f"{key} is a point mass, which needs a central field or mutual gravity (add_effect('mutual')); "
                "this simulation has neither",
            )
        m = to_si(mass, "mass", f"{key}.mass", strict=strict, positive=True)
        bc, rc = self._point_coefficients(ballistic_coefficient, radiation_coefficient, strict, key)
        position, velocity, xkey, vkey = initial_state(position, velocity, orbit, self.field, strict=strict, key=key)
        x = vector_to_si(position, "length", xkey, strict=strict)
        v = vector_to_si(velocity, "speed", vkey, strict=strict)
        self._check_method_supports(self.points, key)
        if self.field is not None:
            self.field.check_start(x, x, v, gravity=True, key=xkey, what=f"{x.tolist()} m", motion_key=vkey)
        if self.structure is not None and self.structure.mutual:  # mutual gravity with other bodies
            for given, which in ((bc, "ballistic_coefficient"), (rc, "radiation_coefficient")):
                if given is not None:
                    raise InputError(
                        f"{key}.{which}", "drag and radiation pressure act on point masses outside a structure"
                    )
            self._structure().add_point(name, m, x, v)
            return
        self.points.add(name, m, x, v)
        if bc is not None:
            self.points.ballistic[name] = bc
        if rc is not None:
            self.points.radiation[name] = rc

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
        from .bodies.rigid import RigidBodies, build_rigid

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
            has_field=self.field is not None,
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
            self.rigid = RigidBodies()
            self.rigid.adaptive = self.adaptive
            self.rigid.zonal = next((t for t in self._effects if t.kind == "zonal"), None)
            self.rigid.effects = self._rigid_terms()
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
        if any(t.kind == "mutual" for t in self._effects):
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

        See :mod:`emorbit.bodies.elastic` for the meshes and materials.

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
            or a method without an elastic kernel (em and midpoint have one).
        """
        from .bodies import elastic as el
        from .bodies.facets import facet_coefficients

        key = key or f"body[{name!r}]"
        self._new_name(name, key)
        position, velocity, xkey, vkey = initial_state(position, velocity, orbit, self.field, strict=strict, key=key)
        if self.method not in ("em", "midpoint"):
            raise InputError(
                "method", f"method {self.method!r} has no elastic-body kernel (needed by {key}); use em or midpoint"
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
            has_field=self.field is not None,
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
        if any(t.kind == "mutual" for t in self._effects):
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
            No such bodies, bad node indices or selector, or a node that does not start on
            the point mass.
        """
        from .bodies.elastic import select_nodes

        st = self._structure()
        if elastic not in st.names or st._body(elastic)["kind"] != "elastic":
            raise InputError(f"{key}.elastic", f"no elastic body named {elastic!r}")
        spec = st._body(elastic)["spec"]
        idx = select_nodes(spec.ref, nodes, f"{key}.nodes")
        if to == elastic:
            raise InputError(f"{key}.to", "a body cannot be attached to itself")
        if to in self.points:
            if self.points.ballistic.get(to, 0.0) != 0.0 and any(t.kind == "drag" for t in self._effects):
                raise InputError(
                    f"body[{to!r}].ballistic_coefficient",
                    "a point mass attached to an elastic body joins its structure, where drag acts on the elastic "
                    "bodies' surfaces and the rigid bodies' facets: give it 0",
                )
            st.add_point(to, *self.points.pop_onto(to, idx, spec.nodes[idx], f"{key}.nodes"))
        elif self.rigid is not None and to in self.rigid.names:
            st.add_rigid(to, **self.rigid.pop(to))
        elif to in st.names and st._body(to)["kind"] in ("point", "rigid"):
            pass  # already in the structure
        else:
            raise InputError(f"{key}.to", f"no point mass or rigid body named {to!r}")
        st.attach(elastic, idx, to)

    # -- running ----------------------------------------------------------------------
    def steps_until(self, t_end) -> int:
        """Number of steps from now to a time.

        Parameters
        ----------
        t_end : Quantity, str or float
            The time to reach, s.

        Returns
        -------
        int
            Whole steps; the nearest count when within 1e-9 relative of one, else rounded up.

        Raises
        ------
        InputError
            ``t_end`` is not after the current time, or is more than :data:`MAX_STEPS` steps
            ahead.
        """
        k = self.keys
        return _steps_between(self.time, to_si(t_end, "time", k["t_end"]), self._dt, k["t_end"], k["dt"])

    def run(
        self,
        t_end=None,
        *,
        steps: int | None = None,
        every: int = 1,
        output=None,
        overwrite: bool = False,
        progress: bool | None = None,
        keep: bool = True,
        checkpoint_every: int | None = None,
        max_output=None,
        strict: bool = False,
        drift_tolerance: float | None = None,
    ) -> Result:
        """Advance to a time, or by a number of steps, recording every ``every`` steps.

        The start state is the first record and the end state always the last. The run ends
        on a whole step: ``t_end`` is rounded up to a multiple of ``dt`` unless it is within
        1e-9 relative of one. A step whose Newton iteration fails is redone in 2, 4, ... 16
        sub-steps (each an ordinary step, so conservation is kept) before the run stops.

        Parameters
        ----------
        t_end : Quantity, str or float, optional
            The time to reach, s. Give exactly one of ``t_end`` and ``steps``.
        steps : int, optional
            The number of steps to take.
        every : int
            Steps between records.
        output : str, bytes or os.PathLike, optional
            An HDF5 file to write while running (layout: :mod:`emorbit.io.reader`).
        overwrite : bool
            Replace an existing ``output`` (otherwise an existing file is an error).
        progress : bool, optional
            A progress bar on stderr (shown after 2 s); default: when stderr is a terminal.
        keep : bool
            Keep every record in memory; if false the returned Result holds the first and
            the last record only (the file, if any, has them all).
        checkpoint_every : int, optional
            Steps between checkpoints, rounded up to a multiple of ``every`` (default: by
            wall time, at most 5 s between checkpoints, on records). At each checkpoint the records
            so far and the complete state are flushed to the file, so a run killed at any
            moment leaves a readable file that ``emorbit resume`` continues bit for bit
            (:mod:`emorbit.io.resume`).
        max_output : Quantity, str or float, optional
            The largest output the run may project, bytes (a string such as ``"50 GB"``;
            default :attr:`max_output`): the records (every dataset of every body, nodal
            positions included) that go to ``output`` or, with ``keep``, stay in memory. A
            longer run is refused before anything is created, naming ``t_end``, ``dt``,
            ``every`` and this limit.
        strict : bool
            Raise :class:`~emorbit.errors.RoundoffError` instead of issuing a
            :class:`~emorbit.errors.RoundoffWarning` when a conserved invariant drifts beyond
            what round-off explains (after the file is complete).
        drift_tolerance : float, optional
            C of that bound, C eps sqrt(n) for n implicit sub-steps (default
            :attr:`drift_tolerance`, 1000; :mod:`emorbit.io.drift`); ``inf`` switches it off.

        Returns
        -------
        Result
            The records of this run.

        Raises
        ------
        InputError
            No bodies, bad arguments, more than :data:`MAX_STEPS` steps, a projected output
            above ``max_output``, a ``drift_tolerance`` that is not a number > 0, or an
            output file that exists.
        RoundoffError
            With ``strict``: a conserved invariant drifted beyond the bound (the file is
            complete, its status "completed").
        IntegrationError
            A step failed even in sub-steps, or a body came inside the central body's
            radius; the simulation and the file hold the state before it.
        KeyboardInterrupt
            Ctrl-C (SIGINT) or SIGTERM stops the run at the end of the chunk in progress:
            the records so far and the final state are written and the file is marked
            "interrupted" (the exception is a :class:`~emorbit.stepping.RunInterrupted`
            naming the signal).
        """
        if not self.systems:
            raise InputError("body", "the simulation has no bodies; add one with add_point() or add_rigid()")
        if self._effects:
            self._check_effects()
        if (t_end is None) == (steps is None):
            raise InputError("t_end", "give exactly one of t_end and steps")
        n_steps = to_count(steps, "steps", 1, MAX_STEPS) if steps is not None else self.steps_until(t_end)
        every = to_count(every, "output_every")
        if output is not None or keep:
            length_key = "steps" if steps is not None else self.keys["t_end"]
            limit = self.max_output if max_output is None else max_output
            check_output(self.systems, n_steps, every, self._dt, limit, self.keys, length_key)
        if progress is None:
            progress = sys.stderr.isatty()
        self._strict = bool(strict)
        return self._start_run(n_steps, every, output, overwrite, keep, checkpoint_every, progress, drift_tolerance)

    # -- scene text ---------------------------------------------------------------------
    def to_toml(self, t_end: float | None = None, output_every: int = 1) -> str:
        """This simulation's set-up as a scene (TOML text) in SI units.

        Point masses are exact to the last bit; rigid bodies are written with their shape
        parameters (see :func:`emorbit.io.scene_toml.simulation_to_toml`).

        Parameters
        ----------
        t_end : float, optional
            The scene's ``t_end``, s (default: one step from now).
        output_every : int
            The scene's ``output_every``.

        Returns
        -------
        str
            The scene.
        """
        from .io.scene_toml import simulation_to_toml

        return simulation_to_toml(self, t_end=t_end, output_every=output_every)


# METHODS is re-exported for discoverability: Simulation.METHODS lists what `method` accepts
Simulation.METHODS = METHODS
