"""The referees of the case ``torque-free`` (:mod:`.torque_free`): the Jacobi-elliptic period
of a torque-free rigid body, scipy's DOP853 on Euler's equations, emorbit's em runs, the flips'
location, and Exudyn's generalized-alpha solver on the same box.

Euler's equations of a torque-free body in principal axes, with the attitude quaternion q
(scalar first, body to space)::

    I w' = (I w) x w,     q' = q (x) (0, w) / 2,     2E = w.I w,     M^2 = |I w|^2.

Their solution is Jacobi's elliptic functions (Landau & Lifshitz, *Mechanics*, sec. 37): with
I1 < I2 < I3 and M^2 > 2E I2 (the tumble on the largest axis's side of the separatrix)::

    w1 = sqrt((2E I3 - M^2) / (I1 (I3 - I1))) cn tau,   w2 = sqrt((2E I3 - M^2) / (I2 (I3 - I2))) sn tau,
    w3 = sqrt((M^2 - 2E I1) / (I3 (I3 - I1))) dn tau,   tau = t sqrt((I3 - I2)(M^2 - 2E I1) / (I1 I2 I3)),
    k^2 = (I2 - I1)(2E I3 - M^2) / ((I3 - I2)(M^2 - 2E I1))

(for M^2 < 2E I2, exchange I1 and I3). The rates repeat after T = 4 K(k) / rate; the
intermediate-axis rate w2 (sn) changes sign every T/2: the flip interval. Near the separatrix
k -> 1, so K is evaluated from the complementary parameter k'^2 = 1 - k^2 =
(I3 - I1)(M^2 - 2E I2) / ((I3 - I2)(M^2 - 2E I1)) with ``scipy.special.ellipkm1``, and
M^2 - 2E I2 = I1 (I1 - I2) w1^2 + I3 (I3 - I2) w3^2 (w2 drops out exactly).

DOP853 integrates the same equations (the state (q, w), 7 numbers; the quaternion is not
renormalised) and locates the sign changes of w2 as events. emorbit runs through its public API,
recorded at every step; a sign change of a recorded rate is located on the cubic through the
four records around it. Exudyn runs through the wrapper of :mod:`emorbit.bench.rigid`
(``_Exudyn``: its rigid body with Euler-parameter or rotation-vector nodes, generalized-alpha
at its default spectral radius, the box ``FREE_BOX`` and ``FREE_OMEGA`` of
:mod:`emorbit.bench.rigid_cases`).

The data layout: every run is a :class:`~.body_case.Trajectory` with ``series`` ``w`` (m, 3)
body-frame rad/s, ``q`` (m, 4) (not for Exudyn), ``energy`` (m,) J and ``L`` (m, 3) kg m^2/s
in space.

References: L. D. Landau, E. M. Lifshitz, *Mechanics* (3rd ed., Pergamon 1976), sec. 37; E.
Hairer, S. P. Norsett, G. Wanner, *Solving Ordinary Differential Equations I* (Springer 1993),
sec. II.5 and II.10 (DOP853); J. Gerstmayr, Exudyn - a C++-based Python package for flexible
multibody systems, Multibody Syst. Dyn. 60 (2024) 533-561.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .body_case import BodyCase, Trajectory

__all__ = [
    "box_inertia",
    "jacobi_period",
    "run_referee",
    "run_em",
    "flip_times",
    "mean_interval",
    "exudyn_wrapper",
    "exudyn_version",
    "run_exudyn",
    "relative_errors",
]


# -- the analytic period ------------------------------------------------------------------------
def box_inertia(size, density) -> np.ndarray:
    """The principal moments of a homogeneous box.

    Parameters
    ----------
    size : sequence of 3 floats
        Edges (a, b, c), m.
    density : float
        kg/m^3.

    Returns
    -------
    ndarray
        m/12 (b^2 + c^2, a^2 + c^2, a^2 + b^2) (3,), kg m^2.
    """
    a, b, c = (float(x) for x in size)
    m = float(density) * a * b * c
    return m / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def jacobi_period(inertia, omega0) -> dict:
    """The period of a torque-free body's rates from the Jacobi-elliptic solution.

    Parameters
    ----------
    inertia : array_like
        The principal moments (3,), kg m^2, all different.
    omega0 : array_like
        The initial angular velocity in the principal axes (3,), rad/s.

    Returns
    -------
    dict
        ``period`` T = 4 K / rate (s, the period of the rates), ``flip`` T/2 (s, between sign
        changes of the intermediate-axis rate), ``k2c`` (k'^2 = 1 - k^2), ``K``, ``rate``
        (1/s), ``intermediate`` (the index of the intermediate axis) and ``regime`` (``"I3"``
        for M^2 > 2E I2, else ``"I1"``).

    Raises
    ------
    ValueError
        Moments that are not positive and different, a rate that is not finite, or a start on
        the separatrix (M^2 = 2E I2: the period is infinite).
    """
    I = np.asarray(inertia, float)
    w = np.asarray(omega0, float)
    if I.shape != (3,) or not np.all(I > 0) or len(set(I.tolist())) < 3:
        raise ValueError(f"inertia must be three different positive principal moments, got {inertia!r}")
    if w.shape != (3,) or not np.all(np.isfinite(w)):
        raise ValueError(f"omega0 must be three finite rates, got {omega0!r}")
    order = np.argsort(I)
    (I1, I2, I3), (w1, w2, w3) = I[order], w[order]
    d = I1 * (I1 - I2) * w1 * w1 + I3 * (I3 - I2) * w3 * w3  # M^2 - 2E I2, w2 drops out
    m_low = I2 * (I2 - I1) * w2 * w2 + I3 * (I3 - I1) * w3 * w3  # M^2 - 2E I1
    m_high = I1 * (I3 - I1) * w1 * w1 + I2 * (I3 - I2) * w2 * w2  # 2E I3 - M^2
    if d == 0:
        raise ValueError(f"omega0 {omega0!r} lies on the separatrix (M^2 = 2E I2): the period is infinite")
    if d > 0:
        rate2 = (I3 - I2) * m_low / (I1 * I2 * I3)
        k2c = (I3 - I1) * d / ((I3 - I2) * m_low)
    else:
        rate2 = (I2 - I1) * m_high / (I1 * I2 * I3)
        k2c = (I3 - I1) * (-d) / ((I2 - I1) * m_high)
    from scipy.special import ellipkm1

    K = float(ellipkm1(k2c))
    rate = math.sqrt(rate2)
    return {
        "period": 4.0 * K / rate,
        "flip": 2.0 * K / rate,
        "k2c": float(k2c),
        "K": K,
        "rate": rate,
        "intermediate": int(order[1]),
        "regime": "I3" if d > 0 else "I1",
    }


# -- DOP853 on Euler's equations and the quaternion --------------------------------------------
def _rhs(inertia):
    I = np.asarray(inertia, float)
    I1, I2, I3 = I

    def f(t, y):
        q, w = y[:4], y[4:]
        return np.array(
            [
                0.5 * (-q[1] * w[0] - q[2] * w[1] - q[3] * w[2]),
                0.5 * (q[0] * w[0] + q[2] * w[2] - q[3] * w[1]),
                0.5 * (q[0] * w[1] + q[3] * w[0] - q[1] * w[2]),
                0.5 * (q[0] * w[2] + q[1] * w[1] - q[2] * w[0]),
                (I2 - I3) * w[1] * w[2] / I1,
                (I3 - I1) * w[2] * w[0] / I2,
                (I1 - I2) * w[0] * w[1] / I3,
            ]
        )

    return f


def _invariants(inertia, q, w):
    """E (m,) and L (m, 3) in space of body rates w (m, 3) at attitudes q (m, 4)."""
    from emorbit.bodies.rotations import quaternion_to_matrix

    I = np.asarray(inertia, float)
    Iw = w * I
    return 0.5 * np.einsum("ni,ni->n", w, Iw), np.einsum("nij,nj->ni", quaternion_to_matrix(q), Iw)


def run_referee(inertia, omega0, times, rtol: float, t_end: float | None = None) -> Trajectory:
    """DOP853 on Euler's equations and the attitude quaternion, recorded at ``times``.

    Parameters
    ----------
    inertia : array_like
        The principal moments (3,), kg m^2 (the body axes are principal axes).
    omega0 : array_like
        The initial body rates (3,), rad/s; the attitude starts at the identity.
    times : array_like
        The record times, s, from 0.
    rtol : float
        DOP853's relative tolerance; the absolute tolerance is 1e-3 of it on the scales 1
        (quaternion) and |w0| (rates).
    t_end : float, optional
        The end of the solve (default the last record); the dense output covers it.

    Returns
    -------
    Trajectory
        ``series`` w, q, energy, L; ``info`` method, rtol, nfev, flips (the times w2 changes
        sign, from DOP853's event location), quaternion_norm_drift, and ``sol`` (the dense
        output, left out of the report).

    Raises
    ------
    RuntimeError
        DOP853 failed.
    """
    from scipy.integrate import solve_ivp

    I, w0 = np.asarray(inertia, float), np.asarray(omega0, float)
    times = np.asarray(times, float)
    t_end = float(times[-1] if t_end is None else t_end)
    k = int(np.argsort(I)[1])

    def crossing(t, y):
        return y[4 + k]

    scale = np.concatenate([np.ones(4), np.full(3, np.linalg.norm(w0))])
    start = time.perf_counter()
    sol = solve_ivp(
        _rhs(I),
        (0.0, t_end),
        np.concatenate([[1.0, 0.0, 0.0, 0.0], w0]),
        method="DOP853",
        t_eval=times,
        rtol=rtol,
        atol=1e-3 * rtol * scale,
        events=crossing,
        dense_output=True,
    )
    wall = time.perf_counter() - start
    if not sol.success:
        raise RuntimeError(f"DOP853 at rtol {rtol:g} failed: {sol.message}")
    q, w = sol.y[:4].T, sol.y[4:].T
    energy, L = _invariants(I, q, w)
    return Trajectory(
        f"DOP853, rtol {rtol:g}",
        sol.t,
        {"w": w, "q": q, "energy": energy, "L": L},
        wall,
        {
            "method": "DOP853",
            "rtol": rtol,
            "nfev": int(sol.nfev),
            "flips": [float(x) for x in sol.t_events[0]],
            "quaternion_norm_drift": float(np.abs(np.linalg.norm(q, axis=-1) - 1.0).max()),
            "sol": sol.sol,
        },
    )


# -- emorbit ----------------------------------------------------------------------------------
def run_em(case: BodyCase, order: int, dt: float, steps: int, label: str | None = None) -> Trajectory:
    """emorbit's em method on the box through the public API, recorded at every step.

    Parameters
    ----------
    case : BodyCase
        The case (``settings`` size, density, omega0).
    order : int
        The composition's order.
    dt : float
        The step, s.
    steps : int
        Steps to take.
    label : str, optional
        The run's label (default ``"em <order>, dt = <dt> s"``).

    Returns
    -------
    Trajectory
        ``series`` w, q, energy, L (every step); ``info`` method, order, dt_s, steps,
        newton_iterations, ns_per_particle_substep and ``inertia`` (of the mass points).
    """
    import emorbit

    s = case.settings
    sim = emorbit.Simulation(None, method="em", order=order, dt=dt)
    sim.add_rigid(
        "box",
        "box",
        size=list(s["size"]),
        density=s["density"],
        position=[0.0, 0.0, 0.0],
        velocity=[0.0, 0.0, 0.0],
        angular_velocity=list(s["omega0"]),
        angular_velocity_frame="body",
    )
    start = time.perf_counter()
    res = sim.run(steps=steps, every=1, progress=False).si
    wall = time.perf_counter() - start
    substeps = steps * {2: 1, 4: 3, 6: 7, 8: 15}.get(order, 1)
    return Trajectory(
        label or f"em {order}, dt = {dt:.6g} s",
        res.time,
        {
            "w": res.angular_velocities["box"],
            "q": res.attitudes["box"],
            "energy": res.energy,
            "L": res.angular_momentum,
        },
        wall,
        {
            "method": "em",
            "order": order,
            "dt_s": dt,
            "steps": steps,
            "newton_iterations": res.mean_newton_iterations(),
            "ns_per_particle_substep": 1e9 * wall / substeps,
            "inertia": sim.rigid.points[0].inertia,
        },
    )


def _local_root(t, y, s):
    """The zero of the cubic through the four records around the sign change between s and s+1."""
    lo = min(max(s - 1, 0), len(t) - 4)
    tt, yy = t[lo : lo + 4], y[lo : lo + 4]
    t0, h = t[s], t[s + 1] - t[s]
    c = np.polyfit((tt - t0) / h, yy, 3)
    roots = np.roots(c)
    roots = roots[np.isreal(roots)].real
    roots = roots[(roots >= -1e-9) & (roots <= 1 + 1e-9)]
    if roots.size == 0:  # not expected: fall back to the straight line
        return t0 - y[s] * h / (y[s + 1] - y[s])
    return t0 + h * float(roots[np.argmin(np.abs(roots - 0.5))])


def flip_times(t, w, axis: int) -> np.ndarray:
    """The times the rate about ``axis`` changes sign.

    Parameters
    ----------
    t : array_like
        Record times (m,), s.
    w : array_like
        Body rates (m, 3), rad/s.
    axis : int
        The axis (the intermediate one).

    Returns
    -------
    ndarray
        The sign changes, each the zero of the cubic through the four records around it, s.
    """
    t, y = np.asarray(t, float), np.asarray(w, float)[:, axis]
    s = np.nonzero(np.signbit(y[1:]) != np.signbit(y[:-1]))[0]
    return np.array([_local_root(t, y, int(i)) for i in s])


def mean_interval(times) -> float:
    """The mean interval of evenly spaced events.

    Parameters
    ----------
    times : array_like
        The events' times, s.

    Returns
    -------
    float
        The slope of a straight-line fit of the times against their number, s (nan for fewer
        than two events).
    """
    times = np.asarray(times, float)
    if times.size < 2:
        return math.nan
    return float(np.polyfit(np.arange(times.size), times, 1)[0])


# -- Exudyn -----------------------------------------------------------------------------------
def exudyn_wrapper():
    """The bench's Exudyn wrapper, or why it is missing.

    Returns
    -------
    tuple
        (``emorbit.bench.rigid._Exudyn``, None), or (None, "skipped: Exudyn not installed
        (<the import error>) ...") when Exudyn does not import.
    """
    from emorbit.bench.rigid import _Exudyn

    ex = _Exudyn()
    if ex.skipped:
        return None, ex.skipped.replace("skipped: Exudyn not importable", "skipped: Exudyn not installed", 1)
    return ex, None


def run_exudyn(ex, case: BodyCase, node: str, dt: float, steps: int, adaptive: bool) -> Trajectory:
    """Exudyn's generalized-alpha solver (its default spectral radius) on the same box.

    Parameters
    ----------
    ex : emorbit.bench.rigid._Exudyn
        The bench's wrapper (the box and w0 of :data:`emorbit.bench.rigid_cases.FREE_BOX`,
        ``FREE_OMEGA``: the case's).
    case : BodyCase
        The case.
    node : str
        ``"euler-parameters"`` or ``"rotation-vector"``.
    dt : float
        The step, s.
    steps : int
        Steps asked for.
    adaptive : bool
        Exudyn's step reduction when Newton fails (its default: on); off, a failed Newton stops
        the run.

    Returns
    -------
    Trajectory
        ``series`` w, energy, L at every step Exudyn took; ``info`` node, dt_s, steps (taken),
        adaptive, converged, failure, t_reached, min_step_s, inertia.
    """
    s = case.settings
    start = time.perf_counter()
    with ex.quiet():
        mbs, ss, solver, inertia, sens = ex.build(dt, steps, node, tuple(s["omega0"]), "generalized-alpha", True)
        ss.timeIntegration.adaptiveStep = bool(adaptive)
        ok, msg = ex.solve(mbs, ss, solver)
        wdata = np.asarray(mbs.GetSensorStoredData(sens[0]))
        Rdata = np.asarray(mbs.GetSensorStoredData(sens[1]))
        t_reached = float(mbs.systemData.GetTime())
    wall = time.perf_counter() - start
    t, w = wdata[:, 0], wdata[:, 1:4]
    R = Rdata[:, 1:10].reshape(-1, 3, 3)  # row-major
    Iw = w @ inertia.T
    energy = 0.5 * np.einsum("ni,ni->n", w, Iw)
    L = np.einsum("nij,nj->ni", R, Iw)
    return Trajectory(
        f"Exudyn gen-alpha {node}, dt = {dt:g} s{'' if adaptive else ', fixed step'}",
        t,
        {"w": w, "energy": energy, "L": L},
        wall,
        {
            "method": "generalized-alpha",
            "node": node,
            "dt_s": dt,
            "steps": int(t.size - 1),
            "steps_asked": steps,
            "adaptive": bool(adaptive),
            "converged": bool(ok),
            "failure": msg,
            "t_reached": t_reached,
            "min_step_s": float(np.diff(t).min()) if t.size > 1 else math.nan,
            "spectral_radius": ex.spectral_radius,
            "inertia": inertia,
        },
    )


def relative_errors(tr: Trajectory) -> tuple[float, float]:
    """The energy and angular-momentum errors of a run.

    Parameters
    ----------
    tr : Trajectory
        With ``series`` energy and L.

    Returns
    -------
    tuple of float
        max |E - E0| / E0 and max |L - L0| / |L0| over every record.
    """
    E, L = tr.series["energy"], tr.series["L"]
    return (
        float(np.abs(E - E[0]).max() / abs(E[0])),
        float(np.linalg.norm(L - L[0], axis=-1).max() / np.linalg.norm(L[0])),
    )


def exudyn_version() -> str:
    """Exudyn's version, as the bench reports it.

    Returns
    -------
    str
        The installed version (or what :func:`emorbit.bench.timing.package_version` says).
    """
    from emorbit.bench.timing import package_version

    return str(package_version("exudyn"))
