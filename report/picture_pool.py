"""The report's rendered pictures drawn in a picture process forked when a run starts.

``asmplan run`` with several cores (:func:`asmplan.pipeline.render_while_simulating` with
``workers``) forks one picture process (:class:`PicturePool`) as soon as its output folder is
reserved, before the sequence is planned. While the run's own process sequences and plans
(one core busy, the other idle on a 2-core machine), the picture process imports the
renderer (pyrender, OSMesa, trimesh), builds the parts' display meshes and renders the
assembled and exploded views. Once the plan exists it renders each step's planned path and
the storyboard while the steps simulate, and each step's section and animation
(:func:`asmplan.report.steppictures.render_step_views`) as that step's result comes back.
The run's own process draws the matplotlib pictures meanwhile (precedence graph, the arm's
reach, each step's clamp-force and insertion plots, :func:`draw_step_plots
<asmplan.report.steppictures.draw_step_plots>`) and never imports the renderer: the
pictures of steps that finish together are drawn by two processes at once, and no library is
imported twice. :func:`asmplan.report.html.write_report` then only writes the page.

Every picture is a function of the product, the plan and (for a step's pictures) the step's
result alone, so the bytes are those one process would draw
(``tests/report/test_picture_pool.py``). A picture whose task fails is left out; the report
draws it again in the run's process and raises there, as without the pool. The picture
process dies with the run's process (Linux ``PR_SET_PDEATHSIG``) and is reaped before the
output folder is swapped in, so its CPU time counts in the run's "report" stage.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from ..knowledge.model import Product
from ..planner.plan import NOT_ROBOT_KINDS, Plan

if TYPE_CHECKING:  # the renderer's modules (trimesh, ~0.4 s) are imported by the picture process
    from .planviews import PlanViews
    from .views import Views

MAX_PICTURE_WORKERS = 1
"""Picture processes: one. A second would import the renderer and build the display meshes
again (0.69 s of CPU in the first, measured on the seed workstation at ``balanced``), more than
it would take off the end of the seed job (the last steps' sections and animations, 0.2-0.3 s
of CPU each, which the run's process cannot draw)."""

_PRODUCT: Product | None = None
"""The product a picture process draws (set by :func:`_start_worker`, in the worker)."""
_VIEWS: Any = None
"""The picture process's :class:`~asmplan.report.views.Views` (meshes built once)."""


def _start_worker(parent_pid: int, product: Product) -> None:
    """Picture process initializer: die with the run's process, then import what every
    picture needs and build the parts' display meshes (while the run plans)."""
    global _PRODUCT, _VIEWS
    from ..parts.models import ProductGeometry
    from ..sim.simulate import _die_with_parent
    from .render import _import_pyrender
    from .views import Views

    _die_with_parent(parent_pid)
    _PRODUCT = product
    _VIEWS = Views(product, ProductGeometry(product))
    _import_pyrender()
    for part in product.part_names:
        _VIEWS.mesh(part)


def _product_views(folder: Path) -> tuple[str, str]:
    return _VIEWS.render_product(folder)


def _path_view(plan: Plan, index: int, folder: Path) -> str:
    from .planviews import path_view_name

    name = path_view_name(index)
    _VIEWS.path_view(plan, plan.steps[index], folder / name)
    return name


def _storyboard(plan: Plan, folder: Path) -> list[tuple[int, str, str]]:
    return _VIEWS.storyboard(plan, folder)


def _step_views(plan: Plan, index: int, res: Any, folder: Path) -> tuple[dict[str, str], ...]:
    from .steppictures import render_step_views

    assert _PRODUCT is not None
    return render_step_views(_PRODUCT, plan, _VIEWS, plan.steps[index], res, folder)


class DeferredViews:
    """A :class:`~asmplan.report.views.Views` made on first use: the run's process imports
    the renderer only when it must render a picture itself (one whose task failed)."""

    def __init__(self, product: Product, geometry: Any) -> None:
        self._args = (product, geometry)
        self._views: Any = None

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        if self._views is None:
            from .views import Views

            self._views = Views(*self._args)
        return getattr(self._views, name)


def picture_workers(jobs: int | None) -> int:
    """Picture processes for a run with ``-j jobs`` (None: automatic): none with ``-j 1``,
    where processes cannot be forked or with one usable core, else
    :data:`MAX_PICTURE_WORKERS`."""
    from ..sim.simulate import default_workers

    if jobs is not None and int(jobs) <= 1:
        return 0
    return MAX_PICTURE_WORKERS if default_workers() >= 2 else 0


@dataclass
class PicturePool:
    """A picture process rendering a run's report pictures into ``folder`` (its staging
    folder) while this process draws the plots, see the module docstring. Forked when made;
    :meth:`views` collects the pictures, :meth:`close` stops it."""

    product: Product
    folder: Path
    workers: int = MAX_PICTURE_WORKERS
    plan: Plan | None = None
    graph: str = ""
    reach: str = ""
    _pool: ProcessPoolExecutor | None = None
    _product_views: Future[tuple[str, str]] | None = None
    _paths: dict[int, Future[str]] = field(default_factory=dict)
    _story: Future[list[tuple[int, str, str]]] | None = None
    _steps: dict[int, tuple[Any, Future[Any], tuple[tuple[str, str], ...] | None]] = field(
        default_factory=dict)

    def __post_init__(self) -> None:
        if self.workers < 1:
            raise ValueError(f"workers: expected >= 1, found {self.workers}")
        self.folder = Path(self.folder)
        self._pool = ProcessPoolExecutor(max_workers=self.workers,
                                         mp_context=multiprocessing.get_context("fork"),
                                         initializer=_start_worker,
                                         initargs=(os.getpid(), self.product))
        # the first task forks the process: it renders the product while the run plans
        self._product_views = self._pool.submit(_product_views, self.folder)

    def plan_ready(self, sequence: Any | None, plan: Plan) -> None:
        """The plan exists: the picture process renders the planned paths and the
        storyboard; this process draws the precedence graph and the arm's reach (as
        :func:`~asmplan.report.planviews.render_plan_views` does in one process)."""
        from . import plots
        from .planviews import has_arm_block

        assert self._pool is not None, "picture pool closed"
        self.plan = plan
        for step in plan.steps:
            if step.kind not in NOT_ROBOT_KINDS:
                self._paths[step.index] = self._pool.submit(_path_view, plan, step.index,
                                                            self.folder)
        self._story = self._pool.submit(_storyboard, plan, self.folder)
        if sequence is not None:
            plots.precedence_graph_plot(sequence.precedence, self.folder / "precedence.png",
                                        order=list(plan.sequence))
            self.graph = "precedence.png"
        if has_arm_block(self.product, plan):
            from ..planner.arm import reach_facts

            robot = self.product.resources.robot
            assert robot is not None  # has_arm_block checked it
            shoulder, reach = reach_facts(robot)
            plots.reach_plot(self.product, plan, shoulder, reach, self.folder / "cell-reach.png")
            self.reach = "cell-reach.png"

    def step_done(self, step_result: Any) -> None:
        """A step's result came back: the picture process renders its section and
        animation, this process draws its plots. A plot that fails is left to the report."""
        from .steppictures import draw_step_plots, grip_limit

        assert self._pool is not None and self.plan is not None, "no plan or pool closed"
        step = self.plan.steps[step_result.index]
        future = self._pool.submit(_step_views, self.plan, step.index, step_result, self.folder)
        try:
            drawn = draw_step_plots(step, step_result, self.folder, grip_limit(self.product, step))
        except Exception:  # deferred: write_report draws it again and raises there
            drawn = None
        self._steps[step.index] = (step_result, future, drawn)

    def views(self, geometry: Any, results: Any | None = None) -> PlanViews | None:
        """Wait for the picture process and stop it; every picture drawn as a
        :class:`~asmplan.report.planviews.PlanViews` (None without a plan, or when the
        product views or the storyboard failed: the report then draws everything). A step
        whose pictures failed is left out (the report draws them). The steps of ``results``
        (:class:`~asmplan.sim.results.PlanResults`) not handed over yet (simulated in this
        process) are drawn now."""
        from .planviews import PlanViews
        from .steppictures import StepPictures

        try:
            plan = self.plan
            if plan is None:
                return None
            for res in results.steps if results is not None else ():
                if res.index not in self._steps:
                    self.step_done(res)
            assembled, exploded = _value(self._product_views) or ("", "")
            story = _value(self._story)
            if not assembled or story is None:
                return None
            out = PlanViews(self.folder, plan, cast("Views", DeferredViews(self.product, geometry)),
                            images={"assembled": assembled, "exploded": exploded},
                            story=story, graph=self.graph, reach=self.reach)
            for k, f in self._paths.items():
                name = _value(f)
                if name:
                    out.paths[k] = name
            for k, (res, f, drawn) in self._steps.items():
                entries = _value(f)
                if entries is not None and drawn is not None:
                    out.steps[k] = StepPictures(res, entries, drawn)
            return out
        finally:
            self.close()

    def close(self, *, now: bool = False) -> None:
        """Stop the picture process (``now``: without waiting for a running picture)."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        if now:
            for proc in list((getattr(pool, "_processes", None) or {}).values()):
                proc.terminate()
        pool.shutdown(wait=True, cancel_futures=True)


def _value(future: Future[Any] | None) -> Any:
    """A finished task's value, None when it failed or was not submitted."""
    if future is None:
        return None
    try:
        return future.result()
    except Exception:  # the report draws it again in the run's process and raises there
        return None
