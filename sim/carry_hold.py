"""A carried part stuck to the gripper while its grip holds the load with a margin (issue 16,
"model only what the scene requires").

While a held part touches nothing but the gripper's pads, in the lift, the transfer and the
lowering down to its first contact with anything else, it moves with the fingers if the grip
holds its load. Bullet's pad contact does not deliver that: the gearbox shaft on prism
(V-groove) jaws turned 8-66 mrad in the pads over its transfer at a grip holding 3x its load,
with neither a monotonic trend in the clamp force nor convergence in the time step (one GJK
point per flank per step, normals drifting off the flank's; tests/sim/test_prism_transfer.py,
docs/physics.md "A carried part stuck to its pads").

:class:`CarryHold` sticks the part to the palm as soon as, in a held phase with the squeeze
fully applied, the part touches nothing but the two pads, its load uses at most ``fraction``
of the grip's analytic capacity and, on flat pads, it rests in them (:func:`settled`: between
two load checks it moved and turned relative to the TCP by less than Bullet's residual
creep; on grooved pads Bullet's flank contact never rests: the gearbox shaft rattles in its V
at 1-70 mrad/s through the pipeline's transfer, so it is stuck from the first check). Stuck,
at every load check the part is put back at its pose relative to the palm (as when it was
stuck) with the palm's rigid-body velocity; along the closing axis it keeps its own position
and velocity, so the two force-controlled pads keep balancing it and each still reads its
squeeze. Waiting for the rest matters: stuck at the first check of the lift, a part picked
from a support kept the pose the support's release had left it in for ~0.1 s (the fits
bench's pin 0.14 um off the jaws' centre line, turned 0.1 mrad, for the rest of the carry;
tests/sim/test_pick_creep.py). Why a reset and not a constraint (measured, docs/physics.md):
a fixed constraint to the palm split the two readings by 17 % on peg_in_hole; PyBullet's
prismatic multibody constraint drives a part at a general orientation along its free axis;
no PyBullet constraint leaves only the closing axis free; and holding only what the pads'
friction resists in flat pads (in-plane shift, turn about the closing axis) leaves the
shaft's tipping to Bullet's V contact, which turned it at up to 92 mrad/s. It checks:

* the part's contact points (Bullet's, within the contact distance, so before the touch; and
  the exact fit contact's) with anything but the pads: every physics step in "lower", every
  check before;
* every ``PEAK_SAMPLE_DT_S`` (:mod:`asmplan.sim.execute`): the load ratio
  (:meth:`asmplan.planner.grasp_capacity.GripCapacity.load_ratio`, the planner's hold
  criterion for one load) of the weight and the inertial load of the part moving rigidly with
  the commanded gripper pose (force ``m (g - a_com)`` at the centre of mass and moment
  ``-(I alpha + omega x I omega)``, from the commanded poses by central differences over
  ``LOAD_DIFF_S``) at the commanded clamp force.

The first contact with another body, the first check whose ratio exceeds ``fraction``, or the
end of the held phases (release) hands the part back to Bullet's pad contact, from its state
then, for the rest of the step.

The pipeline (:mod:`asmplan.sim.simulate`) uses it on grooved pads only, where Bullet's pad
contact is measured wrong. On flat pads Bullet's contact carries the part as a grip does (the
fits bench's pin, peg_in_hole: same verdicts and slips without it), and sticking it there
only moved chaotic hand-backs (measured, docs/physics.md): stuck at the first check of the
lift the pin kept the support's transient pose (tests/sim/test_pick_creep.py's control 0.14
um off against 0.05); stuck once at rest the gearbox's dowel_1 lost both pads' contact for
one record row at the hand-back ('dropped'; it succeeds stuck 24 ms earlier or not at all).
:meth:`CarryHold.summary` records whether and when the part
was stuck, when and why it was released and the largest load ratio.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..knowledge.frames import invert
from ..knowledge.model import Product
from ..parts.models import ProductGeometry
from ..planner.grasp import GraspSurface
from ..planner.grasp_capacity import GripCapacity, grasp_capacity
from ..planner.plan import Grasp
from ..planner.settings import PlannerSettings
from ..planner.trajectory import Trajectory
from .bullet import BulletWorld
from .feature_contact import HeldFitContact
from .gripper import FINGER_LINKS, Gripper

HELD_PHASES = ("lift", "translate", "lower")
"""Phases in which the part may be stuck to the fingers (from the lift off its support to
its first contact in the lowering)."""

LOAD_DIFF_S = 0.005
"""Time step of the central differences giving the part's acceleration from the commanded
poses, s (the planner's trajectories are sampled every 1 ms and interpolated linearly)."""


class PoseGrid:
    """A trajectory's commanded poses every ``step_s`` from its start (one vectorised
    evaluation), looked up at the nearest grid time: what :func:`carried_load` needs per check
    without interpolating the trajectory again (0.7 ms a check)."""

    def __init__(self, trajectory: Trajectory, step_s: float = 1e-3) -> None:
        self._t0 = float(trajectory.t_s[0])
        self._step = float(step_s)
        n = math.ceil(trajectory.duration_s / step_s) + 1
        self._T = trajectory.poses_at(self._t0 + self._step * np.arange(n))

    def index(self, t: np.ndarray) -> np.ndarray:
        """Indices (M,) of the grid times nearest to ``t`` (M,) s (clamped to the span)."""
        return np.clip(np.rint((np.asarray(t, float) - self._t0) / self._step).astype(int), 0,
                       len(self._T) - 1)

    def index_of(self, t_s: float) -> int:
        """:meth:`index` of one time."""
        return min(max(round((float(t_s) - self._t0) / self._step), 0), len(self._T) - 1)

    def poses_at(self, t: np.ndarray) -> np.ndarray:
        """Poses (M, 4, 4) at the grid times nearest to ``t`` (M,) s (clamped to the span)."""
        return self._T[self.index(t)]

    def loads(self, com_tcp_m: np.ndarray, mass_kg: float, inertia_tcp_kgm2: np.ndarray,
              gravity_mps2: np.ndarray, h_s: float = LOAD_DIFF_S
              ) -> tuple[np.ndarray, np.ndarray]:
        """:func:`carried_load` at every grid time at once: forces (N, 3) N and moments
        (N, 3) N m (the same poses and arithmetic, element by element)."""
        n = len(self._T)
        k = np.arange(n)
        d = round(h_s / self._step)
        i0, i2 = np.clip(k - d, 0, n - 1), np.clip(k + d, 0, n - 1)
        T0, T1, T2 = self._T[i0], self._T, self._T[i2]
        com = np.asarray(com_tcp_m, float)
        p0, p1, p2 = (T[:, :3, :3] @ com + T[:, :3, 3] for T in (T0, T1, T2))
        a = (p2 - 2.0 * p1 + p0) / (h_s * h_s)
        R0t = np.transpose(T1[:, :3, :3], (0, 2, 1))
        w_prev = _rotvecs(T1[:, :3, :3] @ np.transpose(T0[:, :3, :3], (0, 2, 1))) / h_s
        w_next = _rotvecs(T2[:, :3, :3] @ R0t) / h_s
        w = np.einsum("nij,nj->ni", R0t, 0.5 * (w_prev + w_next))
        alpha = np.einsum("nij,nj->ni", R0t, (w_next - w_prev) / h_s)
        inertia = np.asarray(inertia_tcp_kgm2, float)
        force = np.einsum("nij,nj->ni", R0t,
                          float(mass_kg) * (np.asarray(gravity_mps2, float) - a))
        moment = -(alpha @ inertia.T + np.cross(w, w @ inertia.T))
        return force, moment


def _rotvecs(R: np.ndarray) -> np.ndarray:
    """:func:`_rotvec` of rotation matrices (N, 3, 3) -> (N, 3)."""
    v = 0.5 * np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0],
                        R[:, 1, 0] - R[:, 0, 1]], axis=1)
    s = np.linalg.norm(v, axis=1)
    c = 0.5 * (np.trace(R, axis1=1, axis2=2) - 1.0)
    scale = np.where(s < 1e-12, 1.0, np.arctan2(s, c) / np.where(s < 1e-12, 1.0, s))
    return v * scale[:, None]


