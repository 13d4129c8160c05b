"""What a CAD import produces and is set with: its settings, the imported parts, the proposed
mates, the whole result, its error, and the small pose helpers they share."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import AsmplanError
from ..knowledge.fit_rules import FitRule
from .cad_features import CadFeature


class CadImportError(AsmplanError, ValueError):
    """An assembly that cannot be imported; ``path`` and ``reason`` say which and why."""

    def __init__(self, path: Path | str, reason: str):
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"{self.path}: {reason}")


@dataclass(frozen=True)
class ImportSettings:
    """Settings of :func:`import_assembly`.

    Parameters
    ----------
    deflection_m : chordal deflection of the STEP tessellation written for each part.
    max_clearance_ratio : a drawn diametral clearance up to this fraction of the male diameter
        makes a mate; a larger gap is a pass-through (noted, no mate).
    mesh_units_m : metres per unit of mesh files (STEP carries its own unit).
    primitives : write plain (chamfered, bored) cylinders as exact primitives, not meshes.
    fit_rules : default fits for line-to-line pairs, tried before the built-in ones
        (``knowledge/data/default_fits.yaml``); e.g. a product file's ``default_fits``
        (``asmplan import --default-fits``). They are written into the product's
        ``default_fits:`` section.
    """

    deflection_m: float = 2e-6
    max_clearance_ratio: float = 0.35
    mesh_units_m: float = 1e-3
    fit_rules: tuple[FitRule, ...] | None = None
    primitives: bool = True


@dataclass(frozen=True, eq=False)
class ImportedPart:
    """One part instance: its definition, placement (4, 4, metres) and features (part frame)."""

    name: str
    definition: str
    T_assembly_part: np.ndarray
    features: tuple[CadFeature, ...]
    vertices_m: np.ndarray
    faces: np.ndarray
    volume_m3: float
    notes: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class ProposedMate:
    """A male feature of one part in a female feature of another, in the assembly frame.

    ``kind``: fit (line to line, ``fit`` from the rules), clearance (as drawn), thread,
    interference (as drawn), non_round. ``mouth_m`` and ``axis`` (outward normal of the female's
    mouth) are in the assembly frame; ``engaged_m`` is the overlap along the axis.
    """

    male_part: str
    male: CadFeature
    female_part: str
    female: CadFeature
    kind: str
    mouth_m: np.ndarray
    axis: np.ndarray
    engaged_m: float
    fit: FitRule | None = None
    evidence: tuple[str, ...] = ()
    engage_start_m: np.ndarray | None = None

    @property
    def simulated(self) -> bool:
        return self.kind in ("fit", "clearance", "interference")


@dataclass(frozen=True, eq=False)
class ImportResult:
    source: Path
    name: str
    file_unit: str
    parts: tuple[ImportedPart, ...]
    mates: tuple[ProposedMate, ...]
    fasteners: tuple[str, ...]
    base: str
    notes: tuple[str, ...] = field(default_factory=tuple)
    primitives: bool = True
    fit_rules: tuple[FitRule, ...] = ()

    def part(self, name: str) -> ImportedPart:
        return next(p for p in self.parts if p.name == name)


def _clean(name: str) -> str:
    s = re.sub(r"[^A-Za-z0-9_-]+", "_", name).strip("_")
    return s or "part"


def _apply(T: np.ndarray, p: np.ndarray) -> np.ndarray:
    return T[:3, :3] @ p + T[:3, 3]


def _apply_all(T: np.ndarray, V: np.ndarray) -> np.ndarray:
    return V @ T[:3, :3].T + T[:3, 3]
