"""The HTML report: product at a glance, sequence with reasons, every step with views and
plots, fidelity and warnings. It reads only results (plan, simulation results, sequence
explanation) and the part meshes to draw them."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import jinja2
import numpy as np

from .. import __version__
from ..fileio import atomic_write_text
from ..knowledge.model import Product
from ..planner.plan import NOT_ROBOT_KINDS, Plan
from . import plots
from .fits import unresolved_fits
from .planviews import PlanViews, path_view_name
from .steppictures import StepPictures, render_step_pictures
from .steppictures import grip_limit as step_grip_limit

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry
    from .views import Views  # the renderer (trimesh) is imported only where this process renders


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
    dropped_orders: list[dict[str, Any]] = field(default_factory=list)
    """Better-ranked orders that could not be planned: ``order`` and ``failure`` each."""


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
    return {"order": order, "note": note, "count": count, "edges": edges,
            "dropped": inp.dropped_orders}


def step_number(index: int) -> int:
    """The number a person reads for the step with 0-based ``index`` (1-based everywhere)."""
    return index + 1


def _margin_row(name: str, value: float | None, limit: float | None, unit: str, scale: float,
                digits: int, note: str = "", kind: str = "max") -> dict[str, Any]:
    """value vs limit with the margin left (limit - value for an upper limit, value - limit
    for a lower one) in the unit and as a percentage of the limit."""
    ok = None
    margin = pct = "–"
    fraction = math.inf  # margin left as a fraction of the limit (for the tightest one)
    if value is not None and limit is not None and math.isfinite(value) and math.isfinite(limit):
        left = (limit - value) if kind == "max" else (value - limit)
        ok = left >= 0
        margin = f"{left * scale:+.{digits}f}"
        if limit:
            fraction = left / limit
            pct = f"{100 * fraction:+.0f} %"
    return {"name": name, "value": _fmt(value, scale, digits), "limit": _fmt(limit, scale, digits),
            "unit": unit, "margin": margin, "pct": pct, "ok": ok, "note": note,
            "fraction": fraction}


def _margins(step: Any, res: Any, gripper: Any) -> list[dict[str, Any]]:
    """Each success criterion of a step as value vs limit and margin (the report's answer to
    "how close to failing?"), plus the clamp force vs what is needed and the gripper rating."""
    rows = []
    crit = res.criteria if res is not None else {}
    out = res.outcome if res is not None else None

    def c(key: str) -> tuple[float | None, float | None]:
        r = crit.get(key)
        return (None, None) if r is None else (float(r["value"]), float(r["limit"]))

    if out is not None:
        rows.append(_margin_row("final position error", *c("position"), "mm", 1e3, 3))
        if "insertion_depth" in crit:
            rows.append(_margin_row("remaining insertion depth", *c("insertion_depth"), "mm",
                                    1e3, 3))
        rows.append(_margin_row("final tilt", *c("angle"), "deg", 180 / math.pi, 2))
        rows.append(_margin_row("slip in the fingers", *c("slip"), "mm", 1e3, 3))
        rows.append(_margin_row("rotational slip", *c("rotational_slip"), "deg", 180 / math.pi, 2))
        rows.append(_margin_row("peak insertion force", *c("insertion_force"), "N", 1.0, 2))
        rows.append(_margin_row("contact penetration", *c("penetration"), "mm", 1e3, 3,
                                "deeper: the solver could not resolve the contact"))
    clamp = step.clamp
    if clamp is not None:
        rows.append(_margin_row("commanded clamp force vs needed", clamp.commanded_N,
                                clamp.translational_N, "N", 1.0, 2,
                                f"needed m(g+a)/(2 mu) = {clamp.translational_N:.2f} N; commanded "
                                f"with safety factor {clamp.safety_factor:g}", kind="min"))
        rows.append(_margin_row("commanded clamp force vs rating", clamp.commanded_N,
                                clamp.limit_N, "N", 1.0, 2, clamp.limit_source))
        if out is not None:
            rows.append(_margin_row("peak simulated clamp force vs rating",
                                    out.peak_clamp_force_N, gripper.max_force_N, "N", 1.0, 2,
                                    "gripper max_force"))
    return rows


def _in_fixture(product: Any, part: str, T_world_part: np.ndarray) -> str:
    """"regrasp fixture <name>" when ``T_world_part`` is a seat of one of the cell's
    regrasp fixtures for ``part``, else ""."""
    for fx in product.resources.regrasp:
        T = fx.T_world_seat(part)
        if T is not None and np.abs(T - T_world_part).max() <= 1e-9:
            return f"regrasp fixture {fx.name}"
    return ""


def _process_sheet(inp: ReportInputs, step: Any) -> dict[str, Any]:
    """One table per step a cell engineer can hand on: what, from where to where, how held,
    how hard, how fast, and each phase's duration and clamp force."""
    product = inp.product
    start = _in_fixture(product, step.part, step.T_world_start)
    picked_again = any(s.kind == "regrasp" and s.part == step.part and s.index < step.index
                       for s in (inp.plan.steps if inp.plan is not None else ()))
    rows: list[tuple[str, str]] = [("part", step.part), ("operation", step.kind),
                                   ("pick from", "fixture" if step.kind == "fixture" else
                                    f"placed by {step.operation}" if step.kind == "operation" else
                                    start or ("table (where the regrasp put it)" if picked_again
                                              else product.part(step.part).start_location))]
    if step.kind == "regrasp":
        rows.append(("put into", _in_fixture(product, step.part, step.T_world_final)
                     or "table, in another stable orientation"))
    mass = inp.geometry.mass_properties(step.part).mass_kg
    rows.append(("mass", f"{mass * 1e3:.1f} g"))
    for m in (mm for mm in product.mates if mm.name in step.mates):
        rows.append((f"mate {m.name}",
                     f"{m.pin_part}.{m.pin_feature} in {m.hole_part}.{m.hole_feature}, "
                     f"{m.fit or 'explicit'}, diametral clearance {m.clearance_min_m * 1e3:+.3f} "
                     f"to {m.clearance_max_m * 1e3:+.3f} mm"))
    if step.insertion_length_m > 0:
        d = step.insertion_direction
        rows.append(("insertion", f"{step.insertion_length_m * 1e3:.1f} mm along "
                     f"({d[0]:+.2f}, {d[1]:+.2f}, {d[2]:+.2f}) at "
                     f"{product.process.insertion_speed_m_s * 1e3:.0f} mm/s"))
    target = step.T_world_final[:3, 3] * 1e3
    rows.append(("target position", f"({target[0]:.1f}, {target[1]:.1f}, {target[2]:.1f}) mm"))
    if step.grasp is not None:
        g = step.grasp
        rows.append(("grasp", f"{g.source}, width {g.width_m * 1e3:.1f} mm, opened to "
                     f"{g.open_width_m * 1e3:.1f} mm, {g.com_offset_m * 1e3:.1f} mm from the "
                     "centre of mass"))
    if step.clamp is not None:
        rows.append(("clamp force per finger", f"{step.clamp.commanded_N:.2f} N (needed "
                     f"{step.clamp.translational_N:.2f} N, rating {step.clamp.limit_N:.0f} N)"))
    rows.append(("speed, acceleration", f"{product.process.max_speed_m_s * 1e3:.0f} mm/s, "
                 f"{product.process.max_acceleration_m_s2:.1f} m/s²"))
    phases = []
    traj = step.trajectory
    if traj is not None:
        t = np.asarray(traj.t_s)
        f = np.asarray(traj.clamp_force_N)
        # with an arm, the step's cycle starts with its joint move from the previous step's
        # last state: the phases then add up to the step's cycle time (the plan's)
        lead = 0.0 if step.arm is None else float(step.arm.transfer_s)
        if lead > 0:
            phases.append({"name": "arm transfer (joint move from the previous step)",
                           "start": "0.00", "duration": f"{lead:.2f}", "force": "–"})
        for ph in traj.phases:
            mask = (t >= ph.t_start_s) & (t <= ph.t_end_s)
            force = f[mask]
            f0, f1 = (float(force[0]), float(force[-1])) if force.size else (math.nan, math.nan)
            phases.append({"name": ph.name, "start": f"{lead + ph.t_start_s - t[0]:.2f}",
                           "duration": f"{ph.t_end_s - ph.t_start_s:.2f}",
                           "force": ("–" if not force.size else f"{f0:.2f}" if abs(f1 - f0) < 1e-9
                                     else f"{f0:.2f} → {f1:.2f}")})
    return {"rows": rows, "phases": phases}


