"""The state shared while a product document is built (:class:`BuilderBase`: the document,
its error context and unit scales) and the small conversions every section uses."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from .frames import make_T
from .product_schema import ANGLE_UNITS, LENGTH_UNITS, MASS_UNITS, UNITS
from .schema import INVALID, Context
from .yamlsource import Located, PathKey


def _pose(v: dict[str, Any] | None) -> np.ndarray:
    return np.eye(4) if v is None else make_T(v["xyz"], v["rpy"])


def _unit(v: Any) -> np.ndarray:
    """Unit vector along ``v`` (non-zero, finite), without overflow for huge components."""
    a = np.asarray(v, dtype=float)
    a = a / np.max(np.abs(a))
    return a / np.linalg.norm(a)


class BuilderBase:
    """The state of one document being built: the document, its error context (issues and
    unit scales) and the key paths of its features and mates."""

    def __init__(self, doc: Located, base_dir: Path, consistency: bool = True):
        self.consistency = consistency
        self.doc = doc
        self.base_dir = base_dir
        self.ctx = Context(doc, {})
        self.feature_paths: dict[tuple[str, str], PathKey] = {}
        self.mate_paths: dict[str, PathKey] = {}

    # -- helpers ---------------------------------------------------------------------------
    def err(self, path: PathKey, message: str, *, key: bool = False) -> None:
        self.ctx.error(path, message, key=key)

    def setup_units(self, data: dict[str, Any]) -> None:
        """The document's unit scales and names (``units:``), into the context."""
        units = UNITS.check(data.get("units") or {}, ("units",), self.ctx) if "units" in data else \
            {"length": "mm", "mass": "kg", "angle": "deg"}
        if units is INVALID:
            units = {"length": "mm", "mass": "kg", "angle": "deg"}
            raw_units: dict[str, Any] = data["units"] if isinstance(data.get("units"), dict) else {}
            units.update({k: v for k, v in raw_units.items()
                          if isinstance(v, str) and v in {**LENGTH_UNITS, **MASS_UNITS, **ANGLE_UNITS}})
        L = LENGTH_UNITS.get(units["length"], 1e-3)
        self.ctx.scales = {"length": L, "mass": MASS_UNITS.get(units["mass"], 1.0),
                           "angle": ANGLE_UNITS.get(units["angle"], math.pi / 180), "speed": L,
                           "acceleration": L}
        length_name = units["length"] if units["length"] in LENGTH_UNITS else "mm"
        self.ctx.unit_names.update(
            length=length_name, speed=f"{length_name}/s", acceleration=f"{length_name}/s^2",
            mass=units["mass"] if units["mass"] in MASS_UNITS else "kg",
            angle=units["angle"] if units["angle"] in ANGLE_UNITS else "deg")
