"""Point-mass ensembles on the GPU: the kernel alone against the paths that use it
(``emorbit bench --only gpu``; formerly ``scripts/bench_gpu.py``).

Test particles on random orbits (a in [4, 10], e up to 0.9, start at apoapsis, random
planes) around GM = 3.9478, em (and leapfrog in the full configuration) at orders 2 and 8,
dt = T/1000 of the widest orbit, ``steps`` steps per call and one record at its end. Rows, in
point-steps per second (warm: compiled and run once before timing; median of the repeats):

* gpu kernel     the kernel alone on device-resident arrays (NVVM -fma=0), no copies
* gpu chunk      :func:`emorbit.kernels.pointmass.cuda.chunk`: the state copied in and the
                 records out on every call (what ``Simulation`` used before the resident path)
* gpu resident   :meth:`emorbit.bodies.pointmasses.PointMasses.advance` with ``device = "gpu"``,
                 as ``Simulation`` calls it: the state stays on the device
                 (:mod:`emorbit.kernels.pointmass.cuda_resident`), the records come back in
                 pinned buffers
* cpu ensemble   :func:`emorbit.kernels.pointmass.packed.ensemble_chunk_parallel`, all threads

The target: the resident path >= 50 % of the kernel alone, em order 2, at 1e6 points.
Without a CUDA device, or on numba's CUDA simulator (which runs the device code as Python),
the section measures nothing and reports ``skipped`` with the reason; it never fails.
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ["CONFIGS", "TARGET", "TARGET_POINTS", "skip_reason", "run", "table"]

#: points, orders, steps per call, repeats and methods per configuration
CONFIGS = {
    "tiny": {"points": [4096], "orders": [2], "steps": 10, "repeats": 1, "methods": ["em"]},
    "quick": {"points": [1_000_000], "orders": [2, 8], "steps": 100, "repeats": 3, "methods": ["em"]},
    "full": {
        "points": [1_000_000, 10_000_000],
        "orders": [2, 8],
        "steps": 100,
        "repeats": 5,
        "methods": ["em", "leapfrog"],
    },
}
#: the resident path's throughput over the kernel's, at least (em order 2, :data:`TARGET_POINTS` points)
TARGET = 0.5
#: the ensemble size the target is measured at
TARGET_POINTS = 1_000_000


def skip_reason() -> str | None:
    """Why nothing can be measured here (no CUDA device, or the simulator), or None."""
    from ..kernels.pointmass import cuda as kcuda

    problem = kcuda.device_problem()
    if problem is None and kcuda._simulator():
        return "numba's CUDA simulator (NUMBA_ENABLE_CUDASIM=1) runs the device code as Python: no GPU to time"
    return problem


def ensemble(n: int, seed: int = 3):
    """(gm, x, v, dt): n test particles on random orbits, dt = T/1000 of the widest one."""
    gm = 3.9478
    rng = np.random.default_rng(seed)
    a = rng.uniform(4.0, 10.0, n)
    e = rng.uniform(0.0, 0.9, n)
    r = a * (1 + e)  # start at apoapsis
    vt = np.sqrt(gm / a * (1 - e) / (1 + e))
    phi = rng.uniform(0, 2 * np.pi, n)
    inc = rng.uniform(0, np.pi, n)
    x = np.vstack([r * np.cos(phi), r * np.sin(phi), np.zeros(n)])
    v = np.vstack([-vt * np.sin(phi) * np.cos(inc), vt * np.cos(phi) * np.cos(inc), vt * np.sin(inc)])
    period = 2 * np.pi * np.sqrt(10.0**3 / gm)
    return gm, np.ascontiguousarray(x), np.ascontiguousarray(v), period / 1000


def _timed(fn, repeats: int) -> float:
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _target(rows: list, reason: str | None) -> dict:
    out = {
        "target": (
            f"GPU resident path >= {TARGET:.0%} of the kernel's point-steps/s (em order 2, {TARGET_POINTS:.0e} points)"
        ),
        "measured": None,
        "limit": TARGET,
        "met": None,
    }
    row = next((r for r in rows if r["method"] == "em" and r["order"] == 2 and r["points"] == TARGET_POINTS), None)
    if reason is not None:
        out["note"] = f"skipped: {reason}"
    elif row is None:
        out["note"] = f"skipped: this configuration has no em order-2 row at {TARGET_POINTS} points"
    else:
        out["measured"] = row["resident_over_kernel"]
        out["met"] = bool(out["measured"] >= TARGET)
    return out


def _rows(cfg: dict) -> list:
    """Measure every row (a CUDA device is present)."""
    return [_row(n, method, order, cfg) for n in cfg["points"] for method in cfg["methods"] for order in cfg["orders"]]


def _row(n: int, method: str, order: int, cfg: dict) -> dict:
    """The four rows of one ensemble size, method and order, point-steps/s (steps of the
    composed method), and the ratios to the kernel."""
    from ..bodies.pointmasses import PointMasses
    from ..integrators import coefficients
    from ..integrators.dispatch import method_code
    from ..kernels.pointmass import cuda as kcuda
    from ..kernels.pointmass import packed

    cuda, kernels = kcuda._compile()
    gammas, steps, center = coefficients(order), cfg["steps"], np.zeros(3)
    gm, x0, v0, dt = ensemble(n)
    code = method_code(method)

    def arrays():
        state = [x0.copy(), v0.copy(), np.zeros((3, n)), np.zeros((3, n))]
        rec = [np.empty((1, 3, n)), np.empty((1, 3, n)), np.zeros((1, n), np.int64), np.full((n, 2), -1, np.int64)]
        return state, rec

    a, rec = arrays()
    dev = [cuda.to_device(q) for q in a + rec]
    d_center, d_gammas = cuda.to_device(center), cuda.to_device(gammas)
    blocks = (n + kcuda.THREADS_PER_BLOCK - 1) // kcuda.THREADS_PER_BLOCK

    def kernel():
        common = (np.float64(gm), d_center, np.float64(dt), d_gammas, steps, 1, 50)
        kernels[code][blocks, kcuda.THREADS_PER_BLOCK](*dev[:4], *common, *dev[4:])
        cuda.synchronize()

    def chunk():
        a, rec = arrays()
        kcuda.chunk(code, *a, gm, center, dt, gammas, steps, 1, 50, *rec)

    points = PointMasses()
    points.names = [f"p{i}" for i in range(n)]
    points.masses, points.x, points.v = np.ones(n), x0.copy(), v0.copy()
    points.cx, points.cv = np.zeros((3, n)), np.zeros((3, n))
    points.plan = points.plan.with_(device="gpu")

    def resident():  # as Simulation calls it: one chunk of one record, the state stays on the device
        points.advance(method, gm, center, dt, gammas, steps, 1, 50)

    def cpu():
        a, rec = arrays()
        packed.ensemble_chunk_parallel(code, *a, gm, center, dt, gammas, steps, 1, 50, *rec)

    row = {"points": n, "method": method, "order": order, "steps": steps}
    for name, fn in (("gpu kernel", kernel), ("gpu chunk", chunk), ("gpu resident", resident), ("cpu ensemble", cpu)):
        row[name] = n * steps / _timed(fn, cfg["repeats"])
    row["resident_over_kernel"] = row["gpu resident"] / row["gpu kernel"]
    row["chunk_over_kernel"] = row["gpu chunk"] / row["gpu kernel"]
    return row


def run(cfg=None, *, config: str | None = None) -> dict:
    """Measure the section, or say why it is skipped.

    Parameters
    ----------
    cfg : object, optional
        Unused (the point-mass sections' :class:`~emorbit.bench.common.Config`).
    config : str, optional
        ``"full"``, ``"quick"`` or ``"tiny"``: a name of :data:`CONFIGS` (default ``"quick"``).

    Returns
    -------
    dict
        JSON-ready: ``device`` (the card's name, or None), ``skipped`` (the reason, or None),
        ``rows`` (per ensemble size and method: point-steps/s of each row, and
        ``resident_over_kernel``) and ``targets`` (one: the resident path against the kernel).
    """
    settings = CONFIGS[config or "quick"]
    reason = skip_reason()
    device, rows = None, []
    if reason is None:
        from numba import cuda

        name = cuda.get_current_device().name
        device = name.decode() if isinstance(name, bytes) else str(name)
        rows = _rows(settings)
    return {"device": device, "skipped": reason, "rows": rows, "targets": [_target(rows, reason)], **settings}


def table(section: dict) -> list[str]:
    """The section's lines as ``emorbit bench`` prints them.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.

    Returns
    -------
    list of str
        The lines.
    """
    if section["skipped"] is not None:
        return [f"gpu: skipped: {section['skipped']}"]
    lines = [
        f"gpu: point-mass ensembles on {section['device']}, {section['steps']} steps per call, one record "
        "(point-steps/s)",
        f"  {'points':>9} {'method':8} {'order':>5} {'kernel':>10} {'chunk':>10} {'resident':>10} {'cpu':>10} "
        f"{'resident/kernel':>16}",
    ]
    for r in section["rows"]:
        lines.append(
            f"  {r['points']:9d} {r['method']:8} {r['order']:5d} {r['gpu kernel']:10.3e} {r['gpu chunk']:10.3e} "
            f"{r['gpu resident']:10.3e} {r['cpu ensemble']:10.3e} {r['resident_over_kernel']:16.1%}"
        )
    return lines
