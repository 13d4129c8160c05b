"""Errors of the sweep machinery (journal and executors).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ...errors import AsmplanError

try:  # POSIX advisory locks keep two sweeps from appending to one journal
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]


class SweepError(AsmplanError, RuntimeError):
    """Base class of the sweep machinery's errors."""


class JournalMismatchError(SweepError):
    """The journal on disk belongs to a different sweep.

    Attributes
    ----------
    path : Path
    differences : tuple of str
        One ``"key: journal has X, this run has Y"`` per differing header entry.
    """

    def __init__(self, path: Path, differences: Sequence[str]) -> None:
        self.path = Path(path)
        self.differences = tuple(differences)
        super().__init__(
            f"{path}: this journal was written for a different sweep, so it cannot be resumed: "
            + "; ".join(self.differences)
            + ". Use a new output folder, or delete the journal to start over."
        )


class JournalCorruptError(SweepError):
    """A line other than the last one of a journal is not a valid record."""

    def __init__(self, path: Path, line_number: int, problem: str) -> None:
        self.path = Path(path)
        self.line_number = line_number
        super().__init__(f"{path}:{line_number}: {problem}")


class JournalLockedError(SweepError):
    """Another process holds the journal open for writing."""


class ExecutorBrokenError(SweepError):
    """A caller-supplied executor broke and cannot be rebuilt by :func:`run_sweep`.

    Attributes
    ----------
    finished : int
        Samples finished (and journalled) before the break; a resume continues from there.
    """

    def __init__(self, message: str, finished: int) -> None:
        self.finished = finished
        super().__init__(message)


class DaskUnavailableError(SweepError):
    """Dask is not installed (it is the optional extra ``asmplan[dask]``)."""
