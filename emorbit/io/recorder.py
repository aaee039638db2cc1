"""Recording a run: the sink that turns each chunk's states into records, and the progress bar.

A :class:`Sink` receives the states a chunk of steps recorded, computes the invariants of
every record (energy in J, linear momentum in kg m/s, angular momentum about the field's
centre in kg m2/s; under effects that do work, such as drag, the work each has done since the
run's start and the energy balance ``E - E0 - sum W``, which an em step keeps at round-off),
the mean Newton iterations per solve, the steps redone in sub-steps and
the sub-steps whose Newton iteration was accepted at a stall in each record interval, and
the drift of the conserved invariants against the bound round-off explains (the
simulation's :class:`~emorbit.io.drift.DriftMonitor`); stops the run when a record falls
inside the central body, appends the records to the output file (a
:class:`~emorbit.io.hdf5.Writer`) and keeps them in memory (all, or the first and the last).
:meth:`Sink.result` assembles the kept records into a :class:`~emorbit.result.Result`.
"""

from __future__ import annotations

import sys

import numpy as np

from ..errors import IntegrationError
from ..integrators import get_method
from ..result import Result
from .drift import UnsolvedStep

__all__ = ["Sink", "progress_bar"]


class _NoBar:
    """Stands in for a progress bar when none is shown: updates are ignored."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n: int) -> None:
        pass


def progress_bar(n_steps: int, progress: bool):
    """A progress bar over the steps of a run, or a stand-in that ignores updates.

    tqdm is imported only when a bar is wanted, so a quiet run does not pay for its import.

    Parameters
    ----------
    n_steps : int
        The steps the run takes.
    progress : bool
        Show tqdm's bar on stderr (from 2 s after the first chunk: a first run's compile of
        the kernels stays out of its rate).

    Returns
    -------
    context manager
        An object with ``update(n)``, used in a ``with`` block.
    """
    if not progress:
        return _NoBar()
    return _LaterBar(n_steps)


class _LaterBar:
    """tqdm's bar, made at the first update with the steps done so far as its start: the first
    chunk (where the kernels compile on a first run) stays out of the bar's rate and time left."""

    def __init__(self, n_steps: int):
        self.n_steps, self.bar = n_steps, None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.close()

    def update(self, n: int) -> None:
        if self.bar is None:
            from tqdm.auto import tqdm

            self.bar = tqdm(
                total=self.n_steps, initial=n, delay=2.0, unit="step", file=sys.stderr, dynamic_ncols=True, leave=False
            )
        else:
            self.bar.update(n)


