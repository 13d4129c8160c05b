"""Parts of an imported assembly that a two-finger gripper cannot place: the ``handling:
{operation: ...}`` the importer writes for them, with its evidence.

- A part mated by a tenon in a mortise (a non-round joint, recognised and not simulated) is
  placed by a manual (joinery) station along the joint's axis: ``operation: manual``.
- A plain ring or sleeve (a body of revolution, :func:`asmplan.parts.cad_product`'s exact
  primitive) whose whole outer cylinder ends up inside one bore (engaged over the part's
  full length) leaves no surface for two fingers when seated (a bearing pressed flush):
  ``operation: press_tool`` along the bore's axis.

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
    _T, d_m, length_m, _bore, _why = revolved
    for m in mates:
        if (m.male_part == part.name and m.simulated and m.female.kind in ("hole", "bore")
                and abs(m.male.diameter_m - d_m) < 1e-6
                and m.engaged_m >= length_m - FLUSH_TOL_M):
            return OperationHint(
                "press_tool", -np.asarray(m.axis, dtype=float),
                f"seated flush in {m.female_part}.{m.female.name}: a press tool or an inside "
                "gripper, not two fingers",
                f"its outer cylinder ({d_m * 1e3:.3g} mm) is engaged {m.engaged_m * 1e3:.3g} mm "
                f"in {m.female_part}.{m.female.name} over its whole length "
                f"({length_m * 1e3:.3g} mm): no surface left outside the bore for the fingers")
    return None
