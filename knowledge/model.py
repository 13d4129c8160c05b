"""The typed product model: what a product is, independent of where its parts are now.

Everything is SI (m, kg, s, N, rad) and frozen. Poses are ``(4, 4)`` arrays named
``T_<to>_<from>``: ``Part.T_product_part`` is the assembled pose in the product frame,
``Part.T_world_start`` the pose the part is picked from (tray, feeder, table), and
``Product.T_world_product`` where the assembled product sits on the table (world z = 0 is the
table top).

Feature frames: a feature's ``origin_m`` and ``axis`` are in the part frame. For a pin or
shaft the origin is the centre of its root (where it leaves the body) and the axis points
from root to tip. For a hole or bore the origin is the centre of its mouth and the axis is
the outward normal of the face it opens in. When a pin is seated in its hole, the pin axis is
opposite the hole axis and the pin root meets the hole mouth; the insertion direction of the
pin's part is therefore the pin axis in the world (= minus the hole axis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

import numpy as np

from .arrays import readonly_array
from .fit_rules import FitRule
from .materials import Material
from .robot import JointLimit

FeatureKind = Literal["pin", "shaft", "hole", "bore"]
MALE_KINDS = ("pin", "shaft")
FEMALE_KINDS = ("hole", "bore")


@dataclass(frozen=True, eq=False)
class Primitive:
    """A solid primitive placed in the part frame.

    ``shape`` box: ``size_m`` (3,) full extents, centred. cylinder: ``diameter_m`` and
    ``length_m`` along the local z axis, centred. sphere: ``diameter_m``.
    """

    shape: Literal["box", "cylinder", "sphere"]
    T_part_shape: np.ndarray
    size_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    diameter_m: float = 0.0
    length_m: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "T_part_shape", readonly_array(self.T_part_shape, (4, 4), "T_part_shape"))


@dataclass(frozen=True, eq=False)
class HoleCut:
    """A cylindrical hole cut into a part's primitives (becomes a ``hole`` feature)."""

    feature: str
    origin_m: np.ndarray
    axis: np.ndarray
    diameter_m: float
    depth_m: float
    through: bool
    chamfer_m: float


@dataclass(frozen=True, eq=False)
class PinAdd:
    """A cylindrical pin added to a part's primitives (becomes a ``pin`` feature)."""

    feature: str
    origin_m: np.ndarray
    axis: np.ndarray
    diameter_m: float
    length_m: float
    chamfer_m: float


@dataclass(frozen=True, eq=False)
class Geometry:
    """A part's shape: primitives (union) with holes cut and pins added, or a mesh file.

    ``kind`` is the YAML ``type`` (box, cylinder, composite, mesh). For ``mesh``,
    ``mesh_file`` is an absolute path and ``mesh_scale`` converts its units to metres;
    ``mesh_body`` names one body of a multi-body file (STEP), None for the whole file.
    """

    kind: Literal["box", "cylinder", "sphere", "composite", "mesh"]
    primitives: tuple[Primitive, ...] = ()
    holes: tuple[HoleCut, ...] = ()
    pins: tuple[PinAdd, ...] = ()
    mesh_file: Path | None = None
    mesh_scale: float = 1.0
    mesh_body: str | None = None


@dataclass(frozen=True, eq=False)
class Feature:
    """A mating feature of a part, in the part frame (see the module docstring)."""

    part: str
    name: str
    kind: FeatureKind
    origin_m: np.ndarray
    axis: np.ndarray
    diameter_m: float
    length_m: float  # pin/shaft length, hole/bore depth
    chamfer_m: float = 0.0
    through: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "origin_m", readonly_array(self.origin_m, (3,), "origin_m"))
        axis = np.asarray(self.axis, dtype=float)
        norm = float(np.linalg.norm(axis))
        if norm == 0:
            raise ValueError(f"feature {self.part}.{self.name}: axis must be non-zero")
        object.__setattr__(self, "axis", readonly_array(axis / norm, (3,), "axis"))

    @property
    def is_male(self) -> bool:
        return self.kind in MALE_KINDS

    @property
    def ref(self) -> str:
        return f"{self.part}.{self.name}"


