"""Collision models at three levels of detail, each with its measured error.

Levels
------
``exact``
    FCL primitives wherever the part is made of primitives: boxes, spheres, cylinders
    (a stepped shaft is one cylinder per section; a chamfered pin tip or shaft end is a
    frustum hull within ``exact_tolerance_m``). A part with holes is one BVH mesh of its bodies
    minus the holes (hole polygons with edges tangent to the hole circle, radial error
    <= ``exact_tolerance_m``) plus its pins as primitives. Mesh files are BVH meshes.
    Error: the analytic polygonisation bound (<= 1 um by default), not measured.
``convex``
    Exact convex pieces for physics engines: a box with holes along one of its axes comes from
    :func:`asmplan.parts.decompose.block_with_holes_pieces` (one ring of ``n`` pieces per hole
    plus a slab under a blind hole); a cylinder with coaxial holes (a tube, a wheel, a collar)
    is a ring of ``n`` convex sectors; any other holed primitive is split by the hole's planes
    (a BSP of the primitive minus each convex hole polytope). Hole mouth chamfers are kept
    (each ring piece is clipped by its face's 45 degree plane). Never a V-HACD blob.
    Pins and hole-free bodies are the exact primitives. :func:`bodies` splits the pieces into
    groups of at most 16 (PyBullet's compound limit).
``coarse``
    One convex piece: the primitive itself for a single box/sphere/cylinder, else the convex
    hull of the part. Holes are filled; for far-away obstacles only.

The hole polygons of the convex level and the piece builders are in
:mod:`asmplan.parts.primitive_pieces` (with how many sides a hole gets); how each level's
error is measured is in :mod:`asmplan.parts.lod_measure`.

The exact level is not measured: its error is the polygon bound (``exact_tolerance_m``) by
construction. Mesh-file parts: exact = BVH of the mesh; convex = :mod:`asmplan.parts.mesh_convex`
(sectors around declared holes on any axes, concave faces split, not filled); coarse = the hull.
"""

from __future__ import annotations

import numpy as np

from .geometry import (
    GeometryError,
    GeometrySettings,
    HoleShape,
    PartShape,
    manifold_to_mesh,
)
from .mesh import hull_vertex_indices
from .pieces import CollisionModel, ConvexPiece, LevelOfDetail
from .primitive_pieces import (
    HoleSides,
    _box_with_holes,
    _bsp_pieces,
    _holes_touching,
    _hull_piece,
    _tube_pieces,
    _Unsupported,
    body_pieces,
    convex_sides,
    piece_points,
    pin_pieces,
)

LEVELS: tuple[LevelOfDetail, ...] = ("exact", "convex", "coarse")


# ---------------------------------------------------------------------------------------------
# Models per level
# ---------------------------------------------------------------------------------------------
def hole_sides(shape: PartShape, radial_clearance: dict[str, float], settings: GeometrySettings
               ) -> dict[str, HoleSides]:
    """The convex-level polygon of every hole of ``shape``."""
    out = {}
    for h in shape.holes:
        c = radial_clearance.get(h.feature, 0.5 * settings.unmated_hole_clearance_m)
        outer = h.radius_m + h.chamfer_m  # the chamfer's mouth has the largest corner recess
        out[h.feature] = HoleSides(h.feature, convex_sides(outer, c, settings), outer, c)
    return out


def exact_model(shape: PartShape, settings: GeometrySettings, solid_without_pins=None,
                mesh=None) -> CollisionModel:
    """The exact level (see the module docstring).

    Parameters
    ----------
    shape : PartShape
    settings : GeometrySettings
    solid_without_pins : manifold3d.Manifold, optional
        Bodies minus holes; required when the part has holes.
    mesh : TriangleMesh, optional
        The part's mesh, for mesh-file parts.
    """
    tol = settings.exact_tolerance_m
    notes = []
    if shape.is_mesh:
        if mesh is None:
            raise GeometryError(shape.part, "exact level of a mesh part needs its mesh")
        return CollisionModel("exact", (), 0.0, 0.0, np.asarray(mesh.vertices, float),
                              np.asarray(mesh.faces, np.int64), ("BVH of the mesh file",))
    pins = [pc for p in shape.pins for pc in pin_pieces(p, tol)]
    if not shape.holes:
        pieces = [pc for i, b in enumerate(shape.bodies) for pc in body_pieces(b, f"body{i}", tol)]
        return CollisionModel("exact", tuple(pieces + pins), tol, 0.0,
                              notes=("primitives; curved hull pieces within the polygon tolerance",))
    if solid_without_pins is None:
        raise GeometryError(shape.part, "exact level of a holed part needs its solid")
    m = manifold_to_mesh(solid_without_pins)
    notes.append(f"BVH of bodies minus holes ({len(m.faces)} triangles) + pins as primitives")
    return CollisionModel("exact", tuple(pins), tol, 0.0, np.asarray(m.vertices, float),
                          np.asarray(m.faces, np.int64), tuple(notes))


