"""Meridian profiles of solids of revolution: signed distances to a closed polygon in the
(rho, z) half-plane (used by :mod:`asmplan.sim.fit_geometry`; split from it for size). No
pybullet here."""

from __future__ import annotations

import numpy as np


class Profile:
    """A closed meridian polygon (k, 2) with its segments precomputed for :meth:`sdf`."""

    def __init__(self, polygon: np.ndarray) -> None:
        self.polygon = np.asarray(polygon, dtype=float)
        a = self.polygon
        b = np.roll(a, -1, axis=0)
        self._a, self._b, self._ab = a, b, b - a
        self._ab2 = np.maximum(np.sum(self._ab * self._ab, axis=1), 1e-300)
        seg_n = np.column_stack([self._ab[:, 1], -self._ab[:, 0]])
        seg_n /= np.maximum(np.linalg.norm(seg_n, axis=1, keepdims=True), 1e-300)
        if 0.5 * np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]) < 0:
            seg_n = -seg_n
        self._seg_n = seg_n
        # convex vertices (material angle < 180 deg) and their outward bisectors: the edges
        # of the solid of revolution (vertex i joins segment i - 1 and segment i)
        prev_ab = np.roll(self._ab, 1, axis=0)
        turn = prev_ab[:, 0] * self._ab[:, 1] - prev_ab[:, 1] * self._ab[:, 0]
        ccw = 0.5 * np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]) > 0
        self.vertex_convex = (turn > 0) if ccw else (turn < 0)
        bis = np.roll(seg_n, 1, axis=0) + seg_n
        self.vertex_bisector = bis / np.maximum(np.linalg.norm(bis, axis=1, keepdims=True),
                                                1e-300)
        self._seg_len = np.sqrt(self._ab2)
        horizontal = self._ab[:, 1] == 0.0
        self._inv_slope = np.where(horizontal, 0.0, self._ab[:, 0]
                                   / np.where(horizontal, 1.0, self._ab[:, 1]))

    def _nearest(self, points: np.ndarray):
        """Per point (n, 2): each segment's offset (dx, dy (n, k)), squared distance (n, k)
        and clamped parameter t (n, k), the nearest segment j (n,), its distance (n,) and
        whether the point lies inside the polygon (n,)."""
        a, ab = self._a, self._ab
        px, py = points[:, 0:1], points[:, 1:2]
        ap0, ap1 = px - a[None, :, 0], py - a[None, :, 1]
        t = np.clip((ap0 * ab[:, 0] + ap1 * ab[:, 1]) / self._ab2, 0.0, 1.0)
        dx, dy = ap0 - t * ab[None, :, 0], ap1 - t * ab[None, :, 1]
        dist2 = dx ** 2 + dy ** 2
        j = np.argmin(dist2, axis=1)
        idx = np.arange(points.shape[0])
        d = np.sqrt(dist2[idx, j])
        cond = (a[None, :, 1] > py) != (self._b[None, :, 1] > py)
        xint = a[None, :, 0] + (py - a[None, :, 1]) * self._inv_slope[None, :]
        inside = np.logical_xor.reduce(cond & (px < xint), axis=1)  # odd crossings
        return dx, dy, dist2, t, idx, j, d, inside

    def distances(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Signed distance (n,) from 2-D ``points`` (n, 2) to the polygon (positive outside),
        the nearest segment (n,) and the distance to the second-nearest segment (n,), m:
        bitwise those of :meth:`sdf` (the same arithmetic, without the directions)."""
        _, _, dist2, _, _, j, d, inside = self._nearest(points)
        second = (np.sqrt(np.partition(dist2, 1, axis=1)[:, 1])
                  if dist2.shape[1] > 1 else np.full(d.shape, np.inf))
        return np.where(inside, -d, d), j, second

    def sdf(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (n,) from 2-D ``points`` (n, 2) to the polygon (positive outside)
        and the unit outward direction (n, 2): toward the nearest boundary point from outside
        reversed (away from the material), toward it from inside."""
        dx, dy, dist2, t, idx, j, d, inside = self._nearest(points)
        self.last_segment = j
        self.last_t = t[idx, j]
        self.last_second_m = (np.sqrt(np.partition(dist2, 1, axis=1)[:, 1])
                              if dist2.shape[1] > 1 else np.full(d.shape, np.inf))
        seg_n = self._seg_n[j]
        safe = d > 1e-12
        diff = np.column_stack([dx[idx, j], dy[idx, j]])
        out = np.where(safe[:, None], diff / np.where(safe, d, 1.0)[:, None], seg_n)
        out = np.where(inside[:, None] & safe[:, None], -out, out)
        return np.where(inside, -d, d), out

    def near_convex_vertex(self, tol_m: float) -> np.ndarray:
        """For the points of the last :meth:`sdf` call: the convex vertex (index) whose
        nearest boundary point lies within ``tol_m`` of it, else -1."""
        j, t = self.last_segment, self.last_t
        length = self._seg_len[j]
        k = self.polygon.shape[0]
        v = np.where(t * length <= tol_m, j, np.where((1.0 - t) * length <= tol_m,
                                                      (j + 1) % k, -1))
        ok = (v >= 0) & (length > 2.0 * tol_m)
        ok[ok] &= self.vertex_convex[v[ok]]
        return np.where(ok, v, -1)


def polygon_sdf(points: np.ndarray, polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`Profile.sdf` of a polygon given as (k, 2) vertices."""
    return Profile(polygon).sdf(points)


def _meridian(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rho, z) of frame points (n, 3) and their radial unit vectors (n, 3)."""
    rho = np.hypot(points[:, 0], points[:, 1])
    radial = np.zeros_like(points)
    ok = rho > 1e-12
    radial[ok, 0] = points[ok, 0] / rho[ok]
    radial[ok, 1] = points[ok, 1] / rho[ok]
    radial[~ok, 0] = 1.0
    return rho, radial


def revolved_sdf(points: np.ndarray, profile: np.ndarray | Profile
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance (n,) from points (n, 3), in a solid of revolution's frame (axis z), to
    the solid whose meridian is ``profile``; and the unit outward normal (n, 3) there."""
    prof = profile if isinstance(profile, Profile) else Profile(profile)
    rho, radial = _meridian(points)
    d, n2 = prof.sdf(np.column_stack([rho, points[:, 2]]))
    normal = n2[:, :1] * radial
    normal[:, 2] += n2[:, 1]
    return d, normal
