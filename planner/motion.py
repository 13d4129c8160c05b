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
(palm + two finger boxes from the Gripper resource, see :func:`gripper_model`).
"""

from __future__ import annotations

import hashlib
import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..knowledge.frames import invert
from ..knowledge.model import Gripper, Product, Table
from ..parts.collision import CollisionWorld, Contact, FclShapes, circumscribed_prism_points
from ..parts.pieces import CollisionModel, ConvexPiece
from .errors import (
    CollidingPair,
    GripInfeasibleError,
    InsertionBlockedError,
    NoGraspError,
    NoPathError,
    PlanningError,
    StartInCollisionError,
)
from .grasp import GraspSurface, GripLoad, Rejections, collision_free, iter_grasps
from .insertion import clear_standoff_m, clearing_travel_m
from .ompl_backend import SE3Bounds, plan_se3
from .plan import Grasp, Plan, PlannerSettings, Step
from .timing import (
    Move,
    StepMotion,
    clamp_force,
    interpolate_poses,
    motion_limits,
    time_step,
)
from .trajectory import rotation_angle_rad

TABLE = "table"
GRIPPER_CLOSED = "gripper"
GRIPPER_OPEN = "gripper(open)"
GRIPPER_SPAN = "gripper(closing)"
_Z = np.array([0.0, 0.0, 1.0])
_ENGAGE_MARGIN_M = 1e-3  # the insertion speed starts this far before the pin tip enters
_HOLE_REGION_TOL_M = 2e-4


# ---------------------------------------------------------------------------------------------
# Models of the cell
# ---------------------------------------------------------------------------------------------
def gripper_model(gripper: Gripper, inner_half_m: float, outer_half_m: float | None = None
                  ) -> CollisionModel:
    """Palm and two finger boxes in the gripper TCP frame.

    Each finger is a box ``finger_size_m`` (x width, y thickness, z length) whose inner face
    lies at ``|y| = inner_half_m`` and whose length is centred on the TCP (the pad's contact
    face centre is the TCP, see :mod:`asmplan.planner.trajectory`); ``outer_half_m`` (default
    ``inner_half_m + thickness``) widens the fingers to cover the space they sweep while
    closing. The palm box (``palm_size_m``) sits right behind the fingers' roots
    (``z < -length / 2``).
    """
    W, t, L = (float(v) for v in gripper.finger_size_m)
    outer = inner_half_m + t if outer_half_m is None else float(outer_half_m)
    th = outer - inner_half_m
    px, py, pz = (float(v) for v in gripper.palm_size_m)
    pieces = []
    for sign, name in ((1.0, "finger1"), (-1.0, "finger2")):
        T = np.eye(4)
        T[1, 3] = sign * (inner_half_m + th / 2)
        pieces.append(ConvexPiece("box", T, half_extents_m=np.array([W / 2, th / 2, L / 2]),
                                  name=name))
    T = np.eye(4)
    T[2, 3] = -L / 2 - pz / 2
    pieces.append(ConvexPiece("box", T, half_extents_m=np.array([px / 2, py / 2, pz / 2]),
                              name="palm"))
    return CollisionModel("exact", tuple(pieces))


def table_model(table: Table) -> CollisionModel:
    """The table as one box whose top face is the world plane z = 0, centred on the origin."""
    size = np.asarray(table.size_m, dtype=float)
    T = np.eye(4)
    T[2, 3] = -size[2] / 2
    return CollisionModel("exact", (ConvexPiece("box", T, half_extents_m=size / 2,
                                                name="table"),))


def _translate(T: np.ndarray, d: np.ndarray) -> np.ndarray:
    out = np.array(T, dtype=float)
    out[:3, 3] += d
    return out


def _pairs(contacts: Sequence[Contact]) -> list[CollidingPair]:
    return [CollidingPair(c.a, c.b, float(c.depth_m), np.asarray(c.point_m)) for c in contacts]


# ---------------------------------------------------------------------------------------------
# Geometry of the parts (from asmplan.parts)
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PartData:
    """What motion planning needs of one part: its collision model at the planning level and
    its coarse model (one convex piece containing it), surface samples for grasps, mass (kg)
    and centre of mass (part frame, m)."""

    name: str
    model: CollisionModel
    coarse: CollisionModel
    surface: GraspSurface
    mass_kg: float
    com_m: np.ndarray
    points_m: np.ndarray  # (n, 3) points whose hull bounds the part, part frame


def part_data(product: Product, settings: PlannerSettings, geometry: Any | None = None
              ) -> dict[str, PartData]:
    """:class:`PartData` of every part, from :class:`asmplan.parts.models.ProductGeometry`."""
    if geometry is None:
        from ..parts.models import ProductGeometry

        geometry = ProductGeometry(product)
    geo = geometry
    out = {}
    for k, part in enumerate(product.parts):
        mesh = geo.mesh(part.name)
        mp = geo.mass_properties(part.name)
        # the planner uses the pieces only: measuring their error (~0.1-1 s per part) is left
        # to the commands that show it
        model = geo.collision_model(part.name, settings.collision_level, measured=False)
        coarse = geo.collision_model(part.name, "coarse", measured=False)
        surface = GraspSurface.from_mesh(mesh, mp.com_m, settings.surface_samples,
                                         settings.seed + 7919 * k, part.geometry.kind)
        out[part.name] = PartData(part.name, model, coarse, surface, float(mp.mass_kg),
                                  np.asarray(mp.com_m, float), np.asarray(mesh.vertices, float))
    return out


# ---------------------------------------------------------------------------------------------
# Insertion geometry
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class HoleRegion:
    """The cylinder of a mated hole, where pin-in-hole contact may be excused.

    ``origin_m`` and ``axis`` are in the frame of ``hole_part`` (axis: outward normal of the
    mouth); the region spans ``-depth_m <= s <= chamfer`` along the axis and radius
    ``radius_m``.
    """

    mate: str
    pin_part: str
    hole_part: str
    origin_m: np.ndarray
    axis: np.ndarray
    radius_m: float
    depth_m: float
    chamfer_m: float
    clearance_min_m: float

    def contains(self, point_world: np.ndarray, T_world_hole_part: np.ndarray) -> bool:
        p = invert(T_world_hole_part) @ np.append(point_world, 1.0)
        rel = p[:3] - self.origin_m
        s = float(rel @ self.axis)
        radial = float(np.linalg.norm(rel - s * self.axis))
        tol = _HOLE_REGION_TOL_M
        return (-self.depth_m - tol <= s <= self.chamfer_m + tol
                and radial <= self.radius_m + self.chamfer_m + tol)


@dataclass(frozen=True, eq=False)
class InsertionSpec:
    """How a part goes in: direction (unit, world), engaged length (m), mates, hole regions."""

    kind: Literal["insert", "place"]
    direction: np.ndarray
    length_m: float
    mates: tuple[str, ...]
    regions: tuple[HoleRegion, ...]
    radial_clearance_min_m: float


def insertion_spec(product: Product, part: str, placed: Sequence[str],
                   fallback_direction: np.ndarray | None = None, step: int = 0,
                   parts: dict[str, PartData] | None = None) -> InsertionSpec:
    """The insertion of ``part`` into the partial assembly ``placed``.

    The engaged length is the longest pin engagement, or with ``parts`` (part geometry) the
    longest travel that takes the part out of every bore it passes
    (:func:`asmplan.planner.insertion.clearing_travel_m`: a shaft through two bearings starts
    before the first).

    The direction is the pin axis in the world when ``part`` carries the pin, minus it when
    ``part`` carries the hole; every mate with a placed part must agree. Without such a mate
    the part is placed along its handling's ``insertion_direction``, else
    ``fallback_direction``, else straight down.
    """
    placed_set = set(placed)
    dirs: list[np.ndarray] = []
    names: list[str] = []
    regions: list[HoleRegion] = []
    length = 0.0
    clear = math.inf
    for m in product.mates:
        if not ((m.pin_part == part and m.hole_part in placed_set)
                or (m.hole_part == part and m.pin_part in placed_set)):
            continue
        pin = product.feature(m.pin_part, m.pin_feature)
        hole = product.feature(m.hole_part, m.hole_feature)
        axis_w = product.T_world_assembled(m.pin_part)[:3, :3] @ pin.axis
        dirs.append(axis_w if m.pin_part == part else -axis_w)
        names.append(m.name)
        engaged = pin.length_m if (hole.through or hole.length_m <= 0) \
            else min(pin.length_m, hole.length_m)
        if parts is not None:  # beyond the feature's engagement by more than mesh noise
            travel = clearing_travel_m(product, m, {n: parts[n].points_m
                                                    for n in (m.pin_part, m.hole_part)})
            engaged = travel if travel > engaged + 1e-6 else engaged
        length = max(length, engaged)
        depth = max(hole.length_m, pin.length_m)
        regions.append(HoleRegion(m.name, m.pin_part, m.hole_part, np.asarray(hole.origin_m),
                                  np.asarray(hole.axis), hole.diameter_m / 2, depth,
                                  hole.chamfer_m, m.clearance_min_m))
        clear = min(clear, max(m.clearance_min_m, 0.0) / 2)
    if not dirs:
        h = product.part(part).handling.insertion_direction
        d = h if h is not None else fallback_direction if fallback_direction is not None else -_Z
        d = np.asarray(d, float) / np.linalg.norm(d)
        return InsertionSpec("place", d, 0.0, (), (), math.inf)
    u = dirs[0]
    for d, n in zip(dirs[1:], names[1:], strict=True):
        if float(np.dot(d, u)) < 1.0 - 1e-6:
            raise NoPathError(step, part, np.zeros((0, 4, 4)),
                              f"mates {names[0]} and {n} need different insertion directions "
                              f"({np.round(u, 4).tolist()} and {np.round(d, 4).tolist()})")
    return InsertionSpec("insert", u / np.linalg.norm(u), float(length), tuple(names),
                         tuple(regions), float(clear))


# ---------------------------------------------------------------------------------------------
# The scene and its checks
# ---------------------------------------------------------------------------------------------
_CORNER_SIGNS = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])


_SWEEP = "~sweep"
_MESH_SWEEP_STEP_M = 1e-4  # BVH parts are stepped at this spacing instead of swept


def piece_boxes(model: CollisionModel) -> np.ndarray:
    """Corners (P, 8, 3) of every piece's bounding box in the model's frame."""
    out = []
    signs = 2.0 * _CORNER_SIGNS - 1.0
    for pc in model.pieces:
        if pc.kind == "box":
            local = signs * pc.half_extents_m
        elif pc.kind == "cylinder":
            local = signs * np.array([pc.radius_m, pc.radius_m, pc.length_m / 2])
        elif pc.kind == "sphere":
            local = signs * pc.radius_m
        else:
            v = np.asarray(pc.vertices_m)
            lo, hi = v.min(axis=0), v.max(axis=0)
            local = np.where(_CORNER_SIGNS == 0, lo, hi)
        T = pc.T_part_piece
        out.append(local @ T[:3, :3].T + T[:3, 3])
    return np.array(out).reshape(-1, 8, 3)


def swept_model(model: CollisionModel, pieces: Sequence[int], T_world_part: np.ndarray,
                delta: np.ndarray) -> CollisionModel:
    """The volume swept by the given pieces of ``model`` (at ``T_world_part``) under the
    translation ``delta`` (world, m), as a model in the world frame.

    A convex piece sweeps to the convex hull of itself and its translate (exact). A box or a
    cylinder moving along its own axis stays a box or cylinder, longer by the distance
    (exact primitives); a cylinder moving otherwise becomes the hull of circumscribed prisms
    (within 1 um); a sphere the hull of its circumscribed cube (conservative).
    """
    delta = np.asarray(delta, dtype=float)
    dist = float(np.linalg.norm(delta))
    u = delta / dist
    out: list[ConvexPiece] = []
    for i in pieces:
        pc = model.pieces[i]
        T = T_world_part @ pc.T_part_piece
        R = T[:3, :3]
        along = int(np.argmax(np.abs(R.T @ u)))
        aligned = float(np.linalg.norm(np.cross(R[:, along], u))) * dist < 1e-9
        if pc.kind == "box" and aligned:
            Tw = T.copy()
            Tw[:3, 3] += 0.5 * delta
            half = np.array(pc.half_extents_m, dtype=float)
            half[along] += 0.5 * dist
            out.append(ConvexPiece("box", Tw, half_extents_m=half, name=pc.name))
            continue
        if pc.kind == "cylinder" and aligned and along == 2:
            Tw = T.copy()
            Tw[:3, 3] += 0.5 * delta
            out.append(ConvexPiece("cylinder", Tw, radius_m=pc.radius_m,
                                   length_m=pc.length_m + dist, name=pc.name))
            continue
        if pc.kind == "box":
            local = (2.0 * _CORNER_SIGNS - 1.0) * pc.half_extents_m
        elif pc.kind == "cylinder":
            local = circumscribed_prism_points(pc.radius_m, pc.length_m)
        elif pc.kind == "sphere":
            local = (2.0 * _CORNER_SIGNS - 1.0) * pc.radius_m
        else:
            local = np.asarray(pc.vertices_m, dtype=float)
        pts = local @ R.T + T[:3, 3]
        out.append(ConvexPiece("hull", np.eye(4), vertices_m=np.vstack([pts, pts + delta]),
                               name=pc.name))
    return CollisionModel(model.level, tuple(out))


def _coarse(name: str) -> str:
    return f"{name}~coarse"


def _box_gaps(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Distance (k,) between ``box`` (2, 3) and each of ``boxes`` (k, 2, 3), m."""
    g = np.maximum(0.0, np.maximum(boxes[:, 0] - box[1], box[0] - boxes[:, 1]))
    return np.sqrt((g * g).sum(axis=1))


