"""The press-fit examples: checked clean, planned end to end with the cell's press, and
failing where a real cell would without it."""

from __future__ import annotations

import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.check import check_assembly
from asmplan.parts.models import ProductGeometry
from asmplan.planner.plan import PlannerSettings
from asmplan.planner.press import PressRequiredError
from asmplan.planner.product import plan_product
from tests.conftest import example_path

PRESS_EXAMPLES = ("bearing_housing", "hinge", "pneumatic_cylinder")


@pytest.mark.parametrize("name", PRESS_EXAMPLES)
def test_example_checks_clean_with_press_forces(name):
    product = load_product(example_path(name))
    result = check_assembly(product, ProductGeometry(product))
    assert result.success, result.reason
    assert not [f for f in result.findings if f.severity == "error"]
    kinds = {m.kind for m in product.mates}
    assert kinds >= {"clearance", "transition"}  # every example has both
    assert result.press_fits and all(p.force_N[2] > 0 for p in result.press_fits)


@pytest.mark.parametrize("name", PRESS_EXAMPLES)
def test_example_plans_end_to_end_with_its_press(name):
    product = load_product(example_path(name))
    plan = plan_product(product, ProductGeometry(product), PlannerSettings()).plan
    pressed = [s for s in plan.steps if s.press is not None]
    assert pressed and all(s.press.by == "press" for s in pressed)
    for s in pressed:  # the press seats the part: the plan ends at the seated pose
        assert s.T_world_final == pytest.approx(product.T_world_assembled(s.part))
        assert s.press.press_max_force_N >= s.press.force_N[2]


@pytest.mark.parametrize("name", PRESS_EXAMPLES)
def test_without_the_press_each_example_fails_where_a_real_cell_would(tmp_path, name):
    text = example_path(name).read_text()
    assert text.count("  press: {max_force: 10000}\n") == 1
    path = tmp_path / "no_press.yaml"
    path.write_text(text.replace("  press: {max_force: 10000}\n", ""))
    product = load_product(path)
    with pytest.raises(PressRequiredError, match="use a press") as err:
        plan_product(product, ProductGeometry(product), PlannerSettings())
    e = err.value
    # the failing step is a real press fit: its max force is beyond what the grip can push
    assert e.force_N[2] > e.capacity.force_N
    assert e.capacity.force_N <= product.gripper_for(e.part).max_force_N * 2
    mates = {m.name: m for m in product.mates}
    assert e.mates and all(mates[m].clearance_min_m < 0 for m in e.mates)
    assert "needs" in str(e) and "gripper max" in str(e)
