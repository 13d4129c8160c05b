"""The selection of one step's scene body by body: :func:`step_scene` and its stages.

:func:`step_scene` picks, for one step and the pose of every part, the table, the cell's
fixtures, the held part (and its tray nest), the parts it mates with or touches when seated,
the contact breaking distance, the supports of dynamic partners and the obstacles near the
swept space (:class:`_Selection`, one method per stage), each with its role, level, dynamics
and reason. The rules it applies are in the :mod:`asmplan.sim.scene` docstring;
:func:`asmplan.sim.scene.select_scene` is the entry point from a plan.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..knowledge.model import Product
from ..parts.cell import gripper_model, table_model
from ..parts.collision import CollisionWorld
from ..parts.pieces import CollisionModel, LevelOfDetail
from ..planner.plan import AssemblyState, Step
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
from .cell_fixtures import carried_by_fixture, fixture_bodies
from .fidelity import Fidelity
from .hole_path import holes_crossed
from .nest import tray_nest
from .scene_types import SceneBody, SceneSettings, StepScene

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry


def _mass_body(geometry: ProductGeometry, product: Product, name: str) -> dict[str, Any]:
    mp = geometry.mass_properties(name)
    return {"mass_kg": float(mp.mass_kg), "com_m": np.asarray(mp.com_m, float),
            "inertia_kgm2": np.asarray(mp.inertia_kgm2, float),
            "friction": float(product.part(name).friction)}


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
        empty = empty_holes(self.product, name, self.present)
        if empty and name != self.held and name in self.poses:  # not those it passes through
            empty -= holes_crossed(self.geometry, self.step, name, self.poses[name], empty)
        return physics_model(self.geometry, name, want, needs, empty)

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
