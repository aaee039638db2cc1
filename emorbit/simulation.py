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
import sys

import numpy as np

from .assembly import Assembly
from .bodies.effect_binding import EffectBinding
from .bodies.pointmasses import PointMasses
from .bodies.system import check_body_name, check_output
from .effects.effectset import EffectSet
from .epochs import to_epoch
from .errors import InputError
from .events import EventSet
from .field import CentralField
from .integrators import METHODS, check_device
from .integrators.dispatch import require_device
from .integrators.plan import Plan
from .notices import compile_notice
from .result import Result
from .state import StateQueries
from .stepping import ChunkDriver
from .units import to_count, to_si

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


class Simulation(Assembly, StateQueries, ChunkDriver):
    """Bodies in a central field (or in free space), advanced by one method at a fixed step.

    Bodies are added with :meth:`add_point`, :meth:`add_rigid` and :meth:`add_elastic`,
    tied together with :meth:`attach`, and advanced with :meth:`run`.

    Parameters
    ----------
    field : CentralField or None
        The field; ``None`` is free space (no gravity; rigid and elastic bodies only).
    method : str
        A name in :data:`emorbit.METHODS`: ``"em"`` (energy-momentum, the default),
        ``"midpoint"``, ``"leapfrog"``, or ``"tfe"`` (energy-momentum time finite elements:
        point masses, also under effects whose force is explicit; rigid bodies, and structures of
        elastic and rigid bodies and point masses, in the central field; fixed or adaptive steps).
    order : int
        2 (the base step) or 4, 6, 8 (symmetric compositions of it, :data:`emorbit.ORDERS`);
        ``"tfe"`` runs at 4, 6, 8, 10 or 12 (its 2 to 6 Gauss stages).
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
        Under effects, the time scale is the fastest the effects that set one give (the
        central field's, mutual gravity's between pairs). A number in (0, 1]; default: fixed
        steps of ``dt``.
    roundoff : str
        Point masses with method ``"em"``: ``"brouwer"`` (default) keeps the energy error a
        random walk over many steps (Brouwer's law, no drift of one sign): a fixed step
        takes the exact root of its scalar equation correctly rounded (a Newton update
        certified to be it, else one on an accurate evaluation), and steps with a large
        h^2/2 GM / (r0 r1 (r0 + r1)) finish on g_em evaluated to within a rounding (see
        :mod:`emorbit.kernels.pointmass.packed`). ``"fast"`` solves the equation in plain
        floating point: a little cheaper per step, with an energy drift
        at round-off level (methods.md compares the two). Only point masses in the central
        field have it: a run that steps other bodies or effects refuses ``"fast"``
        (:meth:`~emorbit.integrators.plan.Plan.check_roundoff`).
    epoch : astropy.time.Time or str, optional
        The instant the run's time 0 stands for (:func:`emorbit.epochs.to_epoch`:
        ``"2000-01-01T12:00:00 TDB"``); the clock then counts seconds of TDB from it.
        Required by the effects that take the Sun's or the Moon's position from an
        ephemeris (``srp``, ``third_body``).

    Attributes
    ----------
    plan : Plan
        The method and its settings (:class:`~emorbit.integrators.plan.Plan`), checked once
        and read by every body system; ``method``, ``order``, ``adaptive``, ``roundoff``,
        ``newton``, ``max_newton_iterations`` and ``device`` read it.
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
        The default C of :meth:`run`'s drift bound C eps sqrt(n), 20 (a scene's
        ``integrator.drift_tolerance`` sets it).
    epoch : astropy.time.Time or None
        The run's epoch in TDB (None: none given).
    effects : EffectSet
        The effects the bodies feel: the central field's (where there is a field), then those
        of :meth:`add_effect`; iterating gives each :class:`~emorbit.effects.base.Effect`
        (``.kind``, ``.label``, ``.table``).

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
        self._dt = to_si(dt, "time", "dt", positive=True)
        self.plan = Plan(method, order, roundoff, "cpu", adaptive, max_newton_iterations, newton)
        self.effects = EffectSet(field)
        self.events = EventSet()
        self.points = PointMasses(self.plan)
        self.points.effects = EffectBinding(self.effects, "point")
        self.rigid = None  # created on the first rigid body, so point-mass runs never import it
        self.structure = None  # elastic bodies and what they are attached to
        self._t_base = 0.0
        self._steps = 0
        self.scene_text: str | None = None
        self.t_end_requested: float | None = None
        self.keys = {k: k for k in ("t_end", "dt", "every", "max_output")}
        self.max_output = MAX_OUTPUT
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
        return self.plan.device

    @device.setter
    def device(self, device: str) -> None:
        plan = self.plan.with_(device=check_device(device))
        if plan.device == "gpu":
            require_device(plan.device)
        self._set_plan(plan)

    def _set_plan(self, plan: Plan) -> None:
        """Hand a new plan to the simulation and every body system."""
        self.plan = plan
        for system in (self.points, self.rigid, self.structure):
            if system is not None:
                system.plan = plan

    @property
    def method(self) -> str:
        """The method's name (:data:`emorbit.METHODS`)."""
        return self.plan.method

    @property
    def order(self) -> int:
        """The step's order: a composition's (:data:`emorbit.ORDERS`), or tfe's
        (:data:`emorbit.integrators.TFE_ORDERS`)."""
        return self.plan.order

    @property
    def adaptive(self) -> float | None:
        """Adaptive steps' accuracy knob eta (None: fixed steps)."""
        return self.plan.adaptive

    @property
    def roundoff(self) -> str:
        """The round-off treatment (:data:`emorbit.integrators.ROUNDOFF`)."""
        return self.plan.roundoff

    @property
    def newton(self) -> str:
        """A structure's Newton strategy: ``"auto"``, ``"reuse"`` or ``"full"``."""
        return self.plan.newton

    @property
    def max_newton_iterations(self) -> int:
        """Newton iterations allowed per implicit sub-step."""
        return self.plan.max_iter

    @property
    def systems(self) -> list:
        """The body systems that have bodies, in a fixed order (points, rigid, structure)."""
        return [s for s in (self.points, self.rigid, self.structure) if s is not None and len(s)]

    @property
    def names(self) -> list[str]:
        """Body names, in the order of their systems and then of adding."""
        return [n for s in self.systems for n in s.names]

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
            :attr:`drift_tolerance`, 20; :mod:`emorbit.io.drift`); ``inf`` switches it off.

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
            "interrupted" (the exception is a :class:`~emorbit.interrupts.RunInterrupted`
            naming the signal).
        """
        if not self.systems:
            raise InputError("body", "the simulation has no bodies; add one with add_point() or add_rigid()")
        self.check()
        if (t_end is None) == (steps is None):
            raise InputError("t_end", "give exactly one of t_end and steps")
        n_steps = to_count(steps, "steps", 1, MAX_STEPS) if steps is not None else self.steps_until(t_end)
        every = to_count(every, "output_every")
        if output is not None or keep:
            length_key = "steps" if steps is not None else self.keys["t_end"]
            limit = self.max_output if max_output is None else max_output
            check_output(self.systems, n_steps, every, self._dt, limit, self.keys, length_key)
        notice = progress is not False  # quiet runs say nothing; others say when kernels compile long
        if progress is None:
            progress = sys.stderr.isatty()
        self._strict = bool(strict)
        with compile_notice(notice):
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
