"""Scenes shared by the simulator tests (plain functions, imported by the test modules).

Everything physical is stated here once: part sizes, masses, friction coefficients, gripper
geometry and the trajectories, so each test asserts against an analytic expectation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from asmplan.bench import BoxPart, box_inertia, box_piece, constant_acceleration_lift
from asmplan.parts.decompose import HoleSpec, block_with_holes_pieces
from asmplan.parts.pieces import ConvexPiece
from asmplan.planner.trajectory import (
    Segment,
    Trajectory,
    read_phase_table,
    seed_cycle,
    trajectory_from_segments,
)
from asmplan.sim.bullet import BulletWorld
from asmplan.sim.execute import execute_step
from asmplan.sim.fidelity import Fidelity
from asmplan.sim.gripper import Gripper, GripperSpec
from asmplan.sim.records import StepOutcome, StepRecord, SuccessCriteria

SEED_CSV = (Path(__file__).parents[2] / "../shared/reference/clamp_cycle_seed.csv").resolve()
G = 9.81
R_DOWN = np.diag([-1.0, 1.0, -1.0])
"""TCP pointing down (z_tool = -z_world), fingers closing along world y."""


def pose(position: tuple[float, float, float], R: np.ndarray = R_DOWN) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = position
    return T


def cylinder_inertia(mass_kg: float, radius_m: float, length_m: float) -> np.ndarray:
    ixx = mass_kg * (3 * radius_m**2 + length_m**2) / 12.0
    return np.diag([ixx, ixx, mass_kg * radius_m**2 / 2.0])


# --------------------------------------------------------------------------------------------
# Seed clamp cycle: an 80 g box gripped across its 30 mm width
# --------------------------------------------------------------------------------------------
def add_box_and_gripper(
    world: BulletWorld, part: BoxPart, gripper_spec: GripperSpec | None = None, clearance_m: float = 0.002
) -> tuple[int, Gripper, np.ndarray]:
    """Ground, the box standing on it at the origin, and the gripper open around it."""
    world.add_ground(friction=0.5)
    T_part = np.eye(4)
    T_part[2, 3] = part.size_m[2] / 2.0
    body = world.add_body(
        (box_piece(part.size_m),),
        part.mass_kg,
        T_part,
        inertia_kgm2=box_inertia(part.mass_kg, part.size_m),
        friction=part.friction,
        name="box",
    )
    T_tcp = pose((0.0, 0.0, part.size_m[2] / 2.0))
    spec = gripper_spec or GripperSpec()
    gripper = Gripper(world, spec, T_tcp, opening_m=part.size_m[1] + 2 * clearance_m)
    return body, gripper, T_tcp


def run_seed_cycle(
    fidelity: Fidelity, part: BoxPart | None = None, translation_m: tuple[float, float, float] = (0.1, 0.0, 0.0)
) -> tuple[StepRecord, StepOutcome, Trajectory]:
    part = part or BoxPart()
    with BulletWorld(fidelity) as world:
        body, gripper, T_tcp = add_box_and_gripper(world, part)
        traj = seed_cycle(read_phase_table(SEED_CSV), T_tcp, lift_m=0.05, translation_m=translation_m)
        target = world.pose(body)
        target[:3, 3] += translation_m
        record, outcome = execute_step(world, gripper, body, traj, T_world_part_target=target)
    return record, outcome, traj


# --------------------------------------------------------------------------------------------
# Slip threshold: lift with constant upward acceleration
# --------------------------------------------------------------------------------------------
def lift_slip_m(fidelity: Fidelity, part: BoxPart, force_N: float, accel_mps2: float) -> float:
    """Largest slip of the part in the fingers while lifted with acceleration ``accel``."""
    with BulletWorld(fidelity) as world:
        body, gripper, T_tcp = add_box_and_gripper(world, part)
        traj = constant_acceleration_lift(T_tcp, force_N, accel_mps2)
        _, outcome = execute_step(world, gripper, body, traj)
    return outcome.max_slip_m


# --------------------------------------------------------------------------------------------
# Pin into a blind hole of a fixtured block
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PinHole:
    hole_radius_m: float = 0.005
    hole_depth_m: float = 0.020
    n_sides: int = 8
    block_size_m: tuple[float, float, float] = (0.04, 0.04, 0.03)
    block_xy_m: tuple[float, float] = (0.10, 0.0)
    pin_length_m: float = 0.040
    pin_density_kg_m3: float = 7800.0
    pin_friction: float = 0.5
    block_friction: float = 0.5
    clamp_force_N: float = 5.0
    grasp_above_centre_m: float = 0.012
    seat_gap_m: float = 0.2e-3  # the gripper stops this far above the hole floor


def pin_insertion(
    fidelity: Fidelity,
    radial_clearance_m: float,
    lateral_offset_m: float = 0.0,
    scene: PinHole | None = None,
    criteria: SuccessCriteria | None = None,
) -> tuple[StepRecord, StepOutcome]:
    """Pick a standing pin, carry it over the hole and insert it along -z.

    ``radial_clearance_m`` < 0 makes an interference fit; ``lateral_offset_m`` shifts the
    place pose along x (no chamfer anywhere).
    """
    s = scene or PinHole()
    r_pin = s.hole_radius_m - radial_clearance_m
    with BulletWorld(fidelity) as world:
        world.add_ground(friction=0.5)
        block_pieces = block_with_holes_pieces(
            s.block_size_m, (HoleSpec((0.0, 0.0), s.hole_radius_m, s.hole_depth_m, s.n_sides),)
        )
        T_block = np.eye(4)
        T_block[:3, 3] = [s.block_xy_m[0], s.block_xy_m[1], s.block_size_m[2] / 2.0]
        world.add_body(block_pieces, 0.0, T_block, friction=s.block_friction, name="block")
        pin_piece = ConvexPiece(kind="cylinder", T_part_piece=np.eye(4), radius_m=r_pin, length_m=s.pin_length_m)
        mass = s.pin_density_kg_m3 * math.pi * r_pin**2 * s.pin_length_m
        T_pin = np.eye(4)
        T_pin[2, 3] = s.pin_length_m / 2.0
        pin = world.add_body(
            (pin_piece,),
            mass,
            T_pin,
            inertia_kgm2=cylinder_inertia(mass, r_pin, s.pin_length_m),
            friction=s.pin_friction,
            name="pin",
        )
        T_grasp = pose((0.0, 0.0, T_pin[2, 3] + s.grasp_above_centre_m))
        gripper = Gripper(world, GripperSpec(), T_grasp, opening_m=2 * r_pin + 0.004)
        floor_z = s.block_size_m[2] - s.hole_depth_m
        seated_centre_z = floor_z + s.pin_length_m / 2.0
        lift_z = s.block_size_m[2] + 0.015 + s.pin_length_m / 2.0 + s.grasp_above_centre_m
        x, y = s.block_xy_m
        above = pose((x + lateral_offset_m, y, lift_z))
        seat = pose((x + lateral_offset_m, y, seated_centre_z + s.seat_gap_m + s.grasp_above_centre_m))
        up = T_grasp.copy()
        up[2, 3] = lift_z
        retreat = seat.copy()
        retreat[2, 3] += 0.03
        F = s.clamp_force_N
        traj = trajectory_from_segments(
            T_grasp,
            (
                Segment("clamp", 0.1, T_grasp, 0.0, F),
                Segment("hold", 0.2, T_grasp, F, F),
                Segment("lift", 0.4, up, F, F),
                Segment("translate", 0.6, above, F, F),
                Segment("lower", 1.0, seat, F, F),
                Segment("release", 0.2, seat, F, 0.0),
                Segment("retreat", 0.3, retreat, 0.0, 0.0),
            ),
        )
        target = np.eye(4)
        target[:3, 3] = [x, y, seated_centre_z]
        return execute_step(
            world,
            gripper,
            pin,
            traj,
            criteria=criteria,
            T_world_part_target=target,
            mate_axis_world=(0.0, 0.0, -1.0),
        )


def entered_depth_m(record: StepRecord, scene: PinHole | None = None) -> float:
    """How deep the pin was in the hole when the gripper stopped pushing (end of "lower"), m."""
    s = scene or PinHole()
    last = np.flatnonzero(record.phase_mask("lower"))[-1]
    return s.hole_depth_m - float(record.axial_error_m[last])


def print_clearance_sweep(
    name: str, radial_m: tuple[float, ...] = (0.2e-3, 0.1e-3, 0.05e-3, 0.025e-3, 0.01e-3)
) -> None:
    """The measurement behind ``Fidelity.min_resolvable_clearance_m`` (prints one row per value).

    Run: ``cd tests/sim && /tmp/venv/bin/python -c "import sim_scenes as s;
    s.print_clearance_sweep('balanced')"``
    """
    from asmplan.sim.fidelity import preset

    fid = preset(name)
    for c in radial_m:
        _, fit = pin_insertion(fid, c)
        rec, _ = pin_insertion(fid, -c)
        print(
            f"{name}: radial {c * 1e3:.3f} mm: fit inserted={fit.success}; interference "
            f"entered {entered_depth_m(rec) * 1e3:.2f} mm of {PinHole().hole_depth_m * 1e3:.0f}"
        )
