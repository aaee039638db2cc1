"""The one place that holds emorbit's Numba options.

Every kernel in :mod:`emorbit.kernels` is compiled with :func:`kernel`, so the options
below apply everywhere:

``cache=True``
    compiled machine code is stored next to the module (``__pycache__``) and loaded in
    later processes (~0.01 s instead of 1-3 s per kernel). Set ``EMORBIT_JIT_CACHE=0``
    to switch the disk cache off (for example on a read-only install). Numba re-checks a
    cached kernel only against its own file, not the kernels it inlines; importing this
    module therefore clears the cache when any kernel source changed (see
    :func:`_drop_stale_cache`).
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


#: the sources whose compiled code is cached: a kernel inlines its callees, and Numba
#: re-validates a cached kernel only against its own file's time stamp
_CACHED_SOURCES = ("kernels/*.py", "kernels/pointmass/*.py", "bench/limits.py")
_STAMP = "emorbit-kernel-sources.sha1"


def _drop_stale_cache() -> None:
    """Delete Numba's cache files in emorbit's ``__pycache__`` folders when any cached
    kernel source changed since they were written.

    Numba checks a cached kernel only against the time stamp of the file that defines it,
    so after an edit to ``gravity.py`` a cached ``pointmass`` kernel would still run the
    old ``g_em`` it inlined. A digest of all the sources above, kept beside the cache,
    catches that. Installs whose folders cannot be written are left alone (Numba then
    caches elsewhere, against files that only change on reinstall)."""
    import glob
    import hashlib

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    files = sorted(f for pattern in _CACHED_SOURCES for f in glob.glob(os.path.join(root, pattern)))
    digest = hashlib.sha1()
    for name in files:
        with open(name, "rb") as fh:
            digest.update(os.path.relpath(name, root).encode() + b"\0" + fh.read())
    stamp_path = os.path.join(root, "kernels", "__pycache__", _STAMP)
    try:
        with open(stamp_path) as fh:
            if fh.read().strip() == digest.hexdigest():
                return
    except OSError:
        pass
    try:
        for folder in {os.path.join(os.path.dirname(f), "__pycache__") for f in files}:
            for cached in glob.glob(os.path.join(folder, "*.nb[ic]")):
                try:
                    os.remove(cached)
                except FileNotFoundError:  # another process got there first
                    pass
        os.makedirs(os.path.dirname(stamp_path), exist_ok=True)
        tmp = f"{stamp_path}.{os.getpid()}"
        with open(tmp, "w") as fh:
            fh.write(digest.hexdigest())
        os.replace(tmp, stamp_path)
    except OSError:  # a read-only install
        pass


if cache_enabled():
    _drop_stale_cache()


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
