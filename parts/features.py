"""Feature frames, feature depths measured on the solid, and the per-mate feature checks.

A feature frame ``T_part_feature`` (4, 4) has its origin at the feature's origin (pin root,
hole mouth) and its z axis along the feature axis (root to tip for a pin, the outward normal
of the face for a hole); see :mod:`asmplan.knowledge.model`.

Checks return :class:`Finding` objects (severity, subject, message, evidence), never raise:

* every feature against the solid (material probes built with manifold3d booleans): a hole
  has no material inside 98 % of its radius over its depth, and material within 10 % outside
  it; a pin is material out to 98 % of its radius over its length, with no material from
  102 % to 110 % of its radius (it stands free). The 2 % allow a tessellated mesh (a 16-gon
  or finer) to pass. A male feature may be HOLLOW (a bearing ring, a bushing, a sleeve: the
  male side of a fit into a bore and the female side for a shaft): when the solid is empty
  along its axis, its bore ``d_i`` is measured (:func:`male_bore_diameter_m`) and the pin
  must be material from 102 % of that bore out to 98 % of its radius.
* every mate at the assembled pose: pin axis antiparallel to the hole axis within 0.1 deg,
  pin root on the hole axis within 10 um, pin root at the hole mouth (the axial offset is
  reported; more than 10 um is a warning), pin no longer than the hole is deep (blind holes),
  equal nominal diameters for an ISO fit, and the built (fitted) clearance inside the
  declared range.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..knowledge.frames import frame_from_axis, transform_points
from ..knowledge.model import Feature, Product
from .geometry import FeatureSizing

AXIS_TOLERANCE_RAD = math.radians(0.1)
COAXIAL_TOLERANCE_M = 10e-6
AXIAL_TOLERANCE_M = 10e-6


@dataclass(frozen=True)
class Finding:
    """One result of a feature or mate check.

    Parameters
    ----------
    severity : {"error", "warning"}
    subject : str
        ``part.feature`` or the mate name.
    message : str
        What was expected and what was found.
    evidence : tuple of (name, value) pairs
        Measured numbers in SI units (names carry the unit).
    """

    severity: Literal["error", "warning"]
    subject: str
    message: str
    evidence: tuple[tuple[str, float], ...] = field(default_factory=tuple)

    def as_dict(self) -> dict[str, object]:
        return {"severity": self.severity, "subject": self.subject, "message": self.message,
                "evidence": dict(self.evidence)}


def T_part_feature(feature: Feature) -> np.ndarray:
    """Feature frame (4, 4) in the part frame: origin at the feature origin, z = axis."""
    return frame_from_axis(feature.origin_m, feature.axis)


def _m3():
    import manifold3d

    return manifold3d


def _tube(r_in: float, r_out: float, z0: float, z1: float, T_part_frame: np.ndarray, n: int = 64):
    """Annulus (or cylinder for r_in = 0) along z of ``T_part_frame`` between z0 < z1."""
    m3 = _m3()
    outer = m3.Manifold.cylinder(z1 - z0, r_out, r_out, n, False).translate([0.0, 0.0, z0])
    if r_in > 0:
        hole = m3.Manifold.cylinder(z1 - z0 + 2e-3, r_in, r_in, n, False)
        outer = outer - hole.translate([0.0, 0.0, z0 - 1e-3])
    return outer.transform(np.ascontiguousarray(T_part_frame[:3, :4]))


def through_depth(solid, feature: Feature, diameter_m: float | None = None) -> float:
    """Depth (m) of material around a hole, measured along its axis from the mouth.

    The solid is intersected with a thin annulus just outside the hole wall (from 2 % to
    10 % of the radius beyond it, at most 0.5 mm thick) reaching 10 m down the axis; the
    depth is the farthest point of that intersection. 0 when there is no material.
    """
    r = 0.5 * (diameter_m or feature.diameter_m)
    r_in = r * 1.02
    r_out = min(r * 1.10, r_in + 0.5e-3)
    T = T_part_feature(feature)
    ring = _tube(r_in, r_out, -10.0, 1e-3, T)
    inter = solid ^ ring
    if inter.is_empty():
        return 0.0
    V = np.asarray(inter.to_mesh64().vert_properties, dtype=float)[:, :3]
    return float(np.max((feature.origin_m - V) @ feature.axis))


BORE_RADIUS_TOLERANCE = 0.005
"""Relative resolution of the bore search of a hollow male feature."""
_EMPTY = 2e-3  # filled volume fraction still counted as empty (polygonised circles)


def male_bore_diameter_m(solid, male: Feature, male_diameter_m: float) -> float:
    """Bore ``d_i`` (m) of a hollow male feature, 0 for a solid one.

    Twice the largest radius of a cylinder on the male axis, over 2-98 % of its length, that
    holds no material (a binary search to ``BORE_RADIUS_TOLERANCE`` of the radius, one
    boolean per probe). A male feature whose axis is material within 2 % of its radius is
    solid; one with no material out to 98 % of its radius has no wall, and is returned as
    solid (0) so that the feature check reports the missing material.
    """
    R = 0.5 * male_diameter_m
    T = T_part_feature(male)
    z0, z1 = 0.02 * male.length_m, 0.98 * male.length_m

    def empty(r: float) -> bool:
        tube = _tube(0.0, r, z0, z1, T, n=96)
        v = tube.volume()
        return v <= 0 or (solid ^ tube).volume() / v <= _EMPTY

    lo = 0.02 * R
    if not empty(lo):
        return 0.0
    hi = 0.98 * R
    if empty(hi):
        return 0.0  # no wall at all: not a hollow feature but a missing one (checked as solid)
    while hi - lo > BORE_RADIUS_TOLERANCE * R:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if empty(mid) else (lo, mid)
    return 2.0 * lo


def feature_depth(solid, feature: Feature, diameter_m: float | None = None) -> float:
    """Declared depth (blind hole, pin length) or the depth measured on ``solid`` (through)."""
    if feature.is_male or not feature.through:
        return feature.length_m
    return through_depth(solid, feature, diameter_m)


def check_feature(solid, feature: Feature, depth_m: float, diameter_m: float | None = None,
                  ) -> list[Finding]:
    """Probe the solid around one feature (see the module docstring)."""
    r = 0.5 * (diameter_m or feature.diameter_m)
    T = T_part_feature(feature)
    out: list[Finding] = []
    ref = feature.ref
    if depth_m <= 0:
        return [Finding("error", ref, f"expected material around {feature.kind} {ref}, found none "
                        "along its axis", (("radius_m", r),))]
    if feature.is_male:
        z0, z1 = 0.01 * depth_m, 0.99 * depth_m - feature.chamfer_m
        r_in = 0.5 * male_bore_diameter_m(solid, feature, 2 * r)
        core = _tube(1.02 * r_in if r_in > 0 else 0.0, 0.98 * r, z0, max(z1, z0 + 1e-6), T)
        missing = (core - solid).volume() / max(core.volume(), 1e-300)
        if missing > 1e-3:
            wall = f"from its {2.04 * r_in * 1e3:.4g} mm bore " if r_in > 0 else ""
            out.append(Finding("error", ref, f"expected the {feature.kind} to be material {wall}out to "
                               f"{0.98 * r * 2e3:.4g} mm diameter over its {depth_m * 1e3:g} mm length, "
                               f"found {missing:.1%} of that volume empty",
                               (("missing_fraction", missing), ("diameter_m", 2 * r),
                                ("bore_diameter_m", 2 * r_in))))
        ring = _tube(1.02 * r, 1.10 * r, 0.02 * depth_m, 0.98 * depth_m, T)
        buried = (ring ^ solid).volume() / max(ring.volume(), 1e-300)
        if buried > 1e-3:
            out.append(Finding("warning", ref, f"expected the {feature.kind} to stand free, found "
                               f"material around it ({buried:.1%} of a ring 2-10 % outside its radius)",
                               (("material_fraction", buried),)))
        return out
    z0, z1 = -0.99 * depth_m, -0.01 * depth_m
    core = _tube(0.0, 0.98 * r, z0, z1, T)
    inside = (core ^ solid).volume() / max(core.volume(), 1e-300)
    if inside > 1e-3:
        out.append(Finding("error", ref, f"expected no material inside the {feature.kind} "
                           f"({2 * r * 1e3:.4g} mm over {depth_m * 1e3:.4g} mm), found {inside:.1%} "
                           "of it filled", (("filled_fraction", inside), ("diameter_m", 2 * r))))
        return out
    z_top = -0.02 * depth_m - feature.chamfer_m
    ring = _tube(1.02 * r, min(1.10 * r, 1.02 * r + 0.5e-3), -0.98 * depth_m, z_top, T)
    wall = (ring ^ solid).volume() / max(ring.volume(), 1e-300)
    if wall < 0.5:
        out.append(Finding("warning", ref, f"expected a wall just outside the {feature.kind}'s "
                           f"{2 * r * 1e3:.4g} mm diameter, found material in {wall:.0%} of it: the "
                           "hole may be larger than declared", (("wall_fraction", wall),)))
    return out


def check_mates(product: Product, sizing: FeatureSizing,
                depth_of: Callable[[Feature], float]) -> list[Finding]:
    """Check every mate at the assembled pose (see the module docstring).

    Parameters
    ----------
    product : Product
    sizing : FeatureSizing
        The fitted diameters the geometry was built with.
    depth_of : callable
        ``depth_of(feature)`` -> hole depth in metres (measured for through holes).
    """
    out: list[Finding] = []
    for mate in product.mates:
        pin = product.feature(mate.pin_part, mate.pin_feature)
        hole = product.feature(mate.hole_part, mate.hole_feature)
        T_wp = product.T_world_assembled(mate.pin_part)
        T_wh = product.T_world_assembled(mate.hole_part)
        a_p = T_wp[:3, :3] @ pin.axis
        a_h = T_wh[:3, :3] @ hole.axis
        root = transform_points(T_wp, pin.origin_m[None])[0]
        mouth = transform_points(T_wh, hole.origin_m[None])[0]
        angle = float(np.arccos(np.clip(-float(a_p @ a_h), -1.0, 1.0)))
        v = root - mouth
        axial = float(v @ a_h)
        radial = float(np.linalg.norm(v - axial * a_h))
        ev = (("axis_angle_rad", angle), ("radial_offset_m", radial), ("axial_offset_m", axial))
        if angle > AXIS_TOLERANCE_RAD:
            out.append(Finding("error", mate.name, f"expected pin {pin.ref} antiparallel to hole "
                               f"{hole.ref} within 0.1 deg, found {math.degrees(angle):.3f} deg apart",
                               ev))
        if radial > COAXIAL_TOLERANCE_M:
            out.append(Finding("error", mate.name, f"expected the root of pin {pin.ref} on the axis "
                               f"of hole {hole.ref} within 10 um, found it {radial * 1e3:.4g} mm off", ev))
        if abs(axial) > AXIAL_TOLERANCE_M:
            where = "outside" if axial > 0 else "inside"
            out.append(Finding("warning", mate.name, f"expected the root of pin {pin.ref} at the mouth "
                               f"of hole {hole.ref}, found it {abs(axial) * 1e3:.4g} mm {where}", ev))
        depth = depth_of(hole)
        reach = pin.length_m - axial
        if not hole.through and reach > depth + 1e-6:
            out.append(Finding("error", mate.name, f"expected pin {pin.ref} ({pin.length_m * 1e3:g} mm) "
                               f"to fit hole {hole.ref} ({depth * 1e3:g} mm deep), found it "
                               f"{(reach - depth) * 1e3:.4g} mm too long: it bottoms out",
                               (("pin_reach_m", reach), ("hole_depth_m", depth))))
        if mate.fit and abs(pin.diameter_m - hole.diameter_m) > 1e-9:
            out.append(Finding("error", mate.name, f"expected equal nominal diameters for fit {mate.fit}, "
                               f"found pin {pin.diameter_m * 1e3:g} mm, hole {hole.diameter_m * 1e3:g} mm",
                               (("pin_diameter_m", pin.diameter_m), ("hole_diameter_m", hole.diameter_m))))
        built = sizing.diameter(hole) - sizing.diameter(pin)
        if not (mate.clearance_min_m - 1e-9 <= built <= mate.clearance_max_m + 1e-9):
            out.append(Finding("error", mate.name, f"expected the built clearance inside the declared "
                               f"{mate.clearance_min_m * 1e6:+.1f}..{mate.clearance_max_m * 1e6:+.1f} um, "
                               f"found {built * 1e6:+.2f} um (another mate resized a shared feature)",
                               (("built_clearance_m", built),)))
    return out


def feature_frames(features: tuple[Feature, ...]) -> Mapping[str, np.ndarray]:
    """``{feature name: T_part_feature}`` for a part's features."""
    return {f.name: T_part_feature(f) for f in features}


__all__ = [
    "AXIAL_TOLERANCE_M",
    "AXIS_TOLERANCE_RAD",
    "COAXIAL_TOLERANCE_M",
    "Finding",
    "T_part_feature",
    "check_feature",
    "check_mates",
    "feature_depth",
    "feature_frames",
    "male_bore_diameter_m",
    "through_depth",
]
