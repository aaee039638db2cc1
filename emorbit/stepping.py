"""Taking a simulation's steps: compiled chunks, records, checkpoints, and failed steps.

:class:`ChunkDriver` is the part of :class:`emorbit.Simulation` that steps. It advances every
body system in chunks of steps that end on records and never straddle a checkpoint
(:data:`CHUNK_WORK` and :data:`CHUNK_BYTES` bound a chunk), hands each chunk's records to
the :class:`~emorbit.io.recorder.Sink`, and writes the complete state at every checkpoint,
so that a run restarted from one continues bit for bit (:mod:`emorbit.io.resume`).

A step that fails (Newton does not converge) is redone from the chunk's snapshots in 2, 4,
... 2**MAX_SPLIT sub-steps; each sub-step is an ordinary step of the method, so energy and
angular momentum stay conserved. Whatever ends the run (its end, a failure, Ctrl-C), the
output file is closed with the matching status: "completed", "failed" or "interrupted".
"""

from __future__ import annotations

import numbers
import signal
import threading

import numpy as np

from .errors import InputError, IntegrationError
from .integrators import coefficients
from .io.recorder import Sink, progress_bar
from .kernels.codes import STATUS_NO_CONVERGENCE
from .result import Result

__all__ = ["ChunkDriver", "CHUNK_WORK", "CHUNK_BYTES"]

#: body-substeps (weighted by system cost) per compiled chunk: about 0.5 s of em work
CHUNK_WORK = 4_000_000
#: bytes of recorded state per chunk at most
CHUNK_BYTES = 128 * 2**20


class ChunkDriver:
    """The stepping half of :class:`emorbit.Simulation`: a base class that holds no state.

    It reads the simulation's ``systems``, ``method``, ``order``, ``dt``, field and settings
    and moves its step counter; :meth:`state_arrays` and :meth:`set_state_arrays` are the
    state a checkpoint stores and a restart restores.
    """

    # -- state, for checkpoints and restarts -------------------------------------------
    def state_arrays(self) -> dict[str, np.ndarray]:
        """Copies of every system's state arrays: what a checkpoint stores.

        Returns
        -------
        dict
            {``"<kind>/<name>"``: array}: each system's
            :meth:`~emorbit.bodies.system.BodySystem.state_arrays`, compensation terms and warm
            starts included.
        """
        return {f"{s.kind}/{k}": a for s in self.systems for k, a in s.state_arrays().items()}

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
        self._steps = int(steps)

    def _file_attrs(self, every: int, n_steps: int) -> dict:
        """The root attributes that say how the run is made (see :mod:`emorbit.io.hdf5`)."""
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
