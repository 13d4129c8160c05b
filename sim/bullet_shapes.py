"""Shapes the PyBullet world builds, as data (no pybullet call): the compound child limit,
frame helpers, the Wavefront OBJ text of a part's hulls, and the margin-free hulls that
stand for boxes and cylinders (inscribed prisms)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..parts.pieces import ConvexPiece
from ..planner.trajectory import quat_xyzw_from_matrix

MAX_COMPOUND_CHILDREN = 16
"""PyBullet drops compound children beyond this count silently."""


def pose_to_pq(T: np.ndarray) -> tuple[list[float], list[float]]:
    """(4, 4) homogeneous transform -> (position list (3,), quaternion xyzw list (4,))."""
    T = np.asarray(T, dtype=float)
    return T[:3, 3].tolist(), quat_xyzw_from_matrix(T[:3, :3]).tolist()


def principal_frame(inertia_kgm2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (3,) and a proper rotation (3, 3) whose columns are the axes."""
    inertia = np.asarray(inertia_kgm2, dtype=float)
    sym = 0.5 * (inertia + inertia.T)
    moments, axes = np.linalg.eigh(sym)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes


_OBJ_CACHE: dict[bytes, str] = {}
_OBJ_CACHE_MAX = 512


def _hulls_obj_text(hulls: Sequence[ConvexPiece], units_per_m: float) -> str:
    """Wavefront OBJ text with one object per hull (vertices in the body frame), cached by
    content: a part is built in several steps' worlds, its hulls are computed once."""
    import hashlib

    h = hashlib.blake2b(digest_size=20)
    h.update(repr(units_per_m).encode())
    for pc in hulls:
        assert pc.vertices_m is not None
        h.update(np.ascontiguousarray(pc.vertices_m, dtype=float).tobytes())
        h.update(np.ascontiguousarray(pc.T_part_piece, dtype=float).tobytes())
        h.update(b"|")
    key = h.digest()
    text = _OBJ_CACHE.get(key)
    if text is not None:
        return text
    from ..parts.mesh import convex_hull

    lines = []
    offset = 1
    for k, pc in enumerate(hulls):
        assert pc.vertices_m is not None
        R, t = pc.T_part_piece[:3, :3], pc.T_part_piece[:3, 3]
        hull = convex_hull((pc.vertices_m @ R.T + t) * units_per_m)
        lines.append(f"o hull{k}")
        lines.extend(f"v {x!r} {y!r} {z!r}" for x, y, z in hull.vertices.tolist())
        lines.extend(
            f"f {i + offset} {j + offset} {m + offset}" for i, j, m in hull.faces.tolist()
        )
        offset += len(hull.vertices)
    text = "\n".join(lines) + "\n"
    if len(_OBJ_CACHE) >= _OBJ_CACHE_MAX:
        _OBJ_CACHE.clear()
    _OBJ_CACHE[key] = text
    return text


def _is_compound(group: Sequence[ConvexPiece]) -> bool:
    """Whether PyBullet builds a compound shape for this collision-shape group.

    Several hulls (OBJ objects) or several primitives make a compound; one primitive too when
    it has a collision-frame offset; one hull or one primitive at the identity do not.
    """
    if len(group) != 1:
        return True
    piece = group[0]
    return piece.kind != "hull" and not np.array_equal(piece.T_part_piece, np.eye(4))


PRISM_TOLERANCE_FRACTION = 0.05
"""A cylinder is simulated as a prism inscribed in it whose radial error ``r (1 - cos(pi/n))``
is at most this fraction of the preset's interference resolution
(``Fidelity.interference_resolution_m``), so the fit's clearance changes by at most a
tenth of it: 2.5 um at BALANCED (a 10 mm pin gets 100 sides), 1 um at ACCURATE (160 sides),
20 um at FAST (36 sides)."""

PRISM_MIN_SIDES = 16
PRISM_MAX_SIDES = 256


def prism_sides(radius_m: float, tolerance_m: float) -> int:
    """Fewest sides (a multiple of 4, within [16, 256]) of a prism inscribed in a circle of
    ``radius_m`` whose faces are at most ``tolerance_m`` inside it: r (1 - cos(pi/n)) <= tol."""
    if not (radius_m > 0 and tolerance_m > 0):
        raise ValueError(f"prism_sides: expected positive radius and tolerance, found "
                         f"{radius_m}, {tolerance_m}")
    ratio = min(1.0, tolerance_m / radius_m)
    n = math.pi / math.acos(1.0 - ratio) if ratio < 1.0 else 4.0
    n = 4 * math.ceil(n / 4 - 1e-9)
    return int(min(PRISM_MAX_SIDES, max(PRISM_MIN_SIDES, n)))


def exact_hull(piece: ConvexPiece, tolerance_m: float) -> ConvexPiece:
    """The margin-free hull PyBullet simulates for a box or cylinder piece (same frame).

    PyBullet's GEOM_BOX and GEOM_CYLINDER keep their collision margin (1 mm) inside the shape:
    faces sit where declared but every edge and rim is rounded by the margin (a probe off a
    10 mm box's edge measures 0.41 mm too far, off a cylinder's rim likewise). A hull with
    zero margin has sharp edges. A box becomes its 8 corners; a cylinder a prism inscribed in
    it (never larger than the part, so a fit never turns into an interference) with
    :func:`prism_sides` sides, a vertex on the piece's +x axis. Hulls and spheres are
    returned unchanged (a sphere's margin is its radius: exact)."""
    if piece.kind == "box":
        assert piece.half_extents_m is not None
        h = np.asarray(piece.half_extents_m, dtype=float)
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                           dtype=float) * h
        return ConvexPiece(kind="hull", T_part_piece=piece.T_part_piece, vertices_m=corners,
                           name=piece.name)
    if piece.kind == "cylinder":
        n = prism_sides(piece.radius_m, tolerance_m)
        ang = 2.0 * math.pi * np.arange(n) / n
        ring = np.column_stack([piece.radius_m * np.cos(ang), piece.radius_m * np.sin(ang)])
        half = 0.5 * piece.length_m
        verts = np.vstack([np.column_stack([ring, np.full(n, -half)]),
                           np.column_stack([ring, np.full(n, half)])])
        return ConvexPiece(kind="hull", T_part_piece=piece.T_part_piece, vertices_m=verts,
                           name=piece.name)
    return piece
