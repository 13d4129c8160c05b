"""Read a part's mesh file (STL, OBJ, PLY, OFF, GLB; STEP with the optional ``cascadio``).

Every step is bounded in time and says what it did:

1. **Size gate, before reading.** Files over ``max_mesh_file_bytes`` are refused. The triangle
   count is read from the header where the format has one (binary STL, PLY, OFF) or counted
   on the raw bytes (ASCII STL ``facet``, OBJ ``f`` lines, a linear scan); over
   ``hard_max_triangles`` the file is refused without being parsed.
2. **Read** with trimesh (no processing), scale to metres. STEP comes through cascadio already
   in metres (its own units are converted), so the YAML ``units`` are NOT applied to it. A STEP
   file that does not open with ``ISO-10303-21;`` or close with ``END-ISO-10303-21;`` (truncated)
   is refused before translation; a failed translation says so (not trimesh's missing GLB).
3. **Safe repair** only: merge duplicate vertices, drop degenerate and duplicate faces, make
   the winding consistent and the normals point outwards, fill holes of three or four edges.
   Nothing that moves a surface.
4. **Checks**: still not watertight -> :class:`MeshFileError` with the number of open edges;
   zero (or negative) volume -> :class:`MeshFileError` (a flat sheet or an empty file).
5. **Huge meshes** (more than ``max_triangles`` faces, 200 000 by default) skip the trimesh
   path (its vertex merge took 18 s for 2 million triangles): the triangles are read straight
   from a binary STL, vertices merged by one sort, edges counted. A surface that is not closed
   cannot be simplified safely and gets a :class:`MeshFileError` naming the count and the
   limit (about 5 s for 2 million triangles). A closed one is simplified with manifold3d's
   ``simplify`` (edge collapse within a tolerance that starts at 1e-5 of the bounding-box
   diagonal and grows 4x per round, at most 6 rounds) and then goes through steps 2-4; a note
   records the tolerance and the triangle counts.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import AsmplanError
from .geometry import GeometrySettings, manifold_to_trimesh, trimesh_to_manifold

if TYPE_CHECKING:
    import trimesh


class MeshFileError(AsmplanError, ValueError):
    """A mesh file cannot be used; ``path`` and ``reason`` say which and why."""

    def __init__(self, path: Path | str, reason: str):
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"{self.path.name}: {reason}")


@dataclass(frozen=True, eq=False)
class LoadedMesh:
    """A watertight mesh in metres with what was done to it.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Watertight, outward normals, metres, the file's own frame.
    source_triangles : int
        Triangle count as read.
    notes : tuple of str
        Repairs, unit decisions and simplifications applied.
    """

    mesh: trimesh.Trimesh
    source_triangles: int
    notes: tuple[str, ...] = field(default_factory=tuple)


_STEP_SUFFIXES = (".step", ".stp")


def count_triangles(path: Path) -> int | None:
    """Triangle (face) count from the file without parsing it, or None when unknown.

    Binary STL: the header's count. ASCII STL: ``facet`` keywords. OBJ: ``f`` lines (a polygon
    counts once). PLY and OFF: the header's face element count.
    """
    suffix = path.suffix.lower()
    size = path.stat().st_size
    with path.open("rb") as fh:
        head = fh.read(4096)
    if suffix == ".stl":
        if len(head) >= 84:
            n = int(np.frombuffer(head[80:84], dtype="<u4")[0])
            if 84 + 50 * n == size:
                return n
        return path.read_bytes().count(b"facet normal") or None
    if suffix == ".obj":
        data = path.read_bytes()
        return data.count(b"\nf ") + (1 if data.startswith(b"f ") else 0)
    if suffix == ".ply":
        m = re.search(rb"element\s+face\s+(\d+)", head)
        return int(m.group(1)) if m else None
    if suffix == ".off":
        lines = [ln for ln in head.split(b"\n") if ln.strip() and not ln.startswith(b"#")]
        if lines and lines[0].strip().upper().startswith(b"OFF"):
            rest = lines[0].strip()[3:].split() or (lines[1].split() if len(lines) > 1 else [])
            if len(rest) >= 2:
                return int(rest[1])
        return None
    return None


_STEP_START = b"ISO-10303-21;"
_STEP_END = b"END-ISO-10303-21;"


def _check_step_frame(path: Path) -> None:
    """Refuse a STEP file that does not open with ``ISO-10303-21;`` or close with
    ``END-ISO-10303-21;`` (ISO 10303-21 section 5): cascadio only reports a failed
    translation, which trimesh surfaces as a missing temporary ``converted.glb``."""
    size = path.stat().st_size
    with path.open("rb") as fh:
        head = fh.read(256)
        fh.seek(max(0, size - 4096))
        tail = fh.read()
    start = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if not start.startswith(_STEP_START):
        found = repr(start[:20].decode("latin-1")) if start else "an empty file"
        raise MeshFileError(path, f"expected a STEP (ISO 10303-21) text file starting with "
                            f"'ISO-10303-21;', found {found}")
    if _STEP_END not in tail:
        raise MeshFileError(path, "expected a STEP (ISO 10303-21) file ending with "
                            f"'END-ISO-10303-21;', found none in its last {len(tail):,} bytes: "
                            "the file looks truncated")


def _require_step_reader(path: Path) -> None:
    """Register cascadio's STEP loader with trimesh (the optional extra ``step``) and check
    the file's frame, before a STEP file is read."""
    try:
        import cascadio  # noqa: F401  (registers the STEP loader with trimesh)
    except ImportError:
        raise MeshFileError(path, "reading STEP needs the optional extra: pip install "
                            "'asmplan[step]' (cascadio)") from None
    _check_step_frame(path)


