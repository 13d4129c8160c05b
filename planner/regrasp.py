"""Where to put a part down to grasp it again: stable poses on a free area of the table.

A part whose every grasp collides either where it lies (its tray pose) or where it goes (its
assembled pose) is picked with a grasp that is free where it lies, put down on the table in
another stable orientation, and picked again with a grasp that is free where it goes (a sleeve
lying flat that must go into a vertical bore: put down upright, picked from above). The
motion of both legs is planned and proven like any other step by
:class:`asmplan.planner.motion.MotionPlanner`; this module only proposes the poses.

Orientations
------------
The part's assembled orientation first (then the grasp that inserts it also picks it, seen
from the same side), then every orientation that puts one of the part frame's six axis
directions straight down, turned as little as possible from the assembled one. An orientation
that puts down the same side as the start pose is skipped (it cannot free a grasp that the
table blocked there). An orientation is kept only if it is stable: the centre of mass lies
inside the support polygon (the hull of the points within ``SUPPORT_BAND_M`` of the lowest
one) far enough that the part tips only beyond ``MIN_TIP_ANGLE_RAD``.

Positions
---------
Grid points of the table (``step_m``) in order of distance from the part's start position;
the part's footprint there must keep ``clearance_m`` (room for the open fingers) from every
other body and from the part's own start footprint (a nest may hold it there), and stay on
the table.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from ..knowledge.frames import rotation_between

SUPPORT_BAND_M = 5e-5
"""Points this close to a part's lowest point carry it on the table, m."""
MIN_TIP_ANGLE_RAD = math.radians(10.0)
"""A part put down must be tilted at least this much before it tips over its support
polygon's nearest edge (``atan(margin / height of the centre of mass)``): a disc on its rim or
a cylinder on the line of its flank is not put down."""


@dataclass(frozen=True, eq=False)
class RegraspPose:
    """A pose to put a part down on the table and pick it again.

    Parameters
    ----------
    T_world_part : (4, 4) float array
        The part's pose, world frame, m; its lowest point on the table (z = 0).
    down_axis_part : (3,) float array
        The part-frame direction that points down.
    stability_margin_m : float
        Distance of the centre of mass inside the support polygon, m.
    """

    T_world_part: np.ndarray
    down_axis_part: np.ndarray
    stability_margin_m: float

    def describe(self) -> str:
        d = np.round(self.down_axis_part, 3).tolist()
        p = np.round(self.T_world_part[:3, 3] * 1e3, 1).tolist()
        return (f"put down at {p} mm with its part-frame axis {d} down "
                f"(centre of mass {self.stability_margin_m * 1e3:.1f} mm inside its footing)")


