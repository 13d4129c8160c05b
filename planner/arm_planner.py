"""Plans every step of a plan with the cell's arm: IK along the step's trajectory on every
branch (the tool turned too), joint-space transfers between steps, joint-limited retiming,
and the step's :class:`asmplan.planner.plan.ArmMotion`."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..knowledge.model import Robot
from ..parts.arm_links import link_models
from ..parts.pieces import CollisionModel
from .arm import _TWO_PI, ARM_PREFIX, TURN, ArmModel, IkSolution, _read_urdf
from .arm_clearance import ArmClearance, _Phase
from .arm_timing import joint_move_s, retime
from .errors import ArmCollisionError, ArmPathError, JointLimitError, OutOfReachError
from .plan import ArmMotion
from .settings import ArmSettings
from .trajectory import PhaseSpan, Trajectory


class ArmPlanner(ArmClearance):
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
        variants = _Variants(traj, T_tcp_part)  # the turned tool's built when first tried
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
            timed = retime(tr, Q, self.arm.vmax, self.arm.amax)
            return timed[0].duration_s + transfer[1], (tr, Q, stats, sol, names, checked,
                                                       n_branches, False, transfer, turned,
                                                       timed)

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
                turned: bool = False,
                timed: tuple[Trajectory, np.ndarray] | None = None
                ) -> tuple[Trajectory, ArmMotion]:
        new_traj, scales = timed if timed is not None else retime(traj, Q, self.arm.vmax,
                                                                   self.arm.amax)
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
            from .rotations import rotation_angle_rad

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


class _Variants(dict):
    """``{False: (traj, T_tcp_part), True: (turned traj, TURN @ T_tcp_part)}``, the turned
    variant made when first asked for (a trajectory's validation is not free)."""

    def __init__(self, traj: Trajectory, T_tcp_part: np.ndarray) -> None:
        super().__init__({False: (traj, T_tcp_part)})
        self._traj, self._T = traj, T_tcp_part

    def __missing__(self, turned: bool) -> tuple[Trajectory, np.ndarray]:
        if not turned:  # pragma: no cover - set in __init__
            raise KeyError(turned)
        value = self[True] = (_turned(self._traj), TURN @ self._T)
        return value


def _turned(traj: Trajectory) -> Trajectory:
    """``traj`` with the tool turned half a turn about its approach axis (:data:`TURN`)."""
    return Trajectory(t_s=traj.t_s, T_world_gripper=traj.T_world_gripper @ TURN,
                      clamp_force_N=traj.clamp_force_N, phases=traj.phases)
