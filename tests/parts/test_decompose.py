"""Exact convex decomposition of blocks with holes (parts/decompose.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull

from asmplan.parts.decompose import (
    HoleSpec,
    block_with_holes_pieces,
    effective_clearance_range,
    piece_volume_m3,
    pieces_mass_properties,
)
from asmplan.parts.pieces import ConvexPiece

SIZE = (0.08, 0.05, 0.03)
HOLES = (
    HoleSpec((-0.02, 0.0), 0.005, None, 8),  # through
    HoleSpec((0.02, 0.006), 0.004, 0.018, 8),  # blind
    HoleSpec((0.02, -0.014), 0.003, 0.010, 12),  # blind, 12 sides
)


def _piece_mesh(piece: ConvexPiece) -> trimesh.Trimesh:
    if piece.kind == "box":
        assert piece.half_extents_m is not None
        mesh = trimesh.creation.box(extents=2 * piece.half_extents_m)
    else:
        assert piece.vertices_m is not None
        mesh = trimesh.convex.convex_hull(piece.vertices_m)
    mesh.apply_transform(piece.T_part_piece)
    return mesh


def _prism_xy(piece: ConvexPiece) -> tuple[np.ndarray, float, float]:
    """(vertices (n, 2) of the piece's cross-section hull, z_min, z_max) in the block frame."""
    v = _piece_mesh(piece).vertices
    pts = v[:, :2]
    h = ConvexHull(pts)
    return pts[h.vertices], float(v[:, 2].min()), float(v[:, 2].max())


def _point_polygon_distance(p: np.ndarray, poly: np.ndarray) -> float:
    """Distance from a point to a convex polygon (0 inside)."""
    n = len(poly)
    inside = True
    best = math.inf
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        ab = b - a
        t = np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0)
        best = min(best, float(np.linalg.norm(a + t * ab - p)))
        cross = ab[0] * (p - a)[1] - ab[1] * (p - a)[0]
        if cross < 0:
            inside = False
    # hull vertices from scipy are counter-clockwise
    return 0.0 if inside else best


def test_piece_count_per_hole_is_n_sides_plus_slab_for_blind_holes():
    pieces = block_with_holes_pieces(SIZE, HOLES)
    for i, hole in enumerate(HOLES):
        sides = [p for p in pieces if p.name.startswith(f"block/hole{i}/side")]
        slabs = [p for p in pieces if p.name == f"block/hole{i}/slab"]
        assert len(sides) == hole.n_sides
        assert len(slabs) == (0 if hole.depth_m is None else 1)
    assert len(pieces) == 8 + (8 + 1) + (12 + 1)


def test_union_volume_is_box_minus_hole_prisms_and_pieces_do_not_overlap():
    pieces = block_with_holes_pieces(SIZE, HOLES)
    expected = float(np.prod(SIZE))
    for hole in HOLES:
        depth = SIZE[2] if hole.depth_m is None else hole.depth_m
        expected -= hole.n_sides * hole.radius_m**2 * math.tan(math.pi / hole.n_sides) * depth
    total = sum(piece_volume_m3(p) for p in pieces)
    assert total == pytest.approx(expected, rel=1e-9)
    meshes = [_piece_mesh(p) for p in pieces]
    union = trimesh.boolean.union(meshes, engine="manifold")
    # Equal union and sum of volumes means the pieces do not overlap.
    assert union.volume == pytest.approx(expected, rel=1e-6)
    # And the union stays inside the block.
    assert np.all(union.bounds[0] >= -np.asarray(SIZE) / 2 - 1e-9)
    assert np.all(union.bounds[1] <= np.asarray(SIZE) / 2 + 1e-9)


@pytest.mark.parametrize("eps", [1e-6, 1e-5])
def test_pin_slightly_smaller_than_hole_touches_no_piece(eps):
    """Exact 2D math: every piece's cross-section stays >= r from each hole axis."""
    pieces = block_with_holes_pieces(SIZE, HOLES)
    top = SIZE[2] / 2
    for hole in HOLES:
        depth = SIZE[2] if hole.depth_m is None else hole.depth_m
        centre = np.asarray(hole.centre_xy_m)
        pin_r = hole.radius_m - eps
        z0, z1 = top - depth + eps, top + 0.01  # pin from just above the floor to above the top
        for piece in pieces:
            poly, pz0, pz1 = _prism_xy(piece)
            if pz1 <= z0 or pz0 >= z1:
                continue
            assert _point_polygon_distance(centre, poly) >= pin_r, (piece.name, hole)


