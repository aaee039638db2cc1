"""Where the packed ensemble kernel spends its time, loop by loop (Linux, needs ``perf`` and
``objdump``).

    python scripts/profile_ensemble.py [--method em|fast|midpoint|leapfrog] [--seconds 10]
                                       [--n 100000] [--steps 50] [--top 12] [--annotate FILE]

Runs the one-thread kernel (:func:`emorbit.kernels.pointmass.packed.ensemble_chunk`) on the
bench's ensemble (:func:`emorbit.bench.common.ensemble_states`, dt = T/1000) for
``--seconds`` while ``perf record -e cpu-clock`` samples this process, charges every sample
to the compiled function of :mod:`emorbit.kernels.pointmass.packed` it falls in (the passes
are separate functions or inlined into the range kernel, as LLVM decides), disassembles
those functions from memory, and prints the ns per particle-step and, per function, its
loops (found as backward jumps) with their share of the samples, their instruction count
and their divisions, square roots and packed (ymm) instructions; a loop nested in another
is counted in its share too. A sample is charged to the instruction after a slow one
(skid), so read shares per loop, not per instruction. ``--annotate`` writes the
disassembly with each instruction's share.
"""

from __future__ import annotations

import argparse
import collections
import ctypes
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

CODE_BYTES = 65536  # at most this much of a function's machine code is read (the range kernel: ~40 KB)


def _require(tool: str) -> None:
    if shutil.which(tool) is None:
        sys.exit(f"profile_ensemble: '{tool}' not found on PATH (Linux perf and binutils are needed)")


def _kernel(method: str):
    from emorbit.integrators.dispatch import method_code
    from emorbit.kernels.pointmass import packed as ens

    methods = {
        "em": method_code("em"),
        "fast": method_code("em", "fast"),
        "midpoint": method_code("midpoint"),
        "leapfrog": method_code("leapfrog"),
    }
    if method not in methods:
        sys.exit(f"profile_ensemble: --method must be one of {sorted(methods)}, not {method!r}")
    return ens, methods[method]


def _functions(ens):
    """{entry address: name} of every compiled function of the ensemble module."""
    from numba.core.registry import CPUDispatcher

    out = {}
    for name, obj in vars(ens).items():
        if isinstance(obj, CPUDispatcher):
            for cres in obj.overloads.values():
                out[cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)] = name
    return out


def _mapped(start: int, size: int) -> int:
    """How many bytes from ``start`` (up to ``size``) lie in one readable mapping of this process."""
    with open("/proc/self/maps") as fh:
        for line in fh:
            lo, hi = (int(a, 16) for a in line.split()[0].split("-"))
            if lo <= start < hi and line.split()[1].startswith("r"):
                return min(size, hi - start)
    return 0


