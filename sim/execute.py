"""Execute one assembly step in a :class:`BulletWorld` and judge it.

:func:`execute_step` drives a :class:`~asmplan.sim.gripper.Gripper` along a
:class:`~asmplan.planner.trajectory.Trajectory` at the world's fidelity, records every control
tick into a :class:`~asmplan.sim.records.StepRecord` and returns a
:class:`~asmplan.sim.records.StepOutcome`. :func:`settle` runs a scene without a gripper
(stability checks), :func:`scene_warnings` flags scenes the fidelity cannot resolve. The
record is judged by :func:`asmplan.sim.judge.judge`.

Definitions
-----------
* Commands are applied every physics step: the finger force is the trajectory's value at the
  END of the step, the pose-constraint target its pose :attr:`Gripper.pose_lead_s` later
  (cancels the constraint's lag). In "approach"/"retreat" the fingers
  are position-controlled open; in every other phase they are force-controlled.
* Finger frame: the measured TCP frame shifted along its y axis to the midpoint of the two
  pads' faces (synchronised jaws keep it on the TCP; floating ones move together along y). Slip is the change
  of the part's pose in this frame since the end of the "clamp" phase (first tick at or after
  it): translation norm (m) and rotation angle (rad).
* Measured clamp force of a finger: sum of the contact normal forces between its pad and the
  part; on grooved pads each times the cosine of its normal's angle to the closing axis
  (the squeeze: ``sin(theta / 2)`` on the flanks of a V-groove of included angle ``theta``).
  External force: total contact force (normal + friction) on the part from every other
  body and from the palm.
* Dropped: during the held phases (hold, lift, translate, lower) neither finger touches the
  part at some tick, or the slip exceeds ``criteria.drop_slip_m``.
* Energy growth: the part's kinetic energy exceeds ``2 * 0.5 m v_allow^2`` with
  ``v_allow = 2 v_tcp_max + sqrt(2 g dz) + 0.1 m/s`` (``v_tcp_max`` the trajectory's peak TCP
  speed, ``dz`` the part's largest drop below its start height): faster than the commanded
  motion and free fall can explain, i.e. the solver injected energy.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from ..knowledge.frames import invert
from ..planner.trajectory import OPEN_PHASES, Trajectory, quat_xyzw_from_matrix, rotation_angle_rad
from .bullet import BulletWorld
from .carry_hold import CarryHold
from .contacts import Contacts, concat_contacts
from .feature_contact import HeldFitContact
from .gripper import FINGER_LINKS, Gripper
from .guard import SceneWatch
from .judge import _SPEED_MARGIN_MPS, _failures, judge
from .partner_hold import PartnerHold
from .placed_hold import PlacedHold
from .records import StepOutcome, StepRecord, SuccessCriteria
from .rest import RestKeeper
from .verdicts import ContactEvidence, Failure, SceneGuard, two_point_contacts

PEAK_SAMPLE_DT_S = 0.004
"""The peak criteria (insertion force, penetration) are sampled every
``max(1, round(PEAK_SAMPLE_DT_S / dt))`` physics steps, whatever ``record_every_steps``: every
step at FAST (1/240 s), every 4th at BALANCED and every 16th at ACCURATE (their record rates).
Single-step impact spikes between two samples are not seen."""


def _is_finger_link(links: np.ndarray) -> np.ndarray:
    return (links == FINGER_LINKS[0]) | (links == FINGER_LINKS[1])


def _touches_other_than(con: Contacts, gripper_body: int) -> bool:
    """Whether the part presses on a body other than the gripper (its set-down contact)."""
    return bool(np.any((con.body_b != gripper_body) & (con.normal_force_N > 0.0)))


def _finger_frame(T_world_tcp: np.ndarray, travel: np.ndarray) -> np.ndarray:
    T = T_world_tcp.copy()
    y_mid = 0.5 * (travel[1] - travel[0])
    T[:3, 3] = T_world_tcp[:3, 3] + T_world_tcp[:3, 1] * y_mid
    return T


def scene_warnings(
    fidelity_min_clearance_m: float,
    diametral_clearances_m: Sequence[float] = (),
    masses_kg: Sequence[float] = (),
    smallest_feature_m: float | None = None,
    dt_s: float | None = None,
    peak_speed_mps: float = 0.0,
) -> tuple[str, ...]:
    """Warnings for scenes the chosen fidelity may not resolve (checked before running).

    Parameters
    ----------
    fidelity_min_clearance_m : float
        ``Fidelity.min_resolvable_clearance_m``.
    diametral_clearances_m : sequence of float
        Diametral clearances of the fits involved, m (negative for interference).
    masses_kg : sequence of float
        Masses of the dynamic bodies in contact, kg.
    smallest_feature_m : float, optional
        Smallest dimension of any dynamic part, m.
    dt_s : float, optional
        Time step, s (with ``peak_speed_mps``, checks tunnelling of small parts).
    peak_speed_mps : float
        Largest expected part speed, m/s.

    Returns
    -------
    tuple of str
    """
    out = []
    for c in diametral_clearances_m:
        if 0.0 <= c < fidelity_min_clearance_m:
            out.append(
                f"diametral clearance {c * 1e3:.3f} mm is below this fidelity's smallest "
                f"resolvable clearance {fidelity_min_clearance_m * 1e3:.3f} mm"
            )
    live = [m for m in masses_kg if m > 0]
    if len(live) >= 2:
        ratio = max(live) / min(live)
        if ratio > 100.0:
            out.append(
                f"mass ratio {ratio:.0f}:1 between contacting bodies exceeds 100:1; the "
                f"iterative solver lets the heavy body sink into the light one"
            )
    if smallest_feature_m is not None and dt_s is not None and peak_speed_mps > 0:
        travel = peak_speed_mps * dt_s
        if travel > 0.25 * smallest_feature_m:
            out.append(
                f"a part of {smallest_feature_m * 1e3:.2f} mm moves {travel * 1e3:.2f} mm per "
                f"step at {peak_speed_mps:.2f} m/s; contacts may be missed (tunnelling)"
            )
    return tuple(out)


# Complexity above C (radon): the simulation loop; per tick the gripper mode, the press hook,
# the record rows, the peak criteria and the guard share the loop state (staged in sim/bodies, nest).
def execute_step(
    world: BulletWorld,
    gripper: Gripper,
    part_body: int,
    trajectory: Trajectory,
    criteria: SuccessCriteria | None = None,
    T_world_part_target: np.ndarray | None = None,
    mate_axis_world: ArrayLike | None = None,
    warnings: Sequence[str] = (),
    before_step: Callable[[int], None] | None = None,
    insertion_length_m: float | None = None,
    guard: SceneGuard | None = None,
    carry_anchor: bool = False,
    fit_contact: HeldFitContact | None = None,
    partner_hold: PartnerHold | None = None,
    carry_hold: CarryHold | None = None,
) -> tuple[StepRecord, StepOutcome]:
    """Drive the gripper along ``trajectory`` and judge the step.

    Parameters
    ----------
    world : BulletWorld
        World holding the gripper and the part; simulated from its current state.
    gripper : Gripper
        Gripper already at ``trajectory.pose_at(t_s[0])`` with the part between its fingers
        (or able to reach it in "approach").
    part_body : int
        Body id of the part being moved.
    trajectory : Trajectory
    criteria : SuccessCriteria, optional
    T_world_part_target : (4, 4) float array, optional
        Where the part should end; without it the pose criteria are skipped.
    mate_axis_world : (3,) float, optional
        Insertion direction (unit vector, world frame), e.g. (0, 0, -1) for a vertical
        insertion from above; enables the axial/lateral errors.
    warnings : sequence of str
        Warnings to carry into the outcome (e.g. from :func:`scene_warnings`).
    before_step : callable, optional
        ``before_step(i)`` is called before physics step ``i`` (forces applied there act
        during that step only), e.g. :class:`asmplan.sim.press.PressRecorder`.
    insertion_length_m : float, optional
        Engagement length of the insertion: a step short of its depth is classified as
        ``rim_stop`` or ``jammed`` (:mod:`asmplan.sim.verdicts`).
    guard : SceneGuard, optional
        Speed, cell and sinking bounds (default :class:`~asmplan.sim.verdicts.SceneGuard`,
        checked by :class:`~asmplan.sim.guard.SceneWatch`): a dynamic body (other than the
        gripper) beyond them ends the step at that record row as ``fell`` or ``unstable``;
        the record keeps the rows before it.
    carry_anchor : bool
        Friction anchors on the fingers from the start of the clamp until the part's first
        contact with a body other than the gripper in "lower" (the pipeline passes
        :attr:`~asmplan.sim.fidelity.Fidelity.carry_anchor`); no effect when the world's
        fidelity has ``friction_anchor`` (anchors throughout).
    fit_contact : HeldFitContact, optional
        The exact contact of the part's fits (:mod:`asmplan.sim.feature_contact`): switched on
        before the first step and kept to the end (it costs nothing while the pin is away from
        its bore); its points join Bullet's in every contact criterion (insertion force,
        penetration, two-point evidence).
    partner_hold : PartnerHold, optional
        Holds the mate partners static while the load check allows
        (:mod:`asmplan.sim.partner_hold`): started after the first physics step, checked at
        every peak sample.
    carry_hold : CarryHold, optional
        Sticks the part to the palm in the held phases while it touches nothing but the pads
        and its grip holds the load (:mod:`asmplan.sim.carry_hold`): called after every
        physics step, its load checked at every peak sample.

    Returns
    -------
    (StepRecord, StepOutcome)
    """
    guard = SceneGuard() if guard is None else guard
    crit = SuccessCriteria() if criteria is None else criteria
    fid = world.fidelity
    dt = fid.dt_s
    k = fid.record_every_steps
    t0 = float(trajectory.t_s[0])
    n_steps = max(1, round(trajectory.duration_s / dt))
    t_cmd = t0 + dt * np.arange(1, n_steps + 1)
    T_cmd = trajectory.poses_at(t_cmd + gripper.pose_lead_s)
    pos_cmd = T_cmd[:, :3, 3]
    quat_cmd = quat_xyzw_from_matrix(T_cmd[:, :3, :3])
    f_cmd = trajectory.forces_at(t_cmd)
    phase_idx = trajectory.phase_indices_at(t_cmd)
    names = tuple(p.name for p in trajectory.phases)
    is_open = np.array([names[i] in OPEN_PHASES for i in phase_idx])
    f_cmd = np.where(is_open, 0.0, f_cmd)
    clamp_end = next((p.t_end_s for p in trajectory.phases if p.name == "clamp"), t0)

    target = None if T_world_part_target is None else np.asarray(T_world_part_target, float)
    axis = None
    if mate_axis_world is not None:
        axis = np.asarray(mate_axis_world, dtype=float)
        axis = axis / np.linalg.norm(axis)
        if target is None:
            raise ValueError("mate_axis_world given without T_world_part_target")

    tick_steps = [i for i in range(n_steps) if (i + 1) % k == 0 or i == n_steps - 1]
    m = len(tick_steps)
    rec = {
        "t_s": np.zeros(m),
        "phase_index": np.zeros(m, dtype=int),
        "commanded_force_N": np.zeros(m),
        "measured_force_N": np.zeros((m, 2)),
        "slip_m": np.zeros(m),
        "slip_rad": np.zeros(m),
        "T_world_part": np.zeros((m, 4, 4)),
        "T_world_gripper": np.zeros((m, 4, 4)),
        "finger_travel_m": np.zeros((m, 2)),
        "axial_error_m": np.full(m, np.nan),
        "lateral_error_m": np.full(m, np.nan),
        "external_force_N": np.zeros((m, 3)),
        "max_penetration_m": np.zeros(m),
        "speed_mps": np.zeros(m),
        "kinetic_energy_J": np.zeros(m),
    }
    is_lower = np.array([names[i] == "lower" for i in phase_idx])
    peak_every = max(1, round(PEAK_SAMPLE_DT_S / dt))
    peak_insert_between = 0.0
    pen_between = 0.0
    T_grip_part_ref: np.ndarray | None = None
    nan_detected = False
    mode_open: bool | None = None
    watch = SceneWatch(world, [b for b in world.dynamic_bodies() if b != gripper.body], guard,
                       not_sinking=(part_body,))
    stop: Failure | None = None
    lower_contacts: dict[int, Contacts] = {}  # record row -> the part's non-finger contacts
    rest = RestKeeper(world, gripper.body, part_body) if fid.rest_window_s > 0 else None
    placed = (PlacedHold(world, part_body, gripper.body,
                         () if fit_contact is None else tuple(p.partner for p in fit_contact.pairs),
                         fid.partner_hold_fraction)
              if fid.rest_window_s > 0 and before_step is None else None)  # a press's ram may act
    placed_after = names.index("lower") if "lower" in names else len(names)
    wall0 = time.perf_counter()
    r = 0
    carry_anchor = carry_anchor and not fid.friction_anchor
    grooved = gripper.spec.pad_groove_depth_m > 0.0
    anchored = False
    set_down = False  # the part touched something but the fingers in "lower"
    # switched on before the first step: changing Bullet's collision filter of a body drops
    # its contact manifolds (a gripped part's pads lost theirs and sank 0.2 mm into it)
    fit_from = 0
    if fit_contact is not None:  # the pads take their share of the fit contact's solve
        spec = gripper.spec
        fit_contact.set_grip(gripper.body, FINGER_LINKS, spec.pad_friction,
                             spec.synchronised and fid.grip_rows,
                             spec.finger_mass_kg,
                             None if spec.pad_groove_depth_m > 0.0 else spec.pad_size_m,
                             floating=not spec.synchronised,
                             lateral_stiffness_N_per_m=spec.lateral_stiffness_N_per_m,
                             coupling=gripper.coupling)

    def part_contacts() -> Contacts:
        con = world.contacts(part_body)
        if fit_contact is not None and fit_contact.active:
            return concat_contacts(con, fit_contact.contacts())
        return con

    # the per-step scalars as Python lists: indexing a numpy array per step costs a scalar
    # object each time (the same doubles and ints)
    open_at, lower_at = is_open.tolist(), is_lower.tolist()
    phase_at, force_at, t_at = phase_idx.tolist(), f_cmd.tolist(), t_cmd.tolist()
    for i in range(n_steps):
        if carry_anchor:  # anchors while clamped and carried, off at the set-down contact
            want = not open_at[i] and not set_down and phase_at[i] <= placed_after
            if want != anchored:
                world.set_friction_anchor(gripper.body, FINGER_LINKS, want)
                anchored = want
        if fit_contact is not None:
            if i == fit_from:
                fit_contact.activate()
            fit_contact.before_step()
        gripper.command_pose_pq(pos_cmd[i], quat_cmd[i])
        if open_at[i]:
            if mode_open is not True:
                gripper.command_open()
                mode_open = True
        else:
            gripper.command_clamp_force(force_at[i])
            mode_open = False
        if before_step is not None:  # e.g. a press fit's resistance (asmplan.sim.press)
            before_step(i)
        world.step()
        if fit_contact is not None:
            fit_contact.after_step()
        if partner_hold is not None and (i == 0 or (i + 1) % peak_every == 0):
            partner_hold.check(t_at[i])
        if carry_hold is not None:
            carry_hold.after_step(t_at[i], names[phase_at[i]], force_at[i],
                                  (i + 1) % peak_every == 0)
        if r >= m or tick_steps[r] != i:
            # between record rows: sample the peak criteria at their own rate
            if (i + 1) % peak_every:
                continue
            if lower_at[i]:
                con = part_contacts()
                is_finger = (con.body_b == gripper.body) & _is_finger_link(con.link_b)
                if carry_anchor and not set_down:
                    set_down = _touches_other_than(con, gripper.body)
                peak_insert_between = max(peak_insert_between, float(
                    np.linalg.norm(con.select(~is_finger).force_on_a_N())))
                pen_between = max(pen_between, con.max_penetration_m())
            else:
                pen_between = max(pen_between, world.max_penetration_m(part_body))
            continue
        # carried: the part's speed in the grip
        carried = ({part_body: world.velocity(gripper.body)[0]} if mode_open is False
                   else None)
        stop = watch.check(t_at[i], carried)
        if stop is not None:
            break
        T_part = world.pose(part_body)
        T_tcp = gripper.tcp_pose()
        travel = gripper.finger_travel_m()
        con = part_contacts()
        is_finger = (con.body_b == gripper.body) & _is_finger_link(con.link_b)
        # the squeeze: normal forces along the closing axis (a grooved pad's flanks press
        # the part at +-(90 deg - theta/2) to it; a flat pad's normals lie along it)
        squeeze = (con.normal_force_N * np.abs(con.normal_on_b @ T_tcp[:3, 1]) if grooved
                   else con.normal_force_N)
        forces = [float(np.sum(squeeze[is_finger & (con.link_b == link)]))
                  for link in FINGER_LINKS]
        others = con.select(~is_finger)
        external = others.force_on_a_N()
        if lower_at[i] and axis is not None:
            lower_contacts[r] = others
        if carry_anchor and not set_down and lower_at[i]:
            set_down = _touches_other_than(con, gripper.body)
        v, w = world.velocity(part_body)
        ke = world.kinetic_energy_J(part_body, (v, w), T_part)
        T_grip = _finger_frame(T_tcp, travel)
        T_grip_part = invert(T_grip) @ T_part
        t = t_at[i]
        if T_grip_part_ref is None and t >= clamp_end - 1e-12:
            T_grip_part_ref = T_grip_part
        if T_grip_part_ref is not None:
            d = T_grip_part[:3, 3] - T_grip_part_ref[:3, 3]
            rec["slip_m"][r] = float(np.linalg.norm(d))
            rec["slip_rad"][r] = float(
                rotation_angle_rad(T_grip_part_ref[:3, :3].T @ T_grip_part[:3, :3])
            )
        if target is not None and axis is not None:
            e = target[:3, 3] - T_part[:3, 3]
            ax = float(e @ axis)
            rec["axial_error_m"][r] = ax
            rec["lateral_error_m"][r] = float(np.linalg.norm(e - ax * axis))
        rec["t_s"][r] = t
        rec["phase_index"][r] = phase_at[i]
        rec["commanded_force_N"][r] = force_at[i]
        rec["measured_force_N"][r] = forces
        rec["T_world_part"][r] = T_part
        rec["T_world_gripper"][r] = T_tcp
        rec["finger_travel_m"][r] = travel
        rec["external_force_N"][r] = external
        rec["max_penetration_m"][r] = con.max_penetration_m()
        rec["speed_mps"][r] = float(np.linalg.norm(v))
        rec["kinetic_energy_J"][r] = ke
        if not (np.all(np.isfinite(T_part)) and np.all(np.isfinite(v)) and math.isfinite(ke)):
            nan_detected = True
        r += 1
        if nan_detected:
            break
        if rest is not None:  # bodies at rest that nothing moving can reach sleep (sim/rest)
            rest.tick(bool(mode_open) and phase_at[i] > placed_after)
        if placed is not None:  # the placed part static while nothing can move it (sim/placed_hold)
            placed.tick(t, phase_at[i] > placed_after, con)
    wall = time.perf_counter() - wall0
    if r < m:  # stopped early (NaN, guard): keep the rows written so far
        rec = {name: a[:r] for name, a in rec.items()}
    record = StepRecord(phase_names=names, **rec)
    outcome = judge(
        record,
        trajectory,
        crit,
        part_mass_kg=world.body_mass_kg(part_body),
        gravity_mps2=float(np.linalg.norm(world.gravity_mps2)),
        T_world_part_target=target,
        mate_axis_world=axis,
        nan_detected=nan_detected,
        warnings=tuple(warnings),
        wall_time_s=wall,
        peak_insertion_force_between_N=peak_insert_between,
        max_penetration_between_m=pen_between,
    )
    def evidence(row: int) -> tuple[ContactEvidence, ...]:
        con = lower_contacts.get(row)
        if con is None or axis is None or con.count == 0:
            return ()
        names_b = [world.body_name(int(b)) for b in con.body_b]
        return two_point_contacts(names_b, con.position_on_b_m, con.normal_on_b,
                                  con.normal_force_N, record.T_world_part[row][:3, 3], axis)

    failures = _failures(record, outcome, crit, target, axis, insertion_length_m, stop,
                         evidence)
    if failures:
        outcome = replace(outcome, success=False, failures=failures,
                          reasons=tuple(f.message for f in failures) + outcome.reasons)
    return record, outcome


@dataclass(frozen=True)
class SettleOutcome:
    """Result of :func:`settle`: how a scene without a gripper behaved.

    Attributes
    ----------
    stable : bool
        No NaN, no energy growth, penetration within the bound.
    reasons : tuple of str
    nan_detected, energy_growth : bool
    max_penetration_m : float
        Deepest contact penetration of any watched body, m.
    max_drift_m : float
        Largest displacement of a watched body from its start position, m.
    final_kinetic_energy_J : float
        Sum over the watched bodies at the end, J.
    kinetic_energy_J : (M,) float array
        Sum over the watched bodies per tick, J.
    """

    stable: bool
    reasons: tuple[str, ...]
    nan_detected: bool
    energy_growth: bool
    max_penetration_m: float
    max_drift_m: float
    final_kinetic_energy_J: float
    kinetic_energy_J: np.ndarray


def settle(
    world: BulletWorld,
    bodies: Sequence[int],
    duration_s: float,
    max_penetration_m: float = 0.5e-3,
) -> SettleOutcome:
    """Step a scene without commands and watch ``bodies`` for instability.

    Energy growth: the watched bodies' kinetic energy exceeds what free fall of each body by
    its largest drop (plus 0.1 m/s) can explain.
    """
    n_steps = max(1, round(duration_s / world.fidelity.dt_s))
    k = world.fidelity.record_every_steps
    g = float(np.linalg.norm(world.gravity_mps2))
    p0 = {b: world.pose(b)[:3, 3].copy() for b in bodies}
    z_min = {b: p0[b][2] for b in bodies}
    ke_hist: list[float] = []
    max_pen = 0.0
    max_drift = 0.0
    nan = False
    growth = False
    for i in range(n_steps):
        world.step()
        if (i + 1) % k and i != n_steps - 1:
            continue
        ke_total = 0.0
        for b in bodies:
            p = world.pose(b)[:3, 3]
            ke = world.kinetic_energy_J(b)
            if not (np.all(np.isfinite(p)) and math.isfinite(ke)):
                nan = True
                break
            z_min[b] = min(z_min[b], float(p[2]))
            max_drift = max(max_drift, float(np.linalg.norm(p - p0[b])))
            max_pen = max(max_pen, world.contacts(b).max_penetration_m())
            v_allow = math.sqrt(2.0 * g * max(0.0, p0[b][2] - z_min[b])) + _SPEED_MARGIN_MPS
            if ke > 2.0 * 0.5 * world.body_mass_kg(b) * v_allow**2:
                growth = True
            ke_total += ke
        ke_hist.append(ke_total)
        if nan:
            break
    reasons = []
    if nan:
        reasons.append("NaN in the simulation state")
    if growth:
        reasons.append("energy growth: a body moved faster than free fall can explain")
    if max_pen > max_penetration_m:
        reasons.append(
            f"contact penetration {max_pen * 1e3:.3f} mm > {max_penetration_m * 1e3:.3f} mm"
        )
    return SettleOutcome(
        stable=not reasons,
        reasons=tuple(reasons),
        nan_detected=nan,
        energy_growth=growth,
        max_penetration_m=max_pen,
        max_drift_m=max_drift,
        final_kinetic_energy_J=ke_hist[-1] if ke_hist else math.nan,
        kinetic_energy_J=np.asarray(ke_hist),
    )
