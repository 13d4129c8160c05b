"""Benchmarks of asmplan: accuracy vs cost of the physics presets, planning, scaling, culling
and sweep throughput; the library behind ``asmplan bench``.

Every measurement is a function returning typed, frozen results; formatting to Markdown and
the accuracy assertions (:data:`BOUNDS`, :func:`check_bounds`) are separate. Time is measured
and reported, never asserted: the machine is shared and noisy.

Accuracy scenarios (the physics validation scenes of ``tests/sim``, defined once in
:mod:`bench.scenarios`):

* seed clamp cycle: an 80 g box through the seed paper's 4 s clamp-lift-translate-lower-release
  cycle; figure = mean absolute error between measured and commanded clamp force over the
  clamped phases (hold..lower);
* slip threshold: bisection of the smallest clamp force that lifts a 100 g box at 2 m/s^2
  without slipping; figure = relative error against ``m (g + a) / (2 mu)``;
* pin insertion: a 10 mm steel pin pushed into a 20 mm deep blind hole (8-sided exact hole,
  no chamfer) at radial clearance c (fit) and -c (interference), c = 0.2 and 0.025 mm;
  figures = outcome mismatch and depth error against a converged reference run (ACCURATE with
  a 16x smaller time step, 1/16000 s) and the largest contact penetration of the fits.
"""

from __future__ import annotations

import dataclasses
import io
import itertools
import math
import os
import platform
import statistics
import subprocess
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

from asmplan.commands.bench import SCALING_SIZES

PAPER_MAE_N = 0.03
"""Mean clamp-force error the seed paper reports between prediction and measurement, N."""

REFERENCE_DT_S = 1.0 / 16000.0
"""Time step of the converged reference insertion runs (ACCURATE settings otherwise), s."""
INSERTION_CLEARANCES_M: tuple[float, ...] = (0.2e-3, 0.025e-3)
"""Radial clearances of the insertion scenarios (each run as fit +c and interference -c), m."""
SEED_RUNS = 9
SEED_REPORT_RUNS = 3
"""Repetitions of the seed workstation at BALANCED with the report (each ~10 s of CPU)."""
"""Repetitions of each seed-workstation timing (medians are reported)."""
CULLING_SIZE = 50
SCALING_FIT_MM = 0.5
"""Diametral clearance of every pin of the generated scaling products, mm: above FAST's
``interference_resolution_m`` (0.4 mm; its clearance-fit resolution is 2 mm, so these runs
warn at FAST; the generator's default H7/g6, 4-24 um, is within BALANCED's 4 um)."""


# ---------------------------------------------------------------------------------------------
# bounds


@dataclass(frozen=True)
class Bound:
    """The documented limit of one accuracy figure at one preset (``|value| <= limit``)."""

    figure: str
    preset: str
    limit: float
    unit: str
    reason: str


def _bounds() -> tuple[Bound, ...]:
    out = []
    for p in ("fast", "balanced", "accurate"):
        out.append(Bound("seed_force_mae_N", p, 0.005, "N",
                         "MAE <= 0.03 N as in the paper, by construction: the fingers are "
                         "force-controlled, so measured equals commanded (<= 0.0004 N at every "
                         "preset); the planner's predicted profile is compared with the "
                         "paper's Table 4 in seed_profile_error_N"))
        out.append(Bound("slip_threshold_error", p, 0.03, "",
                         "a = 0, 5, 20 m/s^2 (and 2 in tests): measured -1.4 to +0.4 % "
                         "(docs/physics.md); 3 % = 5 bisection steps of 0.6 %, well inside the "
                         "10 % the slip tests allow"))
        out.append(Bound("insertion_outcome_mismatch", p, 0.0, "",
                         "a fit at or above the preset's interference_resolution_m must be "
                         "judged as the reference judges it (sim/fidelity.py)"))
    out += [
        Bound("insertion_depth_error_m", "fast", 0.6e-3, "m",
              "FAST does not resolve a 0.2 mm radial interference (its contact penetrates "
              "1.8-3.8 mm while pushed; the outcome, not inserted, is right): the pin stops "
              "0.50 mm in (0.30 mm before the pads closed without impact, issue 16), against "
              "the reference's 0.001 mm; 0.6 mm = 1.2x that"),
        Bound("insertion_depth_error_m", "balanced", 0.3e-3, "m",
              "0.01 mm at 0.2 mm interference; at BALANCED's resolution limit (0.025 mm radial "
              "interference) the pin enters 0.2 mm deeper than in the reference (1.0 mm of 20 "
              "in docs/physics.md's sweep)"),
        Bound("insertion_depth_error_m", "accurate", 0.02e-3, "m",
              "ACCURATE penetrates 3-10 um; 2x the worst measured"),
        Bound("fit_penetration_m", "fast", 0.5e-3, "m",
              "measured 0.15-0.25 mm; 0.5 mm is the success criteria's penetration limit"),
        Bound("fit_penetration_m", "balanced", 0.05e-3, "m",
              "measured 4-28 um (the largest: the released pin dropping 0.2 mm onto the hole "
              "floor); the 68-70 um of session 4 were the pads closing into the pin, fixed "
              "(docs/physics.md, 'Fit penetration')"),
        Bound("fit_penetration_m", "accurate", 0.02e-3, "m",
              "measured 3-10 um (docs/physics.md)"),
    ]
    out.append(Bound("jam_depth_exact_solver_error_m", "balanced", 0.1e-3, "m",
                     "issue 16: the jam scene with Bullet's direct solver at BALANCED's time "
                     "step, slop 0.1 um: Whitney's l* within 0.1 mm at every tilt 0.5-5 deg for "
                     "c >= 0.05 mm (measured |error| <= 0.066 mm): proves the scene and the "
                     "geometry; the preset's own error at small tilts is its iterative solver"))
    for p in ("balanced", "accurate"):
        out.append(Bound("jam_depth_error_m", p, 0.1e-3, "m",
                         "issue 16: Whitney's l* = (D - d cos t) / sin t within 0.1 mm for "
                         "c >= 0.05 mm at 5 deg (millimetre units; smaller tilts are reported, "
                         "not asserted: the solver's contact compliance, ~20 um across the "
                         "wedge, grows as 1 / sin t)"))
        out.append(Bound("fit_verdict_mismatch", p, 0.0, "",
                         "issue 17: a clearance fit at or above the preset's "
                         "min_resolvable_clearance_m is judged as capture geometry and the "
                         "reference judge it (bench/fits.py)"))
        out.append(Bound("rim_capture_mismatch", p, 0.0, "",
                         "capture boundary |e0| < c/2 + chamfer width: an unchamfered pin "
                         "0.5 mm off stays on the rim, 0.02 mm off goes in"))
    for p in ("fast", "balanced", "accurate"):
        out.append(Bound("held_drift_m", p, 0.1e-3, "m",
                         "issue 16: the held part's travel along the closing axis over the "
                         "seed cycle, closing axis horizontal, 0.1 rad and vertical; measured "
                         "<= 0.015 mm"))
    return tuple(out)


BOUNDS: tuple[Bound, ...] = _bounds()
"""The documented accuracy bounds asserted by ``asmplan bench`` (quick and full)."""


# ---------------------------------------------------------------------------------------------
# scenarios (the physics validation scenes of tests/sim)


SLIP_ACCELS_MPS2: tuple[float, ...] = (0.0, 5.0, 20.0)
"""Vertical accelerations of the slip-threshold scenes (issue 16): 0 = held still in the air
after a slow lift (:func:`bench.scenarios.hold_slip_m`), 5 and 20 = lifted off the table
(:func:`bench.scenarios.lift_profile`)."""


def slip_threshold_error(fidelity: Any, accel_mps2: float = 2.0, iterations: int = 8,
                         slip_limit_m: float = 0.2e-3) -> float:
    """Relative error of the bisected minimum holding force against ``m (g + a) / (2 mu)``.

    A 100 g box, mu = 1.0 (pads) x 0.5, fingers closing along a horizontal axis, the part
    accelerated vertically (so its weight and inertia, ``m (g + a)``, are carried by the two
    pads' friction, ``2 mu F``); bracket [0.5, 2] x analytic, ``iterations`` halvings (8: a
    step of 0.6 %).
    """
    from .scenarios import BoxPart, G, lift_slip_m

    part = BoxPart(mass_kg=0.1, friction=0.5)
    analytic = part.mass_kg * (G + accel_mps2) / (2 * 1.0 * part.friction)
    lo, hi = 0.5 * analytic, 2.0 * analytic
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if lift_slip_m(fidelity, part, mid, accel_mps2) < slip_limit_m:
            hi = mid
        else:
            lo = mid
    return hi / analytic - 1.0


