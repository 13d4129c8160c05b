"""Recognise mating features of a CAD part from its surfaces: holes, bores, pins, shafts,
counterbores, chamfers, threads, hex heads and nuts, slots.

Input is a list of :class:`~asmplan.parts.surface_fit.Surface` (cylinders, cones, planes) in
the part's frame, either the exact analytic faces of a STEP solid (:mod:`asmplan.parts.step_brep`)
or fitted to a mesh (:func:`~asmplan.parts.surface_fit.fit_mesh_surfaces`), plus the part's
closed triangle mesh for ray probes. Output is a list of :class:`CadFeature` with diameter,
axis, extent, end conditions and the evidence.

Rules (the same for STEP and mesh input)
----------------------------------------
- Coaxial cylindrical faces of the same radius and side are merged (CAD systems split a full
  cylinder into two half faces). A merged cylinder is *full* when it covers the circle.
- An inner full cylinder is a hole segment. Each end is ``open`` (a ray along the axis leaves
  the part), ``floor`` (material right there: a blind hole's bottom), or steps into a coaxial
  ``larger`` or ``smaller`` segment (a shoulder). A segment whose far end is a floor or steps
  into a smaller segment is blind (depth = its length plus the mouth chamfer); both ends open
  or larger: through. A larger segment on the mouth side that is no deeper than its diameter
  is the hole's counterbore (it moves the mouth out); otherwise it is its own hole.
- A hole is a ``bore`` when its part is a body of revolution about the same axis (a ring, a
  sleeve, a knob), else a ``hole``.
- An outer full cylinder is a male segment with its chamfers (coaxial cones touching its ends);
  a ``shaft`` when the part is a body of revolution about it and at least 5 diameters long,
  else a ``pin``. A male segment with a coaxial outer hexagon (six planes 60 degrees apart at
  one distance from the axis) at one end is a hex bolt's shank: a ``thread``.
- An inner hexagon or an outer hexagon is reported as a ``hex`` feature (not round, not
  simulated); two coaxial-free half cylinders of equal radius with parallel axes are a
  ``slot`` (width, length); another partial inner cylinder of half a turn or more is a
  ``non_round`` feature. Smaller partial cylinders (fillets, rounds) are counted in the
  evidence and otherwise ignored.
- Threads in holes are recognised when mating (:mod:`asmplan.parts.cad_import`): CAD models a
  tapped hole at its tap-drill diameter and a nut at its minor diameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .surface_fit import Surface, _parallel, _unit, fit_mesh_surfaces, line_distance


@dataclass(frozen=True)
class RecognitionTolerance:
    """How close two surfaces must be to count as coaxial, equal or touching.

    Parameters
    ----------
    angle_rad : parallel axes within this angle.
    distance_m : coaxial lines, equal radii and touching ends within this distance.
    """

    angle_rad: float = 1e-6
    distance_m: float = 1e-7

    @classmethod
    def for_mesh(cls) -> RecognitionTolerance:
        """Looser tolerances for cylinders fitted to a mesh (0.2 deg, 20 um)."""
        return cls(angle_rad=math.radians(0.2), distance_m=2e-5)


@dataclass(frozen=True, eq=False)
class CadFeature:
    """A recognised feature in the part frame (metres).

    ``point_m`` and ``axis`` define the axis line; the feature spans ``t0_m``..``t1_m`` along it
    (chamfers included, a counterbore not). For a female feature, ``axis`` is the outward
    normal of its mouth and ``mouth_m`` the mouth centre (``t1_m`` end, counterbore included);
    ``depth_m`` is 0 for a through hole. ``kind``: hole, bore, pin, shaft, thread, hex, slot,
    tenon (a rectangular male: width ``diameter_m`` along ``side_axis`` by ``slot_length_m``),
    mortise (its rectangular female), non_round.
    """

    name: str
    kind: str
    female: bool
    point_m: np.ndarray
    axis: np.ndarray
    t0_m: float
    t1_m: float
    diameter_m: float
    through: bool = False
    depth_m: float = 0.0
    chamfer_m: float = 0.0
    chamfer_t0_m: float = 0.0
    chamfer_t1_m: float = 0.0
    counterbore: tuple[float, float] | None = None
    across_flats_m: float = 0.0
    slot_length_m: float = 0.0
    evidence: tuple[str, ...] = field(default_factory=tuple)
    side_axis: np.ndarray | None = None
    """A tenon's or mortise's width direction (the ``diameter_m`` side; the other side is
    ``slot_length_m``), part frame."""

    @property
    def mouth_m(self) -> np.ndarray:
        """Centre of the mouth (of the counterbore when there is one)."""
        return self.point_m + self.axis * (self.t1_m + (self.counterbore[1] if self.counterbore else 0.0))

    @property
    def length_m(self) -> float:
        return self.t1_m - self.t0_m

    @property
    def simulated(self) -> bool:
        return self.kind in ("hole", "bore", "pin", "shaft")


def _same_line(s: Surface, p: np.ndarray, a: np.ndarray, tol: RecognitionTolerance, scale: float) -> bool:
    return _parallel(s.axis, a, tol.angle_rad) and line_distance(p, a, s.point_m) <= tol.distance_m * scale


def _extent_on(s: Surface, p: np.ndarray, a: np.ndarray) -> tuple[float, float]:
    """The patch's extent along the line (p, a)."""
    base = float(np.dot(s.point_m - p, a))
    sign = 1.0 if float(np.dot(s.axis, a)) > 0 else -1.0
    lo, hi = base + sign * s.t0_m, base + sign * s.t1_m
    return (min(lo, hi), max(lo, hi))


