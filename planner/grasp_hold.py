"""Can a two-finger grasp hold the part? Force and moment about the contact patches.

A parallel gripper squeezes the part with a force ``F`` per finger. Each pad touches the part
over a contact patch (the surface points within the contact band, in the pad plane: gripper
x and z). The part's weight and its inertial load while carried, ``m (g d + a e)`` (``d`` the
direction of gravity at the pick and at the insertion pose, and once the transfer is planned
along it too (:class:`HoldInputs`, :mod:`asmplan.planner.transfer_hold`), ``e`` any
direction, ``a`` the largest planned acceleration), act at the centre of mass. Taking
moments about the contact centre (the midpoint of the two patch centroids), the grip must
carry:

- the load in the pad plane, ``f_t``, and the moment about the closing axis, ``M_c``, by
  friction. Under uniform pressure a patch resists at most ``mu F`` of force and
  ``mu F rho`` of moment about its centroid, ``rho`` the mean distance of the patch from its
  centroid (``2/3 R`` for a disc of radius ``R``, ``L/4`` for a line of length ``L``; see
  :func:`disc_torsion_radius_m`, :func:`rectangle_torsion_radius_m`). Force and moment share
  the friction; their combination uses the ellipsoidal limit surface (Goyal, Ruina and
  Papadopoulos 1991; Howe and Cutkosky 1996), two pads:
  ``F >= sqrt(f_t^2 + (M_c / rho)^2) / (2 mu)``, ``rho`` the mean of the two pads';
- the moment about the pad plane's axes (tipping about the contact line) either by moving
  the two pads' centres of pressure apart within their patches: the normal forces ``F`` and
  ``-F`` then make a couple ``F s``, ``s`` their distance across the moment's axis, at most
  ``max(P_2 . t) - min(P_1 . t)`` along the needed direction ``t``: ``F >= |M_in| / s_max``
  (no friction used); or by the pads' friction forces ``f_1``, ``f_2`` in opposite
  directions, a couple across the grip width ``w``: ``f_1 - f_2 = 2 M_in x y / w``, with
  ``f_1 + f_2`` carrying the load in the pad plane and each pad within its limit surface
  (``sqrt((|f_i| / mu)^2 + (M_c / (2 mu rho))^2) <= F`` for two like pads). A line contact
  (no extent across it, ``s_max = 0``) still holds a moment about the line so: a cylinder
  pinched across its diameter does not roll about its axis while both pads grip it. Per load
  case the cheaper of the two mechanisms is taken (not their sum: conservative).

The required force is the largest over the load cases, times the process's safety factor.
A grasp whose required force exceeds the gripper's (or the part's) force limit cannot hold the
part; among those that can, the ranking prefers a large margin ``limit / required``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

G_M_S2 = 9.81

_NORMAL_EQUATIONS_ABOVE = 1000  # samples above which the patch's quadratic fit solves them

# directions of the inertial load: the six axes, the eight diagonals and none
_CUBE = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)], float)
_DIRECTIONS = np.vstack([_CUBE[np.abs(_CUBE).sum(axis=1) == 1],
                         _CUBE[np.abs(_CUBE).sum(axis=1) == 3] / math.sqrt(3.0),
                         np.zeros((1, 3))])


@dataclass(frozen=True)
class GripLoad:
    """What the grip must carry (SI): the hold criterion and the ranking's hold term.

    Parameters
    ----------
    mass_kg : float
        The part's mass.
    acceleration_m_s2 : float
        The largest acceleration of the part while carried.
    force_limit_N : float
        The largest clamp force per finger (the gripper's, or the part's if lower).
    safety_factor : float
        The process's safety factor on the clamp force.
    """

    mass_kg: float
    acceleration_m_s2: float
    force_limit_N: float
    safety_factor: float = 2.0

    def __post_init__(self) -> None:
        for name in ("mass_kg", "force_limit_N", "safety_factor"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"GripLoad.{name}: expected > 0, found {v!r}")
        if not (math.isfinite(self.acceleration_m_s2) and self.acceleration_m_s2 >= 0):
            raise ValueError(f"GripLoad.acceleration_m_s2: expected >= 0, found "
                             f"{self.acceleration_m_s2!r}")


def disc_torsion_radius_m(radius_m: float) -> float:
    """Mean distance of a disc of radius ``R`` from its centre, ``2 R / 3``, m: the moment a
    uniformly pressed disc resists under normal force ``F`` is ``mu F 2 R / 3``."""
    return 2.0 * float(radius_m) / 3.0


def rectangle_torsion_radius_m(width_m: float, length_m: float) -> float:
    """Mean distance of a ``width x length`` rectangle from its centre, m.

    With half sides ``a, b`` and ``d = sqrt(a^2 + b^2)``:
    ``(2 a b d + a^3 ln((b + d) / a) + b^3 ln((a + d) / b)) / (6 a b)``; a line of length
    ``L`` (one side 0) gives ``L / 4``."""
    a, b = 0.5 * float(width_m), 0.5 * float(length_m)
    if a <= 0.0 or b <= 0.0:
        return max(a, b) / 2.0
    d = math.hypot(a, b)
    return (2 * a * b * d + a**3 * math.log((b + d) / a) + b**3 * math.log((a + d) / b)) / (6 * a * b)


@dataclass(frozen=True, eq=False)
class ContactPatch:
    """Where one pad touches the part: area-uniform samples of the contact, pad plane.

    Parameters
    ----------
    points_m : (k, 2) float array
        Contact samples in the pad plane (gripper x, z), m, relative to the TCP.
    area_m2 : float
        Contact area, m^2.
    slope : (2,) float array, optional
        Where the pad's edge bears on a surface that falls away from it (a cylinder's
        shoulder under the pad's edge), the surface's slope to the pad plane there, as the
        gradient of its depth behind the pad (tan of the contact normal's tilt from the
        closing axis); None or 0 for a contact inside the pad.
    groove_sin : float
        ``sin(theta / 2)`` for a part seated on the two flanks of a V-groove of included
        angle ``theta`` (:func:`asmplan.planner.grasp_groove.groove_seat`), 1 for a flat pad.
        A squeeze ``F`` presses each flank with ``F / (2 sin(theta / 2))``: the pad's
        friction is ``mu / sin(theta / 2)`` per newton of squeeze, and a twist about the
        closing axis slides a flank's points along the groove by their distance across it
        and across the groove by ``sin(theta / 2)`` of their distance along it.
    """

    points_m: np.ndarray
    area_m2: float
    slope: np.ndarray | None = None
    groove_sin: float = 1.0

    def __post_init__(self) -> None:
        p = np.asarray(self.points_m, float)
        if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] == 0:
            raise ValueError(f"ContactPatch.points_m: expected (k>0, 2), found {p.shape}")
        object.__setattr__(self, "points_m", p)
        if self.slope is not None:
            object.__setattr__(self, "slope", np.asarray(self.slope, float).reshape(2))
        if not (0.0 < self.groove_sin <= 1.0):
            raise ValueError(f"ContactPatch.groove_sin: expected within (0, 1], found "
                             f"{self.groove_sin!r}")

    @property
    def tilt_tan(self) -> float:
        """tan of the contact normal's tilt from the closing axis (0 inside the pad)."""
        return 0.0 if self.slope is None else float(np.linalg.norm(self.slope))

    def friction(self, mu: float) -> float:
        """Friction coefficient left for the load: a contact normal tilted by ``theta`` from
        the squeeze spends ``tan theta`` of it on the squeeze itself, and the load may pull
        the part towards the slope: ``tan(atan(mu) - theta)`` (the worst direction), 0 when
        the tilt is outside the friction cone."""
        t = self.tilt_tan
        if t <= 0.0:
            return float(mu) / self.groove_sin
        return max(0.0, (float(mu) - t) / (1.0 + float(mu) * t)) / self.groove_sin

    @classmethod
    def rigid(cls, points_m: np.ndarray, depth_m: np.ndarray, area_m2: float, band_m: float,
              tilt_tan: np.ndarray | None = None) -> ContactPatch:
        """The contact of a rigid flat pad with the surface samples ``points_m`` (pad plane,
        (k, 2)) lying ``depth_m`` (k,) behind it, all within ``band_m``.

        A flat face touches the pad over its whole patch, but a curved one only along a line
        (a cylinder's flank) or at a point (a sphere, an edge's end): the band of samples
        within ``band_m`` is wider than what carries the load. The depth is fitted with a
        quadratic ``d = c + g . t + 1/2 sum(k_i t_i^2)`` in the principal axes ``t`` of its
        curvature; along an axis where the fit rises by more than half the band within the
        patch, the samples are moved onto the fit's lowest line ``t_i = -g_i / k_i`` (or the
        patch's edge). A flat patch (no curvature) is kept as it is.

        ``tilt_tan`` (k, 2): the samples' normals' in-plane components over their component
        along the closing axis. Their mean is the patch's ``slope``: a band about a line
        inside the pad has normals tilted both ways (mean about 0), the pad's edge on a
        cylinder's shoulder has them all tilted one way (few samples suffice)."""
        p = np.asarray(points_m, float)
        d = np.asarray(depth_m, float)
        slope = None if tilt_tan is None else np.asarray(tilt_tan, float).reshape(-1, 2).mean(axis=0)
        if p.shape[0] < 6:  # too few for the full fit: the curvature across the patch only
            return cls(_collapse_across(p, d, band_m), area_m2, slope)
        x, z = p[:, 0], p[:, 1]
        A = np.stack([np.ones_like(x), x, z, 0.5 * x * x, x * z, 0.5 * z * z], axis=1)
        if len(d) > _NORMAL_EQUATIONS_ABOVE:  # a rasterised patch: the 6 x 6 normal equations
            # (lstsq on thousands of rows costs ~40 ms with threaded BLAS on a shared machine)
            coef = np.linalg.solve(A.T @ A, A.T @ d)
        else:
            coef, *_ = np.linalg.lstsq(A, d, rcond=None)
        H = np.array([[coef[3], coef[4]], [coef[4], coef[5]]])
        k, E = np.linalg.eigh(H)
        t = p @ E
        grad = E.T @ coef[1:3]
        moved = False
        for i in range(2):
            lo, hi = float(t[:, i].min()), float(t[:, i].max())

            def f(s: float, i: int = i) -> float:
                return float(grad[i] * s + 0.5 * k[i] * s * s)

            s_min = (min(max(-grad[i] / k[i], lo), hi) if k[i] > 0
                     else lo if f(lo) <= f(hi) else hi)
            if max(f(lo), f(hi)) - f(s_min) > 0.5 * band_m:
                t[:, i] = s_min
                moved = True
        return cls(t @ E.T if moved else p, area_m2, slope)

    @cached_property
    def centroid_m(self) -> np.ndarray:
        """Centre of the patch (pad plane x, z), m."""
        return self.points_m.mean(axis=0)

    @cached_property
    def torsion_radius_m(self) -> float:
        """Mean distance of the patch from its centroid, m (uniform pressure: the patch
        resists ``mu F`` times this about its centroid)."""
        d = self.points_m - self.centroid_m
        if self.groove_sin != 1.0:
            d = d * np.array([1.0, self.groove_sin])
        return float(np.linalg.norm(d, axis=1).mean())


