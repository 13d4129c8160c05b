"""Tolerance-robustness sweeps: sample part tolerances and robot error, run many independent
simulations through any :class:`concurrent.futures.Executor`, journal them, summarise them.

Four pieces, usable on their own:

* **Sampling** -- :class:`SweepSpec` says which factors vary and how; :func:`draw_sample`
  turns ``(spec, sample index)`` into a :class:`SampleParams`. Every factor of every sample
  has its own random stream, ``SeedSequence(spec.seed, spawn_key=(index, crc32(name)))``
  (the same as a child of ``SeedSequence(spec.seed).spawn(...)[index]``), so a sample's values
  depend only on the seed, its index and the factor's name: never on which worker drew it, in
  what order, how many samples the sweep has, or which other factors vary.
* **Execution** -- :func:`run_sweep` submits ``task(params)`` for every sample to an executor
  (a local process pool by default, or a Dask cluster through :func:`connect_dask`), keeps the
  results by sample index, retries samples whose worker died and records a sample that keeps
  killing its worker, or whose task raised, as a failed :class:`TaskResult` with the reason.
* **Journal** -- :class:`SweepJournal` is an append-only JSON-lines file: a header (what the
  sweep is) and one line per finished sample, flushed and fsync'ed as each completes. A resumed
  sweep skips the samples already in it; a different sweep is refused.
* **Statistics** -- :func:`summarize` gives per step the success rate with a Wilson 95 %
  interval, the failure reasons counted, and per varied factor the success rate in bins, the
  point-biserial correlation and a one-factor logistic fit (which factor drives the failures).

A fifth piece wires these to the simulator: :class:`PlanSweep` (product, plan, fidelity),
:func:`perturb_product` (sampled clearances and friction), :func:`apply_pose_error` (the
robot's error on a step's trajectory) and the task :func:`simulate_sample`, which calls
:func:`asmplan.sim.simulate.simulate_step` per step. Importing this module loads no pybullet:
the task imports the simulator when it runs, in the worker.

Distributions (documented once; see :class:`SweepSpec`)
-------------------------------------------------------
clearance
    Diametral clearance (hole minus pin diameter) of every mate, within its declared fit
    range ``[clearance_min_m, clearance_max_m]``: ``"uniform"`` over the range, or
    ``"truncnormal"``: a normal centred on the middle of the range with sigma = range / 6,
    truncated to the range (the +-3 sigma process-capability reading of a tolerance).
friction
    Every part's friction coefficient times ``1 + friction_rel_sigma * z`` with ``z`` a
    standard normal truncated to [-3, 3].
pose
    Robot positioning error per step, in the step's insertion frame (x, y perpendicular to
    the insertion direction): lateral offset (2,) in m and tilt (2,) in rad about x and y.
    ``"normal"``: each component normal with sigma ``pose_lateral_m`` / ``pose_angular_rad``.
    ``"uniform"``: the magnitude uniform in ``[0, pose_lateral_m]`` (``[0, pose_angular_rad]``)
    and the direction uniform on the circle; this covers the magnitudes evenly, which is what a
    study of where success falls off needs.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import hashlib
import json
import math
import multiprocessing
import os
import re
import time
import traceback
import zlib
from collections import Counter, deque
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import IO, Any, Literal

import numpy as np

try:  # POSIX advisory locks keep two sweeps from appending to one journal
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

FACTORS: tuple[str, ...] = ("clearance", "friction", "pose")
"""Factors a sweep can vary."""

JOURNAL_NAME = "sweep-journal.jsonl"
"""File name of the journal inside a sweep's output folder."""

JOURNAL_FORMAT = 1
_TRUNC_Z = 3.0


# ---------------------------------------------------------------------------------------------
# errors


class SweepError(RuntimeError):
    """Base class of the sweep machinery's errors."""


class JournalMismatchError(SweepError):
    """The journal on disk belongs to a different sweep.

    Attributes
    ----------
    path : Path
    differences : tuple of str
        One ``"key: journal has X, this run has Y"`` per differing header entry.
    """

    def __init__(self, path: Path, differences: Sequence[str]) -> None:
        self.path = Path(path)
        self.differences = tuple(differences)
        super().__init__(
            f"{path}: this journal was written for a different sweep, so it cannot be resumed: "
            + "; ".join(self.differences)
            + ". Use a new output folder, or delete the journal to start over."
        )


class JournalCorruptError(SweepError):
    """A line other than the last one of a journal is not a valid record."""

    def __init__(self, path: Path, line_number: int, problem: str) -> None:
        self.path = Path(path)
        self.line_number = line_number
        super().__init__(f"{path}:{line_number}: {problem}")


class JournalLockedError(SweepError):
    """Another process holds the journal open for writing."""


class ExecutorBrokenError(SweepError):
    """A caller-supplied executor broke and cannot be rebuilt by :func:`run_sweep`.

    Attributes
    ----------
    finished : int
        Samples finished (and journalled) before the break; a resume continues from there.
    """

    def __init__(self, message: str, finished: int) -> None:
        self.finished = finished
        super().__init__(message)


class DaskUnavailableError(SweepError):
    """Dask is not installed (it is the optional extra ``asmplan[dask]``)."""


# ---------------------------------------------------------------------------------------------
# sampling


