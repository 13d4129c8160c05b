"""The main job as a library call: product in; sequence, plan, simulation and report out.

>>> from asmplan.pipeline import RunSettings, run_product          # doctest: +SKIP
>>> result = run_product("examples/pinhole_station.yaml", RunSettings(fidelity="fast"))
>>> result.success, [s.part for s in result.plan.steps]

Stages share one :class:`~asmplan.parts.models.ProductGeometry`, so every part's geometry and
collision models are built once. A planning failure or a failed physical check is part of the
result (``failure``, ``results.failed_steps``), not an exception; only bad input raises
(:class:`~asmplan.knowledge.errors.ProductError`).
"""

from __future__ import annotations

import math
import resource
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .fileio import OutputFolder, atomic_write_json
from .knowledge.loader import load_product
from .knowledge.model import Product
from .parts.models import ProductGeometry
from .planner.errors import PlanningError
from .planner.fcl_oracle import FclOracle
from .planner.plan import Plan
from .planner.product import plan_product, ranked_sequences
from .planner.sequence import SequencePlan, SequenceSettings, plan_sequence
from .planner.settings import PlannerSettings
from .sim.fidelity import Fidelity, preset
from .sim.pose_error import PoseError
from .sim.results import PlanResults, StepResult
from .sim.simulate import PipelinedSimulation, resolve_workers, simulate_plan

Progress = Callable[[str, int, int, str], None]
"""``progress(stage, done, total, label)``: stage is "sequence", "plan", "simulate" or "report"."""


@dataclass(frozen=True)
class RunSettings:
    """Settings of one run; every costly knob is in ``fidelity`` and ``planner``."""

    fidelity: Fidelity | str = "balanced"
    planner: PlannerSettings = field(default_factory=PlannerSettings)
    sequence: SequenceSettings = field(default_factory=SequenceSettings)
    cull: bool = True
    simulate: bool = True
    workers: int | None = None
    """Processes that simulate steps (None: see ``simulate_plan``; 1 inside your own pool).
    With more than one, each step is simulated while the next ones are planned, and
    ``timings_s["simulate"]`` is the time simulation took after planning ended."""
    pose_error: PoseError | None = None
    """A robot pose error applied at every insertion (``--pose-error``), or None."""

    @property
    def fidelity_preset(self) -> Fidelity:
        return preset(self.fidelity) if isinstance(self.fidelity, str) else self.fidelity


@dataclass
class RunResult:
    """What a run produced. ``error`` is the typed planning failure when no plan exists (its
    words: ``failure``; its evidence: ``failure_evidence``)."""

    product: Product
    geometry: ProductGeometry
    fidelity: Fidelity
    sequence: SequencePlan | None = None
    plan: Plan | None = None
    results: PlanResults | None = None
    error: PlanningError | None = None
    dropped_orders: list[dict[str, Any]] = field(default_factory=list)
    """Better-ranked part orders that could not be planned, each with ``order`` and ``failure``."""
    warnings: list[str] = field(default_factory=list)
    timings_s: dict[str, float] = field(default_factory=dict)
    cpu_s: dict[str, float] = field(default_factory=dict)
    """CPU time (user + system) per stage, s: this process's and that of its finished child
    processes (the simulation workers, counted when they end, i.e. in "simulate"). What
    ``while_simulating`` spent (the report's plan-only pictures) is counted in "report", not
    in "simulate"; ``timings_s["report"]`` is the report's wall time after the simulation."""
    while_simulating_cpu_s: float = 0.0
    """CPU seconds this process spent in ``run_product``'s ``while_simulating``."""
    report_views: Any = None
    """The report's plan-only pictures rendered while simulating
    (:class:`asmplan.report.planviews.PlanViews`, see :func:`render_while_simulating`)."""

    @property
    def failure(self) -> str:
        """Why no plan exists, in words ("" when a plan exists)."""
        return "" if self.error is None else str(self.error)

    @property
    def failure_evidence(self) -> dict[str, Any]:
        """The planning failure's evidence as JSON-safe data ({} when a plan exists)."""
        return {} if self.error is None else finite_json(self.error.evidence())

    @property
    def success(self) -> bool:
        """Every step planned and (when simulated) succeeded physically."""
        if self.failure or self.plan is None:
            return False
        return self.results is None or self.results.success

    @property
    def exit_code(self) -> int:
        return 0 if self.success else 1


