"""Compile emorbit's CUDA kernels to PTX on a machine without a GPU.

The CUDA simulator (tests/test_cuda.py) runs the device code as Python; this script checks
that the real CUDA target types and compiles it, by asking NVVM for PTX:

    python -m venv /tmp/cudavenv && /tmp/cudavenv/bin/pip install -e . "numba-cuda[cu12]"
    /tmp/cudavenv/bin/python scripts/cuda_compile_check.py [--cc 9.0]

It prints the PTX size and how many fused multiply-adds, divisions and square roots NVVM
emitted (double precision). Compiling a kernel that calls device functions asks the
driver for the current GPU's compute capability; with no driver here the script answers
for it (``--cc``), the one thing it patches.
"""

from __future__ import annotations

import argparse
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cc", default="9.0", help="compute capability to compile for (default 9.0, H100)")
    args = ap.parse_args()
    cc = tuple(int(p) for p in args.cc.split("."))

    from numba import cuda
    from numba import types as nt

    import numba.cuda.dispatcher as dispatcher
    from emorbit.kernels import cuda as kcuda

    class _Device:
        compute_capability = cc

    dispatcher.get_current_device = lambda: _Device()  # no driver: say which GPU to compile for
    print(f"numba.cuda: {getattr(cuda, 'implementation', '?')} ({cuda.__file__})")
    table = {"cuda": cuda}
    for d in kcuda._SOURCES:
        table[d.py_func.__name__] = cuda.jit(device=True)(kcuda._rebind(d.py_func, table))
    f1, f2, f3 = (nt.Array(nt.float64, k, "C") for k in (1, 2, 3))
    i2 = nt.Array(nt.int64, 2, "C")
    implicit = (nt.int64, f2, f2, f2, f2, nt.float64, f1, nt.float64, f1, nt.int64, nt.int64, nt.int64, f3, f3, i2, i2)
    for name, fn, sig in (("em / midpoint", kcuda._implicit_kernel, implicit),
                          ("leapfrog", kcuda._leapfrog_kernel, implicit[1:])):
        start = time.perf_counter()
        ptx, _ = cuda.compile_ptx(kcuda._rebind(fn, table), sig, device=False, cc=cc)
        print(f"{name:14s} sm_{cc[0]}{cc[1]}: {ptx.count(chr(10))} PTX lines, fma.rn.f64 {ptx.count('fma.rn.f64')}, "
              f"div.rn.f64 {ptx.count('div.rn.f64')}, sqrt.rn.f64 {ptx.count('sqrt.rn.f64')} "
              f"({time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    main()
