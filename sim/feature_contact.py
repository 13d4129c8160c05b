"""Exact feature-level contact between a held pin and its hole during the insertion (issues 16
and 17).

Why
---
Bullet's contact between a pin and its hole is judged on shapes (hull prisms, cylinders with a
margin) through a contact distance (25 um at BALANCED) and solved by projected Gauss-Seidel.
Three measured defects follow: the small-tilt jam depth is too deep (the two wedge normals
nearly oppose, condition ~4/t^2, and the unresolved push penetrates 5-27 um, magnified by
1/sin t: +3.3 mm at 0.5 deg), a chamfer contact is kept across a fit's 8.5 um radial gap
(the chamfered peg 0.02 mm off its axis jams) and an unchamfered pin tips into a hole from the
rim at ACCURATE. The knowledge base knows each mate is a cylinder of given diameters, chamfers,
axis and depth: this module spends the accuracy there.

What
----
:class:`HeldFitContact` switches Bullet's contact between the held body and the hole's body off
(``BulletWorld.set_collision_enabled``) and, after every physics step, solves the contact of
the pin in its bore itself, on the exact geometry of :mod:`asmplan.sim.fit_geometry`:

1. Velocity. Bullet's step gave the held body a velocity u (gravity, the fingers, everything
   else). The contact points found at the body's pose before the step (gaps g >= 0, within a
   search margin covering the step's travel) must not be closed faster than the gap allows:
   J_n u' >= -g / dt. u' is the M-nearest velocity to u meeting them: a least-distance
   problem min |M^(1/2) (u' - u)| s.t. G y >= h, solved EXACTLY (Lawson and Hanson's
   reduction to non-negative least squares, ``scipy.optimize.nnls``, QR based) however nearly
   the normals oppose: the wedge of a peg at 0.5 deg is solved as well as at 5 deg. Its
   multipliers are the normal impulses. Coulomb friction (combined coefficient as Bullet's,
   the product of the two bodies') follows by block Gauss-Seidel on the tangent impulses
   (clamped to mu x the normal impulse), alternated with the exact normal solve
   (:data:`FRICTION_ROUNDS`).
2. Pose. The body is re-integrated from its pre-step pose with u' (as Bullet integrates:
   x + dt v, rotation by dt w), so it never enters the bore's walls; what curvature leaves
   (the linearised gaps) is removed by a position projection of the same kind (no velocity
   change) when any point penetrates more than :data:`PROJECTION_TOLERANCE_M`.
3. The reaction. The contact force on the block is applied to it in the next step when it is
   dynamic.

Scope. Only the pin and the bore of the declared mate are modelled between the two bodies,
plus the part's shoulder (``PinFeature.seat_radius_m``) on the block's face: other geometry of
the same two bodies does not touch while the model is on (:func:`asmplan.sim.execute.execute_step`
switches it on before the step's first physics step: changing a body's collision filter later
drops its contact manifolds, and a gripped part's pads sank 0.2 mm into it). The fingers and
every other body keep Bullet's contact.

The grip. Bullet solves the pads against the held body a step before this model. With
synchronised jaws their normals and friction join this model's solve on the part and the
fingers (:mod:`asmplan.sim.grip_pads`); with floating jaws only their friction, with what
their cones have left (:meth:`HeldFitContact.set_grip`), solved with the fit as one exact
problem (:mod:`asmplan.sim.fit_grip_qp`). Over a dynamic partner (a cap slid
over a loose rod) the held body keeps Bullet's step and the partner takes the correction while
the grip can carry the contact (:meth:`HeldFitContact._partner_moves`). Known limits (measured, open): a
step into free space is kept as Bullet took it; the block's face is a disc out to the
solid's farthest vertex (docs/physics.md, "Exact fit contact")."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..knowledge.frames import rotation_about
from .bullet import BulletWorld
from .contacts import Contacts
from .fit_clear import DeferredReuse
from .fit_forces import SolvedStep, solved_forces
from .fit_geometry import FitContact, FitContactModel
from .fit_grip_qp import solve_fit_with_pad_friction
from .fit_ldp import least_distance
from .fit_memo import LastCall
from .grip_pads import Grip, apply_fingers, cross_rows, grip_share, synchronised_grip, tangent_rows

FRICTION_ROUNDS = 3
"""Alternations of the exact normal solve and the friction sweep per step."""

GRIP_ROUNDS = 10
"""... with a synchronised gripper's pads in the solve (:mod:`asmplan.sim.grip_pads`)."""

PROJECTION_TOLERANCE_M = 0.05e-6
"""Penetration left by the velocity step above which the pose is projected out, m."""

FRICTION_GAP_M = 0.1e-6
"""Contact points closer than this (m) take friction; a point still closing its gap this step
takes it from the next (friction at a point not yet touching would hold the part off it)."""

REUSE_MOTION_M = 1e-6
"""A detection is reused, its gaps updated to first order, while no point of the held body
has moved more than this since it was made, m (the error is second order: < 1e-4 um)."""

REUSE_SLIDE_M = 20e-6
"""... and, for a single-feature detection (``FitContact.single_feature``), while it has slid
at most this along the bore's axis (its gaps do not change under that sliding), m."""

