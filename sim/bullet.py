"""PyBullet world: the ONLY module of asmplan that imports pybullet.

What needs no pybullet call lives beside it: the shapes it builds (hull OBJ text, exact hulls of
primitives) in :mod:`asmplan.sim.bullet_shapes`, Bullet's bounding radius and contact
breaking distance in :mod:`asmplan.sim.bullet_breaking`, the contact arrays in
:mod:`asmplan.sim.contacts` and the link specifications in :mod:`asmplan.sim.bullet_specs`.

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

Contact forces
--------------
:meth:`BulletWorld.contacts` returns the points as arrays; ``normal_on_b`` points from B to A,
so ``normal_force_N * normal_on_b`` is the normal force ON A. PyBullet reports the friction
vectors of a contact as the force on its internal manifold's body 0, whatever order the query
used. Measured rule: if exactly one of the two colliders is a compound shape it is body 0,
otherwise the collider created first is. :class:`~asmplan.sim.contacts.Contacts` stores
friction already signed as the force on A (validated in ``tests/sim/test_bullet.py`` against
static equilibrium on a slope for every kind of collider this module builds, in both creation
orders).
"""
from __future__ import annotations

import contextlib
import math
import operator
import os
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from types import TracebackType

import numpy as np
from numpy.typing import ArrayLike

from ..errors import AsmplanError
from ..knowledge.frames import invert
from ..parts.pieces import ConvexPiece
from ..planner.trajectory import quat_xyzw_from_matrix
from .bullet_breaking import (
    BREAKING_CAP_EXTRA_UNITS,
    BREAKING_RADIUS_CAP_UNITS,
    _breaking_distance_m,
    bounding_radius_m,
    default_breaking_fraction,
)
from .bullet_shapes import (
    MAX_COMPOUND_CHILDREN,
    PRISM_TOLERANCE_FRACTION,
    _hulls_obj_text,
    _is_compound,
    exact_hull,
    pose_to_pq,
    principal_frame,
)
from .bullet_specs import LinkSpec, _BodyInfo
from .contacts import Contacts
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


@contextlib.contextmanager
def _fd_to_devnull(fd: int) -> Iterator[None]:
    """Point file descriptor ``fd`` at /dev/null for the block (C code's prints)."""
    import sys

    stream = sys.stdout if fd == 1 else sys.stderr
    try:
        stream.flush()
        saved = os.dup(fd)
    except (OSError, ValueError):
        yield
        return
    try:
        with open(os.devnull, "wb") as devnull:
            os.dup2(devnull.fileno(), fd)
            yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


MILLIMETRE_UNITS_PER_M = 1000.0
"""``Fidelity.bullet_units_per_m`` of BALANCED and ACCURATE: Bullet length units per metre,
the simulated world is in millimetres (mass kg, time s); FAST keeps metres (1.0).

Bullet's collision code has absolute tolerances written for metre-sized objects. The one that
decides contact at features: GJK stops when a new support point lies within 1e-2 units of a
simplex vertex (``VORONOI_DEFAULT_EQUAL_VERTEX_THRESHOLD`` = 1e-4 units squared), so in metres
every hull vertex within 1 cm of another is "the same point": a 10 mm 100-sided prism probed
0.5 mm off its side measured 40-90 um too far, contacts appeared 40 um before touching and a
tilted peg hung on the hole's mouth. In millimetres the threshold is 10 um of vertex spacing
(a 10 mm 160-gon's are 0.2 mm apart) and EPA's tolerance 1 um. Every value crossing this
module's boundary is converted: lengths and linear velocities x S, forces x S (kg mm / s^2),
torques and inertias x S^2; a prismatic joint's damping (kg/s) is unchanged, a revolute's x S^2.
Callers see SI only."""

_PRIMITIVES_AS_HULLS = False

# A multibody clamps every velocity coordinate to 100 units/s by default (0.1 m/s in mm);
# raised to 1 km/s (the scene's speed guard acts long before).
# Bullet's bound of a fixed pose constraint is one number for its linear rows (kg mm/s^2)
# and its angular rows (kg mm^2/s^2): it is S^2 max_force_N, so that the torque bound is
# max_force_N N m as it was in metres; the force bound is then S x max_force_N N: the robot's
# position hold is stiff, as a robot's is.

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
_contact_distance = operator.itemgetter(8)
"""Signed distance (Bullet units) of a ``getContactPoints`` row."""


