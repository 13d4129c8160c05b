"""Issue 14's reproducers: hostile or inconsistent product files are located exit-2 errors.

Each case is a one-line change to a bundled example (or a small hostile document) that used
to hang, exhaust memory, end in "internal error" (exit 3), or validate and then crash or
"succeed" in ``run``. Each must now be refused by ``asmplan validate`` with exit code 2 and
``file:line:col: key.path: message`` pointing at the offending text.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from asmplan.cli import main
from asmplan.knowledge.consistency import signed_distance
from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.model import Primitive
from asmplan.knowledge.yamlsource import MAX_ALIAS_VALUES, MAX_DEPTH, parse_located
from tests.conftest import example_path

PEG = example_path("peg_in_hole").read_text(encoding="utf-8")
SEED = example_path("pinhole_station").read_text(encoding="utf-8")


def _edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def _bomb(levels: int) -> str:
    lines = ['a0: &a0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    lines += [f"a{i}: &a{i} [" + ",".join([f"*a{i - 1}"] * 9) + "]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


# (id, file text, needle the first error must point at (line:col of its first character),
#  key path regex, message regex)
CASES = [
    ("alias-bomb-7", _bomb(7), "*a4", r"a5\[0\]",
     rf"expected aliases to repeat at most {MAX_ALIAS_VALUES:,} values in all, found more at \*a4"),
    ("alias-bomb-9", _bomb(9), "*a4", r"a5\[0\]", r"expected aliases to repeat at most"),
    ("recursive-alias", PEG + "loop: &L [1, *L]\n", "*L", r"loop\[1\]",
     r"expected an alias outside the value it names, found \*L inside &L"),
    ("undefined-alias", _edit(PEG, "fit: H7/g6", "fit: *nowhere"), "*nowhere", r"mates\[0\]\.fit",
     r'expected an alias to an anchor written before it, found \*nowhere with no "&nowhere" above'),
    ("deep-nesting", PEG + "deep: " + "[" * 600 + "]" * 600 + "\n", None, r"deep(\[0\])*",
     rf"expected lists and mappings nested at most {MAX_DEPTH} deep"),
    ("int-above-1e308", _edit(PEG, "size: [60, 60, 30]", "size: [1" + "0" * 309 + ", 60, 30]"), "1000",
     r"parts\[0\]\.geometry\.size\[0\]", r"expected a number within \+-1\.8e308, found an integer of 310 digits"),
    ("int-4400-digits", _edit(PEG, "size: [60, 60, 30]", "size: [" + "9" * 4400 + ", 60, 30]"), "9999",
     r"parts\[0\]\.geometry\.size\[0\]", r"expected a number within \+-1\.8e308, found an integer of 4400 digits"),
    ("float-tag-abc", _edit(PEG, "diameter: 10, depth", "diameter: !!float abc, depth"), "!!float",
     r"parts\[0\]\.geometry\.holes\[0\]\.diameter", r'expected a number after the tag !!float, found "abc"'),
    ("int-tag-empty", _edit(PEG, "depth: 20", 'depth: !!int ""'), "!!int", r"parts\[0\]\.geometry\.holes\[0\]\.depth",
     r'expected an integer after the tag !!int, found ""'),
    ("bool-tag-maybe", _edit(PEG, "fixtured: true", "fixtured: !!bool maybe"), "!!bool", r"parts\[0\]\.fixtured",
     r'expected true or false after the tag !!bool, found "maybe"'),
    ("unknown-tag", _edit(PEG, "product: peg_in_hole", "product: !!python/name:os.system x"), "!!python",
     r"product", r"expected a plain value .*, found the unsupported YAML tag tag:yaml\.org,2002:python/name:os\.system"),
    ("axis-1e308", _edit(PEG, "axis: [0, 0, -1]", "axis: [1.0e+308, 0, -1]"), "1.0e+308",
     r"parts\[1\]\.features\[0\]\.axis\[0\]", r"expected a number within \+-1e\+06, found 1e\+308"),
    ("overflow-to-inf", _edit(PEG, "length: 20,", "length: 1.0e+400,"), "1.0e+400",
     r"parts\[1\]\.features\[0\]\.length", r"expected a finite number, found inf"),
    ("lone-surrogate", _edit(PEG, "product: peg_in_hole", 'product: "\\ud800"'), None, r"product",
     r"YAML syntax error: found invalid Unicode character escape code"),
    ("control-character", _edit(PEG, "product: peg_in_hole", "product: peg\x07in_hole"), "\x07", None,
     r"expected printable text, found the control character U\+0007"),
    ("geometry-type-a-list", _edit(PEG, "type: box", "type: [box]"), "[box]", r"parts\[0\]\.geometry\.type",
     r"expected one of: box, cylinder, sphere, composite, mesh, found a list of 1"),
    ("units-a-list", _edit(PEG, "units: {length: mm, mass: g}", "units: [mm]"), "[mm]", r"units",
     r"expected units \(a mapping\), found a list of 1"),
    ("two-documents", PEG + "---\nasmplan: 1\n", "---", None, r"expected one YAML document, found a second one"),
    # sizes and distances outside the limits (docs/product-format.md, "Limits")
    ("pin-length-1e308", _edit(PEG, "length: 20,", "length: 1e308,"), "1e308",
     r"parts\[1\]\.features\[0\]\.length", r"expected a length within \+-100000 mm, found 1e\+308 mm"),
    ("part-1e30-mm", _edit(PEG, "size: [60, 60, 30]", "size: [1e30, 60, 30]"), "1e30",
     r"parts\[0\]\.geometry\.size\[0\]", r"expected a length within \+-100000 mm, found 1e\+30 mm"),
    ("lift-height-1e30", _edit(SEED, "lift_height: 40", "lift_height: 1e30"), "1e30", r"process\.lift_height",
     r"expected a length within \+-5000 mm, found 1e\+30 mm"),
    ("start-1e30-away", _edit(PEG, "xyz: [120, 80, 20]", "xyz: [1e30, 80, 20]"), "1e30", r"parts\[1\]\.start\.xyz\[0\]",
     r"expected a length within \+-100000 mm"),
    ("micrometre-seed", _edit(SEED, "units: {length: mm,", "units: {length: um,"), "8, depth",
     r"parts\[0\]\.geometry\.holes\[0\]\.diameter", r"expected a length of at least 10 um \(0\.01 mm\), found 8 um"),
    ("colour-out-of-range", _edit(PEG, "    material: steel\n    geometry: {type: cyl",
                                  "    material: steel\n    color: [0, 2, 0]\n    geometry: {type: cyl"),
     "2, 0]", r"parts\[1\]\.color\[1\]", r"expected a number <= 1, found 2"),
    # contradictions (knowledge/consistency.py)
    ("pin-50mm-off-its-hole", _edit(PEG, "at: [0, 0, 0], axis", "at: [50, 0, 0], axis"), "{pin: peg.tip",
     r"mates\[0\]", r"expected the root of pin peg\.tip on the axis of hole block\.hole .* found it 50 mm off"),
    ("block-narrower-than-hole", _edit(PEG, "size: [60, 60, 30]", "size: [8, 8, 30]"), "10, depth",
     r"parts\[0\]\.geometry\.holes\[0\]\.diameter",
     r"expected part block to surround hole block\.hole \(10 mm\) with a wall, found material in \d+%"),
    ("hole-outside-its-part", _edit(PEG, "at: [0, 0, 15], diameter", "at: [0, 0, 100], diameter"), "[0, 0, 100]",
     r"parts\[0\]\.geometry\.holes\[0\]\.at",
     r"expected the mouth of hole block\.hole on the surface of part block, found it 85 mm outside"),
    ("hole-shallower-than-pin", _edit(PEG, "depth: 20", "depth: 8"), "{pin: peg.tip", r"mates\[0\]",
     r"expected pin peg\.tip \(20 mm engaged\) to fit hole block\.hole \(8 mm deep\), found it 12 mm too long"),
    ("duplicate-mate", _edit(PEG, "  - {pin: peg.tip, hole: block.hole, fit: H7/g6}\n",
                             "  - {pin: peg.tip, hole: block.hole, fit: H7/g6}\n"
                             "  - {name: again, pin: peg.tip, hole: block.hole, fit: H7/g6}\n"),
     "{name: again", r"mates\[1\]", r"expected one mate per pin and hole, found peg\.tip in block\.hole already"),
    ("pin-root-in-the-air", _edit(SEED, "{name: p1, at: [-40, 0, -10]", "{name: p1, at: [-40, 0, -14]"),
     "[-40, 0, -14]", r"parts\[1\]\.geometry\.pins\[0\]\.at",
     r"expected the root of pin part2\.p1 on the body of part part2, found it 4 mm away"),
    ("iso-deviation-as-large-as-the-pin",
     PEG.replace("diameter: 10, depth: 20, chamfer: 0.5", "diameter: 0.1, depth: 20, chamfer: 0")
        .replace("diameter: 10, length: 20, chamfer: 0.5", "diameter: 0.1, length: 20, chamfer: 0")
        .replace("fit: H7/g6", "fit: H11/c11"), "H11/c11", r"mates\[0\]\.fit",
     r"expected the fit to leave pin peg\.tip at least half its nominal 0\.1 mm, found it built at 0\.01 mm"),
    ("clearance-larger-than-pin", _edit(PEG, "fit: H7/g6", "clearance: 25"), "25}",
     r"mates\[0\]\.clearance", r"expected the clearance to leave pin peg\.tip at least half its nominal 10 mm"),
]


def _at(text: str, needle: str) -> str:
    i = text.index(needle)
    line = text.count("\n", 0, i) + 1
    return f"{line}:{i - (text.rfind(chr(10), 0, i) + 1) + 1}"


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_hostile_or_inconsistent_input_is_a_located_exit_2(case, tmp_path, capsys) -> None:
    _id, text, needle, keypath, message = case
    path = tmp_path / "bad.yaml"
    path.write_text(text, encoding="utf-8")
    code = main(["validate", str(path)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and "internal error" not in err
    where = re.escape(str(path)) + ":" + (_at(text, needle) if needle else r"\d+:\d+")
    pattern = where + ": " + (keypath + ": " if keypath else "") + message
    assert re.search(pattern, err), f"\nexpected /{pattern}/ in:\n{err}"
    # every issue line is located (file:line:col), and the summary line closes the report
    lines = err.strip().splitlines()
    assert lines[-1].startswith("asmplan: ") and "nothing was planned" in lines[-1]
    assert all(re.match(re.escape(str(path)) + r":\d+:\d+: ", line) for line in lines[:-1]), err


def test_all_errors_of_a_file_are_reported_at_once(tmp_path) -> None:
    text = _edit(PEG, "fixtured: true", "fixtured: !!bool maybe")
    text = _edit(text, "depth: 20", 'depth: !!int ""')
    text = _edit(text, "xyz: [120, 80, 20]", "xyz: [1e30, 80, 20]")
    path = tmp_path / "p.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ProductError) as info:
        from asmplan.knowledge.loader import load_product

        load_product(path)
    assert [i.path for i in info.value.issues] == ["parts[0].geometry.holes[0].depth", "parts[0].fixtured"]
    # the number out of range is a schema error, found once the file reads as YAML
    path.write_text(_edit(PEG, "xyz: [120, 80, 20]", "xyz: [1e30, 80, -1e30]"), encoding="utf-8")
    with pytest.raises(ProductError) as info:
        load_product(path)
    assert [i.path for i in info.value.issues] == ["parts[1].start.xyz[0]", "parts[1].start.xyz[2]"]


def test_aliases_and_merge_keys_keep_the_position_where_values_are_written() -> None:
    text = ("base: &b {size: [1, 2, 3], pose: {xyz: [0, 0, 1]}}\n"
            "one: *b\n"
            "two:\n"
            "  <<: *b\n"
            "  size: [4, 5, 6]\n")
    doc = parse_located(text, "a.yaml")
    assert doc.data["one"] == {"size": [1, 2, 3], "pose": {"xyz": [0, 0, 1]}}
    assert doc.data["two"] == {"size": [4, 5, 6], "pose": {"xyz": [0, 0, 1]}}
    assert doc.where(("one",)) == (2, 6)                     # the alias itself
    assert doc.where(("one", "pose", "xyz", 2)) == (1, 47)   # inside: where the anchor writes it
    assert doc.where(("two", "pose", "xyz", 0)) == (1, 41)   # merged in from the anchor
    assert doc.where(("two", "size", 0)) == (5, 10)          # written in the mapping: wins


def test_yaml12_exponents_are_numbers_and_yaml11_octal_is_kept() -> None:
    doc = parse_located("a: 1e-3\nb: -2E+6\nc: 010\nd: '1e3'\ne: 0.5\nf: 1_000\n", "n.yaml")
    assert doc.data == {"a": 1e-3, "b": -2e6, "c": 8, "d": "1e3", "e": 0.5, "f": 1000}


_scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**30, 10**30),
                     st.floats(allow_nan=False, allow_infinity=False),
                     st.text(st.characters(blacklist_categories=("Cs", "Cc")), max_size=12))
_documents = st.recursive(_scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4),
    st.dictionaries(st.text("abcxyz_", min_size=1, max_size=6), inner, max_size=4)), max_leaves=20)


@settings(max_examples=150, deadline=None)
@given(data=st.dictionaries(st.text("abcdefgh", min_size=1, max_size=5), _documents, min_size=1, max_size=5),
       flow=st.booleans())
def test_reader_agrees_with_pyyaml_and_locates_every_value(data, flow) -> None:
    """Invariant: on any document PyYAML writes, the reader gives what ``yaml.safe_load``
    gives (except that a plain ``1e3``, text in YAML 1.1, is the number of YAML 1.2), and
    has a position for every value, inside the text."""
    text = yaml.safe_dump(data, default_flow_style=flow, allow_unicode=True)
    doc = parse_located(text, "h.yaml")

    def yaml12(value):
        if isinstance(value, dict):
            return {k: yaml12(v) for k, v in value.items()}
        if isinstance(value, list):
            return [yaml12(v) for v in value]
        plain = isinstance(value, str) and re.fullmatch(r"[-+]?[0-9]+[eE][-+]?[0-9]+", value)
        return float(value) if plain and f"'{value}'" not in text and f'"{value}"' not in text else value

    assert doc.data == yaml12(yaml.safe_load(text))
    n_lines = text.count("\n") + 1

    def walk(value, path):
        line, col = doc.where(path)
        assert 1 <= line <= n_lines and col >= 1
        if isinstance(value, dict):
            for k, v in value.items():
                walk(v, (*path, k))
        elif isinstance(value, list):
            for i, v in enumerate(value):
                walk(v, (*path, i))

    walk(doc.data, ())


@settings(max_examples=200, deadline=None)
@given(point=st.tuples(*[st.floats(-0.1, 0.1)] * 3), size=st.tuples(*[st.floats(0.001, 0.1)] * 3),
       yaw=st.floats(-math.pi, math.pi))
def test_signed_distance_of_a_turned_box_is_exact(point, size, yaw) -> None:
    """Invariant: the box's signed distance is the exact distance to its surface, negative
    inside (checked against the box frame's clamp construction)."""
    c, s = math.cos(yaw), math.sin(yaw)
    T = np.eye(4)
    T[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    T[:3, 3] = [0.01, -0.02, 0.005]
    prim = Primitive("box", T, size_m=size)
    p = np.asarray(point)
    q = T[:3, :3].T @ (p - T[:3, 3])
    h = 0.5 * np.asarray(size)
    inside = bool(np.all(np.abs(q) <= h))
    outside_distance = float(np.linalg.norm(q - np.clip(q, -h, h)))
    expected = -float(np.min(h - np.abs(q))) if inside else outside_distance
    assert signed_distance((prim,), p[None])[0] == pytest.approx(expected, abs=1e-12)
