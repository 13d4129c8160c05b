"""Why a step failed, as typed codes with values and limits (one place, easy to merge).

A :class:`Failure` names a cause a cell engineer recognises, with the number that decided it:

* ``rim_stop``  the insertion never got past the hole's mouth (no capture): ``value`` is the
  depth entered, ``limit`` the depth below which that counts as the rim;
* ``jammed``    it entered and stopped short: ``value`` the depth reached, ``limit`` the
  engagement length; ``detail`` the two-point evidence (tilt and lateral offset at the stop);
* ``slipped``   the part slipped in the grip before the insertion: ``value`` the slip, ``limit``
  the allowed slip;
* ``fell``      a body left the scene or fell freely: ``value`` its speed, ``limit`` the speed
  bound, with the body and its position;
* ``unstable``  a body gained speed no force in the scene explains: ``value`` its speed,
  ``limit`` the bound, with the body and its position.

The step ends at the first ``fell``/``unstable`` (:class:`SceneGuard`), so no result holds a
position from after it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

FailureCode = Literal["rim_stop", "jammed", "slipped", "fell", "unstable"]
FAILURE_CODES: tuple[str, ...] = ("rim_stop", "jammed", "slipped", "fell", "unstable")


@dataclass(frozen=True)
class Failure:
    """One typed failure cause (see the module docstring for each code's value and limit)."""

    code: FailureCode
    value: float
    limit: float
    unit: str
    body: str = ""
    position_m: tuple[float, float, float] | None = None
    detail: str = ""

    def __post_init__(self) -> None:
        if self.code not in FAILURE_CODES:
            raise ValueError(f"Failure.code: expected one of {list(FAILURE_CODES)}, "
                             f"found {self.code!r}")

    @property
    def message(self) -> str:
        """The cause in words, with its numbers."""
        scale, u = (1e3, "mm") if self.unit == "m" else (1.0, self.unit)
        v, lim = self.value * scale, self.limit * scale
        where = ("" if self.position_m is None else
                 " at (" + ", ".join(f"{c * 1e3:.1f}" for c in self.position_m) + ") mm")
        text = {
            "rim_stop": f"stopped on the rim: entered {v:.3f} {u} (< {lim:.3f} {u}), no capture",
            "jammed": f"jammed at {v:.3f} {u} of {lim:.3f} {u}",
            "slipped": f"slipped in the grip: {v:.3f} {u} > {lim:.3f} {u} before the insertion",
            "fell": f"fell: {self.body} at {v:.2f} {u} (bound {lim:.2f} {u}){where}",
            "unstable": f"unstable: {self.body} at {v:.2f} {u} (bound {lim:.2f} {u}){where}",
        }[self.code]
        return text + (f"; {self.detail}" if self.detail else "")

    def to_dict(self) -> dict[str, Any]:
        return {"code": self.code, "value": _finite(self.value), "limit": _finite(self.limit),
                "unit": self.unit, "body": self.body,
                "position_m": None if self.position_m is None else list(self.position_m),
                "detail": self.detail}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Failure:
        pos = d.get("position_m")
        return cls(code=d["code"], value=_nan(d.get("value")), limit=_nan(d.get("limit")),
                   unit=d.get("unit", ""), body=d.get("body", ""),
                   position_m=None if pos is None else (float(pos[0]), float(pos[1]),
                                                        float(pos[2])),
                   detail=d.get("detail", ""))


def _finite(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def _nan(v: Any) -> float:
    return math.nan if v is None else float(v)


@dataclass(frozen=True)
class SceneGuard:
    """When a step stops early: a watched body faster than ``max_speed_mps`` or farther than
    ``cell_half_size_m`` from the cell's centre (its table) ends the step at that record row.

    A body with more kinetic energy than its fall explains (``m g`` times its drop from the
    highest point it reached, plus ``m max_speed^2 / 2``) is "unstable": the solver gave it
    that energy (a light cube ejected from under a heavy block). Otherwise it "fell" (a part
    dropped beside the table, a peg toppling), as does one that left the cell.
    """

    max_speed_mps: float = 1.0
    cell_half_size_m: float = 1.0
    cell_centre_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for label in ("max_speed_mps", "cell_half_size_m"):
            v = getattr(self, label)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"SceneGuard.{label}: expected > 0, found {v}")


def classify_insertion(entered_m: float, engagement_m: float, rim_depth_m: float,
                       tilt_rad: float, lateral_m: float) -> Failure:
    """The cause of an insertion that did not reach its depth: ``rim_stop`` when less than
    ``rim_depth_m`` entered, else ``jammed`` at the depth reached, with the tilt and lateral
    offset of the part at its deepest point (the two-point contact evidence)."""
    if entered_m < rim_depth_m:
        return Failure("rim_stop", entered_m, rim_depth_m, "m",
                       detail=f"lateral offset {lateral_m * 1e3:.3f} mm, tilt "
                              f"{math.degrees(tilt_rad):.2f} deg")
    return Failure("jammed", entered_m, engagement_m, "m",
                   detail=f"two-point evidence: tilt {math.degrees(tilt_rad):.2f} deg, lateral "
                          f"offset {lateral_m * 1e3:.3f} mm at the deepest point")


__all__ = ["FAILURE_CODES", "Failure", "FailureCode", "SceneGuard", "classify_insertion"]
