"""Timing: min-jerk phases within the limits, clamp force from m (g + a) / (2 mu)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from asmplan.planner.errors import GripInfeasibleError
from asmplan.planner.timing import (
    G_M_S2,
    Move,
    StepMotion,
    TimingSettings,
    clamp_force,
    max_point_speed_m_s,
    min_jerk_duration_s,
    motion_limits,
    phase_durations_s,
    time_step,
)
from asmplan.planner.trajectory import PHASES


def _down(x: float, y: float, z: float, yaw: float = 0.0) -> np.ndarray:
    """Gripper pointing down (z = -z_world) at (x, y, z), rotated by yaw about world z."""
    c, s = np.cos(yaw), np.sin(yaw)
    T = np.eye(4)
    T[:3, :3] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.diag([-1.0, 1.0, -1.0])
    T[:3, 3] = (x, y, z)
    return T


def _motion() -> StepMotion:
    return StepMotion(
        approach=np.array([_down(0, 0.2, 0.05), _down(0, 0.2, 0.02)]),
        lift=np.array([_down(0, 0.2, 0.02), _down(0, 0.2, 0.06)]),
        translate=np.array([_down(0, 0.2, 0.06), _down(0.05, 0.1, 0.1, 0.8),
                            _down(0, 0, 0.06, np.pi / 2)]),
        lower=(Move(np.array([_down(0, 0, 0.06, np.pi / 2), _down(0, 0, 0.04, np.pi / 2)]), 1.0),
               Move(np.array([_down(0, 0, 0.04, np.pi / 2), _down(0, 0, 0.032, np.pi / 2)]), 0.01)),
        retreat=np.array([_down(0, 0, 0.032, np.pi / 2), _down(0, 0, 0.062, np.pi / 2)]),
    )


def test_clamp_force_matches_formula_and_limits(examples):
    product = examples["pinhole_station"]
    part = product.part("part3")  # POM, friction 0.45; finger friction 1.0
    mass = 0.1128
    cf = clamp_force(product, "part3", mass)
    mu = 1.0 * part.friction
    R = product.process.insertion_resistance_N  # 1 N default, carried through the pads
    expected = product.process.safety_factor * (mass * (G_M_S2 + 2.0) + R) / (2 * mu)
    assert cf.mu == pytest.approx(mu, rel=1e-12)
    assert cf.required_N == pytest.approx(expected, rel=1e-12)
    assert cf.commanded_N == pytest.approx(expected, rel=1e-12)
    assert cf.acceleration_m_s2 == pytest.approx(product.process.max_acceleration_m_s2)
    # the gripper limit (40 N) is exceeded by a heavy part: a typed error with the numbers
    heavy = (40.0 * 2 * mu / product.process.safety_factor - R) / (G_M_S2 + 2.0) * 1.01
    with pytest.raises(GripInfeasibleError, match=r"needs 40\.\d\d N per finger .* gripper "
                                                    r"max_force is 40\.00 N") as err:
        clamp_force(product, "part3", heavy, step=2)
    assert err.value.evidence()["limit_source"] == "gripper max_force"
    assert err.value.required_N == pytest.approx(2 * (heavy * (G_M_S2 + 2.0) + R) / (2 * mu), rel=1e-9)


def test_part_clamp_limit_is_checked(examples):
    product = examples["pinhole_station"]
    part = product.part("part4")
    limited = dataclasses.replace(part, handling=dataclasses.replace(part.handling,
                                                                     max_clamp_force_N=1.0))
    p2 = dataclasses.replace(product, parts=tuple(limited if p.name == "part4" else p
                                                  for p in product.parts))
    with pytest.raises(GripInfeasibleError, match=r"part max_clamp_force is 1\.00 N"):
        clamp_force(p2, "part4", 0.05)


def test_min_jerk_duration_respects_both_limits():
    # long move: speed-limited, T = 1.875 D / v
    assert min_jerk_duration_s(1.0, 0.25, 2.0) == pytest.approx(1.875 / 0.25)
    # short move: acceleration-limited, T = sqrt(5.7735 D / a)
    assert min_jerk_duration_s(0.001, 0.25, 2.0) == pytest.approx(np.sqrt(5.7735027 * 0.001 / 2))
    assert min_jerk_duration_s(0.0, 0.25, 2.0) == 0.0


def test_trajectory_phases_limits_and_forces(examples):
    product = examples["pinhole_station"]
    limits = motion_limits(product, "part2")
    radius = 0.08
    settings = TimingSettings(sample_dt_s=0.002)
    traj = time_step(_motion(), limits, 5.0, radius, settings)
    names = [p.name for p in traj.phases]
    assert names == ["approach", *PHASES, "retreat"]
    # every point within the radius stays under the speed limit (finite differences of a
    # min-jerk profile sampled at 2 ms slightly underestimate the peak: 1 % tolerance)
    v = max_point_speed_m_s(traj, radius)
    assert v.max() <= limits.max_speed_m_s * 1.001
    assert v.max() >= 0.9 * limits.max_speed_m_s  # the long translate reaches the limit
    # acceleration of the TCP within the limit (second differences, 5 % for sampling)
    t = traj.t_s
    p = traj.T_world_gripper[:, :3, 3]
    lift = traj.phase_span("lift")
    m = (t >= lift.t_start_s) & (t <= lift.t_end_s)
    acc = np.diff(np.diff(p[m], axis=0), axis=0) / np.diff(t[m])[:-1, None] ** 2
    assert np.linalg.norm(acc, axis=1).max() <= limits.max_acceleration_m_s2 * 1.05
    # insertion part of "lower" runs at the insertion speed
    low = traj.phase_span("lower")
    m = (t >= low.t_start_s) & (t <= low.t_end_s) & (p[:, 2] < 0.04 - 1e-9)
    speed = np.linalg.norm(np.diff(p[m], axis=0), axis=1) / np.diff(t[m])
    assert speed.max() <= limits.insertion_speed_m_s * 1.01
    # forces: 0 in approach/retreat, ramp in clamp, F while held, ramp down in release
    assert traj.force_at(traj.phase_span("approach").t_start_s) == 0.0
    for name in ("hold", "lift", "translate", "lower"):
        span = traj.phase_span(name)
        mid = 0.5 * (span.t_start_s + span.t_end_s)
        assert traj.force_at(mid) == pytest.approx(5.0)
    clamp = traj.phase_span("clamp")
    assert traj.force_at(0.5 * (clamp.t_start_s + clamp.t_end_s)) == pytest.approx(2.5, rel=0.05)
    assert traj.force_at(traj.phase_span("retreat").t_end_s) == 0.0
    # the path passes exactly through every waypoint and ends where the motion ends
    np.testing.assert_allclose(traj.pose_at(low.t_end_s), _motion().lower[-1].poses[-1],
                               atol=1e-12)
    d = phase_durations_s(traj)
    assert d["clamp"] == pytest.approx(settings.clamp_s)
    assert d["release"] == pytest.approx(settings.release_s)


def test_clamp_force_adds_the_moment_of_an_off_centre_grasp_and_the_insertion_resistance(examples):
    """F = sf sqrt(F_t^2 + F_m^2), F_t = (m (g + a) + R) / (2 mu), F_m = 2 m (g d_g + a d) / (mu W):
    a line contact of length W resists at most mu F W / 4 per pad about the closing axis
    (uniform pressure); force and moment combine on an ellipsoidal limit surface."""
    import dataclasses
    import math

    from asmplan.planner.timing import clamp_force

    product = examples["pinhole_station"]  # finger width 20 mm, mu = 1.0 x 0.45 for POM
    product = dataclasses.replace(product, process=dataclasses.replace(
        product.process, insertion_resistance_N=1.0))
    m, a, mu, sf, W, R, d = 0.1, 2.0, 0.45, 2.0, 0.020, 1.0, 0.010
    centred = clamp_force(product, "part3", m)
    off = clamp_force(product, "part3", m, lever_m=d)
    below = clamp_force(product, "part3", m, lever_m=d, gravity_lever_m=0.0)
    slide = (m * (9.81 + a) + R) / (2 * mu)
    assert centred.slip_limit_N == pytest.approx(m * (9.81 + a) / (2 * mu), rel=1e-9)
    assert centred.required_N == pytest.approx(sf * slide, rel=1e-9)
    assert off.required_N == pytest.approx(sf * math.hypot(slide, 2 * m * (9.81 + a) * d / (mu * W)), rel=1e-9)
    # centre of mass straight below the fingers: gravity makes no moment, acceleration does
    assert below.required_N == pytest.approx(sf * math.hypot(slide, 2 * m * a * d / (mu * W)), rel=1e-9)
    assert centred.required_N < below.required_N < off.required_N
    assert off.slip_limit_N == centred.slip_limit_N  # the classic limit is still reported
