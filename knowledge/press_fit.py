"""Press and transition fits: the interference a fit gives and the axial force it needs.

Contact pressure (thick-walled cylinders, Lame; Shigley's Mechanical Engineering Design,
10th ed., eq. 3-56, and DIN 7190-1 for the elastic case)::

    p = delta / (d [ (1/E_o) ((D_o^2 + d^2) / (D_o^2 - d^2) + nu_o)
                   + (1/E_i) ((d^2 + d_i^2) / (d^2 - d_i^2) - nu_i) ])

with ``delta`` the diametral interference, ``d`` the nominal joint diameter, ``D_o`` the hub's
outer diameter (``inf`` for a hole deep inside a large block: the ratio tends to 1), ``d_i``
the bore of a hollow male part (0 for a solid pin), ``E``/``nu`` Young's modulus and Poisson's
ratio of the outer (hub, ``_o``) and inner (male, ``_i``) part. The axial force to press the
male part in over an engaged length ``L`` is ``F = mu p pi d L`` with ``mu`` the press-fit
friction (adhesion) coefficient of the material pair (``data/press_fit.yaml``, DIN 7190-1).
The force grows linearly with the engaged depth; ``F`` is its value at full depth.

Size model (transition fits and the press force range)
------------------------------------------------------
Each actual size is assumed NORMAL, centred in its ISO 286 tolerance zone, with the zone
width equal to 6 standard deviations (a process just capable, Cp = 1; parts outside the zone
are rejected at inspection, so the extremes are the zone limits). This is the usual
assumption of statistical tolerancing (RSS stack-up) for machined sizes from a stable process;
a uniform distribution would overstate how often the zone's extremes occur. The clearance
``c = D - d`` is then normal with mean ``mid(hole zone) - mid(shaft zone)`` and standard
deviation ``sqrt(IT_hole^2 + IT_shaft^2) / 6``; a transition fit interferes with probability
``Phi(-mean / sigma)`` (the truncation at the zone limits is ignored there: it changes the
tails beyond 3 sigma only). A mate declared by a clearance range without an ISO fit uses a
normal clearance centred in the range with 6 sigma = its width.

The force range reported for a mate that interferes: ``min`` at the smallest interference
(0 for a transition fit: the pair just touches), ``typical`` at the expected interference
given that it interferes (the mid-zone interference for an interference fit), ``max`` at the
largest interference the zones allow (``-clearance_min``). Units: SI throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from importlib import resources

import yaml

from ..errors import AsmplanError
from . import iso286
from .materials import Material
from .model import Mate


class PressFitError(AsmplanError, ValueError):
    """The press force of a mate cannot be predicted (a material lacks elastic data, a
    geometry that is not a cylinder joint); ``mate`` names it."""

    def __init__(self, mate: str, message: str):
        self.mate = mate
        super().__init__(f"mate {mate}: {message}")


def lame_pressure_Pa(interference_m: float, diameter_m: float, hub_outer_diameter_m: float,
                     male_bore_diameter_m: float, E_outer_Pa: float, nu_outer: float,
                     E_inner_Pa: float, nu_inner: float) -> float:
    """Contact pressure (Pa) of a cylindrical interference joint (see the module docstring).

    Parameters
    ----------
    interference_m : float
        Diametral interference delta >= 0, m.
    diameter_m : float
        Joint diameter d, m.
    hub_outer_diameter_m : float
        Hub outer diameter D_o > d, m (``math.inf`` for an unbounded plate).
    male_bore_diameter_m : float
        Bore d_i of a hollow male part, 0 <= d_i < d, m.
    E_outer_Pa, nu_outer, E_inner_Pa, nu_inner : float
        Elastic constants of the hub (outer) and the male part (inner).
    """
    d, D, di = float(diameter_m), float(hub_outer_diameter_m), float(male_bore_diameter_m)
    if not d > 0:
        raise ValueError(f"diameter_m: expected > 0, found {d}")
    if not d < D:
        raise ValueError(f"hub_outer_diameter_m: expected > d = {d}, found {D}")
    if not 0 <= di < d:
        raise ValueError(f"male_bore_diameter_m: expected 0 <= d_i < d = {d}, found {di}")
    if interference_m <= 0:
        return 0.0
    outer = 1.0 if math.isinf(D) else (D * D + d * d) / (D * D - d * d)
    inner = (d * d + di * di) / (d * d - di * di)
    compliance = (outer + nu_outer) / E_outer_Pa + (inner - nu_inner) / E_inner_Pa
    return float(interference_m) / (d * compliance)


def press_force_N(pressure_Pa: float, mu: float, diameter_m: float, length_m: float) -> float:
    """Axial press force ``mu p pi d L`` (N) at an engaged length ``length_m``."""
    return float(mu) * float(pressure_Pa) * math.pi * float(diameter_m) * float(length_m)


@cache
def _friction_table() -> tuple[float, dict[frozenset[str], float]]:
    text = resources.files("asmplan.knowledge").joinpath("data/press_fit.yaml").read_text("utf-8")
    data = yaml.safe_load(text)
    pairs = {frozenset((row["a"], row["b"])): float(row["mu"]) for row in data["pairs"]}
    return float(data["default"]), pairs


def press_friction(a: str, b: str) -> tuple[float, str]:
    """Press-fit friction coefficient of materials ``a`` and ``b`` and where it came from
    (``"table"`` for a tabulated pair, ``"default"`` otherwise)."""
    default, pairs = _friction_table()
    mu = pairs.get(frozenset((a, b)))
    return (mu, "table") if mu is not None else (default, "default")


@dataclass(frozen=True)
class ClearanceModel:
    """The statistical model of one mate's diametral clearance ``c`` (m; < 0 interferes).

    ``min_m``/``max_m`` are the worst-case limits, ``mean_m``/``sigma_m`` the normal model of
    the module docstring (``sigma_m`` 0 for a single declared value).
    """

    min_m: float
    max_m: float
    mean_m: float
    sigma_m: float
    distribution: str

    @property
    def probability_interference(self) -> float:
        """P(c < 0): 1 for an interference fit, 0 for a clearance fit."""
        if self.max_m <= 0:
            return 1.0
        if self.min_m >= 0:
            return 0.0
        if self.sigma_m <= 0:
            return 1.0 if self.mean_m < 0 else 0.0
        return 0.5 * math.erfc(self.mean_m / (self.sigma_m * math.sqrt(2.0)))

    def interference_range_m(self) -> tuple[float, float, float]:
        """(min, typical, max) diametral interference when the pair interferes, m."""
        hi = -self.min_m
        if self.max_m <= 0:
            return -self.max_m, -self.mean_m, hi
        if self.sigma_m <= 0:
            return 0.0, max(-self.mean_m, 0.0), hi
        mu = -self.mean_m  # interference delta = -c ~ N(mu, sigma); E[delta | delta > 0]
        z = mu / self.sigma_m
        tail = 0.5 * math.erfc(-z / math.sqrt(2.0))  # P(delta > 0)
        pdf = math.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)
        typical = mu + self.sigma_m * pdf / max(tail, 1e-300)
        return 0.0, min(max(typical, 0.0), hi), hi

    def sample_m(self, rng) -> float:
        """One clearance drawn from the model, within [min_m, max_m] (rejection), m.

        ``rng`` is a ``numpy.random.Generator``."""
        if self.sigma_m <= 0:
            return self.mean_m
        for _ in range(1000):
            c = float(rng.normal(self.mean_m, self.sigma_m))
            if self.min_m <= c <= self.max_m:
                return c
        return min(max(self.mean_m, self.min_m), self.max_m)


def clearance_model(mate: Mate, nominal_m: float) -> ClearanceModel:
    """The clearance model of ``mate`` at its nominal diameter (see the module docstring)."""
    if mate.fit:
        f = iso286.fit(mate.fit, nominal_m)
        mean = 0.5 * (f.hole.lower_m + f.hole.upper_m) - 0.5 * (f.shaft.lower_m + f.shaft.upper_m)
        sigma = math.hypot(f.hole.width_m, f.shaft.width_m) / 6.0
        return ClearanceModel(f.clearance_min_m, f.clearance_max_m, mean, sigma,
                              f"normal sizes centred in {f.hole.code} and {f.shaft.code}, "
                              "6 sigma = zone width")
    width = mate.clearance_max_m - mate.clearance_min_m
    return ClearanceModel(mate.clearance_min_m, mate.clearance_max_m, mate.clearance_mean_m,
                          width / 6.0, "normal clearance centred in the declared range, "
                          "6 sigma = its width" if width > 0 else "single declared value")


@dataclass(frozen=True)
class PressFit:
    """The predicted press force of one interference or transition mate (SI).

    ``force_N`` and ``pressure_Pa`` are (min, typical, max) at full engagement for the
    interference range ``interference_m`` (see the module docstring).
    ``probability_interference`` is 1 for an interference fit.
    """

    mate: str
    kind: str
    fit: str | None
    diameter_m: float
    engaged_length_m: float
    hub_outer_diameter_m: float
    hub_outer_source: str
    male_bore_diameter_m: float
    hub_material: str
    male_material: str
    mu: float
    mu_source: str
    interference_m: tuple[float, float, float]
    pressure_Pa: tuple[float, float, float]
    force_N: tuple[float, float, float]
    probability_interference: float
    distribution: str

    def force_at_depth_N(self, depth_m: float, which: int = 1) -> float:
        """Resistance (N) at an engaged depth ``depth_m``: linear in the depth (the contact
        area grows with it), ``force_N[which]`` at full engagement."""
        frac = min(max(depth_m / self.engaged_length_m, 0.0), 1.0) if self.engaged_length_m > 0 else 0.0
        return self.force_N[which] * frac

    def as_dict(self) -> dict[str, object]:
        lo, typ, hi = self.force_N
        return {
            "mate": self.mate, "kind": self.kind, "fit": self.fit,
            "press_force_N": {"min": lo, "typical": typ, "max": hi},
            "probability_interference": self.probability_interference,
            "interference_m": dict(zip(("min", "typical", "max"), self.interference_m, strict=True)),
            "pressure_Pa": dict(zip(("min", "typical", "max"), self.pressure_Pa, strict=True)),
            "diameter_m": self.diameter_m, "engaged_length_m": self.engaged_length_m,
            "hub_outer_diameter_m": None if math.isinf(self.hub_outer_diameter_m)
            else self.hub_outer_diameter_m,
            "hub_outer_source": self.hub_outer_source,
            "male_bore_diameter_m": self.male_bore_diameter_m,
            "hub_material": self.hub_material, "male_material": self.male_material,
            "mu": self.mu, "mu_source": self.mu_source, "size_distribution": self.distribution,
        }


def predict_press_fit(mate: Mate, diameter_m: float, engaged_length_m: float,
                      hub_outer_diameter_m: float, male_bore_diameter_m: float,
                      hub_material: Material | None, male_material: Material | None,
                      hub_outer_source: str = "measured") -> PressFit:
    """Press force range of ``mate`` (see the module docstring).

    Parameters
    ----------
    mate : Mate
        A mate whose clearance range reaches below zero (interference or transition).
    diameter_m, engaged_length_m : float
        Nominal joint diameter and engaged length, m.
    hub_outer_diameter_m, male_bore_diameter_m : float
        ``D_o`` (``inf`` allowed) and ``d_i`` (0 for a solid male), m.
    hub_material, male_material : Material or None
        The hole part's and the male part's materials.

    Raises
    ------
    PressFitError
        A material is missing or lacks E or nu; the mate does not interfere.
    """
    if mate.clearance_min_m >= 0:
        raise PressFitError(mate.name, "expected an interference or transition fit, found a "
                            f"clearance fit ({mate.clearance_min_m * 1e6:+.1f} um minimum)")
    for role, m in (("hub", hub_material), ("male", male_material)):
        if m is None:
            raise PressFitError(mate.name, f"the {role} part has no material: expected one with "
                                "elastic_modulus_gpa and poisson_ratio to predict the press force")
        if m.elastic_modulus_Pa is None or m.poisson_ratio is None:
            raise PressFitError(mate.name, f'the {role} material "{m.name}" has no '
                                "elastic_modulus_gpa/poisson_ratio: expected both to predict the "
                                "press force")
    assert hub_material is not None and male_material is not None
    E_hub, nu_hub = hub_material.elastic_modulus_Pa, hub_material.poisson_ratio
    E_male, nu_male = male_material.elastic_modulus_Pa, male_material.poisson_ratio
    assert E_hub is not None and nu_hub is not None and E_male is not None and nu_male is not None
    model = clearance_model(mate, diameter_m)
    deltas = model.interference_range_m()
    p_lo, p_typ, p_hi = (lame_pressure_Pa(dl, diameter_m, hub_outer_diameter_m, male_bore_diameter_m,
                                          E_hub, nu_hub, E_male, nu_male) for dl in deltas)
    pressures = (p_lo, p_typ, p_hi)
    mu, mu_source = press_friction(hub_material.name, male_material.name)
    f_lo, f_typ, f_hi = (press_force_N(p, mu, diameter_m, engaged_length_m) for p in pressures)
    forces = (f_lo, f_typ, f_hi)
    return PressFit(mate.name, mate.kind, mate.fit, float(diameter_m), float(engaged_length_m),
                    float(hub_outer_diameter_m), hub_outer_source, float(male_bore_diameter_m),
                    hub_material.name, male_material.name, mu, mu_source, deltas, pressures,
                    forces, model.probability_interference, model.distribution)


__all__ = [
    "ClearanceModel",
    "PressFit",
    "PressFitError",
    "clearance_model",
    "lame_pressure_Pa",
    "predict_press_fit",
    "press_force_N",
    "press_friction",
]
