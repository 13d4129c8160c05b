"""The grip's share in the exact fit contact's solve (issues 16 and 17): the pads' normal and
friction impulses solved together with the fit's contact, acting on the part AND the fingers.

Why
---
:class:`~asmplan.sim.feature_contact.HeldFitContact` solves a held pin's contact with its bore
after Bullet's step. Bullet solved the gripper's pads against the part in that step without
the fit's contact, so a wall impulse of the fit moved the part as a free body in the grip:
across the closing axis into one pad (Bullet then pushed it out over the next steps with up
to 10 N against a 0.16 N clamp while the other pad's contact slid off) and about the pad-plane
axes (the pads' pressure moment acted only a step later). Measured: ACCURATE's 0.5 deg tilted
8 mm / 10 um pin turned 0.45 deg in the grip and went in where it jams at 1/8000 s; the 10 mm
pin 5 deg off turned 5.5 deg in the grip. The friction-only share (the model before) cannot
carry either, and rows that moved the part but not the fingers (session 10, six rows welding
the part to the palm) fought Bullet's pads: a pad was pushed 2 mm out of the part.

What
----
Each pad contact point Bullet holds becomes a row of the one solve: its normal (impulse >= 0)
and its two tangents (Coulomb; a pad's points share the friction coefficient times the pad's
normal impulse evenly, :func:`pad_friction_caps`). A row acts on the part's twist and on the
fingers' closing velocity: the fingers are force-controlled prismatic joints, so a pad's
reaction moves its finger (its mass, :attr:`Grip.finger_mass_kg`) and the clamp stays the
commanded force (applied by Bullet's step, which this correction does not touch).
Synchronised jaws (a rack and pinion) move as one: one closing degree of freedom of mass
``2 m_f``; the pair cannot move across the closing axis, so a push across it is carried by the
mechanism between the two pads, as in a real parallel gripper. Floating jaws get a degree of
freedom each.

Bullet's own pad impulses of the step (reported per point) are taken out of the part's and
the fingers' velocities, and the whole set, pads and fit, is solved again exactly
(:func:`asmplan.sim.fit_ldp.least_distance` on the normals, block Gauss-Seidel on the
tangents). A pad point Bullet pushed keeps Bullet's relative normal velocity as its bound
(its penetration recovery kept), a point it did not may close its gap: with no fit contact
the solve returns Bullet's step unchanged. The fingers' corrected velocity is written back
with their positions re-integrated (:meth:`~asmplan.sim.bullet.BulletWorld.set_joint_states`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .bullet import BulletWorld
from .contacts import Contacts
from .fit_ldp import least_distance
from .grip_line import face_contacts, piece_vertices_m

GRIP_TOLERANCE = 0.0
"""The solve's rounds stop when a round changes no impulse by more than this fraction of the
largest (the round cap, ``rounds``, otherwise). 0: only at the exact fixed point (the sweep
moved no impulse and the normal solve returned the last round's), where every further round
would repeat the same arithmetic, so the answer is bit for bit the capped one's. Measured,
1e-6 stopped early in the peg-in-hole golden (BALANCED: peak insertion force 0.340 ->
0.269 N, final position error 0.269 -> 0.261 um) and in none of the seed job's or the
8 mm / 10 um tilted case's solves."""

FRICTION_GAP_M = 0.1e-6
"""Fit contact points closer than this (m) take friction (as the fit contact's own)."""


@dataclass(frozen=True)
class Grip:
    """The gripper holding the part.

    Parameters
    ----------
    body : int
        The gripper's body (its base frame is the TCP frame).
    pad_size_m : (3,) float tuple or None
        A flat pad's box (width, thickness, length), its face at ``face_sign x thickness / 2``
        on its link's y axis: the pads' contact is filled along the line or patch the face
        touches (:mod:`asmplan.sim.grip_line`); None: Bullet's points only.
    held_vertices_m : (n, 3) float array or None
        The held part's vertices in its frame (:func:`~asmplan.sim.grip_line.piece_vertices_m`).
    pad_links : tuple of int
        The fingers' links (joint index = link index).
    closing_axes_tcp : tuple of (3,) tuples
        Each finger's closing direction (its joint's positive travel) in the TCP frame.
    friction : float
        The pads' combined Coulomb coefficient with the part (Bullet's product).
    finger_mass_kg : float
    synchronised : bool
        The jaws move as one (one closing degree of freedom).
    lateral_stiffness_N_per_m : float or None
        Synchronised jaws only: a spring (N/m) on their common shift along the closing axis
        relative to the palm (the cell's compliance there,
        :attr:`~asmplan.sim.gripper.GripperSpec.lateral_stiffness_N_per_m`), a second degree
        of freedom of mass ``2 m_f``; None: rigid across the closing axis.
    coupling : int or None
        The synchronising gear constraint (:meth:`BulletWorld.couple_joints`): holds the
        shift the solve leaves through Bullet's next step.
    """

    body: int
    pad_links: tuple[int, ...]
    closing_axes_tcp: tuple[tuple[float, float, float], ...]
    friction: float
    finger_mass_kg: float
    synchronised: bool = True
    pad_size_m: tuple[float, float, float] | None = None
    face_signs: tuple[float, ...] = (-1.0, 1.0)
    held_vertices_m: np.ndarray | None = None
    lateral_stiffness_N_per_m: float | None = None
    coupling: int | None = None

    def __post_init__(self) -> None:
        if len(self.pad_links) != len(self.closing_axes_tcp) or not self.pad_links:
            raise ValueError(f"Grip: expected one closing axis per pad link, found "
                             f"{len(self.pad_links)} links, {len(self.closing_axes_tcp)} axes")
        if not (math.isfinite(self.finger_mass_kg) and self.finger_mass_kg > 0):
            raise ValueError(f"Grip.finger_mass_kg: expected > 0, found {self.finger_mass_kg}")

    @property
    def compliant(self) -> bool:
        """Synchronised jaws with a spring across the closing axis (a shift DOF)."""
        return self.synchronised and self.lateral_stiffness_N_per_m is not None

    @property
    def dofs(self) -> int:
        """The fingers' degrees of freedom in the solve: synchronised jaws' closing (and,
        :attr:`compliant`, their common shift along finger 1's closing axis), else one a
        finger."""
        if self.synchronised:
            return 2 if self.compliant else 1
        return len(self.pad_links)


@dataclass(frozen=True)
class PadRows:
    """One step's pad contact rows (k points) on the augmented velocity (part's twist (6,),
    then the fingers' closing velocities (``Grip.dofs``,)).

    Attributes
    ----------
    normal : (k, 6 + f) float array
        Relative normal velocity rows (separating positive).
    bound : (k,) float array
        Least relative normal velocity (besides the palm's, already subtracted), m/s.
    tangent : (k, 2, 6 + f) float array
    tangent_target : (k, 2) float array
        The palm's tangential velocity at each point (sticking target), m/s.
    bullet_normal, bullet_tangent : (k,), (k, 2) float arrays
        Bullet's impulses of the step, N s.
    finger_velocity : (f,) float array
        The fingers' closing velocities after Bullet's step, m/s.
    pad : (k,) int array or None
        Each point's pad (index into ``Grip.pad_links``): the pad's friction capacity is
        shared by its points (:func:`pad_friction_caps`); None: a cone per point.
    shift_m : float
        :attr:`Grip.compliant`: the jaws' common shift along finger 1's closing axis after
        Bullet's step, m (half the travel difference).
    """

    normal: np.ndarray
    bound: np.ndarray
    tangent: np.ndarray
    tangent_target: np.ndarray
    bullet_normal: np.ndarray
    bullet_tangent: np.ndarray
    finger_velocity: np.ndarray
    pad: np.ndarray | None = None
    shift_m: float = 0.0


def cross_rows(a: np.ndarray, b: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Row-wise cross product of (k, 3) arrays, ``np.cross``'s arithmetic (the same bits)
    without its overhead (it dominates at k ~ 10), into ``out`` (k, 3) when given."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    if out is None:
        out = np.empty((a.shape[0], 3))
    out[:, 0] = a1 * b2 - a2 * b1
    out[:, 1] = a2 * b0 - a0 * b2
    out[:, 2] = a0 * b1 - a1 * b0
    return out


_HELPER_X = np.array([[1.0, 0.0, 0.0]])
_HELPER_Y = np.array([[0.0, 1.0, 0.0]])


def tangent_rows(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangents (k, 3) each of unit normals ``n`` (k, 3), the fit contact's
    (:class:`~asmplan.sim.feature_contact.HeldFitContact`)."""
    helper = np.where(np.abs(n[:, :1]) < 0.9, _HELPER_X, _HELPER_Y)
    t1 = cross_rows(n, helper)
    t1 /= np.sqrt(np.sum(t1 * t1, axis=1))[:, None]
    return t1, cross_rows(n, t1)


def synchronised_grip(world: BulletWorld, gripper_body: int, pad_links: tuple[int, ...],
                      friction: float, finger_mass_kg: float,
                      pad_size_m: Sequence[float] | None, held_body: int,
                      lateral_stiffness_N_per_m: float | None = None,
                      coupling: int | None = None) -> Grip:
    """The :class:`Grip` of a synchronised parallel gripper (finger 1 closing along the TCP's
    -y, finger 2 along +y), its pads' faces filled against ``held_body``'s pieces (and its
    lateral spring, :attr:`Grip.lateral_stiffness_N_per_m`)."""
    size = None if pad_size_m is None else (float(pad_size_m[0]), float(pad_size_m[1]),
                                            float(pad_size_m[2]))
    return Grip(gripper_body, pad_links, ((0.0, -1.0, 0.0), (0.0, 1.0, 0.0)), friction,
                float(finger_mass_kg), True, size, (-1.0, 1.0),
                piece_vertices_m(world.body_pieces(held_body)),
                None if lateral_stiffness_N_per_m is None else float(lateral_stiffness_N_per_m),
                coupling)


def _tangents(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = cross_rows(n, helper)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    return t1, cross_rows(n, t1)


def _line_points(world: BulletWorld, grip: Grip, T_held: np.ndarray, links: np.ndarray,
                 dt: float, gripper: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                           np.ndarray]
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each touching pad's face contact with the held part at its pre-step pose
    (:func:`~asmplan.sim.grip_line.face_contacts`): points (m, 3), outward face normals
    (m, 3), gaps before the step (m,) and pad index (m,); ``gripper``: its pose, linear and
    angular velocity, centre of mass and the fingers' closing velocities (:func:`pad_rows`)."""
    if grip.pad_size_m is None or grip.held_vertices_m is None:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=int)
    W, t, L = grip.pad_size_m
    V = grip.held_vertices_m @ T_held[:3, :3].T + T_held[:3, 3]
    T_g, v_g, w_g, com_g, qd = gripper
    pts, nrm, gaps, idx = [], [], [], []
    for i, link in enumerate(grip.pad_links):
        if link not in links:
            continue
        T_l = world.pose(grip.body, link)
        sign = grip.face_signs[i]
        n_out = T_l[:3, 1] * sign
        centre = T_l[:3, 3] + n_out * (t / 2.0)
        R_face = np.column_stack([T_l[:3, 0], T_l[:3, 2], n_out])
        p, gap = face_contacts(V, centre, R_face, (W / 2.0, L / 2.0), 50e-6)
        if p.shape[0] == 0:
            continue
        d_l = T_g[:3, :3] @ np.asarray(grip.closing_axes_tcp[i], dtype=float)
        v_pad = v_g + cross_rows(np.broadcast_to(w_g, p.shape), p - com_g) + qd[i] * d_l
        pts.append(p)
        nrm.append(np.broadcast_to(n_out, p.shape))
        gaps.append(gap + dt * (v_pad @ n_out))
        idx.append(np.full(p.shape[0], i))
    if not pts:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=int)
    return np.vstack(pts), np.vstack(nrm), np.concatenate(gaps), np.concatenate(idx)


def pad_rows(world: BulletWorld, grip: Grip, held_body: int, c_held: np.ndarray, u: np.ndarray,
             dt: float, T_held: np.ndarray | None = None) -> PadRows | None:
    """The rows of the pad contact points Bullet holds with the held body after its step
    (``u`` (6,): the body's twist then; ``c_held`` (3,): its centre of mass before the step),
    with each touching pad's face contact filled (``T_held``: the body's pose before the
    step), or None when no pad touches it."""
    con = world.contacts(held_body, grip.body)
    on_pad = np.isin(con.link_b, grip.pad_links)
    if not np.any(on_pad):
        return None
    con = con.select(on_pad)
    T_g = world.pose(grip.body)
    v_g, w_g = world.velocity(grip.body)
    com_g = world.com_position_m(grip.body)
    q_f, qd = world.joint_states(grip.body, grip.pad_links)
    if T_held is not None:
        lp, ln, lg, li = _line_points(world, grip, T_held, np.unique(con.link_b), dt,
                                      (T_g, v_g, w_g, com_g, qd))
        m = lp.shape[0]
        if m:
            con = Contacts(
                np.concatenate([con.body_b, np.full(m, grip.body)]),
                np.concatenate([con.link_a, np.full(m, -1)]),
                np.concatenate([con.link_b, np.asarray(grip.pad_links)[li]]),
                np.vstack([con.position_on_a_m, lp]), np.vstack([con.position_on_b_m, lp]),
                np.vstack([con.normal_on_b, ln]), np.concatenate([con.distance_m, lg]),
                np.concatenate([con.normal_force_N, np.zeros(m)]),
                np.vstack([con.friction_on_a_N, np.zeros((m, 3))]))
    k = con.count
    f = grip.dofs
    R = T_g[:3, :3]
    axes = np.asarray(grip.closing_axes_tcp, dtype=float) @ R.T  # (links, 3) world
    link_index = {link: i for i, link in enumerate(grip.pad_links)}
    which = np.array([link_index[int(b)] for b in con.link_b])
    n = con.normal_on_b  # on the part, from the pad
    p = con.position_on_a_m
    r = p - c_held
    v_palm = v_g + cross_rows(np.broadcast_to(w_g, p.shape), p - com_g)
    dof = np.zeros(k, dtype=int) if grip.synchronised else which
    finger_velocity = np.array([float(np.mean(qd))]) if grip.synchronised else qd.copy()
    shift = 0.0
    if grip.compliant:  # q = c + s for finger 1, c - s for finger 2: s along finger 1's axis
        finger_velocity = np.array([float(np.mean(qd)), 0.5 * float(qd[0] - qd[1])])
        shift = 0.5 * float(q_f[0] - q_f[1])

    def rows(d: np.ndarray) -> np.ndarray:
        out = np.zeros((k, 6 + f))
        out[:, :3] = d
        out[:, 3:6] = cross_rows(r, d)
        out[np.arange(k), 6 + dof] = -np.sum(d * axes[which], axis=1)
        if grip.compliant:
            out[:, 7] = -(d @ axes[0])
        return out

    J = rows(n)
    t1, t2 = _tangents(n)
    T = np.stack([rows(t1), rows(t2)], axis=1)
    x = np.concatenate([u, finger_velocity])
    achieved = J @ x - np.sum(n * v_palm, axis=1)
    lam_b = con.normal_force_N * dt
    bound = np.where(lam_b > 0.0, achieved, np.minimum(achieved, -con.distance_m / dt))
    bound = bound + np.sum(n * v_palm, axis=1)
    fr = con.friction_on_a_N * dt
    p_b = np.column_stack([np.sum(fr * t1, axis=1), np.sum(fr * t2, axis=1)])
    target = np.column_stack([np.sum(t1 * v_palm, axis=1), np.sum(t2 * v_palm, axis=1)])
    return PadRows(J, bound, T, target, lam_b, p_b, finger_velocity, which, shift)


def pad_friction_caps(mu: np.ndarray, lam: np.ndarray, k: int, pad: np.ndarray | None
                      ) -> np.ndarray:
    """Each row's friction bound (k + kp,): ``mu x`` its normal impulse for the fit's k rows;
    a pad's points share their pad's ``mu x`` total normal impulse evenly (``pad`` (kp,):
    each point's pad; None: ``mu x`` its own, a cone per point).

    Why: a flat pad's points on one line or patch carry a statically indeterminate normal
    load, and the exact normal solve returns a vertex of its solution set: one point per pad
    carries it all, a different one from round to round as the friction changes. With a cone
    per point the friction the last sweep built sat on points the next normal solve had
    unloaded, was cut to zero and started again: the 0.05 mm-off bundled peg (across the
    closing axis, BALANCED with the rows) slid 1.2 mm down its pads under its 0.24 N weight
    against 0.67 N of capacity (friction 0.01-0.4 N), 1.1 mm with 60 rounds; angle_bracket's
    knob chattered across the closing axis and left its post (docs/physics.md). Evenly shared
    is the uniformly loaded face the pads' torsional friction already assumes
    (``pad_torsion_radius_m``): slip 0.041 mm, the knob seated."""
    cap = mu * lam
    if pad is None:
        return cap
    for i in np.unique(pad).tolist():
        rows = k + np.flatnonzero(pad == i)
        cap[rows] = mu[rows] * (lam[rows].sum() / rows.size)
    return cap


@dataclass(frozen=True)
class GripSolution:
    """The solve's result: the part's twist (6,), the fingers' closing velocities (f,), the
    fit's normal (k,) and tangent (k, 2) impulses along ``t1``, ``t2`` (k, 3 each), the pads'
    normal (kp,) impulses, N s, and the fingers' velocities Bullet's step left (f,)."""

    twist: np.ndarray
    finger_velocity: np.ndarray
    fit_normal: np.ndarray
    fit_tangent: np.ndarray
    pad_normal: np.ndarray
    t1: np.ndarray | None = None
    t2: np.ndarray | None = None
    bullet_finger_velocity: np.ndarray | None = None


def grip_share(world: BulletWorld, grip: Grip, held_body: int, points: np.ndarray,
               normals: np.ndarray, gaps: np.ndarray, mu: np.ndarray, T_held: np.ndarray,
               c_held: np.ndarray, u: np.ndarray, Minv_sqrt: np.ndarray, dt: float,
               rounds: int) -> GripSolution | None:
    """The held body's step solved with its fit contact (``points``, ``normals`` pushing the
    body, ``gaps`` before the step, (k, 3), (k, 3), (k,); Coulomb coefficients ``mu`` (k,))
    and its grip together (:func:`pad_rows`, :func:`solve_with_pads`); ``T_held`` (4, 4) and
    ``c_held`` (3,): its pose and centre of mass before the step, ``u`` (6,) its twist after
    Bullet's step. None when no pad touches the body or the solve fails (the caller then
    solves the fit alone)."""
    r = points - c_held
    Jn = np.hstack([normals, cross_rows(r, normals)])
    pads = pad_rows(world, grip, held_body, c_held, u, dt, T_held)
    if pads is None:
        return None
    t1, t2 = _tangents(normals)
    Jt = np.stack([np.hstack([t1, cross_rows(r, t1)]), np.hstack([t2, cross_rows(r, t2)])],
                  axis=1)
    solved = solve_with_pads(Jn, -gaps / dt, Jt, mu, gaps <= FRICTION_GAP_M, u, Minv_sqrt,
                             pads, grip, rounds, dt)
    if solved is None:
        return None
    return GripSolution(solved.twist, solved.finger_velocity, solved.fit_normal,
                        solved.fit_tangent, solved.pad_normal, t1, t2, pads.finger_velocity)


def solve_with_pads(Jn: np.ndarray, fit_bound: np.ndarray, Jt: np.ndarray, fit_mu: np.ndarray,
                    touching: np.ndarray, u: np.ndarray, Minv_sqrt: np.ndarray, pads: PadRows,
                    grip: Grip, rounds: int, dt: float = 0.0) -> GripSolution | None:
    """The fit's contact (normal rows ``Jn`` (k, 6) with ``Jn u' >= fit_bound``, tangent rows
    ``Jt`` (k, 2, 6), coefficients ``fit_mu`` (k,), friction only where ``touching``) and the
    pads' (:class:`PadRows`) solved together on the part (``u`` (6,), ``Minv_sqrt`` (6, 6) its
    inverse mass's square root) and the fingers: the exact normal solve alternated ``rounds``
    times with a Gauss-Seidel sweep of every tangent. When the normal solve is infeasible the
    pads yield: each pad row ``J_i x >= b_i`` becomes ``J_i x + lam_i / M >= b_i``, ``M`` the
    fingers' closing mass (as if the row's own impulse ``lam_i`` moved the fingers along its
    normal, across the closing axis too); None when it is infeasible even so. A part fixed across the
    closing axis both by the pads' V-grooves and by its bores has no rigid solution once the
    two disagree (Bullet's pad rows keep their penetration recovery, the fit none): the
    gearbox shaft entering bearing_1 on its prism jaws, every few steps. A real cell's robot
    and fingers yield there; solved as infeasible it fell back to the fit alone (jammed 77 mm
    in, 6.9 deg), read as feasible (round-off, :func:`~asmplan.sim.fit_ldp.least_distance`)
    it gave impulses of 1e10 N s.

    :attr:`Grip.compliant` jaws: their shift ``s`` (:attr:`PadRows.shift_m`) is a degree of
    freedom of mass ``m = 2 m_f`` on a spring ``k`` integrated implicitly over ``dt``:
    ``(m + k dt^2) v' = m v - dt k s + P`` (P the pads' impulses on it), so the solve sees the
    mass ``m + k dt^2`` and the free velocity ``(m v - dt k s) / (m + k dt^2)``; Bullet's pad
    impulses of the step went into the coupling (which held the shift), so the shift's
    velocity after Bullet's step is its velocity before them."""
    f = grip.dofs
    m = 6 + f
    k, kp = Jn.shape[0], pads.normal.shape[0]
    S = np.zeros((m, m))
    S[:6, :6] = Minv_sqrt
    mass = grip.finger_mass_kg * (len(grip.pad_links) if grip.synchronised else 1)
    S[6:, 6:] = np.eye(f) / math.sqrt(mass)
    k_lat = grip.lateral_stiffness_N_per_m if grip.compliant else None
    if k_lat is not None:
        m_s = mass + k_lat * dt * dt
        S[7, 7] = 1.0 / math.sqrt(m_s)
    Minv = S @ S
    pad = np.zeros((k, m))
    pad[:, :6] = Jn
    J = np.vstack([pad, pads.normal])
    bound = np.concatenate([fit_bound, pads.bound])
    tan = np.zeros((k, 2, m))
    tan[:, :, :6] = Jt
    Tall = np.concatenate([tan, pads.tangent], axis=0)  # (k + kp, 2, m)
    t_target = np.concatenate([np.zeros((k, 2)), pads.tangent_target], axis=0)
    MT = np.einsum("ab,kib->kai", Minv, Tall)  # (k + kp, m, 2)
    W = np.einsum("kib,kbj->kij", Tall, MT)
    Winv = np.linalg.inv(W + 1e-300 * np.eye(2)[None])
    mu = np.concatenate([fit_mu * touching, np.full(kp, grip.friction)])
    # Bullet's pad impulses out: the velocity before they acted
    x0 = np.concatenate([u, pads.finger_velocity])
    x0 = x0 - Minv @ (pads.normal.T @ pads.bullet_normal)
    x0 = x0 - np.einsum("kai,ki->a", MT[k:], pads.bullet_tangent)
    if k_lat is not None:
        x0[7] = (mass * pads.finger_velocity[1] - dt * k_lat * pads.shift_m) / m_s
    q = np.concatenate([np.zeros((k, 2)), pads.bullet_tangent], axis=0)
    rows = (list(Tall), list(MT), list(Winv), list(t_target))  # per-row views, listed once
    G = J @ S
    slack = np.zeros((k + kp, kp))
    slack[k:] = np.eye(kp) / math.sqrt(mass)
    lam = np.zeros(k + kp)
    x = x0
    dq = math.inf
    for rnd in range(rounds):
        x_f = x0 + np.einsum("kai,ki->a", MT, q)
        h = bound - J @ x_f
        sol = least_distance(G, h)
        if sol is None:  # the pads yield (above)
            soft = least_distance(np.hstack([G, slack]), h)
            if soft is None:
                return None
            sol = (soft[0][:m], soft[1])
        y, lam_new = sol
        x = x_f + S @ y
        # converged: the last sweep and this normal solve changed no impulse by more than
        # GRIP_TOLERANCE of the largest (the next rounds would repeat them)
        scale = max(float(np.abs(lam_new).max(initial=0.0)), float(np.abs(q).max(initial=0.0)))
        change = max(dq, float(np.abs(lam_new - lam).max(initial=0.0)))
        lam = lam_new
        if rnd == rounds - 1 or change <= GRIP_TOLERANCE * scale:
            break
        cap = pad_friction_caps(mu, lam, k, pads.pad)
        active = np.flatnonzero((cap > 0) | np.any(q != 0.0, axis=1)).tolist()
        q_new, x = _sweep(active, x, list(q), cap.tolist(), rows)
        dq = float(np.abs(q_new - q).max(initial=0.0))
        q = q_new
    # what the last normal solve bears (the velocity keeps the sweep's impulses, as the fit
    # contact's own solve does)
    norm = np.linalg.norm(q, axis=1)
    cap = pad_friction_caps(mu, lam, k, pads.pad)
    over = norm > cap
    if np.any(over):
        q[over] *= (cap[over] / np.maximum(norm[over], 1e-300))[:, None]
    return GripSolution(x[:6], x[6:], lam[:k], q[:k], lam[k:])


def _sweep(active: list[int], x: np.ndarray, q: list[np.ndarray], cap: list[float],
           rows: tuple[list[np.ndarray], ...]) -> tuple[np.ndarray, np.ndarray]:
    """One Gauss-Seidel sweep of the tangent rows ``active``: each row's impulse ``q[i]`` (2,)
    made to stick (``rows``: its rows, their ``Minv``-products, its 2 x 2 inverse and its
    target), clipped to its cone ``cap[i]``. Returns the impulses (n, 2) and the velocity
    after the sweep (the same arithmetic as numpy row by row, on listed views)."""
    Tall, MT, Winv, target = rows
    for i in active:
        old = q[i]
        new = old - Winv[i] @ (Tall[i] @ x - target[i])
        a, b = new.tolist()
        norm = math.hypot(a, b)
        if norm > cap[i]:
            new = new * (cap[i] / norm) if norm > 0 else new * 0.0
        x = x + MT[i] @ (new - old)
        q[i] = new
    return np.array(q), x


def apply_fingers(world: BulletWorld, grip: Grip, solved: GripSolution, dt: float) -> None:
    """Write the fingers' corrected closing velocity back, their positions re-integrated with
    the change (Bullet integrated them with its own velocity)."""
    if solved.bullet_finger_velocity is None:
        return
    dv = solved.finger_velocity - solved.bullet_finger_velocity
    if not np.any(dv) and not grip.compliant:
        return
    q, qd = world.joint_states(grip.body, grip.pad_links)
    if grip.compliant:  # closing and shift (finger 1 + s, finger 2 - s)
        delta = np.array([float(dv[0] + dv[1]), float(dv[0] - dv[1])])
    else:
        delta = np.full(len(grip.pad_links), float(dv[0])) if grip.synchronised else dv
    q_new = q + dt * delta
    world.set_joint_states(grip.body, grip.pad_links, q_new.tolist(), (qd + delta).tolist())
    if grip.compliant and grip.coupling is not None:
        world.set_coupling_offset(grip.coupling, float(q_new[0] - q_new[1]))


__all__ = ["Grip", "GripSolution", "PadRows", "apply_fingers", "cross_rows", "grip_share",
           "pad_friction_caps", "pad_rows", "solve_with_pads", "synchronised_grip",
           "tangent_rows"]
