"""``asmplan run [PRODUCT] -o OUTDIR``: the main job, from product YAML to a report.

Validate, sequence, plan grasps and paths, simulate every step and write ``plan.json``,
``results.json``, ``sequence.json``, ``summary.json``, ``report.html`` and its images into
OUTDIR (built beside it and swapped in at the end). Exit 0 when every step succeeds, 1 when a
step fails physically or no plan exists (with the reason), 2 on bad input.
"""

from __future__ import annotations

import argparse
import sys
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

from .argtypes import add_jobs_argument, add_pose_error_argument
from .plan import dropped_lines, evidence_lines
from .textout import StageProgress, format_table

if TYPE_CHECKING:  # the pipeline (trimesh, scipy, pybullet) is imported when a run starts
    from ..pipeline import RunResult


def bundled_example(name: str = "pinhole_station") -> Path:
    """Path of a bundled example product (``pinhole_station`` is the seed workstation)."""
    return Path(str(resources.files("asmplan.examples").joinpath(f"{name}.yaml")))


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="the main job: product YAML in, plan, simulation and report out",
                       description="Validate, sequence, plan and simulate a product and write the "
                                   "results and the report to OUTDIR (replaced atomically). Without "
                                   "PRODUCT, runs the bundled seed pin-hole workstation.")
    p.add_argument("product", nargs="?", help="product YAML file (default: the bundled seed "
                                               "pin-hole workstation)")
    p.add_argument("-o", "--out", default="out", help="output folder (default: out)")
    p.add_argument("--fidelity", choices=("fast", "balanced", "accurate"), default="balanced",
                   help="physics fidelity preset (default: balanced)")
    p.add_argument("--seed", type=int, default=0, help="planner seed (default 0)")
    p.add_argument("--no-report", action="store_true", help="skip rendering the report")
    p.add_argument("--no-cull", action="store_true",
                   help="load the whole product into every step's scene (slower; for comparison)")
    add_jobs_argument(p)
    add_pose_error_argument(p)
    p.set_defaults(func=run)


def summary_table(result: RunResult) -> str:
    head = ("step", "part", "kind", "cycle s", "clamp N", "slip lim N", "insert N", "error mm", "result")
    rows: list[tuple[str, ...]] = []
    sims = {s.index: s for s in result.results.steps} if result.results is not None else {}
    for step in result.plan.steps if result.plan is not None else ():
        sim = sims.get(step.index)
        o = sim.outcome if sim is not None else None
        traj = step.trajectory
        cycle = f"{step.cycle_time_s:.2f}" if traj is not None else "-"
        verdict = "-" if o is None else ("ok" if o.success else "FAILED: " + "; ".join(o.reasons))
        if sim is not None and sim.unresolved:
            verdict = (f"NOT RESOLVED at {result.fidelity.name}: "
                       + "; ".join(u.cause for u in sim.unresolved)
                       + " (it saw: " + "; ".join(sim.reasons) + ")")
        if step.kind == "operation":
            verdict = f"placed by {step.operation}: not simulated"
        rows.append((str(step.index + 1), step.part, step.kind, cycle,
                     f"{o.peak_clamp_force_N:.2f}" if o else "-",
                     f"{step.clamp.slip_limit_N:.2f}" if step.clamp else "-",
                     f"{o.peak_insertion_force_N:.2f}" if o else "-",
                     f"{o.final_position_error_m * 1e3:.3f}" if o else "-", verdict))
    table = format_table(head, rows)
    if result.plan is not None and any(s.arm is not None for s in result.plan.steps):
        table += (f"\ncycle time with the arm: {result.plan.cycle_time_s:.2f} s (joint moves "
                  "between steps included)")
    return table


def terminal_warnings(result: RunResult) -> list[str]:
    """The run's warnings once each, the fits the preset cannot resolve grouped into one
    warning that names every mate (with its fit, clearance and step)."""
    from ..report.fits import grouped_fit_warning, unresolved_fits

    rows = unresolved_fits(result.product, result.fidelity) if result.results is not None else []
    names = {r["mate"] for r in rows}
    rest = [w for w in result.warnings if not any(w.startswith(f"mate {m} (") for m in names)]
    order = ({s.part: s.index for s in result.plan.steps} if result.plan is not None else {})
    mate_steps = {m.name: max(order.get(m.pin_part, -1), order.get(m.hole_part, -1))
                  for m in result.product.mates}
    grouped = grouped_fit_warning(rows, result.fidelity.name, mate_steps)
    return [grouped, *rest] if grouped else rest


