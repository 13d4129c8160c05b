"""``asmplan simulate plan.json --fidelity balanced -o results.json``: prove a plan in PyBullet.

Every step that moves a part is simulated in a scene holding only the bodies it needs, with a
force-controlled gripper following the planned trajectory and clamp force; each step is judged
against the product's process limits. The product is loaded from the plan's ``source``.
Writes ``results.json`` (docs/results-format.md, bit-identical for the same plan and preset)
and the wall-clock times beside it (``<output stem>.timing.json``).

Exit codes: 0 every step succeeded, 1 a step failed physically (which criterion, with its
numbers, on stderr), 2 bad input (e.g. a file that is not a plan).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

from ..fileio import atomic_write_json, check_output_file
from ..knowledge.errors import InputIssue, ProductError
from ..knowledge.loader import load_product
from ..planner.plan import Plan
from .argtypes import add_jobs_argument, add_pose_error_argument


def register(sub: argparse._SubParsersAction) -> None:
    from ..sim.fidelity import PRESETS

    p = sub.add_parser(
        "simulate", help="simulate a plan step by step in PyBullet and judge every step",
        description="Simulate every step of a plan (from `asmplan plan`) in a headless PyBullet "
                    "world that holds only the bodies the step needs, with a force-controlled "
                    "parallel gripper following the planned trajectory and clamp force. Each "
                    "step is judged: final pose within the position tolerance, slip below the "
                    "limit, no drop, insertion force within the limit. Exit 1 when a step "
                    "fails (the criterion and its numbers on stderr), 2 on bad input.")
    p.add_argument("plan", help="plan JSON file written by `asmplan plan`")
    p.add_argument("--fidelity", choices=sorted(PRESETS), default="balanced",
                   help="physics preset (default balanced; see docs/physics.md)")
    p.add_argument("-o", "--output", default="results.json",
                   help="results file to write (default results.json; replaced atomically)")
    p.add_argument("--timing", metavar="PATH",
                   help="wall-clock times file (default: <output stem>.timing.json)")
    p.add_argument("--no-cull", action="store_true",
                   help="keep every part in every step's scene (slower; for comparison)")
    add_jobs_argument(p)
    add_pose_error_argument(p)
    p.set_defaults(func=run)


def _plan_issue(path: str, message: str, line: int = 0, column: int = 0) -> ProductError:
    return ProductError([InputIssue(path, line, column, "", message)])


def read_plan(path: str) -> Plan:
    """Read a plan file; anything that is not a plan raises ProductError naming the file."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise _plan_issue(path, "plan file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise _plan_issue(path, f"cannot read the plan file: {exc}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise _plan_issue(path, f"expected a JSON plan written by `asmplan plan`, found invalid "
                                f"JSON: {exc.msg}", exc.lineno, exc.colno) from None
    if not isinstance(data, dict):
        raise _plan_issue(path, f"expected a JSON object (a plan), found {type(data).__name__}")
    try:
        return Plan.from_dict(data)
    except (ValueError, KeyError, TypeError) as exc:
        what = f"missing key {exc}" if isinstance(exc, KeyError) else str(exc)
        raise _plan_issue(path, f"not a valid asmplan plan: {what}") from None


def product_path(plan: Plan, plan_file: str) -> Path:
    """The plan's product file: as written, else relative to the plan file's folder."""
    given = Path(plan.source)
    candidates = [given] if given.is_absolute() else [given, Path(plan_file).parent / given]
    for c in candidates:
        if c.is_file():
            return c
    raise _plan_issue(plan_file, f'the plan\'s product file "{plan.source}" was not found '
                                 f"(looked at {', '.join(str(c) for c in candidates)})")


