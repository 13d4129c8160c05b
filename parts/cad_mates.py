"""Proposes the mates of an imported CAD assembly: every male and female feature of two parts
with parallel, coaxial axes and overlapping extents, classified as a fit, a drawn clearance or
interference, an ISO metric thread or a non-round mate, with the side a through female is
entered from."""

from __future__ import annotations

import math

import numpy as np

from ..knowledge.fit_rules import builtin_rules, default_fit
from .cad_features import CadFeature
from .cad_types import ImportedPart, ImportSettings, ProposedMate, _apply, _apply_all
from .surface_fit import line_distance

# ISO 261/724 metric coarse threads: nominal -> (tap drill, minor diameter of the nut), mm
ISO_METRIC = {1.6: (1.25, 1.221), 2: (1.6, 1.567), 2.5: (2.05, 2.013), 3: (2.5, 2.459), 4: (3.3, 3.242),
              5: (4.2, 4.134), 6: (5.0, 4.917), 8: (6.8, 6.647), 10: (8.5, 8.376), 12: (10.2, 10.106),
              14: (12.0, 11.835), 16: (14.0, 13.835), 20: (17.5, 17.294), 24: (21.0, 20.752)}


# ---------------------------------------------------------------------------------------------
# Mates
# ---------------------------------------------------------------------------------------------
def _thread_nominal(d_male_mm: float, d_female_mm: float) -> float | None:
    for nominal, (tap, minor) in ISO_METRIC.items():
        if abs(d_male_mm - nominal) <= 0.05 and \
                (abs(d_female_mm - tap) <= 0.15 or abs(d_female_mm - minor) <= 0.15):
            return nominal
    return None


def _solid(part: ImportedPart, T: np.ndarray):
    import trimesh

    from .geometry import trimesh_to_manifold

    m = trimesh.Trimesh(_apply_all(T, part.vertices_m), part.faces, process=False)
    m.merge_vertices()
    return trimesh_to_manifold(m)


def _blocked(male: ImportedPart, female: ImportedPart, direction: np.ndarray, distance: float) -> bool:
    """Does ``male`` collide with ``female`` when withdrawn along ``direction``?"""
    try:
        fsolid = _solid(female, female.T_assembly_part)
    except ValueError:
        return False
    limit = 1e-3 * male.volume_m3
    for s in (0.25, 0.5, 0.75, 1.0):
        T = male.T_assembly_part.copy()
        T[:3, 3] += direction * distance * s
        try:
            vol = (_solid(male, T) ^ fsolid).volume()
        except ValueError:
            return False
        if vol > limit:
            return True
    return False


