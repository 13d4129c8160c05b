"""Scenes shared by the simulator tests: the validation scenes of :mod:`asmplan.sim.scenarios`
(the same ones ``asmplan bench`` measures), plus the shared seed table's path and the sweep
that measured each preset's resolvable clearance.

Every physical quantity is stated once, in asmplan.sim.scenarios, so each test asserts against
an analytic expectation of a scene the benchmark also runs.
"""

from __future__ import annotations

from pathlib import Path

from asmplan.sim.scenarios import (
    R_DOWN,
    BoxPart,
    G,
    PinHole,
    add_box_and_gripper,
    box_inertia,
    box_piece,
    constant_acceleration_lift,
    cylinder_inertia,
    entered_depth_m,
    lift_slip_m,
    pin_insertion,
    pose,
    run_seed_cycle,
)

SEED_CSV = (Path(__file__).parents[2] / "../shared/reference/clamp_cycle_seed.csv").resolve()
"""The seed paper's Table 4 as transcribed for the project (the scenes embed the same table)."""


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


__all__ = [
    "R_DOWN",
    "SEED_CSV",
    "BoxPart",
    "G",
    "PinHole",
    "add_box_and_gripper",
    "box_inertia",
    "box_piece",
    "constant_acceleration_lift",
    "cylinder_inertia",
    "entered_depth_m",
    "lift_slip_m",
    "pin_insertion",
    "pose",
    "print_clearance_sweep",
    "run_seed_cycle",
]