def test_pin_slightly_smaller_than_hole_has_zero_overlap_volume_with_trimesh():
    pieces = block_with_holes_pieces(SIZE, HOLES[:2])
    union = trimesh.boolean.union([_piece_mesh(p) for p in pieces], engine="manifold")
    for hole in HOLES[:2]:
        depth = SIZE[2] if hole.depth_m is None else hole.depth_m
        length = depth - 1e-5
        pin = trimesh.creation.cylinder(radius=hole.radius_m - 1e-5, height=length, sections=256)
        pin.apply_translation([*hole.centre_xy_m, SIZE[2] / 2 - length / 2])
        inter = trimesh.boolean.intersection([union, pin], engine="manifold")
        assert inter.is_empty or inter.volume < 1e-15
        # A pin 0.1 mm LARGER than the nominal hole does hit material.
        big = trimesh.creation.cylinder(radius=hole.radius_m + 1e-4, height=length, sections=256)
        big.apply_translation([*hole.centre_xy_m, SIZE[2] / 2 - length / 2])
        assert trimesh.boolean.intersection([union, big], engine="manifold").volume > 1e-10


def test_effective_clearance_range_matches_polygon_geometry():
    c = 1e-4
    lo, hi = effective_clearance_range(c, 8)
    assert lo == c
    assert hi == pytest.approx(c / math.cos(math.pi / 8))
    assert hi / lo - 1 == pytest.approx(0.0824, abs=5e-4)  # about 8 % extra play at n = 8
    # Geometric check: a pin of radius r - c moved toward a polygon vertex touches the two
    # adjacent edges after c / cos(pi/n).
    hole = HoleSpec((0.0, 0.0), 0.005, None, 8)
    poly = hole.polygon_xy_m()
    vertex_dir = poly[0] / np.linalg.norm(poly[0])
    d = hi
    centre = d * vertex_dir
    normals = [np.array([math.cos(a), math.sin(a)]) for a in (0.0, math.pi / 4)]
    gaps = [hole.radius_m - centre @ n - (hole.radius_m - c) for n in normals]
    assert gaps == pytest.approx([0.0, 0.0], abs=1e-12)
    with pytest.raises(ValueError, match="radial_clearance_m"):
        effective_clearance_range(-1e-3, 8)


def test_hole_cutting_the_block_side_is_rejected_with_its_wall_thickness():
    with pytest.raises(ValueError, match="wall thickness"):
        block_with_holes_pieces((0.02, 0.02, 0.01), (HoleSpec((0.008, 0.0), 0.003),))
    with pytest.raises(ValueError, match=r"meets another hole|wall thickness"):
        block_with_holes_pieces(
            (0.05, 0.02, 0.01), (HoleSpec((0.0, 0.0), 0.004), HoleSpec((0.007, 0.0), 0.004))
        )
    with pytest.raises(ValueError, match="n_sides"):
        HoleSpec((0.0, 0.0), 0.003, None, 2)


def test_block_without_holes_is_one_exact_box():
    (piece,) = block_with_holes_pieces(SIZE, ())
    assert piece.kind == "box"
    assert np.allclose(piece.half_extents_m, np.asarray(SIZE) / 2)


def test_mass_properties_of_pieces_match_the_solid_block_minus_holes():
    hole = HoleSpec((0.0, 0.0), 0.005, None, 8)
    pieces = block_with_holes_pieces(SIZE, (hole,))
    rho = 2700.0
    mass, com, inertia = pieces_mass_properties(pieces, rho)
    a, b, c = SIZE
    prism_area = hole.polygon_area_m2()
    assert mass == pytest.approx(rho * (a * b * c - prism_area * c), rel=1e-9)
    assert np.allclose(com, 0.0, atol=1e-12)
    # Inertia of the box minus the (convex) hole prism, both from trimesh.
    box = trimesh.creation.box(extents=SIZE)
    poly = hole.polygon_xy_m()
    prism = trimesh.convex.convex_hull(
        np.vstack([np.column_stack([poly, np.full(len(poly), z)]) for z in (-c / 2, c / 2)])
    )
    box.density = rho
    prism.density = rho
    expected = box.moment_inertia - prism.moment_inertia
    assert np.allclose(inertia, expected, rtol=1e-6, atol=1e-12)