@dataclass(frozen=True)
class Mate:
    """A pin (or shaft) seated in a hole (or bore), with its diametral clearance range.

    ``clearance_min_m``/``clearance_max_m`` are hole minus pin diameter; negative means
    interference. ``fit`` is the ISO 286 designation when one was given, or the default fit
    of a line-to-line mate written without one; ``fit_source`` then says which rule gave it
    (its file and line, and its reason). ``hub_diameter_m`` is the outer diameter of the hub
    around the hole when declared (press fits; otherwise it is measured on the hole part's
    solid, see :mod:`asmplan.parts.press_fit`).
    """

    name: str
    pin_part: str
    pin_feature: str
    hole_part: str
    hole_feature: str
    clearance_min_m: float
    clearance_max_m: float
    fit: str | None = None
    hub_diameter_m: float | None = None
    fit_source: str | None = None

    @property
    def kind(self) -> Literal["clearance", "transition", "interference"]:
        if self.clearance_min_m >= 0:
            return "clearance"
        if self.clearance_max_m <= 0:
            return "interference"
        return "transition"

    @property
    def clearance_mean_m(self) -> float:
        return 0.5 * (self.clearance_min_m + self.clearance_max_m)


@dataclass(frozen=True, eq=False)
class GraspHint:
    """Process knowledge on how to grip a part: the closing axis in the part frame, an
    optional finger opening and an offset of the grasp centre from the part origin."""

    closing_axis: np.ndarray | None = None
    approach_axis: np.ndarray | None = None
    width_m: float | None = None
    offset_m: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Handling:
    """Per-part process knowledge; ``None`` means "use the product-wide default"."""

    insertion_direction: np.ndarray | None = None
    grasp: GraspHint | None = None
    max_clamp_force_N: float | None = None
    max_speed_m_s: float | None = None
    max_acceleration_m_s2: float | None = None
    finger: str | None = None  # a named pad set of the gripper (``Gripper.fingers``)
    # placed by another operation ("press_tool", "manual", "fastening") at its place in the
    # sequence: no grasp, no path, not simulated; ``note`` says what that operation does
    operation: str | None = None
    note: str = ""


@dataclass(frozen=True, eq=False)
class Part:
    """One part of the product."""

    name: str
    geometry: Geometry
    T_product_part: np.ndarray
    T_world_start: np.ndarray
    start_location: str
    material: Material | None
    mass_kg: float | None
    friction: float
    color_rgb: tuple[float, float, float]
    features: tuple[Feature, ...]
    handling: Handling = field(default_factory=Handling)
    fixtured: bool = False

    def feature(self, name: str) -> Feature:
        for f in self.features:
            if f.name == name:
                return f
        raise KeyError(f'part "{self.name}" has no feature "{name}"; it has: '
                       f'{", ".join(f.name for f in self.features) or "none"}')


@dataclass(frozen=True)
class PrecedenceRule:
    """Knowledge: ``before`` must be assembled before ``after``, for ``reason``."""

    before: str
    after: str
    reason: str
    source_line: int = 0


@dataclass(frozen=True)
class AssemblyGroup:
    """Knowledge: these parts are assembled one right after another."""

    parts: tuple[str, ...]
    reason: str


@dataclass(frozen=True)
class Precedence:
    base: str | None
    rules: tuple[PrecedenceRule, ...] = ()
    groups: tuple[AssemblyGroup, ...] = ()


@dataclass(frozen=True)
class Process:
    """Product-wide process knowledge, SI."""

    safety_factor: float = 2.0
    max_speed_m_s: float = 0.25
    max_acceleration_m_s2: float = 2.0
    insertion_speed_m_s: float = 0.01
    max_insertion_force_N: float = 50.0
    insertion_resistance_N: float = 0.0
    lift_height_m: float = 0.05
    approach_distance_m: float = 0.02
    position_tolerance_m: float = 0.5e-3
    max_slip_m: float = 1.0e-3


