"""Geometric feasibility by assembly-by-disassembly: the (non-directional) blocking table.

For every part ``p`` and every candidate removal direction ``d`` (the six axis directions and
both senses of every mate axis of ``p``, in the world frame) the table holds, computed ONCE in
the fully assembled product, the set of parts that block ``p`` when it is swept along ``d``
far enough to clear the product's bounding box. In any partial assembly ``S`` (a set of part
names, ``p`` in ``S``), ``p`` can be the last part added, inserted along ``-d``, iff

    blockers(p, d) & S == {}   and the table does not block d.

This is exact for translations along the candidate directions as long as removing a part
along ``d`` in ``S`` meets only parts of ``S``, which holds because parts do not move once
placed. Feasibility of any subset is then a set operation, so planning is fast for products
of tens of parts (the collision checks are spent once, here).

Conventions
-----------
* A :class:`RemovalDirection` is the direction the part MOVES AWAY along when it is taken out
  of the assembly; the insertion direction of the step is its opposite (``insertion``).
* The work table (world plane z = 0) is an obstacle that is always present: a direction with a
  downward component that would carry the part below the table top is blocked by it.
* Pins sliding out of their holes along the mate axis do not block when the mate has a
  positive clearance: exact geometry lets the sweep pass (checked by the tests). For
  interference and transition fits the pin overlaps its hole in the nominal model, so the
  mate partner is dropped from the blockers along that mate's own axis (a press fit is
  inserted exactly along its axis); it still blocks every other direction.
* Support (for the stability check): the parts that would stop ``p`` from falling are the
  blockers of a short probe of ``p`` straight down; a part whose lowest point is within
  ``table_contact_m`` of the table rests on the table. The probe is ``support_probe_m``
  (0.1 mm) long, or, for a part with mates, as long as the largest lead-in of its mates (the
  hole's chamfer plus half the largest diametral clearance, :func:`capture_m`): a gear
  standing 0.2 mm above its ribs before the shaft arrives drops onto them and the shaft's
  chamfer still finds its bore, so the ribs hold it.

The geometry is reached through the small :class:`GeometryOracle` protocol (bounding boxes and
``blockers(part, direction, distance_m)``); :class:`asmplan.planner.fcl_oracle.FclOracle`
implements it with FCL collision models from :mod:`asmplan.parts`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..knowledge.model import Product

AXES: tuple[tuple[str, tuple[float, float, float]], ...] = (
    ("+x", (1.0, 0.0, 0.0)), ("-x", (-1.0, 0.0, 0.0)),
    ("+y", (0.0, 1.0, 0.0)), ("-y", (0.0, -1.0, 0.0)),
    ("+z", (0.0, 0.0, 1.0)), ("-z", (0.0, 0.0, -1.0)),
)
_SAME_DIRECTION_COS = 1.0 - 1e-9


def direction_label(vector: np.ndarray) -> str:
    """``"+x"`` for an axis direction, else the rounded components, e.g. ``"(0.71,0,-0.71)"``."""
    v = np.asarray(vector, dtype=float)
    for label, axis in AXES:
        if float(np.dot(v, axis)) >= _SAME_DIRECTION_COS:
            return label
    return "(" + ",".join(f"{c:.2g}" for c in v) + ")"


@dataclass(frozen=True, eq=False)
class RemovalDirection:
    """A direction along which a part is taken out of the assembly, in the world frame.

    Parameters
    ----------
    vector : (3,) float array
        Unit removal direction in the world frame.
    mates : tuple of str
        Names of the mates of the part whose axis is along this direction (either sense).
    """

    vector: np.ndarray
    mates: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        v = np.array(self.vector, dtype=float)
        norm = float(np.linalg.norm(v)) if v.shape == (3,) else 0.0
        if v.shape != (3,) or norm == 0.0 or not np.all(np.isfinite(v)):
            raise ValueError(f"RemovalDirection.vector: expected a non-zero finite (3,) vector, "
                             f"found {v.tolist()}")
        v = v / norm
        v.setflags(write=False)
        object.__setattr__(self, "vector", v)

    @property
    def insertion(self) -> np.ndarray:
        """The insertion direction of a step using this direction, (3,) unit world vector."""
        return -self.vector

    @property
    def label(self) -> str:
        """Removal direction as ``"+x"`` or components."""
        return direction_label(self.vector)

    @property
    def insertion_label(self) -> str:
        """Insertion direction as ``"-x"`` or components."""
        return direction_label(-self.vector)


def mate_insertion_direction(product: Product, mate_name: str, part: str) -> np.ndarray:
    """World insertion direction (3,) of ``part`` onto its partner in mate ``mate_name``.

    The pin's part moves along the pin axis (root to tip); the hole's part moves along the
    hole axis (its outward normal), which is minus the pin axis (see the model docstring).
    """
    mate = next(m for m in product.mates if m.name == mate_name)
    if part == mate.pin_part:
        feature = product.feature(mate.pin_part, mate.pin_feature)
    elif part == mate.hole_part:
        feature = product.feature(mate.hole_part, mate.hole_feature)
    else:
        raise KeyError(f'part "{part}" is not in mate "{mate_name}" '
                       f"({mate.pin_part} into {mate.hole_part})")
    R = product.T_world_assembled(part)[:3, :3]
    v = R @ feature.axis
    return v / np.linalg.norm(v)


def candidate_directions(product: Product, part: str) -> tuple[RemovalDirection, ...]:
    """The six axis directions, then both senses of every mate axis not already listed.

    Mates are attached to every direction parallel to their axis (either sense).
    """
    vectors: list[np.ndarray] = [np.array(axis) for _label, axis in AXES]
    for mate in sorted(product.mates, key=lambda m: m.name):
        if part not in (mate.pin_part, mate.hole_part):
            continue
        ins = mate_insertion_direction(product, mate.name, part)
        for v in (-ins, ins):
            if not any(float(np.dot(v, w)) >= _SAME_DIRECTION_COS for w in vectors):
                vectors.append(v)
    hint = product.part(part).handling.insertion_direction
    if product.placed_by(part) is not None and hint is not None:  # the operation's own axis
        v = -np.asarray(hint, dtype=float) / float(np.linalg.norm(hint))
        if not any(float(np.dot(v, w)) >= _SAME_DIRECTION_COS for w in vectors):
            vectors.append(v)
    out = []
    for v in vectors:
        names = tuple(sorted(
            m.name for m in product.mates if part in (m.pin_part, m.hole_part)
            and abs(float(np.dot(v, mate_insertion_direction(product, m.name, part))))
            >= _SAME_DIRECTION_COS))
        out.append(RemovalDirection(v, names))
    return tuple(out)


class GeometryOracle(Protocol):
    """What the planner needs from geometry, in the assembled product (world frame)."""

    def bounds(self, part: str) -> np.ndarray:
        """Axis-aligned bounding box of ``part`` assembled: ``[[xmin, ymin, zmin], [xmax, ...]]``,
        shape (2, 3), m."""
        ...

    def blockers(self, part: str, direction: np.ndarray, distance_m: float) -> frozenset[str]:
        """Parts (other than ``part``) hit when ``part`` is translated by up to ``distance_m``
        along the unit world ``direction`` (3,) from its assembled pose, all others in place.
        Touching contacts at the start do not count."""
        ...


def clearing_distance_m(part_bounds: np.ndarray, product_bounds: np.ndarray,
                        direction: np.ndarray, margin_m: float) -> float:
    """Shortest translation along ``direction`` after which the part's box no longer overlaps
    the product's box (on at least one axis), plus ``margin_m``; m."""
    best = np.inf
    for i in range(3):
        di = float(direction[i])
        if abs(di) < 1e-12:
            continue
        gap = (product_bounds[1, i] - part_bounds[0, i]) / di if di > 0 else \
            (product_bounds[0, i] - part_bounds[1, i]) / di
        best = min(best, max(gap, 0.0))
    return float(best) + margin_m


