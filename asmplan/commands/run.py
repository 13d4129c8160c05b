"""``asmplan run [PRODUCT] -o OUTDIR``: the main job, from product YAML to results.

Stages so far: validate, liaison and precedence graphs. Later stages (sequence, motion,
simulation, report) are added as they land.
"""

from __future__ import annotations

import argparse
import sys
from importlib import resources
from pathlib import Path

import networkx as nx

from ..fileio import atomic_write_json, staged_directory
from ..knowledge.graphs import liaison_graph, precedence_graph
from ..knowledge.loader import load_product
from .validate import summary


def bundled_example(name: str = "pinhole_station") -> Path:
    """Path of a bundled example product (``pinhole_station`` is the seed workstation)."""
    return Path(str(resources.files("asmplan.examples").joinpath(f"{name}.yaml")))


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="the main job: product YAML in, results and report out",
                       description="Validate, plan and simulate a product and write the results "
                                   "to OUTDIR. Without PRODUCT, runs the bundled seed workstation.")
    p.add_argument("product", nargs="?", help="product YAML file (default: the bundled seed "
                                               "pin-hole workstation)")
    p.add_argument("-o", "--out", default="out", help="output folder (replaced atomically)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    path = Path(args.product) if args.product else bundled_example()
    product = load_product(path, display_name=args.product or "pinhole_station.yaml (bundled)")
    with staged_directory(args.out) as stage:
        atomic_write_json(stage / "product.json", summary(product))
        atomic_write_json(stage / "graphs.json", {
            "liaison": nx.node_link_data(liaison_graph(product), edges="edges"),
            "precedence": nx.node_link_data(precedence_graph(product), edges="edges")})
    print(f'{product.name}: {len(product.parts)} parts, {len(product.mates)} mates validated; '
          f"results in {args.out}/", file=sys.stdout)
    return 0
