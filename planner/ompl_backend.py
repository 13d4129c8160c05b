"""Rigid-body motion planning in SE(3) with OMPL 2.x (the only module that imports ``ompl``).

The caller supplies a validity callable on a pose (``(4, 4)`` float array, ``T_world_body``)
and gets back the waypoints of a simplified path, or a result saying why there is none. OMPL
itself checks motions only at its own resolution (``resolution_m``); the caller must re-check
the returned path densely (see :mod:`asmplan.planner.motion`).

Notes on the OMPL 2.x nanobind API (see the project's field notes):

* states come from ``space.allocState()``; the validity checker is a plain callable;
* ``SimpleSetup.setup()`` segfaults without start and goal, so it is never called directly
  (``solve`` calls it after start and goal are set);
* ``solve`` is given a ``timedPlannerTerminationCondition`` (a float budget adds ~4 ms);
* seeding: ``ompl.util.RNG.setSeed`` resets the seed generator that every RNG created
  afterwards draws from; a fresh ``SimpleSetup`` (planner, samplers, simplifier) is built
  after it on every call, so the same seed gives the same path. OMPL logs an "already
  started" error when the seed is set a second time in one process; logging is silenced
  during our calls and restored afterwards.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from .rotations import quat_xyzw_from_matrix

PLANNERS: dict[str, Callable[[ob.SpaceInformation], ob.Planner]] = {
    "RRTConnect": og.RRTConnect,
    "RRT": og.RRT,
    "KPIECE1": og.KPIECE1,
    "BKPIECE1": og.BKPIECE1,
    "LBKPIECE1": og.LBKPIECE1,
    "PRM": og.PRM,
    "PRMstar": og.PRMstar,
    "RRTstar": og.RRTstar,
    "InformedRRTstar": og.InformedRRTstar,
    "SORRTstar": og.SORRTstar,
    "BITstar": og.BITstar,
    "FMT": og.FMT,
    "BFMT": og.BFMT,
    "AORRTC": og.AORRTC,
}
"""Planner names accepted by :func:`plan_se3` (RRTConnect is the default)."""


@dataclass(frozen=True, eq=False)
class SE3Bounds:
    """Axis-aligned bounds of the body origin's position, world frame, m."""

    low_m: np.ndarray
    high_m: np.ndarray

    def __post_init__(self) -> None:
        lo = np.array(self.low_m, dtype=float)
        hi = np.array(self.high_m, dtype=float)
        if lo.shape != (3,) or hi.shape != (3,):
            raise ValueError(f"SE3Bounds: expected two (3,) arrays, found {lo.shape}, {hi.shape}")
        if not np.all(hi > lo):
            raise ValueError(f"SE3Bounds: expected high > low, found low {lo.tolist()}, "
                             f"high {hi.tolist()}")
        lo.setflags(write=False)
        hi.setflags(write=False)
        object.__setattr__(self, "low_m", lo)
        object.__setattr__(self, "high_m", hi)

    def contains(self, p: np.ndarray) -> bool:
        """Whether point ``p`` (3,) lies inside the bounds."""
        return bool(np.all(p >= self.low_m) and np.all(p <= self.high_m))


@dataclass(frozen=True, eq=False)
class OmplResult:
    """Outcome of one OMPL query.

    Attributes
    ----------
    solved : bool
        An exact solution was found.
    status : str
        OMPL's planner status text (e.g. "Exact solution", "Timeout").
    poses : (N, 4, 4) float array
        Waypoints of the simplified path (start first, goal last) when solved; otherwise the
        best partial path OMPL had (possibly just the start), for evidence.
    planning_time_s : float
        Wall time of ``solve`` plus simplification, s.
    validity_checks : int
        Number of validity-callable calls.
    planner : str
    """

    solved: bool
    status: str
    poses: np.ndarray
    planning_time_s: float
    validity_checks: int
    planner: str


def _simplify(ss: og.SimpleSetup, path: og.PathGeometric) -> None:
    """Shorten a solved path in place, deterministically and bounded: drop vertices that can be
    skipped, then merge close ones (simplifyMax would also smooth, at ~10x the validity checks)."""
    ps = ss.getPathSimplifier()
    ps.reduceVertices(path)
    ps.collapseCloseVertices(path)
    ps.reduceVertices(path)

@dataclass(frozen=True, eq=False)
class _Outcome:
    """What :func:`_query` found: ``values`` are the path's waypoints (start and goal exactly
    when solved; the best partial path, at least the start, when not); ``direct`` when the
    straight motion was valid (no search ran)."""

    status: str
    solved: bool
    values: list[np.ndarray]
    elapsed_s: float
    checks: int
    direct: bool = False


