"""Per-step trace of the bundled peg's insertion with a commanded pose error, the grip's pad
rows in the fit contact's solve on or off (`Fidelity.grip_rows`, :mod:`asmplan.sim.grip_pads`).

Why the rows made the chamfered peg fail at BALANCED (docs/physics.md, "The grip's normals
in the solve", open): this prints, every ``every`` physics steps while the fit contact is
active, the peg's lateral position and tilt (world, um and mrad), its axial position relative
to the TCP (its slip along the pads), the finger travel, Bullet's pad normal forces and
deepest pad penetration, and the rows' solve (fit and pad normal force, N), beside the
analytic depths of the two rigid-jaw outcomes (:func:`rigid_jaw_depths_m`).

Run: ``.venv/bin/python -m bench.grip_rows_trace --preset balanced --rows on --error 0,-0.05``
(error in mm, world x and y; the pipeline's closing axis is world y for this peg).
The per-step hook wraps :meth:`HeldFitContact.after_step` for the run only; ``--rounds``
sets :data:`asmplan.sim.feature_contact.GRIP_ROUNDS` for the run only.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

PAD_LENGTH_M = 25e-3
"""The bundled peg's gripper finger pad length along the part (examples/peg_in_hole.yaml)."""


@dataclass(frozen=True)
class TraceRow:
    """One physics step while the fit contact is active (SI units)."""

    step: int
    T_world_part: np.ndarray
    T_world_tcp: np.ndarray
    finger_travel_m: np.ndarray
    pad_force_N: np.ndarray
    pad_penetration_m: np.ndarray
    fit_force_N: float


@contextmanager
def traced(rows: list[TraceRow], rounds: int | None) -> Iterator[None]:
    """Record a :class:`TraceRow` after every fit-contact step of the runs inside."""
    from asmplan.sim import feature_contact as fc

    original = fc.HeldFitContact.after_step
    original_rounds = fc.GRIP_ROUNDS

    def after_step(self: Any) -> None:
        original(self)
        if not self.active or self._grip is None:
            return
        w, (gripper, links, _) = self.world, self._grip
        con = w.contacts(self.held_body, gripper)
        q, _ = w.joint_states(gripper, links)
        fit = self.contacts()
        rows.append(TraceRow(
            len(rows), w.pose(self.held_body), w.pose(gripper), np.asarray(q, dtype=float),
            np.array([con.normal_force_N[con.link_b == k].sum() for k in links]),
            np.array([min([0.0, *con.distance_m[con.link_b == k].tolist()]) for k in links]),
            float(np.sum(fit.normal_force_N)) if fit.count else 0.0))

    fc.HeldFitContact.after_step = after_step  # type: ignore[method-assign]
    if rounds is not None:
        fc.GRIP_ROUNDS = int(rounds)
    try:
        yield
    finally:
        fc.HeldFitContact.after_step = original  # type: ignore[method-assign]
        fc.GRIP_ROUNDS = original_rounds


def rigid_jaw_depths_m(lateral_m: float, clearance_m: float, chamfer_pin_m: float,
                       chamfer_hole_m: float, pivot_above_tip_m: float) -> tuple[float, float]:
    """The two outcomes of a pin offset ``lateral_m`` along a rigid gripper's closing axis
    (jaws that cannot move across it, a stiff robot), diametral clearance ``clearance_m``,
    45 deg chamfers of radial widths ``chamfer_pin_m`` and ``chamfer_hole_m``:

    * no give at all: the two chamfer cones meet at depth
      ``w_pin + w_hole - (e - c / 2)`` (the pin stays on the chamfer);
    * the pin pivoting in the pads about the middle of their contact line
      (``pivot_above_tip_m`` above the pin's end; the jaws open against the clamp): its axis
      passes through that point, ``e`` off the bore's axis, and two-point contact (tip
      chamfer circle on one wall, mouth chamfer foot on the other) is reached at engaged
      length ``l = c H / (e + c / 2)``, ``H`` the pivot's height above the tip chamfer
      circle: depth ``l + w_pin + w_hole``.

    Returns (chamfer stop depth, pivot jam depth), m."""
    e, c = lateral_m, clearance_m
    stop = chamfer_pin_m + chamfer_hole_m - (e - 0.5 * c)
    H = pivot_above_tip_m - chamfer_pin_m
    return stop, c * H / (e + 0.5 * c) + chamfer_pin_m + chamfer_hole_m


