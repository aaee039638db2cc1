"""The scripting API: a :class:`Simulation` holds the field, the method and the bodies, and
runs them in compiled chunks, recording every ``every`` steps to memory and, optionally, to
an HDF5 file while it runs.

Example::

    import astropy.units as u
    import emorbit

    sim = emorbit.Simulation(emorbit.CentralField(gm=3.9478 * u.m**3 / u.s**2),
                             method="em", order=2, dt=0.464758 * u.s)
    sim.add_point("satellite", mass=1 * u.kg, position=[10, 0, 0] * u.m,
                  velocity=[0, 0.36276, 0] * u.m / u.s)
    result = sim.run(t_end=4647.58 * u.s, every=10, output="paper.h5")
    print(abs(result.relative_energy_error()).max())

Physical values accept astropy Quantities, strings with units or plain SI floats.

Bodies of each kind live in a *system* (:class:`~emorbit.bodies.pointmasses.PointMasses`,
:class:`~emorbit.bodies.rigid.RigidBodies`) that owns their arrays and kernel. Bodies do not
interact, so every system advances on its own; only the systems that have bodies run, so a
point-mass scene never touches rigid-body code. A system offers: ``names``, ``DATASETS``,
``METHODS``, ``work_per_step()``, ``advance(...)``, ``current()``, ``snapshot()``,
``restore()``, ``invariants(...)``, ``datasets(...)``, ``body_attrs(i)``, ``body_constants(i)``.
"""

from __future__ import annotations

import math
import numbers
import signal
import sys
import threading

import numpy as np

from .bodies.pointmasses import PointMasses
from .errors import InputError, IntegrationError
from .field import CentralField
from .integrators import METHODS, check_device, check_order, check_roundoff, coefficients, get_method
from .integrators.dispatch import require_device
from .io.hdf5 import Writer
from .io.recorder import Sink, progress_bar
from .kernels.codes import STATUS_NO_CONVERGENCE
from .orbits import OrbitalElements, elements
from .result import Result
from .units import to_si, vector_to_si

__all__ = ["Simulation", "check_body_name"]

#: body-substeps (weighted by system cost) per compiled chunk: about 0.5 s of em work
CHUNK_WORK = 4_000_000
#: bytes of recorded state per chunk at most
CHUNK_BYTES = 128 * 2**20

#: the arrays that are a system's whole state (compensation terms and warm starts included):
#: what a checkpoint stores and a restart restores, bit for bit
STATE_FIELDS = {
    "point": ("x", "v", "cx", "cv"),
    "rigid": ("q", "v", "cq", "cv", "lam"),
    "structure": ("u", "v", "cu", "cv", "lam", "acc"),
}


def check_body_name(name, key: str = "name") -> str:
    """A body name must be a non-empty string without '/' (it names an HDF5 group)."""
    if not isinstance(name, str) or not name.strip() or "/" in name or name in (".", ".."):
        raise InputError(key, f"a body name must be a non-empty string without '/', got {name!r}")
    return name


def _steps_between(t_start: float, t_end: float, dt: float, key: str) -> int:
    """Whole steps from t_start to t_end: the nearest count if within 1e-9 relative, else rounded up."""
    span = (t_end - t_start) / dt
    nearest = round(span)
    n = nearest if abs(span - nearest) <= 1e-9 * max(1.0, abs(span)) else math.ceil(span)
    if n < 1:
        raise InputError(key, f"t_end = {t_end!r} s is not after the current time {t_start!r} s (dt = {dt!r} s)")
    return int(n)


