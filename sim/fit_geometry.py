"""Exact contact geometry of a cylindrical fit: a (chamfered) pin against a (chamfered) bore in
the face of a block, as the knowledge base declares them (no meshes, no margins).

Used by :mod:`asmplan.sim.feature_contact`, which replaces Bullet's contact between a held pin
and its hole during the insertion. No pybullet here.

Geometry
--------
Both solids are bodies of revolution about their own axis, so the distance from a point to
either is a distance in the point's meridian half-plane (radius rho from the axis, height z
along it) to a polygon, the solid's profile:

* The block (:class:`BoreFeature`, frame: origin at the mouth centre, z the outward normal of
  the face): material where z <= 0 outside the bore: top face out to ``rim_radius_m``, a 45 deg
  mouth chamfer of leg ``chamfer_m`` (radius R + ch at z = 0 to R at z = -ch), the wall down to
  ``depth_m`` and, for a blind bore, its floor.
* The pin (:class:`PinFeature`, frame: origin at the tip centre, s along the axis toward the
  root): material where 0 <= s, inside radius r, its tip chamfer of leg ``chamfer_m`` (radius
  r - ch at s = 0 to r at s = ch).

Contacts between two such solids lie on their edges (circles): a pin edge (the tip circle, the
chamfer's top circle, the seat circle of a shoulder) against the block's surface, or a block
edge (the mouth circle, the chamfer's bottom circle) against the pin's surface. Each circle is
sampled at :data:`CIRCLE_SAMPLES` angles, each local minimum of the signed distance below the
search margin is refined by a parabola through its neighbours (angle error ~ (2 pi / N)^3: the
distance is exact to < 0.01 um on a 10 mm pin), and a circle lying flat on a face (every sample
within :data:`FLAT_TOLERANCE_M` of the least) gives up to :data:`MAX_POINTS_PER_CIRCLE` points
spread around it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from .fit_clear import ClearanceProof
from .fit_profile import Profile, polygon_sdf, revolved_sdf  # noqa: F401
from .fit_samples import SKIP_BAND_M, MaterialBound, SampledCircles

CIRCLE_SAMPLES = 96
"""Angles sampled per edge circle."""

MAX_POINTS_PER_CIRCLE = 4
"""Contact points kept per circle (a circle lying flat on a face gives that many, spread)."""

FLAT_TOLERANCE_M = 0.2e-6
"""Samples of one circle within this of its least distance count as one flat contact."""

FACE_ENTRY_M = 0.5e-6
"""A penetration this shallow below a face (the block's top face under a pin edge, the pin's
end face above a mouth edge) is resolved back through that face, m (see
:meth:`FitContactModel.contacts`)."""

EDGE_EDGE_M = 1e-6
"""A sampled edge point whose nearest point on the other solid lies within this of one of that
solid's convex edges (a profile vertex: the mouth circle, the pin's tip circle) touches that
edge: two edges touch, and their contact normal is the cross product of the two circles'
tangents (see :meth:`FitContactModel.contacts`), m."""

BESIDE_DEPTH_M = 0.2e-3
"""A pin edge more than this below the block's face and this far outside its bore's mouth is
beside the block, not in it: no contact (see :meth:`FitContactModel.contacts`), m."""

EDGE_PARALLEL_SIN = 1e-6
"""Below this sine of the angle between the two edges' tangents the edges run parallel (a pin
concentric in its bore at the mouth) and the point-to-surface normal is kept."""

_FAR = 1.0  # m: "infinitely" far along a profile (the profiles are local)


@dataclass(frozen=True)
class PinFeature:
    """A cylindrical pin on the held body, in that body's link frame.

    Attributes
    ----------
    tip_m : (3,) float
        Centre of the pin's leading end face, m.
    axis_to_root : (3,) float
        Unit vector from the tip toward the root (into the part).
    radius_m : float
    chamfer_m : float
        45 deg tip chamfer leg, m (0: a sharp rim).
    length_m : float
        Tip to root, m.
    seat_radius_m : float
        Radius of the shoulder circle at the root that seats on the block's face, m (0: the
        part does not seat there, e.g. a plain pin longer than its hole).
    """

    tip_m: np.ndarray
    axis_to_root: np.ndarray
    radius_m: float
    chamfer_m: float
    length_m: float
    seat_radius_m: float = 0.0

    def profile(self) -> np.ndarray:
        """The pin's meridian profile polygon (rho, s), counter-clockwise, m."""
        r, ch = self.radius_m, min(self.chamfer_m, 0.999 * self.radius_m)
        pts = [(0.0, 0.0), (r - ch, 0.0)]
        if ch > 0:
            pts.append((r, ch))
        pts += [(r, _FAR), (0.0, _FAR)]
        return np.asarray(pts)