@dataclass(frozen=True)
class Groove:
    """A V-groove (prism) cut into a pad's contact face along the pad's length (gripper z):
    included angle ``angle_rad`` (0 < angle < pi) and depth ``depth_m`` below the face.

    A round part whose axis lies along the groove touches each flank along a line; the
    flank's normal force is ``F / (2 sin(angle / 2))`` for a squeeze ``F``, and the two lines
    lie ``R cos(angle / 2)`` either side of the closing axis (``R`` the part's radius), so
    they resist a moment about the closing axis with that lever (prism jaws centre a shaft
    and hold it against turning in the grip; a flat pad on a round part touches one line).
    """

    angle_rad: float
    depth_m: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.angle_rad) and 0.0 < self.angle_rad < math.pi):
            raise ValueError(f"Groove.angle_rad: expected within (0, pi), found {self.angle_rad!r}")
        if not (math.isfinite(self.depth_m) and self.depth_m > 0.0):
            raise ValueError(f"Groove.depth_m: expected > 0, found {self.depth_m!r}")

    @property
    def half_width_m(self) -> float:
        """Half the groove's width at the pad face, ``depth tan(angle / 2)``, m."""
        return self.depth_m * math.tan(0.5 * self.angle_rad)

    @property
    def flank_sin(self) -> float:
        """``sin(angle / 2)``: the squeeze per unit normal force on one flank, / 2."""
        return math.sin(0.5 * self.angle_rad)


@dataclass(frozen=True, eq=False)
class Finger:
    """A named set of finger pads the gripper can be fitted with (a short pad for small parts,
    a long one for deep reaches, prism jaws for shafts): size (width x, thickness y, length z,
    m), friction and an optional V-groove (:class:`Groove`)."""

    name: str
    size_m: np.ndarray
    friction: float
    groove: Groove | None = None


@dataclass(frozen=True, eq=False)
class Gripper:
    """A parallel two-finger gripper. ``stroke_m`` is the largest opening between the pads;
    ``finger_size_m`` is (width along x, thickness along the closing axis, length along z).
    ``fingers`` are alternative pad sets a part's handling may choose by name
    (:meth:`Product.gripper_for`); ``finger_name`` names the pads fitted ("" = the default);
    ``finger_groove`` is the fitted pads' V-groove (None: flat pads)."""

    stroke_m: float
    finger_size_m: np.ndarray
    finger_friction: float
    max_force_N: float
    min_force_N: float = 0.0
    mass_kg: float = 0.5
    palm_size_m: np.ndarray = field(default_factory=lambda: np.array([0.04, 0.1, 0.03]))
    fingers: tuple[Finger, ...] = ()
    finger_name: str = ""
    finger_groove: Groove | None = None

    def with_finger(self, name: str) -> Gripper:
        """This gripper fitted with the pad set ``name`` (KeyError naming the known ones)."""
        for f in self.fingers:
            if f.name == name:
                return replace(self, finger_size_m=np.asarray(f.size_m, float),
                               finger_friction=float(f.friction), finger_name=f.name,
                               finger_groove=f.groove)
        raise KeyError(f'gripper has no finger "{name}"; it has: '
                       f'{", ".join(f.name for f in self.fingers) or "none"}')


@dataclass(frozen=True, eq=False)
class Table:
    """The work table; its top face is the world plane z = 0."""

    size_m: np.ndarray
    friction: float = 0.5


@dataclass(frozen=True)
class Fixture:
    name: str
    holds: str
    kind: str = "vise"


@dataclass(frozen=True, eq=False)
class Robot:
    """The cell's arm (see :mod:`asmplan.knowledge.robot`).

    Parameters
    ----------
    model : str
        As written in the product file (a bundled name or a URDF path).
    T_world_base : (4, 4) float array
        Pose of the URDF's root link in the world (table top centre, z up).
    reach_m : float or None
        The stated reach (distance from the shoulder to the flange); None: measured from
        the URDF by the planner.
    urdf_path : Path or None
        The resolved URDF file (None only for hand-built products without an arm file).
    T_flange_tcp : (4, 4) float array
        The gripper's TCP in the flange frame (the mounting: adapter plate and gripper
        length); TCP frame as in :mod:`asmplan.planner.trajectory` (z approach).
    flange_link : str
        The URDF link the gripper is mounted on.
    joints : tuple of JointLimit
        Position, velocity and acceleration limits, URDF values overridden by the file.
    """

    model: str
    T_world_base: np.ndarray
    reach_m: float | None
    urdf_path: Path | None = None
    T_flange_tcp: np.ndarray = field(default_factory=lambda: np.eye(4))
    flange_link: str = ""
    joints: tuple[JointLimit, ...] = ()