# ---------------------------------------------------------------------------------------------
# Recognition
# ---------------------------------------------------------------------------------------------
@dataclass
class _Cyl:
    point: np.ndarray
    axis: np.ndarray
    radius: float
    inner: bool
    t0: float
    t1: float
    span: float
    faces: int
    evidence: str


def _merge_cylinders(surfaces: list[Surface], tol: RecognitionTolerance) -> list[_Cyl]:
    cyls: list[_Cyl] = []
    for s in sorted((s for s in surfaces if s.kind == "cylinder"), key=lambda s: (-s.radius_m, s.t0_m)):
        for c in cyls:
            if c.inner == s.inner and abs(c.radius - s.radius_m) <= tol.distance_m * 10 + 1e-9 \
                    and _same_line(s, c.point, c.axis, tol, 10):
                lo, hi = _extent_on(s, c.point, c.axis)
                if lo <= c.t1 + tol.distance_m * 10 and hi >= c.t0 - tol.distance_m * 10:
                    same_band = abs(lo - c.t0) < tol.distance_m * 10 and abs(hi - c.t1) < tol.distance_m * 10
                    c.span = c.span + s.span_rad if same_band else max(c.span, s.span_rad)
                    c.t0, c.t1 = min(c.t0, lo), max(c.t1, hi)
                    c.faces += 1
                    break
        else:
            a = s.axis
            p = s.point_m
            cyls.append(_Cyl(p, a, s.radius_m, s.inner, s.t0_m, s.t1_m, s.span_rad, 1, s.evidence))
    return cyls


def _is_full(c: _Cyl) -> bool:
    return c.span >= 2 * math.pi - 0.35


def _touch(tol: RecognitionTolerance) -> float:
    """How far apart two ends may be and still touch."""
    return tol.distance_m * 5 + 1e-6


def _chamfer_at(c: _Cyl, t_end: float, outward: float, cones: list[Surface], tol: RecognitionTolerance
                ) -> float:
    """Axial length of a coaxial cone that touches the cylinder's end ``t_end`` on side
    ``outward`` (+1 beyond t1, -1 before t0) and meets it at the cylinder's radius."""
    touch = _touch(tol)
    for s in cones:
        if s.inner != c.inner or not _same_line(s, c.point, c.axis, tol, 10):
            continue
        lo, hi = _extent_on(s, c.point, c.axis)
        near, far = (lo, hi) if outward > 0 else (hi, lo)
        if abs(near - t_end) <= touch and (abs(s.radius_m - c.radius) <= touch
                                           or abs(s.radius_min_m - c.radius) <= touch):
            return abs(far - near)
    return 0.0


class _Rays:
    def __init__(self, vertices_m: np.ndarray, faces: np.ndarray):
        import trimesh

        self.mesh = trimesh.Trimesh(vertices_m, faces, process=False)
        self.intersector = trimesh.ray.ray_triangle.RayMeshIntersector(self.mesh)

    def first_hit(self, origin: np.ndarray, direction: np.ndarray) -> float:
        locs, _, _ = self.intersector.intersects_location([origin], [direction], multiple_hits=True)
        if len(locs) == 0:
            return math.inf
        return float(np.min((locs - origin) @ direction))


