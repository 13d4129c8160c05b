"""Clearance fits judged by the physics presets against a converged reference and geometry.

Issue 17, item 1: every mate whose diametral clearance c is >= 5 um must be judged at
BALANCED (and ACCURATE) as a converged reference judges it. This section runs the REAL
pipeline (a product written as YAML, planned once, each step simulated as ``asmplan run``
simulates it: scene culling, the coupled gripper, the planner's insertion speed) on one
steel pin in a fixtured steel block per fit, at each preset and at the reference (ACCURATE
with a 16x smaller time step, :func:`bench.suite.reference_fidelity`), in three cases whose
answer geometry gives:

``aligned``
    the pin's axis on the hole's (no pose error): inserted to full depth;
``off``
    the pin displaced across the axis by ``c`` (twice the capture radius c/2 of an
    unchamfered pin in an unchamfered hole): stays on the rim (no capture), entered ~0;
``inside``
    displaced by c/4 (inside the capture radius): inserted;
``tilted``
    tilted by :data:`TILT_DEG` about the pin's tip (the TCP tilted and displaced so that the
    tip stays on the axis), held by a stiff robot: Whitney's two-point contact stops it at
    l* = (D - d cos t) / sin t (:func:`bench.scenarios.whitney_jam_depth_m`): jammed.
    Its verdict is asserted against the reference; its depth against Whitney is reported
    (the jam depth at small tilts is issue 16's).

Both features are unchamfered, so the capture boundary |e| < c/2 is the fit's own; with the
0.5 mm chamfers of a real product it moves out by the chamfer widths and no longer tests the
clearance. The verdict is the step's (success or its first typed failure); the depth is the
insertion depth reached (engagement length minus the remaining axial error).
"""

from __future__ import annotations

import math
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

FITS: tuple[tuple[float, float], ...] = ((6e-3, 5e-6), (8e-3, 10e-6), (12e-3, 25e-6),
                                         (20e-3, 50e-6))
"""(pin diameter, diametral clearance) of the benchmarked fits, m."""

QUICK_FITS: tuple[tuple[float, float], ...] = ((6e-3, 5e-6),)
"""The fit ``asmplan bench --quick`` runs (the smallest clearance), at BALANCED only, against
capture geometry (no reference run)."""

CASES: tuple[str, ...] = ("aligned", "off", "inside", "tilted")
TILT_DEG = 0.5
"""Tilt of the ``tilted`` case, deg."""
HOLE_DEPTH_FACTOR = 1.5
"""Hole depth / pin diameter (engaged length of the generated fits)."""
GRIPPER_MIN_FORCE_N = 15.0
"""A realistic least clamp force for the bench gripper (``resources.gripper.min_force``), N:
25 % of its 60 N maximum. Catalogue parallel grippers cannot squeeze gently below about a
quarter of their maximum: Robotiq's 3-Finger Adaptive Gripper 15-60 N ("0x00 force does not
mean zero force; it is the minimum force that the Gripper can apply", instruction manual,
FORCE register), Weiss Robotics' IEG modules "recommended minimum gripping force is 25 % of
the nominal gripping force" (manual 5.1.2), DH-Robotics PGC-140 40-140 N, AG-95 45-160 N and
RGI-14 10-35 N (data sheets). Not in the bench product by default (``product_yaml``'s
``min_force_N``): at this clamp Bullet's pads tip the 6 mm pin 0.73 mrad at the first touch
and the 5 um fit stops on the rim at BALANCED (docs/physics.md, "Exact fit contact", the
gripper's least clamp force)."""


