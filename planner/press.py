"""Press steps: who pushes a press-fitted part home, and the force it takes.

A step whose mates with the parts already placed include interference or transition fits
needs the axial force of :mod:`asmplan.parts.press_fit` (the forces of mates engaged together
add up). The planner sizes the step on the MAX force (the worst pair the tolerance zones
allow), as a process engineer sizes a press:

* the gripper can push the part in while it holds it by friction only: the largest axial
  force it transmits is ``2 mu F_lim / sf - m (g + a)`` (the clamp force formula of
  :func:`asmplan.planner.timing.clamp_force` solved for the resistance: ``F_lim`` the gripper's
  ``max_force`` or the part's ``max_clamp_force``, ``mu`` finger times part friction, ``sf``
  the safety factor), and at most the process's ``max_insertion_force`` (what the robot may
  push with). When the max force is within that, the gripper presses and the clamp force is
  planned for the resistance (``gripper_resistance_N``);
* otherwise the cell's press (``resources.press``) must do it: the step is a press operation.
  The robot carries the part to the HAND-OVER pose (on the hole's mouth, backed off its
  engaged depth: :func:`hand_over_pose`; its grasp need only be free there, so a bearing
  pressed flush into a bore can be handled by an outside gripper) and lets go; the ram pushes
  it home at the process's insertion speed (the step's trajectory lasts until then,
  :func:`press_step`). The part's whole travel to its seat is collision-checked as for any
  insertion. The grip carries no press force but is planned firm, see
  ``PressOperation.gripper_resistance_N``. Without a
  press, or with one too weak, planning fails with
  :class:`PressRequiredError` carrying the numbers.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..knowledge.model import Product
from ..knowledge.press_fit import PressFit
from .errors import PlanningError
from .timing import G_M_S2, motion_limits
from .trajectory import PhaseSpan, Trajectory

if TYPE_CHECKING:
    from .plan import Step


def _kn(v: float) -> str:
    return f"{v / 1e3:.2g} kN" if v >= 1e3 else f"{v:.3g} N"


@dataclass(frozen=True)
class PushCapacity:
    """The largest axial force the robot and gripper may press a part in with (N), and why."""

    force_N: float
    grip_N: float
    robot_N: float
    source: str

    def as_dict(self) -> dict[str, Any]:
        return {"force_N": self.force_N, "grip_N": self.grip_N, "robot_N": self.robot_N,
                "source": self.source}


def push_capacity(product: Product, part: str, mass_kg: float) -> PushCapacity:
    """:class:`PushCapacity` of the gripper holding ``part`` (see the module docstring)."""
    p = product.part(part)
    gripper = product.gripper_for(part)
    limit = float(gripper.max_force_N)
    if p.handling.max_clamp_force_N is not None:
        limit = min(limit, float(p.handling.max_clamp_force_N))
    mu = float(gripper.finger_friction) * float(p.friction)
    sf = float(product.process.safety_factor)
    a = motion_limits(product, part).max_acceleration_m_s2
    grip = max(2.0 * mu * limit / sf - mass_kg * (G_M_S2 + a), 0.0)
    robot = float(product.process.max_insertion_force_N)
    source = (f"grip: 2 x mu {mu:.2f} x {limit:g} N / safety factor {sf:g} - weight"
              if grip <= robot else f"process max_insertion_force {robot:g} N")
    return PushCapacity(min(grip, robot), grip, robot, source)


@dataclass(frozen=True)
class PressOperation:
    """How one step's press fits go home (SI).

    ``force_N`` (min, typical, max) sums the step's interfering mates at full depth;
    ``by`` is ``"gripper"`` (the robot pushes, the grip carries ``gripper_resistance_N``) or
    ``"press"`` (the cell's press, up to ``press_max_force_N``). ``depth_m`` is the engaged
    length: the predicted resistance grows linearly with the contact length to ``force_N``
    there (and stays there over the rest of a longer ``stroke_m``).
    """

    part: str
    mates: tuple[str, ...]
    force_N: tuple[float, float, float]
    probability_interference: float
    depth_m: float
    by: Literal["gripper", "press"]
    capacity: PushCapacity
    press_max_force_N: float = math.nan
    pass_through_m: float = 0.0

    @property
    def stroke_m(self) -> float:
        """How far the part travels while engaged with its press partners, m: the engaged
        length, or more when the part passes through them first (a hinge pin through a
        lever's eye)."""
        return max(self.depth_m, self.pass_through_m)

    @property
    def gripper_resistance_N(self) -> float:
        """Axial force the grip is planned to carry while inserting, N: the max press force
        when the gripper presses; for a press operation half the grip's push capacity (the
        robot sets the part on the chamfered mouth, where it must not tilt in the fingers; no
        model here predicts that contact force, so the grip is firm, with half the gripper in
        reserve)."""
        return self.force_N[2] if self.by == "gripper" else 0.5 * self.capacity.force_N

    def predicted_curve(self, n: int = 11) -> list[tuple[float, float]]:
        """(depth m, resistance N) at the typical force, linear in the engaged depth."""
        return [(self.depth_m * k / (n - 1), self.force_N[1] * k / (n - 1)) for k in range(n)]

    def to_dict(self) -> dict[str, Any]:
        return {"part": self.part, "mates": list(self.mates),
                "force_N": dict(zip(("min", "typical", "max"), self.force_N, strict=True)),
                "probability_interference": self.probability_interference,
                "depth_m": self.depth_m, "stroke_m": self.stroke_m,
                "pass_through_m": self.pass_through_m,
                "by": self.by, "capacity": self.capacity.as_dict(),
                "press_max_force_N": None if math.isnan(self.press_max_force_N)
                else self.press_max_force_N,
                "gripper_resistance_N": self.gripper_resistance_N,
                "predicted_force_depth": [list(p) for p in self.predicted_curve()]}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PressOperation:
        f = d["force_N"]
        pmax = d.get("press_max_force_N")
        return cls(d["part"], tuple(d["mates"]), (f["min"], f["typical"], f["max"]),
                   float(d["probability_interference"]), float(d["depth_m"]), d["by"],
                   PushCapacity(**d["capacity"]), math.nan if pmax is None else float(pmax),
                   float(d.get("pass_through_m", 0.0)))


class PressRequiredError(PlanningError):
    """A press fit needs more force than the gripper (or the declared press) can give.

    Evidence: the force range, the mates, the gripper's push capacity and how it was derived,
    and the press's max force when one is declared.
    """

    kind = "press_required"

    def __init__(self, step: int, part: str, mates: Sequence[str],
                 force_N: tuple[float, float, float], capacity: PushCapacity,
                 press_max_force_N: float | None = None) -> None:
        self.mates = tuple(mates)
        self.force_N = tuple(float(x) for x in force_N)
        self.capacity = capacity
        self.press_max_force_N = press_max_force_N
        lo, _, hi = self.force_N
        if lo >= 1e3:
            need = f"needs {lo / 1e3:.2g}-{hi / 1e3:.2g} kN"
        else:
            need = f"needs {_kn(lo)}-{_kn(hi)}" if lo > 0 else f"needs up to {_kn(hi)}"
        if press_max_force_N is None:
            tail = (f"gripper max {_kn(capacity.force_N)} ({capacity.source}): use a press "
                    "(declare resources.press: {max_force: ...})")
        else:
            tail = (f"gripper max {_kn(capacity.force_N)} and the press max "
                    f"{_kn(press_max_force_N)}: use a stronger press")
        super().__init__(f'step {step} (part "{part}"): press fit {", ".join(self.mates)} '
                         f"{need}; {tail}", step, part)

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "mates": list(self.mates),
                "force_N": dict(zip(("min", "typical", "max"), self.force_N, strict=True)),
                "capacity": self.capacity.as_dict(), "press_max_force_N": self.press_max_force_N}


def press_operation(product: Product, part: str, placed: Sequence[str], mass_kg: float,
                    press_fits: Mapping[str, PressFit], step: int) -> PressOperation | None:
    """The press operation of inserting ``part`` into the parts ``placed`` (None when no mate
    engaged in this step interferes).

    Raises
    ------
    PressRequiredError
        The max force exceeds what the gripper can push and no press (or too weak a press) is
        declared.
    """
    placed_set = set(placed)
    fits = [press_fits[m.name] for m in product.mates if m.name in press_fits
            and ((m.pin_part == part and m.hole_part in placed_set)
                 or (m.hole_part == part and m.pin_part in placed_set))]
    if not fits:
        return None
    force = (float(sum(f.force_N[0] for f in fits)), float(sum(f.force_N[1] for f in fits)),
             float(sum(f.force_N[2] for f in fits)))
    p_any = 1.0 - math.prod(1.0 - f.probability_interference for f in fits)
    depth = max(f.engaged_length_m for f in fits)
    names = tuple(f.mate for f in fits)
    capacity = push_capacity(product, part, mass_kg)
    if force[2] <= capacity.force_N:
        return PressOperation(part, names, force, p_any, depth, "gripper", capacity)
    press = product.resources.press
    if press is None:
        raise PressRequiredError(step, part, names, force, capacity)
    if force[2] > press.max_force_N:
        raise PressRequiredError(step, part, names, force, capacity, press.max_force_N)
    return PressOperation(part, names, force, p_any, depth, "press", capacity, press.max_force_N)


PRESS_SETTLE_S = 0.3
"""Time the ram dwells at the end of its stroke before the step ends, s."""


def hand_over_pose(op: PressOperation | None, T_world_seated: np.ndarray,
                   direction_world: np.ndarray) -> np.ndarray:
    """Where the robot leaves the part (4, 4): for a press operation the part stands on the
    hole's mouth, backed off its engaged depth along the insertion direction (the ram pushes
    it home); otherwise the seated pose itself."""
    if op is None or op.by != "press":
        return T_world_seated
    T = np.array(T_world_seated, dtype=float)
    T[:3, 3] -= np.asarray(direction_world, float) * op.stroke_m
    return T


def press_step(step: Step, op: PressOperation, T_world_seated: np.ndarray,
               ram_speed_m_s: float) -> Step:
    """``step`` as a press step: the press record, the seated pose as its final pose (the
    gripper's trajectory ends at the hand-over pose for a press operation) and, for a press
    operation, the trajectory's last (open) phase lengthened by the ram's stroke
    (stroke / ``ram_speed_m_s`` + ``PRESS_SETTLE_S``) so that the step lasts until the part is
    home; with the cell's arm, the arm holds its last joint angles over that time."""
    if op.by != "press" or step.trajectory is None:
        return replace(step, press=op)
    tr = step.trajectory
    stroke_s = op.stroke_m / ram_speed_m_s + PRESS_SETTLE_S
    last = tr.phases[-1]
    end = float(tr.t_s[-1]) + stroke_s
    traj = Trajectory(t_s=np.append(tr.t_s, end),
                      T_world_gripper=np.concatenate([tr.T_world_gripper, tr.T_world_gripper[-1:]]),
                      clamp_force_N=np.append(tr.clamp_force_N, 0.0),
                      phases=(*tr.phases[:-1], PhaseSpan(last.name, last.t_start_s, end)))
    # the arm holds its last pose (the gripper open beside the part) while the ram seats it
    arm = None if step.arm is None else replace(
        step.arm, q_rad=np.concatenate([step.arm.q_rad, step.arm.q_rad[-1:]]))
    return replace(step, press=op, trajectory=traj, arm=arm,
                   T_world_final=np.asarray(T_world_seated),
                   notes=(*step.notes, f"press operation: the robot leaves the part on the mouth, "
                          f"the press seats it over {op.stroke_m * 1e3:.2f} mm at "
                          f"{ram_speed_m_s * 1e3:.0f} mm/s (needs {op.force_N[0]:.4g}-"
                          f"{op.force_N[2]:.4g} N, press max {op.press_max_force_N:.4g} N)"))


def product_press_fits(product: Product, geometry: Any | None = None) -> dict[str, PressFit]:
    """``{mate: PressFit}`` of every interfering or transition mate (empty, without building
    any geometry, when there is none). Mates whose force cannot be predicted are left out
    (``asmplan check`` reports them)."""
    if not any(m.clearance_min_m < 0 for m in product.mates):
        return {}
    from ..parts.models import ProductGeometry
    from ..parts.press_fit import press_fits

    fits, _ = press_fits(product, geometry if geometry is not None else ProductGeometry(product))
    return {f.mate: f for f in fits}


__all__ = ["PRESS_SETTLE_S", "PressOperation", "PressRequiredError", "PushCapacity",
           "hand_over_pose", "press_operation", "press_step", "product_press_fits",
           "push_capacity"]
