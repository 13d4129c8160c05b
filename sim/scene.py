"""Which bodies one simulated step needs, at which level of detail, and why.

:func:`select_scene` decides, for one :class:`~asmplan.planner.plan.Step` of a plan, which
bodies go into its PyBullet world; :func:`build_scene` creates them in a
:class:`~asmplan.sim.bullet.BulletWorld`. The selection is a plain record
(:class:`StepScene`: one :class:`SceneBody` per body with its role, level, static/dynamic and
the reason, plus every part left out with the reason), so reports and tests can show it.

Roles
-----
``held``
    The part the step moves, at the step's start pose, dynamic.
``mate``
    A part already in place that the held part mates with (a pin of one in a hole of the
    other). Dynamic unless fixtured, so that the insertion pushes a real body (its reaction,
    friction and seating are physical, not those of an immovable wall); static when the
    fidelity's ``dynamic_partners`` is off (FAST).
``touching``
    A part already in place that the held part touches when seated (distance at most
    :attr:`SceneSettings.touch_tolerance_m`), without a mate. Dynamic or static as a mate.
``support``
    A part in place that touches a dynamic ``mate``/``touching`` body: what it rests on. Static
    (one level of dynamics: the bodies under the partner do not move).
``obstacle``
    Any other part (in place, or still waiting at its start pose) whose bounding box comes
    within :attr:`SceneSettings.include_margin_m` of the space swept by the held part and the
    open gripper over the whole trajectory. Static. Within
    :attr:`SceneSettings.near_margin_m` it gets the detailed level, beyond that the coarse
    one (one convex hull: bigger than the part, so a coarse obstacle can report a false
    contact, never miss one).
``table``
    The work table (top face z = 0), static, always present.
``nest``
    A static tray nest under the held part when it does not rest on the table with its
    largest downward face (e.g. pins pointing down hold it above the table): boxes under that
    face from the table top up to it, with pockets (``nest_clearance_m`` wide) around every
    piece that protrudes below the face, so the part rests flat until clamped.

Fixtured parts are static (mass 0: the fixture holds them); the fixture itself is not
modelled as a body. Everything else is left out.

Contact breaking distance
-------------------------
When the held part has fits with parts in place, at least one of those partners is dynamic,
and the smallest diametral clearance of the fits is one the fidelity resolves
(``Fidelity.min_resolvable_clearance_m``), the scene limits the distance at which PyBullet
creates and keeps a contact point between the held part and its dynamic fit partners to half
that clearance (:attr:`StepScene.contact_breaking_m`, applied by :func:`build_scene` through
:meth:`~asmplan.sim.bullet.BulletWorld.limit_contact_breaking_m`). At PyBullet's default
(0.02 of a body's bounding radius: 0.36 mm for gear_unit's 20 mm collar) a contact point found
between the collar's and the shaft's chamfers as the collar reached the shaft was kept, with
its 44 deg normal, while the collar slid on through its 40-85 um radial gap; the stale normal
then pushed the shaft, free in the bearing block's bore, 9 mm along (a phantom contact).
Limited to 40 um, the collar never touches the shaft and the shaft stays within 13 um.

The limit is not free, hence the conditions. With a shorter distance in every step (fraction
0.005, 0.002 or 0.001 at BALANCED) 6 to 8 of the 9 steps with H7/g6, H7/h6 or H8/f7 fits
(below BALANCED's resolution) in pinhole_station, peg_in_hole and gear_unit failed (the peg
stuck at the hole mouth and the fingers slid down it; slips of 3.9-9.2 mm, a 247 N seating
force). A peg with 0.15 mm clearance placed 0.3-0.5 mm off its hole's axis was guided in by
the 0.5 mm chamfers at the default and stuck on the seam between the chamfer's and the bore's
convex pieces with the limit (75 um); its block is fixtured, where a phantom contact only
resists the position-controlled gripper. Measured unchanged by the limit: the measurement
behind BALANCED's resolution (radial 50 and 25 um: inserted, interference blocked after 0.75
and 0.98 mm, at distances of 13-51 um) and the slip threshold of a grip.

Features that stay empty
------------------------
A hole that nothing enters during the step is modelled solid (:func:`empty_holes`): a hole
of a part waiting at its start pose, or one whose mating pin belongs to a part placed in a
later step. Its ring of convex pieces and their contacts leave the scene (a block whose
holes all wait becomes its exact box); holes no mate names are kept. Mass properties are
always those of the real part.

Whole product (``cull=False``, the baseline culling is measured against): every part of the
product is in the scene as the simulator would model it without selecting anything: parts
already placed at their assembled poses as DYNAMIC bodies resting on each other (pins in
holes; static when the fidelity's ``dynamic_partners`` is off, as the partners of a culled
scene), parts not yet placed at their start poses as DYNAMIC bodies on the table or on their
own tray nest, fixtured parts static; all with their features (the fidelity's level, raised
from "coarse" to "convex" like the required bodies). The parts the step needs keep the roles
above; the others get the role ``obstacle`` (dynamic unless fixtured) and nests ``nest``.

Levels of detail
----------------
Bodies are built from the :class:`~asmplan.parts.pieces.ConvexPiece` tuples of
:class:`~asmplan.parts.models.ProductGeometry` at ``fidelity.geometry_lod``, with two rules:

* "exact" models of parts with holes are triangle meshes, which PyBullet cannot use for a
  dynamic body; those parts use the "convex" level (holes as exact polygons whose inscribed
  circle is the nominal hole, see :mod:`asmplan.parts.lod`). Holes are never V-HACD blobs.
* the held part, its mates, touching parts and supports need their features: "coarse" (one
  hull: holes filled, pins bridged) is raised to "convex" for them when it differs.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from asmplan.knowledge.frames import invert
from asmplan.knowledge.model import Gripper as GripperResource
from asmplan.knowledge.model import Product
from asmplan.parts.collision import CollisionWorld
from asmplan.parts.geometry import PartShape
from asmplan.parts.lod import convex_pieces
from asmplan.parts.pieces import CollisionModel, ConvexPiece, LevelOfDetail
from asmplan.planner.motion import gripper_model, table_model
from asmplan.planner.plan import Plan, Step
from asmplan.planner.trajectory import OPEN_PHASES
from asmplan.sim.bullet import BulletWorld
from asmplan.sim.fidelity import Fidelity
from asmplan.sim.gripper import GripperSpec

Role = Literal["held", "mate", "touching", "support", "obstacle", "table", "nest"]
ROLES: tuple[str, ...] = ("held", "mate", "touching", "support", "obstacle", "table", "nest")
REQUIRED_ROLES: tuple[str, ...] = ("held", "mate", "touching", "support", "table", "nest")
"""Roles a step cannot do without (obstacles are there to catch deviations)."""

_DETAIL = {"coarse": 0, "convex": 1, "exact": 2}


class PlanProductMismatchError(ValueError):
    """The plan does not belong to the product (names of the product or its parts differ)."""


@dataclass(frozen=True)
class SceneSettings:
    """How a step's scene is selected (SI).

    Parameters
    ----------
    near_margin_m : float
        Obstacles closer than this to the swept space get the fidelity's level of detail.
    include_margin_m : float
        Obstacles closer than this are included (coarse beyond ``near_margin_m``); farther
        ones are left out.
    touch_tolerance_m : float
        Two parts whose FCL distance is at most this touch (pins in holes with clearance,
        faces resting on faces).
    nest_clearance_m : float
        Gap around each piece protruding below the face a tray nest supports, m.
    nest_inset_m : float
        The nest stays this far inside the supported face's outline, m.
    nest_min_height_m : float
        A largest downward face lower than this above the table rests on the table (no nest).
    dynamic_partners : bool or None
        Make non-fixtured mates and touching parts dynamic or static; None (default) follows
        ``Fidelity.dynamic_partners`` (static at FAST). In the whole-product scene
        (``cull=False``) the placed parts follow the same choice.
    limit_contact_breaking : bool
        Limit the contact breaking distance between the held part and its dynamic fit
        partners when the fidelity resolves the fits (see the module docstring); False keeps
        PyBullet's default everywhere.
    """

    near_margin_m: float = 5e-3
    include_margin_m: float = 30e-3
    touch_tolerance_m: float = 0.2e-3
    nest_clearance_m: float = 1e-3
    nest_inset_m: float = 0.5e-3
    nest_min_height_m: float = 10e-6
    dynamic_partners: bool | None = None
    limit_contact_breaking: bool = True

    def __post_init__(self) -> None:
        for name in ("near_margin_m", "include_margin_m", "touch_tolerance_m",
                     "nest_clearance_m", "nest_inset_m", "nest_min_height_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"SceneSettings.{name}: expected a finite value >= 0, found {v}")
        if self.include_margin_m < self.near_margin_m:
            raise ValueError(
                f"SceneSettings.include_margin_m: expected >= near_margin_m "
                f"({self.near_margin_m}), found {self.include_margin_m}"
            )


@dataclass(frozen=True, eq=False)
class SceneBody:
    """One body of a step's scene.

    Attributes
    ----------
    name : str
        Part name, "table" or "nest:<part>".
    role : str
        One of :data:`ROLES`.
    dynamic : bool
    level : str
        Level of detail of the pieces ("exact", "convex", "coarse"; "box" for table/nest).
    T_world_body : (4, 4) float array
    pieces : tuple of ConvexPiece
        Collision pieces in the body frame.
    reason : str
        Why the body is in the scene, and why at this level and with these dynamics.
    mass_kg : float
        0 for static bodies.
    com_m : (3,) float array, body frame.
    inertia_kgm2 : (3, 3) float array about the centre of mass.
    friction : float
    distance_m : float
        Distance of its bounding box from the swept space (0 for required bodies), m.
    """

    name: str
    role: str
    dynamic: bool
    level: str
    T_world_body: np.ndarray
    pieces: tuple[ConvexPiece, ...]
    reason: str
    mass_kg: float = 0.0
    com_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia_kgm2: np.ndarray | None = None
    friction: float = 0.5
    distance_m: float = 0.0

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"SceneBody {self.name}: role expected one of {ROLES}, "
                             f"found {self.role!r}")
        if self.dynamic and not self.mass_kg > 0:
            raise ValueError(f"SceneBody {self.name}: a dynamic body needs mass > 0, found "
                             f"{self.mass_kg}")

    def summary(self) -> dict[str, Any]:
        """JSON-safe description (no geometry)."""
        return {
            "name": self.name, "role": self.role, "dynamic": self.dynamic, "level": self.level,
            "pieces": len(self.pieces), "reason": self.reason,
            "mass_kg": float(self.mass_kg), "distance_m": float(self.distance_m),
            "T_world_body": np.asarray(self.T_world_body, float).tolist(),
        }


@dataclass(frozen=True, eq=False)
class StepScene:
    """The selected scene of one step.

    Attributes
    ----------
    step_index : int
    part : str
        The held part.
    bodies : tuple of SceneBody
        In a fixed order: table, nest, held part, then the others by role and name.
    left_out : tuple of (str, str)
        (part, reason) of every product part not in the scene.
    notes : tuple of str
    culled : bool
        False when every part was kept (``cull=False``).
    contact_breaking_m : float or None
        Largest distance at which the simulator keeps a contact point between the held part
        and its dynamic fit partners (``contact_breaking_partners``), m; None: PyBullet's
        default (see the module docstring).
    contact_breaking_partners : tuple of str
    """

    step_index: int
    part: str
    bodies: tuple[SceneBody, ...]
    left_out: tuple[tuple[str, str], ...]
    notes: tuple[str, ...] = ()
    culled: bool = True
    contact_breaking_m: float | None = None
    contact_breaking_partners: tuple[str, ...] = ()

    def body(self, name: str) -> SceneBody:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(f"scene of step {self.step_index} has no body {name!r}; it has "
                       f"{[b.name for b in self.bodies]}")

    def names(self, *roles: str) -> tuple[str, ...]:
        """Names of the bodies with one of ``roles`` (all when none given)."""
        return tuple(b.name for b in self.bodies if not roles or b.role in roles)

    @property
    def parts(self) -> tuple[str, ...]:
        """Names of the product parts in the scene."""
        return tuple(b.name for b in self.bodies if b.role not in ("table", "nest"))

    def summary(self) -> dict[str, Any]:
        """JSON-safe description of the selection (see docs/results-format.md)."""
        return {
            "culled": self.culled,
            "bodies": [b.summary() for b in self.bodies],
            "left_out": [{"name": n, "reason": r} for n, r in self.left_out],
            "notes": list(self.notes),
            "contact_breaking_m": self.contact_breaking_m,
            "contact_breaking_partners": list(self.contact_breaking_partners),
        }


# ---------------------------------------------------------------------------------------------
# Gripper
# ---------------------------------------------------------------------------------------------
def gripper_spec(resource: GripperResource, max_commanded_N: float = 0.0) -> GripperSpec:
    """The simulated gripper matching the product's gripper resource (and the planner's model).

    Pads are the finger boxes (``finger_size_m``: width x, thickness y, length z, centred on
    the TCP along z), the palm sits right behind them (``palm_gap_m = 0``) as in
    :func:`asmplan.planner.motion.gripper_model`; stroke, finger friction and mass come from
    the resource. ``max_clamp_force_N`` is the resource's ``max_force_N`` or the largest
    commanded force if larger (the plan is executed as planned; the excess is a warning).
    """
    finger = tuple(float(v) for v in resource.finger_size_m)
    finger_mass = 0.02
    palm_mass = max(float(resource.mass_kg) - 2 * finger_mass, 0.05)
    return GripperSpec(
        pad_size_m=finger,  # type: ignore[arg-type]
        pad_friction=float(resource.finger_friction),
        max_opening_m=float(resource.stroke_m),
        finger_mass_kg=finger_mass,
        palm_mass_kg=palm_mass,
        palm_size_m=tuple(float(v) for v in resource.palm_size_m),  # type: ignore[arg-type]
        palm_gap_m=0.0,
        max_clamp_force_N=max(float(resource.max_force_N), float(max_commanded_N), 1e-3),
    )


# ---------------------------------------------------------------------------------------------
# Geometry helpers
# ---------------------------------------------------------------------------------------------
def piece_corners(pc: ConvexPiece) -> np.ndarray:
    """Points (n, 3) in the part frame whose convex hull contains the piece."""
    if pc.kind == "hull":
        assert pc.vertices_m is not None
        local = pc.vertices_m
    else:
        if pc.kind == "box":
            assert pc.half_extents_m is not None
            he = pc.half_extents_m
        elif pc.kind == "cylinder":
            he = np.array([pc.radius_m, pc.radius_m, pc.length_m / 2])
        else:
            he = np.full(3, pc.radius_m)
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        local = signs * he
    return local @ pc.T_part_piece[:3, :3].T + pc.T_part_piece[:3, 3]


def _transform(points: np.ndarray, T: np.ndarray) -> np.ndarray:
    return points @ T[:3, :3].T + T[:3, 3]


def _aabb(points: np.ndarray) -> np.ndarray:
    return np.stack([points.min(axis=0), points.max(axis=0)])


def box_distance_m(a: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Euclidean distance between AABB ``a`` (2, 3) and each of ``boxes`` (n, 2, 3), m."""
    gap = np.maximum(0.0, np.maximum(boxes[:, 0] - a[1], a[0] - boxes[:, 1]))
    return np.linalg.norm(gap, axis=1)


