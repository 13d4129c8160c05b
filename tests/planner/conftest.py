"""Planner test fixtures: part geometry computed once per product and session."""

from __future__ import annotations

from pathlib import Path

import pytest

from asmplan.knowledge.loader import load_product
from asmplan.knowledge.model import Product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.partdata import PartData, part_data
from asmplan.planner.settings import PlannerSettings

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"

# the obvious feasible orders (the sequence planner is tested on its own)
ORDERS = {
    "pinhole_station": ["part1", "part2", "part3", "part4"],
    "peg_in_hole": ["block", "peg"],
    "gear_unit": ["base", "bearing_block", "shaft", "wheel", "collar", "post_1", "post_2", "cover"],
}


class GeometryCache:
    """ProductGeometry and PartData per (product name, collision level), built on demand."""

    def __init__(self) -> None:
        self.geometry: dict[str, ProductGeometry] = {}
        self.data: dict[tuple[str, str], dict[str, PartData]] = {}

    def geo(self, product: Product) -> ProductGeometry:
        return self.geometry.setdefault(product.name, ProductGeometry(product))

    def parts(self, product: Product, level: str = "convex") -> dict[str, PartData]:
        key = (product.name, level)
        if key not in self.data:
            geo = self.geometry.setdefault(product.name, ProductGeometry(product))
            self.data[key] = part_data(product, PlannerSettings(collision_level=level), geo)
        return self.data[key]


@pytest.fixture(scope="session")
def geometry_cache() -> GeometryCache:
    return GeometryCache()


@pytest.fixture(scope="session")
def blocked_product() -> Product:
    return load_product(FIXTURES / "blocked_product.yaml")
