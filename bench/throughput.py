"""Sweep throughput: simulations per second through local process pools and a Dask cluster
(``asmplan bench``'s sweep section).
"""

from __future__ import annotations

import concurrent.futures as cf
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from asmplan.sim.sweep import SweepError, default_executor, run_sweep

try:  # POSIX advisory locks keep two sweeps from appending to one journal
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]


# ---------------------------------------------------------------------------------------------
# throughput


@dataclass(frozen=True)
class Throughput:
    """Simulations per second through one executor.

    ``startup_s`` is the time to create the executor and run one warm-up task per worker;
    ``wall_s`` is the median over ``repeats`` timed runs after that, and ``per_second`` is
    ``n_tasks / wall_s``.
    """

    label: str
    workers: int
    n_tasks: int
    startup_s: float
    wall_s: float
    per_second: float
    repeats: int = 1


def _warm_up(executor: cf.Executor, workers: int) -> None:
    list(executor.map(_noop, range(workers)))


def _noop(x: int) -> int:
    return x


def measure_throughput(
    label: str,
    task: Callable[[Any], Any],
    params_list: Sequence[Any],
    make_executor: Callable[[], tuple[cf.Executor, Callable[[], None]]],
    workers: int,
    repeats: int = 1,
) -> Throughput:
    """Time :func:`run_sweep` of ``task`` over ``params_list`` on a freshly made executor.

    ``make_executor()`` returns ``(executor, close)``; ``close`` is called at the end.
    """
    t0 = time.perf_counter()
    ex, close = make_executor()
    walls = []
    try:
        _warm_up(ex, workers)
        startup = time.perf_counter() - t0
        for _ in range(repeats):
            t1 = time.perf_counter()
            results = run_sweep(task, params_list, executor=ex, retries=0)
            walls.append(time.perf_counter() - t1)
            bad = [r for r in results if not r.ok]
            if bad:
                raise SweepError(
                    f"throughput run {label}: {len(bad)} tasks failed, first: {bad[0].error}")
    finally:
        close()
    wall = float(np.median(walls))
    return Throughput(label, workers, len(params_list), startup, wall, len(params_list) / wall,
                      repeats)


def throughput(
    task: Callable[[Any], Any],
    params_list: Sequence[Any],
    local_workers: Sequence[int] = (1, 2),
    dask_workers: int | None = 2,
    repeats: int = 1,
) -> list[Throughput]:
    """Simulations per second with local process pools and a local Dask cluster.

    Parameters
    ----------
    task, params_list
        As for :func:`run_sweep`; the same work is timed on each executor.
    local_workers : sequence of int
        Pool sizes to time with :func:`default_executor`.
    dask_workers : int or None
        Workers (one thread each, separate processes) of a ``distributed.LocalCluster`` to
        time; None skips Dask (so does a missing Dask installation).
    repeats : int
        Timed runs per executor (the median is reported).

    Returns
    -------
    list of Throughput
    """
    out = []
    for w in local_workers:
        def make(w: int = w) -> tuple[cf.Executor, Callable[[], None]]:
            ex = default_executor(w)
            return ex, lambda: ex.shutdown(wait=True)

        out.append(measure_throughput(f"local pool, {w} worker{'s' if w != 1 else ''}",
                                      task, params_list, make, w, repeats))
    if dask_workers:
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError:
            return out

        def make_dask() -> tuple[cf.Executor, Callable[[], None]]:
            cluster = LocalCluster(n_workers=dask_workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, host="127.0.0.1")
            client = Client(cluster, set_as_default=False)

            def close() -> None:
                client.close()
                cluster.close()

            return client.get_executor(pure=False), close

        out.append(measure_throughput(f"Dask LocalCluster, {dask_workers} workers",
                                      task, params_list, make_dask, dask_workers, repeats))
    return out


def calibration_task(index: int, n_rounds: int = 100) -> dict[str, float]:
    """Fixed, deterministic CPU work standing in for one simulation (~0.2 s on a 2-core box).

    Single-threaded element-wise numpy (no BLAS, so no hidden threads) working in place: no
    large allocations, whose cost differs between executors (Dask's nanny sets
    ``MALLOC_TRIM_THRESHOLD_``, which makes every 800 kB temporary an mmap/munmap pair and the
    same work ~1.7x slower). What it measures is the executors' overhead and scaling, not a
    physics figure.
    """
    x = np.linspace(0.0, 1.0, 100_000) + 1e-6 * index
    y = np.empty_like(x)
    for _ in range(n_rounds):  # x <- sin(3.1 x) + 0.5 x
        np.multiply(x, 3.1, out=y)
        np.sin(y, out=y)
        x *= 0.5
        x += y
    return {"checksum": float(x.sum())}


def format_throughput(rows: Sequence[Throughput]) -> str:
    """A Markdown table of :func:`throughput` rows."""
    lines = ["| executor | workers | tasks | start-up (s) | median wall (s) | repeats | tasks/s |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    lines += [f"| {r.label} | {r.workers} | {r.n_tasks} | {r.startup_s:.2f} | {r.wall_s:.2f} | "
              f"{r.repeats} | {r.per_second:.2f} |" for r in rows]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m bench.throughput``: time :func:`calibration_task` on each executor."""
    import argparse
    import functools
    import sys

    parser = argparse.ArgumentParser(prog="python -m bench.throughput",
                                     description="Sweep throughput with local pools and Dask.")
    parser.add_argument("--tasks", type=int, default=100, help="tasks per executor")
    parser.add_argument("--rounds", type=int, default=100, help="work per task (calibration)")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--dask-workers", type=int, default=2, help="0 skips Dask")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per executor")
    args = parser.parse_args(argv)
    task = functools.partial(calibration_task, n_rounds=args.rounds)
    rows = throughput(task, list(range(args.tasks)), args.workers, args.dask_workers or None,
                      args.repeats)
    sys.stdout.write(format_throughput(rows))
    return 0



if __name__ == "__main__":
    raise SystemExit(main())
