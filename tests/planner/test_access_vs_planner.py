"""gear_unit's collar after the cover: the gripper-access screening and the motion planner
compared on the one order where they disagreed (issue 18).

Measured (this file's tests): the screening looks at the best 200 grasp candidates and stops
after 96 in a row without a new minimal set (24 before the screening took the planner's 3000
surface samples; the figures below were measured then); every grasp it keeps meets the cover, so it ranks
the order unreachable. The planner, with its budget of 400 candidates plus 1600 whose fingers
reach below the table, finds a pinch of the collar's outer end: the pads on a 2.05 mm strip of
its 8 mm flank at 1.72 N per finger (the plan of this order, with the cell's arm). Given the
planner's budget the screening finds a free grasp too (1331 candidates examined, 1186 of them
below the table), so the geometric disagreement is the screening's budget. Without the carry
anchors (pads anchored from the clamp to the set-down contact, sim/fidelity.py) the collar
turned 3.24 deg in the pads during the transfer and jammed at 9.455 of 10 mm; with them BALANCED
inserts the planner's grasp (slow test below), so here the planner is right and the screening's
'unreachable' is its budget.

The screening's budget is kept, because of what the same order does: `asmplan plan
examples/gear_unit.yaml --sequence base,bearing_block,shaft,wheel,post_1,post_2,cover,collar`
plans the collar on a 2.05 mm strip at 1.72 N with a joint-space transfer (the arm cannot
follow the Cartesian one), and `asmplan simulate` at BALANCED then fails it: the collar turns
3.3 deg in the pads during the transfer with nothing touching it, and jams 0.55 mm short at
3.2 deg tilt. With the screening's budget widened to the planner's (measured on this branch,
reverted) the order ranks first (31.24 s against 31.39 s), `asmplan run` takes it, and
gear_unit fails at BALANCED; sequencing CPU also went 1.65 -> 2.78 s.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.access import AccessSettings, GripperAccess
from asmplan.planner.product import plan_product

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
COVER_THEN_COLLAR = ["base", "bearing_block", "shaft", "wheel", "post_1", "post_2", "cover",
                     "collar"]
PRE_DISTANCE_M = 0.02  # the collar's straight insertion (the sequence planner's)
REQUIRED = frozenset({"base", "bearing_block", "shaft"})


@pytest.fixture(scope="module")
def gear_unit():
    product = load_product(EXAMPLES / "gear_unit.yaml")
    return product, ProductGeometry(product)


@pytest.fixture(scope="module")
def cover_then_collar(gear_unit):
    product, geometry = gear_unit
    return plan_product(product, geometry, sequence=COVER_THEN_COLLAR).plan


def _collar_access(product, geometry, settings=None):
    access = GripperAccess(product, geometry, settings or AccessSettings())
    return access.access("collar", np.array([1.0, 0.0, 0.0]), PRE_DISTANCE_M, REQUIRED)


def test_screening_ranks_the_collar_after_the_cover_unreachable(gear_unit):
    product, geometry = gear_unit
    acc = _collar_access(product, geometry)
    present = frozenset(COVER_THEN_COLLAR[:-1])
    assert not acc.reachable(present)
    assert acc.reachable(present - {"cover"})  # the cover alone is what it finds in the way
    assert "cover" in acc.reason(present)
    assert acc.examined <= AccessSettings().max_candidates


def test_the_planner_grasps_it_by_a_2_mm_strip_that_the_screening_finds_with_its_budget(
        gear_unit, cover_then_collar):
    """The planner's grasp of the collar after the cover and the screening given the
    planner's budget: both find a free grasp, so the screening's 'unreachable' is its budget."""
    product, geometry = gear_unit
    step = cover_then_collar.step("collar")
    assert cover_then_collar.sequence[-1] == "collar" and step.kind == "insert"
    # the pads on a 2.05 mm strip of the 8 mm flank, across the collar's 20 mm, about
    # 1.7 N per finger
    assert step.grasp.width_m == pytest.approx(20e-3, abs=1e-4)
    assert step.clamp.pad_width_m < 3.5e-3
    assert 0.5 < step.clamp.commanded_N < 2.0
    wide = AccessSettings(max_candidates=2000, patience=2000)
    acc = _collar_access(product, geometry, wide)
    assert acc.reachable(frozenset(COVER_THEN_COLLAR[:-1]))
    assert acc.examined > AccessSettings().max_candidates  # beyond the screening's budget


@pytest.mark.slow
def test_the_planners_collar_grasp_after_the_cover_inserts_it_at_balanced(gear_unit,
                                                                          cover_then_collar):
    """About 25 s CPU: the planner's strip pinch holds and inserts the collar (it turned 3.24 deg
    in the pads and jammed at 9.455 of 10 mm before BALANCED's carry anchors)."""
    from asmplan.sim.fidelity import BALANCED
    from asmplan.sim.simulate import simulate_step

    product, geometry = gear_unit
    step = cover_then_collar.step("collar")
    result = simulate_step(cover_then_collar, step.index, product, geometry, BALANCED)
    assert result.outcome.success, result.outcome.reasons
    assert result.outcome.max_slip_rad < np.radians(3.0)
    assert result.outcome.final_position_error_m < product.process.position_tolerance_m
