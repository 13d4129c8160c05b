"""Rendered views of a product and its plan: assembled, exploded, and each step's key poses.

Views are built from the part meshes of :class:`~asmplan.parts.models.ProductGeometry` and the
poses of a :class:`~asmplan.planner.plan.Plan`, and rendered offscreen by
:mod:`asmplan.report.render`.
"""

from __future__ import annotations

import io
import itertools
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np
import trimesh

from ..knowledge.model import Product
from ..parts.cell import gripper_model, regrasp_fixture_model
from ..parts.pieces import CollisionModel
from ..planner.plan import Plan, Step
from .camera import Camera, SceneItem, exploded, fit_camera
from .render import render, save_png

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry
    from ..sim.records import StepRecord

GRIPPER_RGBA = (0.25, 0.27, 0.30, 1.0)
ARM_RGBA = (0.92, 0.92, 0.94, 1.0)
HELD_RGBA = (0.95, 0.55, 0.10, 1.0)
TABLE_RGBA = (0.86, 0.84, 0.80, 1.0)
FIXTURE_RGBA = (0.50, 0.52, 0.56, 1.0)  # the cell's regrasp fixtures
WAITING_RGBA = (0.78, 0.78, 0.78, 1.0)  # parts still on the tray
PATH_RGBA = (0.10, 0.35, 0.85, 1.0)  # the planned path of the part's centre (transport)
INSERT_PATH_RGBA = (0.85, 0.10, 0.10, 1.0)  # the part's centre while it is lowered/inserted
GHOST_ALPHA = 0.35
ANIMATION_FRAMES = 12
"""Most frames of a step's animation (see :func:`animation_ticks`)."""
ANIMATION_STILL_M = 0.5e-3
"""A candidate frame is left out when neither the part nor the gripper moved more than this
since the frame before it and the gripper's opening is the same (it would show the same
picture under another phase name)."""
ANIMATION_SIZE_PX = (320, 240)
STORY_SIZE_PX = (320, 240)
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

    def shoot(self, items: list[SceneItem], path: Path, *, camera: Camera | None = None,
              labelled: bool = False) -> Path:
        """Render ``items`` on the table top; with ``labelled``, each item's name is written
        beside it."""
        cam = camera or fit_camera(items, direction=VIEW_DIRECTION, width_px=self.width_px,
                                   height_px=self.height_px)
        image = render([*items, self.table_item(items)], cam)
        if labelled:
            image = draw_labels(image, cam, list(zip([it.name for it in items],
                                                     visible_anchors(items, cam), strict=True)))
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
        self.shoot(self.assembled_items(), folder / "assembled.png", labelled=True)
        self.shoot(self.exploded_items(), folder / "exploded.png", labelled=True)
        return "assembled.png", "exploded.png"

    # ------------------------------------------------------------------------------------
    # What a cell engineer looks at per step: the path, the mate in section, the motion
    # ------------------------------------------------------------------------------------
    def waiting_items(self, plan: Plan, after_index: int) -> list[SceneItem]:
        """Parts of steps after ``after_index`` at their start poses (on the tray), in grey."""
        moved = {s.part for s in plan.steps if s.index <= after_index}
        first: dict[str, Step] = {}
        for s in plan.steps:  # a regrasped part waits once, where its first step picks it
            if s.index > after_index and s.kind != "fixture" and s.part not in moved:
                first.setdefault(s.part, s)
        return [self.part_item(s.part, s.T_world_start, WAITING_RGBA) for s in first.values()]

    def placed_items(self, plan: Plan, before_index: int) -> list[SceneItem]:
        """Parts of the steps before ``before_index`` at their assembled poses (a regrasped
        part where its regrasp put it), and the cell's regrasp fixtures."""
        last = {s.part: s for s in plan.steps if s.index < before_index}  # the latest pose
        return [*self.fixture_items(), *(self.part_item(s.part, s.T_world_final)
                                         for s in plan.steps if last.get(s.part) is s)]

    def fixture_items(self) -> list[SceneItem]:
        """The cell's declared regrasp fixtures (``resources.regrasp``), in grey."""
        if not hasattr(self, "_fixture_meshes"):
            self._fixture_meshes = [(f"fixture:{fx.name}", pieces_mesh(regrasp_fixture_model(fx)),
                                     np.asarray(fx.T_world_fixture, float))
                                    for fx in self.product.resources.regrasp]
        return [SceneItem(m, T, FIXTURE_RGBA, name=n) for n, m, T in self._fixture_meshes]

    def part_centre_path_m(self, step: Step) -> tuple[np.ndarray, np.ndarray]:
        """The planned path of the held part's centre: (transport points, insertion points),
        each (K, 3) in metres, from the step's trajectory (held phases only)."""
        traj = step.trajectory
        if traj is None or step.grasp is None:
            return np.zeros((0, 3)), np.zeros((0, 3))
        T_gripper_part = np.linalg.inv(step.grasp.T_part_gripper)
        centre = np.r_[np.asarray(self.mesh(step.part).centroid, float), 1.0]
        points = (traj.T_world_gripper @ T_gripper_part @ centre)[:, :3]
        t = np.asarray(traj.t_s)

        def span(*names: str) -> np.ndarray:
            mask = np.zeros(t.shape, bool)
            for ph in traj.phases:
                if ph.name in names:
                    mask |= (t >= ph.t_start_s) & (t <= ph.t_end_s)
            return points[mask]

        return span("hold", "lift", "translate"), span("lower", "insert")

    def path_view(self, plan: Plan, step: Step, path: Path) -> Path:
        """The planned path of the part's centre drawn over the cell: parts placed so far,
        parts still waiting (grey), the part at its pick pose (translucent) and at its target,
        the transport path (blue) and the insertion (red); every part labelled."""
        transport, insertion = self.part_centre_path_m(step)
        items = [*self.placed_items(plan, step.index), *self.waiting_items(plan, step.index)]
        ghost = self.part_item(step.part, step.T_world_start, (*HELD_RGBA[:3], GHOST_ALPHA))
        final = self.part_item(step.part, step.T_world_final, HELD_RGBA)
        items += [final, ghost]
        extent = float(np.linalg.norm(np.ptp(np.array([it.world_bounds_m() for it in items])
                                             .reshape(-1, 3), axis=0)))
        radius = max(0.004 * extent, 3e-4)
        for pts, rgba, name in ((transport, PATH_RGBA, "path"), (insertion, INSERT_PATH_RGBA,
                                                                   "insertion")):
            tube = tube_mesh(pts, radius)
            if tube is not None:
                items.append(SceneItem(tube, np.eye(4), rgba, name=name))
        cam = fit_camera(items, direction=VIEW_DIRECTION, width_px=self.width_px,
                         height_px=self.height_px)
        image = render([*items, self.table_item(items)], cam)
        anchors = dict(zip(map(id, items), visible_anchors(items, cam), strict=True))
        labels = [(f"{step.part} (pick)", anchors[id(ghost)]),
                  (f"{step.part} (target)", anchors[id(final)])]
        labels += [(it.name, anchors[id(it)]) for it in items
                   if it.name not in (step.part, "path", "insertion")]
        return save_png(draw_labels(image, cam, labels), path)

    def section_view(self, step: Step, T_world_part: np.ndarray, path: Path,
                     others: Sequence[tuple[str, np.ndarray]]) -> tuple[Path, str]:
        """Close-up of the mate cut through the pin axis (gripper hidden), with the part at
        ``T_world_part`` and its mate partners at ``others`` (name, pose). Returns the path
        and a description of the cut."""
        mates = [m for m in self.product.mates if m.name in step.mates]
        direction = (np.asarray(step.insertion_direction, float)
                     if step.insertion_direction is not None else np.array([0.0, 0.0, -1.0]))
        direction = direction / np.linalg.norm(direction)
        pins = []
        for m in mates:
            pin_part, pin_feature = ((m.pin_part, m.pin_feature) if m.pin_part == step.part
                                     else (m.hole_part, m.hole_feature))
            feat = self.product.feature(pin_part, pin_feature)
            T = T_world_part if pin_part == step.part else dict(others).get(pin_part, np.eye(4))
            pins.append(T[:3, :3] @ feat.origin_m + T[:3, 3])
        if pins:
            origin = pins[0]
            across = pins[-1] - pins[0] if len(pins) > 1 else np.cross(direction, [0.3, 0.5, 0.8])
        else:
            origin = T_world_part[:3, 3]
            across = np.cross(direction, [0.3, 0.5, 0.8])
        across = across - direction * float(across @ direction)
        normal = np.cross(direction, across / max(np.linalg.norm(across), 1e-12))
        if normal @ np.asarray(VIEW_DIRECTION) < 0:
            normal = -normal
        held = self.part_item(step.part, T_world_part, HELD_RGBA)
        items = [held, *(self.part_item(n, T) for n, T in others if n != step.part)]
        cut = [section_item(it, origin, normal) for it in items]
        cam = fit_camera([cut[0]], direction=normal + 0.45 * np.array([0, 0, 1.0]) + 0.25 * across
                         / max(np.linalg.norm(across), 1e-12), margin=1.8,
                         width_px=self.width_px, height_px=self.height_px)
        image = render(cut, cam)
        labels = list(zip([it.name for it in items], visible_anchors(cut, cam), strict=True))
        names = ", ".join(m.name for m in mates) or "the part"
        return (save_png(draw_labels(image, cam, labels), path),
                f"section through {names} (gripper hidden)")

    def animation(self, plan: Plan, step: Step, record: StepRecord, path: Path,
                  frames: int = ANIMATION_FRAMES) -> Path:
        """An animated PNG of the simulated step at the ticks of :func:`animation_ticks` (at
        most ``frames``): part and gripper as simulated, one fixed camera, the part labelled,
        each frame captioned with its time and phase."""
        from PIL import Image

        w, h = ANIMATION_SIZE_PX
        static = [*self.placed_items(plan, step.index), *self.waiting_items(plan, step.index)]
        open_ids = [i for i, n in enumerate(record.phase_names) if n in ("approach", "retreat",
                                                                          "release")]
        ticks = animation_ticks(record, open_ids, frames)
        grippers = {}
        if step.grasp is not None:
            for opening in ("open", "closed"):
                half = (step.grasp.open_width_m if opening == "open" else step.grasp.width_m) / 2
                grippers[opening] = pieces_mesh(gripper_model(self.product.gripper_for(step.part),
                                                                half))
        frame_items = [*static, self.part_item(step.part, record.T_world_part[0]),
                       self.part_item(step.part, record.T_world_part[-1]),
                       self.part_item(step.part, step.T_world_final)]
        # the arm (issue 20), when the plan has one: posed at the trajectory sample nearest
        # each frame's time, and framed at its pick, pre-insertion and inserted poses
        arm_q = self.arm_states(step)
        for q in arm_q.values():
            frame_items += self.arm_items(q)
        cam = fit_camera(frame_items, direction=VIEW_DIRECTION, width_px=w, height_px=h)
        table = self.table_item(frame_items)
        images = []
        for k in ticks:
            part = self.part_item(step.part, record.T_world_part[k], HELD_RGBA)
            items = [*static, part, table]
            if step.arm is not None and step.trajectory is not None:
                j = int(np.argmin(np.abs(step.trajectory.t_s - record.t_s[k])))
                items += self.arm_items(step.arm.q_rad[j])
            if grippers and np.all(np.isfinite(record.T_world_gripper[k])):
                opening = "open" if int(record.phase_index[k]) in open_ids else "closed"
                items.append(SceneItem(grippers[opening], record.T_world_gripper[k], GRIPPER_RGBA,
                                       name="gripper"))
            phase = record.phase_names[int(record.phase_index[k])]
            image = draw_labels(render(items, cam), cam, [(step.part, _centre(part))],
                                caption=f"t = {record.t_s[k] - record.t_s[0]:.2f} s  {phase}")
            images.append(Image.fromarray(image).quantize(colors=256,
                                                          method=Image.Quantize.FASTOCTREE,
                                                          dither=Image.Dither.NONE))
        durations = [400] * (len(images) - 1) + [1200]  # 8 frames or so: 0.4 s each
        buf = io.BytesIO()
        images[0].save(buf, format="PNG", save_all=True, append_images=images[1:],
                       duration=durations, loop=0, compress_level=6)
        from ..fileio import atomic_write_bytes

        return atomic_write_bytes(path, buf.getvalue())

    def storyboard(self, plan: Plan, folder: Path) -> list[tuple[int, str, str]]:
        """The assembly state after each step, one small image each with a fixed camera:
        (step index, part, file name)."""
        w, h = ANIMATION_SIZE_PX
        every = [*self.placed_items(plan, len(plan.steps)), *self.waiting_items(plan, -1)]
        cam = fit_camera(every, direction=VIEW_DIRECTION, width_px=w, height_px=h)
        table = self.table_item(every)
        out = []
        for step in plan.steps:
            placed = self.placed_items(plan, step.index)
            new = self.part_item(step.part, step.T_world_final, HELD_RGBA)
            items = [*placed, new, *self.waiting_items(plan, step.index), table]
            name = f"step{step.index + 1:02d}-after.png"
            image = draw_labels(render(items, cam), cam, [(step.part, _centre(new))])
            save_png(image, folder / name)
            out.append((step.index, step.part, name))
        return out


