"""Rendered views of a product and its plan: assembled, exploded, and each step's key poses.

Views are built from the part meshes of :class:`~asmplan.parts.models.ProductGeometry` and the
poses of a :class:`~asmplan.planner.plan.Plan`, and rendered offscreen by
:mod:`asmplan.report.render`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np
import trimesh

from ..knowledge.model import Product
from ..parts.cell import gripper_model
from ..parts.pieces import CollisionModel
from ..planner.plan import Plan, Step
from .render import Camera, SceneItem, exploded, fit_camera, render, save_png

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry

GRIPPER_RGBA = (0.25, 0.27, 0.30, 1.0)
ARM_RGBA = (0.92, 0.92, 0.94, 1.0)
HELD_RGBA = (0.95, 0.55, 0.10, 1.0)
TABLE_RGBA = (0.86, 0.84, 0.80, 1.0)
VIEW_DIRECTION = (1.0, -1.3, 0.9)
# distinct, print-friendly part colours (the held part is always HELD_RGBA)
PALETTE = ((0.55, 0.63, 0.75), (0.45, 0.70, 0.55), (0.80, 0.45, 0.45), (0.60, 0.50, 0.78),
           (0.85, 0.75, 0.40), (0.40, 0.70, 0.75), (0.75, 0.55, 0.40), (0.65, 0.65, 0.65))


def pieces_mesh(model: CollisionModel) -> trimesh.Trimesh:
    """One display mesh of a collision model's pieces (boxes, cylinders, spheres, hulls)."""
    meshes = []
    for piece in model.pieces:
        if piece.kind == "box":
            m = trimesh.creation.box(extents=2.0 * np.asarray(piece.half_extents_m))
        elif piece.kind == "cylinder":
            m = trimesh.creation.cylinder(radius=piece.radius_m, height=piece.length_m, sections=48)
        elif piece.kind == "sphere":
            m = trimesh.creation.icosphere(subdivisions=3, radius=piece.radius_m)
        else:
            m = trimesh.convex.convex_hull(np.asarray(piece.vertices_m))
        m.apply_transform(piece.T_part_piece)
        meshes.append(m)
    return cast(trimesh.Trimesh, trimesh.util.concatenate(meshes))


