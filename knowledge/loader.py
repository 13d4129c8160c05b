"""Load a product YAML file into a validated :class:`~asmplan.knowledge.model.Product`.

Validation reports every problem at once with file, line, column, key path, what was
expected and what was found (:class:`~asmplan.knowledge.errors.ProductError`). The format is
documented in ``docs/product-format.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

from . import iso286
from .consistency import find_inconsistencies
from .errors import InputIssue, ProductError, did_you_mean
from .fit_rules import FitRule, builtin_rules, default_fit
from .frames import make_T
from .materials import Material, builtin_materials
from .model import (
    FEMALE_KINDS,
    MALE_KINDS,
    AssemblyGroup,
    Feature,
    Finger,
    Fixture,
    Geometry,
    GraspHint,
    Gripper,
    Handling,
    HoleCut,
    Mate,
    Part,
    PinAdd,
    Precedence,
    PrecedenceRule,
    Press,
    Primitive,
    Process,
    Product,
    Resources,
    Robot,
    Table,
)
from .robot import JointLimit, UrdfError, read_urdf_arm, resolve_model
from .schema import (
    INVALID,
    Bool,
    Context,
    Field,
    ListOf,
    Map,
    Num,
    OneOf,
    Str,
    Tagged,
    Vec,
)
from .yamlsource import Located, PathKey, load_located

FORMAT_VERSION = 1
LENGTH_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "in": 0.0254}
MASS_UNITS = {"kg": 1.0, "g": 1e-3}
ANGLE_UNITS = {"deg": math.pi / 180.0, "rad": 1.0}

# ---------------------------------------------------------------------------------------------
# Schema
# ---------------------------------------------------------------------------------------------
POSE = Map({"xyz": Field(Vec(3, "length"), default=[0.0, 0.0, 0.0]),
            "rpy": Field(Vec(3, "angle"), default=[0.0, 0.0, 0.0])}, name="a pose")
START = Map({"location": Field(Str(expected="a location name (tray, feeder, table)"), default="table"),
             "xyz": Field(Vec(3, "length"), required=True),
             "rpy": Field(Vec(3, "angle"), default=[0.0, 0.0, 0.0])}, name="a start pose")
DIRECTION = Vec(3, nonzero=True)
MAX_MOVE_M = 5.0  # lift height and approach distance: a robot's reach, not a building's
SIZE = Num("length", size=True)  # a part or feature dimension: 0.01 mm .. 100 m
SIZE3 = Vec(3, item=SIZE)
COLOR = Vec(3, item=Num(minimum=0.0, maximum=1.0))


def _hole_depth_check(v: dict[str, Any], path: PathKey, ctx: Context) -> None:
    if v["depth"] is None and not v["through"]:
        ctx.error(path, 'missing required key "depth" (a positive length), or set "through: true"')


HOLE = Map({
    "name": Field(Str(expected="a feature name"), required=True),
    "at": Field(Vec(3, "length"), required=True),
    "axis": Field(DIRECTION, default=[0.0, 0.0, 1.0]),
    "diameter": Field(SIZE, required=True),
    "depth": Field(SIZE),
    "through": Field(Bool(), default=False),
    "chamfer": Field(Num("length", nonnegative=True), default=0.0),
}, name="a hole", check_fn=_hole_depth_check)
PIN = Map({
    "name": Field(Str(expected="a feature name"), required=True),
    "at": Field(Vec(3, "length"), required=True),
    "axis": Field(DIRECTION, default=[0.0, 0.0, 1.0]),
    "diameter": Field(SIZE, required=True),
    "length": Field(SIZE, required=True),
    "chamfer": Field(Num("length", nonnegative=True), default=0.0),
}, name="a pin")
CUTS = {"holes": Field(ListOf(HOLE), default=[]), "pins": Field(ListOf(PIN), default=[])}
CHILD = Tagged("shape", {
    "box": Map({"size": Field(SIZE3, required=True),
                "pose": Field(POSE, default=None)}),
    "cylinder": Map({"diameter": Field(SIZE, required=True),
                     "length": Field(SIZE, required=True),
                     "pose": Field(POSE, default=None)}),
    "sphere": Map({"diameter": Field(SIZE, required=True),
                   "pose": Field(POSE, default=None)}),
})
GEOMETRY = Tagged("type", {
    "box": Map({"size": Field(SIZE3, required=True), **CUTS}),
    "cylinder": Map({"diameter": Field(SIZE, required=True),
                     "length": Field(SIZE, required=True), **CUTS}),
    "sphere": Map({"diameter": Field(SIZE, required=True)}),
    "composite": Map({"children": Field(ListOf(CHILD, min_len=1), required=True), **CUTS}),
    "mesh": Map({"file": Field(Str(expected="a mesh file path (STL, OBJ, PLY or STEP)"), required=True),
                 "units": Field(Str(tuple(LENGTH_UNITS)), default=None),
                 "body": Field(Str(expected="the name of one body (solid) of a multi-body STEP file"),
                               default=None)}),
})
FEATURE = Map({
    "name": Field(Str(expected="a feature name"), required=True),
    "type": Field(Str(("pin", "shaft", "hole", "bore")), required=True),
    "at": Field(Vec(3, "length"), required=True),
    "axis": Field(DIRECTION, required=True),
    "diameter": Field(SIZE, required=True),
    "length": Field(SIZE),
    "depth": Field(SIZE),
    "through": Field(Bool(), default=False),
    "chamfer": Field(Num("length", nonnegative=True), default=0.0),
}, name="a feature")
GRASP = Map({
    "closing_axis": Field(DIRECTION), "approach_axis": Field(DIRECTION),
    "width": Field(Num("length", positive=True)), "offset": Field(Vec(3, "length")),
}, name="a grasp hint")
HANDLING = Map({
    "insertion_direction": Field(DIRECTION),
    "grasp": Field(GRASP),
    "max_clamp_force": Field(Num("force", positive=True)),
    "max_speed": Field(Num("speed", positive=True)),
    "max_acceleration": Field(Num("acceleration", positive=True)),
    "finger": Field(Str(expected="the name of one of the gripper's fingers")),
}, name="handling knowledge")
PART = Map({
    "name": Field(Str(expected="a part name"), required=True),
    "description": Field(Str(), default=""),
    "material": Field(Str(expected="a material name")),
    "mass": Field(Num("mass", positive=True)),
    "friction": Field(Num(nonnegative=True, maximum=10.0)),
    "color": Field(COLOR),
    "geometry": Field(GEOMETRY, required=True),
    "pose": Field(POSE, required=True),
    "start": Field(START),
    "fixtured": Field(Bool(), default=False),
    "features": Field(ListOf(FEATURE), default=[]),
    "handling": Field(HANDLING),
}, name="a part")
CLEARANCE_RANGE = Map({"min": Field(Num("length"), required=True),
                       "max": Field(Num("length"), required=True)}, name="a clearance range")
MATE = Map({
    "name": Field(Str()),
    "pin": Field(Str(expected='a feature reference "part.feature"'), required=True),
    "hole": Field(Str(expected='a feature reference "part.feature"'), required=True),
    "fit": Field(Str(expected='an ISO 286 fit such as "H7/g6"')),
    "clearance": Field(OneOf({(int, float): Num("length"), dict: CLEARANCE_RANGE},
                             expected="a diametral clearance (a length or {min, max})")),
    "interference": Field(Num("length", positive=True)),
    "hub_diameter": Field(Num("length", positive=True)),
}, name="a mate")
DEFAULT_FIT = Map({
    "male": Field(Str(("pin", "shaft", "any")), default="any"),
    "female": Field(Str(("hole", "bore", "any")), default="any"),
    "min_diameter": Field(Num("length", nonnegative=True), default=0.0),
    "max_diameter": Field(Num("length", positive=True), required=True),
    "fit": Field(Str(expected='an ISO 286 fit such as "H7/g6"'), required=True),
    "why": Field(Str(expected="the reason for the fit"), default=""),
}, name="a default fit rule")
RULE = Map({"before": Field(Str(expected="a part name"), required=True),
            "after": Field(Str(expected="a part name"), required=True),
            "reason": Field(Str(expected="a reason for the rule"), required=True)}, name="a rule")
GROUP = Map({"parts": Field(ListOf(Str(expected="a part name"), min_len=2), required=True),
             "reason": Field(Str(expected="a reason for the group"), required=True)}, name="a group")
PRECEDENCE = Map({"base": Field(Str(expected="a part name")),
                  "rules": Field(ListOf(RULE), default=[]),
                  "groups": Field(ListOf(GROUP), default=[])}, name="precedence knowledge")
PROCESS = Map({
    "safety_factor": Field(Num(positive=True, maximum=100.0)),
    "max_speed": Field(Num("speed", positive=True)),
    "max_acceleration": Field(Num("acceleration", positive=True)),
    "insertion_speed": Field(Num("speed", positive=True)),
    "max_insertion_force": Field(Num("force", positive=True)),
    "insertion_resistance": Field(Num("force", nonnegative=True)),
    "lift_height": Field(Num("length", positive=True, limit_si=MAX_MOVE_M)),
    "approach_distance": Field(Num("length", positive=True, limit_si=MAX_MOVE_M)),
    "position_tolerance": Field(Num("length", positive=True)),
    "max_slip": Field(Num("length", positive=True)),
}, name="process knowledge")
GRIPPER = Map({
    "type": Field(Str(("parallel",)), default="parallel"),
    "stroke": Field(Num("length", positive=True), required=True),
    "finger": Field(Map({"size": Field(Vec(3, "length", positive=True), required=True),
                         "friction": Field(Num(positive=True, maximum=10.0), required=True)},
                        name="finger"), required=True),
    "max_force": Field(Num("force", positive=True), required=True),
    "min_force": Field(Num("force", nonnegative=True), default=0.0),
    "mass": Field(Num("mass", positive=True)),
    "fingers": Field(ListOf(Map({"name": Field(Str(expected="a finger name"), required=True),
                                 "size": Field(Vec(3, "length", positive=True), required=True),
                                 "friction": Field(Num(positive=True, maximum=10.0),
                                                   required=True)},
                                name="a finger")), default=[]),
}, name="a gripper")
JOINT_LIMITS = Map({"lower": Field(Num("angle")), "upper": Field(Num("angle")),
                    "velocity": Field(Num("angle", positive=True)),
                    "acceleration": Field(Num("angle", positive=True))},
                   name="joint limits (lower, upper, velocity, acceleration)")


class _JointTable(Map):
    """Mapping of URDF joint name -> JOINT_LIMITS (names checked against the URDF later)."""

    def __init__(self) -> None:
        super().__init__({}, name="a table of joint limits")

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        if not isinstance(value, dict):
            return ctx.error(path, f"expected a table of joint limits (joint name: {{lower, "
                             f"upper, velocity, acceleration}}), found {value!r}")
        out = {str(n): JOINT_LIMITS.check(v, (*path, n), ctx) for n, v in value.items()}
        return INVALID if any(v is INVALID for v in out.values()) else out


ROBOT = Map({
    "model": Field(Str(expected="a bundled arm name (xarm6) or a path to a URDF file"),
                   required=True),
    "base": Field(POSE, default=None),
    "mounting": Field(POSE, default=None),
    "flange": Field(Str(expected="a link name of the URDF")),
    "reach": Field(Num("length", positive=True)),
    "joints": Field(_JointTable(), default={}),
}, name="a robot")


class _CellMap(Map):
    """The resources section, read in its own ``units`` when it gives them (the cell keeps its
    units whatever the product's): the scales and unit names are swapped while it is checked,
    so limits and messages use the cell's units too."""

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        units = value.get("units") if isinstance(value, dict) else None
        if not isinstance(units, dict):
            return super().check(value, path, ctx)
        scales, names = dict(ctx.scales), dict(ctx.unit_names)
        length, mass = units.get("length"), units.get("mass")
        if isinstance(length, str) and length in LENGTH_UNITS:
            L = LENGTH_UNITS[length]
            ctx.scales.update(length=L, speed=L, acceleration=L)
            ctx.unit_names.update(length=length, speed=f"{length}/s", acceleration=f"{length}/s^2")
        if isinstance(mass, str) and mass in MASS_UNITS:
            ctx.scales.update(mass=MASS_UNITS[mass])
            ctx.unit_names.update(mass=mass)
        try:
            return super().check(value, path, ctx)
        finally:
            ctx.scales.clear()
            ctx.scales.update(scales)
            ctx.unit_names.clear()
            ctx.unit_names.update(names)


RESOURCES = _CellMap({
    "units": Field(Map({"length": Field(Str(tuple(LENGTH_UNITS)), default=None),
                        "mass": Field(Str(tuple(MASS_UNITS)), default=None)}, name="units of the cell"),
                   default=None),
    "gripper": Field(GRIPPER, required=True),
    "table": Field(Map({"size": Field(Vec(3, "length", positive=True), required=True),
                        "friction": Field(Num(nonnegative=True, maximum=10.0), default=0.5)},
                       name="a table"), required=True),
    "fixtures": Field(ListOf(Map({"name": Field(Str(), required=True),
                                  "holds": Field(Str(expected="a part name"), required=True),
                                  "kind": Field(Str(), default="vise")}, name="a fixture")),
                      default=[]),
    "robot": Field(ROBOT),
    "press": Field(Map({"max_force": Field(Num(positive=True), required=True)},
                       name="a press (its max_force in N)")),
}, name="resources")
MATERIAL = Map({"density": Field(Num("density", positive=True), required=True),
                "friction": Field(Num(nonnegative=True, maximum=10.0), required=True),
                "color": Field(COLOR),
                "elastic_modulus_gpa": Field(Num(positive=True)),
                "poisson_ratio": Field(Num(nonnegative=True, maximum=0.4999))}, name="a material")
UNITS = Map({"length": Field(Str(tuple(LENGTH_UNITS)), default="mm"),
             "mass": Field(Str(tuple(MASS_UNITS)), default="kg"),
             "angle": Field(Str(tuple(ANGLE_UNITS)), default="deg")}, name="units")


class _MaterialTable(Map):
    """Mapping of user material name -> MATERIAL (any key allowed)."""

    def __init__(self) -> None:
        super().__init__({}, name="a table of materials")

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        if not isinstance(value, dict):
            return ctx.error(path, f"expected a table of materials (a mapping), found {value!r}")
        out = {name: MATERIAL.check(v, (*path, name), ctx) for name, v in value.items()}
        return INVALID if any(v is INVALID for v in out.values()) else out


DOCUMENT = Map({
    "asmplan": Field(Num(integer=True), required=True),
    "product": Field(Str(expected="the product name"), required=True),
    "description": Field(Str(), default=""),
    "units": Field(UNITS, default=None),
    "placement": Field(POSE, default=None),
    "materials": Field(_MaterialTable(), default={}),
    "parts": Field(ListOf(PART, min_len=1), required=True),
    "mates": Field(ListOf(MATE), default=[]),
    "default_fits": Field(ListOf(DEFAULT_FIT), default=None),
    "precedence": Field(PRECEDENCE, default=None),
    "process": Field(PROCESS, default=None),
    "resources": Field(RESOURCES, required=True),
}, name="a product")

# ---------------------------------------------------------------------------------------------
# Building the model
# ---------------------------------------------------------------------------------------------


def load_product(path: Path | str, *, display_name: str | None = None,
                 consistency: bool = True) -> Product:
    """Read, validate and convert a product file.

    Parameters
    ----------
    path : path to the YAML file. Mesh files it names are resolved relative to its folder.
    display_name : how to name the file in messages (default: ``path`` as given).
    consistency : also refuse contradictions between valid values (a pin off its hole's
        axis, a hole outside its part...; :mod:`asmplan.knowledge.consistency`). Turn off
        only to study such a product with the measuring checks of :mod:`asmplan.parts`.

    Raises
    ------
    ProductError
        With every problem found, each with file, line, column, key path, expected and found.
    """
    doc = load_located(path, display_name)
    return build_product(doc, Path(path).resolve().parent, consistency=consistency)


def build_robot(r: dict[str, Any], base_dir: Path,
                err: Callable[[PathKey, str], None]) -> Robot | None:
    """The cell's arm from the checked ``resources.robot`` mapping: resolve and read the
    URDF (:mod:`asmplan.knowledge.robot`), apply the joint-limit overrides. Problems go to
    ``err`` with their key path; returns None then."""
    where = ("resources", "robot")
    try:
        urdf = read_urdf_arm(resolve_model(r["model"], base_dir), r["flange"])
    except UrdfError as exc:
        err((*where, "flange" if r["flange"] and "flange" in str(exc) else "model"), str(exc))
        return None
    by_name = {j.name: j for j in urdf.joints}
    joints = dict(by_name)
    ok = True
    for name, o in r["joints"].items():
        if name not in by_name:
            err((*where, "joints", name), f'expected a joint of the arm ({", ".join(by_name)}), '
                f'found "{name}"{did_you_mean(name, by_name)}')
            ok = False
            continue
        j = by_name[name]
        lo = j.lower_rad if o["lower"] is None else o["lower"]
        hi = j.upper_rad if o["upper"] is None else o["upper"]
        if not lo < hi:
            err((*where, "joints", name), f"expected lower < upper, found {math.degrees(lo):g} "
                f">= {math.degrees(hi):g} deg")
            ok = False
            continue
        joints[name] = JointLimit(name, lo, hi, o["velocity"] or j.velocity_rad_s,
                                  o["acceleration"] or j.acceleration_rad_s2)
    if not ok:
        return None
    return Robot(r["model"], _pose(r["base"]), r["reach"], urdf_path=urdf.path,
                 T_flange_tcp=_pose(r["mounting"]), flange_link=urdf.flange_link,
                 joints=tuple(joints[j.name] for j in urdf.joints))


def _pose(v: dict[str, Any] | None) -> np.ndarray:
    return np.eye(4) if v is None else make_T(v["xyz"], v["rpy"])


def _unit(v: Any) -> np.ndarray:
    """Unit vector along ``v`` (non-zero, finite), without overflow for huge components."""
    a = np.asarray(v, dtype=float)
    a = a / np.max(np.abs(a))
    return a / np.linalg.norm(a)


class _Builder:
    def __init__(self, doc: Located, base_dir: Path, consistency: bool = True):
        self.consistency = consistency
        self.doc = doc
        self.base_dir = base_dir
        self.ctx = Context(doc, {})
        self.feature_paths: dict[tuple[str, str], PathKey] = {}
        self.mate_paths: dict[str, PathKey] = {}

    # -- helpers ---------------------------------------------------------------------------
    def err(self, path: PathKey, message: str, *, key: bool = False) -> None:
        self.ctx.error(path, message, key=key)

    def setup_units(self, data: dict[str, Any]) -> None:
        """The document's unit scales and names (``units:``), into the context."""
        units = UNITS.check(data.get("units") or {}, ("units",), self.ctx) if "units" in data else \
            {"length": "mm", "mass": "kg", "angle": "deg"}
        if units is INVALID:
            units = {"length": "mm", "mass": "kg", "angle": "deg"}
            raw_units: dict[str, Any] = data["units"] if isinstance(data.get("units"), dict) else {}
            units.update({k: v for k, v in raw_units.items()
                          if isinstance(v, str) and v in {**LENGTH_UNITS, **MASS_UNITS, **ANGLE_UNITS}})
        L = LENGTH_UNITS.get(units["length"], 1e-3)
        self.ctx.scales = {"length": L, "mass": MASS_UNITS.get(units["mass"], 1.0),
                           "angle": ANGLE_UNITS.get(units["angle"], math.pi / 180), "speed": L,
                           "acceleration": L}
        length_name = units["length"] if units["length"] in LENGTH_UNITS else "mm"
        self.ctx.unit_names.update(
            length=length_name, speed=f"{length_name}/s", acceleration=f"{length_name}/s^2",
            mass=units["mass"] if units["mass"] in MASS_UNITS else "kg",
            angle=units["angle"] if units["angle"] in ANGLE_UNITS else "deg")

    # Complexity above C (radon): the loader's top level: every section of the file is read in order
    # and every issue collected (units, header, materials, resources, parts, mates, consistency).
    def run(self) -> Product:
        data = self.doc.data
        if not isinstance(data, dict):
            raise ProductError([self.doc.issue((), "expected a YAML mapping at the top level "
                                               "(asmplan, product, parts, ...), found "
                                               f"{type(data).__name__}")])
        self.setup_units(data)
        top, _ = DOCUMENT.check_partial(data, (), self.ctx)
        if top is INVALID:
            raise ProductError(self.ctx.issues)
        if isinstance(top.get("asmplan"), int) and top["asmplan"] != FORMAT_VERSION:
            self.err(("asmplan",), f"expected format version {FORMAT_VERSION}, found {top['asmplan']}")

        materials = dict(builtin_materials())
        for name, m in (top.get("materials") or {}).items() if top.get("materials") else []:
            if m is not INVALID:
                E = m["elastic_modulus_gpa"]
                materials[name] = Material(name, m["density"], m["friction"],
                                           tuple(m["color"]) if m["color"] else (0.7, 0.7, 0.7),
                                           None if E is None else E * 1e9, m["poisson_ratio"])
        raw_parts: list[Any] = data["parts"] if isinstance(data.get("parts"), list) else []
        # every part name written down, even in a part that is otherwise invalid, so that
        # cross-references to it are not reported as unknown on top of the real error
        self.all_names: list[str] = [p["name"] for p in raw_parts if isinstance(p, dict)
                                     and isinstance(p.get("name"), str)]
        self.known_names = set(self.all_names)
        parts = self.build_parts(raw_parts, materials)
        gripper_etc = top.get("resources")
        process = self.build_process(top.get("process"))
        resources = self.build_resources(gripper_etc) if gripper_etc else None
        self.default_fits = self.build_default_fits(top.get("default_fits"), data.get("default_fits"))
        mates = self.build_mates(data.get("mates"), parts)
        precedence = self.build_precedence(top.get("precedence"), data.get("precedence"))
        if resources is not None:
            for i, fx in enumerate(resources.fixtures):
                self.check_part_ref(fx.holds, ("resources", "fixtures", i, "holds"))
            known = [f.name for f in resources.gripper.fingers]
            for i, raw in enumerate(raw_parts):
                h = raw.get("handling") if isinstance(raw, dict) else None
                finger = h.get("finger") if isinstance(h, dict) else None
                if isinstance(finger, str) and finger not in known:
                    names = ", ".join(known) or "none declared in resources.gripper.fingers"
                    self.err(("parts", i, "handling", "finger"),
                             f"expected one of the gripper's fingers ({names}), found "
                             f'"{finger}"{did_you_mean(finger, known)}')
        if self.ctx.issues:
            raise ProductError(self.ctx.issues)
        assert resources is not None  # a missing resources section is an issue above
        product = Product(
            name=top["product"], source=Path(self.doc.file), parts=tuple(parts.values()),
            mates=tuple(mates), precedence=precedence, process=process, resources=resources,
            T_world_product=_pose(top.get("placement")), description=top.get("description") or "",
            default_fits=self.default_fits or (),
        )
        if self.consistency:
            for found in find_inconsistencies(product):
                if found.subject[0] == "feature":
                    where = self.feature_paths[(found.subject[1], found.subject[2])]
                else:
                    where = self.mate_paths[found.subject[1]]
                self.err((*where, found.key) if found.key else where, found.message)
            if self.ctx.issues:
                raise ProductError(self.ctx.issues)
        return product

    # -- parts -----------------------------------------------------------------------------
    def build_parts(self, raw_parts: list[Any], materials: dict[str, Material]) -> dict[str, Part]:
        parts: dict[str, Part] = {}
        first_line: dict[str, int] = {}
        for i, raw in enumerate(raw_parts):
            path: PathKey = ("parts", i)
            v = PART.check(raw, path, self.ctx)
            name = raw.get("name") if isinstance(raw, dict) else None
            if isinstance(name, str):
                if name in first_line:
                    self.err((*path, "name"), f'duplicate part name "{name}" (first defined on '
                             f"line {first_line[name]})")
                    continue
                first_line[name] = self.doc.where((*path, "name"))[0]
                if "." in name:
                    self.err((*path, "name"), f'expected a part name without ".", found "{name}"')
                    continue
            if v is INVALID:
                # still report an unknown material of a part that has other errors too
                if isinstance(raw, dict) and isinstance(raw.get("material"), str):
                    self.material(raw["material"], (*path, "material"), materials)
                continue
            part = self.build_part(v, path, materials)
            if part is not None:
                parts[part.name] = part
        return parts

    def build_part(self, v: dict[str, Any], path: PathKey, materials: dict[str, Material]
                   ) -> Part | None:
        name = v["name"]
        material = None
        if v["material"] is not None:
            material = self.material(v["material"], (*path, "material"), materials)
            if material is None:
                return None
        elif v["mass"] is None:
            self.err(path, 'expected "material" (to compute the mass) or "mass", found neither')
            return None
        friction = v["friction"] if v["friction"] is not None else (
            material.friction if material else 0.6)
        color = tuple(v["color"]) if v["color"] else (material.color_rgb if material else (0.7, 0.7, 0.7))
        geometry = self.build_geometry(v["geometry"], (*path, "geometry"), name)
        if geometry is None:
            return None
        features = self.build_features(name, v, geometry, path)
        if features is None:
            return None
        T_product_part = _pose(v["pose"])
        if v["start"] is None:
            T_world_start, location = None, "table"
        else:
            T_world_start, location = _pose(v["start"]), v["start"]["location"]
        handling = self.build_handling(v["handling"])
        return Part(name=name, geometry=geometry, T_product_part=T_product_part,
                    T_world_start=T_world_start if T_world_start is not None else np.full((4, 4), np.nan),
                    start_location=location, material=material, mass_kg=v["mass"],
                    friction=friction, color_rgb=color, features=features, handling=handling,
                    fixtured=v["fixtured"])

    def material(self, name: str, path: PathKey, materials: dict[str, Material]) -> Material | None:
        if name in materials:
            return materials[name]
        self.err(path, f'unknown material "{name}"{did_you_mean(name, materials)}; known materials: '
                 f"{', '.join(sorted(materials))}")
        return None

    # Complexity above C (radon): one branch per geometry type (mesh, box, cylinder, sphere,
    # compound) and per hole or pin check, each with its own message.
    def build_geometry(self, g: dict[str, Any], path: PathKey, part: str) -> Geometry | None:
        kind = g["type"]
        if kind == "mesh":
            file = Path(g["file"])
            full = file if file.is_absolute() else self.base_dir / file
            if not full.is_file():
                self.err((*path, "file"), f'mesh file not found: expected a file at "{full}"')
                return None
            if full.suffix.lower() not in (".stl", ".obj", ".ply", ".step", ".stp", ".glb", ".off"):
                self.err((*path, "file"), f'expected an STL, OBJ, PLY, OFF, GLB or STEP file, found '
                         f'"{full.suffix}"')
                return None
            scale = LENGTH_UNITS[g["units"]] if g["units"] else self.ctx.scales["length"]
            if g.get("body") is not None and full.suffix.lower() not in (".step", ".stp"):
                self.err((*path, "body"), f'expected "body" only with a multi-body STEP file, found a '
                         f'{full.suffix} file', key=True)
                return None
            return Geometry(kind="mesh", mesh_file=full, mesh_scale=scale, mesh_body=g.get("body"))
        prims: tuple[Primitive, ...]
        if kind == "box":
            prims = (Primitive("box", np.eye(4), size_m=tuple(g["size"])),)
        elif kind == "cylinder":
            prims = (Primitive("cylinder", np.eye(4), diameter_m=g["diameter"], length_m=g["length"]),)
        elif kind == "sphere":
            prims = (Primitive("sphere", np.eye(4), diameter_m=g["diameter"]),)
        else:
            prims = tuple(
                Primitive(c["shape"], _pose(c["pose"]), size_m=tuple(c.get("size") or (0, 0, 0)),
                          diameter_m=c.get("diameter") or 0.0, length_m=c.get("length") or 0.0)
                for c in g["children"])
        holes = tuple(HoleCut(h["name"], np.asarray(h["at"]), _unit(h["axis"]), h["diameter"],
                              h["depth"] or 0.0, h["through"], h["chamfer"])
                      for h in g.get("holes") or [])
        pins = tuple(PinAdd(p["name"], np.asarray(p["at"]), _unit(p["axis"]), p["diameter"],
                            p["length"], p["chamfer"]) for p in g.get("pins") or [])
        ok = True
        for i, h in enumerate(holes):
            if h.chamfer_m * 2 >= h.diameter_m:
                ok = False
                self.err((*path, "holes", i, "chamfer"), f"expected a chamfer smaller than the "
                         f"radius {h.diameter_m / 2 * 1e3:g} mm, found {h.chamfer_m * 1e3:g} mm")
            elif not h.through and h.chamfer_m >= h.depth_m:
                ok = False
                self.err((*path, "holes", i, "chamfer"), f"expected a chamfer shallower than the "
                         f"hole's depth {h.depth_m * 1e3:g} mm, found {h.chamfer_m * 1e3:g} mm")
        for i, p in enumerate(pins):
            if p.chamfer_m * 2 >= p.diameter_m:
                ok = False
                self.err((*path, "pins", i, "chamfer"), f"expected a chamfer smaller than the "
                         f"radius {p.diameter_m / 2 * 1e3:g} mm, found {p.chamfer_m * 1e3:g} mm")
        return Geometry(kind=kind, primitives=prims, holes=holes, pins=pins) if ok else None

    def build_features(self, part: str, v: dict[str, Any], geometry: Geometry, path: PathKey
                       ) -> tuple[Feature, ...] | None:
        features: list[Feature] = []
        where: dict[str, PathKey] = {}
        ok = True

        def add(f: Feature, fpath: PathKey) -> None:
            nonlocal ok
            if f.name in where:
                ok = False
                self.err((*fpath, "name"), f'duplicate feature name "{f.name}" in part "{part}" '
                         f"(first defined on line {self.doc.where((*where[f.name], 'name'))[0]})")
                return
            where[f.name] = fpath
            self.feature_paths[(part, f.name)] = fpath
            features.append(f)

        for i, h in enumerate(geometry.holes):
            add(Feature(part, h.feature, "hole", h.origin_m, h.axis, h.diameter_m, h.depth_m,
                        h.chamfer_m, h.through), (*path, "geometry", "holes", i))
        for i, p in enumerate(geometry.pins):
            add(Feature(part, p.feature, "pin", p.origin_m, p.axis, p.diameter_m, p.length_m,
                        p.chamfer_m), (*path, "geometry", "pins", i))
        for i, f in enumerate(v["features"]):
            fpath = (*path, "features", i)
            male = f["type"] in MALE_KINDS
            length = f["length"] if male else f["depth"]
            if length is None and not (f["through"] and not male):
                ok = False
                need = "length" if male else "depth"
                self.err(fpath, f'missing required key "{need}" for a {f["type"]} (a positive length)')
                continue
            wrong = "depth" if male else "length"
            if f[wrong] is not None:
                ok = False
                right = "length" if male else "depth"
                self.err((*fpath, wrong), f'a {f["type"]} has a "{right}", not a "{wrong}"', key=True)
                continue
            add(Feature(part, f["name"], f["type"], np.asarray(f["at"]), _unit(f["axis"]),
                        f["diameter"], length or 0.0, f["chamfer"], f["through"]), fpath)
        return tuple(features) if ok else None

    def build_handling(self, h: dict[str, Any] | None) -> Handling:
        if h is None:
            return Handling()
        grasp = None
        if h["grasp"] is not None:
            g = h["grasp"]
            grasp = GraspHint(closing_axis=_unit(g["closing_axis"]) if g["closing_axis"] else None,
                              approach_axis=_unit(g["approach_axis"]) if g["approach_axis"] else None,
                              width_m=g["width"],
                              offset_m=np.asarray(g["offset"]) if g["offset"] else None)
        return Handling(
            insertion_direction=_unit(h["insertion_direction"]) if h["insertion_direction"] else None,
            grasp=grasp, max_clamp_force_N=h["max_clamp_force"], max_speed_m_s=h["max_speed"],
            max_acceleration_m_s2=h["max_acceleration"], finger=h["finger"])

    # -- knowledge and resources -----------------------------------------------------------
    def build_process(self, v: dict[str, Any] | None) -> Process:
        if not v:
            return Process()
        names = {"max_speed": "max_speed_m_s", "max_acceleration": "max_acceleration_m_s2",
                 "insertion_speed": "insertion_speed_m_s", "max_insertion_force": "max_insertion_force_N",
                 "insertion_resistance": "insertion_resistance_N",
                 "lift_height": "lift_height_m", "approach_distance": "approach_distance_m",
                 "position_tolerance": "position_tolerance_m", "max_slip": "max_slip_m"}
        return Process(**{names.get(k, k): val for k, val in v.items()
                          if val is not None and val is not INVALID})

    def build_resources(self, v: dict[str, Any]) -> Resources | None:
        if any(v.get(k) is INVALID for k in ("gripper", "table", "fixtures", "robot", "press", "units")):
            return None
        # the cell's own units (resources.units) were applied while reading it (_CellMap)
        units = v.get("units") or {}
        self.check_cell_scale(v, bool(units.get("length")))
        g = v["gripper"]
        if g["min_force"] > g["max_force"]:
            self.err(("resources", "gripper", "min_force"), f"expected min_force <= max_force "
                     f"({g['max_force']:g} N), found {g['min_force']:g} N")
        gripper = Gripper(stroke_m=g["stroke"], finger_size_m=np.asarray(g["finger"]["size"]),
                          finger_friction=g["finger"]["friction"], max_force_N=g["max_force"],
                          min_force_N=g["min_force"], mass_kg=g["mass"] or 0.5,
                          fingers=tuple(Finger(f["name"], np.asarray(f["size"]), f["friction"])
                                        for f in g["fingers"]))
        seen: dict[str, int] = {}
        for i, f in enumerate(g["fingers"]):
            if f["name"] in seen:
                self.err(("resources", "gripper", "fingers", i, "name"),
                         f'expected a unique finger name, found "{f["name"]}" again (fingers['
                         f'{seen[f["name"]]}])')
            seen.setdefault(f["name"], i)
        table = Table(np.asarray(v["table"]["size"]), v["table"]["friction"])
        fixtures = tuple(Fixture(f["name"], f["holds"], f["kind"]) for f in v["fixtures"])
        robot = build_robot(v["robot"], self.base_dir, self.err) if v["robot"] else None
        press = Press(float(v["press"]["max_force"])) if v.get("press") else None
        return Resources(gripper, table, fixtures, robot, press=press)

    def check_cell_scale(self, v: dict[str, Any], own_units: bool) -> None:
        """A gripper stroke or a table out of any real cell's range means the product's length
        unit was applied to the cell by mistake (a product in cm: an 85 cm stroke, an 8 m table):
        an input error naming the value in mm, never a silent rescale."""
        unit = [k for k, s in LENGTH_UNITS.items() if s == self.ctx.scales["length"]]
        hint = ("" if own_units else f"; the document's length unit ({unit[0] if unit else '?'}) "
                "applies to resources unless they give their own: resources.units: {length: mm}")
        stroke = v["gripper"]["stroke"]
        if not 1e-3 <= stroke <= 0.5:
            self.err(("resources", "gripper", "stroke"), f"expected a gripper stroke of 1-500 mm, found "
                     f"{stroke * 1e3:.4g} mm{hint}")
        size = max(v["table"]["size"][:2])
        if not 0.05 <= size <= 20.0:  # 20 m: a long transfer line (a 2,000-part tray layout is 10.6 m)
            self.err(("resources", "table", "size"), f"expected a table of 50 mm to 20 m, found "
                     f"{size * 1e3:.4g} mm across{hint}")

    def check_part_ref(self, name: str, path: PathKey) -> bool:
        if name in self.known_names:
            return True
        self.err(path, f'unknown part "{name}"{did_you_mean(name, self.all_names)}; known parts: '
                 f'{", ".join(sorted(self.all_names))}')
        return False

    def build_mates(self, raw: Any, parts: dict[str, Part]) -> list[Mate]:
        mm_per_m = 1e3
        mates: list[Mate] = []
        if not isinstance(raw, list):
            return mates
        names: dict[str, int] = {}
        for i, item in enumerate(raw):
            path: PathKey = ("mates", i)
            v = MATE.check(item, path, self.ctx)
            if v is INVALID:
                continue
            pin = self.resolve_feature(v["pin"], (*path, "pin"), parts, MALE_KINDS)
            hole = self.resolve_feature(v["hole"], (*path, "hole"), parts, FEMALE_KINDS)
            if pin is None or hole is None:
                continue
            if pin.part == hole.part:
                self.err(path, "expected a pin and a hole on two different parts, found both on "
                         f'"{pin.part}"')
                continue
            name = v["name"] or f"{pin.ref}->{hole.ref}"
            if name in names:
                self.err((*path, "name"), f'duplicate mate name "{name}" (first on line {names[name]})')
                continue
            names[name] = self.doc.where(path)[0]
            self.mate_paths[name] = path
            given = [k for k in ("fit", "clearance", "interference") if v[k] is not None]
            if len(given) > 1:
                self.err((*path, given[1]), f"expected one of fit, clearance or interference, "
                         f"found {' and '.join(given)}", key=True)
                continue
            clearance = self.mate_clearance(v, path, pin, hole)
            if clearance is None:
                continue
            hub = v["hub_diameter"]
            if hub is not None and hub <= hole.diameter_m:
                self.err((*path, "hub_diameter"), f"expected a hub diameter larger than the hole "
                         f"{hole.ref} ({hole.diameter_m * mm_per_m:g} mm), found "
                         f"{hub * mm_per_m:g} mm")
                continue
            fit = iso286_normal(v["fit"]) if v["fit"] else self.defaulted.pop(path, None)
            mates.append(Mate(name, pin.part, pin.name, hole.part, hole.name, *clearance,
                              fit=fit, hub_diameter_m=hub))
        return mates

    def mate_clearance(self, v: dict[str, Any], path: PathKey, pin: Feature, hole: Feature
                       ) -> tuple[float, float] | None:
        mm = 1e3
        if v["fit"] is None and v["clearance"] is None and v["interference"] is None:
            if self.default_fits is not None and abs(pin.diameter_m - hole.diameter_m) <= 1e-9:
                return self.default_fit_clearance(path, pin, hole)
            c = hole.diameter_m - pin.diameter_m
            if c < 0:
                self.err(path, f"pin {pin.ref} ({pin.diameter_m * mm:g} mm) is larger than hole "
                         f"{hole.ref} ({hole.diameter_m * mm:g} mm); expected a clearance, or declare "
                         f'"interference" or an ISO "fit"')
                return None
            return c, c
        if abs(pin.diameter_m - hole.diameter_m) > 1e-9:
            key = next(k for k in ("fit", "clearance", "interference") if v[k] is not None)
            if key == "fit" and pin.diameter_m > hole.diameter_m:
                kind: str
                try:
                    kind = iso286.fit(v["fit"], hole.diameter_m).kind
                except iso286.FitError:
                    kind = "unknown"
                if kind == "clearance":
                    self.err((*path, "fit"), f"pin {pin.ref} ({pin.diameter_m * mm:g} mm) is larger "
                             f"than hole {hole.ref} ({hole.diameter_m * mm:g} mm) under the clearance "
                             f'fit "{v["fit"]}"; expected equal nominal diameters')
                    return None
            self.err((*path, key), f"expected equal nominal diameters for a {key} (the {key} gives "
                     f"the deviation), found pin {pin.ref} {pin.diameter_m * mm:g} mm and hole "
                     f"{hole.ref} {hole.diameter_m * mm:g} mm", key=True)
            return None
        if v["fit"] is not None:
            try:
                f = iso286.fit(v["fit"], hole.diameter_m)
            except iso286.FitError as exc:
                self.err((*path, "fit"), f'invalid ISO 286 fit "{v["fit"]}" at '
                         f"{hole.diameter_m * mm:g} mm: {exc}")
                return None
            return f.clearance_min_m, f.clearance_max_m
        if v["interference"] is not None:
            return -v["interference"], -v["interference"]
        c = v["clearance"]
        if isinstance(c, dict):
            if c["min"] > c["max"]:
                self.err((*path, "clearance"), f"expected min <= max, found min {c['min'] * mm:g} mm "
                         f"> max {c['max'] * mm:g} mm")
                return None
            return c["min"], c["max"]
        return c, c

    def build_default_fits(self, raw: Any, data: Any) -> tuple[FitRule, ...] | None:
        """The product's ``default_fits`` rules (None without the key). Each fit must be a
        valid ISO 286 fit over the rule's whole size range (checked at its ends)."""
        self.defaulted: dict[PathKey, str] = {}
        if raw is None:
            return None
        if raw is INVALID:  # one rule failed its schema (reported): check the others too
            if not isinstance(data, list):
                return None
            quiet = Context(self.doc, self.ctx.scales, unit_names=self.ctx.unit_names)
            raw = [DEFAULT_FIT.check(r, ("default_fits", i), quiet) for i, r in enumerate(data)]
        rules: list[FitRule] = []
        for i, r in enumerate(raw):
            if r is INVALID:
                continue
            path: PathKey = ("default_fits", i)
            lo, hi = r["min_diameter"], r["max_diameter"]
            if lo >= hi:
                self.err((*path, "min_diameter"), f"expected min_diameter < max_diameter, found "
                         f"{lo * 1e3:g} mm >= {hi * 1e3:g} mm")
                continue
            try:
                for d in (hi, max(lo * (1 + 1e-9), min(hi, 1e-3))):
                    iso286.fit(r["fit"], d)
            except iso286.FitError as exc:
                self.err((*path, "fit"), f'expected an ISO 286 fit valid from {lo * 1e3:g} to '
                         f'{hi * 1e3:g} mm, found "{r["fit"]}": {exc}')
                continue
            rules.append(FitRule(r["male"], r["female"], hi, iso286_normal(r["fit"]), r["why"],
                                 lo, source=f"{self.doc.file}:{self.doc.where(path)[0]}"))
        return tuple(rules)

    def default_fit_clearance(self, path: PathKey, pin: Feature, hole: Feature
                              ) -> tuple[float, float] | None:
        """A line-to-line mate without a fit, with ``default_fits`` given: the first matching
        rule of the product's, then the built-in rules (:mod:`asmplan.knowledge.fit_rules`)."""
        rules = (*(self.default_fits or ()), *builtin_rules())
        rule = default_fit(pin.kind, hole.kind, hole.diameter_m, rules)
        if rule is None:
            self.err(path, f"expected a fit: no default_fits rule matches {pin.kind} {pin.ref} in "
                     f"{hole.kind} {hole.ref} at {hole.diameter_m * 1e3:g} mm (line to line)")
            return None
        try:
            f = iso286.fit(rule.fit, hole.diameter_m)
        except iso286.FitError as exc:
            self.err(path, f'default fit "{rule.fit}" ({rule.source}) at {hole.diameter_m * 1e3:g} mm: {exc}')
            return None
        self.defaulted[path] = rule.fit
        return f.clearance_min_m, f.clearance_max_m

    def resolve_feature(self, ref: str, path: PathKey, parts: dict[str, Part],
                        kinds: tuple[str, ...]) -> Feature | None:
        if ref.count(".") != 1:
            self.err(path, f'expected a feature reference "part.feature", found "{ref}"')
            return None
        part_name, feat = ref.split(".")
        if not self.check_part_ref(part_name, path):
            return None
        part = parts.get(part_name)
        if part is None:  # the part itself is invalid; its error is reported already
            return None
        names = [f.name for f in part.features]
        if feat not in names:
            self.err(path, f'unknown feature "{feat}" on part "{part_name}"{did_you_mean(feat, names)}'
                     f'; its features: {", ".join(names) or "none"}')
            return None
        f = part.feature(feat)
        if f.kind not in kinds:
            self.err(path, f"expected a {' or '.join(kinds)}, found {ref} which is a {f.kind}")
            return None
        return f

    def build_precedence(self, v: dict[str, Any] | None, raw: Any) -> Precedence:
        if not v:
            return Precedence(base=None)
        base = v.get("base")
        if base not in (None, INVALID):
            self.check_part_ref(base, ("precedence", "base"))
        rules: list[PrecedenceRule] = []
        graph: nx.DiGraph[str] = nx.DiGraph()
        for i, r in enumerate(v.get("rules") or []):
            path: PathKey = ("precedence", "rules", i)
            ok = self.check_part_ref(r["before"], (*path, "before"))
            ok = self.check_part_ref(r["after"], (*path, "after")) and ok
            if ok and r["before"] == r["after"]:
                self.err((*path, "after"), "expected two different parts, found "
                         f'"{r["after"]}" before itself')
                ok = False
            if ok:
                line = self.doc.where(path)[0]
                rules.append(PrecedenceRule(r["before"], r["after"], r["reason"], line))
                graph.add_edge(r["before"], r["after"], index=i, line=line)
        groups: list[AssemblyGroup] = []
        for i, g in enumerate(v.get("groups") or []):
            ok = all([self.check_part_ref(p, ("precedence", "groups", i, "parts", j))
                      for j, p in enumerate(g["parts"])])
            if ok:
                groups.append(AssemblyGroup(tuple(g["parts"]), g["reason"]))
        try:
            cycle = nx.find_cycle(graph)
        except nx.NetworkXNoCycle:
            cycle = None
        if cycle:
            names = " -> ".join([cycle[0][0], *(e[1] for e in cycle)])
            lines = ", ".join(str(graph.edges[e]["line"]) for e in cycle)
            first = min(graph.edges[e]["index"] for e in cycle)
            self.err(("precedence", "rules", first), f"precedence rules form a cycle: {names} "
                     f"(rules on lines {lines}); expected an order that can be met")
        return Precedence(base=base if base is not INVALID else None, rules=tuple(rules),
                          groups=tuple(groups))


def load_default_fits(path: Path | str) -> tuple[FitRule, ...]:
    """The ``default_fits`` rules of a YAML file (a product file, or a file holding only
    ``units:`` and ``default_fits:``), for ``asmplan import --default-fits``.

    Raises
    ------
    ProductError
        With every problem found (file, line, key path, expected and found).
    """
    doc = load_located(path)
    b = _Builder(doc, Path(path).resolve().parent)
    data = doc.data
    if not isinstance(data, dict) or "default_fits" not in data:
        raise ProductError([doc.issue((), "expected a YAML mapping with a default_fits list")])
    b.setup_units(data)
    raw = ListOf(DEFAULT_FIT).check(data["default_fits"], ("default_fits",), b.ctx)
    rules = b.build_default_fits(raw, data["default_fits"])
    if b.ctx.issues:
        raise ProductError(b.ctx.issues)
    return rules or ()


def iso286_normal(designation: str) -> str:
    """Normalise ``"H7-g6"``/``"H7 g6"`` to ``"H7/g6"``."""
    for sep in ("-", " "):
        designation = designation.replace(sep, "/")
    return designation


def build_product(doc: Located, base_dir: Path, *, consistency: bool = True) -> Product:
    """Validate a parsed document and build the :class:`Product` (see :func:`load_product`)."""
    return _Builder(doc, base_dir, consistency).run()


__all__ = ["FORMAT_VERSION", "InputIssue", "ProductError", "build_product", "load_product"]
