"""Simulation fidelity: every costly physics knob in one typed, documented object.

A :class:`Fidelity` is passed explicitly to :class:`asmplan.sim.bullet.BulletWorld` and to
:func:`asmplan.sim.execute.execute_step`. Three presets trade accuracy for cost:

========== ======== ========= ========== ======= ===================================
preset     dt_s     iters     slop (m)   cone    geometry / use
========== ======== ========= ========== ======= ===================================
FAST       1/240    50        1e-5       on      "coarse", static partners; screening
BALANCED   1/1000   100       1e-6       on      "convex"; default
ACCURATE   1/4000   200       1e-6       on      "exact"; tight fits, final proof
========== ======== ========= ========== ======= ===================================

``min_resolvable_clearance_m`` is the smallest DIAMETRAL clearance c_d (hole diameter minus
pin diameter) of a clearance fit that a preset judges as capture geometry does (issue 17).
Measured through the whole pipeline (:mod:`bench.fits`, ``asmplan bench --sections fits``):
a steel pin planned and inserted by the gripper into a fixtured steel block, both
UNCHAMFERED (so the capture boundary |e| < c_d / 2 is the fit's own), at the planner's
insertion speed, with a robot pose error e across the axis; the step must SUCCEED with
e = 0 and e = c_d / 4 and STOP ON THE RIM with e = c_d (twice the capture radius):

* FAST: rim at c_d = 2 mm; 1 mm, 0.4 mm and 0.1 mm were inserted 1x c_d off (its rims are
  rounded by 0.41-0.73 mm in metre units) -> 2 mm.
* BALANCED: right at 4 um (6 mm pin), 5 um (6 and 20 mm), 10 um (8 mm); at 2 um the pin
  went in 2 um off (1 um overlap: the contact slop) -> 4 um.
* ACCURATE: right at 4 um (6 mm pin) -> 4 um (finer values not measured).

Below it a clearance fit's capture (and with it rim stops and jams) is not resolved, so
:func:`asmplan.sim.step_warnings.clearance_warnings` flags such fits, a success there means "went in
at this preset's resolution", and a step that stops on such a fit inside its capture boundary
is reported as "not resolved at <preset>" with the preset that resolves it, not as jammed
(:mod:`asmplan.sim.resolution`, which also covers FAST's pad creep, ``grip_creep``, and its
impact penetration, ``impact_penetration_m``). What makes BALANCED resolve
micrometres is the millimetre world (rims rounded by 1 um, EPA exact to 1 um) together with
the contact distance (``contact_distance_m``): a contact is created that far before two
bodies touch, so a part approaching at v finds the rim before it penetrates when
v dt < ``contact_distance_m`` (10 um per step at the planner's 10 mm/s and 1/1000 s, against
25 um); :func:`asmplan.sim.execute.scene_warnings` flags steps that approach faster.

``interference_resolution_m`` is the older, different figure: the smallest interference a
preset tells from a fit by rigid contact alone (an interference of c_d / 2 radial must stay
blocked at the mouth of a 10 mm hole; FAST 0.4 mm, BALANCED 0.05 mm, ACCURATE 0.02 mm,
docs/physics.md). Press fits are simulated at that clearance with their predicted press force
(:mod:`asmplan.sim.press`), and the world's contact distance is half of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..parts.pieces import LevelOfDetail

_LODS = ("exact", "convex", "coarse")
CONSTRAINT_SOLVERS = ("sequential_impulse", "dantzig")
"""Values of :attr:`Fidelity.constraint_solver`."""


@dataclass(frozen=True)
class Fidelity:
    """Physics settings of one simulation run.

    Parameters
    ----------
    name : str
        Preset name (free text for custom settings).
    dt_s : float
        Physics time step, s. Use <= 1/1000 s for fits <= 0.1 mm; at 1/240 s an impact
        penetrates ~1-2 mm and jams are missed.
    solver_iterations : int
        Sequential-impulse solver iterations per step (``numSolverIterations``).
    contact_slop_m : float
        Allowed penetration before position correction (``contactSlop``), m. 1e-6 for tight
        fits (PyBullet's default 1e-5 lets parts sink ~10 um).
    erp : float
        Error reduction parameter for joints and constraints (0..1).
    contact_erp : float
        Error reduction parameter for contacts (0..1).
    friction_erp : float
        Error reduction parameter for friction anchors (0..1).
    cone_friction : bool
        Use the friction cone (``enableConeFriction``). PyBullet applies torsional (spinning)
        friction ONLY with the cone on. Without torsion a two-finger grip pivots about the
        closing axis (the solver loads one corner of the pad) and needs up to twice
        ``m (g + a) / (2 mu)``; with the cone and the pads' torsional friction
        (:class:`~asmplan.sim.gripper.GripperSpec`) the measured threshold is within 1 %.
    spinning_friction : float
        Torsional friction coefficient (m) given to parts by default; PyBullet combines it
        as ``s_a mu_b + s_b mu_a``. 0 leaves torsion to the gripper pads.
    collision_margin_m : float
        Collision margin of convex-hull pieces, m. 0 keeps hulls exact (PyBullet's default of
        1 mm inflates them and closes sub-millimetre holes). Boxes/spheres keep margins inside.
    geometry_lod : {"exact", "convex", "coarse"}
        Which :class:`~asmplan.parts.pieces.CollisionModel` level the caller should feed.
    record_every_steps : int
        Record tick: one record row every this many physics steps (commands are applied
        every step). The peak criteria (insertion force, penetration) are sampled at the
        rate of ``asmplan.sim.execute.PEAK_SAMPLE_DT_S`` whatever this value; slip, drop
        and the clamp-force error are judged on the rows. FAST: 4 (60 rows/s); on
        pinhole_station against 1: same outcomes, final errors and peak criteria, slip
        within 0.1 um, clamp-force MAE within 0.0002 N, peak clamp force within 0.04 N of
        2.5-6.9 N.
    min_resolvable_clearance_m : float
        Smallest diametral clearance of a clearance fit this preset judges right (capture,
        rim stop; see the module docstring), m.
    interference_resolution_m : float
        Smallest diametral interference this preset blocks by rigid contact (see the module
        docstring), m: press fits are simulated at this clearance
        (:func:`asmplan.sim.press.press_clearance_m`).
    dynamic_partners : bool
        Parts already in place that the held part mates with or touches are dynamic bodies
        (True: the insertion pushes a real body, which rests on its supports) or static
        (False: an immovable partner; no supports are needed and the partner's resting
        contacts leave the solver). FAST: False (on pinhole_station the simulation takes
        ~40 % less time with the same verdicts); BALANCED and ACCURATE: True.
        ``SceneSettings.dynamic_partners`` overrides it.
    friction_anchor : bool
        PyBullet's friction anchors (``changeDynamics(frictionAnchor=1)``) on the links of
        articulated bodies, i.e. the gripper's fingers: a contact with a pad is held at its
        anchor point while it sticks instead of drifting a little in every solver step.
        FAST: True. Without them a 50 g POM block held at 2.2x the Coulomb force crept
        1.1-5.9 mm down the pads over a 5-12 s FAST cycle (generated products); with them
        < 0.01 mm. The slip threshold against m (g + a) / (2 mu) is unchanged (-0.20 %) and
        the seed clamp-force error falls (0.37 -> 0.16 mN). BALANCED and ACCURATE: False;
        their pads crept little without anchors, and with them a part seated by the
        position-controlled gripper got the pads' full friction as extra seating force
        (peg_in_hole at BALANCED: 62 N against its 50 N limit). Parts never get anchors: on
        every body they also stick pins in their holes.
    carry_anchor : bool
        Friction anchors on the fingers only while the part is clamped and carried: on when
        "clamp" begins, off at the part's first contact with a body other than the gripper
        in "lower" (its set-down or insertion contact). The pipeline
        (:func:`asmplan.sim.simulate.simulate_step`) passes it to
        :func:`asmplan.sim.execute.execute_step` (``carry_anchor``); scenes that call
        ``execute_step`` themselves (the bench's PinHole) choose. No effect when
        ``friction_anchor`` is True. BALANCED: True. Without anchors a part clamped while it
        still stands on its support (pads and tray both holding it) creeps in the pads at
        ~1 mrad/s about the closing axis: the fits bench's 6 mm pin left the grip tilted
        0.115 mrad, its tip 1.2 um off the TCP along the pad face, and a pin 5 um off a 5 um
        fit arrived 4.23 um off and went in (capture geometry: rim stop); with them it
        arrives within 0.0002 mrad and 0.01 um and stops on the rim. Anchors for the whole
        step pass the palm's push on at the set-down (a 1 m bar met the table with 56.7 N
        against its 42.4 N limit); switched off when "lower" begins the pneumatic piston rod
        crept 573 um / 13.6 mrad in the pads in free air and jammed. ACCURATE: False (not
        measured).
    bullet_units_per_m : float
        Bullet length units per metre (:mod:`asmplan.sim.bullet` converts at its boundary).
        Bullet's collision code has absolute tolerances made for metre-sized bodies: GJK
        treats support points within 1e-2 units as one (every vertex of a small hull within
        1 cm of another, in metres), and primitive shapes keep a margin of 1e-3 units inside
        them that rounds every edge and rim. BALANCED and ACCURATE simulate in millimetres
        (1000): rims rounded by 1 um instead of 1 mm, GJK exact to 10 um of vertex spacing.
        FAST keeps metres (1.0): its resolvable clearance is 0.4 mm, and at 1/240 s a body
        steps 0.4 mm into a contact, which the 1 mm margin absorbs (in millimetres a FAST pin
        entered a hole's wall by 2-3 mm).
    constraint_solver : {"sequential_impulse", "dantzig"}
        Bullet's constraint solver. "sequential_impulse" (every preset): projected
        Gauss-Seidel, ``solver_iterations`` sweeps per step. It does not converge where two
        contact normals nearly oppose each other, as in a peg wedged at a small tilt (the
        contact matrix's condition number grows as 4 / t^2, 52,000 at 0.5 deg): the unresolved
        push leaves 5-27 um of penetration across the wedge, which Whitney's geometry
        magnifies by 1 / sin t into +0.07 mm (5 deg) to +3.3 mm (0.5 deg) of jam depth at
        BALANCED. "dantzig": Bullet's direct MLCP solver (``CONSTRAINT_SOLVER_LCP_DANTZIG``),
        exact to the contact slop on that wedge, but its box friction does not hold a part in
        a two-finger grip the way the cone does (slip threshold +11.5 %, a gripped pin dropped
        during a BALANCED insertion): a reference for contact geometry, not a preset's choice
        (docs/physics.md, "Jam depth at small tilts").
    rest_window_s : float
        Bodies at rest that no moving body can reach sleep (:mod:`asmplan.sim.rest`): a
        dynamic body (not the gripper, not the part while carried) that moved less than
        ``rest_displacement_m`` over the last ``rest_window_s`` and has no moving body within
        1 mm is skipped by the solver until something comes near. 0 turns it off (FAST: its
        partners are static, and its metre units put the sleep residual above Bullet's
        wake threshold). BALANCED and ACCURATE: 0.1 s. On pinhole_station at BALANCED the
        CPU time in the physics steps fell from 12.2 to 9.8 s with the same verdicts and
        final errors within 3.1 um (docs/physics.md, "Sleeping bodies at rest").
    rest_displacement_m : float
        Largest displacement (m; and that over 10 mm as a rotation) over ``rest_window_s``
        of a body at rest: 1 um at BALANCED and ACCURATE (the contact slop), i.e. a body
        creeping slower than 10 um/s is held where it is.
    feature_contact : bool
        Exact feature-level contact for the held part's cylindrical fits during the insertion
        (:mod:`asmplan.sim.feature_contact`): for the whole step Bullet's contact between the
        held part and its mate partners is off and the pin in its bore is solved on the
        declared geometry (diameters as built, chamfers, depth), exactly in the wedge.
        BALANCED and ACCURATE: True; FAST: False (coarse on purpose, unchanged).
    grip_creep : bool
        The preset's pads may creep under a load the grip holds, so a slip, turn or drop of a
        part whose planned clamp holds it (:mod:`asmplan.sim.resolution`) is not resolved.
        FAST: True: gear_unit's 49 g shaft, held with a 6x torsion margin (the moment of its
        weight and acceleration 0.019 N m against the pads' 0.114 N m), turned 1.0 deg in the
        pads over its carry at 1/240 s, 2.3 deg (and slipped out) at 1/720 s, 0.83 deg at
        1/960 s and 0.03 deg at 1/480 s: not converging in the time step. BALANCED and
        ACCURATE: False (their slips are judged).
    impact_penetration_m : float
        Penetration the preset's solver leaves at an impact, m: a failed penetration
        criterion within it is not resolved (:mod:`asmplan.sim.resolution`). FAST: 2 mm (at
        1/240 s in metres an impact penetrates 1-2 mm, ``dt_s``; gear_unit's shaft 1.54 mm).
        BALANCED and ACCURATE: 0 (every penetration above the criterion is a failure).
    partner_hold_fraction : float
        Dynamic mate partners held static under a load check
        (:mod:`asmplan.sim.partner_hold`): after the step's first physics step each group of
        partners resting on static supports is made immovable, and at every peak sample
        (``asmplan.sim.execute.PEAK_SAMPLE_DT_S``) the loads of the held part, the gripper
        and the exact fit contact on it are checked against this share of its support's
        friction (mu x (weight + push)) and of its weight's restoring moment about every
        edge of its bearing polygon; the first sample beyond either gives the group its
        mass back, from rest, to the end of the step. 0 turns it off. BALANCED: 0.5 (on
        pinhole_station part3's and part4's steps 3.5 -> 2.6 s of CPU each, the job 12.98 ->
        11.73 s; same verdicts, final errors within 0.01 um: docs/physics.md, "Mate partners
        held static under a load check"). FAST: 0 (its partners are static throughout).
        ACCURATE: 0 (not measured; the final proof keeps every partner dynamic). The same
        fraction lets the placed part be held static while the pads are still on it in
        "release" (:mod:`asmplan.sim.placed_hold`; with 0 it is held only once the gripper
        does not touch it; the placed hold is on wherever ``rest_window_s`` > 0).
    carry_hold_fraction : float
        A carried part stuck to the palm (:mod:`asmplan.sim.carry_hold`; the pipeline applies
        it on grooved pads, whose Bullet contact does not hold a part): in the lift, the
        transfer and the lowering, while the part touches nothing but the pads and its load
        (weight and inertia of the part moving with the commanded gripper pose) uses at most
        this share of the grip's analytic capacity (the planner's hold criterion for that
        load, :mod:`asmplan.planner.grasp_capacity`), it is kept at its pose relative to the
        palm (free along the closing axis; put back every 4 ms; on flat pads from when it
        rests in them, :mod:`asmplan.sim.carry_hold`); the first contact with anything
        else, the first load sample beyond the share or the end of the held phases hands it
        back to Bullet's pad contact. 0 turns it off. BALANCED: 0.75 (ratio 1 is where the
        analytic grip just holds; the criterion leaves out the pads' friction couple across
        the grip; the gearbox shaft on prism jaws peaks at 0.54 over its transfer and is
        carried within 0.78 mrad instead of turning 8-66 mrad, at half the clamp it is
        handed back at 0.75 and turns as before: docs/physics.md, "A carried part stuck to
        its pads"). FAST and ACCURATE: 0 (not measured).
    grip_rows : bool
        A synchronised gripper's pad normals and friction as rows of the exact fit contact's
        solve, acting on the part and the fingers (:mod:`asmplan.sim.grip_pads`); off: the
        pads take only their friction's share (floating jaws always). ACCURATE: on (its 0.5 deg
        tilted 8 mm / 10 um and 12 mm / 25 um fits jam at 1.117 / 2.704 mm, Whitney 1.181 /
        2.917, instead of going in). BALANCED: off, measured: with the rows the bundled peg
        0.05 mm off along the closing axis jams at 9.709 mm with 3.6 mm of slip in the grip
        (tests/sim/test_sweep_nominal.py; tests/sim/test_sweep.py's pose sweep likewise).
        Traced (docs/physics.md, "Why the rows fail the chamfered peg at BALANCED"): the
        rows make the jaws rigid across the closing axis, so the offset beyond c/2 has
        nowhere to go (the pin pivots in the pads and jams at the rigid-jaw depth, 9.682 mm;
        with the friction converged, and at ACCURATE, it stays on the chamfer); without
        them Bullet's pads absorb it by 27-92 um of penetration (and tests/sim/test_sweep.py's
        loose peg 0.3 mm off along the axis goes in with the rows, where it asserts a
        failure). Open: the cell's lateral compliance. Fixed: the rows' friction, a cone per
        pad point, let the pin 0.05 mm off across the axis slide 1.2 mm in the pads at no
        fit load (now shared per pad, :func:`~asmplan.sim.grip_pads.pad_friction_caps`).
        Cost at BALANCED: +24 % CPU of the seed job. FAST: no fit contact.
"""

    name: str
    dt_s: float
    solver_iterations: int
    contact_slop_m: float
    erp: float
    contact_erp: float
    friction_erp: float
    cone_friction: bool
    spinning_friction: float
    collision_margin_m: float
    geometry_lod: LevelOfDetail
    record_every_steps: int
    min_resolvable_clearance_m: float
    interference_resolution_m: float
    dynamic_partners: bool = True
    friction_anchor: bool = False
    carry_anchor: bool = False
    bullet_units_per_m: float = 1000.0
    constraint_solver: str = "sequential_impulse"
    rest_window_s: float = 0.0
    rest_displacement_m: float = 1e-6
    feature_contact: bool = False
    grip_creep: bool = False
    impact_penetration_m: float = 0.0
    partner_hold_fraction: float = 0.0
    carry_hold_fraction: float = 0.0
    grip_rows: bool = False

    def __post_init__(self) -> None:
        def positive(label: str, value: float) -> None:
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"Fidelity.{label}: expected a finite value > 0, found {value}")

        def nonneg(label: str, value: float) -> None:
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"Fidelity.{label}: expected a finite value >= 0, found {value}")

        positive("dt_s", self.dt_s)
        if self.dt_s > 0.05:
            raise ValueError(f"Fidelity.dt_s: expected <= 0.05 s, found {self.dt_s}")
        if int(self.solver_iterations) != self.solver_iterations or self.solver_iterations < 1:
            raise ValueError(
                f"Fidelity.solver_iterations: expected an integer >= 1, found "
                f"{self.solver_iterations}"
            )
        nonneg("contact_slop_m", self.contact_slop_m)
        for label in ("erp", "contact_erp", "friction_erp"):
            v = getattr(self, label)
            if not (0.0 <= v <= 1.0):
                raise ValueError(f"Fidelity.{label}: expected a value in [0, 1], found {v}")
        nonneg("spinning_friction", self.spinning_friction)
        nonneg("collision_margin_m", self.collision_margin_m)
        positive("bullet_units_per_m", self.bullet_units_per_m)
        if self.constraint_solver not in CONSTRAINT_SOLVERS:
            raise ValueError(
                f"Fidelity.constraint_solver: expected one of {list(CONSTRAINT_SOLVERS)}, found "
                f"{self.constraint_solver!r}"
            )
        if self.geometry_lod not in _LODS:
            raise ValueError(
                f"Fidelity.geometry_lod: expected one of {list(_LODS)}, found "
                f"{self.geometry_lod!r}"
            )
        if int(self.record_every_steps) != self.record_every_steps or self.record_every_steps < 1:
            raise ValueError(
                f"Fidelity.record_every_steps: expected an integer >= 1, found "
                f"{self.record_every_steps}"
            )
        positive("min_resolvable_clearance_m", self.min_resolvable_clearance_m)
        positive("interference_resolution_m", self.interference_resolution_m)
        nonneg("rest_window_s", self.rest_window_s)
        if not 0.0 <= self.partner_hold_fraction <= 1.0:
            raise ValueError(f"Fidelity.partner_hold_fraction: expected a value in [0, 1], "
                             f"found {self.partner_hold_fraction}")
        if not 0.0 <= self.carry_hold_fraction <= 1.0:
            raise ValueError(f"Fidelity.carry_hold_fraction: expected a value in [0, 1], "
                             f"found {self.carry_hold_fraction}")
        positive("rest_displacement_m", self.rest_displacement_m)
        nonneg("impact_penetration_m", self.impact_penetration_m)

    @property
    def record_dt_s(self) -> float:
        """Time between two record rows, s."""
        return self.dt_s * self.record_every_steps

    @property
    def contact_distance_m(self) -> float:
        """Contact creation and breaking distance of the world, m: half
        ``interference_resolution_m`` (see the class docstring)."""
        return 0.5 * self.interference_resolution_m



FAST = Fidelity(
    name="fast",
    dt_s=1.0 / 240.0,
    solver_iterations=50,
    contact_slop_m=1e-5,
    erp=0.2,
    contact_erp=0.2,
    friction_erp=0.2,
    cone_friction=True,
    spinning_friction=0.0,
    collision_margin_m=0.0,
    geometry_lod="coarse",
    record_every_steps=4,
    min_resolvable_clearance_m=2e-3,
    interference_resolution_m=0.4e-3,
    dynamic_partners=False,
    friction_anchor=True,
    bullet_units_per_m=1.0,
    grip_creep=True,
    impact_penetration_m=2e-3,
)

BALANCED = Fidelity(
    name="balanced",
    dt_s=1.0 / 1000.0,
    solver_iterations=100,
    contact_slop_m=1e-6,
    erp=0.2,
    contact_erp=0.2,
    friction_erp=0.2,
    cone_friction=True,
    spinning_friction=0.0,
    collision_margin_m=0.0,
    geometry_lod="convex",
    record_every_steps=4,
    carry_anchor=True,
    min_resolvable_clearance_m=4e-6,
    interference_resolution_m=0.05e-3,
    rest_window_s=0.1,
    feature_contact=True,
    partner_hold_fraction=0.5,
    carry_hold_fraction=0.75,
)

ACCURATE = Fidelity(
    name="accurate",
    dt_s=1.0 / 4000.0,
    solver_iterations=200,
    contact_slop_m=1e-6,
    erp=0.2,
    contact_erp=0.2,
    friction_erp=0.2,
    cone_friction=True,
    spinning_friction=0.0,
    collision_margin_m=0.0,
    geometry_lod="exact",
    record_every_steps=16,
    min_resolvable_clearance_m=4e-6,
    interference_resolution_m=0.02e-3,
    rest_window_s=0.1,
    feature_contact=True,
    grip_rows=True,
)

PRESETS: dict[str, Fidelity] = {f.name: f for f in (FAST, BALANCED, ACCURATE)}


def preset(name: str) -> Fidelity:
    """The preset called ``name`` ("fast", "balanced" or "accurate", case-insensitive).

    Raises
    ------
    ValueError
        For an unknown name, listing the known ones.
    """
    key = str(name).strip().lower()
    if key not in PRESETS:
        raise ValueError(f"unknown fidelity preset {name!r}; expected one of {sorted(PRESETS)}")
    return PRESETS[key]