def product_yaml(diameter_m: float, clearance_m: float, chamfer_m: float = 0.0,
                 min_force_N: float = 0.0) -> str:
    """A product as a process engineer writes it: a fixtured steel block with one blind hole
    and a steel pin (a cylinder standing on the tray) that goes into it with diametral
    clearance ``clearance_m``; no chamfers by default.

    The gripper gives 60 N at most and ``min_force_N`` at least (0: none declared, the
    planner commands what the pin needs, 0.06-2.1 N here; a real gripper's least force is
    about a quarter of its maximum, :data:`GRIPPER_MIN_FORCE_N`)."""
    d = diameter_m * 1e3
    depth = round(HOLE_DEPTH_FACTOR * d, 3)
    pin_len = round(depth + d, 3)
    block = round(max(40.0, 3 * d), 3)
    block_h = round(depth + 10.0, 3)
    ch = f", chamfer: {chamfer_m * 1e3:g}" if chamfer_m > 0 else ""
    finger = round(min(25.0, 0.8 * d + 8), 1)
    least = f"\n    min_force: {min_force_N:g}" if min_force_N > 0 else ""
    return f"""asmplan: 1
product: fit_d{d:g}_c{clearance_m * 1e6:g}um
units: {{length: mm, mass: g}}
parts:
  - name: block
    material: steel
    geometry:
      type: box
      size: [{block}, {block}, {block_h}]
      holes:
        - {{name: hole, at: [0, 0, {block_h / 2:g}], diameter: {d:g}, depth: {depth:g}{ch}}}
    pose: {{xyz: [0, 0, {block_h / 2:g}]}}
    fixtured: true
  - name: pin
    material: steel
    geometry: {{type: cylinder, diameter: {d:g}, length: {pin_len:g}}}
    features:
      - {{name: tip, type: pin, at: [0, 0, {depth - pin_len / 2:g}], axis: [0, 0, -1],
         diameter: {d:g}, length: {depth:g}{ch}}}
    pose: {{xyz: [0, 0, {block_h + pin_len / 2 - depth:g}]}}
    start: {{location: tray, xyz: [{block + 60:g}, 80, {pin_len / 2:g}]}}
mates:
  - {{pin: pin.tip, hole: block.hole, clearance: {clearance_m * 1e3:g}}}
precedence:
  base: block
resources:
  gripper:
    stroke: {round(d + 40, 1):g}
    finger: {{size: [{finger:g}, 8, 25], friction: 1.0}}
    max_force: 60{least}
  table: {{size: [600, 400, 40]}}
  fixtures: [{{name: vise, holds: block}}]
"""


@dataclass(frozen=True)
class FitRun:
    """One simulated insertion of one fit at one fidelity and one case."""

    diameter_m: float
    clearance_m: float
    case: str
    fidelity: str
    lateral_m: float
    verdict: str
    depth_m: float
    engagement_m: float
    wall_s: float
    reasons: tuple[str, ...] = ()
    expected_depth_m: float = float("nan")
    """Depth geometry gives: the engagement (inserted), 0 (rim) or Whitney's l* (jammed)."""

    @property
    def inserted(self) -> bool:
        return self.verdict == "inserted"


def expected_verdict(case: str) -> str:
    """The verdict capture geometry gives (unchamfered pin and hole, |e| vs c/2)."""
    return {"off": "rim_stop", "tilted": "jammed"}.get(case, "inserted")


def case_lateral_m(case: str, clearance_m: float) -> float:
    """Lateral pose error of a case, m (see the module docstring)."""
    return {"aligned": 0.0, "off": clearance_m, "inside": 0.25 * clearance_m,
            "tilted": 0.0}[case]


def _verdict(outcome: Any) -> str:
    if outcome is None:
        return "not simulated"
    if outcome.success:
        return "inserted"
    failures = getattr(outcome, "failures", ())
    return failures[0].code if failures else "failed"


def _depth_m(outcome: Any, engagement_m: float) -> float:
    """Insertion depth reached: a failure's own depth (rim_stop, jammed), else the engagement
    less the final axial error."""
    if outcome is None:
        return float("nan")
    for f in getattr(outcome, "failures", ()):
        if f.code in ("rim_stop", "jammed"):
            return float(f.value)
    return engagement_m - float(outcome.final_axial_error_m)


