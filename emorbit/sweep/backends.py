"""Where sweep tasks run: every backend hands out a :class:`concurrent.futures.Executor`.

========== =====================================================================================
serial     in the calling process, one run after another (debugging; nothing to start)
process    local processes (:class:`~concurrent.futures.ProcessPoolExecutor`, "spawn"): the default
dask       Dask distributed: a :class:`~distributed.LocalCluster` on loopback, or an existing
           cluster at ``scheduler="tcp://HOST:PORT"`` (e.g. one dask-jobqueue started on Slurm)
mpi        :class:`mpi4py.futures.MPIPoolExecutor` (``mpiexec -n N python -m mpi4py.futures ...``
           or dynamic process spawning), where mpi4py is installed
========== =====================================================================================

Any other executor can be passed to :func:`emorbit.sweep.run_sweep` as ``executor=``. Tasks
are plain functions of picklable dicts, so any executor whose workers can import emorbit
works; run files are written by the workers, so the output folder must be visible to them
at the same path (a shared file system on a cluster).

Workers run Numba with ``threads`` threads each (default 1: one process per core is the
efficient layout for many independent runs); ``threads=None`` leaves Numba's default.
"""

from __future__ import annotations

import concurrent.futures as cf
import logging
import multiprocessing
import os

from ..errors import InputError

__all__ = ["BACKENDS", "make_backend", "InlineExecutor"]

BACKENDS = ("process", "dask", "mpi", "serial")
#: thread-count variables of BLAS / OpenMP set for spawned workers unless already set
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


class InlineExecutor(cf.Executor):
    """Runs each call at submit, in the calling thread (the serial backend)."""

    def submit(self, fn, /, *args, **kwargs):
        future = cf.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # handed to the caller through the future, as any executor does
            future.set_exception(exc)
        return future


def _init_worker(threads) -> None:
    from .task import limit_threads

    limit_threads(threads)


class Backend:
    """Starts an executor, replaces it when it breaks, and closes it."""

    name = "executor"
    #: at most this many tasks in flight (None: submit all); bounds what a broken pool loses
    window: int | None = None

    def __init__(self, executor: cf.Executor | None = None):
        self.executor = executor

    def start(self) -> cf.Executor:
        return self.executor

    def restart(self) -> cf.Executor:
        """A working executor after :class:`~concurrent.futures.BrokenExecutor`."""
        raise RuntimeError("the executor broke and cannot be restarted")

    def close(self) -> None:
        pass

    def describe(self) -> str:
        return f"executor {type(self.executor).__name__}"


class SerialBackend(Backend):
    name = "serial"
    window = 1

    def __init__(self, threads):
        super().__init__(InlineExecutor())
        self.threads = threads

    def restart(self) -> cf.Executor:
        return self.executor

    def describe(self) -> str:
        return "serial (this process)"


class ProcessBackend(Backend):
    name = "process"

    def __init__(self, workers: int | None, threads):
        super().__init__()
        self.workers = workers or os.cpu_count() or 1
        self.threads = threads
        self.window = 2 * self.workers
        self._saved_env = None

    def _new(self) -> cf.Executor:
        return cf.ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_init_worker,
            initargs=(self.threads,),
        )

    def start(self) -> cf.Executor:
        if self.threads is not None:  # BLAS reads these when a worker imports numpy
            self._saved_env = {k: os.environ.get(k) for k in _THREAD_VARS}
            for k in _THREAD_VARS:
                os.environ.setdefault(k, str(self.threads))
        self.executor = self._new()
        return self.executor

    def restart(self) -> cf.Executor:
        self.executor.shutdown(wait=True, cancel_futures=True)  # a broken pool has stopped its workers
        self.executor = self._new()
        return self.executor

    def close(self) -> None:
        if self.executor is not None:
            self.executor.shutdown(wait=True, cancel_futures=True)
        if self._saved_env is not None:
            for k, v in self._saved_env.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
            self._saved_env = None

    def describe(self) -> str:
        return f"{self.workers} local processes"


