"""Why a step failed, as typed codes with values and limits (one place, easy to merge).

A :class:`Failure` names a cause a cell engineer recognises, with the number that decided it:

* ``rim_stop``  the insertion never got past the hole's mouth (no capture): ``value`` is the
  depth entered, ``limit`` the depth below which that counts as the rim;
* ``jammed``    it entered and stopped short: ``value`` the depth reached, ``limit`` the
  engagement length; ``detail`` the two-point evidence (tilt and lateral offset at the stop)
  and ``contacts`` the two contact points that hold it (:func:`two_point_contacts`: the most
  loaded contact, and the most loaded one on the opposite side of the mate axis, with their
  partner, position, normal and force);
* ``slipped``   the part slipped in the grip before the insertion: ``value`` the slip, ``limit``
  the allowed slip;
* ``fell``      a body left the scene or fell freely: ``value`` its speed, ``limit`` the speed
  bound, with the body and its position;
* ``unstable``  a body gained speed no force in the scene explains: ``value`` its speed,
  ``limit`` the bound, with the body and its position; or it sinks into another body (the
  solver cannot hold it up): ``value`` its penetration (unit "m"), ``limit`` the bound.

The step ends at the first ``fell``/``unstable`` (:class:`SceneGuard`), so no result holds a
position from after it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

FailureCode = Literal["rim_stop", "jammed", "slipped", "fell", "unstable"]
FAILURE_CODES: tuple[str, ...] = ("rim_stop", "jammed", "slipped", "fell", "unstable")


@dataclass(frozen=True)
class ContactEvidence:
    """One contact point of the part at the moment a failure was judged: ``partner`` (body
    name), ``position_m`` (world, on the partner's surface), ``normal`` (world, unit, from
    the partner toward the part), ``normal_force_N`` and ``side`` ("a": the most loaded
    contact; "b": the most loaded on the other side of the mate axis)."""

    partner: str
    position_m: tuple[float, float, float]
    normal: tuple[float, float, float]
    normal_force_N: float
    side: str

    def to_dict(self) -> dict[str, Any]:
        return {"partner": self.partner, "position_m": list(self.position_m),
                "normal": list(self.normal), "normal_force_N": _finite(self.normal_force_N),
                "side": self.side}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ContactEvidence:
        p, n = d["position_m"], d["normal"]
        return cls(partner=d.get("partner", ""),
                   position_m=(float(p[0]), float(p[1]), float(p[2])),
                   normal=(float(n[0]), float(n[1]), float(n[2])),
                   normal_force_N=_nan(d.get("normal_force_N")), side=d.get("side", ""))


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
    contacts: tuple[ContactEvidence, ...] = ()

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
            "unstable": (f"unstable: {self.body} at {v:.2f} {u} (bound {lim:.2f} {u}){where}"
                         if self.unit != "m" else
                         f"unstable: {self.body} sank {v:.3f} {u} (bound {lim:.3f} {u}){where}"),
        }[self.code]
        return text + (f"; {self.detail}" if self.detail else "")

    def to_dict(self) -> dict[str, Any]:
        return {"code": self.code, "value": _finite(self.value), "limit": _finite(self.limit),
                "unit": self.unit, "body": self.body,
                "position_m": None if self.position_m is None else list(self.position_m),
                "detail": self.detail, "contacts": [c.to_dict() for c in self.contacts]}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Failure:
        pos = d.get("position_m")
        return cls(code=d["code"], value=_nan(d.get("value")), limit=_nan(d.get("limit")),
                   unit=d.get("unit", ""), body=d.get("body", ""),
                   position_m=None if pos is None else (float(pos[0]), float(pos[1]),
                                                        float(pos[2])),
                   detail=d.get("detail", ""),
                   contacts=tuple(ContactEvidence.from_dict(c) for c in d.get("contacts", ())))


def _finite(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def _nan(v: Any) -> float:
    return math.nan if v is None else float(v)


@dataclass(frozen=True)
class SceneGuard:
    """When a step stops early: a watched body faster than ``max_speed_mps``, farther than
    ``cell_half_size_m`` from the cell's centre (its table), or sinking into another body
    (a penetration deeper than ``max_sink_m`` at two record rows in a row, still growing)
    ends the step at that record row (:class:`asmplan.sim.guard.SceneWatch`).

    A body with more kinetic energy than its fall explains (``m g`` times its drop from the
    highest point it reached, plus ``m max_speed^2 / 2``) is "unstable": the solver gave it
    that energy (a light cube ejected from under a heavy block). Otherwise it "fell" (a part
    dropped beside the table, a peg toppling), as does one that left the cell.
    """

    max_speed_mps: float = 1.0
    cell_half_size_m: float = 1.0
    cell_centre_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    max_sink_m: float = 0.5e-3

    def __post_init__(self) -> None:
        for label in ("max_speed_mps", "cell_half_size_m", "max_sink_m"):
            v = getattr(self, label)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"SceneGuard.{label}: expected > 0, found {v}")


def two_point_contacts(partners: Sequence[str], positions_m: np.ndarray, normals: np.ndarray,
                       normal_forces_N: np.ndarray, axis_point_m: np.ndarray,
                       axis: np.ndarray) -> tuple[ContactEvidence, ...]:
    """The two contacts that hold a wedged part: the most loaded contact point (side "a")
    and the most loaded one on the other side of the mate axis (side "b": its offset from
    the axis, perpendicular to it, points away from the first's), or the first alone when
    no loaded contact lies on the other side (no two-point wedge). Points without normal
    force are ignored.

    Parameters
    ----------
    partners : (n,) body names; positions_m, normals : (n, 3) world; normal_forces_N : (n,)
    axis_point_m : (3,) a point on the part's axis; axis : (3,) unit mate axis (world).
    """
    f = np.asarray(normal_forces_N, dtype=float)
    loaded = np.flatnonzero(f > 0.0)
    if loaded.size == 0:
        return ()
    pos = np.asarray(positions_m, dtype=float)
    ax = np.asarray(axis, dtype=float)
    rel = pos - np.asarray(axis_point_m, dtype=float)
    lateral = rel - np.outer(rel @ ax, ax)
    i = int(loaded[np.argmax(f[loaded])])

    def ev(k: int, side: str) -> ContactEvidence:
        p, n = pos[k], np.asarray(normals[k], dtype=float)
        return ContactEvidence(str(partners[k]), (float(p[0]), float(p[1]), float(p[2])),
                               (float(n[0]), float(n[1]), float(n[2])), float(f[k]), side)

    out = [ev(i, "a")]
    other = [int(k) for k in loaded if float(lateral[k] @ lateral[i]) < 0.0]
    if other:
        out.append(ev(max(other, key=lambda k: float(f[k])), "b"))
    return tuple(out)


def _contacts_text(contacts: Sequence[ContactEvidence], axis: np.ndarray | None) -> str:
    if not contacts:
        return ""
    parts = [f"{c.side}: {c.partner} at (" + ", ".join(f"{v * 1e3:.2f}" for v in c.position_m)
             + f") mm, normal ({', '.join(f'{v:+.3f}' for v in c.normal)}), "
             f"{c.normal_force_N:.2f} N" for c in contacts]
    if len(contacts) == 2 and axis is not None:
        sep = abs(float((np.asarray(contacts[0].position_m) - np.asarray(contacts[1].position_m))
                        @ np.asarray(axis)))
        head = f"two-point contact {sep * 1e3:.2f} mm apart along the axis"
    else:
        head = "one-sided contact (no second point across the axis)"
    return head + ": " + "; ".join(parts)


def classify_insertion(entered_m: float, engagement_m: float, rim_depth_m: float,
                       tilt_rad: float, lateral_m: float,
                       contacts: Sequence[ContactEvidence] = (),
                       axis: np.ndarray | None = None) -> Failure:
    """The cause of an insertion that did not reach its depth: ``rim_stop`` when less than
    ``rim_depth_m`` entered, else ``jammed`` at the depth reached, with the tilt and lateral
    offset of the part at its deepest point and the contacts holding it there
    (:func:`two_point_contacts`): the two-point contact evidence."""
    if entered_m < rim_depth_m:
        return Failure("rim_stop", entered_m, rim_depth_m, "m",
                       detail=f"lateral offset {lateral_m * 1e3:.3f} mm, tilt "
                              f"{math.degrees(tilt_rad):.2f} deg",
                       contacts=tuple(contacts))
    text = _contacts_text(contacts, axis)
    return Failure("jammed", entered_m, engagement_m, "m",
                   detail=f"two-point evidence: tilt {math.degrees(tilt_rad):.2f} deg, lateral "
                          f"offset {lateral_m * 1e3:.3f} mm at the deepest point"
                          + (f"; {text}" if text else ""),
                   contacts=tuple(contacts))


__all__ = ["FAILURE_CODES", "ContactEvidence", "Failure", "FailureCode", "SceneGuard",
           "classify_insertion", "two_point_contacts"]
