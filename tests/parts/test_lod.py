"""Levels of detail and their measured error (parts/lod.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from asmplan.knowledge.frames import frame_from_axis, make_T
from asmplan.parts.decompose import piece_volume_m3
from asmplan.parts.geometry import (
    BodyShape,
    CylinderSection,
    GeometrySettings,
    HoleShape,
    PartShape,
    body_solid,
    hole_solid,
    manifold_to_trimesh,
    part_shape,
    polygon_excess,
    shape_solid,
)
from asmplan.parts.lod import bodies, convex_pieces, exact_model, hole_sides
from asmplan.parts.lod_measure import effective_clearance, hausdorff, model_solid
from asmplan.parts.models import ProductGeometry
from asmplan.parts.pieces import CollisionModel, ConvexPiece
from asmplan.parts.primitive_pieces import convex_sides

SETTINGS = GeometrySettings()
TOL = SETTINGS.exact_tolerance_m

BLOCK_10MM = """
parts:
  - name: block
    material: steel
    pose: {xyz: [0, 0, 10]}
    geometry:
      type: box
      size: [40, 40, 20]
      holes: [{name: h, at: [0, 0, 10], diameter: 10, depth: 15, chamfer: 0.5}]
"""


@pytest.mark.parametrize(("clearance_mm", "expected_sides"), [(1.0, 12), (0.1, 12), (0.02, 8)])
def test_ten_mm_hole_keeps_its_clearance_in_convex_pieces_but_not_in_one_hull(
        make_product, clearance_mm, expected_sides):
    shape = part_shape(make_product(BLOCK_10MM).part("block"))
    (hole,) = shape.holes
    c = clearance_mm / 2e3  # radial
    sides = hole_sides(shape, {"h": c}, SETTINGS)
    assert sides["h"].n_sides == expected_sides
    bound = sides["h"].play_bound_m
    assert bound == pytest.approx(2 * c * (1 / math.cos(math.pi / expected_sides) - 1))
    assert bound <= max(SETTINGS.convex_play_fraction * 2 * c, 2 * SETTINGS.convex_play_floor_m)

    pieces, _ = convex_pieces(shape, sides, SETTINGS)
    assert all(len(group) <= 16 for group in bodies(CollisionModel("convex", pieces)))
    lo, hi = effective_clearance(CollisionModel("convex", pieces), hole, c, SETTINGS)
    err_convex = max(abs(lo - 2 * c), abs(hi - 2 * c))
    assert lo == pytest.approx(2 * c, abs=2e-9)  # exact towards the polygon's faces
    assert err_convex <= bound + 2e-9  # within the stated bound ...
    assert err_convex >= 0.99 * bound  # ... which the corners reach

    # the single convex hull of the holed block (what a V-HACD-like blob does at worst) fills
    # the hole: the probe pin cannot even be centred in it
    exact = manifold_to_trimesh(shape_solid(shape, TOL))
    hull = exact.convex_hull
    centre = hull.bounds.mean(axis=0)
    one_hull = CollisionModel("coarse", (ConvexPiece(kind="hull", T_part_piece=make_T(centre),
                                                     vertices_m=np.asarray(hull.vertices) - centre),))
    lo_h, hi_h = effective_clearance(one_hull, hole, c, SETTINGS)
    err_hull = max(abs(lo_h - 2 * c), abs(hi_h - 2 * c))
    assert hi_h < 0
    assert err_hull > 2 * c + 1e-3  # more than the whole clearance plus a millimetre
    assert err_hull > 100 * max(err_convex, 1e-6)


def test_piece_count_follows_the_clearance_rule():
    r = 5e-3
    for c in (1e-6, 10e-6, 50e-6, 0.5e-3, 2e-3):
        n = convex_sides(r, c, SETTINGS)
        tol = max(SETTINGS.convex_play_fraction * c, SETTINGS.convex_play_floor_m)
        assert polygon_excess(c, n) <= tol or n == max(SETTINGS.convex_sides)
        assert polygon_excess(r, n) <= SETTINGS.convex_max_hausdorff_m
        smaller = [m for m in SETTINGS.convex_sides if m < n]
        for m in smaller:  # n is the smallest that meets both bounds
            assert polygon_excess(c, m) > tol or polygon_excess(r, m) > SETTINGS.convex_max_hausdorff_m


def test_convex_block_hausdorff_is_the_polygon_corner_recess(make_product):
    p = make_product(BLOCK_10MM.replace(", chamfer: 0.5", ""))
    shape = part_shape(p.part("block"))
    sides = hole_sides(shape, {"h": 10e-6}, SETTINGS)
    n = sides["h"].n_sides
    pieces, _ = convex_pieces(shape, sides, SETTINGS)
    h = hausdorff(shape_solid(shape, TOL), model_solid(CollisionModel("convex", pieces)), 400, 0)
    assert h == pytest.approx(polygon_excess(5e-3, n), rel=0.01)


def test_coarse_hull_of_a_block_with_a_blind_hole_misses_by_the_hole(make_product):
    g = ProductGeometry(make_product(BLOCK_10MM))
    report = g.level_report("block", "coarse")
    # the hull is the block: a point of the hole wall at height z (-5..10 mm, block -10..10 mm)
    # is min(10 - z, z + 10, 15) mm from it, at most 10 mm (z = 0); sampling finds at most that
    assert 9e-3 < report.hausdorff_m <= 10e-3 + 1e-6
    assert report.hole_clearance_error_m > 5e-3
    assert g.collision_model("block", "coarse").pieces[0].kind == "hull"


def test_exact_level_uses_primitives_where_it_can(examples):
    g = ProductGeometry(examples["pinhole_station"])
    part4 = g.collision_model("part4", "exact")  # box with two chamfered pins, no hole
    assert part4.mesh_faces is None
    assert sorted(pc.kind for pc in part4.pieces) == ["box", "cylinder", "cylinder", "hull", "hull"]
    part1 = g.collision_model("part1", "exact")  # box with holes: one BVH
    assert part1.mesh_faces is not None and part1.pieces == ()
    part2 = g.collision_model("part2", "exact")  # holes and pins: BVH + pin primitives
    assert part2.mesh_faces is not None
    assert sum(pc.kind == "cylinder" for pc in part2.pieces) == 2


@pytest.mark.slow
def test_every_example_part_has_a_convex_model_within_its_bounds(examples):
    for product in examples.values():
        g = ProductGeometry(product)
        for name in product.part_names:
            report = g.level_report(name, "convex")
            model = g.collision_model(name, "convex")
            assert model.hausdorff_m == report.hausdorff_m
            assert report.hausdorff_m <= SETTINGS.convex_max_hausdorff_m + 1e-6, name
            for hole in report.holes:
                assert hole.error_m <= hole.bound_m + 2e-9, (name, hole)


def _box_with_hole(size, centre_xy, radius, depth, chamfer, through, n):
    half = np.asarray(size) / 2
    body = BodyShape("box", np.eye(4), half_extents_m=half)
    mouth = [centre_xy[0], centre_xy[1], half[2]]
    hole = HoleShape("h", frame_from_axis(mouth, [0, 0, 1]), radius, size[2] + 1e-3 if through else depth,
                     through, chamfer)
    return PartShape("x", (body,), (hole,), ()), body, hole


@settings(max_examples=25, deadline=None)
@given(sx=st.floats(0.02, 0.08), sy=st.floats(0.02, 0.08), sz=st.floats(0.005, 0.04),
       fx=st.floats(-0.5, 0.5), fy=st.floats(-0.5, 0.5), fr=st.floats(0.05, 0.3),
       fd=st.floats(0.2, 0.9), through=st.booleans(), fc=st.floats(0.0, 0.4),
       c=st.sampled_from([1e-6, 20e-6, 0.5e-3]))
def test_convex_pieces_have_the_volume_of_the_same_polygon_cut(sx, sy, sz, fx, fy, fr, fd, through, fc, c):
    # invariant: the pieces tile the block minus the hole's polygon prism and chamfer exactly
    radius = fr * min(sx, sy) / 2
    # a chamfer deeper than a blind hole is invalid input (the loader refuses it)
    assume(through or fc * radius < 0.9 * fd * sz)
    x, y = fx * (sx / 2 - 1.5 * radius), fy * (sy / 2 - 1.5 * radius)
    shape, body, hole = _box_with_hole((sx, sy, sz), (x, y), radius, fd * sz, fc * radius, through, 0)
    sides = hole_sides(shape, {"h": c}, SETTINGS)
    pieces, _ = convex_pieces(shape, sides, SETTINGS)
    v_pieces = sum(piece_volume_m3(pc) for pc in pieces)
    cut = body_solid(body, TOL) - hole_solid(hole, TOL, n_sides=sides["h"].n_sides)
    # relative 1e-7 (~0.01 mm^3 here): a nanometre chamfer leaves slivers above 1e-9
    assert v_pieces == pytest.approx(cut.volume(), rel=1e-7, abs=1e-15)


@pytest.mark.xfail(strict=True, reason=(
    "known defect, found by random exploration: a shallow blind hole (1.39 mm) with a 0.32 mm "
    "mouth chamfer 8 mm from a block corner: the convex pieces hold 0.03 mm^3 (1.7e-6 relative) "
    "more than the polygon cut, so part of the chamfer is not cut from them; not yet explained"))
def test_convex_pieces_of_a_shallow_chamfered_hole_near_a_corner_have_the_cut_volume():
    inner = test_convex_pieces_have_the_volume_of_the_same_polygon_cut.hypothesis.inner_test
    inner(sx=0.05, sy=0.04919053263687363, sz=0.006932168992444677, fx=-0.4134400259032307,
          fy=-0.4134400259032307, fr=0.2597622686425183, fd=0.2, through=False,
          fc=0.006932168992444677, c=1e-06)


@settings(max_examples=15, deadline=None)
@given(R=st.floats(0.005, 0.03), fr=st.floats(0.2, 0.7), L=st.floats(0.004, 0.05),
       c=st.sampled_from([5e-6, 0.2e-3]))
def test_tube_sectors_have_the_volume_of_their_polygons(R, fr, L, c):
    r = fr * R
    body = BodyShape("cylinder", np.eye(4), radius_m=R, length_m=L, sections=(CylinderSection(-L / 2, L / 2, R),))
    hole = HoleShape("b", frame_from_axis([0, 0, L / 2], [0, 0, 1]), r, L + 1e-3, True, 0.0)
    shape = PartShape("t", (body,), (hole,), ())
    sides = hole_sides(shape, {"b": c}, SETTINGS)
    n = sides["b"].n_sides
    pieces, _notes = convex_pieces(shape, sides, SETTINGS)
    assert len(pieces) == n
    sub = len(pieces[0].vertices_m) // 2 - 3  # each sector: 2 inner + (sub + 1) outer points per end
    N = n * sub
    expected = L * (N * R * R * math.tan(math.pi / N) - n * r * r * math.tan(math.pi / n))
    assert sum(piece_volume_m3(pc) for pc in pieces) == pytest.approx(expected, rel=1e-9)
    # the outer arcs stay within the convex arc tolerance of the circle
    assert R * (1 / math.cos(math.pi / N) - 1) <= SETTINGS.convex_arc_tolerance_m


def test_holes_in_other_directions_fall_back_to_plane_splits():
    # a box with holes along x and z: decompose handles one axis only, so it is split by planes
    body = BodyShape("box", np.eye(4), half_extents_m=np.array([0.02, 0.02, 0.02]))
    h1 = HoleShape("a", frame_from_axis([0, 0, 0.02], [0, 0, 1]), 0.004, 0.01, False, 0.0)
    h2 = HoleShape("b", frame_from_axis([0.02, 0.01, -0.01], [1, 0, 0]), 0.003, 0.041, True, 0.0)
    shape = PartShape("x", (body,), (h1, h2), ())
    sides = hole_sides(shape, {}, SETTINGS)
    pieces, notes = convex_pieces(shape, sides, SETTINGS)
    assert any("split by the hole planes" in n for n in notes)
    model = CollisionModel("convex", pieces)
    exact = body_solid(body, TOL) - hole_solid(h1, TOL, n_sides=sides["a"].n_sides) \
        - hole_solid(h2, TOL, n_sides=sides["b"].n_sides)
    assert sum(piece_volume_m3(pc) for pc in pieces) == pytest.approx(exact.volume(), rel=1e-6)
    for hole in (h1, h2):
        lo, hi = effective_clearance(model, hole, 50e-6, SETTINGS)
        assert lo == pytest.approx(100e-6, abs=2e-9)
        assert hi <= 100e-6 + sides[hole.feature].play_bound_m + 2e-9


def test_exact_model_of_a_part_with_holes_needs_its_solid():
    shape, _body, _hole = _box_with_hole((0.04, 0.04, 0.02), (0, 0), 0.005, 0.01, 0.0, False, 0)
    with pytest.raises(ValueError, match="needs its solid"):
        exact_model(shape, SETTINGS)


def test_unmeasured_model_has_the_same_pieces_without_the_cost(examples):
    g = ProductGeometry(examples["gear_unit"])
    raw = g.collision_model("wheel", "convex", measured=False)
    assert raw.hausdorff_m == 0.0
    assert "report_convex" not in {k for k, _ in g._cache}  # nothing measured yet
    measured = g.collision_model("wheel", "convex")
    assert measured.pieces is raw.pieces
    assert measured.hausdorff_m > 0
