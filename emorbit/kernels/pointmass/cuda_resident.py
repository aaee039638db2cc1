"""Point-mass ensembles that stay on the GPU across chunks: :class:`DeviceEnsemble`.

:func:`.cuda.chunk` copies the state to the device and the records back on every call; on an
H100 with 1e6 points (em) that ran at 3 % of the kernel's throughput (8.5e8 against 2.7e10
point-steps/s; ``emorbit bench --only gpu``). Here the state (x, v, cx, cv) is uploaded once
and stays in device memory; each :meth:`DeviceEnsemble.advance` launches the same device
code as :func:`.cuda.chunk` (:func:`~.chunk._run_point` per thread, compiled from the CPU
kernels by :func:`.cuda._compile`, NVVM ``-fma=0``), so the results are the CPU kernels' bits.

Method. A chunk of ``nrec`` records is launched in up to :data:`PIECES` pieces of whole
records, on a compute stream. Each piece writes its records into one of two device record
slots, used in turn (double buffering); a second stream copies a slot's rows into pinned
(page-locked) host buffers as soon as the piece that wrote them has finished (an event), so
that the copy of piece p runs while piece p + 1 computes, and piece p + 2 waits (an event)
until the copy out of its slot is done. A point that fails stops, as on the CPU: the kernel
skips it in later pieces, its failure's step index counts from the chunk's start, and its
iteration counts after the failure are 0. The (n, 2) failure array is copied back only when
a point failed in this chunk: every failure also writes the chunk's serial number into a
one-element device flag, which is copied with the records (eight bytes instead of 16 n).

Data layout. Device: ``x, v, cx, cv`` (3, n) float64, C order, as on the host; two record
slots of (rows, 3, n) positions and velocities and (rows, n) int64 iteration counts; ``fail``
(n, 2) int64; the flag (1,) int64. Host: the records of a chunk are returned in pinned
buffers ((capacity, 3, n), ...; the arrays handed out are their first ``nrec`` rows). A
buffer is used again only when nothing outside this module holds it or a view of it any
longer (its reference counts are back at their values when it was made), so records handed
out are never overwritten; a caller that keeps them simply makes the next chunk take a new
buffer. The state comes back to the host only when asked (:meth:`DeviceEnsemble.download`);
:meth:`DeviceEnsemble.snapshot` and :meth:`DeviceEnsemble.restore` copy device to device.

The stepping layer (:mod:`emorbit.stepping`) reads a chunk's records before it asks for the
next chunk, so the copies overlap the computation within a chunk (between its pieces), not
the host's handling of one chunk's records (HDF5, invariants) with the next chunk's steps.

The throughput of this path has not been measured on a GPU yet (it was written and tested on
numba's CUDA simulator, which gives the CPU's bits but times Python): ``emorbit bench --only
gpu`` measures it against the kernel alone.
"""

from __future__ import annotations

import inspect
import sys

import numpy as np

from ..codes import METHOD_EM, METHOD_EM_PLAIN, METHOD_LEAPFROG, METHOD_MIDPOINT
from . import cuda as base
from .chunk import _run_point

__all__ = ["PIECES", "DeviceEnsemble", "DeviceRecords"]

#: a chunk's records are launched in at most this many pieces (their copies overlap the next piece)
PIECES = 4

#: (cuda, kernels) per ``contract`` value
_compiled: dict = {}


def _resident_kernel(method: int, name: str):
    """The kernel of one method for :class:`DeviceEnsemble`: :func:`~.chunk._run_point` on
    column i for one piece of a chunk, skipping a point that failed in an earlier piece,
    zeroing its iteration counts first (the CPU's callers pre-fill them with 0) and
    counting a failure's step from the chunk's start (``step0``: the piece's first step)."""

    def kernel(
        x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, step0, flag, serial
    ):
        i = cuda.grid(1)  # noqa: F821 - compiled with cuda and the device functions in its globals
        if i < x.shape[1]:
            if step0 == 0:
                fail[i, 0] = -1
                fail[i, 1] = -1
            for r in range(nrec):
                rec_iters[r, i] = 0
            if fail[i, 0] < 0:
                _run_point(
                    method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter,
                    rec_x, rec_v, rec_iters, fail, i,
                )  # fmt: skip
                if fail[i, 0] >= 0:
                    fail[i, 0] += step0
                    flag[0] = serial

    kernel.__name__ = kernel.__qualname__ = f"resident_{name}"
    return kernel


