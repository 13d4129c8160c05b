"""A carried part stuck to the palm while its grip holds the load (asmplan/sim/carry_hold.py).

The slip scene of tests/sim/test_slip.py: a 100 g box (mu = 1.0 x 0.5) clamped on the table by
20 x 20 mm pads centred on its centre of mass and lifted at a constant 4 m/s^2, then braked at
2 m/s^2. With the centre of mass on the contact centre the load is a pure force, so the
grip's load ratio is m (g + a) / (2 mu F) while accelerating (1.381 N / F) and the box slips
in the pads below F = 1.381 N (test_slip.py measures that threshold within 10 %)."""

from __future__ import annotations

import numpy as np
import pytest

from asmplan.planner.grasp_capacity import GripCapacity
from asmplan.planner.grasp_hold import ContactPatch
from asmplan.sim.bullet import BulletWorld
from asmplan.sim.carry_hold import CarryHold, carried_load
from asmplan.sim.execute import execute_step
from asmplan.sim.fidelity import BALANCED
from bench.scenarios import BoxPart, G, add_box_and_gripper, constant_acceleration_lift

PART = BoxPart(mass_kg=0.1, friction=0.5)
MU = 1.0 * PART.friction
ACCEL = 4.0
FRACTION = 0.75


def _capacity() -> GripCapacity:
    s = np.linspace(-0.01, 0.01, 21)  # the 20 mm pads, all on the box's 40 x 50 mm faces
    x, z = np.meshgrid(s, s)
    pad = ContactPatch(np.stack([x.ravel(), z.ravel()], axis=1), 4e-4)
    return GripCapacity(pad, pad, MU, np.zeros(3))


def _lift(force_N: float, carry: bool):
    with BulletWorld(BALANCED) as world:
        body, gripper, T_tcp = add_box_and_gripper(world, PART)
        traj = constant_acceleration_lift(T_tcp, force_N, ACCEL)
        hold = (CarryHold(world, gripper, body, traj, _capacity(), FRACTION) if carry
                else None)
        record, outcome = execute_step(world, gripper, body, traj, carry_hold=hold)
    return record, outcome, None if hold is None else hold.summary(), traj


def test_carried_load_of_a_constant_acceleration_is_m_g_minus_a():
    """The load from the commanded poses by central differences: m (g - a), no moment."""
    traj = constant_acceleration_lift(np.eye(4), 2.5, ACCEL)
    f, m = carried_load(traj, 0.4, np.zeros(3), PART.mass_kg, np.eye(3) * 1e-5,
                        np.array([0.0, 0.0, -G]))
    assert f == pytest.approx([0.0, 0.0, -PART.mass_kg * (G + ACCEL)], abs=1e-9)
    assert m == pytest.approx(np.zeros(3), abs=1e-12)


def test_a_grip_within_its_capacity_carries_the_part_stuck():
    """F = 2.5 N: ratio 1.381 / 2.5 = 0.552 < 0.75 from the lift on: stuck from when the box
    rests in the pads until the end of the held phases, the largest ratio the closed form's,
    no slip in the pads."""
    F = 2.5
    record, outcome, carry, _ = _lift(F, True)
    assert carry["stuck"]
    assert carry["released_s"] is None  # the trajectory ends in "translate": stuck to the end
    # stuck once the box rests in the pads (carry_hold.settled): the lift starts at 0.3 s and
    # the pads' anchors take up the new load over ~0.08 s (measured: stuck at 0.376 s)
    assert 0.3 < carry["stuck_from_s"] < 0.4
    assert carry["max_load_ratio"] == pytest.approx(PART.mass_kg * (G + ACCEL) / (2 * MU * F),
                                                    rel=1e-6)
    assert outcome.max_slip_m < 5e-6
    # the fingers stay force-controlled: each pad reads the command while stuck (measured
    # within 0.02 %; a fixed constraint to the palm split them 2.38 / 2.62 N)
    stuck = record.t_s > carry["stuck_from_s"] + 0.01
    assert np.abs(record.measured_force_N[stuck] - F).max() < 0.002 * F


