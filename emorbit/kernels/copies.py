"""Copies between float64 arrays of one, two and three dimensions, as plain loops.

The step kernels copy whole arrays (a step's start state kept for a retry, records) with these
instead of slice assignment (``a[:, :] = b``). Numba compiles every slice assignment between
arrays through its broadcasting setitem, with an error message of the shapes formatted in
compiled code: seconds of CPU for the first one in a process and a fraction of a second for
each further site, where these compile once per array layout. The copy is exact either way.

Arrays: ``dst`` and ``src`` of the same shape, any layout (rows of a C array, sub-arrays).
Unlike slice assignment, nothing checks the shapes: every caller copies between arrays it
allocated with one shape (a state and its saved copy, a record row and the state).
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
