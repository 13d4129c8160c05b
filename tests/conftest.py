"""Shared fixtures: the example products and the reference data beside the checkout."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

from asmplan.knowledge.loader import load_product
from asmplan.knowledge.model import Product

# Property tests draw the same examples on every run (CI must not pass or fail by chance);
# HYPOTHESIS_PROFILE=explore draws new random examples, to hunt for failures by hand.
settings.register_profile("deterministic", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "deterministic"))

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
SHARED = REPO.parent / "shared"
EXAMPLE_NAMES = ("peg_in_hole", "pinhole_station", "gear_unit")


def example_path(name: str) -> Path:
    return EXAMPLES / f"{name}.yaml"


@pytest.fixture(scope="session")
def examples() -> dict[str, Product]:
    """Every bundled example product, loaded once."""
    return {name: load_product(example_path(name)) for name in EXAMPLE_NAMES}


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--regen-golden", action="store_true",
                     help="rewrite tests/fixtures/golden/ from this checkout's outputs "
                          "(only when behaviour is meant to change)")
