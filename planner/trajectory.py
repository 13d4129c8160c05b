"""Gripper trajectories: the contract between the motion planner and the simulator.

A :class:`Trajectory` is a time-sampled gripper pose plus the commanded per-finger clamp force,
split into named phases. The simulator (``asmplan.sim.execute``) drives its gripper along it.

Gripper TCP frame convention
----------------------------
``T_world_gripper`` is the pose of the gripper's tool centre point (TCP) frame:

* origin: midway between the centres of the two fingertip pads' contact faces;
* z axis: approach direction, from the wrist toward the fingertips;
* y axis: finger closing axis; finger 1 sits at +y, finger 2 at -y, and closing moves both
  toward the origin;
* x axis: ``y cross z`` (right-handed).

A gripper pointing straight down with its fingers closing along world y therefore has
``R_world_gripper = [[-1, 0, 0], [0, 1, 0], [0, 0, -1]]`` (columns are the TCP axes).

Clamp force
-----------
``clamp_force_N`` is the commanded squeeze force of EACH finger along the closing axis (the
force one finger presses on the part), not the sum over both fingers. It is used in every
phase except "approach" and "retreat", where the fingers are position-controlled open.

Phases
------
``PHASES`` lists the phases of a pick-and-place step in their usual order; "approach" (before
"clamp") and "retreat" (after "release") are optional. Phases must tile ``[t_s[0], t_s[-1]]``
without gaps or overlaps.

Quaternions in this module are ``(x, y, z, w)`` (scalar last, as PyBullet uses).
"""

from __future__ import annotations

import csv
import io
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..knowledge.arrays import readonly_array
from .rotations import matrix_from_quat_xyzw as matrix_from_quat_xyzw
from .rotations import quat_xyzw_from_matrix as quat_xyzw_from_matrix
from .rotations import rotation_angle_rad as rotation_angle_rad
from .rotations import slerp_xyzw as slerp_xyzw

PHASES: tuple[str, ...] = ("clamp", "hold", "lift", "translate", "lower", "release")
OPTIONAL_PHASES: tuple[str, ...] = ("approach", "retreat")
OPEN_PHASES: tuple[str, ...] = OPTIONAL_PHASES
"""Phases in which the fingers are position-controlled open instead of force-controlled."""

_ALL_PHASES = frozenset(PHASES + OPTIONAL_PHASES)
_TIME_TOL_S = 1e-9
_ROT_TOL = 1e-6


