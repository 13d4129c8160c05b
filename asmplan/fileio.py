"""Atomic output: a file or a whole output folder appears complete or not at all.

Every file asmplan writes goes through here: the bytes go to a temporary file in the same
folder, are flushed to disk (fsync), then ``os.replace`` swaps it in. A crash or Ctrl-C leaves
either the old file or the new one, never half of one. :func:`staged_directory` does the same
for a folder of outputs (a report): it is built beside the target and swapped in at the end.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _current_umask()


def _fsync_dir(folder: Path) -> None:
    with contextlib.suppress(OSError):  # not every file system allows opening a folder
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, 0o666 & ~_UMASK)  # mkstemp makes 0600; give the usual permissions
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    _fsync_dir(path.parent)
    return path


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 ``text`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


_INDENT_LEVELS = 4


def dumps_json(data: Any) -> str:
    """Deterministic JSON text: sorted keys, trailing newline; objects (and lists holding
    objects) indented by 2 spaces down to 4 levels, anything deeper or any list of numbers
    on one line. Readable where it matters and ~5x faster on recorded arrays than a full
    indent (which forces Python's pure-Python encoder)."""
    return _dumps(data, 0) + "\n"


def _dumps(v: Any, level: int) -> str:
    pad, inner = "  " * level, "  " * (level + 1)
    if level < _INDENT_LEVELS:
        if isinstance(v, dict) and v:
            items = sorted((str(k), x) for k, x in v.items())
            return "{\n" + ",\n".join(f"{inner}{json.dumps(k)}: {_dumps(x, level + 1)}"
                                      for k, x in items) + f"\n{pad}}}"
        if isinstance(v, list | tuple) and any(isinstance(x, dict) for x in v):
            return "[\n" + ",\n".join(f"{inner}{_dumps(x, level + 1)}" for x in v) + f"\n{pad}]"
    return json.dumps(v, sort_keys=True, allow_nan=False, separators=(", ", ": "))


def atomic_write_json(path: str | os.PathLike[str], data: Any) -> Path:
    """Write ``data`` as deterministic JSON (see :func:`dumps_json`) atomically."""
    return atomic_write_text(path, dumps_json(data))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def _remove_abandoned(target: Path) -> None:
    """Delete staging folders left by runs that were killed (their process is gone)."""
    for kind in ("staging", "old"):
        for folder in target.parent.glob(f".{target.name}.{kind}.*"):
            pid_text = folder.name[len(f".{target.name}.{kind}."):].split(".", 1)[0]
            if pid_text.isdigit() and not _pid_alive(int(pid_text)):
                shutil.rmtree(folder, ignore_errors=True)


@contextlib.contextmanager
def staged_directory(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Build a folder's new contents beside it and swap it in only when the block succeeds.

    Yields a fresh staging folder. On success the previous ``target`` (if any) is moved
    aside, the staging folder renamed to ``target``, and the old one deleted; on any
    exception (including KeyboardInterrupt) the staging folder is removed and ``target`` is
    untouched.
    """
    target = Path(target).resolve()
    target.parent.mkdir(parents=True, exist_ok=True)
    _remove_abandoned(target)
    pid = os.getpid()
    stage = Path(tempfile.mkdtemp(prefix=f".{target.name}.staging.{pid}.", dir=target.parent))
    os.chmod(stage, 0o777 & ~_UMASK)  # mkdtemp makes 0700; the output folder is a normal one
    try:
        yield stage
        _fsync_dir(stage)
        old = None
        if target.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{target.name}.old.{pid}.", dir=target.parent))
            os.replace(target, old / "previous")
        os.replace(stage, target)
        _fsync_dir(target.parent)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