@dataclass(frozen=True)
class InsertionRun:
    """One pin insertion: outcome, depth entered when the gripper stopped pushing (m),
    largest contact penetration (m), wall time (s)."""

    radial_clearance_m: float
    success: bool
    entered_depth_m: float
    max_penetration_m: float
    wall_s: float
    reasons: tuple[str, ...] = ()


def pin_insertion(fidelity: Any, radial_clearance_m: float) -> InsertionRun:
    """Pick a standing 40 mm steel pin, carry it over a 10 mm, 20 mm deep blind hole in a
    fixtured 40 x 40 x 30 mm block and push it straight in to 0.2 mm above the floor
    (:func:`bench.scenarios.pin_insertion`, the scene of ``tests/sim``).

    ``radial_clearance_m`` < 0 makes an interference fit. No chamfer.
    """
    from .scenarios import entered_depth_m
    from .scenarios import pin_insertion as insert

    t0 = time.perf_counter()
    record, outcome = insert(fidelity, radial_clearance_m)
    return InsertionRun(radial_clearance_m, bool(outcome.success), entered_depth_m(record),
                        float(outcome.max_penetration_m), time.perf_counter() - t0,
                        tuple(outcome.reasons))


def reference_fidelity(dt_s: float = REFERENCE_DT_S) -> Any:
    """ACCURATE with a smaller time step (record interval kept at 4 ms)."""
    from asmplan.sim.fidelity import ACCURATE

    return dataclasses.replace(ACCURATE, name=f"reference dt 1/{round(1 / dt_s)} s", dt_s=dt_s,
                            record_every_steps=max(1, round(0.004 / dt_s)))


# ---------------------------------------------------------------------------------------------
# accuracy


@dataclass(frozen=True)
class AccuracyFigure:
    """One accuracy figure of one scenario at one preset.

    ``asserted`` is False where the scenario lies below the preset's documented resolution
    (the figure is reported, not checked); ``wall_s`` is the cost of the scenario's run(s).
    """

    preset: str
    scenario: str
    figure: str
    value: float
    unit: str
    wall_s: float
    asserted: bool = True
    note: str = ""


@dataclass(frozen=True)
class AccuracyResult:
    """All accuracy figures, the reference runs and their convergence check."""

    figures: tuple[AccuracyFigure, ...]
    reference: tuple[InsertionRun, ...]
    reference_dt_s: float
    convergence_m: float | None = None
    """Largest |entered depth| difference between the reference and a 2x coarser step, m."""
    peers: tuple[PeerRow, ...] = ()
    """The validation scenes in PyBullet (BALANCED) and MuJoCo side by side (:func:`peer_rows`;
    empty without MuJoCo or without BALANCED among the presets)."""


def _scenario_name(c: float) -> str:
    kind = "fit" if c > 0 else "interference"
    return f"pin {kind} {abs(c) * 1e3:.3f} mm radial"


# Complexity above C (radon): the accuracy scenarios per preset (seed cycle, slip, insertions
# against the reference, contact figures), each adding its figures in the report's order.
def run_accuracy(presets: Sequence[str] = ("fast", "balanced", "accurate"),
                 clearances_m: Sequence[float] | None = None, *,
                 check_convergence: bool = False, with_peers: bool = False,
                 log: Callable[[str], None] | None = None) -> AccuracyResult:
    """Run the accuracy scenarios at every preset (see the module docstring).

    Parameters
    ----------
    presets : preset names.
    clearances_m : radial clearances c of the insertion scenarios (each as +c and -c), m
        (default :data:`INSERTION_CLEARANCES_M`).
    check_convergence : also run the reference at twice its time step and report the largest
        depth difference (``convergence_m``).
    with_peers : also run every scene in MuJoCo beside BALANCED (:func:`peer_rows`).
    log : called with one line per finished run (progress).
    """
    from asmplan.sim.fidelity import preset

    from .scenarios import run_seed_cycle

    say = log or (lambda _s: None)
    cases = [s * c for c in (INSERTION_CLEARANCES_M if clearances_m is None else clearances_m)
             for s in (1.0, -1.0)]
    ref_fid = reference_fidelity()
    reference = tuple(pin_insertion(ref_fid, c) for c in cases)
    say(f"reference ({ref_fid.name}): {sum(r.wall_s for r in reference):.1f} s")
    convergence = None
    if check_convergence:
        coarse = [pin_insertion(reference_fidelity(2 * REFERENCE_DT_S), c) for c in cases]
        convergence = max(abs(a.entered_depth_m - b.entered_depth_m)
                          for a, b in zip(reference, coarse, strict=True))
    figures: list[AccuracyFigure] = []
    for name in presets:
        fid = preset(name)
        t0 = time.perf_counter()
        _, seed, _ = run_seed_cycle(fid)
        figures.append(AccuracyFigure(name, "seed clamp cycle (4 s)", "seed_force_mae_N",
                                      float(seed.clamp_force_mae_N), "N", time.perf_counter() - t0))
        for a in SLIP_ACCELS_MPS2:
            t0 = time.perf_counter()
            err = slip_threshold_error(fid, a)
            what = "held in the air: m g / (2 mu)" if a == 0 else "lifted: m (g + a) / (2 mu)"
            figures.append(AccuracyFigure(name, f"slip threshold, a = {a:g} m/s^2 (8 bisection "
                                          f"runs)", "slip_threshold_error", err, "",
                                          time.perf_counter() - t0, note=what))
        for c, ref in zip(cases, reference, strict=True):
            run = pin_insertion(fid, c)
            # the fit/interference scene measures the interference resolution (sim/fidelity.py)
            resolvable = 2 * abs(c) >= fid.interference_resolution_m - 1e-12
            note = "" if resolvable else (f"below the preset's interference resolution "
                                          f"({fid.interference_resolution_m * 1e3:.2f} mm diametral)")
            scen = _scenario_name(c)
            verdict = f"{'inserted' if run.success else 'not inserted'} (reference: " \
                      f"{'inserted' if ref.success else 'not inserted'})"
            figures.append(AccuracyFigure(name, scen, "insertion_outcome_mismatch",
                                          float(run.success != ref.success), "", run.wall_s,
                                          resolvable, "; ".join(x for x in (verdict, note) if x)))
            figures.append(AccuracyFigure(name, scen, "insertion_depth_error_m",
                                          run.entered_depth_m - ref.entered_depth_m, "m", run.wall_s,
                                          resolvable,
                                          f"entered {run.entered_depth_m * 1e3:.3f} mm vs "
                                          f"{ref.entered_depth_m * 1e3:.3f} mm"))
            if c > 0:
                figures.append(AccuracyFigure(name, scen, "fit_penetration_m", run.max_penetration_m,
                                              "m", run.wall_s, resolvable, note))
        figures.extend(contact_figures(fid))
        if name == presets[0]:
            figures.extend(seed_profile_figures(name))
        say(f"accuracy {name}: {sum(f.wall_s for f in figures if f.preset == name):.1f} s")
    peer: tuple[PeerRow, ...] = ()
    if with_peers and "balanced" in presets:
        peer = tuple(peer_rows(preset("balanced"), log=say))
    return AccuracyResult(tuple(figures), reference, REFERENCE_DT_S, convergence, peer)


JAM_CLEARANCES_M: tuple[float, ...] = (0.01e-3, 0.05e-3, 0.1e-3, 0.5e-3)
JAM_TILTS_DEG: tuple[float, ...] = (0.5, 1.0, 2.0, 5.0)
DRIFT_TILTS_RAD: tuple[float, ...] = (0.0, 0.1, math.pi / 2)


def exact_solver_fidelity(fid: Any) -> Any:
    """``fid`` with Bullet's direct MLCP solver (Dantzig) and a 0.1 um contact slop: the
    jam scene's geometric reference (sim/fidelity.py, ``constraint_solver``)."""
    return dataclasses.replace(fid, name=f"{fid.name}+dantzig", constraint_solver="dantzig",
                               contact_slop_m=1e-7)


