"""The physics validation scenes, each with an analytic or converged answer.

One definition serves the simulator's tests (``tests/sim``) and ``asmplan bench``, so that
the benchmark measures exactly the scenes the tests check:

* the seed paper's 4 s clamp-lift-translate-lower-release cycle on an 80 g box
  (:func:`run_seed_cycle`; commanded clamp force from :data:`SEED_PHASE_TABLE_CSV`);
* a box lifted at constant acceleration (:func:`lift_slip_m`; the holding force it needs is
  ``m (g + a) / (2 mu)``);
* a standing steel pin picked, carried and pushed straight into a blind hole of a fixtured
  block, no chamfer (:func:`pin_insertion`, :class:`PinHole`).

Every physical quantity is stated once here: sizes, masses, friction coefficients, gripper
geometry and the trajectories. The world convention: ground at z = 0, TCP pointing down
(:data:`R_DOWN`), fingers closing along world y.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from asmplan.parts.decompose import HoleSpec, block_with_holes_pieces
from asmplan.parts.pieces import ConvexPiece
from asmplan.planner.trajectory import (
    PhaseSpan,
    Segment,
    Trajectory,
    parse_phase_table,
    seed_cycle,
    trajectory_from_segments,
)
from asmplan.sim.bullet import BulletWorld
from asmplan.sim.execute import execute_step
from asmplan.sim.feature_contact import FitPair, HeldFitContact
from asmplan.sim.fidelity import Fidelity
from asmplan.sim.fit_geometry import BoreFeature, FitContactModel, PinFeature
from asmplan.sim.gripper import CoupledGripper, Gripper, GripperSpec
from asmplan.sim.guard import SceneWatch
from asmplan.sim.pose_error import PoseError, apply_pose_error
from asmplan.sim.records import StepOutcome, StepRecord, SuccessCriteria
from asmplan.sim.simulate import step_gripper
from asmplan.sim.verdicts import Failure, SceneGuard

G = 9.81
"""Gravity in the scenes, m/s^2 (PyBullet's world is set up with the same value)."""

R_DOWN = np.diag([-1.0, 1.0, -1.0])
"""TCP pointing down (z_tool = -z_world), fingers closing along world y."""

# The seed paper's clamp-force table (section 3, "Table 4 Clamping force data"), as in
# shared/reference/clamp_cycle_seed.csv; embedded so that the benchmark runs anywhere
# (tests/sim/test_scenarios.py checks that the two agree).
SEED_PHASE_TABLE_CSV = """\
phase,t_start_s,t_end_s,force_start_N,force_end_N,force_min_N,force_max_N
clamp,0.0,0.1,0.0,2.0,0.0,2.0
hold,0.1,0.5,1.57,1.57,1.57,1.57
lift,0.5,1.5,1.57,1.70,1.57,1.70
translate,1.5,3.0,1.55,1.60,1.55,1.60
lower,3.0,3.5,1.60,1.65,1.60,1.65
release,3.5,4.0,1.65,0.0,0.0,1.65
"""


def pose(position: tuple[float, float, float], R: np.ndarray = R_DOWN) -> np.ndarray:
    """(4, 4) pose with rotation ``R`` (TCP down by default) at ``position`` (m)."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = position
    return T


def box_piece(size_m: tuple[float, float, float]) -> ConvexPiece:
    """A centred box piece of full size ``size_m`` (m)."""
    return ConvexPiece(kind="box", T_part_piece=np.eye(4), half_extents_m=np.asarray(size_m) / 2)


def box_inertia(mass_kg: float, size_m: tuple[float, float, float]) -> np.ndarray:
    """Inertia (3, 3) of a solid box about its centre, kg m^2."""
    a, b, c = size_m
    return np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) * mass_kg / 12.0


def cylinder_inertia(mass_kg: float, radius_m: float, length_m: float) -> np.ndarray:
    """Inertia (3, 3) of a solid cylinder (axis z) about its centre, kg m^2."""
    ixx = mass_kg * (3 * radius_m**2 + length_m**2) / 12.0
    return np.diag([ixx, ixx, mass_kg * radius_m**2 / 2.0])


@dataclass(frozen=True)
class BoxPart:
    """A box gripped across its y width: size (m), mass (kg), friction (times the pads' 1.0)."""

    size_m: tuple[float, float, float] = (0.04, 0.03, 0.05)
    mass_kg: float = 0.08
    friction: float = 0.6


# --------------------------------------------------------------------------------------------
# A box standing on the ground, the gripper open around it
# --------------------------------------------------------------------------------------------
def add_box_and_gripper(world: BulletWorld, part: BoxPart, gripper_spec: GripperSpec | None = None,
                        clearance_m: float = 0.002) -> tuple[int, Gripper, np.ndarray]:
    """Ground, the box standing on it at the origin, and the gripper open around it with
    ``clearance_m`` on each side. Returns (body id, gripper, T_world_tcp)."""
    world.add_ground(friction=0.5)
    T_part = np.eye(4)
    T_part[2, 3] = part.size_m[2] / 2.0
    body = world.add_body((box_piece(part.size_m),), part.mass_kg, T_part,
                          inertia_kgm2=box_inertia(part.mass_kg, part.size_m),
                          friction=part.friction, name="box")
    T_tcp = pose((0.0, 0.0, part.size_m[2] / 2.0))
    gripper = Gripper(world, gripper_spec or GripperSpec(), T_tcp,
                      opening_m=part.size_m[1] + 2 * clearance_m)
    return body, gripper, T_tcp


def run_seed_cycle(fidelity: Fidelity, part: BoxPart | None = None,
                   translation_m: tuple[float, float, float] = (0.1, 0.0, 0.0)
                   ) -> tuple[StepRecord, StepOutcome, Trajectory]:
    """The seed paper's 4 s cycle (lift 50 mm, translate by ``translation_m``) on ``part``
    (the 80 g box by default); the target is the start pose moved by ``translation_m``."""
    part = part or BoxPart()
    with BulletWorld(fidelity) as world:
        body, gripper, T_tcp = add_box_and_gripper(world, part)
        traj = seed_cycle(parse_phase_table(SEED_PHASE_TABLE_CSV), T_tcp, lift_m=0.05,
                          translation_m=translation_m)
        target = world.pose(body)
        target[:3, 3] += translation_m
        record, outcome = execute_step(world, gripper, body, traj, T_world_part_target=target)
    return record, outcome, traj


# --------------------------------------------------------------------------------------------
# Held-part drift along a tilted closing axis
# --------------------------------------------------------------------------------------------
def held_drift_record(fidelity: Fidelity, tilt_rad: float, part: BoxPart | None = None,
                      synchronised: bool = True) -> StepRecord:
    """The record of the held-drift scene (:func:`held_drift_m`)."""
    part = part or BoxPart()
    traj = drift_trajectory(tilt_rad)
    T_tcp = traj.T_world_gripper[0]
    with BulletWorld(fidelity) as world:
        body = world.add_body((box_piece(part.size_m),), part.mass_kg, T_tcp.copy(),
                              inertia_kgm2=box_inertia(part.mass_kg, part.size_m),
                              friction=part.friction, name="box")
        gripper = (step_gripper(world, GripperSpec(), traj, part.size_m[1]) if synchronised
                   else Gripper(world, GripperSpec(synchronised=False), T_tcp,
                                opening_m=part.size_m[1]))
        record, _ = execute_step(world, gripper, body, traj)
    return record


def held_drift_m(fidelity: Fidelity, tilt_rad: float, part: BoxPart | None = None,
                 synchronised: bool = True) -> float:
    """Largest travel (m) of ``part`` along the gripper's closing axis, relative to the palm,
    over the seed cycle's clamp-to-lower span (0.1-3.5 s), with the closing axis tilted
    ``tilt_rad`` from horizontal (pi/2: vertical, the part hangs on the lower finger).

    The part starts held between the pads in the air (no table: with a tilted closing axis
    it cannot stand between them) and the seed cycle's motion is followed, its commanded
    force never below the hold value (1.57 N) before the release.

    The gripper (:class:`GripperSpec` defaults) is built as every pipeline step builds its
    own (:func:`asmplan.sim.simulate.step_gripper`: jaws synchronised like a rack and
    pinion); ``synchronised=False`` floats its jaws instead (the plain gripper before: the
    part slides downhill until a finger reaches its joint limit).
    """
    record = held_drift_record(fidelity, tilt_rad, part, synchronised)
    t = record.t_s
    span = (t >= 0.1) & (t <= 3.5)
    y = np.array([(np.linalg.inv(Tg) @ Tp)[1, 3] for Tg, Tp
                   in zip(record.T_world_gripper[span], record.T_world_part[span], strict=True)])
    return float(y.max() - y.min())


# --------------------------------------------------------------------------------------------
# Slip threshold: lift with constant upward acceleration
# --------------------------------------------------------------------------------------------
def constant_acceleration_lift(T_tcp: np.ndarray, force_N: float, accel_mps2: float,
                               lift_s: float = 0.2, decel_mps2: float = 2.0, dt_s: float = 1e-3
                               ) -> Trajectory:
    """Clamp (0 -> ``force_N`` in 0.1 s), hold to 0.3 s, lift at constant ``accel_mps2`` for
    ``lift_s``, brake at ``decel_mps2`` (< g, so the part stays pressed down) to rest."""
    t_clamp, t_hold = 0.1, 0.3
    v_top = accel_mps2 * lift_s
    t_lift = t_hold + lift_s
    t_end = t_lift + v_top / decel_mps2
    t = np.round(np.arange(0.0, t_end + 1e-12, dt_s), 12)
    if t[-1] < t_end - 1e-12:
        t = np.append(t, t_end)
    tau = np.clip(t - t_hold, 0.0, lift_s)
    tb = np.clip(t - t_lift, 0.0, None)
    z = 0.5 * accel_mps2 * tau**2 + v_top * tb - 0.5 * decel_mps2 * tb**2
    T = np.repeat(T_tcp[None], t.shape[0], axis=0)
    T[:, 2, 3] += z
    f = np.where(t < t_clamp, force_N * t / t_clamp, force_N)
    phases = (PhaseSpan("clamp", 0.0, t_clamp), PhaseSpan("hold", t_clamp, t_hold),
              PhaseSpan("lift", t_hold, t_lift), PhaseSpan("translate", t_lift, float(t[-1])))
    return Trajectory(t_s=t, T_world_gripper=T, clamp_force_N=f, phases=phases)


def lift_profile(accel_mps2: float) -> tuple[float, float]:
    """(lift_s, decel_mps2) of :func:`constant_acceleration_lift` for ``accel_mps2``: 0.2 s
    of acceleration up to 5 m/s^2, shorter above so that the top speed stays 1 m/s or
    less... but never under 0.1 s (20 m/s^2: 2 m/s), so that a force 0.6 % short of the
    threshold still slips 0.5 (0.006 (g + a)) T^2 >= 0.9 mm, past the 0.2 mm slip limit;
    braking at ``v_top / 0.3 s`` (at least 2, at most 7.5 m/s^2 < g: the part stays pressed
    down in the grip while the lift slows)."""
    lift_s = 0.2 if accel_mps2 <= 5.0 else max(0.1, 1.0 / accel_mps2)
    v_top = accel_mps2 * lift_s
    return lift_s, min(7.5, max(2.0, v_top / 0.3))


def lift_slip_m(fidelity: Fidelity, part: BoxPart, force_N: float, accel_mps2: float) -> float:
    """Largest slip (m) of ``part`` in the fingers, lifted from the table at ``accel_mps2``
    with ``force_N`` (:func:`lift_profile`). ``accel_mps2`` = 0 is :func:`hold_slip_m` (a
    part lifted at no acceleration never leaves the table)."""
    with BulletWorld(fidelity) as world:
        body, gripper, T_tcp = add_box_and_gripper(world, part)
        _, outcome = execute_step(world, gripper, body,
                                  slip_trajectory(T_tcp, force_N, accel_mps2))
    return float(outcome.max_slip_m)


HOLD_LIFT_M = 0.002
HOLD_LIFT_S = 1.2


def hold_lift_trajectory(T_tcp: np.ndarray, force_N: float, hold_s: float = 0.3) -> Trajectory:
    """Clamp on the table (0 -> ``force_N`` in 0.1 s), hold to 0.3 s, lift
    :data:`HOLD_LIFT_M` by a minimum-jerk move over :data:`HOLD_LIFT_S` (peak acceleration
    5.77 h / T^2 = 0.008 m/s^2, 0.08 % of g), hold still in the air for ``hold_s``."""
    up = T_tcp.copy()
    up[2, 3] += HOLD_LIFT_M
    return trajectory_from_segments(T_tcp, (
        Segment("clamp", 0.1, T_tcp, 0.0, force_N),
        Segment("hold", 0.2, T_tcp, force_N, force_N),
        Segment("lift", HOLD_LIFT_S, up, force_N, force_N),
        Segment("translate", hold_s, up, force_N, force_N),
    ))


def hold_slip_m(fidelity: Fidelity, part: BoxPart, force_N: float, hold_s: float = 0.3
                ) -> float:
    """Largest slip (m) of ``part`` clamped on the table with ``force_N``, lifted slowly and
    held still in the air (:func:`hold_lift_trajectory`): the a = 0 case, whose holding
    force is ``m g / (2 mu)``. A part squeezed in the air from rest instead falls for the
    few milliseconds the squeeze takes to rise and slides on (+9-12 % apparent threshold)."""
    with BulletWorld(fidelity) as world:
        body, gripper, T_tcp = add_box_and_gripper(world, part)
        _, outcome = execute_step(world, gripper, body,
                                  hold_lift_trajectory(T_tcp, force_N, hold_s))
    return float(outcome.max_slip_m)


def slip_trajectory(T_tcp: np.ndarray, force_N: float, accel_mps2: float) -> Trajectory:
    """The slip-threshold scene's trajectory at ``accel_mps2`` (0: held in the air,
    :func:`hold_lift_trajectory`; else :func:`constant_acceleration_lift` with
    :func:`lift_profile`)."""
    if accel_mps2 == 0.0:
        return hold_lift_trajectory(T_tcp, force_N)
    lift_s, decel = lift_profile(accel_mps2)
    return constant_acceleration_lift(T_tcp, force_N, accel_mps2, lift_s=lift_s,
                                      decel_mps2=decel)


def drift_trajectory(tilt_rad: float) -> Trajectory:
    """The held-drift scene's trajectory (:func:`held_drift_m`): the seed cycle from a TCP
    0.3 m up, closing axis tilted ``tilt_rad`` from horizontal, force at least the hold
    value (1.57 N) until the release."""
    c, sn = math.cos(tilt_rad), math.sin(tilt_rad)
    R_tilt = np.array([[1.0, 0.0, 0.0], [0.0, c, -sn], [0.0, sn, c]])
    T_tcp = pose((0.0, 0.0, 0.3), R_DOWN @ R_tilt)
    traj = seed_cycle(parse_phase_table(SEED_PHASE_TABLE_CSV), T_tcp, lift_m=0.05,
                      translation_m=(0.1, 0.0, 0.0))
    hold = np.where(traj.t_s < 3.5, np.maximum(traj.clamp_force_N, 1.57), traj.clamp_force_N)
    return Trajectory(t_s=traj.t_s, T_world_gripper=traj.T_world_gripper,
                      clamp_force_N=hold, phases=traj.phases)


# --------------------------------------------------------------------------------------------
# Pin into a blind hole of a fixtured block
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PinHole:
    """The pin-insertion scene: a blind hole (exact 8-sided decomposition by default, no
    chamfer) in a fixtured block, a standing steel pin, the gripper's force and seat gap."""

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
    # True: the pipeline's gripper (CoupledGripper: synchronised jaws, open phases at the
    # grasp's opening); False: floating jaws (GripperSpec(synchronised=False)), fully open in
    # the open phases: the scene the stored interference resolutions (sim/fidelity.py) were
    # measured with, its pin held off-centre where a finger first touched it. With the
    # coupled gripper BALANCED and ACCURATE keep every figure, FAST pushes its -0.2 mm
    # interference 2.049 mm in (bound 2 mm): docs/physics.md, "The bench's PinHole scene"
    coupled_gripper: bool = False


def plain_fit_contact(world: BulletWorld, pin: int, block: int, pin_radius_m: float,
                      pin_length_m: float, hole_radius_m: float, hole_depth_m: float,
                      block_height_m: float, friction: float) -> HeldFitContact:
    """The exact fit contact (:mod:`asmplan.sim.feature_contact`) of a plain, unchamfered pin
    (body frame at its centre, axis z, tip at -z) in a blind, unchamfered hole at the centre of
    a block's top face (block frame at its centre)."""
    model = FitContactModel(
        PinFeature(np.array([0.0, 0.0, -pin_length_m / 2.0]), np.array([0.0, 0.0, 1.0]),
                   pin_radius_m, 0.0, pin_length_m),
        BoreFeature(np.array([0.0, 0.0, block_height_m / 2.0]), np.array([0.0, 0.0, 1.0]),
                    hole_radius_m, 0.0, hole_depth_m, False,
                    hole_radius_m + min(pin_radius_m, 2e-3)))
    return HeldFitContact(world, pin, (FitPair(block, model),), (friction,))


def pin_insertion(fidelity: Fidelity, radial_clearance_m: float, lateral_offset_m: float = 0.0,
                  scene: PinHole | None = None, criteria: SuccessCriteria | None = None,
                  pose_error: PoseError | None = None) -> tuple[StepRecord, StepOutcome]:
    """Pick a standing pin, carry it over the hole and insert it along -z.

    ``radial_clearance_m`` < 0 makes an interference fit; ``lateral_offset_m`` shifts the
    place pose along x (no chamfer anywhere); ``pose_error`` is the robot's error at the
    insertion (:func:`asmplan.sim.pose_error.apply_pose_error`).
    """
    s = scene or PinHole()
    r_pin = s.hole_radius_m - radial_clearance_m
    with BulletWorld(fidelity) as world:
        world.add_ground(friction=0.5)
        block_pieces = block_with_holes_pieces(
            s.block_size_m, (HoleSpec((0.0, 0.0), s.hole_radius_m, s.hole_depth_m, s.n_sides),))
        T_block = np.eye(4)
        T_block[:3, 3] = [s.block_xy_m[0], s.block_xy_m[1], s.block_size_m[2] / 2.0]
        block = world.add_body(block_pieces, 0.0, T_block, friction=s.block_friction,
                               name="block")
        pin_piece = ConvexPiece(kind="cylinder", T_part_piece=np.eye(4), radius_m=r_pin,
                                length_m=s.pin_length_m)
        mass = s.pin_density_kg_m3 * math.pi * r_pin**2 * s.pin_length_m
        T_pin = np.eye(4)
        T_pin[2, 3] = s.pin_length_m / 2.0
        pin = world.add_body((pin_piece,), mass, T_pin,
                             inertia_kgm2=cylinder_inertia(mass, r_pin, s.pin_length_m),
                             friction=s.pin_friction, name="pin")
        T_grasp = pose((0.0, 0.0, T_pin[2, 3] + s.grasp_above_centre_m))
        gripper: Gripper
        if s.coupled_gripper:
            gripper = CoupledGripper(world, GripperSpec(), T_grasp, opening_m=2 * r_pin + 0.004)
        else:
            gripper = Gripper(world, GripperSpec(synchronised=False), T_grasp,
                              opening_m=2 * r_pin + 0.004)
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
        traj = trajectory_from_segments(T_grasp, (
            Segment("clamp", 0.1, T_grasp, 0.0, F),
            Segment("hold", 0.2, T_grasp, F, F),
            Segment("lift", 0.4, up, F, F),
            Segment("translate", 0.6, above, F, F),
            Segment("lower", 1.0, seat, F, F),
            Segment("release", 0.2, seat, F, 0.0),
            Segment("retreat", 0.3, retreat, 0.0, 0.0),
        ))
        if pose_error is not None:
            traj = apply_pose_error(traj, (0.0, 0.0, -1.0), pose_error)
        target = np.eye(4)
        target[:3, 3] = [x, y, seated_centre_z]
        fit = None
        if fidelity.feature_contact and radial_clearance_m > 0:
            fit = plain_fit_contact(world, pin, block, r_pin, s.pin_length_m, s.hole_radius_m,
                                    s.hole_depth_m, s.block_size_m[2],
                                    s.pin_friction * s.block_friction)
            # the block is offset in x, y: the fit model's block frame is the block body's
        return execute_step(world, gripper, pin, traj, criteria=criteria,
                            T_world_part_target=target, mate_axis_world=(0.0, 0.0, -1.0),
                            insertion_length_m=s.hole_depth_m, fit_contact=fit)


# --------------------------------------------------------------------------------------------
# Whitney's two-point contact (jam) depth: a peg held at a fixed tilt, pushed into a hole
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class JamScene:
    """A 10 mm steel peg held at a fixed tilt (a stiff wrist: its rotational inertia is set
    ``rotational_stiffening`` times higher and its angular velocity is zeroed after every
    step, so contact torques cannot turn it; it translates freely, at most ``max_speed_mps``
    fast, as a robot feeds near contact), pushed down
    with ``push_N`` and sideways with ``side_N`` into a blind hole (no chamfer) of a fixed
    block. The hole polygon has a flat face at +x and -x (the tilt plane), the peg prism a
    vertex there, so the planar two-point geometry holds exactly."""

    peg_diameter_m: float = 0.010
    peg_length_m: float = 0.030
    hole_depth_m: float = 0.020
    hole_sides: int = 16
    block_size_m: tuple[float, float, float] = (0.04, 0.04, 0.03)
    friction: float = 0.3
    push_N: float = 2.0
    side_N: float = 0.5
    max_speed_mps: float = 0.005
    settle_s: float = 1.0
    rotational_stiffening: float = 1e6


def whitney_jam_depth_m(clearance_m: float, tilt_rad: float, peg_diameter_m: float = 0.010
                        ) -> float:
    """Whitney's two-point contact insertion depth l* = (D - d cos t) / sin t, m: the peg
    length inside the hole (along its axis, from the leading corner to the mouth contact)
    at which a peg tilted by ``tilt_rad`` touches both walls; D = d + ``clearance_m``."""
    D = peg_diameter_m + clearance_m
    return (D - peg_diameter_m * math.cos(tilt_rad)) / math.sin(tilt_rad)


def jam_depth_m(fidelity: Fidelity, clearance_m: float, tilt_rad: float,
                scene: JamScene | None = None) -> float:
    """Simulated two-point contact depth (m, as :func:`whitney_jam_depth_m` defines it) of
    the peg of ``scene`` tilted by ``tilt_rad`` in a hole ``clearance_m`` wider (diametral)."""
    s = scene or JamScene()
    d = s.peg_diameter_m
    D = d + clearance_m
    H = s.block_size_m[2]
    with BulletWorld(fidelity) as world:
        block = block_with_holes_pieces(s.block_size_m, (HoleSpec((0.0, 0.0), D / 2.0,
                                                                  s.hole_depth_m, s.hole_sides),))
        T_block = np.eye(4)
        T_block[2, 3] = H / 2.0
        block_body = world.add_body(block, 0.0, T_block, friction=s.friction, name="block")
        L = s.peg_length_m
        mass = 7800.0 * math.pi * (d / 2.0) ** 2 * L
        # axis u = (-sin t, 0, cos t) (top leans to -x), across e = (cos t, 0, sin t)
        c, sn = math.cos(tilt_rad), math.sin(tilt_rad)
        u, e = np.array([-sn, 0.0, c]), np.array([c, 0.0, sn])
        R = np.column_stack([e, np.array([0.0, 1.0, 0.0]), u])
        # leading (+x) bottom corner 2 um off the +x wall, 0.05 mm below the mouth
        corner = np.array([D / 2.0 - 2e-6, 0.0, H - 0.05e-3])
        bottom = corner - (d / 2.0) * e
        T_peg = np.eye(4)
        T_peg[:3, :3] = R
        T_peg[:3, 3] = bottom + (L / 2.0) * u
        peg = world.add_body((ConvexPiece(kind="cylinder", T_part_piece=np.eye(4),
                                          radius_m=d / 2.0, length_m=L),),
                             mass, T_peg, inertia_kgm2=cylinder_inertia(mass, d / 2.0, L)
                             * s.rotational_stiffening, friction=s.friction, name="peg")
        fit = None
        if fidelity.feature_contact:
            fit = plain_fit_contact(world, peg, block_body, d / 2.0, L, D / 2.0, s.hole_depth_m,
                                    H, s.friction * s.friction)
            fit.activate()
        force = [s.side_N, 0.0, -s.push_N]
        for _ in range(round(s.settle_s / fidelity.dt_s)):
            world.apply_force(peg, -1, force, world.com_position_m(peg).tolist())
            world.step()
            if fit is not None:
                fit.after_step()
            v = world.velocity(peg)[0]
            speed = float(np.linalg.norm(v))
            if speed > s.max_speed_mps:  # a robot feeding slowly near contact
                v = v * (s.max_speed_mps / speed)
            world.set_velocity(peg, v.tolist(), (0.0, 0.0, 0.0))  # the wrist holds the tilt
            if fit is not None:  # exactly: the model's solve is the only source of rotation
                T_now = world.pose(peg)
                T_now[:3, :3] = R
                world.set_pose(peg, T_now)
                fit.held_pose_changed(T_now)
        T = world.pose(peg)
    u = T[:3, 2]
    bottom = T[:3, 3] - (L / 2.0) * u
    e = T[:3, 0]
    trailing = bottom - (d / 2.0) * e  # the (-x) bottom corner, on the side line
    return float((H - trailing[2]) / u[2])


def entered_depth_m(record: StepRecord, scene: PinHole | None = None) -> float:
    """How deep the pin was in the hole when the gripper stopped pushing (end of "lower"), m."""
    s = scene or PinHole()
    last = np.flatnonzero(record.phase_mask("lower"))[-1]
    return s.hole_depth_m - float(record.axial_error_m[last])


__all__ = [
    "R_DOWN",
    "SEED_PHASE_TABLE_CSV",
    "BoxPart",
    "G",
    "HeavyOnLight",
    "JamScene",
    "PinHole",
    "add_box_and_gripper",
    "box_inertia",
    "box_piece",
    "constant_acceleration_lift",
    "cylinder_inertia",
    "drift_trajectory",
    "entered_depth_m",
    "heavy_on_light",
    "held_drift_m",
    "held_drift_record",
    "hold_lift_trajectory",
    "hold_slip_m",
    "jam_depth_m",
    "lift_profile",
    "lift_slip_m",
    "pin_insertion",
    "pose",
    "run_seed_cycle",
    "slip_trajectory",
    "whitney_jam_depth_m",
]


@dataclass(frozen=True)
class HeavyOnLight:
    """Result of :func:`heavy_on_light`: the fastest cube (m/s) and the block's sink (m) up
    to the end of the scene, the simulated time it ran (s), and the guard's failure that
    ended it early (None: it ran to the end)."""

    max_cube_speed_mps: float
    sink_m: float
    t_end_s: float
    failure: Failure | None


def heavy_on_light(fidelity: Fidelity, settle_s: float = 1.0,
                   guard: SceneGuard | None = None) -> HeavyOnLight:
    """A 120 x 120 x 900 mm, 100 kg block resting on four 10 mm, 1 g cubes on the ground,
    no gripper, for ``settle_s`` (the scene of ``tests/sim/test_guards.py`` without the
    gripper's cycle), watched as a step is (:class:`asmplan.sim.guard.SceneWatch` with
    ``guard``, every record row): the scene ends at the guard's first failure. Analytic:
    nothing moves. Cube speeds are sampled every physics step."""
    cube = (0.01, 0.01, 0.01)
    block = (0.12, 0.12, 0.9)
    with BulletWorld(fidelity) as world:
        world.add_ground(friction=0.5)
        cubes = []
        for dx in (-0.04, 0.04):
            for dy in (-0.04, 0.04):
                T = np.eye(4)
                T[:3, 3] = (dx, dy, 0.005)
                cubes.append(world.add_body((box_piece(cube),), 0.001, T,
                                            inertia_kgm2=box_inertia(0.001, cube), name="cube"))
        T = np.eye(4)
        T[:3, 3] = (0.0, 0.0, 0.01 + 0.45)
        top = world.add_body((box_piece(block),), 100.0, T,
                             inertia_kgm2=box_inertia(100.0, block), name="block")
        watch = SceneWatch(world, world.dynamic_bodies(), guard or SceneGuard())
        k = fidelity.record_every_steps
        vmax = 0.0
        failure = None
        n = round(settle_s / fidelity.dt_s)
        i = 0
        while i < n and failure is None:
            world.step()
            i += 1
            vmax = max(vmax, max(float(np.linalg.norm(world.velocity(c)[0])) for c in cubes))
            if i % k == 0 or i == n:
                failure = watch.check(i * fidelity.dt_s)
        sink = 0.46 - float(world.pose(top)[2, 3])
    return HeavyOnLight(vmax, sink, i * fidelity.dt_s, failure)
