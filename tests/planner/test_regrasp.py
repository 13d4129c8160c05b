"""Regrasp (issue 18): a part that no grasp holds both where it lies and where it goes is put
down on the table in another orientation and picked again, as steps of the plan that are
simulated like any other."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from asmplan.knowledge.frames import rotation_from_rpy
from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.errors import NoGraspError
from asmplan.planner.plan import Plan, assembly_state
from asmplan.planner.product import plan_product
from asmplan.planner.regrasp import free_positions, stable_orientations
from asmplan.planner.settings import PlannerSettings
from asmplan.sim.fidelity import BALANCED
from asmplan.sim.simulate import simulate_step

SLEEVE = Path(__file__).resolve().parents[1] / "fixtures" / "products" / "guide_sleeve.yaml"


def _cylinder_points(d: float, length: float, n: int = 64) -> np.ndarray:
    a = np.linspace(0, 2 * math.pi, n, endpoint=False)
    ring = np.stack([d / 2 * np.cos(a), d / 2 * np.sin(a)], axis=1)
    return np.vstack([np.column_stack([ring, np.full(n, z)]) for z in (-length / 2, length / 2)])


def test_a_sleeve_lying_flat_is_put_down_upright_first():
    pts = _cylinder_points(0.02, 0.04)
    R_flat = rotation_from_rpy([0.0, math.pi / 2, 0.0])  # axis along world x
    out = stable_orientations(pts, np.zeros(3), np.eye(3), R_flat)
    assert out, "a 20 x 40 mm cylinder stands on either end"
    R, down, margin = out[0]
    np.testing.assert_allclose(R, np.eye(3), atol=1e-12)  # the assembled orientation first
    np.testing.assert_allclose(down, [0, 0, -1], atol=1e-12)
    assert margin == pytest.approx(0.01, abs=2e-4)  # the centre sits 10 mm inside its end face
    # only its end faces: the start's side down is never proposed, and a cylinder on the
    # line of its flank tips (rolls) at once
    assert sorted(round(float(d[2])) for _, d, _ in out) == [-1, 1]


def test_a_disc_is_not_stood_on_its_rim():
    # a 2 mm disc on a 40 mm diameter: stable on its face, its rim is a line: not proposed
    pts = _cylinder_points(0.04, 0.002)
    out = stable_orientations(pts, np.zeros(3), rotation_from_rpy([math.pi / 2, 0, 0]),
                              rotation_from_rpy([math.pi / 2, 0, 0]))
    assert all(abs(abs(d[2]) - 1) < 1e-9 for _, d, _ in out)


def test_free_positions_keep_clear_of_other_footprints_and_the_table_edge():
    foot = np.array([[-0.01, -0.01], [0.01, 0.01]])
    avoid = np.array([[[0.09, -0.05], [0.15, 0.05]]])  # a part 90-150 mm along x
    got = list(free_positions(foot, np.array([0.12, 0.0]), avoid, np.array([0.2, 0.1]),
                              0.02, 0.01, 50))
    assert got
    for p in got:
        lo, hi = p + foot[0] - 0.02, p + foot[1] + 0.02
        assert not (np.all(lo < avoid[0, 1]) and np.all(hi > avoid[0, 0]))
        assert np.all(lo >= -np.array([0.2, 0.1]) - 1e-12) and np.all(hi <= [0.2, 0.1])
    d = [float(np.linalg.norm(p - [0.12, 0.0])) for p in got]
    assert d == sorted(d)  # nearest the start first


@pytest.fixture(scope="module")
def sleeve_plan():
    product = load_product(SLEEVE)
    geometry = ProductGeometry(product)
    return product, geometry, plan_product(product, geometry).plan


def test_sleeve_without_regrasp_has_no_grasp():
    """The product needs the regrasp: without it no grasp survives (tray pose or bore)."""
    product = load_product(SLEEVE)
    with pytest.raises(NoGraspError, match="start pose"):
        plan_product(product, ProductGeometry(product), PlannerSettings(regrasp=False))


@pytest.mark.slow
def test_sleeve_lying_flat_gets_a_regrasp_that_simulates(sleeve_plan, tmp_path):
    product, geometry, plan = sleeve_plan
    assert [s.kind for s in plan.steps] == ["fixture", "regrasp", "insert"]
    assert plan.sequence == ("block", "sleeve")
    put, pick = plan.steps[1], plan.steps[2]
    # put down upright (the assembled orientation), on its end face: centre 20 mm up
    np.testing.assert_allclose(put.T_world_final[:3, :3], np.eye(3), atol=1e-9)
    assert put.T_world_final[2, 3] == pytest.approx(0.02, abs=1e-6)
    np.testing.assert_array_equal(pick.T_world_start, put.T_world_final)
    assert "regrasp" in pick.start_note
    # both grasps come from above (no steeper than 45 deg) where the sleeve lies flat, and the
    # second straight down onto the upright sleeve in its bore
    down = np.array([0.0, 0.0, -1.0])
    for step, T_part, least in ((put, put.T_world_start, 0.7), (pick, pick.T_world_final, 0.99)):
        approach = T_part[:3, :3] @ step.grasp.approach_axis_part
        assert float(approach @ down) > least
    assert plan.step("sleeve") is pick
    state = assembly_state(plan, 2)
    np.testing.assert_array_equal(state.T_world_part["sleeve"], put.T_world_final)
    assert state.placed == frozenset({"block"})
    # the plan file keeps the steps
    again = Plan.from_json(plan.to_json())
    assert [s.kind for s in again.steps] == ["fixture", "regrasp", "insert"]
    for k in (1, 2):  # success includes: it stands where it was put down (position)
        result = simulate_step(plan, k, product, geometry, BALANCED)
        assert result.outcome.success, (k, result.outcome.reasons)
        assert result.outcome.final_position_error_m < product.process.position_tolerance_m


def test_plan_rejects_a_regrasp_out_of_sequence(sleeve_plan):
    _, _, plan = sleeve_plan
    with pytest.raises(ValueError, match="sequence order"):
        replace(plan, sequence=("sleeve", "block"))


@pytest.mark.slow
def test_gearbox_bearing_pressed_from_outside_gets_a_grasp_on_its_flange():
    """The gearbox's flanged bearing (issue 18): once in its seat only the 3 mm flange stands
    out of the wall, so only fingers coming along the bearing's axis and covering 2 mm of the
    flange rim fit. On the tray (on edge) such a grasp centred on the axis puts the palm into
    the table; one with the pads' edge on the flange's equator clears it. That grasp touches
    the rim along two 2 mm lines (7 mm^2, below the old 12 mm^2 area floor, which made it a
    regrasp): the hold criterion (mu 0.35, lever 5 mm) needs about 35 N of the 40 N, so it is
    picked directly, without the regrasp."""
    from asmplan.planner.motion import MotionPlanner
    from asmplan.planner.partdata import part_data

    product = load_product(SLEEVE.parent / "gearbox.yaml")
    settings = PlannerSettings()
    planner = MotionPlanner(product, settings,
                            part_data(product, settings, ProductGeometry(product)))
    steps = [s for s, _ in planner.plan_steps(1, "bearing_1")]
    assert [s.kind for s in steps] == ["insert"]
    insert = steps[0]
    g = insert.grasp
    assert g.hold_required_N <= insert.clamp.limit_N
    assert insert.clamp.commanded_N == pytest.approx(g.hold_required_N, rel=1e-9)
    assert 4 * g.torsion_radius_m <= 3e-3  # line contacts across the 3 mm flange
    approach = insert.T_world_final[:3, :3] @ insert.grasp.approach_axis_part
    np.testing.assert_allclose(approach, [1, 0, 0], atol=1e-9)  # along the bearing's axis
    # the fingertips (pad centre + half the pad length along the approach) stop short of the
    # wall face (x = -66 mm) by at least the position tolerance
    tip = (insert.T_world_final @ insert.grasp.T_part_gripper)[:3, 3] + approach * 0.015
    assert tip[0] <= -0.066 - product.process.position_tolerance_m + 1e-9
    assert "bearing_1" in planner.placed