def _near_mask(box: np.ndarray, boxes: np.ndarray, margin: float) -> np.ndarray:
    """Which of ``boxes`` (k, 2, 3) come within ``margin`` of ``box`` (2, 3): bool (k,)."""
    return (np.all(box[0] <= boxes[:, 1] + margin, axis=1)
            & np.all(boxes[:, 0] <= box[1] + margin, axis=1))


class Scene:
    """A :class:`CollisionWorld` holding the table, every part and the gripper variants.

    Every part is held twice: at the planning level (``name``) and as its coarse model
    (``name~coarse``, one convex piece containing the part). Checks go in tiers: bounding
    boxes (each body's model box moved to its pose, against the obstacles' world boxes), then
    the coarse models (a superset: coarse-free means free), then the planning level. ``poses``
    records where every part is. The moving part and the gripper are never obstacles to each
    other (the pads touch the part).
    """

    def __init__(self, product: Product, parts: dict[str, PartData],
                 initial_poses: dict[str, np.ndarray], tolerance_m: float,
                 shapes: FclShapes | None = None) -> None:
        self.product = product
        self.parts = parts
        self.tolerance_m = tolerance_m
        self.world = CollisionWorld(shapes)
        self.corners: dict[str, np.ndarray] = {}  # body-frame box corners (8, 3)
        self._boxes: dict[int, tuple[CollisionModel, np.ndarray]] = {}
        self._add(TABLE, table_model(product.resources.table), np.eye(4))
        self.poses = {n: np.array(T, float) for n, T in initial_poses.items()}
        for name in product.part_names:
            self._add(name, parts[name].model, self.poses[name])
            self._add(_coarse(name), parts[name].coarse, self.poses[name])
        self._gripper_key: tuple[float, float, str] | None = None
        self._gripper_models: dict[tuple[float, float, str], tuple[CollisionModel, ...]] = {}

    def piece_boxes(self, model: CollisionModel) -> np.ndarray:
        """:func:`piece_boxes`, cached per model object."""
        hit = self._boxes.get(id(model))
        if hit is None or hit[0] is not model:
            hit = (model, piece_boxes(model))
            self._boxes[id(model)] = hit
        return hit[1]

    def _add(self, name: str, model: CollisionModel, T: np.ndarray) -> None:
        if name not in self.corners or self.world.model(name) is not model:
            pts = self.piece_boxes(model).reshape(-1, 3)
            if model.mesh_vertices_m is not None:
                pts = np.vstack([pts, np.asarray(model.mesh_vertices_m)]) if len(pts) \
                    else np.asarray(model.mesh_vertices_m)
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            self.corners[name] = np.where(_CORNER_SIGNS == 0, lo, hi)
        self.world.add(name, model, T)

    def coarse_of(self, name: str) -> str:
        c = _coarse(name)
        return c if c in self.corners else name

    def set_part_pose(self, name: str, T: np.ndarray) -> None:
        self.poses[name] = np.array(T, float)
        self.world.set_pose(name, T)
        self.world.set_pose(_coarse(name), T)

    def use_gripper(self, grasp: Grasp, gripper: Gripper | None = None) -> None:
        """(Re)build the three gripper bodies for ``grasp``'s widths (with ``gripper``'s pads;
        default the product's gripper)."""
        g = gripper if gripper is not None else self.product.resources.gripper
        key = (round(grasp.width_m, 9), round(grasp.open_width_m, 9), g.finger_name)
        if key == self._gripper_key:
            return
        if key not in self._gripper_models:
            t = float(g.finger_size_m[1])
            self._gripper_models[key] = (
                gripper_model(g, grasp.width_m / 2), gripper_model(g, grasp.open_width_m / 2),
                gripper_model(g, grasp.width_m / 2, grasp.open_width_m / 2 + t))
        far = np.eye(4)
        far[:3, 3] = 1e3
        for name, model in zip((GRIPPER_CLOSED, GRIPPER_OPEN, GRIPPER_SPAN),
                               self._gripper_models[key], strict=True):
            self._add(name, model, far)
        self._gripper_key = key

    def obstacles(self, moving: str) -> list[str]:
        """Everything but the moving part and the gripper bodies."""
        return [TABLE, *[n for n in self.product.part_names if n != moving]]

    # -- tiers ------------------------------------------------------------------------------
    def box_at(self, name: str, T: np.ndarray) -> np.ndarray:
        """World bounding box (2, 3) of body ``name`` (its model box) at pose ``T``."""
        w = self.corners[name] @ T[:3, :3].T + T[:3, 3]
        return np.stack([w.min(axis=0), w.max(axis=0)])

    def near(self, box: np.ndarray, obstacles: Sequence[str], margin: float = 0.0) -> list[str]:
        """Obstacles whose world box comes within ``margin`` of ``box``."""
        if not len(obstacles):
            return []
        return [o for o, k in zip(obstacles, _near_mask(box, self.world.aabbs(obstacles), margin),
                                  strict=True) if k]

    def gap(self, box: np.ndarray, obstacles: Sequence[str]) -> float:
        """Smallest distance between ``box`` and the obstacles' world boxes, m (a lower bound
        of the true distance)."""
        if not len(obstacles):
            return math.inf
        return float(_box_gaps(box, self.world.aabbs(obstacles)).min())

    def hits(self, name: str, T: np.ndarray, obstacles: Sequence[str]) -> list[str]:
        """Obstacles that body ``name`` at ``T`` penetrates (deeper than the tolerance)."""
        cand = self.near(self.box_at(name, T), obstacles)
        if not cand:
            return []
        world, tol = self.world, self.tolerance_m
        cb = self.coarse_of(name)
        world.set_pose(cb, T)
        coarse_hit = [o for o in cand if world.in_collision(cb, [self.coarse_of(o)], tol)]
        if not coarse_hit:
            return []
        if cb != name:
            world.set_pose(name, T)
        return [o for o in coarse_hit if world.in_collision(name, [o], tol)]

    def collides(self, bodies: Sequence[tuple[str, np.ndarray]], obstacles: Sequence[str]
                 ) -> bool:
        return any(self.hits(n, T, obstacles) for n, T in bodies)

    def contacts_at(self, bodies: Sequence[tuple[str, np.ndarray]], obstacles: Sequence[str]
                    ) -> list[CollidingPair]:
        """Contacts (deeper than the tolerance) of bodies placed at the given poses."""
        out: list[CollidingPair] = []
        for name, T in bodies:
            hit = self.hits(name, T, obstacles)
            if hit:
                self.world.set_pose(name, T)
                out.extend(_pairs(self.world.contacts([name], hit, self.tolerance_m)))
        return out

    def sweep(self, bodies: Sequence[tuple[str, np.ndarray]], delta: np.ndarray,
              obstacles: Sequence[str]) -> dict[str, set[str]]:
        """Exact sweep of each body from its pose by ``delta`` (world, m): blockers per body.

        Tiers: the swept bounding box, the coarse model's swept volume, the planning level's
        swept volume (only the pieces whose swept box meets an obstacle's box). See
        :func:`swept_model`.
        """
        dist = float(np.linalg.norm(delta))
        out: dict[str, set[str]] = {}
        for name, T in bodies:
            if dist <= 0:
                hit = set(self.hits(name, T, obstacles))
            else:
                b0 = self.box_at(name, T)
                box = np.stack([np.minimum(b0[0], b0[0] + delta), np.maximum(b0[1], b0[1] + delta)])
                cand = self.near(box, obstacles)
                if not cand:
                    continue
                cb = self.coarse_of(name)
                coarse = [o for o in cand
                          if self._swept_hits(cb, T, delta, [self.coarse_of(o)])]
                if not coarse:
                    continue
                hit = set(coarse) if cb == name else set(self._swept_hits(name, T, delta, coarse))
            if hit:
                out[name] = set(hit)
        return out

    def _model(self, name: str) -> CollisionModel:
        return self.world.model(name)

    def _swept_hits(self, name: str, T: np.ndarray, delta: np.ndarray,
                    obstacles: Sequence[str]) -> list[str]:
        """Obstacles hit by body ``name`` translated by ``delta`` from ``T``."""
        model = self._model(name)
        tol = self.tolerance_m
        if model.mesh_vertices_m is not None:  # a BVH cannot be swept exactly: sample it
            dist = float(np.linalg.norm(delta))
            n = max(1, math.ceil(dist / _MESH_SWEEP_STEP_M))
            hit: list[str] = []
            for k in range(n + 1):
                Tk = _translate(T, delta * (k / n))
                hit += [o for o in self.hits(name, Tk, obstacles) if o not in hit]
            return hit
        boxes = self.piece_boxes(model)  # (P, 8, 3) part frame
        w = boxes @ T[:3, :3].T + T[:3, 3]
        lo = np.minimum(w.min(axis=1), w.min(axis=1) + delta)
        hi = np.maximum(w.max(axis=1), w.max(axis=1) + delta)
        ob = self.world.aabbs(obstacles)
        over = ((lo[:, None] <= ob[None, :, 1]) & (ob[None, :, 0] <= hi[:, None])).all(axis=2)
        keep = tuple(int(i) for i in np.flatnonzero(over.any(axis=1)))
        if not keep:
            return []
        self.world.add(_SWEEP, swept_model(model, keep, T, delta), np.eye(4))
        return [o for o in obstacles if self.world.in_collision(_SWEEP, [o], tol)]

    def distance_bound(self, bodies: Sequence[tuple[str, np.ndarray]], obstacles: Sequence[str],
                       enough: float) -> float:
        """A lower bound of the distance between the bodies (at their poses) and the
        obstacles, m, exact where boxes come closer than ``enough``; negative when
        penetrating."""
        return self.closest(bodies, obstacles, enough)[0]

    def closest(self, bodies: Sequence[tuple[str, np.ndarray]], obstacles: Sequence[str],
                enough: float) -> tuple[float, str]:
        """:meth:`distance_bound` and the obstacle it was measured to ("" when none is
        within ``enough``)."""
        best, who = math.inf, ""
        for name, T in bodies:
            box = self.box_at(name, T)
            if not len(obstacles):
                best = min(best, math.inf)
                continue
            ob = self.world.aabbs(obstacles)
            gaps = _box_gaps(box, ob)
            g = float(gaps.min())
            if g >= enough:
                best = min(best, g)
                continue
            mask = _near_mask(box, ob, enough)
            close = [o for o, k in zip(obstacles, mask, strict=True) if k]
            if not mask.all():  # the gap to the far boxes (the near ones are measured exactly)
                best = min(best, float(gaps[~mask].min()))
            self.world.set_pose(name, T)
            for o in close:
                d = self.world.distance(name, o)
                if d < best:
                    best, who = d, o
        return best, who


