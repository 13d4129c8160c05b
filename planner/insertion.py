"""Insertion geometry: the direction, engaged length and mated hole regions of a part going into
the partial assembly, which contacts along an insertion are excused, and how far the part must
start before its seat.

How far a part must start before its seat: the whole engaged length, over every bore.

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

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..knowledge.frames import invert
from ..knowledge.model import Mate, Product
from .errors import (
    CollidingPair,
    NoPathError,
)

_Z = np.array([0.0, 0.0, 1.0])
_HOLE_REGION_TOL_M = 2e-4

if TYPE_CHECKING:
    from .partdata import PartData


@dataclass(frozen=True, eq=False)
class HoleRegion:
    """The cylinder of a mated hole, where pin-in-hole contact may be excused.

    ``origin_m`` and ``axis`` are in the frame of ``hole_part`` (axis: outward normal of the
    mouth); the region spans ``-depth_m <= s <= chamfer`` along the axis and radius
    ``radius_m``.
    """

    mate: str
    pin_part: str
    hole_part: str
    origin_m: np.ndarray
    axis: np.ndarray
    radius_m: float
    depth_m: float
    chamfer_m: float
    clearance_min_m: float

    def contains(self, point_world: np.ndarray, T_world_hole_part: np.ndarray) -> bool:
        p = invert(T_world_hole_part) @ np.append(point_world, 1.0)
        rel = p[:3] - self.origin_m
        s = float(rel @ self.axis)
        radial = float(np.linalg.norm(rel - s * self.axis))
        tol = _HOLE_REGION_TOL_M
        return (-self.depth_m - tol <= s <= self.chamfer_m + tol
                and radial <= self.radius_m + self.chamfer_m + tol)


@dataclass(frozen=True, eq=False)
class InsertionSpec:
    """How a part goes in: direction (unit, world), engaged length (m), mates, hole regions."""

    kind: Literal["insert", "place"]
    direction: np.ndarray
    length_m: float
    mates: tuple[str, ...]
    regions: tuple[HoleRegion, ...]
    radial_clearance_min_m: float


def mate_engagement_m(product: Product, m: Mate, parts: dict[str, PartData] | None = None
                      ) -> float:
    """How far the pin part of mate ``m`` travels engaged: the pin's engagement in its hole,
    or with ``parts`` (part geometry) the travel that takes it out of the bore when that is
    longer by more than mesh noise (:func:`clearing_travel_m`), m."""
    pin = product.feature(m.pin_part, m.pin_feature)
    hole = product.feature(m.hole_part, m.hole_feature)
    engaged = pin.length_m if (hole.through or hole.length_m <= 0) \
        else min(pin.length_m, hole.length_m)
    if parts is not None:  # beyond the feature's engagement by more than mesh noise
        travel = clearing_travel_m(product, m, {n: parts[n].points_m
                                                for n in (m.pin_part, m.hole_part)})
        engaged = travel if travel > engaged + 1e-6 else engaged
    return float(engaged)


def insertion_spec(product: Product, part: str, placed: Sequence[str],
                   fallback_direction: np.ndarray | None = None, step: int = 0,
                   parts: dict[str, PartData] | None = None) -> InsertionSpec:
    """The insertion of ``part`` into the partial assembly ``placed``.

    The engaged length is the longest pin engagement, or with ``parts`` (part geometry) the
    longest travel that takes the part out of every bore it passes
    (:func:`asmplan.planner.insertion.clearing_travel_m`: a shaft through two bearings starts
    before the first).

    The direction is the pin axis in the world when ``part`` carries the pin, minus it when
    ``part`` carries the hole; every mate with a placed part must agree. Without such a mate
    the part is placed along its handling's ``insertion_direction``, else
    ``fallback_direction``, else straight down.
    """
    placed_set = set(placed)
    dirs: list[np.ndarray] = []
    names: list[str] = []
    regions: list[HoleRegion] = []
    length = 0.0
    clear = math.inf
    for m in product.mates:
        if not ((m.pin_part == part and m.hole_part in placed_set)
                or (m.hole_part == part and m.pin_part in placed_set)):
            continue
        pin = product.feature(m.pin_part, m.pin_feature)
        hole = product.feature(m.hole_part, m.hole_feature)
        axis_w = product.T_world_assembled(m.pin_part)[:3, :3] @ pin.axis
        dirs.append(axis_w if m.pin_part == part else -axis_w)
        names.append(m.name)
        length = max(length, mate_engagement_m(product, m, parts))
        depth = max(hole.length_m, pin.length_m)
        regions.append(HoleRegion(m.name, m.pin_part, m.hole_part, np.asarray(hole.origin_m),
                                  np.asarray(hole.axis), hole.diameter_m / 2, depth,
                                  hole.chamfer_m, m.clearance_min_m))
        clear = min(clear, max(m.clearance_min_m, 0.0) / 2)
    if not dirs:
        h = product.part(part).handling.insertion_direction
        d = h if h is not None else fallback_direction if fallback_direction is not None else -_Z
        d = np.asarray(d, float) / np.linalg.norm(d)
        return InsertionSpec("place", d, 0.0, (), (), math.inf)
    u = dirs[0]
    for d, n in zip(dirs[1:], names[1:], strict=True):
        if float(np.dot(d, u)) < 1.0 - 1e-6:
            raise NoPathError(step, part, np.zeros((0, 4, 4)),
                              f"mates {names[0]} and {n} need different insertion directions "
                              f"({np.round(u, 4).tolist()} and {np.round(d, 4).tolist()})")
    return InsertionSpec("insert", u / np.linalg.norm(u), float(length), tuple(names),
                         tuple(regions), float(clear))



def unexcused(pairs: Sequence[CollidingPair], spec: InsertionSpec, part: str,
              T_part: np.ndarray, poses: dict[str, np.ndarray]) -> list[CollidingPair]:
    """The contacts of moving ``part`` (at ``T_part``) that are not excused: a contact with a
    mate partner is excused only inside the mated hole's region and only when the mate's
    clearance is >= 0. ``poses`` gives the other parts' poses."""
    out = []
    for p in pairs:
        other = other_body(p, part)
        excused = False
        for r in spec.regions:
            if {r.pin_part, r.hole_part} != {part, other} or r.clearance_min_m < 0:
                continue
            T_hole = T_part if r.hole_part == part else poses[r.hole_part]
            if p.point_m is not None and r.contains(np.asarray(p.point_m), T_hole):
                excused = True
                break
        if not excused:
            out.append(p)
    return out


def other_body(p: CollidingPair, name: str) -> str:
    return p.b if p.a == name else p.a


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
