"""One steady turn along a planned transfer: the via poses' orientations, levelled.

OMPL's SE(3) search samples the orientation of every via pose at random, and the simplifier
(``reduceVertices``) removes vertices but keeps the orientations of those it cannot skip. A
transfer that needs a via pose (over a wall, around a part) then turns the gripper through
a random orientation and back: on the imported angle bracket the knob's transfer turned
111 deg for no net turn and the second dowel's 228 deg for a 90 deg turn, at up to 1.6 rad/s;
the dowel turned 1.9-3.5 deg in the pads on the way and jammed in its 5 um fit.

:func:`levelled_turns` keeps the via positions and gives the via poses orientations on a
single slerp from the first to the last pose's (what a robot programmer writes: one turn, no
detour), in three schedules: the turn spread over the path's length, made on the last leg
(carried upright to the last via pose) and made on the first leg. The planner certifies them
in that order like any other path (:func:`asmplan.planner.certify.certify_path`), takes the
first that is free and keeps OMPL's own where none is.
"""

from __future__ import annotations

import numpy as np

from .rotations import matrix_from_quat_xyzw, quat_xyzw_from_matrix, slerp_xyzw

LEVEL_TOLERANCE_RAD = 1e-9
"""Via orientations within this of the levelled ones: the path is returned as it is."""


def levelled_turns(poses_T: np.ndarray) -> list[np.ndarray]:
    """The path ``poses_T`` with its via poses turned onto one slerp from start to goal.

    Parameters
    ----------
    poses_T : (N, 4, 4) float array
        Waypoints of a planned path (start first, goal last), world frame.

    Returns
    -------
    list of (N, 4, 4) float arrays
        The same positions, start and goal untouched, the via poses at the orientation
        ``slerp(R_start, R_goal, s)``: ``s`` the fraction of the path's translation
        travelled at that pose (the turn spread over the move), then ``s = 0`` (the turn on
        the last leg) and ``s = 1`` (on the first leg), the same schedules once. Empty when
        there is nothing to level (fewer than three poses, no translation, or via
        orientations already on the spread slerp).
    """
    P = np.asarray(poses_T, float)
    if len(P) < 3:
        return []
    seg_m = np.linalg.norm(np.diff(P[:, :3, 3], axis=0), axis=1)
    total_m = float(np.sum(seg_m))
    if total_m <= 0.0:
        return []
    q = quat_xyzw_from_matrix(P[[0, -1], :3, :3])
    spread = np.cumsum(seg_m)[:-1] / total_m
    out: list[np.ndarray] = []
    for s in (spread, np.zeros_like(spread), np.ones_like(spread)):
        R = matrix_from_quat_xyzw(slerp_xyzw(q[0], q[1], s))
        if not out:
            cos = (np.einsum("nij,nij->n", R, P[1:-1, :3, :3]) - 1.0) / 2.0
            if float(np.max(np.arccos(np.clip(cos, -1.0, 1.0)))) <= LEVEL_TOLERANCE_RAD:
                return []
        if any(np.allclose(R, c[1:-1, :3, :3], rtol=0.0, atol=1e-12) for c in out):
            continue
        T = P.copy()
        T[1:-1, :3, :3] = R
        out.append(T)
    return out