def run(args: argparse.Namespace) -> int:
    from ..fileio import OutputFolder
    from ..knowledge.loader import load_product
    from ..pipeline import RunSettings, render_while_simulating, run_product, write_outputs
    from ..planner.settings import PlannerSettings
    from ..report.picture_pool import picture_workers
    from ..sim.pose_error import PoseError

    path = Path(args.product) if args.product else bundled_example()
    product = load_product(path, display_name=args.product or "pinhole_station.yaml (bundled)")
    pose_error = None if args.pose_error is None else PoseError.from_cli(*args.pose_error)
    settings = RunSettings(fidelity=args.fidelity, planner=PlannerSettings(seed=args.seed),
                           cull=not args.no_cull, workers=args.jobs, pose_error=pose_error)
    progress = StageProgress(sys.stderr)
    with OutputFolder(args.out) as folder:  # checked and locked before any work
        # the report's pictures are drawn while the run plans and the steps simulate, by
        # picture processes forked now when there are cores for them (else in this one)
        early = (None if args.no_report else
                 render_while_simulating(folder, product, picture_workers(args.jobs)))
        try:
            result = run_product(product, settings, progress=progress, while_simulating=early,
                                 on_step_result=None if early is None else early.step_done)
            write_outputs(result, folder, report=not args.no_report, progress=progress)
        except BaseException:
            if early is not None:
                early.close(now=True)
            raise
        finally:
            if early is not None:
                early.close()
    out = sys.stdout
    if result.plan is not None:
        print(summary_table(result), file=out)
    for line in dropped_lines(result.dropped_orders):
        print(line, file=out)
    for w in terminal_warnings(result):
        print(f"warning: {w}", file=out)
    t = result.timings_s
    times = ", ".join(f"{k} {v:.1f} s" for k, v in t.items())
    if result.failure:
        print(f"{product.name}: no plan: {result.failure}", file=out)
        for line in evidence_lines(result.failure_evidence):
            print(line, file=out)
    elif result.results is not None and not result.results.success:
        failed = ", ".join(f"{s.index + 1} ({s.part})" for s in result.results.failed_steps)
        if failed:
            print(f"{product.name}: step(s) {failed} fail physically at fidelity "
                  f"{result.fidelity.name}", file=out)
        unresolved = result.results.unresolved_steps
        if unresolved:  # neither a success nor a failure (asmplan.sim.resolution)
            names = ", ".join(f"{s.index + 1} ({s.part})" for s in unresolved)
            needs = sorted({u.needs for s in unresolved for u in s.unresolved if u.needs})
            print(f"{product.name}: step(s) {names} not resolved at fidelity "
                  f"{result.fidelity.name}: not a verdict on the product"
                  + (f"; run --fidelity {' or '.join(needs)} to judge them" if needs else ""),
                  file=out)
    else:
        ops = [s for s in result.plan.steps if s.kind == "operation"] if result.plan else []
        also = (f" ({len(ops)} placed by another operation, not simulated: "
                f"{', '.join(f'{s.part} by {s.operation}' for s in ops)})" if ops else "")
        n_sim = sum(s.simulated for s in result.results.steps) if result.results else 0
        print(f"{product.name}: no step is simulated{also}" if ops and not n_sim else
              f"{product.name}: every simulated step succeeds at fidelity "
              f"{result.fidelity.name}{also}" if ops else
              f"{product.name}: every step succeeds at fidelity {result.fidelity.name}", file=out)
    cpu = ", ".join(f"{k} {v:.1f} s" for k, v in result.cpu_s.items())
    if result.while_simulating_cpu_s > 0:  # the report's plan-only pictures
        cpu += f", of it {result.while_simulating_cpu_s:.1f} s while simulating"
    print(f"results and report in {args.out}/ ({times}; CPU {cpu})", file=out)
    return result.exit_code
