"""Part geometry, feature frames, collision models at levels of detail, and the assembly check.

Start from :class:`ProductGeometry` (one cache per product, shared by the planner and the
simulator)::

    geometry = ProductGeometry(product)
    model = geometry.collision_model("peg", "convex")      # pieces + measured error
    world = geometry.collision_world("exact")             # FCL, parts at assembled poses
    result = check_assembly(product, geometry)             # clearances and interferences

Modules: ``geometry`` (shapes, fitted sizes, exact solids, mass properties), ``meshfile``
(mesh files), ``features`` (frames, depths, checks), ``lod`` (the levels of detail),
``primitive_pieces`` (convex pieces of bodies, pins and holed primitives), ``lod_measure``
(each level's measured error), ``decompose`` (exact convex pieces of holed blocks),
``collision`` (the only FCL user), ``check`` (assembly check), ``models`` (the cache),
``pieces`` (the piece contract shared with PyBullet). See ``docs/geometry.md``.
"""

from __future__ import annotations

import importlib
from typing import Any

# name -> submodule; resolved on first use so that importing asmplan.parts.pieces (as the
# simulator does) does not import FCL, trimesh or manifold3d.
_EXPORTS = {
    "AssemblyCheck": "check", "Interference": "check", "MateClearance": "check", "check_assembly": "check",
    "CollisionWorld": "collision", "Contact": "collision", "FclShapes": "collision",
    "Finding": "features", "T_part_feature": "features", "check_mates": "features",
    "FeatureSizing": "geometry", "GeometryError": "geometry", "GeometrySettings": "geometry",
    "MassProperties": "mass", "fitted_sizes": "geometry",
    "LEVELS": "lod", "bodies": "lod",
    "HoleClearance": "lod_measure", "LevelReport": "lod_measure", "convex_sides": "primitive_pieces",
    "LoadedMesh": "meshfile", "MeshFileError": "meshfile", "load_mesh_file": "meshfile",
    "ProductGeometry": "models",
    "CollisionModel": "pieces", "ConvexPiece": "pieces", "LevelOfDetail": "pieces",
}


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


__all__ = [
    "LEVELS",
    "AssemblyCheck",
    "CollisionModel",
    "CollisionWorld",
    "Contact",
    "ConvexPiece",
    "FclShapes",
    "FeatureSizing",
    "Finding",
    "GeometryError",
    "GeometrySettings",
    "HoleClearance",
    "Interference",
    "LevelOfDetail",
    "LevelReport",
    "LoadedMesh",
    "MassProperties",
    "MateClearance",
    "MeshFileError",
    "ProductGeometry",
    "T_part_feature",
    "bodies",
    "check_assembly",
    "check_mates",
    "convex_sides",
    "fitted_sizes",
    "load_mesh_file",
]
