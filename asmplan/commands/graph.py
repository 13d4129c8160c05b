"""``asmplan graph PRODUCT``: the liaison and precedence graphs as JSON or DOT."""

from __future__ import annotations

import argparse
import json

import networkx as nx

from ..knowledge.graphs import graph_to_dot, liaison_graph, precedence_graph
from ..knowledge.loader import load_product


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("graph", help="print the liaison and precedence graphs",
                       description="Print the liaison graph (parts, mates with fits) and the "
                                   "knowledge precedence graph (every edge with its origin).")
    p.add_argument("product", help="product YAML file")
    p.add_argument("--format", choices=("json", "dot"), default="json")
    p.add_argument("--kind", choices=("both", "liaison", "precedence"), default="both")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    product = load_product(args.product)
    graphs: dict[str, nx.Graph[str]] = {}
    if args.kind in ("both", "liaison"):
        graphs["liaison"] = liaison_graph(product)
    if args.kind in ("both", "precedence"):
        graphs["precedence"] = precedence_graph(product)
    if args.format == "dot":
        print("".join(graph_to_dot(g, f"{product.name} {k}") for k, g in graphs.items()), end="")
    else:
        out = {k: nx.node_link_data(g, edges="edges") for k, g in graphs.items()}
        print(json.dumps(out, indent=2, sort_keys=True))
    return 0