@dataclass(frozen=True)
class SweepSpec:
    """What a sweep samples: which factors vary, their spreads, how many samples, the seed.

    Parameters
    ----------
    n_samples : int
        Number of samples (>= 1).
    seed : int
        Seed of every random choice (>= 0).
    vary : tuple of str
        Subset of :data:`FACTORS` that vary; the others stay nominal (clearance at the middle
        of its range, friction as declared, zero pose error).
    clearance_distribution : {"uniform", "truncnormal"}
        See the module docstring.
    friction_rel_sigma : float
        Relative 1-sigma spread of each friction coefficient, in [0, 1/3) so that the
        truncated multiplier stays positive.
    pose_lateral_m : float
        Lateral robot error: sigma per axis ("normal") or largest magnitude ("uniform"), m.
    pose_angular_rad : float
        Tilt error: sigma per axis ("normal") or largest magnitude ("uniform"), rad.
    pose_distribution : {"normal", "uniform"}
        See the module docstring.
    """

    n_samples: int
    seed: int = 0
    vary: tuple[str, ...] = FACTORS
    clearance_distribution: Literal["uniform", "truncnormal"] = "uniform"
    friction_rel_sigma: float = 0.1
    pose_lateral_m: float = 0.2e-3
    pose_angular_rad: float = math.radians(0.2)
    pose_distribution: Literal["normal", "uniform"] = "normal"

    def __post_init__(self) -> None:
        if isinstance(self.n_samples, bool) or int(self.n_samples) != self.n_samples or self.n_samples < 1:
            raise ValueError(f"SweepSpec.n_samples: expected an integer >= 1, found {self.n_samples!r}")
        if isinstance(self.seed, bool) or int(self.seed) != self.seed or self.seed < 0:
            raise ValueError(f"SweepSpec.seed: expected an integer >= 0, found {self.seed!r}")
        object.__setattr__(self, "n_samples", int(self.n_samples))
        object.__setattr__(self, "seed", int(self.seed))
        vary = (self.vary,) if isinstance(self.vary, str) else tuple(self.vary)
        unknown = [v for v in vary if v not in FACTORS]
        if unknown:
            raise ValueError(
                f"SweepSpec.vary: expected factors among {list(FACTORS)}, found {unknown}")
        # canonical order, no duplicates: the spec (and the journal header) does not depend on
        # how the user listed them
        object.__setattr__(self, "vary", tuple(f for f in FACTORS if f in vary))
        if self.clearance_distribution not in ("uniform", "truncnormal"):
            raise ValueError("SweepSpec.clearance_distribution: expected 'uniform' or "
                             f"'truncnormal', found {self.clearance_distribution!r}")
        if self.pose_distribution not in ("normal", "uniform"):
            raise ValueError("SweepSpec.pose_distribution: expected 'normal' or 'uniform', "
                             f"found {self.pose_distribution!r}")
        s = float(self.friction_rel_sigma)
        if not (math.isfinite(s) and 0.0 <= s < 1.0 / _TRUNC_Z):
            raise ValueError(
                f"SweepSpec.friction_rel_sigma: expected a value in [0, 1/3), found {s}")
        for name in ("pose_lateral_m", "pose_angular_rad"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"SweepSpec.{name}: expected a finite value >= 0, found {v}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict (``vary`` as a list)."""
        d = asdict(self)
        d["vary"] = list(self.vary)
        return d

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SweepSpec:
        """Inverse of :meth:`to_dict`."""
        d = dict(data)
        d["vary"] = tuple(d.get("vary", FACTORS))
        return cls(**d)


@dataclass(frozen=True)
class PoseError:
    """Robot positioning error of one step, in the step's insertion frame.

    The insertion frame's z axis is the insertion direction; x and y span the plane across it.

    Attributes
    ----------
    lateral_m : (2,) tuple of float
        Offset of the part along x and y, m.
    tilt_rad : (2,) tuple of float
        Small rotations about x and y, rad.
    """

    lateral_m: tuple[float, float] = (0.0, 0.0)
    tilt_rad: tuple[float, float] = (0.0, 0.0)

    @property
    def lateral_norm_m(self) -> float:
        return math.hypot(*self.lateral_m)

    @property
    def tilt_norm_rad(self) -> float:
        return math.hypot(*self.tilt_rad)


@dataclass(frozen=True)
class SampleParams:
    """The values one sample runs with (picklable, JSON-able with :meth:`to_dict`).

    Attributes
    ----------
    index : int
        Sample index in the sweep.
    seed : int
        The sweep seed (``SweepSpec.seed``).
    clearance_m : dict of str to float
        Diametral clearance per mate name, m.
    friction : dict of str to float
        Friction coefficient per part name.
    pose : dict of str to PoseError
        Robot error per step name.
    """

    index: int
    seed: int
    clearance_m: dict[str, float] = field(default_factory=dict)
    friction: dict[str, float] = field(default_factory=dict)
    pose: dict[str, PoseError] = field(default_factory=dict)

    def pose_error(self, step: str) -> PoseError:
        """The robot error of ``step`` (zero when the sweep has none for it)."""
        return self.pose.get(step, PoseError())

    def factors(self, step: str, vary: Sequence[str] = FACTORS) -> dict[str, float]:
        """Scalar factor values of this sample as seen by ``step``, for the statistics.

        Keys: ``clearance[<mate>]`` (m), ``friction[<part>]``, ``pose_lateral_m`` (magnitude,
        m) and ``pose_angular_rad`` (magnitude, rad); only the factors in ``vary``.
        """
        out: dict[str, float] = {}
        if "clearance" in vary:
            out.update({f"clearance[{k}]": v for k, v in sorted(self.clearance_m.items())})
        if "friction" in vary:
            out.update({f"friction[{k}]": v for k, v in sorted(self.friction.items())})
        if "pose" in vary:
            p = self.pose_error(step)
            out["pose_lateral_m"] = p.lateral_norm_m
            out["pose_angular_rad"] = p.tilt_norm_rad
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "index": self.index,
            "seed": self.seed,
            "clearance_m": dict(self.clearance_m),
            "friction": dict(self.friction),
            "pose": {k: {"lateral_m": list(p.lateral_m), "tilt_rad": list(p.tilt_rad)}
                     for k, p in self.pose.items()},
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SampleParams:
        return cls(
            index=int(data["index"]),
            seed=int(data["seed"]),
            clearance_m={k: float(v) for k, v in data.get("clearance_m", {}).items()},
            friction={k: float(v) for k, v in data.get("friction", {}).items()},
            pose={k: PoseError(tuple(v["lateral_m"]), tuple(v["tilt_rad"]))  # type: ignore[arg-type]
                  for k, v in data.get("pose", {}).items()},
        )


@dataclass(frozen=True)
class ClearanceRange:
    """A mate's declared diametral clearance range [min_m, max_m] (negative: interference)."""

    mate: str
    min_m: float
    max_m: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.min_m) and math.isfinite(self.max_m) and self.min_m <= self.max_m):
            raise ValueError(f"ClearanceRange {self.mate}: expected finite min <= max, found "
                             f"[{self.min_m}, {self.max_m}]")


