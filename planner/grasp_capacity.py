"""What a planned grasp can carry: the hold criterion of :mod:`asmplan.planner.grasp_hold`
applied to one load (force and moment) instead of the planner's load cases.

:func:`grasp_capacity` finds the two pads' contact patches of a planned :class:`Grasp` again
(the same surface samples and pad evaluation as the grasp search, :mod:`asmplan.planner.grasp`,
with V seats from :mod:`asmplan.planner.grasp_groove`); :meth:`GripCapacity.load_ratio` is the
share of the grip's capacity a load uses at a given clamp force, by the same mechanisms as
:func:`~asmplan.planner.grasp_hold.hold_requirement`:

* friction: the load in the pad plane ``f_t`` and the moment about the closing axis ``M_c``
  (about the contact centre) against the pads' friction force and torsion, combined on the
  ellipsoidal limit surface: ``sqrt((f_t / (c_f F))^2 + (M_c / (c_t F))^2)``, ``c_f`` the sum
  and ``c_t`` the torsion-weighted sum of the pads' friction coefficients per newton of
  squeeze;
* tipping: the moment about the pad plane's axes against the couple of the two pads'
  normal forces moved apart within their patches, ``|M_in| / (F s_max)``.

The ratio is the larger of the two: 1 at the clamp force that just holds the load (the
planner's required force divided by its safety factor). A load along the closing axis is
carried by the synchronised jaws (the planner does not count it either).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..knowledge.model import Gripper
from .grasp import GraspSurface
from .grasp_hold import ContactPatch
from .grasp_pads import Frame, Strip, evaluate
from .grasp_patch import FrameTriangles
from .plan import Grasp


@dataclass(frozen=True, eq=False)
class GripCapacity:
    """The contact patches of a grasp and its friction: what it can carry per newton of clamp.

    Parameters
    ----------
    top, bottom : ContactPatch
        The pads' contacts at gripper y = +width/2 and -width/2 (pad plane x, z; TCP origin).
    mu : float
        Pad-part Coulomb coefficient (finger friction times part friction).
    com_gripper_m : (3,) float array
        The part's centre of mass in the gripper (TCP) frame, m, as planned.
    """

    top: ContactPatch
    bottom: ContactPatch
    mu: float
    com_gripper_m: np.ndarray

    def __post_init__(self) -> None:
        if not (math.isfinite(self.mu) and self.mu > 0.0):
            raise ValueError(f"GripCapacity.mu: expected > 0, found {self.mu!r}")
        object.__setattr__(self, "com_gripper_m",
                           np.asarray(self.com_gripper_m, float).reshape(3))

    @cached_property
    def centre_m(self) -> np.ndarray:
        """The contact centre (midpoint of the two patch centroids), gripper frame, m."""
        c1, c2 = self.top.centroid_m, self.bottom.centroid_m
        return np.array([0.5 * (c1[0] + c2[0]), 0.0, 0.5 * (c1[1] + c2[1])])

    @cached_property
    def force_per_N(self) -> float:
        """Friction force in the pad plane per newton of clamp, ``mu_1 + mu_2``."""
        return self.top.friction(self.mu) + self.bottom.friction(self.mu)

    @cached_property
    def torsion_per_N_m(self) -> float:
        """Friction moment about the closing axis per newton of clamp, m."""
        return (self.top.friction(self.mu) * self.top.torsion_radius_m
                + self.bottom.friction(self.mu) * self.bottom.torsion_radius_m)

    def couple_arm_m(self, direction: np.ndarray) -> float:
        """How far apart (m) the pads' normal forces can move along ``direction`` (pad plane
        x, z; unit): ``max(bottom . t) - min(top . t)``."""
        t = np.asarray(direction, float)
        return float((self.bottom.points_m @ t).max() - (self.top.points_m @ t).min())

    def load_ratio(self, force_N: np.ndarray, moment_com_N_m: np.ndarray, clamp_N: float
                   ) -> tuple[float, str]:
        """Share of the grip's capacity a load uses at clamp force ``clamp_N`` per finger.

        Parameters
        ----------
        force_N : (3,) float array
            Force the grip must resist, acting at the centre of mass (weight and inertial
            load), gripper frame, N.
        moment_com_N_m : (3,) float array
            Moment about the centre of mass the grip must resist as well (the part's
            rotational inertia), gripper frame, N m.
        clamp_N : float
            Squeeze per finger, N.

        Returns
        -------
        (float, str)
            The ratio (inf without clamp) and its mechanism: "friction" or "tipping".
        """
        f = np.asarray(force_N, float)
        moment = (np.cross(self.com_gripper_m - self.centre_m, f)
                  + np.asarray(moment_com_N_m, float))
        if not clamp_N > 0.0:
            return (math.inf if np.any(f) or np.any(moment) else 0.0), "friction"
        f_t = math.hypot(float(f[0]), float(f[2]))
        friction = math.hypot(f_t / self.force_per_N,
                              abs(float(moment[1])) / self.torsion_per_N_m
                              if self.torsion_per_N_m > 0.0 else
                              (math.inf if abs(float(moment[1])) > 1e-15 else 0.0))
        need = np.array([-moment[2], moment[0]])
        size = float(np.linalg.norm(need))
        tipping = 0.0
        if size > 1e-15:
            arm = self.couple_arm_m(need / size)
            tipping = size / arm if arm > 1e-9 else math.inf
        if tipping > friction:
            return tipping / float(clamp_N), "tipping"
        return friction / float(clamp_N), "friction"

    def ratios_per_N(self, force_N: np.ndarray, moment_com_N_m: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`load_ratio` of many loads at once, times the clamp force: (ratio x clamp N
        (M,), whether tipping decides (M,) bool) for forces (M, 3) N and moments (M, 3) N m
        (the same arithmetic, element by element)."""
        f = np.asarray(force_N, float).reshape(-1, 3)
        moment = (np.cross(self.com_gripper_m - self.centre_m, f)
                  + np.asarray(moment_com_N_m, float).reshape(-1, 3))
        f_t = np.hypot(f[:, 0], f[:, 2])
        if self.torsion_per_N_m > 0.0:
            torsion = np.abs(moment[:, 1]) / self.torsion_per_N_m
        else:
            torsion = np.where(np.abs(moment[:, 1]) > 1e-15, math.inf, 0.0)
        friction = np.hypot(f_t / self.force_per_N, torsion)
        need = np.stack([-moment[:, 2], moment[:, 0]], axis=1)
        size = np.linalg.norm(need, axis=1)
        tipping = np.zeros(len(f))
        big = size > 1e-15
        if np.any(big):
            t = need[big] / size[big, None]
            arm = ((self.bottom.points_m @ t.T).max(axis=0)
                   - (self.top.points_m @ t.T).min(axis=0))
            with np.errstate(divide="ignore"):
                tipping[big] = np.where(arm > 1e-9, size[big] / arm, math.inf)
        tips = tipping > friction
        return np.where(tips, tipping, friction), tips


