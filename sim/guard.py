"""Watch a step's dynamic bodies and stop it at the first sign the scene has left physics
(:class:`SceneWatch`, the checks of :class:`~asmplan.sim.verdicts.SceneGuard`).

Three checks, every record row, on every watched body:

* **left the cell**: farther than ``guard.cell_half_size_m`` from the cell centre: "fell";
* **too fast**: faster than ``guard.max_speed_mps`` (a carried part: relative to the palm):
  "fell" when its fall explains its kinetic energy, else "unstable" (the solver gave it that
  energy);
* **sinking**: a contact penetration deeper than ``guard.max_sink_m`` at two record rows in
  a row and deeper at the second: "unstable". A resting contact's penetration shrinks under
  the solver's error reduction (an impact's too, within a step or two); one that keeps
  growing beyond the bound means the solver cannot hold the body up. The
  case that needs it: a 100 kg block on four 1 g cubes (mass ratio 1e5). PyBullet's
  iterative multibody solver moves the block's weight into the ground through a cube at
  about ``iterations x m_cube / m_block`` per step (1e-3 at BALANCED), so the block
  falls nearly freely, squeezing the cubes into the ground (0.5 mm at 11 ms, 0.1 m/s), and
  squeezed cubes are later shot out at up to 3 m/s. Neither split impulse, the direct
  (Dantzig) solver, a global CFM nor 1,000 iterations keeps them put (measured at BALANCED:
  2.98, 3.48, 3.08 and 0.29 m/s); the check ends the step first (``heavy_on_light`` in
  ``bench/scenarios.py``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from .bullet import BulletWorld
from .verdicts import Failure, FailureCode, SceneGuard


class SceneWatch:
    """The guard's state over one step: each body's highest point and last penetration.

    Parameters
    ----------
    world : BulletWorld
    bodies : sequence of int
        The watched (dynamic) bodies.
    guard : SceneGuard
    not_sinking : sequence of int
        Bodies left out of the sinking check: a step's own part, which the robot pushes into
        its partners on purpose (at FAST a shaft fed into its bore at 6 mm/s sat 0.55-0.6 mm
        deep in the coarse geometry) and whose penetration is a success criterion of its own.
    """

    def __init__(self, world: BulletWorld, bodies: Sequence[int], guard: SceneGuard,
                 not_sinking: Sequence[int] = ()) -> None:
        self.world = world
        self.bodies = tuple(bodies)
        self.guard = guard
        self._sink_checked = frozenset(self.bodies) - frozenset(not_sinking)
        self._centre = np.asarray(guard.cell_centre_m, dtype=float)
        self._g = float(np.linalg.norm(world.gravity_mps2))
        self._z_top = {b: float(world.com_position_m(b)[2]) for b in self.bodies}
        self._sink = {b: 0.0 for b in self.bodies}

    def check(self, t_s: float, frame_velocity_mps: Mapping[int, np.ndarray] | None = None
              ) -> Failure | None:
        """The first failure among the watched bodies after the last step, or None.

        ``frame_velocity_mps`` maps a body to the velocity (3,) m/s its speed is measured
        against (a carried part: the palm's), ``t_s`` the simulated time for the message.
        """
        w, guard = self.world, self.guard
        for b in self.bodies:
            vb = w.velocity(b)[0]
            if frame_velocity_mps is not None and b in frame_velocity_mps:
                vb = vb - frame_velocity_mps[b]
            pb = w.com_position_m(b)
            speed = float(np.linalg.norm(vb))
            away = float(np.max(np.abs(pb - self._centre)))
            if math.isfinite(pb[2]):
                self._z_top[b] = max(self._z_top[b], float(pb[2]))
            position = ((float(pb[0]), float(pb[1]), float(pb[2]))
                        if np.all(np.isfinite(pb)) else None)
            if not (speed <= guard.max_speed_mps and away <= guard.cell_half_size_m):
                return self._too_fast(b, speed, away, pb, position, t_s)
            if b in self._sink_checked:
                sink = self._sinking(b, speed, position, t_s)
                if sink is not None:
                    return sink
        return None

    def _too_fast(self, b: int, speed: float, away: float, pb: np.ndarray,
                  position: tuple[float, float, float] | None, t_s: float) -> Failure:
        # gravity explains m g (highest - now) of kinetic energy (plus what the speed bound
        # allows); more than that came from the solver
        w, guard = self.world, self.guard
        ke = w.kinetic_energy_J(b)
        budget = w.body_mass_kg(b) * (self._g * max(0.0, self._z_top[b] - float(pb[2]))
                                      + 0.5 * guard.max_speed_mps ** 2)
        explained = math.isfinite(ke) and ke <= budget
        code: FailureCode = ("fell" if explained or away > guard.cell_half_size_m
                             else "unstable")
        return Failure(code, speed if math.isfinite(speed) else math.inf, guard.max_speed_mps,
                       "m/s", body=w.body_name(b), position_m=position,
                       detail=(f"{away * 1e3:.0f} mm from the cell centre (cell half size "
                               f"{guard.cell_half_size_m * 1e3:.0f} mm)"
                               if away > guard.cell_half_size_m else
                               f"kinetic energy {ke:.3g} J, its fall explains {budget:.3g} J, "
                               f"at t = {t_s:.3f} s"))

    def _sinking(self, b: int, speed: float, position: tuple[float, float, float] | None,
                 t_s: float) -> Failure | None:
        w = self.world
        depth, partner_body = w.deepest_contact(b)
        before, self._sink[b] = self._sink[b], depth
        if not (before > self.guard.max_sink_m and depth > before) or partner_body is None:
            return None
        partner = w.body_name(partner_body)
        return Failure("unstable", depth, self.guard.max_sink_m, "m", body=w.body_name(b),
                       position_m=position,
                       detail=(f"sinking into {partner}: penetration {depth * 1e3:.3f} mm "
                               f"(was {before * 1e3:.3f} mm one record row before), speed "
                               f"{speed:.3f} m/s, at t = {t_s:.3f} s; the solver cannot hold "
                               f"it up (extreme mass ratio in a stack?)"))