def _hexagons(planes: list[Surface], p: np.ndarray, a: np.ndarray, tol: RecognitionTolerance
              ) -> list[tuple[float, bool]]:
    """(across flats, outer) of hexagons of planes parallel to the line (p, a)."""
    cands = []
    for s in planes:
        if abs(float(np.dot(s.axis, a))) > math.sin(max(tol.angle_rad * 10, 1e-4)):
            continue
        d = float(np.dot(s.axis, s.point_m - p))
        cands.append((abs(d), d > 0, s.axis))
    found = []
    used = set()
    for i, (d, outer, _n) in enumerate(cands):
        if i in used:
            continue
        group = [j for j, (dj, oj, _) in enumerate(cands)
                 if oj == outer and abs(dj - d) <= _touch(tol)]
        normals = [cands[j][2] for j in group]
        # distinct directions 60 degrees apart
        dirs: list[np.ndarray] = []
        for nn in normals:
            if all(float(np.dot(nn, m)) < 0.999 for m in dirs):
                dirs.append(nn)
        if len(dirs) == 6:
            angles = sorted(float(np.degrees(np.arccos(np.clip(np.dot(dirs[0], m), -1, 1))))
                            for m in dirs[1:])
            if np.allclose(angles, [60, 60, 120, 120, 180], atol=0.5):
                found.append((2 * d, outer))
                used.update(group)
    return found


