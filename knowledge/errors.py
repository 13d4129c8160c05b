"""Input errors that point at the file, line, column and key path of the bad value."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from ..errors import AsmplanError


@dataclass(frozen=True, order=True)
class InputIssue:
    """One problem in an input file.

    Parameters
    ----------
    file : str
        The file as the user named it.
    line, column : int
        1-based position of the offending value (0 when unknown).
    path : str
        Key path such as ``parts[2].geometry.size`` ("" for the whole document).
    message : str
        What was expected and what was found.
    """

    file: str
    line: int
    column: int
    path: str
    message: str

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}:{self.column}" if self.line else self.file
        return f"{where}: {self.path}: {self.message}" if self.path else f"{where}: {self.message}"


class ProductError(AsmplanError, ValueError):
    """A product file (or a file it names) is invalid; carries every issue found at once."""

    def __init__(self, issues: Iterable[InputIssue]):
        self.issues: tuple[InputIssue, ...] = tuple(sorted(set(issues)))
        n = len(self.issues)
        head = f"{n} error{'s' if n != 1 else ''} in product input"
        super().__init__(head + ":\n" + "\n".join(f"  {i}" for i in self.issues))


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """Return ``'; did you mean "x"?'`` for the closest choice, or ``""``."""
    import difflib

    match = difflib.get_close_matches(word, sorted(choices), n=1, cutoff=0.6)
    return f'; did you mean "{match[0]}"?' if match else ""
