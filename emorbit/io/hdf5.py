"""Writing the HDF5 run file, in chunks while a run runs.

The layout is :mod:`emorbit.io.reader`'s (docs/hdf5.md lists every dataset and attribute):
one row per record in ``/time``, ``/invariants/`` and ``/diagnostics/``, the bodies'
datasets under ``/bodies/<name>/``, every dataset with a ``unit`` attribute, and root
attributes that say how the run was made (method, order, ``dt``, the field, the scene as
TOML text, ``status``, ...), each with a unit followed by ``<name>_unit``. Datasets are
chunked and growable and every appended block is flushed, and HDF5's metadata cache keeps
what changed in memory until that flush (:func:`_hold_metadata`), so a run that stops early,
killed at any moment included, leaves the readable file of its last flush.

A new file is created under a temporary name in the output's folder and renamed into place
with its first checkpoint (a run to the same path removes the temporary files of killed
runs whose process is gone), so an existing file is never truncated and a file at the path
always has a checkpoint. With ``overwrite`` the existing file is first opened for writing,
which takes its HDF5 file lock: a file that another run is writing (and so holds locked) is
refused, never replaced. The writer checks at every flush that its path still names the
file it writes; a file removed or replaced under a run stops that run with
:class:`FileLostError`, and the file it wrote is copied next to the path if nothing else
reaches it. Before it writes, the writer also checks that the file is not shorter than after
its last flush: a file truncated in place under a run (its records lost) stops that run with
:class:`FileLostError` too, at the next record, checkpoint or close. Every dataset is stored
with a Fletcher-32 checksum per chunk (:func:`emorbit.io.reader.read_dataset` names the rows
of a chunk whose bytes changed).

``/checkpoint`` holds the complete state (every system's arrays, compensation terms and
warm starts included, each with its ``unit``; attributes ``steps`` since the run's start,
``time`` and ``records``), replaced at every checkpoint: written as ``/checkpoint_next``,
flushed, then renamed, so that a kill never leaves half a checkpoint. ``/final_state`` holds
the state at the end of the run, also of an interrupted one. ``emorbit resume`` continues
from the checkpoint (:mod:`emorbit.io.resume`); hdf5.md lists every dataset and attribute.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import re
import secrets
import weakref

import h5py
import numpy as np

from .._version import __version__
from ..errors import EmorbitError, InputError
from .reader import (
    DAMAGE,
    EFFECT_RECORDS,
    LAYOUT_UNITS,
    NEXT_CHECKPOINT,
    OPTIONAL,
    ROOT_UNITS,
    STATE_UNITS,
    WIDTHS,
    _alive,
    _busy_message,
    _locked,
    file_path,
    live_writer,
    not_regular,
    optional_rows,
    state_digest,
    writer_id,
)

__all__ = ["Writer", "FileLostError", "temp_name", "temp_pattern"]


#: what a truncated file's error adds: the records are not kept anywhere
_TRUNCATED = (
    " (by another process or by hand): the records this run wrote before are lost from it, and the run stops; "
    "run it again"
)


class FileLostError(EmorbitError, OSError):
    """The run file was removed, replaced or truncated while a run wrote it; the message says
    where the records are, if they could be kept (``emorbit run`` exits with code 1)."""


def _exists_message(path: str) -> str:
    """An output file exists: how to replace it from Python and from the command line."""
    return (
        f"{path!r} exists; choose another name, or replace it: overwrite=True in Simulation.run, "
        "--overwrite on the command line"
    )


def _versions() -> str:
    import astropy
    import numba

    return json.dumps(
        {
            "python": platform.python_version(),
            "numpy": np.__version__,
            "numba": numba.__version__,
            "h5py": h5py.__version__,
            "astropy": astropy.__version__,
        }
    )


#: the numeric datasets of the ``events/`` group: {name: (width, unit)}
EVENT_DATASETS = {
    "time": (None, "s"),
    "step": (None, "1"),
    "position": (3, "m"),
    "velocity": (3, "m / s"),
    "dv": (3, "m / s"),
    "work": (None, "J"),
}
#: its text datasets
EVENT_TEXT = ("label", "kind", "body")


def _growable(group, name, width, unit, chunk_rows, fill=0.0):
    """A dataset growing along its first axis, with a Fletcher-32 checksum on each chunk (a
    changed byte fails the read of its chunk); ``width`` is None (1-D), an int, or a shape."""
    tail = () if width is None else ((width,) if isinstance(width, int) else tuple(width))
    shape = (0,) + tail
    maxshape = (None,) + tail
    rows = max(1, min(chunk_rows, (1 << 20) // (8 * max(1, int(np.prod(tail))))))
    chunks = (rows,) + tail
    ds = group.create_dataset(
        name, shape=shape, maxshape=maxshape, chunks=chunks, dtype="f8", fillvalue=fill or None, fletcher32=True
    )
    ds.attrs["unit"] = unit
    return ds


def _constant(group, name, data):
    """A dataset written once, with a Fletcher-32 checksum on each chunk where it has any
    (HDF5 checksums chunks only: an empty or 0-d array is stored without one)."""
    data = np.asarray(data)
    checked = data.ndim > 0 and data.size > 0
    return group.create_dataset(name, data=data, fletcher32=checked)


def _hold_metadata(f) -> None:
    """Keep changed metadata in memory until the next flush: HDF5's cache otherwise writes what
    it evicts, and a kill then leaves structures past the end the superblock records (a file
    that cannot be read). Without evictions the file on disk is that of the last flush, plus
    raw data past its end; the cache grows until the flush that every appended block makes."""
    config = f.id.get_mdc_config()
    config.evictions_enabled = False
    config.incr_mode = config.flash_incr_mode = config.decr_mode = 0  # HDF5 needs the size fixed
    f.id.set_mdc_config(config)


def _append(ds, block):
    if len(block) == 0:
        return
    n0 = ds.shape[0]
    ds.resize(n0 + block.shape[0], axis=0)
    ds[n0:] = block


def _write_root_attrs(f, attrs: dict) -> None:
    """Root attributes, each with a unit followed by its ``<name>_unit``."""
    for key, value in attrs.items():
        f.attrs[key] = value
        if key in ROOT_UNITS:
            f.attrs[f"{key}_unit"] = ROOT_UNITS[key]


def _hold(path: str):
    """Open an existing output file for writing, which takes its HDF5 lock, so that no other run
    starts writing it while it is replaced; None for a file that is not HDF5 (no run writes it).

    Raises InputError when another process holds the lock, or when the path stops naming
    the file that was opened."""
    try:
        held = h5py.File(path, "r+")
    except OSError as exc:
        if _locked(exc):
            raise InputError("output", _busy_message(path)) from None
        try:  # a read-only file: a shared lock still excludes a writer
            held = h5py.File(path, "r")
        except OSError as exc2:
            if _locked(exc2):
                raise InputError("output", _busy_message(path)) from None
            return None
    try:
        same = _identity(os.stat(path)) == _identity(os.fstat(held.id.get_vfd_handle()))
    except OSError:
        same = False
    if not same:
        held.close()
        raise InputError("output", f"{path!r} was replaced by another process while this run opened it; try again")
    try:
        writer = live_writer(held.attrs)
    except DAMAGE:  # its attributes cannot be read: no run can be writing it either
        writer = None
    if writer is not None:  # a file system that does not take HDF5's locks
        held.close()
        raise InputError("output", _busy_message(path, writer))
    return held


def _identity(st) -> tuple[int, int]:
    return (st.st_dev, st.st_ino)


class Writer:
    """A run file being written: created with its layout, then appended to record by record.

    The file is created under a temporary name in the same folder and gets its name with its
    first checkpoint (or when it is closed before one), so nothing at ``path`` is truncated
    and a file at ``path`` always holds a checkpoint to resume from. With ``overwrite`` an
    existing file is replaced only while this writer holds its HDF5 lock, so a file another
    run is writing is refused. Every flush checks that ``path`` still names this file.

    Parameters
    ----------
    path : str, bytes or os.PathLike
        The file to create.
    bodies : list of dict
        One per body: ``name``, ``attrs`` (the group's attributes), ``datasets``
        ({dataset: (width or shape, unit)}: growable, a row per record or fewer) and
        ``constants`` ({path: (array, unit)}, written once).
    attrs : dict
        Root attributes to store (those in :data:`ROOT_UNITS` get a ``<name>_unit``).
    overwrite : bool
        Replace an existing file; otherwise an existing file is an error, so a finished run
        is never lost by accident.
    chunk_rows : int
        Rows per HDF5 chunk (at most 1 MiB per chunk).
    potentials : sequence of str
        Labels of the effects whose potential energy each record holds, in
        ``invariants/potential_<label>`` (J); :meth:`append` takes them by
        ``potential_<label>``.
    works : sequence of str
        Labels of the non-conservative effects (drag): each record holds the work each has
        done since the run's start in ``invariants/work_<label>`` (J) and the energy balance
        ``E - E0 - sum W`` in ``invariants/energy_balance`` (J); :meth:`append` takes them by
        ``work_<label>`` and ``energy_balance``. None given: neither is written.
    jacobi : bool
        Each record holds the Jacobi integral ``E - w . L`` of a turning central body's field
        in ``invariants/jacobi`` (J); :meth:`append` takes it by ``jacobi``.
    ledger : bool
        Each record holds the mass ledger of burns that expel mass (J): the bodies' energy at
        their true masses ``invariants/ledger_energy``, the work done on them there
        ``invariants/ledger_work``, the energy the propellant has carried away
        ``invariants/ledger_expelled`` and the balance ``invariants/ledger_balance``;
        :meth:`append` takes them by those names.

    Raises
    ------
    InputError
        The file exists (without ``overwrite``), another process is writing it, its folder
        does not exist, or it cannot be created.
    """

    def __init__(
        self,
        path,
        bodies,
        attrs: dict,
        *,
        overwrite: bool = False,
        chunk_rows: int = 1024,
        potentials=(),
        works=(),
        jacobi: bool = False,
        ledger: bool = False,
    ):
        path = file_path(path, "output")
        if (what := not_regular(path)) is not None:  # checked before anything opens it
            raise InputError("output", f"{path!r} is {what}, not a regular file; an output must be a file of its own")
        if os.path.lexists(path) and not overwrite:
            raise InputError("output", _exists_message(path))
        folder = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(folder):
            raise InputError("output", f"folder {folder!r} does not exist")
        self.path = path
        self.file = None
        self.rescued = None
        self._lost = None
        self._flushed_size = None  # the file's size after the last flush, bytes
        self._overwrite = overwrite
        self._held = _hold(path) if overwrite and os.path.lexists(path) else None
        _remove_orphans(folder, os.path.basename(path))
        self._temp = os.path.join(folder, temp_name(os.path.basename(path), os.getpid(), secrets.token_hex(4)))
        try:
            try:
                self.file = h5py.File(self._temp, "x")
            except OSError as exc:
                raise InputError("output", f"cannot create a file in {folder!r}: {exc}") from None
            _hold_metadata(self.file)
            self._identity = _identity(os.fstat(self.file.id.get_vfd_handle()))
            self._layout(bodies, attrs, chunk_rows, potentials, works, jacobi, ledger)
            self.file.flush()
            self._flushed_size = self._size()
        except BaseException:
            self._discard()
            raise
        # a writer dropped before its file got its name (an error before the first
        # checkpoint) leaves no temporary file behind
        self._finalizer = weakref.finalize(self, _discard, self.file, self._temp, self._held)

    def _discard(self) -> None:
        _discard(self.file, self._temp, self._held)
        self._held = None

    def _place(self) -> None:
        """Give the file its name, once it holds a checkpoint: replace what is at the path
        (overwrite, while holding its lock) or link without replacing."""
        if self._temp is None:
            return
        temp, path = self._temp, self.path
        try:
            if (what := not_regular(path)) is not None:  # became one since the run started
                raise InputError("output", f"{path!r} is {what}, not a regular file; it is left as it is")
            if self._overwrite:
                os.replace(temp, path)
            else:
                try:
                    os.link(temp, path)  # fails if a file appeared at path meanwhile
                except FileExistsError:
                    raise InputError("output", _exists_message(path)) from None
                except OSError:  # no hard links on this file system
                    if os.path.lexists(path):
                        raise InputError("output", _exists_message(path)) from None
                    os.replace(temp, path)
                else:
                    os.unlink(temp)
        except BaseException as exc:
            self._discard()
            self._finalizer.detach()
            if isinstance(exc, OSError):
                raise InputError("output", f"cannot create {path!r}: {exc}") from None
            raise
        self._temp = None
        self._finalizer.detach()
        if self._held is not None:
            self._held.close()
            self._held = None

    def _layout(self, bodies, attrs: dict, chunk_rows: int, potentials=(), works=(), jacobi=False, ledger=False):
        f = self.file
        f.attrs["creator"] = f"emorbit {__version__}"
        f.attrs["emorbit_version"] = __version__
        f.attrs["created"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        f.attrs["versions"] = _versions()
        _write_root_attrs(f, attrs)
        f.attrs["status"] = "running"
        f.attrs["writer"] = writer_id()
        self._ds = {
            name: _growable(f, name, WIDTHS[name], unit, chunk_rows, OPTIONAL.get(name) or 0.0)
            for name, unit in LAYOUT_UNITS.items()
        }
        for label in potentials:  # each effect's potential energy (emorbit.effects)
            name = f"invariants/potential_{label}"
            self._ds[name] = _growable(f, name, None, "J", chunk_rows)
        for name in [f"invariants/work_{label}" for label in works] + (["invariants/energy_balance"] if works else []):
            self._ds[name] = _growable(f, name, None, "J", chunk_rows)  # the non-conservative effects' work
        if jacobi:  # E - w . L of a turning field
            self._ds["invariants/jacobi"] = _growable(f, "invariants/jacobi", None, "J", chunk_rows)
        for name in ("energy", "work", "expelled", "balance") if ledger else ():  # burns that expel mass
            self._ds[f"invariants/ledger_{name}"] = _growable(f, f"invariants/ledger_{name}", None, "J", chunk_rows)
        self._body_ds = {}
        group = f.create_group("bodies", track_order=True)
        for body in bodies:
            g = group.create_group(body["name"])
            for key, value in body["attrs"].items():
                g.attrs[key] = value
            for path_, (array, unit) in body.get("constants", {}).items():
                ds = _constant(g, path_, array)
                ds.attrs["unit"] = unit
            self._body_ds[body["name"]] = {
                q: _growable(g, q, width, unit, chunk_rows) for q, (width, unit) in body["datasets"].items()
            }

    # -- the file's identity --------------------------------------------------------------
    def lost(self) -> str | None:
        """Whether the path still names the file this writer writes.

        Returns
        -------
        str or None
            None while it does (or before the file has its name); else what happened to it.
        """
        if self._temp is not None:
            return None
        try:
            now = _identity(os.stat(self.path))
        except FileNotFoundError:
            return "was removed"
        except OSError:  # cannot tell (permissions, a file system hiccup): no evidence of a loss
            return None
        return None if now == self._identity else "was replaced by another file"

    def _size(self) -> int | None:
        """The size of the file this writer holds open, bytes (None where it cannot be told)."""
        try:
            return os.fstat(self.file.id.get_vfd_handle()).st_size
        except (OSError, ValueError, AttributeError):
            return None

    def _shrunk(self, flushed: bool = False) -> str | None:
        """Whether the file is shorter than it was after the last flush (between flushes HDF5
        only writes, which never shortens a file) or, just after a flush, than HDF5 holds it to
        be: truncated in place by another process."""
        size = self._size()
        if size is None:
            return None
        was = self._flushed_size
        if flushed:
            try:
                was = self.file.id.get_filesize()  # a flush leaves the file as long as HDF5 has it
            except (OSError, RuntimeError, ValueError):
                return None
        if was is None or size >= was:
            return None
        return f"was truncated to {size:,} bytes (it had {was:,})"

    def _watch(self, flushed: bool = False) -> None:
        """Before writing, before a flush and after one: stop the run if its file was truncated
        in place since the last flush; what it wrote before is lost, and writing on would
        leave a file that cannot be read."""
        if self._lost is None and (what := self._shrunk(flushed)):
            self._lost = what
            raise FileLostError(f"{self.path!r} {what} while this run was writing it{_TRUNCATED}")

    def _flush(self) -> None:
        """Flush, then stop the run if the file was truncated or the path no longer names it."""
        self._watch()
        self.file.flush()
        self._watch(flushed=True)
        self._flushed_size = self._size()
        if self._lost is None and (what := self.lost()):
            self._lost = what
            raise FileLostError(
                f"{self.path!r} {what} while this run was writing it (by another process or by hand); "
                "the records this run wrote are not at that path"
            )

    def _rescue(self) -> str:
        """Copy the file this writer still holds open next to the path, if no other name reaches
        it; say where the records are."""
        try:
            fd = self.file.id.get_vfd_handle()
            if os.fstat(fd).st_nlink > 0:
                return "; the file this run wrote was moved elsewhere and holds them"
            rescue = f"{self.path}.lost-{os.getpid()}"
            with open(rescue, "xb") as out:
                offset = 0
                while block := os.pread(fd, 1 << 22, offset):
                    out.write(block)
                    offset += len(block)
            self.rescued = rescue
            return f"; they are kept in {rescue!r}"
        except (OSError, ValueError, AttributeError) as exc:
            return f", and could not be kept elsewhere ({exc})"

    # -- records and states ---------------------------------------------------------------
    def append(self, time, energy, momentum, angular_momentum, newton_iterations, data, **diagnostics):
        """Append a block of records and flush.

        Parameters
        ----------
        time : array_like
            (k,) record times, s.
        energy : array_like
            (k,) total energy, J.
        momentum, angular_momentum : array_like
            (k, 3) totals, kg m/s and kg m^2/s.
        newton_iterations : array_like
            (k,) mean Newton iterations per body and sub-step.
        data : dict
            {body: {dataset: block}}, a block of rows for each of the body's datasets.
        **diagnostics : array_like
            Blocks of the other record datasets by name (``split_steps``,
            ``stalled_solves``, ``invariant_drift``, ``drift_bound``, ``energy_range``); one
            not given is filled as :data:`~emorbit.io.reader.OPTIONAL` says.

        Raises
        ------
        FileLostError
            The path no longer names this file.
        """
        self._watch()
        time = np.asarray(time, float)
        blocks = dict(zip(list(LAYOUT_UNITS)[:5], (time, energy, momentum, angular_momentum, newton_iterations)))
        for name, fill in OPTIONAL.items():
            shape = (time.shape[0],) + self._ds[name].shape[1:]
            if fill is None:  # energy_range: the record's energy, as least and greatest
                fill = np.asarray(energy, float)[:, None]
            blocks[name] = diagnostics.get(name.split("/")[1], np.broadcast_to(fill, shape))
        for name in self._ds:
            if name.startswith(EFFECT_RECORDS):
                blocks[name] = diagnostics.get(name.split("/")[1], np.zeros(time.shape[0]))
        for name, block in blocks.items():
            _append(self._ds[name], np.asarray(block, float))
        for name, sets in self._body_ds.items():
            for q, ds in sets.items():
                _append(ds, data[name][q])
        self._flush()

    def append_event(self, entry: dict) -> None:
        """Append an event to the ``events/`` group (made on the first) and flush: ``time`` (s),
        ``step`` (the step it fell in, from the run's start), ``label``, ``kind``, ``body``
        (strings), ``position`` (m) and ``velocity`` (m/s) of its body (NaN for a time event),
        and an impulse's ``dv`` (m/s, in the scene's axes) and ``work`` (J; 0 for others).

        Raises
        ------
        FileLostError
            The path no longer names this file.
        """
        self._watch()
        g = self.file.require_group("events")
        if "time" not in g:
            for name, (width, unit) in EVENT_DATASETS.items():
                _growable(g, name, width, unit, 64)
            for name in EVENT_TEXT:
                ds = g.create_dataset(name, shape=(0,), maxshape=(None,), chunks=(64,), dtype=h5py.string_dtype())
                ds.attrs["unit"] = ""
        for name in EVENT_DATASETS:
            _append(g[name], np.asarray([entry[name]], float))
        for name in EVENT_TEXT:
            ds = g[name]
            ds.resize(ds.shape[0] + 1, axis=0)
            ds[-1] = entry[name]
        self._flush()

    def write_checkpoint(self, steps: int, time: float, arrays: dict, rows: int, units: dict | None = None) -> None:
        """Store the complete state and the number of records that belong to it, then flush.

        The new state goes into ``/checkpoint_next`` first, is flushed, and only then
        replaces ``/checkpoint`` (a link operation): a run killed while the arrays are being
        written keeps the previous checkpoint, and one killed between the two link operations
        leaves the complete ``/checkpoint_next``, which a resume takes. The file gets its name
        with its first checkpoint.

        Parameters
        ----------
        steps : int
            Steps since the start of the run.
        time : float
            The time of the state, s.
        arrays : dict
            {``"<kind>/<field>"``: array}, as :meth:`emorbit.Simulation.state_arrays` gives.
        rows : int
            Records written up to and including this state.
        units : dict, optional
            {``"<kind>/<field>"``: unit} for arrays not in :data:`STATE_UNITS`.

        Raises
        ------
        FileLostError
            The path no longer names this file.
        """
        self._watch()
        f = self.file
        if NEXT_CHECKPOINT in f:
            del f[NEXT_CHECKPOINT]
        g = self._state_group(NEXT_CHECKPOINT, steps, time, arrays, units)
        g.attrs["records"] = int(rows)
        g.attrs["complete"] = True
        f.flush()
        if "checkpoint" in f:
            del f["checkpoint"]
        f.move(NEXT_CHECKPOINT, "checkpoint")
        self._flush()
        self._place()

    def write_final_state(self, steps: int, time: float, arrays: dict, units: dict | None = None) -> None:
        """Store the state at the end of the run in ``/final_state`` (resuming uses the checkpoint).

        Parameters
        ----------
        steps : int
            Steps since the start of the run.
        time : float
            The time of the state, s.
        arrays : dict
            {``"<kind>/<field>"``: array}.
        units : dict, optional
            {``"<kind>/<field>"``: unit} for arrays not in :data:`STATE_UNITS`.

        Raises
        ------
        FileLostError
            The path no longer names this file.
        """
        self._watch()
        self._state_group("final_state", steps, time, arrays, units)
        self._flush()

    def _state_group(self, name: str, steps: int, time: float, arrays: dict, units: dict | None = None):
        g = self.file.require_group(name)
        stale = []
        g.visititems(
            lambda key, obj: stale.append(key) if isinstance(obj, h5py.Dataset) and key not in arrays else None
        )
        for key in stale:  # arrays of an earlier state that this one has not (a structure's kept factors)
            del g[key]
        for key, value in arrays.items():
            value = np.asarray(value, float)
            if key in g and g[key].shape == value.shape:
                g[key][...] = value
            else:
                if key in g:
                    del g[key]
                _constant(g, key, value)
            unit = (units or {}).get(key, STATE_UNITS.get(key))
            if unit is not None:
                g[key].attrs["unit"] = unit
        g.attrs["steps"] = int(steps)
        g.attrs["time"] = float(time)
        g.attrs["time_unit"] = "s"
        g.attrs["digest"] = state_digest(arrays, steps, time)
        return g

    @classmethod
    def reopen(cls, path, records: int, attrs: dict) -> Writer:
        """Open an existing run file to continue it.

        Every record after the first ``records`` is dropped (nodal outputs after the last
        kept record too), the root attributes are updated and the status is set to running.
        The caller checks the file first (:func:`emorbit.io.resume.load_checkpoint` does).

        Parameters
        ----------
        path : str, bytes or os.PathLike
            The run file.
        records : int
            Records to keep (at least 1, at most the rows of every record dataset).
        attrs : dict
            Root attributes to set.

        Returns
        -------
        Writer
            Appending after the kept records.

        Raises
        ------
        InputError
            Another process is writing the file, or it cannot be opened for writing.
        """
        self = cls.__new__(cls)
        self.path = file_path(path)
        self._lost, self._temp, self._held, self.rescued, self._flushed_size = None, None, None, None, None
        try:
            self.file = h5py.File(self.path, "r+")
        except OSError as exc:
            if _locked(exc):
                raise InputError("file", _busy_message(self.path)) from None
            raise InputError("file", f"cannot open {self.path!r} for writing ({exc})") from None
        f = self.file
        _hold_metadata(f)
        self._identity = _identity(os.fstat(f.id.get_vfd_handle()))
        for name, fill in OPTIONAL.items():  # a file of an earlier version: its rows read as OPTIONAL says
            if name not in f:
                rows = optional_rows(f, name, f["time"].shape[0])
                ds = _growable(f, name, WIDTHS[name], LAYOUT_UNITS[name], 1024, fill or 0.0)
                ds.resize(rows.shape[0], axis=0)
                ds[:] = rows
        self._ds = {name: f[name] for name in LAYOUT_UNITS}
        for label in f["invariants"]:  # each effect's potential energy, the work of those doing work
            if label.startswith(tuple(p.split("/")[1] for p in EFFECT_RECORDS)):
                self._ds[f"invariants/{label}"] = f[f"invariants/{label}"]
        self._body_ds = {}
        for name, g in f["bodies"].items():
            self._body_ds[name] = {q: ds for q, ds in g.items() if isinstance(ds, h5py.Dataset)}
            for q, ds in list(g["nodes"].items()) if "nodes" in g else []:
                self._body_ds[name][f"nodes/{q}"] = ds
        times = f["time"][:records]
        for ds in self._ds.values():
            ds.resize(records, axis=0)
        for name, sets in self._body_ds.items():
            for q, ds in sets.items():
                if q.startswith("nodes/"):
                    keep = int(np.searchsorted(f["bodies"][name]["nodes/time"][()], times[-1], side="right"))
                    ds.resize(keep, axis=0)
                elif ds.maxshape and ds.maxshape[0] is None:
                    ds.resize(records, axis=0)
        if "events" in f and "time" in f["events"]:  # events after the kept records are found again
            keep = int(np.count_nonzero(f["events/time"][()] <= times[-1]))
            for ds in f["events"].values():
                ds.resize(keep, axis=0)
        for key in ("stopped_by",):
            if key in f.attrs:
                del f.attrs[key]
        _write_root_attrs(f, attrs)
        for key in ROOT_UNITS:
            if key in f.attrs and f"{key}_unit" not in f.attrs:
                f.attrs[f"{key}_unit"] = ROOT_UNITS[key]
        f.attrs["status"] = "running"
        f.attrs["writer"] = writer_id()
        if "error" in f.attrs:
            del f.attrs["error"]
        self._flush()
        return self

    def close(self, status: str = "completed", error: str | None = None) -> str:
        """Mark the run's status, flush and close the file; a second call does nothing.

        A file that has no name yet (no checkpoint was written) gets it now. A file whose
        path was removed or replaced under the run is copied next to the path
        (``<path>.lost-<pid>``) when no other name reaches it.

        Parameters
        ----------
        status : str
            ``"completed"``, ``"failed"`` or ``"interrupted"``.
        error : str, optional
            The message to store in the root attribute ``error``.

        Returns
        -------
        str
            "" or, for a lost file, where its records are (appended to the error's message).

        Raises
        ------
        FileLostError
            The path no longer names this file and that was not reported yet; the file is
            marked and closed all the same.
        InputError
            The file could not get its name (another run's file appeared at the path).
        """
        if not self.file:
            return ""
        shrunk = self._shrunk() if self._lost is None else None  # before this close writes
        self.file.attrs["status"] = status
        if error is not None:
            self.file.attrs["error"] = error
        self.file.flush()
        if self._lost is None:
            shrunk = shrunk or self._shrunk(flushed=True)
        if self._temp is not None:
            try:
                self._place()
            except BaseException:
                self.file.close()
                raise
        reported = self._lost is not None
        if not reported:
            self._lost = shrunk or self.lost()
        note = self._rescue() if self._lost and not self._lost.startswith("was truncated") else ""
        self.file.close()
        if self._lost and not reported:
            if shrunk:
                raise FileLostError(f"{self.path!r} {self._lost} while this run was writing it{_TRUNCATED}")
            raise FileLostError(
                f"{self.path!r} {self._lost} while this run was writing it (by another process or by hand); "
                f"the records this run wrote are not at that path{note}"
            )
        return note


def temp_name(name: str, pid: int, tag: str) -> str:
    """The name of a run's temporary file for the output ``name`` (no folder):
    ``.<name>.<pid>-<tag>.tmp``, ``tag`` 8 random hex digits."""
    return f".{name}.{pid}-{tag}.tmp"


def temp_pattern(name: str) -> str:
    """A regular expression that the whole name of every temporary file :func:`temp_name`
    gives for the output ``name`` (itself a regular expression) matches; the process id is its
    group ``pid``."""
    return r"\." + name + r"\.(?P<pid>\d+)-[0-9a-f]{8}\.tmp"


def _remove_orphans(folder: str, name: str) -> None:
    """Remove the hidden temporary files that runs to ``name`` left when they were killed
    (SIGKILL) before their first checkpoint gave the file its name: those whose whole name is
    such a file's (:func:`temp_name`) and whose process is gone. A temporary file of a process
    that still runs is its run's, and stays; any other file stays."""
    pattern = re.compile(temp_pattern(re.escape(name)))
    try:
        entries = os.listdir(folder)
    except OSError:
        return
    for entry in entries:
        m = pattern.fullmatch(entry)
        if m is None or _alive(int(m.group("pid"))):
            continue
        try:
            os.unlink(os.path.join(folder, entry))
        except OSError:
            pass


def _discard(file, temp, held) -> None:
    """Close and remove a file that never got its name, and let go of the file it was to replace."""
    if file:
        file.close()
    if temp is not None and os.path.lexists(temp):
        os.unlink(temp)
    if held:
        held.close()
