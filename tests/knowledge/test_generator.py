"""The seeded product generator: fits, side plates standing on the base, bad arguments."""

from __future__ import annotations

import pytest

from asmplan.knowledge.generator import BASE_T_MM, SIDE_GAP_MM, generate_product, generated_product


def test_fit_is_an_iso_fit_or_a_clearance():
    iso = generate_product(12, seed=3)
    assert {m["fit"] for m in iso["mates"]} == {"H7/g6"}
    loose = generate_product(12, seed=3, fit=0.5)
    assert all("fit" not in m and m["clearance"] == 0.5 for m in loose["mates"])
    # the same product otherwise
    assert [p["name"] for p in loose["parts"]] == [p["name"] for p in iso["parts"]]
    product = generated_product(12, seed=3, fit=0.5)
    assert all(m.clearance_min_m == pytest.approx(0.5e-3) == m.clearance_max_m
               for m in product.mates)
    for bad in (-0.1, float("nan"), True, None):
        with pytest.raises(ValueError, match="fit: expected an ISO fit name or a clearance"):
            generate_product(5, seed=0, fit=bad)


def test_side_plates_stand_on_the_base_with_their_pin_at_the_top_block():
    doc = generate_product(30, seed=1)
    parts = {p["name"]: p for p in doc["parts"]}
    sides = [p for name, p in parts.items() if name.endswith("_side")]
    assert sides
    for side in sides:
        cell = side["name"].rsplit("_", 1)[0]
        top = max((p for n, p in parts.items() if n.startswith(cell + "_block")),
                  key=lambda p: p["pose"]["xyz"][2])
        height = side["geometry"]["size"][2]
        z = side["pose"]["xyz"][2]
        # bottom SIDE_GAP_MM above the base, top flush with the top block's top
        assert z - height / 2 == pytest.approx(BASE_T_MM + SIDE_GAP_MM)
        assert z + height / 2 == pytest.approx(top["pose"]["xyz"][2] + top["geometry"]["size"][2] / 2)
        # the pin sits at the top block's centre height
        pin_z = z + side["geometry"]["pins"][0]["at"][2]
        assert pin_z == pytest.approx(top["pose"]["xyz"][2])