#: method code -> the resident kernel's Python function
_KERNELS = {
    code: _resident_kernel(code, name)
    for code, name in (
        (METHOD_EM, "em"),
        (METHOD_EM_PLAIN, "em_plain"),
        (METHOD_MIDPOINT, "midpoint"),
        (METHOD_LEAPFROG, "leapfrog"),
    )
}


def _compile(contract: bool = False):
    """(cuda, {method code: kernel}) of the resident kernels, compiled once per ``contract``
    value with the device functions of :func:`.cuda._compile` (the same options)."""
    contract = bool(contract)
    if contract not in _compiled:
        cuda, _ = base._compile(contract)  # checks the device, compiles the device functions
        options = {}
        if not contract and "lto" in inspect.signature(cuda.jit).parameters:
            options["lto"] = False  # as .cuda._compile: nvJitLink would contract again
        kernels = {
            code: base._Kernel(cuda.jit(base._rebind(f, cuda, base._devices), **options), contract)
            for code, f in _KERNELS.items()
        }
        _compiled[contract] = (cuda, kernels)
    return _compiled[contract]


def _chain(a: np.ndarray) -> list:
    """``a`` and the arrays below it (its ``base`` chain): a view of ``a`` refers to one of them."""
    out = [a]
    while isinstance(out[-1].base, np.ndarray):
        out.append(out[-1].base)
    return out


def _counts(chain: list) -> list:
    """The reference counts of the arrays of a chain (measured the same way every time)."""
    return [sys.getrefcount(a) for a in chain]


class _Pinned:
    """A set of pinned host buffers (records of up to ``rows`` rows of n points) and whether
    anything outside holds them."""

    def __init__(self, cuda, rows: int, n: int):
        self.rows = rows
        self.x = cuda.pinned_array((rows, 3, n), dtype=np.float64)
        self.v = cuda.pinned_array((rows, 3, n), dtype=np.float64)
        self.iters = cuda.pinned_array((rows, n), dtype=np.int64)
        self._chains = [_chain(a) for a in (self.x, self.v, self.iters)]
        self._free = [_counts(c) for c in self._chains]

    def free(self) -> bool:
        """Whether no array handed out (nor a view of one) is alive any longer."""
        return all(_counts(c) == f for c, f in zip(self._chains, self._free))


class DeviceRecords:
    """The records of one :meth:`DeviceEnsemble.advance` (host arrays, the layout of
    :class:`emorbit.bodies.pointmasses.ChunkRecords`).

    Attributes
    ----------
    x, v : ndarray
        (nrec, 3, n) positions and velocities after each record interval (pinned memory).
    iterations : ndarray
        (nrec, n) Newton iterations per interval (0 after a point's failure).
    fail : ndarray
        (n, 2) step index in the chunk and status per point, -1 if none (read-only when no
        point failed: one array of -1 serves every such chunk).
    """

    __slots__ = ("x", "v", "iterations", "fail")

    def __init__(self, x, v, iterations, fail):
        self.x, self.v, self.iterations, self.fail = x, v, iterations, fail


class _Snapshot:
    """Device copies of a state (:meth:`DeviceEnsemble.snapshot`); its buffers go back to the
    ensemble's free list when it is no longer referenced."""

    def __init__(self, owner, arrays):
        self._owner, self.arrays = owner, arrays

    def __del__(self):
        owner = self._owner
        if owner is not None and len(owner._spare) < 2:
            owner._spare.append(self.arrays)


