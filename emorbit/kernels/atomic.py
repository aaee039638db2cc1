"""An atomic counter for compiled kernels on the CPU: the shared work queue of
:func:`emorbit.kernels.pointmass.packed.ensemble_chunk_parallel`.

Numba's ``prange`` hands each thread a fixed, equal share of the iterations before the loop
starts (its ``omp`` and ``workqueue`` threading layers schedule statically), so a loop over
independent blocks ends when the slowest thread ends. On a machine whose cores are shared
with other work (a virtual machine, a laptop) one thread often runs slower than the other
for a while; with a counter that every thread increments to claim its next blocks, the
faster threads take more of them and the loop ends when the work is done. The increment
is LLVM's ``atomicrmw add`` (one ``lock xadd`` instruction on x86-64).
"""

from __future__ import annotations

from numba.core import cgutils, types
from numba.extending import intrinsic

__all__ = ["fetch_add"]


@intrinsic
def fetch_add(typingctx, counter, index, value):
    """``old = counter[index]; counter[index] += value; return old`` as one atomic operation
    (sequentially consistent) on a C-contiguous int64 array."""
    if not (
        isinstance(counter, types.Array)
        and counter.dtype == types.int64
        and counter.ndim == 1
        and isinstance(index, types.Integer)
        and isinstance(value, types.Integer)
    ):
        return None
    sig = types.int64(counter, index, value)

    def codegen(context, builder, signature, args):
        array_type = signature.args[0]
        array = context.make_array(array_type)(context, builder, args[0])
        i = context.cast(builder, args[1], signature.args[1], types.intp)
        ptr = cgutils.get_item_pointer(context, builder, array_type, array, [i])
        v = context.cast(builder, args[2], signature.args[2], types.int64)
        return builder.atomic_rmw("add", ptr, v, "seq_cst")

    return sig, codegen
