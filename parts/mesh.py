"""Triangle meshes, convex hulls and surface sampling with numpy and manifold3d only.

The run path (plan and simulate) needs little of a mesh library: vertices and faces, the mass
properties of a closed mesh, bounds, convex hulls and seeded surface samples. Importing
trimesh for that cost ~0.5 s per run (it imports scipy.spatial, scipy.special and
scipy.optimize), a quarter of the seed workstation's whole FAST run. This module does the same
arithmetic without it:

* :class:`TriangleMesh` computes volume, centre of mass and inertia with the same formulas,
  in the same order, as ``trimesh.triangles.mass_properties`` (Eberly, "Polyhedral Mass
  Properties"), so the figures are bit-identical to trimesh's for the same vertices and faces.
* :func:`sample_surface` is ``trimesh.sample.sample_surface`` (area-weighted faces, uniform
  points in each) step by step: the same seed gives the same points, so grasps do not change.
* Convex hulls come from manifold3d's QuickHull (``Manifold.hull_points``), whose vertices
  are input points, bit for bit. :func:`hull_vertex_indices` lists them in input order, as
  scipy's ``ConvexHull.vertices`` does in 3-D.

trimesh stays the reader of mesh files and the report's mesh type (``TriangleMesh.to_trimesh``).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from ..errors import AsmplanError

_TOL_ZERO = float(np.finfo(np.float64).resolution * 100)  # trimesh.util.TOL_ZERO, 1e-13
_TOL_MERGE = 1e-8  # trimesh.constants.tol.merge


def _row_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product, summed as trimesh.util.diagonal_dot sums it."""
    return np.dot(a * b, [1.0] * a.shape[1])


def _unitize(vectors: np.ndarray, check_valid: bool = False):
    """Rows scaled to unit length (rows shorter than 1e-13 kept); trimesh.util.unitize for
    (n, d) arrays, operation for operation."""
    norm = np.sqrt(np.dot(vectors * vectors, [1.0] * vectors.shape[1]))
    valid = norm > _TOL_ZERO
    norm[valid] **= -1
    unit = vectors * norm.reshape((-1, 1))
    if check_valid:
        return unit[valid], valid
    return unit


class DegenerateHullError(AsmplanError, ValueError):
    """The points span no volume (fewer than 4 points, or all on one plane or line)."""


