"""Convex pieces of primitives: bodies, pins, and holed boxes, tubes and BSP splits.

These build the ``exact`` and ``convex`` levels of :mod:`asmplan.parts.lod`.

Piece count per hole (convex level)
-----------------------------------
A hole of radius ``r`` whose pin has radial clearance ``c`` is an ``n``-gon with inscribed
radius ``r``. The pin can move ``c`` towards a face and ``c / cos(pi / n)`` towards a corner,
so the model adds at most ``c (1 / cos(pi / n) - 1)`` of radial play (twice that in diametral
clearance), and the corner recess is ``r (1 / cos(pi / n) - 1)`` (the Hausdorff error of the
hole wall). ``n`` is the smallest of ``GeometrySettings.convex_sides`` with

    c (1 / cos(pi / n) - 1) <= max(convex_play_fraction * c, convex_play_floor_m)   and
    (r + chamfer) (1 / cos(pi / n) - 1) <= convex_max_hausdorff_m.

With the defaults (5 %, 1 um, 0.5 mm) a 10 mm hole gets 12 sides at 1 mm and 0.1 mm
diametral clearance and 8 sides at 0.02 mm; the stated bound on the effective diametral
clearance error is ``2 c (1 / cos(pi / n) - 1)``.
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass

import numpy as np

from ..knowledge.frames import invert, transform_points
from .geometry import (
    BodyShape,
    GeometrySettings,
    HoleShape,
    PinShape,
    polygon_excess,
    sides_for_tolerance,
)
from .mesh import DegenerateHullError, convex_hull, hull_faces
from .pieces import ConvexPiece


# ---------------------------------------------------------------------------------------------
# Small convex helpers
# ---------------------------------------------------------------------------------------------
def _hull_piece(points: np.ndarray, name: str) -> ConvexPiece:
    """A hull piece centred on its points' bounding-box centre."""
    pts = np.asarray(points, dtype=float)
    centre = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    T = np.eye(4)
    T[:3, 3] = centre
    return ConvexPiece(kind="hull", T_part_piece=T, vertices_m=pts - centre, name=name)


def _ring(radius_circ: float, n: int, z: float, phase: float = 0.0) -> np.ndarray:
    ang = phase + 2.0 * math.pi * np.arange(n) / n
    return np.column_stack([radius_circ * np.cos(ang), radius_circ * np.sin(ang), np.full(n, z)])


def frustum_points(r0: float, r1: float, z0: float, z1: float, n: int, *, inscribed: bool = False
                   ) -> np.ndarray:
    """Vertices (2n, 3) of an n-gon frustum along z around circles r0 (at z0) and r1 (at z1):
    circumscribing them (faces tangent), or inscribed in them (vertices on the circles)."""
    k = 1.0 if inscribed else 1.0 / math.cos(math.pi / n)
    return np.concatenate([_ring(r0 * k, n, z0), _ring(r1 * k, n, z1)])


def clip_convex(points: np.ndarray, normal: np.ndarray, offset: float, eps: float = 1e-12) -> np.ndarray:
    """Vertices of ``hull(points) ∩ {x : normal . x <= offset}`` ((k, 3), k may be 0)."""
    pts = np.asarray(points, dtype=float)
    nrm = np.asarray(normal, dtype=float)
    s = pts @ nrm - offset
    if np.all(s <= eps):
        return pts
    if np.all(s >= -eps):
        return np.zeros((0, 3))
    tri = hull_faces(pts)
    pairs = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges = np.unique(np.sort(pairs, axis=1), axis=0)
    a, b = edges[:, 0], edges[:, 1]
    cross = (s[a] < -eps) & (s[b] > eps) | (s[a] > eps) & (s[b] < -eps)
    t = s[a[cross]] / (s[a[cross]] - s[b[cross]])
    new = pts[a[cross]] + t[:, None] * (pts[b[cross]] - pts[a[cross]])
    kept = pts[s <= eps]
    out = np.concatenate([kept, new])
    return out


