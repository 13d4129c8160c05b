"""PyBullet world: the ONLY module of asmplan that imports pybullet.

:class:`BulletWorld` is a context manager that owns one DIRECT physics client and passes its
id explicitly on every call (no global client). It is configured from a
:class:`~asmplan.sim.fidelity.Fidelity` and builds bodies from the
:class:`~asmplan.parts.pieces.ConvexPiece` tuples that FCL also uses.

Body layout
-----------
A part is one multibody. All its hull pieces form the BASE collision shape: a compound of
convex hulls loaded from a temporary Wavefront OBJ with one object per hull (no 16-child
limit there), whose margin is set to ``fidelity.collision_margin_m`` (0 keeps hulls exact;
PyBullet's default 1 mm inflates them and closes sub-millimetre holes). Two traps avoided
here: ``createCollisionShapeArray`` takes no hulls, and ``changeDynamics(collisionMargin=...)``
only reaches BASE colliders (a hull on a link, or wrapped in a one-child compound by a
collision-frame offset, keeps 1 mm). Primitives (box, cylinder, sphere; margins inside the
shape, exact) are grouped up to 16 per compound (PyBullet silently drops the 17th child) on
the base, or on links joined to the base by FIXED joints when hulls occupy the base or there
are more than 16. Every shape's child count is checked after creation, so nothing is dropped
silently. Mass and inertia are split evenly over the links, every link's inertial frame at the
part's centre of mass and aligned with its principal axes, so the rigid assembly has exactly
the requested mass, centre of mass and inertia tensor. Static bodies (mass 0) have a fixed
base and never move.

Poses returned by this module are link frames (the part frame for parts), not PyBullet's
centre-of-mass frames.

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
:meth:`BulletWorld.limit_contact_breaking_m` lowers the fraction for one world so that no
contact of a given body is kept farther than a given distance (:func:`bounding_radius_m`).

Contact forces
--------------
:meth:`BulletWorld.contacts` returns the points as arrays; ``normal_on_b`` points from B to A,
so ``normal_force_N * normal_on_b`` is the normal force ON A. PyBullet reports the friction
vectors of a contact as the force on its internal manifold's body 0, whatever order the query
used. Measured rule: if exactly one of the two colliders is a compound shape it is body 0,
otherwise the collider created first is. :class:`Contacts` stores friction already signed as
the force on A (validated in ``tests/sim/test_bullet.py`` against static equilibrium on a
slope for every kind of collider this module builds, in both creation orders).
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from types import TracebackType
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from ..errors import AsmplanError
from ..knowledge.frames import invert
from ..parts.pieces import ConvexPiece
from ..planner.trajectory import matrix_from_quat_xyzw, quat_xyzw_from_matrix
from .fidelity import Fidelity


def _import_pybullet_quietly():
    """Import pybullet with file descriptor 2 pointed at /dev/null: it prints its build time
    to stderr from C at import, which is noise among the warnings a user must read."""
    import sys

    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no real stderr: import as is
        import pybullet as module

        return module
    try:
        with open(os.devnull, "wb") as devnull:
            os.dup2(devnull.fileno(), 2)
            import pybullet as module
    finally:
        os.dup2(saved, 2)
        os.close(saved)
    return module


pybullet = _import_pybullet_quietly()

MAX_COMPOUND_CHILDREN = 16
"""PyBullet drops compound children beyond this count silently."""

JointKind = Literal["fixed", "prismatic", "revolute"]
_JOINT_TYPES = {
    "fixed": pybullet.JOINT_FIXED,
    "prismatic": pybullet.JOINT_PRISMATIC,
    "revolute": pybullet.JOINT_REVOLUTE,
}


class BulletError(AsmplanError, RuntimeError):
    """PyBullet refused a request; carries what was asked."""


class ShapeDroppedError(BulletError):
    """PyBullet kept fewer child shapes than requested for a link."""

    def __init__(self, body_name: str, link: int, expected: int, found: int) -> None:
        super().__init__(
            f"body {body_name!r} link {link}: expected {expected} collision shapes, "
            f"found {found} (PyBullet dropped some)"
        )
        self.body_name = body_name
        self.link = link
        self.expected = expected
        self.found = found


# --------------------------------------------------------------------------------------------
# Small frame helpers
# --------------------------------------------------------------------------------------------
def pose_to_pq(T: np.ndarray) -> tuple[list[float], list[float]]:
    """(4, 4) homogeneous transform -> (position list (3,), quaternion xyzw list (4,))."""
    T = np.asarray(T, dtype=float)
    return T[:3, 3].tolist(), quat_xyzw_from_matrix(T[:3, :3]).tolist()


def pq_to_pose(position: Sequence[float], quat_xyzw: Sequence[float]) -> np.ndarray:
    """(position (3,), quaternion xyzw (4,)) -> (4, 4) homogeneous transform."""
    T = np.eye(4)
    T[:3, :3] = matrix_from_quat_xyzw(np.asarray(quat_xyzw, dtype=float))
    T[:3, 3] = position
    return T


def _pose_from_bullet(position: Sequence[float], quat_xyzw: Sequence[float]) -> np.ndarray:
    """:func:`pq_to_pose` for PyBullet's own unit quaternions (its C conversion, ~10x faster
    in the per-step loop)."""
    T = np.eye(4)
    T[:3, :3] = np.reshape(pybullet.getMatrixFromQuaternion(quat_xyzw), (3, 3))
    T[:3, 3] = position
    return T


def principal_frame(inertia_kgm2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (3,) and a proper rotation (3, 3) whose columns are the axes."""
    inertia = np.asarray(inertia_kgm2, dtype=float)
    sym = 0.5 * (inertia + inertia.T)
    moments, axes = np.linalg.eigh(sym)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes


_OBJ_CACHE: dict[bytes, str] = {}
_OBJ_CACHE_MAX = 512


def _hulls_obj_text(hulls: Sequence[ConvexPiece]) -> str:
    """Wavefront OBJ text with one object per hull (vertices in the body frame), cached by
    content: a part is built in several steps' worlds, its hulls are computed once."""
    import hashlib

    h = hashlib.blake2b(digest_size=20)
    for pc in hulls:
        assert pc.vertices_m is not None
        h.update(np.ascontiguousarray(pc.vertices_m, dtype=float).tobytes())
        h.update(np.ascontiguousarray(pc.T_part_piece, dtype=float).tobytes())
        h.update(b"|")
    key = h.digest()
    text = _OBJ_CACHE.get(key)
    if text is not None:
        return text
    from ..parts.mesh import convex_hull

    lines = []
    offset = 1
    for k, pc in enumerate(hulls):
        assert pc.vertices_m is not None
        R, t = pc.T_part_piece[:3, :3], pc.T_part_piece[:3, 3]
        hull = convex_hull(pc.vertices_m @ R.T + t)
        lines.append(f"o hull{k}")
        lines.extend(f"v {x!r} {y!r} {z!r}" for x, y, z in hull.vertices.tolist())
        lines.extend(
            f"f {i + offset} {j + offset} {m + offset}" for i, j, m in hull.faces.tolist()
        )
        offset += len(hull.vertices)
    text = "\n".join(lines) + "\n"
    if len(_OBJ_CACHE) >= _OBJ_CACHE_MAX:
        _OBJ_CACHE.clear()
    _OBJ_CACHE[key] = text
    return text


def _is_compound(group: Sequence[ConvexPiece]) -> bool:
    """Whether PyBullet builds a compound shape for this collision-shape group.

    Several hulls (OBJ objects) or several primitives make a compound; one primitive too when
    it has a collision-frame offset; one hull or one primitive at the identity do not.
    """
    if len(group) != 1:
        return True
    piece = group[0]
    return piece.kind != "hull" and not np.array_equal(piece.T_part_piece, np.eye(4))


PYBULLET_CONTACT_BREAKING_FRACTION = 0.02
"""PyBullet's default ``contactBreakingThreshold`` (Bullet's ``gContactBreakingThreshold``): a
fraction of each collider's bounding radius, see the module docstring."""

HULL_BOX_GROWTH_M = 2e-3
"""Bullet's bounding box of a hull collider (the OBJ compound) is the hulls' box grown by this
much along every axis: PyBullet's 1 mm default margin, counted at creation by the hulls and by
their compound, before :meth:`BulletWorld.add_body` sets the margin to the fidelity's value.
Measured: with it the probed breaking distances of five gear_unit parts match to 1e-4
relative; without it they are 6-22 % larger than predicted. ``tests/sim/test_bullet.py``
re-checks it."""


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
                      R_link_inertial: np.ndarray) -> float:
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
        half = half + HULL_BOX_GROWTH_M
    R = np.asarray(R_link_inertial, dtype=float)
    centre = R.T @ (0.5 * (hi + lo) - np.asarray(com_m, dtype=float))
    return float(np.linalg.norm(np.abs(R.T) @ half) + np.linalg.norm(centre))


# --------------------------------------------------------------------------------------------
# Contacts
# --------------------------------------------------------------------------------------------
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


# --------------------------------------------------------------------------------------------
# Link specification (articulated bodies such as the gripper)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class LinkSpec:
    """One link of an articulated body built by :meth:`BulletWorld.add_articulated`.

    Parameters
    ----------
    name : str
    pieces : tuple of ConvexPiece
        Collision pieces in the link frame: up to 16 primitives, or exactly one hull.
    mass_kg : float
    T_parent_link : (4, 4) float array
        Link frame in the parent's link frame at joint position 0.
    joint : {"fixed", "prismatic", "revolute"}
    axis : (3,) float
        Joint axis in the link frame (unit vector).
    com_m : (3,) float
        Centre of mass in the link frame, m.
    inertia_diag_kgm2 : (3,) float
        Principal inertia about the centre of mass, axes aligned with the link frame.
    parent : int
        Index of the parent link in the list passed to ``add_articulated``, -1 for the base.
    limits_m : (lower, upper) or None
        Joint limits (m or rad).
    friction : float
        Lateral friction coefficient of the link.
    spinning_friction : float
    joint_damping : float
        Viscous joint damping, N s/m (prismatic) or N m s/rad (revolute).
    """

    name: str
    pieces: tuple[ConvexPiece, ...]
    mass_kg: float
    T_parent_link: np.ndarray
    joint: JointKind = "fixed"
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    com_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia_diag_kgm2: tuple[float, float, float] | None = None
    parent: int = -1
    limits: tuple[float, float] | None = None
    friction: float = 0.5
    spinning_friction: float = 0.0
    joint_damping: float = 0.0

    def __post_init__(self) -> None:
        T = np.array(self.T_parent_link, dtype=float)
        if T.shape != (4, 4):
            raise ValueError(f"LinkSpec {self.name}: T_parent_link expected (4, 4), found {T.shape}")
        object.__setattr__(self, "T_parent_link", T)
        if self.joint not in _JOINT_TYPES:
            raise ValueError(
                f"LinkSpec {self.name}: joint expected one of {list(_JOINT_TYPES)}, "
                f"found {self.joint!r}"
            )
        if self.mass_kg < 0:
            raise ValueError(f"LinkSpec {self.name}: mass_kg expected >= 0, found {self.mass_kg}")