# Complexity above C (radon): the recognition rules in order (holes with their mouths, chamfers
# and counterbores; male cylinders; hexagons; slots), sharing the surface bookkeeping.
def recognise(surfaces: list[Surface], vertices_m: np.ndarray, faces: np.ndarray,
              tol: RecognitionTolerance | None = None) -> tuple[list[CadFeature], list[str]]:
    """Features of one part from its surfaces and mesh (see the module docstring).

    Returns
    -------
    features : list of CadFeature, deterministic order (female first, by position).
    notes : list of str
        What was seen and not made a feature (fillets, internal cavities).
    """
    tol = tol or RecognitionTolerance()
    notes: list[str] = []
    cyls = _merge_cylinders(surfaces, tol)
    cones = [s for s in surfaces if s.kind == "cone"]
    planes = [s for s in surfaces if s.kind == "plane"]
    full = [c for c in cyls if _is_full(c)]
    partial = [c for c in cyls if not _is_full(c)]
    outer_full = [c for c in full if not c.inner]
    rays = _Rays(vertices_m, faces) if len(faces) else None
    size = float(np.ptp(vertices_m, axis=0).max()) if len(vertices_m) else 1.0

    def revolved_about(c: _Cyl) -> bool:
        """The part is a body of revolution about c's axis: every full cylinder is coaxial and
        there is an outer one."""
        return any(not o.inner for o in full) and all(
            _parallel(o.axis, c.axis, tol.angle_rad * 10) and
            line_distance(c.point, c.axis, o.point) <= tol.distance_m * 10 for o in full) and not \
            _hexagons(planes, c.point, c.axis, tol)

    features: list[CadFeature] = []
    # -- holes -----------------------------------------------------------------------------
    inner = [c for c in full if c.inner]
    stacks: list[list[_Cyl]] = []
    for c in inner:
        for st in stacks:
            if _parallel(st[0].axis, c.axis, tol.angle_rad * 10) and \
                    line_distance(st[0].point, st[0].axis, c.point) <= tol.distance_m * 10:
                lo, hi = _extent_on(Surface("cylinder", c.point, c.axis, c.radius, True, c.t0, c.t1, 0),
                                    st[0].point, st[0].axis)
                st.append(_Cyl(st[0].point, st[0].axis, c.radius, True, lo, hi, c.span, c.faces, c.evidence))
                break
        else:
            stacks.append([c])
    for st in stacks:
        st.sort(key=lambda c: c.t0)
        ends = []
        for i, c in enumerate(st):
            def state(t_end: float, side: int, c=c, i=i, st=st) -> tuple[str, float]:
                j = i + side
                if 0 <= j < len(st) and \
                        abs((st[j].t0 if side > 0 else st[j].t1) - t_end) <= _touch(tol):
                    return ("larger" if st[j].radius > c.radius else "smaller"), 0.0
                ch = _chamfer_at(c, t_end, side, cones, tol)
                if rays is None:
                    return "open", ch
                start = c.point + c.axis * (t_end - side * min(1e-5, 0.1 * (c.t1 - c.t0)))
                hit = rays.first_hit(start, c.axis * side)
                if hit <= 3e-5 + _touch(tol) + ch:
                    return "floor", ch
                return "open", ch
            ends.append((state(c.t0, -1), state(c.t1, +1)))
        absorbed = set()
        for i, c in enumerate(st):
            if i in absorbed:
                continue
            (lo_state, lo_ch), (hi_state, hi_ch) = ends[i]
            opens = {"open", "larger"}
            if lo_state in opens and hi_state in opens:
                # a through hole's mouth: the chamfered end (the entry), else the +axis end
                through, mouth_side = True, (-1 if lo_ch > hi_ch else +1)
            elif hi_state in opens:
                through, mouth_side = False, +1
            elif lo_state in opens:
                through, mouth_side = False, -1
            else:
                notes.append(f"internal cavity of diameter {2 * c.radius * 1e3:.4g} mm (no opening)")
                continue
            # counterbore on the mouth side
            cb = None
            k = i + mouth_side
            mouth_state = hi_state if mouth_side > 0 else lo_state
            if mouth_state == "larger" and 0 <= k < len(st):
                big = st[k]
                big_len = big.t1 - big.t0
                far_state = ends[k][1][0] if mouth_side > 0 else ends[k][0][0]
                if big_len <= 2 * big.radius and far_state == "open":
                    cb = (2 * big.radius, big_len)
                    absorbed.add(k)
            # frame: axis = outward normal at the mouth
            a = c.axis * mouth_side
            p = c.point
            t_lo, t_hi = (c.t0, c.t1) if mouth_side > 0 else (-c.t1, -c.t0)
            ch_mouth = hi_ch if mouth_side > 0 else lo_ch
            ch_far = lo_ch if mouth_side > 0 else hi_ch
            t_hi_all = t_hi + ch_mouth
            depth = 0.0 if through else (t_hi + ch_mouth) - t_lo
            ev = [c.evidence + (f" ({c.faces} faces)" if c.faces > 1 else ""),
                  f"ends: {lo_state}/{hi_state}"]
            if ch_mouth:
                ev.append(f"mouth chamfer {ch_mouth * 1e3:.3g} mm (coaxial cone)")
            if cb:
                ev.append(f"counterbore {cb[0] * 1e3:.4g} x {cb[1] * 1e3:.4g} mm")
            kind = "bore" if revolved_about(c) else "hole"
            features.append(CadFeature("", kind, True, p, a, t_lo - ch_far, t_hi_all, 2 * c.radius,
                                       through=through, depth_m=depth, chamfer_m=ch_mouth,
                                       counterbore=cb, evidence=tuple(ev)))
    # -- male cylinders --------------------------------------------------------------------
    for c in outer_full:
        ch0 = _chamfer_at(c, c.t0, -1, cones, tol)
        ch1 = _chamfer_at(c, c.t1, +1, cones, tol)
        length = c.t1 - c.t0 + ch0 + ch1
        hexes = [h for h in _hexagons(planes, c.point, c.axis, tol) if h[1]]
        rev = revolved_about(c)
        ev = [c.evidence]
        if ch0 or ch1:
            ev.append(f"chamfers {ch0 * 1e3:.3g} / {ch1 * 1e3:.3g} mm (coaxial cones)")
        if hexes:
            kind = "thread"
            ev.append(f"hex head {hexes[0][0] * 1e3:.4g} mm across flats on the same axis: a bolt's shank")
        elif rev and length >= 5 * 2 * c.radius:
            kind = "shaft"
        else:
            kind = "pin"
        if rev:
            ev.append("the part is a body of revolution about this axis")
        features.append(CadFeature("", kind, False, c.point, c.axis, c.t0 - ch0, c.t1 + ch1, 2 * c.radius,
                                   chamfer_m=max(ch0, ch1), chamfer_t0_m=ch0, chamfer_t1_m=ch1,
                                   evidence=tuple(ev)))
    # -- non-round -------------------------------------------------------------------------
    axes_seen: list[tuple[np.ndarray, np.ndarray]] = [(c.point, c.axis) for c in full]
    hex_done: list[tuple[float, np.ndarray, np.ndarray]] = []
    for p, a in axes_seen:
        for af, outer in _hexagons(planes, p, a, tol):
            if any(abs(af - h[0]) < 1e-9 and line_distance(h[1], h[2], p) < 1e-6 for h in hex_done):
                continue
            hex_done.append((af, p, a))
            features.append(CadFeature("", "hex", not outer, p, a, 0.0, 0.0, 0.0, across_flats_m=af,
                                       evidence=(f"six planes 60 deg apart, {af * 1e3:.4g} mm across flats, "
                                                 f"{'outside' if outer else 'inside'}: not round, not "
                                                 "simulated",)))
    halves = [c for c in partial if c.inner and c.span >= math.pi - 0.1]
    used: set[int] = set()
    for i, c in enumerate(halves):
        if i in used:
            continue
        for j in range(i + 1, len(halves)):
            o = halves[j]
            if j in used or abs(o.radius - c.radius) > _touch(tol) or \
                    not _parallel(o.axis, c.axis, tol.angle_rad * 10):
                continue
            sep = line_distance(c.point, c.axis, o.point)
            if sep <= 2 * c.radius * 10:
                used.update((i, j))
                d = o.point - c.point
                d = d - c.axis * np.dot(d, c.axis)
                mid = c.point + 0.5 * d
                features.append(CadFeature("", "slot", True, mid, c.axis, c.t0, c.t1, 2 * c.radius,
                                           slot_length_m=sep + 2 * c.radius,
                                           evidence=(f"two half cylinders r {c.radius * 1e3:.4g} mm "
                                                     f"{sep * 1e3:.4g} mm apart: a slot "
                                                     f"{2 * c.radius * 1e3:.4g} x "
                                                     f"{(sep + 2 * c.radius) * 1e3:.4g}"
                                                     " mm, not round, not simulated",)))
                break
        else:
            used.add(i)
            features.append(CadFeature("", "non_round", True, c.point, c.axis, c.t0, c.t1, 2 * c.radius,
                                       evidence=(f"partial cylinder of {math.degrees(c.span):.0f} deg, "
                                                 "not round, not simulated",)))
    features += _rectangles(planes, vertices_m, rays, tol, size)
    small = [c for c in partial if not (c.inner and c.span >= math.pi - 0.1)]
    if small:
        notes.append(f"{len(small)} partial cylinders under half a turn (fillets, rounds) ignored")
    # deterministic names: kind_k ordered by mouth/centre position
    def key(f: CadFeature):
        m = f.mouth_m
        return (not f.female, f.kind, round(m[0] / size, 6), round(m[1] / size, 6), round(m[2] / size, 6))

    features.sort(key=key)
    counts: dict[str, int] = {}
    named = []
    for f in features:
        counts[f.kind] = counts.get(f.kind, 0) + 1
        named.append(_rename(f, f"{f.kind}_{counts[f.kind]}"))
    return named, notes


