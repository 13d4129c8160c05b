"""Contact points of a body after a simulation step, as arrays (:class:`Contacts`), with the
force on body A they add up to (friction already signed as the force on A, see
:mod:`asmplan.sim.bullet`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Contacts:
    """Contact points between body A and others after the last step (arrays of length n).

    Attributes
    ----------
    body_b, link_a, link_b : (n,) int arrays
    position_on_a_m, position_on_b_m : (n, 3) float arrays, world frame, m.
    normal_on_b : (n, 3) unit vectors from B toward A (world frame).
    distance_m : (n,) signed distance, m; negative is penetration.
    normal_force_N : (n,) normal force magnitude, N (>= 0).
    friction_on_a_N : (n, 3) friction force vector acting on A, N.
    """

    body_b: np.ndarray
    link_a: np.ndarray
    link_b: np.ndarray
    position_on_a_m: np.ndarray
    position_on_b_m: np.ndarray
    normal_on_b: np.ndarray
    distance_m: np.ndarray
    normal_force_N: np.ndarray
    friction_on_a_N: np.ndarray

    @property
    def count(self) -> int:
        """Number of contact points."""
        return int(self.distance_m.shape[0])

    def force_on_a_N(self) -> np.ndarray:
        """Total contact force (normal + friction) acting on A, world frame, (3,) N."""
        if self.count == 0:
            return np.zeros(3)
        normal = self.normal_force_N[:, None] * self.normal_on_b
        return np.sum(normal + self.friction_on_a_N, axis=0)

    def normal_force_sum_N(self) -> float:
        """Sum of the normal force magnitudes, N."""
        return float(np.sum(self.normal_force_N))

    def max_penetration_m(self) -> float:
        """Deepest penetration among the points, m (0 when none penetrates)."""
        if self.count == 0:
            return 0.0
        return float(max(0.0, -np.min(self.distance_m)))

    def select(self, mask: np.ndarray) -> Contacts:
        """Subset of the points where ``mask`` (n,) is true."""
        return Contacts(*(getattr(self, f)[mask] for f in _CONTACT_FIELDS))


def concat_contacts(a: Contacts, b: Contacts) -> Contacts:
    """The points of ``a`` followed by those of ``b`` (same body A), e.g. Bullet's and the
    exact fit model's (:mod:`asmplan.sim.feature_contact`)."""
    if b.count == 0:
        return a
    if a.count == 0:
        return b
    return Contacts(*(np.concatenate([getattr(a, f), getattr(b, f)]) for f in _CONTACT_FIELDS))


_CONTACT_FIELDS = (
    "body_b",
    "link_a",
    "link_b",
    "position_on_a_m",
    "position_on_b_m",
    "normal_on_b",
    "distance_m",
    "normal_force_N",
    "friction_on_a_N",
)
