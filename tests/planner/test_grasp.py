"""Antipodal grasps: widths, contact areas and ranking against analytic values."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from asmplan.knowledge.model import GraspHint, Gripper
from asmplan.planner.errors import CollidingPair
from asmplan.planner.grasp import (
    GraspSurface,
    Rejections,
    collision_free,
    grasp_candidates,
    iter_grasps,
)

GRIPPER = Gripper(stroke_m=0.085, finger_size_m=np.array([0.02, 0.008, 0.03]),
                  finger_friction=1.0, max_force_N=40.0)
DOWN = np.array([0.0, 0.0, -1.0])


def _box(size_m, n=4000, seed=0) -> GraspSurface:
    return GraspSurface.from_mesh(trimesh.creation.box(size_m), np.zeros(3), n, seed, "box")


def test_box_with_hint_closes_along_the_hint_and_is_centred():
    surface = _box([0.1, 0.06, 0.02])
    hint = GraspHint(closing_axis=np.array([0.0, 1.0, 0.0]),
                     approach_axis=np.array([0.0, 0.0, -1.0]))
    grasps = grasp_candidates("p", surface, GRIPPER, hint, limit=20, part_friction=0.75,
                              down_start_part=DOWN, down_final_part=DOWN)
    g = grasps[0]
    assert g.source == "hint"
    np.testing.assert_allclose(g.closing_axis_part, [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(g.approach_axis_part, [0, 0, -1], atol=1e-12)
    assert g.width_m == pytest.approx(0.06, abs=1e-9)  # the box's extent along y
    np.testing.assert_allclose(g.T_part_gripper[:3, 3], 0.0, atol=1e-9)  # on the CoM
    # the pad (20 x 30 mm) covers 20 mm of x and all 20 mm of the height: 400 mm^2;
    # area-uniform sampling with 4000 points estimates it within 15 %
    assert g.contact_area_m2 == pytest.approx(400e-6, rel=0.15)
    assert g.open_width_m == pytest.approx(0.06 + 2 * 3e-3)
    # every hint grasp ranks before every other
    sources = [x.source for x in grasps]
    assert sources == sorted(sources, key=lambda s: s != "hint")
    costs = [x.cost for x in grasps]
    assert costs == sorted(costs)


def test_box_wider_than_the_stroke_is_never_closed_across_it():
    surface = _box([0.1, 0.06, 0.02])  # 100 mm > 85 mm stroke
    grasps = grasp_candidates("p", surface, GRIPPER, None, part_friction=0.75,
                              down_start_part=DOWN, down_final_part=DOWN)
    assert grasps
    assert all(abs(g.closing_axis_part[0]) < 1e-6 for g in grasps)
    assert max(g.width_m for g in grasps) <= GRIPPER.stroke_m - 2 * 3e-3 + 1e-12
    # without a hint the best grasp closes across the 60 mm side from above, on the CoM
    best = grasps[0]
    assert best.width_m == pytest.approx(0.06, abs=1e-9)
    assert float(best.approach_axis_part @ DOWN) == pytest.approx(1.0)


def test_cylinder_radial_grasps_have_the_diameter_and_avoid_the_palm():
    mesh = trimesh.creation.cylinder(radius=0.005, height=0.04, sections=128)
    surface = GraspSurface.from_mesh(mesh, np.zeros(3), 4000, 0, "cylinder")
    grasps = grasp_candidates("peg", surface, GRIPPER, None, limit=30, part_friction=0.5,
                              down_start_part=DOWN, down_final_part=DOWN)
    radial = [g for g in grasps if abs(g.closing_axis_part[2]) < 1e-9]
    assert radial
    for g in radial:
        assert g.width_m == pytest.approx(0.010, abs=5e-6)  # diameter (128-gon: 3 um)
    # a 40 mm peg cannot be held centred from above by 30 mm fingers: the palm would hit its
    # top; the best top grasp is shifted up so the palm clears the top face
    top = [g for g in radial if float(g.approach_axis_part @ DOWN) > 0.999]
    L = GRIPPER.finger_size_m[2]
    for g in top:
        tcp_z = g.T_part_gripper[2, 3]
        assert tcp_z + L / 2 >= 0.02 - 1e-9  # the finger roots are above the top face


def test_friction_cone_rejects_a_wedge():
    """Closing across two faces 40 deg apart needs mu >= tan(20 deg) = 0.36."""
    h, w, length = 0.02, 0.01, 0.04
    top = w / 2 + h * math.tan(math.radians(20.0))
    # a prism along z whose cross-section is a trapezoid in x-y: its two side faces lean
    # 20 deg away from the y axis, so closing along x meets them 20 deg off their normals
    prof = [(-w / 2, -h / 2), (w / 2, -h / 2), (top, h / 2), (-top, h / 2)]
    pts = np.array([(x, y, z) for x, y in prof for z in (-length / 2, length / 2)])
    mesh = trimesh.convex.convex_hull(pts)
    surface = GraspSurface.from_mesh(mesh, mesh.center_mass, 4000, 0, "mesh")

    def across(mu: float) -> list:
        out = grasp_candidates("w", surface, GRIPPER, None, part_friction=mu)
        return [g for g in out if abs(g.closing_axis_part[0]) > 0.999]

    assert not across(0.3)  # cone half-angle 16.7 deg < 20 deg
    assert across(0.5)  # 26.6 deg > 20 deg


def test_collision_free_filters_and_tallies():
    surface = _box([0.04, 0.04, 0.04])
    cands = grasp_candidates("c", surface, GRIPPER, None, limit=40, part_friction=0.5,
                             down_start_part=DOWN, down_final_part=DOWN)

    def collisions(g):
        if float(g.approach_axis_part @ DOWN) > 0.999:
            return "start pose", [CollidingPair("gripper(closing)", "table")]
        return "", []

    rej = Rejections()
    free = list(collision_free(cands, collisions, rej, max_candidates=40))
    assert free and all(float(g.approach_axis_part @ DOWN) < 0.999 for g in free)
    n_top = sum(float(g.approach_axis_part @ DOWN) > 0.999 for g in cands)
    assert rej.examined == len(cands)
    assert rej.reasons() == [f"{n_top} candidates: the gripper hits table at the start pose"]


def test_lazy_order_equals_full_ranking_and_is_deterministic():
    surface = _box([0.05, 0.03, 0.02], seed=3)
    full = list(iter_grasps("b", surface, GRIPPER, None, part_friction=0.5,
                            down_start_part=DOWN, down_final_part=np.array([1.0, 0.0, 0.0])))
    costs = [g.cost for g in full]
    assert costs == sorted(costs)
    again = list(iter_grasps("b", _box([0.05, 0.03, 0.02], seed=3), GRIPPER, None,
                             part_friction=0.5, down_start_part=DOWN,
                             down_final_part=np.array([1.0, 0.0, 0.0])))
    assert [g.T_part_gripper.tobytes() for g in full] == [g.T_part_gripper.tobytes()
                                                          for g in again]


def test_scalar_clip_matches_numpy_bit_for_bit():
    """The grasp search clips its offsets with a scalar helper: same bits as np.clip,
    including signed zeros, infinities and an empty range (lo > hi)."""
    import itertools

    from asmplan.planner.grasp import _clip

    values = [-0.0, 0.0, 1.0, -1.0, 0.5, 2.0, 1e-300, -1e-300, math.inf, -math.inf]
    for x, lo, hi in itertools.product(values, repeat=3):
        assert _clip(x, lo, hi).hex() == float(np.clip(x, lo, hi)).hex(), (x, lo, hi)