def held_part_poses(step: Step, t_s: np.ndarray) -> np.ndarray:
    """Pose (n, 4, 4) of the held part at times ``t_s``: at its start pose until the clamp,
    carried by the gripper through the held phases, at its final pose after the release."""
    assert step.trajectory is not None and step.grasp is not None
    traj = step.trajectory
    T_grip = traj.poses_at(t_s)
    carried = T_grip @ invert(step.grasp.T_part_gripper)
    clamp0 = traj.phase_span("clamp").t_start_s
    idx = traj.phase_indices_at(t_s)
    out = carried.copy()
    names = [p.name for p in traj.phases]
    for k, t in enumerate(t_s):
        if names[idx[k]] in OPEN_PHASES:
            out[k] = step.T_world_start if t <= clamp0 else step.T_world_final
    return out


def swept_boxes(step: Step, part_points: np.ndarray, gripper_points: np.ndarray) -> np.ndarray:
    """Bounding boxes (n - 1, 2, 3) covering the held part and the open gripper between two
    consecutive trajectory samples (the box of both samples' boxes), world frame, m."""
    assert step.trajectory is not None
    t = step.trajectory.t_s
    T_part = held_part_poses(step, t)
    T_grip = step.trajectory.T_world_gripper
    lo_hi = []
    for T, points in ((T_part, part_points), (T_grip, gripper_points)):
        pts = np.matmul(T[:, :3, :3], np.ascontiguousarray(points.T))  # (n, 3, k)
        lo_hi.append((pts.min(axis=2) + T[:, :3, 3], pts.max(axis=2) + T[:, :3, 3]))
    lo = np.minimum(lo_hi[0][0], lo_hi[1][0])
    hi = np.maximum(lo_hi[0][1], lo_hi[1][1])
    return np.stack([np.minimum(lo[:-1], lo[1:]), np.maximum(hi[:-1], hi[1:])], axis=1)


