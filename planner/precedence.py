"""Derived precedence: the knowledge graph completed with geometry and stability edges, with evidence.

Step 2 of the method in :mod:`asmplan.planner.sequence`: :func:`derive_precedence` adds, to a
fixpoint, every order the geometry (a part blocked in every direction its predecessors leave
open) or stability (the only part that can hold another) imposes, and reports a knowledge
rule that contradicts them as a :class:`PrecedenceConflictError` naming the rule's line.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from typing import Any

import networkx as nx

from ..knowledge.errors import InputIssue, ProductError
from ..knowledge.graphs import add_precedence, precedence_graph
from ..knowledge.model import PrecedenceRule, Product
from .blocking import BlockingTable
from .errors import PlanningError


# ---------------------------------------------------------------------------------------------
# Errors
# ---------------------------------------------------------------------------------------------
class PrecedenceConflictError(ProductError):
    """Knowledge rules contradict the geometry (an input error: exit code 2 in the CLI).

    Attributes
    ----------
    rules : tuple of PrecedenceRule
        The rule(s) in conflict, with their line in the product file.
    geometry : list of dict
        The geometric side: derived precedence origins (blocker, blocked insertion
        directions, ...) or, for a part that cannot be inserted at all, its blocked directions.
    """

    def __init__(self, product: Product, rules: Sequence[PrecedenceRule], explanation: str,
                 geometry: list[dict[str, Any]]):
        self.rules = tuple(rules)
        self.geometry = geometry
        self.explanation = explanation
        index = {id(r): i for i, r in enumerate(product.precedence.rules)}
        issues = [InputIssue(str(product.source), r.source_line, _rule_column(product, r),
                             f"precedence.rules[{index[id(r)]}]" if id(r) in index
                             else "precedence.rules",
                             f'rule "{r.before} before {r.after}" ({r.reason}) contradicts the '
                             f"geometry: {explanation}") for r in self.rules]
        super().__init__(issues)

    def evidence(self) -> dict[str, Any]:
        """JSON-safe evidence: the rules (with lines) and the geometric side."""
        return {"kind": "precedence_conflict", "message": str(self),
                "rules": [{"before": r.before, "after": r.after, "reason": r.reason,
                           "line": r.source_line} for r in self.rules],
                "geometry": self.geometry}


def _rule_column(product: Product, rule: PrecedenceRule) -> int:
    """1-based column of the rule's item on its line (0 when the file cannot be read)."""
    try:
        line = product.source.read_text(encoding="utf-8").splitlines()[rule.source_line - 1]
    except (OSError, IndexError, UnicodeDecodeError):
        return 0
    stripped = line.lstrip(" -")
    return len(line) - len(stripped) + 1 if stripped else 0


class NoFeasibleSequenceError(PlanningError):
    """No order assembles the product.

    Attributes
    ----------
    dead_end : tuple of str
        The smallest partial assembly found after which no part can be added.
    reasons : dict part -> str
        Why each remaining part cannot be added to it.
    """

    kind = "no_feasible_sequence"

    def __init__(self, product: str, dead_end: Sequence[str], reasons: dict[str, str]):
        self.product = product
        self.dead_end = tuple(dead_end)
        self.reasons = dict(reasons)
        placed = ", ".join(self.dead_end) if self.dead_end else "nothing"
        lines = "; ".join(f"{p}: {r}" for p, r in sorted(self.reasons.items()))
        super().__init__(f'no feasible assembly sequence for "{product}": with {placed} placed '
                         f"({len(self.dead_end)} parts), no further part can be added -- {lines}",
                         step=len(self.dead_end))

    def evidence(self) -> dict[str, Any]:
        return {**super().evidence(), "dead_end": list(self.dead_end), "reasons": self.reasons}


# ---------------------------------------------------------------------------------------------
# Precedence: knowledge + geometry + stability
# ---------------------------------------------------------------------------------------------
class _Dead(Exception):
    """A part can never be inserted (or never held) given the edges so far."""

    def __init__(self, part: str, why: str, evidence: list[dict[str, Any]], given: frozenset[str]):
        super().__init__(why)
        self.part, self.why, self.evidence, self.given = part, why, evidence, given


def _mate_partners(product: Product) -> dict[str, dict[str, str]]:
    """part -> {partner: mate name (first by name)}."""
    out: dict[str, dict[str, str]] = {p: {} for p in product.part_names}
    for m in sorted(product.mates, key=lambda m: m.name):
        out[m.pin_part].setdefault(m.hole_part, m.name)
        out[m.hole_part].setdefault(m.pin_part, m.name)
    return out


def _rule_holders(product: Product) -> dict[str, dict[str, PrecedenceRule]]:
    """part -> {q: rule} for every knowledge rule "q before part": the rule asserts that the
    part goes onto q, so q holds it even where the geometric probe finds no contact (ribs a
    millimetre below, a support the model leaves out)."""
    out: dict[str, dict[str, PrecedenceRule]] = {p: {} for p in product.part_names}
    for r in sorted(product.precedence.rules, key=lambda r: r.source_line):
        out[r.after].setdefault(r.before, r)
    return out


