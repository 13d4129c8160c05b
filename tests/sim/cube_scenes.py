"""Small scenes of cubes shared by the tests of the keepers that hold resting bodies
(asmplan.sim.rest, asmplan.sim.placed_hold)."""

from __future__ import annotations

import numpy as np

from asmplan.sim.bullet import BulletWorld
from bench.scenarios import box_inertia, box_piece

A_SIZE = (0.02, 0.02, 0.02)
B_SIZE = (0.01, 0.01, 0.01)


def cube_and_pusher(world: BulletWorld) -> tuple[int, int, np.ndarray]:
    """A 100 g, 20 mm cube A resting on the ground and a frictionless 200 g, 10 mm cube B
    30 mm from A's side (face to face after 0.3 s at 0.1 m/s along +x): (A, B, A's pose)."""
    world.add_ground()
    Ta = np.eye(4)
    Ta[2, 3] = A_SIZE[2] / 2
    a = world.add_body((box_piece(A_SIZE),), 0.1, Ta, inertia_kgm2=box_inertia(0.1, A_SIZE),
                       name="A")
    Tb = np.eye(4)
    Tb[:3, 3] = (-0.045, 0.0, B_SIZE[2] / 2)
    b = world.add_body((box_piece(B_SIZE),), 0.2, Tb, inertia_kgm2=box_inertia(0.2, B_SIZE),
                       friction=0.0, name="B")
    return a, b, Ta
