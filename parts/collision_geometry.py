"""The pure-geometry side of the collision world (no FCL): the contact record, the pieces'
bounding boxes and vertex sets, and the axis test of an exact sweep. Split out of
:mod:`asmplan.parts.collision` (the FCL module), which re-exports :class:`Contact`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .pieces import ConvexPiece

BOX_SIGNS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
"""The eight corners of a unit half-extent box, (8, 3)."""


@dataclass(frozen=True, eq=False)
class Contact:
    """The deepest contact between two named objects.

    Parameters
    ----------
    a, b : str
        The two names (``a < b`` from :meth:`CollisionWorld.contacts`).
    depth_m : float
        Penetration depth, metres (> the tolerance that reported it).
    point_m : (3,) float array
        World position of the deepest contact point.
    """

    a: str
    b: str
    depth_m: float
    point_m: np.ndarray


def piece_local_extent(piece: ConvexPiece) -> np.ndarray:
    """Corners (8, 3) of the piece's bounding box in the piece frame."""
    if piece.kind == "box":
        return BOX_SIGNS * np.asarray(piece.half_extents_m)
    if piece.kind == "cylinder":
        return BOX_SIGNS * np.array([piece.radius_m, piece.radius_m, 0.5 * piece.length_m])
    if piece.kind == "sphere":
        return BOX_SIGNS * piece.radius_m
    v = np.asarray(piece.vertices_m)
    lo, hi = v.min(axis=0), v.max(axis=0)
    return 0.5 * (lo + hi) + BOX_SIGNS * 0.5 * (hi - lo)


def along_local_axis(R: np.ndarray, u: np.ndarray, dist: float) -> int | None:
    """Index of the local axis (columns of R) parallel to ``u`` closely enough that the
    sideways drift over ``dist`` is below 1 nm, else None. Cylinders: only their z axis."""
    for k in range(3):
        s = float(np.linalg.norm(np.cross(R[:, k], u)))
        if s * dist < 1e-9:
            return k
    return None


def piece_points_world(pc: ConvexPiece, T: np.ndarray, tol_m: float = 1e-6) -> np.ndarray:
    """Points (n, 3) whose hull contains the piece (exactly for boxes and hulls; cylinders by
    a circumscribed polygon within ``tol_m``)."""
    if pc.kind == "box":
        local = BOX_SIGNS * pc.half_extents_m
    elif pc.kind == "hull":
        local = np.asarray(pc.vertices_m)
    else:  # cylinder (spheres are capsules)
        local = circumscribed_prism_points(pc.radius_m, pc.length_m, tol_m)
    return local @ T[:3, :3].T + T[:3, 3]


def circumscribed_prism_points(radius_m: float, length_m: float, tol_m: float = 1e-6
                               ) -> np.ndarray:
    """Vertices (2n, 3) of a regular prism circumscribing a z-axis cylinder centred on the
    origin within ``tol_m`` (n = 8, 16, 32, ... up to 4096 sides)."""
    n = 8
    while radius_m * (1.0 / math.cos(math.pi / n) - 1.0) > tol_m and n < 4096:
        n *= 2
    ang = 2.0 * math.pi * np.arange(n) / n
    R = radius_m / math.cos(math.pi / n)
    ring = np.stack([R * np.cos(ang), R * np.sin(ang)], axis=1)
    h = 0.5 * length_m
    return np.concatenate([np.column_stack([ring, np.full(n, -h)]),
                           np.column_stack([ring, np.full(n, h)])])


def swept_aabb(corners_part: np.ndarray, T_world_part: np.ndarray, delta: np.ndarray
               ) -> np.ndarray:
    """World AABB (2, 3) of the volume swept by a piece whose bounding-box corners are
    ``corners_part`` (8, 3), part frame, under the translation ``delta`` (world)."""
    corners = corners_part @ T_world_part[:3, :3].T + T_world_part[:3, 3]
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    return np.stack([np.minimum(lo, lo + delta), np.maximum(hi, hi + delta)])
