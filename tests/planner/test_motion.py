"""Motion planning: plans for every example, re-checked densely with FCL; typed failures."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from asmplan.knowledge.frames import make_T
from asmplan.knowledge.model import Product
from asmplan.planner.certify import certify_path
from asmplan.planner.errors import (
    InsertionBlockedError,
    NoGraspError,
    NoPathError,
    StartInCollisionError,
)
from asmplan.planner.insertion import insertion_spec
from asmplan.planner.motion import MotionPlanner
from asmplan.planner.plan import Step
from asmplan.planner.product import plan_product
from asmplan.planner.recheck import dense_recheck
from asmplan.planner.scene import GRIPPER_CLOSED, BroadPhaseValidity
from asmplan.planner.settings import PlannerSettings
from asmplan.planner.trajectory import Trajectory
from tests.planner.conftest import ORDERS


def with_start(product: Product, part: str, xyz_mm: tuple[float, float, float],
               rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Product:
    """``product`` with ``part`` starting at another pose."""
    T = make_T(np.array(xyz_mm) * 1e-3, np.radians(rpy_deg))
    parts = tuple(dataclasses.replace(p, T_world_start=T) if p.name == part else p
                  for p in product.parts)
    return dataclasses.replace(product, parts=parts)


def gear_unit_standing(product: Product) -> Product:
    """The gear unit with the wheel and the collar standing on edge in their tray (axis along
    world x, as assembled): lying flat they cannot be grasped by a parallel gripper and slid
    onto the horizontal shaft without regrasping (see test_flat_wheel_has_no_grasp)."""
    p = with_start(product, "wheel", (20, 220, 18), (0, -90, 0))
    return with_start(p, "collar", (80, 220, 10), (0, 90, 0))


def _plan(product: Product, cache, settings: PlannerSettings | None = None):
    settings = settings or PlannerSettings()
    return plan_product(product, cache.geo(product), settings, sequence=ORDERS.get(product.name),
                        parts=cache.parts(product, settings.collision_level))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["pinhole_station", "peg_in_hole", "gear_unit"])
def test_every_example_plans_and_passes_a_dense_exact_recheck(name, examples, geometry_cache):
    product = examples[name]
    if name == "gear_unit":
        product = gear_unit_standing(product)
    result = _plan(product, geometry_cache)
    plan = result.plan
    assert [s.part for s in plan.steps] == ORDERS[name]
    for s in plan.steps:
        if product.is_fixtured(s.part):
            assert s.kind == "fixture" and s.trajectory is None
            continue
        assert s.kind == "insert"
        traj = s.trajectory
        # the trajectory starts at the pre-grasp pose, grasps the part where it lies and
        # releases it seated: TCP = part pose @ grasp at both ends of the held phases
        T_clamp = traj.pose_at(traj.phase_span("clamp").t_start_s)
        T_release = traj.pose_at(traj.phase_span("release").t_start_s)
        np.testing.assert_allclose(T_clamp, s.T_world_start @ s.grasp.T_part_gripper, atol=1e-9)
        np.testing.assert_allclose(T_release, s.T_world_final @ s.grasp.T_part_gripper,
                                   atol=1e-9)
        # the seated pose is the assembled pose; the pre-insertion pose lies on the mate axis
        np.testing.assert_allclose(s.T_world_final, product.T_world_assembled(s.part),
                                   atol=1e-12)
        back = s.T_world_final[:3, 3] - s.T_world_pre_insertion[:3, 3]
        assert np.linalg.norm(np.cross(back, s.insertion_direction)) < 1e-9
        assert float(back @ s.insertion_direction) == pytest.approx(
            s.insertion_length_m + product.process.approach_distance_m, abs=1e-12)
    # independent re-check: uniform 0.1 mm steps, exact collision models (BVH meshes)
    exact = geometry_cache.parts(product, "exact")
    report = dense_recheck(plan, product, exact, step_m=1e-4)
    assert report.violations == ()
    assert report.poses_checked > 1000


def test_pinhole_median_step_time_and_determinism(examples, geometry_cache):
    product = examples["pinhole_station"]
    a = _plan(product, geometry_cache)
    b = _plan(product, geometry_cache)
    assert a.plan.to_json() == b.plan.to_json()  # same seed, same bytes
    c = _plan(product, geometry_cache, PlannerSettings(seed=7))
    assert c.plan.to_json() != a.plan.to_json() or all(
        s.path_T_world_gripper is None or len(s.path_T_world_gripper) == 2
        for s in c.plan.steps)  # a straight path is the same for every seed
    # CPU time (the steps now include the arm: IK, arm collisions, joint timing): wall time
    # on a shared 2-core machine at load 10 was 6x the CPU time; generous bound, the
    # benchmark reports the real figures
    times = sorted(t.cpu_s for t in a.step_times[1:])
    assert times[len(times) // 2] < 0.5


def test_blocked_product_names_the_obstacle(blocked_product, geometry_cache):
    with pytest.raises(InsertionBlockedError, match=r'blocked by "bridge"') as err:
        plan_product(blocked_product, geometry_cache.geo(blocked_product), PlannerSettings(), sequence=["block", "bridge", "peg"],
                     parts=geometry_cache.parts(blocked_product))
    e = err.value
    assert e.obstacle == "bridge" and e.part == "peg" and e.step == 2
    ev = e.evidence()
    assert ev["pairs"] and {ev["pairs"][0]["a"], ev["pairs"][0]["b"]} == {"bridge", "peg"}
    # the pose is on the peg's mate axis (x = y = 0), above the seated pose
    assert np.allclose(e.T_world_part[:2, 3], 0.0) and e.T_world_part[2, 3] > 0.03


def test_start_in_collision_is_typed_with_pairs(examples, geometry_cache):
    product = examples["pinhole_station"]
    # part3 starts where part4 lies (overlapping), both on the tray
    bad = with_start(product, "part3", (-130, 200, 20))
    with pytest.raises(StartInCollisionError, match=r"part3 / part4|part4 / part3") as err:
        MotionPlanner(bad, PlannerSettings(), geometry_cache.parts(product))
    assert err.value.pairs[0].depth_m > 0.01


def test_flat_wheel_has_no_grasp(examples, geometry_cache):
    """Lying flat, the wheel must be reoriented by 90 deg onto a horizontal shaft: every
    grasp collides (table at the start, shaft or block when seated)."""
    product = with_start(gear_unit_standing(examples["gear_unit"]), "wheel", (20, 220, 5))
    with pytest.raises(NoGraspError, match=r'part "wheel"') as err:
        plan_product(product, geometry_cache.geo(product), PlannerSettings(max_grasp_candidates=150),
                     sequence=ORDERS["gear_unit"][:4] + ORDERS["gear_unit"][4:],
                     parts=geometry_cache.parts(examples["gear_unit"]))
    assert any("table at the start pose" in r for r in err.value.reasons)


def test_insertion_spec_directions(examples):
    g = examples["gear_unit"]
    shaft = insertion_spec(g, "shaft", ["base", "bearing_block"])
    np.testing.assert_allclose(shaft.direction, [-1, 0, 0], atol=1e-12)  # pin part: pin axis
    assert shaft.length_m == pytest.approx(0.040) and shaft.mates == ("shaft_in_bore",)
    wheel = insertion_spec(g, "wheel", ["base", "bearing_block", "shaft"])
    np.testing.assert_allclose(wheel.direction, [-1, 0, 0], atol=1e-12)  # hole part: -pin axis
    collar = insertion_spec(g, "collar", ["base", "bearing_block", "shaft"])
    np.testing.assert_allclose(collar.direction, [1, 0, 0], atol=1e-12)
    cover = insertion_spec(g, "cover", ["base", "post_1", "post_2"])
    np.testing.assert_allclose(cover.direction, [0, 0, -1], atol=1e-12)
    assert set(cover.mates) == {"cover_on_post_1", "cover_on_post_2"}
    # no mate with the placed parts: placed along the fallback (here the handling default)
    lone = insertion_spec(g, "cover", ["base"])
    assert lone.kind == "place" and lone.length_m == 0.0
    np.testing.assert_allclose(lone.direction, [0, 0, -1])


def test_certify_path_catches_what_sampling_steps_over(examples, geometry_cache):
    """A straight leg through part1 (15 mm thick) whose ends are free: OMPL at a 20 mm
    resolution would accept it; the certification finds the collision."""
    product = examples["pinhole_station"]
    planner = MotionPlanner(product, PlannerSettings(), geometry_cache.parts(product))
    scene = planner.scene
    obstacles = scene.obstacles("part4")
    carried = [("part4", np.eye(4))]
    valid = BroadPhaseValidity(scene, carried, obstacles)
    free_a, free_b = make_T((-0.12, -0.1, 0.06)), make_T((0.12, -0.1, 0.06))
    assert valid(free_a) and valid(free_b)
    mid = make_T((0.0, 0.0, 0.02))
    assert not valid(mid)  # part4 (20 mm tall) at z 10..30 mm overlaps part1 (0..15 mm)
    cert = certify_path(scene, np.array([make_T((-0.2, 0.0, 0.02)), make_T((0.2, 0.0, 0.02))]),
                        carried, obstacles, radius_m=0.05, fine_step_m=1e-4)
    assert not cert.ok and any("part1" in (p.a, p.b) for p in cert.pairs)
    assert -0.1 < cert.T_world_gripper[0, 3] < 0.0  # the first hit, on the way in
    ok = certify_path(scene, np.array([free_a, free_b]), carried, obstacles, 0.05, 1e-4)
    assert ok.ok and ok.checked < 50  # far from everything: few distance-bounded steps


def test_dense_recheck_finds_a_collision_in_a_corrupted_plan(examples, geometry_cache):
    product = examples["pinhole_station"]
    plan = _plan(product, geometry_cache).plan
    step = plan.steps[1]
    traj = step.trajectory
    T = traj.T_world_gripper.copy()
    lift = traj.phase_span("translate")
    m = (traj.t_s > lift.t_start_s) & (traj.t_s < lift.t_end_s)
    T[m, 2, 3] -= 0.2  # carry the part through the table
    bad = Trajectory(traj.t_s, T, traj.clamp_force_N, traj.phases)
    steps = list(plan.steps)
    steps[1] = Step(**{**{f.name: getattr(step, f.name) for f in dataclasses.fields(Step)},
                       "trajectory": bad})
    corrupted = dataclasses.replace(plan, steps=tuple(steps))
    report = dense_recheck(corrupted, product, geometry_cache.parts(product), step_m=1e-3)
    assert report.violations and report.violations[0].part == "part2"
    assert report.violations[0].phase == "translate"
    assert any("table" in (p.a, p.b) for p in report.violations[0].pairs)
    assert GRIPPER_CLOSED  # the closed gripper body is part of the check


@pytest.mark.slow
def test_direct_insertion_baseline_does_not_reach_the_hole_quickly(examples, geometry_cache):
    """Planning straight into the hole (no pre-insertion pose) is the benchmark's baseline:
    with a 17 um fit it finds no path within a short budget, while the planner succeeds."""
    product = examples["peg_in_hole"]
    settings = PlannerSettings(time_budget_s=0.3, replan_attempts=0)
    from bench.motion import DirectInsertionPlanner

    baseline = DirectInsertionPlanner(product, settings, geometry_cache.parts(product))
    with pytest.raises((NoPathError, NoGraspError), match=r"no collision-free path|no feasible"):
        for k, part in enumerate(ORDERS["peg_in_hole"]):
            baseline.plan_step(k, part)
    assert plan_product(product, geometry_cache.geo(product), settings, sequence=ORDERS["peg_in_hole"],
                        parts=geometry_cache.parts(product)).plan.steps[1].kind == "insert"


def test_ompl_search_is_seeded():
    """A wall with a window forces a search (the straight motion is blocked): the same seed
    gives the same path, another seed another one; both pass through the window."""
    from asmplan.planner.ompl_backend import SE3Bounds, plan_se3

    def valid(T: np.ndarray) -> bool:
        x, y, z = T[:3, 3]
        in_wall = abs(x) < 0.01
        in_window = abs(y - 0.1) < 0.03 and abs(z - 0.15) < 0.03
        return not in_wall or in_window

    bounds = SE3Bounds(np.array([-0.2, -0.2, 0.0]), np.array([0.2, 0.2, 0.3]))
    start, goal = make_T((-0.15, 0.0, 0.05)), make_T((0.15, 0.0, 0.05))
    a = plan_se3(valid, start, goal, bounds, seed=1, time_budget_s=5.0)
    b = plan_se3(valid, start, goal, bounds, seed=1, time_budget_s=5.0)
    c = plan_se3(valid, start, goal, bounds, seed=2, time_budget_s=5.0)
    assert a.solved and b.solved and c.solved and a.status != "direct motion valid"
    np.testing.assert_array_equal(a.poses, b.poses)
    assert a.poses.shape != c.poses.shape or not np.array_equal(a.poses, c.poses)
    for path in (a.poses, c.poses):
        for p0, p1 in itertools.pairwise(path[:, :3, 3]):
            if (p0[0] < 0) != (p1[0] < 0):  # where the leg crosses the wall's mid-plane
                q = p0 + (p1 - p0) * (-p0[0] / (p1[0] - p0[0]))
                assert abs(q[1] - 0.1) < 0.03 and abs(q[2] - 0.15) < 0.03


def test_missing_start_pose_gets_a_free_table_spot(examples, geometry_cache):
    product = examples["pinhole_station"]
    parts = tuple(dataclasses.replace(p, T_world_start=np.full((4, 4), np.nan))
                  if p.name == "part4" else p for p in product.parts)
    nostart = dataclasses.replace(product, parts=parts)
    result = plan_product(nostart, geometry_cache.geo(product), PlannerSettings(), sequence=ORDERS["pinhole_station"],
                          parts=geometry_cache.parts(product))
    step = result.plan.step("part4")
    assert step.start_note.startswith("no start pose given: placed on the table")
    # assembled orientation, lowest point (the pins' tips) on the table top
    np.testing.assert_allclose(step.T_world_start[:3, :3],
                               product.T_world_assembled("part4")[:3, :3], atol=1e-12)
    pts = geometry_cache.parts(product)["part4"].points_m
    lowest = (pts @ step.T_world_start[:3, :3].T + step.T_world_start[:3, 3])[:, 2].min()
    assert lowest == pytest.approx(0.0, abs=1e-9)
    # beside the product, clear of it: the spot is on the -y side of part1
    assert step.T_world_start[1, 3] < -0.04


def test_too_heavy_part_is_a_grip_failure_with_numbers(examples, geometry_cache):
    from asmplan.planner.errors import GripInfeasibleError

    product = examples["pinhole_station"]
    parts = dict(geometry_cache.parts(product))
    parts["part3"] = dataclasses.replace(parts["part3"], mass_kg=2.0)
    with pytest.raises(GripInfeasibleError, match=r"step 3 \(part \"part3\"\).*needs 52\.49 N") \
            as err:
        plan_product(product, geometry_cache.geo(product), PlannerSettings(),
                     sequence=ORDERS["pinhole_station"], parts=parts)
    # 2 x 2.0 kg x (9.81 + 2.0) / (2 x 1.0 x 0.45) = 52.5 N > 40 N (found before any grasp is
    # tried, so without a moment term; no insertion resistance is declared)
    assert err.value.required_N == pytest.approx(2 * 2.0 * 11.81 / 0.9, rel=1e-9)
    assert err.value.limit_N == 40.0
