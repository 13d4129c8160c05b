"""The sweep machinery: sampling, execution with retries, journal/resume, statistics.

The tasks here are cheap but real: a seeded numpy computation, and a quasi-static, time-stepped
model of a chamfered pin entering a hole under a compliant robot, whose success region is known
in closed form (``chamfer_insertion_expected``). The PyBullet step sweep is tested where the
simulator's step API lives. The module-level task functions are also imported by the Dask test
(its workers import this module by name), so they must stay at module level.
"""

from __future__ import annotations

import functools
import json
import math
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from asmplan.sim import sweep as sw

# --- the chamfer model ------------------------------------------------------------------------
MATE = "pin_in_hole"
STEP = "insert"
CHAMFER_M = 0.5e-3  # radial width of the 45-degree chamfer at the hole mouth
CLEARANCE = sw.ClearanceRange(MATE, 0.05e-3, 0.4e-3)  # declared diametral clearance range
FRICTION = {"pin": 0.3, "block": 0.3}
K_LATERAL_N_M = 1.0e4  # lateral stiffness of the robot holding the pin
F_MAX_N = 20.0  # insertion force limit
DEPTH_M = 5e-3
DZ_M = 2e-6  # descent per tick


def chamfer_insertion(params: sw.SampleParams) -> dict:
    """Descend a pin at lateral error e onto a hole with a 45-degree chamfer.

    ``u`` is how far the pin's leading edge overhangs the bore wall (e - c/2). The edge lands
    on the flat top face (u >= chamfer: jam), on the chamfer (slides inward while the robot's
    lateral spring pushes back; the force needed downward is k d (1 + mu) / (1 - mu) for a
    lateral deflection d), or straight in the bore (u < 0). In the bore a deflected pin drags
    along the wall with friction mu k d.
    """
    c = params.clearance_m[MATE]
    mu = params.friction["pin"] * params.friction["block"] / 0.3  # product, normalised to 0.3 nominal
    e = params.pose_error(STEP).lateral_norm_m
    u_cmd = e - 0.5 * c
    z = 1e-4  # the pin tip starts above the top face (z = 0), bore bottom at -DEPTH_M
    u = u_cmd
    peak = 0.0
    reasons: list[str] = []
    codes: list[tuple[str, float, float]] = []  # failed criterion, value, limit (SI)
    while z > -DEPTH_M:
        z_cmd = z - DZ_M
        if u >= CHAMFER_M and z_cmd < 0.0:
            reasons.append(f"pin landed on the top face: overhang {u * 1e3:.3f} mm >= chamfer "
                           f"{CHAMFER_M * 1e3:.3f} mm")
            codes.append(("insertion_depth", DEPTH_M + min(z, 0.0), 0.0))
            break
        if 0.0 <= u < CHAMFER_M and z_cmd < u - CHAMFER_M:
            u = max(z_cmd + CHAMFER_M, 0.0)  # slide down the chamfer
            if mu >= 1.0:
                reasons.append(f"friction {mu:.2f} >= 1 locks the 45-degree chamfer")
                codes.append(("chamfer_lock", mu, 1.0))
                break
            force = K_LATERAL_N_M * (u_cmd - u) * (1.0 + mu) / (1.0 - mu)
            peak = max(peak, force)
            if force > F_MAX_N:
                reasons.append(f"wedged on the chamfer: {force:.2f} N > {F_MAX_N:.2f} N")
                codes.append(("insertion_force", force, F_MAX_N))
                break
            if u == 0.0:
                u = -1e-12  # past the chamfer: in the bore
        elif u < 0.0 and u_cmd > 0.0:
            force = mu * K_LATERAL_N_M * u_cmd
            peak = max(peak, force)
            if force > F_MAX_N:
                reasons.append(f"stuck on the bore wall: {force:.2f} N > {F_MAX_N:.2f} N")
                codes.append(("insertion_force", force, F_MAX_N))
                break
        z = z_cmd
    success = not reasons
    failures = {code: {"value": value, "limit": limit} for code, value, limit in codes}
    return {"steps": {STEP: {"success": success, "reasons": reasons, "failures": failures}},
            "depth_m": -min(z, 0.0), "peak_force_N": peak}


def chamfer_insertion_expected(params: sw.SampleParams) -> bool:
    """Closed form of :func:`chamfer_insertion`'s verdict."""
    c = params.clearance_m[MATE]
    mu = params.friction["pin"] * params.friction["block"] / 0.3
    u = params.pose_error(STEP).lateral_norm_m - 0.5 * c
    if u < 0:
        return True
    if u >= CHAMFER_M or mu >= 1:
        return False
    return K_LATERAL_N_M * u * (1 + mu) / (1 - mu) <= F_MAX_N and mu * K_LATERAL_N_M * u <= F_MAX_N


