"""A sweep whose factors vary nothing reproduces `asmplan run` exactly: same plan, same
product, so the same verdict, reasons, failed criteria and outcome numbers (byte for byte in
JSON). Before, an unvaried clearance was replaced by its mean placed symmetrically about the
nominal size, and the bundled peg failed (slip 9.3 mm, 137 N) where `run` succeeds."""

from __future__ import annotations

import json

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
