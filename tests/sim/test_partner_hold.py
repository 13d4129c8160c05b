"""Mate partners held static under a load check (asmplan.sim.partner_hold): the sliding and
tipping ratios against their analytic values, the wake at the bound, and a held block struck
by a moving body moving as it would have dynamic."""

from __future__ import annotations

import math

import numpy as np
import pytest

from asmplan.sim.bullet import BulletWorld
from asmplan.sim.fidelity import BALANCED
from asmplan.sim.partner_hold import PartnerHold
from bench.scenarios import box_inertia, box_piece

G = 9.81
BLOCK = (0.02, 0.02, 0.06)  # 20 x 20 mm footprint, 60 mm tall
BLOCK_KG = 0.5
MU = 0.8  # block and ground 0.8 / 1.0 -> Bullet's product 0.8


class _Load:
    """Stands in for the exact fit contact: one force on the block at a point."""

    def __init__(self, block: int) -> None:
        self.block = block
        self.force_N = np.zeros(3)
        self.point_m = np.zeros(3)

    def reaction_on(self, body: int) -> list[tuple[np.ndarray, np.ndarray]]:
        return [(self.force_N, self.point_m)] if body == self.block else []


def _scene(world: BulletWorld) -> tuple[int, int, int]:
    world.add_ground(friction=1.0)
    T = np.eye(4)
    T[2, 3] = BLOCK[2] / 2
    block = world.add_body((box_piece(BLOCK),), BLOCK_KG, T,
                           inertia_kgm2=box_inertia(BLOCK_KG, BLOCK), friction=MU, name="block")
    movers = []
    for k, x in enumerate((0.3, -0.3)):  # stand-ins for the gripper and the held part, far away
        Tm = np.eye(4)
        Tm[:3, 3] = (x, 0.0, 0.005)
        movers.append(world.add_body((box_piece((0.01,) * 3),), 0.01, Tm,
                                     inertia_kgm2=box_inertia(0.01, (0.01,) * 3), name=f"m{k}"))
    return block, movers[0], movers[1]


def _ratios(hold: PartnerHold) -> tuple[float, float, str, bool]:
    s = hold.summary()[0]
    return s["max_slide_ratio"], s["max_tip_ratio"], s["reason"], s["woke_s"] is not None


@pytest.mark.parametrize(("height_m", "share", "wakes", "which"), [
    (0.0, 0.4, False, "slide"),  # in the support plane: no moment, slides at mu W
    (0.0, 0.6, True, "slide"),
    (BLOCK[2], 0.4, False, "tip"),  # at the top: tips at F h = W b / 2 (F = W / 6 here)
    (BLOCK[2], 0.6, True, "tip"),
])
def test_sliding_and_tipping_ratios_are_the_analytic_ones(height_m: float, share: float,
                                                          wakes: bool, which: str) -> None:
    with BulletWorld(BALANCED) as world:
        block, gripper, held = _scene(world)
        load = _Load(block)
        hold = PartnerHold(world, gripper, held, load, fraction=0.5)  # type: ignore[arg-type]
        world.step()
        hold.check(world.time_s)
        assert world.is_static(block), hold.summary()
        W = BLOCK_KG * G
        tip_force = W * (BLOCK[0] / 2) / BLOCK[2]  # F h = W b / 2 at h = 60 mm
        slide_force = MU * W
        F = share * (slide_force if which == "slide" else tip_force)
        load.force_N = np.array([F, 0.0, 0.0])
        load.point_m = np.array([0.0, 0.0, height_m])
        world.step()
        hold.check(world.time_s)
        slide, tip, reason, woke = _ratios(hold)
        assert math.isclose(slide, F / slide_force, rel_tol=1e-3), (slide, reason)
        expected_tip = F * height_m / (W * BLOCK[0] / 2)
        assert math.isclose(tip, expected_tip, rel_tol=1e-3, abs_tol=1e-9), (tip, reason)
        assert woke == wakes, reason
        assert world.is_static(block) == (not wakes)
        if wakes:
            assert ("sliding" if which == "slide" else "tipping") in reason, reason


def _strike(hold: bool) -> np.ndarray:
    """A 10 mm frictionless cube driven at 0.1 m/s (its velocity set every step, as a robot
    drives it) meets a 20 mm, 0.1 kg cube resting on the ground 30 mm away and pushes it on
    for 0.3 s (the struck cube held static when ``hold``). Returns its displacement."""
    size_a, size_b = (0.02,) * 3, (0.01,) * 3
    with BulletWorld(BALANCED) as world:
        world.add_ground()
        Ta = np.eye(4)
        Ta[2, 3] = size_a[2] / 2
        a = world.add_body((box_piece(size_a),), 0.1, Ta, inertia_kgm2=box_inertia(0.1, size_a),
                           name="A")
        Tb = np.eye(4)
        Tb[:3, 3] = (-0.045, 0.0, size_b[2] / 2)
        b = world.add_body((box_piece(size_b),), 0.2, Tb, inertia_kgm2=box_inertia(0.2, size_b),
                           friction=0.0, name="B")
        Tc = np.eye(4)
        Tc[:3, 3] = (0.3, 0.0, 0.005)
        c = world.add_body((box_piece(size_b),), 0.01, Tc, inertia_kgm2=box_inertia(0.01, size_b),
                           name="C")
        world.set_velocity(b, (0.1, 0.0, 0.0), (0.0, 0.0, 0.0))
        keeper = PartnerHold(world, c, b) if hold else None
        for i in range(600):
            world.set_velocity(b, (0.1, 0.0, 0.0), (0.0, 0.0, 0.0))
            world.step()
            if keeper is not None and (i == 0 or (i + 1) % 4 == 0):
                keeper.check(world.time_s)
        if keeper is not None:
            s = keeper.summary()
            a_group = next(g for g in s if g["bodies"] == ["A"])
            assert a_group["woke_s"] is not None and 0.29 < a_group["woke_s"] < 0.31, s
        return world.pose(a)[:3, 3] - Ta[:3, 3]


def test_a_held_block_struck_wakes_and_moves_as_a_dynamic_one() -> None:
    ref = _strike(hold=False)
    moved = _strike(hold=True)
    assert ref[0] > 25e-3, ref  # pushed about 30 mm
    # woken within one check (4 ms) of the first contact: the pusher waited at most those
    # 4 ms (0.4 mm at 0.1 m/s) against the held cube
    assert abs(moved[0] - ref[0]) < 0.4e-3, (moved, ref)


def test_a_body_without_a_bearing_polygon_is_not_held() -> None:
    with BulletWorld(BALANCED) as world:
        world.add_ground()
        T = np.eye(4)
        T[:3, 3] = (0.0, 0.0, 0.1)  # in the air: no support
        body = world.add_body((box_piece((0.02,) * 3),), 0.1, T,
                              inertia_kgm2=box_inertia(0.1, (0.02,) * 3), name="floating")
        g1 = world.add_body((box_piece((0.01,) * 3),), 0.01, np.eye(4) @ np.diag([1, 1, 1, 1]),
                            inertia_kgm2=box_inertia(0.01, (0.01,) * 3), name="g")
        hold = PartnerHold(world, g1, g1)
        world.step()
        hold.check(world.time_s)
        assert not world.is_static(body)
        assert "bearing contact points" in hold.summary()[0]["reason"]
