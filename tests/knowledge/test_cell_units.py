"""The cell (gripper, table, robot) has its own units or the document's; a product's length unit
never silently rescales it (issue 19: a product in cm got an 85 cm stroke and an 8 m table)."""

from __future__ import annotations

import pytest

from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.loader import load_product

PRODUCT = """\
asmplan: 1
product: cm
units: {{length: cm, mass: kg}}
parts:
  - name: block
    material: steel
    geometry: {{type: box, size: [4, 4, 2]}}
    pose: {{xyz: [0, 0, 1]}}
resources:
{units}  gripper: {{stroke: 85, finger: {{size: [20, 8, 30], friction: 1.0}}, max_force: 40, mass: 600}}
  table: {{size: [800, 600, 40]}}
  robot: {{model: xarm6, base: {{xyz: [0, -350, 0]}}, reach: 700}}
"""


def test_product_unit_applied_to_a_cell_in_mm_is_an_error_naming_the_values(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text(PRODUCT.format(units=""))
    with pytest.raises(ProductError) as info:
        load_product(path)
    text = str(info.value)
    assert "resources.gripper.stroke: expected a gripper stroke of 1-500 mm, found 850 mm" in text
    assert "resources.table.size" not in text  # 8 m is a real (long) table: the stroke tells
    path.write_text(PRODUCT.format(units="").replace("size: [800, 600, 40]", "size: [8000, 600, 40]"))
    with pytest.raises(ProductError, match=r"resources\.table\.size: expected a table of 50 mm to "
                                           r"20 m, found 8e\+04 mm across"):
        load_product(path)
    assert "resources.units: {length: mm}" in text


def test_cell_units_of_their_own(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text(PRODUCT.format(units="  units: {length: mm, mass: g}\n"))
    p = load_product(path)
    # the part in cm, the cell in mm and g
    assert p.part("block").geometry.primitives[0].size_m == pytest.approx((0.04, 0.04, 0.02))
    g = p.resources.gripper
    assert g.stroke_m == pytest.approx(0.085)
    assert list(g.finger_size_m) == pytest.approx([0.020, 0.008, 0.030])
    assert g.mass_kg == pytest.approx(0.6)
    assert list(p.resources.table.size_m) == pytest.approx([0.8, 0.6, 0.04])
    assert p.resources.robot.reach_m == pytest.approx(0.7)
    assert p.resources.robot.T_world_base[:3, 3] == pytest.approx([0, -0.35, 0])
