"""A part placed by another operation (``handling.operation``): validated, planned as a
declared non-gripper step, placed at its assembled pose when its turn comes, and the later
steps simulated against it.

The product is the seed pin-hole station (part1 in the vise, part2 onto part1, part3 onto
part2, part4 onto part3) with part2 declared as placed by hand.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from asmplan.cli import main
from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.plan import Plan, assembly_state
from asmplan.planner.product import plan_product
from asmplan.planner.settings import PlannerSettings
from tests.conftest import example_path

HINT = "      grasp: {closing_axis: [0, 1, 0], approach_axis: [0, 0, -1]}\n"


def _station(tmp_path, handling: str, fixture_extra: str = ""):
    text = example_path("pinhole_station").read_text()
    assert HINT in text
    text = text.replace(HINT, handling)
    if fixture_extra:
        text = text.replace("    fixtured: true\n", "    fixtured: true\n" + fixture_extra, 1)
    path = tmp_path / "station.yaml"
    path.write_text(text)
    return path


def test_operation_key_errors_are_located_and_all_reported(tmp_path, capsys):
    path = _station(tmp_path, "      operation: press\n      grasp: {closing_axis: [0, 1, 0]}\n",
                    "    handling: {operation: manual}\n")
    with pytest.raises(ProductError) as info:
        load_product(path)
    text = str(info.value)
    assert "parts[1].handling.operation" in text and 'found "press"' in text
    assert "press_tool" in text  # expected: the operations, with a did-you-mean
    assert "parts[0].handling.operation" in text and "fixtured" in text
    # the grasp beside an invalid operation is not judged (operation invalid); with a valid one:
    path = _station(tmp_path, "      operation: press_tool\n      grasp: {closing_axis: [0, 1, 0]}\n"
                    "      max_clamp_force: 20\n")
    with pytest.raises(ProductError) as info:
        load_product(path)
    issues = info.value.issues
    keys = sorted(i.path for i in issues)
    assert keys == ["parts[1].handling.grasp", "parts[1].handling.max_clamp_force"], keys
    assert all("not by the gripper" in i.message for i in issues)
    path = _station(tmp_path, "      note: a press\n")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "parts[1].handling.note" in err and 'expected "operation"' in err


@pytest.fixture(scope="module")
def placed_by_hand(tmp_path_factory):
    path = _station(tmp_path_factory.mktemp("op"),
                    "      operation: manual\n      note: \"set by the operator\"\n")
    product = load_product(path)
    geometry = ProductGeometry(product)
    plan = plan_product(product, geometry, PlannerSettings()).plan
    return product, geometry, plan


def test_plan_declares_the_step_not_planned_for_the_robot(placed_by_hand, tmp_path):
    product, _geometry, plan = placed_by_hand
    assert list(plan.sequence) == ["part1", "part2", "part3", "part4"]
    step = plan.step("part2")
    assert step.kind == "operation" and step.operation == "manual"
    assert step.grasp is None and step.trajectory is None and step.path_T_world_gripper is None
    np.testing.assert_allclose(step.T_world_final, product.T_world_assembled("part2"), atol=1e-12)
    assert step.cycle_time_s == 0.0
    d = json.loads(plan.to_json())["steps"][1]
    assert d["kind"] == "operation" and d["grasp"] is None and d["trajectory"] is None
    assert d["operation"] == {"name": "manual", "note": "set by the operator",
                              "planned_for_robot": False, "simulated": False}
    assert Plan.from_json(plan.to_json()).to_json() == plan.to_json()
    # the robot steps around it are planned as usual
    assert plan.step("part3").kind == "insert" and plan.step("part3").grasp is not None


def test_later_step_is_simulated_against_the_placed_part(placed_by_hand):
    from asmplan.sim.fidelity import FAST
    from asmplan.sim.simulate import simulate_step

    product, geometry, plan = placed_by_hand
    op = simulate_step(plan, 1, product, geometry, FAST)
    assert not op.simulated and op.success and op.kind == "operation"
    assert op.warnings == ("placed by manual: not simulated",)
    assert op.to_dict()["simulated"] is False
    # part3's pins go into part2's holes: part2 stands at its assembled pose in that scene
    state = assembly_state(plan, 2)
    assert "part2" in state.placed
    np.testing.assert_allclose(state.T_world_part["part2"], product.T_world_assembled("part2"),
                               atol=1e-12)
    r = simulate_step(plan, 2, product, geometry, FAST)
    assert r.simulated and r.success, r.reasons
    assert "part2" in json.dumps(r.scene)  # in the scene, as the mate partner
    # seated within the H7/g6 fit's position tolerance on the placed part (analytic: 0)
    assert r.outcome.final_position_error_m < product.process.position_tolerance_m


@pytest.mark.slow
def test_run_reports_the_operation_step(tmp_path, capsys):
    path = _station(tmp_path, "      operation: manual\n      note: \"set by the operator\"\n")
    out = tmp_path / "out"
    assert main(["run", str(path), "--fidelity", "fast", "-o", str(out), "-j", "1"]) == 0
    text = capsys.readouterr().out
    assert "placed by manual: not simulated" in text
    assert "1 placed by another operation, not simulated: part2 by manual" in text
    results = json.loads((out / "results.json").read_text())
    step = next(s for s in results["steps"] if s["part"] == "part2")
    assert step["simulated"] is False and step["warnings"] == ["placed by manual: not simulated"]
    assert all(s["simulated"] and s["success"] for s in results["steps"]
               if s["part"] in ("part3", "part4"))
    html = (out / "report.html").read_text()
    assert "Placed by manual at its assembled pose" in html and "set by the operator" in html
    assert "part2 (manual)" in html  # in the verdict