def convex_pieces(shape: PartShape, sides: dict[str, HoleSides], settings: GeometrySettings,
                  mesh=None, mesh_holes: tuple[HoleShape, ...] = ()
                  ) -> tuple[tuple[ConvexPiece, ...], tuple[str, ...]]:
    """Convex pieces of the part (see the module docstring) and notes on how they were made.

    ``mesh`` and ``mesh_holes`` (its declared holes) are for mesh-file parts."""
    tol = settings.convex_arc_tolerance_m
    notes: list[str] = []
    if shape.is_mesh:
        # holes on any axes kept, concave faces split (pins, steps, slots): parts/mesh_convex.py
        from .mesh_convex import mesh_feature_pieces

        try:
            return mesh_feature_pieces(mesh, list(mesh_holes), sides)
        except ValueError as why:
            notes.append(f"mesh part: not decomposed ({why})")
        hull = mesh.convex_hull
        excess = float(hull.volume / mesh.volume - 1.0)
        notes.append("mesh part: its convex hull" + (
            "" if excess < 1e-3 else f" (NOT convex: the hull adds {excess:.1%} of the volume; "
            "holes are filled - use the exact level for the mesh)"))
        return (_hull_piece(np.asarray(hull.vertices), "hull"),), tuple(notes)
    pieces: list[ConvexPiece] = []
    for i, b in enumerate(shape.bodies):
        name = f"body{i}"
        holes = _holes_touching(b, shape.holes, settings.exact_tolerance_m) if shape.holes else []
        if not holes:
            pieces += body_pieces(b, name, tol)
            continue
        try:
            if b.kind == "box":
                pieces += _box_with_holes(b, holes, sides, name)
                notes.append(f"{name}: box with {len(holes)} hole(s) from decompose.block_with_holes_pieces")
            elif b.kind == "cylinder":
                pieces += _tube_pieces(b, holes, sides, name, settings)
                notes.append(f"{name}: tube of convex sectors")
            else:
                raise _Unsupported("sphere")
        except _Unsupported as why:
            pieces += _bsp_pieces(b, holes, sides, name, settings)
            notes.append(f"{name}: split by the hole planes ({why})")
    pieces += [pc for p in shape.pins for pc in pin_pieces(p, tol)]
    for hs in sides.values():
        notes.append(f"hole {hs.feature}: {hs.n_sides} sides for radial clearance "
                     f"{hs.radial_clearance_m * 1e6:.1f} um (play bound {hs.play_bound_m * 1e6:.2f} um "
                     f"diametral, corner recess {hs.hausdorff_m * 1e3:.3f} mm)")
    return tuple(pieces), tuple(notes)


def coarse_pieces(shape: PartShape, convex: tuple[ConvexPiece, ...], settings: GeometrySettings,
                  mesh=None) -> tuple[ConvexPiece, ...]:
    """One convex piece: the primitive for a lone box/sphere/cylinder, else the hull."""
    if not shape.is_mesh and len(shape.bodies) == 1 and not shape.holes and not shape.pins:
        b = shape.bodies[0]
        if b.kind in ("box", "sphere"):
            return tuple(body_pieces(b, "coarse", settings.exact_tolerance_m))
        R = max(s.radius_m for s in b.sections)
        return (ConvexPiece(kind="cylinder", T_part_piece=b.T_part_body, radius_m=R, length_m=b.length_m,
                            name="coarse"),)
    if shape.is_mesh:
        return (_hull_piece(np.asarray(mesh.convex_hull.vertices), "coarse"),)
    pts = np.concatenate([piece_points(pc, settings.convex_arc_tolerance_m) for pc in convex])
    return (_hull_piece(pts[hull_vertex_indices(pts)], "coarse"),)


def bodies(model: CollisionModel, max_per_body: int = 16) -> tuple[tuple[ConvexPiece, ...], ...]:
    """Pieces in consecutive groups of at most ``max_per_body`` (PyBullet keeps 16 children per
    compound shape). Pieces are ordered body by body and hole by hole, so a group is compact."""
    if max_per_body < 1:
        raise ValueError(f"max_per_body: expected >= 1, found {max_per_body}")
    p = model.pieces
    return tuple(p[i:i + max_per_body] for i in range(0, len(p), max_per_body))


__all__ = ["LEVELS", "bodies", "coarse_pieces", "convex_pieces", "exact_model", "hole_sides"]
