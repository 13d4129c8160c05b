"""Slip threshold of a two-finger grip against m (g + a) / (2 mu).

A 100 g box is clamped with force F per finger and lifted with constant acceleration a for
0.2 s, then braked at 2 m/s^2 (< g: braking needs less grip). Bisection finds the smallest F at which it does not slip (slip < 0.2 mm, twist
< 0.6 deg). PyBullet multiplies friction coefficients: mu = mu_pad * mu_part = 1.0 * 0.5.
"""

from __future__ import annotations

import pytest

from asmplan.sim.fidelity import BALANCED, FAST
from bench.scenarios import BoxPart, G, lift_slip_m

PART = BoxPart(mass_kg=0.1, friction=0.5)
MU = 1.0 * PART.friction
SLIP_LIMIT_M = 0.2e-3


def min_holding_force_N(accel_mps2: float, iterations: int = 10, fidelity=BALANCED) -> float:
    analytic = PART.mass_kg * (G + accel_mps2) / (2 * MU)
    lo, hi = 0.5 * analytic, 1.5 * analytic
    assert lift_slip_m(fidelity, PART, lo, accel_mps2) > SLIP_LIMIT_M  # bracket is valid
    assert lift_slip_m(fidelity, PART, hi, accel_mps2) < SLIP_LIMIT_M
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if lift_slip_m(fidelity, PART, mid, accel_mps2) < SLIP_LIMIT_M:
            hi = mid
        else:
            lo = mid
    return hi


@pytest.mark.slow
@pytest.mark.parametrize("accel_mps2", [1.0, 4.0])
def test_minimum_holding_force_matches_coulomb_friction(accel_mps2):
    analytic = PART.mass_kg * (G + accel_mps2) / (2 * MU)
    found = min_holding_force_N(accel_mps2)
    print(f"slip threshold a={accel_mps2} m/s^2: {found:.5f} N vs analytic {analytic:.5f} N "
          f"({(found / analytic - 1) * 100:+.2f} %)")
    assert found == pytest.approx(analytic, rel=0.10)


@pytest.mark.slow
@pytest.mark.parametrize("accel_mps2", [0.0, 20.0])
def test_holding_force_in_the_air_and_at_20_mps2_matches_coulomb_at_fast(accel_mps2):
    """Issue 16's slip scenes at their extremes (the bench asserts 0, 5 and 20 m/s^2 at every
    preset): held still in the air after a slow lift (a = 0: m g / (2 mu)) and lifted at
    20 m/s^2 for 0.1 s. Measured at FAST: +0.39 % and -1.37 % (bisection step 0.1 %)."""
    analytic = PART.mass_kg * (G + accel_mps2) / (2 * MU)
    found = min_holding_force_N(accel_mps2, fidelity=FAST)
    assert found == pytest.approx(analytic, rel=0.03)
