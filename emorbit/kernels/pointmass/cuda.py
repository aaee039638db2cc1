"""CUDA kernels for point-mass ensembles: the CPU's own per-point steps on the GPU.

One GPU thread advances one point through a whole chunk (``nrec * every`` composed steps),
exactly as :func:`~.chunk._run_point` does on the CPU for a point taken alone (the packed
kernels of :mod:`.packed` give the same bits; tests/test_ensemble.py). The device code is
not a second copy of the algorithm: :func:`_compile` takes the Python functions behind those
CPU kernels (``_run_point`` and every kernel it calls, found by following the names each
function uses, across modules: the em root solve of :mod:`.roots`, the point steps of
:mod:`.point_step`, the reference kernel's finish and Newton, the compensated sums, the
gravity helpers) and compiles them again with ``numba.cuda.jit(device=True)``, their calls
re-pointed at the device versions, and ``eft.fma`` at ``cuda.fma``. Each thread calls
``_run_point`` on its own column of the (3, n) arrays, so a point's result does not depend
on the others.

Rounding. NVVM contracts a multiply and an add into one fused multiply-add by default; the
kernels here are compiled with its ``-fma=0`` (:func:`_nvvm_fma`), so every product and sum
is rounded as on the CPU (division and square root are IEEE-rounded on both) and the GPU
gives the CPU's results: states, records, iteration counts and failures, for em at orders 2
and 4 (also where Newton fails), midpoint and leapfrog (tests/test_cuda.py; on an NVIDIA H100
with numba-cuda 0.30.4). ``chunk(..., contract=True)`` compiles with NVVM's default, which
differs from the CPU at round-off (the states by up to 4e-15 relative after 12 steps; at huge
steps a different set of points can fail). On numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``,
which runs the device code as Python with IEEE doubles) the results equal the CPU kernels
bit for bit as well (the tests require it).

Use: :func:`chunk` has the arguments of the CPU chunk kernels plus a method code and runs
on the device, copying the arrays there and back; :func:`device_problem` says why the kernels
cannot run (numba.cuda missing, no device), and :func:`chunk` raises a RuntimeError with it.
``Simulation`` does not call :func:`chunk`: it keeps the state on the device across chunks
(:class:`.cuda_resident.DeviceEnsemble`, the same device functions), since copying the state in
and the records out on every call ran at 3 % of the kernel's throughput (1e6 points, H100).
"""

from __future__ import annotations

import contextlib
import inspect
import math
import types
from fractions import Fraction

import numpy as np

from .. import eft
from ..codes import METHOD_EM, METHOD_EM_PLAIN, METHOD_LEAPFROG, METHOD_MIDPOINT
from .chunk import _run_point

__all__ = ["CODES", "THREADS_PER_BLOCK", "available", "device_problem", "chunk"]

#: the method codes that have a CUDA kernel
CODES = (METHOD_EM, METHOD_EM_PLAIN, METHOD_MIDPOINT, METHOD_LEAPFROG)
#: threads per block (one point each); a multiple of the warp size
THREADS_PER_BLOCK = 128

#: (cuda, kernels) per ``contract`` value; the device functions, by Python function
_compiled: dict = {}
_devices: dict = {}


def _numpy_problem(numpy_version: str, numba_cuda_version: str | None) -> str | None:
    """Why this NumPy breaks the CUDA target's compiler, or None: numba-cuda 0.30.4 and older
    call ``numpy.row_stack``, which NumPy 2.5 removed, and then no kernel compiles
    (``AttributeError: module 'numpy' has no attribute 'row_stack'``)."""

    def version(text):
        return tuple(int(p) for p in text.split("+")[0].split(".")[:3] if p.isdigit())

    if numba_cuda_version is None or version(numpy_version)[:2] < (2, 5):
        return None
    if version(numba_cuda_version) > (0, 30, 4):
        return None
    return (
        f"numba-cuda {numba_cuda_version} cannot compile kernels with NumPy {numpy_version} (it calls "
        "numpy.row_stack, removed in NumPy 2.5): pip install 'numpy<2.5' (the gpu extra pins it)"
    )


def device_problem() -> str | None:
    """Why the kernels cannot run here (numba.cuda missing, a NumPy its compiler cannot use,
    or no device), or None when a CUDA device (or numba's CUDA simulator) is ready."""
    try:
        from numba import cuda
    except ImportError as exc:  # a Numba without its CUDA target
        return f"numba.cuda cannot be imported ({exc}); pip install numba-cuda"
    from importlib import metadata

    try:
        numba_cuda = metadata.version("numba-cuda")
    except metadata.PackageNotFoundError:  # numba's own CUDA target (the simulator)
        numba_cuda = None
    problem = _numpy_problem(np.__version__, numba_cuda)
    if problem is not None:
        return problem
    if not cuda.is_available():
        return (
            "no CUDA device: numba.cuda found no usable NVIDIA GPU and driver on this machine; run on the CPU "
            "(device 'cpu'), or on a machine with an NVIDIA GPU (pip install 'emorbit[gpu]' for the numba-cuda "
            "target)"
        )
    return None