def contact_figures(fid: Any) -> list[AccuracyFigure]:
    """Issue 16's validation scenes at one preset, each against its analytic answer:
    Whitney's jam depth (every clearance x tilt whose l* fits the 20 mm hole; asserted at
    5 deg for c >= 0.05 mm), the capture boundary of an unchamfered pin (0.5 mm off: rim;
    0.02 mm off: in) and the held part's drift along its closing axis at three tilts."""
    from asmplan.sim import peers

    from .scenarios import (
        JamScene,
        entered_depth_m,
        held_drift_m,
        jam_depth_m,
        whitney_jam_depth_m,
    )
    from .scenarios import pin_insertion as scene_pin_insertion

    out: list[AccuracyFigure] = []
    for c in JAM_CLEARANCES_M:
        for t_deg in JAM_TILTS_DEG:
            t = math.radians(t_deg)
            ref = whitney_jam_depth_m(c, t)
            if ref > 0.018:
                continue
            t0 = time.perf_counter()
            got = jam_depth_m(fid, c, t)
            asserted = (t_deg == 5.0 and c >= 0.05e-3 - 1e-12
                        and fid.bullet_units_per_m != 1.0)
            wall = time.perf_counter() - t0
            out.append(AccuracyFigure(
                fid.name, f"Whitney jam c = {c * 1e3:.2f} mm, t = {t_deg:g} deg",
                "jam_depth_error_m", got - ref, "m", wall, asserted,
                f"l* = {ref * 1e3:.3f} mm, simulated {got * 1e3:.3f} mm; PyBullet "
                f"{wall / JamScene().settle_s:.2f} wall s per simulated s"))
            if fid.name == "balanced":
                exact = exact_solver_fidelity(fid)
                t0 = time.perf_counter()
                got_x = jam_depth_m(exact, c, t)
                wall_x = time.perf_counter() - t0
                out.append(AccuracyFigure(
                    fid.name, f"Whitney jam, direct (Dantzig) solver, slop 0.1 um: c = "
                    f"{c * 1e3:.2f} mm, t = {t_deg:g} deg", "jam_depth_exact_solver_error_m",
                    got_x - ref, "m", wall_x, c >= 0.05e-3 - 1e-12,
                    f"simulated {got_x * 1e3:.3f} mm: the scene's geometry (peg, hole, depth "
                    f"measure) is exact; BALANCED's error above is its iterative solver"))
            if fid.name == "balanced" and peers.available():
                mj, mj_cost = peers.mujoco_jam_depth_m(fid.dt_s, c, t)
                out.append(AccuracyFigure(
                    fid.name, f"MuJoCo peer (dt = {fid.dt_s:g} s): Whitney jam c = "
                    f"{c * 1e3:.2f} mm, t = {t_deg:g} deg", "peer_jam_depth_error_m", mj - ref,
                    "m", mj_cost * JamScene().settle_s, False,
                    f"simulated {mj * 1e3:.3f} mm; MuJoCo {mj_cost:.2f} wall s per simulated "
                    f"s (elliptic cone, impratio 10, solref 2 dt, noslip 20)"))
    for e, expect_in in ((0.5e-3, False), (0.02e-3, True)):
        t0 = time.perf_counter()
        record, _ = scene_pin_insertion(fid, 0.1e-3, lateral_offset_m=e)
        went_in = entered_depth_m(record) > 2e-3
        out.append(AccuracyFigure(
            fid.name, f"unchamfered pin {e * 1e3:.2f} mm off, c/2 = 0.1 mm",
            "rim_capture_mismatch", float(went_in != expect_in), "", time.perf_counter() - t0,
            fid.bullet_units_per_m != 1.0,
            f"entered {entered_depth_m(record) * 1e3:.2f} mm (expected "
            f"{'in' if expect_in else 'on the rim'})"))
    for tilt in DRIFT_TILTS_RAD:
        t0 = time.perf_counter()
        d = held_drift_m(fid, tilt, coupled=True)
        out.append(AccuracyFigure(fid.name, f"held drift, closing axis at {tilt:.2f} rad",
                                  "held_drift_m", d, "m", time.perf_counter() - t0))
    return out


SEED_PART_MASS_KG = 0.16
SEED_MU = 0.5


def predicted_seed_profile(mass_kg: float = SEED_PART_MASS_KG, mu: float = SEED_MU
                           ) -> dict[str, tuple[float, float]]:
    """The planner's clamp-force model (per finger, no safety factor: ``m |g - a| / (2 mu)``,
    ``planner/timing.py``) along the seed cycle's motion (lift 50 mm, translate 100 mm, lower,
    min-jerk), per phase ``(min, max)`` in N: 0.16 kg at mu 0.5 holds with 1.57 N."""
    import numpy as np

    from asmplan.planner.trajectory import parse_phase_table, seed_cycle

    from .scenarios import SEED_PHASE_TABLE_CSV, pose

    traj = seed_cycle(parse_phase_table(SEED_PHASE_TABLE_CSV), pose((0.0, 0.0, 0.025)),
                      lift_m=0.05, translation_m=(0.1, 0.0, 0.0), sample_dt_s=1e-3)
    t = traj.t_s
    p = traj.T_world_gripper[:, :3, 3]
    a = np.gradient(np.gradient(p, t, axis=0), t, axis=0)
    g = np.array([0.0, 0.0, -9.81])
    f = mass_kg * np.linalg.norm(g - a, axis=1) / (2.0 * mu)
    out = {}
    for ph in traj.phases:
        m = (t >= ph.t_start_s) & (t <= ph.t_end_s)
        out[ph.name] = (float(f[m].min()), float(f[m].max()))
    return out


def seed_profile_figures(preset_name: str) -> list[AccuracyFigure]:
    """The planner's predicted clamp force per phase of the seed cycle against the seed
    paper's Table 4 (hold, lift, translate, lower; clamp and release are ramps the planner
    commands, not predicts): the largest difference of the phase's min and max, N. Reported,
    not asserted (the paper's motion profile is not published; ours is min-jerk)."""
    from asmplan.planner.trajectory import parse_phase_table

    from .scenarios import SEED_PHASE_TABLE_CSV

    t0 = time.perf_counter()
    pred = predicted_seed_profile()
    table = {r.name: r for r in parse_phase_table(SEED_PHASE_TABLE_CSV)}
    out = []
    for ph in ("hold", "lift", "translate", "lower"):
        lo, hi = pred[ph]
        row = table[ph]
        diff = max(abs(lo - row.force_min_N), abs(hi - row.force_max_N))
        out.append(AccuracyFigure(
            preset_name, f"planner clamp profile vs seed Table 4: {ph}", "seed_profile_error_N",
            diff, "N", time.perf_counter() - t0, False,
            f"predicted {lo:.3f}-{hi:.3f} N, paper {row.force_min_N:.2f}-{row.force_max_N:.2f} N "
            f"(preset-independent)"))
    return out


@dataclass(frozen=True)
class Regression:
    """An asserted figure beyond its bound."""

    figure: AccuracyFigure
    bound: Bound

    def __str__(self) -> str:
        f, b = self.figure, self.bound
        return (f"REGRESSION: {f.figure} [{f.preset}, {f.scenario}] = {_fmt(f.value, f.unit)} "
                f"exceeds bound {_fmt(b.limit, b.unit)} ({b.reason})")


def check_bounds(figures: Sequence[AccuracyFigure],
                 bounds: Sequence[Bound] | None = None) -> list[Regression]:
    """The asserted figures whose magnitude exceeds their bound (:data:`BOUNDS` by default).

    A figure without a bound is not checked; NaN always fails.
    """
    table = {(b.figure, b.preset): b for b in (BOUNDS if bounds is None else bounds)}
    out = []
    for f in figures:
        b = table.get((f.figure, f.preset))
        if b is None or not f.asserted:
            continue
        if not (abs(f.value) <= b.limit):
            out.append(Regression(f, b))
    return out


# ---------------------------------------------------------------------------------------------
# planning


@dataclass(frozen=True)
class PlanningResult:
    """``planner.bench_motion`` results per product (ProductBench) and its text report."""

    products: tuple[Any, ...]
    text: str


def run_arm(log: Callable[[str], None] | None = None) -> list[Any]:
    """The arm section: IK per waypoint and planning per step with and without the arm."""
    from .arm import bench_arm

    return bench_arm(log=log)


def format_arm(rows: Sequence[Any]) -> str:
    """Markdown table of :func:`run_arm`."""
    from .arm import format_arm as fmt

    return fmt(rows)


def run_planning(products: Sequence[str] | None = None, direct_budget_s: float = 2.0) -> PlanningResult:
    """Per-step motion-planning time and the ratio against direct OMPL insertion planning."""
    from .motion import bench

    buf = io.StringIO()
    rows = bench(products, direct_budget_s=direct_budget_s, stream=buf)
    return PlanningResult(tuple(rows), buf.getvalue())


# ---------------------------------------------------------------------------------------------
# scaling and culling


@dataclass(frozen=True)
class ScalingRow:
    """The whole job on one generated product: stage times (s), outcome, failure reason."""

    n_parts: int
    seed: int
    timings_s: dict[str, float]
    planned: bool
    success: bool
    failure: str = ""
    failed_steps: int = 0
    steps: int = 0


@dataclass(frozen=True)
class CullingResult:
    """Each step simulated with only the bodies it needs vs the whole product loaded."""

    n_parts: int
    steps: int
    culled_s: float
    whole_s: float
    identical: bool
    differences: tuple[str, ...] = ()
    failure: str = ""
    product: str = ""

    @property
    def ratio(self) -> float:
        """Whole-scene time / culled time."""
        return self.whole_s / self.culled_s if self.culled_s > 0 else float("nan")


STAGES = ("validation", "sequence", "plan", "simulate", "report")


