"""Mate partners held static while what acts on them cannot move them (issues 16/17, the
seed job's cost: "model only what a scene requires").

A dynamic mate partner (a part in place that the held part is inserted into or touches) rests
on its support through its own seat: part2's pins in part1's holes on pinhole_station carry
about 100 contact points. Bullet solves them in every step once the held part touches the
partner and wakes it (0.5 -> 3.4 ms per BALANCED step), although the partner moves by less
than 0.01 um. :class:`PartnerHold` makes such a partner static (mass 0,
:meth:`asmplan.sim.bullet.BulletWorld.hold_static`) after the step's first physics step, and
at every sampled step (every ``PEAK_SAMPLE_DT_S``) checks whether what the held part and the
robot put on it could move it; the first time it could, the partner gets its mass back, from
rest, and stays dynamic to the end of the step.

The check, for each group of partners touching each other (held and woken together), with
``up`` against gravity, the group's weight ``W`` at its centre of mass and the loads ``F_i``
at ``r_i`` from every body outside the group (Bullet's contact forces and the reaction of the
exact fit contact, :mod:`asmplan.sim.feature_contact`):

* Support: the points of the group's contacts with static bodies after the first step whose
  normal is within 10 deg of ``up`` (bearing points: the checks take the support as
  horizontal), and ``mu`` the smallest Coulomb
  coefficient of those pairs (Bullet's product of the two bodies' coefficients). A group with
  fewer than 3 bearing points spanning a polygon, or with its centre of mass outside that
  polygon, is not held (its reason is recorded).
* Sliding: the resultant ``L = W + sum F_i`` must press on the support (``N = -L . up > 0``)
  with a tangential part ``T`` such that ``T / (mu N) <= fraction``.
* Tipping: about every edge (a, e) of the bearing polygon, the overturning moment of the
  loads ``sum ((r_i - a) x F_i) . e`` must stay within ``fraction`` of the weight's
  restoring moment.

``fraction`` is ``Fidelity.hold_load_fraction`` (BALANCED 0.5). Both checks are conservative:
the support's friction alone is counted against sideways loads (pins in holes and shoulders
hold a partner too), and a twisting moment about ``up`` is not checked (it is resisted by
the same friction). Between two samples (4 ms at BALANCED) a load above the bound acts on the
static partner for at most 3 physics steps. What the held partner changes and its measured
cost: docs/physics.md, "Mate partners held static under a load check".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .bullet import BulletWorld
from .feature_contact import HeldFitContact

BEARING_COS = math.cos(math.radians(10.0))
"""A support contact bears the partner when its normal is within 10 deg of ``up``: the
checks take the support as horizontal (a part on a slope or in a V cradle has no such
polygon and is not held)."""

MIN_SUPPORT_AREA_M2 = 1e-8
"""A bearing polygon smaller than this (0.1 mm x 0.1 mm) is a point or a line: not held."""


STATIC_NEAR_M = 1e-3
"""Static bodies whose bounding boxes come this close to a held partner's have their contact
with it switched off while it is held (static against static: nothing to solve)."""


def _hull_2d(p: np.ndarray) -> np.ndarray:
    """Indices of the convex hull of 2-D points (n, 2), counter-clockwise (monotone chain)."""
    order = np.lexsort((p[:, 1], p[:, 0]))

    def half(idx: np.ndarray) -> list[int]:
        out: list[int] = []
        for k in idx:
            while len(out) >= 2:
                a, b = p[out[-2]], p[out[-1]]
                if (b[0] - a[0]) * (p[k][1] - a[1]) - (b[1] - a[1]) * (p[k][0] - a[0]) > 0:
                    break
                out.pop()
            out.append(int(k))
        return out

    lower, upper = half(order), half(order[::-1])
    return np.array(lower[:-1] + upper[:-1], dtype=int)


def bearing_polygon(p3: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, float]:
    """The convex hull of bearing points ``p3`` (n, 3) seen along ``up`` and its area (m^2):
    (indices into ``p3``, counter-clockwise; area)."""
    e1 = np.cross(up, [1.0, 0.0, 0.0])
    if float(np.linalg.norm(e1)) < 0.5:
        e1 = np.cross(up, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    p2 = np.stack([p3 @ e1, p3 @ e2], axis=1)
    hull = _hull_2d(p2)
    q = p2[hull]
    area = 0.5 * float(np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1]))
    return hull, area


@dataclass
class _Group:
    """Partners touching each other, held and woken together."""

    bodies: tuple[int, ...]
    names: tuple[str, ...]
    mass_kg: float
    com_m: np.ndarray
    mu: float = math.nan
    edge_point_m: np.ndarray | None = None  # (k, 3) a point on each bearing polygon edge
    edge_dir: np.ndarray | None = None  # (k, 3) unit edge directions (counter-clockwise)
    held: bool = False
    reason: str = ""
    held_from_s: float = math.nan
    woke_s: float | None = None
    checks: int = 0
    max_slide: float = 0.0
    max_tip: float = -math.inf
    max_load_N: float = 0.0
    statics: dict[int, list[int]] = field(default_factory=dict)  # static bodies near each

    def summary(self) -> dict[str, Any]:
        return {"bodies": list(self.names), "held": self.held or self.woke_s is not None,
                "reason": self.reason, "held_from_s": _json(self.held_from_s),
                "woke_s": self.woke_s, "checks": self.checks,
                "max_slide_ratio": _json(self.max_slide), "max_tip_ratio": _json(self.max_tip),
                "max_load_N": float(self.max_load_N),
                "support_friction": _json(self.mu)}


def _json(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


class PartnerHold:
    """Holds a step's dynamic partners static while the load check allows (module docstring).

    Parameters
    ----------
    world : BulletWorld
    gripper_body, held_body : int
        The gripper and the part it moves: never held; their contacts are the loads.
    fit_contact : HeldFitContact, optional
        The exact fit contact, whose reaction on a partner is a load too.
    fraction : float
        Share of the support's friction and of the restoring moment the loads may use.
    """

    def __init__(self, world: BulletWorld, gripper_body: int, held_body: int,
                 fit_contact: HeldFitContact | None = None, fraction: float = 0.5) -> None:
        if not 0.0 < fraction <= 1.0:
            raise ValueError(f"PartnerHold: fraction expected in (0, 1], found {fraction}")
        self._world = world
        self._movers = {gripper_body, held_body}
        self._fit = fit_contact
        self._fraction = float(fraction)
        self._candidates = [b for b in world.dynamic_bodies() if b not in self._movers]
        self._groups: list[_Group] = []
        self._started = False
        g = np.asarray(world.gravity_mps2, dtype=float)
        self._g = g
        self._up = -g / float(np.linalg.norm(g))

    # ------------------------------------------------------------------ set-up
    def _make_groups(self) -> None:
        w = self._world
        parent = {b: b for b in self._candidates}

        def root(b: int) -> int:
            while parent[b] != b:
                b = parent[b]
            return b

        self._contacts = {b: w.contacts(b) for b in self._candidates}
        for b, con in self._contacts.items():
            for o in set(con.body_b.tolist()) & set(self._candidates):
                parent[root(int(o))] = root(b)
        members: dict[int, list[int]] = {}
        for b in self._candidates:
            members.setdefault(root(b), []).append(b)
        for bodies in members.values():
            masses = np.array([w.body_mass_kg(b) for b in bodies])
            coms = np.array([w.com_position_m(b) for b in bodies])
            self._groups.append(_Group(
                bodies=tuple(bodies), names=tuple(w.body_name(b) for b in bodies),
                mass_kg=float(masses.sum()),
                com_m=(masses[:, None] * coms).sum(axis=0) / float(masses.sum())))

    def _support(self, grp: _Group) -> str:
        """Fill the group's bearing polygon and friction; returns why it is not held ('')."""
        w, up = self._world, self._up
        pts, mus = [], []
        for b in grp.bodies:
            con = self._contacts[b]
            for k in range(con.count):
                o = int(con.body_b[k])
                if o in grp.bodies:
                    continue
                if o in self._movers:
                    return f"touches {w.body_name(o)} at the start"
                if not w.is_static(o):
                    return f"rests on {w.body_name(o)}, which moves"
                if float(con.normal_on_b[k] @ up) >= BEARING_COS:
                    pts.append(con.position_on_b_m[k])
                    mus.append(w.lateral_friction(b) * w.lateral_friction(o))
        if len(pts) < 3:
            return f"{len(pts)} bearing contact points (needs a polygon)"
        p3 = np.array(pts)
        hull, area = bearing_polygon(p3, up)
        if len(hull) < 3 or area < MIN_SUPPORT_AREA_M2:
            return f"bearing polygon of {area * 1e6:.3f} mm^2 (a point or a line)"
        a = p3[hull]
        d = np.roll(a, -1, axis=0) - a
        d -= (d @ up)[:, None] * up
        d /= np.linalg.norm(d, axis=1)[:, None]
        grp.edge_point_m, grp.edge_dir, grp.mu = a, d, float(min(mus))
        if not np.all(self._restoring(grp) > 0.0):
            return "centre of mass outside its bearing polygon"
        return ""

    def _restoring(self, grp: _Group) -> np.ndarray:
        """The weight's restoring moment about each bearing edge (N m, > 0 when stable)."""
        assert grp.edge_point_m is not None and grp.edge_dir is not None
        W = grp.mass_kg * self._g
        tau = np.cross(grp.com_m - grp.edge_point_m, W)
        return -np.einsum("ij,ij->i", tau, grp.edge_dir)

    def start(self, t_s: float) -> None:
        """After the step's first physics step (every partner on its support): group the
        partners, find their supports and hold those the rules allow."""
        self._started = True
        self._make_groups()
        for grp in self._groups:
            grp.reason = self._support(grp)
            if grp.reason:
                continue
            self._hold(grp, True)
            grp.held, grp.held_from_s = True, t_s
            grp.reason = "held static"
        self._contacts = {}

    def _hold(self, grp: _Group, static: bool) -> None:
        """Hold a group static or give it back its mass. Held, its contacts with the static
        bodies around it are switched off too: Bullet keeps finding (and solving) the
        contact points of a body made massless with the static bodies it rests on (part2
        in part1 on pinhole_station: 57 points in every step, stepSimulation 1.2 -> 3.0 s)."""
        w = self._world
        if static:
            grp.statics = {b: sorted(o for o in w.bodies_near(b, STATIC_NEAR_M)
                                     if o not in grp.bodies and w.is_static(o))
                           for b in grp.bodies}
        for b in grp.bodies:
            w.hold_static(b, static)
            for o in grp.statics.get(b, ()):
                w.set_collision_enabled(b, o, not static)

    # ------------------------------------------------------------------ per sample
    def _loads(self, grp: _Group) -> tuple[np.ndarray, np.ndarray]:
        """Total force (3,) and torque about the origin (3,) on the group from outside."""
        F, tau = np.zeros(3), np.zeros(3)
        for b in grp.bodies:
            con = self._world.contacts(b)
            if con.count:
                # static against static carries nothing (Bullet solves no force there)
                sel = np.array([not self._world.is_static(int(o)) for o in con.body_b])
                f = con.normal_force_N[sel, None] * con.normal_on_b[sel] + con.friction_on_a_N[sel]
                F += f.sum(axis=0)
                tau += np.cross(con.position_on_a_m[sel], f).sum(axis=0)
            if self._fit is not None:
                for f_b, r_b in self._fit.reaction_on(b):
                    F += f_b
                    tau += np.cross(r_b, f_b)
        return F, tau

    def check(self, t_s: float) -> None:
        """Check every held group's loads; wake those that exceed the bounds."""
        if not self._started:
            self.start(t_s)
            return
        up, frac = self._up, self._fraction
        for grp in self._groups:
            if not grp.held:
                continue
            F, tau = self._loads(grp)
            grp.checks += 1
            if not (np.any(F) or np.any(tau)):  # nothing on it but its weight: ratios 0
                grp.max_slide, grp.max_tip = max(grp.max_slide, 0.0), max(grp.max_tip, 0.0)
                continue
            L = F + grp.mass_kg * self._g
            N = -float(L @ up)
            T = float(np.linalg.norm(L + N * up))
            slide = T / (grp.mu * N) if N > 0.0 else math.inf
            assert grp.edge_point_m is not None and grp.edge_dir is not None
            over = np.einsum("ij,ij->i", tau - np.cross(grp.edge_point_m, F), grp.edge_dir)
            tip = float(np.max(over / self._restoring(grp)))
            grp.max_slide = max(grp.max_slide, slide)
            grp.max_tip = max(grp.max_tip, tip)
            grp.max_load_N = max(grp.max_load_N, float(np.linalg.norm(F)))
            if slide > frac or tip > frac:
                self._hold(grp, False)
                grp.held, grp.woke_s = False, t_s
                what = (f"sliding {slide:.2f}" if slide > frac else f"tipping {tip:.2f}")
                grp.reason = (f"woken at {t_s:.3f} s: {what} of the support's capacity "
                              f"> {frac:.2f}")

    def summary(self) -> list[dict[str, Any]]:
        """Per group: bodies, held or why not, when it woke and why, the largest ratios."""
        return [g.summary() for g in self._groups]