class BroadPhaseValidity:
    """Validity of a TCP pose for OMPL: the carried bodies against the obstacles, in the
    tiers of :meth:`Scene.hits` (boxes, coarse models, planning level).

    The obstacles do not move during a step, so their boxes are stacked once. A carried
    body's box (centre ``c``, half extents ``h`` in the TCP frame) at rotation ``R`` has the
    world box ``R c + t +- |R| h``: the box tier is a few small array operations.
    """

    def __init__(self, scene: Scene, carried: Sequence[tuple[str, np.ndarray]],
                 obstacles: Sequence[str]) -> None:
        self.scene = scene
        self.carried = [(n, np.asarray(Tb, float)) for n, Tb in carried]
        self.obstacles = list(obstacles)
        boxes = scene.world.aabbs(self.obstacles)  # (k, 2, 3)
        self.lo, self.hi = boxes[:, 0], boxes[:, 1]
        centres, halves = [], []
        for n, Tb in self.carried:
            c = scene.corners[n] @ Tb[:3, :3].T + Tb[:3, 3]  # body box corners, TCP frame
            lo, hi = c.min(axis=0), c.max(axis=0)
            centres.append(0.5 * (lo + hi))
            halves.append(0.5 * (hi - lo))
        self.centres = np.array(centres)  # (m, 3)
        self.halves = np.array(halves)
        self.calls = 0
        self.narrow = 0

    def __call__(self, T: np.ndarray) -> bool:
        self.calls += 1
        R = T[:3, :3]
        c = self.centres @ R.T + T[:3, 3]
        h = self.halves @ np.abs(R).T
        over = ((c - h)[:, None, :] <= self.hi) & (self.lo <= (c + h)[:, None, :])
        over = over.all(axis=2)
        if not over.any():
            return True
        self.narrow += 1
        for k, (name, Tb) in enumerate(self.carried):
            near = [self.obstacles[i] for i in np.flatnonzero(over[k])]
            if near and self.scene.hits(name, T @ Tb, near):
                return False
        return True


