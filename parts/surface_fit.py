"""Analytic surfaces of a part (:class:`Surface`: planes, cylinders, cones) fitted to a
triangle mesh by region growing, with the line and circle geometry the recognition shares."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Surface:
    """An analytic surface patch of a part, in the part frame (metres).

    Cylinder and cone: ``point_m`` on the axis, unit ``axis``, extent ``t0_m``..``t1_m``
    along the axis from ``point_m``, ``radius_m`` (a cone's largest radius in the patch,
    ``radius_min_m`` its smallest), ``inner`` when the material is outside (a hole's wall),
    ``span_rad`` the angle the patch covers. Plane: ``point_m`` on it, ``axis`` the outward
    normal, ``offset_m`` = normal . point.
    """

    kind: str
    point_m: np.ndarray
    axis: np.ndarray
    radius_m: float
    inner: bool
    t0_m: float
    t1_m: float
    span_rad: float
    radius_min_m: float = 0.0
    semi_angle_rad: float = 0.0
    offset_m: float = 0.0
    area_m2: float = 0.0
    residual_m: float = 0.0
    evidence: str = ""


# ---------------------------------------------------------------------------------------------
# Geometry helpers
# ---------------------------------------------------------------------------------------------
def _unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def line_distance(p: np.ndarray, a: np.ndarray, q: np.ndarray) -> float:
    """Distance of point ``q`` from the line through ``p`` along unit ``a``."""
    d = q - p
    return float(np.linalg.norm(d - a * np.dot(d, a)))


def _parallel(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    return abs(float(np.dot(a, b))) >= math.cos(tol)


# ---------------------------------------------------------------------------------------------
# Fitting surfaces to a mesh
# ---------------------------------------------------------------------------------------------
def _circle_fit(xy: np.ndarray) -> tuple[np.ndarray, float]:
    A = np.column_stack([2 * xy, np.ones(len(xy))])
    b = (xy ** 2).sum(axis=1)
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    c = sol[:2]
    return c, float(math.sqrt(max(sol[2] + c @ c, 0.0)))


def _basis(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
    u /= np.linalg.norm(u)
    return u, np.cross(a, u)


def _fit_cylinder(V: np.ndarray, a0: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Least-squares cylinder through points ``V`` starting from axis ``a0``:
    (point on axis, axis, radius, rms residual)."""
    from scipy.optimize import least_squares

    u, w = _basis(a0)
    centre = V.mean(axis=0)
    X = V - centre
    c2, r0 = _circle_fit(np.column_stack([X @ u, X @ w]))
    p0 = centre + c2[0] * u + c2[1] * w

    def residual(x):
        a = _unit(a0 + x[0] * u + x[1] * w)
        p = p0 + x[2] * u + x[3] * w
        d = V - p
        return np.linalg.norm(d - np.outer(d @ a, a), axis=1) - x[4]

    sol = least_squares(residual, [0, 0, 0, 0, r0], x_scale=[1e-3, 1e-3, r0 * 1e-3, r0 * 1e-3, r0],
                        xtol=1e-15, ftol=1e-15, gtol=1e-15)
    x = sol.x
    a = _unit(a0 + x[0] * u + x[1] * w)
    p = p0 + x[2] * u + x[3] * w
    return p, a, float(x[4]), float(np.sqrt(np.mean(sol.fun ** 2)))


# Complexity above C (radon): region growing, then one classification per region (plane,
# cylinder, cone), each with its own fit and acceptance test.
def fit_mesh_surfaces(vertices_m: np.ndarray, faces: np.ndarray, *, smooth_angle_deg: float = 25.0,
                      min_faces: int = 6) -> list[Surface]:
    """Planes, cylinders and cones fitted to a closed triangle mesh.

    The mesh is split into smooth regions (neighbouring triangles within ``smooth_angle_deg``);
    a region whose normals are one direction is a plane; one whose normals are perpendicular to
    a common axis is a cylinder, fitted by least squares to its vertices (a tessellation's
    vertices lie on the CAD surface, so the fit recovers the CAD radius); a region whose
    normals keep one angle to an axis is a cone.
    """
    import trimesh
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    mesh = trimesh.Trimesh(vertices_m, faces, process=False)
    normals = mesh.face_normals
    areas = mesh.area_faces
    adj = mesh.face_adjacency
    ang = mesh.face_adjacency_angles
    keep = ang < math.radians(smooth_angle_deg)
    n = len(faces)
    g = coo_matrix((np.ones(int(keep.sum())), (adj[keep, 0], adj[keep, 1])), shape=(n, n))
    _, labels = connected_components(g, directed=False)
    out: list[Surface] = []
    # a flat face that continues a curve tangentially (a slot's wall between its two half
    # cylinders) joins the curve's region: split such regions at their large coplanar facets
    facet_of = np.full(n, -1)
    for k, fc in enumerate(mesh.facets):
        facet_of[fc] = k
    facet_area = mesh.facets_area
    labels = labels.copy()
    next_label = int(labels.max()) + 1 if n else 0
    for lab in np.unique(labels):
        idx = np.flatnonzero(labels == lab)
        ks = np.unique(facet_of[idx])
        ks = ks[ks >= 0]
        if len(ks) < 3:
            continue
        areas_k = facet_area[ks]
        big = ks[areas_k > 4.0 * np.median(areas_k)]
        if len(big) == 0 or len(big) == len(ks):
            continue
        flat = np.isin(facet_of[idx], big)
        rest = idx[~flat]
        sub = np.isin(adj[:, 0], rest) & np.isin(adj[:, 1], rest) & keep
        gs = coo_matrix((np.ones(int(sub.sum())), (adj[sub, 0], adj[sub, 1])), shape=(n, n))
        _, sub_labels = connected_components(gs, directed=False)
        for comp in np.unique(sub_labels[rest]):
            labels[rest[sub_labels[rest] == comp]] = next_label
            next_label += 1
        for k in big:
            labels[idx[facet_of[idx] == k]] = next_label
            next_label += 1
    order = np.argsort(labels, kind="stable")
    splits = np.flatnonzero(np.diff(labels[order])) + 1
    for idx in np.split(order, splits):
        N = normals[idx]
        W = areas[idx]
        vids = np.unique(faces[idx])
        V = vertices_m[vids]
        mean_n = (N * W[:, None]).sum(axis=0)
        if np.linalg.norm(mean_n) > 0 and np.all(N @ _unit(mean_n) > math.cos(math.radians(0.5))):
            nrm = _unit(mean_n)
            c = 0.5 * (V.min(axis=0) + V.max(axis=0))  # the patch's box centre (a hole in it
            c = c - nrm * float(nrm @ (c - V.mean(axis=0)))  # does not move it), on the plane
            out.append(Surface("plane", c, nrm, 0.0, False, 0.0, 0.0, 0.0, offset_m=float(nrm @ c),
                               area_m2=float(W.sum()), evidence=f"plane fitted to {len(idx)} triangles"))
            continue
        if len(idx) < min_faces:
            continue
        M = (N * W[:, None]).T @ N
        evals, evecs = np.linalg.eigh(M)
        a0 = evecs[:, 0]
        cosines = N @ a0
        face_c = mesh.triangles_center[idx]
        if np.max(np.abs(cosines)) >= 0.2:
            # a cone's axis is the eigenvector whose eigenvalue stands apart from the other two
            gaps = [min(abs(evals[i] - evals[j]) for j in range(3) if j != i) for i in range(3)]
            a0 = evecs[:, int(np.argmax(gaps))]
            cosines = N @ a0
        if np.max(np.abs(cosines)) < 0.2:
            p, a, r, rms = _fit_cylinder(V, a0)
            if rms > 1e-3 * r + 1e-7:
                continue
            d = face_c - p
            radial = d - np.outer(d @ a, a)
            inner = float(np.sum(np.einsum("ij,ij->i", radial, N) * W)) < 0
            t = (V - p) @ a
            u, w = _basis(a)
            X = V - p
            ang_v = np.sort(np.arctan2(X @ w, X @ u))
            ang_gaps = np.diff(np.concatenate([ang_v, [ang_v[0] + 2 * math.pi]]))
            span = 2 * math.pi - float(ang_gaps.max())
            out.append(Surface("cylinder", p, a, r, inner, float(t.min()), float(t.max()), span,
                               area_m2=float(W.sum()), residual_m=rms,
                               evidence=f"cylinder fitted to {len(vids)} vertices, rms {rms * 1e6:.2g} um"))
            continue
        # a cone: normals at one angle to an axis; the axis is the direction the normals'
        # cosines vary least about
        spread = float(np.std(cosines))
        if spread < 0.02 and 0.2 < abs(float(np.mean(cosines))) < 0.98:
            a = a0 * (1 if np.mean(cosines) > 0 else -1)
            # axis line: least squares through the normals' lines
            A = np.zeros((3, 3))
            b = np.zeros(3)
            for nn, cc in zip(N, face_c, strict=True):
                P = np.eye(3) - np.outer(nn, nn)
                A += P
                b += P @ cc
            apex_line = np.linalg.lstsq(A + np.outer(a, a), b, rcond=None)[0]
            X = V - apex_line
            t = X @ a
            r = np.linalg.norm(X - np.outer(t, a), axis=1)
            d = face_c - apex_line
            radial = d - np.outer(d @ a, a)
            inner = float(np.sum(np.einsum("ij,ij->i", radial, N) * W)) < 0
            out.append(Surface("cone", apex_line, a, float(r.max()), inner, float(t.min()), float(t.max()),
                               2 * math.pi, radius_min_m=float(r.min()),
                               semi_angle_rad=math.acos(min(1.0, abs(float(np.mean(cosines))))),
                               area_m2=float(W.sum()), evidence=f"cone fitted to {len(vids)} vertices"))
    return out
