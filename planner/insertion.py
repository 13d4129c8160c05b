"""How far a part must start before its seat: the whole engaged length, over every bore.

A mate's feature lengths say how deep a pin goes into ITS hole; they do not say how far the
moving part must stand off so that nothing of it is yet inside any bore it will pass. A shaft
pushed through two bearings and a gear starts with its tip before the FIRST bearing; a shaft
whose end sticks out past its bore (gear_unit's shaft, 10 mm beyond the bearing block) must
start with that end, not the feature's tip, before the mouth.

:func:`clearing_travel_m` measures it from the geometry: along the pin axis ``e`` (the pin
part moves along ``+e`` relative to the hole part), the leading point of the pin part's
material near the hole's axis (within the hole radius plus chamfer) must lie behind the
hole part's entry face near that axis:

    travel = max(p . e, p pin-part points near the axis) - min(q . e, q hole-part points near the axis)

both at the assembled poses. For a pin in a blind hole this is the pin length; for a shaft
through several bores, each mate gives its own travel and the largest is the one to plan.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..knowledge.model import Mate, Product


def clearing_travel_m(product: Product, mate: Mate, points_m: dict[str, np.ndarray],
                      margin_m: float = 1e-4) -> float:
    """Relative travel (m) along the mate axis that takes the pin part's material near the
    hole axis out of the hole part's bore, from the assembled poses.

    Parameters
    ----------
    product : Product
    mate : Mate
    points_m : dict part -> (n, 3) float array
        Points of each part in its own frame whose hull bounds it (mesh vertices), m.
    margin_m : float
        Added to the hole radius plus chamfer when selecting points near the axis, m.
    """
    pin = product.feature(mate.pin_part, mate.pin_feature)
    hole = product.feature(mate.hole_part, mate.hole_feature)
    T_pin = product.T_world_assembled(mate.pin_part)
    T_hole = product.T_world_assembled(mate.hole_part)
    e = T_pin[:3, :3] @ pin.axis
    o = T_hole[:3, :3] @ hole.origin_m + T_hole[:3, 3]
    radius = hole.diameter_m / 2 + hole.chamfer_m + margin_m

    def near(part: str, T: np.ndarray) -> np.ndarray:
        p = np.asarray(points_m[part], float) @ T[:3, :3].T + T[:3, 3]
        rel = p - o
        s = rel @ e
        radial = np.linalg.norm(rel - np.outer(s, e), axis=1)
        return s[radial <= radius]

    lead = near(mate.pin_part, T_pin)
    entry = near(mate.hole_part, T_hole)
    if not len(lead) or not len(entry):
        return 0.0
    return max(float(lead.max() - entry.min()), 0.0)




def clear_standoff_m(scene: Any, part: str, T_final: np.ndarray, direction: np.ndarray,
                     obstacles: Sequence[str], start_m: float, clearance_m: float = 1e-3,
                     step_m: float = 1e-3, limit_m: float = 0.2) -> float:
    """The pre-insertion distance (m, >= ``start_m``) at which ``part`` stands at least
    ``clearance_m`` from every obstacle, backing off along ``-direction`` from ``T_final``.

    A spacer dropped into a slot 0.1 mm wider than itself is still in the slot 15 mm above
    its seat: starting the straight (exactly checked) segment there left the free-space
    planner a 0.1 mm passage to find. Backing the start off until the part is clear of
    everything puts the whole narrow passage on the straight segment. ``scene`` is a
    :class:`asmplan.planner.motion.Scene`; ``start_m`` is returned when the part is clear
    there, or when it is not clear anywhere up to ``limit_m``.
    """
    u = np.asarray(direction, float)
    s = float(start_m)
    while s <= limit_m:
        T = np.array(T_final, float)
        T[:3, 3] -= u * s
        if scene.distance_bound([(part, T)], obstacles, enough=clearance_m) >= clearance_m:
            return s
        s += step_m
    return float(start_m)


__all__ = ["clear_standoff_m", "clearing_travel_m"]