def grasp_capacity(surface: GraspSurface, grasp: Grasp, gripper: Gripper,
                   part_friction: float) -> GripCapacity | None:
    """The capacity of a planned ``grasp`` (:class:`GripCapacity`), its contact patches found
    as the grasp search finds them on ``surface`` (the part's samples, part frame); None when
    the pads do not touch the samples as planned (a grasp from other samples)."""
    mu = float(gripper.finger_friction) * float(part_friction)
    if not mu > 0.0:
        return None
    T = np.asarray(grasp.T_part_gripper, float)
    x, c, a = T[:3, 0], T[:3, 1], T[:3, 2]
    com = np.asarray(surface.com_m, float)
    rel = surface.points_m - com
    u, v = float((T[:3, 3] - com) @ x), float((T[:3, 3] - com) @ a)
    frame = Frame(np.stack([rel @ x, rel @ c, rel @ a]), surface.normals, surface.n_area)
    W, _, L = (float(s) for s in gripper.finger_size_m)
    palm = np.asarray(gripper.palm_size_m, float)
    cos_cone = math.cos(math.atan(mu))
    mesh = surface.mesh  # the planner measures small patches on it (grasp_patch)
    tris = (None if mesh is None else
            FrameTriangles.of(mesh.vertices, mesh.faces, mesh.face_normals, com, x, c, a))
    g = evaluate(Strip(frame, u, W / 2), Strip(frame, u, palm[0] / 2), x, c, a, com, u, v, L,
                 palm, cos_cone, float(gripper.stroke_m), float(gripper.stroke_m), 0.0,
                 surface.area_per_point_m2, None, gripper.finger_groove, tris, W / 2)
    if g is None:
        return None
    top, bottom = g[5]
    return GripCapacity(top, bottom, mu, np.array([-u, -g[6], -v]))