def _volume_ok(points: np.ndarray, min_volume: float = 1e-15) -> bool:
    if len(points) < 4:
        return False
    try:
        return convex_hull(points).volume > min_volume
    except DegenerateHullError:
        return False


def piece_points(pc: ConvexPiece, tol_m: float) -> np.ndarray:
    """Points (n, 3) in the PART frame whose hull contains the piece (cylinders and spheres
    by circumscribed polygons within ``tol_m``)."""
    if pc.kind == "box":
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        local = signs * pc.half_extents_m
    elif pc.kind == "hull":
        local = np.asarray(pc.vertices_m)
    elif pc.kind == "cylinder":
        n = sides_for_tolerance(pc.radius_m, tol_m)
        h = 0.5 * pc.length_m
        local = frustum_points(pc.radius_m, pc.radius_m, -h, h, n)
    else:
        n = sides_for_tolerance(pc.radius_m, tol_m)
        sec = 1.0 / math.cos(math.pi / n)
        rings = [_ring(pc.radius_m * sec**2 * math.cos(phi), n, pc.radius_m * sec**2 * math.sin(phi))
                 for phi in np.linspace(-math.pi / 2, math.pi / 2, n // 2 + 1)[1:-1]]
        poles = np.array([[0, 0, pc.radius_m * sec**2], [0, 0, -pc.radius_m * sec**2]])
        local = np.concatenate([*rings, poles])
    return transform_points(pc.T_part_piece, local)


# ---------------------------------------------------------------------------------------------
# Primitive pieces
# ---------------------------------------------------------------------------------------------
def _cylinder_body_pieces(body: BodyShape, name: str, tol_m: float) -> list[ConvexPiece]:
    """Exact cylinder sections (+ frustum hulls at chamfered ends), part frame."""
    out: list[ConvexPiece] = []
    secs = body.sections
    z_lo, z_hi = secs[0].z0_m, secs[-1].z1_m
    for k, s in enumerate(secs):
        a, b = s.z0_m, s.z1_m
        n = sides_for_tolerance(s.radius_m, tol_m)
        if body.chamfer_low_m > 0 and abs(a - z_lo) < 1e-12:
            c = body.chamfer_low_m
            pts = frustum_points(s.radius_m - c, s.radius_m, a, a + c, n, inscribed=True)
            out.append(_placed_hull(pts, body.T_part_body, f"{name}/chamfer_low"))
            a += c
        if body.chamfer_high_m > 0 and abs(b - z_hi) < 1e-12:
            c = body.chamfer_high_m
            pts = frustum_points(s.radius_m, s.radius_m - c, b - c, b, n, inscribed=True)
            out.append(_placed_hull(pts, body.T_part_body, f"{name}/chamfer_high"))
            b -= c
        if b - a > 1e-12:
            T = np.eye(4)
            T[2, 3] = 0.5 * (a + b)
            out.append(ConvexPiece(kind="cylinder", T_part_piece=body.T_part_body @ T, radius_m=s.radius_m,
                                   length_m=b - a, name=f"{name}/section{k}"))
    return out


def _placed_hull(points_local: np.ndarray, T_part_local: np.ndarray, name: str) -> ConvexPiece:
    return _hull_piece(transform_points(T_part_local, points_local), name)


def body_pieces(body: BodyShape, name: str, tol_m: float) -> list[ConvexPiece]:
    """Exact pieces of a hole-free body (box, sphere, stepped/chamfered cylinder)."""
    if body.kind == "box":
        return [ConvexPiece(kind="box", T_part_piece=body.T_part_body, half_extents_m=body.half_extents_m,
                            name=name)]
    if body.kind == "sphere":
        return [ConvexPiece(kind="sphere", T_part_piece=body.T_part_body, radius_m=body.radius_m, name=name)]
    return _cylinder_body_pieces(body, name, tol_m)


def pin_pieces(pin: PinShape, tol_m: float) -> list[ConvexPiece]:
    """A pin as an exact cylinder (+ a frustum hull for its tip chamfer), part frame."""
    c = min(pin.chamfer_m, 0.5 * pin.length_m)
    T = np.eye(4)
    T[2, 3] = 0.5 * (pin.length_m - c)
    out = [ConvexPiece(kind="cylinder", T_part_piece=pin.T_part_pin @ T, radius_m=pin.radius_m,
                       length_m=pin.length_m - c, name=f"pin:{pin.feature}")]
    if c > 0:
        n = sides_for_tolerance(pin.radius_m, tol_m)
        L = pin.length_m
        pts = frustum_points(pin.radius_m, pin.radius_m - c, L - c, L, n, inscribed=True)
        out.append(_placed_hull(pts, pin.T_part_pin, f"pin:{pin.feature}/tip"))
    return out


# ---------------------------------------------------------------------------------------------
# Convex decompositions of holed primitives
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class HoleSides:
    """The polygon chosen for one hole at the convex level.

    ``radius_m`` is the largest inscribed radius of the hole's polygon (the hole radius plus
    its mouth chamfer), which sets the corner recess ``hausdorff_m``.
    """

    feature: str
    n_sides: int
    radius_m: float
    radial_clearance_m: float

    @property
    def play_bound_m(self) -> float:
        """Stated bound on the effective DIAMETRAL clearance error, ``2 c (sec(pi/n) - 1)``."""
        return 2.0 * polygon_excess(self.radial_clearance_m, self.n_sides)

    @property
    def hausdorff_m(self) -> float:
        return polygon_excess(self.radius_m, self.n_sides)


def convex_sides(radius_m: float, radial_clearance_m: float, settings: GeometrySettings) -> int:
    """Side count of a hole's polygon at the convex level (rule in the module docstring)."""
    c = abs(radial_clearance_m)
    play_tol = max(settings.convex_play_fraction * c, settings.convex_play_floor_m)
    choices = sorted(settings.convex_sides)
    for n in choices:
        if (polygon_excess(c, n) <= play_tol
                and polygon_excess(radius_m, n) <= settings.convex_max_hausdorff_m):
            return n
    return choices[-1]


class _Unsupported(Exception):
    pass


def _axis_index(v: np.ndarray) -> tuple[int, float]:
    k = int(np.argmax(np.abs(v)))
    if abs(abs(v[k]) - 1.0) > 1e-9:
        raise _Unsupported("hole axis not along a body axis")
    return k, float(np.sign(v[k]))


def _box_rotation(k: int, sign: float) -> np.ndarray:
    """Rotation R (3, 3) from the decomposition frame to the box frame mapping +z to sign*e_k."""
    R = np.zeros((3, 3))
    perm = {2: (0, 1, 2), 0: (1, 2, 0), 1: (2, 0, 1)}[k]
    # columns: images of x, y, z of the decomposition frame
    R[perm[0], 0] = 1.0
    R[perm[1], 1] = 1.0
    R[perm[2], 2] = 1.0
    if sign < 0:  # turn half around x so that +z maps to -e_k
        R = R @ np.diag([1.0, -1.0, -1.0])
    return R


def _box_with_holes(body: BodyShape, holes: list[HoleShape], sides: dict[str, HoleSides],
                    name: str) -> list[ConvexPiece]:
    from .decompose import HoleSpec, block_with_holes_pieces

    T_body_part = invert(body.T_part_body)
    axes = []
    for h in holes:
        axis_b = T_body_part[:3, :3] @ h.T_part_hole[:3, 2]
        axes.append(_axis_index(axis_b))
    ks = {k for k, _ in axes}
    if len(ks) != 1:
        raise _Unsupported("holes along different axes of one box")
    k = ks.pop()
    blind_signs = {s for (_, s), h in zip(axes, holes, strict=True) if not h.through}
    if len(blind_signs) > 1:
        raise _Unsupported("blind holes opening on opposite faces of one box")
    sign = blind_signs.pop() if blind_signs else axes[0][1]
    R = _box_rotation(k, sign)
    T_body_dec = np.eye(4)
    T_body_dec[:3, :3] = R
    size = 2.0 * (R.T @ body.half_extents_m)
    size = np.abs(size)
    top = 0.5 * size[2]
    T_dec_part = invert(T_body_dec) @ T_body_part
    specs = []
    for h in holes:
        mouth = transform_points(T_dec_part, h.T_part_hole[:3, 3][None])[0]
        if h.through:
            depth = None
        else:
            if abs(mouth[2] - top) > 1e-6:
                raise _Unsupported("blind hole mouth not on the box face")
            depth = h.depth_m
            if depth >= size[2] - 1e-12:
                depth = None
        specs.append(HoleSpec((float(mouth[0]), float(mouth[1])), h.radius_m, depth,
                              sides[h.feature].n_sides))
    try:
        raw = block_with_holes_pieces(size, specs, name=name)
    except ValueError as exc:
        raise _Unsupported(str(exc)) from None
    T_part_dec = body.T_part_body @ T_body_dec
    out: list[ConvexPiece] = []
    for pc in raw:
        m = re.search(r"/hole(\d+)/side(\d+)$", pc.name)
        if m is not None:
            i, kside = int(m.group(1)), int(m.group(2))
            h, spec = holes[i], specs[i]
            chamfer_on_top = h.chamfer_m > 0 and (not h.through or _mouth_on_top(h, T_dec_part, top))
            if chamfer_on_top:
                pts = piece_points(pc, 1e-6)
                n = spec.n_sides
                phi = 2.0 * math.pi * kside / n
                nrm = np.array([math.cos(phi), math.sin(phi), 0.0])
                cxy = np.array([spec.centre_xy_m[0], spec.centre_xy_m[1], 0.0])
                z0 = top - h.chamfer_m
                # keep rho_k - (z - z0) >= r  <=>  (-nrm + e_z) . p <= -r - nrm.c + z0
                normal = -nrm + np.array([0.0, 0.0, 1.0])
                offset = -h.radius_m - float(nrm @ cxy) + z0
                pts = clip_convex(pts, normal, offset)
                if not _volume_ok(pts):
                    continue
                out.append(_placed_hull(pts, T_part_dec, pc.name))
                continue
        out.append(ConvexPiece(kind=pc.kind, T_part_piece=T_part_dec @ pc.T_part_piece,
                               half_extents_m=pc.half_extents_m, radius_m=pc.radius_m,
                               length_m=pc.length_m, vertices_m=pc.vertices_m, name=pc.name))
    return out


def _mouth_on_top(h: HoleShape, T_dec_part: np.ndarray, top: float) -> bool:
    mouth = transform_points(T_dec_part, h.T_part_hole[:3, 3][None])[0]
    return abs(mouth[2] - top) <= 1e-6


def _coaxial_holes(body: BodyShape, holes: list[HoleShape]) -> list[tuple[HoleShape, float, float, float]]:
    """For a cylinder body: (hole, z_mouth, direction sign, z_end) per coaxial hole, else raise."""
    T_body_part = invert(body.T_part_body)
    out = []
    for h in holes:
        axis_b = T_body_part[:3, :3] @ h.T_part_hole[:3, 2]
        mouth = transform_points(T_body_part, h.T_part_hole[:3, 3][None])[0]
        if abs(abs(axis_b[2]) - 1.0) > 1e-9 or math.hypot(mouth[0], mouth[1]) > 1e-9:
            raise _Unsupported("hole not coaxial with the cylinder")
        s = float(np.sign(axis_b[2]))
        out.append((h, float(mouth[2]), s, float(mouth[2] - s * h.depth_m)))
    return out


# Complexity above C (radon): per ring and sector the inner polygon and the outer arc are built in one
# pass; the checks that fall back to the split by hole planes are inline.
def _tube_pieces(body: BodyShape, holes: list[HoleShape], sides: dict[str, HoleSides], name: str,
                 settings: GeometrySettings) -> list[ConvexPiece]:
    """A cylinder with coaxial holes as rings of convex sectors (body frame z = axis)."""
    co = _coaxial_holes(body, holes)
    secs = body.sections
    z_lo, z_hi = secs[0].z0_m, secs[-1].z1_m
    # breakpoints: outer steps and hole ends (radius jumps); chamfer kinks stay inside pieces
    cuts = {z_lo, z_hi, *(s.z0_m for s in secs), *(s.z1_m for s in secs)}
    for _h, zm, _s, ze in co:
        cuts.update({min(max(zm, z_lo), z_hi), min(max(ze, z_lo), z_hi)})
    zs = sorted(cuts)
    out: list[ConvexPiece] = []

    def covering(z: float) -> list[tuple[HoleShape, float, float, float]]:
        return [c for c in co if min(c[1], c[3]) - 1e-12 <= z <= max(c[1], c[3]) + 1e-12]

    def inner(z: float, hs: list[tuple[HoleShape, float, float, float]]) -> float:
        r = 0.0
        for h, zm, s, _ze in hs:  # the chamfer cone widens towards the mouth
            depth_from_mouth = (zm - z) * s
            r = max(r, h.radius_m, h.radius_m + h.chamfer_m - depth_from_mouth if h.chamfer_m > 0 else 0.0)
        return r

    def outer(z: float, R: float) -> float:
        g = R
        if body.chamfer_low_m > 0:
            g = min(g, R - body.chamfer_low_m + (z - z_lo))
        if body.chamfer_high_m > 0:
            g = min(g, R - body.chamfer_high_m + (z_hi - z))
        return g

    for j, (a, b) in enumerate(itertools.pairwise(zs)):
        if b - a <= 1e-12:
            continue
        mid = 0.5 * (a + b)
        R = next(s.radius_m for s in secs if s.z0_m - 1e-12 <= mid <= s.z1_m + 1e-12)
        hs = covering(mid)
        kinks = {a, b}
        for h, zm, s, _ze in hs:
            if h.chamfer_m > 0:
                kinks.add(zm - s * h.chamfer_m)
        if body.chamfer_low_m > 0:
            kinks.add(z_lo + body.chamfer_low_m)
        if body.chamfer_high_m > 0:
            kinks.add(z_hi - body.chamfer_high_m)
        zk = sorted(z for z in kinks if a - 1e-12 <= z <= b + 1e-12)
        if not hs:
            T_local = np.eye(4)
            nn = sides_for_tolerance(R, settings.exact_tolerance_m)
            if any(outer(z, R) < R - 1e-12 for z in zk):
                pts = np.concatenate([_ring(outer(z, R) / math.cos(math.pi / nn), nn, z) for z in zk])
                out.append(_placed_hull(pts, body.T_part_body, f"{name}/core{j}"))
            else:
                T_local[2, 3] = mid
                out.append(ConvexPiece(kind="cylinder", T_part_piece=body.T_part_body @ T_local, radius_m=R,
                                       length_m=b - a, name=f"{name}/core{j}"))
            continue
        n = max(sides[h.feature].n_sides for h, *_ in hs)
        sub = max(1, math.ceil(math.pi / n / math.acos(1.0 / (1.0 + settings.convex_arc_tolerance_m / R))))
        dphi = 2.0 * math.pi / n / sub
        for k in range(n):
            phi = 2.0 * math.pi * k / n
            ends = np.array([phi - math.pi / n, phi + math.pi / n])
            arc = phi - math.pi / n + dphi * np.arange(sub + 1)
            rings: list[np.ndarray] = []
            for z in zk:
                ri = inner(z, hs) / math.cos(math.pi / n)
                ro = outer(z, R) / math.cos(dphi / 2)
                if ri >= outer(z, R) - 1e-9:
                    raise _Unsupported("tube wall too thin for the hole polygon")
                rings.append(np.column_stack([ri * np.cos(ends), ri * np.sin(ends), np.full(2, z)]))
                rings.append(np.column_stack([ro * np.cos(arc), ro * np.sin(arc), np.full(sub + 1, z)]))
            out.append(_placed_hull(np.concatenate(rings), body.T_part_body, f"{name}/ring{j}/side{k}"))
    return out


def _body_points_local(body: BodyShape, tol_m: float) -> np.ndarray:
    if body.kind == "box":
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        return signs * body.half_extents_m
    if body.kind == "sphere":
        pc = ConvexPiece(kind="sphere", T_part_piece=np.eye(4), radius_m=body.radius_m)
        return piece_points(pc, tol_m)
    R = max(s.radius_m for s in body.sections)
    n = sides_for_tolerance(R, tol_m)
    return frustum_points(R, R, body.sections[0].z0_m, body.sections[-1].z1_m, n)


def _hole_polytopes(h: HoleShape, n: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The hole's convex polytopes (prism, chamfer frustum) as half-spaces (normals (k,3),
    offsets (k,)) in the part frame: x inside iff normals @ x <= offsets."""
    T = h.T_part_hole
    R, o = T[:3, :3], T[:3, 3]
    out = []
    ang = 2.0 * math.pi * np.arange(n) / n
    radial = np.column_stack([np.cos(ang), np.sin(ang), np.zeros(n)])
    out_m = 1e-3
    # prism: faces rho_k <= r, z <= out, z >= -depth
    nl = np.concatenate([radial, [[0, 0, 1.0]], [[0, 0, -1.0]]])
    ol = np.concatenate([np.full(n, h.radius_m), [out_m], [h.depth_m]])
    out.append((nl, ol))
    if h.chamfer_m > 0:
        c = h.chamfer_m
        # frustum: rho_k - z <= r + c (radius r at z=-c, r+c at 0), z <= out, z >= -c
        nl2 = np.concatenate([radial - np.array([0, 0, 1.0]), [[0, 0, 1.0]], [[0, 0, -1.0]]])
        ol2 = np.concatenate([np.full(n, h.radius_m), [out_m], [c]])
        out.append((nl2, ol2))
    world = []
    for nl_, ol_ in out:
        nw = nl_ @ R.T
        world.append((nw, ol_ + nw @ o))
    return world


def _bsp_pieces(body: BodyShape, holes: list[HoleShape], sides: dict[str, HoleSides], name: str,
                settings: GeometrySettings) -> list[ConvexPiece]:
    """Body minus convex hole polytopes by successive half-space splits."""
    pieces = [transform_points(body.T_part_body, _body_points_local(body, settings.convex_arc_tolerance_m))]
    for h in holes:
        for normals, offsets in _hole_polytopes(h, sides[h.feature].n_sides):
            nxt = []
            for pts in pieces:
                s = pts @ normals.T - offsets  # (m, k): > 0 outside that half-space
                if np.any(np.all(s >= -1e-12, axis=0)):  # wholly outside one face: untouched
                    nxt.append(pts)
                    continue
                rest = pts
                for nrm, off in zip(normals, offsets, strict=True):
                    part = clip_convex(rest, -nrm, -off)  # outside this face
                    if _volume_ok(part):
                        nxt.append(part)
                    rest = clip_convex(rest, nrm, off)
                    if not _volume_ok(rest):
                        break
            pieces = nxt
    return [_hull_piece(p, f"{name}/bsp{i}") for i, p in enumerate(pieces)]


def _holes_touching(body: BodyShape, holes: tuple[HoleShape, ...], tol_m: float) -> list[HoleShape]:
    from .geometry import body_solid, hole_solid

    solid = body_solid(body, tol_m)
    return [h for h in holes if (solid ^ hole_solid(h, tol_m, n_sides=8)).volume() > 1e-15]


__all__ = ["HoleSides", "body_pieces", "clip_convex", "convex_sides", "pin_pieces"]
