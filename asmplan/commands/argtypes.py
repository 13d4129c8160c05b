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
