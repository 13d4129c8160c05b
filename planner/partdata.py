"""What motion planning needs of each part (collision models, grasp surface, mass), from the
product's shared geometry.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from ..knowledge.model import Product
from ..parts.models import ProductGeometry
from ..parts.pieces import CollisionModel, LevelOfDetail
from .grasp import GraspSurface
from .settings import PlannerSettings


@dataclass(frozen=True, eq=False)
class PartData:
    """What motion planning needs of one part: its collision model at the planning level and
    its coarse model (one convex piece containing it), surface samples for grasps, mass (kg)
    and centre of mass (part frame, m)."""

    name: str
    model: CollisionModel
    coarse: CollisionModel
    surface: GraspSurface
    mass_kg: float
    com_m: np.ndarray
    points_m: np.ndarray  # (n, 3) points whose hull bounds the part, part frame


def part_data(product: Product, settings: PlannerSettings, geometry: ProductGeometry
              ) -> dict[str, PartData]:
    """:class:`PartData` of every part, from :class:`asmplan.parts.models.ProductGeometry`."""
    geo = geometry
    out = {}
    for k, part in enumerate(product.parts):
        mesh = geo.mesh(part.name)
        mp = geo.mass_properties(part.name)
        # the planner uses the pieces only: measuring their error (~0.1-1 s per part) is left
        # to the commands that show it
        model = geo.collision_model(part.name, cast(LevelOfDetail, settings.collision_level),
                                    measured=False)
        coarse = geo.collision_model(part.name, "coarse", measured=False)
        surface = GraspSurface.from_mesh(mesh, mp.com_m, settings.surface_samples,
                                         settings.seed + 7919 * k, part.geometry.kind)
        out[part.name] = PartData(part.name, model, coarse, surface, float(mp.mass_kg),
                                  np.asarray(mp.com_m, float), np.asarray(mesh.vertices, float))
    return out

