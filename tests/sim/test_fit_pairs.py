"""Which features of a held part the exact fit contact models (sim/fit_pairs.py)."""

from __future__ import annotations

import numpy as np

from asmplan.knowledge.loader import load_product
from asmplan.sim.fit_pairs import fit_model, leading_features
from tests.conftest import example_path


def test_a_stepped_shafts_thinner_end_enters_the_bore_first():
    # gear_unit's shaft: 'front' (z -10..30, the block's H7/g6 fit) is followed on its axis by
    # 'tail' (z 30..40, the collar's H11/c11): the tail enters the bearing block's bore for the
    # first 10 mm of the 50 mm stroke. Without it, nothing touched the bore over those 10 mm
    # (Bullet's contact between the two bodies is off), the shaft drifted 0.28 mm / 0.56 deg
    # in the grip and the front's tip chamfer jammed on the mouth (10.9 mm).
    product = load_product(example_path("gear_unit"))
    shaft = product.part("shaft")
    assert [f.name for f in leading_features(product, shaft.feature("front"))] == ["tail"]
    # nothing lies beyond the shaft's ends, and the hub points the other way
    assert leading_features(product, shaft.feature("tail")) == ()
    assert leading_features(product, shaft.feature("hub")) == ()
    # the tail's model puts the pin's tip at the shaft's end (local z = 40 mm), with no
    # shoulder (the front's own solid follows it in)
    tail, bore = shaft.feature("tail"), product.feature("bearing_block", "bore")
    m = fit_model(tail, bore, 9.9e-3, 10.0075e-3, 40e-3)
    assert np.allclose(m.pin.tip_m, [0.0, 0.0, 40e-3])
    assert np.allclose(m.pin.axis_to_root, [0.0, 0.0, -1.0])
    assert m.pin.seat_radius_m == 0.0
