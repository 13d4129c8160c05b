"""The cell's arm: kinematics (pinocchio), reach, joint limits, singularities, arm collisions
and joint-limited timing of every step. The ONLY module of asmplan that imports pinocchio.

Kinematics
----------
The URDF named by ``resources.robot`` is loaded with pinocchio (``pin``, see the README's
dependency table for why). Forward kinematics gives the flange; the gripper's TCP is
``T_world_base @ T_base_flange(q) @ T_flange_tcp``. Inverse kinematics is damped least
squares on the SE(3) log error (pinocchio's ``log6`` and ``Jlog6``), converging to
:attr:`ArmSettings.ik_tolerance_m` in position and 1e-6 rad in orientation:

* **all branches** (:meth:`ArmModel.ik_all`): the solver is started from a fixed set of seeds
  that span the shoulder (facing the target or turned away), the elbow (up/down) and the wrist
  (flipped or not) plus seeded random configurations; converged solutions are deduplicated
  (joint angles compared modulo 2 pi) and each is labelled by its shoulder/elbow/wrist signs.
  A 6-axis arm without a closed form has at most 16 branches; the seeds find the ones the
  limits allow in practice (tests check FK(IK(T)) = T and the branch count of the xArm 6).
* **along a path** (:meth:`ArmModel.track`): from one branch at the path's first pose, every
  next pose is solved from the previous solutions (continuity): started from their linear
  extrapolation and solved by Newton's chord method with a recent pose's Jacobian inverse
  (refreshed every 8 poses; a fresh damped step where that converges slowly). A solution that moves any
  joint more than :attr:`ArmSettings.max_joint_jump_rad` between two samples 10 ms apart is
  a branch change or a singularity: the branch fails there.

Margins: the joint-limit margin (smallest distance of a joint to its limit, rad, and which
joint) and Yoshikawa's manipulability ``sqrt(det(J J^T))`` of the 6x6 Jacobian, reported as a
fraction of the arm's best (measured over 2000 seeded configurations). A path whose
manipulability falls below :attr:`ArmSettings.min_manipulability_ratio` passes too close to
a singularity and fails.

Collisions
----------
The links' collision models (:mod:`asmplan.parts.arm_links`) join the planner's FCL scene as
bodies ``arm:<link>``. Every state of the step's joint path (the IK solutions at the
trajectory's samples, linear in joint space between them) is checked against the table, every
part at its current pose (the moving part at its start pose until the clamp, at its seated
pose from the release on), the mounted gripper and the carried part (every link, the two
wrist links included) and the other links (pairs that are not neighbours and not in contact at every
one of 200 seeded configurations, the usual "allowed collision" rule). The check is
conservative advancement in joint space (:meth:`ArmPlanner._advance`): at a state whose bodies
are ``d`` apart, the next state checked is where a bound of the travel of any point of the
bodies (relative to each other: only the joints between them count) reaches ``d`` (``d``
floored at :attr:`ArmSettings.check_step_m`; closer than that, the states are checked for
contact at that step). Two bounds are used and the farther state taken (both hold):

* along the current linear leg ``q + s dq``: the speed at ``s = 0`` of the body's bounding
  sphere (centre velocity plus angular velocity times radius, from pinocchio's joint
  Jacobian) ``A``, and a configuration-free bound ``B`` of the acceleration of any point,
  ``sum_j |dq_j| (2 R_j sum_{i<j} |dq_i| + sum_{i>=j} |dq_i| R_i)`` (``R_j`` bounds the
  distance of the body's points from joint ``j``, the triangle inequality over the joint
  offsets): the travel is at most ``A s + B s^2 / 2``;
* across legs (dense paths): ``sum_j C_j (r_j + sum_{i>j} R_i C_i)`` with ``C_j`` the joints'
  path lengths from the state and ``r_j`` the sphere's distance from joint ``j``'s axis at
  the state.

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

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..knowledge.frames import invert
from ..knowledge.model import Robot
from ..parts.arm_links import link_models
from ..parts.cell import HALF_TURN
from ..parts.pieces import CollisionModel
from .errors import (
    ArmCollisionError,
    ArmPathError,
    CollidingPair,
    JointLimitError,
    OutOfReachError,
)
from .plan import ArmMotion, ArmSettings
from .timing import min_jerk_duration_s
from .trajectory import PhaseSpan, Trajectory

ARM_PREFIX = "arm:"
TURN = HALF_TURN  # a parallel gripper's other way of holding the same grasp
CARRIED = "@carried"
_ENOUGH_M = 0.02  # exact distances only between bodies whose boxes come closer than this
_STRIDE = 16  # the cross-leg travel bound: every 16th sample first, then the ones between
_TWO_PI = 2.0 * math.pi


def _wrap(a: np.ndarray) -> np.ndarray:
    return (np.asarray(a) + math.pi) % _TWO_PI - math.pi


@dataclass(frozen=True)
class IkSolution:
    """One inverse-kinematics solution: joint angles (rad, within the limits), its branch
    label, manipulability and joint-limit margin (rad) with the joint that has it."""

    q_rad: np.ndarray
    branch: str
    manipulability: float
    limit_margin_rad: float
    limit_joint: str


@dataclass(frozen=True)
class IkFailure:
    """Why a pose has no usable IK solution: ``kind`` "reach" (no solution converged; the
    flange is ``distance_m`` from the shoulder) or "limit" (solutions exist, each needs a
    joint beyond its limits: the least violating one is given)."""

    kind: str
    distance_m: float
    joint: str = ""
    value_rad: float = 0.0
    lower_rad: float = 0.0
    upper_rad: float = 0.0


class ArmModel:
    """Kinematics of the cell's arm (pinocchio model of the URDF, base pose, mounting).

    Parameters
    ----------
    robot : Robot
        From the product's resources (URDF path, base, mounting, joint limits).
    settings : ArmSettings
    """

    def __init__(self, robot: Robot, settings: ArmSettings) -> None:
        if robot.urdf_path is None:
            raise ValueError("robot: expected a URDF path, found none")
        self.robot = robot
        self.settings = settings
        self.model = pin.buildModelFromUrdf(str(robot.urdf_path))
        self.data = self.model.createData()
        names = [self.model.names[i] for i in range(1, self.model.njoints)]
        order = [j.name for j in robot.joints]
        if names != order or self.model.nq != len(order):
            raise ValueError(f"robot: expected pinocchio's joints {names} to match the URDF chain "
                             f"{order}")
        self.joint_names = tuple(order)
        self.lower = np.array([j.lower_rad for j in robot.joints])
        self.upper = np.array([j.upper_rad for j in robot.joints])
        self.vmax = np.array([j.velocity_rad_s for j in robot.joints])
        self.amax = np.array([j.acceleration_rad_s2 for j in robot.joints])
        self.flange_id = self.model.getFrameId(robot.flange_link)
        self._frame_ids: dict[tuple[str, ...], list[int]] = {}
        self.T_world_base = np.asarray(robot.T_world_base, float)
        self.T_base_world = invert(self.T_world_base)
        self.T_flange_tcp = np.asarray(robot.T_flange_tcp, float)
        self.T_tcp_flange = invert(self.T_flange_tcp)
        self.joint_ids = list(range(1, self.model.njoints))
        q0 = np.zeros(6)
        pin.forwardKinematics(self.model, self.data, q0)
        # the shoulder: where joint 2's axis meets the plane of joint 1's axis (base frame)
        self.shoulder_base = self.data.oMi[2].translation.copy()
        facts = _arm_facts(str(robot.urdf_path), robot.flange_link, tuple(self.lower),
                           tuple(self.upper))
        self.best_manipulability = facts[0]
        self.measured_reach_m = facts[1]
        self.elbow_ref, self.wrist_ref = facts[2], facts[3]
        self.reach_m = robot.reach_m if robot.reach_m is not None else self.measured_reach_m

    # -- forward kinematics -----------------------------------------------------------------
    def fk(self, q: np.ndarray) -> np.ndarray:
        """TCP pose (4, 4) in the world for joint angles ``q`` (6,), rad."""
        pin.framesForwardKinematics(self.model, self.data, np.asarray(q, float))
        return self.T_world_base @ self.data.oMf[self.flange_id].homogeneous @ self.T_flange_tcp

    def link_poses(self, q: np.ndarray, links: Sequence[str]) -> list[np.ndarray]:
        """World poses (4, 4) of the named links at ``q``."""
        pin.framesForwardKinematics(self.model, self.data, np.asarray(q, float))
        ids = self._frame_ids.get(tuple(links))
        if ids is None:
            ids = self._frame_ids[tuple(links)] = [self.model.getFrameId(n) for n in links]
        return [self.T_world_base @ self.data.oMf[i].homogeneous for i in ids]

    def flange_distance_m(self, T_world_tcp: np.ndarray) -> float:
        """Distance from the shoulder to the flange that puts the TCP at ``T_world_tcp``, m."""
        p = (self.T_base_world @ T_world_tcp @ self.T_tcp_flange)[:3, 3]
        return float(np.linalg.norm(p - self.shoulder_base))

    def manipulability(self, q: np.ndarray) -> float:
        """Yoshikawa's ``sqrt(det(J J^T))`` of the flange Jacobian at ``q``."""
        J = pin.computeFrameJacobian(self.model, self.data, np.asarray(q, float), self.flange_id,
                                     pin.LOCAL_WORLD_ALIGNED)
        return float(abs(np.linalg.det(J)))

    def limit_margin(self, q: np.ndarray) -> tuple[float, int]:
        """Smallest distance of a joint to its limits (rad, negative beyond) and the joint."""
        m = np.minimum(q - self.lower, self.upper - q)
        i = int(np.argmin(m))
        return float(m[i]), i

    def branch_label(self, q: np.ndarray, T_world_tcp: np.ndarray) -> str:
        """Shoulder (front/back: the wrist on the side joint 1 faces or behind), elbow (up/down
        of the stretched arm) and wrist (flip) signs of a configuration."""
        p = (self.T_base_world @ T_world_tcp @ self.T_tcp_flange)[:3, 3]
        facing = math.cos(q[0] - math.atan2(p[1], p[0])) if np.hypot(p[0], p[1]) > 1e-9 else 1
        shoulder = "front" if facing >= 0 else "back"
        elbow = "up" if math.sin(q[2] - self.elbow_ref) >= 0 else "down"
        wrist = "noflip" if math.sin(q[4] - self.wrist_ref) >= 0 else "flip"
        return f"{shoulder}/{elbow}/{wrist}"

    # -- inverse kinematics -----------------------------------------------------------------
    def _target(self, T_world_tcp: np.ndarray) -> pin.SE3:
        T = self.T_base_world @ T_world_tcp @ self.T_tcp_flange
        return pin.SE3(T[:3, :3].copy(), T[:3, 3].copy())

    def solve(self, T_world_tcp: np.ndarray, q_seed: np.ndarray, max_iter: int = 60
              ) -> tuple[np.ndarray, bool]:
        """Damped least squares from ``q_seed``; returns (q, converged). ``q`` is not wrapped
        into the limits (continuity from the seed)."""
        return self._solve(self._target(T_world_tcp), np.array(q_seed, float), max_iter)

    def _solve(self, target: pin.SE3, q: np.ndarray, max_iter: int) -> tuple[np.ndarray, bool]:
        model, data, fid = self.model, self.data, self.flange_id
        frame = model.frames[fid]
        parent, placement, oMi = frame.parentJoint, frame.placement, data.oMi
        tol_p2 = self.settings.ik_tolerance_m ** 2
        tol_r2 = self.settings.ik_tolerance_rad ** 2
        lam_I = 1e-6 * np.eye(6)
        for it in range(max_iter):
            pin.forwardKinematics(model, data, q)
            M = (oMi[parent] * placement).actInv(target)
            err = pin.log6(M).vector
            ep = err[0] * err[0] + err[1] * err[1] + err[2] * err[2]
            er = err[3] * err[3] + err[4] * err[4] + err[5] * err[5]
            if ep < tol_p2 and er < tol_r2:
                return q, True
            if it == 20 and ep + er > 1e-4:  # not converging from this seed
                return q, False
            J = pin.Jlog6(M) @ pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL)
            dq = J.T @ np.linalg.solve(J @ J.T + lam_I, err)
            n2 = float(dq @ dq)
            if n2 > 0.25:  # trust region: big steps cross branches
                dq *= 0.5 / math.sqrt(n2)
            q = q + dq
        return q, False

    def track(self, T_world_tcp: np.ndarray, q0: np.ndarray, max_iter: int = 30
              ) -> tuple[np.ndarray, int, np.ndarray, np.ndarray]:
        """IK along a densely sampled path ``T_world_tcp`` (N, 4, 4) from ``q0`` (a solution
        at the first pose), each pose solved from the previous solution.

        Each pose starts from the previous two solutions extrapolated (the samples are
        evenly timed) and is solved by Newton's chord method: the inverse of the flange
        Jacobian at a recent solution (refreshed every 8 poses and after a slow one; a
        damped least-squares step instead when an iteration does not cut the error a
        hundredfold). Converged to the same tolerance as :meth:`solve`.

        Returns
        -------
        Q : (N, 6) float array
            The solutions (rows from ``n_ok`` on are undefined).
        n_ok : int
            The first pose that did not converge (N when all did).
        manipulability : (N,) float array
            Yoshikawa's ``|det J|`` at each solution.
        tcp_error_m : (N,) float array
            Distance of FK's TCP from the pose's, m.
        """
        model, data, fid = self.model, self.data, self.flange_id
        frame = model.frames[fid]
        parent, placement = frame.parentJoint, frame.placement
        tol_p2 = self.settings.ik_tolerance_m ** 2
        tol_r2 = self.settings.ik_tolerance_rad ** 2
        T_world_tcp = np.asarray(T_world_tcp, float)
        n = len(T_world_tcp)
        same = np.zeros(n, bool)  # a repeated pose (the gripper closing or opening)
        same[1:] = (T_world_tcp[1:] == T_world_tcp[:-1]).all(axis=(1, 2))
        Tb = self.T_base_world @ T_world_tcp @ self.T_tcp_flange
        Q = np.empty((n, 6))
        Js = np.empty((n, 6, 6))
        Ms = np.empty((n, 4, 4))
        q = np.array(q0, float)
        q_prev: np.ndarray | None = None
        Jinv: np.ndarray | None = None
        age = 0
        lam_I = 1e-6 * np.eye(6)
        fk, log6, jac, local, oMi = (pin.forwardKinematics, pin.log6, pin.computeFrameJacobian,
                                     pin.LOCAL, data.oMi)
        for k in range(n):
            if same[k]:
                Q[k], Js[k], Ms[k] = Q[k - 1], Js[k - 1], Ms[k - 1]
                continue
            target = pin.SE3(Tb[k])
            x = q if q_prev is None else 2.0 * q - q_prev
            last = math.inf
            ok = False
            for it in range(max_iter):
                fk(model, data, x)
                M = (oMi[parent] * placement).actInv(target)
                err = log6(M).vector
                ep = err[0] * err[0] + err[1] * err[1] + err[2] * err[2]
                er = err[3] * err[3] + err[4] * err[4] + err[5] * err[5]
                if ep < tol_p2 and er < tol_r2:
                    ok = True
                    break
                size = ep + er
                if it == 20 and size > 1e-4:
                    break
                if Jinv is None or size > 1e-2 * last:  # slow: a fresh damped Newton step
                    J = pin.Jlog6(M) @ jac(model, data, x, fid, local)
                    dq = J.T @ np.linalg.solve(J @ J.T + lam_I, err)
                    Jinv = None
                else:
                    dq = Jinv @ err
                step = float(dq @ dq)
                if step > 0.25:  # trust region: big steps cross branches
                    dq *= 0.5 / math.sqrt(step)
                x = x + dq
                last = size
            if not ok:
                return Q, k, np.abs(np.linalg.det(Js[:k])) if k else np.zeros(0), \
                    self._tcp_errors(Ms[:k])
            J = jac(model, data, x, fid, local)
            Js[k] = J
            Ms[k] = M.homogeneous
            # the chord's Jacobian: refreshed every 8 poses, or when this one was slow
            age += 1
            if Jinv is None or age >= 8 or it > 1:
                try:
                    Jinv = np.linalg.inv(J)
                except np.linalg.LinAlgError:
                    Jinv = None
                age = 0
            q_prev, q = q, x
            Q[k] = x
        return Q, n, np.abs(np.linalg.det(Js)), self._tcp_errors(Ms)

    def _tcp_errors(self, Ms: np.ndarray) -> np.ndarray:
        """TCP position errors (K,), m, of residual flange transforms ``Ms`` (K, 4, 4)
        (``M = oMf^-1 target``: the TCP is off by ``|R_M t + p_M - t|``, ``t`` the
        flange-to-TCP offset)."""
        t = self.T_flange_tcp[:3, 3]
        return np.linalg.norm(Ms[:, :3, :3] @ t + Ms[:, :3, 3] - t, axis=1)

    def _in_limits(self, q: np.ndarray) -> np.ndarray | None:
        """The representation ``q + 2 pi k`` within the limits nearest to zero, or None."""
        out = np.empty(6)
        for i, (v, lo, hi) in enumerate(zip(q, self.lower, self.upper, strict=True)):
            cands = [v + _TWO_PI * k for k in range(-2, 3) if lo <= v + _TWO_PI * k <= hi]
            if not cands:
                return None
            out[i] = min(cands, key=abs)
        return out

    def seeds(self, T_world_tcp: np.ndarray) -> list[np.ndarray]:
        """Seeds spanning the branches: shoulder facing/away x elbow up/down x wrist flip,
        then seeded random configurations within the limits (wide joints within +-pi)."""
        p = (self.T_base_world @ T_world_tcp @ self.T_tcp_flange)[:3, 3]
        phi = math.atan2(p[1], p[0])
        lo = np.maximum(self.lower, -math.pi)
        hi = np.minimum(self.upper, math.pi)
        mid = 0.5 * (lo + hi)
        out = []
        for sh, el, wr in itertools.product((0.0, math.pi), (-0.6, 0.6), (-1.0, 1.0)):
            q = mid.copy()
            q[0] = float(_wrap(np.asarray(phi + sh)))
            q[1] = mid[1] + (0.4 if sh == 0 else -0.4)
            q[2] = self.elbow_ref + el
            q[4] = self.wrist_ref + wr
            out.append(np.clip(q, lo, hi))
        rng = np.random.default_rng(self.settings.seed)
        extra = max(0, self.settings.ik_seeds - len(out))
        out += list(rng.uniform(lo, hi, size=(extra, 6)))
        return out

    def ik_any(self, T_world_tcp: np.ndarray, near: np.ndarray | None = None
               ) -> np.ndarray | None:
        """One solution within the limits (from ``near`` first, then the branch seeds), or
        None; cheap when the pose is reachable (a feasibility test)."""
        target = self._target(T_world_tcp)
        seeds = ([] if near is None else [np.asarray(near, float)]) + self.seeds(T_world_tcp)
        for seed in seeds:
            q, ok = self._solve(target, seed, 60)
            if ok:
                qi = self._in_limits(q)
                if qi is not None:
                    return qi
        return None

    def ik_all(self, T_world_tcp: np.ndarray) -> tuple[list[IkSolution], IkFailure | None]:
        """Every branch found for ``T_world_tcp`` within the limits (sorted by label), and
        when none is usable, why (:class:`IkFailure`)."""
        target = self._target(T_world_tcp)
        found: list[np.ndarray] = []
        outside: list[np.ndarray] = []
        seeds = self.seeds(T_world_tcp)
        k = 0
        while k < len(seeds):
            q, ok = self._solve(target, seeds[k], 60)
            k += 1
            if not ok:
                continue
            if any(np.abs(_wrap(q - f)).max() < 1e-3 for f in found + outside):
                continue
            qi = self._in_limits(q)
            if qi is None:
                outside.append(q)
            else:
                found.append(qi)
            # the wrist flip of a solution is (nearly, with wrist offsets) another one
            flip = q.copy()
            flip[3] += math.pi
            flip[4] = 2 * self.wrist_ref - flip[4]
            flip[5] += math.pi
            seeds.append(flip)
        sols = []
        for q in found:
            m, i = self.limit_margin(q)
            sols.append(IkSolution(q, self.branch_label(q, T_world_tcp), self.manipulability(q),
                                   m, self.joint_names[i]))
        sols.sort(key=lambda s: (s.branch, tuple(np.round(s.q_rad, 6))))
        if sols:
            return sols, None
        dist = self.flange_distance_m(T_world_tcp)
        if not outside:
            return [], IkFailure("reach", dist)
        # per solution and joint: by how much the nearest representation is beyond the limits
        over = np.zeros((len(outside), 6))
        value = np.zeros((len(outside), 6))
        for n, q in enumerate(outside):
            for i in range(6):
                reps = [float(q[i]) + _TWO_PI * k for k in range(-2, 3)]
                o, r = min((max(self.lower[i] - r, r - self.upper[i]), r) for r in reps)
                over[n, i], value[n, i] = o, r
        # name the joint every branch violates (the smallest violation among those); else the
        # smallest violation of any branch
        common = [i for i in range(6) if np.all(over[:, i] > 0)]
        pool = [(float(over[n, i]), n, i) for n in range(len(outside))
                for i in (common or range(6)) if over[n, i] > 0]
        _, n, i = min(pool)
        v = float(value[n, i])
        return [], IkFailure("limit", dist, self.joint_names[i], v, float(self.lower[i]),
                             float(self.upper[i]))


