"""A robot's pose error at a step's insertion, applied to the trajectory the robot follows.

One mechanism serves ``asmplan run/simulate --pose-error LATERAL_MM,TILT_DEG`` (the same error
at every insertion, :func:`asmplan.sim.simulate.simulate_plan`'s ``pose_error``) and the sweep's
sampled errors (:mod:`asmplan.sim.sweep`): the TCP, and with it the held part, is displaced
across the insertion axis and tilted about the axis perpendicular to both, ramped in during
the move before the insertion and held through it, as a stiff robot's calibration error is.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..knowledge.frames import rotation_about


@dataclass(frozen=True)
class PoseError:
    """Robot positioning error of one step, in the step's insertion frame.

    The insertion frame's z axis is the insertion direction; x and y span the plane across it.

    Attributes
    ----------
    lateral_m : (2,) tuple of float
        Offset of the part along x and y, m.
    tilt_rad : (2,) tuple of float
        Small rotations about x and y, rad.
    """

    lateral_m: tuple[float, float] = (0.0, 0.0)
    tilt_rad: tuple[float, float] = (0.0, 0.0)

    @property
    def lateral_norm_m(self) -> float:
        return math.hypot(*self.lateral_m)

    @property
    def tilt_norm_rad(self) -> float:
        return math.hypot(*self.tilt_rad)



    @classmethod
    def from_cli(cls, lateral_m: float, tilt_rad: float) -> PoseError:
        """``--pose-error LATERAL,TILT``: the part displaced ``lateral_m`` along the insertion
        frame's x (across the mate axis) and tilted ``tilt_rad`` about its y (perpendicular
        to both the mate axis and the displacement)."""
        return cls(lateral_m=(float(lateral_m), 0.0), tilt_rad=(0.0, float(tilt_rad)))

    def to_dict(self) -> dict[str, list[float]]:
        """JSON-safe: ``{"lateral_m": [x, y], "tilt_rad": [about x, about y]}``."""
        return {"lateral_m": [float(v) for v in self.lateral_m],
                "tilt_rad": [float(v) for v in self.tilt_rad]}


def insertion_frame(direction: Sequence[float]) -> np.ndarray:
    """Rotation (3, 3) whose columns are the insertion frame's x, y, z axes in the world.

    z is the insertion direction; x is the world x axis made perpendicular to z (the world y
    axis when z is within ~25 degrees of world x); y = z cross x.
    """
    z = np.asarray(direction, dtype=float)
    n = float(np.linalg.norm(z))
    if not (math.isfinite(n) and n > 0.0):
        raise ValueError(f"insertion direction: expected a non-zero vector, found {list(z)}")
    z = z / n
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = a - (a @ z) * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


POSE_ERROR_RAMP_PHASE = "translate"
"""The phase over which the robot's pose error builds up (min-jerk from 0 to full)."""


def apply_pose_error(trajectory: Any, direction: Sequence[float], error: PoseError) -> Any:
    """The trajectory a robot with positioning error ``error`` really follows.

    The error is that of the place pose: zero until the start of the
    :data:`POSE_ERROR_RAMP_PHASE` phase ("translate"; if absent, the phase before "lower"),
    growing along a min-jerk profile to its full value at its end and constant afterwards
    ("lower", "release", "retreat"). The lateral offset moves the TCP along the insertion
    frame's x and y (:func:`insertion_frame`); the tilt rotates the TCP about those axes
    through the TCP itself (x first, then y).

    Parameters
    ----------
    trajectory : asmplan.planner.trajectory.Trajectory
    direction : (3,) float
        The step's insertion direction, world frame.
    error : PoseError

    Returns
    -------
    Trajectory
        A new trajectory with the same times, forces and phases.
    """
    from asmplan.planner.trajectory import Trajectory, min_jerk

    if error == PoseError():
        return trajectory
    names = [p.name for p in trajectory.phases]
    if POSE_ERROR_RAMP_PHASE in names:
        ramp = trajectory.phases[names.index(POSE_ERROR_RAMP_PHASE)]
    elif "lower" in names and names.index("lower") > 0:
        ramp = trajectory.phases[names.index("lower") - 1]
    else:
        raise ValueError(f"apply_pose_error: expected a '{POSE_ERROR_RAMP_PHASE}' or 'lower' "
                         f"phase, found phases {names}")
    R_ins = insertion_frame(direction)
    t = trajectory.t_s
    s = min_jerk((t - ramp.t_start_s) / (ramp.t_end_s - ramp.t_start_s))
    offset = R_ins[:, :2] @ np.asarray(error.lateral_m, dtype=float)
    T = np.array(trajectory.T_world_gripper, dtype=float)
    for i in np.flatnonzero(s > 0.0):
        R_err = (rotation_about(R_ins[:, 1], s[i] * error.tilt_rad[1])
                 @ rotation_about(R_ins[:, 0], s[i] * error.tilt_rad[0]))
        T[i, :3, :3] = R_err @ T[i, :3, :3]
        T[i, :3, 3] += s[i] * offset
    return Trajectory(t_s=t, T_world_gripper=T, clamp_force_N=trajectory.clamp_force_N,
                      phases=trajectory.phases)