MIN_MARGIN_M = 50e-6
"""Least search margin for contact points, m (plus the step's travel)."""


def _norm(x: np.ndarray) -> float:
    """Euclidean norm of a 1-D float array: ``np.linalg.norm``'s own computation for it,
    sqrt(x . x), without its ~3 us of dispatch (the same bits)."""
    return math.sqrt(float(x.dot(x)))


@dataclass(frozen=True)
class FitPair:
    """One modelled fit of the held body: the ``partner`` body and the geometry; ``held_is_pin``
    says which side the held body is (False: the held body has the bore, e.g. a collar)."""

    partner: int
    model: FitContactModel
    held_is_pin: bool = True


class HeldFitContact:
    """The exact contact of a held body's fits (see the module docstring).

    Parameters
    ----------
    world : BulletWorld
    held_body : int
        The body the gripper carries.
    pairs : sequence of FitPair
        Its fits, with the partner bodies; Bullet's contact between the held body and each
        partner is off while the model is active.
    friction : sequence of float
        Combined Coulomb coefficient of each pair.
    """

    def __init__(self, world: BulletWorld, held_body: int, pairs: Sequence[FitPair],
                 friction: Sequence[float]) -> None:
        if len(pairs) != len(friction) or not pairs:
            raise ValueError(f"HeldFitContact: expected one friction value per pair (>= 1 pair), "
                             f"found {len(pairs)} pairs and {len(friction)} values")
        self.world = world
        self.held_body = held_body
        self.pairs = tuple(pairs)
        self.friction = np.asarray(friction, dtype=float)
        mass, T_link_inertial, inertia_link = world.rigid_properties(held_body)
        self._mass = mass
        self._com_link = T_link_inertial[:3, 3].copy()
        self._minv_sqrt_linear, self._inv_sqrt_inertia_link = _minv_sqrt_parts(mass,
                                                                               inertia_link)
        # a dynamic partner's (mass, link-to-inertial pose, M^(-1/2) parts), read once
        self._partner_inertia: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._partners = sorted({p.partner for p in self.pairs})
        self._dynamic = {b: not world.is_static(b) for b in self._partners}
        self._reach = max(p.model.pin.length_m + p.model.pin.radius_m
                          + p.model.bore.rim_radius_m for p in self.pairs)
        self.active = False
        self._T_prev: np.ndarray | None = None
        self._T_partner: dict[int, np.ndarray] = {}
        self._found: tuple[FitContact, np.ndarray] | None = None
        self._found_margin = 0.0
        self._last = _empty_contacts()
        self._reaction: list[tuple[int, np.ndarray, np.ndarray]] = []
        self._solved: SolvedStep | None = None  # forces not made yet (_forces)
        self.steps_solved = 0
        self.reused = 0
        self._axis: np.ndarray | None = None
        # the last detection: pose, contacts, their pairs, margin and, while not yet made
        # (_stands), None, None and the partners' poses
        self._base: tuple[np.ndarray, FitContact | None, np.ndarray | None, float,
                          dict[int, np.ndarray] | None] | None = None
        self._grip: tuple[int, tuple[int, ...], float] | None = None
        self._grip_rows: Grip | None = None
        self._floating = False  # floating jaws: the pads' friction solved exactly with the fit
        # the same every step while a detection is reused (asmplan.sim.fit_memo)
        self._tangents_of = LastCall(tangent_rows)
        self._base_rows: LastCall[tuple, np.ndarray] = LastCall(self._rows_at_base)
        self._deferred = DeferredReuse(self)
        self.partner_steps = 0  # steps whose correction the partner took (_partner_moves)

    def set_grip(self, gripper_body: int, pad_links: Sequence[int], pad_friction: float,
                 synchronised: bool = False, finger_mass_kg: float = 0.0,
                 pad_size_m: Sequence[float] | None = None, floating: bool = False,
                 lateral_stiffness_N_per_m: float | None = None,
                 coupling: int | None = None) -> None:
        """The gripper whose pads hold the body: their friction takes its share of each step's
        solve (:meth:`_pad_rows`; ``pad_friction`` combined with the body's by product).
        Synchronised jaws (finger 1 closing along -y, finger 2 along +y, ``finger_mass_kg``
        each): normals and friction on the part and fingers, a flat pad's contact
        (``pad_size_m``) filled along its face (:mod:`asmplan.sim.grip_pads`), the jaws on a
        spring across the closing axis when ``lateral_stiffness_N_per_m`` is given (their
        gear constraint ``coupling`` then holds the shift the solve leaves; it starts at 0);
        ``synchronised`` says whether to use those rows. Floating jaws (``floating``, each
        finger on its own force-controlled joint): their friction solved exactly with the fit
        (:mod:`asmplan.sim.fit_grip_qp`)."""
        mu = float(pad_friction) * self.world.lateral_friction(self.held_body)
        self._grip = (int(gripper_body), tuple(int(k) for k in pad_links), mu)
        self._floating = bool(floating) and not synchronised
        if synchronised:
            self._grip_rows = synchronised_grip(self.world, *self._grip, finger_mass_kg,
                                                pad_size_m, self.held_body,
                                                lateral_stiffness_N_per_m, coupling)
            if lateral_stiffness_N_per_m is not None and coupling is not None:
                self.world.set_coupling_offset(coupling, 0.0)

    # ------------------------------------------------------------------ switching
    def activate(self) -> None:
        """Take the pairs' contact over from Bullet (from the body's present pose)."""
        if self.active:
            return
        for b in self._partners:
            self.world.set_collision_enabled(self.held_body, b, False)
        self._T_prev = self.world.pose(self.held_body)
        self._found = None
        self.active = True

    def deactivate(self) -> None:
        """Give the pairs' contact back to Bullet."""
        if self.active:
            for b in self._partners:
                self.world.set_collision_enabled(self.held_body, b, True)
            self.active = False
            self._last = _empty_contacts()
            self._solved = None

    def held_pose_changed(self, T_world_held: np.ndarray) -> None:
        """Tell the model the caller moved the held body (e.g. a scene holding its tilt)."""
        self._T_prev = np.array(T_world_held, dtype=float)
        self._found = None

    # ------------------------------------------------------------------ per step
    def before_step(self) -> None:
        """Apply last step's reaction to dynamic partners (one step late)."""
        if not self.active:
            return
        # a partner may be switched between static and dynamic (asmplan.sim.partner_hold)
        self._dynamic = {b: not self.world.is_static(b) for b in self._partners}
        if any(self._dynamic.values()):
            self._forces()
        for body, force, point in self._reaction:
            if self._dynamic[body]:
                self.world.apply_force(body, -1, force.tolist(), point.tolist())

    def _detect(self, T_held: np.ndarray, margin: float,
                partners: dict[int, np.ndarray] | None = None) -> tuple[FitContact, np.ndarray]:
        """Contacts of every pair (normals pushing the held body) and each point's pair
        (``partners``: their poses, default the present ones)."""
        pts, nrm, gap, owner = [], [], [], []
        single = True
        for i, pair in enumerate(self.pairs):
            T_other = (self._T_partner if partners is None else partners)[pair.partner]
            if pair.held_is_pin:
                fc = pair.model.contacts(T_held, T_other, margin)
                n = fc.normal
            else:
                fc = pair.model.contacts(T_other, T_held, margin)
                n = -fc.normal
            if fc.count:
                single = single and fc.single_feature
                pts.append(fc.point_m)
                nrm.append(n)
                gap.append(fc.gap_m)
                owner.append(np.full(fc.count, i))
        if not gap:
            return (FitContact(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)),
                    np.zeros(0, dtype=int))
        return (FitContact(np.vstack(pts), np.vstack(nrm), np.concatenate(gap), single),
                np.concatenate(owner))

    def _motion(self, T_held: np.ndarray, T0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The held body's motion from ``T0``: its centre of mass's (3,) and the small
        rotation's vector (3,)."""
        dc = T_held[:3, :3] @ self._com_link + T_held[:3, 3] - (
            T0[:3, :3] @ self._com_link + T0[:3, 3])
        dR = T_held[:3, :3] @ T0[:3, :3].T
        dth = 0.5 * np.array([dR[2, 1] - dR[1, 2], dR[0, 2] - dR[2, 0], dR[1, 0] - dR[0, 1]])
        return dc, dth

    def _reuse_ok(self, single: bool, dc: np.ndarray, dth: np.ndarray, margin: float) -> bool:
        """Whether a detection (``single``: its ``single_feature``) made before the motion
        (dc, dth) stands for this one (:data:`REUSE_MOTION_M`, :data:`REUSE_SLIDE_M`)."""
        slide = 0.0
        if single and self._axis is not None:
            slide = float(dc @ self._axis)
        lateral = _norm(dc - slide * (self._axis if self._axis is not None else 0.0))
        return (lateral + self._reach * _norm(dth) <= REUSE_MOTION_M
                and abs(slide) <= REUSE_SLIDE_M and abs(slide) <= 0.25 * margin)

    def _may_reuse(self, T_held: np.ndarray, margin: float) -> bool:
        """Whether :meth:`_detect_near` might reuse the last detection here."""
        base = self._base
        if base is None or base[3] < margin:
            return False
        dc, dth = self._motion(T_held, base[0])
        if base[1] is not None:
            return self._reuse_ok(base[1].single_feature, dc, dth, margin)
        return self._reuse_ok(True, dc, dth, margin) or self._reuse_ok(False, dc, dth, margin)

    def _detect_near(self, T_held: np.ndarray, margin: float) -> tuple[FitContact, np.ndarray]:
        """:meth:`_detect`, or the last detection with its gaps moved to first order while the
        held body has moved less than :data:`REUSE_MOTION_M` since (partners unmoved). A
        detection :meth:`_stands` left undone is made here when its reuse is possible."""
        base = self._base
        if base is not None and base[3] >= margin:
            T0 = base[0]
            dc, dth = self._motion(T_held, T0)
            if base[1] is None and (self._reuse_ok(True, dc, dth, margin)
                                    or self._reuse_ok(False, dc, dth, margin)):
                found0, owner0 = self._detect(T0, base[3], base[4])
                self._base = base = (T0, found0, owner0, base[3], None)
            if base[1] is not None and self._reuse_ok(base[1].single_feature, dc, dth, margin):
                found, owner = base[1], base[2]
                assert owner is not None  # detected together with found
                J = self._base_rows(base)  # the rows at the detection's pose T0
                gap = found.gap_m + J @ np.concatenate([dc, dth])
                self.reused += 1
                return FitContact(found.point_m, found.normal, gap), owner
        found, owner = self._detect(T_held, margin)
        self._base = (T_held.copy(), found, owner, margin, None)
        return found, owner

    def _rows_at_base(self, base: tuple) -> np.ndarray:
        """The rows of a detection ``base`` (:attr:`_base`) at its own pose."""
        T0, found = base[0], base[1]
        c0 = T0[:3, :3] @ self._com_link + T0[:3, 3]
        return self._rows(found.point_m, found.normal, c0)

    def _clear(self, T_held: np.ndarray, margin: float, gap: float) -> bool:
        """True only if every contact :meth:`_detect` finds here has a gap above ``gap``
        (:meth:`FitContactModel.clear_of`, without detecting)."""
        for pair in self.pairs:
            T_other = self._T_partner[pair.partner]
            if not (pair.model.clear_of(T_held, T_other, margin, gap) if pair.held_is_pin
                    else pair.model.clear_of(T_other, T_held, margin, gap)):
                return False
        return True

    def _stands(self, T_prev: np.ndarray, margin: float) -> bool:
        """Keep Bullet's step when the detections of :meth:`after_step` would keep it, proved
        without making them: where a reuse of the last (deferred) detection is possible, by
        :class:`~asmplan.sim.fit_clear.DeferredReuse`; otherwise every contact at the pre-step
        pose has a gap above :data:`FRICTION_GAP_M` (none: the pin is free; all: approaching)
        and none penetrates at the pose Bullet reached. The pre-step detection, which a later step may
        reuse, is left for :meth:`_detect_near` to make if one does (its pose, margin and
        partners kept), so every result is the same, bit for bit."""
        if self._may_reuse(T_prev, margin):
            # the reuse decided without the detection where provable (sim/fit_clear.py)
            T_reused = self._deferred.stands(T_prev, margin, FRICTION_GAP_M, MIN_MARGIN_M)
            if T_reused is None:
                return False
            T_step = T_reused
            self.reused += 1
        else:
            if not self._clear(T_prev, margin, FRICTION_GAP_M):
                return False
            T_step = self.world.pose(self.held_body)
            if not self._clear(T_step, MIN_MARGIN_M, 0.0):
                return False
            self._base = (T_prev.copy(), None, None, margin, dict(self._T_partner))
        self._reaction, self._solved = [], None
        self._last = _empty_contacts()
        self._T_prev = T_step
        self._found = None
        return True

    def after_step(self) -> None:
        """Solve the held body's fit contact for the step Bullet just took (module docstring)."""
        if not self.active or self.world.is_static(self.held_body):
            return  # static: the placed part held where it rests (sim/placed_hold.py)
        assert self._T_prev is not None
        world, dt = self.world, self.world.fidelity.dt_s
        T_prev = self._T_prev
        moved = False
        for b in self._partners:
            if self._dynamic[b] or b not in self._T_partner:
                T = world.pose(b)
                old = self._T_partner.get(b)
                moved = moved or old is None or not np.allclose(T, old, atol=1e-9)
                self._T_partner[b] = T
        v, w = world.velocity(self.held_body)
        R_prev = T_prev[:3, :3]
        c_prev = R_prev @ self._com_link + T_prev[:3, 3]
        travel = dt * (_norm(v) + self._reach * _norm(w))
        margin = MIN_MARGIN_M + 2.0 * travel
        if moved:
            self._base = None
            axes = [p.model.bore_axis_world(self._T_partner[p.partner]) for p in self.pairs]
            self._axis = axes[0] if all(abs(float(a @ axes[0])) > 1.0 - 1e-9
                                        for a in axes) else None
        if self._found is None or self._found_margin < margin or moved:
            if self._stands(T_prev, margin):
                return
            self._found = self._detect_near(T_prev, margin)
            self._found_margin = margin
        found, owner = self._found
        self._reaction, self._solved = [], None
        if found.count == 0:
            self._last = _empty_contacts()
            self._T_prev = world.pose(self.held_body)
            self._found = None
            return
        u = np.concatenate([v, w])
        if float(np.min(found.gap_m)) > FRICTION_GAP_M:
            # approaching: when the step Bullet took meets nothing, it stands. The linearised
            # gaps would stop a point passing beside an edge (a pin's corner entering its bore
            # 0.4 um inside the mouth edge: its gap to that edge points up until the corner is
            # past; the pin stopped in one step from 64 mm/s and the pads, a step behind,
            # sank 0.34 mm into it)
            T_step = world.pose(self.held_body)
            at = (None if self._clear(T_step, MIN_MARGIN_M, 0.0)  # proved: none penetrates
                  else self._detect(T_step, MIN_MARGIN_M)[0])
            if at is None or at.count == 0 or float(np.min(at.gap_m)) >= 0.0:
                self._T_prev = T_step
                self._found = None
                self._last = _empty_contacts()
                return
        Minv_sqrt = self._minv_sqrt(R_prev)
        mu = self.friction[owner]
        if self._partner_moves(found, owner, mu, c_prev, u, dt):
            return
        gripped = (None if self._grip_rows is None else grip_share(
            world, self._grip_rows, self.held_body, found.point_m, found.normal, found.gap_m,
            mu, T_prev, c_prev, u, Minv_sqrt, dt, GRIP_ROUNDS))
        pads = None if gripped is not None else self._pad_rows(c_prev, dt)
        exact = gripped is None and pads is not None and self._floating  # sim/fit_grip_qp.py
        if gripped is None and not exact:
            u_new, lam_n, p_t, t1, t2 = self._solve_velocity(
                found, mu, c_prev, u, Minv_sqrt, dt, pads)
        elif gripped is None:
            assert pads is not None
            t1, t2 = self._tangents_of(found.normal)
            Jt = np.stack([self._rows(found.point_m, t1, c_prev),
                           self._rows(found.point_m, t2, c_prev)], axis=1)
            u_new, lam_n, p_t = solve_fit_with_pad_friction(
                self._rows(found.point_m, found.normal, c_prev), found.gap_m, Jt, mu,
                found.gap_m <= FRICTION_GAP_M, *pads, u, Minv_sqrt, dt)
        else:
            u_new, lam_n, p_t = gripped.twist, gripped.fit_normal, gripped.fit_tangent
            t1, t2 = gripped.t1, gripped.t2
        # re-integrate from the pre-step pose with the corrected velocity
        c_new = c_prev + dt * u_new[:3]
        wn = _norm(u_new[3:])
        R_new = (rotation_about(u_new[3:] / wn, wn * dt) @ R_prev) if wn > 0 else R_prev
        T_new = np.eye(4)
        T_new[:3, :3] = R_new
        T_new[:3, 3] = c_new - R_new @ self._com_link
        new_margin = MIN_MARGIN_M + 4.0 * dt * (_norm(u_new[:3])
                                               + self._reach * wn)
        after = self._detect_near(T_new, new_margin)
        if after[0].count and float(np.min(after[0].gap_m)) < -PROJECTION_TOLERANCE_M:
            T_new, after = self._project(T_new, after, new_margin)
        world.set_pose(self.held_body, T_new)
        world.set_velocity(self.held_body, u_new[:3], u_new[3:])
        if gripped is not None and self._grip_rows is not None:
            apply_fingers(world, self._grip_rows, gripped, dt)
        self._T_prev = T_new
        self._found, self._found_margin = after, new_margin
        self.steps_solved += 1
        # this step's impulses as forces: made when asked for (sim/fit_forces.py)
        self._solved = SolvedStep(found, owner, lam_n, p_t, t1, t2, dt)

    def _partner_moves(self, found: FitContact, owner: np.ndarray, mu: np.ndarray,
                       c_held: np.ndarray, u_held: np.ndarray, dt: float) -> bool:
        """A held body over a dynamic partner: when the grip can carry the contact, the held
        body keeps Bullet's step (its pads hold it to the gripper) and the partner takes the
        whole correction in this step. Returns whether it did (the caller returns).

        The fit's rows are solved on the partner's twist relative to the held body's rigid
        motion (``u_held`` (6,), ``c_held`` (3,) its centre of mass before the step), in the
        partner's mass metric (:meth:`_solve_velocity` with the normals flipped), the
        partner's velocity and pose corrected by the change (its pose re-integrated from
        Bullet's by ``dt`` times it, as the held body's), its touching contacts with every
        other body rows it may not be pushed further into (frictionless). The impulses are
        this step's contact forces; no reaction is applied to the partner next step (its
        velocity has it). Done only when every point's partner is the same dynamic body and the wrench of
        the impulses on the held body is within the grip's holding capacity
        (:func:`grip_utilisation` <= 1); otherwise the held body is solved as before (it
        moves in the grip, the partner gets the reaction one step late).

        Why: solved as a body the pads hold only through Bullet's step a step before, the
        held body moved in the grip instead of the partner. The pneumatic front cap (hole
        side, its bore chamfer on the rod's sagging end) turned 1.8 deg in its fingers within
        80 ms at 0.2 N of fit force (< 5 mN m, against 0.22 N m of grip torsion) and did not
        lift the rod (0.44 N needed); the fit's rows against a partner static within the
        solve admit no solution with the part held, so the friction rounds only grew the
        impulse (11.5 N after 1,000 rounds) while the part turned on."""
        partners = {self.pairs[i].partner for i in owner.tolist()}
        if len(partners) != 1 or self._grip is None:
            return False
        b = partners.pop()
        if not self._dynamic.get(b, False):
            return False
        world = self.world
        con = world.contacts(self.held_body, self._grip[0])
        on_pad = np.isin(con.link_b, self._grip[1]) & (con.normal_force_N > 0.0)
        if not np.any(on_pad):
            return False
        if b not in self._partner_inertia:
            mass, T_li, I_link = world.rigid_properties(b)
            self._partner_inertia[b] = (T_li, *_minv_sqrt_parts(mass, I_link))
        T_li, minv_linear, inv_sqrt_link = self._partner_inertia[b]
        T_p = world.pose(b)
        R_p = T_p[:3, :3]
        c_p = R_p @ T_li[:3, 3] + T_p[:3, 3]
        v_p, w_p = world.velocity(b)
        v_held_at = u_held[:3] + np.cross(u_held[3:], c_p - c_held)
        u_rel = np.concatenate([v_p - v_held_at, w_p - u_held[3:]])
        R_i = R_p @ T_li[:3, :3]
        Minv_sqrt = minv_linear.copy()
        Minv_sqrt[3:, 3:] = R_i @ inv_sqrt_link @ R_i.T
        # the partner's own supports (Bullet's contacts with every other body, touching):
        # the correction may not push it further into them than Bullet's step left it
        sup = world.contacts(b)
        keep = ((sup.body_b != self.held_body) & (sup.body_b != self._grip[0])
                & ((sup.normal_force_N > 0.0) | (sup.distance_m <= 0.0)))
        sp, sn = sup.position_on_a_m[keep], sup.normal_on_b[keep]
        now = np.sum(sn * (u_rel[:3] + cross_rows(np.broadcast_to(u_rel[3:], sp.shape),
                                                  sp - c_p)), axis=1)
        k = found.count
        rows = FitContact(np.vstack([found.point_m, sp]), np.vstack([-found.normal, sn]),
                          np.concatenate([found.gap_m, -dt * now]), False)
        u_new, lam_n, p_t, t1, t2 = self._solve_velocity(
            rows, np.concatenate([mu, np.zeros(sp.shape[0])]), c_p, u_rel, Minv_sqrt, dt)
        lam_n, p_t, t1, t2 = lam_n[:k], p_t[:k], t1[:k], t2[:k]
        # the force on the held body at each point: the partner's, reversed
        f_held = (lam_n[:, None] * found.normal - p_t[:, :1] * t1 - p_t[:, 1:] * t2) / dt
        if grip_utilisation(con.select(on_pad), self._grip[2], f_held, found.point_m) > 1.0:
            return False
        du = u_new - u_rel
        c_new = c_p + dt * du[:3]
        wn = _norm(du[3:])
        R_new = (rotation_about(du[3:] / wn, wn * dt) @ R_p) if wn > 0 else R_p
        T_new = np.eye(4)
        T_new[:3, :3] = R_new
        T_new[:3, 3] = c_new - R_new @ T_li[:3, 3]
        world.set_pose(b, T_new)
        world.set_velocity(b, v_p + du[:3], w_p + du[3:])
        self._T_partner[b] = T_new
        self._base = None
        self._T_prev = world.pose(self.held_body)
        self._found = None
        self.steps_solved += 1
        self.partner_steps += 1
        self._solved = SolvedStep(found, owner, lam_n, -p_t, t1, t2, dt)
        self._forces()
        self._reaction = []  # the partner's velocity has it
        return True

    def _forces(self) -> None:
        """:attr:`_last` and :attr:`_reaction` from the last solve, if not made yet."""
        if self._solved is not None:
            self._last, self._reaction = solved_forces(
                self._solved, [p.partner for p in self.pairs], self._partners)
            self._solved = None

    def reaction_on(self, body: int) -> list[tuple[np.ndarray, np.ndarray]]:
        """The last step's reaction on a partner: (force N (3,), point m (3,)) pairs."""
        self._forces()
        return [(force, point) for b, force, point in self._reaction if b == body]

    def contacts(self) -> Contacts:
        """The pin's contact points with the bore after the last step (with their forces)."""
        self._forces()
        return self._last

    # ------------------------------------------------------------------ internals
    def _minv_sqrt(self, R: np.ndarray) -> np.ndarray:
        Minv_sqrt = self._minv_sqrt_linear.copy()
        Minv_sqrt[3:, 3:] = R @ self._inv_sqrt_inertia_link @ R.T
        return Minv_sqrt

    @staticmethod
    def _rows(points: np.ndarray, dirs: np.ndarray, c: np.ndarray) -> np.ndarray:
        rows = np.empty((dirs.shape[0], 6))
        rows[:, :3] = dirs
        cross_rows(points - c, dirs, rows[:, 3:])
        return rows

    def _pad_rows(self, c: np.ndarray, dt: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The grip's share: the pads' friction left after Bullet's step, as friction-only
        contacts of this step's solve.

        Bullet solved the pads against the held body a step before this model's contact (the
        body free of the rim in its step), so an impulse of the fit contact moved the body as
        a free body in the grip: a pin stopped on a rim spun in the pads (1.8 rad/s, then
        rocking at 7-8 rad/s) and the fingers sank into it. Each pad contact point resists the
        body's sliding relative to the gripper with what its friction cone has left,
        sqrt((mu N)^2 - |f_Bullet|^2) dt, where N and f_Bullet are the normal and friction
        forces Bullet's step applied there; the normal direction (force-controlled fingers)
        is not added. Returns (rows (k, 2, 6), the gripper's tangential velocity there
        (k, 2), impulse caps (k,)) or None when no pad touches the body."""
        if self._grip is None:
            return None
        body, links, mu = self._grip
        con = self.world.contacts(self.held_body, body)
        on_pad = np.isin(con.link_b, links) & (con.normal_force_N > 0.0)
        if not np.any(on_pad):
            return None
        con = con.select(on_pad)
        n = con.normal_on_b
        p = con.position_on_a_m
        t1, t2 = tangent_rows(n)
        rows = np.stack([self._rows(p, t1, c), self._rows(p, t2, c)], axis=1)
        v_g, w_g = self.world.velocity(body)
        v_pad = v_g + cross_rows(np.broadcast_to(w_g, p.shape), p - self.world.com_position_m(body))
        target = np.column_stack([np.sum(t1 * v_pad, axis=1), np.sum(t2 * v_pad, axis=1)])
        used2 = np.sum(con.friction_on_a_N * con.friction_on_a_N, axis=1)
        cap = np.sqrt(np.maximum(0.0, (mu * con.normal_force_N) ** 2 - used2)) * dt
        return rows, target, cap

    def _solve_velocity(self, found: FitContact, mu: np.ndarray, c: np.ndarray, u: np.ndarray,
                        Minv_sqrt: np.ndarray, dt: float,
                        pads: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None):
        Jn = self._rows(found.point_m, found.normal, c)
        Gn = Jn @ Minv_sqrt
        t1, t2 = self._tangents_of(found.normal)
        Jt1, Jt2 = self._rows(found.point_m, t1, c), self._rows(found.point_m, t2, c)
        Minv = Minv_sqrt @ Minv_sqrt
        k = found.count
        p_t = np.zeros((k, 2))
        lam = np.zeros(k)
        target = -found.gap_m / dt
        touching = found.gap_m <= FRICTION_GAP_M
        u_new = u.copy()
        Jt = np.stack([Jt1, Jt2], axis=1)  # (k, 2, 6)
        MJt = np.einsum("ab,kib->kai", Minv, Jt)  # (k, 6, 2): Minv Jt^T per contact
        W = np.einsum("kib,kbj->kij", Jt, MJt)  # (k, 2, 2)
        det = W[:, 0, 0] * W[:, 1, 1] - W[:, 0, 1] * W[:, 1, 0]
        det = np.where(np.abs(det) > 1e-300, det, 1e-300)
        Winv = np.empty_like(W)
        Winv[:, 0, 0], Winv[:, 1, 1] = W[:, 1, 1] / det, W[:, 0, 0] / det
        Winv[:, 0, 1], Winv[:, 1, 0] = -W[:, 0, 1] / det, -W[:, 1, 0] / det
        if pads is not None:
            P, v_pad, pad_cap = pads
            MP = np.einsum("ab,kib->kai", Minv, P)  # (kp, 6, 2)
            WP = np.einsum("kib,kbj->kij", P, MP)
            WPinv = np.linalg.inv(WP + 1e-300 * np.eye(2)[None])
            q_p = np.zeros((P.shape[0], 2))
        for rnd in range(FRICTION_ROUNDS):
            u_f = u + np.einsum("kai,ki->a", MJt, p_t)
            if pads is not None:
                u_f = u_f + np.einsum("kai,ki->a", MP, q_p)
            sol = least_distance(Gn, target - Jn @ u_f)
            if sol is None:  # infeasible (cannot happen for a pin in a bore): leave as is
                break
            y, lam = sol
            u_new = u_f + Minv_sqrt @ y
            cap = mu * lam * touching
            if rnd == FRICTION_ROUNDS - 1 or not (np.any(cap > 0) or pads is not None):
                break
            for i in np.flatnonzero((cap > 0) | np.any(p_t != 0.0, axis=1)).tolist():
                old = p_t[i]
                new = old - Winv[i] @ (Jt[i] @ u_new)
                norm = math.hypot(new[0], new[1])
                if norm > cap[i]:
                    new = new * (cap[i] / norm) if norm > 0 else new * 0.0
                u_new = u_new + MJt[i] @ (new - old)
                p_t[i] = new
            if pads is not None:  # the pads hold the body to the gripper, within their cone
                for i in range(P.shape[0]):
                    old = q_p[i]
                    new = old - WPinv[i] @ (P[i] @ u_new - v_pad[i])
                    norm = math.hypot(new[0], new[1])
                    if norm > pad_cap[i]:
                        new = new * (pad_cap[i] / norm) if norm > 0 else new * 0.0
                    u_new = u_new + MP[i] @ (new - old)
                    q_p[i] = new
        norm = np.linalg.norm(p_t, axis=1)
        over = norm > mu * lam * touching
        if np.any(over):  # what the last normal solve bears
            p_t[over] *= (mu[over] * lam[over] * touching[over] / norm[over])[:, None]
        return u_new, lam, p_t, t1, t2

    def _project(self, T: np.ndarray, found: tuple[FitContact, np.ndarray], margin: float
                 ) -> tuple[np.ndarray, tuple[FitContact, np.ndarray]]:
        R = T[:3, :3]
        c = R @ self._com_link + T[:3, 3]
        for _ in range(2):
            fc = found[0]
            Minv_sqrt = self._minv_sqrt(R)
            Jn = self._rows(fc.point_m, fc.normal, c)
            sol = least_distance(Jn @ Minv_sqrt, -fc.gap_m)
            if sol is None:
                break
            dq = Minv_sqrt @ sol[0]
            c = c + dq[:3]
            ang = _norm(dq[3:])
            if ang > 0:
                R = rotation_about(dq[3:] / ang, ang) @ R
            T = np.eye(4)
            T[:3, :3] = R
            T[:3, 3] = c - R @ self._com_link
            found = self._detect(T, margin)
            if found[0].count == 0 or float(np.min(found[0].gap_m)) >= -PROJECTION_TOLERANCE_M:
                break
        return T, found


def _minv_sqrt_parts(mass: float, inertia_link: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A rigid body's M^(-1/2) in two parts: the (6, 6) matrix with its linear block
    (1/sqrt(mass) I) and a zero rotational block, and the rotational block in the inertial
    frame, I^(-1/2) (3, 3), to be turned into the world as R I^(-1/2) R^T."""
    w, V = np.linalg.eigh(inertia_link)
    linear = np.zeros((6, 6))
    linear[:3, :3] = np.eye(3) / math.sqrt(mass)
    return linear, V @ np.diag(1.0 / np.sqrt(w)) @ V.T


def grip_utilisation(pads: Contacts, mu: float, force_N: np.ndarray, point_m: np.ndarray
                     ) -> float:
    """How much of a grip's holding capacity a set of forces on the held body takes (<= 1:
    the pads carry it while sticking), on top of what Bullet's step left them.

    ``pads``: the pad contact points Bullet holds (normals ``normal_on_b`` along each pad's
    closing direction, forces N); ``mu``: their combined Coulomb coefficient; ``force_N``
    (k, 3) at ``point_m`` (k, 3). The forces' wrench about the pads' centre (normal-force
    weighted) is split along the closing axis a (the pads' mean normal, sign-free) and
    across it, each part against its own capacity, and the shares summed (a linear
    interaction, conservative):

    * force across a: friction, mu sum N minus the friction Bullet's step used (|sum f|);
    * force along a: the lesser pad's normal force (it may unload that much);
    * moment about a: each pad's torsion, mu N_pad rho_pad, rho_pad the normal-force weighted
      mean distance of its points from their centre (the pressure spread: 2.1 mm on the
      pneumatic front cap's 40 mm flange, 0.22 N m for both pads at 68.5 N each, as the
      analytic mu F r_t x 2 = 0.75 x 64 N x 2.3 mm x 2);
    * moment across a: opposite friction on the two pads, mu N_min d, d their distance.
    """
    N = pads.normal_force_N
    links = np.unique(pads.link_b)
    n = pads.normal_on_b
    ref = n[int(np.argmax(N))]
    a = np.sum(np.where((n @ ref)[:, None] >= 0.0, n, -n) * N[:, None], axis=0)
    a = a / max(_norm(a), 1e-300)
    centre = np.sum(pads.position_on_a_m * N[:, None], axis=0) / float(np.sum(N))
    F = np.sum(force_N, axis=0)
    M = np.sum(np.cross(point_m - centre, force_N), axis=0)
    f_used = _norm(np.sum(pads.friction_on_a_N, axis=0))
    per_pad, torsion, centres = [], 0.0, []
    for link in links.tolist():
        sel = pads.link_b == link
        Np = N[sel]
        total = float(np.sum(Np))
        c = np.sum(pads.position_on_a_m[sel] * Np[:, None], axis=0) / total
        r = pads.position_on_a_m[sel] - c
        r = r - np.outer(r @ a, a)
        rho = float(np.sum(Np * np.sqrt(np.sum(r * r, axis=1)))) / total
        torsion += mu * total * rho
        per_pad.append(total)
        centres.append(c)
    n_min = min(per_pad) if len(per_pad) > 1 else 0.0
    d = _norm(centres[0] - centres[-1]) if len(centres) > 1 else 0.0
    F_a = abs(float(F @ a))
    F_t = _norm(F - (F @ a) * a)
    M_a = abs(float(M @ a))
    M_t = _norm(M - (M @ a) * a)

    def share(load: float, capacity: float) -> float:
        if load == 0.0:
            return 0.0
        return load / capacity if capacity > 0.0 else math.inf

    return (share(F_t, mu * float(np.sum(N)) - f_used) + share(F_a, n_min)
            + share(M_a, torsion) + share(M_t, mu * n_min * d))


def _make_empty_contacts() -> Contacts:
    arrays = (np.zeros(0, dtype=int), np.zeros(0, dtype=int), np.zeros(0, dtype=int),
              np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0),
              np.zeros(0), np.zeros((0, 3)))
    for a in arrays:
        a.flags.writeable = False
    return Contacts(*arrays)


_EMPTY_CONTACTS = _make_empty_contacts()
"""No contact: one shared read-only instance (it was built from 9 arrays at every step)."""


def _empty_contacts() -> Contacts:
    return _EMPTY_CONTACTS
