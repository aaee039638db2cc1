"""Point-mass ensemble throughput on the GPU: a wrapper of ``emorbit bench --only gpu``.

    python scripts/bench_gpu.py [--quick] [--json FILE]

The rows (the kernel alone, the copy-every-chunk path, the resident path Simulation uses,
the CPU ensemble) and the target are those of :mod:`emorbit.bench.gpu`. Without a CUDA
device the section says "skipped" and why.
"""

from __future__ import annotations

import argparse


def main() -> int:
    """Run the bench's gpu section (full configuration unless ``--quick``)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1e6 points and em only")
    ap.add_argument("--json", help="write the figures, the machine and the target as JSON")
    args = ap.parse_args()

    from emorbit.bench.runner import run_bench

    return run_bench(["gpu"], quick=args.quick, json_path=args.json)


if __name__ == "__main__":
    raise SystemExit(main())
