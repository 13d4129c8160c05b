"""What the report and the terminal tell a cell engineer: margins against the limits the
simulator judged with, one numbering of steps, grouped warnings that name the mate, depth only
where it is a depth, and why better-ranked orders were dropped."""

from __future__ import annotations

import re
from html import unescape

import numpy as np
import pytest

from asmplan.cli import main
from asmplan.pipeline import RunSettings, run_product, write_outputs
from asmplan.report.plots import meaningful_depth_mm
from tests.conftest import example_path

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def seed_run():
    return run_product(example_path("pinhole_station"), RunSettings(fidelity="fast"))


def test_margins_show_value_limit_and_margin_of_every_criterion(seed_run, tmp_path) -> None:
    folder = write_outputs(seed_run, tmp_path / "out")
    html = (folder / "report.html").read_text()
    step = seed_run.results.steps[1]  # part2, step 2
    crit = step.criteria
    section = html[html.index('id="step2"'):html.index('id="step3"')]
    # the final position error vs its tolerance, in mm, with the margin left
    value, limit = crit["position"]["value"] * 1e3, crit["position"]["limit"] * 1e3
    assert f"{value:.3f} mm" in section and f"{limit:.3f} mm" in section
    assert f"{limit - value:+.3f} mm" in section
    force, force_limit = crit["insertion_force"]["value"], crit["insertion_force"]["limit"]
    assert f"{force:.2f} N" in section and f"{force_limit - force:+.2f} N" in section
    clamp = seed_run.plan.steps[1].clamp
    assert "commanded clamp force vs needed" in section
    assert f"{clamp.commanded_N - clamp.translational_N:+.2f} N" in section
    assert "commanded clamp force vs rating" in section
    # cycle time per step and in total, and a process sheet with every phase
    # (each step's cycle as the plan times it: with the arm, its joint-space moves)
    cycles = [s.cycle_time_s for s in seed_run.plan.steps if s.trajectory is not None]
    assert f"cycle {cycles[0]:.2f} s" in section
    assert f"<th class=\"num\">{sum(cycles):.2f}</th>" in html
    assert "process sheet: step 2" in section
    for phase in seed_run.plan.steps[1].trajectory.phases:
        assert f"<td>{phase.name}</td>" in section
    # the unresolved fits are one table naming each mate, not one paragraph each
    for mate in seed_run.product.mates:
        assert f"<td>{mate.name}</td>" in html
    assert html.count("A success means the pin fits") == 0


def test_terminal_groups_the_fit_warnings_into_one_naming_every_mate(tmp_path, capsys) -> None:
    code = main(["run", str(example_path("pinhole_station")), "-o", str(tmp_path / "o"),
                 "--fidelity", "fast", "--no-report"])
    out = capsys.readouterr().out
    assert code == 0, out
    warnings = [line for line in out.splitlines() if line.startswith("warning:")]
    fit_warnings = [w for w in warnings if "resolves" in w]
    assert len(fit_warnings) == 1, warnings
    for mate in ("m21a", "m21b", "m32a", "m32b", "m43a", "m43b"):
        assert mate in fit_warnings[0]
    assert "step 2" in fit_warnings[0] and "step 4" in fit_warnings[0]
    # steps count from 1 in the table (the fixture is step 1)
    rows = [line.split()[:2] for line in out.splitlines() if re.match(r"^\d+\s+part\d", line)]
    assert rows == [["1", "part1"], ["2", "part2"], ["3", "part3"], ["4", "part4"]]


def test_depth_is_left_out_while_the_part_is_on_the_tray_or_carried(seed_run) -> None:
    step = seed_run.plan.steps[1]
    rec = seed_run.results.steps[1].record
    depth = meaningful_depth_mm(rec, step.insertion_length_m)
    carried = rec.phase_mask("approach", "clamp", "hold", "lift", "translate")
    assert np.isnan(depth[carried]).all()
    # the raw distance there reaches tens of mm: it would have been plotted as a "depth"
    raw = (step.insertion_length_m - rec.axial_error_m[carried]) * 1e3
    assert np.nanmax(np.abs(raw)) > 10.0
    shown = depth[np.isfinite(depth)]
    assert shown.size and shown.min() >= -5.0 - 1e-9
    assert shown[-1] == pytest.approx(step.insertion_length_m * 1e3, abs=0.5)


