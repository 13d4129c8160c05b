"""Bad product input: every error names file:line:column, key path, expected and found;
all errors at once; exit code 2; no traceback."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from asmplan.cli import main
from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.loader import load_product

BASE = """\
asmplan: 1
product: tiny
units: {length: mm, mass: g}
parts:
  - name: block
    material: steel
    geometry:
      type: box
      size: [60, 60, 30]
      holes:
        - {name: hole, at: [0, 0, 15], diameter: 10, depth: 20, chamfer: 0.5}
    pose: {xyz: [0, 0, 15]}
    fixtured: true
  - name: peg
    material: steel
    geometry: {type: cylinder, diameter: 10, length: 40}
    features:
      - {name: tip, type: pin, at: [0, 0, 0], axis: [0, 0, -1], diameter: 10, length: 20}
    pose: {xyz: [0, 0, 30]}
    start: {location: tray, xyz: [120, 80, 20]}
  - name: cap
    mass: 20
    geometry: {type: box, size: [20, 20, 5]}
    pose: {xyz: [0, 0, 52.5]}
mates:
  - {name: m1, pin: peg.tip, hole: block.hole, fit: H7/g6}
precedence:
  base: block
  rules:
    - {before: peg, after: cap, reason: cap goes on top}
resources:
  gripper: {stroke: 60, finger: {size: [16, 8, 25], friction: 1.0}, max_force: 60}
  table: {size: [600, 400, 40]}
  fixtures: [{name: vise, holds: block}]
