"""validate and sequence name every declared feature the convex level fills or bridges."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from asmplan.cli import main
from asmplan.knowledge.loader import load_product
from asmplan.parts.feature_levels import feature_losses
from asmplan.parts.models import ProductGeometry

PRODUCT = """\
asmplan: 1
product: cross_drilled
units: {length: mm}
parts:
  - name: manifold_block
    geometry: {type: mesh, file: manifold_block.stl, units: mm}
    material: aluminium
    fixtured: true
    pose: {xyz: [0, 0, 20]}
    features:
      - {name: bore_z, type: hole, at: [0, 0, 20], axis: [0, 0, 1], diameter: 10, through: true}
      - {name: bore_x, type: hole, at: [20, 0, 0], axis: [1, 0, 0], diameter: 8, through: true}
  - name: plug
    geometry: {type: cylinder, diameter: 10, length: 30}
    material: steel
    pose: {xyz: [0, 0, 35]}
    features: [{name: p, type: pin, at: [0, 0, -5], axis: [0, 0, -1], diameter: 10, length: 10}]
mates:
  - {name: plug_in_block, pin: plug.p, hole: manifold_block.bore_z, fit: H7/g6}
resources:
  gripper: {stroke: 60, finger: {size: [20, 8, 30], friction: 1.0}, max_force: 60}
  table: {size: [600, 400, 40]}
"""


def _cross_drilled(tmp_path: Path) -> Path:
    """A 40 mm manifold block cross-drilled 10 mm along z and 8 mm along x: the two bores
    meet, so no plane separates them and the convex level keeps one axis only."""
    m3 = pytest.importorskip("manifold3d")
    import trimesh

    solid = (m3.Manifold.cube([40, 40, 40], center=True)
             - m3.Manifold.cylinder(60, 5, 5, 128, center=True)
             - m3.Manifold.cylinder(60, 4, 4, 128, center=True).rotate([0, 90, 0]))
    mesh = solid.to_mesh()
    trimesh.Trimesh(np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts)).export(
        tmp_path / "manifold_block.stl")
    p = tmp_path / "p.yaml"
    p.write_text(PRODUCT)
    return p


def test_a_filled_hole_is_named_with_its_part_and_evidence(tmp_path):
    product = load_product(_cross_drilled(tmp_path))
    losses = feature_losses(product, ProductGeometry(product))
    assert [(x.part, x.feature, x.action) for x in losses] == [("manifold_block", "bore_x", "filled")]
    loss = losses[0]
    # probes at a quarter, half and three quarters of the 40 mm bore (on its axis and half way
    # to its wall): those of one quarter lie in solid pieces (the middle ones are in the z
    # bore), up to the bore's 4 mm radius deep
    assert loss.probes_inside == 5 and loss.probes == 15
    assert 2e-3 < loss.depth_m <= 4.0e-3 + 1e-6


@pytest.mark.parametrize("command", ["validate", "sequence"])
def test_validate_and_sequence_warn(tmp_path, capsys, command):
    p = _cross_drilled(tmp_path)
    assert main([command, str(p)]) == 0
    err = capsys.readouterr().err
    assert ('warning: part "manifold_block" (mesh manifold_block.stl): hole bore_x is filled at the '
            "convex level that sequence, plan and the simulation use for contact") in err
    assert "bore_z" not in err


def test_imported_fixture_meshes_keep_every_feature(tmp_path):
    """The imported fixtures' mesh parts (holes on two axes in the angle bracket, a slot, a
    counterbore) lose nothing at the convex level."""
    pytest.importorskip("OCP")
    from asmplan.parts.cad_import import import_assembly, write_product

    cad = Path(__file__).resolve().parents[1] / "fixtures" / "cad"
    for name in ("angle_bracket", "locating_fixture"):
        out = tmp_path / f"{name}.yaml"
        write_product(import_assembly(cad / f"{name}.step"), out)
        product = load_product(out)
        assert feature_losses(product, ProductGeometry(product)) == []
