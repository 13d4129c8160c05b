"""Press-fit model: Lame pressure, press friction, the size model of transition fits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from asmplan.knowledge.materials import builtin_materials
from asmplan.knowledge.model import Mate
from asmplan.knowledge.press_fit import (
    PressFitError,
    clearance_model,
    lame_pressure_Pa,
    predict_press_fit,
    press_friction,
)


def test_lame_equal_materials_solid_shaft_matches_the_textbook_closed_form():
    # same material, solid shaft: p = E delta (D^2 - d^2) / (2 d D^2)  (Shigley eq. 3-57)
    E, nu, d, D, delta = 207e9, 0.292, 0.020, 0.050, 25e-6
    expected = E * delta * (D**2 - d**2) / (2 * d * D**2)
    assert lame_pressure_Pa(delta, d, D, 0.0, E, nu, E, nu) == pytest.approx(expected, rel=1e-12)


def test_lame_unbounded_hub_and_thin_sleeve_limits():
    E, nu, d = 200e9, 0.3, 0.01
    # an unbounded plate: the outer term is (1 + nu) / E
    p_inf = lame_pressure_Pa(10e-6, d, math.inf, 0.0, E, nu, E, nu)
    assert p_inf == pytest.approx(10e-6 / (d * ((1 + nu) / E + (1 - nu) / E)), rel=1e-12)
    # a very large finite hub approaches it; a thinner hub and a hollow male give less
    assert lame_pressure_Pa(10e-6, d, 1.0, 0.0, E, nu, E, nu) == pytest.approx(p_inf, rel=1e-3)
    # D_o = 15 mm: outer term (225 + 100) / 125 + 0.3 = 2.9 against 1.3
    assert lame_pressure_Pa(10e-6, d, 0.015, 0.0, E, nu, E, nu) == pytest.approx(p_inf * 2.0 / 3.6)
    # d_i = 8 mm: inner term (100 + 64) / 36 - 0.3 against 0.7
    inner = 164 / 36 - 0.3
    assert lame_pressure_Pa(10e-6, d, math.inf, 0.008, E, nu, E, nu) == pytest.approx(
        p_inf * 2.0 / (1.3 + inner))
    assert lame_pressure_Pa(0.0, d, math.inf, 0.0, E, nu, E, nu) == 0.0
    with pytest.raises(ValueError, match="hub_outer_diameter_m: expected > d"):
        lame_pressure_Pa(1e-6, d, d, 0.0, E, nu, E, nu)


def test_press_friction_table_is_symmetric_and_has_a_default():
    assert press_friction("steel", "aluminium") == press_friction("aluminium", "steel") == (0.08, "table")
    assert press_friction("steel", "steel") == (0.10, "table")
    assert press_friction("wood", "pla")[1] == "default"


def test_materials_carry_shigley_elastic_constants():
    m = builtin_materials()
    assert m["steel"].elastic_modulus_Pa == pytest.approx(207e9)
    assert m["aluminium"].poisson_ratio == pytest.approx(0.333)
    assert m["wood"].elastic_modulus_Pa is None


def _mate(fit: str) -> Mate:
    from asmplan.knowledge import iso286
    f = iso286.fit(fit, 0.010)
    return Mate("m", "p", "pin", "h", "hole", f.clearance_min_m, f.clearance_max_m, fit)


def test_transition_probability_matches_a_seeded_monte_carlo_of_the_size_model():
    # H7/k6 at 10 mm: hole 0..+15 um, shaft +1..+10 um: clearance -10..+14 um
    mate = _mate("H7/k6")
    model = clearance_model(mate, 0.010)
    assert (model.min_m, model.max_m) == pytest.approx((-10e-6, 14e-6))
    assert model.mean_m == pytest.approx(7.5e-6 - 5.5e-6)
    assert model.sigma_m == pytest.approx(math.hypot(15e-6, 9e-6) / 6)
    rng = np.random.default_rng(7)
    hole = rng.normal(7.5e-6, 15e-6 / 6, 400_000)
    shaft = rng.normal(5.5e-6, 9e-6 / 6, 400_000)
    p_mc = float(np.mean(hole - shaft < 0))
    assert model.probability_interference == pytest.approx(p_mc, abs=0.003)
    assert 0.2 < model.probability_interference < 0.3
    # E[delta | delta > 0] from the same samples
    delta = shaft - hole
    lo, typ, hi = model.interference_range_m()
    assert lo == 0.0 and hi == pytest.approx(10e-6)
    assert typ == pytest.approx(float(delta[delta > 0].mean()), rel=0.01)


def test_interference_and_clearance_fits_are_certain():
    assert clearance_model(_mate("H7/s6"), 0.010).probability_interference == 1.0
    assert clearance_model(_mate("H7/g6"), 0.010).probability_interference == 0.0
    lo, typ, hi = clearance_model(_mate("H7/s6"), 0.010).interference_range_m()
    assert (lo, typ, hi) == pytest.approx((8e-6, 20e-6, 32e-6))


def test_predict_refuses_a_material_without_elastic_data():
    m = builtin_materials()
    with pytest.raises(PressFitError, match='hub material "wood" has no elastic_modulus_gpa'):
        predict_press_fit(_mate("H7/s6"), 0.010, 0.01, math.inf, 0.0, m["wood"], m["steel"])
    with pytest.raises(PressFitError, match="expected an interference or transition fit"):
        predict_press_fit(_mate("H7/g6"), 0.010, 0.01, math.inf, 0.0, m["steel"], m["steel"])
