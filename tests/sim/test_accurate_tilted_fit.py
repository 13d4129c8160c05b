"""The fits bench's 0.5 deg tilted pin at ACCURATE (bench/fits.py, case ``tilted``): an
unchamfered 8 mm steel pin in an 8.010 mm bore, held by the planner's 0.16 N clamp and tilted
0.5 deg about its tip, must jam at Whitney's two-point depth
l* = (D - d cos t) / sin t = 1.181 mm (tolerance 0.1 mm, issue 16's jam-depth bound at
BALANCED), as the fits bench's reference and BALANCED judge it (docs/physics.md, "Exact fit
contact", Open: the tilted fit at ACCURATE)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from asmplan.sim.fidelity import ACCURATE
from bench.scenarios import whitney_jam_depth_m

D_M, C_M = 8e-3, 10e-6
TOL_M = 0.1e-3


def _tilted(fid):
    from bench.fits import TILT_DEG, run_fit

    (run,) = run_fit(D_M, C_M, [fid], ("tilted",))
    return run, whitney_jam_depth_m(C_M, math.radians(TILT_DEG), D_M)


@pytest.mark.slow
def test_accurate_at_half_its_step_jams_the_tilted_pin_at_whitneys_depth():
    """ACCURATE's own exact fit contact at 1/8000 s (and 1/16000 s: 1.116 mm) converges to the
    jam geometry gives: jammed at 1.117 mm (measured, session 11)."""
    fid = dataclasses.replace(ACCURATE, name="accurate at 1/8000 s", dt_s=1.0 / 8000.0,
                              record_every_steps=32)
    run, whitney = _tilted(fid)
    assert run.verdict == "jammed", run.reasons
    assert run.depth_m == pytest.approx(whitney, abs=TOL_M), run.reasons


@pytest.mark.slow
def test_accurate_jams_the_tilted_pin_at_whitneys_depth():
    """At ACCURATE's own 1/4000 s (session 12, the pads' normals and friction in the fit
    contact's solve on the part and the fingers, each pad's face contact filled along the
    pin: sim/grip_pads.py): jammed at 1.117 mm. Before, the pin went in (12.000 mm): the
    solve had no row for the pads' normals, the wedge's push across the closing axis drove
    the pin into one pad and it turned 0.45 deg in the grip."""
    run, whitney = _tilted(ACCURATE)
    assert run.verdict == "jammed", run.reasons
    assert run.depth_m == pytest.approx(whitney, abs=TOL_M), run.reasons