# Complexity above C (radon): pairs of opposite plane pairs, each tested in turn (perpendicular,
# centred, one depth, facing) and classified as a tenon or a mortise with its end, shoulder or floor.
def _rectangles(planes: list[Surface], vertices_m: np.ndarray, rays: _Rays | None,
                tol: RecognitionTolerance, size: float) -> list[CadFeature]:
    """Rectangular tenons (male) and mortises (female) from plane patches.

    Two pairs of parallel, opposite plane patches with perpendicular normals, whose four
    centres lie at one depth along the common axis and are centred on each other, bound a
    rectangular prism: a mortise when each pair's outward normals face each other (the
    material is outside), a tenon when they face away, with an end face on its centre line
    (the tip; its normal is the insertion axis) and a shoulder: a plane facing the same way at
    its root (so not the part's own box). A mortise's floor is a plane facing out of it on its
    centre line; without one it is through (measured by rays)."""
    near = max(tol.distance_m * 10, 2e-5)
    cos_par = math.cos(max(tol.angle_rad * 10, 1e-6))
    pairs = []
    for i, a in enumerate(planes):
        for b in planes[i + 1:]:
            if float(np.dot(a.axis, b.axis)) > -cos_par:
                continue
            d = float(np.dot(a.axis, b.point_m - a.point_m))
            if abs(d) <= near:
                continue
            pairs.append((a, b, abs(d), d > 0))
    out: list[CadFeature] = []
    seen: list[np.ndarray] = []
    ext = np.ptp(vertices_m, axis=0) if len(vertices_m) else np.zeros(3)  # through mortises
    for i, (a1, b1, w1, in1) in enumerate(pairs):
        for a2, b2, w2, in2 in pairs[i + 1:]:
            if in1 != in2 or abs(float(np.dot(a1.axis, a2.axis))) > 1e-6 + (1 - cos_par):
                continue
            u, v = a1.axis, a2.axis
            axis = _unit(np.cross(u, v))
            cu = 0.5 * float(np.dot(a1.point_m + b1.point_m, u))
            cv = 0.5 * float(np.dot(a2.point_m + b2.point_m, v))
            walls = (a1, b1, a2, b2)
            ws = [float(np.dot(s.point_m, axis)) for s in walls]
            if max(ws) - min(ws) > near:
                continue
            if any(abs(float(np.dot(s.point_m, v)) - cv) > near for s in (a1, b1)) or \
                    any(abs(float(np.dot(s.point_m, u)) - cu) > near for s in (a2, b2)):
                continue
            w_mid = float(np.mean(ws))
            centre = cu * u + cv * v + w_mid * axis
            if any(np.linalg.norm(centre - c) <= near for c in seen):
                continue
            ends = [s for s in planes if abs(float(np.dot(s.axis, axis))) >= cos_par and
                    line_distance(centre, axis, s.point_m) <= near + 0.5 * min(w1, w2)]
            if not in1:  # tenon: its tip on the centre line, a shoulder facing the same way at its root
                tips = [s for s in ends if float(np.dot(s.axis, s.point_m - centre)) > near]
                tip = None
                for t in sorted(tips, key=lambda s: float(np.dot(s.axis, s.point_m - centre))):
                    h = float(np.dot(t.axis, t.point_m - centre))
                    if any(float(np.dot(s.axis, t.axis)) >= cos_par
                           and abs(float(np.dot(t.axis, s.point_m - centre)) + h) <= near for s in planes):
                        tip = t
                        break
                if tip is None:
                    continue
                ax = tip.axis
                half = float(np.dot(ax, tip.point_m - centre))
                kind, female, through, depth = "tenon", False, False, 0.0
                t0, t1 = -half, half
                how = f"tip face on its centre line, {2 * half * 1e3:.4g} mm long"
            else:  # mortise: the floor faces out of it; none: through
                floors = [s for s in ends if float(np.dot(s.axis, centre - s.point_m)) > near]
                if floors:
                    fl = min(floors, key=lambda s: float(np.dot(s.axis, centre - s.point_m)))
                    ax = fl.axis
                    half = float(np.dot(ax, centre - fl.point_m))
                    kind, female, through, depth = "mortise", True, False, 2 * half
                    t0, t1 = -half, half
                    how = f"floor on its centre line, {2 * half * 1e3:.4g} mm deep"
                else:
                    ax = axis
                    lo = hi = 0.0
                    if rays is not None:
                        hi = rays.first_hit(centre, ax)
                        lo = rays.first_hit(centre, -ax)
                    if not (math.isfinite(lo) and math.isfinite(hi)):
                        lo = hi = 0.5 * float(np.abs(ax) @ ext)
                    kind, female, through, depth = "mortise", True, True, 0.0
                    t0, t1 = -lo, hi
                    how = "open at both ends: through"
            seen.append(centre)
            side, other = (u, w2) if w1 <= w2 else (v, w1)
            width = min(w1, w2)
            out.append(CadFeature(
                "", kind, female, centre, ax, t0, t1, width, through=through, depth_m=depth,
                slot_length_m=other, side_axis=side,
                evidence=(f"rectangular {kind} {width * 1e3:.4g} x {other * 1e3:.4g} mm: two pairs of "
                          f"parallel planes at right angles, their centres at one depth; {how}; "
                          "not round, not simulated",)))
    return out


def _rename(f: CadFeature, name: str) -> CadFeature:
    from dataclasses import replace

    return replace(f, name=name)


__all__ = ["CadFeature", "RecognitionTolerance", "Surface", "fit_mesh_surfaces", "line_distance", "recognise"]