def _rotvec(R: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) of a rotation matrix of less than 90 deg (log map)."""
    v = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    s = float(np.linalg.norm(v))
    if s < 1e-12:
        return v
    return v * (math.atan2(s, 0.5 * (float(np.trace(R)) - 1.0)) / s)


SETTLE_SPEED_MPS = 0.2e-6
"""A part is stuck only once it rests in the pads: between two load checks the point of it at
the TCP moved in the pad plane (TCP x, z) at less than this speed, m/s ..."""

SETTLE_RATE_RADPS = 2e-5
"""... and it turned relative to the TCP at less than this rate, rad/s. The fits bench's 6 mm
pin, picked from its tray, leaves it at 3.9 um/s and 0.68 mrad/s in the pads (the pads' elastic
load from the tray's contact relaxing, time constant ~10 ms) and rests at 0.002-0.005 um/s and
0.0001-0.001 mrad/s from ~0.1 s later (flat pads; grooved pads do not wait)."""

MAX_SETTLE_GAP_S = 0.0045
"""Two checks further apart than this (not consecutive) do not measure a rest, s."""


def settled(T_tcp_part_before: np.ndarray, T_tcp_part: np.ndarray, dt_s: float) -> bool:
    """Whether a part moved from ``T_tcp_part_before`` to ``T_tcp_part`` (both (4, 4), the part
    in the TCP frame) in ``dt_s`` rests in the pads: the point of it at the TCP before moved
    in the pad plane (TCP x, z) at less than :data:`SETTLE_SPEED_MPS` and it turned at less
    than :data:`SETTLE_RATE_RADPS` (any axis)."""
    if not 0.0 < dt_s <= MAX_SETTLE_GAP_S:
        return False
    p = invert(T_tcp_part_before)[:3, 3]  # the TCP in the part frame before
    d = T_tcp_part[:3, :3] @ p + T_tcp_part[:3, 3]
    speed = math.hypot(float(d[0]), float(d[2])) / dt_s
    rate = float(np.linalg.norm(_rotvec(T_tcp_part_before[:3, :3].T @ T_tcp_part[:3, :3]))) / dt_s
    return speed < SETTLE_SPEED_MPS and rate < SETTLE_RATE_RADPS


def carried_load(trajectory: Trajectory | PoseGrid, t_s: float, com_tcp_m: np.ndarray, mass_kg: float,
                 inertia_tcp_kgm2: np.ndarray, gravity_mps2: np.ndarray,
                 h_s: float = LOAD_DIFF_S) -> tuple[np.ndarray, np.ndarray]:
    """The load on the grip of a part moving rigidly with the gripper along ``trajectory``.

    Parameters
    ----------
    trajectory : Trajectory or PoseGrid
        The commanded gripper poses.
    t_s : float
        Time, s.
    com_tcp_m : (3,) float array
        The part's centre of mass in the TCP frame, m.
    mass_kg : float
    inertia_tcp_kgm2 : (3, 3) float array
        The part's inertia tensor about its centre of mass, TCP-frame axes, kg m^2.
    gravity_mps2 : (3,) float array
        World gravity.
    h_s : float
        Central-difference step, s.

    Returns
    -------
    (force (3,), moment (3,))
        What the grip must resist, TCP frame at ``t_s``: ``m (g - a)`` at the centre of mass
        (N) and ``-(I alpha + omega x I omega)`` about it (N m).
    """
    T = trajectory.poses_at(np.array([t_s - h_s, t_s, t_s + h_s]))
    p = T[:, :3, :3] @ np.asarray(com_tcp_m, float) + T[:, :3, 3]
    a = (p[2] - 2.0 * p[1] + p[0]) / (h_s * h_s)
    R0 = T[1, :3, :3]
    w_prev = _rotvec(T[1, :3, :3] @ T[0, :3, :3].T) / h_s
    w_next = _rotvec(T[2, :3, :3] @ T[1, :3, :3].T) / h_s
    w = R0.T @ (0.5 * (w_prev + w_next))
    alpha = R0.T @ ((w_next - w_prev) / h_s)
    inertia = np.asarray(inertia_tcp_kgm2, float)
    force = R0.T @ (float(mass_kg) * (np.asarray(gravity_mps2, float) - a))
    moment = -(inertia @ alpha + np.cross(w, inertia @ w))
    return force, moment


class CarryHold:
    """Sticks a carried part to the palm while its grip holds the load (module docstring).

    Parameters
    ----------
    world : BulletWorld
    gripper : Gripper
    part_body : int
    trajectory : Trajectory
        The step's gripper trajectory (commanded poses and clamp force).
    capacity : GripCapacity or None
        The grasp's capacity; None: never stuck (``unavailable`` says why).
    fraction : float
        Share of the capacity the load may use while stuck, in (0, 1].
    fit_contact : HeldFitContact, optional
        The exact fit contact: its contact points count as contact with another body.
    unavailable : str
        Why there is no capacity (recorded).
    """

    def __init__(self, world: BulletWorld, gripper: Gripper, part_body: int,
                 trajectory: Trajectory, capacity: GripCapacity | None, fraction: float,
                 fit_contact: HeldFitContact | None = None, unavailable: str = "") -> None:
        if not 0.0 < fraction <= 1.0:
            raise ValueError(f"CarryHold: fraction expected in (0, 1], found {fraction}")
        self._world = world
        self._gripper = gripper
        self._part = part_body
        self._traj = PoseGrid(trajectory)
        self._cap = capacity
        self._fraction = float(fraction)
        self._fit = fit_contact
        self._T_tcp_part: np.ndarray | None = None  # the part in the TCP frame while stuck
        self._com_tcp: np.ndarray | None = None
        self._previous: tuple[float, np.ndarray] | None = None  # the last unstuck check
        self._table: tuple[np.ndarray, np.ndarray] | None = None  # ratio x clamp, tipping
        self._inertia_tcp: np.ndarray | None = None
        self.stuck_from_s: float | None = None
        self.released_s: float | None = None
        self.release = "" if capacity is not None else (unavailable or "no grip capacity")
        self.max_ratio = 0.0
        self.max_ratio_s: float | None = None
        self.mechanism = ""
        self.checks = 0
        self._done = capacity is None
        # flat pads: stuck once the part rests in them; grooved pads: from the first check
        # (Bullet's V-flank contact does not come to rest: one GJK point per flank)
        self._wait_for_rest = gripper.spec.pad_groove_depth_m <= 0.0
        mass, T_link_inertial, inertia_link = world.rigid_properties(part_body)
        self._mass = mass
        self._T_link_inertial = T_link_inertial
        self._inertia_link = inertia_link

    @property
    def stuck(self) -> bool:
        """Whether the part is stuck to the palm now."""
        return self._T_tcp_part is not None

    def _touching_other(self) -> str | None:
        """Name of a body the part touches other than the pads (None if none)."""
        other = self._world.touching_other(self._part, self._gripper.body, FINGER_LINKS)
        if other is not None:
            return self._world.body_name(other)
        if self._fit is not None and self._fit.active and self._fit.contacts().count:
            return "its mate (exact fit contact)"
        return None

    def _ratio(self, t_s: float, clamp_N: float) -> float:
        assert self._cap is not None and self._com_tcp is not None
        assert self._inertia_tcp is not None
        if self._table is not None and clamp_N > 0.0:  # stuck: the load is the table's
            i = self._traj.index_of(t_s)
            ratio = float(self._table[0][i]) / float(clamp_N)
            mech = "tipping" if self._table[1][i] else "friction"
        else:
            f, m = carried_load(self._traj, t_s, self._com_tcp, self._mass, self._inertia_tcp,
                                self._world.gravity_mps2)
            ratio, mech = self._cap.load_ratio(f, m, clamp_N)
        self.checks += 1
        if ratio > self.max_ratio:
            self.max_ratio, self.max_ratio_s, self.mechanism = ratio, t_s, mech
        return ratio

    def _let_go(self, t_s: float, why: str) -> None:
        self._T_tcp_part = None
        self.released_s, self.release, self._done = t_s, why, True

    def _carry(self) -> None:
        """Put the part back where it was in the pad plane relative to the palm, turned as it
        was, with the palm's rigid velocity; along the closing axis it keeps its position and
        velocity relative to the palm (the pads' squeeze balances it there)."""
        assert self._T_tcp_part is not None
        w, g = self._world, self._gripper
        T_tcp = g.tcp_pose()
        T_rel = self._T_tcp_part.copy()
        T_rel[1, 3] = float((invert(T_tcp) @ w.pose(self._part))[1, 3])
        T_new = T_tcp @ T_rel
        v_part = w.velocity(self._part)[0]  # before set_pose (PyBullet's reset zeroes it)
        w.set_pose(self._part, T_new)
        if self._fit is not None and self._fit.active:  # its pre-step pose for the next step
            self._fit.held_pose_changed(T_new)
        v_palm, w_palm = w.velocity(g.body)
        r = w.com_position_m(self._part) - w.com_position_m(g.body)
        v_rigid = v_palm + np.array([w_palm[1] * r[2] - w_palm[2] * r[1],
                                     w_palm[2] * r[0] - w_palm[0] * r[2],
                                     w_palm[0] * r[1] - w_palm[1] * r[0]])
        y = T_tcp[:3, 1]
        w.set_velocity(self._part, (v_rigid + y * float((v_part - v_rigid) @ y)).tolist(),
                       w_palm.tolist())

    def after_step(self, t_s: float, phase: str, clamp_N: float, sample: bool) -> None:
        """Called after every physics step: ``phase`` the trajectory's phase, ``clamp_N`` the
        commanded squeeze, ``sample`` whether the load is checked at this step."""
        if self._done:
            return
        held = phase in HELD_PHASES
        if self._T_tcp_part is None:
            if not (held and sample and self._gripper.squeeze_settled):
                return
            other = self._touching_other()
            if other is not None:
                if phase == "lower":  # set down before it was ever stuck
                    self._done, self.release = True, f"contact with {other} before stuck"
                return
            if not all(self._world.contacts(self._part, self._gripper.body, link_b=k).count
                       for k in FINGER_LINKS):
                return
            T_tcp_part = invert(self._gripper.tcp_pose()) @ self._world.pose(self._part)
            R = T_tcp_part[:3, :3] @ self._T_link_inertial[:3, :3]
            self._com_tcp = (T_tcp_part @ self._T_link_inertial)[:3, 3]
            self._inertia_tcp = R @ self._inertia_link @ R.T
            ratio = self._ratio(t_s, clamp_N)
            if ratio > self._fraction:
                self._let_go(t_s, f"load ratio {ratio:.2f} > {self._fraction:.2f} at the first "
                                  f"check ({self.mechanism})")
                return
            previous, self._previous = self._previous, (t_s, T_tcp_part)
            if self._wait_for_rest and (
                    previous is None or not settled(previous[1], T_tcp_part, t_s - previous[0])):
                return  # still moving in the pads (e.g. the support's release): Bullet's
            self._T_tcp_part = T_tcp_part
            self.stuck_from_s = t_s
            # stuck, the part's centre of mass and inertia in the TCP frame stay as they are
            # now: its load at every grid time in one go (a check then costs a look-up)
            assert self._cap is not None
            self._table = self._cap.ratios_per_N(*self._traj.loads(
                self._com_tcp, self._mass, self._inertia_tcp, self._world.gravity_mps2))
            return
        if not held:
            self._let_go(t_s, f"end of the held phases ({phase})")
            return
        if not (sample or phase == "lower"):
            return
        other = self._touching_other()
        if other is not None:
            self._let_go(t_s, f"contact with {other}")
            return
        if sample:
            self._carry()
            ratio = self._ratio(t_s, clamp_N)
            if ratio > self._fraction:
                self._let_go(t_s, f"load ratio {ratio:.2f} > {self._fraction:.2f} "
                                  f"({self.mechanism})")

    def summary(self) -> dict[str, Any]:
        """Whether the part was stuck, from when, when and why it was released, the largest
        load ratio (and when, by which mechanism) over the checks."""
        return {"stuck": self.stuck_from_s is not None, "stuck_from_s": self.stuck_from_s,
                "released_s": self.released_s, "release": self.release,
                "fraction": self._fraction, "checks": self.checks,
                "max_load_ratio": float(self.max_ratio) if math.isfinite(self.max_ratio)
                else None,
                "max_load_ratio_s": self.max_ratio_s, "mechanism": self.mechanism}


def grip_capacity(product: Product, geometry: ProductGeometry, part: str, grasp: Grasp,
                  settings: PlannerSettings | None = None) -> tuple[GripCapacity | None, str]:
    """The planned ``grasp``'s capacity (:func:`asmplan.planner.grasp_capacity.grasp_capacity`)
    on the part's grasp surface sampled as the planner samples it (``settings``: the plan's
    planner settings, default :class:`PlannerSettings`), and '' or why there is none."""
    s = settings or PlannerSettings()
    k = next(i for i, p in enumerate(product.parts) if p.name == part)
    spec = product.part(part)
    mp = geometry.mass_properties(part)
    surface = GraspSurface.from_mesh(geometry.mesh(part), mp.com_m, s.surface_samples,
                                     s.seed + 7919 * k, spec.geometry.kind)
    cap = grasp_capacity(surface, grasp, product.gripper_for(part), spec.friction)
    return cap, ("" if cap is not None else "the planned pads' contact patches were not found "
                 "on the part's surface samples")
