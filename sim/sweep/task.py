"""The task of a plan sweep: the perturbed product and plan of one sample, simulated step by step
(pybullet is imported in the worker, when the task runs).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from ..pose_error import POSE_ERROR_RAMP_PHASE, apply_pose_error, insertion_frame  # noqa: F401
from .journal import canonical_json, sha256_hex
from .sampling import PoseError, SampleParams, SweepSpec, clearance_ranges, draw_samples, nominal_friction

try:  # POSIX advisory locks keep two sweeps from appending to one journal
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]


def perturb_product(product: Any, params: SampleParams) -> Any:
    """The product as sample ``params`` has it: its clearances and friction coefficients.

    A mate's clearance ``c`` replaces its declared range (``clearance_min_m = clearance_max_m
    = c``, ``fit`` None), so the geometry (:func:`asmplan.parts.geometry.fitted_sizes`) gives
    the hole ``nominal + c/2`` and the pin ``nominal - c/2`` (symmetric about the nominal,
    whatever the fit's deviations were). Friction replaces each part's coefficient. Mates and
    parts not in ``params`` are unchanged.
    """
    from dataclasses import replace

    mates = tuple(
        replace(m, clearance_min_m=float(params.clearance_m[m.name]),
                clearance_max_m=float(params.clearance_m[m.name]), fit=None)
        if m.name in params.clearance_m else m
        for m in product.mates)
    parts = tuple(replace(p, friction=float(params.friction[p.name]))
                  if p.name in params.friction else p for p in product.parts)
    return replace(product, mates=mates, parts=parts)


@dataclass(frozen=True, eq=False)
class PlanSweep:
    """What every sample of a plan sweep shares (pickled with each task).

    Parameters
    ----------
    product : asmplan.knowledge.model.Product
    plan : asmplan.planner.plan.Plan
        A plan for ``product``.
    fidelity : asmplan.sim.fidelity.Fidelity
    steps : tuple of int
        Plan step indices to simulate per sample (default: every step that moves a part).
        Each step is simulated from its planned start state, so its success rate is that of
        the step given that the steps before it succeeded.
    """

    product: Any
    plan: Any
    fidelity: Any
    steps: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        n = len(self.plan.steps)
        steps = tuple(self.steps) or tuple(k for k, st in enumerate(self.plan.steps)
                                           if st.kind != "fixture")
        bad = [k for k in steps if not 0 <= k < n or self.plan.steps[k].kind == "fixture"]
        if bad:
            raise ValueError(f"PlanSweep.steps: expected indices of non-fixture steps in 0..{n - 1}, "
                             f"found {bad}")
        if self.plan.product != self.product.name:
            raise ValueError(f"PlanSweep: the plan is for product {self.plan.product!r}, found "
                             f"product {self.product.name!r}")
        object.__setattr__(self, "steps", steps)

    @property
    def step_names(self) -> tuple[str, ...]:
        """One name per simulated step: the part it moves (unique within a plan)."""
        return tuple(self.plan.steps[k].part for k in self.steps)

    def fingerprint(self) -> str:
        """SHA-256 of the product file, the plan and the fidelity (for the journal header)."""
        source = Path(self.product.source)
        data = source.read_bytes() if source.is_file() else str(source).encode("utf-8")
        return sha256_hex(data, self.plan.to_json(), canonical_json(asdict(self.fidelity)))

    def samples(self, spec: SweepSpec) -> list[SampleParams]:
        """:func:`draw_samples` for this product's mates, parts and steps."""
        return draw_samples(spec, clearance_ranges(self.product), nominal_friction(self.product),
                            self.step_names)


def simulate_sample(sweep: PlanSweep, params: SampleParams) -> dict[str, Any]:
    """The sweep task: simulate every step of ``sweep`` with the sample's parameters.

    Returns
    -------
    dict
        ``{"steps": {part: {"success", "reasons", "failed_criteria", "failures", "outcome"}}}``
        (``failures``: the failed criteria's values and limits) with the
        outcome's numbers (:class:`~asmplan.sim.records.StepOutcome`, NaN as None, without its
        wall time), JSON-safe.
    """

    from ...parts.models import ProductGeometry
    from ..results import criteria_for
    from ..simulate import simulate_step

    product = perturb_product(sweep.product, params)
    geometry = ProductGeometry(product)
    criteria = criteria_for(sweep.product)
    out: dict[str, Any] = {}
    for k in sweep.steps:
        step = sweep.plan.steps[k]
        err = params.pose_error(step.part)
        res = simulate_step(sweep.plan, k, product, geometry, sweep.fidelity, criteria=criteria,
                            pose_error=err if err != PoseError() else None)
        outcome = None if res.outcome is None else res.outcome.to_dict()
        if outcome is not None:
            outcome.pop("wall_time_s", None)
        failures = {name: {"value": _finite(res.criteria[name]["value"]),
                           "limit": _finite(res.criteria[name]["limit"])}
                    for name in res.failed_criteria}
        out[step.part] = {"success": res.success if res.simulated else None,
                          "reasons": list(res.reasons),
                          "failed_criteria": list(res.failed_criteria),
                          "failures": failures,
                          "outcome": outcome}
    return {"steps": out}




def _finite(v: Any) -> Any:
    """A criterion's value or limit as JSON: NaN and infinities become None."""
    return None if isinstance(v, float) and not math.isfinite(v) else v
