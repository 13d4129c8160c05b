"""Caches that must not change results: the collision world's stacked boxes
(``CollisionWorld.aabbs``) and one solid / one set of convex pieces per distinct part shape."""

from __future__ import annotations

import numpy as np
import pytest

from asmplan.knowledge.frames import make_T
from asmplan.parts.collision import CollisionWorld
from asmplan.parts.lod import coarse_pieces, convex_pieces
from asmplan.parts.models import ProductGeometry
from asmplan.parts.pieces import CollisionModel, ConvexPiece
from asmplan.planner.fcl_oracle import unmeasured_convex_model


def cube(side_m: float) -> CollisionModel:
    return CollisionModel("exact", (ConvexPiece(kind="box", T_part_piece=np.eye(4),
                                                half_extents_m=np.full(3, side_m / 2)),))


def expected_box(x_m: float, z_m: float, side_m: float) -> np.ndarray:
    c = np.array([x_m, 0.0, z_m])
    return np.stack([c - side_m / 2, c + side_m / 2])


def test_aabbs_follow_poses_replacements_removals_and_growth():
    w = CollisionWorld()
    for k in range(40):  # more names than the world's first box array holds: it grows
        w.add(f"c{k}", cube(0.01), make_T([0.1 * k, 0.0, 0.0]))
    names = ["c39", "c3", "c17"]
    np.testing.assert_allclose(w.aabbs(names), [expected_box(0.1 * k, 0.0, 0.01) for k in (39, 3, 17)],
                               rtol=0, atol=1e-15)
    w.set_pose("c3", make_T([0.3, 0.0, 0.5]))
    w.add("c17", cube(0.02), make_T([1.7, 0.0, 0.0]))  # replaced by a bigger cube
    np.testing.assert_allclose(w.aabbs(names)[1:], [expected_box(0.3, 0.5, 0.01),
                                                    expected_box(1.7, 0.0, 0.02)], rtol=0, atol=1e-15)
    copy = w.aabbs(["c3"])
    copy[:] = 0.0  # a new array: the world is untouched
    assert w.aabb("c3")[1, 2] == pytest.approx(0.505, abs=1e-15)
    w.remove("c39")
    with pytest.raises(KeyError, match='no object "c39" in the collision world'):
        w.aabbs(names)
    w.add("new", cube(0.01), make_T([0.0, 1.0, 0.0]))  # takes the freed row
    np.testing.assert_allclose(w.aabbs(["new", "c3"])[0], [[-0.005, 0.995, -0.005], [0.005, 1.005, 0.005]],
                               rtol=0, atol=1e-15)
    for n in w.names:  # every name's box, also those added before the array grew
        np.testing.assert_array_equal(w.aabbs([n])[0], w.aabb(n))
    # the queries read the same boxes: c0 is free, and hit once c1 is moved onto it
    assert not w.in_collision("c0")
    w.set_pose("c1", make_T([0.005, 0.0, 0.0]))
    assert w.in_collision("c0") and w.in_collision("c1", ["c0"])


BLOCK = """
  - name: {name}
    material: aluminium
    geometry:
      type: box
      size: [40, 40, 20]
      holes:
      - {{name: {h}a, at: [-12, 0, 10], diameter: {d}, depth: 8, chamfer: 0.5}}
      - {{name: {h}b, at: [12, 0, 10], diameter: 6, depth: 8, chamfer: 0.5}}
      pins:
      - {{name: pa, at: [-12, 0, -10], axis: [0, 0, -1], diameter: 6, length: 6, chamfer: 0.5}}
    pose: {{xyz: [{x}, 0, 30]}}
"""


@pytest.fixture
def blocks(make_product):
    parts = "".join(BLOCK.format(name=n, h=h, d=d, x=x) for n, h, d, x in (
        ("b1", "h", 6, 0), ("b2", "h", 6, 100), ("b3", "h", 7, 200), ("b4", "k", 6, 300)))
    return make_product("parts:" + parts, name="blocks")


def test_parts_of_equal_shape_share_one_solid_and_one_set_of_pieces(blocks):
    g = ProductGeometry(blocks)
    assert g.solid("b1") is g.solid("b2")
    assert g.solid("b4") is g.solid("b1")  # feature names do not shape the solid ...
    convex = {n: g.collision_model(n, "convex", measured=False) for n in ("b1", "b2", "b3", "b4")}
    assert convex["b1"].pieces is convex["b2"].pieces
    assert convex["b4"].pieces is not convex["b1"].pieces  # ... but they name the pieces' notes
    assert any("hole ka" in n for n in convex["b4"].notes)
    assert g.solid("b3") is not g.solid("b1")  # a 7 mm hole
    assert g.solid("b3").volume() < g.solid("b1").volume()
    assert g.mesh("b1") is not g.mesh("b2")  # each part has its own mesh
    # what b2 shares is what b2 alone builds
    alone = ProductGeometry(blocks)
    assert alone.solid("b2").volume() == g.solid("b2").volume()
    pieces, notes = convex_pieces(alone.shape("b2"), alone.hole_sides("b2"), alone.settings)
    assert notes == convex["b2"].notes
    for a, b in zip(pieces, convex["b2"].pieces, strict=True):
        assert a.kind == b.kind and a.name == b.name
        np.testing.assert_array_equal(a.T_part_piece, b.T_part_piece)
        if a.kind == "hull":
            np.testing.assert_array_equal(a.vertices_m, b.vertices_m)


def test_coarse_and_oracle_models_reuse_the_convex_pieces(blocks):
    g = ProductGeometry(blocks)
    convex = g.collision_model("b3", "convex", measured=False)
    oracle = unmeasured_convex_model(g, "b3")
    assert oracle.pieces is convex.pieces and oracle.notes == (*convex.notes, "error not measured")
    coarse = g.collision_model("b3", "coarse", measured=False)
    (direct,) = coarse_pieces(g.shape("b3"), convex_pieces(g.shape("b3"), g.hole_sides("b3"),
                                                           g.settings)[0], g.settings)
    np.testing.assert_array_equal(coarse.pieces[0].vertices_m, direct.vertices_m)
