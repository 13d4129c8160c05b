"""The simulation's results: every criterion of a step by name with its measured value and limit,
a step's :class:`StepResult`, a plan's :class:`PlanResults`, and their results.json form
(``docs/results-format.md``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from ..fileio import atomic_write_json, dumps_json
from ..knowledge.model import Product
from .fidelity import Fidelity
from .records import StepOutcome, StepRecord, SuccessCriteria
from .resolution import Unresolved
from .scene import (
    SceneSettings,
)
from .verdicts import Failure

if TYPE_CHECKING:
    pass
RESULTS_FORMAT = "asmplan-results"
RESULTS_VERSION = 1

def _clean(v: Any) -> Any:
    """JSON-safe copy: non-finite floats become None, tuples lists, arrays lists."""
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, np.ndarray):
        if v.dtype.kind in "biu" or (v.dtype.kind == "f" and bool(np.isfinite(v).all())):
            return v.tolist()  # already JSON-safe: no per-element pass (records are large)
        return _clean(v.tolist())
    if isinstance(v, np.generic):
        return _clean(v.item())
    if isinstance(v, dict):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_clean(x) for x in v]
    return v


def _nan(v: Any) -> float:
    return math.nan if v is None else float(v)


def criteria_for(product: Product) -> SuccessCriteria:
    """Success criteria from the product's process knowledge (defaults for the rest)."""
    p = product.process
    return SuccessCriteria(position_tol_m=float(p.position_tolerance_m),
                           max_slip_m=float(p.max_slip_m),
                           max_insertion_force_N=float(p.max_insertion_force_N))


def criteria_table(outcome: StepOutcome, criteria: SuccessCriteria, has_axis: bool
                   ) -> dict[str, dict[str, Any]]:
    """Every criterion by name: measured ``value``, ``limit`` and ``ok`` (SI units).

    Names: position, angle, insertion_depth (only with a mate axis), slip, rotational_slip,
    drop, insertion_force, penetration, nan, energy.
    """
    def row(value: float, limit: float) -> dict[str, Any]:
        ok = bool(value <= limit) if math.isfinite(value) else False
        return {"value": value, "limit": limit, "ok": ok}

    out = {
        "position": row(outcome.final_position_error_m, criteria.position_tol_m),
        "angle": row(outcome.final_angle_error_rad, criteria.angle_tol_rad),
        "slip": row(outcome.max_slip_m, criteria.max_slip_m),
        "rotational_slip": row(outcome.max_slip_rad, criteria.max_slip_rad),
        "drop": {"value": bool(outcome.dropped), "limit": False, "ok": not outcome.dropped},
        "insertion_force": row(outcome.peak_insertion_force_N, criteria.max_insertion_force_N),
        "penetration": row(outcome.max_penetration_m, criteria.max_penetration_m),
        "nan": {"value": bool(outcome.nan_detected), "limit": False,
                "ok": not outcome.nan_detected},
        "energy": {"value": bool(outcome.energy_growth), "limit": False,
                   "ok": not outcome.energy_growth},
    }
    if has_axis:
        out["insertion_depth"] = row(outcome.final_axial_error_m, criteria.axial_tol_m)
    return out


def _outcome_to_dict(o: StepOutcome) -> dict[str, Any]:
    d = o.to_dict()
    d.pop("wall_time_s", None)  # wall-clock time is not part of the physics result
    return d


def _outcome_from_dict(d: dict[str, Any]) -> StepOutcome:
    kw: dict[str, Any] = {}
    for f in fields(StepOutcome):
        if f.name == "wall_time_s":
            continue
        if f.name == "failures":
            kw[f.name] = tuple(Failure.from_dict(x) for x in d.get("failures") or ())
            continue
        v = d[f.name]
        if f.name in ("reasons", "warnings"):
            v = tuple(v)
        elif f.name in ("success", "dropped", "nan_detected", "energy_growth"):
            v = bool(v)
        else:
            v = _nan(v)
        kw[f.name] = v
    return StepOutcome(**kw)


