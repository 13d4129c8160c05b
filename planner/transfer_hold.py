"""The grip judged along the planned transfer, not only at the pick and the insertion pose.

The grasp search judges a grasp's hold (:mod:`asmplan.planner.grasp_hold`) with gravity's
direction at the pick and at the insertion pose. Between them the gripper turns (a part
picked lying and inserted upright, a horizontal insertion, a regrasp), and gravity takes
every direction the turn passes through: a part whose grip carries its weight by the pads'
normal forces at both ends (gravity along the closing axis) must carry it in friction and
torsion when the gripper has turned it 90 deg. Once the transfer is planned, the part-frame
gravity directions are sampled along it (the orientations between two poses of the path are
their slerp, as the trajectory interpolates them) and the hold is judged again on them.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from .rotations import matrix_from_quat_xyzw, quat_xyzw_from_matrix, slerp_xyzw

TURN_SAMPLE_RAD = math.radians(5.0)
"""Largest turn between two sampled orientations of the transfer."""


def part_orientations_along(path_T_world_gripper: np.ndarray, T_part_gripper: np.ndarray,
                            max_turn_rad: float = TURN_SAMPLE_RAD) -> np.ndarray:
    """The part's orientations ``R_world_part`` (n, 3, 3) along a gripper path.

    Parameters
    ----------
    path_T_world_gripper : (N, 4, 4) float array
        The gripper's poses along the path, world frame (N >= 1).
    T_part_gripper : (4, 4) float array
        The grasp (the gripper frame in the part frame).
    max_turn_rad : float
        Each leg is sampled on the slerp of its ends' orientations at most this far apart.
    """
    P = np.asarray(path_T_world_gripper, float).reshape(-1, 4, 4)
    q = quat_xyzw_from_matrix(P[:, :3, :3]).reshape(-1, 4)
    out = [P[:1, :3, :3]]
    for q0, q1 in itertools.pairwise(q):
        angle = 2.0 * math.acos(min(1.0, abs(float(q0 @ q1))))
        n = max(1, math.ceil(angle / max_turn_rad))
        s = np.arange(1, n + 1) / n
        out.append(matrix_from_quat_xyzw(slerp_xyzw(q0, q1, s)))
    R_world_gripper = np.concatenate(out, axis=0)
    R_gripper_part = np.asarray(T_part_gripper, float)[:3, :3].T
    return R_world_gripper @ R_gripper_part


def gravity_in_part(R_world_part: np.ndarray) -> np.ndarray:
    """Gravity's direction (world -z) in the part frame at each orientation, (n, 3)."""
    return -np.asarray(R_world_part, float)[:, 2, :]


def horizontal_lever_m(R_world_part: np.ndarray, lever_part_m: np.ndarray) -> float:
    """The largest horizontal length of the lever ``lever_part_m`` (3,), part frame, over the
    orientations: the part of it through which gravity turns the part."""
    v = np.asarray(R_world_part, float) @ np.asarray(lever_part_m, float)
    return float(np.hypot(v[:, 0], v[:, 1]).max())
