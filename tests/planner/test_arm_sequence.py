"""Sequences that know the arm (issue 20 item 3, issue 18): an order whose step needs a pose
the arm cannot take ranks below the orders the arm can do, with the distance and the reach."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.fcl_oracle import FclOracle
from asmplan.planner.sequence import SequenceSettings, plan_sequence

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "arm"
# every term but reach equal: only the names' order (cover < drawer) would rank the orders
EVEN = SequenceSettings(top_k=4, reorientation_s=0.0, direction_change_s=0.0,
                        travel_s_per_m=0.0)


@pytest.fixture(scope="module")
def drawer():
    product = load_product(FIXTURES / "drawer_reach.yaml")
    return product, FclOracle(product, ProductGeometry(product))


def _mm(text: str, what: str) -> float:
    m = re.search(rf"{what} of drawer is (\d+) mm from the arm's shoulder, reach (\d+) mm", text)
    assert m, text
    return float(m.group(1)), float(m.group(2))


def test_the_order_whose_step_the_arm_cannot_reach_ranks_below_with_its_reason(drawer):
    """With the cover on, the drawer slides in along -x from 80 mm further out: beyond the
    stated 650 mm. Ranked by the names alone (every other term equal), that order would come
    first; with the arm screened it ranks below the other, carrying the distance and reach."""
    product, oracle = drawer
    blind = plan_sequence(product, oracle, dataclasses.replace(EVEN, arm_reach=False))
    assert blind.best.order == ("cabinet", "cover", "drawer")
    assert all(s.terms["unreachable"] == 0 for s in blind.sequences)

    sp = plan_sequence(product, oracle, EVEN)
    first, second = sp.sequences
    assert first.order == ("cabinet", "drawer", "cover")
    assert first.terms["unreachable"] == 0 and all(st.unreachable == "" for st in first.steps)
    assert second.order == ("cabinet", "cover", "drawer")
    assert second.terms["unreachable"] == 1
    step = second.steps[2]
    assert step.part == "drawer" and step.insertion_label == "-x"
    dist, reach = _mm(step.unreachable, "pre-insertion pose")
    assert reach == 650 and dist > reach
    # the motion planner's start along -x: clear of the cabinet (110 mm out), then the
    # 80 mm approach: every grasp is beyond the reach there, whatever else is placed
    assert step.unreachable.startswith("the arm cannot do the step of drawer in any order: "
                                       "pre-insertion pose of drawer is")
    # with the default weights the reachable order was first already; it stays first
    default = plan_sequence(product, oracle, SequenceSettings(top_k=4))
    assert default.best.order == ("cabinet", "drawer", "cover")
    assert default.sequences[1].terms["unreachable"] == 1


def test_the_reported_distance_is_the_flange_from_the_shoulder(drawer):
    """The screened distance is |flange - shoulder| (computed here from the base pose, the
    mounting and the shoulder without the planner) at the motion planner's pre-insertion
    pose: 190 mm along +x from the seated pose (110 mm to clear the cabinet's walls, then the
    80 mm approach), within the tool's length of the part's pre-insertion position."""
    from asmplan.planner.access import GripperAccess
    from asmplan.planner.arm import ArmModel
    from asmplan.planner.settings import ArmSettings

    product, oracle = drawer
    sp = plan_sequence(product, oracle, EVEN)
    dist, _ = _mm(sp.sequences[1].steps[2].unreachable, "pre-insertion pose")
    arm = ArmModel(product.resources.robot, ArmSettings())
    shoulder = (arm.T_world_base @ np.append(arm.shoulder_base, 1.0))[:3]
    seat = product.T_world_assembled("drawer")[:3, 3]
    pre_m = GripperAccess(product).pre_distance_m("drawer", np.array([-1.0, 0.0, 0.0]),
                                                  frozenset({"cabinet", "cover"}))
    assert pre_m == pytest.approx(0.190, abs=1e-6)
    pre = seat + np.array([pre_m, 0.0, 0.0])
    # the flange is within the tool's length (mounting + TCP offset) of the TCP, which is
    # within the part's half-size of its centre
    tool = float(np.linalg.norm(product.resources.robot.T_flange_tcp[:3, 3])) + 0.1
    assert np.linalg.norm(pre - shoulder) - tool <= dist / 1e3 <= (
        np.linalg.norm(pre - shoulder) + tool)


def test_a_tray_part_beyond_reach_carries_the_arm_reason_in_every_order():
    """far_tray: the peg's pick pose is about 1 m from the shoulder (reach 700 mm): no order
    can do its step, and the sequence says so with the pose, the distance and the reach."""
    product = load_product(FIXTURES / "far_tray.yaml")
    sp = plan_sequence(product, FclOracle(product, ProductGeometry(product)))
    step = next(st for st in sp.best.steps if st.part == "peg")
    assert sp.best.terms["unreachable"] == 1
    m = re.search(r"the arm cannot do the step of peg in any order: (pick|lifted) pose of peg "
                  r"is (\d+) mm from the arm's shoulder, reach 700 mm", step.unreachable)
    assert m, step.unreachable
    assert 900 < float(m.group(2)) < 1200


def test_the_order_whose_step_needs_the_forearm_through_a_placed_part_ranks_below():
    """guard.yaml: with the 480 mm guard standing, the forearm at the peg's pre-insertion and
    seated poses passes through it (every IK branch); the gripper alone is clear. Ranked by
    the names alone (every other term equal) guard-first would come first; with the arm's
    links screened it ranks below, its reason naming the link and the guard, and the motion
    planner fails that order at the peg's step on the same pair."""
    product = load_product(FIXTURES / "guard.yaml")
    oracle = FclOracle(product, ProductGeometry(product))
    blind = plan_sequence(product, oracle, dataclasses.replace(EVEN, arm_collisions=False))
    assert blind.best.order == ("block", "guard", "peg")
    assert all(s.terms["unreachable"] == 0 for s in blind.sequences)

    sp = plan_sequence(product, oracle, EVEN)
    first, second = sp.sequences
    assert first.order == ("block", "peg", "guard") and first.terms["unreachable"] == 0
    assert second.order == ("block", "guard", "peg") and second.terms["unreachable"] == 1
    step = second.steps[2]
    assert step.part == "peg"
    assert re.search(r"the arm cannot reach peg with guard placed: at the pre-insertion and "
                     r"seated poses .*forearm \(arm:link3\) hits guard", step.unreachable), \
        step.unreachable
    # the motion planner, checking every state of the path with FCL, agrees
    from asmplan.planner.errors import ArmCollisionError
    from asmplan.planner.product import plan_product

    with pytest.raises(ArmCollisionError) as info:
        plan_product(product, ProductGeometry(product), sequence=("block", "guard", "peg"))
    assert info.value.part == "peg"
    assert any(p.a == "arm:link3" and p.b == "guard" for p in info.value.pairs)


