"""Judge one executed assembly step against its criteria: held, slip, position, axis and
angle, insertion force, penetration and energy growth, each failure as a typed criterion with
its measured value and limit (the definitions are in :mod:`asmplan.sim.execute`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from ..planner.trajectory import Trajectory, rotation_angle_rad
from .records import HELD_PHASES, StepOutcome, StepRecord, SuccessCriteria
from .verdicts import ContactEvidence, Failure, classify_insertion

_SPEED_MARGIN_MPS = 0.1


def _trajectory_peak_speed(trajectory: Trajectory) -> float:
    p = trajectory.T_world_gripper[:, :3, 3]
    dt = np.diff(trajectory.t_s)
    if dt.size == 0:
        return 0.0
    return float(np.max(np.linalg.norm(np.diff(p, axis=0), axis=1) / dt))


RIM_DEPTH_M = 0.5e-3
"""An insertion that entered less than this (or less than a tenth of its engagement) stopped
on the rim: a tilted unchamfered pin's corner can drop a fraction of a millimetre into the
gap on one side without being captured."""


def _failures(record: StepRecord, outcome: StepOutcome, crit: SuccessCriteria,
              target: np.ndarray | None, axis: np.ndarray | None,
              insertion_length_m: float | None, stop: Failure | None,
              evidence: Callable[[int], tuple[ContactEvidence, ...]] | None = None
              ) -> tuple[Failure, ...]:
    """The typed causes of a failed step (:mod:`asmplan.sim.verdicts`); ``evidence(row)``
    gives the contacts holding the part at a record row of "lower"."""
    out: list[Failure] = [] if stop is None else [stop]
    if outcome.success and stop is None:
        return ()
    n = record.n_ticks
    held = record.phase_mask("lift", "translate")
    if n and held.any():
        slip = float(np.max(record.slip_m[held]))
        if slip > crit.max_slip_m:
            out.append(Failure("slipped", slip, crit.max_slip_m, "m"))
    lower = record.phase_mask("lower")
    if (n and lower.any() and target is not None and axis is not None
            and insertion_length_m is not None and insertion_length_m > 0):
        ax = record.axial_error_m[lower]
        # the part stopped while the gripper kept pushing: where it first slipped past the
        # limit (whatever happened after, e.g. forced in by penetration); else, short of its
        # depth at the end, where it got deepest
        slipped = np.flatnonzero(record.slip_m[lower] > crit.max_slip_m)
        if slipped.size:
            j = int(slipped[0])
        elif abs(outcome.final_axial_error_m) > crit.axial_tol_m:
            j = int(np.nanargmin(ax))
        else:
            return tuple(out)
        entered = float(insertion_length_m - ax[j])
        T = record.T_world_part[lower][j]
        tilt = float(rotation_angle_rad(target[:3, :3].T @ T[:3, :3]))
        row = int(np.flatnonzero(lower)[j])
        out.append(classify_insertion(entered, insertion_length_m,
                                      min(RIM_DEPTH_M, 0.1 * insertion_length_m), tilt,
                                      float(record.lateral_error_m[lower][j]),
                                      evidence(row) if evidence is not None else (), axis))
    return tuple(out)


def failed_outcome(reasons: Sequence[str], warnings: Sequence[str] = (), wall_time_s: float = 0.0,
                   *, nan_detected: bool = False) -> StepOutcome:
    """A failed outcome with nothing measured (every figure NaN, the part counted as dropped):
    the simulation produced no usable record (NaN at the first step, or the simulator
    process died), for the reasons given."""
    return StepOutcome(
        success=False,
        reasons=tuple(reasons),
        warnings=tuple(warnings),
        final_position_error_m=math.nan,
        final_angle_error_rad=math.nan,
        final_axial_error_m=math.nan,
        max_slip_m=math.nan,
        max_slip_rad=math.nan,
        dropped=True,
        peak_clamp_force_N=math.nan,
        clamp_force_mae_N=math.nan,
        peak_insertion_force_N=math.nan,
        max_penetration_m=math.nan,
        nan_detected=nan_detected,
        energy_growth=False,
        wall_time_s=wall_time_s,
    )


# Complexity above C (radon): one branch per criterion (held, slip, position, axis, angle,
# insertion force, penetration, energy), each producing its typed failure.
def judge(
    record: StepRecord,
    trajectory: Trajectory,
    criteria: SuccessCriteria,
    part_mass_kg: float,
    gravity_mps2: float = 9.81,
    T_world_part_target: np.ndarray | None = None,
    mate_axis_world: np.ndarray | None = None,
    nan_detected: bool = False,
    warnings: tuple[str, ...] = (),
    wall_time_s: float = 0.0,
    peak_insertion_force_between_N: float = 0.0,
    max_penetration_between_m: float = 0.0,
) -> StepOutcome:
    """Apply the success criteria to a record (see the module docstring for definitions).

    ``peak_insertion_force_between_N`` and ``max_penetration_between_m`` are the peaks seen
    between two record rows (:func:`execute_step` samples them every
    :data:`PEAK_SAMPLE_DT_S`), so the peak criteria do not depend on ``record_every_steps``.
    """
    reasons: list[str] = []
    n = record.n_ticks
    if n == 0:
        return failed_outcome(("no tick recorded (NaN at the first step)",), warnings,
                              wall_time_s, nan_detected=True)
    clamp_end = next((p.t_end_s for p in trajectory.phases if p.name == "clamp"), record.t_s[0])
    held = record.phase_mask(*HELD_PHASES) & (record.t_s >= clamp_end - 1e-12)
    max_slip = float(np.max(record.slip_m[held])) if held.any() else 0.0
    max_slip_rad = float(np.max(record.slip_rad[held])) if held.any() else 0.0
    # the hold phase lets the fingers settle while the part still rests where it lies: a
    # gently commanded clamp (27 mN on a 1.2 g bolt) may close its fingers during it; the
    # part must be in the fingers when the hold ends and at every sample from the lift on
    no_force = np.max(record.measured_force_N, axis=1) <= 0.0
    in_hold = record.phase_mask("hold")
    lost = held & no_force & ~in_hold
    if in_hold.any():
        last_hold = int(np.flatnonzero(in_hold)[-1])
        lost[last_hold] |= bool(held[last_hold] and no_force[last_hold])
    dropped = bool(lost.any()) or max_slip > criteria.drop_slip_m
    mae = (
        # the squeeze (mean of the two fingers) against the command: synchronised jaws make
        # the pads differ by the load along the closing axis, which the mechanism carries
        float(np.mean(np.abs(record.measured_force_N[held].mean(axis=1)
                             - record.commanded_force_N[held])))
        if held.any()
        else math.nan
    )
    peak_clamp = float(np.max(record.measured_force_N))
    lower = record.phase_mask("lower")
    ext = np.linalg.norm(record.external_force_N, axis=1)
    peak_insert = float(np.max(ext[lower])) if lower.any() else 0.0
    peak_insert = max(peak_insert, float(peak_insertion_force_between_N))
    max_pen = max(float(np.max(record.max_penetration_m)), float(max_penetration_between_m))

    pos_err = ang_err = axial_err = math.nan
    T_final = record.T_world_part[-1]
    if T_world_part_target is not None:
        pos_err = float(np.linalg.norm(T_final[:3, 3] - T_world_part_target[:3, 3]))
        R_err = T_world_part_target[:3, :3].T @ T_final[:3, :3]
        if mate_axis_world is not None and criteria.ignore_rotation_about_axis:
            a_part = T_world_part_target[:3, :3].T @ mate_axis_world
            tilt = float(np.clip((R_err @ a_part) @ a_part, -1.0, 1.0))
            ang_err = math.acos(tilt)
        else:
            ang_err = float(rotation_angle_rad(R_err))
        if mate_axis_world is not None:
            axial_err = float(record.axial_error_m[-1])

    # energy growth: faster than commanded motion plus free fall can explain
    z0 = record.T_world_part[0, 2, 3]
    drop = max(0.0, float(z0 - np.min(record.T_world_part[:, 2, 3])))
    v_allow = (
        2.0 * _trajectory_peak_speed(trajectory)
        + math.sqrt(2.0 * gravity_mps2 * drop)
        + _SPEED_MARGIN_MPS
    )
    ke_allow = 2.0 * 0.5 * part_mass_kg * v_allow**2
    ke_max = float(np.max(record.kinetic_energy_J))
    energy_growth = bool(ke_max > ke_allow)

    if nan_detected:
        reasons.append(f"NaN in the simulation state at t = {record.t_s[-1]:.4f} s")
    if dropped:
        if lost.any():
            t_lost = float(record.t_s[np.argmax(lost)])
            reasons.append(f"part dropped: no finger contact at t = {t_lost:.3f} s in a held phase")
        else:
            reasons.append(
                f"part dropped: slip {max_slip * 1e3:.2f} mm > {criteria.drop_slip_m * 1e3:.2f} mm"
            )
    if max_slip > criteria.max_slip_m:
        reasons.append(
            f"slip {max_slip * 1e3:.3f} mm > limit {criteria.max_slip_m * 1e3:.3f} mm"
        )
    if max_slip_rad > criteria.max_slip_rad:
        reasons.append(
            f"rotational slip {math.degrees(max_slip_rad):.2f} deg > limit "
            f"{math.degrees(criteria.max_slip_rad):.2f} deg"
        )
    if T_world_part_target is not None:
        if mate_axis_world is not None and axial_err > criteria.axial_tol_m:
            reasons.append(
                f"insertion depth not reached: {axial_err * 1e3:.3f} mm short of the target "
                f"along the mate axis (tolerance {criteria.axial_tol_m * 1e3:.3f} mm)"
            )
        if pos_err > criteria.position_tol_m:
            reasons.append(
                f"final position error {pos_err * 1e3:.3f} mm > tolerance "
                f"{criteria.position_tol_m * 1e3:.3f} mm"
            )
        if ang_err > criteria.angle_tol_rad:
            reasons.append(
                f"final angle error {math.degrees(ang_err):.2f} deg > tolerance "
                f"{math.degrees(criteria.angle_tol_rad):.2f} deg"
            )
    if peak_insert > criteria.max_insertion_force_N:
        reasons.append(
            f"peak insertion force {peak_insert:.2f} N > limit "
            f"{criteria.max_insertion_force_N:.2f} N"
        )
    if max_pen > criteria.max_penetration_m:
        reasons.append(
            f"contact penetration {max_pen * 1e3:.3f} mm > {criteria.max_penetration_m * 1e3:.3f}"
            f" mm: the solver did not resolve a contact, the result cannot be trusted"
        )
    if energy_growth:
        reasons.append(
            f"energy growth: part kinetic energy {ke_max:.4g} J > {ke_allow:.4g} J that the "
            f"motion and free fall can explain"
        )
    return StepOutcome(
        success=not reasons,
        reasons=tuple(reasons),
        warnings=warnings,
        final_position_error_m=pos_err,
        final_angle_error_rad=ang_err,
        final_axial_error_m=axial_err,
        max_slip_m=max_slip,
        max_slip_rad=max_slip_rad,
        dropped=dropped,
        peak_clamp_force_N=peak_clamp,
        clamp_force_mae_N=mae,
        peak_insertion_force_N=peak_insert,
        max_penetration_m=max_pen,
        nan_detected=nan_detected,
        energy_growth=energy_growth,
        wall_time_s=wall_time_s,
    )