def _collapse_across(p: np.ndarray, d: np.ndarray, band_m: float) -> np.ndarray:
    """A patch of 3-5 samples (too few for the quadratic fit): the depth's linear fit gives
    the direction in which the surface falls away from the pad; where it falls by more than
    half the band across the patch the samples are moved onto the line through the shallowest
    one (a cylinder's flank clipped by the pad's corner touches it along a short line)."""
    n = p.shape[0]
    if n < 3:
        return p
    A = np.stack([np.ones(n), p[:, 0], p[:, 1]], axis=1)
    coef, *_ = np.linalg.lstsq(A, d, rcond=None)
    g = coef[1:3]
    norm = float(np.linalg.norm(g))
    if norm <= 0.0:
        return p
    e = g / norm
    t = p @ e
    if norm * float(np.ptp(t)) <= 0.5 * band_m:
        return p
    return p + np.outer(float(t[int(np.argmin(d))]) - t, e)


@dataclass(frozen=True)
class HoldRequirement:
    """Clamp force per finger a grasp needs, by mechanism (safety factor included), N.

    ``friction_N`` carries the load in the pad plane and the moment about the closing axis;
    ``tipping_N`` the moment about the pad plane's axes; ``required_N`` is the larger;
    ``slide_N`` what a grasp with no moment would need (the load alone); ``lever_m`` the
    largest distance of the centre of mass from the contact centre in the pad plane;
    ``torsion_radius_m`` the mean of the two patches'."""

    required_N: float
    friction_N: float
    tipping_N: float
    slide_N: float
    lever_m: float
    torsion_radius_m: float

    @property
    def mechanism(self) -> str:
        """What limits the grip: "turning about the closing axis", "tipping about the contact
        line" or "sliding"."""
        if self.tipping_N > self.friction_N:
            return "tipping about the contact line"
        return "turning about the closing axis" if self.friction_N > 1.0001 * self.slide_N \
            else "sliding"

    def margin(self, limit_N: float) -> float:
        """``limit / required`` (inf for a part of no weight)."""
        return math.inf if self.required_N <= 0 else float(limit_N) / self.required_N

    def describe(self, limit_N: float) -> str:
        """One line of evidence: needed force, mechanism, lever and patch size."""
        return (f"needs {self.required_N:.3g} N per finger > {limit_N:.3g} N "
                f"({self.mechanism}: lever {self.lever_m * 1e3:.1f} mm, contact torsion "
                f"radius {self.torsion_radius_m * 1e3:.2f} mm)")


