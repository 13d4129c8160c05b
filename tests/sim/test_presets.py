"""Fidelity presets measured: clearance resolution, accuracy and cost.

Reproduce the table of docs/physics.md with
``/tmp/venv/bin/python -m pytest tests/sim/test_presets.py -s -k report``.
"""

from __future__ import annotations

import pytest

from asmplan.sim.fidelity import preset
from bench.scenarios import BoxPart, G, entered_depth_m, lift_slip_m, pin_insertion

NAMES = ("fast", "balanced", "accurate")


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_min_resolvable_clearance_is_resolved(name):
    """At the stored diametral clearance c_d, through the whole pipeline (bench/fits.py: an
    unchamfered 6 mm steel pin into a fixtured block): the step succeeds on the axis and
    c_d / 4 off it, and stops on the rim c_d off it (twice the capture radius c_d / 2), as
    capture geometry says (see sim/fidelity.py)."""
    from bench.fits import expected_verdict, run_fit

    fid = preset(name)
    c = fid.min_resolvable_clearance_m
    runs = run_fit(6e-3, c, [fid], ("aligned", "off", "inside"))
    for r in runs:
        if expected_verdict(r.case) == "inserted":
            # captured and pushed home; at FAST's 2 mm the pin may land up to 1 mm off the
            # axis (its radial play), beyond a product's 0.5 mm position tolerance
            assert r.depth_m == pytest.approx(r.engagement_m, abs=0.05e-3), (r.case, r.reasons)
            if c < 0.5e-3:
                assert r.inserted, (r.case, r.reasons)
        else:
            assert r.verdict == "rim_stop", (r.case, r.reasons)
            assert r.depth_m < 0.5e-3


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_interference_resolution_is_resolved(name):
    """At the stored interference resolution c_d: a fit of c_d/2 radial is inserted and an
    interference of c_d/2 stays blocked at the entrance (see sim/fidelity.py)."""
    fid = preset(name)
    radial = fid.interference_resolution_m / 2
    _, fit = pin_insertion(fid, radial)
    assert fit.success, fit.reasons
    record, interference = pin_insertion(fid, -radial)
    assert not interference.success
    assert entered_depth_m(record) < 2e-3


def _slip_threshold_error(name: str, accel: float = 2.0, iterations: int = 8) -> float:
    part = BoxPart(mass_kg=0.1, friction=0.5)
    analytic = part.mass_kg * (G + accel) / (2 * 1.0 * part.friction)
    lo, hi = 0.5 * analytic, 2.0 * analytic
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if lift_slip_m(preset(name), part, mid, accel) < 0.2e-3:
            hi = mid
        else:
            lo = mid
    return hi / analytic - 1.0


@pytest.mark.slow
def test_report_accuracy_and_cost_per_preset(seed_runs):
    rows = []
    for name in NAMES:
        _, outcome, traj = seed_runs[name]
        slip_err = _slip_threshold_error(name)
        rows.append((name, outcome.clamp_force_mae_N, slip_err, outcome.wall_time_s, traj.duration_s))
    print("\npreset    seed MAE (N)  slip-threshold error  wall s / 4 s cycle  realtime factor")
    for name, mae, slip_err, wall, dur in rows:
        print(f"{name:9s} {mae:12.5f}  {slip_err * 100:+19.2f} %  {wall:18.2f}  {dur / wall:15.1f}")
    by = {r[0]: r for r in rows}
    # accuracy: the balanced and accurate presets meet the paper and Coulomb within 10 %
    for name in ("balanced", "accurate"):
        assert by[name][1] <= 0.03
        assert abs(by[name][2]) <= 0.10
    # cost grows with fidelity
    assert by["fast"][3] < by["accurate"][3]