@cache
def _arm_facts(urdf: str, flange: str, lower: tuple[float, ...], upper: tuple[float, ...]
               ) -> tuple[float, float, float, float]:
    """Measured once per arm: best manipulability and reach (2000 seeded configurations
    within the limits), the elbow angle of the stretched arm and the wrist's aligned angle."""
    model = pin.buildModelFromUrdf(urdf)
    data = model.createData()
    fid = model.getFrameId(flange)
    lo = np.maximum(lower, -math.pi)
    hi = np.minimum(upper, math.pi)
    rng = np.random.default_rng(0)
    best_w = 0.0
    pin.forwardKinematics(model, data, np.zeros(6))
    shoulder = data.oMi[2].translation.copy()
    reach = 0.0
    for q in rng.uniform(lo, hi, size=(2000, 6)):
        J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        best_w = max(best_w, abs(float(np.linalg.det(J))))
    # elbow: the q3 that puts the wrist centre (joint 5's origin) farthest from the shoulder
    scan = np.linspace(-math.pi, math.pi, 721)
    dists = []
    for a in scan:
        q = np.zeros(6)
        q[2] = a
        pin.forwardKinematics(model, data, q)
        dists.append(np.linalg.norm(data.oMi[5].translation - shoulder))
    elbow = float(scan[int(np.argmax(dists))])
    # reach: the stretched arm's flange distance over the wrist angles
    for a5 in np.linspace(lo[4], hi[4], 181):
        q = np.zeros(6)
        q[2] = elbow
        q[4] = a5
        pin.framesForwardKinematics(model, data, q)
        reach = max(reach, float(np.linalg.norm(data.oMf[fid].translation - shoulder)))
    # wrist: the q5 that aligns joint 4's and joint 6's axes (the wrist singularity)
    cross = []
    for a in scan:
        q = np.zeros(6)
        q[4] = a
        pin.forwardKinematics(model, data, q)
        z4 = data.oMi[4].rotation[:, 2]
        z6 = data.oMi[6].rotation[:, 2]
        cross.append(float(np.dot(z4, z6)))
    wrist = float(scan[int(np.argmax(cross))])
    return best_w, reach, elbow, wrist