def _stable_alone(product: Product, table: BlockingTable, part: str) -> bool:
    """Fixtured, on the table, or placed by another operation (``handling.operation``: the
    press tool, joint or fastening that places it holds it there)."""
    return (product.is_fixtured(part) or table.on_table[part]
            or product.placed_by(part) is not None)


def _fixture_names(product: Product, part: str) -> list[str]:
    names = [f.name for f in product.resources.fixtures if f.holds == part]
    return names or (["fixture"] if product.part(part).fixtured else [])


def _blocked_text(table: BlockingTable, part: str, given: frozenset[str]) -> list[dict[str, Any]]:
    rows = []
    for d, b, t in zip(table.directions[part], table.blockers[part], table.table_blocked[part],
                       strict=True):
        who = sorted(b & given) + (["table"] if t else [])
        rows.append({"insertion": d.insertion_label, "blockers": who})
    return rows


# Complexity above C (radon): a fixpoint over parts and removal directions; each branch is one
# precedence reason (geometry, stability, fixture) with its evidence.
def _derive(product: Product, table: BlockingTable, graph: nx.DiGraph) -> int:
    """Add geometry and stability edges to ``graph`` up to a fixpoint; returns how many.

    Raises
    ------
    _Dead
        When a part has no direction left open by its required predecessors, or nothing can
        hold it.
    """
    partners = _mate_partners(product)
    ruled = _rule_holders(product)
    added = 0
    changed = True
    while changed:
        changed = False
        for p in product.part_names:
            anc = frozenset(nx.ancestors(graph, p))
            open_dirs = [i for i, (b, t) in enumerate(zip(table.blockers[p], table.table_blocked[p],
                                                          strict=True)) if not t and not (b & anc)]
            if not open_dirs:
                raise _Dead(p, "no insertion direction is free", _blocked_text(table, p, anc), anc)
            common = frozenset.intersection(*(table.blockers[p][i] for i in open_dirs)) - {p}
            for q in sorted(common):
                if graph.has_edge(p, q) and any(o["kind"] == "geometry"
                                                for o in graph.edges[p, q]["origins"]):
                    continue
                labels = [table.directions[p][i].insertion_label for i in open_dirs]
                closed = [i for i in range(len(table.directions[p])) if i not in open_dirs]
                given = sorted(set().union(*(table.blockers[p][i] & anc for i in closed))) \
                    if closed else []
                by_table = [table.directions[p][i].insertion_label for i in closed
                            if table.table_blocked[p][i]]
                rest = []
                if given:
                    rest.append(f"{', '.join(given)} (placed before {p}) block"
                                f"{'s' if len(given) == 1 else ''} the other directions")
                if by_table:
                    rest.append(f"the table blocks {', '.join(by_table)}")
                reason = (f"with {q} in place {p} cannot be inserted: {q} blocks its insertion "
                          f"along {', '.join(labels)}" + ("; " + "; ".join(rest) if rest else ""))
                add_precedence(graph, p, q, {"kind": "geometry", "reason": reason, "blocker": q,
                                             "blocked_directions": labels, "given": given})
                added += 1
                changed = True
            if _stable_alone(product, table, p):
                continue
            desc = frozenset(nx.descendants(graph, p))
            holders = (table.supporters[p] | frozenset(partners[p]) | frozenset(ruled[p])) \
                - desc - {p}
            if not holders:
                raise _Dead(p, "nothing can hold it (not fixtured, not on the table, and every "
                            "part under it or mated to it must come after it; a rule "
                            "\"<support> before " + p + "\" says what it rests on)",
                            [{"supporters": sorted(table.supporters[p]),
                              "mated_to": sorted(partners[p]), "after_it": sorted(desc)}], anc)
            if len(holders) == 1:
                (q,) = holders
                if graph.has_edge(q, p) and any(o["kind"] == "stability"
                                                for o in graph.edges[q, p]["origins"]):
                    continue
                how = []
                if q in table.supporters[p]:
                    how.append(f"it rests on {q}")
                if q in partners[p]:
                    how.append(f"mate {partners[p][q]}")
                if q in ruled[p]:
                    how.append(f"rule (line {ruled[p][q].source_line}): {ruled[p][q].reason}")
                add_precedence(graph, q, p, {
                    "kind": "stability", "holder": q,
                    "reason": f"{p} is not fixtured and not on the table; {q} is the only part "
                              f"that can hold it ({', '.join(how)})"})
                added += 1
                changed = True
    return added


