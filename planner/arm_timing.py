"""Joint-limited timing of the arm's motions: finite-difference joint rates, retiming a
Cartesian trajectory phase by phase within the joints' limits, rest-to-rest joint moves.

Timing
------
The Cartesian trajectory (timed within the process's speed and acceleration limits) is
retimed phase by phase: each phase's time axis is stretched by
``k = max(1, max |dq/dt| / v_max, sqrt(max |d2q/dt2| / a_max))`` (finite differences of the
IK solutions at the samples), which keeps the path, keeps every Cartesian speed within its
limit (it only slows) and brings every joint within its velocity and acceleration limits.
Between steps the arm moves rest-to-rest in joint space from the previous step's last state
to the next step's first (minimum-jerk, the slowest joint within its limits); that transfer
time counts in the cycle time.
"""

from __future__ import annotations

import math

import numpy as np

from .timing import min_jerk_duration_s
from .trajectory import PhaseSpan, Trajectory


def joint_rates(t: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Finite-difference joint velocities (N-1, 6) and accelerations (N-2, 6) of samples
    ``Q`` (N, 6) at times ``t`` (N,)."""
    dt = np.diff(t)
    v = np.diff(Q, axis=0) / dt[:, None]
    tm = 0.5 * (t[1:] + t[:-1])
    a = np.diff(v, axis=0) / np.diff(tm)[:, None]
    return v, a


def retime(traj: Trajectory, Q: np.ndarray, vmax: np.ndarray, amax: np.ndarray
           ) -> tuple[Trajectory, np.ndarray]:
    """Stretch each phase's time axis by its factor ``k >= 1`` so that the joint velocities
    and accelerations of ``Q`` (the IK solutions at ``traj``'s samples) keep within ``vmax``
    and ``amax``. Returns the retimed trajectory (same poses and forces) and the factors."""
    t = traj.t_s
    idx = traj.phase_indices_at(t)
    scales = np.ones(len(traj.phases))
    for p in range(len(traj.phases)):
        sel = np.flatnonzero(idx == p)
        if len(sel) < 2:
            continue
        lo = max(0, sel[0] - 1)  # the boundary sample before the phase (it starts there)
        seg = slice(lo, sel[-1] + 1)
        v, a = joint_rates(t[seg], Q[seg])
        kv = float((np.abs(v) / vmax).max()) if len(v) else 0.0
        ka = math.sqrt(float((np.abs(a) / amax).max())) if len(a) else 0.0
        k = max(kv, ka)
        scales[p] = k * (1.0 + 1e-9) if k > 1.0 else 1.0  # the margin covers rounding
    if np.all(scales == 1.0):
        return traj, scales
    new_t = np.empty_like(t)
    starts_old = np.array([ph.t_start_s for ph in traj.phases])
    durs = np.array([ph.t_end_s - ph.t_start_s for ph in traj.phases]) * scales
    starts_new = t[0] + np.concatenate([[0.0], np.cumsum(durs)[:-1]])
    for i in range(len(t)):
        p = int(idx[i])
        new_t[i] = starts_new[p] + scales[p] * (t[i] - starts_old[p])
    phases = tuple(PhaseSpan(ph.name, float(starts_new[p]), float(starts_new[p] + durs[p]))
                   for p, ph in enumerate(traj.phases))
    new_t[-1] = phases[-1].t_end_s
    out = Trajectory(t_s=new_t, T_world_gripper=traj.T_world_gripper,
                     clamp_force_N=traj.clamp_force_N, phases=phases)
    return out, scales


def joint_move_s(q0: np.ndarray, q1: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> float:
    """Duration of a synchronised rest-to-rest minimum-jerk joint move, s (the slowest joint
    at its limits)."""
    return max(min_jerk_duration_s(abs(float(d)), float(v), float(a))
               for d, v, a in zip(np.asarray(q1) - np.asarray(q0), vmax, amax, strict=True))