# ---------------------------------------------------------------------------------------------
# The arm in the planner's scene
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class _Phase:
    name: str
    carried: bool  # the part moves with the TCP
    gripper: str  # which gripper body is at the TCP


@dataclass(frozen=True, eq=False)
class _Groups:
    """The clearances of a stretch grouped for :meth:`ArmPlanner._advance`: each
    clearance's group ``of``; per group the moving body (the deeper of the two; "" for a
    rigid pair, whose clearance cannot change), the joints that move it relative to the
    other body (``mask`` (g, 6), ``live``: any), the quadratic forms (36, g) of the travel
    bounds' growth terms ``G`` (across legs) and ``H`` (the acceleration along a leg), and
    the distinct bodies with each group's index among them."""

    of: np.ndarray
    bodies: list[str]
    mask: np.ndarray
    live: np.ndarray
    G: np.ndarray
    H: np.ndarray
    unique: list[str]
    body_index: np.ndarray


def _skew_rows(w: np.ndarray) -> np.ndarray:
    """(18, 3): rows ``3 j .. 3 j + 2`` are the cross-product matrix of ``w[j]`` (6, 3)."""
    S = np.zeros((6, 3, 3))
    S[:, 0, 1], S[:, 0, 2] = -w[:, 2], w[:, 1]
    S[:, 1, 0], S[:, 1, 2] = w[:, 2], -w[:, 0]
    S[:, 2, 0], S[:, 2, 1] = -w[:, 1], w[:, 0]
    return S.reshape(18, 3)


class _BoxTier:
    """World bounding-box gaps of a stretch's clearances (:meth:`ArmPlanner._items`) at the
    bodies' poses, all at once: each body's model box corners moved to its pose, against the
    obstacles' world boxes (a body against the cell) or the other body's box (a pair)."""

    def __init__(self, scene, bodies: Sequence[str], env: Sequence[str],
                 items: Sequence[tuple[str, str]]) -> None:
        self.corners = np.array([scene.corners[b] for b in bodies])  # (B, 8, 3)
        where = {b: i for i, b in enumerate(bodies)}
        self.env_items = np.array([i for i, (_, b) in enumerate(items) if b == ""], int)
        self.env_body = np.array([where[a] for a, b in items if b == ""], int)
        self.pair_items = np.array([i for i, (_, b) in enumerate(items) if b != ""], int)
        self.pair_a = np.array([where[a] for a, b in items if b != ""], int)
        self.pair_b = np.array([where[b] for a, b in items if b != ""], int)
        self.env = scene.world.aabbs(env) if len(env) else np.zeros((0, 2, 3))
        self.n = len(items)

    def gaps(self, poses: np.ndarray) -> np.ndarray:
        """Box gaps (items,) of the bodies at ``poses`` (B, 4, 4), m."""
        w = np.einsum("bij,bkj->bki", poses[:, :3, :3], self.corners) + poses[:, None, :3, 3]
        lo, hi = w.min(axis=1), w.max(axis=1)
        out = np.empty(self.n)
        if len(self.env_items):
            if len(self.env):
                bl, bh = lo[self.env_body][:, None], hi[self.env_body][:, None]
                g = np.maximum(0.0, np.maximum(self.env[None, :, 0] - bh, bl - self.env[None, :, 1]))
                out[self.env_items] = np.sqrt((g * g).sum(axis=2)).min(axis=1)
            else:
                out[self.env_items] = math.inf
        if len(self.pair_items):
            a, b = self.pair_a, self.pair_b
            g = np.maximum(0.0, np.maximum(lo[b] - hi[a], lo[a] - hi[b]))
            out[self.pair_items] = np.sqrt((g * g).sum(axis=1))
        return out


