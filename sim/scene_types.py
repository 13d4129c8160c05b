"""The records of a step's scene: what :mod:`asmplan.sim.scene` selects and builds.

The body roles (:data:`ROLES`, :data:`REQUIRED_ROLES`; what each role means is in the
:mod:`asmplan.sim.scene` docstring), the selection's settings (:class:`SceneSettings`), one
body (:class:`SceneBody`), one step's selection (:class:`StepScene`) and the error raised when
a plan does not belong to the product (:class:`PlanProductMismatchError`). Plain frozen
records without geometry code, so the selection (:mod:`asmplan.sim.scene_select`), the tray
nest and the results can share them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from ..errors import AsmplanError
from ..parts.pieces import ConvexPiece

Role = Literal["held", "mate", "touching", "support", "obstacle", "table", "fixture", "nest"]
ROLES: tuple[str, ...] = ("held", "mate", "touching", "support", "obstacle", "table", "fixture",
                          "nest")
REQUIRED_ROLES: tuple[str, ...] = ("held", "mate", "touching", "support", "table", "fixture",
                                   "nest")
"""Roles a step cannot do without (obstacles are there to catch deviations)."""

_DETAIL = {"coarse": 0, "convex": 1, "exact": 2}


class PlanProductMismatchError(AsmplanError, ValueError):
    """The plan does not belong to the product (names of the product or its parts differ)."""


@dataclass(frozen=True)
class SceneSettings:
    """How a step's scene is selected (SI).

    Parameters
    ----------
    near_margin_m : float
        Obstacles closer than this to the swept space get the fidelity's level of detail.
    include_margin_m : float
        Obstacles closer than this are included (coarse beyond ``near_margin_m``); farther
        ones are left out.
    touch_tolerance_m : float
        Two parts whose FCL distance is at most this touch (pins in holes with clearance,
        faces resting on faces).
    nest_clearance_m : float
        Gap around each piece protruding below the face a tray nest supports, m.
    nest_inset_m : float
        The nest stays this far inside the supported face's outline, m.
    nest_min_height_m : float
        A largest downward face lower than this above the table rests on the table (no nest).
    dynamic_partners : bool or None
        Make non-fixtured mates and touching parts dynamic or static; None (default) follows
        ``Fidelity.dynamic_partners`` (static at FAST). In the whole-product scene
        (``cull=False``) the placed parts follow the same choice.
    limit_contact_breaking : bool
        Limit the contact breaking distance between the held part and its dynamic fit
        partners when the fits are at least the interference resolution (see the module
        docstring); False keeps PyBullet's default everywhere.
    """

    near_margin_m: float = 5e-3
    include_margin_m: float = 30e-3
    touch_tolerance_m: float = 0.2e-3
    nest_clearance_m: float = 1e-3
    nest_inset_m: float = 0.5e-3
    nest_min_height_m: float = 10e-6
    dynamic_partners: bool | None = None
    limit_contact_breaking: bool = True

    def __post_init__(self) -> None:
        for name in ("near_margin_m", "include_margin_m", "touch_tolerance_m",
                     "nest_clearance_m", "nest_inset_m", "nest_min_height_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"SceneSettings.{name}: expected a finite value >= 0, found {v}")
        if self.include_margin_m < self.near_margin_m:
            raise ValueError(
                f"SceneSettings.include_margin_m: expected >= near_margin_m "
                f"({self.near_margin_m}), found {self.include_margin_m}"
            )


@dataclass(frozen=True, eq=False)
class SceneBody:
    """One body of a step's scene.

    Attributes
    ----------
    name : str
        Part name, "table" or "nest:<part>".
    role : str
        One of :data:`ROLES`.
    dynamic : bool
    level : str
        Level of detail of the pieces ("exact", "convex", "coarse"; "box" for table/nest).
    T_world_body : (4, 4) float array
    pieces : tuple of ConvexPiece
        Collision pieces in the body frame.
    reason : str
        Why the body is in the scene, and why at this level and with these dynamics.
    mass_kg : float
        0 for static bodies.
    com_m : (3,) float array, body frame.
    inertia_kgm2 : (3, 3) float array about the centre of mass.
    friction : float
    distance_m : float
        Distance of its bounding box from the swept space (0 for required bodies), m.
    """

    name: str
    role: str
    dynamic: bool
    level: str
    T_world_body: np.ndarray
    pieces: tuple[ConvexPiece, ...]
    reason: str
    mass_kg: float = 0.0
    com_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia_kgm2: np.ndarray | None = None
    friction: float = 0.5
    distance_m: float = 0.0

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"SceneBody {self.name}: role expected one of {ROLES}, "
                             f"found {self.role!r}")
        if self.dynamic and not self.mass_kg > 0:
            raise ValueError(f"SceneBody {self.name}: a dynamic body needs mass > 0, found "
                             f"{self.mass_kg}")

    def summary(self) -> dict[str, Any]:
        """JSON-safe description (no geometry)."""
        return {
            "name": self.name, "role": self.role, "dynamic": self.dynamic, "level": self.level,
            "pieces": len(self.pieces), "reason": self.reason,
            "mass_kg": float(self.mass_kg), "distance_m": float(self.distance_m),
            "T_world_body": np.asarray(self.T_world_body, float).tolist(),
        }


@dataclass(frozen=True, eq=False)
class StepScene:
    """The selected scene of one step.

    Attributes
    ----------
    step_index : int
    part : str
        The held part.
    bodies : tuple of SceneBody
        In a fixed order: table, nest, held part, then the others by role and name.
    left_out : tuple of (str, str)
        (part, reason) of every product part not in the scene.
    notes : tuple of str
    culled : bool
        False when every part was kept (``cull=False``).
    contact_breaking_m : float or None
        Largest distance at which the simulator keeps a contact point between the held part
        and its dynamic fit partners (``contact_breaking_partners``), m; None: PyBullet's
        default (see the module docstring).
    contact_breaking_partners : tuple of str
    """

    step_index: int
    part: str
    bodies: tuple[SceneBody, ...]
    left_out: tuple[tuple[str, str], ...]
    notes: tuple[str, ...] = ()
    culled: bool = True
    contact_breaking_m: float | None = None
    contact_breaking_partners: tuple[str, ...] = ()

    def body(self, name: str) -> SceneBody:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(f"scene of step {self.step_index} has no body {name!r}; it has "
                       f"{[b.name for b in self.bodies]}")

    def names(self, *roles: str) -> tuple[str, ...]:
        """Names of the bodies with one of ``roles`` (all when none given)."""
        return tuple(b.name for b in self.bodies if not roles or b.role in roles)

    @property
    def parts(self) -> tuple[str, ...]:
        """Names of the product parts in the scene."""
        return tuple(b.name for b in self.bodies if b.role not in ("table", "fixture", "nest"))

    def summary(self) -> dict[str, Any]:
        """JSON-safe description of the selection (see docs/results-format.md)."""
        return {
            "culled": self.culled,
            "bodies": [b.summary() for b in self.bodies],
            "left_out": [{"name": n, "reason": r} for n, r in self.left_out],
            "notes": list(self.notes),
            "contact_breaking_m": self.contact_breaking_m,
            "contact_breaking_partners": list(self.contact_breaking_partners),
        }
