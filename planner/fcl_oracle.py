"""The sequence planner's geometry from FCL: :class:`FclOracle` on :mod:`asmplan.parts`.

Implements :class:`asmplan.planner.blocking.GeometryOracle` with a
:class:`asmplan.parts.collision.CollisionWorld` of every part at its assembled pose, built by
:class:`asmplan.parts.models.ProductGeometry`. It does not import fcl itself.

Level of detail: ``convex`` -- exact convex pieces (holes as polygons whose inscribed
circle is the fitted hole, pins as exact cylinders at their fitted diameter), so a sweep is
exact (each piece's swept volume is one convex hull) and a pin with a positive clearance
slides out of its hole along the mate axis without touching. Mesh-file parts are their
convex sectors (or hull) at this level; any BVH mesh left is stepped, with the step tied to
the clearance: the smallest positive built radial clearance of the product's mates, clamped
to ``[min_step_m, max_step_m]``, so a pin cannot skip across its hole wall between checks.

By default the convex pieces are built without the error measurement that
:meth:`ProductGeometry.collision_model` runs (about 1 s per part; the sweeps need the
pieces, not the report): the pieces ``ProductGeometry.collision_model(part, "convex",
measured=False)`` caches, so the motion planner reuses them and their FCL geometry; pass
``measured=True`` to use (and cache) the measured models instead.

Resting contacts: a part that rests on a support within micrometres (a gear 6 um above two
ribs) may overlap it in the convex model, whose circumscribed polygons stand up to a few
micrometres proud of the true surface, while ``asmplan check`` (exact) sees a gap. A start
overlap of at most ``resting_tolerance_m`` is therefore a resting contact: it blocks only the
directions that deepen it (into the support), not lifting off or sliding along it
(:meth:`asmplan.parts.collision.CollisionWorld.sweep_blockers`, ``resting_m``).

Sweeps start with a broad phase of their own: a part is swept only against the parts whose
boxes meet its swept box, and not at all when there are none.
"""

from __future__ import annotations

import numpy as np

from ..knowledge.model import Product
from ..parts.collision import CollisionWorld
from ..parts.models import ProductGeometry
from ..parts.pieces import CollisionModel


def unmeasured_convex_model(geometry: ProductGeometry, part: str) -> CollisionModel:
    """``part``'s convex-level model as :class:`ProductGeometry` builds it, without the
    error measurement (``hausdorff_m`` and ``hole_clearance_error_m`` left at 0)."""
    raw = geometry.collision_model(part, "convex", measured=False)  # the same pieces, cached
    return CollisionModel("convex", raw.pieces, notes=(*raw.notes, "error not measured"))


class FclOracle:
    """Blocking sweeps and bounding boxes in the assembled product, through FCL.

    Parameters
    ----------
    product : Product
    geometry : ProductGeometry, optional
        Shared geometry cache (default: a new one for ``product``).
    measured : bool
        Use :meth:`ProductGeometry.collision_model` (measured errors, slow) instead of the
        unmeasured convex pieces.
    tolerance_m : float
        Penetration depth ignored as touching, m (default 1 um).
    resting_tolerance_m : float
        Largest start overlap treated as a resting contact, m (default 20 um, the motion
        planner's contact tolerance; 0 turns resting contacts off).
    min_step_m, max_step_m : float
        Bounds of the BVH mesh step, m.
    """

    def __init__(self, product: Product, geometry: ProductGeometry, *,
                 measured: bool = False, tolerance_m: float = 1e-6,
                 min_step_m: float = 5e-6, max_step_m: float = 1e-4,
                 resting_tolerance_m: float = 2e-5):
        if not tolerance_m >= 0:
            raise ValueError(f"tolerance_m: expected >= 0, found {tolerance_m!r}")
        if not resting_tolerance_m >= 0:
            raise ValueError(f"resting_tolerance_m: expected >= 0, found {resting_tolerance_m!r}")
        self.resting_tolerance_m = resting_tolerance_m
        if not 0 < min_step_m <= max_step_m:
            raise ValueError(f"min_step_m, max_step_m: expected 0 < min <= max, found "
                             f"{min_step_m!r}, {max_step_m!r}")
        self.product = product
        self.geometry = geometry
        self.tolerance_m = tolerance_m
        self.world = CollisionWorld(self.geometry.fcl_shapes)
        for name in product.part_names:
            model = (self.geometry.collision_model(name, "convex") if measured
                     else unmeasured_convex_model(self.geometry, name))
            self.world.add(name, model, product.T_world_assembled(name))
        self._boxes = {name: self.world.aabb(name) for name in product.part_names}
        radial = [c for c in self.geometry.sizing.radial_clearance_m.values() if c > 0]
        self.step_m = float(np.clip(min(radial), min_step_m, max_step_m)) if radial else max_step_m
        self.sweeps = 0

    def bounds(self, part: str) -> np.ndarray:
        """World AABB (2, 3) of ``part`` assembled, m."""
        return self.world.aabb(part)

    def blockers(self, part: str, direction: np.ndarray, distance_m: float) -> frozenset[str]:
        """Parts hit by ``part`` swept ``distance_m`` along unit ``direction`` (3,), world."""
        box = self._boxes[part]
        delta = np.asarray(direction, dtype=float) * distance_m
        lo = np.minimum(box[0], box[0] + delta)
        hi = np.maximum(box[1], box[1] + delta)
        near = [q for q, b in self._boxes.items()
                if q != part and np.all(b[0] <= hi) and np.all(lo <= b[1])]
        if not near:
            return frozenset()
        self.sweeps += 1
        return frozenset(self.world.sweep_blockers(part, direction, distance_m, others=near,
                                                   step_m=self.step_m, tolerance_m=self.tolerance_m,
                                                   resting_m=self.resting_tolerance_m))


__all__ = ["FclOracle", "unmeasured_convex_model"]
