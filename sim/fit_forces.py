"""The exact fit contact's forces of a solved step (:mod:`asmplan.sim.feature_contact`): its
contact points with their forces, and the reaction on each partner. Made when asked for (a
record row, a dynamic partner's next step), not every step."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .contacts import Contacts
from .fit_geometry import FitContact


@dataclass(frozen=True)
class SolvedStep:
    """What one step's solve leaves: the contacts (``found``, each point's pair ``owner``),
    normal impulses ``lam_n`` (k,), tangent impulses ``p_t`` (k, 2) along ``t1``, ``t2``
    (k, 3 each), the step ``dt_s``."""

    found: FitContact
    owner: np.ndarray
    lam_n: np.ndarray
    p_t: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    dt_s: float


def solved_forces(s: SolvedStep, partner_of_pair: Sequence[int], partners: Sequence[int]
                  ) -> tuple[Contacts, list[tuple[int, np.ndarray, np.ndarray]]]:
    """The step's impulses as forces on the held body (its contacts) and the reaction on each
    partner of ``partners`` touched: (body, force N (3,), point m (3,), the normal forces'
    centre). ``partner_of_pair``: each pair's partner body."""
    found, dt = s.found, s.dt_s
    n = found.normal
    f_n = s.lam_n / dt
    f_t = (s.p_t[:, :1] * s.t1 + s.p_t[:, 1:] * s.t2) / dt
    partner_of = np.array([partner_of_pair[i] for i in s.owner], dtype=int)
    last = Contacts(
        body_b=partner_of,
        link_a=np.full(found.count, -1, dtype=int),
        link_b=np.full(found.count, -1, dtype=int),
        position_on_a_m=found.point_m.copy(),
        position_on_b_m=found.point_m.copy(),
        normal_on_b=n.copy(),
        distance_m=found.gap_m.copy(),
        normal_force_N=f_n,
        friction_on_a_N=f_t,
    )
    reaction = []
    for b in partners:
        sel = (partner_of == b) & (f_n > 0)
        if np.any(sel):
            total = np.sum(f_n[sel, None] * n[sel] + f_t[sel], axis=0)
            weights = f_n[sel] / float(np.sum(f_n[sel]))
            point = np.sum(weights[:, None] * found.point_m[sel], axis=0)
            reaction.append((b, -total, point))
    return last, reaction