class TriangleMesh:
    """A triangle mesh (metres), with the properties the planner and simulator use.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
        Vertex indices; counter-clockwise seen from outside for a closed mesh (volume and
        inertia assume it).

    Both arrays are copied and made read-only; derived properties are computed on first use.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        v = np.array(vertices, dtype=np.float64)
        f = np.array(faces, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ValueError(f"TriangleMesh.vertices: expected shape (n, 3), found {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise ValueError(f"TriangleMesh.faces: expected shape (m, 3), found {f.shape}")
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise ValueError(f"TriangleMesh.faces: expected indices in [0, {len(v)}), found "
                             f"[{f.min()}, {f.max()}]")
        v.setflags(write=False)
        f.setflags(write=False)
        self.vertices = v
        self.faces = f

    def __repr__(self) -> str:
        return f"TriangleMesh({len(self.vertices)} vertices, {len(self.faces)} faces)"

    @classmethod
    def from_manifold(cls, solid) -> TriangleMesh:
        """The mesh (float64) of a manifold3d solid."""
        mesh = solid.to_mesh64()
        return cls(np.asarray(mesh.vert_properties, dtype=float)[:, :3],
                   np.asarray(mesh.tri_verts, dtype=np.int64))

    def to_trimesh(self):
        """The same mesh as a ``trimesh.Trimesh`` (unprocessed)."""
        import trimesh

        return trimesh.Trimesh(self.vertices.copy(), self.faces.copy(), process=False)

    # -- per face -------------------------------------------------------------------------------
    @cached_property
    def triangles(self) -> np.ndarray:
        """(m, 3, 3) corner coordinates of every face."""
        return self.vertices[self.faces]

    @cached_property
    def triangles_cross(self) -> np.ndarray:
        """(m, 3) cross product of the two edges from each face's first corner (2 x area along
        the normal)."""
        tri = self.triangles
        vectors = tri[:, 1:, :] - tri[:, :2, :]
        return np.cross(vectors[:, 0], vectors[:, 1])

    @cached_property
    def area_faces(self) -> np.ndarray:
        """(m,) face areas, m^2."""
        return np.sqrt((self.triangles_cross**2).sum(axis=1)) / 2.0

    @cached_property
    def face_normals(self) -> np.ndarray:
        """(m, 3) outward unit normals; zero for a degenerate face (as trimesh)."""
        unit, valid = _unitize(self.triangles_cross, check_valid=True)
        if valid.all():
            return unit
        padded = np.zeros((len(self.faces), 3), dtype=np.float64)
        padded[valid] = unit
        return padded

    @cached_property
    def face_angles(self) -> np.ndarray:
        """(m, 3) interior angle at each corner of each face, rad (all zero for a face with a
        corner below 1e-8 rad, as trimesh)."""
        tri = self.triangles
        u = _unitize(tri[:, 1] - tri[:, 0])
        v = _unitize(tri[:, 2] - tri[:, 0])
        w = _unitize(tri[:, 2] - tri[:, 1])
        result = np.zeros((len(tri), 3), dtype=np.float64)
        result[:, 0] = np.arccos(np.clip(_row_dot(u, v), -1, 1))
        result[:, 1] = np.arccos(np.clip(_row_dot(-u, w), -1, 1))
        result[:, 2] = np.pi - result[:, 0] - result[:, 1]
        result[(result < _TOL_MERGE).any(axis=1), :] = 0.0
        return result

    @cached_property
    def vertex_normals(self) -> np.ndarray:
        """(n, 3) unit normals at the vertices: the normals of the faces around each vertex
        weighted by the face's angle there (trimesh's ``weighted_vertex_normals``, summed in
        the same order); zero for a vertex no face uses."""
        normals = self.face_normals
        ok = (normals**2).sum(axis=1) > 0.5
        faces, normals, angles = self.faces[ok], normals[ok], self.face_angles[ok]
        summed = np.zeros((len(self.vertices), 3), dtype=np.float64)
        # face by face, corner by corner: the order scipy's sparse product adds them in
        np.add.at(summed, faces.reshape(-1), angles.reshape(-1, 1) * np.repeat(normals, 3, axis=0))
        return _unitize(summed)

    @property
    def area(self) -> float:
        """Surface area, m^2."""
        return float(self.area_faces.sum())

    # -- extent ---------------------------------------------------------------------------------
    @cached_property
    def bounds(self) -> np.ndarray:
        """(2, 3) lowest and highest corner of the axis-aligned bounding box, m."""
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    @property
    def extents(self) -> np.ndarray:
        """(3,) size of the axis-aligned bounding box, m."""
        lo, hi = self.bounds
        return hi - lo

    # -- mass properties (density 1) ------------------------------------------------------------
    @cached_property
    def _integrals(self) -> np.ndarray:
        # trimesh.triangles.mass_properties, term for term, so results are bit-identical
        tri = self.triangles
        crosses = self.triangles_cross
        f1 = tri[:, 0, :] + tri[:, 1, :] + tri[:, 2, :]
        f2 = tri[:, 0, :] ** 2 + tri[:, 1, :] ** 2 + tri[:, 0, :] * tri[:, 1, :] + tri[:, 2, :] * f1
        f3 = ((tri[:, 0, :] ** 3) + (tri[:, 0, :] ** 2) * (tri[:, 1, :])
              + (tri[:, 0, :]) * (tri[:, 1, :] ** 2) + (tri[:, 1, :] ** 3) + (tri[:, 2, :] * f2))
        g0 = f2 + (tri[:, 0, :] + f1) * tri[:, 0, :]
        g1 = f2 + (tri[:, 1, :] + f1) * tri[:, 1, :]
        g2 = f2 + (tri[:, 2, :] + f1) * tri[:, 2, :]
        integral = np.zeros((10, len(f1)))
        integral[0] = crosses[:, 0] * f1[:, 0]
        integral[1:4] = (crosses * f2).T
        integral[4:7] = (crosses * f3).T
        for i in range(3):
            j = np.mod(i + 1, 3)
            integral[i + 7] = crosses[:, i] * ((tri[:, 0, j] * g0[:, i]) + (tri[:, 1, j] * g1[:, i])
                                              + (tri[:, 2, j] * g2[:, i]))
        return integral.sum(axis=1) / np.array([6, 24, 24, 24, 60, 60, 60, 120, 120, 120],
                                               dtype=np.float64)

    @property
    def volume(self) -> float:
        """Enclosed volume, m^3 (negative when the faces point inwards)."""
        return float(self._integrals[0])

    @cached_property
    def center_mass(self) -> np.ndarray:
        """(3,) centre of mass of the enclosed volume (uniform density), m."""
        return self._integrals[1:4] / self._integrals[0]

    @cached_property
    def moment_inertia(self) -> np.ndarray:
        """(3, 3) inertia tensor about the centre of mass for density 1, m^5."""
        integrated = self._integrals
        volume, c = integrated[0], self.center_mass
        inertia = np.zeros((3, 3))
        inertia[0, 0] = integrated[5] + integrated[6] - (volume * (c[[1, 2]] ** 2).sum())
        inertia[1, 1] = integrated[4] + integrated[6] - (volume * (c[[0, 2]] ** 2).sum())
        inertia[2, 2] = integrated[4] + integrated[5] - (volume * (c[[0, 1]] ** 2).sum())
        inertia[0, 1] = -(integrated[7] - (volume * np.prod(c[[0, 1]])))
        inertia[1, 2] = -(integrated[8] - (volume * np.prod(c[[1, 2]])))
        inertia[0, 2] = -(integrated[9] - (volume * np.prod(c[[0, 2]])))
        inertia[2, 0] = inertia[0, 2]
        inertia[2, 1] = inertia[1, 2]
        inertia[1, 0] = inertia[0, 1]
        return inertia

    # -- derived meshes -------------------------------------------------------------------------
    @cached_property
    def convex_hull(self) -> TriangleMesh:
        """The convex hull of the vertices (raises :class:`DegenerateHullError` if flat)."""
        return convex_hull(self.vertices)


def _hull(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hull vertices (k, 3) and outward faces (f, 3) indexing them, from manifold3d."""
    import manifold3d as m3

    pts = np.ascontiguousarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"convex hull points: expected shape (n, 3), found {pts.shape}")
    if len(pts) < 4 or not np.all(np.isfinite(pts)):
        raise DegenerateHullError(f"convex hull: expected >= 4 finite points spanning a volume, "
                                  f"found {len(pts)} points")
    solid = m3.Manifold.hull_points(pts)
    if solid.is_empty() or not solid.volume() > 0:
        raise DegenerateHullError(f"convex hull: the {len(pts)} points span no volume "
                                  "(all on one plane or line)")
    mesh = solid.to_mesh64()
    return (np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3],
            np.asarray(mesh.tri_verts, dtype=np.int64))


