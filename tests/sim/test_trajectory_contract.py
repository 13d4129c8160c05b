"""The trajectory contract (planner/trajectory.py) the simulator executes."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from sim_scenes import SEED_CSV

from asmplan.planner.trajectory import (
    PHASES,
    PhaseSpan,
    Segment,
    Trajectory,
    matrix_from_quat_xyzw,
    quat_xyzw_from_matrix,
    read_phase_table,
    rotation_angle_rad,
    seed_cycle,
    trajectory_from_segments,
)
from bench.scenarios import R_DOWN, pose


def random_rotations(n: int, seed: int) -> np.ndarray:
    q = np.random.default_rng(seed).normal(size=(n, 4))
    return matrix_from_quat_xyzw(q / np.linalg.norm(q, axis=1, keepdims=True))


def seed() -> Trajectory:
    return seed_cycle(read_phase_table(SEED_CSV), pose((0.0, 0.0, 0.025)), lift_m=0.05)


def test_quaternion_round_trip_on_random_rotations():
    R = random_rotations(200, seed=1)
    assert np.allclose(matrix_from_quat_xyzw(quat_xyzw_from_matrix(R)), R, atol=1e-12)
    # 180 degree rotations (trace -1) are the numerically hard case.
    flips = np.array([np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), R_DOWN])
    assert np.allclose(matrix_from_quat_xyzw(quat_xyzw_from_matrix(flips)), flips, atol=1e-12)


def test_seed_cycle_follows_the_paper_force_table():
    rows = read_phase_table(SEED_CSV)
    assert tuple(r.name for r in rows) == PHASES
    traj = seed()
    assert traj.duration_s == pytest.approx(4.0)
    assert [p.name for p in traj.phases] == list(PHASES)
    # clamp ramps 0 -> 2.0 N in 0.1 s; hold 1.57; lift 1.57 -> 1.70; translate 1.55 -> 1.60;
    # lower 1.60 -> 1.65; release 1.65 -> 0 over 0.5 s.
    expected = {0.0: 0.0, 0.05: 1.0, 0.3: 1.57, 1.0: 1.635, 2.25: 1.575, 3.25: 1.625, 3.75: 0.825, 4.0: 0.0}
    for t, f in expected.items():
        assert traj.force_at(t) == pytest.approx(f, abs=1e-9), t
    for r in rows:
        inside = np.linspace(r.t_start_s + 1e-3, r.t_end_s - 1e-3, 50)
        f = traj.forces_at(inside)
        assert np.all(f >= r.force_min_N - 1e-9) and np.all(f <= r.force_max_N + 1e-9), r.name


def test_seed_cycle_motion_lifts_translates_and_lowers_smoothly():
    traj = seed()
    p = lambda t: traj.pose_at(t)[:3, 3]  # noqa: E731
    assert np.allclose(p(0.5), [0, 0, 0.025])
    assert np.allclose(p(1.5), [0, 0, 0.075])
    assert np.allclose(p(3.0), [0.1, 0, 0.075])
    assert np.allclose(p(3.5), [0.1, 0, 0.025])
    assert np.allclose(traj.pose_at(2.0)[:3, :3], R_DOWN)
    # Minimum-jerk: zero velocity at the phase boundaries, peak 1.875 x the mean inside.
    dt = 1e-4
    for t in (0.5, 1.5, 3.0, 3.5):
        v = (p(t + dt) - p(t - dt)) / (2 * dt)
        assert np.linalg.norm(v) < 1e-3, t
    v_mid = np.linalg.norm(p(2.25 + dt) - p(2.25 - dt)) / (2 * dt)
    assert v_mid == pytest.approx(1.875 * 0.1 / 1.5, rel=1e-3)


def test_phase_lookup_puts_boundaries_in_the_later_phase():
    traj = seed()
    assert traj.phase_at(0.0) == "clamp"
    assert traj.phase_at(0.1) == "hold"
    assert traj.phase_at(0.0999) == "clamp"
    assert traj.phase_at(4.0) == "release"
    assert traj.phase_span("lift") == PhaseSpan("lift", 0.5, 1.5)
    with pytest.raises(KeyError, match="retreat"):
        traj.phase_span("retreat")


def test_slerp_interpolates_rotation_at_constant_rate():
    R0 = np.eye(3)
    angle = 1.2
    R1 = np.array([[math.cos(angle), -math.sin(angle), 0], [math.sin(angle), math.cos(angle), 0], [0, 0, 1]])
    T0, T1 = np.eye(4), np.eye(4)
    T0[:3, :3], T1[:3, :3] = R0, R1
    T1[:3, 3] = [0.1, 0.2, 0.3]
    traj = Trajectory(
        t_s=np.array([0.0, 1.0]),
        T_world_gripper=np.stack([T0, T1]),
        clamp_force_N=np.array([0.0, 2.0]),
        phases=(PhaseSpan("translate", 0.0, 1.0),),
    )
    for s in (0.25, 0.5, 0.9):
        T = traj.pose_at(s)
        assert rotation_angle_rad(R0.T @ T[:3, :3]) == pytest.approx(s * angle, abs=1e-12)
        assert np.allclose(T[:3, 3], s * T1[:3, 3])
        assert traj.force_at(s) == pytest.approx(2.0 * s)


def test_json_round_trip_is_exact():
    traj = seed()
    back = Trajectory.from_dict(json.loads(json.dumps(traj.to_dict())))
    assert np.array_equal(back.t_s, traj.t_s)
    assert np.array_equal(back.T_world_gripper, traj.T_world_gripper)
    assert np.array_equal(back.clamp_force_N, traj.clamp_force_N)
    assert back.phases == traj.phases


def _two_samples(**over):
    kw = {
        "t_s": np.array([0.0, 1.0]),
        "T_world_gripper": np.stack([np.eye(4), np.eye(4)]),
        "clamp_force_N": np.array([1.0, 1.0]),
        "phases": (PhaseSpan("hold", 0.0, 1.0),),
    }
    kw.update(over)
    return Trajectory(**kw)


def test_validation_says_what_was_expected_and_found():
    _two_samples()  # valid
    with pytest.raises(ValueError, match="strictly increasing"):
        _two_samples(t_s=np.array([0.0, 0.0]))
    bad = np.stack([np.eye(4), np.eye(4)])
    bad[1, 0, 0] = 1.1
    with pytest.raises(ValueError, match=r"proper rotation"):
        _two_samples(T_world_gripper=bad)
    mirror = np.stack([np.eye(4), np.diag([1.0, 1.0, -1.0, 1.0])])
    with pytest.raises(ValueError, match=r"det"):
        _two_samples(T_world_gripper=mirror)
    with pytest.raises(ValueError, match=r"clamp_force_N\[1\]: expected >= 0"):
        _two_samples(clamp_force_N=np.array([1.0, -0.1]))
    with pytest.raises(ValueError, match="gap or overlap"):
        _two_samples(phases=(PhaseSpan("clamp", 0.0, 0.4), PhaseSpan("hold", 0.5, 1.0)))
    with pytest.raises(ValueError, match="last phase to end"):
        _two_samples(phases=(PhaseSpan("hold", 0.0, 0.9),))
    with pytest.raises(ValueError, match="phase name"):
        PhaseSpan("wiggle", 0.0, 1.0)
    with pytest.raises(ValueError, match="shape"):
        _two_samples(clamp_force_N=np.array([1.0]))


def test_segments_reach_each_waypoint_at_the_phase_end():
    A = pose((0.0, 0.0, 0.1))
    B = pose((0.1, 0.0, 0.1), R=np.eye(3) @ R_DOWN)
    traj = trajectory_from_segments(
        A, (Segment("approach", 0.5, B), Segment("clamp", 0.2, B, 0.0, 3.0)), sample_dt_s=0.01
    )
    assert np.allclose(traj.pose_at(0.5), B)
    assert traj.force_at(0.7) == pytest.approx(3.0)
    assert [p.name for p in traj.phases] == ["approach", "clamp"]