def cpu_now_s() -> float:
    """CPU seconds (user + system) used so far by this process and its reaped children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def finite_json(value: Any) -> Any:
    """``value`` with every non-finite float (nan, inf) replaced by None: JSON has neither,
    and asmplan writes strict JSON."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_json(v) for v in value]
    return value


def run_product(product: Product | str | Path, settings: RunSettings | None = None, *,
                progress: Progress | None = None,
                while_simulating: Callable[[RunResult], None] | None = None,
                on_step_result: Callable[[RunResult, StepResult], None] | None = None,
                ) -> RunResult:
    """Sequence, plan and simulate ``product`` (a validated Product or a YAML path).

    ``while_simulating(result)`` is called once the plan exists (``result.plan``), after every
    step has been handed to the simulation workers and before their results are awaited: work
    that needs only the plan (:func:`render_while_simulating`: the report's plan-only
    pictures) then runs while the workers simulate. With one worker the steps simulate in
    this process after it returns. ``on_step_result(result, step_result)`` is called in this
    process as each step's result comes back from a worker, in the order they finish (with
    several workers only: :meth:`EarlyReport.step_done` draws that step's report pictures
    while the others simulate). The CPU time of both is kept out of ``cpu_s["simulate"]``
    (``while_simulating_cpu_s``)."""
    settings = settings or RunSettings()
    if not isinstance(product, Product):
        product = load_product(product)
    fidelity = settings.fidelity_preset
    t0 = time.perf_counter()
    c0 = cpu_now_s()
    geometry = ProductGeometry(product)
    result = RunResult(product, geometry, fidelity)

    def tick(stage: str, done: int, total: int, label: str) -> None:
        if progress is not None:
            progress(stage, done, total, label)

    tick("sequence", 0, 1, "")
    try:
        result.sequence = plan_sequence(product, FclOracle(product, geometry), settings.sequence)
    except PlanningError as exc:
        result.error = exc
    t1 = time.perf_counter()
    result.timings_s["sequence"] = t1 - t0
    c1 = cpu_now_s()
    result.cpu_s["sequence"] = c1 - c0
    tick("sequence", 1, 1, "")
    n_moving = sum(not product.is_fixtured(p) for p in product.part_names)
    workers = resolve_workers(settings.workers, n_moving) if settings.simulate else 1
    # with several worker processes, each step is simulated as soon as it is planned
    pipe = (PipelinedSimulation(product, geometry, fidelity, workers=workers, cull=settings.cull,
                                pose_error=settings.pose_error)
            if workers > 1 and result.sequence is not None else None)

    def sim_progress(i: int, n: int, part: str, status: str) -> None:
        if status == "done":
            tick("simulate", i + 1, n, part)

    try:
        if result.sequence is not None:
            def on_step(i: int, n: int, part: str, status: str) -> None:
                if status == "done":
                    tick("plan", i + 1, n, part)

            try:
                planned = plan_product(product, geometry, settings.planner,
                                       sequences=ranked_sequences(result.sequence),
                                       progress=on_step,
                                       on_step=None if pipe is None else pipe.on_step)
                result.plan = planned.plan
                result.dropped_orders = list(planned.dropped)
                result.warnings.extend(n for s in planned.plan.steps for n in s.notes)
            except PlanningError as exc:
                result.error = exc
        t2 = time.perf_counter()
        result.timings_s["plan"] = t2 - t1
        c2 = cpu_now_s()
        result.cpu_s["plan"] = c2 - c1
        if result.plan is not None and settings.simulate:
            if pipe is not None:
                pipe.start_all()
            if while_simulating is not None:
                c_ws = time.process_time()
                while_simulating(result)
                result.while_simulating_cpu_s = time.process_time() - c_ws
            if pipe is not None:
                def step_back(step_result: StepResult) -> None:
                    if on_step_result is not None:
                        c_sr = time.process_time()
                        on_step_result(result, step_result)
                        result.while_simulating_cpu_s += time.process_time() - c_sr

                result.results = pipe.results(result.plan, progress=sim_progress,
                                              on_result=step_back)
            else:
                result.results = simulate_plan(result.plan, product, geometry, fidelity,
                                               cull=settings.cull, workers=1,
                                               progress=sim_progress,
                                               pose_error=settings.pose_error)
            # the fits the preset does not resolve (computed once, by the simulation)
            result.warnings.extend(result.results.warnings)
            # each step's own warnings stay with the step (results.json, the report's step
            # section); the run-level list holds the plan's notes and the unresolved fits
    except BaseException:  # Ctrl-C or a crash: no step goes on simulating after we return
        if pipe is not None:
            pipe.close(now=True)
            pipe = None
        raise
    finally:
        if pipe is not None:
            pipe.close()
    result.timings_s["simulate"] = time.perf_counter() - t2
    if "plan" in result.cpu_s:
        result.cpu_s["simulate"] = cpu_now_s() - c2 - result.while_simulating_cpu_s
    result.warnings = list(dict.fromkeys(result.warnings))  # once each, in order
    return result


