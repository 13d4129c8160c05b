"""The arm's links at a step's assembled-end poses, for the sequence planner's access screening.

:mod:`asmplan.planner.arm_reach` screens a grasp for the arm's reach and joint limits; this
module adds the arm's collisions there, with the same FCL models the motion planner checks
every state of a path with (:mod:`asmplan.parts.arm_links`, :mod:`asmplan.planner.arm_clearance`).
At the grasp's pre-insertion and seated TCP poses, the arm's moving links are posed at the
IK solution the reach screening found and checked against the table and every other part
at its assembled pose (the full assembly, as the access screening's other checks):

* no link meets anything: the grasp's blocking set is unchanged (the common case; one
  forward-kinematics pass and a box test per pose);
* otherwise every IK branch of the seated pose (tool as it is and turned half a turn) is
  tried, each carried to the pre-insertion pose from its own joint angles; a branch whose
  links meet the table, a fixtured part (it stands in its pose from the start: a clamp
  column, a vise) or the moving part itself is unusable, and one whose links meet parts
  ``M`` makes the grasp usable only in partial assemblies disjoint from ``M``, like the parts
  its fingers meet. The grasp gives one blocking set per usable branch; with no
  usable branch it is dropped, with the pairs of the first branch as the reason
  ("forearm (arm:link3) hits column").

An order whose step needs the forearm where a part already stands is so ranked as the
gripper's access ranks it (the ``unreachable`` cost term) with the reason kept. Links against
the gripper, the carried part and each other are the motion planner's (they do not depend on
the order).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..knowledge.model import Robot
from ..parts.cell import HALF_TURN
from .errors import ArmCollisionError, CollidingPair
from .scene import TABLE as _TABLE


@dataclass(frozen=True, eq=False)
class ArmHits:
    """The arm's collisions at a grasp's assembled-end poses.

    Parameters
    ----------
    sets : tuple of frozenset of str
        One per usable IK branch: the parts its links meet (empty: free in every order).
        Empty tuple: no branch is usable.
    error : ArmCollisionError or None
        When the first branch tried meets anything: its pairs (the reason when no set is
        usable in the order at hand).
    """

    sets: tuple[frozenset[str], ...]
    error: ArmCollisionError | None = None


@dataclass
class ArmLinkScreen:
    """The arm's links in the access screening's FCL scene (added once, as ``arm:<link>``).

    Parameters
    ----------
    robot : Robot
    arm : asmplan.planner.arm.ArmModel
        The reach screening's kinematics (its solutions are reused).
    scene : asmplan.planner.scene.Scene
        The access screening's scene (parts at their assembled poses).
    """

    robot: Robot
    arm: Any
    scene: Any
    _links: list[str] = field(default_factory=list)
    _body: dict[str, str] = field(default_factory=dict)
    _names: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from ..knowledge.robot import LINK_NAMES
        from ..parts.arm_links import link_models
        from .arm import ARM_PREFIX, _read_urdf

        urdf = _read_urdf(Path(self.robot.urdf_path), self.robot.flange_link)  # type: ignore[arg-type]
        models = link_models(urdf)
        m = self.arm.model
        far = np.eye(4)
        far[:3, 3] = -1e3
        for ln in urdf.links:
            # the links on the base never move: the cell is laid out around them
            if ln not in models or m.frames[m.getFrameId(ln)].parentJoint == 0:
                continue
            self._links.append(ln)
            self._body[ln] = ARM_PREFIX + ln
            self.scene.add_body(ARM_PREFIX + ln, models[ln], far)
        self._names = {ARM_PREFIX + ln: n for ln, n in
                       LINK_NAMES.get(self.robot.model.lower(), {}).items()
                       if ln in self._body}

    def _pairs(self, q: np.ndarray, obstacles: Sequence[str]) -> list[CollidingPair]:
        out = []
        for ln, T in zip(self._links, self.arm.link_poses(q, self._links), strict=True):
            out += [CollidingPair(self._body[ln], o)
                    for o in self.scene.hits(self._body[ln], T, obstacles)]
        return out

    def _branch(self, qs: Sequence[np.ndarray], obstacles: Sequence[str]
                ) -> list[CollidingPair]:
        out: dict[tuple[str, str], CollidingPair] = {}
        for q in qs:
            for p in self._pairs(q, obstacles):
                out.setdefault((p.a, p.b), p)
        return list(out.values())

    def screen(self, part: str, poses: Sequence[tuple[str, np.ndarray]],
               solutions: Sequence[np.ndarray | None], others: Sequence[str]) -> ArmHits:
        """The arm's collisions at ``poses`` (``(name, T_world_tcp)``: the pre-insertion pose,
        then the seated pose), whose IK ``solutions`` the reach screening found; ``others``
        are the parts besides ``part`` (at their assembled poses). A fixtured part stands in
        its assembled pose from the start (:func:`asmplan.planner.layout.initial_layout`):
        like the table, a branch meeting it is unusable in every order."""
        obstacles = [_TABLE, part, *others]
        always = {_TABLE, part, *(o for o in others if self.scene.product.is_fixtured(o))}
        if all(q is not None for q in solutions):
            first = self._branch(solutions, obstacles)  # type: ignore[arg-type]
            if not first:
                return ArmHits((frozenset(),))
        else:
            first = []
        # every branch of the seated pose, each carried back to the pre-insertion pose
        (what_pre, T_pre), (what_seat, T_seat) = poses
        sets: list[frozenset[str]] = []
        tried: list[CollidingPair] = []
        for turn in (np.eye(4), HALF_TURN):
            sols, _ = self.arm.ik_all(T_seat @ turn)
            for sol in sols:
                q_pre = self.arm.ik_any(T_pre @ turn, sol.q_rad)
                if q_pre is None:
                    continue
                pairs = self._branch((q_pre, sol.q_rad), obstacles)
                tried = tried or pairs
                met = {p.b for p in pairs}
                if not met & always:
                    sets.append(frozenset(met))
        pairs = first or tried
        error = ArmCollisionError(-1, part, f"{what_pre} and {what_seat}", pairs, None, T_seat,
                                  self._names) if pairs else None
        if sets:
            return ArmHits(tuple(sorted(set(sets), key=lambda m: (len(m), sorted(m)))), error)
        if error is None:  # no branch carried to the pre-insertion pose: the reach
            return ArmHits((frozenset(),))  # screening's answer stands (the planner decides)
        return ArmHits((), error)

__all__ = ["ArmHits", "ArmLinkScreen"]
