"""Simulate a whole :class:`~asmplan.planner.plan.Plan` in PyBullet, step by step.

:func:`simulate_plan` runs every step that moves a part in its own
:class:`~asmplan.sim.bullet.BulletWorld` holding only the bodies the step needs
(:mod:`asmplan.sim.scene`), drives a force-controlled parallel gripper along the step's
trajectory (:func:`asmplan.sim.execute.execute_step`) and judges it against the product's
process limits. The result is a :class:`PlanResults` of frozen :class:`StepResult` objects,
written as ``results.json`` (format in ``docs/results-format.md``).

Success criteria per step (:class:`~asmplan.sim.records.SuccessCriteria`): the product's
``process.position_tolerance_m`` (final position of the part against its assembled pose),
``process.max_slip_m`` (slip in the fingers while held), ``process.max_insertion_force_N``
(contact force on the part from anything but the fingers while lowering), the remaining
insertion depth along the step's ``insertion_direction`` and the defaults of
``SuccessCriteria`` for the rest (tilt, rotational slip, drop, penetration, NaN, energy).
Each failed criterion is named in :attr:`StepResult.criteria` and in the outcome's reasons.

Determinism: the same plan, product and preset give bit-identical results; wall-clock times
are kept out of :meth:`PlanResults.to_json` (see :meth:`PlanResults.timing`).

Worlds: one fresh world per step. Building a step's world costs 30-150 ms against seconds of
simulation (measured on pinhole_station, see docs/results-format.md), so sharing one world
through save/restore could save at most a few per cent, while it would put the bodies of
every step into every step's collision detection. Because the steps are independent worlds,
``simulate_plan(workers=N)`` runs them in N forked processes with identical results.

Gripper fingers: :class:`~asmplan.sim.gripper.CoupledGripper` (in :mod:`asmplan.sim.gripper`)
holds the two force-controlled fingers at equal travel like the rack and pinion of a real
parallel gripper (a gear constraint): with free fingers the pair and the part float along the
closing axis, and a 0.3 kg part carried 200 mm along that axis drifted 10 mm off the TCP
(to the finger's joint limit) and missed its holes.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..knowledge.model import Product
from ..planner.plan import AssemblyState, Plan, Step, assembly_state, state_before
from .bullet import BulletWorld
from .carry_hold import CarryHold, grip_capacity
from .execute import execute_step
from .fidelity import BALANCED, Fidelity
from .fit_ldp import preload_solver
from .fit_pairs import held_fit_contact
from .gripper import CoupledGripper, GripperSpec
from .judge import failed_outcome
from .partner_hold import PartnerHold
from .pose_error import PoseError, apply_pose_error
from .press import press_clearance_m, press_recorder, press_relaxed
from .records import SuccessCriteria
from .resolution import held_clamp_force_N, unresolved_causes
from .results import (
    PlanResults,
    StepResult,
    criteria_for,
    criteria_table,
)
from .scene import (
    SceneSettings,
    build_scene,
    check_plan_product,
    gripper_spec,
    step_scene,
)
from .step_warnings import clearance_warnings, step_warnings
from .verdicts import SceneGuard

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry
    from ..planner.trajectory import Trajectory


# ---------------------------------------------------------------------------------------------
# Simulation
# ---------------------------------------------------------------------------------------------
ProgressFn = Callable[[int, int, str, str], None]


def step_gripper(world: BulletWorld, spec: GripperSpec, trajectory: Trajectory,
                 opening_m: float) -> CoupledGripper:
    """The gripper every simulated step runs with: ``spec`` (for a product, its gripper
    resource through :func:`~asmplan.sim.scene.gripper_spec`) with synchronised jaws, at the
    trajectory's first pose, opening to ``opening_m`` (m) in the open phases. The bench's
    held-drift scene builds its gripper here too, so it measures this model."""
    return CoupledGripper(world, spec, trajectory.T_world_gripper[0], opening_m=float(opening_m))


def simulate_step(plan: Plan, index: int, product: Product, geometry: ProductGeometry,
                  fidelity: Fidelity = BALANCED, *, cull: bool = True,
                  settings: SceneSettings | None = None,
                  criteria: SuccessCriteria | None = None,
                  pose_error: PoseError | None = None) -> StepResult:
    """Simulate step ``index`` of ``plan`` in a fresh world (see the module docstring).
    ``pose_error``: the robot's error at the insertion (:mod:`asmplan.sim.pose_error`)."""
    check_plan_product(plan, product)
    return simulate_placed_step(plan.steps[index], assembly_state(plan, index), product, geometry,
                                fidelity, cull=cull, settings=settings, criteria=criteria,
                                pose_error=pose_error)


