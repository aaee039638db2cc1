"""Taking a simulation's steps: compiled chunks, records, checkpoints, failed steps and signals.

:class:`ChunkDriver` is the part of :class:`emorbit.Simulation` that steps. It advances every
body system in chunks of steps that end on records and never straddle a checkpoint, hands
each chunk's records to the :class:`~emorbit.io.recorder.Sink`, and writes the complete state
at every checkpoint, so that a run restarted from one continues bit for bit
(:mod:`emorbit.io.resume`). Chunks are sized from the measured wall time of the chunks before
(:class:`~emorbit.pacing.Pace`; :data:`CHUNK_BYTES` of records at most). Checkpoints fall every
``checkpoint_every`` steps when that is given, else by wall time: at most
:data:`~emorbit.pacing.CHECKPOINT_SECONDS` apart (or one record interval, where a single one
takes longer).
Where chunks end and checkpoints fall changes no result.

A step that fails (Newton does not converge) is redone from the chunk's snapshots in 2, 4,
... 2**MAX_SPLIT sub-steps; each sub-step is an ordinary step of the method, so energy and
angular momentum stay conserved, and the record that closes the interval counts it in
``diagnostics/split_steps``. A step that fails even then stops the run with a message that
says what failed (:func:`emorbit.bodies.system.newton_failure`). SIGINT and SIGTERM stop the
run at the end of the chunk in progress (:func:`emorbit.interrupts.stop_on_signals`). Where
the run has events (:mod:`emorbit.events`), each chunk's steps are recorded one by one and
handed to an :class:`~emorbit.event_run.EventRun`, which finds, locates and logs their
crossings without changing the run's states; a stopping event ends the run at its state.
Whatever ends the run (its end, a stopping event, a failure, a signal), the output file gets
the final state, a checkpoint where the state is on the record grid, and the matching
status: "completed", "stopped", "failed" or "interrupted".

With ``energy_range`` on (by default for the methods that do not conserve energy, where
``output_every`` > 1), every record also gets the least and the greatest total energy over
the steps of its interval (``invariants/energy_range``), so that decimated records cannot
alias an oscillating energy error: the systems record every step into scratch records
(:data:`RANGE_BYTES` of them per call at most), whose energies give the range, and the
records are taken from them (:func:`_every_kth`); the steps are the same steps, so the
records are bit-identical to a run without the range.

A completed run whose conserved invariants drifted beyond the bound round-off explains
(:mod:`emorbit.io.drift`) gets the root attribute ``warning`` and, once its file is closed,
a :class:`~emorbit.errors.RoundoffWarning`, or with ``strict`` a
:class:`~emorbit.errors.RoundoffError`.
"""

from __future__ import annotations

import dataclasses
import json
import numbers
import signal
import time as _time
import warnings

import numpy as np

from . import pacing
from .bodies.system import newton_failure
from .epochs import epoch_text
from .errors import InputError, IntegrationError, RoundoffError, RoundoffWarning
from .event_run import EventRun
from .integrators import get_method
from .interrupts import RunInterrupted, StopRequest, stop_on_signals
from .io.drift import (
    DRIFT_TOLERANCE,
    STATE,
    STATUS_UNSOLVED,
    DriftMonitor,
    UnsolvedStep,
    absent_state,
    check_tolerance,
    conserved,
    is_absent,
)
from .io.hdf5 import FileLostError, Writer
from .io.recorder import Sink, progress_bar
from .kernels.codes import STATUS_NO_CONVERGENCE, STATUS_OK
from .pacing import Pace
from .result import Result

__all__ = [
    "ChunkDriver",
    "CHUNK_BYTES",
    "RunInterrupted",
]

#: bytes of recorded state per chunk at most
CHUNK_BYTES = 128 * 2**20
#: bytes of step-by-step states that one call records at most to measure energy ranges
RANGE_BYTES = 32 * 2**20
#: what ``energy_range`` may be set to
RANGE_CHOICES = ("auto", True, False)


