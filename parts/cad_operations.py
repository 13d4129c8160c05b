"""Parts of an imported assembly that a two-finger gripper cannot place: the ``handling:
{operation: ...}`` the importer writes for them, with its evidence.

- A part mated by a tenon in a mortise (a non-round joint, recognised and not simulated) is
  placed by a manual (joinery) station along the joint's axis: ``operation: manual``.
- A plain ring, sleeve or dowel (a body of revolution, :func:`asmplan.parts.cad_product`'s
  exact primitive) whose whole outer cylinder ends up inside bores or holes (engaged over the
  part's full length, summed over coaxial through holes) with both ends in one part leaves
  no surface for two fingers when seated (a bearing pressed flush in its bore, a dowel flush
  with both faces of a leg): ``operation: press_tool`` along the mates' axis (the note says
  an inside gripper could take a ring or sleeve by its bore; a solid dowel only a press tool
  pushing its end: its end face is no grip for fingers). A dowel whose
  ends lie in two parts (the second goes over it later) is not flagged.

Screwed fasteners (bolts, nuts) are not parts of the written product at all (listed as
fastenings in comments), so no ``operation: fastening`` is written for them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .cad_types import ImportedPart, ProposedMate

FLUSH_TOL_M = 1e-4  # engaged within 0.1 mm of the part's length: nothing sticks out


@dataclass(frozen=True)
class OperationHint:
    """What places a part instead of the gripper: ``operation`` (press_tool, manual),
    ``insertion_direction`` (world = assembly frame, unit), ``note`` and ``evidence``."""

    operation: str
    insertion_direction: np.ndarray
    note: str
    evidence: str


def _ends_in_one_part(outer: Sequence[ProposedMate]) -> bool:
    """Both ends of the male lie in females of one part (a bearing in its bore; a dowel
    across a leg, flush with both faces): that part is there when the male is placed, so the
    male ends flush whatever the order. Ends in two parts (a dowel in a base plate that a
    plate goes over later) say nothing of the male's own step."""
    if any(m.engage_start_m is None for m in outer):
        return len({m.female_part for m in outer}) == 1
    ref = np.asarray(outer[0].axis, dtype=float)
    spans = []
    for m in outer:
        start = m.engage_start_m
        assert start is not None  # every None returned above
        t = float(np.dot(start, ref))
        lo, hi = (t - m.engaged_m, t) if float(np.dot(m.axis, ref)) > 0 else (t, t + m.engaged_m)
        spans.append((lo, hi, m.female_part))
    return min(spans)[2] == max(spans, key=lambda s: s[1])[2]


def operation_hint(part: ImportedPart, mates: Sequence[ProposedMate],
                   revolved: tuple | None) -> OperationHint | None:
    """The operation that places ``part`` if the importer can tell it is not a gripper step,
    else None. ``revolved``: the part's exact primitive (``_revolved_primitive``) or None."""
    for m in mates:
        if m.male_part == part.name and m.kind == "non_round" and m.male.kind == "tenon":
            return OperationHint(
                "manual", -np.asarray(m.axis, dtype=float),
                f"{m.male.name} into {m.female_part}.{m.female.name}: a tenon in a mortise",
                f"{m.male.kind} {m.male.name} in {m.female.kind} {m.female_part}."
                f"{m.female.name}, engaged {m.engaged_m * 1e3:.1f} mm: not round, not simulated")
    if revolved is None:
        return None
    _T, d_m, length_m, bore, _why = revolved
    outer = [m for m in mates
             if m.male_part == part.name and m.simulated and m.female.kind in ("hole", "bore")
             and abs(m.male.diameter_m - d_m) < 1e-6]
    engaged_m = sum(m.engaged_m for m in outer)  # through coaxial females: disjoint spans
    if not outer or engaged_m < length_m - FLUSH_TOL_M or not _ends_in_one_part(outer):
        return None
    where = ", ".join(f"{m.female_part}.{m.female.name} ({m.engaged_m * 1e3:.3g} mm)"
                      for m in outer)
    return OperationHint(
        "press_tool", -np.asarray(outer[0].axis, dtype=float),
        f"seated flush in {', '.join(f'{m.female_part}.{m.female.name}' for m in outer)}: a "
        + ("press tool or an inside gripper in its bore" if bore is not None else
           "press tool pushing its end (solid: no bore for an inside gripper)")
        + ", not two fingers",
        f"its outer cylinder ({d_m * 1e3:.3g} mm) is engaged {engaged_m * 1e3:.3g} mm over "
        f"its whole length ({length_m * 1e3:.3g} mm) in {where}: no surface left outside "
        "for the fingers")
