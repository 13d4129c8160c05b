"""The placed part held static while it rests and nothing can move it (asmplan.sim.placed_hold):
held once at rest on static bodies, kept under a load the check allows (it does not move),
freed by a push beyond the check or by a dynamic body, and then moving as it would have."""

from __future__ import annotations

import math

import numpy as np

from asmplan.sim.bullet import BulletWorld
from asmplan.sim.fidelity import BALANCED
from asmplan.sim.placed_hold import PlacedHold
from bench.scenarios import box_inertia, box_piece
from tests.sim.cube_scenes import A_SIZE, B_SIZE, cube_and_pusher


def _push_scene(hold: bool, b_is_gripper: bool) -> tuple[np.ndarray, PlacedHold | None, float]:
    """A 100 g, 20 mm cube A on the ground; a frictionless 200 g, 10 mm cube B driven at
    0.1 m/s (its velocity set before every physics step, as a pose-controlled finger) into A's
    side from 30 mm away (face to face after 0.3 s). B is the hold's gripper or a dynamic body
    (the gripper then a body far away). Returns A's displacement, the hold and B's speed at
    the end."""
    with BulletWorld(BALANCED) as world:
        a, b, Ta = cube_and_pusher(world)
        Tf = np.eye(4)
        Tf[:3, 3] = (0.5, 0.5, B_SIZE[2] / 2)
        far = world.add_body((box_piece(B_SIZE),), 0.1, Tf, inertia_kgm2=box_inertia(0.1, B_SIZE),
                             name="far")
        keeper = (PlacedHold(world, a, b if b_is_gripper else far, fraction=0.5) if hold
                  else None)
        k = BALANCED.record_every_steps
        for row in range(int(0.6 / BALANCED.record_dt_s)):
            for _ in range(k):
                world.set_velocity(b, (0.1, 0.0, 0.0), (0.0, 0.0, 0.0))
                world.step()
            if keeper is not None:
                keeper.tick((row + 1) * BALANCED.record_dt_s, True, world.contacts(a))
        moved = world.pose(a)[:3, 3] - Ta[:3, 3]
        return moved, keeper, float(np.linalg.norm(world.velocity(b)[0]))


def test_a_resting_part_is_held_then_freed_by_a_gripper_push_beyond_the_check() -> None:
    ref_moved, _, ref_vb = _push_scene(hold=False, b_is_gripper=True)
    moved, keeper, vb = _push_scene(hold=True, b_is_gripper=True)
    assert keeper is not None
    # at rest after the window (0.1 s), held until B's face reaches A's at 0.3 s
    assert keeper.held_at_s and keeper.held_at_s[0] < 0.15, keeper.held_at_s
    assert keeper.freed_at_s and 0.29 <= keeper.freed_at_s[0] <= 0.31, keeper.freed_at_s
    # freed within a record row (4 physics steps, 0.4 mm of B's travel), A is pushed on as in
    # the run without the hold
    assert ref_moved[0] > 20e-3, ref_moved
    assert math.isclose(moved[0], ref_moved[0], abs_tol=0.4e-3), (moved, ref_moved)
    assert math.isclose(vb, ref_vb, rel_tol=0.05, abs_tol=1e-3)


def test_a_dynamic_body_touching_the_part_frees_it() -> None:
    ref_moved, _, _ = _push_scene(hold=False, b_is_gripper=False)
    moved, keeper, _ = _push_scene(hold=True, b_is_gripper=False)
    assert keeper is not None and keeper.held_at_s and keeper.freed_at_s
    assert 0.29 <= keeper.freed_at_s[0] <= 0.31, keeper.freed_at_s
    assert math.isclose(moved[0], ref_moved[0], abs_tol=0.4e-3), (moved, ref_moved)


def _cube_with_pad_on_top(world: BulletWorld) -> tuple[int, int]:
    """Cube A (100 g) on the ground and a 10 g 'pad' cube resting on its top: (A, pad)."""
    world.add_ground()
    Ta = np.eye(4)
    Ta[2, 3] = A_SIZE[2] / 2
    a = world.add_body((box_piece(A_SIZE),), 0.1, Ta, inertia_kgm2=box_inertia(0.1, A_SIZE),
                       name="A")
    Tp = np.eye(4)
    Tp[2, 3] = A_SIZE[2] + B_SIZE[2] / 2
    pad = world.add_body((box_piece(B_SIZE),), 0.01, Tp,
                         inertia_kgm2=box_inertia(0.01, B_SIZE), name="pad")
    return a, pad


def test_a_gripper_load_within_the_check_keeps_the_part_held_where_it_rests() -> None:
    """A 10 g 'pad' resting on A's top: 0.1 N straight down on a 1 N part, slide ratio 0 and
    no overturning moment: A stays static, where it came to rest."""
    with BulletWorld(BALANCED) as world:
        a, pad = _cube_with_pad_on_top(world)
        keeper = PlacedHold(world, a, pad, fraction=0.5)
        k = BALANCED.record_every_steps
        rest_pose = None
        for row in range(int(0.5 / BALANCED.record_dt_s)):
            world.step(k)
            keeper.tick((row + 1) * BALANCED.record_dt_s, True, world.contacts(a))
            if keeper.holding and rest_pose is None:
                rest_pose = world.pose(a)
        assert keeper.held_at_s and not keeper.freed_at_s, (keeper.held_at_s, keeper.freed_at_s)
        assert rest_pose is not None
        assert np.array_equal(world.pose(a), rest_pose)
        # the pad rests on the static part (a contact with a normal force of its weight)
        con = world.contacts(pad, a)
        assert con.count and math.isclose(float(np.sum(con.normal_force_N)), 0.01 * 9.81,
                                          rel_tol=0.05)


def test_without_the_load_fraction_a_touching_gripper_keeps_the_part_free() -> None:
    """``fraction`` 0 (ACCURATE): held only while the gripper does not touch."""
    with BulletWorld(BALANCED) as world:
        a, pad = _cube_with_pad_on_top(world)
        keeper = PlacedHold(world, a, pad, fraction=0.0)
        for row in range(int(0.3 / BALANCED.record_dt_s)):
            world.step(BALANCED.record_every_steps)
            keeper.tick((row + 1) * BALANCED.record_dt_s, True, world.contacts(a))
        assert not keeper.held_at_s
