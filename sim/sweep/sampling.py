"""Sampling of a sweep: which factors vary and how, and each sample's values from its own seeded
stream (see :mod:`asmplan.sim.sweep`).
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np

from ..pose_error import PoseError

try:  # POSIX advisory locks keep two sweeps from appending to one journal
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]
FACTORS: tuple[str, ...] = ("clearance", "friction", "pose")
"""Factors a sweep can vary."""

_TRUNC_Z = 3.0

@dataclass(frozen=True)
class SweepSpec:
    """What a sweep samples: which factors vary, their spreads, how many samples, the seed.

    Parameters
    ----------
    n_samples : int
        Number of samples (>= 1).
    seed : int
        Seed of every random choice (>= 0).
    vary : tuple of str
        Subset of :data:`FACTORS` that vary; the others stay nominal (clearance at the middle
        of its range, friction as declared, zero pose error).
    clearance_distribution : {"sizes", "uniform", "truncnormal"}
        See the module docstring. ``"sizes"`` (the default) draws the actual hole and shaft
        sizes from the size model of :mod:`asmplan.knowledge.press_fit` (the model that gives
        ``check``'s probability of interference and press force).
    friction_rel_sigma : float
        Relative 1-sigma spread of each friction coefficient, in [0, 1/3) so that the
        truncated multiplier stays positive.
    pose_lateral_m : float
        Lateral robot error: sigma per axis ("normal") or largest magnitude ("uniform"), m.
    pose_angular_rad : float
        Tilt error: sigma per axis ("normal") or largest magnitude ("uniform"), rad.
    pose_distribution : {"normal", "uniform"}
        See the module docstring.
    """

    n_samples: int
    seed: int = 0
    vary: tuple[str, ...] = FACTORS
    clearance_distribution: Literal["sizes", "uniform", "truncnormal"] = "sizes"
    friction_rel_sigma: float = 0.1
    pose_lateral_m: float = 0.2e-3
    pose_angular_rad: float = math.radians(0.2)
    pose_distribution: Literal["normal", "uniform"] = "normal"

    def __post_init__(self) -> None:
        if isinstance(self.n_samples, bool) or int(self.n_samples) != self.n_samples or self.n_samples < 1:
            raise ValueError(f"SweepSpec.n_samples: expected an integer >= 1, found {self.n_samples!r}")
        if isinstance(self.seed, bool) or int(self.seed) != self.seed or self.seed < 0:
            raise ValueError(f"SweepSpec.seed: expected an integer >= 0, found {self.seed!r}")
        object.__setattr__(self, "n_samples", int(self.n_samples))
        object.__setattr__(self, "seed", int(self.seed))
        vary = (self.vary,) if isinstance(self.vary, str) else tuple(self.vary)
        unknown = [v for v in vary if v not in FACTORS]
        if unknown:
            raise ValueError(
                f"SweepSpec.vary: expected factors among {list(FACTORS)}, found {unknown}")
        # canonical order, no duplicates: the spec (and the journal header) does not depend on
        # how the user listed them
        object.__setattr__(self, "vary", tuple(f for f in FACTORS if f in vary))
        if self.clearance_distribution not in ("sizes", "uniform", "truncnormal"):
            raise ValueError("SweepSpec.clearance_distribution: expected 'sizes', 'uniform' or "
                             f"'truncnormal', found {self.clearance_distribution!r}")
        if self.pose_distribution not in ("normal", "uniform"):
            raise ValueError("SweepSpec.pose_distribution: expected 'normal' or 'uniform', "
                             f"found {self.pose_distribution!r}")
        s = float(self.friction_rel_sigma)
        if not (math.isfinite(s) and 0.0 <= s < 1.0 / _TRUNC_Z):
            raise ValueError(
                f"SweepSpec.friction_rel_sigma: expected a value in [0, 1/3), found {s}")
        for name in ("pose_lateral_m", "pose_angular_rad"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"SweepSpec.{name}: expected a finite value >= 0, found {v}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict (``vary`` as a list)."""
        d = asdict(self)
        d["vary"] = list(self.vary)
        return d

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SweepSpec:
        """Inverse of :meth:`to_dict`."""
        d = dict(data)
        d["vary"] = tuple(d.get("vary", FACTORS))
        return cls(**d)


@dataclass(frozen=True)
class SampleParams:
    """The values one sample runs with (picklable, JSON-able with :meth:`to_dict`).

    Attributes
    ----------
    index : int
        Sample index in the sweep.
    seed : int
        The sweep seed (``SweepSpec.seed``).
    clearance_m : dict of str to float
        Diametral clearance per mate name, m.
    friction : dict of str to float
        Friction coefficient per part name.
    pose : dict of str to PoseError
        Robot error per step name.
    size_deviation_m : dict of str to float
        Actual size minus nominal diameter per feature (``"part.feature"``), m: one draw per
        feature and sample, so every mate that shares the feature sees the same size (the
        ``"sizes"`` model of an ISO fit; empty otherwise). The clearance of a mate between two
        drawn features is their difference (``clearance_m``).
    """

    index: int
    seed: int
    clearance_m: dict[str, float] = field(default_factory=dict)
    friction: dict[str, float] = field(default_factory=dict)
    pose: dict[str, PoseError] = field(default_factory=dict)
    size_deviation_m: dict[str, float] = field(default_factory=dict)

    def pose_error(self, step: str) -> PoseError:
        """The robot error of ``step`` (zero when the sweep has none for it)."""
        return self.pose.get(step, PoseError())

    def factors(self, step: str, vary: Sequence[str] = FACTORS) -> dict[str, float]:
        """Scalar factor values of this sample as seen by ``step``, for the statistics.

        Keys: ``clearance[<mate>]`` (m), ``friction[<part>]``, ``pose_lateral_m`` (magnitude,
        m) and ``pose_angular_rad`` (magnitude, rad); only the factors in ``vary``.
        """
        out: dict[str, float] = {}
        if "clearance" in vary:
            out.update({f"clearance[{k}]": v for k, v in sorted(self.clearance_m.items())})
        if "friction" in vary:
            out.update({f"friction[{k}]": v for k, v in sorted(self.friction.items())})
        if "pose" in vary:
            p = self.pose_error(step)
            out["pose_lateral_m"] = p.lateral_norm_m
            out["pose_angular_rad"] = p.tilt_norm_rad
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "index": self.index,
            "seed": self.seed,
            "clearance_m": dict(self.clearance_m),
            "friction": dict(self.friction),
            "pose": {k: {"lateral_m": list(p.lateral_m), "tilt_rad": list(p.tilt_rad)}
                     for k, p in self.pose.items()},
            "size_deviation_m": dict(self.size_deviation_m),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SampleParams:
        return cls(
            index=int(data["index"]),
            seed=int(data["seed"]),
            clearance_m={k: float(v) for k, v in data.get("clearance_m", {}).items()},
            friction={k: float(v) for k, v in data.get("friction", {}).items()},
            pose={k: PoseError(tuple(v["lateral_m"]), tuple(v["tilt_rad"]))
                  for k, v in data.get("pose", {}).items()},
            size_deviation_m={k: float(v) for k, v in data.get("size_deviation_m", {}).items()},
        )


@dataclass(frozen=True)
class ClearanceRange:
    """A mate's declared diametral clearance range [min_m, max_m] (negative: interference).

    ``hole_zone_m``/``shaft_zone_m``: the (lower, upper) deviations of the hole's and the
    shaft's ISO 286 tolerance zones when the mate is an ISO fit (their difference spans
    [min_m, max_m]); None for a mate declared by its clearance range.

    ``hole_ref``/``pin_ref``: the features the mate joins (``"part.feature"``). The ``"sizes"``
    model draws one actual size per feature and sample, shared by every mate naming it; left
    empty, the mate's two sides are features of its own (``"<mate>:hole"``, ``"<mate>:pin"``).
    """

    mate: str
    min_m: float
    max_m: float
    hole_zone_m: tuple[float, float] | None = None
    shaft_zone_m: tuple[float, float] | None = None
    hole_ref: str = ""
    pin_ref: str = ""

    @property
    def size_refs(self) -> tuple[str, str]:
        """The (hole, pin) feature keys the ``"sizes"`` model draws a size for."""
        return (self.hole_ref or f"{self.mate}:hole", self.pin_ref or f"{self.mate}:pin")

    def __post_init__(self) -> None:
        if not (math.isfinite(self.min_m) and math.isfinite(self.max_m) and self.min_m <= self.max_m):
            raise ValueError(f"ClearanceRange {self.mate}: expected finite min <= max, found "
                             f"[{self.min_m}, {self.max_m}]")
        if (self.hole_zone_m is None) != (self.shaft_zone_m is None):
            raise ValueError(f"ClearanceRange {self.mate}: expected both tolerance zones or "
                             "neither")
        if self.hole_zone_m is not None and self.shaft_zone_m is not None:
            (hl, hu), (sl, su) = self.hole_zone_m, self.shaft_zone_m
            if not (hl <= hu and sl <= su and abs((hl - su) - self.min_m) < 1e-9
                    and abs((hu - sl) - self.max_m) < 1e-9):
                raise ValueError(f"ClearanceRange {self.mate}: expected zones whose difference "
                                 f"spans [{self.min_m}, {self.max_m}], found hole "
                                 f"{self.hole_zone_m} and shaft {self.shaft_zone_m}")

    def draw_sizes_m(self, rng: np.random.Generator) -> float:
        """One clearance from the size model (:mod:`asmplan.knowledge.press_fit`), m.

        ISO fit: the actual hole and shaft sizes, each normal, centred in its zone with
        6 sigma = the zone width and truncated to the zone (parts outside it are rejected at
        inspection); the clearance is their difference. Declared range: the clearance itself,
        normal, centred in the range with 6 sigma = its width, truncated to the range.
        """
        if self.hole_zone_m is None or self.shaft_zone_m is None:
            mid, half = 0.5 * (self.min_m + self.max_m), 0.5 * (self.max_m - self.min_m)
            return mid + half * _truncated_standard_normal(rng) / _TRUNC_Z

        hole = _zone_size(rng, self.hole_zone_m)
        return hole - _zone_size(rng, self.shaft_zone_m)


def _zone_size(rng: np.random.Generator, zone: tuple[float, float]) -> float:
    """An actual size deviation in a tolerance zone: normal, centred, 6 sigma = the zone width,
    truncated to the zone, m."""
    lo, hi = zone
    return 0.5 * (lo + hi) + 0.5 * (hi - lo) * _truncated_standard_normal(rng) / _TRUNC_Z


def feature_zones(clearances: Sequence[ClearanceRange]) -> dict[str, tuple[float, float]]:
    """The tolerance zone of every feature an ISO-fit mate in ``clearances`` names, by its
    ``size_refs`` key. A feature named by several mates takes the zone of the first (in the
    given order, the product's); the others must agree for one part to satisfy both."""
    zones: dict[str, tuple[float, float]] = {}
    for c in clearances:
        if c.hole_zone_m is None or c.shaft_zone_m is None or c.max_m == c.min_m:
            continue
        hole, pin = c.size_refs
        zones.setdefault(hole, c.hole_zone_m)
        zones.setdefault(pin, c.shaft_zone_m)
    return zones


def factor_rng(seed: int, index: int, name: str) -> np.random.Generator:
    """The random stream of factor ``name`` in sample ``index`` of a sweep seeded ``seed``."""
    key = zlib.crc32(name.encode("utf-8"))
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index, key)))


