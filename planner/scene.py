"""The planning scene: an FCL world of the table, every part (planning level and coarse model) and
the gripper variants, with tiered checks (boxes, coarse, planning level), exact sweeps of
translations and the broad-phase validity OMPL calls.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..knowledge.model import Gripper, Product
from ..parts.cell import (
    gripper_model,
    regrasp_fixture_body,
    regrasp_fixture_model,
    table_model,
)
from ..parts.collision import CollisionWorld, Contact, FclShapes
from ..parts.collision_geometry import circumscribed_prism_points
from ..parts.pieces import CollisionModel, ConvexPiece
from .errors import (
    CollidingPair,
)
from .partdata import PartData
from .plan import Grasp

TABLE = "table"
GRIPPER_CLOSED = "gripper"
GRIPPER_OPEN = "gripper(open)"
GRIPPER_SPAN = "gripper(closing)"

def translated(T: np.ndarray, d: np.ndarray) -> np.ndarray:
    out = np.array(T, dtype=float)
    out[:3, 3] += d
    return out


def colliding_pairs(contacts: Sequence[Contact]) -> list[CollidingPair]:
    return [CollidingPair(c.a, c.b, float(c.depth_m), np.asarray(c.point_m)) for c in contacts]



_CORNER_SIGNS = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])


_SWEEP = "~sweep"
_MESH_SWEEP_STEP_M = 1e-4  # BVH parts are stepped at this spacing instead of swept


def piece_boxes(model: CollisionModel) -> np.ndarray:
    """Corners (P, 8, 3) of every piece's bounding box in the model's frame."""
    out = []
    signs = 2.0 * _CORNER_SIGNS - 1.0
    for pc in model.pieces:
        if pc.kind == "box":
            local = signs * np.asarray(pc.half_extents_m)
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
            local = (2.0 * _CORNER_SIGNS - 1.0) * np.asarray(pc.half_extents_m)
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
        self.cell: list[str] = [TABLE]  # the static bodies of the cell: table, regrasp fixtures
        for fx in product.resources.regrasp:
            self._add(regrasp_fixture_body(fx.name), regrasp_fixture_model(fx),
                      np.asarray(fx.T_world_fixture, float))
            self.cell.append(regrasp_fixture_body(fx.name))
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

    def add_body(self, name: str, model: CollisionModel, T: np.ndarray) -> None:
        """Add (or replace) a body of the cell, e.g. an arm link (:mod:`asmplan.planner.arm`)."""
        self._add(name, model, T)

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
        """Everything but the moving part and the gripper bodies (the table, the regrasp
        fixtures and the other parts)."""
        return [*self.cell, *[n for n in self.product.part_names if n != moving]]

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
                out.extend(colliding_pairs(self.world.contacts([name], hit, self.tolerance_m)))
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
                # always against the obstacles' planning-level models (a body without a
                # coarse model, the gripper, met only their coarse hulls so far)
                hit = set(self._swept_hits(name, T, delta, coarse))
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
                Tk = translated(T, delta * (k / n))
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

