"""Assembly sequence planning: "in which order?", explained and ranked by cell time.

Method
------
1. **Geometry** (:mod:`asmplan.planner.blocking`): every part is swept once, in the full
   assembly, along the six axis directions and its mate axes; the blockers of each sweep are
   stored. A part ``p`` can be the last one added to a partial assembly ``S`` iff one of its
   directions has no blocker in ``S`` (assembly by disassembly, as set operations).
2. **Precedence**: the knowledge graph (:func:`asmplan.knowledge.graphs.precedence_graph`:
   base and rules) is completed, to a fixpoint, with derived edges, each with its evidence:

   * ``geometry`` -- ``p`` before ``q`` when, with every part that must precede ``p`` in
     place, ``q`` blocks ``p`` in every direction those parts leave open (origin records the
     blocker, the blocked insertion directions and the parts that block the rest);
   * ``stability`` -- ``q`` before ``p`` when ``q`` is the only part that can hold ``p``
     (see *Stability* below).

   First without the rules (geometry, stability and the declared base only): a rule that
   goes against a derived order, or that makes a part impossible to insert or to hold, is a
   :class:`PrecedenceConflictError` naming the rule (file:line) and the geometry. Rules that
   the geometry also implies get the geometry origin on the same edge.
3. **Search** over assembly states (sets of placed parts). When at most
   ``SequenceSettings.max_states`` states are reachable, all of them are enumerated (the
   state graph is the sequential equivalent of the AND/OR graph): the number of feasible
   sequences is counted, the top-k sequences are exact (dynamic programming over
   (state, last part)), and the precedences that hold in EVERY feasible sequence are listed.
   Otherwise a beam search on cost (plus an admissible travel bound) is used; the beam widens
   when it dead-ends, and an exhaustive depth-first search with memoised dead states decides
   in the end.

Stability
---------
A part placed must be held: it is fixtured (the product declares a fixture for it, or
``fixtured: true``), or it rests on the table, or a part already placed supports it (the
part is among the blockers of a 0.1 mm probe of it straight down: something is under it, a
shaft through its bore included), or it is mated to a part already placed. Held by mates
only (nothing under it) counts one unit of *stability risk*.

Costs
-----
Named terms, weighted in seconds of cell time (defaults in :class:`SequenceSettings`):
``reorientations`` (the gripper's approach direction changes between consecutive steps; the
approach is the part's grasp hint when given, else its insertion direction),
``direction_changes`` (the insertion direction changes), ``tool_changes`` (a step uses
another tool than the one before: a fixture for fixtured parts, the gripper otherwise),
``travel_m`` (from the previous part's assembled position to this part's start pose and on to
its assembled position; the first trip starts at the product origin) and ``stability_risk``.
Ties are broken by the lexicographic order of the part names, so the output is deterministic
(nothing here is random).
"""

from __future__ import annotations

import heapq
import itertools
import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import networkx as nx
import numpy as np

from ..knowledge.errors import InputIssue, ProductError
from ..knowledge.graphs import add_precedence, precedence_graph
from ..knowledge.model import PrecedenceRule, Product
from .access import GripperAccess
from .blocking import (
    BlockingTable,
    GeometryOracle,
    blocking_table,
    direction_label,
    mate_insertion_direction,
)
from .errors import PlanningError

COST_TERMS: tuple[str, ...] = ("reorientations", "direction_changes", "tool_changes", "travel_m",
                               "stability_risk", "unreachable")
"""Names of the cost terms, in the order of :attr:`RankedSequence.terms`."""


