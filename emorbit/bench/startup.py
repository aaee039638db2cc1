"""Start-up: wall time of ``emorbit run paper-ellipse`` (10,000 em steps, records every 10,
an HDF5 file) in a fresh process, with an empty Numba cache (cold: every kernel the run
needs is compiled) and with that cache filled (warm: loaded). The cache is a new temporary
directory (``NUMBA_CACHE_DIR``), so the user's own cache is neither used nor touched.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

__all__ = ["run", "table"]


def _run_once(cache_dir: str, out: str) -> float:
    env = {**os.environ, "NUMBA_CACHE_DIR": cache_dir}
    cmd = [sys.executable, "-m", "emorbit.cli", "run", "paper-ellipse", "-o", out, "--overwrite", "-q"]
    start = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, capture_output=True)
    return time.perf_counter() - start


def run(cfg) -> dict:
    """Measure the section: one cold run, then ``cfg.warm_runs`` warm ones.

    Parameters
    ----------
    cfg : Config
        A configuration of :data:`emorbit.bench.common.CONFIGS`.

    Returns
    -------
    dict
        ``cold_s``, ``warm_s`` (the median) and the warm samples, s of wall time.
    """
    with tempfile.TemporaryDirectory(prefix="emorbit-bench-") as tmp:
        cache = os.path.join(tmp, "numba-cache")
        os.makedirs(cache)
        out = os.path.join(tmp, "paper.h5")
        cold = _run_once(cache, out)
        warm = [_run_once(cache, out) for _ in range(cfg.warm_runs)]
    return {
        "case": "emorbit run paper-ellipse -o OUT.h5 --overwrite -q (10,000 em steps), fresh process",
        "cold_s": cold,
        "warm_s": float(np.median(warm)),
        "warm_samples_s": warm,
    }


def table(section: dict) -> list[str]:
    """The section as printable lines.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.

    Returns
    -------
    list of str
        One line.
    """
    return [
        f"start-up: {section['case']}: cold (empty Numba cache) {section['cold_s']:.2f} s, "
        f"warm {section['warm_s']:.2f} s (median of {len(section['warm_samples_s'])})"
    ]
