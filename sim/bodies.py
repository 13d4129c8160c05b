"""The physics models of a step's bodies and the space a step sweeps: piece corners and boxes,
the held part's poses along the trajectory, which holes stay empty, and each part's collision
model for the simulator (holes filled where nothing goes into them; see :mod:`asmplan.sim.scene`).
"""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING, Any

import numpy as np

from ..knowledge.frames import invert
from ..knowledge.model import Product
from ..parts.geometry import PartShape
from ..parts.lod import convex_pieces
from ..parts.pieces import CollisionModel, ConvexPiece, LevelOfDetail
from ..planner.plan import Step
from ..planner.trajectory import OPEN_PHASES

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry


def piece_corners(pc: ConvexPiece) -> np.ndarray:
    """Points (n, 3) in the part frame whose convex hull contains the piece."""
    if pc.kind == "hull":
        assert pc.vertices_m is not None
        local = pc.vertices_m
    else:
        if pc.kind == "box":
            assert pc.half_extents_m is not None
            he = pc.half_extents_m
        elif pc.kind == "cylinder":
            he = np.array([pc.radius_m, pc.radius_m, pc.length_m / 2])
        else:
            he = np.full(3, pc.radius_m)
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        local = signs * he
    return local @ pc.T_part_piece[:3, :3].T + pc.T_part_piece[:3, 3]


def transform_points(points: np.ndarray, T: np.ndarray) -> np.ndarray:
    return points @ T[:3, :3].T + T[:3, 3]


def aabb(points: np.ndarray) -> np.ndarray:
    return np.stack([points.min(axis=0), points.max(axis=0)])


