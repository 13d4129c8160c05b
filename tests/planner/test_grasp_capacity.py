"""The grip capacity for one load (planner/grasp_capacity.py) against closed forms and against
the planner's hold criterion (grasp_hold.hold_requirement) for the same load."""

from __future__ import annotations

import math

import numpy as np
import pytest

from asmplan.planner.grasp_capacity import GripCapacity
from asmplan.planner.grasp_hold import ContactPatch, hold_requirement

G = 9.81


def _square(side_m: float, n: int = 21, centre=(0.0, 0.0)) -> ContactPatch:
    s = np.linspace(-side_m / 2, side_m / 2, n)
    x, z = np.meshgrid(s, s)
    pts = np.stack([x.ravel() + centre[0], z.ravel() + centre[1]], axis=1)
    return ContactPatch(pts, side_m * side_m)


def test_pure_force_load_uses_two_mu_f():
    """Centre of mass on the contact centre, load in the pad plane: m |g - a| / (2 mu F)."""
    cap = GripCapacity(_square(0.02), _square(0.02), 0.5, np.zeros(3))
    m, a, F = 0.1, 4.0, 2.5
    ratio, mech = cap.load_ratio(np.array([0.0, 0.0, -m * (G + a)]), np.zeros(3), F)
    assert mech == "friction"
    assert ratio == pytest.approx(m * (G + a) / (2 * 0.5 * F), rel=1e-12)


def test_load_along_the_closing_axis_tips_about_the_contact_line():
    """Weight along the closing axis at a lever L from a patch of length s along the lever:
    the pads' normal forces make the couple F s, ratio m g L / (F s)."""
    s, L, m, F = 0.005, 0.065, 0.22, 37.7
    line = ContactPatch(np.stack([np.zeros(11), np.linspace(0.0, s, 11)], axis=1), 1e-6)
    cap = GripCapacity(line, line, 0.7, np.array([0.0, 0.0, s / 2 + L]))
    ratio, mech = cap.load_ratio(np.array([0.0, -m * G, 0.0]), np.zeros(3), F)
    assert mech == "tipping"
    assert ratio == pytest.approx(m * G * L / (F * s), rel=1e-12)


@pytest.mark.parametrize("down", [(0.0, 0.0, -1.0), (1.0, 0.0, 0.0), (0.3, -0.8, 0.5),
                                  (0.0, 1.0, 0.0)])
@pytest.mark.parametrize("com", [(0.0, 0.0, 0.03), (0.01, 0.002, -0.02), (0.004, 0.0, 0.0)])
def test_ratio_is_the_planners_required_force_over_the_clamp(down, com):
    """For the weight alone (no acceleration) the planner's required force is its safety factor
    times the force at ratio 1: ratio x F x sf = hold_requirement(...).required_N."""
    top, bottom = _square(0.012, centre=(0.001, 0.0)), _square(0.016, centre=(-0.002, 0.001))
    m, mu, sf, F = 0.3, 0.4, 2.0, 12.0
    d = np.asarray(down) / np.linalg.norm(down)
    req = hold_requirement(top, bottom, np.asarray(com), m, 0.0, mu, sf, (d,))
    cap = GripCapacity(top, bottom, mu, np.asarray(com))
    ratio, _ = cap.load_ratio(m * G * d, np.zeros(3), F)
    assert ratio * F * sf == pytest.approx(req.required_N, rel=1e-9)


def test_no_clamp_holds_nothing():
    cap = GripCapacity(_square(0.02), _square(0.02), 0.5, np.zeros(3))
    assert math.isinf(cap.load_ratio(np.array([0.0, 0.0, -1.0]), np.zeros(3), 0.0)[0])


def test_many_loads_at_once_give_each_loads_ratio():
    """ratios_per_N over many loads equals load_ratio x F for each (the carry hold's table)."""
    rng = np.random.default_rng(3)
    top, bottom = _square(0.012, centre=(0.001, 0.0)), _square(0.016, centre=(-0.002, 0.001))
    cap = GripCapacity(top, bottom, 0.4, np.array([0.01, 0.002, -0.02]))
    f = rng.normal(size=(50, 3))
    m = 0.01 * rng.normal(size=(50, 3))
    f[0], m[0] = 0.0, 0.0
    per_N, tips = cap.ratios_per_N(f, m)
    for k in range(50):
        ratio, mech = cap.load_ratio(f[k], m[k], 2.0)
        assert per_N[k] / 2.0 == pytest.approx(ratio, rel=1e-12, abs=1e-15)
        assert (mech == "tipping") == bool(tips[k])
