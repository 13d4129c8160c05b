"""Sequence planning: geometric feasibility, precedence with reasons, stability, search, costs.

Two kinds of geometry: the real one (FCL on the exact collision models of ``asmplan.parts``,
through :class:`asmplan.planner.fcl_oracle.FclOracle`) for the example products, and a test
double (:class:`BoxOracle`: axis-aligned boxes of the primitives, mated pairs free only along
their mate axis) for the search logic, where the expected answers follow from combinatorics.
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from asmplan.knowledge.generator import generate_product, generated_product
from asmplan.knowledge.graphs import precedence_graph
from asmplan.knowledge.loader import load_product
from asmplan.knowledge.model import Product
from asmplan.parts.models import ProductGeometry
from asmplan.planner.blocking import BlockingTable, blocking_table, mate_insertion_direction
from asmplan.planner.sequence import (
    COST_TERMS,
    NoFeasibleSequenceError,
    PrecedenceConflictError,
    SequenceSettings,
    plan_sequence,
)

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "sequence"


# --------------------------------------------------------------------------------------------
# Test double: boxes and mate axes
# --------------------------------------------------------------------------------------------
def _primitive_box(prim, T_world_part: np.ndarray) -> np.ndarray:
    if prim.shape == "box":
        h = np.asarray(prim.size_m) / 2
    elif prim.shape == "cylinder":
        h = np.array([prim.diameter_m / 2, prim.diameter_m / 2, prim.length_m / 2])
    else:
        h = np.full(3, prim.diameter_m / 2)
    corners = np.array(list(itertools.product((-1, 1), repeat=3))) * h
    M = T_world_part @ prim.T_part_shape
    w = corners @ M[:3, :3].T + M[:3, 3]
    return np.stack([w.min(axis=0), w.max(axis=0)])


class BoxOracle:
    """Each primitive is its world AABB (holes and pins ignored); a mated pair blocks each
    other except along the mate's own removal direction; touching faces do not block."""

    def __init__(self, product: Product, tolerance_m: float = 1e-7):
        self.product = product
        self.tol = tolerance_m
        self.boxes = {p.name: [_primitive_box(pr, product.T_world_assembled(p.name))
                               for pr in p.geometry.primitives] for p in product.parts}

    def bounds(self, part: str) -> np.ndarray:
        b = np.stack(self.boxes[part])
        return np.stack([b[:, 0].min(axis=0), b[:, 1].max(axis=0)])

    def _hits(self, A: np.ndarray, B: np.ndarray, d: np.ndarray, dist: float) -> bool:
        lo, hi = 1e-12, dist
        for i in range(3):
            if abs(d[i]) < 1e-12:
                if not (A[0, i] < B[1, i] - self.tol and A[1, i] > B[0, i] + self.tol):
                    return False
                continue
            t1 = (B[1, i] - self.tol - A[0, i]) / d[i]
            t2 = (B[0, i] + self.tol - A[1, i]) / d[i]
            lo, hi = max(lo, min(t1, t2)), min(hi, max(t1, t2))
        return lo < hi

    def blockers(self, part: str, direction: np.ndarray, distance_m: float) -> frozenset[str]:
        d = np.asarray(direction, dtype=float)
        out = set()
        for q in self.boxes:
            if q == part:
                continue
            mates = [m for m in self.product.mates if {m.pin_part, m.hole_part} == {part, q}]
            if mates:
                free = all(float(np.dot(d, -mate_insertion_direction(self.product, m.name, part)))
                           > 1 - 1e-9 for m in mates)
                if not free:
                    out.add(q)
                continue
            if any(self._hits(A, B, d, distance_m) for A in self.boxes[part] for B in self.boxes[q]):
                out.add(q)
        return frozenset(out)


def _with_double(product: Product, **settings: object):
    # the box double replaces the geometry: the gripper screening (real FCL geometry) and the
    # collapsing of identical parts (these fixtures' blocks are identical) are tested apart
    settings = {"gripper_access": False, "collapse_identical": False, **settings}
    return plan_sequence(product, BoxOracle(product), SequenceSettings(**settings))


def _load_text(tmp_path: Path, text: str, name: str = "product.yaml") -> Product:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return load_product(path)


