"""Compile time and start-up of effect sets and shipped scenes: ``emorbit run`` in fresh processes.

Each case runs once with an empty kernel cache (``XDG_CACHE_HOME``, ``LOCALAPPDATA`` and, on
macOS, ``HOME`` point into a new temporary folder and ``NUMBA_CACHE_DIR`` is unset, so the
kernel cache of :func:`emorbit.kernels.jit.cache_dir` and the compiled effect sets of
:func:`~emorbit.effects.program.compile_set` go there; the user's own cache is neither used
nor touched), then warm. :func:`compile_rows` runs a short scene of two points in LEO per
effect set (compile time = cold - warm); :func:`scene_compile_rows` runs shipped scenes,
shortened to 20 steps, and measures the cold run's CPU time, the CPU time of a run whose
effect set's compiled module alone was removed (the set's own compile) and the warm start.
Python's bytecode cache is written as a warm install has it (``PYTHONDONTWRITEBYTECODE`` is
unset for the runs: an install compiles the bytecode, and without it every warm start compiles
about a hundred modules again). Beside the scenes, :func:`library_floor` times what the
libraries cost before emorbit does anything: a process that imports astropy's units and Numba
and readies Numba's CPU target (which loads SciPy's linear algebra), as a warm start must.
Part of the ``effects`` section (:mod:`.effects`).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

__all__ = ["SETS", "SCENES", "compile_rows", "scene_compile_rows", "library_floor"]

#: the effect sets of the start-up rows, each with the central field
SETS = (("central",), ("central", "zonal"), ("central", "mutual"), ("central", "zonal", "mutual"))
#: the shipped scenes whose cold compile and warm start the section times
SCENES = ("leo-drag-sunlight-moon-sun", "earth-j2-sun-synchronous", "three-body-figure-eight", "binary-asteroid")


def _cpu_children() -> float:
    """CPU seconds of this process's finished children (wall clock where there is no resource)."""
    try:
        import resource
    except ImportError:  # Windows
        return time.perf_counter()
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def scene_compile_rows(scenes=SCENES, warm_runs: int = 2) -> dict:
    """Cold and warm ``emorbit run`` of shipped scenes, shortened to 20 steps, in fresh processes.

    Parameters
    ----------
    scenes : sequence of str
        Shipped scene names.
    warm_runs : int
        Warm runs per scene (their median is the warm time).

    Returns
    -------
    dict
        ``scenes`` (one per scene: ``scene``, ``cold_cpu_s`` (the cold run's CPU time, an empty
        kernel cache: compiling every kernel the scene needs, the body kinds' step kernels
        included, as the first run after an install does), ``set_cpu_s`` (the CPU time of a
        run whose effect set's compiled module alone was removed from the cache: what a new
        effect set costs once the install's step kernels are cached), ``cold_s`` (wall),
        ``warm_s`` (wall, the median of the warm runs), ``warm_samples_s``), the case and
        ``floor_s`` (:func:`library_floor`, with as many runs).
    """
    import emorbit

    out = []
    with tempfile.TemporaryDirectory(prefix="emorbit-bench-scenes-") as tmp:
        for name in scenes:
            home = os.path.join(tmp, name)
            os.makedirs(home)
            env, h5 = _environment(home), os.path.join(tmp, f"{name}.h5")
            t_end = f"{20 * emorbit.load_scene(name).dt!r} s"
            cmd = [sys.executable, "-m", "emorbit.cli", "run", name, "-o", h5, "--overwrite", "-q", "--t-end", t_end]

            def once(cmd=cmd, env=env):
                cpu, start = _cpu_children(), time.perf_counter()
                subprocess.run(cmd, env=env, check=True, capture_output=True)
                return time.perf_counter() - start, _cpu_children() - cpu

            cold, cold_cpu = once()
            warm = [once()[0] for _ in range(warm_runs)]
            for folder, dirs, _ in os.walk(home):  # the effect set's compiled module, not the step kernels
                # <cache>/emorbit/numba/<install>/effects (kernels/effects beside it is the pieces' own cache)
                if (
                    os.path.basename(folder) == "effects"
                    and os.path.basename(os.path.dirname(os.path.dirname(folder))) == "numba"
                ):
                    shutil.rmtree(folder)
                    dirs.clear()
            _, set_cpu = once()
            out.append(
                {"scene": name, "cold_s": cold, "cold_cpu_s": cold_cpu, "set_cpu_s": set_cpu,
                 "warm_s": float(np.median(warm)), "warm_samples_s": warm}
            )  # fmt: skip
    return {
        "case": "emorbit run SCENE --t-end (20 steps) -o OUT.h5 --overwrite -q, fresh processes; cold: an empty "
        "kernel cache (a new temporary folder: every kernel the scene needs compiles), warm: the same cache filled",
        "scenes": out,
        "floor_s": library_floor(max(warm_runs, 1)),
    }


