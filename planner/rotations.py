"""Rotation helpers (pure numpy): quaternions ``(x, y, z, w)`` (scalar last, as PyBullet uses)
from and to rotation matrices, their slerp and rotation angles.

Split out of :mod:`asmplan.planner.trajectory`, which re-exports them for its users (the
simulator's modules import them from there)."""

from __future__ import annotations

import math

import numpy as np


def quat_xyzw_from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(x, y, z, w)`` of rotation matrices.

    Parameters
    ----------
    R : (..., 3, 3) float array
        Proper rotation matrices.

    Returns
    -------
    (..., 4) float array
        Quaternions with ``w >= 0``.
    """
    R = np.asarray(R, dtype=float)
    if R.shape == (3, 3):
        return _quat_xyzw_from_one_matrix(R)
    m00, m01, m02 = R[..., 0, 0], R[..., 0, 1], R[..., 0, 2]
    m10, m11, m12 = R[..., 1, 0], R[..., 1, 1], R[..., 1, 2]
    m20, m21, m22 = R[..., 2, 0], R[..., 2, 1], R[..., 2, 2]
    # Four candidate formulas; pick the numerically best one per matrix (Shepperd's method).
    cands = np.stack(
        [
            np.stack([m21 - m12, m02 - m20, m10 - m01, 1.0 + m00 + m11 + m22], axis=-1),
            np.stack([1.0 + m00 - m11 - m22, m01 + m10, m02 + m20, m21 - m12], axis=-1),
            np.stack([m01 + m10, 1.0 - m00 + m11 - m22, m12 + m21, m02 - m20], axis=-1),
            np.stack([m02 + m20, m12 + m21, 1.0 - m00 - m11 + m22, m10 - m01], axis=-1),
        ],
        axis=-2,
    )
    diag = np.stack([m00 + m11 + m22, m00, m11, m22], axis=-1)
    best = np.argmax(diag, axis=-1)
    q = np.take_along_axis(cands, best[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., 3:4] < 0.0, -q, q)


def _quat_xyzw_from_one_matrix(R: np.ndarray) -> np.ndarray:
    """:func:`quat_xyzw_from_matrix` of one (3, 3) matrix on Python floats (the same
    operations in the same order, so the same bits; the simulator's per-step ``set_pose``
    calls it, where numpy's small-array overhead was ~90 us a call)."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = R.tolist()
    diag = (m00 + m11 + m22, m00, m11, m22)
    best = max(range(4), key=diag.__getitem__)  # the first largest, as np.argmax
    if best == 0:
        q = (m21 - m12, m02 - m20, m10 - m01, 1.0 + m00 + m11 + m22)
    elif best == 1:
        q = (1.0 + m00 - m11 - m22, m01 + m10, m02 + m20, m21 - m12)
    elif best == 2:
        q = (m01 + m10, 1.0 - m00 + m11 - m22, m12 + m21, m02 - m20)
    else:
        q = (m02 + m20, m12 + m21, 1.0 - m00 - m11 + m22, m10 - m01)
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    sign = -1.0 if q[3] / norm < 0.0 else 1.0
    return np.array([sign * (v / norm) for v in q])


def matrix_from_quat_xyzw(q: np.ndarray) -> np.ndarray:
    """Rotation matrices of quaternions ``(x, y, z, w)``; shape (..., 4) -> (..., 3, 3)."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty((*q.shape[:-1], 3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - z * w)
    R[..., 0, 2] = 2 * (x * z + y * w)
    R[..., 1, 0] = 2 * (x * y + z * w)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - x * w)
    R[..., 2, 0] = 2 * (x * z - y * w)
    R[..., 2, 1] = 2 * (y * z + x * w)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def slerp_xyzw(q0: np.ndarray, q1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation between quaternions, shortest arc.

    Parameters
    ----------
    q0, q1 : (..., 4) float arrays
    s : (...) float array, interpolation fraction in [0, 1].

    Returns
    -------
    (..., 4) unit quaternions.
    """
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    s = np.asarray(s, dtype=float)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0.0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_t = np.sin(theta)
    small = sin_t < 1e-9
    safe = np.where(small, 1.0, sin_t)
    w0 = np.where(small, 1.0 - s, np.sin((1.0 - s) * theta) / safe)
    w1 = np.where(small, s, np.sin(s * theta) / safe)
    q = w0 * q0 + w1 * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def rotation_angle_rad(R: np.ndarray) -> np.ndarray:
    """Rotation angle of rotation matrices, (..., 3, 3) -> (...), in [0, pi]."""
    R = np.asarray(R, dtype=float)
    c = (np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0
    return np.arccos(np.clip(c, -1.0, 1.0))