# --------------------------------------------------------------------------------------------
# Settings
# --------------------------------------------------------------------------------------------
def test_settings_reject_bad_values() -> None:
    with pytest.raises(ValueError, match=r"reorientation_s: expected a finite weight >= 0, found -1"):
        SequenceSettings(reorientation_s=-1.0)
    with pytest.raises(ValueError, match=r"beam_width: expected an integer >= 1, found 0"):
        SequenceSettings(beam_width=0)
    with pytest.raises(ValueError, match=r"max_beam_width: expected >= beam_width \(64\)"):
        SequenceSettings(beam_width=64, max_beam_width=8)


# --------------------------------------------------------------------------------------------
# Search logic on the box double (combinatorial expectations)
# --------------------------------------------------------------------------------------------
def test_independent_blocks_give_every_permutation() -> None:
    product = load_product(FIXTURES / "three_blocks.yaml")
    plan = _with_double(product, top_k=100)
    expected = {("plate", *perm) for perm in itertools.permutations("abc")}
    assert plan.method == "exhaustive"
    assert plan.feasible_count == 6 == math.factorial(3)
    assert {s.order for s in plan.sequences} == expected
    # only the base is necessarily before anything
    assert set(plan.necessary) == {("plate", x) for x in "abc"}


def test_group_is_consecutive(tmp_path: Path) -> None:
    text = (FIXTURES / "three_blocks.yaml").read_text(encoding="utf-8").replace(
        "  base: plate\n", "  base: plate\n  groups:\n    - {parts: [a, c], reason: same tray}\n")
    plan = _with_double(_load_text(tmp_path, text), top_k=100)
    orders = {s.order for s in plan.sequences}
    expected = {("plate", *p) for p in itertools.permutations("abc")
                if abs(p.index("a") - p.index("c")) == 1}
    assert orders == expected and len(expected) == 4
    assert plan.feasible_count == 4


def test_costs_are_sorted_and_sum_their_breakdown() -> None:
    product = load_product(FIXTURES / "three_blocks.yaml")
    settings = SequenceSettings(top_k=100)
    plan = _with_double(product, top_k=100)
    costs = [s.cost_s for s in plan.sequences]
    assert costs == sorted(costs)
    for s in plan.sequences:
        assert s.cost_s == pytest.approx(sum(s.breakdown.values()), abs=1e-12)
        for t in COST_TERMS:
            assert s.breakdown[t] == pytest.approx(settings.weights[t] * s.terms[t], abs=1e-12)


def test_travel_term_matches_hand_computation() -> None:
    """Travel: the plate (fixtured, no trip) is where the arm is; then plate origin -> a's
    tray -> a's place -> b's tray -> ... (the YAML numbers)."""
    product = load_product(FIXTURES / "three_blocks.yaml")
    plan = _with_double(product, top_k=100)
    seq = next(s for s in plan.sequences if s.order == ("plate", "a", "b", "c"))
    mm = 1e-3
    here = np.array([0.0, 0.0, 5.0]) * mm  # the plate's origin
    travel = 0.0
    for x in (-100.0, 0.0, 100.0):
        tray, place = np.array([x, 300.0, 20.0]) * mm, np.array([x, 0.0, 20.0]) * mm
        travel += np.linalg.norm(tray - here) + np.linalg.norm(place - tray)
        here = place
    assert seq.terms["travel_m"] == pytest.approx(travel, rel=1e-12)
    # sweeping along the row is shortest; the mirrored sweep ties and loses on name order
    assert plan.sequences[0].order == ("plate", "a", "b", "c")
    assert plan.sequences[1].order == ("plate", "c", "b", "a")
    assert plan.sequences[0].cost_s == pytest.approx(plan.sequences[1].cost_s, abs=1e-9)
    assert plan.sequences[2].cost_s > plan.sequences[1].cost_s + 0.1


def test_weights_change_the_ranking() -> None:
    """With travel free and nothing else differing, ties fall back to name order."""
    product = load_product(FIXTURES / "three_blocks.yaml")
    plan = _with_double(product, travel_s_per_m=0.0)
    assert plan.best.order == ("plate", "a", "b", "c")
    assert plan.best.cost_s == pytest.approx(plan.sequences[-1].cost_s)


