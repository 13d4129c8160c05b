"""The Plan: JSON round trip, byte identity, validation; the ``asmplan plan`` command."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from asmplan.cli import main
from asmplan.planner.plan import PLAN_FORMAT, Grasp, Plan, Step
from asmplan.planner.product import plan_product
from asmplan.planner.settings import PlannerSettings
from tests.conftest import example_path
from tests.planner.conftest import FIXTURES, ORDERS


@pytest.fixture(scope="module")
def peg_plan(examples, geometry_cache) -> Plan:
    product = examples["peg_in_hole"]
    return plan_product(product, geometry_cache.geo(product), PlannerSettings(), sequence=ORDERS["peg_in_hole"],
                        parts=geometry_cache.parts(product)).plan


def test_json_round_trip_is_byte_identical(peg_plan, tmp_path):
    text = peg_plan.to_json()
    again = Plan.from_json(text)
    assert again.to_json() == text
    path = peg_plan.write(tmp_path / "plan.json")
    assert path.read_text(encoding="utf-8") == text
    assert not [p for p in tmp_path.iterdir() if p.name != "plan.json"]  # no temp file left
    back = Plan.read(path)
    step = back.step("peg")
    np.testing.assert_array_equal(step.trajectory.T_world_gripper,
                                  peg_plan.step("peg").trajectory.T_world_gripper)
    assert step.commanded_force_N == pytest.approx(peg_plan.step("peg").clamp.commanded_N)
    doc = json.loads(text)
    assert doc["format"] == PLAN_FORMAT and doc["version"] == 1
    assert doc["sequence"] == ["block", "peg"]
    assert doc["steps"][0]["kind"] == "fixture" and doc["steps"][0]["trajectory"] is None
    assert len(doc["source_sha256"]) == 64


def test_clamp_force_in_the_plan_follows_the_physics(peg_plan, examples):
    from asmplan.planner.grasp_hold import ContactPatch, hold_requirement

    product = examples["peg_in_hole"]
    step = peg_plan.step("peg")
    mass = step.clamp.mass_kg
    # a steel cylinder 10 mm x 40 mm (the pin is part of it): 7850 kg/m^3 within 1 %
    assert mass == pytest.approx(7850 * np.pi * 0.005**2 * 0.04, rel=0.01)
    mu = product.resources.gripper.finger_friction * product.part("peg").friction
    # the grasp closes across the upright peg from above: each flat pad touches the flank
    # along a line, from the pad's tip (TCP - L/2 along the peg axis) to the peg's top end
    # (z = 20 mm), so the contact length and its centre's lever follow from the TCP alone
    T = step.grasp.T_part_gripper
    np.testing.assert_allclose(np.abs(T[:3, 2]), [0, 0, 1], atol=1e-9)
    L = float(product.resources.gripper.finger_size_m[2])
    z_lo, z_hi = max(T[2, 3] - L / 2, -0.02), min(T[2, 3] + L / 2, 0.02)
    length, centre = z_hi - z_lo, 0.5 * (z_hi + z_lo)
    # a line of length l resists like a pad "width" l (rho = l / 4): sampled within 2 %
    assert step.clamp.pad_width_m == pytest.approx(length, rel=0.02)
    assert step.clamp.lever_m == pytest.approx(abs(centre), abs=6e-4)
    # the required force is the hold criterion's for two such lines (gravity along the
    # approach at both poses, a = 2 m/s^2 in any direction), safety factor included
    line = np.zeros((2001, 2))
    line[:, 1] = np.linspace(z_lo, z_hi, 2001) - T[2, 3]
    patch = ContactPatch(line * [1, -1], 0.0)  # pad z is -part z
    down = (np.array([0.0, 0.0, 1.0]),)  # world down is the approach (+z) in the gripper frame
    expected = hold_requirement(patch, patch, np.array([0.0, 0.0, T[2, 3]]), mass, 2.0, mu,
                                product.process.safety_factor, down).required_N
    # and never less than the former model: sf sqrt(F_t^2 + F_m^2), F_t = m (g + a) / (2 mu),
    # F_m = 2 m (g d_g + a d) / (mu W), d the TCP's distance from the centre of mass normal to
    # the closing axis, d_g its horizontal part, W the finger width (planner/timing.py)
    W = float(product.resources.gripper.finger_size_m[0])
    o, y = T[:3, 3], T[:3, 1]
    perp = -o - (-o @ y) * y  # the peg is a centred cylinder: centre of mass ~ part origin
    d, d_g = float(np.linalg.norm(perp)), float(np.linalg.norm(perp[:2]))
    former = product.process.safety_factor * float(np.hypot(
        mass * (9.81 + 2.0) / (2 * mu), 2 * mass * (9.81 * d_g + 2.0 * d) / (mu * W)))
    assert step.clamp.required_N == pytest.approx(max(expected, former), rel=0.03)
    assert step.clamp.commanded_N == pytest.approx(
        max(expected, former, product.resources.gripper.min_force_N), rel=0.03)
    # at least the classic slip force with the safety factor: the moment adds to it
    assert step.clamp.required_N >= product.process.safety_factor * mass * (9.81 + 2.0) / (2 * mu)
    assert step.clamp.slip_limit_N == pytest.approx(mass * (9.81 + 2.0) / (2 * mu), rel=1e-9)
    held = [p.name for p in step.trajectory.phases if p.name not in ("approach", "retreat")]
    for name in ("hold", "lift", "translate", "lower"):
        span = step.trajectory.phase_span(name)
        assert step.trajectory.force_at(0.5 * (span.t_start_s + span.t_end_s)) == \
            pytest.approx(step.clamp.commanded_N, rel=1e-12)
    assert held == ["clamp", "hold", "lift", "translate", "lower", "release"]


def test_validation_says_expected_and_found(peg_plan):
    g = peg_plan.step("peg").grasp
    with pytest.raises(ValueError, match=r"expected 0 < width_m <= open_width_m"):
        dataclasses.replace(g, open_width_m=g.width_m / 2)
    with pytest.raises(ValueError, match=r"T_part_gripper: expected a rigid transform"):
        Grasp(g.part, np.diag([2.0, 1.0, 1.0, 1.0]), g.width_m, g.open_width_m,
              g.contact_area_m2, g.com_offset_m, g.source, g.cost)
    s = peg_plan.step("peg")
    with pytest.raises(ValueError, match=r"needs a grasp and a trajectory"):
        Step(s.index, s.part, "insert", s.mates, s.T_world_start, s.T_world_final)
    with pytest.raises(ValueError, match=r"expected steps in sequence order"):
        dataclasses.replace(peg_plan, sequence=("peg", "block"))
    with pytest.raises(ValueError, match=r"planner: expected one of .* found 'RRTX'"):
        PlannerSettings(planner="RRTX")
    with pytest.raises(ValueError, match=r"expected format 'asmplan-plan', found 'other'"):
        Plan.from_dict({"format": "other"})


def test_cli_plan_writes_a_plan_and_a_summary(tmp_path, capsys):
    out = tmp_path / "plan.json"
    code = main(["plan", str(example_path("peg_in_hole")), "-o", str(out), "--seed", "3"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    plan = Plan.read(out)
    assert plan.sequence == ("block", "peg") and plan.settings.seed == 3
    assert "sequence planner" in plan.sequence_note
    assert "step  part" in captured.out and "peg" in captured.out
    assert "plan: 2/2 peg" in captured.err  # plain progress lines when not a TTY
    # the same input and seed give the same bytes
    out2 = tmp_path / "again.json"
    assert main(["plan", str(example_path("peg_in_hole")), "-o", str(out2), "--seed", "3"]) == 0
    assert out2.read_bytes() == out.read_bytes()


def test_cli_blocked_product_fails_naming_the_obstacle(tmp_path, capsys):
    out = tmp_path / "plan.json"
    code = main(["plan", str(FIXTURES / "blocked_product.yaml"), "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 1
    assert 'blocked by "bridge"' in err and "contact: bridge / peg" in err
    assert not out.exists()


def test_cli_bad_input_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("asmplan: 1\nproduct: x\nparts: []\n", encoding="utf-8")
    assert main(["plan", str(bad), "-o", str(tmp_path / "p.json")]) == 2
    assert main(["plan", str(example_path("peg_in_hole")), "--sequence", "peg,nope",
                 "-o", str(tmp_path / "p.json")]) == 2
    assert "expected every part" in capsys.readouterr().err


def test_progress_bar_on_a_terminal_and_lines_otherwise():
    import io

    from asmplan.commands.textout import StageProgress

    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    tty, plain = Tty(), io.StringIO()
    for stream in (tty, plain):
        p = StageProgress(stream)
        p("plan", 0, 2, "")
        for k, part in enumerate(("a", "b")):
            p("plan", k + 1, 2, part)
    assert tty.getvalue().count("\rplan") == 3 and tty.getvalue().endswith("\n")
    assert "[########################] 2/2" in tty.getvalue()
    lines = plain.getvalue().splitlines()
    assert len(lines) == 2 and lines[1].startswith("plan: 2/2 b (")
