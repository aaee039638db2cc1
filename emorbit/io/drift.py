"""Invariants that leave round-off: each record's drift, the bound round-off explains, the warning.

A method conserves some invariants exactly, up to round-off: em the energy and the angular
momentum about the field's centre, midpoint and leapfrog the angular momentum; in free space
every method conserves the linear momentum too (:func:`conserved`). Each record's drift is
measured from the run file's first record, relative to the invariant's *round-off scale*
``S``: the largest, over the records so far, of a bound of the invariant's terms
(:func:`emorbit.bodies.system.roundoff_scales`: ``T + |V| + W`` plus, for elastic bodies,
the elements' volume times stress (:func:`emorbit.kernels.elastic.stress_scale`) for the
energy, ``sqrt(2 M T)`` for the momentum, ``sqrt(2 T J)`` for the angular momentum), since
round-off in a step is a few eps of those terms, not of their sum, which can be small or
zero. The drift is
compared with the bound

    B(n) = C eps sqrt(max(n, 1)),

a random walk whose implicit sub-steps each move the invariant by up to C eps of S; ``n`` counts the
implicit sub-steps since the first record (steps times the composition's stages; adaptive
runs count the kernel's sub-steps) and ``C`` is the drift tolerance
(:data:`DRIFT_TOLERANCE`, 20, unless the run sets it). The shipped scenes and the long runs
of ``tests/test_hardcases.py`` need C of at most 6.5 (a box tumbling 150 degrees per step),
a point mass at e = 0.999 6.0, a close binary and a close three-body encounter 0.12 and 0.06;
a loss that a step's own arithmetic does not explain exceeds it: pair forces formed without the
positions' compensation (the binary at 20 s steps needed 23), a stiff structure at a large step
(the round-off its step leaves grows like (omega_max dt)^2, with omega_max its highest natural
frequency), a Newton iteration accepted far from round-off. docs/hard-cases.md has the
measurements.

A :class:`DriftMonitor` keeps the reference, the running scales, the sub-step count and the
largest excess; its state is part of a run's checkpoint (:meth:`DriftMonitor.state_arrays`),
so a resumed run records the same bits as one that never stopped.

Two changes are not round-off at all, and the monitor refuses them before they are recorded.
An energy-conserving step (em, without effects that do work) whose record interval moves the
energy by more than :data:`UNSOLVED` sqrt(n) of its round-off scale was not solved, however
its Newton iteration ended (:meth:`DriftMonitor.unsolved`; the steps are redone in sub-steps,
then the run fails: :class:`UnsolvedStep`). A run whose energy moves from its first record by
more than :data:`DIVERGED` times the energy's round-off scale at its start has diverged
(:meth:`DriftMonitor.diverged`; the run fails). Neither changes what a run that passes records.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError, IntegrationError

__all__ = [
    "DRIFT_TOLERANCE",
    "DIVERGED",
    "INVARIANTS",
    "STATE",
    "STATUS_UNSOLVED",
    "UNSOLVED",
    "DriftMonitor",
    "UnsolvedStep",
    "absent_state",
    "check_tolerance",
    "conserved",
    "is_absent",
]

_EPS = 2.0**-52
#: the default drift tolerance C: a record is flagged when its drift exceeds C eps sqrt(n)
DRIFT_TOLERANCE = 20.0
#: the most an energy-conserving step's record interval may move the energy, in units of its
#: round-off scale times sqrt(n), n its implicit sub-steps: 4.5e9 eps, 2000 times the drift of
#: the stiffest solved step measured (a steel bar at dt = 0.1 s, docs/hard-cases.md)
UNSOLVED = 1e-6
#: a run whose energy moves from its first record by more than this many times the energy's
#: round-off scale at its start (T + |V| + W) has diverged
DIVERGED = 1e3
#: the failure status of a step refused by :meth:`DriftMonitor.unsolved` (the kernels' codes
#: are >= 0)
STATUS_UNSOLVED = -1
#: the invariants checked, in the column order of ``diagnostics/invariant_drift``
INVARIANTS = ("energy", "linear momentum", "angular momentum")
#: the state a checkpoint stores: {name: (length, unit)}
STATE = {
    "reference": (7, "J (0), kg m / s (1-3), kg m2 / s (4-6)"),
    "scale": (3, "J (0), kg m / s (1), kg m2 / s (2)"),
    "progress": (19, "s (5, 10, 15), 1 (the others)"),
}


def conserved(method: str, momentum: bool, angular_momentum: bool) -> np.ndarray:
    """Which invariants a run conserves up to round-off.

    Parameters
    ----------
    method : str
        ``"em"``, ``"midpoint"`` or ``"leapfrog"`` (only em keeps the energy).
    momentum : bool
        Every force keeps the linear momentum (free space, mutual gravity).
    angular_momentum : bool
        Every force keeps the angular momentum about the centre (not zonal harmonics, which
        keep it about the pole only).

    Returns
    -------
    ndarray
        (3,) bool, in the order of :data:`INVARIANTS`.
    """
    return np.array([method == "em", bool(momentum), bool(angular_momentum)])


def check_tolerance(value, key: str = "drift_tolerance") -> float:
    """A drift tolerance: a number > 0, or ``inf`` to switch the check off.

    Parameters
    ----------
    value : float
        The multiple C of eps sqrt(n).
    key : str
        Its name in errors.

    Returns
    -------
    float
        ``value``, ``inf`` taken as the largest double (the bound stays finite, as a
        checkpoint stores it).

    Raises
    ------
    InputError
        Not a number > 0.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) or not value > 0:
        raise InputError(key, f"must be a number > 0 (the multiple C of eps sqrt(steps)), got {value!r}")
    return min(float(value), np.finfo(float).max)


