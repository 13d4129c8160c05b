"""One grasp candidate's pads on the part's surface: the surface samples under a pad's
footprint (:class:`Strip`, per candidate frame :class:`Frame`), the contact found there and
its two contact patches (:func:`evaluate`). Split out of :mod:`asmplan.planner.grasp` (the
candidates and their ranking), which re-exports ``CONTACT_BAND_M``."""

from __future__ import annotations

import math

import numpy as np

from ..knowledge.model import GraspHint, Groove
from .grasp_groove import groove_seat
from .grasp_hold import ContactPatch
from .grasp_patch import FrameTriangles

CONTACT_BAND_M = 3e-4
"""Surface points within this distance of a pad's plane count as touching it, m."""

_MIN_CONTACT_POINTS = 3
RASTER_BELOW = 30
"""A pad's patch with fewer samples than this is measured on the mesh: the mean distance of
k random samples from their centroid scatters by some 1/sqrt(k) of the patch's."""


class Strip:
    """Surface points of one candidate frame within a band of gripper x, sorted by z."""

    __slots__ = ("N", "S", "X", "Y", "Z")

    def __init__(self, frame: Frame, u: float, half_width: float) -> None:
        keep = np.abs(frame.X - u) <= half_width
        self.X = frame.X[keep]
        self.Z = frame.Z[keep]
        self.Y = frame.Y[keep]
        self.N = frame.N[keep]
        self.S = frame.S[keep]

    def window(self, z_lo: float, z_hi: float) -> slice:
        return slice(int(np.searchsorted(self.Z, z_lo, side="left")),
                     int(np.searchsorted(self.Z, z_hi, side="right")))


class Frame:
    """Surface points projected on one candidate gripper frame, sorted by z (approach)."""

    __slots__ = ("N", "S", "X", "Y", "Z")

    def __init__(self, XYZ: np.ndarray, N: np.ndarray, n_area: int | None = None) -> None:
        order = np.argsort(XYZ[2], kind="stable")
        self.X, self.Y, self.Z = XYZ[0, order], XYZ[1, order], XYZ[2, order]
        self.N = N[order]
        # area samples (True) apart from mesh vertices (False); all area samples if unknown
        self.S = (order < n_area) if n_area is not None else np.ones(order.size, bool)


def evaluate(pad: Strip, palm_strip: Strip, x: np.ndarray, c: np.ndarray,
              a: np.ndarray, com: np.ndarray, u: float, v: float, L: float,
              palm: np.ndarray, cos_cone: float, max_width: float, stroke: float,
              clearance: float, area_per_point: float, hint: GraspHint | None,
              groove: Groove | None = None, tris: FrameTriangles | None = None,
              half_width: float = 0.0) -> tuple[np.ndarray, float, float, float, float,
                         tuple[ContactPatch, ContactPatch], float] | None:
    """(T_part_gripper, width, open width, contact area, CoM offset, the two pads' contact
    patches (+y, -y), y of the pads' midplane in the frame's coordinates) or None.

    With grooved pads (``groove``), a part that seats in both grooves (:func:`groove_seat`)
    is held on the four flanks; one that touches the lands only is held as by flat pads (the
    flat patches about the pad's centre line under-count the torsion of the two strips
    either side of the groove); one that would seat off the pads' centre line is rejected
    (the grooves centre it, away from the planned pose)."""
    w = pad.window(v - L / 2, v + L / 2)
    yin = pad.Y[w]
    if yin.size == 0:
        return None
    y_max, y_min = float(yin.max()), float(yin.min())
    width = y_max - y_min
    if width <= 1e-4 or width > max_width:
        return None
    top = yin >= y_max - CONTACT_BAND_M
    bot = yin <= y_min + CONTACT_BAND_M
    if top.sum() < _MIN_CONTACT_POINTS or bot.sum() < _MIN_CONTACT_POINTS:
        return None
    # the contact normals must lie inside the friction cone about the closing direction;
    # judged on the area samples where a pad has enough of them (a vertex on an edge carries
    # the average of its faces' normals: 45 deg on the rim of a cylinder a pad just overlaps)
    n_in, s_in = pad.N[w], pad.S[w]
    if (top & s_in).sum() >= _MIN_CONTACT_POINTS and (bot & s_in).sum() >= _MIN_CONTACT_POINTS:
        top, bot = top & s_in, bot & s_in
    top_ok = (n_in[top] @ c) >= cos_cone
    bot_ok = (n_in[bot] @ -c) >= cos_cone
    if top_ok.mean() < 0.5 or bot_ok.mean() < 0.5:
        return None
    area = min(float(top_ok.sum()), float(bot_ok.sum())) * area_per_point
    y_mid = 0.5 * (y_max + y_min)
    # palm box behind the finger roots: z in [v - L/2 - palm_z, v - L/2), centred on the TCP
    z_root = v - L / 2
    pw = palm_strip.window(z_root - palm[2], z_root)
    yp = palm_strip.Y[pw]
    if np.any((np.abs(yp - y_mid) <= palm[1] / 2) & (palm_strip.Z[pw] < z_root)):
        return None
    def placed() -> tuple[np.ndarray, float]:
        """The grasp's pose (x across, c closing, a along) and the fingers' open width."""
        T = np.eye(4)
        T[:3, 0], T[:3, 1], T[:3, 2] = x, c, a
        T[:3, 3] = com + u * x + y_mid * c + v * a
        open_width = min(stroke, width + 2.0 * clearance)
        if hint is not None and hint.width_m is not None and width <= hint.width_m <= stroke:
            open_width = float(hint.width_m)
        return T, open_width

    xin, zin = pad.X[w], pad.Z[w]
    if groove is not None:
        seat = groove_seat(xin - u, yin - y_mid, zin - v, n_in @ x, n_in @ c, groove,
                           cos_cone, area_per_point)
        if seat is False:
            return None
        if seat is not None:
            T, open_width = placed()
            area = min(p.area_m2 for p in seat)
            return T, width, open_width, area, math.hypot(u, v), seat, y_mid
    ti, bi = np.flatnonzero(top)[top_ok], np.flatnonzero(bot)[bot_ok]

    def patch(idx: np.ndarray, side: int, y_ref: float) -> ContactPatch:
        """The pad's contact patch: rasterised on the mesh where the samples are too few to
        measure it (:mod:`asmplan.planner.grasp_patch`), else from the samples."""
        if tris is not None and idx.size < RASTER_BELOW:
            r = tris.contact(side, u, v, half_width, L / 2, y_ref, CONTACT_BAND_M, cos_cone)
            if r is not None:
                return ContactPatch.rigid(r[0], r[1], r[3], CONTACT_BAND_M, r[2])
        n = n_in[idx]
        return ContactPatch.rigid(np.stack([xin[idx] - u, zin[idx] - v], axis=1),
                                  side * (y_ref - yin[idx]), float(idx.size) * area_per_point,
                                  CONTACT_BAND_M,
                                  np.stack([n @ x, n @ a], axis=1) / (side * (n @ c))[:, None])

    patches = (patch(ti, 1, y_max), patch(bi, -1, y_min))
    T, open_width = placed()
    return T, width, open_width, area, math.hypot(u, v), patches, y_mid
