"""Solid geometry of a part from the product model: shapes, exact meshes, mass properties.

A part is described once as a :class:`PartShape` (bodies, holes cut, pins added, all in the
part frame, with the diameters a mate's fit gives them) and turned into an exact manifold
solid with manifold3d booleans. Every level of detail (``parts.lod``), the feature checks
(``parts.features``) and the mass properties start from that one description.

Fitted sizes
------------
The product model gives nominal diameters and, per mate, a diametral clearance range (from an
ISO 286 fit or written down). The geometry is built at the middle of each tolerance zone:
for a fit ``H7/g6`` at 8 mm the hole is ``8 + (0 + 15)/2 um`` and the pin
``8 + (-5 - 14)/2 um``, so the diametral clearance of the built pair is the middle of the
declared range and an FCL distance measured between them is comparable with the fit. Without a
fit the clearance range's middle is split evenly between hole and pin.

Circles
-------
Curved surfaces become regular polygons whose radial error is at most
``GeometrySettings.exact_tolerance_m`` (1 um by default):

* holes are cut with a polygon whose INSCRIBED circle is the hole radius (edges tangent to the
  circle), so a hole is never narrower than declared; towards the polygon's corners it is
  wider by ``r (1 / cos(pi / n) - 1)``;
* outer surfaces (cylindrical bodies, pins, spheres) use the CIRCUMSCRIBED polygon, so a body
  is never smaller than declared.

The bodies of a composite are grown by 10 nm before their union so that bodies touching
face to face fuse into one solid (exactly touching faces are not welded by the booleans).

A cylinder body that carries coaxial male features of its own diameter (a shaft with bearing
seats, a post with a foot and a head) is built as a stack of sections, each at the fitted
diameter of the feature covering it (nominal elsewhere); a feature tip on an end face
chamfers that end. Pin tips and hole mouths get their declared 45 degree chamfers.

Frames follow ``T_a_b`` (maps b-coordinates to a); lengths are metres, masses kilograms.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..errors import AsmplanError
from ..knowledge import iso286
from ..knowledge.frames import frame_from_axis, invert, transform_points
from ..knowledge.model import Feature, Part, Product
from .mesh import TriangleMesh

FeatureKey = tuple[str, str]  # (part name, feature name)


class GeometryError(AsmplanError, ValueError):
    """A part's geometry cannot be built as described; ``part`` names it."""

    def __init__(self, part: str, message: str):
        self.part = part
        super().__init__(f'part "{part}": {message}')


