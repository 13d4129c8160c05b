"""Argument types for the subcommands: numbers with a bound, saying expected vs found."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def int_at_least(minimum: int) -> Callable[[str], int]:
    """An ``argparse`` type: an integer >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'expected an integer, found "{text}"') from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, found {value}")
        return value

    return parse


def float_above(minimum: float, *, inclusive: bool = False) -> Callable[[str], float]:
    """An ``argparse`` type: a finite number > ``minimum`` (>= with ``inclusive``)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'expected a number, found "{text}"') from None
        ok = math.isfinite(value) and (value >= minimum if inclusive else value > minimum)
        if not ok:
            sign = ">=" if inclusive else ">"
            raise argparse.ArgumentTypeError(f"expected a number {sign} {minimum:g}, found {text}")
        return value

    return parse


positive_int = int_at_least(1)
nonnegative_int = int_at_least(0)
positive_float = float_above(0.0)
nonnegative_float = float_above(0.0, inclusive=True)


def add_jobs_argument(parser: argparse.ArgumentParser) -> None:
    """``-j/--jobs N``: processes that simulate steps (default None: one per usable core)."""
    parser.add_argument("-j", "--jobs", type=int_at_least(1), default=None, metavar="N",
                        help="processes that simulate steps in parallel (default: one per "
                             "usable core; results are identical for any N)")


POSE_ERROR_MAX_LATERAL_MM = 50.0
POSE_ERROR_MAX_TILT_DEG = 30.0


def pose_error_arg(text: str) -> tuple[float, float]:
    """An ``argparse`` type: ``LATERAL_MM,TILT_DEG`` -> (lateral m, tilt rad).

    The held part is displaced LATERAL_MM across each insertion's mate axis and tilted
    TILT_DEG about the axis perpendicular to both (``asmplan.sim.pose_error``).
    """
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(
            f'expected two numbers LATERAL_MM,TILT_DEG (e.g. "0.5,0"), found "{text}"')
    values = []
    for label, p, limit in (("LATERAL_MM", parts[0], POSE_ERROR_MAX_LATERAL_MM),
                            ("TILT_DEG", parts[1], POSE_ERROR_MAX_TILT_DEG)):
        try:
            v = float(p)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f'{label}: expected a number, found "{p}" in "{text}"') from None
        if not (math.isfinite(v) and abs(v) <= limit):
            raise argparse.ArgumentTypeError(
                f"{label}: expected a number within [-{limit:g}, {limit:g}], found {p}")
        values.append(v)
    return values[0] * 1e-3, math.radians(values[1])


def add_pose_error_argument(parser: argparse.ArgumentParser) -> None:
    """``--pose-error LATERAL_MM,TILT_DEG`` (default: none)."""
    parser.add_argument("--pose-error", type=pose_error_arg, default=None,
                        metavar="LATERAL_MM,TILT_DEG",
                        help="robot pose error at every insertion: the held part displaced "
                             "LATERAL_MM across the mate axis and tilted TILT_DEG about the "
                             "axis perpendicular to both, carried by a stiff robot (e.g. 0.5,0)")
