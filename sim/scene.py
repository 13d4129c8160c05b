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
``fixture``
    A declared regrasp fixture of the cell (``resources.regrasp``, ``fixture:<name>``),
    static, always present (:mod:`asmplan.sim.cell_fixtures`). A part put into it or picked
    from it rests in it; no tray nest is built under a part a fixture carries.
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
and the smallest diametral clearance of the fits is at least the fidelity's interference
resolution (``Fidelity.interference_resolution_m``, twice the world's contact distance), the
scene limits the distance at which PyBullet
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
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..errors import AsmplanError
from ..knowledge.model import Gripper as GripperResource
from ..knowledge.model import Product
from ..parts.cell import gripper_model, table_model
from ..parts.collision import CollisionWorld
from ..parts.pieces import CollisionModel, ConvexPiece, LevelOfDetail
from ..planner.plan import AssemblyState, Plan, Step, assembly_state
from .bodies import (
    aabb,
    box_distance_m,
    coarse_fills_path,
    empty_holes,
    physics_model,
    piece_corners,
    swept_boxes,
    transform_points,
)
from .bullet import BulletWorld
from .cell_fixtures import carried_by_fixture, fixture_bodies
from .fidelity import Fidelity
from .gripper import GripperSpec
from .nest import tray_nest

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry

Role = Literal["held", "mate", "touching", "support", "obstacle", "table", "fixture", "nest"]
ROLES: tuple[str, ...] = ("held", "mate", "touching", "support", "obstacle", "table", "fixture",
                          "nest")
REQUIRED_ROLES: tuple[str, ...] = ("held", "mate", "touching", "support", "table", "fixture",
                                   "nest")
"""Roles a step cannot do without (obstacles are there to catch deviations)."""

_DETAIL = {"coarse": 0, "convex": 1, "exact": 2}


class PlanProductMismatchError(AsmplanError, ValueError):
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
        partners when the fits are at least the interference resolution (see the module
        docstring); False keeps PyBullet's default everywhere.
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
        return tuple(b.name for b in self.bodies if b.role not in ("table", "fixture", "nest"))

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
    :func:`asmplan.parts.cell.gripper_model`; stroke, finger friction and mass come from
    the resource, and so does the pads' V-groove (prism jaws). ``max_clamp_force_N`` is the
    resource's ``max_force_N`` or the largest commanded force if larger (the plan is
    executed as planned; the excess is a warning).
    """
    finger = tuple(float(v) for v in resource.finger_size_m)
    groove = resource.finger_groove
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
        pad_groove_angle_rad=0.0 if groove is None else float(groove.angle_rad),
        pad_groove_depth_m=0.0 if groove is None else float(groove.depth_m),
    )


# ---------------------------------------------------------------------------------------------
# Selection
# ---------------------------------------------------------------------------------------------
def check_plan_product(plan: Plan, product: Product) -> None:
    """Raise :class:`PlanProductMismatchError` when ``plan`` was not made for ``product``."""
    if plan.product != product.name:
        raise PlanProductMismatchError(
            f"plan is for product {plan.product!r}, found product {product.name!r}")
    if sorted(plan.sequence) != sorted(product.part_names):
        raise PlanProductMismatchError(
            f"plan parts {sorted(plan.sequence)} differ from the product's "
            f"{sorted(product.part_names)}")


def _mass_body(geometry: ProductGeometry, product: Product, name: str) -> dict[str, Any]:
    mp = geometry.mass_properties(name)
    return {"mass_kg": float(mp.mass_kg), "com_m": np.asarray(mp.com_m, float),
            "inertia_kgm2": np.asarray(mp.inertia_kgm2, float),
            "friction": float(product.part(name).friction)}


def select_scene(plan: Plan, index: int, product: Product, geometry: ProductGeometry, fidelity: Fidelity,
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
    return step_scene(plan.steps[index], assembly_state(plan, index), product, geometry, fidelity,
                      settings, cull=cull)


def step_scene(step: Step, state: AssemblyState, product: Product, geometry: ProductGeometry,
               fidelity: Fidelity, settings: SceneSettings | None = None, *, cull: bool = True) -> StepScene:
    """:func:`select_scene` for one ``step`` given where every part is (``state``).

    The selection goes in stages (:class:`_Selection`): the table, the held part (and its
    nest), the parts it mates with or touches when seated, the contact breaking distance, the
    supports of dynamic partners, and the obstacles near the swept space.
    """
    index = step.index
    if step.kind == "fixture" or step.trajectory is None or step.grasp is None:
        raise ValueError(f"step {index + 1} ({step.part}): expected a step that moves its part, "
                         f"found kind {step.kind!r}")
    missing = set(product.part_names) - set(state.T_world_part)
    if missing:
        raise ValueError(f"state: expected a pose for every part, found none for "
                         f"{sorted(missing)}")
    sel = _Selection(step, state, product, geometry, fidelity, settings or SceneSettings())
    bodies = [sel.table_body(), *sel.fixture_bodies()]
    nest, held_body = sel.held_bodies()
    bodies += nest
    partners = sel.partners()
    breaking, breaking_partners = sel.contact_breaking(partners)
    supports = sel.supports(partners)
    obstacles, left_out = sel.obstacles({step.part, *partners, *supports}, cull)
    ordered = [*bodies, held_body]
    ordered += [partners[n] for n in sorted(partners)]
    ordered += [supports[n] for n in sorted(supports)]
    ordered += obstacles
    return StepScene(index, step.part, tuple(ordered), tuple(left_out), tuple(sel.notes),
                     culled=cull, contact_breaking_m=breaking,
                     contact_breaking_partners=breaking_partners)


class _Selection:
    """The stages of :func:`step_scene` over one step's inputs; ``notes`` collects what the
    scene summary says besides the bodies."""

    def __init__(self, step: Step, state: AssemblyState, product: Product,
                 geometry: ProductGeometry, fidelity: Fidelity, s: SceneSettings) -> None:
        self.step, self.product, self.geometry, self.fidelity, self.s = (
            step, product, geometry, fidelity, s)
        self.held = step.part
        self.poses, self.placed = state.T_world_part, state.placed
        self.level = fidelity.geometry_lod
        self.notes: list[str] = []
        self.table = product.resources.table
        self.present = frozenset(self.placed) | {self.held}
        self.dynamic_partners = (fidelity.dynamic_partners if s.dynamic_partners is None
                                 else s.dynamic_partners)
        # mates of the held part with parts in place
        self.mate_partners: dict[str, list[str]] = {}
        self.fits = []
        for m in product.mates:
            other = (m.hole_part if m.pin_part == self.held
                     else m.pin_part if m.hole_part == self.held else None)
            if other is not None and other in self.placed:
                self.mate_partners.setdefault(other, []).append(m.name)
                self.fits.append(m)
        self._world: CollisionWorld | None = None

    def model_of(self, name: str, want: LevelOfDetail, needs: bool) -> tuple[CollisionModel, str]:
        return physics_model(self.geometry, name, want, needs,
                             empty_holes(self.product, name, self.present))

    def table_body(self) -> SceneBody:
        tm = table_model(self.table)
        return SceneBody("table", "table", False, "box", np.eye(4), tm.pieces,
                         "work table (top face z = 0), static", friction=float(self.table.friction))

    def fixture_bodies(self) -> list[SceneBody]:
        """The cell's declared regrasp fixtures, static."""
        return [SceneBody(f.name, "fixture", False, "box", f.T_world_body, f.pieces,
                          "regrasp fixture of the cell (resources.regrasp), static",
                          friction=f.friction) for f in fixture_bodies(self.product)]

    def held_bodies(self) -> tuple[list[SceneBody], SceneBody]:
        """The held part's nest (when it does not rest on the table) and the held part."""
        held, step = self.held, self.step
        held_model, note = self.model_of(held, self.level, True)
        held_reason = f"held part, dynamic, at its start pose; level {held_model.level}"
        if note:
            held_reason += f": {note}"
        bodies = []
        carrier = carried_by_fixture(self.product, self.geometry, held, step.T_world_start,
                                     self.s.touch_tolerance_m)
        nest = None if carrier is not None else tray_nest(
            self.geometry, held, step.T_world_start, held_model.pieces, self.s)
        if carrier is not None:
            held_reason += f"; starts in {carrier}"
        if nest is not None:
            pieces, T_nest, desc = nest
            bodies.append(SceneBody(f"nest:{held}", "nest", False, "box", T_nest, pieces,
                                    f"{desc}, static (the part does not rest on the table)",
                                    friction=float(self.table.friction)))
        held_body = SceneBody(held, "held", True, held_model.level, step.T_world_start,
                              held_model.pieces, held_reason,
                              **_mass_body(self.geometry, self.product, held))
        return bodies, held_body

    def touching(self, a: str, candidates: list[str]) -> list[tuple[str, float]]:
        """The candidates within the touch tolerance of ``a`` (the held part seated, the
        others in place), with their distances, m."""
        if self._world is None:
            world = CollisionWorld(self.geometry.fcl_shapes)
            for name in [self.held, *sorted(self.placed)]:
                world.add(name, self.geometry.collision_model(name, "convex", measured=False),
                          self.step.T_world_final if name == self.held else self.poses[name])
            self._world = world
        world, tol = self._world, self.s.touch_tolerance_m
        out = []
        box_a = world.aabb(a)
        for b in candidates:
            if b == a:
                continue
            if box_distance_m(box_a, world.aabb(b)[None])[0] > tol:
                continue
            d = world.distance(a, b)
            if d <= tol:
                out.append((b, d))
        return out

    def partners(self) -> dict[str, SceneBody]:
        """The parts in place that the held part mates with or touches when seated."""
        held, product = self.held, self.product
        partners: dict[str, SceneBody] = {}
        for other, dist in self.touching(held, sorted(self.placed)):
            fixt = product.is_fixtured(other)
            dyn = self.dynamic_partners and not fixt
            model, note = self.model_of(other, self.level, True)
            role = "mate" if other in self.mate_partners else "touching"
            why = (f"mates with {held} ({', '.join(self.mate_partners[other])})" if role == "mate"
                   else f"touches {held} when seated (distance {dist * 1e6:.1f} um)")
            dyn_why = ("static: fixtured" if fixt else
                       "dynamic, so the insertion pushes a real body" if dyn else
                       "static (dynamic partners off at this fidelity)")
            reason = (f"{why}; in place; {dyn_why}; level {model.level}"
                      + (f": {note}" if note else ""))
            kw = _mass_body(self.geometry, product, other) if dyn else {
                "friction": float(product.part(other).friction)}
            partners[other] = SceneBody(other, role, dyn, model.level, self.poses[other],
                                        model.pieces, reason, **kw)
        for other in sorted(set(self.mate_partners) - set(partners)):
            self.notes.append(f"{other} mates with {held} but does not touch it when seated "
                              f"(distance > {self.s.touch_tolerance_m * 1e3:.2f} mm); treated "
                              "as an obstacle")
        return partners

    def contact_breaking(self, partners: dict[str, SceneBody]
                         ) -> tuple[float | None, tuple[str, ...]]:
        """The contact breaking distance: half the fits' smallest clearance when that is at
        least the preset's interference resolution and a fit partner is dynamic (a phantom
        contact can push it)."""
        movable = sorted(o for o in self.mate_partners if o in partners and partners[o].dynamic)
        if not (self.s.limit_contact_breaking and movable):
            return None, ()
        tightest = min(self.fits, key=lambda m: m.clearance_min_m)
        c = float(tightest.clearance_min_m)
        if c < self.fidelity.interference_resolution_m:
            return None, ()
        breaking = 0.5 * c
        self.notes.append(
            f"contact points between {self.held} and {', '.join(movable)} "
            f"(dynamic) are kept up to {breaking * 1e3:.3f} mm apart, half the smallest "
            f"diametral clearance of the fits ({tightest.name}: {c * 1e3:.3f} mm, resolved "
            f"at {self.fidelity.name}); at PyBullet's default distance (0.02 of a body's "
            "bounding radius) a contact found at a chamfer is carried across the fit's gap "
            "and can push the partner")
        return breaking, tuple(movable)

    def supports(self, partners: dict[str, SceneBody]) -> dict[str, SceneBody]:
        """The parts in place that touch a dynamic partner (static)."""
        supports: dict[str, SceneBody] = {}
        for name in sorted(partners):
            if not partners[name].dynamic:
                continue
            for other, _ in self.touching(name, sorted(self.placed - set(partners))):
                if other in supports:
                    continue
                model, note = self.model_of(other, self.level, True)
                reason = (f"supports {name} (touches it), in place, static; level {model.level}"
                          + (f": {note}" if note else ""))
                if self.product.is_fixtured(other):
                    reason += "; fixtured"
                supports[other] = SceneBody(other, "support", False, model.level,
                                            self.poses[other], model.pieces, reason,
                                            friction=float(self.product.part(other).friction))
        return supports

    def obstacles(self, required: set[str], cull: bool
                  ) -> tuple[list[SceneBody], list[tuple[str, str]]]:
        """The other parts near the space the part and the gripper sweep (all of them when
        ``cull`` is off), and those left out with why."""
        step, product, geometry, s = self.step, self.product, self.geometry, self.s
        assert step.grasp is not None  # checked by step_scene
        g = product.gripper_for(step.part)
        open_half = 0.5 * max(step.grasp.open_width_m, step.grasp.width_m)
        grip_pts = np.concatenate([piece_corners(pc) for pc in gripper_model(g, open_half).pieces])
        # the hull's vertices bound the same boxes as all the mesh's vertices, with fewer points
        held_pts = np.asarray(geometry.mesh(self.held).convex_hull.vertices, float)
        sweep = swept_boxes(step, held_pts, grip_pts)
        obstacles: list[SceneBody] = []
        left_out: list[tuple[str, str]] = []
        for other in product.part_names:
            if other in required:
                continue
            pts = transform_points(np.asarray(geometry.mesh(other).vertices, float), self.poses[other])
            d = float(box_distance_m(aabb(pts), sweep).min())
            where = "in place" if other in self.placed else "at its start pose"
            if cull and d > s.include_margin_m:
                left_out.append((other, f"{where}, {d * 1e3:.1f} mm from the space the part and "
                                        f"gripper sweep (> {s.include_margin_m * 1e3:.0f} mm)"))
                continue
            if not cull:
                obstacles += self.whole_product_body(other, where, d)
                continue
            near = d <= s.near_margin_m
            want: LevelOfDetail = self.level if near else "coarse"
            # a mate partner the held part does not touch when seated (a washer's bore with
            # a drawn clearance) is still passed through: it keeps its holes (one coarse hull
            # would fill the bore the part enters)
            passed = other in self.mate_partners
            # nor may it fill a bore the part crosses without a mate (a housing's relief bore
            # the shaft passes through to the far bearing): the coarse hull would stop it there
            filled_m = 0.0 if passed or want != "coarse" or d > 0.0 else coarse_fills_path(
                geometry, step, other, self.poses[other])
            model, note = self.model_of(other, want, passed or filled_m > 0.0)
            reason = (f"obstacle {where}, {d * 1e3:.1f} mm from the swept space "
                      + f"({'<=' if near else '>'} {s.near_margin_m * 1e3:.0f} mm)"
                      + (f"; mates with {self.held} (passed through)" if passed else "")
                      + (f"; {self.held} passes through it ({filled_m * 1e3:.1f} mm inside its "
                         "coarse hull): keeps its holes" if filled_m > 0.0 else "")
                      + f", static; level {model.level}" + (f": {note}" if note else ""))
            obstacles.append(SceneBody(other, "obstacle", False, model.level, self.poses[other],
                                       model.pieces, reason,
                                       friction=float(product.part(other).friction),
                                       distance_m=d))
        return obstacles, left_out

    def whole_product_body(self, other: str, where: str, d: float) -> list[SceneBody]:
        """``other`` as the naive whole product has it (cull off): as the simulator would
        model it if it selected nothing (dynamic unless fixtured, with its features, on a nest
        when waiting at a start pose it cannot rest on the table at; placed parts static when
        the fidelity makes partners static)."""
        product, geometry = self.product, self.geometry
        fixt = product.is_fixtured(other)
        dyn = not fixt and (self.dynamic_partners or other not in self.placed)
        model, note = self.model_of(other, self.level, True)
        how = ("static: fixtured" if fixt else "dynamic" if dyn
               else "static (dynamic partners off at this fidelity)")
        reason = (f"obstacle {where}, {d * 1e3:.1f} mm from the swept space (whole "
                  f"product loaded: cull off), {how}; "
                  f"level {model.level}" + (f": {note}" if note else ""))
        kw = (_mass_body(geometry, product, other) if dyn
              else {"friction": float(product.part(other).friction)})
        out = [SceneBody(other, "obstacle", dyn, model.level, self.poses[other],
                         model.pieces, reason, distance_m=d, **kw)]
        other_nest = (None if fixt or other in self.placed or carried_by_fixture(
            product, geometry, other, self.poses[other], self.s.touch_tolerance_m) else
                      tray_nest(geometry, other, self.poses[other], model.pieces, self.s))
        if other_nest is not None:
            pieces, T_nest, desc = other_nest
            out.append(SceneBody(f"nest:{other}", "nest", False, "box", T_nest, pieces,
                                 f"{desc}, static (whole product loaded)",
                                 friction=float(self.table.friction)))
        return out


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