class _Interpolator:
    """Pose at fraction ``s`` between two poses: position lerp, rotation about the fixed
    relative axis (= slerp), without per-call quaternion conversions."""

    def __init__(self, T0: np.ndarray, T1: np.ndarray) -> None:
        self.T0 = T0
        self.dp = T1[:3, 3] - T0[:3, 3]
        Rrel = T0[:3, :3].T @ T1[:3, :3]
        self.angle = float(rotation_angle_rad(Rrel))
        if self.angle > 1e-12:
            if self.angle < math.pi - 1e-6:
                w = np.array([Rrel[2, 1] - Rrel[1, 2], Rrel[0, 2] - Rrel[2, 0],
                              Rrel[1, 0] - Rrel[0, 1]]) / (2.0 * math.sin(self.angle))
            else:  # near pi: axis from the symmetric part
                B = (Rrel + np.eye(3)) / 2.0
                w = B[:, int(np.argmax(np.diag(B)))]
            w = w / np.linalg.norm(w)
            self.K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
            self.K2 = self.K @ self.K

    def __call__(self, s: float) -> np.ndarray:
        T = self.T0.copy()
        T[:3, 3] += s * self.dp
        if self.angle > 1e-12:
            th = s * self.angle
            T[:3, :3] = self.T0[:3, :3] @ (np.eye(3) + math.sin(th) * self.K
                                           + (1.0 - math.cos(th)) * self.K2)
        return T


@dataclass(frozen=True, eq=False)
class PathCheck:
    """Result of certifying a path: ``ok``, the poses checked, and on failure the first
    colliding TCP pose with its pairs and the leg index."""

    ok: bool
    checked: int
    T_world_gripper: np.ndarray | None = None
    pairs: tuple[CollidingPair, ...] = ()
    leg: int = -1


