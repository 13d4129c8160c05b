"""Scene items and the pinhole camera: what a picture shows and from where.

:class:`SceneItem` (a mesh placed in the world, with a colour), :class:`Camera`,
:func:`fit_camera` (frame the items) and :func:`exploded` (an exploded view), drawn by
:mod:`asmplan.report.render`.

Pixel convention: images are ``(height_px, width_px, 3)`` uint8, row 0 at the top. The camera
is a pinhole with square pixels: with ``f_px = (height_px / 2) / tan(yfov_rad / 2)``, a point
at camera coordinates ``(x, y, z)`` (x right, y up, looking along -z) lands at column
``width_px / 2 + f_px * x / -z`` and row ``height_px / 2 - f_px * y / -z`` (pixel edges,
so the pixel with index ``(i, j)`` has its centre at ``(j + 0.5, i + 0.5)``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import trimesh

from ..knowledge.arrays import readonly_array

__all__ = ["Camera", "SceneItem", "exploded", "fit_camera"]


def _as_rigid_transform(value: Any, name: str) -> np.ndarray:
    array = np.array(value, dtype=float)
    if array.shape != (4, 4):
        raise ValueError(f"{name}: expected a (4, 4) transform, found shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: expected finite values, found non-finite entries")
    if not np.allclose(array[3], (0.0, 0.0, 0.0, 1.0), atol=1e-9):
        raise ValueError(f"{name}: expected last row [0, 0, 0, 1], found {array[3].tolist()}")
    rotation = array[:3, :3]
    orthonormality_error = float(np.abs(rotation.T @ rotation - np.eye(3)).max())
    determinant = float(np.linalg.det(rotation))
    if orthonormality_error > 1e-6 or determinant < 0.0:
        raise ValueError(
            f"{name}: expected a rotation block (orthonormal, det +1), found max |R^T R - I| = "
            f"{orthonormality_error:.3g} and det = {determinant:.6g}"
        )
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class SceneItem:
    """One mesh placed in the world, with a colour.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Geometry in the item's own frame, metres. Not copied; do not mutate it afterwards.
    T_world_item : (4, 4) float array
        Rigid transform mapping item coordinates to world coordinates (metres).
    color_rgba : tuple of 4 floats
        Base colour, each channel in [0, 1]; alpha < 1 draws the item translucent.
    name : str
        Label used by :func:`render_mask`; names should be unique within a scene.
    """

    mesh: trimesh.Trimesh
    T_world_item: np.ndarray
    color_rgba: tuple[float, float, float, float]
    name: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.mesh, trimesh.Trimesh):
            raise TypeError(
                f"SceneItem {self.name!r}: expected mesh as trimesh.Trimesh, "
                f"found {type(self.mesh).__name__}"
            )
        if len(self.mesh.faces) == 0:
            raise ValueError(f"SceneItem {self.name!r}: expected a mesh with faces, found 0")
        object.__setattr__(
            self,
            "T_world_item",
            _as_rigid_transform(self.T_world_item, f"SceneItem {self.name!r} T_world_item"),
        )
        rgba = tuple(float(c) for c in self.color_rgba)
        if len(rgba) != 4 or not all(0.0 <= c <= 1.0 for c in rgba):
            raise ValueError(
                f"SceneItem {self.name!r}: expected color_rgba as 4 floats in [0, 1], "
                f"found {self.color_rgba!r}"
            )
        object.__setattr__(self, "color_rgba", rgba)

    def world_bounds_m(self) -> np.ndarray:
        """Axis-aligned bounds of the placed mesh in world coordinates.

        Returns
        -------
        (2, 3) float array
            ``[min_xyz, max_xyz]`` in metres (bounds of the transformed local box corners).
        """
        corners = trimesh.bounds.corners(self.mesh.bounds)
        corners_world = corners @ self.T_world_item[:3, :3].T + self.T_world_item[:3, 3]
        return np.array([corners_world.min(axis=0), corners_world.max(axis=0)])


@dataclass(frozen=True, eq=False)
class Camera:
    """A pinhole camera with square pixels looking from ``eye_m`` at ``target_m``.

    Parameters
    ----------
    eye_m : (3,) float array
        Camera centre in world coordinates, metres.
    target_m : (3,) float array
        Point the optical axis passes through, metres; must differ from ``eye_m``.
    up : (3,) float array
        World direction that appears up in the image; must not be parallel to the view.
    yfov_rad : float
        Vertical field of view in radians, in (0, pi).
    width_px, height_px : int
        Image size in pixels.
    """

    eye_m: np.ndarray
    target_m: np.ndarray
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    yfov_rad: float = 0.6
    width_px: int = 800
    height_px: int = 600

    def __post_init__(self) -> None:
        object.__setattr__(self, "eye_m", readonly_array(self.eye_m, (3,), "Camera eye_m", finite=True))
        object.__setattr__(self, "target_m",
                           readonly_array(self.target_m, (3,), "Camera target_m", finite=True))
        object.__setattr__(self, "up", readonly_array(self.up, (3,), "Camera up", finite=True))
        view = self.target_m - self.eye_m
        if np.linalg.norm(view) <= 1e-12:
            raise ValueError(
                f"Camera: expected target_m different from eye_m, found both {self.eye_m.tolist()}"
            )
        up_norm = float(np.linalg.norm(self.up))
        sine = float(np.linalg.norm(np.cross(view / np.linalg.norm(view), self.up))) / max(
            up_norm, 1e-300
        )
        if up_norm <= 1e-12 or sine < 1e-6:
            raise ValueError(
                f"Camera: expected up not parallel to the view direction, found up "
                f"{self.up.tolist()} and view direction {view.tolist()}"
            )
        if not 0.0 < float(self.yfov_rad) < np.pi:
            raise ValueError(f"Camera: expected yfov_rad in (0, pi), found {self.yfov_rad!r}")
        object.__setattr__(self, "yfov_rad", float(self.yfov_rad))
        for attribute in ("width_px", "height_px"):
            value = getattr(self, attribute)
            if isinstance(value, bool) or int(value) != value or not 1 <= int(value) <= 16384:
                raise ValueError(
                    f"Camera: expected {attribute} as an integer in [1, 16384], found {value!r}"
                )
            object.__setattr__(self, attribute, int(value))

    @property
    def focal_px(self) -> float:
        """Focal length in pixels (same for both axes): ``(height_px / 2) / tan(yfov_rad / 2)``."""
        return 0.5 * self.height_px / float(np.tan(0.5 * self.yfov_rad))

    @property
    def T_world_camera(self) -> np.ndarray:
        """(4, 4) pose of the camera in the world: columns x right, y up, z backwards (OpenGL)."""
        z_axis = self.eye_m - self.target_m
        z_axis = z_axis / np.linalg.norm(z_axis)
        x_axis = np.cross(self.up, z_axis)
        x_axis = x_axis / np.linalg.norm(x_axis)
        y_axis = np.cross(z_axis, x_axis)
        pose = np.eye(4)
        pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = x_axis, y_axis, z_axis, self.eye_m
        return pose

    def project(self, points_world_m: np.ndarray) -> np.ndarray:
        """Project world points to pixel coordinates (pinhole model, see module docstring).

        Parameters
        ----------
        points_world_m : (N, 3) or (3,) float array
            Points in world coordinates, metres; must lie in front of the camera.

        Returns
        -------
        (N, 2) or (2,) float array
            ``(column, row)`` in pixels, origin at the top-left image corner.
        """
        points = np.asarray(points_world_m, dtype=float)
        single = points.ndim == 1
        points = np.atleast_2d(points)
        T_camera_world = np.linalg.inv(self.T_world_camera)
        points_camera = points @ T_camera_world[:3, :3].T + T_camera_world[:3, 3]
        depth = -points_camera[:, 2]
        if np.any(depth <= 0.0):
            raise ValueError(
                f"Camera.project: expected points in front of the camera, found depths "
                f"{depth[depth <= 0.0].tolist()} m"
            )
        column = 0.5 * self.width_px + self.focal_px * points_camera[:, 0] / depth
        row = 0.5 * self.height_px - self.focal_px * points_camera[:, 1] / depth
        pixels = np.column_stack([column, row])
        return pixels[0] if single else pixels


def _union_bounds_m(items: Sequence[SceneItem]) -> np.ndarray:
    if len(items) == 0:
        raise ValueError("expected at least one SceneItem, found none")
    bounds = np.array([item.world_bounds_m() for item in items])
    return np.array([bounds[:, 0].min(axis=0), bounds[:, 1].max(axis=0)])


def fit_camera(
    items: Sequence[SceneItem],
    direction: Sequence[float] = (1.0, -1.3, 0.9),
    margin: float = 1.15,
    width_px: int = 800,
    height_px: int = 600,
    yfov_rad: float = 0.6,
) -> Camera:
    """Frame the union of the items' world bounding boxes.

    The camera looks at the centre of the union box from ``direction`` (pointing from the
    centre towards the eye) and is placed at the smallest distance at which all eight corners
    of the box lie inside the image shrunk by ``margin``.

    Parameters
    ----------
    items : sequence of SceneItem
        Items to frame (at least one).
    direction : (3,) float
        World direction from the scene centre to the eye; need not be unit length.
    margin : float
        >= 1; 1.15 leaves about 15 % free space around the box on the tighter axis.
    width_px, height_px : int
        Image size in pixels.
    yfov_rad : float
        Vertical field of view in radians.

    Returns
    -------
    Camera
        ``up`` is world +z, or world +y when ``direction`` is (anti)parallel to z.
    """
    if not margin >= 1.0:
        raise ValueError(f"fit_camera: expected margin >= 1, found {margin!r}")
    direction_unit = readonly_array(direction, (3,), "fit_camera direction", finite=True)
    length = float(np.linalg.norm(direction_unit))
    if length <= 1e-12:
        raise ValueError(f"fit_camera: expected a non-zero direction, found {list(direction)}")
    direction_unit = direction_unit / length
    up = np.array([0.0, 0.0, 1.0])
    if np.linalg.norm(np.cross(direction_unit, up)) < 1e-3:
        up = np.array([0.0, 1.0, 0.0])
    bounds = _union_bounds_m(items)
    center = bounds.mean(axis=0)
    # Orientation does not depend on distance: build it once at unit distance.
    probe = Camera(center + direction_unit, center, up, yfov_rad, width_px, height_px)
    R_world_camera = probe.T_world_camera[:3, :3]
    corners_camera = (trimesh.bounds.corners(bounds) - center) @ R_world_camera
    tan_half_y = float(np.tan(0.5 * yfov_rad)) / margin
    tan_half_x = tan_half_y * width_px / height_px
    # A corner at camera offset (x, y, z) from the target is at depth d - z for eye distance d;
    # it is inside the view when |x| <= (d - z) tan_half_x and |y| <= (d - z) tan_half_y.
    needed = np.concatenate(
        [
            corners_camera[:, 2] + np.abs(corners_camera[:, 0]) / tan_half_x,
            corners_camera[:, 2] + np.abs(corners_camera[:, 1]) / tan_half_y,
        ]
    )
    extent = float(np.linalg.norm(bounds[1] - bounds[0]))
    distance = max(float(needed.max()), 1e-3 * max(extent, 1e-3))
    return Camera(center + distance * direction_unit, center, up, yfov_rad, width_px, height_px)


def exploded(
    items: Sequence[SceneItem], center_m: Sequence[float], factor: float
) -> list[SceneItem]:
    """Move items away from a centre along the direction of their centroids (exploded view).

    Each item is translated by ``factor * (c_i - center_m)``, with ``c_i`` the world position
    of its mesh centroid; an item whose centroid is at the centre stays put. Rotations, meshes,
    colours and names are kept.

    Parameters
    ----------
    items : sequence of SceneItem
        Items to move.
    center_m : (3,) float
        Centre of the explosion in world coordinates, metres.
    factor : float
        Dimensionless, >= 0: 0 leaves the items in place, 1 doubles each centroid's distance.

    Returns
    -------
    list of SceneItem
        New items, in the same order.
    """
    center = readonly_array(center_m, (3,), "exploded center_m", finite=True)
    if not (np.isfinite(factor) and factor >= 0.0):
        raise ValueError(f"exploded: expected factor >= 0, found {factor!r}")
    moved = []
    for item in items:
        T = item.T_world_item
        centroid_world = T[:3, :3] @ np.asarray(item.mesh.centroid, dtype=float) + T[:3, 3]
        T_new = T.copy()
        T_new[:3, 3] += factor * (centroid_world - center)
        moved.append(SceneItem(item.mesh, T_new, item.color_rgba, item.name))
    return moved
