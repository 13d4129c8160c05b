"""Contact at features against analytic answers (issue 16): Whitney's two-point jam depth, the
rim of an unchamfered hole, and a held part that stays put along a tilted closing axis."""

from __future__ import annotations

import math

import numpy as np
import pytest

from asmplan.parts.pieces import ConvexPiece
from asmplan.sim.bullet import BulletWorld
from asmplan.sim.fidelity import BALANCED, FAST, preset
from bench.scenarios import (
    PinHole,
    entered_depth_m,
    held_drift_m,
    jam_depth_m,
    pin_insertion,
    whitney_jam_depth_m,
)


def test_whitney_formula():
    # D = 10.1, d = 10, t = 0.1 rad: (10.1 - 10 cos 0.1) / sin 0.1 = 1.5001 mm
    assert whitney_jam_depth_m(0.1e-3, 0.1) == pytest.approx(
        (10.1e-3 - 10e-3 * math.cos(0.1)) / math.sin(0.1), rel=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize(("clearance_mm", "tilt_deg"), [(0.05, 0.5), (0.1, 0.5), (0.05, 1.0),
                                                       (0.1, 2.0), (0.5, 3.0)])
def test_jam_scene_geometry_is_exact_with_a_direct_solver(clearance_mm, tilt_deg):
    """The jam scene at BALANCED's time step with Bullet's direct (Dantzig) solver and a
    0.1 um slop stops within 0.1 mm of l* at small tilts, where BALANCED itself is +0.5 mm
    (2 deg) to +3.3 mm (0.5 deg) deep: the peg, hole and depth measure are exact, and
    BALANCED's error is its iterative solver (docs/physics.md, "Jam depth at small tilts").
    Measured |error| <= 0.066 mm."""
    import dataclasses

    exact = dataclasses.replace(BALANCED, constraint_solver="dantzig", contact_slop_m=1e-7,
                                feature_contact=False)
    c, t = clearance_mm * 1e-3, math.radians(tilt_deg)
    err = jam_depth_m(exact, c, t) - whitney_jam_depth_m(c, t)
    assert abs(err) < 0.1e-3


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "chaotic after the wedge (measured session 13 with floating jaws' pads solved exactly with "
    "the fit, sim/fit_grip_qp.py): from the first touch the grip now holds to its torsion "
    "capacity (fit force 0.73-1.0 N, analytic 0.85 N; it yielded at 0.08 N before) and the pin "
    "wedges near Whitney's depth, but the verdict's contacts depend on the BLAS kernels: with "
    "OpenBLAS's Haswell kernels 'jammed at 10.609 mm', tilt 4.02 deg, two opposed contacts (the "
    "test passes); with SkylakeX (pinned by tests/conftest.py) 'jammed at 7.471 mm', tilt "
    "3.93 deg (Whitney 7.64 mm), one-sided contact at the deepest point: after the wedge one pad "
    "holds the pin at one point and Bullet's own step turns it about the axis across the pads "
    "(0.4-0.9 rad/s; the pads' normals are not in the floating jaws' solve)"))
def test_jammed_verdict_carries_the_two_contact_points():
    """A 10 mm pin held 5 deg off the hole's axis (0.5 mm diametral clearance, no chamfer),
    its tip placed over the hole: it wedges. The verdict names the two contacts holding it:
    the hole's mouth on one side and its wall deeper down on the other, with opposed
    normals."""
    from asmplan.sim.pose_error import PoseError

    scene = PinHole()
    tilt = math.radians(5.0)
    # the TCP is 32 mm above the pin's tip: tilting about it moves the tip 32 sin t sideways
    reach = scene.grasp_above_centre_m + scene.pin_length_m / 2.0
    _, outcome = pin_insertion(BALANCED, 0.25e-3, scene=scene, pose_error=PoseError(
        (-reach * math.sin(tilt), 0.0), (0.0, tilt)))
    jam = next(f for f in outcome.failures if f.code == "jammed")
    a, b = jam.contacts
    assert (a.side, b.side) == ("a", "b")
    # opposite walls; on the exact round bore (balanced's fit contact) the two points leave
    # the tilt plane by 13-16 deg (the pin also sits off centre along the closing axis):
    # measured dot -0.88
    assert np.dot(a.normal, b.normal) < -0.8
    top = scene.block_size_m[2]
    z = sorted((a.position_m[2], b.position_m[2]))
    assert z[1] == pytest.approx(top, abs=0.1e-3)  # one at the mouth
    assert top - z[0] > 2e-3  # the other deep in the hole
    assert a.normal_force_N > 0 and b.normal_force_N > 0
    assert "two-point contact" in jam.message and "block" in jam.message


