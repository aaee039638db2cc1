"""The referees of the libration cases (:mod:`.libration`): the linear and the pendulum theory of
the gravity-gradient libration, the measurements of a period and of frequencies from records,
the attitude invariant K, and the runs of emorbit's em and of Basilisk.

Axes. The orbit frame (LVLH) of a record is e_r = x / |x| (radial), e_n = x cross v / |x cross v|
(orbit normal) and e_t = e_n cross e_r (along track). The box's body axes coincide with it at the
equilibrium: body x radial (the yaw axis, the smallest moment I_yaw = 52.08 kg m^2), body y
along track (the roll axis, I_roll = 177.08 kg m^2), body z normal (the pitch axis, the largest
moment I_pitch = 208.33 kg m^2). With R the attitude (body to space) and L = [e_r e_t e_n], the
rotation vector of C = L^T R gives yaw (about e_r), roll (about e_t) and pitch (about e_n). The
usual LVLH frame (yaw towards nadir, pitch along the negative normal) flips signs of axes,
which leaves every frequency below unchanged.

Theory (first order in size / r: the torque 3 n^2 c x I c, c the radial unit vector in body axes;
Hughes, *Spacecraft Attitude Dynamics*, ch. 9; Kaplan, *Modern Spacecraft Dynamics and
Control*)::

    pitch:    I_pitch theta'' + (3/2) n^2 (I_roll - I_yaw) sin 2 theta = 0
              linear: w_pitch = n sqrt(3 (I_roll - I_yaw) / I_pitch)            (sqrt(3) n for a radial dumbbell)
              finite amplitude (a pendulum in 2 theta):  P = 4 K(k) / w_pitch,  k = sin theta0
                  (Landau & Lifshitz, *Mechanics*, sec. 11, problem 1; scipy.special.ellipk(k^2))
    roll-yaw (roll phi, yaw psi, in the usual LVLH axes):
              I_roll phi'' + 4 n^2 (I_pitch - I_yaw) phi - n (I_roll - I_pitch + I_yaw) psi' = 0
              I_yaw psi'' + n^2 (I_pitch - I_roll) psi + n (I_roll - I_pitch + I_yaw) phi' = 0
              k_R = (I_pitch - I_yaw) / I_roll,  k_Y = (I_pitch - I_roll) / I_yaw
              (s / n)^4 + (1 + 3 k_R + k_R k_Y) (s / n)^2 + 4 k_R k_Y = 0  (Hughes ch. 9, eq. for the roll-yaw modes)
              w^2 = n^2 (b -+ sqrt(b^2 - 16 k_R k_Y)) / 2,  b = 1 + 3 k_R + k_R k_Y

The box's k_R = 0.882, k_Y = 0.600 lie in the Lagrange region (I_pitch > I_roll > I_yaw):
w_pitch = sqrt(1.8) n = 1.3416 n, and the roll-yaw modes 1.8937 n and 0.7685 n.

The theory's truncation: the mass points' torque differs from the first-order torque by terms
relative (size / r)^2 = 8e-14 (the box is centrally symmetric: the (size / r) term vanishes), and
so does the centre's orbit (the body's own quadrupole makes it eccentric by 1e-13): both lie far
below what the checks resolve. The pendulum is exact for a planar libration at the first order;
the linear pitch theory's truncation is the pendulum's amplitude correction 1 - pi / (2 K(k)),
theta0^2 / 4 to leading order; the roll-yaw frequencies at offsets eps carry a correction
A eps^2, which two runs at eps and 2 eps remove (f0 = (4 f(eps) - f(2 eps)) / 3).

Measurements. The pitch period is twice the slope of a straight line through the zero
crossings of the pitch angle (each found on the cubic through the four records around it); its
standard error is the fit's. The roll-yaw frequencies are fitted to the roll and the yaw series
together: two frequencies, each series a sum of cos and sin of both plus a constant, the
amplitudes by linear least squares for given frequencies (variable projection), the
frequencies by ``scipy.optimize.least_squares`` started at the two largest peaks of the
zero-padded Fourier spectrum.

Basilisk (``bsk``, when installed): a ``Spacecraft`` hub with the box's mass and analytic
inertia, the same GM as a point-mass central body, its ``GravityGradientEffector`` (first
order), RK4, the same initial state (attitude as modified Rodrigues parameters, body rates
R^T n z). Where it does not import, :func:`basilisk_missing` says why.

Conservation. em keeps the energy E and the angular momentum L about the Earth's centre at
round-off, relative to the terms that cancel (T + |V| and sum m |x| |v| + |I w|, dominated by the
orbit). The attitude's share of E is 1e-14 of it, so E says nothing about the attitude: the
cases also follow K = E - n L_z (conserved since E and L are) written without the orbit's
cancelling terms::

    K = m (|u|^2 / 2 + n^2 (z^2 / 2 - d^2 / 2 - r0 d^2 / |x|)) + w.I w / 2 - n e_z.(R I w)
        - (GM / |x|) sum_i m_i sum_{l=2..4} (|X_i| / |x|)^l P_l(-c.R X_i / |X_i|),

u = v - n e_z x x, d = |x| - r0 (the orbit's part, second order in its departure from the
circle: exact), the last sum the mass points' potential beyond the centre's (Legendre series;
its remainder is (size / r)^3 = 2e-20 of its first term or less).

Data layout: every run is a :class:`~.body_case.Trajectory` recorded at every step; ``series``
holds ``angles`` (m, 3) (yaw, roll, pitch) rad, for em runs also ``energy``, ``angular_momentum``
and ``K`` (m,) relative changes from the start and the raw records ``x``, ``v`` (m, 3) m, m/s,
``w`` (m, 3) body-frame rad/s and ``R`` (m, 3, 3) body to space, for Basilisk runs ``torque0``
(3,) N m at t = 0 (body frame).

References: P. C. Hughes, *Spacecraft Attitude Dynamics* (Wiley 1986; Dover 2004), ch. 9;
M. H. Kaplan, *Modern Spacecraft Dynamics and Control* (Wiley 1976); L. D. Landau,
E. M. Lifshitz, *Mechanics* (3rd ed., Pergamon 1976), sec. 11; P. W. Kenneally, S. Piggott,
H. Schaub, "Basilisk: a flexible, scalable and modular astrodynamics simulation framework",
J. Aerospace Information Systems 17 (2020) 496-507; P. Betsch, P. Steinmann, Int. J. Numer.
Meth. Engng. 50 (2001) 1137-1157 (emorbit's director step).
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import checks as C
from .body_case import Trajectory

__all__ = [
    "orbit_rate",
    "referee_inertia",
    "principal_moments",
    "pitch_frequency",
    "pendulum_period",
    "roll_yaw_frequencies",
    "lvlh_angles",
    "zero_crossings",
    "libration_period",
    "spectrum",
    "fit_modes",
    "attitude_invariant",
    "run_em",
    "em_torque",
    "basilisk_modules",
    "basilisk_missing",
    "run_basilisk",
    "amplitude_key",
]


# -- theory -------------------------------------------------------------------------------------------
def orbit_rate(gm: float, radius: float) -> float:
    """The mean motion of a circular orbit.

    Parameters
    ----------
    gm : float
        GM, m^3/s^2.
    radius : float
        The orbit's radius, m.

    Returns
    -------
    float
        n = sqrt(GM / r^3), rad/s.
    """
    return math.sqrt(gm / radius**3)


def referee_inertia(size, density) -> np.ndarray:
    """The referee's inertia: the analytic inertia of a homogeneous box about its centre.

    Parameters
    ----------
    size : sequence of 3 floats
        The edges along the body axes x, y, z, m.
    density : float
        kg/m^3.

    Returns
    -------
    ndarray
        (3, 3) m/12 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2), kg m^2.
    """
    from emorbit.bench.rigid_cases import box_inertia

    return box_inertia(list(size), density)


def principal_moments(inertia) -> tuple[float, float, float]:
    """(I_roll, I_pitch, I_yaw) of an inertia in emorbit's body axes at the equilibrium.

    Body x is radial (yaw), y along track (roll), z the orbit normal (pitch).

    Parameters
    ----------
    inertia : array_like
        (3, 3) kg m^2, diagonal in the body axes.

    Returns
    -------
    tuple of float
        I_roll = I_yy, I_pitch = I_zz, I_yaw = I_xx, kg m^2.
    """
    I = np.asarray(inertia, float)
    return float(I[1, 1]), float(I[2, 2]), float(I[0, 0])


def pitch_frequency(n: float, inertia) -> float:
    """The linear pitch libration frequency n sqrt(3 (I_roll - I_yaw) / I_pitch).

    Parameters
    ----------
    n : float
        The orbit rate, rad/s.
    inertia : array_like
        (3, 3) kg m^2 in the body axes of :func:`principal_moments`.

    Returns
    -------
    float
        rad/s.

    Raises
    ------
    ValueError
        I_roll <= I_yaw: the radial orientation is not stable in pitch.
    """
    roll, pitch, yaw = principal_moments(inertia)
    if not roll > yaw:
        raise ValueError(f"inertia: I_roll = {roll:g} must exceed I_yaw = {yaw:g} kg m2 for a stable pitch libration")
    return n * math.sqrt(3.0 * (roll - yaw) / pitch)


def pendulum_period(n: float, inertia, theta0: float) -> float:
    """The pitch period at amplitude theta0: 4 K(sin theta0) / w_pitch (a pendulum in 2 theta).

    ``n`` and ``inertia`` are those of :func:`pitch_frequency`; ``theta0`` (rad) lies in (0, pi/2)
    (at pi/2 the body tumbles), else ValueError. Returns the period, s.
    """
    from scipy.special import ellipk

    if not 0.0 < theta0 < math.pi / 2:
        raise ValueError(f"theta0 must lie in (0, pi/2) rad, got {theta0!r}")
    return 4.0 * float(ellipk(math.sin(theta0) ** 2)) / pitch_frequency(n, inertia)


def roll_yaw_frequencies(n: float, inertia) -> dict:
    """The two linear roll-yaw frequencies from the characteristic equation (Hughes ch. 9).

    (s/n)^4 + b (s/n)^2 + 4 k_R k_Y = 0 with b = 1 + 3 k_R + k_R k_Y,
    k_R = (I_pitch - I_yaw) / I_roll, k_Y = (I_pitch - I_roll) / I_yaw.

    ``n`` and ``inertia`` are those of :func:`pitch_frequency`.

    Returns
    -------
    dict
        ``fast`` and ``slow`` (rad/s), ``k_roll`` and ``k_yaw``.

    Raises
    ------
    ValueError
        Inertias for which the roll-yaw motion is not a stable libration (k_R k_Y <= 0, or
        b^2 <= 16 k_R k_Y, or b <= 0).
    """
    roll, pitch, yaw = principal_moments(inertia)
    kr, ky = (pitch - yaw) / roll, (pitch - roll) / yaw
    b, c = 1.0 + 3.0 * kr + kr * ky, 4.0 * kr * ky
    if not (c > 0 and b > 0 and b * b > 4 * c):
        raise ValueError(
            f"inertia: k_R = {kr:.6g}, k_Y = {ky:.6g} give no stable roll-yaw libration (need k_R k_Y > 0, "
            "1 + 3 k_R + k_R k_Y > 4 sqrt(k_R k_Y))"
        )
    disc = math.sqrt(b * b - 4.0 * c)
    return {
        "fast": n * math.sqrt((b + disc) / 2.0),
        "slow": n * math.sqrt((b - disc) / 2.0),
        "k_roll": kr,
        "k_yaw": ky,
    }


# -- measurements ----------------------------------------------------------------------------------------
def lvlh_angles(x, v, body_to_space) -> np.ndarray:
    """The attitude in the orbit frame: the rotation vector of C = L^T R per record.

    Parameters
    ----------
    x, v : array_like
        (m, 3) the centre's position and velocity, m and m/s (relative to the field's centre).
    body_to_space : array_like
        (m, 3, 3) attitude matrices R (body components to space components).

    Returns
    -------
    ndarray
        (m, 3) rad: yaw (about the radial e_r), roll (about the along-track e_t), pitch (about
        the normal e_n).
    """
    from scipy.spatial.transform import Rotation

    x, v = np.asarray(x, float), np.asarray(v, float)
    er = x / np.linalg.norm(x, axis=-1)[:, None]
    h = np.cross(x, v)
    en = h / np.linalg.norm(h, axis=-1)[:, None]
    et = np.cross(en, er)
    L = np.stack([er, et, en], axis=-1)
    return Rotation.from_matrix(np.swapaxes(L, -1, -2) @ np.asarray(body_to_space, float)).as_rotvec()


def zero_crossings(t, y) -> np.ndarray:
    """The times where y changes sign, each a root of the cubic through the 4 records around it.

    Parameters
    ----------
    t, y : array_like
        (m,) record times (s) and values.

    Returns
    -------
    ndarray
        The crossing times, s, ascending.
    """
    t, y = np.asarray(t, float), np.asarray(y, float)
    out = []
    for i in np.flatnonzero(np.signbit(y[:-1]) != np.signbit(y[1:])):
        j = min(max(i - 1, 0), len(y) - 4)
        h = t[i + 1] - t[i]
        roots = np.roots(np.polyfit((t[j : j + 4] - t[i]) / h, y[j : j + 4], 3))
        roots = roots[np.abs(roots.imag) < 1e-12].real
        roots = roots[(roots >= -1e-9) & (roots <= 1 + 1e-9)]
        if roots.size:
            out.append(t[i] + h * roots[np.argmin(np.abs(roots - 0.5))])
    return np.array(out)


def libration_period(t, y) -> C.Period:
    """The period of a libration: twice the slope of its zero crossings against their count.

    Parameters
    ----------
    t, y : array_like
        (m,) record times (s) and the angle (rad), oscillating about 0.

    Returns
    -------
    Period
        The period (s), the standard error of the fitted slope times 2, the crossings used.

    Raises
    ------
    ValueError
        Fewer than 4 crossings.
    """
    c = zero_crossings(t, y)
    if c.size < 4:
        raise ValueError(f"the angle crosses zero {c.size} times: at least 4 are needed for a period")
    fit, cov = np.polyfit(np.arange(c.size), c, 1, cov=True)
    return C.Period(2.0 * float(fit[0]), 2.0 * float(np.sqrt(max(cov[0, 0], 0.0))), int(c.size), "crossings")


def spectrum(t, y, pad: int = 16):
    """The amplitude spectrum of a uniformly sampled series (Hann window, zero-padded).

    Parameters
    ----------
    t, y : array_like
        (m,) record times (s, uniform) and values.
    pad : int
        The zero padding factor.

    Returns
    -------
    tuple of ndarray
        Angular frequencies (rad/s) and amplitudes.
    """
    t, y = np.asarray(t, float), np.asarray(y, float)
    dt = (t[-1] - t[0]) / (len(t) - 1)
    w = np.hanning(len(y))
    amp = np.abs(np.fft.rfft((y - y.mean()) * w, pad * len(y))) * 2 / w.sum()
    return 2 * np.pi * np.fft.rfftfreq(pad * len(y), dt), amp


def _peaks(t, y, count: int) -> np.ndarray:
    f, a = spectrum(t, y)
    i = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])) + 1
    return np.sort(f[i[np.argsort(a[i])[::-1][:count]]])[::-1]


def fit_modes(t, series, count: int = 2, seeds=None):
    """Frequencies shared by several series, each a sum of sinusoids and a constant.

    Variable projection: for given frequencies the amplitudes follow by linear least squares;
    ``scipy.optimize.least_squares`` varies the frequencies, started at ``seeds`` or at the
    largest peaks of the first series' spectrum.

    Parameters
    ----------
    t : array_like
        (m,) record times, s.
    series : sequence of array_like
        Each (m,), fitted together.
    count : int
        The number of frequencies.
    seeds : array_like, optional
        Starting frequencies, rad/s (default: the spectrum's peaks).

    Returns
    -------
    freqs : ndarray
        (count,) rad/s, descending.
    sigma : ndarray
        Their formal standard errors, rad/s.
    rms : float
        The residual's root mean square relative to the series' RMS.

    Raises
    ------
    RuntimeError
        The fit did not converge.
    """
    from scipy.optimize import least_squares

    t = np.asarray(t, float)
    ys = [np.asarray(y, float) for y in series]
    t0 = t - t.mean()
    seeds = _peaks(t, ys[0], count) if seeds is None else np.asarray(seeds, float)

    def design(w):
        return np.column_stack([f(wk * t0) for wk in w for f in (np.cos, np.sin)] + [np.ones_like(t0)])

    def residual(w):
        A = design(w)
        return np.concatenate([A @ np.linalg.lstsq(A, y, rcond=None)[0] - y for y in ys])

    sol = least_squares(residual, seeds, x_scale=np.abs(seeds), xtol=1e-15, ftol=1e-15, gtol=1e-15)
    if not sol.success:
        raise RuntimeError(f"the frequency fit did not converge: {sol.message}")
    r = sol.fun
    jtj = sol.jac.T @ sol.jac
    cov = np.linalg.pinv(jtj) * float(r @ r) / max(1, r.size - count * (2 * len(ys) + 1) - len(ys))
    order = np.argsort(sol.x)[::-1]
    scale = math.sqrt(sum(float(np.mean((y - y.mean()) ** 2)) for y in ys) / len(ys))
    return sol.x[order], np.sqrt(np.abs(np.diag(cov)))[order], float(np.sqrt(np.mean(r**2)) / scale)


def attitude_invariant(points, gm, radius, x, v, body_to_space, w):
    """K = E - n L_z + const, written without the orbit's cancelling terms, and its scale.

    Parameters
    ----------
    points : MassPoints
        The body's mass points (body coordinates ``X`` (3, N), masses ``m``).
    gm : float
        GM, m^3/s^2.
    radius : float
        r0, the reference circle's radius (n = sqrt(GM / r0^3)), m.
    x, v : array_like
        (m, 3) the centre's position and velocity, m and m/s.
    body_to_space : array_like
        (m, 3, 3) attitudes.
    w : array_like
        (m, 3) body-frame angular velocities, rad/s.

    Returns
    -------
    K : ndarray
        (m,) J.
    scale : float
        The largest sum of the magnitudes of K's terms over the records, J.
    """
    x, v, w = (np.asarray(a, float) for a in (x, v, w))
    Rm = np.asarray(body_to_space, float)
    n = orbit_rate(gm, radius)
    I = points.inertia
    r = np.linalg.norm(x, axis=-1)
    d = r - radius
    u = v - n * np.cross([0.0, 0.0, 1.0], x)
    orbit = points.mass * (
        0.5 * np.einsum("ni,ni->n", u, u) + n * n * (0.5 * x[:, 2] ** 2 - 0.5 * d * d - radius * d * d / r)
    )
    Iw = w @ I
    spin = 0.5 * np.einsum("ni,ni->n", w, Iw)
    Lz = n * np.einsum("nij,nj->ni", Rm, Iw)[:, 2]
    Xs = np.einsum("nij,jk->nik", Rm, points.X)
    dist = np.linalg.norm(points.X, axis=0)
    cos = -np.einsum("ni,nik->nk", x / r[:, None], Xs) / dist
    h = dist[None, :] / r[:, None]
    legendre = (
        h**2 * 0.5 * (3 * cos**2 - 1) + h**3 * 0.5 * (5 * cos**3 - 3 * cos) + h**4 * (35 * cos**4 - 30 * cos**2 + 3) / 8
    )
    V = -(gm / r) * (legendre * points.m).sum(axis=1)
    K = orbit + spin - Lz + V
    scale = float((np.abs(orbit) + np.abs(spin) + np.abs(Lz) + np.abs(V)).max())
    return K, scale


# -- emorbit ----------------------------------------------------------------------------------------------
def _quaternion_matrices(q):
    from emorbit.bodies.rotations import quaternion_to_matrix

    return quaternion_to_matrix(np.asarray(q, float))


def run_em(label, s, rotation_vector, steps_per_orbit, orbits, *, size=None, mass=None) -> Trajectory:
    """One em run of the box on the circular orbit, recorded at every step.

    Parameters
    ----------
    label : str
        The run's name.
    s : dict
        The case's settings (``gm``, ``radius``, ``size``, ``density``, ``order``).
    rotation_vector : sequence of 3 floats
        The initial attitude relative to the orbit frame (rad; body x radial, z normal).
    steps_per_orbit : int
        Steps per orbit period T.
    orbits : float
        The run's length in T.
    size : sequence of 3 floats, optional
        Another box (m) instead of the case's, with ``mass`` (kg).
    mass : float, optional
        The other box's mass, kg.

    Returns
    -------
    Trajectory
        ``series``: ``angles`` (m, 3) (yaw, roll, pitch) rad, ``energy`` |E - E0| / (T + |V|),
        ``angular_momentum`` |L - L0| / (sum m |x| |v| + |I w|), ``K`` |K - K0| / scale (m,);
        ``x``, ``v``, ``w``, ``R`` (the raw records); ``info``: method, order, dt_s, steps,
        rotation_vector, and ``points`` (emorbit's mass points, left out of the report).
    """
    import emorbit

    field = emorbit.CentralField(body="earth")
    gm, r0 = field.gm, s["radius"]
    n = orbit_rate(gm, r0)
    dt = 2 * math.pi / n / steps_per_orbit
    steps = int(round(orbits * steps_per_orbit))
    sim = emorbit.Simulation(field, method="em", order=s["order"], dt=dt)
    shape = {"size": list(s["size"]), "density": s["density"]} if size is None else {"size": list(size), "mass": mass}
    sim.add_rigid(
        "box",
        "box",
        position=[r0, 0.0, 0.0],
        velocity=[0.0, math.sqrt(gm / r0), 0.0],
        rotation_vector=[float(a) for a in rotation_vector],
        angular_velocity=[0.0, 0.0, n],
        angular_velocity_frame="space",
        gravity="volume",
        **shape,
    )
    t0 = time.perf_counter()
    res = sim.run(steps=steps, every=1, progress=False).si
    wall = time.perf_counter() - t0
    pts = sim.rigid.points[0]
    x, v = res.positions["box"], res.velocities["box"]
    w, Rm = res.angular_velocities["box"], _quaternion_matrices(res.attitudes["box"])
    Iw = w @ pts.inertia
    # the terms that cancel: T + |V| (the potential of the centre's mass dominates) and
    # sum m |x| |v| + |I w|
    e_scale = 0.5 * pts.mass * np.einsum("ni,ni->n", v, v) + 0.5 * np.einsum("ni,ni->n", w, Iw)
    e_scale = float((e_scale + gm * pts.mass / np.linalg.norm(x, axis=-1)).max())
    l_scale = float((pts.mass * np.linalg.norm(x, axis=-1) * np.linalg.norm(v, axis=-1)).max())
    l_scale += float(np.linalg.norm(Iw, axis=-1).max())
    K, k_scale = attitude_invariant(pts, gm, r0, x, v, Rm, w)
    series = {
        "angles": lvlh_angles(x, v, Rm),
        "energy": np.abs(res.energy - res.energy[0]) / e_scale,
        "angular_momentum": np.linalg.norm(res.angular_momentum - res.angular_momentum[0], axis=-1) / l_scale,
        "K": np.abs(K - K[0]) / k_scale,
        "x": x,
        "v": v,
        "w": w,
        "R": Rm,
    }
    info = {
        "method": "em",
        "order": int(s["order"]),
        "dt_s": dt,
        "steps": steps,
        "steps_per_orbit": int(steps_per_orbit),
        "rotation_vector": [float(a) for a in rotation_vector],
        "mass_points": len(pts),
        "newton_iterations": res.mean_newton_iterations(),
        "points": pts,
    }
    if size is not None:
        info["size"] = [float(a) for a in size]
    return Trajectory(label, res.time, series, wall, info)


def em_torque(tr: Trajectory) -> np.ndarray:
    """emorbit's torque at the start of an em run (body frame, N m): its field's acceleration at its
    mass points, summed as its volume gravity sums it, sum m_i (R X_i) x g(x + R X_i), in body axes."""
    import emorbit

    pts = tr.info["points"]
    R0 = tr.series["R"][0]
    arm = R0 @ pts.X
    g = emorbit.CentralField(body="earth").acceleration(tr.series["x"][0][:, None] + arm)
    return R0.T @ np.cross(arm.T, (g * pts.m).T).sum(axis=0)


def amplitude_key(amplitude: float) -> str:
    """The label of a pitch amplitude (rad) in run names: degrees, 4 digits."""
    return f"{math.degrees(amplitude):.4g} deg"


# -- Basilisk -------------------------------------------------------------------------------------------------
def basilisk_modules():
    """Basilisk's modules this comparison uses, imported.

    Returns
    -------
    tuple
        (GravityGradientEffector, spacecraft, SimulationBaseClass, macros, simIncludeGravBody).

    Raises
    ------
    ImportError
        Basilisk is not installed (``pip install 'emorbit[rigid-peers]'``).
    """
    from Basilisk.simulation import GravityGradientEffector, spacecraft
    from Basilisk.utilities import SimulationBaseClass, macros, simIncludeGravBody

    return GravityGradientEffector, spacecraft, SimulationBaseClass, macros, simIncludeGravBody


def run_basilisk(label, inertia, mass, gm, radius, rotation_vector, dt, t_end, record_dt=None) -> Trajectory:
    """The box as a Basilisk spacecraft hub with the first-order gravity-gradient torque.

    Parameters
    ----------
    label : str
        The run's name.
    inertia : array_like
        (3, 3) kg m^2 about the centre of mass.
    mass : float
        kg.
    gm : float
        The central body's GM, m^3/s^2.
    radius : float
        The circular orbit's radius, m.
    rotation_vector : sequence of 3 floats
        The initial attitude relative to the orbit frame, rad (as :func:`run_em`).
    dt : float
        RK4's step, s (a whole number of nanoseconds).
    t_end : float
        The run's length, s (0: the start only).
    record_dt : float, optional
        The interval of the records, s (default ``dt``).

    Returns
    -------
    Trajectory
        ``series``: ``angles`` (m, 3) (yaw, roll, pitch) rad and ``torque0`` (3,) the
        effector's torque at t = 0 (body frame, N m); ``info``: method, dt_s, steps.

    Raises
    ------
    ImportError
        Basilisk is not installed.
    """
    from emorbit.bench.rigid_cases import mrp_to_dcm
    from emorbit.bodies.rotations import rotation_vector_to_matrix

    GravityGradientEffector, spacecraft, SimulationBaseClass, macros, simIncludeGravBody = basilisk_modules()
    record_dt = dt if record_dt is None else record_dt
    n = orbit_rate(gm, radius)
    rv = np.asarray(rotation_vector, float)
    th = float(np.linalg.norm(rv))
    sigma = math.tan(th / 4) * rv / th if th > 0 else np.zeros(3)  # MRP of [BN] = R^T
    w_body = rotation_vector_to_matrix(rv).T @ np.array([0.0, 0.0, n])
    sim = SimulationBaseClass.SimBaseClass()
    sim.CreateNewProcess("dynamics").addTask(sim.CreateNewTask("task", macros.sec2nano(dt)))
    sc = spacecraft.Spacecraft()
    sc.ModelTag = "box"
    sc.hub.mHub = float(mass)
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = np.asarray(inertia, float).tolist()
    sim.AddModelToTask("task", sc)
    grav = simIncludeGravBody.gravBodyFactory()
    earth = grav.createCustomGravObject("earth", gm)
    earth.isCentralBody = True
    grav.addBodiesTo(sc)
    sc.hub.r_CN_NInit = [[radius], [0.0], [0.0]]
    sc.hub.v_CN_NInit = [[0.0], [math.sqrt(gm / radius)], [0.0]]
    sc.hub.sigma_BNInit = [[float(a)] for a in sigma]
    sc.hub.omega_BN_BInit = [[float(a)] for a in w_body]
    gg = GravityGradientEffector.GravityGradientEffector()
    gg.ModelTag = "gravityGradient"
    gg.addPlanetName(earth.planetName)
    sc.addDynamicEffector(gg)
    sim.AddModelToTask("task", gg)
    rec = sc.scStateOutMsg.recorder(macros.sec2nano(record_dt))
    torque = gg.gravityGradientOutMsg.recorder(macros.sec2nano(record_dt))
    sim.AddModelToTask("task", rec)
    sim.AddModelToTask("task", torque)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(macros.sec2nano(t_end))
    t0 = time.perf_counter()
    sim.ExecuteSimulation()
    wall = time.perf_counter() - t0
    x, v = np.asarray(rec.r_BN_N, float), np.asarray(rec.v_BN_N, float)
    R = np.swapaxes(mrp_to_dcm(rec.sigma_BN), -1, -2)
    series = {"angles": lvlh_angles(x, v, R), "torque0": np.asarray(torque.gravityGradientTorque_B, float)[0]}
    info = {"method": "Basilisk RK4 + GravityGradientEffector", "dt_s": float(dt), "steps": int(round(t_end / dt))}
    return Trajectory(label, np.asarray(rec.times(), float) * 1e-9, series, wall, info)


def basilisk_missing() -> str:
    """'' when Basilisk imports, else why it does not ("skipped: Basilisk not installed ...")."""
    try:
        basilisk_modules()
    except Exception as exc:  # noqa: BLE001 - any import failure means: skipped
        return f"skipped: Basilisk not installed ({type(exc).__name__}: {exc}); pip install 'emorbit[rigid-peers]'"
    return ""
