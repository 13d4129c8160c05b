"""Assembly sequence planning: "in which order?", explained and ranked by cell time.

Method
------
1. **Geometry** (:mod:`asmplan.planner.blocking`): every part is swept once, in the full
   assembly, along the six axis directions and its mate axes; the blockers of each sweep are
   stored. A part ``p`` can be the last one added to a partial assembly ``S`` iff one of its
   directions has no blocker in ``S`` (assembly by disassembly, as set operations).
2. **Precedence** (:mod:`asmplan.planner.precedence`): the knowledge graph
   (:func:`asmplan.knowledge.graphs.precedence_graph`: base and rules) is completed, to a
   fixpoint, with derived edges, each with its evidence:

   * ``geometry`` -- ``p`` before ``q`` when, with every part that must precede ``p`` in
     place, ``q`` blocks ``p`` in every direction those parts leave open (origin records the
     blocker, the blocked insertion directions and the parts that block the rest);
   * ``stability`` -- ``q`` before ``p`` when ``q`` is the only part that can hold ``p``
     (see *Stability* below).

   First without the rules (geometry, stability and the declared base only): a rule that
   goes against a derived order, or that makes a part impossible to insert or to hold, is a
   :class:`PrecedenceConflictError` naming the rule (file:line) and the geometry. Rules that
   the geometry also implies get the geometry origin on the same edge.
3. **Search** (:mod:`asmplan.planner.sequence_search`) over assembly states (sets of placed
   parts). When at most ``SequenceSettings.max_states`` states are reachable, all of them are
   enumerated (the state graph is the sequential equivalent of the AND/OR graph): the number
   of feasible sequences is counted, the top-k sequences are exact (dynamic programming over
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

import itertools
import math
import time
from dataclasses import dataclass, field
from typing import Any

import networkx as nx
import numpy as np

from ..knowledge.model import Product
from .access import AccessSettings, GripperAccess
from .blocking import BlockingTable, GeometryOracle, blocking_table
from .precedence import NoFeasibleSequenceError, PrecedenceConflictError, _fixture_names, derive_precedence
from .sequence_search import (
    COST_TERMS,
    _Compiled,
    _distinct,
    _first_blocking_rule,
    _Label,
    identical_parts,
    search_orders,
)


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
        Per step the gripper or the arm cannot do in that order (no screened grasp is free
        of the parts already placed and within the arm's reach and joint limits,
        :mod:`asmplan.planner.access`, :mod:`asmplan.planner.arm_reach`), default 600 s:
        such an order ranks below every order the cell can do, its reason kept, and is
        still tried last.
    gripper_access : bool
        Screen every step for gripper access (default True; False: the order ignores the
        gripper and the arm, and ``unreachable`` stays 0).
    arm_reach : bool
        With an arm in the cell, screen the screened grasps' key TCP poses for the arm's
        reach and joint limits too (default True; only with ``gripper_access``).
    arm_collisions : bool
        With ``arm_reach``, also check the arm's links at each screened grasp's pre-insertion
        and seated poses against the table and the other parts (default True): an order
        whose step needs a link where a placed part stands ranks as ``unreachable``, with the
        colliding pair in its reason.
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
    arm_reach: bool = True
    arm_collisions: bool = True
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
        What holds the part once placed: ``"fixture:<name>"``, ``"operation:<operation>"``,
        ``"table"``, or part names (supporting or mated parts already placed).
    stability : str
        ``"fixtured"``, ``"operation"`` (placed and held by another operation,
        ``handling.operation``), ``"table"``, ``"resting"`` (something under it), ``"rule"`` (a
        knowledge rule "q before part" says it goes onto q, placed) or ``"mated"`` (held by
        mates only: one unit of stability risk).
    tool : str
        ``"gripper"``, ``"fixture:<name>"`` or ``"operation:<operation>"``.
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
            elif c.product.placed_by(name) is not None:
                held, stab = (f"operation:{c.product.placed_by(name)}",), "operation"
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
    access = GripperAccess(product, getattr(oracle, "geometry", None),
                           AccessSettings(arm_reach=settings.arm_reach,
                                          arm_collisions=settings.arm_collisions)) \
        if settings.gripper_access else None
    c = _Compiled(product, table, graph, settings, access)
    t2 = time.perf_counter()
    timings["precedence"] = t2 - t1
    classes = identical_parts(product) if settings.collapse_identical else []
    # orders that differ only in the order of identical parts are one process: search deep
    # enough to return top_k distinct ones
    k = min(settings.top_k * math.prod(math.factorial(len(g)) for g in classes),
            max(settings.top_k, settings.max_identical_pool))
    labels, method, count, states, necessary, dead_end = search_orders(c, k)
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
