"""The sections of ``asmplan bench``, as the CLI (:mod:`asmplan.commands.bench`) loads them:
one namespace over the bench's accuracy (:mod:`bench.accuracy`), bounds (:mod:`bench.bounds`),
cost measurements (:mod:`bench.cost`), tables (:mod:`bench.tables`) and report
(:mod:`bench.report`). The arm, CAD import, exact fits, motion and sequencing benchmarks are in
their own modules beside these; the validation scenes in :mod:`bench.scenarios`.

Every measurement is a function returning typed, frozen results; formatting to Markdown and
the accuracy assertions (:data:`BOUNDS`, :func:`check_bounds`) are separate. Time is measured
and reported, never asserted: the machine is shared and noisy.
"""

from __future__ import annotations

from .accuracy import (
    DRIFT_TILTS_RAD,
    INSERTION_CLEARANCES_M,
    JAM_CLEARANCES_M,
    JAM_TILTS_DEG,
    PAPER_MAE_N,
    REFERENCE_DT_S,
    SEED_MU,
    SEED_PART_MASS_KG,
    SLIP_ACCELS_MPS2,
    AccuracyResult,
    InsertionRun,
    PeerRow,
    contact_figures,
    exact_solver_fidelity,
    peer_rows,
    pin_insertion,
    predicted_seed_profile,
    reference_fidelity,
    run_accuracy,
    seed_profile_figures,
    slip_threshold_error,
)
from .bounds import BOUNDS, AccuracyFigure, Bound, Regression, check_bounds
from .cost import (
    CULLING_SIZE,
    READ_PARTS,
    READ_RUNS,
    SCALING_FIT_MM,
    SEED_REPORT_RUNS,
    SEED_RUNS,
    STAGES,
    CullingResult,
    PlanningResult,
    ReadTiming,
    ScalingRow,
    SeedRunTiming,
    SweepResult,
    run_arm,
    run_culling,
    run_planning,
    run_read,
    run_scaling,
    run_seed_timing,
    run_sweep_throughput,
    scaling_growth,
)
from .report import BenchReport, format_markdown, machine_description
from .tables import (
    accuracy_plot_png,
    format_accuracy,
    format_accuracy_summary,
    format_arm,
    format_culling,
    format_peers,
    format_planning,
    format_read,
    format_scaling,
    format_seed_timing,
    format_sweep,
)

__all__ = [
    "BOUNDS", "CULLING_SIZE", "DRIFT_TILTS_RAD", "INSERTION_CLEARANCES_M", "JAM_CLEARANCES_M",
    "JAM_TILTS_DEG", "PAPER_MAE_N", "READ_PARTS", "READ_RUNS", "REFERENCE_DT_S", "SCALING_FIT_MM",
    "SEED_MU", "SEED_PART_MASS_KG", "SEED_REPORT_RUNS", "SEED_RUNS", "SLIP_ACCELS_MPS2", "STAGES",
    "AccuracyFigure", "AccuracyResult", "BenchReport", "Bound", "CullingResult", "InsertionRun",
    "PeerRow", "PlanningResult", "ReadTiming", "Regression", "ScalingRow", "SeedRunTiming",
    "SweepResult", "accuracy_plot_png", "check_bounds", "contact_figures", "exact_solver_fidelity",
    "format_accuracy", "format_accuracy_summary", "format_arm", "format_culling", "format_markdown",
    "format_peers", "format_planning", "format_read", "format_scaling", "format_seed_timing",
    "format_sweep", "machine_description", "peer_rows", "pin_insertion", "predicted_seed_profile",
    "reference_fidelity", "run_accuracy", "run_arm", "run_culling", "run_planning", "run_read",
    "run_scaling", "run_seed_timing", "run_sweep_throughput", "scaling_growth", "seed_profile_figures",
    "slip_threshold_error",
]