@dataclass(frozen=True, eq=False)
class BlockingTable:
    """Blocking sets of every part along every candidate direction, in the full assembly.

    Parameters
    ----------
    parts : tuple of str
        Part names, product order.
    directions : dict part -> tuple of RemovalDirection
    blockers : dict part -> tuple of frozenset of str
        Aligned with ``directions[part]``.
    table_blocked : dict part -> tuple of bool
        Aligned with ``directions[part]``: True when the work table is in the way.
    supporters : dict part -> frozenset of str
        Parts that stop ``part`` from falling (blockers of a short downward probe).
    on_table : dict part -> bool
        True when the part rests on the work table.
    bounds : dict part -> (2, 3) float array
        Assembled world AABBs, m.
    """

    parts: tuple[str, ...]
    directions: dict[str, tuple[RemovalDirection, ...]]
    blockers: dict[str, tuple[frozenset[str], ...]]
    table_blocked: dict[str, tuple[bool, ...]]
    supporters: dict[str, frozenset[str]]
    on_table: dict[str, bool]
    bounds: dict[str, np.ndarray]

    def __post_init__(self) -> None:
        for p in self.parts:
            n_dirs, n_block = len(self.directions[p]), len(self.blockers[p])
            if n_dirs != n_block or n_dirs != len(self.table_blocked[p]):
                raise ValueError(f'BlockingTable: part "{p}": expected one blocker set and one '
                                 f"table flag per direction ({n_dirs}), found {n_block} and "
                                 f"{len(self.table_blocked[p])}")

    def as_dict(self) -> dict[str, list[dict[str, object]]]:
        """JSON-safe: per part, per direction, removal/insertion labels and blockers."""
        return {p: [{"removal": d.label, "insertion": d.insertion_label,
                     "vector": [round(float(c), 6) for c in d.vector], "mates": list(d.mates),
                     "blockers": sorted(b) + (["table"] if t else [])}
                    for d, b, t in zip(self.directions[p], self.blockers[p],
                                       self.table_blocked[p], strict=True)]
                for p in self.parts}