def run_peg(preset: str, grip_rows: bool, lateral_m: tuple[float, float],
            rounds: int | None = None) -> tuple[dict[str, Any], list[TraceRow], float]:
    """The bundled peg's step with pose error ``lateral_m`` (world x, y), m, at ``preset``
    with the rows on or off: the sweep's step result, the trace and the CPU seconds."""
    from asmplan.knowledge.loader import load_product
    from asmplan.parts.models import ProductGeometry
    from asmplan.planner.product import plan_product
    from asmplan.sim import sweep as sw
    from asmplan.sim.fidelity import preset as named

    fid = dataclasses.replace(named(preset), grip_rows=grip_rows)
    product = load_product(Path(__file__).resolve().parents[1] / "examples" / "peg_in_hole.yaml")
    ps = sw.PlanSweep(product, plan_product(product, ProductGeometry(product)).plan, fid)
    (base,) = ps.samples(sw.SweepSpec(n_samples=1, vary=()))
    sample = sw.SampleParams(0, 0, base.clearance_m, base.friction,
                             {"peg": sw.PoseError(lateral_m)})
    rows: list[TraceRow] = []
    t0 = time.process_time()
    with traced(rows, rounds):
        result = sw.simulate_sample(ps, sample)["steps"]["peg"]
    return result, rows, time.process_time() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="balanced")
    ap.add_argument("--rows", choices=("on", "off"), default="on")
    ap.add_argument("--error", default="0,-0.05", help="lateral pose error x,y in mm")
    ap.add_argument("--rounds", type=int, default=None)
    ap.add_argument("--every", type=int, default=200)
    args = ap.parse_args(argv)
    ex, ey = (float(v) * 1e-3 for v in args.error.split(","))
    result, rows, cpu = run_peg(args.preset, args.rows == "on", (ex, ey), args.rounds)
    out = ["step  x_um    y_um  tilt_x_mrad tilt_y_mrad  tcp_above_part_mm  travel_mm  "
           "pad_N  pad_pen_um  fit_N"]
    for r in rows[::max(1, args.every)]:
        a = r.T_world_part[:3, 2]
        rel = r.T_world_tcp[:3, 3] - r.T_world_part[:3, 3]
        out.append(f"{r.step:5d} {r.T_world_part[0, 3] * 1e6:6.1f} {r.T_world_part[1, 3] * 1e6:7.1f} "
                   f"{a[1] * 1e3:8.2f} {a[0] * 1e3:11.2f} {rel[2] * 1e3:14.3f} "
                   f"{r.finger_travel_m[0] * 1e3:12.3f} "
                   f"{r.pad_force_N[0]:5.2f}/{r.pad_force_N[1]:4.2f} "
                   f"{r.pad_penetration_m.min() * 1e6:8.1f} {r.fit_force_N:7.2f}")
    # the bundled peg: 10 mm H7/g6 as built 17 um, 0.5 mm chamfers, pads centred 13.25 mm
    # above the peg's centre, the peg's top 20 mm above it and its end 20 mm below
    top, tcp = 20e-3, 13.25e-3
    pivot = 0.5 * (max(tcp - 0.5 * PAD_LENGTH_M, -top) + min(tcp + 0.5 * PAD_LENGTH_M, top))
    stop, jam = rigid_jaw_depths_m(math.hypot(ex, ey), 17e-6, 0.5e-3, 0.5e-3, pivot + top)
    out.append(f"verdict: success {result['success']}; {result['reasons']}")
    out.append(f"slip {result['outcome']['max_slip_m'] * 1e3:.3f} mm; CPU {cpu:.1f} s; "
               f"rigid jaws: chamfer stop {stop * 1e3:.3f} mm, pivot jam {jam * 1e3:.3f} mm "
               f"(along the closing axis only)")
    print("\n".join(out))  # noqa: T201 (a bench script's output)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
