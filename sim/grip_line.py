"""A flat pad's contact with the held part as the whole line (or patch) it touches, not the one
point Bullet's first contact gives (:mod:`asmplan.sim.grip_pads`).

Bullet's first contact between a flat pad and a round part is one point per pad (GJK's closest
point), and a part at rest in the grip keeps it: the two pads of the fits bench held their pin
at opposite ends of the line contact (pad 0 at 12.5 mm, pad 1 at 5.3 mm up the pin), so the
grip's pressure could carry a moment about the pad-plane axis in one sense only. A flat face
against a convex part touches it where the part's support set along the face normal is: the
part's vertices (hull vertices, box corners, sampled cylinder rims) within a band of the
nearest, and the segments between them clipped to the face's rectangle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..parts.pieces import ConvexPiece

CYLINDER_SAMPLES = 48
"""Rim samples per circle of a cylinder piece."""

SUPPORT_BAND_M = 20e-6
"""Vertices within this of the nearest one along the face normal form the support set, m."""

MAX_POINTS = 12
"""Most contact points per pad (the deepest kept)."""


def piece_vertices_m(pieces: Sequence[ConvexPiece]) -> np.ndarray:
    """The vertices of convex pieces in their body's frame, (n, 3) m: hull vertices, box
    corners, :data:`CYLINDER_SAMPLES` points on each rim of a cylinder (spheres: none)."""
    out = []
    for piece in pieces:
        if piece.kind == "hull" and piece.vertices_m is not None:
            v = np.asarray(piece.vertices_m, dtype=float)
        elif piece.kind == "box" and piece.half_extents_m is not None:
            h = np.asarray(piece.half_extents_m, dtype=float)
            v = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                         dtype=float) * h
        elif piece.kind == "cylinder":
            a = np.linspace(0.0, 2.0 * math.pi, CYLINDER_SAMPLES, endpoint=False)
            ring = np.column_stack([piece.radius_m * np.cos(a), piece.radius_m * np.sin(a)])
            v = np.vstack([np.column_stack([ring, np.full(len(a), s * piece.length_m / 2)])
                           for s in (-1.0, 1.0)])
        else:
            continue
        T = piece.T_part_piece
        out.append(v @ T[:3, :3].T + T[:3, 3])
    return np.vstack(out) if out else np.zeros((0, 3))


def face_contacts(V_world: np.ndarray, face_centre: np.ndarray, R_face: np.ndarray,
                  half_size: tuple[float, float], margin_m: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Contact points of a rectangular face with a convex part.

    Parameters
    ----------
    V_world : (n, 3) float array
        The part's vertices, world frame, m.
    face_centre : (3,) float array
    R_face : (3, 3) float array
        Columns: the face's two in-plane axes (half sizes ``half_size`` along them, m) and
        its outward normal (toward the part).
    margin_m : float
        Points farther in front of the face than this are left out.

    Returns
    -------
    points : (m, 3) float array
        On the part, world frame.
    gaps : (m,) float array
        Their distance in front of the face (negative: inside it), m.
    """
    local = (V_world - face_centre) @ R_face  # (n, 3): in-plane u, w, height h
    h = local[:, 2]
    if h.size == 0:
        return np.zeros((0, 3)), np.zeros(0)
    near = h <= min(float(h.min()) + SUPPORT_BAND_M, margin_m)
    S = local[near]
    if S.shape[0] == 0:
        return np.zeros((0, 3)), np.zeros(0)
    hu, hw = half_size
    cand = [S[(np.abs(S[:, 0]) <= hu) & (np.abs(S[:, 1]) <= hw)]]
    # segments between support vertices, clipped to the rectangle (Liang-Barsky)
    i, j = np.triu_indices(S.shape[0], 1)
    if i.size:
        a, d = S[i], S[j] - S[i]
        t0, t1 = np.zeros(i.size), np.ones(i.size)
        for axis, half in ((0, hu), (1, hw)):
            for sign in (-1.0, 1.0):
                p = sign * d[:, axis]
                q = half - sign * a[:, axis]
                with np.errstate(divide="ignore", invalid="ignore"):
                    r = q / p
                enter = p < 0
                leave = p > 0
                t0 = np.where(enter, np.maximum(t0, r), t0)
                t1 = np.where(leave, np.minimum(t1, r), t1)
                t1 = np.where((p == 0) & (q < 0), -1.0, t1)
        ok = t0 <= t1
        cand.append(a[ok] + t0[ok, None] * d[ok])
        cand.append(a[ok] + t1[ok, None] * d[ok])
    C = np.vstack(cand)
    if C.shape[0] == 0:
        return np.zeros((0, 3)), np.zeros(0)
    # one point per 0.1 mm cell of the face, the deepest; at most MAX_POINTS
    keys = np.round(C[:, :2] / 0.1e-3).astype(np.int64)
    order = np.lexsort((C[:, 2], keys[:, 1], keys[:, 0]))
    C, keys = C[order], keys[order]
    first = np.ones(C.shape[0], dtype=bool)
    first[1:] = np.any(keys[1:] != keys[:-1], axis=1)
    C = C[first]
    if C.shape[0] > MAX_POINTS:
        # keep the extremes along the face's axes and the deepest
        keep = {int(np.argmin(C[:, 0])), int(np.argmax(C[:, 0])), int(np.argmin(C[:, 1])),
                int(np.argmax(C[:, 1]))}
        for k in np.argsort(C[:, 2]).tolist():
            if len(keep) >= MAX_POINTS:
                break
            keep.add(int(k))
        C = C[sorted(keep)]
    points = face_centre + C @ R_face.T
    return points, C[:, 2].copy()


__all__ = ["face_contacts", "piece_vertices_m"]
