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
later step, unless the held part passes through it on its insertion
(:func:`asmplan.sim.hole_path.holes_crossed`: the gearbox's shaft through the seat of the
bearing pressed in after it). Its ring of convex pieces and their contacts leave the scene (a
block whose holes all wait becomes its exact box); holes no mate names are kept. Mass properties are
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

Modules
-------
This module holds the entry points (:func:`select_scene` from a plan, :func:`build_scene`
into a world, :func:`gripper_spec`, :func:`check_plan_product`) and re-exports the rest:
the records (roles, :class:`SceneSettings`, :class:`SceneBody`, :class:`StepScene`,
:class:`PlanProductMismatchError`) are in :mod:`asmplan.sim.scene_types`, the selection's
stages (:func:`step_scene`) in :mod:`asmplan.sim.scene_select`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..knowledge.model import Gripper as GripperResource
from ..knowledge.model import Product
from ..planner.plan import Plan, assembly_state
from .bullet import BulletWorld
from .fidelity import Fidelity
from .gripper import GripperSpec
from .scene_select import step_scene
from .scene_types import (
    REQUIRED_ROLES,
    ROLES,
    PlanProductMismatchError,
    Role,
    SceneBody,
    SceneSettings,
    StepScene,
)

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry

__all__ = [
    "REQUIRED_ROLES",
    "ROLES",
    "PlanProductMismatchError",
    "Role",
    "SceneBody",
    "SceneSettings",
    "StepScene",
    "build_scene",
    "check_plan_product",
    "gripper_spec",
    "select_scene",
    "step_scene",
]


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