# ---------------------------------------------------------------------------------------------
# Settings
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SequenceSettings:
    """Weights and search limits of the sequence planner.

    Weights are seconds of cell time per unit of each cost term (defaults are engineering
    estimates for a 6-axis arm with one parallel gripper, not measurements):

    Parameters
    ----------
    reorientation_s : float
        Per change of the gripper's approach direction (wrist re-orientation), default 2 s.
    direction_change_s : float
        Per change of the insertion direction (re-teaching the approach), default 1 s.
    tool_change_s : float
        Per change of tool or fixture between consecutive steps, default 8 s.
    travel_s_per_m : float
        Per metre of travel (about 1 / (0.25 m/s)), default 4 s/m.
    stability_risk_s : float
        Per part held by mates only (nothing under it), default 5 s.
    unreachable_s : float
        Per step the gripper cannot do in that order (no screened grasp is free of the parts
        already placed, :mod:`asmplan.planner.access`), default 600 s: such an order ranks
        below every order the gripper can do, its reason kept, and is still tried last.
    gripper_access : bool
        Screen every step for gripper access (default True; False: the order ignores the
        gripper and ``unreachable`` stays 0).
    top_k : int
        Number of ranked sequences to return.
    max_states : int
        Enumerate all assembly states (exact count and top-k) when at most this many are
        reachable; beam search otherwise.
    beam_width, max_beam_width : int
        Initial beam width (nodes kept per depth) and the widest the beam may grow to when it
        dead-ends (it doubles).
    collapse_identical : bool
        List orders that differ only in the order of identical parts once (default True).
    max_identical_pool : int
        The search keeps up to this many orders per state to find ``top_k`` distinct ones
        when identical parts are collapsed (default 240).
    angle_tolerance_rad : float
        Two directions closer than this are the same (no reorientation, no direction change).
    support_probe_m : float
        Length of the downward probe that finds what a part rests on, m.
    table_contact_m : float
        A part whose lowest point is at most this high rests on the table, m.
    """

    reorientation_s: float = 2.0
    direction_change_s: float = 1.0
    tool_change_s: float = 8.0
    travel_s_per_m: float = 4.0
    stability_risk_s: float = 5.0
    unreachable_s: float = 600.0
    gripper_access: bool = True
    top_k: int = 5
    max_states: int = 20_000
    beam_width: int = 64
    max_beam_width: int = 1024
    collapse_identical: bool = True
    max_identical_pool: int = 240
    angle_tolerance_rad: float = math.radians(1.0)
    support_probe_m: float = 1.0e-4
    table_contact_m: float = 1.0e-4

    def __post_init__(self) -> None:
        for name in ("reorientation_s", "direction_change_s", "tool_change_s", "travel_s_per_m",
                     "stability_risk_s", "unreachable_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"SequenceSettings.{name}: expected a finite weight >= 0, found {v!r}")
        for name in ("top_k", "max_states", "beam_width", "max_beam_width", "max_identical_pool"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v >= 1):
                raise ValueError(f"SequenceSettings.{name}: expected an integer >= 1, found {v!r}")
        if self.max_beam_width < self.beam_width:
            raise ValueError(f"SequenceSettings.max_beam_width: expected >= beam_width "
                             f"({self.beam_width}), found {self.max_beam_width}")
        for name in ("angle_tolerance_rad", "support_probe_m", "table_contact_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"SequenceSettings.{name}: expected > 0, found {v!r}")

    @property
    def weights(self) -> dict[str, float]:
        """Weight of each cost term (:data:`COST_TERMS`), seconds per unit."""
        return {"reorientations": self.reorientation_s, "direction_changes": self.direction_change_s,
                "tool_changes": self.tool_change_s, "travel_m": self.travel_s_per_m,
                "stability_risk": self.stability_risk_s, "unreachable": self.unreachable_s}


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
# Results
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class SequenceStep:
    """One placement.

    Parameters
    ----------
    part : str
    insertion : (3,) float array
        Chosen insertion direction (unit, world).
    insertion_label : str
        ``"-z"`` or components.
    free_insertions : tuple of str
        Every insertion direction that was free at this step.
    held_by : tuple of str
        What holds the part once placed: ``"fixture:<name>"``, ``"table"``, or part names
        (supporting or mated parts already placed).
    stability : str
        ``"fixtured"``, ``"table"``, ``"resting"`` (something under it), ``"rule"`` (a
        knowledge rule "q before part" says it goes onto q, placed) or ``"mated"`` (held by
        mates only: one unit of stability risk).
    tool : str
        ``"gripper"`` or ``"fixture:<name>"``.
    unreachable : str
        Why the gripper cannot do this step in this order ("" when it can).
    """

    part: str
    insertion: np.ndarray
    insertion_label: str
    free_insertions: tuple[str, ...]
    held_by: tuple[str, ...]
    stability: str
    tool: str
    unreachable: str = ""

    def as_dict(self) -> dict[str, Any]:
        return {"part": self.part, "insertion": self.insertion_label,
                "insertion_vector": [round(float(c), 6) for c in self.insertion],
                "free_insertions": list(self.free_insertions), "held_by": list(self.held_by),
                "stability": self.stability, "tool": self.tool,
                "unreachable": self.unreachable}


@dataclass(frozen=True, eq=False)
class RankedSequence:
    """A feasible sequence with its cost.

    ``terms`` holds the raw value of every cost term (counts, metres), ``breakdown`` the
    weighted seconds; ``cost_s`` is their sum.
    """

    rank: int
    order: tuple[str, ...]
    steps: tuple[SequenceStep, ...]
    cost_s: float
    terms: dict[str, float]
    breakdown: dict[str, float]

    def as_dict(self) -> dict[str, Any]:
        return {"rank": self.rank, "order": list(self.order), "cost_s": round(self.cost_s, 6),
                "cost_terms": {k: {"value": round(self.terms[k], 6),
                                   "cost_s": round(self.breakdown[k], 6)} for k in COST_TERMS},
                "steps": [s.as_dict() for s in self.steps]}


@dataclass(frozen=True, eq=False)
class SequencePlan:
    """The planner's answer.

    Parameters
    ----------
    product : str
    sequences : tuple of RankedSequence
        Best first.
    precedence : nx.DiGraph
        Knowledge and derived precedence; every edge has ``origins`` (list of dicts with
        ``kind`` in base, rule, geometry, stability and a ``reason``).
    blocking : BlockingTable
    method : str
        ``"exhaustive"``, ``"beam"`` or ``"dfs"``.
    feasible_count : int or None
        Number of feasible sequences (exhaustive only).
    states : int
        Assembly states visited.
    necessary : tuple of (str, str)
        Pairs (a, b) with a before b in every feasible sequence (exhaustive only).
    timings_s : dict
        ``blocking``, ``precedence``, ``search`` wall times, s.
    """

    product: str
    sequences: tuple[RankedSequence, ...]
    precedence: nx.DiGraph
    blocking: BlockingTable
    method: str
    feasible_count: int | None
    states: int
    necessary: tuple[tuple[str, str], ...] = ()
    settings: SequenceSettings = field(default_factory=SequenceSettings)
    timings_s: dict[str, float] = field(default_factory=dict)
    links: dict[tuple[str, str], str] = field(default_factory=dict)

    @property
    def best(self) -> RankedSequence:
        return self.sequences[0]

    def origins(self, before: str, after: str) -> list[dict[str, Any]]:
        """Origins of the direct edge ``before -> after`` ([] when there is none)."""
        if not self.precedence.has_edge(before, after):
            return []
        return list(self.precedence.edges[before, after]["origins"])

    def explain(self, before: str, after: str) -> str:
        """Why ``before`` comes before ``after``: the direct edge's reasons, else the chain of
        edges (shortest path) with each edge's reasons. When ``after`` blocks some but not all
        of ``before``'s insertion directions, that is said too."""
        try:
            path = nx.shortest_path(self.precedence, before, after)
        except (nx.NetworkXNoPath, nx.NodeNotFound):
            if (before, after) in self.necessary:
                link = self.links.get((before, after), "")
                if link:
                    return f"{before} before {after}: {link}"
                return (f"{before} before {after}: every feasible sequence (exhaustive search) "
                        f"places {before} first, though no single precedence edge says so")
            return f"nothing requires {before} before {after}"
        parts = []
        for u, v in itertools.pairwise(path):
            reasons = "; ".join(f'{o["kind"]}: {o["reason"]}'
                                for o in self.precedence.edges[u, v]["origins"])
            parts.append(f"{u} before {v} ({reasons})")
        if len(path) == 2:
            return parts[0]
        text = f"{before} before {after} through {' -> '.join(path)}: " + "; and ".join(parts)
        anc = frozenset(nx.ancestors(self.precedence, before))
        t = self.blocking
        rows = list(zip(t.directions[before], t.blockers[before], t.table_blocked[before],
                        strict=True))
        by_after = [d.insertion_label for d, b, tb in rows if after in b and not tb and not (b & anc)]
        free = [d.insertion_label for d, b, tb in rows if after not in b and not tb and not (b & anc)]
        if by_after:
            text += (f". Directly, {after} blocks {before}'s insertion along {', '.join(by_after)}"
                     + (f" but not along {', '.join(free)}" if free else "")
                     + (", so that alone would not order them" if free else ""))
        return text

    def edges(self) -> list[dict[str, Any]]:
        """Every precedence edge with its origins, sorted."""
        return [{"before": u, "after": v, "origins": d["origins"]}
                for u, v, d in sorted(self.precedence.edges(data=True), key=lambda e: (e[0], e[1]))]

    def as_dict(self) -> dict[str, Any]:
        """JSON-safe summary: sequences with cost breakdown, every precedence edge with its
        reasons, the necessary order, the blocking table and the timings."""
        return {
            "product": self.product, "method": self.method,
            "feasible_count": self.feasible_count, "states": self.states,
            "weights_s": self.settings.weights,
            "sequences": [s.as_dict() for s in self.sequences],
            "precedence": self.edges(),
            "necessary": [{"before": a, "after": b, "explanation": self.explain(a, b)}
                          for a, b in self.necessary],
            "blocking": self.blocking.as_dict(),
            "timings_s": {k: round(v, 6) for k, v in self.timings_s.items()},
        }


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
    return product.is_fixtured(part) or table.on_table[part]


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
    """Knowledge precedence completed with geometry and stability edges (see module doc).

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


# ---------------------------------------------------------------------------------------------
# Search
# ---------------------------------------------------------------------------------------------
@dataclass
class _Label:
    cost: float
    key: tuple[int, ...]  # name ranks of the order, for lexicographic ties
    order: tuple[int, ...]
    dirs: tuple[int, ...]
    terms: tuple[float, ...]


class _Compiled:
    """The planning problem as bit masks (part i <-> bit i, product order)."""

    # Complexity above C (radon): compiles product, blocking table and precedence into bit masks once;
    # each block fills one table the search reads.
    def __init__(self, product: Product, table: BlockingTable, graph: nx.DiGraph,
                 settings: SequenceSettings, access: GripperAccess | None = None):
        self.product, self.table, self.settings = product, table, settings
        self.access = access if settings.gripper_access else None
        self._reach: dict[tuple[int, int], list[int]] = {}
        names = list(product.part_names)
        self.names = names
        self.n = len(names)
        self.full = (1 << self.n) - 1
        idx = {p: i for i, p in enumerate(names)}
        self.idx = idx
        rank = {p: r for r, p in enumerate(sorted(names))}
        self.rank = [rank[p] for p in names]

        def mask(parts: Iterable[str]) -> int:
            m = 0
            for q in parts:
                m |= 1 << idx[q]
            return m

        self.pred = [mask(nx.ancestors(graph, p)) for p in names]
        self.dir_masks: list[list[tuple[int, int]]] = []  # (direction index, blocker mask)
        for p in names:
            self.dir_masks.append([(i, mask(b)) for i, (b, t) in enumerate(
                zip(table.blockers[p], table.table_blocked[p], strict=True)) if not t])
        self.stable_alone = [_stable_alone(product, table, p) for p in names]
        partners = _mate_partners(product)
        self.support = [mask(table.supporters[p]) for p in names]
        ruled = _rule_holders(product)
        self.ruled = [mask(ruled[p]) for p in names]
        self.holders = [mask(table.supporters[p] | frozenset(partners[p]) | frozenset(ruled[p]))
                        for p in names]
        self.groups = [mask(g.parts) for g in product.precedence.groups]
        # preferred directions: handling knowledge, then mates whose partner is present,
        # then top-down insertion, then the rest
        cos_tol = math.cos(settings.angle_tolerance_rad)
        self.head: list[list[int]] = []
        self.mate_dirs: list[list[tuple[int, int]]] = []
        self.rest: list[list[int]] = []
        for k, p in enumerate(names):
            dirs = table.directions[p]
            usable = [i for i, _m in self.dir_masks[k]]

            def find(v: np.ndarray, dirs: Any = dirs, usable: list[int] = usable) -> int | None:
                for i in usable:
                    if float(np.dot(dirs[i].insertion, v)) >= cos_tol:
                        return i
                return None

            head = []
            hint = product.part(p).handling.insertion_direction
            if hint is not None:
                i = find(np.asarray(hint, dtype=float))
                if i is not None:
                    head.append(i)
            mdirs = []
            for m in sorted(product.mates, key=lambda m: m.name):
                if p not in (m.pin_part, m.hole_part):
                    continue
                other = m.hole_part if p == m.pin_part else m.pin_part
                i = find(mate_insertion_direction(product, m.name, p))
                # -1: the mate's direction is not usable at all (e.g. into the table)
                mdirs.append((1 << idx[other], -1 if i is None else i))
            down = find(np.array([0.0, 0.0, -1.0]))
            rest = ([down] if down is not None else []) + [i for i in usable if i != down]
            self.head.append(head)
            self.mate_dirs.append(mdirs)
            self.rest.append(rest)
        # cost data
        T_prod = product.T_world_product
        self.home = T_prod[:3, 3].copy()
        self.place = [product.T_world_assembled(p)[:3, 3].copy() for p in names]
        self.start: list[np.ndarray | None] = []
        for p in names:
            s = product.part(p).T_world_start
            self.start.append(None if not np.all(np.isfinite(s)) else s[:3, 3].copy())
        self.travel_lb = [0.0 if s is None else float(np.linalg.norm(s - x))
                          for s, x in zip(self.start, self.place, strict=True)]
        self.tool = [("fixture:" + _fixture_names(product, p)[0]) if product.is_fixtured(p)
                     else "gripper" for p in names]
        # directions as class ids (equal within the angle tolerance): comparisons are ints
        classes: list[np.ndarray] = []

        def class_id(v: np.ndarray) -> int:
            for j, u in enumerate(classes):
                if float(np.dot(u, v)) >= cos_tol:
                    return j
            classes.append(v)
            return len(classes) - 1

        self.approach_id: list[list[int]] = []
        self.insertion_id: list[list[int]] = []
        for p in names:
            grasp = product.part(p).handling.grasp
            R = product.T_world_assembled(p)[:3, :3]
            ins = [class_id(d.insertion) for d in table.directions[p]]
            if grasp is not None and grasp.approach_axis is not None:
                a = R @ np.asarray(grasp.approach_axis, dtype=float)
                self.approach_id.append([class_id(a / np.linalg.norm(a))] * len(ins))
            else:
                self.approach_id.append(ins)
            self.insertion_id.append(ins)
        # travel: from the previous part's place (or home, index n) to this part's start + on
        origins = [*self.place, self.home]
        self.travel = [[0.0 if s is None else float(np.linalg.norm(s - o)) + lb
                        for s, lb in zip(self.start, self.travel_lb, strict=True)] for o in origins]
        w = settings.weights
        self.w = [w[t] for t in COST_TERMS]

    # -- feasibility -------------------------------------------------------------------------
    def allowed(self, done: int) -> int:
        """Mask of parts that the open groups allow next."""
        allow = self.full
        for g in self.groups:
            if g & done and g & ~done:
                allow &= g
        return allow & ~done

    def choose(self, p: int, done: int) -> int:
        """Direction index for inserting part p into done, or -1 when p cannot be added."""
        if self.pred[p] & ~done:
            return -1
        if not self.stable_alone[p] and not (self.holders[p] & done):
            return -1
        free = {i for i, m in self.dir_masks[p] if not (m & done)}
        if not free:
            return -1
        # a feature enters its mate from the mouth side: every mate with a part already
        # present fixes the insertion direction, and two different ones cannot both be met
        required = {i for partner, i in self.mate_dirs[p] if partner & done}
        if required:
            if len(required) > 1 or -1 in required:
                return -1
            (i,) = required
            return i if i in free else -1
        for i in self.head[p]:
            if i in free:
                return i
        for i in self.rest[p]:
            if i in free:
                return i
        return -1  # pragma: no cover - rest lists every usable direction

    def successors(self, done: int) -> list[tuple[int, int]]:
        out = []
        allow = self.allowed(done)
        for p in range(self.n):
            if allow >> p & 1:
                d = self.choose(p, done)
                if d >= 0:
                    out.append((p, d))
        return out

    # -- cost --------------------------------------------------------------------------------
    def step_terms(self, last: int, dlast: int, p: int, dp: int, done: int) -> tuple[float, ...]:
        """Raw cost terms of adding part p along direction dp to done after (last, dlast)."""
        if last < 0:
            reo = dch = tch = 0.0
        else:
            reo = 0.0 if self.approach_id[last][dlast] == self.approach_id[p][dp] else 1.0
            dch = 0.0 if self.insertion_id[last][dlast] == self.insertion_id[p][dp] else 1.0
            tch = 0.0 if self.tool[last] == self.tool[p] else 1.0
        travel = self.travel[last][p]  # last = -1 picks the home row
        risk = 0.0 if (self.stable_alone[p] or (self.support[p] | self.ruled[p]) & done) else 1.0
        return (reo, dch, tch, travel, risk, 0.0 if self.reachable(p, dp, done) else 1.0)

    # -- gripper access ----------------------------------------------------------------------
    def _access(self, p: int, d: int) -> Any:
        name = self.names[p]
        ins = self.table.directions[name][d].insertion
        pre = self.product.process.approach_distance_m + max(
            (self.product.feature(m.pin_part, m.pin_feature).length_m for m in self.product.mates
             if name in (m.pin_part, m.hole_part)), default=0.0)
        required = frozenset(self.bits(self.pred[p]))
        if self.access is None:
            raise ValueError("gripper access is off (SequenceSettings.gripper_access)")
        return self.access.access(name, ins, pre, required)

    def reachable(self, p: int, d: int, done: int) -> bool:
        """Whether some screened grasp of part p (inserted along direction d) is free of
        every part in ``done`` (always True for fixtured parts or without screening)."""
        if self.access is None or self.product.is_fixtured(self.names[p]):
            return True
        masks = self._reach.get((p, d))
        if masks is None:
            acc = self._access(p, d)
            masks = [sum(1 << self.idx[q] for q in o) for o in acc.options]
            self._reach[(p, d)] = masks
        return any(not (m & done) for m in masks)

    def unreachable_reason(self, p: int, d: int, done: int) -> str:
        if self.reachable(p, d, done):
            return ""
        return self._access(p, d).reason(frozenset(self.bits(done)))

    def extend(self, lab: _Label, done: int, p: int, d: int) -> _Label:
        last = lab.order[-1] if lab.order else -1
        dlast = lab.dirs[-1] if lab.dirs else -1
        t = self.step_terms(last, dlast, p, d, done)
        cost = lab.cost + sum(wi * ti for wi, ti in zip(self.w, t, strict=True))
        terms = tuple(a + b for a, b in zip(lab.terms, t, strict=True))
        return _Label(cost, (*lab.key, self.rank[p]), (*lab.order, p), (*lab.dirs, d), terms)

    def h(self, done: int) -> float:
        """Admissible lower bound of the remaining cost (travel from tray to place)."""
        w = self.w[3]
        return w * sum(self.travel_lb[p] for p in range(self.n) if not done >> p & 1)

    def reasons(self, done: int) -> dict[str, str]:
        """Why each part outside done cannot be added to done."""
        out = {}
        present = {self.names[i] for i in range(self.n) if done >> i & 1}
        allow = self.allowed(done)
        for p in range(self.n):
            if done >> p & 1:
                continue
            name = self.names[p]
            if not allow >> p & 1:
                out[name] = "an assembly group in progress must be completed first"
            elif self.pred[p] & ~done:
                missing = [self.names[i] for i in range(self.n) if (self.pred[p] & ~done) >> i & 1]
                out[name] = f"must come after {', '.join(missing)}"
            elif not self.stable_alone[p] and not (self.holders[p] & done):
                out[name] = "nothing placed can hold it"
            elif self.mate_conflict(p, done):
                out[name] = self.mate_conflict(p, done)
            else:
                rows = _blocked_text(self.table, name, frozenset(present))
                out[name] = "blocked: " + _evidence_text(rows)
        return out

    def mate_conflict(self, p: int, done: int) -> str:
        """Why the mates of part p with parts in ``done`` admit no common insertion ("" when
        they do): each feature enters its mate from the mouth side."""
        required = [(partner, i) for partner, i in self.mate_dirs[p] if partner & done]
        dirs = {i for _partner, i in required}
        if not required or (len(dirs) == 1 and -1 not in dirs):
            return ""
        name = self.names[p]
        texts = []
        for m in sorted(self.product.mates, key=lambda m: m.name):
            if name not in (m.pin_part, m.hole_part):
                continue
            other = m.hole_part if name == m.pin_part else m.pin_part
            if not (done >> self.idx[other] & 1):
                continue
            v = mate_insertion_direction(self.product, m.name, name)
            texts.append(f"mate {m.name} with {other} enters along {direction_label(v)}")
        return ("its mates with parts already placed need different insertion directions ("
                + "; ".join(texts) + "): each feature enters its mate from the mouth side")

    def link(self, before: str, after: str) -> str:
        """Why ``before`` must precede ``after`` when no precedence edge chain says so: the
        reason ``before`` cannot be added once ``after`` and everything ``after`` requires are
        in place ("" when it can be added there; the reason then lies further on)."""
        a, b = self.idx[before], self.idx[after]
        S = self.pred[b] | 1 << b
        if S >> a & 1:
            return ""
        placed = [n for n in self.bits(S) if n != after]
        head = (f"once {after} is in place (with {', '.join(placed) or 'nothing'} before it, as "
                "required), ")
        if self.choose(a, S) < 0:
            return head + f"{before} cannot be added: {self.reasons(S)[before]}"
        # a deeper link: every way on from S dead-ends; name the smallest dead end
        seen, frontier, dead = {S}, [S], []
        while frontier and len(seen) < 5000:
            nxt = []
            for T in frontier:
                succ = self.successors(T)
                if not succ and self.full != T:
                    dead.append(T)
                for p, _d in succ:
                    U = T | 1 << p
                    if U not in seen:
                        seen.add(U)
                        nxt.append(U)
            frontier = nxt
        if not dead or self.full in seen:
            return ""
        D = min(dead, key=lambda T: (bin(T).count("1"), sorted(self.bits(T))))
        extra = [n for n in self.bits(D) if n not in self.bits(S)]
        why = "; ".join(f"{p}: {r}" for p, r in sorted(self.reasons(D).items()))
        return (head + f"every way on dead-ends, e.g. after also placing "
                f"{', '.join(extra) or 'nothing'}: {why}")

    def bits(self, done: int) -> list[str]:
        return [self.names[i] for i in range(self.n) if done >> i & 1]


def _key(lab: _Label) -> tuple[float, tuple[int, ...]]:
    return (round(lab.cost, 9), lab.key)


# Complexity above C (radon): the exact layered search with k best labels per state merged through a
# heap; the state bookkeeping is shared by every branch.
def _exhaustive(c: _Compiled, k: int) -> tuple[list[_Label], int, int, list[tuple[str, str]], int] | None:
    """Enumerate reachable states; None when more than ``max_states``.

    Returns (top labels, feasible count, states, necessary pairs, smallest dead end).
    """
    succ: dict[int, list[tuple[int, int]]] = {}
    layers: list[list[int]] = [[0]]
    seen = {0}
    while layers[-1]:
        nxt = []
        for done in layers[-1]:
            lst = c.successors(done)
            succ[done] = lst
            for p, _d in lst:
                T = done | 1 << p
                if T not in seen:
                    seen.add(T)
                    nxt.append(T)
                    if len(seen) > c.settings.max_states:
                        return None
        layers.append(sorted(nxt))
    count: dict[int, int] = {0: 1}
    for layer in layers:
        for done in layer:
            for p, _d in succ[done]:
                T = done | 1 << p
                count[T] = count.get(T, 0) + count[done]
    feasible = count.get(c.full, 0)
    dead = [done for done in seen if done != c.full and not succ[done]]
    dead_end = min(dead, key=lambda done: (bin(done).count("1"), sorted(c.bits(done)))) if dead else -1
    # states on complete sequences
    alive = {c.full} if c.full in seen else set()
    for layer in reversed(layers):
        for done in layer:
            if any((done | 1 << p) in alive for p, _d in succ[done]):
                alive.add(done)
    # exact top-k over (state, last part): labels of one (state, last) share the direction of
    # the last step, so a successor adds the same cost to all of them (sorted lists stay
    # sorted) and each new bucket is a k-way merge of its sources
    zero = (0.0,) * len(COST_TERMS)
    labels: dict[tuple[int, int], list[_Label]] = {(0, -1): [_Label(0.0, (), (), (), zero)]}
    for layer in layers:
        pending: dict[tuple[int, int], list[tuple[list[_Label], float, tuple[float, ...], int]]] = {}
        for done in layer:
            if done not in alive or done == c.full:
                continue
            for last in [-1, *range(c.n)]:
                labs = labels.pop((done, last), None)
                if not labs:
                    continue
                dlast = labs[0].dirs[-1] if labs[0].dirs else -1
                for p, d in succ[done]:
                    T = done | 1 << p
                    if T in alive:
                        t = c.step_terms(last, dlast, p, d, done)
                        delta = sum(wi * ti for wi, ti in zip(c.w, t, strict=True))
                        pending.setdefault((T, p), []).append((labs, delta, t, d))
        for (T, p), sources in pending.items():
            heap = [(round(src[0][0].cost + src[1], 9), src[0][0].key, i, 0)
                    for i, src in enumerate(sources)]
            heapq.heapify(heap)
            out: list[_Label] = []
            while heap and len(out) < k:
                _c, _k, i, j = heapq.heappop(heap)
                labs, delta, t, d = sources[i]
                src = labs[j]
                out.append(_Label(src.cost + delta, (*src.key, c.rank[p]), (*src.order, p),
                                  (*src.dirs, d), tuple(a + b for a, b in zip(src.terms, t, strict=True))))
                if j + 1 < len(labs):
                    following = labs[j + 1]
                    heapq.heappush(heap, (round(following.cost + delta, 9), following.key, i,
                                          j + 1))
            labels[(T, p)] = out
    final = [lab for last in range(c.n) for lab in labels.get((c.full, last), [])]
    final.sort(key=_key)
    # necessary pairs: a before b in every feasible sequence
    violated = [0] * c.n  # violated[b]: bits a such that some feasible state has b without a
    for done in alive:
        for b in range(c.n):
            if done >> b & 1:
                violated[b] |= c.full & ~done
    necessary = [(c.names[a], c.names[b]) for b in range(c.n) for a in range(c.n)
                 if a != b and alive and not violated[b] >> a & 1]
    necessary.sort()
    return final[:k], feasible, len(seen), necessary, dead_end


def _beam(c: _Compiled, width: int, k: int) -> tuple[list[_Label], int, int]:
    """Beam search; returns (complete labels best first, states expanded, last dead state)."""
    nodes: list[tuple[int, _Label]] = [(0, _Label(0.0, (), (), (), (0.0,) * len(COST_TERMS)))]
    expanded = 0
    for _depth in range(c.n):
        buckets: dict[tuple[int, int], list[_Label]] = {}
        for done, lab in nodes:
            expanded += 1
            for p, d in c.successors(done):
                T = done | 1 << p
                bucket = buckets.setdefault((T, p), [])
                bucket.append(c.extend(lab, done, p, d))
                if len(bucket) > 4 * k:
                    bucket.sort(key=_key)
                    del bucket[k:]
        if not buckets:
            dead = min((done for done, _ in nodes),
                       key=lambda done: (bin(done).count("1"), sorted(c.bits(done))))
            return [], expanded, dead
        cand: list[tuple[float, tuple[int, ...], int, _Label]] = []
        for (T, _p), labs in buckets.items():
            labs.sort(key=_key)
            hT = c.h(T)
            cand.extend((round(lab.cost + hT, 9), lab.key, T, lab) for lab in labs[:k])
        cand.sort(key=lambda x: (x[0], x[1]))
        nodes = [(T, lab) for _f, _key2, T, lab in cand[:width]]
    final = sorted((lab for _S, lab in nodes), key=_key)
    return final[:k], expanded, -1


def _dfs(c: _Compiled) -> tuple[_Label | None, int, int]:
    """Any feasible sequence by depth-first search with memoised dead states (complete)."""
    dead: set[int] = set()
    smallest = [c.full]

    def rec(done: int, lab: _Label) -> _Label | None:
        if done == c.full:
            return lab
        succ = c.successors(done)
        if not succ and bin(done).count("1") <= bin(smallest[0]).count("1"):
            smallest[0] = done
        for p, d in succ:
            T = done | 1 << p
            if T in dead:
                continue
            out = rec(T, c.extend(lab, done, p, d))
            if out is not None:
                return out
            dead.add(T)
        return None

    found = rec(0, _Label(0.0, (), (), (), (0.0,) * len(COST_TERMS)))
    return found, len(dead), smallest[0]


def _ranked(c: _Compiled, labels: list[_Label]) -> tuple[RankedSequence, ...]:
    out = []
    for r, lab in enumerate(labels, start=1):
        steps = []
        done = 0
        for p, d in zip(lab.order, lab.dirs, strict=True):
            name = c.names[p]
            direction = c.table.directions[name][d]
            free = tuple(c.table.directions[name][i].insertion_label
                         for i, m in c.dir_masks[p] if not (m & done))
            if c.product.is_fixtured(name):
                held, stab = tuple("fixture:" + f for f in _fixture_names(c.product, name)), "fixtured"
            elif c.table.on_table[name]:
                held, stab = ("table",), "table"
            elif c.support[p] & done:
                held, stab = tuple(c.bits(c.holders[p] & done)), "resting"
            elif c.ruled[p] & done:
                held, stab = tuple(c.bits(c.holders[p] & done)), "rule"
            else:
                held, stab = tuple(c.bits(c.holders[p] & done)), "mated"
            steps.append(SequenceStep(name, direction.insertion, direction.insertion_label, free,
                                      held, stab, c.tool[p], c.unreachable_reason(p, d, done)))
            done |= 1 << p
        terms = dict(zip(COST_TERMS, lab.terms, strict=True))
        breakdown = {t: c.settings.weights[t] * terms[t] for t in COST_TERMS}
        out.append(RankedSequence(r, tuple(c.names[p] for p in lab.order), tuple(steps),
                                  sum(breakdown.values()), terms, breakdown))
    return tuple(out)


def _first_blocking_rule(product: Product, table: BlockingTable, settings: SequenceSettings
                         ) -> PrecedenceRule | None:
    """The first rule (by line) whose removal makes the product feasible, if any."""
    import dataclasses

    for rule in sorted(product.precedence.rules, key=lambda r: r.source_line):
        rest = tuple(r for r in product.precedence.rules if r is not rule)
        reduced = dataclasses.replace(product, precedence=dataclasses.replace(
            product.precedence, rules=rest))
        try:
            c = _Compiled(reduced, table, derive_precedence(reduced, table), settings)
        except (PrecedenceConflictError, NoFeasibleSequenceError):
            continue
        if _dfs(c)[0] is not None:
            return rule
    return None


def _part_signature(product: Product, name: str) -> str:
    """What makes a part interchangeable with another: shape, material, mass, friction,
    features and handling (not its name, pose or start)."""
    p = product.part(name)

    def r(a: Any) -> Any:
        return None if a is None else np.round(np.asarray(a, float), 9).tolist()

    g = p.geometry
    geo = (g.kind, [(q.shape, r(q.T_part_shape), r(q.size_m), q.diameter_m, q.length_m)
                    for q in g.primitives],
           [(r(h.origin_m), r(h.axis), h.diameter_m, h.depth_m, h.through, h.chamfer_m)
            for h in g.holes],
           [(r(q.origin_m), r(q.axis), q.diameter_m, q.length_m, q.chamfer_m) for q in g.pins],
           str(g.mesh_file), g.mesh_scale)
    feats = sorted((f.kind, r(f.origin_m), r(f.axis), f.diameter_m, f.length_m, f.chamfer_m,
                    f.through) for f in p.features)
    h = p.handling
    hint = None if h.grasp is None else (r(h.grasp.closing_axis), r(h.grasp.approach_axis),
                                         h.grasp.width_m, r(h.grasp.offset_m))
    hand = (r(h.insertion_direction), hint, h.max_clamp_force_N, h.max_speed_m_s,
            h.max_acceleration_m_s2, h.finger)
    mat = None if p.material is None else p.material.name
    return repr((geo, feats, hand, mat, p.mass_kg, p.friction, product.is_fixtured(name)))


def identical_parts(product: Product) -> list[tuple[str, ...]]:
    """Groups (of two or more, product order) of interchangeable parts: the same shape,
    material, features and handling (four identical dowels)."""
    groups: dict[str, list[str]] = {}
    for n in product.part_names:
        groups.setdefault(_part_signature(product, n), []).append(n)
    return [tuple(g) for g in groups.values() if len(g) > 1]


def _distinct(c: _Compiled, labels: list[_Label], classes: list[tuple[str, ...]]
              ) -> list[_Label]:
    """The labels (best first) with orders that differ only in the order of identical parts
    collapsed to the best of them."""
    cls = {n: f"#{k}" for k, g in enumerate(classes) for n in g}
    seen: set[tuple[str, ...]] = set()
    out = []
    for lab in labels:
        key = tuple(cls.get(c.names[p], c.names[p]) for p in lab.order)
        if key not in seen:
            seen.add(key)
            out.append(lab)
    return out


def plan_sequence(product: Product, oracle: GeometryOracle | None = None,
                  settings: SequenceSettings | None = None, *,
                  table: BlockingTable | None = None) -> SequencePlan:
    """Plan, explain and rank assembly sequences of ``product``.

    Parameters
    ----------
    product : the validated product.
    oracle : geometry, e.g. :class:`asmplan.planner.fcl_oracle.FclOracle` (FCL on the exact
        collision models of :mod:`asmplan.parts`); not needed when ``table`` is given.
    settings : weights and limits (default :class:`SequenceSettings`).
    table : a precomputed blocking table (skips the collision sweeps).

    Raises
    ------
    PrecedenceConflictError
        A rule contradicts the geometry: names the rule (line) and the geometric evidence.
    NoFeasibleSequenceError
        No sequence exists: names the smallest dead-end partial assembly.
    """
    settings = settings or SequenceSettings()
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    if table is None:
        if oracle is None:
            raise TypeError("plan_sequence: expected a geometry oracle or a blocking table, found "
                            "neither")
        table = blocking_table(product, oracle, support_probe_m=settings.support_probe_m,
                               table_contact_m=settings.table_contact_m)
    t1 = time.perf_counter()
    timings["blocking"] = t1 - t0
    graph = derive_precedence(product, table)
    access = GripperAccess(product, getattr(oracle, "geometry", None)) \
        if settings.gripper_access else None
    c = _Compiled(product, table, graph, settings, access)
    t2 = time.perf_counter()
    timings["precedence"] = t2 - t1
    classes = identical_parts(product) if settings.collapse_identical else []
    # orders that differ only in the order of identical parts are one process: search deep
    # enough to return top_k distinct ones
    k = min(settings.top_k * math.prod(math.factorial(len(g)) for g in classes),
            max(settings.top_k, settings.max_identical_pool))
    necessary: list[tuple[str, str]] = []
    result = _exhaustive(c, k)
    if result is not None:
        labels, feasible, states, necessary, dead_end = result
        method: str = "exhaustive"
        count: int | None = feasible
    else:
        method, count, labels, states, dead_end = "beam", None, [], 0, -1
        width = settings.beam_width
        while width <= settings.max_beam_width:
            labels, expanded, dead_end = _beam(c, width, k)
            states += expanded
            if labels:
                break
            width *= 2
        if not labels:
            found, n_dead, dead_end = _dfs(c)
            states += n_dead
            method = "dfs"
            labels = [found] if found is not None else []
    timings["search"] = time.perf_counter() - t2
    if not labels:
        rule = _first_blocking_rule(product, table, settings) if product.precedence.rules else None
        done = max(dead_end, 0)
        if rule is not None:
            raise PrecedenceConflictError(
                product, [rule], "without this rule the product can be assembled; with it, every "
                f"order dead-ends, e.g. after {', '.join(c.bits(done)) or 'nothing'}: "
                + "; ".join(f"{p}: {r}" for p, r in sorted(c.reasons(done).items())),
                [{"dead_end": c.bits(done), "reasons": c.reasons(done)}])
        raise NoFeasibleSequenceError(product.name, c.bits(done), c.reasons(done))
    labels = _distinct(c, labels, classes)[: settings.top_k]
    links = {(a, b): c.link(a, b) for a, b in necessary if not nx.has_path(graph, a, b)}
    return SequencePlan(product=product.name, sequences=_ranked(c, labels), precedence=graph,
                        blocking=table, method=method, feasible_count=count, states=states,
                        necessary=tuple(necessary), settings=settings, timings_s=timings,
                        links={k: v for k, v in links.items() if v})


__all__ = ["COST_TERMS", "NoFeasibleSequenceError", "PrecedenceConflictError", "RankedSequence",
           "SequencePlan", "SequenceSettings", "SequenceStep", "derive_precedence", "plan_sequence"]
