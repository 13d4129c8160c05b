"""Exact convex decomposition of a block with cylindrical holes (never V-HACD).

A hole is modelled by a regular ``n``-gon prism whose INSCRIBED circle is the nominal hole
circle: material never reaches inside the nominal radius, so a pin that fits the real hole
can never pass through material in the model, and the clearance seen in the directions of
the polygon's face normals is exact. Toward the polygon's vertices the hole is wider: a pin
with nominal radial clearance ``c`` can move ``c / cos(pi / n)`` there, i.e. the model adds
``c (1 / cos(pi / n) - 1)`` of lateral play (8.2 % of ``c`` at ``n = 8``, 2.0 % at 16);
:func:`effective_clearance_range` returns that range. The polygon is oriented so that one
face normal points along the block's +x axis.

Decomposition
-------------
The block's cross-section (x, y) is split into convex cells, one per hole, by the
perpendicular bisectors between hole centres (a Voronoi partition clipped to the rectangle).
In each cell, piece ``k`` of the hole is

    (angular sector between the rays from the hole centre through the polygon's vertices
     k and k+1)  intersect  (cell)  minus  (the half-plane inside polygon edge k),

a convex polygon, extruded over the hole depth from the block's top face (+z) down. A blind
hole adds one slab (the whole cell) under it. Each hole therefore yields exactly ``n_sides``
pieces (+1 slab if blind), the pieces do not overlap, and their union is the block minus the
hole prisms.

Frames: the block frame is centred on the block, holes open on the top face ``z = +h/2``.
Lengths are metres.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .mesh import convex_hull
from .pieces import ConvexPiece

_AREA_EPS_M2 = 1e-14


@dataclass(frozen=True)
class HoleSpec:
    """A cylindrical hole along the block's local z axis, opening on the top face.

    Parameters
    ----------
    centre_xy_m : (float, float)
        Hole axis position in the block frame, m.
    radius_m : float
        Nominal hole radius, m (the inscribed radius of the modelling polygon).
    depth_m : float or None
        Depth from the top face, m; None (or >= block height) for a through hole.
    n_sides : int
        Sides of the modelling polygon (>= 3).
    """

    centre_xy_m: tuple[float, float]
    radius_m: float
    depth_m: float | None = None
    n_sides: int = 8

    def __post_init__(self) -> None:
        c = tuple(float(v) for v in self.centre_xy_m)
        if len(c) != 2 or not all(math.isfinite(v) for v in c):
            raise ValueError(f"HoleSpec.centre_xy_m: expected 2 finite numbers, found {c}")
        object.__setattr__(self, "centre_xy_m", c)
        if not (math.isfinite(self.radius_m) and self.radius_m > 0):
            raise ValueError(f"HoleSpec.radius_m: expected > 0, found {self.radius_m}")
        if self.depth_m is not None and not (math.isfinite(self.depth_m) and self.depth_m > 0):
            raise ValueError(f"HoleSpec.depth_m: expected > 0 or None, found {self.depth_m}")
        if int(self.n_sides) != self.n_sides or self.n_sides < 3:
            raise ValueError(f"HoleSpec.n_sides: expected an integer >= 3, found {self.n_sides}")

    @property
    def circumradius_m(self) -> float:
        """Distance from the axis to the polygon's vertices, m."""
        return self.radius_m / math.cos(math.pi / self.n_sides)

    def polygon_xy_m(self) -> np.ndarray:
        """Vertices (n, 2) of the modelling polygon, counter-clockwise, block frame."""
        n = self.n_sides
        ang = 2.0 * math.pi * (np.arange(n) + 0.5) / n
        c = np.asarray(self.centre_xy_m)
        return c + self.circumradius_m * np.stack([np.cos(ang), np.sin(ang)], axis=1)

    def polygon_area_m2(self) -> float:
        """Area of the modelling polygon, m^2 (``n r^2 tan(pi/n)``)."""
        return self.n_sides * self.radius_m**2 * math.tan(math.pi / self.n_sides)


def effective_clearance_range(radial_clearance_m: float, n_sides: int) -> tuple[float, float]:
    """Range of lateral play of a pin in a hole modelled by an inscribed ``n``-gon.

    A pin of radius ``r - c`` in a hole of nominal radius ``r`` modelled by a regular
    ``n``-gon whose inscribed circle has radius ``r`` can move ``c`` toward a face (exact) and
    ``c / cos(pi / n)`` toward a vertex (it then touches the two edges adjacent to it).

    Parameters
    ----------
    radial_clearance_m : float
        Nominal radial clearance ``c`` (half the diametral clearance), m, >= 0.
    n_sides : int

    Returns
    -------
    (min_play_m, max_play_m) : tuple of float
        Smallest and largest radial play, m. Multiply by 2 for diametral values.
    """
    if radial_clearance_m < 0:
        raise ValueError(f"radial_clearance_m: expected >= 0, found {radial_clearance_m}")
    if n_sides < 3:
        raise ValueError(f"n_sides: expected >= 3, found {n_sides}")
    return radial_clearance_m, radial_clearance_m / math.cos(math.pi / n_sides)