def certify_path(scene: Scene, poses: np.ndarray, carried: Sequence[tuple[str, np.ndarray]],
                 obstacles: Sequence[str], radius_m: float, fine_step_m: float) -> PathCheck:
    """Prove a polyline of TCP poses (N, 4, 4) free of collision for the carried bodies.

    ``carried`` lists (body name, ``T_tcp_body``). Conservative advancement: at each checked
    pose a lower bound ``d`` of the distance to every obstacle (box gaps, exact FCL distance
    where boxes are close) lets the bodies move ``d`` (point travel ``|dp| + r dtheta``)
    without another check; where ``d < fine_step_m`` the pose is checked for collision and the
    next one is ``fine_step_m`` further.
    """
    checked = 0
    for leg, (T0, T1) in enumerate(itertools.pairwise(poses)):
        dp = T1[:3, 3] - T0[:3, 3]
        dth = float(rotation_angle_rad(T0[:3, :3].T @ T1[:3, :3]))
        travel = float(np.linalg.norm(dp)) + radius_m * dth
        if travel <= 0:
            continue
        interp = _Interpolator(T0, T1)
        s = 0.0
        while True:
            T = interp(min(s, 1.0))
            bodies = [(n, T @ Tb) for n, Tb in carried]
            checked += 1
            remaining = (1.0 - s) * travel
            d = scene.distance_bound(bodies, obstacles, enough=min(remaining, 0.05) + fine_step_m)
            if d <= fine_step_m:
                if scene.collides(bodies, obstacles):
                    return PathCheck(False, checked, T,
                                     tuple(scene.contacts_at(bodies, obstacles)), leg)
                step = fine_step_m
            else:
                step = d
            if step >= remaining:
                break
            s += step / travel
        # the leg's end pose is the next leg's start (or checked below for the last leg)
    T = poses[-1]
    bodies = [(n, T @ Tb) for n, Tb in carried]
    checked += 1
    if scene.collides(bodies, obstacles):
        return PathCheck(False, checked, T, tuple(scene.contacts_at(bodies, obstacles)),
                         len(poses) - 2)
    return PathCheck(True, checked)


