"""Read a STEP assembly's tree and exact B-rep surfaces (the only module importing OCP).

OCP is the CadQuery project's binding of OpenCASCADE (pip ``cadquery-ocp-novtk``: without the
VTK viewer libraries). Through OpenCASCADE's XCAF reader this module gives

- the assembly tree: every solid instance with its name (the component's name, else the
  part definition's), its placement in the assembly frame and the part definition it shares
  with other instances (six identical nuts are one definition placed six times);
- per part definition, its analytic surfaces (:class:`~asmplan.parts.surface_fit.Surface`:
  cylinders, cones, planes with their exact parameters), and a tessellation within a chordal
  deflection, in the definition's own frame;
- the file's length unit (OpenCASCADE converts to millimetres on reading; this module converts
  to metres once).

Nothing else of OpenCASCADE leaves this module.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import AsmplanError
from .surface_fit import Surface


class StepReadError(AsmplanError, ValueError):
    """A STEP file that cannot be read as an assembly; ``path`` and ``reason`` say why."""

    def __init__(self, path: Path | str, reason: str):
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"{self.path.name}: {reason}")


@dataclass(frozen=True, eq=False)
class BodyDefinition:
    """One solid of a part definition, in the definition's frame (metres).

    ``surfaces`` are the solid's analytic faces; ``vertices_m`` (n, 3) and ``faces`` (m, 3)
    its tessellation; ``other_faces`` counts faces that are neither cylinder, cone nor plane.
    """

    name: str
    surfaces: tuple[Surface, ...]
    vertices_m: np.ndarray
    faces: np.ndarray
    other_faces: int
    volume_m3: float


@dataclass(frozen=True, eq=False)
class SolidInstance:
    """A placed solid: ``T_assembly_part`` (4, 4) in metres, ``definition`` a key of
    :attr:`StepAssembly.definitions`, ``path`` the names from the root to the component."""

    name: str
    definition: str
    T_assembly_part: np.ndarray
    path: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class StepAssembly:
    source: Path
    root_name: str
    file_unit: str
    definitions: dict[str, BodyDefinition]
    instances: tuple[SolidInstance, ...]
    notes: tuple[str, ...]


_UNIT_RE = re.compile(rb"SI_UNIT\s*\(\s*(\.[A-Z]+\.|\$)\s*,\s*\.METRE\.\s*\)")
_CONV_RE = re.compile(rb"CONVERSION_BASED_UNIT\s*\(\s*'([^']+)'")


def file_length_unit(path: Path) -> str:
    """The length unit the STEP file declares (``mm``, ``m``, ``inch``, ...), from its text."""
    data = path.read_bytes()
    conv = _CONV_RE.search(data)
    if conv and conv.group(1).decode("latin-1").lower() in ("inch", "foot", "mil"):
        return conv.group(1).decode("latin-1").lower()
    m = _UNIT_RE.search(data)
    if not m:
        return "unknown"
    prefix = m.group(1).decode()
    return {"$": "m", ".MILLI.": "mm", ".CENTI.": "cm", ".MICRO.": "um", ".KILO.": "km"}.get(prefix, prefix)


def _name(label) -> str | None:
    from OCP.TDataStd import TDataStd_Name

    attr = TDataStd_Name()
    if label.FindAttribute(TDataStd_Name.GetID_s(), attr):
        text = attr.Get().ToExtString().strip()
        return text or None
    return None


def _matrix_mm(trsf) -> np.ndarray:
    T = np.eye(4)
    for i in range(3):
        for j in range(4):
            T[i, j] = trsf.Value(i + 1, j + 1)
    return T


def _surfaces(solid, mm: float) -> tuple[list[Surface], int]:
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepGProp import BRepGProp_Face
    from OCP.BRepTools import BRepTools
    from OCP.GeomAbs import GeomAbs_Cone, GeomAbs_Cylinder, GeomAbs_Plane
    from OCP.gp import gp_Pnt, gp_Vec
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out: list[Surface] = []
    other = 0
    exp = TopExp_Explorer(solid, TopAbs_FACE)
    while exp.More():
        face = TopoDS.Face(exp.Current())
        exp.Next()
        ad = BRepAdaptor_Surface(face, True)
        kind = ad.GetType()
        umin, umax, vmin, vmax = BRepTools.UVBounds_s(face)
        pnt, vec = gp_Pnt(), gp_Vec()
        BRepGProp_Face(face).Normal(0.5 * (umin + umax), 0.5 * (vmin + vmax), pnt, vec)
        mid = np.array([pnt.X(), pnt.Y(), pnt.Z()]) * mm
        normal = np.array([vec.X(), vec.Y(), vec.Z()])
        normal = normal / (np.linalg.norm(normal) or 1.0)
        # corner and mid-edge points of the face's UV box, for its extent along an axis
        grid = [ad.Value(u, v) for u in np.linspace(umin, umax, 5) for v in (vmin, vmax)]
        pts = np.array([[p.X(), p.Y(), p.Z()] for p in grid]) * mm
        if kind == GeomAbs_Cylinder:
            c = ad.Cylinder()
            ax = c.Axis()
            origin = np.array([ax.Location().X(), ax.Location().Y(), ax.Location().Z()]) * mm
            axis = np.array([ax.Direction().X(), ax.Direction().Y(), ax.Direction().Z()])
            radial = mid - origin - axis * float(np.dot(mid - origin, axis))
            inner = float(np.dot(radial, normal)) < 0
            t = (pts - origin) @ axis
            out.append(Surface("cylinder", origin, axis, c.Radius() * mm, inner, float(t.min()),
                               float(t.max()), float(umax - umin), area_m2=0.0, evidence="B-rep cylinder"))
        elif kind == GeomAbs_Cone:
            c = ad.Cone()
            ax = c.Axis()
            origin = np.array([ax.Location().X(), ax.Location().Y(), ax.Location().Z()]) * mm
            axis = np.array([ax.Direction().X(), ax.Direction().Y(), ax.Direction().Z()])
            t = (pts - origin) @ axis
            r = np.linalg.norm(pts - origin - np.outer((pts - origin) @ axis, axis), axis=1)
            radial = mid - origin - axis * float(np.dot(mid - origin, axis))
            inner = float(np.dot(radial, normal)) < 0
            out.append(Surface("cone", origin, axis, float(r.max()), inner, float(t.min()), float(t.max()),
                               float(umax - umin), radius_min_m=float(r.min()),
                               semi_angle_rad=abs(c.SemiAngle()), evidence="B-rep cone"))
        elif kind == GeomAbs_Plane:
            pl = ad.Plane()
            n = pl.Axis().Direction()
            n = np.array([n.X(), n.Y(), n.Z()])
            if float(np.dot(n, normal)) < 0:
                n = -n
            out.append(Surface("plane", mid, n, 0.0, False, 0.0, 0.0, 0.0,
                               offset_m=float(np.dot(n, mid)), evidence="B-rep plane"))
        else:
            other += 1
    return out, other


def _tessellate(solid, deflection_mm: float, mm: float) -> tuple[np.ndarray, np.ndarray]:
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    BRepMesh_IncrementalMesh(solid, deflection_mm, False, 0.2, True)
    verts, faces, offset = [], [], 0
    exp = TopExp_Explorer(solid, TopAbs_FACE)
    while exp.More():
        face = TopoDS.Face(exp.Current())
        exp.Next()
        loc = TopLoc_Location()
        tri = BRep_Tool.Triangulation_s(face, loc)
        if tri is None:
            continue
        trsf = loc.Transformation()
        n = tri.NbNodes()
        v = np.empty((n, 3))
        for i in range(n):
            p = tri.Node(i + 1).Transformed(trsf)
            v[i] = (p.X(), p.Y(), p.Z())
        f = np.empty((tri.NbTriangles(), 3), np.int64)
        for i in range(tri.NbTriangles()):
            a, b, c = tri.Triangle(i + 1).Get()
            f[i] = (a - 1, b - 1, c - 1)
        if face.Orientation() == TopAbs_REVERSED:
            f = f[:, ::-1]
        verts.append(v * mm)
        faces.append(f + offset)
        offset += n
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    return np.vstack(verts), np.vstack(faces)


def _solids(shape) -> list:
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer

    out = []
    exp = TopExp_Explorer(shape, TopAbs_SOLID)
    while exp.More():
        out.append(exp.Current())
        exp.Next()
    return out


def _volume(solid) -> float:
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(solid, props)
    return float(props.Mass())


def read_step_assembly(path: Path | str, deflection_m: float = 1e-6) -> StepAssembly:
    """Read a STEP (AP203/AP214/AP242) file's assembly tree, solids and surfaces.

    Parameters
    ----------
    path : the STEP file.
    deflection_m : float
        Chordal deflection of the tessellation (m); the analytic surfaces are exact.

    Raises
    ------
    StepReadError
        The file does not translate, or holds no solid.
    """
    from OCP.collections import Sequence_TDF_Label as label_sequence
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPCAFControl import STEPCAFControl_Reader
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDF import TDF_Label
    from OCP.TDocStd import TDocStd_Document
    from OCP.XCAFDoc import XCAFDoc_DocumentTool, XCAFDoc_ShapeTool

    path = Path(path)
    mm = 1e-3  # OpenCASCADE's session unit
    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    reader = STEPCAFControl_Reader()
    reader.SetNameMode(True)
    if reader.ReadFile(str(path)) != IFSelect_RetDone:
        raise StepReadError(path, "OpenCASCADE could not read the file as STEP (ISO 10303-21)")
    if not reader.Transfer(doc):
        raise StepReadError(path, "OpenCASCADE could not translate the STEP entities to shapes")
    tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    free = label_sequence()
    tool.GetFreeShapes(free)
    definitions: dict[str, BodyDefinition] = {}
    by_tag: dict[int, list[str]] = {}
    instances: list[SolidInstance] = []
    notes: list[str] = []
    used_names: dict[str, int] = {}

    def unique(name: str) -> str:
        k = used_names.get(name, 0)
        used_names[name] = k + 1
        return name if k == 0 else f"{name}_{k + 1}"

    def definition(label) -> list[str]:
        """The definition keys of a part label: one per solid (a multi-body part -> several)."""
        tag = label.Tag()
        if tag in by_tag:
            return by_tag[tag]
        base = _name(label) or f"part{tag}"
        shape = XCAFDoc_ShapeTool.GetShape_s(label)
        solids = _solids(shape)
        keys = []
        for i, solid in enumerate(solids, 1):
            key = base if len(solids) == 1 else f"{base}.body{i}"
            key = key if key not in definitions else f"{key}#{tag}"
            surfaces, other = _surfaces(solid, mm)
            V, F = _tessellate(solid, deflection_m / mm, mm)
            definitions[key] = BodyDefinition(key, tuple(surfaces), V, F, other, _volume(solid) * mm ** 3)
            keys.append(key)
        if len(solids) > 1:
            notes.append(f'part "{base}" holds {len(solids)} solids: each is its own part '
                         f'({", ".join(keys)})')
        by_tag[tag] = keys
        return keys

    def walk(label, T_mm: np.ndarray, names: tuple[str, ...], inst_name: str | None) -> None:
        if XCAFDoc_ShapeTool.IsAssembly_s(label):
            comps = label_sequence()
            XCAFDoc_ShapeTool.GetComponents_s(label, comps, False)
            for i in range(1, comps.Length() + 1):
                comp = comps.Value(i)
                ref = TDF_Label()
                XCAFDoc_ShapeTool.GetReferredShape_s(comp, ref)
                T_c = T_mm @ _matrix_mm(XCAFDoc_ShapeTool.GetLocation_s(comp).Transformation())
                cname = _name(comp) or _name(ref) or f"component{i}"
                walk(ref, T_c, (*names, cname), cname)
            return
        keys = definition(label)
        base = inst_name or _name(label) or "part"
        for k, key in enumerate(keys, 1):
            T = T_mm.copy()
            T[:3, 3] *= mm
            name = base if len(keys) == 1 else f"{base}_body{k}"
            instances.append(SolidInstance(unique(name), key, T, names))

    root_name = path.stem
    for i in range(1, free.Length() + 1):
        label = free.Value(i)
        if free.Length() == 1 and XCAFDoc_ShapeTool.IsAssembly_s(label):
            root_name = _name(label) or root_name
        walk(label, np.eye(4), (_name(label) or path.stem,), None if XCAFDoc_ShapeTool.IsAssembly_s(label)
             else _name(label))
    if not instances:
        raise StepReadError(path, "expected at least one solid, found none (a surface or wire model "
                            "cannot be assembled)")
    return StepAssembly(path, root_name, file_length_unit(path), definitions, tuple(instances),
                        tuple(notes))


def step_body_names(path: Path | str) -> list[str]:
    """Names of the solids of a STEP file, in file order (``name`` or ``name_bodyK``)."""
    return [inst.name for inst in read_step_assembly(path, deflection_m=1e-3).instances]


__all__ = ["BodyDefinition", "SolidInstance", "StepAssembly", "StepReadError", "file_length_unit",
           "read_step_assembly", "step_body_names"]
