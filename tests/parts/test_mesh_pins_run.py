"""A mesh part with pins sequences, plans and runs (issue 19): a cast cover with two locating
pins on its underside, put onto a base by them."""

from __future__ import annotations

import numpy as np
import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.feature_levels import level_warnings
from asmplan.parts.models import ProductGeometry

PRODUCT = """\
asmplan: 1
product: pinned_cover
units: {length: mm}
parts:
  - name: base
    material: steel
    geometry:
      type: box
      size: [80, 60, 20]
      holes:
        - {name: hole_1, at: [-20, 0, 10], axis: [0, 0, 1], diameter: 8, depth: 10, chamfer: 0.5}
        - {name: hole_2, at: [20, 0, 10], axis: [0, 0, 1], diameter: 8, depth: 10, chamfer: 0.5}
    pose: {xyz: [0, 0, 10]}
    fixtured: true
  - name: cover
    material: aluminium
    geometry: {type: mesh, file: cover.stl, units: mm}
    features:
      - {name: pin_1, type: pin, at: [-20, 0, 0], axis: [0, 0, -1], diameter: 8, length: 8, chamfer: 0.5}
      - {name: pin_2, type: pin, at: [20, 0, 0], axis: [0, 0, -1], diameter: 8, length: 8, chamfer: 0.5}
    pose: {xyz: [0, 0, 20]}
    start: {location: feeder, xyz: [200, 0, 25]}
mates:
  # cast locating pins: a loose H11/c11 (80..260 um), resolved at BALANCED (50 um)
  - {name: pin_1_in_base, pin: cover.pin_1, hole: base.hole_1, fit: H11/c11}
  - {name: pin_2_in_base, pin: cover.pin_2, hole: base.hole_2, fit: H11/c11}
resources:
  gripper: {stroke: 60, finger: {size: [20, 8, 30], friction: 1.0}, max_force: 60}
  table: {size: [600, 400, 40]}
"""


@pytest.fixture
def cover_product(tmp_path):
    """The cover: a 60 x 40 x 8 mm plate (bottom face at z = 0) with two 8 x 8 mm pins at
    x = -20 and 20 mm, 0.5 mm tip chamfers, 128 facets, one watertight STL."""
    m3 = pytest.importorskip("manifold3d")
    import trimesh

    cover = m3.Manifold.cube([60, 40, 8]).translate([-30, -20, 0])
    for x in (-20, 20):
        pin = (m3.Manifold.cylinder(7.5, 4, 4, 128).translate([0, 0, -7.5])
               + m3.Manifold.cylinder(0.5, 3.5, 4, 128).translate([0, 0, -8]))
        cover += pin.translate([x, 0, 0])
    m = cover.to_mesh()
    trimesh.Trimesh(np.asarray(m.vert_properties)[:, :3], np.asarray(m.tri_verts)).export(
        tmp_path / "cover.stl")
    (tmp_path / "cover.yaml").write_text(PRODUCT)
    return load_product(tmp_path / "cover.yaml")


def test_the_convex_level_keeps_the_pins_apart_from_the_plate(cover_product):
    """Split at the plate's underside, the pins are pieces of their own: no hull bridges a pin
    to the plate (a cut in the face's own plane had left a flat sheet of that face on each
    pin, and its hull, 1470-1500 mm^3 for a 399 mm^3 pin, bridged the pin to the plate)."""
    geometry = ProductGeometry(cover_product)
    model = geometry.collision_model("cover", "convex", measured=False)
    assert level_warnings(cover_product, geometry) == []
    assert not any("budget" in n for n in model.notes)
    pin_volume_mm3 = np.pi * 16 * 7.5 + np.pi * 0.5 / 3 * (16 + 12.25 + 14)   # cylinder + frustum
    below = [pc for pc in model.pieces if (pc.vertices_m + pc.T_part_piece[:3, 3])[:, 2].max() <= 1e-6]
    assert len(below) == 2
    for pc in below:
        import trimesh

        hull = trimesh.Trimesh(pc.vertices_m).convex_hull
        assert hull.volume * 1e9 == pytest.approx(pin_volume_mm3, rel=2e-3)   # 128-gon in the circle


@pytest.mark.slow
def test_a_mesh_part_with_pins_sequences_plans_and_runs(cover_product):
    from asmplan.pipeline import RunSettings, run_product

    result = run_product(cover_product, RunSettings(fidelity="balanced", workers=1))
    assert result.plan is not None, result.failure
    assert [s.part for s in result.plan.steps] == ["base", "cover"]
    step = result.plan.steps[1]
    assert np.allclose(step.insertion_direction, [0, 0, -1])
    assert step.insertion_length_m == pytest.approx(8e-3, abs=1e-9)
    r = result.results.steps[1]
    assert r.success, r.outcome.reasons
    # seated: the cover's underside on the base within the position tolerance (0.5 mm)
    T = r.record.T_world_part[-1]
    assert np.linalg.norm(T[:3, 3] - step.T_world_final[:3, 3]) < 0.5e-3