class ArmPlanner:
    """Checks and times every step of a plan with the cell's arm.

    Parameters
    ----------
    robot : Robot
    scene : asmplan.planner.motion.Scene
        The planner's FCL scene; the link bodies ``arm:<link>`` are added to it.
    settings : ArmSettings
    gripper_names : (closed, open) body names of the gripper in the scene.
    """

    def __init__(self, robot: Robot, scene, settings: ArmSettings,
                 gripper_names: tuple[str, str]) -> None:
        self.arm = ArmModel(robot, settings)
        self.settings = settings
        self.scene = scene
        self.gripper_closed, self.gripper_open = gripper_names
        urdf = _read_urdf(Path(robot.urdf_path), robot.flange_link)  # type: ignore[arg-type]
        self.models: dict[str, CollisionModel] = link_models(urdf)
        self.links = [ln for ln in urdf.links if ln in self.models]
        m = self.arm.model
        # links on the base (their frame hangs on the universe joint) never move
        self.static_links = [ln for ln in self.links
                             if m.frames[m.getFrameId(ln)].parentJoint == 0]
        self.moving_links = [ln for ln in self.links if ln not in self.static_links]
        # how many joints move each link (pinocchio's parent joint of its frame)
        self.joint_depth = {ARM_PREFIX + ln: int(m.frames[m.getFrameId(ln)].parentJoint)
                            for ln in self.links}
        self.body = {ln: ARM_PREFIX + ln for ln in self.links}
        self.bodies = [self.body[ln] for ln in self.links]
        from ..knowledge.robot import LINK_NAMES

        self.link_names = {self.body[ln]: n for ln, n in
                           LINK_NAMES.get(robot.model.lower(), {}).items() if ln in self.body}
        self.moving_bodies = [self.body[ln] for ln in self.moving_links]
        far = np.eye(4)
        far[:3, 3] = -1e3
        for ln in self.links:
            scene.add_body(self.body[ln], self.models[ln], far)
        # index of each link along the chain (0 = root); links[k] moves with joints < k
        self.chain_index = {ln: urdf.links.index(ln) for ln in self.links}
        # the tool (the mounted gripper) and the carried part are checked against every link,
        # the two wrist links included: a gripper mounted into the flange or the wrist, or a
        # part held so that it reaches back into them, collides there. (The wrist links are
        # rigid with the tool or turn it about its own axis only, so those clearances hardly
        # change along a path: each is measured once per stretch or as its bound runs out.)
        self.tool_links = list(self.links)
        self.self_pairs = self._self_pairs(urdf.links)
        self._bounds = self._reach_bounds()
        self._link_sphere = self._link_spheres()
        fl = m.frames[self.arm.flange_id]
        assert fl.parentJoint == 6
        self._tcp_in_joint6 = fl.placement.act(self.arm.T_flange_tcp[:3, 3].copy())
        self.last_q: np.ndarray | None = None
        self._poses: dict[str, np.ndarray] = {}

    # -- setup ------------------------------------------------------------------------------
    def _self_pairs(self, chain: Sequence[str]) -> list[tuple[str, str]]:
        """Link pairs to check: not neighbours on the chain and not in contact at every one
        of 200 seeded configurations."""
        cand = [(a, b) for a, b in itertools.combinations(self.links, 2)
                if abs(chain.index(a) - chain.index(b)) > 1]
        rng = np.random.default_rng(self.settings.seed)
        lo = np.maximum(self.arm.lower, -math.pi)
        hi = np.minimum(self.arm.upper, math.pi)
        always = set(cand)
        world = self.scene.world
        for q in rng.uniform(lo, hi, size=(200, 6)):
            self._pose_links(q)
            always = {p for p in always if world.in_collision(self.body[p[0]], [self.body[p[1]]],
                                                              1e-6)}
            if not always:
                break
        return [p for p in cand if p not in always]

    def _reach_bounds(self) -> tuple[np.ndarray, dict[str, float], float]:
        """The joint offsets (6,): ``offs[i]`` is the distance of joint ``i``'s origin from
        joint ``i - 1``'s (m); per link body, the largest distance of its collision geometry
        from its parent joint's origin (the link frame's offset plus its farthest point); and
        the flange frame's distance from joint 6's origin (m)."""
        m = self.arm.model
        offs = np.array([float(np.linalg.norm(m.jointPlacements[i].translation))
                         for i in range(1, m.njoints)])
        ext: dict[str, float] = {}
        for ln, model in self.models.items():
            if ln not in self.body:
                continue
            e = 0.0
            for p in model.pieces:
                R, t = p.T_part_piece[:3, :3], p.T_part_piece[:3, 3]
                if p.vertices_m is not None:
                    r = float(np.linalg.norm(p.vertices_m @ R.T + t, axis=1).max())
                elif p.half_extents_m is not None:
                    c = np.array(list(itertools.product(*[(-h, h) for h in p.half_extents_m])))
                    r = float(np.linalg.norm(c @ R.T + t, axis=1).max())
                else:
                    r = float(np.linalg.norm(t)) + math.hypot(p.radius_m, p.length_m / 2)
                e = max(e, r)
            frame = float(np.linalg.norm(m.frames[m.getFrameId(ln)].placement.translation))
            ext[self.body[ln]] = frame + e
        flange = float(np.linalg.norm(m.frames[self.arm.flange_id].placement.translation))
        return offs, ext, flange

    def _link_spheres(self) -> dict[str, tuple[int, np.ndarray, float]]:
        """Per link body: its parent joint, the centre (3,) of its bounding sphere in that
        joint's frame (the centre of its collision geometry's box) and the radius, m."""
        m = self.arm.model
        out = {}
        for ln in self.links:
            pts = []
            for p in self.models[ln].pieces:
                R, t = p.T_part_piece[:3, :3], p.T_part_piece[:3, 3]
                if p.vertices_m is not None:
                    pts.append(p.vertices_m @ R.T + t)
                elif p.half_extents_m is not None:
                    c = np.array(list(itertools.product(*[(-h, h) for h in p.half_extents_m])))
                    pts.append(c @ R.T + t)
                else:  # a cylinder or a sphere: its bounding box's corners
                    h = np.array([p.radius_m, p.radius_m, max(p.length_m / 2, p.radius_m)])
                    c = np.array(list(itertools.product(*[(-v, v) for v in h])))
                    pts.append(c @ R.T + t)
            P = np.concatenate(pts)
            centre = 0.5 * (P.min(axis=0) + P.max(axis=0))
            e = float(np.linalg.norm(P - centre, axis=1).max())
            f = m.frames[m.getFrameId(ln)]
            out[self.body[ln]] = (int(f.parentJoint), f.placement.act(centre), e)
        return out

    def rho(self, tool_radius_m: float) -> dict[str, np.ndarray]:
        """Per body (links, the two gripper bodies and :data:`CARRIED` for the carried part),
        per joint ``j``: a bound (m) of the distance from joint ``j``'s axis to any point of
        the body, zero for the joints that do not move it. The triangle inequality over the
        joint offsets from joint ``j`` to the body's parent joint, plus the body's extent
        about that joint (the tool: the flange offset, the flange-to-TCP offset and
        ``tool_radius_m``, which bounds the gripper and the carried part about the TCP)."""
        offs, ext, flange = self._bounds
        out: dict[str, np.ndarray] = {}

        def chain(depth: int, extent: float) -> np.ndarray:
            v = np.zeros(6)
            for j in range(depth):
                v[j] = float(offs[j + 1:depth].sum()) + extent
            return v

        for b in self.bodies:
            out[b] = chain(self.joint_depth[b], ext[b])
        tool = chain(6, flange + float(np.linalg.norm(self.arm.T_flange_tcp[:3, 3]))
                     + tool_radius_m)
        for t in (self.gripper_closed, self.gripper_open, CARRIED):
            out[t] = tool
        return out

    def _pose_links(self, q: np.ndarray) -> list[tuple[str, np.ndarray]]:
        poses = self.arm.link_poses(q, self.links)
        out = []
        for ln, T in zip(self.links, poses, strict=True):
            self.scene.world.set_pose(self.body[ln], T)
            out.append((self.body[ln], T))
        return out

    # -- key poses --------------------------------------------------------------------------
    def check_pose(self, index: int, part: str, what: str, T_world_tcp: np.ndarray
                   ) -> list[IkSolution]:
        """The IK branches of a key pose; raises when there is none: out of reach (with the
        distance and the reach) or beyond a joint limit (naming the joint)."""
        dist = self.arm.flange_distance_m(T_world_tcp)
        if dist > self.arm.reach_m:
            raise OutOfReachError(index, part, what, dist, self.arm.reach_m, T_world_tcp)
        if self.arm.ik_any(T_world_tcp, self.last_q) is not None:
            return []
        sols, fail = self.arm.ik_all(T_world_tcp)
        if fail is None:
            return sols
        if fail.kind == "limit":
            raise JointLimitError(index, part, what, fail.joint, fail.value_rad, fail.lower_rad,
                                  fail.upper_rad, T_world_tcp)
        raise OutOfReachError(index, part, what, dist, min(self.arm.reach_m, dist),
                              T_world_tcp) if dist > self.arm.measured_reach_m else ArmPathError(
            index, part, what, f"no inverse-kinematics solution from {len(self.arm.seeds(T_world_tcp))}"
            f" seeds (flange {dist * 1e3:.0f} mm from the shoulder, reach "
            f"{self.arm.reach_m * 1e3:.0f} mm)", T_world_tcp)

    # -- a whole step -----------------------------------------------------------------------
    # Complexity above C (radon): every IK branch (and the turned tool) is tried in order through
    # IK along the path, the OMPL joint-space transfer fallback, collision checks and retiming.
    def plan_step(self, index: int, part: str, traj: Trajectory, T_tcp_part: np.ndarray,
                  obstacles: Sequence[str], T_start: np.ndarray, T_final: np.ndarray,
                  tool_radius_m: float, max_tcp_speed_m_s: float = math.inf,
                  ompl: tuple[str, float, int] = ("RRTConnect", 1.0, 0)
                  ) -> tuple[Trajectory, ArmMotion]:
        """IK along the step's whole trajectory on the best branch that works, every state
        checked for collisions, then the trajectory retimed within the joint limits.

        A parallel gripper is the same turned half a turn about its approach axis (its two
        fingers are alike, :func:`asmplan.parts.cell.gripper_model`): every branch is also
        tried with the tool turned (the TCP frames times :data:`TURN`), which holds the part
        the same way and takes the same path; the arm's links and joint 6 see it
        differently. After a previous step the candidates are tried in the order of the
        joint move from the arm's last state (its time, then the joints' total travel; the
        turn saves up to half a wrist turn between steps), else by manipulability and limit
        margin.

        Where no branch can follow the planned (Cartesian) transfer from the lifted to the
        pre-insertion pose, the transfer is planned in joint space with OMPL on each branch
        (``ompl``: planner, time budget s, seed), the straight segments staying Cartesian;
        the TCP then follows FK of the joint path, at most ``max_tcp_speed_m_s`` fast
        (``tool_radius_m`` bounds the gripper and part about the TCP).

        Returns
        -------
        trajectory : Trajectory
            Retimed (and turned, when so planned).
        motion : ArmMotion
            ``tool_turned`` when the tool is turned half a turn about its approach axis: the
            grasp's TCP frame is then ``T_part_gripper @ TURN`` (the part's path is unchanged).

        Raises
        ------
        ArmError
            The first key pose out of reach or beyond a joint limit; else, when every branch
            fails along the path, the failure of the branch nearest the arm's last state.
        """
        phase_idx = traj.phase_indices_at(traj.t_s)
        names = [p.name for p in traj.phases]
        variants = {False: (traj, T_tcp_part), True: (_turned(traj), TURN @ T_tcp_part)}
        self.check_pose_either(index, part, "pre-grasp pose", traj.T_world_gripper[0])
        cands = self._candidates(traj.T_world_gripper[0])
        n_branches = sum(1 for _, turned in cands if not turned)
        failures: list = []
        def attempt(sol: IkSolution, turned: bool) -> tuple:
            tr, T_tp = variants[turned]
            Q, stats = self._track_wrapped(index, part, tr.T_world_gripper, phase_idx, names,
                                           sol.q_rad)
            checked = self._check_path(index, part, Q, phase_idx, names, T_tp, obstacles,
                                       T_start, T_final, tool_radius_m)
            transfer = self._transfer(index, part, Q[0], obstacles, T_start, T_final,
                                      tool_radius_m, ompl)
            cycle = retime(tr, Q, self.arm.vmax, self.arm.amax)[0].duration_s + transfer[1]
            return cycle, (tr, Q, stats, sol, names, checked, n_branches, False, transfer,
                           turned)

        for i, (sol, turned) in enumerate(cands):
            try:
                cycle, best = attempt(sol, turned)
            except (ArmPathError, ArmCollisionError, JointLimitError) as exc:
                failures.append(exc)
                continue
            # the same branch held the other way, when the move here took longer than that
            # one's straight joint move would (a detour, or a start a turn away): tried too,
            # the shorter step kept
            sib = next(((s2, t2) for s2, t2 in cands[i + 1:]
                        if t2 != turned and s2.branch == sol.branch), None)
            if sib is not None and self.last_q is not None and best[8][1] > joint_move_s(
                    self.last_q, sib[0].q_rad, self.arm.vmax, self.arm.amax) + 1e-9:
                try:
                    cycle2, other = attempt(*sib)
                except (ArmPathError, ArmCollisionError, JointLimitError):
                    pass
                else:
                    if cycle2 < cycle - 1e-9:
                        best = other
            return self._finish(*best)
        translate_failed = [f for f in failures if f.phase == "translate"]
        if translate_failed and "translate" in names:
            for sol, turned in cands:
                tr, T_tp = variants[turned]
                try:
                    new, Q, stats = self._joint_translate(
                        index, part, tr, sol.q_rad, sol.branch, T_tp, obstacles, T_final,
                        tool_radius_m, max_tcp_speed_m_s, ompl)
                    names2 = [p.name for p in new.phases]
                    idx2 = new.phase_indices_at(new.t_s)
                    checked = self._check_path(index, part, Q, idx2, names2, T_tp,
                                               obstacles, T_start, T_final,
                                               tool_radius_m,
                                               tool_env_phases=("translate",))
                    transfer = self._transfer(index, part, Q[0], obstacles, T_start, T_final,
                                              tool_radius_m, ompl)
                except (ArmPathError, ArmCollisionError, JointLimitError) as exc:
                    failures.append(exc)
                    continue
                return self._finish(new, Q, stats, sol, names2, checked, n_branches, True,
                                    transfer, turned)
        raise failures[0]

    def check_pose_either(self, index: int, part: str, what: str, T_world_tcp: np.ndarray
                          ) -> None:
        """:meth:`check_pose` of the pose or of the tool turned half a turn about its
        approach axis (the same grasp); raises the first pose's failure when both fail."""
        try:
            self.check_pose(index, part, what, T_world_tcp)
        except (OutOfReachError, JointLimitError, ArmPathError):
            try:
                self.check_pose(index, part, what, T_world_tcp @ TURN)
            except (OutOfReachError, JointLimitError, ArmPathError):
                pass
            else:
                return
            raise

    def _candidates(self, T_world_tcp: np.ndarray) -> list[tuple[IkSolution, bool]]:
        """The start configurations to try at the step's first pose, best first: every IK
        branch (moved by whole turns nearest the arm's last state), each also with the tool
        turned (solved from the branch's solution with joint 6 half a turn on)."""
        arm = self.arm
        sols, _ = arm.ik_all(T_world_tcp)
        ref = self.last_q
        T_turned = T_world_tcp @ TURN
        target = arm._target(T_turned)
        out: list[tuple[IkSolution, bool]] = []
        for sol in sols:
            q0 = sol.q_rad if ref is None else self._near(sol.q_rad, ref)
            out.append((replace(sol, q_rad=q0), False))
            seed = q0.copy()
            seed[5] += math.pi
            qt, ok = arm._solve(target, seed, 30)
            qi = arm._in_limits(qt) if ok else None
            if qi is None:
                continue
            qi = qi if ref is None else self._near(qi, ref)
            m, j = arm.limit_margin(qi)
            out.append((IkSolution(qi, arm.branch_label(qi, T_turned), arm.manipulability(qi),
                                   m, arm.joint_names[j]), True))
        if ref is not None:  # the shortest joint move from the last state first
            return sorted(out, key=lambda c: (
                round(joint_move_s(ref, c[0].q_rad, arm.vmax, arm.amax), 6),
                float(np.abs(c[0].q_rad - ref).sum())))
        return sorted(out, key=lambda c: (-min(c[0].manipulability / arm.best_manipulability,
                                               0.2) - c[0].limit_margin_rad * 0.01, c[1]))

    def _finish(self, traj: Trajectory, Q: np.ndarray, stats: tuple[float, float, str, float],
                sol: IkSolution, names: list[str], checked: int, n_branches: int,
                joint_space: bool, transfer: tuple[np.ndarray, float, int],
                turned: bool = False) -> tuple[Trajectory, ArmMotion]:
        new_traj, scales = retime(traj, Q, self.arm.vmax, self.arm.amax)
        self.last_q = Q[-1].copy()
        motion = ArmMotion(
            joint_names=self.arm.joint_names, q_rad=Q, branch=sol.branch,
            min_manipulability_ratio=stats[0], min_limit_margin_rad=stats[1],
            limit_margin_joint=stats[2], max_ik_error_m=stats[3],
            phase_time_scale=tuple((n, float(s)) for n, s in zip(names, scales, strict=True)),
            transfer_s=transfer[1], checked_states=checked + transfer[2],
            branches_found=n_branches, joint_space_translate=joint_space,
            transfer_q_rad=transfer[0], tool_turned=turned)
        return new_traj, motion

    def _transfer(self, index: int, part: str, q_goal: np.ndarray, obstacles: Sequence[str],
                  T_start: np.ndarray, T_final: np.ndarray, tool_radius_m: float,
                  ompl: tuple[str, float, int]) -> tuple[np.ndarray, float, int]:
        """The arm's move from its last state (the previous step's end) to ``q_goal`` (this
        step's first state), gripper open, this part at its start: the straight joint move
        when it is free, else an OMPL joint-space path; certified by conservative advancement
        and timed rest-to-rest per leg. Returns the waypoints (M, 6), the time (s) and the
        states checked; no previous state: no move."""
        from .ompl_backend import plan_joint

        ref = self.last_q
        if ref is None:
            return np.zeros((0, 6)), 0.0, 0
        setup = _Phase("transfer", False, self.gripper_open)
        self.scene.set_part_pose(part, T_start)
        env = [*obstacles, part]

        def free(q: np.ndarray) -> bool:
            self._pose_all(q, setup, np.eye(4), part)
            return not self._contacts(setup, env, part, tool_env=True)

        def certify(W: np.ndarray) -> int:
            return self._check_path(index, part, W, np.zeros(len(W), int), ["transfer"],
                                    np.eye(4), obstacles, T_start, T_final,
                                    tool_radius_m, tool_env_phases=("transfer",))

        W = np.array([ref, q_goal])
        try:  # the straight joint move, certified, when it is free
            checked = certify(W)
        except ArmCollisionError as exc:
            planner, budget, seed = ompl
            res = plan_joint(free, ref, q_goal, self.arm.lower, self.arm.upper, planner=planner,
                             time_budget_s=budget, seed=seed + 7907 * index,
                             resolution_rad=0.01, try_direct=False)
            if not res.solved:
                raise ArmPathError(index, part, "transfer", f"the straight joint move from the "
                                   f"previous step's last state is blocked ({exc}) and "
                                   f"{planner} found no joint-space path in {budget:g} s "
                                   f"({res.status})") from None
            W = res.q_rad
            self.scene.set_part_pose(part, T_start)
            checked = certify(W)
        time_s = sum(joint_move_s(a, b, self.arm.vmax, self.arm.amax)
                     for a, b in itertools.pairwise(W))
        return W, float(time_s), checked

    def _joint_translate(self, index: int, part: str, traj: Trajectory, q0: np.ndarray,
                         branch: str, T_tcp_part: np.ndarray, obstacles: Sequence[str],
                         T_final: np.ndarray, tool_radius_m: float, max_tcp_speed_m_s: float,
                         ompl: tuple[str, float, int]
                         ) -> tuple[Trajectory, np.ndarray, tuple[float, float, str, float]]:
        """The step with its translate phase planned in joint space (see :meth:`plan_step`)."""
        from .ompl_backend import plan_joint
        from .trajectory import min_jerk

        t, T, F = traj.t_s, traj.T_world_gripper, traj.clamp_force_N
        idx = traj.phase_indices_at(t)
        names = [p.name for p in traj.phases]
        ti = names.index("translate")
        a_end = int(np.flatnonzero(idx == ti)[0])  # the lifted pose (the translate's start)
        c_start = int(np.flatnonzero(idx > ti)[0])  # the pre-insertion pose
        QA, sa = self._track_wrapped(index, part, T[:a_end + 1], idx[:a_end + 1], names, q0)
        sols, _ = self.arm.ik_all(T[c_start])
        same = [s for s in sols if s.branch == branch]
        if not same:
            raise ArmPathError(index, part, "translate", f"the pre-insertion pose has no IK "
                               f"solution on the branch {branch}", T[c_start])
        qc = min((self._near(s.q_rad, QA[-1]) for s in same),
                 key=lambda q: float(np.abs(q - QA[-1]).sum()))
        QC, sc = self._track_wrapped(index, part, T[c_start:], idx[c_start:], names, qc)
        setup = _Phase("translate", True, self.gripper_closed)
        env = list(obstacles)

        def free(q: np.ndarray) -> bool:
            self._pose_all(q, setup, T_tcp_part, part)
            return not self._contacts(setup, env, part, tool_env=True)

        planner, budget, seed = ompl
        res = plan_joint(free, QA[-1], QC[0], self.arm.lower, self.arm.upper, planner=planner,
                         time_budget_s=budget, seed=seed + 7919 * index, resolution_rad=0.01)
        if not res.solved:
            raise ArmPathError(index, part, "translate", f"{planner} found no joint-space path "
                               f"from the lifted to the pre-insertion pose in {budget:g} s "
                               f"({res.status})", T[a_end])
        # rest-to-rest minimum-jerk legs within the joint limits, sampled every 10 ms, then
        # slowed as a whole where the TCP would exceed its speed limit
        qs = [res.q_rad[:1]]
        times = [np.zeros(1)]
        t_leg = 0.0
        for qa, qb in itertools.pairwise(res.q_rad):
            dur = joint_move_s(qa, qb, self.arm.vmax, self.arm.amax)
            if dur <= 0:
                continue
            tau = np.linspace(0.0, 1.0, max(2, math.ceil(dur / 0.01) + 1))[1:]
            qs.append(qa + np.outer(min_jerk(tau), qb - qa))
            times.append(t_leg + dur * tau)
            t_leg += dur
        QT = np.concatenate(qs)
        tt = np.concatenate(times)
        TT = np.array([self.arm.fk(q) for q in QT])
        if math.isfinite(max_tcp_speed_m_s) and len(TT) > 1:
            from .trajectory import rotation_angle_rad

            dp = np.linalg.norm(np.diff(TT[:, :3, 3], axis=0), axis=1)
            rel = np.einsum("nji,njk->nik", TT[:-1, :3, :3], TT[1:, :3, :3])
            speed = (dp + tool_radius_m * rotation_angle_rad(rel)) / np.diff(tt)
            k = float(speed.max()) / max_tcp_speed_m_s
            if k > 1.0:
                tt = tt * k * (1 + 1e-9)
        old_dur = traj.phases[ti].t_end_s - traj.phases[ti].t_start_s
        new_dur = float(tt[-1])
        shift = new_dur - old_dur
        t0 = traj.phases[ti].t_start_s
        t_new = np.concatenate([t[:a_end + 1], t0 + tt[1:-1], t[c_start:] + shift])
        T_new = np.concatenate([T[:a_end + 1], TT[1:-1], T[c_start:]])
        F_new = np.concatenate([F[:a_end + 1], np.full(len(TT) - 2, F[a_end]), F[c_start:]])
        Q_new = np.concatenate([QA, QT[1:-1], QC])
        phases = []
        for p, ph in enumerate(traj.phases):
            if p < ti:
                phases.append(ph)
            elif p == ti:
                phases.append(PhaseSpan(ph.name, ph.t_start_s, ph.t_start_s + new_dur))
            else:
                phases.append(PhaseSpan(ph.name, ph.t_start_s + shift, ph.t_end_s + shift))
        new = Trajectory(t_s=t_new, T_world_gripper=T_new, clamp_force_N=F_new,
                         phases=tuple(phases))
        stats = (min(sa[0], sc[0]), min(sa[1], sc[1]), sa[2] if sa[1] <= sc[1] else sc[2],
                 max(sa[3], sc[3]))
        for q in QT:  # the joint path's own margins
            m, j = self.arm.limit_margin(q)
            w = self.arm.manipulability(q) / self.arm.best_manipulability
            stats = (min(stats[0], w), min(stats[1], m),
                     self.arm.joint_names[j] if m < stats[1] else stats[2], stats[3])
        return new, Q_new, stats

    def _near(self, q: np.ndarray, ref: np.ndarray) -> np.ndarray:
        """``q`` with each joint moved by 2 pi k (within the limits) nearest to ``ref``."""
        out = q.copy()
        for i in range(6):
            cands = [q[i] + _TWO_PI * k for k in range(-2, 3)
                     if self.arm.lower[i] <= q[i] + _TWO_PI * k <= self.arm.upper[i]]
            # nearest to ref among those clear of the limits by the margin
            m = self.settings.joint_limit_margin_rad
            clear = [v for v in cands if self.arm.lower[i] + m <= v <= self.arm.upper[i] - m]
            r = float(ref[i])
            out[i] = min(clear or cands, key=lambda v: abs(v - r))
        return out

    def _track_wrapped(self, index: int, part: str, T: np.ndarray, phase_idx: np.ndarray,
                       names: list[str], q0: np.ndarray
                       ) -> tuple[np.ndarray, tuple[float, float, str, float]]:
        """:meth:`_track`; when a joint whose range exceeds a turn runs into its limit, the
        path is tracked again from the start angle one turn the other way (same branch)."""
        q = q0.copy()
        for _ in range(3):
            try:
                return self._track(index, part, T, phase_idx, names, q)
            except JointLimitError as exc:
                j = self.arm.joint_names.index(exc.joint)
                shift = -_TWO_PI if exc.value_rad > self.arm.upper[j] - 1e-9 else _TWO_PI
                if not (self.arm.lower[j] <= q[j] + shift <= self.arm.upper[j]):
                    raise
                q[j] += shift
        return self._track(index, part, T, phase_idx, names, q)

    def _track(self, index: int, part: str, T: np.ndarray, phase_idx: np.ndarray,
               names: list[str], q0: np.ndarray) -> tuple[np.ndarray, tuple[float, float, str, float]]:
        """IK along the path (:meth:`ArmModel.track`), then the first sample (in path order)
        that fails: no convergence, a joint jump (a branch change or a singularity), a joint
        within its limit margin, or manipulability below the settings' ratio."""
        arm, s = self.arm, self.settings
        Q, n_ok, w_abs, err = arm.track(T, q0)
        Qk = Q[:n_ok]
        jump = np.abs(np.diff(Qk, axis=0)).max(axis=1) if n_ok > 1 else np.zeros(0)
        margins = np.minimum(Qk - arm.lower, arm.upper - Qk)
        w = w_abs / arm.best_manipulability

        def first(bad: np.ndarray, offset: int = 0) -> int:
            i = np.flatnonzero(bad)
            return int(i[0]) + offset if len(i) else n_ok

        k_jump = first(jump > s.max_joint_jump_rad, 1)
        k_lim = first(margins.min(axis=1) < s.joint_limit_margin_rad)
        k_w = first(w < s.min_manipulability_ratio)
        k = min(n_ok, k_jump, k_lim, k_w)
        if k < len(T):
            phase = names[int(phase_idx[k])]
            if k == n_ok:
                raise ArmPathError(index, part, phase, f"inverse kinematics does not converge "
                                   f"near the {phase}'s pose {k} (a singularity or the edge of "
                                   "the workspace)", T[k])
            if k == k_jump:
                d = np.abs(Q[k] - Q[k - 1])
                j = int(np.argmax(d))
                raise ArmPathError(index, part, phase, f"{arm.joint_names[j]} jumps "
                                   f"{math.degrees(d[j]):.1f} deg between two samples (a "
                                   "branch change or a singularity)", T[k])
            if k == k_lim:
                j = int(np.argmin(margins[k]))
                raise JointLimitError(index, part, phase, arm.joint_names[j], float(Q[k, j]),
                                      float(arm.lower[j]), float(arm.upper[j]), T[k],
                                      along_path=True)
            raise ArmPathError(index, part, phase, f"manipulability {w[k] * 100:.2f} % of the "
                               f"arm's best, below {s.min_manipulability_ratio * 100:.1f} % "
                               "(too close to a singularity)", T[k])
        flat = int(np.argmin(margins))
        kk, j = divmod(flat, 6)
        return Q, (float(w.min()), float(margins[kk, j]), arm.joint_names[j], float(err.max()))

    # -- collisions -------------------------------------------------------------------------
    def _phase_setup(self, name: str) -> _Phase:
        carried = name in ("clamp", "hold", "lift", "translate", "lower")
        gripper = (self.gripper_open if name in ("approach", "retreat", "transfer")
                   else self.gripper_closed)
        return _Phase(name, carried, gripper)

    # Complexity above C (radon): conservative advancement over every stretch of the path, per pair
    # of bodies, with the carried part and the gripper's opening set per phase.
    def _check_path(self, index: int, part: str, Q: np.ndarray, phase_idx: np.ndarray,
                    names: list[str], T_tcp_part: np.ndarray, obstacles: Sequence[str],
                    T_start: np.ndarray, T_final: np.ndarray, tool_radius_m: float,
                    tool_env_phases: Sequence[str] = ()) -> int:
        """Conservative advancement along the joint path ``Q`` (N, 6), linear between
        samples, parametrised by ``u`` in [0, N-1].

        The clearances to keep (:meth:`_items`: every moving link against the cell, every
        checked pair of bodies of the chain) are measured at a state and each is then
        certified up to where the travel bound of :meth:`_advance` for the two bodies
        reaches it (floored at :attr:`ArmSettings.check_step_m`: closer than that, the
        states are checked for contact at that step). The next state is the earliest end
        of those stretches. Bounding-box gaps are measured at every state; an exact FCL
        distance (boxes closer than 2 cm) only when its stretch ends or is more than half
        used. Consecutive phases with the same bodies (the gripper open or closed, the part
        carried, at its start or at its final pose) form one stretch; every clearance is
        measured afresh where the bodies change. Returns the number of states checked."""
        scene, s = self.scene, self.settings
        checked = 0
        self._leg_dq = np.diff(Q, axis=0) if len(Q) > 1 else np.zeros((1, 6))
        # per sample, each joint's path length from the start (N, 6), rad
        cumJ = np.concatenate([np.zeros((1, 6)), np.cumsum(np.abs(self._leg_dq), axis=0)])
        rho = self.rho(tool_radius_m)
        last = len(Q) - 1

        def bodies_of(k: int) -> tuple:
            phase = names[int(phase_idx[k])]
            setup = self._phase_setup(phase)
            where = "" if setup.carried else ("start" if phase in ("approach", "transfer")
                                              else "final")
            return setup.carried, setup.gripper, where, phase in tool_env_phases

        starts = [0, *[k for k in range(1, len(Q)) if bodies_of(k) != bodies_of(k - 1)]]
        for b, k0 in enumerate(starts):
            k1 = starts[b + 1] if b + 1 < len(starts) else last
            carried, gripper, where, tool_env = bodies_of(k0)
            setup = _Phase(names[int(phase_idx[k0])], carried, gripper)
            if carried:
                env = list(obstacles)
            else:
                scene.set_part_pose(part, T_start if where == "start" else T_final)
                env = [*obstacles, part]
            tool = [gripper] + ([part] if carried else [])
            items = self._items(setup, part, tool_env)
            keys = [(a if a != part else CARRIED, b if b != part else CARRIED) for a, b in items]
            plan = self._group_plan(tuple(keys), rho)
            of = plan.of
            boxes = _BoxTier(scene, [*self.bodies, *tool], env, items)
            until = np.full(len(items), -math.inf)  # certified up to here
            since = np.zeros(len(items))  # from here (where measured)
            u = float(k0)
            while True:
                k = min(int(u), last - 1) if last > 0 else 0
                f = u - k
                q = Q[k] + f * (Q[k + 1] - Q[k]) if last > 0 else Q[0]
                T_tcp = self.arm.fk(q)
                poses = self.arm.link_poses(q, self.links)
                poses.append(T_tcp)
                if carried:
                    poses.append(T_tcp @ T_tcp_part)
                self._poses = dict(zip([*self.bodies, *tool], poses, strict=True))
                d = boxes.gaps(np.array(poses))
                close = d < _ENOUGH_M
                # exact distances where the boxes are close and the stretch ends (or is more
                # than half used: fewer states in all); box gaps everywhere else
                exact = close & ((until <= u) | (until - u <= 0.5 * (until - since)))
                fresh = ~close | exact
                for i in np.flatnonzero(exact):
                    d[i] = self._exact(items[i], env)
                checked += 1
                if float(d[fresh].min(initial=math.inf)) <= s.check_step_m:
                    hit = self._contacts(setup, env, part, tool_env=tool_env)
                    if hit:
                        scene.set_part_pose(part, T_start)
                        phase = names[int(phase_idx[min(int(u), last)])]
                        raise ArmCollisionError(index, part, phase, hit, q, T_tcp,
                                                self.link_names)
                if u >= k1 or last == 0:
                    break
                idx = np.flatnonzero(fresh)
                groups = np.unique(of[idx])
                reach = self._advance(u, q, groups, of[idx], d[idx], cumJ, k1, tool_radius_m,
                                      plan)
                until[idx] = reach[np.searchsorted(groups, of[idx])]
                since[idx] = u
                u = min(float(k1), max(float(until.min()), u + 1e-9))
        scene.set_part_pose(part, T_start)
        return checked

    def _items(self, setup: _Phase, part: str, tool_env: bool) -> list[tuple[str, str]]:
        """The clearances a stretch keeps: ``(body, "")`` a moving body against the cell
        (every moving link; the tool and the carried part only where ``tool_env``: elsewhere
        the motion planner certified them along the Cartesian path), and ``(a, b)`` the
        checked pairs of the chain (links; links against the gripper and the carried part)."""
        tool = [setup.gripper] + ([part] if setup.carried else [])
        env_items = [(b, "") for b in [*self.moving_bodies, *(tool if tool_env else [])]]
        pairs = [*self.self_pairs_bodies(), *[(self.body[ln], t) for t in tool
                                               for ln in self.tool_links]]
        return env_items + pairs

    def _exact(self, item: tuple[str, str], env: Sequence[str]) -> float:
        """The clearance ``item`` (:meth:`_items`) at the poses of :meth:`_check_path`: FCL
        distances (a body against the cell: exact to the obstacles whose boxes come within
        2 cm, box gaps to the others), m."""
        a, b = item
        if b == "":
            return self.scene.distance_bound([(a, self._poses[a])], env, _ENOUGH_M)
        world = self.scene.world
        world.set_pose(a, self._poses[a])
        world.set_pose(b, self._poses[b])
        return world.distance(a, b)

    def _advance(self, u: float, q: np.ndarray, groups: np.ndarray, of: np.ndarray,
                 d: np.ndarray, cumJ: np.ndarray, k1: int, tool_radius_m: float,
                 plan: _Groups) -> np.ndarray:
        """Per group in ``groups`` (sorted indices into ``plan``), how far along the path
        (``u`` units, at most ``k1``) the smallest of its clearances ``d`` (those with
        ``of == group``) is certified from the state ``u`` (configuration ``q``) on the path
        with joint path lengths ``cumJ`` (N, 6).

        A point ``p`` of a body moves at ``|sum_j dq_j (v_j + w_j x p)|`` (``v_j``, ``w_j``:
        joint ``j``'s twist, pinocchio's joint Jacobian in the base frame; only the joints
        between the two bodies count). Two bounds of the travel, the farther certified
        position taken (both hold):

        * along this leg ``q + s dq``: ``A s + B s^2 / 2``, ``A`` the speed of the body's
          bounding sphere (centre ``c``, radius ``e``) at ``q``,
          ``|sum_j dq_j (v_j + w_j x c)| + |sum_j dq_j w_j| e``, and ``B`` a
          configuration-free bound of any point's acceleration,
          ``sum_j |dq_j| (2 R_j sum_{i<j} |dq_i| + sum_{i>=j} |dq_i| R_i)`` (``R_j``:
          :meth:`rho`, a bound of the distance of the body's points from joint ``j``);
        * across legs: ``sum_j C_j (r_j + sum_{i>j} R_i C_i)``, ``C_j`` the joints' path
          lengths from ``u``, ``r_j = |v_j + w_j x c| + e`` (the sphere's distance from joint
          ``j``'s axis at ``q``; it grows by at most ``sum_{i>j} R_i C_i``). Nondecreasing
          along the path, and convex along each leg, so the chord's crossing of ``d``
          between two samples (taken) comes no later than its own."""
        floor = self.settings.check_step_m
        dist = np.full(len(plan.bodies), math.inf)
        np.minimum.at(dist, of, np.maximum(d, floor))
        dist = dist[groups]
        mask = plan.mask[groups]
        live = plan.live[groups]
        if not live.any():
            return np.full(len(groups), float(k1))
        J = pin.computeJointJacobians(self.arm.model, self.arm.data, q)  # (6, 6), base frame
        lin, ang = J[:3].T, J[3:].T  # (6, 3) per joint
        # the bounding spheres of the bodies (tool: the TCP, tool_radius_m)
        bi = plan.body_index[groups]
        used = np.unique(bi)
        c = np.zeros((len(plan.unique), 3))
        e = np.zeros(len(plan.unique))
        for i in used:
            c[i], e[i] = self._sphere(plan.unique[i], tool_radius_m)
        S = _skew_rows(ang)  # (18, 3): the cross products w_j x c as one product
        vel = lin + (S @ c[used].T).T.reshape(len(used), 6, 3)  # per body and joint at c
        pos = np.searchsorted(used, bi)
        vel = vel[pos]  # (g, 6, 3)
        eg = e[bi]
        R0 = (np.sqrt((vel * vel).sum(axis=2)) + eg[:, None]) * mask
        k = min(int(u), len(cumJ) - 2)
        dq = mask * self._leg_dq[k]  # (g, 6) this leg's change of the joints that count
        v0 = np.einsum("gj,gjk->gk", dq, vel)
        w0 = dq @ ang
        first = np.sqrt((v0 * v0).sum(axis=1)) + np.sqrt((w0 * w0).sum(axis=1)) * eg
        adq = np.abs(self._leg_dq[k])
        second = np.outer(adq, adq).ravel() @ plan.H[:, groups]
        # s A + s^2 B / 2 reaches d at s = 2 d / (A + sqrt(A^2 + 2 B d))
        with np.errstate(divide="ignore"):
            s_leg = 2.0 * dist / (first + np.sqrt(first * first + 2.0 * second * dist))
        u_leg = np.minimum(u + s_leg, float(k + 1))
        # across legs, at the samples after u: every _STRIDE-th first, then the samples
        # between the last one below d and the first above
        c_u = cumJ[k] + (u - k) * (cumJ[k + 1] - cumJ[k])
        G = plan.G[:, groups]  # (36, g)

        n_c = np.arange(k + 1, k1 + 1, _STRIDE)
        if len(n_c) == 0 or n_c[-1] != k1:
            n_c = np.append(n_c, k1)
        C = cumJ[n_c] - c_u  # (Wc, 6)
        t_c = C @ R0.T + (C[:, :, None] * C[:, None, :]).reshape(len(C), 36) @ G
        over = t_c >= dist
        hit = over.any(axis=0)
        wc = np.argmax(over, axis=0)
        # fine: per group the samples from the coarse one before the crossing to it
        lo = np.where(wc > 0, n_c[np.maximum(wc - 1, 0)], k)  # k: the start is u itself
        idx = np.minimum(lo[:, None] + np.arange(_STRIDE + 1), k1)  # (g, S + 1)
        Cf = cumJ[idx] - c_u  # (g, S + 1, 6)
        first_is_u = wc == 0
        Cf[first_is_u, 0] = 0.0
        t_f = (np.einsum("gsj,gj->gs", Cf, R0)
               + np.einsum("gsk,kg->gs", (Cf[..., :, None] * Cf[..., None, :]).reshape(
                   len(groups), _STRIDE + 1, 36), G))
        pos_f = idx.astype(float)
        pos_f[first_is_u, 0] = u
        j = np.maximum(np.argmax(t_f >= dist[:, None], axis=1), 1)
        gi = np.arange(len(groups))
        prev, cur = t_f[gi, j - 1], t_f[gi, j]
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.clip((dist - prev) / (cur - prev), 0.0, 1.0)
        u_cross = np.where(hit, pos_f[gi, j - 1] + frac * (pos_f[gi, j] - pos_f[gi, j - 1]),
                           float(k1))
        return np.where(live, np.minimum(np.maximum(u_leg, u_cross), float(k1)), float(k1))

    def _group_plan(self, keys: tuple[tuple[str, str], ...], rho: dict[str, np.ndarray]
                    ) -> _Groups:
        """For :meth:`_advance`: the clearances ``keys`` grouped by the moving body (the
        deeper of the two) and the joints between them (:class:`_Groups`)."""
        groups: dict[tuple[str, int, int], int] = {}
        of = []
        for a, b in keys:
            if b == "":
                x, lo, hi = a, 0, self._depth(a)
            else:
                da, db = self._depth(a), self._depth(b)
                x = b if db >= da else a
                lo, hi = min(da, db), max(da, db)
            if hi <= lo:
                x, lo, hi = "", 0, 0
            of.append(groups.setdefault((x, lo, hi), len(groups)))
        bodies = [x for x, _, _ in groups]
        unique = sorted(set(bodies))
        mask = np.zeros((len(groups), 6))
        G = np.zeros((36, len(groups)))
        H = np.zeros((36, len(groups)))
        jj, ii = np.meshgrid(np.arange(6), np.arange(6), indexing="ij")  # [j, i]
        for g, (x, lo, hi) in enumerate(groups):
            mask[g, lo:hi] = 1.0
            if not x:
                continue
            m = mask[g]
            R = rho[x] * m
            mm = np.outer(m, m)
            # sum_j C_j sum_{i>j} R_i C_i, and sum_j a_j (2 R_j sum_{i<j} a_i +
            # sum_{i>=j} a_i R_i), as quadratic forms [j, i]
            G[:, g] = (mm * np.where(ii > jj, R[ii], 0.0)).ravel()
            H[:, g] = (mm * (np.where(ii < jj, 2.0 * R[jj], 0.0)
                             + np.where(ii >= jj, R[ii], 0.0))).ravel()
        return _Groups(np.array(of, int), bodies, mask, np.asarray(mask.any(axis=1), bool), G, H, unique,
                       np.array([unique.index(x) for x in bodies], int))

    def _depth(self, body: str) -> int:
        """How many joints move ``body`` (the tool and the carried part: all)."""
        return self.joint_depth.get(body, 6)

    def _sphere(self, body: str, tool_radius_m: float) -> tuple[np.ndarray, float]:
        """Bounding sphere of ``body`` at the arm's current configuration (the one of the last
        :func:`pinocchio.computeJointJacobians`): centre (3,) in the base frame and radius, m.
        The tool and the carried part: the TCP and ``tool_radius_m``."""
        arm = self.arm
        if body == "":
            return np.zeros(3), 0.0
        if body in self._link_sphere:
            joint, c, e = self._link_sphere[body]
            return arm.data.oMi[joint].act(c), e
        return arm.data.oMi[6].act(self._tcp_in_joint6), tool_radius_m

    def _pose_all(self, q: np.ndarray, setup: _Phase, T_tcp_part: np.ndarray, part: str
                  ) -> None:
        """Poses of the links, the tool and the carried part at ``q`` for :meth:`_contacts`."""
        T_tcp = self.arm.fk(q)
        poses = dict(zip(self.bodies, self.arm.link_poses(q, self.links), strict=True))
        poses[setup.gripper] = T_tcp
        if setup.carried:
            poses[part] = T_tcp @ T_tcp_part
        self._poses = poses

    def self_pairs_bodies(self) -> list[tuple[str, str]]:
        return [(self.body[a], self.body[b]) for a, b in self.self_pairs]

    def _contacts(self, setup: _Phase, env: Sequence[str], part: str, tool_env: bool = False
                  ) -> list[CollidingPair]:
        world, tol = self.scene.world, self.scene.tolerance_m
        for b, T in self._poses.items():
            world.set_pose(b, T)
        out = []
        moving = [self.body[ln] for ln in self.moving_links]
        if tool_env:
            moving += [setup.gripper] + ([part] if setup.carried else [])
        for b in moving:
            for o in env:
                if world.in_collision(b, [o], tol):
                    out.append(CollidingPair(b, o))
        tool = [setup.gripper] + ([part] if setup.carried else [])
        for t in tool:
            for ln in self.tool_links:
                if world.in_collision(self.body[ln], [t], tol):
                    out.append(CollidingPair(self.body[ln], t))
        for a, b in self.self_pairs_bodies():
            if world.in_collision(a, [b], tol):
                out.append(CollidingPair(a, b))
        return out