class DaskBackend(Backend):
    name = "dask"

    def __init__(self, workers: int | None, threads, scheduler: str | None = None):
        super().__init__()
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise InputError(
                "backend",
                "the Dask backend needs dask.distributed, which is not installed: pip install 'emorbit[cluster]'",
            ) from None
        self.workers = workers
        self.threads = threads
        self.scheduler = scheduler
        self.cluster = None
        self.client = None

    def start(self) -> cf.Executor:
        from distributed import Client, LocalCluster

        if self.scheduler is not None:
            try:
                self.client = Client(self.scheduler, timeout="20s")
            except (OSError, TimeoutError) as exc:
                raise InputError("scheduler", f"cannot reach the Dask scheduler at {self.scheduler!r}: {exc}") from None
        else:
            env = {"NUMBA_NUM_THREADS": str(self.threads)} if self.threads is not None else {}
            self.cluster = LocalCluster(
                n_workers=self.workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
                silence_logs=logging.ERROR,
                env=env,
            )
            self.client = Client(self.cluster)
        # pure=False: a resubmitted task is a new task, not the cached result of the lost one
        self.executor = self.client.get_executor(pure=False)
        return self.executor

    def restart(self) -> cf.Executor:
        return self.executor  # Dask replaces lost workers itself; the executor never breaks

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def describe(self) -> str:
        if self.scheduler is not None:
            return f"Dask cluster at {self.scheduler}"
        return f"Dask LocalCluster, {self.workers or os.cpu_count()} workers on 127.0.0.1"


class MPIBackend(Backend):
    name = "mpi"

    def __init__(self, workers: int | None, threads):
        super().__init__()
        try:
            from mpi4py import MPI  # noqa: F401 - loads the MPI library
            from mpi4py.futures import MPIPoolExecutor  # noqa: F401
        except Exception as exc:  # ImportError, or mpi4py present without an MPI library
            raise InputError(
                "backend",
                f"the MPI backend needs mpi4py with an MPI library ({exc}); install them "
                "(pip install mpi4py, and Open MPI or MPICH), or use the process or "
                "Dask backend",
            ) from None
        self.workers = workers
        self.threads = threads
        self.window = 2 * workers if workers else None

    def _new(self) -> cf.Executor:
        from mpi4py.futures import MPIPoolExecutor

        return MPIPoolExecutor(max_workers=self.workers, initializer=_init_worker, initargs=(self.threads,))

    def start(self) -> cf.Executor:
        self.executor = self._new()
        return self.executor

    def restart(self) -> cf.Executor:
        self.executor.shutdown(wait=False, cancel_futures=True)
        self.executor = self._new()
        return self.executor

    def close(self) -> None:
        if self.executor is not None:
            self.executor.shutdown(wait=True, cancel_futures=True)

    def describe(self) -> str:
        return f"MPI ({self.workers or 'all'} workers)"


def make_backend(
    backend: str = "process",
    *,
    workers: int | None = None,
    threads=1,
    scheduler: str | None = None,
    executor: cf.Executor | None = None,
) -> Backend:
    """The backend named ``backend`` (see :data:`BACKENDS`); ``scheduler`` means Dask on an
    existing cluster; ``executor`` wraps a ready executor (the caller owns and closes it)."""
    if executor is not None:
        if not isinstance(executor, cf.Executor):
            raise InputError("executor", f"a concurrent.futures.Executor expected, got {executor!r}")
        return Backend(executor)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise InputError("workers", f"must be an integer >= 1, got {workers!r}")
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
        raise InputError("threads", f"must be an integer >= 1, got {threads!r}")
    if scheduler is not None:
        if backend not in ("dask", "process"):
            raise InputError("scheduler", f"a scheduler address is for the Dask backend, not {backend!r}")
        return DaskBackend(workers, threads, scheduler)
    if backend == "process":
        return ProcessBackend(workers, threads)
    if backend == "dask":
        return DaskBackend(workers, threads)
    if backend == "mpi":
        return MPIBackend(workers, threads)
    if backend == "serial":
        return SerialBackend(threads)
    raise InputError("backend", f"unknown backend {backend!r}; known: {', '.join(BACKENDS)}")
