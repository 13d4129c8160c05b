"""The exact fit contact's clearance proof in scalar arithmetic (issues 16/17: the seed job's
simulation CPU).

Why
---
:class:`~asmplan.sim.feature_contact.HeldFitContact` keeps Bullet's step without detecting
contacts whenever it can prove that every contact point a detection would return has a gap
above a threshold (:meth:`asmplan.sim.fit_geometry.FitContactModel.clear_of`): twice per pair
and physics step, whatever the phase (the pin carried 40 mm above its bore; the pin sliding
down its bore's mouth without touching). Written on numpy arrays of 2-3 edge circles, one proof
cost 45-65 us of which almost all is numpy's per-call dispatch (about 60 array operations
on (3,) and (C, 3) arrays); the seed job's three steps make about 60,000 of them.

What
----
:class:`ClearanceProof` is the same proof, term for term, on Python floats: the pin apart
from the block's face or beyond its rim (:meth:`FitContactModel._apart`), else the edge
circles' meridian extents (:func:`asmplan.sim.fit_samples.circle_extents`) against each
solid's superset (:meth:`asmplan.sim.fit_samples.MaterialBound.lower_box`), a blind bore's
floor, and no two edges crossing in plan view. Only the order of a few floating-point sums
differs (the world frames are composed by hand instead of by a 4x4 product), i.e. at the
1e-16 m level, far inside the proof's own slack (``SKIP_BAND_M``, 1 nm): a proof can only say
True where every contact has a gap above the threshold, and a True where the numpy version
said False would only skip a detection whose every gap is above it, which the caller would
have discarded the same way. Results are therefore unchanged, bit for bit.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .fit_samples import SKIP_BAND_M

if TYPE_CHECKING:
    from .fit_geometry import FitContactModel

Vec = tuple[float, float, float]


def _frame(T_world_body: np.ndarray, T_link_feature: np.ndarray) -> tuple[Vec, Vec, Vec, Vec]:
    """The feature's world frame (T_world_body @ T_link_feature): its x, y, z axes and origin."""
    (a, b, c, tx), (d, e, f, ty), (g, h, i, tz), _ = T_world_body.tolist()
    (p, q, r, ox), (s, t, u, oy), (v, w, x, oz), _ = T_link_feature.tolist()
    return ((a * p + b * s + c * v, d * p + e * s + f * v, g * p + h * s + i * v),
            (a * q + b * t + c * w, d * q + e * t + f * w, g * q + h * t + i * w),
            (a * r + b * u + c * x, d * r + e * u + f * x, g * r + h * u + i * x),
            (a * ox + b * oy + c * oz + tx, d * ox + e * oy + f * oz + ty,
             g * ox + h * oy + i * oz + tz))


def _dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _extents(x: Vec, y: Vec, z: Vec, origin: Vec, circles: tuple[tuple[float, float], ...],
             zo: Vec, origin_other: Vec) -> list[tuple[float, float, float, float, float]]:
    """:func:`asmplan.sim.fit_samples.circle_extents` of one family of circles (height along
    the own axis ``z``, radius) in the other frame (axis ``zo``): per circle (rho_lo, rho_hi,
    z_lo, z_hi, ecc)."""
    lean = min(1.0, math.hypot(_dot(x, zo), _dot(y, zo)))
    flat = math.sqrt(1.0 - lean * lean)
    out = []
    for h, r in circles:
        rx = origin[0] + h * z[0] - origin_other[0]
        ry = origin[1] + h * z[1] - origin_other[1]
        rz = origin[2] + h * z[2] - origin_other[2]
        z_c = rx * zo[0] + ry * zo[1] + rz * zo[2]
        ecc = math.sqrt((rx - z_c * zo[0]) ** 2 + (ry - z_c * zo[1]) ** 2
                        + (rz - z_c * zo[2]) ** 2)
        out.append((r * flat - ecc, ecc + r, z_c - r * lean, z_c + r * lean, ecc))
    return out


