"""Attitude conversions, and an attitude checked from user input.

Quaternions are scalar first, q = (w, x, y, z), and rotate body coordinates into space:
x_space = R(q) X_body. Rotation vectors are angle times unit axis, in rad.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..units import vector_to_si

__all__ = ["quaternion_to_matrix", "matrix_to_quaternion", "rotation_vector_to_matrix", "attitude_matrix"]


def quaternion_to_matrix(q) -> np.ndarray:
    """Rotation matrices from unit quaternions.

    Parameters
    ----------
    q : array_like
        Unit quaternions (..., 4), scalar first.

    Returns
    -------
    ndarray
        R (..., 3, 3), body to space.
    """
    q = np.asarray(q, float)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def matrix_to_quaternion(R) -> np.ndarray:
    """Unit quaternions from rotation matrices (Shepperd's method).

    The largest of the four candidate components is computed first, so nothing cancels.

    Parameters
    ----------
    R : array_like
        Rotation matrices (..., 3, 3).

    Returns
    -------
    ndarray
        Unit quaternions (..., 4), scalar first, with w >= 0.
    """
    R = np.asarray(R, float)
    tr = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2]
    cand = np.stack([tr, R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]], -1)
    k = np.argmax(cand, axis=-1)
    q = np.empty(R.shape[:-2] + (4,))
    s = np.sqrt(np.maximum(1.0 + 2.0 * np.take_along_axis(cand, k[..., None], -1)[..., 0] - tr, 0.0))
    # k == 0
    w0 = 0.5 * s
    with np.errstate(divide="ignore", invalid="ignore"):
        f = 0.5 / s
        opts = [
            (
                w0,
                (R[..., 2, 1] - R[..., 1, 2]) * f,
                (R[..., 0, 2] - R[..., 2, 0]) * f,
                (R[..., 1, 0] - R[..., 0, 1]) * f,
            ),
            (
                (R[..., 2, 1] - R[..., 1, 2]) * f,
                w0,
                (R[..., 0, 1] + R[..., 1, 0]) * f,
                (R[..., 0, 2] + R[..., 2, 0]) * f,
            ),
            (
                (R[..., 0, 2] - R[..., 2, 0]) * f,
                (R[..., 0, 1] + R[..., 1, 0]) * f,
                w0,
                (R[..., 1, 2] + R[..., 2, 1]) * f,
            ),
            (
                (R[..., 1, 0] - R[..., 0, 1]) * f,
                (R[..., 0, 2] + R[..., 2, 0]) * f,
                (R[..., 1, 2] + R[..., 2, 1]) * f,
                w0,
            ),
        ]
    for j, comps in enumerate(opts):
        sel = k == j
        for c in range(4):
            q[..., c] = np.where(sel, comps[c], q[..., c]) if j else comps[c]
    q *= np.where(q[..., :1] < 0, -1.0, 1.0)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def rotation_vector_to_matrix(v) -> np.ndarray:
    """The rotation matrix of a rotation vector (Rodrigues' formula).

    Parameters
    ----------
    v : array_like
        Rotation vector (3,): the rotation by |v| rad about v / |v|.

    Returns
    -------
    ndarray
        R (3, 3).
    """
    v = np.asarray(v, float)
    th = float(np.linalg.norm(v))
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    if th < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + np.sin(th) / th * K + (1 - np.cos(th)) / th**2 * K @ K


def attitude_matrix(attitude, rotation_vector, angular_velocity, frame, strict, key):
    """A body's attitude matrix and angular velocity in space, checked from user input.

    Parameters
    ----------
    attitude : sequence of 4 floats or None
        Unit quaternion (w, x, y, z), body to space (|q| within 1e-6 of 1).
    rotation_vector : Quantity, sequence or None
        The attitude as angle times unit axis, rad (at most one of the two; neither: body
        axes are space axes).
    angular_velocity : Quantity or sequence
        Angular velocity, rad/s.
    frame : str
        ``"body"`` or ``"space"``: the axes of ``angular_velocity``.
    strict : bool
        Require units on every value.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    R : ndarray
        (3, 3) body to space, orthonormal to round-off.
    omega_space : ndarray
        (3,) angular velocity in space axes, rad/s.

    Raises
    ------
    InputError
        Both attitudes given, a quaternion that is not a unit one, or a bad value.
    """
    if attitude is not None and rotation_vector is not None:
        raise InputError(f"{key}.attitude", "give the attitude or the rotation_vector, not both")
    if attitude is not None:
        try:
            qa = np.asarray(attitude, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{key}.attitude", f"expected 4 numbers (w, x, y, z), got {attitude!r}") from None
        if qa.shape != (4,) or not np.all(np.isfinite(qa)):
            raise InputError(f"{key}.attitude", f"expected 4 finite numbers (w, x, y, z), got {attitude!r}")
        nq = float(np.linalg.norm(qa))
        if abs(nq - 1.0) > 1e-6:
            raise InputError(f"{key}.attitude", f"a unit quaternion is needed, |q| = {nq!r}")
        R = quaternion_to_matrix(qa / nq)
    elif rotation_vector is not None:
        R = rotation_vector_to_matrix(vector_to_si(rotation_vector, "angle", f"{key}.rotation_vector", strict=strict))
    else:
        R = np.eye(3)
    # re-orthonormalise to round-off so the constraints hold from the start
    U, _, Vt = np.linalg.svd(R)
    R = U @ Vt
    w = vector_to_si(angular_velocity, "angular_speed", f"{key}.angular_velocity", strict=strict)
    if frame not in ("body", "space"):
        raise InputError(f"{key}.angular_velocity_frame", f"must be 'body' or 'space', got {frame!r}")
    return R, (R @ w if frame == "body" else w)
