"""The cases of the rigid-body bench (:mod:`emorbit.bench.rigid`) and their references.

* The orbiting box: 2 x 1 x 0.5 m, 500 kg/m^3, in a 7000 km circular Earth orbit, rotated
  by :data:`LEO_ROTATION_VECTOR` from long-axis-radial and turning at about the orbit rate.
* The torque-free box: 3 x 2 x 1 m tumbling near its intermediate axis (it flips).

References: the box's analytic inertia; the rotational Jacobi integral of a body in a
circular orbit under the first-order gravity-gradient torque,
J = T - n e_n.(I w) + 3/2 n^2 c_r.I c_r (T the rotational kinetic energy, n the orbit rate,
e_n the orbit normal and c_r the radial unit vector in body axes); Euler's equations solved
by scipy's DOP853 (rtol 1e-12); and Basilisk's modified Rodrigues parameters as a matrix.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "CONFIGS",
    "Config",
    "earth_field",
    "orbit_rate",
    "leo_sim",
    "free_sim",
    "box_inertia",
    "jacobi",
    "drift",
    "omega_reference",
    "mrp_to_dcm",
]
#: the orbiting box: circular Earth orbit radius, m
R_ORBIT = 7.0e6
LEO_BOX = dict(size=[2.0, 1.0, 0.5], density=500.0)  # m, kg/m^3: 500 kg
LEO_ROTATION_VECTOR = (0.05, 0.03, 0.1)  # rad, from the stable orientation (long axis radial)
LEO_RATE_OFFSET = (2e-4, -1e-4, 3e-4)  # rad/s in space axes, added to the orbit rate about z
#: the torque-free box, its tumble and a faster one (rad/s, body frame; near the
#: intermediate axis, so it flips)
FREE_BOX = dict(size=[3.0, 2.0, 1.0], density=1.0)
FREE_OMEGA = (0.01, 2.0, 0.01)
FAST_OMEGA = (0.01, 5.0, 0.01)
#: steps of the torque-free runs, s: Exudyn's, and emorbit's (Exudyn's and 10x larger)
EXUDYN_DTS = (2e-3, 1e-2)
FREE_DTS = (2e-3, 1e-2, 2e-2, 1e-1)
#: the step of Exudyn's trapezoidal rules, s
TRAPEZOIDAL_DT = 1e-2
#: steps of the orbiting box against Basilisk, and of the scan over mass points, s
FIELD_DTS = (60.0, 10.0)
SCAN_DT = 10.0
#: Exudyn's rotation parametrisations compared
EXUDYN_NODES = ("euler-parameters", "rotation-vector")


@dataclass(frozen=True)
class Config:
    """How long and how often the rigid-body bench measures (see :data:`CONFIGS`)."""

    refinements: tuple  # box refinements of the scan (8 r^3 mass points)
    repeat_s: float  # wall time aimed at per timed call
    repeats: int
    orbits: float  # length of the accuracy runs in the field
    t_free: float  # s, length of the torque-free accuracy runs


#: "full", "quick" (``emorbit bench --quick``) and "tiny" (a smoke run for the tests)
CONFIGS = {
    "full": Config(refinements=(2, 3, 4, 5, 6, 8, 11), repeat_s=0.1, repeats=11, orbits=10.0, t_free=20.0),
    "quick": Config(refinements=(1, 2, 3, 5), repeat_s=0.03, repeats=5, orbits=2.0, t_free=20.0),
    "tiny": Config(refinements=(1, 2), repeat_s=0.003, repeats=2, orbits=0.2, t_free=1.0),
}


def earth_field():
    """The Earth's field, GM from astropy's constants.

    Returns
    -------
    CentralField
        Centred on the origin.
    """
    import emorbit

    return emorbit.CentralField(body="earth")


def orbit_rate(gm: float) -> float:
    """The mean motion of the circular orbit of radius :data:`R_ORBIT`.

    Parameters
    ----------
    gm : float
        GM, m^3/s^2.

    Returns
    -------
    float
        n = sqrt(GM / R^3), rad/s.
    """
    return math.sqrt(gm / R_ORBIT**3)


def leo_sim(refinement: int, dt: float, gravity: str = "volume", order: int = 2, method: str = "em"):
    """The orbiting box as a :class:`emorbit.Simulation` (em unless ``method`` says otherwise).

    Parameters
    ----------
    refinement : int
        Box cells per edge: 8 refinement^3 mass points.
    dt : float
        The step, s.
    gravity : str
        ``"volume"`` or ``"point"``.
    order : int
        The composition's order.
    method : str
        The method (``"em"`` or ``"midpoint"``).

    Returns
    -------
    Simulation
        One rigid body named ``"box"``.
    """
    import emorbit

    field = earth_field()
    n = orbit_rate(field.gm)
    sim = emorbit.Simulation(field, method=method, order=order, dt=dt)
    sim.add_rigid(
        "box",
        "box",
        refinement=refinement,
        position=[R_ORBIT, 0.0, 0.0],
        velocity=[0.0, math.sqrt(field.gm / R_ORBIT), 0.0],
        rotation_vector=list(LEO_ROTATION_VECTOR),
        angular_velocity=[LEO_RATE_OFFSET[0], LEO_RATE_OFFSET[1], n + LEO_RATE_OFFSET[2]],
        angular_velocity_frame="space",
        gravity=gravity,
        **LEO_BOX,
    )
    return sim


def free_sim(dt: float, omega=FREE_OMEGA, method: str = "em", order: int = 2):
    """The torque-free box as a :class:`emorbit.Simulation` in free space (em, order 2 unless
    ``method`` and ``order`` say otherwise).

    Parameters
    ----------
    dt : float
        The step, s.
    omega : sequence of 3 floats
        Initial angular velocity, rad/s, body frame.
    method : str
        The method (``"em"`` or ``"midpoint"``).
    order : int
        The composition's order.

    Returns
    -------
    Simulation
        One rigid body named ``"box"``.
    """
    import emorbit

    sim = emorbit.Simulation(None, method=method, order=order, dt=dt)
    sim.add_rigid(
        "box", "box", position=[0.0, 0.0, 0.0], velocity=[0.0, 0.0, 0.0], angular_velocity=list(omega), **FREE_BOX
    )
    return sim


def box_inertia(size, density) -> np.ndarray:
    """The analytic inertia tensor of a homogeneous box.

    Parameters
    ----------
    size : sequence of 3 floats
        Edges, m.
    density : float
        kg/m^3.

    Returns
    -------
    ndarray
        (3, 3), kg m^2.
    """
    a, b, c = size
    m = density * a * b * c
    return np.diag([m / 12 * (b * b + c * c), m / 12 * (a * a + c * c), m / 12 * (a * a + b * b)])


def jacobi(inertia, n, positions, space_to_body, omega_body) -> np.ndarray:
    """The rotational Jacobi integral J = T - n e_n.(I w) + 3/2 n^2 c_r.I c_r per record.

    Conserved by a rigid body in a circular orbit (rate n about z) under the first-order
    gravity-gradient torque.

    Parameters
    ----------
    inertia : ndarray
        (3, 3) inertia tensor, kg m^2.
    n : float
        Orbit rate, rad/s.
    positions : ndarray
        (m, 3) centre-of-mass positions, m.
    space_to_body : ndarray
        (m, 3, 3) matrices taking space components to body components.
    omega_body : ndarray
        (m, 3) body-frame angular velocities, rad/s.

    Returns
    -------
    ndarray
        J per record (m,), J.
    """
    r_hat = positions / np.linalg.norm(positions, axis=-1)[:, None]
    c_r = np.einsum("nij,nj->ni", space_to_body, r_hat)
    e_n = space_to_body[:, :, 2]
    Iw = omega_body @ inertia
    return (
        0.5 * np.einsum("ni,ni->n", omega_body, Iw)
        - n * np.einsum("ni,ni->n", e_n, Iw)
        + 1.5 * n * n * np.einsum("ni,ij,nj->n", c_r, inertia, c_r)
    )


def drift(values) -> float:
    """The drift of a conserved quantity: the largest |value / value[0] - 1|.

    Parameters
    ----------
    values : array_like
        The quantity per record.

    Returns
    -------
    float
        The largest relative deviation from the first value.
    """
    values = np.asarray(values, float)
    return float(np.abs(values / values[0] - 1.0).max())


def omega_reference(inertia, omega0, t_end) -> np.ndarray:
    """A body-frame angular velocity from Euler's equations (DOP853, rtol 1e-12).

    Parameters
    ----------
    inertia : ndarray
        (3, 3) inertia tensor, kg m^2.
    omega0 : sequence of 3 floats
        Initial angular velocity, rad/s.
    t_end : float
        Time, s.

    Returns
    -------
    ndarray
        The angular velocity (3,) at ``t_end``, rad/s.
    """
    from scipy.integrate import solve_ivp

    Iinv = np.linalg.inv(inertia)
    sol = solve_ivp(
        lambda _, w: Iinv @ np.cross(inertia @ w, w),
        (0.0, t_end),
        np.asarray(omega0, float),
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
    )
    return sol.y[:, -1]


def mrp_to_dcm(sigma) -> np.ndarray:
    """Basilisk's [BN] matrices (space to body components) from modified Rodrigues parameters.

    Parameters
    ----------
    sigma : array_like
        sigma_BN (n, 3).

    Returns
    -------
    ndarray
        (n, 3, 3).
    """
    s = np.asarray(sigma, float)
    s2 = np.einsum("ni,ni->n", s, s)
    S = np.zeros(s.shape[:-1] + (3, 3))
    S[:, 0, 1], S[:, 0, 2], S[:, 1, 2] = -s[:, 2], s[:, 1], -s[:, 0]
    S -= np.swapaxes(S, -1, -2)
    return np.eye(3) + (8 * S @ S - 4 * (1 - s2)[:, None, None] * S) / ((1 + s2) ** 2)[:, None, None]
