"""ISO 286 limits and fits: standard tolerance grades, fundamental deviations and fits.

This module is a built-in copy of the ISO system of limits and fits for nominal sizes
0 < d <= 500 mm, enough to turn a drawing callout such as ``"H7/g6"`` at 10 mm into the
diametral clearance range of a pin in a hole.

Sources of the tables
---------------------
All table values are the *published* (rounded) values in micrometres, not values recomputed
from the ISO formulas (the standard rounds every tabulated value by its own rules).

* Standard tolerance grades IT1..IT16 (``_IT_UM``): ISO 286-1:2010 Table 1 (identical to
  ISO 286-1:1988 Table 1), cross-checked against the IT table in K.L. Narayana et al.,
  *Machine Drawing*, Table 15.1, the h1..h9 shaft table of the BIG DAISHOWA catalogue (up to
  500 mm) and the js8..js16 columns of the DME "Tables for Determining Metric Tolerances"
  (Table 7), whose half-widths give IT8..IT16 up to 500 mm.
* Fundamental deviations of shafts (``_SHAFT_ES_UM``, ``_SHAFT_C_ES_UM``, ``_SHAFT_EI_UM``,
  ``_SHAFT_EI_FINE_UM``): ISO 286-1:2010 Table 2, cross-checked against *Machine Drawing*
  Table 15.2 and the shaft a..h table reproduced on docs.steelcam.org (ZCC-CT catalogue).
* Fundamental deviations of holes: ISO 286-1:2010 Table 3. Holes C..H mirror the shafts
  (``EI = -es``); K, M, N (up to IT8) and P..U (up to IT7) use the Delta rule
  ``ES = -ei + Delta`` with ``Delta = IT_n - IT_(n-1)`` above 3 mm. Cross-checked against
  *Machine Drawing* Table 15.3, Machinery's Handbook 31st ed. Table 6a (BS 4500) and the
  EN ISO 286-1 Table 3 excerpt for N..ZC on usefastener.com.

Special cases implemented (ISO 286-1 Table 2/3 and their notes)
----------------------------------------------------------------
* Nominal size steps are "above lower, up to and including upper"; the first step is
  0 < d <= 3 mm. Letters c, r, s, u (and C, R, S, U) use the standard's intermediate steps
  (e.g. 50-65 / 65-80 mm).
* k shaft: ``ei`` is the tabulated value for IT4..IT7 and 0 for grades <= IT3 or > IT7.
* K hole above IT8 is defined only up to 3 mm (``ES = 0``); the standard leaves it blank
  ("-") above 3 mm, so it raises :class:`FitError`.
* M hole above IT8: ``ES = -m`` (no Delta). Special case M6 above 250 up to 315 mm:
  ``ES = -9 um`` instead of ``-11 um``.
* N hole above IT8: ``ES = 0`` above 3 mm, ``-4 um`` up to 3 mm, and not used for sizes
  <= 1 mm.
* P..U holes above IT7: ``ES = -ei`` of the matching shaft (no Delta).
* Delta is tabulated only for IT3..IT8, so K, M, N, P..U in grades IT1, IT2 raise.
* IT14..IT16 are not used for nominal sizes <= 1 mm (ISO 286-1 Table 1 note).
* js / JS: ``+-IT/2``. ISO 286-1:1988 (Table 2/3 note) allows, for grades 7 to 11 with an
  odd IT value in micrometres, rounding to the even value immediately below so that the
  deviations are whole micrometres (e.g. JS7 above 18 up to 30 mm: +-10 um instead of
  +-10.5 um). This is applied by default (``round_js=True``), as in the JIS B 0401-2 hole
  table (MISUMI reprint: JS7 = +-7 um at 6-10 mm). Many other published tables (the JIS
  shaft table, DME, ISO 286-2 transcriptions) print the exact half: use ``round_js=False``.

Units: the public API takes nominal sizes in metres and returns deviations and clearances
in metres. Internally everything is exact integer nanometres.
"""

from __future__ import annotations

import math
import re
from bisect import bisect_left
from dataclasses import dataclass
from numbers import Real
from typing import Literal

