"""What a preset does not resolve (asmplan.sim.resolution): each rule on gear_unit's planned
steps with a given outcome, including the controls that keep a resolved failure a failure."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.product import plan_product
from asmplan.sim.fidelity import ACCURATE, BALANCED, FAST
from asmplan.sim.records import StepOutcome
from asmplan.sim.resolution import (
    GRIP_MARGIN_RESOLVED,
    Unresolved,
    held_clamp_force_N,
    unresolved_causes,
)
from asmplan.sim.results import StepResult
from asmplan.sim.verdicts import Failure
from tests.conftest import example_path


@pytest.fixture(scope="module")
def gear():
    product = load_product(example_path("gear_unit"))
    plan = plan_product(product, ProductGeometry(product)).plan
    steps = {s.part: s for s in plan.steps}
    return product, steps


def _outcome(failures=(), penetration_m=0.0):
    return StepOutcome(success=False, reasons=("x",), warnings=(),
                       final_position_error_m=3e-3, final_angle_error_rad=0.0,
                       final_axial_error_m=3e-3, max_slip_m=0.0, max_slip_rad=0.0,
                       dropped=False, peak_clamp_force_N=1.0, clamp_force_mae_N=0.0,
                       peak_insertion_force_N=1.0, max_penetration_m=penetration_m,
                       nan_detected=False, energy_growth=False, failures=tuple(failures))


def _record(lateral_m):
    return SimpleNamespace(n_ticks=2, lateral_error_m=np.array([math.nan, lateral_m]))


JAM = Failure("jammed", 2.8e-3, 6e-3, "m")
RIM = Failure("rim_stop", 0.1e-3, 0.5e-3, "m")
COVER_SCENE = ("base", "bearing_block", "post_1", "post_2", "cover")


def test_a_stop_on_a_fit_below_fast_is_not_resolved_and_names_balanced(gear):
    product, steps = gear
    failed = {"insertion_depth", "position", "angle", "slip"}
    (u,) = unresolved_causes(_outcome([JAM]), failed, steps["cover"], product, COVER_SCENE,
                             FAST, _record(0.05e-3))
    assert u.code == "fit" and u.subject in ("cover_on_post_1", "cover_on_post_2")
    assert u.fit == "H11/c11" and u.value == pytest.approx(80e-6, abs=1e-9)
    assert u.limit == FAST.min_resolvable_clearance_m and u.needs == "balanced"
    assert set(u.criteria) == failed
    assert u.message.startswith("not resolved at fast: fit cover_on_post_")
    assert "run --fidelity balanced (resolves 4 um)" in u.message
    assert Unresolved.from_dict(u.to_dict()) == u


@pytest.mark.parametrize("fidelity", [BALANCED, ACCURATE], ids=["balanced", "accurate"])
def test_a_preset_that_resolves_the_fit_keeps_the_failure(gear, fidelity):
    product, steps = gear
    assert unresolved_causes(_outcome([JAM]), {"insertion_depth"}, steps["cover"], product,
                             COVER_SCENE, fidelity, _record(0.05e-3)) == ()


def test_a_rim_stop_beyond_the_capture_boundary_stays_a_failure(gear):
    """c_max / 2 + chamfers = 0.13 + 1.0 mm, plus half FAST's 2 mm: 2.13 mm."""
    product, steps = gear
    args = ({"insertion_depth", "position"}, steps["cover"], product, COVER_SCENE, FAST)
    assert unresolved_causes(_outcome([RIM]), *args, _record(2.5e-3)) == ()
    assert [u.code for u in unresolved_causes(_outcome([RIM]), *args, _record(1.5e-3))] == ["fit"]


def test_a_failure_the_preset_resolves_keeps_the_step_failed(gear):
    product, steps = gear
    cover = steps["cover"]
    # a criterion no cause explains
    assert unresolved_causes(_outcome([JAM]), {"insertion_depth", "nan"}, cover, product,
                             COVER_SCENE, FAST, _record(0.0)) == ()
    # a body that fell or went unstable
    fell = Failure("fell", 1.2, 1.0, "m/s", body="cover")
    assert unresolved_causes(_outcome([JAM, fell]), {"insertion_depth"}, cover, product,
                             COVER_SCENE, FAST, _record(0.0)) == ()
    # no fit partner in the scene: nothing below the resolution was entered
    assert unresolved_causes(_outcome([JAM]), {"insertion_depth"}, cover, product,
                             ("base", "bearing_block"), FAST, _record(0.0)) == ()


def test_a_slip_under_a_planned_grip_at_fast_is_its_pads_creep(gear):
    product, steps = gear
    shaft = steps["shaft"]
    c = shaft.clamp
    (u,) = unresolved_causes(_outcome(), {"rotational_slip"}, shaft, product, (), FAST)
    assert u.code == "grip" and u.needs == "balanced"
    held = held_clamp_force_N(shaft.trajectory)
    assert held == pytest.approx(c.commanded_N, rel=1e-6)  # the planned force while carried
    assert u.value == pytest.approx(held * c.safety_factor / c.required_N)
    # the same slip at BALANCED is judged
    assert unresolved_causes(_outcome(), {"rotational_slip"}, shaft, product, (), BALANCED) == ()
    # a grip at the slip threshold is resolved at every preset: a slip there is a slip
    assert GRIP_MARGIN_RESOLVED > 1.05
    assert unresolved_causes(_outcome(), {"slip"}, shaft, product, (), FAST,
                             held_force_N=1.05 * c.required_N / c.safety_factor) == ()
    # and a trajectory that commands less than the plan (the force simulated decides)
    assert unresolved_causes(_outcome(), {"slip"}, shaft, product, (), FAST,
                             held_force_N=0.05 * held) == ()


def test_penetration_within_fasts_impact_penetration_is_not_resolved(gear):
    product, steps = gear
    shaft = steps["shaft"]
    (u,) = unresolved_causes(_outcome(penetration_m=1.5e-3), {"penetration"}, shaft, product,
                             (), FAST)
    assert u.code == "contact" and u.limit == FAST.impact_penetration_m
    assert unresolved_causes(_outcome(penetration_m=2.5e-3), {"penetration"}, shaft, product,
                             (), FAST) == ()
    assert unresolved_causes(_outcome(penetration_m=1.5e-3), {"penetration"}, shaft, product,
                             (), BALANCED) == ()


def test_an_unresolved_step_is_neither_a_success_nor_a_failure(gear):
    product, steps = gear
    (u,) = unresolved_causes(_outcome([JAM]), {"insertion_depth"}, steps["cover"], product,
                             COVER_SCENE, FAST, _record(0.0))
    res = StepResult(7, "cover", "insert", _outcome([JAM]), None, None, (),
                     {"insertion_depth": {"value": 3e-3, "limit": 5e-4, "ok": False}},
                     unresolved=(u,))
    assert not res.success and res.verdict == "unresolved"
    d = res.to_dict()
    assert d["success"] is False and d["unresolved"][0]["code"] == "fit"
    back = StepResult.from_dict(d)
    assert back.verdict == "unresolved" and back.unresolved == (u,)
    failed = dataclasses.replace(res, unresolved=())
    assert failed.verdict == "failed" and "unresolved" not in failed.to_dict()