def chamfer_samples(n: int, seed: int = 7, **spec_kw: object) -> tuple[sw.SweepSpec, list[sw.SampleParams]]:
    kw: dict = {"clearance_distribution": "uniform", "pose_distribution": "uniform", "pose_lateral_m": 1.0e-3, "pose_angular_rad": 0.0}
    kw.update(spec_kw)
    spec = sw.SweepSpec(n_samples=n, seed=seed, **kw)
    return spec, sw.draw_samples(spec, [CLEARANCE], FRICTION, [STEP])


# --- other module-level tasks (picklable) ------------------------------------------------------
def numpy_task(params: sw.SampleParams) -> dict:
    """Eigenvalues of a seeded random symmetric matrix; success when the spectrum is narrow."""
    rng = sw.factor_rng(params.seed, params.index, "work")
    a = rng.normal(size=(40, 40))
    w = np.linalg.eigvalsh(a + a.T)
    spread = float(w[-1] - w[0])
    return {"steps": {"work": {"success": spread < 35.0,
                               "reasons": [] if spread < 35.0 else [f"spread {spread:.3f} >= 35"]}},
            "eig": [float(v) for v in w[:3]]}


def slow_in_reverse(i: int) -> int:
    time.sleep(0.02 * (5 - i))
    return i * i


def raise_on_three(i: int) -> int:
    if i == 3:
        raise ValueError("three is not allowed")
    return i


def die_once(marker_dir: str, i: int) -> int:
    """Kill the worker process the first time sample 2 runs."""
    marker = Path(marker_dir) / f"died-{i}"
    if i == 2 and not marker.exists():
        marker.write_text("x")
        os._exit(13)
    return 10 * i


def die_always(i: int) -> int:
    if i == 2:
        os._exit(13)
    time.sleep(0.05)
    return 10 * i


PIN_CLEARANCE = sw.ClearanceRange(MATE, 0.8e-3, 1.0e-3)  # diametral; FAST resolves >= 0.4 mm


def pybullet_pin_insertion(fidelity_name: str, params: sw.SampleParams) -> dict:
    """A real PyBullet pick-and-insert (bench.scenarios.pin_insertion, no chamfer) per sample.

    The diametral clearance is the sample's; its lateral pose error magnitude becomes an
    offset of the place pose along x. The wall time is left out (not a physics result).
    """
    from asmplan.sim.fidelity import preset
    from bench.scenarios import pin_insertion

    _, outcome = pin_insertion(preset(fidelity_name), 0.5 * params.clearance_m[MATE],
                               lateral_offset_m=params.pose_error(STEP).lateral_norm_m)
    d = outcome.to_dict()
    del d["wall_time_s"]
    return {"steps": {STEP: {"success": outcome.success, "reasons": list(outcome.reasons)}},
            "outcome": d}


PARENT_STATE = {"value": "import-time"}


def read_parent_state(_: int) -> str:
    return PARENT_STATE["value"]


# --- sampling ---------------------------------------------------------------------------------
def test_spec_validation_says_expected_and_found() -> None:
    with pytest.raises(ValueError, match=r"n_samples: expected an integer >= 1, found 0"):
        sw.SweepSpec(n_samples=0)
    with pytest.raises(ValueError, match=r"vary: expected factors among .*found \['temperature'\]"):
        sw.SweepSpec(n_samples=3, vary=("pose", "temperature"))
    with pytest.raises(ValueError, match=r"friction_rel_sigma: expected a value in \[0, 1/3\), found 0.5"):
        sw.SweepSpec(n_samples=3, friction_rel_sigma=0.5)
    with pytest.raises(ValueError, match="pose_distribution"):
        sw.SweepSpec(n_samples=3, pose_distribution="cauchy")  # type: ignore[arg-type]
    # order and duplicates of `vary` do not matter
    assert sw.SweepSpec(3, vary=("pose", "clearance", "pose")).vary == ("clearance", "pose")
    spec = sw.SweepSpec(5, seed=3, vary=("pose",))
    assert sw.SweepSpec.from_dict(json.loads(json.dumps(spec.to_dict()))) == spec


