"""``--pose-error LATERAL_MM,TILT_DEG`` on ``asmplan run`` and ``asmplan simulate`` (issue 16)."""

from __future__ import annotations

import json

import pytest

from asmplan.cli import main
from tests.conftest import example_path


def _unchamfered_peg(tmp_path):
    text = example_path("peg_in_hole").read_text(encoding="utf-8")
    product = tmp_path / "peg_no_chamfer.yaml"
    product.write_text(text.replace(", chamfer: 0.5}", "}"), encoding="utf-8")
    assert "chamfer" not in product.read_text(encoding="utf-8")
    return product


@pytest.mark.slow
def test_half_a_millimetre_off_without_chamfer_stops_on_the_rim(tmp_path, capsys):
    """H7/g6 (5-29 um diametral) without chamfers: 0.5 mm off is far outside the capture
    boundary |e0| < c/2; 0.005 mm is inside it. (0.05 mm is outside it too: it stops on the
    rim as well, measured.)"""
    product = _unchamfered_peg(tmp_path)
    out = tmp_path / "off"
    code = main(["run", str(product), "-o", str(out), "--no-report", "-j", "1",
                 "--pose-error", "0.5,0"])
    text = capsys.readouterr().out
    assert code == 1
    assert "stopped on the rim" in text
    step = next(s for s in json.loads((out / "results.json").read_text())["steps"]
                if s["simulated"])
    assert step["pose_error"] == {"lateral_m": [0.0005, 0.0], "tilt_rad": [0.0, 0.0]}
    assert step["outcome"]["failures"][0]["code"] == "rim_stop"
    code = main(["run", str(product), "-o", str(tmp_path / "on"), "--no-report", "-j", "1",
                 "--pose-error", "0.005,0"])
    assert code == 0, capsys.readouterr().out


@pytest.mark.parametrize("value", ["abc", "0.5", "0.5,0,1", "nan,0", "0.5,90", "1e3,0", ","])
@pytest.mark.parametrize("command", ["run", "simulate"])
def test_bad_pose_error_exits_2_naming_the_option(tmp_path, capsys, value, command):
    args = ([command, str(example_path("peg_in_hole")), "-o", str(tmp_path / "o")]
            if command == "run" else [command, str(tmp_path / "plan.json")])
    assert main([*args, "--pose-error", value]) == 2
    err = capsys.readouterr().err
    assert "--pose-error" in err and "expected" in err
    assert "Traceback" not in err
