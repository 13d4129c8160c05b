"""Typed planning failures, each carrying its evidence.

Every error derives from :class:`PlanningError` and offers ``evidence()``, a JSON-safe dict
(SI units, poses as nested lists) that the CLI prints and a report can show. The message
(``str(error)``) names the step, the part and the obstacle in words.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import AsmplanError


def _pose_list(T: np.ndarray | None) -> list[list[float]] | None:
    return None if T is None else np.asarray(T, dtype=float).round(9).tolist()


@dataclass(frozen=True, eq=False)
class CollidingPair:
    """Two bodies found in contact: names, penetration depth (m) and a contact point (world, m).

    ``depth_m`` and ``point_m`` are None when the checker gave only a yes/no answer.
    """

    a: str
    b: str
    depth_m: float | None = None
    point_m: np.ndarray | None = None

    def as_dict(self) -> dict[str, Any]:
        return {"a": self.a, "b": self.b,
                "depth_m": None if self.depth_m is None else float(self.depth_m),
                "point_m": None if self.point_m is None
                else np.asarray(self.point_m, dtype=float).round(9).tolist()}

    def __str__(self) -> str:
        depth = "" if self.depth_m is None else f" (depth {self.depth_m * 1e3:.3f} mm"
        if self.point_m is not None:
            p = np.asarray(self.point_m) * 1e3
            depth += f"{', ' if depth else ' ('}at [{p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}] mm"
        return f"{self.a} / {self.b}{depth}{')' if depth else ''}"


def step_number(index: int | None) -> int | None:
    """The 1-based step number people read for a 0-based step index (None stays None)."""
    return None if index is None else index + 1


class PlanningError(AsmplanError):
    """Base of all planning failures. ``step`` is the step index (0-based) or None; messages
    name the step as people count it, from 1 (``step_number``), as every report and table
    does; ``alternatives`` lists other part orders that were tried and how they failed."""

    kind = "planning"

    def __init__(self, message: str, step: int | None = None, part: str | None = None) -> None:
        super().__init__(message)
        self.step = step
        self.part = part
        self.alternatives: list[dict[str, Any]] = []  # other part orders tried, with failures

    def evidence(self) -> dict[str, Any]:
        """JSON-safe evidence of the failure."""
        out: dict[str, Any] = {"kind": self.kind, "message": str(self), "step": self.step,
                               "step_number": step_number(self.step), "part": self.part}
        if self.alternatives:
            out["alternatives"] = list(self.alternatives)
        return out


class StartInCollisionError(PlanningError):
    """A body is in collision where the plan must start from (a start pose or a layout)."""

    kind = "start_in_collision"

    def __init__(self, pairs: Sequence[CollidingPair], step: int | None = None,
                 part: str | None = None, T_world_part: np.ndarray | None = None,
                 where: str = "start pose") -> None:
        self.pairs = tuple(pairs)
        self.T_world_part = None if T_world_part is None else np.asarray(T_world_part, float)
        self.where = where
        listed = "; ".join(str(p) for p in self.pairs[:4])
        more = f" and {len(self.pairs) - 4} more" if len(self.pairs) > 4 else ""
        who = f'step {step_number(step)} (part "{part}")' if step is not None else "the initial layout"
        super().__init__(f"{who}: in collision at the {where}: {listed}{more}", step, part)

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "where": self.where,
                "pairs": [p.as_dict() for p in self.pairs],
                "T_world_part": _pose_list(self.T_world_part)}


class NoPathError(PlanningError):
    """No collision-free path between two poses was found within the budget.

    ``partial_path`` holds the gripper poses (N, 4, 4) reached so far (at least the start);
    ``pairs`` the collisions seen at the closest failing pose, when known.
    """

    kind = "no_path"

    def __init__(self, step: int, part: str, partial_path: np.ndarray, reason: str,
                 pairs: Sequence[CollidingPair] = ()) -> None:
        self.partial_path = np.asarray(partial_path, dtype=float).reshape(-1, 4, 4)
        self.reason = reason
        self.pairs = tuple(pairs)
        super().__init__(f'step {step_number(step)} (part "{part}"): no collision-free path: {reason}',
                         step, part)

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "reason": self.reason,
                "partial_path_T_world_gripper": _pose_list(self.partial_path),
                "pairs": [p.as_dict() for p in self.pairs]}


class InsertionBlockedError(PlanningError):
    """The straight approach/insertion along the mate axis hits an obstacle.

    ``obstacle`` names the body in the way, ``T_world_part`` is the pose of the moving part
    where it hits (the first colliding sample), ``to_seat_m`` how far that pose is from the
    seated pose along the mate axis, ``segment`` which pose or segment: "pre-insertion pose",
    "insertion" or "assembled pose".
    """

    kind = "insertion_blocked"

    def __init__(self, step: int, part: str, obstacle: str, T_world_part: np.ndarray,
                 pairs: Sequence[CollidingPair] = (), to_seat_m: float = 0.0,
                 segment: str = "insertion") -> None:
        self.obstacle = obstacle
        self.T_world_part = np.asarray(T_world_part, dtype=float)
        self.pairs = tuple(pairs)
        self.to_seat_m = float(to_seat_m)
        self.segment = segment
        p = self.T_world_part[:3, 3] * 1e3
        super().__init__(
            f'step {step_number(step)} (part "{part}"): {segment} blocked by "{obstacle}": the part hits it '
            f"{self.to_seat_m * 1e3:.2f} mm before its seated pose along the mate axis, at "
            f"[{p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}] mm"
            + (f"; contacts: {'; '.join(str(c) for c in self.pairs[:3])}" if self.pairs else ""),
            step, part)

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "obstacle": self.obstacle, "segment": self.segment,
                "T_world_part": _pose_list(self.T_world_part),
                "to_seat_m": self.to_seat_m,
                "pairs": [c.as_dict() for c in self.pairs]}


class NoGraspError(PlanningError):
    """No grasp of ``part`` survived; ``reasons`` says why each candidate family failed."""

    kind = "no_grasp"

    def __init__(self, part: str, reasons: Sequence[str], step: int | None = None) -> None:
        self.reasons = tuple(reasons)
        shown = "; ".join(self.reasons[:5])
        more = f" (and {len(self.reasons) - 5} more)" if len(self.reasons) > 5 else ""
        where = f'step {step_number(step)} (part "{part}")' if step is not None else f'part "{part}"'
        super().__init__(f"{where}: no feasible grasp: {shown}{more}", step, part)

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "reasons": list(self.reasons)}


class GripInfeasibleError(PlanningError):
    """The clamp force needed to hold the part exceeds what may be applied.

    Numbers: ``required_N`` = safety_factor * m (g + a) / (2 mu) per finger, the ``limit_N``
    it exceeds and which limit that is (``limit_source``: "gripper max_force" or
    "part max_clamp_force").
    """

    kind = "grip_infeasible"

    def __init__(self, part: str, required_N: float, limit_N: float, limit_source: str,
                 mass_kg: float, mu: float, acceleration_m_s2: float, safety_factor: float,
                 step: int | None = None, *, lever_m: float = 0.0, pad_width_m: float = 0.0,
                 resistance_N: float = 0.0) -> None:
        self.lever_m = float(lever_m)
        self.pad_width_m = float(pad_width_m)
        self.resistance_N = float(resistance_N)
        self.required_N = float(required_N)
        self.limit_N = float(limit_N)
        self.limit_source = limit_source
        self.mass_kg = float(mass_kg)
        self.mu = float(mu)
        self.acceleration_m_s2 = float(acceleration_m_s2)
        self.safety_factor = float(safety_factor)
        where = f'step {step_number(step)} (part "{part}")' if step is not None else f'part "{part}"'
        super().__init__(
            f"{where}: grip infeasible: needs {self.required_N:.2f} N per finger "
            f"(= {self.safety_factor:g} x {self.mass_kg:.4f} kg x (9.81 + "
            f"{self.acceleration_m_s2:g}) m/s^2 / (2 x mu {self.mu:.3f})"
            + (f", combined with the moment of a {self.lever_m * 1e3:.1f} mm lever on "
               f"{self.pad_width_m * 1e3:.0f} mm pads" if self.lever_m > 0 else "")
            + (f", plus an insertion resistance of {self.resistance_N:g} N"
               if self.resistance_N > 0 else "")
            + f") but the {limit_source} is {self.limit_N:.2f} N", step, part)

    def evidence(self) -> dict[str, Any]:
        # no friction (mu = 0) needs an unbounded force: JSON has no infinity, so null
        required = self.required_N if math.isfinite(self.required_N) else None
        return {**super().evidence(), "required_N": required, "limit_N": self.limit_N,
                "limit_source": self.limit_source, "mass_kg": self.mass_kg, "mu": self.mu,
                "acceleration_m_s2": self.acceleration_m_s2,
                "safety_factor": self.safety_factor}


class ArmError(PlanningError):
    """The cell's arm cannot do a step: a pose out of reach, a joint beyond its limit, a
    singularity on the path, or an arm link in collision. ``T_world_tcp`` is the TCP pose
    where it fails, ``phase`` the trajectory phase ("approach", "lift", ...) or the named
    key pose ("grasp pose", "pre-insertion pose", ...)."""

    kind = "arm"

    def __init__(self, message: str, step: int, part: str, phase: str,
                 T_world_tcp: np.ndarray | None = None) -> None:
        self.phase = phase
        self.T_world_tcp = None if T_world_tcp is None else np.asarray(T_world_tcp, float)
        super().__init__(f'step {step} (part "{part}"): {message}', step, part)

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "phase": self.phase,
                "T_world_tcp": _pose_list(self.T_world_tcp)}


class OutOfReachError(ArmError):
    """A pose's flange lies farther from the arm's shoulder than its reach."""

    kind = "out_of_reach"

    def __init__(self, step: int, part: str, phase: str, distance_m: float, reach_m: float,
                 T_world_tcp: np.ndarray | None = None) -> None:
        self.distance_m = float(distance_m)
        self.reach_m = float(reach_m)
        super().__init__(f"{phase} of {part} is {distance_m * 1e3:.0f} mm from the arm's "
                         f"shoulder, reach {reach_m * 1e3:.0f} mm", step, part, phase,
                         T_world_tcp)

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "distance_m": self.distance_m, "reach_m": self.reach_m}


class JointLimitError(ArmError):
    """Every inverse-kinematics branch of a pose needs a joint beyond its limit.

    ``joint`` names the joint (of the branch that violates least), ``value_rad`` the angle
    it needs and ``lower_rad``/``upper_rad`` its limits."""

    kind = "joint_limit"

    def __init__(self, step: int, part: str, phase: str, joint: str, value_rad: float,
                 lower_rad: float, upper_rad: float, T_world_tcp: np.ndarray | None = None,
                 along_path: bool = False) -> None:
        self.joint = joint
        self.value_rad = float(value_rad)
        self.lower_rad = float(lower_rad)
        self.upper_rad = float(upper_rad)
        self.along_path = along_path
        limits = f"[{np.degrees(lower_rad):.1f}, {np.degrees(upper_rad):.1f}] deg"
        if along_path:
            msg = (f"{joint} reaches its limit during the {phase} of {part} "
                   f"({np.degrees(value_rad):.1f} deg, limits {limits})")
        else:
            msg = (f"{phase} of {part} needs {joint} at {np.degrees(value_rad):.1f} deg, beyond "
                   f"its limits {limits} (every inverse-kinematics branch)")
        super().__init__(msg, step, part, phase, T_world_tcp)

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "joint": self.joint, "value_rad": self.value_rad,
                "lower_rad": self.lower_rad, "upper_rad": self.upper_rad}


class ArmPathError(ArmError):
    """The arm cannot follow a Cartesian segment on any branch: the IK solution jumps
    (a singularity or a branch change), the manipulability falls below its floor, or a
    joint runs into its limit along the way. ``reason`` says which, per branch tried."""

    kind = "arm_path"

    def __init__(self, step: int, part: str, phase: str, reason: str,
                 T_world_tcp: np.ndarray | None = None) -> None:
        self.reason = reason
        super().__init__(f"the arm cannot follow the {phase}: {reason}", step, part, phase,
                         T_world_tcp)

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "reason": self.reason}


class ArmCollisionError(ArmError):
    """An arm link hits the cell, a part, the gripper or another link on the step's path."""

    kind = "arm_collision"

    def __init__(self, step: int, part: str, phase: str, pairs: Sequence[CollidingPair],
                 q_rad: np.ndarray | None = None, T_world_tcp: np.ndarray | None = None,
                 names: dict[str, str] | None = None) -> None:
        self.pairs = tuple(pairs)
        self.q_rad = None if q_rad is None else np.asarray(q_rad, float)
        names = names or {}

        def said(body: str) -> str:
            return f"{names[body]} ({body})" if body in names else body

        listed = "; ".join(f"{said(p.a)} hits {said(p.b)}" for p in self.pairs[:3])
        self.listed = listed
        super().__init__(f"during the {phase}: {listed}", step, part, phase, T_world_tcp)

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "pairs": [p.as_dict() for p in self.pairs],
                "q_rad": None if self.q_rad is None else self.q_rad.round(9).tolist()}
