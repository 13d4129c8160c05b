"""Text tables of the sections of ``asmplan bench`` (one per section, Markdown) and the
accuracy-vs-cost plot."""

from __future__ import annotations

import io
import statistics
from collections.abc import Sequence
from typing import Any

from .accuracy import AccuracyResult, PeerRow, _scenario_name
from .bounds import BOUNDS, AccuracyFigure, Bound, _fmt
from .cost import (
    SEED_JOB_TARGET_S,
    STAGES,
    CullingResult,
    PlanningResult,
    ReadTiming,
    ScalingRow,
    SeedRunTiming,
    SweepResult,
    scaling_growth,
)


def format_arm(rows: Sequence[Any]) -> str:
    """Markdown table of :func:`run_arm`."""
    from .arm import format_arm as fmt

    return fmt(rows)


def _seed_stage_rows(t: SeedRunTiming) -> list[str]:
    """Per-stage wall and CPU medians of the BALANCED job with the report (as the CLI prints
    them; the simulation workers' CPU counts in "simulate")."""
    if not t.report_stages_s:
        return []
    out = ["| stage (BALANCED job with the report) | wall, median | CPU, median |",
           "| --- | ---: | ---: |"]
    for k, v in t.report_stages_s.items():
        cpu = t.report_stages_cpu_s.get(k, ())
        out.append(f"| {k} | {statistics.median(v):.2f} s | "
                   + (f"{statistics.median(cpu):.2f} s |" if cpu else "- |"))
    return [*out, "", "Wall of the stages excludes starting Python and the imports; sequence, "
                  "plan and simulate overlap (each step is simulated as soon as it is planned), "
                  "so simulate's wall is what remains after planning. CPU: the main process's "
                  "plus the simulation workers' (counted in simulate).", ""]


def _seed_target_line(t: SeedRunTiming) -> str:
    """The BALANCED job with the report against the issues' target: its median wall time and
    the wall time its median CPU needs at best on 2 cores (CPU / 2, no other load)."""
    wall = statistics.median(t.report_cli_s)
    cpu = statistics.median(t.report_cpu_s)
    floor = cpu / 2.0
    met = wall <= SEED_JOB_TARGET_S
    return (f"Target <= {SEED_JOB_TARGET_S:g} s on 2 cores: **{'met' if met else 'not met'}**: "
            f"median wall {wall:.2f} s; median CPU {cpu:.2f} s, i.e. at least {floor:.2f} s of "
            f"wall on 2 otherwise idle cores ({floor / SEED_JOB_TARGET_S:.1f}x the target).")


def format_seed_timing(t: SeedRunTiming) -> str:
    """Markdown: medians and ranges of the seed workstation timings."""
    def row(name: str, v: Sequence[float]) -> str:
        return f"| {name} | {statistics.median(v):.2f} s | {min(v):.2f}-{max(v):.2f} s |"

    lines = ["| seed workstation, FAST, no report | median | range |", "| --- | ---: | ---: |",
             row("`asmplan run --fidelity fast --no-report` (new process)", t.cli_s),
             row("new process importing the pipeline only", t.imports_s),
             row("`run_product` + `write_outputs(report=False)` in a running Python", t.library_s), ""]
    stages = ", ".join(f"{k} {v:.2f} s" for k, v in t.stages_s.items() if k != "report")
    lines.append(f"{t.runs} runs each, interleaved. Stages of the last library run: {stages}. "
                 + ("Every run succeeded." if t.success else f"NOT every run succeeded: {t.failure}"))
    if t.report_runs:
        lines += ["", "| seed workstation, BALANCED, with the report (target <= 5 s, 2 cores) | "
                      "median | range |", "| --- | ---: | ---: |",
                  row("`asmplan run --fidelity balanced` (new process), wall", t.report_cli_s),
                  row("the same, CPU of the process and its workers", t.report_cpu_s),
                  row("its report stage, wall (as the CLI prints it)", t.report_stage_s), "",
                  *_seed_stage_rows(t), _seed_target_line(t), "",
                  f"{t.report_runs} runs, after the FAST runs. The machine is shared: wall time "
                  "rises with other load, CPU time much less."]
    return "\n".join(lines) + "\n"