def empty_holes(product: Product, part: str, present: frozenset[str] | set[str]) -> frozenset[str]:
    """Hole features of ``part`` that nothing enters during a step.

    ``present`` holds the parts at their assembled poses in the step (the placed ones and the
    held one). A hole is empty when ``part`` is not present (it waits at its start pose), or
    when every mate of the hole has its pin part absent (the pin arrives in a later step). A
    hole no mate names is never called empty (something undeclared may pass through it).
    """
    mates_of: dict[str, list[str]] = {}
    for m in product.mates:
        if m.hole_part == part:
            mates_of.setdefault(m.hole_feature, []).append(m.pin_part)
    return frozenset(f for f, pins in mates_of.items()
                     if part not in present or all(p not in present for p in pins))


_FILLED: weakref.WeakKeyDictionary[Any, dict[tuple[str, frozenset[str]], CollisionModel]] = (
    weakref.WeakKeyDictionary())


def filled_model(geometry: Any, part: str, filled: frozenset[str]) -> CollisionModel | None:
    """``part``'s convex model with the holes ``filled`` left solid (cached per geometry).

    None when nothing changes (no such hole cut in the part, or a mesh-file part, whose
    sectors come from its declared holes as a whole). The other holes keep their convex
    decomposition; a body left without holes becomes its exact primitive.
    """
    shape = geometry.shape(part)
    if shape.is_mesh or not any(h.feature in filled for h in shape.holes):
        return None
    cache = _FILLED.setdefault(geometry, {})
    key = (part, filled)
    if key not in cache:
        kept = tuple(h for h in shape.holes if h.feature not in filled)
        probe = PartShape(shape.part, shape.bodies, kept, shape.pins, shape.is_mesh)
        sides = {k: v for k, v in geometry.hole_sides(part).items() if k not in filled}
        pieces, notes = convex_pieces(probe, sides, geometry.settings)
        done = sorted(h.feature for h in shape.holes if h.feature in filled)
        cache[key] = CollisionModel("convex", pieces, notes=(
            *notes, f"hole(s) {', '.join(done)} left solid: empty during this step"))
    return cache[key]