def test_a_load_beyond_the_capacity_is_handed_back_and_slips_as_before():
    """F = 1.2 N < m (g + a) / (2 mu) = 1.381 N: ratio up to 1.15, > 0.75 at the first check, so
    the box is never stuck and slips exactly as without the carry hold (> 0.2 mm)."""
    F = 1.2
    _, with_hold, carry, _ = _lift(F, True)
    _, without, _, _ = _lift(F, False)
    assert not carry["stuck"] and carry["release"].startswith("load ratio")
    # its first check, 4 ms into the lift: the central difference still spans the start of
    # the acceleration (0.98 measured), between the fraction and the closed form's 1.15
    assert FRACTION < carry["max_load_ratio"] <= PART.mass_kg * (G + ACCEL) / (2 * MU * F)
    assert with_hold.max_slip_m == without.max_slip_m
    assert with_hold.max_slip_m > 0.2e-3



def test_settled_measures_the_motion_of_the_point_at_the_tcp_and_the_turn():
    """A part turning about the TCP at 1e-5 rad/s rests; at 3e-5 rad/s it does not (limit
    2e-5); 0.1 um/s across the pad plane rests, 0.3 um/s does not (limit 0.2 um/s); motion
    along the closing axis (TCP y) is the pads' and does not count; checks further apart than
    4.5 ms measure nothing."""
    from scipy.spatial.transform import Rotation

    from asmplan.sim.carry_hold import settled

    T0 = np.eye(4)
    T0[:3, 3] = [0.0, 0.0, 0.05]  # the part's origin 50 mm from the TCP

    def moved(rotvec=(0.0, 0.0, 0.0), shift=(0.0, 0.0, 0.0)) -> np.ndarray:
        T = np.eye(4)
        T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
        T[:3, 3] = shift
        return T @ T0  # turned about the TCP, then shifted

    dt = 0.004
    assert settled(T0, moved((1e-5 * dt, 0.0, 0.0)), dt)
    assert not settled(T0, moved((3e-5 * dt, 0.0, 0.0)), dt)
    assert settled(T0, moved(shift=(0.1e-6 * dt, 0.0, 0.0)), dt)
    assert not settled(T0, moved(shift=(0.0, 0.0, 0.3e-6 * dt)), dt)
    assert settled(T0, moved(shift=(0.0, 5e-6 * dt, 0.0)), dt)
    assert not settled(T0, T0, 0.008)


def test_the_grid_s_loads_are_carried_load_at_each_grid_time():
    """PoseGrid.loads (the table a stuck part's checks look up) equals carried_load at every
    grid time, along a lift that also turns (rotational terms)."""
    from scipy.spatial.transform import Rotation

    from asmplan.sim.carry_hold import PoseGrid

    traj = constant_acceleration_lift(np.eye(4), 2.5, ACCEL)
    T = traj.T_world_gripper.copy()
    turn = Rotation.from_rotvec(np.outer(np.linspace(0.0, 0.8, len(T)) ** 2, [0.3, -0.5, 0.8]))
    T[:, :3, :3] = turn.as_matrix()
    traj = type(traj)(traj.t_s, T, traj.clamp_force_N, traj.phases)
    grid = PoseGrid(traj)
    com, inertia = np.array([0.01, -0.002, 0.03]), np.diag([2e-4, 3e-4, 1e-4])
    g = np.array([0.0, 0.0, -G])
    forces, moments = grid.loads(com, PART.mass_kg, inertia, g)
    t0 = float(traj.t_s[0])
    for k in range(0, len(forces), 37):
        f, m = carried_load(grid, t0 + 1e-3 * k, com, PART.mass_kg, inertia, g)
        assert forces[k] == pytest.approx(f, rel=1e-9, abs=1e-12)
        assert moments[k] == pytest.approx(m, rel=1e-9, abs=1e-12)
