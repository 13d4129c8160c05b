"""Antipodal grasps for a parallel two-finger gripper.

Candidates
----------
A grasp is a gripper TCP frame in the part frame (``T_part_gripper``; z approach, y closing
axis, origin between the pad faces; see :mod:`asmplan.planner.trajectory`) and a width. The
search works on the part's surface, sampled with normals (any mesh: boxes, cylinders,
composites with holes, imported meshes):

1. closing axes: the knowledge hint's ``closing_axis``; the normals of large opposite planar
   faces; the part frame's axes and the principal axes of the surface (exact, from the mesh;
   those with equal second moments, a turned part's radial ones, left out:
   :func:`principal_axes`); for cylinders, the axis and radial directions every 45 deg;
2. approach axes: perpendicular to the closing axis every 45 deg, starting from "down" at the
   start pose (and the hint's ``approach_axis``);
3. offsets of the pad centre along the approach axis (steps of a sixth of the finger length)
   and along the finger width (half-finger steps on parts wider than a finger; centred or
   sticking out on one side only, its other edge 1 mm inside the part, or covering only one
   end of the part in steps of an eighth of a finger width or 1 mm, on narrower ones),
   centred on the centre of mass.

For each candidate the pads are the finger boxes' inner faces, ``width x length`` rectangles
(gripper x, z) centred on the TCP. The surface points inside a pad's footprint prism decide
the contact: the outermost points along the closing axis touch the pads; those within
``CONTACT_BAND_M`` of the extreme make the pad's contact patch, and their normals must lie
inside the friction cone (``mu = finger friction * part friction``) of the closing direction.
Rejected: no contact on one side, a normal outside the cone, a width beyond the stroke (minus
the opening clearance on both sides), any surface point inside the palm box, and (with a
:class:`GripLoad`) a grip that cannot hold the part: the clamp force per finger that carries
its weight and inertia, as force and as moment about the contact patches (torsional friction
of the patches, tipping about the contact line; :mod:`asmplan.planner.grasp_hold`), above the
force limit.

Ranking
-------
``cost = 10 [not the hint] + 2 [closing axis not the hint's] + 1 [fingertips lead the part
into its mate] + (1 - F_slide / F_hold) + 0.25 (1 - down_start . approach)
+ 0.25 (1 - down_final . approach)``: knowledge hints first, then grasps whose fingers stay
behind the mating face, with the largest holding margin, coming from above at both poses.
``F_hold`` is the clamp force the grasp needs and ``F_slide`` what a grasp with no moment
would need (the load alone), so the term is 0 for a grasp whose patches surround the centre of
mass and grows towards 1 as the moment about small patches dominates; for one part, ranking by
it is ranking by the margin ``force limit / F_hold``. Without a load the term is computed for
a unit mass at 5 m/s^2.

Finger collisions with the partial assembly and the table at the start and final poses are
judged by :func:`collision_free` with a checker supplied by :mod:`asmplan.planner.motion`.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..knowledge.model import GraspHint, Gripper
from ..parts.mesh import TriangleMesh, sample_surface
from .errors import CollidingPair
from .grasp_hold import (
    GripLoad,
    HoldInputs,
    HoldRejections,
    hold_lower_bound,
    hold_requirement,
    hold_term,
)
from .grasp_pads import CONTACT_BAND_M as CONTACT_BAND_M
from .grasp_pads import Frame, Strip, evaluate
from .grasp_patch import FrameTriangles
from .plan import Grasp

_MAX_OFFSETS = 41  # pad centres per axis and candidate frame (the whole part, every depth)
_END_STEP_M = 1e-3  # finest step of a finger covering only an end of a narrow part
_EDGE_INSET_M = 1e-3  # a finger sticking out on one side keeps its other edge this far in
_STOP_GAP_M = 2.5e-4  # fingertips stopped this far short of the lead limit
_ANGLE_STEP_RAD = math.pi / 4


@dataclass(frozen=True, eq=False)
class GraspSurface:
    """Surface samples of a part in its own frame.

    Parameters
    ----------
    points_m : (n, 3) float array
        Surface points, m, part frame.
    normals : (n, 3) float array
        Outward unit normals at the points.
    area_per_point_m2 : float
        Surface area represented by one sample, m^2.
    com_m : (3,) float array
        Centre of mass, part frame, m.
    kind : str
        Geometry kind ("box", "cylinder", "composite", "mesh", ...); cylinders add radial
        closing axes about their local z axis.
    n_area : int, optional
        The first ``n_area`` points are area samples (face normals); the rest are mesh
        vertices, whose averaged normals on edges say nothing about the faces a pad touches
        (the friction-cone test uses the area samples where a pad has enough of them).
    mesh : TriangleMesh, optional
        The part's mesh (part frame): a pad's contact patch with few samples is measured on
        it (:mod:`asmplan.planner.grasp_patch`); without it, on the samples.
    """

    points_m: np.ndarray
    normals: np.ndarray
    area_per_point_m2: float
    com_m: np.ndarray
    kind: str = "mesh"
    n_area: int | None = None
    mesh: TriangleMesh | None = field(default=None, repr=False)
    axes_cache: dict[float, list[np.ndarray]] = field(default_factory=dict, repr=False)

    @classmethod
    def from_mesh(cls, mesh, com_m: np.ndarray, n_samples: int, seed: int,
                  kind: str = "mesh") -> GraspSurface:
        """Sample ``n_samples`` surface points (area-uniform, seeded) plus the vertices.

        ``mesh`` is a :class:`~asmplan.parts.mesh.TriangleMesh`; anything else with
        ``vertices`` and ``faces`` (a trimesh) is read as one, with the same samples."""
        if not isinstance(mesh, TriangleMesh):
            mesh = TriangleMesh(mesh.vertices, mesh.faces)
        pts, face = sample_surface(mesh, int(n_samples), seed=int(seed))
        normals = mesh.face_normals[face]
        # vertices make the extreme points (box corners and edges) exact
        vn = mesh.vertex_normals
        pts = np.vstack([pts, mesh.vertices])
        normals = np.vstack([normals, vn])
        return cls(points_m=np.asarray(pts, float), normals=np.asarray(normals, float),
                   area_per_point_m2=float(mesh.area) / float(n_samples),
                   com_m=np.asarray(com_m, float), kind=kind, n_area=int(n_samples), mesh=mesh)


def _clip(x: float, lo: float, hi: float) -> float:
    """``float(np.clip(x, lo, hi))`` for one number (same result, also for ``lo > hi`` and
    signed zeros), without numpy's per-call cost."""
    m = lo if lo > x else x
    return float(hi if hi < m else m)


