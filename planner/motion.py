"""Per-step motion planning: pick, carry, insert along the mate axis, proven collision-free.

One step moves one part from its start pose to its assembled pose with the gripper:

    approach  open gripper, straight along its approach axis onto the part (standoff)
    clamp     fingers close (the space they sweep must be free)
    lift      straight up by the process's lift height
    translate OMPL path (SE(3), gripper + held part as one rigid body) from the lifted pose
              to the pre-insertion pose: the assembled pose moved back along the insertion
              direction by the engaged pin length plus ``approach_distance``
    lower     straight along the mate axis into the seated pose
    release   fingers open (the space they sweep must be free)
    retreat   open gripper, straight back along its approach axis

Proof of freedom
----------------
* Straight segments are pure translations: each convex piece of the moving bodies is swept
  EXACTLY (``CollisionWorld.sweep_blockers``: the hull of the piece and its translate; a
  longer cylinder when a pin moves along its own axis), so a segment is checked for every
  intermediate pose at once, not at samples.
* The planned path's legs (translation plus slerp rotation) are certified by conservative
  advancement: at a pose whose distance to every obstacle is ``d``, no point of the moving
  bodies can travel ``d`` before the next checked pose (point travel is bounded by
  ``|dp| + r dtheta``, ``r`` the radius of the moving bodies about the TCP). Where bodies are
  closer than ``recheck_step_m`` (0.1 mm) the leg is sampled at that step with exact
  collision checks. Every final path is certified before it is accepted; a path that fails is
  re-planned at a finer OMPL resolution with another seed.
* Mates: when the sweep of an insertion reports the part's own mate partner, the segment is
  sampled at a step tied to the clearance (``min(insertion_step_m, 4 c_radial)``, floor
  ``min_insertion_step_m``) and contacts with the partner are excused only inside the mated
  hole's cylinder and only when the mate's clearance is positive; anything else blocks.
  Touching (penetration <= ``contact_tolerance_m``) is not a collision, so a part may rest on
  the table and seat face-on-face on its partner.

Bodies: the table (a box whose top is z = 0, centred on the world origin), every part (placed
parts at their assembled poses, parts not yet placed at their start poses) and the gripper
(palm + two finger boxes from the Gripper resource, see :func:`asmplan.parts.cell.gripper_model`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np

from ..knowledge.frames import invert
from ..knowledge.model import Product
from ..parts.cell import HALF_TURN as TURN
from .certify import PathCheck, carried_radius, certify_path
from .errors import (
    ArmError,
    CollidingPair,
    GripInfeasibleError,
    NoGraspError,
    NoPathError,
    PlanningError,
    StartInCollisionError,
)
from .grasp import Rejections, collision_free, iter_grasps
from .grasp_hold import GripLoad, HoldRejections
from .insertion import (
    InsertionSpec,
    clear_standoff_m,
    clearing_travel_m,
    insertion_spec,
    mate_engagement_m,
)
from .layout import initial_layout
from .ompl_backend import SE3Bounds, plan_se3
from .partdata import PartData
from .path_turn import levelled_turns
from .plan import Grasp, Plan, Step
from .press import hand_over_pose, press_operation, press_step, product_press_fits
from .regrasp_steps import plan_regrasp
from .scene import (
    GRIPPER_CLOSED,
    GRIPPER_OPEN,
    BroadPhaseValidity,
    Scene,
    colliding_pairs,
    translated,
)
from .settings import PlannerSettings
from .step_checks import check_insertion, grasp_collisions
from .timing import (
    Move,
    StepMotion,
    clamp_force,
    held_clamp_force,
    motion_limits,
    time_step,
)
from .transfer_hold import gravity_in_part, horizontal_lever_m, part_orientations_along

_Z = np.array([0.0, 0.0, 1.0])
_ENGAGE_MARGIN_M = 1e-3  # the insertion speed starts this far before the pin tip enters


@dataclass(frozen=True, eq=False)
class StepTiming:
    """Times of one step's planning, s (not part of the plan file): wall-clock in total and
    per stage, and the process CPU time in total (less sensitive to a busy machine)."""

    part: str
    total_s: float
    grasp_s: float = 0.0
    ompl_s: float = 0.0
    check_s: float = 0.0
    grasps_tried: int = 0
    poses_certified: int = 0
    cpu_s: float = 0.0


@dataclass(frozen=True, eq=False)
class PlanResult:
    """A plan and how long it took: per step, in total and for the part geometry (s)."""

    plan: Plan
    step_times: tuple[StepTiming, ...]
    total_s: float
    geometry_s: float = 0.0
    dropped: tuple[dict[str, Any], ...] = ()  # better-ranked orders that failed: order, note, failure


class _GraspFailed(Exception):
    def __init__(self, reason: str, error: PlanningError | None = None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.error = error


class MotionPlanner:
    """Plans the steps of one product in sequence; holds the scene between steps.

    Parameters
    ----------
    product : Product
    settings : PlannerSettings
    parts : dict of PartData
        The parts' planning geometry (:func:`~asmplan.planner.partdata.part_data`).
    """

    seats_directly: ClassVar[bool] = False
    """Plan with OMPL straight into the seated pose (no pre-insertion pose, no straight
    insertion). False here; only the benchmark's baseline (``bench/motion.py``) subclasses
    with True."""

    def __init__(self, product: Product, settings: PlannerSettings,
                 parts: dict[str, PartData]) -> None:
        self.product = product
        self.settings = settings
        self.parts = parts
        self.start_poses, self.start_notes = initial_layout(product, self.parts)
        self.press_fits = product_press_fits(product)
        initial = {n: (product.T_world_assembled(n) if product.is_fixtured(n)
                       else self.start_poses[n]) for n in product.part_names}
        self.scene = Scene(product, self.parts, initial, settings.contact_tolerance_m)
        self.placed: list[str] = [n for n in product.part_names if product.is_fixtured(n)]
        self._check_layout()
        self.arm = None
        if product.resources.robot is not None and product.resources.robot.urdf_path is not None:
            from .arm_planner import ArmPlanner  # pinocchio only when the cell has an arm

            self.arm = ArmPlanner(product.resources.robot, self.scene, settings.arm,
                                  (GRIPPER_CLOSED, GRIPPER_OPEN))

    def place(self, part: str) -> None:
        """Record ``part`` as assembled (used to set up a partial assembly, e.g. by the
        benchmark); planning a step does this itself."""
        if part not in self.placed:
            self.placed.append(part)
        self.scene.set_part_pose(part, self.product.T_world_assembled(part))

    def _check_layout(self) -> None:
        names = [*self.scene.cell, *self.product.part_names]
        contacts = self.scene.world.contacts(names, names, self.settings.contact_tolerance_m)
        if contacts:
            raise StartInCollisionError(colliding_pairs(contacts), where="initial layout (fixtured parts "
                                        "assembled, the others at their start poses)")

    # -- bounds -----------------------------------------------------------------------------
    def _bounds(self, key_poses: Sequence[np.ndarray], radius: float) -> SE3Bounds:
        size = np.asarray(self.product.resources.table.size_m, float)
        lo = np.array([-size[0] / 2, -size[1] / 2, 0.0])
        hi = np.array([size[0] / 2, size[1] / 2, 0.0])
        tops = [self.scene.world.aabb(n)[1, 2] for n in self.product.part_names]
        hi[2] = max(tops) + self.product.process.lift_height_m + radius
        pts = np.array([T[:3, 3] for T in key_poses])
        lo = np.minimum(lo, pts.min(axis=0) - 0.01)
        hi = np.maximum(hi, pts.max(axis=0) + 0.01)
        return SE3Bounds(lo, hi)

    # -- one step ---------------------------------------------------------------------------
    def plan_steps(self, index: int, part: str, fallback_direction: np.ndarray | None = None
                   ) -> list[tuple[Step, StepTiming]]:
        """The steps that bring ``part`` into the current partial assembly, numbered from
        ``index``: the step of :meth:`plan_step`, or when no grasp works both where the part
        lies and where it goes, a regrasp step (put down on a free area of the table in
        another orientation, :mod:`asmplan.planner.regrasp`) and the step from there."""
        try:
            return [self.plan_step(index, part, fallback_direction)]
        except NoGraspError as exc:
            if not self.settings.regrasp or self.product.is_fixtured(part) \
                    or self.product.placed_by(part) is not None:
                raise
            return plan_regrasp(self, index, part, fallback_direction, exc)

    # Complexity above C (radon): one step's stages (fixture, press hand-over, the part alone,
    # grasps best first with their failure bookkeeping) share the grasp state.
    def plan_step(self, index: int, part: str, fallback_direction: np.ndarray | None = None,
                  grasp: Grasp | None = None, *, T_start: np.ndarray | None = None,
                  start_note: str | None = None, regrasp_to: np.ndarray | None = None
                  ) -> tuple[Step, StepTiming]:
        """Plan the step that inserts ``part`` into the current partial assembly; on success
        the part is recorded as placed. ``grasp`` restricts the search to that grasp (the
        benchmark's baseline uses the grasp of the real plan). ``T_start``: where the part
        is picked (default its start pose). ``regrasp_to``: instead put the part down there
        on the table (a "regrasp" step; the part is not placed)."""
        t_start = time.perf_counter()
        c_start = time.process_time()
        product, settings, scene = self.product, self.settings, self.scene
        if product.is_fixtured(part):
            T = product.T_world_assembled(part)
            step = Step(index, part, "fixture", (), T, T,
                        start_note="held by a fixture in its assembled pose from the start")
            if part not in self.placed:
                self.placed.append(part)
            return step, StepTiming(part, time.perf_counter() - t_start,
                                    cpu_s=time.process_time() - c_start)
        operation = product.placed_by(part)
        if operation is not None and regrasp_to is None:
            # placed by another operation (a press tool, a manual or fastening station) at
            # its assembled pose at this point of the sequence: no grasp, no path
            h = product.part(part).handling
            step = Step(index, part, "operation", (), self.start_poses[part],
                        product.T_world_assembled(part), start_note=(
                            f"placed by {operation} at its assembled pose: not planned for the "
                            "robot" + (f" ({h.note})" if h.note else "")),
                        operation=operation, operation_note=h.note)
            if part not in self.placed:
                self.placed.append(part)
            return step, StepTiming(part, time.perf_counter() - t_start,
                                    cpu_s=time.process_time() - c_start)
        data = self.parts[part]
        if regrasp_to is None:
            press = press_operation(product, part, self.placed, data.mass_kg, self.press_fits,
                                    index)
            spec = insertion_spec(product, part, self.placed, fallback_direction, index,
                                  self.parts)
            T_seated = product.T_world_assembled(part)
        else:  # put down on the table, straight down
            press = None
            spec = InsertionSpec("place", -_Z, 0.0, (), (), math.inf)
            T_seated = regrasp_to
        clamp = clamp_force(product, part, data.mass_kg, step=index, resistance_N=(
            product.process.insertion_resistance_N + (press.gripper_resistance_N if press else 0.0)))
        if T_start is None:
            T_start = self.start_poses[part]
        approach = product.process.approach_distance_m
        # a press operation: the robot hands the part over on the mouth, the ram seats it
        # (its stroke: the whole clearing travel of the pressed mates, e.g. a hinge pin
        # through a bushing before the lever's eye)
        if press is not None:
            stroke = max(clearing_travel_m(product, m, {n: self.parts[n].points_m
                                                        for n in (m.pin_part, m.hole_part)})
                         for m in product.mates if m.name in press.mates)
            press = replace(press, pass_through_m=stroke)
        T_final = hand_over_pose(press, T_seated, spec.direction)
        obstacles = scene.obstacles(part)
        pre_dist = clear_standoff_m(scene, part, T_seated, spec.direction, obstacles,
                                    spec.length_m + approach,
                                    clearance_m=product.process.position_tolerance_m)
        T_pre = translated(T_seated, -spec.direction * pre_dist)

        # 1. the part alone along its insertion (independent of the grasp)
        sampled = 0.0 if self.seats_directly else check_insertion(
            self.scene, settings, index, part, spec, T_pre, T_seated, obstacles)

        # 2. grasps, best first: free at the start and final poses, then the full motion
        t_g = time.perf_counter()
        down_s = T_start[:3, :3].T @ -_Z
        down_f = T_final[:3, :3].T @ -_Z
        # fingers should stay behind the mating face: the pin roots of a pin part, the
        # leading face of a hole part (or of a part placed without a mate)
        ins_part = T_final[:3, :3].T @ spec.direction
        lead = float(((data.points_m - data.com_m) @ ins_part).max())
        if spec.kind == "insert" and any(r.pin_part == part for r in spec.regions):
            # the part's own pins only: a bearing slid over a shaft end that sticks out of
            # it travels further than its own seat is deep (gearbox bearing_2: 16 against
            # 12 mm), but only its seat's length must stay free of the fingers
            own = [m for m in product.mates if m.name in spec.mates and m.pin_part == part]
            lead -= max(mate_engagement_m(product, m, self.parts) for m in own)
        gripper = product.gripper_for(part)
        held = HoldRejections()
        candidates = iter_grasps(part, data.surface, gripper,
                                 product.part(part).handling.grasp,
                                 part_friction=product.part(part).friction,
                                 finger_clearance_m=settings.finger_clearance_m,
                                 down_start_part=down_s, down_final_part=down_f,
                                 insertion_part=ins_part,
                                 lead_limit_m=lead - product.process.position_tolerance_m,
                                 load=GripLoad(data.mass_kg, clamp.acceleration_m_s2,
                                               clamp.limit_N, product.process.safety_factor),
                                 hold_rejections=held)
        if grasp is not None:
            candidates = iter([grasp])
        rejected = Rejections()
        failures: list[_GraspFailed] = []
        attempts = 0  # grasps whose motion was attempted
        ompl_s = check_s = grasp_s = 0.0
        free = collision_free(
            candidates, lambda g: grasp_collisions(self.scene, product, g, part, T_start, T_final,
                                       obstacles, None if self.seats_directly else T_pre),
            rejected, settings.max_grasp_candidates)
        for g in free:
            grasp_s += time.perf_counter() - t_g
            try:
                step, o_s, c_s, checked = self._plan_with_grasp(
                    index, part, g, spec, clamp, T_start, T_pre, T_final, obstacles,
                    len(failures), sampled)
                if regrasp_to is not None:
                    step = replace(step, kind="regrasp")
                elif start_note is not None:
                    step = replace(step, start_note=start_note)
            except _GraspFailed as f:
                failures.append(f)
                # a grasp whose grip cannot hold the step's load (its lever, the insertion or
                # press hand-over resistance) is rejected before any motion is planned: it
                # does not use up one of the ``max_grasps`` full attempts (the bearing unit's
                # shaft: six grasps far from its centre of mass came first, the one over it
                # seventh)
                attempts += not isinstance(f.error, GripInfeasibleError)
                if attempts >= settings.max_grasps:
                    break
                t_g = time.perf_counter()
                continue
            ompl_s += o_s
            check_s += c_s
            if press is not None:
                step = press_step(step, press, T_seated, product.process.insertion_speed_m_s)
            if regrasp_to is None:
                self.placed.append(part)
            scene.set_part_pose(part, T_seated)
            timing = StepTiming(part, time.perf_counter() - t_start, grasp_s, ompl_s, check_s,
                                len(failures) + 1, checked, time.process_time() - c_start)
            return step, timing
        scene.set_part_pose(part, T_start)
        first_path = next((f.error for f in failures if isinstance(f.error, NoPathError)), None)
        if first_path is not None:
            raise first_path
        first_arm = next((f.error for f in failures if isinstance(f.error, ArmError)), None)
        if first_arm is not None:
            raise first_arm
        reasons = [f"grasp {k + 1}: {f.reason}" for k, f in enumerate(failures)]
        reasons += rejected.reasons()
        reasons += held.reasons(clamp.limit_N)
        if rejected.examined == 0 and held.count == 0:
            reasons.append("no antipodal finger placement within the gripper's stroke and the "
                           "friction cone")
        raise NoGraspError(part, reasons, index)

    # Complexity above C (radon): the straight segments and the planned path of one grasp in the order
    # the robot moves them; each check ends the grasp with its own reason.
    def _plan_with_grasp(self, index: int, part: str, g: Grasp, spec: InsertionSpec,
                         clamp: Any, T_start: np.ndarray, T_pre: np.ndarray,
                         T_final: np.ndarray, obstacles: list[str], grasp_rank: int,
                         insertion_sampled_m: float) -> tuple[Step, float, float, int]:
        product, settings, scene = self.product, self.settings, self.scene
        # the grip must also hold the moment of an off-centre grasp about the closing axis
        offset = self.parts[part].com_m - g.T_part_gripper[:3, 3]
        y = g.T_part_gripper[:3, 1]
        perp = offset - (offset @ y) * y  # part frame, normal to the closing axis
        lever = float(np.linalg.norm(perp))
        # gravity turns the part only through the horizontal part of the lever, at the pick
        # and at the insertion pose (orientations in between are blends of these two)
        R_s, R_f = T_start[:3, :3], T_final[:3, :3]
        gravity_lever = max(float(np.linalg.norm((R @ perp)[:2])) for R in (R_s, R_f))
        try:
            if g.hold_required_N is not None and g.torsion_radius_m is not None:
                clamp = held_clamp_force(product, part, clamp, g, index, lever_m=lever,
                                         gravity_lever_m=gravity_lever)
            else:
                clamp = clamp_force(product, part, clamp.mass_kg, step=index, lever_m=lever,
                                    gravity_lever_m=gravity_lever,
                                    resistance_N=clamp.resistance_N)
        except GripInfeasibleError as exc:
            raise _GraspFailed(f"grip infeasible for this grasp: {exc}", exc) from None
        scene.use_gripper(g, product.gripper_for(part))
        t0 = time.perf_counter()
        T_gp = g.T_part_gripper
        T_pg = invert(T_gp)
        G_grasp = T_start @ T_gp
        G_final = T_final @ T_gp
        G_pre = T_pre @ T_gp
        standoff = settings.grasp_standoff_m
        G_pregrasp = translated(G_grasp, -G_grasp[:3, 2] * standoff)
        G_retreat = translated(G_final, -G_final[:3, 2] * standoff)
        lift = product.process.lift_height_m
        G_lift = translated(G_grasp, _Z * lift)
        carried = [(part, T_pg), (GRIPPER_CLOSED, np.eye(4))]
        radius = self._radius(part, T_pg, g)
        if self.arm is not None:  # the key poses in reach and within the joint limits
            try:
                for what, G in (("pick pose", G_grasp), ("lifted pose", G_lift),
                                ("pre-insertion pose", G_pre), ("seated pose", G_final)):
                    self.arm.check_pose_either(index, part, what, G)
            except ArmError as exc:
                raise _GraspFailed(str(exc), exc) from None

        # straight segments, certified like the planned path (conservative advancement)
        def straight(bodies: list[tuple[str, np.ndarray]], T0: np.ndarray, T1: np.ndarray,
                     against: list[str]) -> PathCheck:
            return certify_path(scene, np.array([T0, T1]), bodies, against, radius,
                                settings.recheck_step_m)

        scene.set_part_pose(part, T_start)
        cert = straight([(GRIPPER_OPEN, np.eye(4))], G_pregrasp, G_grasp, [*obstacles, part])
        checked = cert.checked
        if not cert.ok:
            raise _GraspFailed(f"approach onto the part blocked: {_names(cert.pairs)}")
        cert = straight(carried, G_grasp, G_lift, obstacles)
        checked += cert.checked
        if not cert.ok:
            if any(part in (q.a, q.b) for q in cert.pairs):
                raise NoPathError(index, part, np.array([G_grasp]),
                                  f"lifting the part {lift * 1e3:.0f} mm hits "
                                  f"{_names(cert.pairs)}", cert.pairs)
            raise _GraspFailed(f"lift: the gripper hits {_names(cert.pairs)}")
        scene.set_part_pose(part, T_final)
        cert = straight([(GRIPPER_OPEN, np.eye(4))], G_final, G_retreat, [*obstacles, part])
        scene.set_part_pose(part, T_start)
        checked += cert.checked
        if not cert.ok:
            raise _GraspFailed(f"retreat after release blocked: {_names(cert.pairs)}")
        # the gripper along the insertion (the part alone was checked already)
        if not self.seats_directly:
            cert = straight([(GRIPPER_CLOSED, np.eye(4))], G_pre, G_final, obstacles)
            checked += cert.checked
            if not cert.ok:
                raise _GraspFailed(f"insertion: the gripper hits {_names(cert.pairs)}")
        check_s = time.perf_counter() - t0

        # the planned path: lifted -> pre-insertion (or straight to the seated pose)
        goal = G_final if self.seats_directly else G_pre
        key = [G_lift, goal, G_grasp, G_final]
        bounds = self._bounds(key, radius)
        valid = BroadPhaseValidity(scene, carried, obstacles)

        ompl_s = 0.0
        resolution = settings.ompl_resolution_m
        last_reason = ""
        path = None
        partial = np.array([G_lift])
        pairs_seen: list[CollidingPair] = []
        direct = True
        winding = None  # a free path whose via poses turn off the steady slerp
        for attempt in range(settings.replan_attempts + 1):
            res = plan_se3(valid, G_lift, goal, bounds, planner=settings.planner,
                           time_budget_s=settings.time_budget_s,
                           seed=settings.seed + 1009 * index + 101 * grasp_rank + attempt,
                           resolution_m=resolution, try_direct=direct)
            ompl_s += res.planning_time_s
            if not res.solved:
                last_reason = (f"{settings.planner} found no path from the lifted pose to the "
                               f"{'seated' if self.seats_directly else 'pre-insertion'} pose "
                               f"in {settings.time_budget_s:g} s ({res.status})")
                partial = res.poses
                break
            t1 = time.perf_counter()
            levels = levelled_turns(res.poses)  # one steady turn, where free (path_turn)
            for candidate in [*levels, res.poses]:
                cert = certify_path(scene, candidate, carried, obstacles, radius,
                                    settings.recheck_step_m)
                checked += cert.checked
                if cert.ok:
                    break
            check_s += time.perf_counter() - t1
            direct = direct and len(res.poses) > 2  # the straight motion is known to collide
            if cert.ok and (candidate is not res.poses or not levels):
                path = candidate
                break
            if cert.ok:  # free, but through a detour of turns: another seed may turn steadily
                winding = res.poses if winding is None else winding
                continue
            last_reason = (f"the path collides between OMPL's checks (leg {cert.leg}) at "
                           f"resolution {resolution * 1e3:.2f} mm")
            partial = res.poses[: cert.leg + 1]
            pairs_seen = list(cert.pairs)
            resolution /= 2
        scene.set_part_pose(part, T_start)
        path = winding if path is None else path
        if path is None:
            err = NoPathError(index, part, partial, last_reason, pairs_seen)
            raise _GraspFailed(last_reason, err)

        g, clamp = self._hold_along(index, part, g, clamp, path, lever, perp, "transfer")
        limits = motion_limits(product, part)
        lower: tuple[Move, ...]
        if self.seats_directly:
            lower = (Move(np.array([G_final, G_final]), limits.insertion_speed_m_s),)
        else:
            G_engage = translated(G_final, -spec.direction * (spec.length_m + _ENGAGE_MARGIN_M))
            if spec.kind == "place":
                G_engage = translated(G_final, -spec.direction * min(2e-3, float(
                    np.linalg.norm(G_pre[:3, 3] - G_final[:3, 3]))))
            lower = (Move(np.array([G_pre, G_engage]), limits.max_speed_m_s),
                     Move(np.array([G_engage, G_final]), limits.insertion_speed_m_s))
        motion = StepMotion(approach=np.array([G_pregrasp, G_grasp]),
                            lift=np.array([G_grasp, G_lift]), translate=path, lower=lower,
                            retreat=np.array([G_final, G_retreat]))
        traj = time_step(motion, limits, clamp.commanded_N, radius, settings.timing)
        arm_motion = None
        if self.arm is not None:  # IK, arm collisions and joint-limited timing of the step
            try:
                traj, arm_motion = self.arm.plan_step(
                    index, part, traj, T_pg, obstacles, T_start, T_final, radius,
                    limits.max_speed_m_s,
                    (settings.planner, settings.time_budget_s, settings.seed + 101 * grasp_rank))
            except ArmError as exc:
                raise _GraspFailed(str(exc), exc) from None
            if arm_motion.tool_turned:  # the same grasp, the gripper turned half a turn
                g = replace(g, T_part_gripper=g.T_part_gripper @ TURN)
                path = path @ TURN
            if arm_motion.joint_space_translate:  # the TCP follows the arm's joint path
                sel = traj.phase_indices_at(traj.t_s) == [p.name for p in traj.phases].index(
                    "translate")
                path = traj.T_world_gripper[sel]
                commanded = clamp.commanded_N
                g, clamp = self._hold_along(index, part, g, clamp, path, lever, perp,
                                            "arm's joint-space transfer")
                if clamp.commanded_N > commanded * (1.0 + 1e-9):
                    raise _GraspFailed(
                        f"the arm's joint-space transfer turns the part so that the grip "
                        f"needs {clamp.commanded_N:.3g} N per finger, more than the "
                        f"{commanded:.3g} N the step was timed with")
        notes = []
        if arm_motion is not None and arm_motion.joint_space_translate:
            notes.append("the arm cannot follow the planned Cartesian transfer; it was planned "
                         "in joint space (the gripper follows the arm's joint path)")
        if g.source != "hint" and product.part(part).handling.grasp is not None:
            notes.append("the knowledge grasp hint collided; an antipodal grasp is used")
        if insertion_sampled_m > 0:
            notes.append(f"insertion: the exact sweep touched the mate partner; sampled every "
                         f"{insertion_sampled_m * 1e6:.0f} um, only pin-in-hole contact "
                         "(positive clearance) found and excused")
        step = Step(index=index, part=part, kind=spec.kind, mates=spec.mates,
                    T_world_start=T_start, T_world_final=T_final,
                    start_note=self.start_notes[part], T_world_pre_insertion=T_pre,
                    insertion_direction=spec.direction, insertion_length_m=spec.length_m,
                    grasp=g, clamp=clamp, trajectory=traj, path_T_world_gripper=path,
                    check_step_m=settings.recheck_step_m,
                    insertion_check_step_m=insertion_sampled_m,
                    checked_poses=checked, notes=tuple(notes), arm=arm_motion)
        return step, ompl_s, check_s, checked

    def _hold_along(self, index: int, part: str, g: Grasp, clamp: Any, path: np.ndarray,
                    lever: float, perp: np.ndarray, what: str) -> tuple[Grasp, Any]:
        """The grasp's hold judged again with gravity's directions along the planned
        ``path`` (gripper poses, world; :mod:`asmplan.planner.transfer_hold`): the grasp with
        the larger requirement and its clamp force, or the same ones."""
        if g.hold is None or g.hold_required_N is None:
            return g, clamp
        R_wp = part_orientations_along(path, g.T_part_gripper)
        req = g.hold.requirement(gravity_in_part(R_wp))
        if req.required_N <= float(g.hold_required_N) * (1.0 + 1e-9):
            return g, clamp
        g = replace(g, hold_required_N=req.required_N, lever_m=req.lever_m)
        try:
            clamp = held_clamp_force(self.product, part, clamp, g, index, lever_m=lever,
                                     gravity_lever_m=horizontal_lever_m(R_wp, perp))
        except GripInfeasibleError as exc:
            raise _GraspFailed(f"grip infeasible along the {what} (the gripper turns the "
                               f"part; {req.mechanism}): {exc}", exc) from None
        return g, clamp

    def _radius(self, part: str, T_pg: np.ndarray, g: Grasp) -> float:
        return carried_radius(self.product.gripper_for(part), self.parts[part], T_pg, g)



def _names(pairs: Sequence[CollidingPair]) -> str:
    return "; ".join(str(p) for p in pairs[:3]) or "(no contact detail)"
