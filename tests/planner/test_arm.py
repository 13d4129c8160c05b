"""The arm in the cell: kinematics against an independent FK, IK round trips over every branch,
reach, joint-limit and arm-collision failures with their evidence, joint-limited timing, and
every example planned with its arm."""

from __future__ import annotations

import dataclasses
import itertools
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from asmplan.examples import __file__ as _examples_init
from asmplan.knowledge.frames import make_T
from asmplan.knowledge.loader import load_product
from asmplan.knowledge.robot import JointLimit, bundled_urdf
from asmplan.parts.models import ProductGeometry
from asmplan.planner.arm import ArmModel
from asmplan.planner.arm_timing import joint_rates
from asmplan.planner.errors import ArmCollisionError, JointLimitError, OutOfReachError
from asmplan.planner.plan import Plan
from asmplan.planner.product import plan_product as _plan_product
from asmplan.planner.settings import ArmSettings

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "arm"


def plan_product(product, settings=None):
    return _plan_product(product, ProductGeometry(product), settings)
EXAMPLES = Path(_examples_init).parent


@pytest.fixture(scope="module")
def arm() -> ArmModel:
    product = load_product(EXAMPLES / "pinhole_station.yaml")
    return ArmModel(product.resources.robot, ArmSettings())


def _urdf_fk(q: np.ndarray) -> np.ndarray:
    """Flange pose of the xArm 6 in its base frame, composed straight from the URDF's joint
    origins and z axes (no pinocchio)."""
    root = ET.parse(bundled_urdf("xarm6")).getroot()
    T = np.eye(4)
    k = 0
    for j in root.findall("joint"):
        o = j.find("origin")
        T = T @ make_T([float(v) for v in o.get("xyz").split()],
                       [float(v) for v in o.get("rpy").split()])
        if j.get("type") == "revolute":
            assert j.find("axis").get("xyz").split() == ["0", "0", "1"]
            T = T @ make_T(rpy_rad=(0.0, 0.0, q[k]))
            k += 1
    assert k == 6
    return T


def test_fk_matches_the_urdf_chain_composed_by_hand(arm: ArmModel) -> None:
    rng = np.random.default_rng(3)
    base_inv = np.linalg.inv(arm.T_world_base)
    for q in rng.uniform(np.maximum(arm.lower, -3), np.minimum(arm.upper, 3), size=(20, 6)):
        T_base_flange = base_inv @ arm.fk(q) @ np.linalg.inv(arm.T_flange_tcp)
        assert np.abs(T_base_flange - _urdf_fk(q)).max() < 1e-9


def test_ik_round_trip_every_branch(arm: ArmModel) -> None:
    """FK(IK(T)) = T to 1 um and 1e-6 rad on every branch found, all branches distinct and
    within the limits, and the configuration T came from among them."""
    rng = np.random.default_rng(7)
    found_origin = 0
    trials = 0
    for q in rng.uniform(np.maximum(arm.lower, -3), np.minimum(arm.upper, 3), size=(40, 6)):
        if arm.manipulability(q) / arm.best_manipulability < 0.02:
            continue  # near a singularity the branches merge
        trials += 1
        T = arm.fk(q)
        sols, fail = arm.ik_all(T)
        assert fail is None and sols
        for s in sols:
            E = np.linalg.inv(T) @ arm.fk(s.q_rad)
            assert np.linalg.norm(E[:3, 3]) < 1e-6
            assert math.acos(np.clip((np.trace(E[:3, :3]) - 1) / 2, -1, 1)) < 2e-6
            assert np.all(s.q_rad >= arm.lower) and np.all(s.q_rad <= arm.upper)
        for a, b in itertools.combinations(sols, 2):
            assert np.abs((a.q_rad - b.q_rad + np.pi) % (2 * np.pi) - np.pi).max() > 1e-3
        diffs = [np.abs((s.q_rad - q + np.pi) % (2 * np.pi) - np.pi).max() for s in sols]
        found_origin += min(diffs) < 1e-4
    assert trials >= 20
    assert found_origin >= 0.9 * trials, f"{found_origin} of {trials}"


def test_a_pose_has_several_branches(arm: ArmModel) -> None:
    """Above the table in front of the arm: shoulder, elbow and wrist variants exist."""
    T = arm.fk(np.array([0.3, -0.2, -0.9, 0.1, 0.8, 0.2]))
    sols, _ = arm.ik_all(T)
    labels = {s.branch for s in sols}
    assert len(sols) >= 3 and len(labels) >= 3, labels
    assert {"noflip", "flip"} <= {lab.split("/")[2] for lab in labels}


