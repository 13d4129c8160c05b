"""Knowledge: the default ISO 286 fit of a pin/hole pair that CAD draws line to line.

CAD models a pin and its hole at one nominal diameter; the fit is an annotation on the
drawing. The rules in ``data/default_fits.yaml`` (or a product's own) give a fit per male and
female feature kind and diameter, with the reason, so that an imported line-to-line pair gets
a real clearance range instead of being judged as an interference.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from typing import Any

import yaml


@dataclass(frozen=True)
class FitRule:
    """``fit`` applies to a ``male`` kind in a ``female`` kind of a nominal diameter over
    ``min_diameter_m`` up to and including ``max_diameter_m`` (ISO 286's size ranges; ``any``
    matches every kind). ``source`` says where the rule was written (a product file's
    ``default_fits`` entry, or the built-in table)."""

    male: str
    female: str
    max_diameter_m: float
    fit: str
    why: str
    min_diameter_m: float = 0.0
    source: str = "knowledge/data/default_fits.yaml"

    def matches(self, male: str, female: str, diameter_m: float) -> bool:
        return (self.male in ("any", male) and self.female in ("any", female)
                and self.min_diameter_m + 1e-12 < diameter_m <= self.max_diameter_m + 1e-12)


def rules_from(data: list[dict[str, Any]]) -> tuple[FitRule, ...]:
    """Rules from YAML mappings (``min_diameter`` and ``max_diameter`` in mm)."""
    return tuple(FitRule(str(r.get("male", "any")), str(r.get("female", "any")),
                         float(r.get("max_diameter", 500)) * 1e-3, str(r["fit"]), str(r.get("why", "")),
                         float(r.get("min_diameter", 0)) * 1e-3)
                 for r in data)


def builtin_rules() -> tuple[FitRule, ...]:
    """The built-in rules (``knowledge/data/default_fits.yaml``)."""
    text = resources.files("asmplan.knowledge").joinpath("data/default_fits.yaml").read_text()
    return rules_from(yaml.safe_load(text)["rules"])


def default_fit(male: str, female: str, diameter_m: float, rules: tuple[FitRule, ...] | None = None
                ) -> FitRule | None:
    """The first rule for this pair, or None."""
    for r in rules if rules is not None else builtin_rules():
        if r.matches(male, female, diameter_m):
            return r
    return None


__all__ = ["FitRule", "builtin_rules", "default_fit", "rules_from"]
