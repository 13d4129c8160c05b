"""Assembly check: every part at its assembled pose, every mate's clearance, every interference.

For each mate a probe cylinder of the pin's built (fitted) diameter is placed on the pin's
axis over the middle half of the length it shares with the hole, and its FCL distance to the
hole part's collision model (at the chosen level) is measured: twice that distance is the
diametral clearance the model gives the fit (minus twice the penetration depth when they
overlap, for interference fits). It must lie in the declared range widened by the level's
error bound for that hole (``measured_within``).

Every pair of parts is then tested for contact deeper than ``tolerance_m``; a contact between
the two parts of an interference or transition mate is expected up to half the declared
interference (plus the bound) and is listed as ``intended``; anything else is an
interference, with the pair, the point, FCL's deepest local contact depth, and as ``depth_m``
the smallest translation along a world axis that separates the two parts (the overlap of a
part placed too low, for instance). The contact tolerance ``tolerance_m`` (1 um) applies to
that separation too: two BVH surfaces lying face on face (a cover resting on a housing) give
FCL triangle-local depths of micrometres, but parts that a translation of at most the
tolerance separates touch; they do not interfere.

Every mate whose clearance range reaches below zero (interference and transition fits) gets
its press force range (:mod:`asmplan.parts.press_fit`): min/typical/max axial force, the
probability that the pair interferes, the hub and bore diameters and the materials used.

A failed check is a result (``AssemblyCheck.success`` False with the reason), not an exception.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..knowledge.model import Product
from ..knowledge.press_fit import PressFit
from .collision import CollisionWorld
from .features import Finding, check_mates
from .geometry import polygon_excess, sides_for_tolerance
from .models import ProductGeometry
from .nominal_contacts import nominal_contact
from .pieces import CollisionModel, ConvexPiece, LevelOfDetail
from .press_fit import press_fits

NUMERIC_ALLOWANCE_M = 0.01e-6  # FCL in millimetres resolves about 1 nm; allow 10 nm


@dataclass(frozen=True)
class MateClearance:
    """Measured clearance of one mate (diametral values, metres)."""

    mate: str
    pin: str
    hole: str
    fit: str | None
    declared_min_m: float
    declared_max_m: float
    built_m: float
    measured_m: float
    bound_m: float
    axial_overlap_m: float

    @property
    def measured_within(self) -> bool:
        """Whether the measured clearance is inside the declared range widened by the bound."""
        return self.declared_min_m - self.bound_m <= self.measured_m <= self.declared_max_m + self.bound_m


@dataclass(frozen=True, eq=False)
class Interference:
    """Two parts that overlap deeper than the tolerance at their assembled poses."""

    a: str
    b: str
    depth_m: float
    point_m: np.ndarray
    intended_by: str | None = None
    contact_depth_m: float = 0.0
    separate_along: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True, eq=False)
class AssemblyCheck:
    """Result of :func:`check_assembly`.

    ``success`` is False when any part interferes, any mate's clearance is out of its
    declared range (widened by the level's bound), or any finding is an error; ``reason``
    says which.
    """

    product: str
    level: LevelOfDetail
    mates: tuple[MateClearance, ...]
    interferences: tuple[Interference, ...]
    intended_contacts: tuple[Interference, ...]
    findings: tuple[Finding, ...]
    timings_s: dict[str, float] = field(default_factory=dict)
    press_fits: tuple[PressFit, ...] = ()

    @property
    def success(self) -> bool:
        return not self.reason

    @property
    def reason(self) -> str:
        parts = []
        if self.interferences:
            parts.append("interference: " + ", ".join(f"{i.a}/{i.b} {i.depth_m * 1e3:.3g} mm"
                                                       for i in self.interferences))
        bad = [m.mate for m in self.mates if not m.measured_within]
        if bad:
            parts.append("clearance out of the declared range: " + ", ".join(bad))
        errors = [f.subject for f in self.findings if f.severity == "error"]
        if errors:
            parts.append("feature errors: " + ", ".join(dict.fromkeys(errors)))
        return "; ".join(parts)

    def press_fit(self, mate: str) -> PressFit | None:
        """The press force prediction of ``mate`` (None for a clearance fit)."""
        return next((p for p in self.press_fits if p.mate == mate), None)

    def as_dict(self) -> dict[str, object]:
        """JSON-safe summary (SI units). Each mate carries ``press_force_N`` ({min, typical,
        max}, null for a clearance fit) and ``probability_interference``; ``press_fits``
        holds the full prediction (diameters, materials, friction, pressure)."""
        def press(m: MateClearance) -> dict[str, object]:
            pf = self.press_fit(m.mate)
            if pf is None:
                return {"press_force_N": None, "probability_interference": 0.0}
            d = pf.as_dict()
            return {"press_force_N": d["press_force_N"],
                    "probability_interference": pf.probability_interference}

        return {
            "product": self.product, "level": self.level, "success": self.success, "reason": self.reason,
            "mates": [{"mate": m.mate, "pin": m.pin, "hole": m.hole, "fit": m.fit,
                       "declared_min_m": m.declared_min_m, "declared_max_m": m.declared_max_m,
                       "built_m": m.built_m, "measured_m": m.measured_m, "bound_m": m.bound_m,
                       "within": m.measured_within, **press(m)} for m in self.mates],
            "press_fits": [p.as_dict() for p in self.press_fits],
            "interferences": [{"a": i.a, "b": i.b, "depth_m": i.depth_m, "point_m": i.point_m.tolist(),
                               "contact_depth_m": i.contact_depth_m, "separate_along": list(i.separate_along)}
                              for i in self.interferences],
            "intended_contacts": [{"a": i.a, "b": i.b, "depth_m": i.depth_m, "mate": i.intended_by}
                                  for i in self.intended_contacts],
            "findings": [f.as_dict() for f in self.findings],
            "timings_s": self.timings_s,
        }


def _mate_bound(geometry: ProductGeometry, hole_part: str, hole_feature: str, level: LevelOfDetail) -> float:
    """Error bound (diametral, m) of the hole's clearance in the level's model."""
    if level == "exact":
        # a mesh file's hole is the polygon of its tessellation: its chords sag inside the circle
        from .nominal_contacts import mesh_hole_bound

        sag = mesh_hole_bound(geometry, hole_part, hole_feature)
        if sag is not None:
            return sag + NUMERIC_ALLOWANCE_M
        # the exact hole polygon's faces are tangent to the circle: only the corner play
        # 2 c (sec(pi/n) - 1) of its n >= 160 sides separates it from the true hole
        for h in geometry.holes(hole_part):
            if h.feature == hole_feature and not geometry.shape(hole_part).is_mesh:
                n = sides_for_tolerance(h.radius_m + h.chamfer_m + 1e-3, geometry.settings.exact_tolerance_m)
                c = abs(geometry.hole_sides(hole_part)[hole_feature].radial_clearance_m)
                return 2.0 * polygon_excess(c, n) + NUMERIC_ALLOWANCE_M
        return NUMERIC_ALLOWANCE_M
    report = geometry.level_report(hole_part, level)
    for hc in report.holes:
        if hc.feature == hole_feature:
            return hc.error_m + NUMERIC_ALLOWANCE_M
    return report.hausdorff_m * 2.0 + NUMERIC_ALLOWANCE_M


def measure_mate_clearance(product: Product, geometry: ProductGeometry, world: CollisionWorld, mate,
                           level: LevelOfDetail) -> MateClearance:
    """Clearance of one mate in ``world`` (parts at their assembled poses)."""
    pin = product.feature(mate.pin_part, mate.pin_feature)
    hole = product.feature(mate.hole_part, mate.hole_feature)
    d_pin = geometry.sizing.diameter(pin)
    d_hole = geometry.sizing.diameter(hole)
    depth = geometry.feature_depth(hole)
    overlap = min(pin.length_m, depth)
    a, b = 0.25 * overlap, 0.75 * overlap
    T = np.eye(4)
    T[2, 3] = 0.5 * (a + b)
    T_world_pin = product.T_world_assembled(mate.pin_part) @ geometry.feature_frames(mate.pin_part)[pin.name]
    T_world_probe = T_world_pin @ T
    piece = ConvexPiece(kind="cylinder", T_part_piece=np.eye(4), radius_m=0.5 * d_pin,
                        length_m=max(b - a, 1e-6), name="probe")
    probe = CollisionModel("exact", (piece,))
    name = f"__probe__{mate.name}"
    world.add(name, probe, T_world_probe)
    try:
        d = world.distance(name, mate.hole_part)
    finally:
        world.remove(name)
    bound = _mate_bound(geometry, mate.hole_part, mate.hole_feature, level)
    return MateClearance(mate.name, pin.ref, hole.ref, mate.fit, mate.clearance_min_m, mate.clearance_max_m,
                         d_hole - d_pin, 2.0 * d, bound, overlap)


def check_assembly(product: Product, geometry: ProductGeometry, level: LevelOfDetail = "exact",
                   tolerance_m: float = 1e-6) -> AssemblyCheck:
    """Place all parts at their assembled poses and check mates and interferences.

    Parameters
    ----------
    product : Product
    geometry : ProductGeometry
        The product's shared geometry.
    level : {"exact", "convex", "coarse"}
    tolerance_m : float
        Contacts up to this depth count as touching (1 um).

    Returns
    -------
    AssemblyCheck
    """
    t0 = time.perf_counter()
    geometry.build(level)
    t1 = time.perf_counter()
    world = geometry.collision_world(level)
    t2 = time.perf_counter()
    mates = tuple(measure_mate_clearance(product, geometry, world, m, level) for m in product.mates)
    t3 = time.perf_counter()
    allowed: dict[tuple[str, str], tuple[str, float]] = {}
    for m, mc in zip(product.mates, mates, strict=True):
        if m.clearance_min_m < 0:
            first, second = sorted((m.pin_part, m.hole_part))
            allowed[(first, second)] = (m.name, -0.5 * m.clearance_min_m + mc.bound_m + tolerance_m)
    interferences, intended = [], []
    for c in world.contacts(tolerance_m=tolerance_m):
        ok = allowed.get((c.a, c.b))
        if ok is not None and c.depth_m <= ok[1]:
            intended.append(Interference(c.a, c.b, c.depth_m, c.point_m, ok[0], c.depth_m))
            continue
        # CAD's line-to-line pin and hole (mesh parts): judged against the fit, real depth
        nominal = nominal_contact(product, geometry, c.a, c.b)
        if nominal is not None:
            intended.append(Interference(c.a, c.b, nominal.depth_m, c.point_m, nominal.mate, c.depth_m))
        else:
            # report how far one part must move to clear the other (FCL's per-triangle depth
            # against a BVH is a local figure, not the overlap of the solids)
            sep, u = world.separation(c.a, c.b, tolerance_m)
            if sep <= tolerance_m:
                # face-on-face contact (a cover resting on a housing): FCL reported a
                # triangle-local depth, but no translation of more than the contact tolerance
                # is needed to part them, so they touch and do not interfere
                continue
            interferences.append(Interference(c.a, c.b, sep, c.point_m, None, c.depth_m,
                                              (float(u[0]), float(u[1]), float(u[2]))))
    t4 = time.perf_counter()
    findings: list[Finding] = []
    for name in product.part_names:
        findings += geometry.feature_findings(name)
    findings += check_mates(product, geometry.sizing, geometry.feature_depth)
    t5 = time.perf_counter()
    fits, press_findings = press_fits(product, geometry)
    findings += press_findings
    t6 = time.perf_counter()
    timings = {"geometry_s": t1 - t0, "world_s": t2 - t1, "mates_s": t3 - t2, "contacts_s": t4 - t3,
               "features_s": t5 - t4, "press_fits_s": t6 - t5}
    return AssemblyCheck(product.name, level, mates, tuple(interferences), tuple(intended), tuple(findings),
                         timings, fits)


__all__ = ["AssemblyCheck", "Interference", "MateClearance", "check_assembly", "measure_mate_clearance"]