def available() -> bool:
    """Whether a CUDA device (or numba's CUDA simulator) can run the kernels."""
    return device_problem() is None


def _require_device():
    """The numba.cuda module; a RuntimeError naming :func:`device_problem` when it cannot run."""
    problem = device_problem()
    if problem is not None:
        raise RuntimeError(problem)
    from numba import cuda

    return cuda


def _point_kernel(method: int, name: str):
    """The kernel of one method: one thread per point, :func:`~.chunk._run_point` on
    column i. ``method`` is a constant of the closure, so NVVM drops the other methods."""

    def kernel(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail):
        i = cuda.grid(1)  # noqa: F821 - compiled by _compile with cuda and the device functions in its globals
        if i < x.shape[1]:
            _run_point(
                method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, i
            )

    kernel.__name__ = kernel.__qualname__ = f"kernel_{name}"
    return kernel


#: method code -> the kernel's Python function
_KERNELS = {
    code: _point_kernel(code, name)
    for code, name in (
        (METHOD_EM, "em"),
        (METHOD_EM_PLAIN, "em_plain"),
        (METHOD_MIDPOINT, "midpoint"),
        (METHOD_LEAPFROG, "leapfrog"),
    )
}


def _fma(a, b, c):
    """The device's fused multiply-add (the CPU kernels' :func:`~.eft.fma`)."""
    return cuda.fma(a, b, c)  # noqa: F821 - compiled by _compile with cuda in its globals


def _fma_exact(a, b, c):
    """``a b + c`` rounded once, in exact rational arithmetic: the fused multiply-add of
    Numba's CUDA simulator (which runs device functions as Python and has no ``cuda.fma``)."""
    if not (abs(a) < math.inf and abs(b) < math.inf and abs(c) < math.inf):
        return np.float64(a) * np.float64(b) + np.float64(c)  # inf or nan, as the hardware gives
    return np.float64(Fraction(float(a)) * Fraction(float(b)) + Fraction(float(c)))


class _SimulatorMath:
    """``math`` for device code on the simulator: square roots as NumPy float64, so that a
    division by zero or the root of a negative number gives inf or nan, as on the GPU and in
    the CPU kernels (``error_model="numpy"``), instead of a Python exception."""

    sqrt = staticmethod(np.sqrt)

    def __getattr__(self, name):
        return getattr(math, name)


def _simulator() -> bool:
    """Whether numba.cuda is numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``)."""
    from numba import config

    return bool(config.ENABLE_CUDASIM)


def _is_kernel(value) -> bool:
    """Whether ``value`` is one of emorbit's CPU kernels (a Numba dispatcher of a Python function)."""
    return callable(value) and hasattr(value, "py_func") and hasattr(value, "targetoptions")


def _rebind(f, cuda, devices: dict):
    """``f`` (a Python function) with every CPU kernel it names (and ``eft.fma``) replaced
    by its device version, compiled on first use into ``devices`` (keyed by the Python
    function); ``cuda`` joins its globals."""
    scope = dict(f.__globals__)
    scope["cuda"] = cuda
    # A warning raised in a function inserts __warningregistry__ into its globals. On the
    # simulator every device call iterates its function's globals (numba swaps its cuda
    # module in), and a point dividing by zero in one simulated thread while another
    # iterates can make that "dictionary changed size during iteration"; so the key is
    # there from the start and no launch changes the size of a scope.
    scope.setdefault("__warningregistry__", {})
    if _simulator() and "math" in scope:  # the simulator runs the device code as Python
        scope["math"] = _SimulatorMath()
    for name in f.__code__.co_names:
        value = f.__globals__.get(name)
        if value is eft.fma:
            scope[name] = devices["fma"]
        elif _is_kernel(value):
            scope[name] = _device(value.py_func, cuda, devices)
    clone = types.FunctionType(f.__code__, scope, f.__name__, f.__defaults__, f.__closure__)
    clone.__qualname__ = f"cuda.{f.__qualname__}"
    clone.__doc__ = f.__doc__
    return clone


def _device(f, cuda, devices: dict):
    """The device function compiled from the Python function ``f`` of a CPU kernel."""
    if f not in devices:
        devices[f] = cuda.jit(device=True)(_rebind(f, cuda, devices))
    return devices[f]