@pytest.mark.slow
@pytest.mark.parametrize("clearance_mm", [0.05, 0.1, 0.5])
def test_jam_depth_within_0_1_mm_at_balanced(clearance_mm):
    """A 10 mm peg held at 5 deg stops where its leading corner and the mouth touch both
    walls. Measured at BALANCED with the exact fit contact: within 0.1 um (Bullet's own
    contact: +0.07 to +0.09 mm; in metres +1.8 to +2.0 mm). Every tilt: test_feature_contact."""
    c, t = clearance_mm * 1e-3, math.radians(5.0)
    err = jam_depth_m(BALANCED, c, t) - whitney_jam_depth_m(c, t)
    assert abs(err) < 0.1e-3


@pytest.mark.slow
def test_unchamfered_pin_0_5_mm_off_axis_stays_on_the_rim():
    """No chamfer, 0.5 mm off the axis with 0.1 mm radial clearance: outside the capture
    boundary |e0| < c/2 + chamfer width, so the pin must stop on the rim (it slid in with
    1 mm-rounded rims, as it still does at FAST). Measured: its corner dropped 1.0 mm into
    the 0.6 mm gap on one side, then the pin slipped in the grip."""
    record, outcome = pin_insertion(BALANCED, 0.1e-3, lateral_offset_m=0.5e-3)
    assert not outcome.success
    assert entered_depth_m(record) < 2e-3  # of 20 mm: blocked at the entrance


@pytest.mark.slow
def test_pin_inside_the_capture_boundary_goes_in():
    """0.02 mm off the axis with 0.1 mm radial clearance (inside |e0| < c/2; the plain
    gripper also holds the pin 0.08 mm off centre along its closing axis, where it first
    touched it): it is inserted. Measured: 19.23 of 19.8 mm (0.2 mm seat gap), success."""
    record, outcome = pin_insertion(BALANCED, 0.1e-3, lateral_offset_m=0.02e-3)
    assert outcome.success, outcome.reasons
    assert entered_depth_m(record) > 19e-3


@pytest.mark.parametrize("name", ["fast", "balanced", "accurate"])
@pytest.mark.parametrize("tilt", [0.0, 0.1, math.pi / 2])
def test_held_part_does_not_drift_along_the_closing_axis(name, tilt):
    """The pipeline's gripper (simulate.step_gripper: force-controlled fingers whose jaws are
    synchronised like a rack and pinion) over the seed cycle: < 0.1 mm with the closing
    axis horizontal, tilted 0.1 rad and vertical (issue 16 item 2). Measured: <= 0.0017 mm at
    FAST, < 0.1 um at BALANCED and ACCURATE."""
    assert held_drift_m(preset(name), tilt) < 0.1e-3


def test_floating_jaws_slide_down_a_tilted_closing_axis():
    """The measure sees drift: with the jaws floating (no synchronisation, the fingers' own
    weight fed forward) the same scene slides downhill, m g sin t / (2 d) = 20 mm/s at
    0.1 rad, until a finger reaches its joint limit. Measured: 13.6 mm at BALANCED."""
    assert held_drift_m(BALANCED, 0.1, synchronised=False) > 5e-3


@pytest.mark.parametrize("fidelity", [BALANCED, FAST], ids=["balanced", "fast"])
def test_simulated_edges_are_sharp(fidelity):
    """Closest points of the simulated shapes against the exact geometry, off a box's edge
    and corner and a cylinder's rim along their bisectors, 0.5 mm out: millimetre units
    (BALANCED) leave Bullet's 1e-3-unit margin at 1 um; metres (FAST) round by 1 mm."""
    box = ConvexPiece(kind="box", T_part_piece=np.eye(4), half_extents_m=[0.01] * 3)
    cyl = ConvexPiece(kind="cylinder", T_part_piece=np.eye(4), radius_m=0.005, length_m=0.02)
    h = 0.5e-3
    with BulletWorld(fidelity) as world:
        T = np.eye(4)
        b = world.add_body((box,), 0.0, T)
        T[0, 3] = 1.0
        c = world.add_body((cyl,), 0.0, T)
        s2, s3 = h / math.sqrt(2), h / math.sqrt(3)
        errors = [
            world.probe_distance_m(b, (0.01 + h, 0.0, 0.0)) - h,
            world.probe_distance_m(b, (0.01 + s2, 0.01 + s2, 0.0)) - h,
            world.probe_distance_m(b, (0.01 + s3, 0.01 + s3, 0.01 + s3)) - h,
            world.probe_distance_m(c, (1.005 + h, 0.0, 0.0)) - h,
            world.probe_distance_m(c, (1.005 + s2, 0.0, 0.01 + s2)) - h,
        ]
    worst = max(abs(e) for e in errors)
    if fidelity.bullet_units_per_m == 1.0:
        assert worst == pytest.approx(math.sqrt(3) * 1e-3 - 1e-3, rel=0.01)  # corner
    else:
        assert worst < 10e-6
