"""`asmplan check` on an imported CAD product: line-to-line pins and holes drawn at one nominal
diameter are judged against their fit with their real (tessellation) depth; a real overlap is
still an interference."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.cad_import import ImportSettings, import_assembly, write_product
from asmplan.parts.check import check_assembly
from asmplan.parts.models import ProductGeometry

pytest.importorskip("OCP")
CAD = Path(__file__).resolve().parents[1] / "fixtures" / "cad"


@pytest.fixture(scope="module")
def bracket_yaml(tmp_path_factory):
    out = tmp_path_factory.mktemp("cad") / "bracket.yaml"
    # every part as its CAD mesh (no primitives): the fits cannot be built into the geometry
    write_product(import_assembly(CAD / "angle_bracket.step", ImportSettings(primitives=False)), out)
    return out


def test_line_to_line_pairs_are_judged_by_their_fit(bracket_yaml):
    product = load_product(bracket_yaml)
    result = check_assembly(product, ProductGeometry(product))
    assert result.success, result.reason
    assert not result.interferences
    by_pair = {(i.a, i.b): i for i in result.intended_contacts}
    for pair in (("angle_bracket", "dowel_1"), ("angle_bracket", "post"), ("dowel_1", "side_block")):
        contact = by_pair[pair]
        assert contact.intended_by is not None
        # the real overlap is the tessellations' chord error (2 um deflection), not FCL's
        # millimetre "depth" between two BVH meshes
        assert contact.depth_m <= 2.5e-6
    # every line-to-line mate's clearance is measured within its fit's range widened by the
    # mesh hole's chord sagitta (and the H7 deviation the mesh cannot take)
    for m in result.mates:
        assert m.measured_within, m


def test_a_real_overlap_is_still_an_interference(bracket_yaml, tmp_path):
    text = bracket_yaml.read_text()
    # push the side block 0.5 mm into the bracket's wall (+y)
    text = re.sub(r"(- name: side_block\n(?:.*\n)*?    pose: \{xyz: \[0, )20(, 40\])", r"\g<1>20.5\2", text)
    assert "[0, 20.5, 40]" in text
    moved = tmp_path / "moved.yaml"
    moved.write_text(text)
    (tmp_path / "bracket_parts").symlink_to(bracket_yaml.parent / "bracket_parts")
    moved_product = load_product(moved)
    result = check_assembly(moved_product, ProductGeometry(moved_product))
    assert not result.success
    pairs = {(i.a, i.b): i for i in result.interferences}
    hit = pairs[("angle_bracket", "side_block")]
    assert hit.depth_m == pytest.approx(0.5e-3, abs=2e-6)


def test_line_to_line_mates_without_a_fit_get_the_knowledge_default(bracket_yaml, tmp_path):
    """Issue 19: the CAD file's mates with their `fit:` removed and no `default_fits:` key.
    The knowledge base's rules still give each line-to-line pair its fit (H7/g6 for a pin in a
    hole or a bore, knowledge/data/default_fits.yaml), so `check` judges the nominal contact
    against that fit: no interference, every clearance within its fit."""
    from asmplan.knowledge import iso286

    text = bracket_yaml.read_text()
    assert "default_fits:" not in text
    fitted = set(re.findall(r"- \{name: (\w+), [^}]*, fit: H7/g6\}", text))
    assert len(fitted) >= 5  # the post and the dowels, in the bracket and the blocks
    bare = re.sub(r", fit: H7/g6\}", "}", text)
    assert bare.count("fit: H7/g6}") == 0
    path = tmp_path / "bare.yaml"
    path.write_text(bare)
    (tmp_path / "bracket_parts").symlink_to(bracket_yaml.parent / "bracket_parts")
    product = load_product(path)
    for m in product.mates:
        if m.name not in fitted:  # a real clearance, written as such (the washer's bore)
            assert m.fit is None and m.clearance_min_m > 0
            continue
        hole = product.feature(m.hole_part, m.hole_feature)
        f = iso286.fit("H7/g6", hole.diameter_m)
        assert m.fit == "H7/g6", m
        assert "default_fits.yaml" in m.fit_source
        assert (m.clearance_min_m, m.clearance_max_m) == pytest.approx(
            (f.clearance_min_m, f.clearance_max_m), abs=1e-12)
    result = check_assembly(product, ProductGeometry(product))
    assert result.success, result.reason
    assert not result.interferences
    assert all(m.measured_within for m in result.mates)
