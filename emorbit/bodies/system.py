"""The interface every body kind offers a :class:`~emorbit.simulation.Simulation`.

A *system* holds all bodies of one kind as flat float64 arrays and advances them with its
kernels: :class:`~emorbit.bodies.pointmasses.PointMasses`,
:class:`~emorbit.bodies.rigid.RigidBodies` and :class:`~emorbit.bodies.coupled.Structure`.
Systems do not interact, so the simulation advances each one on its own, in chunks: a call
of :meth:`BodySystem.advance` takes ``nrec * every`` composed steps and returns *records*,
an object with the states after every ``every`` steps, the Newton iterations per record
interval and the earliest failure. The simulation turns records into invariants and file
datasets through the same system (:meth:`~BodySystem.invariants`,
:meth:`~BodySystem.datasets`), and takes and restores snapshots of the whole state (for a
failed step redone in sub-steps, and for checkpoints).

To add a body kind: subclass :class:`BodySystem`, implement every method below, name the
kind's state arrays (compensation terms and warm starts included) in
:attr:`~BodySystem.STATE_FIELDS` so that checkpoints store them, and let the simulation
create the system when a scene adds a body of that kind.
"""

from __future__ import annotations

import unicodedata

import numpy as np

from ..errors import InputError
from ..integrators.plan import Plan

__all__ = ["WorkSums", "BodySystem", "check_body_name", "check_output", "newton_failure", "roundoff_scales"]


def roundoff_scales(kinetic, potential, mass, moment):
    """The magnitudes against which round-off moves the invariants: a bound of each one's terms.

    Parameters
    ----------
    kinetic : float or ndarray
        Kinetic energy T, J.
    potential : float or ndarray
        The magnitudes of the other energy terms summed (|V| of the field, strain energy), J.
    mass : float or ndarray
        The total mass M whose velocities make the linear momentum, kg.
    moment : float or ndarray
        J = sum m |x - c|^2 over the mass (rigid bodies: m |phi - c|^2 + tr E), kg m^2.

    Returns
    -------
    ndarray
        (..., 3): ``T + |V|`` (J), ``sqrt(2 M T)`` (kg m/s, at least ``|sum m v|`` by
        Cauchy-Schwarz) and ``sqrt(2 T J)`` (kg m^2/s, at least ``|sum m (x - c) x v|``).
    """
    kinetic = np.asarray(kinetic, float)
    return np.stack(
        [kinetic + potential, np.sqrt(2.0 * mass * kinetic), np.sqrt(2.0 * kinetic * np.asarray(moment, float))],
        axis=-1,
    )


def check_body_name(name, key: str = "name") -> str:
    """Check a body name: a non-empty string without '/' and without control characters (it
    names an HDF5 group, whose name ends at a NUL: "a\\0b" would be recorded as "a").

    Parameters
    ----------
    name : object
        The proposed name.
    key : str
        Where it came from, for the error message.

    Returns
    -------
    str
        ``name``, unchanged.

    Raises
    ------
    InputError
        ``name`` is not such a string, holds a control character, or is ``"."`` or ``".."``.
    """
    if not isinstance(name, str) or not name.strip() or "/" in name or name in (".", ".."):
        raise InputError(key, f"a body name must be a non-empty string without '/', got {name!r}")
    bad = [c for c in name if unicodedata.category(c) in _CONTROL]
    if bad:
        raise InputError(
            key, f"a body name must not hold control characters or line breaks, got {name!r} (with {bad[0]!r})"
        )
    return name


#: the Unicode categories a body name may not hold: control characters (NUL, tab, newline, ...),
#: surrogates (not text) and line and paragraph separators
_CONTROL = ("Cc", "Cs", "Zl", "Zp")