class Views:
    """Renders a product's parts at given poses, with the gripper and the table top."""

    def __init__(self, product: Product, geometry, width_px: int = 800, height_px: int = 600):
        self.product = product
        self.geometry = geometry
        self.width_px = width_px
        self.height_px = height_px
        self._meshes: dict[str, trimesh.Trimesh] = {}

    def mesh(self, part: str) -> trimesh.Trimesh:
        if part not in self._meshes:
            self._meshes[part] = self.geometry.mesh(part).to_trimesh()
        return self._meshes[part]

    def part_item(self, part: str, T_world_part: np.ndarray, rgba: Sequence[float] | None = None
                  ) -> SceneItem:
        if rgba is None:
            index = self.product.part_names.index(part)
            rgba = (*PALETTE[index % len(PALETTE)], 1.0)
        color = (float(rgba[0]), float(rgba[1]), float(rgba[2]), float(rgba[3]))
        return SceneItem(self.mesh(part), np.asarray(T_world_part, float), color, name=part)

    def gripper_item(self, step: Step, T_world_part: np.ndarray, opening: str) -> SceneItem:
        grasp = step.grasp
        assert grasp is not None
        half = (grasp.open_width_m if opening == "open" else grasp.width_m) / 2.0
        mesh = pieces_mesh(gripper_model(self.product.resources.gripper, half))
        return SceneItem(mesh, np.asarray(T_world_part) @ grasp.T_part_gripper, GRIPPER_RGBA,
                         name="gripper")

    def arm_states(self, step: Step) -> dict[str, np.ndarray]:
        """The arm's joint angles (6,) at the pick (the clamp's start), pre-insertion (the
        lowering's start) and inserted (the release's start) views; empty without an arm."""
        if step.arm is None or step.trajectory is None:
            return {}
        traj = step.trajectory
        out = {}
        for label, phase in (("pick", "clamp"), ("pre-insertion", "lower"),
                             ("inserted", "release")):
            names = [p.name for p in traj.phases]
            if phase in names:
                t = traj.phases[names.index(phase)].t_start_s
                k = int(np.argmin(np.abs(traj.t_s - t)))
                out[label] = step.arm.q_rad[k]
        return out

    def arm_items(self, q_rad: np.ndarray) -> list[SceneItem]:
        """The arm's links (their collision hulls) posed at ``q_rad``."""
        robot = self.product.resources.robot
        if robot is None:
            return []
        from ..planner.arm import posed_links  # the planner's kinematics poses the links

        if not hasattr(self, "_arm_meshes"):
            self._arm_meshes: dict[str, trimesh.Trimesh] = {}
        # one mesh for the whole arm: one draw call, so the renderer's draw order between
        # overlapping link hulls cannot change pixels from run to run
        meshes = []
        for name, model, T in posed_links(robot, q_rad):
            if name not in self._arm_meshes:
                self._arm_meshes[name] = pieces_mesh(model)
            m = self._arm_meshes[name].copy()
            m.apply_transform(T)
            meshes.append(m)
        arm: trimesh.Trimesh = trimesh.util.concatenate(meshes)  # type: ignore[assignment]
        return [SceneItem(arm, np.eye(4), ARM_RGBA, name="arm")]

    def table_item(self, items: Sequence[SceneItem]) -> SceneItem:
        """A thin slab under the items (the table top, z <= 0), only as large as needed."""
        bounds = np.array([it.world_bounds_m() for it in items])
        lo, hi = bounds[:, 0].min(axis=0), bounds[:, 1].max(axis=0)
        pad = 0.25 * max(hi[0] - lo[0], hi[1] - lo[1], 0.05)
        size = [hi[0] - lo[0] + 2 * pad, hi[1] - lo[1] + 2 * pad, 0.004]
        T = np.eye(4)
        T[:3, 3] = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, -0.002]
        return SceneItem(trimesh.creation.box(extents=size), T, TABLE_RGBA, name="table")

    def shoot(self, items: list[SceneItem], path: Path, *, camera: Camera | None = None) -> Path:
        cam = camera or fit_camera(items, direction=VIEW_DIRECTION, width_px=self.width_px,
                                   height_px=self.height_px)
        image = render([*items, self.table_item(items)], cam)
        return save_png(image, path)

    def assembled_items(self, parts: Sequence[str] | None = None) -> list[SceneItem]:
        names = self.product.part_names if parts is None else parts
        return [self.part_item(n, self.product.T_world_assembled(n)) for n in names]

    def exploded_items(self, factor: float = 0.9) -> list[SceneItem]:
        """The assembled items moved outward and upward from the product's bottom centre."""
        items = self.assembled_items()
        bounds = np.array([it.world_bounds_m() for it in items])
        centre = 0.5 * (bounds[:, 0].min(axis=0) + bounds[:, 1].max(axis=0))
        centre[2] = bounds[:, 0, 2].min()
        return exploded(items, centre, factor)

    def render_product(self, folder: Path) -> tuple[str, str]:
        """Assembled and exploded views; returns their file names."""
        self.shoot(self.assembled_items(), folder / "assembled.png")
        self.shoot(self.exploded_items(), folder / "exploded.png")
        return "assembled.png", "exploded.png"

    def render_step(self, plan: Plan, step: Step, folder: Path) -> dict[str, str]:
        """Pick, pre-insertion and inserted views of one step (with the gripper)."""
        placed = [s.part for s in plan.steps if s.index < step.index]
        out: dict[str, str] = {}
        poses = {"pick": (step.T_world_start, "closed")}
        if step.T_world_pre_insertion is not None:
            poses["pre-insertion"] = (step.T_world_pre_insertion, "closed")
        poses["inserted"] = (step.T_world_final, "closed")
        # one camera for the three views of a step, framing the product and the pick spot
        frame_items = [*self.assembled_items(placed), self.part_item(step.part, step.T_world_start),
                       self.part_item(step.part, step.T_world_final)]
        camera = fit_camera(frame_items, direction=VIEW_DIRECTION, width_px=self.width_px,
                            height_px=self.height_px)
        arm_q = self.arm_states(step)
        for label, (T, opening) in poses.items():
            items = [*self.assembled_items(placed), self.part_item(step.part, T, HELD_RGBA)]
            if step.grasp is not None:
                items.append(self.gripper_item(step, T, opening))
            if label in arm_q:
                items += self.arm_items(arm_q[label])
            name = f"step{step.index:02d}-{label}.png"
            self.shoot(items, folder / name, camera=camera)
            out[label] = name
        return out


def render_product(product: Product, path: str | Path, geometry: ProductGeometry, *,
                   exploded_view: bool = False,
                   width_px: int = 800, height_px: int = 600) -> Path:
    """Render the assembled (or exploded) product offscreen to a PNG at ``path``."""
    views = Views(product, geometry, width_px, height_px)
    items = views.exploded_items() if exploded_view else views.assembled_items()
    return views.shoot(items, Path(path))
