"""The one place that holds emorbit's Numba options.

Every kernel in :mod:`emorbit.kernels` is compiled with :func:`kernel`, so the options
below apply everywhere:

``cache=True``
    compiled machine code is stored on disk and loaded in later processes (~0.01 s instead
    of 1-3 s per kernel), in a per-user folder, not inside the installed package
    (:func:`cache_dir`: ``<user cache>/emorbit/numba/<install>``, one folder per install;
    where it cannot be written or Numba's internals differ, Numba's default applies).
    ``NUMBA_CACHE_DIR`` set: Numba's own rule applies. ``EMORBIT_JIT_CACHE=0``: no disk
    cache. Numba re-checks a cached kernel only against its own file, not the kernels it
    inlines; importing this module therefore clears the cache when any kernel source
    changed (see :func:`_drop_stale_cache`).
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

import glob
import hashlib
import os
import sys
import warnings

import numba
from numba.core.errors import NumbaExperimentalFeatureWarning

# the step kernels take an effect set's compiled functions as first-class function values
# (emorbit.kernels.effects.signatures), which Numba labels experimental: deliberate here
warnings.filterwarnings(
    "ignore", message=".*First-class function type feature is experimental", category=NumbaExperimentalFeatureWarning
)

__all__ = [
    "JIT_OPTIONS",
    "kernel",
    "cache_enabled",
    "cache_dir",
    "user_cache_dir",
    "cache_location",
    "cached_sources_digest",
]

#: the emorbit package folder
_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: the sources whose compiled code is cached: a kernel inlines its callees, and Numba
#: re-validates a cached kernel only against its own file
_CACHED_SOURCES = ("kernels/*.py", "kernels/pointmass/*.py", "kernels/effects/*.py", "bench/limits.py")
_STAMP = "emorbit-kernel-sources.sha1"


def cache_enabled() -> bool:
    """Whether compiled kernels are cached on disk (``EMORBIT_JIT_CACHE``, default on).

    Returns
    -------
    bool
        False where ``EMORBIT_JIT_CACHE`` is ``0``, ``false``, ``no`` or ``off``.
    """
    return os.environ.get("EMORBIT_JIT_CACHE", "1").strip().lower() not in {"0", "false", "no", "off"}


def user_cache_dir() -> str:
    """emorbit's per-user cache folder, as the platform names it.

    Returns
    -------
    str
        ``$XDG_CACHE_HOME/emorbit`` (default ``~/.cache/emorbit``) on Linux and other Unix
        systems, ``~/Library/Caches/emorbit`` on macOS, ``%LOCALAPPDATA%\\emorbit\\Cache``
        on Windows.
    """
    if sys.platform.startswith("win"):
        base = os.environ.get("LOCALAPPDATA") or os.path.join(os.path.expanduser("~"), "AppData", "Local")
        return os.path.join(base, "emorbit", "Cache")
    if sys.platform == "darwin":
        return os.path.join(os.path.expanduser("~"), "Library", "Caches", "emorbit")
    base = os.environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "emorbit")


def cache_dir() -> str:
    """The folder of this install's compiled kernels inside :func:`user_cache_dir`.

    Each install (a checkout, a virtual environment's ``site-packages``) has its own
    folder, named by a digest of the package's location, so two installs never share or
    clear each other's entries.

    Returns
    -------
    str
        ``<user cache>/emorbit/numba/<digest of the package folder>``; the kernels of
        ``emorbit/kernels/pointmass/`` are in its ``kernels/pointmass``.
    """
    where = os.path.realpath(_ROOT)
    return os.path.join(user_cache_dir(), "numba", hashlib.sha1(where.encode()).hexdigest()[:16])


def _inside(path: str, root: str) -> bool:
    try:
        return os.path.commonpath([os.path.realpath(path), root]) == root
    except ValueError:  # another drive
        return False


def _install_locator(folder: str) -> bool:
    """Put a cache locator for emorbit's own kernels first in Numba's list.

    It places the cache of a function defined under the package in ``folder`` and leaves
    every other function (and emorbit's, where ``NUMBA_CACHE_DIR`` is set) to Numba's own
    locators. False, and nothing changed, where Numba's internals are not as expected."""
    try:
        from numba.core import caching, config
    except ImportError:
        return False
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    locators = getattr(impl, "_locator_classes", None)
    mixin = getattr(caching, "_SourceFileBackedLocatorMixin", None)
    base = getattr(caching, "_CacheLocator", None)
    if not isinstance(locators, list) or mixin is None or base is None:
        return False
    root = os.path.realpath(_ROOT)

    class EmorbitCacheLocator(mixin, base):
        """The cache of an emorbit kernel: ``folder`` / its source folder within the package."""

        emorbit_folder = folder

        def __init__(self, py_func, py_file):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            sub = os.path.relpath(os.path.dirname(os.path.realpath(py_file)), root)
            self._cache_path = os.path.join(folder, sub)

        def get_cache_path(self):
            return self._cache_path

        @classmethod
        def from_function(cls, py_func, py_file):
            try:
                if getattr(config, "CACHE_DIR", "") or not _inside(py_file, root):
                    return None
                return super().from_function(py_func, py_file)
            except Exception:  # anything unexpected: Numba's own locators decide
                return None

    locators[:] = [c for c in locators if not hasattr(c, "emorbit_folder")]
    locators.insert(0, EmorbitCacheLocator)
    return True


def _redirect() -> str | None:
    """Send the cache of emorbit's kernels to :func:`cache_dir`; returns that folder, or
    None where Numba's own rule applies (``NUMBA_CACHE_DIR`` or Numba's locator classes
    set, the folder cannot be written, or Numba's internals differ)."""
    from numba.core import config

    if getattr(config, "CACHE_DIR", "") or getattr(config, "CACHE_LOCATOR_CLASSES", ""):
        return None
    folder = cache_dir()
    if not os.path.isabs(folder):
        return None
    try:
        import tempfile

        os.makedirs(folder, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return None
    return folder if _install_locator(folder) else None


def _cache_folders(dirs: list[str]) -> list[str]:
    """Where the cache of each source folder ``dirs`` (absolute) lives now."""
    if _LOCATION is not None:
        root = os.path.realpath(_ROOT)
        return [os.path.join(_LOCATION, os.path.relpath(os.path.realpath(d), root)) for d in dirs]
    from numba.core import caching, config

    if getattr(config, "CACHE_DIR", ""):
        try:
            sub = caching._CacheLocator.get_suitable_cache_subpath
            return [os.path.join(config.CACHE_DIR, sub(os.path.join(d, "jit.py"))) for d in dirs]
        except Exception:
            return []
    return [os.path.join(d, "__pycache__") for d in dirs]


def cache_location() -> str | None:
    """Where emorbit's compiled kernels are cached in this process.

    Returns
    -------
    str or None
        :func:`cache_dir` where the kernels are redirected there; Numba's folder for the
        kernels of ``emorbit/kernels/`` where ``NUMBA_CACHE_DIR`` is set or Numba's
        internals differ; None without a disk cache (``EMORBIT_JIT_CACHE=0``).
    """
    if not cache_enabled():
        return None
    if _LOCATION is not None:
        return _LOCATION
    folders = _cache_folders([os.path.join(_ROOT, "kernels")])
    return folders[0] if folders else None


def _cached_files() -> list[str]:
    return sorted(f for pattern in _CACHED_SOURCES for f in glob.glob(os.path.join(_ROOT, pattern)))


_DIGEST: list[str] = []


def cached_sources_digest() -> str:
    """A digest (hex) of every kernel source whose compiled code is cached: code compiled
    elsewhere that inlines kernels (an effect set's functions) is valid while it is the same.

    Returns
    -------
    str
        The SHA-1 of the sources' paths and contents, computed once per process.
    """
    if not _DIGEST:
        digest = hashlib.sha1()
        for name in _cached_files():
            with open(name, "rb") as fh:
                digest.update(os.path.relpath(name, _ROOT).encode() + b"\0" + fh.read())
        _DIGEST.append(digest.hexdigest())
    return _DIGEST[0]


def _drop_stale_cache() -> None:
    """Delete emorbit's cached kernels when any cached kernel source changed since they were
    written.

    Numba checks a cached kernel only against the file that defines it, so after an edit to
    ``gravity.py`` a cached ``pointmass`` kernel would still run the old ``g_em`` it
    inlined. A digest of all the sources above, kept beside the cache (in the folder of
    ``kernels/``), catches that. With the per-user folder, clearing also removes cache
    files that older versions left in the package's ``__pycache__`` folders. Folders that
    cannot be written are left alone."""
    files = _cached_files()
    digest = cached_sources_digest()
    dirs = sorted({os.path.dirname(f) for f in files})
    folders = _cache_folders(dirs)
    if not folders:
        return
    stamp_path = os.path.join(folders[dirs.index(os.path.join(_ROOT, "kernels"))], _STAMP)
    try:
        with open(stamp_path) as fh:
            if fh.readline().strip() == digest:
                return
    except OSError:
        pass
    if _LOCATION is not None:  # left inside the package by older versions: never read now
        folders = folders + [os.path.join(d, "__pycache__") for d in dirs]
    for folder in folders:
        for cached in glob.glob(os.path.join(folder, "*.nb[ic]")):
            try:
                os.remove(cached)
            except OSError:  # gone already (another process), or a read-only folder
                pass
    if _LOCATION is not None:
        try:
            os.remove(os.path.join(_ROOT, "kernels", "__pycache__", _STAMP))
        except OSError:
            pass
    try:
        os.makedirs(os.path.dirname(stamp_path), exist_ok=True)
        tmp = f"{stamp_path}.{os.getpid()}"
        with open(tmp, "w") as fh:
            fh.write(f"{digest}\n{os.path.realpath(_ROOT)}\n")
        os.replace(tmp, stamp_path)
    except OSError:  # a read-only folder
        pass


#: the per-user folder holding emorbit's compiled kernels, or None (Numba's rule, or no disk cache)
_LOCATION = _redirect() if cache_enabled() else None
if cache_enabled():
    _drop_stale_cache()


JIT_OPTIONS = {
    "cache": cache_enabled(),
    "nogil": True,
    "fastmath": False,
    "error_model": "numpy",
}


def kernel(func=None, **overrides):
    """Compile ``func`` with :data:`JIT_OPTIONS` (``@kernel`` or ``@kernel(parallel=True)``).

    Parameters
    ----------
    func : callable, optional
        The Python function; omitted, a decorator is returned.
    **overrides
        Numba options that replace those of :data:`JIT_OPTIONS` (e.g. ``parallel=True``).

    Returns
    -------
    numba.core.registry.CPUDispatcher or callable
        The compiled function, or a decorator.
    """
    options = {**JIT_OPTIONS, **overrides}
    if func is None:
        return lambda f: numba.njit(**options)(f)
    return numba.njit(**options)(func)