@dataclass
class _BodyInfo:
    name: str
    mass_kg: float
    static: bool
    T_link_inertial: np.ndarray  # base inertial frame in the base link frame
    n_links: int
    inertia_kgm2: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    compound_links: frozenset[int] = frozenset()
    bounding_radius_m: float = math.nan  # the largest of its colliders' (bounding_radius_m)

    def __post_init__(self) -> None:
        self.T_inertial_link = invert(self.T_link_inertial)


# --------------------------------------------------------------------------------------------
# World
# --------------------------------------------------------------------------------------------
class BulletWorld:
    """A headless PyBullet world configured from a :class:`Fidelity`.

    Use as a context manager; the DIRECT client is disconnected on exit.

    Parameters
    ----------
    fidelity : Fidelity
    gravity_mps2 : (3,) float
        Gravity vector in the world frame, m/s^2.
    """

    def __init__(
        self,
        fidelity: Fidelity,
        gravity_mps2: Sequence[float] = (0.0, 0.0, -9.81),
    ) -> None:
        self.fidelity = fidelity
        self.gravity_mps2 = np.asarray(gravity_mps2, dtype=float)
        if self.gravity_mps2.shape != (3,):
            raise ValueError(f"gravity_mps2: expected 3 numbers, found {self.gravity_mps2}")
        self._cid = pybullet.connect(pybullet.DIRECT)
        if self._cid < 0:
            raise BulletError("pybullet.connect(DIRECT) failed")
        self._bodies: dict[int, _BodyInfo] = {}
        self._steps = 0
        self._states: list[int] = []
        self._state_steps: dict[int, int] = {}
        self._tmpdir: str | None = None
        self._breaking_fraction = PYBULLET_CONTACT_BREAKING_FRACTION
        cid = self._cid
        pybullet.setGravity(*self.gravity_mps2.tolist(), physicsClientId=cid)
        pybullet.setPhysicsEngineParameter(
            fixedTimeStep=fidelity.dt_s,
            numSolverIterations=int(fidelity.solver_iterations),
            numSubSteps=0,
            contactSlop=fidelity.contact_slop_m,
            erp=fidelity.erp,
            contactERP=fidelity.contact_erp,
            frictionERP=fidelity.friction_erp,
            enableConeFriction=int(fidelity.cone_friction),
            contactBreakingThreshold=PYBULLET_CONTACT_BREAKING_FRACTION,
            deterministicOverlappingPairs=1,
            enableFileCaching=0,
            physicsClientId=cid,
        )

    # ---------------------------------------------------------------- lifecycle
    def __enter__(self) -> BulletWorld:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Disconnect the client (idempotent)."""
        if self._cid >= 0:
            pybullet.disconnect(physicsClientId=self._cid)
            self._cid = -1
        if self._tmpdir is not None:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = None

    @property
    def client_id(self) -> int:
        """The PyBullet client id owned by this world."""
        if self._cid < 0:
            raise BulletError("world is closed")
        return self._cid

    @property
    def time_s(self) -> float:
        """Simulated time since creation (or since the restored state was saved), s."""
        return self._steps * self.fidelity.dt_s

    @property
    def step_count(self) -> int:
        """Number of physics steps taken."""
        return self._steps

    # ---------------------------------------------------------------- shapes
    def _primitive_shape(self, pieces: Sequence[ConvexPiece]) -> int:
        """One compound collision shape of up to 16 primitives (box, cylinder, sphere)."""
        if len(pieces) > MAX_COMPOUND_CHILDREN:
            raise ValueError(
                f"expected at most {MAX_COMPOUND_CHILDREN} primitives per shape, "
                f"found {len(pieces)}"
            )
        types, radii, half, lengths, positions, quats = [], [], [], [], [], []
        for pc in pieces:
            pos, quat = pose_to_pq(pc.T_part_piece)
            positions.append(pos)
            quats.append(quat)
            if pc.kind == "box":
                assert pc.half_extents_m is not None
                types.append(pybullet.GEOM_BOX)
                half.append(pc.half_extents_m.tolist())
                radii.append(0.0)
                lengths.append(0.0)
            elif pc.kind == "cylinder":
                types.append(pybullet.GEOM_CYLINDER)
                half.append([0.0, 0.0, 0.0])
                radii.append(float(pc.radius_m))
                lengths.append(float(pc.length_m))
            elif pc.kind == "sphere":
                types.append(pybullet.GEOM_SPHERE)
                half.append([0.0, 0.0, 0.0])
                radii.append(float(pc.radius_m))
                lengths.append(0.0)
            else:
                raise ValueError(f"expected a primitive piece, found kind {pc.kind!r}")
        sid = pybullet.createCollisionShapeArray(
            shapeTypes=types,
            radii=radii,
            halfExtents=half,
            lengths=lengths,
            collisionFramePositions=positions,
            collisionFrameOrientations=quats,
            physicsClientId=self.client_id,
        )
        if sid < 0:
            raise BulletError(f"createCollisionShapeArray failed for {len(pieces)} primitives")
        return sid

    def _hull_compound_shape(self, hulls: Sequence[ConvexPiece]) -> int:
        """One compound of convex hulls (any number), vertices in the body frame.

        ``createCollisionShapeArray`` takes no hulls, and a hull given a collision-frame
        offset becomes a one-child compound whose child keeps PyBullet's 1 mm margin (and so
        does a hull on any non-base link: changeDynamics sets margins of base colliders
        only). A Wavefront OBJ with one object per hull loads as a compound of hulls without
        the 16-child limit, and ``changeDynamics(collisionMargin=...)`` on the base reaches
        every child. The file lives in a temporary folder removed by :meth:`close` (PyBullet
        reads it again when the body is created).
        """
        text = _hulls_obj_text(hulls)
        if self._tmpdir is None:
            self._tmpdir = tempfile.mkdtemp(prefix="asmplan_bullet_")
        fd, path = tempfile.mkstemp(suffix=".obj", prefix="hulls_", dir=self._tmpdir)
        with os.fdopen(fd, "w", encoding="ascii") as fh:
            fh.write(text)
        sid = pybullet.createCollisionShape(
            pybullet.GEOM_MESH, fileName=path, physicsClientId=self.client_id
        )
        if sid < 0:
            raise BulletError(f"createCollisionShape failed for {len(hulls)} hull pieces")
        return sid

    @staticmethod
    def _group_primitives(prims: Sequence[ConvexPiece]) -> list[list[ConvexPiece]]:
        """Split primitives into compound groups of at most 16."""
        return [
            list(prims[i : i + MAX_COMPOUND_CHILDREN])
            for i in range(0, len(prims), MAX_COMPOUND_CHILDREN)
        ]

    def _check_shapes(self, body: int, name: str, expected: Sequence[int]) -> None:
        for k, n in enumerate(expected):
            link = k - 1
            found = len(pybullet.getCollisionShapeData(body, link, physicsClientId=self.client_id))
            if found != n:
                raise ShapeDroppedError(name, link, n, found)

    # ---------------------------------------------------------------- bodies
    def add_body(
        self,
        pieces: Sequence[ConvexPiece],
        mass_kg: float,
        T_world_body: np.ndarray,
        com_m: ArrayLike | None = None,
        inertia_kgm2: np.ndarray | None = None,
        friction: float = 0.5,
        spinning_friction: float | None = None,
        rolling_friction: float = 0.0,
        restitution: float = 0.0,
        name: str = "",
    ) -> int:
        """Add a rigid body made of convex pieces.

        Parameters
        ----------
        pieces : sequence of ConvexPiece
            Collision pieces in the body (part) frame; any number.
        mass_kg : float
            Total mass, kg; 0 makes a static (fixed) body.
        T_world_body : (4, 4) float array
            Pose of the body frame.
        com_m : (3,) float, optional
            Centre of mass in the body frame, m (default: the origin).
        inertia_kgm2 : (3, 3) float array, optional
            Inertia tensor about the centre of mass in body-frame axes, kg m^2. Required for
            dynamic bodies.
        friction : float
            Lateral friction coefficient (PyBullet multiplies the two bodies' values).
        spinning_friction : float, optional
            Torsional friction; default ``fidelity.spinning_friction``.
        rolling_friction, restitution : float
        name : str
            Used in error messages.

        Returns
        -------
        int
            Body unique id.
        """
        pieces = tuple(pieces)
        if not pieces:
            raise ValueError(f"body {name!r}: expected at least one piece, found none")
        if not (math.isfinite(mass_kg) and mass_kg >= 0.0):
            raise ValueError(f"body {name!r}: mass_kg expected >= 0, found {mass_kg}")
        static = mass_kg == 0.0
        com = np.zeros(3) if com_m is None else np.asarray(com_m, dtype=float)
        if com.shape != (3,):
            raise ValueError(f"body {name!r}: com_m expected shape (3,), found {com.shape}")
        if static:
            inertia = np.zeros((3, 3))
            moments, axes = np.zeros(3), np.eye(3)
        else:
            if inertia_kgm2 is None:
                raise ValueError(f"body {name!r}: inertia_kgm2 is required for a dynamic body")
            inertia = np.asarray(inertia_kgm2, dtype=float)
            if inertia.shape != (3, 3):
                raise ValueError(
                    f"body {name!r}: inertia_kgm2 expected shape (3, 3), found {inertia.shape}"
                )
            moments, axes = principal_frame(inertia)
            if np.any(moments <= 0):
                raise ValueError(
                    f"body {name!r}: inertia expected positive definite, found principal "
                    f"moments {moments.tolist()}"
                )
        hulls = [pc for pc in pieces if pc.kind == "hull"]
        prim_groups = self._group_primitives([pc for pc in pieces if pc.kind != "hull"])
        shapes: list[tuple[int, int]] = []  # (shape id, expected child count)
        groups: list[list[ConvexPiece]] = []
        if hulls:
            shapes.append((self._hull_compound_shape(hulls), len(hulls)))
            groups.append(hulls)
        shapes.extend((self._primitive_shape(g), len(g)) for g in prim_groups)
        groups.extend(prim_groups)
        n = len(shapes)
        frac = 1.0 / n
        inertial_quat = quat_xyzw_from_matrix(axes).tolist()
        pos, quat = pose_to_pq(T_world_body)
        cid = self.client_id
        k = n - 1
        body = pybullet.createMultiBody(
            baseMass=mass_kg * frac,
            baseCollisionShapeIndex=shapes[0][0],
            baseVisualShapeIndex=-1,
            basePosition=pos,
            baseOrientation=quat,
            baseInertialFramePosition=com.tolist(),
            baseInertialFrameOrientation=inertial_quat,
            linkMasses=[mass_kg * frac] * k,
            linkCollisionShapeIndices=[s[0] for s in shapes[1:]],
            linkVisualShapeIndices=[-1] * k,
            linkPositions=[[0.0, 0.0, 0.0]] * k,
            linkOrientations=[[0.0, 0.0, 0.0, 1.0]] * k,
            linkInertialFramePositions=[com.tolist()] * k,
            linkInertialFrameOrientations=[inertial_quat] * k,
            linkParentIndices=[0] * k,
            linkJointTypes=[pybullet.JOINT_FIXED] * k,
            linkJointAxis=[[0.0, 0.0, 1.0]] * k,
            physicsClientId=cid,
        )
        if body < 0:
            raise BulletError(f"createMultiBody failed for body {name!r}")
        self._check_shapes(body, name, [s[1] for s in shapes])
        spin = self.fidelity.spinning_friction if spinning_friction is None else spinning_friction
        for j in range(n):
            link = j - 1
            kwargs: dict[str, float | list[float]] = {
                "lateralFriction": float(friction),
                "spinningFriction": float(spin),
                "rollingFriction": float(rolling_friction),
                "restitution": float(restitution),
            }
            if link == -1:  # PyBullet's default damping (0.04 /s) is not physics; remove it
                kwargs["linearDamping"] = 0.0
                kwargs["angularDamping"] = 0.0
            if not static:
                kwargs["localInertiaDiagonal"] = (moments * frac).tolist()
            if link == -1 and hulls:
                kwargs["collisionMargin"] = float(self.fidelity.collision_margin_m)
            pybullet.changeDynamics(body, link, physicsClientId=cid, **kwargs)
        T_link_inertial = np.eye(4)
        T_link_inertial[:3, :3] = axes
        T_link_inertial[:3, 3] = com
        self._bodies[body] = _BodyInfo(
            name=name or f"body{body}",
            mass_kg=float(mass_kg),
            static=static,
            T_link_inertial=T_link_inertial,
            n_links=k,
            inertia_kgm2=inertia,
            compound_links=frozenset(j - 1 for j, g in enumerate(groups) if _is_compound(g)),
            bounding_radius_m=max(bounding_radius_m(g, com, axes) for g in groups),
        )
        return body

    def add_ground(
        self, z_m: float = 0.0, friction: float = 0.5, half_size_m: float = 1.0, name: str = "ground"
    ) -> int:
        """Static ground slab whose top face is the plane ``z = z_m``; returns its body id."""
        thickness = 0.05
        slab = ConvexPiece(
            kind="box",
            T_part_piece=np.eye(4),
            half_extents_m=np.array([half_size_m, half_size_m, thickness]),
            name=name,
        )
        T = np.eye(4)
        T[2, 3] = z_m - thickness
        return self.add_body((slab,), 0.0, T, friction=friction, name=name)

    def add_articulated(
        self,
        base_pieces: Sequence[ConvexPiece],
        base_mass_kg: float,
        T_world_base: np.ndarray,
        links: Sequence[LinkSpec],
        base_com_m: Sequence[float] = (0.0, 0.0, 0.0),
        base_inertia_diag_kgm2: Sequence[float] | None = None,
        base_friction: float = 0.5,
        name: str = "",
    ) -> int:
        """Add an articulated body (base + links joined by fixed/prismatic/revolute joints).

        Joint motors are disabled (velocity motors set to zero force), so joints are free
        until commanded with :meth:`set_joint_forces` or :meth:`set_joint_position_targets`.
        Links of one body do not collide with each other.

        Returns
        -------
        int
            Body unique id; link ``i`` of ``links`` has PyBullet link index ``i``.
        """
        cid = self.client_id
        for piece in [*base_pieces, *(pc for spec in links for pc in spec.pieces)]:
            if piece.kind == "hull":
                raise ValueError(
                    f"articulated body {name!r}: expected primitive pieces only, found a hull "
                    f"({piece.name!r}); hull margins cannot be set on links"
                )
        base_shape = (self._primitive_shape(tuple(base_pieces)), len(base_pieces))
        link_shapes = [(self._primitive_shape(tuple(spec.pieces)), len(spec.pieces)) for spec in links]
        pos, quat = pose_to_pq(T_world_base)
        body = pybullet.createMultiBody(
            baseMass=float(base_mass_kg),
            baseCollisionShapeIndex=base_shape[0],
            baseVisualShapeIndex=-1,
            basePosition=pos,
            baseOrientation=quat,
            baseInertialFramePosition=list(base_com_m),
            baseInertialFrameOrientation=[0.0, 0.0, 0.0, 1.0],
            linkMasses=[float(s.mass_kg) for s in links],
            linkCollisionShapeIndices=[s[0] for s in link_shapes],
            linkVisualShapeIndices=[-1] * len(links),
            linkPositions=[pose_to_pq(s.T_parent_link)[0] for s in links],
            linkOrientations=[pose_to_pq(s.T_parent_link)[1] for s in links],
            linkInertialFramePositions=[list(s.com_m) for s in links],
            linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]] * len(links),
            linkParentIndices=[s.parent + 1 for s in links],
            linkJointTypes=[_JOINT_TYPES[s.joint] for s in links],
            linkJointAxis=[list(s.axis) for s in links],
            physicsClientId=cid,
        )
        if body < 0:
            raise BulletError(f"createMultiBody failed for articulated body {name!r}")
        self._check_shapes(body, name, [base_shape[1]] + [s[1] for s in link_shapes])
        base_kwargs: dict[str, float | list[float]] = {"lateralFriction": float(base_friction)}
        if base_inertia_diag_kgm2 is not None:
            base_kwargs["localInertiaDiagonal"] = list(base_inertia_diag_kgm2)
        pybullet.changeDynamics(body, -1, physicsClientId=cid, **base_kwargs)
        for i, spec in enumerate(links):
            kw: dict[str, float | list[float]] = {
                "lateralFriction": float(spec.friction),
                # anchors on the links (the gripper's fingers): every contact with them holds
                # its anchor point while it sticks (Fidelity.friction_anchor)
                "frictionAnchor": int(self.fidelity.friction_anchor),
                "spinningFriction": float(spec.spinning_friction),
                "linearDamping": 0.0,
                "angularDamping": 0.0,
                "jointDamping": float(spec.joint_damping),
            }
            if spec.inertia_diag_kgm2 is not None:
                kw["localInertiaDiagonal"] = list(spec.inertia_diag_kgm2)
            if spec.limits is not None:
                kw["jointLowerLimit"] = float(spec.limits[0])
                kw["jointUpperLimit"] = float(spec.limits[1])
            pybullet.changeDynamics(body, i, physicsClientId=cid, **kw)
        pybullet.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
        movable = [i for i, s in enumerate(links) if s.joint != "fixed"]
        self.disable_motors(body, movable)
        T_link_inertial = np.eye(4)
        T_link_inertial[:3, 3] = np.asarray(base_com_m, dtype=float)
        groups = [list(base_pieces)] + [list(spec.pieces) for spec in links]
        coms = [np.asarray(base_com_m, dtype=float)] + [np.asarray(s.com_m, float) for s in links]
        self._bodies[body] = _BodyInfo(
            name=name or f"body{body}",
            mass_kg=float(base_mass_kg + sum(s.mass_kg for s in links)),
            static=base_mass_kg == 0.0,
            T_link_inertial=T_link_inertial,
            n_links=len(links),
            compound_links=frozenset(j - 1 for j, g in enumerate(groups) if _is_compound(g)),
            bounding_radius_m=max(bounding_radius_m(g, c, np.eye(3))
                                  for g, c in zip(groups, coms, strict=True)),
        )
        return body

    def body_name(self, body: int) -> str:
        """Name given when the body was added."""
        return self._bodies[body].name

    def body_mass_kg(self, body: int) -> float:
        """Total mass of a body, kg (0 for static bodies)."""
        return self._bodies[body].mass_kg

    def body_inertia_kgm2(self, body: int) -> np.ndarray:
        """Inertia tensor about the centre of mass, body axes, (3, 3) kg m^2 (parts only)."""
        return self._bodies[body].inertia_kgm2.copy()

    def body_com_m(self, body: int) -> np.ndarray:
        """Centre of mass of a body's base in its link frame, (3,) m."""
        return self._bodies[body].T_link_inertial[:3, 3].copy()

    def contact_breaking_m(self, body: int, other: int | None = None) -> float:
        """Largest distance (m) at which Bullet creates or keeps a contact point between
        ``body`` and ``other`` (any body when None): the world's breaking fraction times the
        smaller of the two bodies' bounding radii (each the largest of its colliders'; Bullet
        takes the smaller radius of the two colliders of a pair, so this bounds every pair)."""
        radius = self._bodies[body].bounding_radius_m
        if other is not None:
            radius = min(radius, self._bodies[other].bounding_radius_m)
        return self._breaking_fraction * radius

    def limit_contact_breaking_m(self, body: int, distance_m: float,
                                 others: Sequence[int] = ()) -> None:
        """Lower the world's breaking fraction so that :meth:`contact_breaking_m` of ``body``
        and each of ``others`` (of ``body`` and anything, when ``others`` is empty) is at most
        ``distance_m``; never raises it (see the module docstring).

        The fraction is one value for the whole world: every other pair's distance shrinks in
        proportion. Bullet fixes a pair's breaking distance when it first meets the pair, so
        this must be called before the first step.

        Raises
        ------
        ValueError
            For a distance that is not > 0.
        BulletError
            After the first step.
        """
        if not (math.isfinite(distance_m) and distance_m > 0.0):
            raise ValueError(f"distance_m: expected a finite value > 0, found {distance_m}")
        if self._steps > 0:
            raise BulletError(f"limit_contact_breaking_m: expected before the first step, "
                              f"found {self._steps} steps taken")
        radius = self._bodies[body].bounding_radius_m
        if others:
            radius = min(radius, max(self._bodies[o].bounding_radius_m for o in others))
        fraction = distance_m / radius
        if fraction < self._breaking_fraction:
            self._breaking_fraction = fraction
            pybullet.setPhysicsEngineParameter(contactBreakingThreshold=fraction,
                                               physicsClientId=self.client_id)

    def body_link_count(self, body: int) -> int:
        """Number of non-base links of a body."""
        return self._bodies[body].n_links

    # ---------------------------------------------------------------- state queries
    def pose(self, body: int, link: int = -1) -> np.ndarray:
        """World pose (4, 4) of a body's link frame (-1: base = part frame)."""
        cid = self.client_id
        if link == -1:
            p, q = pybullet.getBasePositionAndOrientation(body, physicsClientId=cid)
            return _pose_from_bullet(p, q) @ self._bodies[body].T_inertial_link
        st = pybullet.getLinkState(body, link, computeForwardKinematics=1, physicsClientId=cid)
        return _pose_from_bullet(st[4], st[5])

    def set_pose(self, body: int, T_world_body: np.ndarray) -> None:
        """Teleport a body's base link frame to ``T_world_body`` (4, 4)."""
        T_world_inertial = np.asarray(T_world_body, dtype=float) @ self._bodies[body].T_link_inertial
        p, q = pose_to_pq(T_world_inertial)
        pybullet.resetBasePositionAndOrientation(body, p, q, physicsClientId=self.client_id)

    def velocity(self, body: int) -> tuple[np.ndarray, np.ndarray]:
        """Linear velocity of the base centre of mass (3,) m/s and angular velocity (3,) rad/s."""
        v, w = pybullet.getBaseVelocity(body, physicsClientId=self.client_id)
        return np.asarray(v, dtype=float), np.asarray(w, dtype=float)

    def set_velocity(
        self, body: int, linear_mps: Sequence[float], angular_radps: Sequence[float]
    ) -> None:
        """Set the base velocity (world frame)."""
        pybullet.resetBaseVelocity(
            body, list(linear_mps), list(angular_radps), physicsClientId=self.client_id
        )

    def kinetic_energy_J(self, body: int, velocity: tuple[np.ndarray, np.ndarray] | None = None,
                         T_world_body: np.ndarray | None = None) -> float:
        """Kinetic energy of a rigid (part) body from its base velocity, J.

        ``velocity`` ((3,) m/s, (3,) rad/s) and ``T_world_body`` (4, 4) may be passed when
        already read after the last step (saves two queries).
        """
        info = self._bodies[body]
        if info.static:
            return 0.0
        v, w = self.velocity(body) if velocity is None else velocity
        R = (self.pose(body) if T_world_body is None else T_world_body)[:3, :3]
        inertia_world = R @ info.inertia_kgm2 @ R.T
        return float(0.5 * info.mass_kg * v @ v + 0.5 * w @ inertia_world @ w)

    def contacts(
        self,
        body_a: int,
        body_b: int | None = None,
        link_a: int | None = None,
        link_b: int | None = None,
    ) -> Contacts:
        """Contact points of body A (optionally only with body B / given links).

        Reflects the last :meth:`step`. Forces are those the solver applied in that step.
        """
        cid = self.client_id
        kwargs: dict[str, int] = {"bodyA": body_a, "physicsClientId": cid}
        if body_b is not None:
            kwargs["bodyB"] = body_b
        if link_a is not None:
            kwargs["linkIndexA"] = link_a
        if link_b is not None:
            kwargs["linkIndexB"] = link_b
        pts = pybullet.getContactPoints(**kwargs)
        n = len(pts)
        if n == 0:
            e = np.zeros(0)
            e3 = np.zeros((0, 3))
            ei = np.zeros(0, dtype=int)
            return Contacts(ei, ei, ei, e3, e3, e3, e, e, e3)
        # one array: body_b, link_a, link_b, pos_a (3), pos_b (3), normal (3), distance,
        # normal force, friction 1, its direction (3), friction 2, its direction (3)
        a = np.array([(c[2], c[3], c[4], *c[5], *c[6], *c[7], c[8], c[9], c[10], *c[11],
                       c[12], *c[13]) for c in pts], dtype=float)
        arr_b = a[:, 0].astype(int)
        la = a[:, 1].astype(int)
        lb = a[:, 2].astype(int)
        pa, pb, nb = a[:, 3:6], a[:, 6:9], a[:, 9:12]
        dist, fn = a[:, 12], a[:, 13]
        fric = a[:, 14:15] * a[:, 15:18] + a[:, 18:19] * a[:, 19:22]
        # PyBullet reports friction as the force on the contact manifold's body 0. Measured
        # rule (tests/sim/test_bullet.py): when exactly one of the two colliders is a compound
        # shape, the compound is body 0; otherwise the collider created first is (lower body
        # id; within a body, lower link index, base first).
        info_a = self._bodies[body_a]
        bodies = self._bodies
        comp_a = np.array([c[3] in info_a.compound_links for c in pts])
        comp_b = np.array([c[4] in bodies[c[2]].compound_links if c[2] in bodies else False
                           for c in pts])
        created_first = (body_a < arr_b) | ((body_a == arr_b) & (la < lb))
        a_is_body0 = np.where(comp_a != comp_b, comp_a, created_first)
        fric = np.where(a_is_body0[:, None], fric, -fric)
        return Contacts(arr_b, la, lb, pa, pb, nb, dist, fn, fric)

    def contact_count(self, body_a: int, link_a: int | None = None) -> int:
        """Number of contact points of body A (optionally of one link) after the last step;
        cheaper than :meth:`contacts` when only their presence matters."""
        if link_a is None:
            return len(pybullet.getContactPoints(bodyA=body_a, physicsClientId=self.client_id))
        return len(pybullet.getContactPoints(bodyA=body_a, linkIndexA=link_a,
                                             physicsClientId=self.client_id))

    def max_penetration_m(self, body_a: int) -> float:
        """Deepest penetration among body A's contact points after the last step, m (0 when
        none penetrates); cheaper than ``contacts(body_a).max_penetration_m()``."""
        pts = pybullet.getContactPoints(bodyA=body_a, physicsClientId=self.client_id)
        return max(0.0, -min(c[8] for c in pts)) if pts else 0.0

    # ---------------------------------------------------------------- joints
    def disable_motors(self, body: int, joints: Sequence[int]) -> None:
        """Switch the default velocity motors of ``joints`` off (zero max force)."""
        if not joints:
            return
        pybullet.setJointMotorControlArray(
            body,
            list(joints),
            pybullet.VELOCITY_CONTROL,
            targetVelocities=[0.0] * len(joints),
            forces=[0.0] * len(joints),
            physicsClientId=self.client_id,
        )

    def set_joint_forces(self, body: int, joints: Sequence[int], forces: Sequence[float]) -> None:
        """Apply joint forces (N, prismatic) or torques (N m, revolute) for the next step.

        The velocity motors must be disabled first (:meth:`disable_motors`).
        """
        pybullet.setJointMotorControlArray(
            body,
            list(joints),
            pybullet.TORQUE_CONTROL,
            forces=[float(f) for f in forces],
            physicsClientId=self.client_id,
        )

    def set_joint_velocity_targets(
        self,
        body: int,
        joints: Sequence[int],
        velocities: Sequence[float],
        max_forces: Sequence[float],
    ) -> None:
        """Velocity-control joints with bounded motor force (N or N m).

        A blocked joint (velocity below its target) is pushed with exactly ``max_forces``.
        """
        pybullet.setJointMotorControlArray(
            body,
            list(joints),
            pybullet.VELOCITY_CONTROL,
            targetVelocities=[float(v) for v in velocities],
            forces=[float(f) for f in max_forces],
            physicsClientId=self.client_id,
        )

    def set_joint_position_targets(
        self,
        body: int,
        joints: Sequence[int],
        targets: Sequence[float],
        max_forces: Sequence[float],
        position_gain: float = 0.1,
        velocity_gain: float = 1.0,
    ) -> None:
        """Position-control joints toward ``targets`` with bounded motor force."""
        n = len(joints)
        pybullet.setJointMotorControlArray(
            body,
            list(joints),
            pybullet.POSITION_CONTROL,
            targetPositions=[float(t) for t in targets],
            targetVelocities=[0.0] * n,
            forces=[float(f) for f in max_forces],
            positionGains=[position_gain] * n,
            velocityGains=[velocity_gain] * n,
            physicsClientId=self.client_id,
        )

    def reset_joints(self, body: int, joints: Sequence[int], positions: Sequence[float]) -> None:
        """Teleport joints to ``positions`` with zero velocity."""
        for j, q in zip(joints, positions, strict=True):
            pybullet.resetJointState(body, j, float(q), 0.0, physicsClientId=self.client_id)

    def joint_positions(self, body: int, joints: Sequence[int]) -> np.ndarray:
        """Joint positions (m or rad), (len(joints),)."""
        st = pybullet.getJointStates(body, list(joints), physicsClientId=self.client_id)
        return np.array([s[0] for s in st], dtype=float)

    def joint_positions_velocities(self, body: int, joints: Sequence[int]
                                   ) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions and velocities in one query, each (len(joints),)."""
        st = pybullet.getJointStates(body, list(joints), physicsClientId=self.client_id)
        return (np.array([s[0] for s in st], dtype=float),
                np.array([s[1] for s in st], dtype=float))

    def joint_velocities(self, body: int, joints: Sequence[int]) -> np.ndarray:
        """Joint velocities (m/s or rad/s), (len(joints),)."""
        st = pybullet.getJointStates(body, list(joints), physicsClientId=self.client_id)
        return np.array([s[1] for s in st], dtype=float)

    def apply_force(
        self, body: int, link: int, force_N: Sequence[float] | np.ndarray,
        position_m: Sequence[float] | np.ndarray,
    ) -> None:
        """Apply a world-frame force at a world point during the next step only."""
        pybullet.applyExternalForce(
            body,
            link,
            list(force_N),
            list(position_m),
            pybullet.WORLD_FRAME,
            physicsClientId=self.client_id,
        )

    def com_position_m(self, body: int, link: int = -1) -> np.ndarray:
        """World position of a link's centre of mass, (3,) m."""
        cid = self.client_id
        if link == -1:
            return np.asarray(pybullet.getBasePositionAndOrientation(body, physicsClientId=cid)[0])
        st = pybullet.getLinkState(body, link, computeForwardKinematics=1, physicsClientId=cid)
        return np.asarray(st[0])

    # ---------------------------------------------------------------- pose constraints
    def add_pose_constraint(
        self, body: int, T_world_target: np.ndarray, max_force_N: float, erp: float | None = None
    ) -> int:
        """Fixed constraint pulling a body's base link frame to a world pose.

        ``erp`` is the fraction of the pose error corrected per step (default: the world's
        ``fidelity.erp``); a moving target lags by about ``v dt / erp``. Returns the
        constraint id; move it with :meth:`move_pose_constraint`.
        """
        T_inertial_link = invert(self._bodies[body].T_link_inertial)
        parent_pos, parent_quat = pose_to_pq(T_inertial_link)
        pos, quat = pose_to_pq(T_world_target)
        cons = pybullet.createConstraint(
            parentBodyUniqueId=body,
            parentLinkIndex=-1,
            childBodyUniqueId=-1,
            childLinkIndex=-1,
            jointType=pybullet.JOINT_FIXED,
            jointAxis=[0.0, 0.0, 0.0],
            parentFramePosition=parent_pos,
            childFramePosition=pos,
            parentFrameOrientation=parent_quat,
            childFrameOrientation=quat,
            physicsClientId=self.client_id,
        )
        if cons < 0:
            raise BulletError(f"createConstraint failed for body {self.body_name(body)!r}")
        pybullet.changeConstraint(
            cons,
            maxForce=float(max_force_N),
            erp=float(self.fidelity.erp if erp is None else erp),
            physicsClientId=self.client_id,
        )
        return cons

    def move_pose_constraint(
        self,
        constraint: int,
        position_m: Sequence[float],
        quat_xyzw: Sequence[float],
        max_force_N: float,
    ) -> None:
        """Move the world target of a pose constraint."""
        pybullet.changeConstraint(
            constraint,
            jointChildPivot=list(position_m),
            jointChildFrameOrientation=list(quat_xyzw),
            maxForce=float(max_force_N),
            physicsClientId=self.client_id,
        )

    # ---------------------------------------------------------------- stepping and state
    def step(self, n: int = 1) -> None:
        """Advance the simulation by ``n`` steps of ``fidelity.dt_s``."""
        cid = self.client_id
        for _ in range(int(n)):
            pybullet.stepSimulation(physicsClientId=cid)
        self._steps += int(n)

    def save_state(self) -> int:
        """Snapshot the world in memory; returns a state id for :meth:`restore_state`.

        Bodies and constraints must not be added or removed between save and restore.
        """
        sid = pybullet.saveState(physicsClientId=self.client_id)
        self._states.append(sid)
        self._state_steps[sid] = self._steps
        return sid

    def restore_state(self, state_id: int) -> None:
        """Restore a snapshot taken by :meth:`save_state` (also resets :attr:`time_s`)."""
        if state_id not in self._states:
            raise KeyError(f"unknown state id {state_id}; known {self._states}")
        pybullet.restoreState(stateId=state_id, physicsClientId=self.client_id)
        # Refresh the contact manifolds: otherwise getContactPoints keeps reporting the
        # contacts of the last step before the restore until the next step.
        pybullet.performCollisionDetection(physicsClientId=self.client_id)
        self._steps = self._state_steps[state_id]

    def remove_state(self, state_id: int) -> None:
        """Free a snapshot."""
        if state_id in self._states:
            pybullet.removeState(state_id, physicsClientId=self.client_id)
            self._states.remove(state_id)