def _truncated_standard_normal(rng: np.random.Generator) -> float:
    while True:  # rejection: accepts 99.7 % of draws
        z = float(rng.standard_normal())
        if abs(z) <= _TRUNC_Z:
            return z


def _planar(rng: np.random.Generator, scale: float, distribution: str) -> tuple[float, float]:
    if scale == 0.0:
        return (0.0, 0.0)
    if distribution == "normal":
        a, b = rng.normal(0.0, scale, size=2)
        return (float(a), float(b))
    r = float(rng.uniform(0.0, scale))
    theta = float(rng.uniform(0.0, 2.0 * math.pi))
    return (r * math.cos(theta), r * math.sin(theta))


def draw_sample(
    spec: SweepSpec,
    index: int,
    clearances: Sequence[ClearanceRange],
    friction: Mapping[str, float],
    steps: Sequence[str],
) -> SampleParams:
    """The parameters of sample ``index`` (a pure function of its arguments).

    Parameters
    ----------
    spec : SweepSpec
    index : int
        Sample index, 0 <= index (may exceed ``spec.n_samples`` when extending a sweep).
    clearances : sequence of ClearanceRange
        Declared clearance range of each mate.
    friction : mapping of str to float
        Nominal friction coefficient per part name.
    steps : sequence of str
        Step names that get a robot pose error.

    Returns
    -------
    SampleParams
        Clearances only of the mates whose range is varied: a mate left out keeps its declared
        fit in :func:`perturb_product` (replacing an H7/g6 by its mean clearance placed
        symmetrically about the nominal size changes the simulated sizes by micrometres,
        enough to turn the unperturbed peg_in_hole sample from success into a failure).
    """
    if index < 0:
        raise ValueError(f"draw_sample: expected index >= 0, found {index}")
    clear: dict[str, float] = {}
    sizes: dict[str, float] = {}
    if "clearance" in spec.vary and spec.clearance_distribution == "sizes":
        # one actual size per feature: the mates sharing it see the same part
        sizes = {ref: _zone_size(factor_rng(spec.seed, index, f"size/{ref}"), zone)
                 for ref, zone in sorted(feature_zones(clearances).items())}
    for c in sorted(clearances, key=lambda c: c.mate):
        if "clearance" not in spec.vary or c.max_m == c.min_m:
            continue  # not varied: the mate keeps its declared fit, as `asmplan run` has it
        hole_ref, pin_ref = c.size_refs
        if hole_ref in sizes and pin_ref in sizes:
            clear[c.mate] = sizes[hole_ref] - sizes[pin_ref]
            continue
        rng = factor_rng(spec.seed, index, f"clearance/{c.mate}")
        if spec.clearance_distribution == "sizes":
            clear[c.mate] = float(c.draw_sizes_m(rng))
        elif spec.clearance_distribution == "uniform":
            clear[c.mate] = float(rng.uniform(c.min_m, c.max_m))
        else:
            mid, half = 0.5 * (c.min_m + c.max_m), 0.5 * (c.max_m - c.min_m)
            clear[c.mate] = mid + half * _truncated_standard_normal(rng) / _TRUNC_Z
    fric: dict[str, float] = {}
    for part, mu in sorted(friction.items()):
        if "friction" not in spec.vary or spec.friction_rel_sigma == 0.0:
            fric[part] = float(mu)
            continue
        rng = factor_rng(spec.seed, index, f"friction/{part}")
        fric[part] = float(mu) * (1.0 + spec.friction_rel_sigma * _truncated_standard_normal(rng))
    pose: dict[str, PoseError] = {}
    for step in steps:
        if "pose" not in spec.vary:
            pose[step] = PoseError()
            continue
        rng = factor_rng(spec.seed, index, f"pose/{step}")
        lateral = _planar(rng, spec.pose_lateral_m, spec.pose_distribution)
        tilt = _planar(rng, spec.pose_angular_rad, spec.pose_distribution)
        pose[step] = PoseError(lateral, tilt)
    return SampleParams(index=index, seed=spec.seed, clearance_m=clear, friction=fric, pose=pose,
                        size_deviation_m={k: float(v) for k, v in sizes.items()})


