"""Sleeping bodies at rest (asmplan.sim.rest): a resting body sleeps, wakes when something
reaches it and then moves as it would have awake; a body that is tipping is never slept."""

from __future__ import annotations

import math

import numpy as np

from asmplan.sim.bullet import BulletWorld
from asmplan.sim.fidelity import BALANCED
from asmplan.sim.rest import RestKeeper
from bench.scenarios import box_inertia, box_piece
from tests.sim.cube_scenes import B_SIZE, cube_and_pusher


def _push_scene(keep: bool) -> tuple[np.ndarray, list[int], dict[str, int], float]:
    """A 20 mm cube resting on the ground; a frictionless 10 mm cube slides into its side at
    0.1 m/s from 30 mm away (face to face). Returns A's displacement, the record rows at which A was at
    zero velocity, the keeper's sleep counts and B's speed at the end."""
    with BulletWorld(BALANCED) as world:
        a, b, Ta = cube_and_pusher(world)
        world.set_velocity(b, (0.1, 0.0, 0.0), (0.0, 0.0, 0.0))
        keeper = RestKeeper(world, b, a) if keep else None
        still = []
        k = BALANCED.record_every_steps
        for row in range(int(0.6 / BALANCED.record_dt_s)):
            world.step(k)
            if keeper is not None:
                keeper.tick(released=True)
            v, w = world.velocity(a)
            if not (np.any(v) or np.any(w)):
                still.append(row)
        moved = world.pose(a)[:3, 3] - Ta[:3, 3]
        return moved, still, {} if keeper is None else keeper.slept, float(
            np.linalg.norm(world.velocity(b)[0]))


def test_a_resting_body_sleeps_then_wakes_when_struck_and_moves_as_if_awake() -> None:
    ref_moved, _, _, ref_vb = _push_scene(keep=False)
    moved, still, slept, vb = _push_scene(keep=True)
    # B's face reaches A's after (45 - 10 - 5) mm / 0.1 m/s = 0.3 s
    assert slept.get("A", 0) >= 1
    rows_asleep_before_impact = [r for r in still if r * BALANCED.record_dt_s < 0.28]
    assert len(rows_asleep_before_impact) > 10  # asleep (zero velocity) before the impact
    # struck, A moves: the same displacement as the run without sleeping (momentum from B)
    assert ref_moved[0] > 0.5e-3, ref_moved
    assert math.isclose(moved[0], ref_moved[0], rel_tol=0.05, abs_tol=20e-6), (moved, ref_moved)
    assert math.isclose(vb, ref_vb, rel_tol=0.05, abs_tol=1e-3)


def test_a_tipping_body_is_never_put_to_sleep() -> None:
    # a 10 x 10 x 60 mm post on one bottom edge, tilted 10 deg (tips beyond atan(5/30) = 9.46)
    size = (0.01, 0.01, 0.06)
    t = math.radians(10.0)
    c, s = math.cos(t), math.sin(t)
    R = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    edge_local = np.array([-size[0] / 2, 0.0, -size[2] / 2])
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = -R @ edge_local + np.array([0.0, 0.0, 1e-6])
    with BulletWorld(BALANCED) as world:
        world.add_ground()
        post = world.add_body((box_piece(size),), 0.05, T, inertia_kgm2=box_inertia(0.05, size),
                              friction=1.0, name="post")
        # a far-away mover, so that "nothing near" holds for the post
        Tm = np.eye(4)
        Tm[:3, 3] = (0.5, 0.5, 0.005)
        mover = world.add_body((box_piece(B_SIZE),), 0.1, Tm, inertia_kgm2=box_inertia(0.1, B_SIZE))
        keeper = RestKeeper(world, mover, post)
        z_at_first_sleep = None
        for _ in range(int(1.0 / BALANCED.record_dt_s)):
            world.step(BALANCED.record_every_steps)
            keeper.tick(released=True)
            if z_at_first_sleep is None and "post" in keeper.slept:
                z_at_first_sleep = float(world.com_position_m(post)[2])
        # it fell over (centre of mass at half its width, 5 mm, not near half its height) and
        # was put to sleep only lying down, never while tipping
        assert world.com_position_m(post)[2] < 0.006
        assert z_at_first_sleep is None or z_at_first_sleep < 0.006