def _loops(rows):
    """(share, first, last) for every backward jump's range of rows (address, share, text)."""
    index = {a: i for i, (a, _, _) in enumerate(rows)}
    out = []
    for i, (a, _, text) in enumerate(rows):
        m = re.search(r"\bj[a-z]+\s+0x([0-9a-f]+)", text)
        if m and int(m.group(1), 16) < a and int(m.group(1), 16) in index:
            j = index[int(m.group(1), 16)]
            out.append((sum(r[1] for r in rows[j : i + 1]), j, i))
    return sorted(out, reverse=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--method", default="em", help="em, fast, midpoint or leapfrog (default em)")
    p.add_argument("--seconds", type=float, default=10.0, help="sampled run time (default 10)")
    p.add_argument("--n", type=int, default=100_000, help="particles (default 1e5)")
    p.add_argument("--steps", type=int, default=50, help="steps per kernel call (default 50)")
    p.add_argument("--top", type=int, default=12, help="loops to print (default 12)")
    p.add_argument("--annotate", metavar="FILE", help="write the annotated disassembly here")
    args = p.parse_args(argv)
    if args.seconds <= 0 or args.n < 64 or args.steps < 1:
        sys.exit("profile_ensemble: --seconds must be > 0, --n >= 64 and --steps >= 1")
    _require("perf")
    _require("objdump")

    from emorbit.bench.common import ENSEMBLE_DT, GM, ensemble_states
    from emorbit.integrators import coefficients

    ens, method = _kernel(args.method)
    x, v = ensemble_states(args.n)
    state = [np.array(x), np.array(v), np.zeros_like(x), np.zeros_like(v)]
    rec = (
        np.zeros((1, 3, args.n)),
        np.zeros((1, 3, args.n)),
        np.zeros((1, args.n), np.int64),
        np.full((args.n, 2), -1, np.int64),
    )
    gammas = coefficients(2)

    def call(steps):
        ens.ensemble_chunk(method, *state, GM, np.zeros(3), ENSEMBLE_DT, gammas, steps, 1, 50, *rec)

    call(2)  # compiles or loads the kernel
    with tempfile.TemporaryDirectory(prefix="emorbit-profile-") as tmp:
        data = os.path.join(tmp, "perf.data")
        perf = subprocess.Popen(
            ["perf", "record", "-q", "-e", "cpu-clock", "-F", "4000", "-p", str(os.getpid()), "-o", data],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        time.sleep(0.5)  # perf attaches
        start, steps = time.perf_counter(), 0
        while time.perf_counter() - start < args.seconds:
            call(args.steps)
            steps += args.steps
        elapsed = time.perf_counter() - start
        perf.send_signal(signal.SIGINT)
        _, err = perf.communicate(timeout=60)
        if not os.path.exists(data):
            sys.exit(
                f"profile_ensemble: perf recorded nothing ({err.decode().strip()[-300:]}); "
                "perf_event_paranoid may forbid it"
            )
        ips = subprocess.run(
            ["perf", "script", "-i", data, "-F", "ip"], capture_output=True, text=True, check=True
        ).stdout.split()
        counts = collections.Counter(int(ip, 16) for ip in ips)
        total = max(sum(counts.values()), 1)
        starts = sorted(_functions(ens).items())
        per_function = collections.Counter()
        for ip, n in counts.items():
            owner = [(a, name) for a, name in starts if a <= ip < a + CODE_BYTES]
            if owner:
                per_function[owner[-1]] += n
        print(
            f"{args.method}, {args.n} particles, {steps} steps in {elapsed:.1f} s: "
            f"{1e9 * elapsed / (steps * args.n):.2f} ns per particle-step (one thread, sampled); "
            f"{total} samples, {100.0 * sum(per_function.values()) / total:.1f} % in emorbit's ensemble kernels"
        )
        rows = []
        for (entry, name), n in per_function.most_common():
            if 100.0 * n / total < 1.0:
                continue
            nxt = [a for a, _ in starts if a > entry]
            size = _mapped(entry, min(CODE_BYTES, (nxt[0] - entry) if nxt else CODE_BYTES))
            code = os.path.join(tmp, f"{entry:x}.bin")
            with open(code, "wb") as fh:
                fh.write(ctypes.string_at(entry, size))
            asm = subprocess.run(
                ["objdump", "-D", "-b", "binary", "-m", "i386:x86-64", f"--adjust-vma={entry:#x}", code],
                capture_output=True,
                text=True,
                check=True,
            ).stdout
            fn_rows = []
            for line in asm.splitlines():
                m = re.match(r"\s*([0-9a-f]+):\s+(?:[0-9a-f]{2} )+\s*(.*)", line)
                if m:
                    a = int(m.group(1), 16)
                    fn_rows.append((a, 100.0 * counts.get(a, 0) / total, m.group(2)))
            print(f"\n{name} at {entry:#x}: {100.0 * n / total:.1f} % of the samples")
            print(f"{'share':>7} {'instructions':>12} {'div':>4} {'sqrt':>5} {'packed':>7}  rows of its disassembly")
            shown = []
            for share, j, i in _loops(fn_rows):
                if len(shown) >= args.top or share < 0.5:
                    break
                body = [t for _, _, t in fn_rows[j : i + 1]]
                shown.append((j, i))
                print(
                    f"{share:6.1f}% {len(body):>12} {sum('vdiv' in t for t in body):>4} "
                    f"{sum('sqrt' in t for t in body):>5} {sum('ymm' in t for t in body):>7}  {j}-{i}"
                )
            rows += [(name, k, r) for k, r in enumerate(fn_rows)]
    if args.annotate:
        with open(args.annotate, "w") as fh:
            for name, k, (a, share, text) in rows:
                fh.write(f"{name} {k:6d} {share:6.2f} {a:#x}  {text}\n")
        print(f"annotated disassembly: {args.annotate}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
