"""Same trajectory and preset twice -> bit-identical records."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from sim_scenes import SEED_CSV

from asmplan.planner.trajectory import read_phase_table, seed_cycle
from asmplan.sim.bullet import BulletWorld
from asmplan.sim.execute import execute_step
from asmplan.sim.fidelity import BALANCED, FAST
from bench.scenarios import BoxPart, add_box_and_gripper, pin_insertion, run_seed_cycle


def _assert_identical(rec_a, rec_b, out_a, out_b):
    arrays_a, arrays_b = rec_a.arrays(), rec_b.arrays()
    for name, a in arrays_a.items():
        assert np.array_equal(a, arrays_b[name], equal_nan=True), name
    strip = {"wall_time_s": 0.0}
    assert dataclasses.replace(out_a, **strip) == dataclasses.replace(out_b, **strip)


@pytest.mark.slow
def test_seed_cycle_twice_is_bit_identical():
    rec_a, out_a, _ = run_seed_cycle(BALANCED)
    rec_b, out_b, _ = run_seed_cycle(BALANCED)
    _assert_identical(rec_a, rec_b, out_a, out_b)


@pytest.mark.slow
def test_insertion_twice_is_bit_identical():
    rec_a, out_a = pin_insertion(FAST, 0.1e-3)
    rec_b, out_b = pin_insertion(FAST, 0.1e-3)
    _assert_identical(rec_a, rec_b, out_a, out_b)


@pytest.mark.slow
def test_reused_world_after_restore_state_replays_the_step():
    """saveState/restoreState lets one world run many trials of a step, bit-identically."""
    with BulletWorld(BALANCED) as world:
        body, gripper, T0 = add_box_and_gripper(world, BoxPart())
        traj = seed_cycle(read_phase_table(SEED_CSV), T0)
        start = world.save_state()
        rec_a, out_a = execute_step(world, gripper, body, traj)
        world.restore_state(start)
        gripper.command_open()  # commands are not part of the saved state
        rec_b, out_b = execute_step(world, gripper, body, traj)
    _assert_identical(rec_a, rec_b, out_a, out_b)
