"""Error-free transformations and double-double arithmetic on plain float64 scalars.

A double-double number is an unevaluated sum ``hi + lo`` with ``|lo| <= ulp(hi) / 2``; its
arithmetic carries about 106 bits. emorbit uses it in one place that decides whether the
energy error over 1e7 steps is a random walk or a drift: the final evaluation of ``g_em``
in an energy-momentum step (see :func:`emorbit.kernels.gravity.em_accel_accurate`).

The transformations are the classical ones (Knuth's two-sum; the exact product from one
fused multiply-add, :func:`two_prod`, or without one from Dekker's product with Veltkamp's
split, :func:`two_prod_dekker`); they are exact only under IEEE round-to-nearest without
re-association, which :mod:`emorbit.kernels.jit` guarantees (``fastmath=False``). The
explicit :func:`fma` is one instruction on CPUs with FMA (x86-64 since Haswell/Piledriver,
every ARMv8) and ``cuda.fma`` on the GPU; elsewhere LLVM calls a correctly rounded library
function, slower but exact. Overflow of the split (|a| > 1e300) is outside the range any
orbit reaches.
"""

from __future__ import annotations

import math

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

from .jit import kernel

__all__ = ["fma", "two_sum", "two_prod", "two_prod_dekker", "dd_add", "dd_mul", "dd_div", "dd_sqrt", "kahan_add"]

_SPLIT = 134217729.0  # 2**27 + 1 (Veltkamp)


@kernel(inline="always")
def two_sum(a, b):
    """a + b = s + e exactly (Knuth): returns (s, e)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@intrinsic
def fma(typingctx, a, b, c):
    """a b + c rounded once (LLVM's ``llvm.fma.f64``: one instruction where the CPU has
    fused multiply-add, a correctly rounded library call where it has not)."""
    if not all(isinstance(t, types.Float) for t in (a, b, c)):
        return None
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        args = [context.cast(builder, v, t, types.float64) for v, t in zip(args, signature.args)]
        fnty = ir.FunctionType(ir.DoubleType(), [ir.DoubleType()] * 3)
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.fma.f64")
        return builder.call(fn, args)

    return sig, codegen


@kernel(inline="always")
def two_prod(a, b):
    """a b = p + e exactly (with a fused multiply-add): returns (p, e)."""
    p = a * b
    return p, fma(a, b, -p)


@kernel(inline="always")
def two_prod_dekker(a, b):
    """a b = p + e exactly without a fused multiply-add (Dekker, Veltkamp's split)."""
    p = a * b
    c = _SPLIT * a
    a1 = c - (c - a)
    a2 = a - a1
    c = _SPLIT * b
    b1 = c - (c - b)
    b2 = b - b1
    return p, ((a1 * b1 - p) + a1 * b2 + a2 * b1) + a2 * b2


@kernel(inline="always")
def dd_add(ah, al, bh, bl):
    """(ah + al) + (bh + bl) as a double-double."""
    s, e = two_sum(ah, bh)
    e += al + bl
    return two_sum(s, e)


@kernel(inline="always")
def dd_mul(ah, al, bh, bl):
    """(ah + al) (bh + bl) as a double-double."""
    p, e = two_prod(ah, bh)
    e += ah * bl + al * bh
    return two_sum(p, e)


@kernel(inline="always")
def dd_div(ah, al, bh, bl):
    """(ah + al) / (bh + bl) as a double-double (one correction of the approximate
    quotient; one division)."""
    ib = 1.0 / bh
    q = ah * ib
    ph, pl = dd_mul(q, 0.0, bh, bl)
    rh, rl = dd_add(ah, al, -ph, -pl)
    return two_sum(q, (rh + rl) * ib)


@kernel(inline="always")
def dd_sqrt(ah, al):
    """sqrt(ah + al) as a double-double (one Newton correction of the double root)."""
    s = math.sqrt(ah)
    ph, pl = two_prod(s, s)
    rh, rl = dd_add(ah, al, -ph, -pl)
    corr = (rh + rl) / (s + s)
    return two_sum(s, corr if s > 0.0 else 0.0)  # a select, not a branch: vectorises


@kernel
def kahan_add(s, c, d):
    """Compensated sum: add ``d`` to ``s`` whose running error is ``c``; returns (s, c)."""
    y = d - c
    t = s + y
    return t, (t - s) - y
