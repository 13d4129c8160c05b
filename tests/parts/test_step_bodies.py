"""A multi-body STEP file: referenced as one part it warns naming its bodies; ``body:`` loads one."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.loader import load_product
from asmplan.parts.input_warnings import geometry_warnings
from asmplan.parts.meshfile import MeshFileError, load_mesh_file

pytest.importorskip("cascadio")

STEP = Path(__file__).resolve().parents[1] / "fixtures" / "cad" / "angle_bracket.step"
BODIES = {"knob", "washer", "post", "nut", "bolt", "side_block", "dowel_1", "dowel_2", "angle_bracket_1"}

PRODUCT = """\
asmplan: 1
product: bodies
parts:
  - name: whole
    material: steel
    geometry: {{type: mesh, file: bracket.step}}
    pose: {{}}
  - name: post
    material: steel
    geometry: {{type: mesh, file: {file}, body: post}}
    pose: {{xyz: [200, 0, 0]}}
resources:
  gripper: {{stroke: 85, finger: {{size: [20, 8, 30], friction: 1.0}}, max_force: 40}}
  table: {{size: [800, 600, 40]}}
"""


@pytest.fixture
def folder(tmp_path):
    shutil.copy(STEP, tmp_path / "bracket.step")
    return tmp_path


def test_multi_body_step_as_one_part_warns_naming_its_bodies(folder):
    (folder / "p.yaml").write_text(PRODUCT.format(file="bracket.step"))
    product = load_product(folder / "p.yaml")
    warnings = geometry_warnings(product)
    assert len(warnings) == 1  # the part with body: post gives none
    w = warnings[0]
    assert w.startswith('part "whole": bracket.step holds 9 bodies')
    for name in BODIES:
        assert name in w
    # and the load itself records it
    whole = load_mesh_file(folder / "bracket.step")
    assert any("holds 9 bodies" in n for n in whole.notes)


def test_body_loads_that_body_only_in_the_file_frame(folder):
    post = load_mesh_file(folder / "bracket.step", body="post")
    # the post is a 10 x 22 mm pin with 0.5 mm chamfers, at (-40, -20, 2..24) mm in the file
    chamfer_loss = 2 * 3.141592653589793 * 0.5 ** 2 * (5 - 0.5 / 3)   # two 45 deg chamfer rings
    volume_mm3 = 3.141592653589793 * 25 * 22 - chamfer_loss
    assert post.mesh.volume * 1e9 == pytest.approx(volume_mm3, rel=2e-3)
    lo, hi = post.mesh.bounds * 1e3
    assert lo[2] == pytest.approx(2.0, abs=1e-3) and hi[2] == pytest.approx(24.0, abs=1e-3)
    assert (lo[0] + hi[0]) / 2 == pytest.approx(-40.0, abs=1e-3)


def test_unknown_body_lists_the_bodies(folder):
    with pytest.raises(MeshFileError, match=r'expected a body named "pots", found bodies: .*post'):
        load_mesh_file(folder / "bracket.step", body="pots")


def test_body_on_a_non_step_file_is_an_input_error(folder):
    (folder / "part.stl").write_bytes(b"solid x\nendsolid x\n")
    (folder / "p.yaml").write_text(PRODUCT.format(file="part.stl"))
    with pytest.raises(ProductError, match='expected "body" only with a multi-body STEP file'):
        load_product(folder / "p.yaml")


def test_validate_reports_an_unknown_body_at_its_key(folder, capsys):
    """validate reads the STEP file's bodies: a misspelt ``body`` is an input error at its
    line and key (exit 2), not found only when a later command loads the part."""
    from asmplan.cli import main

    (folder / "p.yaml").write_text(PRODUCT.format(file="bracket.step").replace("body: post", "body: pots"))
    assert main(["validate", str(folder / "p.yaml")]) == 2
    err = capsys.readouterr().err
    line = next(i for i, t in enumerate((folder / "p.yaml").read_text().splitlines(), 1) if "pots" in t)
    assert f"p.yaml:{line}:" in err
    assert 'parts[1].geometry.body: mesh file bracket.step: expected a body named "pots", found bodies:' in err
    for name in BODIES:
        assert name in err
    (folder / "p.yaml").write_text(PRODUCT.format(file="bracket.step"))
    assert main(["validate", str(folder / "p.yaml")]) == 0


def _write_one_product_with_three_solids(path: Path) -> None:
    """A multi-body PART as CAD systems write one: a single product whose shape is a compound
    of three solids (boxes of 10, 5 and 3 mm at x = 0, 20 and 40 mm), no assembly tree."""
    pytest.importorskip("OCP")
    from OCP.BRep import BRep_Builder
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Pnt
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from OCP.TopoDS import TopoDS_Compound

    builder, compound = BRep_Builder(), TopoDS_Compound()
    builder.MakeCompound(compound)
    for x, a in ((0.0, 10.0), (20.0, 5.0), (40.0, 3.0)):
        builder.Add(compound, BRepPrimAPI_MakeBox(gp_Pnt(x, 0.0, 0.0), a, a, a).Shape())
    writer = STEPControl_Writer()
    writer.Transfer(compound, STEPControl_AsIs)
    assert writer.Write(str(path)) == IFSelect_RetDone


def test_solids_of_one_product_are_bodies_too(tmp_path):
    """Issue 19's first case: the solids of ONE product (cascadio's scene gives one node for
    them) warn by their names when fused, and ``body:`` loads one of them in the file frame."""
    path = tmp_path / "multi.step"
    _write_one_product_with_three_solids(path)
    whole = load_mesh_file(path)
    warn = [n for n in whole.notes if "holds 3 bodies" in n]
    assert len(warn) == 1, whole.notes
    names = warn[0].split("(", 1)[1].split(")", 1)[0].split(", ")
    assert len(names) == 3 and len(set(names)) == 3
    one = load_mesh_file(path, body=names[1])
    assert one.mesh.volume == pytest.approx(125e-9, rel=1e-6)  # the 5 mm box, in m^3
    assert one.mesh.bounds[0] == pytest.approx([0.020, 0.0, 0.0], abs=1e-9)
    with pytest.raises(MeshFileError, match=f"found bodies: {', '.join(names)}"):
        load_mesh_file(path, body="nope")