def check_output(systems, n_steps: int, every: int, dt: float, max_output, keys: dict, length_key: str) -> None:
    """Refuse a run whose records would take more than ``max_output`` bytes.

    Parameters
    ----------
    systems : list of BodySystem
        The systems that record.
    n_steps, every : int
        Steps of the run and steps between records.
    dt : float
        The step, s.
    max_output : Quantity, str or float
        The limit, bytes.
    keys : dict
        The names of ``dt``, ``every`` and ``max_output`` in errors.
    length_key : str
        The key that sets the run's length (``t_end`` or ``steps``), named by the error.

    Raises
    ------
    InputError
        ``max_output`` is not a positive size, or the projected output is above it: the
        records (``n_steps // every`` and the first and last) times the bytes of every
        dataset of every body (:meth:`BodySystem.output_bytes`) and of the root datasets
        (at most 3 values each).
    """
    from ..io.reader import LAYOUT_UNITS
    from ..units import information_text, to_si

    limit = to_si(max_output, "information", keys["max_output"], positive=True)
    records = n_steps // every + 1 + (1 if n_steps % every else 0)
    size = 24 * len(LAYOUT_UNITS) * records + sum(s.output_bytes(records) for s in systems)
    if size > limit:
        raise InputError(
            length_key,
            f"{n_steps} steps of {keys['dt']} = {dt!r} s with a record every {every} ({keys['every']}) make "
            f"{records} records, about {information_text(size)} of output, above {keys['max_output']} = "
            f"{information_text(limit)}; shorten the run, raise {keys['dt']} or {keys['every']}, or raise "
            f"{keys['max_output']}",
        )


