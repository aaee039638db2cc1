"""CUDA kernels for point-mass ensembles: the reference steps of :mod:`.pointmass` on the GPU.

One GPU thread advances one point through a whole chunk (``nrec * every`` composed steps),
exactly as one iteration of the point loop in :func:`~.pointmass.implicit_chunk` (em,
midpoint) or :func:`~.pointmass.leapfrog_chunk` does on the CPU. The device code is not a
second copy of the algorithm: :func:`_compile` takes the Python functions behind those
CPU kernels (the chunk loops, :func:`~.pointmass.em_step`, :func:`~.pointmass.midpoint_step`,
the compensated sum and the gravity helpers of :mod:`.gravity`) and compiles them again
with ``numba.cuda.jit(device=True)``, their calls re-pointed at the device versions. So the
GPU runs the same operations in the same order: the same Newton predictor and stopping
rule, ``h**2/2`` never formed, the velocity from ``g_em`` linearised at the last iterate,
Kahan sums of the state, the same failure codes. Each thread calls the chunk function on
its own column of the (3, n) arrays, so a point's result does not depend on the others.

Rounding. On numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, which runs the device code
as Python with IEEE doubles) the results equal the CPU kernels bit for bit; the tests
require 1e-12 relative. On a real GPU, NVVM contracts a multiply and an add into one fused
multiply-add where it can (its default; numba offers no switch for it short of
``fastmath``, which would also flush denormals and approximate division and square root,
and is not used). A fused operation rounds once instead of twice, so results differ from
the CPU's at round-off (about 1e-16 relative per step), without a bias of one sign: the
compensated sums have no products to fuse, and no rounded constant multiplies gravity in
one update but not the other. The accurate ``g_em`` of :func:`~.pointmass.em_finish` forms
its exact products with explicit fused multiply-adds (``cuda.fma`` here, ``llvm.fma`` on the
CPU), which contraction cannot change; contracting its small correction terms changes them
by a rounding of themselves only.

Use: :func:`chunk` has the arguments of the CPU chunk kernels plus a method code and runs
on the device, copying the arrays there and back; :func:`require_device` raises a clear
:class:`~emorbit.errors.InputError` when no CUDA device is present.
"""

from __future__ import annotations

import types
from fractions import Fraction

import numpy as np

from ..errors import InputError
from . import eft, gravity, pointmass

__all__ = ["METHOD_EM", "METHOD_EM_PLAIN", "METHOD_MIDPOINT", "METHOD_LEAPFROG", "METHODS", "THREADS_PER_BLOCK", "available",
           "require_device", "chunk"]

METHOD_EM = pointmass.METHOD_EM
METHOD_EM_PLAIN = pointmass.METHOD_EM_PLAIN
METHOD_MIDPOINT = pointmass.METHOD_MIDPOINT
METHOD_LEAPFROG = 2
#: method name -> code
METHODS = {"em": METHOD_EM, "midpoint": METHOD_MIDPOINT, "leapfrog": METHOD_LEAPFROG}
#: threads per block (one point each); a multiple of the warp size
THREADS_PER_BLOCK = 128

#: CPU kernels compiled again for the device, callees first
_SOURCES = (eft.two_sum, eft.two_prod, gravity.accel, gravity.accel_jacobian_coeffs, gravity.em_accel,
            gravity.em_jacobian_coeffs, gravity.norm_sq_lo, gravity.em_accel_root, gravity.em_accel_dd, pointmass._residual,
            pointmass.em_finish,
            pointmass.kahan_add, pointmass._newton_done, pointmass._finite, pointmass.em_step,
            pointmass.midpoint_step, pointmass.implicit_chunk, pointmass.leapfrog_chunk)
_compiled = None


def _cuda():
    try:
        from numba import cuda
    except ImportError as exc:  # a Numba without its CUDA target
        raise InputError("device", f"numba.cuda cannot be imported ({exc}); pip install numba-cuda") from None
    return cuda


def available() -> bool:
    """Whether a CUDA device (or numba's CUDA simulator) can run the kernels."""
    try:
        return bool(_cuda().is_available())
    except InputError:
        return False


def require_device():
    """The numba.cuda module, or an :class:`InputError` saying why the GPU cannot be used."""
    cuda = _cuda()
    if not cuda.is_available():
        raise InputError("device", "no CUDA device: numba.cuda found no usable NVIDIA GPU and driver on this "
                                   "machine; run on the CPU (device 'cpu'), or on a machine with an NVIDIA GPU "
                                   "(pip install 'emorbit[gpu]' for the numba-cuda target)")
    return cuda


