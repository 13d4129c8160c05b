"""Time-parameterise a pick-and-insert step and compute the commanded clamp force.

Profiles
--------
Every geometric segment (a straight move between two gripper poses, or one leg of the
planned path) is executed with a minimum-jerk (quintic) profile that starts and ends at rest,
so the executed path is exactly the polyline that was collision-checked. A segment's "length"
``D`` bounds the travel of every point of the carried body: ``D = |dp| + r * dtheta`` with
``r`` the radius of the gripper-plus-part around the TCP, so the limits hold for every point.
A min-jerk move of length ``D`` in time ``T`` peaks at ``v = 1.875 D / T`` and
``a = 5.7735 D / T^2``; ``T`` is the smallest value meeting both limits.

Phases: approach (fingers open), clamp (force ramps 0 -> F), hold, lift, translate,
lower (approach to the hole mouth at the travel limits, then the insertion at the insertion
speed), release (F -> 0), retreat (fingers open: the gripper stands still for ``open_s``,
then moves). See :mod:`asmplan.planner.trajectory`.

Clamp force
-----------
Per finger, ``F = safety_factor * m (g + a_max) / (2 mu)`` with ``mu = finger friction *
part friction`` (PyBullet multiplies the coefficients of the two bodies), raised to the
gripper's ``min_force_N``; above the gripper's ``max_force_N`` or the part's
``max_clamp_force_N`` the grip is infeasible (:class:`GripInfeasibleError`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..knowledge.model import Product
from .errors import GripInfeasibleError
from .trajectory import (
    PhaseSpan,
    Trajectory,
    matrix_from_quat_xyzw,
    min_jerk,
    quat_xyzw_from_matrix,
    rotation_angle_rad,
    slerp_xyzw,
)

G_M_S2 = 9.81
"""Standard gravity used for the clamp force, m/s^2."""

_MJ_PEAK_V = 1.875  # peak velocity of a min-jerk move of unit length and unit time
_MJ_PEAK_A = 5.773502691896258  # peak acceleration (10 / sqrt(3))


@dataclass(frozen=True)
class MotionLimits:
    """Velocity and acceleration limits of one part's transport, SI.

    ``max_speed_m_s`` and ``max_acceleration_m_s2`` bound every point of the carried body;
    ``insertion_speed_m_s`` bounds the speed while the pin is inside the hole.
    """

    max_speed_m_s: float
    max_acceleration_m_s2: float
    insertion_speed_m_s: float

    def __post_init__(self) -> None:
        for label in ("max_speed_m_s", "max_acceleration_m_s2", "insertion_speed_m_s"):
            v = getattr(self, label)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"MotionLimits.{label}: expected > 0, found {v}")


def motion_limits(product: Product, part: str) -> MotionLimits:
    """The part's limits: its own Handling values where given, else the product's Process."""
    h = product.part(part).handling
    p = product.process
    speed = h.max_speed_m_s if h.max_speed_m_s is not None else p.max_speed_m_s
    acc = h.max_acceleration_m_s2 if h.max_acceleration_m_s2 is not None else p.max_acceleration_m_s2
    return MotionLimits(float(speed), float(acc), float(min(p.insertion_speed_m_s, speed)))


@dataclass(frozen=True)
class ClampForce:
    """The commanded per-finger clamp force and how it was derived (SI).

    ``translational_N`` = m (g + a) / (2 mu) is the classic slip limit of a two-finger grip;
    ``required_N`` adds the moment of an off-centre grasp and the insertion resistance and
    multiplies by the safety factor (see :func:`clamp_force`).
    """

    commanded_N: float
    required_N: float
    mass_kg: float
    mu: float
    acceleration_m_s2: float
    safety_factor: float
    limit_N: float
    limit_source: str
    translational_N: float = math.nan
    lever_m: float = 0.0
    pad_width_m: float = 0.0
    resistance_N: float = 0.0

    @property
    def slip_limit_N(self) -> float:
        """The analytic slip limit m (g + a) / (2 mu) without the safety factor, N."""
        if math.isfinite(self.translational_N):
            return self.translational_N
        return self.mass_kg * (G_M_S2 + self.acceleration_m_s2) / (2.0 * self.mu)

    def as_dict(self) -> dict[str, float | str]:
        return {"commanded_N": self.commanded_N, "required_N": self.required_N,
                "mass_kg": self.mass_kg, "mu": self.mu,
                "acceleration_m_s2": self.acceleration_m_s2,
                "safety_factor": self.safety_factor, "limit_N": self.limit_N,
                "limit_source": self.limit_source, "translational_N": self.slip_limit_N,
                "lever_m": self.lever_m, "pad_width_m": self.pad_width_m,
                "resistance_N": self.resistance_N}


def clamp_force(product: Product, part: str, mass_kg: float,
                acceleration_m_s2: float | None = None, step: int | None = None, *,
                lever_m: float = 0.0, gravity_lever_m: float | None = None,
                pad_width_m: float | None = None, resistance_N: float | None = None) -> ClampForce:
    """Per-finger clamp force to carry ``part`` (mass ``mass_kg``) with the product's gripper.

    ``F = sf sqrt(F_t^2 + F_m^2)`` with ``F_t = (m (g + a) + R) / (2 mu)`` the force that
    keeps the part from sliding and ``F_m = 2 m (g d_g + a d) / (mu W)`` the force that keeps
    it from turning about the closing axis. ``sf`` is the safety factor,
    ``mu = finger_friction * part friction`` (PyBullet multiplies), ``a`` the part's
    acceleration limit unless given, ``d`` (``lever_m``) the distance of the centre of mass from
    the fingers' closing axis, ``d_g`` (``gravity_lever_m``, default ``d``) its horizontal part
    (gravity only makes a moment with that), ``W`` (``pad_width_m``, default the finger width)
    the length of the pad contact and ``R`` (``resistance_N``) the axial resistance the grip
    carries while inserting: by default the product's ``insertion_resistance_N`` (default 0);
    the planner adds a press fit's force when the gripper presses the part in
    (:mod:`asmplan.planner.press`). With a centred grasp and ``R = 0`` this is the classic
    ``sf m (g+a) / (2 mu)``.

    The moment term: a load f at lever d makes a moment f d about the closing axis; a line
    contact of length W under a normal force F resists at most mu F W / 4 per pad (uniform
    pressure). Force and moment share the same friction; their combination uses the
    ellipsoidal limit-surface approximation of a frictional contact (Goyal, Ruina and
    Papadopoulos 1991; Xydas and Kao 1999), ``(f / f_max)^2 + (m / m_max)^2 <= 1``. Raises
    :class:`GripInfeasibleError` when ``F`` exceeds the gripper's ``max_force_N`` or the part's
    ``max_clamp_force_N``.
    """
    if not (math.isfinite(mass_kg) and mass_kg > 0):
        raise ValueError(f"mass_kg: expected > 0, found {mass_kg}")
    p = product.part(part)
    gripper = product.gripper_for(part)
    a = motion_limits(product, part).max_acceleration_m_s2 if acceleration_m_s2 is None \
        else float(acceleration_m_s2)
    mu = float(gripper.finger_friction) * float(p.friction)
    sf = float(product.process.safety_factor)
    width = float(gripper.finger_size_m[0]) if pad_width_m is None else float(pad_width_m)
    resistance = float(product.process.insertion_resistance_N if resistance_N is None else resistance_N)
    limit, source = float(gripper.max_force_N), "gripper max_force"
    if p.handling.max_clamp_force_N is not None and p.handling.max_clamp_force_N < limit:
        limit, source = float(p.handling.max_clamp_force_N), "part max_clamp_force"
    if mu <= 0:
        raise GripInfeasibleError(part, math.inf, limit, source, mass_kg, mu, a, sf, step)
    translational = mass_kg * (G_M_S2 + a) / (2.0 * mu)
    d = max(float(lever_m), 0.0)
    d_g = d if gravity_lever_m is None else min(max(float(gravity_lever_m), 0.0), d)
    slide = (mass_kg * (G_M_S2 + a) + resistance) / (2.0 * mu)
    turn = 2.0 * mass_kg * (G_M_S2 * d_g + a * d) / (mu * width)
    required = sf * math.hypot(slide, turn)
    if required > limit:
        raise GripInfeasibleError(part, required, limit, source, mass_kg, mu, a, sf, step,
                                  lever_m=lever_m, pad_width_m=width, resistance_N=resistance)
    commanded = max(required, float(gripper.min_force_N))
    if commanded > limit:  # the gripper cannot squeeze gently enough for this part
        raise GripInfeasibleError(part, commanded, limit, source + " (below gripper min_force)",
                                  mass_kg, mu, a, sf, step)
    return ClampForce(commanded, required, mass_kg, mu, a, sf, limit, source, translational,
                      float(lever_m), width, resistance)


def held_clamp_force(product: Product, part: str, base: ClampForce, grasp: Any,
                     step: int | None = None, *, lever_m: float = 0.0,
                     gravity_lever_m: float | None = None) -> ClampForce:
    """The clamp force for a grasp whose hold was judged on its contact patches.

    ``grasp.hold_required_N`` is the force that carries the part's weight and inertia as force
    and as moment about the patches (:mod:`asmplan.planner.grasp_hold`, safety factor
    included); an insertion resistance ``R`` (``base.resistance_N``) adds to the load in
    proportion, ``F = F_hold (1 + R / (m (g + a)))`` (conservative: as if it also turned the
    part). It is never less than :func:`clamp_force` with the grasp's TCP lever
    (``lever_m``, ``gravity_lever_m``) over the whole finger width, the former model, unless
    that one exceeds the force limit: neither model counts the contact forces of the
    insertion itself (a ring's entry on its shaft's chamfer, 0.4-0.5 N at FAST on
    gear_unit's 13 g wheel, which slipped at the patch model's 0.37 N and held at the former
    0.56 N). ``lever_m`` and ``pad_width_m`` of the result are the grasp's (the distance of
    the centre of mass from the contact centre; the contact length of the same torsional
    capacity, ``4 rho``: a line contact of length ``L`` has ``rho = L / 4``). Raises
    :class:`GripInfeasibleError` when the hold needs more than the force limit."""
    slide = clamp_force(product, part, base.mass_kg, base.acceleration_m_s2, step,
                        resistance_N=base.resistance_N)
    load = base.mass_kg * (G_M_S2 + base.acceleration_m_s2)
    required = max(slide.required_N,
                   float(grasp.hold_required_N) * (1.0 + base.resistance_N / load))
    try:
        former = clamp_force(product, part, base.mass_kg, base.acceleration_m_s2, step,
                             lever_m=lever_m, gravity_lever_m=gravity_lever_m,
                             resistance_N=base.resistance_N).required_N
    except GripInfeasibleError:
        former = 0.0
    required = max(required, former)
    lever = float(grasp.lever_m or 0.0)
    width = 4.0 * float(grasp.torsion_radius_m)
    if required > slide.limit_N:
        raise GripInfeasibleError(part, required, slide.limit_N, slide.limit_source,
                                  base.mass_kg, slide.mu, slide.acceleration_m_s2,
                                  slide.safety_factor, step, lever_m=lever, pad_width_m=width,
                                  resistance_N=base.resistance_N)
    gripper = product.gripper_for(part)
    commanded = max(required, float(gripper.min_force_N))
    if commanded > slide.limit_N:
        raise GripInfeasibleError(part, commanded, slide.limit_N,
                                  slide.limit_source + " (below gripper min_force)",
                                  base.mass_kg, slide.mu, slide.acceleration_m_s2,
                                  slide.safety_factor, step)
    return replace(slide, commanded_N=commanded, required_N=required, lever_m=lever,
                   pad_width_m=width)


def min_jerk_duration_s(length_m: float, max_speed_m_s: float, max_acceleration_m_s2: float
                        ) -> float:
    """Shortest duration (s) of a rest-to-rest min-jerk move of ``length_m`` within limits."""
    if length_m <= 0.0:
        return 0.0
    return max(_MJ_PEAK_V * length_m / max_speed_m_s,
               math.sqrt(_MJ_PEAK_A * length_m / max_acceleration_m_s2))


def segment_length_m(T0: np.ndarray, T1: np.ndarray, radius_m: float) -> float:
    """Bound on the travel of any point within ``radius_m`` of the TCP, m."""
    dp = float(np.linalg.norm(T1[:3, 3] - T0[:3, 3]))
    dth = float(rotation_angle_rad(T0[:3, :3].T @ T1[:3, :3]))
    return dp + radius_m * dth


def interpolate_poses(T0: np.ndarray, T1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Poses (M, 4, 4) between ``T0`` and ``T1``: position lerp and rotation slerp at ``s``."""
    s = np.asarray(s, dtype=float)
    q = quat_xyzw_from_matrix(np.stack([T0[:3, :3], T1[:3, :3]]))
    out = np.zeros((s.shape[0], 4, 4))
    out[:, :3, :3] = matrix_from_quat_xyzw(slerp_xyzw(q[0], q[1], s))
    out[:, :3, 3] = T0[:3, 3] + s[:, None] * (T1[:3, 3] - T0[:3, 3])
    out[:, 3, 3] = 1.0
    return out