def test_tray_beyond_reach_fails_with_distance_and_reach() -> None:
    product = load_product(FIXTURES / "far_tray.yaml")
    with pytest.raises(OutOfReachError, match=r"pick pose of peg is \d+ mm from the arm's "
                                              r"shoulder, reach 700 mm") as info:
        plan_product(product)
    err = info.value
    arm = ArmModel(product.resources.robot, ArmSettings())
    # the flange above the pick pose, measured from the shoulder by hand
    flange = err.T_world_tcp @ np.linalg.inv(arm.T_flange_tcp)
    shoulder = arm.T_world_base @ np.array([0.0, 0.0, 0.267, 1.0])
    expected = float(np.linalg.norm(flange[:3, 3] - shoulder[:3]))
    assert err.distance_m == pytest.approx(expected, abs=1e-9)
    # the tray at x = 900 mm, the shoulder at (-200, -120, 267) mm: about 1.1 m
    assert 1.05 < err.distance_m < 1.2
    assert err.reach_m == pytest.approx(0.7)
    assert err.evidence()["kind"] == "out_of_reach"


def test_grasp_beyond_a_joint_limit_fails_naming_the_joint() -> None:
    product = load_product(FIXTURES / "joint_limited.yaml")
    j1 = product.resources.robot.joints[0]
    assert (math.degrees(j1.lower_rad), math.degrees(j1.upper_rad)) == pytest.approx((-30, 30))
    with pytest.raises(JointLimitError, match=r"joint1 at 90\.0 deg, beyond its limits "
                                              r"\[-30\.0, 30\.0\] deg") as info:
        plan_product(product)
    err = info.value
    assert err.joint == "joint1"
    # the tray is straight to the left of the base (+y): joint 1 must face 90 deg
    assert math.degrees(err.value_rad) == pytest.approx(90.0, abs=0.1)


def test_forearm_through_a_fixture_fails_naming_the_pair() -> None:
    product = load_product(FIXTURES / "column.yaml")
    with pytest.raises(ArmCollisionError, match=r"(upper arm|forearm) \(arm:link\d\) hits "
                                                 r"column") as info:
        plan_product(product)
    pairs = {(p.a, p.b) for p in info.value.pairs}
    assert any(a.startswith("arm:link") and b == "column" for a, b in pairs)
    # without the column the same cell plans
    free = dataclasses.replace(product, parts=tuple(p for p in product.parts
                                                    if p.name != "column"),
                               resources=dataclasses.replace(
                                   product.resources,
                                   fixtures=product.resources.fixtures[:1]))
    plan = plan_product(free).plan
    assert plan.step("peg").arm is not None


def _slow_joints(product, velocity_rad_s: float, acceleration_rad_s2: float):
    robot = product.resources.robot
    joints = tuple(JointLimit(j.name, j.lower_rad, j.upper_rad, velocity_rad_s,
                              acceleration_rad_s2) for j in robot.joints)
    robot = dataclasses.replace(robot, joints=joints)
    return dataclasses.replace(product, resources=dataclasses.replace(product.resources,
                                                                      robot=robot))


def test_trajectory_is_retimed_within_the_joint_limits() -> None:
    product = load_product(EXAMPLES / "peg_in_hole.yaml")
    fast = plan_product(product).plan.step("peg")
    v, a = 0.3, 1.0
    slow = plan_product(_slow_joints(product, v, a)).plan.step("peg")
    # the Cartesian timing alone breaks the slower joints' limits ...
    vel, acc = joint_rates(fast.trajectory.t_s, fast.arm.q_rad)
    assert np.abs(vel).max() > v * 1.2
    # ... the arm's timing keeps them (same path, phases stretched)
    vel, acc = joint_rates(slow.trajectory.t_s, slow.arm.q_rad)
    assert np.abs(vel).max() <= v * (1 + 1e-6)
    assert np.abs(acc).max() <= a * (1 + 1e-6)
    assert np.array_equal(slow.trajectory.T_world_gripper, fast.trajectory.T_world_gripper)
    assert slow.trajectory.duration_s > fast.trajectory.duration_s
    scales = dict(slow.arm.phase_time_scale)
    assert scales["clamp"] == 1.0 and max(scales.values()) > 1.0


