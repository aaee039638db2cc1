"""What a sweep costs on each backend: wall time of the same sweep run serially, on local
processes and on a Dask LocalCluster, from the call to the written summary (start-up of
the workers included).

    python scripts/bench_sweep.py [--workers 2] [--json FILE]

Two sweeps of the paper's orbit (em, order 2): 200 runs of 5 to 10 steps each (the cost of
a run is the sweep's own overhead: scene, file, summary row) and 24 runs of 1e6 steps each
(about 0.2 s of stepping per run: the cost is the kernels', and the workers share it).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import tempfile
import time

DT = 0.464758


def sweep_text(steps: int, every: int, speeds: int, steps_sizes: int) -> str:
    """The paper's orbit with ``speeds`` speeds at aphelion x ``steps_sizes`` steps, ``steps`` steps each."""
    dts = ", ".join(f'"{DT * (1 + k / 10)!r} s"' for k in range(steps_sizes))
    return "\n".join(
        [
            "[sweep]",
            'scene = "paper-ellipse"',
            "[set]",
            f"integrator.output_every = {every}",
            f'integrator.t_end = "{steps * DT * (1 + (steps_sizes - 1) / 10)!r} s"',
            "[[parameter]]",
            'key = "integrator.dt"',
            f"values = [{dts}]",
            "[[parameter]]",
            'key = "body[satellite].velocity[1]"',
            f"range = {{ start = 0.30, stop = 0.40, num = {speeds} }}",
            'unit = "m / s"',
            "",
        ]
    )


TINY = sweep_text(steps=5, every=1, speeds=20, steps_sizes=10)  # 200 runs of 5 to 10 steps
LONG = sweep_text(steps=1_000_000, every=100_000, speeds=24, steps_sizes=1)  # 24 runs of 1e6 steps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()

    from emorbit.sweep import parse_sweep, run_sweep

    backends = ["serial", "process"]
    try:
        import distributed  # noqa: F401

        backends.append("dask")
    except ImportError:
        print("dask.distributed not installed: no Dask row")
    out = []
    root = tempfile.mkdtemp(prefix="bench_sweep_")
    try:
        # warm the kernel cache once, so no backend pays for compiling
        run_sweep(parse_sweep(TINY), os.path.join(root, "warm"), backend="serial")
        for name, text in (("200 runs x 5 steps", TINY), ("24 runs x 1e6 steps", LONG)):
            sweep = parse_sweep(text)
            for backend in backends:
                folder = os.path.join(root, f"{backend}-{len(sweep)}")
                start = time.perf_counter()
                res = run_sweep(sweep, folder, backend=backend, workers=args.workers)
                wall = time.perf_counter() - start
                stepping = sum(r["wall_time"] for r in res.rows)
                row = {
                    "sweep": name,
                    "backend": backend,
                    "workers": 1 if backend == "serial" else args.workers,
                    "runs": len(sweep),
                    "completed": res.counts["completed"],
                    "wall_s": round(wall, 2),
                    "runs_per_s": round(len(sweep) / wall, 1),
                    "sum_of_run_wall_s": round(stepping, 2),
                }
                out.append(row)
                print(
                    f"{name:22s} {backend:8s} workers {row['workers']}: {wall:6.2f} s wall, "
                    f"{row['runs_per_s']:7.1f} runs/s, runs' own wall time summed {stepping:6.2f} s"
                )
    finally:
        shutil.rmtree(root, ignore_errors=True)
    if args.json:
        meta = {"python": platform.python_version(), "cpus": os.cpu_count(), "load": os.getloadavg()}
        with open(args.json, "w") as fh:
            json.dump({"meta": meta, "rows": out}, fh, indent=1)


if __name__ == "__main__":
    main()
