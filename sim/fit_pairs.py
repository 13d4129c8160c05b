"""The exact fit contact of one pipeline step: the held part's mates with the parts in its scene,
as :mod:`asmplan.sim.feature_contact` models them (from the knowledge base's features and the
diameters as built, :attr:`asmplan.parts.models.ProductGeometry.sizing`).

A partner is modelled only when every mate the held part has with it can be (a clearance as
built > 0): Bullet's contact with that partner is switched off as a whole while the model is on.
So the pin part's coaxial features beyond the mated pin's tip (:func:`leading_features`, a
stepped shaft's thinner end) are modelled in the same bore too: they enter it first.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..knowledge.model import Feature, Product
from .bullet import BulletWorld
from .feature_contact import FitPair, HeldFitContact
from .fit_geometry import BoreFeature, FitContactModel, PinFeature

RIM_WIDTH_M = 2e-3
"""How far beyond the mouth chamfer the block's face is modelled when the hole part's solid does
not give the face's extent (at most the pin's radius), m. With the solid, the face is modelled
out to its farthest vertex in the face's plane: Bullet's contact between the two bodies is off
while the model is on, so a pin landing beyond the modelled face would sink into the block
(measured: the bundled peg 12 mm off the hole, with a 2 mm face, tipped 0.5 deg into the
block and was judged 'jammed 0.54 mm deep' instead of stopped on the face). The shoulder seat
stays within the 2 mm face (a shoulder circle as wide as the whole face stopped pinhole_station
part2 6.3 mm off its hole: the part's solid is not a disc)."""

SEAT_INSET_M = 0.5e-3
"""The shoulder circle that seats on the face lies this far inside the modelled face's edge
(so that it is one feature from it, :attr:`FitContact.single_feature`), m."""

SHOULDER_MIN_STEP_M = 0.05e-3
"""A pin part seats on its shoulder when its solid reaches this much beyond the pin's radius in
the root plane."""


def _radial_extent(vertices: np.ndarray, origin: np.ndarray, axis: np.ndarray,
                   along_m: float, tol_m: float = 1e-6) -> float:
    """Largest distance from the axis of the part-frame ``vertices`` lying in the plane
    ``along_m`` along ``axis`` from ``origin`` (0 when none)."""
    rel = vertices - origin
    s = rel @ axis
    on = np.abs(s - along_m) <= tol_m
    if not np.any(on):
        return 0.0
    radial = rel[on] - np.outer(s[on], axis)
    return float(np.max(np.linalg.norm(radial, axis=1)))


def fit_model(pin: Feature, hole: Feature, pin_diameter_m: float, hole_diameter_m: float,
              hole_depth_m: float, pin_vertices: np.ndarray | None = None,
              hole_vertices: np.ndarray | None = None) -> FitContactModel:
    """The exact contact model of a pin feature in a hole feature (each in its part frame).

    ``pin_vertices`` / ``hole_vertices`` (part-frame vertices of the parts' solids) give the
    pin part's shoulder in the root plane (it seats on the block's face) and the extent of the
    hole's face."""
    r, R = 0.5 * pin_diameter_m, 0.5 * hole_diameter_m
    tip = pin.origin_m + pin.length_m * pin.axis
    rim = R + hole.chamfer_m + min(r, RIM_WIDTH_M)
    face_rim = rim
    if hole_vertices is not None:
        face = _radial_extent(hole_vertices, hole.origin_m, hole.axis, 0.0)
        if face > R + hole.chamfer_m:
            rim = min(rim, face)
            face_rim = face
    seat = 0.0
    if pin_vertices is not None:
        shoulder = _radial_extent(pin_vertices, pin.origin_m, pin.axis, 0.0)
        if shoulder > r + SHOULDER_MIN_STEP_M:
            seat = min(shoulder, rim - SEAT_INSET_M)
            if seat <= R + hole.chamfer_m:
                seat = 0.0
    return FitContactModel(
        PinFeature(tip, -pin.axis, r, pin.chamfer_m, pin.length_m, seat),
        BoreFeature(hole.origin_m, hole.axis, R, hole.chamfer_m, hole_depth_m, hole.through,
                    face_rim))


LEADING_TOL_M = 1e-6
"""A feature is coaxial with a pin, and starts at its tip, within this distance, m."""


def leading_features(product: Product, pin: Feature) -> tuple[Feature, ...]:
    """The pin part's other pin or shaft features that lie beyond ``pin``'s tip on its axis
    (a stepped shaft's thinner end, e.g. gear_unit's ``tail`` beyond ``front``): they enter the
    bore before ``pin`` does, and Bullet's contact between the two bodies is off while the
    model is on, so the bore must meet them too."""
    tip = pin.origin_m + pin.length_m * pin.axis
    out = []
    for f in product.part(pin.part).features:
        if f.name == pin.name or f.kind not in ("pin", "shaft"):
            continue
        rel = f.origin_m - tip
        along = float(rel @ pin.axis)
        off_axis = float(np.linalg.norm(rel - along * pin.axis))
        if (float(f.axis @ pin.axis) > 1.0 - 1e-9 and off_axis <= LEADING_TOL_M
                and along >= -LEADING_TOL_M):
            out.append(f)
    return tuple(out)


def held_fit_contact(world: BulletWorld, ids: Mapping[str, int], held: str, product: Product,
                     geometry) -> HeldFitContact | None:
    """The exact fit contact of ``held``'s mates with the parts in the world (``ids``: part
    name -> body), or None when none can be modelled."""
    by_partner: dict[str, list] = {}
    blocked: set[str] = set()
    for mate in product.mates:
        if held not in (mate.pin_part, mate.hole_part):
            continue
        other = mate.hole_part if mate.pin_part == held else mate.pin_part
        if other not in ids or other == held:
            continue
        pin = product.feature(mate.pin_part, mate.pin_feature)
        hole = product.feature(mate.hole_part, mate.hole_feature)
        d, D = geometry.sizing.diameter(pin), geometry.sizing.diameter(hole)
        if not (D - d > 0.0 and pin.kind in ("pin", "shaft") and hole.kind in ("hole", "bore")):
            blocked.add(other)
            continue
        by_partner.setdefault(other, []).append((mate, pin, hole, d, D))
    pairs, friction = [], []
    for other, mates in by_partner.items():
        if other in blocked:
            continue
        for mate, pin, hole, d, D in mates:
            model = fit_model(pin, hole, d, D, geometry.feature_depth(hole),
                              np.asarray(geometry.mesh(mate.pin_part).vertices, float),
                              np.asarray(geometry.mesh(mate.hole_part).vertices, float))
            mu = world.lateral_friction(ids[held]) * world.lateral_friction(ids[other])
            pairs.append(FitPair(ids[other], model, held_is_pin=mate.pin_part == held))
            friction.append(mu)
            for lead in leading_features(product, pin):
                d_lead = geometry.sizing.diameter(lead)
                if d_lead < D:
                    # no shoulder (the mated pin's own solid follows it into the bore)
                    pairs.append(FitPair(ids[other], fit_model(
                        lead, hole, d_lead, D, geometry.feature_depth(hole), None,
                        np.asarray(geometry.mesh(mate.hole_part).vertices, float)),
                        held_is_pin=mate.pin_part == held))
                    friction.append(mu)
    if not pairs:
        return None
    return HeldFitContact(world, ids[held], pairs, friction)
