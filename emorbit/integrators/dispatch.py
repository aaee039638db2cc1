"""Which kernel runs a method: the one mapping from (method, roundoff, device) to a kernel.

Every caller that runs point masses (the bodies, sweeps, benchmarks) asks here; the body
kinds with one kernel per method (rigid, coupled) take :func:`method_code` alone.

==========  ==========  ==========================================================
device      steps       kernel
==========  ==========  ==========================================================
"cpu"       fixed       :func:`emorbit.kernels.pointmass.packed.ensemble_chunk`,
                        ``ensemble_chunk_parallel`` from ``PARALLEL_MIN`` points on
"cpu"       adaptive    :func:`emorbit.kernels.pointmass.adaptive.adaptive_chunk` through
                        :func:`adaptive_points` (tfe's composed step: one step of it)
"cpu"       fixed, tfe  :func:`emorbit.kernels.pointmass.tfe.tfe_chunk` through
                        :func:`tfe_chunk` (one point at a time, one thread)
"gpu"       fixed       :func:`emorbit.kernels.pointmass.cuda.chunk` (state copied in and
                        out per call), or the state kept on the device across chunks:
                        :class:`emorbit.kernels.pointmass.cuda_resident.DeviceEnsemble`
                        (:func:`point_ensemble`; what :class:`~emorbit.bodies.pointmasses.PointMasses` uses)
==========  ==========  ==========================================================

The order of a method does not pick a kernel: every kernel takes the step's coefficients
(:meth:`emorbit.integrators.Method.coefficients`) as an array, a composition's sub-step
fractions. The one exception is ``"tfe"``, whose order is its number of Gauss stages: its
coefficients are the stages' Gauss weights, :func:`tfe_chunk` reads the order from their
count and runs one step of 2 to 6 stages per step, with fixed steps or adaptive ones
(:func:`adaptive_points`). These run point masses in the central field alone, on the CPU
(point masses under effects, rigid bodies and structures have their own tfe paths); the
other paths refuse it naming their key.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..kernels import codes
from . import TFE_ORDERS, check_device, check_roundoff, gauss_weights, get_method

__all__ = [
    "method_code",
    "point_chunk",
    "point_ensemble",
    "adaptive_chunk",
    "require_device",
    "tfe_chunk",
    "tfe_tables",
    "adaptive_points",
]

_CODES = {
    "em": codes.METHOD_EM,
    "midpoint": codes.METHOD_MIDPOINT,
    "leapfrog": codes.METHOD_LEAPFROG,
    "tfe": codes.METHOD_TFE,
}
#: tfe's Gauss tables, by order
_TABLES: dict = {}


def _order_of(gammas) -> int | None:
    """The tfe order whose coefficients (Gauss weights, :meth:`~emorbit.integrators.Method.coefficients`)
    ``gammas`` are, or None."""
    g = np.asarray(gammas, dtype=float)
    order = 2 * g.size
    if g.ndim == 1 and order in TFE_ORDERS and np.array_equal(g, gauss_weights(g.size)):
        return order
    return None


def tfe_tables(gammas) -> np.ndarray:
    """The Gauss tables of the time finite element (``"tfe"``) whose order ``gammas`` says.

    ``gammas`` must be tfe's coefficients of its order (``get_method("tfe").coefficients(order)``:
    the weights of k = order / 2 Gauss stages): the step is one solve of those k stages
    (:func:`emorbit.kernels.pointmass.tfe.tables`).

    Raises
    ------
    InputError
        ``order``: any other coefficients.
    """
    order = _order_of(gammas)
    if order is None:
        raise InputError(
            "order",
            f"method 'tfe' runs at order {', '.join(map(str, TFE_ORDERS))} and takes its Gauss weights "
            f"(get_method('tfe').coefficients(order)); got {np.size(gammas)} coefficients",
        )
    if order in _TABLES:
        return _TABLES[order]
    from ..kernels.pointmass import tfe

    _TABLES[order] = tfe.tables(order)
    return _TABLES[order]


def tfe_chunk(code, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail):
    """Fixed steps of the time finite element (``"tfe"``) with the arguments of every
    point-mass chunk kernel (:func:`point_chunk`): one solve of 2 to 6 Gauss stages per step
    (:func:`emorbit.kernels.pointmass.tfe.tfe_chunk`, tables by :func:`tfe_tables`).
    ``rec_iters`` counts Newton iterations per step."""
    from ..kernels.pointmass import tfe

    tfe.tfe_chunk(
        tfe_tables(gammas), x, v, cx, cv, float(gm), np.ascontiguousarray(center, float), float(dt), int(every),
        int(nrec), int(max_iter), rec_x, rec_v, rec_iters, fail,
    )  # fmt: skip


def _refuse_tfe(name: str, key: str, what: str) -> None:
    if name == "tfe":
        raise InputError(key, f"method 'tfe' steps the central field alone, on the CPU; {what}")


def method_code(method: str, roundoff: str = "brouwer") -> int:
    """The kernels' code of a method.

    Parameters
    ----------
    method : str
        A name of :data:`~emorbit.integrators.METHODS`.
    roundoff : str
        A name of :data:`~emorbit.integrators.ROUNDOFF`: em with ``"fast"`` is
        :data:`~emorbit.kernels.codes.METHOD_EM_PLAIN`.

    Returns
    -------
    int
        A ``METHOD_*`` code of :mod:`emorbit.kernels.codes`.

    Raises
    ------
    InputError
        An unknown method or roundoff.
    """
    name = get_method(method).name
    if check_roundoff(roundoff) == "fast" and name == "em":
        return codes.METHOD_EM_PLAIN
    return _CODES[name]


def require_device(device: str) -> None:
    """Check that point masses can run on a device.

    Parameters
    ----------
    device : str
        A name of :data:`~emorbit.integrators.DEVICES`.

    Raises
    ------
    InputError
        They cannot (for ``"gpu"``: no CUDA target or device), saying why.
    """
    if check_device(device) == "gpu":
        from ..kernels.pointmass import cuda

        problem = cuda.device_problem()
        if problem is not None:
            raise InputError("device", problem)


def point_chunk(method: str, roundoff: str = "brouwer", device: str = "cpu", n: int = 0, parallel: bool | None = None):
    """The kernel that takes fixed steps of point masses, and its method code.

    Call it as ``chunk(code, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter,
    rec_x, rec_v, rec_iters, fail)``.

    Parameters
    ----------
    method : str
        A name of :data:`~emorbit.integrators.METHODS`.
    roundoff : str
        A name of :data:`~emorbit.integrators.ROUNDOFF`.
    device : str
        ``"cpu"`` or ``"gpu"``.
    n : int
        Number of points (picks the threading on the CPU).
    parallel : bool, optional
        On the CPU: the kernel on all of Numba's threads (True) or on one (False); None
        picks all threads from ``PARALLEL_MIN`` points on.

    Returns
    -------
    code : int
        The method code.
    chunk : callable
        The kernel.

    Raises
    ------
    InputError
        An unknown name, or a GPU that cannot be used.
    """
    code = method_code(method, roundoff)
    if code == codes.METHOD_TFE:
        _refuse_tfe("tfe" if check_device(device) != "cpu" else "", "device", f"got device {device!r}")
        return code, tfe_chunk
    if check_device(device) == "gpu":
        require_device(device)
        from ..kernels.pointmass import cuda

        return code, cuda.chunk
    from ..kernels.pointmass import packed

    if parallel is None:
        parallel = n >= packed.PARALLEL_MIN
    return code, packed.ensemble_chunk_parallel if parallel else packed.ensemble_chunk


def point_ensemble(device: str = "gpu"):
    """The class that keeps point masses on a device across chunks of fixed steps.

    Parameters
    ----------
    device : str
        ``"gpu"`` (the only device with one).

    Returns
    -------
    type
        :class:`emorbit.kernels.pointmass.cuda_resident.DeviceEnsemble`: built from (x, v,
        cx, cv), advanced with a method code (:func:`method_code`).

    Raises
    ------
    InputError
        An unknown device, the CPU (whose kernels take the host arrays), or a GPU that
        cannot be used.
    """
    if check_device(device) != "gpu":
        raise InputError("device", f"only the GPU keeps point masses resident, got device {device!r}")
    require_device(device)
    from ..kernels.pointmass import cuda_resident

    return cuda_resident.DeviceEnsemble


def adaptive_chunk(method: str, roundoff: str = "brouwer", device: str = "cpu"):
    """The kernel that takes adaptive steps of point masses, and its method code.

    See :mod:`emorbit.kernels.pointmass.adaptive`; adaptive steps run on the CPU only.

    Parameters
    ----------
    method : str
        A name of :data:`~emorbit.integrators.METHODS`.
    roundoff : str
        A name of :data:`~emorbit.integrators.ROUNDOFF`.
    device : str
        Must be ``"cpu"``.

    Returns
    -------
    code : int
        The method code.
    chunk : callable
        :func:`adaptive_points`: the kernel's arguments without its Gauss tables.

    Raises
    ------
    InputError
        An unknown name, or a device other than the CPU.
    """
    code = method_code(method, roundoff)
    if check_device(device) != "cpu":
        raise InputError("device", f"adaptive steps run on the CPU only, got device {device!r}")
    return code, adaptive_points


#: the tables that methods other than tfe hand the adaptive kernel (it does not read them)
_NO_TABLES = np.zeros((1, 5))
_ONE_STEP = np.ones(1)


def adaptive_points(
    code, x, v, cx, cv, rho, gm, center, interval, every, eta, gammas, nrec, max_iter, rec_x, rec_v, rec_iters,
    rec_steps, fail,
):  # fmt: skip
    """:func:`emorbit.kernels.pointmass.adaptive.adaptive_chunk` with the tables it needs: for
    tfe (``code`` METHOD_TFE) ``gammas`` (its Gauss weights) says the order, and the
    composed step is one step of its Gauss stages (:func:`tfe_tables`)."""
    from ..kernels.pointmass import adaptive

    tab, gammas = (tfe_tables(gammas), _ONE_STEP) if code == codes.METHOD_TFE else (_NO_TABLES, gammas)
    adaptive.adaptive_chunk(
        code, x, v, cx, cv, rho, float(gm), np.ascontiguousarray(center, float), float(interval), int(every),
        float(eta), np.ascontiguousarray(gammas, float), tab, int(nrec), int(max_iter), rec_x, rec_v, rec_iters,
        rec_steps, fail,
    )  # fmt: skip