from ..errors import AsmplanError
from .iso286_tables import (
    _FINE_STEPS_MM,
    _IT_UM,
    _MAIN_STEPS_MM,
    _SHAFT_C_ES_UM,
    _SHAFT_EI_FINE_UM,
    _SHAFT_EI_UM,
    _SHAFT_ES_UM,
    MAX_NOMINAL_MM,
    SUPPORTED_GRADES,
)

__all__ = [
    "SUPPORTED_GRADES",
    "Fit",
    "FitError",
    "ToleranceZone",
    "fit",
    "standard_tolerance_m",
    "supported_letters",
    "tolerance_zone",
]


class FitError(AsmplanError, ValueError):
    """A tolerance code, fit designation or nominal size that the ISO 286 table cannot serve."""



_SHAFT_LETTERS: tuple[str, ...] = (
    "c", "d", "e", "f", "g", "h", "js", "k", "m", "n", "p", "r", "s", "u",
)  # fmt: skip
_HOLE_LETTERS: tuple[str, ...] = tuple(s.upper() for s in _SHAFT_LETTERS)
_ES_LETTERS = frozenset({"d", "e", "f", "g"})
_MAIN_EI_LETTERS = frozenset({"m", "n", "p"})
_FINE_EI_LETTERS = frozenset({"r", "s", "u"})
_DELTA_HOLES_UP_TO_IT8 = frozenset({"K", "M", "N"})
_DELTA_HOLES_UP_TO_IT7 = frozenset({"P", "R", "S", "U"})
_M6_SPECIAL_ES_NM = -9_000  # ISO 286-1 Table 3 note: M6 above 250 up to 315 mm

_CODE_RE = re.compile(r"([A-Za-z]{1,2})(\d{1,2})")
_FIT_RE = re.compile(r"\s*([A-Za-z]{1,2}\d{1,2})\s*(?:/|-|\s)\s*([A-Za-z]{1,2}\d{1,2})\s*")
_NM_PER_M = 1_000_000_000


def supported_letters() -> dict[str, tuple[str, ...]]:
    """Return the fundamental-deviation letters the table serves.

    Returns
    -------
    dict[str, tuple[str, ...]]
        ``{"hole": ("C", "D", ...), "shaft": ("c", "d", ...)}``.
    """
    return {"hole": _HOLE_LETTERS, "shaft": _SHAFT_LETTERS}


