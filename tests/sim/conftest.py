"""Shared, expensive simulator runs (computed once per session)."""

from __future__ import annotations

import pytest

from asmplan.sim.fidelity import preset
from bench.scenarios import run_seed_cycle


@pytest.fixture(scope="session")
def seed_runs():
    """The seed clamp cycle at every preset: name -> (StepRecord, StepOutcome, Trajectory)."""
    return {name: run_seed_cycle(preset(name)) for name in ("fast", "balanced", "accurate")}