def _pose_from_bullet(position: Sequence[float], quat_xyzw: Sequence[float], units_per_m: float
                      ) -> np.ndarray:
    """(position, quaternion xyzw) from PyBullet, in its units, -> (4, 4) transform in metres
    (PyBullet's own C conversion of its unit quaternions, ~10x faster in the per-step loop)."""
    m = pybullet.getMatrixFromQuaternion(quat_xyzw)
    # built in one call from Python floats (the same doubles as filling np.eye(4); ~3x faster)
    return np.array(((m[0], m[1], m[2], position[0] / units_per_m),
                     (m[3], m[4], m[5], position[1] / units_per_m),
                     (m[6], m[7], m[8], position[2] / units_per_m),
                     (0.0, 0.0, 0.0, 1.0)))


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
        self._S = float(fidelity.bullet_units_per_m)
        self._S2 = self._S * self._S
        self._breaking_fraction = default_breaking_fraction(fidelity)
        self._joint_kinds: dict[int, tuple[str, ...]] = {}
        self._joint_scale_cache: dict[tuple[int, tuple[int, ...]], tuple[list[float], list[float]]] = {}
        self._probe: int | None = None
        self._pieces: dict[int, tuple[ConvexPiece, ...]] = {}
        self._probe_r = 0.0
        self._held_static: set[int] = set()
        cid = self._cid
        pybullet.setGravity(*(self._S * self.gravity_mps2).tolist(), physicsClientId=cid)
        pybullet.setPhysicsEngineParameter(
            fixedTimeStep=fidelity.dt_s,
            numSolverIterations=int(fidelity.solver_iterations),
            numSubSteps=0,
            contactSlop=self._S * fidelity.contact_slop_m,
            erp=fidelity.erp,
            contactERP=fidelity.contact_erp,
            frictionERP=fidelity.friction_erp,
            enableConeFriction=int(fidelity.cone_friction),
            contactBreakingThreshold=self._breaking_fraction,
            deterministicOverlappingPairs=1,
            enableFileCaching=0,
            physicsClientId=cid,
        )
        if fidelity.constraint_solver == "dantzig":
            # PyBullet announces the switch on stdout from C: keep it out of the CLI's output
            with _fd_to_devnull(1):
                pybullet.setPhysicsEngineParameter(
                    constraintSolverType=pybullet.CONSTRAINT_SOLVER_LCP_DANTZIG,
                    physicsClientId=cid)

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
            positions.append([self._S * v for v in pos])
            quats.append(quat)
            if pc.kind == "box":
                assert pc.half_extents_m is not None
                types.append(pybullet.GEOM_BOX)
                half.append((self._S * pc.half_extents_m).tolist())
                radii.append(0.0)
                lengths.append(0.0)
            elif pc.kind == "cylinder":
                types.append(pybullet.GEOM_CYLINDER)
                half.append([0.0, 0.0, 0.0])
                radii.append(self._S * float(pc.radius_m))
                lengths.append(self._S * float(pc.length_m))
            elif pc.kind == "sphere":
                types.append(pybullet.GEOM_SPHERE)
                half.append([0.0, 0.0, 0.0])
                radii.append(self._S * float(pc.radius_m))
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
        text = _hulls_obj_text(hulls, self._S)
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
    # Complexity above C (radon): validates mass, centre of mass and inertia, then sets the engine's
    # per-link dynamics (damping, hulls, margins); each check raises its own error.
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
        if _PRIMITIVES_AS_HULLS and self.fidelity.collision_margin_m == 0.0:
            tol = PRISM_TOLERANCE_FRACTION * self.fidelity.interference_resolution_m
            pieces = tuple(exact_hull(pc, tol) for pc in pieces)
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
        pos = [self._S * v for v in pos]
        com_u = (self._S * com).tolist()
        cid = self.client_id
        k = n - 1
        body = pybullet.createMultiBody(
            baseMass=mass_kg * frac,
            baseCollisionShapeIndex=shapes[0][0],
            baseVisualShapeIndex=-1,
            basePosition=pos,
            baseOrientation=quat,
            baseInertialFramePosition=com_u,
            baseInertialFrameOrientation=inertial_quat,
            linkMasses=[mass_kg * frac] * k,
            linkCollisionShapeIndices=[s[0] for s in shapes[1:]],
            linkVisualShapeIndices=[-1] * k,
            linkPositions=[[0.0, 0.0, 0.0]] * k,
            linkOrientations=[[0.0, 0.0, 0.0, 1.0]] * k,
            linkInertialFramePositions=[com_u] * k,
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
                "spinningFriction": self._S * float(spin),  # a length: torque / normal force
                "rollingFriction": self._S * float(rolling_friction),
                "restitution": float(restitution),
            }
            if link == -1:  # PyBullet's default damping (0.04 /s) is not physics; remove it
                kwargs["linearDamping"] = 0.0
                kwargs["angularDamping"] = 0.0
                # body-wide; on a link it makes changeDynamics drop the call's other values
                kwargs["maxJointVelocity"] = 1e3 * self._S
            if not static:
                kwargs["localInertiaDiagonal"] = (self._S2 * moments * frac).tolist()
            if link == -1 and hulls:
                kwargs["collisionMargin"] = self._S * float(self.fidelity.collision_margin_m)
            pybullet.changeDynamics(body, link, physicsClientId=cid, **kwargs)
        T_link_inertial = np.eye(4)
        T_link_inertial[:3, :3] = axes
        T_link_inertial[:3, 3] = com
        self._pieces[body] = tuple(pieces)
        self._bodies[body] = _BodyInfo(
            name=name or f"body{body}",
            mass_kg=float(mass_kg),
            static=static,
            T_link_inertial=T_link_inertial,
            n_links=k,
            inertia_kgm2=inertia,
            compound_links=frozenset(j - 1 for j, g in enumerate(groups) if _is_compound(g)),
            bounding_radius_m=max(bounding_radius_m(g, com, axes, self._S) for g in groups),
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

    # Complexity above C (radon): builds one multibody: base and links with their pieces,
    # inertias, joint limits and per-link contact settings.
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
            basePosition=[self._S * v for v in pos],
            baseOrientation=quat,
            baseInertialFramePosition=[self._S * float(v) for v in base_com_m],
            baseInertialFrameOrientation=[0.0, 0.0, 0.0, 1.0],
            linkMasses=[float(s.mass_kg) for s in links],
            linkCollisionShapeIndices=[s[0] for s in link_shapes],
            linkVisualShapeIndices=[-1] * len(links),
            linkPositions=[[self._S * v for v in pose_to_pq(s.T_parent_link)[0]] for s in links],
            linkOrientations=[pose_to_pq(s.T_parent_link)[1] for s in links],
            linkInertialFramePositions=[[self._S * float(v) for v in s.com_m] for s in links],
            linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]] * len(links),
            linkParentIndices=[s.parent + 1 for s in links],
            linkJointTypes=[_JOINT_TYPES[s.joint] for s in links],
            linkJointAxis=[list(s.axis) for s in links],
            physicsClientId=cid,
        )
        if body < 0:
            raise BulletError(f"createMultiBody failed for articulated body {name!r}")
        self._check_shapes(body, name, [base_shape[1]] + [s[1] for s in link_shapes])
        base_kwargs: dict[str, float | list[float]] = {"lateralFriction": float(base_friction),
                                                       "maxJointVelocity": 1e3 * self._S}
        if base_inertia_diag_kgm2 is not None:
            base_kwargs["localInertiaDiagonal"] = [self._S2 * float(v) for v in base_inertia_diag_kgm2]
        pybullet.changeDynamics(body, -1, physicsClientId=cid, **base_kwargs)
        for i, spec in enumerate(links):
            kw: dict[str, float | list[float]] = {
                "lateralFriction": float(spec.friction),
                # anchors on the links (the gripper's fingers): every contact with them holds
                # its anchor point while it sticks (Fidelity.friction_anchor)
                "frictionAnchor": int(self.fidelity.friction_anchor),
                "spinningFriction": self._S * float(spec.spinning_friction),
                "linearDamping": 0.0,
                "angularDamping": 0.0,
                # N s/m = kg/s is unit-free in length; N m s/rad scales with S^2
                "jointDamping": float(spec.joint_damping) * (self._S2 if spec.joint == "revolute"
                                                             else 1.0),
            }
            if spec.inertia_diag_kgm2 is not None:
                kw["localInertiaDiagonal"] = [self._S2 * float(v) for v in spec.inertia_diag_kgm2]
            if spec.limits is not None:
                js = self._S if spec.joint == "prismatic" else 1.0
                kw["jointLowerLimit"] = js * float(spec.limits[0])
                kw["jointUpperLimit"] = js * float(spec.limits[1])
            pybullet.changeDynamics(body, i, physicsClientId=cid, **kw)
        pybullet.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
        movable = [i for i, s in enumerate(links) if s.joint != "fixed"]
        self._joint_kinds[body] = tuple(s.joint for s in links)
        self._joint_scale_cache = {k: v for k, v in self._joint_scale_cache.items() if k[0] != body}
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
            bounding_radius_m=max(bounding_radius_m(g, c, np.eye(3), self._S)
                                  for g, c in zip(groups, coms, strict=True)),
        )
        return body

    def dynamic_bodies(self) -> list[int]:
        """Ids of the bodies that can move (mass > 0), in creation order."""
        return [b for b, info in self._bodies.items() if not info.static]

    def body_name(self, body: int) -> str:
        """Name given when the body was added."""
        return self._bodies[body].name

    def body_mass_kg(self, body: int) -> float:
        """Total mass of a body, kg (0 for static bodies)."""
        return self._bodies[body].mass_kg

    def rigid_properties(self, body: int) -> tuple[float, np.ndarray, np.ndarray]:
        """(mass kg, base inertial frame in the link frame (4, 4), inertia tensor about the
        centre of mass in link-frame axes (3, 3) kg m^2) of a part body."""
        info = self._bodies[body]
        return info.mass_kg, info.T_link_inertial.copy(), np.array(info.inertia_kgm2, float)

    def lateral_friction(self, body: int) -> float:
        """The base link's Coulomb coefficient (Bullet combines a pair's as the product)."""
        return float(pybullet.getDynamicsInfo(body, -1, physicsClientId=self.client_id)[1])

    def set_collision_enabled(self, body_a: int, body_b: int, enabled: bool) -> None:
        """Switch Bullet's contact between every link of two bodies on or off
        (``setCollisionFilterPair``); e.g. while :mod:`asmplan.sim.feature_contact` models it."""
        cid = self.client_id
        for la in range(-1, self._bodies[body_a].n_links):
            for lb in range(-1, self._bodies[body_b].n_links):
                pybullet.setCollisionFilterPair(body_a, body_b, la, lb, int(enabled),
                                                physicsClientId=cid)

    def contact_breaking_m(self, body: int, other: int | None = None) -> float:
        """Largest distance (m) at which Bullet creates or keeps a contact point between
        ``body`` and ``other`` (any body when None): the world's breaking fraction times the
        smaller of the two bodies' bounding radii (each the largest of its colliders'; Bullet
        takes the smaller radius of the two colliders of a pair, so this bounds every pair)."""
        radius = self._bodies[body].bounding_radius_m
        if other is not None:
            radius = min(radius, self._bodies[other].bounding_radius_m)
        return _breaking_distance_m(self._breaking_fraction, radius, self._S)

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
        cap, extra = BREAKING_RADIUS_CAP_UNITS / self._S, BREAKING_CAP_EXTRA_UNITS / self._S
        fraction = (max(distance_m - extra, 0.1 * distance_m) / cap if radius >= cap
                    else distance_m / radius)
        if fraction < self._breaking_fraction:
            self._breaking_fraction = fraction
            pybullet.setPhysicsEngineParameter(contactBreakingThreshold=fraction,
                                               physicsClientId=self.client_id)

    def body_pieces(self, body: int) -> tuple[ConvexPiece, ...]:
        """The collision pieces a rigid body was made of (:meth:`add_body`), body frame."""
        return self._pieces.get(body, ())

    def body_link_count(self, body: int) -> int:
        """Number of non-base links of a body."""
        return self._bodies[body].n_links

    def probe_distance_m(self, body: int, point_m: Sequence[float]) -> float:
        """Distance (m) from a world point to ``body``'s simulated collision shapes, as
        Bullet computes it (``getClosestPoints`` against a 1 um sphere): compared with the
        exact geometry it measures how much the simulator rounds edges and rims. The first
        call adds a static probe body: not between :meth:`save_state` and a restore."""
        cid = self.client_id
        if self._probe is None:
            r_units = 1e-6 * self._S
            sid = pybullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=r_units,
                                                physicsClientId=cid)
            self._probe = pybullet.createMultiBody(0.0, sid, basePosition=[0.0, 0.0, -1e3],
                                                   physicsClientId=cid)
            self._probe_r = r_units
        pos = [self._S * float(v) for v in point_m]
        pybullet.resetBasePositionAndOrientation(self._probe, pos, [0.0, 0.0, 0.0, 1.0],
                                                 physicsClientId=cid)
        pts = pybullet.getClosestPoints(body, self._probe, 0.1 * self._S, physicsClientId=cid)
        if not pts:
            return math.inf
        return (min(p[8] for p in pts) + self._probe_r) / self._S

    # ---------------------------------------------------------------- state queries
    def pose(self, body: int, link: int = -1) -> np.ndarray:
        """World pose (4, 4) of a body's link frame (-1: base = part frame)."""
        cid = self.client_id
        if link == -1:
            p, q = pybullet.getBasePositionAndOrientation(body, physicsClientId=cid)
            return _pose_from_bullet(p, q, self._S) @ self._bodies[body].T_inertial_link
        st = pybullet.getLinkState(body, link, computeForwardKinematics=1, physicsClientId=cid)
        return _pose_from_bullet(st[4], st[5], self._S)

    def set_pose(self, body: int, T_world_body: np.ndarray) -> None:
        """Teleport a body's base link frame to ``T_world_body`` (4, 4)."""
        T_world_inertial = np.asarray(T_world_body, dtype=float) @ self._bodies[body].T_link_inertial
        p, q = pose_to_pq(T_world_inertial)
        pybullet.resetBasePositionAndOrientation(body, [self._S * v for v in p], q,
                                                 physicsClientId=self.client_id)

    def velocity(self, body: int) -> tuple[np.ndarray, np.ndarray]:
        """Linear velocity of the base centre of mass (3,) m/s and angular velocity (3,) rad/s."""
        v, w = pybullet.getBaseVelocity(body, physicsClientId=self.client_id)
        return np.asarray(v, dtype=float) / self._S, np.asarray(w, dtype=float)

    def set_velocity(
        self, body: int, linear_mps: Sequence[float], angular_radps: Sequence[float]
    ) -> None:
        """Set the base velocity (world frame)."""
        pybullet.resetBaseVelocity(
            body, [self._S * float(v) for v in linear_mps], list(angular_radps),
            physicsClientId=self.client_id
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
        pa, pb, nb = a[:, 3:6] / self._S, a[:, 6:9] / self._S, a[:, 9:12]
        dist, fn = a[:, 12] / self._S, a[:, 13] / self._S
        fric = (a[:, 14:15] * a[:, 15:18] + a[:, 18:19] * a[:, 19:22]) / self._S
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

    def gap_m(self, body: int, link: int, max_distance_m: float,
              direction: Sequence[float] | None = None) -> float:
        """Smallest distance (m) from one link of ``body`` to any other body, as Bullet's
        closest points measure it (negative when penetrating), or ``inf`` when nothing is
        within ``max_distance_m``. Candidates come from the broad phase (the link's bounding
        box grown by ``max_distance_m``), so the cost is that of the few bodies near it.
        With ``direction`` (world, unit), only points ahead of a motion along it count
        (normal within 60 deg of facing it): a pad sliding on a table is not "in front" of it.

        Used to bring a moving link into contact without an impact: Bullet creates a
        contact only within the pair's breaking distance (25 um at BALANCED, see the module
        docstring), so a link moving farther than that in one step enters a body before
        the solver sees it (a pad closing at 50 mm/s: 50 um per 1 ms step)."""
        cid = self.client_id
        grow = self._S * float(max_distance_m)
        lo, hi = pybullet.getAABB(body, link, physicsClientId=cid)
        near = pybullet.getOverlappingObjects([v - grow for v in lo], [v + grow for v in hi],
                                              physicsClientId=cid) or ()
        best = math.inf
        for other in sorted({b for b, _ in near if b != body and b != self._probe}):
            pts = pybullet.getClosestPoints(body, other, grow, linkIndexA=link,
                                            physicsClientId=cid)
            for p in pts:
                if direction is not None and float(np.dot(p[7], direction)) > -0.5:
                    continue
                best = min(best, p[8] / self._S)
        return best

    def bodies_near(self, body: int, margin_m: float) -> set[int]:
        """Ids of the other bodies whose bounding boxes overlap ``body``'s (all its links)
        grown by ``margin_m`` (Bullet's broad phase; cheap, conservative)."""
        cid = self.client_id
        grow = self._S * float(margin_m)
        near: set[int] = set()
        for link in range(-1, self._bodies[body].n_links):
            lo, hi = pybullet.getAABB(body, link, physicsClientId=cid)
            found = pybullet.getOverlappingObjects([v - grow for v in lo],
                                                   [v + grow for v in hi],
                                                   physicsClientId=cid) or ()
            near.update(b for b, _ in found if b != body)
        return near

    def sleep(self, body: int, wake_speed_mps: float) -> None:
        """Put a dynamic body to sleep where it is (Bullet deactivation, zero velocity):
        the solver and integrator skip it until an active body's bounding box overlaps its
        own (it is then integrated again; :mod:`asmplan.sim.rest`). Bullet also wakes it
        when, after a step it was integrated in, its squared speed (units^2/s^2 +
        rad^2/s^2) exceeds ``wake_speed_mps`` squared (in Bullet units)."""
        cid = self.client_id
        pybullet.resetBaseVelocity(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=cid)
        pybullet.changeDynamics(body, -1, sleepThreshold=(self._S * float(wake_speed_mps)) ** 2,
                                activationState=pybullet.ACTIVATION_STATE_ENABLE_SLEEPING,
                                physicsClientId=cid)
        pybullet.changeDynamics(body, -1, activationState=pybullet.ACTIVATION_STATE_SLEEP,
                                physicsClientId=cid)

    def hold_static(self, body: int, static: bool) -> None:
        """Make a dynamic body immovable where it is (mass 0 on every link: Bullet then
        treats it as a fixed base and stops solving its contacts with other static bodies)
        or give it back its mass and inertia, from rest (``changeDynamics(mass=...)``;
        :mod:`asmplan.sim.partner_hold`). :meth:`is_static` tells the present state."""
        info = self._bodies[body]
        if info.static:
            raise ValueError(f"hold_static: body {info.name!r} is static from its creation")
        if static == (body in self._held_static):
            return
        cid = self.client_id
        n = info.n_links + 1
        pybullet.resetBaseVelocity(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=cid)
        moments = np.diag(info.T_link_inertial[:3, :3].T @ info.inertia_kgm2
                          @ info.T_link_inertial[:3, :3])
        for link in range(-1, info.n_links):
            if static:
                pybullet.changeDynamics(body, link, mass=0.0, physicsClientId=cid)
            else:
                pybullet.changeDynamics(body, link, mass=info.mass_kg / n,
                                        localInertiaDiagonal=(self._S2 * moments / n).tolist(),
                                        physicsClientId=cid)
        if static:
            self._held_static.add(body)
        else:
            self._held_static.discard(body)
            pybullet.changeDynamics(body, -1, activationState=pybullet.ACTIVATION_STATE_WAKE_UP,
                                    physicsClientId=cid)

    def is_static(self, body: int) -> bool:
        """Whether a body cannot move now: static from its creation or held static
        (:meth:`hold_static`)."""
        return self._bodies[body].static or body in self._held_static

    def max_penetration_m(self, body_a: int) -> float:
        """Deepest penetration among body A's contact points after the last step, m (0 when
        none penetrates); cheaper than ``contacts(body_a).max_penetration_m()``."""
        pts = pybullet.getContactPoints(bodyA=body_a, physicsClientId=self.client_id)
        return max(0.0, -min(c[8] for c in pts) / self._S) if pts else 0.0

    def deepest_contact(self, body_a: int) -> tuple[float, int | None]:
        """Deepest penetration among body A's contact points after the last step, m (0 when
        none penetrates), and the body B of its closest point (None without contacts): what
        ``contacts(body_a)`` gives as ``max_penetration_m()`` and
        ``body_b[argmin(distance_m)]``, without building the arrays."""
        pts = pybullet.getContactPoints(bodyA=body_a, physicsClientId=self.client_id)
        if not pts:
            return 0.0, None
        c = min(pts, key=_contact_distance)
        return max(0.0, -c[8] / self._S), int(c[2])

    def set_friction_anchor(self, body: int, links: Sequence[int], on: bool) -> None:
        """Switch PyBullet's friction anchors (``changeDynamics(frictionAnchor=...)``) on
        or off for ``links`` of ``body``; contacts refreshed from the next step on follow."""
        for link in links:
            pybullet.changeDynamics(body, int(link), frictionAnchor=int(on),
                                    physicsClientId=self.client_id)

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

    def _joint_scales(self, body: int, joints: Sequence[int]) -> tuple[list[float], list[float]]:
        """Per joint, (position scale, force scale) from SI to Bullet units: S and S for a
        prismatic joint (m, N), 1 and S^2 for a revolute one (rad, N m)."""
        key = (body, tuple(joints))
        cached = self._joint_scale_cache.get(key)
        if cached is not None:  # called every step by the gripper's commands
            return cached
        kinds = self._joint_kinds.get(body, ())
        pos, force = [], []
        for j in joints:
            revolute = j < len(kinds) and kinds[j] == "revolute"
            pos.append(1.0 if revolute else self._S)
            force.append(self._S2 if revolute else self._S)
        self._joint_scale_cache[key] = (pos, force)
        return pos, force

    def set_joint_forces(self, body: int, joints: Sequence[int], forces: Sequence[float]) -> None:
        """Apply joint forces (N, prismatic) or torques (N m, revolute) for the next step.

        The velocity motors must be disabled first (:meth:`disable_motors`).
        """
        _, fs = self._joint_scales(body, joints)
        pybullet.setJointMotorControlArray(
            body,
            list(joints),
            pybullet.TORQUE_CONTROL,
            forces=[k * float(f) for k, f in zip(fs, forces, strict=True)],
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
        ps, fs = self._joint_scales(body, joints)
        pybullet.setJointMotorControlArray(
            body,
            list(joints),
            pybullet.VELOCITY_CONTROL,
            targetVelocities=[k * float(v) for k, v in zip(ps, velocities, strict=True)],
            forces=[k * float(f) for k, f in zip(fs, max_forces, strict=True)],
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
        ps, fs = self._joint_scales(body, joints)
        pybullet.setJointMotorControlArray(
            body,
            list(joints),
            pybullet.POSITION_CONTROL,
            targetPositions=[k * float(t) for k, t in zip(ps, targets, strict=True)],
            targetVelocities=[0.0] * n,
            forces=[k * float(f) for k, f in zip(fs, max_forces, strict=True)],
            positionGains=[position_gain] * n,
            velocityGains=[velocity_gain] * n,
            physicsClientId=self.client_id,
        )

    def reset_joints(self, body: int, joints: Sequence[int], positions: Sequence[float]) -> None:
        """Teleport joints to ``positions`` with zero velocity."""
        ps, _ = self._joint_scales(body, joints)
        for j, k, q in zip(joints, ps, positions, strict=True):
            pybullet.resetJointState(body, j, k * float(q), 0.0, physicsClientId=self.client_id)

    def joint_states(self, body: int, joints: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions (m or rad) and velocities (m/s or rad/s), two (len(joints),)."""
        st = pybullet.getJointStates(body, list(joints), physicsClientId=self.client_id)
        ps = np.array(self._joint_scales(body, joints)[0])
        return (np.array([s[0] for s in st], dtype=float) / ps,
                np.array([s[1] for s in st], dtype=float) / ps)

    def set_joint_states(self, body: int, joints: Sequence[int], positions: Sequence[float],
                         velocities: Sequence[float]) -> None:
        """Teleport joints to ``positions`` with ``velocities`` (SI, as :meth:`joint_states`)."""
        ps, _ = self._joint_scales(body, joints)
        for j, k, q, v in zip(joints, ps, positions, velocities, strict=True):
            pybullet.resetJointState(body, j, k * float(q), k * float(v),
                                     physicsClientId=self.client_id)

    def joint_positions(self, body: int, joints: Sequence[int]) -> np.ndarray:
        """Joint positions (m or rad), (len(joints),)."""
        st = pybullet.getJointStates(body, list(joints), physicsClientId=self.client_id)
        ps, _ = self._joint_scales(body, joints)
        return np.array([s[0] for s in st], dtype=float) / np.array(ps)

    def apply_force(
        self, body: int, link: int, force_N: Sequence[float] | np.ndarray,
        position_m: Sequence[float] | np.ndarray,
    ) -> None:
        """Apply a world-frame force at a world point during the next step only."""
        pybullet.applyExternalForce(
            body,
            link,
            [self._S * float(f) for f in force_N],
            [self._S * float(p) for p in position_m],
            pybullet.WORLD_FRAME,
            physicsClientId=self.client_id,
        )

    def com_position_m(self, body: int, link: int = -1) -> np.ndarray:
        """World position of a link's centre of mass, (3,) m."""
        cid = self.client_id
        if link == -1:
            return np.asarray(pybullet.getBasePositionAndOrientation(body, physicsClientId=cid)[0]) / self._S
        st = pybullet.getLinkState(body, link, computeForwardKinematics=1, physicsClientId=cid)
        return np.asarray(st[0]) / self._S

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
        parent_pos = [self._S * v for v in parent_pos]
        pos, quat = pose_to_pq(T_world_target)
        pos = [self._S * v for v in pos]
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
            maxForce=self._S2 * float(max_force_N),
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
            jointChildPivot=[self._S * float(v) for v in position_m],
            jointChildFrameOrientation=list(quat_xyzw),
            maxForce=self._S2 * float(max_force_N),
            physicsClientId=self.client_id,
        )

    def touching_other(self, body: int, allowed: int, allowed_links: Sequence[int]) -> int | None:
        """A body that ``body`` has a contact point with (within the contact distance, after
        the last step) other than links ``allowed_links`` of body ``allowed``; None if none."""
        keep = set(int(k) for k in allowed_links)
        for c in pybullet.getContactPoints(bodyA=body, physicsClientId=self.client_id):
            if c[2] != allowed or c[4] not in keep:
                return int(c[2])
        return None

    def couple_joints(self, body: int, joint_a: int, joint_b: int, max_force_N: float,
                      erp: float = 0.5) -> int:
        """Hold two prismatic joints of ``body`` at equal travel (``q_a = q_b``), as a rack and
        pinion does: a gear constraint (``JOINT_GEAR``, ratio -1) solved with the contacts,
        its internal force bounded by ``max_force_N`` (N), ``erp`` of its drift corrected per
        step. Returns the constraint id."""
        cid = self.client_id
        cons = pybullet.createConstraint(body, joint_a, body, joint_b, pybullet.JOINT_GEAR,
                                         [0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0],
                                         physicsClientId=cid)
        if cons < 0:
            raise BulletError(f"createConstraint(JOINT_GEAR) failed for body "
                              f"{self.body_name(body)!r} joints {joint_a}, {joint_b}")
        pybullet.changeConstraint(cons, gearRatio=-1.0, erp=float(erp),
                                  maxForce=self._S * float(max_force_N), physicsClientId=cid)
        return cons

    def set_coupling_offset(self, cons: int, offset_m: float) -> None:
        """Hold the joints coupled by :meth:`couple_joints` at ``q_a - q_b = offset_m`` (m)
        instead of equal travel (Bullet's gear constraint's ``relativePositionTarget``)."""
        pybullet.changeConstraint(cons, relativePositionTarget=self._S * float(offset_m),
                                  physicsClientId=self.client_id)

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
