"""Imported CAD fixtures plan in a physically right order and simulate (issue 19 done-when)."""

from __future__ import annotations

from pathlib import Path

import pytest

from asmplan.knowledge.loader import load_product
from asmplan.parts.cad_import import import_assembly, write_product

pytest.importorskip("OCP")
CAD = Path(__file__).resolve().parent / "fixtures" / "cad"

# physically necessary precedences of each fixture (before, after), from its ground truth
PRECEDENCES = {
    "locating_fixture": [("dowel_1", "locating_plate"), ("dowel_2", "locating_plate"),
                         ("locating_plate", "locating_pin_1"), ("locating_plate", "locating_pin_2"),
                         ("locating_pin_1", "workpiece")],
    "bearing_housing": [("bearing_1", "spacer"), ("spacer", "bearing_2"), ("bearing_2", "cover")],
    "angle_bracket": [("dowel_1", "side_block"), ("dowel_2", "side_block"), ("post", "knob")],
}


def _imported(name: str, tmp_path: Path):
    out = tmp_path / f"{name}.yaml"
    write_product(import_assembly(CAD / f"{name}.step"), out)
    return load_product(out)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(PRECEDENCES))
def test_imported_fixture_sequences_in_a_physically_right_order(name, tmp_path):
    from asmplan.parts.models import ProductGeometry
    from asmplan.planner.fcl_oracle import FclOracle
    from asmplan.planner.sequence import plan_sequence

    product = _imported(name, tmp_path)
    plan = plan_sequence(product, FclOracle(product, ProductGeometry(product)))
    assert plan.sequences, f"{name}: no feasible order"
    for seq in plan.sequences:
        order = list(seq.order)
        assert order[0] == product.precedence.base
        for before, after in PRECEDENCES[name]:
            assert order.index(before) < order.index(after), (name, order)


@pytest.mark.slow
def test_imported_locating_fixture_runs_its_pin_steps_at_fast(tmp_path):
    """Dowels into the base, the locating plate onto both dowels and both locating pins are
    planned and simulated successfully at FAST (the workpiece onto a pin and a slot is not: it
    stops short, see docs/cad-import.md)."""
    from asmplan.pipeline import RunSettings, run_product

    product = _imported("locating_fixture", tmp_path)
    result = run_product(product, RunSettings(fidelity="fast", workers=1))
    assert result.results is not None, result.failure
    ok = {s.part for s in result.results.steps if s.outcome is not None and s.outcome.success}
    assert {"dowel_1", "dowel_2", "locating_plate", "locating_pin_1", "locating_pin_2"} <= ok


@pytest.mark.slow
def test_bearing_seated_flush_in_its_bore_has_no_gripper_grasp(tmp_path):
    """The ground truth calls the bearings a press-tool step: the planner finds no grasp for a
    two-finger gripper around a bearing that ends flush in its bore, and says so."""
    import yaml

    from asmplan.pipeline import RunSettings, run_product

    truth = yaml.safe_load((CAD / "bearing_housing.truth.yaml").read_text())
    assert not next(s for s in truth["order"] if s["part"] == "bearing_1")["feasible"]
    product = _imported("bearing_housing", tmp_path)
    result = run_product(product, RunSettings(fidelity="fast", workers=1, simulate=False))
    assert result.failure is not None
    assert 'part "bearing_1"' in result.failure and "no feasible grasp" in result.failure