class BodySystem:
    """Bodies of one kind, their state arrays and their kernel calls.

    Attributes
    ----------
    kind : str
        The kind's name: the group of its state in checkpoints (``"<kind>/<field>"``).
    METHODS : tuple of str
        The methods (names of :data:`emorbit.integrators.METHODS`) it has kernels for.
    POINTS_ONLY : tuple of str
        Those of them whose steps take effects at its points' positions only (none may act on
        its surfaces, nor at its points with a force that depends on the velocity).
    names : list of str
        The bodies' names, in the order of adding (an attribute or a property of the kind).
    STATE_FIELDS : tuple of str
        The attributes (float64 arrays) that are the kind's whole state, compensation terms
        and warm starts included: what :meth:`state_arrays` returns by default.
    plan : Plan
        The run's plan (:class:`~emorbit.integrators.plan.Plan`), handed over by the
        simulation; the system reads its settings (adaptive steps, round-off, device) there.
    """

    kind: str = ""
    METHODS: tuple[str, ...] = ()
    POINTS_ONLY: tuple[str, ...] = ()
    STATE_FIELDS: tuple[str, ...] = ()
    plan: Plan = Plan()

    @property
    def adaptive(self) -> float | None:
        """Adaptive steps' accuracy knob eta from the plan (None: fixed steps)."""
        return self.plan.adaptive

    def __len__(self) -> int:
        return len(self.names)

    def __contains__(self, name) -> bool:
        return name in self.names

    def work_per_step(self) -> int:
        """A rough cost of one step, in point updates, for sizing chunks of steps."""
        raise NotImplementedError

    def advance(
        self,
        method: str,
        gm: float,
        center,
        dt: float,
        gammas,
        every: int,
        nrec: int,
        max_iter: int,
        clock: tuple = (0.0, 0),
    ):
        """Advance every body ``nrec * every`` composed steps, recording every ``every`` steps.

        Parameters
        ----------
        method : str
            A name of :attr:`METHODS`.
        gm : float
            GM of the field, m^3/s^2 (0 in free space).
        center : ndarray
            The field's centre (3,), m.
        dt : float
            The step, s.
        gammas : ndarray
            The composition's sub-step coefficients (:func:`emorbit.integrators.coefficients`).
        every : int
            Steps per record.
        nrec : int
            Records to take.
        max_iter : int
            Newton iterations allowed per implicit sub-step.
        clock : tuple
            ``(t_base, n0)``: the chunk's j-th step starts at ``t_base + (n0 + j) dt``, s from
            the run's epoch (effects that depend on time read it; a step's time does not
            depend on where chunks start).

        Returns
        -------
        records
            The states after each record interval, the Newton iterations per interval and
            ``first_failure()``: (step index in the chunk, body index, status) of the
            earliest failed step, or None. A failed body stops at the start of its failing step.
            Kinds whose Newton iteration can be accepted at a stall (above round-off) give
            ``stalled`` too: (nrec, bodies) such sub-steps per interval.
        """
        raise NotImplementedError

    def current(self):
        """The current state as records of one record (nothing failed)."""
        raise NotImplementedError

    def snapshot(self):
        """Copies of the whole state, compensation terms included, for :meth:`restore`."""
        raise NotImplementedError

    def restore(self, snap) -> None:
        """Put back the state :meth:`snapshot` returned."""
        raise NotImplementedError

    #: whether :meth:`kick` adds impulses to this kind's bodies
    KICKS = False

    def kick(self, name: str, dv, key: str = "dv") -> tuple[float, np.ndarray]:
        """Add ``dv`` (3,) m/s to a body's velocity (a rigid body's centre of mass), with the
        compensation of its rounding: an impulsive manoeuvre (:mod:`emorbit.events`).

        Returns
        -------
        (float, ndarray)
            The body's mass (kg) and its velocity before, m/s.

        Kinds whose bodies take impulses set :attr:`KICKS` and override this; a run refuses an
        impulse on another kind before it starts, naming the event.
        """
        raise NotImplementedError

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Copies of the whole state, by name: what a checkpoint stores (default: the arrays
        named in :attr:`STATE_FIELDS`)."""
        return {f: np.array(getattr(self, f), copy=True) for f in self.STATE_FIELDS}

    def set_state_arrays(self, arrays: dict) -> None:
        """Restore the state :meth:`state_arrays` returned, bit for bit, then :meth:`on_checkpoint`.

        Parameters
        ----------
        arrays : dict
            {name: array}, as read from a checkpoint.

        Raises
        ------
        InputError
            An array is missing or its shape does not match the bodies (key ``checkpoint``).
        """
        for f in self.STATE_FIELDS:
            current = getattr(self, f)
            if f not in arrays or np.shape(arrays[f]) != np.shape(current):
                raise InputError("checkpoint", f"the file's state '{self.kind}/{f}' does not match the scene's bodies")
        for f in self.STATE_FIELDS:
            setattr(self, f, np.ascontiguousarray(np.array(arrays[f], dtype=float)))
        self.on_checkpoint()

    def on_checkpoint(self) -> None:
        """Drop what depends on the path taken so far (cached factorisations, warm starts that
        are not state), so that a run restarted from a checkpoint continues bit for bit."""

    def invariants(self, rec, nrec: int, gm: float, center) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The bodies' total invariants at each of the first ``nrec`` records.

        Parameters
        ----------
        rec : records
            What :meth:`advance` or :meth:`current` returned.
        nrec : int
            How many records to evaluate.
        gm : float
            GM of the field, m^3/s^2.
        center : array_like
            The field's centre, m.

        Returns
        -------
        tuple of ndarray
            Energy (nrec,) in J, linear momentum (nrec, 3) in kg m/s, angular momentum about
            the centre (nrec, 3) in kg m^2/s.
        """
        raise NotImplementedError

    def invariant_scales(self, rec, nrec: int, gm: float, center) -> np.ndarray:
        """The magnitudes against which round-off moves the invariants, at each record.

        Parameters
        ----------
        rec : records
            What :meth:`advance` or :meth:`current` returned.
        nrec : int
            How many records to evaluate.
        gm : float
            GM of the field, m^3/s^2.
        center : array_like
            The field's centre, m.

        Returns
        -------
        ndarray
            (nrec, 3): :func:`roundoff_scales` of the bodies' kinetic energy, the magnitudes
            of their other energy terms, their mass and their second moment about the centre;
            J, kg m/s and kg m^2/s.
        """
        raise NotImplementedError

    def newton_facts(self, index: int, method: str, gm: float, center, h: float, max_iter: int):
        """How Newton's iteration fares on one body's next step of size ``h`` (for the message
        of a failed step); the state is left as it was.

        Parameters
        ----------
        index : int
            The body.
        method : str
            The method's name.
        gm : float
            GM, m^3/s^2.
        center : ndarray
            The field's centre (3,), m.
        h : float
            The step, s.
        max_iter : int
            Newton iterations allowed.

        Returns
        -------
        tuple or None
            (status, last update, residual or None), the last two relative to the step's
            scale; None where the kind cannot say (default).
        """
        return None

    def datasets(self, rec, nrec: int, times=None, first_row: int = 0) -> dict:
        """The first ``nrec`` records as per-body datasets.

        Parameters
        ----------
        rec : records
            What :meth:`advance` or :meth:`current` returned.
        nrec : int
            How many records.
        times : ndarray, optional
            The records' times, s (for datasets written at a lower rate than the records).
        first_row : int
            The index of the first of these records in the run.

        Returns
        -------
        dict
            {body name: {dataset: array with one row per record}}, in the units of
            :meth:`body_datasets`.
        """
        raise NotImplementedError

    def body_datasets(self, i: int) -> dict:
        """The growing datasets of body ``i``'s HDF5 group: {path: (width or shape, unit)}."""
        raise NotImplementedError

    def dataset_rows(self, i: int, dataset: str, records: int) -> int:
        """The rows dataset ``dataset`` of body ``i`` has after ``records`` records (default: one each)."""
        return records

    def output_bytes(self, records: int) -> int:
        """The bytes the bodies' growing datasets take after ``records`` records (float64 values).

        Parameters
        ----------
        records : int
            Records of the run.

        Returns
        -------
        int
            Bytes, over every body and dataset of :meth:`body_datasets`.
        """
        total = 0
        for i in range(len(self)):
            for name, (width, _) in self.body_datasets(i).items():
                shape = () if width is None else ((width,) if isinstance(width, int) else tuple(width))
                total += 8 * int(np.prod(shape, dtype=object)) * self.dataset_rows(i, name, records)
        return total

    def body_attrs(self, i: int) -> dict:
        """The attributes of body ``i``'s HDF5 group: ``kind``, ``mass`` (kg) and the kind's own."""
        raise NotImplementedError

    def body_constants(self, i: int) -> dict:
        """The fixed datasets of body ``i``, written once: {path: (array, unit)}."""
        raise NotImplementedError