def factor_rng(seed: int, index: int, name: str) -> np.random.Generator:
    """The random stream of factor ``name`` in sample ``index`` of a sweep seeded ``seed``."""
    key = zlib.crc32(name.encode("utf-8"))
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index, key)))


def _truncated_standard_normal(rng: np.random.Generator) -> float:
    while True:  # rejection: accepts 99.7 % of draws
        z = float(rng.standard_normal())
        if abs(z) <= _TRUNC_Z:
            return z


def _planar(rng: np.random.Generator, scale: float, distribution: str) -> tuple[float, float]:
    if scale == 0.0:
        return (0.0, 0.0)
    if distribution == "normal":
        a, b = rng.normal(0.0, scale, size=2)
        return (float(a), float(b))
    r = float(rng.uniform(0.0, scale))
    theta = float(rng.uniform(0.0, 2.0 * math.pi))
    return (r * math.cos(theta), r * math.sin(theta))


def draw_sample(
    spec: SweepSpec,
    index: int,
    clearances: Sequence[ClearanceRange],
    friction: Mapping[str, float],
    steps: Sequence[str],
) -> SampleParams:
    """The parameters of sample ``index`` (a pure function of its arguments).

    Parameters
    ----------
    spec : SweepSpec
    index : int
        Sample index, 0 <= index (may exceed ``spec.n_samples`` when extending a sweep).
    clearances : sequence of ClearanceRange
        Declared clearance range of each mate.
    friction : mapping of str to float
        Nominal friction coefficient per part name.
    steps : sequence of str
        Step names that get a robot pose error.

    Returns
    -------
    SampleParams
    """
    if index < 0:
        raise ValueError(f"draw_sample: expected index >= 0, found {index}")
    clear: dict[str, float] = {}
    for c in sorted(clearances, key=lambda c: c.mate):
        if "clearance" not in spec.vary or c.max_m == c.min_m:
            clear[c.mate] = 0.5 * (c.min_m + c.max_m)
            continue
        rng = factor_rng(spec.seed, index, f"clearance/{c.mate}")
        if spec.clearance_distribution == "uniform":
            clear[c.mate] = float(rng.uniform(c.min_m, c.max_m))
        else:
            mid, half = 0.5 * (c.min_m + c.max_m), 0.5 * (c.max_m - c.min_m)
            clear[c.mate] = mid + half * _truncated_standard_normal(rng) / _TRUNC_Z
    fric: dict[str, float] = {}
    for part, mu in sorted(friction.items()):
        if "friction" not in spec.vary or spec.friction_rel_sigma == 0.0:
            fric[part] = float(mu)
            continue
        rng = factor_rng(spec.seed, index, f"friction/{part}")
        fric[part] = float(mu) * (1.0 + spec.friction_rel_sigma * _truncated_standard_normal(rng))
    pose: dict[str, PoseError] = {}
    for step in steps:
        if "pose" not in spec.vary:
            pose[step] = PoseError()
            continue
        rng = factor_rng(spec.seed, index, f"pose/{step}")
        lateral = _planar(rng, spec.pose_lateral_m, spec.pose_distribution)
        tilt = _planar(rng, spec.pose_angular_rad, spec.pose_distribution)
        pose[step] = PoseError(lateral, tilt)
    return SampleParams(index=index, seed=spec.seed, clearance_m=clear, friction=fric, pose=pose)


def draw_samples(
    spec: SweepSpec,
    clearances: Sequence[ClearanceRange],
    friction: Mapping[str, float],
    steps: Sequence[str],
) -> list[SampleParams]:
    """All ``spec.n_samples`` samples, in index order (see :func:`draw_sample`)."""
    return [draw_sample(spec, i, clearances, friction, steps) for i in range(spec.n_samples)]


def clearance_ranges(product: Any) -> tuple[ClearanceRange, ...]:
    """The declared clearance range of every mate of a :class:`~asmplan.knowledge.model.Product`."""
    return tuple(ClearanceRange(m.name, m.clearance_min_m, m.clearance_max_m) for m in product.mates)


def nominal_friction(product: Any) -> dict[str, float]:
    """Friction coefficient per part of a :class:`~asmplan.knowledge.model.Product`."""
    return {p.name: float(p.friction) for p in product.parts}


# ---------------------------------------------------------------------------------------------
# a plan sweep: the perturbed product and plan of one sample, and the task that simulates them


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
    from asmplan.planner.trajectory import Trajectory, min_jerk

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
        return sha256_hex(data, self.plan.to_json(), _canonical(asdict(self.fidelity)))

    def samples(self, spec: SweepSpec) -> list[SampleParams]:
        """:func:`draw_samples` for this product's mates, parts and steps."""
        return draw_samples(spec, clearance_ranges(self.product), nominal_friction(self.product),
                            self.step_names)


def simulate_sample(sweep: PlanSweep, params: SampleParams) -> dict[str, Any]:
    """The sweep task: simulate every step of ``sweep`` with the sample's parameters.

    Returns
    -------
    dict
        ``{"steps": {part: {"success", "reasons", "failed_criteria", "outcome"}}}`` with the
        outcome's numbers (:class:`~asmplan.sim.records.StepOutcome`, NaN as None, without its
        wall time), JSON-safe.
    """
    from dataclasses import replace

    from asmplan.parts.models import ProductGeometry
    from asmplan.sim.simulate import criteria_for, simulate_step

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
        out[step.part] = {"success": res.success if res.simulated else None,
                          "reasons": list(res.reasons),
                          "failed_criteria": list(res.failed_criteria),
                          "outcome": outcome}
    return {"steps": out}


# ---------------------------------------------------------------------------------------------
# results and journal


