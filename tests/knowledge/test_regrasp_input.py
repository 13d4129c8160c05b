"""resources.regrasp: declared regrasp fixtures read in SI, and every bad entry reported at once
with file:line:column, key path, expected and found (exit 2 from the CLI, no traceback)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.loader import load_product

PRODUCT = """\
asmplan: 1
product: stand
units: {{length: mm, mass: g, angle: deg}}
parts:
  - name: block
    material: steel
    geometry: {{type: box, size: [60, 60, 30]}}
    pose: {{xyz: [0, 0, 15]}}
    fixtured: true
  - name: pin
    material: steel
    geometry: {{type: cylinder, diameter: 10, length: 40}}
    pose: {{xyz: [0, 0, 50]}}
    start: {{location: tray, xyz: [100, 100, 5], rpy: [0, 90, 0]}}
resources:
  gripper: {{stroke: 60, finger: {{size: [16, 8, 25], friction: 1.0}}, max_force: 60}}
  table: {{size: [600, 400, 40]}}
  regrasp:
{regrasp}
"""

GOOD = """\
    - name: stand
      pose: {xyz: [-200, 100, 0], rpy: [0, 0, 90]}
      geometry:
        - {shape: box, size: [40, 40, 10], pose: {xyz: [0, 0, 5]}}
        - {shape: cylinder, diameter: 30, length: 20, pose: {xyz: [0, 0, 20]}}
      holds:
        - {part: pin, pose: {xyz: [0, 0, 50]}}"""


def _write(tmp_path: Path, regrasp: str) -> Path:
    p = tmp_path / "p.yaml"
    p.write_text(PRODUCT.format(regrasp=regrasp), encoding="utf-8")
    return p


def test_a_fixture_is_read_in_si_with_its_seat(tmp_path: Path) -> None:
    product = load_product(_write(tmp_path, GOOD))
    (fx,) = product.resources.regrasp
    assert fx.name == "stand" and fx.friction == 0.5
    assert [p.shape for p in fx.primitives] == ["box", "cylinder"]
    assert fx.primitives[1].diameter_m == pytest.approx(0.030)
    T = fx.T_world_seat("pin")
    # the seat is 50 mm above the fixture frame, which is turned 90 deg about z
    np.testing.assert_allclose(T[:3, 3], [-0.2, 0.1, 0.05], atol=1e-12)
    np.testing.assert_allclose(T[:3, 0], [0.0, 1.0, 0.0], atol=1e-12)
    assert fx.T_world_seat("block") is None


def test_every_bad_entry_is_reported_at_once_with_its_place(tmp_path: Path) -> None:
    bad = GOOD + """
    - name: stand
      pose: {xyz: [0, 150, 5]}
      geometry:
        - {shape: box, size: [40, 40, 10], pose: {xyz: [0, 0, 5]}}
      holds:
        - {part: pni, pose: {xyz: [0, 0, 30]}}
        - {part: block, pose: {xyz: [0, 0, 30]}}
    - name: pin
      pose: {xyz: [0, -150, 0]}
      geometry: [{shape: box, size: [40, 40, 10], pose: {xyz: [0, 0, 5]}}]
      holds: [{part: pin, pose: {xyz: [0, 0, 30]}}, {part: pin, pose: {xyz: [0, 0, 60]}}]"""
    with pytest.raises(ProductError) as info:
        load_product(_write(tmp_path, bad))
    text = [str(i) for i in info.value.issues]
    expected = [
        r'p\.yaml:\d+:\d+: resources\.regrasp\[1\]\.name: expected a unique fixture name, '
        r'found "stand" \(also regrasp\[0\]\)',
        r'resources\.regrasp\[1\]\.holds\[0\]\.part: unknown part "pni"; did you mean "pin"\?',
        r'resources\.regrasp\[1\]\.holds\[1\]\.part: expected a part the robot moves, found '
        r'"block", which is fixtured',
        r"resources\.regrasp\[1\]\.pose: expected the fixture on the table \(its lowest point "
        r"at z = 0\), found its lowest point at z = 5\.000 mm",
        r'resources\.regrasp\[2\]\.name: expected a unique fixture name, found "pin" \(also a '
        r'part\)',
        r'resources\.regrasp\[2\]\.holds\[1\]\.part: expected each part once per fixture, found '
        r'"pin" again',
    ]
    for pattern in expected:
        assert any(re.search(pattern, t) for t in text), (pattern, text)
    assert len(text) == len(expected), text


def test_schema_errors_name_the_key(tmp_path: Path) -> None:
    bad = """\
    - name: stand
      pose: {xyz: [0, 150, 0]}
      geometry: [{shape: cone, size: [1, 1, 1]}]
      hold: [{part: pin, pose: {xyz: [0, 0, 30]}}]"""
    with pytest.raises(ProductError) as info:
        load_product(_write(tmp_path, bad))
    text = "\n".join(str(i) for i in info.value.issues)
    assert 'resources.regrasp[0].geometry[0].shape: unknown shape "cone"' in text
    assert 'resources.regrasp[0].hold: unknown key "hold"; did you mean "holds"?' in text
    assert 'resources.regrasp[0]: missing required key "holds"' in text


def test_cli_exits_2_on_a_bad_fixture(tmp_path: Path, capsys) -> None:
    from asmplan.cli import main

    path = _write(tmp_path, GOOD.replace("part: pin", "part: pni"))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr()
    text = err.out + err.err
    assert 'resources.regrasp[0].holds[0].part: unknown part "pni"' in text
    assert "Traceback" not in text
