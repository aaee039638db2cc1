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
import sys

from ..errors import InputError

__all__ = ["BACKENDS", "make_backend", "InlineExecutor"]

BACKENDS = ("process", "dask", "mpi", "serial")
"""The backends :func:`make_backend` knows, the default first."""
#: thread-count variables of BLAS / OpenMP set for spawned workers unless already set
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


class InlineExecutor(cf.Executor):
    """An executor that runs each call at submit, in the calling thread (the serial backend)."""

    def submit(self, fn, /, *args, **kwargs):
        """Run ``fn(*args, **kwargs)`` now.

        Parameters
        ----------
        fn : callable
            The function.
        *args, **kwargs
            Its arguments.

        Returns
        -------
        concurrent.futures.Future
            Done, holding the result or the exception.
        """
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
    """Starts an executor, replaces it when it breaks, and closes it.

    This base class wraps an executor the caller owns; the subclasses start their own.

    Parameters
    ----------
    executor : concurrent.futures.Executor, optional
        A ready executor (the caller closes it).

    Attributes
    ----------
    name : str
        The backend's name.
    window : int or None
        At most this many tasks in flight (None: submit all); it bounds what a broken pool
        loses.
    """

    name = "executor"
    #: at most this many tasks in flight (None: submit all); bounds what a broken pool loses
    window: int | None = None

    def __init__(self, executor: cf.Executor | None = None):
        self.executor = executor

    def start(self) -> cf.Executor:
        """Start the executor.

        Returns
        -------
        concurrent.futures.Executor
            Ready for tasks.
        """
        return self.executor

    def restart(self) -> cf.Executor:
        """A working executor after :class:`~concurrent.futures.BrokenExecutor`.

        Returns
        -------
        concurrent.futures.Executor
            A new or the same executor.

        Raises
        ------
        RuntimeError
            A wrapped executor cannot be restarted.
        """
        raise RuntimeError("the executor broke and cannot be restarted")

    def close(self) -> None:
        """Stop the executor and its workers (a wrapped executor is left to its owner)."""
        pass

    def describe(self) -> str:
        """What runs the tasks, in words (stored in the summary file).

        Returns
        -------
        str
            A short description.
        """
        return f"executor {type(self.executor).__name__}"


class SerialBackend(Backend):
    """The runs in this process, one after another.

    Parameters
    ----------
    threads : int or None
        Ignored: the calling process keeps its Numba threads.
    """

    name = "serial"
    window = 1

    def __init__(self, threads):
        super().__init__(InlineExecutor())
        self.threads = threads

    def restart(self) -> cf.Executor:
        """The same inline executor (it never breaks).

        Returns
        -------
        InlineExecutor
            The executor.
        """
        return self.executor

    def describe(self) -> str:
        """``"serial (this process)"``.

        Returns
        -------
        str
            The description.
        """
        return "serial (this process)"


class ProcessBackend(Backend):
    """Local worker processes (``spawn``), each with its own Numba threads.

    Parameters
    ----------
    workers : int or None
        Processes (default: one per core).
    threads : int or None
        Numba (and BLAS) threads per worker; None leaves the defaults.
    """

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
        """Start the pool; BLAS and OpenMP thread variables are set for the workers.

        Returns
        -------
        concurrent.futures.ProcessPoolExecutor
            The pool.
        """
        if self.threads is not None:  # BLAS reads these when a worker imports numpy
            self._saved_env = {k: os.environ.get(k) for k in _THREAD_VARS}
            for k in _THREAD_VARS:
                os.environ.setdefault(k, str(self.threads))
        self.executor = self._new()
        return self.executor

    def restart(self) -> cf.Executor:
        """Replace a broken pool with a new one.

        Returns
        -------
        concurrent.futures.ProcessPoolExecutor
            The new pool.
        """
        # A worker killed while it held the pool's result queue leaves the others blocked on
        # that queue's lock for ever, and shutdown would wait for them: a broken pool's
        # workers are ended first (their runs are already failed and retried).
        for process in list((getattr(self.executor, "_processes", None) or {}).values()):
            if process.is_alive():
                process.kill()
        self.executor.shutdown(wait=True, cancel_futures=True)
        self.executor = self._new()
        return self.executor

    def close(self) -> None:
        """Shut the pool down and restore the thread variables."""
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
        """``"<n> local processes"``.

        Returns
        -------
        str
            The description.
        """
        return f"{self.workers} local processes"


