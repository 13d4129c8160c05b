"""Shared fixtures: the example products and the reference data beside the checkout."""

from __future__ import annotations

from pathlib import Path

import pytest

from asmplan.knowledge.loader import load_product
from asmplan.knowledge.model import Product

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