def _step_scene(path: Path, step_deflection_m: float):
    """A STEP file as a trimesh Scene through cascadio (metres; OpenCASCADE meshes in mm)."""
    import trimesh

    _require_step_reader(path)
    try:
        return trimesh.load(str(path), force="scene", tol_linear=step_deflection_m * 1e3)
    except FileNotFoundError:
        raise MeshFileError(path, "cascadio (OpenCASCADE) could not translate the STEP file to "
                            "a mesh: expected valid ISO 10303-21 entities describing a solid or "
                            "a closed shell (OpenCASCADE printed its reason on the console)") from None
    except Exception as exc:
        raise MeshFileError(path, f"cannot read the file as STEP: {type(exc).__name__}: {exc}") from None


def _solid_bodies(path: Path, step_deflection_m: float):
    """The STEP file's solids through OpenCASCADE's XCAF reader (:mod:`asmplan.parts.step_brep`),
    or None without the ``cad`` extra or when it cannot read the file. cascadio's scene has one
    node per product: the several solids of ONE product (a multi-body part written as a
    compound) come out of it as one mesh, which only the solids show."""
    try:
        from .step_brep import StepReadError, read_step_assembly

        return read_step_assembly(path, deflection_m=step_deflection_m)
    except (ImportError, StepReadError):
        return None


def step_body_names(path: Path | str, step_deflection_m: float = 1e-4) -> list[str]:
    """Names of the bodies (solid instances) of a STEP file, as ``body:`` takes them: the
    scene's nodes, or, where one node holds several solids, the solids (``name_bodyK``)."""
    scene = _step_scene(Path(path), step_deflection_m)
    names = [str(n) for n in scene.graph.nodes_geometry]
    if len(names) <= 1:
        solids = _solid_bodies(Path(path), step_deflection_m)
        if solids is not None and len(solids.instances) > 1:
            return [inst.name for inst in solids.instances]
    return names


