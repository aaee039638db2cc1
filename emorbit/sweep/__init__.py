"""Parameter sweeps: one base scene, many runs, on local processes, Dask or MPI.

::

    from emorbit.sweep import load_sweep, run_sweep

    result = run_sweep("sweep.toml", "out/")                  # local processes, one per core
    result = run_sweep("sweep.toml", "out/", backend="dask")  # a Dask LocalCluster on loopback
    result = run_sweep("sweep.toml", "out/", scheduler="tcp://10.0.0.5:8786")  # an existing cluster
    for row in result.rows:
        print(row["run"], row["status"], row["energy_error"])

``emorbit sweep SWEEP.toml -o OUT`` is the same from the command line. The sweep file's
schema is in :mod:`emorbit.sweep.spec`, the run files in :mod:`emorbit.sweep.task`, the
backends in :mod:`emorbit.sweep.backends`, the summary in :mod:`emorbit.sweep.runner` and
the GPU path in :mod:`emorbit.sweep.device`.
"""

from .backends import BACKENDS, InlineExecutor, make_backend
from .device import DEVICES, use_device
from .runner import SweepResult, read_summary, run_sweep
from .spec import Parameter, Sweep, Task, load_sweep, parse_key, parse_sweep
from .task import run_task

__all__ = [
    "BACKENDS",
    "DEVICES",
    "InlineExecutor",
    "Parameter",
    "Sweep",
    "SweepResult",
    "Task",
    "load_sweep",
    "make_backend",
    "parse_key",
    "parse_sweep",
    "read_summary",
    "run_sweep",
    "run_task",
    "use_device",
]
