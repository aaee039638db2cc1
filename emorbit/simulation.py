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
"""

from __future__ import annotations

import math
import numbers
import sys

import numpy as np
from tqdm.auto import tqdm

from .errors import InputError, IntegrationError
from .field import CentralField
from .integrators import METHODS, check_order, coefficients, get_method
from .io.hdf5 import Writer
from .kernels import invariants as inv
from .kernels import pointmass as kern
from .orbits import OrbitalElements, elements
from .pointmasses import PointMasses
from .result import Result
from .units import to_si, vector_to_si

__all__ = ["Simulation", "check_body_name"]

#: point-substeps per compiled chunk (about 0.5 s of em work at ~150 ns per point-substep)
CHUNK_WORK = 4_000_000
#: bytes of recorded state per chunk at most
CHUNK_BYTES = 128 * 2**20


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
    """Bodies in a central field, advanced by one method at a fixed step.

    Parameters
    ----------
    field : CentralField
    method : str
        a name in :data:`emorbit.integrators.METHODS` (``"em"``, ``"midpoint"``, ``"leapfrog"``).
    order : int
        2 (the base step) or 4, 6, 8 (symmetric compositions).
    dt : Quantity, str or float
        the step in s.
    max_newton_iterations : int
        Newton iterations allowed per implicit sub-step before the step fails.
    """

    def __init__(self, field: CentralField, *, method: str = "em", order: int = 2, dt,
                 max_newton_iterations: int = 50):
        if not isinstance(field, CentralField):
            raise InputError("field", f"expected a CentralField, got {field!r}")
        self.field = field
        self.method = get_method(method).name
        self.order = check_order(order)
        self._dt = to_si(dt, "time", "dt", positive=True)
        if isinstance(max_newton_iterations, bool) or not isinstance(max_newton_iterations, numbers.Integral) \
                or max_newton_iterations < 1:
            raise InputError("max_newton_iterations", f"must be an integer >= 1, got {max_newton_iterations!r}")
        self.max_newton_iterations = int(max_newton_iterations)
        self.points = PointMasses()
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
    def names(self) -> list[str]:
        """Body names, in the order they were added."""
        return list(self.points.names)

    def add_point(self, name: str, *, mass, position, velocity, strict: bool = False, key: str | None = None) -> None:
        """Add a point mass (a test particle: it feels the field and nothing else).

        ``mass`` in kg (> 0), ``position`` in m and ``velocity`` in m/s as 3-vectors.
        ``strict`` requires units on every value; ``key`` prefixes error messages.
        """
        key = key or f"body[{name!r}]"
        check_body_name(name, f"{key}.name")
        if name in self.points.names:
            raise InputError(f"{key}.name", f"a body named {name!r} already exists")
        m = to_si(mass, "mass", f"{key}.mass", strict=strict, positive=True)
        x = vector_to_si(position, "length", f"{key}.position", strict=strict)
        v = vector_to_si(velocity, "speed", f"{key}.velocity", strict=strict)
        r = float(np.linalg.norm(x - self.field.center))
        if not r > 0.0:
            raise InputError(f"{key}.position", f"{x.tolist()} m is at the field's centre, where gravity is singular")
        self.points.add(name, m, x, v)

    # -- diagnostics of the current state ----------------------------------------------
    def state(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and velocity (m/s) of body ``name`` now, as (3,) arrays."""
        i = self._index(name)
        return self.points.x[:, i].copy(), self.points.v[:, i].copy()

    def energy(self) -> float:
        """Total energy now, in J."""
        return float(inv.energy(self.points.masses, self.points.x, self.points.v, self.field.gm, self.field.center))

    def momentum(self) -> np.ndarray:
        """Total linear momentum now, in kg m/s."""
        return inv.momentum(self.points.masses, self.points.v)

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum about the centre now, in kg m^2/s."""
        return inv.angular_momentum(self.points.masses, self.points.x, self.points.v, self.field.center)

    def elements(self, name: str) -> OrbitalElements:
        """Osculating elements of body ``name`` now."""
        x, v = self.state(name)
        return elements(x, v, self.field.gm, self.field.center)

    def _index(self, name: str) -> int:
        try:
            return self.points.names.index(name)
        except ValueError:
            raise InputError("name", f"no body named {name!r}; bodies: {', '.join(self.points.names)}") from None

    # -- running ----------------------------------------------------------------------
    def steps_until(self, t_end) -> int:
        """Number of steps from now to ``t_end`` (rounded up to whole steps)."""
        return _steps_between(self.time, to_si(t_end, "time", "t_end"), self._dt, "t_end")

    def run(self, t_end=None, *, steps: int | None = None, every: int = 1, output=None,
            overwrite: bool = False, progress: bool | None = None, keep: bool = True) -> Result:
        """Advance to time ``t_end`` (or by ``steps`` steps), recording every ``every`` steps.

        The start state is the first record and the end state always the last. The run ends
        on a whole step: ``t_end`` is rounded up to a multiple of ``dt`` unless it is within
        1e-9 relative of one.

        output     HDF5 file to write while running (see :mod:`emorbit.io.hdf5`); an
                   existing file is an error unless ``overwrite``.
        progress   a progress bar on stderr (shown after 2 s); default: when stderr is a terminal.
        keep       keep all records in memory; if false the returned Result holds the first
                   and last record only (the file, if any, has them all).

        Raises :class:`~emorbit.errors.IntegrationError` when a step fails; the simulation
        and the file then hold the state at the start of the failing step.
        """
        if len(self.points) == 0:
            raise InputError("body", "the simulation has no bodies; add one with add_point()")
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

        writer = None
        if output is not None:
            writer = Writer(output, [(n, "point", m) for n, m in zip(self.points.names, self.points.masses)],
                            self._file_attrs(every, n_steps), overwrite=overwrite)
        sink = _Sink(self, writer, keep)
        try:
            sink.emit_state(iterations=np.zeros(1))
            self._advance(n_steps, every, sink, progress)
        except BaseException as exc:
            if writer is not None:
                writer.close("failed", f"{type(exc).__name__}: {exc}")
            raise
        if writer is not None:
            writer.close("completed")
        return sink.result()

    def _file_attrs(self, every: int, n_steps: int) -> dict:
        return {
            "method": self.method,
            "order": self.order,
            "dt": self._dt,
            "t_start": self.time,
            "t_end": self.time + n_steps * self._dt,
            "steps": n_steps,
            "output_every": every,
            "gm": self.field.gm,
            "center": self.field.center,
            "field_body": self.field.body or "",
            "scene": self.scene_text if self.scene_text is not None else self.to_toml(),
        }

    def _advance(self, n_steps: int, every: int, sink: "_Sink", progress: bool) -> None:
        gammas = coefficients(self.order)
        pts = self.points
        per_record = max(1, every * gammas.size * len(pts))
        chunk_records = max(1, min(CHUNK_WORK // per_record, CHUNK_BYTES // (48 * len(pts))))
        done = 0
        with tqdm(total=n_steps, disable=not progress, delay=2.0, unit="step", file=sys.stderr,
                  dynamic_ncols=True, leave=False) as bar:
            while done < n_steps:
                left = n_steps - done
                k = every if left >= every else left
                nrec = min(left // k, chunk_records)
                snapshot = (pts.x.copy(), pts.v.copy(), pts.cx.copy(), pts.cv.copy())
                rec = pts.advance(self.method, self.field.gm, self.field.center, self._dt, gammas, k, nrec,
                                  self.max_newton_iterations)
                failure = rec.first_failure()
                if failure is None:
                    sink.emit(rec, k, nrec)
                    self._steps += k * nrec
                    done += k * nrec
                    bar.update(k * nrec)
                    continue
                self._stop_at_failure(rec, snapshot, failure, k, gammas, sink)

    def _stop_at_failure(self, rec, snapshot, failure, k, gammas, sink) -> None:
        """Keep the records before the first failing step, bring every point to the start of
        that step (re-running from the chunk's snapshot; the kernels are deterministic), record
        that state and raise."""
        step, index, status = failure
        good = step // k
        if good:
            sink.emit(rec, k, good)
        pts = self.points
        pts.x[...], pts.v[...], pts.cx[...], pts.cv[...] = snapshot
        if step:
            again = pts.advance(self.method, self.field.gm, self.field.center, self._dt, gammas, step, 1,
                                self.max_newton_iterations)
            if again.first_failure() is not None:  # cannot happen: the same steps succeeded before
                raise RuntimeError("re-running the steps before a failure failed again")
            if step % k:
                sink.emit(again, step % k, 1)
        self._steps += step
        name = pts.names[index]
        if status == kern.STATUS_NO_CONVERGENCE:
            reason = (f"Newton's iteration did not converge within {self.max_newton_iterations} iterations "
                      f"(method {self.method}, order {self.order}, dt = {self._dt!r} s); try a smaller dt")
        else:
            x = pts.x[:, index]
            reason = (f"the point reached the field's centre or its state stopped being finite "
                      f"(last good position {x.tolist()} m)")
        raise IntegrationError(self.time, name, reason)

    # -- scene text ---------------------------------------------------------------------
    def to_toml(self, t_end: float | None = None, output_every: int = 1) -> str:
        """This simulation's set-up as a scene (TOML), in SI units, exact to the last bit."""
        from .scene import simulation_to_toml

        return simulation_to_toml(self, t_end=t_end, output_every=output_every)


class _Sink:
    """Collects records: computes invariants, appends to the file and keeps them in memory."""

    def __init__(self, sim: Simulation, writer: Writer | None, keep: bool):
        self.sim = sim
        self.writer = writer
        self.keep = keep
        self.blocks: list[tuple] = []
        self.steps_recorded = sim._steps

    def emit_state(self, iterations) -> None:
        pts = self.sim.points
        self._add(np.array([self.sim._steps]), pts.x[None].copy(), pts.v[None].copy(), iterations)

    def emit(self, rec, k: int, nrec: int) -> None:
        """Record rows [:nrec] of a chunk whose records are ``k`` steps apart."""
        sim = self.sim
        steps = self.steps_recorded + k * (np.arange(nrec) + 1)
        subs = k * coefficients(sim.order).size * len(sim.points)
        self._add(steps, rec.x[:nrec], rec.v[:nrec], rec.iterations[:nrec].sum(axis=1) / subs)

    def _add(self, steps, x, v, its) -> None:
        sim = self.sim
        pts = sim.points
        gm, center = sim.field.gm, sim.field.center
        times = sim._t_base + steps * sim._dt
        e = inv.energy(pts.masses, x, v, gm, center)
        p = inv.momentum(pts.masses, v)
        L = inv.angular_momentum(pts.masses, x, v, center)
        pos = {n: np.ascontiguousarray(x[:, :, i]) for i, n in enumerate(pts.names)}
        vel = {n: np.ascontiguousarray(v[:, :, i]) for i, n in enumerate(pts.names)}
        block = (times, e, p, L, np.asarray(its, float), pos, vel)
        if self.writer is not None:
            self.writer.append(*block)
        if self.keep or not self.blocks:
            self.blocks.append(block if self.keep else _row(block, 0))
        if not self.keep:
            self.blocks[1:] = [_row(block, -1)]
        self.steps_recorded = int(steps[-1])

    def result(self) -> Result:
        blocks = self.blocks
        names = self.sim.points.names
        cat = lambda j: np.concatenate([b[j] for b in blocks])  # noqa: E731
        return Result(
            time=cat(0), energy=cat(1), momentum=cat(2), angular_momentum=cat(3), newton_iterations=cat(4),
            positions={n: np.concatenate([b[5][n] for b in blocks]) for n in names},
            velocities={n: np.concatenate([b[6][n] for b in blocks]) for n in names},
            masses=dict(zip(names, self.sim.points.masses.tolist())),
            method=self.sim.method, order=self.sim.order, dt=self.sim.dt, gm=self.sim.field.gm,
            center=self.sim.field.center.copy(),
        )


def _row(block, i):
    sl = slice(i, i + 1) if i >= 0 else slice(i, None)
    times, e, p, L, its, pos, vel = block
    return (times[sl], e[sl], p[sl], L[sl], its[sl], {k: a[sl] for k, a in pos.items()},
            {k: a[sl] for k, a in vel.items()})


# METHODS is re-exported for discoverability: Simulation.METHODS lists what `method` accepts
Simulation.METHODS = METHODS
