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
  FAST resolves 2 mm of clearance (sim/fidelity.py), 25x these fits. What stops the cover
  (session 13, 069c1b8) is a phantom contact: in metre units Bullet keeps a contact point
  until the pair is 0.644 mm apart (0.02 x the post's bounding radius), 7.6x the fit's
  modelled 85 um radial gap, so the points born 0.64 mm apart between the post head's and
  the hole's chamfers (45 deg normals) are carried into the gap and, 1.2 mm into the hole
  with the cover 1 um off the axis and level, push it up and sideways (2.8 N at the post,
  30 mm from the grip: 0.083 N m against the grip's 2 mu F rho = 0.0195 N m); it turns
  3-4 deg about the closing axis and its rear edge lands on the bearing block. In millimetre
  units (42 um) or with the distance limited to 40 um it seats
  (``test_cover_phantom_contact_distance``, ``test_cover_jam_is_a_phantom_contact``).

Refining FAST's time step is not an answer: at 1/480 s the shaft succeeds (it turns
0.03 deg) but the cover jams (24 of 25 runs over 1/240-1/720 s and the clamp x0.99-1.05;
it seats at 1/960 s), at 1/720 s the shaft slips out of the grip (2.3 deg) and the cover jams
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
from asmplan.sim.bodies import physics_model
from asmplan.sim.bullet import BulletWorld
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


def _cover_and_post(units_per_m: float):
    """Bullet's breaking distance of the cover-post_1 pair at FAST in the given units, m: the
    two bodies built from the pieces FAST simulates, as the scene places them (static)."""
    product = load_product(example_path("gear_unit"))
    geometry = ProductGeometry(product)
    fast = dataclasses.replace(FAST, bullet_units_per_m=units_per_m)
    with BulletWorld(fast) as world:
        ids = {}
        for name in ("cover", "post_1"):
            model, _ = physics_model(geometry, name, fast.geometry_lod, True)
            ids[name] = world.add_body(model.pieces, 0.0, product.part(name).T_product_part,
                                      name=name)
        return world.contact_breaking_m(ids["cover"], ids["post_1"])


def test_cover_phantom_contact_distance():
    """Why FAST jams the cover: in metre units Bullet keeps a contact point of the cover-post
    pair until it is 0.02 x the post's bounding radius apart (0.644 mm measured), 7.6x the
    modelled radial gap of the H11/c11 fit (85 um); a point born between the head's chamfer
    and the hole's (45 deg normal) is carried into the gap and pushes on its stale normal. In
    millimetre units the distance is 42 um, inside the gap."""
    geometry = ProductGeometry(load_product(example_path("gear_unit")))
    gap = geometry.sizing.radial_clearance_m[("cover", "h1")]
    assert gap == pytest.approx(85e-6, abs=1e-9)
    metres = _cover_and_post(1.0)
    millimetres = _cover_and_post(1000.0)
    assert metres == pytest.approx(0.644e-3, abs=5e-6)
    assert metres > 5 * gap
    assert millimetres == pytest.approx(42e-6, abs=1e-6)
    assert millimetres < gap


@pytest.mark.slow
@pytest.mark.parametrize("divisor", [1, 2])
def test_cover_jam_is_a_phantom_contact(gear_plan, divisor):
    """Control: with everything FAST but the millimetre world (breaking distance 42 um < the
    85 um gap: no phantom contact), the cover seats at FAST's time step and at half of it,
    level in the grip. The former control (metres, half the step seats) was chaotic: over
    1/240-1/720 s and the clamp x0.99-1.05, 24 of 25 runs jam 2.8-3.2 mm short; the one seat
    on record flipped with a 4e-6 relative change of the clamp force."""
    product, geometry, plan = gear_plan
    mm = dataclasses.replace(FAST, bullet_units_per_m=1000.0, dt_s=FAST.dt_s / divisor,
                             record_every_steps=4 * divisor)
    res = simulate_step(plan, _step(plan, "cover"), product, geometry, mm)
    assert res.success, res.to_dict()["outcome"]["reasons"]
    outcome = res.to_dict()["outcome"]
    assert outcome["final_position_error_m"] < 0.5e-3
    assert math.degrees(outcome["max_slip_rad"]) < 0.1  # metres, half the step: 4.41 deg


@pytest.mark.slow
def test_time_step_does_not_converge(gear_plan):
    """Control for the decision not to refine FAST's step: at a third of it (1/720 s) the shaft
    turns > 1 deg in the pads over its carry (measured 2.3 deg) and the cover stops > 2 mm
    short (measured 2.8 mm in of 6), though the shaft succeeds at half of it."""
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