@dataclass(frozen=True)
class TaskResult:
    """What one sample produced.

    Attributes
    ----------
    index : int
        Sample index.
    ok : bool
        The task returned a value. False when it raised or its worker kept dying; this is not
        the physical verdict, which lives inside ``value``.
    value : JSON-safe object or None
        The task's return value after a JSON round trip (so a fresh result and one read back
        from the journal are equal).
    error : str or None
        Why ``ok`` is False.
    attempts : int
        How many times the sample was started.
    """

    index: int
    ok: bool
    value: Any = None
    error: str | None = None
    attempts: int = 1

    def to_dict(self) -> dict[str, Any]:
        return {"index": self.index, "ok": self.ok, "value": self.value, "error": self.error,
                "attempts": self.attempts}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TaskResult:
        return cls(index=int(data["index"]), ok=bool(data["ok"]), value=data.get("value"),
                   error=data.get("error"), attempts=int(data.get("attempts", 1)))


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def sha256_hex(*chunks: bytes | str) -> str:
    """SHA-256 of the concatenated chunks (str encoded as UTF-8), hex; for journal headers."""
    h = hashlib.sha256()
    for c in chunks:
        h.update(c.encode("utf-8") if isinstance(c, str) else c)
    return h.hexdigest()


def journal_header(spec: SweepSpec, fingerprint: str, **extra: Any) -> dict[str, Any]:
    """The header identifying a sweep: the spec without ``n_samples`` plus a fingerprint.

    ``n_samples`` is left out on purpose: sample ``i`` does not depend on it, so a finished
    sweep can be extended to more samples by resuming it with a larger ``n_samples``.

    Parameters
    ----------
    spec : SweepSpec
    fingerprint : str
        Identifies what is simulated, e.g. ``sha256_hex(product_yaml_bytes, plan_json)``.
    **extra
        Further JSON-safe entries that must match on resume (fidelity, criteria, ...).
    """
    s = spec.to_dict()
    del s["n_samples"]
    return {"spec": s, "fingerprint": fingerprint, **extra}


