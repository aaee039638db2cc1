"""Continue a run file: ``emorbit resume OUT.h5 --t-end T2``.

The file says how it was made (its scene text and the effective method, order, dt and
output stride in its attributes) and holds the complete state at its last checkpoint. A
resume rebuilds the simulation from the scene, restores that state bit for bit, drops the
records written after the checkpoint and runs to T2 (continuing the record grid), so the
file ends up identical to one written by a single uninterrupted run to T2 - whether the
first run finished, failed, was interrupted with Ctrl-C or killed.
"""

from __future__ import annotations

import os

import h5py
import numpy as np

from ..errors import InputError
from ..result import Result
from ..scene import parse_scene
from ..units import to_si
from .hdf5 import NEXT_CHECKPOINT, Writer

__all__ = ["resume", "load_checkpoint"]


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def load_checkpoint(path):
    """Rebuild a run file's simulation at its last checkpoint.

    Parameters
    ----------
    path : str or os.PathLike
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
        The file is missing, unreadable or has no checkpoint.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError("file", f"{path!r} does not exist")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError("file", f"{path!r} is not a readable HDF5 file ({exc})") from None
    with f:
        attrs = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in f.attrs.items()}
        if "checkpoint" in f:
            cp = f["checkpoint"]
        elif NEXT_CHECKPOINT in f and f[NEXT_CHECKPOINT].attrs.get("complete", False):
            cp = f[NEXT_CHECKPOINT]  # killed between replacing the old checkpoint and renaming the new one
        else:
            raise InputError("file", f"{path!r} has no checkpoint to continue from")
        arrays = {}
        cp.visititems(lambda name, obj: arrays.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
        steps = int(cp.attrs["steps"])
        records = int(cp.attrs["records"])
    scene = parse_scene(_text(attrs["scene"]), path)
    scene = scene.with_overrides(
        method=_text(attrs["method"]),
        order=int(attrs["order"]),
        dt=f"{float(attrs['dt'])!r} s",
        output_every=int(attrs["output_every"]),
    )
    sim = scene.build()
    if sim.structure is not None:
        sim.structure.build()
    sim._t_base = float(attrs["t_start"])
    sim.set_state_arrays(arrays, steps)
    sim._run_origin = 0
    return sim, attrs, records


def resume(path, t_end, *, progress: bool | None = None) -> Result:
    """Continue the run in a file to a later time, in place.

    Parameters
    ----------
    path : str or os.PathLike
        A run file (finished, failed, interrupted or killed).
    t_end : Quantity, str or float
        The new end time, s.
    progress : bool, optional
        A progress bar on stderr; default: when stderr is a terminal.

    Returns
    -------
    Result
        The records computed by this call, from the checkpoint on.

    Raises
    ------
    InputError
        The file cannot be continued, or ``t_end`` is not after its checkpoint.
    IntegrationError
        A step failed, as in :meth:`emorbit.Simulation.run`.
    """
    import sys

    from .recorder import Sink

    sim, attrs, records = load_checkpoint(path)
    t2 = to_si(t_end, "time", "t_end", positive=False)
    n_steps = sim.steps_until(t2)
    every = int(attrs["output_every"])
    cp = int(attrs.get("checkpoint_every", every))
    total = int(round((sim.time - sim._t_base) / sim.dt)) + n_steps
    writer = Writer.reopen(path, records, {"t_end": sim._t_base + total * sim.dt, "steps": total})
    sink = Sink(sim, writer, True)
    sink.rows = records
    if progress is None:
        progress = sys.stderr.isatty()
    return sim._run_and_close(n_steps, every, cp, sink, writer, progress)
