"""Homogeneous transforms as plain ``(4, 4)`` float arrays (``T_a_b`` maps b-coords to a)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike


def rotation_from_rpy(rpy_rad: Sequence[float]) -> np.ndarray:
    """Rotation matrix ``Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (fixed-axis XYZ), shape (3, 3)."""
    r, p, y = (float(v) for v in rpy_rad)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def make_T(xyz_m: Sequence[float] = (0.0, 0.0, 0.0), rpy_rad: Sequence[float] = (0.0, 0.0, 0.0)
           ) -> np.ndarray:
    """Homogeneous transform from a translation (m) and roll-pitch-yaw (rad), shape (4, 4)."""
    T = np.eye(4)
    T[:3, :3] = rotation_from_rpy(rpy_rad)
    T[:3, 3] = np.asarray(xyz_m, dtype=float)
    return T


def invert(T: np.ndarray) -> np.ndarray:
    """Inverse of a rigid transform, shape (4, 4)."""
    out = np.eye(4)
    R = T[:3, :3]
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ T[:3, 3]
    return out


def transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply ``T`` (4, 4) to ``points`` (n, 3); returns (n, 3)."""
    pts = np.asarray(points, dtype=float)
    return pts @ T[:3, :3].T + T[:3, 3]


def rotation_about(axis: ArrayLike, angle_rad: float) -> np.ndarray:
    """Rotation matrix (3, 3) of ``angle_rad`` about the unit vector ``axis`` (Rodrigues)."""
    k = np.asarray(axis, dtype=float)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle_rad) * K + (1.0 - math.cos(angle_rad)) * (K @ K)


def rotation_between(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """A rotation matrix (3, 3) that turns unit direction ``a`` onto ``b``."""
    u = np.asarray(a, float)
    u = u / np.linalg.norm(u)
    w = np.asarray(b, float)
    w = w / np.linalg.norm(w)
    v = np.cross(u, w)
    c = float(np.dot(u, w))
    if c > 1.0 - 1e-12:
        return np.eye(3)
    if c < -1.0 + 1e-12:  # opposite: rotate pi about any axis normal to a
        axis = np.cross(u, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(u, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx * (1.0 / (1.0 + c))


def frame_from_axis(origin: ArrayLike, axis: ArrayLike) -> np.ndarray:
    """A transform (4, 4) whose z axis is ``axis`` and origin is ``origin``."""
    T = np.eye(4)
    T[:3, :3] = rotation_between([0.0, 0.0, 1.0], axis)
    T[:3, 3] = np.asarray(origin, dtype=float)
    return T