def physics_model(geometry: Any, part: str, level: LevelOfDetail, needs_features: bool,
                  filled: frozenset[str] = frozenset()) -> tuple[CollisionModel, str]:
    """The collision model PyBullet can use for ``part`` at the requested ``level``.

    ``filled``: holes that stay empty during the step (:func:`empty_holes`); where the level
    keeps holes they are modelled solid, which saves their ring of pieces and the contacts
    on it. Returns the model and a note on any change of level (see the module docstring).
    """
    note = ""
    reduced = filled_model(geometry, part, filled) if filled else None
    if reduced is not None:
        note = f"{len(filled)} hole(s) that stay empty modelled solid"
    if level == "coarse" and needs_features:
        coarse = geometry.collision_model(part, "coarse", measured=False)
        convex = reduced or geometry.collision_model(part, "convex", measured=False)
        if len(convex.pieces) > 1:
            return convex, "; ".join(x for x in (
                "convex (coarse would fill its holes and bridge its pins, and it is in contact)",
                note) if x)
        return coarse, ""
    if level == "exact":
        exact = geometry.collision_model(part, "exact")
        if exact.mesh_faces is not None or not exact.pieces:
            if reduced is not None and all(pc.kind != "hull" for pc in reduced.pieces):
                return reduced, note + " (every hole solid: the exact primitives)"
            return reduced or geometry.collision_model(part, "convex", measured=False), "; ".join(
                x for x in (
                    "convex (its exact model is a triangle mesh, which PyBullet cannot use for "
                    "every body; convex pieces keep the holes as exact polygons)", note) if x)
        return exact, ""
    if level == "coarse":
        return geometry.collision_model(part, level, measured=False), ""
    return reduced or geometry.collision_model(part, level, measured=False), note


