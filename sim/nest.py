"""The tray nest: a static body under a part that waits at a start pose it cannot rest on the
table at (pins standing in a tray), with pockets around its protruding pieces; or a cradle
under a part lying on its side that would tip over on the table (a piston with its rod).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..knowledge.frames import invert
from ..parts.pieces import ConvexPiece
from .bodies import aabb, piece_corners, transform_points

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry
    from .scene_types import SceneSettings


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
        return _cradle(geometry, part, T_world_part, v, pieces, settings)
    z = tri[down, :, 2].mean(axis=1)
    key = np.round(z / 1e-6).astype(np.int64)
    areas = 0.5 * area2[down]
    uniq = np.unique(key)
    totals = np.array([areas[key == u].sum() for u in uniq])
    best = uniq[int(np.argmax(totals))]
    sel = np.flatnonzero(down)[key == best]
    z_face = float(tri[sel, :, 2].mean())
    if z_face < settings.nest_min_height_m:
        return _cradle(geometry, part, T_world_part, v, pieces, settings)
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
        # no face to carry a nest (a facet strip of a cylinder's side: a flanged bearing on
        # its edge, its body's lowest facet 4 mm up): the part may still tip over (cradle)
        return _cradle(geometry, part, T_world_part, v, pieces, settings)
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


CRADLE_CONTACT_M = 0.1e-3
"""Mesh vertices within this of the part's lowest point touch the table (rest test), m."""
CRADLE_WIDTH_M = 1e-3
"""Width of a cradle rail across the line it supports, m (narrow: the fingers close around
the part above it)."""


def _rests_on_table(points_world: np.ndarray, com_world: np.ndarray) -> bool:
    """Whether a rigid part whose lowest points are ``points_world`` (n, 3) rests on the table:
    the centre of mass over the convex hull of the points touching it (within
    ``CRADLE_CONTACT_M``, which absorbs the tessellation of curved faces)."""
    z0 = float(points_world[:, 2].min())
    xy = points_world[points_world[:, 2] <= z0 + CRADLE_CONTACT_M, :2]
    c = np.asarray(com_world[:2], float)
    centred = xy - xy.mean(axis=0)
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    if len(xy) < 3 or sv[-1] < 1e-9 * max(sv[0], 1e-12):  # a point or a line of contact
        d = vt[0]
        t = centred @ d
        rel = c - xy.mean(axis=0)
        off = rel - (rel @ d) * d
        return bool(np.linalg.norm(off) <= CRADLE_CONTACT_M and t.min() - 1e-9 <= rel @ d <= t.max() + 1e-9)
    from scipy.spatial import ConvexHull

    hull = ConvexHull(xy)
    return bool(np.all(hull.equations[:, :2] @ c + hull.equations[:, 2] <= CRADLE_CONTACT_M))


def _cradle(geometry: ProductGeometry, part: str, T_world_part: np.ndarray, v_world: np.ndarray,
            pieces: tuple[ConvexPiece, ...], settings: SceneSettings
            ) -> tuple[tuple[ConvexPiece, ...], np.ndarray, str] | None:
    """Rails under the lowest line of every piece held clear of the table, when the part would
    not rest at its start pose on the table alone (None otherwise).

    A part lying on its side with no flat face down (a piston with its rod: the piston touches
    the table along a line, the rod is 10 mm above it, the centre of mass 34 mm along the rod)
    tips over on a bare table (measured: 5.2 deg, onto the rod's end, before the fingers close;
    the geometry gives atan((16 - 6) / 110) = 5.2 deg) and is then carried tilted. A tray holds
    such a part in a cradle; each rail is ``CRADLE_WIDTH_M`` wide, under the piece's lowest
    line, from the table up to it, with pockets (``nest_clearance_m``) around lower pieces.
    """
    com = transform_points(np.asarray(geometry.mass_properties(part).com_m, float)[None], T_world_part)[0]
    if _rests_on_table(v_world, com):
        return None
    z_part = float(v_world[:, 2].min())
    corners = [transform_points(piece_corners(pc), T_world_part) for pc in pieces]
    out: list[ConvexPiece] = []
    for k, pts in enumerate(corners):
        z_low = float(pts[:, 2].min())
        if z_low < max(z_part + CRADLE_CONTACT_M, settings.nest_min_height_m):
            continue  # on the table already
        low = pts[pts[:, 2] <= z_low + CRADLE_CONTACT_M]
        box = aabb(pts[:, :2])
        centre = 0.5 * (aabb(low[:, :2])[0] + aabb(low[:, :2])[1])
        size = box[1] - box[0]
        along = int(np.argmax(size))  # rail along the piece's longer horizontal side (world axes)
        rail = box.copy()
        across = 1 - along
        rail[0, across] = centre[across] - 0.5 * CRADLE_WIDTH_M
        rail[1, across] = centre[across] + 0.5 * CRADLE_WIDTH_M
        rail[0, along] += settings.nest_inset_m
        rail[1, along] -= settings.nest_inset_m
        pockets = [aabb(q[:, :2]) + np.array([[-1.0, -1.0], [1.0, 1.0]]) * settings.nest_clearance_m
                   for j, q in enumerate(corners) if j != k and q[:, 2].min() < z_low - 1e-6]
        for c in _rect_minus(rail, pockets):
            T = np.eye(4)
            T[:2, 3] = 0.5 * (c[0] + c[1])
            T[2, 3] = z_low / 2
            he = np.array([(c[1, 0] - c[0, 0]) / 2, (c[1, 1] - c[0, 1]) / 2, z_low / 2])
            out.append(ConvexPiece("box", T, half_extents_m=he, name=f"cradle{len(out)}"))
    if not out:
        return None
    desc = (f"tray cradle: {len(out)} rails under the lowest lines of the pieces above the table "
            "(the part would tip over on the bare table at its start pose)")
    return tuple(out), np.eye(4), desc