class EarlyReport:
    """The report's pictures drawn while the steps simulate, into an :class:`OutputFolder`'s
    staging folder: called as ``while_simulating`` it renders the plan-only pictures
    (:mod:`asmplan.report.planviews`); :meth:`step_done`, given to :func:`run_product` as
    ``on_step_result``, draws each step's result pictures as its result comes back while other
    steps still simulate (:mod:`asmplan.report.steppictures`). :func:`write_outputs` into the
    same folder then draws only what is left (the pictures are the same either way).

    With ``workers`` >= 1 and the ``product``, the pictures are drawn by that many picture
    processes forked now, before the run plans (:mod:`asmplan.report.picture_pool`), and this
    process only hands them the plan and the results; :meth:`close` stops them (a run that
    ends without :func:`write_outputs`)."""

    def __init__(self, folder: OutputFolder, product: Product | None = None,
                 workers: int = 0) -> None:
        self.folder = folder
        self.pool = None
        if product is not None and workers >= 1:
            from .report.picture_pool import PicturePool

            self.pool = PicturePool(product, folder.stage, workers)

    def __call__(self, result: RunResult) -> None:
        from .report.planviews import render_plan_views

        assert result.plan is not None  # called once the plan exists
        if self.pool is not None:
            from .report.html import report_template

            self.pool.plan_ready(result.sequence, result.plan)
            result.report_views = self
            report_template()  # compiled now, not after the simulation
            return
        result.report_views = render_plan_views(result.product, result.geometry,
                                                result.sequence, result.plan, self.folder.stage)

    def step_done(self, result: RunResult, step_result: StepResult) -> None:
        """Draw the pictures of a step whose result came back (plan views rendered first).

        A picture that fails here is left to :func:`write_outputs`, which draws it again and
        reports its error there, after every step's result is kept (as without this)."""
        if self.pool is not None:
            if self.pool.plan is not None:
                self.pool.step_done(step_result)
            return
        if result.report_views is None:
            return
        try:
            result.report_views.step_done(result.product, step_result)
        except Exception:  # deferred: write_report draws it again and raises there
            result.report_views.steps.pop(step_result.index, None)

    def views(self, result: RunResult) -> Any:
        """The pictures drawn (a :class:`~asmplan.report.planviews.PlanViews` or None); with
        picture processes, waits for them and stops them."""
        if self.pool is None:
            return result.report_views
        return self.pool.views(result.geometry, result.results)

    def close(self, *, now: bool = False) -> None:
        """Stop the picture processes, if any (``now``: without waiting for them)."""
        if self.pool is not None:
            self.pool.close(now=now)