@dataclass(frozen=True, eq=False)
class Move:
    """A polyline of gripper poses (N >= 2, (N, 4, 4)) executed rest-to-rest per leg, with
    its own speed limit (m/s) for every point of the carried body."""

    poses: np.ndarray
    max_speed_m_s: float


@dataclass(frozen=True, eq=False)
class StepMotion:
    """The geometric content of one pick-and-insert step, in gripper TCP poses (4, 4).

    ``approach``: pre-grasp -> grasp (fingers open). ``lift``: grasp -> lifted.
    ``translate``: the planned path, lifted -> pre-insertion. ``lower``: one or more moves
    from the pre-insertion pose down to the seated pose. ``retreat``: seated -> clear.
    """

    approach: np.ndarray
    lift: np.ndarray
    translate: np.ndarray
    lower: tuple[Move, ...]
    retreat: np.ndarray


@dataclass(frozen=True)
class TimingSettings:
    """Dwell times (s) of the force phases and the sample spacing (s) of trajectories.

    ``open_s``: the retreat starts with the gripper standing still at the seated pose while
    the fingers open (a real cell waits for the gripper's "open" signal); moving at once drags
    a loosely fitted part out of its hole by the pads' friction.
    """

    clamp_s: float = 0.3
    hold_s: float = 0.2
    release_s: float = 0.3
    open_s: float = 0.2
    sample_dt_s: float = 0.01

    def __post_init__(self) -> None:
        for label in ("clamp_s", "hold_s", "release_s", "open_s", "sample_dt_s"):
            v = getattr(self, label)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"TimingSettings.{label}: expected > 0, found {v}")


