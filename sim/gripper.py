"""Parallel two-finger gripper driven along a trajectory, with force-controlled fingers.

Model
-----
* The palm is the base of one multibody whose base link frame IS the TCP frame of
  :mod:`asmplan.planner.trajectory` (origin between the pads' contact-face centres, z toward
  the fingertips, y the closing axis). The palm box sits behind the pads (at -z).
* Two prismatic fingers, each a box pad. Finger 1 (link 0) sits at +y and closes along -y;
  finger 2 (link 1) at -y closes along +y. Joint position ``q`` is the closing travel from
  fully open: the pad's contact face is at ``|y| = max_opening_m / 2 - q``.
* The palm follows the commanded TCP pose through a fixed constraint to the world
  (``changeConstraint`` every step, bounded by ``pose_max_force_N``), so its velocity is
  physical and friction carries the part. Its weight is compensated (as a robot controller
  does) and commands lead the trajectory by :attr:`Gripper.pose_lead_s` to cancel the
  constraint's lag.
* Synchronised jaws (:attr:`GripperSpec.synchronised`, the default): the two finger joints
  are held at equal travel by a gear constraint (:meth:`BulletWorld.couple_joints`), as the
  rack and pinion of a real parallel gripper holds them. The pair cannot travel along the
  closing axis relative to the palm: a load along that axis (the part's weight with the axis
  tilted, the palm's acceleration, a chamfer pushing sideways) is carried by the mechanism,
  and an offset along it shows as the part pushed, tilted or slipping in the pads, never as
  the jaws moving off the TCP.
* Force mode: the default velocity motors are off and each finger gets the commanded
  per-finger squeeze force as a joint force (TORQUE_CONTROL). The coupling's internal force
  acts on the two joints with opposite signs, so the squeeze (the mean of the two pads'
  normal forces) equals the command in statics; the pads differ by the load along the
  closing axis (the lower pad carries the part's weight when that axis is vertical).
* Open mode: fingers are position-controlled to an opening with a bounded motor force
  (approach, retreat, or the initial opening before the clamp).

Measured clamp force of a finger = sum of the normal forces of the contact points between
that finger's pad and the part (``getContactPoints(...)[9]``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..parts.pieces import ConvexPiece
from ..planner.trajectory import quat_xyzw_from_matrix
from .bullet import BulletWorld
from .bullet_specs import LinkSpec
from .pad_shapes import pad_pieces

TOUCH_RAMP_S = 0.01
"""Time over which the squeeze rises to the command once both pads touch, s
(:meth:`Gripper._touch_ramp`)."""

FINGER_LINKS: tuple[int, int] = (0, 1)
"""PyBullet link indices of finger 1 (+y) and finger 2 (-y)."""


@dataclass(frozen=True)
class GripperSpec:
    """Geometry, mass and limits of the parallel gripper.

    Parameters
    ----------
    pad_size_m : (3,) float
        Full pad box size along TCP (x, y, z): width, thickness (closing axis), height, m.
    pad_friction : float
        Lateral friction coefficient of the pads (PyBullet multiplies it with the part's).
    pad_spinning_friction : float or None
        Torsional friction coefficient of the pads, m. None: the mean distance of the pad's
        contact face (a grooved pad's: one land's) from its centre, so that a uniformly
        loaded face resists a twist with ``mu N r_mean`` (PyBullet combines
        ``s_pad mu_part``). Without it (or without cone friction, see
        :class:`~asmplan.sim.fidelity.Fidelity`) a grip pivots about the closing axis long
        before it slips.
    max_opening_m : float
        Distance between the pads' contact faces when fully open, m.
    finger_mass_kg, palm_mass_kg : float
    palm_size_m : (3,) float
        Palm box size along TCP (x, y, z), m.
    palm_gap_m : float
        Distance from the pads' back (wrist-side) edge to the palm's front face, m.
    pose_max_force_N : float
        Force bound of the constraint that drives the palm along the trajectory, N.
    open_max_force_N : float
        Motor force bound of each finger in open (position) mode, N.
    max_clamp_force_N : float
        Largest per-finger force that may be commanded, N.
    finger_damping_Nspm : float
        Viscous damping of each finger joint, N s/m. It acts only on finger motion relative
        to the palm, so it does not change the static clamp force; with floating jaws
        (``synchronised=False``) it keeps the pair from keeping the momentum of the impact.
    gravity_compensation : bool
        Cancel the gripper's own weight with external forces every step (as a robot's
        controller does), so the pose constraint does not sag and the weight does not leak
        into the measured contact forces.
    closing_speed_mps : float or None
        Closing speed of each finger before both pads touch, m/s; None closes under pure
        force control from the start (at 1/240 s the pads then hit the part fast enough to
        penetrate it by millimetres).
    synchronised : bool
        Couple the two jaws like the rack and pinion of a real parallel gripper (equal travel,
        :meth:`BulletWorld.couple_joints`). False leaves them floating together along the
        closing axis under force control, the fingers' own weight fed forward: a part then
        slides downhill at ``m g sin t / (2 finger_damping)`` with the closing axis tilted by
        t (the model before; kept for the scenes measured with it, no pipeline gripper uses
        it).
    synchronisation_max_force_N : float
        Bound of the coupling's internal force, N (what the mechanism can carry along the
        closing axis before it gives).
    pad_groove_angle_rad, pad_groove_depth_m : float
        A V-groove along each pad's length (prism jaws, :mod:`asmplan.sim.pad_shapes`):
        included angle and depth; depth 0 (the default) is a flat pad.
    synchronisation_erp : float
        Fraction of the coupling's travel mismatch the solver corrects per step (0 < erp <= 1).
        A numerical setting, measured on gear_unit at BALANCED: at 1.0 (full correction
        every step) the 13 g POM wheel pushed onto its H7/h6 hub pitched 1.0 deg in the pads
        and ended 0.916 mm / 2.68 deg off; at 0.2 the wheel ends 0.019 mm off but the shaft
        (held by its end, 8.4 N) jams in the bearing block (tilt 0.24 deg at 21 mm, slips
        4.4 mm in the pads); at 0.5 both pass (wheel 0.023 mm, shaft 0.099 mm; floating jaws
        at 6de422a: 0.023 / 0.011 mm). Those were measured without friction anchors on the
        pads; the window was the pads' creep, not the coupling: with anchors on the pads
        (measured for the whole step; BALANCED now has them while the part is carried,
        :attr:`~asmplan.sim.fidelity.Fidelity.carry_anchor`) gear_unit succeeds at
        BALANCED at 0.5 and at 1.0 (wheel 9.2 um / 0.12 mrad off at 1.0), and at either value
        the finger travels stay equal within 0.2 um through a rim contact. 0.5 is kept.
    lateral_stiffness_N_per_m : float or None
        Stiffness of the held part's seat across the closing axis relative to the palm, N/m:
        the cell's compliance there (finger bending, pad compression, jaw guide play, the
        arm's joints or a compliance device / Cartesian impedance control), as one spring on
        the synchronised jaws' common shift along the closing axis. None (the default): the
        jaws are rigid across that axis (a stiff cell, issue 16 item 3). It acts in the grip
        rows' solve (:attr:`~asmplan.sim.fidelity.Fidelity.grip_rows`, while the fit contact
        is solved; :mod:`asmplan.sim.grip_pads`) and Bullet's step holds the shift it leaves
        (the coupling's position target). Sourced figures (docs/physics.md, "The cell's
        lateral compliance"): a stiff cell's is 1e5-1e6 N/m and more; Cartesian impedance
        controllers are configured at 150-4000 N/m.
    """

    pad_size_m: tuple[float, float, float] = (0.02, 0.006, 0.02)
    pad_friction: float = 1.0
    pad_spinning_friction: float | None = None
    max_opening_m: float = 0.08
    finger_mass_kg: float = 0.02
    palm_mass_kg: float = 0.3
    palm_size_m: tuple[float, float, float] = (0.04, 0.11, 0.02)
    palm_gap_m: float = 0.04
    pose_max_force_N: float = 2000.0
    open_max_force_N: float = 20.0
    max_clamp_force_N: float = 200.0
    finger_damping_Nspm: float = 2.0
    closing_speed_mps: float | None = 0.05
    gravity_compensation: bool = True
    synchronised: bool = True
    synchronisation_max_force_N: float = 2000.0
    synchronisation_erp: float = 0.5
    pad_groove_angle_rad: float = 0.0
    pad_groove_depth_m: float = 0.0
    lateral_stiffness_N_per_m: float | None = None

    def __post_init__(self) -> None:
        for label in ("pad_size_m", "palm_size_m"):
            v = np.asarray(getattr(self, label), dtype=float)
            if v.shape != (3,) or np.any(v <= 0) or np.any(~np.isfinite(v)):
                raise ValueError(f"GripperSpec.{label}: expected 3 positive numbers, found {v}")
        for label in (
            "max_opening_m",
            "finger_mass_kg",
            "palm_mass_kg",
            "pose_max_force_N",
            "open_max_force_N",
            "max_clamp_force_N",
            "synchronisation_max_force_N",
        ):
            v = getattr(self, label)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"GripperSpec.{label}: expected > 0, found {v}")
        if not (math.isfinite(self.synchronisation_erp) and 0.0 < self.synchronisation_erp <= 1.0):
            raise ValueError("GripperSpec.synchronisation_erp: expected 0 < erp <= 1, found "
                             f"{self.synchronisation_erp}")
        k_lat = self.lateral_stiffness_N_per_m
        if k_lat is not None and not (math.isfinite(k_lat) and k_lat > 0):
            raise ValueError("GripperSpec.lateral_stiffness_N_per_m: expected > 0 or None, "
                             f"found {k_lat}")
        if self.pad_spinning_friction is not None and not (
            math.isfinite(self.pad_spinning_friction) and self.pad_spinning_friction >= 0
        ):
            raise ValueError(
                f"GripperSpec.pad_spinning_friction: expected >= 0 or None, found "
                f"{self.pad_spinning_friction}"
            )
        for label in ("pad_friction", "palm_gap_m", "finger_damping_Nspm"):
            v = getattr(self, label)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"GripperSpec.{label}: expected >= 0, found {v}")


def pad_torsion_radius_m(width_m: float, height_m: float) -> float:
    """Mean distance of the points of a ``width x height`` rectangle from its centre, m.

    Closed form (mean of ``sqrt(x^2 + y^2)`` over the rectangle); 0.3826 a for a square of
    side a.
    """
    a, b = width_m / 2.0, height_m / 2.0
    d = math.hypot(a, b)
    return (
        2.0 * a * b * d + a**3 * math.log((b + d) / a) + b**3 * math.log((a + d) / b)
    ) / (6.0 * a * b)


def _land_width_m(spec: GripperSpec) -> float:
    """Width of the pad face that touches a flat part: the whole face, or for a grooved pad
    one land beside the groove (a part bridging the groove bears on the two lands)."""
    width = float(spec.pad_size_m[0])
    if spec.pad_groove_depth_m <= 0.0:
        return width
    return width / 2.0 - spec.pad_groove_depth_m * math.tan(0.5 * spec.pad_groove_angle_rad)


def _box_inertia(mass: float, size: np.ndarray) -> tuple[float, float, float]:
    a, b, c = size
    return (mass * (b * b + c * c) / 12, mass * (a * a + c * c) / 12, mass * (a * a + b * b) / 12)


class Gripper:
    """A parallel gripper in a :class:`BulletWorld`.

    Parameters
    ----------
    world : BulletWorld
    spec : GripperSpec
    T_world_tcp : (4, 4) float array
        Initial TCP pose; the pose constraint starts there.
    opening_m : float, optional
        Initial distance between the pad faces (default: fully open). Fingers start in open
        mode, position-controlled to this opening.
    """

    def __init__(
        self,
        world: BulletWorld,
        spec: GripperSpec,
        T_world_tcp: np.ndarray,
        opening_m: float | None = None,
    ) -> None:
        self.world = world
        self.spec = spec
        self._palm_v: np.ndarray | None = None
        self._palm_step = 0
        pad = np.asarray(spec.pad_size_m, dtype=float)
        palm = np.asarray(spec.palm_size_m, dtype=float)
        half_open = spec.max_opening_m / 2.0
        palm_T = np.eye(4)
        palm_z = -(pad[2] / 2.0 + spec.palm_gap_m + palm[2] / 2.0)
        palm_T[2, 3] = palm_z
        palm_piece = ConvexPiece(kind="box", T_part_piece=palm_T, half_extents_m=palm / 2.0)
        spin = (
            pad_torsion_radius_m(_land_width_m(spec), pad[2])
            if spec.pad_spinning_friction is None
            else spec.pad_spinning_friction
        )
        links = []
        for sign in (+1.0, -1.0):
            T = np.eye(4)
            T[1, 3] = sign * (half_open + pad[1] / 2.0)
            links.append(
                LinkSpec(
                    name="finger1" if sign > 0 else "finger2",
                    pieces=pad_pieces(pad, -sign, spec.pad_groove_angle_rad,
                                      spec.pad_groove_depth_m),
                    mass_kg=spec.finger_mass_kg,
                    T_parent_link=T,
                    joint="prismatic",
                    axis=(0.0, -sign, 0.0),
                    inertia_diag_kgm2=_box_inertia(spec.finger_mass_kg, pad),
                    limits=(0.0, half_open),
                    friction=spec.pad_friction,
                    spinning_friction=spin,
                    joint_damping=spec.finger_damping_Nspm,
                )
            )
        self.body = world.add_articulated(
            base_pieces=(palm_piece,),
            base_mass_kg=spec.palm_mass_kg,
            T_world_base=np.asarray(T_world_tcp, dtype=float),
            links=links,
            base_com_m=(0.0, 0.0, palm_z),
            base_inertia_diag_kgm2=_box_inertia(spec.palm_mass_kg, palm),
            name="gripper",
        )
        self._constraint = world.add_pose_constraint(
            self.body, np.asarray(T_world_tcp, dtype=float), spec.pose_max_force_N
        )
        total_kg = spec.palm_mass_kg + 2.0 * spec.finger_mass_kg
        self._lift_N = (-total_kg * world.gravity_mps2).tolist()
        self._mode = "open"
        self._touching = False
        self._touch_step: int | None = None
        self._torque = False
        q0 = self.travel_for_opening(spec.max_opening_m if opening_m is None else opening_m)
        world.reset_joints(self.body, FINGER_LINKS, [q0, q0])
        self._coupling: int | None = None
        if spec.synchronised:
            self._coupling = world.couple_joints(self.body, *FINGER_LINKS,
                                                 spec.synchronisation_max_force_N,
                                                 spec.synchronisation_erp)
        self.command_open(spec.max_opening_m if opening_m is None else opening_m)

    @property
    def coupling(self) -> int | None:
        """The synchronising gear constraint's id (None: floating jaws)."""
        return self._coupling

    # ---------------------------------------------------------------- geometry
    def travel_for_opening(self, opening_m: float) -> float:
        """Joint travel of each finger that leaves ``opening_m`` between the pad faces."""
        if not (0.0 <= opening_m <= self.spec.max_opening_m):
            raise ValueError(
                f"opening_m: expected within [0, {self.spec.max_opening_m}], found {opening_m}"
            )
        return (self.spec.max_opening_m - opening_m) / 2.0

    def finger_travel_m(self) -> np.ndarray:
        """Closing travel of finger 1 and finger 2, (2,) m."""
        return self.world.joint_positions(self.body, FINGER_LINKS)

    def opening_m(self) -> float:
        """Current distance between the pad faces, m."""
        return float(self.spec.max_opening_m - np.sum(self.finger_travel_m()))

    def tcp_pose(self) -> np.ndarray:
        """Measured TCP (palm base frame) pose, (4, 4)."""
        return self.world.pose(self.body)

    @property
    def pose_lead_s(self) -> float:
        """How far ahead along a trajectory to command the pose constraint, s.

        The constraint corrects a fraction ``erp`` of its error per step (PyBullet uses the
        world's ERP for it), so a target moving at speed v is followed ``v dt (1/erp - 1)``
        behind after the step; commanding the pose ``dt (1/erp - 1)`` ahead cancels that lag
        (7 um at 0.2 m/s with BALANCED instead of 0.9 mm).
        """
        fid = self.world.fidelity
        return fid.dt_s * (1.0 / fid.erp - 1.0) if fid.erp > 0 else 0.0

    # ---------------------------------------------------------------- commands
    def command_pose(self, T_world_tcp: np.ndarray) -> None:
        """Move the palm's pose-constraint target to ``T_world_tcp`` (4, 4)."""
        T = np.asarray(T_world_tcp, dtype=float)
        self.command_pose_pq(T[:3, 3], quat_xyzw_from_matrix(T[:3, :3]))

    def command_pose_pq(self, position_m: np.ndarray, quat_xyzw: np.ndarray) -> None:
        """Move the pose-constraint target (position (3,), quaternion xyzw (4,))."""
        self.world.move_pose_constraint(
            self._constraint, position_m.tolist(), quat_xyzw.tolist(), self.spec.pose_max_force_N
        )
        if self.spec.gravity_compensation:
            # The whole gripper's weight, lifted at the palm's centre of mass (the fingers sit
            # symmetrically about it; what remains is a small torque the constraint takes).
            w = self.world
            w.apply_force(self.body, -1, self._lift_N, w.com_position_m(self.body))

    def command_clamp_force(self, force_N: float) -> None:
        """Force mode: each finger pushes toward the centre with ``force_N`` (>= 0), N.

        Until both pads touch something, the fingers close under velocity control at
        ``spec.closing_speed_mps`` with the motor force bounded by ``force_N`` (a real gripper
        does not slam its fingers shut); from then on (until :meth:`command_open`) the motors
        are off and the joints get ``force_N`` exactly (TORQUE_CONTROL).
        """
        if not (math.isfinite(force_N) and 0.0 <= force_N <= self.spec.max_clamp_force_N):
            raise ValueError(
                f"clamp force: expected within [0, {self.spec.max_clamp_force_N}] N, found {force_N}"
            )
        v = self.spec.closing_speed_mps
        if v is not None and not self._touching:
            # Closing: speed-limited, force-limited velocity control until both pads touch.
            self._touching = all(
                self.world.contact_count(self.body, link_a=link) > 0 for link in FINGER_LINKS
            )
            if self._touching:
                self._touch_step = self.world.step_count
        if v is None or self._touching:
            if self._mode != "force" or not self._torque:
                self.world.disable_motors(self.body, FINGER_LINKS)
                self._torque = True
            # one call per step: PyBullet adds repeated TORQUE_CONTROL forces within a step
            f = force_N * self._touch_ramp()
            w = 0.0 if self.spec.synchronised else 0.5 * self._finger_load_along_closing_N()
            self.world.set_joint_forces(self.body, FINGER_LINKS, (f + w, f - w))
        else:
            self.world.set_joint_velocity_targets(
                self.body, FINGER_LINKS, self._approach_speeds_mps(v), (force_N, force_N)
            )
            self._torque = False
        self._mode = "force"

    def _touch_ramp(self) -> float:
        """Fraction (0..1] of the commanded squeeze applied: it rises linearly over
        :data:`TOUCH_RAMP_S` after the pads first touch in a clamp.

        Bullet's first contact between a pad and a round part is ONE point (GJK's closest
        point; the line contact fills in over the next steps). With the full force at once,
        the two pads' single points at opposite ends of a 10 mm pin made a couple that
        tipped it by ~6 mrad in one 1 ms step: 60-75 um of pad penetration.

        Only in millimetre units (BALANCED, ACCURATE). In metres (FAST) Bullet creates the pad
        contacts up to ~0.3 mm before the pads touch, so the contact set is there at the
        touch, and a ramp only weakens the grip at the impact (1/240 s: a pad closes 0.2 mm
        per step): gear_unit's shaft turned 10.8 deg in the grip with a 10 ms ramp, 4.5 deg
        with 42 ms, 0 without."""
        fid = self.world.fidelity
        if self._touch_step is None or fid.bullet_units_per_m == 1.0:
            return 1.0
        dt = fid.dt_s
        return min(1.0, (self.world.step_count - self._touch_step + 1) * dt / TOUCH_RAMP_S)

    def _approach_speeds_mps(self, v: float) -> tuple[float, float]:
        """Closing speed of each finger for the next step: ``v``, but never farther than the
        pad's gap to what lies ahead of it (:meth:`BulletWorld.gap_m` along its closing
        direction), so that a pad arrives touching instead of inside the part.

        Bullet creates a contact only within the pair's breaking distance (25 um at
        BALANCED, in millimetre units); a pad closing at 50 mm/s moves 50 um per 1 ms step,
        so it entered the part before the solver saw the contact: 24 um at first contact,
        then up to 109 um as the one-point contacts at opposite ends of the two pads tipped
        a 10 mm pin (bench pin insertion: 68-70 um of "fit" penetration, all of it at the
        pads; 15-35 um in metre units, whose breaking distance is ten times larger). The
        arrival is as fast as before (the last step covers the remaining gap plus the
        preset's contact slop).

        Synchronised jaws move as one: both get the smallest of these speeds among the pads
        that do not touch yet (a pad already on the part pushes it, as a real synchronised
        gripper shoves an off-centre part toward its centre line)."""
        w = self.world
        dt = w.fidelity.dt_s
        R = self.tcp_pose()[:3, :3]
        look = 2.0 * v * dt
        # ... plus the contact slop: some pairs (box on box) report a contact only once they
        # overlap, so the pad must end its last step that little inside
        slop = w.fidelity.contact_slop_m
        out, gaps = [], []
        for link, sign in zip(FINGER_LINKS, (1.0, -1.0), strict=True):
            gap = w.gap_m(self.body, link, look, direction=R @ np.array([0.0, -sign, 0.0]))
            gaps.append(gap)
            out.append(v if not math.isfinite(gap) else min(v, (max(gap, 0.0) + slop) / dt))
        if self.spec.synchronised:
            free = [s for s, gap in zip(out, gaps, strict=True) if not gap <= slop]
            common = min(free) if free else min(out)
            return common, common
        return out[0], out[1]

    def _finger_load_along_closing_N(self) -> float:
        """Floating jaws only: the fingers' own weight and inertia along the TCP's +y axis,
        ``2 m_f (g - a_palm) . y`` (palm acceleration over the last step), N, split +W/2 on
        finger 1 and -W/2 on finger 2 so the empty pair does not slide downhill (the model
        before synchronised jaws, kept as it was: the scenes of the stored interference
        resolutions, ``bench/scenarios.py`` ``PinHole``, were measured with it)."""
        w = self.world
        v = w.velocity(self.body)[0]
        step = w.step_count
        a = np.zeros(3)
        if self._palm_v is not None and step > self._palm_step:
            a = (v - self._palm_v) / ((step - self._palm_step) * w.fidelity.dt_s)
        self._palm_v, self._palm_step = v, step
        y_world = self.tcp_pose()[:3, 1]
        return float(2.0 * self.spec.finger_mass_kg * ((w.gravity_mps2 - a) @ y_world))

    def command_open(self, opening_m: float | None = None) -> None:
        """Open mode: position-control both fingers to ``opening_m`` (default fully open)."""
        q = self.travel_for_opening(self.spec.max_opening_m if opening_m is None else opening_m)
        if self._mode == "force":
            self.world.set_joint_forces(self.body, FINGER_LINKS, (0.0, 0.0))
        self.world.set_joint_position_targets(
            self.body,
            FINGER_LINKS,
            (q, q),
            (self.spec.open_max_force_N, self.spec.open_max_force_N),
            position_gain=0.2,
            velocity_gain=1.0,
        )
        self._mode = "open"
        self._touching = False
        self._touch_step = None
        self._torque = False

    @property
    def squeeze_settled(self) -> bool:
        """Force mode with the commanded squeeze fully applied (the fingers under joint
        force, the touch ramp over): :mod:`asmplan.sim.carry_hold` waits for it."""
        return self._mode == "force" and self._torque and self._touch_ramp() >= 1.0

    @property
    def mode(self) -> str:
        """"force" or "open"."""
        return self._mode


class CoupledGripper(Gripper):
    """The pipeline's gripper: a synchronised :class:`Gripper` (its jaws coupled like a rack
    and pinion, :attr:`GripperSpec.synchronised`) that opens to the grasp's opening rather
    than its full stroke.

    Parameters
    ----------
    world, spec, T_world_tcp, opening_m
        As for :class:`~asmplan.sim.gripper.Gripper`; ``opening_m`` is also the opening of
        every open phase (approach, retreat), as planned.
    """

    def __init__(
        self,
        world: BulletWorld,
        spec: GripperSpec,
        T_world_tcp: np.ndarray,
        opening_m: float | None = None,
    ) -> None:
        if not spec.synchronised:
            raise ValueError("CoupledGripper: expected a synchronised GripperSpec, found "
                             "synchronised=False")
        self._open_default = opening_m
        super().__init__(world, spec, T_world_tcp, opening_m)

    def command_open(self, opening_m: float | None = None) -> None:
        """Open mode at ``opening_m`` (default: the opening given at construction)."""
        super().command_open(self._open_default if opening_m is None else opening_m)