def test_sample_depends_only_on_seed_index_and_factor() -> None:
    steps = ["a", "b"]
    big = sw.SweepSpec(n_samples=50, seed=11)
    small = sw.SweepSpec(n_samples=3, seed=11, vary=("pose",))
    ref = sw.draw_samples(big, [CLEARANCE], FRICTION, steps)
    # the same sample drawn alone, out of order, in a smaller sweep: identical
    for i in (37, 2, 49, 0):
        assert sw.draw_sample(big, i, [CLEARANCE], FRICTION, steps) == ref[i]
    # pose values do not change when clearance and friction stop varying
    for i in range(3):
        s = sw.draw_sample(small, i, [CLEARANCE], FRICTION, steps)
        assert s.pose == ref[i].pose
        assert MATE not in s.clearance_m  # not varied: the mate keeps its declared fit
        assert s.friction == FRICTION
    # steps get independent errors; another seed gives other values
    assert ref[0].pose["a"] != ref[0].pose["b"]
    other = sw.draw_sample(sw.SweepSpec(50, seed=12), 0, [CLEARANCE], FRICTION, steps)
    assert other.clearance_m != ref[0].clearance_m
    assert sw.SampleParams.from_dict(json.loads(json.dumps(ref[4].to_dict()))) == ref[4]


def test_sample_distributions_match_their_definition() -> None:
    n = 4000
    lo, hi = CLEARANCE.min_m, CLEARANCE.max_m
    mid, rng_w = 0.5 * (lo + hi), hi - lo
    # sd of a standard normal truncated to +-3: sqrt(1 - 2*3*phi(3)/(2*Phi(3) - 1))
    phi3 = math.exp(-4.5) / math.sqrt(2 * math.pi)
    trunc_sd = math.sqrt(1 - 6 * phi3 / math.erf(3 / math.sqrt(2)))

    def draws(**kw: object) -> list[sw.SampleParams]:
        spec = sw.SweepSpec(n_samples=n, seed=5, **kw)
        return sw.draw_samples(spec, [CLEARANCE], FRICTION, [STEP])

    uni = np.array([s.clearance_m[MATE] for s in draws(clearance_distribution="uniform")])
    assert lo <= uni.min() and uni.max() <= hi
    assert uni.mean() == pytest.approx(mid, abs=4 * rng_w / math.sqrt(12 * n))
    assert uni.std() == pytest.approx(rng_w / math.sqrt(12), rel=0.05)

    tn_samples = draws(clearance_distribution="truncnormal", friction_rel_sigma=0.1,
                       pose_lateral_m=0.3e-3, pose_angular_rad=0.01)
    tn = np.array([s.clearance_m[MATE] for s in tn_samples])
    assert lo <= tn.min() and tn.max() <= hi
    assert tn.std() == pytest.approx(rng_w / 6 * trunc_sd, rel=0.05)
    mu = np.array([s.friction["pin"] for s in tn_samples])
    assert mu.mean() == pytest.approx(0.3, abs=4 * 0.03 / math.sqrt(n))
    assert mu.std() == pytest.approx(0.03 * trunc_sd, rel=0.05)
    assert mu.min() >= 0.3 * 0.7 - 1e-12 and mu.max() <= 0.3 * 1.3 + 1e-12
    lat = np.array([s.pose_error(STEP).lateral_m for s in tn_samples])
    assert lat.std(axis=0) == pytest.approx([0.3e-3, 0.3e-3], rel=0.05)
    assert np.abs(lat.mean(axis=0)).max() < 4 * 0.3e-3 / math.sqrt(n)

    unif_pose = draws(pose_distribution="uniform", pose_lateral_m=1e-3)
    mag = np.array([s.pose_error(STEP).lateral_norm_m for s in unif_pose])
    assert mag.max() <= 1e-3
    assert mag.mean() == pytest.approx(0.5e-3, abs=4 * 1e-3 / math.sqrt(12 * n))


# --- execution --------------------------------------------------------------------------------
def test_process_pool_gives_the_serial_results_in_index_order() -> None:
    _, samples = chamfer_samples(24)
    serial = [json.loads(json.dumps(numpy_task(s))) for s in samples]
    results = sw.run_sweep(numpy_task, samples, max_workers=2)
    assert [r.index for r in results] == list(range(24))
    assert all(r.ok and r.attempts == 1 for r in results)
    assert [r.value for r in results] == serial
    # completion order differs from index order; the output is still by index
    out = sw.run_sweep(slow_in_reverse, list(range(6)), executor=ThreadPoolExecutor(6))
    assert [r.value for r in out] == [i * i for i in range(6)]


def test_default_workers_are_not_forked_from_the_caller() -> None:
    PARENT_STATE["value"] = "changed in the parent after import"
    try:
        results = sw.run_sweep(read_parent_state, [0, 1], max_workers=1)
    finally:
        PARENT_STATE["value"] = "import-time"
    # a forked worker would see the parent's changed dict; a forkserver/spawned one re-imports
    assert [r.value for r in results] == ["import-time", "import-time"]