def run_scaling(sizes: Sequence[int] = SCALING_SIZES, seed: int = 0, fidelity: str = "fast",
                keep: int | None = CULLING_SIZE,
                log: Callable[[str], None] | None = None) -> tuple[list[ScalingRow], Any]:
    """Run the whole job (validate, sequence, plan, simulate, report) on generated products.

    Returns the rows and the :class:`~asmplan.pipeline.RunResult` of size ``keep`` (reused by
    :func:`run_culling`; None if that size was not run). A failure is a row, not an exception.
    """
    from asmplan.knowledge.generator import generate_product, product_yaml
    from asmplan.knowledge.loader import load_product
    from asmplan.pipeline import RunSettings, run_product, write_outputs

    say = log or (lambda _s: None)
    rows, kept = [], None
    with tempfile.TemporaryDirectory(prefix="asmplan-bench-") as tmp:
        for n in sizes:
            path = Path(tmp) / f"generated_{n}.yaml"
            path.write_text(product_yaml(generate_product(n, seed, fit=SCALING_FIT_MM)),
                            encoding="utf-8")
            t0 = time.perf_counter()
            try:
                product = load_product(path)
                timings = {"validation": time.perf_counter() - t0}
                result = run_product(product, RunSettings(fidelity=fidelity))
                timings.update(result.timings_s)
                write_outputs(result, Path(tmp) / f"out_{n}")
                timings["report"] = result.timings_s["report"]
            except Exception as exc:  # a benchmark row, not a crash: keep the reason
                rows.append(ScalingRow(n, seed, {}, False, False, f"{type(exc).__name__}: {exc}"))
                say(f"scaling {n} parts: {type(exc).__name__}: {exc}")
                continue
            res = result.results
            failed = 0 if res is None else sum(1 for s in res.steps if not s.success)
            rows.append(ScalingRow(n, seed, {k: timings.get(k, 0.0) for k in STAGES},
                                   result.plan is not None, result.success, result.failure,
                                   failed, 0 if result.plan is None else len(result.plan.steps)))
            say(f"scaling {n} parts: " + ", ".join(f"{k} {v:.2f} s" for k, v in rows[-1].timings_s.items())
                + ("" if result.plan is not None else f"; {result.failure[:120]}"))
            if n == keep:
                kept = result
    return rows, kept


def scaling_growth(rows: Sequence[ScalingRow]) -> dict[str, list[tuple[int, int, float]]]:
    """Growth exponents ``k`` (time ~ n^k) per stage between consecutive measured sizes."""
    out: dict[str, list[tuple[int, int, float]]] = {}
    ok = [r for r in rows if r.timings_s]
    for stage in (*STAGES, "total"):
        pts = []
        for a, b in itertools.pairwise(ok):
            ta = sum(a.timings_s.values()) if stage == "total" else a.timings_s.get(stage, 0.0)
            tb = sum(b.timings_s.values()) if stage == "total" else b.timings_s.get(stage, 0.0)
            if ta > 1e-3 and tb > 1e-3 and a.n_parts != b.n_parts:
                pts.append((a.n_parts, b.n_parts, math.log(tb / ta) / math.log(b.n_parts / a.n_parts)))
        out[stage] = pts
    return out


def run_culling(result: Any | None, n_parts: int = CULLING_SIZE, seed: int = 0,
                fidelity: str = "fast", example: str | None = None,
                last_steps: int | None = 3) -> CullingResult:
    """Simulate the plan of ``result`` (a RunResult of the generated ``n_parts`` product; made
    here when None; or of the bundled ``example`` when given) culled and with the whole
    product loaded; compare times and outcomes.

    ``last_steps`` limits both runs to the plan's last steps (the fullest scenes; the whole
    50-part product costs ~100 s per step at fast, so all 49 steps would take over an hour);
    None runs every step.
    """
    from asmplan.knowledge.generator import generated_product
    from asmplan.knowledge.loader import load_product
    from asmplan.pipeline import RunSettings, run_product
    from asmplan.sim.simulate import simulate_plan

    from .motion import _example_path

    if example is not None:
        result = run_product(load_product(_example_path(example)),
                             RunSettings(fidelity=fidelity, simulate=False))
    elif result is None:
        result = run_product(generated_product(n_parts, seed, fit=SCALING_FIT_MM),
                             RunSettings(fidelity=fidelity, simulate=False))
    name = example or f"generated, {n_parts} parts"
    n_parts = len(result.product.parts)
    if result.plan is None:
        return CullingResult(n_parts, 0, float("nan"), float("nan"), False,
                             failure=result.failure or "no plan", product=name)
    fid = result.fidelity
    moved = [s.index for s in result.plan.steps if s.kind != "fixture"]
    chosen = moved if last_steps is None else moved[-last_steps:]
    t0 = time.perf_counter()
    culled = simulate_plan(result.plan, result.product, result.geometry, fid, cull=True,
                           steps=chosen)
    t1 = time.perf_counter()
    whole = simulate_plan(result.plan, result.product, result.geometry, fid, cull=False,
                          steps=chosen)
    t2 = time.perf_counter()
    diffs = []
    for a, b in zip(culled.steps, whole.steps, strict=True):
        if a.success != b.success or a.failed_criteria != b.failed_criteria:
            diffs.append(f"step {a.index + 1} ({a.part}): culled {a.success} {list(a.failed_criteria)}, "
                         f"whole {b.success} {list(b.failed_criteria)}")
    n = sum(1 for s in culled.steps if s.simulated)
    return CullingResult(n_parts, n, t1 - t0, t2 - t1, not diffs, tuple(diffs), product=name)


# ---------------------------------------------------------------------------------------------
# sweep throughput


@dataclass(frozen=True)
class SeedRunTiming:
    """The bundled seed workstation, end to end at FAST without the report, ``runs`` times each:

    * ``cli_s``: ``python -m asmplan run --fidelity fast --no-report`` in a new process (what a
      user waits for, including starting Python and the imports);
    * ``imports_s``: a new process that only imports the pipeline (the floor of the above);
    * ``library_s``: ``run_product`` + ``write_outputs(report=False)`` in this process.

    ``stages_s`` are the stage times of the last library run; ``success`` whether every run
    exited 0 with every step succeeding.

    The whole job of issues 16/17 (target <= 5 s on 2 cores), ``report_runs`` times:
    ``python -m asmplan run`` at BALANCED with the report and the default workers, in a new
    process: ``report_cli_s`` its wall time, ``report_cpu_s`` the CPU time of it and its
    workers (user + system, from ``RUSAGE_CHILDREN``: what the job costs the machine, less
    sensitive to other load than wall time), ``report_stage_s`` the report stage's wall time
    as the CLI printed it.
    """

    runs: int
    cli_s: tuple[float, ...]
    imports_s: tuple[float, ...]
    library_s: tuple[float, ...]
    stages_s: dict[str, float]
    success: bool
    failure: str = ""
    report_runs: int = 0
    report_cli_s: tuple[float, ...] = ()
    report_cpu_s: tuple[float, ...] = ()
    report_stage_s: tuple[float, ...] = ()


def run_seed_timing(runs: int = SEED_RUNS, log: Callable[[str], None] | None = None, *,
                    report_runs: int = SEED_REPORT_RUNS) -> SeedRunTiming:
    """Time the seed workstation at FAST without the report, and its whole job at BALANCED
    with the report (see :class:`SeedRunTiming`)."""
    import re
    import resource
    import sys

    from asmplan.pipeline import RunSettings, run_product, write_outputs

    from .motion import _example_path

    say = log or (lambda _s: None)
    seed = str(_example_path("pinhole_station"))
    cli, imports, library, ok, failure = [], [], [], True, ""
    stages: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="asmplan-bench-seed-") as tmp:
        for i in range(runs):
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "asmplan", "run", seed, "--fidelity", "fast",
                                   "--no-report", "-o", str(Path(tmp) / "cli")],
                                  capture_output=True, text=True)
            cli.append(time.perf_counter() - t0)
            if proc.returncode != 0:
                ok, failure = False, f"asmplan run exited {proc.returncode}: {proc.stderr.strip()[-300:]}"
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-c", "import asmplan.pipeline"], check=True)
            imports.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            result = run_product(seed, RunSettings(fidelity="fast"))
            write_outputs(result, Path(tmp) / f"lib{i}", report=False)
            library.append(time.perf_counter() - t0)
            stages = dict(result.timings_s)
            ok = ok and result.success
        say(f"seed workstation: CLI median {statistics.median(cli):.2f} s, imports "
            f"{statistics.median(imports):.2f} s, library {statistics.median(library):.2f} s")
        report_cli, report_cpu, report_stage = [], [], []
        for _ in range(report_runs):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "asmplan", "run", seed,
                                   "--fidelity", "balanced", "-o", str(Path(tmp) / "report")],
                                  capture_output=True, text=True)
            report_cli.append(time.perf_counter() - t0)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            report_cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
            stage = re.search(r"report ([0-9.]+) s\)", proc.stdout)
            report_stage.append(float(stage.group(1)) if stage else math.nan)
            if proc.returncode != 0:
                ok, failure = False, (f"asmplan run --fidelity balanced exited {proc.returncode}: "
                                      f"{proc.stderr.strip()[-300:]}")
        if report_runs:
            say(f"seed workstation at BALANCED with the report: median "
                f"{statistics.median(report_cli):.2f} s wall, {statistics.median(report_cpu):.2f} s "
                "CPU")
    return SeedRunTiming(runs, tuple(cli), tuple(imports), tuple(library), stages, ok, failure,
                         report_runs, tuple(report_cli), tuple(report_cpu), tuple(report_stage))


