"""Blocks of points for the loops of a compiled effect set (:mod:`emorbit.effects.program`).

Method: ``forces`` and ``work`` run over the points in blocks of :data:`BLOCK`. A block's
inputs and sums live in one buffer ``B`` whose rows lie :data:`LD` apart (row r holds the
block's values at ``B[r LD : r LD + nb]``), so that in every loop over the block LLVM sees
accesses at constant distances that cannot overlap and vectorises the loop where the
effect's piece allows (no calls, no inner loops); each point's Jacobian block is a (3, 3)
array on the stack (:func:`block33`), which LLVM keeps in registers. The arithmetic per
point is the pieces' own, in the set's order: a point's bits do not depend on the block.
A block's rows are loaded and stored by :func:`load_forces`, :func:`store_forces`,
:func:`load_work` and :func:`store_work`, compiled once per install for every set.

An effect's block loops (of the types :data:`FORCES_LOOP` and :data:`WORK_LOOP`) and the
loads and stores (:mod:`.block_calls`) are C callbacks compiled once per install; a set's
functions call them by name (:func:`call_c`: each array as its data pointer and shape, each
flag an int64), so that LLVM neither optimises nor emits their code again in each set.

Data layout: ``B`` float64 (rows * LD,); a row's source a row of a float64 (k, n) array, the
block its entries ``lo`` to ``lo + nb``; rows x0 (0-2), x1 or dx (3-5), F (6-8), W (9-17), the
running effect's coefficients (:data:`ROW_K`) and work (:data:`ROW_OUT`), then from
:data:`ROW_COEF` each effect's coefficients and, in ``work``, each working effect's work. An
effect's loop reads and writes rows at constant offsets only: a row passed at run time keeps
LLVM from ruling out that it overlaps the others, and the loop then stays scalar
(``python scripts/block_loops.py`` times each set's functions per point).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from ..jit import kernel

__all__ = [
    "BLOCK",
    "LD",
    "ROW_K",
    "ROW_OUT",
    "ROW_COEF",
    "FORCES_LOOP",
    "WORK_LOOP",
    "block33",
    "c_arguments",
    "call_c",
    "run_forces",
    "load_row",
    "copy_row",
    "load_forces",
    "store_forces",
    "load_work",
    "store_work",
]

#: points per block
BLOCK = 64
#: the distance between two rows of a block's buffer
LD = 72
#: the row of the coefficients of the effect whose loop runs (copied there from its own row:
#: a loop reads rows at constant distances only, so that LLVM vectorises it)
ROW_K = 18
#: the row an effect's ``work`` loop writes its work into (then copied into its slot's row)
ROW_OUT = 19
#: the first row of the effects' coefficients in a block's buffer: x0 (rows 0-2), x1 or dx
#: (3-5), F (6-8), W (9-17), :data:`ROW_K`, :data:`ROW_OUT`, then each effect's coefficients
#: (and, in ``work``, after them each working effect's work)
ROW_COEF = 20

_BLOCK = types.Array(types.float64, 2, "C")


def block33():
    """A (3, 3) float64 C-contiguous array, contents undefined. Compiled, it lies in the
    calling function's stack frame (:func:`_stack33`, inlined into the caller): no allocation
    and no reference count, valid while that function runs, one slot reused by a loop that
    takes one per iteration. In Python (a kernel's ``py_func``) it is a new array."""
    return np.empty((3, 3))


@overload(block33, inline="always")
def _block33():
    def impl():
        return _stack33()

    return impl


@intrinsic
def _stack33(typingctx):
    """:func:`block33`'s array in the stack frame of the function it is compiled into."""

    def codegen(context, builder, signature, args):
        ary = context.make_array(_BLOCK)(context, builder)
        data = cgutils.alloca_once(builder, context.get_data_type(types.float64), size=9)
        intp = context.get_value_type(types.intp)
        context.populate_array(
            ary,
            data=data,
            shape=cgutils.pack_array(builder, [intp(3), intp(3)]),
            strides=cgutils.pack_array(builder, [intp(24), intp(8)]),
            itemsize=intp(8),
            meminfo=None,
        )
        return ary._getvalue()

    return _BLOCK(), codegen


@kernel(inline="always")
def load_row(B, row, src, c, lo, nb):
    """Row ``row`` of the buffer from ``src[c, lo : lo + nb]``."""
    r = src[c, lo : lo + nb]
    for j in range(nb):
        B[row * LD + j] = r[j]


@kernel(inline="always")
def copy_row(B, src, dst, nb):
    """Row ``src`` of the buffer into row ``dst`` (the block's ``nb`` entries)."""
    for j in range(nb):
        B[dst * LD + j] = B[src * LD + j]


# the loads and stores of a set's ``forces`` and ``work`` (:mod:`emorbit.effects.program`):
# compiled once per install, so that a new set compiles none of them


@kernel
def load_forces(B, x0, x1, F, W, coef, lo, nb, jac, weighted):
    """A block's rows of ``forces``: x0, x1, F, W (where ``jac``) and the coefficients; weighted,
    F and W at 0 (the own effects' sum times the mass joins the pair forces, N)."""
    for c in range(3):
        load_row(B, c, x0, c, lo, nb)
        load_row(B, 3 + c, x1, c, lo, nb)
        load_row(B, 6 + c, F, c, lo, nb)
    if jac:
        for c in range(9):
            load_row(B, 9 + c, W, c, lo, nb)
    if weighted:
        B[6 * LD : 18 * LD] = 0.0
    for e in range(coef.shape[0]):
        load_row(B, ROW_COEF + e, coef, e, lo, nb)


@kernel
def store_forces(B, F, W, m, lo, nb, jac, weighted):
    """A block's F and W (where ``jac``) back into F and W; weighted, added times the mass."""
    mb = m[lo : lo + nb]
    for c in range(3):
        r = F[c, lo : lo + nb]
        for j in range(nb):
            r[j] = r[j] + mb[j] * B[(6 + c) * LD + j] if weighted else B[(6 + c) * LD + j]
    if jac:
        for c in range(9):
            r = W[c, lo : lo + nb]
            for j in range(nb):
                r[j] = r[j] + mb[j] * B[(9 + c) * LD + j] if weighted else B[(9 + c) * LD + j]


@kernel
def load_work(B, x0, dx, coef, lo, nb):
    """A block's rows of ``work``: x0, dx and the coefficients."""
    for c in range(3):
        load_row(B, c, x0, c, lo, nb)
        load_row(B, 3 + c, dx, c, lo, nb)
    for e in range(coef.shape[0]):
        load_row(B, ROW_COEF + e, coef, e, lo, nb)


@kernel
def store_work(B, out, k, lo, nb, working):
    """The block's work rows (``working`` of them, after the ``k`` coefficient rows) into out."""
    for w in range(working):
        r = out[w, lo : lo + nb]
        for j in range(nb):
            r[j] = B[(ROW_COEF + k + w) * LD + j]


# C callbacks called by symbol: an effect's block loops and the loads and stores above, compiled
# once per install (:mod:`emorbit.effects.program`, :mod:`.block_calls`); a set's functions
# call them by name, each process binding the names to the compiled code
_P = types.CPointer(types.float64)
_N = types.int64
#: ``forces_jac`` and ``forces_plain``: (B, len B, nb, h, p, len p, t, len t, s, len s, mid, pt)
FORCES_LOOP = types.void(_P, _N, _N, types.float64, _P, _N, _P, _N, _P, _N, _N, _N)
#: ``work``: (B, len B, nb, mb, len mb, h, p, len p, t, len t, s, len s, mid, pt)
WORK_LOOP = types.void(_P, _N, _N, _P, _N, types.float64, _P, _N, _P, _N, _P, _N, _N, _N)


def c_arguments(tys) -> list:
    """The C callback's argument types for arguments of Numba types ``tys``: a C-contiguous
    float64 array as its data pointer and its shape, a float as float64, an integer or a
    boolean as int64."""
    out = []
    for ty in tys:
        if isinstance(ty, types.Array):
            if ty.layout != "C" or ty.dtype != types.float64:
                raise TypeError(f"a C callback takes C-contiguous float64 arrays, not {ty}")
            out += [_P] + [_N] * ty.ndim
        elif isinstance(ty, types.Float):
            out.append(types.float64)
        elif isinstance(ty, (types.Integer, types.Boolean)):
            out.append(_N)
        else:
            raise TypeError(f"a C callback takes arrays and scalars, not {ty}")
    return out


@intrinsic
def call_c(typingctx, symbol, args):
    """Call the C callback named ``symbol`` (a string literal) with the tuple ``args``, each
    argument as :func:`c_arguments` passes it; the name is bound to its code in each process
    (``llvmlite.binding.add_symbol``) before a function that calls it is loaded."""
    if not isinstance(symbol, types.StringLiteral) or not isinstance(args, types.BaseTuple):
        return None
    tys = [types.unliteral(t) for t in args]
    c_types = c_arguments(tys)
    sig = types.void(symbol, args)

    def codegen(context, builder, signature, llargs):
        values = []
        for i, (ty, raw) in enumerate(zip(args, tys)):
            v = builder.extract_value(llargs[1], i)
            if isinstance(raw, types.Array):
                a = context.make_array(raw)(context, builder, v)
                values.append(a.data)
                values += cgutils.unpack_tuple(builder, a.shape, raw.ndim)
            else:
                values.append(context.cast(builder, v, ty, c_types[len(values)]))
        fnty = ir.FunctionType(ir.VoidType(), [context.get_value_type(t) for t in c_types])
        fn = cgutils.get_or_insert_function(builder.module, fnty, symbol.literal_value)
        builder.call(fn, values)
        return context.get_dummy_value()

    return sig, codegen


@kernel
def run_forces(forces, x0, x1, m, body, coef, h, mode, P, I, T, S, F, W, R, jac, first):
    """A set's ``forces`` (:mod:`.signatures`' ``FORCES``) called from Python: its compiled
    code. A ``cfunc`` called from Python runs its Python source, where :func:`call_c` cannot
    run; returns its status."""
    return forces(x0, x1, m, body, coef, h, mode, P, I, T, S, F, W, R, jac, first)
