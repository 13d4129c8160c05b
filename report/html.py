"""The HTML report: product at a glance, sequence with reasons, every step with views and
plots, fidelity and warnings. It reads only results (plan, simulation results, sequence
explanation) and the part meshes to draw them."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import jinja2

from .. import __version__
from ..fileio import atomic_write_text
from ..knowledge.model import Product
from ..planner.plan import Plan
from . import plots
from .views import Views

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry


@dataclass
class ReportInputs:
    """Everything a report shows. ``plan``/``results``/``sequence`` may be None when that
    stage did not run or failed (``failure`` then says why)."""

    product: Product
    geometry: ProductGeometry
    sequence: Any | None = None
    plan: Plan | None = None
    results: Any | None = None
    fidelity: Any | None = None
    failure: str = ""
    warnings: list[str] = field(default_factory=list)


def _fmt(value: float | None, scale: float = 1.0, digits: int = 2) -> str:
    if value is None or not math.isfinite(value):
        return "–"
    return f"{value * scale:.{digits}f}"


def _parts_rows(inp: ReportInputs) -> list[dict[str, Any]]:
    rows = []
    for p in inp.product.parts:
        mass = inp.geometry.mass_properties(p.name).mass_kg
        held = "fixture" if inp.product.is_fixtured(p.name) else "robot"
        start = "in the fixture" if held == "fixture" else p.start_location
        rows.append({"name": p.name, "material": p.material.name if p.material else "given mass",
                     "mass_g": mass * 1e3, "held": held, "start": start,
                     "features": ", ".join(f"{f.name} ({f.kind} Ø{f.diameter_m * 1e3:g})"
                                           for f in p.features)})
    return rows


def _mates_rows(product: Product) -> list[dict[str, Any]]:
    return [{"name": m.name, "pin": f"{m.pin_part}.{m.pin_feature}",
             "hole": f"{m.hole_part}.{m.hole_feature}",
             "fit": m.fit or "explicit",
             "clearance": f"{m.clearance_min_m * 1e6:+.0f} .. {m.clearance_max_m * 1e6:+.0f} ({m.kind})"}
            for m in product.mates]


def _sequence_block(inp: ReportInputs) -> dict[str, Any] | None:
    if inp.plan is None and inp.sequence is None:
        return None
    if inp.plan is not None:
        order = list(inp.plan.sequence)
    else:
        assert inp.sequence is not None  # one of the two is set (checked above)
        order = list(inp.sequence.best.order)
    note = inp.plan.sequence_note if inp.plan is not None else ""
    edges = []
    count = None
    if inp.sequence is not None:
        count = inp.sequence.feasible_count
        for e in inp.sequence.edges():
            kinds = sorted({o["kind"] for o in e["origins"]})
            if kinds == ["base"]:
                continue
            reason = "; ".join(o["reason"] for o in e["origins"] if o["kind"] != "base")
            edges.append({"before": e["before"], "after": e["after"], "kinds": ", ".join(kinds),
                          "reason": reason})
        if inp.product.precedence.base:
            edges.insert(0, {"before": inp.product.precedence.base, "after": "every other part",
                             "kinds": "base", "reason": "declared the base part"})
    return {"order": order, "note": note, "count": count, "edges": edges}


# Complexity above C (radon): one report row per step, each field formatted where it is shown (absent
# values as '-').
def _step_rows(inp: ReportInputs, views: Views | None, folder: Path) -> list[dict[str, Any]]:
    if inp.plan is None:
        return []
    gripper = inp.product.resources.gripper
    results = {r.index: r for r in inp.results.steps} if inp.results is not None else {}
    rows = []
    for step in inp.plan.steps:
        res = results.get(step.index)
        outcome = res.outcome if res is not None else None
        clamp = step.clamp
        grip_limit = clamp.limit_N if clamp is not None else gripper.max_force_N
        cycle = step.cycle_time_s if step.trajectory is not None else None
        row: dict[str, Any] = {
            "index": step.index, "part": step.part, "kind": step.kind, "cycle": _fmt(cycle),
            "commanded": _fmt(clamp.commanded_N if clamp else None),
            "slip_limit": _fmt(clamp.slip_limit_N if clamp else None),
            "grip_limit": _fmt(grip_limit if clamp else None),
            "peak_clamp": _fmt(outcome.peak_clamp_force_N if outcome else None),
            "peak_insertion": _fmt(outcome.peak_insertion_force_N if outcome else None),
            "final_error": _fmt(outcome.final_position_error_m if outcome else None, 1e3, 3),
            "success": None if outcome is None else bool(outcome.success),
            "reasons": "; ".join(outcome.reasons) if outcome is not None else "",
            "views": {}, "plots": {}, "notes": [*_press_notes(step, res), *step.notes,
                                                *(res.warnings if res is not None else ())],
            "summary": "",
        }
        if step.kind == "fixture":
            row["summary"] = "Held by the fixture from the start; not handled by the robot."
        if views is not None and step.kind != "fixture":
            row["views"] = views.render_step(inp.plan, step, folder)
        if res is not None and res.record is not None and res.record.n_ticks > 1:
            rec = res.record
            title = f"step {step.index}: {step.part}"
            name = f"step{step.index:02d}-clamp-force.png"
            plots.clamp_force_plot(rec, folder / name, title=title,
                                   slip_threshold_N=clamp.slip_limit_N if clamp else None,
                                   grip_limit_N=grip_limit if clamp else None)
            row["plots"]["clamp force: commanded vs simulated"] = name
            if step.insertion_length_m > 0 and math.isfinite(float(rec.axial_error_m[-1])):
                name = f"step{step.index:02d}-insertion.png"
                plots.insertion_plot(rec, folder / name, target_depth_m=step.insertion_length_m,
                                     title=title)
                row["plots"]["insertion depth and contact force"] = name
            if outcome is not None:
                row["summary"] = (
                    f"Clamp force error (mean absolute, held phases): {outcome.clamp_force_mae_N:.4f} N; "
                    f"max slip {outcome.max_slip_m * 1e3:.3f} mm; final axial error "
                    f"{_fmt(outcome.final_axial_error_m, 1e3, 3)} mm; max penetration "
                    f"{outcome.max_penetration_m * 1e3:.3f} mm.")
        rows.append(row)
    return rows


def _arm_block(inp: ReportInputs) -> dict[str, Any] | None:
    """The arm's table: per step transfer, trajectory and cycle time, branch and margins."""
    robot = inp.product.resources.robot
    if inp.plan is None or robot is None or not any(s.arm for s in inp.plan.steps):
        return None
    rows = []
    for s in inp.plan.steps:
        if s.arm is None or s.trajectory is None:
            continue
        slowed = ", ".join(f"{n} x{k:.2f}" for n, k in s.arm.phase_time_scale if k > 1.0 + 1e-6)
        rows.append({"index": s.index, "part": s.part, "transfer": _fmt(s.arm.transfer_s),
                     "trajectory": _fmt(s.trajectory.duration_s), "cycle": _fmt(s.cycle_time_s),
                     "branch": s.arm.branch,
                     "manipulability": _fmt(s.arm.min_manipulability_ratio, 100.0, 1),
                     "margin": _fmt(s.arm.min_limit_margin_rad, 180.0 / math.pi, 1)
                     + f" ({s.arm.limit_margin_joint})",
                     "slowed": slowed or "none"})
    return {"model": robot.model, "total": _fmt(inp.plan.cycle_time_s), "rows": rows,
            "reach_image": ""}


