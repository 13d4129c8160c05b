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


def sample_press_step(plan: Any, index: int, product: Any, geometry: Any,
                      press_fits: Any = None) -> tuple[Any, dict[str, Any] | None]:
    """Step ``index`` of ``plan`` as the sample's actual sizes have it (``product``: the
    perturbed product, ``geometry`` its geometry), or a ``press_required`` failure.

    The press force of every mate the step engages is predicted for the sample's clearance
    with the model ``check`` and the planner use (:mod:`asmplan.knowledge.press_fit`,
    :func:`asmplan.planner.press.press_operation`): a sample whose fit interferes needs the
    Lame force of ITS interference, one that does not needs none.

    * The plan hands the part to the cell's press (``step.press.by == "press"``): the press
      seats it against the sample's force (0 N for a sample without interference), or the
      step fails ``press_required`` when that force is above the press's max force.
    * Otherwise the robot pushes: the step is a gripper press with the sample's force when it
      interferes, a plain insertion when it does not, and fails ``press_required`` when the
      sample needs more than the grip can push (less friction than planned for; the plan
      would have to hand the part to a press).

    Returns
    -------
    step : asmplan.planner.plan.Step
    failure : dict or None
        ``{"reason", "needed_N", "capacity_N"}`` when the step cannot be done as planned.
    """
    from dataclasses import replace

    from ...planner.plan import assembly_state
    from ...planner.press import PressRequiredError, press_operation, product_press_fits

    step = plan.steps[index]
    planned = step.press
    if step.kind == "fixture" or step.trajectory is None:
        return step, None
    fits = product_press_fits(product, geometry) if press_fits is None else press_fits
    placed = sorted(assembly_state(plan, index).placed)
    mass = float(geometry.mass_properties(step.part).mass_kg)
    try:
        op = press_operation(product, step.part, placed, mass, fits, index)
    except PressRequiredError as e:
        if planned is not None and planned.by == "press" and (
                e.press_max_force_N is None or e.force_N[2] <= e.press_max_force_N):
            op = replace(planned, mates=e.mates, force_N=e.force_N, probability_interference=1.0)
        else:
            limit = e.press_max_force_N if e.press_max_force_N is not None else e.capacity.force_N
            return step, {"reason": f"press_required: {e}", "needed_N": e.force_N[2],
                          "capacity_N": float(limit)}
    if planned is not None and planned.by == "press":
        if op is None:  # no interference in this sample: the press seats it without force
            op = replace(planned, force_N=(0.0, 0.0, 0.0), probability_interference=0.0)
        else:
            op = replace(planned, mates=op.mates, force_N=op.force_N,
                         probability_interference=op.probability_interference)
        return replace(step, press=op), None
    if op is not None and op.by == "press":  # the robot was planned to push; it cannot
        return step, {"reason": f"press_required: step {index} (part \"{step.part}\"): the "
                      f"sample's fit needs {op.force_N[2]:.4g} N, more than the grip can push "
                      f"({op.capacity.force_N:.4g} N, {op.capacity.source}); the plan has the "
                      "robot push it (a press operation would need another plan)",
                      "needed_N": op.force_N[2], "capacity_N": op.capacity.force_N}
    if op is not None and planned is not None:
        op = replace(op, pass_through_m=planned.pass_through_m)
    return replace(step, press=op), None