def render_while_simulating(folder: OutputFolder, product: Product | None = None,
                            workers: int = 0) -> EarlyReport:
    """A ``while_simulating`` for :func:`run_product` that renders the report's plan-only
    pictures into ``folder``'s staging folder (:mod:`asmplan.report.planviews`); its
    ``step_done``, passed as ``on_step_result``, draws each step's result pictures as the
    step finishes. :func:`write_outputs` into the same ``folder`` then renders only the rest.
    With ``product`` and ``workers`` >= 1 (:func:`asmplan.report.picture_pool.picture_workers`)
    the pictures are drawn by picture processes forked now, while the run plans; call it
    before :func:`run_product` and :meth:`EarlyReport.close` if the run raises.

    >>> with OutputFolder("out") as folder:                            # doctest: +SKIP
    ...     early = render_while_simulating(folder)
    ...     result = run_product(product, settings, while_simulating=early,
    ...                          on_step_result=early.step_done)
    ...     write_outputs(result, folder)
    """
    return EarlyReport(folder, product, workers)


def write_outputs(result: RunResult, outdir: str | Path | OutputFolder, *, report: bool = True,
                  progress: Progress | None = None) -> Path:
    """Write plan.json, results.json, sequence.json and the report into ``outdir``.

    ``outdir`` is a path, or an :class:`~asmplan.fileio.OutputFolder` reserved before the work
    (as ``asmplan run`` does, so that a folder asmplan may not replace is refused before
    anything is computed). The folder is built beside ``outdir`` and swapped in at the end: a
    crash or Ctrl-C leaves the previous ``outdir`` untouched. Only a new, empty or
    asmplan-written folder is ever replaced (:class:`~asmplan.fileio.OutputPathError`
    otherwise).
    """
    t0 = time.perf_counter()
    c0 = cpu_now_s()
    folder = outdir if isinstance(outdir, OutputFolder) else OutputFolder(outdir)
    try:
        stage = folder.stage
        if result.sequence is not None:
            atomic_write_json(stage / "sequence.json", result.sequence.as_dict() | {"timings_s": {}})
        if result.plan is not None:
            result.plan.write(stage / "plan.json")
        if result.results is not None:
            result.results.write(stage / "results.json")
        summary = {"product": result.product.name, "success": result.success,
                   "failure": result.failure, "failure_evidence": result.failure_evidence,
                   "warnings": result.warnings, "fidelity": result.fidelity.name,
                   "cycle_time_s": None if result.plan is None else result.plan.cycle_time_s,
                   "step_cycle_times_s": None if result.plan is None else
                   {s.part: s.cycle_time_s for s in result.plan.steps}}
        atomic_write_json(stage / "summary.json", summary)
        if report:
            from .report.html import ReportInputs, write_report

            if progress is not None:
                progress("report", 0, 1, "")
            prepared = result.report_views
            if isinstance(prepared, EarlyReport):  # drawn by picture processes: wait for them
                prepared = result.report_views = prepared.views(result)
            write_report(ReportInputs(result.product, result.geometry, result.sequence, result.plan,
                                      result.results, result.fidelity, result.failure,
                                      list(result.warnings), result.dropped_orders), stage,
                         prepared=prepared)
            if progress is not None:
                progress("report", 1, 1, "")
        target = folder.commit()
    finally:
        if folder is not outdir:
            folder.close()
    result.timings_s["report"] = time.perf_counter() - t0
    # the plan-only pictures rendered while simulating count here (see RunResult.cpu_s)
    result.cpu_s["report"] = result.while_simulating_cpu_s + cpu_now_s() - c0
    return target if not isinstance(outdir, str | Path) else Path(outdir)
