"""The sweep journal: an append-only JSON-lines file (a header, then one flushed and fsync'ed line
per finished sample) with an advisory lock, and each sample's :class:`TaskResult`.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from .errors import JournalCorruptError, JournalLockedError, JournalMismatchError
from .sampling import SweepSpec

try:  # POSIX advisory locks keep two sweeps from appending to one journal
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]
JOURNAL_NAME = "sweep-journal.jsonl"
"""File name of the journal inside a sweep's output folder."""

JOURNAL_FORMAT = 1

@dataclass(frozen=True)
class TaskResult:
    """What one sample produced.

    Attributes
    ----------
    index : int
        Sample index.
    ok : bool
        The task returned a value. False when it raised or its worker kept dying; this is not
        the physical verdict, which lives inside ``value``.
    value : JSON-safe object or None
        The task's return value after a JSON round trip (so a fresh result and one read back
        from the journal are equal).
    error : str or None
        Why ``ok`` is False, in words (with the exception's message and where it was raised).
    attempts : int
        How many times the sample was started.
    error_code : str or None
        Why ``ok`` is False, as a code that statistics count: ``"worker_died"``,
        ``"not_json_safe"`` or ``"raised:<exception type>"``.
    """

    index: int
    ok: bool
    value: Any = None
    error: str | None = None
    attempts: int = 1
    error_code: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"index": self.index, "ok": self.ok, "value": self.value, "error": self.error,
                "attempts": self.attempts, "error_code": self.error_code}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TaskResult:
        return cls(index=int(data["index"]), ok=bool(data["ok"]), value=data.get("value"),
                   error=data.get("error"), attempts=int(data.get("attempts", 1)),
                   error_code=data.get("error_code"))


def canonical_json(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def sha256_hex(*chunks: bytes | str) -> str:
    """SHA-256 of the concatenated chunks (str encoded as UTF-8), hex; for journal headers."""
    h = hashlib.sha256()
    for c in chunks:
        h.update(c.encode("utf-8") if isinstance(c, str) else c)
    return h.hexdigest()


def journal_header(spec: SweepSpec, fingerprint: str, **extra: Any) -> dict[str, Any]:
    """The header identifying a sweep: the spec without ``n_samples`` plus a fingerprint.

    ``n_samples`` is left out on purpose: sample ``i`` does not depend on it, so a finished
    sweep can be extended to more samples by resuming it with a larger ``n_samples``.

    Parameters
    ----------
    spec : SweepSpec
    fingerprint : str
        Identifies what is simulated, e.g. ``sha256_hex(product_yaml_bytes, plan_json)``.
    **extra
        Further JSON-safe entries that must match on resume (fidelity, criteria, ...).
    """
    s = spec.to_dict()
    del s["n_samples"]
    return {"spec": s, "fingerprint": fingerprint, **extra}


def _flatten(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


class SweepJournal:
    """Append-only JSON-lines record of a sweep (one per output folder).

    Line 1 is ``{"asmplan_sweep_journal": 1, "header": {...}}``; every further line is one
    :class:`TaskResult` as a JSON object, written with a single ``write`` then flushed and
    fsync'ed. Opening an existing journal checks its header against ``header``
    (:class:`JournalMismatchError` when they differ), reads the finished results, and cuts off
    a last line that a crash left half-written. A POSIX advisory lock refuses a second writer.

    Use as a context manager, or call :meth:`close`.

    Parameters
    ----------
    path : path-like
        The journal file; created (with its folder) when missing.
    header : mapping
        JSON-safe description of the sweep (see :func:`journal_header`).
    """

    def __init__(self, path: str | os.PathLike[str], header: Mapping[str, Any]) -> None:
        self.path = Path(path)
        self.header: dict[str, Any] = json.loads(canonical_json(dict(header)))
        self.finished: dict[int, TaskResult] = {}
        self.truncated_bytes = 0
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh: IO[bytes] = open(self.path, "a+b")  # noqa: SIM115 - held open until close()
        try:
            self._lock()
            self._load()
        except BaseException:
            self._fh.close()
            raise

    def _lock(self) -> None:
        if fcntl is None:  # pragma: no cover
            return
        try:
            fcntl.flock(self._fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            raise JournalLockedError(
                f"{self.path}: another process is writing this sweep journal ({exc})") from exc

    def _load(self) -> None:
        self._fh.seek(0)
        data = self._fh.read()
        lines = data.split(b"\n")
        # everything after the last newline is an unfinished line: a crash mid-write
        complete, tail = lines[:-1], lines[-1]
        keep = len(data) - len(tail)
        if not complete:
            self._truncate(0)
            self._write_line({"asmplan_sweep_journal": JOURNAL_FORMAT, "header": self.header})
            return
        try:
            first = json.loads(complete[0])
        except json.JSONDecodeError as exc:
            raise JournalCorruptError(self.path, 1, f"the header line is not JSON ({exc})") from exc
        if not isinstance(first, dict) or first.get("asmplan_sweep_journal") != JOURNAL_FORMAT:
            raise JournalCorruptError(
                self.path, 1, f"expected an asmplan sweep journal header (format {JOURNAL_FORMAT}), "
                f"found {complete[0][:80]!r}")
        have = _flatten(first.get("header", {}))
        want = _flatten(self.header)
        diffs = [f"{k}: journal has {have.get(k, '(missing)')!r}, this run has {want.get(k, '(missing)')!r}"
                 for k in sorted(set(have) | set(want)) if have.get(k) != want.get(k)]
        if diffs:
            raise JournalMismatchError(self.path, diffs)
        for n, raw in enumerate(complete[1:], start=2):
            if not raw.strip():
                continue
            try:
                result = TaskResult.from_dict(json.loads(raw))
            except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
                raise JournalCorruptError(self.path, n, f"not a sample record ({exc})") from exc
            self.finished[result.index] = result
        if tail:  # a line without its newline: the write was cut short; drop it
            self._truncate(keep)

    def _truncate(self, size: int) -> None:
        self.truncated_bytes = self._fh.seek(0, os.SEEK_END) - size
        self._fh.truncate(size)
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def _write_line(self, obj: Mapping[str, Any]) -> None:
        self._fh.seek(0, os.SEEK_END)
        self._fh.write(canonical_json(obj).encode("utf-8") + b"\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def append(self, result: TaskResult) -> None:
        """Write one finished sample (durable when this returns)."""
        self._write_line(result.to_dict())
        self.finished[result.index] = result

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.close()

    def __enter__(self) -> SweepJournal:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()




def iter_journal_results(path: str | os.PathLike[str]) -> Iterator[TaskResult]:
    """Read the sample records of a journal without opening it for writing (for reports)."""
    with open(path, "rb") as fh:
        lines = fh.read().split(b"\n")
    for raw in lines[1:-1]:
        if raw.strip():
            yield TaskResult.from_dict(json.loads(raw))

