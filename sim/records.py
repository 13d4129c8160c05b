"""What a simulated step produced: per-tick records, the outcome, and the success criteria.

:class:`StepRecord` holds one row per control tick (every ``fidelity.record_every_steps``
physics steps); :class:`StepOutcome` is the verdict with its evidence; :class:`SuccessCriteria`
holds the thresholds. A failed physical check is a result (``success=False`` with every failed
criterion named in ``reasons`` with its numbers), never an exception.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ..knowledge.arrays import readonly_array
from .verdicts import Failure

HELD_PHASES: tuple[str, ...] = ("hold", "lift", "translate", "lower")
"""Phases during which the part must stay in the fingers (slip and drop are checked)."""


@dataclass(frozen=True)
class SuccessCriteria:
    """Thresholds that decide whether a simulated step succeeded.

    Parameters
    ----------
    position_tol_m : float
        Largest final distance between the part's origin and its target, m.
    angle_tol_rad : float
        Largest final rotation error, rad (tilt of the mate axis when one is given and
        ``ignore_rotation_about_axis``).
    axial_tol_m : float
        Largest remaining insertion depth along the mate axis, m (only with a mate axis).
    max_slip_m : float
        Largest slip of the part in the fingers during the held phases, m.
    max_slip_rad : float
        Largest rotational slip during the held phases, rad.
    drop_slip_m : float
        Slip beyond which the part counts as dropped, m.
    max_insertion_force_N : float
        Largest contact force on the part from anything but the fingers during "lower", N.
    max_penetration_m : float
        Largest acceptable contact penetration, m. Deeper penetration means the solver could
        not resolve the contact and the answer cannot be trusted.
    ignore_rotation_about_axis : bool
        With a mate axis, measure only the tilt of the axis (the mate is axisymmetric).
    """

    position_tol_m: float = 1e-3
    angle_tol_rad: float = math.radians(2.0)
    axial_tol_m: float = 0.5e-3
    max_slip_m: float = 2e-3
    max_slip_rad: float = math.radians(3.0)
    drop_slip_m: float = 10e-3
    max_insertion_force_N: float = 20.0
    max_penetration_m: float = 0.5e-3
    ignore_rotation_about_axis: bool = True

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool):
                continue
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"SuccessCriteria.{f.name}: expected > 0, found {v}")


_RECORD_ARRAYS = (
    "t_s",
    "phase_index",
    "commanded_force_N",
    "measured_force_N",
    "slip_m",
    "slip_rad",
    "T_world_part",
    "T_world_gripper",
    "finger_travel_m",
    "axial_error_m",
    "lateral_error_m",
    "external_force_N",
    "max_penetration_m",
    "speed_mps",
    "kinetic_energy_J",
)


@dataclass(frozen=True, eq=False)
class StepRecord:
    """Per-tick time series of one simulated step (M ticks).

    Attributes
    ----------
    phase_names : tuple of str
        Names of the trajectory's phases; ``phase_index`` indexes it.
    t_s : (M,) trajectory time, s.
    phase_index : (M,) int.
    commanded_force_N : (M,) commanded per-finger clamp force (0 in open phases), N.
    measured_force_N : (M, 2) sum of contact normal forces finger 1 / finger 2 on the part, N.
    slip_m, slip_rad : (M,) part motion relative to the fingers since the end of "clamp".
    T_world_part : (M, 4, 4) part pose.
    T_world_gripper : (M, 4, 4) measured TCP pose.
    finger_travel_m : (M, 2) closing travel of each finger, m.
    axial_error_m : (M,) remaining insertion depth along the mate axis, m (NaN without one).
    lateral_error_m : (M,) distance of the part origin from the target's axis line, m (NaN).
    external_force_N : (M, 3) contact force on the part from everything except the fingers.
    max_penetration_m : (M,) deepest contact penetration of the part, m.
    speed_mps : (M,) speed of the part's centre of mass, m/s.
    kinetic_energy_J : (M,) kinetic energy of the part, J.
    """

    phase_names: tuple[str, ...]
    t_s: np.ndarray
    phase_index: np.ndarray
    commanded_force_N: np.ndarray
    measured_force_N: np.ndarray
    slip_m: np.ndarray
    slip_rad: np.ndarray
    T_world_part: np.ndarray
    T_world_gripper: np.ndarray
    finger_travel_m: np.ndarray
    axial_error_m: np.ndarray
    lateral_error_m: np.ndarray
    external_force_N: np.ndarray
    max_penetration_m: np.ndarray
    speed_mps: np.ndarray
    kinetic_energy_J: np.ndarray

    def __post_init__(self) -> None:
        m = np.asarray(self.t_s).shape[0]
        for name in _RECORD_ARRAYS:
            a = readonly_array(getattr(self, name), dtype=None)
            if a.shape[:1] != (m,):
                raise ValueError(f"StepRecord.{name}: expected {m} rows, found shape {a.shape}")
            object.__setattr__(self, name, a)
        object.__setattr__(self, "phase_names", tuple(self.phase_names))

    @property
    def n_ticks(self) -> int:
        """Number of recorded ticks."""
        return int(self.t_s.shape[0])

    def phase_mask(self, *names: str) -> np.ndarray:
        """Boolean (M,) mask of the ticks whose phase is one of ``names``."""
        idx = [i for i, n in enumerate(self.phase_names) if n in names]
        return np.isin(self.phase_index, idx)

    def arrays(self) -> dict[str, np.ndarray]:
        """All arrays by name (for comparisons and saving with ``np.savez``)."""
        return {name: getattr(self, name) for name in _RECORD_ARRAYS}

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict (nested lists of floats; NaN becomes None)."""

        def clean(a: np.ndarray) -> Any:
            if a.dtype.kind in "iu" or bool(np.isfinite(a).all()):
                return a.tolist()  # already JSON-safe: no object copy (records are large)
            obj = a.astype(object)
            obj[~np.isfinite(a)] = None
            return obj.tolist()

        out: dict[str, Any] = {"phase_names": list(self.phase_names)}
        out.update({name: clean(getattr(self, name)) for name in _RECORD_ARRAYS})
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> StepRecord:
        """Inverse of :meth:`to_dict`."""

        def load(name: str) -> np.ndarray:
            raw = data[name]
            if name == "phase_index":
                return np.asarray(raw, dtype=int)
            arr = np.array(raw, dtype=object)
            arr[arr == None] = np.nan  # noqa: E711 - elementwise comparison on an object array
            return arr.astype(float)

        return cls(phase_names=tuple(data["phase_names"]), **{n: load(n) for n in _RECORD_ARRAYS})