def test_floating_part_has_no_feasible_sequence(tmp_path: Path) -> None:
    text = (FIXTURES / "three_blocks.yaml").read_text(encoding="utf-8")
    text = text.replace("pose: {xyz: [100, 0, 20]}", "pose: {xyz: [100, 0, 60]}")
    text = text.replace("  - {name: mc, pin: c.p, hole: plate.hc, fit: H7/g6}\n", "")
    product = _load_text(tmp_path, text)
    with pytest.raises(NoFeasibleSequenceError, match=r"c: nothing can hold it") as info:
        _with_double(product)
    assert info.value.dead_end == ("plate",)
    assert "c" in info.value.reasons


def test_beam_reaches_the_exhaustive_optimum_when_wide() -> None:
    product = generated_product(12, seed=0)
    table = blocking_table(product, BoxOracle(product))
    exact = plan_sequence(product, settings=SequenceSettings(top_k=3), table=table)
    assert exact.method == "exhaustive"
    narrow = plan_sequence(product, settings=SequenceSettings(max_states=1, beam_width=2),
                           table=table)
    # wide enough to keep every (state, last part) bucket with its top-3 labels at any depth
    width = exact.states * len(product.part_names) * 3
    wide = plan_sequence(product, settings=SequenceSettings(max_states=1, beam_width=width,
                                                            max_beam_width=width),
                         table=table)
    assert narrow.method == wide.method == "beam"
    assert narrow.best.cost_s >= exact.best.cost_s - 1e-9
    assert wide.best.cost_s == pytest.approx(exact.best.cost_s, abs=1e-9)
    assert wide.best.order == exact.best.order


def test_same_input_same_output() -> None:
    product = generated_product(15, seed=4)
    a = _with_double(product).as_dict()
    b = _with_double(product).as_dict()
    for d in (a, b):
        d.pop("timings_s")
    assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


# --------------------------------------------------------------------------------------------
# Generator
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("n_parts", [2, 5, 10, 20, 50])
def test_generator_is_deterministic_and_exact_in_size(n_parts: int) -> None:
    a, b = generate_product(n_parts, seed=7), generate_product(n_parts, seed=7)
    assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)
    product = generated_product(n_parts, seed=7)
    assert len(product.parts) == n_parts
    assert product.is_fixtured("base")


def test_generator_seeds_differ_and_use_two_insertion_axes() -> None:
    docs = [json.dumps(generate_product(30, seed=s), sort_keys=True) for s in range(3)]
    assert len(set(docs)) == 3
    product = generated_product(30, seed=1)
    axes = {tuple(np.round(mate_insertion_direction(product, m.name, m.pin_part), 6))
            for m in product.mates}
    assert (0.0, 0.0, -1.0) in axes and len(axes) >= 2
    assert any(p.name.endswith("_cover") for p in product.parts)


# --------------------------------------------------------------------------------------------
# Real geometry (FCL on the exact convex pieces of asmplan.parts)
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def fcl_tables(examples: dict[str, Product]) -> dict[str, BlockingTable]:
    """Blocking tables of the bundled examples, swept once with FCL."""
    from asmplan.planner.fcl_oracle import FclOracle

    return {name: blocking_table(p, FclOracle(p, ProductGeometry(p))) for name, p in examples.items()}


def _removal_blockers(table: BlockingTable, part: str, removal: str) -> frozenset[str]:
    (i,) = [k for k, d in enumerate(table.directions[part]) if d.label == removal]
    return table.blockers[part][i]


def _assert_feasible(product: Product, table: BlockingTable, order: tuple[str, ...]) -> None:
    """Replay ``order`` against the blocking table, the rules and the stability rule."""
    assert sorted(order) == sorted(product.part_names)
    partners: dict[str, set[str]] = {p: set() for p in product.part_names}
    for m in product.mates:
        partners[m.pin_part].add(m.hole_part)
        partners[m.hole_part].add(m.pin_part)
    placed: set[str] = set()
    for p in order:
        free = [d.insertion_label for d, b, t in zip(table.directions[p], table.blockers[p],
                                                     table.table_blocked[p], strict=True)
                if not t and not (b & placed)]
        assert free, f"{p} has no free insertion direction after {sorted(placed)}"
        held = (product.is_fixtured(p) or table.on_table[p] or table.supporters[p] & placed
                or partners[p] & placed)
        assert held, f"nothing holds {p} after {sorted(placed)}"
        placed.add(p)
    for rule in product.precedence.rules:
        assert order.index(rule.before) < order.index(rule.after), rule
    if product.precedence.base:
        assert order[0] == product.precedence.base


