"""Atomic output: a file or a whole output folder appears complete or not at all.

Every file asmplan writes goes through here: the bytes go to a temporary file in the same
folder, are flushed to disk (fsync), then ``os.replace`` swaps it in. A crash or Ctrl-C leaves
either the old file or the new one, never half of one. :class:`OutputFolder` does the same
for a folder of outputs (a report): it is built beside the target and swapped in at the end
with one atomic exchange.

asmplan never deletes or overwrites what it did not write: an output folder is replaced only
when it is new, empty, or carries the marker (:data:`OUTPUT_MARKER`) that lists the files
asmplan put there; an output file only when it is asmplan's own JSON. Both are checked before
any work starts (:func:`check_output_folder`, :func:`check_output_file`), so a refusal costs
nothing. docs/output-folders.md states the rules.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import fcntl
import json
import os
import shutil
import tempfile
import time
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
    """Clean up after runs that were killed (their process is gone): drop their staging
    folders, and put back a previous output that a kill left moved aside (only possible on file
    systems without an atomic exchange, where the swap takes two renames)."""
    for kind in ("staging", "old"):
        for folder in sorted(target.parent.glob(f".{target.name}.{kind}.*")):
            pid_text = folder.name[len(f".{target.name}.{kind}."):].split(".", 1)[0]
            if not pid_text.isdigit() or _pid_alive(int(pid_text)):
                continue
            previous = folder / "previous"
            if kind == "old" and previous.is_dir() and not os.path.lexists(target):
                os.replace(previous, target)
            shutil.rmtree(folder, ignore_errors=True)


# ---------------------------------------------------------------------------------------------
# Output folders: asmplan replaces only what it wrote itself
# ---------------------------------------------------------------------------------------------

#: Written into every output folder asmplan builds: the manifest of the files it wrote. A
#: folder is replaced only when it holds this marker and nothing that the marker does not list.
OUTPUT_MARKER = ".asmplan-output"
_MARKER_TAG = "asmplan-output-folder"


class OutputPathError(Exception):
    """An output path asmplan must not (or cannot) write: raised before any work is done.

    Attributes
    ----------
    path : Path
        The output path as the user gave it.
    reason : str
        What is wrong, and what to do instead.
    """

    def __init__(self, path: str | os.PathLike[str], reason: str) -> None:
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"{path}: {reason}")


def _marker_files(folder: Path) -> set[str] | None:
    """The files the marker in ``folder`` says asmplan wrote, or None without a valid marker."""
    try:
        data = json.loads((folder / OUTPUT_MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("written_by") != _MARKER_TAG:
        return None
    files = data.get("files")
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    return set(files)


def _tree_files(folder: Path) -> set[str]:
    """Every file and folder below ``folder`` (relative, '/'-separated), folders with a '/'."""
    found: set[str] = set()
    for root, dirs, files in os.walk(folder):
        rel = Path(root).relative_to(folder)
        for d in dirs:
            found.add(f"{(rel / d).as_posix()}/")
        for f in files:
            found.add((rel / f).as_posix())
    return found


def _manifest(folder: Path) -> list[str]:
    return sorted(_tree_files(folder) - {OUTPUT_MARKER})


def _write_marker(folder: Path, files: list[str] | None = None) -> None:
    listed = _manifest(folder) if files is None else sorted(set(files) | set(_manifest(folder)))
    atomic_write_json(folder / OUTPUT_MARKER, {"written_by": _MARKER_TAG, "files": listed})


def claim_work_folder(path: str | os.PathLike[str], expected: list[str]) -> Path:
    """Check and mark a folder that asmplan fills in place over a long job (a sweep with its
    journal): :func:`check_output_folder` first, then the folder is made and its marker lists
    what is there plus ``expected`` (the files the job is about to write), so that an
    interrupted job can be resumed and nothing foreign is ever written over. Call
    :func:`mark_output_folder` when the job has written its files."""
    target = check_output_folder(path)
    target.mkdir(parents=True, exist_ok=True)
    _write_marker(target, expected)
    return target


def mark_output_folder(folder: str | os.PathLike[str]) -> None:
    """Rewrite the marker of an asmplan folder filled in place to list every file in it."""
    _write_marker(Path(folder))


def _nearest_existing(path: Path) -> Path:
    p = path
    while not os.path.lexists(p):
        p = p.parent
    return p


def _check_parent_writable(user_path: Path, target: Path) -> None:
    """The folder that will hold ``target`` exists or can be made, and is writable."""
    anchor = _nearest_existing(target.parent)
    if not anchor.is_dir():
        raise OutputPathError(user_path, f"{anchor} is a file, not a folder: it cannot hold the output")
    if not os.access(anchor, os.W_OK | os.X_OK):
        raise OutputPathError(user_path, f"no permission to write in {anchor}")


def check_output_folder(path: str | os.PathLike[str]) -> Path:
    """Check, before any work, that asmplan may build (or replace) the output folder ``path``.

    Allowed: a path that does not exist yet (its nearest existing ancestor a writable folder),
    an empty folder, or a folder asmplan wrote before (its :data:`OUTPUT_MARKER` lists every
    file in it). Refused with :class:`OutputPathError`: a file, a symbolic link, a folder that
    holds anything asmplan did not write, the current folder or one of its ancestors, a
    folder whose parent is not writable.

    Returns the absolute target path.
    """
    user_path = Path(path)
    target = Path(os.path.abspath(user_path))
    if os.path.islink(target):
        raise OutputPathError(user_path, "is a symbolic link; asmplan replaces its output folder "
                                         "whole, so name a real folder")
    if os.path.lexists(target) and not target.is_dir():
        raise OutputPathError(user_path, "is a file, not an output folder; asmplan never "
                                         "overwrites a file it did not write: name a folder")
    cwd = Path(os.path.abspath(os.getcwd()))
    if target == cwd or target in cwd.parents:
        raise OutputPathError(user_path, "is the current folder (or holds it); asmplan replaces "
                                         "its output folder whole: name a subfolder such as out/")
    if target.is_dir():
        present = _tree_files(target)
        if present:
            listed = _marker_files(target)
            if listed is None:
                shown = ", ".join(sorted(present)[:5]) + (", ..." if len(present) > 5 else "")
                raise OutputPathError(
                    user_path, f"is a folder asmplan did not write (it holds {shown}); asmplan "
                               "replaces only its own output folders: name a new or empty folder")
            foreign = sorted(present - listed - {OUTPUT_MARKER})
            if foreign:
                shown = ", ".join(foreign[:5]) + (", ..." if len(foreign) > 5 else "")
                raise OutputPathError(
                    user_path, f"holds files asmplan did not write ({shown}); move them out or "
                               "name another folder")
    _check_parent_writable(user_path, target)
    return target


def check_output_file(path: str | os.PathLike[str], *, json_format: str | None = None) -> Path:
    """Check, before any work, that asmplan may write (or replace) the file ``path``.

    Refused with :class:`OutputPathError`: a folder, a symbolic link, a path under a file, an
    unwritable folder, and an existing file that asmplan did not write. An existing file counts
    as asmplan's when it is JSON whose top-level ``"format"`` is ``json_format`` (plan and
    results files carry it), or, with ``json_format=None``, any JSON object asmplan writes
    (sorted keys, no NaN).
    """
    user_path = Path(path)
    target = Path(os.path.abspath(user_path))
    if os.path.islink(target):
        raise OutputPathError(user_path, "is a symbolic link; name a real file")
    if target.is_dir():
        raise OutputPathError(user_path, "is a folder; name the file to write (for example "
                                         f"{user_path / 'plan.json'})")
    _check_parent_writable(user_path, target)
    if target.exists():
        try:
            data = json.loads(target.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            data = None
        ours = isinstance(data, dict) and (json_format is None or data.get("format") == json_format)
        if not ours:
            what = f"an asmplan {json_format} file" if json_format else "a JSON file asmplan wrote"
            raise OutputPathError(user_path, f"exists and is not {what}; asmplan never overwrites "
                                             "a file it did not write: name another file")
    return target


# renameat2(2) with RENAME_EXCHANGE swaps two paths in one step (Linux >= 3.15, glibc >= 2.28).
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _load_renameat2() -> Any:
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    return fn


_renameat2 = _load_renameat2()


def exchange_paths(a: Path, b: Path) -> bool:
    """Atomically swap the folders ``a`` and ``b``; False where the system cannot."""
    if _renameat2 is None:  # pragma: no cover
        return False
    rc = _renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):  # file system without exchange
        return False
    raise OSError(err, os.strerror(err), str(a), None, str(b))


class OutputFolder:
    """An output folder reserved before the work starts and replaced whole at the end.

    On construction the target is checked (:func:`check_output_folder`), a lock beside it
    (``.NAME.lock``) refuses a second asmplan writing the same folder, and the staging folder
    is made beside it (which also proves the place writable). :meth:`commit` writes the marker,
    re-checks that nobody put foreign files into the target meanwhile, and swaps the staging
    folder in with one atomic exchange (no moment without an output folder). :meth:`close`
    (or leaving the ``with`` block) removes the staging folder if it was not committed and
    releases the lock.

    Parameters
    ----------
    target : path-like
        The output folder.
    """

    def __init__(self, target: str | os.PathLike[str]) -> None:
        self.user_path = Path(target)
        self.target = check_output_folder(target)
        self.target.parent.mkdir(parents=True, exist_ok=True)
        lock = self.target.parent / f".{self.target.name}.lock"
        self._lock_fd: int | None = _acquire_lock(self.user_path, lock)
        try:
            _remove_abandoned(self.target)
            check_output_folder(self.user_path)  # again, under the lock
            pid = os.getpid()
            self.stage = Path(tempfile.mkdtemp(prefix=f".{self.target.name}.staging.{pid}.",
                                               dir=self.target.parent))
            os.chmod(self.stage, 0o777 & ~_UMASK)  # mkdtemp makes 0700
        except BaseException:
            self._release_lock()
            raise
        self.committed = False

    def __enter__(self) -> OutputFolder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def commit(self) -> Path:
        """Swap the staged contents in as the target; returns the target."""
        if self.committed:
            raise RuntimeError(f"{self.target}: already committed")
        _write_marker(self.stage)
        _fsync_dir(self.stage)
        check_output_folder(self.user_path)  # nothing foreign arrived while we worked
        parent = self.target.parent
        if os.path.lexists(self.target):
            if exchange_paths(self.stage, self.target):
                old = self.stage.with_name(self.stage.name.replace(".staging.", ".old.", 1))
                os.replace(self.stage, old)  # the previous output, now under the staging name
                _fsync_dir(parent)
                shutil.rmtree(old, ignore_errors=True)
            else:  # pragma: no cover - file systems without RENAME_EXCHANGE
                old = Path(tempfile.mkdtemp(prefix=f".{self.target.name}.old.{os.getpid()}.",
                                            dir=parent))
                os.replace(self.target, old / "previous")
                os.replace(self.stage, self.target)
                _fsync_dir(parent)
                shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(self.stage, self.target)
            _fsync_dir(parent)
        self.committed = True
        return self.target

    def close(self) -> None:
        """Drop the staging folder if not committed, and release the lock."""
        if not self.committed:
            shutil.rmtree(self.stage, ignore_errors=True)
        self._release_lock()

    def _release_lock(self) -> None:
        if self._lock_fd is not None:
            fd, self._lock_fd = self._lock_fd, None
            _release_lock(fd, self.target.parent / f".{self.target.name}.lock")


LOCK_WAIT_S = 2.0
"""How long a run waits for an output folder's lock before it says another process writes
there, s. A run killed with SIGKILL leaves its worker and picture processes holding the lock
until the kernel has delivered their parent-death signal and they have exited: measured 10-60
ms after the killed run was reaped on 2 loaded cores (more under heavier load); a run that
really writes there holds it for seconds."""


def _acquire_lock(user_path: Path, lock_path: Path) -> int:
    """Take an exclusive lock on ``lock_path``, waiting up to :data:`LOCK_WAIT_S` for a holder
    that is exiting; the file is ours alone."""
    deadline = time.monotonic() + LOCK_WAIT_S
    for _ in range(10):
        fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o666 & ~_UMASK)
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except OSError:
                if time.monotonic() < deadline:
                    time.sleep(0.02)
                    continue
                os.close(fd)
                raise OutputPathError(user_path, "another asmplan process is writing this "
                                                 "output folder now; wait for it or name "
                                                 "another folder") from None
        try:  # the holder before us may have unlinked the file we opened: then retry
            if os.fstat(fd).st_ino == os.stat(lock_path).st_ino:
                return fd
        except FileNotFoundError:
            pass
        os.close(fd)
    raise OutputPathError(user_path, f"cannot lock {lock_path}")  # pragma: no cover


def _release_lock(fd: int, lock_path: Path) -> None:
    with contextlib.suppress(FileNotFoundError):
        os.unlink(lock_path)  # while still holding it (see the inode check in _acquire_lock)
    os.close(fd)


@contextlib.contextmanager
def staged_directory(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Build a folder's new contents beside it and swap it in only when the block succeeds.

    ``target`` is checked first (:func:`check_output_folder`: only a new, empty or
    asmplan-written folder is ever replaced; :class:`OutputPathError` otherwise). Yields a
    fresh staging folder. On success the marker is written and the staging folder exchanged
    with ``target`` atomically; on any exception (including KeyboardInterrupt) the staging
    folder is removed and ``target`` is untouched.
    """
    with OutputFolder(target) as folder:
        yield folder.stage
        folder.commit()
