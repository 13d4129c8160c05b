"""The arm's reach for the sequence planner: can the cell's arm put a grasp where a step needs
it?

The gripper-access screening (:mod:`asmplan.planner.access`) tries each part's best grasp
candidates once per insertion direction; with an arm in the cell each candidate is also
screened here at the step's key TCP poses, as the motion planner checks them
(:meth:`asmplan.planner.arm_planner.ArmPlanner.check_pose`): the pick pose, the lifted pose,
the pre-insertion pose and the seated pose. A pose passes when the arm has an inverse
kinematics solution within its joint limits for the gripper as it is or turned half a turn
about its approach axis (a parallel gripper holds the same grasp both ways). Tiers, cheapest
first:

1. reach: the flange's distance from the shoulder against the arm's reach (no IK);
2. one IK solution (:meth:`asmplan.planner.arm.ArmModel.ik_any`), warm-started from the last
   solution found (neighbouring grasps and poses of one step are close in joint space);
3. only when both fail: every branch (:meth:`ArmModel.ik_all`), for the evidence (the joint
   beyond its limit, or no solution).

Results are cached per pose (rounded to 1 um and 1e-6), so a part's pick and lifted poses,
which do not depend on the insertion direction, are solved once per grasp. The result does
not depend on which parts are placed, so an order whose step needs a pose the arm cannot
reach carries that step's reason in every order that uses it. The arm's links at the
pre-insertion and seated poses, which do depend on the parts placed, are checked by
:mod:`asmplan.planner.arm_reach_collisions` from the solutions found here
(:meth:`ArmReach.solution`).

This module imports no kinematics library itself; :mod:`asmplan.planner.arm` (pinocchio) is
loaded only when the cell has an arm.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..knowledge.model import Robot
from ..parts.cell import HALF_TURN
from .errors import ArmCollisionError, ArmError, ArmPathError, JointLimitError, OutOfReachError
from .settings import ArmSettings

if TYPE_CHECKING:
    from .arm import ArmModel


@dataclass(frozen=True, eq=False)
class ReachFailure:
    """Why the arm cannot hold a grasp at one of a step's key poses.

    Parameters
    ----------
    pose : str
        "pick pose", "lifted pose", "pre-insertion pose" or "seated pose".
    error : ArmError
        The typed failure with its evidence (:class:`OutOfReachError` with the distance and
        the reach, :class:`JointLimitError` naming the joint, or :class:`ArmPathError`).
    """

    pose: str
    error: ArmError

    @property
    def kind(self) -> str:
        return self.error.kind

    def text(self) -> str:
        """The failure in words, without a step number (the sequence planner's steps are
        numbered per order)."""
        e = self.error
        if isinstance(e, OutOfReachError):
            return (f"{self.pose} of {e.part} is {e.distance_m * 1e3:.0f} mm from the arm's "
                    f"shoulder, reach {e.reach_m * 1e3:.0f} mm")
        if isinstance(e, JointLimitError):
            return (f"{self.pose} of {e.part} needs {e.joint} at "
                    f"{np.degrees(e.value_rad):.1f} deg, beyond its limits "
                    f"[{np.degrees(e.lower_rad):.1f}, {np.degrees(e.upper_rad):.1f}] deg "
                    "(every inverse-kinematics branch)")
        if isinstance(e, ArmCollisionError):
            return f"{self.pose} of {e.part}: {e.listed} (every inverse-kinematics branch)"
        return f"{self.pose} of {e.part}: {getattr(e, 'reason', e)}"


def _pose_key(T: np.ndarray) -> bytes:
    return np.round(np.asarray(T, float)[:3], 6).tobytes()


@dataclass
class ArmReach:
    """Reach and joint-limit screening of TCP poses for one cell's arm (cached per pose).

    Parameters
    ----------
    robot : Robot
        The product's ``resources.robot`` (with its URDF).
    settings : ArmSettings
    """

    robot: Robot
    settings: ArmSettings = field(default_factory=ArmSettings)
    _arm: ArmModel | None = None
    _cache: dict[bytes, ArmError | None] = field(default_factory=dict)
    _q: dict[bytes, np.ndarray] = field(default_factory=dict)
    _near: np.ndarray | None = None
    solved: int = 0  # poses that needed IK (not answered by the cache or the reach tier)

    @property
    def arm(self) -> ArmModel:
        if self._arm is None:
            from .arm import ArmModel  # pinocchio only when the cell has an arm

            self._arm = ArmModel(self.robot, self.settings)
        return self._arm

    def pose_failure(self, part: str, what: str, T_world_tcp: np.ndarray) -> ArmError | None:
        """Why the arm cannot put its TCP at ``T_world_tcp`` (4, 4) (tool as it is or
        turned half a turn), or None when it can."""
        key = _pose_key(T_world_tcp)
        if key in self._cache:
            return self._rename(self._cache[key], part, what)
        arm = self.arm
        dist = arm.flange_distance_m(T_world_tcp)
        turned = T_world_tcp @ HALF_TURN
        err: ArmError | None
        if dist > arm.reach_m:
            err = OutOfReachError(-1, part, what, dist, arm.reach_m, T_world_tcp)
        else:
            self.solved += 1
            q = arm.ik_any(T_world_tcp, self._near)
            if q is None:
                q = arm.ik_any(turned, self._near)
            if q is not None:
                self._near = q
                self._q[key] = q
                err = None
            else:
                err = self._evidence(part, what, T_world_tcp, dist)
        self._cache[key] = err
        return err

    def solution(self, T_world_tcp: np.ndarray) -> np.ndarray | None:
        """The joint angles (6,) found for a pose :meth:`pose_failure` passed (for the tool as
        it is or turned half a turn), else None."""
        return self._q.get(_pose_key(T_world_tcp))

    def _evidence(self, part: str, what: str, T: np.ndarray, dist: float) -> ArmError:
        """The failure of a pose within reach that no IK seed solved (every branch tried)."""
        arm = self.arm
        _, fail = arm.ik_all(T)
        if fail is not None and fail.kind == "limit":
            return JointLimitError(-1, part, what, fail.joint, fail.value_rad, fail.lower_rad,
                                   fail.upper_rad, T)
        return ArmPathError(-1, part, what, f"no inverse-kinematics solution (flange "
                            f"{dist * 1e3:.0f} mm from the shoulder, reach "
                            f"{arm.reach_m * 1e3:.0f} mm)", T)

    @staticmethod
    def _rename(err: ArmError | None, part: str, what: str) -> ArmError | None:
        """A cached failure for another part or pose name at the same TCP pose."""
        if err is None or (err.part == part and err.phase == what):
            return err
        if isinstance(err, OutOfReachError):
            return OutOfReachError(-1, part, what, err.distance_m, err.reach_m, err.T_world_tcp)
        if isinstance(err, JointLimitError):
            return JointLimitError(-1, part, what, err.joint, err.value_rad, err.lower_rad,
                                   err.upper_rad, err.T_world_tcp)
        return ArmPathError(-1, part, what, str(getattr(err, "reason", err)), err.T_world_tcp)

    def screen(self, part: str, poses: Sequence[tuple[str, np.ndarray]]) -> ReachFailure | None:
        """The first of a step's key TCP poses ``(name, (4, 4))`` the arm cannot take, or
        None when it can take them all."""
        for what, T in poses:
            err = self.pose_failure(part, what, T)
            if err is not None:
                return ReachFailure(what, err)
        return None


__all__ = ["ArmReach", "ReachFailure"]