@pytest.mark.slow
@pytest.mark.parametrize("name", ["pinhole_station", "peg_in_hole", "gear_unit"])
def test_every_example_plans_with_its_arm(name: str, tmp_path: Path) -> None:
    product = load_product(EXAMPLES / f"{name}.yaml")
    assert product.resources.robot is not None
    plan = plan_product(product).plan
    arm = ArmModel(product.resources.robot, ArmSettings())
    moved = [s for s in plan.steps if s.kind != "fixture"]
    assert moved
    for s in moved:
        assert s.arm is not None and s.arm.q_rad.shape == (len(s.trajectory.t_s), 6)
        # the simulated gripper follows the arm's TCP: FK of the joint path is the trajectory
        for k in range(0, len(s.trajectory.t_s), 7):
            assert np.linalg.norm(arm.fk(s.arm.q_rad[k])[:3, 3]
                                  - s.trajectory.T_world_gripper[k][:3, 3]) < 1.5e-6
        assert np.all(s.arm.q_rad >= arm.lower - 1e-9) and np.all(s.arm.q_rad <= arm.upper + 1e-9)
        vel, acc = joint_rates(s.trajectory.t_s, s.arm.q_rad)
        assert np.all(np.abs(vel) <= arm.vmax * (1 + 1e-6))
        assert np.all(np.abs(acc) <= arm.amax * (1 + 1e-6))
        assert s.cycle_time_s == pytest.approx(s.trajectory.duration_s + s.arm.transfer_s)
    # the arm's moves between steps join one step's last state to the next one's first
    for prev, s in itertools.pairwise(moved):
        W = s.arm.transfer_q_rad
        assert len(W) >= 2
        assert np.abs(W[0] - prev.arm.q_rad[-1]).max() < 1e-12
        assert np.abs(W[-1] - s.arm.q_rad[0]).max() < 1e-12
        assert s.arm.transfer_s > 0
    assert len(moved[0].arm.transfer_q_rad) == 0 and moved[0].arm.transfer_s == 0
    assert plan.cycle_time_s == pytest.approx(sum(s.cycle_time_s for s in plan.steps))
    # the plan file carries the joint trajectories
    path = plan.write(tmp_path / "plan.json")
    back = Plan.read(path)
    for a, b in zip(plan.steps, back.steps, strict=True):
        if a.arm is not None:
            assert np.abs(a.arm.q_rad - b.arm.q_rad).max() < 1e-8
            assert a.arm.branch == b.arm.branch


def test_transfer_the_arm_cannot_follow_is_planned_in_joint_space() -> None:
    """The tray lies behind the arm: the gripper's planned straight transfer would sweep
    through the arm's own base; OMPL plans the transfer in joint space (the base turns) and
    the gripper follows FK of that path."""
    product = load_product(FIXTURES / "behind.yaml")
    step = plan_product(product).plan.step("peg")
    a = step.arm
    assert a.joint_space_translate
    assert any("planned in joint space" in n for n in step.notes)
    arm = ArmModel(product.resources.robot, ArmSettings())
    traj = step.trajectory
    idx = traj.phase_indices_at(traj.t_s)
    names = [p.name for p in traj.phases]
    sel = np.flatnonzero(idx == names.index("translate"))
    # the base turns about half a turn between the tray (-x of the base) and the vise (+x)
    turn = abs(a.q_rad[sel[-1], 0] - a.q_rad[sel[0], 0])
    assert math.degrees(turn) == pytest.approx(180.0, abs=20.0)
    # inside the joint-space leg the TCP is FK of the joint path exactly; its two ends are
    # the lifted and pre-insertion poses, solved by IK to its 1 um tolerance
    for k in sel[1:-1:10]:
        assert np.linalg.norm(arm.fk(a.q_rad[k])[:3, 3] - traj.T_world_gripper[k][:3, 3]) < 1e-9
    for k in (sel[0], sel[-1]):
        assert np.linalg.norm(arm.fk(a.q_rad[k])[:3, 3] - traj.T_world_gripper[k][:3, 3]) < 1.5e-6
    assert np.array_equal(step.path_T_world_gripper, traj.T_world_gripper[sel])
    assert np.all(a.q_rad >= arm.lower) and np.all(a.q_rad <= arm.upper)
    vel, acc = joint_rates(traj.t_s, a.q_rad)
    assert np.all(np.abs(vel) <= arm.vmax * (1 + 1e-6))
    assert np.all(np.abs(acc) <= arm.amax * (1 + 1e-6))


