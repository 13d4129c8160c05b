"""Writes an imported CAD assembly as a product: the product YAML (parts, features, mates,
fastenings and notes, commented with the evidence), the parts' STL meshes, the check that
nothing asmplan did not write is overwritten, and a short summary."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..knowledge.frames import rotation_between
from .cad_operations import operation_hint
from .cad_types import CadImportError, ImportedPart, ImportResult, ProposedMate, _apply, _apply_all


# ---------------------------------------------------------------------------------------------
# Writing the product
# ---------------------------------------------------------------------------------------------
def _mm(v: float) -> str:
    return f"{round(v * 1e3, 6):.6f}".rstrip("0").rstrip(".").replace("-0", "-0") or "0"


def _vec_mm(v) -> str:
    return "[" + ", ".join(_fmt(x * 1e3) for x in v) + "]"


def _fmt(x: float) -> str:
    x = round(float(x), 6) + 0.0
    return f"{x:.6f}".rstrip("0").rstrip(".") if x != int(x) else str(int(x))


def _vec(v) -> str:
    return "[" + ", ".join(_fmt(round(float(x), 9)) for x in v) + "]"


def _rpy_deg(R: np.ndarray) -> np.ndarray:
    """Fixed-axis X-Y-Z angles (R = Rz Ry Rx) in degrees."""
    pitch = math.asin(-max(-1.0, min(1.0, R[2, 0])))
    if abs(math.cos(pitch)) > 1e-9:
        roll = math.atan2(R[2, 1], R[2, 2])
        yaw = math.atan2(R[1, 0], R[0, 0])
    else:
        roll = math.atan2(-R[1, 2], R[1, 1])
        yaw = 0.0
    return np.degrees([roll, pitch, yaw])


def _write_stl(path: Path, V_m: np.ndarray, F: np.ndarray) -> None:
    import trimesh

    m = trimesh.Trimesh(V_m * 1e3, F, process=False)
    m.merge_vertices()
    tmp = path.with_suffix(".stl.tmp")
    m.export(tmp, file_type="stl")
    tmp.replace(path)


def _start_rotations(parts: list[ImportedPart], base: str, frames: dict[str, np.ndarray],
                     mates: list[ProposedMate]) -> dict[str, tuple[np.ndarray, str]]:
    """World start rotation of each part and why.

    A part waits in its assembled orientation, except a plain cylinder (a dowel, a pin) whose
    axis is not vertical when assembled: lying on its side it has no flat face a feeder's nest
    can hold (it would roll), so it stands on the end that leads into its mate (the mate in
    the base first), as dowels come out of a magazine, and the gripper turns it on the way."""
    out: dict[str, tuple[np.ndarray, str]] = {}
    for p in parts:
        R = frames[p.name][:3, :3]
        prim = _revolved_primitive(p)
        if p.name == base or prim is None or abs(float(R[2, 2])) > 1.0 - 1e-9:
            out[p.name] = (R, "assembled orientation")
            continue
        own = [m for m in mates if m.male_part == p.name and m.simulated]
        own.sort(key=lambda m: (m.female_part != base,))
        lead = -own[0].axis if own else R[:, 2]
        Q = rotation_between(np.asarray(lead, float), np.array([0.0, 0.0, -1.0]))
        out[p.name] = (Q @ R, "standing on its leading end (lying on its side it would roll)")
    return out


def _start_poses(parts: list[ImportedPart], base: str, frames: dict[str, np.ndarray],
                 rotations: dict[str, tuple[np.ndarray, str]]) -> dict[str, np.ndarray]:
    """World start positions (m): a row of feeders behind the assembly (+y), each part in its
    start orientation (:func:`_start_rotations`) with its lowest point 15 mm above the table,
    80 mm apart."""
    world = {p.name: _apply_all(p.T_assembly_part, p.vertices_m) for p in parts}
    y_row = max(float(v[:, 1].max()) for v in world.values()) + 0.12
    x = min(float(v[:, 0].min()) for v in world.values())
    out = {}
    for p in parts:
        if p.name == base:
            continue
        V = world[p.name] - frames[p.name][:3, 3]  # about the part origin, assembled rotation
        Q = rotations[p.name][0] @ frames[p.name][:3, :3].T
        V = V @ Q.T
        lo, hi = V.min(axis=0), V.max(axis=0)
        out[p.name] = np.array([x - lo[0], y_row - 0.5 * (lo[1] + hi[1]), 0.015 - lo[2]])
        x += float(hi[0] - lo[0]) + 0.08
    return out


def _revolved_primitive(p: ImportedPart):
    """A part that is a plain (chamfered) cylinder, optionally with one coaxial through bore
    (a dowel, a pin, a shaft, a ring, a sleeve, a washer), as an exact primitive:
    (T_definition_cylinder, diameter, length, bore feature or None, why) or None.

    The primitive's volume must match the solid's within 0.5 %, so nothing else is hidden."""
    males = [f for f in p.features if not f.female]
    females = [f for f in p.features if f.female]
    if len(males) != 1 or males[0].kind not in ("pin", "shaft") or len(females) > 1:
        return None
    m = males[0]
    bore = females[0] if females else None
    if bore is not None and (bore.kind != "bore" or not bore.through or bore.counterbore):
        return None
    r = 0.5 * m.diameter_m
    length = m.length_m
    vol = math.pi * r * r * length
    for c in (m.chamfer_t0_m, m.chamfer_t1_m):
        vol -= math.pi * c * c * (r - c / 3.0)
    if bore is not None:
        vol -= math.pi * (0.5 * bore.diameter_m) ** 2 * length
    if abs(vol - p.volume_m3) > 5e-3 * p.volume_m3:
        return None
    a = m.axis
    u = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
    u /= np.linalg.norm(u)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2] = u, np.cross(a, u), a
    T[:3, 3] = m.point_m + a * 0.5 * (m.t0_m + m.t1_m)
    why = (f"recognised as a plain cylinder {m.diameter_m * 1e3:.6g} x {length * 1e3:.6g} mm"
           + (f" with a {bore.diameter_m * 1e3:.6g} mm bore" if bore is not None else "")
           + f" (its volume matches the CAD solid's within {abs(vol / p.volume_m3 - 1):.2%}): "
           "an exact primitive")
    return T, m.diameter_m, length, bore, why


def _part_frame(p: ImportedPart, primitives: bool = True) -> np.ndarray:
    """The written part frame in the assembly: the definition's, or the primitive's."""
    prim = _revolved_primitive(p) if primitives else None
    return p.T_assembly_part if prim is None else p.T_assembly_part @ prim[0]


def _material(part: ImportedPart) -> str:
    males = [f for f in part.features if not f.female and f.kind in ("pin", "shaft", "thread")]
    return "steel" if males or any(f.kind == "hex" for f in part.features) else "aluminium"


# Complexity above C (radon): writes every section of the product file (parts with their
# features, mates, fasteners, notes); each feature and mate kind is one branch.
def product_yaml(result: ImportResult, mesh_dir_rel: str) -> str:
    """The product file text for ``result``; part meshes are named ``<mesh_dir_rel>/<def>.stl``."""
    simulated_parts = [p for p in result.parts if p.name not in result.fasteners]
    names = {p.name for p in simulated_parts}
    mates = [m for m in result.mates if m.male_part in names and m.female_part in names]
    L: list[str] = []
    w = L.append
    w(f"{_HEADER} from {result.source.name} (file unit: {result.file_unit}).")
    w("# Review before use: every recognised feature and proposed mate carries its evidence;")
    w("# fits of line-to-line pairs come from the default fit rules (default_fits below, if any,")
    w("# then knowledge/data/default_fits.yaml);")
    w("# materials are guessed from the shape (steel for pins, shafts and fasteners).")
    for n in result.notes:
        w(f"# note: {n}")
    w("asmplan: 1")
    w(f"product: {result.name}")
    w(f"description: Imported from {result.source.name}")
    w("units: {length: mm, mass: kg, angle: deg}")
    zmin = min(float(_apply_all(p.T_assembly_part, p.vertices_m)[:, 2].min()) for p in simulated_parts)
    w(f"placement: {{xyz: [0, 0, {_fmt(-zmin * 1e3)}]}}   # the assembly's lowest point on the table")
    w("")
    w("parts:")
    frames = {p.name: _part_frame(p, result.primitives) for p in simulated_parts}
    rotations = _start_rotations(simulated_parts, result.base, frames, mates)
    starts = _start_poses(simulated_parts, result.base, frames, rotations)
    male_feats: dict[tuple[str, int], str] = {}
    female_used: dict[tuple[str, str], ProposedMate] = {}
    per_part_males: dict[str, list[tuple[int, ProposedMate]]] = {}
    for i, m in enumerate(mates):
        if m.simulated:
            per_part_males.setdefault(m.male_part, []).append((i, m))
            female_used[(m.female_part, m.female.name)] = m
    for p in simulated_parts:
        w(f"  - name: {p.name}")
        w(f"    material: {_material(p)}")
        prim = _revolved_primitive(p) if result.primitives else None
        bore_written = None
        if prim is None:
            w(f"    geometry: {{type: mesh, file: {mesh_dir_rel}/{p.definition}.stl, units: mm}}"
              f"   # definition {p.definition}")
        T = frames[p.name]
        Tinv = np.linalg.inv(T)
        if prim is not None:
            _T, d, length, bore, why = prim
            w(f"    # {why}")
            if bore is None:
                w(f"    geometry: {{type: cylinder, diameter: {_mm(d)}, length: {_mm(length)}}}")
            else:
                used = female_used.get((p.name, bore.name))
                axis, mouth = Tinv[:3, :3] @ (p.T_assembly_part[:3, :3] @ bore.axis), \
                    _apply(Tinv, _apply(p.T_assembly_part, bore.mouth_m))
                if used is not None:
                    axis, mouth = Tinv[:3, :3] @ used.axis, _apply(Tinv, used.mouth_m)
                cham = f", chamfer: {_mm(bore.chamfer_m)}" if bore.chamfer_m else ""
                w(f"    geometry: {{type: cylinder, diameter: {_mm(d)}, length: {_mm(length)}, holes: "
                  f"[{{name: {bore.name}, at: {_vec_mm(mouth)}, axis: {_vec(axis)}, "
                  f"diameter: {_mm(bore.diameter_m)}, through: true{cham}}}]}}")
                bore_written = bore.name
        w(f"    pose: {{xyz: {_vec_mm(T[:3, 3])}, rpy: {_vec(_rpy_deg(T[:3, :3]))}}}")
        if p.name == result.base:
            w("    fixtured: true   # the largest part: the base, held by a fixture")
        else:
            R_start, why_start = rotations[p.name]
            w(f"    start: {{location: feeder, xyz: {_vec_mm(starts[p.name])}, "
              f"rpy: {_vec(_rpy_deg(R_start))}}}   # {why_start}, 15 mm above the table")
        hint = None if p.name == result.base else operation_hint(
            p, result.mates, _revolved_primitive(p))
        if hint is not None:
            w(f"    # not a gripper step: {hint.evidence}")
            w(f"    handling: {{operation: {hint.operation}, insertion_direction: "
              f"{_vec(hint.insertion_direction)}, note: \"{hint.note}\"}}")
        lines: list[str] = []
        comments: list[str] = []
        T_def = np.linalg.inv(T) @ p.T_assembly_part  # definition frame -> written part frame
        for f in p.features:
            ev = "; ".join(f.evidence)
            if f.name == bore_written:
                continue
            if f.female and f.kind in ("hole", "bore"):
                used = female_used.get((p.name, f.name))
                axis, mouth = T_def[:3, :3] @ f.axis, _apply(T_def, f.mouth_m)
                if used is not None and f.through:
                    axis = Tinv[:3, :3] @ used.axis
                    mouth = _apply(Tinv, used.mouth_m)
                depth = "through: true" if f.through else f"depth: {_mm(f.depth_m)}"
                cham = f", chamfer: {_mm(f.chamfer_m)}" if f.chamfer_m else ""
                cb = (f"  # counterbore {_mm(f.counterbore[0])} x {_mm(f.counterbore[1])} mm at the mouth"
                      if f.counterbore else "")
                lines.append(f"      # {ev}")
                lines.append(f"      - {{name: {f.name}, type: {f.kind}, at: {_vec_mm(mouth)}, "
                             f"axis: {_vec(axis)}, "
                             f"diameter: {_mm(f.diameter_m)}, {depth}{cham}}}{cb}")
            elif f.female:
                comments.append(f"      # {f.name}: {f.kind} ({ev})")
            elif f.kind == "hex":
                comments.append(f"      # {f.name}: hex {_mm(f.across_flats_m)} mm across flats ({ev})")
            elif f.kind == "thread":
                comments.append(f"      # {f.name}: external thread {_mm(f.diameter_m)} mm ({ev})")
        for k, (_i, m) in enumerate(per_part_males.get(p.name, []), 1):
            f = m.male
            name = f"{f.name}_{k}" if len(per_part_males[p.name]) > 1 else f.name
            male_feats[(p.name, _i)] = name
            at = _apply(Tinv, m.engage_start_m if m.engage_start_m is not None else m.mouth_m)
            axis = Tinv[:3, :3] @ (-m.axis)
            # the tip is the male's end inside the female
            tip_t1 = float(np.dot(p.T_assembly_part[:3, :3] @ f.axis, -m.axis)) > 0
            ch = f.chamfer_t1_m if tip_t1 else f.chamfer_t0_m
            cham = f", chamfer: {_mm(ch)}" if ch else ""
            lines.append(f"      # {'; '.join(f.evidence)}; seated in {m.female_part}.{m.female.name}")
            d = f.diameter_m
            lines.append(f"      - {{name: {name}, type: {f.kind}, at: {_vec_mm(at)}, axis: {_vec(axis)}, "
                         f"diameter: {_mm(d)}, length: {_mm(m.engaged_m)}{cham}}}")
        if lines:
            w("    features:")
            L.extend(lines)
        L.extend(comments)
        for n in p.notes:
            w(f"    # note: {n}")
    w("")
    w("mates:")
    for i, m in enumerate(mates):
        ev = "; ".join(m.evidence)
        if not m.simulated:
            w(f"  # not simulated ({m.kind}): {m.male_part}.{m.male.name} in "
              f"{m.female_part}.{m.female.name}: {ev}")
            continue
        w(f"  # {ev}")
        ref = f"{m.male_part}.{male_feats[(m.male_part, i)]}"
        key = ""
        if m.kind == "fit" and m.fit is not None:
            key = f", fit: {m.fit.fit}"
        elif m.kind == "interference":
            key = f", interference: {_mm(m.male.diameter_m - m.female.diameter_m)}"
        w(f"  - {{name: m{i + 1}_{m.male_part}_in_{m.female_part}, pin: {ref}, "
          f"hole: {m.female_part}.{m.female.name}{key}}}")
    if result.fasteners:
        w("")
        w("# Fastenings (recognised, declared, not simulated): screwing needs a nutrunner, not a")
        w("# two-finger gripper. Each fastener and what it is screwed into:")
        for name in result.fasteners:
            p = result.part(name)
            T = p.T_assembly_part
            into = [m for m in result.mates if m.kind == "thread" and name in (m.male_part, m.female_part)]
            what = ", ".join(f"{m.male_part}.{m.male.name} into {m.female_part}.{m.female.name}"
                             for m in into)
            axis = _vec(-into[0].axis) if into else "?"
            w(f"#   {name} (definition {p.definition}) at {_vec_mm(T[:3, 3])} mm, screwed along "
              f"{axis}: {what}")
            for m in result.mates:
                if name in (m.male_part, m.female_part) and m.kind != "thread":
                    w(f"#     also {m.male_part}.{m.male.name} in {m.female_part}.{m.female.name} ({m.kind})")
    w("")
    if result.fit_rules:
        w("# the fits of line-to-line pairs (tried before knowledge/data/default_fits.yaml);")
        w("# a mate written without a fit whose pin and hole share a diameter gets its fit here")
        w("default_fits:")
        for r in result.fit_rules:
            rng = (f"min_diameter: {_mm(r.min_diameter_m)}, " if r.min_diameter_m else "")
            w(f"  - {{male: {r.male}, female: {r.female}, {rng}max_diameter: {_mm(r.max_diameter_m)}, "
              f"fit: {r.fit}, why: {json.dumps(r.why)}}}   # from {r.source}")
        w("")
    w("precedence:")
    w(f"  base: {result.base}")
    w("")
    w("process:")
    w("  # sliding fits resist the insertion: the grip must carry it (raises the clamp force)")
    w("  insertion_resistance: 2   # N, an estimate: edit")
    w("")
    w("resources:   # a default cell; every length in mm")
    w("  units: {length: mm, mass: kg}")
    w("  gripper: {type: parallel, stroke: 100, finger: {size: [20, 8, 30], friction: 1.0}, max_force: 60, "
      "mass: 0.6}")
    w("  table: {size: [800, 600, 40], friction: 0.5}")
    w(f"  fixtures: [{{name: vise, holds: {result.base}, kind: vise}}]")
    return "\n".join(L) + "\n"


_MARKER = ".asmplan-import"
_HEADER = "# Imported by `asmplan import`"


def check_outputs(out: Path | str) -> Path:
    """Refuse, before any work, outputs asmplan import did not write (module docstring).

    ``out`` may be missing or a product file this command wrote (its first line); its parts
    folder ``<stem>_parts`` may be missing, empty, or hold only what the marker file
    ``.asmplan-import`` lists. Returns the parts folder.

    Raises
    ------
    CadImportError
        Naming the path and what it holds.
    """
    import json

    out = Path(out)
    if out.is_symlink() or (out.exists() and not out.is_file()):
        raise CadImportError(out, "is not a regular file: expected a product YAML file to write")
    if out.exists() and not out.read_text(errors="replace").startswith(_HEADER):
        raise CadImportError(out, "exists and was not written by asmplan import: choose another name")
    if not out.parent.is_dir():
        raise CadImportError(out, f"its folder {out.parent} does not exist")
    mesh_dir = out.parent / f"{out.stem}_parts"
    if mesh_dir.is_symlink() or (mesh_dir.exists() and not mesh_dir.is_dir()):
        raise CadImportError(mesh_dir, "is not a folder: the part meshes go there")
    if mesh_dir.is_dir():
        present = sorted(p.name for p in mesh_dir.iterdir())
        listed: list[str] = []
        marker = mesh_dir / _MARKER
        if marker.is_file():
            try:
                listed = list(json.loads(marker.read_text()).get("files", []))
            except (ValueError, AttributeError):
                listed = []
        foreign = [n for n in present if n != _MARKER and n not in listed]
        if foreign:
            raise CadImportError(mesh_dir, "holds files asmplan import did not write: "
                                 f"{', '.join(foreign[:5])}{' ...' if len(foreign) > 5 else ''}; "
                                 "choose another output name")
    return mesh_dir


def write_product(result: ImportResult, out: Path | str) -> list[Path]:
    """Write ``out`` (the product YAML) and ``<out stem>_parts/<definition>.stl`` (mm).

    Never overwrites what asmplan import did not write (:func:`check_outputs`); meshes of an
    earlier import that this one does not need are removed (the marker lists them). Every
    file is written atomically. Returns the files written.
    """
    import json

    from ..fileio import atomic_write_text

    out = Path(out)
    mesh_dir = check_outputs(out)
    mesh_dir.mkdir(exist_ok=True)
    marker = mesh_dir / _MARKER
    old = []
    if marker.is_file():
        old = list(json.loads(marker.read_text()).get("files", []))
    written = []
    done = set()
    for p in result.parts:
        if p.name in result.fasteners or p.definition in done or \
                (result.primitives and _revolved_primitive(p) is not None):
            continue
        done.add(p.definition)
        target = mesh_dir / f"{p.definition}.stl"
        _write_stl(target, p.vertices_m, p.faces)
        written.append(target)
    names = sorted(t.name for t in written)
    atomic_write_text(marker, json.dumps({"written_by": "asmplan-import", "files": names}))
    for n in old:
        if n not in names and (mesh_dir / n).is_file():
            (mesh_dir / n).unlink()
    atomic_write_text(out, product_yaml(result, mesh_dir.name))
    written.append(out)
    return written


def summary_lines(result: ImportResult) -> list[str]:
    """A short human summary of an import."""
    kinds: dict[str, int] = {}
    for p in result.parts:
        for f in p.features:
            kinds[f.kind] = kinds.get(f.kind, 0) + 1
    mk: dict[str, int] = {}
    for m in result.mates:
        mk[m.kind] = mk.get(m.kind, 0) + 1
    defs = len({p.definition for p in result.parts})
    return [f"{len(result.parts)} parts ({defs} definitions), unit {result.file_unit}",
            "features: " + ", ".join(f"{v} {k}" for k, v in sorted(kinds.items())),
            "mates: " + ", ".join(f"{v} {k}" for k, v in sorted(mk.items())),
            f"fasteners (not simulated): {', '.join(result.fasteners) or 'none'}",
            f"base: {result.base}"]
