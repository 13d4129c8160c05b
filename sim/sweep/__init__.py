"""Tolerance-robustness sweeps: sample part tolerances and robot error, run many independent
simulations through any :class:`concurrent.futures.Executor`, journal them, summarise them.

Four pieces, usable on their own:

* **Sampling** -- :class:`SweepSpec` says which factors vary and how; :func:`draw_sample`
  turns ``(spec, sample index)`` into a :class:`SampleParams`. Every factor of every sample
  has its own random stream, ``SeedSequence(spec.seed, spawn_key=(index, crc32(name)))``
  (the same as a child of ``SeedSequence(spec.seed).spawn(...)[index]``), so a sample's values
  depend only on the seed, its index and the factor's name: never on which worker drew it, in
  what order, how many samples the sweep has, or which other factors vary.
* **Execution** -- :func:`run_sweep` submits ``task(params)`` for every sample to an executor
  (a local process pool by default, or a Dask cluster through :func:`connect_dask`), keeps the
  results by sample index, retries samples whose worker died and records a sample that keeps
  killing its worker, or whose task raised, as a failed :class:`TaskResult` with the reason.
* **Journal** -- :class:`SweepJournal` is an append-only JSON-lines file: a header (what the
  sweep is) and one line per finished sample, flushed and fsync'ed as each completes. A resumed
  sweep skips the samples already in it; a different sweep is refused.
* **Statistics** -- :func:`summarize` gives per step the success rate with a Wilson 95 %
  interval, the failure reasons counted, and per factor of the step's scene the success rate
  in bins, the point-biserial correlation with its p-value and Benjamini-Hochberg q-value, and
  a one-factor logistic fit; a factor is named as driving the failures only under the rules of
  :class:`DriverSettings` (scene, minimum sample size, false discovery rate).

A fifth piece (:mod:`.task`) wires these to the simulator: :class:`PlanSweep` (product, plan, fidelity),
:func:`perturb_product` (sampled clearances and friction), :func:`apply_pose_error` (the
robot's error on a step's trajectory) and the task :func:`simulate_sample`, which calls
:func:`asmplan.sim.simulate.simulate_step` per step. Importing this module loads no pybullet:
the task imports the simulator when it runs, in the worker.

Distributions (documented once; see :class:`SweepSpec`)
-------------------------------------------------------
clearance
    Diametral clearance (hole minus pin diameter) of every mate, within its declared fit
    range ``[clearance_min_m, clearance_max_m]``. ``"sizes"`` (the default) draws the actual
    sizes with the size model of :mod:`asmplan.knowledge.press_fit` (the one behind ``check``'s
    ``probability_interference`` and ``press_force_N``): for an ISO fit the hole's and the
    shaft's actual sizes, each normal, centred in its tolerance zone with 6 sigma = the zone
    width and truncated to the zone (out-of-zone parts are rejected at inspection), the
    clearance being their difference; for a declared range the clearance, normal, centred in
    the range with 6 sigma = its width, truncated to it. Sizes are drawn per feature (part
    feature instance) and sample, from the stream ``size/<part>.<feature>``: two mates that
    share a feature (a bore taking a piston and seating a cap) see the same actual size, and
    the geometry builds it once (:attr:`SampleParams.size_deviation_m`); a feature named by
    two ISO fits takes the zone of the first mate in the product. A sample whose clearance is negative
    interferes: its step is pressed against the Lame force of THAT interference
    (:func:`.task.sample_press_step`), or fails ``press_required`` when neither the grip nor
    the cell's press can give it. ``"uniform"`` over the range, or
    ``"truncnormal"``: a normal centred on the middle of the range with sigma = range / 6,
    truncated to the range (the +-3 sigma process-capability reading of a tolerance).
friction
    Every part's friction coefficient times ``1 + friction_rel_sigma * z`` with ``z`` a
    standard normal truncated to [-3, 3].
pose
    Robot positioning error per step, in the step's insertion frame (x, y perpendicular to
    the insertion direction): lateral offset (2,) in m and tilt (2,) in rad about x and y.
    ``"normal"``: each component normal with sigma ``pose_lateral_m`` / ``pose_angular_rad``.
    ``"uniform"``: the magnitude uniform in ``[0, pose_lateral_m]`` (``[0, pose_angular_rad]``)
    and the direction uniform on the circle; this covers the magnitudes evenly, which is what a
    study of where success falls off needs.
"""

from __future__ import annotations

from .errors import (
    DaskUnavailableError,
    ExecutorBrokenError,
    JournalCorruptError,
    JournalLockedError,
    JournalMismatchError,
    SweepError,
)
from .executors import (
    START_METHOD,
    DaskConnection,
    connect_dask,
    default_executor,
    run_sweep,
)
from .journal import (
    JOURNAL_FORMAT,
    JOURNAL_NAME,
    SweepJournal,
    TaskResult,
    iter_journal_results,
    journal_header,
    sha256_hex,
)
from .sampling import (
    FACTORS,
    ClearanceRange,
    PoseError,
    SampleParams,
    SweepSpec,
    clearance_ranges,
    draw_sample,
    draw_samples,
    factor_rng,
    nominal_friction,
)
from .statistics import (
    BinStat,
    DriverSettings,
    DriverStatus,
    FactorEffect,
    FailureCount,
    StepSummary,
    SweepSummary,
    factor_effect,
    select_driver,
    summarize,
    wilson_interval,
)
from .task import (
    POSE_ERROR_RAMP_PHASE,
    PlanSweep,
    apply_pose_error,
    insertion_frame,
    perturb_product,
    sample_press_step,
    simulate_sample,
)

__all__ = [
    "FACTORS",
    "JOURNAL_FORMAT",
    "JOURNAL_NAME",
    "POSE_ERROR_RAMP_PHASE",
    "START_METHOD",
    "BinStat",
    "ClearanceRange",
    "DaskConnection",
    "DaskUnavailableError",
    "DriverSettings",
    "DriverStatus",
    "ExecutorBrokenError",
    "FactorEffect",
    "FailureCount",
    "JournalCorruptError",
    "JournalLockedError",
    "JournalMismatchError",
    "PlanSweep",
    "PoseError",
    "SampleParams",
    "StepSummary",
    "SweepError",
    "SweepJournal",
    "SweepSpec",
    "SweepSummary",
    "TaskResult",
    "apply_pose_error",
    "clearance_ranges",
    "connect_dask",
    "default_executor",
    "draw_sample",
    "draw_samples",
    "factor_effect",
    "factor_rng",
    "insertion_frame",
    "iter_journal_results",
    "journal_header",
    "nominal_friction",
    "perturb_product",
    "run_sweep",
    "sample_press_step",
    "select_driver",
    "sha256_hex",
    "simulate_sample",
    "summarize",
    "wilson_interval",
]
