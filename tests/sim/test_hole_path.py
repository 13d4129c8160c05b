"""Holes the held part passes through stay open in its step's scene (asmplan/sim/hole_path.py).

A block 12 mm thick (x 54..66) with a 32 mm hole along x, mouth at x = 66, declared 12.5 mm
deep (0.5 mm past the wall into the open side, as the gearbox's seat_2); a 15 mm rod,
x -73..70 at the end, pushed along +x from 150 mm back: it crosses the hole. A rod ending at
x = 53.8 (0.3 mm inside the declared depth, as the gearbox's seated spacer) or one passing
20 mm beside the hole does not."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from asmplan.knowledge.frames import frame_from_axis
from asmplan.parts.geometry import HoleShape
from asmplan.parts.mesh import TriangleMesh
from asmplan.sim.hole_path import holes_crossed


def _rod(x0: float, x1: float, r: float, n: int = 16) -> TriangleMesh:
    a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    ring = np.stack([np.zeros(n), r * np.cos(a), r * np.sin(a)], axis=1)
    ends = np.array([[x0, 0.0, 0.0], [x1, 0.0, 0.0]])
    v = np.concatenate([ring + ends[0], ring + ends[1], ends])
    f = []
    for i in range(n):
        j = (i + 1) % n
        f += [[i, j, n + j], [i, n + j, n + i], [2 * n, j, i], [2 * n + 1, n + i, n + j]]
    return TriangleMesh(v, np.array(f))


def _case(rod: TriangleMesh, y_m: float = 0.0, travel_m: float = 0.150):
    hole = HoleShape("seat", frame_from_axis([0.066, 0.0, 0.05], [1.0, 0.0, 0.0]), 0.016,
                     0.0125, False, 0.0005)
    geometry = SimpleNamespace(shape=lambda part: SimpleNamespace(holes=(hole,)),
                               mesh=lambda part: rod)
    final = np.eye(4)
    final[:3, 3] = [0.0, y_m, 0.05]
    pre = final.copy()
    pre[0, 3] -= travel_m
    step = SimpleNamespace(part="rod", T_world_pre_insertion=pre, T_world_final=final)
    return holes_crossed(geometry, step, "block", np.eye(4), frozenset({"seat"}))


def test_a_rod_pushed_through_a_hole_crosses_it():
    assert _case(_rod(-0.073, 0.070, 0.0075)) == {"seat"}
    # its end alone, 4 mm out of the mouth at the end of a 1 mm push: the side edges cross
    assert _case(_rod(-0.073, 0.070, 0.0075), travel_m=0.001) == {"seat"}


def test_a_rod_ending_short_of_the_wall_or_beside_the_hole_does_not():
    assert _case(_rod(-0.073, 0.0538, 0.0075)) == frozenset()
    assert _case(_rod(-0.073, 0.070, 0.0075), y_m=0.024) == frozenset()
