"""Convex pieces of a mesh part that keep its features: holes on any axes, pins, slots, steps.

A mesh part's convex level used to keep only declared holes along one axis and replace every
sector by its hull, so a mesh with holes on two axes, a pin standing on a face, or a slot that
is not a declared feature became one hull with the feature filled (issue 19). Here:

1. **Regions per hole axis.** Declared holes are grouped by axis direction. While more than one
   direction is left, the solid is split by a plane that separates holes of different
   directions without cutting any of them (normals: the part's axes and the holes' axes; the
   widest free gap between the holes' extents). A hole set no plane separates keeps its largest
   group; the others are filled and a note names them.
2. **Sectors around holes.** In a region, space is split into one prism per hole (the Voronoi
   cells of the hole axes) and each prism into ``n`` wedges around its hole, each wedge cut by
   the plane of its polygon face (inscribed radius = the fitted hole radius) and, for a blind
   hole, by its floor; coaxial holes (a stepped bore) each keep their own slab along the axis.
3. **Concave faces split, not filled.** A piece whose hull is larger than itself by more than
   ``rel_tol`` is split by the plane of its largest concave face (a face with some of the
   piece beyond its plane), recursively, until every piece is convex within ``rel_tol`` or the
   piece budget is spent (then the rest are hulls and a note says how much they fill). A pin on
   a face, a step, a slot or an L corner keeps its shape; a tessellated concave curve becomes
   one piece per facet it needs.
"""

from __future__ import annotations

import math

import numpy as np

from .geometry import HoleShape, trimesh_to_manifold
from .pieces import ConvexPiece
from .primitive_pieces import _hull_piece


def _points(solid) -> np.ndarray:
    return np.asarray(solid.to_mesh64().vert_properties, dtype=float)[:, :3]


def _trim(solid, normal: np.ndarray, offset: float):
    """The part of ``solid`` with normal . x >= offset."""
    return solid.trim_by_plane([float(x) for x in normal], float(offset))


def _empty(solid, min_volume: float = 1e-15) -> bool:
    return solid.is_empty() or solid.volume() <= min_volume


def _hole_interval(h: HoleShape, n: np.ndarray) -> tuple[float, float]:
    """Extent of the hole's cylinder (chamfer and a margin included) along unit ``n``."""
    a = h.T_part_hole[:3, 2]
    o = h.T_part_hole[:3, 3]
    ends = [float(n @ o), float(n @ (o - a * h.depth_m))]
    r = (h.radius_m + h.chamfer_m) * 1.05 + 1e-4
    spread = r * math.sqrt(max(0.0, 1.0 - float(n @ a) ** 2))
    return min(ends) - spread, max(ends) + spread


def _axis_classes(holes: list[HoleShape]) -> list[int]:
    reps: list[np.ndarray] = []
    out = []
    for h in holes:
        a = h.T_part_hole[:3, 2]
        for k, r in enumerate(reps):
            if abs(abs(float(a @ r)) - 1.0) <= 1e-9:
                out.append(k)
                break
        else:
            reps.append(a)
            out.append(len(reps) - 1)
    return out


# Complexity above C (radon): a search over candidate cut planes (axis and hole normals)
# for the one that separates the hole classes, with the interval sweep inline.
def _split_by_axes(solid, holes: list[HoleShape], notes: list[str]) -> list[tuple[object, list[HoleShape]]]:
    """Regions of ``solid`` each holding holes of one axis direction (step 1)."""
    classes = _axis_classes(holes)
    if len(set(classes)) <= 1:
        return [(solid, holes)]
    normals = [np.eye(3)[i] for i in range(3)]
    for h in holes:
        a = h.T_part_hole[:3, 2]
        if all(abs(abs(float(a @ m)) - 1.0) > 1e-9 for m in normals):
            normals.append(a / np.linalg.norm(a))
    best = None
    for n in normals:
        iv = sorted((_hole_interval(h, n), c, i) for i, (h, c) in enumerate(zip(holes, classes, strict=True)))
        reach = -math.inf
        for k in range(1, len(iv)):
            reach = max(reach, iv[k - 1][0][1])
            gap = iv[k][0][0] - reach
            if gap <= 0:
                continue
            left = {c for _, c, _ in iv[:k]}
            right = {c for _, c, _ in iv[k:]}
            if left == right and len(left) == 1:
                continue
            if best is None or gap > best[0]:
                best = (gap, n, reach + 0.5 * gap, [i for _, _, i in iv[:k]], [i for _, _, i in iv[k:]])
    if best is None:
        keep = max(set(classes), key=classes.count)
        dropped = [h.feature for h, c in zip(holes, classes, strict=True) if c != keep]
        notes.append(f"holes {', '.join(dropped)} share no separating plane with the holes on the "
                     "main axis: they are filled at the convex level")
        return [(solid, [h for h, c in zip(holes, classes, strict=True) if c == keep])]
    _gap, n, offset, lo, hi = best
    out = []
    for side, idx in ((_trim(solid, -n, -offset), lo), (_trim(solid, n, offset), hi)):
        if not _empty(side):
            out += _split_by_axes(side, [holes[i] for i in idx], notes)
    return out


