"""What the sweep shows people: settings and factors in mm, µm and degrees, a warning when the
sampled clearances are below what the preset resolves, steps numbered as `run` numbers them,
and why no driver is named (the driver selection itself is tested in
tests/sim/test_sweep_drivers.py)."""

from __future__ import annotations

import math

import pytest

from asmplan.report.plots import factor_label, factor_unit
from asmplan.report.sweep import resolution_warnings, spec_rows
from asmplan.sim.fidelity import preset
from asmplan.sim.sweep import SampleParams, SweepSpec


def test_settings_and_factors_in_units_people_read() -> None:
    rows = dict(spec_rows(SweepSpec(n_samples=4).to_dict()))
    assert rows["pose_angular"] == "0.2 deg" and rows["pose_lateral"] == "0.2 mm"
    assert "pose_angular_rad" not in rows
    # a clearance of a few micrometres is not rounded to 0.0: shown in µm
    scale, unit = factor_unit("clearance[m21a]")
    assert unit == "µm" and f"{8e-6 * scale:.1f}" == "8.0"
    assert factor_unit("pose_angular_rad") == (pytest.approx(180 / math.pi), "deg")
    assert factor_label("pose_angular_rad") == "robot tilt error"
    assert factor_label("friction[part3]") == "friction part3"


def test_resolution_warning_names_the_mate_and_counts_the_samples(examples) -> None:
    product = examples["peg_in_hole"]
    mate = product.mates[0]
    balanced = preset("fast")  # peg_in_hole's H7/g6 (5 um) is below FAST's resolution only
    res = balanced.min_resolvable_clearance_m
    samples = [SampleParams(index=i, seed=0, clearance_m={mate.name: c}, friction={}, pose={})
               for i, c in enumerate((0.5 * res, 2.0 * res, 0.9 * res))]
    (warning,) = resolution_warnings(product, balanced, samples, {"peg": (mate.name,)},
                                     {"peg": 2})
    assert warning.startswith("step 2 (peg): ")
    assert mate.name in warning and "2 of 3 samples" in warning
    assert f"({res * 1e6:.0f} µm)" in warning
    # resolved everywhere: no warning; not varied but below: says so
    assert resolution_warnings(product, balanced, samples[1:2], {"peg": (mate.name,)}) == []
    (unvaried,) = resolution_warnings(product, balanced, [], {"peg": (mate.name,)})
    assert "not varied" in unvaried


def test_the_report_says_why_no_driver_is_named() -> None:
    from asmplan.report.sweep import driver_text, no_driver_text
    from asmplan.sim.sweep import DriverSettings, FactorEffect, StepSummary

    drivers = DriverSettings()
    effects = (FactorEffect("pose_lateral_m", 40, -0.3, 0.04, 0.0, math.nan, (), 0.12),
               FactorEffect("friction[part2]", 40, 0.1, 0.5, 0.0, math.nan, (), 0.5))

    def step(n: int, k: int, status: str, driver: str | None = None) -> StepSummary:
        return StepSummary("part2", n, k, k / n, 0.0, 1.0, (), effects, driver, status, 2)

    assert step(40, 20, "none_significant").label == "step 2 (part2)"
    assert no_driver_text(step(40, 20, "none_significant"), drivers) == (
        "none of the 2 factors tested has q < 0.05 (lowest: lateral robot error, q = 0.12)")
    assert no_driver_text(step(4, 2, "too_few_samples"), drivers) == (
        "too few samples (needs >= 10 with >= 2 successes and 2 failures; has 4 with 2 and 2)")
    assert no_driver_text(step(8, 0, "no_failures"), drivers).startswith("every sample failed")
    named = driver_text(step(40, 20, "named", "pose_lateral_m"))
    assert named.startswith("lateral robot error (correlation -0.30, p = 0.04, "
                            "Benjamini-Hochberg q = 0.12")
