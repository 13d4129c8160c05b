"""The embedded seed table of bench.scenarios is the project's transcription of the
paper's Table 4 (shared/reference/clamp_cycle_seed.csv), phase by phase."""

from __future__ import annotations

import pytest
from sim_scenes import SEED_CSV

from asmplan.planner.trajectory import parse_phase_table, read_phase_table
from bench.scenarios import SEED_PHASE_TABLE_CSV


def test_embedded_seed_table_equals_the_shared_transcription():
    if not SEED_CSV.exists():
        pytest.skip(f"{SEED_CSV} is not beside the checkout")
    assert parse_phase_table(SEED_PHASE_TABLE_CSV) == read_phase_table(SEED_CSV)
