"""Bullet's contact breaking distance, computed without pybullet: a collider's bounding
radius ("angular motion disc"), the breaking distance of a pair and the world's breaking
fraction per fidelity preset.

Contact breaking distance
-------------------------
Bullet keeps a contact point of a pair in a persistent manifold, with the normal it had when
it was found, until the point separates along that normal or slides sideways by more than
the pair's breaking distance; it also creates points up to that distance before the bodies
touch. The distance is the world's breaking fraction (PyBullet's ``contactBreakingThreshold``,
0.02 by default) times the smaller of the two colliders' bounding radii (Bullet's "angular
motion disc": half the diagonal of the collider's bounding box in its inertial frame plus
the box centre's distance from the centre of mass): 0.36 mm for a 20 mm collar. A point born
between two chamfers therefore survives while a part slides on through a gap narrower than
that, pushing along its stale normal (a phantom contact).
:meth:`asmplan.sim.bullet.BulletWorld.limit_contact_breaking_m` lowers the fraction for one world so that no
contact of a given body is kept farther than a given distance (:func:`bounding_radius_m`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..parts.pieces import ConvexPiece
from .fidelity import Fidelity

PYBULLET_CONTACT_BREAKING_FRACTION = 0.02
"""PyBullet's default ``contactBreakingThreshold`` (Bullet's ``gContactBreakingThreshold``): a
fraction of each collider's bounding radius, see the module docstring."""

HULL_BOX_GROWTH_UNITS = 2e-3
"""Bullet's bounding box of a hull collider (the OBJ compound) is the hulls' box grown by this
much along every axis: PyBullet's default margin of 0.001 units, counted at creation by the hulls and by
their compound, before :meth:`asmplan.sim.bullet.BulletWorld.add_body` sets the margin to the
fidelity's value.
Measured: with it the probed breaking distances of five gear_unit parts match to 1e-4
relative; without it they are 6-22 % larger than predicted. ``tests/sim/test_bullet.py``
re-checks it."""


BREAKING_RADIUS_CAP_UNITS = 2.0
"""Measured: the breaking distance stops growing with the bounding radius at 2 Bullet units
(2 mm here); from there it is ``fraction x 2 units`` plus :data:`BREAKING_CAP_EXTRA_M` (the
two colliders' creation margins), 42 um at PyBullet's default fraction, for any larger body
(``tests/sim/test_bullet.py``). In metres the cap (2 m) was never reached."""

BREAKING_CAP_EXTRA_UNITS = 2e-3


def default_breaking_fraction(fidelity: Fidelity) -> float:
    """The world's breaking fraction: PyBullet's default (0.02) in metres; in millimetres the
    fraction that makes the capped distance the preset's contact distance
    (``Fidelity.contact_distance_m``, half its ``interference_resolution_m``: 25 um at
    BALANCED, 10 um at ACCURATE, less PyBullet's 2 um of creation margins). PyBullet's 0.02
    gives 42 um. A part approaching at v finds a contact before it penetrates when
    v dt is below it (the rim of an unchamfered hole: ``Fidelity.min_resolvable_clearance_m``)."""
    units = float(fidelity.bullet_units_per_m)
    if units == 1.0:
        return PYBULLET_CONTACT_BREAKING_FRACTION
    target_m = fidelity.contact_distance_m - BREAKING_CAP_EXTRA_UNITS / units
    cap_m = BREAKING_RADIUS_CAP_UNITS / units
    return min(PYBULLET_CONTACT_BREAKING_FRACTION, max(target_m, 0.25 * target_m) / cap_m)


def _breaking_distance_m(fraction: float, radius_m: float, units_per_m: float) -> float:
    """Bullet's contact creation/breaking distance of a pair, m, for the smaller radius."""
    cap = BREAKING_RADIUS_CAP_UNITS / units_per_m
    if radius_m >= cap:
        return fraction * cap + BREAKING_CAP_EXTRA_UNITS / units_per_m
    return fraction * radius_m


def _piece_box(piece: ConvexPiece) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) (3,) of the box Bullet bounds ``piece`` by, body frame, m: the hull's exact box,
    a sphere's, or the box of the rotated local box of a box or cylinder."""
    T = piece.T_part_piece
    if piece.kind == "hull":
        assert piece.vertices_m is not None
        pts = piece.vertices_m @ T[:3, :3].T + T[:3, 3]
        return pts.min(axis=0), pts.max(axis=0)
    if piece.kind == "sphere":
        return T[:3, 3] - piece.radius_m, T[:3, 3] + piece.radius_m
    if piece.kind == "box":
        assert piece.half_extents_m is not None
        half = np.asarray(piece.half_extents_m, dtype=float)
    else:
        half = np.array([piece.radius_m, piece.radius_m, 0.5 * piece.length_m])
    reach = np.abs(T[:3, :3]) @ half
    return T[:3, 3] - reach, T[:3, 3] + reach


def bounding_radius_m(group: Sequence[ConvexPiece], com_m: ArrayLike,
                      R_link_inertial: np.ndarray, units_per_m: float = 1.0) -> float:
    """Bullet's bounding radius ("angular motion disc") of one collider, m.

    Parameters
    ----------
    group : sequence of ConvexPiece
        The pieces of one collision shape (all hulls, or up to 16 primitives), link frame.
    com_m : (3,) float
        The link's centre of mass (its inertial frame's origin), link frame, m.
    R_link_inertial : (3, 3) float array
        Axes of the inertial frame in the link frame.

    Returns
    -------
    float
        Half the diagonal of the collider's box taken into the inertial frame (the box of the
        rotated box, as Bullet bounds a compound's child) plus the distance of its centre from
        the centre of mass. A pair's breaking distance is the world's breaking fraction times
        the smaller of its two colliders' radii.
    """
    boxes = [_piece_box(pc) for pc in group]
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    half = 0.5 * (hi - lo)
    if any(pc.kind == "hull" for pc in group):
        half = half + HULL_BOX_GROWTH_UNITS / units_per_m
    R = np.asarray(R_link_inertial, dtype=float)
    centre = R.T @ (0.5 * (hi + lo) - np.asarray(com_m, dtype=float))
    return float(np.linalg.norm(np.abs(R.T) @ half) + np.linalg.norm(centre))