def newton_failure(max_iter: int, update: float, residual: float | None, where: str) -> str:
    """Say what failed in a Newton iteration that ran out of iterations, and what to change.

    Parameters
    ----------
    max_iter : int
        The iterations allowed (``max_newton_iterations``).
    update : float
        The last update, relative to the step's scale (the size of the step's increment, or
        the scale the kind's round-off test uses).
    residual : float or None
        The residual of the last iterate, relative to the increment (None: not known).
    where : str
        Which step, e.g. ``"at the sub-step dt/16 = 0.5 s"``.

    Returns
    -------
    str
        One clause: the iterate at round-off with an update not yet at the test (raise
        ``max_newton_iterations``), an update still above round-off (more iterations or a
        smaller ``dt``), or one as large as the step (a smaller ``dt``).
    """
    eps = 2.0**-52
    res = f", residual {residual:.2g} of the step" if residual is not None else ""
    ran_out = f"when the max_newton_iterations = {max_iter} iterations ran out"
    if residual is not None and residual <= 64 * eps and update < 1e-3:
        return (
            f"{where} the iterate solves the step to round-off (residual {residual:.2g} of the step), but "
            f"Newton's update, {update:.2g} of the step's scale, had not yet fallen to the round-off test (4 eps) "
            f"{ran_out}; raise integrator.max_newton_iterations"
        )
    if update < 0.5:
        return (
            f"{where} Newton's update had not fallen to round-off (4 eps) {ran_out}: the last was {update:.2g} of "
            f"the step's scale{res}; raise integrator.max_newton_iterations, or take a smaller dt"
        )
    return (
        f"{where} Newton's iteration does not approach a solution: after {max_iter} iterations its update is "
        f"{update:.2g} of the step's scale{res}; take a smaller dt"
    )


class WorkSums:
    """The work sums of a body system under effects that do work (drag, radiation pressure,
    third bodies): ``work`` and its Kahan compensation ``cwork``, J, shaped by the system's
    ``_work_shape()`` (an array of that shape is kept; a change of shape, new bodies or
    effects, starts it at zeros). A base class whose ``_work`` and ``_cwork`` the system holds."""

    @property
    def work(self) -> np.ndarray:
        """The work each effect that does work has done on each body since the run's start, J
        (:meth:`reset_work` at a run's start); zeros for new bodies."""
        if self._work.shape != self._work_shape():
            self._work, self._cwork = np.zeros(self._work_shape()), np.zeros(self._work_shape())
        return self._work

    @work.setter
    def work(self, value) -> None:
        self._work = np.ascontiguousarray(value, dtype=float)

    @property
    def cwork(self) -> np.ndarray:
        """The Kahan compensation terms of :attr:`work`, J."""
        self.work  # noqa: B018 (shapes both)
        return self._cwork

    @cwork.setter
    def cwork(self, value) -> None:
        self._cwork = np.ascontiguousarray(value, dtype=float)

    def reset_work(self) -> None:
        """Start the work sums at 0 (a new run; a resumed run restores them instead)."""
        self.work[...] = 0.0
        self.cwork[...] = 0.0
