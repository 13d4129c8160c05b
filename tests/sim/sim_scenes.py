"""What the simulator tests share besides the validation scenes (those are in
:mod:`bench.scenarios`, which ``asmplan bench`` measures too): the shared seed table's
path and the sweep that measured each preset's resolvable clearance.
"""

from __future__ import annotations

from pathlib import Path

from bench.scenarios import PinHole, entered_depth_m, pin_insertion

SEED_CSV = (Path(__file__).parents[2] / "../shared/reference/clamp_cycle_seed.csv").resolve()
"""The seed paper's Table 4 as transcribed for the project (the scenes embed the same table)."""


def print_clearance_sweep(
    name: str, radial_m: tuple[float, ...] = (0.2e-3, 0.1e-3, 0.05e-3, 0.025e-3, 0.01e-3)
) -> None:
    """The measurement behind ``Fidelity.interference_resolution_m`` (one row per value; the
    clearance-fit resolution ``min_resolvable_clearance_m`` is measured by bench/fits.py).

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
