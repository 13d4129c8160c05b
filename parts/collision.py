"""FCL collision world: the ONLY module of asmplan that imports ``fcl``.

:class:`CollisionWorld` holds named objects, each a part's
:class:`~asmplan.parts.pieces.CollisionModel` at a pose ``T_world_part``. A name may stand for
many FCL objects (one per convex piece, plus one BVH for a mesh); queries always speak of
names. Exact primitives are used wherever the model has them (``fcl.Box``, ``fcl.Cylinder``,
``fcl.Sphere``), ``fcl.Convex`` for hull pieces and ``fcl.BVHModel`` (OBBRSS) for meshes.

Speed: FCL geometries (BVH trees above all) are built once per model and shared through an
:class:`FclShapes` cache; a pose update builds one ``fcl.Transform`` per piece that is not at
the part origin; candidate pairs are filtered by world AABBs (vectorised numpy, one array per
name) before any narrow-phase call. That numpy filter is the broad phase: python-fcl's
managers call back into Python for every candidate pair anyway and cannot tell two objects of
the same name apart, so they would not save anything here.

Units: FCL's libccd GJK/EPA solver works with fixed absolute tolerances of 1e-6 model units.
In metres that is 1 um, the size of the clearances asmplan must resolve: collisions of 0.4 um
were missed and GJK distances to hull pieces were off by up to 8 um in our measurements. The
world therefore hands FCL millimetres (every length times ``FCL_SCALE`` = 1000) and converts
results back to metres; both errors then drop to about 1 nm. The API is SI throughout.

Touching is not colliding: a contact whose penetration depth is at most ``tolerance_m``
(1 um by default) is ignored, so parts resting on each other or a pin in a hole with zero
clearance are free. Collision requests use FCL's libccd GJK (``GST_LIBCCD``); the ``GST_INDEP``
solver missed 25 um penetrations in our measurements.

Limitations (measured with python-fcl 0.7.0.11):

* ``fcl.continuousCollide`` segfaults for a box against a BVH, so :meth:`sweep_blockers`
  builds the exact swept volume of each convex piece under a translation instead (the convex
  hull of the piece and its translate; a longer cylinder/box when moving along its axis; a
  capsule for a sphere) and steps BVH meshes along the motion at ``step_m``.
* A BVH is a surface: a piece entirely inside a mesh without touching its surface is not a
  contact. :meth:`contacts` therefore also tests containment (one vertex inside the other
  solid) for pairs whose boxes overlap but whose surfaces do not meet.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import fcl
import numpy as np
from numpy.typing import ArrayLike

from ..knowledge.frames import rotation_between
from .collision_geometry import (
    BOX_SIGNS,
    Contact,
    along_local_axis,
    piece_local_extent,
    piece_points_world,
    swept_aabb,
)
from .mesh import hull_faces
from .pieces import CollisionModel, ConvexPiece

FCL_SCALE = 1000.0  # FCL sees millimetres (see the module docstring)
_K = FCL_SCALE
_REQ_BOOL = fcl.CollisionRequest(num_max_contacts=1, enable_contact=False)
_REQ_DEPTH = fcl.CollisionRequest(num_max_contacts=100_000, enable_contact=True)
_REQ_DIST = fcl.DistanceRequest(enable_nearest_points=False)


@dataclass(frozen=True, eq=False)
class _Geom:
    geometry: object  # an fcl.CollisionGeometry
    piece: ConvexPiece | None  # None for the BVH mesh
    T_part_geom: np.ndarray  # (4, 4)
    corners_part: np.ndarray  # (8, 3) corners of the geometry's bounding box, part frame
    identity: bool
    hull_faces: np.ndarray | None = None  # (m, 3) for hull pieces


def _convex(vertices: np.ndarray, faces: np.ndarray | None = None):
    """An fcl.Convex of ``vertices`` (n, 3) given in metres."""
    v = np.ascontiguousarray(vertices, dtype=float) * _K
    f = hull_faces(v) if faces is None else faces
    flat = np.hstack([np.full((len(f), 1), 3, dtype=np.int64), f]).ravel()
    return fcl.Convex(v, len(f), flat)


def _tf(T: np.ndarray):
    """fcl.Transform of a (4, 4) pose in metres (FCL gets millimetres)."""
    return fcl.Transform(np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3]) * _K)


class FclShapes:
    """Cache of FCL geometries per :class:`CollisionModel` (a BVH is built once).

    Keyed by the model object; share one cache between worlds that use the same models.
    """

    def __init__(self) -> None:
        self._cache: dict[int, tuple[CollisionModel, tuple[_Geom, ...]]] = {}

    def geoms(self, model: CollisionModel) -> tuple[_Geom, ...]:
        hit = self._cache.get(id(model))
        if hit is not None and hit[0] is model:
            return hit[1]
        out: list[_Geom] = []
        for pc in model.pieces:
            faces = None
            if pc.kind == "box":
                g = fcl.Box(*(2.0 * _K * np.asarray(pc.half_extents_m)))
            elif pc.kind == "cylinder":
                g = fcl.Cylinder(_K * pc.radius_m, _K * pc.length_m)
            elif pc.kind == "sphere":
                g = fcl.Sphere(_K * pc.radius_m)
            else:
                vertices = np.asarray(pc.vertices_m)
                faces = hull_faces(vertices)
                g = _convex(vertices, faces)
            T = np.array(pc.T_part_piece)
            corners = piece_local_extent(pc) @ T[:3, :3].T + T[:3, 3]
            out.append(_Geom(g, pc, T, corners, bool(np.allclose(T, np.eye(4), atol=0, rtol=0)), faces))
        if model.mesh_vertices_m is not None and model.mesh_faces is not None:
            V = np.ascontiguousarray(model.mesh_vertices_m, dtype=float)
            bvh = _bvh(V, model.mesh_faces)
            lo, hi = V.min(axis=0), V.max(axis=0)
            out.append(_Geom(bvh, None, np.eye(4), 0.5 * (lo + hi) + BOX_SIGNS * 0.5 * (hi - lo), True))
        geoms = tuple(out)
        self._cache[id(model)] = (model, geoms)
        return geoms


class _Entry:
    """One name: its FCL objects, pose and world AABBs. FCL transforms are set lazily, only
    for pieces that survive the AABB filter of a query (a pose update is then ~10 us)."""

    __slots__ = ("T", "aabb", "bbox", "corners", "fresh", "geoms", "model", "name", "objects", "tf_part")

    def __init__(self, name: str, model: CollisionModel, geoms: tuple[_Geom, ...], T: np.ndarray,
                 bbox: np.ndarray | None = None):
        self.name = name
        self.model = model
        self.geoms = geoms
        self.corners = np.stack([g.corners_part for g in geoms])  # (P, 8, 3)
        self.objects = [fcl.CollisionObject(g.geometry, fcl.Transform()) for g in geoms]
        self.T = np.eye(4)
        self.aabb = np.zeros((len(geoms), 2, 3))
        self.bbox = np.zeros((2, 3)) if bbox is None else bbox  # a view into the world's boxes
        self.fresh = [False] * len(geoms)
        self.tf_part = None
        self.set_pose(T)

    def set_pose(self, T: np.ndarray) -> None:
        T = np.array(T, dtype=float)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise ValueError(f'pose of "{self.name}": expected a finite (4, 4) transform, found '
                             f"shape {T.shape}")
        self.T = T
        self.fresh = [False] * len(self.geoms)
        self.tf_part = None
        w = self.corners @ T[:3, :3].T + T[:3, 3]
        self.aabb[:, 0] = w.min(axis=1)
        self.aabb[:, 1] = w.max(axis=1)
        self.bbox[0] = self.aabb[:, 0].min(axis=0)
        self.bbox[1] = self.aabb[:, 1].max(axis=0)

    def obj(self, i: int | np.integer):
        """FCL object of piece ``i`` at the current pose."""
        o = self.objects[i]
        if not self.fresh[i]:
            g = self.geoms[i]
            if g.identity:
                if self.tf_part is None:
                    self.tf_part = _tf(self.T)
                o.setTransform(self.tf_part)
            else:
                o.setTransform(_tf(self.T @ g.T_part_geom))
            self.fresh[i] = True
        return o


def _boxes_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.all(a[0] <= b[1]) and np.all(b[0] <= a[1]))


def _candidates(ea: _Entry, eb: _Entry, margin: float = 0.0) -> np.ndarray:
    """Index pairs (k, 2) of pieces whose world AABBs overlap (grown by ``margin``)."""
    A, B = ea.aabb, eb.aabb
    ok = np.all((A[:, None, 0] <= B[None, :, 1] + margin) & (B[None, :, 0] <= A[:, None, 1] + margin), axis=2)
    return np.argwhere(ok)


def _bvh(vertices_m: np.ndarray, faces: np.ndarray):
    V = np.ascontiguousarray(vertices_m, dtype=float) * _K
    F = np.ascontiguousarray(faces, dtype=np.int64)
    bvh = fcl.BVHModel()
    bvh.beginModel(len(V), len(F))
    bvh.addSubModel(V, F)
    bvh.endModel()
    return bvh


def _max_depth(o1, o2) -> tuple[float, np.ndarray | None]:
    """Largest penetration depth (m) of two FCL objects and its world point (m)."""
    res = fcl.CollisionResult()
    fcl.collide(o1, o2, _REQ_DEPTH, res)
    if not res.contacts:
        return 0.0, None
    best = max(res.contacts, key=lambda c: c.penetration_depth)
    return float(best.penetration_depth) / _K, np.asarray(best.pos, dtype=float) / _K


class CollisionWorld:
    """Named collision objects at poses, with collision, contact, distance and sweep queries.

    Parameters
    ----------
    shapes : FclShapes, optional
        Geometry cache to share between worlds (default: a private one).
    """

    def __init__(self, shapes: FclShapes | None = None):
        self.shapes = shapes or FclShapes()
        self._entries: dict[str, _Entry] = {}
        self._meshes: dict[int, tuple[CollisionModel, Any]] = {}
        # every name's world AABB is a row of one array (each entry's ``bbox`` is a view of its
        # row), so the boxes of many names are one fancy-indexing gather (:meth:`aabbs`)
        self._boxes = np.zeros((16, 2, 3))
        self._slots: dict[str, int] = {}
        self._free: list[int] = []
        self._rows: dict[tuple[str, ...], np.ndarray] = {}

    # -- content ------------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._entries)

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def add(self, name: str, model: CollisionModel, T_world_part: np.ndarray) -> None:
        """Add ``model`` under ``name`` at ``T_world_part`` (4, 4); replaces an existing name."""
        geoms = self.shapes.geoms(model)
        if not geoms:
            raise ValueError(f'"{name}": expected a collision model with pieces or a mesh, found none')
        known = self._slots.get(name)
        new = known is None
        slot = -1 if known is None else known
        if new:
            if self._free:
                slot = self._free.pop()
            else:
                slot = len(self._slots)
                if slot == len(self._boxes):  # grow; the entries' views move to the new array
                    boxes = np.zeros((2 * len(self._boxes), 2, 3))
                    boxes[:slot] = self._boxes
                    self._boxes = boxes
                    for n, e in self._entries.items():
                        e.bbox = boxes[self._slots[n]]
        try:
            entry = _Entry(name, model, geoms, T_world_part, self._boxes[slot])
        except BaseException:
            if new:
                self._free.append(slot)
            raise
        if new:
            self._slots[name] = slot
        self._entries[name] = entry

    def remove(self, name: str) -> None:
        self._entry(name)
        del self._entries[name]
        self._free.append(self._slots.pop(name))
        self._rows.clear()

    def set_pose(self, name: str, T_world_part: np.ndarray) -> None:
        """Move ``name`` to ``T_world_part`` (4, 4)."""
        self._entry(name).set_pose(T_world_part)

    def pose(self, name: str) -> np.ndarray:
        """Current ``T_world_part`` (4, 4) of ``name`` (a copy)."""
        return self._entry(name).T.copy()

    def model(self, name: str) -> CollisionModel:
        return self._entry(name).model

    def aabb(self, name: str) -> np.ndarray:
        """World axis-aligned bounding box (2, 3): min and max corner, metres."""
        return self._entry(name).bbox.copy()

    def aabbs(self, names: Sequence[str]) -> np.ndarray:
        """World axis-aligned bounding boxes (k, 2, 3) of ``names`` (a new array), metres."""
        key = tuple(names)
        rows = self._rows.get(key)
        if rows is None:
            for n in key:
                self._entry(n)  # KeyError naming the known objects
            rows = np.array([self._slots[n] for n in key], dtype=np.intp)
            if len(self._rows) > 256:
                self._rows.clear()
            self._rows[key] = rows
        return self._boxes[rows]

    def _entry(self, name: str) -> _Entry:
        try:
            return self._entries[name]
        except KeyError:
            raise KeyError(f'no object "{name}" in the collision world; it has: '
                           f'{", ".join(sorted(self._entries)) or "nothing"}') from None

    def _others(self, name: str, others: Iterable[str] | None) -> list[_Entry]:
        if others is None:
            return [e for n, e in self._entries.items() if n != name]
        return [self._entry(n) for n in others if n != name]

    # -- queries ------------------------------------------------------------------------------
    def in_collision(self, name: str, others: Iterable[str] | None = None, tolerance_m: float = 1e-6) -> bool:
        """Whether ``name`` penetrates any of ``others`` (default: everything else) deeper than
        ``tolerance_m``; touching within the tolerance is not a collision."""
        e = self._entry(name)
        for o in self._others(name, others):
            if not _boxes_overlap(e.bbox, o.bbox):
                continue
            for i, j in _candidates(e, o):
                o1, o2 = e.obj(i), o.obj(j)
                if fcl.collide(o1, o2, _REQ_BOOL, fcl.CollisionResult()) and (
                        tolerance_m <= 0 or _max_depth(o1, o2)[0] > tolerance_m):
                    return True
        return False

    def pair_contact(self, a: str, b: str, tolerance_m: float = 1e-6, *,
                     containment: bool = True) -> Contact | None:
        """The deepest contact of ``a`` with ``b`` deeper than ``tolerance_m``, or None."""
        ea, eb = self._entry(a), self._entry(b)
        if not _boxes_overlap(ea.bbox, eb.bbox):
            return None
        best_depth, best_point = -1.0, None
        surface_met = False
        for i, j in _candidates(ea, eb):
            o1, o2 = ea.obj(i), eb.obj(j)
            if not fcl.collide(o1, o2, _REQ_BOOL, fcl.CollisionResult()):
                continue
            surface_met = True
            depth, point = _max_depth(o1, o2)
            if depth > best_depth:
                best_depth, best_point = depth, point
        if best_depth > tolerance_m and best_point is not None:
            return Contact(a, b, best_depth, best_point)
        if containment and not surface_met:
            return self._containment(ea, eb) or self._containment(eb, ea)
        return None

    def separation(self, a: str, b: str, tolerance_m: float = 1e-6,
                   directions: Sequence[Sequence[float]] | None = None) -> tuple[float, np.ndarray]:
        """Smallest translation of ``a`` along one of ``directions`` (default: the six world
        axis directions) after which ``a`` and ``b`` overlap by at most ``tolerance_m``.

        An upper bound of the penetration depth, exact for two parts overlapping across a
        face along an axis (a part placed too low). Bisection on collision, to 1 nm.
        Returns the distance (m, 0 when they do not overlap) and the direction (3,).
        """
        ea, eb = self._entry(a), self._entry(b)
        dirs = np.eye(3).tolist() + (-np.eye(3)).tolist() if directions is None else directions
        T0 = ea.T.copy()
        reach = float(np.max(ea.bbox[1] - ea.bbox[0]) + np.max(eb.bbox[1] - eb.bbox[0])) + 1e-3
        best, best_dir = math.inf, np.zeros(3)
        try:
            if not self.in_collision(a, (b,), tolerance_m):
                return 0.0, best_dir
            for d in dirs:
                u = np.asarray(d, dtype=float) / np.linalg.norm(d)
                lo, hi = 0.0, min(reach, best)
                T = T0.copy()
                T[:3, 3] = T0[:3, 3] + hi * u
                ea.set_pose(T)
                if self.in_collision(a, (b,), tolerance_m):
                    continue
                while hi - lo > 1e-9:
                    mid = 0.5 * (lo + hi)
                    T[:3, 3] = T0[:3, 3] + mid * u
                    ea.set_pose(T)
                    if self.in_collision(a, (b,), tolerance_m):
                        lo = mid
                    else:
                        hi = mid
                if hi < best:
                    best, best_dir = hi, u
        finally:
            ea.set_pose(T0)
        return (best if math.isfinite(best) else reach), best_dir

    def _containment(self, inner: _Entry, outer: _Entry) -> Contact | None:
        """Contact when ``inner`` lies wholly inside ``outer``'s BVH solid (no surface met):
        then any point of ``inner``'s material is inside ``outer``; one is tested."""
        m = outer.model
        if m.mesh_vertices_m is None or m.mesh_faces is None:
            return None
        import trimesh

        g = inner.geoms[0]
        if g.piece is not None:
            p_part = g.T_part_geom[:3, 3] + (g.T_part_geom[:3, :3] @ (
                np.asarray(g.piece.vertices_m).mean(axis=0) if g.piece.kind == "hull" else np.zeros(3)))
        else:
            p_part = np.asarray(inner.model.mesh_vertices_m, dtype=float)[0]
        p_world = inner.T[:3, :3] @ p_part + inner.T[:3, 3]
        T_outer_world = np.linalg.inv(outer.T)
        p = T_outer_world[:3, :3] @ p_world + T_outer_world[:3, 3]
        mesh = self._meshes.get(id(m))
        if mesh is None or mesh[0] is not m:
            mesh = (m, trimesh.Trimesh(m.mesh_vertices_m, m.mesh_faces, process=False))
            self._meshes[id(m)] = mesh
        if not bool(mesh[1].contains(p[None])[0]):
            return None
        depth = float(abs(trimesh.proximity.signed_distance(mesh[1], p[None])[0]))
        a, b = sorted((inner.name, outer.name))
        return Contact(a, b, depth, p_world)

    def contacts(self, names_a: Iterable[str] | None = None, names_b: Iterable[str] | None = None,
                 tolerance_m: float = 1e-6) -> list[Contact]:
        """Deepest contact of every pair (a in ``names_a``, b in ``names_b``, a != b) that
        penetrates deeper than ``tolerance_m``, sorted by names. Default: all pairs."""
        A = list(self._entries) if names_a is None else [self._entry(n).name for n in names_a]
        B = list(self._entries) if names_b is None else [self._entry(n).name for n in names_b]
        pairs = sorted({tuple(sorted((a, b))) for a in A for b in B if a != b})
        out = []
        for a, b in pairs:
            c = self.pair_contact(a, b, tolerance_m)
            if c is not None:
                out.append(c)
        return out

    def distance(self, a: str, b: str) -> float:
        """Smallest distance between ``a`` and ``b``, metres; when they penetrate, minus the
        penetration depth (0 for touching)."""
        ea, eb = self._entry(a), self._entry(b)
        lo_a, hi_a = ea.aabb[:, None, 0], ea.aabb[:, None, 1]
        lo_b, hi_b = eb.aabb[None, :, 0], eb.aabb[None, :, 1]
        gap = np.maximum(0.0, np.maximum(lo_b - hi_a, lo_a - hi_b))
        bound = np.sqrt((gap**2).sum(axis=2))  # AABB distance: a lower bound per pair
        order = np.argsort(bound, axis=None).tolist()
        flat_bound = bound.ravel().tolist()
        n_b = bound.shape[1]
        best = math.inf
        deepest = 0.0
        for flat in order:
            i, j = divmod(flat, n_b)
            if flat_bound[flat] >= best:
                break
            o1, o2 = ea.obj(i), eb.obj(j)
            d = fcl.distance(o1, o2, _REQ_DIST, fcl.DistanceResult()) / _K
            if d <= 0:
                depth, _ = _max_depth(o1, o2)
                deepest = max(deepest, depth)
                best = 0.0
                continue
            best = min(best, d)
        return -deepest if best <= 0 else float(best)

    # Complexity above C (radon): three tiers (swept boxes, coarse FCL, exact FCL) and the primitive
    # and BVH cases in one loop, so that each tier prunes the next without intermediate lists.
    def sweep_blockers(self, name: str, direction: ArrayLike, distance_m: float,
                       others: Iterable[str] | None = None, step_m: float | None = None,
                       tolerance_m: float = 1e-6, resting_m: float = 0.0) -> set[str]:
        """Names that ``name`` hits when translated by ``distance_m`` along ``direction``
        (world) from its current pose; the pose is left unchanged.

        Convex pieces sweep exactly (see the module docstring); BVH meshes are checked at
        steps of ``step_m`` (default ``min(1e-4, distance_m / 10)`` m) plus the end pose.

        ``resting_m`` (m, default 0) makes the sweep contact-aware: a piece pair that already
        overlaps at the start by at most ``resting_m`` is a resting contact whose overlap is
        the model's error (a circumscribed polygon under a cylinder resting micrometres above
        a rib), not material in the way; it blocks only when the motion deepens the overlap
        by more than ``tolerance_m`` (sliding along or lifting off the support does not; moving
        into it does). Deeper start overlaps block as before.
        """
        d = np.asarray(direction, dtype=float)
        norm = float(np.linalg.norm(d))
        if norm == 0 or not math.isfinite(norm):
            raise ValueError(f"direction: expected a non-zero vector, found {d.tolist()}")
        if not (distance_m >= 0 and math.isfinite(distance_m)):
            raise ValueError(f"distance_m: expected >= 0, found {distance_m!r}")
        u = d / norm
        delta = u * distance_m
        e = self._entry(name)
        targets = self._others(name, others)
        blockers: set[str] = set()
        # swept boxes first; a piece's swept FCL object is built when a box first meets one
        piece_index = [i for i, g in enumerate(e.geoms) if g.piece is not None]
        pieces = [e.geoms[i] for i in piece_index]
        swept_boxes = [swept_aabb(g.corners_part, e.T, delta) for g in pieces]
        swept_objs: list[object] = [None] * len(pieces)
        lo = np.minimum(e.bbox[0], e.bbox[0] + delta)
        hi = np.maximum(e.bbox[1], e.bbox[1] + delta)
        for o in targets:
            if not _boxes_overlap(np.stack([lo, hi]), o.bbox):
                continue
            hit = False
            for k, aabb in enumerate(swept_boxes):
                cand = np.nonzero(np.all((aabb[0] <= o.aabb[:, 1]) & (o.aabb[:, 0] <= aabb[1]), axis=1))[0]
                if len(cand) and swept_objs[k] is None:
                    swept_objs[k] = _swept_geometry(pieces[k], e.T, delta)
                obj = swept_objs[k]
                for j in cand:
                    if not fcl.collide(obj, o.obj(j), _REQ_BOOL, fcl.CollisionResult()):
                        continue
                    allowed = tolerance_m
                    if resting_m > 0:
                        start = _max_depth(e.obj(piece_index[k]), o.obj(j))[0]
                        if start <= resting_m:
                            allowed = start + tolerance_m
                    if allowed <= 0 or _max_depth(obj, o.obj(j))[0] > allowed:
                        hit = True
                        break
                if hit:
                    break
            if hit:
                blockers.add(o.name)
        meshes = [k for k, g in enumerate(e.geoms) if g.piece is None]
        if meshes and distance_m > 0:
            rest = [o for o in targets if o.name not in blockers]
            step = step_m if step_m is not None else min(1e-4, distance_m / 10.0)
            if step <= 0:
                raise ValueError(f"step_m: expected > 0, found {step!r}")
            n = max(1, math.ceil(distance_m / step))
            T0 = e.T.copy()
            mesh_set = set(meshes)
            try:
                for s in range(1, n + 1):
                    T = T0.copy()
                    T[:3, 3] += delta * (s / n)
                    e.set_pose(T)
                    for o in rest:
                        if o.name in blockers or not _boxes_overlap(e.bbox, o.bbox):
                            continue
                        for i, j in _candidates(e, o):
                            if i not in mesh_set:
                                continue
                            o1, o2 = e.obj(i), o.obj(j)
                            if fcl.collide(o1, o2, _REQ_BOOL, fcl.CollisionResult()) and (
                                    tolerance_m <= 0 or _max_depth(o1, o2)[0] > tolerance_m):
                                blockers.add(o.name)
                                break
            finally:
                e.set_pose(T0)
        return blockers