def draw_samples(
    spec: SweepSpec,
    clearances: Sequence[ClearanceRange],
    friction: Mapping[str, float],
    steps: Sequence[str],
) -> list[SampleParams]:
    """All ``spec.n_samples`` samples, in index order (see :func:`draw_sample`)."""
    return [draw_sample(spec, i, clearances, friction, steps) for i in range(spec.n_samples)]


def clearance_ranges(product: Any) -> tuple[ClearanceRange, ...]:
    """The declared clearance range of every mate of a :class:`~asmplan.knowledge.model.Product`,
    with the hole's and the shaft's tolerance zones for an ISO fit (at the hole's nominal
    diameter, as :func:`asmplan.knowledge.press_fit.clearance_model` has them)."""
    from ...knowledge import iso286

    out = []
    for m in product.mates:
        hole_ref, pin_ref = f"{m.hole_part}.{m.hole_feature}", f"{m.pin_part}.{m.pin_feature}"
        if m.fit:
            f = iso286.fit(m.fit, product.feature(m.hole_part, m.hole_feature).diameter_m)
            out.append(ClearanceRange(m.name, m.clearance_min_m, m.clearance_max_m,
                                      (f.hole.lower_m, f.hole.upper_m),
                                      (f.shaft.lower_m, f.shaft.upper_m), hole_ref, pin_ref))
        else:
            out.append(ClearanceRange(m.name, m.clearance_min_m, m.clearance_max_m,
                                      hole_ref=hole_ref, pin_ref=pin_ref))
    return tuple(out)


def nominal_friction(product: Any) -> dict[str, float]:
    """Friction coefficient per part of a :class:`~asmplan.knowledge.model.Product`."""
    return {p.name: float(p.friction) for p in product.parts}

