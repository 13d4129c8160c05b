"""The Plan: sequence, grasps, trajectories and commanded forces, as a JSON document.

A :class:`Plan` is what the simulator executes and the report shows. It is written with
:meth:`Plan.write` (deterministic JSON, sorted keys, written atomically: temp file in the same
folder, fsync, ``os.replace``) and read back with :meth:`Plan.read`; the same product, settings
and seed give byte-identical files. The format is documented in ``docs/plan-format.md``.

Wall-clock planning times are kept out of the file (they would break byte identity); they
are returned next to the plan by :func:`asmplan.planner.product.plan_product`.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..fileio import atomic_write_text, dumps_json
from ..knowledge.arrays import readonly_array
from .grasp_hold import HoldInputs
from .press import PressOperation
from .settings import PlannerSettings
from .timing import ClampForce
from .trajectory import Trajectory

PLAN_FORMAT = "asmplan-plan"
PLAN_VERSION = 1

StepKind = Literal["fixture", "operation", "insert", "place", "regrasp"]
# steps the robot does not plan: no grasp, no trajectory
NOT_ROBOT_KINDS = ("fixture", "operation")


def _pose(value: Any, name: str) -> np.ndarray:
    T = readonly_array(value, (4, 4), name, finite=True)
    R = T[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or abs(np.linalg.det(R) - 1.0) > 1e-6:
        raise ValueError(f"{name}: expected a rigid transform, found a non-rotation block")
    return T


@dataclass(frozen=True, eq=False)
class ArmMotion:
    """The arm's part of a step: joint angles at every trajectory sample and its margins.

    Parameters
    ----------
    joint_names : tuple of str
    q_rad : (N, 6) float array
        Joint angles at the step trajectory's samples (its ``t_s``), rad.
    branch : str
        IK branch (shoulder/elbow/wrist) the step runs on.
    min_manipulability_ratio : float
        Smallest manipulability along the step as a fraction of the arm's best.
    min_limit_margin_rad : float
        Smallest distance of a joint to its limits along the step, rad; ``limit_margin_joint``
        names the joint.
    max_ik_error_m : float
        Largest distance between FK(q) and the planned TCP position, m.
    phase_time_scale : tuple of (phase, factor)
        How much each phase of the Cartesian timing was slowed for the joint limits (1 = not).
    transfer_s : float
        The joint move from the previous step's last state to this step's first, s
        (rest-to-rest per leg of ``transfer_q_rad``).
    transfer_q_rad : (M, 6) float array
        Waypoints of that move (the straight joint move when free, else OMPL's joint-space
        path; certified free of collisions, gripper open); empty for the first step.
    checked_states : int
        Arm states checked for collision.
    branches_found : int
        IK branches of the step's first pose within the limits.
    joint_space_translate : bool
        True when the arm could not follow the planned Cartesian transfer (lifted to
        pre-insertion pose) and OMPL planned it in joint space; the trajectory's translate
        phase is then FK of that joint path.
    tool_turned : bool
        True when the arm holds the grasp with the gripper turned half a turn about its
        approach axis (the two fingers swapped; the step's grasp and trajectory are given
        turned), which the arm reached nearer its last state.
    """

    joint_names: tuple[str, ...]
    q_rad: np.ndarray
    branch: str
    min_manipulability_ratio: float
    min_limit_margin_rad: float
    limit_margin_joint: str
    max_ik_error_m: float
    phase_time_scale: tuple[tuple[str, float], ...]
    transfer_s: float
    checked_states: int
    branches_found: int
    joint_space_translate: bool = False
    transfer_q_rad: np.ndarray | None = None
    tool_turned: bool = False

    def __post_init__(self) -> None:
        q = np.array(self.q_rad, dtype=float)
        if q.ndim != 2 or q.shape[1] != len(self.joint_names):
            raise ValueError(f"arm q_rad: expected (N, {len(self.joint_names)}), found {q.shape}")
        q.setflags(write=False)
        object.__setattr__(self, "q_rad", q)
        w = np.zeros((0, q.shape[1])) if self.transfer_q_rad is None else np.array(
            self.transfer_q_rad, dtype=float).reshape(-1, q.shape[1])
        w.setflags(write=False)
        object.__setattr__(self, "transfer_q_rad", w)

    def to_dict(self) -> dict[str, Any]:
        return {"joint_names": list(self.joint_names), "q_rad": self.q_rad.round(9).tolist(),
                "branch": self.branch,
                "min_manipulability_ratio": float(self.min_manipulability_ratio),
                "min_limit_margin_rad": float(self.min_limit_margin_rad),
                "limit_margin_joint": self.limit_margin_joint,
                "max_ik_error_m": float(self.max_ik_error_m),
                "phase_time_scale": {n: float(k) for n, k in self.phase_time_scale},
                "transfer_s": float(self.transfer_s), "checked_states": int(self.checked_states),
                "branches_found": int(self.branches_found),
                "joint_space_translate": bool(self.joint_space_translate),
                "tool_turned": bool(self.tool_turned),
                "transfer_q_rad": np.asarray(self.transfer_q_rad).round(9).tolist()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ArmMotion:
        return cls(joint_names=tuple(d["joint_names"]), q_rad=np.array(d["q_rad"], float),
                   branch=d["branch"], min_manipulability_ratio=float(d["min_manipulability_ratio"]),
                   min_limit_margin_rad=float(d["min_limit_margin_rad"]),
                   limit_margin_joint=d["limit_margin_joint"],
                   max_ik_error_m=float(d["max_ik_error_m"]),
                   phase_time_scale=tuple((n, float(k)) for n, k in d["phase_time_scale"].items()),
                   transfer_s=float(d["transfer_s"]), checked_states=int(d["checked_states"]),
                   branches_found=int(d["branches_found"]),
                   joint_space_translate=bool(d.get("joint_space_translate", False)),
                   transfer_q_rad=np.array(d.get("transfer_q_rad", []), dtype=float),
                   tool_turned=bool(d.get("tool_turned", False)))


@dataclass(frozen=True, eq=False)
class Grasp:
    """A two-finger grasp of a part.

    Parameters
    ----------
    part : str
    T_part_gripper : (4, 4) float array
        The gripper TCP frame in the part frame (z approach, y closing axis; see
        :mod:`asmplan.planner.trajectory`).
    width_m : float
        Distance between the pads when closed on the part, m.
    open_width_m : float
        Opening used to approach and to release, m (<= the gripper's stroke).
    contact_area_m2 : float
        Estimated contact area of the smaller pad, m^2.
    com_offset_m : float
        Distance from the part's centre of mass to the TCP, m.
    source : {"hint", "antipodal"}
        "hint" when built from the part's handling knowledge.
    cost : float
        Ranking cost (lower is better); see :mod:`asmplan.planner.grasp`.
    torsion_radius_m : float, optional
        Mean torsion radius of the two pads' contact patches, m: under uniform pressure a
        pad resists ``mu F`` times this about its patch (:mod:`asmplan.planner.grasp_hold`).
    lever_m : float, optional
        Distance of the centre of mass from the contact centre in the pad plane, m.
    hold_required_N : float, optional
        Clamp force per finger that holds the part's weight and inertia with this grasp
        (safety factor included), N.
    hold : HoldInputs, optional
        The contact patches and load the hold was judged on, to judge it again along the
        planned transfer (in memory only: not written to the plan file).
    """

    part: str
    T_part_gripper: np.ndarray
    width_m: float
    open_width_m: float
    contact_area_m2: float
    com_offset_m: float
    source: Literal["hint", "antipodal"]
    cost: float
    torsion_radius_m: float | None = None
    lever_m: float | None = None
    hold_required_N: float | None = None
    hold: HoldInputs | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "T_part_gripper", _pose(self.T_part_gripper, "T_part_gripper"))
        if not (self.width_m > 0 and self.open_width_m >= self.width_m):
            raise ValueError(f"grasp of {self.part}: expected 0 < width_m <= open_width_m, found "
                             f"{self.width_m}, {self.open_width_m}")
        if self.source not in ("hint", "antipodal"):
            raise ValueError(f"grasp source: expected hint or antipodal, found {self.source!r}")

    @property
    def closing_axis_part(self) -> np.ndarray:
        """Closing axis (3,) in the part frame."""
        return self.T_part_gripper[:3, 1].copy()

    @property
    def approach_axis_part(self) -> np.ndarray:
        """Approach axis (3,) in the part frame."""
        return self.T_part_gripper[:3, 2].copy()

    def to_dict(self) -> dict[str, Any]:
        return {"part": self.part, "T_part_gripper": self.T_part_gripper.tolist(),
                "width_m": float(self.width_m), "open_width_m": float(self.open_width_m),
                "contact_area_m2": float(self.contact_area_m2),
                "com_offset_m": float(self.com_offset_m), "source": self.source,
                "cost": float(self.cost),
                **{k: float(v) for k, v in (("torsion_radius_m", self.torsion_radius_m),
                                            ("lever_m", self.lever_m),
                                            ("hold_required_N", self.hold_required_N))
                   if v is not None}}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Grasp:
        return cls(part=d["part"], T_part_gripper=np.array(d["T_part_gripper"]),
                   width_m=float(d["width_m"]), open_width_m=float(d["open_width_m"]),
                   contact_area_m2=float(d["contact_area_m2"]),
                   com_offset_m=float(d["com_offset_m"]), source=d["source"],
                   cost=float(d["cost"]),
                   torsion_radius_m=_optional_float(d, "torsion_radius_m"),
                   lever_m=_optional_float(d, "lever_m"),
                   hold_required_N=_optional_float(d, "hold_required_N"))


def _optional_float(d: dict[str, Any], key: str) -> float | None:
    v = d.get(key)
    return None if v is None else float(v)


@dataclass(frozen=True, eq=False)
class Step:
    """One step of the plan.

    ``kind``: "fixture" (the part is in place from the start, held by a fixture; no
    trajectory), "operation" (placed at its assembled pose at this point of the sequence by
    another operation, ``operation``: press_tool, manual or fastening, ``operation_note``
    what it does; no grasp, no trajectory, not planned for the robot), "insert" (pick,
    carry and insert along the mate axis), "place" (no mate
    with the parts already placed: lowered onto its pose along ``insertion_direction``) or
    "regrasp" (no grasp holds the part both where it lies and where it goes: it is put down
    on a free area of the table in another orientation, ``T_world_final``, and picked again
    with another grasp by the part's next step, whose ``T_world_start`` is that pose).
    Poses are of the part, world frame; ``path_T_world_gripper`` is the planned (simplified,
    re-checked) path of the gripper TCP from the lifted pose to the pre-insertion pose.
    ``check_step_m`` is the finest step of the path certification; ``insertion_check_step_m``
    the sampling step used along the insertion to excuse pin-in-hole contact (0 when the exact
    swept-volume check met nothing); ``checked_poses`` how many poses were certified.
    ``press`` is set when the step presses an interference or transition fit home (who pushes,
    the force range, :mod:`asmplan.planner.press`).
    """

    index: int
    part: str
    kind: StepKind
    mates: tuple[str, ...]
    T_world_start: np.ndarray
    T_world_final: np.ndarray
    start_note: str = ""
    T_world_pre_insertion: np.ndarray | None = None
    insertion_direction: np.ndarray | None = None
    insertion_length_m: float = 0.0
    grasp: Grasp | None = None
    clamp: ClampForce | None = None
    trajectory: Trajectory | None = None
    path_T_world_gripper: np.ndarray | None = None
    check_step_m: float = 0.0
    insertion_check_step_m: float = 0.0
    checked_poses: int = 0
    notes: tuple[str, ...] = ()
    arm: ArmMotion | None = None
    press: PressOperation | None = None
    operation: str | None = None
    operation_note: str = ""

    def __post_init__(self) -> None:
        if self.kind not in ("fixture", "operation", "insert", "place", "regrasp"):
            raise ValueError(f"step {self.index + 1}: kind expected fixture, operation, insert, "
                             f"place or regrasp, found {self.kind!r}")
        if (self.kind == "operation") != (self.operation is not None):
            raise ValueError(f"step {self.index + 1} ({self.part}): an operation step names its "
                             f"operation and only it does: kind {self.kind!r}, operation "
                             f"{self.operation!r}")
        object.__setattr__(self, "T_world_start", _pose(self.T_world_start, "T_world_start"))
        object.__setattr__(self, "T_world_final", _pose(self.T_world_final, "T_world_final"))
        if self.T_world_pre_insertion is not None:
            object.__setattr__(self, "T_world_pre_insertion",
                               _pose(self.T_world_pre_insertion, "T_world_pre_insertion"))
        if self.insertion_direction is not None:
            object.__setattr__(self, "insertion_direction",
                               readonly_array(self.insertion_direction, (3,), "insertion_direction",
                                              finite=True))
        if self.path_T_world_gripper is not None:
            p = np.array(self.path_T_world_gripper, dtype=float)
            if p.ndim != 3 or p.shape[1:] != (4, 4):
                raise ValueError(f"path_T_world_gripper: expected (N, 4, 4), found {p.shape}")
            p.setflags(write=False)
            object.__setattr__(self, "path_T_world_gripper", p)
        if self.kind not in NOT_ROBOT_KINDS and (self.grasp is None or self.trajectory is None):
            raise ValueError(f"step {self.index + 1} ({self.part}): a {self.kind} step needs a "
                             "grasp and a trajectory, found none")
        if self.arm is not None and (self.trajectory is None
                                     or len(self.arm.q_rad) != len(self.trajectory.t_s)):
            raise ValueError(f"step {self.index} ({self.part}): expected the arm's joint angles "
                             "at every trajectory sample")

    @property
    def cycle_time_s(self) -> float:
        """The step's time on the cell: the arm's transfer from the previous step plus the
        trajectory (0 for fixture steps), s."""
        if self.trajectory is None:
            return 0.0
        return self.trajectory.duration_s + (0.0 if self.arm is None else self.arm.transfer_s)

    @property
    def commanded_force_N(self) -> float:
        """Commanded per-finger clamp force, N (0 for fixture steps)."""
        return 0.0 if self.clamp is None else self.clamp.commanded_N

    def to_dict(self) -> dict[str, Any]:
        def opt(a: np.ndarray | None) -> Any:
            return None if a is None else a.tolist()

        return {
            "index": self.index, "part": self.part, "kind": self.kind, "mates": list(self.mates),
            "T_world_start": self.T_world_start.tolist(), "start_note": self.start_note,
            "T_world_final": self.T_world_final.tolist(),
            "T_world_pre_insertion": opt(self.T_world_pre_insertion),
            "insertion_direction": opt(self.insertion_direction),
            "insertion_length_m": float(self.insertion_length_m),
            "grasp": None if self.grasp is None else self.grasp.to_dict(),
            "clamp": None if self.clamp is None else self.clamp.as_dict(),
            "commanded_force_N": self.commanded_force_N,
            "trajectory": None if self.trajectory is None else self.trajectory.to_dict(),
            "path_T_world_gripper": opt(self.path_T_world_gripper),
            "check_step_m": float(self.check_step_m),
            "insertion_check_step_m": float(self.insertion_check_step_m),
            "checked_poses": int(self.checked_poses),
            "notes": list(self.notes),
            "arm": None if self.arm is None else self.arm.to_dict(),
            "cycle_time_s": float(self.cycle_time_s),
            "press": None if self.press is None else self.press.to_dict(),
            # only on operation steps (plans without them keep their bytes)
            **({} if self.operation is None else {"operation": {
                "name": self.operation, "note": self.operation_note,
                "planned_for_robot": False, "simulated": False}}),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Step:
        def opt(a: Any) -> np.ndarray | None:
            return None if a is None else np.array(a, dtype=float)

        clamp = d.get("clamp")
        return cls(
            index=int(d["index"]), part=d["part"], kind=d["kind"], mates=tuple(d["mates"]),
            T_world_start=np.array(d["T_world_start"]), T_world_final=np.array(d["T_world_final"]),
            start_note=d.get("start_note", ""),
            T_world_pre_insertion=opt(d.get("T_world_pre_insertion")),
            insertion_direction=opt(d.get("insertion_direction")),
            insertion_length_m=float(d.get("insertion_length_m", 0.0)),
            grasp=None if d.get("grasp") is None else Grasp.from_dict(d["grasp"]),
            clamp=None if clamp is None else ClampForce(**clamp),
            trajectory=None if d.get("trajectory") is None
            else Trajectory.from_dict(d["trajectory"]),
            path_T_world_gripper=opt(d.get("path_T_world_gripper")),
            check_step_m=float(d.get("check_step_m", 0.0)),
            insertion_check_step_m=float(d.get("insertion_check_step_m", 0.0)),
            checked_poses=int(d.get("checked_poses", 0)), notes=tuple(d.get("notes", ())),
            arm=None if d.get("arm") is None else ArmMotion.from_dict(d["arm"]),
            press=None if d.get("press") is None else PressOperation.from_dict(d["press"]),
            operation=None if d.get("operation") is None else d["operation"]["name"],
            operation_note="" if d.get("operation") is None else d["operation"]["note"],
        )


@dataclass(frozen=True, eq=False)
class Plan:
    """A complete assembly plan.

    Parameters
    ----------
    product : str
        Product name.
    source : str
        The product file as given.
    source_sha256 : str
        SHA-256 of the product file's bytes ("" when unknown).
    sequence : tuple of str
        Part order, the first being the base (fixtured or placed first).
    sequence_note : str
        Where the sequence came from (e.g. the sequence planner's rank and score).
    steps : tuple of Step
        One per part, in sequence order, each preceded by the part's regrasp steps (kind
        "regrasp") if it has any.
    settings : PlannerSettings
    """

    product: str
    source: str
    source_sha256: str
    sequence: tuple[str, ...]
    steps: tuple[Step, ...]
    settings: PlannerSettings
    sequence_note: str = ""

    def __post_init__(self) -> None:
        parts = tuple(s.part for s in self.steps if s.kind != "regrasp")
        if parts != tuple(self.sequence):
            raise ValueError(f"plan: expected steps in sequence order {list(self.sequence)}, "
                             f"found {list(parts)}")
        for k, s in enumerate(self.steps):
            if s.index != k:
                raise ValueError(f"plan: expected step index {k}, found {s.index}")

    def step(self, part: str) -> Step:
        for s in self.steps:  # the step that assembles it, not its regrasps
            if s.part == part and s.kind != "regrasp":
                return s
        raise KeyError(f'plan has no step for part "{part}"; parts: {", ".join(self.sequence)}')

    @property
    def cycle_time_s(self) -> float:
        """The product's cycle time on the cell: every step's transfer and trajectory, s."""
        return float(sum(s.cycle_time_s for s in self.steps))

    def to_dict(self) -> dict[str, Any]:
        return {"format": PLAN_FORMAT, "version": PLAN_VERSION, "product": self.product,
                "cycle_time_s": self.cycle_time_s,
                "source": self.source, "source_sha256": self.source_sha256,
                "sequence": list(self.sequence), "sequence_note": self.sequence_note,
                "settings": self.settings.as_dict(),
                "steps": [s.to_dict() for s in self.steps]}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Plan:
        if d.get("format") != PLAN_FORMAT:
            raise ValueError(f"plan file: expected format {PLAN_FORMAT!r}, found {d.get('format')!r}")
        if d.get("version") != PLAN_VERSION:
            raise ValueError(f"plan file: expected version {PLAN_VERSION}, found {d.get('version')!r}")
        return cls(product=d["product"], source=d["source"], source_sha256=d["source_sha256"],
                   sequence=tuple(d["sequence"]), sequence_note=d.get("sequence_note", ""),
                   settings=PlannerSettings.from_dict(d["settings"]),
                   steps=tuple(Step.from_dict(s) for s in d["steps"]))

    def to_json(self) -> str:
        """Deterministic JSON text (sorted keys, 2-space indent, trailing newline)."""
        return dumps_json(self.to_dict())

    @classmethod
    def from_json(cls, text: str) -> Plan:
        return cls.from_dict(json.loads(text))

    def write(self, path: str | Path) -> Path:
        """Write the plan atomically (temp file in the same folder, fsync, os.replace)."""
        return atomic_write_text(path, self.to_json())

    @classmethod
    def read(cls, path: str | Path) -> Plan:
        return cls.from_json(Path(path).read_text(encoding="utf-8"))


@dataclass(frozen=True, eq=False)
class AssemblyState:
    """Where things are while one step runs, kept apart from the static product.

    ``T_world_part``: the pose (4, 4) of every part, world frame, m; ``placed``: the parts in
    place (fixtured or assembled by an earlier step).
    """

    T_world_part: Mapping[str, np.ndarray]
    placed: frozenset[str]


def assembly_state(plan: Plan, index: int) -> AssemblyState:
    """The :class:`AssemblyState` while step ``index`` of ``plan`` runs.

    Parts in place: fixtured ones (kind "fixture", in place from the start) and those
    assembled by the earlier steps, at their final (assembled) poses; a part put down by an
    earlier regrasp step where that step left it; the others at their start poses.
    """
    starts: dict[str, np.ndarray] = {}
    for s in plan.steps:
        starts.setdefault(s.part, s.T_world_start)
    return state_before(plan.steps[: index + 1], starts,
                        {s.part for s in plan.steps if s.kind == "fixture"})


def state_before(steps: Sequence[Step], start_poses: Mapping[str, np.ndarray],
                 fixtured: Iterable[str]) -> AssemblyState:
    """Where every part is while the last of ``steps`` runs (the steps so far, in order).

    Parameters
    ----------
    steps : sequence of Step
        The plan's steps up to and including the running one.
    start_poses : mapping of str to (4, 4) float array
        Where every part lies before its first step, world frame, m.
    fixtured : iterable of str
        Parts in place from the start (their poses are taken from their steps or
        ``start_poses``, which hold their assembled poses).
    """
    current = steps[-1]
    poses = dict(start_poses)
    placed = set(fixtured)
    for s in steps[:-1]:
        poses[s.part] = s.T_world_final
        if s.kind != "regrasp":
            placed.add(s.part)
    placed.discard(current.part)
    poses[current.part] = current.T_world_start
    return AssemblyState(poses, frozenset(placed))