def _unit(v: np.ndarray) -> np.ndarray:
    return np.asarray(v, float) / float(np.linalg.norm(v))


def _perpendicular(c: np.ndarray, prefer: np.ndarray | None) -> np.ndarray:
    if prefer is not None:
        p = prefer - np.dot(prefer, c) * c
        if np.linalg.norm(p) > 1e-6:
            return _unit(p)
    for axis in np.eye(3):
        p = axis - np.dot(axis, c) * c
        if np.linalg.norm(p) > 0.5:
            return _unit(p)
    raise AssertionError("unreachable: some axis is not parallel to c")


def closing_axes(surface: GraspSurface, hint: GraspHint | None, min_area_fraction: float = 0.03
                 ) -> list[np.ndarray]:
    """Candidate closing axes (unit, part frame), deduplicated up to sign, hint first."""
    cands: list[np.ndarray] = []
    if hint is not None and hint.closing_axis is not None:
        cands.append(_unit(hint.closing_axis))
    cands.extend(_geometric_axes(surface, min_area_fraction))
    out: list[np.ndarray] = []
    for c in cands:
        c = np.where(np.abs(c) < 1e-12, 0.0, c)
        if all(abs(float(np.dot(c, o))) < 0.999 for o in out):
            out.append(c)
    return out


