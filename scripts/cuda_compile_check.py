"""Compile emorbit's CUDA kernels to PTX on a machine without a GPU.

The CUDA simulator (tests/test_cuda.py) runs the device code as Python; this script checks
that the real CUDA target types and compiles it, by asking NVVM for PTX:

    python -m venv /tmp/cudavenv && /tmp/cudavenv/bin/pip install -e . "numba-cuda[cu12]"
    /tmp/cudavenv/bin/python scripts/cuda_compile_check.py [--cc 9.0]

It prints, for each kernel compiled with NVVM's ``-fma=0`` (what emorbit uses) and with its
default contraction, the PTX size and how many fused multiply-adds, multiplications,
additions, divisions and square roots NVVM emitted (double precision; ``.rn`` marks an
operation that ptxas may not fuse). Compiling a kernel that calls device functions asks the
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

    import numba.cuda.dispatcher as dispatcher
    from numba import cuda
    from numba import types as nt

    from emorbit.kernels.pointmass import cuda as kcuda

    class _Device:
        compute_capability = cc

    dispatcher.get_current_device = lambda: _Device()  # no driver: say which GPU to compile for
    print(f"numba.cuda: {getattr(cuda, 'implementation', '?')} ({cuda.__file__})")
    devices: dict = {}
    devices["fma"] = cuda.jit(device=True)(kcuda._rebind(kcuda._fma, cuda, devices))
    f1, f2, f3 = (nt.Array(nt.float64, k, "C") for k in (1, 2, 3))
    i2 = nt.Array(nt.int64, 2, "C")
    sig = (f2, f2, f2, f2, nt.float64, f1, nt.float64, f1, nt.int64, nt.int64, nt.int64, f3, f3, i2, i2)
    for fn in kcuda._KERNELS.values():
        for contract in (False, True):
            start = time.perf_counter()
            with kcuda._nvvm_fma(contract):
                ptx, _ = cuda.compile_ptx(kcuda._rebind(fn, cuda, devices), sig, device=False, cc=cc)
            counts = ", ".join(
                f"{op} {ptx.count(op + ' ')}"
                for op in ("fma.rn.f64", "mul.rn.f64", "mul.f64", "add.rn.f64", "add.f64", "div.rn.f64", "sqrt.rn.f64")
            )
            print(
                f"{fn.__name__:18s} {'contracted' if contract else '-fma=0':10s} sm_{cc[0]}{cc[1]}: "
                f"{ptx.count(chr(10))} PTX lines; {counts} ({time.perf_counter() - start:.1f} s)"
            )


if __name__ == "__main__":
    main()