def convex_hull(points: np.ndarray) -> TriangleMesh:
    """The convex hull of ``points`` (n, 3) as a closed mesh with outward faces.

    Raises
    ------
    DegenerateHullError
        Fewer than 4 points, or all on one plane or line.
    """
    vertices, faces = _hull(points)
    return TriangleMesh(vertices, faces)


def _input_indices(points: np.ndarray, hull_vertices: np.ndarray) -> np.ndarray:
    """Index in ``points`` of every hull vertex (its first occurrence; hull vertices are input
    points bit for bit)."""
    first: dict[bytes, int] = {}
    pts = np.ascontiguousarray(points, dtype=np.float64)
    for i, row in enumerate(pts):
        first.setdefault(row.tobytes(), i)
    try:
        return np.array([first[row.tobytes()] for row in np.ascontiguousarray(hull_vertices)],
                        dtype=np.int64)
    except KeyError as exc:  # not expected from QuickHull; say so rather than guess
        raise RuntimeError("convex hull: a hull vertex is not one of the input points") from exc


def hull_vertex_indices(points: np.ndarray) -> np.ndarray:
    """Indices (k,) of the points that are hull vertices, ascending (input order)."""
    vertices, _ = _hull(points)
    return np.sort(_input_indices(points, vertices))


def hull_faces(points: np.ndarray) -> np.ndarray:
    """Hull faces (f, 3) as indices into ``points``, outward (counter-clockwise from outside)."""
    vertices, faces = _hull(points)
    return _input_indices(points, vertices)[faces]


def sample_surface(mesh, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` points on the surface of ``mesh``, faces picked by area: (count, 3) points
    and (count,) face indices.

    ``trimesh.sample.sample_surface(mesh, count, seed=seed)`` step by step (same random draws
    in the same order), so the same seed gives the same points. ``mesh`` needs ``vertices``,
    ``faces`` and ``area_faces`` (a :class:`TriangleMesh` or a ``trimesh.Trimesh``).
    """
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces)
    weight_cum = np.cumsum(mesh.area_faces)
    random = np.random.default_rng(seed).random
    face_pick = random(count) * weight_cum[-1]
    face_index = np.searchsorted(weight_cum, face_pick)
    tri_origins = vertices[faces[:, 0]]
    tri_vectors = vertices[faces[:, 1:]].copy()
    tri_vectors -= np.tile(tri_origins, (1, 2)).reshape((-1, 2, 3))
    tri_origins = tri_origins[face_index]
    tri_vectors = tri_vectors[face_index]
    random_lengths = random((len(tri_vectors), 2, 1))
    random_test = random_lengths.sum(axis=1).reshape(-1) > 1.0
    random_lengths[random_test] -= 1.0
    random_lengths = np.abs(random_lengths)
    sample_vector = (tri_vectors * random_lengths).sum(axis=1)
    return sample_vector + tri_origins, face_index


__all__ = [
    "DegenerateHullError",
    "TriangleMesh",
    "convex_hull",
    "hull_faces",
    "hull_vertex_indices",
    "sample_surface",
]