def test_the_gripper_is_turned_half_a_turn_where_that_spares_the_wrist() -> None:
    """pinhole_station: after part2, part3's grasp as the grasp planner gives it needs joint 6
    about half a turn from where the arm stands; the parallel gripper holds the part the same
    way turned half a turn about its approach axis, and the arm takes that."""
    from asmplan.parts.cell import HALF_TURN

    product = load_product(EXAMPLES / "pinhole_station.yaml")
    plan = plan_product(product).plan
    arm = ArmModel(product.resources.robot, ArmSettings())
    moved = [s for s in plan.steps if s.kind != "fixture"]
    turned = [(prev, s) for prev, s in itertools.pairwise(moved) if s.arm.tool_turned]
    assert turned, [s.part for s in moved]
    for prev, s in turned:
        q_last = prev.arm.q_rad[-1]
        q_first = s.arm.q_rad[0]
        # the joint-6 move between the steps is short ...
        assert abs(q_first[5] - q_last[5]) < math.pi / 2
        # ... and the grasp as planned (turned back) would need about half a turn more
        T_back = s.trajectory.T_world_gripper[0] @ HALF_TURN
        q_back, ok = arm.solve(T_back, q_first + np.array([0, 0, 0, 0, 0, math.pi]))
        assert ok
        assert abs(q_back[5] - q_last[5]) > abs(q_first[5] - q_last[5]) + math.pi / 2
        # the grasp is given turned with the trajectory: the part is seated where it belongs
        traj = s.trajectory
        idx = traj.phase_indices_at(traj.t_s)
        k = int(np.flatnonzero(idx == [p.name for p in traj.phases].index("lower"))[-1])
        T_part = traj.T_world_gripper[k] @ np.linalg.inv(s.grasp.T_part_gripper)
        assert np.abs(T_part[:3, :3] - s.T_world_final[:3, :3]).max() < 1e-9
        assert np.linalg.norm(T_part[:3, 3] - s.T_world_final[:3, 3]) < 1e-6


def test_a_gripper_mounted_into_the_wrist_fails_naming_the_pair() -> None:
    """The wrist links are checked against the mounted gripper: peg_in_hole's gripper (palm
    30 mm deep behind 30 mm fingers) mounted 40 mm from the flange instead of 60 mm has its
    palm 5.4 mm inside the flange link, whatever the wrist does; planning fails naming the
    flange and the gripper (before, only links up to wrist 1 were checked against it)."""
    product = load_product(EXAMPLES / "peg_in_hole.yaml")
    robot = product.resources.robot
    T = np.array(robot.T_flange_tcp, float)
    T[2, 3] = 0.040
    short = dataclasses.replace(product, resources=dataclasses.replace(
        product.resources, robot=dataclasses.replace(robot, T_flange_tcp=T)))
    g = short.resources.gripper
    # palm back face: TCP - finger length / 2 - palm depth, here 5 mm behind the flange face
    assert 0.040 - g.finger_size_m[2] / 2 - g.palm_size_m[2] < 0
    with pytest.raises(ArmCollisionError, match=r"flange \(arm:link6\) hits gripper") as info:
        plan_product(short)
    assert any(p.a == "arm:link6" and p.b.startswith("gripper") for p in info.value.pairs)


def test_a_press_step_plans_with_the_arm() -> None:
    """pneumatic_cylinder with its xArm 6 (base 320 mm in front of the product): its
    press-fitted caps are handed over to the press by the arm; the step's trajectory is
    lengthened by the ram's stroke and the arm holds its last joint angles over it (this
    raised 'expected the arm's joint angles at every trajectory sample' before)."""
    product = load_product(EXAMPLES / "pneumatic_cylinder.yaml")
    assert product.resources.robot is not None
    plan = plan_product(product).plan
    pressed = [s for s in plan.steps if s.press is not None and s.press.by == "press"]
    assert pressed
    for s in pressed:
        assert s.arm is not None and len(s.arm.q_rad) == len(s.trajectory.t_s)
        assert np.array_equal(s.arm.q_rad[-1], s.arm.q_rad[-2])
        # the ram's stroke is the last sample's extra time, the arm standing still
        assert s.trajectory.t_s[-1] > s.trajectory.t_s[-2]