def load_cases(acceleration_m_s2: float, downs_gripper: tuple[np.ndarray, ...] = ()
               ) -> np.ndarray:
    """The accelerations the grip must carry per unit mass, (n, 3), m/s^2, gripper frame:
    gravity along each of ``downs_gripper`` plus ``a`` along each of 26 directions or none; or,
    without ``downs_gripper``, ``g + a`` along each direction (gravity's direction unknown)."""
    if downs_gripper:
        g = np.array([G_M_S2 * np.asarray(d, float) / np.linalg.norm(d) for d in downs_gripper])
        return (g[:, None, :] + acceleration_m_s2 * _DIRECTIONS[None, :, :]).reshape(-1, 3)
    return (G_M_S2 + acceleration_m_s2) * _DIRECTIONS


def hold_requirement(top: ContactPatch, bottom: ContactPatch, com_gripper_m: np.ndarray,
                     mass_kg: float, acceleration_m_s2: float, mu: float, safety_factor: float,
                     downs_gripper: tuple[np.ndarray, ...] = (), width_m: float = 0.0
                     ) -> HoldRequirement:
    """Clamp force per finger that holds the part (see the module docstring).

    Parameters
    ----------
    top, bottom : ContactPatch
        The pads' contacts at gripper y = +width/2 and -width/2.
    com_gripper_m : (3,) float array
        The centre of mass in the gripper frame (x, y closing, z approach; TCP origin), m.
    mass_kg, acceleration_m_s2, mu, safety_factor : float
    downs_gripper : tuple of (3,) float arrays
        Gravity's direction in the gripper frame at the poses the part is held in; empty:
        any direction (worst case).
    width_m : float
        Distance between the pads, m: the arm of the pads' friction couple about the pad
        plane's axes (0: that couple is not counted).
    """
    if mu <= 0:
        return HoldRequirement(math.inf, math.inf, 0.0, math.inf, 0.0, 0.0)
    c1, c2 = top.centroid_m, bottom.centroid_m
    centre = np.array([0.5 * (c1[0] + c2[0]), 0.0, 0.5 * (c1[1] + c2[1])])
    r = np.asarray(com_gripper_m, float) - centre
    rho = 0.5 * (top.torsion_radius_m + bottom.torsion_radius_m)
    mu1, mu2 = top.friction(mu), bottom.friction(mu)
    force_cap = mu1 + mu2  # per newton of clamp force: load in the pad plane
    torsion_cap = mu1 * top.torsion_radius_m + mu2 * bottom.torsion_radius_m
    m = float(mass_kg)
    loads = m * load_cases(float(acceleration_m_s2), downs_gripper)
    f_t = np.hypot(loads[:, 0], loads[:, 2])
    moments = np.cross(r, loads)
    m_c = np.abs(moments[:, 1])
    sf = float(safety_factor)
    if force_cap <= 0.0:
        friction = math.inf
    elif torsion_cap > 0.0:
        friction = sf * float(np.max(np.hypot(f_t / force_cap, m_c / torsion_cap)))
    else:
        friction = math.inf if float(m_c.max()) > 1e-15 else sf * float(f_t.max()) / force_cap
    slide = sf * m * (G_M_S2 + float(acceleration_m_s2)) / (2.0 * mu)
    # tipping: the normal-force couple F (p2 - p1) x c must balance the in-plane moment;
    # (p2 - p1) x y_hat = (dz, 0, -dx) for a shift (dx, dz): needed shift s = (-M_z, M_x)/F
    need = np.stack([-moments[:, 2], moments[:, 0]], axis=1)
    size = np.linalg.norm(need, axis=1)
    tipping = 0.0
    big = size > 1e-15
    if np.any(big):
        t = need[big] / size[big, None]
        reach = (bottom.points_m @ t.T).max(axis=0) - (top.points_m @ t.T).min(axis=0)
        per = np.where(reach > 1e-9, size[big] / np.maximum(reach, 1e-9), math.inf)
        if width_m > 0.0 and force_cap > 0.0:
            per = np.minimum(per, _friction_couple(loads[big], moments[big], mu1, mu2,
                                                   m_c[big], torsion_cap, float(width_m)))
        tipping = sf * float(per.max())
    lever = float(math.hypot(r[0], r[2]))
    return HoldRequirement(max(friction, tipping), friction, tipping, slide, lever, rho)


