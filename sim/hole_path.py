"""Holes the held part passes through on its way in (issue 16, gearbox shaft): a hole that
waits for a later step's part (:func:`asmplan.sim.bodies.empty_holes`) is modelled solid
only when the held part does not cross it.

The gearbox's shaft goes in through bearing_1, the gear, the spacer and out through the
right wall's seat for bearing_2, which is pressed in a later step: with that seat modelled
solid, the shaft's tip met the wall's inner face 16.0 mm short of its depth (123.0 of 139 mm
in; 442-965 N along the axis, the pads sliding 16 mm on it: a wall that is not there).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..knowledge.frames import invert
from ..planner.plan import Step

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry

EDGE_SPACING_M = 1e-3
"""The held part's mesh edges are sampled at most this far apart (a long shaft's side edges
run from cap to cap, past every hole between)."""

END_TOLERANCE_M = 1e-3
"""A part reaching less than this far into a hole's cylinder from its mouth or its floor does
not cross it (the gearbox's spacer, seated, lies 0.3 mm inside seat_2's declared depth,
which reaches 0.5 mm past the wall into the open interior)."""


def _edge_points(vertices: np.ndarray, edges: np.ndarray, spacing_m: float) -> np.ndarray:
    """The mesh's vertices and points along its edges at most ``spacing_m`` apart, (n, 3)."""
    a, b = vertices[edges[:, 0]], vertices[edges[:, 1]]
    length = np.linalg.norm(b - a, axis=1)
    counts = np.maximum(1, np.ceil(length / spacing_m).astype(int))
    out = [vertices]
    for n in np.unique(counts[counts > 1]):
        sel = counts == n
        s = (np.arange(1, n) / n)[None, :, None]
        out.append((a[sel][:, None, :] + s * (b[sel] - a[sel])[:, None, :]).reshape(-1, 3))
    return np.concatenate(out)


def _segments_enter(q: np.ndarray, d: np.ndarray, radius_m: float, z_lo: float, z_hi: float
                    ) -> bool:
    """Whether any point ``q + u d`` (q (n, 3), d (3,), u in [0, 1]) lies inside the cylinder
    about z of ``radius_m`` between ``z_lo`` and ``z_hi``."""
    lo = np.zeros(len(q))
    hi = np.ones(len(q))
    if abs(d[2]) > 1e-15:
        u0, u1 = (z_lo - q[:, 2]) / d[2], (z_hi - q[:, 2]) / d[2]
        lo, hi = np.maximum(lo, np.minimum(u0, u1)), np.minimum(hi, np.maximum(u0, u1))
    else:
        keep = (q[:, 2] > z_lo) & (q[:, 2] < z_hi)
        hi = np.where(keep, hi, -1.0)
    a = float(d[0] ** 2 + d[1] ** 2)
    b = 2.0 * (q[:, 0] * d[0] + q[:, 1] * d[1])
    c = q[:, 0] ** 2 + q[:, 1] ** 2 - radius_m ** 2
    if a > 1e-30:
        disc = b * b - 4.0 * a * c
        ok = disc > 0.0
        root = np.sqrt(np.where(ok, disc, 0.0))
        lo = np.maximum(lo, (-b - root) / (2.0 * a))
        hi = np.where(ok, np.minimum(hi, (-b + root) / (2.0 * a)), -1.0)
    else:
        hi = np.where(c < 0.0, hi, -1.0)
    return bool(np.any(lo < hi))


def holes_crossed(geometry: ProductGeometry, step: Step, part: str, T_world_part: np.ndarray,
                  holes: frozenset[str]) -> frozenset[str]:
    """The ``holes`` of ``part`` (at ``T_world_part``) that the held part of ``step`` enters
    on its straight insertion from ``T_world_pre_insertion`` to ``T_world_final``: a sample
    of its surface (mesh vertices and edge points :data:`EDGE_SPACING_M` apart), each point
    moving straight at the final rotation, enters a hole's cylinder (fitted radius, from the
    mouth to the declared or cut depth, less :data:`END_TOLERANCE_M` at each end). Empty
    when the step has no insertion."""
    if not holes or step.T_world_pre_insertion is None:
        return frozenset()
    shape = geometry.shape(part)
    wanted = [h for h in shape.holes if h.feature in holes]
    if not wanted:
        return frozenset()
    mesh = geometry.mesh(step.part)
    f = np.asarray(mesh.faces, int)
    edges = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]),
                              axis=1), axis=0)
    pts = _edge_points(np.asarray(mesh.vertices, float), edges, EDGE_SPACING_M)
    A = np.asarray(step.T_world_pre_insertion, float)
    B = np.asarray(step.T_world_final, float)  # the path: B's rotation, translation A -> B
    T_part_world = invert(np.asarray(T_world_part, float))
    crossed = set()
    for h in wanted:
        M = invert(h.T_part_hole) @ T_part_world @ B  # held part -> hole frame, at the end
        q = pts @ M[:3, :3].T + M[:3, 3]
        d = (invert(h.T_part_hole) @ T_part_world)[:3, :3] @ (A[:3, 3] - B[:3, 3])
        if _segments_enter(q, d, h.radius_m, -h.depth_m + END_TOLERANCE_M, -END_TOLERANCE_M):
            crossed.add(h.feature)
    return frozenset(crossed)
