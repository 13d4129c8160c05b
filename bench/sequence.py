"""Sequence-planning benchmark on generated products (:mod:`asmplan.knowledge.generator`).

For each size the product is generated with the same seed, then planned ``repeats`` times
from scratch (collision models, blocking sweeps, precedence, search); the table reports the
median of each phase and the growth exponent between consecutive sizes,
``k = log(t2 / t1) / log(n2 / n1)`` (time ~ n^k). Run it with
``python -m bench.sequence [--sizes 5 10 20 50] [--repeats 3] [--seed 0]``;
the ``asmplan bench`` command can call :func:`bench` and :func:`format_table`.
"""

from __future__ import annotations

import argparse
import itertools
import math
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from asmplan.knowledge.generator import generated_product
from asmplan.knowledge.model import Product
from asmplan.planner.blocking import GeometryOracle
from asmplan.planner.sequence import SequenceSettings, plan_sequence

DEFAULT_SIZES: tuple[int, ...] = (5, 10, 20, 50)


@dataclass(frozen=True)
class BenchRow:
    """Median timings (s) of one product size.

    ``geometry_s`` builds the collision models, ``blocking_s`` sweeps every part along every
    candidate direction, ``precedence_s`` derives the precedence graph, ``search_s`` searches;
    ``total_s`` is their sum. ``sweeps`` counts part-direction sweeps (+ one support probe
    per part); ``feasible_count`` is None when the product was too large to enumerate.
    """

    n_parts: int
    seed: int
    method: str
    states: int
    feasible_count: int | None
    sweeps: int
    best_cost_s: float
    geometry_s: float
    blocking_s: float
    precedence_s: float
    search_s: float
    total_s: float


def _default_oracle(product: Product) -> GeometryOracle:
    from asmplan.parts.models import ProductGeometry
    from asmplan.planner.fcl_oracle import FclOracle

    return FclOracle(product, ProductGeometry(product))


def bench(sizes: Sequence[int] = DEFAULT_SIZES, *, seed: int = 0, repeats: int = 3,
          settings: SequenceSettings | None = None,
          oracle_factory: Callable[[Product], GeometryOracle] | None = None) -> list[BenchRow]:
    """Time sequence planning on generated products of the given sizes.

    Parameters
    ----------
    sizes : part counts.
    seed : generator seed (the same for every size).
    repeats : runs per size; medians are reported.
    settings : planner settings (default :class:`SequenceSettings`).
    oracle_factory : builds the geometry for a product (default: FCL on exact models).
    """
    if repeats < 1:
        raise ValueError(f"repeats: expected >= 1, found {repeats}")
    settings = settings or SequenceSettings()
    factory = oracle_factory or _default_oracle
    rows = []
    for n in sizes:
        product = generated_product(n, seed)
        runs: list[tuple[float, float, float, float]] = []
        plan = None
        for _ in range(repeats):
            t0 = time.perf_counter()
            oracle = factory(product)
            t_geom = time.perf_counter() - t0
            plan = plan_sequence(product, oracle, settings)
            runs.append((t_geom, plan.timings_s["blocking"], plan.timings_s["precedence"],
                         plan.timings_s["search"]))
        assert plan is not None
        med = [statistics.median(r[i] for r in runs) for i in range(4)]
        sweeps = sum(len(plan.blocking.directions[p]) + 1 for p in plan.blocking.parts)
        geometry_s, blocking_s, precedence_s, search_s = med
        rows.append(BenchRow(n, seed, plan.method, plan.states, plan.feasible_count, sweeps,
                             plan.best.cost_s, geometry_s, blocking_s, precedence_s, search_s,
                             total_s=statistics.median(sum(r) for r in runs)))
    return rows


def growth(rows: Sequence[BenchRow]) -> list[tuple[int, int, float]]:
    """Growth exponents ``(n1, n2, k)`` of the total time between consecutive sizes."""
    out = []
    for a, b in itertools.pairwise(rows):
        if a.total_s > 0 and b.total_s > 0 and b.n_parts != a.n_parts:
            out.append((a.n_parts, b.n_parts,
                        math.log(b.total_s / a.total_s) / math.log(b.n_parts / a.n_parts)))
    return out


def format_table(rows: Sequence[BenchRow], repeats: int | None = None) -> str:
    """A plain-text table of the rows and the growth exponents."""
    head = (f"{'parts':>5} {'method':>10} {'states':>7} {'sweeps':>6} {'geometry_s':>10} "
            f"{'blocking_s':>10} {'precedence_s':>12} {'search_s':>9} {'total_s':>8}  feasible")
    lines = [f"sequence planning, generated products (seed {rows[0].seed if rows else 0}"
             + (f", median of {repeats} runs" if repeats else "") + ")", head]
    for r in rows:
        count = "not counted" if r.feasible_count is None else f"{r.feasible_count:.6g}"
        lines.append(f"{r.n_parts:>5} {r.method:>10} {r.states:>7} {r.sweeps:>6} "
                     f"{r.geometry_s:>10.3f} {r.blocking_s:>10.3f} {r.precedence_s:>12.3f} "
                     f"{r.search_s:>9.3f} {r.total_s:>8.3f}  {count}")
    for n1, n2, k in growth(rows):
        lines.append(f"growth {n1:>3} -> {n2:>3} parts: time ~ n^{k:.2f}")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m bench.sequence``: print the benchmark table."""
    parser = argparse.ArgumentParser(prog="python -m bench.sequence",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=list(DEFAULT_SIZES))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    rows = bench(args.sizes, seed=args.seed, repeats=args.repeats)
    sys.stdout.write(format_table(rows, args.repeats))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