# --------------------------------------------------------------------------------------------
# Trajectory
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PhaseSpan:
    """A named time interval ``[t_start_s, t_end_s]`` of a trajectory."""

    name: str
    t_start_s: float
    t_end_s: float

    def __post_init__(self) -> None:
        if self.name not in _ALL_PHASES:
            raise ValueError(
                f"phase name: expected one of {sorted(_ALL_PHASES)}, found {self.name!r}"
            )
        if not (math.isfinite(self.t_start_s) and math.isfinite(self.t_end_s)):
            raise ValueError(
                f"phase {self.name}: expected finite times, found "
                f"[{self.t_start_s}, {self.t_end_s}]"
            )
        if not self.t_end_s > self.t_start_s:
            raise ValueError(
                f"phase {self.name}: expected t_end_s > t_start_s, found "
                f"[{self.t_start_s}, {self.t_end_s}]"
            )


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Time-sampled gripper TCP poses and commanded clamp forces, split into phases.

    Parameters
    ----------
    t_s : (N,) float array
        Strictly increasing sample times, s (N >= 2).
    T_world_gripper : (N, 4, 4) float array
        Gripper TCP pose at each sample (see the module docstring for the TCP frame).
    clamp_force_N : (N,) float array
        Commanded per-finger squeeze force at each sample, N, >= 0.
    phases : tuple of PhaseSpan
        Consecutive phases covering ``[t_s[0], t_s[-1]]`` without gaps.
    """

    t_s: np.ndarray
    T_world_gripper: np.ndarray
    clamp_force_N: np.ndarray
    phases: tuple[PhaseSpan, ...]

    def __post_init__(self) -> None:
        t = readonly_array(self.t_s)
        T = readonly_array(self.T_world_gripper)
        f = readonly_array(self.clamp_force_N)
        if t.ndim != 1 or t.shape[0] < 2:
            raise ValueError(f"t_s: expected shape (N>=2,), found {t.shape}")
        n = t.shape[0]
        if T.shape != (n, 4, 4):
            raise ValueError(f"T_world_gripper: expected shape ({n}, 4, 4), found {T.shape}")
        if f.shape != (n,):
            raise ValueError(f"clamp_force_N: expected shape ({n},), found {f.shape}")
        for name, arr in (("t_s", t), ("T_world_gripper", T), ("clamp_force_N", f)):
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name}: expected finite values, found NaN or inf")
        dt = np.diff(t)
        if np.any(dt <= 0.0):
            i = int(np.argmin(dt))
            raise ValueError(
                f"t_s: expected strictly increasing times, found t[{i}]={t[i]} >= "
                f"t[{i + 1}]={t[i + 1]}"
            )
        R = T[:, :3, :3]
        ortho_err = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
        det = np.linalg.det(R)
        bad = np.flatnonzero((ortho_err > _ROT_TOL) | (np.abs(det - 1.0) > _ROT_TOL))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"T_world_gripper[{i}]: expected a proper rotation (R^T R = I, det 1), found "
                f"orthonormality error {ortho_err[i]:.3g}, det {det[i]:.6g}"
            )
        bottom = np.abs(T[:, 3, :] - np.array([0.0, 0.0, 0.0, 1.0])).max()
        if bottom > 1e-12:
            raise ValueError(
                f"T_world_gripper: expected last rows [0, 0, 0, 1], found deviation {bottom}"
            )
        if np.any(f < 0.0):
            i = int(np.argmin(f))
            raise ValueError(f"clamp_force_N[{i}]: expected >= 0, found {f[i]}")
        phases = tuple(self.phases)
        if not phases:
            raise ValueError("phases: expected at least one PhaseSpan, found none")
        if abs(phases[0].t_start_s - t[0]) > _TIME_TOL_S:
            raise ValueError(
                f"phases: expected the first phase to start at t_s[0]={t[0]}, found "
                f"{phases[0].name} starting at {phases[0].t_start_s}"
            )
        for a, b in itertools.pairwise(phases):
            if abs(a.t_end_s - b.t_start_s) > _TIME_TOL_S:
                raise ValueError(
                    f"phases: expected {b.name} to start where {a.name} ends ({a.t_end_s}), "
                    f"found {b.t_start_s} (gap or overlap)"
                )
        if abs(phases[-1].t_end_s - t[-1]) > _TIME_TOL_S:
            raise ValueError(
                f"phases: expected the last phase to end at t_s[-1]={t[-1]}, found "
                f"{phases[-1].name} ending at {phases[-1].t_end_s}"
            )
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "T_world_gripper", T)
        object.__setattr__(self, "clamp_force_N", f)
        object.__setattr__(self, "phases", phases)
        quat = quat_xyzw_from_matrix(T[:, :3, :3])
        # Make consecutive quaternions lie on the same hemisphere for interpolation.
        for i in range(1, n):
            if np.dot(quat[i], quat[i - 1]) < 0.0:
                quat[i] = -quat[i]
        quat.setflags(write=False)
        object.__setattr__(self, "_quat", quat)

    # ---------------------------------------------------------------- queries
    @property
    def duration_s(self) -> float:
        """Total duration ``t_s[-1] - t_s[0]``, s."""
        return float(self.t_s[-1] - self.t_s[0])

    def _segment(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        tc = np.clip(t, self.t_s[0], self.t_s[-1])
        i = np.clip(np.searchsorted(self.t_s, tc, side="right") - 1, 0, len(self.t_s) - 2)
        s = (tc - self.t_s[i]) / (self.t_s[i + 1] - self.t_s[i])
        return i, np.clip(s, 0.0, 1.0)

    def poses_at(self, t: np.ndarray) -> np.ndarray:
        """Gripper TCP poses at times ``t`` (clamped to the trajectory's range).

        Position is interpolated linearly between samples, rotation by slerp.

        Parameters
        ----------
        t : (M,) float array, s.

        Returns
        -------
        (M, 4, 4) float array.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        i, s = self._segment(t)
        p0 = self.T_world_gripper[i, :3, 3]
        p1 = self.T_world_gripper[i + 1, :3, 3]
        q = slerp_xyzw(self._quat[i], self._quat[i + 1], s)  # type: ignore[attr-defined]
        out = np.zeros((t.shape[0], 4, 4))
        out[:, :3, :3] = matrix_from_quat_xyzw(q)
        out[:, :3, 3] = p0 + s[:, None] * (p1 - p0)
        out[:, 3, 3] = 1.0
        return out

    def pose_at(self, t: float) -> np.ndarray:
        """Gripper TCP pose (4, 4) at time ``t``, s (clamped to the trajectory's range)."""
        return self.poses_at(np.array([t]))[0]

    def forces_at(self, t: np.ndarray) -> np.ndarray:
        """Commanded per-finger clamp force, N, at times ``t`` (M,), linearly interpolated."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        i, s = self._segment(t)
        f0 = self.clamp_force_N[i]
        return f0 + s * (self.clamp_force_N[i + 1] - f0)

    def force_at(self, t: float) -> float:
        """Commanded per-finger clamp force, N, at time ``t``, s."""
        return float(self.forces_at(np.array([t]))[0])

    def phase_indices_at(self, t: np.ndarray) -> np.ndarray:
        """Index into ``phases`` of the phase containing each time (M,) -> (M,) int.

        A boundary time belongs to the later phase; times past the end belong to the last.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        starts = np.array([p.t_start_s for p in self.phases])
        idx = np.searchsorted(starts, t + _TIME_TOL_S, side="right") - 1
        return np.clip(idx, 0, len(self.phases) - 1)

    def phase_at(self, t: float) -> str:
        """Name of the phase containing time ``t``, s (a boundary belongs to the later one)."""
        return self.phases[int(self.phase_indices_at(np.array([t]))[0])].name

    def phase_span(self, name: str) -> PhaseSpan:
        """The first phase called ``name``; raises KeyError naming the known phases."""
        for p in self.phases:
            if p.name == name:
                return p
        raise KeyError(
            f"phase {name!r} not in trajectory; found {[p.name for p in self.phases]}"
        )

    # ---------------------------------------------------------------- serialisation
    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict (lists of floats)."""
        return {
            "t_s": [float(x) for x in self.t_s],
            "T_world_gripper": self.T_world_gripper.tolist(),
            "clamp_force_N": [float(x) for x in self.clamp_force_N],
            "phases": [
                {"name": p.name, "t_start_s": float(p.t_start_s), "t_end_s": float(p.t_end_s)}
                for p in self.phases
            ],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Trajectory:
        """Inverse of :meth:`to_dict`."""
        missing = {"t_s", "T_world_gripper", "clamp_force_N", "phases"} - set(data)
        if missing:
            raise ValueError(f"trajectory dict: missing keys {sorted(missing)}")
        return cls(
            t_s=np.asarray(data["t_s"], dtype=float),
            T_world_gripper=np.asarray(data["T_world_gripper"], dtype=float),
            clamp_force_N=np.asarray(data["clamp_force_N"], dtype=float),
            phases=tuple(
                PhaseSpan(str(p["name"]), float(p["t_start_s"]), float(p["t_end_s"]))
                for p in data["phases"]
            ),
        )


# --------------------------------------------------------------------------------------------
# Seed clamp cycle
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PhaseForceSpec:
    """One row of a clamp-force phase table (e.g. the seed paper's Table 4).

    The commanded force ramps linearly from ``force_start_N`` to ``force_end_N`` over
    ``[t_start_s, t_end_s]``; ``force_min_N``/``force_max_N`` bound it inside the phase.
    """

    name: str
    t_start_s: float
    t_end_s: float
    force_start_N: float
    force_end_N: float
    force_min_N: float
    force_max_N: float

    def __post_init__(self) -> None:
        PhaseSpan(self.name, self.t_start_s, self.t_end_s)  # validates name and times
        for label in ("force_start_N", "force_end_N", "force_min_N", "force_max_N"):
            v = getattr(self, label)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"phase {self.name}: {label} expected >= 0, found {v}")
        if self.force_min_N > self.force_max_N:
            raise ValueError(
                f"phase {self.name}: expected force_min_N <= force_max_N, found "
                f"{self.force_min_N} > {self.force_max_N}"
            )


def parse_phase_table(text: str) -> tuple[PhaseForceSpec, ...]:
    """Parse a phase table in CSV form (``#`` comment lines allowed).

    Columns: ``phase,t_start_s,t_end_s,force_start_N,force_end_N,force_min_N,force_max_N``
    (further columns such as ``purpose`` are ignored).
    """
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    reader = csv.DictReader(io.StringIO("\n".join(lines)))
    need = ("phase", "t_start_s", "t_end_s", "force_start_N", "force_end_N")
    rows = []
    for k, row in enumerate(reader):
        missing = [c for c in need if c not in row or row[c] is None]
        if missing:
            raise ValueError(f"phase table row {k + 1}: missing columns {missing}")
        fs, fe = float(row["force_start_N"]), float(row["force_end_N"])
        rows.append(
            PhaseForceSpec(
                name=row["phase"].strip(),
                t_start_s=float(row["t_start_s"]),
                t_end_s=float(row["t_end_s"]),
                force_start_N=fs,
                force_end_N=fe,
                force_min_N=float(row.get("force_min_N") or min(fs, fe)),
                force_max_N=float(row.get("force_max_N") or max(fs, fe)),
            )
        )
    return tuple(rows)


def read_phase_table(path: str | Path) -> tuple[PhaseForceSpec, ...]:
    """Read a phase table CSV file (see :func:`parse_phase_table`)."""
    return parse_phase_table(Path(path).read_text(encoding="utf-8"))


def min_jerk(s: np.ndarray) -> np.ndarray:
    """Minimum-jerk (quintic) profile ``10 s^3 - 15 s^4 + 6 s^5`` for s in [0, 1].

    Zero velocity and acceleration at both ends.
    """
    s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s * s)


@dataclass(frozen=True, eq=False)
class Segment:
    """One phase of a piecewise trajectory, ending at a waypoint.

    The TCP moves from the previous waypoint to ``T_world_gripper_end`` with a minimum-jerk
    profile (position linear in the profile, rotation by slerp); the commanded force ramps
    linearly from ``force_start_N`` to ``force_end_N``.

    Parameters
    ----------
    phase : str
        Phase name (see ``PHASES``/``OPTIONAL_PHASES``).
    duration_s : float
    T_world_gripper_end : (4, 4) float array
    force_start_N, force_end_N : float
        Per-finger clamp force at the start and end of the segment, N (ignored by the
        simulator in "approach"/"retreat", where fingers are open).
    """

    phase: str
    duration_s: float
    T_world_gripper_end: np.ndarray
    force_start_N: float = 0.0
    force_end_N: float = 0.0

    def __post_init__(self) -> None:
        PhaseSpan(self.phase, 0.0, self.duration_s)  # validates the name and duration > 0
        T = np.array(self.T_world_gripper_end, dtype=float)
        if T.shape != (4, 4):
            raise ValueError(
                f"segment {self.phase}: T_world_gripper_end expected shape (4, 4), found {T.shape}"
            )
        object.__setattr__(self, "T_world_gripper_end", T)
        for label in ("force_start_N", "force_end_N"):
            v = getattr(self, label)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"segment {self.phase}: {label} expected >= 0, found {v}")


def trajectory_from_segments(
    T_world_gripper_start: np.ndarray,
    segments: Sequence[Segment],
    t_start_s: float = 0.0,
    sample_dt_s: float = 1e-3,
) -> Trajectory:
    """Sample a piecewise minimum-jerk trajectory through waypoints.

    Parameters
    ----------
    T_world_gripper_start : (4, 4) float array
        TCP pose at ``t_start_s``.
    segments : sequence of Segment
        Consecutive phases; each ends at its waypoint.
    t_start_s : float
    sample_dt_s : float
        Sample spacing, s; phase boundaries are always sampled. At a boundary the later
        segment's start force applies.

    Returns
    -------
    Trajectory
    """
    segs = tuple(segments)
    if not segs:
        raise ValueError("segments: expected at least one Segment, found none")
    if not sample_dt_s > 0.0:
        raise ValueError(f"sample_dt_s: expected > 0, found {sample_dt_s}")
    T_prev = np.asarray(T_world_gripper_start, dtype=float)
    if T_prev.shape != (4, 4):
        raise ValueError(f"T_world_gripper_start: expected shape (4, 4), found {T_prev.shape}")
    times: list[np.ndarray] = []
    poses: list[np.ndarray] = []
    forces: list[np.ndarray] = []
    spans: list[PhaseSpan] = []
    t0 = float(t_start_s)
    for k, seg in enumerate(segs):
        t1 = t0 + seg.duration_s
        n = max(1, math.ceil(seg.duration_s / sample_dt_s - 1e-9))
        last = k == len(segs) - 1
        s = np.linspace(0.0, 1.0, n + 1)
        if not last:
            s = s[:-1]
        prof = min_jerk(s)
        q0 = quat_xyzw_from_matrix(T_prev[:3, :3])
        q1 = quat_xyzw_from_matrix(seg.T_world_gripper_end[:3, :3])
        T = np.zeros((s.shape[0], 4, 4))
        T[:, :3, :3] = matrix_from_quat_xyzw(slerp_xyzw(q0, q1, prof))
        move = seg.T_world_gripper_end[:3, 3] - T_prev[:3, 3]
        T[:, :3, 3] = T_prev[:3, 3] + prof[:, None] * move
        T[:, 3, 3] = 1.0
        times.append(t0 + s * seg.duration_s)
        poses.append(T)
        forces.append(seg.force_start_N + s * (seg.force_end_N - seg.force_start_N))
        spans.append(PhaseSpan(seg.phase, t0, t1))
        T_prev = seg.T_world_gripper_end
        t0 = t1
    t = np.concatenate(times)
    t[-1] = spans[-1].t_end_s
    return Trajectory(
        t_s=t,
        T_world_gripper=np.concatenate(poses),
        clamp_force_N=np.concatenate(forces),
        phases=tuple(spans),
    )


def seed_cycle(
    phase_table: Sequence[PhaseForceSpec],
    T_world_gripper_start: np.ndarray,
    lift_m: float = 0.05,
    translation_m: Sequence[float] = (0.10, 0.0, 0.0),
    sample_dt_s: float = 1e-3,
) -> Trajectory:
    """Clamp-lift-translate-lower-release cycle of the seed paper.

    The gripper holds still during "clamp", "hold" and "release"; during "lift" it rises by
    ``lift_m`` along world +z, during "translate" it moves by ``translation_m``, during
    "lower" it descends by ``lift_m``, each with a minimum-jerk profile. The commanded force
    ramps linearly inside each phase from the table's ``force_start_N`` to ``force_end_N``
    (at a phase boundary the later phase's start value applies).

    Parameters
    ----------
    phase_table : sequence of PhaseForceSpec
        Rows for the phases "clamp", "hold", "lift", "translate", "lower", "release", in this
        order and contiguous in time (e.g. ``read_phase_table(".../clamp_cycle_seed.csv")``).
    T_world_gripper_start : (4, 4) float array
        TCP pose at the start (fingers around the part).
    lift_m : float
        Lift height, m (>= 0).
    translation_m : (3,) float
        Displacement during "translate", world frame, m.
    sample_dt_s : float
        Sample spacing, s; phase boundaries are always sampled.

    Returns
    -------
    Trajectory
    """
    rows = tuple(phase_table)
    names = tuple(r.name for r in rows)
    if names != PHASES:
        raise ValueError(f"phase table: expected phases {list(PHASES)}, found {list(names)}")
    for a, b in itertools.pairwise(rows):
        if abs(a.t_end_s - b.t_start_s) > _TIME_TOL_S:
            raise ValueError(
                f"phase table: expected {b.name} to start where {a.name} ends ({a.t_end_s}), "
                f"found {b.t_start_s}"
            )
    if not (lift_m >= 0.0 and math.isfinite(lift_m)):
        raise ValueError(f"lift_m: expected a finite value >= 0, found {lift_m}")
    move = np.asarray(translation_m, dtype=float)
    if move.shape != (3,) or not np.all(np.isfinite(move)):
        raise ValueError(f"translation_m: expected 3 finite numbers, found {move.tolist()}")
    T0 = np.asarray(T_world_gripper_start, dtype=float)
    if T0.shape != (4, 4):
        raise ValueError(f"T_world_gripper_start: expected shape (4, 4), found {T0.shape}")

    def shifted(offset: np.ndarray) -> np.ndarray:
        T = T0.copy()
        T[:3, 3] += offset
        return T

    up = np.array([0.0, 0.0, lift_m])
    ends = {
        "clamp": shifted(np.zeros(3)),
        "hold": shifted(np.zeros(3)),
        "lift": shifted(up),
        "translate": shifted(up + move),
        "lower": shifted(move),
        "release": shifted(move),
    }
    segments = [
        Segment(r.name, r.t_end_s - r.t_start_s, ends[r.name], r.force_start_N, r.force_end_N)
        for r in rows
    ]
    return trajectory_from_segments(
        T0, segments, t_start_s=rows[0].t_start_s, sample_dt_s=sample_dt_s
    )
