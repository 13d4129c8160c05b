"""A pad's contact patch rasterised from the part's triangles (for the hold criterion).

The grasp search finds contacts on the part's area samples (:mod:`asmplan.planner.grasp`):
about 3000 per part, a few square millimetres each. That is enough to find the pads' contact,
but not to measure a small one: a pad over 2 mm of a 24 mm head touches a line 2 mm long,
and the 3 to 5 samples within the contact band neither say which way that line runs nor how
long it is (the hold criterion then credited that line with a 1.0 mm torsion radius instead
of its ``L / 4 = 0.5`` mm). This module measures the patch on the part's mesh instead: the
triangles facing the pad (normal inside the friction cone of the closing direction) are
projected on the pad plane and rasterised on a regular grid of cell centres over their extent
within the pad's footprint, each cell taking the triangle nearest the pad (a z-buffer); the
cells within the contact band of the pad plane make the patch. The grid has equal-area cells,
so the samples are area-uniform in the pad plane, and its cell centres cover the region's
extent exactly: a line spanning the grid has the mean distance ``L / 4`` of a continuous line
(exactly for an even number of cells along it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

RASTER_CELLS = 400
"""Cells of the grid laid over a contact's extent (about 20 x 20; even counts each way)."""
_BOX_SLACK_M = 1e-9  # a triangle's bounding box widened by this beyond the inside test's


@dataclass(frozen=True, eq=False)
class FrameTriangles:
    """The part's triangles in one candidate gripper frame.

    Parameters
    ----------
    corners : (F, 3, 3) float array
        Each triangle's corners as (x across, y closing, z approach), m, relative to the
        centre of mass.
    normals : (F, 3) float array
        The triangles' outward unit normals in the same axes.
    """

    corners: np.ndarray
    normals: np.ndarray

    @classmethod
    def of(cls, vertices_m: np.ndarray, faces: np.ndarray, face_normals: np.ndarray,
           com_m: np.ndarray, x: np.ndarray, c: np.ndarray, a: np.ndarray) -> FrameTriangles:
        """Triangles of a mesh (part frame) in the frame with axes ``x, c, a``."""
        R = np.stack([x, c, a], axis=1)
        V = (np.asarray(vertices_m, float) - np.asarray(com_m, float)) @ R
        return cls(V[np.asarray(faces)], np.asarray(face_normals, float) @ R)

    def contact(self, side: int, u: float, v: float, half_width_m: float,
                half_length_m: float, y_ref_m: float, band_m: float, cos_cone: float,
                cells: int = RASTER_CELLS
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float] | None:
        """The contact of the pad at ``y_ref_m`` (``side`` +1: the pad on +y touching the
        part's largest y; -1: the pad on -y) with its footprint ``|x - u| <= half_width_m``,
        ``|z - v| <= half_length_m``.

        Returns
        -------
        (points (k, 2), depth (k,), tilt_tan (k, 2), area_m2) or None
            The cells within ``band_m`` of the pad plane: their centres (x - u, z - v), m;
            their depth behind the pad plane, m; the in-plane components of their triangle's
            normal over its component towards the pad (the depth's gradient); the patch's
            area in the pad plane, m^2. None when no triangle facing the pad reaches the band
            within the footprint.
        """
        s = float(side)
        h = s * self.corners[:, :, 1]  # height towards the pad
        ref = s * float(y_ref_m)
        n_c = s * self.normals[:, 1]
        y_lo, y_hi = self._extent[2], self._extent[3]
        keep = (n_c >= cos_cone) & ((y_hi if side > 0 else -y_lo) >= ref - band_m) & self._over(
            u, v, half_width_m, half_length_m)
        if not keep.any():
            return None
        grid = _Grid.over(self.corners[keep], u, v, half_width_m, half_length_m, cells)
        if grid is None:
            return None
        best, face = grid.zbuffer(self.corners[keep], h[keep])
        hit = (face >= 0) & (best >= ref - band_m)
        if not hit.any():
            return None
        nf = self.normals[keep][face[hit]]
        tilt = np.stack([nf[:, 0], nf[:, 2]], axis=1) / (s * nf[:, 1])[:, None]
        points = np.stack([grid.QX[hit] - u, grid.QZ[hit] - v], axis=1)
        return points, ref - best[hit], tilt, float(hit.sum()) * grid.dx * grid.dz

    @cached_property
    def _extent(self) -> np.ndarray:
        """Each triangle's extent: x min, x max, y min, y max, z min, z max, (6, F), m."""
        lo, hi = self.corners.min(axis=1), self.corners.max(axis=1)
        return np.stack([lo[:, 0], hi[:, 0], lo[:, 1], hi[:, 1], lo[:, 2], hi[:, 2]])

    def _over(self, u: float, v: float, half_width_m: float, half_length_m: float
              ) -> np.ndarray:
        """Triangles whose extent overlaps the footprint, (F,) bool."""
        e = self._extent
        return ((e[1] >= u - half_width_m) & (e[0] <= u + half_width_m)
                & (e[5] >= v - half_length_m) & (e[4] <= v + half_length_m))


