"""Collision models of the arm's links, from the URDF's collision geometry.

Each link becomes a :class:`~asmplan.parts.pieces.CollisionModel` in its link frame, so that
``parts.collision`` (the FCL world) checks arm links exactly like parts:

* an OBJ collision mesh is read object by object (``o``/``g`` groups): a V-HACD decomposition
  such as the xArm's ``*_vhacd.obj`` gives one convex hull per group, as its author made it;
* any other mesh file (STL, PLY, ...) gives the convex hull of all its vertices (a superset
  of the link: conservative);
* URDF boxes, cylinders and spheres are exact primitives.

URDF lengths are metres and mesh ``scale`` factors are applied; nothing is rescaled by the
product file's units.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from ..knowledge.robot import UrdfArm, UrdfCollision
from .pieces import CollisionModel, ConvexPiece


def _obj_groups(path: Path) -> list[np.ndarray]:
    """Vertices of each object/group of an OBJ file (faces name the vertices they use)."""
    verts: list[tuple[float, float, float]] = []
    groups: list[set[int]] = [set()]
    for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
        if line.startswith("v "):
            x, y, z = (float(v) for v in line.split()[1:4])
            verts.append((x, y, z))
        elif line.startswith(("o ", "g ")):
            if groups[-1]:
                groups.append(set())
        elif line.startswith("f "):
            for tok in line.split()[1:]:
                i = int(tok.split("/")[0])
                groups[-1].add(i - 1 if i > 0 else len(verts) + i)
    V = np.array(verts, dtype=float)
    out = [V[sorted(g)] for g in groups if len(g) >= 4]
    if not out and len(V) >= 4:
        out = [V]
    return out


@cache
def _mesh_groups(path: Path) -> tuple[np.ndarray, ...]:
    if path.suffix.lower() == ".obj":
        return tuple(_obj_groups(path))
    import trimesh

    mesh = trimesh.load(str(path), force="mesh", process=False)
    return (np.asarray(mesh.vertices, dtype=float),)  # type: ignore[attr-defined]


def _pieces(c: UrdfCollision) -> list[ConvexPiece]:
    T = np.asarray(c.T_link_geom, dtype=float)
    if c.kind == "box":
        return [ConvexPiece("box", T, half_extents_m=np.asarray(c.size_m) / 2, name=c.link)]
    if c.kind == "cylinder":
        return [ConvexPiece("cylinder", T, radius_m=c.size_m[0], length_m=c.size_m[1],
                            name=c.link)]
    if c.kind == "sphere":
        return [ConvexPiece("sphere", T, radius_m=c.size_m[0], name=c.link)]
    assert c.mesh_path is not None
    out = []
    for V in _mesh_groups(c.mesh_path):
        Vs = V * np.asarray(c.mesh_scale)
        centre = 0.5 * (Vs.min(axis=0) + Vs.max(axis=0))
        Tp = T.copy()
        Tp[:3, 3] = T[:3, :3] @ centre + T[:3, 3]
        out.append(ConvexPiece("hull", Tp, vertices_m=Vs - centre, name=c.link))
    return out


def link_models(arm: UrdfArm) -> dict[str, CollisionModel]:
    """Collision model of every link of the chain that has collision geometry, link frame."""
    by_link: dict[str, list[ConvexPiece]] = {}
    for c in arm.collisions:
        by_link.setdefault(c.link, []).extend(_pieces(c))
    return {ln: CollisionModel("exact", tuple(p)) for ln, p in by_link.items() if p}
