"""Mesh parts keep their features at the convex level (issue 19): holes on two axes, a pin
standing on a face and an undeclared slot are not filled by hulls."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay

from asmplan.parts.models import ProductGeometry


def _write_stl(path, solid) -> None:
    import trimesh

    m = solid.to_mesh()
    trimesh.Trimesh(np.asarray(m.vert_properties)[:, :3], np.asarray(m.tri_verts), process=False).export(path)


def _inside_any(model, points_m: np.ndarray) -> np.ndarray:
    inside = np.zeros(len(points_m), bool)
    for pc in model.pieces:
        pts = pc.vertices_m + pc.T_part_piece[:3, 3]
        inside |= Delaunay(pts).find_simplex(points_m) >= 0
    return inside


@pytest.fixture
def bracket_stl(tmp_path):
    """An L bracket (mm): base 100 x 60 x 10, wall 100 x 10 x 60 at y 20..30; a 10 mm hole down
    into the base at (-30, -10) 8 deep, two 8 mm holes through the wall along y at z 40."""
    import manifold3d as m3

    base = m3.Manifold.cube([100, 60, 10]).translate([-50, -30, 0])
    wall = m3.Manifold.cube([100, 10, 60]).translate([-50, 20, 10])
    solid = base + wall
    solid -= m3.Manifold.cylinder(8, 5, 5, 96).translate([-30, -10, 2])
    for x in (-20, 20):
        solid -= m3.Manifold.cylinder(40, 4, 4, 96).rotate([-90, 0, 0]).translate([x, 0, 40])
    _write_stl(tmp_path / "bracket.stl", solid)
    return tmp_path / "bracket.stl"


def test_holes_on_two_axes_stay_open(make_product, bracket_stl, tmp_path):
    product = make_product(f"""
        parts:
          - name: bracket
            material: steel
            geometry: {{type: mesh, file: {bracket_stl}}}
            pose: {{}}
            features:
              - {{name: down, type: hole, at: [-30, -10, 10], axis: [0, 0, 1], diameter: 10, depth: 8}}
              - {{name: wall_1, type: hole, at: [-20, 20, 40], axis: [0, -1, 0], diameter: 8, through: true}}
              - {{name: wall_2, type: hole, at: [20, 20, 40], axis: [0, -1, 0], diameter: 8, through: true}}
        """)
    model = ProductGeometry(product).collision_model("bracket", "convex", measured=False)
    # points on the hole axes, inside each hole, are outside every convex piece
    probes = np.array([[-30, -10, 6], [-30, -10, 3], [-20, 25, 40], [20, 22, 40], [20, 28, 40]]) * 1e-3
    assert not _inside_any(model, probes).any()
    # ... and 3.5 mm off the axis of the 8 mm holes too (the polygon is inscribed in the circle)
    off = np.array([[-20 + 3.5, 25, 40], [20, 25, 40 - 3.5], [-30 + 4.5, -10, 5]]) * 1e-3
    assert not _inside_any(model, off).any()
    # the inside corner of the L (in front of the wall, above the base) is not filled
    corner = np.array([[0, 15, 20], [40, 0, 30]]) * 1e-3
    assert not _inside_any(model, corner).any()
    # while the material is covered
    solid = np.array([[0, 0, 5], [0, 25, 50], [-45, 25, 65], [45, -25, 2]]) * 1e-3
    assert _inside_any(model, solid).all()


def test_a_pin_on_a_face_and_a_slot_keep_their_shape(make_product, tmp_path):
    import manifold3d as m3

    block = m3.Manifold.cube([60, 40, 10]).translate([-30, -20, 0])
    block += m3.Manifold.cylinder(8, 3, 3, 96).translate([-15, 0, 10])          # a 6 mm pin on top
    slot = m3.Manifold.cube([6, 8.2, 30]).translate([12, -4.1, -10])             # an undeclared slot
    slot += m3.Manifold.cylinder(30, 4.1, 4.1, 96).translate([12, 0, -10])
    slot += m3.Manifold.cylinder(30, 4.1, 4.1, 96).translate([18, 0, -10])
    _write_stl(tmp_path / "block.stl", block - slot)
    product = make_product(f"""
        parts:
          - name: block
            material: steel
            geometry: {{type: mesh, file: {tmp_path / "block.stl"}}}
            pose: {{}}
            features:
              - {{name: pin, type: pin, at: [-15, 0, 10], axis: [0, 0, 1], diameter: 6, length: 8}}
        """)
    model = ProductGeometry(product).collision_model("block", "convex", measured=False)
    # beside the pin, above the top face: free (one hull of block and pin would fill it)
    beside = np.array([[-15 + 5, 0, 14], [-15, 6, 17], [0, 0, 12]]) * 1e-3
    assert not _inside_any(model, beside).any()
    # the pin and the block are covered
    assert _inside_any(model, np.array([[-15, 0, 14], [-15, 2.5, 11], [0, 0, 5]]) * 1e-3).all()
    # the slot stays open (4 mm wide probes along its length)
    slot_pts = np.array([[12, 0, 5], [15, 3.5, 5], [18 + 3.5, 0, 5], [15, -3.5, 9]]) * 1e-3
    assert not _inside_any(model, slot_pts).any()
