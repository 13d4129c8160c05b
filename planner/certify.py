"""Certification of a path of TCP poses by conservative advancement: distance bounds let the
carried bodies move without a check; where they come close, exact checks at a fine step.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..knowledge.model import Gripper
from .errors import (
    CollidingPair,
)
from .partdata import PartData
from .plan import Grasp
from .rotations import rotation_angle_rad
from .scene import Scene


class _Interpolator:
    """Pose at fraction ``s`` between two poses: position lerp, rotation about the fixed
    relative axis (= slerp), without per-call quaternion conversions."""

    def __init__(self, T0: np.ndarray, T1: np.ndarray) -> None:
        self.T0 = T0
        self.dp = T1[:3, 3] - T0[:3, 3]
        Rrel = T0[:3, :3].T @ T1[:3, :3]
        self.angle = float(rotation_angle_rad(Rrel))
        if self.angle > 1e-12:
            if self.angle < math.pi - 1e-6:
                w = np.array([Rrel[2, 1] - Rrel[1, 2], Rrel[0, 2] - Rrel[2, 0],
                              Rrel[1, 0] - Rrel[0, 1]]) / (2.0 * math.sin(self.angle))
            else:  # near pi: axis from the symmetric part
                B = (Rrel + np.eye(3)) / 2.0
                w = B[:, int(np.argmax(np.diag(B)))]
            w = w / np.linalg.norm(w)
            self.K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
            self.K2 = self.K @ self.K

    def __call__(self, s: float) -> np.ndarray:
        T = self.T0.copy()
        T[:3, 3] += s * self.dp
        if self.angle > 1e-12:
            th = s * self.angle
            T[:3, :3] = self.T0[:3, :3] @ (np.eye(3) + math.sin(th) * self.K
                                           + (1.0 - math.cos(th)) * self.K2)
        return T


@dataclass(frozen=True, eq=False)
class PathCheck:
    """Result of certifying a path: ``ok``, the poses checked, and on failure the first
    colliding TCP pose with its pairs and the leg index."""

    ok: bool
    checked: int
    T_world_gripper: np.ndarray | None = None
    pairs: tuple[CollidingPair, ...] = ()
    leg: int = -1


def certify_path(scene: Scene, poses: np.ndarray, carried: Sequence[tuple[str, np.ndarray]],
                 obstacles: Sequence[str], radius_m: float, fine_step_m: float) -> PathCheck:
    """Prove a polyline of TCP poses (N, 4, 4) free of collision for the carried bodies.

    ``carried`` lists (body name, ``T_tcp_body``). Conservative advancement: at each checked
    pose a lower bound ``d`` of the distance to every obstacle (box gaps, exact FCL distance
    where boxes are close) lets the bodies move ``d`` (point travel ``|dp| + r dtheta``)
    without another check; where ``d < fine_step_m`` the pose is checked for collision and the
    next one is ``fine_step_m`` further.
    """
    checked = 0
    for leg, (T0, T1) in enumerate(itertools.pairwise(poses)):
        dp = T1[:3, 3] - T0[:3, 3]
        dth = float(rotation_angle_rad(T0[:3, :3].T @ T1[:3, :3]))
        travel = float(np.linalg.norm(dp)) + radius_m * dth
        if travel <= 0:
            continue
        interp = _Interpolator(T0, T1)
        s = 0.0
        while True:
            T = interp(min(s, 1.0))
            bodies = [(n, T @ Tb) for n, Tb in carried]
            checked += 1
            remaining = (1.0 - s) * travel
            d = scene.distance_bound(bodies, obstacles, enough=min(remaining, 0.05) + fine_step_m)
            if d <= fine_step_m:
                if scene.collides(bodies, obstacles):
                    return PathCheck(False, checked, T,
                                     tuple(scene.contacts_at(bodies, obstacles)), leg)
                step = fine_step_m
            else:
                step = d
            if step >= remaining:
                break
            s += step / travel
        # the leg's end pose is the next leg's start (or checked below for the last leg)
    T = poses[-1]
    bodies = [(n, T @ Tb) for n, Tb in carried]
    checked += 1
    if scene.collides(bodies, obstacles):
        return PathCheck(False, checked, T, tuple(scene.contacts_at(bodies, obstacles)),
                         len(poses) - 2)
    return PathCheck(True, checked)



def carried_radius(gripper: Gripper, data: PartData, T_pg: np.ndarray, g: Grasp) -> float:
    """Radius (m) about the TCP of the gripper (open) and the held part: bounds the travel of
    any of their points under a rotation (``r dtheta``)."""
    pts = data.points_m @ T_pg[:3, :3].T + T_pg[:3, 3]
    W, t, L = (float(v) for v in gripper.finger_size_m)
    px, py, pz = (float(v) for v in gripper.palm_size_m)
    corner = max(math.hypot(math.hypot(W / 2, g.open_width_m / 2 + t), L / 2),
                 math.hypot(math.hypot(px / 2, py / 2), L / 2 + pz))
    return max(float(np.linalg.norm(pts, axis=1).max()), corner)
