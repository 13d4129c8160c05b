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

import numpy as np
import pytest

from asmplan.knowledge.generator import generate_product, generated_product
from asmplan.knowledge.loader import load_product
from asmplan.knowledge.model import Product
from asmplan.planner.blocking import blocking_table, mate_insertion_direction
from asmplan.planner.sequence import (
    COST_TERMS,
    NoFeasibleSequenceError,
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
    wide = plan_sequence(product, settings=SequenceSettings(max_states=1, beam_width=exact.states),
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