def run_fit(diameter_m: float, clearance_m: float, fidelities: Sequence[Any],
            cases: Sequence[str] = CASES, log: Callable[[str], None] | None = None
            ) -> list[FitRun]:
    """Plan the fit's product once, then simulate its insertion step at every fidelity and
    case; returns one :class:`FitRun` each."""
    from asmplan.knowledge.loader import load_product
    from asmplan.pipeline import RunSettings, run_product
    from asmplan.sim.pose_error import PoseError
    from asmplan.sim.simulate import simulate_plan

    from .scenarios import whitney_jam_depth_m

    say = log or (lambda _s: None)
    with tempfile.TemporaryDirectory(prefix="asmplan-bench-fit-") as tmp:
        path = Path(tmp) / "fit.yaml"
        path.write_text(product_yaml(diameter_m, clearance_m))
        product = load_product(path)
    planned = run_product(product, RunSettings(simulate=False, workers=1))
    if planned.plan is None:
        raise RuntimeError(f"fit d {diameter_m * 1e3:g} mm c {clearance_m * 1e6:g} um: "
                           f"planning failed: {planned.failure}")
    step = next(i for i, s in enumerate(planned.plan.steps) if s.kind == "insert")
    engagement = HOLE_DEPTH_FACTOR * diameter_m
    # the tilted case turns the TCP about the pin's tip: the TCP's height above the tip when
    # seated (the tip on the hole floor, 10 mm above the table: product_yaml's block)
    traj = planned.plan.steps[step].trajectory
    assert traj is not None
    lower = next(ph for ph in traj.phases if ph.name == "lower")
    k = int(np.searchsorted(traj.t_s, lower.t_end_s)) - 1
    lever = float(traj.T_world_gripper[k][2, 3]) - 10e-3
    t = math.radians(TILT_DEG)
    out = []
    for fid in fidelities:
        for case in cases:
            e = case_lateral_m(case, clearance_m)
            err = (PoseError((-lever * math.sin(t), 0.0), (0.0, t)) if case == "tilted"
                   else PoseError((e, 0.0), (0.0, 0.0)))
            want = {"inserted": engagement, "rim_stop": 0.0,
                    "jammed": whitney_jam_depth_m(clearance_m, t, diameter_m)}[
                        expected_verdict(case)]
            t0 = time.perf_counter()
            res = simulate_plan(planned.plan, product, planned.geometry, fid, steps=[step],
                                workers=1, pose_error=err)
            wall = time.perf_counter() - t0
            sr = res.steps[0] if len(res.steps) == 1 else res.steps[step]
            o = sr.outcome
            depth = _depth_m(o, engagement)
            run = FitRun(diameter_m, clearance_m, case, fid.name, e, _verdict(o), depth,
                         engagement, wall, tuple(o.reasons) if o is not None else (), want)
            say(f"fit d {diameter_m * 1e3:g} mm c {clearance_m * 1e6:g} um {case} at "
                f"{fid.name}: {run.verdict}, depth {depth * 1e3:.3f} mm, {wall:.1f} s")
            out.append(run)
    return out


REFERENCE_DT_S = 1.0 / 8000.0
"""Time step of the fits' converged reference (ACCURATE settings otherwise): 8x BALANCED's,
2x ACCURATE's; ACCURATE agreeing with it is the convergence check (the accuracy section's
1/16000 s costs ~60-120 s per step of these products)."""


def fits_reference_fidelity() -> Any:
    """ACCURATE at :data:`REFERENCE_DT_S` (record interval kept at 4 ms), with no body put
    to sleep (a reference models everything; :mod:`asmplan.sim.rest`) and Bullet's own
    contact (no exact fit contact: independent of the presets that use it)."""
    import dataclasses

    from asmplan.sim.fidelity import ACCURATE

    return dataclasses.replace(ACCURATE, name=f"reference (1/{round(1 / REFERENCE_DT_S)} s)",
                               dt_s=REFERENCE_DT_S,
                               record_every_steps=max(1, round(0.004 / REFERENCE_DT_S)),
                               rest_window_s=0.0, feature_contact=False)


@dataclass(frozen=True)
class SeedJob:
    """The seed workstation's whole job (``asmplan run``, report included) at one preset."""

    fidelity: str
    exit_code: int
    wall_s: float
    stages_s: dict[str, float]
    steps: tuple[tuple[str, str, float, float], ...]
    """(part, verdict, depth m, wall s of its simulation) per simulated step."""
    warnings: tuple[str, ...]


