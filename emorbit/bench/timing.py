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
    "paired_ratio",
    "loadavg",
    "machine",
    "package_version",
]

#: environment variables that set BLAS / OpenMP threads: recorded, because the volume kernel's
#: 10 x N block product goes through BLAS, and threaded OpenBLAS on a busy 2-core machine made
#: the 10,000-point row about 7x slower (README, "What rigid bodies cost")
#: the time that verdicts, ratios and fits use: CPU (process) time per step. On a shared machine
#: wall-clock time also counts the time the process waits for a core; for these single-threaded
#: engines CPU and wall time agree on an idle machine. Both are recorded.
CLOCK = "cpu_us_per_step"
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


def clock():
    return time.perf_counter(), time.process_time()


def since(start) -> tuple:
    """(wall, CPU) seconds since ``start = clock()``."""
    wall, cpu = clock()
    return wall - start[0], cpu - start[1]


def calibrate(step_runner, repeat_s: float, min_steps: int = 20, max_steps: int = 2_000_000) -> int:
    """Steps per timed call of ``step_runner(n) -> (wall, CPU) seconds for n steps``, after a warm-up call:
    n grows until a call takes a quarter of ``repeat_s`` (so a fixed cost per call does not
    inflate the estimate), then is set so that a call takes about ``repeat_s``."""
    n = min_steps
    step_runner(n)  # warm-up: Numba's first call, caches, a peer's first solve
    while True:
        t = step_runner(n)[0]
        if t >= repeat_s / 4 or n >= max_steps:
            break
        n = int(min(max_steps, n * min(100.0, max(2.0, repeat_s / 4 / max(t, 1e-9)))))
    return int(min(max_steps, max(min_steps, n * repeat_s / max(t, 1e-9))))


def timed(runners: dict, cfg, optional=()) -> dict:
    """Time several engines interleaved: {name: stats}. ``runners`` maps a name to
    ``step_runner(n) -> (wall, CPU) seconds``; a runner named in ``optional`` (a peer) that
    raises is dropped and reported as ``{"status": "skipped: ..."}``. Stats: median and
    minimum wall-clock us per step, median CPU (process) us per step, and the samples."""
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
    """Median over interleaved repeats of a's time / b's time (CPU time by default)."""
    return float(np.median(np.array(a[key]) / np.array(b[key])))


def loadavg():
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover - not on Linux
        return None


def machine() -> dict:
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
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(dist)
    except PackageNotFoundError:
        return None
