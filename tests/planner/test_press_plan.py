"""Press steps at planning: the force a step needs against what the gripper or the press gives."""

from __future__ import annotations

from pathlib import Path

import pytest

from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.plan import Plan
from asmplan.planner.press import PressRequiredError, push_capacity
from asmplan.planner.product import plan_product
from asmplan.planner.settings import PlannerSettings

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "press"
DOWEL = FIXTURES / "steel_pin_in_steel.yaml"


def _with_press(tmp_path, max_force: str) -> Path:
    text = DOWEL.read_text().replace("  table: {size: [600, 600, 40]}",
                                     f"  table: {{size: [600, 600, 40]}}\n  press: {{max_force: {max_force}}}")
    path = tmp_path / "dowel_press.yaml"
    path.write_text(text)
    return path


def test_press_fit_beyond_the_gripper_fails_at_planning_with_the_numbers():
    product = load_product(DOWEL)
    with pytest.raises(PressRequiredError) as info:
        plan_product(product, ProductGeometry(product), PlannerSettings(), sequence=["block", "dowel"])
    err = info.value
    # 8 mm H7/s6 steel in steel, 10 mm: 2.5 / 6.25 / 10 kN (tests/parts/test_press_fit_geometry)
    assert err.force_N[0] == pytest.approx(2.50e3, rel=0.02)
    assert err.force_N[2] == pytest.approx(10.0e3, rel=0.02)
    # grip: 2 x (1.0 x 0.7) x 60 N / 2 - m (g + a)
    mass = product.part("dowel").material.density_kg_m3 * 3.141592653589793 * 0.004**2 * 0.030
    cap = push_capacity(product, "dowel", mass)
    assert cap.grip_N == pytest.approx(42.0 - mass * (9.81 + 2.0), rel=1e-6)
    assert err.capacity.force_N == pytest.approx(cap.force_N, rel=1e-3)
    msg = str(err)
    assert "needs 2.5-10 kN" in msg and "gripper max 41.9 N" in msg and "use a press" in msg
    ev = err.evidence()
    assert ev["kind"] == "press_required" and ev["mates"] == ["dowel_press"]
    assert ev["force_N"]["max"] == pytest.approx(err.force_N[2])


def test_too_weak_a_press_fails_with_its_max(tmp_path):
    product = load_product(_with_press(tmp_path, "5000"))
    with pytest.raises(PressRequiredError, match=r"the press max 5(\.0)? kN: use a stronger press"):
        plan_product(product, ProductGeometry(product), PlannerSettings(), sequence=["block", "dowel"])


def test_with_a_press_the_step_is_a_press_operation_with_a_firm_grip(tmp_path):
    product = load_product(_with_press(tmp_path, "20000"))
    plan = plan_product(product, ProductGeometry(product), PlannerSettings(), sequence=["block", "dowel"]).plan
    step = plan.step("dowel")
    assert step.press is not None and step.press.by == "press"
    assert step.press.force_N[1] == pytest.approx(6.25e3, rel=0.02)
    # the grip is planned firm (half the push capacity), not the 0.1 N of a free dowel
    assert step.clamp.resistance_N == pytest.approx(0.5 * step.press.capacity.force_N)
    assert step.clamp.commanded_N > 10.0
    back = Plan.from_json(plan.to_json())
    assert back.step("dowel").press == step.press


def test_gripper_presses_a_light_transition_fit_and_the_clamp_carries_it():
    product = load_product(FIXTURES / "pin_in_pom.yaml")
    plan = plan_product(product, ProductGeometry(product), PlannerSettings(), sequence=["block", "pin"]).plan
    step = plan.step("pin")
    assert step.press.by == "gripper"
    # H7/js6 at 6 mm: -4..+16 um; interferes with probability Phi(-6 / (sqrt(12^2 + 8^2) / 6))
    assert step.press.probability_interference == pytest.approx(0.0062, abs=0.001)
    assert 20.0 < step.press.force_N[2] < 30.0
    assert step.clamp.resistance_N == pytest.approx(step.press.force_N[2])
    mu = 1.0 * 0.7
    assert step.clamp.required_N >= 2.0 * step.press.force_N[2] / (2 * mu)


def test_press_resource_is_validated_with_location(tmp_path):
    text = DOWEL.read_text().replace("  table: {size: [600, 600, 40]}",
                                     "  table: {size: [600, 600, 40]}\n  press: {max_forse: 2000}")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ProductError) as info:
        load_product(path)
    text = str(info.value)
    assert "resources.press" in text and 'unknown key "max_forse"' in text and "max_force" in text
