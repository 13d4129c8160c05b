"""Prism (V-groove) pads on a round shaft head: the planner's hold criterion against the
simulation (issue 18: the gearbox shaft held by its 24 mm head).

The scene: a 0.22 kg steel shaft (15 mm, 143 mm long) with a 24 x 6 mm head, lying
horizontal, held by its head only (5.25 mm of the head under 30 mm pads with a 90 deg groove
10 mm deep, as the gearbox's ``prism`` finger): the weight acts 72 mm from the pads and turns
the shaft about the closing axis. The criterion (:func:`~asmplan.planner.grasp_groove.groove_seat`
and :func:`~asmplan.planner.grasp_hold.hold_requirement`, no safety factor, at rest) credits
the four flank lines ``R cos 45 deg`` either side of the closing axis with ``mu F / (2 sin 45
deg)`` each; the closed form is ``F = m g d sin(theta/2) / (2 mu R cos(theta/2))`` (8.6 N).
Measured (BALANCED, 0.5 s after the weight comes on; predicted 8.9 N): 0.3 times the
prediction drops the shaft, 0.45 times turns it 1.5 deg, 0.6 to 2 times hold it within
0.15 deg. The criterion is conservative: the simulated threshold lies between 0.3 and 0.6
times the predicted force. Part of the margin is the pads' spinning friction: a grooved pad
gets the torsion radius of one land (so that a part bridging the groove, the gearbox shaft
lying on the tray, holds as on flat pads; without it that shaft pivoted on one contact point
per land and dropped), and PyBullet applies it at every flank point too. Without it the
threshold was between 0.6 and 0.8 times the prediction.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from asmplan.knowledge.model import Groove
from asmplan.parts.pieces import ConvexPiece
from asmplan.planner.grasp_groove import groove_seat
from asmplan.planner.grasp_hold import hold_requirement
from asmplan.sim.bullet import BulletWorld
from asmplan.sim.fidelity import BALANCED
from asmplan.sim.gripper import Gripper, GripperSpec

MASS_KG = 0.22
MU = 0.7  # PyBullet multiplies the pad's 1.0 by the part's 0.7
HEAD_R_M = 0.012
OVERLAP_M = 0.00525
PAD_M = (0.03, 0.012, 0.03)
GROOVE = Groove(math.radians(90.0), 0.010)
COM_PART_M = np.array([0.0, 0.0, -0.0031])
# gripper axes in the world (columns): x down, y the closing axis, z along the shaft
R_WORLD_GRIPPER = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
TCP_Z_PART_M = -0.075 + OVERLAP_M - PAD_M[2] / 2


def _cylinder(r: float, length: float, z: float) -> ConvexPiece:
    T = np.eye(4)
    T[2, 3] = z
    return ConvexPiece(kind="cylinder", T_part_piece=T, radius_m=r, length_m=length)


def predicted_force_N() -> float:
    """The criterion's clamp force per finger (safety factor 1, at rest), from samples of
    the head's surface under the pads."""
    rng = np.random.default_rng(7)
    n = 3000
    phi = rng.uniform(0.0, 2.0 * math.pi, n)
    z = rng.uniform(-0.075, -0.075 + OVERLAP_M, n) - TCP_Z_PART_M  # along the pad from the TCP
    x, y = HEAD_R_M * np.cos(phi), HEAD_R_M * np.sin(phi)
    seat = groove_seat(x, y, z, np.cos(phi), np.sin(phi), GROOVE, math.cos(math.atan(MU)),
                       2.0 * math.pi * HEAD_R_M * OVERLAP_M / n)
    assert isinstance(seat, tuple)
    top, bottom = seat
    com_gripper = np.array([0.0, 0.0, COM_PART_M[2] - TCP_Z_PART_M])
    down_gripper = R_WORLD_GRIPPER.T @ np.array([0.0, 0.0, -1.0])
    req = hold_requirement(top, bottom, com_gripper, MASS_KG, 0.0, MU, 1.0, (down_gripper,))
    return req.required_N