"""


def at(text: str, needle: str, nth: int = 0) -> str:
    """``line:column`` (1-based) of the ``nth`` occurrence of ``needle`` in ``text``."""
    pos = -1
    for _ in range(nth + 1):
        pos = text.index(needle, pos + 1)
    line = text.count("\n", 0, pos) + 1
    col = pos - (text.rfind("\n", 0, pos) + 1) + 1
    return f"{line}:{col}"


def edit(old: str, new: str, nth: int = 0) -> str:
    assert BASE.count(old) > nth, f"fixture text {old!r} not found"
    parts = BASE.split(old)
    return old.join(parts[: nth + 1]) + new + old.join(parts[nth + 1:])


# (id, modified text, needle whose position the error must name (None: no position), key path,
#  message regex)
CASES = [
    ("yaml-syntax", edit("size: [60, 60, 30]", "size: [60, 60, 30"), None, r"parts\[0\]\.geometry\.size\[3\]",
     r"YAML syntax error: did not find expected ',' or '\]'"),
    ("unknown-top-key", BASE + "procss: {}\n", "procss", "procss",
     r'unknown key "procss"; did you mean "process"\?; expected one of: .*process'),
    ("unknown-part-key", edit("    material: steel\n    geometry: {type: cyl",
                              "    materail: steel\n    geometry: {type: cyl"), "materail",
     r"parts\[1\]\.materail", r'unknown key "materail"; did you mean "material"\?'),
    ("wrong-type", edit("diameter: 10, length: 40}", "diameter: ten, length: 40}"), "ten",
     r"parts\[1\]\.geometry\.diameter", r'expected a number \(length\), found text "ten"'),
    ("zero-size", edit("size: [60, 60, 30]", "size: [60, 0, 30]"), "0, 30]",
     r"parts\[0\]\.geometry\.size\[1\]", r"expected a positive length, found 0"),
    ("negative-hole-diameter", edit("diameter: 10, depth: 20", "diameter: -10, depth: 20"), "-10",
     r"parts\[0\]\.geometry\.holes\[0\]\.diameter", r"expected a positive length, found -10"),
    ("unknown-part-in-rule", edit("after: cap", "after: cpa"), "cpa",
     r"precedence\.rules\[0\]\.after", r'unknown part "cpa"; did you mean "cap"\?; known parts: block, cap, peg'),
    ("unknown-feature", edit("pin: peg.tip", "pin: peg.tpi"), "peg.tpi", r"mates\[0\]\.pin",
     r'unknown feature "tpi" on part "peg"; did you mean "tip"\?; its features: tip'),
    ("unknown-material", edit("material: steel", "material: steal", nth=1), "steal",
     r"parts\[1\]\.material", r'unknown material "steal"; did you mean "steel"\?; known materials: .*aluminium'),
    ("pin-larger-than-hole", edit("diameter: 10, length: 20}", "diameter: 10.2, length: 20}"), "H7/g6",
     r"mates\[0\]\.fit", r"pin peg\.tip \(10\.2 mm\) is larger than hole block\.hole \(10 mm\) under the "
     r'clearance fit "H7/g6"'),
    ("unknown-fit", edit("fit: H7/g6", "fit: H7/q6"), "H7/q6", r"mates\[0\]\.fit",
     r'invalid ISO 286 fit "H7/q6" at 10 mm: .*found .q.'),
    ("duplicate-part", edit("- name: cap", "- name: peg"), "peg\n    mass", r"parts\[2\]\.name",
     r'duplicate part name "peg" \(first defined on line 14\)'),
    ("duplicate-feature", edit("length: 20}\n", "length: 20}\n      - {name: tip, type: pin, at: [0, 0, 5], "
                               "axis: [0, 0, 1], diameter: 4, length: 3}\n"), "tip, type: pin, at: [0, 0, 5]",
     r"parts\[1\]\.features\[1\]\.name", r'duplicate feature name "tip" in part "peg"'),
    ("missing-mesh-file", edit("geometry: {type: box, size: [20, 20, 5]}",
                               "geometry: {type: mesh, file: nothere.stl}"), "nothere.stl",
     r"parts\[2\]\.geometry\.file", r'mesh file not found: expected a file at ".*nothere\.stl"'),
    ("precedence-cycle", edit("reason: cap goes on top}\n",
                              "reason: cap goes on top}\n    - {before: cap, after: peg, reason: odd}\n"),
     "{before: peg", r"precedence\.rules\[0\]",
     r"precedence rules form a cycle: (peg -> cap -> peg|cap -> peg -> cap) \(rules on lines \d+, \d+\)"),
    ("missing-required", edit("    pose: {xyz: [0, 0, 52.5]}\n", ""), "name: cap", r"parts\[2\]",
     r'missing required key "pose"'),
    ("short-vector", edit("xyz: [0, 0, 52.5]", "xyz: [0, 52.5]"), "[0, 52.5]", r"parts\[2\]\.pose\.xyz",
     r"expected a list of 3 numbers, found a list of 2"),
    ("unknown-geometry-type", edit("type: cylinder", "type: cylindre"), "cylindre",
     r"parts\[1\]\.geometry\.type", r'unknown type "cylindre"; did you mean "cylinder"\?'),
    ("unknown-unit", edit("length: mm", "length: mmm"), "mmm", r"units\.length",
     r'expected one of m, cm, mm, um, in, found "mmm"; did you mean "mm"\?'),
    ("mate-two-holes", edit("pin: peg.tip", "pin: block.hole"), "block.hole,", r"mates\[0\]\.pin",
     r"expected a pin or shaft, found block\.hole which is a hole"),
    ("no-mass-no-material", edit("    mass: 20\n", ""), "name: cap", r"parts\[2\]",
     r'expected "material" \(to compute the mass\) or "mass", found neither'),
    ("zero-axis", edit("axis: [0, 0, -1]", "axis: [0, 0, 0]"), "[0, 0, 0], diam", r"parts\[1\]\.features\[0\]\.axis",
     r"expected a non-zero vector"),
    ("unknown-base", edit("base: block", "base: blok"), "blok", r"precedence\.base",
     r'unknown part "blok"; did you mean "block"\?'),
    ("duplicate-yaml-key", edit("    fixtured: true\n", "    fixtured: true\n    fixtured: false\n"),
     "fixtured: false", r"parts\[0\]\.fixtured", r'duplicate key "fixtured" \(first given on line 13\)'),
    ("negative-friction", edit("table: {size: [600, 400, 40]}", "table: {size: [600, 400, 40], friction: -0.5}"),
     "-0.5", r"resources\.table\.friction", r"expected a number >= 0, found -0\.5"),
    ("fit-and-clearance", edit("fit: H7/g6", "fit: H7/g6, clearance: 0.05"), "clearance: 0.05",
     r"mates\[0\]\.clearance", r"expected one of fit, clearance or interference, found fit and clearance"),
    ("fixture-unknown-part", edit("holds: block", "holds: blocks"), "blocks",
     r"resources\.fixtures\[0\]\.holds", r'unknown part "blocks"; did you mean "block"\?'),
    ("fit-size-out-of-table", edit("diameter: 10, depth: 20", "diameter: 600, depth: 20").replace(
        "diameter: 10, length: 20}", "diameter: 600, length: 20}"), "H7/g6", r"mates\[0\]\.fit",
     r'invalid ISO 286 fit "H7/g6" at 600 mm: .*500'),
    ("self-precedence", edit("after: cap", "after: peg"), "peg, reason", r"precedence\.rules\[0\]\.after",
     r'expected two different parts, found "peg" before itself'),
    ("bad-feature-ref", edit("pin: peg.tip", "pin: peg-tip"), "peg-tip", r"mates\[0\]\.pin",
     r'expected a feature reference "part\.feature", found "peg-tip"'),
    ("format-version", edit("asmplan: 1", "asmplan: 2"), "2\n", r"asmplan", r"expected format version 1, found 2"),
    ("top-level-list", "- a\n- b\n", None, "", r"expected a YAML mapping at the top level"),
    ("wrong-bool", edit("fixtured: true", "fixtured: yes please"), "yes please", r"parts\[0\]\.fixtured",
     r'expected true or false, found text "yes please"'),
    ("chamfer-too-big", edit("chamfer: 0.5}", "chamfer: 5}"), "5}", r"parts\[0\]\.geometry\.holes\[0\]\.chamfer",
     r"expected a chamfer smaller than the radius 5 mm, found 5 mm"),
    ("chamfer-deeper-than-hole", edit("depth: 20, chamfer: 0.5}", "depth: 0.4, chamfer: 0.5}"), "0.5}",
     r"parts\[0\]\.geometry\.holes\[0\]\.chamfer", r"expected a chamfer shallower than the hole's depth 0\.4 mm, found 0\.5 mm"),
    ("empty-parts", edit(BASE[BASE.index("  - name: block"):BASE.index("mates:")], "  []\n"), None, "parts",
     r"expected at least 1 entries, found 0"),
    ("clearance-min-gt-max", edit("fit: H7/g6", "clearance: {min: 0.05, max: 0.01}"), "{min: 0.05",
     r"mates\[0\]\.clearance", r"expected min <= max, found min 0\.05 mm > max 0\.01 mm"),
    ("mate-same-part", edit("hole: block.hole", "hole: peg.tip").replace("pin: peg.tip", "pin: peg.tip"),
     None, r"mates\[0\]\.hole", r"expected a hole or bore, found peg\.tip which is a pin"),
    ("group-too-small", edit("  rules:", "  groups: [{parts: [peg], reason: x}]\n  rules:"), "[peg]",
     r"precedence\.groups\[0\]\.parts", r"expected at least 2 entries, found 1"),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_reported_with_location(case, tmp_path: Path, capsys) -> None:
    _name, text, needle, keypath, message = case
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    code = main(["validate", str(path)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    location = re.escape(str(path)) + (":" + at(text, needle) if needle else r"(:\d+:\d+)?")
    pattern = location + r": " + (keypath + ": " if keypath else "") + message
    assert re.search(pattern, err), f"\nexpected /{pattern}/ in:\n{err}"
    assert err.rstrip().endswith("nothing was planned.")


def test_cases_are_distinct() -> None:
    texts = [c[1] for c in CASES]
    assert len(CASES) >= 25
    assert len(set(texts)) == len(texts)


def test_all_errors_reported_at_once(tmp_path: Path) -> None:
    text = edit("size: [60, 60, 30]", "size: [60, -1, 30]")
    text = text.replace("after: cap", "after: cpa").replace("material: steel", "material: wood!")
    text = text.replace("fit: H7/g6", "fit: X9/q1")
    path = tmp_path / "many.yaml"
    path.write_text(text)
    with pytest.raises(ProductError) as info:
        load_product(path)
    paths = {i.path for i in info.value.issues}
    assert {"parts[0].geometry.size[1]", "precedence.rules[0].after", "parts[0].material",
            "parts[1].material"} <= paths
    # the mate refers to parts that are themselves invalid: no spurious "unknown part" errors
    assert not any("unknown part" in i.message and i.path.startswith("mates") for i in info.value.issues)


@pytest.mark.parametrize("args", [["validate"], ["graph"]])
def test_cli_exit_code_and_no_traceback_in_a_real_process(tmp_path: Path, args: list[str]) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(edit("size: [60, 60, 30]", "size: [60, 0, 30]"))
    proc = subprocess.run([sys.executable, "-m", "asmplan", *args, str(path)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert f"{path}:{at(path.read_text(), '0, 30]')}: parts[0].geometry.size[1]" in proc.stderr
    assert proc.stdout == ""


def test_missing_file_and_empty_file(tmp_path: Path, capsys) -> None:
    assert main(["validate", str(tmp_path / "nope.yaml")]) == 2
    assert "nope.yaml: file not found" in capsys.readouterr().err
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    assert main(["validate", str(empty)]) == 2
    assert "expected a YAML mapping, found an empty file" in capsys.readouterr().err