def simulate_placed_step(step: Step, state: AssemblyState, product: Product, geometry: ProductGeometry,
                         fidelity: Fidelity = BALANCED, *, cull: bool = True,
                         settings: SceneSettings | None = None,
                         criteria: SuccessCriteria | None = None,
                         pose_error: PoseError | None = None) -> StepResult:
    """:func:`simulate_step` for one ``step`` given where every part is (``state``:
    poses and the parts in place, :func:`asmplan.planner.plan.assembly_state`)."""
    index = step.index
    if step.kind == "operation":  # the part stands at its assembled pose from now on
        return StepResult(index, step.part, step.kind, None, None, None,
                          (f"placed by {step.operation}: not simulated",))
    if step.kind == "fixture" or step.trajectory is None or step.grasp is None:
        return StepResult(index, step.part, step.kind, None, None, None,
                          ("in place from the start (held by a fixture): not simulated",))
    crit = criteria or criteria_for(product)
    t0 = time.perf_counter()
    # press and transition fits: at the preset's resolvable clearance (asmplan.sim.press)
    product, geometry = press_relaxed(product, geometry, press_clearance_m(
        fidelity, (settings or SceneSettings()).touch_tolerance_m))
    scene = step_scene(step, state, product, geometry, fidelity, settings, cull=cull)
    warns = step_warnings(scene, product, step, geometry, fidelity)
    traj = step.trajectory
    applied: dict[str, list[float]] | None = None
    if pose_error is not None and pose_error != PoseError() and step.insertion_direction is not None:
        traj = apply_pose_error(traj, [float(v) for v in step.insertion_direction], pose_error)
        applied = pose_error.to_dict()
    f_max = float(np.max(traj.clamp_force_N))
    g_res = product.gripper_for(step.part)
    if f_max > g_res.max_force_N:
        warns += (f"the trajectory commands {f_max:.2f} N per finger, more than the gripper's "
                  f"max_force {g_res.max_force_N:.2f} N; executed as planned",)
    t1 = time.perf_counter()
    with BulletWorld(handover_fidelity(fidelity, step)) as world:
        ids = build_scene(world, scene)
        gripper = step_gripper(world, gripper_spec(g_res, f_max), traj,
                               float(step.grasp.open_width_m))
        t2 = time.perf_counter()
        press = press_recorder(world, ids[step.part], step, gripper.body,
                               product.process.insertion_speed_m_s,
                               every=fidelity.record_every_steps)
        table_size = product.resources.table.size_m
        guard = SceneGuard(cell_half_size_m=max(1.0, float(np.max(table_size))))
        # a regrasp sets the part down on a station, not into its mates: no fit to model
        # (gearbox shaft: with its mates' contact switched to the model, 'unstable' at the
        # first step, 2.2 m/s; without, the step succeeds)
        fit = (held_fit_contact(world, ids, step.part, product, geometry)
               if fidelity.feature_contact and step.kind != "regrasp" else None)
        hold = (PartnerHold(world, gripper.body, ids[step.part], fit,
                            fidelity.partner_hold_fraction)
                if fidelity.partner_hold_fraction > 0.0 else None)
        carry = None
        # grooved pads only: on flat pads Bullet's contact carries the part (sim/carry_hold.py)
        if fidelity.carry_hold_fraction > 0.0 and gripper.spec.pad_groove_depth_m > 0.0:
            cap, why = grip_capacity(product, geometry, step.part, step.grasp)
            carry = CarryHold(world, gripper, ids[step.part], traj, cap,
                              fidelity.carry_hold_fraction, fit, why)
        record, outcome = execute_step(world, gripper, ids[step.part], traj, crit,
                                       T_world_part_target=step.T_world_final,
                                       mate_axis_world=step.insertion_direction,
                                       warnings=warns,
                                       before_step=None if press is None else press.before_step,
                                       insertion_length_m=step.insertion_length_m or None,
                                       guard=guard, carry_anchor=fidelity.carry_anchor,
                                       fit_contact=fit, partner_hold=hold,
                                       carry_hold=carry)
    t3 = time.perf_counter()
    table = criteria_table(outcome, crit, step.insertion_direction is not None)
    failed = [k for k, v in table.items() if not v["ok"]]
    # a failure the preset does not resolve is reported as such (asmplan.sim.resolution)
    unresolved = unresolved_causes(outcome, failed, step, product, scene.parts, fidelity, record,
                                   held_clamp_force_N(traj))
    return StepResult(index, step.part, step.kind, outcome, record, scene.summary(), warns,
                      table, wall_time_s=t3 - t0,
                      timing_s={"select": t1 - t0, "build": t2 - t1, "simulate": t3 - t2},
                      press=None if press is None else press.summary(),
                      pose_error=applied, unresolved=unresolved,
                      partners=None if hold is None else hold.summary(),
                      carry=None if carry is None else carry.summary())