_FIGURE_LABEL = {
    "seed_force_mae_N": "clamp-force MAE (hold..lower)",
    "slip_threshold_error": "min. holding force vs m(g+a)/(2mu)",
    "insertion_outcome_mismatch": "outcome differs from reference",
    "insertion_depth_error_m": "entered depth - reference",
    "fit_penetration_m": "max. contact penetration",
}


def format_accuracy(acc: AccuracyResult, bounds: Sequence[Bound] | None = None) -> str:
    """Markdown: one row per figure with its bound and wall time."""
    table = {(b.figure, b.preset): b for b in (BOUNDS if bounds is None else bounds)}
    lines = ["| preset | scenario | figure | value | bound | checked | wall (s) | note |",
             "| --- | --- | --- | ---: | ---: | --- | ---: | --- |"]
    for f in acc.figures:
        b = table.get((f.figure, f.preset))
        is_outcome = f.figure == "insertion_outcome_mismatch"
        value = ("yes" if f.value else "no") if is_outcome else _fmt(f.value, f.unit)
        bound = "-" if b is None else ("must match" if f.figure == "insertion_outcome_mismatch"
                                       else f"<= {_fmt(b.limit, b.unit).lstrip('+')}")
        unasserted = ("no (below resolution)" if "resolution" in f.note
                      or f.figure.startswith("insertion") or f.figure == "fit_penetration_m"
                      else "no (reported)")
        checked = unasserted if not f.asserted else (
            "FAIL" if b is not None and not abs(f.value) <= b.limit else "ok")
        lines.append(f"| {f.preset} | {f.scenario} | {_FIGURE_LABEL.get(f.figure, f.figure)} | {value} | "
                     f"{bound} | {checked} | {f.wall_s:.2f} | {f.note} |")
    ref = ", ".join(f"{_scenario_name(r.radial_clearance_m)}: {'inserted' if r.success else 'not inserted'}, "
                    f"{r.entered_depth_m * 1e3:.3f} mm, {r.wall_s:.1f} s" for r in acc.reference)
    lines.append("")
    lines.append(f"Reference (ACCURATE at dt = 1/{round(1 / acc.reference_dt_s)} s): {ref}.")
    if acc.convergence_m is not None:
        lines.append(f"Reference convergence: entered depth changes by at most "
                     f"{acc.convergence_m * 1e6:.2f} um between dt = 1/{round(0.5 / acc.reference_dt_s)} s "
                     f"and 1/{round(1 / acc.reference_dt_s)} s.")
    return "\n".join(lines) + "\n"


def format_accuracy_summary(acc: AccuracyResult) -> str:
    """Markdown: one row per preset with the headline figures and the cost."""
    lines = ["| preset | clamp-force MAE (N) | worst slip threshold error (a = 0 / 5 / 20 m/s^2) "
             "| worst depth error, resolved (mm) "
             "| worst fit penetration (mm) | wall: seed cycle / pin insertion (s) |",
             "| --- | ---: | ---: | ---: | ---: | ---: |"]
    for p in dict.fromkeys(f.preset for f in acc.figures):
        fs = [f for f in acc.figures if f.preset == p]

        def one(name: str, fs: list[AccuracyFigure] = fs) -> AccuracyFigure:
            return next(f for f in fs if f.figure == name)

        depth = [abs(f.value) for f in fs if f.figure == "insertion_depth_error_m" and f.asserted]
        pen = [f.value for f in fs if f.figure == "fit_penetration_m" and f.asserted]
        ins = [f.wall_s for f in fs if f.figure == "insertion_depth_error_m"]
        slip = max((f.value for f in fs if f.figure == "slip_threshold_error"), key=abs,
                   default=float("nan"))
        lines.append(f"| {p} | {one('seed_force_mae_N').value:.5f} | "
                     f"{slip * 100:+.2f} % | "
                     f"{max(depth, default=float('nan')) * 1e3:.3f} | "
                     f"{max(pen, default=float('nan')) * 1e3:.3f} | "
                     f"{one('seed_force_mae_N').wall_s:.2f} / {statistics.median(ins):.2f} |")
    return "\n".join(lines) + "\n"