# ---------------------------------------------------------------------------------------------
# Tray nest
# ---------------------------------------------------------------------------------------------
def _rect_minus(rect: np.ndarray, holes: list[np.ndarray]) -> list[np.ndarray]:
    """Cover rectangle ``rect`` (2, 2: min, max of x, y) minus the rectangles ``holes`` with
    a few disjoint rectangles (grid cells merged along rows, then equal strips across rows)."""
    xs = {rect[0, 0], rect[1, 0]}
    ys = {rect[0, 1], rect[1, 1]}
    clipped = []
    for h in holes:
        lo = np.maximum(h[0], rect[0])
        hi = np.minimum(h[1], rect[1])
        if np.all(hi > lo):
            clipped.append(np.stack([lo, hi]))
            xs.update((lo[0], hi[0]))
            ys.update((lo[1], hi[1]))
    xv, yv = sorted(xs), sorted(ys)
    strips: list[list[tuple[float, float]]] = []
    for j in range(len(yv) - 1):
        cy = 0.5 * (yv[j] + yv[j + 1])
        row: list[tuple[float, float]] = []
        for i in range(len(xv) - 1):
            cx = 0.5 * (xv[i] + xv[i + 1])
            free = not any(h[0, 0] < cx < h[1, 0] and h[0, 1] < cy < h[1, 1] for h in clipped)
            if free:
                if row and row[-1][1] == xv[i]:
                    row[-1] = (row[-1][0], xv[i + 1])
                else:
                    row.append((xv[i], xv[i + 1]))
        strips.append(row)
    out: list[np.ndarray] = []
    open_: dict[tuple[float, float], float] = {}
    for j, row in enumerate([*strips, []]):
        current = set(row)
        for seg in list(open_):
            if seg not in current:
                y0 = open_.pop(seg)
                out.append(np.array([[seg[0], y0], [seg[1], yv[j]]]))
        for seg in row:
            if seg not in open_:
                open_[seg] = yv[j]
    return [r for r in out if np.all(r[1] - r[0] > 1e-9)]


