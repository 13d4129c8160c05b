"""The cell's declared regrasp fixtures (``resources.regrasp``) in a step's simulated scene.

A regrasp fixture is a static body on the table, like the table itself: the planner put a part
into it (a "regrasp" step) or picks the part from it. :func:`fixture_bodies` gives every
fixture's pieces and pose (the scene adds them as static bodies of role ``fixture``), and
:func:`carried_by_fixture` says whether a part at a pose rests in or on one, so the scene does
not build a tray nest under it (the fixture, not a nest, carries it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..knowledge.model import Product
from ..parts.cell import regrasp_fixture_body, regrasp_fixture_model
from ..parts.collision import CollisionWorld
from ..parts.pieces import ConvexPiece

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry

_SEAT_MATCH_M = 1e-9
"""A pose this close to a fixture's seat (position, and rotation entries) is in the seat."""


@dataclass(frozen=True, eq=False)
class FixtureBody:
    """One regrasp fixture as a static body: its scene name (``fixture:<name>``), pose (4, 4),
    exact pieces (fixture frame) and friction."""

    name: str
    T_world_body: np.ndarray
    pieces: tuple[ConvexPiece, ...]
    friction: float


def fixture_bodies(product: Product) -> list[FixtureBody]:
    """Every declared regrasp fixture of the product's cell, in file order."""
    return [FixtureBody(regrasp_fixture_body(fx.name), np.asarray(fx.T_world_fixture, float),
                        regrasp_fixture_model(fx).pieces, float(fx.friction))
            for fx in product.resources.regrasp]


def carried_by_fixture(product: Product, geometry: ProductGeometry, part: str,
                       T_world_part: np.ndarray, touch_m: float) -> str | None:
    """The body name of the regrasp fixture that holds ``part`` at ``T_world_part`` (the pose
    is one of its seats, or the part's convex model comes within ``touch_m`` of it), else
    None."""
    fixtures = product.resources.regrasp
    if not fixtures:
        return None
    for fx in fixtures:
        T = fx.T_world_seat(part)
        if T is not None and np.abs(T - T_world_part).max() <= _SEAT_MATCH_M:
            return regrasp_fixture_body(fx.name)
    world = CollisionWorld(geometry.fcl_shapes)
    world.add(part, geometry.collision_model(part, "convex", measured=False), T_world_part)
    for fx in fixtures:
        name = regrasp_fixture_body(fx.name)
        world.add(name, regrasp_fixture_model(fx), np.asarray(fx.T_world_fixture, float))
        if world.distance(part, name) <= touch_m:
            return name
    return None