def _polyline_samples(poses: np.ndarray, speed: float, acc: float, radius_m: float,
                      dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Times (from 0) and poses of a polyline executed rest-to-rest per leg."""
    times = [np.zeros(1)]
    out = [poses[:1]]
    t0 = 0.0
    for T0, T1 in itertools.pairwise(poses):
        length = segment_length_m(T0, T1, radius_m)
        if length <= 1e-12:
            continue
        dur = min_jerk_duration_s(length, speed, acc)
        n = max(2, math.ceil(dur / dt) + 1)
        tau = np.linspace(0.0, 1.0, n)[1:]
        out.append(interpolate_poses(T0, T1, min_jerk(tau)))
        times.append(t0 + tau * dur)
        t0 += dur
    return np.concatenate(times), np.concatenate(out)


def _dwell(T: np.ndarray, duration: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    n = max(2, math.ceil(duration / dt) + 1)
    tau = np.linspace(0.0, duration, n)
    return tau, np.repeat(T[None], n, axis=0)


def time_step(motion: StepMotion, limits: MotionLimits, force_N: float, radius_m: float,
              settings: TimingSettings = TimingSettings()) -> Trajectory:
    """The trajectory of one step through approach, clamp, hold, lift, translate, lower,
    release and retreat.

    Parameters
    ----------
    motion : StepMotion
        Gripper TCP poses of every segment (consecutive segments share their end poses).
    limits : MotionLimits
    force_N : float
        Commanded per-finger clamp force, N (0 in approach and retreat).
    radius_m : float
        Radius of the gripper plus held part around the TCP, m (bounds point speeds under
        rotation).
    settings : TimingSettings

    Returns
    -------
    Trajectory
        Sampled at ``settings.sample_dt_s`` or finer; phase boundaries are samples.
    """
    v, a, dt = limits.max_speed_m_s, limits.max_acceleration_m_s2, settings.sample_dt_s
    pieces: list[tuple[str, np.ndarray, np.ndarray, np.ndarray]] = []

    def add(name: str, tau: np.ndarray, poses: np.ndarray, force: np.ndarray) -> None:
        pieces.append((name, tau, poses, force))

    def moving(name: str, poses: np.ndarray, speed: float, f0: float, f1: float) -> None:
        tau, T = _polyline_samples(np.asarray(poses, float), speed, a, radius_m, dt)
        if tau[-1] <= 0.0:  # no motion: keep the phase with a minimal dwell
            tau, T = _dwell(T[0], dt, dt)
        add(name, tau, T, f0 + (f1 - f0) * tau / tau[-1])

    moving("approach", motion.approach, v, 0.0, 0.0)
    grasp_pose = motion.approach[-1]
    tau, T = _dwell(grasp_pose, settings.clamp_s, dt)
    add("clamp", tau, T, force_N * tau / tau[-1])
    tau, T = _dwell(grasp_pose, settings.hold_s, dt)
    add("hold", tau, T, np.full(tau.shape, force_N))
    moving("lift", motion.lift, v, force_N, force_N)
    moving("translate", motion.translate, v, force_N, force_N)
    lower_t: list[np.ndarray] = []
    lower_T: list[np.ndarray] = []
    t_off = 0.0
    for k, mv in enumerate(motion.lower):
        tau, T = _polyline_samples(np.asarray(mv.poses, float), min(mv.max_speed_m_s, v), a,
                                   radius_m, dt)
        if k > 0:
            tau, T = tau[1:], T[1:]
        lower_t.append(tau + t_off)
        lower_T.append(T)
        t_off = float(lower_t[-1][-1]) if lower_t[-1].size else t_off
    tl = np.concatenate(lower_t)
    if tl[-1] <= 0.0:
        tl, TL = _dwell(motion.lower[0].poses[0], dt, dt)
    else:
        TL = np.concatenate(lower_T)
    add("lower", tl, TL, np.full(tl.shape, force_N))
    seated = TL[-1]
    tau, T = _dwell(seated, settings.release_s, dt)
    add("release", tau, T, force_N * (1.0 - tau / tau[-1]))
    tau_open, T_open = _dwell(seated, settings.open_s, dt)
    tau, T = _polyline_samples(np.asarray(motion.retreat, float), v, a, radius_m, dt)
    tau = np.concatenate([tau_open, tau_open[-1] + tau[1:]])
    T = np.concatenate([T_open, T[1:]])
    add("retreat", tau, T, np.zeros(tau.shape))

    t_all: list[np.ndarray] = []
    T_all: list[np.ndarray] = []
    f_all: list[np.ndarray] = []
    spans: list[PhaseSpan] = []
    t0 = 0.0
    for k, (name, tau, T, f) in enumerate(pieces):
        if k > 0:  # the first sample of a phase is the previous phase's last one
            tau, T, f = tau[1:], T[1:], f[1:]
            # the boundary sample belongs to the later phase: give it the later force
            f_all[-1] = f_all[-1].copy()
            f_all[-1][-1] = pieces[k][3][0]
        t_all.append(t0 + tau)
        T_all.append(T)
        f_all.append(f)
        spans.append(PhaseSpan(name, t0, t0 + float(pieces[k][1][-1])))
        t0 += float(pieces[k][1][-1])
    return Trajectory(t_s=np.concatenate(t_all), T_world_gripper=np.concatenate(T_all),
                      clamp_force_N=np.concatenate(f_all), phases=tuple(spans))


def max_point_speed_m_s(traj: Trajectory, radius_m: float) -> np.ndarray:
    """Finite-difference bound on the speed of points within ``radius_m`` of the TCP, per
    interval (N-1,), m/s (for tests and reports)."""
    T = traj.T_world_gripper
    dt = np.diff(traj.t_s)
    dp = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)
    rel = np.einsum("nji,njk->nik", T[:-1, :3, :3], T[1:, :3, :3])
    return (dp + radius_m * rotation_angle_rad(rel)) / dt


def phase_durations_s(traj: Trajectory) -> dict[str, float]:
    """Duration (s) of each phase by name."""
    return {p.name: p.t_end_s - p.t_start_s for p in traj.phases}