# ---------------------------------------------------------------------------------------------
# Per-step planning
# ---------------------------------------------------------------------------------------------
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
    parts : dict of PartData, optional
        Precomputed part geometry (default: from :class:`asmplan.parts.models.ProductGeometry`).
    direct_insertion : bool
        Benchmark baseline: plan with OMPL straight into the seated pose (no pre-insertion
        pose and no straight insertion); never used for real plans.
    """

    def __init__(self, product: Product, settings: PlannerSettings,
                 parts: dict[str, PartData] | None = None, *, direct_insertion: bool = False,
                 ) -> None:
        self.product = product
        self.settings = settings
        self.parts = parts if parts is not None else part_data(product, settings)
        self.direct_insertion = direct_insertion
        self.start_poses, self.start_notes = initial_layout(product, self.parts)
        initial = {n: (product.T_world_assembled(n) if product.is_fixtured(n)
                       else self.start_poses[n]) for n in product.part_names}
        self.scene = Scene(product, self.parts, initial, settings.contact_tolerance_m)
        self.placed: list[str] = [n for n in product.part_names if product.is_fixtured(n)]
        self._check_layout()

    def place(self, part: str) -> None:
        """Record ``part`` as assembled (used to set up a partial assembly, e.g. by the
        benchmark); planning a step does this itself."""
        if part not in self.placed:
            self.placed.append(part)
        self.scene.set_part_pose(part, self.product.T_world_assembled(part))

    def _check_layout(self) -> None:
        names = [TABLE, *self.product.part_names]
        contacts = self.scene.world.contacts(names, names, self.settings.contact_tolerance_m)
        if contacts:
            raise StartInCollisionError(_pairs(contacts), where="initial layout (fixtured parts "
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
    def plan_step(self, index: int, part: str, fallback_direction: np.ndarray | None = None,
                  grasp: Grasp | None = None) -> tuple[Step, StepTiming]:
        """Plan the step that inserts ``part`` into the current partial assembly; on success
        the part is recorded as placed. ``grasp`` restricts the search to that grasp (the
        benchmark's baseline uses the grasp of the real plan)."""
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
        data = self.parts[part]
        clamp = clamp_force(product, part, data.mass_kg, step=index)
        spec = insertion_spec(product, part, self.placed, fallback_direction, index, self.parts)
        T_start = self.start_poses[part]
        T_final = product.T_world_assembled(part)
        approach = product.process.approach_distance_m
        obstacles = scene.obstacles(part)
        pre_dist = clear_standoff_m(scene, part, T_final, spec.direction, obstacles,
                                    spec.length_m + approach,
                                    clearance_m=product.process.position_tolerance_m)
        T_pre = _translate(T_final, -spec.direction * pre_dist)

        # 1. the part alone along its insertion (independent of the grasp)
        sampled = 0.0 if self.direct_insertion else self._check_insertion(
            index, part, spec, T_pre, T_final, obstacles)

        # 2. grasps, best first: free at the start and final poses, then the full motion
        t_g = time.perf_counter()
        down_s = T_start[:3, :3].T @ -_Z
        down_f = T_final[:3, :3].T @ -_Z
        # fingers should stay behind the mating face: the pin roots of a pin part, the
        # leading face of a hole part (or of a part placed without a mate)
        ins_part = T_final[:3, :3].T @ spec.direction
        lead = float(((data.points_m - data.com_m) @ ins_part).max())
        if spec.kind == "insert" and any(r.pin_part == part for r in spec.regions):
            lead -= spec.length_m
        gripper = product.gripper_for(part)
        candidates = iter_grasps(part, data.surface, gripper,
                                 product.part(part).handling.grasp,
                                 part_friction=product.part(part).friction,
                                 finger_clearance_m=settings.finger_clearance_m,
                                 down_start_part=down_s, down_final_part=down_f,
                                 insertion_part=ins_part,
                                 lead_limit_m=lead - product.process.position_tolerance_m,
                                 load=GripLoad(data.mass_kg, clamp.acceleration_m_s2,
                                               clamp.limit_N, product.process.safety_factor))
        if grasp is not None:
            candidates = iter([grasp])
        rejected = Rejections()
        failures: list[_GraspFailed] = []
        ompl_s = check_s = grasp_s = 0.0
        free = collision_free(
            candidates, lambda g: self._grasp_collisions(g, part, T_start, T_final, obstacles),
            rejected, settings.max_grasp_candidates)
        for g in free:
            grasp_s += time.perf_counter() - t_g
            try:
                step, o_s, c_s, checked = self._plan_with_grasp(
                    index, part, g, spec, clamp, T_start, T_pre, T_final, obstacles,
                    len(failures), sampled)
            except _GraspFailed as f:
                failures.append(f)
                if len(failures) >= settings.max_grasps:
                    break
                t_g = time.perf_counter()
                continue
            ompl_s += o_s
            check_s += c_s
            self.placed.append(part)
            scene.set_part_pose(part, T_final)
            timing = StepTiming(part, time.perf_counter() - t_start, grasp_s, ompl_s, check_s,
                                len(failures) + 1, checked, time.process_time() - c_start)
            return step, timing
        scene.set_part_pose(part, T_start)
        first_path = next((f.error for f in failures if isinstance(f.error, NoPathError)), None)
        if first_path is not None:
            raise first_path
        reasons = [f"grasp {k + 1}: {f.reason}" for k, f in enumerate(failures)]
        reasons += rejected.reasons()
        if rejected.examined == 0:
            reasons.append("no antipodal finger placement within the gripper's stroke and the "
                           "friction cone")
        raise NoGraspError(part, reasons, index)

    def _grasp_collisions(self, g: Grasp, part: str, T_start: np.ndarray, T_final: np.ndarray,
                          obstacles: list[str]) -> tuple[str, list[CollidingPair]]:
        """Fingers (the space they sweep while closing) at the start and assembled poses, and
        the open gripper against the part itself. The fingers must also keep the process's
        position tolerance from every obstacle at both poses (a real gripper is only placed
        that accurately)."""
        scene = self.scene
        scene.use_gripper(g, self.product.gripper_for(part))
        margin = self.product.process.position_tolerance_m
        span = scene.piece_boxes(scene.world.model(GRIPPER_SPAN)).reshape(-1, 3)
        for where, T_part in (("start pose", T_start), ("assembled pose", T_final)):
            T = T_part @ g.T_part_gripper
            # the gripper is made of boxes: its lowest point is exact without FCL
            if float((span @ T[2, :3] + T[2, 3]).min()) < margin:
                return where, [CollidingPair(GRIPPER_SPAN, TABLE)]
            hit = scene.hits(GRIPPER_SPAN, T, obstacles)
            if hit:
                return where, [CollidingPair(GRIPPER_SPAN, o) for o in hit]
            d, who = scene.closest([(GRIPPER_SPAN, T)], obstacles, margin)
            if d < margin:
                return (f"{where} (closer than the position tolerance "
                        f"{margin * 1e3:.2f} mm)", [CollidingPair(GRIPPER_SPAN, who, None)])
        scene.set_part_pose(part, T_start)
        if scene.hits(GRIPPER_OPEN, T_start @ g.T_part_gripper, [part]):
            return "grasp (open fingers on the part)", [CollidingPair(GRIPPER_OPEN, part)]
        return "", []

    def _check_insertion(self, index: int, part: str, spec: InsertionSpec, T_pre: np.ndarray,
                         T_final: np.ndarray, obstacles: list[str]) -> float:
        """The part alone along its straight insertion: the seated and pre-insertion poses,
        then the exact sweep between them. Returns the sampling step used to excuse contact
        with a mate partner (0 when the sweep met nothing)."""
        scene = self.scene
        pairs = scene.contacts_at([(part, T_final)], obstacles)
        bad = self._unexcused(pairs, spec, part, T_final)
        dist = float(np.linalg.norm(T_final[:3, 3] - T_pre[:3, 3]))
        if bad:
            raise InsertionBlockedError(index, part, _other(bad[0], part), T_final, bad, 0.0,
                                        segment="assembled pose")
        pairs = scene.contacts_at([(part, T_pre)], obstacles)
        if pairs:
            raise InsertionBlockedError(index, part, _other(pairs[0], part), T_pre, pairs, dist,
                                        segment="pre-insertion pose")
        delta = T_final[:3, 3] - T_pre[:3, 3]
        hits = scene.sweep([(part, T_pre)], delta, obstacles).get(part, set())
        if not hits:
            return 0.0
        partners = {r.hole_part if r.pin_part == part else r.pin_part for r in spec.regions}
        strangers = sorted(hits - partners)
        # locate the first blocking sample for evidence (and excuse pin-in-hole contact)
        step = self._insertion_step(spec)
        n = max(1, math.ceil(dist / step))
        check = sorted(hits)
        for i in range(n + 1):
            T = _translate(T_pre, delta * (i / n))
            pairs = scene.contacts_at([(part, T)], check)
            bad = self._unexcused(pairs, spec, part, T)
            if bad:
                raise InsertionBlockedError(index, part, _other(bad[0], part), T, bad,
                                            dist * (1 - i / n))
        if strangers:  # the sweep hit something the samples did not: report it anyway
            raise InsertionBlockedError(index, part, strangers[0], T_pre, [], dist,
                                        segment="insertion (swept volume)")
        return step

    def _insertion_step(self, spec: InsertionSpec) -> float:
        s = self.settings
        c = spec.radial_clearance_min_m
        return max(s.min_insertion_step_m, min(s.insertion_step_m, 4.0 * c))

    def _unexcused(self, pairs: Sequence[CollidingPair], spec: InsertionSpec, part: str,
                   T_part: np.ndarray) -> list[CollidingPair]:
        return unexcused(pairs, spec, part, T_part, self.scene.poses)

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
        R_s, R_f = self.start_poses[part][:3, :3], product.T_world_assembled(part)[:3, :3]
        gravity_lever = max(float(np.linalg.norm((R @ perp)[:2])) for R in (R_s, R_f))
        try:
            clamp = clamp_force(product, part, clamp.mass_kg, step=index, lever_m=lever,
                                gravity_lever_m=gravity_lever)
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
        G_pregrasp = _translate(G_grasp, -G_grasp[:3, 2] * standoff)
        G_retreat = _translate(G_final, -G_final[:3, 2] * standoff)
        lift = product.process.lift_height_m
        G_lift = _translate(G_grasp, _Z * lift)
        carried = [(part, T_pg), (GRIPPER_CLOSED, np.eye(4))]
        radius = self._radius(part, T_pg, g)

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
        if not self.direct_insertion:
            cert = straight([(GRIPPER_CLOSED, np.eye(4))], G_pre, G_final, obstacles)
            checked += cert.checked
            if not cert.ok:
                raise _GraspFailed(f"insertion: the gripper hits {_names(cert.pairs)}")
        check_s = time.perf_counter() - t0

        # the planned path: lifted -> pre-insertion (or straight to the seated pose)
        goal = G_final if self.direct_insertion else G_pre
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
        for attempt in range(settings.replan_attempts + 1):
            res = plan_se3(valid, G_lift, goal, bounds, planner=settings.planner,
                           time_budget_s=settings.time_budget_s,
                           seed=settings.seed + 1009 * index + 101 * grasp_rank + attempt,
                           resolution_m=resolution, try_direct=direct)
            ompl_s += res.planning_time_s
            if not res.solved:
                last_reason = (f"{settings.planner} found no path from the lifted pose to the "
                               f"{'seated' if self.direct_insertion else 'pre-insertion'} pose "
                               f"in {settings.time_budget_s:g} s ({res.status})")
                partial = res.poses
                break
            t1 = time.perf_counter()
            cert = certify_path(scene, res.poses, carried, obstacles, radius,
                                settings.recheck_step_m)
            check_s += time.perf_counter() - t1
            checked += cert.checked
            if cert.ok:
                path = res.poses
                break
            last_reason = (f"the path collides between OMPL's checks (leg {cert.leg}) at "
                           f"resolution {resolution * 1e3:.2f} mm")
            partial = res.poses[: cert.leg + 1]
            pairs_seen = list(cert.pairs)
            resolution /= 2
            direct = direct and len(res.poses) > 2  # the straight motion is known to collide
        scene.set_part_pose(part, T_start)
        if path is None:
            err = NoPathError(index, part, partial, last_reason, pairs_seen)
            raise _GraspFailed(last_reason, err)

        limits = motion_limits(product, part)
        if self.direct_insertion:
            lower = (Move(np.array([G_final, G_final]), limits.insertion_speed_m_s),)
        else:
            G_engage = _translate(G_final, -spec.direction * (spec.length_m + _ENGAGE_MARGIN_M))
            if spec.kind == "place":
                G_engage = _translate(G_final, -spec.direction * min(2e-3, float(
                    np.linalg.norm(G_pre[:3, 3] - G_final[:3, 3]))))
            lower = (Move(np.array([G_pre, G_engage]), limits.max_speed_m_s),
                     Move(np.array([G_engage, G_final]), limits.insertion_speed_m_s))
        motion = StepMotion(approach=np.array([G_pregrasp, G_grasp]),
                            lift=np.array([G_grasp, G_lift]), translate=path, lower=lower,
                            retreat=np.array([G_final, G_retreat]))
        traj = time_step(motion, limits, clamp.commanded_N, radius, settings.timing)
        notes = []
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
                    checked_poses=checked, notes=tuple(notes))
        return step, ompl_s, check_s, checked

    def _radius(self, part: str, T_pg: np.ndarray, g: Grasp) -> float:
        return carried_radius(self.product.gripper_for(part), self.parts[part], T_pg, g)


