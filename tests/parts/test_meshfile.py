"""Mesh files: units, safe repair, clear errors, bounded time on huge meshes (parts/meshfile.py)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.loader import load_product
from asmplan.parts.geometry import GeometrySettings
from asmplan.parts.meshfile import MeshFileError, count_triangles, load_mesh_file
from asmplan.parts.models import ProductGeometry

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "parts"


def _write_binary_stl(path: Path, triangles: np.ndarray) -> None:
    rec = np.zeros(len(triangles), dtype=[("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = triangles
    with path.open("wb") as fh:
        fh.write(b"\0" * 80)
        fh.write(np.uint32(len(triangles)).tobytes())
        fh.write(rec.tobytes())


def test_plate_loads_in_metres_and_watertight():
    loaded = load_mesh_file(FIXTURES / "plate_with_hole_mm.stl", 1e-3)
    m = loaded.mesh
    assert m.is_watertight
    np.testing.assert_allclose(m.bounds, [[-0.02, -0.02, -0.005], [0.02, 0.02, 0.005]], atol=1e-9)
    n, r = 64, 10.0075e-3 / 2  # the fixture's hole: a 64-gon whose inscribed circle is the hole
    expected = 0.04 * 0.04 * 0.01 - n * r * r * np.tan(np.pi / n) * 0.01
    assert m.volume == pytest.approx(expected, rel=1e-6)
    assert any("scaled by 0.001" in note for note in loaded.notes)


def test_duplicated_vertices_are_merged_safely(tmp_path):
    box = trimesh.creation.box((10.0, 20.0, 30.0))
    soup = box.vertices[box.faces]  # every triangle with its own vertices
    path = tmp_path / "soup.stl"
    _write_binary_stl(path, soup)
    loaded = load_mesh_file(path, 1e-3)
    assert loaded.mesh.is_watertight
    assert loaded.mesh.volume == pytest.approx(6e-6, rel=1e-9)


def test_open_surface_is_a_clear_error():
    with pytest.raises(MeshFileError, match=r"not watertight after safe repair \(32 open edges"):
        load_mesh_file(FIXTURES / "open_cylinder_mm.stl", 1e-3)


def test_zero_volume_is_a_clear_error():
    with pytest.raises(MeshFileError, match="zero volume"):
        load_mesh_file(FIXTURES / "flat_mm.stl", 1e-3)


def test_missing_and_unreadable_files(tmp_path):
    with pytest.raises(MeshFileError, match="file not found"):
        load_mesh_file(tmp_path / "nope.stl")
    bad = tmp_path / "bad.obj"
    bad.write_text("this is not a mesh\n")
    with pytest.raises(MeshFileError, match=r"expected a triangle mesh|cannot read"):
        load_mesh_file(bad)


def test_product_error_points_at_the_yaml_line():
    product = load_product(FIXTURES / "broken_mesh.yaml")
    with pytest.raises(ProductError) as info:
        ProductGeometry(product).mesh("can")
    (issue,) = info.value.issues
    assert issue.path == "parts[1].geometry.file"
    assert issue.line == 15
    assert "not watertight" in issue.message


def test_triangle_count_comes_from_the_header(tmp_path):
    path = tmp_path / "t.stl"
    _write_binary_stl(path, np.zeros((7, 3, 3), dtype=np.float32))
    assert count_triangles(path) == 7


@pytest.mark.slow
def test_two_million_triangle_soup_fails_fast_with_count_and_limit(tmp_path):
    rng = np.random.default_rng(0)
    path = tmp_path / "huge.stl"
    _write_binary_stl(path, rng.random((2_000_000, 3, 3), dtype=np.float32))
    t = time.perf_counter()
    with pytest.raises(MeshFileError, match=r"2,000,000 triangles, over the limit of 200,000"):
        load_mesh_file(path, 1e-3)
    assert time.perf_counter() - t < 30.0


def test_hard_limit_refuses_before_reading(tmp_path):
    path = tmp_path / "huge.stl"
    _write_binary_stl(path, np.zeros((2_000_000, 3, 3), dtype=np.float32))
    settings = GeometrySettings(hard_max_triangles=1_000_000)
    t = time.perf_counter()
    with pytest.raises(MeshFileError, match=r"2,000,000 triangles, over the hard limit of 1,000,000"):
        load_mesh_file(path, 1e-3, settings)
    assert time.perf_counter() - t < 1.0


@pytest.mark.slow
def test_large_watertight_mesh_is_simplified_and_says_so(tmp_path):
    sphere = trimesh.creation.icosphere(subdivisions=7, radius=20.0)  # 327,680 triangles
    path = tmp_path / "sphere.stl"
    _write_binary_stl(path, sphere.vertices[sphere.faces].astype(np.float32))
    t = time.perf_counter()
    loaded = load_mesh_file(path, 1e-3)
    elapsed = time.perf_counter() - t
    assert len(loaded.mesh.faces) <= 200_000
    assert loaded.mesh.is_watertight
    assert loaded.mesh.volume == pytest.approx(sphere.volume * 1e-9, rel=1e-3)
    assert any(n.startswith("simplified from 327,680 to") for n in loaded.notes)
    assert elapsed < 30.0
