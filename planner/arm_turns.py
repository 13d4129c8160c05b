"""The tool turn chosen over the whole sequence, not one step at a time.

A parallel gripper holds a grasp the same way turned half a turn about its approach axis
(:data:`asmplan.parts.cell.HALF_TURN`); the arm then reaches it with joint 6 half a turn
further (exactly, when the TCP lies on joint 6's axis: the mounting is a translation along
and a rotation about the flange's z axis). Step by step, :meth:`ArmPlanner.plan_step` takes
the variant nearest the arm's last state (greedy). That can cost later: a step that starts
half a wrist turn away from where the greedy choice left the arm.

:func:`best_turns` is a small dynamic programme over the steps: per step the variants (as
planned, joint 6 half a turn on or back where its limits allow), the cost of a pair of
neighbouring steps the rest-to-rest joint move from one's last state to the next one's first
(:func:`asmplan.planner.arm_timing.joint_move_s`; a step's own trajectory takes the same
time either way, its joint velocities being the same). :func:`retune_turns` applies the
programme's choice to the planned steps and proves it again: every changed step's joint path
is checked for collisions (joint 6 moves the wrist links and the flange) and every transfer
whose ends changed is certified or planned again (:meth:`ArmPlanner._transfer`); when any of
it fails, or the certified transfers do not add up to less time than the greedy ones, the
greedy steps are kept.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..knowledge.frames import invert
from ..parts.cell import HALF_TURN
from .arm_timing import joint_move_s
from .errors import ArmError
from .plan import Step, state_before
from .trajectory import Trajectory

if TYPE_CHECKING:
    from .motion import MotionPlanner


def best_turns(variants: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]],
               move_s: Callable[[np.ndarray, np.ndarray], float]) -> tuple[list[int], float]:
    """The variant per step that minimises the sum of the moves between steps.

    Parameters
    ----------
    variants : per step, its variants as (first state, last state), joint angles (6,), rad;
        variant 0 is the step as planned.
    move_s : the time of the move from a last state to the next step's first, s.

    Returns
    -------
    choice : the variant index per step (ties: the lower index, so "as planned" wins).
    cost_s : the sum of the moves of that choice, s.
    """
    if not variants:
        return [], 0.0
    cost = [0.0] * len(variants[0])
    back: list[list[int]] = []
    for k in range(1, len(variants)):
        new: list[float] = []
        arg: list[int] = []
        for start, _end in variants[k]:
            via = [cost[u] + move_s(variants[k - 1][u][1], start)
                   for u in range(len(variants[k - 1]))]
            best = 0
            for u in range(1, len(via)):  # ties: the lower index
                if round(via[u], 9) < round(via[best], 9):
                    best = u
            new.append(via[best])
            arg.append(best)
        cost, back = new, [*back, arg]
    last = 0
    for v in range(1, len(cost)):
        if round(cost[v], 9) < round(cost[last], 9):
            last = v
    choice = [last]
    for arg in reversed(back):
        choice.append(arg[choice[-1]])
    return choice[::-1], float(cost[last])


def _coaxial(planner: MotionPlanner) -> bool:
    """Whether turning the tool half a turn is joint 6 half a turn (checked by FK at seeded
    configurations: ``FK(q + pi e6) = FK(q) @ HALF_TURN``)."""
    arm = planner.arm.arm  # type: ignore[union-attr]
    rng = np.random.default_rng(0)
    lo, hi = np.maximum(arm.lower, -3.0), np.minimum(arm.upper, 3.0)
    for q in rng.uniform(lo, hi, size=(4, 6)):
        q2 = q.copy()
        q2[5] += math.pi
        if np.abs(arm.fk(q2) - arm.fk(q) @ HALF_TURN).max() > 1e-9:
            return False
    return True


def _flips(planner: MotionPlanner, Q: np.ndarray) -> list[np.ndarray]:
    """``Q`` (N, 6) with joint 6 half a turn on or back, where the whole path keeps its limit
    margin."""
    arm = planner.arm.arm  # type: ignore[union-attr]
    m = planner.settings.arm.joint_limit_margin_rad
    out = []
    for shift in (math.pi, -math.pi):
        q6 = Q[:, 5] + shift
        if q6.min() >= arm.lower[5] + m and q6.max() <= arm.upper[5] - m:
            Q2 = Q.copy()
            Q2[:, 5] = q6
            out.append(Q2)
    return out


def _variants(planner: MotionPlanner, steps: Sequence[Step]
              ) -> tuple[list[int], list[list[np.ndarray]]]:
    """The arm steps' indices and, per arm step, its joint paths: as planned, then joint 6
    half a turn on or back where the limits allow."""
    idx = [k for k, s in enumerate(steps) if s.arm is not None]
    return idx, [[np.asarray(steps[k].arm.q_rad),  # type: ignore[union-attr]
                  *_flips(planner, np.asarray(steps[k].arm.q_rad))]  # type: ignore[union-attr]
                 for k in idx]


def retune_turns(planner: MotionPlanner, steps: Sequence[Step]) -> list[Step]:
    """The planned ``steps`` with the tool turns of :func:`best_turns` (see the module
    docstring); the steps unchanged when the planned choice is as good, or when the new
    choice cannot be proven."""
    steps = list(steps)
    ap = planner.arm
    if ap is None or not planner.settings.arm.plan_tool_turns:
        return steps
    idx, paths = _variants(planner, steps)
    if len(idx) < 2 or not _coaxial(planner):
        return steps
    arm = ap.arm

    def move(a: np.ndarray, b: np.ndarray) -> float:
        return joint_move_s(a, b, arm.vmax, arm.amax)

    choice, _ = best_turns([[(P[0], P[-1]) for P in alts] for alts in paths], move)
    if not any(choice):
        return steps
    try:
        out = apply_turns(planner, steps, choice)
    except ArmError:
        return steps
    old = new = 0.0
    for k in idx:
        a, b = steps[k].arm, out[k].arm
        assert a is not None and b is not None
        old += a.transfer_s
        new += b.transfer_s
    if new >= old - 1e-9:
        return steps
    ap.last_q = np.asarray(out[idx[-1]].arm.q_rad)[-1].copy()  # type: ignore[union-attr]
    return out


# Complexity above C (radon): the choice applied step by step: each turned step re-checked, each
# transfer with a changed end certified again, the scene set to that step's state.
def apply_turns(planner: MotionPlanner, steps: Sequence[Step], choice: Sequence[int]
                ) -> list[Step]:
    """``steps`` with arm step ``j`` on its variant ``choice[j]`` (0: as planned; see
    :func:`_variants`), every changed step's joint path checked for collisions and every
    transfer with a changed end certified or planned again. Raises the
    :class:`~asmplan.planner.errors.ArmError` of the first that fails."""
    steps = list(steps)
    ap = planner.arm
    assert ap is not None
    arm = ap.arm
    idx, paths = _variants(planner, steps)
    product, scene = planner.product, planner.scene
    fixtured = [n for n in product.part_names if product.is_fixtured(n)]
    starts = {n: (product.T_world_assembled(n) if n in fixtured else planner.start_poses[n])
              for n in product.part_names}
    last_q_before = ap.last_q
    out = list(steps)
    try:
        prev_end: np.ndarray | None = None
        prev_changed = False
        for j, k in enumerate(idx):
            s = steps[k]
            motion = s.arm
            assert motion is not None and s.trajectory is not None and s.grasp is not None
            flip = choice[j] != 0
            Q = paths[j][choice[j]]
            if flip or prev_changed:
                state = state_before(steps[: k + 1], starts, fixtured)
                for n, T in state.T_world_part.items():
                    scene.set_part_pose(n, T)
                obstacles = scene.obstacles(s.part)
                g = replace(s.grasp, T_part_gripper=s.grasp.T_part_gripper @ HALF_TURN) \
                    if flip else s.grasp
                T_pg = invert(g.T_part_gripper)
                radius = planner._radius(s.part, T_pg, g)
                traj = s.trajectory
                checked = 0
                if flip:
                    traj = Trajectory(t_s=traj.t_s, T_world_gripper=traj.T_world_gripper
                                      @ HALF_TURN, clamp_force_N=traj.clamp_force_N,
                                      phases=traj.phases)
                    names = [p.name for p in traj.phases]
                    checked = ap._check_path(
                        s.index, s.part, Q, traj.phase_indices_at(traj.t_s), names, T_pg,
                        obstacles, s.T_world_start, s.T_world_final, radius,
                        tool_env_phases=("translate",) if motion.joint_space_translate else ())
                ap.last_q = prev_end
                W, t_s, n_t = ap._transfer(
                    s.index, s.part, Q[0], obstacles, s.T_world_start, s.T_world_final, radius,
                    (planner.settings.planner, planner.settings.time_budget_s,
                     planner.settings.seed))
                margins = np.minimum(Q - arm.lower, arm.upper - Q)
                kk, jj = divmod(int(np.argmin(margins)), 6)
                new_motion = replace(
                    motion, q_rad=Q, tool_turned=motion.tool_turned != flip, transfer_q_rad=W,
                    transfer_s=t_s,
                    checked_states=(checked if flip else motion.checked_states) + n_t,
                    min_limit_margin_rad=float(margins[kk, jj]),
                    limit_margin_joint=arm.joint_names[jj])
                path = s.path_T_world_gripper
                out[k] = replace(s, grasp=g, trajectory=traj, arm=new_motion,
                                 path_T_world_gripper=path if path is None or not flip
                                 else path @ HALF_TURN)
            prev_end = Q[-1]
            prev_changed = flip
    finally:
        after = dict(starts)  # the scene as planning left it: every step's part at its end
        for s in steps:
            after[s.part] = s.T_world_final
        for n, T in after.items():
            scene.set_part_pose(n, T)
        ap.last_q = last_q_before
    return out


__all__ = ["apply_turns", "best_turns", "retune_turns"]
