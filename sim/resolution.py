"""Which failed steps a preset does not resolve: 'not resolved at fast', not a failure verdict.

A preset judges only what it resolves (:mod:`asmplan.sim.fidelity`). Below that, a success
still means "it went in at this preset's resolution" (the plan-wide warnings say so), but a
failure is not evidence: FAST, for one, jammed gear_unit's cover on H11/c11 post heads
(80-260 um diametral clearance, 2 mm below what it resolves) with the cover inside the
capture boundary, and its pads let the 49 g shaft turn 1.0 deg at a 6x torsion margin. Those
steps are not failures of the product, and refining FAST's time step does not make them
answers either: gear_unit's shaft, collar and cover all succeed at 1/480 s, but at 1/720 s the
shaft slips out of the grip and the cover jams again, and at 1/960 s the shaft turns 0.83 deg
(``tests/test_gear_unit_fast.py``). So a step whose every failed criterion is explained by
something the preset does not resolve gets a distinct result, :class:`Unresolved`, naming
what it does not resolve and which preset does; its step is neither a success nor a
failure (exit code 1: not proven; results.json ``unresolved``).

Three causes, each decided from the plan and the preset, never from the outcome's wording:

* ``fit``: the step stopped short of its depth (``insertion_depth`` failed, or a rim stop or
  jam) and a clearance fit the held part enters is below the preset's
  ``min_resolvable_clearance_m``; it explains the insertion criteria (position, angle,
  insertion depth, slip and rotational slip as the robot pushes on the stop, insertion
  force). A rim stop farther off the axis than the capture boundary plus half the preset's
  resolution (``c_max / 2`` + both chamfers + ``min_resolvable_clearance_m / 2``) is resolved:
  it stays a failure. Interference and transition fits are simulated with their press force
  (:mod:`asmplan.sim.press`) and keep their verdict.
* ``grip``: the part slipped, turned or dropped in the fingers at a preset whose pads creep
  under a held load (``Fidelity.grip_creep``), while the simulated trajectory's clamp holds
  the load with a margin of at least :data:`GRIP_MARGIN_RESOLVED` (the smallest force it
  commands while carrying over the planner's slip force, its required force without the
  safety factor). Every preset resolves the slip threshold itself (the bench's
  slip scenes, within 1 %).
* ``contact``: the penetration criterion failed with a penetration the preset's solver leaves
  at an impact (``Fidelity.impact_penetration_m``: FAST 2 mm at 1/240 s in metres).

Any other failed criterion (or a ``fell``/``unstable`` stop) keeps the step a failure.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from .fidelity import PRESETS, Fidelity
from .records import HELD_PHASES

if TYPE_CHECKING:
    from ..knowledge.model import Mate, Product
    from ..planner.plan import Step
    from ..planner.trajectory import Trajectory
    from .records import StepOutcome, StepRecord

UnresolvedCode = Literal["fit", "grip", "contact"]
UNRESOLVED_CODES: tuple[str, ...] = ("fit", "grip", "contact")

INSERTION_CRITERIA = frozenset({"position", "angle", "insertion_depth", "slip", "rotational_slip",
                                "insertion_force"})
"""Criteria a stop on an unresolved fit explains (the robot keeps pushing on the stop)."""
GRIP_CRITERIA = frozenset({"slip", "rotational_slip", "drop"})
"""Criteria a creeping grip explains."""
GRIP_MARGIN_RESOLVED = 1.1
"""Smallest planned grip margin (commanded clamp force over the analytic slip force, without
the safety factor) at which a slip at a creeping preset is not resolved: the slip threshold is
resolved within 1 % at every preset (the bench's slip scenes), so a grip within 10 % of it is
judged as simulated."""


@dataclass(frozen=True)
class Unresolved:
    """One thing a step's preset does not resolve, with its numbers.

    Attributes
    ----------
    code : {"fit", "grip", "contact"}
        See the module docstring.
    preset : str
        The preset that ran the step.
    subject : str
        The mate (fit), the part (grip) or the part (contact).
    value : float
        fit: the mate's smallest diametral clearance, m; grip: the planned grip margin (1);
        contact: the largest penetration, m.
    limit : float
        fit: the preset's ``min_resolvable_clearance_m``, m; grip:
        :data:`GRIP_MARGIN_RESOLVED`; contact: the preset's ``impact_penetration_m``, m.
    fit : str
        The mate's ISO fit ("H11/c11"), if declared.
    needs : str
        The coarsest preset that resolves it ("" when none does).
    criteria : tuple of str
        The failed criteria this cause explains.
    """

    code: UnresolvedCode
    preset: str
    subject: str
    value: float
    limit: float
    fit: str = ""
    needs: str = ""
    criteria: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.code not in UNRESOLVED_CODES:
            raise ValueError(f"Unresolved.code: expected one of {list(UNRESOLVED_CODES)}, "
                             f"found {self.code!r}")

    @property
    def cause(self) -> str:
        """What the preset does not resolve and which preset does, in words."""
        run = f"; run --fidelity {self.needs}" if self.needs else "; no preset resolves it"
        if self.code == "fit":
            fit = f"{self.fit}, " if self.fit else ""
            finer = PRESETS.get(self.needs)
            res = ("" if finer is None else
                   f" (resolves {finer.min_resolvable_clearance_m * 1e6:.0f} um)")
            return (f"fit {self.subject} ({fit}{self.value * 1e6:.0f} um diametral clearance) "
                    f"is below the {self.limit * 1e6:.0f} um {self.preset} resolves{run}{res}")
        if self.code == "grip":
            return (f"its pads creep under a held load, and the planned grip holds "
                    f"{self.subject} with {self.value:.1f}x the slip force{run}")
        return (f"{self.subject} penetrated {self.value * 1e3:.3f} mm, within the "
                f"{self.limit * 1e3:.1f} mm its solver leaves at an impact{run}")

    @property
    def message(self) -> str:
        """``not resolved at <preset>: <cause>``."""
        return f"not resolved at {self.preset}: {self.cause}"

    def to_dict(self) -> dict[str, Any]:
        return {"code": self.code, "preset": self.preset, "subject": self.subject,
                "value": self.value, "limit": self.limit, "fit": self.fit, "needs": self.needs,
                "criteria": list(self.criteria), "message": self.message}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Unresolved:
        return cls(code=d["code"], preset=d["preset"], subject=d["subject"],
                   value=float(d["value"]), limit=float(d["limit"]), fit=d.get("fit", ""),
                   needs=d.get("needs", ""), criteria=tuple(d.get("criteria", ())))


def _finer(fidelity: Fidelity, ok: Any) -> str:
    """The coarsest preset other than ``fidelity`` for which ``ok(preset)`` holds."""
    order = sorted(PRESETS.values(), key=lambda f: f.dt_s, reverse=True)
    return next((f.name for f in order if f.name != fidelity.name and ok(f)), "")


def _step_mates(product: Product, part: str, in_scene: Collection[str]) -> list[Mate]:
    return [m for m in product.mates
            if part in (m.pin_part, m.hole_part)
            and (m.hole_part if m.pin_part == part else m.pin_part) in in_scene]


def _final_lateral_m(record: StepRecord | None) -> float:
    if record is None or not record.n_ticks:
        return math.nan
    lat = np.asarray(record.lateral_error_m, float)
    lat = lat[np.isfinite(lat)]
    return float(lat[-1]) if lat.size else math.nan


def held_clamp_force_N(trajectory: Trajectory) -> float:
    """The smallest per-finger clamp force ``trajectory`` commands while it carries the part
    (phases hold, lift, translate, lower), N; NaN when it has none of them."""
    names = [p.name for p in trajectory.phases]
    held = [names.index(n) for n in HELD_PHASES if n in names]
    if not held:
        return math.nan
    idx = trajectory.phase_indices_at(np.asarray(trajectory.t_s, float))
    f = np.asarray(trajectory.clamp_force_N, float)[np.isin(idx, held)]
    return float(f.min()) if f.size else math.nan


def unresolved_causes(outcome: StepOutcome, failed: Collection[str], step: Step,
                      product: Product, in_scene: Collection[str], fidelity: Fidelity,
                      record: StepRecord | None = None,
                      held_force_N: float | None = None) -> tuple[Unresolved, ...]:
    """What ``fidelity`` does not resolve in a failed step, when that explains every failed
    criterion (see the module docstring); () when the step succeeded or failed for a reason
    the preset resolves.

    Parameters
    ----------
    outcome : StepOutcome
    failed : collection of str
        The failed criteria (:attr:`asmplan.sim.results.StepResult.failed_criteria`).
    step : Step
        The plan step (its part, kind and planned clamp).
    product : Product
    in_scene : collection of str
        The parts in the step's world.
    fidelity : Fidelity
    record : StepRecord, optional
        For a rim stop's final lateral offset.
    held_force_N : float, optional
        The per-finger clamp force the simulated trajectory commands while carrying, N
        (:func:`held_clamp_force_N`; default: that of ``step.trajectory``). The grip margin
        is this force over the planner's slip force (its required force without the
        safety factor).
    """
    failed = set(failed)
    if outcome.success or not failed:
        return ()
    codes = {f.code for f in outcome.failures}
    if codes & {"fell", "unstable"}:
        return ()
    causes: list[Unresolved] = []
    explained: set[str] = set()
    stopped = "insertion_depth" in failed or bool(codes & {"rim_stop", "jammed"})
    if step.kind == "insert" and stopped:
        res = fidelity.min_resolvable_clearance_m
        fits = sorted((m for m in _step_mates(product, step.part, in_scene)
                       if 0.0 <= m.clearance_min_m < res), key=lambda m: m.clearance_min_m)
        if fits and "rim_stop" in codes:
            # a rim stop beyond the capture boundary by half the resolution is resolved
            capture = max(0.5 * m.clearance_max_m
                          + product.feature(m.pin_part, m.pin_feature).chamfer_m
                          + product.feature(m.hole_part, m.hole_feature).chamfer_m
                          for m in fits)
            if _final_lateral_m(record) > capture + 0.5 * res:
                fits = []
        if fits:
            m = fits[0]
            hit = tuple(sorted(failed & INSERTION_CRITERIA))
            causes.append(Unresolved(
                "fit", fidelity.name, m.name, float(m.clearance_min_m), float(res),
                fit=m.fit or "", criteria=hit,
                needs=_finer(fidelity, lambda f: f.min_resolvable_clearance_m <= m.clearance_min_m)))
            explained |= INSERTION_CRITERIA
    grip_failed = failed & GRIP_CRITERIA - explained
    clamp = step.clamp
    if held_force_N is None and step.trajectory is not None:
        held_force_N = held_clamp_force_N(step.trajectory)
    if (grip_failed and fidelity.grip_creep and clamp is not None and held_force_N is not None
            and math.isfinite(held_force_N)):
        slip_force = clamp.required_N / max(clamp.safety_factor, 1e-9)
        margin = held_force_N / slip_force if slip_force > 0 else math.inf
        if margin >= GRIP_MARGIN_RESOLVED:
            causes.append(Unresolved(
                "grip", fidelity.name, step.part, float(margin), GRIP_MARGIN_RESOLVED,
                criteria=tuple(sorted(grip_failed)),
                needs=_finer(fidelity, lambda f: not f.grip_creep)))
            explained |= GRIP_CRITERIA
    pen = float(outcome.max_penetration_m)
    if "penetration" in failed and math.isfinite(pen) and pen <= fidelity.impact_penetration_m:
        causes.append(Unresolved(
            "contact", fidelity.name, step.part, pen, float(fidelity.impact_penetration_m),
            criteria=("penetration",),
            needs=_finer(fidelity, lambda f: f.impact_penetration_m < pen)))
        explained.add("penetration")
    if failed - explained:
        return ()
    return tuple(causes)
