"""Benchmark of the arm (``asmplan bench --sections arm``, from ``bench/suite.py``): inverse
kinematics per waypoint and planning time per pick-and-insert step with the arm, against the
same steps without it.

* IK per waypoint: every step trajectory of the bundled examples' plans tracked as planning
  does (:meth:`ArmModel.track`: each distinct TCP pose from the previous solutions), CPU time
  per distinct pose (median over the steps), and the all-branches IK (seeded, what each
  grasp's first pose costs), medians.
* Plan time per step: ``plan_product`` of each example, ``runs`` times, interleaved with and
  without the arm (the product's ``resources.robot`` removed); medians of the wall-clock and
  CPU time of the pick-and-insert steps (fixture steps excluded).

Times are reported, never asserted (machines are shared).
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.arm import ArmModel
from asmplan.planner.product import plan_product
from asmplan.planner.settings import PlannerSettings

EXAMPLES = ("pinhole_station", "peg_in_hole", "gear_unit")


@dataclass(frozen=True)
class ArmBenchRow:
    """One example: IK medians (us, ms), waypoints timed, and per-step plan times (ms)."""

    product: str
    waypoints: int
    ik_track_us: float
    ik_all_ms: float
    branches_median: float
    steps: int
    plan_arm_ms: float
    plan_arm_cpu_ms: float
    plan_free_ms: float
    plan_free_cpu_ms: float
    cycle_time_s: float


def _example(name: str):
    from importlib import resources

    return load_product(str(resources.files("asmplan.examples").joinpath(f"{name}.yaml")))


# Complexity above C (radon): one benchmark loop per product: planning with and without the arm,
# then IK along every path and all-branch IK, all feeding the same row.
def bench_arm(products: Sequence[str] = EXAMPLES, runs: int = 5, log=None) -> list[ArmBenchRow]:
    """Measure every example (see the module docstring)."""
    rows = []
    for name in products:
        product = _example(name)
        free = dataclasses.replace(product, resources=dataclasses.replace(product.resources,
                                                                          robot=None))
        settings = PlannerSettings()
        arm_ms: list[float] = []
        arm_cpu: list[float] = []
        free_ms: list[float] = []
        free_cpu: list[float] = []
        plan = None
        for _ in range(runs):
            for which, prod in (("arm", product), ("free", free)):
                res = plan_product(prod, ProductGeometry(prod), settings)
                times = [t for t, s in zip(res.step_times, res.plan.steps, strict=True)
                         if s.kind != "fixture"]
                (arm_ms if which == "arm" else free_ms).extend(1e3 * t.total_s for t in times)
                (arm_cpu if which == "arm" else free_cpu).extend(1e3 * t.cpu_s for t in times)
                if which == "arm":
                    plan = res.plan
        assert plan is not None
        model = ArmModel(product.resources.robot, settings.arm)
        track: list[float] = []
        full: list[float] = []
        branches: list[int] = []
        n = 0
        for step in plan.steps:
            if step.arm is None:
                continue
            assert step.trajectory is not None
            T = step.trajectory.T_world_gripper
            distinct = 1 + sum(1 for k in range(1, len(T)) if not np.array_equal(T[k], T[k - 1]))
            t0 = time.process_time()
            model.track(T, step.arm.q_rad[0])  # what planning does along the step's path
            track.append((time.process_time() - t0) / distinct)
            n += distinct
            for k in range(0, len(T), max(1, len(T) // 10)):
                t0 = time.perf_counter()
                sols, _ = model.ik_all(T[k])
                full.append(time.perf_counter() - t0)
                branches.append(len(sols))
        rows.append(ArmBenchRow(
            product=name, waypoints=n, ik_track_us=1e6 * statistics.median(track),
            ik_all_ms=1e3 * statistics.median(full), branches_median=statistics.median(branches),
            steps=len([s for s in plan.steps if s.kind != "fixture"]),
            plan_arm_ms=statistics.median(arm_ms), plan_arm_cpu_ms=statistics.median(arm_cpu),
            plan_free_ms=statistics.median(free_ms), plan_free_cpu_ms=statistics.median(free_cpu),
            cycle_time_s=plan.cycle_time_s))
        if log is not None:
            log(f"arm: {name} done")
    return rows


def format_arm(rows: Sequence[ArmBenchRow]) -> str:
    """Markdown table of :func:`bench_arm`."""
    lines = ["| product | waypoints | IK along the path, median us | all-branch IK, median ms "
             "(branches) | steps | plan ms/step with arm (CPU) | without arm (CPU) | ratio | "
             "cycle time s |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r.product} | {r.waypoints} | {r.ik_track_us:.0f} | {r.ik_all_ms:.1f} "
                     f"({r.branches_median:g}) | {r.steps} | {r.plan_arm_ms:.0f} "
                     f"({r.plan_arm_cpu_ms:.0f}) | {r.plan_free_ms:.0f} ({r.plan_free_cpu_ms:.0f}) | "
                     f"{r.plan_arm_cpu_ms / max(r.plan_free_cpu_ms, 1e-9):.1f} | "
                     f"{r.cycle_time_s:.2f} |")
    return "\n".join(lines) + "\n"
