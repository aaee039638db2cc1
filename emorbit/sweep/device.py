"""Point masses on the GPU: route a :class:`~emorbit.Simulation`'s point masses through the
CUDA kernels of :mod:`emorbit.kernels.cuda`.

::

    sim = emorbit.load_scene("cloud.toml").build()
    use_device(sim, "gpu")          # InputError at once if no CUDA device is present
    sim.run(...)

Only the point masses move to the device (em, midpoint and leapfrog, every order); rigid
and elastic bodies of the same scene stay on the CPU. Worth it for large ensembles of test
particles: each chunk copies the state to the device and the records back.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..pointmasses import ChunkRecords

__all__ = ["use_device", "DEVICES"]

DEVICES = ("cpu", "gpu")


def use_device(sim, device: str = "gpu") -> None:
    """Advance ``sim``'s point masses on ``device`` ("gpu" or "cpu", the default path)."""
    if device not in DEVICES:
        raise InputError("device", f"must be one of {', '.join(DEVICES)}, got {device!r}")
    points = sim.points
    if device == "cpu":
        points.__dict__.pop("advance", None)  # back to the class's CPU kernels
        return
    from ..kernels import cuda as kcuda

    kcuda.require_device()
    if sim.method not in kcuda.METHODS:
        raise InputError("device", f"method {sim.method!r} has no CUDA kernel; use one of {', '.join(kcuda.METHODS)}")

    def advance(method, gm, center, dt, gammas, every, nrec, max_iter) -> ChunkRecords:
        n = len(points)
        rec = ChunkRecords(x=np.empty((nrec, 3, n)), v=np.empty((nrec, 3, n)),
                           iterations=np.zeros((nrec, n), dtype=np.int64), fail=np.full((n, 2), -1, dtype=np.int64))
        code = kcuda.METHOD_EM_PLAIN if method == "em" and points.roundoff == "fast" else kcuda.METHODS[method]
        kcuda.chunk(code, points.x, points.v, points.cx, points.cv, gm, center, dt, gammas, every,
                    nrec, max_iter, rec.x, rec.v, rec.iterations, rec.fail)
        return rec

    points.advance = advance