def animation_ticks(record: StepRecord, open_phases: Sequence[int],
                    frames: int = ANIMATION_FRAMES) -> np.ndarray:
    """The record ticks an animation shows: the start of every phase, the middle of each phase
    longer than a fifth of the step (the transport, the insertion) and the last tick; a
    candidate that shows the same picture as the frame before it (part and gripper within
    :data:`ANIMATION_STILL_M`, same opening; e.g. "hold" after "clamp") is left out. Every
    phase in which something moves is thus shown at its start, which evenly spaced ticks do
    not promise (a short clamp or release falls between them), with fewer frames to render.
    More than ``frames`` candidates are thinned evenly.

    Parameters
    ----------
    record : StepRecord
    open_phases : indices of phases in which the gripper is drawn open.
    frames : most frames.

    Returns
    -------
    (K,) int array
        Increasing tick indices, 1 <= K <= ``frames``.
    """
    n = record.n_ticks
    idx = np.asarray(record.phase_index)
    starts = [int(i) for i in np.flatnonzero(np.r_[True, idx[1:] != idx[:-1]])]
    ends = [*starts[1:], n]
    t = np.asarray(record.t_s)
    total = max(float(t[-1] - t[0]), 1e-12)
    candidates = set(starts) | {n - 1}
    for a, b in zip(starts, ends, strict=True):
        if float(t[b - 1] - t[a]) > 0.2 * total:
            candidates.add((a + b) // 2)
    part = np.asarray(record.T_world_part)[:, :3, 3]
    grip = np.asarray(record.T_world_gripper)[:, :3, 3]
    opened = np.isin(idx, list(open_phases))
    kept: list[int] = []
    for k in sorted(candidates):
        if kept and k != n - 1:
            j = kept[-1]
            moved = max(float(np.linalg.norm(part[k] - part[j])),
                        float(np.nan_to_num(np.linalg.norm(grip[k] - grip[j]), nan=np.inf)))
            if moved <= ANIMATION_STILL_M and opened[k] == opened[j]:
                continue
        kept.append(k)
    if len(kept) > frames:
        kept = [kept[i] for i in np.unique(np.linspace(0, len(kept) - 1, frames).round()
                                           .astype(int))]
    return np.asarray(kept, dtype=int)


def visible_anchors(items: Sequence[SceneItem], camera: Camera) -> list[np.ndarray | None]:
    """Per item, the pixel ``(column, row)`` of its visible area nearest that area's centroid
    (None when it is hidden or out of view): where its label's leader should point."""
    from .render import render_labels

    seg = render_labels(items, camera)
    out: list[np.ndarray | None] = []
    for k in range(len(items)):
        rows, cols = np.nonzero(seg == k)
        if rows.size == 0:
            out.append(None)
            continue
        i = int(np.argmin((rows - rows.mean()) ** 2 + (cols - cols.mean()) ** 2))
        out.append(np.array([cols[i] + 0.5, rows[i] + 0.5]))
    return out


def _centre(item: SceneItem) -> np.ndarray:
    b = item.world_bounds_m()
    return 0.5 * (b[0] + b[1])


def tube_mesh(points_m: np.ndarray, radius_m: float) -> trimesh.Trimesh | None:
    """A polyline as a chain of thin cylinders (points closer than a radius are merged)."""
    pts = np.asarray(points_m, float)
    if len(pts) < 2:
        return None
    # keep the corners: a point is dropped while the path runs straight on (within ~1 deg)
    # and is less than a radius from the last kept one (paths are mostly straight lines)
    kept = [pts[0]]
    for i in range(1, len(pts) - 1):
        a, b = pts[i] - kept[-1], pts[i + 1] - pts[i]
        na, nb = np.linalg.norm(a), np.linalg.norm(b)
        if na < 2.0 * radius_m:
            continue
        if nb > 1e-12 and float(a @ b) / (na * nb) > 0.9998:
            continue
        kept.append(pts[i])
    if np.linalg.norm(pts[-1] - kept[-1]) > 1e-9:
        kept.append(pts[-1])
    segments = [trimesh.creation.cylinder(radius=radius_m, segment=[a, b], sections=10)
                for a, b in itertools.pairwise(kept)
                if np.linalg.norm(b - a) > 1e-9]
    if not segments:
        return None
    segments.append(trimesh.creation.icosphere(subdivisions=1, radius=2.0 * radius_m)
                    .apply_translation(kept[-1]))
    return cast(trimesh.Trimesh, trimesh.util.concatenate(segments))


def section_item(item: SceneItem, origin_m: np.ndarray, normal: np.ndarray) -> SceneItem:
    """The part of ``item`` behind the plane through ``origin_m`` with ``normal`` (the half
    facing the viewer removed), as a closed mesh (manifold boolean); the whole item when the
    cut fails or leaves nothing."""
    T_item_world = np.linalg.inv(item.T_world_item)
    o = T_item_world[:3, :3] @ origin_m + T_item_world[:3, 3]
    n = T_item_world[:3, :3] @ normal
    size = 4.0 * float(np.linalg.norm(item.mesh.extents)) + 1.0
    box = trimesh.creation.box(extents=[size, size, size])
    z = n / np.linalg.norm(n)
    x = np.cross(z, [1.0, 0, 0] if abs(z[0]) < 0.9 else [0, 1.0, 0])
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2] = x, np.cross(z, x), z
    T[:3, 3] = o - z * size / 2.0  # the box fills the half-space behind the plane
    box.apply_transform(T)
    try:
        kept = item.mesh.intersection(box, engine="manifold")
    except Exception:  # a display cut: the whole part is a fine fallback
        return item
    if kept is None or len(kept.faces) == 0:
        return item
    return SceneItem(kept, item.T_world_item, item.color_rgba, item.name)


