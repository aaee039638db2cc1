"""The one place that holds emorbit's Numba options.

Every kernel in :mod:`emorbit.kernels` is compiled with :func:`kernel`, so the options
below apply everywhere:

``cache=True``
    compiled machine code is stored next to the module (``__pycache__``) and loaded in
    later processes (~0.01 s instead of 1-3 s per kernel). Set ``EMORBIT_JIT_CACHE=0``
    to switch the disk cache off (for example on a read-only install).
``fastmath=False``
    compensated (Kahan) summation and the exact energy balance rely on IEEE rounding; fast
    math would let LLVM re-associate ``(t - s) - y`` to zero.
``error_model="numpy"``
    a division by zero gives inf/nan instead of raising, so divisions carry no zero test
    and loops can vectorise. The kernels guard the only singularity (a point at the
    centre) themselves and report it as a failure code.
``nogil=True``
    kernels release the GIL, so threads can run them side by side.

Kernels must be plain functions of float64 arrays and scalars: functions passed as
arguments, closures and jitclasses are not disk-cacheable in Numba (they recompile in
every process), so each method has its own explicit kernel.
"""

from __future__ import annotations

import os

import numba

__all__ = ["JIT_OPTIONS", "kernel", "cache_enabled"]


def cache_enabled() -> bool:
    """Whether compiled kernels are cached on disk (``EMORBIT_JIT_CACHE``, default on)."""
    return os.environ.get("EMORBIT_JIT_CACHE", "1").strip().lower() not in {"0", "false", "no", "off"}


JIT_OPTIONS = {
    "cache": cache_enabled(),
    "nogil": True,
    "fastmath": False,
    "error_model": "numpy",
}


def kernel(func=None, **overrides):
    """Compile ``func`` with :data:`JIT_OPTIONS` (``@kernel`` or ``@kernel(parallel=True)``)."""
    options = {**JIT_OPTIONS, **overrides}
    if func is None:
        return lambda f: numba.njit(**options)(f)
    return numba.njit(**options)(func)
