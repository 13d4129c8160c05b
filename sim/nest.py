"""The tray nest: a static body under a part that waits at a start pose it cannot rest on the
table at (pins standing in a tray), with pockets around its protruding pieces.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..knowledge.frames import invert
from ..parts.pieces import ConvexPiece
from .bodies import aabb, piece_corners, transform_points

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry
    from .scene import SceneSettings


def _rect_minus(rect: np.ndarray, holes: list[np.ndarray]) -> list[np.ndarray]:
    """Cover rectangle ``rect`` (2, 2: min, max of x, y) minus the rectangles ``holes`` with
    a few disjoint rectangles (grid cells merged along rows, then equal strips across rows)."""
    xs = {rect[0, 0], rect[1, 0]}
    ys = {rect[0, 1], rect[1, 1]}
    clipped = []
    for h in holes:
        lo = np.maximum(h[0], rect[0])
        hi = np.minimum(h[1], rect[1])
        if np.all(hi > lo):
            clipped.append(np.stack([lo, hi]))
            xs.update((lo[0], hi[0]))
            ys.update((lo[1], hi[1]))
    xv, yv = sorted(xs), sorted(ys)
    strips: list[list[tuple[float, float]]] = []
    for j in range(len(yv) - 1):
        cy = 0.5 * (yv[j] + yv[j + 1])
        row: list[tuple[float, float]] = []
        for i in range(len(xv) - 1):
            cx = 0.5 * (xv[i] + xv[i + 1])
            free = not any(h[0, 0] < cx < h[1, 0] and h[0, 1] < cy < h[1, 1] for h in clipped)
            if free:
                if row and row[-1][1] == xv[i]:
                    row[-1] = (row[-1][0], xv[i + 1])
                else:
                    row.append((xv[i], xv[i + 1]))
        strips.append(row)
    out: list[np.ndarray] = []
    open_: dict[tuple[float, float], float] = {}
    for j, row in enumerate([*strips, []]):
        current = set(row)
        for seg in list(open_):
            if seg not in current:
                y0 = open_.pop(seg)
                out.append(np.array([[seg[0], y0], [seg[1], yv[j]]]))
        for seg in row:
            if seg not in open_:
                open_[seg] = yv[j]
    return [r for r in out if np.all(r[1] - r[0] > 1e-9)]


def tray_nest(geometry: ProductGeometry, part: str, T_world_part: np.ndarray, pieces: tuple[ConvexPiece, ...],
              settings: SceneSettings) -> tuple[tuple[ConvexPiece, ...], np.ndarray, str] | None:
    """Static support under the part's largest downward face, or None when the part rests on
    the table with that face (or has no horizontal downward face).

    Returns (box pieces in the nest frame, T_world_nest (4, 4), description).
    """
    mesh = geometry.mesh(part)
    v = transform_points(np.asarray(mesh.vertices, float), T_world_part)
    faces = np.asarray(mesh.faces)
    tri = v[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(n, axis=1)
    ok = area2 > 0
    nz = np.zeros(len(faces))
    nz[ok] = n[ok, 2] / area2[ok]
    down = ok & (nz < -1.0 + 1e-9)
    if not down.any():
        return None
    z = tri[down, :, 2].mean(axis=1)
    key = np.round(z / 1e-6).astype(np.int64)
    areas = 0.5 * area2[down]
    uniq = np.unique(key)
    totals = np.array([areas[key == u].sum() for u in uniq])
    best = uniq[int(np.argmax(totals))]
    sel = np.flatnonzero(down)[key == best]
    z_face = float(tri[sel, :, 2].mean())
    if z_face < settings.nest_min_height_m:
        return None
    # nest frame: world z, x along the part's horizontal axis closest to world x (yaw only)
    R = T_world_part[:3, :3]
    horiz = [c for c in range(3) if abs(R[2, c]) < 0.5]
    ax = R[:, horiz[0]].copy()
    ax[2] = 0.0
    ax /= np.linalg.norm(ax)
    T_nest = np.eye(4)
    T_nest[:3, 0] = ax
    T_nest[:3, 1] = np.cross([0.0, 0.0, 1.0], ax)
    T_nest[:3, 2] = [0.0, 0.0, 1.0]
    to_nest = invert(T_nest)
    face_pts = transform_points(tri[sel].reshape(-1, 3), to_nest)
    rect = aabb(face_pts[:, :2])
    rect = rect + np.array([[1.0, 1.0], [-1.0, -1.0]]) * settings.nest_inset_m
    if np.any(rect[1] <= rect[0]):
        return None
    pockets = []
    for pc in pieces:
        pts = transform_points(transform_points(piece_corners(pc), T_world_part), to_nest)
        if pts[:, 2].min() < z_face - 1e-6:
            box = aabb(pts[:, :2])
            pockets.append(box + np.array([[-1.0, -1.0], [1.0, 1.0]]) * settings.nest_clearance_m)
    cells = _rect_minus(rect, pockets)
    if not cells:
        return None
    out = []
    for k, c in enumerate(cells):
        T = np.eye(4)
        T[:2, 3] = 0.5 * (c[0] + c[1])
        T[2, 3] = z_face / 2
        he = np.array([(c[1, 0] - c[0, 0]) / 2, (c[1, 1] - c[0, 1]) / 2, z_face / 2])
        out.append(ConvexPiece("box", T, half_extents_m=he, name=f"nest{k}"))
    desc = (f"tray nest: {len(out)} boxes under its largest downward face at "
            f"z = {z_face * 1e3:.2f} mm, pockets around {len(pockets)} protruding pieces")
    return tuple(out), T_nest, desc
