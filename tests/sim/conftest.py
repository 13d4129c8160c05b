"""Shared, expensive simulator runs (computed once per session)."""

from __future__ import annotations

import pytest
from sim_scenes import run_seed_cycle

from asmplan.sim.fidelity import preset


@pytest.fixture(scope="session")
def seed_runs():
    """The seed clamp cycle at every preset: name -> (StepRecord, StepOutcome, Trajectory)."""
    return {name: run_seed_cycle(preset(name)) for name in ("fast", "balanced", "accurate")}
