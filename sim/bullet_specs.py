"""Descriptions of the bodies the PyBullet world builds (no pybullet call): the links of an
articulated body (:class:`LinkSpec`) and the world's record of each body it holds."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..knowledge.frames import invert
from ..parts.pieces import ConvexPiece

JointKind = Literal["fixed", "prismatic", "revolute"]
JOINT_KINDS: tuple[JointKind, ...] = ("fixed", "prismatic", "revolute")
"""The joint kinds a link may have (the keys of the world's pybullet joint types)."""


@dataclass(frozen=True, eq=False)
class LinkSpec:
    """One link of an articulated body built by :meth:`asmplan.sim.bullet.BulletWorld.add_articulated`.

    Parameters
    ----------
    name : str
    pieces : tuple of ConvexPiece
        Collision pieces in the link frame: up to 16 primitives, or exactly one hull.
    mass_kg : float
    T_parent_link : (4, 4) float array
        Link frame in the parent's link frame at joint position 0.
    joint : {"fixed", "prismatic", "revolute"}
    axis : (3,) float
        Joint axis in the link frame (unit vector).
    com_m : (3,) float
        Centre of mass in the link frame, m.
    inertia_diag_kgm2 : (3,) float
        Principal inertia about the centre of mass, axes aligned with the link frame.
    parent : int
        Index of the parent link in the list passed to ``add_articulated``, -1 for the base.
    limits_m : (lower, upper) or None
        Joint limits (m or rad).
    friction : float
        Lateral friction coefficient of the link.
    spinning_friction : float
    joint_damping : float
        Viscous joint damping, N s/m (prismatic) or N m s/rad (revolute).
    """

    name: str
    pieces: tuple[ConvexPiece, ...]
    mass_kg: float
    T_parent_link: np.ndarray
    joint: JointKind = "fixed"
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    com_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia_diag_kgm2: tuple[float, float, float] | None = None
    parent: int = -1
    limits: tuple[float, float] | None = None
    friction: float = 0.5
    spinning_friction: float = 0.0
    joint_damping: float = 0.0

    def __post_init__(self) -> None:
        T = np.array(self.T_parent_link, dtype=float)
        if T.shape != (4, 4):
            raise ValueError(f"LinkSpec {self.name}: T_parent_link expected (4, 4), found {T.shape}")
        object.__setattr__(self, "T_parent_link", T)
        if self.joint not in JOINT_KINDS:
            raise ValueError(
                f"LinkSpec {self.name}: joint expected one of {list(JOINT_KINDS)}, "
                f"found {self.joint!r}"
            )
        if self.mass_kg < 0:
            raise ValueError(f"LinkSpec {self.name}: mass_kg expected >= 0, found {self.mass_kg}")


@dataclass
class _BodyInfo:
    name: str
    mass_kg: float
    static: bool
    T_link_inertial: np.ndarray  # base inertial frame in the base link frame
    n_links: int
    inertia_kgm2: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    compound_links: frozenset[int] = frozenset()
    bounding_radius_m: float = math.nan  # the largest of its colliders' (bounding_radius_m)

    def __post_init__(self) -> None:
        self.T_inertial_link = invert(self.T_link_inertial)
