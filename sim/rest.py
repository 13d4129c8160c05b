"""Sleeping bodies at rest that nothing moving can reach: the cost of a step is spent where
the motion is (issue 16/17, "model only what a scene requires").

A step's world holds bodies that mostly lie still: the mate partner resting on its support
while the gripper picks and carries the held part, and, after the release, the held part and
its partner while the gripper retreats. Each costs the contact solver every step (on
pinhole_station at BALANCED a resting partner carries 90-125 contact points, a seated part
90-160; the release and retreat phases cost 2.1-2.2 ms per step against 0.3 ms in
transport). :class:`RestKeeper` puts such a body to sleep (Bullet's deactivation,
:meth:`asmplan.sim.bullet.BulletWorld.sleep`) once it is at rest and no moving body is near;
a sleeping body is skipped by the solver and the integrator until something touches it.

Rules (checked at every record row):

* Candidates: every dynamic body but the gripper; the held part only once it is placed and
  let go (the fingers commanded open after the "lower" phase: retreat), never before: the
  gripper is about to take it in the approach, and carries it after.
* At rest: over the last ``Fidelity.rest_window_s`` the body's centre of mass moved less than
  ``Fidelity.rest_displacement_m`` from where it was at the start of the window and turned by
  less than ``rest_displacement_m / REST_RADIUS_M`` rad; its speed now is below
  :data:`REST_SPEED_MPS`. A body that is tipping or settling accelerates away from rest
  within the window and is never put to sleep.
* Nothing near: no moving body (the gripper, and the held part while carried) overlaps the
  body's bounding box grown by :data:`NEAR_MARGIN_M`.
* Waking is Bullet's own: a body whose bounding box overlaps an active body's (Bullet's
  broad phase, before any contact) joins its simulation island and is integrated again, from
  rest. The keeper then forgets it; it may sleep again by the rules above.

What it changes: a sleeping body is held exactly where it came to rest (its velocity is set
to zero when it goes to sleep), so the residual solver jitter of a resting body (0.3-17 um/s
on pinhole_station) and any creep slower than ``rest_displacement_m / rest_window_s``
(10 um/s at BALANCED) are removed. Verdicts and errors on the bundled examples and the fits
bench are unchanged (docs/physics.md, "Sleeping bodies at rest").
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ..planner.trajectory import rotation_angle_rad
from .bullet import BulletWorld

REST_SPEED_MPS = 1e-3
"""A body faster than this (1 mm/s) at a row is not at rest, whatever its window says."""

REST_RADIUS_M = 0.01
"""Lever arm (m) turning ``rest_displacement_m`` into a rotation bound: 1 um at 10 mm is
1e-4 rad."""

NEAR_MARGIN_M = 1e-3
"""A candidate within this distance (bounding boxes, m) of a moving body stays awake."""


class RestKeeper:
    """Puts resting, unreachable bodies of one step's world to sleep (module docstring).

    Parameters
    ----------
    world : BulletWorld
    gripper_body : int
        The gripper (never a candidate; always a moving body).
    held_body : int
        The part being moved: a candidate only once released (:meth:`tick`).
    """

    def __init__(self, world: BulletWorld, gripper_body: int, held_body: int) -> None:
        fid = world.fidelity
        self._world = world
        self._gripper = gripper_body
        self._held = held_body
        self._window_rows = max(2, round(fid.rest_window_s / fid.record_dt_s) + 1)
        self._d_rest = fid.rest_displacement_m
        self._a_rest = fid.rest_displacement_m / REST_RADIUS_M
        self._wake_speed = fid.rest_displacement_m / fid.rest_window_s
        self._bodies = [b for b in world.dynamic_bodies() if b != gripper_body]
        self._history: dict[int, deque[np.ndarray]] = {
            b: deque(maxlen=self._window_rows) for b in self._bodies}
        self._asleep: set[int] = set()
        self.slept: dict[str, int] = {}
        """How often each body was put to sleep (by name), for the step's record."""

    def _still(self, T_world_body: np.ndarray) -> bool:
        """Every pose of the window (n, 4, 4) within the rest bounds of its first one."""
        T0 = T_world_body[0]
        moved_m = np.linalg.norm(T_world_body[:, :3, 3] - T0[:3, 3], axis=1)
        if not np.all(moved_m < self._d_rest):
            return False
        turned_rad = rotation_angle_rad(T0[:3, :3].T @ T_world_body[:, :3, :3])
        return bool(np.all(turned_rad < self._a_rest))

    def tick(self, released: bool) -> None:
        """Check every candidate after a record row's physics step; ``released``: the held
        part is placed and the fingers are open (a candidate too). Bodies at rest that touch
        each other are put to sleep together (Bullet wakes a sleeping body that touches an
        awake one)."""
        w = self._world
        movers = {self._gripper} if released else {self._gripper, self._held}
        resting: set[int] = set()
        for b in self._bodies:
            if w.is_static(b):  # held static (asmplan.sim.partner_hold): not at rest, immovable
                self._history[b].clear()
                continue
            v, om = w.velocity(b)
            if b in self._asleep:
                if not (np.any(v) or np.any(om)):
                    continue
                self._asleep.discard(b)  # Bullet woke it (an active body came near)
                self._history[b].clear()
            hist = self._history[b]
            hist.append(w.pose(b))
            if float(np.linalg.norm(v)) > REST_SPEED_MPS:
                hist.clear()
                continue
            if b in movers or len(hist) < self._window_rows:
                continue
            if self._still(np.stack(hist)):
                resting.add(b)
        if not resting:
            return
        near = {b: w.bodies_near(b, NEAR_MARGIN_M) for b in resting}
        awake = {b for b in self._bodies if not w.is_static(b)} - self._asleep
        # a moving body near: stays awake; then so does every resting body touching an awake
        # one that stays awake (until nothing changes)
        sleepy = {b for b in resting if not movers & near[b]}
        while True:
            keep = {b for b in sleepy if not (near[b] & awake) <= sleepy}
            if not keep:
                break
            sleepy -= keep
        for b in sorted(sleepy):
            w.sleep(b, self._wake_speed)
            self._asleep.add(b)
            self._history[b].clear()
            name = w.body_name(b)
            self.slept[name] = self.slept.get(name, 0) + 1