class Sink:
    """Collects records: computes invariants, appends to the file and keeps them in memory.

    Parameters
    ----------
    sim : Simulation
        The simulation whose systems record.
    writer : Writer or None
        The output file, if any.
    keep : bool
        Keep every record in memory (else the first and the last).

    Attributes
    ----------
    rows : int
        Records emitted so far.
    last_step : int or None
        The step count of the last record.
    split_pending : int
        Steps redone in sub-steps since the last record: the next record's
        ``diagnostics/split_steps``.
    stalled_pending : int
        Sub-steps accepted at a stall since the last record that no emitted chunk holds (in
        steps redone in sub-steps): added to the next record's ``diagnostics/stalled_solves``.
    monitor : DriftMonitor or None
        The simulation's drift monitor (``sim._drift``); None: no drift is measured (-1).
    range_pending : ndarray
        (2,) the least and greatest total energy, J, of the steps since the last record that
        no emitted chunk holds (steps redone in sub-steps); widens the next record's
        ``invariants/energy_range``.
    energy0 : float or None
        Under effects that do work (drag): the energy of the run file's first record, J, the
        E0 of ``invariants/energy_balance = E - E0 - sum W``.
    ledger0 : float or None
        Under burns that expel mass: the bodies' energy at their true masses at the run
        file's first record, J (the ledger's E_b0).
    ledger : bool
        Whether the records hold the mass ledger (``invariants/ledger_*``).
    works : list of dict
        Under effects that do work: each emitted block's ``work_<label>`` (the work since the
        run's start, J, summed over the points) and ``energy_balance`` (J).
    """

    def __init__(self, sim, writer, keep: bool):
        self.sim = sim
        self.writer = writer
        self.keep = keep
        self.blocks: list[tuple] = []
        self.rows = 0  # records emitted so far
        self.last_step = None  # the step count of the last record
        self.split_pending = 0
        self.stalled_pending = 0
        self.monitor = getattr(sim, "_drift", None)
        self.range_pending = np.array([np.inf, -np.inf])
        self.energy0 = None  # E0 of the energy balance: the run file's first record
        self.ledger0 = None  # the bodies' energy at their true masses at the run file's first record
        self.ledger = bool(getattr(sim, "effects", None) is not None and sim.effects.ledger())
        self.works: list[dict] = []  # {work_<label>, energy_balance: (rows,) J} per emitted block
        self.last_energy = None  # the last record's total energy, J

    def widen(self, energy) -> None:
        """Widen the next record's energy range by energies (J) of steps between records.

        Parameters
        ----------
        energy : array_like
            Total energies, J, any shape.
        """
        energy = np.asarray(energy, float)
        if energy.size:
            self.range_pending = np.array(
                [min(self.range_pending[0], energy.min()), max(self.range_pending[1], energy.max())]
            )

    def emit_rows(self, recs, steps, nrec: int, k: int, span=None) -> None:
        """Record the first ``nrec`` rows of a chunk (the ones before a collision).

        Parameters
        ----------
        recs : list
            (system, records) pairs of one chunk.
        steps : ndarray
            Step counts of the chunk's records.
        nrec : int
            Rows to record.
        k : int
            Steps in each record interval.
        span : ndarray, optional
            (rows, 2) the least and greatest total energy over each record's interval, J.
        """
        self.emit(recs, steps[:nrec], nrec, k, None if span is None else span[:nrec])

    def emit(self, recs, steps, nrec: int, k: int, span=None, times=None) -> None:
        """Record rows of each system's chunk: invariants, datasets, file, memory.

        Parameters
        ----------
        recs : list
            (system, records) pairs of one chunk.
        steps : ndarray
            (nrec,) step counts of the rows.
        nrec : int
            Rows to record.
        k : int
            Steps in each record interval, for the mean Newton iterations (0 for the start
            record, which closes no interval).
        span : ndarray, optional
            (nrec, 2) the least and greatest total energy over the steps of each record's
            interval, J (None: the interval's range is the record's own energy).
        times : ndarray, optional
            (nrec,) the records' times, s (default: from the steps; a stopping event's record
            is off the step grid).

        Raises
        ------
        IntegrationError
            A body is inside the central body's radius; the rows before it are recorded.
        """
        sim = self.sim
        gm, center = sim.gm, sim.center
        times = sim._t_base + np.asarray(steps) * sim._dt if times is None else np.asarray(times, float)
        energy = np.zeros(nrec)
        momentum = np.zeros((nrec, 3))
        angular = np.zeros((nrec, 3))
        data = {}
        iters = np.zeros(nrec)
        stalled = np.zeros(nrec)
        substeps = None  # counted by an adaptive kernel
        solves = 0
        potentials = {}  # each effect's potential energy (systems under effects)
        works = {}  # the work of the effects that do work, since the run's start
        for system, rec in recs:
            if hasattr(rec, "t"):  # the records' times, for potentials that depend on time
                rec.t = times[:nrec]
            if hasattr(system, "effect_energies") and self.writer is not None:
                for name, e in system.effect_energies(rec, nrec, gm, center).items():
                    potentials[name] = potentials.get(name, 0.0) + e
            if hasattr(system, "effect_work"):
                for name, w in system.effect_work(rec, nrec).items():
                    works[name] = works.get(name, 0.0) + w
            e, p, L = system.invariants(rec, nrec, gm, center)
            energy += e
            momentum += p
            angular += L
            data.update(system.datasets(rec, nrec, times, self.rows))
            iters += rec.iterations[:nrec].sum(axis=1)
            if getattr(rec, "stalled", None) is not None:
                stalled += rec.stalled[:nrec].sum(axis=1)
            if getattr(rec, "solves", None) is not None:  # adaptive: solves counted by the kernel
                solves = solves + rec.solves[:nrec].sum(axis=1) / max(k, 1)
                substeps = rec.solves[:nrec].max(axis=1, initial=0)
            else:  # solves per step: points, bodies, or 1 per structure
                solves = solves + rec.iterations.shape[1] * get_method(sim.method).solves_per_step(sim.order)
        lost = sim.effects.mass_lost(times[:nrec]) if self.ledger else {}
        terms = [system.ledger(rec, nrec, lost) for system, rec in recs if self.ledger and hasattr(system, "ledger")]
        if sim.events.impulses:  # the impulses' work so far (emorbit.events)
            works["work_manoeuvres"] = np.full(nrec, sim.events.impulse_work)
        its = iters / np.maximum(k * solves, 1) if k else np.zeros(nrec)
        rel = np.asarray(steps[:nrec]) - getattr(sim, "_run_origin", 0)  # steps since the file's start
        # under effects that do work, E - W is what the step keeps (the balance)
        kept = energy - sum(works.values()) if works else energy
        scales = None
        if self.monitor is not None:
            scales = sum(system.invariant_scales(rec, nrec, gm, center) for system, rec in recs)
            self._refuse(recs, steps, times, nrec, k, span, rel, energy, kept, scales, substeps)
        radius = sim.field.radius if sim.field is not None else 0.0
        if radius > 0.0:  # a body inside the central body: keep the records before, then stop
            names = list(data)
            pos = np.stack([data[n]["position"] for n in names])  # (bodies, nrec, 3), one pass
            below = np.einsum("brk,brk->br", pos - sim.center, pos - sim.center) < radius * radius
            inside = below.any(axis=0)
            if inside.any():
                first = int(np.argmax(inside))
                who = names[int(np.argmax(below[:, first]))]
                if first:
                    self.emit_rows(recs, steps, first, k, span)
                raise IntegrationError(
                    float(times[first]),
                    who,
                    f"it is inside the central body (r < radius = {radius!r} m); "
                    "records up to the one before are written",
                )
        erange = np.repeat(energy[:, None], 2, axis=1)
        if span is not None:  # the record's own energy too: it is one of the interval's steps
            erange[:, 0] = np.minimum(erange[:, 0], span[:nrec, 0])
            erange[:, 1] = np.maximum(erange[:, 1], span[:nrec, 1])
        erange[0] = min(erange[0, 0], self.range_pending[0]), max(erange[0, 1], self.range_pending[1])
        self.range_pending = np.array([np.inf, -np.inf])
        split = np.zeros(nrec)
        split[0] = self.split_pending
        stalled[0] += self.stalled_pending
        self.split_pending = self.stalled_pending = 0
        jacobi = {}
        spin = sim.effects.spin() if getattr(sim, "effects", None) is not None else None
        if spin is not None:  # a turning field: the Jacobi integral E - w . L about its centre
            jacobi["jacobi"] = energy - angular @ spin
        if works:  # E - E0 - W: the energy the records hold beyond the work done on the bodies
            if self.energy0 is None:
                resumed = self.writer is not None and self.rows > 0  # the file's first record is E0
                self.energy0 = float(self.writer.file["invariants/energy"][0]) if resumed else float(energy[0])
            works["energy_balance"] = energy - self.energy0 - sum(works.values())
            if self.ledger:
                works.update(self._ledger(energy, works, terms, nrec))
            entry = {k: np.array(w, float) for k, w in works.items()}
            if self.keep or not self.works:  # as the blocks: all, or the first and the last
                self.works.append(entry if self.keep else {k: w[:1] for k, w in entry.items()})
            if not self.keep:
                self.works[1:] = [{k: w[-1:] for k, w in entry.items()}]
        drift, bound = np.full((nrec, 3), -1.0), np.full(nrec, -1.0)  # -1: not measured
        if self.monitor is not None:
            drift, bound = self.monitor.update(times, rel, kept, momentum, angular, scales, substeps, stalled)
        self.rows += nrec
        self.last_step = int(steps[nrec - 1])
        self.last_energy = float(energy[nrec - 1])
        block = (times, energy, momentum, angular, its, data, split, stalled, drift, bound, erange)
        if self.writer is not None:
            self.writer.append(
                *block[:6],
                split_steps=split,
                stalled_solves=stalled,
                invariant_drift=drift,
                drift_bound=bound,
                energy_range=erange,
                **potentials,
                **works,
                **jacobi,
            )
        if self.keep or not self.blocks:
            self.blocks.append(block if self.keep else _row(block, 0))
        if not self.keep:
            self.blocks[1:] = [_row(block, -1)]

    def _ledger(self, energy, works, terms, nrec) -> dict:
        """The mass ledger of a run whose burns expel mass (``docs/methods.md``, "Finite
        burns"): the bodies' energy at their true masses, the work done on them there, the
        energy the propellant has carried away, and the ledger's balance ``E_b - E_b0 - W_b +
        X``, which stays at round-off (each (nrec,) J)."""
        body = energy + sum(t.get("energy", 0.0) for t in terms)
        done = sum(w for k, w in works.items() if k != "energy_balance")
        done = done + sum(t.get("work", 0.0) for t in terms) + np.zeros(nrec)
        expelled = np.zeros(nrec) + sum(t.get("expelled", 0.0) for t in terms)
        if self.ledger0 is None:
            resumed = self.writer is not None and self.rows > 0  # the file's first record is E_b0
            self.ledger0 = float(self.writer.file["invariants/ledger_energy"][0]) if resumed else float(body[0])
        return {
            "ledger_energy": body,
            "ledger_work": done,
            "ledger_expelled": expelled,
            "ledger_balance": body - self.ledger0 - done + expelled,
        }

    def _refuse(self, recs, steps, times, nrec, k, span, rel, energy, kept, scales, substeps) -> None:
        """Refuse a block before anything of it is recorded: an energy-conserving step that moved
        the energy beyond round-off (:class:`~emorbit.io.drift.UnsolvedStep`: nothing of the block
        is recorded, so that the steps can be redone), or a run whose energy grew by orders of
        magnitude (:class:`~emorbit.errors.IntegrationError`, the records before recorded)."""
        sim = self.sim
        names = sim.names
        who = ", ".join(names) if len(names) <= 3 else f"{names[0]} and {len(names) - 1} other bodies"
        if k:  # the start record closes no interval
            previous = self.last_energy
            if previous is None and self.writer is not None and self.rows > 0:  # resumed: the file's last record
                previous = float(self.writer.file["invariants/energy"][self.rows - 1])
            bad = self.monitor.unsolved(previous, rel, energy, scales, substeps)
            if bad is not None:
                row, change, scale, n = bad
                raise UnsolvedStep(float(times[row]) - k * sim._dt, who, change, scale, n, row)
        gone = self.monitor.diverged(kept, scales)
        if gone is not None:
            row, first, now, start = gone
            if row:
                self.emit_rows(recs, steps, row, k, span)
            raise IntegrationError(
                float(times[row]) - k * sim._dt,
                who,
                f"the run diverged: its energy went from {first:.6g} J at the first record to {now:.6g} J, "
                f"{abs(now - first) / max(start, np.finfo(float).tiny):.3g} times the energy's round-off scale "
                f"at the start (T + |V| + W = {start:.6g} J); records up to the one before are written. "
                f"Method {sim.method} at dt = {sim.dt!r} s does not follow this motion: take a smaller dt",
            )

    def result(self) -> Result:
        """The kept records.

        Returns
        -------
        Result
            With the simulation's method, order, step, field and body masses and kinds.
        """
        blocks = self.blocks
        sim = self.sim
        cat = lambda j: np.concatenate([b[j] for b in blocks])  # noqa: E731
        bodies = {n: {q: np.concatenate([b[5][n][q] for b in blocks]) for q in blocks[0][5][n]} for n in sim.names}
        masses, kinds = {}, {}
        for s in sim.systems:
            for i, n in enumerate(s.names):
                attrs = s.body_attrs(i)
                masses[n] = attrs["mass"]
                kinds[n] = attrs["kind"]
        return Result(
            time=cat(0),
            energy=cat(1),
            momentum=cat(2),
            angular_momentum=cat(3),
            newton_iterations=cat(4),
            bodies=bodies,
            masses=masses,
            kinds=kinds,
            method=sim.method,
            order=sim.order,
            dt=sim.dt,
            gm=sim.gm,
            center=sim.center.copy(),
            split_steps=cat(6),
            stalled_solves=cat(7),
            invariant_drift=cat(8),
            drift_bound=cat(9),
            energy_range=cat(10),
            events=list(sim.events.log),
            **self._works(sum(len(b[0]) for b in blocks)),
        )

    def _works(self, rows: int) -> dict:
        """``work``, ``energy_balance`` and the mass ``ledger`` of the kept records (empty when
        none were kept)."""
        if not self.works or sum(len(w["energy_balance"]) for w in self.works) != rows:
            return {}
        cat = {k: np.concatenate([w[k] for w in self.works]) for k in self.works[0]}
        balance = cat.pop("energy_balance")
        ledger = {k[len("ledger_") :]: cat.pop(k) for k in list(cat) if k.startswith("ledger_")}
        work = {k[len("work_") :]: v for k, v in cat.items()}
        return {"work": work, "energy_balance": balance, "ledger": ledger}


def _row(block, i):
    sl = slice(i, i + 1) if i >= 0 else slice(i, None)
    rows = {n: {q: a[sl] for q, a in d.items()} for n, d in block[5].items()}
    return tuple(rows if j == 5 else a[sl] for j, a in enumerate(block))
