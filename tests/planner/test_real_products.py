"""Real products written as a process engineer would (issue 18): a gearbox, a beam-and-tenon
frame, and a gear resting micrometres above its ribs. Each test names the failure it pins."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.check import check_assembly
from asmplan.parts.collision import CollisionWorld
from asmplan.parts.models import ProductGeometry
from asmplan.planner.sequence import plan_sequence

PRODUCTS = Path(__file__).resolve().parents[1] / "fixtures" / "products"

_RIBS = """\
asmplan: 1
product: gear_on_ribs
units: {{length: mm, mass: g, angle: deg}}
parts:
  - name: base
    material: aluminium
    geometry:
      type: composite
      children:
        - {{shape: box, size: [120, 80, 10], pose: {{xyz: [0, 0, 5]}}}}
        - {{shape: box, size: [16, 4, {rib_h:.9f}], pose: {{xyz: [0, -8, {rib_z:.9f}]}}}}
        - {{shape: box, size: [16, 4, {rib_h:.9f}], pose: {{xyz: [0, 8, {rib_z:.9f}]}}}}
    pose: {{xyz: [0, 0, 0]}}
    fixtured: true
  - name: gear
    material: steel
    geometry:
      type: cylinder
      diameter: 56
      length: 12
      holes:
        - {{name: bore, at: [0, 0, -6], axis: [0, 0, -1], diameter: 15, through: true, chamfer: 0.5}}
    pose: {{xyz: [0, 0, 50], rpy: [0, 90, 0]}}
    start: {{location: tray, xyz: [0, 150, 28], rpy: [0, 90, 0]}}
precedence:
  base: base
resources:
  gripper: {{stroke: 85, finger: {{size: [20, 8, 30], friction: 1.0}}, max_force: 60}}
  table: {{size: [600, 500, 40]}}
  fixtures: [{{name: vise, holds: base}}]
"""


def gear_on_ribs(tmp_path: Path, gap_m: float) -> Path:
    """A 56 mm gear (axis along x, centre 50 mm up) whose rim rests ``gap_m`` above two ribs
    at |y| = 6..10 mm: the rim's lowest point over a rib is at |y| = 6 mm."""
    r, y = 28.0, 6.0
    top = 50.0 - math.sqrt(r * r - y * y) - gap_m * 1e3
    path = tmp_path / f"gear_on_ribs_{gap_m * 1e6:.0f}um.yaml"
    path.write_text(_RIBS.format(rib_h=top - 10.0, rib_z=10.0 + (top - 10.0) / 2))
    return path


@pytest.mark.parametrize("gap_um", [1, 3, 6, 10])
def test_part_resting_micrometres_above_ribs_sequences_as_resting(tmp_path, gap_um):
    product = load_product(gear_on_ribs(tmp_path, gap_um * 1e-6))
    # exact geometry sees the gap (check agrees it is not an interference)
    assert check_assembly(product).interferences == ()
    sp = plan_sequence(product)
    step = sp.best.steps[1]
    assert step.part == "gear"
    assert step.stability == "resting" and step.held_by == ("base",)
    assert step.insertion_label == "-z"
    # lifting off (-z insertion) is free; moving into the ribs is not
    rows = {d.insertion_label: b for d, b in zip(sp.blocking.directions["gear"],
                                                  sp.blocking.blockers["gear"], strict=True)}
    assert rows["-z"] == frozenset()
    assert "base" in rows["+z"] and "base" in rows["-y"] and "base" in rows["+y"]
    assert rows["-x"] == frozenset() and rows["+x"] == frozenset()  # sliding along the ribs


def test_convex_model_overlaps_the_ribs_at_one_micrometre(tmp_path):
    """The precondition of the test above: the planner's convex model of the gear overlaps
    the ribs by micrometres while the exact model keeps the gap (why a plain 1 um tolerance
    reported the gear blocked in every direction)."""
    product = load_product(gear_on_ribs(tmp_path, 1e-6))
    geo = ProductGeometry(product)
    d = {}
    for level in ("exact", "convex"):
        w = CollisionWorld(geo.fcl_shapes)
        for n in product.part_names:
            w.add(n, geo.collision_model(n, level, measured=False), product.T_world_assembled(n))
        d[level] = w.distance("gear", "base")
    assert d["exact"] > 0
    assert d["convex"] < -1e-6


def test_check_cover_resting_on_housing_is_not_an_interference():
    """gearbox: the cover lies face on face on both wall tops; exact BVH contact gave a
    triangle-local depth and check reported a 10 nm "interference"."""
    product = load_product(PRODUCTS / "gearbox.yaml")
    result = check_assembly(product)
    assert not [i for i in result.interferences if {i.a, i.b} == {"cover", "housing"}]
    assert result.interferences == ()
    # and a cover sunk 50 um into the housing is still reported, with its depth
    import dataclasses

    sunk = dataclasses.replace(product, parts=tuple(
        dataclasses.replace(p, T_product_part=p.T_product_part - np.pad(
            np.array([[0.0], [0.0], [50e-6]]), ((0, 1), (3, 0))))
        if p.name == "cover" else p for p in product.parts))
    hits = [i for i in check_assembly(sunk).interferences if {i.a, i.b} == {"cover", "housing"}]
    assert hits and hits[0].depth_m == pytest.approx(50e-6, abs=1e-6)


def test_part_resting_one_micrometre_above_ribs_plans(tmp_path):
    """The motion planner's model (convex, contact tolerance 20 um) agrees: the gear is
    placed onto the ribs along -z."""
    from asmplan.planner.motion import plan_product

    product = load_product(gear_on_ribs(tmp_path, 1e-6))
    plan = plan_product(product).plan
    step = plan.steps[1]
    assert step.part == "gear" and step.kind == "place"
    assert np.allclose(step.insertion_direction, [0, 0, -1])