def _find_body(scene, path: Path, body: str, step_deflection_m: float):
    """The graph node of the body named ``body`` (its instance or its geometry's name), or
    the solid (:func:`_solid_bodies`) of that name as a mesh in the file's frame (metres)."""
    import trimesh

    for n in scene.graph.nodes_geometry:
        if str(n) == body or str(scene.graph[n][1]) == body:
            return n
    solids = _solid_bodies(path, step_deflection_m)
    if solids is not None:
        for inst in solids.instances:
            if inst.name == body:
                d = solids.definitions[inst.definition]
                mesh = trimesh.Trimesh(d.vertices_m, d.faces, process=False)
                mesh.apply_transform(inst.T_assembly_part)
                return mesh
    names = step_body_names(path, step_deflection_m)
    raise MeshFileError(path, f'expected a body named "{body}", found bodies: {", ".join(names)}')


def check_step_body(path: Path | str, body: str, step_deflection_m: float = 1e-4) -> None:
    """Raise :class:`MeshFileError` unless ``body`` names a body of the STEP file at ``path``
    (as ``geometry.body`` is resolved when the part is loaded), listing the bodies it has."""
    _find_body(_step_scene(Path(path), step_deflection_m), Path(path), body, step_deflection_m)


def _step_body(path: Path, body: str, step_deflection_m: float):
    """One named body of a STEP file, in the file's frame (its placement applied)."""
    import trimesh

    scene = _step_scene(path, step_deflection_m)
    found = _find_body(scene, path, body, step_deflection_m)
    if isinstance(found, trimesh.Trimesh):
        return found
    T, geom = scene.graph[found]
    mesh = scene.geometry[geom].copy()
    mesh.apply_transform(T)
    return mesh


def _read(path: Path, step_deflection_m: float):
    """The file as an unprocessed trimesh. STEP surfaces are tessellated with a chordal
    deflection of ``step_deflection_m``: chords lie inside a curve, so a hole comes out up to
    that much narrower (with cascadio's default, 9.6 um on an 8 mm hole, which fails H7/g6)."""
    import trimesh

    suffix = path.suffix.lower()
    is_step = suffix in _STEP_SUFFIXES
    if is_step:
        _require_step_reader(path)
    try:
        # OpenCASCADE meshes in millimetres whatever the file's unit
        extra: dict[str, Any] = {"tol_linear": step_deflection_m * 1e3} if is_step else {}
        loaded = trimesh.load(str(path), force="mesh", process=False, **extra)
    except FileNotFoundError as exc:
        if not is_step:
            raise MeshFileError(path, f"cannot read the file as {suffix[1:].upper()}: "
                                f"{type(exc).__name__}: {exc}") from None
        # cascadio writes no GLB when OpenCASCADE fails; its reason goes to the console
        raise MeshFileError(path, "cascadio (OpenCASCADE) could not translate the STEP file to "
                            "a mesh: expected valid ISO 10303-21 entities describing a solid or "
                            "a closed shell (OpenCASCADE printed its reason on the console)") from None
    except Exception as exc:  # trimesh raises many types on malformed files
        raise MeshFileError(path, f"cannot read the file as {suffix[1:].upper()}: "
                            f"{type(exc).__name__}: {exc}") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshFileError(path, "expected a triangle mesh, found no triangles")
    return loaded


def _repair(mesh) -> list[str]:
    import trimesh

    notes = []
    n_v, n_f = len(mesh.vertices), len(mesh.faces)
    mesh.merge_vertices()
    keep = mesh.nondegenerate_faces() & mesh.unique_faces()
    if not keep.all():
        mesh.update_faces(keep)
        mesh.remove_unreferenced_vertices()
    if len(mesh.vertices) != n_v or len(mesh.faces) != n_f:
        notes.append(f"merged duplicate vertices and dropped degenerate/duplicate faces: "
                     f"{n_v} -> {len(mesh.vertices)} vertices, {n_f} -> {len(mesh.faces)} faces")
    if not mesh.is_watertight:
        before = len(mesh.faces)
        trimesh.repair.fill_holes(mesh)
        if len(mesh.faces) != before:
            notes.append(f"filled small holes with {len(mesh.faces) - before} triangles")
    if mesh.is_watertight:
        trimesh.repair.fix_normals(mesh)
    return notes


