"""gear_unit's shaft and cover steps at FAST: physics or model? (issue 16, session 7 "fast").

Measured on main a3cea70 (``asmplan run examples/gear_unit.yaml --fidelity fast``):

* shaft: stops on the bore's rim with the tip 1.26 mm off, is pushed out of the grip and falls
  (final error 52.8 mm). The rim stop follows from the offset (capture needs
  |e0| < c/2 + chamfers = 0.5 + 0.5 mm), and the offset is the shaft turning 1.10 deg and
  sliding 0.55 mm in the pads while carried. A real grip does not: the moment of the
  shaft's weight and acceleration about the grip, m (g + a) l = 0.049 kg x 11.81 m/s^2 x
  33.4 mm = 0.0194 N m, is 1/5.9 of the simulated pads' torsional capacity
  (2 mu F r_mean = 0.114 N m) and 1/2.9 of the planner's line-contact estimate
  (2 mu F L/4 = 0.057 N m) (``test_shaft_grip_holds_analytically``). At half FAST's time
  step the same scene turns 0.03 deg and the step succeeds; with 3x (0.5x) the pads'
  torsional friction it still turns 1.04 (0.60) deg, and with friction_erp 0.5 / 0.8 / 1.0
  it turns 0.71 / 0.23 / 0.71 deg: the creep is FAST's time step (friction anchors at
  1/240 s in metre units), not the friction limit, and no FAST knob tried removes it.
* cover: stops 3.2 mm short on the post heads with the cover level in the grip (0.01 deg) and
  0.07 mm off, well inside the capture boundary of two chamfered H11/c11 holes
  (0.04 mm + 1.0 mm); it succeeds at BALANCED, at FAST with half the time step and at FAST
  in millimetre units: FAST (which resolves 2 mm of clearance) does not resolve this fit.

Both FAST verdicts are model defects; they are pinned here as strict expected failures
(they flip to passes when FAST's grip creep and fit resolution are fixed), with the
controls that locate the cause.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.product import plan_product
from asmplan.sim.fidelity import FAST
from asmplan.sim.gripper import pad_torsion_radius_m
from asmplan.sim.simulate import simulate_step

from .conftest import example_path

G = 9.81


@pytest.fixture(scope="module")
def gear_plan():
    product = load_product(example_path("gear_unit"))
    geometry = ProductGeometry(product)
    plan = plan_product(product, geometry).plan
    return product, geometry, plan


def _step(plan, part):
    return next(i for i, s in enumerate(plan.steps) if s.part == part)


def _grip_rotation_deg(result) -> float:
    """Rotation of the part relative to the gripper from the start of the hold to the start of
    the lowering (the carry), deg."""
    rec = result.to_dict()["record"]
    G_ = np.asarray(rec["T_world_gripper"])
    P = np.asarray(rec["T_world_part"])
    ph = np.asarray(rec["phase_index"])
    names = list(rec["phase_names"])
    i0 = int(np.argmax(ph == names.index("hold")))
    i1 = int(np.argmax(ph == names.index("lower")))
    r0 = np.linalg.inv(G_[i0]) @ P[i0]
    r1 = np.linalg.inv(G_[i1]) @ P[i1]
    R = r0[:3, :3].T @ r1[:3, :3]
    return math.degrees(math.acos(float(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))))


@pytest.mark.slow
def test_shaft_grip_holds_analytically(gear_plan):
    """A real grip holds the shaft: the pads' torsional capacity (the simulator's own
    coefficient, mu F r_mean per pad) exceeds the moment of m (g + a) about the grip by > 4x
    (measured 5.9x; the planner's line-contact estimate 2.9x), and the linear load is below
    a tenth of 2 mu F. So a 1.1 deg turn in the pads is not physics."""
    product, _, plan = gear_plan
    step = plan.steps[_step(plan, "shaft")]
    clamp = step.clamp
    lever = step.grasp.com_offset_m
    moment = clamp.mass_kg * (G + clamp.acceleration_m_s2) * lever
    grip = product.gripper_for("shaft")
    pad = np.asarray(grip.finger_size_m, float)
    mu_part = product.part("shaft").friction
    force = clamp.commanded_N
    capacity = 2 * force * mu_part * pad_torsion_radius_m(pad[0], pad[2])
    assert 0.025 <= lever <= 0.040, lever  # the grasp sits ~33 mm from the centre of mass
    assert capacity > 4.0 * moment, (capacity, moment)
    # the planner's own (line-contact) torsion radius still leaves > 2x
    planner_capacity = 2 * force * clamp.mu * step.grasp.torsion_radius_m
    assert planner_capacity > 2.0 * moment, (planner_capacity, moment)
    load = clamp.mass_kg * (G + clamp.acceleration_m_s2)
    assert load < 0.1 * 2 * grip.finger_friction * mu_part * force, (load, force)


@pytest.mark.slow
def test_shaft_grip_creep_is_the_time_step(gear_plan):
    """Control: at half FAST's time step the grip holds (< 0.1 deg) and the step succeeds."""
    product, geometry, plan = gear_plan
    fine = dataclasses.replace(FAST, dt_s=FAST.dt_s / 2, record_every_steps=8)
    res = simulate_step(plan, _step(plan, "shaft"), product, geometry, fine)
    assert _grip_rotation_deg(res) < 0.1
    assert res.success, res.to_dict()["outcome"]["reasons"]


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="model defect: the held shaft creeps ~1.1 deg in the pads "
                   "at FAST's 1/240 s (metre units); a real grip holds it (6x torsion margin)")
def test_shaft_step_at_fast(gear_plan):
    product, geometry, plan = gear_plan
    res = simulate_step(plan, _step(plan, "shaft"), product, geometry, FAST)
    assert _grip_rotation_deg(res) < 0.1
    assert res.success


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="model defect: FAST (2 mm fit resolution) jams the cover's "
                   "H11/c11 holes on the post heads 3.2 mm short with the cover level and 0.07 mm "
                   "off, inside the capture boundary; it succeeds at BALANCED and at FAST/2")
def test_cover_step_at_fast(gear_plan):
    product, geometry, plan = gear_plan
    res = simulate_step(plan, _step(plan, "cover"), product, geometry, FAST)
    assert res.success


@pytest.mark.slow
def test_cover_jam_is_the_time_step(gear_plan):
    """Control: at half FAST's time step the cover seats (final error < 0.5 mm)."""
    product, geometry, plan = gear_plan
    fine = dataclasses.replace(FAST, dt_s=FAST.dt_s / 2, record_every_steps=8)
    res = simulate_step(plan, _step(plan, "cover"), product, geometry, fine)
    assert res.success, res.to_dict()["outcome"]["reasons"]
    assert res.to_dict()["outcome"]["final_position_error_m"] < 0.5e-3