@pytest.fixture(scope="module")
def gear_blind(tmp_path_factory):
    """gear_unit ranked without the gripper screening, with a delicate collar (at most 0.6 N
    of clamp force): the best-ranked order (the collar after the cover) cannot be planned, so
    the planner drops it and plans the next one. (With the plain collar the hold criterion
    finds a 45 deg grasp over the cover that needs 0.84 N, and BALANCED inserts it.)"""
    from asmplan.planner.sequence import SequenceSettings

    text = example_path("gear_unit").read_text()
    start = "    start: {location: tray, xyz: [80, 220, 10], rpy: [0, 90, 0]}    # on edge, bore along x\n"
    assert start in text
    path = tmp_path_factory.mktemp("gear") / "gear_unit.yaml"
    path.write_text(text.replace(start, start + "    handling: {max_clamp_force: 0.6}\n"))
    return run_product(path, RunSettings(simulate=False,
                                         sequence=SequenceSettings(gripper_access=False)))


def test_plan_output_says_why_each_better_ranked_order_was_dropped(gear_blind) -> None:
    import io

    from asmplan.commands.plan import PlanProgress, dropped_lines
    from asmplan.commands.textout import StageProgress

    (line,) = dropped_lines(gear_blind.dropped_orders)
    # the order, the step (1-based: the collar is the 8th part) and the reason
    assert re.match(r"order 1 \(base -> .* -> cover -> collar\) could not be planned: "
                    r"step 8 \(part \"collar\"\): no feasible grasp", line), line
    # the progress says when the planner gives an order up instead of restarting silently
    stream = io.StringIO()
    progress = PlanProgress(StageProgress(stream), stream)
    for k in range(8):
        progress(k, 8, f"p{k}", "start")
        if k < 7:
            progress(k, 8, f"p{k}", "done")
    progress(0, 8, "p0", "start")
    assert "order 1 could not be planned (why: below); planning the order ranked 2" in \
        stream.getvalue()


def test_report_lists_the_dropped_orders_with_why(gear_blind, tmp_path) -> None:
    assert len(gear_blind.dropped_orders) == 1
    html = unescape((write_outputs(gear_blind, tmp_path / "gear") / "report.html").read_text())
    assert "Better-ranked orders that could not be planned" in html
    assert html.count('step 8 (part "collar"): no feasible grasp') == 1
    assert 'src="precedence.png"' in html


def test_a_failed_step_picture_says_what_it_shows(tmp_path) -> None:
    text = example_path("peg_in_hole").read_text().replace(
        "precedence:", "process: {max_insertion_force: 0.01}\nprecedence:")
    product = tmp_path / "weak.yaml"
    product.write_text(text)
    result = run_product(product, RunSettings(fidelity="fast"))
    assert not result.success
    html = (write_outputs(result, tmp_path / "out") / "report.html").read_text()
    reason = result.results.steps[1].outcome.reasons[0].replace(">", "&gt;")
    assert f"FAILED, this is where peg ended: {reason}" in html
    assert f"simulated step (animated; FAILED: {reason})" in html
    assert "step(s) 2 fail" in html


def test_one_cycle_time_in_plan_summary_and_report(seed_run, tmp_path) -> None:
    """With the arm, the cycle time is the arm's (joint-limited trajectory plus the joint move
    from the previous step) everywhere: the plan, summary.json, the report's step table and
    total, the arm's table, and each process sheet, whose phases add up to the step's cycle."""
    import json

    folder = write_outputs(seed_run, tmp_path / "out")
    html = (folder / "report.html").read_text()
    summary = json.loads((folder / "summary.json").read_text())
    plan = seed_run.plan
    assert plan.steps[-1].arm is not None and plan.steps[-1].arm.transfer_s > 0
    assert summary["cycle_time_s"] == pytest.approx(plan.cycle_time_s, abs=1e-9)
    assert f"<th class=\"num\">{plan.cycle_time_s:.2f}</th>" in html
    assert f"<b>{plan.cycle_time_s:.2f} s</b>" in html
    for s in plan.steps:
        if s.trajectory is None:
            continue
        assert summary["step_cycle_times_s"][s.part] == pytest.approx(s.cycle_time_s)
        n = s.index + 1
        sheet = html[html.index('<table class="phases">', html.index(f'id="step{n}"')):]
        sheet = sheet[:sheet.index("</table>")]
        lasts = [float(d) for _, d in re.findall(r'<td class="num">([0-9.]+)</td>'
                                                 r'<td class="num">([0-9.]+)</td>', sheet)]
        n_phases = len(s.trajectory.phases) + (1 if s.arm.transfer_s > 0 else 0)
        assert len(lasts) == n_phases
        assert sum(lasts) == pytest.approx(s.cycle_time_s, abs=0.01 * n_phases)
        assert f'<th class="num">{s.cycle_time_s:.2f}</th>' in sheet