def _fidelity_block(fidelity: Any) -> dict[str, Any]:
    if fidelity is None:
        return {"name": "not simulated", "rows": [], "accuracy": ""}
    rows = [("time step", f"{fidelity.dt_s * 1e3:.3g} ms"),
            ("solver iterations", str(fidelity.solver_iterations)),
            ("contact slop", f"{fidelity.contact_slop_m * 1e6:.3g} µm"),
            ("geometry level of detail", str(fidelity.geometry_lod)),
            ("smallest resolvable diametral clearance",
             f"{fidelity.min_resolvable_clearance_m * 1e6:.0f} µm")]
    accuracy = ("Measured for this preset (docs/physics.md, docs/benchmarks.md): a clearance below the "
                "smallest resolvable one cannot be told from an interference at this preset; such "
                "mates are listed in the warnings.")
    return {"name": fidelity.name, "rows": rows, "accuracy": accuracy}


def write_report(inp: ReportInputs, folder: Path, *, render_images: bool = True) -> Path:
    """Render the images and write ``report.html`` into ``folder``; returns its path."""
    folder.mkdir(parents=True, exist_ok=True)
    views = Views(inp.product, inp.geometry) if render_images else None
    images = {"assembled": "", "exploded": ""}
    if views is not None:
        images["assembled"], images["exploded"] = views.render_product(folder)
    steps = _step_rows(inp, views, folder)
    arm = _arm_block(inp)
    if arm is not None and render_images:
        from ..planner.arm import reach_facts

        robot = inp.product.resources.robot
        assert robot is not None  # the arm block exists only with an arm
        shoulder, reach = reach_facts(robot)
        plots.reach_plot(inp.product, inp.plan, shoulder, reach, folder / "cell-reach.png")
        arm["reach_image"] = "cell-reach.png"
    success = (inp.results is not None and inp.results.success and not inp.failure)
    if inp.failure:
        verdict = "no plan"
    elif inp.results is None:
        verdict = "not simulated"
    else:
        failed = [s for s in steps if s["success"] is False]
        verdict = f"{len(failed)} step(s) fail" if failed else "every step succeeds"
    env = jinja2.Environment(loader=jinja2.PackageLoader("asmplan.report", "templates"),
                             autoescape=jinja2.select_autoescape(["html", "j2"]),
                             undefined=jinja2.StrictUndefined, keep_trailing_newline=True)
    html = env.get_template("report.html.j2").render(
        product=inp.product, source=str(inp.product.source), images=images,
        parts=_parts_rows(inp), mates=_mates_rows(inp.product), sequence=_sequence_block(inp),
        steps=steps, arm=arm, fidelity=_fidelity_block(inp.fidelity), warnings=inp.warnings,
        failure=inp.failure, success=success, verdict=verdict, version=__version__)
    return atomic_write_text(folder / "report.html", html)


def _press_notes(step, res) -> list[str]:
    """The press force a step's fits need (plan) and what the simulation measured."""
    out = []
    op = step.press
    if op is not None:
        lo, typ, hi = op.force_N
        out.append(f"press fit {', '.join(op.mates)}: needs {lo:.4g} / {typ:.4g} / {hi:.4g} N "
                   f"(min / typical / max; interferes with probability "
                   f"{op.probability_interference:.1%}), pressed by the {op.by}")
    if res is not None and getattr(res, "press", None):
        out.append(res.press["verdict"])
    return out
