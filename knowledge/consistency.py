"""Contradictions between the values of a product that each look valid alone.

:func:`find_inconsistencies` runs when a product is read (``asmplan validate`` reports
them, ``run``, ``plan`` and every other command refuse the product before any work). It
answers analytically, from the primitives, what ``asmplan check`` later measures on the built
solids (:mod:`asmplan.parts.features`), so that a product ``check`` would fail never reaches
the planner:

* every mate at the assembled pose: pin axis antiparallel to the hole axis within
  :data:`AXIS_TOLERANCE_RAD`, pin root on the hole axis within :data:`COAXIAL_TOLERANCE_M`,
  a pin no longer than its blind hole is deep (after its root's axial offset);
* no two mates with the same pin and hole; no feature that two mates want at different
  built sizes; a fit or clearance that leaves the pin (and hole) at least half its nominal
  diameter (an ISO 286 deviation larger than the feature makes a negative radius);
* on parts made of primitives (meshes are left to ``check``): a hole's mouth on the part's
  surface, a wall around the hole (at least :data:`MIN_WALL_FRACTION` of a ring just
  outside its radius over its depth is material: a hole outside its part, or a part
  narrower than its hole, has none), no material inside a declared hole the geometry does
  not cut, a pin's root on the part's body, and a stand-alone pin or shaft that is material
  over its length.

Distances to the primitives are exact signed distances (box, cylinder, sphere; their union
is the minimum). Messages say what was expected and what was found; the loader points them
at the feature or mate in the file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import iso286
from .model import Feature, Part, Primitive, Product

AXIS_TOLERANCE_RAD = math.radians(0.1)
COAXIAL_TOLERANCE_M = 10e-6
SURFACE_TOLERANCE_M = 10e-6
MIN_WALL_FRACTION = 0.5
_RING_ANGLES = 24
_RING_LEVELS = 6


@dataclass(frozen=True)
class Inconsistency:
    """One contradiction, about a feature ``("feature", part, name)`` or a mate
    ``("mate", name)``; ``key`` names the entry to point at (``"at"``, ``"fit"``...)."""

    subject: tuple[str, ...]
    key: str | None
    message: str


def _mm(v: float) -> str:
    return f"{v * 1e3:.4g} mm"


def signed_distance(primitives: tuple[Primitive, ...], points_m: np.ndarray) -> np.ndarray:
    """Signed distance (m, negative inside) of points (n, 3) in the part frame to the union
    of ``primitives``."""
    d = np.full(len(points_m), np.inf)
    for prim in primitives:
        T = prim.T_part_shape
        Q = (points_m - T[:3, 3]) @ T[:3, :3]
        if prim.shape == "sphere":
            sd = np.linalg.norm(Q, axis=1) - 0.5 * prim.diameter_m
        else:
            if prim.shape == "box":
                q = np.abs(Q) - 0.5 * np.asarray(prim.size_m)
            else:
                q = np.stack([np.hypot(Q[:, 0], Q[:, 1]) - 0.5 * prim.diameter_m,
                              np.abs(Q[:, 2]) - 0.5 * prim.length_m], axis=1)
            sd = np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)
        d = np.minimum(d, sd)
    return d


def _basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x, y, z = (float(c) for c in axis)
    u = np.array([0.0, z, -y]) if abs(x) < 0.9 else np.array([-z, 0.0, x])  # axis x (1,0,0) or (0,1,0)
    u /= math.sqrt(float(u @ u))
    return u, np.array([y * u[2] - z * u[1], z * u[0] - x * u[2], x * u[1] - y * u[0]])


def _ring(f: Feature, radius_m: float, depths_m: np.ndarray) -> np.ndarray:
    """Points (levels, angles, 3) on a circle of ``radius_m`` about the feature axis at each
    depth below the origin (along -axis)."""
    u, v = _basis(f.axis)
    t = np.linspace(0.0, 2 * math.pi, _RING_ANGLES, endpoint=False)
    circle = radius_m * (np.cos(t)[:, None] * u + np.sin(t)[:, None] * v)
    return f.origin_m + circle[None, :, :] - depths_m[:, None, None] * f.axis


def _extent(primitives: tuple[Primitive, ...]) -> float:
    out = 0.0
    for p in primitives:
        span = np.linalg.norm(p.size_m) if p.shape == "box" else math.hypot(p.diameter_m, p.length_m)
        half = 0.5 * float(span)
        out = max(out, float(np.linalg.norm(p.T_part_shape[:3, 3])) + half)
    return out


def _probe_points(f: Feature, prims: tuple[Primitive, ...], cut: bool, added: bool
                  ) -> dict[str, np.ndarray]:
    """The points (n, 3) in the part frame at which :func:`part_inconsistencies` judges one
    feature, by role: ``origin``, ``body`` (a stand-alone pin), ``core`` and ``wall`` (a hole,
    ``wall`` shaped (levels, angles, 3))."""
    r = 0.5 * f.diameter_m
    out = {"origin": f.origin_m[None]}
    if f.is_male:
        if not added:
            s = np.linspace(0.0, max(f.length_m - f.chamfer_m, 0.0), 8)
            out["body"] = np.concatenate([f.origin_m + s[:, None] * f.axis,
                                          _ring(f, 0.9 * r, -s).reshape(-1, 3)])
        return out
    depth = f.length_m if not f.through else 2.0 * _extent(prims)
    depths = np.linspace(f.chamfer_m + 0.05 * min(depth, 2 * r), 0.95 * depth, _RING_LEVELS)
    if not cut:
        out["core"] = f.origin_m - np.outer(depths[:-1] if f.through else depths, f.axis)
    out["wall"] = _ring(f, 1.06 * r, depths)
    return out


# Complexity above C (radon): one check per feature kind (pin on a body, stand-alone pin,
# hole origin, core, through, wall), each a branch with its own message.
def part_inconsistencies(part: Part) -> list[Inconsistency]:
    """Features against the primitives of one part (none for a mesh part)."""
    g = part.geometry
    if g.kind == "mesh" or not g.primitives:
        return []
    prims = g.primitives
    cut = {h.feature for h in g.holes}
    added = {p.feature for p in g.pins}
    probes = [_probe_points(f, prims, f.name in cut, f.name in added) for f in part.features]
    # one signed-distance evaluation for every point of every feature of the part
    flat = [(k, v.reshape(-1, 3)) for pr in probes for k, v in pr.items()]
    if not flat:
        return []
    d_all = signed_distance(prims, np.concatenate([v for _, v in flat]))
    distances: list[dict[str, np.ndarray]] = []
    i = 0
    for pr in probes:
        distances.append({})
        for k, v in pr.items():
            n = v.size // 3
            distances[-1][k] = d_all[i:i + n].reshape(v.shape[:-1])
            i += n
    out: list[Inconsistency] = []
    for f, d in zip(part.features, distances, strict=True):
        subject = ("feature", part.name, f.name)
        origin = float(d["origin"][0])
        if f.is_male:
            if f.name in added:
                if origin > SURFACE_TOLERANCE_M:
                    out.append(Inconsistency(subject, "at", f"expected the root of pin {f.ref} on the "
                                             f"body of part {part.name}, found it {_mm(origin)} away "
                                             "from it"))
            elif d["body"].max() > SURFACE_TOLERANCE_M:  # a stand-alone pin or shaft: material
                out.append(Inconsistency(subject, "at", f"expected {f.kind} {f.ref} to be material of "
                                         f"part {part.name} over its {_mm(f.length_m)} length, found "
                                         f"points of it up to {_mm(float(d['body'].max()))} outside "
                                         "the part"))
            continue
        if abs(origin) > SURFACE_TOLERANCE_M + f.chamfer_m:
            where = "outside" if origin > 0 else "inside"
            out.append(Inconsistency(subject, "at", f"expected the mouth of {f.kind} {f.ref} on the "
                                     f"surface of part {part.name}, found it {_mm(abs(origin))} {where} "
                                     "the part"))
            continue
        if "core" in d and d["core"].min() < -SURFACE_TOLERANCE_M:
            out.append(Inconsistency(subject, None, f"expected no material inside {f.kind} {f.ref} "
                                     f"(part {part.name} has no hole cut there), found material "
                                     f"up to {_mm(float(-d['core'].min()))} deep along its axis"))
            continue
        wall = d["wall"] <= 0
        if f.through:
            wall = wall[wall.any(axis=1)]
        fraction = float(wall.mean()) if wall.size else 0.0
        if fraction < MIN_WALL_FRACTION:
            out.append(Inconsistency(subject, "diameter", f"expected part {part.name} to surround "
                                     f"{f.kind} {f.ref} ({_mm(f.diameter_m)}) with a wall, found material "
                                     f"in {fraction:.0%} of a ring just outside it (the part is narrower "
                                     "than the hole, or the hole lies outside it)"))
    return out


def _built_diameters(pin: Feature, hole: Feature, mate) -> tuple[float, float]:
    """Built (mid-tolerance) pin and hole diameters of a mate, metres."""
    if mate.fit:
        f = iso286.fit(mate.fit, hole.diameter_m)
        return (pin.diameter_m + 0.5 * (f.shaft.lower_m + f.shaft.upper_m),
                hole.diameter_m + 0.5 * (f.hole.lower_m + f.hole.upper_m))
    extra = mate.clearance_mean_m - (hole.diameter_m - pin.diameter_m)
    return pin.diameter_m - 0.5 * extra, hole.diameter_m + 0.5 * extra


# Complexity above C (radon): one check per mate property (one mate per pin and hole, sizes
# already built, diameters, axis, coaxiality, reach), each with its own message.
def mate_inconsistencies(product: Product) -> list[Inconsistency]:
    """Mates at the assembled pose and against each other (see the module docstring)."""
    out: list[Inconsistency] = []
    parts = {p.name: p for p in product.parts}  # Product.part() is a linear search
    pairs: dict[tuple[str, str], str] = {}
    built: dict[tuple[str, str], tuple[float, str]] = {}
    for mate in product.mates:
        subject = ("mate", mate.name)
        pin = parts[mate.pin_part].feature(mate.pin_feature)
        hole = parts[mate.hole_part].feature(mate.hole_feature)
        pair = (pin.ref, hole.ref)
        if pair in pairs:
            out.append(Inconsistency(subject, None, f"expected one mate per pin and hole, found "
                                     f"{pin.ref} in {hole.ref} already in mate {pairs[pair]}"))
            continue
        pairs[pair] = mate.name
        d_pin, d_hole = _built_diameters(pin, hole, mate)
        # one side already built by an earlier mate (a bore fitted H7 for a bearing that also
        # takes a loose spacer): the other side takes this mate's whole clearance, as
        # parts.geometry.fitted_sizes builds it
        hk, pk = (hole.part, hole.name), (pin.part, pin.name)
        if hk in built and pk not in built:
            d_hole, d_pin = built[hk][0], built[hk][0] - (d_hole - d_pin)
        elif pk in built and hk not in built:
            d_pin, d_hole = built[pk][0], built[pk][0] + (d_hole - d_pin)
        key = "fit" if mate.fit else ("interference" if mate.clearance_max_m < 0 and
                                      mate.clearance_min_m == mate.clearance_max_m else "clearance")
        bad = [(f, d) for f, d in ((pin, d_pin), (hole, d_hole)) if d < 0.5 * f.diameter_m]
        if bad:
            f, d = bad[0]
            out.append(Inconsistency(subject, key, f"expected the {key} to leave {f.kind} {f.ref} at "
                                     f"least half its nominal {_mm(f.diameter_m)}, found it built at "
                                     f"{_mm(d)} (the deviation is as large as the feature)"))
            continue
        for f, d in ((pin, d_pin), (hole, d_hole)):
            first = built.get((f.part, f.name))
            if first is None:
                built[(f.part, f.name)] = (d, mate.name)
            elif abs(first[0] - d) > 1e-9:
                out.append(Inconsistency(subject, key, f"expected {f.ref} built at one size, found mate "
                                         f"{first[1]} asking for {_mm(first[0])} and this one for "
                                         f"{_mm(d)}"))
        T_wp = product.T_world_product @ parts[mate.pin_part].T_product_part
        T_wh = product.T_world_product @ parts[mate.hole_part].T_product_part
        a_p = T_wp[:3, :3] @ pin.axis
        a_h = T_wh[:3, :3] @ hole.axis
        root = T_wp[:3, :3] @ pin.origin_m + T_wp[:3, 3]
        mouth = T_wh[:3, :3] @ hole.origin_m + T_wh[:3, 3]
        angle = float(np.arccos(np.clip(-float(a_p @ a_h), -1.0, 1.0)))
        v = root - mouth
        axial = float(v @ a_h)
        radial = float(np.linalg.norm(v - axial * a_h))
        if angle > AXIS_TOLERANCE_RAD:
            out.append(Inconsistency(subject, None, f"expected pin {pin.ref} antiparallel to hole "
                                     f"{hole.ref} at the assembled poses (within 0.1 deg), found "
                                     f"{math.degrees(angle):.3g} deg apart"))
        if radial > COAXIAL_TOLERANCE_M:
            out.append(Inconsistency(subject, None, f"expected the root of pin {pin.ref} on the axis of "
                                     f"hole {hole.ref} at the assembled poses (within 0.01 mm), found "
                                     f"it {_mm(radial)} off the axis"))
        reach = pin.length_m - axial
        if not hole.through and angle <= AXIS_TOLERANCE_RAD and reach > hole.length_m + 1e-6:
            out.append(Inconsistency(subject, None, f"expected pin {pin.ref} ({_mm(pin.length_m)} "
                                     f"engaged) to fit hole {hole.ref} ({_mm(hole.length_m)} deep), "
                                     f"found it {_mm(reach - hole.length_m)} too long: it bottoms out"))
    return out


def find_inconsistencies(product: Product) -> list[Inconsistency]:
    """Every contradiction in ``product`` (parts first, then mates)."""
    out: list[Inconsistency] = []
    for part in product.parts:
        out += part_inconsistencies(part)
    return out + mate_inconsistencies(product)


__all__ = ["Inconsistency", "find_inconsistencies", "mate_inconsistencies", "part_inconsistencies",
           "signed_distance"]
