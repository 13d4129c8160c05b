"""Planning a whole product: the ranked part orders of the sequence planner tried best first,
every step planned by :class:`~asmplan.planner.motion.MotionPlanner`, into a :class:`Plan`.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..knowledge.model import Product
from ..parts.models import ProductGeometry
from .arm_turns import retune_turns
from .errors import (
    PlanningError,
)
from .fcl_oracle import FclOracle
from .motion import MotionPlanner, PlanResult, StepTiming
from .partdata import PartData, part_data
from .plan import Plan, Step
from .sequence import SequencePlan, plan_sequence
from .settings import PlannerSettings

ProgressFn = Callable[[int, int, str, str], None]
StepFn = Callable[[tuple[str, ...], Step, dict[str, np.ndarray]], None]


@dataclass(frozen=True, eq=False)
class SequenceChoice:
    """A part order to plan, where it came from, and the insertion direction (3,) the
    sequence planner chose per part (used for parts without a mate to the partial assembly).
    """

    order: tuple[str, ...]
    note: str = ""
    insertions: dict[str, np.ndarray] = field(default_factory=dict)


def ranked_sequences(sp: SequencePlan) -> list[SequenceChoice]:
    """The sequence planner's ranked orders in ``sp``, best first."""
    return [SequenceChoice(tuple(r.order),
                           f"sequence planner: rank {r.rank} of {len(sp.sequences)} "
                           f"({sp.method}), cost {r.cost_s:.2f} s",
                           {s.part: np.asarray(s.insertion, float) for s in r.steps})
            for r in sp.sequences]


def plan_product(product: Product, geometry: ProductGeometry,
                 settings: PlannerSettings | None = None, *,
                 sequence: Sequence[str] | None = None, sequence_note: str = "",
                 insertions: dict[str, np.ndarray] | None = None,
                 sequences: Sequence[SequenceChoice] | None = None,
                 parts: dict[str, PartData] | None = None, progress: ProgressFn | None = None,
                 on_step: StepFn | None = None) -> PlanResult:
    """Plan every step of ``product``.

    The order is ``sequence`` when given; otherwise the ranked ``sequences`` (default: the
    sequence planner's, :func:`ranked_sequences`) are tried best first and the first that
    can be planned is used (the sequence planner does not know the gripper: a part may be
    reachable only before another one closes the space around it).

    Parameters
    ----------
    product : Product
    geometry : ProductGeometry
        The product's shared geometry (every part's models are built once).
    settings : PlannerSettings, optional
    sequence : sequence of str, optional
        Part order; fixtured parts may appear anywhere (they are in place from the start).
    sequence_note : str
        Where ``sequence`` came from (stored in the plan).
    insertions : dict, optional
        Insertion direction (3,) per part, for parts without a mate to the partial assembly.
    sequences : sequence of SequenceChoice, optional
        Ranked orders to try when ``sequence`` is not given.
    parts : dict of PartData, optional
        The parts' planning data when already made from ``geometry`` (default: made now).
    progress : callable, optional
        ``progress(step_index, n_steps, part, status)`` with status "start" or "done".
    on_step : callable, optional
        ``on_step(order, step, start_poses)`` after each step is planned: the order being
        tried (tuple of part names), the new :class:`Step`, and the start pose (4, 4) of every
        part. Lets a caller start simulating a step while later ones are planned; when an
        order fails and the next is tried, the steps already reported for it are void.

    Raises
    ------
    PlanningError
        A typed failure with evidence (see :mod:`asmplan.planner.errors`). When several ranked
        orders were tried, the best-ranked one's failure is raised and ``alternatives`` lists
        the others' failures.
    """
    settings = settings or PlannerSettings()
    t0 = time.perf_counter()
    if parts is None:
        parts = part_data(product, settings, geometry)
    geometry_s = time.perf_counter() - t0
    if sequence is not None:
        choices = [SequenceChoice(tuple(sequence), sequence_note, dict(insertions or {}))]
    else:
        if sequences is None:
            sequences = ranked_sequences(plan_sequence(product, FclOracle(product, geometry)))
        choices = list(sequences)
    failures: list[tuple[SequenceChoice, PlanningError]] = []
    for choice in choices:
        try:
            plan, times = _plan_order(product, settings, choice, parts, progress,
                                      len(failures), on_step)
        except PlanningError as exc:
            failures.append((choice, exc))
            continue
        return PlanResult(plan, times, time.perf_counter() - t0, geometry_s, tuple(
            {"order": list(c.order), "note": c.note, "failure": str(e)} for c, e in failures))
    if not failures:
        raise ValueError("sequences: expected at least one order to plan, found none")
    first = failures[0][1]
    first.alternatives = [{"order": list(c.order), "note": c.note, "failure": str(e)}
                          for c, e in failures[1:]]
    raise first


def _plan_order(product: Product, settings: PlannerSettings, choice: SequenceChoice,
                parts: dict[str, PartData], progress: ProgressFn | None,
                failed_before: int,
                on_step: StepFn | None = None) -> tuple[Plan, tuple[StepTiming, ...]]:
    sequence = list(choice.order)
    if sorted(sequence) != sorted(product.part_names):
        raise ValueError(f"sequence: expected every part once ({', '.join(product.part_names)}), "
                         f"found {sequence}")
    planner = MotionPlanner(product, settings, parts)
    steps: list[Step] = []
    times: list[StepTiming] = []
    # with the tool turns chosen over the whole sequence (the arm's, planner/arm_turns.py),
    # a step is final only once every step is planned: it is reported then
    defer = planner.arm is not None and settings.arm.plan_tool_turns
    for k, name in enumerate(sequence):
        if progress is not None:
            progress(k, len(sequence), name, "start")
        for step, timing in planner.plan_steps(len(steps), name, choice.insertions.get(name)):
            steps.append(step)
            times.append(timing)
            if on_step is not None and not defer:
                on_step(tuple(sequence), step, planner.start_poses)
        if progress is not None:
            progress(k, len(sequence), name, "done")
    if defer:
        steps = retune_turns(planner, steps)
        if on_step is not None:
            for step in steps:
                on_step(tuple(sequence), step, planner.start_poses)
    note = choice.note
    if failed_before:
        note += (f"; {failed_before} better-ranked order{'s' if failed_before > 1 else ''} "
                 "could not be planned")
    plan = Plan(product=product.name, source=str(product.source),
                source_sha256=_sha256(product.source), sequence=tuple(sequence),
                steps=tuple(steps), settings=settings, sequence_note=note)
    return plan, tuple(times)


def _sha256(path: Path) -> str:
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return ""