@dataclass(frozen=True)
class GeometrySettings:
    """Every knob of geometry, levels of detail and their measurement, in one object.

    Parameters
    ----------
    exact_tolerance_m : float
        Largest radial error of a polygonised circle in the exact level (1 um).
    max_triangles : int
        Mesh files with more triangles are simplified (when they are manifold) or rejected.
    hard_max_triangles : int
        Mesh files with more triangles than this are rejected before they are read.
    max_mesh_file_bytes : int
        Files larger than this are rejected before they are read.
    convex_play_fraction, convex_play_floor_m : float
        Convex level: a hole's polygon may add at most
        ``max(convex_play_fraction * c, convex_play_floor_m)`` of lateral play to a pin with
        radial clearance ``c`` (the play towards a polygon corner is ``c / cos(pi / n)``).
    convex_max_hausdorff_m : float
        Convex level: largest corner recess ``r (1 / cos(pi / n) - 1)`` of a hole polygon.
    convex_sides : tuple of int
        Side counts the convex level may choose per hole (smallest that meets both bounds).
    convex_arc_tolerance_m : float
        Radial error of convex curved pieces (tube outer arcs, chamfer frustums) in the convex
        level.
    unmated_hole_clearance_m : float
        Diametral clearance assumed for a hole no mate names (to choose its sides and to
        measure its effective clearance).
    max_pieces_per_body : int
        PyBullet keeps at most 16 children per compound shape; :func:`parts.lod.bodies`
        groups pieces accordingly.
    hausdorff_samples : int
        Random surface samples per surface, on top of all vertices, when measuring the
        Hausdorff distance.
    clearance_directions : int
        Lateral directions in which a probe pin is pushed to measure a hole's effective
        clearance (refined around the worst one).
    seed : int
        Seed of every random sample.
    """

    exact_tolerance_m: float = 1e-6
    max_triangles: int = 200_000
    hard_max_triangles: int = 5_000_000
    max_mesh_file_bytes: int = 300_000_000
    convex_play_fraction: float = 0.05
    convex_play_floor_m: float = 1e-6
    convex_max_hausdorff_m: float = 0.5e-3
    convex_sides: tuple[int, ...] = (8, 12, 16, 24, 32, 48)
    convex_arc_tolerance_m: float = 10e-6
    unmated_hole_clearance_m: float = 0.1e-3
    max_pieces_per_body: int = 16
    hausdorff_samples: int = 400
    clearance_directions: int = 36
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("exact_tolerance_m", "convex_play_floor_m", "convex_max_hausdorff_m",
                     "convex_arc_tolerance_m", "unmated_hole_clearance_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"GeometrySettings.{name}: expected a positive length, found {v!r}")
        if not 0 < self.convex_play_fraction < 1:
            raise ValueError("GeometrySettings.convex_play_fraction: expected 0 < f < 1, found "
                             f"{self.convex_play_fraction!r}")
        if not self.convex_sides or any(int(n) != n or n < 3 for n in self.convex_sides):
            raise ValueError("GeometrySettings.convex_sides: expected integers >= 3, found "
                             f"{self.convex_sides!r}")
        for name in ("max_triangles", "hard_max_triangles", "max_mesh_file_bytes",
                     "max_pieces_per_body", "clearance_directions"):
            if getattr(self, name) < 1:
                raise ValueError(f"GeometrySettings.{name}: expected >= 1, found {getattr(self, name)!r}")
        if self.hausdorff_samples < 0:
            raise ValueError(f"GeometrySettings.hausdorff_samples: expected >= 0, found "
                             f"{self.hausdorff_samples!r}")


def sides_for_tolerance(radius_m: float, tolerance_m: float, *, minimum: int = 8,
                        maximum: int = 2048) -> int:
    """Smallest multiple of 4 (>= ``minimum``) whose polygon deviates from the circle of
    ``radius_m`` by at most ``tolerance_m``: ``r (1 / cos(pi / n) - 1) <= tol``."""
    n = max(4 * math.ceil(minimum / 4), 4)
    while n < maximum and radius_m * (1.0 / math.cos(math.pi / n) - 1.0) > tolerance_m:
        n += 4
    return n


def polygon_excess(radius_m: float, n_sides: int) -> float:
    """Corner excess ``r (1 / cos(pi / n) - 1)`` of a regular n-gon with inscribed radius r."""
    return radius_m * (1.0 / math.cos(math.pi / n_sides) - 1.0)


# ---------------------------------------------------------------------------------------------
# Fitted sizes
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FeatureSizing:
    """Fitted diameters of mated features (see the module docstring).

    Parameters
    ----------
    diameters_m : mapping (part, feature) -> float
        Diameter to build, metres. Features no mate names keep their nominal diameter.
    radial_clearance_m : mapping (part, feature) -> float
        For each mated hole, the radial clearance of its pin as built, metres.
    notes : tuple of str
        Features named by several mates that ask for different sizes (the first mate wins).
    """

    diameters_m: Mapping[FeatureKey, float]
    radial_clearance_m: Mapping[FeatureKey, float]
    notes: tuple[str, ...] = ()

    def diameter(self, feature: Feature) -> float:
        return float(self.diameters_m.get((feature.part, feature.name), feature.diameter_m))


def fitted_sizes(product: Product) -> FeatureSizing:
    """Diameters at the middle of each mate's tolerance zones (see the module docstring)."""
    diam: dict[FeatureKey, float] = {}
    radial: dict[FeatureKey, float] = {}
    notes: list[str] = []
    for mate in product.mates:
        pin = product.feature(mate.pin_part, mate.pin_feature)
        hole = product.feature(mate.hole_part, mate.hole_feature)
        if mate.fit:
            f = iso286.fit(mate.fit, hole.diameter_m)
            D = hole.diameter_m + 0.5 * (f.hole.lower_m + f.hole.upper_m)
            d = pin.diameter_m + 0.5 * (f.shaft.lower_m + f.shaft.upper_m)
        else:
            extra = mate.clearance_mean_m - (hole.diameter_m - pin.diameter_m)
            D = hole.diameter_m + 0.5 * extra
            d = pin.diameter_m - 0.5 * extra
        # one side already sized by an earlier mate (a bore fitted H7 for a bearing that also
        # takes a loose spacer): the other side takes this mate's whole clearance
        hole_key, pin_key = (hole.part, hole.name), (pin.part, pin.name)
        if hole_key in diam and pin_key not in diam:
            D, d = diam[hole_key], diam[hole_key] - (D - d)
        elif pin_key in diam and hole_key not in diam:
            D, d = diam[pin_key] + (D - d), diam[pin_key]
        for key, value in (((pin.part, pin.name), d), ((hole.part, hole.name), D)):
            if key in diam and abs(diam[key] - value) > 1e-9:
                notes.append(f"{key[0]}.{key[1]}: mate {mate.name} asks for {value * 1e3:.4f} mm, "
                             f"an earlier mate for {diam[key] * 1e3:.4f} mm; kept the earlier")
                continue
            diam[key] = value
        radial.setdefault((hole.part, hole.name), 0.5 * (diam[(hole.part, hole.name)]
                                                         - diam[(pin.part, pin.name)]))
    return FeatureSizing(diam, radial, tuple(notes))


# ---------------------------------------------------------------------------------------------
# Shape description
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CylinderSection:
    """An axial section ``z0_m <= z <= z1_m`` of a cylinder body, of radius ``radius_m``."""

    z0_m: float
    z1_m: float
    radius_m: float


@dataclass(frozen=True, eq=False)
class BodyShape:
    """One primitive of a part, in the part frame.

    ``kind`` box: ``half_extents_m`` (3,). cylinder: ``sections`` along the body's z axis
    (covering ``-length_m/2 .. +length_m/2``) and 45 degree chamfers ``chamfer_low_m`` /
    ``chamfer_high_m`` on the end faces. sphere: ``radius_m``.
    """

    kind: Literal["box", "cylinder", "sphere"]
    T_part_body: np.ndarray
    half_extents_m: np.ndarray | None = None
    radius_m: float = 0.0
    length_m: float = 0.0
    sections: tuple[CylinderSection, ...] = ()
    chamfer_low_m: float = 0.0
    chamfer_high_m: float = 0.0


@dataclass(frozen=True, eq=False)
class HoleShape:
    """A hole cut into the bodies: frame z = outward axis, origin = mouth centre.

    ``depth_m`` is the declared depth (blind) or the cut length through the whole part
    (through); ``radius_m`` is the fitted radius.
    """

    feature: str
    T_part_hole: np.ndarray
    radius_m: float
    depth_m: float
    through: bool
    chamfer_m: float


@dataclass(frozen=True, eq=False)
class PinShape:
    """A pin added to the bodies: frame z = root-to-tip axis, origin = root centre."""

    feature: str
    T_part_pin: np.ndarray
    radius_m: float
    length_m: float
    chamfer_m: float


@dataclass(frozen=True, eq=False)
class PartShape:
    """A part's solid as bodies minus holes plus pins (``mesh_file`` parts have no bodies)."""

    part: str
    bodies: tuple[BodyShape, ...]
    holes: tuple[HoleShape, ...]
    pins: tuple[PinShape, ...]
    is_mesh: bool = False
    notes: tuple[str, ...] = field(default_factory=tuple)


def _body_male_features(part: Part) -> list[Feature]:
    pin_names = {p.feature for p in part.geometry.pins}
    return [f for f in part.features if f.is_male and f.name not in pin_names]


def _cylinder_sections(part: Part, T_part_body: np.ndarray, radius: float, length: float,
                       sizing: FeatureSizing) -> tuple[tuple[CylinderSection, ...], float, float]:
    """Sections and end chamfers of a cylinder body from coaxial male features on it."""
    T_body_part = invert(T_part_body)
    half = 0.5 * length
    spans: list[tuple[float, float, float]] = []
    ch_lo = ch_hi = 0.0
    for f in _body_male_features(part):
        axis_b = T_body_part[:3, :3] @ f.axis
        origin_b = transform_points(T_body_part, f.origin_m[None])[0]
        if abs(abs(axis_b[2]) - 1.0) > 1e-9 or np.hypot(origin_b[0], origin_b[1]) > 1e-9:
            continue
        if abs(f.diameter_m - 2 * radius) > 1e-9:
            continue
        z_tip = origin_b[2] + axis_b[2] * f.length_m
        z0, z1 = sorted((origin_b[2], z_tip))
        z0, z1 = max(z0, -half), min(z1, half)
        if z1 - z0 <= 1e-12:
            continue
        spans.append((z0, z1, 0.5 * sizing.diameter(f)))
        if abs(z_tip - half) < 1e-9:
            ch_hi = max(ch_hi, f.chamfer_m)
        elif abs(z_tip + half) < 1e-9:
            ch_lo = max(ch_lo, f.chamfer_m)
    cuts = sorted({-half, half, *(z for s in spans for z in s[:2])})
    sections: list[CylinderSection] = []
    for a, b in itertools.pairwise(cuts):
        if b - a <= 1e-12:
            continue
        mid = 0.5 * (a + b)
        covering = [s[2] for s in spans if s[0] - 1e-12 <= mid <= s[1] + 1e-12]
        r = min(covering) if covering else radius
        if sections and abs(sections[-1].radius_m - r) < 1e-15:
            sections[-1] = CylinderSection(sections[-1].z0_m, b, r)
        else:
            sections.append(CylinderSection(a, b, r))
    return tuple(sections), ch_lo, ch_hi


def part_shape(part: Part, sizing: FeatureSizing | None = None) -> PartShape:
    """Describe a part's solid in its frame, with fitted diameters.

    Parameters
    ----------
    part : Part
    sizing : FeatureSizing, optional
        Fitted diameters (default: nominal everywhere).

    Returns
    -------
    PartShape
    """
    sizing = sizing or FeatureSizing({}, {})
    g = part.geometry
    if g.kind == "mesh":
        return PartShape(part.name, (), (), (), is_mesh=True)
    bodies: list[BodyShape] = []
    for prim in g.primitives:
        T = np.array(prim.T_part_shape, dtype=float)
        if prim.shape == "box":
            bodies.append(BodyShape("box", T, half_extents_m=0.5 * np.asarray(prim.size_m, float)))
        elif prim.shape == "cylinder":
            r, L = 0.5 * prim.diameter_m, prim.length_m
            sections, lo, hi = _cylinder_sections(part, T, r, L, sizing)
            bodies.append(BodyShape("cylinder", T, radius_m=r, length_m=L, sections=sections,
                                    chamfer_low_m=lo, chamfer_high_m=hi))
        else:
            bodies.append(BodyShape("sphere", T, radius_m=0.5 * prim.diameter_m))
    corners = _body_points(bodies)
    holes: list[HoleShape] = []
    for h in g.holes:
        T = frame_from_axis(h.origin_m, h.axis)
        feat = part.feature(h.feature)
        if h.through:
            reach = float(np.max((h.origin_m - corners) @ h.axis)) if len(corners) else 0.0
            depth = max(reach, 0.0) + 1e-3
        else:
            depth = h.depth_m
        holes.append(HoleShape(h.feature, T, 0.5 * sizing.diameter(feat), depth, h.through, h.chamfer_m))
    pins = tuple(PinShape(p.feature, frame_from_axis(p.origin_m, p.axis),
                          0.5 * sizing.diameter(part.feature(p.feature)), p.length_m, p.chamfer_m)
                 for p in g.pins)
    return PartShape(part.name, tuple(bodies), tuple(holes), pins)


def _body_points(bodies: tuple[BodyShape, ...] | list[BodyShape]) -> np.ndarray:
    """Corner points (n, 3) of the bodies' bounding boxes, part frame."""
    pts = []
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    for b in bodies:
        if b.kind == "box":
            he = b.half_extents_m
        elif b.kind == "cylinder":
            r = max([s.radius_m for s in b.sections] + [b.radius_m])
            he = np.array([r, r, 0.5 * b.length_m])
        else:
            he = np.full(3, b.radius_m)
        pts.append(transform_points(b.T_part_body, signs * he))
    return np.concatenate(pts) if pts else np.zeros((0, 3))


# ---------------------------------------------------------------------------------------------
# Manifold solids
# ---------------------------------------------------------------------------------------------
def _m3():
    import manifold3d

    return manifold3d


def _placed(solid, T: np.ndarray):
    return solid.transform(np.ascontiguousarray(T[:3, :4], dtype=float))


def prism(radius_in_m: float, z0_m: float, z1_m: float, n_sides: int, *, radius_top_in_m: float | None = None,
          face_on_x: bool = True):
    """A regular n-gon prism (or frustum) along z from ``z0_m`` to ``z1_m`` whose INSCRIBED
    radius is ``radius_in_m`` (at ``z0_m``) and ``radius_top_in_m`` (at ``z1_m``).

    ``face_on_x`` turns it so that one face normal points along +x (as in
    ``parts.decompose``); otherwise a vertex is on +x.
    """
    m3 = _m3()
    sec = 1.0 / math.cos(math.pi / n_sides)
    top = radius_in_m if radius_top_in_m is None else radius_top_in_m
    solid = m3.Manifold.cylinder(z1_m - z0_m, radius_in_m * sec, top * sec, n_sides, False)
    if face_on_x:
        solid = solid.rotate([0.0, 0.0, 180.0 / n_sides])
    return solid.translate([0.0, 0.0, z0_m])


def revolved(profile_rz: list[tuple[float, float]], n_sides: int):
    """Solid of revolution about z of a closed profile [(radius, z), ...] (counter-clockwise in
    the (r, z) half-plane), as an n-gon CIRCUMSCRIBING each profile circle."""
    m3 = _m3()
    sec = 1.0 / math.cos(math.pi / n_sides)
    section = m3.CrossSection([[(r * sec, z) for r, z in profile_rz]])
    return m3.Manifold.revolve(section, n_sides)


def _cylinder_profile(sections: tuple[CylinderSection, ...], ch_lo: float, ch_hi: float
                      ) -> list[tuple[float, float]]:
    """(radius, z) profile of a stepped cylinder with end chamfers, counter-clockwise."""
    z_lo, z_hi = sections[0].z0_m, sections[-1].z1_m
    first, last = sections[0].radius_m, sections[-1].radius_m
    pts: list[tuple[float, float]] = [(0.0, z_lo)]
    if ch_lo > 0:
        pts += [(first - ch_lo, z_lo), (first, z_lo + ch_lo)]
    else:
        pts.append((first, z_lo))
    for a, b in itertools.pairwise(sections):
        pts += [(a.radius_m, a.z1_m), (b.radius_m, b.z0_m)]
    if ch_hi > 0:
        pts += [(last, z_hi - ch_hi), (last - ch_hi, z_hi)]
    else:
        pts.append((last, z_hi))
    pts.append((0.0, z_hi))
    out: list[tuple[float, float]] = []
    for p in pts:  # drop repeated points (equal radii at a section boundary)
        if not out or abs(out[-1][0] - p[0]) > 1e-15 or abs(out[-1][1] - p[1]) > 1e-15:
            out.append(p)
    return out


WELD_M = 10e-9  # bodies of a composite grow by this much so that touching bodies fuse


def body_solid(body: BodyShape, tol_m: float, grow_m: float = 0.0):
    """Manifold of one body in the part frame, grown outwards by ``grow_m``."""
    m3 = _m3()
    if body.kind == "box":
        solid = m3.Manifold.cube(list(2.0 * np.asarray(body.half_extents_m) + 2.0 * grow_m), True)
    elif body.kind == "cylinder":
        n = sides_for_tolerance(max(s.radius_m for s in body.sections), tol_m)
        solid = revolved(_cylinder_profile(body.sections, body.chamfer_low_m, body.chamfer_high_m), n)
        if grow_m > 0:
            solid = solid.scale([1.0 + grow_m / body.radius_m, 1.0 + grow_m / body.radius_m,
                                 1.0 + 2.0 * grow_m / body.length_m])
    else:
        n = sides_for_tolerance(body.radius_m, tol_m)
        solid = m3.Manifold.sphere((body.radius_m + grow_m) / math.cos(math.pi / n) ** 2, n)
    return _placed(solid, body.T_part_body)


def hole_solid(hole: HoleShape, tol_m: float, n_sides: int | None = None, outward_m: float = 1e-3):
    """The material a hole removes, part frame: inscribed-radius prism plus mouth chamfer,
    extended ``outward_m`` beyond the mouth for a clean cut."""
    m3 = _m3()
    n = n_sides or sides_for_tolerance(hole.radius_m + hole.chamfer_m + outward_m, tol_m)
    parts = [prism(hole.radius_m, -hole.depth_m, outward_m, n)]
    if hole.chamfer_m > 0:
        c = hole.chamfer_m
        parts.append(prism(hole.radius_m, -c, outward_m, n, radius_top_in_m=hole.radius_m + c + outward_m))
    return _placed(m3.Manifold.batch_boolean(parts, m3.OpType.Add), hole.T_part_hole)


def pin_solid(pin: PinShape, tol_m: float):
    """A pin with its tip chamfer, part frame (circumscribed polygons)."""
    n = sides_for_tolerance(pin.radius_m, tol_m)
    c = min(pin.chamfer_m, 0.5 * pin.length_m)
    r, L = pin.radius_m, pin.length_m
    profile = [(0.0, 0.0), (r, 0.0), (r, L - c), (r - c, L), (0.0, L)] if c > 0 else \
        [(0.0, 0.0), (r, 0.0), (r, L), (0.0, L)]
    return _placed(revolved(profile, n), pin.T_part_pin)


def shape_solid(shape: PartShape, tol_m: float, *, with_pins: bool = True):
    """The part's exact manifold solid: (union of bodies - holes) + pins, part frame."""
    m3 = _m3()
    if shape.is_mesh:
        raise GeometryError(shape.part, "a mesh part has no primitive shape; load its file")
    # bodies that touch face to face only fuse when they overlap: grow them by 10 nm
    grow = WELD_M if len(shape.bodies) > 1 else 0.0
    solid = m3.Manifold.batch_boolean([body_solid(b, tol_m, grow) for b in shape.bodies], m3.OpType.Add)
    if shape.holes:
        solid = m3.Manifold.batch_boolean([solid, *(hole_solid(h, tol_m) for h in shape.holes)],
                                          m3.OpType.Subtract)
    if with_pins and shape.pins:
        solid = m3.Manifold.batch_boolean([solid, *(pin_solid(p, tol_m) for p in shape.pins)],
                                          m3.OpType.Add)
    if solid.is_empty() or solid.volume() <= 0:
        raise GeometryError(shape.part, "the solid is empty after cutting its holes")
    return solid


def manifold_to_mesh(solid) -> TriangleMesh:
    """The :class:`~asmplan.parts.mesh.TriangleMesh` (float64) of a manifold3d solid."""
    return TriangleMesh.from_manifold(solid)


def manifold_to_trimesh(solid):
    """A ``trimesh.Trimesh`` (float64) of a manifold3d solid (imports trimesh; the run path
    uses :func:`manifold_to_mesh`)."""
    return TriangleMesh.from_manifold(solid).to_trimesh()


def trimesh_to_manifold(mesh):
    """A manifold3d solid of a watertight mesh (a TriangleMesh or a trimesh); raises
    ValueError when it is not manifold."""
    m3 = _m3()
    # copies: manifold3d refuses read-only arrays (TriangleMesh's are)
    solid = m3.Manifold(m3.Mesh64(vert_properties=np.array(mesh.vertices, dtype=float),
                                  tri_verts=np.array(mesh.faces, dtype=np.uint64)))
    if solid.status() != m3.Error.NoError:
        raise ValueError(f"not an oriented 2-manifold ({solid.status().name})")
    return solid


# mass properties live in parts/mass.py, re-exported here
from .mass import MassProperties, mass_properties  # noqa: E402

__all__ = [
    "BodyShape",
    "CylinderSection",
    "FeatureSizing",
    "GeometryError",
    "GeometrySettings",
    "HoleShape",
    "MassProperties",
    "PartShape",
    "PinShape",
    "body_solid",
    "fitted_sizes",
    "hole_solid",
    "manifold_to_mesh",
    "manifold_to_trimesh",
    "mass_properties",
    "part_shape",
    "pin_solid",
    "polygon_excess",
    "prism",
    "shape_solid",
    "sides_for_tolerance",
    "trimesh_to_manifold",
]
