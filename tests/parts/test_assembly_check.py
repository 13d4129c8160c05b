"""Assembly check and ``asmplan check`` (parts/check.py, asmplan/commands/check.py)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from asmplan.cli import main
from asmplan.knowledge.loader import load_product
from asmplan.parts.check import check_assembly
from asmplan.parts.models import ProductGeometry

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "parts"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("name", ["peg_in_hole", "pinhole_station", "gear_unit"])
def test_examples_check_clean_with_every_clearance_in_its_fit(examples, name):
    product = examples[name]
    result = check_assembly(product, ProductGeometry(product), level="exact")
    assert result.success, result.reason
    assert result.interferences == ()
    assert len(result.mates) == len(product.mates)
    for m in result.mates:
        assert m.measured_within
        # the built pair sits in the middle of the fit; FCL measures it to the level's bound
        assert m.declared_min_m <= m.measured_m <= m.declared_max_m
        assert abs(m.measured_m - m.built_m) <= m.bound_m
        assert m.measured_m == pytest.approx(0.5 * (m.declared_min_m + m.declared_max_m), abs=m.bound_m)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["pinhole_station", "gear_unit"])
def test_examples_check_clean_at_the_convex_level(examples, name):
    result = check_assembly(examples[name], ProductGeometry(examples[name]), level="convex")
    assert result.success, result.reason
    for m in result.mates:
        assert abs(m.measured_m - m.built_m) <= m.bound_m
        # the piece count follows the clearance to resolve: within 2 um, or 5 % of a loose fit
        assert m.bound_m < max(2e-6, 0.05 * m.built_m)


def test_interfering_product_names_the_pair_and_depth():
    interfering = load_product(FIXTURES / "interfering.yaml")
    result = check_assembly(interfering, ProductGeometry(interfering))
    assert not result.success
    (i,) = result.interferences
    assert (i.a, i.b) == ("block", "cap")
    assert i.depth_m == pytest.approx(2e-3, abs=2e-6)
    assert abs(i.separate_along[2]) == pytest.approx(1.0)
    assert "interference: block/cap" in result.reason


def test_an_interference_fit_is_an_intended_overlap(make_product):
    p = make_product("""
        parts:
          - name: hub
            material: steel
            pose: {xyz: [0, 0, 10]}
            fixtured: true
            geometry: {type: box, size: [30, 30, 20], holes: [{name: h, at: [0, 0, 10], diameter: 8, depth: 15}]}
          - name: pin
            material: steel
            pose: {xyz: [0, 0, 15]}
            start: {xyz: [60, 0, 10]}
            geometry: {type: cylinder, diameter: 8, length: 20}
            features: [{name: p, type: pin, at: [0, 0, 5], axis: [0, 0, -1], diameter: 8, length: 10}]
        mates:
          - {pin: pin.p, hole: hub.h, interference: 0.02}
    """)
    result = check_assembly(p, ProductGeometry(p))
    assert result.success, result.reason
    (c,) = result.intended_contacts
    assert (c.a, c.b, c.intended_by) == ("hub", "pin", "pin.p->hub.h")
    assert c.depth_m == pytest.approx(10e-6, abs=0.1e-6)  # radial overlap: half of 20 um
    (m,) = result.mates
    assert m.measured_m == pytest.approx(-20e-6, abs=0.1e-6)


def test_mesh_part_checks_at_exact_and_convex_levels():
    product = load_product(FIXTURES / "mesh_plate.yaml")
    g = ProductGeometry(product)
    for level in ("exact", "convex"):
        result = check_assembly(product, g, level=level)
        assert result.success, (level, result.reason)
        (m,) = result.mates
        assert m.measured_m == pytest.approx(17e-6, abs=m.bound_m)


def test_gear_unit_cover_is_carried_on_both_sides_of_its_centre_of_mass(examples):
    # Lowered 50 um from its assembled pose, the cover must meet what carries it: the bearing
    # block behind its centre of mass and the posts' shoulders in front of it. With plain
    # posts only the block met it, and the centre of mass (x = 12.6 mm) lies 32.6 mm in front
    # of the block's front edge (x = -20 mm): the cover tipped when released.
    product = examples["gear_unit"]
    g = ProductGeometry(product)
    world = g.collision_world("exact")
    T = product.T_world_assembled("cover").copy()
    assert not world.in_collision("cover", tolerance_m=1e-6)
    T[2, 3] -= 50e-6
    world.set_pose("cover", T)
    carriers = {n for n in product.part_names
                if n != "cover" and world.in_collision("cover", (n,), tolerance_m=1e-6)}
    assert carriers == {"bearing_block", "post_1", "post_2"}
    com_x = (T[:3, :3] @ g.mass_properties("cover").com_m + T[:3, 3])[0]
    block_front_x = world.aabb("bearing_block")[1, 0]
    post_x = [product.T_world_assembled(p)[0, 3] for p in ("post_1", "post_2")]
    assert block_front_x == pytest.approx(-20e-3, abs=1e-6)
    assert com_x == pytest.approx(12.586e-3, abs=1e-6)
    assert block_front_x < com_x < min(post_x)


def test_world_for_a_product_builds_in_milliseconds_once_geometry_is_cached(examples):
    g = ProductGeometry(examples["gear_unit"])
    g.collision_world("exact")  # builds solids, models and BVH trees once
    t = time.perf_counter()
    world = g.collision_world("exact")
    elapsed = time.perf_counter() - t
    assert len(world.names) == 8
    assert elapsed < 0.05  # measured ~2 ms


def test_cli_check_exit_codes_and_json(capsys):
    assert main(["check", str(EXAMPLES / "peg_in_hole.yaml")]) == 0
    out = capsys.readouterr().out
    assert "peg.tip->block.hole  H7/g6" in out and "no interference between parts" in out

    assert main(["check", str(FIXTURES / "interfering.yaml")]) == 1
    out = capsys.readouterr().out
    assert "INTERFERENCE block / cap: depth 1.999 mm" in out

    assert main(["check", str(FIXTURES / "interfering.yaml"), "--json"]) == 1
    data = json.loads(capsys.readouterr().out)
    assert data["success"] is False
    assert [(i["a"], i["b"]) for i in data["interferences"]] == [("block", "cap")]
    assert data["mates"][0]["within"] is True
    np.testing.assert_allclose(data["interferences"][0]["depth_m"], 2e-3, atol=2e-6)

    assert main(["check", str(FIXTURES / "broken_mesh.yaml")]) == 2
    err = capsys.readouterr().err
    assert "broken_mesh.yaml:15:13: parts[1].geometry.file: mesh file open_cylinder_mm.stl: not watertight" in err

    assert main(["check", str(FIXTURES / "nope.yaml")]) == 2