def _open_edges(mesh) -> int:
    import trimesh

    groups = trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1)
    return len(groups)


# Complexity above C (radon): read, scale, repair and check a mesh: one branch per file
# format and per check (bodies, watertight, size), each with its own message.
def load_mesh_file(path: Path | str, scale: float = 1.0,
                   settings: GeometrySettings | None = None, body: str | None = None) -> LoadedMesh:
    """Read, scale, repair and check a mesh file (see the module docstring).

    Parameters
    ----------
    path : path to the file.
    scale : float
        File units to metres (ignored for STEP, which carries its own units).
    settings : GeometrySettings, optional
        Size limits.
    body : str, optional
        One body (solid instance) of a multi-body STEP file, by its name; without it every body
        is fused into one mesh and a note names them.

    Returns
    -------
    LoadedMesh

    Raises
    ------
    MeshFileError
        Missing, unreadable, too large, not watertight after safe repair, or zero volume.
    """
    settings = settings or GeometrySettings()
    path = Path(path)
    if not path.is_file():
        raise MeshFileError(path, "file not found")
    size = path.stat().st_size
    if size > settings.max_mesh_file_bytes:
        raise MeshFileError(path, f"file is {size / 1e6:.0f} MB, over the limit of "
                            f"{settings.max_mesh_file_bytes / 1e6:.0f} MB; simplify it first")
    counted = count_triangles(path)
    if counted is not None and counted > settings.hard_max_triangles:
        raise MeshFileError(path, f"{counted:,} triangles, over the hard limit of "
                            f"{settings.hard_max_triangles:,} (and the simplification limit "
                            f"{settings.max_triangles:,}); simplify it before use")
    notes: list[str] = []
    if counted is not None and counted > settings.max_triangles:
        mesh, note = _simplify(path, _read_triangles(path, settings.exact_tolerance_m),
                               settings.max_triangles)
        notes.append(note)
        n_read = counted
    elif body is not None:
        mesh = _step_body(path, body, settings.exact_tolerance_m)
        n_read = len(mesh.faces)
        notes.append(f'body "{body}" of the STEP file')
    else:
        mesh = _read(path, settings.exact_tolerance_m)
        n_read = len(mesh.faces)
        if path.suffix.lower() in _STEP_SUFFIXES:
            bodies = step_body_names(path)
            if len(bodies) > 1:
                notes.append(multi_body_warning(path, bodies))
        if n_read > settings.hard_max_triangles:
            raise MeshFileError(path, f"{n_read:,} triangles, over the hard limit of "
                                f"{settings.hard_max_triangles:,}; simplify it before use")
        if n_read > settings.max_triangles:
            mesh, note = _simplify(path, np.asarray(mesh.vertices, np.float64)[mesh.faces],
                                   settings.max_triangles)
            notes.append(note)
    if path.suffix.lower() in _STEP_SUFFIXES:
        notes.append("STEP read through cascadio in metres; the YAML units are not applied")
    elif scale != 1.0:
        mesh.apply_scale(scale)
        notes.append(f"scaled by {scale:g} to metres")
    if not np.all(np.isfinite(mesh.vertices)):
        raise MeshFileError(path, "expected finite vertex coordinates, found NaN or infinity")
    with np.errstate(invalid="ignore", divide="ignore"):  # trimesh divides by a zero volume
        notes += _repair(mesh)
    if not mesh.is_watertight:
        raise MeshFileError(path, f"not watertight after safe repair ({_open_edges(mesh):,} open "
                            "edges; only holes of 3-4 edges are filled): close the surface in a CAD or "
                            "mesh tool")
    extent = mesh.bounding_box.extents
    with np.errstate(invalid="ignore", divide="ignore"):  # trimesh divides by a zero volume
        volume = float(mesh.volume)
    if not volume > 1e-9 * float(np.prod(np.maximum(extent, 1e-300))) or volume <= 0:
        raise MeshFileError(path, f"zero volume ({volume:.3g} m^3 inside a bounding box of "
                            f"{' x '.join(f'{e * 1e3:.3g}' for e in extent)} mm): a flat or "
                            "inside-out surface is not a solid")
    if float(np.max(extent)) > 10.0 or float(np.max(extent)) < 1e-4:
        notes.append(f"the part is {np.max(extent) * 1e3:.3g} mm across: check the units")
    return LoadedMesh(mesh, n_read, tuple(notes))


