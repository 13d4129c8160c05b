"""``asmplan sweep PRODUCT --samples N -o OUTDIR``: how robust is each step to real parts?

Samples the declared fit ranges, the friction spread and the robot's positioning error
(:mod:`asmplan.sim.sweep`, distributions in docs/sweep.md), simulates every step per sample
through a local process pool (all cores) or a Dask cluster (``--scheduler tcp://HOST:PORT``),
and reports per step the success rate with its Wilson 95 % interval, the failure reasons and
which factor drives them, with one plot per step.

OUTDIR holds ``sweep-journal.jsonl`` (every finished sample, fsync'ed: re-running the same
command resumes, a different sweep in the same folder is refused), ``sweep.json`` (spec,
summary and per-sample table) and ``sweep-<part>.png``.

Exit codes: 0 the sweep finished (whatever the success rates), 1 planning failed or some
samples produced no verdict (their task raised or their worker kept dying; listed on stderr),
2 bad input.
"""

from __future__ import annotations

import argparse
import functools
import math
import sys
import time
from pathlib import Path
from typing import Any

from ..fileio import atomic_write_json, claim_work_folder, mark_output_folder
from ..knowledge.errors import InputIssue, ProductError
from ..knowledge.loader import load_product
from .argtypes import nonnegative_float, nonnegative_int, positive_int


def _vary(text: str) -> tuple[str, ...]:
    from ..sim.sweep import FACTORS

    items = tuple(s.strip() for s in text.split(",") if s.strip())
    bad = [s for s in items if s not in FACTORS]
    if bad or not items:
        raise argparse.ArgumentTypeError(
            f"expected a comma-separated subset of {','.join(FACTORS)}, found \"{text}\"")
    twice = sorted({s for s in items if items.count(s) > 1})
    if twice:
        raise argparse.ArgumentTypeError(
            f"expected each factor once, found {', '.join(twice)} more than once in \"{text}\"")
    return items


MAX_SAMPLES = 100_000
"""Largest ``--samples``: every sample is kept in memory and in sweep.json (about 1 kB each)
and simulates every step; a larger study is several sweeps with different ``--seed``."""


def _samples(text: str) -> int:
    n = positive_int(text)
    if n > MAX_SAMPLES:
        raise argparse.ArgumentTypeError(
            f"expected at most {MAX_SAMPLES:,} samples (every sample simulates every step and is "
            f"kept in sweep.json; run several sweeps with different --seed), found {n:,}")
    return n


def register(sub: argparse._SubParsersAction) -> None:
    from ..sim.fidelity import PRESETS
    from ..sim.sweep import FACTORS, SweepSpec

    d = SweepSpec(n_samples=1)
    p = sub.add_parser(
        "sweep", help="success probability of every step under part tolerances and robot error",
        description="Sample the declared fit ranges, the friction spread and the robot's "
                    "positioning error, simulate every step per sample, and report per step "
                    "the success rate with a 95 % confidence interval, the failure reasons "
                    "and which factor drives them (docs/sweep.md). Runs on all local cores, "
                    "or on a Dask cluster with --scheduler. Re-running the same command "
                    "resumes from the journal in OUTDIR.")
    p.add_argument("product", help="product YAML file")
    p.add_argument("--samples", type=_samples, required=True, metavar="N",
                   help=f"number of samples (1 to {MAX_SAMPLES:,})")
    p.add_argument("--vary", type=_vary, default=FACTORS, metavar="F,...",
                   help=f"factors to vary, among {','.join(FACTORS)} (default all)")
    p.add_argument("--seed", type=nonnegative_int, default=0, help="sampling seed (default 0)")
    p.add_argument("-o", "--out", default="sweep", metavar="OUTDIR",
                   help="output folder (default sweep/); holds the journal for resuming")
    p.add_argument("--plan", metavar="PLAN_JSON",
                   help="plan to sweep (from `asmplan plan`; default: plan the product here)")
    p.add_argument("--fidelity", choices=sorted(PRESETS), default="balanced",
                   help="physics preset (default balanced; it must resolve the clearances)")
    p.add_argument("--clearance-dist", choices=("sizes", "uniform", "truncnormal"),
                   default=d.clearance_distribution,
                   help="clearance distribution in each fit range: 'sizes' draws the actual hole and "
                   "shaft sizes from the size model that check's probability of interference "
                   "and press force use (normal in each ISO zone, 6 sigma = zone width); an "
                   "interfering sample is pressed with its own force "
                   f"(default {d.clearance_distribution})")
    p.add_argument("--friction-sigma", type=nonnegative_float, default=d.friction_rel_sigma,
                   metavar="REL", help=f"relative 1-sigma friction spread (default {d.friction_rel_sigma:g})")
    p.add_argument("--pose-lateral", type=nonnegative_float, default=d.pose_lateral_m * 1e3,
                   metavar="MM", help="lateral robot error: sigma per axis (normal) or largest "
                                      f"magnitude (uniform), mm (default {d.pose_lateral_m * 1e3:g})")
    p.add_argument("--pose-angular", type=nonnegative_float,
                   default=math.degrees(d.pose_angular_rad), metavar="DEG",
                   help="tilt error: sigma per axis or largest magnitude, degrees (default "
                        f"{math.degrees(d.pose_angular_rad):g})")
    p.add_argument("--pose-dist", choices=("normal", "uniform"), default=d.pose_distribution,
                   help=f"pose error distribution (default {d.pose_distribution})")
    p.add_argument("--workers", type=positive_int, metavar="N",
                   help="local worker processes (default: all cores)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run on this Dask scheduler instead of locally (extra asmplan[dask])")
    p.add_argument("--retries", type=nonnegative_int, default=2,
                   help="re-runs of a sample whose worker died (default 2)")
    p.add_argument("--redo-failed", action="store_true",
                   help="on resume, run again the samples that produced no verdict")
    p.set_defaults(func=run)


