"""The sequence search's labels: a partial order with its cost (:mod:`asmplan.planner.sequence_search`).

A label is a partial order (part indices), the insertion direction chosen at each step, its
weighted cost and the raw cost terms. The beam and depth-first searches build each label in
full; the exhaustive search makes hundreds of thousands of them (20 parts: top-k times the
permutations of identical parts, per state and last part) and chains them instead: a label
holds the label it extends and its own step, and its order, directions and terms are made
only for the labels returned (:func:`_materialize`). Its key, the name ranks of the order for
lexicographic ties, is then one base-n integer: the same order as the rank tuples, since the
labels compared have equal lengths.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass
class _Label:
    cost: float
    key: Any  # name ranks of the order (tuple of int), for lexicographic ties
    order: tuple[int, ...]
    dirs: tuple[int, ...]
    terms: tuple[float, ...]
    # the exhaustive search's labels are chained instead (:func:`_materialize`): the label
    # they extend, the step's terms, part and direction; order, dirs and terms are empty
    # until materialized, and the key is the ranks as one base-n integer (the same order as
    # the tuples: the labels compared have equal lengths)
    parent: _Label | None = None
    step: tuple[float, ...] | None = None
    part: int = -1
    dir: int = -1


def _materialize(lab: _Label) -> _Label:
    """``lab`` with its order, directions and terms filled in along its chain of parents
    (the terms summed in step order, the same additions as summing them step by step)."""
    if lab.parent is None:
        return lab
    chain = []
    node: _Label = lab
    while node.parent is not None:
        chain.append(node)
        node = node.parent
    order, dirs, acc = list(node.order), list(node.dirs), node.terms
    for x in reversed(chain):
        assert x.step is not None
        order.append(x.part)
        dirs.append(x.dir)
        acc = tuple(a + b for a, b in zip(acc, x.step, strict=True))
    lab.order, lab.dirs, lab.terms = tuple(order), tuple(dirs), acc
    lab.parent = lab.step = None
    return lab


def _key(lab: _Label) -> tuple[float, Any]:
    return (round(lab.cost, 9), lab.key)