@dataclass(frozen=True)
class StepOutcome:
    """Verdict of one simulated step with its evidence.

    Attributes
    ----------
    success : bool
        All criteria met.
    reasons : tuple of str
        One entry per failed criterion, with the measured value and the threshold.
    warnings : tuple of str
        Conditions under which the result may be numerically unreliable (not failures).
    final_position_error_m, final_angle_error_rad : float
        Final pose error of the part w.r.t. its target (NaN without a target).
    final_axial_error_m : float
        Remaining insertion depth along the mate axis at the end, m (NaN without one).
    max_slip_m, max_slip_rad : float
        Largest slip during the held phases.
    dropped : bool
        The part left the fingers during the held phases.
    peak_clamp_force_N : float
        Largest measured finger normal force, N.
    clamp_force_mae_N : float
        Mean absolute error of the measured squeeze (mean of the two fingers' forces) vs the
        commanded per-finger force over the held phases, N (the pads themselves differ by the
        load along the closing axis that the synchronised jaws carry).
    peak_insertion_force_N : float
        Largest non-finger contact force on the part during "lower", N.
    max_penetration_m : float
    nan_detected : bool
    energy_growth : bool
        The part moved faster than the gripper motion and free fall can explain.
    wall_time_s : float
    failures : tuple of Failure
        Typed causes (:mod:`asmplan.sim.verdicts`): rim_stop, jammed, slipped, fell,
        unstable, each with its value and limit.
        Wall-clock time of the simulation loop, s (not part of the physics result).
    """

    success: bool
    reasons: tuple[str, ...]
    warnings: tuple[str, ...]
    final_position_error_m: float
    final_angle_error_rad: float
    final_axial_error_m: float
    max_slip_m: float
    max_slip_rad: float
    dropped: bool
    peak_clamp_force_N: float
    clamp_force_mae_N: float
    peak_insertion_force_N: float
    max_penetration_m: float
    nan_detected: bool
    energy_growth: bool
    wall_time_s: float = 0.0
    failures: tuple[Failure, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict (NaN becomes None)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, float) and not math.isfinite(v):
                v = None
            elif isinstance(v, tuple):
                v = [x.to_dict() if isinstance(x, Failure) else x for x in v]
            out[f.name] = v
        return out
