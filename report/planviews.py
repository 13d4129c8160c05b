"""The report's pictures that need only the plan, rendered while the steps simulate.

The product views (assembled, exploded), each step's planned path, the storyboard, the
precedence graph and the arm's reach need the plan, not the simulation. ``asmplan run``
simulates the steps in worker processes while its own process waits for them; it renders these
pictures in that time (:func:`render_plan_views`, called by
:func:`asmplan.pipeline.run_product` through ``while_simulating``) into the run's staging
folder, and :func:`asmplan.report.html.write_report` then draws only what needs the simulation
(sections at the simulated end, animations, force and depth plots). The pictures are the same
bytes either way; the output folder is still swapped in whole at the end (outputs atomic).
With a core to spare, ``asmplan run`` draws them in a picture process forked before it plans
instead (:mod:`asmplan.report.picture_pool`); this module is the one-process way (``-j 1``,
the library's default).

Measured on the seed workstation at ``balanced`` (``asmplan run``'s last line, median of 3):
1.5 s of the report's 2.7 s CPU is plan-only (the imports of trimesh, pyrender, matplotlib and
the template included) and now runs while the simulation workers run; the report's wall time
after the simulation fell from 2.8 to 1.2 s. The job's CPU is about the same: this moves work,
it does not remove it (on 2 cores it shortens the job where a core would otherwise idle, e.g.
while the last step simulates alone).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..knowledge.model import Product
from ..planner.plan import NOT_ROBOT_KINDS, Plan
from . import plots
from .steppictures import StepPictures, grip_limit, render_step_pictures

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry
    from .views import Views


def path_view_name(index: int) -> str:
    """File name of the planned-path picture of the step with 0-based ``index``."""
    return f"step{index + 1:02d}-path.png"


@dataclass
class PlanViews:
    """The plan-only pictures of a report, already written into ``folder``.

    Attributes
    ----------
    folder : Path
        Where they were written (only a report into the same folder reuses them).
    plan : Plan
        The plan they show (only a report of this very plan reuses them).
    views : Views
        The renderer's views, with their meshes (reused for the remaining pictures).
    images : dict
        ``assembled`` and ``exploded``: file names.
    paths : dict
        Step index -> file name of its planned-path picture (steps the robot moves).
    story : list of (step index, part, file name)
        The storyboard.
    graph : str
        File name of the precedence graph ("" without a sequence).
    reach : str
        File name of the arm's reach plot ("" without an arm).
    steps : dict
        Step index -> its result pictures (:mod:`asmplan.report.steppictures`), drawn by
        :meth:`step_done` as each step's result came back.
    cpu_s : float
        CPU seconds this process spent rendering them.
    """

    folder: Path
    plan: Plan
    views: Views
    images: dict[str, str] = field(default_factory=dict)
    paths: dict[int, str] = field(default_factory=dict)
    story: list[tuple[int, str, str]] = field(default_factory=list)
    graph: str = ""
    reach: str = ""
    steps: dict[int, StepPictures] = field(default_factory=dict)
    cpu_s: float = 0.0

    def step_done(self, product: Product, step_result: Any) -> None:
        """Draw the pictures of the step whose result just came back (see
        :mod:`asmplan.report.steppictures`); its CPU time is added to :attr:`cpu_s`."""
        c0 = time.process_time()
        step = self.plan.steps[step_result.index]
        self.steps[step.index] = render_step_pictures(
            product, self.plan, self.views, step, step_result, self.folder,
            grip_limit(product, step))
        self.cpu_s += time.process_time() - c0

    def usable_for(self, plan: Plan | None, folder: Path) -> bool:
        """True when these pictures show ``plan`` and lie in ``folder``."""
        return plan is self.plan and Path(folder) == self.folder


def has_arm_block(product: Product, plan: Plan | None) -> bool:
    """Whether the report has the arm's table (a robot arm and a plan with arm motions)."""
    return (plan is not None and product.resources.robot is not None
            and any(s.arm for s in plan.steps))


def render_plan_views(product: Product, geometry: ProductGeometry, sequence: Any | None,
                      plan: Plan, folder: Path) -> PlanViews:
    """Render the report's plan-only pictures into ``folder`` (see the module docstring).

    Parameters
    ----------
    product, geometry : the product and its shared geometry.
    sequence : SequencePlan or None
        The sequence explanation (its precedence graph is drawn), None when it did not run.
    plan : Plan
    folder : Path
        The report's folder (the run's staging folder).

    Returns
    -------
    PlanViews
    """
    from .views import Views

    c0 = time.process_time()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    views = Views(product, geometry)
    out = PlanViews(folder, plan, views)
    assembled, exploded = views.render_product(folder)
    out.images = {"assembled": assembled, "exploded": exploded}
    for step in plan.steps:
        if step.kind not in NOT_ROBOT_KINDS:
            name = path_view_name(step.index)
            views.path_view(plan, step, folder / name)
            out.paths[step.index] = name
    out.story = views.storyboard(plan, folder)
    if sequence is not None:
        out.graph = "precedence.png"
        plots.precedence_graph_plot(sequence.precedence, folder / out.graph,
                                    order=list(plan.sequence))
    if has_arm_block(product, plan):
        from ..planner.arm import reach_facts

        robot = product.resources.robot
        assert robot is not None  # has_arm_block checked it
        shoulder, reach = reach_facts(robot)
        plots.reach_plot(product, plan, shoulder, reach, folder / "cell-reach.png")
        out.reach = "cell-reach.png"
    from .html import report_template

    report_template()  # compiled now, not after the simulation
    out.cpu_s = time.process_time() - c0
    return out
