"""Copies between float64 arrays of one, two and three dimensions, as plain loops.

The step kernels copy whole arrays (a step's start state kept for a retry, records) with these
instead of slice assignment (``a[:, :] = b``). Numba compiles every slice assignment between
arrays through its broadcasting setitem, with an error message of the shapes formatted in
compiled code: the first one in a process costs about 5 s of CPU to compile and each further
site about 0.2 s (``a[:, :] = b`` and ``b[:, :] = a`` on (3, 4) arrays, Numba 0.61; on 2 cores
of an AMD EPYC), against about 0.3 s for one loop of these. The copy is exact either way.

Arrays: ``dst`` and ``src`` of the same shape, any layout (rows of a C array, sub-arrays);
the shapes are the caller's to match (no check, as for the loops they replace).
"""

from __future__ import annotations

from .jit import kernel

__all__ = ["copy1", "copy2", "copy3"]


@kernel
def copy1(dst, src):
    """``dst[i] = src[i]`` for every i."""
    for i in range(dst.shape[0]):
        dst[i] = src[i]


@kernel
def copy2(dst, src):
    """``dst[i, j] = src[i, j]`` for every i, j."""
    for i in range(dst.shape[0]):
        for j in range(dst.shape[1]):
            dst[i, j] = src[i, j]


@kernel
def copy3(dst, src):
    """``dst[i, j, k] = src[i, j, k]`` for every i, j, k."""
    for i in range(dst.shape[0]):
        for j in range(dst.shape[1]):
            for k in range(dst.shape[2]):
                dst[i, j, k] = src[i, j, k]