@pytest.mark.slow  # shares the FCL sweeps of the examples (~2 s)
def test_peg_in_hole_exactly_block_then_peg(examples, fcl_tables) -> None:
    product, table = examples["peg_in_hole"], fcl_tables["peg_in_hole"]
    plan = plan_sequence(product, settings=SequenceSettings(top_k=10), table=table)
    assert plan.feasible_count == 1
    assert [s.order for s in plan.sequences] == [("block", "peg")]
    # H7/g6 (positive clearance): the peg leaves its hole upward touching nothing
    assert _removal_blockers(table, "peg", "+z") == frozenset()
    assert plan.best.steps[1].insertion_label == "-z"


@pytest.mark.slow  # shares the FCL sweeps of the examples (~2 s)
def test_pinhole_station_has_one_feasible_order(examples, fcl_tables) -> None:
    product, table = examples["pinhole_station"], fcl_tables["pinhole_station"]
    plan = plan_sequence(product, settings=SequenceSettings(top_k=100), table=table)
    assert plan.feasible_count == 1
    assert [s.order for s in plan.sequences] == [("part1", "part2", "part3", "part4")]
    assert [s.insertion_label for s in plan.best.steps] == ["-z"] * 4
    # pins slide out of their holes along the mate axis: only the parts above block
    assert _removal_blockers(table, "part4", "+z") == frozenset()
    assert _removal_blockers(table, "part3", "+z") == {"part4"}
    assert _removal_blockers(table, "part2", "+z") == {"part3", "part4"}
    # sideways, the pins in the part below (and the pins of the part above) block
    assert _removal_blockers(table, "part3", "+x") == {"part2", "part4"}
    _assert_feasible(product, table, plan.best.order)


@pytest.mark.slow  # shares the FCL sweeps of the examples (~2 s)
def test_gear_unit_geometry_reveals_wheel_and_shaft_before_cover(examples, fcl_tables) -> None:
    product, table = examples["gear_unit"], fcl_tables["gear_unit"]
    knowledge = precedence_graph(product)
    assert not nx.has_path(knowledge, "wheel", "cover")
    assert not nx.has_path(knowledge, "shaft", "cover")
    plan = plan_sequence(product, settings=SequenceSettings(top_k=1000, collapse_identical=False),
                         table=table)
    assert plan.feasible_count == len(plan.sequences) > 1
    for s in plan.sequences:
        assert s.order.index("shaft") < s.order.index("wheel") < s.order.index("cover")
        _assert_feasible(product, table, s.order)
    assert {("shaft", "cover"), ("wheel", "cover")} <= set(plan.necessary)
    # wheel before cover: a geometry edge; the flange blocks -x, the bearing block +x
    (geo,) = [o for o in plan.origins("wheel", "cover") if o["kind"] == "geometry"]
    assert geo["blocker"] == "cover" and geo["blocked_directions"] == ["-x"]
    assert "bearing_block" in geo["given"]
    assert "with cover in place wheel cannot be inserted" in geo["reason"]
    # the flange is in the shaft's way along -x too, but the shaft could come in along +x:
    # shaft before cover holds through the wheel, which only the shaft can hold
    assert "cover" in _removal_blockers(table, "shaft", "+x")
    assert _removal_blockers(table, "shaft", "-x") == frozenset()
    text = plan.explain("shaft", "cover")
    assert "shaft -> wheel -> cover" in text
    assert "stability: wheel is not fixtured" in text
    assert "cover blocks its insertion along -x" in text
    assert "Directly, cover blocks shaft's insertion along -x but not along +x" in text
    # the rule "bearing_block before cover" is also geometry
    kinds = {o["kind"] for o in plan.origins("bearing_block", "cover")}
    assert kinds == {"rule", "geometry"}