@dataclass(frozen=True)
class FitsResult:
    """Everything the fits section measured."""

    runs: tuple[FitRun, ...]
    seed: tuple[SeedJob, ...]
    figures: tuple[Any, ...]


def run_seed_job(fidelity: str, report: bool = True) -> SeedJob:
    """``asmplan run`` (the bundled seed workstation) at ``fidelity`` in a subprocess, as a
    user runs it (``-j`` default: one process per core), timed from outside."""
    import json
    import subprocess
    import sys

    with tempfile.TemporaryDirectory(prefix="asmplan-bench-seedjob-") as tmp:
        out = Path(tmp) / "out"
        cmd = [sys.executable, "-m", "asmplan", "run", "--fidelity", fidelity, "-o", str(out)]
        if not report:
            cmd.append("--no-report")
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        steps: list[tuple[str, str, float, float]] = []
        stages: dict[str, float] = {}
        warnings: tuple[str, ...] = ()
        res_path = out / "results.json"
        if res_path.is_file():
            doc = json.loads(res_path.read_text())
            for st in doc.get("steps", []):
                o = st.get("outcome")
                if not o:
                    continue
                fails = o.get("failures") or []
                verdict = "inserted" if o.get("success") else (fails[0]["code"] if fails else "failed")
                steps.append((st.get("part", "?"), verdict,
                              float(o.get("final_axial_error_m", float("nan"))), float("nan")))
            warnings = tuple(w for w in doc.get("warnings", []) if "resolv" in w)
        # "results and report in out/ (sequence 1.2 s, ..., report 12.7 s; CPU sequence ...)"
        from .cost import cli_stage_times

        stages = cli_stage_times(proc.stdout)[0]
    return SeedJob(fidelity, proc.returncode, wall, stages, tuple(steps), warnings)


def _figures(runs: Sequence[FitRun], reference: dict[tuple[float, float, str], FitRun]
             ) -> list[Any]:
    """``fit_verdict_mismatch`` per run: 1 when its verdict differs from the reference's or
    from capture geometry's; asserted where the fit is at or above the preset's resolution."""
    from asmplan.sim.fidelity import PRESETS

    from .bounds import AccuracyFigure

    out = []
    for r in runs:
        ref = reference.get((r.diameter_m, r.clearance_m, r.case))
        fid = PRESETS.get(r.fidelity)
        if fid is None:
            continue
        expect = expected_verdict(r.case)
        wrong = r.verdict != expect or (ref is not None and r.verdict != ref.verdict)
        resolvable = r.clearance_m >= fid.min_resolvable_clearance_m - 1e-12
        note = (f"{r.verdict}, depth {r.depth_m * 1e3:.3f} mm; geometry: {expect} "
                f"{r.expected_depth_m * 1e3:.3f} mm"
                + ("" if ref is None else f"; reference: {ref.verdict}, "
                   f"{ref.depth_m * 1e3:.3f} mm")
                + ("" if resolvable else f"; below the preset's resolution "
                   f"({fid.min_resolvable_clearance_m * 1e3:.3f} mm)"))
        out.append(AccuracyFigure(
            r.fidelity, f"fit d {r.diameter_m * 1e3:g} mm, c {r.clearance_m * 1e6:g} um, {r.case} "
            f"(e = {r.lateral_m * 1e6:g} um)", "fit_verdict_mismatch", float(wrong), "", r.wall_s,
            resolvable, note))
    return out


def run_fits(fits: Sequence[tuple[float, float]] = FITS,
             presets: Sequence[str] = ("fast", "balanced", "accurate"), *,
             reference: bool = True, seed_job: bool = True,
             log: Callable[[str], None] | None = None) -> FitsResult:
    """The fits section: every fit of ``fits`` at every preset (and the reference), every
    case; then the seed workstation's whole job at BALANCED (with the report)."""
    from asmplan.sim.fidelity import preset

    fids = [preset(p) for p in presets]
    if reference:
        fids.append(fits_reference_fidelity())
    runs: list[FitRun] = []
    for d, c in fits:
        runs.extend(run_fit(d, c, fids, CASES, log=log))
    ref = {(r.diameter_m, r.clearance_m, r.case): r for r in runs
           if r.fidelity.startswith("reference")}
    seed: tuple[SeedJob, ...] = ()
    if seed_job:
        say = log or (lambda _s: None)
        job = run_seed_job("balanced")
        seed = (job,)
        say(f"seed workstation at balanced with the report: {job.wall_s:.1f} s")
    return FitsResult(tuple(runs), seed, tuple(_figures(runs, ref)))