def perturb_product(product: Any, params: SampleParams) -> Any:
    """The product as sample ``params`` has it: its actual sizes, clearances and friction.

    A feature with a drawn size (``params.size_deviation_m``, one per feature and sample) is
    built at its nominal diameter plus that deviation, whichever mates share it. A mate's
    clearance ``c`` replaces its declared range (``clearance_min_m = clearance_max_m = c``,
    ``fit`` None); between two drawn features ``c`` is their actual difference, so the geometry
    (:func:`asmplan.parts.geometry.fitted_sizes`) builds both at their drawn sizes. A mate
    with a clearance but no drawn sizes (a declared range, or the ``"uniform"`` and
    ``"truncnormal"`` clearance models) gets the hole ``nominal + c/2`` and the pin ``nominal
    - c/2``, or, when one side is a drawn feature, keeps that side and gives the other the
    clearance. Friction replaces each part's coefficient. Mates and parts not in ``params``
    are unchanged.
    """
    from dataclasses import replace

    actual = {}  # (part, feature) -> built diameter, m
    for part in product.parts:
        for f in part.features:
            if f.ref in params.size_deviation_m:
                actual[(f.part, f.name)] = f.diameter_m + float(params.size_deviation_m[f.ref])
    mates = []
    for m in product.mates:
        if m.name not in params.clearance_m:
            mates.append(m)
            continue
        c = float(params.clearance_m[m.name])
        hole, pin = (m.hole_part, m.hole_feature), (m.pin_part, m.pin_feature)
        if hole in actual and pin in actual:
            c = actual[hole] - actual[pin]
        elif hole in actual:
            actual[pin] = actual[hole] - c
        elif pin in actual:
            actual[hole] = actual[pin] + c
        mates.append(replace(m, clearance_min_m=c, clearance_max_m=c, fit=None))

    def part_of(p: Any) -> Any:
        if any((f.part, f.name) in actual for f in p.features):
            p = replace(p, features=tuple(
                replace(f, diameter_m=actual[(f.part, f.name)]) if (f.part, f.name) in actual
                else f for f in p.features))
        return replace(p, friction=float(params.friction[p.name])) if p.name in params.friction else p

    return replace(product, mates=tuple(mates), parts=tuple(part_of(p) for p in product.parts))


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
                                           if st.kind not in ("fixture", "operation"))
        bad = [k for k in steps if not 0 <= k < n
               or self.plan.steps[k].kind in ("fixture", "operation")]
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

    @property
    def step_numbers(self) -> dict[str, int]:
        """Per step name, its plan step number counted from 1 (as ``run`` and the report)."""
        return {self.plan.steps[k].part: k + 1 for k in self.steps}

    def scene_factors(self) -> dict[str, frozenset[str]]:
        """Per step name, the factor keys (:meth:`SampleParams.factors`) that can touch its
        scene: the robot's pose error, the friction of every part placed so far or held, and the
        clearance of every mate between two such parts. A part placed later is still on its
        tray, outside the scene, and never tested for the step."""
        out = {}
        for k in self.steps:
            present = {s.part for s in self.plan.steps[:k + 1]}
            keys = {"pose_lateral_m", "pose_angular_rad"}
            keys |= {f"friction[{p}]" for p in present}
            keys |= {f"clearance[{m.name}]" for m in self.product.mates
                     if m.pin_part in present and m.hole_part in present}
            out[self.plan.steps[k].part] = frozenset(keys)
        return out

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
        (and ``"press"``: who pressed, the final depth and the peak force, for a press step)
        (``failures``: the failed criteria's values and limits) with the
        outcome's numbers (:class:`~asmplan.sim.records.StepOutcome`, NaN as None, without its
        wall time), JSON-safe.
    """

    from ...parts.models import ProductGeometry
    from ...planner.plan import assembly_state
    from ...planner.press import product_press_fits
    from ..results import criteria_for
    from ..simulate import simulate_placed_step

    product = perturb_product(sweep.product, params)
    geometry = ProductGeometry(product)
    criteria = criteria_for(sweep.product)
    fits = product_press_fits(product, geometry)
    out: dict[str, Any] = {}
    for k in sweep.steps:
        step, failure = sample_press_step(sweep.plan, k, product, geometry, fits)
        if failure is not None:
            out[step.part] = {"success": False, "reasons": [failure["reason"]],
                              "failed_criteria": ["press_required"],
                              "failures": {"press_required": {"value": failure["needed_N"],
                                                              "limit": failure["capacity_N"]}},
                              "outcome": None}
            continue
        err = params.pose_error(step.part)
        res = simulate_placed_step(step, assembly_state(sweep.plan, k), product, geometry,
                                   sweep.fidelity, criteria=criteria,
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
        if res.press is not None:  # the sample's press: who, how deep, its peak force
            out[step.part]["press"] = {k: res.press[k] for k in (
                "by", "final_depth_m", "stroke_m", "peak_force_N", "force_full_typical_N", "home")}
    return {"steps": out}




def _finite(v: Any) -> Any:
    """A criterion's value or limit as JSON: NaN and infinities become None."""
    return None if isinstance(v, float) and not math.isfinite(v) else v