def _mate_steps(inp: ReportInputs) -> dict[str, int]:
    """The step (0-based index) that makes each mate: the later of its two parts."""
    if inp.plan is None:
        return {}
    order = {s.part: s.index for s in inp.plan.steps}
    return {m.name: max(order.get(m.pin_part, -1), order.get(m.hole_part, -1))
            for m in inp.product.mates}


_CLEARANCE_NOTE = "is below this fidelity's smallest resolvable clearance"


def _step_notes(notes: list[str], mates: list[str], unresolved: list[dict[str, Any]]) -> list[str]:
    """A step's notes once each; the per-scene clearance notes (which do not name the mate)
    are replaced by one line naming the mates this step makes that the preset cannot resolve."""
    out = [n for n in dict.fromkeys(notes) if _CLEARANCE_NOTE not in n]
    mine = [u for u in unresolved if u["mate"] in mates]
    if mine:
        listed = ", ".join(f"{u['mate']} ({u['fit']}, {u['clearance_um']:.0f} µm)" for u in mine)
        out.insert(0, f"This step makes {listed}: below the preset's resolution "
                      f"({mine[0]['resolution_um']:.0f} µm), see Fits the preset cannot resolve.")
    return out


# Complexity above C (radon): one report row per step, each field formatted where it is shown (absent
# values as '-').
def _step_rows(inp: ReportInputs, views: Views | None, folder: Path,
               unresolved: list[dict[str, Any]], paths: dict[int, str] | None = None,
               done: dict[int, StepPictures] | None = None) -> list[dict[str, Any]]:
    if inp.plan is None:
        return []
    results = {r.index: r for r in inp.results.steps} if inp.results is not None else {}
    rows = []
    for step in inp.plan.steps:
        n = step_number(step.index)
        res = results.get(step.index)
        outcome = res.outcome if res is not None else None
        gripper = inp.product.gripper_for(step.part)  # with the pads this part's step uses
        grip_limit = step_grip_limit(inp.product, step)
        cycle = step.cycle_time_s if step.trajectory is not None else None
        row: dict[str, Any] = {
            "index": step.index, "number": n, "part": step.part, "kind": step.kind,
            "cycle": _fmt(cycle), "cycle_s": cycle or 0.0,
            "mates": ", ".join(step.mates) or "–",
            "success": None if outcome is None else bool(outcome.success),
            "reasons": "; ".join(outcome.reasons) if outcome is not None else "",
            # a failure the preset does not resolve (asmplan.sim.resolution): not a verdict
            "unresolved": ("; ".join(u.message for u in res.unresolved)
                           if res is not None and res.unresolved else ""),
            "views": [], "plots": {},
            "notes": [*_press_notes(step, res),
                      *_step_notes([*step.notes, *(res.warnings if res is not None else ())],
                                   list(step.mates), unresolved)],
            "summary": "", "margins": _margins(step, res, gripper),
            "sheet": _process_sheet(inp, step),
        }
        tight = [m for m in row["margins"] if m["ok"] is not None]
        if tight:
            worst = min(tight, key=lambda m: m["fraction"])
            row["tightest"] = f"{worst['name']} ({worst['margin']} {worst['unit']}, {worst['pct']})"
        else:
            row["tightest"] = "–"
        if step.kind == "fixture":
            row["summary"] = "Held by the fixture from the start; not handled by the robot."
        elif step.kind == "operation":
            row["summary"] = (f"Placed by {step.operation} at its assembled pose at this point "
                              "of the sequence; not planned for the robot, not simulated"
                              + (f" ({step.operation_note})." if step.operation_note else "."))
        if views is not None and step.kind not in NOT_ROBOT_KINDS:
            name = (paths or {}).get(step.index, "")  # rendered while simulating
            if not name:
                name = path_view_name(step.index)
                views.path_view(inp.plan, step, folder / name)
            row["views"].append({"src": name, "kind": "path", "caption":
                                 f"planned path of {step.part}: pick (translucent) → transport "
                                 "(blue) → insertion (red) → target"})
        pics = (done or {}).get(step.index)  # drawn when the step's result came back
        if pics is None or pics.result is not res:
            pics = render_step_pictures(inp.product, inp.plan, views, step, res, folder,
                                        grip_limit)
        row["views"].extend(pics.views)
        row["plots"].update(pics.plots)
        if (res is not None and res.record is not None and res.record.n_ticks > 1
                and outcome is not None):
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
        rows.append({"index": step_number(s.index), "part": s.part, "transfer": _fmt(s.arm.transfer_s),
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
    accuracy = ("Measured for this preset (sim/fidelity.py, docs/physics.md, asmplan bench --sections "
                "fits): below the smallest resolvable clearance the capture boundary, rim stops "
                "and jams of a clearance fit are not resolved at this preset; such mates are "
                "listed in the warnings.")
    return {"name": fidelity.name, "rows": rows, "accuracy": accuracy}


# Complexity above C (radon): assembles the report: each optional input (views, arm,
# sequence, failure, results, warnings) adds its section.
def write_report(inp: ReportInputs, folder: Path, *, render_images: bool = True,
                 prepared: PlanViews | None = None) -> Path:
    """Render the images and write ``report.html`` into ``folder``; returns its path.

    ``prepared``: the plan-only pictures already rendered into ``folder`` while the steps
    simulated (:func:`asmplan.report.planviews.render_plan_views`); used when they show
    ``inp.plan`` in this ``folder`` (else everything is rendered here). The report is the
    same either way."""
    folder.mkdir(parents=True, exist_ok=True)
    if prepared is not None and not (render_images and prepared.usable_for(inp.plan, folder)):
        prepared = None
    views: Views | None = None
    if prepared is not None:
        views = prepared.views
    elif render_images:
        from .views import Views

        views = Views(inp.product, inp.geometry)
    images = {"assembled": "", "exploded": ""}
    if prepared is not None:
        images = dict(prepared.images)
    elif views is not None:
        images["assembled"], images["exploded"] = views.render_product(folder)
    unresolved = unresolved_fits(inp.product, inp.fidelity) if inp.results is not None else []
    mate_steps = _mate_steps(inp)
    for u in unresolved:
        k = mate_steps.get(u["mate"])
        u["step"] = "–" if k is None or k < 0 else str(step_number(k))
    steps = _step_rows(inp, views, folder, unresolved,
                       prepared.paths if prepared is not None else None,
                       prepared.steps if prepared is not None else None)
    arm = _arm_block(inp)
    if arm is not None and prepared is not None and prepared.reach:
        arm["reach_image"] = prepared.reach
    elif arm is not None and render_images:
        from ..planner.arm import reach_facts

        robot = inp.product.resources.robot
        assert robot is not None  # the arm block exists only with an arm
        shoulder, reach = reach_facts(robot)
        plots.reach_plot(inp.product, inp.plan, shoulder, reach, folder / "cell-reach.png")
        arm["reach_image"] = "cell-reach.png"
    story = []
    if views is not None and inp.plan is not None:
        board = prepared.story if prepared is not None else views.storyboard(inp.plan, folder)
        story = [{"number": step_number(k), "part": part, "src": src} for k, part, src in board]
    graph = ""
    if prepared is not None and prepared.graph:
        graph = prepared.graph
    elif inp.sequence is not None:
        graph = "precedence.png"
        block = _sequence_block(inp)
        plots.precedence_graph_plot(inp.sequence.precedence, folder / graph,
                                    order=block["order"] if block is not None else ())
    success = (inp.results is not None and inp.results.success and not inp.failure)
    if inp.failure:
        verdict = "no plan"
    elif inp.results is None:
        verdict = "not simulated"
    else:
        failed = [s for s in steps if s["success"] is False and not s["unresolved"]]
        unres = [s for s in steps if s["unresolved"]]
        verdict = (f"step(s) {', '.join(str(s['number']) for s in failed)} fail" if failed
                   else "" if unres else "every step succeeds")
        if unres:
            verdict += ("; " if failed else "") + (
                f"step(s) {', '.join(str(s['number']) for s in unres)} not resolved at "
                f"fidelity {inp.results.fidelity.name}")
        ops = [s for s in inp.plan.steps if s.kind == "operation"] if inp.plan else []
        if ops:
            verdict = verdict.replace("every step", "every simulated step") + (
                f"; {len(ops)} placed by another operation, not simulated: "
                + ", ".join(f"{s.part} ({s.operation})" for s in ops))
    cycle_total = sum(s["cycle_s"] for s in steps)
    # run-level warnings: the unresolved-fit paragraphs become one table (one row per mate)
    covered = {u["mate"] for u in unresolved}
    warnings = [w for w in inp.warnings
                if not any(w.startswith(f"mate {m} (") for m in covered)]
    html = report_template().render(
        product=inp.product, source=str(inp.product.source), images=images,
        parts=_parts_rows(inp), mates=_mates_rows(inp.product), sequence=_sequence_block(inp),
        steps=steps, arm=arm, fidelity=_fidelity_block(inp.fidelity), warnings=warnings,
        unresolved=unresolved, story=story, graph=graph, cycle_total=f"{cycle_total:.2f}",
        failure=inp.failure, success=success, verdict=verdict, version=__version__)
    return atomic_write_text(folder / "report.html", html)


@functools.cache
def report_template() -> jinja2.Template:
    """The report's compiled template (compiled once per process: ~0.1 s; the pictures
    rendered while simulating compile it then, :mod:`asmplan.report.planviews`)."""
    env = jinja2.Environment(loader=jinja2.PackageLoader("asmplan.report", "templates"),
                             autoescape=jinja2.select_autoescape(["html", "j2"]),
                             undefined=jinja2.StrictUndefined, keep_trailing_newline=True)
    return env.get_template("report.html.j2")


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