def _friction_couple(loads: np.ndarray, moments: np.ndarray, mu1: float, mu2: float,
                     m_c: np.ndarray, torsion_cap: float, width_m: float) -> np.ndarray:
    """Clamp force per finger (no safety factor) at which the pads' friction carries the
    in-plane load, the moment about the closing axis and, as a couple across the grip width,
    the moment about the pad plane's axes (see the module docstring), per load case (n,)."""
    load_t = loads[:, [0, 2]]  # (n, 2): the load in the pad plane (x, z)
    share = -load_t / (mu1 + mu2)
    a, b = mu1 * share, mu2 * share  # each pad's share of the load, by its friction
    # (w / 2) y x (f1 - f2) = -(M_x, M_z): f1 - f2 = (2 M_z / w, -2 M_x / w) in (x, z)
    diff = np.stack([2.0 * moments[:, 2], -2.0 * moments[:, 0]], axis=1) / width_m
    d = 0.5 * (diff - (a - b))
    f1, f2 = np.linalg.norm(a + d, axis=1), np.linalg.norm(b - d, axis=1)
    twist = m_c / torsion_cap if torsion_cap > 0.0 else np.where(m_c > 1e-15, math.inf, 0.0)
    need = np.zeros(len(loads))
    for f, mu_i in ((f1, mu1), (f2, mu2)):
        pad = np.hypot(f / mu_i, twist) if mu_i > 0.0 else np.where(f > 1e-15, math.inf, 0.0)
        need = np.maximum(need, pad)
    return need