def box_distance_m(a: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Euclidean distance between AABB ``a`` (2, 3) and each of ``boxes`` (n, 2, 3), m."""
    gap = np.maximum(0.0, np.maximum(boxes[:, 0] - a[1], a[0] - boxes[:, 1]))
    return np.linalg.norm(gap, axis=1)


def held_part_poses(step: Step, t_s: np.ndarray) -> np.ndarray:
    """Pose (n, 4, 4) of the held part at times ``t_s``: at its start pose until the clamp,
    carried by the gripper through the held phases, at its final pose after the release."""
    assert step.trajectory is not None and step.grasp is not None
    traj = step.trajectory
    T_grip = traj.poses_at(t_s)
    carried = T_grip @ invert(step.grasp.T_part_gripper)
    clamp0 = traj.phase_span("clamp").t_start_s
    idx = traj.phase_indices_at(t_s)
    out = carried.copy()
    names = [p.name for p in traj.phases]
    for k, t in enumerate(t_s):
        if names[idx[k]] in OPEN_PHASES:
            out[k] = step.T_world_start if t <= clamp0 else step.T_world_final
    return out


def swept_boxes(step: Step, part_points: np.ndarray, gripper_points: np.ndarray) -> np.ndarray:
    """Bounding boxes (n - 1, 2, 3) covering the held part and the open gripper between two
    consecutive trajectory samples (the box of both samples' boxes), world frame, m."""
    assert step.trajectory is not None
    t = step.trajectory.t_s
    T_part = held_part_poses(step, t)
    T_grip = step.trajectory.T_world_gripper
    lo_hi = []
    for T, points in ((T_part, part_points), (T_grip, gripper_points)):
        pts = np.matmul(T[:, :3, :3], np.ascontiguousarray(points.T))  # (n, 3, k)
        lo_hi.append((pts.min(axis=2) + T[:, :3, 3], pts.max(axis=2) + T[:, :3, 3]))
    lo = np.minimum(lo_hi[0][0], lo_hi[1][0])
    hi = np.maximum(lo_hi[0][1], lo_hi[1][1])
    return np.stack([np.minimum(lo[:-1], lo[1:]), np.maximum(hi[:-1], hi[1:])], axis=1)


def empty_holes(product: Product, part: str, present: frozenset[str] | set[str]) -> frozenset[str]:
    """Hole features of ``part`` that nothing enters during a step.

    ``present`` holds the parts at their assembled poses in the step (the placed ones and the
    held one). A hole is empty when ``part`` is not present (it waits at its start pose), or
    when every mate of the hole has its pin part absent (the pin arrives in a later step). A
    hole no mate names is never called empty (something undeclared may pass through it).
    """
    mates_of: dict[str, list[str]] = {}
    for m in product.mates:
        if m.hole_part == part:
            mates_of.setdefault(m.hole_feature, []).append(m.pin_part)
    return frozenset(f for f, pins in mates_of.items()
                     if part not in present or all(p not in present for p in pins))


_FILLED: weakref.WeakKeyDictionary[Any, dict[tuple[str, frozenset[str]], CollisionModel]] = (
    weakref.WeakKeyDictionary())


def filled_model(geometry: ProductGeometry, part: str, filled: frozenset[str]) -> CollisionModel | None:
    """``part``'s convex model with the holes ``filled`` left solid (cached per geometry).

    None when nothing changes (no such hole cut in the part, or a mesh-file part, whose
    sectors come from its declared holes as a whole). The other holes keep their convex
    decomposition; a body left without holes becomes its exact primitive.
    """
    shape = geometry.shape(part)
    if shape.is_mesh or not any(h.feature in filled for h in shape.holes):
        return None
    cache = _FILLED.setdefault(geometry, {})
    key = (part, filled)
    if key not in cache:
        kept = tuple(h for h in shape.holes if h.feature not in filled)
        probe = PartShape(shape.part, shape.bodies, kept, shape.pins, shape.is_mesh)
        sides = {k: v for k, v in geometry.hole_sides(part).items() if k not in filled}
        pieces, notes = convex_pieces(probe, sides, geometry.settings)
        done = sorted(h.feature for h in shape.holes if h.feature in filled)
        cache[key] = CollisionModel("convex", pieces, notes=(
            *notes, f"hole(s) {', '.join(done)} left solid: empty during this step"))
    return cache[key]


def physics_model(geometry: ProductGeometry, part: str, level: LevelOfDetail, needs_features: bool,
                  filled: frozenset[str] = frozenset()) -> tuple[CollisionModel, str]:
    """The collision model PyBullet can use for ``part`` at the requested ``level``.

    ``filled``: holes that stay empty during the step (:func:`empty_holes`); where the level
    keeps holes they are modelled solid, which saves their ring of pieces and the contacts
    on it. Returns the model and a note on any change of level (see the module docstring).
    """
    note = ""
    reduced = filled_model(geometry, part, filled) if filled else None
    if reduced is not None:
        note = f"{len(filled)} hole(s) that stay empty modelled solid"
    if level == "coarse" and needs_features:
        coarse = geometry.collision_model(part, "coarse", measured=False)
        convex = reduced or geometry.collision_model(part, "convex", measured=False)
        if len(convex.pieces) > 1:
            return convex, "; ".join(x for x in (
                "convex (coarse would fill its holes and bridge its pins, and it is in contact)",
                note) if x)
        return coarse, ""
    if level == "exact":
        exact = geometry.collision_model(part, "exact")
        if exact.mesh_faces is not None or not exact.pieces:
            if reduced is not None and all(pc.kind != "hull" for pc in reduced.pieces):
                return reduced, note + " (every hole solid: the exact primitives)"
            return reduced or geometry.collision_model(part, "convex", measured=False), "; ".join(
                x for x in (
                    "convex (its exact model is a triangle mesh, which PyBullet cannot use for "
                    "every body; convex pieces keep the holes as exact polygons)", note) if x)
        return exact, ""
    if level == "coarse":
        return geometry.collision_model(part, level, measured=False), ""
    return reduced or geometry.collision_model(part, level, measured=False), note


def coarse_fills_path(geometry: ProductGeometry, step: Step, other: str, T_world_other: np.ndarray,
                      tolerance_m: float = 0.05e-3, samples: int = 9) -> float:
    """How deep the held part of ``step`` would sit inside ``other``'s coarse hull along its
    insertion (from ``T_world_pre_insertion`` to ``T_world_final``, ``samples`` poses), m; 0
    when it stays outside (within ``tolerance_m``).

    A part the held one passes through without a mate (a housing whose relief bore the shaft
    crosses on its way to the far bearing) needs that bore in the step: its one coarse hull
    fills it, and the part would stop on a wall that is not there. A positive depth says the
    coarse level would fill a feature the step needs (issue 19's rule: a level that must fill
    or drop a feature says so; here the scene keeps it instead)."""
    from scipy.spatial import ConvexHull, QhullError

    from ..parts.primitive_pieces import piece_points

    if step.T_world_pre_insertion is None:
        return 0.0
    coarse = geometry.collision_model(other, "coarse", measured=False)
    pts = np.concatenate([piece_points(pc, 1e-5) for pc in coarse.pieces])  # part frame
    try:
        eq = ConvexHull(transform_points(pts, T_world_other)).equations  # n . x + d <= 0 inside
    except QhullError:
        return 0.0
    held = np.asarray(geometry.mesh(step.part).vertices, float)
    A, B = np.asarray(step.T_world_pre_insertion, float), np.asarray(step.T_world_final, float)
    deepest = 0.0
    for s in np.linspace(0.0, 1.0, samples):
        T = B.copy()
        T[:3, 3] = (1.0 - s) * A[:3, 3] + s * B[:3, 3]
        w = transform_points(held, T)
        depth = -(w @ eq[:, :3].T + eq[:, 3]).max(axis=1)  # > 0: inside every face
        deepest = max(deepest, float(depth.max()))
    return deepest if deepest > tolerance_m else 0.0