def absent_state() -> dict[str, np.ndarray]:
    """The checkpoint state of a run that measures no drift (a file of an earlier version
    continued): the arrays of :data:`STATE`, zeros, with the tolerance 0.

    Returns
    -------
    dict
        {name: array}.
    """
    return {name: np.zeros(n) for name, (n, _) in STATE.items()}


def is_absent(arrays: dict) -> bool:
    """Whether checkpoint arrays say that no drift is measured (:func:`absent_state`).

    Parameters
    ----------
    arrays : dict
        {name: array} as read from a checkpoint's ``drift`` group.

    Returns
    -------
    bool
        True when ``progress`` holds the tolerance 0.
    """
    p = np.asarray(arrays.get("progress", ()), float)
    return p.shape == (STATE["progress"][0],) and p[3] == 0.0


class UnsolvedStep(IntegrationError):
    """A record interval of an energy-conserving method moved the energy beyond round-off
    (:meth:`DriftMonitor.unsolved`): its steps were not solved. Raised before anything of the
    interval is recorded; where it cannot be redone in sub-steps the run fails with it.

    Parameters
    ----------
    time : float
        The start of the refused interval, s.
    body : str
        The bodies whose energy changed most.
    change : float
        The energy's change over the interval, J.
    scale : float
        The energy's round-off scale, J.
    substeps : float
        The interval's implicit sub-steps.
    row : int
        The refused record's row in the block of records it came in.
    """

    def __init__(self, time: float, body: str, change: float, scale: float, substeps: float, row: int = 0):
        self.change, self.scale, self.substeps, self.row = change, scale, substeps, row
        super().__init__(time, body, unsolved_reason(change, scale, substeps))


def unsolved_reason(change: float, scale: float, substeps: float) -> str:
    """What an unsolved step did to the energy, in words."""
    return (
        f"the step changed the energy by {change:.6g} J, {change / max(scale, np.finfo(float).tiny):.3g} of its "
        f"round-off scale {scale:.6g} J over {substeps:.0f} implicit sub-steps, far beyond round-off "
        f"({UNSOLVED:g} sqrt(n)): an energy-conserving step that changes the energy was not solved"
    )


