"""The HDF5 run file: written in chunks while a run runs, read back into a Result.

Layout (every dataset has a ``unit`` attribute; one row per record unless said)::

    /time                              (n,)      s
    /invariants/energy                 (n,)      J
    /invariants/momentum               (n, 3)    kg m / s
    /invariants/angular_momentum       (n, 3)    kg m2 / s   about the field's centre
    /diagnostics/newton_iterations     (n,)      1           mean per body and sub-step
    /bodies/<name>/position            (n, 3)    m           centre of mass of extended bodies
    /bodies/<name>/velocity            (n, 3)    m / s
    /bodies/<name>/attitude            (n, 4)    1           rigid: unit quaternion (w, x, y, z), body to space
    /bodies/<name>/angular_velocity    (n, 3)    rad / s     rigid: in the body frame
    /bodies/<name>/mass_points/...     position (N, 3) m, mass (N,) kg: rigid, body frame, written once
    /bodies/<name>/nodes/position      (k, N, 3) m           elastic: every node_output_every records
    /bodies/<name>/nodes/time          (k,)      s
    /bodies/<name>/mesh/...            reference_nodes (N, 3) m, bars, tetrahedra: elastic, written once

Body groups carry ``kind`` ("point", "rigid", "elastic") and ``mass`` (kg); rigid bodies
``shape``, ``gravity``, ``mass_points`` and ``inertia`` (kg m2, of the discretisation);
elastic bodies their element counts and material. Root attributes: ``creator``,
``emorbit_version``, ``created`` (UTC, ISO 8601), ``versions`` (JSON), the run's ``method``,
``order``, ``dt`` (s), ``t_start`` and ``t_end`` (s), ``steps``, ``output_every``,
``checkpoint_every``, ``gm`` (m3 / s2), ``center`` (m), ``field_body``, ``field_radius`` (m),
``adaptive``, ``roundoff``, ``scene`` (the scene as TOML text), ``status`` ("running",
"completed", "failed", "interrupted") and ``error``. Datasets are chunked and growable and
every appended block is flushed, so a run that stops early leaves a readable file.

``/checkpoint`` holds the complete state (every system's arrays, compensation terms and
warm starts included; attributes ``steps`` since the run's start, ``time`` and ``records``),
replaced every ``checkpoint_every`` steps: written as ``/checkpoint_next``, flushed, then
renamed, so that a kill never leaves half a checkpoint. ``/final_state`` holds the state at
the end of the run, also of an interrupted one. ``emorbit resume`` continues from the
checkpoint (:mod:`emorbit.io.resume`); hdf5.md lists every dataset and attribute.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform

import h5py
import numpy as np

from .._version import __version__
from ..errors import InputError
from ..result import Result

__all__ = ["Writer", "read", "LAYOUT_UNITS"]

#: the unit attribute of each top-level dataset
LAYOUT_UNITS = {
    "time": "s",
    "invariants/energy": "J",
    "invariants/momentum": "kg m / s",
    "invariants/angular_momentum": "kg m2 / s",
    "diagnostics/newton_iterations": "1",
}
_SCALAR = ("time", "invariants/energy", "diagnostics/newton_iterations")


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


def _growable(group, name, width, unit, chunk_rows):
    """A dataset growing along its first axis; ``width`` is None (1-D), an int, or a shape."""
    tail = () if width is None else ((width,) if isinstance(width, int) else tuple(width))
    shape = (0,) + tail
    maxshape = (None,) + tail
    rows = max(1, min(chunk_rows, (1 << 20) // (8 * max(1, int(np.prod(tail))))))
    chunks = (rows,) + tail
    ds = group.create_dataset(name, shape=shape, maxshape=maxshape, chunks=chunks, dtype="f8")
    ds.attrs["unit"] = unit
    return ds


def _append(ds, block):
    if len(block) == 0:
        return
    n0 = ds.shape[0]
    ds.resize(n0 + block.shape[0], axis=0)
    ds[n0:] = block


#: where a new checkpoint is written before it replaces /checkpoint
NEXT_CHECKPOINT = "checkpoint_next"


class Writer:
    """A run file being written: created with its layout, then appended to record by record.

    Parameters
    ----------
    path : str or os.PathLike
        The file to create.
    bodies : list of dict
        One per body: ``name``, ``attrs`` (the group's attributes), ``datasets``
        ({dataset: (width or shape, unit)}: growable, a row per record or fewer) and
        ``constants`` ({path: (array, unit)}, written once).
    attrs : dict
        Root attributes to store.
    overwrite : bool
        Replace an existing file; otherwise an existing file is an error, so a finished run
        is never lost by accident.
    chunk_rows : int
        Rows per HDF5 chunk (at most 1 MiB per chunk).

    Raises
    ------
    InputError
        The file exists (without ``overwrite``), its folder does not, or it cannot be created.
    """

    def __init__(self, path, bodies, attrs: dict, *, overwrite: bool = False, chunk_rows: int = 1024):
        path = os.fspath(path)
        if os.path.exists(path) and not overwrite:
            raise InputError("output", f"{path!r} exists; choose another name or pass overwrite (--overwrite)")
        folder = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(folder):
            raise InputError("output", f"folder {folder!r} does not exist")
        try:
            self.file = h5py.File(path, "w")
        except OSError as exc:
            raise InputError("output", f"cannot create {path!r}: {exc}") from None
        self.path = path
        f = self.file
        f.attrs["creator"] = f"emorbit {__version__}"
        f.attrs["emorbit_version"] = __version__
        f.attrs["created"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        f.attrs["versions"] = _versions()
        for key, value in attrs.items():
            f.attrs[key] = value
        f.attrs["status"] = "running"
        self._ds = {
            name: _growable(f, name, None if name in _SCALAR else 3, unit, chunk_rows)
            for name, unit in LAYOUT_UNITS.items()
        }
        self._body_ds = {}
        group = f.create_group("bodies", track_order=True)
        for body in bodies:
            g = group.create_group(body["name"])
            for key, value in body["attrs"].items():
                g.attrs[key] = value
            for path_, (array, unit) in body.get("constants", {}).items():
                ds = g.create_dataset(path_, data=array)
                ds.attrs["unit"] = unit
            self._body_ds[body["name"]] = {
                q: _growable(g, q, width, unit, chunk_rows) for q, (width, unit) in body["datasets"].items()
            }
        f.flush()

    def append(self, time, energy, momentum, angular_momentum, newton_iterations, data):
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
        """
        for name, block in (
            ("time", time),
            ("invariants/energy", energy),
            ("invariants/momentum", momentum),
            ("invariants/angular_momentum", angular_momentum),
            ("diagnostics/newton_iterations", newton_iterations),
        ):
            _append(self._ds[name], np.asarray(block, float))
        for name, sets in self._body_ds.items():
            for q, ds in sets.items():
                _append(ds, data[name][q])
        self.file.flush()

    def write_checkpoint(self, steps: int, time: float, arrays: dict, rows: int) -> None:
        """Store the complete state and the number of records that belong to it, then flush.

        The new state goes into ``/checkpoint_next`` first, is flushed, and only then
        replaces ``/checkpoint`` (a link operation): a run killed while the arrays are being
        written keeps the previous, consistent checkpoint (an in-place update could leave
        some arrays of the new state beside the old step count). If a kill falls between the
        two link operations, :func:`emorbit.io.resume.load_checkpoint` takes the complete
        ``/checkpoint_next``.

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
        """
        f = self.file
        if NEXT_CHECKPOINT in f:
            del f[NEXT_CHECKPOINT]
        g = self._state_group(NEXT_CHECKPOINT, steps, time, arrays)
        g.attrs["records"] = int(rows)
        g.attrs["complete"] = True
        f.flush()
        if "checkpoint" in f:
            del f["checkpoint"]
        f.move(NEXT_CHECKPOINT, "checkpoint")
        f.flush()

    def write_final_state(self, steps: int, time: float, arrays: dict) -> None:
        """Store the state at the end of the run in ``/final_state`` (resuming uses the checkpoint).

        Parameters
        ----------
        steps : int
            Steps since the start of the run.
        time : float
            The time of the state, s.
        arrays : dict
            {``"<kind>/<field>"``: array}.
        """
        self._state_group("final_state", steps, time, arrays)
        self.file.flush()

    def _state_group(self, name: str, steps: int, time: float, arrays: dict):
        g = self.file.require_group(name)
        for key, value in arrays.items():
            value = np.asarray(value, float)
            if key in g and g[key].shape == value.shape:
                g[key][...] = value
            else:
                if key in g:
                    del g[key]
                g.create_dataset(key, data=value)
        g.attrs["steps"] = int(steps)
        g.attrs["time"] = float(time)
        g.attrs["time_unit"] = "s"
        return g

    @classmethod
    def reopen(cls, path, records: int, attrs: dict) -> Writer:
        """Open an existing run file to continue it.

        Every record after the first ``records`` is dropped (nodal outputs after the last
        kept record too), the root attributes are updated and the status is set to running.

        Parameters
        ----------
        path : str or os.PathLike
            The run file.
        records : int
            Records to keep.
        attrs : dict
            Root attributes to set.

        Returns
        -------
        Writer
            Appending after the kept records.
        """
        self = cls.__new__(cls)
        self.path = os.fspath(path)
        self.file = h5py.File(self.path, "r+")
        f = self.file
        self._ds = {name: f[name] for name in LAYOUT_UNITS}
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
        for key, value in attrs.items():
            f.attrs[key] = value
        f.attrs["status"] = "running"
        if "error" in f.attrs:
            del f.attrs["error"]
        f.flush()
        return self

    def close(self, status: str = "completed", error: str | None = None) -> None:
        """Mark the run's status, flush and close the file; a second call does nothing.

        Parameters
        ----------
        status : str
            ``"completed"``, ``"failed"`` or ``"interrupted"``.
        error : str, optional
            The message to store in the root attribute ``error``.
        """
        if not self.file:
            return
        self.file.attrs["status"] = status
        if error is not None:
            self.file.attrs["error"] = error
        self.file.close()


def read(path) -> Result:
    """Read a run file.

    Parameters
    ----------
    path : str or os.PathLike
        An HDF5 file written by emorbit.

    Returns
    -------
    Result
        Every record, SI arrays; ``attrs`` holds the root attributes.
    """
    with h5py.File(path, "r") as f:
        bodies, masses, kinds = {}, {}, {}
        for name, g in f["bodies"].items():
            bodies[name] = {q: ds[()] for q, ds in g.items() if isinstance(ds, h5py.Dataset)}
            if "nodes" in g:
                bodies[name].update({f"nodes/{q}": ds[()] for q, ds in g["nodes"].items()})
            masses[name] = float(g.attrs["mass"])
            kinds[name] = str(g.attrs["kind"])
        return Result(
            time=f["time"][()],
            energy=f["invariants/energy"][()],
            momentum=f["invariants/momentum"][()],
            angular_momentum=f["invariants/angular_momentum"][()],
            newton_iterations=f["diagnostics/newton_iterations"][()],
            bodies=bodies,
            masses=masses,
            kinds=kinds,
            method=str(f.attrs["method"]),
            order=int(f.attrs["order"]),
            dt=float(f.attrs["dt"]),
            gm=float(f.attrs["gm"]),
            center=np.asarray(f.attrs["center"], float),
            attrs={k: (v.item() if isinstance(v, np.generic) else v) for k, v in f.attrs.items()},
        )
