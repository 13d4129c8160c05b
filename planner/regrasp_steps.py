"""Planning a regrasp: the two steps that put a part down and pick it again.

When no grasp of a part holds it both where it lies and where it goes
(:meth:`asmplan.planner.motion.MotionPlanner.plan_steps` met a
:class:`~asmplan.planner.errors.NoGraspError`), the part is put down and picked again with
another grasp:

* on a free area of the table in another stable orientation (the poses of
  :mod:`asmplan.planner.regrasp`), or
* in a declared regrasp fixture of the cell that holds it (``resources.regrasp``: a sleeve
  holder that stands a shaft upright, a V-block), at the fixture's seat for the part.

The first workable table pose and the first workable fixture seat are both planned in full
(motion proven like any other step); the way with the shorter cycle time (both steps) is
kept, and the put-down step's notes say which and what the other would have cost. When
neither works, the failure lists every attempt with its reason.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import NoGraspError, PlanningError
from .plan import Step
from .regrasp import regrasp_poses

if TYPE_CHECKING:
    from .motion import MotionPlanner, StepTiming


def plan_regrasp(planner: MotionPlanner, index: int, part: str, fallback_direction: np.ndarray | None,
             failure: NoGraspError) -> list[tuple[Step, StepTiming]]:
    """Put the part down and pick it again: on a free area of the table in another stable
    orientation, or in a declared regrasp fixture that holds it (``resources.regrasp``).
    The first workable table pose and the first workable fixture are both planned; the
    one with the shorter cycle time (both steps) is kept, and its steps say why."""
    product, scene, data = planner.product, planner.scene, planner.parts[part]
    T_start = planner.start_poses[part]
    gripper = product.gripper_for(part)
    avoid = [scene.world.aabb(n) for n in [*scene.cell[1:], *product.part_names] if n != part]
    avoid.append(scene.world.aabb(part))  # its own start footprint (a nest may be there)
    clearance = float(gripper.stroke_m) / 2 + float(gripper.finger_size_m[1])
    poses = regrasp_poses(data.points_m, data.com_m, T_start,
                          product.T_world_assembled(part), avoid,
                          product.resources.table.size_m, clearance)
    table = [(f"table: {p.describe()}", p.T_world_part, "")
             for p in poses[: planner.settings.max_regrasp_poses]]
    seats = [(f"regrasp fixture {fx.name}", T, fx.name)
             for fx in product.resources.regrasp
             if (T := fx.T_world_seat(part)) is not None]
    tried: list[str] = []
    found: list[tuple[float, str, list[tuple[Step, StepTiming]], tuple[Any, ...]]] = []
    before = _snapshot(planner, part)
    for way, group in (("on the table", table), ("through a regrasp fixture", seats)):
        for label, T_r, fixture in group:
            steps = _put_and_pick(planner, index, part, fallback_direction, T_start, T_r,
                                       fixture, label, tried)
            if steps is None:
                continue
            cost = float(sum(st.cycle_time_s for st, _ in steps))
            found.append((cost, way, steps, _snapshot(planner, part)))
            _restore(planner, part, before)
            break
    if found:
        cost, way, steps, after = min(found, key=lambda f: f[0])
        _restore(planner, part, after)
        if len(found) == 2:
            other = max(found, key=lambda f: f[0])
            put, timing = steps[0]
            why = (f"{part}: regrasp {way}: {cost:.2f} s for both steps, the shorter cycle time "
                   f"(regrasp {other[1]}: {other[0]:.2f} s)")
            steps = [(replace(put, notes=(*put.notes, why)), timing), steps[1]]
        return steps
    reasons = [*failure.reasons, *(f"regrasp {k + 1}: {t}" for k, t in enumerate(tried))]
    if not poses:
        reasons.append("regrasp: no stable orientation other than the start pose's with "
                       "a free area of the table to put the part down")
    if not seats:
        reasons.append("regrasp: no declared regrasp fixture holds this part "
                       "(resources.regrasp)")
    raise NoGraspError(part, reasons, index)

def _put_and_pick(planner: MotionPlanner, index: int, part: str, fallback_direction: np.ndarray | None,
                  T_start: np.ndarray, T_r: np.ndarray, fixture: str, label: str,
                  tried: list[str]) -> list[tuple[Step, StepTiming]] | None:
    """The regrasp's two steps through ``T_r`` (None when either fails; why is appended
    to ``tried``)."""
    try:
        put = planner.plan_step(index, part, fallback_direction, regrasp_to=T_r)
    except PlanningError as exc:
        planner.scene.set_part_pose(part, T_start)
        tried.append(f"{label}: putting it down: {exc}")
        return None
    where = (f"from regrasp fixture {fixture}, where step {index + 1} put it" if fixture
             else f"where step {index + 1} put it down on the table")
    note = (f"picked again {where} (regrasp: no grasp holds it both on the tray and in "
            "its assembled pose)")
    try:
        pick = planner.plan_step(index + 1, part, fallback_direction, T_start=T_r,
                              start_note=note)
    except PlanningError as exc:
        planner.scene.set_part_pose(part, T_start)
        tried.append(f"{label}: picking it again: {exc}")
        return None
    put_note = (f"{part}: put into regrasp fixture {fixture} (resources.regrasp) and picked "
                "again there" if fixture else
                f"{part}: put down on a free area of the table in another stable orientation "
                "and picked again there")
    step = put[0]
    return [(replace(step, notes=(*step.notes, put_note)), put[1]), pick]

def _snapshot(planner: MotionPlanner, part: str) -> tuple[Any, ...]:
    """What planning a regrasp changes: the placed parts, the part's pose, the arm's
    last joint state."""
    last_q = None if planner.arm is None else getattr(planner.arm, "last_q", None)
    return (list(planner.placed), np.array(planner.scene.poses[part]),
            None if last_q is None else np.array(last_q))

def _restore(planner: MotionPlanner, part: str, snap: tuple[Any, ...]) -> None:
    placed, T, last_q = snap
    planner.placed[:] = placed
    planner.scene.set_part_pose(part, T)
    if planner.arm is not None and hasattr(planner.arm, "last_q"):
        planner.arm.last_q = None if last_q is None else np.array(last_q)
