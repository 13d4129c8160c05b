"""parts.mesh against trimesh and scipy, which it replaces on the run path: the same numbers
bit for bit where it ports their formulas, the same geometry where it computes hulls."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull

from asmplan.parts.mesh import (
    DegenerateHullError,
    TriangleMesh,
    convex_hull,
    hull_faces,
    hull_vertex_indices,
    sample_surface,
)


def _meshes():
    box = trimesh.creation.box((0.01, 0.02, 0.03))
    cyl = trimesh.creation.cylinder(radius=0.005, height=0.04, sections=128)
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.02)
    holed = trimesh.boolean.difference([trimesh.creation.box((0.04, 0.04, 0.02)), cyl],
                                       engine="manifold")
    return {"box": box, "cylinder": cyl, "sphere": sphere, "holed block": holed}


@pytest.mark.parametrize("name", ["box", "cylinder", "sphere", "holed block"])
def test_mass_properties_normals_and_samples_are_trimesh_bit_for_bit(name):
    tm = _meshes()[name]
    m = TriangleMesh(tm.vertices, tm.faces)
    assert m.volume == tm.volume
    for attr in ("center_mass", "moment_inertia", "area_faces", "face_normals", "face_angles",
                 "vertex_normals", "bounds", "extents"):
        assert np.array_equal(getattr(m, attr), getattr(tm, attr)), attr
    pts, face = sample_surface(m, 500, seed=11)
    ref_pts, ref_face = trimesh.sample.sample_surface(tm, 500, seed=11)
    assert np.array_equal(pts, ref_pts) and np.array_equal(face, ref_face)


def test_box_mass_properties_are_analytic():
    a, b, c = 0.01, 0.02, 0.03
    box = trimesh.creation.box((a, b, c))
    m = TriangleMesh(box.vertices, box.faces)
    assert m.volume == pytest.approx(a * b * c, rel=1e-12)
    assert np.allclose(m.center_mass, 0.0, atol=1e-15)
    expected = a * b * c / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    assert np.allclose(m.moment_inertia, expected, rtol=1e-12, atol=1e-20)


def test_hull_matches_qhull_on_random_points():
    rng = np.random.default_rng(3)
    for n in (4, 10, 200):
        pts = rng.normal(size=(n, 3)) * 0.01 + 0.5
        ref = ConvexHull(pts)
        assert np.array_equal(hull_vertex_indices(pts), np.sort(ref.vertices))
        hull = convex_hull(pts)
        assert hull.volume == pytest.approx(ref.volume, rel=1e-12)
        assert len(hull_faces(pts)) == len(ref.simplices)  # 2 v - 4 faces for a simplicial hull


def test_hull_faces_index_the_input_and_point_outwards():
    rng = np.random.default_rng(5)
    pts = rng.uniform(-1, 1, size=(60, 3))
    faces = hull_faces(pts)
    centre = pts[np.unique(faces)].mean(axis=0)
    tri = pts[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.all(np.einsum("ij,ij->i", normal, tri.mean(axis=1) - centre) > 0)
    # every point is on the inner side of every hull face
    d = np.einsum("fj,fpj->fp", normal, pts[None, :, :] - tri[:, None, 0, :])
    assert d.max() <= 1e-12


def test_interior_and_duplicate_points_are_not_hull_vertices():
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    pts = np.vstack([[[0.5, 0.5, 0.5]], corners, corners[:2]])
    assert list(hull_vertex_indices(pts)) == list(range(1, 9))
    assert convex_hull(pts).volume == pytest.approx(1.0, rel=1e-15)


@pytest.mark.parametrize("pts, what", [
    (np.eye(3), "3 points"),
    (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float), "coplanar"),
    (np.array([[t, 2 * t, 3 * t] for t in range(6)], float), "collinear"),
])
def test_flat_point_sets_raise(pts, what):
    with pytest.raises(DegenerateHullError, match="points"):
        convex_hull(pts)


def test_cylinder_hull_volume_is_the_prism_volume():
    n, r, h = 64, 0.004, 0.02
    ang = 2 * math.pi * np.arange(n) / n
    ring = np.column_stack([r * np.cos(ang), r * np.sin(ang), np.zeros(n)])
    pts = np.vstack([ring, ring + np.array([0.0, 0.0, h])])
    prism = 0.5 * n * r * r * math.sin(2 * math.pi / n) * h
    assert convex_hull(pts).volume == pytest.approx(prism, rel=1e-12)


def test_bad_shapes_are_refused():
    with pytest.raises(ValueError, match=r"expected shape \(n, 3\)"):
        TriangleMesh(np.zeros((4, 2)), np.zeros((1, 3), int))
    with pytest.raises(ValueError, match=r"expected indices in \[0, 3\)"):
        TriangleMesh(np.zeros((3, 3)), np.array([[0, 1, 3]]))
