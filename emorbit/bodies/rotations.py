"""Attitude conversions. Quaternions are scalar first, q = (w, x, y, z), and rotate body
coordinates into space: x_space = R(q) X_body. Rotation vectors are angle * unit axis (rad)."""

from __future__ import annotations

import numpy as np

__all__ = ["quaternion_to_matrix", "matrix_to_quaternion", "rotation_vector_to_matrix"]


def quaternion_to_matrix(q) -> np.ndarray:
    """R (..., 3, 3) from unit quaternions (..., 4), scalar first."""
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
    """Unit quaternions (..., 4), scalar first with w >= 0, from rotation matrices (..., 3, 3)
    (Shepperd's method: the largest of the four candidates is taken, so no cancellation)."""
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
    """R (3, 3) for the rotation by |v| rad about v / |v| (Rodrigues)."""
    v = np.asarray(v, float)
    th = float(np.linalg.norm(v))
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    if th < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + np.sin(th) / th * K + (1 - np.cos(th)) / th**2 * K @ K
