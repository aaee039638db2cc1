"""The referees of the case ``centre-of-gravity`` (:mod:`.centre_of_gravity`): emorbit's
resultant gravity force and torque on a rigid body of mass points, their exact sums, the closed
forms of a dumbbell and a homogeneous rod, and the centre of gravity with its quadrupole theory.

In an inhomogeneous field the resultant gravity force on a rigid body does not act at its
centre of mass: the field is summed over the body's mass points (Goettlicher & Schweizerhof's
rigid body; ``gravity="volume"``), which gives the gravity-gradient torque. With the field's
centre at the origin, GM its strength, a body with centre of mass x_c, attitude R and mass
points m_i at body coordinates X_i (x_i = x_c + R X_i, r_i = R X_i)::

    F = -GM sum_i m_i x_i / |x_i|^3,        tau = sum_i r_i x (-GM m_i x_i / |x_i|^3)   (about x_c)

Every point force points at the centre, so the resultant's line of action passes through it:
tau = -x_c x F. The centre of gravity is the point on that line where a point mass M (the
body's mass) feels F::

    x_g = -(F / |F|) sqrt(GM M / |F|),       gap  d = x_g - x_c.

Quadrupole theory (MacCullagh's potential, U = -GM M / R - GM (tr I - 3 u.I u) / (2 R^3), u =
x_c / R, R = |x_c|, I the inertia about x_c in space axes) gives F = -grad U and, to first order
in F's quadrupole part f, d = (R^3 / (GM M)) ((u.f / 2) u - f_perp), that is::

    d = ((9 u.I u - 3 tr I) / 4 u + 3 (I u - (u.I u) u)) / (M R)    + O(l^4 / R^3),

a gap of order l^2 / R (l the body's size). The relative truncation is O((l / R)^2) for a
centrally symmetric body (no octupole: the box, the rod).

emorbit's code path is its rigid-body force kernel, :func:`emorbit.kernels.rigid.rigid_forces`,
which sums g_em over the mass points into the generalised force (F, F_1, F_2, F_3) of the
director formulation; at q0 = q1 g_em is the field g itself, and tau = sum_k d_k x F_k. It runs
on emorbit's box (``SHAPES["box"]``, 3 x 2 x 1 m, refinement 2: 64 mass points), on a dumbbell
of two mass points, and on a rod of N mass points at the midpoints of N equal cells. End to end,
one em step of a body at rest through the public API (``Simulation``, ``add_rigid``, ``run``)
gives M dv / h -> F and L_spin / h -> tau with an O(h^2) error.

The referees here:

1. Exact sums over the same mass points, in Python's ``decimal`` at 40 digits (each double input
   converted exactly), at many random attitudes and directions.
2. The dumbbell: F = -GM sum_j m_j (R u + s_j e) / (R^2 + 2 R s_j cos(theta) + s_j^2)^(3/2), s_j
   = -m2 L / M, m1 L / M, theta the angle between u and the axis e.
3. The homogeneous rod (mass M, length L, line density lambda = M / L) along e: with b = x_c.e,
   x_perp = x_c - b e, c = |x_perp|, u_(1,2) = b -/+ L/2, r_(1,2) = |x_c -/+ (L/2) e| = sqrt(u^2
   + c^2), the integral of -GM lambda (x_c + s e) / |x_c + s e|^3 over s in [-L/2, L/2] is (with
   int du / rho^3 = u / (c^2 rho), int u du / rho^3 = -1 / rho, rho = sqrt(u^2 + c^2))::

       F = -GM lambda (A x_perp + e 2 L b / ((r1 + r2) r1 r2)),
       A = (u2 / r2 - u1 / r1) / c^2 = 2 L b / (r1 r2 (u2 r1 + u1 r2))    (u1 u2 > 0)
       tau = -GM lambda b (e x x_c) (2 L / ((r1 + r2) r1 r2) - A)

   (the second form of A where the centre lies beyond the rod's ends, free of cancellation; the
   segment's potential -GM lambda ln((r1 + r2 + L) / (r1 + r2 - L)), Riaguas, Elipe & Lara 1999,
   is its antiderivative). It is checked here against 64-point Gauss-Legendre quadrature. The
   N-point midpoint rod converges to it at O(1/N^2), with the Euler-Maclaurin leading term
   (h^2 / 24) (g'(L/2) - g'(-L/2)), h = L / N, g the integrand (checked).
4. The quadrupole formula for the gap.

The data layout: mass points as emorbit holds them, body coordinates X (3, N) relative to the
centre of mass and masses m (N,); attitudes R (3, 3), body to space; positions, forces and
torques (3,) in space axes, SI (m, N, N m), the field's centre at the origin.

References: M. Goettlicher, K. Schweizerhof (the energy-momentum method for a satellite in a
central field); MacCullagh's formula for the potential of an extended body (e.g. A. E. Roy,
*Orbital Motion*, 4th ed., IoP 2005); A. Riaguas, A. Elipe, M. Lara, Periodic orbits around a
massive straight segment, Celest. Mech. Dyn. Astron. 73 (1999) 169-178; P. J. Davis, P.
Rabinowitz, *Methods of Numerical Integration* (2nd ed., Academic Press 1984) (the
Euler-Maclaurin formula of the midpoint rule).
"""

