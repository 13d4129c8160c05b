"""Running a sweep's samples through an executor (a local process pool or a Dask cluster): results
by sample index, retries of dead workers, the journal kept as samples finish.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import json
import multiprocessing
import os
import re
import traceback
from collections import Counter, deque
from collections.abc import Callable, Sequence
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import DaskUnavailableError, ExecutorBrokenError
from .journal import SweepJournal, TaskResult, canonical_json

try:  # POSIX advisory locks keep two sweeps from appending to one journal
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]


START_METHOD = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
"""Start method of the default pool. Workers are never forked from the caller: a fork copies
the caller's threads' locks (Dask's client thread, BLAS, OMPL) in whatever state they are in.
A forkserver is a fresh single-threaded process that forks the workers."""


def default_executor(max_workers: int | None = None) -> cf.ProcessPoolExecutor:
    """A process pool with ``max_workers`` (default: all cores) started with :data:`START_METHOD`."""
    n = (os.cpu_count() or 1) if max_workers is None else int(max_workers)
    if n < 1:
        raise ValueError(f"default_executor: expected max_workers >= 1, found {max_workers}")
    return cf.ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context(START_METHOD))


def _executor_width(executor: cf.Executor) -> int:
    if isinstance(executor, cf.ProcessPoolExecutor | cf.ThreadPoolExecutor):
        return int(getattr(executor, "_max_workers"))  # noqa: B009 (private attribute)
    client = getattr(executor, "_client", None)  # distributed.cfexecutor.ClientExecutor
    if client is not None:
        with contextlib.suppress(Exception):
            return max(1, sum(client.nthreads().values()))
    return os.cpu_count() or 1


def _is_worker_death(exc: BaseException) -> bool:
    """A dead worker (retry), as opposed to the task raising (record)."""
    if isinstance(exc, BrokenProcessPool | cf.CancelledError):
        return True
    # distributed.KilledWorker, without importing distributed
    return any(c.__name__ == "KilledWorker" for c in type(exc).__mro__)


_TB_LINE = re.compile(r'File "([^"]+)", line (\d+)')


def _describe(exc: BaseException) -> str:
    """``"Type: message (at file.py:line)"`` with the line where the task raised.

    A process pool attaches the worker's traceback as text in ``__cause__``; Dask rebuilds
    the remote frames in ``__traceback__``.
    """
    where = ""
    cause = exc.__cause__
    if cause is not None and type(cause).__name__ == "_RemoteTraceback":
        found = _TB_LINE.findall(str(cause))
        if found:
            where = f" (at {Path(found[-1][0]).name}:{found[-1][1]})"
    if not where:
        tb = traceback.extract_tb(exc.__traceback__)
        if tb:
            where = f" (at {Path(tb[-1].filename).name}:{tb[-1].lineno})"
    return f"{type(exc).__name__}: {exc}{where}"


ProgressFn = Callable[[int, int, TaskResult], None]


# Complexity above C (radon): one event loop for submission, retries of dead workers, isolating a
# culprit, the journal and executor rebuilds, which share the in-flight state.
def run_sweep(
    task: Callable[[Any], Any],
    params_list: Sequence[Any],
    executor: cf.Executor | None = None,
    journal: SweepJournal | None = None,
    retries: int = 2,
    max_workers: int | None = None,
    max_in_flight: int | None = None,
    redo_failed: bool = False,
    progress: ProgressFn | None = None,
) -> list[TaskResult]:
    """Run ``task(params_list[i])`` for every sample ``i``; results in index order.

    Parameters
    ----------
    task : callable
        Picklable (a module-level function or a ``functools.partial`` of one) and
        deterministic: its value must depend on its argument only. It returns a JSON-safe value
        (dicts, lists, str, finite numbers, bool, None).
    params_list : sequence
        One picklable argument per sample; the position is the sample index.
    executor : concurrent.futures.Executor, optional
        Where to run. Default: :func:`default_executor` (``max_workers``, all cores), created
        here, rebuilt when a worker dies, and shut down at the end. A Dask cluster:
        ``connect_dask(address).executor``. A caller's executor is not shut down.
    journal : SweepJournal, optional
        Samples already in it are not run again (failed ones neither, unless ``redo_failed``);
        each new result is appended as it completes.
    retries : int
        How often a sample whose worker died is run again before it is recorded as failed.
    max_workers : int, optional
        Workers of the default pool.
    max_in_flight : int, optional
        Samples submitted but not finished at any time (default: twice the executor's workers).
    redo_failed : bool
        Run journalled samples with ``ok=False`` again.
    progress : callable, optional
        Called as ``progress(n_done, n_total, result)`` in the caller's process after every
        sample (journalled ones are not reported).

    Returns
    -------
    list of TaskResult
        ``len(params_list)`` results; ``result[i].index == i``.

    Raises
    ------
    ExecutorBrokenError
        A caller-supplied process pool broke (it cannot be rebuilt here). Finished samples are
        journalled, so a resume continues.

    Notes
    -----
    Worker deaths: ``BrokenProcessPool`` (a pool worker died: every sample in flight fails),
    distributed's ``KilledWorker`` and ``CancelledError``. When a process pool breaks with
    several samples in flight the culprit is unknown, so the samples in flight are re-run one at
    a time ("isolation"); only a death while a sample runs alone counts against its
    ``retries``. A sample whose task raises is recorded as failed at once (a deterministic task
    raises again). Ctrl-C cancels what is in flight and re-raises; the journal keeps the rest.
    """
    n = len(params_list)
    if retries < 0:
        raise ValueError(f"run_sweep: expected retries >= 0, found {retries}")
    results: dict[int, TaskResult] = {}
    if journal is not None:
        for i, r in journal.finished.items():
            if 0 <= i < n and (r.ok or not redo_failed):
                results[i] = r
    pending: deque[int] = deque(i for i in range(n) if i not in results)
    own = executor is None
    ex: cf.Executor = default_executor(max_workers) if executor is None else executor
    cap = max_in_flight if max_in_flight is not None else 2 * _executor_width(ex)
    if cap < 1:
        raise ValueError(f"run_sweep: expected max_in_flight >= 1, found {max_in_flight}")
    started: Counter[int] = Counter()
    deaths: Counter[int] = Counter()  # deaths while running alone
    isolate: deque[int] = deque()
    in_flight: dict[cf.Future[Any], int] = {}
    n_done = len(results)

    def finish(result: TaskResult) -> None:
        nonlocal n_done
        results[result.index] = result
        if journal is not None:
            journal.append(result)
        n_done += 1
        if progress is not None:
            progress(n_done, n, result)

    def submit(i: int) -> bool:
        started[i] += 1
        try:
            in_flight[ex.submit(task, params_list[i])] = i
        except BrokenProcessPool:
            started[i] -= 1
            isolate.appendleft(i)
            return False
        return True

    def rebuild(reason: str) -> None:
        nonlocal ex
        if not own:
            raise ExecutorBrokenError(
                f"the executor broke ({reason}); {n_done} of {n} samples are finished"
                + (" and journalled; resume to continue" if journal is not None else ""), n_done)
        ex.shutdown(wait=False, cancel_futures=True)
        ex = default_executor(max_workers)

    try:
        while pending or isolate or in_flight:
            broken = False
            if isolate:
                if not in_flight:
                    broken = not submit(isolate.popleft())
            else:
                while pending and len(in_flight) < cap:
                    if not submit(pending.popleft()):
                        broken = True
                        break
            if broken and not in_flight:
                rebuild("the process pool was already broken")
                continue
            done, _ = cf.wait(in_flight, return_when=cf.FIRST_COMPLETED)
            alone = len(in_flight) == 1
            pool_broke = False
            if any(isinstance(f.exception(), BrokenProcessPool) for f in done if not f.cancelled()):
                # every other sample in flight fails the same way: collect them all now
                done, _ = cf.wait(in_flight, return_when=cf.ALL_COMPLETED)
                pool_broke = True
            for fut in sorted(done, key=lambda f: in_flight[f]):
                i = in_flight.pop(fut)
                try:
                    value = fut.result()
                except BaseException as exc:
                    if isinstance(exc, KeyboardInterrupt):
                        raise
                    if not _is_worker_death(exc):
                        finish(TaskResult(i, False, None, f"the task raised {_describe(exc)}",
                                          started[i], f"raised:{type(exc).__name__}"))
                        continue
                    if pool_broke and not alone:
                        isolate.append(i)  # culprit unknown: run it again on its own
                        continue
                    deaths[i] += 1
                    if deaths[i] > retries:
                        times = f"{deaths[i]} time{'s' if deaths[i] != 1 else ''}"
                        finish(TaskResult(
                            i, False, None, f"worker died {times} running this sample "
                            f"({type(exc).__name__}: {exc})", started[i], "worker_died"))
                    elif pool_broke:
                        isolate.appendleft(i)
                    else:
                        pending.appendleft(i)
                    continue
                try:
                    normalised = json.loads(canonical_json(value))
                except (TypeError, ValueError) as exc:
                    finish(TaskResult(i, False, None,
                                      f"the task returned a value that is not JSON-safe ({exc})",
                                      started[i], "not_json_safe"))
                    continue
                finish(TaskResult(i, True, normalised, None, started[i]))
            if pool_broke:
                rebuild("a worker process died")
    except BaseException:
        for fut in in_flight:
            fut.cancel()
        if own:
            ex.shutdown(wait=False, cancel_futures=True)
        raise
    if own:
        ex.shutdown(wait=True)
    return [results[i] for i in range(n)]


# ---------------------------------------------------------------------------------------------
# Dask


@dataclass
class DaskConnection:
    """A connected ``dask.distributed.Client`` and its ``concurrent.futures`` executor.

    Created by :func:`connect_dask`; close it (or use ``with``) to disconnect. Closing does not
    stop the cluster.
    """

    client: Any
    executor: cf.Executor

    def close(self) -> None:
        self.client.close()

    def __enter__(self) -> DaskConnection:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def connect_dask(address: str, timeout_s: float = 10.0) -> DaskConnection:
    """Connect to a running Dask scheduler (``tcp://HOST:PORT``).

    The executor submits with ``pure=False``: Dask does not merge or cache tasks by argument
    hash, so a resubmitted sample really runs again. The workers must be able to import
    ``asmplan`` and the task's module (same environment on every machine).

    Raises
    ------
    DaskUnavailableError
        When ``dask.distributed`` is not installed.
    OSError
        When no scheduler answers within ``timeout_s``.
    """
    try:
        from dask.distributed import Client
    except ImportError as exc:
        raise DaskUnavailableError(
            "running a sweep on a Dask cluster needs the optional extra: "
            "pip install 'asmplan[dask]'") from exc
    client = Client(address, timeout=timeout_s, set_as_default=False)
    return DaskConnection(client=client, executor=client.get_executor(pure=False))


