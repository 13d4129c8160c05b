"""The sampled edge circles of the exact fit contact, evaluated only where they can matter
(issues 16 and 17: the cost of :mod:`asmplan.sim.fit_geometry`).

Why
---
:meth:`FitContactModel.contacts` samples each edge circle at 96 angles and measures every
sample's signed distance to the other solid's meridian profile: one (samples x segments)
evaluation per call, 60-70 % of the fit contact's CPU on the seed workstation, although most
samples lie millimetres from the other solid (a pin's tip circle 0.5 mm inside the wall of its
bore, the mouth circle 0.5 mm outside the pin, a shoulder 8 mm above the face).

What
----
Each solid's material lies inside a simple superset in its meridian half-plane (the block's
below its face, inside its outer radius, outside the bore's radius or below a blind bore's
floor; the pin's beyond its tip and inside its radius), whose distance is a lower bound of the
sample's signed distance at the cost of a few comparisons (:class:`MaterialBound`). Only a sample
whose bound is below the search margin (plus the flat tolerance and a 1 nm band) and its two
neighbours on the circle are evaluated; every other sample gets +inf. This changes no result,
bit for bit: the candidates of :func:`asmplan.sim.fit_geometry._candidates` are samples below
the margin (evaluated, with their neighbours, which the parabola reads), a circle's least
sample and the samples within the flat tolerance of it are evaluated whenever the least is
below the margin (otherwise that circle gives nothing either way), and a skipped sample's
distance to its second-nearest segment is no less than to its nearest, so the single-feature
test is unchanged. The evaluation is the same arithmetic per sample
(:meth:`asmplan.sim.fit_geometry.Profile.distances`), so its values are bitwise those of the
whole circle's.

The samples of one pose pair are kept (:class:`SampledCircles`): the fit contact measures the
pose Bullet's step reached with the least margin and, the next step, the same pose again with
that step's margin; the second call evaluates only samples the first left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SKIP_BAND_M = 1e-9
"""Slack between a sample's lower bound and the threshold above which it is not evaluated, m
(the evaluated distances are exact to ~1e-15 m on profiles of 1 m extent)."""


@dataclass(frozen=True)
class MaterialBound:
    """A superset of a solid of revolution's meridian region (rho from the axis, z along it):
    ``z_min <= z <= z_max``, ``rho <= rho_max`` and (``rho >= rho_hole`` or ``z <= z_floor``).
    Its distance, the largest of the distances to each condition's half-plane (each a lower
    bound wherever it is positive), bounds a point's distance to the solid from below, m.
    """

    z_min: float
    z_max: float
    rho_max: float
    rho_hole: float = -np.inf
    z_floor: float = -np.inf

    def lower(self, rho: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Lower bound (n,) of the signed distance of meridian points (rho (n,), z (n,)) to the
        solid, m: where it is positive the point is outside and at least that far."""
        hole = np.minimum(self.rho_hole - rho, z - self.z_floor)
        return np.maximum(np.maximum(z - self.z_max, self.z_min - z),
                          np.maximum(rho - self.rho_max, hole))


    def lower_box(self, rho_lo: np.ndarray, rho_hi: np.ndarray, z_lo: np.ndarray,
                  z_hi: np.ndarray) -> np.ndarray:
        """Lower bound of :meth:`lower` over meridian boxes (each (k,): rho in
        [rho_lo, rho_hi], z in [z_lo, z_hi]), m: each condition's distance at its nearest
        corner of the box."""
        hole = np.minimum(self.rho_hole - rho_hi, z_lo - self.z_floor)
        return np.maximum(np.maximum(z_lo - self.z_max, self.z_min - z_hi),
                          np.maximum(rho_lo - self.rho_max, hole))


def circle_extents(R_world_own: np.ndarray, origin_own: np.ndarray, heights_m: np.ndarray,
                   radii_m: np.ndarray, R_world_other: np.ndarray, origin_other: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where whole edge circles lie in the other solid's meridian half-plane.

    The circles (C,) are coaxial with the own frame's z (``heights_m`` along it, radii
    ``radii_m``); a point of one is c + r w, w a unit vector normal to that axis, so in the
    other frame (axis z) its height is within r |w_z| <= r lean of the centre's, and its
    distance from the other axis within [r sqrt(1 - lean^2) - e, e + r] (e: the centre's
    distance from that axis, lean: the sine of the angle between the axes).

    Returns
    -------
    rho_lo, rho_hi, z_lo, z_hi, ecc : (C,) float
        Bounds of the circles' points' (rho, z) and each centre's distance e, m.
    """
    zo = R_world_other[:, 2]
    rel = origin_own + heights_m[:, None] * R_world_own[:, 2] - origin_other
    z_c = rel @ zo
    ecc = np.linalg.norm(rel - z_c[:, None] * zo, axis=1)
    lean = min(1.0, math.hypot(float(R_world_own[:, 0] @ zo), float(R_world_own[:, 1] @ zo)))
    return (radii_m * math.sqrt(1.0 - lean * lean) - ecc, ecc + radii_m,
            z_c - radii_m * lean, z_c + radii_m * lean, ecc)


class SampledCircles:
    """Signed distances of one family of sampled edge circles to the other solid.

    Parameters
    ----------
    local_m : (C * N, 3) float
        The samples in the other solid's frame (axis z), circle by circle, m.
    circles : int
        C, the number of circles (N samples each, in angular order).
    profile : Profile
        The other solid's meridian profile (:class:`asmplan.sim.fit_geometry.Profile`).
    bound : MaterialBound or None
        A superset of that solid; None evaluates every sample.
    """

    def __init__(self, local_m: np.ndarray, circles: int, profile, bound: MaterialBound | None
                 ) -> None:
        self._shape = (circles, local_m.shape[0] // circles)
        self._rho = np.hypot(local_m[:, 0], local_m[:, 1])
        self._z = local_m[:, 2]
        self._profile = profile
        self._lower = None if bound is None else bound.lower(self._rho, self._z)
        n = local_m.shape[0]
        self._value = np.full(n, np.inf)
        self._segment = np.zeros(n, dtype=np.intp)
        self._second = np.full(n, np.inf)
        self._done = np.zeros(n, dtype=bool)

    def at(self, margin_m: float, flat_tolerance_m: float
           ) -> tuple[np.ndarray, np.ndarray, float]:
        """Distances (C, N) of every sample that can be a contact candidate within
        ``margin_m`` (and of their neighbours), +inf elsewhere; each sample's nearest profile
        segment (C, N; meaningful where evaluated); and the least distance of any sample to
        its second-nearest segment (+inf when none was evaluated), m."""
        if self._lower is None:
            todo = ~self._done
        else:
            near = (self._lower < margin_m + flat_tolerance_m + SKIP_BAND_M).reshape(self._shape)
            need = near.copy()
            need[:, 1:] |= near[:, :-1]
            need[:, 0] |= near[:, -1]
            need[:, :-1] |= near[:, 1:]
            need[:, -1] |= near[:, 0]
            todo = need.ravel() & ~self._done
        if np.any(todo):
            idx = np.flatnonzero(todo)
            d, j, second = self._profile.distances(np.column_stack([self._rho[idx],
                                                                    self._z[idx]]))
            self._value[idx] = d
            self._segment[idx] = j
            self._second[idx] = second
            self._done[idx] = True
        return (self._value.reshape(self._shape), self._segment.reshape(self._shape),
                float(np.min(self._second)))