def format_seed_timing(t: SeedRunTiming) -> str:
    """Markdown: medians and ranges of the seed workstation timings."""
    def row(name: str, v: Sequence[float]) -> str:
        return f"| {name} | {statistics.median(v):.2f} s | {min(v):.2f}-{max(v):.2f} s |"

    lines = ["| seed workstation, FAST, no report | median | range |", "| --- | ---: | ---: |",
             row("`asmplan run --fidelity fast --no-report` (new process)", t.cli_s),
             row("new process importing the pipeline only", t.imports_s),
             row("`run_product` + `write_outputs(report=False)` in a running Python", t.library_s), ""]
    stages = ", ".join(f"{k} {v:.2f} s" for k, v in t.stages_s.items() if k != "report")
    lines.append(f"{t.runs} runs each, interleaved. Stages of the last library run: {stages}. "
                 + ("Every run succeeded." if t.success else f"NOT every run succeeded: {t.failure}"))
    if t.report_runs:
        lines += ["", "| seed workstation, BALANCED, with the report (target <= 5 s, 2 cores) | "
                      "median | range |", "| --- | ---: | ---: |",
                  row("`asmplan run --fidelity balanced` (new process), wall", t.report_cli_s),
                  row("the same, CPU of the process and its workers", t.report_cpu_s),
                  row("its report stage, wall (as the CLI prints it)", t.report_stage_s), "",
                  f"{t.report_runs} runs, after the FAST runs. The machine is shared: wall time "
                  "rises with other load, CPU time much less."]
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class SweepResult:
    """:func:`asmplan.sim.sweep.throughput` rows for one real step sweep."""

    product: str
    fidelity: str
    n_tasks: int
    rows: tuple[Any, ...]
    failure: str = ""


def _sweep_task(sweep: Any, params: Any) -> Any:
    from asmplan.sim.sweep import simulate_sample

    return simulate_sample(sweep, params)


def run_sweep_throughput(product: str = "peg_in_hole", n_tasks: int = 8, fidelity: str = "balanced",
                         repeats: int = 1) -> SweepResult:
    """Simulations per second of a real sweep (every step of ``product`` per sample) with 1 and
    2 local workers and a 2-worker Dask LocalCluster."""
    import functools

    from asmplan.knowledge.loader import load_product
    from asmplan.pipeline import RunSettings, run_product
    from asmplan.sim.fidelity import preset
    from asmplan.sim.sweep import PlanSweep, SweepSpec

    from .motion import _example_path
    from .throughput import throughput

    p = load_product(_example_path(product))
    result = run_product(p, RunSettings(fidelity=fidelity, simulate=False))
    if result.plan is None:
        return SweepResult(product, fidelity, n_tasks, (), result.failure)
    sweep = PlanSweep(p, result.plan, preset(fidelity))
    samples = sweep.samples(SweepSpec(n_samples=n_tasks, seed=0))
    rows = throughput(functools.partial(_sweep_task, sweep), samples, (1, 2), 2, repeats)
    return SweepResult(product, fidelity, n_tasks, tuple(rows))


# ---------------------------------------------------------------------------------------------
# machine and formatting


def machine_description() -> dict[str, str]:
    """CPU model, cores, memory, load, OS, Python and package versions, git commit."""
    info: dict[str, str] = {}
    try:
        cpu = Path("/proc/cpuinfo").read_text(encoding="utf-8")
        models = [ln.split(":", 1)[1].strip() for ln in cpu.splitlines() if ln.startswith("model name")]
        info["CPU"] = models[0] if models else platform.processor() or "unknown"
    except OSError:
        info["CPU"] = platform.processor() or "unknown"
    info["cores (os.cpu_count)"] = str(os.cpu_count())
    if hasattr(os, "sched_getaffinity"):
        info["cores usable by this process"] = str(len(os.sched_getaffinity(0)))
    try:
        mem = Path("/proc/meminfo").read_text(encoding="utf-8").splitlines()[0].split()
        info["memory"] = f"{int(mem[1]) / 1024**2:.1f} GiB"
    except (OSError, IndexError, ValueError):
        pass
    if hasattr(os, "getloadavg"):
        info["load average at start (1/5/15 min)"] = " / ".join(f"{x:.2f}" for x in os.getloadavg())
    info["OS"] = platform.platform()
    info["Python"] = platform.python_version()
    versions = []
    for dist in ("numpy", "pybullet", "ompl", "python-fcl", "trimesh", "manifold3d", "networkx",
                 "matplotlib", "dask", "distributed"):
        try:
            versions.append(f"{dist} {metadata.version(dist)}")
        except metadata.PackageNotFoundError:
            continue
    info["packages"] = ", ".join(versions)
    try:
        here = Path(__file__).resolve().parent
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=here, capture_output=True,
                                text=True, timeout=5, check=False).stdout.strip()
        if commit:
            info["asmplan commit"] = commit
    except (OSError, subprocess.SubprocessError):
        pass
    return info


def _fmt(value: float, unit: str) -> str:
    if unit == "m":
        return f"{value * 1e3:.4f} mm"
    if unit == "N":
        return f"{value:.5f} N"
    if unit == "":
        return f"{value * 100:+.2f} %" if abs(value) < 1 and value != 0 and value != 1 else f"{value:g}"
    return f"{value:g} {unit}"


_FIGURE_LABEL = {
    "seed_force_mae_N": "clamp-force MAE (hold..lower)",
    "slip_threshold_error": "min. holding force vs m(g+a)/(2mu)",
    "insertion_outcome_mismatch": "outcome differs from reference",
    "insertion_depth_error_m": "entered depth - reference",
    "fit_penetration_m": "max. contact penetration",
}


def format_accuracy(acc: AccuracyResult, bounds: Sequence[Bound] | None = None) -> str:
    """Markdown: one row per figure with its bound and wall time."""
    table = {(b.figure, b.preset): b for b in (BOUNDS if bounds is None else bounds)}
    lines = ["| preset | scenario | figure | value | bound | checked | wall (s) | note |",
             "| --- | --- | --- | ---: | ---: | --- | ---: | --- |"]
    for f in acc.figures:
        b = table.get((f.figure, f.preset))
        is_outcome = f.figure == "insertion_outcome_mismatch"
        value = ("yes" if f.value else "no") if is_outcome else _fmt(f.value, f.unit)
        bound = "-" if b is None else ("must match" if f.figure == "insertion_outcome_mismatch"
                                       else f"<= {_fmt(b.limit, b.unit).lstrip('+')}")
        unasserted = ("no (below resolution)" if "resolution" in f.note
                      or f.figure.startswith("insertion") or f.figure == "fit_penetration_m"
                      else "no (reported)")
        checked = unasserted if not f.asserted else (
            "FAIL" if b is not None and not abs(f.value) <= b.limit else "ok")
        lines.append(f"| {f.preset} | {f.scenario} | {_FIGURE_LABEL.get(f.figure, f.figure)} | {value} | "
                     f"{bound} | {checked} | {f.wall_s:.2f} | {f.note} |")
    ref = ", ".join(f"{_scenario_name(r.radial_clearance_m)}: {'inserted' if r.success else 'not inserted'}, "
                    f"{r.entered_depth_m * 1e3:.3f} mm, {r.wall_s:.1f} s" for r in acc.reference)
    lines.append("")
    lines.append(f"Reference (ACCURATE at dt = 1/{round(1 / acc.reference_dt_s)} s): {ref}.")
    if acc.convergence_m is not None:
        lines.append(f"Reference convergence: entered depth changes by at most "
                     f"{acc.convergence_m * 1e6:.2f} um between dt = 1/{round(0.5 / acc.reference_dt_s)} s "
                     f"and 1/{round(1 / acc.reference_dt_s)} s.")
    return "\n".join(lines) + "\n"


