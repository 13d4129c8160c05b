"""The collision pieces of a gripper pad: a box, or a box with a V-groove (prism jaw).

A V-groove of included angle ``theta`` and depth ``d`` runs along the pad's length (its z
axis) in the middle of its contact face: the face is cut away for ``|x| < w``,
``w = d tan(theta / 2)``, down to the apex at depth ``d``. Articulated links take only
primitive pieces (:meth:`~asmplan.sim.bullet.BulletWorld.add_articulated`), so the grooved
pad is five boxes, all exactly inside the pad's envelope or on its faces: the back slab
behind the apex (depth ``d`` to the back face), two lands (``w <= |x| <= W/2``, full
thickness) and two flank boxes whose front faces are the groove's flanks (from the apex to
the groove's edge at the face). Boxes keep PyBullet's collision margin inside them, so the
flank faces are where the contact is: a round part lying along the groove touches each flank
along a line, and the solver gets contact points on both flanks of both pads.
"""

from __future__ import annotations

import math

import numpy as np

from ..parts.pieces import ConvexPiece


def _box(centre_xy: tuple[float, float], half: tuple[float, float, float],
         angle_rad: float = 0.0) -> ConvexPiece:
    T = np.eye(4)
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    T[:2, :2] = [[c, -s], [s, c]]
    T[0, 3], T[1, 3] = centre_xy
    return ConvexPiece(kind="box", T_part_piece=T, half_extents_m=np.asarray(half, float))


def pad_pieces(size_m: np.ndarray, face_sign: float, groove_angle_rad: float = 0.0,
               groove_depth_m: float = 0.0) -> tuple[ConvexPiece, ...]:
    """The pieces of one pad in its link frame (the pad box's centre).

    Parameters
    ----------
    size_m : (3,) float array
        Pad width (x), thickness (y, the closing axis) and length (z), m.
    face_sign : float
        -1 when the contact face is at ``y = -thickness / 2`` (the finger at +y), +1 when
        it is at ``+thickness / 2``.
    groove_angle_rad, groove_depth_m : float
        The V-groove; a depth of 0 gives the plain box.

    Returns
    -------
    tuple of ConvexPiece
        One box, or five (back slab, two lands, two flanks) for a grooved pad.
    """
    W, t, L = (float(v) for v in size_m)
    d = float(groove_depth_m)
    if d <= 0.0:
        return (ConvexPiece(kind="box", T_part_piece=np.eye(4),
                            half_extents_m=np.array([W, t, L]) / 2.0),)
    w = d * math.tan(0.5 * float(groove_angle_rad))
    if not (0.0 < w < W / 2 and d < t):
        raise ValueError(f"pad groove: expected width {2 * w:g} m < pad width {W:g} m and depth "
                         f"{d:g} m < thickness {t:g} m")

    def y_of(depth: float) -> float:  # link-frame y of a point ``depth`` behind the face
        return face_sign * (t / 2.0 - depth)

    pieces = [_box((0.0, y_of(0.5 * (d + t))), (w, 0.5 * (t - d), L / 2))]
    half_land = 0.5 * (W / 2 - w)
    for sx in (-1.0, 1.0):
        pieces.append(_box((sx * (w + half_land), 0.0), (half_land, t / 2, L / 2)))
    # flank from the apex (0, depth d) to the edge (w, depth 0); the box lies behind it
    flank = math.hypot(w, d)
    tau = min(t - d, d) if t - d > 0 else d
    ux, udepth = w / flank, -d / flank          # along the flank, (x, depth)
    nx, ndepth = d / flank, w / flank           # into the pad, (x, depth)
    for sx in (-1.0, 1.0):
        cx = sx * (0.5 * w + 0.5 * tau * nx)
        cdepth = 0.5 * d + 0.5 * tau * ndepth
        # the box's x axis along the flank in link coordinates (x, y)
        vx, vy = sx * ux, -face_sign * udepth
        pieces.append(_box((cx, y_of(cdepth)), (flank / 2, tau / 2, L / 2), math.atan2(vy, vx)))
    return tuple(pieces)