def unexcused(pairs: Sequence[CollidingPair], spec: InsertionSpec, part: str,
              T_part: np.ndarray, poses: dict[str, np.ndarray]) -> list[CollidingPair]:
    """The contacts of moving ``part`` (at ``T_part``) that are not excused: a contact with a
    mate partner is excused only inside the mated hole's region and only when the mate's
    clearance is >= 0. ``poses`` gives the other parts' poses."""
    out = []
    for p in pairs:
        other = _other(p, part)
        excused = False
        for r in spec.regions:
            if {r.pin_part, r.hole_part} != {part, other} or r.clearance_min_m < 0:
                continue
            T_hole = T_part if r.hole_part == part else poses[r.hole_part]
            if p.point_m is not None and r.contains(np.asarray(p.point_m), T_hole):
                excused = True
                break
        if not excused:
            out.append(p)
    return out


def carried_radius(gripper: Gripper, data: PartData, T_pg: np.ndarray, g: Grasp) -> float:
    """Radius (m) about the TCP of the gripper (open) and the held part: bounds the travel of
    any of their points under a rotation (``r dtheta``)."""
    pts = data.points_m @ T_pg[:3, :3].T + T_pg[:3, 3]
    W, t, L = (float(v) for v in gripper.finger_size_m)
    px, py, pz = (float(v) for v in gripper.palm_size_m)
    corner = max(math.hypot(math.hypot(W / 2, g.open_width_m / 2 + t), L / 2),
                 math.hypot(math.hypot(px / 2, py / 2), L / 2 + pz))
    return max(float(np.linalg.norm(pts, axis=1).max()), corner)


def _names(pairs: Sequence[CollidingPair]) -> str:
    return "; ".join(str(p) for p in pairs[:3]) or "(no contact detail)"


def _other(p: CollidingPair, name: str) -> str:
    return p.b if p.a == name else p.a


def _take(it: Any, n: int) -> list[Grasp]:
    out = []
    for g in it:
        out.append(g)
        if len(out) >= n:
            break
    return out


# ---------------------------------------------------------------------------------------------
# Start poses
# ---------------------------------------------------------------------------------------------
def initial_layout(product: Product, parts: dict[str, PartData]
                   ) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Start pose of every part and a note on where it came from.

    A part without a start pose (NaN in the model) that is not fixtured is put on the table
    in its assembled orientation, lowest point on the table top, on a row beside the product
    (towards -y), left to right in part order, 20 mm apart and clear of every other start
    pose's footprint. Deterministic.

    A given start pose whose part reaches below the table top (a tray is not modelled; e.g.
    pins standing in a tray's pockets) is raised along world z until its lowest point rests on
    the table, and the note says by how much. Any other overlap is left for the layout check
    (:class:`StartInCollisionError`).
    """
    poses: dict[str, np.ndarray] = {}
    notes: dict[str, str] = {}
    boxes: list[np.ndarray] = []

    def footprint(name: str, T: np.ndarray) -> np.ndarray:
        pts = parts[name].points_m @ T[:3, :3].T + T[:3, 3]
        return np.stack([pts.min(axis=0), pts.max(axis=0)])

    for p in product.parts:
        if product.is_fixtured(p.name):
            poses[p.name] = product.T_world_assembled(p.name)
            notes[p.name] = "fixtured in its assembled pose"
            boxes.append(footprint(p.name, poses[p.name]))
        elif np.all(np.isfinite(p.T_world_start)):
            T = np.array(p.T_world_start, float)
            notes[p.name] = f"given: {p.start_location}"
            below = -float(footprint(p.name, T)[0, 2])
            if below > 1e-6:
                T[2, 3] += below
                notes[p.name] += (f"; raised by {below * 1e3:.2f} mm: the given pose reaches "
                                  "below the table top")
            poses[p.name] = T
            boxes.append(footprint(p.name, T))
    size = np.asarray(product.resources.table.size_m, float)
    gap = 0.02
    for p in product.parts:
        if p.name in poses:
            continue
        T = product.T_world_assembled(p.name)
        fp = footprint(p.name, T)
        ext = fp[1] - fp[0]
        y_lo = min(b[0, 1] for b in boxes) if boxes else 0.0
        y = y_lo - gap - ext[1] / 2
        x = -size[0] / 2 + gap + ext[0] / 2
        while True:
            cand = np.stack([[x - ext[0] / 2, y - ext[1] / 2], [x + ext[0] / 2, y + ext[1] / 2]])
            if not any(np.all(cand[0] < b[1, :2] + gap) and np.all(b[0, :2] - gap < cand[1])
                       for b in boxes):
                break
            x += ext[0] + gap
            if x + ext[0] / 2 > size[0] / 2:
                x = -size[0] / 2 + gap + ext[0] / 2
                y -= ext[1] + gap
        Tn = T.copy()
        centre = 0.5 * (fp[0] + fp[1])
        Tn[:3, 3] += np.array([x - centre[0], y - centre[1], -fp[0, 2]])
        poses[p.name] = Tn
        boxes.append(footprint(p.name, Tn))
        notes[p.name] = (f"no start pose given: placed on the table at ({x * 1e3:.0f}, "
                         f"{y * 1e3:.0f}) mm in its assembled orientation, lowest point on the "
                         "table top")
    return poses, notes


# ---------------------------------------------------------------------------------------------
# Whole product
# ---------------------------------------------------------------------------------------------
ProgressFn = Callable[[int, int, str, str], None]
StepFn = Callable[[tuple[str, ...], Step, dict[str, np.ndarray]], None]


@dataclass(frozen=True, eq=False)
class SequenceChoice:
    """A part order to plan, where it came from, and the insertion direction (3,) the
    sequence planner chose per part (used for parts without a mate to the partial assembly).
    """

    order: tuple[str, ...]
    note: str = ""
    insertions: dict[str, np.ndarray] = field(default_factory=dict)


def ranked_sequences(product: Product, sequence_plan: Any | None = None) -> list[SequenceChoice]:
    """The sequence planner's ranked orders, best first (from ``sequence_plan`` when given,
    a :class:`~asmplan.planner.sequence.SequencePlan`, else planned now)."""
    from .sequence import plan_sequence

    sp = sequence_plan if sequence_plan is not None else plan_sequence(product)
    return [SequenceChoice(tuple(r.order),
                           f"sequence planner: rank {r.rank} of {len(sp.sequences)} "
                           f"({sp.method}), cost {r.cost_s:.2f} s",
                           {s.part: np.asarray(s.insertion, float) for s in r.steps})
            for r in sp.sequences]


def best_sequence(product: Product) -> tuple[list[str], str, dict[str, np.ndarray]]:
    """The sequence planner's best order, a note on it, and its insertion directions."""
    best = ranked_sequences(product)[0]
    return list(best.order), best.note, dict(best.insertions)