def _query(make_space: Callable[[], Any], low: np.ndarray, high: np.ndarray, resolution: float,
           state_valid: Callable[[Any], bool], fill_start: Callable[[Any], None],
           fill_goal: Callable[[Any], None], value_of: Callable[[Any], np.ndarray],
           ends: tuple[np.ndarray, np.ndarray], *, planner: str, seed: int, time_budget_s: float,
           try_direct: bool, simplify: bool) -> _Outcome:
    """One seeded, silenced OMPL query on a bounded space, shared by :func:`plan_se3` and
    :func:`plan_joint` (which differ only in the space and how a state reads and is set):
    the straight motion first when ``try_direct``, else a timed search and, when solved and
    ``simplify``, :func:`_simplify`. ``ends`` are the start and goal values: a solved path
    begins and ends on them exactly (a state's round trip, e.g. through a quaternion, changes
    the last bits)."""
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    try:
        ou.RNG.setSeed(int(seed) & 0x7FFFFFFF or 1)
        space = make_space()
        b = ob.RealVectorBounds(len(low))
        for i in range(len(low)):
            b.setLow(i, float(low[i]))
            b.setHigh(i, float(high[i]))
        space.setBounds(b)
        ss = og.SimpleSetup(space)
        calls = [0]

        def checker(state: Any) -> bool:
            calls[0] += 1
            return state_valid(state)

        ss.setStateValidityChecker(checker)
        si = ss.getSpaceInformation()
        si.setStateValidityCheckingResolution(min(1.0, resolution / space.getMaximumExtent()))
        start = space.allocState()
        goal = space.allocState()
        fill_start(start)
        fill_goal(goal)
        ss.setStartAndGoalStates(start, goal)
        ss.setPlanner(PLANNERS[planner](si))
        t0 = time.perf_counter()
        if try_direct:
            si.setup()  # start and goal are set: safe (see the module docstring)
            if si.isValid(start) and si.checkMotion(start, goal):
                return _Outcome("direct motion valid", True, [ends[0].copy(), ends[1].copy()],
                                time.perf_counter() - t0, calls[0], direct=True)
        status = ss.solve(ob.timedPlannerTerminationCondition(float(time_budget_s)))
        solved = bool(ss.haveExactSolutionPath())
        values: list[np.ndarray] = []
        if ss.haveSolutionPath():
            path = ss.getSolutionPath()
            if solved and simplify:
                _simplify(ss, path)
            values = [value_of(s) for s in path.getStates()]
        elapsed = time.perf_counter() - t0
    finally:
        ou.setLogLevel(level)
    if not values:
        values = [ends[0]]
    if solved:
        values[0] = ends[0].copy()
        values[-1] = ends[1].copy()
    return _Outcome(str(status), solved, values, elapsed, calls[0])


def _set_state(state: ob.SE3State, T: np.ndarray) -> None:
    q = quat_xyzw_from_matrix(T[:3, :3])
    state.setXYZ(float(T[0, 3]), float(T[1, 3]), float(T[2, 3]))
    rot = state.rotation()
    rot.x, rot.y, rot.z, rot.w = (float(v) for v in q)


def pose_from_xyz_quat(x: float, y: float, z: float, qx: float, qy: float, qz: float,
                       qw: float) -> np.ndarray:
    """Homogeneous transform (4, 4) from a position (m) and a unit quaternion (x, y, z, w)."""
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
    xx, yy, zz = qx * qx, qy * qy, qz * qz
    xy, xz, yz, wx, wy, wz = qx * qy, qx * qz, qy * qz, qw * qx, qw * qy, qw * qz
    return np.array([
        [1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy), x],
        [2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx), y],
        [2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy), z],
        [0.0, 0.0, 0.0, 1.0],
    ])


def _state_pose(state: ob.SE3State) -> np.ndarray:
    r = state.rotation()
    return pose_from_xyz_quat(state.getX(), state.getY(), state.getZ(), r.x, r.y, r.z, r.w)


