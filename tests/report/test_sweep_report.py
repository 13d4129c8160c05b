"""What the sweep shows people: settings and factors in mm, µm and degrees, a warning when the
sampled clearances are below what the preset resolves, and drivers named only among the
factors of a step's scene after a multiple-testing correction."""

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
    (warning,) = resolution_warnings(product, balanced, samples, {"peg": (mate.name,)})
    assert mate.name in warning and "2 of 3 samples" in warning
    assert f"({res * 1e6:.0f} µm)" in warning
    # resolved everywhere: no warning; not varied but below: says so
    assert resolution_warnings(product, balanced, samples[1:2], {"peg": (mate.name,)}) == []
    (unvaried,) = resolution_warnings(product, balanced, [], {"peg": (mate.name,)})
    assert "not varied" in unvaried


def _effect(factor: str, r: float, p: float):
    from asmplan.sim.sweep import FactorEffect

    return FactorEffect(factor, 20, r, p, 0.0, math.nan, ())


def _summary(n: int, successes: int, effects):
    from asmplan.sim.sweep import StepSummary, SweepSummary

    st = StepSummary("part2", n, successes, successes / n, 0.0, 1.0, (), tuple(effects), None)
    return SweepSummary(n, 0, (), (st,))


def test_only_factors_in_the_step_scene_are_tested(examples) -> None:
    from types import SimpleNamespace

    from asmplan.report.sweep import step_factors

    product = examples["pinhole_station"]
    plan = SimpleNamespace(steps=[SimpleNamespace(part=p) for p in ("part1", "part2", "part3",
                                                                     "part4")])
    factors = step_factors(plan, product, 1)  # part2 goes onto part1; part3 is still on the tray
    assert "friction[part2]" in factors and "clearance[m21a]" in factors
    assert "friction[part3]" not in factors and "clearance[m32a]" not in factors
    assert {"pose_lateral_m", "pose_angular_rad"} <= factors


def test_driver_needs_the_scene_a_correction_and_enough_samples() -> None:
    from asmplan.report.sweep import named_drivers

    allowed = {"part2": {"friction[part2]", "clearance[m21a]", "pose_lateral_m"}}
    effects = [_effect("friction[part3]", 1.0, 0.0014),  # not in the scene: never named
               _effect("friction[part2]", -0.6, 0.03),
               _effect("clearance[m21a]", 0.2, 0.40),
               _effect("pose_lateral_m", -0.5, 0.02)]
    summary, q = named_drivers(_summary(40, 20, effects), allowed)
    (st,) = summary.steps
    assert {e.factor for e in st.effects} == allowed["part2"]
    # Benjamini-Hochberg over the three tested: 0.02 -> 0.045, 0.03 -> 0.045, 0.40 -> 0.40
    assert q["part2"]["pose_lateral_m"] == pytest.approx(0.045)
    assert q["part2"]["friction[part2]"] == pytest.approx(0.045)
    assert st.driver == "friction[part2]"  # the larger |r| among q < 0.05
    # an uncorrected p of 0.04 among three does not survive the correction
    weak = [_effect("friction[part2]", -0.6, 0.04), _effect("clearance[m21a]", 0.2, 0.5),
            _effect("pose_lateral_m", 0.1, 0.6)]
    assert named_drivers(_summary(40, 20, weak), allowed)[0].steps[0].driver is None
    # too few samples (4, as in the issue): nothing is named however small p is
    assert named_drivers(_summary(4, 2, effects), allowed)[0].steps[0].driver is None