def test_a_task_that_raises_is_a_failed_result_not_a_crash() -> None:
    results = sw.run_sweep(raise_on_three, list(range(6)), max_workers=2)
    assert [r.ok for r in results] == [True, True, True, False, True, True]
    assert results[3].error is not None
    assert "ValueError: three is not allowed (at test_sweep.py:" in results[3].error
    assert results[3].attempts == 1  # not retried: a deterministic task raises again
    bad = sw.run_sweep(float, [float("nan")], executor=ThreadPoolExecutor(1))
    assert not bad[0].ok and "not JSON-safe" in (bad[0].error or "")


@pytest.mark.slow
def test_a_worker_that_dies_is_retried(tmp_path: Path) -> None:
    task = functools.partial(die_once, str(tmp_path))
    results = sw.run_sweep(task, list(range(8)), max_workers=2)
    assert [r.value for r in results] == [10 * i for i in range(8)]
    assert results[2].attempts == 2
    assert (tmp_path / "died-2").exists()


@pytest.mark.slow
def test_a_sample_that_keeps_killing_its_worker_is_recorded_after_retries() -> None:
    results = sw.run_sweep(die_always, list(range(6)), max_workers=2, retries=1)
    assert results[2].ok is False
    assert results[2].error is not None and "worker died 2 times" in results[2].error
    others = [r for r in results if r.index != 2]
    assert [r.value for r in others] == [0, 10, 30, 40, 50]
    # innocent samples caught in the crash are re-run once on their own, never charged twice
    assert max(r.attempts for r in others) <= 2
    # even without retries only the culprit fails: a death counts only when a sample ran alone
    strict = sw.run_sweep(die_always, list(range(6)), max_workers=2, retries=0)
    assert [r.ok for r in strict] == [True, True, False, True, True, True]
    assert strict[2].error is not None and "worker died 1 time running" in strict[2].error


@pytest.mark.slow
def test_a_callers_broken_pool_stops_the_sweep_with_the_finished_samples_journalled(tmp_path: Path) -> None:
    spec = sw.SweepSpec(n_samples=6)
    ex = sw.default_executor(1)
    seen: list[int] = []
    with sw.SweepJournal(tmp_path / sw.JOURNAL_NAME, sw.journal_header(spec, "die")) as j:
        with pytest.raises(sw.ExecutorBrokenError, match=r"the executor broke .*journalled; resume"):
            sw.run_sweep(die_always, list(range(6)), executor=ex, journal=j, max_in_flight=1,
                         progress=lambda done, total, r: seen.append(r.index))
        assert sorted(j.finished) == [0, 1] == seen
    ex.shutdown()


# --- journal and resume -----------------------------------------------------------------------
class CountingTask:
    """In-process task (threads) that records which samples ran."""

    def __init__(self) -> None:
        self.calls: list[int] = []
        self.lock = threading.Lock()

    def __call__(self, params: sw.SampleParams) -> dict:
        with self.lock:
            self.calls.append(params.index)
        return chamfer_insertion(params)