def _lower_box(bound, rho_lo: float, rho_hi: float, z_lo: float, z_hi: float) -> float:
    """:meth:`asmplan.sim.fit_samples.MaterialBound.lower_box` of one box."""
    hole = min(bound.rho_hole - rho_hi, z_lo - bound.z_floor)
    return max(z_lo - bound.z_max, bound.z_min - z_hi, rho_lo - bound.rho_max, hole)


class ClearanceProof:
    """:meth:`FitContactModel.clear_of` of one model on Python floats (module docstring).

    Parameters
    ----------
    model : FitContactModel
    """

    def __init__(self, model: FitContactModel) -> None:
        self._T_link_pin = model._T_link_pin
        self._T_link_bore = model._T_link_bore
        self._pin_circles = tuple((float(h), float(r)) for h, r in model._pin_circles)
        self._bore_circles = tuple((float(h), float(r)) for h, r in model._bore_circles)
        self._far = float(model._far)
        self._pin_length = float(model.pin.length_m)
        self._pin_bound = model._pin_bound
        self._bore_bound = model._bore_bound
        self._blind_depth = None if model.bore.through else float(model.bore.depth_m)
        # the edge circles that are vertices of their own profile, and the other profile's
        # convex vertices' radii (the plan-view crossing test), per family (pin, bore)
        self._own = ([k for k, v in enumerate(model._pin_vertex) if v >= 0],
                     [k for k, v in enumerate(model._bore_vertex) if v >= 0])
        self._rv = (tuple(float(v) for v in model._bore_profile.polygon[
                        model._bore_profile.vertex_convex, 0]),
                    tuple(float(v) for v in model._pin_profile.polygon[
                        model._pin_profile.vertex_convex, 0]))

    def apart(self, pin: tuple[Vec, Vec, Vec, Vec], bore: tuple[Vec, Vec, Vec, Vec],
              margin_m: float) -> bool:
        """:meth:`FitContactModel._apart` at the features' world frames (axes, origin)."""
        zp, pp = pin[2], pin[3]
        zb, pb = bore[2], bore[3]
        rel = (pp[0] - pb[0], pp[1] - pb[1], pp[2] - pb[2])
        tip_z = _dot(zb, rel)
        ax_z = _dot(zb, zp)
        lean = math.sqrt(max(0.0, 1.0 - ax_z * ax_z))
        lowest = min(tip_z + s * ax_z - rad * lean for s, rad in self._pin_circles)
        if lowest > margin_m:
            return True
        lateral = math.sqrt((rel[0] - tip_z * zb[0]) ** 2 + (rel[1] - tip_z * zb[1]) ** 2
                            + (rel[2] - tip_z * zb[2]) ** 2)
        return lateral > self._far + self._pin_length * lean + margin_m

    def clear_of(self, T_world_pin_body: np.ndarray, T_world_bore_body: np.ndarray,
                 margin_m: float, gap_m: float) -> bool:
        """True only if every contact :meth:`FitContactModel.contacts` returns at these poses
        with this margin has a gap above ``gap_m`` (m); False says nothing."""
        pin = _frame(T_world_pin_body, self._T_link_pin)
        bore = _frame(T_world_bore_body, self._T_link_bore)
        if self.apart(pin, bore, margin_m):
            return True
        if self._pin_bound is None or self._bore_bound is None:
            return False
        need = gap_m + SKIP_BAND_M
        pin_ext = _extents(*pin, self._pin_circles, bore[2], bore[3])
        bound = self._bore_bound
        for rho_lo, rho_hi, z_lo, z_hi, _ in pin_ext:
            if _lower_box(bound, rho_lo, rho_hi, z_lo, z_hi) < need:
                return False
        if self._blind_depth is not None and (
                min(e[2] for e in pin_ext) < need - self._blind_depth):
            return False
        bore_ext = _extents(*bore, self._bore_circles, pin[2], pin[3])
        bound = self._pin_bound
        for rho_lo, rho_hi, z_lo, z_hi, _ in bore_ext:
            if _lower_box(bound, rho_lo, rho_hi, z_lo, z_hi) < need:
                return False
        return not self.edges_may_cross(pin_ext, bore_ext, SKIP_BAND_M)

    def edges_may_cross(self, pin_ext: list, bore_ext: list, band: float) -> bool:
        """Whether an edge circle of either feature may come within ``band`` of an edge circle
        of the other (from each own circle's radial extent against the other's radii)."""
        for ext, circles, own, rvs in ((pin_ext, self._pin_circles, self._own[0], self._rv[0]),
                                       (bore_ext, self._bore_circles, self._own[1],
                                        self._rv[1])):
            for k in own:
                e, r = ext[k][4], circles[k][1]
                for rv in rvs:
                    if abs(rv - r) - band < e < rv + r + band:
                        return True
        return False


