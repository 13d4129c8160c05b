"""The tool turn (half-turn grasp symmetry) chosen over the whole sequence (issue 20): a
dynamic programme over the steps instead of the nearest variant one step at a time."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from asmplan.knowledge.loader import load_product
from asmplan.planner.arm_turns import apply_turns, best_turns, retune_turns
from asmplan.planner.motion import MotionPlanner
from asmplan.planner.settings import ArmSettings, PlannerSettings
from tests.planner.conftest import ORDERS

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _q6(*values: float) -> np.ndarray:
    q = np.zeros(6)
    q[5] = values[0]
    return q


def _slowest_joint(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(b - a).max())


def _greedy(variants) -> tuple[list[int], float]:
    """Step by step: the first step as planned (variant 0), each next one the variant nearest
    the previous step's last state."""
    choice, cost = [0], 0.0
    for k in range(1, len(variants)):
        end = variants[k - 1][choice[-1]][1]
        v = min(range(len(variants[k])), key=lambda i: (_slowest_joint(end, variants[k][i][0]), i))
        cost += _slowest_joint(end, variants[k][v][0])
        choice.append(v)
    return choice, cost


def test_the_programme_beats_the_greedy_choice_when_a_later_step_cannot_turn():
    """Step 1 can hold its grasp either way (joint 6 at 0 or pi), step 2 only one way (its
    other variant is beyond joint 6's limit), step 3 either way. Greedy keeps step 1 as
    planned and pays half a turn before step 2; the programme turns step 1 and pays nothing
    (analytic: pi vs 0 on the slowest joint, plus step 3 nearest either way)."""
    pi = math.pi
    variants = [
        [(_q6(0.0), _q6(0.0)), (_q6(pi), _q6(pi))],
        [(_q6(pi), _q6(pi + 0.3))],
        [(_q6(0.3), _q6(0.3)), (_q6(pi + 0.3), _q6(pi + 0.3))],
    ]
    g_choice, g_cost = _greedy(variants)
    choice, cost = best_turns(variants, _slowest_joint)
    assert g_choice == [0, 0, 1] and math.isclose(g_cost, pi)
    assert choice == [1, 0, 1] and math.isclose(cost, 0.0, abs_tol=1e-12)
    # ties keep the plan as it is
    assert best_turns([[(_q6(0), _q6(0)), (_q6(pi), _q6(pi))]] * 2, _slowest_joint)[0] == [0, 0]


def test_retuning_a_worse_turn_choice_on_the_seed_workstation():
    """pinhole_station planned step by step, then its first arm step turned the other way
    (a valid plan, proven again: path checked, transfer certified, but half a wrist turn
    longer before step 2). The programme brings the turns back to the cheaper choice, with
    less transfer time, and every arm state still puts the TCP on the planned path."""
    product = load_product(EXAMPLES / "pinhole_station.yaml")
    settings = PlannerSettings(arm=ArmSettings(plan_tool_turns=False))
    planner = MotionPlanner(product, settings, _parts(product, settings))
    steps = []
    for name in ORDERS["pinhole_station"]:
        steps += [s for s, _ in planner.plan_steps(len(steps), name)]
    arm_steps = [s for s in steps if s.arm is not None]
    assert len(arm_steps) == 3
    worse = apply_turns(planner, steps, [1, 0, 0])
    w_arm = [s for s in worse if s.arm is not None]
    assert w_arm[0].arm.tool_turned != arm_steps[0].arm.tool_turned
    assert w_arm[1].arm.transfer_s > arm_steps[1].arm.transfer_s + 0.1
    planner.settings = PlannerSettings(arm=ArmSettings(plan_tool_turns=True))
    better = retune_turns(planner, worse)
    b_arm = [s for s in better if s.arm is not None]
    assert [s.arm.tool_turned for s in b_arm] == [s.arm.tool_turned for s in arm_steps]
    assert sum(s.arm.transfer_s for s in b_arm) < sum(s.arm.transfer_s for s in w_arm) - 0.1
    for s in [*w_arm, *b_arm]:
        T = np.array([planner.arm.arm.fk(q) for q in s.arm.q_rad[:: 10]])
        assert np.abs(T - s.trajectory.T_world_gripper[:: 10]).max() < 1e-5
        # the grasp turned with the tool: the part's path is unchanged
        tr = s.trajectory
        seated = int(np.flatnonzero(tr.phase_indices_at(tr.t_s)
                                    == [p.name for p in tr.phases].index("lower"))[-1])
        T_part = tr.T_world_gripper[seated] @ np.linalg.inv(s.grasp.T_part_gripper)
        assert np.abs(T_part - s.T_world_final).max() < 1e-6


def _parts(product, settings):
    from asmplan.parts.models import ProductGeometry
    from asmplan.planner.partdata import part_data

    return part_data(product, settings, ProductGeometry(product))
