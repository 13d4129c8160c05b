"""A sweep through a real Dask cluster: one scheduler and two single-thread workers on 127.0.0.1.

The cluster is started as subprocesses (``python -m dask scheduler`` / ``worker``), as a user
would start one, on a free port without dashboards, and torn down in the fixture's finalizer.
The workers import the task functions from ``test_sweep`` by name, so this folder is put on
their PYTHONPATH. Dask is a dev dependency: a missing Dask fails here rather than skipping.
"""

from __future__ import annotations

import functools
import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from test_sweep import (
    PIN_CLEARANCE,
    STEP,
    chamfer_insertion,
    chamfer_insertion_expected,
    chamfer_samples,
    die_once,
    pybullet_pin_insertion,
)

from asmplan.sim import sweep as sw

pytestmark = [pytest.mark.dask, pytest.mark.slow]

HERE = Path(__file__).resolve().parent
START_TIMEOUT_S = 60.0


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10)


@pytest.fixture(scope="module")
def dask_address(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """``tcp://127.0.0.1:PORT`` of a scheduler with two workers (--nthreads 1 each)."""
    from dask.distributed import Client

    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    logs = tmp_path_factory.mktemp("dask-logs")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(HERE), str(HERE.parents[1]), *filter(None, [env.get("PYTHONPATH")])])
    procs: list[subprocess.Popen[bytes]] = []

    def start(name: str, *args: str) -> None:
        log = open(logs / f"{name}.log", "wb")  # noqa: SIM115 - closed with the process
        procs.append(subprocess.Popen([sys.executable, "-m", "dask", *args], env=env,
                                      stdout=log, stderr=subprocess.STDOUT, cwd=logs))
        log.close()

    try:
        start("scheduler", "scheduler", "--host", "127.0.0.1", "--port", str(port),
              "--no-dashboard")
        for w in range(2):
            start(f"worker{w}", "worker", address, "--nthreads", "1", "--no-dashboard",
                  "--host", "127.0.0.1", "--name", f"w{w}", "--death-timeout", "60")
        deadline = time.monotonic() + START_TIMEOUT_S
        while True:
            try:
                with Client(address, timeout=5, set_as_default=False) as client:
                    client.wait_for_workers(2, timeout=max(1.0, deadline - time.monotonic()))
                    break
            except (OSError, TimeoutError) as exc:
                dead = [p.args for p in procs if p.poll() is not None]
                if dead or time.monotonic() > deadline:
                    logs_text = "\n".join(f"--- {f.name}\n{f.read_text()[-2000:]}"
                                          for f in sorted(logs.iterdir()))
                    pytest.fail(f"Dask cluster did not start within {START_TIMEOUT_S} s "
                                f"({exc}); exited: {dead}\n{logs_text}")
                time.sleep(0.2)
        yield address
    finally:
        for p in reversed(procs):  # workers first, then the scheduler
            _stop(p)


def test_sweep_on_dask_gives_the_local_numbers(dask_address: str) -> None:
    spec, samples = chamfer_samples(60)
    local = sw.run_sweep(chamfer_insertion, samples, max_workers=2)
    with sw.connect_dask(dask_address) as conn:
        assert len(conn.client.scheduler_info()["workers"]) == 2
        remote = sw.run_sweep(chamfer_insertion, samples, executor=conn.executor)
        ran_on = conn.client.run(os.getpid)
    assert len(set(ran_on.values())) == 2 and os.getpid() not in ran_on.values()
    assert all(r.ok for r in remote)
    assert remote == local  # values, order and attempts
    assert [r.value["steps"][STEP]["success"] for r in remote] == [
        chamfer_insertion_expected(s) for s in samples]
    a = sw.summarize(samples, local, spec.vary).to_dict()
    b = sw.summarize(samples, remote, spec.vary).to_dict()
    assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


def test_a_pybullet_sweep_gives_bit_identical_outcomes_on_dask_and_locally(dask_address: str) -> None:
    spec = sw.SweepSpec(n_samples=4, seed=3, vary=("clearance", "pose"),
                        pose_distribution="uniform", pose_lateral_m=2.5e-3, pose_angular_rad=0.0)
    samples = sw.draw_samples(spec, [PIN_CLEARANCE], {}, [STEP])
    task = functools.partial(pybullet_pin_insertion, "fast")
    local = sw.run_sweep(task, samples, max_workers=2)
    with sw.connect_dask(dask_address) as conn:
        remote = sw.run_sweep(task, samples, executor=conn.executor)
    assert all(r.ok for r in local), [r.error for r in local]
    assert remote == local  # every float of every outcome
    ok = {s.pose_error(STEP).lateral_norm_m: r.value["steps"][STEP]["success"]
          for s, r in zip(samples, local, strict=True)}
    # inside the radial clearance the pin goes straight in; far outside it the pin lands on
    # the block's top face and the grip gives way (no chamfer in this scene)
    assert all(v for e, v in ok.items() if e < 0.5 * PIN_CLEARANCE.min_m)
    assert not any(v for e, v in ok.items() if e > 2.0e-3)
    assert min(ok) < 0.5 * PIN_CLEARANCE.min_m and max(ok) > 2.0e-3


def test_a_dask_worker_that_dies_is_replaced_and_the_sample_rerun(
        dask_address: str, tmp_path: Path) -> None:
    task = functools.partial(die_once, str(tmp_path))
    with sw.connect_dask(dask_address) as conn:
        results = sw.run_sweep(task, list(range(6)), executor=conn.executor)
        # the nanny restarts the dead worker: the cluster is whole again for the next test
        conn.client.wait_for_workers(2, timeout=30)
    assert (tmp_path / "died-2").exists()
    assert [r.value for r in results] == [10 * i for i in range(6)]


def test_an_unreachable_scheduler_is_an_os_error() -> None:
    with pytest.raises(OSError, match="Timed out"):
        sw.connect_dask(f"tcp://127.0.0.1:{_free_port()}", timeout_s=0.5)
