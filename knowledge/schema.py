"""A small declarative schema for YAML input that converts units and collects every error.

Each spec checks a value at a key path and returns the converted value, or :data:`INVALID`
after recording an :class:`~asmplan.knowledge.errors.InputIssue` that says what was expected
and what was found. Unknown keys get a did-you-mean. Units are applied here, once: a
``Num(unit="length")`` read from a file in millimetres comes back in metres.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from .errors import InputIssue, did_you_mean
from .yamlsource import Located, PathKey


class _Invalid:
    def __repr__(self) -> str:
        return "INVALID"

    def __bool__(self) -> bool:
        return False


INVALID: Any = _Invalid()


MAX_MAGNITUDE_SI: dict[str | None, float] = {
    "length": 100.0,         # m: a product, its cell and its moves fit in a 100 m cube
    "mass": 1000.0,          # kg
    "angle": 2 * math.pi,    # rad (360 deg)
    "speed": 10.0,           # m/s
    "acceleration": 1000.0,  # m/s^2 (about 100 g)
    "force": 1e5,            # N
    "density": 1e5,          # kg/m^3 (osmium is 22,590)
    None: 1e6,               # any other number (directions, factors)
}
"""Largest magnitude of a value of each kind, in SI units (docs/product-format.md, "Limits")."""
MIN_SIZE_M = 10e-6
"""Smallest size of a part or feature (diameter, length, depth, box edge): 0.01 mm."""
SI_UNIT_NAMES = {"length": "m", "mass": "kg", "angle": "rad", "speed": "m/s",
                 "acceleration": "m/s^2", "force": "N", "density": "kg/m^3"}


@dataclass
class Context:
    """Where errors go, which unit scales apply and how the file names its units."""

    doc: Located
    scales: dict[str, float]
    issues: list[InputIssue] = field(default_factory=list)
    unit_names: dict[str, str] = field(default_factory=lambda: dict(SI_UNIT_NAMES))

    def error(self, path: PathKey, message: str, *, key: bool = False) -> Any:
        self.issues.append(self.doc.issue(path, message, key=key))
        return INVALID


def describe(value: Any) -> str:
    """A short description of a found value for error messages."""
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"boolean {str(value).lower()}"
    if isinstance(value, (int, float)):
        return f"number {_num(value)}"
    if isinstance(value, str):
        return f'text "{value}"' if len(value) < 40 else f'text "{value[:37]}..."'
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if isinstance(value, dict):
        return "a mapping"
    return type(value).__name__


def _num(value: float) -> str:
    """``value`` formatted with ``:g``, also for integers too large for a float."""
    try:
        return f"{float(value):g}"
    except OverflowError:
        return f"an integer of {len(str(abs(int(value))))} digits"


class Spec:
    """Base class: ``check(value, path, ctx)`` returns the converted value or INVALID."""

    expected = "a value"

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        raise NotImplementedError


@dataclass
class Str(Spec):
    choices: tuple[str, ...] | None = None
    expected: str = "text"

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        if not isinstance(value, str) or not value.strip():
            return ctx.error(path, f"expected {self.expected}, found {describe(value)}")
        if self.choices is not None and value not in self.choices:
            return ctx.error(path, f'expected one of {", ".join(self.choices)}, found "{value}"'
                             + did_you_mean(value, self.choices))
        return value


@dataclass
class Bool(Spec):
    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        if not isinstance(value, bool):
            return ctx.error(path, f"expected true or false, found {describe(value)}")
        return value


@dataclass
class Num(Spec):
    """A real number; ``unit`` names a scale in the context (length, mass, angle, speed...).

    Every number is finite and within :data:`MAX_MAGNITUDE_SI` of its kind; ``size`` (a
    part or feature dimension) is also at least :data:`MIN_SIZE_M`. ``minimum`` and
    ``maximum`` are in the file's units.
    """

    unit: str | None = None
    positive: bool = False
    nonnegative: bool = False
    maximum: float | None = None
    integer: bool = False
    minimum: float | None = None
    size: bool = False
    limit_si: float | None = None
    """Largest magnitude in SI units (default: :data:`MAX_MAGNITUDE_SI` of the unit)."""

    def __post_init__(self) -> None:
        self._limit = self.limit_si or MAX_MAGNITUDE_SI.get(self.unit, MAX_MAGNITUDE_SI[None])
        self._low = max(0.0 if self.nonnegative else -math.inf, self.minimum if self.minimum is not None
                        else -math.inf)
        self._high = self.maximum if self.maximum is not None else math.inf

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        t = type(value)
        if (t is float and math.isfinite(value)) or t is int:
            # fast path for a valid number; anything else gets its message from _check
            scale = ctx.scales.get(self.unit, 1.0) if self.unit else 1.0
            si = value * scale
            if ((not self.integer or t is int) and self._low <= value <= self._high
                    and (value > 0 or not (self.positive or self.size)) and abs(si) <= self._limit
                    and (not self.size or si >= MIN_SIZE_M * (1 - 1e-9))):
                return si if self.unit else value
        return self._check(value, path, ctx)

    # Complexity above C (radon): one branch per constraint on a number (type, finite, whole,
    # sign, minimum, maximum, magnitude, smallest size), each with its own message.
    def _check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return ctx.error(path, f"expected {self._what()}, found {describe(value)}")
        if isinstance(value, float) and not math.isfinite(value):
            return ctx.error(path, f"expected a finite number, found {value}")
        if self.integer and not isinstance(value, int):
            return ctx.error(path, f"expected a whole number, found {_num(value)}")
        u = self._unit_name(ctx)
        if (self.positive or self.size) and value <= 0:
            return ctx.error(path, f"expected a positive {self._noun()}, found {_num(value)}{u}")
        if self.nonnegative and value < 0:
            return ctx.error(path, f"expected {self._a_noun()} >= 0, found {_num(value)}{u}")
        if self.minimum is not None and value < self.minimum:
            return ctx.error(path, f"expected {self._a_noun()} >= {self.minimum:g}{u}, found "
                             f"{_num(value)}{u}")
        if self.maximum is not None and value > self.maximum:
            return ctx.error(path, f"expected {self._a_noun()} <= {self.maximum:g}{u}, found "
                             f"{_num(value)}{u}")
        scale = ctx.scales.get(self.unit, 1.0) if self.unit else 1.0
        limit = self._limit
        if abs(value) * scale > limit:
            return ctx.error(path, f"expected {self._a_noun()} within +-{limit / scale:g}{u}, found "
                             f"{_num(value)}{u}")
        if self.size and value * scale < MIN_SIZE_M * (1 - 1e-9):
            return ctx.error(path, f"expected {self._a_noun()} of at least {MIN_SIZE_M / scale:g}{u} "
                             f"(0.01 mm), found {_num(value)}{u}")
        return value * scale if self.unit else value

    def _unit_name(self, ctx: Context) -> str:
        name = ctx.unit_names.get(self.unit) if self.unit else None
        return f" {name}" if name else ""

    def _noun(self) -> str:
        return self.unit or "number"

    def _a_noun(self) -> str:
        noun = self._noun()
        return ("an " if noun[0] in "aeiou" else "a ") + noun

    def _what(self) -> str:
        return f"a number ({self.unit})" if self.unit else "a number"


@dataclass
class Vec(Spec):
    """A list of ``n`` numbers, optionally unit-scaled and non-zero."""

    n: int = 3
    unit: str | None = None
    positive: bool = False
    nonzero: bool = False
    item: Num | None = None
    """The spec of each number (default: ``Num(unit, positive)``)."""

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        if not isinstance(value, list) or len(value) != self.n:
            return ctx.error(path, f"expected a list of {self.n} numbers, found {describe(value)}")
        item = self.item or Num(unit=self.unit, positive=self.positive)
        out = [item.check(v, (*path, i), ctx) for i, v in enumerate(value)]
        if any(v is INVALID for v in out):
            return INVALID
        if self.nonzero and all(v == 0 for v in out):
            return ctx.error(path, "expected a non-zero vector, found [0, 0, 0]")
        return out


@dataclass
class ListOf(Spec):
    item: Spec
    min_len: int = 0

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        if not isinstance(value, list):
            return ctx.error(path, f"expected a list, found {describe(value)}")
        if len(value) < self.min_len:
            return ctx.error(path, f"expected at least {self.min_len} entries, found {len(value)}")
        out = [self.item.check(v, (*path, i), ctx) for i, v in enumerate(value)]
        return INVALID if any(v is INVALID for v in out) else out


@dataclass
class Field:
    spec: Spec
    required: bool = False
    default: Any = None


@dataclass
class Map(Spec):
    """A mapping with known keys; unknown keys are errors with a did-you-mean."""

    fields: Mapping[str, Field]
    name: str = "mapping"
    check_fn: Callable[[dict[str, Any], PathKey, Context], None] | None = None

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        out, ok = self.check_partial(value, path, ctx)
        return out if ok else INVALID

    def check_partial(self, value: Any, path: PathKey, ctx: Context) -> tuple[Any, bool]:
        """Like :meth:`check`, but return the entries that are valid (others are INVALID),
        so that later checks can still run on the rest of the document."""
        if not isinstance(value, dict):
            return ctx.error(path, f"expected {self.name} (a mapping), found {describe(value)}"), False
        ok = True
        for key in value:
            if key not in self.fields:
                ok = False
                known = ", ".join(self.fields)
                ctx.error((*path, key), f'unknown key "{key}"{did_you_mean(str(key), self.fields)}'
                          f"; expected one of: {known}", key=True)
        out: dict[str, Any] = {}
        for key, fld in self.fields.items():
            if key in value:
                out[key] = fld.spec.check(value[key], (*path, key), ctx)
                ok = ok and out[key] is not INVALID
            elif fld.required:
                ok = False
                ctx.error(path, f'missing required key "{key}" ({fld.spec.expected})')
            else:
                out[key] = fld.default
        if ok and self.check_fn is not None:
            before = len(ctx.issues)
            self.check_fn(out, path, ctx)
            ok = len(ctx.issues) == before
        return out, ok


@dataclass
class Tagged(Spec):
    """A mapping whose ``tag`` key (e.g. ``type``) selects the Map spec for the rest."""

    tag: str
    variants: Mapping[str, Map]

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        if not isinstance(value, dict):
            return ctx.error(path, f"expected a mapping with a \"{self.tag}\", found {describe(value)}")
        kind = value.get(self.tag)
        if kind is not None and not isinstance(kind, str):
            return ctx.error((*path, self.tag), f"expected one of: {', '.join(self.variants)}, "
                             f"found {describe(kind)}")
        if kind is None:
            return ctx.error(path, f'missing required key "{self.tag}" (one of: '
                             f'{", ".join(self.variants)})')
        if kind not in self.variants:
            return ctx.error((*path, self.tag), f'unknown {self.tag} "{kind}"'
                             f"{did_you_mean(str(kind), self.variants)}; expected one of: "
                             f'{", ".join(self.variants)}')
        rest = {k: v for k, v in value.items() if k != self.tag}
        out = self.variants[kind].check(rest, path, ctx)
        if out is INVALID:
            return INVALID
        out[self.tag] = kind
        return out


@dataclass
class OneOf(Spec):
    """Either of two specs chosen by the YAML type of the value (number vs mapping, ...)."""

    by_type: Mapping[type | tuple[type, ...], Spec]
    expected: str = "a value"

    def check(self, value: Any, path: PathKey, ctx: Context) -> Any:
        for typ, spec in self.by_type.items():
            if isinstance(value, typ) and not (isinstance(value, bool) and typ is not bool):
                return spec.check(value, path, ctx)
        return ctx.error(path, f"expected {self.expected}, found {describe(value)}")
