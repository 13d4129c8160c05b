"""Pin-in-hole insertion driven by the gripper (blind hole from parts/decompose.py).

Scene (bench.scenarios.PinHole): a 10 mm nominal hole, 20 mm deep, 8-sided exact
decomposition, in a fixtured 40 x 40 x 30 mm block; a 40 mm steel pin picked standing from
the table, carried over the hole and pushed straight down to 0.2 mm above the hole floor,
released, gripper retreats. No chamfer anywhere. Success = pin seated within 0.5 mm of the
floor and 1 mm of the target, no slip, no drop, insertion force within 20 N.
"""

from __future__ import annotations

import pytest

from asmplan.parts.decompose import effective_clearance_range
from asmplan.sim.fidelity import BALANCED
from bench.scenarios import PinHole, entered_depth_m, pin_insertion


@pytest.mark.slow
@pytest.mark.parametrize("radial_clearance_mm", [1.0, 0.5, 0.2, 0.1])
def test_clearance_fit_is_inserted(radial_clearance_mm):
    record, outcome = pin_insertion(BALANCED, radial_clearance_mm * 1e-3)
    assert outcome.success, outcome.reasons
    assert abs(outcome.final_axial_error_m) < 0.1e-3  # seated on the floor
    assert outcome.final_position_error_m < 0.5e-3
    # the lateral play inside the hole never exceeds the modelled polygon's widest play
    _, widest = effective_clearance_range(radial_clearance_mm * 1e-3, PinHole().n_sides)
    seated = record.phase_mask("release", "retreat")
    assert record.lateral_error_m[seated].max() <= widest + 20e-6
    assert outcome.max_penetration_m < 0.1e-3


@pytest.mark.slow
def test_interference_fit_is_reported_as_a_failed_insertion():
    record, outcome = pin_insertion(BALANCED, -0.05e-3)  # pin 0.1 mm larger in diameter
    assert not outcome.success
    assert any("insertion depth not reached" in r for r in outcome.reasons), outcome.reasons
    # blocked at the entrance (20 mm short at the end of "lower"), not pushed through; with
    # sharp rims (millimetre units) the unseated pin may topple when the fingers retreat
    assert outcome.final_position_error_m > 15e-3
    assert entered_depth_m(record) < 2e-3
    # the gripper kept pushing: the pin slipped in the fingers instead of entering
    assert outcome.max_slip_m > 10e-3
    assert any("slip" in r for r in outcome.reasons)


@pytest.mark.slow
def test_misaligned_insertion_without_chamfer_fails_with_its_numbers():
    record, outcome = pin_insertion(BALANCED, 0.5e-3, lateral_offset_m=2e-3)
    assert not outcome.success
    assert outcome.final_position_error_m > 1e-3
    assert entered_depth_m(record) < 2e-3
    text = " ".join(outcome.reasons)
    assert "final position error" in text and "mm" in text
