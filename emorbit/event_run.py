"""The events of a run in progress: each step's crossings noted, located and logged, a stop made.

The chunk driver (:mod:`emorbit.stepping`) hands every chunk's per-step states to
:meth:`EventRun.scan`, which evaluates every event's g (:mod:`emorbit.events`) and notes the
crossings as (step, event, g before, g after). After a chunk, :meth:`EventRun.log_crossings`
puts the systems back to the chunk's start, re-runs them to each crossing's step (the kernels
are deterministic), locates it there with steps of shorter length (:meth:`EventRun.find`),
logs it and puts the systems back where the chunk left them, so the run's states do not
depend on its events. A step redone in sub-steps after a failed Newton iteration is checked
on its own (:meth:`EventRun.redone`), its crossings located with the same sub-steps. A
stopping event's crossing is handled before the chunk is recorded (:meth:`EventRun.stop_at`):
the records before it are emitted again, the run ends at the event's state, and its clock
goes on from the event's time.

Data layout: crossings are tuples (step: int, the step number after which g has its new
sign; event index; g before; g after); the log is :attr:`emorbit.events.EventSet.log`.
"""

from __future__ import annotations

import numpy as np

from .errors import IntegrationError
from .events import locate

__all__ = ["EventRun"]


class EventRun:
    """The events of one run (or resume) of a simulation.

    Parameters
    ----------
    sim : Simulation
        The simulation running; its ``events`` (:class:`emorbit.events.EventSet`), systems,
        clock and method are read, and ``stopped_by`` set by a stop.
    """

    def __init__(self, sim):
        self.sim = sim
        self.events = sim.events
        self._crossings: list = []
        self._scanning = True
        self._mark = (None, set())

    def data(self, recs, rows: int, times) -> dict:
        """{body: datasets} of the first ``rows`` records."""
        data = {}
        for s, r in recs:
            data.update(s.datasets(r, rows, times, 0))
        return data

    def g(self, recs, rows: int, times) -> np.ndarray:
        """Every event's g at the first ``rows`` records: (rows, events)."""
        radius = self.sim.field.radius if self.sim.field is not None else 0.0
        return self.events.values(times, self.data(recs, rows, times), self.sim.center, radius)

    def _from_here(self) -> None:
        """g at the systems' current state: the sign the next step is compared with."""
        if self.events:
            self.events.previous = self.g(self.sim._current(), 1, np.array([self.sim.time]))[0]

    def start(self) -> None:
        """g at the run's start: the sign each event's first step is compared with."""
        self.sim.stopped_by = None
        self._from_here()

    def scan(self, recs, m: int, first: int) -> None:
        """Note the crossings in ``m`` steps whose states are the rows of ``recs`` (the steps
        ``first + 1`` to ``first + m``): (step, event, g before, g after)."""
        if not self.events or not self._scanning:
            return
        steps = first + 1 + np.arange(m)
        g = self.g(recs, m, self.sim._t_base + steps * self.sim._dt)
        self._crossings += [(int(steps[r]), j, g0, g1) for r, j, g0, g1 in self.events.crossings(g)]

    def mark(self):
        """What a failed or cut chunk puts back: the sign state before it, and which events had
        happened."""
        self._crossings = []
        self._mark = (None if self.events.previous is None else self.events.previous.copy(), set(self.events.fired))
        return self._mark

    def reset(self, mark) -> None:
        """A chunk failed: forget its crossings (the steps before the failure are logged, the
        step redone in sub-steps is checked by :meth:`redone`)."""
        self.events.previous, self.events.fired = mark[0], set(mark[1])
        self._crossings, self._scanning = [], False

    def restart(self) -> None:
        """After steps redone in sub-steps: scan again, from the state reached."""
        self._scanning = True
        self._crossings = []
        self._from_here()

    def before_redo(self):
        """g at the start of a step about to be redone in sub-steps (None without events)."""
        if not self.events:
            return None
        return self.g(self.sim._current(), 1, np.array([self.sim.time]))[0]

    def _sub_step(self, j: int, tau: float, t0: float, parts: int, gammas):
        """``parts`` sub-steps of ``tau / parts`` from the systems' state at time ``t0`` (as a
        redone step takes them): (g of event j after them, the records)."""
        sim = self.sim
        its = sim.max_newton_iterations
        recs = [
            (s, s.advance(sim.method, sim.gm, sim.center, tau / parts, gammas, parts, 1, its, (t0, 0)))
            for s in sim.systems
        ]
        if any(r.first_failure() is not None for _, r in recs):
            return float("nan"), recs
        return float(self.g(recs, 1, np.array([t0 + tau]))[0, j]), recs

    def redone(self, start, t0: float, parts: int, g0, gammas, sink) -> str:
        """A step from ``start`` (snapshots at time ``t0``) redone in ``parts`` sub-steps after
        its Newton iteration failed: its crossings against g0 (g at its start), located by
        the same sub-steps of shorter length and logged; a stop ends the run at its event
        (as :meth:`stop_at`), an impulse or a burn's switch splits the step there (as
        :meth:`kick_at`). Returns "stop", "split" or "" (the systems then at the step's end);
        the caller counts the step."""
        if g0 is None:
            return ""
        sim = self.sim
        step = sim._steps + 1
        self.events.previous = g0
        found = self.events.crossings(self.g(sim._current(), 1, np.array([t0 + sim._dt])))
        if not found:
            return ""
        end = [s.snapshot() for s in sim.systems]

        def at(j, g_a, g_b):
            def g_of(tau):
                for s, snap in zip(sim.systems, start):
                    s.restore(snap)
                return self._sub_step(j, tau, t0, parts, gammas)[0]

            return locate(g_of, sim._dt, g_a, g_b, t0)

        located = sorted((at(j, a, b), j, a, b) for _, j, a, b in found)
        for tau, j, a, b in located:
            crossing, e, t = (step, j, a, b), self.events.events[j], t0 + tau
            for s, snap in zip(sim.systems, start):
                s.restore(snap)
            recs = self._sub_step(j, tau, t0, parts, gammas)[1]
            if e.stop:
                sim._steps = step
                sim._t_base = t - step * sim._dt  # the clock goes on from the event
                sink.emit(recs, np.array([step]), 1, 1, times=np.array([t]))
                self.log_event(crossing, t, recs, sink)
                sim.stopped_by = e
                return "stop"
            if e.splits:
                self._kick(crossing, t, recs, sink)
                rest = self._sub_step(j, sim._dt - tau, t, parts, gammas)[1] if tau < sim._dt else recs
                if any(r.first_failure() is not None for _, r in rest):
                    raise IntegrationError(t, e.body or "", f"the rest of the step after {e.label} failed")
                return "split"
            self.log_event(crossing, t, recs, sink)
        for s, snap in zip(sim.systems, end):
            s.restore(snap)
        return ""

    def first_stop(self, failed=None):
        """The earliest crossing in the chunk of an event that stops the run or splits its step
        (an impulse, a burn's switch), or None; with a step that failed (its index in the
        chunk), only a crossing in a step before it."""
        events = self.events.events
        stops = [c for c in self._crossings if events[c[1]].stop or events[c[1]].splits]
        if failed is not None:
            stops = [c for c in stops if c[0] - self.sim._steps <= failed]
        return min(stops) if stops else None

    def _step(self, length: float, t0: float, gammas):
        """Every system one step of ``length`` from its state at time ``t0``: its records."""
        sim = self.sim
        its = sim.max_newton_iterations
        return [(s, s.advance(sim.method, sim.gm, sim.center, length, gammas, 1, 1, its, (t0, 0))) for s in sim.systems]

    def g_after(self, j: int, tau: float, t0: float, gammas):
        """One step of length ``tau`` from the systems' state at time ``t0``: (g of event j
        after it, the records)."""
        recs = self._step(tau, t0, gammas)
        if any(r.first_failure() is not None for _, r in recs):
            return float("nan"), recs
        return float(self.g(recs, 1, np.array([t0 + tau]))[0, j]), recs

    def find(self, crossing, gammas):
        """The systems at the start of the crossing's step: the step length at the event
        (:func:`emorbit.events.locate`); the systems are left at the event. Returns (time, the
        step length, records at the event, the snapshots of the step's start)."""
        step, j, g0, g1 = crossing
        systems = self.sim.systems
        start = [s.snapshot() for s in systems]
        t0 = self.sim._t_base + (step - 1) * self.sim._dt
        last = [None]  # (tau, records) of the last trial, whose state the systems hold

        def g_of(tau):
            for s, snap in zip(systems, start):
                s.restore(snap)
            g, recs = self.g_after(j, tau, t0, gammas)
            last[0] = tau, recs
            return g

        tau = locate(g_of, self.sim._dt, g0, g1, t0)
        if last[0] is not None and last[0][0] == tau:  # the systems are at the event already
            recs = last[0][1]
        else:
            for s, snap in zip(systems, start):
                s.restore(snap)
            recs = self.g_after(j, tau, t0, gammas)[1]
        return t0 + tau, tau, recs, start

    def log_event(self, crossing, t: float, recs, sink, dv=None, work: float = 0.0) -> None:
        """Add the event at time ``t`` (state: ``recs``; an impulse ``dv`` and its work) to the
        log and the file."""
        step, j = crossing[:2]
        e = self.events.events[j]
        entry = {"label": e.label, "kind": e.kind, "body": e.body or "", "time": float(t),
                 "step": int(step - self.sim._run_origin), "dv": np.zeros(3) if dv is None else np.array(dv, float),
                 "work": float(work)}  # fmt: skip
        if e.body is not None:
            data = self.data(recs, 1, np.array([t]))[e.body]
            entry["position"], entry["velocity"] = np.array(data["position"][0]), np.array(data["velocity"][0])
        else:
            entry["position"] = entry["velocity"] = np.full(3, np.nan)
        self.events.log.append(entry)
        if sink.writer is not None:
            sink.writer.append_event(entry)
        self.sim.effects.on_event(e.label, float(t), self.events)

    def log_crossings(self, snapshots, first: int, gammas, sink, until=None) -> None:
        """Locate and log the crossings of a chunk that started at step ``first`` from
        ``snapshots`` (re-run from there; the kernels are deterministic), those before the
        crossing ``until`` only where given, then put the systems back where they were."""
        crossings = sorted(c for c in self._crossings if until is None or c < until)
        self._crossings = [c for c in self._crossings if c not in crossings]
        if not crossings:
            return
        end = [s.snapshot() for s in self.sim.systems]
        for s, snap in zip(self.sim.systems, snapshots):
            s.restore(snap)
        at = first
        located = []  # the crossings of one step, logged in time order
        for n, crossing in enumerate(crossings):
            if crossing[0] - 1 > at:
                self.sim._advance_all(gammas, crossing[0] - 1 - at, 1, at)
                at = crossing[0] - 1
            t, _, recs, start = self.find(crossing, gammas)
            located.append((t, crossing, recs))
            for s, snap in zip(self.sim.systems, start):
                s.restore(snap)
            if n + 1 == len(crossings) or crossings[n + 1][0] != crossing[0]:
                for t, c, recs in sorted(located, key=lambda item: (item[0], item[1])):
                    self.log_event(c, t, recs, sink)
                located = []
        for s, snap in zip(self.sim.systems, end):
            s.restore(snap)

    def act(self, crossing, snapshots, k: int, every: int, gammas, sink) -> int:
        """A crossing that stops the run (:meth:`stop_at`), or fires an impulse or switches a
        burn (:meth:`kick_at`). Returns the steps taken."""
        if self.events.events[crossing[1]].stop:
            return self.stop_at(crossing, snapshots, k, gammas, sink)
        return self.kick_at(crossing, snapshots, k, every, gammas, sink)

    def kick_at(self, crossing, snapshots, k: int, every: int, gammas, sink) -> int:
        """An impulse (or a burn's switch) in the chunk that started from ``snapshots``: record
        the records before its step, split the step at the event, add the impulse (or let the
        effects act: :meth:`~emorbit.effects.effectset.EffectSet.on_event`), take the rest of
        the step (the run stays on its grid) and log it with its work. The chunk's steps after
        it are dropped and taken again. Returns the steps taken."""
        sim = self.sim
        self.log_crossings(snapshots, sim._steps, gammas, sink, until=crossing)
        self._scanning = False
        step, j = crossing[:2]
        pre = step - 1 - sim._steps
        refused = sim._replay(snapshots, pre, k, gammas, sink)
        if refused is not None:
            raise refused[0]
        t, tau, recs, _ = self.find(crossing, gammas)
        e = self.events.events[j]
        self._kick(crossing, t, recs, sink)
        # the rest of the step (none where the event ends it: a step of length 0 divides by it)
        rest = self._step(sim._dt - tau, t, gammas) if tau < sim._dt else sim._current()
        if any(r.first_failure() is not None for _, r in rest):
            raise IntegrationError(t, e.body or "", f"the rest of the step after {e.label} failed")
        sim._steps = step
        if (step - sim._run_origin) % every == 0:
            sink.emit(rest, np.array([step]), 1, 1)
        self.events.fired = self._mark[1] | {entry["label"] for entry in self.events.log}
        self._from_here()
        self._scanning, self._crossings = True, []
        return pre + 1

    def _kick(self, crossing, t: float, recs, sink) -> None:
        """At a located event that splits its step (the systems at it, their records ``recs``):
        add its impulse and log it with its work, or log it and let the effects act."""
        e = self.events.events[crossing[1]]
        if e.dv is not None:
            state = self.data(recs, 1, np.array([t]))[e.body]
            x, v = np.array(state["position"][0]), np.array(state["velocity"][0])
            dv = e.impulse(x, v, self.sim.center)
            system = next(s for s in self.sim.systems if e.body in s.names)
            mass, before = system.kick(e.body, dv, f"{e.key}.dv")
            self.log_event(crossing, t, recs, sink, dv=dv, work=mass * (float(before @ dv) + 0.5 * float(dv @ dv)))
        else:  # an effect acts at it (log_event tells the effects)
            self.log_event(crossing, t, recs, sink)

    def stop_at(self, crossing, snapshots, k: int, gammas, sink) -> int:
        """A stopping event in the chunk that started from ``snapshots``: record the chunk's
        records before its step, end the run at the event (one step of the located length:
        its record is the run's last) and log it, after the events before it. Returns the
        steps taken."""
        self.log_crossings(snapshots, self.sim._steps, gammas, sink, until=crossing)
        self._scanning = False
        step = crossing[0]
        pre = step - 1 - self.sim._steps
        refused = self.sim._replay(snapshots, pre, k, gammas, sink)
        if refused is not None:
            raise refused[0]
        self.sim._steps = step - 1
        t, _, recs, _ = self.find(crossing, gammas)
        self.sim._steps = step
        self.sim._t_base = t - step * self.sim._dt  # the clock goes on from the event
        sink.emit(recs, np.array([step]), 1, 1, times=np.array([t]))
        self.log_event(crossing, t, recs, sink)
        self.sim.stopped_by = self.events.events[crossing[1]]
        self._scanning, self._crossings = True, []
        return pre + 1
