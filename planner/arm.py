"""The cell's arm's kinematics (pinocchio): forward and inverse kinematics, reach, joint limits,
singularities. The ONLY module of asmplan that imports pinocchio.

The arm's collision checks are in :mod:`asmplan.planner.arm_clearance`, its joint-limited
timing in :mod:`asmplan.planner.arm_timing`, and the planning of a step with the arm in
:mod:`asmplan.planner.arm_planner`.

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
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..knowledge.frames import invert
from ..knowledge.model import Robot
from ..parts.arm_links import link_models
from ..parts.cell import HALF_TURN
from ..parts.pieces import CollisionModel
from .settings import ArmSettings

ARM_PREFIX = "arm:"
TURN = HALF_TURN  # a parallel gripper's other way of holding the same grasp
CARRIED = "@carried"
_TWO_PI = 2.0 * math.pi


try:  # numpy's own LAPACK solve without its Python wrapper (the same routine, same bits):
    # np.linalg.solve spends most of a 6x6 solve checking types and setting error states
    from numpy.linalg import _umath_linalg

    def _solve_spd(A: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``np.linalg.solve(A, b)`` for a float (6, 6) ``A`` that cannot be singular
        (``J J^T`` plus a positive damping)."""
        return _umath_linalg.solve1(A, b, signature="dd->d")
except ImportError:  # pragma: no cover - another numpy layout
    _solve_spd = np.linalg.solve  # type: ignore[assignment]


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

    def link_and_tcp_poses(self, q: np.ndarray, links: Sequence[str]
                           ) -> tuple[list[np.ndarray], np.ndarray]:
        """:meth:`link_poses` and :meth:`fk` at ``q`` from one kinematics pass."""
        pin.framesForwardKinematics(self.model, self.data, np.asarray(q, float))
        ids = self._frame_ids.get(tuple(links))
        if ids is None:
            ids = self._frame_ids[tuple(links)] = [self.model.getFrameId(n) for n in links]
        oMf, base = self.data.oMf, self.T_world_base
        tcp = base @ oMf[self.flange_id].homogeneous @ self.T_flange_tcp
        return [base @ oMf[i].homogeneous for i in ids], tcp

    def flange_distance_m(self, T_world_tcp: np.ndarray) -> float:
        """Distance from the shoulder to the flange that puts the TCP at ``T_world_tcp``, m."""
        p = (self.T_base_world @ T_world_tcp @ self.T_tcp_flange)[:3, 3]
        return float(np.linalg.norm(p - self.shoulder_base))

    def manipulability(self, q: np.ndarray) -> float:
        """Yoshikawa's ``sqrt(det(J J^T))`` of the flange Jacobian at ``q``."""
        J = pin.computeFrameJacobian(self.model, self.data, np.asarray(q, float), self.flange_id,
                                     pin.LOCAL_WORLD_ALIGNED)
        return float(abs(np.linalg.det(J)))

    def joint_jacobians(self, q: np.ndarray) -> np.ndarray:
        """The joints' Jacobians (6, 6) at ``q`` in the base frame (pinocchio's
        ``computeJointJacobians``)."""
        return pin.computeJointJacobians(self.model, self.data, q)

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
            dq = J.T @ _solve_spd(J @ J.T + lam_I, err)
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
                    dq = J.T @ _solve_spd(J @ J.T + lam_I, err)
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


@cache
def _read_urdf(path: Path, flange: str):
    from ..knowledge.robot import read_urdf_arm

    return read_urdf_arm(path, flange)


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