def test_a_fixture_in_the_forearm_s_way_makes_the_step_unreachable_in_every_order():
    """column.yaml: the clamp column is fixtured (in its pose from the start), so a branch
    whose links meet it is unusable in every order, like the table; the reason names the
    pair. (The motion planner's failure on the same pair: tests/planner/test_arm.py.)"""
    product = load_product(FIXTURES / "column.yaml")
    sp = plan_sequence(product, FclOracle(product, ProductGeometry(product)))
    for seq in sp.sequences:
        step = next(st for st in seq.steps if st.part == "peg")
        assert seq.terms["unreachable"] == 1
        assert re.search(r"the arm cannot do the step of peg in any order: pre-insertion and "
                         r"seated poses of peg: .*(upper arm|forearm) \(arm:link\d\) hits "
                         r"column \(every inverse-kinematics branch\)", step.unreachable), \
            step.unreachable
    blind = plan_sequence(product, FclOracle(product, ProductGeometry(product)),
                          SequenceSettings(arm_collisions=False))
    assert all(s.terms["unreachable"] == 0 for s in blind.sequences)


def test_the_screened_pre_insertion_pose_is_the_motion_planners():
    """gear_unit: for every step, the access screening's pre-insertion distance with the
    parts placed before it equals the plan's (|T_world_pre_insertion - seated|); the shaft's is its clearing travel through both
    bearing bores plus the approach (70 mm), not its pin feature's length (60 mm)."""
    from asmplan.examples import __file__ as examples_init
    from asmplan.planner.access import GripperAccess
    from asmplan.planner.product import plan_product

    product = load_product(Path(examples_init).parent / "gear_unit.yaml")
    plan = plan_product(product, ProductGeometry(product)).plan
    access = GripperAccess(product, ProductGeometry(product))
    order = list(plan.sequence)
    checked = 0
    for step in plan.steps:
        if step.T_world_pre_insertion is None:
            continue
        seated = product.T_world_assembled(step.part)[:3, 3]
        planned = float(np.linalg.norm(step.T_world_pre_insertion[:3, 3] - seated))
        placed = frozenset(order[:order.index(step.part)])
        screened = access.pre_distance_m(step.part, step.insertion_direction, placed)
        assert screened == pytest.approx(planned, abs=1e-6), step.part
        checked += 1
    assert checked >= 6
    shaft = plan.step("shaft")
    assert float(np.linalg.norm(shaft.T_world_pre_insertion[:3, 3] - product.T_world_assembled(
        "shaft")[:3, 3])) == pytest.approx(0.070, abs=1e-6)


def test_the_sequence_inserts_along_the_direction_the_arm_can_reach():
    """drawer_front.yaml: the drawer may go into its raised cabinet from above (-z, the
    sequencer's first choice without the arm) or through the front (+x). From above the
    pre-insertion pose is beyond the stated 580 mm reach; through the front it starts 190 mm
    closer to the arm. The sequence takes +x, and the motion planner plans the step that way
    (starting where the screening put it) instead of failing on the reach."""
    from asmplan.planner.access import GripperAccess
    from asmplan.planner.product import plan_product

    product = load_product(FIXTURES / "drawer_front.yaml")
    oracle = FclOracle(product, ProductGeometry(product))
    blind = plan_sequence(product, oracle, SequenceSettings(arm_reach=False))
    assert blind.best.steps[1].insertion_label == "-z"
    sp = plan_sequence(product, oracle)
    step = sp.best.steps[1]
    assert step.part == "drawer" and step.insertion_label == "+x"
    assert step.free_insertions == ("+x", "-z")
    assert sp.best.terms["unreachable"] == 0 and step.unreachable == ""

    plan = plan_product(product, ProductGeometry(product)).plan
    planned = plan.step("drawer")
    assert np.allclose(planned.insertion_direction, [1.0, 0.0, 0.0])
    seated = product.T_world_assembled("drawer")[:3, 3]
    pre_m = GripperAccess(product).pre_distance_m("drawer", np.array([1.0, 0.0, 0.0]),
                                                  frozenset({"cabinet"}))
    assert pre_m == pytest.approx(0.190, abs=1e-6)
    assert float(np.linalg.norm(planned.T_world_pre_insertion[:3, 3] - seated)) == \
        pytest.approx(pre_m, abs=1e-6)
    assert planned.arm is not None
