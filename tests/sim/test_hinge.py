"""The hinge example's verdicts at BALANCED (issue 17): both bronze bushings (5.5 g, held at
30 N per finger for the press handover) are carried to their lugs without turning in the
fingers and pressed home; bushing_b slides over the already-placed pin (F8/h8, 13-57 um) as
it goes in. Before, bushing_a was thrown off the pads on the lift (1.2 m/s) and bushing_b
turned 2 deg in the fingers during the carry and stopped on the rim: pad creep of a light part
squeezed at 555 times its weight, which friction anchors remove
(:func:`asmplan.sim.simulate.handover_fidelity`)."""

from __future__ import annotations

import math

import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.product import plan_product
from asmplan.planner.settings import PlannerSettings
from asmplan.sim.fidelity import BALANCED, FAST
from asmplan.sim.simulate import handover_fidelity
from tests.conftest import example_path


@pytest.fixture(scope="module")
def hinge() -> tuple:
    product = load_product(example_path("hinge"))
    geometry = ProductGeometry(product)
    return product, geometry, plan_product(product, geometry, PlannerSettings()).plan


def test_press_handovers_and_only_they_get_friction_anchors(hinge) -> None:
    _, _, plan = hinge
    for step in plan.steps:
        fid = handover_fidelity(BALANCED, step)
        handed = step.press is not None and step.press.by == "press"
        assert fid.friction_anchor is handed, step.part
        assert fid.dt_s == BALANCED.dt_s and fid.name == "balanced"
        assert handover_fidelity(FAST, step) is FAST  # FAST has them already
    # the grip the anchors are for: a light part squeezed far beyond its weight
    step = plan.step("bushing_a")
    assert step.clamp is not None
    assert step.commanded_force_N / (step.clamp.mass_kg * 9.81) > 500
    # and a product without a press is simulated as before
    peg = load_product(example_path("peg_in_hole"))
    peg_plan = plan_product(peg, ProductGeometry(peg), PlannerSettings()).plan
    assert all(handover_fidelity(BALANCED, s) is BALANCED for s in peg_plan.steps)


@pytest.mark.slow
@pytest.mark.parametrize("part", ["bushing_a", "bushing_b"])
def test_the_hinge_bushings_are_carried_and_pressed_home_at_balanced(hinge, part) -> None:
    from asmplan.sim.simulate import simulate_step

    product, geometry, plan = hinge
    k = next(i for i, s in enumerate(plan.steps) if s.part == part)
    result = simulate_step(plan, k, product, geometry, BALANCED)
    assert result.success, result.reasons
    assert result.press is not None and result.press["home"], result.press
    rec = result.record
    carried = [i for i, p in enumerate(rec.phase_index)
               if rec.phase_names[p] in ("hold", "lift", "translate", "lower")]
    # the analytic grip holds 33 N against 0.065 N: no creep worth the name
    assert math.degrees(float(rec.slip_rad[carried].max())) < 0.5
    assert float(rec.slip_m[carried].max()) < 0.1e-3
    assert result.outcome.max_penetration_m < 0.05e-3
