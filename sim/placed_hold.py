"""The placed part held static once it rests after "lower" and nothing can move it (issue 16,
the seed job's cost: "model only what a scene requires").

After "lower" the step goes on through "release" (the clamp force ramps to zero while the
gripper stands still) and "retreat" (the fingers open, then the gripper moves away) so that a
release or a gripper disturbing the seated part is seen. Simulating the seated part at rest
is what those phases cost most: with the exact fit contact (:mod:`asmplan.sim.feature_contact`)
Bullet lets the part fall by g dt every step and the fit contact stops it again (24 contact
points solved every step on pinhole_station: 1.2 ms per BALANCED step in "release", 0.36 ms
in "retreat", against 0.02-0.16 ms for Bullet's own). :class:`asmplan.sim.rest.RestKeeper`
cannot put it to sleep: the fingers stay within its 1 mm of the part's bounding box for most
of the retreat, and Bullet wakes a sleeping body whose bounding box an active body's overlaps.

:class:`PlacedHold` makes the part static instead (mass 0,
:meth:`asmplan.sim.bullet.BulletWorld.hold_static`, as :mod:`asmplan.sim.partner_hold` does
for mate partners) at a record row where all of these hold:

* the part is placed: the step is past "lower";
* it is at rest: over the last ``Fidelity.rest_window_s`` its centre of mass stayed within
  ``Fidelity.rest_displacement_m`` and it turned by less than that over
  :data:`asmplan.sim.rest.REST_RADIUS_M`, and its speed now is below
  :data:`asmplan.sim.rest.REST_SPEED_MPS` (the rest keeper's rules);
* it rests on static bodies only: no contact point (Bullet's or the fit contact's) with a
  dynamic body other than the gripper, and every partner of its fit contact static, so
  holding it takes no load off a body that could move;
* the gripper cannot move it: with no contact point between them, always; otherwise (the
  pads still on it in "release") only with ``Fidelity.partner_hold_fraction`` > 0 and the
  load check of :mod:`asmplan.sim.partner_hold` passing, on the part's bearing polygon (its
  contact points with static bodies whose normal is within 10 deg of ``up``: the seat of its
  pins' shoulders) and the gripper's contact forces on it: sliding ``T / (mu N)`` and the
  overturning moment about every bearing edge within that fraction of the support's friction
  and of the weight's restoring moment.

At every later record row the part gets its mass back, from rest, when the check fails:
a dynamic body other than the gripper touches it, a fit partner is dynamic again, the gripper
touches it when it did not at the hold, or the gripper's loads exceed the bounds; it may be
held again by the rules above. A load between two rows (4 ms at BALANCED) acts on the
static part for at most 3 physics steps. While held, the fit contact skips its solve
(:meth:`asmplan.sim.feature_contact.HeldFitContact.after_step`) and keeps its last contact
points and forces (the part's weight on its seat) for the record.

Not in a step with a ``before_step`` hook (:func:`asmplan.sim.execute.execute_step`): a press
step's ram pushes the part home after the robot let go of it (:mod:`asmplan.sim.press`), and
a pose constraint or force on a static body does nothing.

What it changes is measured in docs/physics.md ("The placed part held static").
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ..planner.trajectory import rotation_angle_rad
from .bullet import BulletWorld
from .contacts import Contacts
from .partner_hold import BEARING_COS, MIN_SUPPORT_AREA_M2, bearing_polygon
from .rest import REST_RADIUS_M, REST_SPEED_MPS


class PlacedHold:
    """Holds the placed part static while it rests and nothing can move it (module docstring).

    Parameters
    ----------
    world : BulletWorld
    part_body : int
        The part the step placed.
    gripper_body : int
    partners : tuple of int
        Bodies of the part's exact fit contact (they must be static for the part to be held).
    fraction : float
        Share of the support's friction and restoring moment the gripper's loads may use
        (``Fidelity.partner_hold_fraction``); 0: held only while the gripper does not touch.
    """

    def __init__(self, world: BulletWorld, part_body: int, gripper_body: int,
                 partners: tuple[int, ...] = (), fraction: float = 0.0) -> None:
        fid = world.fidelity
        self._world = world
        self._part = part_body
        self._gripper = gripper_body
        self._partners = tuple(partners)
        self._fraction = float(fraction)
        self._window_rows = max(2, round(fid.rest_window_s / fid.record_dt_s) + 1)
        self._d_rest = fid.rest_displacement_m
        self._a_rest = fid.rest_displacement_m / REST_RADIUS_M
        self._history: deque[np.ndarray] = deque(maxlen=self._window_rows)
        g = np.asarray(world.gravity_mps2, dtype=float)
        self._weight_N = world.body_mass_kg(part_body) * g
        self._up = -g / float(np.linalg.norm(g))
        # the bearing polygon of the present hold: (a point on each edge, edge directions,
        # the support's friction), None when held untouched without one
        self._support: tuple[np.ndarray, np.ndarray, float] | None = None
        self._touched = False  # the gripper touched the part when it was held
        self.held_at_s: list[float] = []
        """Times (s) at which the part was made static."""
        self.freed_at_s: list[float] = []
        """Times (s) at which it got its mass back."""

    @property
    def holding(self) -> bool:
        """Whether the part is static now."""
        return self._world.is_static(self._part)

    def _on_statics(self, con: Contacts) -> bool:
        """No contact point with a dynamic body but the gripper; every fit partner static."""
        w = self._world
        if any(not w.is_static(b) for b in self._partners):
            return False
        return all(int(b) == self._gripper or w.is_static(int(b)) for b in con.body_b)

    def _bearing(self, con: Contacts) -> tuple[np.ndarray, np.ndarray, float] | None:
        """The bearing polygon of the part's contacts with static bodies (as
        :meth:`asmplan.sim.partner_hold.PartnerHold` finds a partner's), None if it has
        fewer than 3 points, no area or the centre of mass outside it."""
        w, up = self._world, self._up
        sel = (con.body_b != self._gripper) & (con.normal_on_b @ up >= BEARING_COS)
        if int(np.count_nonzero(sel)) < 3:
            return None
        p3 = con.position_on_b_m[sel]
        mu = min(w.lateral_friction(self._part) * w.lateral_friction(int(o))
                 for o in set(con.body_b[sel].tolist()))
        hull, area = bearing_polygon(p3, up)
        if len(hull) < 3 or area < MIN_SUPPORT_AREA_M2:
            return None
        a = p3[hull]
        d = np.roll(a, -1, axis=0) - a
        d -= (d @ up)[:, None] * up
        d /= np.linalg.norm(d, axis=1)[:, None]
        support = (a, d, float(mu))
        return support if np.all(self._restoring(support) > 0.0) else None

    def _restoring(self, support: tuple[np.ndarray, np.ndarray, float]) -> np.ndarray:
        """The weight's restoring moment about each bearing edge (N m, > 0 when stable)."""
        a, d, _ = support
        tau = np.cross(self._world.com_position_m(self._part) - a, self._weight_N)
        return -np.einsum("ij,ij->i", tau, d)

    def _gripper_holds(self, con: Contacts,
                       support: tuple[np.ndarray, np.ndarray, float] | None) -> bool:
        """Whether the gripper's contact forces on the part stay within the load check (a
        gripper that did not touch the part when it was held may not touch it at all)."""
        grip = con.body_b == self._gripper
        if not np.any(grip):
            return True
        if support is None or self._fraction <= 0.0 or (self.holding and not self._touched):
            return False
        f = (con.normal_force_N[grip, None] * con.normal_on_b[grip]
             + con.friction_on_a_N[grip])
        F = f.sum(axis=0)
        tau = np.cross(con.position_on_a_m[grip], f).sum(axis=0)
        up = self._up
        L = F + self._weight_N
        N = -float(L @ up)
        if N <= 0.0:
            return False
        a, d, mu = support
        slide = float(np.linalg.norm(L + N * up)) / (mu * N)
        over = np.einsum("ij,ij->i", tau - np.cross(a, F), d)
        tip = float(np.max(over / self._restoring(support)))
        return slide <= self._fraction and tip <= self._fraction

    def tick(self, t_s: float, placed: bool, con: Contacts) -> None:
        """Check the part after a record row's physics step; ``placed``: the step is past
        "lower"; ``con``: the part's contact points at this row (Bullet's and the fit
        contact's)."""
        w = self._world
        if self.holding:
            if not (placed and self._on_statics(con)
                    and self._gripper_holds(con, self._support)):
                w.hold_static(self._part, False)
                self.freed_at_s.append(float(t_s))
                self._history.clear()
            return
        if not placed or float(np.linalg.norm(w.velocity(self._part)[0])) > REST_SPEED_MPS:
            self._history.clear()
            return
        self._history.append(w.pose(self._part))
        if len(self._history) < self._window_rows or not self._on_statics(con):
            return
        T = np.stack(self._history)
        moved_m = np.linalg.norm(T[:, :3, 3] - T[0, :3, 3], axis=1)
        if not np.all(moved_m < self._d_rest):
            return
        if not np.all(rotation_angle_rad(T[0, :3, :3].T @ T[:, :3, :3]) < self._a_rest):
            return
        support = self._bearing(con)
        if not self._gripper_holds(con, support):
            return
        w.hold_static(self._part, True)
        self._support = support
        self._touched = bool(np.any(con.body_b == self._gripper))
        self.held_at_s.append(float(t_s))
        self._history.clear()
