"""Benchmark of per-step motion planning, against planning the insertion directly with OMPL.

For each product: the part geometry is prepared once (reported apart), the plan is made with
the sequence planner's order (the first ranked order that can be planned), and every
pick-and-insert step is timed (wall clock and process CPU). The baseline plans the same
step, in the same partial assembly and with the grasp the plan chose, but lets OMPL plan from
the lifted pose straight into the seated pose (no pre-insertion pose, no straight insertion)
within ``direct_budget_s`` (one query, no re-planning); the ratio is baseline time / our time
(a lower bound when the baseline finds no path within its budget).

Run ``python -m bench.motion [PRODUCT.yaml ...]`` (default: the bundled
examples); ``asmplan bench`` calls :func:`bench`.
"""

from __future__ import annotations

import dataclasses
import statistics
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.errors import PlanningError
from asmplan.planner.motion import MotionPlanner
from asmplan.planner.partdata import part_data
from asmplan.planner.product import plan_product
from asmplan.planner.settings import PlannerSettings

EXAMPLES = ("pinhole_station", "peg_in_hole", "gear_unit")
TARGET_MS = 50.0
"""Target median planning time per pick-and-insert step on pinhole_station, ms."""


@dataclass(frozen=True)
class StepBench:
    """One step: our wall and CPU time (s), the baseline's time (s) and whether it solved."""

    product: str
    index: int
    part: str
    wall_s: float
    cpu_s: float
    direct_s: float
    direct_solved: bool
    direct_reason: str = ""

    @property
    def ratio(self) -> float:
        """Baseline time / our wall time (a lower bound when the baseline failed)."""
        return self.direct_s / self.wall_s if self.wall_s > 0 else float("inf")


@dataclass(frozen=True)
class ProductBench:
    """One product: part geometry time, the time spent outside the final plan's steps
    (sequence planning, better-ranked orders that could not be planned), and the steps."""

    product: str
    geometry_s: float
    other_s: float
    steps: tuple[StepBench, ...]
    sequence_note: str

    @property
    def total_s(self) -> float:
        """Sum of the pick-and-insert steps' planning times (wall), s."""
        return sum(s.wall_s for s in self.steps)

    @property
    def median_ms(self) -> float:
        return 1e3 * statistics.median(s.wall_s for s in self.steps) if self.steps else 0.0

    @property
    def median_cpu_ms(self) -> float:
        return 1e3 * statistics.median(s.cpu_s for s in self.steps) if self.steps else 0.0


class DirectInsertionPlanner(MotionPlanner):
    """The baseline: OMPL from the lifted pose straight into the seated pose (no pre-insertion
    pose and no straight insertion)."""

    seats_directly = True


def _example_path(name: str) -> Path:
    from importlib import resources

    return Path(str(resources.files("asmplan.examples").joinpath(f"{name}.yaml")))


def bench_product(path: str | Path, settings: PlannerSettings | None = None,
                  direct_budget_s: float = 2.0) -> ProductBench:
    """Plan one product, time every step, and run the direct-insertion baseline per step."""
    settings = settings or PlannerSettings()
    product = load_product(path)
    t0 = time.perf_counter()
    geometry = ProductGeometry(product)
    parts = part_data(product, settings, geometry)
    geometry_s = time.perf_counter() - t0
    result = plan_product(product, geometry, settings, parts=parts)
    plan = result.plan
    direct_settings = dataclasses.replace(settings, time_budget_s=direct_budget_s, replan_attempts=0)
    rows = []
    for step, timing in zip(plan.steps, result.step_times, strict=True):
        if step.kind == "fixture":
            continue
        base = DirectInsertionPlanner(product, direct_settings, parts)
        for earlier in plan.steps[: step.index]:
            base.place(earlier.part)
        t = time.perf_counter()
        try:
            base.plan_step(step.index, step.part, step.insertion_direction, step.grasp)
            solved, reason = True, ""
        except PlanningError as exc:
            solved, reason = False, type(exc).__name__
        rows.append(StepBench(product.name, step.index, step.part, timing.total_s,
                              timing.cpu_s, time.perf_counter() - t, solved, reason))
    steps_s = sum(t.total_s for t in result.step_times)
    return ProductBench(product.name, geometry_s, result.total_s - result.geometry_s - steps_s,
                        tuple(rows), plan.sequence_note)


def bench(products: Sequence[str | Path] | None = None, settings: PlannerSettings | None = None,
          direct_budget_s: float = 2.0, stream: TextIO | None = None) -> list[ProductBench]:
    """Benchmark every product (default: the bundled examples) and print a report.

    Parameters
    ----------
    products : sequence of paths or example names, optional
    settings : PlannerSettings, optional
    direct_budget_s : float
        OMPL budget of the direct-insertion baseline per step, s.
    stream : text stream, optional
        Where the report goes (default: standard output).

    Returns
    -------
    list of ProductBench
    """
    out = stream if stream is not None else sys.stdout
    names = list(products) if products else list(EXAMPLES)
    results = []
    for item in names:
        path = Path(item) if str(item).endswith((".yaml", ".yml")) else _example_path(str(item))
        try:
            r = bench_product(path, settings, direct_budget_s)
        except PlanningError as exc:
            out.write(f"\n{path.stem}: planning failed: {exc}\n")
            continue
        results.append(r)
        out.write(f"\n{r.product}: part geometry {r.geometry_s:.2f} s and sequence planning "
                  f"{r.other_s:.2f} s (once per product); order: {r.sequence_note}\n")
        out.write(f"  {'step':<5}{'part':<15}{'plan ms':>9}{'cpu ms':>9}{'direct ms':>11}  "
                  f"{'direct':<14}{'ratio':>8}\n")
        for s in r.steps:
            status = "solved" if s.direct_solved else f"failed ({s.direct_reason})"
            ratio = f"{s.ratio:.1f}" if s.direct_solved else f">={s.ratio:.1f}"
            out.write(f"  {s.index + 1:<5}{s.part:<15}{1e3 * s.wall_s:>9.1f}{1e3 * s.cpu_s:>9.1f}"
                      f"{1e3 * s.direct_s:>11.1f}  {status:<14}{ratio:>8}\n")
        out.write(f"  median {r.median_ms:.1f} ms per step (CPU {r.median_cpu_ms:.1f} ms), "
                  f"total {1e3 * r.total_s:.1f} ms for {len(r.steps)} steps\n")
        if r.product == "pinhole_station":
            verdict = "met" if r.median_ms < TARGET_MS else "NOT met"
            out.write(f"  target: median < {TARGET_MS:.0f} ms per pick-and-insert step: "
                      f"{verdict}\n")
    return results


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m bench.motion [PRODUCT ...]``."""
    args = list(sys.argv[1:] if argv is None else argv)
    bench(args or None)
    return 0


if __name__ == "__main__":
    sys.exit(main())