def _read_triangles(path: Path, step_deflection_m: float) -> np.ndarray:
    """Triangles (n, 3, 3) of a file; binary STL straight from the bytes (no per-vertex work)."""
    if path.suffix.lower() == ".stl":
        size = path.stat().st_size
        with path.open("rb") as fh:
            fh.seek(80)
            n = int(np.frombuffer(fh.read(4), dtype="<u4")[0])
            if 84 + 50 * n == size:
                rec = np.fromfile(fh, dtype=[("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")], count=n)
                return np.asarray(rec["v"], dtype=np.float64)
    mesh = _read(path, step_deflection_m)
    return np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces)]


def _merge(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bit-identical vertices merged: (vertices (m, 3), faces (n, 3)) by one lexicographic sort."""
    v = np.ascontiguousarray(triangles.reshape(-1, 3), dtype=np.float64)
    order = np.lexsort((v[:, 2], v[:, 1], v[:, 0]))
    s = v[order]
    new = np.ones(len(s), dtype=bool)
    new[1:] = np.any(s[1:] != s[:-1], axis=1)
    ids = np.cumsum(new) - 1
    inverse = np.empty(len(s), dtype=np.int64)
    inverse[order] = ids
    return s[new], inverse.reshape(-1, 3)


def _simplify(path: Path, triangles: np.ndarray, limit: int):
    """A huge mesh simplified below ``limit`` triangles when it is a closed manifold, else an
    error; at most a few seconds per million triangles (one sort, one edge count)."""
    import trimesh

    n = len(triangles)
    V, F = _merge(triangles)
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges[:, 0] * len(V) + edges[:, 1], return_counts=True)
    open_edges = int(np.count_nonzero(counts != 2))
    if open_edges:
        raise MeshFileError(path, f"{n:,} triangles, over the limit of {limit:,}, and not a closed "
                            f"surface ({open_edges:,} edges not shared by exactly two triangles): it "
                            "cannot be simplified safely; simplify or repair it before use")
    try:
        solid = trimesh_to_manifold(trimesh.Trimesh(V, F, process=False))
    except ValueError as exc:
        raise MeshFileError(path, f"{n:,} triangles, over the limit of {limit:,}, and it cannot "
                            f"be simplified safely: {exc}") from None
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    tol = 1e-5 * diag
    small = solid
    for _ in range(6):
        small = solid.simplify(tol)
        if small.num_tri() <= limit:
            out = manifold_to_trimesh(small)
            if out.is_watertight and out.volume > 0:
                return out, (f"simplified from {n:,} to {len(out.faces):,} triangles (limit "
                             f"{limit:,}) by edge collapse within {tol:.3g} file units")
        tol *= 4.0
    raise MeshFileError(path, f"{n:,} triangles, over the limit of {limit:,}; simplification "
                        f"within {tol / 4:.3g} file units still left {small.num_tri():,}")


def multi_body_warning(path: Path, bodies: list[str]) -> str:
    """The warning for a multi-body file loaded as one part."""
    return (f"{Path(path).name} holds {len(bodies)} bodies ({', '.join(bodies)}): they are fused "
            "into one part; name one with geometry.body, or import the assembly with `asmplan import`")


__all__ = ["LoadedMesh", "MeshFileError", "check_step_body", "count_triangles", "load_mesh_file",
           "multi_body_warning",
           "step_body_names"]
