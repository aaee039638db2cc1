"""Continue a run file: ``emorbit resume OUT.h5 --t-end T2``.

The file says how it was made (its scene text and the effective method, order, dt and
output stride in its attributes) and holds the complete state at its last checkpoint. A
resume checks that the file fits together (attributes, checkpoint, datasets, bodies), rebuilds
the simulation from the scene, restores that state bit for bit, drops the records written
after the checkpoint and runs to T2 (continuing the record grid), so the file ends up
identical to one written by a single uninterrupted run to T2 - whether the first run
finished, failed, was interrupted (SIGINT, SIGTERM) or killed. A T2 before the file's last
record would delete records: that takes ``truncate=True`` (``--truncate``).
"""

from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass

import h5py
import numpy as np

from ..errors import InputError
from ..notices import compile_notice
from ..result import Result
from ..scene import parse_scene, scene_overrides
from ..units import to_si
from .hdf5 import Writer
from .reader import (
    DAMAGE,
    LAYOUT_UNITS,
    NEXT_CHECKPOINT,
    _busy_message,
    damage_message,
    file_path,
    live_writer,
    open_run_file,
    probe,
    state_digest,
    verify_checksums,
)

__all__ = ["resume", "load_checkpoint"]


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


@dataclass
class _Loaded:
    sim: object
    attrs: dict
    records: int  # the records that belong to the checkpoint
    rows: int  # the records complete in every dataset of the file
    times: np.ndarray  # their times, s
    steps: int  # the checkpoint's steps since the run's start


def _bad(path: str, what: str, message: str) -> InputError:
    return InputError("file", f"{path!r}: {what} {message}; the file cannot be continued")


def _number(path, attrs, name, *, integer=False, minimum=None, positive=False):
    """A root or checkpoint attribute that must be a finite number (an integer >= minimum)."""
    if name not in attrs:
        raise _bad(path, f"attribute {name!r}", "is missing")
    value = attrs[name]
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if ok and integer:
        ok = isinstance(value, numbers.Integral) or (math.isfinite(value) and float(value).is_integer())
        value = int(value) if ok else value
    if ok:
        ok = math.isfinite(value) and (minimum is None or value >= minimum) and (not positive or value > 0)
    if not ok:
        need = "an integer" if integer else "a finite number"
        need += f" >= {minimum}" if minimum is not None else (" > 0" if positive else "")
        raise _bad(path, f"attribute {name!r}", f"is {value!r}, not {need}")
    return int(value) if integer else float(value)


def _string(path, attrs, name):
    if name not in attrs:
        raise _bad(path, f"attribute {name!r}", "is missing")
    value = attrs[name]
    if not isinstance(value, (str, bytes)):
        raise _bad(path, f"attribute {name!r}", f"is {value!r}, not a string")
    return _text(value)


def _plain(attrs) -> dict:
    return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in attrs.items()}


def _checkpoint_group(f, path):
    if isinstance(f.get("checkpoint"), h5py.Group):
        return "checkpoint", f["checkpoint"]
    nxt = f.get(NEXT_CHECKPOINT)
    if isinstance(nxt, h5py.Group) and nxt.attrs.get("complete", False):
        return NEXT_CHECKPOINT, nxt  # killed between replacing the old checkpoint and renaming the new one
    raise InputError("file", f"{path!r} has no checkpoint to continue from")


def _check_bodies(f, path, sim, records: int) -> None:
    """Every body of the scene has its group with the datasets it writes, long enough; nothing else."""
    groups = list(f["bodies"])
    if sorted(groups) != sorted(sim.names):
        raise _bad(
            path,
            "group /bodies",
            f"holds {groups}, but the file's scene has the bodies {sim.names} (a body renamed, added or removed)",
        )
    t_last = f["time"][records - 1]
    for s in sim.systems:
        for i, name in enumerate(s.names):
            g = f["bodies"][name]
            if not isinstance(g, h5py.Group):
                raise _bad(path, f"/bodies/{name}", "is not a group")
            expected = s.body_datasets(i)
            found = [q for q, ds in g.items() if isinstance(ds, h5py.Dataset)]
            found += [f"nodes/{q}" for q in g["nodes"]] if isinstance(g.get("nodes"), h5py.Group) else []
            for q in sorted(set(found) - set(expected)):
                raise _bad(path, f"dataset /bodies/{name}/{q}", "is not one the file's scene writes")
            for q, (width, _unit) in expected.items():
                ds = g.get(q)
                where = f"dataset /bodies/{name}/{q}"
                if not isinstance(ds, h5py.Dataset):
                    raise _bad(path, where, "is missing")
                tail = () if width is None else ((width,) if isinstance(width, int) else tuple(width))
                if ds.shape[1:] != tail or not ds.maxshape or ds.maxshape[0] is not None:
                    raise _bad(path, where, f"has shape {ds.shape}, expected (rows{''.join(f', {w}' for w in tail)})")
                if ds.dtype != np.float64:
                    raise _bad(path, where, f"holds {ds.dtype}, not float64")
                need = records
                if q.startswith("nodes/"):
                    need = int(np.searchsorted(g["nodes/time"][()], t_last, side="right"))
                if ds.shape[0] < need:
                    raise _bad(path, where, f"has {ds.shape[0]} rows, fewer than the checkpoint's {need}")


