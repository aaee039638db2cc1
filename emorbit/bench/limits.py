"""The machine's throughput of packed divisions and square roots, measured with the same
Numba options as the kernels (``error_model="numpy"``: the loops vectorise), on data that
stays in the L1 cache. A kernel that does ``d`` divisions and ``s`` square roots per
particle-step cannot run faster than ``d t_div + s t_sqrt`` per particle-step on one core
when the divider is busy all the time; ``mix`` measures exactly such a loop (the kernel's
counts, independent operands), so overlap between the two is included.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import prange

from ..kernels.jit import kernel

__all__ = ["measure"]

_N = 1024  # 8 KiB per array: L1-resident


@kernel
def _divide(a, b, out, reps):
    n = a.shape[0]
    for r in range(reps):
        for i in range(n):
            out[i] = a[i] / b[i]
        b[r % n] += 0.0  # keeps the loop from being hoisted


@kernel
def _sqrt(a, out, reps):
    n = a.shape[0]
    for r in range(reps):
        for i in range(n):
            out[i] = math.sqrt(a[i])
        a[r % n] += 0.0


#: the operation counts _mix knows: (square roots, divisions) per element
MIXES = ((2, 3), (1, 1))


@kernel
def _mix(a, b, c, d, e, out, nsqrt, ndiv, reps):
    """Per element: 2 square roots and 3 divisions (the em kernel's counts, either
    roundoff) or 1 and 1 (leapfrog's), on independent operands."""
    n = a.shape[0]
    for r in range(reps):
        if nsqrt == 2:
            for i in range(n):
                out[i] = (math.sqrt(a[i]) + math.sqrt(b[i])) + ((c[i] / a[i] + d[i] / b[i]) + e[i] / c[i])
        else:
            for i in range(n):
                out[i] = math.sqrt(a[i]) + c[i] / b[i]
        a[r % n] += 0.0


@kernel(parallel=True)
def _mix_parallel(a, b, c, d, e, out, nsqrt, ndiv, reps):
    """:func:`_mix` on every thread, each on its own copy (a, ... are (threads, n))."""
    for t in prange(a.shape[0]):
        _mix(a[t], b[t], c[t], d[t], e[t], out[t], nsqrt, ndiv, reps)


def _best_ns(fn, args, elements: int, seconds: float) -> float:
    """Nanoseconds per element, the fastest of a few calls of about ``seconds`` each."""
    fn(*args, 2)
    reps = 16
    while True:
        t = time.perf_counter()
        fn(*args, reps)
        t = time.perf_counter() - t
        if t > seconds / 4:
            break
        reps *= 4
    reps = max(1, int(reps * seconds / t))
    best = math.inf
    for _ in range(5):
        t = time.perf_counter()
        fn(*args, reps)
        best = min(best, time.perf_counter() - t)
    return 1e9 * best / (reps * elements)


def measure(counts: dict, threads: int, seconds: float = 0.05) -> dict:
    """ns per packed division and square root (one thread); ns per element of loops with a
    kernel's counts ``{name: (square roots, divisions)}`` on one thread and on ``threads``."""
    rng = np.random.default_rng(0)
    a, b, c, d, e = (rng.uniform(1.0, 2.0, _N) for _ in range(5))
    out = np.zeros(_N)
    result = {"divide_ns": _best_ns(_divide, (a, b, out), _N, seconds),
              "sqrt_ns": _best_ns(_sqrt, (a, out), _N, seconds), "kernels": {}}
    big = [np.ascontiguousarray(np.tile(q, (threads, 1))) for q in (a, b, c, d, e)]
    big_out = np.zeros((threads, _N))
    mixes = {}  # kernels with the same counts share one measurement (their bounds must agree)
    for name, (nsqrt, ndiv) in counts.items():
        if (nsqrt, ndiv) not in MIXES:
            raise ValueError(f"no division / square-root loop with counts {(nsqrt, ndiv)}; known: {MIXES}")
        if (nsqrt, ndiv) not in mixes:
            mixes[nsqrt, ndiv] = (_best_ns(_mix, (a, b, c, d, e, out, nsqrt, ndiv), _N, seconds),
                                  _best_ns(_mix_parallel, (*big, big_out, nsqrt, ndiv), _N * threads, seconds))
        one, all_ = mixes[nsqrt, ndiv]
        result["kernels"][name] = {
            "sqrts": nsqrt, "divisions": ndiv,
            "sum_ns": nsqrt * result["sqrt_ns"] + ndiv * result["divide_ns"],
            "mix_ns_1_thread": one, "mix_ns_all_threads": all_,
            "bound_per_s_1_thread": 1e9 / one, "bound_per_s_all_threads": 1e9 / all_,
        }
    return result
