"""A step's pictures that need its simulation result, rendered as soon as that step is done.

The section at the simulated end, the animation and the clamp-force and insertion plots of a
step need only the plan, the product and that step's own :class:`~asmplan.sim.results.StepResult`.
``asmplan run`` simulates the steps in worker processes; when a step's result comes back while
others still simulate, :func:`render_step_pictures` draws its pictures then
(:func:`asmplan.pipeline.render_while_simulating`), and :func:`asmplan.report.html.write_report`
reuses them (:attr:`StepPictures.result` must be the very result it reports). The pictures are
the same bytes either way; only when they are drawn changes.

Measured on the seed workstation at ``balanced`` (2 cores): these pictures cost about 0.5 s of
CPU per step (animation 0.2 s, insertion plot 0.14 s, clamp-force plot 0.1 s, section 0.08 s),
which all fell after the simulation before; now only the last step's remain there (figures in
docs/physics.md, "Where the seed job's CPU goes").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..knowledge.model import Product
from ..planner.plan import NOT_ROBOT_KINDS, Plan, Step
from . import plots

if TYPE_CHECKING:  # the renderer (trimesh) is imported where pictures are rendered
    from .views import Views


@dataclass(frozen=True)
class StepPictures:
    """The result-dependent pictures of one step, already written.

    Attributes
    ----------
    result : StepResult
        The result they show (a report of another result draws its own).
    views : tuple of dict
        Entries of the step's ``views`` after its planned path (section, animation), each
        ``src``, ``kind``, ``caption``.
    plots : tuple of (title, file name)
        The step's plots in the order they are shown.
    """

    result: Any
    views: tuple[dict[str, str], ...] = ()
    plots: tuple[tuple[str, str], ...] = ()


def failure_caption(res: Any) -> str:
    """The reasons of a failed step ("" when it succeeded)."""
    o = res.outcome
    if o.success:
        return ""
    return "; ".join(o.reasons)


def step_base_name(index: int) -> str:
    """File name stem of the pictures of the step with 0-based ``index``."""
    return f"step{index + 1:02d}"


def render_step_pictures(product: Product, plan: Plan, views: Views | None, step: Step,
                         res: Any, folder: Path, grip_limit_N: float | None) -> StepPictures:
    """Draw the pictures of ``step`` that need its result ``res`` (None: not simulated).

    ``views`` None draws only the plots (a report without rendered images);
    ``grip_limit_N``: the clamp's limit drawn on the clamp-force plot (None without a clamp).
    The rendered views (:func:`render_step_views`) and the plots (:func:`draw_step_plots`)
    are independent: a run may draw them in different processes.
    """
    entries = (render_step_views(product, plan, views, step, res, folder)
               if views is not None else ())
    return StepPictures(res, entries, draw_step_plots(step, res, folder, grip_limit_N))


def render_step_views(product: Product, plan: Plan, views: Views, step: Step, res: Any,
                      folder: Path) -> tuple[dict[str, str], ...]:
    """Render the section at the simulated end and the animation of ``step`` (result ``res``,
    None: not simulated) into ``folder``; their ``views`` entries (``src``, ``kind``,
    ``caption``), none for a step the robot does not move."""
    folder = Path(folder)
    base = step_base_name(step.index)
    outcome = res.outcome if res is not None else None
    entries: list[dict[str, str]] = []
    if step.kind not in NOT_ROBOT_KINDS:
        failed = outcome is not None and not outcome.success
        rec = res.record if res is not None else None
        placed = {s.part: s.T_world_final for s in plan.steps if s.index < step.index}
        partners = [(p, placed[p]) for m in product.mates if m.name in step.mates
                    for p in (m.pin_part, m.hole_part) if p in placed]
        partners = list(dict(partners).items())
        if rec is not None and rec.n_ticks > 0 and np.all(np.isfinite(rec.T_world_part[-1])):
            T_end, where = rec.T_world_part[-1], "simulated end of the step"
        else:
            T_end, where = step.T_world_final, "planned target"
        name = f"{base}-section.png"
        _, cut = views.section_view(step, T_end, folder / name, partners)
        caption = f"{cut}, {where}"
        if failed:
            caption = (f"FAILED, this is where {step.part} ended: {failure_caption(res)} "
                       f"({cut})")
        entries.append({"src": name, "kind": "section", "caption": caption})
        if rec is not None and rec.n_ticks > 1:
            name = f"{base}-animation.png"
            views.animation(plan, step, rec, folder / name)
            entries.append({"src": name, "kind": "animation", "caption":
                            ("simulated step (animated; " +
                             ("FAILED: " + failure_caption(res) if failed else
                              "part and gripper as simulated") + ")")})
    return tuple(entries)


def draw_step_plots(step: Step, res: Any, folder: Path, grip_limit_N: float | None
                    ) -> tuple[tuple[str, str], ...]:
    """Draw the clamp-force and insertion plots of ``step`` (result ``res``, None: not
    simulated) into ``folder``; (title, file name) of each, in the order they are shown."""
    folder = Path(folder)
    base = step_base_name(step.index)
    drawn: list[tuple[str, str]] = []
    if res is not None and res.record is not None and res.record.n_ticks > 1:
        rec = res.record
        clamp = step.clamp
        title = f"step {step.index + 1}: {step.part}"
        name = f"{base}-clamp-force.png"
        plots.clamp_force_plot(rec, folder / name, title=title,
                               slip_threshold_N=clamp.slip_limit_N if clamp else None,
                               grip_limit_N=grip_limit_N if clamp else None)
        drawn.append(("clamp force: commanded vs simulated", name))
        if step.insertion_length_m > 0 and math.isfinite(float(rec.axial_error_m[-1])):
            name = f"{base}-insertion.png"
            plots.insertion_plot(rec, folder / name, target_depth_m=step.insertion_length_m,
                                 title=title)
            drawn.append(("insertion depth and contact force", name))
    return tuple(drawn)


def grip_limit(product: Product, step: Step) -> float:
    """The clamp limit a step's clamp-force plot shows: the planned clamp's, else the
    gripper's maximum (with the pads this part's step uses)."""
    clamp = step.clamp
    return clamp.limit_N if clamp is not None else product.gripper_for(step.part).max_force_N
