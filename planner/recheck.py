"""An independent dense re-check of a finished plan: every trajectory resampled so no point moves
more than a step, each pose checked with FCL against the scene at that moment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..knowledge.frames import invert
from ..knowledge.model import Product
from .certify import carried_radius
from .errors import (
    CollidingPair,
)
from .insertion import insertion_spec, unexcused
from .layout import initial_layout
from .partdata import PartData
from .plan import Plan
from .rotations import rotation_angle_rad
from .scene import GRIPPER_CLOSED, GRIPPER_OPEN, Scene, colliding_pairs
from .timing import (
    interpolate_poses,
)


@dataclass(frozen=True, eq=False)
class RecheckViolation:
    """A collision found by :func:`dense_recheck`: step, phase, time (s), the pairs."""

    step: int
    part: str
    phase: str
    t_s: float
    pairs: tuple[CollidingPair, ...]


@dataclass(frozen=True, eq=False)
class RecheckReport:
    violations: tuple[RecheckViolation, ...]
    poses_checked: int
    excused_contacts: int = 0
    notes: tuple[str, ...] = field(default_factory=tuple)


# Complexity above C (radon): one independent pass over every step, phase and sample; the held and the
# open gripper share the sampling and the excuse rule.
def dense_recheck(plan: Plan, product: Product, parts: dict[str, PartData],
                  step_m: float = 1e-4) -> RecheckReport:
    """Re-check every trajectory of ``plan`` at uniform samples, independently of the planner.

    The trajectory is resampled so that no point of the gripper or the held part moves more
    than ``step_m`` between two checked poses; at each pose the part (in held phases) and the
    gripper (closed while held, open otherwise) are checked with FCL against the table and
    every other part at its pose at that moment. Contacts of the part with a mate partner
    inside the mated hole (positive clearance) are excused and counted.
    """
    settings = plan.settings
    starts, _ = initial_layout(product, parts)
    poses = {n: (product.T_world_assembled(n) if product.is_fixtured(n) else starts[n])
             for n in product.part_names}
    for s in plan.steps:  # the plan's own start poses win
        poses[s.part] = s.T_world_start if s.kind != "fixture" else s.T_world_final
    scene = Scene(product, parts, poses, settings.contact_tolerance_m)
    violations: list[RecheckViolation] = []
    checked = 0
    excused = 0
    placed = [n for n in product.part_names if product.is_fixtured(n)]
    for step in plan.steps:
        if step.kind == "fixture" or step.trajectory is None or step.grasp is None:
            if step.part not in placed:
                placed.append(step.part)
            continue
        g = step.grasp
        scene.use_gripper(g, product.gripper_for(step.part))
        spec = insertion_spec(product, step.part, placed, step.insertion_direction, step.index,
                              parts)
        T_pg = invert(g.T_part_gripper)
        traj = step.trajectory
        radius = carried_radius(product.gripper_for(step.part), parts[step.part], T_pg, g)
        obstacles = scene.obstacles(step.part)
        T_all = traj.T_world_gripper
        t_all = traj.t_s
        names = [p.name for p in traj.phases]
        idx = traj.phase_indices_at(t_all)
        held_from = traj.phase_span("clamp").t_end_s
        held_to = traj.phase_span("release").t_start_s
        for i in range(len(t_all) - 1):
            T0, T1 = T_all[i], T_all[i + 1]
            dth = float(rotation_angle_rad(T0[:3, :3].T @ T1[:3, :3]))
            travel = float(np.linalg.norm(T1[:3, 3] - T0[:3, 3])) + radius * dth
            n = max(1, math.ceil(travel / step_m))
            Ts = interpolate_poses(T0, T1, np.arange(n) / n)
            phase = names[int(idx[i])]
            tm = t_all[i]
            held = held_from - 1e-12 <= tm <= held_to + 1e-12
            for T in Ts:
                checked += 1
                if held:
                    T_part = T @ T_pg
                    scene.world.set_pose(step.part, T_part)
                    scene.world.set_pose(GRIPPER_CLOSED, T)
                    bodies = [step.part, GRIPPER_CLOSED]
                else:
                    T_part = step.T_world_start if tm < held_from else step.T_world_final
                    scene.world.set_pose(step.part, T_part)
                    scene.world.set_pose(GRIPPER_OPEN, T)
                    bodies = [GRIPPER_OPEN]
                hit = [b for b in bodies if scene.world.in_collision(
                    b, obstacles + ([step.part] if b == GRIPPER_OPEN else []),
                    settings.contact_tolerance_m)]
                if not hit:
                    continue
                pairs = []
                for b in hit:
                    extra = [step.part] if b == GRIPPER_OPEN else []
                    pairs.extend(colliding_pairs(scene.world.contacts([b], obstacles + extra,
                                                             settings.contact_tolerance_m)))
                if held:
                    bad = unexcused([p for p in pairs if step.part in (p.a, p.b)], spec,
                                    step.part, T_part, scene.poses)
                    excused += sum(1 for p in pairs if step.part in (p.a, p.b)) - len(bad)
                    pairs = bad + [p for p in pairs if step.part not in (p.a, p.b)]
                if pairs:
                    violations.append(RecheckViolation(step.index, step.part, phase, float(tm),
                                                       tuple(pairs)))
                    break
        scene.set_part_pose(step.part, step.T_world_final)
        placed.append(step.part)
    return RecheckReport(tuple(violations), checked, excused)
