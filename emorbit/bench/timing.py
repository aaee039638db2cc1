"""How ``emorbit bench`` times: calibrated calls, interleaved repeats, medians, paired ratios.

Every engine gets a warm-up call (Numba's first call, a peer's first solve), then calls
calibrated to last about ``cfg.repeat_s``; the engines of one comparison run interleaved,
repeat by repeat, so that load from other processes on a shared machine hits all of them.
A time is the median over repeats, in microseconds per step, wall-clock and CPU (process)
time; a ratio is the median of the per-repeat ratios (:func:`paired_ratio`). Each result
also records the machine (:func:`machine`) and the load average (:func:`loadavg`).
"""

from __future__ import annotations

import os
import platform
import time

import numpy as np

__all__ = [
    "CLOCK",
    "THREAD_VARIABLES",
    "clock",
    "since",
    "calibrate",
    "timed",
    "best_cpu",
    "paired_ratio",
    "loadavg",
    "machine",
    "package_version",
]

#: the time that verdicts, ratios and fits use: CPU (process) time per step. On a shared machine
#: wall-clock time also counts the time the process waits for a core; for these single-threaded
#: engines CPU and wall time agree on an idle machine. Both are recorded.
CLOCK = "cpu_us_per_step"
#: the key of the per-repeat CPU samples (us per step) in what :func:`timed` returns
CPU = "cpu_samples_us"
#: environment variables that set BLAS, OpenMP and Numba threads: recorded with every result,
#: because threaded BLAS on a busy machine slows the rigid-body rows down
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


def clock():
    """The current wall and CPU clocks, to pass to :func:`since`.

    Returns
    -------
    tuple of float
        (``time.perf_counter()``, ``time.process_time()``), s.
    """
    return time.perf_counter(), time.process_time()


def since(start) -> tuple:
    """Wall and CPU seconds since a :func:`clock` reading.

    Parameters
    ----------
    start : tuple
        What :func:`clock` returned.

    Returns
    -------
    tuple of float
        (wall, CPU) seconds.
    """
    wall, cpu = clock()
    return wall - start[0], cpu - start[1]


def calibrate(step_runner, repeat_s: float, min_steps: int = 20, max_steps: int = 2_000_000) -> int:
    """Steps per timed call, so that a call lasts about ``repeat_s``.

    After a warm-up call, n grows until a call takes a quarter of ``repeat_s`` (so that a
    fixed cost per call does not inflate the estimate), then is scaled to ``repeat_s``.

    Parameters
    ----------
    step_runner : callable
        ``step_runner(n) -> (wall, CPU)`` seconds for n steps.
    repeat_s : float
        Wall time aimed at per call, s.
    min_steps, max_steps : int
        Bounds on the result.

    Returns
    -------
    int
        Steps per call.
    """
    n = min_steps
    step_runner(n)  # warm-up: Numba's first call, caches, a peer's first solve
    while True:
        t = step_runner(n)[0]
        if t >= repeat_s / 4 or n >= max_steps:
            break
        n = int(min(max_steps, n * min(100.0, max(2.0, repeat_s / 4 / max(t, 1e-9)))))
    return int(min(max_steps, max(min_steps, n * repeat_s / max(t, 1e-9))))


def best_cpu(go, setup=None):
    """``(go's result, CPU seconds)`` of ``go(setup())`` (``go()`` without a set-up), the set-up
    not timed; the best of three where the first run takes under 50 ms.

    Parameters
    ----------
    go : callable
        The run: ``go(state)``, or ``go()`` without ``setup``.
    setup : callable, optional
        Builds a fresh state for each run.

    Returns
    -------
    tuple
        The last run's result and the least CPU time (``time.process_time``), s.
    """
    best, out = float("inf"), None
    for k in range(3):
        state = setup() if setup is not None else None
        t = time.process_time()
        out = go(state) if setup is not None else go()
        best = min(best, time.process_time() - t)
        if k == 0 and best > 0.05:
            break
    return out, best


def timed(runners: dict, cfg, optional=()) -> dict:
    """Time several engines interleaved, repeat by repeat.

    Parameters
    ----------
    runners : dict
        {name: ``step_runner(n) -> (wall, CPU)`` seconds}.
    cfg : Config
        ``repeat_s`` (length of a call) and ``repeats``.
    optional : sequence of str
        Runners (peers) that may fail: one that raises is dropped and reported as
        ``{"status": "skipped: ..."}``; any other runner's exception propagates.

    Returns
    -------
    dict
        {name: stats}: ``us_per_step`` (median wall clock), ``us_min``, ``cpu_us_per_step``
        (median CPU time), ``steps`` per call, ``repeats`` and the samples, in us per step.
    """
    steps, out = {}, {}
    for name, fn in runners.items():
        try:
            steps[name] = calibrate(fn, cfg.repeat_s)
        except Exception as exc:  # noqa: BLE001
            if name not in optional:
                raise
            out[name] = {"status": f"skipped: {type(exc).__name__}: {exc}"}
    samples = {name: [] for name in steps}
    for _ in range(cfg.repeats):
        for name in list(samples):
            try:
                samples[name].append(np.array(runners[name](steps[name])) / steps[name] * 1e6)
            except Exception as exc:  # noqa: BLE001
                if name not in optional:
                    raise
                out[name] = {"status": f"skipped: {type(exc).__name__}: {exc}"}
                del samples[name]
    for name, us in samples.items():
        wall, cpu = np.array(us).T
        out[name] = {
            "us_per_step": float(np.median(wall)),
            "us_min": float(wall.min()),
            "cpu_us_per_step": float(np.median(cpu)),
            "steps": steps[name],
            "repeats": len(us),
            "samples_us": [round(float(x), 4) for x in wall],
            "cpu_samples_us": [round(float(x), 4) for x in cpu],
        }
    return out


def paired_ratio(a: dict, b: dict, key: str = "cpu_samples_us") -> float:
    """The median over interleaved repeats of a's time over b's.

    Parameters
    ----------
    a, b : dict
        Stats of :func:`timed` from the same call.
    key : str
        The samples to compare (CPU time by default; ``"samples_us"``: wall clock).

    Returns
    -------
    float
        The ratio.
    """
    return float(np.median(np.array(a[key]) / np.array(b[key])))


def loadavg():
    """The load averages of the machine.

    Returns
    -------
    list of float or None
        The 1-, 5- and 15-minute load averages, rounded; None where the OS has none.
    """
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover - not on Linux
        return None


def machine() -> dict:
    """The machine the bench runs on.

    Returns
    -------
    dict
        ``cpu`` (model), ``cores``, ``simd`` (the widest of avx512f, avx2, avx),
        ``python``, ``platform`` and ``thread_variables`` (those of :data:`THREAD_VARIABLES`
        that are set).
    """
    cpu, flags = platform.processor(), set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() == "model name":
                    cpu = value.strip()
                elif key.strip() == "flags":
                    flags = set(value.split())
                    break
    except OSError:  # pragma: no cover - not on Linux
        pass
    simd = next((f for f in ("avx512f", "avx2", "avx") if f in flags), "")
    threads = {k: os.environ[k] for k in THREAD_VARIABLES if k in os.environ}
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "simd": simd,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "thread_variables": threads,
    }


def package_version(dist: str):
    """The installed version of a distribution.

    Parameters
    ----------
    dist : str
        The distribution's name.

    Returns
    -------
    str or None
        Its version, or None if it is not installed.
    """
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(dist)
    except PackageNotFoundError:
        return None