def held_turn(force_N: float, hold_s: float = 0.5) -> tuple[float, float]:
    """(rotation deg, displacement m) of the shaft in the pads ``hold_s`` after its weight
    comes on, clamped with ``force_N`` per finger (closed with the weight cancelled)."""
    pieces = [_cylinder(0.0075, 0.143, -0.0015), _cylinder(HEAD_R_M, 0.006, -0.072)]
    inertia = np.diag([MASS_KG * 0.143**2 / 12] * 2 + [MASS_KG * 0.0075**2 / 2])
    T_part = np.eye(4)
    T_part[:3, :3] = R_WORLD_GRIPPER
    T_part[:3, 3] = (0.0, 0.0, 0.3)
    T_tcp = T_part.copy()
    T_tcp[:3, 3] += R_WORLD_GRIPPER @ np.array([0.0, 0.0, TCP_Z_PART_M])
    spec = GripperSpec(pad_size_m=PAD_M, pad_friction=1.0, max_opening_m=0.1,
                       max_clamp_force_N=500.0, palm_size_m=(0.04, 0.12, 0.02), palm_gap_m=0.0,
                       pad_groove_angle_rad=GROOVE.angle_rad, pad_groove_depth_m=GROOVE.depth_m)
    with BulletWorld(BALANCED) as world:
        body = world.add_body(pieces, MASS_KG, T_part, com_m=COM_PART_M, inertia_kgm2=inertia,
                              friction=MU, name="shaft")
        gripper = Gripper(world, spec, T_tcp, opening_m=0.03)
        for _ in range(int(0.3 / BALANCED.dt_s)):
            gripper.command_pose(T_tcp)
            gripper.command_clamp_force(force_N)
            world.apply_force(body, -1, [0.0, 0.0, MASS_KG * world.gravity_mps2[2] * -1.0],
                              world.com_position_m(body))
            world.step()
        T0 = world.pose(body)
        for _ in range(int(hold_s / BALANCED.dt_s)):
            gripper.command_pose(T_tcp)
            gripper.command_clamp_force(force_N)
            world.step()
        T1 = world.pose(body)
    R = T0[:3, :3].T @ T1[:3, :3]
    angle = math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0))))
    return angle, float(np.linalg.norm(T1[:3, 3] - T0[:3, 3]))


def test_criterion_matches_the_closed_form():
    """Four flank lines R cos 45 deg off the closing axis, mu F / (2 sin 45 deg) each:
    F = m g d sin 45 / (2 mu R cos 45), d the centre of mass's distance from the pads'
    contact centre; within 3 % (the contact centre from samples of a 5.25 mm band)."""
    d = (COM_PART_M[2] - TCP_Z_PART_M) - (-0.075 + OVERLAP_M / 2 - TCP_Z_PART_M)
    closed = MASS_KG * 9.81 * d * math.sin(math.pi / 4) / (2 * MU * HEAD_R_M * math.cos(math.pi / 4))
    assert predicted_force_N() == pytest.approx(closed, rel=0.03)


@pytest.mark.parametrize("factor, holds", [(0.3, False), (0.6, True), (1.0, True), (2.0, True)])
def test_simulated_threshold_agrees_with_the_criterion(factor, holds):
    """At 0.3 times the predicted force the shaft turns more than 1 deg in 0.5 s; from 0.6
    times it stays within 0.5 deg and 0.5 mm (the simulated threshold lies between)."""
    angle, shift = held_turn(factor * predicted_force_N())
    if holds:
        assert angle < 0.5 and shift < 0.5e-3, (angle, shift)
    else:
        assert angle > 1.0, (angle, shift)


def _ring(n: int = 2000, centre_x: float = 0.0, seed: int = 3):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.0, 2.0 * math.pi, n)
    z = rng.uniform(0.0, 0.005, n)
    return (centre_x + HEAD_R_M * np.cos(phi), HEAD_R_M * np.sin(phi), z, np.cos(phi),
            np.sin(phi))


def test_seat_on_the_flank_lines_off_centre_and_on_the_lands():
    """A centred round head seats on four lines R cos 45 deg off the closing axis; 0.5 mm
    off the grooves' centre line it is rejected (the grooves would move it); a groove too
    narrow for it (its flank contact beyond the groove's edge) leaves it on the lands."""
    cc = math.cos(math.atan(MU))
    seat = groove_seat(*_ring(), GROOVE, cc, 1e-8)
    assert isinstance(seat, tuple)
    for patch in seat:
        assert np.allclose(np.abs(patch.points_m[:, 0]), HEAD_R_M * math.cos(math.pi / 4),
                           atol=2e-4)
        assert patch.friction(MU) == pytest.approx(MU / math.sin(math.pi / 4))
    assert groove_seat(*_ring(centre_x=5e-4), GROOVE, cc, 1e-8) is False
    assert groove_seat(*_ring(), Groove(math.radians(90.0), 0.004), cc, 1e-8) is None


def test_groove_that_does_not_fit_the_pad_is_a_located_input_error(tmp_path):
    from asmplan.knowledge.errors import ProductError
    from asmplan.knowledge.loader import load_product

    gearbox = Path(__file__).resolve().parents[1] / "fixtures" / "products" / "gearbox.yaml"
    text = gearbox.read_text().replace("groove: {angle: 90, depth: 10}",
                                       "groove: {angle: 90, depth: 16}")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ProductError, match=r"2 errors(.|\n)*bad\.yaml:\d+:\d+: resources\.gripper"
                       r"\.fingers\[0\]\.groove\.depth: expected a depth below the pad's "
                       r"thickness \(12 mm\), found 16 mm\n.*groove\.depth: expected a groove "
                       r"narrower than the pad at its face \(30 mm\), found 32 mm"):
        load_product(path)
