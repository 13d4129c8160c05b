"""Press fits measured on the geometry: hub walls, hollow male parts and the press force.

The press force model (Lame pressure, friction, size distribution) lives in
:mod:`asmplan.knowledge.press_fit`; this module measures the two diameters it needs on the
parts' exact solids (manifold3d):

* ``D_o``, the hub's outer diameter around a hole: twice the largest radius out to which an
  annulus around the hole axis, over the engaged length, is all material. A hole in a block
  gets the diameter of the largest round hub the block contains there (the thinnest wall
  governs, as DIN 7190 suggests for non-round hubs); a hub wall thicker than
  ``UNBOUNDED_RATIO`` times the hole diameter counts as unbounded (``inf``: the Lame ratio is
  then within 1 % of its limit 1). A mate's declared ``hub_diameter`` replaces the measure.
  The search doubles the wall from a quarter of the radius until the ring is no longer all
  material, then bisects to ``RADIUS_TOLERANCE`` of the radius or ``WALL_TOLERANCE`` of the
  wall (one boolean per probe, on the solid clipped to the neighbourhood of the hole).
* ``d_i``, the bore of a hollow male feature (a bearing ring, a bushing, a sleeve):
  :func:`asmplan.parts.features.male_bore_diameter_m`; 0 for a solid pin.

"""

from __future__ import annotations

import math

from ..knowledge.model import Feature, Mate, Product
from ..knowledge.press_fit import PressFit, PressFitError, predict_press_fit
from .features import Finding, T_part_feature, _tube, male_bore_diameter_m

UNBOUNDED_RATIO = 10.0
"""A hub wall out to this many hole diameters counts as unbounded (D_o = inf)."""
RADIUS_TOLERANCE = 0.01
"""Resolution of the hub search, relative to the hole radius ..."""
WALL_TOLERANCE = 0.03
"""... or to the wall thickness when that is coarser (a thick wall hardly changes p)."""
PROBE_SIDES = 48
"""Sides of the probe rings (their polygon error, 0.2 % of the radius, is below the
search's resolution)."""
_FULL = 2e-3  # missing volume fraction still counted as "all material" (polygonised circles)


def _fraction(solid, tube) -> float:
    v = tube.volume()
    return (solid ^ tube).volume() / v if v > 0 else 0.0


def hub_outer_diameter_m(solid, hole: Feature, hole_diameter_m: float, engaged_m: float) -> float:
    """``D_o`` (m) of the material around ``hole`` over ``engaged_m`` below its mouth chamfer;
    ``inf`` when the wall reaches ``UNBOUNDED_RATIO`` diameters (see the module docstring)."""
    r = 0.5 * hole_diameter_m
    T = T_part_feature(hole)
    z0 = -max(engaged_m, 1e-6) * 0.98
    z1 = -min(hole.chamfer_m + 0.02 * engaged_m, 0.5 * engaged_m)

    cap = UNBOUNDED_RATIO * hole_diameter_m
    # the probes only need the material near the hole: clip the solid once (fewer triangles)
    near = solid ^ _tube(0.0, cap * 1.01, z0 - 1e-4, z1 + 1e-4, T, n=PROBE_SIDES)

    def full(R: float) -> bool:
        return _fraction(near, _tube(r * 1.005, R, z0, z1, T, n=PROBE_SIDES)) >= 1.0 - _FULL

    # bracket the wall by doubling its thickness from a quarter of the radius, then bisect
    # to RADIUS_TOLERANCE of the radius or WALL_TOLERANCE of the wall, whichever is larger
    lo, hi = r * 1.02, r * 1.25
    if not full(hi):
        if not full(lo):
            return 2.0 * lo  # hardly any wall: the thinnest hub the search can state
    else:
        while True:
            lo, hi = hi, min(r + 2.0 * (hi - r), cap)
            if full(hi):
                if hi >= cap:
                    return math.inf
                continue
            break
    while hi - lo > max(RADIUS_TOLERANCE * r, WALL_TOLERANCE * (lo - r)):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if full(mid) else (lo, mid)
    return 2.0 * lo


def engaged_length_m(geometry, mate: Mate) -> float:
    """Length over which pin and hole overlap when seated: min(pin length, hole depth), m."""
    product = geometry.product
    pin = product.feature(mate.pin_part, mate.pin_feature)
    hole = product.feature(mate.hole_part, mate.hole_feature)
    return float(min(pin.length_m, geometry.feature_depth(hole)))


def mate_press_fit(product: Product, geometry, mate: Mate) -> PressFit:
    """The press force range of one interfering (or transition) mate.

    Raises
    ------
    PressFitError
        As :func:`asmplan.knowledge.press_fit.predict_press_fit`.
    """
    pin = product.feature(mate.pin_part, mate.pin_feature)
    hole = product.feature(mate.hole_part, mate.hole_feature)
    L = engaged_length_m(geometry, mate)
    if mate.hub_diameter_m is not None:
        D_o, source = float(mate.hub_diameter_m), "declared"
    else:
        D_o = hub_outer_diameter_m(geometry.solid(mate.hole_part), hole,
                                   geometry.sizing.diameter(hole), L)
        source = "measured" if math.isfinite(D_o) else \
            f"unbounded (wall > {UNBOUNDED_RATIO:g} x d)"
    d_i = male_bore_diameter_m(geometry.solid(mate.pin_part), pin, geometry.sizing.diameter(pin))
    return predict_press_fit(mate, hole.diameter_m, L, D_o, d_i,
                             product.part(mate.hole_part).material,
                             product.part(mate.pin_part).material, source)


def press_fits(product: Product, geometry) -> tuple[tuple[PressFit, ...], tuple[Finding, ...]]:
    """Press force of every mate whose clearance range reaches below zero, and a finding
    (error) for each such mate whose force cannot be predicted.

    Parameters
    ----------
    product : Product
    geometry : asmplan.parts.models.ProductGeometry
    """
    fits: list[PressFit] = []
    findings: list[Finding] = []
    for mate in product.mates:
        if mate.clearance_min_m >= 0:
            continue
        try:
            fits.append(mate_press_fit(product, geometry, mate))
        except PressFitError as exc:
            findings.append(Finding("error", mate.name, f"cannot predict the press force: {exc}",
                                    (("clearance_min_m", mate.clearance_min_m),)))
    return tuple(fits), tuple(findings)


def hollow_male_bores(product: Product, geometry) -> dict[tuple[str, str], float]:
    """``{(part, feature): d_i}`` of every male feature, m (0 for solid ones)."""
    out: dict[tuple[str, str], float] = {}
    for part in product.parts:
        for f in part.features:
            if f.is_male:
                out[(part.name, f.name)] = male_bore_diameter_m(geometry.solid(part.name), f,
                                                                geometry.sizing.diameter(f))
    return out


__all__ = ["UNBOUNDED_RATIO", "engaged_length_m", "hollow_male_bores", "hub_outer_diameter_m",
           "male_bore_diameter_m", "mate_press_fit", "press_fits"]
