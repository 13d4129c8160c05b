"""A flat pad's contact patch measured on the part's mesh (planner/grasp_patch.py) against
closed forms: a line ``L / 4``, a disc ``2 R / 3``, a rectangle's mean distance (quadrature)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from asmplan.knowledge.model import GraspHint, Gripper
from asmplan.parts.mesh import TriangleMesh
from asmplan.planner.grasp import CONTACT_BAND_M, GraspSurface, iter_grasps
from asmplan.planner.grasp_hold import ContactPatch, rectangle_torsion_radius_m
from asmplan.planner.grasp_patch import FrameTriangles

X, Y, Z = np.eye(3)
COS_CONE = math.cos(math.atan(0.5))
HALF_W, HALF_L = 0.010, 0.015  # a 20 x 30 mm pad


def _mesh(tm: trimesh.Trimesh) -> TriangleMesh:
    return TriangleMesh(tm.vertices, tm.faces)


def _patch(mesh: TriangleMesh, x, c, a, u: float, v: float) -> ContactPatch:
    """The +y pad's rigid patch at (u, v), the pad plane on the part's largest y."""
    tris = FrameTriangles.of(mesh.vertices, mesh.faces, mesh.face_normals, np.zeros(3), x, c, a)
    y_ref = float((mesh.vertices @ c).max())
    r = tris.contact(1, u, v, HALF_W, HALF_L, y_ref, CONTACT_BAND_M, COS_CONE)
    assert r is not None
    return ContactPatch.rigid(r[0], r[1], r[3], CONTACT_BAND_M, r[2])


def test_rectangle_torsion_radius_is_the_mean_distance_by_quadrature():
    """The closed form against the midpoint rule on a 600 x 600 grid (1 %)."""
    for w, h in [(1.0, 1.0), (1.0, 5.0), (0.1, 3.0), (0.02, 0.03)]:
        n = 600
        qx = (np.arange(n) + 0.5) / n * w - w / 2
        qz = (np.arange(n) + 0.5) / n * h - h / 2
        mean = float(np.hypot(qx[:, None], qz[None, :]).mean())
        assert rectangle_torsion_radius_m(w, h) == pytest.approx(mean, rel=0.01)


@pytest.mark.parametrize("overlap_m", [2e-3, 3.2e-3, 6e-3])
def test_flat_pad_on_a_cylinder_flank_touches_a_line_of_its_overlap(overlap_m):
    """A 24 mm head (6 mm long, 64 facets) closed across its axis, the pad's tip over
    ``overlap_m`` of it: a rigid flat pad touches the flank along a line as long as the
    overlap, mean distance ``L / 4`` (2 mm: 0.5 mm, not the 1.0 mm the samples gave)."""
    mesh = _mesh(trimesh.creation.cylinder(radius=0.012, height=0.006, sections=64))
    # closing along part x, approach along part z (the line runs along the approach)
    x, c, a = np.cross(X, Z), X, Z
    v = -0.003 + overlap_m - HALF_L  # the pad's tip overlap_m past the head's -z face
    p = _patch(mesh, x, c, a, 0.0, v)
    assert float(np.ptp(p.points_m[:, 0])) < 1e-9  # collapsed onto one line
    assert p.torsion_radius_m == pytest.approx(min(overlap_m, 6e-3) / 4, rel=0.01)


def test_flat_pad_on_an_end_face_touches_a_disc():
    """A 10 mm cylinder's end face (128 facets) under the pad: ``2 R / 3``."""
    R = 0.005
    mesh = _mesh(trimesh.creation.cylinder(radius=R, height=0.02, sections=128))
    p = _patch(mesh, X, Z, np.cross(X, Z), 0.001, -0.002)
    assert p.torsion_radius_m == pytest.approx(2 * R / 3, rel=0.01)
    np.testing.assert_allclose(p.centroid_m, [-0.001, 0.002], atol=2e-5)
    assert p.area_m2 == pytest.approx(math.pi * R**2, rel=0.01)


def test_flat_pad_over_part_of_a_box_face_touches_the_overlap_rectangle():
    """A 40 x 12 mm face, the pad (20 x 30 mm) across it 5 mm off centre: a 20 x 12 mm patch
    whose mean distance is the rectangle's closed form."""
    mesh = _mesh(trimesh.creation.box([0.04, 0.01, 0.012]))
    p = _patch(mesh, X, Y, Z, 0.005, 0.0)
    assert p.torsion_radius_m == pytest.approx(rectangle_torsion_radius_m(0.02, 0.012),
                                               rel=0.01)
    assert p.area_m2 == pytest.approx(0.02 * 0.012, rel=1e-9)


def test_grasp_over_2_mm_of_a_head_gets_the_line_torsion_radius():
    """The gearbox case (tests/fixtures/products/gearbox.yaml, flat pads): a pad over 2 mm of
    a 24 mm head, sampled as the planner samples it (2.7 mm^2 per sample: 3 to 5 samples in
    the contact band). The grasp's torsion radius is the 2 mm line's ``L / 4``."""
    tm = trimesh.creation.cylinder(radius=0.012, height=0.006, sections=64)
    surface = GraspSurface.from_mesh(tm, np.zeros(3), 500, 0, "cylinder")
    gripper = Gripper(stroke_m=0.1, finger_size_m=np.array([0.02, 0.008, 0.03]),
                      finger_friction=1.0, max_force_N=400.0)
    tcp = np.array([0.0, 0.0, -0.003 + 0.002 - 0.015])  # the fingertips 2 mm over the head
    hint = GraspHint(closing_axis=X, approach_axis=Z, offset_m=tcp)
    g = next(g for g in iter_grasps("head", surface, gripper, hint, part_friction=0.5)
             if g.source == "hint" and np.allclose(g.T_part_gripper[:3, 3], tcp, atol=1e-9))
    assert g.torsion_radius_m == pytest.approx(0.5e-3, rel=0.01)
