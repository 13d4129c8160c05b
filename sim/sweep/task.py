"""The task of a plan sweep: the perturbed product and plan of one sample, simulated step by step
(pybullet is imported in the worker, when the task runs).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .journal import canonical_json, sha256_hex
from .sampling import PoseError, SampleParams, SweepSpec, clearance_ranges, draw_samples, nominal_friction

try:  # POSIX advisory locks keep two sweeps from appending to one journal
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]


def insertion_frame(direction: Sequence[float]) -> np.ndarray:
    """Rotation (3, 3) whose columns are the insertion frame's x, y, z axes in the world.

    z is the insertion direction; x is the world x axis made perpendicular to z (the world y
    axis when z is within ~25 degrees of world x); y = z cross x.
    """
    z = np.asarray(direction, dtype=float)
    n = float(np.linalg.norm(z))
    if not (math.isfinite(n) and n > 0.0):
        raise ValueError(f"insertion direction: expected a non-zero vector, found {list(z)}")
    z = z / n
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = a - (a @ z) * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _rotation_about(axis: np.ndarray, angle_rad: float) -> np.ndarray:
    k = np.asarray(axis, dtype=float)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle_rad) * K + (1.0 - math.cos(angle_rad)) * (K @ K)


POSE_ERROR_RAMP_PHASE = "translate"
"""The phase over which the robot's pose error builds up (min-jerk from 0 to full)."""


def apply_pose_error(trajectory: Any, direction: Sequence[float], error: PoseError) -> Any:
    """The trajectory a robot with positioning error ``error`` really follows.

    The error is that of the place pose: zero until the start of the
    :data:`POSE_ERROR_RAMP_PHASE` phase ("translate"; if absent, the phase before "lower"),
    growing along a min-jerk profile to its full value at its end and constant afterwards
    ("lower", "release", "retreat"). The lateral offset moves the TCP along the insertion
    frame's x and y (:func:`insertion_frame`); the tilt rotates the TCP about those axes
    through the TCP itself (x first, then y).

    Parameters
    ----------
    trajectory : asmplan.planner.trajectory.Trajectory
    direction : (3,) float
        The step's insertion direction, world frame.
    error : PoseError

    Returns
    -------
    Trajectory
        A new trajectory with the same times, forces and phases.
    """
    from ...planner.trajectory import Trajectory, min_jerk

    if error == PoseError():
        return trajectory
    names = [p.name for p in trajectory.phases]
    if POSE_ERROR_RAMP_PHASE in names:
        ramp = trajectory.phases[names.index(POSE_ERROR_RAMP_PHASE)]
    elif "lower" in names and names.index("lower") > 0:
        ramp = trajectory.phases[names.index("lower") - 1]
    else:
        raise ValueError(f"apply_pose_error: expected a '{POSE_ERROR_RAMP_PHASE}' or 'lower' "
                         f"phase, found phases {names}")
    R_ins = insertion_frame(direction)
    t = trajectory.t_s
    s = min_jerk((t - ramp.t_start_s) / (ramp.t_end_s - ramp.t_start_s))
    offset = R_ins[:, :2] @ np.asarray(error.lateral_m, dtype=float)
    T = np.array(trajectory.T_world_gripper, dtype=float)
    for i in np.flatnonzero(s > 0.0):
        R_err = (_rotation_about(R_ins[:, 1], s[i] * error.tilt_rad[1])
                 @ _rotation_about(R_ins[:, 0], s[i] * error.tilt_rad[0]))
        T[i, :3, :3] = R_err @ T[i, :3, :3]
        T[i, :3, 3] += s[i] * offset
    return Trajectory(t_s=t, T_world_gripper=T, clamp_force_N=trajectory.clamp_force_N,
                      phases=trajectory.phases)


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
    from dataclasses import replace

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
        if err != PoseError() and step.insertion_direction is not None:
            traj = apply_pose_error(step.trajectory, step.insertion_direction, err)
            steps = list(sweep.plan.steps)
            steps[k] = replace(step, trajectory=traj)
            plan = replace(sweep.plan, steps=tuple(steps))
        else:
            plan = sweep.plan
        res = simulate_step(plan, k, product, geometry, sweep.fidelity, criteria=criteria)
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
