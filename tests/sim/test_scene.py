"""Step scene selection: which bodies a step needs, at which level, and the tray nest."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from asmplan.knowledge.loader import load_product
from asmplan.knowledge.model import Product
from asmplan.parts.cell import gripper_model
from asmplan.parts.models import ProductGeometry
from asmplan.planner.plan import Plan
from asmplan.planner.product import plan_product
from asmplan.sim.bodies import piece_corners
from asmplan.sim.bullet import BulletWorld
from asmplan.sim.execute import settle
from asmplan.sim.fidelity import ACCURATE, BALANCED, FAST
from asmplan.sim.nest import _rect_minus, tray_nest
from asmplan.sim.scene import PlanProductMismatchError, SceneSettings, build_scene, gripper_spec, select_scene
from tests.conftest import example_path


@functools.cache
def plan_for(name: str) -> tuple[Plan, Product, ProductGeometry]:
    """The planner's plan of a bundled example (computed once per test session), its product
    and a shared geometry cache."""
    product = load_product(example_path(name))
    geometry = ProductGeometry(product)
    return plan_product(product, geometry).plan, product, geometry


# ---------------------------------------------------------------------------------------------
# Rectangle minus pockets (the nest's layout)
# ---------------------------------------------------------------------------------------------
_coord = st.floats(-0.05, 0.05, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(_coord, _coord, st.floats(0.001, 0.03), st.floats(0.001, 0.03)),
                max_size=5),
       st.integers(0, 2**31 - 1))
def test_rect_minus_covers_exactly_the_rectangle_outside_the_pockets(pockets, seed):
    rect = np.array([[-0.04, -0.03], [0.04, 0.03]])
    holes = [np.array([[x, y], [x + w, y + h]]) for x, y, w, h in pockets]
    cells = _rect_minus(rect, holes)
    pts = np.random.default_rng(seed).uniform(rect[0], rect[1], size=(400, 2))

    def inside(box: np.ndarray, p: np.ndarray) -> np.ndarray:
        return np.all((p > box[0]) & (p < box[1]), axis=1)

    in_cells = np.sum([inside(c, pts) for c in cells], axis=0) if cells else np.zeros(len(pts))
    in_holes = np.any([inside(h, pts) for h in holes], axis=0) if holes else np.zeros(len(pts), bool)
    # every point is in exactly one cell or in a pocket, never both (boundaries have measure 0)
    assert np.all(in_cells <= 1)
    assert np.array_equal(in_cells == 1, ~in_holes)
    area = sum(float(np.prod(c[1] - c[0])) for c in cells)
    assert area <= float(np.prod(rect[1] - rect[0])) + 1e-12


# ---------------------------------------------------------------------------------------------
# Tray nest
# ---------------------------------------------------------------------------------------------
@pytest.mark.slow  # plans the example once per session
def test_nest_supports_the_bottom_face_with_pockets_around_the_pins():
    plan, _, geo = plan_for("pinhole_station")
    step = plan.step("part2")  # box 100 x 60 x 20 mm, two 8 mm pins 8 mm long pointing down
    pieces = geo.collision_model("part2", "convex", measured=False).pieces
    s = SceneSettings()
    boxes, T_nest, _ = tray_nest(geo, "part2", step.T_world_start, pieces, s)
    face_z = step.T_world_start[2, 3] - 0.010
    r_pin = next(p.radius_m for p in pieces if p.name == "pin:p1")  # 4 mm at its fitted size
    assert r_pin == pytest.approx(0.004, abs=20e-6)
    pins = [step.T_world_start[:3, 3] + [x, 0.0, 0.0] for x in (-0.040, 0.040)]
    area = 0.0
    for b in boxes:
        c = (T_nest @ b.T_part_piece)[:3, 3]
        he = b.half_extents_m
        # from the table top up to the bottom face, exactly
        assert c[2] - he[2] == pytest.approx(0.0, abs=1e-12)
        assert c[2] + he[2] == pytest.approx(face_z, abs=1e-9)
        # inside the face outline (100 x 60 mm) by the inset
        assert abs(c[0] - step.T_world_start[0, 3]) + he[0] <= 0.050 - s.nest_inset_m + 1e-9
        assert abs(c[1] - step.T_world_start[1, 3]) + he[1] <= 0.030 - s.nest_inset_m + 1e-9
        # no box within the pocket clearance of a pin
        for p in pins:
            gap = np.maximum(np.abs(p[:2] - c[:2]) - he[:2], 0.0)
            assert np.linalg.norm(gap) >= r_pin + s.nest_clearance_m - 1e-9
        area += 4 * he[0] * he[1]
    # the face minus the inset and two square pockets (pin + clearance) is supported
    full = (0.100 - 2 * s.nest_inset_m) * (0.060 - 2 * s.nest_inset_m)
    assert area == pytest.approx(full - 2 * (2 * r_pin + 2 * s.nest_clearance_m) ** 2, rel=1e-9)


def test_part_rests_still_on_its_nest():
    plan, product, geo = plan_for("pinhole_station")
    scene = select_scene(plan, 1, product, geo, BALANCED)
    assert scene.body("nest:part2").role == "nest"
    with BulletWorld(BALANCED) as world:
        ids = build_scene(world, scene)
        out = settle(world, [ids["part2"]], 0.5)
        pose = world.pose(ids["part2"])
        pins_touch = world.contacts(ids["part2"], ids["table"]).count
    assert out.stable, out.reasons
    assert out.max_drift_m < 20e-6  # rests; resting bodies creep ~10 um/s (docs/physics.md)
    np.testing.assert_allclose(pose[:3, :3], np.eye(3), atol=1e-4)
    assert pins_touch == 0  # the pins hang in the pockets, 2 mm above the table


@pytest.mark.slow  # plans the example once per session
def test_part_standing_on_the_table_gets_no_nest():
    plan, product, geo = plan_for("peg_in_hole")
    step = plan.step("peg")
    pieces = geo.collision_model("peg", "convex", measured=False).pieces
    assert tray_nest(geo, "peg", step.T_world_start, pieces, SceneSettings()) is None
    scene = select_scene(plan, step.index, product, geo, BALANCED)
    assert "nest:peg" not in scene.names()


# ---------------------------------------------------------------------------------------------
# Selection and culling
# ---------------------------------------------------------------------------------------------
@pytest.mark.slow  # plans the example once per session
def test_culled_scene_holds_only_the_required_bodies():
    plan, product, geo = plan_for("gear_unit")
    step = plan.step("bearing_block")
    scene = select_scene(plan, step.index, product, geo, BALANCED)
    # the block, the base it mates with (its pins in the base's holes), table and tray nest
    assert scene.names() == ("table", "nest:bearing_block", "bearing_block", "base")
    assert scene.body("bearing_block").dynamic and scene.body("base").role == "mate"
    assert not scene.body("base").dynamic and "fixtured" in scene.body("base").reason
    others = set(product.part_names) - {"bearing_block", "base"}
    assert {n for n, _ in scene.left_out} == others
    assert all("mm from the space" in r for _, r in scene.left_out)
    whole = select_scene(plan, step.index, product, geo, BALANCED, cull=False)
    assert set(whole.parts) == set(product.part_names) and not whole.left_out
    assert {b.name for b in whole.bodies if b.role == "obstacle"} == others
    # the whole product as loaded naively: every other part dynamic unless fixtured
    assert all(b.dynamic != product.is_fixtured(b.name)
               for b in whole.bodies if b.role == "obstacle")
    assert any(b.dynamic for b in whole.bodies if b.role == "obstacle")


def test_partners_are_dynamic_and_rest_on_static_supports():
    plan, product, geo = plan_for("pinhole_station")
    scene = select_scene(plan, plan.step("part3").index, product, geo, BALANCED)
    roles = {b.name: (b.role, b.dynamic) for b in scene.bodies}
    assert roles["part3"] == ("held", True)
    assert roles["part2"] == ("mate", True)  # part3's pins go into part2's holes
    assert roles["part1"] == ("support", False)  # part2 rests on the fixtured base
    assert "part4" not in roles  # still in its tray, far from the path
    assert scene.body("part2").mass_kg == pytest.approx(
        geo.mass_properties("part2").mass_kg, rel=1e-12)
    static = select_scene(plan, plan.step("part3").index, product, geo, BALANCED,
                          SceneSettings(dynamic_partners=False))
    assert not static.body("part2").dynamic
    # a static partner needs no support: part1 is at most an obstacle
    assert all(b.role != "support" for b in static.bodies)


def test_levels_follow_the_fidelity_but_keep_holes_and_pins():
    plan, product, geo = plan_for("gear_unit")
    k = plan.step("wheel").index
    # FAST with dynamic partners (as BALANCED): held, mate and support need their features
    fast = select_scene(plan, k, product, geo, dataclasses.replace(FAST, dynamic_partners=True))
    for name in ("wheel", "shaft", "bearing_block"):
        b = fast.body(name)
        assert b.level == "convex" and len(b.pieces) == len(
            geo.collision_model(name, "convex", measured=False).pieces), name
    assert fast.body("shaft").dynamic and fast.body("bearing_block").role == "support"
    far = [b for b in fast.bodies if b.role == "obstacle" and b.distance_m > 5e-3]
    assert far and all(b.level == "coarse" and len(b.pieces) == 1 for b in far)
    # the FAST preset itself: a static partner needs no support
    fast = select_scene(plan, k, product, geo, FAST)
    assert fast.body("shaft").role == "mate" and not fast.body("shaft").dynamic
    assert "dynamic partners off" in fast.body("shaft").reason
    assert not fast.names("support")
    accurate = select_scene(plan, k, product, geo, ACCURATE)
    # the wheel's exact model is a mesh (its bore): PyBullet gets the convex pieces
    assert accurate.body("wheel").level == "convex" and "mesh" in accurate.body("wheel").reason
    # the shaft's exact model is primitives: used as is
    exact = geo.collision_model("shaft", "exact")
    assert accurate.body("shaft").level == "exact"
    assert len(accurate.body("shaft").pieces) == len(exact.pieces)


def test_fits_the_preset_resolves_limit_the_contact_breaking_distance():
    # gear_unit's collar and cover mate with H11/c11 (smallest diametral clearance 80 um) with
    # dynamic partners, at least BALANCED's interference resolution (50 um; FAST: 0.4 mm, and
    # its partners are static); pinhole_station's H7/g6 and H8/f7 fits are below it:
    # PyBullet's default there.
    plan, product, geo = plan_for("gear_unit")
    k = plan.step("collar").index
    scene = select_scene(plan, k, product, geo, BALANCED)
    assert scene.contact_breaking_m == pytest.approx(40e-6, rel=1e-9)
    assert scene.contact_breaking_partners == ("shaft",)
    assert any("kept up to 0.040 mm apart" in n and "collar_on_shaft" in n for n in scene.notes)
    assert scene.summary()["contact_breaking_m"] == scene.contact_breaking_m
    cover = select_scene(plan, plan.step("cover").index, product, geo, BALANCED)
    assert cover.contact_breaking_partners == ("post_1", "post_2")
    assert select_scene(plan, k, product, geo, FAST).contact_breaking_m is None
    off = select_scene(plan, k, product, geo, BALANCED,
                       SceneSettings(limit_contact_breaking=False))
    assert off.contact_breaking_m is None and not off.contact_breaking_partners
    static = select_scene(plan, k, product, geo, BALANCED,
                          SceneSettings(dynamic_partners=False))
    assert static.contact_breaking_m is None  # a static shaft cannot be pushed
    other_plan, other, other_geo = plan_for("pinhole_station")
    assert all(select_scene(other_plan, s.index, other, other_geo, BALANCED).contact_breaking_m
               is None for s in other_plan.steps if s.kind != "fixture")
    # built: the collar-shaft pair within 40 um; in millimetre units BALANCED's default is
    # already 25 um (half its resolvable clearance, sim/bullet.py), which the limit never raises
    for chosen, expected in ((scene, 25e-6), (off, 25e-6)):
        with BulletWorld(BALANCED) as world:
            ids = build_scene(world, chosen)
            got = world.contact_breaking_m(ids["collar"], ids["shaft"])
            assert got == pytest.approx(expected, rel=1e-4)


def test_scene_summary_is_json_safe_and_names_every_reason():
    import json

    plan, product, geo = plan_for("pinhole_station")
    summary = select_scene(plan, 3, product, geo, BALANCED).summary()
    text = json.dumps(summary, allow_nan=False)
    assert json.loads(text)["culled"] is True
    assert all(b["reason"] for b in summary["bodies"])
    assert [b["name"] for b in summary["bodies"]][:3] == ["table", "nest:part4", "part4"]


def test_plan_of_another_product_is_refused():
    plan, _, geo = plan_for("peg_in_hole")
    _, other, other_geo = plan_for("pinhole_station")
    with pytest.raises(PlanProductMismatchError, match="plan is for product 'peg_in_hole'"):
        select_scene(plan, 1, other, other_geo, BALANCED)
    renamed = dataclasses.replace(plan, product="pinhole_station")
    with pytest.raises(PlanProductMismatchError, match="plan parts"):
        select_scene(renamed, 1, other, other_geo, BALANCED)
    with pytest.raises(ValueError, match="expected a step that moves its part"):
        select_scene(plan, 0, plan_for("peg_in_hole")[1], geo, BALANCED)


def test_simulated_gripper_matches_the_planned_one():
    _, product, _ = plan_for("pinhole_station")
    res = product.resources.gripper
    spec = gripper_spec(res)
    assert spec.max_opening_m == pytest.approx(res.stroke_m)
    assert spec.pad_friction == pytest.approx(res.finger_friction)
    assert spec.max_clamp_force_N == pytest.approx(res.max_force_N)
    # pads and palm occupy the same space as the planner's finger and palm boxes
    planned = gripper_model(res, spec.max_opening_m / 2)
    corners = np.concatenate([piece_corners(p) for p in planned.pieces])
    pad = np.asarray(spec.pad_size_m)
    palm = np.asarray(spec.palm_size_m)
    z_palm_back = -(pad[2] / 2 + spec.palm_gap_m + palm[2])
    assert corners[:, 2].min() == pytest.approx(z_palm_back)
    assert corners[:, 2].max() == pytest.approx(pad[2] / 2)
    assert corners[:, 1].max() == pytest.approx(spec.max_opening_m / 2 + pad[1])


def test_holes_that_stay_empty_are_modelled_solid():
    from asmplan.sim.bodies import empty_holes

    plan, product, geo = plan_for("pinhole_station")
    k = plan.step("part2").index
    placed = {"part1"}
    # part2's holes wait for part3 (not placed): empty; part1's holes receive part2's pins
    assert empty_holes(product, "part2", placed | {"part2"}) == {"h1", "h2"}
    assert empty_holes(product, "part1", placed | {"part2"}) == frozenset()
    # a part waiting at its start pose: every mated hole is empty
    assert empty_holes(product, "part3", placed | {"part2"}) == {"h1", "h2"}
    scene = select_scene(plan, k, product, geo, BALANCED)
    held, mate = scene.body("part2"), scene.body("part1")
    full = geo.collision_model("part2", "convex", measured=False).pieces
    assert sum(pc.kind == "hull" for pc in full) > 10  # two rings of sectors
    # solid: one box, two pin cylinders and their chamfered tips
    assert sorted(pc.kind for pc in held.pieces) == ["box", "cylinder", "cylinder", "hull", "hull"]
    assert "left solid" in held.reason or "modelled solid" in held.reason
    assert len(mate.pieces) == len(geo.collision_model("part1", "convex", measured=False).pieces)
    # the part's mass properties stay those of the real part (holes cut)
    assert held.mass_kg == pytest.approx(geo.mass_properties("part2").mass_kg)