def format_planning(res: PlanningResult) -> str:
    """Markdown: per product, median step time, the baseline and the ratio."""
    lines = ["| product | steps | median plan ms/step | median CPU ms/step | median direct-OMPL ms/step "
             "| direct solved | median ratio (direct / ours) |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in res.products:
        if not r.steps:
            continue
        ratios = [s.ratio for s in r.steps]
        solved = sum(s.direct_solved for s in r.steps)
        lo = "" if solved == len(r.steps) else ">="
        lines.append(f"| {r.product} | {len(r.steps)} | {r.median_ms:.1f} | {r.median_cpu_ms:.1f} | "
                     f"{1e3 * statistics.median(s.direct_s for s in r.steps):.1f} | "
                     f"{solved}/{len(r.steps)} | "
                     f"{lo}{statistics.median(ratios):.1f} |")
    return "\n".join(lines) + "\n"


def format_scaling(rows: Sequence[ScalingRow]) -> str:
    """Markdown: stage times per size, outcome, and growth exponents."""
    lines = ["| parts | " + " | ".join(f"{s} (s)" for s in STAGES) + " | total (s) | steps | outcome |",
             "| ---: | " + " | ".join("---:" for _ in STAGES) + " | ---: | ---: | --- |"]
    for r in rows:
        cells = [f"{r.timings_s[s]:.2f}" if s in r.timings_s else "-" for s in STAGES]
        total = f"{sum(r.timings_s.values()):.2f}" if r.timings_s else "-"
        if r.success:
            outcome = "all steps succeeded"
        elif r.planned:
            outcome = f"{r.failed_steps} step(s) failed in simulation"
        else:
            outcome = "not planned: " + (r.failure.splitlines()[0][:160] if r.failure else "?")
        lines.append(f"| {r.n_parts} | " + " | ".join(cells) + f" | {total} | {r.steps} | "
                     f"{outcome.replace('|', '/')} |")
    growth = scaling_growth(rows)
    lines.append("")
    lines.append("Growth exponent k (time ~ n^k) between consecutive sizes:")
    lines.append("")
    pairs = sorted({(a, b) for v in growth.values() for a, b, _ in v})
    if pairs:
        lines.append("| stage | " + " | ".join(f"{a} -> {b}" for a, b in pairs) + " |")
        lines.append("| --- | " + " | ".join("---:" for _ in pairs) + " |")
        for stage, pts in growth.items():
            d = {(a, b): k for a, b, k in pts}
            lines.append(f"| {stage} | " + " | ".join(f"{d[p]:.2f}" if p in d else "-" for p in pairs) + " |")
    else:
        lines.append("(fewer than two sizes measured)")
    return "\n".join(lines) + "\n"


def format_culling(results: Sequence[CullingResult]) -> str:
    """Markdown: culled vs whole-product simulation time and whether outcomes agree."""
    lines = ["| product | parts | simulated steps | culled (s) | whole product (s) | ratio whole / culled "
             "| identical outcomes |",
             "| --- | ---: | ---: | ---: | ---: | ---: | --- |"]
    notes = []
    for c in results:
        if c.failure:
            lines.append(f"| {c.product} | {c.n_parts} | - | - | - | - | not measured: no plan |")
            notes.append(f"- {c.product}: {c.failure.splitlines()[0][:200]}")
            continue
        lines.append(f"| {c.product} | {c.n_parts} | {c.steps} | {c.culled_s:.2f} | {c.whole_s:.2f} | "
                     f"{c.ratio:.2f} | {'yes' if c.identical else 'NO'} |")
        notes += [f"- {c.product}: {d}" for d in c.differences]
    return "\n".join(lines) + "\n" + ("\n" + "\n".join(notes) + "\n" if notes else "")


def format_sweep(s: SweepResult) -> str:
    """Markdown: :func:`asmplan.sim.sweep.format_throughput` of the sweep."""
    from .throughput import format_throughput

    if s.failure:
        return f"Not measured: {s.failure.splitlines()[0][:200]}\n"
    return (f"One task = one sample of `{s.product}` (every step simulated at {s.fidelity.upper()}, "
            f"product geometry rebuilt per sample); {s.n_tasks} tasks per executor.\n\n"
            + format_throughput(s.rows))


def accuracy_plot_png(acc: AccuracyResult) -> bytes:
    """PNG bytes: accuracy vs wall time, one panel per figure, one point per preset/scenario."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    names = ["seed_force_mae_N", "slip_threshold_error", "insertion_depth_error_m", "fit_penetration_m"]
    scale = {"seed_force_mae_N": (1.0, "N"), "slip_threshold_error": (100.0, "%"),
             "insertion_depth_error_m": (1e3, "mm"), "fit_penetration_m": (1e3, "mm")}
    colours = {"fast": "tab:red", "balanced": "tab:blue", "accurate": "tab:green"}
    fig = Figure(figsize=(10, 7))
    axes = fig.subplots(2, 2)
    for ax, name in zip(axes.ravel(), names, strict=True):
        k, unit = scale[name]
        for f in acc.figures:
            if f.figure != name:
                continue
            y = max(abs(f.value) * k, 1e-6 * k if unit != "%" else 1e-3)
            ax.scatter(f.wall_s, y, color=colours.get(f.preset, "k"),
                       marker="o" if f.asserted else "x", label=f.preset)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel(f"|error| ({unit})")
        ax.set_title(_FIGURE_LABEL[name], fontsize=10)
        handles, labels = ax.get_legend_handles_labels()
        uniq = dict(zip(labels, handles, strict=True))
        ax.legend(uniq.values(), uniq.keys(), fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("Accuracy vs cost per preset (x: below the preset's resolution, not asserted; "
                 "errors below 1 um drawn at 1 um)", fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()


def format_read(r: ReadTiming) -> str:
    return "\n".join([
        "| product | file | YAML reader (median) | load_product (median, min-max) | load_product CPU "
        "(median) | former reader: PyYAML pure-Python compose alone | ratio |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
        f"| generated, {r.n_parts} parts, {r.n_mates} mates | {r.size_bytes / 1e6:.2f} MB | "
        f"{r.parse_s:.2f} s | {r.load_s:.2f} s ({r.load_min_s:.2f}-{r.load_max_s:.2f} s, {r.runs} runs) | "
        f"{r.load_cpu_s:.2f} s | {r.pure_python_compose_s:.2f} s | "
        f"{r.pure_python_compose_s / r.load_s:.1f}x |", ""])


def format_peers(rows: Sequence[PeerRow], preset_name: str) -> str:
    """Markdown: both engines' errors and costs per scene, with who is ahead."""
    lines = [f"| scene | analytic | PyBullet {preset_name} error | MuJoCo error | PyBullet "
             f"CPU s / sim s | MuJoCo CPU s / sim s | more accurate |",
             "| --- | --- | ---: | ---: | ---: | ---: | --- |"]
    for r in rows:
        def v(x: float, r: PeerRow = r) -> str:
            if r.unit == "m":
                return f"{x * 1e3:+.3f} mm"
            if r.unit == "":
                return f"{x * 100:+.2f} %"
            return f"{x:g} {r.unit}"
        a, b = abs(r.pybullet_error), abs(r.mujoco_error)
        # within 1 um, 0.6 % (one bisection step) or 0.01 m/s the two are not told apart
        tol = {"m": 1e-6, "": 0.006}.get(r.unit, 0.01)
        ahead = "equal" if abs(a - b) <= tol else (
            "PyBullet" if a < b else "MuJoCo")
        lines.append(f"| {r.scene} | {r.analytic} | {v(r.pybullet_error)} | "
                     f"{v(r.mujoco_error)} | {r.pybullet_cost:.2f} | {r.mujoco_cost:.2f} | "
                     f"{ahead} |")
    return "\n".join(lines) + "\n"