def handover_fidelity(fidelity: Fidelity, step: Step) -> Fidelity:
    """The fidelity the step's world runs with: ``fidelity``, with friction anchors on the
    fingers (:attr:`Fidelity.friction_anchor`) when the step hands its part to the cell's
    press.

    Such a grip is planned at half the gripper's push capacity whatever the part weighs
    (:attr:`asmplan.planner.press.PressOperation.gripper_resistance_N`), and without anchors a
    light part squeezed that hard creeps in the pads: the hinge's 5.5 g bronze bushings at
    30 N per finger (555 times their weight) turned 2 deg in the fingers over a 3.5 s carry
    (bushing_b, then stopped on the lug's rim) or were thrown off the pads on the lift
    (bushing_a, 1.2 m/s), at BALANCED; at ACCURATE bushing_a slid 1.95 mm. The grip holds
    2 mu F = 33 N against m (g + a) = 0.065 N and, over the 6.7 mm pad contact, mu F W / 4 =
    28 N mm per pad against at most 0.9 N mm of moment (weight and acceleration at the 13 mm
    lever), so the creep is the solver's, not the part's. With anchors both are carried within 0.02 deg and
    pressed home. The anchors' known cost (the pads' friction adds seating force when the
    robot pushes a part into its fit; peg_in_hole at BALANCED) does not arise: the robot only
    sets the part on the mouth and the press seats it."""
    press = step.press
    if fidelity.friction_anchor or press is None or press.by != "press":
        return fidelity
    return replace(fidelity, friction_anchor=True)


@dataclass(frozen=True, eq=False)
class _Job:
    """What the forked simulator workers inherit: the product, its geometry and the settings
    every step is simulated with, and the plan when the workers take steps by index."""

    product: Product
    geometry: ProductGeometry
    fidelity: Fidelity
    cull: bool
    settings: SceneSettings
    criteria: SuccessCriteria | None
    plan: Plan | None = None
    pose_error: PoseError | None = None

    def step(self, index: int) -> StepResult:
        assert self.plan is not None, "a job without a plan simulates given steps only"
        return simulate_step(self.plan, index, self.product, self.geometry, self.fidelity,
                             cull=self.cull, settings=self.settings, criteria=self.criteria,
                             pose_error=self.pose_error)

    def placed_step(self, step: Step, state: AssemblyState) -> StepResult:
        return simulate_placed_step(step, state, self.product, self.geometry, self.fidelity,
                                    cull=self.cull, settings=self.settings,
                                    criteria=self.criteria, pose_error=self.pose_error)


_JOB: _Job | None = None
"""The job of the forked worker processes (set before they are forked; they inherit it)."""


def _simulate_forked(index: int) -> StepResult:
    assert _JOB is not None, "simulate worker started without a job"
    return _JOB.step(index)


def _simulate_planned(step: Step, state: AssemblyState) -> StepResult:
    assert _JOB is not None, "simulate worker started without a job"
    return _JOB.placed_step(step, state)


def default_workers() -> int:
    """Processes :func:`simulate_plan` uses when asked for "auto": the cores this process
    may run on (``os.sched_getaffinity``), 1 where worker processes cannot be forked."""
    if "fork" not in multiprocessing.get_all_start_methods():
        return 1
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def resolve_workers(workers: int | None, n_steps: int) -> int:
    """Processes to simulate ``n_steps`` moving steps in (see :func:`simulate_plan`); 1 when
    worker processes cannot be forked here."""
    if workers is not None and int(workers) < 1:
        raise ValueError(f"workers: expected >= 1 or None, found {workers}")
    if "fork" not in multiprocessing.get_all_start_methods():
        return 1
    if workers is None:
        # up to twice as many steps as cores all run at once: 3 equal steps on 2 cores end
        # after 1.5 step times shared, against 2 in two rounds of 2
        cores = default_workers()
        return max(1, n_steps if n_steps <= 2 * cores else cores)
    return max(1, min(int(workers), n_steps))