@dataclass(frozen=True, eq=False)
class HoldInputs:
    """What :func:`hold_requirement` judged a grasp on, kept to judge it again on more
    load cases (the gravity directions along the planned transfer:
    :mod:`asmplan.planner.transfer_hold`).

    Parameters
    ----------
    top, bottom : ContactPatch
    com_gripper_m : (3,) float array
    mass_kg, acceleration_m_s2, mu, safety_factor, width_m : float
    downs_gripper : tuple of (3,) float arrays
        The gravity directions it was judged on (gripper frame).
    T_part_gripper : (4, 4) float array
        The gripper frame these are expressed in.
    """

    top: ContactPatch
    bottom: ContactPatch
    com_gripper_m: np.ndarray
    mass_kg: float
    acceleration_m_s2: float
    mu: float
    safety_factor: float
    width_m: float
    downs_gripper: tuple[np.ndarray, ...]
    T_part_gripper: np.ndarray

    def requirement(self, downs_part: np.ndarray | None = None) -> HoldRequirement:
        """The hold requirement on the judged gravity directions plus ``downs_part`` ((n, 3)
        gravity directions in the part frame), or on any direction if none was judged."""
        downs = self.downs_gripper
        if downs and downs_part is not None and len(downs_part):
            R = np.asarray(self.T_part_gripper, float)[:3, :3]
            downs = (*downs, *(np.asarray(downs_part, float).reshape(-1, 3) @ R))
        return hold_requirement(self.top, self.bottom, self.com_gripper_m, self.mass_kg,
                                self.acceleration_m_s2, self.mu, self.safety_factor, downs,
                                self.width_m)


