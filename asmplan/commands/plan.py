"""``asmplan plan PRODUCT -o plan.json``: grasps, collision-free paths and timed trajectories.

The part order is the sequence planner's best unless ``--sequence`` gives one. Exit codes: 0 a
plan was written, 1 planning failed (the reason and its evidence on stderr, no file written),
2 bad input.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any, TextIO

from ..fileio import check_output_file
from ..knowledge.loader import load_product
from ..planner.errors import PlanningError
from ..planner.ompl_backend import PLANNERS
from ..planner.plan import PLAN_FORMAT, Plan
from ..planner.settings import PlannerSettings
from .argtypes import nonnegative_int, positive_float
from .textout import StageProgress, format_table


def register(sub: argparse._SubParsersAction) -> None:
    d = PlannerSettings()
    p = sub.add_parser(
        "plan", help="plan grasps, collision-free paths and trajectories for every step",
        description="Plan every assembly step: an antipodal grasp, a lift, an OMPL path to a "
                    "pre-insertion pose on the mate axis, a straight insertion, all proven "
                    "collision-free with FCL, and a timed trajectory with the clamp force. "
                    "Writes the plan as JSON (docs/plan-format.md). Exit 1 with the reason and "
                    "evidence when a step cannot be planned, 2 on bad input.")
    p.add_argument("product", help="product YAML file")
    p.add_argument("-o", "--output", default="plan.json",
                   help="plan file to write (default plan.json; replaced atomically)")
    p.add_argument("--sequence", metavar="A,B,...",
                   help="part order to plan (default: the sequence planner's best)")
    p.add_argument("--seed", type=nonnegative_int, default=d.seed, help=f"random seed (default {d.seed})")
    p.add_argument("--planner", choices=sorted(PLANNERS), default=d.planner,
                   help=f"OMPL planner (default {d.planner})")
    p.add_argument("--time-budget", type=positive_float, default=d.time_budget_s,
                   metavar="SECONDS",
                   help=f"OMPL search budget per query (default {d.time_budget_s:g} s)")
    p.add_argument("--level", choices=("convex", "exact"), default=d.collision_level,
                   help=f"collision model level used for planning (default {d.collision_level})")
    p.set_defaults(func=run)


class PlanProgress:
    """The plan stage's progress bar, saying when the planner gives an order up and plans
    the next-ranked one (it restarts from the first step; why is printed at the end)."""

    def __init__(self, progress: StageProgress, stream: TextIO) -> None:
        self.progress = progress
        self.stream = stream
        self.last_k = -1
        self.order = 1

    def __call__(self, k: int, n: int, part: str, status: str) -> None:
        if status == "start" and k < self.last_k:  # the planner moved on to the next order
            self.order += 1
            if self.progress.tty:
                self.stream.write("\n")
            self.stream.write(f"order {self.order - 1} could not be planned (why: below); "
                              f"planning the order ranked {self.order}\n")
        self.last_k = k
        if status == "done":
            self.progress("plan", k + 1, n, part)


def dropped_lines(dropped: Any) -> list[str]:
    """Why each better-ranked order could not be planned (one line per order)."""
    return [f"order {k} ({' -> '.join(d['order'])}) could not be planned: {d['failure']}"
            for k, d in enumerate(dropped, start=1)]


def evidence_lines(evidence: dict[str, Any]) -> list[str]:
    """Printable lines of a planning failure's evidence (contacts, reasons, alternatives, path)."""
    lines = []
    for p in evidence.get("pairs") or []:
        depth = "" if p.get("depth_m") is None else f" depth {p['depth_m'] * 1e3:.3f} mm"
        point = "" if p.get("point_m") is None else \
            " at [" + ", ".join(f"{1e3 * c:.1f}" for c in p["point_m"]) + "] mm"
        lines.append(f"  contact: {p['a']} / {p['b']}{depth}{point}")
    for r in evidence.get("reasons") or []:
        lines.append(f"  - {r}")
    for alt in evidence.get("alternatives") or []:
        lines.append(f"  also tried {' > '.join(alt['order'])}: {alt['failure']}")
    path = evidence.get("partial_path_T_world_gripper")
    if path:
        last = path[-1]
        lines.append(f"  partial path: {len(path)} pose(s), last gripper position "
                     f"[{1e3 * last[0][3]:.1f}, {1e3 * last[1][3]:.1f}, {1e3 * last[2][3]:.1f}] mm")
    return lines