def _cross2(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _hull_2d(pts: np.ndarray) -> np.ndarray:
    """Convex hull (counter-clockwise, (k, 2)) of 2-D points (Andrew's monotone chain)."""
    p = np.unique(np.round(pts, 9), axis=0)
    if len(p) < 3:
        return p
    p = p[np.lexsort((p[:, 1], p[:, 0]))]

    def half(points: np.ndarray) -> list[np.ndarray]:
        out: list[np.ndarray] = []
        for q in points:
            while len(out) >= 2 and _cross2(out[-1] - out[-2], q - out[-2]) <= 0:
                out.pop()
            out.append(q)
        return out

    lower, upper = half(p), half(p[::-1])
    return np.array(lower[:-1] + upper[:-1])


def _inside_margin(hull: np.ndarray, q: np.ndarray) -> float:
    """Signed distance of ``q`` inside the convex polygon ``hull`` (negative outside)."""
    if len(hull) < 3:
        return -math.inf
    d = math.inf
    for i in range(len(hull)):
        a, b = hull[i], hull[(i + 1) % len(hull)]
        e = b - a
        n = float(np.linalg.norm(e))
        if n == 0:
            continue
        d = min(d, _cross2(e, q - a) / n)
    return d


def stable_orientations(points_part: np.ndarray, com_part: np.ndarray, R_assembled: np.ndarray,
                        R_start: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Stable resting orientations to put the part down in (see the module docstring).

    Parameters
    ----------
    points_part : (n, 3) float array
        Points whose hull is the part, part frame, m.
    com_part : (3,) float array
        Centre of mass, part frame, m.
    R_assembled, R_start : (3, 3) float arrays
        The part's orientation at its assembled and start poses.

    Returns
    -------
    list of (R_world_part (3, 3), down_axis_part (3,), stability margin m)
    """
    down = np.array([0.0, 0.0, -1.0])
    start_down = R_start.T @ down
    cands = [R_assembled]
    for axis in (*np.eye(3), *(-np.eye(3))):
        # turn the assembled orientation so that this axis points down
        cands.append(np.asarray(rotation_between(R_assembled @ axis, down), float) @ R_assembled)
    out: list[tuple[np.ndarray, np.ndarray, float]] = []
    for R in cands:
        d_part = R.T @ down
        if float(d_part @ start_down) > 1 - 1e-6:
            continue  # the same side down as where it lies: nothing gained
        if any(float(d_part @ o[1]) > 1 - 1e-6 for o in out):
            continue
        w = points_part @ R.T
        z0 = float(w[:, 2].min())
        foot = w[w[:, 2] <= z0 + SUPPORT_BAND_M][:, :2]
        hull = _hull_2d(foot)
        c = (R @ com_part)[:2]
        margin = _inside_margin(hull, c)
        height = float((R @ com_part)[2]) - z0
        if margin <= 0 or math.atan2(margin, height) < MIN_TIP_ANGLE_RAD:
            continue
        out.append((R, d_part, margin))
    return out


def free_positions(footprint_xy: np.ndarray, start_xy: np.ndarray, avoid_boxes: np.ndarray,
                   table_half_m: np.ndarray, clearance_m: float, step_m: float,
                   limit: int) -> Iterator[np.ndarray]:
    """Table positions (x, y) of the part's reference point, nearest ``start_xy`` first, where
    its footprint (plus ``clearance_m``) is clear of ``avoid_boxes`` and on the table.

    Parameters
    ----------
    footprint_xy : (2, 2) float array
        The footprint's min and max corners relative to the reference point, m.
    start_xy : (2,) float array
        The part's start position, m.
    avoid_boxes : (k, 2, 2) float array
        Footprints (min, max corners, world xy) to keep ``clearance_m`` from, m.
    table_half_m : (2,) float array
        Half the table's size, m (the table is centred on the world origin).
    clearance_m, step_m : float
        Free space around the footprint, grid step, m.
    limit : int
        Positions yielded at most.
    """
    lo = -table_half_m - footprint_xy[0] + clearance_m
    hi = table_half_m - footprint_xy[1] - clearance_m
    if np.any(lo > hi):
        return
    xs = np.arange(math.ceil(lo[0] / step_m), math.floor(hi[0] / step_m) + 1) * step_m
    ys = np.arange(math.ceil(lo[1] / step_m), math.floor(hi[1] / step_m) + 1) * step_m
    grid = np.array([(x, y) for x in xs for y in ys])
    if grid.size == 0:
        return
    order = np.lexsort((grid[:, 1], grid[:, 0], np.round(
        np.linalg.norm(grid - start_xy, axis=1), 9)))
    n = 0
    for k in order:
        p = grid[k]
        a_lo, a_hi = p + footprint_xy[0] - clearance_m, p + footprint_xy[1] + clearance_m
        if len(avoid_boxes) and np.any(np.all(a_lo < avoid_boxes[:, 1], axis=1)
                                       & np.all(a_hi > avoid_boxes[:, 0], axis=1)):
            continue
        yield p
        n += 1
        if n >= limit:
            return


def regrasp_poses(points_part: np.ndarray, com_part: np.ndarray, T_start: np.ndarray,
                  T_assembled: np.ndarray, avoid_boxes: Sequence[np.ndarray],
                  table_size_m: np.ndarray, clearance_m: float, step_m: float = 0.01,
                  per_orientation: int = 2) -> list[RegraspPose]:
    """Poses to put the part down and grasp it again, best first (module docstring).

    ``avoid_boxes``: world AABBs (2, 3) of every other body on the table and of the part at
    its start pose; ``table_size_m``: (3,) the table's size (its top is z = 0)."""
    avoid = np.array([b[:, :2] for b in avoid_boxes]).reshape(-1, 2, 2)
    out = []
    for R, d_part, margin in stable_orientations(points_part, com_part, T_assembled[:3, :3],
                                                 T_start[:3, :3]):
        w = points_part @ R.T
        foot = np.array([w[:, :2].min(axis=0), w[:, :2].max(axis=0)])
        for xy in free_positions(foot, T_start[:2, 3], avoid,
                                 np.asarray(table_size_m, float)[:2] / 2, clearance_m, step_m,
                                 per_orientation):
            T = np.eye(4)
            T[:3, :3] = R
            T[:3, 3] = [xy[0], xy[1], -float(w[:, 2].min())]
            out.append(RegraspPose(T, d_part, margin))
    return out