def test_resume_skips_finished_samples_and_survives_a_torn_last_line(tmp_path: Path) -> None:
    spec, samples = chamfer_samples(10)
    header = sw.journal_header(spec, sw.sha256_hex("chamfer model v1"))
    path = tmp_path / sw.JOURNAL_NAME
    with sw.SweepJournal(path, header) as j:
        full = sw.run_sweep(chamfer_insertion, samples, executor=ThreadPoolExecutor(2), journal=j)
    lines = path.read_bytes().split(b"\n")
    assert len(lines) == 12 and lines[-1] == b""  # header + 10 records, newline-terminated
    # a crash after 4 records, in the middle of writing the 5th
    path.write_bytes(b"\n".join(lines[:5]) + b"\n" + lines[5][: len(lines[5]) // 2])
    task = CountingTask()
    with sw.SweepJournal(path, header) as j:
        assert sorted(j.finished) == sorted(json.loads(x)["index"] for x in lines[1:5])
        assert j.truncated_bytes == len(lines[5]) // 2
        finished_before = set(j.finished)
        resumed = sw.run_sweep(task, samples, executor=ThreadPoolExecutor(2), journal=j)
    assert sorted(task.calls) == sorted(set(range(10)) - finished_before)
    assert len(task.calls) == 6
    assert resumed == full
    # the journal is whole again: every line parses, every sample once
    records = [json.loads(x) for x in path.read_bytes().split(b"\n")[1:-1]]
    assert sorted(r["index"] for r in records) == list(range(10))
    # nothing left to do: a second resume runs nothing
    again = CountingTask()
    with sw.SweepJournal(path, header) as j:
        assert sw.run_sweep(again, samples, executor=ThreadPoolExecutor(2), journal=j) == full
    assert again.calls == []


def test_resume_with_more_samples_runs_only_the_new_ones(tmp_path: Path) -> None:
    spec, samples = chamfer_samples(6)
    spec12, samples12 = chamfer_samples(12)
    path = tmp_path / sw.JOURNAL_NAME
    fp = sw.sha256_hex("model")
    with sw.SweepJournal(path, sw.journal_header(spec, fp)) as j:
        sw.run_sweep(chamfer_insertion, samples, executor=ThreadPoolExecutor(2), journal=j)
    task = CountingTask()
    with sw.SweepJournal(path, sw.journal_header(spec12, fp)) as j:
        out = sw.run_sweep(task, samples12, executor=ThreadPoolExecutor(2), journal=j)
    assert sorted(task.calls) == list(range(6, 12))
    assert [r.value for r in out] == [json.loads(json.dumps(chamfer_insertion(s))) for s in samples12]


def test_resume_with_a_different_sweep_is_refused(tmp_path: Path) -> None:
    spec, _ = chamfer_samples(4)
    path = tmp_path / sw.JOURNAL_NAME
    sw.SweepJournal(path, sw.journal_header(spec, "abc")).close()
    other, _ = chamfer_samples(4, seed=8)
    with pytest.raises(sw.JournalMismatchError, match=r"spec.seed: journal has 7, this run has 8"):
        sw.SweepJournal(path, sw.journal_header(other, "abc"))
    with pytest.raises(sw.JournalMismatchError, match=r"fingerprint: journal has 'abc', this run has 'abd'"):
        sw.SweepJournal(path, sw.journal_header(spec, "abd"))


def test_journal_corruption_before_the_last_line_and_a_second_writer_are_errors(tmp_path: Path) -> None:
    spec, samples = chamfer_samples(3)
    header = sw.journal_header(spec, "fp")
    path = tmp_path / sw.JOURNAL_NAME
    with sw.SweepJournal(path, header) as j:
        sw.run_sweep(chamfer_insertion, samples, executor=ThreadPoolExecutor(1), journal=j)
        with pytest.raises(sw.JournalLockedError, match="another process is writing"):
            sw.SweepJournal(path, header)
    lines = path.read_bytes().split(b"\n")
    lines[2] = b'{"index": 1, "ok": tru'
    path.write_bytes(b"\n".join(lines))
    with pytest.raises(sw.JournalCorruptError, match=r"sweep-journal.jsonl:3: not a sample record"):
        sw.SweepJournal(path, header)


# --- statistics -------------------------------------------------------------------------------
@pytest.mark.parametrize(("k", "n", "low", "high"), [
    # Newcombe (1998), Statistics in Medicine 17:857, Table I, method 3 (Wilson score)
    (81, 263, 0.2553, 0.3662),
    (15, 148, 0.0624, 0.1605),
    (0, 20, 0.0000, 0.1611),
    (1, 29, 0.0061, 0.1718),
])
def test_wilson_interval_matches_published_values(k: int, n: int, low: float, high: float) -> None:
    lo, hi = sw.wilson_interval(k, n)
    assert lo == pytest.approx(low, abs=1e-4)
    assert hi == pytest.approx(high, abs=1e-4)


def test_factor_effect_finds_a_step_in_success() -> None:
    rng = np.random.default_rng(0)
    x = rng.uniform(0.0, 1.0, 400)
    noise = rng.uniform(0.0, 1.0, 400)
    ok = x < 0.6
    eff = sw.factor_effect("x", x, ok, n_bins=10)
    assert eff.correlation < -0.7 and eff.p_value < 1e-10
    assert eff.x50 == pytest.approx(0.6, abs=0.02)
    assert [b.rate for b in eff.bins[:6]] == [1.0] * 6 and [b.rate for b in eff.bins[6:]] == [0.0] * 4
    flat = sw.factor_effect("noise", noise, ok)
    assert abs(flat.correlation) < 0.15  # 4/sqrt(400) would be 0.2
    assert math.isnan(sw.factor_effect("x", x, np.ones(400, bool)).correlation)


def test_summary_of_a_pose_sweep_shows_the_chamfer_limit() -> None:
    spec, samples = chamfer_samples(400)
    results = sw.run_sweep(chamfer_insertion, samples, executor=ThreadPoolExecutor(2))
    expected = [chamfer_insertion_expected(s) for s in samples]
    assert [r.value["steps"][STEP]["success"] for r in results] == expected
    summary = sw.summarize(samples, results, spec.vary)
    st = summary.step(STEP)
    assert (st.n, st.successes) == (400, sum(expected))
    assert st.ci_low < st.rate < st.ci_high
    # success falls where the lateral error passes half the clearance plus the chamfer width
    assert st.driver == "pose_lateral_m"
    pose = next(e for e in st.effects if e.factor == "pose_lateral_m")
    assert 0.5 * CLEARANCE.min_m + CHAMFER_M - 0.05e-3 < pose.x50 < 0.5 * CLEARANCE.max_m + CHAMFER_M
    assert all(b.rate == 1.0 for b in pose.bins if b.high <= 0.5 * CLEARANCE.min_m + CHAMFER_M)
    assert all(b.rate == 0.0 for b in pose.bins if b.low >= 0.5 * CLEARANCE.max_m + CHAMFER_M)
    # counted by criterion code, with the measured values and the limit (no English parsed)
    assert [(f.criterion, f.count) for f in st.failures] == [("insertion_depth", 400 - sum(expected))]
    assert st.failures[0].limit == 0.0
    assert st.failures[0].value_min == st.failures[0].value_max == pytest.approx(DEPTH_M)
    # clearance helps (positive correlation) but less than pose error
    clear = next(e for e in st.effects if e.factor == f"clearance[{MATE}]")
    assert 0 < clear.correlation < abs(pose.correlation)
    json.dumps(summary.to_dict(), allow_nan=False)


def test_summary_leaves_errored_samples_out_of_the_rates() -> None:
    spec, samples = chamfer_samples(5)
    results = [sw.TaskResult(i, True, chamfer_insertion(s)) for i, s in enumerate(samples)]
    results[1] = sw.TaskResult(1, False, None, "worker died 3 times running this sample (X)", 3,
                               "worker_died")
    summary = sw.summarize(samples, results, spec.vary)
    assert summary.n_errors == 1 and summary.errors == (("worker_died", 1),)
    assert summary.step(STEP).n == 4


def test_throughput_times_each_executor_on_the_same_work() -> None:
    from bench import throughput as tp

    task = functools.partial(tp.calibration_task, n_rounds=2)
    rows = tp.throughput(task, list(range(8)), local_workers=(1, 2), dask_workers=None, repeats=2)
    assert [(r.label, r.workers, r.n_tasks, r.repeats) for r in rows] == [
        ("local pool, 1 worker", 1, 8, 2), ("local pool, 2 workers", 2, 8, 2)]
    assert all(r.per_second == pytest.approx(8 / r.wall_s) for r in rows)
    table = tp.format_throughput(rows).splitlines()
    assert len(table) == 4 and table[2].startswith("| local pool, 1 worker | 1 | 8 |")
    # the stand-in work is deterministic wherever it runs
    out = sw.run_sweep(task, [0, 1], max_workers=1)
    assert [r.value for r in out] == [task(0), task(1)]


# --- a plan sweep: perturbation of product and trajectory, and the real step simulation ------
def _trajectory():
    from asmplan.planner.trajectory import Segment, trajectory_from_segments

    T0 = np.eye(4)
    T0[:3, 3] = [0.1, 0.0, 0.1]
    T1, T2 = T0.copy(), T0.copy()
    T1[:3, 3] = [0.3, 0.1, 0.1]
    T2[:3, 3] = [0.3, 0.1, 0.05]
    return trajectory_from_segments(T0, (
        Segment("clamp", 0.1, T0, 0.0, 2.0), Segment("hold", 0.1, T0, 2.0, 2.0),
        Segment("lift", 0.2, T0, 2.0, 2.0), Segment("translate", 0.5, T1, 2.0, 2.0),
        Segment("lower", 0.5, T2, 2.0, 2.0), Segment("release", 0.1, T2, 2.0, 0.0)))


@pytest.mark.parametrize("direction", [(0, 0, -1), (1, 0, 0), (0.6, 0.0, 0.8), (0, -1, 0)])
def test_insertion_frame_is_right_handed_with_z_along_the_insertion(direction: tuple) -> None:
    R = sw.insertion_frame(direction)
    assert np.abs(R.T @ R - np.eye(3)).max() < 1e-12
    assert np.linalg.det(R) == pytest.approx(1.0)
    assert R[:, 2] == pytest.approx(np.asarray(direction, float) / np.linalg.norm(direction))
    with pytest.raises(ValueError, match="expected a non-zero vector"):
        sw.insertion_frame((0, 0, 0))


def test_pose_error_builds_up_over_translate_and_stays() -> None:
    traj = _trajectory()
    direction = np.array([0.0, 0.0, -1.0])
    err = sw.PoseError(lateral_m=(0.3e-3, -0.4e-3), tilt_rad=(0.01, 0.0))
    out = sw.apply_pose_error(traj, direction, err)
    assert np.array_equal(out.t_s, traj.t_s) and np.array_equal(out.clamp_force_N, traj.clamp_force_N)
    assert out.phases == traj.phases
    tr = next(p for p in traj.phases if p.name == "translate")
    d = out.T_world_gripper[:, :3, 3] - traj.T_world_gripper[:, :3, 3]
    before = traj.t_s <= tr.t_start_s
    after = traj.t_s >= tr.t_end_s
    assert np.abs(d[before]).max() == 0.0
    assert np.linalg.norm(d[after], axis=1) == pytest.approx(0.5e-3, rel=1e-12)  # |(0.3, -0.4)| mm
    assert np.abs(d[after] @ direction).max() < 1e-15  # across the insertion direction only
    R_rel = np.einsum("nji,njk->nik", traj.T_world_gripper[after, :3, :3], out.T_world_gripper[after, :3, :3])
    angle = np.arccos(np.clip((np.trace(R_rel, axis1=1, axis2=2) - 1) / 2, -1, 1))
    assert angle == pytest.approx(0.01, rel=1e-9)
    assert sw.apply_pose_error(traj, direction, sw.PoseError()) is traj


def test_perturbed_product_has_the_sampled_clearance_and_friction(examples: dict) -> None:
    from asmplan.parts.geometry import fitted_sizes

    product = examples["peg_in_hole"]
    mate = product.mates[0]
    params = sw.SampleParams(0, 0, clearance_m={mate.name: 0.123e-3}, friction={"peg": 0.41})
    p2 = sw.perturb_product(product, params)
    m2 = p2.mates[0]
    assert (m2.clearance_min_m, m2.clearance_max_m, m2.fit) == (0.123e-3, 0.123e-3, None)
    sizes = fitted_sizes(p2)
    D = sizes.diameters_m[(mate.hole_part, mate.hole_feature)]
    d = sizes.diameters_m[(mate.pin_part, mate.pin_feature)]
    assert D - d == pytest.approx(0.123e-3, abs=1e-12)
    assert 0.5 * (D + d) == pytest.approx(product.feature(mate.hole_part, mate.hole_feature).diameter_m)
    assert p2.part("peg").friction == 0.41 and p2.part("block").friction == product.part("block").friction
    assert product.mates[0].fit == "H7/g6"  # the original is untouched


LOOSE_PEG = "peg_in_hole_loose"


@pytest.fixture(scope="module")
def loose_peg_sweep(tmp_path_factory: pytest.TempPathFactory) -> sw.PlanSweep:
    """The bundled peg-in-hole with a 0.1-0.2 mm clearance (resolved at BALANCED) and its plan."""
    from asmplan.knowledge.loader import load_product
    from asmplan.planner.product import plan_product
    from asmplan.sim.fidelity import BALANCED

    text = (Path(__file__).resolve().parents[2] / "examples" / "peg_in_hole.yaml").read_text()
    assert "fit: H7/g6}" in text and "chamfer: 0.5}" in text
    text = text.replace("fit: H7/g6}", "clearance: {min: 0.1, max: 0.2}}").replace(
        "product: peg_in_hole", f"product: {LOOSE_PEG}")
    path = tmp_path_factory.mktemp("loose") / "loose.yaml"
    path.write_text(text)
    product = load_product(path)
    from asmplan.parts.models import ProductGeometry

    return sw.PlanSweep(product, plan_product(product, ProductGeometry(product)).plan, BALANCED)


@pytest.mark.slow
def test_a_pose_sweep_of_a_real_step_fails_beyond_clearance_plus_chamfer(loose_peg_sweep: sw.PlanSweep) -> None:
    ps = loose_peg_sweep
    assert ps.step_names == ("peg",)
    base = ps.samples(sw.SweepSpec(1, vary=()))[0]
    hole = ps.product.feature("block", "hole")
    capture_m = 0.5 * ps.product.mates[0].clearance_mean_m + hole.chamfer_m  # 0.575 mm
    # The offsets lie inside the capture range, one along the gripper's closing axis and one
    # across it, and one well beyond it.
    step = ps.plan.step("peg")
    assert step.trajectory is not None and step.insertion_direction is not None
    closing = step.trajectory.T_world_gripper[-1][:3, 1]
    R_ins = sw.insertion_frame(step.insertion_direction)
    i_along = int(np.argmax(np.abs(R_ins[:, :2].T @ closing)))  # insertion-frame x or y
    offsets = (0.3e-3, 1.2e-3)
    along = tuple(offsets[0] if k == i_along else 0.0 for k in range(2))
    across = tuple(0.0 if k == i_along else offsets[0] for k in range(2))
    lateral = [across, along, (offsets[1], 0.0)]
    samples = [sw.SampleParams(i, 0, base.clearance_m, base.friction, {"peg": sw.PoseError(e)})
               for i, e in enumerate(lateral)]
    results = sw.run_sweep(functools.partial(sw.simulate_sample, ps), samples, max_workers=2)
    inside_across, inside_along, beyond = (r.value["steps"]["peg"] for r in results)
    assert offsets[0] < capture_m - 0.25e-3 and offsets[1] > capture_m + 0.5e-3
    # A stiff robot and a synchronised parallel gripper (rack and pinion) comply only where
    # the part can slide in the pads. Across the closing axis the chamfer pushes the peg
    # sideways along the pad faces: it slides by about the offset and goes in.
    assert inside_across["success"] is True, inside_across["reasons"]
    assert inside_across["outcome"]["final_position_error_m"] < (
        0.5 * ps.product.mates[0].clearance_mean_m + 0.05e-3)
    assert inside_across["outcome"]["max_slip_m"] == pytest.approx(offsets[0], rel=0.5)
    # Along the closing axis nothing gives: the jaws cannot travel together (they did when
    # they floated under force control, and the offset vanished in the grip with no slip),
    # so the peg stays on the chamfer, offset, and the robot's push slides it up through
    # the pads: a failed step with slip far beyond the offset, not a success.
    assert inside_along["success"] is False
    assert "slip" in inside_along["failed_criteria"]
    assert inside_along["outcome"]["max_slip_m"] > 10 * offsets[0]
    assert beyond["success"] is False
    assert "slip" in beyond["failed_criteria"]
    assert "wall_time_s" not in inside_across["outcome"]
    summary = sw.summarize(samples, results, ("pose",))
    assert (summary.step("peg").n, summary.step("peg").successes) == (3, 1)


@pytest.mark.slow
def test_the_sweep_command_writes_results_resumes_and_refuses_another_sweep(
        loose_peg_sweep: sw.PlanSweep, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from asmplan.cli import main

    product = str(loose_peg_sweep.product.source)
    out = tmp_path / "sweep"
    argv = ["sweep", product, "--samples", "2", "--vary", "pose", "--pose-dist", "uniform",
            "--pose-lateral", "1.5", "--pose-angular", "0", "--fidelity", "fast", "--workers", "2",
            "-o", str(out)]
    assert main(argv) == 0
    first = capsys.readouterr()
    data = json.loads((out / "sweep.json").read_text())
    assert data["spec"]["n_samples"] == 2 and data["spec"]["vary"] == ["pose"]
    assert data["capture_m"]["peg"] == pytest.approx(0.075e-3 + 0.5e-3)
    st = data["summary"]["steps"][0]
    assert st["step"] == "peg" and st["n"] == 2
    assert (out / "sweep-peg.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    html = (out / "sweep-report.html").read_text()
    assert 'src="sweep-peg.png"' in html and f"{st['successes']} of 2 succeeded" in html
    assert st["number"] == 2  # the peg is step 2 of its plan (the block is step 1), as in `run`
    assert f"step 2 (peg): success {st['successes']}/2" in first.out and "step 2 (peg)" in html
    # the drivers' method and every tested factor's q-value are stored per step
    assert data["summary"]["drivers"]["correction"] == "benjamini-hochberg"
    assert "false_discovery_control" in data["summary"]["drivers"]["method"]
    assert {e["factor"] for e in st["effects"]} <= {"pose_lateral_m", "pose_angular_rad"}
    assert all("q_value" in e for e in st["effects"])
    assert st["driver"] is None and st["driver_status"] in ("too_few_samples", "no_failures")
    # the same command again: everything comes from the journal, same numbers
    assert main(argv) == 0
    again = capsys.readouterr()
    assert "resuming, 2 samples already" in again.err
    assert json.loads((out / "sweep.json").read_text())["summary"] == data["summary"]
    # another seed in the same folder is refused as bad input, naming the difference
    assert main([*argv, "--seed", "5"]) == 2
    assert "spec.seed: journal has 0, this run has 5" in capsys.readouterr().err