@dataclass(frozen=True, eq=False)
class StepResult:
    """What simulating one step gave.

    Attributes
    ----------
    index : int
    part : str
    kind : str
        The plan step's kind; "fixture" steps are not simulated (the part is in place).
    outcome : StepOutcome or None
        None when not simulated.
    record : StepRecord or None
        Per-tick record (time, phase, commanded and measured clamp force, slip, part pose,
        insertion depth, contact forces on the part, ...).
    scene : dict or None
        :meth:`StepScene.summary` of the bodies simulated and those left out, with reasons.
    warnings : tuple of str
        What the preset may not resolve in this step (checked before simulating).
    criteria : dict
        :func:`criteria_table`: every criterion with value, limit and ok.
    wall_time_s : float
        Wall-clock time of the step (selection, building, simulation), s. Not in the JSON.
    timing_s : dict
        Wall-clock time per stage ("select", "build", "simulate"), s. Not in the JSON.
    press : dict or None
        For a press step (:mod:`asmplan.sim.press`): who pressed, the final engaged depth,
        the peak force, the force-depth curve ``[[depth m, force N], ...]`` and the verdict.
    pose_error : dict or None
        The robot pose error applied at the insertion, if any.
    unresolved : tuple of Unresolved
        What the preset does not resolve in this failed step (:mod:`asmplan.sim.resolution`):
        when set, the step is "unresolved", not "failed" (it is not a success either); the
        outcome keeps what the preset saw as evidence.
    partners : list of dict or None
        The mate partners held static under a load check (:mod:`asmplan.sim.partner_hold`),
        one entry per group: bodies, whether held, why not or when and why it woke, the
        number of checks and the largest sliding and tipping ratios seen.
    carry : dict or None
        The held part stuck to the palm while its grip holds the load
        (:mod:`asmplan.sim.carry_hold`): whether and from when it was stuck, when and why it
        was released, the largest load ratio against the grip's capacity.
    """

    index: int
    part: str
    kind: str
    outcome: StepOutcome | None
    record: StepRecord | None
    scene: dict[str, Any] | None
    warnings: tuple[str, ...]
    criteria: dict[str, dict[str, Any]] = field(default_factory=dict)
    wall_time_s: float = 0.0
    timing_s: dict[str, float] = field(default_factory=dict)
    press: dict[str, Any] | None = None
    pose_error: dict[str, list[float]] | None = None
    unresolved: tuple[Unresolved, ...] = ()
    partners: list[dict[str, Any]] | None = None
    carry: dict[str, Any] | None = None

    @property
    def simulated(self) -> bool:
        return self.outcome is not None

    @property
    def verdict(self) -> str:
        """"success", "failed" or "unresolved" (the preset does not resolve why it failed)."""
        if self.success:
            return "success"
        return "unresolved" if self.unresolved else "failed"

    @property
    def success(self) -> bool:
        """True when every criterion held (or the step was not simulated)."""
        return self.outcome is None or self.outcome.success

    @property
    def failed_criteria(self) -> tuple[str, ...]:
        """Names of the criteria that failed (see :func:`criteria_table`)."""
        return tuple(sorted(k for k, v in self.criteria.items() if not v["ok"]))

    @property
    def reasons(self) -> tuple[str, ...]:
        """The failed criteria with their numbers (empty on success)."""
        return () if self.outcome is None else self.outcome.reasons

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict without wall-clock times."""
        out = _clean({
            "index": self.index, "part": self.part, "kind": self.kind,
            "simulated": self.simulated, "success": self.success,
            "failed_criteria": list(self.failed_criteria),
            "outcome": None if self.outcome is None else _outcome_to_dict(self.outcome),
            "criteria": self.criteria,
            "record": None,
            "scene": self.scene, "warnings": list(self.warnings), "press": self.press,
            **({} if self.pose_error is None else {"pose_error": self.pose_error}),
            **({"unresolved": [u.to_dict() for u in self.unresolved]} if self.unresolved
               else {}),
            **({} if self.partners is None else {"partners": self.partners}),
            **({} if self.carry is None else {"carry": self.carry}),
        })
        # the record is JSON-safe as it comes (StepRecord.to_dict): not walked element by
        # element again (its ~10^5 numbers were most of results.json's cost)
        out["record"] = None if self.record is None else self.record.to_dict()
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> StepResult:
        crit = {k: {"value": (_nan(v["value"]) if not isinstance(v["value"], bool)
                              else v["value"]),
                    "limit": v["limit"], "ok": bool(v["ok"])}
                for k, v in (d.get("criteria") or {}).items()}
        return cls(index=int(d["index"]), part=d["part"], kind=d["kind"],
                   outcome=None if d["outcome"] is None else _outcome_from_dict(d["outcome"]),
                   record=None if d["record"] is None else StepRecord.from_dict(d["record"]),
                   scene=d["scene"], warnings=tuple(d["warnings"]), criteria=crit,
                   press=d.get("press"),
                   pose_error=d.get("pose_error"),
                   unresolved=tuple(Unresolved.from_dict(u) for u in d.get("unresolved", ())),
                   partners=d.get("partners"), carry=d.get("carry"))


@dataclass(frozen=True, eq=False)
class PlanResults:
    """The simulation of a whole plan.

    Attributes
    ----------
    product : str
    source : str
        The product file the plan names.
    plan_sequence : tuple of str
    fidelity : Fidelity
    culled : bool
        Whether each step's scene held only the bodies it needs.
    scene_settings : SceneSettings
    steps : tuple of StepResult
    warnings : tuple of str
        Plan-wide warnings (fits the preset cannot resolve, with how to read the result).
    """

    product: str
    source: str
    plan_sequence: tuple[str, ...]
    fidelity: Fidelity
    culled: bool
    scene_settings: SceneSettings
    steps: tuple[StepResult, ...]
    warnings: tuple[str, ...] = ()

    @property
    def success(self) -> bool:
        """True when every simulated step succeeded."""
        return all(s.success for s in self.steps)

    @property
    def failed_steps(self) -> tuple[StepResult, ...]:
        """Steps that failed for a reason the preset resolves."""
        return tuple(s for s in self.steps if s.verdict == "failed")

    @property
    def unresolved_steps(self) -> tuple[StepResult, ...]:
        """Steps that failed for a reason the preset does not resolve (neither a success
        nor a failure; :mod:`asmplan.sim.resolution`)."""
        return tuple(s for s in self.steps if s.verdict == "unresolved")

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict (no wall-clock times; see :meth:`timing`)."""
        out = _clean({
            "format": RESULTS_FORMAT, "version": RESULTS_VERSION,
            "product": self.product, "source": self.source,
            "sequence": list(self.plan_sequence),
            "fidelity": asdict(self.fidelity), "culled": self.culled,
            "scene_settings": asdict(self.scene_settings),
            "success": self.success,
            "failed_steps": [s.index for s in self.failed_steps],
            **({"unresolved_steps": [s.index for s in self.unresolved_steps]}
               if self.unresolved_steps else {}),
            "warnings": list(self.warnings),
            "steps": None,
        })
        out["steps"] = [s.to_dict() for s in self.steps]  # JSON-safe already
        return out

    def to_json(self) -> str:
        """Deterministic JSON text (sorted keys): bit-identical for the same plan and preset."""
        return dumps_json(self.to_dict())

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PlanResults:
        if d.get("format") != RESULTS_FORMAT:
            raise ValueError(f"results: expected format {RESULTS_FORMAT!r}, found "
                             f"{d.get('format')!r}")
        if d.get("version") != RESULTS_VERSION:
            raise ValueError(f"results: expected version {RESULTS_VERSION}, found "
                             f"{d.get('version')!r}")
        return cls(product=d["product"], source=d["source"],
                   plan_sequence=tuple(d["sequence"]), fidelity=Fidelity(**d["fidelity"]),
                   culled=bool(d["culled"]), scene_settings=SceneSettings(**d["scene_settings"]),
                   steps=tuple(StepResult.from_dict(s) for s in d["steps"]),
                   warnings=tuple(d["warnings"]))

    @classmethod
    def from_json(cls, text: str) -> PlanResults:
        import json

        return cls.from_dict(json.loads(text))

    def write(self, path: Any) -> Any:
        """Write :meth:`to_json` atomically; returns the path."""
        return atomic_write_json(path, self.to_dict())

    def timing(self) -> dict[str, Any]:
        """Wall-clock times (outside the determinism guarantee): per step and total, s."""
        steps = [{"index": s.index, "part": s.part, "wall_time_s": s.wall_time_s,
                  **{f"{k}_s": v for k, v in s.timing_s.items()},
                  "simulated_s": (float(s.record.t_s[-1] - s.record.t_s[0])
                                  if s.record is not None and s.record.n_ticks else 0.0)}
                 for s in self.steps]
        return {"fidelity": self.fidelity.name, "culled": self.culled,
                "total_s": sum(s.wall_time_s for s in self.steps), "steps": steps}