@pytest.mark.slow  # shares the FCL sweeps of the examples (~2 s)
def test_gear_unit_rule_implied_by_geometry_changes_nothing(examples, fcl_tables, tmp_path) -> None:
    product, table = examples["gear_unit"], fcl_tables["gear_unit"]
    text = (Path(product.source)).read_text(encoding="utf-8")
    line = next(ln for ln in text.splitlines(keepends=True) if "{before: bearing_block, after: cover" in ln)
    reduced = _load_text(tmp_path, text.replace(line, "").replace("  rules:\n", "  rules: []\n"))
    assert reduced.precedence.rules == ()
    with_rule = plan_sequence(product, settings=SequenceSettings(top_k=1000), table=table)
    without = plan_sequence(reduced, settings=SequenceSettings(top_k=1000), table=table)
    assert without.best.order == with_rule.best.order
    assert without.best.cost_s == pytest.approx(with_rule.best.cost_s, abs=1e-12)
    assert without.feasible_count == with_rule.feasible_count
    assert [s.order for s in without.sequences] == [s.order for s in with_rule.sequences]
    assert without.necessary == with_rule.necessary
    assert [o["kind"] for o in without.origins("bearing_block", "cover")] == ["geometry"]


def test_contradictory_rule_names_the_rule_and_the_geometry() -> None:
    from asmplan.planner.fcl_oracle import FclOracle

    path = FIXTURES / "contradictory_rules.yaml"
    line = 1 + next(i for i, ln in enumerate(path.read_text(encoding="utf-8").splitlines())
                    if "{before: cap, after: riser" in ln)
    product = load_product(path)
    with pytest.raises(PrecedenceConflictError) as info:
        plan_sequence(product, FclOracle(product, ProductGeometry(product)))
    err = info.value
    message = str(err)
    assert f"contradictory_rules.yaml:{line}:" in message
    assert 'rule "cap before riser" (the cap is pre-assembled on the plate by the supplier) ' \
           "contradicts the geometry" in message
    assert "riser must come before cap" in message
    assert "with cap in place riser cannot be inserted: cap blocks its insertion along -z" in message
    assert [(r.before, r.after, r.source_line) for r in err.rules] == [("cap", "riser", line)]
    (edge,) = err.geometry
    assert (edge["before"], edge["after"]) == ("riser", "cap")
    assert any(o["kind"] == "geometry" and o["blocker"] == "cap" for o in edge["origins"])


@pytest.mark.slow
def test_fifty_parts_plan_in_one_go() -> None:
    """50 generated parts: beam search, a feasible best sequence (timing: the benchmark)."""
    from asmplan.planner.fcl_oracle import FclOracle

    product = generated_product(50, seed=0)
    plan = plan_sequence(product, FclOracle(product, ProductGeometry(product)))
    assert plan.method == "beam" and plan.feasible_count is None
    assert len(plan.sequences) == SequenceSettings().top_k
    for s in plan.sequences:
        _assert_feasible(product, plan.blocking, s.order)
    # every L-cover comes after the side plate its flange shields (geometry only)
    covers = [p for p in product.part_names if p.endswith("_cover")]
    for cover in covers:
        side = cover.replace("_cover", "_side")
        if side in product.part_names and any(o["kind"] == "geometry"
                                              for o in plan.origins(side, cover)):
            assert plan.best.order.index(side) < plan.best.order.index(cover)


def test_generated_l_cover_shields_the_side_plate() -> None:
    """The generator's L-cover: side plate before cover is geometry, not a rule."""
    from asmplan.planner.fcl_oracle import FclOracle

    product = generated_product(5, seed=0)
    assert [r.after for r in product.precedence.rules] == ["c0_cover"]
    assert ("c0_side", "c0_cover") not in {(r.before, r.after) for r in product.precedence.rules}
    plan = plan_sequence(product, FclOracle(product, ProductGeometry(product)), SequenceSettings(top_k=10))
    assert plan.feasible_count == 1
    assert plan.best.order == ("base", "c0_block0", "c0_block1", "c0_side", "c0_cover")
    (geo,) = [o for o in plan.origins("c0_side", "c0_cover") if o["kind"] == "geometry"]
    assert geo["blocked_directions"] == ["-x"]
    assert plan.best.steps[3].insertion_label == "-x"