def draw_labels(image: np.ndarray, camera: Camera,
                labels: Sequence[tuple[str, np.ndarray | None]], caption: str = "") -> np.ndarray:
    """Names drawn with a leader line to their anchor, a world point (3,) projected by
    ``camera`` or a pixel ``(column, row)`` (2,); None is skipped. Boxes are pushed apart so
    they do not overlap; an optional caption goes in the top-left corner."""
    from PIL import Image, ImageDraw, ImageFont

    pil = Image.fromarray(image)
    draw = ImageDraw.Draw(pil)
    size = max(12, camera.height_px // 28)
    font = ImageFont.load_default(size=size)
    taken: list[tuple[float, float, float, float]] = []
    for text, point in labels:
        if point is None:
            continue
        anchor = np.asarray(point, float)
        if anchor.shape == (2,):  # already a pixel (column, row)
            col, row = float(anchor[0]), float(anchor[1])
        else:
            try:
                col, row = camera.project(anchor)
            except ValueError:
                continue
        if not (0 <= col < camera.width_px and 0 <= row < camera.height_px):
            continue
        x0, t, r, b = draw.textbbox((0, 0), text, font=font)
        tw, th = r - x0 + 8, b - t + 6
        x = min(max(col + 14, 2), camera.width_px - tw - 2)
        y = min(max(row - th - 14, 2), camera.height_px - th - 2)
        for _ in range(30):
            box = (x, y, x + tw, y + th)
            if not any(box[0] < q[2] and q[0] < box[2] and box[1] < q[3] and q[1] < box[3]
                       for q in taken):
                break
            y = y + th + 2 if y + 2 * th + 4 < camera.height_px else 2
        taken.append((x, y, x + tw, y + th))
        draw.line([(col, row), (x + 2, y + th / 2)], fill=(40, 40, 40), width=1)
        draw.ellipse([col - 2, row - 2, col + 2, row + 2], fill=(40, 40, 40))
        draw.rectangle([x, y, x + tw, y + th], fill=(255, 255, 255), outline=(90, 90, 90))
        draw.text((x + 4 - x0, y + 3 - t), text, fill=(20, 20, 20), font=font)
    if caption:
        x0, t, r, b = draw.textbbox((0, 0), caption, font=font)
        draw.rectangle([2, 2, r - x0 + 10, b - t + 8], fill=(255, 255, 255))
        draw.text((6 - x0, 5 - t), caption, fill=(20, 20, 20), font=font)
    return np.asarray(pil)


def render_product(product: Product, path: str | Path, geometry: ProductGeometry, *,
                   exploded_view: bool = False,
                   width_px: int = 800, height_px: int = 600) -> Path:
    """Render the assembled (or exploded) product offscreen to a PNG at ``path``."""
    views = Views(product, geometry, width_px, height_px)
    items = views.exploded_items() if exploded_view else views.assembled_items()
    return views.shoot(items, Path(path))
