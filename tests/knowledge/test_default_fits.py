"""A product's ``default_fits:``: the fit of a line-to-line mate written without one."""

from __future__ import annotations

from pathlib import Path

import pytest

from asmplan.knowledge import iso286
from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.loader import load_default_fits, load_product

PRODUCT = """\
asmplan: 1
product: dowelled_block
units: {length: mm}
DEFAULT_FITS
parts:
  - name: block
    geometry: {type: box, size: [60, 40, 20], holes: [
      {name: small, at: [-15, 0, 10], axis: [0, 0, 1], diameter: 6, depth: 10},
      {name: large, at: [15, 0, 10], axis: [0, 0, 1], diameter: 12, depth: 10}]}
    material: steel
    fixtured: true
    pose: {xyz: [0, 0, 10]}
  - name: dowel
    geometry: {type: cylinder, diameter: 6, length: 20}
    material: steel
    pose: {xyz: [-15, 0, 30]}
    features: [{name: p, type: pin, at: [0, 0, 0], axis: [0, 0, -1], diameter: 6, length: 10}]
  - name: stud
    geometry: {type: cylinder, diameter: 12, length: 20}
    material: steel
    pose: {xyz: [15, 0, 30]}
    features: [{name: p, type: pin, at: [0, 0, 0], axis: [0, 0, -1], diameter: 12, length: 10}]
mates:
  - {name: dowel_in_block, pin: dowel.p, hole: block.small}
  - {name: stud_in_block, pin: stud.p, hole: block.large}
resources:
  gripper: {stroke: 60, finger: {size: [20, 8, 30], friction: 1.0}, max_force: 60}
  table: {size: [600, 400, 40]}
"""


def _product(tmp_path: Path, fits: str) -> Path:
    p = tmp_path / "p.yaml"
    p.write_text(PRODUCT.replace("DEFAULT_FITS", fits))
    return p


def test_without_the_key_the_knowledge_base_gives_the_fit(tmp_path):
    """A line-to-line mate written without a fit gets the built-in rule's fit (H7/g6 for a pin
    in a hole, knowledge/data/default_fits.yaml) whether or not the product has the key, and
    says which rule gave it; `clearance: 0` keeps a deliberate line-to-line mate."""
    product = load_product(_product(tmp_path, ""))
    m = {m.name: m for m in product.mates}
    for name, d in (("dowel_in_block", 6e-3), ("stud_in_block", 12e-3)):
        f = iso286.fit("H7/g6", d)
        assert m[name].fit == "H7/g6"
        assert m[name].clearance_min_m == pytest.approx(f.clearance_min_m, abs=1e-12)
        assert m[name].clearance_max_m == pytest.approx(f.clearance_max_m, abs=1e-12)
        assert m[name].fit_source.startswith("knowledge/data/default_fits.yaml")
        assert "locating pin" in m[name].fit_source
    # ISO 286 at 6 mm: H7 0..+12 um, g6 -4..-12 um
    assert m["dowel_in_block"].clearance_min_m == pytest.approx(4e-6, abs=1e-9)
    assert m["dowel_in_block"].clearance_max_m == pytest.approx(24e-6, abs=1e-9)
    text = (tmp_path / "p.yaml").read_text().replace("hole: block.small}",
                                                    "hole: block.small, clearance: 0}")
    (tmp_path / "p.yaml").write_text(text)
    m = {m.name: m for m in load_product(tmp_path / "p.yaml").mates}
    assert m["dowel_in_block"].fit is None and m["dowel_in_block"].fit_source is None
    assert m["dowel_in_block"].clearance_min_m == m["dowel_in_block"].clearance_max_m == 0.0


def test_validate_names_the_rule_of_a_default_fit(tmp_path, capsys):
    from asmplan.cli import main

    assert main(["validate", str(_product(tmp_path, ""))]) == 0
    out = capsys.readouterr().out
    assert "dowel_in_block: dowel.p in block.small  H7/g6 clearance +4..+24 um" in out
    assert "default fit (line to line): knowledge/data/default_fits.yaml:" in out