@dataclass(frozen=True)
class BoreFeature:
    """A cylindrical bore in the face of a block, in the block body's link frame.

    Attributes
    ----------
    mouth_m : (3,) float
        Centre of the mouth, on the face, m.
    axis_out : (3,) float
        Unit outward normal of the face.
    radius_m : float
    chamfer_m : float
        45 deg mouth chamfer leg, m.
    depth_m : float
        Mouth to floor (or to the far face for a through bore), m.
    through : bool
    rim_radius_m : float
        How far from the axis the face is modelled (beyond it the block is not there), m.
    """

    mouth_m: np.ndarray
    axis_out: np.ndarray
    radius_m: float
    chamfer_m: float
    depth_m: float
    through: bool
    rim_radius_m: float

    def profile(self) -> np.ndarray:
        """The block's meridian profile polygon (rho, z) around the bore, m."""
        R, ch, h, W = self.radius_m, self.chamfer_m, self.depth_m, self.rim_radius_m
        pts = [(W, 0.0)]
        if ch > 0:
            pts += [(R + ch, 0.0), (R, -ch)]
        else:
            pts.append((R, 0.0))
        if self.through:
            pts += [(R, -h), (W, -h)]
        else:
            pts += [(R, -h), (0.0, -h), (0.0, -h - _FAR), (W, -h - _FAR)]
        return np.asarray(pts)