def plan_product(product: Product, settings: PlannerSettings | None = None, *,
                 sequence: Sequence[str] | None = None, sequence_note: str = "",
                 insertions: dict[str, np.ndarray] | None = None,
                 sequences: Sequence[SequenceChoice] | None = None,
                 parts: dict[str, PartData] | None = None, progress: ProgressFn | None = None,
                 direct_insertion: bool = False,
                 on_step: StepFn | None = None) -> PlanResult:
    """Plan every step of ``product``.

    The order is ``sequence`` when given; otherwise the ranked ``sequences`` (default: the
    sequence planner's, :func:`ranked_sequences`) are tried best first and the first that
    can be planned is used (the sequence planner does not know the gripper: a part may be
    reachable only before another one closes the space around it).

    Parameters
    ----------
    product : Product
    settings : PlannerSettings, optional
    sequence : sequence of str, optional
        Part order; fixtured parts may appear anywhere (they are in place from the start).
    sequence_note : str
        Where ``sequence`` came from (stored in the plan).
    insertions : dict, optional
        Insertion direction (3,) per part, for parts without a mate to the partial assembly.
    sequences : sequence of SequenceChoice, optional
        Ranked orders to try when ``sequence`` is not given.
    parts : dict of PartData, optional
        Part geometry (default: computed from :class:`asmplan.parts.models.ProductGeometry`).
    progress : callable, optional
        ``progress(step_index, n_steps, part, status)`` with status "start" or "done".
    direct_insertion : bool
        Benchmark baseline only (see :class:`MotionPlanner`).
    on_step : callable, optional
        ``on_step(order, step, start_poses)`` after each step is planned: the order being
        tried (tuple of part names), the new :class:`Step`, and the start pose (4, 4) of every
        part. Lets a caller start simulating a step while later ones are planned; when an
        order fails and the next is tried, the steps already reported for it are void.

    Raises
    ------
    PlanningError
        A typed failure with evidence (see :mod:`asmplan.planner.errors`). When several ranked
        orders were tried, the best-ranked one's failure is raised and ``alternatives`` lists
        the others' failures.
    """
    settings = settings or PlannerSettings()
    t0 = time.perf_counter()
    if parts is None:
        parts = part_data(product, settings)
    geometry_s = time.perf_counter() - t0
    if sequence is not None:
        choices = [SequenceChoice(tuple(sequence), sequence_note, dict(insertions or {}))]
    else:
        choices = list(sequences) if sequences is not None else ranked_sequences(product)
    failures: list[tuple[SequenceChoice, PlanningError]] = []
    for choice in choices:
        try:
            plan, times = _plan_order(product, settings, choice, parts, progress,
                                      direct_insertion, len(failures), on_step)
        except PlanningError as exc:
            failures.append((choice, exc))
            continue
        return PlanResult(plan, times, time.perf_counter() - t0, geometry_s)
    if not failures:
        raise ValueError("sequences: expected at least one order to plan, found none")
    first = failures[0][1]
    first.alternatives = [{"order": list(c.order), "note": c.note, "failure": str(e)}
                          for c, e in failures[1:]]
    raise first


def _plan_order(product: Product, settings: PlannerSettings, choice: SequenceChoice,
                parts: dict[str, PartData], progress: ProgressFn | None,
                direct_insertion: bool, failed_before: int,
                on_step: StepFn | None = None) -> tuple[Plan, tuple[StepTiming, ...]]:
    sequence = list(choice.order)
    if sorted(sequence) != sorted(product.part_names):
        raise ValueError(f"sequence: expected every part once ({', '.join(product.part_names)}), "
                         f"found {sequence}")
    planner = MotionPlanner(product, settings, parts, direct_insertion=direct_insertion)
    steps: list[Step] = []
    times: list[StepTiming] = []
    for k, name in enumerate(sequence):
        if progress is not None:
            progress(k, len(sequence), name, "start")
        step, timing = planner.plan_step(k, name, choice.insertions.get(name))
        steps.append(step)
        times.append(timing)
        if on_step is not None:
            on_step(tuple(sequence), step, planner.start_poses)
        if progress is not None:
            progress(k, len(sequence), name, "done")
    note = choice.note
    if failed_before:
        note += (f"; {failed_before} better-ranked order{'s' if failed_before > 1 else ''} "
                 "could not be planned")
    plan = Plan(product=product.name, source=str(product.source),
                source_sha256=_sha256(product.source), sequence=tuple(sequence),
                steps=tuple(steps), settings=settings, sequence_note=note)
    return plan, tuple(times)


def _sha256(path: Path) -> str:
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return ""


# ---------------------------------------------------------------------------------------------
# Independent dense re-check of a finished plan
# ---------------------------------------------------------------------------------------------
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


def dense_recheck(plan: Plan, product: Product, parts: dict[str, PartData] | None = None,
                  step_m: float = 1e-4) -> RecheckReport:
    """Re-check every trajectory of ``plan`` at uniform samples, independently of the planner.

    The trajectory is resampled so that no point of the gripper or the held part moves more
    than ``step_m`` between two checked poses; at each pose the part (in held phases) and the
    gripper (closed while held, open otherwise) are checked with FCL against the table and
    every other part at its pose at that moment. Contacts of the part with a mate partner
    inside the mated hole (positive clearance) are excused and counted.
    """
    settings = plan.settings
    parts = parts if parts is not None else part_data(product, settings)
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
                    pairs.extend(_pairs(scene.world.contacts([b], obstacles + extra,
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
