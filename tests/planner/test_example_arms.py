"""Every bundled example is a cell with an arm: it declares one (``resources.robot``) and its
plan carries the arm's joint trajectory for every step the robot does, which the arm's forward
kinematics turns back into the step's planned TCP path (planning only; the simulations of
the examples are slow and run outside the suite)."""

from __future__ import annotations

import numpy as np
import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.arm import ArmModel
from asmplan.planner.product import plan_product
from asmplan.planner.settings import ArmSettings
from tests.conftest import EXAMPLES

NAMES = sorted(p.stem for p in EXAMPLES.glob("*.yaml"))

FK_TOL_M = 1e-4
"""FK of the planned joints against the planned TCP position: the IK tolerance (the plan's
``max_ik_error_m`` is far below it) with room for the joint-space transfer's FK path."""


def test_the_examples_are_the_six_bundled_cells():
    assert len(NAMES) >= 6 and {"pinhole_station", "bearing_housing", "hinge",
                                "pneumatic_cylinder"} <= set(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_every_example_declares_an_arm_within_reach_of_its_parts(name):
    product = load_product(EXAMPLES / f"{name}.yaml")
    robot = product.resources.robot
    assert robot is not None, f"{name}: no resources.robot"
    assert robot.urdf_path is not None and robot.urdf_path.is_file()
    arm = ArmModel(robot, ArmSettings())
    base = arm.T_world_base[:3, 3]
    for part in product.part_names:  # every start and assembled pose within the stated reach
        if product.is_fixtured(part):  # in its fixture from the start: never picked
            continue
        for T in (product.T_world_assembled(part), product.part(part).T_world_start):
            assert np.linalg.norm(np.asarray(T)[:3, 3] - base) < arm.reach_m, (name, part)


@pytest.mark.parametrize("name", NAMES)
def test_every_example_plans_a_joint_trajectory_per_step(name):
    product = load_product(EXAMPLES / f"{name}.yaml")
    plan = plan_product(product, ProductGeometry(product)).plan
    arm = ArmModel(product.resources.robot, ArmSettings())
    moved = [s for s in plan.steps if s.kind != "fixture"]
    assert moved
    for s in moved:
        assert s.arm is not None, (name, s.part)
        q = np.asarray(s.arm.q_rad)
        assert q.shape == (len(s.trajectory.t_s), len(arm.joint_names))
        assert np.all(q >= arm.lower - 1e-9) and np.all(q <= arm.upper + 1e-9), (name, s.part)
        tcp = np.array([arm.fk(qi)[:3, 3] for qi in q])
        err = np.linalg.norm(tcp - np.asarray(s.trajectory.T_world_gripper)[:, :3, 3], axis=1)
        assert err.max() < FK_TOL_M, (name, s.part, float(err.max()))
        assert s.arm.max_ik_error_m < FK_TOL_M
    # the arm moves between steps: every step after the first starts with a joint transfer
    # from where the last one left it
    assert moved[0].arm.transfer_s == 0
    assert all(s.arm.transfer_s > 0 and len(s.arm.transfer_q_rad) >= 2 for s in moved[1:])