#: compensation terms: each holds the rounding error of the state array it is named after
#: (cx of x, ...), which is at most an ulp of it
_COMPENSATED = ("cx", "cv", "cq", "cu", "cwork")


def _check_state(path, where: str, arrays: dict, sim) -> None:
    """The checkpoint's arrays are state arrays of the scene's systems, finite numbers; each
    system's fixed fields (its ``STATE_FIELDS``) are there with the shapes of the scene's bodies.
    Arrays whose size depends on the path (a structure's kept factors) are checked by the
    system when it restores them."""
    expected = sim.state_arrays()
    fixed = {f"{s.kind}/{f}" for s in sim.systems for f in s.STATE_FIELDS}
    for key in sorted(set(arrays) - set(expected)):
        raise _bad(path, f"dataset /{where}/{key}", "is not part of the state of the file's scene")
    for key in sorted(fixed - set(arrays)):
        raise _bad(path, f"dataset /{where}/{key}", "is missing")
    for key, got in sorted(arrays.items()):
        name = f"dataset /{where}/{key}"
        if not (isinstance(got, np.ndarray) and got.dtype == np.float64):
            raise _bad(path, name, f"holds {getattr(got, 'dtype', type(got).__name__)}, not float64 numbers")
        if key in fixed and got.shape != np.shape(expected[key]):
            raise _bad(path, name, f"has shape {got.shape}, expected {np.shape(expected[key])} for the scene's bodies")
        if not np.all(np.isfinite(got)):
            raise _bad(path, name, "holds values that are not finite")
    for key, c in sorted(arrays.items()):  # a compensation term is the rounding error of its main term
        kind, _, field = key.partition("/")
        main = arrays.get(f"{kind}/{field[1:]}")
        if field in _COMPENSATED and isinstance(main, np.ndarray) and main.shape == c.shape:
            if not np.all(np.abs(c) <= 2 * np.spacing(np.abs(main))):  # measured: at most 1 ulp
                raise _bad(path, f"dataset /{where}/{key}", f"is not a rounding error of /{where}/{kind}/{field[1:]}")


def _load(path) -> _Loaded:
    """Check a run file and rebuild its simulation at its last checkpoint."""
    path = file_path(path)
    problem = probe(path) if os.path.isfile(path) else None  # else: open_run_file says what it is
    if problem is not None:
        raise InputError("file", f"{path!r} is damaged: {problem}")
    with open_run_file(path) as f:
        try:
            loaded, where, arrays, recorded = _read(f, path)
        except InputError:
            raise
        except DAMAGE as exc:  # h5py on a damaged file
            raise _bad(path, "its content", f"cannot be read ({damage_message(exc)})") from None
    sim = loaded.sim
    _check_state(path, where, arrays, sim)
    try:
        sim.set_state_arrays(arrays, loaded.steps)
    except InputError as exc:
        raise _bad(path, f"group /{where}", f"does not fit the file's scene ({exc})") from None
    except (ValueError, TypeError, IndexError, KeyError, ArithmeticError) as exc:
        raise _bad(path, f"group /{where}", f"holds a state the scene's bodies cannot take ({exc})") from None
    _check_invariants(path, where, sim, recorded, loaded.records)
    _check_drift(path, where, arrays, recorded, loaded.steps, loaded.records)
    digest, t_cp = recorded["digest"]
    if digest is not None and not (isinstance(digest, str) and digest == state_digest(arrays, loaded.steps, t_cp)):
        raise _bad(
            path,
            f"group /{where}",
            "does not match the digest written with it: its state changed since it was written (damaged or "
            "edited), and a run continued from it would not be the run the file holds",
        )
    sim._run_origin = 0
    sim._checkpointed_at = sim._steps
    return loaded


