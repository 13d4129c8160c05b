"""Measured error of a collision model: Hausdorff distance and effective hole clearance.

Every convex and coarse model of :mod:`asmplan.parts.lod` is measured against the exact solid:

* Hausdorff distance between the model's surface (the manifold union of its pieces, each
  grown by 0.1 um so that touching pieces fuse) and the exact surface, sampled on the boundary
  of their symmetric difference (all its vertices plus ``hausdorff_samples`` seeded points,
  half of them where the surfaces part most) with exact point-to-triangle distances; the
  maximum is found exactly at polygon corners and to within the sample spacing inside faces;
* per hole, the effective diametral clearance: a probe pin of radius ``r - c`` is centred in
  the hole over the middle half of its depth and pushed sideways until contact (bisection on
  FCL's boolean collision to 0.1 nm) in ``clearance_directions`` directions, refined around
  the extremes by golden-section search; the effective clearance in a direction is the travel
  both ways. The error is the largest deviation from ``2 c``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .geometry import (
    GeometrySettings,
    HoleShape,
    manifold_to_mesh,
    polygon_excess,
    sides_for_tolerance,
)
from .mesh import TriangleMesh
from .pieces import CollisionModel, ConvexPiece, LevelOfDetail
from .primitive_pieces import HoleSides, piece_points


# ---------------------------------------------------------------------------------------------
# Models per level
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class HoleClearance:
    """Measured effective clearance of one hole in one model (diametral values, metres)."""

    feature: str
    n_sides: int
    design_m: float
    effective_min_m: float
    effective_max_m: float
    bound_m: float

    @property
    def error_m(self) -> float:
        return max(abs(self.effective_min_m - self.design_m), abs(self.effective_max_m - self.design_m))


@dataclass(frozen=True)
class LevelReport:
    """What a level's model is and how far it is from the exact geometry."""

    level: LevelOfDetail
    n_pieces: int
    hausdorff_m: float
    hausdorff_measured: bool
    holes: tuple[HoleClearance, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def hole_clearance_error_m(self) -> float:
        return max((h.error_m for h in self.holes), default=0.0)



# ---------------------------------------------------------------------------------------------
# Measurement
# ---------------------------------------------------------------------------------------------
def model_solid(model: CollisionModel, tol_m: float = 1e-6, grow_m: float = 1e-7):
    """Manifold union of a model's pieces (and mesh), part frame (double precision).

    Each piece is grown by ``grow_m`` (0.1 um) so that pieces sharing a face overlap: exactly
    touching pieces are not welded by the union and would leave their shared faces inside.
    """
    import manifold3d as m3

    from .geometry import trimesh_to_manifold

    parts = []
    for pc in model.pieces:
        T = np.ascontiguousarray(pc.T_part_piece[:3, :4])
        if pc.kind == "box":
            half = np.asarray(pc.half_extents_m)
            parts.append(m3.Manifold.cube(list(2.0 * half + 2.0 * grow_m), True).transform(T))
        elif pc.kind == "cylinder":
            n = sides_for_tolerance(pc.radius_m, tol_m)
            R = (pc.radius_m + grow_m) / math.cos(math.pi / n)
            parts.append(m3.Manifold.cylinder(pc.length_m + 2.0 * grow_m, R, R, n, True).transform(T))
        else:
            pts = piece_points(pc, tol_m)
            centre = pts.mean(axis=0)
            inner = float(np.min(np.linalg.norm(pts - centre, axis=1)))
            pts = centre + (pts - centre) * (1.0 + grow_m / max(inner, 1e-9))
            parts.append(m3.Manifold.hull_points(np.ascontiguousarray(pts)))
    if model.mesh_vertices_m is not None and model.mesh_faces is not None:
        parts.append(trimesh_to_manifold(TriangleMesh(model.mesh_vertices_m, model.mesh_faces)))
    return m3.Manifold.batch_boolean(parts, m3.OpType.Add)


def hausdorff(solid_a, solid_b, n_samples: int = 400, seed: int = 0) -> float:
    """Symmetric Hausdorff distance (m) between the surfaces of two manifold solids.

    Every point of one surface that is not on the other lies on the boundary of their
    symmetric difference ``D = (A - B) + (B - A)``, so only ``D``'s boundary is sampled: all
    its vertices, then ``n_samples`` seeded points on its triangles, half by area and half by
    area times the largest distance found at the triangle's corners (to refine where the
    surfaces part). Each point's distance to both surfaces is exact (point-to-triangle); the
    larger of the two counts. A maximum inside a large face is found to within the sample
    spacing there.
    """
    from .collision import point_distances

    diff = (solid_a - solid_b) + (solid_b - solid_a)
    if diff.is_empty():
        return 0.0
    dmesh = manifold_to_mesh(diff)
    ma, mb = manifold_to_mesh(solid_a), manifold_to_mesh(solid_b)

    def dist(pts: np.ndarray) -> np.ndarray:
        da = point_distances(np.asarray(ma.vertices), np.asarray(ma.faces), pts)
        db = point_distances(np.asarray(mb.vertices), np.asarray(mb.faces), pts)
        return np.maximum(da, db)

    verts = np.asarray(dmesh.vertices)
    dv = dist(verts)
    best = float(dv.max())
    if n_samples <= 0:
        return best
    rng = np.random.default_rng(seed)
    faces = np.asarray(dmesh.faces)
    area = dmesh.area_faces
    weights = [area, area * dv[faces].max(axis=1)]
    samples = []
    for w, n in zip(weights, (n_samples // 2, n_samples - n_samples // 2), strict=True):
        if w.sum() <= 0 or n <= 0:
            continue
        f = rng.choice(len(faces), size=n, p=w / w.sum())
        u, v = rng.random(n), rng.random(n)
        flip = u + v > 1
        u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
        tri = verts[faces[f]]
        e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        samples.append(tri[:, 0] + u[:, None] * e1 + v[:, None] * e2)
    if samples:
        best = max(best, float(dist(np.concatenate(samples)).max()))
    return best


def effective_clearance(model: CollisionModel, hole: HoleShape, radial_clearance_m: float,
                        settings: GeometrySettings, probe_span_m: tuple[float, float] | None = None
                        ) -> tuple[float, float]:
    """Smallest and largest effective DIAMETRAL clearance (m) of ``hole`` in ``model`` for a
    probe pin of radius ``r - c`` (see the module docstring).

    The travel in a direction is found by bisection on FCL's boolean collision (libccd GJK,
    sub-micrometre), not on its distance, whose GJK result for hull pieces was measured to be
    several micrometres off. ``probe_span_m`` is the probe's axial extent in the hole frame
    (z <= 0 inside); default: the middle half of the hole's depth.
    """
    from .collision import CollisionWorld

    c = radial_clearance_m
    r_probe = hole.radius_m - c
    if r_probe <= 0:
        raise ValueError(f"hole {hole.feature}: expected a probe radius > 0, found {r_probe}")
    z0, z1 = probe_span_m if probe_span_m is not None else (-0.75 * hole.depth_m, -0.25 * hole.depth_m)
    T_probe_local = np.eye(4)
    T_probe_local[2, 3] = 0.5 * (z0 + z1)
    probe = CollisionModel("exact", (ConvexPiece(kind="cylinder", T_part_piece=np.eye(4), radius_m=r_probe,
                                                 length_m=z1 - z0, name="probe"),))
    world = CollisionWorld()
    world.add("part", model, np.eye(4))
    T_hole = hole.T_part_hole @ T_probe_local
    world.add("probe", probe, T_hole)
    ex, ey = T_hole[:3, 0], T_hole[:3, 1]
    others = ("part",)

    def hits(s: float, u: np.ndarray) -> bool:
        T = T_hole.copy()
        T[:3, 3] = T_hole[:3, 3] + s * u
        world.set_pose("probe", T)
        return world.in_collision("probe", others, tolerance_m=0.0)

    def travel(theta: float) -> float:
        u = math.cos(theta) * ex + math.sin(theta) * ey
        if hits(0.0, u):
            world.set_pose("probe", T_hole)
            contact = world.pair_contact("probe", "part", 0.0, containment=False)
            return -(contact.depth_m if contact is not None else 0.0)
        lo, hi = 0.0, max(c, 1e-7)
        while not hits(hi, u):
            lo, hi = hi, 2.0 * hi
            if hi > 4.0 * hole.radius_m:
                return hi
        while hi - lo > 1e-10:
            mid = 0.5 * (lo + hi)
            if hits(mid, u):
                hi = mid
            else:
                lo = mid
        return 0.5 * (lo + hi)

    k = settings.clearance_directions
    thetas = 2.0 * math.pi * np.arange(k) / k
    memo: dict[float, float] = {}

    def both(theta: float) -> float:
        out = 0.0
        for t in (theta % (2 * math.pi), (theta + math.pi) % (2 * math.pi)):
            key = round(t, 12)
            if key not in memo:
                memo[key] = travel(t)
            out += memo[key]
        return out

    values = np.array([both(t) for t in thetas[: (k + 1) // 2]])
    if np.all(values < 0):
        return float(values.min()), float(values.max())
    step = 2.0 * math.pi / k
    lo_theta = float(thetas[int(np.argmin(values))])
    hi_theta = float(thetas[int(np.argmax(values))])
    v_min = _golden(both, lo_theta - step, lo_theta + step, minimise=True)
    v_max = _golden(both, hi_theta - step, hi_theta + step, minimise=False)
    return min(float(values.min()), v_min), max(float(values.max()), v_max)


def _golden(f, a: float, b: float, *, minimise: bool, iters: int = 14) -> float:
    g = (math.sqrt(5.0) - 1.0) / 2.0
    sign = 1.0 if minimise else -1.0
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = sign * f(c), sign * f(d)
    for _ in range(iters):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = sign * f(c)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = sign * f(d)
    return sign * min(fc, fd)


def measure(model: CollisionModel, level: LevelOfDetail, exact_solid, holes: tuple[HoleShape, ...],
            sides: dict[str, HoleSides], settings: GeometrySettings,
            probe_spans: dict[str, tuple[float, float]] | None = None) -> LevelReport:
    """Measure a convex or coarse model against the exact mesh (see the module docstring)."""
    solid = model_solid(model, settings.exact_tolerance_m)
    h = hausdorff(exact_solid, solid, settings.hausdorff_samples, settings.seed)
    records = []
    for hole in holes:
        hs = sides[hole.feature]
        c = hs.radial_clearance_m if hs.radial_clearance_m > 0 else 0.5 * settings.unmated_hole_clearance_m
        span = (probe_spans or {}).get(hole.feature)
        lo, hi = effective_clearance(model, hole, c, settings, span)
        n = hs.n_sides if level == "convex" else 0
        bound = 2.0 * polygon_excess(c, hs.n_sides) if level == "convex" else float("nan")
        records.append(HoleClearance(hole.feature, n, 2.0 * c, lo, hi, bound))
    return LevelReport(level, len(model.pieces) + (model.mesh_faces is not None), h, True, tuple(records),
                       model.notes)


def with_errors(model: CollisionModel, report: LevelReport) -> CollisionModel:
    """``model`` carrying the measured errors of ``report``."""
    return CollisionModel(model.level, model.pieces, report.hausdorff_m, report.hole_clearance_error_m,
                          model.mesh_vertices_m, model.mesh_faces, model.notes)


__all__ = ["HoleClearance", "LevelReport", "effective_clearance", "hausdorff", "measure", "model_solid",
           "with_errors"]