def _die_with_parent(parent_pid: int) -> None:
    """Worker initializer: the kernel kills this worker when the process that forked it dies
    (Linux ``PR_SET_PDEATHSIG``), so a run killed or interrupted midway leaves no orphan
    simulator behind; a worker whose parent is already gone exits at once."""
    import contextlib
    import ctypes
    import signal

    with contextlib.suppress(OSError, AttributeError):  # not Linux: no parent-death signal
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
    if os.getppid() != parent_pid:
        os._exit(1)


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Stop ``pool`` now: pending steps cancelled, running workers terminated (on Ctrl-C, so
    that no step runs on after the command has ended)."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        with contextlib.suppress(Exception):
            process.terminate()
    pool.shutdown(wait=True, cancel_futures=True)


def _worker_pool(workers: int, job: _Job) -> ProcessPoolExecutor:
    """A pool of ``workers`` forked simulator processes that die with this process. With the
    exact fit contact on, its solver's import happens here, once, and the workers inherit it
    (each imported scipy.optimize again: 0.3-0.5 s of CPU per worker, 3 workers on the
    seed workstation)."""
    if job.fidelity.feature_contact:
        preload_solver()
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"),
                               initializer=_die_with_parent, initargs=(os.getpid(),))


def _crashed(plan: Plan, k: int, exc: BaseException) -> StepResult:
    step = plan.steps[k]
    reason = (f"the simulator process died while simulating this step ({type(exc).__name__}: "
              f"{exc}); PyBullet crashed on this scene - retry at another fidelity")
    return StepResult(k, step.part, step.kind, failed_outcome((reason,)), None, None, (reason,),
                      {"simulator": {"value": False, "limit": True, "ok": False}})


def _retry_alone(job: _Job, todo: Sequence[int], done: dict[int, StepResult],
                 progress: ProgressFn | None) -> None:
    """After a worker died (the pool is broken): every step of ``todo`` not in ``done`` once
    more, each in a fresh process of its own; one that dies again fails with the reason."""
    global _JOB
    assert job.plan is not None
    _JOB = job
    try:
        for n, k in enumerate(todo):
            if k in done:
                continue
            try:
                with _worker_pool(1, job) as pool:
                    done[k] = pool.submit(_simulate_forked, k).result()
            except BrokenProcessPool as exc:
                done[k] = _crashed(job.plan, k, exc)
            if progress is not None:
                progress(n, len(todo), job.plan.steps[k].part, "done")
    finally:
        _JOB = None


def _simulate_parallel(job: _Job, todo: list[int], workers: int,
                       progress: ProgressFn | None) -> list[StepResult]:
    """Steps in forked worker processes (each step builds its own world, so they are
    independent and the results are the same as in one process). Longest trajectories are
    started first; results come back in step order. A worker that dies fails its step (with
    the reason) after one retry in a fresh process; the other steps are unaffected."""
    global _JOB
    plan = job.plan
    assert plan is not None
    moving = [k for k in todo if plan.steps[k].trajectory is not None]
    order = sorted(moving, key=lambda k: -_duration_s(plan.steps[k]))
    done: dict[int, StepResult] = {}
    _JOB = job
    try:
        with _worker_pool(workers, job) as pool:
            try:
                futures = {k: pool.submit(_simulate_forked, k) for k in order}
                for n, k in enumerate(todo):
                    try:
                        done[k] = futures[k].result() if k in futures else job.step(k)
                    except BrokenProcessPool:
                        break
                    if progress is not None:
                        progress(n, len(todo), plan.steps[k].part, "done")
            except KeyboardInterrupt:
                _terminate(pool)
                raise
    finally:
        _JOB = None
    _retry_alone(job, todo, done, progress)
    return [done[k] for k in todo]