def _read(f, path: str):
    """What :func:`_load` reads from the open file, checked: the simulation rebuilt from its
    scene and settings (state not yet restored), the checkpoint group's name, its arrays, and
    the invariants recorded with the checkpoint's record."""
    f.visititems(lambda name, obj: None)  # every group a resume writes into opens (a damaged one raises)
    attrs = _plain(f.attrs)
    if (writer := live_writer(attrs)) is not None:  # a file system that does not take HDF5's locks
        raise InputError("file", _busy_message(path, writer))
    verify_checksums(f, path)  # the records kept, and the state: a changed byte would be continued
    scene_text = _string(path, attrs, "scene")
    method = _string(path, attrs, "method")
    order = _number(path, attrs, "order", integer=True, minimum=1)
    dt = _number(path, attrs, "dt", positive=True)
    every = _number(path, attrs, "output_every", integer=True, minimum=1)
    _number(path, attrs, "checkpoint_every", integer=True, minimum=0)
    t_start = _number(path, attrs, "t_start")
    where, cp = _checkpoint_group(f, path)
    cattrs = _plain(cp.attrs)
    steps = _number(path, cattrs, "steps", integer=True, minimum=0)
    records = _number(path, cattrs, "records", integer=True, minimum=1)
    t_cp = _number(path, cattrs, "time")
    arrays = {}
    cp.visititems(lambda name, obj: arrays.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
    for name in LAYOUT_UNITS:
        if name in f:
            _check_growable(path, f"dataset /{name}", f[name])
    rows = min(f[name].shape[0] for name in LAYOUT_UNITS if name in f)
    if records > rows:
        raise _bad(path, f"attribute /{where}@records", f"is {records}, but the record datasets hold only {rows} rows")
    if steps % every or records != steps // every + 1:
        raise _bad(
            path,
            f"attributes /{where}@steps and @records",
            f"({steps} steps, {records} records) do not fit output_every = {every}: "
            f"a checkpoint at step {steps} has {steps // every + 1} records",
        )
    if not math.isclose(t_start + steps * dt, t_cp, rel_tol=1e-9, abs_tol=1e-9 * dt):
        raise _bad(
            path, f"attribute /{where}@time", f"is {t_cp!r} s, but t_start + steps dt = {t_start + steps * dt!r} s"
        )
    times = f["time"][:rows]
    if times[records - 1] != t_cp:
        raise _bad(
            path,
            f"dataset /time, row {records - 1}",
            f"is {times[records - 1]!r} s, not the checkpoint's time {t_cp!r} s",
        )
    sim = _rebuild(path, scene_text, method, order, dt, every)
    _check_bodies(f, path, sim, records)
    for s in sim.systems:  # rows complete in every body dataset too
        for i, name in enumerate(s.names):
            for q in s.body_datasets(i):
                if not q.startswith("nodes/"):
                    rows = min(rows, f["bodies"][name][q].shape[0])
    recorded = {q: f[f"invariants/{q}"][records - 1] for q in ("energy", "momentum", "angular_momentum")}
    recorded["first"] = np.concatenate([np.atleast_1d(f[f"invariants/{q}"][0]) for q in recorded])
    works = [k for k in f["invariants"] if k.startswith("work_")]
    recorded["work"] = sum(float(f[f"invariants/{k}"][records - 1]) for k in works)  # the monitor checks E - W
    for q in ("drift_bound", "invariant_drift"):
        if f"diagnostics/{q}" in f:
            recorded[q] = f[f"diagnostics/{q}"][records - 1]
    recorded["digest"] = (cattrs.get("digest"), t_cp)
    sim._t_base = t_start
    return _Loaded(sim, attrs, records, rows, f["time"][:rows], steps), where, arrays, recorded


def _rebuild(path: str, scene_text: str, method: str, order: int, dt: float, every: int):
    """The simulation of the file's scene with its method, order, step and record stride, which
    must be the scene's (with the command line's overrides noted in it)."""
    try:
        scene = parse_scene(scene_text, path)
    except InputError as exc:
        raise _bad(path, "attribute 'scene'", f"is not a scene that builds ({exc})") from None
    try:
        written = scene.with_overrides(**scene_overrides(scene_text))
    except InputError as exc:
        raise _bad(path, "attribute 'scene'", f"notes an override that does not build ({exc})") from None
    for name, value, own in (("method", method, written.method), ("order", order, written.order)):
        if value != own:
            raise _bad(path, f"attribute {name!r}", f"is {value!r}, but the file's scene has {own!r}")
    if written.data["integrator"].get("adaptive") is None and dt != written.dt:
        raise _bad(path, "attribute 'dt'", f"is {dt!r} s, but the file's scene has {written.dt!r} s")
    try:
        sim = scene.with_overrides(method=method, order=order, dt=f"{dt!r} s", output_every=every).build()
    except InputError as exc:
        raise _bad(path, "attributes 'dt' and 'output_every'", f"do not fit the file's scene ({exc})") from None
    if sim.structure is not None:
        sim.structure.build()
    return sim


def _check_growable(path: str, where: str, ds) -> None:
    """A record dataset that a resume appends to: float64, growable along its first axis."""
    if not isinstance(ds, h5py.Dataset):
        raise _bad(path, where, "is not a dataset")
    if ds.dtype != np.float64:
        raise _bad(path, where, f"holds {ds.dtype}, not float64")
    if ds.ndim == 0 or not ds.maxshape or ds.maxshape[0] is not None:
        raise _bad(path, where, f"has shape {ds.shape}, fixed: a record dataset grows along its first axis")


def _check_drift(path: str, where: str, arrays: dict, recorded: dict, steps: int, records: int) -> None:
    """The drift monitor's state (``drift/...``, :mod:`emorbit.io.drift`) is the one that gave
    the checkpoint's record: its reference is the first record's invariants, its last step the
    checkpoint's, and its sub-steps, tolerance and scales give the drift bound and the drifts
    recorded in that row. Where it is not, the records after the checkpoint would measure
    another drift than the unbroken run."""
    ref, scale, progress = (arrays.get(f"drift/{q}") for q in ("reference", "scale", "progress"))
    if progress is None or ref is None or scale is None or progress.shape != (19,) or progress[3] == 0:
        return  # no drift measured, or a state that restoring it refuses
    row = f"row {records - 1}"
    if ref.shape != (7,) or not np.array_equal(ref, recorded["first"]):
        raise _bad(path, f"dataset /{where}/drift/reference", "is not the invariants of the first record")
    if progress[1] != steps:
        raise _bad(path, f"dataset /{where}/drift/progress", f"ends at step {progress[1]!r}, not at {steps}")
    bound = progress[3] * 2.0**-52 * math.sqrt(max(progress[0], 1.0))
    if "drift_bound" in recorded and bound != recorded["drift_bound"]:
        raise _bad(
            path,
            f"dataset /{where}/drift/progress",
            f"gives the drift bound {bound!r}, but /diagnostics/drift_bound {row} holds {recorded['drift_bound']!r}",
        )
    drift = recorded.get("invariant_drift")
    if drift is None or scale.shape != (3,) or np.shape(drift) != (3,):
        return
    inv = np.concatenate([np.atleast_1d(recorded[q]) for q in ("energy", "momentum", "angular_momentum")])
    inv[0] -= recorded.get("work", 0.0)
    change = [abs(inv[0] - ref[0]), np.linalg.norm(inv[1:4] - ref[1:4]), np.linalg.norm(inv[4:7] - ref[4:7])]
    with np.errstate(all="ignore"):
        now = np.asarray(change) / np.maximum(scale, np.finfo(float).tiny)
    if not np.array_equal(now[drift >= 0], drift[drift >= 0]):
        raise _bad(
            path,
            f"dataset /{where}/drift/scale",
            f"gives the drifts {now.tolist()!r}, but /diagnostics/invariant_drift {row} holds {drift.tolist()!r}",
        )


def _check_invariants(path: str, where: str, sim, recorded: dict, records: int) -> None:
    """The energy, momentum and angular momentum of the restored state are those recorded with
    the checkpoint's record: a state or a scene changed since (a mass, the field, a position)
    does not continue the run the file holds."""
    with np.errstate(all="ignore"):
        now = {"energy": sim.energy(), "momentum": sim.momentum(), "angular_momentum": sim.angular_momentum()}
    for name, value in now.items():
        value, old = np.asarray(value, float), np.asarray(recorded[name], float)
        scale = max(float(np.max(np.abs(old))), float(np.max(np.abs(value))), np.finfo(float).tiny)
        if not float(np.max(np.abs(value - old))) <= 1e-12 * scale:
            raise _bad(
                path,
                f"group /{where}",
                f"does not continue the run: its state and the file's scene give {name} {value.tolist()!r}, "
                f"but /invariants/{name} row {records - 1} holds {old.tolist()!r}",
            )


def load_checkpoint(path):
    """Rebuild a run file's simulation at its last checkpoint.

    Every value taken from the file is checked first: the root attributes the rebuild reads
    (``scene``, ``method``, ``order``, ``dt``, ``output_every``, ``checkpoint_every``,
    ``t_start``), the checkpoint's ``steps``, ``records`` and ``time`` against each other and
    against the record datasets, the body groups against the scene's bodies, and the state
    arrays against the scene's (names, shapes, finite numbers).

    Parameters
    ----------
    path : str, bytes or os.PathLike
        A run file.

    Returns
    -------
    sim : Simulation
        Built from the file's scene and settings, with the checkpoint's state restored.
    attrs : dict
        The file's root attributes.
    records : int
        The records that belong to the checkpoint.

    Raises
    ------
    InputError
        The file is missing, not a run file, being written by another process, has no
        checkpoint, or has a value that does not fit (the error names the dataset or
        attribute).
    """
    loaded = _load(path)
    return loaded.sim, loaded.attrs, loaded.records


def resume(path, t_end, *, progress: bool | None = None, truncate: bool = False, events=None) -> Result:
    """Continue the run in a file to a later time, in place.

    Parameters
    ----------
    path : str, bytes or os.PathLike
        A run file (finished, failed, interrupted or killed).
    t_end : Quantity, str or float
        The new end time, s.
    progress : bool, optional
        A progress bar on stderr; default: when stderr is a terminal.
    truncate : bool
        Allow a ``t_end`` before the file's last record: the records after ``t_end`` are
        deleted. Without it such a ``t_end`` is an error and the file is left as it is.
    events : list of dict, optional
        New events in place of the file's (each the keys of
        :meth:`emorbit.Simulation.add_event`, with ``kind``), e.g. a stopping condition further
        on; the file's scene is rewritten with them. The run from the checkpoint is the run a
        scene with these events would have made (events do not change states).

    Returns
    -------
    Result
        The records computed by this call, from the checkpoint on.

    Raises
    ------
    InputError
        The file cannot be continued, ``t_end`` is not after its last checkpoint, or
        ``t_end`` is before its last record without ``truncate``.
    IntegrationError
        A step failed, as in :meth:`emorbit.Simulation.run`.
    RunInterrupted
        SIGINT or SIGTERM stopped the run; the file is marked "interrupted".
    """
    import sys

    from .recorder import Sink

    path = file_path(path)
    loaded = _load(path)
    sim, attrs, records = loaded.sim, loaded.attrs, loaded.records
    t2 = to_si(t_end, "time", "t_end", positive=False)
    end_time = float(loaded.times[-1])
    file_end = round((end_time - sim._t_base) / sim.dt)
    if (t2 - sim._t_base) / sim.dt < file_end - 1e-9 * max(1, file_end) and not truncate:
        lost = int(np.count_nonzero(loaded.times > t2))
        raise InputError(
            "t_end",
            f"{t2!r} s is before the end of {path!r} (its last record is at t = {end_time!r} s): "
            f"resuming to it would delete the {lost} records after it; pass truncate=True from Python "
            "or --truncate on the command line to do that",
        )
    if not t2 > sim.time:
        raise InputError(
            "t_end",
            f"{t2!r} s is not after the last checkpoint of {path!r} (t = {sim.time!r} s), where a resume starts",
        )
    n_steps = sim.steps_until(t2)
    every = int(attrs["output_every"])
    cp = int(attrs["checkpoint_every"])
    total = sim._steps + n_steps
    attrs_new = {"t_end": sim._t_base + total * sim.dt, "steps": total}
    if events is not None:
        from ..events import EventSet
        from .scene_toml import replace_events

        if not isinstance(events, (list, tuple)) or not all(isinstance(e, dict) for e in events):
            raise InputError("events", f"a list of event tables (dicts with kind) expected, got {events!r}")
        sim.events = EventSet()
        for i, table in enumerate(events):
            keys = {k: v for k, v in table.items() if k != "kind"}
            sim.add_event(table.get("kind"), key=f"events[{i}]", **keys)
        sim.events.check_bodies(sim.names)
        attrs_new["scene"] = replace_events(attrs["scene"], sim.events)
    writer = Writer.reopen(path, records, attrs_new)
    if sim.events:  # the events before the checkpoint have happened (and their impulses' work)
        from .reader import read_events

        sim.events.resume_from(read_events(writer.file, path))
    sim.effects.replay_events(sim.events)
    sink = Sink(sim, writer, True)
    sink.rows = records
    sink.last_step = sim._steps
    notice = progress is not False
    if progress is None:
        progress = sys.stderr.isatty()
    with compile_notice(notice):
        return sim._run_and_close(n_steps, every, cp, sink, writer, progress)
