"""Line-to-line CAD pairs in ``asmplan check``: a contact the fit explains, with its real depth.

CAD draws a pin and its hole at one nominal diameter; the fit is a drawing annotation. Parts
read from mesh files keep that nominal geometry (the fit cannot be built into a mesh), so the
two meshes touch, and their tessellations overlap by up to the chord error (a few um). FCL's
contact depth between two BVH meshes is then a local figure (one triangle pierced by another,
reported as 4-25 mm) and the separation along a world axis is the length of the engagement,
neither of which is an interference.

:func:`nominal_contact` intersects the two solids (manifold3d) and accepts the contact as the
mate's nominal contact when every vertex of the overlap lies on the mate's cylinder (within
``band_m`` of the nominal radius, along the engaged length) or on a blind hole's floor where
the pin is seated: its real depth is the thickness of the overlap. Anything else in the
overlap is a real interference.

:func:`mesh_hole_bound` is the error bound of a mesh hole's clearance at the exact level (the
mesh as read): twice the sagitta of the largest chord of its wall polygon (the polygon lies
inside the circle by that much) plus the fit's deviation of the hole from nominal, which a mesh
cannot be resized by (the convex level, which the simulator uses, builds the fitted hole).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..knowledge.model import Product


@dataclass(frozen=True)
class NominalContact:
    """The overlap of two parts explained by a line-to-line mate.

    ``depth_m`` is the overlap's radial thickness (the real depth), ``mate`` the mate's name.
    """

    mate: str
    depth_m: float
    volume_m3: float


def _world_vertices(geometry, product: Product, part: str):
    T = product.T_world_assembled(part)
    return geometry.solid(part), T


def _transformed(solid, T: np.ndarray):
    m = [list(map(float, T[0, :])), list(map(float, T[1, :])), list(map(float, T[2, :]))]
    return solid.transform([[m[r][c] for c in range(4)] for r in range(3)])


def nominal_contact(product: Product, geometry, a: str, b: str, band_m: float = 20e-6
                    ) -> NominalContact | None:
    """The line-to-line mate between parts ``a`` and ``b`` that explains their overlap, or None.

    A mate qualifies when its pin and hole have the same nominal diameter and at least one of
    the two parts is a mesh file (primitive parts are built with the fit, so they do not
    overlap). Every vertex of the overlap must lie within ``band_m`` of the nominal cylinder,
    within the hole's depth along its axis (chamfers included).
    """
    candidates = []
    for m in product.mates:
        if {m.pin_part, m.hole_part} != {a, b}:
            continue
        pin = product.feature(m.pin_part, m.pin_feature)
        hole = product.feature(m.hole_part, m.hole_feature)
        if abs(pin.diameter_m - hole.diameter_m) > 1e-9:
            continue
        if not (geometry.shape(a).is_mesh or geometry.shape(b).is_mesh):
            continue
        candidates.append((m, hole))
    if not candidates:
        return None
    sa, Ta = _world_vertices(geometry, product, a)
    sb, Tb = _world_vertices(geometry, product, b)
    inter = _transformed(sa, Ta) ^ _transformed(sb, Tb)
    if inter.is_empty():
        return NominalContact(candidates[0][0].name, 0.0, 0.0)
    V = np.asarray(inter.to_mesh64().vert_properties, float)[:, :3]
    remaining = np.ones(len(V), bool)
    depth = 0.0
    used = None
    for m, hole in candidates:
        T = product.T_world_assembled(hole.part)
        axis = T[:3, :3] @ hole.axis
        mouth = T[:3, :3] @ hole.origin_m + T[:3, 3]
        r = 0.5 * hole.diameter_m
        d = V - mouth
        t = d @ axis  # <= 0 inside the hole
        rho = np.linalg.norm(d - np.outer(t, axis), axis=1)
        length = geometry.feature_depth(hole)
        wall = (np.abs(rho - r) <= band_m) & (t <= band_m + hole.chamfer_m) & (t >= -length - band_m)
        # a pin seated on a blind hole's floor touches it face to face
        floor = (np.abs(t + length) <= band_m) & (rho <= r + band_m) & (not hole.through)
        on = wall | floor
        if on[remaining].any():
            used = used or m.name
            w = wall & remaining
            f = floor & remaining & ~wall
            if w.any():
                depth = max(depth, float(rho[w].max() - rho[w].min()))
            if f.any():
                depth = max(depth, float(t[f].max() - t[f].min()))
        remaining &= ~on
    if remaining.any() or used is None:
        return None
    return NominalContact(used, depth, float(inter.volume()))


def mesh_hole_bound(geometry, part: str, feature: str) -> float | None:
    """Diametral error bound of a mesh part's hole: 2 x the sagitta of its widest wall chord.

    None when the part is not a mesh or the wall has too few vertices to tell.
    """
    if not geometry.shape(part).is_mesh:
        return None
    for h in geometry.holes(part):
        if h.feature != feature:
            continue
        mesh = geometry.mesh(part)
        V = np.asarray(mesh.vertices, float)
        T = h.T_part_hole
        d = V - T[:3, 3]
        t = d @ T[:3, 2]
        rad = d - np.outer(t, T[:3, 2])
        rho = np.linalg.norm(rad, axis=1)
        wall = (np.abs(rho - h.radius_m) <= max(1e-5, 0.01 * h.radius_m)) & (t <= 0) & (t >= -h.depth_m)
        if wall.sum() < 6:
            return None
        ang = np.sort(np.arctan2(rad[wall] @ T[:3, 1], rad[wall] @ T[:3, 0]))
        gaps = np.diff(np.concatenate([ang, [ang[0] + 2 * math.pi]]))
        gap = float(gaps.max())
        if gap >= math.pi / 2:
            return None
        # the mesh keeps the CAD's nominal hole: a fit's deviation cannot be built into it
        f = geometry.product.feature(part, feature)
        resized = abs(geometry.sizing.diameter(f) - f.diameter_m)
        return 2.0 * h.radius_m * (1.0 - math.cos(0.5 * gap)) + resized
    return None


__all__ = ["NominalContact", "mesh_hole_bound", "nominal_contact"]