def _geometric_axes(surface: GraspSurface, min_area_fraction: float) -> list[np.ndarray]:
    """Closing axes from the geometry alone (cached on the surface)."""
    cache = surface.axes_cache
    if min_area_fraction in cache:
        return cache[min_area_fraction]
    cands: list[np.ndarray] = []
    # large planar faces with an opposite face: cluster sample normals on a 0.02 grid
    n = surface.normals[: surface.points_m.shape[0]]
    # the rows (unit normals / 0.02: within +-50) as one integer each, in the same
    # lexicographic order as np.unique(..., axis=0) gives them, without its row sort
    cells = np.round(n / 0.02).astype(np.int64) + 64
    codes, counts = np.unique((cells[:, 0] << 14) | (cells[:, 1] << 7) | cells[:, 2],
                              return_counts=True)
    keys = np.stack([(codes >> 14) & 127, (codes >> 7) & 127, codes & 127], axis=1) - 64
    order = np.argsort(-counts, kind="stable")
    total = float(len(n))
    key_set = {tuple(k): c for k, c in zip(keys.tolist(), counts.tolist(), strict=True)}
    for i in order:
        if counts[i] / total < min_area_fraction:
            break
        opposite = tuple((-keys[i]).tolist())
        if opposite in key_set and key_set[opposite] / total >= min_area_fraction:
            cands.append(_unit(keys[i].astype(float)))
    if surface.kind != "cylinder":  # the part's own axes, then principal axes of its surface
        cands.extend(np.eye(3))
        cands.extend(principal_axes(surface))
    else:  # radial directions and the axis
        for k in range(4):
            a = k * _ANGLE_STEP_RAD
            cands.append(np.array([math.cos(a), math.sin(a), 0.0]))
        cands.append(np.array([0.0, 0.0, 1.0]))
    cache[min_area_fraction] = cands
    return cands


PRINCIPAL_GAP = 1e-6
"""Relative difference of two second moments of the surface below which their principal
axes are taken as undetermined (a turned part's two radial ones)."""


def principal_axes(surface: GraspSurface) -> list[np.ndarray]:
    """The principal axes of the part's surface (unit, part frame), largest second moment
    first, each whose second moment equals another's (within ``PRINCIPAL_GAP``) left out.

    With the mesh, the area's second moments are exact (per triangle ``A / 12 (sum p_i
    p_i^T + s s^T)``, ``s`` the sum of its corners); without it, those of the samples. The
    samples' axes scatter with the sampling: with 3000 samples the gearbox bearing's radial
    ones came out 0.26 deg out of its flange plane (the approach 0.26 deg off its axis),
    the drawer's 3.6 deg off its own axes, and a turned part's two radial axes are any pair
    (equal moments): the part's own axes, listed first, already give them."""
    mesh = surface.mesh
    if mesh is None:
        pts = surface.points_m - surface.points_m.mean(axis=0)
        _, vecs = np.linalg.eigh(pts.T @ pts)
        return [_unit(vecs[:, k]) for k in (2, 1, 0)]
    tri = mesh.triangles
    area = mesh.area_faces
    s = tri.sum(axis=1)
    total = float(area.sum())
    centroid = (area[:, None] * s).sum(axis=0) / (3.0 * total)
    second = (np.einsum("f,fki,fkj->ij", area, tri, tri)
              + np.einsum("f,fi,fj->ij", area, s, s)) / 12.0
    w, vecs = np.linalg.eigh(second - total * np.outer(centroid, centroid))
    scale = max(float(np.abs(w).max()), 1e-300)
    return [_unit(vecs[:, k]) for k in (2, 1, 0)
            if all(abs(float(w[k] - w[j])) > PRINCIPAL_GAP * scale for j in range(3) if j != k)]