def _issue(path: str, message: str) -> ProductError:
    return ProductError([InputIssue(path, 0, 0, "", message)])


def _capture_m(product: Any, plan: Any, k: int) -> float | None:
    """Largest lateral error the step's mates should absorb: mean radial clearance plus the
    hole's chamfer width (the smallest over the step's mates), m."""
    out = []
    for name in plan.steps[k].mates:
        m = next((m for m in product.mates if m.name == name), None)
        if m is None:
            continue
        hole = product.feature(m.hole_part, m.hole_feature)
        out.append(0.5 * m.clearance_mean_m + hole.chamfer_m)
    return min(out) if out else None


# Complexity above C (radon): the command's sequence (spec, plan, journal, run, summary, report,
# printout) in one place.
def run(args: argparse.Namespace) -> int:
    from ..sim import sweep as sw
    from ..sim.fidelity import preset

    product = load_product(args.product)
    claim_work_folder(args.out, [sw.JOURNAL_NAME])  # before any work: only a folder of ours
    spec = sw.SweepSpec(
        n_samples=args.samples, seed=args.seed, vary=args.vary,
        clearance_distribution=args.clearance_dist, friction_rel_sigma=args.friction_sigma,
        pose_lateral_m=args.pose_lateral * 1e-3, pose_angular_rad=math.radians(args.pose_angular),
        pose_distribution=args.pose_dist)
    if args.plan:
        from .simulate import read_plan

        plan = read_plan(args.plan)
        if plan.product != product.name or sorted(plan.sequence) != sorted(product.part_names):
            raise _issue(args.plan, f"expected a plan for product {product.name!r} "
                                    f"({', '.join(product.part_names)}), found one for "
                                    f"{plan.product!r} ({', '.join(plan.sequence)})")
    else:
        from ..parts.models import ProductGeometry
        from ..planner.errors import PlanningError
        from ..planner.product import plan_product

        try:
            plan = plan_product(product, ProductGeometry(product)).plan
        except PlanningError as exc:
            print(f"asmplan sweep: planning failed: {exc}", file=sys.stderr)
            return 1
    fidelity = preset(args.fidelity)
    ps = sw.PlanSweep(product, plan, fidelity)
    if not ps.steps:
        print(f"asmplan sweep: {product.name}: no step moves a part; nothing to sweep",
              file=sys.stderr)
        return 0
    samples = ps.samples(spec)
    out = Path(args.out)
    header = sw.journal_header(spec, ps.fingerprint(), steps=list(ps.step_names))
    t0 = time.perf_counter()
    shown = {"t": t0, "done": 0}

    def progress(done: int, total: int, r: Any) -> None:
        now = time.perf_counter()
        if done == total or now - shown["t"] >= 5.0:
            rate = (done - shown["done"]) / max(now - shown["t"], 1e-9)
            print(f"sweep: {done}/{total} samples ({rate:.2f}/s)", file=sys.stderr, flush=True)
            shown.update(t=now, done=done)

    conn = None
    if args.scheduler:
        try:
            conn = sw.connect_dask(args.scheduler)
        except sw.DaskUnavailableError as exc:
            raise _issue("--scheduler", str(exc)) from None
        except OSError as exc:
            raise _issue("--scheduler", f"cannot reach the Dask scheduler {args.scheduler}: "
                                        f"{exc}") from None
    try:
        with sw.SweepJournal(out / sw.JOURNAL_NAME, header) as journal:
            if journal.finished:
                print(f"sweep: resuming, {len(journal.finished)} samples already in "
                      f"{journal.path}", file=sys.stderr)
            results = sw.run_sweep(functools.partial(sw.simulate_sample, ps), samples,
                                   executor=None if conn is None else conn.executor,
                                   journal=journal, retries=args.retries,
                                   max_workers=args.workers, redo_failed=args.redo_failed,
                                   progress=progress)
    except sw.JournalMismatchError as exc:
        raise _issue(str(exc.path), str(exc).split(": ", 1)[1]) from None
    except (sw.JournalLockedError, sw.JournalCorruptError) as exc:
        raise _issue(args.out, str(exc)) from None
    finally:
        if conn is not None:
            conn.close()
    wall = time.perf_counter() - t0
    # only factors that touch a step's scene are tested for it; a driver is named after a
    # Benjamini-Hochberg correction and a minimum sample size (sim/sweep/statistics.py)
    relevant = ps.scene_factors()
    summary = sw.summarize(samples, results, spec.vary, scene_factors=relevant,
                           step_numbers=ps.step_numbers)
    table = []
    for s, r in zip(samples, results, strict=True):
        row: dict[str, Any] = {"index": s.index, "ok": r.ok, "error": r.error, "steps": {}}
        for name in ps.step_names:
            v = r.value["steps"].get(name, {}) if r.ok else {}
            row["steps"][name] = {"success": v.get("success"),
                                  "failed_criteria": v.get("failed_criteria", []),
                                  "factors": {f: v for f, v in s.factors(name, spec.vary).items()
                                              if f in relevant[name]}}
        table.append(row)
    captures = {plan.steps[k].part: _capture_m(product, plan, k) for k in ps.steps}
    atomic_write_json(out / "sweep.json", {
        "format": "asmplan-sweep", "version": 1, "product": product.name,
        "spec": spec.to_dict(), "fidelity": fidelity.name, "fingerprint": header["fingerprint"],
        "capture_m": captures, "summary": summary.to_dict(), "samples": table})
    # the report (jinja2, matplotlib) only here
    from ..report.sweep import (
        driver_text,
        error_text,
        failure_text,
        no_driver_text,
        resolution_warnings,
        write_sweep_report,
    )

    warnings = resolution_warnings(product, fidelity, samples,
                                   {plan.steps[k].part: plan.steps[k].mates for k in ps.steps},
                                   ps.step_numbers)
    write_sweep_report(out, product, summary, spec.to_dict(), fidelity.name, captures,
                       n_samples=len(samples), warnings=warnings)
    mark_output_folder(out)

    print(f"{product.name}: {len(samples)} samples x {len(ps.steps)} steps at fidelity "
          f"{fidelity.name}, varying {', '.join(spec.vary) or 'nothing'} "
          f"({wall:.1f} s this run)")
    for w in warnings:
        print(f"warning: {w}")
    for st in summary.steps:
        print(f"{st.label}: success {st.successes}/{st.n} = {100 * st.rate:.1f} % "
              f"(95 % CI {100 * st.ci_low:.1f}-{100 * st.ci_high:.1f} %)")
        if st.driver is not None:
            print(f"  driven by {driver_text(st)}")
        elif st.n - st.successes:
            print(f"  no factor named as driving: {no_driver_text(st, summary.drivers)}")
        for f in st.failures[:5]:
            print(f"  {f.count:>5} x {failure_text(f)}")
    print(f"results in {out}/ (sweep.json, sweep-report.html, sweep-<step>.png; journal "
          f"{sw.JOURNAL_NAME})")
    if summary.n_errors:
        print(f"asmplan sweep: {summary.n_errors} of {len(samples)} samples produced no "
              "verdict (left out of the rates):", file=sys.stderr)
        for code, count in summary.errors:
            print(f"  {count} x {error_text(code)}", file=sys.stderr)
        return 1
    return 0
