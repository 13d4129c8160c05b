"""The grip's pad rows in the fit contact's solve (`Fidelity.grip_rows`, sim/grip_pads.py)
against the bundled chamfered peg at small pose errors (session 13's trace, docs/physics.md,
"The grip's normals in the solve", open).

With the rows the jaws are rigid across the closing axis (a rack and pinion, a stiff robot):
a pin offset along that axis can neither slide nor be pushed into a pad, so the offset beyond
half the clearance has nowhere to go. The peg then stops where the two 45 deg chamfer cones
meet with no lateral give, and the robot's push slides it up through the pads (ACCURATE,
shipped with the rows), as the loose peg 0.3 mm off along the closing axis does at BALANCED
(tests/sim/test_sweep.py). Without the rows the same 0.05 mm goes in at BALANCED because
Bullet's pads let the pin sink 30-92 um into one of them (measured): a compliance of the
solver, not of a gripper."""

from __future__ import annotations

import dataclasses

import pytest

from bench.grip_rows_trace import rigid_jaw_depths_m, run_peg

pytestmark = pytest.mark.slow


def _peg_step(preset: str, grip_rows: bool, lateral_m: tuple[float, float],  # type: ignore[no-untyped-def]
              lateral_stiffness_N_per_m: float | None = None):
    from asmplan.knowledge.loader import load_product
    from asmplan.parts.models import ProductGeometry
    from asmplan.planner.plan import assembly_state
    from asmplan.planner.product import plan_product
    from asmplan.sim.fidelity import preset as named
    from asmplan.sim.results import criteria_for
    from asmplan.sim.simulate import simulate_placed_step
    from asmplan.sim.sweep import PoseError
    from tests.conftest import example_path

    product = load_product(example_path("peg_in_hole"))
    geometry = ProductGeometry(product)
    plan = plan_product(product, geometry).plan
    (k,) = [i for i, s in enumerate(plan.steps) if s.part == "peg"]
    closing = plan.steps[k].trajectory.T_world_gripper[-1][:3, 1]
    fid = dataclasses.replace(named(preset), grip_rows=grip_rows)
    import asmplan.sim.simulate as simulate_module
    from asmplan.sim.scene import gripper_spec

    def spec(resource, max_commanded_N=0.0):  # type: ignore[no-untyped-def]
        return dataclasses.replace(gripper_spec(resource, max_commanded_N),
                                   lateral_stiffness_N_per_m=lateral_stiffness_N_per_m)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(simulate_module, "gripper_spec", spec)
        res = simulate_placed_step(plan.steps[k], assembly_state(plan, k), product, geometry,
                                   fid, criteria=criteria_for(product),
                                   pose_error=PoseError(lateral_m))
    return product, closing, res


def test_rigid_jaws_keep_a_peg_offset_along_the_closing_axis_on_the_chamfer() -> None:
    """ACCURATE (rows on): 0.05 mm along the closing axis, H7/g6 as built 17 um, chamfers
    0.5 mm each: the chamfers meet at w_pin + w_hole - (e - c/2) = 0.9585 mm (measured
    0.962 mm, the exact contact's penetration under ~1 N), then the peg slides up the pads
    (5.8 mm, dropped). The same at BALANCED with the rows' friction rounds raised from 10 to
    60 (0.964 mm); with 10 the pin pivots in the pads instead and jams deeper (below)."""
    e = 0.05e-3
    product, closing, res = _peg_step("accurate", True, (0.0, -e))
    assert abs(closing[1]) > 0.999  # the offset lies along the closing axis (world y)
    c = product.mates[0].clearance_mean_m
    w = product.feature("block", "hole").chamfer_m
    assert w == product.feature("peg", "tip").chamfer_m
    stop_m, _ = rigid_jaw_depths_m(e, c, w, w, 1.0)
    assert res.success is False
    (jam,) = [f for f in res.outcome.failures if f.code == "jammed"]
    assert jam.value == pytest.approx(stop_m, abs=0.01e-3)
    assert res.outcome.max_slip_m > 1e-3


def test_pivoting_in_the_pads_jams_where_rigid_jaw_kinematics_put_it() -> None:
    """BALANCED with the rows (10 friction rounds): the pin pivots about the middle of the
    pads' contact line (the jaws open 36 um against the clamp), past the chamfers, and its
    axis, held through that point 0.05 mm off the bore's, reaches two-point contact at
    l = c H / (e + c/2) + both chamfers = 9.682 mm (measured 9.709 mm, the contacts 8.70 mm
    apart along the axis against 8.682). This is the failure of
    tests/sim/test_sweep_nominal.py with the rows on at BALANCED."""
    e = 0.05e-3
    product, _, res = _peg_step("balanced", True, (0.0, -e))
    assert res.success is False
    # the grasp: pads 25 mm long (examples/peg_in_hole.yaml) centred 13.25 mm above the
    # peg's centre (its plan), the peg 40 mm long: contact from 0.75 to 20 mm above its centre
    pivot_above_tip_m = 20e-3 + 0.5 * (0.75e-3 + 20e-3)
    w = product.feature("block", "hole").chamfer_m
    _, jam_m = rigid_jaw_depths_m(e, product.mates[0].clearance_mean_m, w, w, pivot_above_tip_m)
    (jam,) = [f for f in res.outcome.failures if f.code == "jammed"]
    assert jam.value == pytest.approx(jam_m, abs=0.1e-3)


def test_rows_hold_a_pin_offset_across_the_closing_axis_in_the_pads() -> None:
    """BALANCED with the rows, 0.05 mm ACROSS the closing axis: the pin slides along the pad
    faces by about the offset and goes in (slip 0.041 mm; without the rows 0.046 mm). With a
    friction cone per pad point (before sim/grip_pads.pad_friction_caps) it slid 1.17 mm down
    the pads under its 0.24 N weight while the fit carried < 0.05 N (strict xfail here
    until the caps landed): the exact normal solve loaded one point per pad, another each
    round, and the friction built on the unloaded ones was cut to zero."""
    e = 0.05e-3
    result, _, _ = run_peg("balanced", True, (e, 0.0))
    assert result["success"] is True, result["reasons"]
    assert result["outcome"]["max_slip_m"] < 2.0 * e


@pytest.mark.parametrize("k_N_per_m", [1000.0, 20000.0])
def test_a_stated_lateral_compliance_lets_the_closing_axis_offset_in(k_N_per_m: float) -> None:
    """BALANCED with the rows and the jaws on a spring across the closing axis
    (`GripperSpec.lateral_stiffness_N_per_m`, docs/physics.md "The cell's lateral
    compliance"): the same 0.05 mm along the closing axis that jams rigid jaws (above) goes in,
    the chamfer pushing the jaws over by the offset beyond c/2 (41.5 um: 0.04 N at 1 kN/m,
    0.83 N at 20 kN/m). Measured: slip 0.010 mm at 1000 N/m, 0.131 mm at 20000 N/m; a stiff
    cell's 1e6 N/m jams as rigid jaws do (9.841 mm, not asserted here)."""
    e = 0.05e-3
    _, _, res = _peg_step("balanced", True, (0.0, -e), k_N_per_m)
    assert res.success is True, res.reasons
    assert res.outcome.max_slip_m < 0.2e-3
