"""gear_unit's shaft, collar and cover steps at FAST: not resolved, not jammed (issues 16, 17).

Measured on main a3cea70 (``asmplan run examples/gear_unit.yaml --fidelity fast``) and again on
ee9b3bd (session 10):

* shaft: the shaft turns 1.0 deg and slides 0.6 mm in the pads while carried, then turns
  16 deg in the grip as it enters the bore, 1.54 mm into a contact. A real grip does not
  turn: the moment of the shaft's weight and acceleration about the grip, m (g + a) l =
  0.049 kg x 11.81 m/s^2 x 33.4 mm = 0.0194 N m, is 1/5.9 of the simulated pads' torsional
  capacity (2 mu F r_mean = 0.114 N m) and 1/2.9 of the planner's line-contact estimate
  (2 mu F L/4 = 0.057 N m) (``test_shaft_grip_holds_analytically``).
* cover: jams on the post heads 3.2 mm short, 0.05 mm off the axis, well inside the capture
  boundary of two chamfered H11/c11 holes (80-260 um of clearance: 0.04 mm + 1.0 mm); the
  collar (H11/c11 on the shaft's tail) jams 1.1 mm in, 0.1 mm off. Both succeed at BALANCED.
  FAST resolves 2 mm of clearance (sim/fidelity.py), 25x these fits.

Refining FAST's time step is not an answer: at 1/480 s all three steps succeed (the shaft
turns 0.03 deg), but at 1/720 s the shaft slips out of the grip (2.3 deg) and the cover jams
again (2.8 mm in), and at 1/960 s the shaft turns 0.83 deg in the pads: the verdict does not
converge in the step at FAST's metre units (``test_time_step_does_not_converge``). 150 solver
iterations seat the collar and the cover but the shaft jams (0.59 deg of turn), and the exact
fit contact of BALANCED switched on at FAST seats the cover but drops the shaft. So FAST says
what it does not resolve (:mod:`asmplan.sim.resolution`): these steps are "not resolved at
fast", with the fit or the grip it does not resolve and the preset that does, not "jammed".
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from asmplan.cli import main
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
    """Control: at half FAST's time step the grip holds (< 0.1 deg) and the step succeeds (but
    not at a third of it: ``test_time_step_does_not_converge``)."""
    product, geometry, plan = gear_plan
    fine = dataclasses.replace(FAST, dt_s=FAST.dt_s / 2, record_every_steps=8)
    res = simulate_step(plan, _step(plan, "shaft"), product, geometry, fine)
    assert _grip_rotation_deg(res) < 0.1
    assert res.success, res.to_dict()["outcome"]["reasons"]


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "issue 17, measured in session 12 (open): since the planner's grasp hold measured on the "
    "mesh (2155f7f: small pad patches, the friction couple, the hold along the transfer) the "
    "cover is gripped by another grasp, and at half FAST's step it jams at 3.075 mm of 6 "
    "(tilt 3.01 deg, final angle error 4.42 deg) instead of seating; bisected: passes on "
    "b7bbb40, fails on 2155f7f. Whether the new grasp or the control's premise (FAST's jam "
    "is its time step) is wrong is not traced"))
def test_cover_jam_is_the_time_step(gear_plan):
    """Control: at half FAST's time step the cover seats (final error < 0.5 mm); at a third
    of it, it jams again (``test_time_step_does_not_converge``)."""
    product, geometry, plan = gear_plan
    fine = dataclasses.replace(FAST, dt_s=FAST.dt_s / 2, record_every_steps=8)
    res = simulate_step(plan, _step(plan, "cover"), product, geometry, fine)
    assert res.success, res.to_dict()["outcome"]["reasons"]
    assert res.to_dict()["outcome"]["final_position_error_m"] < 0.5e-3


@pytest.mark.slow
def test_time_step_does_not_converge(gear_plan):
    """Control for the decision not to refine FAST's step: at a third of it (1/720 s) the shaft
    turns > 1 deg in the pads over its carry (measured 2.3 deg) and the cover stops > 2 mm
    short (measured 2.8 mm in of 6), though both succeed at half of it."""
    product, geometry, plan = gear_plan
    third = dataclasses.replace(FAST, dt_s=FAST.dt_s / 3, record_every_steps=12)
    shaft = simulate_step(plan, _step(plan, "shaft"), product, geometry, third)
    assert _grip_rotation_deg(shaft) > 1.0
    assert not shaft.success
    cover = simulate_step(plan, _step(plan, "cover"), product, geometry, third)
    assert not cover.success
    assert cover.to_dict()["outcome"]["final_axial_error_m"] > 2e-3


def _unresolved(res, *codes):
    """The step is 'not resolved at fast' for exactly ``codes``, each naming balanced, and no
    'failed' verdict."""
    assert not res.success
    assert res.verdict == "unresolved", res.reasons
    assert tuple(u.code for u in res.unresolved) == codes
    assert all(u.preset == "fast" and u.needs == "balanced" for u in res.unresolved)
    d = res.to_dict()
    assert [u["code"] for u in d["unresolved"]] == list(codes)
    return {u.code: u for u in res.unresolved}


@pytest.mark.slow
def test_shaft_step_at_fast(gear_plan):
    """The shaft's turn in the grip (and the contact it then penetrates 1.5 mm) is reported
    as FAST's pad creep under a grip the planner holds with its safety factor, not as a
    slip of the product."""
    product, geometry, plan = gear_plan
    step = plan.steps[_step(plan, "shaft")]
    res = simulate_step(plan, step.index, product, geometry, FAST)
    causes = _unresolved(res, "grip", "contact")
    clamp = step.clamp
    margin = clamp.commanded_N * clamp.safety_factor / clamp.required_N
    assert causes["grip"].value == pytest.approx(margin)
    assert causes["grip"].value >= clamp.safety_factor - 1e-9  # the planned grip
    assert set(causes["grip"].criteria) <= {"slip", "rotational_slip", "drop"}
    assert causes["contact"].value <= FAST.impact_penetration_m
    assert "jammed" not in {f.code for f in res.outcome.failures}


@pytest.mark.slow
def test_cover_step_at_fast(gear_plan):
    """The cover's stop on the post heads, inside the capture boundary, is FAST not resolving
    the H11/c11 fit (80 um < 2 mm), not a jam of the product: the verdict names the fit and
    BALANCED; the outcome keeps what FAST saw."""
    product, geometry, plan = gear_plan
    res = simulate_step(plan, _step(plan, "cover"), product, geometry, FAST)
    fit = _unresolved(res, "fit")["fit"]
    mate = next(m for m in product.mates if m.name == fit.subject)
    assert mate.hole_part == "cover" and mate.fit == "H11/c11"
    assert fit.value == pytest.approx(mate.clearance_min_m) and fit.value < fit.limit
    assert fit.limit == FAST.min_resolvable_clearance_m
    assert "insertion_depth" in fit.criteria
    # inside the capture boundary: c_max / 2 + both chamfers (0.5 mm each)
    capture = 0.5 * mate.clearance_max_m + 2 * 0.5e-3
    lateral = np.asarray(res.record.lateral_error_m)
    assert float(lateral[np.isfinite(lateral)][-1]) < capture


@pytest.mark.slow
def test_collar_step_at_fast(gear_plan):
    """The collar (H11/c11 on the shaft's tail) stops 1.1 mm in at FAST: not resolved."""
    product, geometry, plan = gear_plan
    res = simulate_step(plan, _step(plan, "collar"), product, geometry, FAST)
    fit = _unresolved(res, "fit")["fit"]
    assert fit.subject == "collar_on_shaft"


@pytest.mark.slow
def test_run_at_fast_says_what_it_does_not_resolve(tmp_path, capsys):
    """``asmplan run examples/gear_unit.yaml --fidelity fast``: the three steps are 'not
    resolved at fidelity fast' (exit 1: not proven), none 'fails physically'; results.json
    lists them apart from the failed steps."""
    out = tmp_path / "out"
    code = main(["run", str(example_path("gear_unit")), "--fidelity", "fast", "--no-report",
                 "-j", "1", "-o", str(out)])
    stdout = capsys.readouterr().out
    assert code == 1
    assert ("step(s) 3 (shaft), 5 (collar), 8 (cover) not resolved at fidelity fast" in stdout
            and "run --fidelity balanced to judge them" in stdout)
    assert "fail physically" not in stdout and "FAILED" not in stdout
    data = json.loads((out / "results.json").read_text())
    assert data["success"] is False and data["failed_steps"] == []
    assert data["unresolved_steps"] == [2, 4, 7]
