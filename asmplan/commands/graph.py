"""``asmplan graph PRODUCT``: the liaison and precedence graphs as JSON or DOT.

The precedence graph is the one ``asmplan sequence`` plans with: the declared rules and the
base part, plus the precedences found from the geometry (a part that blocks another's
insertion) and from stability (a part that needs another to rest on), each edge with its
origins and reasons. ``--knowledge-only`` leaves out the derived ones (no geometry is built).
DOT output is one graph per call (Graphviz tools read only the first graph of a file), so
``--format dot`` draws ``--kind precedence`` (the default) or ``--kind liaison``; JSON holds
both by default.
"""

from __future__ import annotations

import argparse
import json
import sys

import networkx as nx

from ..knowledge.graphs import graph_to_dot, liaison_graph, precedence_graph
from ..knowledge.loader import load_product


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("graph", help="print the liaison and precedence graphs",
                       description="Print the liaison graph (parts, mates with fits) and the "
                                   "precedence graph (every edge with its origin: declared, "
                                   "base, geometry, stability). DOT output is one graph per "
                                   "call: --kind precedence (default) or liaison.")
    p.add_argument("product", help="product YAML file")
    p.add_argument("--format", choices=("json", "dot"), default="json")
    p.add_argument("--kind", choices=("both", "liaison", "precedence"), default=None,
                   help="which graph (default: both for json, precedence for dot)")
    p.add_argument("--knowledge-only", action="store_true",
                   help="only the declared precedences (skip the geometry and stability ones "
                        "that `asmplan sequence` derives)")
    p.set_defaults(func=run)


def full_precedence_graph(product) -> nx.DiGraph:
    """Knowledge, geometry and stability precedences, as the sequence planner finds them."""
    from ..parts.models import ProductGeometry
    from ..planner.errors import PlanningError
    from ..planner.fcl_oracle import FclOracle
    from ..planner.sequence import plan_sequence

    geometry = ProductGeometry(product)
    try:
        return plan_sequence(product, FclOracle(product, geometry)).precedence
    except PlanningError as exc:  # no feasible order: the knowledge graph with the reason
        print(f"asmplan graph: no feasible sequence ({exc}); showing the declared "
              "precedences only", file=sys.stderr)
        return precedence_graph(product)


def run(args: argparse.Namespace) -> int:
    product = load_product(args.product)
    kind = args.kind or ("precedence" if args.format == "dot" else "both")
    if args.format == "dot" and kind == "both":
        print("asmplan graph: --format dot writes one graph per call: expected --kind "
              "precedence or --kind liaison, found --kind both", file=sys.stderr)
        return 2
    graphs: dict[str, nx.Graph[str]] = {}
    if kind in ("both", "liaison"):
        graphs["liaison"] = liaison_graph(product)
    if kind in ("both", "precedence"):
        graphs["precedence"] = (precedence_graph(product) if args.knowledge_only
                                else full_precedence_graph(product))
    if args.format == "dot":
        (name, graph), = graphs.items()
        print(graph_to_dot(graph, f"{product.name} {name}"), end="")
    else:
        out = {k: nx.node_link_data(g, edges="edges") for k, g in graphs.items()}
        print(json.dumps(out, indent=2, sort_keys=True, default=str))
    return 0
