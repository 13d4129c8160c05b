"""Gripper access for the sequence planner: which placed parts keep the gripper from a step.

The blocking table (:mod:`asmplan.planner.blocking`) says whether a PART can go in; this
module says whether the GRIPPER can put it there. For a part ``p`` inserted along a
direction, each of its best grasp candidates (:func:`asmplan.planner.grasp.iter_grasps`,
ranked as the motion planner ranks them) is tried once, in the full assembly, and the set of
other parts the gripper meets is stored:

* the fingers, over the whole space they sweep while closing, at the assembled pose (and
  their clearance: a part closer than the process's position tolerance counts as met);
* the closed gripper along the straight insertion, from the pre-insertion pose to the
  seated pose, and the open gripper straight back along its approach axis by the grasp
  standoff (the retreat after release), both at samples ``sample_step_m`` apart.

A grasp whose fingers reach below the table top at the start or at the assembled pose is
dropped (no order can help it). In any partial assembly ``S`` the step is reachable iff
some grasp's set is disjoint from ``S``, a set operation like the blocking table, so the
search stays exact and fast; only the minimal sets are kept.

With an arm in the cell, each grasp that could give a new set is also screened for the arm's
reach and joint limits at the step's key TCP poses (:mod:`asmplan.planner.arm_reach`) and for
its links' collisions at the pre-insertion and seated poses
(:mod:`asmplan.planner.arm_reach_collisions`: the parts a link meets join the grasp's set, as
the parts its fingers meet); a grasp the arm cannot hold is dropped, and the best-ranked one's
reason is kept.

This is a screening model, not the motion planner: it looks at a bounded number of grasps
(``max_grasps``), only at the assembled end of the step (start poses are fixed whatever the
order), and straight segments only. An order it finds unreachable is therefore ranked last
with the reason (``unreachable`` cost term), not pruned: the motion planner still tries it
if every better order fails.

Measured where the two disagree (tests/planner/test_access_vs_planner.py): gear_unit's collar
after the cover is screened unreachable within ``max_candidates``, while the motion planner,
whose budget is 400 candidates plus 1600 below the table, grasps it by a 2-3 mm strip of its
flank; given that budget the screening finds a free grasp too (1331 candidates examined). The
budget is kept: with the cell's arm that order's plan fails at BALANCED (the collar turns in
the narrow pinch during the transfer), and widening it doubled gear_unit's sequencing CPU.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..knowledge.model import Product
from .arm_reach import ArmReach, ReachFailure
from .errors import ArmCollisionError
from .grasp import iter_grasps
from .grasp_hold import GripLoad

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry

_Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class AccessSettings:
    """Settings of the gripper-access screening.

    Parameters
    ----------
    max_grasps : int
        Grasps kept per part and insertion direction: candidates whose gripper meets a part
        that must precede the step anyway are skipped (no order can free them).
    max_candidates : int
        Grasp candidates examined at most per part and insertion direction.
    patience : int
        Once a grasp is kept, stop after this many candidates in a row that give no new
        minimal set (neighbouring offsets of one grasp family meet the same parts; the
        candidates after them are ranked worse). 96: with 3000 samples the drawer of
        tests/fixtures/arm/drawer_reach.yaml has 30 candidates of two families (centred
        over its top, every depth; from its side) meeting the cover before the first that
        clears it (its 5 mm top edge pinched 20 mm towards its front, 57 N of 60 N), the
        89th; with 1000 samples most of them had too few samples to count and 24 reached it.
    arm_patience : int
        With ``arm_reach``, once no grasp is kept, the screening stops after this many
        candidates in a row beyond the arm.
    grasp_standoff_m : float
        Retreat of the open gripper after release, m (the motion planner's
        ``grasp_standoff_m``).
    finger_clearance_m : float
        Opening per finger beyond the part's width, m (``PlannerSettings``).
    contact_tolerance_m : float
        Penetration that counts as touching, m (``PlannerSettings``).
    surface_samples : int
        Surface samples per part for the screened grasps: the motion planner's 3000, so that
        the screening finds the grasps the planner finds (with 1000, 38 mm^2 per sample on
        the drawer of tests/fixtures/arm/drawer_front.yaml, a pad over the 5 mm top edge of
        its side, 100 mm^2, has fewer than the 3 samples a contact needs: the one grasp the
        arm can reach there was missed and the step screened unreachable). Small contact
        patches are measured on the mesh either way (:mod:`asmplan.planner.grasp_patch`).
    sample_step_m : float
        Spacing of the checked poses along the insertion and the retreat, m (a screening
        step: the motion planner proves the chosen motion exactly).
    arm_reach : bool
        With an arm in the cell (``resources.robot``), keep only grasps whose pick, lifted,
        pre-insertion and seated TCP poses the arm can take (reach and joint limits,
        :mod:`asmplan.planner.arm_reach`). Once no grasp is kept, the screening stops after
        ``arm_patience`` candidates in a row beyond the arm.
    arm_collisions : bool
        With ``arm_reach``, also check the arm's links at the pre-insertion and seated poses
        against the table and the other parts (:mod:`asmplan.planner.arm_reach_collisions`):
        parts a usable IK branch's links meet join the grasp's blocking set; a grasp with no
        usable branch is dropped with the colliding pair as the reason.
    """

    max_grasps: int = 24
    max_candidates: int = 200
    patience: int = 96
    arm_patience: int = 24
    surface_samples: int = 3000
    grasp_standoff_m: float = 0.03
    finger_clearance_m: float = 3e-3
    contact_tolerance_m: float = 2e-5
    sample_step_m: float = 2e-3
    arm_reach: bool = True
    arm_collisions: bool = True

    def __post_init__(self) -> None:
        for name in ("max_grasps", "max_candidates", "patience", "arm_patience",
                     "surface_samples"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v >= 1):
                raise ValueError(f"AccessSettings.{name}: expected an integer >= 1, found {v!r}")
        for name in ("grasp_standoff_m", "finger_clearance_m", "contact_tolerance_m",
                     "sample_step_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"AccessSettings.{name}: expected > 0, found {v!r}")


@dataclass(frozen=True, eq=False)
class Access:
    """The gripper's access to one part's step along one insertion direction.

    Parameters
    ----------
    part : str
    options : tuple of frozenset of str
        Minimal sets of other parts that block a grasp (one set per grasp family); the step
        is reachable in a partial assembly disjoint from one of them. Empty: no grasp
        candidate survives even in an empty cell (the fingers hit the table).
    examined : int
        Grasp candidates examined.
    below_table, meets_predecessors : int
        Candidates dropped because the fingers reach below the table top (at the start or
        the assembled pose), or because the gripper meets a part every order places first.
    beyond_arm : int
        Candidates dropped because the cell's arm cannot take one of their key TCP poses
        (:mod:`asmplan.planner.arm_reach`); ``arm_failure`` says why for the best-ranked one.
    arm_hits : ArmCollisionError or None
        The arm's links meeting parts at a kept grasp's pre-insertion and seated poses (the
        first such grasp; those parts are in its set), for the reason.
    """

    part: str
    options: tuple[frozenset[str], ...]
    examined: int
    below_table: int = 0
    meets_predecessors: int = 0
    beyond_arm: int = 0
    arm_failure: ReachFailure | None = None
    arm_hits: ArmCollisionError | None = None

    def reachable(self, present: frozenset[str] | set[str]) -> bool:
        return any(not (o & present) for o in self.options)

    def reason(self, present: frozenset[str] | set[str]) -> str:
        """Why no grasp of the part is free with ``present`` placed ("" when one is)."""
        if self.reachable(present):
            return ""
        arm = self.arm_failure.text() if self.beyond_arm and self.arm_failure else ""
        if not self.options:
            if arm:
                return (f"the arm cannot do the step of {self.part} in any order: {arm}; of "
                        f"{self.examined} grasp candidates screened, {self.beyond_arm} are "
                        f"beyond the arm's reach or joint limits or put its links into the "
                        f"cell, {self.below_table} put the "
                        f"fingers below the table top and {self.meets_predecessors} meet a part "
                        "that must be placed before it")
            return (f"no grasp of {self.part} can be used in any order: of {self.examined} "
                    f"candidates screened, {self.below_table} put the fingers below the table "
                    f"top (at the start or the assembled pose) and {self.meets_predecessors} "
                    "meet a part that must be placed before it")
        met = sorted(set().union(*(o & present for o in self.options)))
        hit = self.arm_hits
        if not arm and hit is not None and {p.b for p in hit.pairs} & set(present):
            return (f"the arm cannot reach {self.part} with {', '.join(met)} placed: at the "
                    f"pre-insertion and seated poses {hit.listed} (every usable "
                    f"inverse-kinematics branch, or the gripper, of the {self.examined} grasp "
                    f"candidates screened meets {', '.join(met)} or a part that must precede "
                    f"{self.part})")
        if arm:
            return (f"the arm cannot reach {self.part}: {arm} ({self.beyond_arm} of "
                    f"{self.examined} grasp candidates screened beyond the arm's reach or "
                    f"joint limits or putting its links into the cell); every other grasp "
                    f"meets {', '.join(met)} or a part that "
                    f"must precede {self.part} (at the seated pose, along the insertion or on "
                    "the retreat)")
        return (f"the gripper cannot reach {self.part}: every grasp screened ({self.examined} "
                f"candidates) meets {', '.join(met)} or a part that must precede "
                f"{self.part} (at the seated pose, along the insertion or on the retreat)")


@dataclass
class GripperAccess:
    """Lazily computed :class:`Access` per (part, insertion direction), for one product."""

    product: Product
    geometry: ProductGeometry | None = None
    settings: AccessSettings = field(default_factory=AccessSettings)
    _scene: Any = None
    _parts: Any = None
    _cache: dict[tuple[Any, ...], Access] = field(default_factory=dict)
    _arm: ArmReach | None = None
    _links: Any = None  # ArmLinkScreen: the arm's links at the assembled-end poses

    def _setup(self) -> None:
        from ..parts.models import ProductGeometry
        from .layout import initial_layout
        from .partdata import part_data
        from .scene import Scene
        from .settings import PlannerSettings

        ps = PlannerSettings(contact_tolerance_m=self.settings.contact_tolerance_m,
                             finger_clearance_m=self.settings.finger_clearance_m,
                             surface_samples=self.settings.surface_samples)
        # the sequence planner's oracle carries the product's geometry; a box oracle or a
        # precomputed blocking table does not, and then the screening builds its own
        geometry = self.geometry if self.geometry is not None else ProductGeometry(self.product)
        self._parts = part_data(self.product, ps, geometry)
        self._starts, _ = initial_layout(self.product, self._parts)
        poses = {n: self.product.T_world_assembled(n) for n in self.product.part_names}
        self._scene = Scene(self.product, self._parts, poses, ps.contact_tolerance_m)
        robot = self.product.resources.robot
        if self.settings.arm_reach and robot is not None and robot.urdf_path is not None:
            self._arm = ArmReach(robot)
            if self.settings.arm_collisions:
                from .arm_reach_collisions import ArmLinkScreen

                self._links = ArmLinkScreen(robot, self._arm.arm, self._scene)

    def access(self, part: str, insertion: np.ndarray, pre_distance_m: float | None = None,
               required: frozenset[str] = frozenset()) -> Access:
        """Access to ``part``'s step along the unit world ``insertion`` (3,), whose straight
        insertion starts ``pre_distance_m`` before the seated pose (None: where the motion
        planner starts it, :meth:`pre_distance_m`); ``required`` are the parts every order
        places before it (grasps meeting them are skipped)."""
        u = np.asarray(insertion, float) / float(np.linalg.norm(insertion))
        if pre_distance_m is None:
            pre_distance_m = self.pre_distance_m(part, u, required)
        key = (part, tuple(np.round(u, 6)), round(pre_distance_m, 6), tuple(sorted(required)))
        hit = self._cache.get(key)
        if hit is None:
            hit = self._compute(part, u, pre_distance_m, frozenset(required))
            self._cache[key] = hit
        return hit

    def pre_distance_m(self, part: str, insertion: np.ndarray,
                       placed: frozenset[str] = frozenset()) -> float:
        """The pre-insertion distance the motion planner uses
        (:meth:`asmplan.planner.motion.MotionPlanner` step setup) with the parts ``placed``
        (the ones every order places first) and the fixtured ones in their assembled poses:
        the approach distance plus the longest engaged travel of the part's mates with them
        (:func:`asmplan.planner.insertion.mate_engagement_m`, the clearing travel through
        every bore), backed off along the insertion until the part stands the position
        tolerance clear of the table and them (:func:`asmplan.planner.insertion.clear_standoff_m`).
        With more parts placed the planner's start can only lie farther out."""
        from .insertion import clear_standoff_m, mate_engagement_m

        if self._scene is None:
            self._setup()
        product = self.product
        present = set(placed) | {n for n in product.part_names
                                 if n != part and product.is_fixtured(n)}
        u = np.asarray(insertion, float) / float(np.linalg.norm(insertion))
        engaged = max((mate_engagement_m(product, m, self._parts) for m in product.mates
                       if (m.pin_part == part and m.hole_part in present)
                       or (m.hole_part == part and m.pin_part in present)), default=0.0)
        return clear_standoff_m(self._scene, part, product.T_world_assembled(part), u,
                                [*self._scene.cell, *sorted(present)],
                                product.process.approach_distance_m + engaged,
                                clearance_m=product.process.position_tolerance_m)

    # Complexity above C (radon): every grasp candidate passes the same screens in order (below the
    # table, its poses, the insertion and retreat sweeps, minimality), each a branch that drops it.
    def _compute(self, part: str, u: np.ndarray, pre_distance_m: float,
                 required: frozenset[str]) -> Access:
        from .scene import GRIPPER_CLOSED, GRIPPER_OPEN, GRIPPER_SPAN, TABLE

        if self._scene is None:
            self._setup()
        product, scene, s = self.product, self._scene, self.settings
        data = self._parts[part]
        gripper = product.gripper_for(part)
        T_start = self._starts[part]
        T_final = product.T_world_assembled(part)
        others = [n for n in product.part_names if n != part]
        margin = product.process.position_tolerance_m
        limits_a = (product.part(part).handling.max_acceleration_m_s2
                    or product.process.max_acceleration_m_s2)
        limit_N = float(gripper.max_force_N)
        part_limit_N = product.part(part).handling.max_clamp_force_N
        if part_limit_N is not None:
            limit_N = min(limit_N, float(part_limit_N))
        dropped: dict[str, int] = {}
        cands = iter_grasps(part, data.surface, gripper, product.part(part).handling.grasp,
                            part_friction=product.part(part).friction,
                            finger_clearance_m=s.finger_clearance_m,
                            down_start_part=T_start[:3, :3].T @ -_Z,
                            down_final_part=T_final[:3, :3].T @ -_Z,
                            load=GripLoad(data.mass_kg, float(limits_a), limit_N,
                                          product.process.safety_factor),
                            table_poses=(T_start, T_final), table_margin_m=margin,
                            stats=dropped)
        sets: list[frozenset[str]] = []
        examined = below = before = beyond = 0
        arm_failure: ReachFailure | None = None
        arm_hits: ArmCollisionError | None = None
        stale = 0  # candidates in a row, since one was kept, that gave no new minimal set
        arm_run = 0  # candidates in a row beyond the arm
        T_pre = T_final.copy()
        T_pre[:3, 3] -= u * pre_distance_m
        T_lift = T_start.copy()
        T_lift[2, 3] += product.process.lift_height_m
        for g in itertools.islice(cands, s.max_candidates):
            if len(sets) >= s.max_grasps or stale >= s.patience:
                break
            if not sets and arm_run >= s.arm_patience:
                break  # candidate after candidate beyond the arm, none kept: a screening stops
            examined += 1
            stale += 1 if sets else 0
            scene.use_gripper(g, gripper)
            span = scene.piece_boxes(scene.world.model(GRIPPER_SPAN)).reshape(-1, 3)
            low = [float((span @ (T @ g.T_part_gripper)[2, :3] + (T @ g.T_part_gripper)[2, 3])
                         .min()) for T in (T_start, T_final)]
            if min(low) < margin:
                below += 1
                continue  # the fingers reach below the table top: no order helps
            G = T_final @ g.T_part_gripper
            met = set(scene.hits(GRIPPER_SPAN, G, [TABLE, *others]))
            if TABLE in met:
                below += 1
                continue
            d, who = scene.closest([(GRIPPER_SPAN, G)], others, margin)
            if d < margin and who:
                met.add(who)
            if met & required:
                before += 1
                continue
            if any(o <= met for o in sets):  # the segments only add parts: not minimal
                sets.append(frozenset(met))
                continue
            arm_sets: tuple[frozenset[str], ...] = (frozenset(),)
            if self._arm is not None:  # the arm at the step's key poses: only
                # for grasps the gripper can use that may give a new minimal set
                P = T_pre @ g.T_part_gripper
                fail = self._arm.screen(part, (
                    ("pick pose", T_start @ g.T_part_gripper),
                    ("lifted pose", T_lift @ g.T_part_gripper),
                    ("pre-insertion pose", P), ("seated pose", G)))
                if fail is None and self._links is not None:
                    hits = self._links.screen(
                        part, (("pre-insertion pose", P), ("seated pose", G)),
                        (self._arm.solution(P), self._arm.solution(G)), others)
                    arm_sets = tuple(m for m in hits.sets if not m & required)
                    if arm_sets and arm_sets != (frozenset(),):
                        arm_hits = arm_hits or hits.error
                    if not arm_sets and hits.error is not None:
                        fail = ReachFailure("pre-insertion and seated poses", hits.error)
                if fail is not None:
                    beyond += 1
                    arm_run += 1
                    arm_failure = arm_failure or fail
                    continue
                arm_run = 0
            # the straight insertion (closed) and the retreat (open)
            for body, delta in ((GRIPPER_CLOSED, -u * pre_distance_m),
                                (GRIPPER_OPEN, -G[:3, 2] * s.grasp_standoff_m)):
                met |= _segment_hits(scene, body, G, delta, others, s.sample_step_m)
                if met & required:
                    break
            met.discard(TABLE)
            if met & required:
                before += 1
                continue
            for arm_met in arm_sets:  # one set per usable arm branch
                full = frozenset(met | arm_met)
                if not any(o <= full for o in sets):
                    stale = 0
                sets.append(full)
            if not met and frozenset() in arm_sets:
                break  # free in every partial assembly: no other grasp can add to it
        minimal = sorted({m for m in sets if not any(o < m for o in sets)},
                         key=lambda m: (len(m), sorted(m)))
        return Access(part, tuple(minimal), examined, below, before, beyond, arm_failure,
                      arm_hits)


def _segment_hits(scene: Any, body: str, T: np.ndarray, delta: np.ndarray,
                  obstacles: list[str], step_m: float) -> set[str]:
    """Obstacles that ``body`` meets on the straight segment from ``T`` to ``T`` moved by
    ``delta`` (world, m): the exact swept volume of its convex pieces
    (:meth:`asmplan.planner.scene.Scene.sweep`), the pose at ``T`` itself included (one
    query per obstacle instead of one per ``step_m`` sample; ``step_m`` is kept for the
    settings' sake and unused)."""
    del step_m
    return set(scene.sweep([(body, T)], delta, obstacles).get(body, set()))


__all__ = ["Access", "AccessSettings", "GripperAccess"]
