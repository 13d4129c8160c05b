"""Collision models of the cell: the table, the declared regrasp fixtures and the gripper (palm
and two fingers), shared by the planner, the simulator and the report.
"""

from __future__ import annotations

import numpy as np

from ..knowledge.model import Gripper, RegraspFixture, Table
from .pieces import CollisionModel, ConvexPiece

HALF_TURN = np.diag([-1.0, -1.0, 1.0, 1.0])
"""Half a turn about the gripper's TCP z (approach) axis. :func:`gripper_model` is symmetric
under it (the two fingers swap), so ``T_world_tcp @ HALF_TURN`` holds a part the same way."""


def gripper_model(gripper: Gripper, inner_half_m: float, outer_half_m: float | None = None
                  ) -> CollisionModel:
    """Palm and two finger boxes in the gripper TCP frame.

    Each finger is a box ``finger_size_m`` (x width, y thickness, z length) whose inner face
    lies at ``|y| = inner_half_m`` and whose length is centred on the TCP (the pad's contact
    face centre is the TCP, see :mod:`asmplan.planner.trajectory`); ``outer_half_m`` (default
    ``inner_half_m + thickness``) widens the fingers to cover the space they sweep while
    closing. The palm box (``palm_size_m``) sits right behind the fingers' roots
    (``z < -length / 2``).
    """
    W, t, L = (float(v) for v in gripper.finger_size_m)
    outer = inner_half_m + t if outer_half_m is None else float(outer_half_m)
    th = outer - inner_half_m
    px, py, pz = (float(v) for v in gripper.palm_size_m)
    pieces = []
    for sign, name in ((1.0, "finger1"), (-1.0, "finger2")):
        T = np.eye(4)
        T[1, 3] = sign * (inner_half_m + th / 2)
        pieces.append(ConvexPiece("box", T, half_extents_m=np.array([W / 2, th / 2, L / 2]),
                                  name=name))
    T = np.eye(4)
    T[2, 3] = -L / 2 - pz / 2
    pieces.append(ConvexPiece("box", T, half_extents_m=np.array([px / 2, py / 2, pz / 2]),
                              name="palm"))
    return CollisionModel("exact", tuple(pieces))


def table_model(table: Table) -> CollisionModel:
    """The table as one box whose top face is the world plane z = 0, centred on the origin."""
    size = np.asarray(table.size_m, dtype=float)
    T = np.eye(4)
    T[2, 3] = -size[2] / 2
    return CollisionModel("exact", (ConvexPiece("box", T, half_extents_m=size / 2,
                                                name="table"),))


def regrasp_fixture_body(name: str) -> str:
    """The body name of a declared regrasp fixture in the planner's and the simulator's
    worlds (and in their messages): ``"fixture:<name>"``."""
    return f"fixture:{name}"


def regrasp_fixture_model(fixture: RegraspFixture) -> CollisionModel:
    """A declared regrasp fixture's solid as exact pieces (boxes, cylinders, spheres) in the
    fixture frame (place it at ``fixture.T_world_fixture``)."""
    pieces = []
    for k, p in enumerate(fixture.primitives):
        T = np.asarray(p.T_part_shape, float)
        name = f"{fixture.name}/{k}"
        if p.shape == "box":
            pieces.append(ConvexPiece("box", T, half_extents_m=np.asarray(p.size_m, float) / 2,
                                      name=name))
        elif p.shape == "cylinder":
            pieces.append(ConvexPiece("cylinder", T, radius_m=p.diameter_m / 2,
                                      length_m=p.length_m, name=name))
        else:
            pieces.append(ConvexPiece("sphere", T, radius_m=p.diameter_m / 2, name=name))
    return CollisionModel("exact", tuple(pieces))