# Complexity above C (radon): a report: the verdict table (one cell per fit, case and fidelity),
# the differing verdicts, the median costs and the seed runs, each an optional part.
def format_fits(res: FitsResult) -> str:
    """Markdown tables: per fit and case, verdict / depth / wall time per fidelity; the seed."""
    fids = list(dict.fromkeys(r.fidelity for r in res.runs))
    head = ("| pin d | c (diam.) | case (e) | geometry | "
            + " | ".join(fids) + " |")
    rows = [head, "| ---: | ---: | --- | --- | " + " | ".join("---" for _ in fids) + " |"]
    keys = list(dict.fromkeys((r.diameter_m, r.clearance_m, r.case) for r in res.runs))
    by = {(r.diameter_m, r.clearance_m, r.case, r.fidelity): r for r in res.runs}
    for d, c, case in keys:
        cells = []
        for f in fids:
            r = by.get((d, c, case, f))
            cells.append("-" if r is None else
                         f"{r.verdict} {r.depth_m * 1e3:.3f} mm, {r.wall_s:.1f} s")
        e = case_lateral_m(case, c)
        first = next(r for r in res.runs if (r.diameter_m, r.clearance_m, r.case) == (d, c, case))
        how = f"{TILT_DEG:g} deg" if case == "tilted" else f"e = {e * 1e6:g} um"
        rows.append(f"| {d * 1e3:g} mm | {c * 1e6:g} um | {case} ({how}) | "
                    f"{expected_verdict(case)} {first.expected_depth_m * 1e3:.3f} mm | "
                    + " | ".join(cells) + " |")
    out = ["Each cell: verdict, insertion depth reached, wall time of the step's simulation "
           "(scene build included; the plan is made once per fit).", "", *rows, ""]
    wrong = [f for f in res.figures if f.asserted and f.value]
    out.append(f"Verdicts differing from geometry or the reference where the preset resolves the "
               f"fit: {len(wrong)}" + ("" if not wrong else ": " + "; ".join(
                   f"{f.preset} {f.scenario}: {f.note}" for f in wrong)))
    out.append("")
    cost = {}
    for f in fids:
        walls = [r.wall_s for r in res.runs if r.fidelity == f]
        if walls:
            import statistics

            cost[f] = statistics.median(walls)
    out.append("Median wall time per step: " + ", ".join(f"{k} {v:.1f} s" for k, v in cost.items())
               + ".")
    out.append("")
    from .cost import SEED_JOB_TARGET_S

    for job in res.seed:
        out.append(f"Seed workstation, `asmplan run --fidelity {job.fidelity}` with the report: "
                   f"exit {job.exit_code}, {job.wall_s:.1f} s wall (target <= "
                   f"{SEED_JOB_TARGET_S:g} s on 2 cores; CPU in the seed section; stages: "
                   + ", ".join(f"{k} {v:.1f} s" for k, v in job.stages_s.items()) + "); "
                   + "; ".join(f"{p}: {v} (axial error {e * 1e3:.3f} mm)" for p, v, e, _ in job.steps)
                   + f"; resolution warnings: {len(job.warnings)}.")
    return "\n".join(out) + "\n"


__all__ = ["CASES", "FITS", "GRIPPER_MIN_FORCE_N", "QUICK_FITS", "REFERENCE_DT_S", "FitRun",
           "FitsResult", "SeedJob", "case_lateral_m", "expected_verdict", "fits_reference_fidelity",
           "format_fits", "product_yaml", "run_fit", "run_fits", "run_seed_job"]
