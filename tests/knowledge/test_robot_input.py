"""resources.robot: bundled and user URDFs, mounting and joint-limit overrides in SI, and every
bad arm input reported with file:line:column, key path, expected and found."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.loader import load_product
from asmplan.knowledge.robot import bundled_urdf

PRODUCT = """\
asmplan: 1
product: tiny
units: {{length: mm, mass: g, angle: deg}}
parts:
  - name: block
    material: steel
    geometry: {{type: box, size: [60, 60, 30]}}
    pose: {{xyz: [0, 0, 15]}}
    fixtured: true
resources:
  gripper: {{stroke: 60, finger: {{size: [16, 8, 25], friction: 1.0}}, max_force: 60}}
  table: {{size: [600, 400, 40]}}
  robot:
{robot}
"""


def _write(tmp_path: Path, robot: str) -> Path:
    p = tmp_path / "p.yaml"
    p.write_text(PRODUCT.format(robot=robot), encoding="utf-8")
    return p


def _error(tmp_path: Path, robot: str) -> str:
    with pytest.raises(ProductError) as info:
        load_product(_write(tmp_path, robot))
    assert len(info.value.issues) == 1, info.value
    return str(info.value.issues[0])


def test_bundled_arm_with_mounting_and_overrides(tmp_path: Path) -> None:
    p = load_product(_write(tmp_path, """\
    model: xarm6
    base: {xyz: [0, -350, 0], rpy: [0, 0, 90]}
    mounting: {xyz: [0, 0, 60]}
    joints: {joint5: {lower: -90, upper: 90, velocity: 60, acceleration: 200}}"""))
    r = p.resources.robot
    assert r.urdf_path == bundled_urdf("xarm6") and r.flange_link == "link6"
    assert r.T_world_base[:3, 3] == pytest.approx([0.0, -0.35, 0.0])
    assert r.T_world_base[:2, 0] == pytest.approx([0.0, 1.0])  # yaw 90 deg
    assert r.T_flange_tcp[:3, 3] == pytest.approx([0.0, 0.0, 0.06])
    assert r.reach_m is None
    j = {x.name: x for x in r.joints}
    assert [x.name for x in r.joints] == [f"joint{i}" for i in range(1, 7)]
    assert (j["joint5"].lower_rad, j["joint5"].upper_rad) == pytest.approx((-math.pi / 2, math.pi / 2))
    assert j["joint5"].velocity_rad_s == pytest.approx(math.pi / 3)
    assert j["joint5"].acceleration_rad_s2 == pytest.approx(math.radians(200))
    # the rest from the URDF (xarm6_robot.urdf: joint2 -2.059 .. 2.0944 rad, 3.14 rad/s)
    assert (j["joint2"].lower_rad, j["joint2"].upper_rad) == (-2.059, 2.0944)
    assert j["joint2"].velocity_rad_s == 3.14


def test_unknown_model(tmp_path: Path) -> None:
    msg = _error(tmp_path, "    model: xarm7")
    assert msg.startswith(f"{tmp_path / 'p.yaml'}:14:12: resources.robot.model: ")
    assert 'expected a bundled arm (xarm6) or a path to a .urdf file, found unknown model "xarm7"' in msg
    assert 'did you mean "xarm6"' in msg


def test_missing_urdf_file(tmp_path: Path) -> None:
    msg = _error(tmp_path, "    model: cell/arm.urdf")
    assert ":14:12: resources.robot.model: expected an existing URDF file, found no file " \
           '"cell/arm.urdf"' in msg


def test_seven_axis_urdf_is_refused(tmp_path: Path) -> None:
    kuka = Path(bundled_urdf("xarm6")).parents[1] / "kuka_iiwa" / "model.urdf"
    msg = _error(tmp_path, f"    model: {kuka}")
    assert "resources.robot.model: expected a 6-axis arm" in msg and "found 7 in model.urdf" in msg


def test_bad_xml_and_missing_mesh(tmp_path: Path) -> None:
    (tmp_path / "broken.urdf").write_text("<robot name='x'><link name='a'>", encoding="utf-8")
    msg = _error(tmp_path, "    model: broken.urdf")
    assert "resources.robot.model: expected a URDF (XML) file, found invalid XML" in msg
    src = Path(bundled_urdf("xarm6")).read_text(encoding="utf-8")
    (tmp_path / "nomesh.urdf").write_text(src, encoding="utf-8")  # package folder not beside it
    msg = _error(tmp_path, "    model: nomesh.urdf")
    assert 'expected the mesh "package://xarm_description/meshes/xarm6/collision/base_vhacd.obj"' \
           in msg


def test_unknown_joint_and_inverted_limits_all_at_once(tmp_path: Path) -> None:
    with pytest.raises(ProductError) as info:
        load_product(_write(tmp_path, """\
    model: xarm6
    joints: {joint7: {lower: 0}, joint2: {lower: 50, upper: 10}}"""))
    msgs = [str(i) for i in info.value.issues]
    assert len(msgs) == 2
    assert any('resources.robot.joints.joint7: expected a joint of the arm (joint1, joint2, '
               'joint3, joint4, joint5, joint6), found "joint7"' in m for m in msgs)
    assert any("resources.robot.joints.joint2: expected lower < upper, found 50 >= 10 deg" in m
               for m in msgs)


def test_the_urdf_is_not_rescaled_by_the_product_units(tmp_path: Path) -> None:
    text = PRODUCT.format(robot="    model: xarm6\n    base: {xyz: [0, -14, 0]}").replace(
        "length: mm", "length: in").replace("[60, 60, 30]", "[2, 2, 1]").replace(
        "xyz: [0, 0, 15]", "xyz: [0, 0, 0.5]").replace("[600, 400, 40]", "[24, 16, 1.5]").replace(
        "stroke: 60", "stroke: 2.4").replace("[16, 8, 25]", "[0.6, 0.3, 1]")
    p = tmp_path / "inch.yaml"
    p.write_text(text, encoding="utf-8")
    r = load_product(p).resources.robot
    assert r.T_world_base[1, 3] == pytest.approx(-14 * 0.0254)  # the YAML's lengths: inches
    from asmplan.planner.arm import ArmModel
    from asmplan.planner.settings import ArmSettings

    arm = ArmModel(r, ArmSettings())
    # the URDF's own metres: joint 2 sits 0.267 m above the base whatever the YAML's unit
    assert arm.shoulder_base == pytest.approx(np.array([0.0, 0.0, 0.267]))


def test_cli_exits_2_on_a_bad_arm(tmp_path: Path, capsys) -> None:
    from asmplan.cli import main

    path = _write(tmp_path, "    model: xarm6\n    joints: {joint9: {upper: 10}}")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr()
    text = err.out + err.err
    assert "resources.robot.joints.joint9: expected a joint of the arm" in text
    assert "Traceback" not in text
