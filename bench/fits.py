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
    displaced by c/4 (inside the capture radius): inserted.

Both features are unchamfered, so the capture boundary |e| < c/2 is the fit's own; with the
0.5 mm chamfers of a real product it moves out by the chamfer widths and no longer tests the
clearance. The verdict is the step's (success or its first typed failure); the depth is the
insertion depth reached (engagement length minus the remaining axial error).
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

FITS: tuple[tuple[float, float], ...] = ((6e-3, 5e-6), (20e-3, 5e-6), (8e-3, 10e-6),
                                         (12e-3, 25e-6), (20e-3, 50e-6))
"""(pin diameter, diametral clearance) of the benchmarked fits, m."""

QUICK_FITS: tuple[tuple[float, float], ...] = ((6e-3, 5e-6), (20e-3, 50e-6))
"""The fits ``asmplan bench --quick`` runs (the smallest clearance and the largest pin)."""

CASES: tuple[str, ...] = ("aligned", "off", "inside")
HOLE_DEPTH_FACTOR = 1.5
"""Hole depth / pin diameter (engaged length of the generated fits)."""


def product_yaml(diameter_m: float, clearance_m: float, chamfer_m: float = 0.0) -> str:
    """A product as a process engineer writes it: a fixtured steel block with one blind hole
    and a steel pin (a cylinder standing on the tray) that goes into it with diametral
    clearance ``clearance_m``; no chamfers by default."""
    d = diameter_m * 1e3
    depth = round(HOLE_DEPTH_FACTOR * d, 3)
    pin_len = round(depth + d, 3)
    block = round(max(40.0, 3 * d), 3)
    block_h = round(depth + 10.0, 3)
    ch = f", chamfer: {chamfer_m * 1e3:g}" if chamfer_m > 0 else ""
    finger = round(min(25.0, 0.8 * d + 8), 1)
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
    max_force: 60
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

    @property
    def inserted(self) -> bool:
        return self.verdict == "inserted"


def expected_verdict(case: str) -> str:
    """The verdict capture geometry gives (unchamfered pin and hole, |e| vs c/2)."""
    return "rim_stop" if case == "off" else "inserted"


def case_lateral_m(case: str, clearance_m: float) -> float:
    """Lateral pose error of a case, m (see the module docstring)."""
    return {"aligned": 0.0, "off": clearance_m, "inside": 0.25 * clearance_m}[case]


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
    out = []
    for fid in fidelities:
        for case in cases:
            e = case_lateral_m(case, clearance_m)
            t0 = time.perf_counter()
            res = simulate_plan(planned.plan, product, planned.geometry, fid, steps=[step],
                                workers=1, pose_error=PoseError((e, 0.0), (0.0, 0.0)))
            wall = time.perf_counter() - t0
            sr = res.steps[0] if len(res.steps) == 1 else res.steps[step]
            o = sr.outcome
            depth = _depth_m(o, engagement)
            run = FitRun(diameter_m, clearance_m, case, fid.name, e, _verdict(o), depth,
                         engagement, wall, tuple(o.reasons) if o is not None else ())
            say(f"fit d {diameter_m * 1e3:g} mm c {clearance_m * 1e6:g} um {case} at "
                f"{fid.name}: {run.verdict}, depth {depth * 1e3:.3f} mm, {wall:.1f} s")
            out.append(run)
    return out


__all__ = ["CASES", "FITS", "QUICK_FITS", "FitRun", "case_lateral_m", "expected_verdict",
           "product_yaml", "run_fit"]