def tray_nest(geometry: Any, part: str, T_world_part: np.ndarray, pieces: tuple[ConvexPiece, ...],
              settings: SceneSettings) -> tuple[tuple[ConvexPiece, ...], np.ndarray, str] | None:
    """Static support under the part's largest downward face, or None when the part rests on
    the table with that face (or has no horizontal downward face).

    Returns (box pieces in the nest frame, T_world_nest (4, 4), description).
    """
    mesh = geometry.mesh(part)
    v = _transform(np.asarray(mesh.vertices, float), T_world_part)
    faces = np.asarray(mesh.faces)
    tri = v[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(n, axis=1)
    ok = area2 > 0
    nz = np.zeros(len(faces))
    nz[ok] = n[ok, 2] / area2[ok]
    down = ok & (nz < -1.0 + 1e-9)
    if not down.any():
        return None
    z = tri[down, :, 2].mean(axis=1)
    key = np.round(z / 1e-6).astype(np.int64)
    areas = 0.5 * area2[down]
    uniq = np.unique(key)
    totals = np.array([areas[key == u].sum() for u in uniq])
    best = uniq[int(np.argmax(totals))]
    sel = np.flatnonzero(down)[key == best]
    z_face = float(tri[sel, :, 2].mean())
    if z_face < settings.nest_min_height_m:
        return None
    # nest frame: world z, x along the part's horizontal axis closest to world x (yaw only)
    R = T_world_part[:3, :3]
    horiz = [c for c in range(3) if abs(R[2, c]) < 0.5]
    ax = R[:, horiz[0]].copy()
    ax[2] = 0.0
    ax /= np.linalg.norm(ax)
    T_nest = np.eye(4)
    T_nest[:3, 0] = ax
    T_nest[:3, 1] = np.cross([0.0, 0.0, 1.0], ax)
    T_nest[:3, 2] = [0.0, 0.0, 1.0]
    to_nest = invert(T_nest)
    face_pts = _transform(tri[sel].reshape(-1, 3), to_nest)
    rect = _aabb(face_pts[:, :2])
    rect = rect + np.array([[1.0, 1.0], [-1.0, -1.0]]) * settings.nest_inset_m
    if np.any(rect[1] <= rect[0]):
        return None
    pockets = []
    for pc in pieces:
        pts = _transform(_transform(piece_corners(pc), T_world_part), to_nest)
        if pts[:, 2].min() < z_face - 1e-6:
            box = _aabb(pts[:, :2])
            pockets.append(box + np.array([[-1.0, -1.0], [1.0, 1.0]]) * settings.nest_clearance_m)
    cells = _rect_minus(rect, pockets)
    if not cells:
        return None
    out = []
    for k, c in enumerate(cells):
        T = np.eye(4)
        T[:2, 3] = 0.5 * (c[0] + c[1])
        T[2, 3] = z_face / 2
        he = np.array([(c[1, 0] - c[0, 0]) / 2, (c[1, 1] - c[0, 1]) / 2, z_face / 2])
        out.append(ConvexPiece("box", T, half_extents_m=he, name=f"nest{k}"))
    desc = (f"tray nest: {len(out)} boxes under its largest downward face at "
            f"z = {z_face * 1e3:.2f} mm, pockets around {len(pockets)} protruding pieces")
    return tuple(out), T_nest, desc


# ---------------------------------------------------------------------------------------------
# Selection
# ---------------------------------------------------------------------------------------------
def part_poses(plan: Plan, index: int) -> tuple[dict[str, np.ndarray], frozenset[str]]:
    """Pose of every part while step ``index`` runs, and the set of parts in place.

    Parts in place: fixtured ones (kind "fixture", in place from the start) and those of the
    earlier steps, at their final (assembled) poses; the others at their start poses.
    """
    placed = {s.part for s in plan.steps[:index]} | {s.part for s in plan.steps
                                                     if s.kind == "fixture"}
    placed.discard(plan.steps[index].part)
    poses = {s.part: (s.T_world_final if s.part in placed else s.T_world_start)
             for s in plan.steps}
    return poses, frozenset(placed)


def check_plan_product(plan: Plan, product: Product) -> None:
    """Raise :class:`PlanProductMismatchError` when ``plan`` was not made for ``product``."""
    if plan.product != product.name:
        raise PlanProductMismatchError(
            f"plan is for product {plan.product!r}, found product {product.name!r}")
    if sorted(plan.sequence) != sorted(product.part_names):
        raise PlanProductMismatchError(
            f"plan parts {sorted(plan.sequence)} differ from the product's "
            f"{sorted(product.part_names)}")


def _mass_body(geometry: Any, product: Product, name: str) -> dict[str, Any]:
    mp = geometry.mass_properties(name)
    return {"mass_kg": float(mp.mass_kg), "com_m": np.asarray(mp.com_m, float),
            "inertia_kgm2": np.asarray(mp.inertia_kgm2, float),
            "friction": float(product.part(name).friction)}


def select_scene(plan: Plan, index: int, product: Product, geometry: Any, fidelity: Fidelity,
                 settings: SceneSettings | None = None, *, cull: bool = True) -> StepScene:
    """The bodies step ``index`` of ``plan`` needs (see the module docstring).

    Parameters
    ----------
    plan : Plan
    index : int
        Step index; the step must move a part (kind "insert" or "place").
    product : Product
    geometry : ProductGeometry
    fidelity : Fidelity
        Its ``geometry_lod`` sets the level of detail.
    settings : SceneSettings, optional
    cull : bool
        False loads the whole product (see the module docstring: the other parts dynamic
        unless fixtured, with their features, unplaced ones on their nests).

    Returns
    -------
    StepScene
    """
    check_plan_product(plan, product)
    return step_scene(plan.steps[index], part_poses(plan, index), product, geometry, fidelity,
                      settings, cull=cull)


Layout = tuple[dict[str, np.ndarray], frozenset[str]]
"""Pose (4, 4) of every part while a step runs and the set of parts in place
(:func:`part_poses`)."""


def step_scene(step: Step, layout: Layout, product: Product, geometry: Any, fidelity: Fidelity,
               settings: SceneSettings | None = None, *, cull: bool = True) -> StepScene:
    """:func:`select_scene` for one ``step`` given where every part is (``layout``)."""
    s = settings or SceneSettings()
    index = step.index
    if step.kind == "fixture" or step.trajectory is None or step.grasp is None:
        raise ValueError(f"step {index} ({step.part}): expected a step that moves its part, "
                         f"found kind {step.kind!r}")
    held = step.part
    poses, placed = layout
    missing = set(product.part_names) - set(poses)
    if missing:
        raise ValueError(f"layout: expected a pose for every part, found none for "
                         f"{sorted(missing)}")
    level = fidelity.geometry_lod
    notes: list[str] = []
    bodies: list[SceneBody] = []

    # table
    table = product.resources.table
    tm = table_model(table)
    bodies.append(SceneBody("table", "table", False, "box", np.eye(4), tm.pieces,
                            "work table (top face z = 0), static", friction=float(table.friction)))

    # held part (+ nest)
    present = frozenset(placed) | {held}
    dynamic_partners = (fidelity.dynamic_partners if s.dynamic_partners is None
                        else s.dynamic_partners)

    def model_of(name: str, want: LevelOfDetail, needs: bool) -> tuple[CollisionModel, str]:
        return physics_model(geometry, name, want, needs, empty_holes(product, name, present))

    held_model, note = model_of(held, level, True)
    held_reason = f"held part, dynamic, at its start pose; level {held_model.level}"
    if note:
        held_reason += f": {note}"
    nest = tray_nest(geometry, held, step.T_world_start, held_model.pieces, s)
    if nest is not None:
        pieces, T_nest, desc = nest
        bodies.append(SceneBody(f"nest:{held}", "nest", False, "box", T_nest, pieces,
                                f"{desc}, static (the part does not rest on the table)",
                                friction=float(table.friction)))
    held_body = SceneBody(held, "held", True, held_model.level, step.T_world_start,
                          held_model.pieces, held_reason, **_mass_body(geometry, product, held))

    # mates and touching parts at the seated pose
    mate_partners: dict[str, list[str]] = {}
    fits = []  # the held part's mates with parts in place
    for m in product.mates:
        other = m.hole_part if m.pin_part == held else m.pin_part if m.hole_part == held else None
        if other is not None and other in placed:
            mate_partners.setdefault(other, []).append(m.name)
            fits.append(m)
    world = CollisionWorld(geometry.fcl_shapes)
    for name in [held, *sorted(placed)]:
        world.add(name, geometry.collision_model(name, "convex", measured=False),
                  step.T_world_final if name == held else poses[name])

    def touching(a: str, candidates: list[str]) -> list[tuple[str, float]]:
        out = []
        box_a = world.aabb(a)
        for b in candidates:
            if b == a:
                continue
            if box_distance_m(box_a, world.aabb(b)[None])[0] > s.touch_tolerance_m:
                continue
            d = world.distance(a, b)
            if d <= s.touch_tolerance_m:
                out.append((b, d))
        return out

    partners: dict[str, SceneBody] = {}
    for other, dist in touching(held, sorted(placed)):
        fixt = product.is_fixtured(other)
        dyn = dynamic_partners and not fixt
        model, note = model_of(other, level, True)
        role = "mate" if other in mate_partners else "touching"
        why = (f"mates with {held} ({', '.join(mate_partners[other])})" if role == "mate"
               else f"touches {held} when seated (distance {dist * 1e6:.1f} um)")
        dyn_why = ("static: fixtured" if fixt else
                   "dynamic, so the insertion pushes a real body" if dyn else
                   "static (dynamic partners off at this fidelity)")
        reason = f"{why}; in place; {dyn_why}; level {model.level}" + (f": {note}" if note else "")
        kw = _mass_body(geometry, product, other) if dyn else {
            "friction": float(product.part(other).friction)}
        partners[other] = SceneBody(other, role, dyn, model.level, poses[other], model.pieces,
                                    reason, **kw)
    for other in sorted(set(mate_partners) - set(partners)):
        notes.append(f"{other} mates with {held} but does not touch it when seated "
                     f"(distance > {s.touch_tolerance_m * 1e3:.2f} mm); treated as an obstacle")

    # contact breaking distance: below the radial gap of fits the preset resolves, when a
    # fit partner is dynamic (a phantom contact can push it)
    movable = sorted(o for o in mate_partners if o in partners and partners[o].dynamic)
    breaking: float | None = None
    breaking_partners: tuple[str, ...] = ()
    if s.limit_contact_breaking and movable:
        tightest = min(fits, key=lambda m: m.clearance_min_m)
        c = float(tightest.clearance_min_m)
        if c >= fidelity.min_resolvable_clearance_m:
            breaking = 0.5 * c
            breaking_partners = tuple(movable)
            notes.append(
                f"contact points between {held} and {', '.join(breaking_partners)} "
                f"(dynamic) are kept up to {breaking * 1e3:.3f} mm apart, half the smallest "
                f"diametral clearance of the fits ({tightest.name}: {c * 1e3:.3f} mm, resolved "
                f"at {fidelity.name}); at PyBullet's default distance (0.02 of a body's "
                "bounding radius) a contact found at a chamfer is carried across the fit's gap "
                "and can push the partner")

    # supports of the dynamic partners
    supports: dict[str, SceneBody] = {}
    for name in sorted(partners):
        if not partners[name].dynamic:
            continue
        for other, _ in touching(name, sorted(placed - set(partners))):
            if other in supports:
                continue
            model, note = model_of(other, level, True)
            reason = (f"supports {name} (touches it), in place, static; level {model.level}"
                      + (f": {note}" if note else ""))
            if product.is_fixtured(other):
                reason += "; fixtured"
            supports[other] = SceneBody(other, "support", False, model.level, poses[other],
                                        model.pieces, reason,
                                        friction=float(product.part(other).friction))

    # obstacles near the swept space
    required = {held, *partners, *supports}
    g = product.gripper_for(step.part)
    open_half = 0.5 * max(step.grasp.open_width_m, step.grasp.width_m)
    grip_pts = np.concatenate([piece_corners(pc) for pc in gripper_model(g, open_half).pieces])
    # the hull's vertices bound the same boxes as all the mesh's vertices, with fewer points
    held_pts = np.asarray(geometry.mesh(held).convex_hull.vertices, float)
    sweep = swept_boxes(step, held_pts, grip_pts)
    obstacles: list[SceneBody] = []
    left_out: list[tuple[str, str]] = []
    for other in product.part_names:
        if other in required:
            continue
        pts = _transform(np.asarray(geometry.mesh(other).vertices, float), poses[other])
        d = float(box_distance_m(_aabb(pts), sweep).min())
        where = "in place" if other in placed else "at its start pose"
        if cull and d > s.include_margin_m:
            left_out.append((other, f"{where}, {d * 1e3:.1f} mm from the space the part and "
                                    f"gripper sweep (> {s.include_margin_m * 1e3:.0f} mm)"))
            continue
        if not cull:
            # the naive whole product: every part as the simulator would model it if it
            # selected nothing (dynamic unless fixtured, with its features, on a nest when
            # waiting at a start pose it cannot rest on the table at)
            # (placed parts static when the fidelity makes partners static)
            fixt = product.is_fixtured(other)
            dyn = not fixt and (dynamic_partners or other not in placed)
            model, note = model_of(other, level, True)
            how = ("static: fixtured" if fixt else "dynamic" if dyn
                   else "static (dynamic partners off at this fidelity)")
            reason = (f"obstacle {where}, {d * 1e3:.1f} mm from the swept space (whole "
                      f"product loaded: cull off), {how}; "
                      f"level {model.level}" + (f": {note}" if note else ""))
            kw = (_mass_body(geometry, product, other) if dyn
                  else {"friction": float(product.part(other).friction)})
            obstacles.append(SceneBody(other, "obstacle", dyn, model.level, poses[other],
                                       model.pieces, reason, distance_m=d, **kw))
            other_nest = (None if fixt or other in placed else
                          tray_nest(geometry, other, poses[other], model.pieces, s))
            if other_nest is not None:
                pieces, T_nest, desc = other_nest
                obstacles.append(SceneBody(f"nest:{other}", "nest", False, "box", T_nest, pieces,
                                           f"{desc}, static (whole product loaded)",
                                           friction=float(table.friction)))
            continue
        near = d <= s.near_margin_m
        want: LevelOfDetail = level if near else "coarse"
        model, note = model_of(other, want, False)
        reason = (f"obstacle {where}, {d * 1e3:.1f} mm from the swept space "
                  + f"({'<=' if near else '>'} {s.near_margin_m * 1e3:.0f} mm)"
                  + f", static; level {model.level}" + (f": {note}" if note else ""))
        obstacles.append(SceneBody(other, "obstacle", False, model.level, poses[other],
                                   model.pieces, reason, friction=float(product.part(other).friction),
                                   distance_m=d))

    ordered = [*bodies, held_body]
    ordered += [partners[n] for n in sorted(partners)]
    ordered += [supports[n] for n in sorted(supports)]
    ordered += obstacles
    return StepScene(index, held, tuple(ordered), tuple(left_out), tuple(notes), culled=cull,
                     contact_breaking_m=breaking, contact_breaking_partners=breaking_partners)


# ---------------------------------------------------------------------------------------------
# Building
# ---------------------------------------------------------------------------------------------
def build_scene(world: BulletWorld, scene: StepScene) -> dict[str, int]:
    """Create the scene's bodies in ``world`` (before its first step) and limit the held
    part's contact breaking distance (:attr:`StepScene.contact_breaking_m`); returns body ids by
    name (in scene order)."""
    ids: dict[str, int] = {}
    for b in scene.bodies:
        if b.dynamic:
            ids[b.name] = world.add_body(b.pieces, b.mass_kg, b.T_world_body, com_m=b.com_m,
                                         inertia_kgm2=b.inertia_kgm2, friction=b.friction,
                                         name=b.name)
        else:
            ids[b.name] = world.add_body(b.pieces, 0.0, b.T_world_body, friction=b.friction,
                                         name=b.name)
    if scene.contact_breaking_m is not None:
        others = [ids[n] for n in scene.contact_breaking_partners if n in ids]
        if others:
            world.limit_contact_breaking_m(ids[scene.part], scene.contact_breaking_m, others)
    return ids