def run(args: argparse.Namespace) -> int:
    plan = read_plan(args.plan)
    src = product_path(plan, args.plan)
    product = load_product(src, display_name=str(src))
    out = Path(args.output)
    timing_path = Path(args.timing) if args.timing else out.with_name(f"{out.stem}.timing.json")
    from ..sim.results import RESULTS_FORMAT

    check_output_file(out, json_format=RESULTS_FORMAT)  # before any work
    check_output_file(timing_path)
    if plan.source_sha256:
        digest = hashlib.sha256(src.read_bytes()).hexdigest()
        if digest != plan.source_sha256:
            print(f"asmplan simulate: warning: {src} changed since the plan was made "
                  "(SHA-256 differs); simulating the plan against the current file",
                  file=sys.stderr)
    from ..parts.models import ProductGeometry
    from ..sim.fidelity import preset
    from ..sim.pose_error import PoseError
    from ..sim.scene import PlanProductMismatchError
    from ..sim.simulate import simulate_plan

    fidelity = preset(args.fidelity)
    from ..report.fits import grouped_fit_warning, unresolved_fits

    order = {s.part: s.index for s in plan.steps}
    grouped = grouped_fit_warning(  # before simulating: how to read the rest, one warning
        unresolved_fits(product, fidelity), fidelity.name,
        {m.name: max(order.get(m.pin_part, -1), order.get(m.hole_part, -1))
         for m in product.mates})
    if grouped:
        print(f"warning: {grouped}", file=sys.stderr)

    def progress(k: int, n: int, part: str, status: str) -> None:
        if status == "start":
            print(f"simulating step {k + 1}/{n}: {part} ...", file=sys.stderr, flush=True)
        elif args.jobs != 1:
            print(f"simulated step {k + 1}/{n}: {part}", file=sys.stderr, flush=True)

    try:
        pose_error = (None if args.pose_error is None
                      else PoseError.from_cli(*args.pose_error))
        results = simulate_plan(plan, product, ProductGeometry(product), fidelity=fidelity,
                                cull=not args.no_cull, progress=progress, workers=args.jobs,
                                pose_error=pose_error)
    except PlanProductMismatchError as exc:
        raise _plan_issue(args.plan, f"the plan does not match its product file {src}: "
                                     f"{exc}") from None
    results.write(out)
    atomic_write_json(timing_path, results.timing())

    n_sim = sum(s.simulated for s in results.steps)
    for s in results.steps:
        if not s.simulated:
            print(f"step {s.index + 1} {s.part}: "
                  + (s.warnings[0] if s.kind == "operation" and s.warnings
                     else f"{s.kind}, not simulated"))
            continue
        o = s.outcome
        assert o is not None
        word = {"success": "ok", "failed": "FAILED", "unresolved": "NOT RESOLVED"}[s.verdict]
        line = (f"step {s.index + 1} {s.part}: {word} "
                f"(final position error {o.final_position_error_m * 1e3:.3f} mm, slip "
                f"{o.max_slip_m * 1e3:.3f} mm, peak insertion force "
                f"{o.peak_insertion_force_N:.2f} N, {s.wall_time_s:.1f} s)")
        print(line)
        for w in s.warnings:
            if "below this fidelity's smallest resolvable clearance" not in w:  # named above
                print(f"  warning: {w}", file=sys.stderr)
        for u in s.unresolved:
            print(f"asmplan simulate: step {s.index + 1} ({s.part}) {u.message}",
                  file=sys.stderr)
        if not s.success:
            print(f"asmplan simulate: step {s.index + 1} ({s.part}) "
                  f"{'saw' if s.unresolved else 'failed'}: "
                  f"{', '.join(s.failed_criteria)}", file=sys.stderr)
            for r in s.reasons:
                print(f"  - {r}", file=sys.stderr)
    n_unres = len(results.unresolved_steps)
    verdict = "all steps succeeded" if results.success else (
        f"{len(results.failed_steps)} of {n_sim} simulated steps failed"
        + (f", {n_unres} not resolved at this fidelity" if n_unres else ""))
    print(f"{product.name}: {n_sim} steps simulated at fidelity {fidelity.name}: {verdict}; "
          f"results written to {out} (times in {timing_path})")
    return 0 if results.success else 1
