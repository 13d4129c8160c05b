"""Slip threshold of a two-finger grip against m (g + a) / (2 mu).

A 100 g box is clamped with force F per finger and lifted with constant acceleration a for
0.2 s, then braked at 2 m/s^2 (< g: braking needs less grip). Bisection finds the smallest F at which it does not slip (slip < 0.2 mm, twist
< 0.6 deg). PyBullet multiplies friction coefficients: mu = mu_pad * mu_part = 1.0 * 0.5.
"""

from __future__ import annotations

import pytest

from asmplan.sim.fidelity import BALANCED
from bench.scenarios import BoxPart, G, lift_slip_m

PART = BoxPart(mass_kg=0.1, friction=0.5)
MU = 1.0 * PART.friction
SLIP_LIMIT_M = 0.2e-3


def min_holding_force_N(accel_mps2: float, iterations: int = 10) -> float:
    analytic = PART.mass_kg * (G + accel_mps2) / (2 * MU)
    lo, hi = 0.5 * analytic, 1.5 * analytic
    assert lift_slip_m(BALANCED, PART, lo, accel_mps2) > SLIP_LIMIT_M  # bracket is valid
    assert lift_slip_m(BALANCED, PART, hi, accel_mps2) < SLIP_LIMIT_M
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if lift_slip_m(BALANCED, PART, mid, accel_mps2) < SLIP_LIMIT_M:
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
