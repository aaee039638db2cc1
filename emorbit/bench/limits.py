"""The machine's throughput of packed divisions and square roots, measured with the same
Numba options as the kernels (``error_model="numpy"``: the loops vectorise), on data that
stays in the L1 cache. A kernel that does ``d`` divisions and ``s`` square roots per
particle-step cannot run faster than ``d t_div + s t_sqrt`` per particle-step on one core
when the divider is busy all the time; ``mix`` measures exactly such a loop (the kernel's
counts, independent operands), so overlap between the two is included.

The floor (:func:`floor`) is the least work an em particle-step can do on the ensemble
kernel's state: a block of :data:`~emorbit.kernels.pointmass.packed.BLOCK` points in the kernel's
layout (rows ``LD`` apart, in the L1 cache), its 2 square roots and 3 divisions, and the
compensated update of position and velocity (12 rows read and written); no predictor
series, Newton update or certificate. ``bound / floor`` is the most of the bound that any
kernel keeping that state can reach on the machine. The same loop without the compensations
(6 rows) is measured beside it.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import prange

from ..kernels.jit import kernel
from ..kernels.pointmass.packed import BLOCK, LD

__all__ = ["measure", "floor"]

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


@kernel(inline="always")
def _floor_kick(x0, x1, x2, v0, v1, v2, h, h2gm):
    """The floor's kick factor: the dot products, ``r0 = |x|``, the predicted ``r1 = |x + h
    v|`` and ``2 h GM / (r0 r1 (r0 + r1))`` with three independent divisions."""
    A = x0 * x0 + x1 * x1 + x2 * x2
    P = x0 * v0 + x1 * v1 + x2 * v2
    V = v0 * v0 + v1 * v1 + v2 * v2
    r0 = math.sqrt(A)
    r1 = math.sqrt(A + h * (2.0 * P + h * V))
    return (h2gm / r0) * ((1.0 / r1) * (1.0 / (r0 + r1)))


@kernel
def _floor(W, h, gm, compensated, reps):
    """``reps`` em-like steps of a block: per point the dot products, 2 square roots (``r0 =
    |x|`` and the predicted ``r1 = |x + h v|``), 3 divisions, independent of each other (the
    shortest dependency chain those counts allow), and the update of position x and velocity
    v with the kick ``-2 h GM x / (r0 r1 (r0 + r1))``, compensated (rows 6-11 hold the
    compensations) or plain. The orbits are real ones (first order in h), so the state stays
    finite."""
    hh = 0.5 * h
    h2gm = 2.0 * h * gm
    for _ in range(reps):
        if compensated:
            for i in range(BLOCK):
                x0, x1, x2 = W[i], W[LD + i], W[2 * LD + i]
                v0, v1, v2 = W[3 * LD + i], W[4 * LD + i], W[5 * LD + i]
                k = _floor_kick(x0, x1, x2, v0, v1, v2, h, h2gm)
                d0 = -k * x0 - W[9 * LD + i]
                d1 = -k * x1 - W[10 * LD + i]
                d2 = -k * x2 - W[11 * LD + i]
                t0, t1, t2 = v0 + d0, v1 + d1, v2 + d2
                W[9 * LD + i], W[10 * LD + i], W[11 * LD + i] = (t0 - v0) - d0, (t1 - v1) - d1, (t2 - v2) - d2
                W[3 * LD + i], W[4 * LD + i], W[5 * LD + i] = t0, t1, t2
                e0 = h * v0 + hh * d0 - W[6 * LD + i]
                e1 = h * v1 + hh * d1 - W[7 * LD + i]
                e2 = h * v2 + hh * d2 - W[8 * LD + i]
                s0, s1, s2 = x0 + e0, x1 + e1, x2 + e2
                W[6 * LD + i], W[7 * LD + i], W[8 * LD + i] = (s0 - x0) - e0, (s1 - x1) - e1, (s2 - x2) - e2
                W[i], W[LD + i], W[2 * LD + i] = s0, s1, s2
        else:
            for i in range(BLOCK):
                x0, x1, x2 = W[i], W[LD + i], W[2 * LD + i]
                v0, v1, v2 = W[3 * LD + i], W[4 * LD + i], W[5 * LD + i]
                k = _floor_kick(x0, x1, x2, v0, v1, v2, h, h2gm)
                d0, d1, d2 = -k * x0, -k * x1, -k * x2
                W[3 * LD + i], W[4 * LD + i], W[5 * LD + i] = v0 + d0, v1 + d1, v2 + d2
                W[i], W[LD + i], W[2 * LD + i] = (
                    x0 + (h * v0 + hh * d0),
                    x1 + (h * v1 + hh * d1),
                    x2 + (h * v2 + hh * d2),
                )


@kernel(parallel=True)
def _floor_parallel(W, h, gm, compensated, reps):
    """:func:`_floor` on every thread, each on its own block (``W`` is (threads, 12 LD))."""
    for t in prange(W.shape[0]):
        _floor(W[t], h, gm, compensated, reps)


def floor_block(seed: int = 0) -> np.ndarray:
    """The floor's state: a block of points on near-circular orbits in the kernel's layout.

    Parameters
    ----------
    seed : int
        Seed of numpy's default generator.

    Returns
    -------
    ndarray
        (12 LD,): rows of positions and velocities (GM = 1, radii 5-10), compensations zero.
    """
    rng = np.random.default_rng(seed)
    W = np.zeros(12 * LD)
    x = rng.uniform(-10.0, 10.0, (3, BLOCK))
    x *= rng.uniform(5.0, 10.0, BLOCK) / np.sqrt((x * x).sum(axis=0))
    # near-circular: the circular speed, normal to x, times 0.9-1.1
    n = np.cross(x.T, rng.normal(size=(BLOCK, 3))).T
    v = n / np.sqrt((n * n).sum(axis=0)) * rng.uniform(0.9, 1.1, BLOCK) / np.sqrt(np.sqrt((x * x).sum(axis=0)))
    for k in range(3):
        W[k * LD : k * LD + BLOCK] = x[k]
        W[(3 + k) * LD : (3 + k) * LD + BLOCK] = v[k]
    return W


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
    """The machine's packed division and square-root throughput, and the bounds it sets.

    Parameters
    ----------
    counts : dict
        {kernel name: (square roots, divisions) per particle-step}; each pair one of
        :data:`MIXES`.
    threads : int
        Threads of the all-threads measurement.
    seconds : float
        Length of one timed call, s.

    Returns
    -------
    dict
        ``divide_ns`` and ``sqrt_ns`` per element on one thread, and per kernel: its counts,
        ns per element of a loop with those counts on one thread and on ``threads``, and the
        bound in particle-steps per second each gives.

    Raises
    ------
    ValueError
        A pair of counts that no loop here measures.
    """
    rng = np.random.default_rng(0)
    a, b, c, d, e = (rng.uniform(1.0, 2.0, _N) for _ in range(5))
    out = np.zeros(_N)
    result = {
        "divide_ns": _best_ns(_divide, (a, b, out), _N, seconds),
        "sqrt_ns": _best_ns(_sqrt, (a, out), _N, seconds),
        "kernels": {},
    }
    big = [np.ascontiguousarray(np.tile(q, (threads, 1))) for q in (a, b, c, d, e)]
    big_out = np.zeros((threads, _N))
    mixes = {}  # kernels with the same counts share one measurement (their bounds must agree)
    for name, (nsqrt, ndiv) in counts.items():
        if (nsqrt, ndiv) not in MIXES:
            raise ValueError(f"no division / square-root loop with counts {(nsqrt, ndiv)}; known: {MIXES}")
        if (nsqrt, ndiv) not in mixes:
            mixes[nsqrt, ndiv] = (
                _best_ns(_mix, (a, b, c, d, e, out, nsqrt, ndiv), _N, seconds),
                _best_ns(_mix_parallel, (*big, big_out, nsqrt, ndiv), _N * threads, seconds),
            )
        one, all_ = mixes[nsqrt, ndiv]
        result["kernels"][name] = {
            "sqrts": nsqrt,
            "divisions": ndiv,
            "sum_ns": nsqrt * result["sqrt_ns"] + ndiv * result["divide_ns"],
            "mix_ns_1_thread": one,
            "mix_ns_all_threads": all_,
            "bound_per_s_1_thread": 1e9 / one,
            "bound_per_s_all_threads": 1e9 / all_,
        }
    return result


#: the time step of the floor's orbits (GM = 1, radii 5-10: periods 70-200, so 1400-4000
#: steps per orbit)
_FLOOR_H = 0.05


def floor(threads: int, seconds: float = 0.05) -> dict:
    """The floor: ns per particle-step of the least work an em step does on the kernel's state.

    Parameters
    ----------
    threads : int
        Threads of the all-threads measurement (each thread its own block).
    seconds : float
        Length of one timed call, s.

    Returns
    -------
    dict
        Its counts (2 square roots and 3 divisions: the em kernel's,
        :data:`~emorbit.kernels.pointmass.packed.EM_SQRTS` and ``EM_DIVISIONS``), and ns per
        particle-step compensated (12 rows) and plain (6 rows), on one thread and on all.
    """
    out = {"sqrts": 2, "divisions": 3, "rows_compensated": 12, "rows_plain": 6}
    for name, comp in (("compensated", True), ("plain", False)):
        one = floor_block()
        many = np.ascontiguousarray(np.tile(one, (threads, 1)))
        out[name] = {
            "ns_1_thread": _best_ns(_floor, (one, _FLOOR_H, 1.0, comp), BLOCK, seconds),
            "ns_all_threads": _best_ns(_floor_parallel, (many, _FLOOR_H, 1.0, comp), BLOCK * threads, seconds),
        }
    return out
