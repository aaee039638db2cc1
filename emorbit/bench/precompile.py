"""Compile the point-mass kernels the bench times, on two cores at once, before anything is
timed.

Numba compiles one function at a time on one core, and with an empty cache (a first run
after installing, or after a kernel's source changed) compiling the kernels of the
``single`` and ``ensemble`` sections one after the other takes minutes. :func:`precompile`
splits them into two parts: a helper process (``python -m emorbit.bench.precompile PART
SECTION ...``) compiles one, this process the other, and the run waits for the helper
before its first timing, so no timing shares a core with a compilation. Each job calls the
bench's own runners (:class:`~.common.EmorbitRunner`, :class:`~.common.KernelRunner`) on a
few points for one step, so it compiles exactly the signatures the sections call; the
compiled code goes into Numba's cache, where the sections find it. With the cache filled
both parts only load their kernels.

The jobs of one method and roundoff are in one part, so the parts share no top-level
kernel; the small helpers both parts call may be compiled twice (at worst the later write
of a cache index wins and a kernel is compiled again when it is used: time, not results).
"""

from __future__ import annotations

import subprocess
import sys
import time

__all__ = ["precompile", "run_part"]

#: (part, section, kind, method, roundoff): a job compiles what the section will call, the
#: one-orbit kernel ("points", through PointMasses.advance) or the packed one ("range")
_JOBS = (
    (0, "single", "points", "em", "brouwer"),
    (0, "ensemble", "range", "em", "brouwer"),
    (0, "single", "points", "midpoint", "brouwer"),
    (1, "single", "points", "em", "fast"),
    (1, "ensemble", "range", "em", "fast"),
    (1, "single", "points", "leapfrog", "brouwer"),
    (1, "ensemble", "range", "leapfrog", "brouwer"),
)


def _run_job(kind: str, method: str, roundoff: str) -> None:
    from .common import ENSEMBLE_DT, PAPER_DT, PAPER_V0, PAPER_X0, EmorbitRunner, KernelRunner, ensemble_states

    if kind == "points":  # one orbit through PointMasses.advance: the _points_* kernel
        EmorbitRunner(PAPER_X0[:, None], PAPER_V0[:, None], method, 2, PAPER_DT, roundoff=roundoff)(1)
    else:  # the packed kernel on one thread and on all (a last block too small to pack)
        x, v = ensemble_states(3 * 64 + 2)
        for parallel in (False, True) if method != "leapfrog" else (False,):
            KernelRunner(x, v, method, 2, ENSEMBLE_DT, parallel, roundoff=roundoff)(1)


def run_part(part: int, sections) -> None:
    """Compile one part's jobs for the given sections.

    Parameters
    ----------
    part : int
        0 or 1.
    sections : sequence of str
        Section names; jobs of other sections are skipped.
    """
    for p, section, kind, method, roundoff in _JOBS:
        if p == part and section in sections:
            _run_job(kind, method, roundoff)


def precompile(sections) -> float | None:
    """Compile the kernels of the given sections in this process and a helper process at once.

    A helper that fails is ignored: the sections compile what is missing themselves.

    Parameters
    ----------
    sections : sequence of str
        Section names.

    Returns
    -------
    float or None
        The wall time it took, s; None where no section needs it.
    """
    if not any(section in sections for _, section, *_ in _JOBS):
        return None
    start = time.perf_counter()
    helper = subprocess.Popen(
        [sys.executable, "-m", "emorbit.bench.precompile", "1", *sections],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        run_part(0, sections)
    except BaseException:  # Ctrl-C or a failing job: do not leave the helper compiling
        helper.kill()
        helper.wait()
        raise
    helper.wait()
    return time.perf_counter() - start


def _main(argv) -> int:
    if not argv or argv[0] not in ("0", "1"):
        print(
            f"usage: python -m emorbit.bench.precompile PART SECTION ... (PART 0 or 1, got {argv[:1]})", file=sys.stderr
        )
        return 2
    run_part(int(argv[0]), argv[1:])
    return 0


if __name__ == "__main__":  # pragma: no cover - the helper process
    sys.exit(_main(sys.argv[1:]))
