"""Sequence search: the product compiled to bit masks, searched exactly, by beam or depth first.

Step 3 of the method in :mod:`asmplan.planner.sequence`: :class:`_Compiled` turns the product,
its blocking table and its precedence graph into bit masks and cost tables once;
:func:`_exhaustive` enumerates every reachable assembly state (exact top-k, feasible count,
necessary orders), :func:`_beam` and :func:`_dfs` take over when there are too many. Orders
that differ only in the order of identical parts are collapsed (:func:`identical_parts`).
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import networkx as nx
import numpy as np

from ..knowledge.model import PrecedenceRule, Product
from .access import GripperAccess
from .blocking import BlockingTable, direction_label, mate_insertion_direction
from .precedence import (
    NoFeasibleSequenceError,
    PrecedenceConflictError,
    _blocked_text,
    _evidence_text,
    _fixture_names,
    _mate_partners,
    _rule_holders,
    _stable_alone,
    derive_precedence,
)
from .sequence_labels import _key, _Label, _materialize

if TYPE_CHECKING:
    from .sequence import SequenceSettings


COST_TERMS: tuple[str, ...] = ("reorientations", "direction_changes", "tool_changes", "travel_m",
                               "stability_risk", "unreachable")
"""Names of the cost terms, in the order of :attr:`RankedSequence.terms`."""


# ---------------------------------------------------------------------------------------------
# Search
# ---------------------------------------------------------------------------------------------
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
                     else ("operation:" + str(product.placed_by(p)))
                     if product.placed_by(p) is not None else "gripper" for p in names]
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
        # the preferred free direction, unless the gripper or the arm cannot do the step
        # along it in this partial assembly and another free direction can (e.g. a drawer
        # the arm reaches through the cabinet's front but not from above): the order's step
        # then goes that way, as the motion planner will plan it
        first = -1
        for i in itertools.chain(self.head[p], self.rest[p]):
            if i in free:
                if first < 0:
                    first = i
                if self.access is None or self.reachable(p, i, done):
                    return i
        return first

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
        required = frozenset(self.bits(self.pred[p]))
        if self.access is None:
            raise ValueError("gripper access is off (SequenceSettings.gripper_access)")
        return self.access.access(name, ins, None, required)  # the planner's start

    def reachable(self, p: int, d: int, done: int) -> bool:
        """Whether some screened grasp of part p (inserted along direction d) is free of
        every part in ``done`` (always True for fixtured parts or without screening)."""
        if self.access is None or self.tool[p] != "gripper":  # fixtured: always
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
    labels: dict[tuple[int, int], list[_Label]] = {(0, -1): [_Label(0.0, 0, (), (), zero)]}
    for layer in layers:
        pending: dict[tuple[int, int], list[tuple[list[_Label], float, tuple[float, ...], int]]] = {}
        for done in layer:
            if done not in alive or done == c.full:
                continue
            for last in [-1, *range(c.n)]:
                labs = labels.pop((done, last), None)
                if not labs:
                    continue
                dlast = labs[0].dir
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
                # chained: order, dirs and terms are made for the labels kept only
                out.append(_Label(src.cost + delta, src.key * c.n + c.rank[p], (), (), (),
                                  src, t, p, d))
                if j + 1 < len(labs):
                    following = labs[j + 1]
                    heapq.heappush(heap, (round(following.cost + delta, 9), following.key, i,
                                          j + 1))
            labels[(T, p)] = out
    final = [lab for last in range(c.n) for lab in labels.get((c.full, last), [])]
    final.sort(key=_key)
    final = [_materialize(lab) for lab in final[:k]]
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


def search_orders(c: _Compiled, k: int) -> tuple[list[_Label], str, int | None, int,
                                                list[tuple[str, str]], int]:
    """The best ``k`` orders: exhaustive when the states are few enough, else beam search
    widening up to ``max_beam_width``, else depth first (complete).

    Returns (labels best first, method, feasible count or None, states, necessary pairs,
    smallest dead end or -1).
    """
    settings = c.settings
    necessary: list[tuple[str, str]] = []
    result = _exhaustive(c, k)
    if result is not None:
        labels, feasible, states, necessary, dead_end = result
        return labels, "exhaustive", feasible, states, necessary, dead_end
    method, labels, states, dead_end = "beam", [], 0, -1
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
    return labels, method, None, states, necessary, dead_end


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


__all__ = ["COST_TERMS", "identical_parts", "search_orders"]