def _flatten(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


class SweepJournal:
    """Append-only JSON-lines record of a sweep (one per output folder).

    Line 1 is ``{"asmplan_sweep_journal": 1, "header": {...}}``; every further line is one
    :class:`TaskResult` as a JSON object, written with a single ``write`` then flushed and
    fsync'ed. Opening an existing journal checks its header against ``header``
    (:class:`JournalMismatchError` when they differ), reads the finished results, and cuts off
    a last line that a crash left half-written. A POSIX advisory lock refuses a second writer.

    Use as a context manager, or call :meth:`close`.

    Parameters
    ----------
    path : path-like
        The journal file; created (with its folder) when missing.
    header : mapping
        JSON-safe description of the sweep (see :func:`journal_header`).
    """

    def __init__(self, path: str | os.PathLike[str], header: Mapping[str, Any]) -> None:
        self.path = Path(path)
        self.header: dict[str, Any] = json.loads(_canonical(dict(header)))
        self.finished: dict[int, TaskResult] = {}
        self.truncated_bytes = 0
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh: IO[bytes] = open(self.path, "a+b")  # noqa: SIM115 - held open until close()
        try:
            self._lock()
            self._load()
        except BaseException:
            self._fh.close()
            raise

    def _lock(self) -> None:
        if fcntl is None:  # pragma: no cover
            return
        try:
            fcntl.flock(self._fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            raise JournalLockedError(
                f"{self.path}: another process is writing this sweep journal ({exc})") from exc

    def _load(self) -> None:
        self._fh.seek(0)
        data = self._fh.read()
        lines = data.split(b"\n")
        # everything after the last newline is an unfinished line: a crash mid-write
        complete, tail = lines[:-1], lines[-1]
        keep = len(data) - len(tail)
        if not complete:
            self._truncate(0)
            self._write_line({"asmplan_sweep_journal": JOURNAL_FORMAT, "header": self.header})
            return
        try:
            first = json.loads(complete[0])
        except json.JSONDecodeError as exc:
            raise JournalCorruptError(self.path, 1, f"the header line is not JSON ({exc})") from exc
        if not isinstance(first, dict) or first.get("asmplan_sweep_journal") != JOURNAL_FORMAT:
            raise JournalCorruptError(
                self.path, 1, f"expected an asmplan sweep journal header (format {JOURNAL_FORMAT}), "
                f"found {complete[0][:80]!r}")
        have = _flatten(first.get("header", {}))
        want = _flatten(self.header)
        diffs = [f"{k}: journal has {have.get(k, '(missing)')!r}, this run has {want.get(k, '(missing)')!r}"
                 for k in sorted(set(have) | set(want)) if have.get(k) != want.get(k)]
        if diffs:
            raise JournalMismatchError(self.path, diffs)
        for n, raw in enumerate(complete[1:], start=2):
            if not raw.strip():
                continue
            try:
                result = TaskResult.from_dict(json.loads(raw))
            except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
                raise JournalCorruptError(self.path, n, f"not a sample record ({exc})") from exc
            self.finished[result.index] = result
        if tail:  # a line without its newline: the write was cut short; drop it
            self._truncate(keep)

    def _truncate(self, size: int) -> None:
        self.truncated_bytes = self._fh.seek(0, os.SEEK_END) - size
        self._fh.truncate(size)
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def _write_line(self, obj: Mapping[str, Any]) -> None:
        self._fh.seek(0, os.SEEK_END)
        self._fh.write(_canonical(obj).encode("utf-8") + b"\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def append(self, result: TaskResult) -> None:
        """Write one finished sample (durable when this returns)."""
        self._write_line(result.to_dict())
        self.finished[result.index] = result

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.close()

    def __enter__(self) -> SweepJournal:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# ---------------------------------------------------------------------------------------------
# execution

START_METHOD = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
"""Start method of the default pool. Workers are never forked from the caller: a fork copies
the caller's threads' locks (Dask's client thread, BLAS, OMPL) in whatever state they are in.
A forkserver is a fresh single-threaded process that forks the workers."""


def default_executor(max_workers: int | None = None) -> cf.ProcessPoolExecutor:
    """A process pool with ``max_workers`` (default: all cores) started with :data:`START_METHOD`."""
    n = (os.cpu_count() or 1) if max_workers is None else int(max_workers)
    if n < 1:
        raise ValueError(f"default_executor: expected max_workers >= 1, found {max_workers}")
    return cf.ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context(START_METHOD))


def _executor_width(executor: cf.Executor) -> int:
    if isinstance(executor, cf.ProcessPoolExecutor | cf.ThreadPoolExecutor):
        return int(executor._max_workers)  # type: ignore[attr-defined]
    client = getattr(executor, "_client", None)  # distributed.cfexecutor.ClientExecutor
    if client is not None:
        with contextlib.suppress(Exception):
            return max(1, sum(client.nthreads().values()))
    return os.cpu_count() or 1


def _is_worker_death(exc: BaseException) -> bool:
    """A dead worker (retry), as opposed to the task raising (record)."""
    if isinstance(exc, BrokenProcessPool | cf.CancelledError):
        return True
    # distributed.KilledWorker, without importing distributed
    return any(c.__name__ == "KilledWorker" for c in type(exc).__mro__)


_TB_LINE = re.compile(r'File "([^"]+)", line (\d+)')


def _describe(exc: BaseException) -> str:
    """``"Type: message (at file.py:line)"`` with the line where the task raised.

    A process pool attaches the worker's traceback as text in ``__cause__``; Dask rebuilds
    the remote frames in ``__traceback__``.
    """
    where = ""
    cause = exc.__cause__
    if cause is not None and type(cause).__name__ == "_RemoteTraceback":
        found = _TB_LINE.findall(str(cause))
        if found:
            where = f" (at {Path(found[-1][0]).name}:{found[-1][1]})"
    if not where:
        tb = traceback.extract_tb(exc.__traceback__)
        if tb:
            where = f" (at {Path(tb[-1].filename).name}:{tb[-1].lineno})"
    return f"{type(exc).__name__}: {exc}{where}"


ProgressFn = Callable[[int, int, TaskResult], None]


def run_sweep(
    task: Callable[[Any], Any],
    params_list: Sequence[Any],
    executor: cf.Executor | None = None,
    journal: SweepJournal | None = None,
    retries: int = 2,
    max_workers: int | None = None,
    max_in_flight: int | None = None,
    redo_failed: bool = False,
    progress: ProgressFn | None = None,
) -> list[TaskResult]:
    """Run ``task(params_list[i])`` for every sample ``i``; results in index order.

    Parameters
    ----------
    task : callable
        Picklable (a module-level function or a ``functools.partial`` of one) and
        deterministic: its value must depend on its argument only. It returns a JSON-safe value
        (dicts, lists, str, finite numbers, bool, None).
    params_list : sequence
        One picklable argument per sample; the position is the sample index.
    executor : concurrent.futures.Executor, optional
        Where to run. Default: :func:`default_executor` (``max_workers``, all cores), created
        here, rebuilt when a worker dies, and shut down at the end. A Dask cluster:
        ``connect_dask(address).executor``. A caller's executor is not shut down.
    journal : SweepJournal, optional
        Samples already in it are not run again (failed ones neither, unless ``redo_failed``);
        each new result is appended as it completes.
    retries : int
        How often a sample whose worker died is run again before it is recorded as failed.
    max_workers : int, optional
        Workers of the default pool.
    max_in_flight : int, optional
        Samples submitted but not finished at any time (default: twice the executor's workers).
    redo_failed : bool
        Run journalled samples with ``ok=False`` again.
    progress : callable, optional
        Called as ``progress(n_done, n_total, result)`` in the caller's process after every
        sample (journalled ones are not reported).

    Returns
    -------
    list of TaskResult
        ``len(params_list)`` results; ``result[i].index == i``.

    Raises
    ------
    ExecutorBrokenError
        A caller-supplied process pool broke (it cannot be rebuilt here). Finished samples are
        journalled, so a resume continues.

    Notes
    -----
    Worker deaths: ``BrokenProcessPool`` (a pool worker died: every sample in flight fails),
    distributed's ``KilledWorker`` and ``CancelledError``. When a process pool breaks with
    several samples in flight the culprit is unknown, so the samples in flight are re-run one at
    a time ("isolation"); only a death while a sample runs alone counts against its
    ``retries``. A sample whose task raises is recorded as failed at once (a deterministic task
    raises again). Ctrl-C cancels what is in flight and re-raises; the journal keeps the rest.
    """
    n = len(params_list)
    if retries < 0:
        raise ValueError(f"run_sweep: expected retries >= 0, found {retries}")
    results: dict[int, TaskResult] = {}
    if journal is not None:
        for i, r in journal.finished.items():
            if 0 <= i < n and (r.ok or not redo_failed):
                results[i] = r
    pending: deque[int] = deque(i for i in range(n) if i not in results)
    own = executor is None
    ex: cf.Executor = default_executor(max_workers) if executor is None else executor
    cap = max_in_flight if max_in_flight is not None else 2 * _executor_width(ex)
    if cap < 1:
        raise ValueError(f"run_sweep: expected max_in_flight >= 1, found {max_in_flight}")
    started: Counter[int] = Counter()
    deaths: Counter[int] = Counter()  # deaths while running alone
    isolate: deque[int] = deque()
    in_flight: dict[cf.Future[Any], int] = {}
    n_done = len(results)

    def finish(result: TaskResult) -> None:
        nonlocal n_done
        results[result.index] = result
        if journal is not None:
            journal.append(result)
        n_done += 1
        if progress is not None:
            progress(n_done, n, result)

    def submit(i: int) -> bool:
        started[i] += 1
        try:
            in_flight[ex.submit(task, params_list[i])] = i
        except BrokenProcessPool:
            started[i] -= 1
            isolate.appendleft(i)
            return False
        return True

    def rebuild(reason: str) -> None:
        nonlocal ex
        if not own:
            raise ExecutorBrokenError(
                f"the executor broke ({reason}); {n_done} of {n} samples are finished"
                + (" and journalled; resume to continue" if journal is not None else ""), n_done)
        ex.shutdown(wait=False, cancel_futures=True)
        ex = default_executor(max_workers)

    try:
        while pending or isolate or in_flight:
            broken = False
            if isolate:
                if not in_flight:
                    broken = not submit(isolate.popleft())
            else:
                while pending and len(in_flight) < cap:
                    if not submit(pending.popleft()):
                        broken = True
                        break
            if broken and not in_flight:
                rebuild("the process pool was already broken")
                continue
            done, _ = cf.wait(in_flight, return_when=cf.FIRST_COMPLETED)
            alone = len(in_flight) == 1
            pool_broke = False
            if any(isinstance(f.exception(), BrokenProcessPool) for f in done if not f.cancelled()):
                # every other sample in flight fails the same way: collect them all now
                done, _ = cf.wait(in_flight, return_when=cf.ALL_COMPLETED)
                pool_broke = True
            for fut in sorted(done, key=lambda f: in_flight[f]):
                i = in_flight.pop(fut)
                try:
                    value = fut.result()
                except BaseException as exc:
                    if isinstance(exc, KeyboardInterrupt):
                        raise
                    if not _is_worker_death(exc):
                        finish(TaskResult(i, False, None, f"the task raised {_describe(exc)}",
                                          started[i]))
                        continue
                    if pool_broke and not alone:
                        isolate.append(i)  # culprit unknown: run it again on its own
                        continue
                    deaths[i] += 1
                    if deaths[i] > retries:
                        times = f"{deaths[i]} time{'s' if deaths[i] != 1 else ''}"
                        finish(TaskResult(
                            i, False, None, f"worker died {times} running this sample "
                            f"({type(exc).__name__}: {exc})", started[i]))
                    elif pool_broke:
                        isolate.appendleft(i)
                    else:
                        pending.appendleft(i)
                    continue
                try:
                    normalised = json.loads(_canonical(value))
                except (TypeError, ValueError) as exc:
                    finish(TaskResult(i, False, None,
                                      f"the task returned a value that is not JSON-safe ({exc})",
                                      started[i]))
                    continue
                finish(TaskResult(i, True, normalised, None, started[i]))
            if pool_broke:
                rebuild("a worker process died")
    except BaseException:
        for fut in in_flight:
            fut.cancel()
        if own:
            ex.shutdown(wait=False, cancel_futures=True)
        raise
    if own:
        ex.shutdown(wait=True)
    return [results[i] for i in range(n)]


# ---------------------------------------------------------------------------------------------
# Dask


@dataclass
class DaskConnection:
    """A connected ``dask.distributed.Client`` and its ``concurrent.futures`` executor.

    Created by :func:`connect_dask`; close it (or use ``with``) to disconnect. Closing does not
    stop the cluster.
    """

    client: Any
    executor: cf.Executor

    def close(self) -> None:
        self.client.close()

    def __enter__(self) -> DaskConnection:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def connect_dask(address: str, timeout_s: float = 10.0) -> DaskConnection:
    """Connect to a running Dask scheduler (``tcp://HOST:PORT``).

    The executor submits with ``pure=False``: Dask does not merge or cache tasks by argument
    hash, so a resubmitted sample really runs again. The workers must be able to import
    ``asmplan`` and the task's module (same environment on every machine).

    Raises
    ------
    DaskUnavailableError
        When ``dask.distributed`` is not installed.
    OSError
        When no scheduler answers within ``timeout_s``.
    """
    try:
        from dask.distributed import Client
    except ImportError as exc:
        raise DaskUnavailableError(
            "running a sweep on a Dask cluster needs the optional extra: "
            "pip install 'asmplan[dask]'") from exc
    client = Client(address, timeout=timeout_s, set_as_default=False)
    return DaskConnection(client=client, executor=client.get_executor(pure=False))


# ---------------------------------------------------------------------------------------------
# statistics


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion.

    Parameters
    ----------
    successes, n : int
        0 <= successes <= n.
    confidence : float
        Two-sided confidence level in (0, 1).

    Returns
    -------
    (low, high) : tuple of float
        In [0, 1]; ``(0, 1)`` when ``n == 0``.
    """
    if not (0 <= successes <= n):
        raise ValueError(f"wilson_interval: expected 0 <= successes <= n, found {successes}, {n}")
    if n == 0:
        return (0.0, 1.0)
    from scipy.stats import norm

    z = float(norm.ppf(0.5 + 0.5 * confidence))
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    low = 0.0 if successes == 0 else max(0.0, centre - half)  # exact ends (no rounding residue)
    high = 1.0 if successes == n else min(1.0, centre + half)
    return (low, high)


@dataclass(frozen=True)
class BinStat:
    """Success in one bin ``[low, high)`` of a factor (the last bin includes ``high``)."""

    low: float
    high: float
    n: int
    successes: int
    rate: float
    ci_low: float
    ci_high: float


@dataclass(frozen=True)
class FactorEffect:
    """How one factor relates to a step's success.

    Attributes
    ----------
    factor : str
        Factor key (see :meth:`SampleParams.factors`).
    n : int
    correlation : float
        Point-biserial correlation of success (1/0) with the factor; positive: larger values
        succeed more often. NaN when the factor or the outcome does not vary.
    p_value : float
        Two-sided p-value of that correlation (NaN with it).
    logistic_slope_per_sd : float
        Slope of a one-factor logistic fit, in log-odds per standard deviation of the factor
        (slightly ridge-penalised, so finite under perfect separation).
    x50 : float
        Factor value where the fit predicts 50 % success (NaN when outside the sampled range).
    bins : tuple of BinStat
        Equal-width bins over the sampled range.
    """

    factor: str
    n: int
    correlation: float
    p_value: float
    logistic_slope_per_sd: float
    x50: float
    bins: tuple[BinStat, ...]


@dataclass(frozen=True)
class StepSummary:
    """Success statistics of one step over the samples that evaluated it.

    ``driver`` is the factor with the largest absolute correlation among those significant at
    the 5 % level (None when none is).
    """

    step: str
    n: int
    successes: int
    rate: float
    ci_low: float
    ci_high: float
    failure_reasons: tuple[tuple[str, int], ...]
    effects: tuple[FactorEffect, ...]
    driver: str | None


@dataclass(frozen=True)
class SweepSummary:
    """Per-step statistics of a sweep plus the samples that produced no verdict.

    ``errors`` counts samples whose task raised or whose worker kept dying (``TaskResult.ok``
    False) by reason; they are left out of every step's rate.
    """

    n_samples: int
    n_errors: int
    errors: tuple[tuple[str, int], ...]
    steps: tuple[StepSummary, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict (NaN becomes None)."""

        def clean(o: Any) -> Any:
            if isinstance(o, float) and not math.isfinite(o):
                return None
            if isinstance(o, dict):
                return {k: clean(v) for k, v in o.items()}
            if isinstance(o, list | tuple):
                return [clean(v) for v in o]
            return o

        return clean(asdict(self))

    def step(self, name: str) -> StepSummary:
        for s in self.steps:
            if s.step == name:
                return s
        raise KeyError(f'no step "{name}" in the sweep; steps: {", ".join(s.step for s in self.steps)}')


_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def reason_category(reason: str) -> str:
    """A failure reason with its numbers replaced by ``#``, so equal causes count together."""
    return _NUMBER.sub("#", reason).strip()


def _logistic_fit(x: np.ndarray, y: np.ndarray, ridge: float = 1e-2) -> tuple[float, float]:
    """Ridge-penalised logistic regression of y on standardised x: (intercept, slope per sd)."""
    z = (x - x.mean()) / x.std()
    X = np.column_stack([np.ones_like(z), z])
    beta = np.zeros(2)
    penalty = np.array([1e-6, ridge])
    for _ in range(200):
        p = 1.0 / (1.0 + np.exp(-np.clip(X @ beta, -50, 50)))
        grad = X.T @ (y - p) - penalty * beta
        hess = (X * (p * (1 - p))[:, None]).T @ X + np.diag(penalty)
        step = np.linalg.solve(hess, grad)
        beta = beta + step
        if float(np.max(np.abs(step))) < 1e-10:
            break
    return float(beta[0]), float(beta[1])


def factor_effect(factor: str, x: Sequence[float], success: Sequence[bool], n_bins: int = 8) -> FactorEffect:
    """Statistics of one factor against one step's outcomes (see :class:`FactorEffect`)."""
    xs = np.asarray(x, dtype=float)
    ys = np.asarray(success, dtype=float)
    n = int(xs.size)
    bins: list[BinStat] = []
    lo, hi = (float(xs.min()), float(xs.max())) if n else (math.nan, math.nan)
    if n and hi > lo:
        edges = np.linspace(lo, hi, n_bins + 1)
        which = np.clip(np.searchsorted(edges, xs, side="right") - 1, 0, n_bins - 1)
        for b in range(n_bins):
            sel = which == b
            k, m = int(ys[sel].sum()), int(sel.sum())
            ci = wilson_interval(k, m)
            bins.append(BinStat(float(edges[b]), float(edges[b + 1]), m, k,
                                k / m if m else math.nan, ci[0], ci[1]))
    r = p_value = slope = x50 = math.nan
    if n >= 3 and hi > lo and 0 < ys.sum() < n:
        from scipy.stats import pearsonr

        res = pearsonr(xs, ys)
        r, p_value = float(res.statistic), float(res.pvalue)
        b0, b1 = _logistic_fit(xs, ys)
        slope = b1
        if b1 != 0.0:
            cand = float(xs.mean() - b0 / b1 * xs.std())
            x50 = cand if lo <= cand <= hi else math.nan
    return FactorEffect(factor, n, r, p_value, slope, x50, tuple(bins))


def summarize(
    samples: Sequence[SampleParams],
    results: Sequence[TaskResult],
    vary: Sequence[str] = FACTORS,
    n_bins: int = 8,
) -> SweepSummary:
    """Per-step statistics of a sweep.

    Parameters
    ----------
    samples : sequence of SampleParams
        The samples, index order.
    results : sequence of TaskResult
        ``results[i]`` for ``samples[i]``. A successful task's value is a dict with
        ``"steps": {step_name: {"success": bool or None, "reasons": [str, ...]}}``; a step with
        ``success`` None was not evaluated in that sample and does not count.
    vary : sequence of str
        Factors to analyse (normally ``spec.vary``).
    n_bins : int
        Bins per factor.

    Returns
    -------
    SweepSummary
    """
    if len(samples) != len(results):
        raise ValueError(f"summarize: expected as many results as samples, found {len(results)} "
                         f"results for {len(samples)} samples")
    errors: Counter[str] = Counter()
    per_step: dict[str, list[tuple[SampleParams, bool, list[str]]]] = {}
    for s, r in zip(samples, results, strict=True):
        if r.index != s.index:
            raise ValueError(f"summarize: result {r.index} paired with sample {s.index}")
        if not r.ok:
            errors[reason_category(r.error or "unknown")] += 1
            continue
        steps = r.value.get("steps", {}) if isinstance(r.value, dict) else {}
        for name, out in steps.items():
            if out.get("success") is None:
                continue
            per_step.setdefault(name, []).append(
                (s, bool(out["success"]), list(out.get("reasons", []))))
    summaries = []
    for name, rows in per_step.items():
        ok = [row[1] for row in rows]
        k, m = sum(ok), len(ok)
        lo, hi = wilson_interval(k, m)
        reasons: Counter[str] = Counter()
        for _, success, rs in rows:
            if not success:
                reasons.update(reason_category(t) for t in rs or ["(no reason given)"])
        table: dict[str, list[float]] = {}
        for s, _, _ in rows:
            for key, v in s.factors(name, vary).items():
                table.setdefault(key, []).append(v)
        effects = tuple(factor_effect(key, v, ok, n_bins) for key, v in table.items()
                        if len(v) == m)
        significant = [e for e in effects if math.isfinite(e.p_value) and e.p_value < 0.05]
        driver = max(significant, key=lambda e: abs(e.correlation)).factor if significant else None
        summaries.append(StepSummary(
            step=name, n=m, successes=k, rate=k / m, ci_low=lo, ci_high=hi,
            failure_reasons=tuple(sorted(reasons.items(), key=lambda kv: (-kv[1], kv[0]))),
            effects=effects, driver=driver))
    return SweepSummary(
        n_samples=len(samples), n_errors=sum(errors.values()),
        errors=tuple(sorted(errors.items(), key=lambda kv: (-kv[1], kv[0]))),
        steps=tuple(summaries))


# ---------------------------------------------------------------------------------------------
# throughput


@dataclass(frozen=True)
class Throughput:
    """Simulations per second through one executor.

    ``startup_s`` is the time to create the executor and run one warm-up task per worker;
    ``wall_s`` is the median over ``repeats`` timed runs after that, and ``per_second`` is
    ``n_tasks / wall_s``.
    """

    label: str
    workers: int
    n_tasks: int
    startup_s: float
    wall_s: float
    per_second: float
    repeats: int = 1


def _warm_up(executor: cf.Executor, workers: int) -> None:
    list(executor.map(_noop, range(workers)))


def _noop(x: int) -> int:
    return x


def measure_throughput(
    label: str,
    task: Callable[[Any], Any],
    params_list: Sequence[Any],
    make_executor: Callable[[], tuple[cf.Executor, Callable[[], None]]],
    workers: int,
    repeats: int = 1,
) -> Throughput:
    """Time :func:`run_sweep` of ``task`` over ``params_list`` on a freshly made executor.

    ``make_executor()`` returns ``(executor, close)``; ``close`` is called at the end.
    """
    t0 = time.perf_counter()
    ex, close = make_executor()
    walls = []
    try:
        _warm_up(ex, workers)
        startup = time.perf_counter() - t0
        for _ in range(repeats):
            t1 = time.perf_counter()
            results = run_sweep(task, params_list, executor=ex, retries=0)
            walls.append(time.perf_counter() - t1)
            bad = [r for r in results if not r.ok]
            if bad:
                raise SweepError(
                    f"throughput run {label}: {len(bad)} tasks failed, first: {bad[0].error}")
    finally:
        close()
    wall = float(np.median(walls))
    return Throughput(label, workers, len(params_list), startup, wall, len(params_list) / wall,
                      repeats)


def throughput(
    task: Callable[[Any], Any],
    params_list: Sequence[Any],
    local_workers: Sequence[int] = (1, 2),
    dask_workers: int | None = 2,
    repeats: int = 1,
) -> list[Throughput]:
    """Simulations per second with local process pools and a local Dask cluster.

    Parameters
    ----------
    task, params_list
        As for :func:`run_sweep`; the same work is timed on each executor.
    local_workers : sequence of int
        Pool sizes to time with :func:`default_executor`.
    dask_workers : int or None
        Workers (one thread each, separate processes) of a ``distributed.LocalCluster`` to
        time; None skips Dask (so does a missing Dask installation).
    repeats : int
        Timed runs per executor (the median is reported).

    Returns
    -------
    list of Throughput
    """
    out = []
    for w in local_workers:
        def make(w: int = w) -> tuple[cf.Executor, Callable[[], None]]:
            ex = default_executor(w)
            return ex, lambda: ex.shutdown(wait=True)

        out.append(measure_throughput(f"local pool, {w} worker{'s' if w != 1 else ''}",
                                      task, params_list, make, w, repeats))
    if dask_workers:
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError:
            return out

        def make_dask() -> tuple[cf.Executor, Callable[[], None]]:
            cluster = LocalCluster(n_workers=dask_workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, host="127.0.0.1")
            client = Client(cluster, set_as_default=False)

            def close() -> None:
                client.close()
                cluster.close()

            return client.get_executor(pure=False), close

        out.append(measure_throughput(f"Dask LocalCluster, {dask_workers} workers",
                                      task, params_list, make_dask, dask_workers, repeats))
    return out


def calibration_task(index: int, n_rounds: int = 100) -> dict[str, float]:
    """Fixed, deterministic CPU work standing in for one simulation (~0.2 s on a 2-core box).

    Single-threaded element-wise numpy (no BLAS, so no hidden threads) working in place: no
    large allocations, whose cost differs between executors (Dask's nanny sets
    ``MALLOC_TRIM_THRESHOLD_``, which makes every 800 kB temporary an mmap/munmap pair and the
    same work ~1.7x slower). What it measures is the executors' overhead and scaling, not a
    physics figure.
    """
    x = np.linspace(0.0, 1.0, 100_000) + 1e-6 * index
    y = np.empty_like(x)
    for _ in range(n_rounds):  # x <- sin(3.1 x) + 0.5 x
        np.multiply(x, 3.1, out=y)
        np.sin(y, out=y)
        x *= 0.5
        x += y
    return {"checksum": float(x.sum())}


def format_throughput(rows: Sequence[Throughput]) -> str:
    """A Markdown table of :func:`throughput` rows."""
    lines = ["| executor | workers | tasks | start-up (s) | median wall (s) | repeats | tasks/s |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    lines += [f"| {r.label} | {r.workers} | {r.n_tasks} | {r.startup_s:.2f} | {r.wall_s:.2f} | "
              f"{r.repeats} | {r.per_second:.2f} |" for r in rows]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m asmplan.sim.sweep``: time :func:`calibration_task` on each executor."""
    import argparse
    import functools
    import sys

    parser = argparse.ArgumentParser(prog="python -m asmplan.sim.sweep",
                                     description="Sweep throughput with local pools and Dask.")
    parser.add_argument("--tasks", type=int, default=100, help="tasks per executor")
    parser.add_argument("--rounds", type=int, default=100, help="work per task (calibration)")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--dask-workers", type=int, default=2, help="0 skips Dask")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per executor")
    args = parser.parse_args(argv)
    task = functools.partial(calibration_task, n_rounds=args.rounds)
    rows = throughput(task, list(range(args.tasks)), args.workers, args.dask_workers or None,
                      args.repeats)
    sys.stdout.write(format_throughput(rows))
    return 0


def iter_journal_results(path: str | os.PathLike[str]) -> Iterator[TaskResult]:
    """Read the sample records of a journal without opening it for writing (for reports)."""
    with open(path, "rb") as fh:
        lines = fh.read().split(b"\n")
    for raw in lines[1:-1]:
        if raw.strip():
            yield TaskResult.from_dict(json.loads(raw))


if __name__ == "__main__":
    raise SystemExit(main())
