"""The planner scene's box tier (Scene.gap, near, closest) on stacked obstacle boxes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from asmplan.knowledge.frames import make_T
from asmplan.planner.motion import MotionPlanner
from asmplan.planner.settings import PlannerSettings


def test_box_gaps_near_and_closest_are_the_box_distances(examples, geometry_cache):
    product = examples["pinhole_station"]
    scene = MotionPlanner(product, PlannerSettings(), geometry_cache.parts(product)).scene
    obstacles = scene.obstacles("part4")
    hi = scene.world.aabb("part1")[1]
    # a 2 mm cube 3 mm beyond part1's +x face and 4 mm beyond its +y face, level with its top
    lo = hi + np.array([0.003, 0.004, -0.001])
    box = np.stack([lo, lo + 0.002])
    assert scene.gap(box, ["part1"]) == pytest.approx(0.005, abs=1e-12)  # a 3-4-5 triangle
    singles = [scene.gap(box, [o]) for o in obstacles]
    assert scene.gap(box, obstacles) == min(singles)
    assert scene.gap(box, []) == math.inf and scene.near(box, []) == []
    # near: the boxes grown by the margin overlap (per axis: part1 is 4 mm off at most)
    assert "part1" in scene.near(box, obstacles, margin=0.0041)
    assert "part1" not in scene.near(box, obstacles, margin=0.0039)
    margin = 0.01
    near = scene.near(box, obstacles, margin)
    assert near == [o for o in obstacles if o in near]  # in the obstacles' order
    for o, g in zip(obstacles, singles, strict=True):
        assert (g <= margin) <= (o in near) and (o in near) <= (g <= margin * math.sqrt(3))
    # the gap is a lower bound of the exact distance, reached here between two flat faces
    carried = [("part4", make_T((0.0, 0.0, 0.3)))]  # 300 mm above everything
    d, who = scene.closest(carried, obstacles, enough=0.01)
    assert who == "" and d == scene.gap(scene.box_at("part4", carried[0][1]), obstacles) > 0.2