def _sectors(solid, holes: list[HoleShape], sides: dict) -> list[tuple[object, str]]:
    """Step 2: the region cut into wedges around its (parallel) holes."""
    if not holes:
        return [(solid, "body")]
    axis = holes[0].T_part_hole[:3, 2]
    centres = [h.T_part_hole[:3, 3] - float(h.T_part_hole[:3, 3] @ axis) * axis for h in holes]
    def extent(h: HoleShape) -> tuple[float, float]:
        t0 = float(h.T_part_hole[:3, 3] @ axis)
        t1 = t0 - float(h.T_part_hole[:3, 2] @ axis) * h.depth_m
        return min(t0, t1), max(t0, t1)

    out: list[tuple[object, str]] = []
    for i, h in enumerate(holes):
        cell = solid
        lo_i, hi_i = extent(h)
        for j, cj in enumerate(centres):
            if j != i:
                nrm = centres[i] - cj
                norm = float(np.linalg.norm(nrm))
                if norm < 1e-7:
                    # coaxial (a stepped bore): each hole keeps its own slab along the axis
                    lo_j, hi_j = extent(holes[j])
                    if hi_j <= lo_i + 1e-7:
                        cell = _trim(cell, axis, 0.5 * (hi_j + lo_i))
                    elif lo_j >= hi_i - 1e-7:
                        cell = _trim(cell, -axis, -0.5 * (lo_j + hi_i))
                    continue
                nrm = nrm / norm
                cell = _trim(cell, nrm, float(nrm @ (0.5 * (centres[i] + cj))))
        if _empty(cell):
            continue
        n = sides[h.feature].n_sides if h.feature in sides else 12
        Rh = h.T_part_hole[:3, :3]
        o = h.T_part_hole[:3, 3]
        ring = cell
        if not h.through:
            floor = o - h.depth_m * Rh[:, 2]
            below = _trim(cell, -Rh[:, 2], float(-Rh[:, 2] @ floor))
            ring = _trim(cell, Rh[:, 2], float(Rh[:, 2] @ floor))
            if not _empty(below):
                out.append((below, f"{h.feature}/floor"))
        for k in range(n):
            phi = 2.0 * math.pi * k / n
            a0, a1 = phi - math.pi / n, phi + math.pi / n
            n0 = Rh @ np.array([-math.sin(a0), math.cos(a0), 0.0])
            n1 = Rh @ np.array([math.sin(a1), -math.cos(a1), 0.0])
            nf = Rh @ np.array([math.cos(phi), math.sin(phi), 0.0])
            piece = _trim(_trim(ring, n0, float(n0 @ o)), n1, float(n1 @ o))
            piece = _trim(piece, nf, float(nf @ o + h.radius_m))
            if not _empty(piece):
                out.append((piece, f"{h.feature}/side{k}"))
    return out