def _rules_on_paths(graph: nx.DiGraph, sources: Iterable[str], target: str) -> list[PrecedenceRule]:
    """Rules on edges lying on some path from a source to ``target``."""
    anc_t = nx.ancestors(graph, target) | {target}
    found: dict[tuple[str, str], PrecedenceRule] = {}
    for s in sources:
        if s not in anc_t:
            continue
        reach = (nx.descendants(graph, s) | {s}) & anc_t
        for u, v, d in graph.edges(data=True):
            if u in reach and v in reach:
                for o in d["origins"]:
                    if o["kind"] == "rule":
                        found[(u, v)] = o["_rule"]
    return [found[k] for k in sorted(found, key=lambda k: found[k].source_line)]


# Complexity above C (radon): two phases (the physical graph, then the knowledge rules), each with its
# own conflict report.
def derive_precedence(product: Product, table: BlockingTable) -> nx.DiGraph:
    """Knowledge precedence completed with geometry and stability edges (module docs here and
    in :mod:`asmplan.planner.sequence`).

    Raises
    ------
    PrecedenceConflictError
        When a rule contradicts the geometry (or the stability of the parts).
    NoFeasibleSequenceError
        When geometry and the declared base alone leave a part impossible to insert or hold.
    """
    knowledge = precedence_graph(product)
    rules = {(r.before, r.after): r for r in product.precedence.rules}
    # phase 1: the physical graph: base + geometry + stability
    physical: nx.DiGraph[str] = nx.DiGraph()
    physical.graph.update(knowledge.graph)
    physical.add_nodes_from(knowledge.nodes)
    for u, v, d in knowledge.edges(data=True):
        base = [o for o in d["origins"] if o["kind"] == "base"]
        if base:
            physical.add_edge(u, v, origins=[dict(o) for o in base])
    try:
        _derive(product, table, physical)
    except _Dead as dead:
        raise NoFeasibleSequenceError(
            product.name, sorted(dead.given),
            {dead.part: f"{dead.why}: " + _evidence_text(dead.evidence)}) from None
    # a rule against a physical order
    for (a, b), rule in sorted(rules.items(), key=lambda kv: kv[1].source_line):
        if nx.has_path(physical, b, a):
            path = nx.shortest_path(physical, b, a)
            geometry = [{"before": u, "after": v, "origins": physical.edges[u, v]["origins"]}
                        for u, v in itertools.pairwise(path)]
            text = "; ".join(f"{g['before']} must come before {g['after']} "
                             f"({'; '.join(o['kind'] + ': ' + o['reason'] for o in g['origins'])})"
                             for g in geometry)
            raise PrecedenceConflictError(product, [rule], text, geometry)
    # phase 2: rules on top, derived again
    graph = physical.copy()
    for (a, b), rule in rules.items():
        add_precedence(graph, a, b, {"kind": "rule", "reason": rule.reason,
                                     "line": rule.source_line, "_rule": rule})
    try:
        cycle = nx.find_cycle(graph)
    except nx.NetworkXNoCycle:
        cycle = []
    if cycle:
        involved = [graph.edges[u, v] for u, v in cycle]
        bad = [o["_rule"] for d in involved for o in d["origins"] if o["kind"] == "rule"]
        geometry = [{"before": u, "after": v, "origins": _public(graph.edges[u, v]["origins"])}
                    for u, v in cycle if not any(o["kind"] == "rule" for o in graph.edges[u, v]["origins"])]
        text = "the rules and the derived order form a cycle " + " -> ".join(
            [cycle[0][0], *(v for _u, v in cycle)]) + ": " + "; ".join(
            f"{g['before']} must come before {g['after']} "
            f"({'; '.join(o['kind'] + ': ' + o['reason'] for o in g['origins'])})" for g in geometry)
        raise PrecedenceConflictError(product, sorted(set(bad), key=lambda r: r.source_line), text,
                                      geometry)
    try:
        _derive(product, table, graph)
    except _Dead as dead:
        bad = _rules_on_paths(graph, dead.given, dead.part) or list(product.precedence.rules)
        text = (f"with the parts these rules place before {dead.part} "
                f"({', '.join(sorted(dead.given))}), {dead.part} cannot be placed: {dead.why}: "
                + _evidence_text(dead.evidence))
        raise PrecedenceConflictError(product, bad, text,
                                      [{"part": dead.part, "why": dead.why,
                                        "directions": dead.evidence}]) from None
    for _u, _v, d in graph.edges(data=True):
        for o in d["origins"]:
            o.pop("_rule", None)
    return graph


def _public(origins: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in o.items() if not k.startswith("_")} for o in origins]


def _evidence_text(evidence: list[dict[str, Any]]) -> str:
    out = []
    for e in evidence:
        if "insertion" in e:
            who = ", ".join(e["blockers"]) or "nothing"
            out.append(f"along {e['insertion']} blocked by {who}")
        else:
            out.append(", ".join(f"{k.replace('_', ' ')}: {', '.join(v) or 'none'}"
                                 for k, v in e.items()))
    return "; ".join(out)


__all__ = ["NoFeasibleSequenceError", "PrecedenceConflictError", "derive_precedence"]