def _swept_geometry(g: _Geom, T_world_part: np.ndarray, delta: np.ndarray):
    """An FCL object (at its world pose) for the volume swept by piece ``g`` under
    translation ``delta`` (world)."""
    pc = g.piece
    T = T_world_part @ g.T_part_geom
    R, t = T[:3, :3], T[:3, 3]
    dist = float(np.linalg.norm(delta))
    u = delta / dist if dist > 0 else np.array([0.0, 0.0, 1.0])
    if dist == 0:
        geom, Tw = g.geometry, T
    elif pc is None:
        raise ValueError("a BVH mesh cannot be swept exactly; step it instead")
    elif pc.kind == "sphere":
        Tw = np.eye(4)
        Tw[:3, :3] = rotation_between((0.0, 0.0, 1.0), u)
        Tw[:3, 3] = t + 0.5 * delta
        geom = fcl.Capsule(_K * pc.radius_m, _K * dist)
    elif (pc.kind == "box" and along_local_axis(R, u, dist) is not None) or (
            pc.kind == "cylinder" and along_local_axis(R, u, dist) == 2):
        k = along_local_axis(R, u, dist)
        Tw = T.copy()
        Tw[:3, 3] = t + 0.5 * delta
        if pc.kind == "cylinder":
            geom = fcl.Cylinder(_K * pc.radius_m, _K * (pc.length_m + dist))
        else:
            size = 2.0 * np.array(pc.half_extents_m)
            size[k] += dist
            geom = fcl.Box(*(_K * size))
    else:
        pts = piece_points_world(pc, T)
        allp = np.concatenate([pts, pts + delta])
        Tw = np.eye(4)
        geom = _convex(allp)
    return fcl.CollisionObject(geom, _tf(Tw))


def point_distances(vertices_m: np.ndarray, faces: np.ndarray, points_m: np.ndarray) -> np.ndarray:
    """Exact unsigned distance (n,) from each point (n, 3) to a triangle surface, metres."""
    surface = fcl.CollisionObject(_bvh(vertices_m, faces), fcl.Transform())
    r = 1e-9  # mm
    probe = fcl.CollisionObject(fcl.Sphere(r), fcl.Transform())
    out = np.empty(len(points_m))
    for i, p in enumerate(np.asarray(points_m, dtype=float) * _K):
        probe.setTranslation(p)
        d = fcl.distance(probe, surface, _REQ_DIST, fcl.DistanceResult())
        out[i] = (max(d, 0.0) + r) / _K
    return out


__all__ = ["FCL_SCALE", "CollisionWorld", "Contact", "FclShapes", "point_distances"]
