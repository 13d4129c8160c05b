"""The liaison graph (who touches whom, through which mates) and the knowledge precedence graph.

Both are plain networkx graphs with dict attributes, so they can be inspected, drawn and
exported (``nx.node_link_data``). Geometry-derived precedence edges are added by the planner
(:mod:`asmplan.planner.sequence`) on top of :func:`precedence_graph`.
"""

from __future__ import annotations

from typing import Any, cast

import networkx as nx

from .model import Product


def liaison_graph(product: Product) -> nx.MultiGraph:
    """Parts as nodes, one edge per mate (keyed by the mate's name).

    Node attributes: ``mass_kg`` (None when derived from geometry later), ``material``,
    ``fixtured``, ``geometry`` (the YAML type). Edge attributes: ``mate``, ``pin``, ``hole``
    (``part.feature``), ``fit``, ``clearance_min_m``, ``clearance_max_m``, ``kind``,
    ``pin_diameter_m``.
    """
    g: nx.MultiGraph[str] = nx.MultiGraph(product=product.name)
    for part in product.parts:
        g.add_node(part.name, mass_kg=part.mass_kg,
                   material=part.material.name if part.material else None,
                   fixtured=product.is_fixtured(part.name), geometry=part.geometry.kind)
    for mate in product.mates:
        pin = product.feature(mate.pin_part, mate.pin_feature)
        g.add_edge(mate.pin_part, mate.hole_part, key=mate.name, mate=mate.name,
                   pin=f"{mate.pin_part}.{mate.pin_feature}",
                   hole=f"{mate.hole_part}.{mate.hole_feature}", fit=mate.fit,
                   clearance_min_m=mate.clearance_min_m, clearance_max_m=mate.clearance_max_m,
                   kind=mate.kind, pin_diameter_m=pin.diameter_m)
    return g


def add_precedence(graph: nx.DiGraph, before: str, after: str, origin: dict[str, Any]) -> None:
    """Add ``before -> after`` with one more ``origin`` record (kind, reason, ...)."""
    if graph.has_edge(before, after):
        graph.edges[before, after]["origins"].append(origin)
    else:
        graph.add_edge(before, after, origins=[origin])


def precedence_graph(product: Product) -> nx.DiGraph:
    """Precedence from knowledge: the base first, then every rule; each edge lists its origins.

    Every edge carries ``origins``: a list of dicts with ``kind`` ("base" or "rule"),
    ``reason`` and, for rules, ``line`` in the product file.
    """
    g: nx.DiGraph[str] = nx.DiGraph(product=product.name)
    g.add_nodes_from(product.part_names)
    base = product.precedence.base
    if base is not None:
        for name in product.part_names:
            if name != base:
                add_precedence(g, base, name, {"kind": "base",
                                               "reason": f'"{base}" is the base part'})
    for rule in product.precedence.rules:
        add_precedence(g, rule.before, rule.after,
                       {"kind": "rule", "reason": rule.reason, "line": rule.source_line})
    return g


def graph_to_dot(graph: nx.Graph, name: str) -> str:
    """A Graphviz DOT text for a liaison (undirected) or precedence (directed) graph."""
    directed = graph.is_directed()
    lines = [f'{"digraph" if directed else "graph"} "{name}" {{', "  node [shape=box];"]
    for node in sorted(graph.nodes):
        lines.append(f'  "{node}";')
    arrow = "->" if directed else "--"
    edges = cast(nx.MultiGraph, graph).edges(keys=True, data=True) if graph.is_multigraph() else \
        ((u, v, None, d) for u, v, d in graph.edges(data=True))
    for u, v, _key, data in sorted(edges, key=lambda e: (e[0], e[1], str(e[2]))):
        if directed:
            label = "; ".join(f'{o["kind"]}: {o["reason"]}' for o in data.get("origins", []))
        else:
            label = f'{data["mate"]} {data["fit"] or ""}'.strip()
        label = label.replace('"', "'")
        lines.append(f'  "{u}" {arrow} "{v}" [label="{label}"];')
    lines.append("}")
    return "\n".join(lines) + "\n"
