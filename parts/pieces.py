"""Convex pieces: the contract between part geometry, collision checking and physics.

A part's collision model at any level of detail is a tuple of :class:`ConvexPiece`, each an
exact primitive (box, cylinder, sphere) or a convex hull, placed in the part frame. FCL
(`parts.collision`) and PyBullet (`sim`) both build their shapes from these, so the two
worlds see the same geometry.

Frames follow the ``T_a_b`` convention: ``T_part_piece`` maps piece coordinates to part
coordinates, a ``(4, 4)`` homogeneous float array. Lengths are metres.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..knowledge.arrays import readonly_array

PieceKind = Literal["box", "cylinder", "sphere", "hull"]
LevelOfDetail = Literal["exact", "convex", "coarse"]


@dataclass(frozen=True, eq=False)
class ConvexPiece:
    """One convex piece of a collision model, in the part frame.

    Parameters
    ----------
    kind : {"box", "cylinder", "sphere", "hull"}
    T_part_piece : (4, 4) float array
        Pose of the piece in the part frame. Boxes and hulls are centred on the piece frame;
        cylinders are centred on it with their axis along its z axis.
    half_extents_m : (3,) float array, for boxes.
    radius_m, length_m : float, for cylinders (length along z) and spheres (radius).
    vertices_m : (n, 3) float array, for hulls, in the piece frame.
    """

    kind: PieceKind
    T_part_piece: np.ndarray
    half_extents_m: np.ndarray | None = None
    radius_m: float = 0.0
    length_m: float = 0.0
    vertices_m: np.ndarray | None = None
    name: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "T_part_piece",
                           readonly_array(self.T_part_piece, (4, 4), "T_part_piece", finite=True))
        if self.kind == "box":
            if self.half_extents_m is None:
                raise ValueError("box piece: half_extents_m is required")
            he = readonly_array(self.half_extents_m, (3,), "half_extents_m", finite=True)
            if np.any(he <= 0):
                raise ValueError(f"box piece: half extents must be positive, found {he.tolist()}")
            object.__setattr__(self, "half_extents_m", he)
        elif self.kind == "cylinder":
            if self.radius_m <= 0 or self.length_m <= 0:
                raise ValueError(
                    f"cylinder piece: radius and length must be positive, found "
                    f"{self.radius_m}, {self.length_m}"
                )
        elif self.kind == "sphere":
            if self.radius_m <= 0:
                raise ValueError(f"sphere piece: radius must be positive, found {self.radius_m}")
        elif self.kind == "hull":
            if self.vertices_m is None:
                raise ValueError("hull piece: vertices_m is required")
            v = readonly_array(self.vertices_m, None, "vertices_m", finite=True)
            if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 4:
                raise ValueError(f"hull piece: expected (n>=4, 3) vertices, found {v.shape}")
            object.__setattr__(self, "vertices_m", v)
        else:
            raise ValueError(f"unknown piece kind {self.kind!r}; expected box, cylinder, sphere or hull")


@dataclass(frozen=True, eq=False)
class CollisionModel:
    """A part's collision geometry at one level of detail, with its measured error.

    Parameters
    ----------
    level : {"exact", "convex", "coarse"}
    pieces : tuple of ConvexPiece
        Union of convex pieces. ``exact`` may instead (or also) carry ``mesh_vertices_m`` /
        ``mesh_faces`` for a BVH mesh where the part is not made of primitives.
    hausdorff_m : float
        Measured symmetric Hausdorff distance from the exact geometry (0 for exact).
    hole_clearance_error_m : float
        Largest measured change of a hole's effective diametral clearance (0 when exact or
        when the part has no hole).
    """

    level: LevelOfDetail
    pieces: tuple[ConvexPiece, ...]
    hausdorff_m: float = 0.0
    hole_clearance_error_m: float = 0.0
    mesh_vertices_m: np.ndarray | None = None
    mesh_faces: np.ndarray | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
