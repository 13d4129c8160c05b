"""The sweep's size model: actual hole and shaft sizes drawn as `check` models them, and a
sample that interferes pressed with the Lame force of its own interference (or failing
``press_required`` where neither the grip nor the cell's press can give it)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from asmplan.knowledge import iso286
from asmplan.knowledge.loader import load_product
from asmplan.knowledge.press_fit import clearance_model
from asmplan.parts.models import ProductGeometry
from asmplan.planner.press import product_press_fits
from asmplan.planner.product import plan_product
from asmplan.planner.settings import PlannerSettings
from asmplan.sim import sweep as sw

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "press"


def _truncated_normal_pdf(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    mid, sigma = 0.5 * (lo + hi), (hi - lo) / 6.0
    pdf = np.exp(-0.5 * ((x - mid) / sigma) ** 2)
    pdf[(x < lo) | (x > hi)] = 0.0
    return pdf / np.trapezoid(pdf, x)


def test_sizes_are_drawn_from_the_zones_of_the_fit_as_check_models_them() -> None:
    # the hinge's pin in the lever's eye: JS7/h8 at 8 mm, -7..+29 um, a transition fit
    d = 8e-3
    fit = iso286.fit("JS7/h8", d)
    c = sw.ClearanceRange("eye", fit.clearance_min_m, fit.clearance_max_m,
                          (fit.hole.lower_m, fit.hole.upper_m), (fit.shaft.lower_m, fit.shaft.upper_m))
    n = 40000
    spec = sw.SweepSpec(n_samples=n, seed=3, vary=("clearance",))
    assert spec.clearance_distribution == "sizes"  # the default
    v = np.array([s.clearance_m["eye"] for s in sw.draw_samples(spec, [c], {}, [])])
    assert fit.clearance_min_m <= v.min() and v.max() <= fit.clearance_max_m
    # the reference: the clearance D - d of two independent normals, each centred in its zone
    # with 6 sigma = its width and truncated to it (numerical convolution on a 1 nm grid)
    x = np.arange(-60e-6, 60e-6, 1e-9)
    hole = _truncated_normal_pdf(x, fit.hole.lower_m, fit.hole.upper_m)
    shaft = _truncated_normal_pdf(x, fit.shaft.lower_m, fit.shaft.upper_m)
    # clearance pdf: hole(D) * shaft(D - c), integrated over D
    grid_c = np.arange(-40e-6, 40e-6, 1e-9)
    pdf_c = np.array([np.trapezoid(hole * np.interp(x - cc, x, shaft, left=0, right=0), x)
                      for cc in grid_c[::50]])
    cs = grid_c[::50]
    pdf_c /= np.trapezoid(pdf_c, cs)
    p_ref = float(np.trapezoid(pdf_c[cs < 0], cs[cs < 0]))
    p = float((v < 0).mean())
    assert p == pytest.approx(p_ref, abs=4 * math.sqrt(p_ref * (1 - p_ref) / n) + 2e-4)
    # the same model as `check` (untruncated): mean exact, sigma within the truncation's effect
    model = clearance_model(_Mate(), d)
    assert v.mean() == pytest.approx(model.mean_m, abs=4 * model.sigma_m / math.sqrt(n))
    assert v.std() == pytest.approx(model.sigma_m, rel=0.03)
    assert model.probability_interference == pytest.approx(p, abs=0.003)  # 0.0057 vs ~0.0046


class _Mate:
    """The JS7/h8 mate as :func:`clearance_model` reads it."""

    fit = "JS7/h8"
    clearance_min_m = -7e-6
    clearance_max_m = 29e-6


def test_a_declared_range_is_drawn_normal_in_the_range() -> None:
    c = sw.ClearanceRange("m", -15e-6, 15e-6)
    v = np.array([s.clearance_m["m"] for s in sw.draw_samples(
        sw.SweepSpec(20000, seed=1, vary=("clearance",)), [c], {}, [])])
    assert v.min() >= -15e-6 and v.max() <= 15e-6
    assert v.std() == pytest.approx(5e-6 * 0.9866, rel=0.03)  # sigma = width / 6, truncated at 3
    with pytest.raises(ValueError, match="zones whose difference spans"):
        sw.ClearanceRange("m", -15e-6, 15e-6, (0.0, 10e-6), (0.0, 10e-6))


def test_clearance_ranges_carry_the_iso_zones() -> None:
    product = load_product(FIXTURES / "pin_in_pom.yaml")
    (c,) = sw.clearance_ranges(product)
    f = iso286.fit("H7/js6", 6e-3)
    assert c.hole_zone_m == (f.hole.lower_m, f.hole.upper_m)
    assert c.shaft_zone_m == (f.shaft.lower_m, f.shaft.upper_m)


@pytest.fixture(scope="module")
def pom() -> tuple:
    product = load_product(FIXTURES / "pin_in_pom.yaml")
    plan = plan_product(product, ProductGeometry(product), PlannerSettings(),
                        sequence=["block", "pin"]).plan
    assert plan.step("pin").press.by == "gripper"  # H7/js6 in POM: up to 24 N, the robot pushes
    return product, plan


def _sample(product, clearance_m: float):
    params = sw.SampleParams(0, 0, clearance_m={"pin_fit": clearance_m})
    p2 = sw.perturb_product(product, params)
    return params, p2, ProductGeometry(p2)


def test_an_interfering_sample_is_pressed_with_the_force_of_its_interference(pom) -> None:
    product, plan = pom
    _, p2, g2 = _sample(product, -3e-6)
    step, failure = sw.sample_press_step(plan, 1, p2, g2)
    assert failure is None
    fit = product_press_fits(p2, g2)["pin_fit"]
    assert fit.interference_m == pytest.approx((3e-6,) * 3)
    # the Lame force of 3 um in POM: linear in the interference, 3/4 of the zone's max (4 um)
    assert step.press.force_N == pytest.approx((fit.force_N[2],) * 3)
    # (within 1e-3: the perturbed sizes sit symmetric about the nominal, which moves the
    # measured engaged length and hub wall by micrometres)
    assert step.press.force_N[2] == pytest.approx(0.75 * plan.step("pin").press.force_N[2], rel=1e-3)
    assert step.press.by == "gripper"
    assert step.press.pass_through_m == plan.step("pin").press.pass_through_m
    # a sample with clearance needs no force: a plain insertion
    _, p3, g3 = _sample(product, 5e-6)
    step, failure = sw.sample_press_step(plan, 1, p3, g3)
    assert failure is None and step.press is None
    # beyond what the grip can push (and no press in the cell): the step fails press_required
    _, p4, g4 = _sample(product, -8e-6)
    step, failure = sw.sample_press_step(plan, 1, p4, g4)
    assert failure is not None and failure["reason"].startswith("press_required")
    assert "use a press" in failure["reason"]
    assert failure["needed_N"] == pytest.approx(2 * plan.step("pin").press.force_N[2], rel=1e-3)
    assert failure["capacity_N"] == pytest.approx(plan.step("pin").press.capacity.force_N, rel=1e-3)


def test_a_press_step_takes_the_samples_force_up_to_the_press_max(tmp_path) -> None:
    text = (FIXTURES / "steel_pin_in_steel.yaml").read_text().replace(
        "  table: {size: [600, 600, 40]}", "  table: {size: [600, 600, 40]}\n  press: {max_force: 20000}")
    path = tmp_path / "dowel_press.yaml"
    path.write_text(text)
    product = load_product(path)
    plan = plan_product(product, ProductGeometry(product), PlannerSettings(),
                        sequence=["block", "dowel"]).plan
    planned = plan.step("dowel").press
    assert planned.by == "press"
    (mate,) = product.mates
    for c, expect_fail in ((mate.clearance_min_m, False), (10e-6, False), (-0.2e-3, True)):
        params = sw.SampleParams(0, 0, clearance_m={mate.name: c})
        p2 = sw.perturb_product(product, params)
        g2 = ProductGeometry(p2)
        step, failure = sw.sample_press_step(plan, 1, p2, g2)
        if expect_fail:  # 0.2 mm of interference needs more than the 20 kN press
            assert failure is not None and "stronger press" in failure["reason"]
            assert failure["needed_N"] > 20e3 and failure["capacity_N"] == 20e3
            continue
        assert failure is None and step.press.by == "press"
        assert step.press.pass_through_m == planned.pass_through_m
        want = product_press_fits(p2, g2)[mate.name].force_N if c < 0 else (0.0, 0.0, 0.0)
        assert step.press.force_N == pytest.approx(want)
        if c == mate.clearance_min_m:  # the zone's largest interference: the plan's max force
            assert step.press.force_N[1] == pytest.approx(planned.force_N[2], rel=1e-3)


@pytest.mark.slow
def test_an_interfering_sweep_sample_is_simulated_as_a_press_with_its_force(pom) -> None:
    from asmplan.sim.fidelity import BALANCED

    product, plan = pom
    ps = sw.PlanSweep(product, plan, BALANCED)
    params, p2, g2 = _sample(product, -3e-6)
    want = product_press_fits(p2, g2)["pin_fit"].force_N[1]
    got = sw.simulate_sample(ps, params)["steps"]["pin"]
    assert got["success"] is True, got["reasons"]
    press = got["press"]
    assert press["by"] == "gripper" and press["home"]
    assert press["force_full_typical_N"] == pytest.approx(want, rel=1e-9)
    assert press["peak_force_N"] == pytest.approx(want, rel=0.05)  # 18 N, not the nominal 4.7 N
    # a press_required sample is a failure with its numbers, simulated or not
    params, _, _ = _sample(product, -8e-6)
    got = sw.simulate_sample(ps, params)["steps"]["pin"]
    assert got["success"] is False and got["failed_criteria"] == ["press_required"]
    assert got["failures"]["press_required"]["value"] > got["failures"]["press_required"]["limit"]
