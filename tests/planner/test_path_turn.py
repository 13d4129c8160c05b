"""One steady turn along a planned transfer (planner/path_turn.py): via poses on the slerp."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from asmplan.planner.path_turn import levelled_turns
from asmplan.planner.trajectory import rotation_angle_rad


def _rz(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rx(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _pose(R: np.ndarray, p) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def _turned_deg(P: np.ndarray) -> float:
    return math.degrees(sum(float(rotation_angle_rad(a[:3, :3].T @ b[:3, :3]))
                            for a, b in itertools.pairwise(P)))


def test_a_detour_of_turns_becomes_the_geodesic_turn():
    # a 90 deg turn about x with a via pose sampled at 120 deg about z: 120 + ~150 deg turned
    P = np.array([_pose(np.eye(3), [0, 0, 0]), _pose(_rz(120), [0.3, 0, 0]),
                  _pose(_rx(90), [0.3, 0.1, 0])])
    assert _turned_deg(P) > 200
    spread, last, first = levelled_turns(P)
    for L in (spread, last, first):
        assert np.array_equal(L[:, :3, 3], P[:, :3, 3])           # positions untouched
        assert np.array_equal(L[[0, -1]], P[[0, -1]])             # start and goal exact
        assert _turned_deg(L) == pytest.approx(90.0, abs=1e-9)     # the geodesic turn
    # spread by path length: the via pose is 0.3 of 0.4 m along, so 67.5 of the 90 deg turned
    assert math.degrees(float(rotation_angle_rad(spread[1][:3, :3]))) == pytest.approx(67.5, abs=1e-9)
    assert np.allclose(last[1][:3, :3], np.eye(3), atol=1e-12)      # carried unturned
    assert np.allclose(first[1][:3, :3], _rx(90), atol=1e-12)       # turned on the first leg


def test_nothing_to_level():
    a, b = _pose(np.eye(3), [0, 0, 0]), _pose(_rx(90), [0.2, 0, 0])
    assert levelled_turns(np.array([a, b])) == []                   # no via pose
    on = _pose(_rx(45), [0.1, 0, 0])                                  # already on the slerp
    assert levelled_turns(np.array([a, on, b])) == []
    same = _pose(np.eye(3), [0, 0, 0])
    assert levelled_turns(np.array([same, same, same])) == []        # no translation
    # no net turn: every schedule gives the start orientation, listed once
    flat = levelled_turns(np.array([a, _pose(_rz(100), [0.1, 0, 0]), _pose(np.eye(3), [0.2, 0, 0])]))
    assert len(flat) == 1 and np.allclose(flat[0][1][:3, :3], np.eye(3), atol=1e-12)
