"""A sweep whose factors vary nothing reproduces `asmplan run` exactly: same plan, same
product, so the same verdict, reasons, failed criteria and outcome numbers (byte for byte in
JSON). Before, an unvaried clearance was replaced by its mean placed symmetrically about the
nominal size, and the bundled peg failed (slip 9.3 mm, 137 N) where `run` succeeds."""

from __future__ import annotations

import json
import math

import pytest

from asmplan.pipeline import RunSettings, run_product
from asmplan.sim import sweep as sw
from asmplan.sim.results import criteria_for
from tests.conftest import example_path

pytestmark = pytest.mark.slow


def test_the_unperturbed_sample_equals_run_byte_for_byte() -> None:
    run = run_product(example_path("peg_in_hole"), RunSettings(fidelity="balanced", workers=1))
    assert run.success  # the reference: the bundled peg goes in at balanced
    ps = sw.PlanSweep(run.product, run.plan, run.fidelity)
    spec = sw.SweepSpec(n_samples=1, vary=("friction",), friction_rel_sigma=0.0)
    (params,) = ps.samples(spec)
    same = sw.perturb_product(run.product, params)
    assert [(m.fit, m.clearance_min_m, m.clearance_max_m) for m in same.mates] == \
        [(m.fit, m.clearance_min_m, m.clearance_max_m) for m in run.product.mates]
    assert [p.friction for p in same.parts] == [p.friction for p in run.product.parts]
    value = sw.simulate_sample(ps, params)
    (k,) = ps.steps
    expected = run.results.steps[k]
    got = value["steps"][expected.part]
    assert got["success"] is True
    outcome = expected.outcome.to_dict()
    outcome.pop("wall_time_s", None)
    want = {"success": expected.success, "reasons": list(expected.reasons),
            "failed_criteria": list(expected.failed_criteria), "outcome": outcome}
    assert json.dumps({k: got[k] for k in want}, sort_keys=True) == json.dumps(want, sort_keys=True)
    assert not got["failures"]
    assert criteria_for(run.product) == criteria_for(same)


def test_the_bundled_peg_goes_in_at_small_pose_errors() -> None:
    """Issue 17's done-when: the bundled peg (H7/g6, 0.5 mm chamfer) swept with small robot
    errors at BALANCED succeeds at every sample; the capture boundary (half the mean clearance
    plus the chamfer, 0.51 mm) is 10-25x these offsets. It was a strict xfail: at 0.02 mm the
    peg 'jammed' 1.03 mm deep (slip 5.9-9.4 mm, 134-168 N), from a chamfer contact Bullet kept
    across the fit's 8.5 um radial gap (BALANCED's 25 um contact distance). Both offsets insert
    since the hold criterion (issue 18) changed the peg's grasp; the exact fit contact
    (sim/feature_contact.py) takes the pin's contact over during the insertion, so that
    chamfer contact across the gap no longer exists at BALANCED."""
    from asmplan.knowledge.loader import load_product
    from asmplan.parts.models import ProductGeometry
    from asmplan.planner.product import plan_product
    from asmplan.sim.fidelity import BALANCED

    product = load_product(example_path("peg_in_hole"))
    ps = sw.PlanSweep(product, plan_product(product, ProductGeometry(product)).plan, BALANCED)
    (params,) = ps.samples(sw.SweepSpec(n_samples=1, vary=()))
    hole = product.feature("block", "hole")
    capture_m = 0.5 * product.mates[0].clearance_mean_m + hole.chamfer_m
    offsets = ((0.02e-3, 0.0), (0.0, -0.05e-3))
    assert all(math.hypot(*e) < 0.1 * capture_m for e in offsets)
    samples = [sw.SampleParams(i, 0, params.clearance_m, params.friction,
                               {"peg": sw.PoseError(e)}) for i, e in enumerate(offsets)]
    results = [sw.simulate_sample(ps, s)["steps"]["peg"] for s in samples]
    assert [r["success"] for r in results] == [True, True], [r["reasons"] for r in results]
