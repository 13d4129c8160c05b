"""Tests for the built-in ISO 286 limits-and-fits table.

Every expected number below is reference data copied from a named published table (or, for
fits, the difference of two published limit deviations), never computed by the code under
test. Values are in micrometres and compared exactly at 1 nm resolution.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from asmplan.knowledge.iso286 import (
    SUPPORTED_GRADES,
    Fit,
    FitError,
    ToleranceZone,
    fit,
    standard_tolerance_m,
    supported_letters,
    tolerance_zone,
)

# --------------------------------------------------------------------------------------
# Named sources
# --------------------------------------------------------------------------------------
SRC_JIS_SHAFT = (
    "JIS B 0401-2 (1998/1999, identical to ISO 286-2) shaft table 'Dimensional tolerances "
    "for regularly used shaft fits', Sumitomo Electric tool catalogue, technical data p.28"
)
SRC_JIS_HOLE = (
    "JIS B 0401-2 (1999) hole table 'Hole dimensional tolerances for regularly used fitting', "
    "MISUMI technical data p.1263"
)
SRC_ISO2862_T = "ISO 286-2 limit-deviation tables as transcribed in parkergreene/isofits CSVs"
SRC_HZPT = "HZPT 'ISO hole and shaft tolerances' table (H7, H8, f7, g6, k6, n6, p6, s6 to 120 mm)"
SRC_DME = "DME 'Tables for Determining Metric Tolerances', Table 6 (holes) and Table 7 (js8..js16)"
SRC_BIG = "BIG DAISHOWA catalogue p.139, shaft tolerances h1..h9 up to 500 mm"
SRC_EV = "ISO 286 IT grades 1..14 table, engineersvault.blogspot.com 'Index of ISO hole and shaft'"
SRC_WIKI = "Wikipedia 'Engineering fit', clearance-fit example H8/f7 on a 50 mm diameter"
SRC_MD = "Narayana, Kannaiah, Reddy, Machine Drawing, Table 15.3 note (M6 250-315 mm: ES = -9)"

UM = 1e-6


def _nm(x_m: float) -> int:
    return round(x_m * 1e9)


def _um_nm(x_um: float) -> int:
    return round(x_um * 1000)


# --------------------------------------------------------------------------------------
# 1. The project's check values (/work/shared/reference/iso286_check_values.csv)
# --------------------------------------------------------------------------------------
# ../shared sits beside the repository's checkout (also in CI); a missing file is an error,
# not a silent skip.
_CSV = Path(__file__).resolve().parents[2].parent / "shared" / "reference" / "iso286_check_values.csv"


def _check_value_rows() -> list[tuple[str, float, str, int, int]]:
    path = _CSV
    assert path.is_file(), f"reference check values not found at {path}"
    lines = [ln for ln in path.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
    rows = []
    for rec in csv.DictReader(lines):
        lo_mm, hi_mm = (float(v) for v in rec.pop("size_range_mm").split("-"))
        mid_mm = (lo_mm + hi_mm) / 2.0  # representative nominal strictly inside the step
        for designation, span in rec.items():
            cmin, cmax = (int(v) for v in span.split(".."))
            rows.append((f"{lo_mm:g}-{hi_mm:g}", mid_mm, designation, cmin, cmax))
    return rows


_CHECK_ROWS = _check_value_rows()


@pytest.mark.parametrize(("size_range", "nominal_mm", "designation", "cmin_um", "cmax_um"),
                         _CHECK_ROWS)  # fmt: skip
def test_reproduces_project_check_values(
    size_range: str, nominal_mm: float, designation: str, cmin_um: int, cmax_um: int
) -> None:
    f = fit(designation, nominal_mm / 1000.0)
    assert round(f.clearance_min_m / UM) == cmin_um, (size_range, designation)
    assert round(f.clearance_max_m / UM) == cmax_um, (size_range, designation)


def test_check_value_csv_has_expected_shape() -> None:
    assert len(_CHECK_ROWS) == 12  # 4 size ranges x 3 fits


# --------------------------------------------------------------------------------------
# 2. Standard tolerance grades against published IT tables
# --------------------------------------------------------------------------------------
# SRC_EV: IT1..IT14, steps with upper bound 3, 6, 10, 18, 30, 50, 80, 120, 180, 250, 315 mm.
_EV_UPPERS = (3, 6, 10, 18, 30, 50, 80, 120, 180, 250, 315)
_EV_ROWS = {
    1: (0.8, 1, 1, 1.2, 1.5, 1.5, 2, 2.5, 3.5, 4.5, 6),
    2: (1.2, 1.5, 1.5, 2, 2.5, 2.5, 3, 4, 5, 7, 8),
    3: (2, 2.5, 2.5, 3, 4, 4, 5, 6, 8, 10, 12),
    4: (3, 4, 4, 5, 6, 7, 8, 10, 12, 14, 16),
    5: (4, 5, 6, 8, 9, 11, 13, 15, 18, 20, 23),
    6: (6, 8, 9, 11, 13, 16, 19, 22, 25, 29, 32),
    7: (10, 12, 15, 18, 21, 25, 30, 35, 40, 46, 52),
    8: (14, 18, 22, 27, 33, 39, 46, 54, 63, 72, 81),
    9: (25, 30, 36, 43, 52, 62, 74, 87, 100, 115, 130),
    10: (40, 48, 58, 70, 84, 100, 120, 140, 160, 185, 210),
    11: (60, 75, 90, 110, 130, 160, 190, 220, 250, 290, 320),
    12: (100, 120, 150, 180, 210, 250, 300, 350, 400, 460, 520),
    13: (140, 180, 220, 270, 330, 390, 460, 540, 630, 720, 810),
    14: (250, 300, 360, 430, 520, 620, 740, 870, 1000, 1150, 1300),
}
# Above 315 up to 400 mm and above 400 up to 500 mm: IT1..IT9 from SRC_BIG (h-class widths),
# IT8..IT16 from SRC_DME (twice the js half-width); IT8 and IT9 appear in both.
_BIG_315_500 = {1: (7, 8), 2: (9, 10), 3: (13, 15), 4: (18, 20), 5: (25, 27), 6: (36, 40),
                7: (57, 63), 8: (89, 97), 9: (140, 155)}  # fmt: skip
_DME_JS_HALF_315_500 = {8: (44.5, 48.5), 9: (70, 77.5), 10: (115, 125), 11: (180, 200),
                        12: (285, 315), 13: (445, 485), 14: (700, 775), 15: (1150, 1250),
                        16: (1800, 2000)}  # fmt: skip


@pytest.mark.parametrize("grade", sorted(_EV_ROWS))
def test_it_grades_match_published_table_up_to_315mm(grade: int) -> None:
    lower = 0
    for upper, it_um in zip(_EV_UPPERS, _EV_ROWS[grade], strict=True):
        for nominal_mm in ((lower + upper) / 2.0, float(upper)):
            if grade >= 14 and nominal_mm <= 1.0:
                continue
            got = standard_tolerance_m(grade, nominal_mm / 1000.0)
            assert _nm(got) == _um_nm(it_um), (SRC_EV, grade, nominal_mm)
        lower = upper


@pytest.mark.parametrize("grade", range(1, 17))
def test_it_grades_match_published_tables_315_to_500mm(grade: int) -> None:
    for i, nominal_mm in enumerate((350.0, 450.0)):
        got_nm = _nm(standard_tolerance_m(grade, nominal_mm / 1000.0))
        if grade in _BIG_315_500:
            assert got_nm == _um_nm(_BIG_315_500[grade][i]), (SRC_BIG, grade, nominal_mm)
        if grade in _DME_JS_HALF_315_500:
            assert got_nm == _um_nm(2 * _DME_JS_HALF_315_500[grade][i]), (SRC_DME, grade)


def test_it_table_grows_with_grade_and_size_and_decades_every_five_grades() -> None:
    sizes_mm = (2, 5, 8, 15, 25, 40, 65, 100, 150, 200, 300, 350, 450)
    for g in SUPPORTED_GRADES:
        row = [standard_tolerance_m(g, s / 1000.0) for s in sizes_mm if not (g >= 14 and s <= 1)]
        assert row == sorted(row), g
    for s in sizes_mm:
        col = [standard_tolerance_m(g, s / 1000.0) for g in SUPPORTED_GRADES]
        assert col == sorted(col) and len(set(col)) == len(col), s
        # ISO 286-1: from IT7 on, each fifth grade is ten times larger (R5 series).
        for g in range(7, 12):
            assert _nm(standard_tolerance_m(g + 5, s / 1000.0)) == 10 * _nm(
                standard_tolerance_m(g, s / 1000.0)
            ), (g, s)


# --------------------------------------------------------------------------------------
# 3. Tolerance zones against published limit-deviation tables
#    (code, nominal mm, lower um, upper um, round_js, source)
# --------------------------------------------------------------------------------------
ZONES = [
    # 0-3 mm: no Delta in this step
    ("C9", 2, 60, 85, True, SRC_JIS_HOLE),
    ("JS7", 2, -5, 5, True, SRC_JIS_HOLE),
    ("K7", 2, -10, 0, True, SRC_JIS_HOLE),
    ("M6", 2, -8, -2, True, SRC_JIS_HOLE),
    ("N7", 2, -14, -4, True, SRC_JIS_HOLE),
    ("P7", 2, -16, -6, True, SRC_JIS_HOLE),
    ("R7", 2, -20, -10, True, SRC_JIS_HOLE),
    ("S7", 2, -24, -14, True, SRC_JIS_HOLE),
    ("U7", 2, -28, -18, True, SRC_JIS_HOLE),
    # 6-10 mm
    ("c9", 8, -116, -80, True, SRC_JIS_SHAFT),
    ("d9", 8, -76, -40, True, SRC_JIS_SHAFT),
    ("e8", 8, -47, -25, True, SRC_JIS_SHAFT),
    ("f7", 8, -28, -13, True, SRC_JIS_SHAFT),
    ("g6", 8, -14, -5, True, SRC_JIS_SHAFT),
    ("h6", 8, -9, 0, True, SRC_JIS_SHAFT),
    ("js6", 8, -4.5, 4.5, True, SRC_JIS_SHAFT),
    ("js7", 8, -7.5, 7.5, False, SRC_JIS_SHAFT),
    ("k6", 8, 1, 10, True, SRC_JIS_SHAFT),
    ("m6", 8, 6, 15, True, SRC_JIS_SHAFT),
    ("n6", 8, 10, 19, True, SRC_JIS_SHAFT),
    ("p6", 8, 15, 24, True, SRC_JIS_SHAFT),
    ("r6", 8, 19, 28, True, SRC_JIS_SHAFT),
    ("s6", 8, 23, 32, True, SRC_JIS_SHAFT),
    ("u6", 8, 28, 37, True, SRC_JIS_SHAFT),
    ("C10", 8, 80, 138, True, SRC_JIS_HOLE),
    ("D10", 8, 40, 98, True, SRC_JIS_HOLE),
    ("E9", 8, 25, 61, True, SRC_JIS_HOLE),
    ("F8", 8, 13, 35, True, SRC_JIS_HOLE),
    ("G7", 8, 5, 20, True, SRC_JIS_HOLE),
    ("JS6", 8, -4.5, 4.5, True, SRC_JIS_HOLE),
    ("JS7", 8, -7, 7, True, SRC_JIS_HOLE),  # IT7 = 15 um, odd: rounded to the even 14
    ("K6", 8, -7, 2, True, SRC_JIS_HOLE),
    ("K7", 8, -10, 5, True, SRC_JIS_HOLE),
    ("M6", 8, -12, -3, True, SRC_JIS_HOLE),
    ("M7", 8, -15, 0, True, SRC_JIS_HOLE),
    ("N6", 8, -16, -7, True, SRC_JIS_HOLE),
    ("N7", 8, -19, -4, True, SRC_JIS_HOLE),
    ("P6", 8, -21, -12, True, SRC_JIS_HOLE),
    ("P7", 8, -24, -9, True, SRC_JIS_HOLE),
    ("R7", 8, -28, -13, True, SRC_JIS_HOLE),
    ("S7", 8, -32, -17, True, SRC_JIS_HOLE),
    ("U7", 8, -37, -22, True, SRC_JIS_HOLE),
    # 3-6 mm
    ("K6", 4.5, -6, 2, True, SRC_JIS_HOLE),
    ("M6", 4.5, -9, -1, True, SRC_JIS_HOLE),
    ("N6", 4.5, -13, -5, True, SRC_JIS_HOLE),
    ("P6", 4.5, -17, -9, True, SRC_JIS_HOLE),
    ("U7", 4.5, -31, -19, True, SRC_JIS_HOLE),
    ("N8", 4.5, -20, -2, True, SRC_ISO2862_T),
    ("M8", 4.5, -16, 2, True, SRC_ISO2862_T),
    # 10-18 mm
    ("K7", 12, -12, 6, True, SRC_JIS_HOLE),
    ("N7", 12, -23, -5, True, SRC_JIS_HOLE),
    ("R7", 12, -34, -16, True, SRC_JIS_HOLE),
    ("S7", 12, -39, -21, True, SRC_JIS_HOLE),
    ("U7", 12, -44, -26, True, SRC_JIS_HOLE),
    # 18-30 mm (r, s, u: 18-24 and 24-30 sub-steps)
    ("c9", 20, -162, -110, True, SRC_JIS_SHAFT),
    ("d9", 20, -117, -65, True, SRC_JIS_SHAFT),
    ("e9", 20, -92, -40, True, SRC_JIS_SHAFT),
    ("f6", 20, -33, -20, True, SRC_JIS_SHAFT),
    ("k5", 20, 2, 11, True, SRC_JIS_SHAFT),
    ("m5", 20, 8, 17, True, SRC_JIS_SHAFT),
    ("js7", 20, -10.5, 10.5, False, SRC_JIS_SHAFT),
    ("u6", 20, 41, 54, True, SRC_JIS_SHAFT),
    ("u6", 25, 48, 61, True, SRC_JIS_SHAFT),
    ("JS7", 25, -10, 10, True, SRC_JIS_HOLE),  # IT7 = 21 um: rounded to 20
    ("K6", 25, -11, 2, True, SRC_JIS_HOLE),
    ("M6", 25, -17, -4, True, SRC_JIS_HOLE),
    ("N6", 25, -24, -11, True, SRC_JIS_HOLE),
    ("P6", 25, -31, -18, True, SRC_JIS_HOLE),
    ("R7", 25, -41, -20, True, SRC_JIS_HOLE),
    ("S7", 25, -48, -27, True, SRC_JIS_HOLE),
    # 30-50 mm (two sources for the holes)
    ("c9", 35, -182, -120, True, SRC_JIS_SHAFT),
    ("c9", 45, -192, -130, True, SRC_JIS_SHAFT),
    ("d8", 35, -119, -80, True, SRC_JIS_SHAFT),
    ("e7", 35, -75, -50, True, SRC_JIS_SHAFT),
    ("g5", 35, -20, -9, True, SRC_JIS_SHAFT),
    ("js5", 35, -5.5, 5.5, True, SRC_JIS_SHAFT),
    ("js7", 35, -12.5, 12.5, False, SRC_JIS_SHAFT),
    ("r6", 35, 34, 50, True, SRC_JIS_SHAFT),
    ("u6", 35, 60, 76, True, SRC_JIS_SHAFT),
    ("u6", 45, 70, 86, True, SRC_JIS_SHAFT),
    ("JS7", 35, -12, 12, True, SRC_JIS_HOLE),  # IT7 = 25 um: rounded to 24
    ("JS7", 35, -12.5, 12.5, False, SRC_ISO2862_T),
    ("K6", 35, -13, 3, True, SRC_ISO2862_T),
    ("K7", 35, -18, 7, True, SRC_ISO2862_T),
    ("M6", 35, -20, -4, True, SRC_ISO2862_T),
    ("N7", 35, -33, -8, True, SRC_ISO2862_T),
    ("P6", 35, -37, -21, True, SRC_ISO2862_T),
    ("P7", 35, -42, -17, True, SRC_ISO2862_T),
    ("R7", 35, -50, -25, True, SRC_ISO2862_T),
    ("H11", 35, 0, 160, True, SRC_DME),
    # 50-80 mm (r, s, u: 50-65 sub-step; R7 in both sub-steps)
    ("c9", 60, -214, -140, True, SRC_JIS_SHAFT),
    ("d9", 60, -174, -100, True, SRC_JIS_SHAFT),
    ("f7", 60, -60, -30, True, SRC_JIS_SHAFT),
    ("m6", 60, 11, 30, True, SRC_JIS_SHAFT),
    ("n6", 60, 20, 39, True, SRC_JIS_SHAFT),
    ("p6", 60, 32, 51, True, SRC_JIS_SHAFT),
    ("r6", 60, 41, 60, True, SRC_JIS_SHAFT),
    ("s6", 60, 53, 72, True, SRC_JIS_SHAFT),
    ("s6", 60, 53, 72, True, SRC_HZPT),
    ("u6", 60, 87, 106, True, SRC_JIS_SHAFT),
    ("js7", 60, -15, 15, True, SRC_JIS_SHAFT),
    ("R7", 60, -60, -30, True, SRC_ISO2862_T),
    ("R7", 70, -62, -32, True, SRC_ISO2862_T),
    ("r6", 70, 43, 62, True, SRC_ISO2862_T),
    # 80-120 mm
    ("f7", 100, -71, -36, True, SRC_HZPT),
    ("g6", 100, -34, -12, True, SRC_HZPT),
    ("k6", 100, 3, 25, True, SRC_HZPT),
    ("n6", 100, 23, 45, True, SRC_HZPT),
    ("p6", 100, 37, 59, True, SRC_HZPT),
    ("s6", 90, 71, 93, True, SRC_HZPT),
    ("R7", 90, -73, -38, True, SRC_ISO2862_T),
    ("r6", 110, 54, 76, True, SRC_ISO2862_T),
    ("e13", 100, -612, -72, True, SRC_ISO2862_T),
    # 120-500 mm
    ("R7", 150, -90, -50, True, SRC_ISO2862_T),
    ("r6", 170, 68, 93, True, SRC_ISO2862_T),
    ("P6", 200, -70, -41, True, SRC_ISO2862_T),
    ("P7", 200, -79, -33, True, SRC_ISO2862_T),
    ("P8", 200, -122, -50, True, SRC_ISO2862_T),  # above IT7: no Delta
    ("r6", 240, 84, 113, True, SRC_ISO2862_T),
    ("M6", 300, -41, -9, True, SRC_ISO2862_T),  # the M6 special case, also SRC_MD
    ("M7", 300, -52, 0, True, SRC_ISO2862_T),
    ("K6", 350, -29, 7, True, SRC_ISO2862_T),
    ("K7", 350, -40, 17, True, SRC_ISO2862_T),
    ("K8", 350, -61, 28, True, SRC_ISO2862_T),
    ("M8", 350, -78, 11, True, SRC_ISO2862_T),
    ("N7", 350, -73, -16, True, SRC_ISO2862_T),
    ("N8", 350, -94, -5, True, SRC_ISO2862_T),
    ("JS8", 350, -44.5, 44.5, False, SRC_ISO2862_T),
    ("k6", 350, 4, 40, True, SRC_ISO2862_T),
    ("k7", 350, 4, 61, True, SRC_ISO2862_T),
    ("m7", 350, 21, 78, True, SRC_ISO2862_T),
    ("n7", 350, 37, 94, True, SRC_ISO2862_T),
    ("p6", 350, 62, 98, True, SRC_ISO2862_T),
    ("h12", 350, -570, 0, True, SRC_ISO2862_T),
    ("R6", 380, -139, -103, True, SRC_ISO2862_T),
    ("R7", 380, -150, -93, True, SRC_ISO2862_T),
    ("r6", 380, 114, 150, True, SRC_ISO2862_T),
    ("js16", 450, -2000, 2000, True, SRC_DME),
]


@pytest.mark.parametrize(("code", "nominal_mm", "lower_um", "upper_um", "round_js", "source"),
                         ZONES)  # fmt: skip
def test_zone_matches_published_limit_deviations(
    code: str, nominal_mm: float, lower_um: float, upper_um: float, round_js: bool, source: str
) -> None:
    zone = tolerance_zone(code, nominal_mm / 1000.0, round_js=round_js)
    assert (_nm(zone.lower_m), _nm(zone.upper_m)) == (_um_nm(lower_um), _um_nm(upper_um)), source
    assert zone.code == code
    assert zone.is_hole == code[0].isupper()


def test_h7_at_10mm_is_exactly_the_documented_example() -> None:
    assert tolerance_zone("H7", 0.010) == ToleranceZone("H", 7, 0.0, 15e-6)


def test_js_rounding_only_touches_odd_it_in_grades_7_to_11() -> None:
    # IT7 at 6-10 mm is 15 um (odd): rounded +-7, exact +-7.5.
    assert _nm(tolerance_zone("js7", 0.008).upper_m) == 7000
    assert _nm(tolerance_zone("js7", 0.008, round_js=False).upper_m) == 7500
    # IT6 (9 um) is never rounded; IT11 at 3-6 mm (75 um, DME js11 = +-37.5) is.
    assert _nm(tolerance_zone("js6", 0.008).upper_m) == 4500
    assert _nm(tolerance_zone("js11", 0.0045, round_js=False).upper_m) == 37500
    assert _nm(tolerance_zone("js11", 0.0045).upper_m) == 37000
    # Even IT values are identical either way (IT7 at 10-18 mm = 18 um).
    assert tolerance_zone("JS7", 0.012) == tolerance_zone("JS7", 0.012, round_js=False)


@pytest.mark.parametrize(
    ("code", "inside_mm", "outside_mm"),
    [
        ("H7", 10.0, 10.001),  # IT7: 15 um up to and including 10 mm, 18 um above
        ("s6", 65.0, 65.001),  # s: +53 up to 65 mm, +59 above (sub-steps)
        ("H7", 3.0, 3.0005),  # first step includes 3 mm
    ],
)
def test_size_step_bounds_are_above_lower_up_to_and_including_upper(
    code: str, inside_mm: float, outside_mm: float
) -> None:
    zone_inside = tolerance_zone(code, inside_mm / 1000.0)
    just_below = tolerance_zone(code, (inside_mm - 0.001) / 1000.0)
    assert zone_inside == just_below
    assert tolerance_zone(code, outside_mm / 1000.0) != zone_inside


def test_k_shaft_ei_is_zero_outside_it4_to_it7() -> None:
    # Machine Drawing Table 15.2 / ISO 286-1 Table 2: k ei = +1 um at 3-6 mm for IT4..IT7 only.
    assert [_nm(tolerance_zone(f"k{g}", 0.005).lower_m) for g in (3, 4, 7, 8)] == [0, 1000, 1000, 0]


def test_n_hole_above_it8_is_zero_above_3mm_and_minus_4_up_to_3mm() -> None:
    # EN ISO 286-1 Table 3 (usefastener excerpt): N > IT8: -4 um up to 3 mm, 0 above.
    assert _nm(tolerance_zone("N9", 0.002).upper_m) == -4000
    assert _nm(tolerance_zone("N9", 0.010).upper_m) == 0
    assert _nm(tolerance_zone("M9", 0.010).upper_m) == -6000  # M > IT8: -m, no Delta


# --------------------------------------------------------------------------------------
# 4. Fits against published tables: hole and shaft limits from the named tables, clearance
#    = hole limit - shaft limit by hand. (designation, mm, min um, max um, kind, source)
# --------------------------------------------------------------------------------------
_S10 = f"{SRC_JIS_HOLE} + {SRC_JIS_SHAFT}, 6-10 mm rows"
_S25 = f"{SRC_JIS_HOLE} + {SRC_JIS_SHAFT}, 24-30 mm rows"
_S40 = f"{SRC_ISO2862_T} (H7, H9) + {SRC_JIS_SHAFT}, 30-40 mm rows"
FITS = [
    ("H9/d9", 10, 40, 112, "clearance", _S10),
    ("H8/f7", 10, 13, 50, "clearance", _S10),
    ("H7/g6", 10, 5, 29, "clearance", _S10),
    ("H7/k6", 10, -10, 14, "transition", _S10),
    ("H7/n6", 10, -19, 5, "transition", _S10),
    ("H7/p6", 10, -24, 0, "interference", _S10),
    ("H7/s6", 10, -32, -8, "interference", _S10),
    ("H7/u6", 10, -37, -13, "interference", _S10),
    ("G7/h6", 10, 5, 29, "clearance", _S10),
    ("K7/h6", 10, -10, 14, "transition", _S10),
    ("N7/h6", 10, -19, 5, "transition", _S10),
    ("P7/h6", 10, -24, 0, "interference", _S10),
    ("S7/h6", 10, -32, -8, "interference", _S10),
    ("U7/h6", 10, -37, -13, "interference", _S10),
    ("H9/d9", 25, 65, 169, "clearance", _S25),
    ("H7/k6", 25, -15, 19, "transition", _S25),
    ("H7/n6", 25, -28, 6, "transition", _S25),
    ("H7/p6", 25, -35, -1, "interference", _S25),
    ("H7/s6", 25, -48, -14, "interference", _S25),
    ("H7/u6", 25, -61, -27, "interference", _S25),
    ("K7/h6", 25, -15, 19, "transition", _S25),
    ("S7/h6", 25, -48, -14, "interference", _S25),
    # H11 +160 from SRC_DME; c11 = c9's es (-120, SRC_JIS_SHAFT) minus IT11 (160).
    ("H11/c11", 40, 120, 440, "clearance", f"{SRC_DME} + {SRC_JIS_SHAFT}"),
    ("H9/d9", 40, 80, 204, "clearance", _S40),
    ("H7/k6", 40, -18, 23, "transition", _S40),
    ("H7/p6", 40, -42, -1, "interference", _S40),
    ("H7/s6", 40, -59, -18, "interference", _S40),
    ("H7/u6", 40, -76, -35, "interference", _S40),
    ("H8/f7", 50, 25, 89, "clearance", SRC_WIKI),
    ("H8/f7", 100, 36, 125, "clearance", SRC_HZPT),
    ("H7/g6", 100, 12, 69, "clearance", SRC_HZPT),
    ("H7/k6", 100, -25, 32, "transition", SRC_HZPT),
    ("H7/n6", 100, -45, 12, "transition", SRC_HZPT),
    ("H7/p6", 100, -59, -2, "interference", SRC_HZPT),
    ("H7/s6", 100, -93, -36, "interference", SRC_HZPT),  # s6 uses the 80-100 sub-step
]


@pytest.mark.parametrize(("designation", "nominal_mm", "cmin_um", "cmax_um", "kind", "source"),
                         FITS)  # fmt: skip
def test_fit_matches_published_limits(
    designation: str, nominal_mm: float, cmin_um: int, cmax_um: int, kind: str, source: str
) -> None:
    f = fit(designation, nominal_mm / 1000.0)
    assert (_nm(f.clearance_min_m), _nm(f.clearance_max_m)) == (
        _um_nm(cmin_um),
        _um_nm(cmax_um),
    ), source
    assert f.kind == kind
    assert f.designation == designation
    assert f.nominal_m == nominal_mm / 1000.0


@pytest.mark.parametrize("designation", ["H7/g6", "H7-g6", "H7 g6", " H7 / g6 "])
def test_fit_accepts_the_three_separators(designation: str) -> None:
    f = fit(designation, 0.010)
    assert f.designation == "H7/g6"
    assert (_nm(f.clearance_min_m), _nm(f.clearance_max_m)) == (5000, 29000)


def test_fit_kind_boundaries() -> None:
    zone = ToleranceZone("H", 7, 0.0, 15e-6)
    shaft = ToleranceZone("h", 6, -9e-6, 0.0)
    assert Fit("H7/h6", 0.01, zone, shaft, 0.0, 24e-6).kind == "clearance"
    assert Fit("H7/h6", 0.01, zone, shaft, -1e-6, 0.0).kind == "interference"
    assert Fit("H7/h6", 0.01, zone, shaft, -1e-6, 1e-6).kind == "transition"


def test_supported_letters_and_grades() -> None:
    letters = supported_letters()
    assert set(letters) == {"hole", "shaft"}
    for required in ("D", "E", "F", "G", "H", "JS", "K", "N", "P", "S"):
        assert required in letters["hole"]
        assert required.lower() in letters["shaft"]
    assert tuple(s.upper() for s in letters["shaft"]) == letters["hole"]
    assert set(range(5, 12)) <= set(SUPPORTED_GRADES)


# --------------------------------------------------------------------------------------
# 5. Errors
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("designation", "nominal_m", "pattern"),
    [
        ("H7g6", 0.01, r'expected a fit designation .*"H7/g6".*found \'H7g6\''),
        ("H7/", 0.01, r"expected a fit designation"),
        ("", 0.01, r"expected a fit designation"),
        ("H7/g6/f7", 0.01, r"expected a fit designation"),
        (7, 0.01, r"expected a fit designation string .* found 7 \(int\)"),
        ("Z7/g6", 0.01, r"expected a hole letter .*C, D, E.*JS.*found 'Z'"),
        ("H7/x6", 0.01, r"shaft letter \(lowercase\) in c, d, e.*found 'x'"),
        ("H17/g6", 0.01, r"expected an IT grade from 1 to 16, found IT17"),
        ("H7/g0", 0.01, r"expected an IT grade from 1 to 16, found IT0"),
        ("H01/g6", 0.01, r"expected an IT grade from 1 to 16, found IT01"),
        ("H7/g6", 0.6, r"nominal 600 mm is outside the table's 0-500 mm range"),
        ("H7/g6", 0.0, r"nominal 0 mm is outside the table's 0-500 mm range"),
        ("H7/g6", -0.01, r"nominal -10 mm is outside"),
        ("H7/g6", math.nan, r"nominal nan mm is outside"),
        ("H7/g6", "10", r"expected the nominal size as a number of metres, found '10' \(str\)"),
        ("H7/g6", True, r"expected the nominal size as a number of metres"),
        ("h7/g6", 0.01, r"the hole must be uppercase \(e\.g\. \"H7\"\), found lowercase 'h7'"),
        ("H7/G6", 0.01, r"the shaft must be lowercase \(e\.g\. \"g6\"\), found uppercase 'G6'"),
        ("g6/H7", 0.01, r"expected the hole first, then the shaft \(e\.g\. \"H7/g6\"\)"),
        ("Js7/h6", 0.01, r"all uppercase for a hole \(\"JS7\"\) or all lowercase.*found 'Js'"),
        ("K9/h9", 0.01, r"defines K above IT8 only for nominal sizes up to 3 mm"),
        ("N9/h9", 0.0008, r"does not use N above IT8 for nominal sizes up to 1 mm"),
        ("H14/h14", 0.0005, r"does not use IT14 to IT16 for nominal sizes up to 1 mm"),
        ("P2/h2", 0.01, r"gives Delta only for IT3 to IT8.*found IT2"),
    ],
)
def test_fit_errors(designation: object, nominal_m: object, pattern: str) -> None:
    with pytest.raises(FitError, match=pattern):
        fit(designation, nominal_m)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("code", "pattern"),
    [
        ("H", r'expected a tolerance class "<letter\(s\)><IT grade>"'),
        ("7H", r"expected a tolerance class"),
        (None, r"expected a tolerance class string .* found None \(NoneType\)"),
        ("jS6", r"all uppercase for a hole \(\"JS6\"\) or all lowercase for a shaft \(\"js6\"\)"),
        ("A11", r"expected a hole letter .*found 'A'"),
    ],
)
def test_tolerance_zone_errors(code: object, pattern: str) -> None:
    with pytest.raises(FitError, match=pattern):
        tolerance_zone(code, 0.01)  # type: ignore[arg-type]


def test_fit_error_is_a_value_error_and_dataclasses_validate() -> None:
    assert issubclass(FitError, ValueError)
    with pytest.raises(FitError, match=r"expected lower_m <= upper_m"):
        ToleranceZone("H", 7, 1e-6, 0.0)
    with pytest.raises(FitError, match=r"ToleranceZone.letter: expected a hole letter"):
        ToleranceZone("x", 7, 0.0, 1e-6)
    with pytest.raises(FitError, match=r"ToleranceZone.grade: expected an IT grade"):
        ToleranceZone("H", 0, 0.0, 1e-6)
    hole = ToleranceZone("H", 7, 0.0, 15e-6)
    shaft = ToleranceZone("g", 6, -14e-6, -5e-6)
    with pytest.raises(FitError, match=r"Fit.hole: expected a hole zone"):
        Fit("g6/g6", 0.01, shaft, shaft, 0.0, 1e-6)
    with pytest.raises(FitError, match=r"Fit.shaft: expected a shaft zone"):
        Fit("H7/H7", 0.01, hole, hole, 0.0, 1e-6)
    with pytest.raises(FitError, match=r"expected clearance_min_m <= clearance_max_m"):
        Fit("H7/g6", 0.01, hole, shaft, 29e-6, 5e-6)


def test_sub_millimetre_sizes_use_the_first_step() -> None:
    # 0 < d <= 3 mm is one step: H7 = +10 um, g6 = -8..-2 um (SRC_JIS_SHAFT, row "-3").
    f = fit("H7/g6", 0.0006)
    assert (_nm(f.clearance_min_m), _nm(f.clearance_max_m)) == (2000, 18000)


# --------------------------------------------------------------------------------------
# 6. Properties over the whole table
# --------------------------------------------------------------------------------------
_ALL_LETTERS = supported_letters()["hole"] + supported_letters()["shaft"]


def _iso_defines(letter: str, grade: int, nominal_mm: float) -> bool:
    """The combinations ISO 286-1 leaves undefined (mirrors the notes of Tables 1 and 3)."""
    if grade >= 14 and nominal_mm <= 1.0:
        return False
    if letter in ("K", "M", "N", "P", "R", "S", "U") and grade < 3:
        return False
    if letter == "K" and grade > 8 and nominal_mm > 3.0:
        return False
    return not (letter == "N" and grade > 8 and nominal_mm <= 1.0)


_sizes_m = st.floats(min_value=1e-6, max_value=0.5, allow_nan=False, allow_infinity=False)


@settings(max_examples=400, deadline=None)
@given(letter=st.sampled_from(_ALL_LETTERS), grade=st.sampled_from(SUPPORTED_GRADES),
       nominal_m=_sizes_m)  # fmt: skip
def test_zone_width_is_the_it_value(letter: str, grade: int, nominal_m: float) -> None:
    assume(_iso_defines(letter, grade, round(nominal_m * 1000.0, 6)))
    it_nm = _nm(standard_tolerance_m(grade, nominal_m))
    exact = tolerance_zone(f"{letter}{grade}", nominal_m, round_js=False)
    assert _nm(exact.upper_m) - _nm(exact.lower_m) == it_nm
    if letter == "H":
        assert exact.lower_m == 0.0
    if letter == "h":
        assert exact.upper_m == 0.0
    if letter in ("js", "JS"):
        assert exact.lower_m == -exact.upper_m
    rounded = tolerance_zone(f"{letter}{grade}", nominal_m)
    shrink = it_nm - (_nm(rounded.upper_m) - _nm(rounded.lower_m))
    odd_js = letter in ("js", "JS") and 7 <= grade <= 11 and (it_nm // 1000) % 2 == 1
    assert shrink == (1000 if odd_js else 0)


@settings(max_examples=400, deadline=None)
@given(hole=st.sampled_from(supported_letters()["hole"]),
       shaft=st.sampled_from(supported_letters()["shaft"]),
       hole_grade=st.sampled_from(SUPPORTED_GRADES), shaft_grade=st.sampled_from(SUPPORTED_GRADES),
       nominal_m=_sizes_m)  # fmt: skip
def test_fit_clearance_span_is_sum_of_it_values(
    hole: str, shaft: str, hole_grade: int, shaft_grade: int, nominal_m: float
) -> None:
    nominal_mm = round(nominal_m * 1000.0, 6)
    assume(_iso_defines(hole, hole_grade, nominal_mm))
    assume(_iso_defines(shaft, shaft_grade, nominal_mm))
    f = fit(f"{hole}{hole_grade}/{shaft}{shaft_grade}", nominal_m, round_js=False)
    span_nm = _nm(f.clearance_max_m) - _nm(f.clearance_min_m)
    it_sum_nm = _nm(standard_tolerance_m(hole_grade, nominal_m)) + _nm(
        standard_tolerance_m(shaft_grade, nominal_m)
    )
    assert span_nm == it_sum_nm
    assert _nm(f.clearance_min_m) == _nm(f.hole.lower_m) - _nm(f.shaft.upper_m)
    assert f.kind == (
        "clearance"
        if f.clearance_min_m >= 0
        else "interference"
        if f.clearance_max_m <= 0
        else "transition"
    )


@settings(max_examples=200, deadline=None)
@given(grade=st.integers(min_value=3, max_value=7),
       nominal_m=st.floats(min_value=0.0031, max_value=0.5),
       letter=st.sampled_from(["K", "M", "N", "P", "R", "S", "U"]))  # fmt: skip
def test_shaft_basis_fit_mirrors_hole_basis_fit_one_grade_finer(
    grade: int, nominal_m: float, letter: str
) -> None:
    """ISO 286-1's Delta rule (sizes above 3 mm) makes e.g. P7/h6 the same fit as H7/p6."""
    nominal_mm = round(nominal_m * 1000.0, 6)
    # k3 has ei = 0 while K4 uses the k4..k7 value; M6 at 250-315 mm is a deliberate exception.
    assume(not (letter == "K" and grade < 5))
    assume(not (letter == "M" and grade == 6 and 250.0 < nominal_mm <= 315.0))
    shaft_basis = fit(f"{letter}{grade}/h{grade - 1}", nominal_m)
    hole_basis = fit(f"H{grade}/{letter.lower()}{grade - 1}", nominal_m)
    assert _nm(shaft_basis.clearance_min_m) == _nm(hole_basis.clearance_min_m)
    assert _nm(shaft_basis.clearance_max_m) == _nm(hole_basis.clearance_max_m)
