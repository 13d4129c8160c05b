"""Press steps in the simulator: the predicted resistance, the force-depth curve, the hold."""

from __future__ import annotations

from pathlib import Path

import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.product import plan_product
from asmplan.planner.settings import PlannerSettings
from asmplan.sim.fidelity import BALANCED, FAST
from asmplan.sim.simulate import simulate_plan

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "press"


@pytest.mark.parametrize("fidelity", [FAST, BALANCED], ids=["fast", "balanced"])
def test_pressed_dowel_goes_home_with_the_lame_force_and_stays(tmp_path, fidelity):
    text = (FIXTURES / "steel_pin_in_steel.yaml").read_text().replace(
        "  table: {size: [600, 600, 40]}", "  table: {size: [600, 600, 40]}\n  press: {max_force: 20000}")
    path = tmp_path / "dowel_press.yaml"
    path.write_text(text)
    product = load_product(path)
    geometry = ProductGeometry(product)
    plan = plan_product(product, ProductGeometry(product), PlannerSettings(), sequence=["block", "dowel"]).plan
    result = simulate_plan(plan, product, geometry, fidelity).steps[1]
    assert result.success, result.reasons
    press = result.press
    assert press["by"] == "press" and press["home"]
    # the ram force at full depth is the typical Lame force (hand value 6.24 kN)
    assert press["peak_force_N"] == pytest.approx(6.25e3, rel=0.02)
    assert press["final_depth_m"] == pytest.approx(0.010, abs=0.05e-3)
    curve = press["force_depth"]
    # linear in the engaged depth: F(x) / x is the same at every engaged sample
    slopes = [f / x for x, f in curve if x > 1e-3]
    assert slopes and max(slopes) / min(slopes) < 1.05
    # the part stays where it was pressed after the gripper lets go (no drop to the hole's bottom)
    assert result.outcome.final_position_error_m < 0.1e-3


def test_gripper_pressed_transition_fit_at_balanced():
    product = load_product(FIXTURES / "pin_in_pom.yaml")
    plan = plan_product(product, ProductGeometry(product), PlannerSettings(), sequence=["block", "pin"]).plan
    result = simulate_plan(plan, product, ProductGeometry(product), BALANCED).steps[1]
    assert result.success, result.reasons
    assert result.press["by"] == "gripper" and result.press["home"]
    assert result.press["peak_force_N"] == pytest.approx(plan.step("pin").press.force_N[1], rel=0.05)
