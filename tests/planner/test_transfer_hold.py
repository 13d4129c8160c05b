"""The grip judged with gravity's directions along the planned transfer
(planner/transfer_hold.py, grasp_hold.HoldInputs) against closed forms."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from asmplan.planner.grasp_hold import G_M_S2, ContactPatch, HoldInputs
from asmplan.planner.transfer_hold import (
    TURN_SAMPLE_RAD,
    gravity_in_part,
    horizontal_lever_m,
    part_orientations_along,
)

M, MU, SF = 0.2, 0.5, 2.0
L, W, D = 0.008, 0.02, 0.02  # line length, grip width, lever


def _rx(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def _pose(R: np.ndarray, p) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


# the gripper closing vertically (its y axis up), approaching horizontally
R_UP = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
# the transfer turns the part over about the gripper's x axis: up, on its side, upside down
PATH = np.array([_pose(R_UP, [0.0, 0.0, 0.3]), _pose(R_UP @ _rx(math.pi / 2), [0.1, 0.0, 0.35]),
                 _pose(R_UP @ _rx(math.pi), [0.2, 0.0, 0.3])])


def test_orientations_are_sampled_along_each_leg():
    R = part_orientations_along(PATH, np.eye(4))
    np.testing.assert_allclose(R[0], R_UP, atol=1e-12)
    np.testing.assert_allclose(R[-1], R_UP @ _rx(math.pi), atol=1e-12)
    turns = [math.acos(np.clip((np.trace(a.T @ b) - 1) / 2, -1, 1))
             for a, b in itertools.pairwise(R)]
    assert max(turns) <= TURN_SAMPLE_RAD + 1e-9
    assert sum(turns) == pytest.approx(math.pi, rel=1e-9)  # one steady turn, no detour
    down = gravity_in_part(R)
    np.testing.assert_allclose(down[0], [0, -1, 0], atol=1e-12)  # along the closing axis
    assert np.any(np.all(np.isclose(down, [0, 0, 1], atol=1e-12), axis=1))  # on its side
    # a lever along the gripper's approach is horizontal throughout
    assert horizontal_lever_m(R, np.array([0.0, 0.0, D])) == pytest.approx(D, rel=1e-12)


def test_a_part_turned_over_must_hold_its_weight_in_torsion_mid_transfer():
    """Line contacts of length L along x, the centre of mass a lever D along x. At the pick and
    at the insertion pose gravity is along the closing axis: the weight presses the part on a
    pad and its moment m g D about the pad plane's z axis is carried by the normal forces
    along the lines (F = sf m g D / L) or the pads' friction couple across the grip width W
    (F = sf m g D / (mu W)), the cheaper. Turned 90 deg on the way, gravity lies in the pad
    plane across the lever: the pads carry m g in friction and m g D about the closing axis
    in torsion with rho = L / 4: F = sf m g sqrt(1 + (4 D / L)^2) / (2 mu), 5x more here."""
    xs = np.linspace(-L / 2, L / 2, 2001)
    line = ContactPatch(np.stack([xs, np.zeros_like(xs)], axis=1), 0.0)
    downs = (np.array([0.0, -1.0, 0.0]), np.array([0.0, 1.0, 0.0]))  # pick, insertion
    hold = HoldInputs(line, line, np.array([D, 0.0, 0.0]), M, 0.0, MU, SF, W, downs, np.eye(4))
    two_poses = hold.requirement()
    ends = SF * M * G_M_S2 * D * min(1.0 / L, 1.0 / (MU * W))
    assert two_poses.required_N == pytest.approx(ends, rel=1e-9)
    along = hold.requirement(gravity_in_part(part_orientations_along(PATH, np.eye(4))))
    mid = SF * M * G_M_S2 * math.hypot(1.0, 4 * D / L) / (2 * MU)
    assert along.required_N == pytest.approx(mid, rel=1e-3)
    assert along.mechanism == "turning about the closing axis"
    assert along.required_N > 4.5 * two_poses.required_N
    # a gripper of 30 N holds it at the two poses and not along the transfer
    assert two_poses.required_N < 30.0 < along.required_N


def test_a_transfer_that_keeps_the_orientation_adds_nothing():
    xs = np.linspace(-L / 2, L / 2, 2001)
    line = ContactPatch(np.stack([xs, np.zeros_like(xs)], axis=1), 0.0)
    downs = (np.array([0.0, -1.0, 0.0]),)
    hold = HoldInputs(line, line, np.array([D, 0.0, 0.0]), M, 3.0, MU, SF, W, downs, np.eye(4))
    level = np.array([_pose(R_UP, [0.0, 0.0, 0.3]), _pose(R_UP, [0.2, 0.1, 0.3])])
    assert hold.requirement(gravity_in_part(part_orientations_along(level, np.eye(4)))
                            ).required_N == pytest.approx(hold.requirement().required_N,
                                                          rel=1e-12)