def frame_of(origin: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """A (4, 4) frame with ``origin`` and z along the unit ``axis`` (x, y any orthonormal)."""
    z = np.asarray(axis, float) / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = origin
    return T


@dataclass(frozen=True)
class FitContact:
    """Contact points between a pin and a bore, world frame.

    ``normal`` points from the block into the pin (the direction the pin is pushed),
    ``gap_m`` is the signed distance (negative: penetration), ``point_m`` the point on the
    block's surface (pin edges: the pin's point moved back onto it)."""

    point_m: np.ndarray
    normal: np.ndarray
    gap_m: np.ndarray
    single_feature: bool = False
    """No sampled edge point had a second profile segment within the search margin: every
    point's distance is to one straight meridian segment (e.g. the pin sliding along the
    bore's wall), so the gaps are invariant under sliding along the bore's axis."""

    @property
    def count(self) -> int:
        return int(self.gap_m.shape[0])


@functools.cache
def _spread(count: int) -> np.ndarray:
    """Indices of up to :data:`MAX_POINTS_PER_CIRCLE` of ``count`` samples, spread evenly
    (read-only: cached)."""
    idx = np.unique(np.linspace(0, count - 1, min(MAX_POINTS_PER_CIRCLE, count))
                    .round().astype(int))
    idx.flags.writeable = False
    return idx


def _candidates(values: np.ndarray, margin_m: float, segments: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Contact candidates of sampled circles ``values`` (C, n): (circle index, angle rad) of
    each local minimum below ``margin_m`` (parabola-refined), or for a circle lying flat
    (3 or more samples within :data:`FLAT_TOLERANCE_M` of its least) up to
    :data:`MAX_POINTS_PER_CIRCLE` points spread over those samples."""
    n = values.shape[1]
    step = 2.0 * math.pi / n
    lo = values.min(axis=1)
    below = lo < margin_m
    if not below.any():  # no sample below the margin: no local minimum, no flat circle
        return np.zeros(0, dtype=np.intp), np.zeros(0)
    near = values <= (lo + FLAT_TOLERANCE_M)[:, None]
    flat = (np.add.reduce(near, axis=1) >= 3) & below
    prev = np.concatenate((values[:, -1:], values[:, :-1]), axis=1)
    nxt = np.concatenate((values[:, 1:], values[:, :1]), axis=1)
    is_min = (values <= prev) & (values < nxt) & (values < margin_m) & ~flat[:, None]
    rows, idx = np.nonzero(is_min)
    y0, y1, y2 = prev[rows, idx], values[rows, idx], nxt[rows, idx]
    den = y0 - 2.0 * y1 + y2
    shift = np.where(den > 0, 0.5 * (y0 - y2) / np.where(den > 0, den, 1.0), 0.0)
    angles = (idx + np.clip(shift, -0.5, 0.5)) * step
    if rows.size > MAX_POINTS_PER_CIRCLE and np.any(np.bincount(rows) > MAX_POINTS_PER_CIRCLE):
        keep = np.zeros(rows.size, dtype=bool)
        for r in np.unique(rows):
            mine = np.flatnonzero(rows == r)
            keep[mine[np.argsort(y1[mine])[:MAX_POINTS_PER_CIRCLE]]] = True
        rows, angles = rows[keep], angles[keep]
    if flat.any():
        extra_r, extra_a = [rows], [angles]
        for r in np.flatnonzero(flat):
            # spread over each profile segment the flat samples lie on (a pin end face lying
            # on both the block's face and, across the mouth, the bore's edge gets support
            # points on each)
            on = np.flatnonzero(near[r])
            if segments is None:
                groups = [on]
            else:
                seg = segments[r][on]
                groups = [on] if (seg == seg[0]).all() else [on[seg == g]
                                                               for g in np.unique(seg)]
            for at in groups:
                take = at[_spread(at.size)]
                extra_r.append(np.full(take.size, r))
                extra_a.append(take * step)
        rows, angles = np.concatenate(extra_r), np.concatenate(extra_a)
    return rows, angles


class FitContactModel:
    """Contact detection between one pin and one bore, both posed in the world.

    Parameters
    ----------
    pin, bore : PinFeature, BoreFeature
        In their bodies' link frames.
    """

    def __init__(self, pin: PinFeature, bore: BoreFeature) -> None:
        self.pin = pin
        self.bore = bore
        self._T_link_pin = frame_of(pin.tip_m, pin.axis_to_root)
        self._T_link_bore = frame_of(bore.mouth_m, bore.axis_out)
        self._pin_profile = Profile(pin.profile())
        self._bore_profile = Profile(bore.profile())
        self._angles = np.linspace(0.0, 2.0 * math.pi, CIRCLE_SAMPLES, endpoint=False)
        self._cos, self._sin = np.cos(self._angles), np.sin(self._angles)
        r, cp = pin.radius_m, min(pin.chamfer_m, 0.999 * pin.radius_m)
        # pin edge circles: (height s along the axis, radius)
        self._pin_circles = [(0.0, r - cp)] + ([(cp, r)] if cp > 0 else [])
        if pin.seat_radius_m > 0:
            self._pin_circles.append((pin.length_m, pin.seat_radius_m))
        R, ch = bore.radius_m, bore.chamfer_m
        self._bore_circles = [(0.0, R + ch)] + ([(-ch, R)] if ch > 0 else [])
        # each edge circle's vertex in its own profile (-1: the seat circle is not in it)
        self._pin_vertex = [1] + ([2] if cp > 0 else []) + ([-1] if pin.seat_radius_m > 0
                                                              else [])
        self._bore_vertex = [1] + ([2] if ch > 0 else [])
        self._far = bore.rim_radius_m + max(rad for _, rad in self._pin_circles)
        # supersets of the two solids (fit_samples: which samples can be candidates)
        self._pin_bound = MaterialBound(0.0, _FAR, r) if 0.0 <= cp < r else None
        well_formed = R > 0 and 0.0 <= ch <= bore.depth_m and bore.rim_radius_m >= R + ch
        self._bore_bound = (MaterialBound(-bore.depth_m - _FAR, 0.0, bore.rim_radius_m, R,
                                          -np.inf if bore.through else -bore.depth_m)
                            if well_formed else None)
        # per pose pair: each family's samples and refined candidates (reused by the next
        # call at the same poses, with another margin)
        self._samples: tuple[bytes, dict] | None = None
        self._circle_arrays = {
            on_pin: (np.array([h for h, _ in circles]), np.array([rad for _, rad in circles]))
            for on_pin, circles in ((True, self._pin_circles), (False, self._bore_circles))}
        self._proof = ClearanceProof(self)

    def frames(self, T_world_pin_body: np.ndarray, T_world_bore_body: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
        """World frames of the pin (origin: tip, z toward the root) and the bore (origin:
        mouth, z outward)."""
        return T_world_pin_body @ self._T_link_pin, T_world_bore_body @ self._T_link_bore

    def _apart(self, Tp: np.ndarray, Tb: np.ndarray, margin_m: float) -> bool:
        """True when no pin edge comes within ``margin_m`` of the block's face or bore (the
        pin's lowest edge point is above the face, or the pin is beyond the modelled rim)."""
        zb = Tb[:3, 2]
        tip_z = float(zb @ (Tp[:3, 3] - Tb[:3, 3]))
        ax_z = float(zb @ Tp[:3, 2])
        lean = math.sqrt(max(0.0, 1.0 - ax_z * ax_z))
        lowest = min(tip_z + s * ax_z - rad * lean for s, rad in self._pin_circles)
        if lowest > margin_m:
            return True
        rel = Tp[:3, 3] - Tb[:3, 3]
        lateral = float(np.linalg.norm(rel - (zb @ rel) * zb))
        return lateral > self._far + self.pin.length_m * lean + margin_m

    def clear_of(self, T_world_pin_body: np.ndarray, T_world_bore_body: np.ndarray,
                 margin_m: float, gap_m: float) -> bool:
        """True only if every contact :meth:`contacts` returns at these poses with this margin
        has a gap above ``gap_m`` (m), proved without detecting: the pin is apart, or every
        point of every edge circle lies farther than ``gap_m`` from the other solid (each
        solid's superset, :class:`~asmplan.sim.fit_samples.MaterialBound`, over the circle's
        meridian extent, :func:`~asmplan.sim.fit_samples.circle_extents`) and from a blind
        bore's floor, and no two edges cross (:meth:`_edge_edge` then changes no gap; a
        face-entry gap is negative only where the distance is). False says nothing. Computed
        on Python floats by :class:`~asmplan.sim.fit_clear.ClearanceProof`."""
        return self._proof.clear_of(T_world_pin_body, T_world_bore_body, margin_m, gap_m)

    def contacts(self, T_world_pin_body: np.ndarray, T_world_bore_body: np.ndarray,
                 margin_m: float) -> FitContact:
        """Contact points with a gap below ``margin_m`` (m) at these body poses."""
        Tp, Tb = self.frames(T_world_pin_body, T_world_bore_body)
        if self._apart(Tp, Tb, margin_m):
            return FitContact(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
        Rb, pb = Tb[:3, :3], Tb[:3, 3]
        Rp, pp = Tp[:3, :3], Tp[:3, 3]

        def pin_edge_vs_block(world_pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            d, n = revolved_sdf((world_pts - pb) @ Rb, self._bore_profile)
            return d, n @ Rb.T

        def block_edge_vs_pin(world_pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            d, n = revolved_sdf((world_pts - pp) @ Rp, self._pin_profile)
            return d, -(n @ Rp.T)

        pts, nrm, gap = [], [], []
        single = True
        key = T_world_pin_body.tobytes() + T_world_bore_body.tobytes()
        if self._samples is None or self._samples[0] != key:
            self._samples = (key, {})
        for circles, R, origin, sdf, on_pin in (
                (self._pin_circles, Rp, pp, pin_edge_vs_block, True),
                (self._bore_circles, Rb, pb, block_edge_vs_pin, False)):
            heights, radii = self._circle_arrays[on_pin]
            centres = origin + heights[:, None] * R[:, 2]  # (C, 3)
            ring = self._cos[:, None] * R[:, 0] + self._sin[:, None] * R[:, 1]  # (n, 3)
            prof = self._bore_profile if on_pin else self._pin_profile
            sampled = self._samples[1].get(on_pin)
            if sampled is None:  # the samples in the other solid's frame (fit_samples)
                world = (centres[:, None, :] + radii[:, None, None] * ring[None]).reshape(-1, 3)
                other_R, other_origin = (Rb, pb) if on_pin else (Rp, pp)
                sampled = SampledCircles((world - other_origin) @ other_R, len(circles), prof,
                                         self._bore_bound if on_pin else self._pin_bound)
                self._samples[1][on_pin] = sampled
            d_all, segments, second_m = sampled.at(margin_m, FLAT_TOLERANCE_M)
            single = single and not second_m < margin_m
            rows, ang = _candidates(d_all, margin_m, segments)
            if rows.size == 0:
                continue
            refined = self._samples[1].get((on_pin, rows.tobytes(), ang.tobytes()))
            if refined is None:  # the same candidates at the same poses: the same points
                p = centres[rows] + radii[rows, None] * (np.cos(ang)[:, None] * R[:, 0]
                                                         + np.sin(ang)[:, None] * R[:, 1])
                d2, n2 = sdf(p)
                refined = (p, d2, n2, prof.near_convex_vertex(EDGE_EDGE_M))
                self._samples[1][on_pin, rows.tobytes(), ang.tobytes()] = refined
            p, d2, n2, vertex_all = refined
            keep = d2 < margin_m
            if on_pin:
                # the block is modelled as its face (out to rim_radius_m) over a solid of
                # revolution; below the face and outside the bore that solid is not the real
                # block (a box): a pin edge there, deeper than any step can take it through
                # the face, is beside the block, not in it (gearbox dowel_1 carried 157 mm
                # from its bore's axis, 1 mm below the face: pushed 0.2 mm by that solid's
                # outer wall and lost from the grip)
                rel = (p - pb) @ Rb
                rho = np.hypot(rel[:, 0], rel[:, 1])
                keep &= (rho <= self.bore.rim_radius_m) & ~(
                    (rel[:, 2] < -BESIDE_DEPTH_M)
                    & (rho > self.bore.radius_m + self.bore.chamfer_m + BESIDE_DEPTH_M))
            if not np.any(keep):
                continue
            p, d2, n2 = p[keep], d2[keep], n2[keep]
            vertex = vertex_all[keep]
            if np.any(vertex >= 0):
                own = np.asarray(self._pin_vertex if on_pin else self._bore_vertex)[rows[keep]]
                d2, n2 = self._edge_edge(p, d2, n2, vertex, own, on_pin,
                                     self._pin_profile if on_pin else self._bore_profile,
                                     prof, Rp, pp, Rb, pb)
            # a point just inside the other solid through a face came from that face's side
            # (the pin comes down onto the block's face; the mouth edge meets the pin's end
            # face from below): it leaves the way it came, not sideways into the bore
            axis = Rb[:, 2] if on_pin else Rp[:, 2]
            height = (p - (pb if on_pin else pp)) @ axis
            via_face = (d2 < 0.0) & (np.abs(height) <= FACE_ENTRY_M) & (
                height <= 0.0 if on_pin else height >= 0.0)
            if np.any(via_face):
                n2 = n2.copy()
                d2 = d2.copy()
                n2[via_face] = axis
                d2[via_face] = height[via_face] if on_pin else -height[via_face]
            if on_pin:  # the point on the block's surface
                p = p - d2[:, None] * n2
            pts.append(p)
            nrm.append(n2)
            gap.append(d2)
        if not self.bore.through:
            floor = self._floor_contacts(Rp, pp, Rb, pb, margin_m)
            if floor is not None:
                single = False
                pts.append(floor[0])
                nrm.append(floor[1])
                gap.append(floor[2])
        if not gap:
            return FitContact(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
        return FitContact(np.vstack(pts), np.vstack(nrm), np.concatenate(gap), single)

    def _floor_contacts(self, Rp: np.ndarray, pp: np.ndarray, Rb: np.ndarray, pb: np.ndarray,
                        margin_m: float
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The pin's edge circles against a blind bore's floor, as a plane of its own.

        The point-to-solid distance gives each sampled edge point one nearest face: a pin
        tip standing in the concave corner of wall and floor got only the wall (nearer by
        micrometres) and nothing held it up; the re-integrated pose sank below the floor and
        the position projection lifted it back without touching its velocity, which grew at
        g (fits bench pin released on the rim, tipped in and seated: 1.00 m/s at rest,
        'fell'). Both faces of a concave corner are active, so the floor is tested on its
        own: every edge point inside the bore's radius within ``margin_m`` of the floor
        plane (points, normals (the bore's outward axis), gaps) or None."""
        axis = Rb[:, 2]
        floor_z = -self.bore.depth_m
        heights, radii = self._circle_arrays[True]
        centres = pp + heights[:, None] * Rp[:, 2]
        tilt = math.hypot(float(Rp[:, 0] @ axis), float(Rp[:, 1] @ axis))
        if float(np.min((centres - pb) @ axis - radii * tilt)) >= floor_z + margin_m + SKIP_BAND_M:
            return None  # every edge point lies farther than the margin above the floor
        ring = self._cos[:, None] * Rp[:, 0] + self._sin[:, None] * Rp[:, 1]
        world = centres[:, None, :] + radii[:, None, None] * ring[None]  # (C, n, 3)
        rel = (world - pb) @ Rb
        gap = rel[..., 2] - floor_z
        inside = np.hypot(rel[..., 0], rel[..., 1]) <= self.bore.radius_m
        values = np.where(inside, gap, _FAR)  # outside the bore: no floor there
        if not np.any(values < margin_m):
            return None
        rows, ang = _candidates(values, margin_m)
        if rows.size == 0:
            return None
        p = centres[rows] + radii[rows, None] * (np.cos(ang)[:, None] * Rp[:, 0]
                                                 + np.sin(ang)[:, None] * Rp[:, 1])
        d = (p - pb) @ axis - floor_z
        keep = d < margin_m
        if not np.any(keep):
            return None
        p, d = p[keep], d[keep]
        return p - d[:, None] * axis, np.tile(axis, (d.size, 1)), d

    @staticmethod
    def _edge_edge(p: np.ndarray, d2: np.ndarray, n2: np.ndarray, vertex: np.ndarray,
                   own_vertex: np.ndarray, on_pin: bool, own_prof: Profile, prof: Profile,
                   Rp: np.ndarray, pp: np.ndarray, Rb: np.ndarray, pb: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Normals of sampled edge points ``p`` (their circle: ``own_vertex`` of their own
        profile, -1 for the shoulder's seat circle) touching an edge of the other solid (its
        convex profile ``vertex``, -1 where none).

        Where two edges cross, the point-to-surface direction is ill-defined: where the pin's
        tip circle crosses the mouth circle in plan view (a pin over the rim by less than a
        micrometre) it came out sideways and levered an unchamfered pin off the rim into the
        bore (fits bench, 5 um fit 5 um off). The cross product of the two circles' tangents
        is the ideal edges' normal, but where they cross at a shallow angle (a few 1e-4 rad
        there) a tilt of the same size turns it by tens of degrees: the contact is in fact the
        two faces meeting across the sliver between the circles (the pin's end face on the
        block's face). So the normal is the bisector of the two faces that meet: of each
        edge's two faces, the one facing the other edge along the cross product."""
        sel = np.flatnonzero((vertex >= 0) & (own_vertex >= 0))
        if sel.size == 0:
            return d2, n2
        own_axis, own_origin, own_R = (Rp[:, 2], pp, Rp) if on_pin else (Rb[:, 2], pb, Rb)
        other_axis, other_origin, other_R = (Rb[:, 2], pb, Rb) if on_pin else (Rp[:, 2], pp, Rp)
        # only where the two circles cross seen along the other's axis (the end face overlaps
        # the other's face there); circles touching from inside (a pin against the wall at
        # the mouth) keep the point-to-surface normal: the side meets the wall
        own_rz = own_prof.polygon[own_vertex[sel]]
        rel_c = own_origin + own_rz[:, 1:] * own_axis - other_origin
        ecc = np.linalg.norm(rel_c - np.outer(rel_c @ other_axis, other_axis), axis=1)
        rho_other = prof.polygon[vertex[sel], 0]
        crossing = (ecc > np.abs(rho_other - own_rz[:, 0])) & (ecc < rho_other + own_rz[:, 0])
        sel = sel[crossing]
        if sel.size == 0:
            return d2, n2
        q = p[sel]

        def unit(v: np.ndarray) -> np.ndarray:
            return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)

        t_own = unit(np.cross(own_axis, q - own_origin))
        t_other = unit(np.cross(other_axis, q - other_origin))
        cross = np.cross(t_own, t_other)
        size = np.linalg.norm(cross, axis=1)
        use = size > EDGE_PARALLEL_SIN
        if not np.any(use):
            return d2, n2
        sel, q, cross = sel[use], q[use], cross[use] / size[use, None]

        def faces(profile: Profile, v: np.ndarray, origin: np.ndarray, R: np.ndarray,
                  sign: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
            """World push directions (sign x outward) of the two faces at vertex ``v`` and
            the bisector, in the meridian plane of each point, and the vertex itself (world)."""
            rel = (q - origin) @ R
            rho = np.hypot(rel[:, 0], rel[:, 1])
            ok = rho > 1e-12
            radial = np.zeros_like(rel)
            radial[:, 0] = np.where(ok, rel[:, 0] / np.where(ok, rho, 1.0), 1.0)
            radial[:, 1] = np.where(ok, rel[:, 1] / np.where(ok, rho, 1.0), 0.0)
            z = np.array([0.0, 0.0, 1.0])

            def world(n2d: np.ndarray) -> np.ndarray:
                return sign * ((n2d[:, :1] * radial + n2d[:, 1:] * z) @ R.T)

            k = profile.polygon.shape[0]
            vx = profile.polygon[v]
            corner = origin + (vx[:, :1] * radial + vx[:, 1:] * z) @ R.T
            return (world(profile._seg_n[(v - 1) % k]), world(profile._seg_n[v]),
                    world(profile.vertex_bisector[v]), corner)

        # push directions on the pin: the block's outward normals, minus the pin's
        other_sign, own_sign = (1.0, -1.0) if on_pin else (-1.0, 1.0)
        oa, ob, obis, corner = faces(prof, vertex[sel], other_origin, other_R, other_sign)
        wa, wb, _, _ = faces(own_prof, own_vertex[sel], own_origin, own_R, own_sign)
        cross *= np.where(np.sum(cross * obis, axis=1) >= 0.0, 1.0, -1.0)[:, None]

        def facing(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            pick = np.sum(a * cross, axis=1) >= np.sum(b * cross, axis=1)
            return np.where(pick[:, None], a, b)

        n_new = unit(facing(oa, ob) + facing(wa, wb))
        out, gap = n2.copy(), d2.copy()
        out[sel] = n_new
        # pin point minus block point along the push on the pin
        gap[sel] = np.sum(((q - corner) if on_pin else (corner - q)) * n_new, axis=1)
        return gap, out

    def bore_axis_world(self, T_world_bore_body: np.ndarray) -> np.ndarray:
        """The bore's axis (unit, outward) in the world."""
        return T_world_bore_body[:3, :3] @ self._T_link_bore[:3, 2]