# --------------------------------------------------------------------------------------------
# 2D convex polygon helpers
# --------------------------------------------------------------------------------------------
def clip_halfplane(poly: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """Clip a convex polygon (m, 2) to the half-plane ``normal . p <= offset``.

    Sutherland-Hodgman for one edge; returns the (k, 2) clipped polygon (k may be 0).
    """
    if poly.shape[0] == 0:
        return poly
    d = poly @ normal - offset
    out: list[np.ndarray] = []
    m = poly.shape[0]
    for i in range(m):
        p, q = poly[i], poly[(i + 1) % m]
        dp, dq = d[i], d[(i + 1) % m]
        if dp <= 0:
            out.append(p)
        if (dp < 0 < dq) or (dq < 0 < dp):
            t = dp / (dp - dq)
            out.append(p + t * (q - p))
    if not out:
        return np.zeros((0, 2))
    res = np.array(out)
    # Drop consecutive duplicates produced by vertices on the line.
    keep = np.ones(res.shape[0], dtype=bool)
    for i in range(res.shape[0]):
        if np.linalg.norm(res[i] - res[i - 1]) < 1e-15 and res.shape[0] > 1:
            keep[i] = False
    return res[keep]


def polygon_area(poly: np.ndarray) -> float:
    """Signed area of a polygon (m, 2), positive when counter-clockwise."""
    if poly.shape[0] < 3:
        return 0.0
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _cells(size_xy: np.ndarray, centres: np.ndarray) -> list[np.ndarray]:
    hx, hy = size_xy / 2.0
    rect = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
    cells = []
    for i, ci in enumerate(centres):
        cell = rect
        for j, cj in enumerate(centres):
            if i == j:
                continue
            nrm = cj - ci
            mid = 0.5 * (ci + cj)
            cell = clip_halfplane(cell, nrm, float(nrm @ mid))
        cells.append(cell)
    return cells


def _prism_piece(poly: np.ndarray, z0: float, z1: float, name: str) -> ConvexPiece:
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    is_rect = poly.shape[0] == 4 and all(
        (abs(p[0] - lo[0]) < 1e-12 or abs(p[0] - hi[0]) < 1e-12)
        and (abs(p[1] - lo[1]) < 1e-12 or abs(p[1] - hi[1]) < 1e-12)
        for p in poly
    )
    T = np.eye(4)
    if is_rect:
        T[:3, 3] = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (z0 + z1) / 2]
        half = np.array([(hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2, (z1 - z0) / 2])
        return ConvexPiece(kind="box", T_part_piece=T, half_extents_m=half, name=name)
    verts = np.concatenate(
        [np.column_stack([poly, np.full(len(poly), z0)]), np.column_stack([poly, np.full(len(poly), z1)])]
    )
    centre = verts.mean(axis=0)
    T[:3, 3] = centre
    return ConvexPiece(kind="hull", T_part_piece=T, vertices_m=verts - centre, name=name)


def block_with_holes_pieces(
    size_m: Sequence[float], holes: Sequence[HoleSpec], name: str = "block"
) -> tuple[ConvexPiece, ...]:
    """Exact convex pieces of a rectangular block with holes along its local z axis.

    Parameters
    ----------
    size_m : (3,) float
        Full block size (x, y, z), m. The block frame is at the block's centre.
    holes : sequence of HoleSpec
        Holes opening on the top face (z = +size_m[2] / 2).
    name : str
        Prefix of the pieces' names.

    Returns
    -------
    tuple of ConvexPiece
        For each hole, in order, ``n_sides`` ring pieces ("<name>/hole<i>/side<k>") then, for a
        blind hole, one slab ("<name>/hole<i>/slab"). A block without holes is one box.

    Raises
    ------
    ValueError
        If a hole's polygon is not strictly inside its cell (it would cut the block's side or
        meet another hole).
    """
    size = np.asarray(size_m, dtype=float)
    if size.shape != (3,) or np.any(~np.isfinite(size)) or np.any(size <= 0):
        raise ValueError(f"size_m: expected 3 positive numbers, found {size.tolist()}")
    holes = tuple(holes)
    z_top, z_bot = size[2] / 2.0, -size[2] / 2.0
    if not holes:
        return (
            ConvexPiece(kind="box", T_part_piece=np.eye(4), half_extents_m=size / 2.0, name=name),
        )
    centres = np.array([h.centre_xy_m for h in holes], dtype=float)
    for i in range(len(holes)):
        for j in range(i + 1, len(holes)):
            if np.linalg.norm(centres[i] - centres[j]) < 1e-9:
                raise ValueError(
                    f"holes {i} and {j}: expected distinct centres, found both at "
                    f"{centres[i].tolist()}"
                )
    cells = _cells(size[:2], centres)
    pieces: list[ConvexPiece] = []
    for i, (hole, cell) in enumerate(zip(holes, cells, strict=True)):
        poly = hole.polygon_xy_m()
        # Polygon strictly inside the cell: every vertex inside every cell edge.
        m = cell.shape[0]
        for e in range(m):
            a, b = cell[e], cell[(e + 1) % m]
            edge = b - a
            inward = np.array([-edge[1], edge[0]]) / np.linalg.norm(edge)
            wall = float(np.min((poly - a) @ inward))
            if wall <= 1e-9:
                raise ValueError(
                    f"hole {i} at {list(hole.centre_xy_m)} (radius {hole.radius_m}, "
                    f"{hole.n_sides} sides): expected its polygon strictly inside its cell, "
                    f"found a wall thickness of {wall:.3g} m (hole cuts the block side or "
                    f"meets another hole)"
                )
        depth = size[2] if hole.depth_m is None else min(float(hole.depth_m), float(size[2]))
        z_floor = z_top - depth
        c = np.asarray(hole.centre_xy_m)
        n = hole.n_sides
        for k in range(n):
            phi = 2.0 * math.pi * k / n
            a0, a1 = phi - math.pi / n, phi + math.pi / n
            d0 = np.array([math.cos(a0), math.sin(a0)])
            d1 = np.array([math.cos(a1), math.sin(a1)])
            nrm = np.array([math.cos(phi), math.sin(phi)])
            piece = cell
            # Counter-clockwise of ray d0: cross(d0, p - c) >= 0  <=>  (-n0) . (p - c) <= 0.
            n0 = np.array([d0[1], -d0[0]])  # cross(d0, v) = -(n0 . v)
            piece = clip_halfplane(piece, n0, float(n0 @ c))
            n1 = np.array([-d1[1], d1[0]])  # clockwise of ray d1
            piece = clip_halfplane(piece, n1, float(n1 @ c))
            piece = clip_halfplane(piece, -nrm, float(-nrm @ c - hole.radius_m))
            if abs(polygon_area(piece)) <= _AREA_EPS_M2:
                raise ValueError(f"hole {i} side {k}: degenerate piece (area ~0)")
            pieces.append(_prism_piece(piece, z_floor, z_top, f"{name}/hole{i}/side{k}"))
        if z_floor > z_bot + 1e-12:
            pieces.append(_prism_piece(cell, z_bot, z_floor, f"{name}/hole{i}/slab"))
    return tuple(pieces)


# --------------------------------------------------------------------------------------------
# Mass properties
# --------------------------------------------------------------------------------------------
def piece_volume_m3(piece: ConvexPiece) -> float:
    """Volume of one piece, m^3 (hulls through their convex hull)."""
    if piece.kind == "box":
        assert piece.half_extents_m is not None
        return float(8.0 * np.prod(piece.half_extents_m))
    if piece.kind == "cylinder":
        return math.pi * piece.radius_m**2 * piece.length_m
    if piece.kind == "sphere":
        return 4.0 / 3.0 * math.pi * piece.radius_m**3
    assert piece.vertices_m is not None
    return convex_hull(piece.vertices_m).volume


def pieces_mass_properties(
    pieces: Sequence[ConvexPiece], density_kg_m3: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and inertia of a union of NON-overlapping pieces.

    Parameters
    ----------
    pieces : sequence of ConvexPiece
    density_kg_m3 : float

    Returns
    -------
    mass_kg : float
    com_m : (3,) float array, part frame.
    inertia_kgm2 : (3, 3) float array about the centre of mass, part axes.
    """
    items: list[tuple[float, np.ndarray, np.ndarray]] = []  # (mass, centre, inertia in part axes)
    for pc in pieces:
        R = pc.T_part_piece[:3, :3]
        centre = pc.T_part_piece[:3, 3].copy()
        if pc.kind == "box":
            assert pc.half_extents_m is not None
            h = pc.half_extents_m
            m = density_kg_m3 * 8.0 * float(np.prod(h))
            sq = h**2
            inertia_local = m / 3.0 * np.diag([sq[1] + sq[2], sq[0] + sq[2], sq[0] + sq[1]])
        elif pc.kind == "cylinder":
            r, length = pc.radius_m, pc.length_m
            m = density_kg_m3 * math.pi * r * r * length
            ixx = m * (3 * r * r + length * length) / 12.0
            inertia_local = np.diag([ixx, ixx, m * r * r / 2.0])
        elif pc.kind == "sphere":
            m = density_kg_m3 * 4.0 / 3.0 * math.pi * pc.radius_m**3
            inertia_local = np.eye(3) * 0.4 * m * pc.radius_m**2
        else:
            assert pc.vertices_m is not None
            hull = convex_hull(pc.vertices_m)
            m = density_kg_m3 * hull.volume
            local_com = np.asarray(hull.center_mass)
            inertia_local = hull.moment_inertia * density_kg_m3
            centre = centre + R @ local_com
        items.append((m, centre, R @ inertia_local @ R.T))
    mass = sum(m for m, _, _ in items)
    if mass <= 0:
        raise ValueError(f"pieces_mass_properties: expected positive mass, found {mass}")
    com = sum(m * c for m, c, _ in items) / mass
    inertia = np.zeros((3, 3))
    for m, c, inertia_c in items:
        d = c - com
        inertia += inertia_c + m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    return float(mass), np.asarray(com), inertia
