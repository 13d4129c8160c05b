"""Terminal output shared by the subcommands: one progress bar and one plain-text table."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TextIO


class StageProgress:
    """A one-line progress bar per stage on a terminal; plain log lines otherwise.

    Call as ``progress(stage, done, total, label)`` (the pipeline's progress signature).
    """

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.tty = bool(getattr(stream, "isatty", lambda: False)())
        self.t0 = time.perf_counter()

    def __call__(self, stage: str, done: int, total: int, label: str) -> None:
        elapsed = time.perf_counter() - self.t0
        if self.tty:
            width = 24
            fill = round(width * done / max(total, 1))
            self.stream.write(f"\r{stage:<9} [{'#' * fill}{'.' * (width - fill)}] {done}/{total} "
                              f"{label:<16} {elapsed:6.1f} s")
            if done == total:
                self.stream.write("\n")
        elif done > 0:
            self.stream.write(f"{stage}: {done}/{total} {label} ({elapsed:.1f} s)\n".replace("  ", " "))
        self.stream.flush()


def format_table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """Columns left-aligned to their widest cell, a dashed rule under the header."""
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]

    def line(r: Sequence[str]) -> str:
        return "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()

    return "\n".join([line(head), line(["-" * w for w in widths]), *map(line, rows)])