@cache
def _read_urdf(path: Path, flange: str):
    from ..knowledge.robot import read_urdf_arm

    return read_urdf_arm(path, flange)


# ---------------------------------------------------------------------------------------------
# Timing within the joint limits
# ---------------------------------------------------------------------------------------------
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


def _turned(traj: Trajectory) -> Trajectory:
    """``traj`` with the tool turned half a turn about its approach axis (:data:`TURN`)."""
    return Trajectory(t_s=traj.t_s, T_world_gripper=traj.T_world_gripper @ TURN,
                      clamp_force_N=traj.clamp_force_N, phases=traj.phases)


# ---------------------------------------------------------------------------------------------
# For the report: the arm's links posed at given joint angles
# ---------------------------------------------------------------------------------------------
@cache
def _display_arm(robot: Robot) -> tuple[ArmModel, tuple[str, ...], dict[str, CollisionModel]]:
    model = ArmModel(robot, ArmSettings())
    urdf = _read_urdf(Path(robot.urdf_path), robot.flange_link)  # type: ignore[arg-type]
    models = link_models(urdf)
    return model, tuple(ln for ln in urdf.links if ln in models), models


def posed_links(robot: Robot, q_rad: np.ndarray) -> list[tuple[str, CollisionModel, np.ndarray]]:
    """(link name, collision model, world pose (4, 4)) of every link with geometry at
    ``q_rad`` (6,), for drawing the arm."""
    model, links, models = _display_arm(robot)
    poses = model.link_poses(np.asarray(q_rad, float), links)
    return [(ln, models[ln], T) for ln, T in zip(links, poses, strict=True)]


def reach_facts(robot: Robot) -> tuple[np.ndarray, float]:
    """The shoulder's world position (3,) and the reach (the stated one, else measured), m."""
    model, _, _ = _display_arm(robot)
    shoulder = (model.T_world_base @ np.append(model.shoulder_base, 1.0))[:3]
    return shoulder, float(model.reach_m)