def _scheduler_address(address) -> str:
    """A Dask scheduler's address as dask.distributed reads it (``[scheme://]host:port``),
    checked before a client is made: a client made of a bad address raises from deep inside
    Dask and leaves tracebacks on stderr when it is collected."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import get_backend

    try:
        scheme, location = parse_address(address)
        get_backend(scheme)
        _, port = parse_host_port(location)
    except (ValueError, TypeError) as exc:
        what = f"{address!r} is not a Dask scheduler's address tcp://HOST:PORT"
        raise InputError("scheduler", f"{what} ({exc})") from None
    if not 0 < port < 65536:
        raise InputError("scheduler", f"{address!r} is not a Dask scheduler's address: port {port} is not in 1..65535")
    return address


class DaskBackend(Backend):
    """Dask distributed: a LocalCluster on loopback, or an existing cluster.

    Parameters
    ----------
    workers : int or None
        LocalCluster workers (default: one per core).
    threads : int or None
        Numba threads per worker.
    scheduler : str, optional
        ``tcp://HOST:PORT`` of an existing scheduler.

    Raises
    ------
    InputError
        dask.distributed is not installed, or ``scheduler`` is not a scheduler's address.
    """

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
        self.scheduler = None if scheduler is None else _scheduler_address(scheduler)
        self.cluster = None
        self.client = None

    def start(self) -> cf.Executor:
        """Start a LocalCluster or connect to the scheduler.

        Returns
        -------
        concurrent.futures.Executor
            The client's executor.

        Raises
        ------
        InputError
            The scheduler cannot be reached.
        """
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
        """The same executor: Dask replaces lost workers itself.

        Returns
        -------
        concurrent.futures.Executor
            The executor.
        """
        return self.executor  # Dask replaces lost workers itself; the executor never breaks

    def close(self) -> None:
        """Close the client and, if this backend started one, the cluster."""
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def describe(self) -> str:
        """The cluster, in words.

        Returns
        -------
        str
            The description.
        """
        if self.scheduler is not None:
            return f"Dask cluster at {self.scheduler}"
        return f"Dask LocalCluster, {self.workers or os.cpu_count()} workers on 127.0.0.1"


def _mpi_tools_on_path() -> None:
    """Put the interpreter's folder on ``PATH`` where MPICH's process manager lies there.

    MPICH installed from its PyPI wheel puts ``mpiexec`` and ``hydra_pmi_proxy`` beside the
    interpreter of the virtual environment. A process not started by ``mpiexec`` (a
    singleton, as ``emorbit sweep --mpi`` is) spawns its workers through that process
    manager, looked up on ``PATH``: where the environment was not activated, the spawn waits
    forever. Nothing changes where the folder holds no ``hydra_pmi_proxy`` or is on ``PATH``.
    """
    here = os.path.dirname(sys.executable)
    if not os.path.exists(os.path.join(here, "hydra_pmi_proxy")):
        return
    path = os.environ.get("PATH", "")
    if here not in path.split(os.pathsep):
        os.environ["PATH"] = here + os.pathsep + path if path else here


class MPIBackend(Backend):
    """MPI workers through :class:`mpi4py.futures.MPIPoolExecutor`.

    Parameters
    ----------
    workers : int or None
        Workers (default: what MPI offers).
    threads : int or None
        Numba threads per worker.

    Raises
    ------
    InputError
        mpi4py or an MPI library is missing.
    """

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

        _mpi_tools_on_path()
        return MPIPoolExecutor(max_workers=self.workers, initializer=_init_worker, initargs=(self.threads,))

    def start(self) -> cf.Executor:
        """Start the pool.

        Returns
        -------
        concurrent.futures.Executor
            The MPI pool.
        """
        self.executor = self._new()
        return self.executor

    def restart(self) -> cf.Executor:
        """Replace a broken pool with a new one.

        Returns
        -------
        concurrent.futures.Executor
            The new pool.
        """
        self.executor.shutdown(wait=False, cancel_futures=True)
        self.executor = self._new()
        return self.executor

    def close(self) -> None:
        """Shut the pool down."""
        if self.executor is not None:
            self.executor.shutdown(wait=True, cancel_futures=True)

    def describe(self) -> str:
        """``"MPI (<n> workers)"``.

        Returns
        -------
        str
            The description.
        """
        return f"MPI ({self.workers or 'all'} workers)"


def make_backend(
    backend: str = "process",
    *,
    workers: int | None = None,
    threads=1,
    scheduler: str | None = None,
    executor: cf.Executor | None = None,
) -> Backend:
    """The backend of a name, or one wrapping a ready executor.

    Parameters
    ----------
    backend : str
        One of :data:`BACKENDS`.
    workers : int, optional
        Worker processes (default: one per core).
    threads : int or None
        Numba threads per worker (None: Numba's default).
    scheduler : str, optional
        ``tcp://HOST:PORT``: Dask on an existing cluster (with backend "dask" or "process").
    executor : concurrent.futures.Executor, optional
        A ready executor; the caller owns and closes it.

    Returns
    -------
    Backend
        Not started yet.

    Raises
    ------
    InputError
        An unknown backend, bad counts, or a scheduler with a backend other than Dask.
    """
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
