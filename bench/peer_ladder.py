"""The jam scenes at equal accuracy: PyBullet (BALANCED, exact fit contact) against MuJoCo
at the time step where MuJoCo first reaches BALANCED's accuracy bound (issue 16, item 6).

At BALANCED's 1 ms MuJoCo's soft contacts sink 0.5-2.5 mm too deep into the jam, and at
0.1 ms 0.02-0.09 mm: comparing costs there compares unequal answers. This ladder runs each
peer-table jam scene (:data:`LADDER_SCENES`) in MuJoCo at :data:`LADDER_DT_S` and reports the
coarsest step within BALANCED's asserted jam bound (``jam_depth_error_m``, 0.01 mm), its cost,
and the cost ratio to PyBullet's; or that no step tried reaches it.

What the ladder changes in the peer, and why (measured, ``tests/sim/test_peers.py``):

* ``ccd_tolerance`` 1e-10 (:data:`LADDER_CCD_TOLERANCE`; MuJoCo's default 1e-6): at the
  default the 0.5 deg jam stays +0.09 mm deep at every step from 0.1 to 0.02 ms (a ~1 um
  contact error times 1/sin t); at 1e-10 it converges with the step, at the same cost. The
  peer at its best, not tuned down.
* pushed :data:`LADDER_SETTLE_S` (2.5 s) instead of the scene's 1 s: the scene caps the peg's
  speed after each step, so a finer step feeds slower (5 mm/s plus push/m x dt: 6.1 mm/s at
  0.01 ms) and the 0.5 deg peg (l* = 11.5 mm) reaches its jam only after ~1.9 s.
  MuJoCo's jam creeps on (its contacts are soft: 14 um/s deeper at 0.1 ms, 2.7 um/s at
  0.02 ms, c = 0.1 mm, 2 deg), which the longer push includes; PyBullet's exact contact
  stops: its depth is the same, bit for bit, after 0.5, 1 and 2.5 s.

Costs are CPU seconds (``time.process_time``) per simulated second, PyBullet's the median of
:data:`PYBULLET_RUNS` runs.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

LADDER_DT_S: tuple[float, ...] = (1e-4, 5e-5, 2e-5, 1e-5)
"""MuJoCo's time steps, coarsest first, s."""
LADDER_SETTLE_S = 2.5
"""How long MuJoCo pushes the peg at every step of the ladder, s (module docstring)."""
LADDER_CCD_TOLERANCE = 1e-10
"""MuJoCo's ``ccd_tolerance`` in the ladder (module docstring)."""
LADDER_SCENES: tuple[tuple[float, float], ...] = ((0.1e-3, 5.0), (0.1e-3, 2.0), (0.1e-3, 0.5))
"""(diametral clearance c, m; tilt, deg) of the jam scenes: the peer table's."""
PYBULLET_RUNS = 3
"""PyBullet runs per scene; the cost is their median."""


@dataclass(frozen=True)
class LadderStep:
    """MuJoCo's jam scene at one time step: error against l* (m), CPU s per simulated s."""

    dt_s: float
    error_m: float
    cost: float


@dataclass(frozen=True)
class PeerMatch:
    """One jam scene: PyBullet's error and cost, and MuJoCo's at every step of the ladder."""

    clearance_m: float
    tilt_deg: float
    analytic_m: float
    bound_m: float
    pybullet_error_m: float
    pybullet_cost: float
    steps: tuple[LadderStep, ...]

    @property
    def match(self) -> LadderStep | None:
        """The coarsest step within ``bound_m`` (None: no step tried reaches it)."""
        return next((s for s in self.steps if abs(s.error_m) <= self.bound_m), None)

    @property
    def cost_ratio(self) -> float | None:
        """MuJoCo's cost at :attr:`match` over PyBullet's (None without a match)."""
        m = self.match
        return None if m is None else m.cost / self.pybullet_cost


def jam_bound_m(preset_name: str) -> float:
    """The asserted ``jam_depth_error_m`` bound of ``preset_name`` (:data:`bench.bounds.BOUNDS`)."""
    from .bounds import BOUNDS

    return next(b.limit for b in BOUNDS
                if b.figure == "jam_depth_error_m" and b.preset == preset_name)


def peer_matches(fid: Any, scenes: Sequence[tuple[float, float]] = LADDER_SCENES,
                 dts_s: Sequence[float] = LADDER_DT_S,
                 log: Callable[[str], None] | None = None) -> list[PeerMatch]:
    """Each jam scene in PyBullet at ``fid`` and in MuJoCo at every step of ``dts_s``
    (module docstring). Empty when MuJoCo is not installed."""
    from asmplan.sim import peers

    from .scenarios import JamScene, jam_depth_m, whitney_jam_depth_m

    if not peers.available():
        return []
    say = log or (lambda _s: None)
    bound = jam_bound_m(fid.name)
    out = []
    for c, t_deg in scenes:
        t = math.radians(t_deg)
        ref = whitney_jam_depth_m(c, t)
        costs = []
        got = math.nan
        for _ in range(PYBULLET_RUNS):
            t0 = time.process_time()
            got = jam_depth_m(fid, c, t)
            costs.append((time.process_time() - t0) / JamScene().settle_s)
        steps = []
        for dt in dts_s:
            mj, cost = peers.mujoco_jam_depth_m(dt, c, t, settle_s=LADDER_SETTLE_S,
                                                ccd_tolerance=LADDER_CCD_TOLERANCE)
            steps.append(LadderStep(dt, mj - ref, cost))
        out.append(PeerMatch(c, t_deg, ref, bound, got - ref, sorted(costs)[len(costs) // 2],
                             tuple(steps)))
        say(f"peers: equal-accuracy ladder, jam {t_deg:g} deg")
    return out


def format_peer_matches(matches: Sequence[PeerMatch], preset_name: str) -> str:
    """Markdown: per jam scene, MuJoCo's error and cost at every step of the ladder, and the
    cost at which it first matches BALANCED's accuracy bound, beside PyBullet's."""
    if not matches:
        return ""
    dts = [s.dt_s for s in matches[0].steps]
    head = (f"| scene | PyBullet {preset_name} error, CPU s / sim s | "
            + " | ".join(f"MuJoCo {dt * 1e3:g} ms" for dt in dts)
            + " | MuJoCo within the bound | MuJoCo / PyBullet cost |")
    lines = [head, "| --- | ---: | " + " | ".join("---:" for _ in dts) + " | --- | ---: |"]
    for m in matches:
        cells = [f"{s.error_m * 1e3:+.4f} mm, {s.cost:.2f}" for s in m.steps]
        hit = m.match
        ratio = m.cost_ratio
        within = (f"at {hit.dt_s * 1e3:g} ms" if hit is not None else
                  f"not down to {m.steps[-1].dt_s * 1e3:g} ms")
        lines.append(
            f"| c = {m.clearance_m * 1e3:g} mm, t = {m.tilt_deg:g} deg (l* = "
            f"{m.analytic_m * 1e3:.3f} mm, bound {m.bound_m * 1e3:.3f} mm) | "
            f"{m.pybullet_error_m * 1e3:+.4f} mm, {m.pybullet_cost:.2f} | " + " | ".join(cells)
            + f" | {within} | " + (f"{ratio:.1f}x" if ratio is not None else "-") + " |")
    return "\n".join(lines) + "\n"
