"""Turn a CAD assembly (a STEP file, or a folder of per-part meshes in assembled pose) into a
product: parts with their placements and recognised features, proposed mates with fits, and
the product YAML that the rest of asmplan reads, commented with the evidence.

Steps
-----
1. **Read.** STEP through :mod:`asmplan.parts.step_brep` (exact surfaces, names, placements,
   units, shared definitions); meshes through :func:`asmplan.parts.meshfile.load_mesh_file`
   and :func:`asmplan.parts.cad_features.fit_mesh_surfaces`. Identical mesh parts (same volume,
   area and principal moments within 1e-6) are reported as one definition.
2. **Features** per part definition: :func:`asmplan.parts.cad_features.recognise`.
3. **Mates** between every male and female feature of two parts: parallel axes, coaxial lines,
   overlapping extent. Line to line (diameters equal within the input's accuracy) -> the default
   fit of :mod:`asmplan.knowledge.fit_rules`; a drawn clearance up to ``max_clearance_ratio``
   of the diameter -> a clearance mate as drawn; a male larger than the female at an ISO
   metric thread's tap-drill or minor diameter -> a thread (a screw fastening: recognised,
   declared, not simulated); another larger male -> an interference as drawn; a pin in a slot
   -> a non-round mate (not simulated). A through female's mouth is on the side the male comes
   from: the side it can be withdrawn to without its part colliding (a bolt's head), else the
   side the male reaches further out on.
4. **Write** the product YAML: parts that are screwed (bolts, nuts) are listed as fastenings in
   comments, not as parts; the largest part is the fixtured base.

This module reads and runs the steps; the result types are in :mod:`asmplan.parts.cad_types`,
step 3 in :mod:`asmplan.parts.cad_mates`, step 4 in :mod:`asmplan.parts.cad_product`.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from .cad_features import CadFeature, RecognitionTolerance, recognise
from .cad_mates import ISO_METRIC, propose_mates
from .cad_product import product_yaml, summary_lines, write_product
from .cad_types import CadImportError, ImportedPart, ImportResult, ImportSettings, ProposedMate, _clean
from .surface_fit import fit_mesh_surfaces

MESH_SUFFIXES = (".stl", ".obj", ".ply", ".glb", ".off")
STEP_SUFFIXES = (".step", ".stp")


# ---------------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------------
def _read_step(path: Path, settings: ImportSettings) -> tuple[str, str, list[ImportedPart], list[str]]:
    try:
        from .step_brep import StepReadError, read_step_assembly
    except ImportError:
        raise CadImportError(path, "importing STEP assemblies needs OpenCASCADE: pip install "
                             "'asmplan[cad]' (cadquery-ocp-novtk)") from None
    try:
        asm = read_step_assembly(path, settings.deflection_m)
    except StepReadError as exc:
        raise CadImportError(path, exc.reason) from None
    feats: dict[str, tuple[list[CadFeature], list[str]]] = {}
    for key, d in asm.definitions.items():
        feats[key] = recognise(list(d.surfaces), d.vertices_m, d.faces, RecognitionTolerance())
    parts = []
    shared: dict[str, list[str]] = {}
    for inst in asm.instances:
        d = asm.definitions[inst.definition]
        f, notes = feats[inst.definition]
        shared.setdefault(inst.definition, []).append(inst.name)
        parts.append(ImportedPart(_clean(inst.name), inst.definition, inst.T_assembly_part, tuple(f),
                                  d.vertices_m, d.faces, d.volume_m3, tuple(notes)))
    notes = list(asm.notes)
    for key, names in shared.items():
        if len(names) > 1:
            notes.append(f'{len(names)} instances of one part definition "{key}": {", ".join(names)}')
    return asm.root_name, asm.file_unit, parts, notes


def _read_mesh_folder(folder: Path, settings: ImportSettings
                      ) -> tuple[str, str, list[ImportedPart], list[str]]:
    from .meshfile import MeshFileError, load_mesh_file

    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in MESH_SUFFIXES)
    if not files:
        raise CadImportError(folder, f"expected mesh files ({', '.join(MESH_SUFFIXES)}) in the folder, "
                             "found none")
    parts, notes, errors = [], [], []
    signatures: list[tuple[np.ndarray, str]] = []
    for f in files:
        try:
            loaded = load_mesh_file(f, scale=settings.mesh_units_m)
        except MeshFileError as exc:
            errors.append(str(exc))
            continue
        mesh = loaded.mesh
        V = np.asarray(mesh.vertices, float)
        F = np.asarray(mesh.faces, np.int64)
        surfaces = fit_mesh_surfaces(V, F)
        feats, fnotes = recognise(surfaces, V, F, RecognitionTolerance.for_mesh())
        sig = np.concatenate([[mesh.volume, mesh.area], np.sort(mesh.principal_inertia_components)])
        definition = _clean(f.stem)
        for other_sig, other_def in signatures:
            if np.allclose(sig, other_sig, rtol=1e-6, atol=0):
                definition = other_def
                break
        else:
            signatures.append((sig, definition))
        parts.append(ImportedPart(_clean(f.stem), definition, np.eye(4), tuple(feats), V, F,
                                  float(mesh.volume), tuple(fnotes) + loaded.notes))
    if errors:
        raise CadImportError(folder, "; ".join(errors))
    by_def: dict[str, list[str]] = {}
    for p in parts:
        by_def.setdefault(p.definition, []).append(p.name)
    for key, names in by_def.items():
        if len(names) > 1:
            notes.append(f'{len(names)} parts of one shape (definition "{key}"): {", ".join(names)}')
    unit = {1e-3: "mm", 1.0: "m", 1e-2: "cm", 0.0254: "in"}.get(settings.mesh_units_m,
                                                                 f"{settings.mesh_units_m} m")
    return folder.name.removesuffix("_meshes"), unit, parts, notes


def import_assembly(path: Path | str, settings: ImportSettings | None = None) -> ImportResult:
    """Read a STEP assembly or a folder of meshes and propose the product (module docstring).

    Raises
    ------
    CadImportError
        The input is missing, of an unknown kind, or cannot be read.
    """
    settings = settings or ImportSettings()
    path = Path(path)
    if path.is_dir():
        name, unit, parts, notes = _read_mesh_folder(path, settings)
        mesh = True
    elif path.is_file() and path.suffix.lower() in STEP_SUFFIXES:
        name, unit, parts, notes = _read_step(path, settings)
        mesh = False
    elif path.is_file():
        raise CadImportError(path, f"expected a STEP file (.step, .stp) or a folder of meshes, found "
                             f'"{path.suffix}"')
    else:
        raise CadImportError(path, "not found: expected a STEP file or a folder of per-part meshes")
    mates, mnotes = propose_mates(parts, settings, mesh)
    # a female feature a thread is screwed into is a thread (a tapped hole, a nut)
    threaded = {(m.female_part, m.female.name) for m in mates if m.kind == "thread"}
    if threaded:
        parts = [replace(p, features=tuple(replace(f, kind="thread") if (p.name, f.name) in threaded else f
                                           for f in p.features)) for p in parts]
        mates = [replace(m, female=replace(m.female, kind="thread")) if m.kind == "thread" else m
                 for m in mates]
    fasteners = sorted({m.male_part for m in mates if m.kind == "thread"}
                       | {m.female_part for m in mates if m.kind == "thread"
                          and _is_nut(parts, m.female_part)})
    base = max(parts, key=lambda p: p.volume_m3).name
    return ImportResult(path, _clean(name), unit, tuple(parts), tuple(mates), tuple(fasteners), base,
                        tuple(notes + mnotes), settings.primitives, settings.fit_rules or ())


def _is_nut(parts: list[ImportedPart], name: str) -> bool:
    p = next(p for p in parts if p.name == name)
    return any(f.kind == "hex" and not f.female for f in p.features) and \
        not any(not f.female and f.kind != "hex" for f in p.features)


__all__ = [
    "ISO_METRIC",
    "CadImportError",
    "ImportResult",
    "ImportSettings",
    "ImportedPart",
    "ProposedMate",
    "import_assembly",
    "product_yaml",
    "propose_mates",
    "summary_lines",
    "write_product",
]