def _concave_planes(solid, eps: float) -> list[tuple[float, np.ndarray, float]]:
    """(area, normal, offset) of the solid's face planes with some of the solid beyond them,
    coplanar faces merged, largest first."""
    m = solid.to_mesh64()
    V = np.asarray(m.vert_properties, float)[:, :3]
    F = np.asarray(m.tri_verts, np.int64)
    if len(F) == 0:
        return []
    e1 = V[F[:, 1]] - V[F[:, 0]]
    e2 = V[F[:, 2]] - V[F[:, 0]]
    cr = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(cr, axis=1)
    ok = area > 1e-14
    N = cr[ok] / (2 * area[ok])[:, None]
    off = np.einsum("ij,ij->i", N, V[F[ok, 0]])
    area = area[ok]
    groups: dict[tuple, list] = {}
    for nrm, o, a in zip(N, off, area, strict=True):
        key = (round(nrm[0], 5), round(nrm[1], 5), round(nrm[2], 5), round(o / max(eps, 1e-9) / 10))
        if key in groups:
            groups[key][0] += a
        else:
            groups[key] = [a, nrm, o]
    out = []
    for a, nrm, o in groups.values():
        if float(np.max(V @ nrm - o)) > eps:
            out.append((a, nrm, o))
    out.sort(key=lambda t: -t[0])
    return out


def _convex_split(solid, name: str, rel_tol: float, budget: list[int], filled: list[float],
                  depth: int = 0) -> list[ConvexPiece]:
    """Step 3: split by concave face planes until convex (or the budget is spent)."""
    if _empty(solid):
        return []
    comps = solid.decompose()
    if len(comps) > 1:  # a cut can leave separate bodies: each is its own piece
        return [p for c in comps for p in _convex_split(c, name, rel_tol, budget, filled, depth + 1)]
    pts = _points(solid)
    vol = solid.volume()
    hull_vol = solid.hull().volume()
    size = float(np.ptp(pts, axis=0).max())
    if hull_vol - vol <= rel_tol * vol or depth > 40 or budget[0] <= 1:
        if hull_vol - vol > rel_tol * vol:
            filled.append(hull_vol - vol)
        budget[0] -= 1
        return [_hull_piece(pts, name)]
    eps = max(1e-7, 1e-6 * size)
    planes = _concave_planes(solid, eps)
    for _a, nrm, o in planes:
        # cut eps beyond the face: a cut in the face's own plane leaves its coplanar faces
        # as a flat sheet on the far piece (a pin cut off its face kept a sheet to the face's
        # corners, and its hull bridged the pin to the body)
        inside = _trim(solid, -nrm, -(o + eps))
        outside = _trim(solid, nrm, o + eps)
        if _empty(inside, 1e-18) or _empty(outside, 1e-18):
            continue
        return (_convex_split(inside, name, rel_tol, budget, filled, depth + 1)
                + _convex_split(outside, name, rel_tol, budget, filled, depth + 1))
    filled.append(hull_vol - vol)
    budget[0] -= 1
    return [_hull_piece(pts, name)]


def mesh_feature_pieces(mesh, holes: list[HoleShape], sides: dict, *, rel_tol: float = 2e-3,
                        max_pieces: int = 160) -> tuple[tuple[ConvexPiece, ...], tuple[str, ...]]:
    """Convex pieces of a mesh part keeping its holes (any axes) and its shape (module docstring).

    Parameters
    ----------
    mesh : the part's watertight mesh (part frame, metres).
    holes : declared holes (fitted radii).
    sides : ``{feature: HoleSides}`` polygon sides per hole.
    rel_tol : a piece counts as convex when its hull adds at most this fraction of its volume.
    max_pieces : piece budget; beyond it the remaining pieces are hulls (noted).

    Returns
    -------
    pieces, notes
    """
    solid = trimesh_to_manifold(mesh)
    notes: list[str] = []
    regions = _split_by_axes(solid, list(holes), notes)
    budget = [max_pieces]
    filled: list[float] = []
    pieces: list[ConvexPiece] = []
    for r, (region, hs) in enumerate(regions):
        for piece, name in _sectors(region, hs, sides):
            pieces += _convex_split(piece, f"r{r}/{name}", rel_tol, budget, filled)
    n_axes = len({k for k in _axis_classes(list(holes))}) if holes else 0
    notes.append(f"mesh part: {len(pieces)} convex pieces in {len(regions)} region(s), holes on {n_axes} "
                 f"axis direction(s) kept as inscribed polygons, concave faces split (not filled)")
    if filled:
        total = sum(filled)
        notes.append(f"mesh part: the piece budget ({max_pieces}) was spent; {len(filled)} pieces are "
                     f"hulls that fill {total * 1e9:.3g} mm^3 ({total / solid.volume():.2%} of the part)")
    return tuple(pieces), tuple(notes)


__all__ = ["mesh_feature_pieces"]
