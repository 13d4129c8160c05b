"""Feature frames, depths measured on the solid, and mate checks (parts/features.py)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.features import T_part_feature, check_mates
from asmplan.parts.models import ProductGeometry

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "parts"


def test_feature_frame_has_its_z_along_the_axis(examples):
    product = examples["gear_unit"]
    bore = product.feature("bearing_block", "bore")
    T = T_part_feature(bore)
    np.testing.assert_allclose(T[:3, 2], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(T[:3, 3], [0.02, 0, 0], atol=1e-12)
    np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-12)
    frames = ProductGeometry(product).feature_frames("shaft")
    assert sorted(frames) == ["front", "hub", "tail"]


@pytest.mark.parametrize(("part", "feature", "depth_mm"), [
    ("bearing_block", "bore", 40.0), ("wheel", "bore", 10.0), ("collar", "bore", 8.0), ("cover", "h1", 6.0),
])
def test_through_hole_depth_is_measured_on_the_solid(examples, part, feature, depth_mm):
    product = examples["gear_unit"]
    g = ProductGeometry(product)
    assert g.feature_depth(product.feature(part, feature)) == pytest.approx(depth_mm * 1e-3, abs=1e-6)


def test_examples_have_no_feature_or_mate_findings(examples):
    for product in examples.values():
        g = ProductGeometry(product)
        assert check_mates(product, g.sizing, g.feature_depth) == []
        for name in product.part_names:
            assert g.feature_findings(name) == (), name


def _variant(tmp_path: Path, old: str, new: str, name: str = "pinhole_station") -> object:
    src = Path(__file__).resolve().parents[2] / "examples" / f"{name}.yaml"
    text = src.read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / f"{name}.yaml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return load_product(path, consistency=False)


def test_tilted_and_offset_pins_are_findings_with_evidence(tmp_path):
    # part2 turned by 0.5 deg about x and shifted 30 um in y: its pins leave their holes' axes
    product = _variant(tmp_path, "    pose: {xyz: [0, 0, 25]}", "    pose: {xyz: [0, 0.03, 25], rpy: [0.5, 0, 0]}")
    g = ProductGeometry(product)
    findings = check_mates(product, g.sizing, g.feature_depth)
    m21a = [f for f in findings if f.subject == "m21a"]
    assert any("antiparallel" in f.message and f.severity == "error" for f in m21a)
    assert any("on the axis" in f.message for f in m21a)
    angle = dict(m21a[0].evidence)["axis_angle_rad"]
    assert angle == pytest.approx(math.radians(0.5), abs=1e-9)


def test_a_pin_longer_than_its_blind_hole_bottoms_out(tmp_path):
    product = _variant(tmp_path, "{name: p1, at: [-40, 0, -10], axis: [0, 0, -1], diameter: 8, length: 8,",
                       "{name: p1, at: [-40, 0, -10], axis: [0, 0, -1], diameter: 8, length: 12,")
    g = ProductGeometry(product)
    (f,) = [f for f in check_mates(product, g.sizing, g.feature_depth) if f.subject == "m21a"]
    assert "2 mm too long: it bottoms out" in f.message
    assert dict(f.evidence)["hole_depth_m"] == pytest.approx(0.010)


def test_a_declared_bore_that_the_geometry_fills_is_an_error(make_product):
    p = make_product("""
        parts:
          - name: bush
            material: steel
            pose: {xyz: [0, 0, 0]}
            geometry: {type: cylinder, diameter: 20, length: 10}
            features:
              - {name: bore, type: bore, at: [0, 0, 5], axis: [0, 0, 1], diameter: 8, through: true}
    """, consistency=False)  # the loader refuses it (knowledge/consistency.py)
    (f,) = ProductGeometry(p).feature_findings("bush")
    assert f.severity == "error"
    assert "expected material around bore" in f.message or "expected no material inside the bore" in f.message


def test_mesh_part_hole_is_checked_against_the_mesh(tmp_path):
    g = ProductGeometry(load_product(FIXTURES / "mesh_plate.yaml"))
    assert g.feature_findings("plate") == ()
    assert g.feature_depth(g.product.feature("plate", "hole")) == pytest.approx(0.010, abs=1e-6)
    # the same mesh declared with a 12 mm hole: material inside the declared radius
    text = (FIXTURES / "mesh_plate.yaml").read_text().replace("diameter: 10, through", "diameter: 12, through")
    text = text.replace("file: plate_with_hole_mm.stl", f"file: {FIXTURES / 'plate_with_hole_mm.stl'}")
    text = text.replace("diameter: 10, length: 30", "diameter: 12, length: 30")
    text = text.replace("diameter: 10, length: 10", "diameter: 12, length: 10")
    path = tmp_path / "wrong.yaml"
    path.write_text(text)
    g2 = ProductGeometry(load_product(path))
    (f,) = g2.feature_findings("plate")
    assert f.severity == "error" and "expected no material inside the hole" in f.message
    assert dict(f.evidence)["filled_fraction"] > 0.1


def test_a_pin_declared_off_the_body_is_not_backed_by_material(make_product):
    p = make_product("""
        parts:
          - name: post
            material: steel
            pose: {xyz: [0, 0, 0]}
            geometry: {type: cylinder, diameter: 8, length: 20}
            features:
              - {name: foot, type: pin, at: [0, 0, -10], axis: [0, 0, -1], diameter: 8, length: 5}
    """, consistency=False)  # the loader refuses it (knowledge/consistency.py)
    (f,) = ProductGeometry(p).feature_findings("post")
    assert f.severity == "error" and "empty" in f.message