def _box_segment_lower(rho_lo: float, rho_hi: float, z_lo: float, z_hi: float,
                       segment: tuple[float, float, float, float]) -> float:
    """Lower bound of the distance from any point of a meridian box to a profile segment
    (a_rho, a_z, b_rho, b_z): the distance between the box and the segment's bounding box."""
    ar, az, br, bz = segment
    dr = max(0.0, min(ar, br) - rho_hi, rho_lo - max(ar, br))
    dz = max(0.0, min(az, bz) - z_hi, z_lo - max(az, bz))
    return math.hypot(dr, dz)


class DeferredReuse:
    """Decide the reuse of a deferred detection without making it, where that can be proved.

    :meth:`HeldFitContact._stands` leaves the detection at the pre-step pose T0 undone (the
    step stands) and :meth:`HeldFitContact._detect_near` makes it when a later step may reuse
    it (the held body moved less than ``REUSE_MOTION_M`` across, ``REUSE_SLIDE_M`` along the
    bore since T0): a pin slowing down its bore without touching had it made every 2-3 steps
    (1.3-1.5 ms for two pins), although each of those steps kept Bullet's step. Its use there
    is (1) whether it is reused at all, which depends on its ``single_feature`` when only the
    sliding reuse holds, and (2) whether its first-order gaps stay above the friction gap.

    :meth:`stands` proves both without detecting, on the exact geometry at T0 and the detection's
    own margin: each pair apart, or every edge circle within the margin of the other solid
    (its meridian box's superset distance) has exactly one profile segment nearer than the
    margin, a straight wall or pin side (so every sample it evaluates has its second-nearest
    segment beyond the margin: single-feature, normals perpendicular to the axis), no floor
    within the margin, no two edges crossing; a pin circle wholly inside the bore's wall
    within the margin (the detection is not empty); and the gaps' lower bound (the proof of
    :class:`ClearanceProof`) less what the motion since T0 can change them to first order (the
    motion across the bore's axis, the slide along it times the pin's lean, the rotation times
    the farthest circle's lever) above the friction gap. It then applies what the reuse would
    have done (the step stands) and leaves the detection deferred, to be made, from the same
    inputs, by the first step that needs it: every result is the same, bit for bit. Anything
    it cannot prove returns False and the detection is made as before.
    """

    def __init__(self, contact) -> None:
        self._contact = contact
        self._facts: tuple[object, tuple | None] | None = None
        self.skipped = 0

    def _pair_facts(self, T0: np.ndarray, m0: float, partners: dict) -> tuple | None:
        """(per non-apart pair: (gap lower bound, bore axis, sine of the pin's lean, lever),
        whether the detection is surely non-empty, whether every non-empty pair is surely
        single-feature) at the deferred pose, or None when not provable."""
        from .fit_geometry import FLAT_TOLERANCE_M  # (fit_geometry imports this module)

        fc = self._contact
        c0 = T0[:3, :3] @ fc._com_link + T0[:3, 3]
        c0 = (float(c0[0]), float(c0[1]), float(c0[2]))
        band = SKIP_BAND_M
        out, nonempty = [], False
        for pair in fc.pairs:
            if not pair.held_is_pin:
                return None
            model = pair.model
            proof: ClearanceProof = model._proof
            T_other = partners[pair.partner]
            pin = _frame(T0, proof._T_link_pin)
            bore = _frame(T_other, proof._T_link_bore)
            if proof.apart(pin, bore, m0):
                continue
            cached = model._samples
            if cached is not None and cached[0] == T0.tobytes() + T_other.tobytes():
                return None  # samples of another margin kept at this pose: not proved here
            if proof._pin_bound is None or proof._bore_bound is None:
                return None
            R_bore, ch, depth = model.bore.radius_m, model.bore.chamfer_m, model.bore.depth_m
            pin_ext = _extents(*pin, proof._pin_circles, bore[2], bore[3])
            bore_ext = _extents(*bore, proof._bore_circles, pin[2], pin[3])
            if proof._blind_depth is not None and (
                    min(e[2] for e in pin_ext) < -depth + m0 + 2.0 * band):
                return None  # floor contacts possible
            if proof.edges_may_cross(pin_ext, bore_ext, band):
                return None  # two edges may cross
            gap = math.inf
            lever = 0.0
            for ext, circles, bound, prof, own_frame in (
                    (pin_ext, proof._pin_circles, proof._bore_bound, model._bore_profile, pin),
                    (bore_ext, proof._bore_circles, proof._pin_bound, model._pin_profile, bore)):
                poly = prof.polygon.tolist()
                segments = [(*poly[j], *poly[(j + 1) % len(poly)]) for j in range(len(poly))]
                z_own, o_own = own_frame[2], own_frame[3]
                for (rho_lo, rho_hi, z_lo, z_hi, _), (h, r) in zip(ext, circles, strict=True):
                    lo = _lower_box(bound, rho_lo, rho_hi, z_lo, z_hi)
                    if lo >= m0 + FLAT_TOLERANCE_M + 2.0 * band:  # no sample evaluated
                        continue
                    dists = sorted((_box_segment_lower(rho_lo, rho_hi, z_lo, z_hi, s), s)
                                   for s in segments)
                    if dists[1][0] < m0 + band:
                        return None  # maybe two features within the margin
                    near = dists[0][1]
                    if dists[0][0] < m0 + band and near[0] != near[2]:
                        return None  # the one feature is not a wall parallel to the axis
                    gap = min(gap, lo)
                    centre = (o_own[0] + h * z_own[0] - c0[0], o_own[1] + h * z_own[1] - c0[1],
                              o_own[2] + h * z_own[2] - c0[2])
                    lever = max(lever, math.sqrt(_dot(centre, centre)) + r + m0)
            for rho_lo, _, z_lo, z_hi, _ in pin_ext:
                if (R_bore - rho_lo < m0 - band and z_hi < -ch - band
                        and z_lo > -depth + band):
                    nonempty = True  # every sample of this circle within the margin of the wall
            cos_lean = _dot(bore[2], pin[2])
            out.append((gap - band, bore[2], math.sqrt(max(0.0, 1.0 - cos_lean * cos_lean)),
                        lever))
        return out, nonempty

    def stands(self, T_prev: np.ndarray, margin: float, friction_gap_m: float,
               min_margin_m: float) -> np.ndarray | None:
        """The pose Bullet's step reached when that step stands as it would after reusing the
        deferred detection (gaps above ``friction_gap_m``, none penetrating there within
        ``min_margin_m``), proved without making it; None when not proved."""
        fc = self._contact
        base = fc._base
        if base is None or base[1] is not None or base[3] < margin or base[4] is None:
            return None
        T0, m0 = base[0], base[3]
        dc, dth = fc._motion(T_prev, T0)
        if not fc._reuse_ok(True, dc, dth, margin):
            return None
        either = fc._reuse_ok(False, dc, dth, margin)
        if self._facts is None or self._facts[0] is not base:
            self._facts = (base, self._pair_facts(T0, m0, base[4]))
        facts = self._facts[1]
        if facts is None:
            return None
        pairs, nonempty = facts
        if not (either or nonempty):
            return None
        d = (float(dc[0]), float(dc[1]), float(dc[2]))
        turn = math.sqrt(float(dth @ dth))
        for gap, axis, sin_lean, lever in pairs:
            slide = _dot(d, axis)
            across = math.sqrt(max(0.0, _dot(d, d) - slide * slide))
            if gap - (across + abs(slide) * sin_lean + lever * turn) <= friction_gap_m + SKIP_BAND_M:
                return None
        T_step = fc.world.pose(fc.held_body)
        if not fc._clear(T_step, min_margin_m, 0.0):
            return None
        self.skipped += 1
        return T_step