class DriftMonitor:
    """The drift of the conserved invariants from a run file's first record, record by record.

    Parameters
    ----------
    tolerance : float
        C of the bound C eps sqrt(n).
    stages : int
        Implicit sub-steps per step (the composition's stages).
    checked : ndarray
        (3,) bool: the invariants the method conserves (:func:`conserved`).

    Attributes
    ----------
    worst : list
        Per invariant, None or, for the record that exceeded its bound the most, (drift over
        bound, time in s, drift relative to the first record's value, implicit sub-steps n,
        bound).
    stalled : int
        Sub-steps accepted at a stall (above round-off) since the first record.
    """

    def __init__(self, tolerance: float, stages: int, checked):
        self.tolerance = float(tolerance)
        self.stages = int(stages)
        self.checked = np.asarray(checked, bool)
        self.reference: np.ndarray | None = None  # (7,) E0, P0, L0
        self.scale = np.zeros(3)
        self.substeps = 0.0
        self.last_step = 0
        self.stalled = 0
        self.worst: list = [None, None, None]
        #: refuse unsolved steps (:meth:`unsolved`): the run conserves its energy as recorded
        self.gate = bool(self.checked[0])
        #: the energy's round-off scale when this run started (or was resumed), J
        self.start_scale: float | None = None

    # -- checkpoints -------------------------------------------------------------------------
    def state_arrays(self) -> dict[str, np.ndarray]:
        """The monitor's state as float arrays: what a checkpoint stores (:data:`STATE`).

        Returns
        -------
        dict
            ``reference`` (E0, P0, L0; zeros before the first record), ``scale`` (the running
            scales) and ``progress``: sub-steps, the last record's step, stalled sub-steps,
            the tolerance C (0: no drift is measured, see :func:`absent_state`), then for each
            invariant its largest excess (drift over bound, or -1 while none; time; relative
            drift; sub-steps; bound).
        """
        ref = self.reference if self.reference is not None else np.zeros(7)
        progress = [self.substeps, self.last_step, self.stalled, self.tolerance]
        for w in self.worst:
            progress += w or (-1.0, 0.0, 0.0, 0.0, 0.0)
        return {"reference": ref.copy(), "scale": self.scale.copy(), "progress": np.array(progress, float)}

    def set_state_arrays(self, arrays: dict) -> None:
        """Restore :meth:`state_arrays` (as read from a checkpoint) of a monitor that has seen
        its first record.

        Parameters
        ----------
        arrays : dict
            {name: array} with the names and lengths of :data:`STATE`.

        Raises
        ------
        InputError
            An array is missing, has the wrong shape or holds values that cannot be.
        """
        for name, (n, _) in STATE.items():
            a = arrays.get(name)
            if a is None or np.shape(a) != (n,):
                raise InputError("checkpoint", f"the drift monitor's state 'drift/{name}' is missing or not ({n},)")
        ref = np.asarray(arrays["reference"], float)
        scale = np.asarray(arrays["scale"], float)
        p = np.asarray(arrays["progress"], float)
        if not (np.all(p[:3] >= 0) and p[3] > 0 and np.all(scale >= 0)):
            raise InputError("checkpoint", "the drift monitor's state 'drift/progress' or 'drift/scale' is invalid")
        self.reference = ref.copy()
        self.scale = scale.copy()
        self.start_scale = float(scale[0])
        self.substeps, self.last_step, self.stalled, self.tolerance = float(p[0]), int(p[1]), int(p[2]), float(p[3])
        self.worst = [None if p[j] < 0 else tuple(float(x) for x in p[j : j + 5]) for j in (4, 9, 14)]

    # -- refusals ----------------------------------------------------------------------------
    def _substeps(self, steps, substeps) -> np.ndarray:
        """Each record's implicit sub-steps since the record before it."""
        inc = np.diff(np.asarray(steps, np.int64), prepend=self.last_step).astype(float) * self.stages
        return inc if substeps is None else np.maximum(inc, substeps)

    def too_far(self, change, scale, substeps) -> np.ndarray:
        """Whether energy changes are beyond what a solved energy-conserving step leaves.

        Parameters
        ----------
        change : array_like
            Changes of the energy, J.
        scale : array_like
            Its round-off scale, J.
        substeps : array_like
            The implicit sub-steps each change took.

        Returns
        -------
        ndarray
            bool, True for a change above :data:`UNSOLVED` sqrt(n) of the scale (or not finite).
        """
        limit = UNSOLVED * np.sqrt(np.maximum(substeps, 1.0)) * np.maximum(scale, np.finfo(float).tiny)
        return ~(np.abs(change) <= limit)

    def unsolved(self, previous, steps, energy, scales, substeps=None):
        """The first record whose energy moved from the record before it beyond round-off, in a
        run that conserves its energy (:attr:`gate`); nothing is measured or kept.

        Parameters
        ----------
        previous : float or None
            The energy of the record before the block, J (None: the block starts the run).
        steps : ndarray
            (k,) step counts of the records.
        energy : ndarray
            (k,) their energies, J.
        scales : ndarray
            (k, 3) their round-off scales.
        substeps : ndarray or None
            As :meth:`update` takes them.

        Returns
        -------
        (int, float, float, float) or None
            The record's row, its energy change (J), the scale (J) and the sub-steps; None
            when every record is within round-off of the one before.
        """
        if not self.gate or previous is None or not len(energy):
            return None
        change = np.diff(np.concatenate([[previous], np.asarray(energy, float)]))
        scale = np.maximum.accumulate(np.maximum(np.asarray(scales, float)[:, 0], self.scale[0]))
        n = self._substeps(steps, substeps)
        bad = np.flatnonzero(self.too_far(change, scale, n))
        if not bad.size:
            return None
        r = int(bad[0])
        return r, float(abs(change[r])), float(scale[r]), float(n[r])

    def diverged(self, energy, scales):
        """The first record whose energy moved from the first record's by more than
        :data:`DIVERGED` times the energy's round-off scale at this run's start.

        Parameters
        ----------
        energy : ndarray
            (k,) the records' energies (under effects that do work: less the work), J.
        scales : ndarray
            (k, 3) their round-off scales.

        Returns
        -------
        (int, float, float, float) or None
            The record's row, the first record's energy, the record's (J) and the scale at the
            start (J); None while it has not diverged.
        """
        energy = np.asarray(energy, float)
        if not len(energy):
            return None
        first = energy[0] if self.reference is None else self.reference[0]
        start = float(scales[0][0]) if self.start_scale is None else self.start_scale
        bad = np.flatnonzero(~(np.abs(energy - first) <= DIVERGED * max(start, np.finfo(float).tiny)))
        if not bad.size:
            return None
        r = int(bad[0])
        return r, float(first), float(energy[r]), start

    # -- records -----------------------------------------------------------------------------
    def update(self, times, steps, energy, momentum, angular, scales, substeps, stalled):
        """Measure a block of records.

        Parameters
        ----------
        times : ndarray
            (k,) record times, s.
        steps : ndarray
            (k,) step counts of the records.
        energy, momentum, angular : ndarray
            (k,), (k, 3), (k, 3): the invariants, J, kg m/s, kg m^2/s.
        scales : ndarray
            (k, 3) the records' round-off scales.
        substeps : ndarray or None
            (k,) implicit sub-steps of each record's interval counted by a kernel (adaptive
            steps), or None: the steps since the last record times :attr:`stages`.
        stalled : ndarray
            (k,) sub-steps of each interval accepted at a stall.

        Returns
        -------
        drift : ndarray
            (k, 3) |I - I0| / S for the conserved invariants, -1 for the others.
        bound : ndarray
            (k,) C eps sqrt(max(n, 1)).
        """
        k = len(times)
        inv = np.concatenate([np.asarray(energy, float)[:, None], momentum, angular], axis=1)
        steps = np.asarray(steps, np.int64)
        if self.reference is None:
            self.reference = inv[0].copy()
            self.scale = np.zeros(3)
            self.start_scale = float(scales[0][0])
            self.last_step = int(steps[0])
        n = self.substeps + np.cumsum(self._substeps(steps, substeps))
        scale = np.maximum.accumulate(np.maximum(scales, self.scale[None, :]), axis=0)
        ref = self.reference
        change = np.stack(
            [np.abs(inv[:, 0] - ref[0]), np.linalg.norm(inv[:, 1:4] - ref[1:4], axis=1)]
            + [np.linalg.norm(inv[:, 4:7] - ref[4:7], axis=1)],
            axis=1,
        )
        drift = change / np.maximum(scale, np.finfo(float).tiny)  # finite: a checkpoint stores it
        drift[:, ~self.checked] = -1.0
        bound = self.tolerance * _EPS * np.sqrt(np.maximum(n, 1.0))
        with np.errstate(over="ignore"):
            ratio = np.minimum(np.where(self.checked[None, :], drift / bound[:, None], -1.0), np.finfo(float).max)
        for j in range(3):
            r = int(np.argmax(ratio[:, j]))
            if ratio[r, j] > 1.0 and (self.worst[j] is None or ratio[r, j] > self.worst[j][0]):
                size = abs(ref[0]) if j == 0 else np.linalg.norm(ref[1:4] if j == 1 else ref[4:7])
                rel = change[r, j] / size if size > 0 else -1.0  # -1: the first value is 0
                self.worst[j] = (float(ratio[r, j]), float(times[r]), float(rel), float(n[r]), float(bound[r]))
        self.substeps = float(n[-1])
        self.scale = scale[-1].copy()
        self.last_step = int(steps[k - 1])
        self.stalled += int(np.sum(stalled))
        return drift, bound

    def report(self) -> str | None:
        """The end-of-run warning: one paragraph, or None when no record exceeded its bound.

        Returns
        -------
        str or None
            Each invariant that exceeded its bound with its largest excess: the drift
            relative to the first record's value, when, the multiple of the bound; then what
            to change.
        """
        parts = [
            f"the {INVARIANTS[j]} drifted from its first record by "
            + (f"{rel:.3g} of its value" if rel >= 0 else "some (its first value is 0)")
            + f" at t = {t!r} s, {ratio:.3g} times what round-off explains after n = {n:.0f} implicit sub-steps "
            f"(C eps sqrt(n) = {bound:.3g} of its round-off scale)"
            for j, (ratio, t, rel, n, bound) in ((j, w) for j, w in enumerate(self.worst) if w is not None)
        ]
        if not parts:
            return None
        head = (
            "; ".join(parts) + f", with drift_tolerance C = {self.tolerance:g}; every record's drift and bound are in "
            "diagnostics/invariant_drift and diagnostics/drift_bound."
        )
        if self.stalled:
            cause = (
                f" Newton's iteration was accepted at a stall, above round-off, in {self.stalled} sub-steps "
                '(diagnostics/stalled_solves): take a smaller dt, or newton = "full" for an elastic structure, '
                "so that each solve reaches round-off."
            )
        else:
            cause = (
                " Every Newton iteration ended at round-off, so the step itself amplifies round-off: take a smaller "
                "dt (the round-off a stiff elastic structure's step leaves grows like (omega_max dt)^2, omega_max "
                "its highest natural frequency)."
            )
        return head + cause + " To accept the drift, raise drift_tolerance (integrator.drift_tolerance)."