def _implicit_kernel(method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter,
                     rec_x, rec_v, rec_iters, fail):
    """One thread per point: :func:`~.pointmass.implicit_chunk` on column i."""
    i = cuda.grid(1)  # noqa: F821 - compiled by _compile with cuda and the device functions in its globals
    if i < x.shape[1]:
        j = i + 1
        implicit_chunk(method, x[:, i:j], v[:, i:j], cx[:, i:j], cv[:, i:j], gm, center, dt, gammas,  # noqa: F821
                       every, nrec, max_iter, rec_x[:, :, i:j], rec_v[:, :, i:j], rec_iters[:, i:j], fail[i:j])


def _leapfrog_kernel(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail):
    """One thread per point: :func:`~.pointmass.leapfrog_chunk` on column i."""
    i = cuda.grid(1)  # noqa: F821
    if i < x.shape[1]:
        j = i + 1
        leapfrog_chunk(x[:, i:j], v[:, i:j], cx[:, i:j], cv[:, i:j], gm, center, dt, gammas, every,  # noqa: F821
                       nrec, max_iter, rec_x[:, :, i:j], rec_v[:, :, i:j], rec_iters[:, i:j], fail[i:j])


def _fma(a, b, c):
    """The device's fused multiply-add (the CPU kernels' :func:`~.eft.fma`)."""
    return cuda.fma(a, b, c)  # noqa: F821 - compiled by _compile with cuda in its globals


def _fma_exact(a, b, c):
    """``a b + c`` rounded once, in exact rational arithmetic: the fused multiply-add of
    Numba's CUDA simulator (which runs device functions as Python and has no ``cuda.fma``)."""
    return float(Fraction(a) * Fraction(b) + Fraction(c))


def _rebind(f, table: dict):
    """``f`` with the names in ``table`` (device functions, the cuda module) in its globals."""
    scope = dict(f.__globals__)
    scope.update(table)
    clone = types.FunctionType(f.__code__, scope, f.__name__, f.__defaults__, f.__closure__)
    clone.__qualname__ = f"cuda.{f.__qualname__}"
    clone.__doc__ = f.__doc__
    return clone


def _compile():
    """Compile the device functions (from the CPU kernels' Python functions) and the two
    kernels once per process; returns (cuda, implicit kernel, leapfrog kernel)."""
    global _compiled
    if _compiled is not None:
        return _compiled
    cuda = require_device()
    table = {"cuda": cuda}
    table["fma"] = cuda.jit(device=True)(_rebind(_fma if hasattr(cuda, "fma") else _fma_exact, table))
    for dispatcher in _SOURCES:
        f = dispatcher.py_func
        table[f.__name__] = cuda.jit(device=True)(_rebind(f, table))
    _compiled = (cuda, cuda.jit(_rebind(_implicit_kernel, table)), cuda.jit(_rebind(_leapfrog_kernel, table)))
    return _compiled


def chunk(method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail,
          threads_per_block: int = THREADS_PER_BLOCK) -> None:
    """Advance every point ``nrec * every`` composed steps on the GPU.

    ``method`` is a code of :data:`METHODS`; the other arguments are those of
    :func:`~.pointmass.implicit_chunk` (host arrays, updated in place: ``x, v, cx, cv``
    and the records ``rec_x, rec_v, rec_iters, fail``, which the caller pre-fills with -1).
    """
    cuda, implicit_kernel, leapfrog_kernel = _compile()
    n = x.shape[1]
    if n == 0 or nrec == 0:
        return
    host = (x, v, cx, cv, rec_x, rec_v, rec_iters, fail)
    dev = [cuda.to_device(np.ascontiguousarray(a)) for a in host]
    d_center = cuda.to_device(np.ascontiguousarray(center, dtype=np.float64))
    d_gammas = cuda.to_device(np.ascontiguousarray(gammas, dtype=np.float64))
    blocks = (n + threads_per_block - 1) // threads_per_block
    dx, dv, dcx, dcv, drx, drv, dri, dfail = dev
    if method == METHOD_LEAPFROG:
        leapfrog_kernel[blocks, threads_per_block](dx, dv, dcx, dcv, np.float64(gm), d_center, np.float64(dt), d_gammas,
                                                   int(every), int(nrec), int(max_iter), drx, drv, dri, dfail)
    elif method in (METHOD_EM, METHOD_EM_PLAIN, METHOD_MIDPOINT):
        implicit_kernel[blocks, threads_per_block](int(method), dx, dv, dcx, dcv, np.float64(gm), d_center, np.float64(dt),
                                                   d_gammas, int(every), int(nrec), int(max_iter), drx, drv, dri,
                                                   dfail)
    else:
        raise ValueError(f"no CUDA kernel for method code {method!r}")
    for h, d in zip(host, dev):
        h[...] = d.copy_to_host()