def test_rules_by_kind_and_size_range_then_the_builtin_ones(tmp_path):
    """A rule applies over (min_diameter, max_diameter] (ISO 286's ranges); a mate no product
    rule matches falls back to knowledge/data/default_fits.yaml (H7/g6 for a pin in a hole)."""
    product = load_product(_product(tmp_path, """\
default_fits:
  - {male: pin, female: hole, min_diameter: 3, max_diameter: 10, fit: H7/h6, why: close sliding}
"""))
    m = {m.name: m for m in product.mates}
    assert m["dowel_in_block"].fit == "H7/h6"
    assert m["dowel_in_block"].fit_source.startswith(f"{tmp_path / 'p.yaml'}:")
    f = iso286.fit("H7/h6", 6e-3)
    assert m["dowel_in_block"].clearance_min_m == pytest.approx(0.0, abs=1e-12)
    assert m["dowel_in_block"].clearance_max_m == pytest.approx(f.clearance_max_m, abs=1e-12)
    assert f.clearance_max_m == pytest.approx(20e-6, abs=1e-9)  # 12 + 8 um (ISO 286 at 6 mm)
    assert m["stud_in_block"].fit == "H7/g6"  # 12 mm is outside (3, 10]: the built-in rule
    assert m["stud_in_block"].clearance_min_m == pytest.approx(6e-6, abs=1e-9)
    assert product.default_fits[0].min_diameter_m == pytest.approx(3e-3)


def test_an_explicit_fit_or_clearance_wins(tmp_path):
    text = _product(tmp_path, "default_fits:\n  - {max_diameter: 50, fit: H8/f7}\n").read_text()
    text = text.replace("hole: block.small}", "hole: block.small, clearance: 0.1}")
    (tmp_path / "p.yaml").write_text(text)
    m = {m.name: m for m in load_product(tmp_path / "p.yaml").mates}
    assert m["dowel_in_block"].fit is None and m["dowel_in_block"].clearance_min_m == pytest.approx(1e-4)
    assert m["stud_in_block"].fit == "H8/f7"


def test_bad_rules_are_located_all_at_once(tmp_path):
    p = _product(tmp_path, """\
default_fits:
  - {male: pin, female: hole, min_diameter: 40, max_diameter: 30, fit: H7/g6}
  - {male: pin, female: hole, max_diameter: 30, fit: Q7/g6}
  - {male: stud, female: hole, max_diameter: 30, fit: H7/g6}
  - {male: pin, female: hole, fit: H7/g6}
""")
    with pytest.raises(ProductError) as exc:
        load_product(p)
    text = str(exc.value)
    assert "p.yaml:5:" in text and "default_fits[0].min_diameter: expected min_diameter < max_diameter" in text
    assert "p.yaml:6:" in text and 'default_fits[1].fit: expected an ISO 286 fit valid from 0 to 30 mm, found "Q7/g6"' in text
    assert "p.yaml:7:" in text and 'default_fits[2].male: expected one of pin, shaft, any, found "stud"' in text
    assert 'default_fits[3]: missing required key "max_diameter"' in text


def test_a_rules_file_for_import(tmp_path):
    f = tmp_path / "fits.yaml"
    f.write_text("units: {length: in}\ndefault_fits:\n  - {male: pin, female: any, max_diameter: 0.5, fit: H7/h6}\n")
    (rule,) = load_default_fits(f)
    assert rule.max_diameter_m == pytest.approx(0.5 * 25.4e-3)
    assert rule.matches("pin", "bore", 12e-3) and not rule.matches("pin", "bore", 13e-3)
    assert "fits.yaml:3" in rule.source
    f.write_text("default_fits:\n  - {max_diameter: 10, fit: H7/xx6}\n")
    with pytest.raises(ProductError, match=r"fits.yaml:2:.*default_fits\[0\]\.fit"):
        load_default_fits(f)
