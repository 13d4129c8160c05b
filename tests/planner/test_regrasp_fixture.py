"""Declared regrasp fixtures (issue 18): the gearbox's shaft stands in a sleeve holder to be
picked by its head, its cover is presented on a pedestal, and the whole gearbox plans; the
planner keeps the cheaper of a table regrasp and a fixture; a fixture step simulates."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.errors import NoGraspError
from asmplan.planner.motion import MotionPlanner
from asmplan.planner.partdata import part_data
from asmplan.planner.product import plan_product
from asmplan.planner.settings import PlannerSettings

PRODUCTS = Path(__file__).resolve().parents[1] / "fixtures" / "products"
GEARBOX = PRODUCTS / "gearbox.yaml"


def _planner(product, settings=None):
    settings = settings or PlannerSettings()
    return MotionPlanner(product, settings, part_data(product, settings, ProductGeometry(product)))


@pytest.fixture(scope="module")
def gearbox_plan():
    product = load_product(GEARBOX)
    geometry = ProductGeometry(product)
    return product, geometry, plan_product(product, geometry).plan


def test_gearbox_plans_end_to_end(gearbox_plan):
    """Every part of the 11-part gearbox is planned; the shaft goes through its stand and is
    held there by its head in prism jaws (the fixture's ``prism`` finger: seated on four flank
    lines 12 cos 45 deg = 8.49 mm off the closing axis, about 20 N per finger; flat pads
    needed 289 N, see the fixture's note); the bearings are pinched across their 40 mm flanges where
    they lie; the cover is pinched at its 8 mm edge on its pedestal."""
    product, _, plan = gearbox_plan
    assert sorted(plan.sequence) == sorted(product.part_names)
    kinds: dict[str, list[str]] = {}
    for s in plan.steps:
        kinds.setdefault(s.part, []).append(s.kind)
    assert kinds["housing"] == ["fixture"]
    assert kinds["gear"] == ["place"] and kinds["spacer"] == ["place"]
    assert all(kinds[f"dowel_{k}"] == ["insert"] for k in range(1, 5))
    assert kinds["cover"] == ["insert"]
    assert kinds["shaft"] == ["regrasp", "insert"]
    assert len(plan.steps) == 12
    order = plan.sequence
    for before, after in (("bearing_1", "shaft"), ("gear", "shaft"), ("spacer", "shaft")):
        assert order.index(before) < order.index(after)
    assert all(order.index(f"dowel_{k}") < order.index("cover") for k in range(1, 5))
    # the shaft: put into the stand's seat, picked again there by its head along its axis
    put, pick = [s for s in plan.steps if s.part == "shaft"]
    seat = product.resources.regrasp[0].T_world_seat("shaft")
    np.testing.assert_allclose(put.T_world_final, seat, atol=1e-12)
    np.testing.assert_array_equal(pick.T_world_start, put.T_world_final)
    assert put.notes[-1].startswith("shaft: put into regrasp fixture shaft_stand")
    assert "from regrasp fixture shaft_stand" in pick.start_note
    approach = pick.T_world_final[:3, :3] @ pick.grasp.approach_axis_part
    np.testing.assert_allclose(approach, [1, 0, 0], atol=1e-9)  # along the shaft, from the head
    assert pick.grasp.width_m == pytest.approx(24e-3, abs=1e-4)  # across the 24 mm head
    # held by the head in the grooves: 220 g at 65.3 mm from four flank lines 8.49 mm off the
    # closing axis, mu / sin 45 deg each per newton of squeeze:
    # sf m (g + a) d sin 45 / (2 mu R cos 45) = 2 x 0.2197 x 11.81 x 0.0653 / (2 x 0.7 x
    # 0.012) = 20.2 N (the criterion's 19.9 N: the contact centre from samples)
    assert pick.grasp.lever_m == pytest.approx(65.3e-3, abs=1e-3)
    assert pick.grasp.torsion_radius_m == pytest.approx(12e-3 * np.cos(np.pi / 4), abs=3e-4)
    assert pick.grasp.hold_required_N == pytest.approx(20.2, rel=0.05)
    # the bearings: pinched across the 40 mm flange where they lie on the tray
    for name in ("bearing_1", "bearing_2"):
        assert kinds[name] == ["insert"], name
        step = plan.step(name)
        assert step.grasp.width_m == pytest.approx(40e-3, abs=1e-4)
        assert step.grasp.hold_required_N < 60.0  # the light gripper would hold them too
    cover = plan.step("cover")
    assert cover.grasp.width_m == pytest.approx(8e-3, abs=1e-4)
    assert cover.start_note == "given: cover_rest"


def test_a_60_N_gripper_cannot_hold_the_shaft_by_its_head_with_flat_pads():
    """With the light 60 N gripper and flat pads (the shaft's prism finger removed) the shaft
    stands in its stand but no grasp of its head holds it horizontal: the best needs more than
    60 N per finger, turning or tipping about the short line where the flat pad touches the
    round head (the regrasp engineer measured 0.103 N m of grip against 0.164-0.197 N m of
    load at 60 N)."""
    product = load_product(GEARBOX)
    product = dataclasses.replace(product, parts=tuple(
        dataclasses.replace(p, handling=dataclasses.replace(p.handling, finger=None))
        if p.name == "shaft" else p for p in product.parts))
    light = dataclasses.replace(product, resources=dataclasses.replace(
        product.resources, gripper=dataclasses.replace(product.resources.gripper,
                                                       max_force_N=60.0)))
    planner = _planner(light, PlannerSettings(regrasp=False))
    k = 0
    for name in ("housing", "gear", "spacer", "bearing_1"):
        k += len(planner.plan_steps(k, name))
    seat = product.resources.regrasp[0].T_world_seat("shaft")
    with pytest.raises(NoGraspError) as info:
        planner.plan_step(k + 1, "shaft", T_start=seat)
    held = [r for r in info.value.reasons if "the grip cannot hold" in r]
    assert len(held) == 1, info.value.reasons
    m = re.search(r"the best needs ([\d.]+) N per finger > 60 N \((turning about the closing "
                  r"axis|tipping about the contact line): lever ([\d.]+) mm", held[0])
    assert m, held
    assert float(m.group(1)) > 60.0


def test_shaft_has_no_table_regrasp_and_says_so_without_its_stand():
    """Without the stand no way exists: the shaft cannot stand on the table (a 15 mm tip or
    a 24 mm head under a 145 mm shaft tips over within 10 deg), and the failure says both."""
    product = load_product(GEARBOX)
    bare = dataclasses.replace(product, resources=dataclasses.replace(
        product.resources, regrasp=tuple(f for f in product.resources.regrasp
                                         if f.name != "shaft_stand")))
    planner = _planner(bare)
    k = 0
    for name in ("housing", "gear", "spacer", "bearing_1"):
        k += len(planner.plan_steps(k, name))
    with pytest.raises(NoGraspError) as info:
        planner.plan_steps(k, "shaft")
    reasons = info.value.reasons
    assert "regrasp: no stable orientation other than the start pose's with a free area of " \
           "the table to put the part down" in reasons
    assert "regrasp: no declared regrasp fixture holds this part (resources.regrasp)" in reasons


def test_the_neighbour_that_blocks_the_open_fingers_is_named():
    """bearing_2 lies 6 mm from the shaft's head on the tray: grasps whose open fingers meet
    the head are rejected naming the shaft and the fingers; another grasp is found."""
    product = load_product(GEARBOX)
    planner = _planner(product, PlannerSettings(regrasp=False))
    planner.plan_steps(0, "housing")
    with pytest.raises(NoGraspError) as info:  # no grasp holds it on the tray and in the seat
        planner.plan_steps(1, "bearing_2")
    assert any(re.fullmatch(r"\d+ candidates: the gripper hits shaft at the start pose "
                            r"\(open fingers\)", r) for r in info.value.reasons), \
        info.value.reasons
    steps = _planner(product).plan_steps(1, "bearing_2")  # with the regrasp it plans
    assert [s.kind for s, _ in steps] == ["regrasp", "insert"]


def test_auto_layout_keeps_the_bearing_clear_of_the_shaft(tmp_path):
    """Without their tray poses, bearing_2 and the shaft are laid out 20 mm apart (clear of
    the cell's fixtures too) and bearing_2 plans with the shaft still waiting beside it."""
    from asmplan.planner.layout import initial_layout

    text = GEARBOX.read_text()
    lines = [ln for ln in text.splitlines()
             if not (ln.strip().startswith("start:") and ("[-90, 180" in ln or "[0, 180" in ln))]
    path = tmp_path / "gearbox_auto.yaml"
    path.write_text("\n".join(lines) + "\n")
    product = load_product(path)
    planner = _planner(product)
    _, notes = initial_layout(product, planner.parts)
    assert notes["shaft"].startswith("no start pose given") and \
        notes["bearing_2"].startswith("no start pose given")
    boxes = {n: planner.scene.world.aabb(n) for n in ("shaft", "bearing_2")}
    gap = np.maximum(boxes["shaft"][0] - boxes["bearing_2"][1],
                     boxes["bearing_2"][0] - boxes["shaft"][1])[:2].max()
    assert gap >= 20e-3 - 1e-9
    for fx in planner.scene.cell[1:]:
        f = planner.scene.world.aabb(fx)
        for n, b in boxes.items():
            assert np.any(b[0, :2] >= f[1, :2]) or np.any(f[0, :2] >= b[1, :2]), (n, fx)
    planner.plan_steps(0, "housing")
    assert [s.kind for s, _ in planner.plan_steps(1, "bearing_2")] == ["regrasp", "insert"]


SLEEVE_HOLDER = """\
  regrasp:
    - name: holder
      pose: {xyz: [%s, %s, 0]}
      geometry:
        - {shape: box, size: [40, 40, 10], pose: {xyz: [0, 0, 5]}}
      holds:
        - {part: sleeve, pose: {xyz: [0, 0, 30]}}     # upright on the plate
"""


def test_the_cheaper_of_table_and_fixture_is_kept(tmp_path):
    """guide_sleeve with a declared stand 150 mm off: both ways work; the plan keeps the one
    whose two steps take less time (here the table spot beside the tray pose: 12.75 against
    14.21 s) and says what the other costs."""
    where = (150, -120)
    text = (PRODUCTS / "guide_sleeve.yaml").read_text()
    text = text.replace("  fixtures: [{name: vise, holds: block}]",
                        "  fixtures: [{name: vise, holds: block}]\n"
                        + SLEEVE_HOLDER % tuple(map(str, where)))
    path = tmp_path / "sleeve_with_holder.yaml"
    path.write_text(text)
    product = load_product(path)
    plan = plan_product(product, ProductGeometry(product)).plan
    put, pick = plan.steps[1], plan.steps[2]
    assert (put.kind, pick.kind) == ("regrasp", "insert")
    m = re.fullmatch(r"sleeve: regrasp (on the table|through a regrasp fixture): ([\d.]+) s for both "
                     r"steps, the shorter cycle time \(regrasp (on the table|through a regrasp "
                     r"fixture): ([\d.]+) s\)", put.notes[-1])
    assert m, put.notes
    chosen, other = float(m.group(2)), float(m.group(4))
    assert chosen == pytest.approx(put.cycle_time_s + pick.cycle_time_s, abs=0.006)
    assert chosen <= other
    assert m.group(1) != m.group(3)
    in_fixture = np.abs(put.T_world_final - product.resources.regrasp[0].T_world_seat(
        "sleeve")).max() < 1e-9
    assert in_fixture == (m.group(1) == "through a regrasp fixture")


def _sleeve_with_holder(tmp_path, where):
    text = (PRODUCTS / "guide_sleeve.yaml").read_text().replace(
        "  fixtures: [{name: vise, holds: block}]",
        "  fixtures: [{name: vise, holds: block}]\n" + SLEEVE_HOLDER % tuple(map(str, where)))
    path = tmp_path / f"sleeve_holder_{where[0]}_{where[1]}.yaml"
    path.write_text(text)
    return load_product(path)


def _regrasp_cycle_s(product) -> float:
    """Cycle time of the put-down and pick-again steps of the sleeve's plan, s."""
    plan = plan_product(product, ProductGeometry(product)).plan
    put, pick = plan.steps[1], plan.steps[2]
    assert (put.kind, pick.kind) == ("regrasp", "insert")
    return put.cycle_time_s + pick.cycle_time_s


@pytest.mark.parametrize("where, cheaper", [((90, 0), "through a regrasp fixture"),
                                            ((150, -120), "on the table")])
def test_the_planner_keeps_the_cheaper_regrasp_with_both_cycles_computed(tmp_path, monkeypatch,
                                                                         where, cheaper):
    """guide_sleeve with its holder 90 mm in front of the vise, between the tray (120, 60)
    and the block (0, 0): the fixture's two steps take 3.97 + 8.69 = 12.67 s, the table
    spot's 3.86 + 9.24 = 13.10 s, so the plan goes through the fixture; with the holder off
    the way at (150, -120) the fixture costs 4.77 + 9.46 = 14.22 s and the table spot
    3.86 + 8.92 = 12.78 s, so it goes over the table. Each figure in the plan's note is
    checked against the same regrasp planned with only that way open (the fixture's seat
    withdrawn, or no table pose offered), so the comparison is between computed cycles."""
    product = _sleeve_with_holder(tmp_path, where)
    plan = plan_product(product, ProductGeometry(product)).plan
    put, pick = plan.steps[1], plan.steps[2]
    m = re.fullmatch(r"sleeve: regrasp (on the table|through a regrasp fixture): ([\d.]+) s for "
                     r"both steps, the shorter cycle time \(regrasp (on the table|through a "
                     r"regrasp fixture): ([\d.]+) s\)", put.notes[-1])
    assert m, put.notes
    assert m.group(1) == cheaper
    chosen, other = float(m.group(2)), float(m.group(4))
    assert chosen == pytest.approx(put.cycle_time_s + pick.cycle_time_s, abs=0.006)
    in_fixture = np.abs(put.T_world_final - product.resources.regrasp[0].T_world_seat(
        "sleeve")).max() < 1e-9
    assert in_fixture == (cheaper == "through a regrasp fixture")

    # each way alone: the fixture with no table pose offered, the table with the seat withdrawn
    import asmplan.planner.regrasp_steps as regrasp_steps
    with monkeypatch.context() as mp:
        mp.setattr(regrasp_steps, "regrasp_poses", lambda *args, **kwargs: [])
        fixture_s = _regrasp_cycle_s(product)
    with monkeypatch.context() as mp:
        mp.setattr(type(product.resources.regrasp[0]), "T_world_seat", lambda self, part: None)
        table_s = _regrasp_cycle_s(product)
    ways = {"through a regrasp fixture": fixture_s, "on the table": table_s}
    assert chosen == pytest.approx(ways[m.group(1)], abs=0.006)
    assert other == pytest.approx(ways[m.group(3)], abs=0.006)
    assert ways[cheaper] == min(ways.values())
    # not a choice within rounding: the margins were 0.43 and 1.44 s when this was written
    assert max(ways.values()) - min(ways.values()) > 0.2


@pytest.mark.slow
def test_shaft_put_into_its_stand_simulates(gearbox_plan):
    """The shaft's regrasp step at BALANCED (2 s CPU): carried from the tray, turned upright
    and lowered tip first through the stand's funnel into its pocket (0.15 mm play a side),
    where it stands within the position tolerance; the stand is a static body of the step's
    scene, and the next step picks the shaft from it without a tray nest under it. (Without
    the funnel the shaft, carried 0.3 deg tilted, sat on the pocket's rim and the fingers
    slid 40 mm down it.)"""
    from asmplan.sim.fidelity import BALANCED
    from asmplan.sim.scene import select_scene
    from asmplan.sim.simulate import simulate_step

    product, geometry, plan = gearbox_plan
    k = next(s.index for s in plan.steps if s.part == "shaft" and s.kind == "regrasp")
    scene = select_scene(plan, k, product, geometry, BALANCED)
    stand = scene.body("fixture:shaft_stand")
    assert stand.role == "fixture" and not stand.dynamic
    result = simulate_step(plan, k, product, geometry, BALANCED)
    assert result.outcome.success, result.outcome.reasons
    assert result.outcome.final_position_error_m < product.process.position_tolerance_m
    assert result.outcome.max_slip_m < product.process.max_slip_m
    pick = select_scene(plan, k + 1, product, geometry, BALANCED)
    assert "nest:shaft" not in pick.names()
    assert "starts in fixture:shaft_stand" in pick.body("shaft").reason


def test_a_flanged_bearing_on_edge_waits_on_a_cradle_rail():
    """bearing_1 on edge on the tray rests on its 3 mm flange rim with its centre of mass
    beside it: on the bare table it fell over before the fingers arrived (the nest test took
    its body's lowest facet strip, too narrow for a nest, and gave up); now a rail carries the
    body."""
    from asmplan.sim.bodies import empty_holes, physics_model
    from asmplan.sim.nest import tray_nest
    from asmplan.sim.scene import SceneSettings

    product = load_product(GEARBOX)
    geometry = ProductGeometry(product)
    model, _ = physics_model(geometry, "bearing_1", "convex", True,
                             empty_holes(product, "bearing_1", frozenset({"bearing_1"})))
    nest = tray_nest(geometry, "bearing_1", product.part("bearing_1").T_world_start,
                     model.pieces, SceneSettings())
    assert nest is not None and nest[2].startswith("tray cradle")
    tops = [pc.T_part_piece[2, 3] * 2 for pc in nest[0]]
    # up to the 32 mm body (r 16), within its polygon's 4 um
    assert tops == pytest.approx([4e-3] * len(tops), abs=1e-5)


def test_report_views_show_each_part_once_and_the_fixtures(gearbox_plan):
    """The report's scenes: a regrasped part appears once (on the tray, in its regrasp pose,
    then assembled), and the cell's regrasp fixtures are drawn."""
    from asmplan.report.views import Views

    product, geometry, plan = gearbox_plan
    views = Views(product, geometry)
    put = next(s for s in plan.steps if s.part == "shaft" and s.kind == "regrasp")
    for k in range(len(plan.steps)):
        placed = [it.name for it in views.placed_items(plan, k)]
        waiting = [it.name for it in views.waiting_items(plan, k)]
        names = [n for n in placed + waiting if not n.startswith("fixture:")]
        assert len(names) == len(set(names)), (k, names)
        assert {"fixture:shaft_stand", "fixture:cover_rest"} <= set(placed)
    # while the shaft's pick runs, it stands in the stand (the put's final pose)
    during = {it.name: it for it in views.placed_items(plan, put.index + 1)}
    np.testing.assert_array_equal(during["shaft"].T_world_item, put.T_world_final)


def test_flat_cover_fails_where_a_real_cell_would(tmp_path):
    """The cover lying flat on the table (the file before its pedestal): its only grasps
    pinch the 8 mm edge, and for every one the lower finger (and the palm, 100 mm along the
    closing axis) would have to go under the plate into the table. With the pedestal where
    it lay, the layout check names the pedestal."""
    from asmplan.planner.errors import StartInCollisionError

    text = GEARBOX.read_text().replace("start: {location: cover_rest, xyz: [120, 300, 54]}",
                                       "start: {location: tray, xyz: [120, 300, 4]}")
    path = tmp_path / "flat_cover.yaml"
    path.write_text(text)
    product = load_product(path)
    with pytest.raises(StartInCollisionError, match=r"cover / fixture:cover_rest"):
        _planner(product)
    bare = dataclasses.replace(product, resources=dataclasses.replace(
        product.resources, regrasp=tuple(f for f in product.resources.regrasp
                                         if f.name != "cover_rest")))
    planner = _planner(bare, PlannerSettings(regrasp=False))
    k = 0
    for name in ("housing", "dowel_1", "dowel_2", "dowel_3", "dowel_4"):
        k += len(planner.plan_steps(k, name))
    with pytest.raises(NoGraspError) as info:
        planner.plan_steps(k, "cover")
    reasons = info.value.reasons
    table = re.fullmatch(r"(\d+) candidates: the gripper hits table at the start pose \(open "
                         r"fingers and palm\)", reasons[0])
    assert table, reasons
    # the hold criterion is checked before the collisions: the few grasps it rejects first
    # would tip the plate (283 g: 132 x 100 x 8 mm aluminium) about a patch edge; with the
    # 400 N class gripper, at 494 N and lever 49.4 mm, the pads' couple arm was
    # sf m (g + a) d / F = 2 x 0.283 x 11.81 x 0.0494 / 494 = 0.67 mm (a corner's sliver);
    # with the MHL2's 396 N three are rejected, the best just over it (396.x N, printed to 3
    # digits, lever 77.6 mm). With the 60 N gripper this cell had, 126 grasps were rejected
    # so, the best at 60.6 N (lever 77.7 mm: arm 8.6 mm, within the 20 mm pad)
    assert len(reasons) <= 2, reasons
    for r in reasons[1:]:
        m = re.fullmatch(r"(\d+) candidates?: the grip cannot hold the part's weight and inertia "
                         r"\(the best needs ([\d.]+) N per finger > 396 N \(tipping about the "
                         r"contact line: lever ([\d.]+) mm, contact torsion radius [\d.]+ mm\)\)", r)
        assert m, reasons
        assert int(m.group(1)) < 0.02 * int(table.group(1))
        assert float(m.group(2)) >= 396.0  # 3 significant digits