# Complexity above C (radon): a lazy best-first generator: hint, faces, finger placements and the lead
# limit are filtered inline so that a rejected candidate costs nothing.
def iter_grasps(
    part: str,
    surface: GraspSurface,
    gripper: Gripper,
    hint: GraspHint | None = None,
    *,
    part_friction: float = 0.5,
    finger_clearance_m: float = 3e-3,
    down_start_part: np.ndarray | None = None,
    down_final_part: np.ndarray | None = None,
    min_overlap_m: float | None = None,
    insertion_part: np.ndarray | None = None,
    lead_limit_m: float | None = None,
    load: GripLoad | None = None,
    table_poses: Sequence[np.ndarray] = (),
    table_margin_m: float = 0.0,
    stats: dict[str, int] | None = None,
    hold_rejections: HoldRejections | None = None,
) -> Iterator[Grasp]:
    """Antipodal grasps of one part in increasing cost (see the module docstring), lazily.

    Every cost term except the contact-area term is known before a candidate is evaluated
    and the area term is >= 0, so candidates are evaluated best-first by that lower bound and
    a grasp is yielded once no unevaluated candidate can beat it: the order is exactly the
    full ranking, but only the candidates needed are evaluated.

    Parameters
    ----------
    part : str
    surface : GraspSurface
        The part's surface samples, part frame.
    gripper : Gripper
        Stroke, finger size (width x, thickness y, length z), palm size.
    hint : GraspHint, optional
        The part's handling knowledge.
    part_friction : float
        The part's friction coefficient (multiplied with the finger's).
    finger_clearance_m : float
        Opening added per finger beyond the part's width to approach and release, m.
    down_start_part, down_final_part : (3,) float arrays, optional
        World "down" (-z) expressed in the part frame at the start and final poses.
    min_overlap_m : float, optional
        Smallest overlap of a pad with the part along the approach axis, m; default 2 mm (a
        3 mm flange in front of a wall, the fingertips kept clear of the wall), or a quarter
        of the pad length for pads shorter than 8 mm (a short pad on a 3 mm head). Whether
        the contact is enough to hold the part is the load's question (below).
    insertion_part, lead_limit_m : (3,) float array and float, optional
        The insertion direction in the part frame and how far along it (from the centre of
        mass, m) the fingers may reach: grasps whose fingertips would lead the part into its
        mate (reach past the pin roots, or past a hole part's leading face) cost 1 more.
    load : GripLoad, optional
        Mass, acceleration, force limit and safety factor: a grasp whose contact patches need
        more clamp force than the limit to hold the part is rejected (counted in
        ``hold_rejections``); without it the ranking's hold term uses a unit load.
    table_poses : sequence of (4, 4) float arrays, optional
        World poses of the part (start, assembled) at which the fingers must stay
        ``table_margin_m`` above the table top (z = 0): a candidate whose lower finger is
        certainly lower at one of them (whatever its width) is dropped before it is
        evaluated, and counted in ``stats["below_table"]``. The full check stays the
        caller's (the palm, the exact width).
    stats : dict, optional
        Receives counts of dropped candidates.
    hold_rejections : HoldRejections, optional
        Receives the grasps rejected because the grip cannot hold the part.

    Yields
    ------
    Grasp
        In increasing cost; ties broken by generation order (deterministic).
    """
    W, T_f, L = (float(v) for v in gripper.finger_size_m)
    if min_overlap_m is None:
        min_overlap_m = min(2e-3, L / 4)
    palm = np.asarray(gripper.palm_size_m, float)
    mu = float(gripper.finger_friction) * float(part_friction)
    cos_cone = math.cos(math.atan(mu)) if mu > 0 else 1.0
    P = surface.points_m
    N = surface.normals
    com = surface.com_m
    max_width = float(gripper.stroke_m) - 2.0 * finger_clearance_m
    down_s = None if down_start_part is None else _unit(down_start_part)
    down_f = None if down_final_part is None else _unit(down_final_part)
    hint_c = None if hint is None or hint.closing_axis is None else _unit(hint.closing_axis)
    hint_a = None if hint is None or hint.approach_axis is None else _unit(hint.approach_axis)
    hint_o = None if hint is None or hint.offset_m is None else np.asarray(hint.offset_m, float)

    # the load the grip must hold: the part's, or (ranking only) a unit mass at 5 m/s^2
    mass, accel, sf = ((load.mass_kg, load.acceleration_m_s2, load.safety_factor)
                       if load is not None else (1.0, 5.0, 2.0))
    downs = tuple(d for d in (down_s, down_f) if d is not None)
    frames: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]] = []
    order: list[int] = []
    chunks: list[tuple[int, np.ndarray, np.ndarray, bool, np.ndarray]] = []
    rel = P - com
    hold_lbs: dict[float, float] = {}  # hold term lower bound per lever (few distinct ones)
    for c in closing_axes(surface, hint):
        is_hint_c = hint_c is not None and abs(float(np.dot(c, hint_c))) > 0.999
        a0 = _perpendicular(c, down_s)
        b0 = np.cross(c, a0)
        approaches = [math.cos(k * _ANGLE_STEP_RAD) * a0 + math.sin(k * _ANGLE_STEP_RAD) * b0
                      for k in range(8)]
        if is_hint_c and hint_a is not None and abs(float(np.dot(hint_a, c))) < 1e-6:
            approaches.insert(0, hint_a)
        seen: list[np.ndarray] = []
        for a in approaches:
            a = _unit(a)
            if any(float(np.dot(a, s)) > 0.999 for s in seen):
                continue
            seen.append(a)
            x = np.cross(c, a)
            XYZ = np.stack([rel @ x, rel @ c, rel @ a])
            fi = len(frames)
            frames.append((x, c, a, XYZ, is_hint_c))
            is_hint = is_hint_c and hint_a is not None and float(np.dot(a, hint_a)) > 0.999
            base = 0.0
            if hint_c is not None:
                base += (0.0 if is_hint else 10.0) + (0.0 if is_hint_c else 2.0)
            if down_s is not None:
                base += 0.25 * (1.0 - float(np.dot(down_s, a)))
            if down_f is not None:
                base += 0.25 * (1.0 - float(np.dot(down_f, a)))
            centres: list[tuple[float, float]] = []
            if is_hint and hint_o is not None:
                centres.append((float((hint_o - com) @ x), float((hint_o - com) @ a)))
            # the lower finger's lowest corner at each table pose is at most
            # z0 + u x_z + v a_z + max(c_z y) - |x_z| W/2 - |a_z| L/2 - |c_z| T_f
            floors = []
            for T_tab in table_poses:
                R_t = T_tab[:3, :3]
                xz, cz, az = float(R_t[2] @ x), float(R_t[2] @ c), float(R_t[2] @ a)
                z0 = float(T_tab[2, 3] + R_t[2] @ com)
                y_top = max(cz * float(XYZ[1].min()), cz * float(XYZ[1].max()))
                floors.append((xz, az, z0 + y_top - abs(xz) * W / 2 - abs(az) * L / 2
                               - abs(cz) * T_f - table_margin_m))
            xlo, xhi = float(XYZ[0].min()), float(XYZ[0].max())
            zlo, zhi = float(XYZ[2].min()), float(XYZ[2].max())
            v_lo = zlo - L / 2 + min_overlap_m
            v_hi = zhi + L / 2 - min_overlap_m
            # every depth the pads fit at: sixths of the finger length from the centre of
            # mass out to the part's ends (a cover gripped at its edge, a post lying flat)
            vs = sorted({round(_clip(k * L / 6, v_lo, v_hi), 9)
                         for k in _steps(v_lo, v_hi, L / 6)}, key=lambda v: (abs(v), v))
            if xhi - xlo > W:  # the part is wider than a finger: slide along all of it,
                # and past either end by three quarters of a finger (a shaft's head)
                us = sorted({round(_clip(k * W / 2, xlo + W / 2, xhi - W / 2), 9)
                             for k in _steps(xlo + W / 2, xhi - W / 2, W / 2)}
                            | {round(xlo - W / 4, 9), round(xhi + W / 4, 9)},
                            key=lambda u: (abs(u), u))
            else:  # narrower: centred, or sticking out on one side only (an edge 1 mm in),
                # or covering only an end of it, in steps of an eighth of a finger or 1 mm
                # (a bearing's 3 mm flange outside the wall it is pressed into)
                e_step = min(W / 8, _END_STEP_M)
                ends = {round(e, 9) for k in range(1, int((xhi - xlo) / e_step) + 1)
                        for e in (xhi - k * e_step + W / 2, xlo + k * e_step - W / 2)}
                us = sorted({0.0, round(xlo + _EDGE_INSET_M + W / 2, 9),
                             round(xhi - _EDGE_INSET_M - W / 2, 9)} | ends,
                            key=lambda u: (abs(u), u))
            centres.extend((u, v) for v in vs for u in us)
            # how far the finger boxes reach along the insertion direction, per unit offset
            reach = None
            if insertion_part is not None and lead_limit_m is not None:
                ins = _unit(insertion_part)
                reach = (abs(float(x @ ins)) * W / 2 + abs(float(c @ ins)) * (max_width / 2 + T_f)
                         + abs(float(a @ ins)) * L / 2)
                # approaching along the insertion: also the depth at which the fingertips stop
                # just short of the lead limit (a dowel pushed into a wall, held by the half
                # that stays out: a sixth-of-a-finger step can miss it by up to 5 mm)
                a_ins = float(a @ ins)
                if abs(a_ins) > 0.5:
                    for u in us:
                        v = (lead_limit_m - _STOP_GAP_M - reach - u * float(x @ ins)) / a_ins
                        if v_lo <= v <= v_hi:
                            centres.append((u, round(v, 9)))
            # the lead test per centre: (u x + v a) . ins = u (x . ins) + v (a . ins) in
            # float64 (the same operations, element by element, as Python floats), within
            # rounding of numpy's dot, which decides near the limit
            if not centres:
                continue
            cu = np.array([c_[0] for c_ in centres])
            cv = np.array([c_[1] for c_ in centres])
            keep = np.ones(len(centres), bool)
            for xz, az, k in floors:
                keep &= ~(k + cu * xz + cv * az < 0.0)
            if stats is not None and not keep.all():
                stats["below_table"] = stats.get("below_table", 0) + int((~keep).sum())
            cu, cv = cu[keep], cv[keep]
            known = np.full(len(cu), base)
            if reach is not None and lead_limit_m is not None:
                x_ins, a_ins = float(x @ ins), float(a @ ins)
                over = cu * x_ins + cv * a_ins + reach - lead_limit_m
                plus = over > 1e-12
                for i in np.flatnonzero(~plus & (over > -1e-12)).tolist():
                    u, v = float(cu[i]), float(cv[i])
                    plus[i] = float((u * x + v * a) @ ins) + reach > lead_limit_m
                known = np.where(plus, base + 1.0, base)
            chunks.append((fi, cu, cv, is_hint, known))
    # (lower bound, serial, frame, u, v, hint, cost without the hold term), best first: ties
    # by generation order. The hold term (below) is at least a bound per distinct lever
    # (math.hypot, as per candidate before: the offsets are few distinct values)
    if chunks:
        cu = np.concatenate([ch[1] for ch in chunks])
        cv = np.concatenate([ch[2] for ch in chunks])
        knowns_a = np.concatenate([ch[4] for ch in chunks])
        au = np.maximum(0.0, np.abs(cu) - W / 2)
        bv = np.maximum(0.0, np.abs(cv) - L / 2)
        ua, ia = np.unique(au, return_inverse=True)
        ub, ib = np.unique(bv, return_inverse=True)
        keys, inv = np.unique(ia.reshape(-1) * len(ub) + ib.reshape(-1), return_inverse=True)
        hold = np.empty(len(keys))
        ual, ubl = ua.tolist(), ub.tolist()
        for i, key in enumerate(keys.tolist()):
            lever_lb = math.hypot(ual[key // len(ubl)], ubl[key % len(ubl)])
            hold_lb = hold_lbs.get(lever_lb)
            if hold_lb is None:
                hold_lb = hold_lbs[lever_lb] = hold_term(
                    1.0, hold_lower_bound(lever_lb, W, L, accel))
            hold[i] = hold_lb
        lbs = knowns_a + hold[inv.reshape(-1)]
        fis = np.concatenate([np.full(len(ch[1]), ch[0]) for ch in chunks]).tolist()
        hints = np.concatenate([np.full(len(ch[1]), ch[3]) for ch in chunks]).tolist()
        us_, vs_, knowns, lbl = cu.tolist(), cv.tolist(), knowns_a.tolist(), lbs.tolist()
        order = np.lexsort((np.arange(len(lbs)), lbs)).tolist()
    heap: list[tuple[float, int, tuple[Any, ...], bool]] = []
    strips: dict[tuple[int, float], tuple[Strip, Strip]] = {}
    sorted_frames: dict[int, Frame] = {}
    frame_tris: dict[int, FrameTriangles] = {}
    mesh = surface.mesh

    def make(item: tuple[float, int, tuple[Any, ...], bool]) -> Grasp:
        cost, _, (T, width, open_width, area, offset, req, inputs), hinted = item
        return Grasp(part, T, width, open_width, area, offset,
                     "hint" if hinted else "antipodal", cost, req.torsion_radius_m,
                     req.lever_m, req.required_N if load is not None else None,
                     inputs if load is not None else None)

    for serial in order:  # lazily: the first few are all most steps need
        lb, fi, u, v = lbl[serial], fis[serial], us_[serial], vs_[serial]
        is_hint, known = hints[serial], knowns[serial]
        while heap and heap[0][0] <= lb:
            yield make(heapq.heappop(heap))
        x, c, a, XYZ, _ = frames[fi]
        if (fi, u) not in strips:
            if fi not in sorted_frames:
                sorted_frames[fi] = Frame(XYZ, N, surface.n_area)
            f = sorted_frames[fi]
            strips[fi, u] = (Strip(f, u, W / 2), Strip(f, u, palm[0] / 2))
        pad, palm_strip = strips[fi, u]
        if mesh is not None and fi not in frame_tris:
            frame_tris[fi] = FrameTriangles.of(mesh.vertices, mesh.faces, mesh.face_normals,
                                               com, x, c, a)
        g = evaluate(pad, palm_strip, x, c, a, com, u, v, L, palm, cos_cone, max_width,
                      float(gripper.stroke_m), finger_clearance_m, surface.area_per_point_m2,
                      hint, gripper.finger_groove, frame_tris.get(fi), W / 2)
        if g is None:
            continue
        top, bottom = g[5]
        com_g = np.array([-u, -g[6], -v])
        downs_g = tuple(np.array([d @ x, d @ c, d @ a]) for d in downs)
        req = hold_requirement(top, bottom, com_g, mass, accel, mu, sf, downs_g, g[1])
        if load is not None and req.required_N > load.force_limit_N:
            if hold_rejections is not None:
                hold_rejections.add(req)
            continue
        cost = known + hold_term(req.slide_N, req.required_N)
        inputs = HoldInputs(top, bottom, com_g, mass, accel, mu, sf, g[1], downs_g, g[0])
        heapq.heappush(heap, (cost, serial, (*g[:5], req, inputs), is_hint))
    while heap:
        yield make(heapq.heappop(heap))


def _steps(lo: float, hi: float, step: float) -> range:
    """Integer multiples ``k`` of ``step`` covering ``[lo, hi]`` (0 included), at most
    ``_MAX_OFFSETS`` of them around 0 (a coarser step is not needed: the ends are clipped
    onto ``lo`` and ``hi``)."""
    k_lo = max(math.floor(lo / step), -(_MAX_OFFSETS // 2)) if lo < 0 else 0
    k_hi = min(math.ceil(hi / step), _MAX_OFFSETS // 2) if hi > 0 else 0
    return range(min(k_lo, 0), max(k_hi, 0) + 1)


def grasp_candidates(part: str, surface: GraspSurface, gripper: Gripper,
                     hint: GraspHint | None = None, limit: int | None = None,
                     **kwargs: Any) -> list[Grasp]:
    """The first ``limit`` (default all) grasps of :func:`iter_grasps`, ranked."""
    return list(itertools.islice(iter_grasps(part, surface, gripper, hint, **kwargs), limit))


class Rejections:
    """Tally of rejected grasp candidates by reason (pose and obstacles), for NoGraspError."""

    def __init__(self) -> None:
        self.counts: dict[str, int] = {}
        self.examined = 0

    def add(self, where: str, pairs: Sequence[CollidingPair]) -> None:
        names = sorted({n for p in pairs for n in (p.a, p.b) if not n.startswith("gripper")})
        key = f"the gripper hits {', '.join(names) or 'something'} at the {where}"
        self.counts[key] = self.counts.get(key, 0) + 1

    def reasons(self) -> list[str]:
        return [f"{n} candidate{'s' if n != 1 else ''}: {k}"
                for k, n in sorted(self.counts.items(), key=lambda kv: (-kv[1], kv[0]))]


def collision_free(grasps: Iterable[Grasp],
                   collisions: Callable[[Grasp], tuple[str, Sequence[CollidingPair]]],
                   rejections: Rejections, max_candidates: int) -> Iterator[Grasp]:
    """The grasps (in their order) whose fingers are free at the start and final poses.

    Parameters
    ----------
    grasps : iterable of Grasp
        Ranked candidates (e.g. :func:`iter_grasps`).
    collisions : callable
        ``collisions(grasp) -> (where, pairs)``: empty ``pairs`` when the gripper is free at
        every pose it checks, else the first failing pose's name and its colliding pairs.
    rejections : Rejections
        Receives every rejected candidate's reason.
    max_candidates : int
        Stop after examining this many candidates, not counting those whose fingers reach
        below the table top (up to four times as many of those).
    """
    table_only = 0
    for g in grasps:
        if rejections.examined - table_only >= max_candidates or table_only >= 4 * max_candidates:
            return
        rejections.examined += 1
        where, pairs = collisions(g)
        if pairs:
            rejections.add(where, pairs)
            # a finger below the table top is found without a collision query: such
            # candidates (most of a part lying on the table) do not use up the budget
            if len(pairs) == 1 and pairs[0].b == "table":
                table_only += 1
            continue
        yield g