from __future__ import annotations

import decimal
import math

import numpy as np

__all__ = [
    "DIGITS",
    "kernel_resultant",
    "exact_resultant",
    "dumbbell_force",
    "rod_points",
    "rod_force",
    "rod_leading_error",
    "gauss_legendre_rod",
    "centre_of_gravity",
    "quadrupole_gap",
    "random_attitudes",
]

#: decimal digits of the exact sums
DIGITS = 40


# -- emorbit's resultant ------------------------------------------------------------------------
def kernel_resultant(X, m, gm: float, position, R) -> tuple[np.ndarray, np.ndarray]:
    """The resultant force and the torque about the centre of mass from emorbit's kernel.

    :func:`emorbit.kernels.rigid.rigid_forces` (em's discrete forces, gravity summed over the
    mass points) at q0 = q1 = (x_c, d1, d2, d3), with the compiled effect set of a central
    field of GM at the origin (:meth:`emorbit.effects.effectset.EffectSet.program`, the set
    every rigid body's step takes): its generalised force is (F, F_1, F_2, F_3) with
    F_k = sum_i m_i X_i^k g_i, and tau = sum_k d_k x F_k.

    Parameters
    ----------
    X : array_like
        Body coordinates (3, N) of the mass points relative to the centre of mass, m (any N >= 1).
    m : array_like
        Masses (N,), kg.
    gm : float
        GM, m^3/s^2.
    position : array_like
        The centre of mass x_c (3,), m.
    R : array_like
        The attitude (3, 3), body to space.

    Returns
    -------
    tuple of ndarray
        F (3,), N, and tau (3,), N m.

    Raises
    ------
    ValueError
        Arrays of the wrong shape, or a mass point at the centre (the kernel's status).
    """
    import emorbit
    from emorbit.effects.effectset import EffectSet
    from emorbit.kernels.codes import GRAVITY_VOLUME
    from emorbit.kernels.effects.signatures import MODE_STEP
    from emorbit.kernels.rigid import rigid_forces, work_arrays

    X = np.ascontiguousarray(X, float)
    m = np.ascontiguousarray(m, float)
    phi, R = np.asarray(position, float), np.asarray(R, float)
    if X.ndim != 2 or X.shape[0] != 3 or m.shape != (X.shape[1],):
        raise ValueError(f"X must be (3, N) and m (N,), got X {X.shape} and m {m.shape}")
    if phi.shape != (3,) or R.shape != (3, 3):
        raise ValueError(f"position must be (3,) and R (3, 3), got {phi.shape} and {R.shape}")
    n = X.shape[1]
    q = np.concatenate([phi, R[:, 0], R[:, 1], R[:, 2]])
    effects = EffectSet(emorbit.CentralField(gm=float(gm)))  # its centre at the origin
    prog = effects.program()
    P, I, T, S = effects.arrays(n)
    each = effects.coefficients("rigid", "body", {})  # (k,): 1 for the central field
    coef = np.ascontiguousarray(np.repeat(each[:, None], n, axis=1))
    pcoef = np.ascontiguousarray(each[:, None])
    work = work_arrays(X)
    for d in range(3):  # the mass points at the step's start, as the step kernel forms them
        work[25][d] = q[d] + X[0] * q[3 + d] + X[1] * q[6 + d] + X[2] * q[9 + d]
    F = np.empty(12)
    K = np.empty((12, 12))
    W, G = np.empty((10, n)), np.empty((3, n))
    status = rigid_forces(
        prog.forces, MODE_STEP, GRAVITY_VOLUME, q, q, X, m, float(m.sum()), 1.0, coef, pcoef, P, I, T, S, F, K,
        work[4], W, G, work, False,
    )  # fmt: skip
    if status != 0:
        raise ValueError(f"emorbit's force kernel returned status {status} (a mass point at the centre)")
    tau = np.cross(q[3:6], F[3:6]) + np.cross(q[6:9], F[6:9]) + np.cross(q[9:12], F[9:12])
    return F[:3].copy(), tau