def capture_m(product: Product, part: str) -> float:
    """The largest lead-in (m) of ``part``'s mates: hole chamfer plus half the largest
    diametral clearance. A part resting that much lower than its seat is still caught by its
    mate's chamfer when its partner comes."""
    out = 0.0
    for m in product.mates:
        if part in (m.pin_part, m.hole_part):
            hole = product.feature(m.hole_part, m.hole_feature)
            out = max(out, hole.chamfer_m + max(m.clearance_max_m, 0.0) / 2)
    return out


def _operation_seat_cleared(product: Product, part: str, dirs: tuple[RemovalDirection, ...],
                            blocks: list[frozenset[str]]) -> list[frozenset[str]]:
    """A part placed by another operation along its declared ``handling.insertion_direction``
    (a tenon into its mortise, a bearing pressed flush): the parts that block it in every
    direction are its seat, which that operation enters (a line-to-line joint the sweep meets
    at zero depth); along the declared direction they do not block it (as a press fit's
    partner along the fit's axis). Other parts still block it there."""
    hint = product.part(part).handling.insertion_direction
    if product.placed_by(part) is None or hint is None or not blocks:
        return blocks
    seat = frozenset.intersection(*blocks)
    h = np.asarray(hint, dtype=float) / float(np.linalg.norm(hint))
    return [b - seat if float(np.dot(d.insertion, h)) >= _SAME_DIRECTION_COS else b
            for d, b in zip(dirs, blocks, strict=True)]


def blocking_table(product: Product, oracle: GeometryOracle, *, support_probe_m: float = 1.0e-4,
                   table_contact_m: float = 1.0e-4, margin_m: float = 1.0e-3) -> BlockingTable:
    """Sweep every part along every candidate direction in the full assembly.

    Parameters
    ----------
    product : the product (assembled poses, mates).
    oracle : geometry (see :class:`GeometryOracle`).
    support_probe_m : length of the downward probe that finds a part's supporters, m (at
        least; a part with mates is probed over its largest lead-in, :func:`capture_m`).
    table_contact_m : a part whose lowest point is at most this high rests on the table, m.
    margin_m : extra sweep length beyond the product's bounding box, m.
    """
    names = product.part_names
    bounds = {p: np.asarray(oracle.bounds(p), dtype=float) for p in names}
    all_b = np.stack(list(bounds.values()))
    product_bounds = np.stack([all_b[:, 0, :].min(axis=0), all_b[:, 1, :].max(axis=0)])
    non_clearance = {m.name: m for m in product.mates if m.kind != "clearance"}
    directions, blockers, table, supporters, on_table = {}, {}, {}, {}, {}
    for p in names:
        dirs = candidate_directions(product, p)
        blocks, tabs = [], []
        for d in dirs:
            dist = clearing_distance_m(bounds[p], product_bounds, d.vector, margin_m)
            b = set(oracle.blockers(p, d.vector, dist)) - {p}
            for mname in d.mates:
                if mname in non_clearance:  # press fit: inserted along its own axis
                    m = non_clearance[mname]
                    b.discard(m.hole_part if p == m.pin_part else m.pin_part)
            blocks.append(frozenset(b))
            # the table top z = 0: reached when the part's lowest point goes below it
            dz = float(d.vector[2])
            tabs.append(dz < -1e-9 and bounds[p][0, 2] + dz * dist < -table_contact_m)
        blocks = _operation_seat_cleared(product, p, dirs, blocks)
        directions[p], blockers[p], table[p] = dirs, tuple(blocks), tuple(tabs)
        on_table[p] = bool(bounds[p][0, 2] <= table_contact_m)
        probe = max(support_probe_m, capture_m(product, p))
        supporters[p] = frozenset(oracle.blockers(p, np.array([0.0, 0.0, -1.0]), probe)) - {p}
    return BlockingTable(names, directions, blockers, table, supporters, on_table, bounds)


__all__ = [
    "AXES",
    "BlockingTable",
    "GeometryOracle",
    "RemovalDirection",
    "blocking_table",
    "candidate_directions",
    "capture_m",
    "clearing_distance_m",
    "direction_label",
    "mate_insertion_direction",
]