@dataclass(frozen=True, eq=False)
class _Grid:
    """A regular grid of cell centres ``qx`` x ``qz`` (flattened as ``QX``, ``QZ``, x major)."""

    qx: np.ndarray
    qz: np.ndarray
    dx: float
    dz: float

    @classmethod
    def over(cls, corners: np.ndarray, u: float, v: float, half_width_m: float,
             half_length_m: float, cells: int) -> _Grid | None:
        """About ``cells`` cells (an even number each way: a line spanning the grid then has
        exactly L / 4) over the triangles' extent within the footprint; None if it is empty."""
        X, Z = corners[:, :, 0], corners[:, :, 2]
        gx0, gx1 = max(u - half_width_m, float(X.min())), min(u + half_width_m, float(X.max()))
        gz0, gz1 = max(v - half_length_m, float(Z.min())), min(v + half_length_m, float(Z.max()))
        wx, wz = gx1 - gx0, gz1 - gz0
        if wx <= 1e-9 or wz <= 1e-9:
            return None
        nx = max(2, 2 * round(0.5 * math.sqrt(cells * wx / wz)))
        nz = max(2, 2 * round(0.5 * cells / nx))
        dx, dz = wx / nx, wz / nz
        return cls(gx0 + dx * (np.arange(nx) + 0.5), gz0 + dz * (np.arange(nz) + 0.5), dx, dz)

    @property
    def QX(self) -> np.ndarray:
        return np.repeat(self.qx, self.qz.size)

    @property
    def QZ(self) -> np.ndarray:
        return np.tile(self.qz, self.qx.size)

    def zbuffer(self, corners: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per cell the largest height ``h`` ((F, 3) at the corners, linear in between) of the
        triangles covering its centre and that triangle's index (the lowest of equal ones);
        -inf and -1 where none does. Only the cells within each triangle's bounding box are
        tested (a triangle of a fine mesh covers a few of them)."""
        nx, nz = self.qx.size, self.qz.size
        best = np.full(nx * nz, -np.inf)
        X, Z = corners[:, :, 0], corners[:, :, 2]
        x0, z0 = X[:, 0], Z[:, 0]
        e1x, e1z, e2x, e2z = X[:, 1] - x0, Z[:, 1] - z0, X[:, 2] - x0, Z[:, 2] - z0
        det = e1x * e2z - e1z * e2x
        # the cells in each triangle's bounding box (a margin beyond the inside test's slack)
        i0 = np.searchsorted(self.qx, X.min(axis=1) - _BOX_SLACK_M, side="left")
        i1 = np.searchsorted(self.qx, X.max(axis=1) + _BOX_SLACK_M, side="right")
        j0 = np.searchsorted(self.qz, Z.min(axis=1) - _BOX_SLACK_M, side="left")
        j1 = np.searchsorted(self.qz, Z.max(axis=1) + _BOX_SLACK_M, side="right")
        cnx, cnz = np.maximum(i1 - i0, 0), np.maximum(j1 - j0, 0)
        count = np.where(np.abs(det) > 1e-18, cnx * cnz, 0)  # edge-on: no cell
        total = int(count.sum())
        if total == 0:
            return best, np.full(nx * nz, -1)
        t = np.repeat(np.arange(len(count)), count)
        local = np.arange(total) - np.repeat(np.cumsum(count) - count, count)
        ii = i0[t] + local // cnz[t]
        jj = j0[t] + local % cnz[t]
        px, pz = self.qx[ii] - x0[t], self.qz[jj] - z0[t]
        l1 = (px * e2z[t] - pz * e2x[t]) / det[t]
        l2 = (e1x[t] * pz - e1z[t] * px) / det[t]
        inside = (l1 >= -1e-12) & (l2 >= -1e-12) & (l1 + l2 <= 1.0 + 1e-12)
        t, l1, l2 = t[inside], l1[inside], l2[inside]
        cell = ii[inside] * nz + jj[inside]
        hh = h[t]
        height = hh[:, 0] + l1 * (hh[:, 1] - hh[:, 0]) + l2 * (hh[:, 2] - hh[:, 0])
        np.maximum.at(best, cell, height)
        top = height == best[cell]  # per cell the highest, then the lowest index of those
        low = np.full(nx * nz, len(count))
        np.minimum.at(low, cell[top], t[top])
        face = np.where(low < len(count), low, -1)
        return best, face