def simulate_plan(plan: Plan, product: Product, geometry: ProductGeometry,
                  fidelity: Fidelity = BALANCED, *, cull: bool = True,
                  settings: SceneSettings | None = None,
                  criteria: SuccessCriteria | None = None,
                  steps: Sequence[int] | None = None,
                  progress: ProgressFn | None = None,
                  workers: int | None = 1,
                  pose_error: PoseError | None = None) -> PlanResults:
    """Simulate every step of ``plan`` (or the ``steps`` given) and judge each.

    Parameters
    ----------
    plan : Plan
    product : Product
        The product the plan was made for (raises
        :class:`~asmplan.sim.scene.PlanProductMismatchError` otherwise).
    geometry : ProductGeometry
        The product's shared geometry.
    fidelity : Fidelity
        Preset (:data:`~asmplan.sim.fidelity.BALANCED` by default).
    cull : bool
        True: each step's scene holds only what it needs; False: every part is present.
    settings : SceneSettings, optional
    criteria : SuccessCriteria, optional
        Default: :func:`criteria_for` the product.
    steps : sequence of int, optional
        Indices to simulate (default all).
    progress : callable, optional
        ``progress(k, n, part, status)``; status "start" and "done" in one process, only
        "done" (in step order) with several.
    workers : int or None
        Processes to simulate steps in: 1 (default) in this process; more forks worker
        processes (Linux; the steps are independent worlds, so the results are identical);
        None: one per step when there are at most twice as many steps as
        :func:`default_workers` (they share the cores and end together), else one per core.
        Pass 1 inside a process pool of your own.
    pose_error : PoseError, optional
        A robot pose error applied at every insertion (the part displaced across the mate
        axis and tilted, :mod:`asmplan.sim.pose_error`); each step's result records it.

    Returns
    -------
    PlanResults
    """
    check_plan_product(plan, product)
    s = settings or SceneSettings()
    todo = list(range(len(plan.steps))) if steps is None else sorted(set(int(k) for k in steps))
    for k in todo:
        if not 0 <= k < len(plan.steps):
            raise IndexError(f"step {k}: expected 0..{len(plan.steps) - 1}")
    n_workers = resolve_workers(workers, sum(plan.steps[k].trajectory is not None for k in todo))
    if n_workers > 1:
        job = _Job(product, geometry, fidelity, cull, s, criteria, plan, pose_error)
        results = _simulate_parallel(job, todo, n_workers, progress)
    else:
        results = []
        for n, k in enumerate(todo):
            if progress is not None:
                progress(n, len(todo), plan.steps[k].part, "start")
            results.append(simulate_step(plan, k, product, geometry, fidelity, cull=cull,
                                         settings=s, criteria=criteria,
                                         pose_error=pose_error))
            if progress is not None:
                progress(n, len(todo), plan.steps[k].part, "done")
    return PlanResults(product=product.name, source=plan.source,
                       plan_sequence=tuple(plan.sequence), fidelity=fidelity, culled=cull,
                       scene_settings=s, steps=tuple(results),
                       warnings=clearance_warnings(product, fidelity))