def format_accuracy_summary(acc: AccuracyResult) -> str:
    """Markdown: one row per preset with the headline figures and the cost."""
    lines = ["| preset | clamp-force MAE (N) | worst slip threshold error (a = 0 / 5 / 20 m/s^2) "
             "| worst depth error, resolved (mm) "
             "| worst fit penetration (mm) | wall: seed cycle / pin insertion (s) |",
             "| --- | ---: | ---: | ---: | ---: | ---: |"]
    for p in dict.fromkeys(f.preset for f in acc.figures):
        fs = [f for f in acc.figures if f.preset == p]

        def one(name: str, fs: list[AccuracyFigure] = fs) -> AccuracyFigure:
            return next(f for f in fs if f.figure == name)

        depth = [abs(f.value) for f in fs if f.figure == "insertion_depth_error_m" and f.asserted]
        pen = [f.value for f in fs if f.figure == "fit_penetration_m" and f.asserted]
        ins = [f.wall_s for f in fs if f.figure == "insertion_depth_error_m"]
        slip = max((f.value for f in fs if f.figure == "slip_threshold_error"), key=abs,
                   default=float("nan"))
        lines.append(f"| {p} | {one('seed_force_mae_N').value:.5f} | "
                     f"{slip * 100:+.2f} % | "
                     f"{max(depth, default=float('nan')) * 1e3:.3f} | "
                     f"{max(pen, default=float('nan')) * 1e3:.3f} | "
                     f"{one('seed_force_mae_N').wall_s:.2f} / {statistics.median(ins):.2f} |")
    return "\n".join(lines) + "\n"


