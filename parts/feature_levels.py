"""Which declared features a level of detail fills or drops, measured on the model itself.

The convex level is what `sequence`, `plan` and the simulation use wherever a part touches
another. For primitive parts it keeps every hole and pin by construction (exact polygons,
:mod:`asmplan.parts.lod`); for a mesh part (:mod:`asmplan.parts.mesh_convex`) a hole no plane
separates from holes on another axis, a piece budget spent on concave faces, or a mesh that
cannot be decomposed at all leave hulls that fill holes or bridge pins. Rather than trusting
notes, this module probes the model: points on a hole's axis (and half way to its wall) over
its depth, and points just outside a pin's surface at mid-length, that lie outside the exact
solid, are tested against the model's convex pieces. A probe point inside a piece is material
the real part does not have there: the hole is **filled** (the pin that should enter it is
blocked), or the pin is **bridged** (a hull spans from it to the body, so no hole can go over
it).

The coarse level (one hull) fills every hole and bridges every pin by design; it is used only
for obstacles away from a step's motion (more than ``SceneSettings.near_margin_m`` from the
swept space), never for a part the held part touches or passes through, so it is not reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..knowledge.model import Feature, Product
from .models import ProductGeometry
from .pieces import CollisionModel, ConvexPiece, LevelOfDetail

_INSIDE_M = 2e-5
"""A probe point counts as inside a piece (or the exact solid) this far from its surface, m."""


@dataclass(frozen=True)
class FeatureLoss:
    """A declared feature that a level of detail fills (hole) or bridges (pin).

    ``probes_inside`` of ``probes`` probe points (outside the exact solid) lie inside the
    level's pieces; ``depth_m`` is the deepest of them, measured from the piece's surface.
    """

    part: str
    feature: str
    kind: str
    level: LevelOfDetail
    action: str
    probes_inside: int
    probes: int
    depth_m: float
    geometry: str

    def message(self) -> str:
        filled = self.action == "filled"
        what = "filled" if filled else "bridged (a hull spans from it to the body)"
        where = "in the hole" if filled else "beside the pin"
        return (f'part "{self.part}" ({self.geometry}): {self.kind} {self.feature} is {what} at the '
                f"{self.level} level that sequence, plan and the simulation use for contact "
                f"({self.probes_inside} of {self.probes} probe points {where} "
                f"lie up to {self.depth_m * 1e3:.2f} mm inside its pieces)")


def _signed_depth(piece: ConvexPiece, P_part: np.ndarray) -> np.ndarray:
    """Depth of each point inside ``piece`` (positive inside), m; points (n, 3) in the part frame."""
    T = piece.T_part_piece
    q = (P_part - T[:3, 3]) @ T[:3, :3]
    if piece.kind == "box":
        assert piece.half_extents_m is not None
        return np.min(piece.half_extents_m - np.abs(q), axis=1)
    if piece.kind == "cylinder":
        radial = piece.radius_m - np.hypot(q[:, 0], q[:, 1])
        return np.minimum(radial, 0.5 * piece.length_m - np.abs(q[:, 2]))
    if piece.kind == "sphere":
        return piece.radius_m - np.linalg.norm(q, axis=1)
    from scipy.spatial import ConvexHull, QhullError

    assert piece.vertices_m is not None
    try:
        eq = ConvexHull(piece.vertices_m).equations  # n . x + d <= 0 inside, |n| = 1
    except QhullError:  # a flat hull holds no volume
        return np.full(len(q), -np.inf)
    return np.min(-(q @ eq[:, :3].T + eq[:, 3]), axis=1)


def _depth_in_model(model: CollisionModel, P: np.ndarray) -> np.ndarray:
    depth = np.full(len(P), -np.inf)
    for pc in model.pieces:
        depth = np.maximum(depth, _signed_depth(pc, P))
    return depth


def _basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    return u, np.cross(axis, u)


def _probes(f: Feature, vertices_m: np.ndarray) -> np.ndarray:
    """Probe points (n, 3), part frame: in a hole over its depth (a through hole: the part's
    extent behind its mouth), beside a pin at mid-length."""
    a = np.asarray(f.axis, float)
    u, v = _basis(a)
    r = 0.5 * f.diameter_m
    dirs = [math.cos(k * math.pi / 4) * u + math.sin(k * math.pi / 4) * v for k in range(8)]
    if f.is_male:
        mid = f.origin_m + a * 0.5 * f.length_m
        gap = max(1e-3, 0.5 * r)
        return np.array([mid + (r + gap) * d for d in dirs])
    depth = f.length_m if f.length_m > 0 and not f.through else \
        max(0.0, float(((f.origin_m - vertices_m) @ a).max()))
    pts = []
    for t in (0.25, 0.5, 0.75):
        c = f.origin_m - a * t * depth
        pts.append(c)
        pts += [c + 0.5 * r * d for d in dirs[::2]]
    return np.array(pts)


def feature_losses(product: Product, geometry: ProductGeometry,
                   level: LevelOfDetail = "convex") -> list[FeatureLoss]:
    """Every declared hole the ``level`` fills and pin it bridges, part by part (mesh-file
    parts only: primitive parts keep their features at the convex and exact levels by
    construction, see the module docstring)."""
    out: list[FeatureLoss] = []
    for part in product.parts:
        if not part.features or not geometry.shape(part.name).is_mesh:
            continue
        model = geometry.collision_model(part.name, level, measured=False)
        mesh = geometry.mesh(part.name).to_trimesh()
        V = np.asarray(mesh.vertices, float)
        for f in part.features:
            P = _probes(f, V)
            outside = ~mesh.contains(P)
            if f.is_male:  # beside the pin: only where the real part has no material
                outside &= np.abs(mesh.nearest.signed_distance(P)) > _INSIDE_M
            P = P[outside]
            if not len(P):
                continue
            d = _depth_in_model(model, P)
            inside = d > _INSIDE_M
            if inside.any():
                g = part.geometry
                src = g.mesh_file.name if g.mesh_file is not None else g.kind
                out.append(FeatureLoss(part.name, f.name, f.kind, level,
                                       "bridged" if f.is_male else "filled", int(inside.sum()),
                                       len(P), float(d[inside].max()), f"mesh {src}"))
    return out


def level_warnings(product: Product, geometry: ProductGeometry | None = None) -> list[str]:
    """One warning per feature the convex level fills or bridges (:func:`feature_losses`)."""
    if not any(p.features and p.geometry.kind == "mesh" for p in product.parts):
        return []
    geometry = geometry or ProductGeometry(product)
    return [loss.message() for loss in feature_losses(product, geometry)]


__all__ = ["FeatureLoss", "feature_losses", "level_warnings"]