def summary_table(plan: Plan, step_ms: list[float]) -> str:
    """A plain-text table: one row per step."""
    head = ("step", "part", "kind", "grasp", "width mm", "force N", "move s", "plan ms")
    rows = []
    for s, ms in zip(plan.steps, step_ms, strict=True):
        if s.grasp is None or s.trajectory is None or s.clamp is None:
            rows.append((str(s.index + 1), s.part, s.kind, "-", "-", "-", "-", f"{ms:.1f}"))
            continue
        rows.append((str(s.index + 1), s.part, s.kind, s.grasp.source,
                     f"{s.grasp.width_m * 1e3:.1f}", f"{s.clamp.commanded_N:.2f}",
                     f"{s.trajectory.duration_s:.2f}", f"{ms:.1f}"))
    return format_table(head, rows)


# Complexity above C (radon): a CLI command; each branch is one option (--sequence) or one
# outcome it prints (planning failure with evidence, arm, dropped steps, start notes).
def run(args: argparse.Namespace) -> int:
    from ..parts.models import ProductGeometry
    from ..planner.fcl_oracle import FclOracle
    from ..planner.product import plan_product, ranked_sequences
    from ..planner.sequence import NoFeasibleSequenceError, plan_sequence

    product = load_product(args.product)
    check_output_file(args.output, json_format=PLAN_FORMAT)  # before any work
    geometry = ProductGeometry(product)
    settings = PlannerSettings(planner=args.planner, time_budget_s=args.time_budget,
                               seed=args.seed, collision_level=args.level)
    choices = None
    order = None
    note = ""
    if args.sequence:
        order = [s.strip() for s in args.sequence.split(",") if s.strip()]
        unknown = [s for s in order if s not in product.part_names]
        if unknown or sorted(order) != sorted(product.part_names):
            print(f"asmplan plan: --sequence: expected every part of {product.name} once "
                  f"({', '.join(product.part_names)}), found {', '.join(order) or 'nothing'}",
                  file=sys.stderr)
            return 2
        note = "given on the command line"
    else:
        try:
            choices = ranked_sequences(plan_sequence(product, FclOracle(product, geometry)))
        except NoFeasibleSequenceError as exc:
            print(f"asmplan plan: no feasible sequence: {exc}", file=sys.stderr)
            return 1
    progress = StageProgress(sys.stderr)
    on_step = PlanProgress(progress, sys.stderr)
    try:
        result = plan_product(product, geometry, settings, sequence=order, sequence_note=note,
                              sequences=choices, progress=on_step)
    except PlanningError as exc:
        if progress.tty:
            sys.stderr.write("\n")
        print(f"asmplan plan: planning failed: {exc}", file=sys.stderr)
        for line in evidence_lines(exc.evidence()):
            print(line, file=sys.stderr)
        return 1
    result.plan.write(args.output)
    ms = [t.total_s * 1e3 for t in result.step_times]
    print(f"{product.name}: {len(result.plan.steps)} steps planned in {result.total_s:.2f} s "
          f"(part geometry {result.geometry_s:.2f} s; order: {result.plan.sequence_note}); "
          f"plan written to {args.output}")
    print(summary_table(result.plan, ms))
    robot = product.resources.robot
    if robot is not None and any(s.arm is not None for s in result.plan.steps):
        print(f"cycle time with the arm ({robot.model}): "
              f"{result.plan.cycle_time_s:.2f} s; per step: " + ", ".join(
                  f"{s.part} {s.cycle_time_s:.2f} s" for s in result.plan.steps
                  if s.trajectory is not None))
    for line in dropped_lines(result.dropped):
        print(line)
    for s in result.plan.steps:
        for n in (s.start_note, *s.notes):
            if n and ("raised" in n or "no start pose" in n or "hint" in n
                      or "joint space" in n):
                print(f"note: {s.part}: {n}")
    return 0
