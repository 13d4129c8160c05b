"""Settings of planning: :class:`PlannerSettings` (grasp, motion, timing) and :class:`ArmSettings`.

Both are frozen, validated on construction, and stored in the plan file's ``settings`` (see
:class:`asmplan.planner.plan.Plan` and ``docs/plan-format.md``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any

from .ompl_backend import PLANNERS
from .timing import TimingSettings


@dataclass(frozen=True)
class ArmSettings:
    """Settings of the arm's kinematics and checks (see :mod:`asmplan.planner.arm`).

    Parameters
    ----------
    ik_tolerance_m, ik_tolerance_rad : float
        Convergence of inverse kinematics: flange position (m) and orientation (rad) error.
    ik_seeds : int
        Seeds of the all-branches IK (8 structured: shoulder x elbow x wrist, the rest
        seeded random).
    seed : int
        Seed of the random IK seeds and of the self-collision set-up.
    max_joint_jump_rad : float
        Largest joint change between two trajectory samples on one branch; more is a branch
        change or a singularity.
    joint_limit_margin_rad : float
        A joint closer than this to its limit (0.01 rad = 0.57 deg) is "at its limit".
    min_manipulability_ratio : float
        Floor of the manipulability along a path, as a fraction of the arm's best.
    check_step_m : float
        Arm collision check: where links come closer than this to anything, states are
        checked at this point travel.
    plan_tool_turns : bool
        Choose the tool turn (the half-turn grasp symmetry) over the whole sequence, least
        joint travel between steps (:mod:`asmplan.planner.arm_turns`); False: step by step,
        each nearest the arm's last state.
    """

    ik_tolerance_m: float = 1e-6
    ik_tolerance_rad: float = 1e-6
    ik_seeds: int = 16
    seed: int = 0
    max_joint_jump_rad: float = 0.2
    joint_limit_margin_rad: float = 0.01
    min_manipulability_ratio: float = 0.01
    check_step_m: float = 5e-4
    plan_tool_turns: bool = True

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "plan_tool_turns":
                if not isinstance(v, bool):
                    raise ValueError(f"ArmSettings.plan_tool_turns: expected true or false, "
                                     f"found {v!r}")
                continue
            if f.name in ("seed", "joint_limit_margin_rad"):
                ok = isinstance(v, int | float) and v >= 0
            else:
                ok = isinstance(v, int | float) and math.isfinite(v) and v > 0
            if not ok:
                raise ValueError(f"ArmSettings.{f.name}: expected a number > 0 (>= 0 for seed "
                                 f"and margin), found {v!r}")


@dataclass(frozen=True)
class PlannerSettings:
    """Every setting of grasp, motion and timing planning (SI units).

    Parameters
    ----------
    planner : str
        OMPL planner name (see :data:`asmplan.planner.ompl_backend.PLANNERS`).
    time_budget_s : float
        Search budget of one OMPL query, s.
    seed : int
        Seed of every random choice (OMPL, surface sampling); same seed, same plan.
    ompl_resolution_m : float
        OMPL's motion-check resolution (SE(3) distance, m + rad); the result is re-checked.
    recheck_step_m : float
        Dense re-check step: no point of the moving bodies travels more than this between
        two checked poses, m.
    insertion_step_m : float
        Upper bound of the step along the mate axis for the straight segments, m; the step
        actually used is ``min(insertion_step_m, 4 * smallest radial clearance)`` with a floor
        of ``min_insertion_step_m``.
    min_insertion_step_m : float
        Floor of the insertion check step, m.
    contact_tolerance_m : float
        Penetration accepted between a part and its mate partner where they touch when
        seated (face on face), m. Deeper contact is a collision.
    finger_clearance_m : float
        Extra opening per finger beyond the part's width for approach and release, m.
    grasp_standoff_m : float
        Distance the open gripper travels along its approach axis onto the part, and back
        off after release, m.
    max_grasps : int
        Grasps whose full motion is attempted per step before giving up (a grasp whose grip
        cannot hold the step's load is rejected before its motion and is not counted).
    max_grasp_candidates : int
        Ranked grasp candidates examined (finger collisions) per step before giving up.
    surface_samples : int
        Surface samples per part for antipodal grasp search.
    replan_attempts : int
        OMPL retries (halving the resolution, new seed offset) when a path fails the dense
        re-check.
    regrasp : bool
        When no grasp of a part works both where it lies and where it goes, put it down on
        a free area of the table in another stable orientation and grasp it again (a
        "regrasp" step, :mod:`asmplan.planner.regrasp`).
    max_regrasp_poses : int
        Poses to put a part down that are tried per step before giving up.
    collision_level : str
        Level of detail of the part models used for planning ("exact" or "convex", see
        :mod:`asmplan.parts.lod`); coarse models serve as a conservative first tier.
    timing : TimingSettings
    """

    planner: str = "RRTConnect"
    time_budget_s: float = 2.0
    seed: int = 0
    ompl_resolution_m: float = 4e-3
    recheck_step_m: float = 1e-4
    insertion_step_m: float = 1e-4
    min_insertion_step_m: float = 2e-5
    contact_tolerance_m: float = 2e-5
    finger_clearance_m: float = 3e-3
    grasp_standoff_m: float = 0.03
    max_grasps: int = 6
    max_grasp_candidates: int = 400
    surface_samples: int = 3000
    replan_attempts: int = 3
    collision_level: str = "convex"
    regrasp: bool = True
    max_regrasp_poses: int = 6
    timing: TimingSettings = field(default_factory=TimingSettings)
    arm: ArmSettings = field(default_factory=ArmSettings)

    def __post_init__(self) -> None:
        if self.planner not in PLANNERS:
            raise ValueError(f"planner: expected one of {sorted(PLANNERS)}, found {self.planner!r}")
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in ("planner", "timing", "collision_level", "arm"):
                continue
            if f.name == "regrasp":
                if not isinstance(v, bool):
                    raise ValueError(f"PlannerSettings.regrasp: expected true or false, "
                                     f"found {v!r}")
                continue
            if f.name in ("seed", "replan_attempts"):
                if not (isinstance(v, int) and v >= 0):
                    raise ValueError(f"PlannerSettings.{f.name}: expected an integer >= 0, "
                                     f"found {v!r}")
                continue
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"PlannerSettings.{f.name}: expected > 0, found {v!r}")
        if self.collision_level not in ("exact", "convex"):
            raise ValueError(f"collision_level: expected exact or convex, found "
                             f"{self.collision_level!r}")
        if self.min_insertion_step_m > self.insertion_step_m:
            raise ValueError(f"min_insertion_step_m: expected <= insertion_step_m "
                             f"({self.insertion_step_m}), found {self.min_insertion_step_m}")

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PlannerSettings:
        d = dict(data)
        d["timing"] = TimingSettings(**d.get("timing", {}))
        d["arm"] = ArmSettings(**d.get("arm", {}))
        return cls(**d)