def format_planning(res: PlanningResult) -> str:
    """Markdown: per product, median step time, the baseline and the ratio."""
    lines = ["| product | steps | median plan ms/step | median CPU ms/step | median direct-OMPL ms/step "
             "| direct solved | median ratio (direct / ours) |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in res.products:
        if not r.steps:
            continue
        ratios = [s.ratio for s in r.steps]
        solved = sum(s.direct_solved for s in r.steps)
        lo = "" if solved == len(r.steps) else ">="
        lines.append(f"| {r.product} | {len(r.steps)} | {r.median_ms:.1f} | {r.median_cpu_ms:.1f} | "
                     f"{1e3 * statistics.median(s.direct_s for s in r.steps):.1f} | "
                     f"{solved}/{len(r.steps)} | "
                     f"{lo}{statistics.median(ratios):.1f} |")
    return "\n".join(lines) + "\n"


def format_scaling(rows: Sequence[ScalingRow]) -> str:
    """Markdown: stage times per size, outcome, and growth exponents."""
    lines = ["| parts | " + " | ".join(f"{s} (s)" for s in STAGES) + " | total (s) | steps | outcome |",
             "| ---: | " + " | ".join("---:" for _ in STAGES) + " | ---: | ---: | --- |"]
    for r in rows:
        cells = [f"{r.timings_s[s]:.2f}" if s in r.timings_s else "-" for s in STAGES]
        total = f"{sum(r.timings_s.values()):.2f}" if r.timings_s else "-"
        if r.success:
            outcome = "all steps succeeded"
        elif r.planned:
            outcome = f"{r.failed_steps} step(s) failed in simulation"
        else:
            outcome = "not planned: " + (r.failure.splitlines()[0][:160] if r.failure else "?")
        lines.append(f"| {r.n_parts} | " + " | ".join(cells) + f" | {total} | {r.steps} | "
                     f"{outcome.replace('|', '/')} |")
    growth = scaling_growth(rows)
    lines.append("")
    lines.append("Growth exponent k (time ~ n^k) between consecutive sizes:")
    lines.append("")
    pairs = sorted({(a, b) for v in growth.values() for a, b, _ in v})
    if pairs:
        lines.append("| stage | " + " | ".join(f"{a} -> {b}" for a, b in pairs) + " |")
        lines.append("| --- | " + " | ".join("---:" for _ in pairs) + " |")
        for stage, pts in growth.items():
            d = {(a, b): k for a, b, k in pts}
            lines.append(f"| {stage} | " + " | ".join(f"{d[p]:.2f}" if p in d else "-" for p in pairs) + " |")
    else:
        lines.append("(fewer than two sizes measured)")
    return "\n".join(lines) + "\n"


def format_culling(results: Sequence[CullingResult]) -> str:
    """Markdown: culled vs whole-product simulation time and whether outcomes agree."""
    lines = ["| product | parts | simulated steps | culled (s) | whole product (s) | ratio whole / culled "
             "| identical outcomes |",
             "| --- | ---: | ---: | ---: | ---: | ---: | --- |"]
    notes = []
    for c in results:
        if c.failure:
            lines.append(f"| {c.product} | {c.n_parts} | - | - | - | - | not measured: no plan |")
            notes.append(f"- {c.product}: {c.failure.splitlines()[0][:200]}")
            continue
        lines.append(f"| {c.product} | {c.n_parts} | {c.steps} | {c.culled_s:.2f} | {c.whole_s:.2f} | "
                     f"{c.ratio:.2f} | {'yes' if c.identical else 'NO'} |")
        notes += [f"- {c.product}: {d}" for d in c.differences]
    return "\n".join(lines) + "\n" + ("\n" + "\n".join(notes) + "\n" if notes else "")


def format_sweep(s: SweepResult) -> str:
    """Markdown: :func:`asmplan.sim.sweep.format_throughput` of the sweep."""
    from .throughput import format_throughput

    if s.failure:
        return f"Not measured: {s.failure.splitlines()[0][:200]}\n"
    return (f"One task = one sample of `{s.product}` (every step simulated at {s.fidelity.upper()}, "
            f"product geometry rebuilt per sample); {s.n_tasks} tasks per executor.\n\n"
            + format_throughput(s.rows))


def accuracy_plot_png(acc: AccuracyResult) -> bytes:
    """PNG bytes: accuracy vs wall time, one panel per figure, one point per preset/scenario."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    names = ["seed_force_mae_N", "slip_threshold_error", "insertion_depth_error_m", "fit_penetration_m"]
    scale = {"seed_force_mae_N": (1.0, "N"), "slip_threshold_error": (100.0, "%"),
             "insertion_depth_error_m": (1e3, "mm"), "fit_penetration_m": (1e3, "mm")}
    colours = {"fast": "tab:red", "balanced": "tab:blue", "accurate": "tab:green"}
    fig = Figure(figsize=(10, 7))
    axes = fig.subplots(2, 2)
    for ax, name in zip(axes.ravel(), names, strict=True):
        k, unit = scale[name]
        for f in acc.figures:
            if f.figure != name:
                continue
            y = max(abs(f.value) * k, 1e-6 * k if unit != "%" else 1e-3)
            ax.scatter(f.wall_s, y, color=colours.get(f.preset, "k"),
                       marker="o" if f.asserted else "x", label=f.preset)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel(f"|error| ({unit})")
        ax.set_title(_FIGURE_LABEL[name], fontsize=10)
        handles, labels = ax.get_legend_handles_labels()
        uniq = dict(zip(labels, handles, strict=True))
        ax.legend(uniq.values(), uniq.keys(), fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("Accuracy vs cost per preset (x: below the preset's resolution, not asserted; "
                 "errors below 1 um drawn at 1 um)", fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()



# ---------------------------------------------------------------------------------------------
# reading large product files
# ---------------------------------------------------------------------------------------------
READ_PARTS = 2000
READ_RUNS = 5


@dataclass(frozen=True)
class ReadTiming:
    """Reading one generated product file, ``runs`` times: medians (s) of the YAML reader
    alone (text to located values), of ``load_product`` (reader, schema, model and the
    consistency checks; wall and CPU time: the machine is shared), and of PyYAML's pure-Python
    ``compose`` (the former reader) for the ratio."""

    n_parts: int
    n_mates: int
    size_bytes: int
    runs: int
    parse_s: float
    load_s: float
    load_min_s: float
    load_max_s: float
    load_cpu_s: float
    pure_python_compose_s: float


def run_read(n_parts: int = READ_PARTS, runs: int = READ_RUNS, seed: int = 0) -> ReadTiming:
    """Time reading the generated ``n_parts`` product (see :class:`ReadTiming`)."""
    import statistics
    import tempfile

    import yaml

    from asmplan.knowledge.generator import generate_product, product_yaml
    from asmplan.knowledge.loader import load_product
    from asmplan.knowledge.yamlsource import parse_located

    text = product_yaml(generate_product(n_parts, seed))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"generated_{n_parts}.yaml"
        path.write_text(text, encoding="utf-8")
        parse, load, cpu = [], [], []
        product = None
        for _ in range(runs):
            t0 = time.perf_counter()
            parse_located(text, path.name)
            t1 = time.perf_counter()
            c1 = time.process_time()
            product = load_product(path)
            cpu.append(time.process_time() - c1)
            load.append(time.perf_counter() - t1)
            parse.append(t1 - t0)
        t0 = time.perf_counter()
        yaml.compose(text, Loader=yaml.SafeLoader)
        pure = time.perf_counter() - t0
    assert product is not None
    return ReadTiming(n_parts, len(product.mates), len(text.encode()), runs, statistics.median(parse),
                      statistics.median(load), min(load), max(load), statistics.median(cpu), pure)


def format_read(r: ReadTiming) -> str:
    return "\n".join([
        "| product | file | YAML reader (median) | load_product (median, min-max) | load_product CPU "
        "(median) | former reader: PyYAML pure-Python compose alone | ratio |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
        f"| generated, {r.n_parts} parts, {r.n_mates} mates | {r.size_bytes / 1e6:.2f} MB | "
        f"{r.parse_s:.2f} s | {r.load_s:.2f} s ({r.load_min_s:.2f}-{r.load_max_s:.2f} s, {r.runs} runs) | "
        f"{r.load_cpu_s:.2f} s | {r.pure_python_compose_s:.2f} s | "
        f"{r.pure_python_compose_s / r.load_s:.1f}x |", ""])

@dataclass
class BenchReport:
    """Everything one ``asmplan bench`` run measured (sections not run stay None)."""

    quick: bool
    machine: dict[str, str]
    accuracy: AccuracyResult | None = None
    seed: SeedRunTiming | None = None
    planning: PlanningResult | None = None
    arm: list[Any] | None = None
    scaling: list[ScalingRow] | None = None
    culling: list[CullingResult] | None = None
    sweep: SweepResult | None = None
    read: ReadTiming | None = None
    cad_import: list[Any] | None = None
    fits: Any | None = None
    regressions: list[Regression] = field(default_factory=list)
    started: str = ""
    wall_s: float = 0.0
    command: str = ""


def format_markdown(rep: BenchReport, plot_name: str | None = None) -> str:
    """docs/benchmarks.md: machine, how to reproduce, every table of the run."""
    out = ["# Benchmarks", "",
           f"Generated by `{rep.command}` on {rep.started} ({rep.wall_s / 60:.1f} min). "
           "Every figure below comes from this one run; ratios are measured in the same run. "
           "Accuracy figures are asserted against the bounds listed at the end (exit code 1 and "
           "`REGRESSION: ...` otherwise); times are reported, never asserted.", "",
           "## Machine", ""]
    out += [f"- {k}: {v}" for k, v in rep.machine.items()]
    out += ["", "## Reproduce", "", "```bash",
            "bash dev.sh bench                 # full run: writes docs/benchmarks.md and docs/benchmarks.png",
            "bash dev.sh bench --quick         # CI: accuracy at FAST and BALANCED, asserted (~1 min)",
            "asmplan bench --sections planning,scaling --out /tmp/b.md   # a subset",
            "```", ""]
    if rep.accuracy is not None:
        out += ["## Accuracy vs cost per preset", "",
                "Scenarios in `bench/suite.py` (the validation scenes of `tests/sim`, docs/physics.md). "
                "The insertion reference is ACCURATE with a 16x smaller time step; figures of a scenario "
                "below a preset's `min_resolvable_clearance_m` are reported but not asserted.", "",
                format_accuracy_summary(rep.accuracy), format_accuracy(rep.accuracy)]
        if plot_name:
            out += [f"![accuracy vs cost]({plot_name})", ""]
        if rep.accuracy.peers:
            out += ["## PyBullet and MuJoCo side by side", "",
                    "`bench.suite.peer_rows()`: every validation scene in asmplan's PyBullet "
                    "(BALANCED) and in MuJoCo (`asmplan.sim.peers`, extra `peers`) at the same "
                    "time step and its recommended stiff-contact settings (elliptic cone, "
                    "impratio 10, solref 2 dt, noslip 20), each against its analytic answer; "
                    "cost = wall seconds per simulated second. Where PyBullet is behind, the "
                    "last column says so (docs/physics.md explains each).", "",
                    format_peers(rep.accuracy.peers, "balanced")]
    if rep.fits is not None:
        from .fits import format_fits

        out += ["## Clearance fits (issue 17)", "",
                "`bench/fits.py`: for each fit a generated product (a steel pin into a fixtured "
                "steel block, both unchamfered) planned once, its insertion simulated through the "
                "whole pipeline at each preset and at the reference (ACCURATE at 1/8000 s) with "
                "a robot pose error e across the axis: on the axis and c/4 off (inside the "
                "capture radius c/2: inserted) and c off (outside: stays on the rim).", "",
                format_fits(rep.fits)]
    if rep.seed is not None:
        out += ["## The seed workstation end to end", "",
                "`bench.suite.run_seed_timing()`: the bundled seed workstation (4 parts, 3 "
                "insertions) at FAST without the report, the issue's < 2 s target; the CLI row "
                "is what a user waits for. Then its whole job at BALANCED with the report "
                "(issues 16/17: <= 5 s on 2 cores).", "", format_seed_timing(rep.seed)]
    if rep.planning is not None:
        out += ["## Motion planning per step vs direct OMPL insertion", "",
                "`bench.motion.bench()`: each pick-and-insert step of the bundled examples "
                "(one run), against OMPL planning from the lifted pose straight into the seated pose with "
                "a 2 s budget; `>=` marks a lower bound (the baseline failed within its budget).", "",
                format_planning(rep.planning), "<details><summary>per step</summary>", "", "```",
                rep.planning.text.strip(), "```", "", "</details>", ""]
    if rep.arm is not None:
        from .arm import format_arm

        out += ["## The arm: inverse kinematics and planning per step", "",
                "`bench/arm.py` `bench_arm()`: IK along the examples' step trajectories as "
                "planning tracks them (`ArmModel.track`, CPU per distinct TCP pose, median over "
                "the steps) and the seeded all-branch IK (each grasp's first pose); planning "
                "time per pick-and-insert step with the xArm 6 (IK along the whole trajectory, "
                "arm collisions, joint-limited timing) and without the arm, 5 interleaved runs, "
                "medians. Targets: IK <= 1 ms median, plan <= 50 ms per step median on the seed "
                "workstation.", "", format_arm(rep.arm)]
    if rep.scaling is not None:
        out += ["## Scaling on generated products", "",
                f"`asmplan.knowledge.generator.generate_product(n, seed=0, fit={SCALING_FIT_MM})` "
                f"(every pin {SCALING_FIT_MM} mm diametral clearance, above FAST's interference "
                "resolution), written "
                "to YAML, then the whole job (`asmplan.pipeline.run_product` at FAST, the preset the "
                "scaling targets name, each step simulated in a worker process while the next are "
                "planned, and `write_outputs` with the HTML report), one run per size. validation = "
                "load and "
                "validate the YAML; sequence includes building the part geometry; simulate is the "
                "time simulation took after planning ended; a size that does "
                "not plan is shown with its failure reason.", "",
                format_scaling(rep.scaling)]
    if rep.culling is not None:
        out += ["## Scene culling", "",
                f"The plan of the generated {CULLING_SIZE}-part product (or, while that does not plan, "
                "of the largest bundled example) simulated with each step's scene holding only the "
                "bodies it needs (`simulate_plan(cull=True)`) and with every part loaded as the "
                "simulator would naively model it (`cull=False`: placed parts as the preset models "
                "partners - static at FAST -, parts not yet placed dynamic at their start poses), "
                "at FAST, both in one process, over the plan's last 3 steps (the fullest scenes); "
                "outcomes compared step by step (success and failed criteria).", "",
                format_culling(rep.culling)]
    if rep.sweep is not None:
        out += ["## Sweep throughput", "",
                "`bench.throughput.throughput()`: the same tasks through a local process pool with 1 and 2 "
                "workers and a local 2-worker Dask cluster, after a warm-up (start-up column).", "",
                format_sweep(rep.sweep)]
    if rep.read is not None:
        out += ["## Reading a large product file", "",
                f"`bench.suite.run_read()`: `generate_product({rep.read.n_parts}, seed=0)` written to YAML "
                "and read back: the YAML reader (libyaml events composed into located values, "
                "`knowledge/yamlsource.py`) and the whole `load_product` (schema, model, consistency "
                "checks); the last column is PyYAML's pure-Python `compose` of the same text, which "
                "the reader used before.", "", format_read(rep.read)]
    if rep.cad_import is not None:
        from .cad_import import format_import

        out += ["## CAD import", "",
                "`bench.cad_import.bench()`: `import_assembly` (read, recognise features, propose "
                "mates) on the 20-part STEP fixture `tests/fixtures/cad/two_stations_20.step` and two "
                "mesh folders, 3 runs each; the target is < 10 s for a 20-part STEP.", "",
                format_import(rep.cad_import)]
    out += ["## Accuracy bounds", "", "| figure | preset | bound | reason |", "| --- | --- | ---: | --- |"]
    out += [f"| {b.figure} | {b.preset} | {_fmt(b.limit, b.unit).lstrip('+')} | {b.reason} |" for b in BOUNDS]
    out += ["", "Regressions in this run: " + ("none" if not rep.regressions else
                                               "; ".join(str(r) for r in rep.regressions)), ""]
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------
# PyBullet and MuJoCo side by side (issue 16)


@dataclass(frozen=True)
class PeerRow:
    """One validation scene in both engines: the figure's error against its analytic answer
    (same unit, ``unit``) and the wall seconds per simulated second of each engine."""

    scene: str
    analytic: str
    unit: str
    pybullet_error: float
    mujoco_error: float
    pybullet_cost: float
    mujoco_cost: float


def _bisect_force(slips: Callable[[float], tuple[bool, float, float]], analytic: float,
                  iterations: int) -> tuple[float, float, float]:
    """Smallest holding force by bisection in [0.5, 2] x ``analytic``: (relative error, wall
    s, simulated s) summed over the runs; ``slips(F)`` gives (slipped, wall, simulated)."""
    lo, hi = 0.5 * analytic, 2.0 * analytic
    wall = sim = 0.0
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        slipped, w, s = slips(mid)
        wall, sim = wall + w, sim + s
        if slipped:
            lo = mid
        else:
            hi = mid
    return hi / analytic - 1.0, wall, sim


def peer_rows(fid: Any, iterations: int = 8, log: Callable[[str], None] | None = None
              ) -> list[PeerRow]:
    """Every validation scene at ``fid`` (PyBullet) and in MuJoCo at the same time step
    (:mod:`asmplan.sim.peers`, its recommended stiff-contact settings): Whitney jam depth,
    capture boundary, slip threshold at a = 0 / 5 / 20 m/s^2, held drift at three tilts and
    the heavy-on-light stack. Empty when MuJoCo is not installed."""
    import numpy as np

    from asmplan.sim import peers

    from .scenarios import (
        BoxPart,
        G,
        JamScene,
        drift_trajectory,
        entered_depth_m,
        heavy_on_light,
        held_drift_m,
        jam_depth_m,
        lift_slip_m,
        pose,
        slip_trajectory,
        whitney_jam_depth_m,
    )
    from .scenarios import pin_insertion as scene_pin_insertion

    if not peers.available():
        return []
    say = log or (lambda _s: None)
    dt = fid.dt_s
    rows: list[PeerRow] = []
    for c, t_deg in ((0.1e-3, 5.0), (0.1e-3, 2.0), (0.1e-3, 0.5)):
        t = math.radians(t_deg)
        ref = whitney_jam_depth_m(c, t)
        t0 = time.perf_counter()
        got = jam_depth_m(fid, c, t)
        pb_cost = (time.perf_counter() - t0) / JamScene().settle_s
        mj, mj_cost = peers.mujoco_jam_depth_m(dt, c, t)
        rows.append(PeerRow(f"Whitney jam depth, c = {c * 1e3:g} mm, t = {t_deg:g} deg",
                            f"l* = {ref * 1e3:.3f} mm", "m", got - ref, mj - ref, pb_cost,
                            mj_cost))
        say(f"peers: jam {t_deg} deg")
    # capture boundary: 0.5 mm off stays on the rim, 0.02 mm off goes in (c/2 = 0.1 mm)
    mism_pb = mism_mj = 0
    wall_pb = wall_mj = 0.0
    for e, expect_in in ((0.5e-3, False), (0.02e-3, True)):
        t0 = time.perf_counter()
        record, _ = scene_pin_insertion(fid, 0.1e-3, lateral_offset_m=e)
        wall_pb += (time.perf_counter() - t0) / float(record.t_s[-1])
        mism_pb += int((entered_depth_m(record) > 2e-3) != expect_in)
        got_mj, cost = peers.mujoco_capture_entered_m(dt, 0.1e-3, e)
        wall_mj += cost
        mism_mj += int((got_mj > 2e-3) != expect_in)
    rows.append(PeerRow("capture boundary, unchamfered pin 0.5 / 0.02 mm off, c/2 = 0.1 mm",
                        "abs(e0) < c/2: rim / in", "wrong verdicts", mism_pb, mism_mj,
                        wall_pb / 2, wall_mj / 2))
    say("peers: capture")
    # slip threshold
    part = BoxPart(mass_kg=0.1, friction=0.5)
    mu = 1.0 * part.friction
    for a in SLIP_ACCELS_MPS2:
        analytic = part.mass_kg * (G + a) / (2 * mu)

        def pb_slips(F: float, a: float = a) -> tuple[bool, float, float]:
            t0 = time.perf_counter()
            slipped = lift_slip_m(fid, part, F, a) >= 0.2e-3
            T = slip_trajectory(pose((0.0, 0.0, 0.025)), F, a)
            return slipped, time.perf_counter() - t0, float(T.t_s[-1])

        def mj_slips(F: float, a: float = a) -> tuple[bool, float, float]:
            T_tcp = pose((0.0, 0.0, part.size_m[2] / 2.0))
            part_standing = np.eye(4)
            part_standing[2, 3] = part.size_m[2] / 2.0
            traj = slip_trajectory(T_tcp, F, a)
            ts, rel, cost = peers.mujoco_gripper_run(
                dt, traj.t_s, traj.T_world_gripper, traj.clamp_force_N, part.size_m,
                part.mass_kg, part_standing, part.friction,
                part.size_m[1] + 0.004, True)
            ref_t = next(p.t_end_s for p in traj.phases if p.name == "hold")
            k = int(np.searchsorted(ts, ref_t))
            slip = float(np.max(np.linalg.norm(rel[k:, :3, 3] - rel[k, :3, 3], axis=1)))
            return slip >= 0.2e-3, cost * float(traj.t_s[-1]), float(traj.t_s[-1])

        e_pb, w_pb, s_pb = _bisect_force(pb_slips, analytic, iterations)
        e_mj, w_mj, s_mj = _bisect_force(mj_slips, analytic, iterations)
        rows.append(PeerRow(f"slip threshold, a = {a:g} m/s^2 (100 g box, mu 0.5)",
                            f"m (g + a) / (2 mu) = {analytic:.3f} N", "", e_pb, e_mj,
                            w_pb / s_pb, w_mj / s_mj))
        say(f"peers: slip a = {a}")
    # held drift
    for tilt in DRIFT_TILTS_RAD:
        t0 = time.perf_counter()
        d_pb = held_drift_m(fid, tilt, coupled=True)
        traj = drift_trajectory(tilt)
        pb_cost = (time.perf_counter() - t0) / float(traj.t_s[-1])
        bp = BoxPart()
        ts, rel, mj_cost = peers.mujoco_gripper_run(
            dt, traj.t_s, traj.T_world_gripper, traj.clamp_force_N, bp.size_m, bp.mass_kg,
            traj.T_world_gripper[0], bp.friction, bp.size_m[1], False)
        span = (ts >= 0.1) & (ts <= 3.5)
        d_mj = float(np.ptp(rel[span, 1, 3]))
        rows.append(PeerRow(f"held drift along the closing axis, tilted {tilt:.2f} rad",
                            "0", "m", d_pb, d_mj, pb_cost, mj_cost))
        say(f"peers: drift {tilt:.2f}")
    # heavy on light
    t0 = time.perf_counter()
    v_pb, _sink_pb = heavy_on_light(fid)
    pb_cost = time.perf_counter() - t0
    v_mj, _sink_mj, mj_cost = peers.mujoco_heavy_on_light(dt)
    rows.append(PeerRow("100 kg block on four 1 g cubes: fastest cube", "0 m/s", "m/s",
                        v_pb, v_mj, pb_cost, mj_cost))
    return rows


def format_peers(rows: Sequence[PeerRow], preset_name: str) -> str:
    """Markdown: both engines' errors and costs per scene, with who is ahead."""
    lines = [f"| scene | analytic | PyBullet {preset_name} error | MuJoCo error | PyBullet "
             f"wall s / sim s | MuJoCo wall s / sim s | more accurate |",
             "| --- | --- | ---: | ---: | ---: | ---: | --- |"]
    for r in rows:
        def v(x: float, r: PeerRow = r) -> str:
            if r.unit == "m":
                return f"{x * 1e3:+.3f} mm"
            if r.unit == "":
                return f"{x * 100:+.2f} %"
            return f"{x:g} {r.unit}"
        a, b = abs(r.pybullet_error), abs(r.mujoco_error)
        # within 1 um, 0.6 % (one bisection step) or 0.01 m/s the two are not told apart
        tol = {"m": 1e-6, "": 0.006}.get(r.unit, 0.01)
        ahead = "equal" if abs(a - b) <= tol else (
            "PyBullet" if a < b else "MuJoCo")
        lines.append(f"| {r.scene} | {r.analytic} | {v(r.pybullet_error)} | "
                     f"{v(r.mujoco_error)} | {r.pybullet_cost:.2f} | {r.mujoco_cost:.2f} | "
                     f"{ahead} |")
    return "\n".join(lines) + "\n"