def hold_lower_bound(lever_lb_m: float, pad_width_m: float, pad_length_m: float,
                     acceleration_m_s2: float) -> float:
    """A lower bound of ``friction_N / slide_N`` of :func:`hold_requirement` for any patches
    within a ``width x length`` pad whose centroids are at least ``lever_lb_m`` from the
    centre of mass in the pad plane: the inertial load along one of the pad plane's axes makes
    at least ``m a lever / sqrt 2`` of moment about the closing axis, and no patch within the
    pad has a torsion radius above half its diagonal (its standard deviation's bound)."""
    rho_max = 0.5 * math.hypot(pad_width_m, pad_length_m)
    a = float(acceleration_m_s2)
    return a * max(0.0, float(lever_lb_m)) / (math.sqrt(2.0) * rho_max * (G_M_S2 + a))


HOLD_QUANTUM = 0.02
"""Resolution of the ranking's hold term (:func:`hold_term`)."""


def hold_term(slide_N: float, required_N: float) -> float:
    """The ranking's hold term ``1 - F_slide / F_hold`` (0 to 1), floored to ``HOLD_QUANTUM``:
    differences below the sampling noise of the contact patches (a few % of the torsion
    radius) are not physics, so grasps that hold alike (a cylinder closed along any radial
    direction) tie and keep their generation order (the part's own axes first). Flooring is
    monotonic, so a lower bound of the ratio gives a lower bound of the term."""
    t = max(0.0, 1.0 - slide_N / required_N) if required_N > 0 else 0.0
    return math.floor(t / HOLD_QUANTUM) * HOLD_QUANTUM


class HoldRejections:
    """Grasps rejected because the grip cannot hold the part, with the best of them."""

    def __init__(self) -> None:
        self.count = 0
        self.best: HoldRequirement | None = None

    def add(self, req: HoldRequirement) -> None:
        self.count += 1
        if self.best is None or req.required_N < self.best.required_N:
            self.best = req

    def reasons(self, limit_N: float) -> list[str]:
        if not self.count or self.best is None:
            return []
        return [f"{self.count} candidate{'s' if self.count != 1 else ''}: the grip cannot hold "
                f"the part's weight and inertia (the best {self.best.describe(limit_N)})"]
