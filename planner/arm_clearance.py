"""The arm in the planner's FCL scene: its link bodies, the pairs to check, and the collision
check of a joint path by conservative advancement (a mixin of
:class:`asmplan.planner.arm_planner.ArmPlanner`).

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
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..parts.pieces import CollisionModel
from .arm import CARRIED, ArmModel
from .errors import ArmCollisionError, CollidingPair
from .settings import ArmSettings

_ENOUGH_M = 0.02  # exact distances only between bodies whose boxes come closer than this
_STRIDE = 16  # the cross-leg travel bound: every 16th sample first, then the ones between


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


def _sorted_unique(a: np.ndarray) -> np.ndarray:
    """``np.unique`` of small non-negative indices (the same sorted values), by counting:
    called at every checked state, where np.unique's sort costs more than the count."""
    return np.flatnonzero(np.bincount(a))


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


class ArmClearance:
    """The collision checks of :class:`asmplan.planner.arm_planner.ArmPlanner` (its setup
    builds the attributes declared here)."""

    arm: ArmModel
    settings: ArmSettings
    scene: Any
    gripper_closed: str
    gripper_open: str
    models: dict[str, CollisionModel]
    links: list[str]
    static_links: list[str]
    moving_links: list[str]
    joint_depth: dict[str, int]
    body: dict[str, str]
    bodies: list[str]
    link_names: dict[str, str]
    moving_bodies: list[str]
    chain_index: dict[str, int]
    tool_links: list[str]
    self_pairs: list[tuple[str, str]]
    _bounds: tuple[np.ndarray, dict[str, float], float]
    _link_sphere: dict[str, tuple[int, np.ndarray, float]]
    _tcp_in_joint6: np.ndarray
    last_q: np.ndarray | None
    _poses: dict[str, np.ndarray]

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

        def bodies_of_phase(i: int) -> tuple:
            phase = names[i]
            setup = self._phase_setup(phase)
            where = "" if setup.carried else ("start" if phase in ("approach", "transfer")
                                              else "final")
            return setup.carried, setup.gripper, where, phase in tool_env_phases

        # the bodies depend on the phase only: one lookup per phase, not per sample
        pidx = np.asarray(phase_idx[:len(Q)])
        per_phase = {int(i): bodies_of_phase(int(i)) for i in np.unique(pidx)}
        moves = (np.flatnonzero(pidx[1:] != pidx[:-1]) + 1).tolist()
        starts = [0, *[k for k in moves if per_phase[int(pidx[k])] != per_phase[int(pidx[k - 1])]]]
        for b, k0 in enumerate(starts):
            k1 = starts[b + 1] if b + 1 < len(starts) else last
            carried, gripper, where, tool_env = per_phase[int(pidx[k0])]
            setup = _Phase(names[int(phase_idx[k0])], carried, gripper)
            if carried:
                env = list(obstacles)
            else:
                scene.set_part_pose(part, T_start if where == "start" else T_final)
                env = [*obstacles, part]
            tool = [gripper] + ([part] if carried else [])
            items = self._items(setup, part, tool_env)
            keys = [(a if a != part else CARRIED, b if b != part else CARRIED) for a, b in items]
            plan = self._group_plan_cached(tuple(keys), rho, tool_radius_m)
            of = plan.of
            boxes = _BoxTier(scene, [*self.bodies, *tool], env, items)
            until = np.full(len(items), -math.inf)  # certified up to here
            since = np.zeros(len(items))  # from here (where measured)
            u = float(k0)
            while True:
                k = min(int(u), last - 1) if last > 0 else 0
                f = u - k
                q = Q[k] + f * (Q[k + 1] - Q[k]) if last > 0 else Q[0]
                poses, T_tcp = self.arm.link_and_tcp_poses(q, self.links)
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
                todo = np.flatnonzero(exact)
                if len(todo):  # each body of the pairs posed once per state, not per pair
                    world = scene.world
                    for body in {x for i in todo if items[i][1] for x in items[i]}:
                        world.set_pose(body, self._poses[body])
                for i in todo:
                    ia, ib = items[i]
                    d[i] = self._exact(items[i], env) if ib == "" else world.distance(ia, ib)
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
                groups = _sorted_unique(of[idx])
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
        J = self.arm.joint_jacobians(q)  # (6, 6), base frame
        lin, ang = J[:3].T, J[3:].T  # (6, 3) per joint
        # the bounding spheres of the bodies (tool: the TCP, tool_radius_m)
        bi = plan.body_index[groups]
        used = _sorted_unique(bi)
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

    def _group_plan_cached(self, keys: tuple[tuple[str, str], ...],
                           rho: dict[str, np.ndarray], tool_radius_m: float) -> _Groups:
        """:meth:`_group_plan`, kept per (clearances, tool radius): ``rho`` depends on the
        tool radius only, and a plan's stretches repeat the same clearances step after
        step."""
        cache = self.__dict__.setdefault("_group_plans", {})
        key = (keys, float(tool_radius_m))
        hit = cache.get(key)
        if hit is None:
            hit = cache[key] = self._group_plan(keys, rho)
        return hit

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
