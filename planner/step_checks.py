"""The motion planner's checks of one step before its path is planned: the gripper at the
start and assembled poses and along the straight insertion (:func:`grasp_collisions`), and
the part alone along its straight insertion (:func:`check_insertion`). Split out of
:mod:`asmplan.planner.motion` (:class:`~asmplan.planner.motion.MotionPlanner` calls them)."""

from __future__ import annotations

import math

import numpy as np

from ..knowledge.frames import invert
from ..knowledge.model import Product
from .errors import CollidingPair, InsertionBlockedError
from .insertion import InsertionSpec, other_body, unexcused
from .plan import Grasp
from .scene import GRIPPER_CLOSED, GRIPPER_OPEN, GRIPPER_SPAN, TABLE, Scene, translated
from .settings import PlannerSettings


def grasp_collisions(scene: Scene, product: Product, g: Grasp, part: str,
                     T_start: np.ndarray, T_final: np.ndarray, obstacles: list[str],
                     T_pre: np.ndarray | None = None) -> tuple[str, list[CollidingPair]]:
    """Fingers (the space they sweep while closing) at the start and assembled poses, and
    the open gripper against the part itself. The fingers must also keep the process's
    position tolerance from every obstacle at both poses (a real gripper is only placed
    that accurately). With ``T_pre`` (the part's pre-insertion pose), the closed gripper
    must also be free along the straight insertion (exact swept volume): a grasp inside a
    housing that the gripper cannot enter is rejected here, before its motion is planned
    (it would use up the ``max_grasps`` full attempts)."""
    scene.use_gripper(g, product.gripper_for(part))
    margin = product.process.position_tolerance_m
    span = scene.piece_boxes(scene.world.model(GRIPPER_SPAN)).reshape(-1, 3)
    for where, T_part in (("start pose", T_start), ("assembled pose", T_final)):
        T = T_part @ g.T_part_gripper
        # the gripper is made of boxes: its lowest point is exact without FCL
        z = (span @ T[2, :3] + T[2, 3]).reshape(-1, 8).min(axis=1)
        if float(z.min()) < margin:  # pieces: two fingers, then the palm
            low = [n for n, zz in (("open fingers", z[:2].min()), ("palm", z[2:].min()))
                   if zz < margin]
            return f"{where} ({' and '.join(low)})", [CollidingPair(GRIPPER_SPAN, TABLE)]
        hit = scene.hits(GRIPPER_SPAN, T, obstacles)
        if hit:
            return (f"{where} ({gripper_pieces(scene, product, g, T, hit)})",
                    [CollidingPair(GRIPPER_SPAN, o) for o in hit])
        d, who = scene.closest([(GRIPPER_SPAN, T)], obstacles, margin)
        if d < margin:
            return (f"{where} (closer than the position tolerance "
                    f"{margin * 1e3:.2f} mm)", [CollidingPair(GRIPPER_SPAN, who, None)])
    if T_pre is not None:
        G_pre = T_pre @ g.T_part_gripper
        delta = (T_final @ g.T_part_gripper)[:3, 3] - G_pre[:3, 3]
        swept = scene.sweep([(GRIPPER_CLOSED, G_pre)], delta, obstacles)
        if swept.get(GRIPPER_CLOSED):
            return "insertion", [CollidingPair(GRIPPER_CLOSED, o)
                                 for o in sorted(swept[GRIPPER_CLOSED])]
    scene.set_part_pose(part, T_start)
    if scene.hits(GRIPPER_OPEN, T_start @ g.T_part_gripper, [part]):
        return "grasp (open fingers on the part)", [CollidingPair(GRIPPER_OPEN, part)]
    return "", []

def gripper_pieces(scene: Scene, product: Product, g: Grasp, T_world_tcp: np.ndarray,
                   hit: list[str]) -> str:
    """Which of the gripper's pieces (the open fingers with the space they sweep closing,
    or the palm behind them) the deepest contacts with ``hit`` lie in."""
    world = scene.world
    world.set_pose(GRIPPER_SPAN, T_world_tcp)
    half_length = float(product.gripper_for(g.part).finger_size_m[2]) / 2
    found = set()
    for c in world.contacts([GRIPPER_SPAN], hit, scene.tolerance_m):
        z = float((invert(T_world_tcp) @ np.append(c.point_m, 1.0))[2])
        found.add("palm" if z < -half_length - 1e-9 else "open fingers")
    return " and ".join(sorted(found)) or "open fingers"

def check_insertion(scene: Scene, settings: PlannerSettings, index: int, part: str,
                    spec: InsertionSpec, T_pre: np.ndarray, T_final: np.ndarray,
                    obstacles: list[str]) -> float:
    """The part alone along its straight insertion: the seated and pre-insertion poses,
    then the exact sweep between them. Returns the sampling step used to excuse contact
    with a mate partner (0 when the sweep met nothing)."""
    pairs = scene.contacts_at([(part, T_final)], obstacles)
    bad = unexcused(pairs, spec, part, T_final, scene.poses)
    dist = float(np.linalg.norm(T_final[:3, 3] - T_pre[:3, 3]))
    if bad:
        raise InsertionBlockedError(index, part, other_body(bad[0], part), T_final, bad, 0.0,
                                    segment="assembled pose")
    pairs = scene.contacts_at([(part, T_pre)], obstacles)
    if pairs:
        raise InsertionBlockedError(index, part, other_body(pairs[0], part), T_pre, pairs, dist,
                                    segment="pre-insertion pose")
    delta = T_final[:3, 3] - T_pre[:3, 3]
    hits = scene.sweep([(part, T_pre)], delta, obstacles).get(part, set())
    if not hits:
        return 0.0
    partners = {r.hole_part if r.pin_part == part else r.pin_part for r in spec.regions}
    strangers = sorted(hits - partners)
    # locate the first blocking sample for evidence (and excuse pin-in-hole contact)
    step = insertion_step(settings, spec)
    n = max(1, math.ceil(dist / step))
    check = sorted(hits)
    for i in range(n + 1):
        T = translated(T_pre, delta * (i / n))
        pairs = scene.contacts_at([(part, T)], check)
        bad = unexcused(pairs, spec, part, T, scene.poses)
        if bad:
            raise InsertionBlockedError(index, part, other_body(bad[0], part), T, bad,
                                        dist * (1 - i / n))
    if strangers:  # the sweep hit something the samples did not: report it anyway
        raise InsertionBlockedError(index, part, strangers[0], T_pre, [], dist,
                                    segment="insertion (swept volume)")
    return step

def insertion_step(settings: PlannerSettings, spec: InsertionSpec) -> float:
    """The sampling step of a straight insertion that touched its mate partner, m: four
    times the fit's smallest radial clearance, within the settings' bounds."""
    s = settings
    c = spec.radial_clearance_min_m
    return max(s.min_insertion_step_m, min(s.insertion_step_m, 4.0 * c))