# ---------------------------------------------------------------------------------------------
# Simulating while planning
# ---------------------------------------------------------------------------------------------
class PipelinedSimulation:
    """Simulate each step in a forked worker process as soon as the planner has planned it.

    Pass :meth:`on_step` to :func:`asmplan.planner.product.plan_product` (``on_step=``) and
    call :meth:`results` with the finished plan. A step's scene needs of the other steps only
    where their parts are (placed parts at their final poses, the others at their start
    poses, which the planner fixes before planning), so the worker gets the step and that
    layout; the result is the same as :func:`simulate_plan` on the whole plan
    (``tests/test_run.py``). When the planner gives
    up an order and tries the next, the steps of the old order are cancelled or ignored.
    Use as a context manager (the pool is shut down on exit).
    """

    def __init__(self, product: Product, geometry: ProductGeometry, fidelity: Fidelity, *, workers: int,
                 cull: bool = True, settings: SceneSettings | None = None,
                 criteria: SuccessCriteria | None = None,
                 pose_error: PoseError | None = None) -> None:
        if int(workers) < 2:
            raise ValueError(f"workers: expected >= 2 (else simulate after planning), "
                             f"found {workers}")
        self.product = product
        self._job = _Job(product, geometry, fidelity, cull, settings or SceneSettings(), criteria,
                         pose_error=pose_error)
        self.workers = int(workers)
        self._pool: ProcessPoolExecutor | None = None
        self._futures: dict[tuple[tuple[str, ...], int], Any] = {}
        # while the planner runs it keeps one core: at most cores - 1 steps run at once, the
        # others wait here (an abandoned order's waiting steps are dropped, never run)
        self.planning_workers = max(1, min(self.workers, default_workers() - 1))
        self._waiting: dict[tuple[tuple[str, ...], int], tuple[Step, AssemblyState]] = {}
        self._order: tuple[str, ...] | None = None
        self._planned: dict[int, Step] = {}  # steps of the current order so far

    def __enter__(self) -> PipelinedSimulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self, *, now: bool = False) -> None:
        """Stop the workers (pending steps are cancelled; with ``now``, running ones too)."""
        global _JOB
        if self._pool is not None:
            if now:
                _terminate(self._pool)
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
            _JOB = None
        self._futures.clear()

    def on_step(self, order: tuple[str, ...], step: Step,
                start_poses: dict[str, np.ndarray]) -> None:
        """The planner planned ``step`` of ``order``: start simulating it."""
        order = tuple(order)
        for key in [k for k in self._futures if k[0] != order]:  # an abandoned order
            self._futures.pop(key).cancel()
        for key in [k for k in self._waiting if k[0] != order]:
            del self._waiting[key]
        if self._order != order:
            self._order, self._planned = order, {}
        self._planned[step.index] = step
        if step.trajectory is None:
            return
        # what assembly_state(plan, index) gives on the finished plan: the parts of the earlier
        # steps and the fixtured ones at their final poses, a regrasped part where its regrasp
        # put it down, the others at their start poses
        fixtured = [p for p in order if self.product.is_fixtured(p)]
        starts = {p: (self.product.T_world_assembled(p) if p in fixtured else start_poses[p])
                  for p in order}
        state = state_before([self._planned[i] for i in range(step.index + 1)], starts, fixtured)
        self._waiting[(order, step.index)] = (step, state)
        self._submit_waiting(self.planning_workers)

    def start_all(self) -> None:
        """Planning is over: start every waiting step now (every core simulates; the caller
        may do other work, e.g. render the plan's pictures, before :meth:`results`)."""
        self._submit_waiting(None)

    def _submit_waiting(self, limit: int | None) -> None:
        """Start waiting steps, in planning order, while fewer than ``limit`` run (None: all)."""
        while self._waiting:
            running = sum(not f.done() for f in self._futures.values())
            if limit is not None and running >= limit:
                return
            key = next(iter(self._waiting))
            step, state = self._waiting.pop(key)
            self._futures[key] = self._ensure_pool().submit(_simulate_planned, step, state)

    def results(self, plan: Plan, progress: ProgressFn | None = None,
                on_result: Callable[[StepResult], None] | None = None) -> PlanResults:
        """The results of every step of the finished ``plan`` (waits for the workers).

        ``on_result(step_result)`` is called in this process as each step's result comes
        back, in the order the workers finish them (``progress`` likewise, with the count of
        finished steps): the caller may use the wait (e.g. draw that step's report
        pictures while the others simulate). The results are the same whatever the order."""
        check_plan_product(plan, self.product)
        order = tuple(plan.sequence)
        self._submit_waiting(None)  # planning is over: every core simulates
        job = replace(self._job, plan=plan)
        done: dict[int, StepResult] = {}
        n = len(plan.steps)

        def finished(k: int, res: StepResult) -> None:
            done[k] = res
            if on_result is not None:
                on_result(res)
            if progress is not None:
                progress(len(done) - 1, n, plan.steps[k].part, "done")

        pending: dict[Future[StepResult], int] = {}
        for k, step in enumerate(plan.steps):
            future = self._futures.get((order, k))
            if future is None and step.trajectory is not None:  # not reported by the planner
                try:
                    future = self._ensure_pool().submit(_simulate_planned, step,
                                                        assembly_state(plan, k))
                except BrokenProcessPool:
                    continue
            if future is not None:
                pending[future] = k
            else:
                finished(k, job.step(k))
        for future in as_completed(pending):
            try:
                res = future.result()
            except BrokenProcessPool:
                continue
            finished(pending[future], res)
        if len(done) < n:  # a worker died
            self.close()
            _retry_alone(job, range(n), done, progress)
        return PlanResults(product=self.product.name, source=plan.source,
                           plan_sequence=order, fidelity=job.fidelity, culled=job.cull,
                           scene_settings=job.settings,
                           steps=tuple(done[k] for k in range(n)),
                           warnings=clearance_warnings(self.product, job.fidelity))

    def _ensure_pool(self) -> ProcessPoolExecutor:
        """The worker pool, forked on first use (the workers inherit the job)."""
        global _JOB
        if self._pool is None:
            _JOB = self._job
            self._pool = _worker_pool(self.workers, self._job)
        return self._pool


def _duration_s(step: Step) -> float:
    """How long a moving step's trajectory lasts, s (0 for a step without one)."""
    return 0.0 if step.trajectory is None else step.trajectory.duration_s
