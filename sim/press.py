"""Press steps in the simulator: line-to-line fit geometry and the predicted axial resistance.

Rigid bodies cannot model an interference: the pin would be wider than its hole, and at
zero clearance (line-to-line) a rigid pin wedges at the first tilt (measured: the 8 mm H7/s6
dowel jammed 1.4 mm deep at BALANCED, tilted 5.9 deg). A press fit is therefore simulated
with its geometry at the SMALLEST INTERFERENCE THE PRESET BLOCKS (the simulated product has
every interfering or transition mate at ``Fidelity.interference_resolution_m``,
:func:`press_relaxed`: the guidance of the parts as the preset can judge it), and the
elastic part of the joint as an axial resistance on the pressed part, predicted by
:mod:`asmplan.knowledge.press_fit` (``F(x) = F_typical x / L``: the contact area grows with
the engaged depth ``x``).

The resistance is the joint's friction:

* When the gripper presses (``PressOperation.by == "gripper"``, small forces), a sliding
  friction ``F(x)`` against the axial motion is applied to the part at every physics step
  while it is engaged, smoothed near zero speed (``tanh(v / SPEED_SCALE_M_S)``) and capped at
  what stops the axial motion within one step (``m |v| / dt``: an explicit Coulomb force on a
  few grams diverges); the grip must carry it or the part slips.
* When the cell's press presses (``by == "press"``), the robot leaves the part on the mouth
  (the plan's hand-over pose) and lets go; then the RAM, a fixed constraint whose target
  moves along the mate axis at the process's insertion speed with the press's ``max_force``
  as its force limit, pushes it home against ``F(x)`` applied to the part. The ram force
  ``F(x)`` plus the axial force of the rigid contacts is recorded.
* Once home (within ``SEATED_M`` of the full depth), the joint holds the part: a fixed
  constraint at its pose with the press force as its force limit (a released press-fitted
  dowel does not drop to the bottom of its hole, and a later step cannot push it off with less
  than that force).

Both record the force-depth curve (engaged depth measured on the simulated part's pose) and a
verdict "pressed to depth X of L with peak F".
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..knowledge.model import Product
from ..planner.plan import Step
from ..planner.trajectory import quat_xyzw_from_matrix

ON_AXIS_M = 1e-3
"""The part counts as engaged only within this distance of the mate axis."""
SEATED_M = 0.1e-3
"""Engaged to within this of the full depth counts as home."""
SPEED_SCALE_M_S = 1e-3
"""Axial speed at which the applied resistance reaches 76 % of its value (tanh(1))."""

_RELAXED: weakref.WeakKeyDictionary[Any, dict[float, tuple[Product, Any]]] = \
    weakref.WeakKeyDictionary()


def press_clearance_m(fidelity: Any, touch_tolerance_m: float) -> float:
    """Diametral clearance a press fit is simulated at: the smallest interference the preset
    blocks by rigid contact (``Fidelity.interference_resolution_m``), but a radial gap below
    90 % of the scene's touch tolerance (a mate partner
    farther than that from the seated part is taken for a plain obstacle, its holes filled:
    measured at FAST, 0.4 mm diametral = 0.2 mm radial, the dowel stood on a filled hole)."""
    return float(min(fidelity.interference_resolution_m, 1.8 * touch_tolerance_m))


def press_relaxed(product: Product, geometry: Any, clearance_m: float) -> tuple[Product, Any]:
    """The product with every mate whose clearance range reaches below zero set to the
    diametral clearance ``clearance_m``, and its geometry (cached per ``geometry`` and
    clearance); the inputs themselves when no mate interferes."""
    if not any(m.clearance_min_m < 0 for m in product.mates):
        return product, geometry
    cache = _RELAXED.setdefault(geometry, {})
    hit = cache.get(clearance_m)
    if hit is not None:
        return hit
    from ..parts.models import ProductGeometry

    c = float(clearance_m)
    mates = tuple(replace(m, clearance_min_m=c, clearance_max_m=c, fit=None)
                  if m.clearance_min_m < 0 else m for m in product.mates)
    relaxed = replace(product, mates=mates)
    out = (relaxed, ProductGeometry(relaxed, geometry.settings))
    cache[clearance_m] = out
    return out


@dataclass
class PressRecorder:
    """Applies (gripper press) or records (cell press) the resistance of one press step.

    Call :meth:`before_step` before every physics step; :meth:`summary` afterwards.
    """

    world: Any
    body: int
    axis_world: np.ndarray
    p_seated_m: np.ndarray
    depth_m: float
    stroke_m: float
    force_full_N: float
    by: str
    press_max_force_N: float
    gripper_body: int = -1
    samples: list[tuple[float, float]] = field(default_factory=list)
    every: int = 1
    seated: bool = False
    t_ram_s: float | None = None
    t0_s: float = 0.0
    ram_speed_m_s: float = 0.01
    R_seated: np.ndarray = field(default_factory=lambda: np.eye(3))
    _hold: int = -1
    _hold_x: float = 0.0
    _ram_from: np.ndarray = field(default_factory=lambda: np.zeros(3))
    _ram_quat: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))

    def engaged_m(self) -> float:
        """Travel into the press partners (m, 0..``stroke_m``): 0 unless the part is on the
        mate axis (within ``ON_AXIS_M``) and no farther from its seat than the stroke."""
        p = self.world.pose(self.body)[:3, 3]
        rel = self.p_seated_m - p
        to_go = float(rel @ self.axis_world)
        lateral = float(np.linalg.norm(rel - to_go * self.axis_world))
        if lateral > ON_AXIS_M or not -ON_AXIS_M <= to_go <= self.stroke_m:
            return 0.0
        return min(max(self.stroke_m - to_go, 0.0), self.stroke_m)

    @property
    def ram_force_N(self) -> float:
        """The ram's force limit: the press's max force. (A limit of 1.5 x the typical press
        force + 50 N, as a force-controlled press stopping at a shoulder, let the hinge's
        bushing tilt 48 deg and stop 7.8 mm short at BALANCED where the full force seats it,
        and did not change the pneumatic rear cap's 1.66 mm penetration at FAST.)"""
        return self.press_max_force_N

    def force_at_N(self, x: float) -> float:
        """Resistance at travel ``x``: grows with the contact length up to ``depth_m``."""
        if self.depth_m <= 0:
            return 0.0
        return self.force_full_N * min(x, self.depth_m) / self.depth_m

    def before_step(self, i: int) -> None:
        x = self.engaged_m()
        f = self.force_at_N(x)
        if not self.seated and x >= self.stroke_m - SEATED_M and f > 0:
            # home: the joint now holds the part in every direction up to its press force
            # (a fixed constraint at the current pose: implicit, stable for kN on grams)
            self.seated = True
            T = self.world.pose(self.body)
            if self._hold < 0:
                self._hold = self.world.add_pose_constraint(self.body, T, f)
            else:  # the ram finishes its stroke; its constraint becomes the joint's hold
                self.world.move_pose_constraint(self._hold, self.p_seated_m, self._ram_quat, f)
                x = self.stroke_m
            self._hold_x = x
        elif self.seated and x > self._hold_x:
            # pushed deeper: the hold follows inward (a ratchet), never pulls back out
            T = self.world.pose(self.body)
            self.world.move_pose_constraint(self._hold, T[:3, 3], quat_xyzw_from_matrix(T[:3, :3]), f)
            self._hold_x = x
        elif not self.seated and self.by == "press" and self.t_ram_s is not None:
            t = self.t0_s + self.world.fidelity.dt_s * (i + 1)
            if t >= self.t_ram_s:
                self._ram(t, f)
        elif f > 0 and self.by == "gripper" and not self.seated:
            # sliding friction against the insertion, at most what stops the axial motion
            # within one step (an explicit Coulomb force larger than that diverges)
            v, _ = self.world.velocity(self.body)
            v_ax = float(np.asarray(v) @ self.axis_world)
            cap = self.world.body_mass_kg(self.body) * abs(v_ax) / self.world.fidelity.dt_s
            mag = min(f * math.tanh(abs(v_ax) / SPEED_SCALE_M_S), cap)
            if mag > 0:
                com = self.world.com_position_m(self.body)
                self.world.apply_force(self.body, -1, -math.copysign(mag, v_ax) * self.axis_world, com)
        if i % self.every == 0:
            ram = f
            if self.by == "press":  # the rigid contacts' axial resistance adds to the ram force
                con = self.world.contacts(self.body)
                con = con.select(con.body_b != self.gripper_body)
                ram += max(float(-(con.force_on_a_N() @ self.axis_world)), 0.0)
            self.samples.append((x, ram))

    def _ram(self, t: float, f: float) -> None:
        """The press's ram: drives the part along the mate axis through the seat at
        ``ram_speed_m_s`` from where the robot left it (its axial position) to the seat, in the
        seated orientation, with the press's max force as its limit, against the joint's
        resistance ``f``."""
        if self._hold < 0:
            T = self.world.pose(self.body)
            self._ram_from = T[:3, 3].copy()
            self._ram_quat = quat_xyzw_from_matrix(self.R_seated)
            self._hold = self.world.add_pose_constraint(self.body, T, self.ram_force_N)
        # the ram runs on the mate axis through the seat (the press is aligned with the bore),
        # from where the robot left the part along the axis
        assert self.t_ram_s is not None  # only called once the ram has started
        to_go = float((self.p_seated_m - self._ram_from) @ self.axis_world)
        left = max(to_go - self.ram_speed_m_s * (t - self.t_ram_s), 0.0)
        target = self.p_seated_m - self.axis_world * left
        self.world.move_pose_constraint(self._hold, target, self._ram_quat, self.ram_force_N)
        if f > 0:
            com = self.world.com_position_m(self.body)
            self.world.apply_force(self.body, -1, -f * self.axis_world, com)

    def summary(self) -> dict[str, Any]:
        xs = [s[0] for s in self.samples] or [0.0]
        fs = [s[1] for s in self.samples] or [0.0]
        final = xs[-1]
        peak = max(fs)
        home = final >= self.stroke_m - 1e-4
        within = self.by != "press" or peak <= self.press_max_force_N
        verdict = (f"pressed by the {self.by} to depth {final * 1e3:.2f} of "
                   f"{self.stroke_m * 1e3:.2f} mm with peak {peak:.4g} N"
                   + ("" if home else " (not home)")
                   + ("" if within else f" (above the press max {self.press_max_force_N:.4g} N)"))
        # thin the curve to at most 200 points for the results file
        step = max(1, len(self.samples) // 200)
        return {"by": self.by, "depth_m": self.depth_m, "stroke_m": self.stroke_m,
                "final_depth_m": final,
                "peak_force_N": peak, "home": home, "within_press_max": within,
                "force_full_typical_N": self.force_full_N, "verdict": verdict,
                "force_depth": [[x, f] for x, f in self.samples[::step]]}


def press_recorder(world: Any, body: int, step: Step, gripper_body: int, ram_speed_m_s: float,
                   every: int = 1) -> PressRecorder | None:
    """A :class:`PressRecorder` for ``step`` (None when the step presses nothing). For a
    press operation the ram starts when the gripper has let go (the end of the trajectory's
    "release" phase) and moves at ``ram_speed_m_s``."""
    op = step.press
    if op is None or step.insertion_direction is None or step.trajectory is None:
        return None
    axis = np.asarray(step.insertion_direction, float)
    T_seated = np.asarray(step.T_world_final, float)
    t_ram = next((p.t_end_s for p in step.trajectory.phases if p.name == "release"), None)
    return PressRecorder(world, body, axis / np.linalg.norm(axis), T_seated[:3, 3].copy(),
                         float(op.depth_m), float(op.stroke_m), float(op.force_N[1]), op.by,
                         float(op.press_max_force_N), gripper_body, every=every,
                         t_ram_s=None if op.by != "press" else t_ram,
                         t0_s=float(step.trajectory.t_s[0]), ram_speed_m_s=float(ram_speed_m_s),
                         R_seated=T_seated[:3, :3].copy())


__all__ = ["ON_AXIS_M", "SPEED_SCALE_M_S", "PressRecorder", "press_clearance_m", "press_recorder",
           "press_relaxed"]