def plan_se3(
    is_valid: Callable[[np.ndarray], bool],
    T_start: np.ndarray,
    T_goal: np.ndarray,
    bounds: SE3Bounds,
    *,
    planner: str = "RRTConnect",
    time_budget_s: float = 1.0,
    seed: int = 0,
    resolution_m: float = 2e-3,
    simplify: bool = True,
    try_direct: bool = True,
) -> OmplResult:
    """Plan a rigid-body path in SE(3) from ``T_start`` to ``T_goal``.

    Parameters
    ----------
    is_valid : callable
        ``is_valid(T_world_body) -> bool`` for a (4, 4) pose; must be deterministic.
    T_start, T_goal : (4, 4) float arrays
        Start and goal poses of the body; both must lie inside ``bounds``.
    bounds : SE3Bounds
        Position bounds of the body origin, m.
    planner : str
        A key of :data:`PLANNERS`.
    time_budget_s : float
        Wall-time budget of the search, s (simplification is not counted against it).
    seed : int
        Seed of OMPL's random number generators; the same seed and inputs give the same path.
    resolution_m : float
        OMPL's motion-check resolution: the longest segment, in SE(3) distance (m plus rad),
        checked only at its ends.
    simplify : bool
        Shortcut the path: ``reduceVertices``, ``collapseCloseVertices``, ``reduceVertices``
        (deterministic for a given seed).
    try_direct : bool
        First ask OMPL's motion validator (``SpaceInformation.checkMotion``, at
        ``resolution_m``) whether the straight SE(3) motion from start to goal is valid; if so
        that is the path (status "direct motion valid") and no search is run. Easy queries
        then cost one motion check instead of a search and its simplification.

    Returns
    -------
    OmplResult
    """
    if planner not in PLANNERS:
        raise ValueError(f"planner: expected one of {sorted(PLANNERS)}, found {planner!r}")
    if not (time_budget_s > 0 and math.isfinite(time_budget_s)):
        raise ValueError(f"time_budget_s: expected > 0, found {time_budget_s}")
    if not resolution_m > 0:
        raise ValueError(f"resolution_m: expected > 0, found {resolution_m}")
    for label, T in (("T_start", T_start), ("T_goal", T_goal)):
        if not bounds.contains(np.asarray(T)[:3, 3]):
            raise ValueError(f"{label}: position {np.asarray(T)[:3, 3].tolist()} outside the "
                             f"planning bounds {bounds.low_m.tolist()}..{bounds.high_m.tolist()}")

    start, goal = np.asarray(T_start, dtype=float), np.asarray(T_goal, dtype=float)
    out = _query(ob.SE3StateSpace, bounds.low_m, bounds.high_m, resolution_m,
                 lambda state: bool(is_valid(_state_pose(state))),
                 lambda state: _set_state(state, start), lambda state: _set_state(state, goal),
                 _state_pose, (start, goal), planner=planner, seed=seed,
                 time_budget_s=time_budget_s, try_direct=try_direct, simplify=simplify)
    return OmplResult(solved=out.solved, status=out.status, poses=np.array(out.values),
                      planning_time_s=out.elapsed_s, validity_checks=out.checks, planner=planner)


@dataclass(frozen=True, eq=False)
class JointPathResult:
    """A joint-space query's outcome: ``q_rad`` (M, n) waypoints (at least the start)."""

    solved: bool
    status: str
    q_rad: np.ndarray
    planning_time_s: float
    validity_checks: int


def plan_joint(
    is_valid: Callable[[np.ndarray], bool],
    q_start: np.ndarray,
    q_goal: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    *,
    planner: str = "RRTConnect",
    time_budget_s: float = 1.0,
    seed: int = 0,
    resolution_rad: float = 0.01,
    try_direct: bool = True,
) -> JointPathResult:
    """Plan a path in joint space (a box ``lower`` .. ``upper``, rad) from ``q_start`` to
    ``q_goal``; ``is_valid(q)`` must be deterministic. ``resolution_rad`` is the longest
    joint-space segment OMPL checks only at its ends (the caller re-checks the path). Seeding
    and simplification as :func:`plan_se3`."""
    if planner not in PLANNERS:
        raise ValueError(f"planner: expected one of {sorted(PLANNERS)}, found {planner!r}")
    n = len(q_start)

    def q_of(state: Any) -> np.ndarray:
        return np.array([state[i] for i in range(n)])

    def fill(q: np.ndarray) -> Callable[[Any], None]:
        def set_q(state: Any) -> None:
            for i in range(n):
                state[i] = float(q[i])
        return set_q

    start, goal = np.asarray(q_start, dtype=float), np.asarray(q_goal, dtype=float)
    out = _query(lambda: ob.RealVectorStateSpace(n), lower, upper, resolution_rad,
                 lambda state: bool(is_valid(q_of(state))), fill(q_start), fill(q_goal), q_of,
                 (start, goal), planner=planner, seed=seed, time_budget_s=time_budget_s,
                 try_direct=try_direct, simplify=True)
    return JointPathResult(out.solved, out.status, np.array(out.values), out.elapsed_s, out.checks)
