"""``asmplan sequence PRODUCT``: feasible assembly orders, ranked by cell time and explained."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from typing import Any

from ..knowledge.loader import load_product
from ..planner.sequence import (
    COST_TERMS,
    NoFeasibleSequenceError,
    PrecedenceConflictError,
    SequencePlan,
    SequenceSettings,
    plan_sequence,
)
from .argtypes import positive_int

# cost term -> SequenceSettings field holding its weight
WEIGHT_FIELDS = {"reorientations": "reorientation_s", "direction_changes": "direction_change_s",
                 "tool_changes": "tool_change_s", "travel_m": "travel_s_per_m",
                 "stability_risk": "stability_risk_s", "unreachable": "unreachable_s"}


def _weight(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    if not sep or name not in WEIGHT_FIELDS:
        raise argparse.ArgumentTypeError(
            f'expected TERM=SECONDS with TERM one of {", ".join(COST_TERMS)}, found "{text}"')
    try:
        v = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected a number of seconds, found "{value}"') from None
    if not v >= 0:
        raise argparse.ArgumentTypeError(f"expected a weight >= 0, found {value}")
    return name, v


def register(sub: argparse._SubParsersAction) -> None:
    defaults = SequenceSettings()
    p = sub.add_parser(
        "sequence", help="plan, rank and explain assembly orders",
        description="Find the feasible assembly orders of a product (geometry by assembly-by-"
                    "disassembly with FCL, knowledge rules, stability), rank them by estimated "
                    "cell time and explain every precedence. Exit code 2 when a rule contradicts "
                    "the geometry, 1 when no order exists.")
    p.add_argument("product", help="product YAML file")
    p.add_argument("--top", type=positive_int, default=defaults.top_k, metavar="K",
                   help=f"number of ranked sequences (default {defaults.top_k})")
    p.add_argument("--json", action="store_true",
                   help="print every sequence with its cost breakdown and the reason for every "
                        "precedence edge as JSON")
    p.add_argument("--beam-width", type=positive_int, default=defaults.beam_width, metavar="W",
                   help=f"beam width for products too large to enumerate (default "
                        f"{defaults.beam_width})")
    p.add_argument("--max-states", type=positive_int, default=defaults.max_states, metavar="N",
                   help=f"enumerate every assembly state up to this many (default "
                        f"{defaults.max_states})")
    p.add_argument("--weight", type=_weight, action="append", default=[], metavar="TERM=SECONDS",
                   help="weight of a cost term in seconds per unit; terms: "
                        + ", ".join(f"{t} (default {getattr(defaults, WEIGHT_FIELDS[t]):g})"
                                    for t in COST_TERMS))
    p.set_defaults(func=run)


def settings_from_args(args: argparse.Namespace) -> SequenceSettings:
    """The :class:`SequenceSettings` the options ask for."""
    changes: dict[str, Any] = {"top_k": args.top, "beam_width": args.beam_width,
                                  "max_states": args.max_states}
    changes["max_beam_width"] = max(SequenceSettings().max_beam_width, args.beam_width)
    for name, value in args.weight:
        changes[WEIGHT_FIELDS[name]] = value
    return dataclasses.replace(SequenceSettings(), **changes)


def print_table(plan: SequencePlan, n_parts: int) -> None:
    if plan.feasible_count is not None:
        how = (f"{plan.feasible_count} feasible sequence{'s' if plan.feasible_count != 1 else ''} "
               f"(all {plan.states} assembly states enumerated)")
    else:
        how = f"best found by {plan.method} search ({plan.states} states expanded; not counted)"
    total = sum(plan.timings_s.values())
    print(f"{plan.product}: {n_parts} parts; {how}; {total:.2f} s")
    short = {"reorientations": "reorient", "direction_changes": "dir_chg",
             "tool_changes": "tool_chg", "travel_m": "travel_m", "stability_risk": "risk",
             "unreachable": "unreach"}
    print(f"{'rank':>4} {'cost_s':>8} " + " ".join(f"{short[t]:>9}" for t in COST_TERMS)
          + "  sequence (insertion direction)")
    for s in plan.sequences:
        values = " ".join(f"{s.terms[t]:>9.3f}" if t == "travel_m" else f"{s.terms[t]:>9.0f}"
                          for t in COST_TERMS)
        order = " > ".join(f"{st.part}({st.insertion_label})" for st in s.steps)
        print(f"{s.rank:>4} {s.cost_s:>8.2f} {values}  {order}")
        for k, st in enumerate(s.steps, start=1):
            if st.unreachable:
                print(f"{'':>14}step {k} ({st.part}): {st.unreachable}")
    print("precedence (before -> after: why):")
    base_after: dict[str, list[str]] = {}
    for e in plan.edges():
        kinds = [o["kind"] for o in e["origins"]]
        if kinds == ["base"]:
            base_after.setdefault(e["before"], []).append(e["after"])
            continue
        for o in e["origins"]:
            if o["kind"] == "base":
                continue
            where = f" (line {o['line']})" if o.get("line") else ""
            print(f"  {e['before']} -> {e['after']}: {o['kind']}{where}: {o['reason']}")
    for base, after in base_after.items():
        print(f"  {base} -> {', '.join(sorted(after))}: base: {base} is the declared base part")


def run(args: argparse.Namespace) -> int:
    from ..parts.input_warnings import geometry_warnings
    from ..parts.models import ProductGeometry

    product = load_product(args.product)
    geometry = ProductGeometry(product)
    for w in geometry_warnings(product, geometry):
        print(f"{args.product}: warning: {w}", file=sys.stderr)
    settings = settings_from_args(args)
    try:
        from ..planner.fcl_oracle import FclOracle

        plan = plan_sequence(product, FclOracle(product, geometry), settings)
    except PrecedenceConflictError as exc:
        if args.json:
            print(json.dumps({"feasible": False, "error": exc.evidence()}, indent=2, default=str))
            for issue in exc.issues:
                print(issue, file=sys.stderr)
            return 2
        raise  # the CLI prints every issue (file:line: rule and geometry) and exits with 2
    except NoFeasibleSequenceError as exc:
        if args.json:
            print(json.dumps({"feasible": False, "error": exc.evidence()}, indent=2))
        print(f"asmplan: {exc}", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps({"feasible": True, **plan.as_dict()}, indent=2, default=str))
    else:
        print_table(plan, len(product.parts))
    return 0
