"""Where a part seats in V-grooved pads (prism jaws), from its surface samples.

A V-groove of included angle ``theta`` along the pad's length (gripper z) has two flanks whose
normals (towards the part) are ``(+-cos(theta/2), -sin(theta/2))`` in the pad's (x, closing)
plane for the pad at +y, mirrored for the pad at -y. A part touches a flank where it reaches
farthest along that flank's outward direction ``f``: its support ``max(p . f)`` over the
samples. It seats on both flanks of both pads when

- each flank's support point lies on the flank (between the apex, ``x = 0``, and the groove's
  edge, ``|x| = w``, ``w = depth tan(theta/2)``),
- the lands beside the groove stay clear of the part with the pad seated on its flanks, and
- the part is centred on the groove: the two flanks' supports of a pad are equal within
  :data:`CENTRE_TOLERANCE_M` (a part off the pad's centre line is pushed onto it by the
  grooves, away from the planned pose).

The contact patch of a flank is its support line: the samples within the contact band of the
support, moved across onto the support point (a round part touches a flank along one line).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from ..knowledge.model import Groove
from .grasp_hold import ContactPatch

CENTRE_TOLERANCE_M = 2e-4
"""Largest offset of the part from the grooves' centre line for a planned V seat, m."""

_BAND_M = 3e-4
_MIN_POINTS = 3


def groove_seat(x_m: np.ndarray, y_m: np.ndarray, z_m: np.ndarray, nx: np.ndarray,
                ny: np.ndarray, groove: Groove, cos_cone: float, area_per_point_m2: float
                ) -> tuple[ContactPatch, ContactPatch] | Literal[False] | None:
    """The two pads' contact patches (+y, -y) of a part seated in both grooves.

    Parameters
    ----------
    x_m, y_m, z_m : (k,) float arrays
        Surface samples under the pads, m: x across the pad from its centre line, y along the
        closing axis, z along the pad from the TCP.
    nx, ny : (k,) float arrays
        The samples' outward normals' x and y components.
    groove : Groove
    cos_cone : float
        Cosine of the friction cone's half angle: a flank's contact normals must lie in it.
    area_per_point_m2 : float
        Surface area each sample stands for.

    Returns
    -------
    (ContactPatch, ContactPatch), False or None
        The patches of a seated part (``groove_sin = sin(theta/2)``); False when the part
        reaches both grooves' flanks but off their centre line; None when it does not seat
        (it bears on the lands: held as by flat pads).
    """
    cs, sn = math.cos(0.5 * groove.angle_rad), math.sin(0.5 * groove.angle_rad)
    w = groove.half_width_m
    patches = []
    offsets = []
    for side in (1.0, -1.0):
        ys = side * y_m
        flanks = []
        for sx in (1.0, -1.0):
            p = sx * x_m * cs + ys * sn
            s = float(p.max())
            sel = p >= s - _BAND_M
            k = int(np.argmax(p))
            xk = sx * float(x_m[k])
            # the samples on the flank's line: within the band, their normals in the cone
            # (the band also holds samples of faces meeting the round one at an edge)
            sel &= (nx * sx * cs + side * ny * sn) >= cos_cone
            if sel.sum() < _MIN_POINTS or not 0.0 < xk < w:
                return None
            # the pad's face (depth 0) when it bears on this flank: y at the groove's edge
            face = (s - w * cs) / sn
            land = sx * x_m >= w
            if np.any(ys[land] > face + _BAND_M):
                return None
            flanks.append((s, sel, float(x_m[k])))
        (s_r, sel_r, x_r), (s_l, sel_l, x_l) = flanks
        offsets.append((s_r - s_l) / (2.0 * cs))
        pts = np.concatenate([np.stack([np.full(int(sel_r.sum()), x_r), z_m[sel_r]], axis=1),
                              np.stack([np.full(int(sel_l.sum()), x_l), z_m[sel_l]], axis=1)])
        n = min(int(sel_r.sum()), int(sel_l.sum()))
        patches.append(ContactPatch(pts, 2.0 * n * area_per_point_m2, None, sn))
    if max(abs(o) for o in offsets) > CENTRE_TOLERANCE_M:
        return False
    return patches[0], patches[1]