class Simulation:
    """Bodies in a central field (or in free space), advanced by one method at a fixed step.

    Parameters
    ----------
    field : CentralField or None
        the field; ``None`` is free space (no gravity; rigid bodies only).
    method : str
        a name in :data:`emorbit.integrators.METHODS` (``"em"``, ``"midpoint"``, ``"leapfrog"``).
    order : int
        2 (the base step) or 4, 6, 8 (symmetric compositions).
    dt : Quantity, str or float
        the step in s.
    max_newton_iterations : int
        Newton iterations allowed per implicit sub-step before the step fails.
    adaptive : float, optional
        point masses only: step by ``adaptive`` times the local Kepler time scale,
        h = adaptive * 2 pi sqrt(r^3 / GM), at most ``dt``; records stay on the grid of
        ``dt`` (see :mod:`emorbit.kernels.pointmass.adaptive`). Default: fixed steps of ``dt``.
    roundoff : str
        point masses, method "em": "brouwer" (default) keeps the energy error a random walk
        over many steps (Brouwer's law; the drift left is below 2e-22 |E| per step at T/100
        and at T/1000, measured in README "Round-off"): fixed steps take the exact root of
        their scalar equation correctly rounded (a Newton update with a certificate that it
        is, else one on an accurate evaluation; steps with a large
        h**2/2 GM / (r0 r1 (r0 + r1)) and adaptive steps finish on ``g_em`` evaluated to
        within a rounding instead, :func:`emorbit.kernels.pointmass.em_finish`; see
        :mod:`emorbit.kernels.pointmass.packed`). "fast" skips that (measured on a 2-core AMD EPYC:
        about 100 instead of 109 ns per step on one orbit, 8.7 instead of 10.2 ns per
        particle-step of the benchmark ensemble on one thread; README "What accuracy
        costs"), leaving a drift of 4e-20 to
        1.7e-19 |E| per step on the paper's orbit at T/100. Rigid and elastic bodies ignore it.
    newton : str
        for elastic structures: "full" refactors the Jacobian at every iteration, "reuse" keeps
        sparse LU factors while they converge fast, "auto" (default) picks by size (see
        :class:`emorbit.bodies.coupled.Structure`).
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
    ):
        if field is not None and not isinstance(field, CentralField):
            raise InputError("field", f"expected a CentralField or None (free space), got {field!r}")
        self.field = field
        self.method = get_method(method).name
        self.order = check_order(order)
        self._dt = to_si(dt, "time", "dt", positive=True)
        if (
            isinstance(max_newton_iterations, bool)
            or not isinstance(max_newton_iterations, numbers.Integral)
            or max_newton_iterations < 1
        ):
            raise InputError("max_newton_iterations", f"must be an integer >= 1, got {max_newton_iterations!r}")
        self.max_newton_iterations = int(max_newton_iterations)
        if newton not in ("auto", "reuse", "full"):
            raise InputError("newton", f"must be 'auto', 'reuse' or 'full', got {newton!r}")
        self.newton = newton  # structures (elastic bodies) only: see emorbit.bodies.coupled.Structure
        if adaptive is not None:
            if isinstance(adaptive, bool) or not isinstance(adaptive, numbers.Real) or not 0 < adaptive <= 1:
                raise InputError(
                    "adaptive", f"must be a number in (0, 1] (steps per local Kepler time scale), got {adaptive!r}"
                )
            if field is None:
                raise InputError("adaptive", "adaptive steps follow the Kepler time scale: they need a central field")
        self.adaptive = None if adaptive is None else float(adaptive)
        self.roundoff = check_roundoff(roundoff)
        self.points = PointMasses()
        self.points.adaptive = self.adaptive
        self.points.roundoff = roundoff
        self.rigid = None  # created on the first rigid body, so point-mass runs never import it
        self.structure = None  # elastic bodies and what they are attached to
        self._t_base = 0.0
        self._steps = 0
        #: the scene text stored in output files (set by :meth:`emorbit.scene.Scene.build`)
        self.scene_text: str | None = None
        self.t_end_requested: float | None = None

    # -- set-up -----------------------------------------------------------------------
    @property
    def dt(self) -> float:
        """The step in s."""
        return self._dt

    @property
    def time(self) -> float:
        """The current time in s."""
        return self._t_base + self._steps * self._dt

    @property
    def gm(self) -> float:
        """GM of the field in m^3/s^2 (0 in free space)."""
        return self.field.gm if self.field is not None else 0.0

    @property
    def center(self) -> np.ndarray:
        """The field's centre in m (the origin in free space)."""
        return self.field.center if self.field is not None else np.zeros(3)

    @property
    def device(self) -> str:
        """Where the point masses run: "cpu" (default) or "gpu" (see
        :mod:`emorbit.integrators.dispatch`). Rigid and elastic bodies always run on the CPU.
        Setting "gpu" checks at once that a CUDA device is present and that the run can use
        it (fixed steps of a method with a CUDA kernel), else raises an :class:`InputError`."""
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

    def add_point(self, name: str, *, mass, position, velocity, strict: bool = False, key: str | None = None) -> None:
        """Add a point mass (a test particle: it feels the field and nothing else).

        ``mass`` in kg (> 0), ``position`` in m and ``velocity`` in m/s as 3-vectors.
        ``strict`` requires units on every value; ``key`` prefixes error messages.
        """
        key = key or f"body[{name!r}]"
        self._new_name(name, key)
        if self.field is None:
            raise InputError("field", f"{key} is a point mass, which needs a central field; this simulation has none")
        m = to_si(mass, "mass", f"{key}.mass", strict=strict, positive=True)
        x = vector_to_si(position, "length", f"{key}.position", strict=strict)
        v = vector_to_si(velocity, "speed", f"{key}.velocity", strict=strict)
        r = float(np.linalg.norm(x - self.field.center))
        if not r > 0.0:
            raise InputError(f"{key}.position", f"{x.tolist()} m is at the field's centre, where gravity is singular")
        self._check_method_supports(self.points, key)
        self.points.add(name, m, x, v)

    def add_rigid(
        self,
        name: str,
        shape: str,
        *,
        position,
        velocity,
        attitude=None,
        rotation_vector=None,
        angular_velocity=(0.0, 0.0, 0.0),
        angular_velocity_frame: str = "body",
        gravity: str | None = None,
        strict: bool = False,
        key: str | None = None,
        **shape_params,
    ) -> None:
        """Add a rigid body discretised into mass points (see :mod:`emorbit.bodies.shapes`).

        shape            "box" (size), "cylinder" (radius, height), "sphere" (radius),
                         "shell" (radius, mass), "dumbbell" (masses, length[, end_radius]) or
                         "mesh" (nodes, tetrahedra, density[, mesh_unit]); plus density or mass
                         and refinement (elements per edge, default 1) where they apply
        position, velocity  of the centre of mass (m, m/s)
        attitude         unit quaternion (w, x, y, z) rotating body axes into space, or
        rotation_vector  angle * axis (rad); default: body axes = space axes
        angular_velocity rad/s, in the body frame (default) or ``angular_velocity_frame="space"``
        gravity          "volume" (the field summed over the mass points: gravity-gradient
                         torque), "point" (all mass at the centre of mass, no torque) or
                         "none" (free motion); default "volume" with a field, "none" without
        """
        from .bodies.rigid import RigidBodies, build_rigid

        key = key or f"body[{name!r}]"
        self._new_name(name, key)
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
        if self.adaptive is not None:
            raise InputError("adaptive", f"adaptive steps are for point masses only ({key} is a rigid body)")
        if spec["gravity"] != "none":
            x = spec["position"][:, None] + spec["R"] @ spec["points"].X
            if not np.all(np.linalg.norm(x - self.center[:, None], axis=0) > 0):
                raise InputError(f"{key}.position", "a mass point of the body is at the field's centre")
        if self.rigid is None:
            self.rigid = RigidBodies()
        self._check_method_supports(self.rigid, key)
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
        )

    def _structure(self):
        if self.structure is None:
            from .bodies.coupled import Structure

            self.structure = Structure(newton=self.newton)
        if self.structure._built:
            raise InputError("body", "bodies and couplings cannot be added after the structure has started running")
        return self.structure

    def add_elastic(
        self,
        name: str,
        mesh: str,
        *,
        position,
        velocity,
        young,
        density,
        poisson=None,
        area=None,
        attitude=None,
        rotation_vector=None,
        angular_velocity=(0.0, 0.0, 0.0),
        angular_velocity_frame: str = "body",
        gravity: str | None = None,
        mass_matrix: str = "consistent",
        node_output_every: int = 1,
        strict: bool = False,
        key: str | None = None,
        **mesh_params,
    ) -> None:
        """Add an elastic body (St. Venant-Kirchhoff bars and/or tetrahedra; see :mod:`emorbit.bodies.elastic`).

        mesh        "beam" (size, elements), "chain" (start, end, elements), "net" (size,
                    elements) or "file" (file[, mesh_unit]); node coordinates in the body frame
        young, poisson, density, area   E (Pa), nu (tetrahedra), rho (kg/m3), bar cross-section (m2)
        position, velocity, attitude / rotation_vector, angular_velocity[_frame]: the placement
                    and rigid initial motion of the body frame, as for rigid bodies
        gravity     "volume" (at the elements' quadrature points; default with a field) or "none"
        mass_matrix "consistent" or "lumped"
        node_output_every  records between nodal-position outputs in the file
        """
        from .bodies import elastic as el
        from .bodies.rigid import _attitude_matrix

        key = key or f"body[{name!r}]"
        self._new_name(name, key)
        if self.adaptive is not None:
            raise InputError("adaptive", f"adaptive steps are for point masses only ({key} is an elastic body)")
        if self.method not in ("em", "midpoint"):
            raise InputError(
                "method", f"method {self.method!r} has no elastic-body kernel (needed by {key}); use em or midpoint"
            )
        gravity = gravity or ("volume" if self.field is not None else "none")
        if gravity not in ("volume", "none"):
            raise InputError(f"{key}.gravity", f"must be 'volume' or 'none', got {gravity!r}")
        if gravity == "volume" and self.field is None:
            raise InputError(f"{key}.gravity", "'volume' needs a central field; without one use 'none'")
        E = to_si(young, "pressure", f"{key}.young", strict=strict, positive=True)
        rho = to_si(density, "density", f"{key}.density", strict=strict, positive=True)
        A = to_si(area, "area", f"{key}.area", strict=strict, positive=True) if area is not None else None
        if poisson is not None and (isinstance(poisson, bool) or not isinstance(poisson, numbers.Real)):
            raise InputError(f"{key}.poisson", f"a number expected, got {poisson!r}")
        X, tets, bars = el.mesh_from_parameters(mesh, mesh_params, strict, key)
        x = vector_to_si(position, "length", f"{key}.position", strict=strict)
        v = vector_to_si(velocity, "speed", f"{key}.velocity", strict=strict)
        R, omega = _attitude_matrix(attitude, rotation_vector, angular_velocity, angular_velocity_frame, strict, key)
        spec = el.elastic_spec(
            name,
            X,
            tets,
            bars,
            young=E,
            density=rho,
            poisson=poisson,
            area=A,
            mass_matrix=mass_matrix,
            position=x,
            velocity=v,
            R=R,
            omega_space=omega,
            gravity=gravity == "volume",
            node_output_every=node_output_every,
            key=key,
        )
        if gravity == "volume":
            d = np.linalg.norm(spec.nodes - self.center, axis=1)
            if not np.all(d > 0):
                raise InputError(f"{key}.position", "a node of the body is at the field's centre")
        self._structure().add_elastic(spec)

    def attach(self, elastic: str, nodes, to: str, key: str = "coupling") -> None:
        """Let nodes ``nodes`` (indices into the elastic body's mesh) of ``elastic`` ride on body
        ``to``: on a rigid body at the material point where each node is now, or, for a point
        mass, be that point mass (the node must start where the point mass is)."""
        st = self._structure()
        if elastic not in st.names or st._body(elastic)["kind"] != "elastic":
            raise InputError(f"{key}.elastic", f"no elastic body named {elastic!r}")
        spec = st._body(elastic)["spec"]
        try:
            idx = [int(n) for n in nodes]
        except (TypeError, ValueError):
            raise InputError(f"{key}.nodes", f"a list of node indices expected, got {nodes!r}") from None
        if not idx:
            raise InputError(f"{key}.nodes", "no nodes given")
        for n in idx:
            if not 0 <= n < spec.nodes.shape[0]:
                raise InputError(f"{key}.nodes", f"node {n} is not in 0..{spec.nodes.shape[0] - 1}")
        if to == elastic:
            raise InputError(f"{key}.to", "a body cannot be attached to itself")
        if to in self.points:
            # checked before the point leaves self.points: a refused attachment changes nothing
            if len(idx) != 1:
                raise InputError(f"{key}.nodes", f"a point mass takes exactly one node, got {len(idx)}")
            x = self.points.x[:, self.points.names.index(to)]
            if np.linalg.norm(spec.nodes[idx[0]] - x) > 1e-9 * max(1.0, np.linalg.norm(x)):
                raise InputError(
                    f"{key}.nodes",
                    f"node {idx[0]} starts at {spec.nodes[idx[0]].tolist()} m, "
                    f"not at point mass {to!r} ({x.tolist()} m)",
                )
            m, x, v = self.points.pop(to)
            st.add_point(to, m, x, v)
        elif self.rigid is not None and to in self.rigid.names:
            b = self.rigid.pop(to)
            st.add_rigid(
                to,
                b["points"],
                b["gravity"],
                b["position"],
                b["velocity"],
                b["R"],
                b["omega_space"],
                b["shape"],
                b["params"],
            )
        elif to in st.names and st._body(to)["kind"] in ("point", "rigid"):
            pass  # already in the structure
        else:
            raise InputError(f"{key}.to", f"no point mass or rigid body named {to!r}")
        st.attach(elastic, idx, to)

    # -- diagnostics of the current state ----------------------------------------------
    def _find(self, name: str):
        for s in self.systems:
            if name in s.names:
                return s, s.names.index(name)
        raise InputError("name", f"no body named {name!r}; bodies: {', '.join(self.names)}")

    def state(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and velocity (m/s) of body ``name`` now (its centre of mass), as (3,) arrays."""
        s, i = self._find(name)
        d = s.datasets(s.current(), 1)[name]
        return d["position"][0].copy(), d["velocity"][0].copy()

    def _invariants_now(self):
        parts = [s.invariants(s.current(), 1, self.gm, self.center) for s in self.systems]
        return [sum(p[j] for p in parts)[0] for j in range(3)]

    def energy(self) -> float:
        """Total energy now, in J."""
        return float(self._invariants_now()[0])

    def momentum(self) -> np.ndarray:
        """Total linear momentum now, in kg m/s."""
        return self._invariants_now()[1]

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum about the centre now, in kg m^2/s."""
        return self._invariants_now()[2]

    def elements(self, name: str) -> OrbitalElements:
        """Osculating elements of body ``name`` (its centre of mass) now."""
        if self.field is None:
            raise InputError("field", "orbital elements need a central field")
        x, v = self.state(name)
        return elements(x, v, self.field.gm, self.field.center)

    # -- running ----------------------------------------------------------------------
    def steps_until(self, t_end) -> int:
        """Number of steps from now to ``t_end`` (rounded up to whole steps)."""
        return _steps_between(self.time, to_si(t_end, "time", "t_end"), self._dt, "t_end")

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
    ) -> Result:
        """Advance to time ``t_end`` (or by ``steps`` steps), recording every ``every`` steps.

        The start state is the first record and the end state always the last. The run ends
        on a whole step: ``t_end`` is rounded up to a multiple of ``dt`` unless it is within
        1e-9 relative of one.

        output     HDF5 file to write while running (see :mod:`emorbit.io.hdf5`); an
                   existing file is an error unless ``overwrite``.
        progress   a progress bar on stderr (shown after 2 s); default: when stderr is a terminal.
        keep       keep all records in memory; if false the returned Result holds the first
                   and last record only (the file, if any, has them all).
        checkpoint_every  steps between checkpoints (rounded up to a multiple of ``every``;
                   default: about half a second of work, at least ``every``). At each
                   checkpoint the records so far and the complete state are flushed to the
                   file, so a run killed at any moment leaves a readable file that
                   ``emorbit resume`` continues bit for bit (see :mod:`emorbit.io.resume`).

        Raises :class:`~emorbit.errors.IntegrationError` when a step fails; the simulation
        and the file then hold the state at the start of the failing step. Ctrl-C (SIGINT)
        stops the run at the end of the chunk in progress: the records so far and the final
        state are written, the file is marked "interrupted", and KeyboardInterrupt is raised.
        """
        if not self.systems:
            raise InputError("body", "the simulation has no bodies; add one with add_point() or add_rigid()")
        if (t_end is None) == (steps is None):
            raise InputError("t_end", "give exactly one of t_end and steps")
        if steps is not None:
            if isinstance(steps, bool) or not isinstance(steps, numbers.Integral) or steps < 1:
                raise InputError("steps", f"must be an integer >= 1, got {steps!r}")
            n_steps = int(steps)
        else:
            n_steps = self.steps_until(t_end)
        if isinstance(every, bool) or not isinstance(every, numbers.Integral) or every < 1:
            raise InputError("output_every", f"must be an integer >= 1, got {every!r}")
        every = int(every)
        if progress is None:
            progress = sys.stderr.isatty()

        if self.structure is not None:
            self.structure.build()
        cp = self._checkpoint_steps(checkpoint_every, every)
        writer = None
        if output is not None:
            bodies = [
                {"name": n, "attrs": s.body_attrs(i), "datasets": s.body_datasets(i), "constants": s.body_constants(i)}
                for s in self.systems
                for i, n in enumerate(s.names)
            ]
            attrs = self._file_attrs(every, n_steps)
            attrs["checkpoint_every"] = cp
            writer = Writer(output, bodies, attrs, overwrite=overwrite)
        self._run_origin = self._steps
        sink = Sink(self, writer, keep)
        sink.emit([(s, s.current()) for s in self.systems], np.array([self._steps]), 1, 0)
        if writer is not None:
            writer.write_checkpoint(self._steps - self._run_origin, self.time, self.state_arrays(), sink.rows)
        return self._run_and_close(n_steps, every, cp, sink, writer, progress)

    def _run_and_close(self, n_steps, every, cp, sink, writer, progress) -> Result:
        """Step, write, and close the file with the right status whatever happens."""
        stop = threading.Event()
        previous = None
        if threading.current_thread() is threading.main_thread():
            previous = signal.signal(signal.SIGINT, lambda *_: stop.set())
        try:
            self._advance(n_steps, every, sink, progress, cp, stop)
            if stop.is_set():
                raise KeyboardInterrupt
        except KeyboardInterrupt:
            if writer is not None:
                writer.write_final_state(self._steps - self._run_origin, self.time, self.state_arrays())
                writer.close("interrupted", f"interrupted by the user at t = {self.time!r} s")
            raise
        except BaseException as exc:
            if writer is not None:
                writer.close("failed", f"{type(exc).__name__}: {exc}")
            raise
        finally:
            if previous is not None:
                signal.signal(signal.SIGINT, previous)
        if writer is not None:
            writer.write_final_state(self._steps - self._run_origin, self.time, self.state_arrays())
            writer.close("completed")
        return sink.result()

    def _checkpoint_steps(self, checkpoint_every, every: int) -> int:
        """Steps between checkpoints: a multiple of ``every`` (given or ~half a second of work)."""
        if checkpoint_every is None:
            gammas = coefficients(self.order).size
            per_step = max(1, gammas * sum(s.work_per_step() for s in self.systems))
            checkpoint_every = max(every, CHUNK_WORK // per_step)
        if (
            isinstance(checkpoint_every, bool)
            or not isinstance(checkpoint_every, numbers.Integral)
            or checkpoint_every < 1
        ):
            raise InputError("checkpoint_every", f"must be an integer >= 1, got {checkpoint_every!r}")
        return int(-(-int(checkpoint_every) // every) * every)

    # -- state, for checkpoints and restarts -------------------------------------------
    def state_arrays(self) -> dict[str, np.ndarray]:
        """Copies of every system's state arrays, keyed "<kind>/<field>"."""
        return {f"{s.kind}/{f}": np.array(getattr(s, f), copy=True) for s in self.systems for f in STATE_FIELDS[s.kind]}

    def set_state_arrays(self, arrays: dict, steps: int) -> None:
        """Restore :meth:`state_arrays` output (shapes must match this simulation's bodies)
        and set the step counter to ``steps`` steps after ``time`` = 0 of the run."""
        for s in self.systems:
            for f in STATE_FIELDS[s.kind]:
                key = f"{s.kind}/{f}"
                current = getattr(s, f)
                if key not in arrays or np.shape(arrays[key]) != np.shape(current):
                    raise InputError("checkpoint", f"the file's state {key!r} does not match the scene's bodies")
                setattr(s, f, np.ascontiguousarray(np.array(arrays[key], dtype=float)))
            if hasattr(s, "on_checkpoint"):
                s.on_checkpoint()
        self._steps = int(steps)

    def _file_attrs(self, every: int, n_steps: int) -> dict:
        return {
            "method": self.method,
            "order": self.order,
            "dt": self._dt,
            "t_start": self.time,
            "t_end": self.time + n_steps * self._dt,
            "steps": n_steps,
            "output_every": every,
            "gm": self.gm,
            "center": self.center,
            "field_body": (self.field.body or "") if self.field is not None else "none (free space)",
            "field_radius": self.field.radius if self.field is not None else 0.0,
            "adaptive": self.adaptive if self.adaptive is not None else 0.0,
            "roundoff": self.roundoff,
            "scene": self.scene_text if self.scene_text is not None else self.to_toml(),
        }

    def _advance_all(self, gammas, k: int, nrec: int):
        return [
            (s, s.advance(self.method, self.gm, self.center, self._dt, gammas, k, nrec, self.max_newton_iterations))
            for s in self.systems
        ]

    def _advance(
        self,
        n_steps: int,
        every: int,
        sink: Sink,
        progress: bool,
        cp: int | None = None,
        stop: threading.Event | None = None,
    ) -> None:
        """Take ``n_steps`` steps in chunks that end on records and never straddle a checkpoint
        (steps since the run's origin that are multiples of ``cp``); at each checkpoint the
        state is written with the records and systems drop path-dependent caches, so that a
        restart from it continues bit for bit."""
        gammas = coefficients(self.order)
        per_record = max(1, every * gammas.size * sum(s.work_per_step() for s in self.systems))
        nbodies = len(self.names)
        chunk_records = max(1, min(CHUNK_WORK // per_record, CHUNK_BYTES // (128 * nbodies)))
        origin = getattr(self, "_run_origin", 0)
        done = 0
        with progress_bar(n_steps, progress) as bar:
            while done < n_steps:
                if stop is not None and stop.is_set():
                    return
                left = n_steps - done
                off = (self._steps - origin) % every
                if off:  # after a step redone in sub-steps: back onto the record grid
                    k, nrec = min(every - off, left), 1
                else:
                    k = every if left >= every else left
                    nrec = min(left // k, chunk_records)
                if cp:
                    to_cp = cp - (self._steps - origin) % cp
                    nrec = max(1, min(nrec, to_cp // k))
                snapshots = [s.snapshot() for s in self.systems]
                recs = self._advance_all(gammas, k, nrec)
                failures = [(f, j) for j, (s, r) in enumerate(recs) if (f := r.first_failure()) is not None]
                if not failures:
                    sink.emit(recs, self._steps + k * (np.arange(nrec) + 1), nrec, k)
                    self._steps += k * nrec
                    done += k * nrec
                    bar.update(k * nrec)
                else:
                    taken = self._recover(recs, snapshots, min(failures), k, every, gammas, sink, origin)
                    done += taken
                    bar.update(taken)
                if cp and (self._steps - origin) % cp == 0:
                    for s in self.systems:
                        if hasattr(s, "on_checkpoint"):
                            s.on_checkpoint()
                    if sink.writer is not None:
                        sink.writer.write_checkpoint(self._steps - origin, self.time, self.state_arrays(), sink.rows)

    #: a failing step is retried as 2, 4, ... 2**MAX_SPLIT sub-steps before the run stops
    MAX_SPLIT = 4

    def _recover(self, recs, snapshots, failure, k, every, gammas, sink, origin) -> int:
        """A step failed: keep the records before it, bring every body to its start (re-running
        from the chunk's snapshots; the kernels are deterministic), then redo that one step in
        2, 4, ... 2**MAX_SPLIT sub-steps (each an ordinary step: exact conservation is kept).
        Returns the steps taken; raises IntegrationError if every split fails."""
        (step, index, status), j = failure
        good = step // k
        if good:
            sink.emit(recs, self._steps + k * (np.arange(good) + 1), good, k)
        for s, snap in zip(self.systems, snapshots):
            s.restore(snap)
        if step:
            again = self._advance_all(gammas, step, 1)
            if any(r.first_failure() is not None for _, r in again):  # cannot happen: deterministic
                raise RuntimeError("re-running the steps before a failure failed again")
        self._steps += step
        start = [s.snapshot() for s in self.systems]
        for level in range(1, self.MAX_SPLIT + 1):
            parts = 2**level
            sub = [
                (
                    s,
                    s.advance(
                        self.method,
                        self.gm,
                        self.center,
                        self._dt / parts,
                        gammas,
                        parts,
                        1,
                        self.max_newton_iterations,
                    ),
                )
                for s in self.systems
            ]
            if all(r.first_failure() is None for _, r in sub):
                self.retried_steps = getattr(self, "retried_steps", 0) + 1
                self._steps += 1
                if (self._steps - origin) % every == 0:
                    sink.emit(sub, np.array([self._steps]), 1, 1)
                return step + 1
            for s, snap in zip(self.systems, start):
                s.restore(snap)
        if sink.last_step != self._steps:  # record the last good state if it is not yet, then stop
            sink.emit([(s, s.current()) for s in self.systems], np.array([self._steps]), 1, 0)
        system = recs[j][0]
        name = system.names[index]
        if status == STATUS_NO_CONVERGENCE:
            reason = (
                f"Newton's iteration did not converge within {self.max_newton_iterations} iterations, "
                f"even in {2**self.MAX_SPLIT} sub-steps (method {self.method}, order {self.order}, "
                f"dt = {self._dt!r} s){self._residual_note(system, index, gammas)}; try a smaller dt"
            )
        else:
            x, _ = self.state(name)
            reason = (
                f"a point reached the field's centre or the state stopped being finite "
                f"(last good position {x.tolist()} m)"
            )
        raise IntegrationError(self.time, name, reason)

    def _residual_note(self, system, index, gammas) -> str:
        """', residual ...' for a point mass's failed step (the implicit equation's misfit after
        max_newton_iterations iterations), or '' for other bodies."""
        if system.kind != "point" or self.method == "leapfrog":
            return ""
        h = self._dt * gammas[0]
        x, v = system.x[:, index], system.v[:, index]
        c = self.center
        args = (x[0], x[1], x[2], v[0], v[1], v[2], h, self.gm, c[0], c[1], c[2], self.max_newton_iterations)
        # em: the reference kernel's Newton iteration alone (the accurate finish runs only
        # after it converged)
        from .kernels.pointmass import reference

        step = reference.em_step(*args, False) if self.method == "em" else reference.midpoint_step(*args)
        dx, dy, dz, a, b, cc, _, _ = step
        d = np.array([dx, dy, dz])
        R = d - h * (v + 0.5 * np.array([a, b, cc]))
        r = np.linalg.norm(R)
        return f", residual |R| = {r:.3g} m ({r / max(np.linalg.norm(d), 1e-300):.3g} of the step)"

    # -- scene text ---------------------------------------------------------------------
    def to_toml(self, t_end: float | None = None, output_every: int = 1) -> str:
        """This simulation's set-up as a scene (TOML), in SI units, exact to the last bit
        (point masses; rigid bodies are written with their shape parameters)."""
        from .io.scene_toml import simulation_to_toml

        return simulation_to_toml(self, t_end=t_end, output_every=output_every)


# METHODS is re-exported for discoverability: Simulation.METHODS lists what `method` accepts
Simulation.METHODS = METHODS