#: what every warm start runs before emorbit's own code: the libraries' imports, Numba's CPU
#: target readied as its first call (cached or not) does
_FLOOR = "import astropy.units, numba; from numba.core.registry import cpu_target; cpu_target.target_context.refresh()"


def library_floor(runs: int = 3) -> float:
    """The wall time of a fresh process that imports astropy's units and Numba and readies
    Numba's CPU target (the median of ``runs``), s: the part of a warm start that is not
    emorbit's."""
    env = _environment(tempfile.gettempdir())
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", _FLOOR], env=env, check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


_SCENE = """[field]
body = "earth"

[integrator]
method = "em"
dt = "10 s"
t_end = "1000 s"
output_every = 10
{effects}
[[body]]
name = "a"
kind = "point"
mass = "1000 kg"
orbit = {{a = "7000 km", e = 0.001, i = "98 deg"}}

[[body]]
name = "b"
kind = "point"
mass = "1000 kg"
orbit = {{a = "7000 km", e = 0.001, i = "98 deg", nu = "0.01 rad"}}
"""
_TABLES = {
    "zonal": '\n[[effect]]\nkind = "zonal"\nmodel = "earth"\ndegree = 2\n',
    "mutual": '\n[[effect]]\nkind = "mutual"\n',
}


def _environment(home: str) -> dict:
    """The environment of a run whose every kernel cache lies under ``home``, its Python
    bytecode cached as in an install."""
    drop = ("NUMBA_CACHE_DIR", "EMORBIT_JIT_CACHE", "PYTHONDONTWRITEBYTECODE")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env["XDG_CACHE_HOME"] = os.path.join(home, "cache")
    env["LOCALAPPDATA"] = os.path.join(home, "local")
    if sys.platform == "darwin":
        env["HOME"] = home
    return env


def _run_scene(scene: str, out: str, env: dict) -> float:
    cmd = [sys.executable, "-m", "emorbit.cli", "run", scene, "-o", out, "--overwrite", "-q"]
    start = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, capture_output=True)
    return time.perf_counter() - start


def compile_rows(sets=SETS, warm_runs: int = 2) -> dict:
    """Cold and warm ``emorbit run`` of a short scene per effect set, each in fresh processes.

    Parameters
    ----------
    sets : sequence of tuple of str
        Effect sets, each starting with ``"central"``.
    warm_runs : int
        Warm runs per set (their median is the warm time).

    Returns
    -------
    dict
        ``sets`` (one per set: ``effects``, ``cold_s``, ``warm_s``, ``warm_samples_s``,
        ``compile_s`` = cold - warm, ``compile_over_central_s`` where the central-only set
        ran, ``cache_files``: the files the cold run left in the temporary cache) and the case.
    """
    out = []
    with tempfile.TemporaryDirectory(prefix="emorbit-bench-effects-") as tmp:
        for kinds in sets:
            name = "_".join(kinds)
            scene = os.path.join(tmp, f"{name}.toml")
            with open(scene, "w") as f:
                f.write(_SCENE.format(effects="".join(_TABLES[k] for k in kinds if k != "central")))
            home = os.path.join(tmp, name)
            os.makedirs(home)
            env, h5 = _environment(home), os.path.join(tmp, f"{name}.h5")
            cold = _run_scene(scene, h5, env)
            files = sum(len(f) for _, _, f in os.walk(home))
            warm = [_run_scene(scene, h5, env) for _ in range(warm_runs)]
            w = float(np.median(warm))
            out.append(
                {"effects": list(kinds), "cold_s": cold, "warm_s": w, "warm_samples_s": warm, "compile_s": cold - w,
                 "cache_files": files}
            )  # fmt: skip
    central = next((s["compile_s"] for s in out if s["effects"] == ["central"]), None)
    for s in out:
        if central is not None:
            s["compile_over_central_s"] = s["compile_s"] - central
    return {
        "case": "emorbit run SCENE -o OUT.h5 --overwrite -q: two points in LEO, 100 em steps, fresh process; "
        "cold: empty kernel cache (a new temporary folder), warm: the same cache filled",
        "sets": out,
    }
