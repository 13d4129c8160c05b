"""`asmplan bench`: the accuracy figures are measured, checked against their bounds, and a
figure beyond its bound fails the command (exit 1, "REGRESSION: ..." on stderr)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from asmplan.cli import main
from bench import suite as b
from bench.scenarios import PinHole

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def fast_accuracy() -> b.AccuracyResult:
    """FAST against the reference, one clearance (0.2 mm radial: resolvable at FAST)."""
    return b.run_accuracy(("fast",), (0.2e-3,))


def test_every_bound_has_a_reason_and_covers_every_preset() -> None:
    keys = {(x.figure, x.preset) for x in b.BOUNDS}
    assert len(keys) == len(b.BOUNDS)  # one bound per figure and preset
    for fig in ("seed_force_mae_N", "slip_threshold_error", "insertion_outcome_mismatch",
                "insertion_depth_error_m", "fit_penetration_m"):
        for p in ("fast", "balanced", "accurate"):
            assert (fig, p) in keys
    assert all(len(x.reason) > 20 and x.limit >= 0 for x in b.BOUNDS)
    # the paper's 0.03 N is the loosest the clamp-force bound may be
    assert all(x.limit <= b.PAPER_MAE_N for x in b.BOUNDS if x.figure == "seed_force_mae_N")


def test_fast_figures_are_within_their_bounds(fast_accuracy) -> None:
    figs = {(f.scenario, f.figure): f for f in fast_accuracy.figures}
    assert b.check_bounds(fast_accuracy.figures) == []
    pin = ("insertion_outcome_mismatch", "insertion_depth_error_m", "fit_penetration_m")
    # 0.2 mm is above FAST's resolution; issue 16's feature scenes are reported, not asserted,
    # at FAST (metres: rims rounded by 1 mm), its held drift is asserted
    assert all(f.asserted for f in fast_accuracy.figures if f.figure in (*pin, "held_drift_m"))
    assert not any(f.asserted for f in fast_accuracy.figures
                   if f.figure in ("jam_depth_error_m", "rim_capture_mismatch"))
    # analytic expectations, independent of the bounds table
    assert figs[("seed clamp cycle (4 s)", "seed_force_mae_N")].value <= b.PAPER_MAE_N
    slips = [f for f in fast_accuracy.figures if f.figure == "slip_threshold_error"]
    # issue 16: held in the air (a = 0) and lifted at 5 and 20 m/s^2, each vs m (g + a) / (2 mu)
    assert [f.scenario.split(",")[1].split("(")[0].strip() for f in slips] == [
        "a = 0 m/s^2", "a = 5 m/s^2", "a = 20 m/s^2"]
    assert all(abs(f.value) <= 0.03 and f.asserted for f in slips)
    fit, interference = fast_accuracy.reference
    assert fit.success and not interference.success
    scene = PinHole()
    assert fit.entered_depth_m == pytest.approx(scene.hole_depth_m - scene.seat_gap_m, abs=20e-6)
    assert interference.entered_depth_m < 2e-3
    assert all(f.wall_s > 0 for f in fast_accuracy.figures)


def test_a_tightened_bound_is_reported_as_a_regression(fast_accuracy) -> None:
    mae = next(f for f in fast_accuracy.figures if f.figure == "seed_force_mae_N")
    tight = [dataclasses.replace(x, limit=mae.value / 2) if (x.figure, x.preset) == (mae.figure, "fast")
             else x for x in b.BOUNDS]
    regs = b.check_bounds(fast_accuracy.figures, tight)
    assert [r.figure for r in regs] == [mae]
    assert str(regs[0]).startswith("REGRESSION: seed_force_mae_N [fast, seed clamp cycle (4 s)] = ")
    assert "exceeds bound" in str(regs[0])


def test_nan_fails_and_figures_below_resolution_are_not_checked() -> None:
    nan = b.AccuracyFigure("fast", "s", "fit_penetration_m", math.nan, "m", 0.1)
    assert len(b.check_bounds([nan])) == 1
    wild = b.AccuracyFigure("fast", "s", "fit_penetration_m", 1.0, "m", 0.1, asserted=False)
    assert b.check_bounds([wild]) == []


def test_quick_bench_fails_loudly_on_a_regression(tmp_path, monkeypatch, capsys) -> None:
    from bench import accuracy, bounds, report, tables

    monkeypatch.setattr(accuracy, "INSERTION_CLEARANCES_M", (0.2e-3,))
    tight = tuple(dataclasses.replace(x, limit=0.0) if x.figure == "fit_penetration_m" else x
                  for x in b.BOUNDS)
    for module in (bounds, tables, report):  # every module of the bench that reads the bounds
        monkeypatch.setattr(module, "BOUNDS", tight)
    out = tmp_path / "bench.md"
    code = main(["bench", "--quick", "--presets", "fast", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 1
    assert "REGRESSION: fit_penetration_m [fast, pin fit 0.200 mm radial]" in captured.err
    assert "| fast | seed clamp cycle (4 s) |" in captured.out
    text = out.read_text()
    assert "## Accuracy vs cost per preset" in text and "## Machine" in text
    assert "REGRESSION: fit_penetration_m" in text
    assert out.with_suffix(".png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bad_sections_are_bad_usage() -> None:
    assert main(["bench", "--sections", "accuracy,nonsense"]) == 2


@pytest.mark.parametrize(("argv", "expected"), [
    ([], "docs/benchmarks.md"),
    (["--quick"], None),
    (["--sections", "seed"], None),
    (["--presets", "balanced"], None),
    (["--sections", "seed", "--out", "x/b.md"], "x/b.md"),
])
def test_only_a_full_run_writes_docs_benchmarks_md_by_default(argv, expected) -> None:
    # a run of one section once replaced the full run's docs/benchmarks.md with its own table
    import argparse

    from asmplan.commands import bench as cmd

    parser = argparse.ArgumentParser()
    cmd.register(parser.add_subparsers())
    args = parser.parse_args(["bench", *argv])
    out = cmd.default_out(args)
    assert (None if out is None else out.as_posix()) == expected


def test_seed_section_times_the_workstation_through_the_cli_and_the_library() -> None:
    timing = b.run_seed_timing(runs=1, report_runs=1)
    assert timing.success, timing.failure
    # the stages the library run reports add up to no more than its wall time
    assert sum(v for k, v in timing.stages_s.items() if k != "report") <= timing.library_s[0]
    assert 0 < timing.imports_s[0] < timing.cli_s[0]
    # the whole job at BALANCED with the report: its report stage is part of its wall time,
    # and its CPU time (process and workers) was counted
    assert 0 < timing.report_stage_s[0] < timing.report_cli_s[0]
    assert timing.report_cpu_s[0] > 0.5  # at least the imports and the simulation
    # every stage's wall and CPU time as the CLI printed them; the stages' CPU (main process
    # and simulation workers) is part of the whole process tree's
    assert set(timing.report_stages_s) == set(timing.report_stages_cpu_s) == {
        "sequence", "plan", "simulate", "report"}
    stage_cpu = sum(v[0] for v in timing.report_stages_cpu_s.values())
    assert 0 < stage_cpu <= timing.report_cpu_s[0] + 0.1
    assert timing.report_stages_cpu_s["simulate"][0] > 0.5  # the workers' CPU counts there
    text = b.format_markdown(b.BenchReport(quick=False, machine={}, seed=timing))
    assert "## The seed workstation end to end" in text
    assert "Every run succeeded." in text
    assert "BALANCED, with the report (target <= 5 s, 2 cores)" in text
    assert "| stage (BALANCED job with the report) | wall, median | CPU, median |" in text
    assert "Target <= 5 s on 2 cores: **" in text


def test_seed_job_is_reported_against_its_five_second_target() -> None:
    # CPU / 2 is the least wall time the job needs on 2 idle cores; the verdict is the wall's
    base = b.SeedRunTiming(1, (1.0,), (0.5,), (0.8,), {}, True, report_runs=3,
                           report_stage_s=(1.0, 1.2, 1.1))
    slow = dataclasses.replace(base, report_cli_s=(9.0, 6.0, 7.0), report_cpu_s=(16.0, 12.0, 14.0))
    text = b.format_seed_timing(slow)
    assert ("Target <= 5 s on 2 cores: **not met**: median wall 7.00 s; median CPU 14.00 s, i.e. "
            "at least 7.00 s of wall on 2 otherwise idle cores (1.4x the target).") in text
    fast = dataclasses.replace(base, report_cli_s=(4.0, 5.0, 3.0), report_cpu_s=(7.0, 8.0, 6.0))
    assert "Target <= 5 s on 2 cores: **met**: median wall 4.00 s" in b.format_seed_timing(fast)


def test_fits_section_counts_a_verdict_against_geometry_and_the_reference() -> None:
    # bench/fits.py: a run is wrong when its verdict differs from capture geometry's or from
    # the reference's; asserted only where the preset resolves the fit; the table shows both
    from bench import fits as f

    def run(fid: str, case: str, verdict: str, c: float = 5e-6) -> f.FitRun:
        return f.FitRun(6e-3, c, case, fid, f.case_lateral_m(case, c), verdict, 0.0, 9e-3, 1.0,
                        (), 0.0)

    ref_name = f.fits_reference_fidelity().name
    runs = [run("balanced", "off", "rim_stop"), run("balanced", "inside", "rim_stop"),
            run("fast", "off", "inserted"), run(ref_name, "off", "rim_stop"),
            run(ref_name, "inside", "inserted")]
    ref = {(r.diameter_m, r.clearance_m, r.case): r for r in runs if r.fidelity == ref_name}
    figs = {(x.preset, x.scenario.split(", ")[-1].split(" ")[0]): x for x in f._figures(runs, ref)}
    assert figs[("balanced", "off")].value == 0.0 and figs[("balanced", "off")].asserted
    assert figs[("balanced", "inside")].value == 1.0 and figs[("balanced", "inside")].asserted
    assert figs[("fast", "off")].value == 1.0 and not figs[("fast", "off")].asserted  # 5 um < 2 mm
    regs = b.check_bounds(list(figs.values()))
    assert [r.figure.scenario for r in regs] == [figs[("balanced", "inside")].scenario]
    text = f.format_fits(f.FitsResult(tuple(runs), (), tuple(figs.values())))
    assert "| 6 mm | 5 um | off (e = 5 um) | rim_stop" in text
    assert "Verdicts differing from geometry or the reference where the preset resolves the fit: 1" in text
    # the generated product is valid input
    import tempfile
    from pathlib import Path

    from asmplan.knowledge.loader import load_product

    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "fit.yaml"
        p.write_text(f.product_yaml(8e-3, 10e-6))
        product = load_product(p)
    (mate,) = product.mates
    assert mate.clearance_min_m == pytest.approx(10e-6) and mate.clearance_max_m == pytest.approx(10e-6)


@pytest.mark.parametrize(("d_m", "c_m"), [(6e-3, 5e-6), (12e-3, 25e-6)])
def test_fits_product_gripper_least_force(d_m, c_m):
    """The fits bench's product declares no least clamp force by default (the planner commands
    what the pin needs: m (g + a) sf / (2 mu), well under 1 N for these 3-30 g steel pins);
    with ``min_force_N`` the gripper declares it and the planner commands it (docs/physics.md,
    the gripper's least clamp force)."""
    import tempfile
    from pathlib import Path

    from asmplan.knowledge.loader import load_product
    from asmplan.planner.timing import clamp_force
    from bench import fits as f

    def load(text: str):
        with tempfile.TemporaryDirectory() as tmp:
            p = Path(tmp) / "fit.yaml"
            p.write_text(text)
            return load_product(p)

    pin_len = f.HOLE_DEPTH_FACTOR * d_m + d_m
    mass = 7850.0 * math.pi * d_m ** 2 / 4.0 * pin_len  # steel
    plain = load(f.product_yaml(d_m, c_m))
    assert plain.resources.gripper.min_force_N == 0.0
    need = clamp_force(plain, "pin", mass)
    mu = plain.resources.gripper.finger_friction * plain.part("pin").friction
    expect = plain.process.safety_factor * mass * (9.81 + need.acceleration_m_s2) / (2 * mu)
    assert need.commanded_N == pytest.approx(expect, rel=0.02) and need.commanded_N < 1.0
    real = load(f.product_yaml(d_m, c_m, min_force_N=f.GRIPPER_MIN_FORCE_N))
    assert real.resources.gripper.min_force_N == pytest.approx(15.0)
    held = clamp_force(real, "pin", mass)
    assert held.commanded_N == pytest.approx(15.0) and held.required_N == pytest.approx(
        need.required_N)