class ChunkDriver:
    """The stepping half of :class:`emorbit.Simulation`: a base class that holds no state.

    It reads the simulation's ``systems``, ``method``, ``order``, ``dt``, field and settings
    and moves its step counter; :meth:`state_arrays` and :meth:`set_state_arrays` are the
    state a checkpoint stores and a restart restores.

    Attributes
    ----------
    drift_tolerance : float
        C of the drift bound C eps sqrt(n) (:mod:`emorbit.io.drift`) for runs that do not
        give their own; ``inf`` switches the check off.
    energy_range : {"auto", True, False}
        Record the least and greatest total energy between records
        (``invariants/energy_range``): "auto" does for methods that do not conserve energy
        (:data:`emorbit.integrators.METHODS`); an em run's energy is the records' to round-off.
    """

    drift_tolerance: float = DRIFT_TOLERANCE
    _drift: DriftMonitor | None = None
    _energy_range = "auto"
    #: a run with ``strict``: a drift beyond the bound raises instead of warning
    _strict = False
    #: the step count where the present run (or resume) began
    _run_origin = 0
    #: the step count of the last checkpoint written (None: none in this run yet)
    _checkpointed_at: int | None = None
    #: steps redone in sub-steps since the simulation was made
    retried_steps = 0

    @property
    def energy_range(self):
        """Whether records carry the energy's range between them: "auto", True or False."""
        return self._energy_range

    @energy_range.setter
    def energy_range(self, value) -> None:
        if not any(value is c or (isinstance(c, str) and value == c) for c in RANGE_CHOICES):
            raise InputError("energy_range", f'must be "auto", true or false, got {value!r}')
        self._energy_range = value

    def _keeps_angular_momentum(self) -> bool:
        """Whether every effect keeps the angular momentum about the centre (zonal harmonics
        keep it about the pole only, a user's tidal term not at all)."""
        return all(
            "angular momentum" in type(e).CONSERVES or "angular momentum about the centre" in type(e).CONSERVES
            for e in self.effects
        )

    def _ranges_energy(self) -> bool:
        """Whether this run measures the energy between records."""
        if self._energy_range == "auto":
            return "energy" not in get_method(self.method).conserves
        return bool(self._energy_range)

    def _working_labels(self) -> list:
        """The labels of the effects that do work (drag), and ``manoeuvres`` where events fire
        impulses: their work is recorded, not conserved."""
        return [e.label for e in self.effects.working()] + (["manoeuvres"] if self.events.impulses else [])

    def _start_drift(self, tolerance) -> None:
        """A new drift monitor for a run whose first record is the reference. Under an effect
        that does work (drag, radiation pressure, a third body's changing potential) the
        momenta are not conserved and are not checked; the energy is checked as E - W, the
        energy less the work done (its balance), which an em step keeps."""
        tol = check_tolerance(self.drift_tolerance if tolerance is None else tolerance)
        kept = conserved(self.method, self.effects.conserves("momentum"), self._keeps_angular_momentum())
        working = bool(self._working_labels())
        if working:
            kept[1:] = False
        self._drift = DriftMonitor(tol, self.plan.gammas.size, kept)
        self._drift.gate = bool(kept[0]) and not working  # the recorded energy itself is conserved

    def _prepare_effects(self, n_steps: int, gammas) -> None:
        """Effects that depend on time (:meth:`~emorbit.effects.base.Effect.prepare`) sample
        the paths they follow over the next ``n_steps`` steps, with a margin for the
        composition's sub-steps, which reach outside the step."""
        if not self.effects.time_dependent():
            return
        reach = np.concatenate([[0.0], np.cumsum(gammas)])
        lo = self.time + (min(0.0, reach.min()) - 1.0) * self._dt
        hi = self.time + (n_steps + max(1.0, reach.max()) + 1.0) * self._dt
        self.effects.prepare(lo, hi, self.epoch)

    # -- state, for checkpoints and restarts -------------------------------------------
    def state_arrays(self) -> dict[str, np.ndarray]:
        """Copies of every system's state arrays: what a checkpoint stores.

        Returns
        -------
        dict
            {``"<kind>/<name>"``: array}: each system's
            :meth:`~emorbit.bodies.system.BodySystem.state_arrays`, compensation terms and warm
            starts included, and the run's drift monitor (``drift/...``,
            :meth:`~emorbit.io.drift.DriftMonitor.state_arrays`).
        """
        out = {f"{s.kind}/{k}": a for s in self.systems for k, a in s.state_arrays().items()}
        drift = self._drift.state_arrays() if self._drift is not None else absent_state()
        return out | {f"drift/{k}": a for k, a in drift.items()}

    def set_state_arrays(self, arrays: dict, steps: int) -> None:
        """Restore a state written by :meth:`state_arrays` and set the step counter.

        Parameters
        ----------
        arrays : dict
            {``"<kind>/<field>"``: array} with the shapes of this simulation's bodies.
        steps : int
            Steps taken since the start of the run.

        Raises
        ------
        InputError
            An array is missing or its shape does not match.
        """
        for s in self.systems:
            prefix = f"{s.kind}/"
            s.set_state_arrays({k[len(prefix) :]: a for k, a in arrays.items() if k.startswith(prefix)})
        drift = {k[6:]: a for k, a in arrays.items() if k.startswith("drift/")}
        self._drift = None  # a file of an earlier version: no drift is measured
        if drift and not is_absent(drift):
            self._start_drift(None)
            self._drift.set_state_arrays(drift)
        self._steps = int(steps)

    def state_units(self) -> dict[str, str]:
        """The units of state arrays that systems declare beyond :data:`emorbit.io.reader.STATE_UNITS`.

        Returns
        -------
        dict
            {``"<kind>/<field>"``: unit}, from each system's optional ``STATE_UNITS``.
        """
        units = {f"{s.kind}/{k}": u for s in self.systems for k, u in getattr(s, "STATE_UNITS", {}).items()}
        return units | {f"drift/{k}": unit for k, (_, unit) in STATE.items()}

    def _file_attrs(self, every: int, n_steps: int) -> dict:
        """The root attributes that say how the run is made (see :mod:`emorbit.io.reader`)."""
        return {
            "method": self.method,
            "order": self.order,
            "dt": self._dt,
            "t_start": self.time,
            "t_end": self.time + n_steps * self._dt,
            "steps": n_steps,
            "output_every": every,
            "checkpoint_seconds": pacing.CHECKPOINT_SECONDS,
            "gm": self.gm,
            "center": self.center,
            "field_body": (self.field.body or "") if self.field is not None else "none (free space)",
            "field_radius": self.field.radius if self.field is not None else 0.0,
            "adaptive": self.adaptive if self.adaptive is not None else 0.0,
            "roundoff": self.roundoff,
            "scene": self.scene_text if self.scene_text is not None else self.to_toml(),
            "effects": json.dumps([{"kind": e.kind, "label": e.label, **e.facts()} for e in self.effects]),
            "epoch": epoch_text(self.epoch) if self.epoch is not None else "",
        }

    def _start_run(self, n_steps, every, output, overwrite, keep, checkpoint_every, progress, tolerance) -> Result:
        """Open the file, record the start, write the first checkpoint and run (:meth:`Simulation.run`)."""
        if self.structure is not None:
            self.structure.build()
        cp = self._checkpoint_steps(checkpoint_every, every)
        self._prepare_effects(n_steps, self.plan.gammas)  # the first record's potentials need them
        grid, what = (
            (self._dt, "fixed steps") if self.adaptive is None else (every * self._dt, "adaptive steps' records")
        )
        self.effects.check_landings(self.time, self.time + n_steps * self._dt, grid, what)
        self.events.check_bodies(self.names)
        self.effects.attach_events(self.events)
        for e in self.events.events:
            if e.dv is not None and not next(s for s in self.systems if e.body in s.names).KICKS:
                raise InputError(
                    f"{e.key}.body", f"an impulse acts on a point mass or a rigid body; {e.body!r} is neither"
                )
        self._start_drift(tolerance)
        writer = None
        if output is not None:
            bodies = [
                {"name": n, "attrs": s.body_attrs(i), "datasets": s.body_datasets(i), "constants": s.body_constants(i)}
                for s in self.systems
                for i, n in enumerate(s.names)
            ]
            attrs = self._file_attrs(every, n_steps)
            attrs["checkpoint_every"] = cp
            labels = [e.label for e in self.effects.with_potential()] if self.effects.beyond_field() else []
            writer = Writer(
                output, bodies, attrs, overwrite=overwrite, potentials=labels, works=self._working_labels(),
                jacobi=self.effects.spin() is not None, ledger=self.effects.ledger(),
            )  # fmt: skip
        for s in self.systems:  # the work of non-conservative effects counts from the run's start
            if hasattr(s, "reset_work"):
                s.reset_work()
        self._run_origin = self._steps
        sink = Sink(self, writer, keep)
        sink.emit([(s, s.current()) for s in self.systems], np.array([self._steps]), 1, 0)
        if writer is not None:
            writer.write_checkpoint(self._steps - self._run_origin, self.time, self.state_arrays(), sink.rows)
        return self._run_and_close(n_steps, every, cp, sink, writer, progress, stacklevel=4)

    def _run_and_close(self, n_steps, every, cp, sink, writer, progress, stacklevel=3) -> Result:
        """Step, write, and close the file with the right status whatever happens.

        SIGINT and SIGTERM stay trapped until the file is closed, so that a second signal
        cannot cut the final writes short; a run they stop raises :class:`RunInterrupted`
        after its file is closed.
        """
        self._ev = EventRun(self)
        self._ev.start()
        with stop_on_signals() as stop:
            signum = None
            try:
                try:
                    done = self._advance(n_steps, every, sink, progress, cp, stop)
                except KeyboardInterrupt as exc:  # raised by a handler other than ours
                    done, stop.signum = -1, getattr(exc, "signum", signal.SIGINT)
                if done < n_steps and (self.stopped_by is None or done < 0):
                    signum = stop.signum or signal.SIGINT
                if writer is not None:
                    self._write_end(writer, sink, every)
            except BaseException as exc:
                if writer is not None:
                    note = writer.close("failed", f"{type(exc).__name__}: {exc}")
                    if note and isinstance(exc, FileLostError):  # say where the records are
                        exc.args = (f"{exc}{note}",)
                raise
            report = sink.monitor.report() if sink.monitor is not None and signum is None else None
            if writer is not None:
                if report is not None:
                    writer.file.attrs["warning"] = report
                elif "warning" in writer.file.attrs:  # a resumed file whose drift was cut off
                    del writer.file.attrs["warning"]
                if signum is None and self.stopped_by is not None:
                    writer.file.attrs["stopped_by"] = self.stopped_by.describe()
                    writer.close("stopped")
                elif signum is None:
                    writer.close("completed")
                else:
                    name = signal.Signals(signum).name
                    writer.close("interrupted", f"interrupted by {name} at t = {self.time!r} s")
        if signum is not None:
            raise RunInterrupted(signum)
        if report is not None:
            if self._strict:
                raise RoundoffError(report)
            warnings.warn(report, RoundoffWarning, stacklevel=stacklevel)
        return sink.result()

    def _write_end(self, writer, sink, every: int) -> None:
        """The final state, and a checkpoint where the state is a record on the record grid."""
        origin = self._run_origin
        steps = self._steps - origin
        if steps % every == 0 and sink.last_step == self._steps and self._checkpointed_at != self._steps:
            self._checkpoint(sink)
        writer.write_final_state(steps, self.time, self.state_arrays(), self.state_units())

    def _checkpoint(self, sink) -> None:
        """Drop path-dependent caches and write the state with the records so far."""
        for s in self.systems:
            s.on_checkpoint()
        if sink.writer is not None:
            origin = self._run_origin
            sink.writer.write_checkpoint(
                self._steps - origin, self.time, self.state_arrays(), sink.rows, self.state_units()
            )
        self._checkpointed_at = self._steps

    def _checkpoint_steps(self, checkpoint_every, every: int) -> int:
        """Steps between checkpoints, a multiple of ``every``; 0 (by wall time) when not given."""
        if checkpoint_every is None:
            return 0
        if (
            isinstance(checkpoint_every, bool)
            or not isinstance(checkpoint_every, numbers.Integral)
            or checkpoint_every < 1
        ):
            raise InputError("checkpoint_every", f"must be an integer >= 1, got {checkpoint_every!r}")
        return int(-(-int(checkpoint_every) // every) * every)

    def _advance_all(self, gammas, k: int, nrec: int, n0: int | None = None):
        """Every system ``nrec * k`` steps from step ``n0`` (default: now) of the run's clock."""
        clock = (self._t_base, self._steps if n0 is None else n0)
        its = self.max_newton_iterations
        return [
            (s, s.advance(self.method, self.gm, self.center, self._dt, gammas, k, nrec, its, clock))
            for s in self.systems
        ]

    def _current(self):
        """Every system's current state as a one-row record: [(system, records)]."""
        return [(s, s.current()) for s in self.systems]

    def _advance_long(self, gammas, k: int, every: int, sink: Sink, origin: int, pace: Pace, stop) -> int:
        """One record interval of ``k`` steps in calls of ``pace.steps`` steps, so that a stop
        request ends it within about a chunk's time (the state is then inside the interval:
        the file's last checkpoint stays the one to resume from). A failed step is redone as
        :meth:`_recover` does, and the rest of the interval is left to the next chunk. Returns
        the steps taken."""
        ranging = self._ranges_energy()
        acc, lo, hi, taken = None, np.inf, -np.inf, 0
        while taken < k:
            if stop is not None and stop.is_set():
                return taken
            m = min(pace.steps, pace.split_steps(self._steps) if self.events.splitting else pace.steps, k - taken)
            snapshots = [s.snapshot() for s in self.systems]
            start = _time.monotonic()
            before = self._ev.mark()
            got = self._advance_ranged(gammas, m, 1, snapshots) if (ranging or self.events) and m > 1 else None
            recs, span = got if got is not None else (self._advance_all(gammas, m, 1), None)
            failures = [(f, j) for j, (s, r) in enumerate(recs) if (f := r.first_failure()) is not None]
            if m == 1 and got is None and not failures:
                self._ev.scan(recs, 1, self._steps)
            halt = self._ev.first_stop(min(failures)[0][0] if failures else None)
            if failures or halt is not None:
                if acc is not None:  # the parts before: their stalls and energies count in the next record
                    sink.stalled_pending += _stalled(acc)
                sink.widen([lo, hi] if lo <= hi else [])
                if halt is not None:
                    taken += self._ev.act(halt, snapshots, k, every, gammas, sink)
                    pace.split(self._steps)
                    return taken
                self._ev.log_crossings(snapshots, self._steps, gammas, sink)  # those before the failure
                self._ev.reset(before)
                taken += self._recover(recs, snapshots, min(failures), k - taken, every, gammas, sink, origin)
                self._ev.restart()
                return taken
            self._ev.log_crossings(snapshots, self._steps, gammas, sink)
            pace.measured_steps(m, _time.monotonic() - start)
            if ranging:
                e = span[0] if span is not None and self._ranges_energy() else self._energies(recs, 1)
                lo, hi = min(lo, np.min(e)), max(hi, np.max(e))
            acc = recs if acc is None else [(s, _every_kth(r, 2, 1)) for s, r in _stacked([acc, recs])]
            taken += m
            self._steps += m
        sink.emit(acc, np.array([self._steps]), 1, k, np.array([[lo, hi]]) if ranging else None)
        return taken

    def _energies(self, recs, rows: int) -> np.ndarray:
        """The total energy of the first ``rows`` rows of a chunk's records, J."""
        return sum(s.invariants(r, rows, self.gm, self.center)[0] for s, r in recs)

    def _advance_ranged(self, gammas, k: int, nrec: int, snapshots, n0: int | None = None):
        """:meth:`_advance_all` for ``nrec`` records ``k`` steps apart, with the least and
        greatest total energy over each record's ``k`` steps: (records, (nrec, 2) J). The
        systems record every step, at most :data:`RANGE_BYTES` of states per call, and the
        records are every ``k``-th of those. A failed step: every system is put back to
        ``snapshots`` and None returned (the plain chunk then meets the failure)."""
        row = sum(a.nbytes for _, r in self._current() for a in vars(r).values() if isinstance(a, np.ndarray))
        per = max(1, RANGE_BYTES // max(1, row))  # steps per call
        rows, span = [], np.empty((nrec, 2))
        r = 0
        taken = 0  # steps since the clock's
        n0 = self._steps if n0 is None else n0
        while r < nrec:
            n = min(nrec - r, max(1, per // k))  # records of this call (k > per: one, in parts)
            acc, lo, hi = None, np.inf, -np.inf
            for m in (n * k,) if k <= per else (min(per, k - t) for t in range(0, k, per)):
                recs = self._advance_all(gammas, 1, m, n0 + taken)
                taken += m
                failed = [f[0] for _, rec in recs if (f := rec.first_failure()) is not None]
                if self._ev is not None:  # the steps before a failure
                    self._ev.scan(recs, min(failed, default=m), n0 + taken - m)
                if failed:
                    for s, snap in zip(self.systems, snapshots):
                        s.restore(snap)
                    return None
                e = self._energies(recs, m).reshape(-1, min(m, k))
                piece = [(s, _every_kth(rec, min(m, k), m // min(m, k))) for s, rec in recs]
                if k <= per:  # whole record intervals
                    span[r : r + n, 0], span[r : r + n, 1] = e.min(axis=1), e.max(axis=1)
                    acc = piece
                else:  # a part of one record interval, joined to the parts before
                    lo, hi = min(lo, e.min()), max(hi, e.max())
                    acc = piece if acc is None else [(s, _every_kth(rec, 2, 1)) for s, rec in _stacked([acc, piece])]
                    span[r] = lo, hi
            rows.append(acc)
            r += n
        return _stacked(rows), span

    def _advance(
        self,
        n_steps: int,
        every: int,
        sink: Sink,
        progress: bool,
        cp: int | None = None,
        stop: StopRequest | None = None,
    ) -> int:
        """Take up to ``n_steps`` steps in chunks that end on records; return the steps taken.

        With ``cp`` > 0 a checkpoint falls wherever the steps since the run's origin are a
        multiple of ``cp`` (chunks never straddle one); with ``cp`` 0 or None, and a file, it
        falls on a record when the next chunk would end more than :data:`~emorbit.pacing.CHECKPOINT_SECONDS`
        after the last checkpoint. Either way the last record on the record grid is one (the
        end of the run, written by :meth:`_write_end`, or the record before a shorter last
        interval), so that a run's last checkpoint does not depend on wall time. At each
        checkpoint the systems drop path-dependent caches and the state is written with the
        records, so that a restart from it continues bit for bit. A set ``stop`` ends the
        loop before the next chunk.
        """
        gammas = self.plan.gammas
        self._prepare_effects(n_steps, gammas)
        pace = Pace(max(1, CHUNK_BYTES // (128 * len(self.names))))
        origin = self._run_origin
        if self._steps == origin:  # the run's start: Simulation.run has written its checkpoint
            self._checkpointed_at = self._steps
        by_clock = not cp and sink.writer is not None
        split = self.events.splitting
        done = 0
        with progress_bar(n_steps, progress) as bar:
            while done < n_steps:
                if stop is not None and stop.is_set():
                    break
                left = n_steps - done
                off = (self._steps - origin) % every
                if off:  # after a step redone in sub-steps: back onto the record grid
                    k, nrec = min(every - off, left), 1
                else:
                    k = every if left >= every else left
                    most = left // k  # records up to the end, or to the next checkpoint
                    if cp:
                        most = min(most, max(1, (cp - (self._steps - origin) % cp) // k))
                    nrec = min(most, pace.records)
                    if most - nrec == 1:  # leave no chunk of a lone record
                        nrec = most
                    if split:  # a split drops the chunk's steps after it: keep chunks short
                        nrec = min(nrec, max(1, pace.split_steps(self._steps) // k))
                cap = min(pace.steps, pace.split_steps(self._steps)) if split else pace.steps
                if k > cap:  # in calls that a stop can end
                    taken = self._advance_long(gammas, k, every, sink, origin, pace, stop)
                    done += taken
                    bar.update(taken)
                    if self.stopped_by is not None:
                        break
                else:
                    start = _time.monotonic()
                    snapshots = [s.snapshot() for s in self.systems]
                    before = self._ev.mark()
                    scanned = k > 1 and (self._ranges_energy() or bool(self.events))
                    got = self._advance_ranged(gammas, k, nrec, snapshots) if scanned else None
                    recs, span = got if got is not None else (self._advance_all(gammas, k, nrec), None)
                    span = span if self._ranges_energy() else None
                    failures = [(f, j) for j, (s, r) in enumerate(recs) if (f := r.first_failure()) is not None]
                    if k == 1 and got is None:
                        self._ev.scan(recs, min(failures)[0][0] if failures else nrec, self._steps)
                    halt = self._ev.first_stop(min(failures)[0][0] if failures else None)
                    if halt is not None:
                        taken = self._ev.act(halt, snapshots, k, every, gammas, sink)
                        pace.split(self._steps)
                        done += taken
                        bar.update(taken)
                        if self.stopped_by is not None:
                            break
                    else:
                        if not failures:
                            try:
                                sink.emit(recs, self._steps + k * (np.arange(nrec) + 1), nrec, k, span)
                            except UnsolvedStep as exc:  # nothing recorded: the interval's first step is redone
                                failures = [((exc.row * k, 0, STATUS_UNSOLVED), 0)]
                                self._refused = exc
                        if not failures:
                            self._ev.log_crossings(snapshots, self._steps, gammas, sink)
                            self._steps += k * nrec
                            done += k * nrec
                            bar.update(k * nrec)
                            if k == every:
                                pace.measured(nrec, _time.monotonic() - start, k * nrec)
                        else:
                            self._ev.log_crossings(snapshots, self._steps, gammas, sink)  # those before the failure
                            self._ev.reset(before)
                            taken = self._recover(recs, snapshots, min(failures), k, every, gammas, sink, origin)
                            self._ev.restart()
                            done += taken
                            bar.update(taken)
                            if self.stopped_by is not None:  # a stop in the step redone in sub-steps
                                break
                since = self._steps - origin
                # the last record on the grid before a shorter last interval: the run's last checkpoint
                last = since % every == 0 and 0 < n_steps - done < every
                if cp:
                    due = since % cp == 0 or last
                else:
                    due = by_clock and since % every == 0 and done < n_steps and (last or pace.checkpoint_due())
                if due:
                    self._checkpoint(sink)
                    pace.checkpointed()
        return done

    #: a failing step is retried as 2, 4, ... 2**MAX_SPLIT sub-steps before the run stops
    MAX_SPLIT = 4

    def _replay(self, snapshots, steps: int, k: int, gammas, sink):
        """Put every system back to ``snapshots`` (a chunk's start) and take its first ``steps``
        steps again (the kernels are deterministic): the records on the grid of ``k`` are
        emitted, the steps after the last of them count in the next record. Returns None, or
        (the UnsolvedStep an emitted record met, its chunk's records)."""
        for s, snap in zip(self.systems, snapshots):
            s.restore(snap)
        good, rest = divmod(steps, k)
        ranging = self._ranges_energy()
        n0 = self._steps
        for n, each in ((good, k), (1 if rest else 0, rest)):  # the records before it, then the rest
            if not n:
                continue
            got = self._advance_ranged(gammas, each, n, snapshots, n0) if ranging and each > 1 else None
            again, span = got if got is not None else (self._advance_all(gammas, each, n, n0), None)
            n0 += n * each
            if any(r.first_failure() is not None for _, r in again) or (ranging and each > 1 and got is None):
                raise RuntimeError("re-running the steps before a failure failed again")  # deterministic: cannot
            if each == k:
                try:
                    sink.emit(again, self._steps + k * (np.arange(n) + 1), n, k, span)
                except UnsolvedStep as exc:
                    return exc, again
            else:
                sink.stalled_pending += _stalled(again)
                if ranging:
                    sink.widen(span if span is not None else self._energies(again, 1))
        return None

    def _recover(self, recs, snapshots, failure, k, every, gammas, sink, origin) -> int:
        """A step failed: keep the records before it, bring every body to its start (re-running
        from the chunk's snapshots; the kernels are deterministic), then redo that one step in
        2, 4, ... 2**MAX_SPLIT sub-steps (each an ordinary step: exact conservation is kept).
        Returns the steps taken; raises IntegrationError if every split fails."""
        (step, index, status), j = failure
        refused = self._replay(snapshots, step, k, gammas, sink)
        if refused is not None:  # an earlier step was not solved: redo from that one
            self._refused, again = refused
            earlier = ((self._refused.row * k, 0, STATUS_UNSOLVED), 0)
            return self._recover(again, snapshots, earlier, k, every, gammas, sink, origin)
        self._steps += step
        start = [s.snapshot() for s in self.systems]
        g0 = self._ev.before_redo()
        gate = self._drift is not None and self._drift.gate
        e0 = self._energies(self._current(), 1)[0] if gate else 0.0
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
                        (self.time, 0),  # the failed step's start: sub-step j at time + j dt / parts
                    ),
                )
                for s in self.systems
            ]
            if all(r.first_failure() is None for _, r in sub) and not (gate and self._unsolved(sub, e0, parts)):
                self.retried_steps = self.retried_steps + 1
                sink.split_pending += 1
                acted = self._ev.redone(start, self.time, parts, g0, gammas, sink)
                if acted == "stop":  # the run ends at the event, its record emitted
                    return step + 1
                if acted == "split":
                    sub = self._current()
                self._steps += 1
                if (self._steps - origin) % every == 0:
                    sink.emit(sub, np.array([self._steps]), 1, 1)
                else:
                    sink.stalled_pending += _stalled(sub)
                    if self._ranges_energy():
                        sink.widen(self._energies(sub, 1))
                return step + 1
            for s, snap in zip(self.systems, start):
                s.restore(snap)
        if sink.last_step != self._steps:  # record the last good state if it is not yet, then stop
            sink.emit([(s, s.current()) for s in self.systems], np.array([self._steps]), 1, 0)
        system = recs[j][0]
        name = system.names[index]
        if status == STATUS_UNSOLVED:
            reason = (
                f"{self._refused.reason}; so did the step in 2 to {2**self.MAX_SPLIT} sub-steps "
                f"(method {self.method}, order {self.order}, dt = {self._dt!r} s): take a smaller dt"
            )
        elif status == STATUS_NO_CONVERGENCE:
            reason = (
                f"the step failed as a whole and in 2 to {2**self.MAX_SPLIT} sub-steps (method {self.method}, "
                f"order {self.order}, dt = {self._dt!r} s): {self._newton_note(system, index, gammas)}"
            )
        else:
            x, _ = self.state(name)
            reason = (
                f"a point reached the field's centre or the state stopped being finite "
                f"(last good position {x.tolist()} m)"
            )
        raise IntegrationError(self.time, name, reason)

    #: the event that ended the last run (None: it ran to its end, or has not run)
    stopped_by = None
    #: the events of the run in progress (:class:`emorbit.event_run.EventRun`)
    _ev = None

    def _unsolved(self, sub, e0: float, parts: int) -> bool:
        """Whether a step redone in ``parts`` sub-steps (``sub``, one record) still moves the
        energy from ``e0`` (J, at the step's start) beyond round-off (:mod:`emorbit.io.drift`)."""
        e1 = self._energies(sub, 1)[0]
        scale = max(sum(s.invariant_scales(r, 1, self.gm, self.center) for s, r in sub)[0][0], self._drift.scale[0])
        return bool(self._drift.too_far(e1 - e0, scale, parts * self.plan.gammas.size))

    def _newton_note(self, system, index, gammas) -> str:
        """What failed in the Newton iteration of a step that failed even in sub-steps: its
        behaviour from the step's start at the smallest sub-step tried and, where that one
        converges, at the whole step (:meth:`~emorbit.bodies.system.BodySystem.newton_facts`)."""
        n = self.max_newton_iterations
        generic = f"Newton's iteration did not converge within max_newton_iterations = {n} iterations; try a smaller dt"
        parts = 2**self.MAX_SPLIT
        for h, where in (
            (self._dt * gammas[0] / parts, f"at the smallest sub-step, dt/{parts} = {self._dt / parts:.6g} s,"),
            (self._dt * gammas[0], f"at the whole step, dt = {self._dt:.6g} s,"),
        ):
            facts = system.newton_facts(index, self.method, self.gm, self.center, h, n)
            if facts is None:
                return generic
            status, update, residual = facts
            if status != STATUS_OK:
                return newton_failure(n, update, residual, where)
        return generic + " (from the step's start it converges: a later sub-step failed)"


def _every_kth(rec, k: int, n: int):
    """Records of ``n * k`` single steps as ``n`` records ``k`` steps apart: the state of every
    ``k``-th step, the counts (``iterations``, ``stalled``, ``solves``) summed over each ``k``."""
    out = {}
    for f in dataclasses.fields(rec):
        a = getattr(rec, f.name)
        if a is None or f.name == "fail":
            out[f.name] = a
        elif f.name in _COUNTS:
            out[f.name] = a[: n * k].reshape((n, k) + a.shape[1:]).sum(axis=1).astype(a.dtype)
        else:
            out[f.name] = np.ascontiguousarray(a[k - 1 : n * k : k])
    return type(rec)(**out)


def _stacked(rows):
    """One chunk's records from consecutive pieces (each a list of (system, records))."""
    if len(rows) == 1:
        return rows[0]
    out = []
    for j, (s, first) in enumerate(rows[0]):
        recs = [p[j][1] for p in rows]
        fields = {}
        for f in dataclasses.fields(first):
            arrays = [getattr(r, f.name) for r in recs]
            fields[f.name] = arrays[0] if arrays[0] is None or f.name == "fail" else np.concatenate(arrays)
        out.append((s, type(first)(**fields)))
    return out


#: the fields of records that count per record interval (summed when intervals are joined)
_COUNTS = ("iterations", "stalled", "solves")


def _stalled(recs) -> int:
    """Sub-steps accepted at a stall in a list of (system, records) pairs."""
    return int(sum(np.sum(r.stalled) for _, r in recs if getattr(r, "stalled", None) is not None))