# --------------------------------------------------------------------------------------------
# CLI
# --------------------------------------------------------------------------------------------
def test_cli_json_lists_sequences_costs_and_reasons(examples, capsys) -> None:
    from asmplan.cli import main

    path = str(examples["pinhole_station"].source)
    assert main(["sequence", path, "--json", "--top", "3"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["feasible"] is True and out["feasible_count"] == 1
    assert [s["order"] for s in out["sequences"]] == [["part1", "part2", "part3", "part4"]]
    (seq,) = out["sequences"]
    assert set(seq["cost_terms"]) == set(COST_TERMS)
    assert seq["cost_s"] == pytest.approx(sum(t["cost_s"] for t in seq["cost_terms"].values()),
                                          abs=1e-5)
    assert out["precedence"], "expected precedence edges"
    for edge in out["precedence"]:
        assert edge["origins"] and all(o["kind"] and o["reason"] for o in edge["origins"])


def test_cli_contradictory_rules_exit_2_with_the_rule_location(capsys) -> None:
    from asmplan.cli import main

    path = FIXTURES / "contradictory_rules.yaml"
    line = 1 + next(i for i, ln in enumerate(path.read_text(encoding="utf-8").splitlines())
                    if "{before: cap, after: riser" in ln)
    assert main(["sequence", str(path)]) == 2
    err = capsys.readouterr().err
    assert f'contradictory_rules.yaml:{line}:7: precedence.rules[0]: rule "cap before riser"' in err
    assert "cap blocks its insertion along -z" in err


def test_cli_rejects_unknown_weight(capsys) -> None:
    from asmplan.cli import main

    assert main(["sequence", str(FIXTURES / "three_blocks.yaml"), "--weight", "speed=3"]) == 2
    assert "expected TERM=SECONDS with TERM one of reorientations" in capsys.readouterr().err


BOXED_IN = """\
asmplan: 1
product: boxed_in
units: {length: mm, mass: g}
parts:
  - {name: plate, material: steel, geometry: {type: box, size: [200, 200, 10]},
     pose: {xyz: [0, 0, 5]}, fixtured: true}
  - {name: x, material: steel, geometry: {type: box, size: [40, 40, 20]}, pose: {xyz: [0, 0, 20]},
     start: {xyz: [0, 300, 10]}}
  - {name: wall_px, material: steel, geometry: {type: box, size: [10, 60, 30]},
     pose: {xyz: [25, 0, 25]}, start: {xyz: [100, 300, 15]}}
  - {name: wall_nx, material: steel, geometry: {type: box, size: [10, 60, 30]},
     pose: {xyz: [-25, 0, 25]}, start: {xyz: [-100, 300, 15]}}
  - {name: wall_py, material: steel, geometry: {type: box, size: [40, 10, 30]},
     pose: {xyz: [0, 25, 25]}, start: {xyz: [200, 300, 15]}}
  - {name: wall_ny, material: steel, geometry: {type: box, size: [40, 10, 30]},
     pose: {xyz: [0, -25, 25]}, start: {xyz: [-200, 300, 15]}}
  - {name: lid, material: steel, geometry: {type: box, size: [60, 60, 5]},
     pose: {xyz: [0, 0, 42.5]}, start: {xyz: [0, 400, 2.5]}}
precedence:
  base: plate
  rules:
    - {before: wall_px, after: x, reason: walls first}
    - {before: wall_nx, after: x, reason: walls first}
    - {before: wall_py, after: x, reason: walls first}
    - {before: wall_ny, after: x, reason: walls first}
    - {before: lid, after: x, reason: the lid comes pre-mounted}
resources:
  gripper: {stroke: 85, finger: {size: [20, 8, 30], friction: 1.0}, max_force: 40}
  table: {size: [800, 800, 40]}
"""


def test_rules_that_together_box_a_part_in_are_all_named(tmp_path: Path) -> None:
    """No rule alone contradicts the geometry; together they leave x no way in."""
    product = _load_text(tmp_path, BOXED_IN)
    with pytest.raises(PrecedenceConflictError,
                       match=r"x cannot be placed: no insertion direction is free") as info:
        _with_double(product)
    assert {(r.before, r.after) for r in info.value.rules} == {
        ("wall_px", "x"), ("wall_nx", "x"), ("wall_py", "x"), ("wall_ny", "x"), ("lid", "x")}
    assert "along -z blocked by lid" in str(info.value)
    # without the lid rule the box is open from above: x goes in before the lid
    plan = _with_double(_load_text(tmp_path, BOXED_IN.replace(
        "    - {before: lid, after: x, reason: the lid comes pre-mounted}\n", ""), "open.yaml"))
    assert plan.best.order.index("x") < plan.best.order.index("lid")
    assert all(s.order.index("x") < s.order.index("lid") for s in plan.sequences)
