"""The product file's schema: its units, and every section's keys, types, units and limits
(declared with :mod:`asmplan.knowledge.schema`), down to the whole document (:data:`DOCUMENT`).
The format is documented in ``docs/product-format.md``."""

from __future__ import annotations

import math
from typing import Any

from .schema import INVALID, Bool, Context, Field, ListOf, Map, Num, OneOf, Str, Tagged, Vec
from .yamlsource import PathKey

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
OPERATIONS = ("press_tool", "manual", "fastening")
_GRIPPER_HANDLING = ("grasp", "finger", "max_clamp_force", "max_speed", "max_acceleration")


def _operation_check(v: dict[str, Any], path: PathKey, ctx: Context) -> None:
    """A part placed by another operation has no gripper handling; a note needs an operation."""
    if v["operation"] is None:
        if v["note"] is not None:
            ctx.error((*path, "note"), 'a note describes "operation" (the operation that places '
                      'the part): expected "operation" beside it, found none')
        return
    for k in _GRIPPER_HANDLING:
        if v[k] is not None:
            ctx.error((*path, k), f'the part is placed by another operation ("operation: '
                      f'{v["operation"]}"), not by the gripper: expected no "{k}", found one')


HANDLING = Map({
    "operation": Field(Str(OPERATIONS)),
    "note": Field(Str(expected="what the operation does (e.g. the press tool and its force)")),
    "insertion_direction": Field(DIRECTION),
    "grasp": Field(GRASP),
    "max_clamp_force": Field(Num("force", positive=True)),
    "max_speed": Field(Num("speed", positive=True)),
    "max_acceleration": Field(Num("acceleration", positive=True)),
    "finger": Field(Str(expected="the name of one of the gripper's fingers")),
}, name="handling knowledge", check_fn=_operation_check)


def _part_check(v: dict[str, Any], path: PathKey, ctx: Context) -> None:
    h = v["handling"]
    if v["fixtured"] and isinstance(h, dict) and h.get("operation") is not None:
        ctx.error((*path, "handling", "operation"), 'a fixtured part is in place from the '
                  'start: expected no "operation" (placed by another operation) beside '
                  '"fixtured: true", found both')
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
}, name="a part", check_fn=_part_check)
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
GROOVE = Map({"angle": Field(Num("angle", positive=True), required=True),
               "depth": Field(Num("length", positive=True), required=True)},
              name="a V-groove (prism) pad: included angle and depth")
GRIPPER = Map({
    "type": Field(Str(("parallel",)), default="parallel"),
    "stroke": Field(Num("length", positive=True), required=True),
    "finger": Field(Map({"size": Field(Vec(3, "length", positive=True), required=True),
                         "friction": Field(Num(positive=True, maximum=10.0), required=True),
                         "groove": Field(GROOVE)},
                        name="finger"), required=True),
    "max_force": Field(Num("force", positive=True), required=True),
    "min_force": Field(Num("force", nonnegative=True), default=0.0),
    "mass": Field(Num("mass", positive=True)),
    "fingers": Field(ListOf(Map({"name": Field(Str(expected="a finger name"), required=True),
                                 "size": Field(Vec(3, "length", positive=True), required=True),
                                 "friction": Field(Num(positive=True, maximum=10.0),
                                                   required=True),
                                 "groove": Field(GROOVE)},
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


REGRASP_SEAT = Map({
    "part": Field(Str(expected="a part name"), required=True),
    "pose": Field(POSE, required=True),
}, name="a seat (the part and its pose in the fixture frame)")
REGRASP_FIXTURE = Map({
    "name": Field(Str(expected="a fixture name"), required=True),
    "pose": Field(POSE, required=True),
    "geometry": Field(ListOf(CHILD, min_len=1), required=True),
    "friction": Field(Num(nonnegative=True, maximum=10.0), default=0.5),
    "holds": Field(ListOf(REGRASP_SEAT, min_len=1), required=True),
}, name="a regrasp fixture (name, pose, geometry, holds)")
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
    "regrasp": Field(ListOf(REGRASP_FIXTURE), default=[]),
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