def exact_resultant(X, m, gm: float, position, R) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The resultant force and torque about the centre of mass, summed exactly.

    Every double input is converted exactly to a :class:`decimal.Decimal` and the sums run at
    :data:`DIGITS` digits: the result is the exact sum over the given mass points, rounded once.

    Parameters
    ----------
    X, m, gm, position, R
        As :func:`kernel_resultant`.

    Returns
    -------
    tuple
        F (3,), tau (3,), and the scales sum m_i |g_i| (N) and sum m_i |r_i| |g_i| (N m), the
        sizes of the terms that cancel.
    """
    D = decimal.Decimal
    ctx = decimal.Context(prec=DIGITS)
    X, m = np.asarray(X, float), np.asarray(m, float)
    phi = [D(float(x)) for x in np.asarray(position, float)]
    Rm = [[D(float(x)) for x in row] for row in np.asarray(R, float)]
    G = D(float(gm))
    F = [D(0)] * 3
    T = [D(0)] * 3
    f_scale = t_scale = D(0)
    with decimal.localcontext(ctx):
        for i in range(X.shape[1]):
            Xi = [D(float(x)) for x in X[:, i]]
            r = [Rm[d][0] * Xi[0] + Rm[d][1] * Xi[1] + Rm[d][2] * Xi[2] for d in range(3)]
            x = [phi[d] + r[d] for d in range(3)]
            dist = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
            k = -G * D(float(m[i])) / (dist * dist * dist)
            f = [k * x[d] for d in range(3)]
            F = [F[d] + f[d] for d in range(3)]
            T = [T[0] + r[1] * f[2] - r[2] * f[1], T[1] + r[2] * f[0] - r[0] * f[2], T[2] + r[0] * f[1] - r[1] * f[0]]
            fabs = -k * dist
            f_scale += fabs
            t_scale += fabs * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()
    return np.array([float(v) for v in F]), np.array([float(v) for v in T]), float(f_scale), float(t_scale)


# -- closed forms -------------------------------------------------------------------------------
def dumbbell_force(masses, length: float, gm: float, position, axis) -> np.ndarray:
    """The force on two point masses on a massless rod, in the distance and angle to the centre.

    Parameters
    ----------
    masses : sequence of 2 floats
        m1 (at -m2 L / M along the axis) and m2 (at m1 L / M), kg.
    length : float
        Their distance L, m.
    gm : float
        GM, m^3/s^2.
    position : array_like
        The centre of mass (3,), m.
    axis : array_like
        The unit vector e from m1 to m2 (3,).

    Returns
    -------
    ndarray
        F (3,), N: -GM sum_j m_j (R u + s_j e) / (R^2 + 2 R s_j cos(theta) + s_j^2)^(3/2).
    """
    m1, m2 = (float(x) for x in masses)
    M = m1 + m2
    x, e = np.asarray(position, float), np.asarray(axis, float)
    Rn = float(np.linalg.norm(x))
    u = x / Rn
    cos = float(u @ e)
    F = np.zeros(3)
    for mj, s in ((m1, -m2 * length / M), (m2, m1 * length / M)):
        F -= gm * mj * (Rn * u + s * e) / (Rn * Rn + 2.0 * Rn * s * cos + s * s) ** 1.5
    return F


def rod_points(mass: float, length: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A rod of n mass points along the body x axis, at the midpoints of n equal cells.

    Parameters
    ----------
    mass : float
        kg.
    length : float
        m.
    n : int
        Mass points (>= 1).

    Returns
    -------
    tuple of ndarray
        X (3, n), m, and m (n,), kg.

    Raises
    ------
    ValueError
        n < 1, or a mass or length that is not positive.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    if not (mass > 0 and length > 0):
        raise ValueError(f"mass and length must be > 0, got {mass!r} kg and {length!r} m")
    s = -length / 2 + (np.arange(n) + 0.5) * (length / n)
    X = np.zeros((3, n))
    X[0] = s
    return X, np.full(n, mass / n)


def rod_force(mass: float, length: float, gm: float, position, axis) -> tuple[np.ndarray, np.ndarray]:
    """The closed-form force and torque (about its centre) on a homogeneous rod.

    Parameters
    ----------
    mass : float
        kg.
    length : float
        L, m.
    gm : float
        GM, m^3/s^2.
    position : array_like
        The rod's centre x_c (3,), m, farther than L/2 from the field's centre (the origin).
    axis : array_like
        The rod's unit direction e (3,).

    Returns
    -------
    tuple of ndarray
        F (3,), N, and tau (3,), N m (see the module's docstring).

    Raises
    ------
    ValueError
        The field's centre on the rod or within L/2 of its centre.
    """
    x, e = np.asarray(position, float), np.asarray(axis, float)
    e = e / np.linalg.norm(e)
    L = float(length)
    if not np.linalg.norm(x) > L / 2:
        raise ValueError(f"the rod's centre must lie farther than L/2 = {L / 2:g} m from the field's centre, got {x!r}")
    lam = mass / L
    b = float(x @ e)
    xp = x - b * e
    c2 = float(xp @ xp)
    u1, u2 = b - L / 2, b + L / 2
    r1, r2 = math.sqrt(u1 * u1 + c2), math.sqrt(u2 * u2 + c2)
    if u1 * u2 > 0:  # the centre lies beyond an end: the form without cancellation
        A = 2.0 * L * b / (r1 * r2 * (u2 * r1 + u1 * r2))
    else:
        A = (u2 / r2 - u1 / r1) / c2
    D = 2.0 * L / ((r1 + r2) * r1 * r2)
    F = -gm * lam * (A * xp + b * D * e)
    tau = -gm * lam * b * (D - A) * np.cross(e, x)
    return F, tau


def rod_leading_error(mass: float, length: float, gm: float, position, axis, n: int) -> np.ndarray:
    """The leading term of the midpoint rod's force error, F_exact - F_n (Euler-Maclaurin).

    For the midpoint rule, int_a^b g - h sum g(mid) = (h^2 / 24) (g'(b) - g'(a)) + O(h^4), with
    g(s) = -GM lambda (x_c + s e) / |x_c + s e|^3 and h = L / n.

    Parameters
    ----------
    mass, length, gm, position, axis
        As :func:`rod_force`.
    n : int
        The rod's mass points.

    Returns
    -------
    ndarray
        (h^2 / 24) (g'(L/2) - g'(-L/2)) (3,), N.
    """
    x, e = np.asarray(position, float), np.asarray(axis, float)
    lam, h = mass / length, length / n

    def dg(s):
        y = x + s * e
        rho = float(np.linalg.norm(y))
        return -gm * lam * (e / rho**3 - 3.0 * y * float(y @ e) / rho**5)

    return h * h / 24.0 * (dg(length / 2) - dg(-length / 2))


def gauss_legendre_rod(mass: float, length: float, gm: float, position, axis, n: int = 64) -> np.ndarray:
    """The rod's force by n-point Gauss-Legendre quadrature along it (checks :func:`rod_force`).

    Parameters
    ----------
    mass, length, gm, position, axis
        As :func:`rod_force` (``axis`` a unit vector).
    n : int
        Quadrature points (exact for polynomials of degree 2 n - 1).

    Returns
    -------
    ndarray
        F (3,), N.
    """
    s, w = np.polynomial.legendre.leggauss(n)
    s, w = s * length / 2, w * length / 2
    y = np.asarray(position, float)[:, None] + np.asarray(axis, float)[:, None] * s
    rho = np.linalg.norm(y, axis=0)
    return -gm * mass / length * (y * (w / rho**3)).sum(axis=1)


def centre_of_gravity(force, mass: float, gm: float) -> np.ndarray:
    """The centre of gravity: the point on the line of action where a point mass feels the force.

    Parameters
    ----------
    force : array_like
        The resultant force F (3,), N, of a body in the field of a centre at the origin.
    mass : float
        The body's mass M, kg.
    gm : float
        GM, m^3/s^2.

    Returns
    -------
    ndarray
        x_g = -(F / |F|) sqrt(GM M / |F|) (3,), m.
    """
    F = np.asarray(force, float)
    f = float(np.linalg.norm(F))
    return -F / f * math.sqrt(gm * mass / f)


def quadrupole_gap(inertia, mass: float, position) -> np.ndarray:
    """The gap x_g - x_c to first order in the quadrupole (MacCullagh).

    Parameters
    ----------
    inertia : array_like
        The inertia about the centre of mass in space axes (3, 3), kg m^2.
    mass : float
        M, kg.
    position : array_like
        The centre of mass x_c (3,), m (the field's centre at the origin).

    Returns
    -------
    ndarray
        ((9 u.I u - 3 tr I) / 4 u + 3 (I u - (u.I u) u)) / (M R) (3,), m, u = x_c / R.
    """
    I, x = np.asarray(inertia, float), np.asarray(position, float)
    R = float(np.linalg.norm(x))
    u = x / R
    Iu = I @ u
    uIu = float(u @ Iu)
    return ((9.0 * uIu - 3.0 * np.trace(I)) / 4.0 * u + 3.0 * (Iu - uIu * u)) / (mass * R)


def random_attitudes(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Random attitudes (uniform on SO(3)) and random unit directions.

    Parameters
    ----------
    n : int
        How many.
    seed : int
        The generator's seed.

    Returns
    -------
    tuple of ndarray
        R (n, 3, 3), body to space, and u (n, 3).
    """
    from emorbit.bodies.rotations import quaternion_to_matrix

    rng = np.random.default_rng(seed)
    q = rng.standard_normal((n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    u = rng.standard_normal((n, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    return quaternion_to_matrix(q), u
