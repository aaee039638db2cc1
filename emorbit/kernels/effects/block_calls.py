"""The block loads and stores of :mod:`.blocks` as C callbacks, bound by name in each process.

Method: a compiled effect set's ``forces`` and ``work`` (:mod:`emorbit.effects.program`) call
:func:`.blocks.load_forces`, :func:`.blocks.store_forces`, :func:`.blocks.load_work` and
:func:`.blocks.store_work` through :func:`.blocks.call_c`, by the names in :data:`SYMBOLS`,
not as linked functions: Numba would otherwise copy their code into every set, and LLVM
optimise and emit it again there (about 2.5 s of a set's compile). The callbacks here wrap
them once per install (``cache=True``); :func:`bind` tells LLVM, in this process, which code
each name stands for, and must run before a set's functions are compiled or loaded.

Data layout: each array passed as its data pointer and its shape, each flag as an int64
(:func:`.blocks.c_arguments`); the arrays and arguments of :mod:`.blocks`' functions.
"""

from __future__ import annotations

from llvmlite import binding
from numba import carray, cfunc, types

from ..jit import JIT_OPTIONS
from .blocks import c_arguments, load_forces, load_work, store_forces, store_work

__all__ = ["SYMBOLS", "bind"]

_F1 = types.Array(types.float64, 1, "C")
_F2 = types.Array(types.float64, 2, "C")
_N, _B = types.int64, types.boolean
_OPTIONS = {k: v for k, v in JIT_OPTIONS.items() if k != "nogil"}


def _callback(*tys):
    return cfunc(types.void(*c_arguments(tys)), **_OPTIONS)


@_callback(_F1, _F2, _F2, _F2, _F2, _F2, _N, _N, _B, _B)
def _load_forces(Bp, nB, x0p, x0r, x0c, x1p, x1r, x1c, Fp, Fr, Fc, Wp, Wr, Wc, cp, cr, cc, lo, nb, jac, weighted):
    load_forces(
        carray(Bp, nB), carray(x0p, (x0r, x0c)), carray(x1p, (x1r, x1c)), carray(Fp, (Fr, Fc)),
        carray(Wp, (Wr, Wc)), carray(cp, (cr, cc)), lo, nb, jac != 0, weighted != 0,
    )  # fmt: skip


@_callback(_F1, _F2, _F2, _F1, _N, _N, _B, _B)
def _store_forces(Bp, nB, Fp, Fr, Fc, Wp, Wr, Wc, mp, nm, lo, nb, jac, weighted):
    store_forces(
        carray(Bp, nB), carray(Fp, (Fr, Fc)), carray(Wp, (Wr, Wc)), carray(mp, nm), lo, nb, jac != 0, weighted != 0
    )


@_callback(_F1, _F2, _F2, _F2, _N, _N)
def _load_work(Bp, nB, x0p, x0r, x0c, dp, dr, dc, cp, cr, cc, lo, nb):
    load_work(carray(Bp, nB), carray(x0p, (x0r, x0c)), carray(dp, (dr, dc)), carray(cp, (cr, cc)), lo, nb)


@_callback(_F1, _F2, _N, _N, _N, _N)
def _store_work(Bp, nB, op, orows, ocols, k, lo, nb, working):
    store_work(carray(Bp, nB), carray(op, (orows, ocols)), k, lo, nb, working)


#: the names a set's functions call them by
SYMBOLS = {
    "emorbit_block_load_forces": _load_forces,
    "emorbit_block_store_forces": _store_forces,
    "emorbit_block_load_work": _load_work,
    "emorbit_block_store_work": _store_work,
}


def bind(callbacks: dict | None = None) -> None:
    """Bind each name of ``callbacks`` ({name: compiled cfunc}; default :data:`SYMBOLS`) to its
    code in this process, so that LLVM resolves the calls of the functions compiled or loaded
    after this."""
    for name, fn in (SYMBOLS if callbacks is None else callbacks).items():
        binding.add_symbol(name, fn.address)