@dataclass(frozen=True)
class Press:
    """An axial press in the cell: ``max_force_N`` is the largest force its ram applies.

    With a press, a step whose mate needs more force than the gripper can push is a press
    operation (see :mod:`asmplan.planner.press`)."""

    max_force_N: float

    def __post_init__(self) -> None:
        if not self.max_force_N > 0:
            raise ValueError(f"Press.max_force_N: expected > 0, found {self.max_force_N}")


@dataclass(frozen=True, eq=False)
class RegraspSeat:
    """Where a :class:`RegraspFixture` holds one part: ``T_fixture_part`` (4, 4), the part's
    pose in the fixture frame, m."""

    part: str
    T_fixture_part: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "T_fixture_part",
                           readonly_array(self.T_fixture_part, (4, 4), "T_fixture_part"))


@dataclass(frozen=True, eq=False)
class RegraspFixture:
    """A static fixture on the table that holds a part in an orientation the table cannot
    (a shaft standing upright in a sleeve holder, a cylinder in a V-block), used to put the
    part down and grasp it again (a regrasp, :mod:`asmplan.planner.regrasp`).

    Parameters
    ----------
    name : str
    T_world_fixture : (4, 4) float array
        The fixture frame on the table, m.
    primitives : tuple of Primitive
        Its solid (boxes, cylinders, spheres), fixture frame.
    seats : tuple of RegraspSeat
        The parts it holds and where.
    friction : float
    """

    name: str
    T_world_fixture: np.ndarray
    primitives: tuple[Primitive, ...]
    seats: tuple[RegraspSeat, ...]
    friction: float = 0.5

    def __post_init__(self) -> None:
        object.__setattr__(self, "T_world_fixture",
                           readonly_array(self.T_world_fixture, (4, 4), "T_world_fixture"))

    def T_world_seat(self, part: str) -> np.ndarray | None:
        """Where the fixture holds ``part``, world frame (4, 4), m; None if it does not."""
        for s in self.seats:
            if s.part == part:
                return np.asarray(self.T_world_fixture @ s.T_fixture_part)
        return None


@dataclass(frozen=True, eq=False)
class Resources:
    gripper: Gripper
    table: Table
    fixtures: tuple[Fixture, ...] = ()
    robot: Robot | None = None
    press: Press | None = None
    regrasp: tuple[RegraspFixture, ...] = ()
    """Declared regrasp fixtures (``resources.regrasp``)."""


@dataclass(frozen=True, eq=False)
class Product:
    """A validated product: parts, mates, knowledge and the cell's resources."""

    name: str
    source: Path
    parts: tuple[Part, ...]
    mates: tuple[Mate, ...]
    precedence: Precedence
    process: Process
    resources: Resources
    T_world_product: np.ndarray
    description: str = ""
    default_fits: tuple[FitRule, ...] = ()
    """The product's ``default_fits`` rules (the fit of a line-to-line mate without one)."""

    def part(self, name: str) -> Part:
        for p in self.parts:
            if p.name == name:
                return p
        raise KeyError(f'unknown part "{name}"; known parts: {", ".join(self.part_names)}')

    @property
    def part_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parts)

    def feature(self, part: str, name: str) -> Feature:
        return self.part(part).feature(name)

    def T_world_assembled(self, part: str) -> np.ndarray:
        """World pose (4, 4) of ``part`` in the assembled product."""
        return self.T_world_product @ self.part(part).T_product_part

    def gripper_for(self, part: str) -> Gripper:
        """The gripper as fitted for ``part``'s step: with the pad set its handling names
        (``handling.finger``), else the default pads."""
        name = self.part(part).handling.finger
        g = self.resources.gripper
        return g if name is None else g.with_finger(name)

    def placed_by(self, part: str) -> str | None:
        """The operation that places ``part`` instead of the gripper (``handling.operation``:
        press_tool, manual, fastening), or None for a gripper step."""
        return self.part(part).handling.operation

    def is_fixtured(self, part: str) -> bool:
        return self.part(part).fixtured or any(f.holds == part for f in self.resources.fixtures)