@contextlib.contextmanager
def _nvvm_fma(contract: bool):
    """Compilations inside pass NVVM's ``-fma`` option: ``-fma=0`` (no contraction) unless
    ``contract``. numba-cuda's ``cuda.jit`` has no argument for it (``fastmath`` would also
    approximate division and square root), so this wraps its ``nvvm.compile_ir`` while a
    kernel is launched: its first launch compiles it, later launches find it compiled. The
    kernels compiled so are also compiled without link-time optimisation (``lto=False``):
    with it, nvJitLink compiles NVVM's intermediate code again and contracts by default
    (measured on an H100 with numba-cuda 0.30.4: the same bits with and without ``-fma=0``).
    On the simulator (no NVVM) it does nothing."""
    try:
        from numba.cuda.cudadrv import nvvm

        original = nvvm.compile_ir
    except (ImportError, AttributeError):
        yield
        return
    if contract:
        yield
        return

    def compile_ir(llvmir, **options):
        options["fma"] = False
        return original(llvmir, **options)

    nvvm.compile_ir = compile_ir
    try:
        yield
    finally:
        nvvm.compile_ir = original


class _Kernel:
    """A compiled CUDA kernel launched as ``kernel[blocks, threads](*args)``, its
    multiply-adds contracted into fused ones or not (see :func:`_nvvm_fma`)."""

    def __init__(self, dispatcher, contract: bool):
        self.dispatcher, self.contract = dispatcher, contract

    def __getitem__(self, config):
        launch = self.dispatcher[config]

        def run(*args):
            with _nvvm_fma(self.contract):
                launch(*args)

        return run


def _compile(contract: bool = False):
    """Compile the device functions (from the CPU kernels' Python functions) once per
    process and the kernels once per ``contract`` value; returns (cuda, {method code:
    kernel}). ``contract=False`` (what :func:`chunk` uses) compiles with NVVM's ``-fma=0``,
    so that every product and sum is rounded as on the CPU."""
    contract = bool(contract)
    if contract in _compiled:
        return _compiled[contract]
    cuda = _require_device()
    if not _devices:
        fma = _fma_exact if _simulator() else _fma
        _devices["fma"] = cuda.jit(device=True)(_rebind(fma, cuda, _devices))
    options = {}
    if not contract and "lto" in inspect.signature(cuda.jit).parameters:
        # link-time optimisation hands NVVM's output to nvJitLink, which contracts again
        options["lto"] = False
    kernels = {code: _Kernel(cuda.jit(_rebind(f, cuda, _devices), **options), contract) for code, f in _KERNELS.items()}
    _compiled[contract] = (cuda, kernels)
    return _compiled[contract]


def chunk(
    method,
    x,
    v,
    cx,
    cv,
    gm,
    center,
    dt,
    gammas,
    every,
    nrec,
    max_iter,
    rec_x,
    rec_v,
    rec_iters,
    fail,
    threads_per_block: int = THREADS_PER_BLOCK,
    contract: bool = False,
) -> None:
    """Advance every point ``nrec * every`` composed steps on the GPU.

    ``method`` is a code of :data:`CODES`; the other arguments are those of
    :func:`~.reference.implicit_chunk` (host arrays, updated in place: ``x, v, cx, cv``
    and the records ``rec_x, rec_v, rec_iters, fail``, which the caller pre-fills with -1).
    ``contract=True`` lets NVVM fuse multiply-adds (its default; see the module notes).
    """
    if method not in _KERNELS:
        raise ValueError(f"no CUDA kernel for method code {method!r}")
    cuda, kernels = _compile(contract)
    n = x.shape[1]
    if n == 0 or nrec == 0:
        return
    host = (x, v, cx, cv, rec_x, rec_v, rec_iters, fail)
    dev = [cuda.to_device(np.ascontiguousarray(a)) for a in host]
    d_center = cuda.to_device(np.ascontiguousarray(center, dtype=np.float64))
    d_gammas = cuda.to_device(np.ascontiguousarray(gammas, dtype=np.float64))
    blocks = (n + threads_per_block - 1) // threads_per_block
    dx, dv, dcx, dcv, drx, drv, dri, dfail = dev
    kernels[method][blocks, threads_per_block](
        dx,
        dv,
        dcx,
        dcv,
        np.float64(gm),
        d_center,
        np.float64(dt),
        d_gammas,
        int(every),
        int(nrec),
        int(max_iter),
        drx,
        drv,
        dri,
        dfail,
    )
    for h, d in zip(host, dev):
        h[...] = d.copy_to_host()
