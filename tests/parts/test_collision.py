"""The FCL world: touching vs collision, distance accuracy, contacts, sweeps (parts/collision.py)."""

from __future__ import annotations

import numpy as np
import pytest

from asmplan.knowledge.frames import make_T
from asmplan.parts.collision import CollisionWorld, point_distances
from asmplan.parts.geometry import manifold_to_trimesh, prism
from asmplan.parts.pieces import CollisionModel, ConvexPiece


def box(size_m, name="box") -> CollisionModel:
    return CollisionModel("exact", (ConvexPiece(kind="box", T_part_piece=np.eye(4),
                                                half_extents_m=0.5 * np.asarray(size_m), name=name),))


def cylinder(radius_m, length_m) -> CollisionModel:
    return CollisionModel("exact", (ConvexPiece(kind="cylinder", T_part_piece=np.eye(4), radius_m=radius_m,
                                                length_m=length_m),))


def holed_block(radius_m=0.005, n=160) -> CollisionModel:
    """A 40 x 40 x 20 mm block (centred) with a through hole of inscribed radius ``radius_m``."""
    import manifold3d as m3

    solid = m3.Manifold.cube([0.04, 0.04, 0.02], True) - prism(radius_m, -0.02, 0.02, n)
    mesh = manifold_to_trimesh(solid)
    return CollisionModel("exact", (), mesh_vertices_m=np.asarray(mesh.vertices), mesh_faces=np.asarray(mesh.faces))


def test_touching_is_not_colliding_and_penetration_is():
    w = CollisionWorld()
    w.add("floor", box([0.1, 0.1, 0.02]), make_T([0, 0, -0.01]))
    w.add("block", box([0.02, 0.02, 0.02]), make_T([0, 0, 0.01]))
    assert not w.in_collision("block")  # face to face
    w.set_pose("block", make_T([0, 0, 0.01 - 0.5e-6]))
    assert not w.in_collision("block")  # 0.5 um: within the 1 um tolerance
    assert w.in_collision("block", tolerance_m=0.1e-6)
    w.set_pose("block", make_T([0, 0, 0.01 - 2e-6]))
    assert w.in_collision("block")
    (c,) = w.contacts()
    assert (c.a, c.b) == ("block", "floor")
    assert c.depth_m == pytest.approx(2e-6, abs=1e-9)


@pytest.mark.parametrize("clearance_m", [20e-6, 5e-6, 1e-6])
def test_distance_of_a_pin_in_a_hole_is_exact_to_a_nanometre(clearance_m):
    w = CollisionWorld()
    w.add("block", holed_block(), np.eye(4))
    w.add("pin", cylinder(0.005 - clearance_m / 2, 0.03), np.eye(4))
    assert w.distance("pin", "block") == pytest.approx(clearance_m / 2, abs=1e-9)
    assert not w.in_collision("pin", tolerance_m=0.0)
    # off-centre by 60 % of the radial clearance towards a face of the polygon (+x)
    w.set_pose("pin", make_T([0.6 * clearance_m / 2, 0, 0]))
    assert w.distance("pin", "block") == pytest.approx(0.4 * clearance_m / 2, abs=1e-9)
    w.set_pose("pin", make_T([1.2 * clearance_m / 2, 0, 0]))
    assert w.in_collision("pin", tolerance_m=0.0)
    assert w.distance("pin", "block") == pytest.approx(-0.2 * clearance_m / 2, abs=5e-9)


def test_sweep_finds_what_a_translation_hits_and_keeps_the_pose():
    w = CollisionWorld()
    w.add("block", holed_block(), np.eye(4))
    w.add("post", box([0.01, 0.01, 0.05]), make_T([0.05, 0, 0.015]))
    T_pin = make_T([0, 0, 0.03])
    w.add("pin", cylinder(0.005 - 5e-6, 0.02), T_pin)
    assert w.sweep_blockers("pin", [0, 0, -1], 0.05) == set()  # straight through the hole
    w.set_pose("pin", make_T([0.0002, 0, 0.03]))  # 0.2 mm off the axis
    assert w.sweep_blockers("pin", [0, 0, -1], 0.05) == {"block"}
    assert w.sweep_blockers("pin", [0, 0, -1], 0.005) == set()  # stops 5 mm above the block
    assert w.sweep_blockers("pin", [1, 0, 0], 0.1) == {"post"}
    np.testing.assert_array_equal(w.pose("pin"), make_T([0.0002, 0, 0.03]))


def test_sweep_of_a_mesh_steps_along_the_motion():
    w = CollisionWorld()
    w.add("block", holed_block(), np.eye(4))
    w.add("wall", box([0.002, 0.1, 0.1]), make_T([0.05, 0, 0]))
    assert w.sweep_blockers("block", [1, 0, 0], 0.02, step_m=1e-3) == set()  # stops 9 mm short
    assert w.sweep_blockers("block", [1, 0, 0], 0.04, step_m=1e-3) == {"wall"}
    np.testing.assert_array_equal(w.pose("block"), np.eye(4))


def test_separation_is_the_overlap_along_an_axis():
    w = CollisionWorld()
    w.add("a", holed_block(), np.eye(4))
    w.add("b", box([0.02, 0.02, 0.01]), make_T([0.01, 0, 0.013]))  # 2 mm into a's top face
    dist, u = w.separation("b", "a")
    assert dist == pytest.approx(2e-3 - 1e-6, abs=2e-9)  # up to the 1 um tolerance
    np.testing.assert_allclose(u, [0, 0, 1])


def test_containment_without_surface_contact_is_reported():
    w = CollisionWorld()
    w.add("a", holed_block(), np.eye(4))
    w.add("b", box([0.002, 0.002, 0.002]), make_T([0.012, 0.012, 0]))  # inside the block's wall
    (c,) = w.contacts()
    assert (c.a, c.b) == ("a", "b")
    assert c.depth_m > 0
    w.set_pose("b", make_T([0.0, 0.0, 0]))  # inside the hole: free
    assert w.contacts() == []


def test_unknown_names_and_bad_poses_say_what_exists():
    w = CollisionWorld()
    w.add("a", box([0.01] * 3), np.eye(4))
    with pytest.raises(KeyError, match='no object "b" in the collision world; it has: a'):
        w.set_pose("b", np.eye(4))
    with pytest.raises(ValueError, match=r"expected a finite \(4, 4\) transform"):
        w.set_pose("a", np.eye(3))
    with pytest.raises(ValueError, match="direction: expected a non-zero vector"):
        w.sweep_blockers("a", [0, 0, 0], 0.01)


def test_point_distances_to_a_box_surface():
    import trimesh

    m = trimesh.creation.box((0.02, 0.04, 0.06))
    pts = np.array([[0, 0, 0], [0.02, 0, 0], [0.01, 0.02, 0.04], [0.0, 0.0, 0.029]])
    np.testing.assert_allclose(point_distances(m.vertices, m.faces, pts), [0.01, 0.01, 0.01, 0.001], atol=1e-9)