class DeviceEnsemble:
    """The state of n point masses kept in GPU memory, advanced chunk by chunk.

    Parameters
    ----------
    x, v, cx, cv : ndarray
        (3, n) positions, velocities and their compensation terms (copied to the device).
    threads_per_block : int
        Threads (points) per block.
    contract : bool
        Let NVVM fuse multiply-adds (differs from the CPU at round-off; see :mod:`.cuda`).

    Raises
    ------
    RuntimeError
        No CUDA device (the message of :func:`.cuda.device_problem`).
    ValueError
        Arrays that are not (3, n) alike.
    """

    def __init__(self, x, v, cx, cv, threads_per_block: int = base.THREADS_PER_BLOCK, contract: bool = False):
        arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (x, v, cx, cv)]
        shape = arrays[0].shape
        for name, a in zip(("x", "v", "cx", "cv"), arrays):
            if a.ndim != 2 or a.shape[0] != 3 or a.shape != shape:
                raise ValueError(f"{name} must be (3, n) like x {shape}, got shape {a.shape}")
        self.cuda, self._kernels = _compile(contract)
        cuda = self.cuda
        self.n = shape[1]
        self.threads_per_block = int(threads_per_block)
        self.compute, self.copy = cuda.stream(), cuda.stream()
        self.state = tuple(cuda.to_device(a, stream=self.compute) for a in arrays)
        self._fail = cuda.device_array((self.n, 2), dtype=np.int64, stream=self.compute)
        self._flag = cuda.to_device(np.zeros(1, np.int64), stream=self.compute)
        self._flag_host = cuda.pinned_array(1, dtype=np.int64)
        self._serial = 0
        self._slots: list = []  # two device record slots, (rows, 3, n), (rows, 3, n), (rows, n)
        self._written = [cuda.event(), cuda.event()]
        self._copied = [cuda.event(), cuda.event()]
        self._pinned: list[_Pinned] = []
        self._no_failure = np.full((self.n, 2), -1, np.int64)
        self._no_failure.flags.writeable = False
        self._spare: list = []  # snapshot buffers no longer referenced
        self.compute.synchronize()

    def _slot_rows(self, rows: int) -> list:
        """The two device record slots, (re)made with at least ``rows`` rows."""
        if not self._slots or self._slots[0][2].shape[0] < rows:
            self.copy.synchronize()
            self.compute.synchronize()
            cuda, n = self.cuda, self.n
            self._slots = [
                (
                    cuda.device_array((rows, 3, n), np.float64),
                    cuda.device_array((rows, 3, n), np.float64),
                    cuda.device_array((rows, n), np.int64),
                )
                for _ in range(2)
            ]
        return self._slots

    def _host_buffers(self, nrec: int) -> _Pinned:
        """A free set of pinned record buffers with at least ``nrec`` rows."""
        for p in self._pinned:
            if p.rows >= nrec and p.free():
                return p
        p = _Pinned(self.cuda, nrec, self.n)
        self._pinned = ([q for q in self._pinned if q.free()] + [p])[-3:]  # a busy one is freed with its last view
        return p

    def advance(self, method: int, gm, center, dt, gammas, every: int, nrec: int, max_iter: int) -> DeviceRecords:
        """Advance every point ``nrec * every`` composed steps on the device; the state stays there.

        Parameters
        ----------
        method : int
            A code of :data:`.cuda.CODES`.
        gm, center, dt, gammas, every, nrec, max_iter
            As :func:`~.reference.implicit_chunk`.

        Returns
        -------
        DeviceRecords
            The chunk's records (the state after the failing step's start for a failed point).

        Raises
        ------
        ValueError
            A method code without a CUDA kernel.
        """
        if method not in self._kernels:
            raise ValueError(f"no CUDA kernel for method code {method!r}")
        n, nrec, every = self.n, int(nrec), int(every)
        host = self._host_buffers(max(nrec, 1))
        if n == 0 or nrec == 0:
            return DeviceRecords(host.x[:nrec], host.v[:nrec], host.iters[:nrec], self._no_failure)
        cuda = self.cuda
        rows = -(-nrec // PIECES)
        slots = self._slot_rows(rows)
        self._serial += 1
        center = cuda.to_device(np.ascontiguousarray(center, dtype=np.float64), stream=self.compute)
        gammas = cuda.to_device(np.ascontiguousarray(gammas, dtype=np.float64), stream=self.compute)
        blocks = (n + self.threads_per_block - 1) // self.threads_per_block
        launch = self._kernels[method][blocks, self.threads_per_block, self.compute]
        x, v, cx, cv = self.state
        for p, r0 in enumerate(range(0, nrec, rows)):
            m, s = min(rows, nrec - r0), p % 2
            drx, drv, dri = slots[s]
            if p >= 2:  # the slot's rows from two pieces ago must be on the host first
                self._copied[s].wait(self.compute)
            launch(
                x, v, cx, cv, np.float64(gm), center, np.float64(dt), gammas, every, m, int(max_iter),
                drx, drv, dri, self._fail, np.int64(r0 * every), self._flag, np.int64(self._serial),
            )  # fmt: skip
            self._written[s].record(self.compute)
            self._written[s].wait(self.copy)
            for d, h in ((drx, host.x), (drv, host.v), (dri, host.iters)):
                d[:m].copy_to_host(h[r0 : r0 + m], stream=self.copy)
            self._copied[s].record(self.copy)
        self._flag.copy_to_host(self._flag_host, stream=self.copy)
        self.copy.synchronize()
        fail = self._no_failure
        if int(self._flag_host[0]) == self._serial:
            fail = self._fail.copy_to_host(stream=self.compute)
            self.compute.synchronize()
        return DeviceRecords(host.x[:nrec], host.v[:nrec], host.iters[:nrec], fail)

    def download(self, out=None) -> tuple:
        """The state on the host: (x, v, cx, cv), into the four (3, n) arrays of ``out`` if given.

        Parameters
        ----------
        out : tuple of ndarray, optional
            C-contiguous float64 (3, n) arrays to fill.

        Returns
        -------
        tuple of ndarray
            The arrays filled.
        """
        self.compute.synchronize()
        if out is None:
            out = tuple(np.empty((3, self.n)) for _ in range(4))
        for d, h in zip(self.state, out):
            d.copy_to_host(h, stream=self.compute)
        self.compute.synchronize()
        return tuple(out)

    def upload(self, x, v, cx, cv) -> None:
        """Replace the device state by host arrays of the same (3, n) shape.

        Raises
        ------
        ValueError
            An array whose shape is not (3, n).
        """
        for name, a in zip(("x", "v", "cx", "cv"), (x, v, cx, cv)):
            if np.shape(a) != (3, self.n):
                raise ValueError(f"{name} must be (3, {self.n}) to replace the device state, got shape {np.shape(a)}")
        for d, a in zip(self.state, (x, v, cx, cv)):
            d.copy_to_device(np.ascontiguousarray(a, dtype=np.float64), stream=self.compute)
        self.compute.synchronize()

    def snapshot(self) -> _Snapshot:
        """A device-to-device copy of the state, for :meth:`restore` (nothing crosses to the host)."""
        arrays = self._spare.pop() if self._spare else tuple(
            self.cuda.device_array((3, self.n), np.float64) for _ in range(4)
        )  # fmt: skip
        for d, s in zip(arrays, self.state):
            d.copy_to_device(s, stream=self.compute)
        return _Snapshot(self, arrays)

    def restore(self, snap: _Snapshot) -> None:
        """Put back the state :meth:`snapshot` copied (device to device).

        Raises
        ------
        ValueError
            A snapshot of another ensemble.
        """
        if not isinstance(snap, _Snapshot) or snap._owner is not self:
            raise ValueError(f"snapshot must come from this ensemble's snapshot(), got {type(snap).__name__}")
        for d, s in zip(self.state, snap.arrays):
            d.copy_to_device(s, stream=self.compute)