# --------------------------------------------------------------------------------------
# Domain objects
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ToleranceZone:
    """One tolerance class (e.g. ``H7``) at one nominal size, as deviations from nominal.

    Parameters
    ----------
    letter : str
        Fundamental-deviation letter; uppercase for a hole (``"H"``, ``"JS"``), lowercase for
        a shaft (``"g"``, ``"js"``).
    grade : int
        IT grade, one of :data:`SUPPORTED_GRADES`.
    lower_m, upper_m : float
        Lower and upper limit deviations from the nominal size, metres
        (for H7 at 10 mm: ``0.0`` and ``15e-6``).
    """

    letter: str
    grade: int
    lower_m: float
    upper_m: float

    def __post_init__(self) -> None:
        if self.letter not in _HOLE_LETTERS and self.letter not in _SHAFT_LETTERS:
            raise FitError(f"ToleranceZone.letter: {_letters_expected()}, found {self.letter!r}")
        if isinstance(self.grade, bool) or self.grade not in SUPPORTED_GRADES:
            raise FitError(f"ToleranceZone.grade: {_grades_expected()}, found {self.grade!r}")
        for name in ("lower_m", "upper_m"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
                raise FitError(
                    f"ToleranceZone.{name}: expected a finite number of metres, found {value!r}"
                )
        if self.lower_m > self.upper_m:
            raise FitError(
                "ToleranceZone: expected lower_m <= upper_m, "
                f"found lower_m={self.lower_m!r} > upper_m={self.upper_m!r}"
            )

    @property
    def is_hole(self) -> bool:
        """True for a hole (internal feature, uppercase letter)."""
        return self.letter in _HOLE_LETTERS

    @property
    def code(self) -> str:
        """The tolerance class as written on a drawing, e.g. ``"H7"`` or ``"js6"``."""
        return f"{self.letter}{self.grade}"

    @property
    def width_m(self) -> float:
        """Tolerance (upper minus lower deviation), metres."""
        return self.upper_m - self.lower_m


@dataclass(frozen=True)
class Fit:
    """A hole tolerance zone mated with a shaft tolerance zone at one nominal size.

    Clearance is diametral: hole size minus shaft size; a negative value is interference.

    Parameters
    ----------
    designation : str
        Normalised designation, e.g. ``"H7/g6"``.
    nominal_m : float
        Nominal (basic) diameter, metres.
    hole, shaft : ToleranceZone
        The two zones; ``hole`` must be a hole zone and ``shaft`` a shaft zone.
    clearance_min_m, clearance_max_m : float
        Smallest (hole at its lower limit, shaft at its upper) and largest diametral
        clearance, metres.
    """

    designation: str
    nominal_m: float
    hole: ToleranceZone
    shaft: ToleranceZone
    clearance_min_m: float
    clearance_max_m: float

    def __post_init__(self) -> None:
        if not self.hole.is_hole:
            raise FitError(f"Fit.hole: expected a hole zone (uppercase), found {self.hole.code!r}")
        if self.shaft.is_hole:
            raise FitError(
                f"Fit.shaft: expected a shaft zone (lowercase), found {self.shaft.code!r}"
            )
        if not self.clearance_min_m <= self.clearance_max_m:
            raise FitError(
                "Fit: expected clearance_min_m <= clearance_max_m, found "
                f"{self.clearance_min_m!r} > {self.clearance_max_m!r}"
            )

    @property
    def kind(self) -> Literal["clearance", "transition", "interference"]:
        """``"clearance"`` if the minimum clearance is >= 0, ``"interference"`` if the maximum
        clearance is <= 0, otherwise ``"transition"``."""
        if self.clearance_min_m >= 0.0:
            return "clearance"
        if self.clearance_max_m <= 0.0:
            return "interference"
        return "transition"


# --------------------------------------------------------------------------------------
# Public functions
# --------------------------------------------------------------------------------------
def standard_tolerance_m(grade: int, nominal_m: float) -> float:
    """Standard tolerance ``IT<grade>`` at a nominal size (ISO 286-1 Table 1).

    Parameters
    ----------
    grade : int
        IT grade, one of :data:`SUPPORTED_GRADES`.
    nominal_m : float
        Nominal size, metres, 0 < nominal_m <= 0.5.

    Returns
    -------
    float
        The tolerance, metres (IT7 at 10 mm: ``15e-6``).
    """
    nominal_mm = _nominal_mm(nominal_m)
    if isinstance(grade, bool) or not isinstance(grade, int) or grade not in SUPPORTED_GRADES:
        raise FitError(f"{_grades_expected()}, found {grade!r}")
    _check_grade_size(f"IT{grade}", grade, nominal_mm)
    return _it_nm(grade, nominal_mm) / _NM_PER_M


def tolerance_zone(code: str, nominal_m: float, *, round_js: bool = True) -> ToleranceZone:
    """Limit deviations of one tolerance class at a nominal size.

    Parameters
    ----------
    code : str
        Tolerance class such as ``"H7"``, ``"g6"``, ``"js6"``, ``"JS7"``: uppercase letters
        for a hole, lowercase for a shaft, followed by the IT grade.
    nominal_m : float
        Nominal size, metres, 0 < nominal_m <= 0.5 (ISO size steps, each "above lower up to
        and including upper").
    round_js : bool, optional
        For js/JS in IT7..IT11 with an odd IT value in micrometres, use +-(IT - 1 um)/2 (the
        ISO 286-1:1988 rounding note). Default True; False gives the exact +-IT/2.

    Returns
    -------
    ToleranceZone
        Deviations from the nominal size in metres.

    Raises
    ------
    FitError
        Unparseable code, unsupported letter or grade, mixed-case letters, a size outside
        0 < d <= 500 mm, or a class the standard leaves undefined at that size.
    """
    letter, grade = _parse_code(code)
    nominal_mm = _nominal_mm(nominal_m)
    lower_nm, upper_nm = _zone_nm(letter, grade, nominal_mm, round_js)
    return ToleranceZone(letter, grade, lower_nm / _NM_PER_M, upper_nm / _NM_PER_M)


def fit(designation: str, nominal_m: float, *, round_js: bool = True) -> Fit:
    """Hole/shaft fit at a nominal size, e.g. ``fit("H7/g6", 0.010)``.

    Parameters
    ----------
    designation : str
        Hole class then shaft class, separated by ``/``, ``-`` or whitespace:
        ``"H7/g6"``, ``"H7-g6"``, ``"H7 g6"``. Shaft-basis fits (``"G7/h6"``) work too.
    nominal_m : float
        Nominal diameter, metres, 0 < nominal_m <= 0.5.
    round_js : bool, optional
        Passed to :func:`tolerance_zone` for js/JS classes.

    Returns
    -------
    Fit
        Both zones and the diametral clearance range in metres
        (negative clearance = interference).

    Raises
    ------
    FitError
        As :func:`tolerance_zone`, plus a designation that is not "<hole>/<shaft>" or whose
        hole is not uppercase or whose shaft is not lowercase.
    """
    if not isinstance(designation, str):
        raise FitError(
            f'expected a fit designation string such as "H7/g6", found {designation!r} '
            f"({type(designation).__name__})"
        )
    match = _FIT_RE.fullmatch(designation)
    if match is None:
        raise FitError(
            f'expected a fit designation "<hole><grade>/<shaft><grade>" such as "H7/g6" '
            f'(separator "/", "-" or a space), found {designation!r}'
        )
    hole_code, shaft_code = match.group(1), match.group(2)
    hole_letter, hole_grade = _parse_code(hole_code)
    shaft_letter, shaft_grade = _parse_code(shaft_code)
    hole_is_hole = hole_letter in _HOLE_LETTERS
    shaft_is_hole = shaft_letter in _HOLE_LETTERS
    if not hole_is_hole and shaft_is_hole:
        raise FitError(
            f"fit {designation!r}: expected the hole first, then the shaft (e.g. "
            f'"{shaft_code}/{hole_code}"), found shaft {hole_code!r} before hole {shaft_code!r}'
        )
    if not hole_is_hole:
        raise FitError(
            f"fit {designation!r}: the hole must be uppercase (e.g. "
            f'"{hole_letter.upper()}{hole_grade}"), found lowercase {hole_code!r}, '
            "which is a shaft class"
        )
    if shaft_is_hole:
        raise FitError(
            f"fit {designation!r}: the shaft must be lowercase (e.g. "
            f'"{shaft_letter.lower()}{shaft_grade}"), found uppercase {shaft_code!r}, '
            "which is a hole class"
        )
    nominal_mm = _nominal_mm(nominal_m)
    hole_lo, hole_hi = _zone_nm(hole_letter, hole_grade, nominal_mm, round_js)
    shaft_lo, shaft_hi = _zone_nm(shaft_letter, shaft_grade, nominal_mm, round_js)
    return Fit(
        designation=f"{hole_letter}{hole_grade}/{shaft_letter}{shaft_grade}",
        nominal_m=float(nominal_m),
        hole=ToleranceZone(hole_letter, hole_grade, hole_lo / _NM_PER_M, hole_hi / _NM_PER_M),
        shaft=ToleranceZone(
            shaft_letter, shaft_grade, shaft_lo / _NM_PER_M, shaft_hi / _NM_PER_M
        ),
        clearance_min_m=(hole_lo - shaft_hi) / _NM_PER_M,
        clearance_max_m=(hole_hi - shaft_lo) / _NM_PER_M,
    )


# --------------------------------------------------------------------------------------
# Internals (all deviations in integer nanometres)
# --------------------------------------------------------------------------------------
def _letters_expected() -> str:
    return (
        "expected a hole letter (uppercase) in " + ", ".join(_HOLE_LETTERS)
        + " or a shaft letter (lowercase) in " + ", ".join(_SHAFT_LETTERS)
    )  # fmt: skip


def _grades_expected() -> str:
    return f"expected an IT grade from {SUPPORTED_GRADES[0]} to {SUPPORTED_GRADES[-1]}"


def _parse_code(code: object) -> tuple[str, int]:
    if not isinstance(code, str):
        raise FitError(
            f'expected a tolerance class string such as "H7" or "g6", found {code!r} '
            f"({type(code).__name__})"
        )
    match = _CODE_RE.fullmatch(code.strip())
    if match is None:
        raise FitError(
            f'expected a tolerance class "<letter(s)><IT grade>" such as "H7", "g6" or "js6", '
            f"found {code!r}"
        )
    letter, digits = match.group(1), match.group(2)
    if letter not in _HOLE_LETTERS and letter not in _SHAFT_LETTERS:
        if letter.upper() in _HOLE_LETTERS:  # e.g. "Js7": the case is mixed
            raise FitError(
                f"tolerance class {code!r}: letters must be all uppercase for a hole "
                f'("{letter.upper()}{digits}") or all lowercase for a shaft '
                f'("{letter.lower()}{digits}"), found {letter!r}'
            )
        raise FitError(f"tolerance class {code!r}: {_letters_expected()}, found {letter!r}")
    if digits.startswith("0") or int(digits) not in SUPPORTED_GRADES:
        raise FitError(f"tolerance class {code!r}: {_grades_expected()}, found IT{digits}")
    return letter, int(digits)


def _nominal_mm(nominal_m: object) -> float:
    if isinstance(nominal_m, bool) or not isinstance(nominal_m, Real):
        raise FitError(
            f"expected the nominal size as a number of metres, found {nominal_m!r} "
            f"({type(nominal_m).__name__})"
        )
    value_m = float(nominal_m)
    # Snap to 1 nm so that e.g. 0.018 m falls in the "above 10 up to 18 mm" step.
    nominal_mm = round(value_m * 1000.0, 6) if math.isfinite(value_m) else value_m
    if not (0.0 < nominal_mm <= MAX_NOMINAL_MM):
        raise FitError(
            f"nominal {nominal_mm:g} mm is outside the table's 0-{MAX_NOMINAL_MM:g} mm range "
            f"(expected 0 < nominal_m <= {MAX_NOMINAL_MM / 1000:g} m, found {nominal_m!r} m)"
        )
    return nominal_mm


def _step(nominal_mm: float, steps: tuple[int, ...]) -> int:
    """Upper bound of the step "above previous, up to and including upper" holding the size."""
    return steps[bisect_left(steps, nominal_mm)]


def _um_to_nm(value_um: float) -> int:
    return round(value_um * 1000)


def _it_nm(grade: int, nominal_mm: float) -> int:
    return _um_to_nm(_IT_UM[_step(nominal_mm, _MAIN_STEPS_MM)][grade - 1])


def _delta_nm(grade: int, nominal_mm: float) -> int:
    """Delta = IT_n - IT_(n-1) for sizes above 3 mm, 0 up to 3 mm (ISO 286-1 Table 3)."""
    if nominal_mm <= 3.0:
        return 0
    return _it_nm(grade, nominal_mm) - _it_nm(grade - 1, nominal_mm)


def _check_grade_size(code: str, grade: int, nominal_mm: float) -> None:
    if grade >= 14 and nominal_mm <= 1.0:
        raise FitError(
            f"{code} at nominal {nominal_mm:g} mm: ISO 286-1 Table 1 does not use IT14 to IT16 "
            "for nominal sizes up to 1 mm (expected a grade <= IT13 or a size above 1 mm)"
        )


def _shaft_es_nm(letter: str, nominal_mm: float) -> int:
    """Upper deviation es of shafts c..h (the fundamental deviation of those letters)."""
    if letter == "h":
        return 0
    if letter == "c":
        return _um_to_nm(_SHAFT_C_ES_UM[_step(nominal_mm, _FINE_STEPS_MM)])
    return _um_to_nm(_SHAFT_ES_UM[_step(nominal_mm, _MAIN_STEPS_MM)][letter])


def _shaft_ei_nm(letter: str, grade: int, nominal_mm: float) -> int:
    """Lower deviation ei of shafts k..u (the fundamental deviation of those letters)."""
    if letter == "k":
        if 4 <= grade <= 7:
            return _um_to_nm(_SHAFT_EI_UM[_step(nominal_mm, _MAIN_STEPS_MM)]["k"])
        return 0
    if letter in _MAIN_EI_LETTERS:
        return _um_to_nm(_SHAFT_EI_UM[_step(nominal_mm, _MAIN_STEPS_MM)][letter])
    return _um_to_nm(_SHAFT_EI_FINE_UM[_step(nominal_mm, _FINE_STEPS_MM)][letter])


def _js_half_nm(it_nm: int, grade: int, round_js: bool) -> int:
    if round_js and 7 <= grade <= 11 and (it_nm // 1000) % 2 == 1 and it_nm % 1000 == 0:
        return (it_nm - 1000) // 2
    return it_nm // 2  # IT is a multiple of 100 nm, so the half is exact


def _zone_nm(letter: str, grade: int, nominal_mm: float, round_js: bool) -> tuple[int, int]:
    """(lower, upper) limit deviations in nm for one class at one size."""
    code = f"{letter}{grade}"
    _check_grade_size(code, grade, nominal_mm)
    it = _it_nm(grade, nominal_mm)
    if letter in ("js", "JS"):
        half = _js_half_nm(it, grade, round_js)
        return -half, half
    if letter in _SHAFT_LETTERS:
        if letter == "c" or letter == "h" or letter in _ES_LETTERS:
            es = _shaft_es_nm(letter, nominal_mm)
            return es - it, es
        ei = _shaft_ei_nm(letter, grade, nominal_mm)
        return ei, ei + it
    # Holes.
    shaft_letter = letter.lower()
    if letter in ("C", "D", "E", "F", "G", "H"):
        ei_hole = -_shaft_es_nm(shaft_letter, nominal_mm)
        return ei_hole, ei_hole + it
    es_hole = _hole_es_nm(letter, grade, nominal_mm, code)
    return es_hole - it, es_hole


def _hole_es_nm(letter: str, grade: int, nominal_mm: float, code: str) -> int:
    """Upper deviation ES of holes K..U (ISO 286-1 Table 3)."""
    uses_delta = (letter in _DELTA_HOLES_UP_TO_IT8 and grade <= 8) or (
        letter in _DELTA_HOLES_UP_TO_IT7 and grade <= 7
    )
    if uses_delta and grade < 3:
        raise FitError(
            f"{code}: ISO 286-1 Table 3 gives Delta only for IT3 to IT8, so {letter} holes are "
            f"defined from grade 3 (expected a grade >= 3, found IT{grade})"
        )
    if letter == "K":
        if grade <= 8:
            k_ei = _um_to_nm(_SHAFT_EI_UM[_step(nominal_mm, _MAIN_STEPS_MM)]["k"])
            return -k_ei + _delta_nm(grade, nominal_mm)
        if nominal_mm <= 3.0:
            return 0
        raise FitError(
            f"{code} at nominal {nominal_mm:g} mm: ISO 286-1 Table 3 defines K above IT8 only "
            "for nominal sizes up to 3 mm (expected K3..K8, or a size <= 3 mm)"
        )
    if letter == "M":
        m_ei = _um_to_nm(_SHAFT_EI_UM[_step(nominal_mm, _MAIN_STEPS_MM)]["m"])
        if grade <= 8:
            if grade == 6 and 250.0 < nominal_mm <= 315.0:
                return _M6_SPECIAL_ES_NM
            return -m_ei + _delta_nm(grade, nominal_mm)
        return -m_ei
    if letter == "N":
        n_ei = _um_to_nm(_SHAFT_EI_UM[_step(nominal_mm, _MAIN_STEPS_MM)]["n"])
        if grade <= 8:
            return -n_ei + _delta_nm(grade, nominal_mm)
        if nominal_mm <= 1.0:
            raise FitError(
                f"{code} at nominal {nominal_mm:g} mm: ISO 286-1 Table 3 does not use N above "
                "IT8 for nominal sizes up to 1 mm (expected N3..N8, or a size above 1 mm)"
            )
        return -n_ei if nominal_mm <= 3.0 else 0
    # P, R, S, U: same magnitude as the shaft's ei, plus Delta up to IT7.
    ei = _shaft_ei_nm(letter.lower(), grade, nominal_mm)
    return -ei + (_delta_nm(grade, nominal_mm) if grade <= 7 else 0)