# Complexity above C (radon): every male/female pair is tested for kind, axis, coaxiality and
# overlap, and the fit or thread it takes; each test is one branch.
def propose_mates(parts: list[ImportedPart], settings: ImportSettings, mesh: bool
                  ) -> tuple[list[ProposedMate], list[str]]:
    """Every coaxial male/female pair of two parts with overlapping extent (module docstring)."""
    ang = math.radians(0.2) if mesh else 1e-6
    dist = 5e-5 if mesh else 1e-6
    notes: list[str] = []
    world: list[tuple[ImportedPart, CadFeature, np.ndarray, np.ndarray]] = []
    for p in parts:
        for f in p.features:
            world.append((p, f, _apply(p.T_assembly_part, f.point_m), p.T_assembly_part[:3, :3] @ f.axis))
    mates: list[ProposedMate] = []
    for pm, fm, pm_pt, am in world:
        if fm.female or fm.kind in ("hex",):
            continue
        for pf, ff, pf_pt, af in world:
            if pf is pm or not ff.female or ff.kind in ("hex", "non_round"):
                continue
            if abs(float(np.dot(am, af))) < math.cos(ang):
                continue
            if (fm.kind == "tenon") != (ff.kind == "mortise"):
                continue  # a rectangle mates only with a rectangle
            if ff.kind == "mortise":
                assert fm.side_axis is not None and ff.side_axis is not None
                side_m = pm.T_assembly_part[:3, :3] @ fm.side_axis
                side_f = pf.T_assembly_part[:3, :3] @ ff.side_axis
                if abs(float(np.dot(side_m, side_f))) < math.cos(ang) or \
                        fm.diameter_m > ff.diameter_m + dist or fm.slot_length_m > ff.slot_length_m + dist:
                    continue
            if ff.kind == "slot":
                if fm.diameter_m > ff.diameter_m + dist:
                    continue
                off = pm_pt - pf_pt
                off = off - af * float(np.dot(off, af))
                if float(np.linalg.norm(off)) > ff.slot_length_m / 2:
                    continue
            elif line_distance(pf_pt, af, pm_pt) > dist:
                continue
            # extents along the female's axis
            f_lo, f_hi = ff.t0_m, ff.t1_m
            base = float(np.dot(pm_pt - pf_pt, af))
            sgn = 1.0 if float(np.dot(am, af)) > 0 else -1.0
            m_lo, m_hi = sorted((base + sgn * fm.t0_m, base + sgn * fm.t1_m))
            engaged = min(f_hi, m_hi) - max(f_lo, m_lo)
            if engaged <= max(dist, 1e-5):
                continue
            dm, df = fm.diameter_m, ff.diameter_m
            ev = [f"{pm.name}.{fm.name} ({fm.kind} {dm * 1e3:.6g} mm) and {pf.name}.{ff.name} "
                  f"({ff.kind} {df * 1e3:.6g} mm) coaxial within {dist * 1e3:g} mm, "
                  f"overlap {engaged * 1e3:.4g} mm"]
            line = max(1e-6, 2e-3 * dm) if mesh else 1e-6
            fit = None
            if ff.kind == "slot":
                kind = "non_round"
                ev.append("pin in a slot: located in one direction only, not simulated")
            elif ff.kind == "mortise":
                kind = "non_round"
                ev.append(f"rectangular tenon {fm.diameter_m * 1e3:.4g} x {fm.slot_length_m * 1e3:.4g} mm in "
                          f"mortise {ff.diameter_m * 1e3:.4g} x {ff.slot_length_m * 1e3:.4g} mm, sides "
                          "parallel: not round, not simulated")
            elif abs(df - dm) <= line:
                kind = "fit"
                fit = default_fit(fm.kind, ff.kind, dm, None if settings.fit_rules is None
                                  else (*settings.fit_rules, *builtin_rules()))
                ev.append(f"line to line: fit {fit.fit if fit else '?'} from the rules "
                          f"({fit.why if fit else 'no rule matches'}"
                          + (f"; {fit.source}" if fit else "") + ")")
            elif dm < df:
                if df - dm > settings.max_clearance_ratio * dm:
                    notes.append(f"{pm.name}.{fm.name} passes through {pf.name}.{ff.name} with "
                                 f"{(df - dm) * 1e3:.4g} mm clearance: no mate")
                    continue
                kind = "clearance"
                ev.append(f"clearance {(df - dm) * 1e3:.4g} mm as drawn")
            else:
                nominal = _thread_nominal(dm * 1e3, df * 1e3)
                if nominal is not None:
                    kind = "thread"
                    ev.append(f"M{nominal:g} thread: female at the tap-drill/minor diameter of M{nominal:g}")
                else:
                    kind = "interference"
                    ev.append(f"interference {(dm - df) * 1e3:.4g} mm as drawn (not an ISO thread)")
            # the mouth: for a blind female its own; for a through one, the side the male enters
            axis = af.copy()
            mouth = pf_pt + af * (f_hi + (ff.counterbore[1] if ff.counterbore else 0.0))
            if ff.through and kind != "non_round":
                # the side the male PART stands out of the female more (not the feature: the
                # journal of a stepped shaft stands out below the spacer between its bearings,
                # the shaft above it)
                p_t = (_apply_all(pm.T_assembly_part, pm.vertices_m) - pf_pt) @ af
                pick_up = (float(p_t.max()) - f_hi) >= (f_lo - float(p_t.min()))
                if kind != "thread":
                    up_blocked = _blocked(pm, pf, af, engaged + 2e-3)
                    down_blocked = _blocked(pm, pf, -af, engaged + 2e-3)
                    if up_blocked != down_blocked:
                        pick_up = not up_blocked
                        ev.append(f"{pm.name} can be withdrawn only one way along the axis (the other "
                                  "way its part collides)")
                if not pick_up:
                    axis = -af
                    mouth = pf_pt + af * f_lo
            # where the engagement starts, from the mouth side: the male's root when seated
            top = min(f_hi, m_hi) if axis @ af > 0 else max(f_lo, m_lo)
            start = pf_pt + af * top
            mates.append(ProposedMate(pm.name, fm, pf.name, ff, kind, mouth, axis, engaged, fit, tuple(ev),
                                      start))
    mates = _one_entry_side(mates)
    mates.sort(key=lambda m: (m.female_part, m.female.name, m.male_part, m.male.name))
    return mates, notes


def _one_entry_side(mates: list[ProposedMate]) -> list[ProposedMate]:
    """One male feature through several coaxial through females of ONE part (a dowel across
    a leg, through its two holes on either side of a mortise) enters them from one side: where
    the sides chosen per pair disagree, the side most of the male's through mates chose (over
    every part; ties: the first pair's) wins, and the others are entered from their other
    mouth (with the evidence). Mates with different parts keep their sides (a cover lowered
    over a shaft enters it from the other side than the shaft entered its bearings)."""
    from dataclasses import replace

    males: dict[tuple[str, str], list[int]] = {}
    for i, m in enumerate(mates):
        if m.simulated and m.female.through and not m.female.counterbore:
            males.setdefault((m.male_part, m.male.name), []).append(i)
    out = list(mates)
    for idx in males.values():
        ref = mates[idx[0]].axis
        sign = {i: 1 if float(np.dot(mates[i].axis, ref)) > 0 else -1 for i in idx}
        keep = 1 if sum(sign.values()) >= 0 else -1
        for i in idx:
            same = [j for j in idx if mates[j].female_part == mates[i].female_part]
            if sign[i] == keep or len({sign[j] for j in same}) < 2:
                continue
            m = mates[i]
            length = m.female.t1_m - m.female.t0_m
            start = m.engage_start_m
            out[i] = replace(
                m, axis=-m.axis, mouth_m=m.mouth_m - m.axis * length,
                engage_start_m=None if start is None else start - m.axis * m.engaged_m,
                evidence=(*m.evidence, f"entered from its other mouth, as {m.male_part}."
                          f"{m.male.name}'s other through mates (one insertion for the male)"))
    return out
