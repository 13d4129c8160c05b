"""The gearbox test product (tests/fixtures/products/gearbox.yaml, issue 18) simulated at
BALANCED step by step, as `asmplan run --fidelity balanced` does (each step in a fresh world
holding what the plan has placed). About 70 s CPU for all steps.

Measured on this branch (`asmplan run tests/fixtures/products/gearbox.yaml --fidelity
balanced -o OUT`, results.json per step), with the cause of each failure:

* spacer (place): succeeded once the spacer got its 0.2 mm end play a side. At 48 mm in the
  48 mm gap its end face slid flush down the right wall and caught the wall's top edge
  (1.3 N up on its end with the grip 97 mm up), it turned 20 deg in its 1.3 N pinch and
  struck the wall at 1059 N: the model (a part with no end play), not the solver.
* bearing_1: jammed at 9.55 of 12 mm with the 400 N-class estimate (grip 35.4 N per finger,
  mu 0.35: 24.8 N of axial friction against a 45.5 N jam at 0.19 deg tilt, 2.4 mm slip); the
  same grasp and clamp with the catalogue gripper (1.9 kg, 100 mm stroke) insert it (peak
  16.5 N). Borderline: the clamp is planned for weight and inertia only (resistance 0 N), the
  insertion reaction is the "hold" work (grasp_hold), and H7/h6 is simulated at 0 um.
* shaft (insert, held by its 24 mm head), with flat pads (before the prism jaws): slipped
  1.84 mm and 3.6 deg in the pads during the transfer with nothing touching it, at the planned
  289 N per finger. PyBullet's contact of
  a flat pad on the round head is two points 2 mm apart along the shaft per pad, with normal
  forces 279 N and 4 N at hold (147 N and 1.6 N while the clamp ramps; probed with
  BulletWorld.contacts every 50 steps), so the torsion about the closing axis that the criterion
  credits to a line contact (2 mu F L/4 = 0.40 N m at 289 N) is not delivered (and the
  planner's patch of 3-5 samples credited 1.0 mm of torsion radius to a 2 mm line: 0.5 mm).
  With prism jaws (the fixture's ``prism`` finger: 90 deg V, 10 mm deep; handling.finger) the
  criterion asks 19.9 N (safety factor 2) and the plan clamps 37.7 N. With the pads' land
  torsion as spinning friction (sim/gripper.py) the shaft turns 1.13 deg in the pads between
  5.3 and 6.5 s of the transfer, while the gripper turns it from upright to horizontal; over
  that time finger 1's squeeze reading rises from 38 to 137 N against the commanded 37.7 N
  while finger 2's stays at 33-41 N (wedging in the V, explained below: no load along the
  closing axis). It then stops on the rim (tilt
  2.44 deg, 0.295 mm off). Without the land torsion (spinning friction 0 on grooved pads)
  the grip held through the transfer (0.63 deg at most), the shaft arrived 1 um off and
  0.16 deg tilted, went in 3.07 mm and caught on bearing_1's internal seam at x = -66 mm
  (where its flange and sleeve pieces meet; 75 N along -x), the grip then sliding at its
  axial friction limit 2 mu F / sin 45 deg = 75 N; but the shaft's regrasp pick (lying on
  the tray, bridging the groove) then pivoted on one contact point per land and dropped.
  On main at ee9b3bd with the exact fit contact (rebased 16:00): the transfer moves it
  0.56 mm / 0.46 deg in the pads (within the slip limits; its axis 8.3 mrad off, mostly
  about the closing axis), so its tip meets bearing_1's 0.3 mm bore chamfer 0.58 mm off the
  axis at 10.66 s and stops 1.04 mm in. The exact fit contact then holds the tip (it solves
  the shaft alone; the pads' normals act only in Bullet's step) while the pads move on: they
  sink 0.54 mm into the head, finger 1 reads up to 470 N, the shaft slides 0.8 mm back and
  tilts 3 deg in 0.35 s and is levered out and dropped (17.9 s). The transfer's turn is
  PyBullet's contact of the round head on the flank boxes, not the grip: the grip holds
  0.45 N m against 0.14 N m, and the shaft carried alone along the planned poses turns
  66 mrad at 37.7 N, 13.4 at half and 8.0 at twice the clamp
  (tests/sim/test_prism_transfer.py). Finger 1's 137 N squeeze reading
  (s9) is locked-in wedging of the 90 deg V: with friction mu along the flanks the reading
  of a pad squeezed with F lies anywhere in F / (1 + mu) .. F / (1 - mu) = 22-126 N at
  37.7 N and mu 0.7 (PyBullet's friction pyramid lets a little more), with no external
  load. With the carry hold (s11, sim/carry_hold.py: stuck to the palm while the grip holds
  the load at <= 0.75 of its analytic capacity and the shaft touches nothing but the pads):
  stuck from 1.04 s to its first contact with bearing_1 at 11.0 s (largest load ratio 0.53,
  tipping), the shaft entered and stopped 123.2 of 139 mm in against the housing's right
  wall (two contacts of 981 N and 99 N on a face normal to the axis at x = 54 mm, 0.00 mm
  apart along it: an end stop), the pads then sliding 16.0 mm and 6.7 deg on it. The wall
  was the model's: seat_2, whose bearing_2 is pressed in later, was modelled solid
  (sim/bodies.empty_holes) although the shaft passes through it; up to there the shaft slid
  in at 0.04-0.5 N with 0.03-0.05 mm of slip in the pads (s12). With the seat kept open
  (sim/hole_path.py) it went fully in (139.0 mm, slip 0.03 mm at the end of "lower"); at
  a9b0e63 the step failed on a 5.6e12 N fit force at 11.024 s: the pads' V-grooves and the
  bores over-constrain it, the grip rows' solve is infeasible and was read as feasible
  (docs/physics.md). With the pads yielding there (sim/grip_pads.py) it goes in and is
  released (final position error 0.23 mm) but turns 4.67 deg in the pads and a contact
  penetrates 0.637 mm (~50-100 s CPU for the step). Session 13: bearing_1, dynamic, takes
  the fit's correction while the grip holds (sim/feature_contact.py, the partner path): goes
  in, final error 8.9 um, 0.84 deg in the pads.
* bearing_2: jams at 4.5 of 16 mm on the seat's chamfer (two housing contacts, 31 and 29 N,
  tilt 0.54 deg) while its bore runs onto the shaft, and the 48.7 N grip (34 N of axial
  friction at mu 0.35) slides 11.4 mm. H7/h6 at its 0 um minimum clearance is below
  BALANCED's 4 um resolution, and the clamp is not sized for the insertion reaction (with
  Bullet's contact). With the exact fit contact it goes in: passes.
* cover: the seating's contact force peaks at 66.8 N against the process's 60 N limit (43.1 N
  with the 1.5 kg gripper estimate, 1.9 kg now; same grasp and 36.2 N clamp). A contact probe
  finds the gripper's palm (base link) touching the cover through the lift and the transfer
  (and 26 N of external force on the cover there), gone by the seating; whether the palm's
  load is what reaches 66.8 N was not established. Since BALANCED's carry anchors (the pads
  anchored from the clamp to the set-down contact, sim/fidelity.py carry_anchor) the cover
  step succeeds: passes.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.product import plan_product
from asmplan.sim.fidelity import BALANCED
from asmplan.sim.simulate import simulate_step

pytestmark = pytest.mark.slow

GEARBOX = Path(__file__).resolve().parents[1] / "fixtures" / "products" / "gearbox.yaml"


@pytest.fixture(scope="module")
def gearbox():
    product = load_product(GEARBOX)
    geometry = ProductGeometry(product)
    return product, geometry, plan_product(product, geometry).plan


@pytest.mark.parametrize("part, kind", [
    ("dowel_1", "insert"), ("spacer", "place"), ("gear", "place"), ("bearing_1", "insert"),
    ("shaft", "regrasp"),
    ("cover", "insert"),
    # was a strict xfail (carried stuck to its prism pads, it turned 4.67 deg in them entering
    # bearing_1, a contact penetrated 0.637 mm): since session 13 the held shaft keeps its grip
    # and bearing_1 (dynamic, its housing contacts kept) takes the fit's correction
    # (HeldFitContact._partner_moves): 170 steps, bearing_1 moved 20.5 um in all, final error
    # 8.9 um, 0.84 deg in the pads (OpenBLAS SkylakeX)
    ("shaft", "insert"),
    # bearing_2 jammed 4.5 mm in on the seat chamfer (H7/h6 at 0 um) with Bullet's contact
    # (a strict xfail): with the exact fit contact it goes in
    ("bearing_2", "insert"),
])
def test_gearbox_step_at_balanced(gearbox, part, kind):
    product, geometry, plan = gearbox
    step = next(s for s in plan.steps if s.part == part and s.kind == kind)
    o = simulate_step(plan, step.index, product, geometry, BALANCED).outcome
    assert o.success, o.reasons
    assert o.final_position_error_m < product.process.position_tolerance_m
    assert o.max_slip_m < product.process.max_slip_m
