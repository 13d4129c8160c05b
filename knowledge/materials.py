"""The built-in material table (density, friction, display colour, elastic constants)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

import yaml


@dataclass(frozen=True)
class Material:
    """A material: ``density_kg_m3`` and the per-body friction coefficient ``friction``.

    PyBullet multiplies the coefficients of the two bodies in contact, so ``friction`` is
    chosen such that the product matches handbook values for common pairs.
    ``elastic_modulus_Pa`` (Young's modulus) and ``poisson_ratio`` are used by the press-fit
    model (:mod:`asmplan.knowledge.press_fit`); None when unknown.
    """

    name: str
    density_kg_m3: float
    friction: float
    color_rgb: tuple[float, float, float] = (0.7, 0.7, 0.7)
    elastic_modulus_Pa: float | None = None
    poisson_ratio: float | None = None

    def __post_init__(self) -> None:
        if self.density_kg_m3 <= 0:
            raise ValueError(f"material {self.name}: density must be positive, found {self.density_kg_m3}")
        if self.friction < 0:
            raise ValueError(f"material {self.name}: friction must be >= 0, found {self.friction}")
        if self.elastic_modulus_Pa is not None and not self.elastic_modulus_Pa > 0:
            raise ValueError(f"material {self.name}: elastic modulus must be positive, found "
                             f"{self.elastic_modulus_Pa}")
        if self.poisson_ratio is not None and not 0.0 <= self.poisson_ratio < 0.5:
            raise ValueError(f"material {self.name}: Poisson's ratio must be in [0, 0.5), found "
                             f"{self.poisson_ratio}")


@cache
def builtin_materials() -> dict[str, Material]:
    """The built-in table, keyed by name."""
    text = resources.files("asmplan.knowledge").joinpath("data/materials.yaml").read_text("utf-8")
    table = yaml.safe_load(text)
    return {
        name: Material(name, float(row["density"]), float(row["friction"]),
                       _rgb(row.get("color", (0.7, 0.7, 0.7))),
                       _gpa(row.get("elastic_modulus_gpa")),
                       None if row.get("poisson_ratio") is None else float(row["poisson_ratio"]))
        for name, row in table.items()
    }


def _rgb(values: Any) -> tuple[float, float, float]:
    r, g, b = (float(c) for c in values)
    return (r, g, b)


def _gpa(value: Any) -> float | None:
    return None if value is None else float(value) * 1e9
